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
