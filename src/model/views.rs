//! The views of the reference and current configuration that materials and damage models
//! read.

use super::{BondList, PointCloud};
use crate::history::History;

/// The reference configuration of all points (owned and ghost), read by every material.
#[derive(Debug, Clone, Copy)]
pub struct ReferenceView<'a> {
    /// Families (symmetric, directed CSR).
    pub bonds: &'a BondList,
    /// Reference positions X (length).
    pub position: &'a [[f64; 3]],
    /// Cell volumes V (length³).
    pub volume: &'a [f64],
    /// The quadrature volume w_ij of every directed bond (length³, global bond index) when
    /// some block's quadrature rule is not the full cell volume; `None` means w_ij = V_j for
    /// every bond, the default (no per-bond array exists then). Read it through
    /// [`ReferenceView::neighbor_volume`] or [`ReferenceView::bond_volumes`], never directly.
    pub bond_volume: Option<&'a [f64]>,
}

/// The quadrature volume of each bond i→j, the one accessor every family sum reads instead of
/// the neighbour's cell volume V_j (see [`crate::model::quadrature`]).
#[derive(Debug, Clone, Copy)]
pub struct BondVolumes<'a> {
    cell: &'a [f64],
    bond: Option<&'a [f64]>,
}

impl<'a> BondVolumes<'a> {
    /// The accessor over cell volumes `cell` (per point) and, unless the rule is the full
    /// volume, the per-bond quadrature volumes `bond` (global bond index).
    pub fn new(cell: &'a [f64], bond: Option<&'a [f64]>) -> Self {
        Self { cell, bond }
    }

    /// w_ij of bond `b` (global index) whose neighbour is `j` (length³): V_j under the
    /// full-volume rule (the same load as before quadrature rules existed), the per-bond
    /// quadrature volume otherwise.
    #[inline(always)]
    pub fn of(&self, b: usize, j: usize) -> f64 {
        match self.bond {
            None => self.cell[j],
            Some(weights) => weights[b],
        }
    }

    /// True when every bond reads its neighbour's full cell volume.
    pub fn is_full_volume(&self) -> bool {
        self.bond.is_none()
    }
}

impl<'a> BondVolumes<'a> {
    /// The rule this accessor applies, as a type a kernel can be compiled for: one build per
    /// rule, no branch on the rule per bond. Each variant gives the same w_ij as
    /// [`BondVolumes::of`].
    #[inline(always)]
    pub fn rule(&self) -> VolumeRules<'a> {
        match self.bond {
            None => VolumeRules::Full(FullVolume(self.cell)),
            Some(weights) => VolumeRules::PerBond(PerBondVolume(weights)),
        }
    }
}

/// The quadrature rule of a [`BondVolumes`] ([`BondVolumes::rule`]), for kernels that match it
/// once per call instead of once per bond.
#[derive(Debug, Clone, Copy)]
pub enum VolumeRules<'a> {
    /// Every bond reads its neighbour's full cell volume.
    Full(FullVolume<'a>),
    /// Every bond reads its own quadrature volume.
    PerBond(PerBondVolume<'a>),
}

/// w_ij under one quadrature rule, fixed for a whole loop (see [`BondVolumes::rule`]).
pub trait VolumeRule: Copy + Send + Sync {
    /// w_ij of bond `b` (global index) whose neighbour is `j` (length³), as
    /// [`BondVolumes::of`] gives it.
    fn of(self, b: usize, j: usize) -> f64;

    /// The number of points `p` such that [`VolumeRule::of_unchecked`] may read every bond
    /// `b < bonds` whose neighbour is `j < p` (0 when the rule's per-bond data is shorter than
    /// `bonds`): checked once by a loop, so that its bonds need no check each.
    fn covered_points(self, bonds: usize) -> usize;

    /// [`VolumeRule::of`] without bounds checks.
    ///
    /// # Safety
    /// `b < bonds` and `j < self.covered_points(bonds)` for some `bonds`.
    #[inline(always)]
    unsafe fn of_unchecked(self, b: usize, j: usize) -> f64 {
        self.of(b, j)
    }
}

/// Either rule, decided per bond (for loops not worth one build per rule).
impl VolumeRule for BondVolumes<'_> {
    #[inline(always)]
    fn of(self, b: usize, j: usize) -> f64 {
        BondVolumes::of(&self, b, j)
    }

    /// All: [`VolumeRule::of_unchecked`] is the checked [`BondVolumes::of`] here.
    fn covered_points(self, _bonds: usize) -> usize {
        usize::MAX
    }
}

/// The full-volume rule: w_ij = V_j, the neighbour's cell volume (length³).
#[derive(Debug, Clone, Copy)]
pub struct FullVolume<'a>(&'a [f64]);

impl VolumeRule for FullVolume<'_> {
    #[inline(always)]
    fn of(self, _b: usize, j: usize) -> f64 {
        self.0[j]
    }

    #[inline(always)]
    fn covered_points(self, _bonds: usize) -> usize {
        self.0.len()
    }

    #[inline(always)]
    unsafe fn of_unchecked(self, _b: usize, j: usize) -> f64 {
        // SAFETY: j < covered_points = len (the caller's contract).
        unsafe { *self.0.get_unchecked(j) }
    }
}

/// Per-bond quadrature volumes: w_ij is bond b's own (length³, global bond index).
#[derive(Debug, Clone, Copy)]
pub struct PerBondVolume<'a>(&'a [f64]);

impl VolumeRule for PerBondVolume<'_> {
    #[inline(always)]
    fn of(self, b: usize, _j: usize) -> f64 {
        self.0[b]
    }

    #[inline(always)]
    fn covered_points(self, bonds: usize) -> usize {
        if bonds <= self.0.len() {
            usize::MAX
        } else {
            0
        }
    }

    #[inline(always)]
    unsafe fn of_unchecked(self, b: usize, _j: usize) -> f64 {
        // SAFETY: b < bonds <= len (covered_points > j >= 0, the caller's contract).
        unsafe { *self.0.get_unchecked(b) }
    }
}

/// Runs `$body` with `$v` bound to the quadrature rule of the [`ReferenceView`] `$reference`
/// ([`VolumeRules`]), one match per call, so the bond loops in it are compiled once per rule,
/// with no branch on the rule per bond.
macro_rules! with_volume_rule {
    ($reference:expr, |$v:ident| $body:expr) => {
        match $reference.bond_volumes().rule() {
            $crate::model::VolumeRules::Full($v) => $body,
            $crate::model::VolumeRules::PerBond($v) => $body,
        }
    };
}
pub(crate) use with_volume_rule;

impl<'a> ReferenceView<'a> {
    /// The reference configuration of `points` with their families `bonds`.
    pub fn of(bonds: &'a BondList, points: &'a PointCloud) -> Self {
        Self {
            bonds,
            position: &points.position,
            volume: &points.volume,
            bond_volume: None,
        }
    }

    /// This view with the per-bond quadrature volumes `bond_volume` (`None`: full volume).
    pub fn with_bond_volume(self, bond_volume: Option<&'a [f64]>) -> Self {
        Self {
            bond_volume,
            ..self
        }
    }

    /// The quadrature volume w_ij of bond `b` (global index) whose neighbour is `j`
    /// (length³); see [`BondVolumes::of`].
    #[inline(always)]
    pub fn neighbor_volume(&self, b: usize, j: usize) -> f64 {
        self.bond_volumes().of(b, j)
    }

    /// The bond-volume accessor, for kernels that keep it apart from the view.
    #[inline(always)]
    pub fn bond_volumes(&self) -> BondVolumes<'a> {
        BondVolumes {
            cell: self.volume,
            bond: self.bond_volume,
        }
    }
}

/// The current configuration of all points, as materials and damage models read it.
#[derive(Debug, Clone, Copy)]
pub struct CurrentView<'a> {
    /// Current positions Y = X + u (length).
    pub position: &'a [[f64; 3]],
    /// Bond damage d ∈ [0, 1] per directed bond (same indexing as the bond list), or `None`
    /// when no damage model is active (all bonds intact).
    pub bond_damage: Option<&'a [f32]>,
    /// The materials' history fields (trial values of this evaluation, committed values of
    /// the step's start); [`crate::history::NO_HISTORY`] when no model declares any.
    pub history: &'a History,
}
