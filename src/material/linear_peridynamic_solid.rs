//! Linear peridynamic solid (LPS, Silling et al. 2007), Peridigm's `Elastic` material
//! (`elastic.cxx`, `material_utilities.cxx`; reference §0, §1.3), in its large-deformation
//! form: extensions are measured along the current bond.
//!
//! * weighted volume `m_i = Σ_j ω ζ² V_j`, reference configuration, all bonds (damage
//!   ignored), computed once at setup — Peridigm's rule;
//! * dilatation `θ_i = (3/m_i) Σ_j ω (1−d) ζ e V_j`, `e = |Y_j − Y_i| − ζ`;
//! * scalar force state, exactly as Peridigm codes it (note `(1−d)` squared on the deviatoric
//!   part): `t_ij = (1−d)·[ (3K/m − 5μ/m)·ω·θ·ζ + (1−d)·(15μ/m)·ω·e ]`;
//! * force density `F_i = Σ_j (t_ij + t_ji) V_j M_ij` (see the module docs of `material`),
//!   with t_ji from j's own θ and m;
//! * stored energy density (Peridigm's compute class), `α = 15μ/m`, `e^d = e − θζ/3`:
//!   `W_i = K θ_i²/2 + (α_i/2) Σ_j (1−d) ω (e^d)² V_j`. For intact bonds the force is exactly
//!   `−∂(Σ_k W_k V_k)/∂Y_i / V_i` (checked by a finite-difference test).
//!
//! A point whose weighted volume is 0 (no bonds, or ω = 0 on all of them) has no dilatation and
//! carries no force (Peridigm would divide by zero).
//!
//! * partial stress (Peridigm's `Partial_Stress` output), `Σ_j t_ij M_ij ⊗ ξ_ij V_j`: the
//!   force states of the point's own side only, as `elastic.cxx` sums them. Peridigm fills it
//!   only with `Compute Partial Stress: true`; here it is computed whenever an output asks
//!   for it (the key is accepted and changes nothing else).
//!
//! * thermal strain (`Thermal Expansion Coefficient` α, Peridigm's rule): with the point
//!   temperature change ΔT_i, every extension of point i's side is measured from the freely
//!   expanded bond, `e ← e − αΔT_i ζ`, in θ_i, in t_ij and in the stored energy (t_ji uses
//!   ΔT_j and j's material's α, the free strain published per point,
//!   [`crate::history::Thermal::strain`]). A block with α takes these simple bond loops in every
//!   evaluation while the run has point temperatures; blocks without α, and every run without
//!   temperature conditions, keep the fast loops below unchanged.
//! * shear correction (`Apply Shear Correction Factor: true`, off by default; Peridigm's
//!   `Elastic` reads the key and ignores it): μ is replaced pointwise by s_i μ, s_i the
//!   shear-correction factor of the point's neighbourhood (`super::shear_correction`), so
//!   `α_i = 15 s_i μ/m_i` and the isotropic coefficient is `(3K − 5 s_i μ)θ/m`; the bulk
//!   response is unchanged and the stiffest probed pure shear of every point has modulus μ.

use super::influence::InfluenceFunction;
use super::keys::{
    AUTOMATIC_DIFFERENTIATION, DENSITY, ELASTIC, PROBE_LENGTH, TANGENT, THERMAL_EXPANSION,
};
use super::{
    checked_row, gather_bound, influence_weighted_volumes, local_offsets, BlockData, BlockInput,
    BondWeights, CurrentView, Damaged, ElasticConstants, Integrity, Material, MaterialError,
    MaterialKeys, MaterialModel, MaterialOutputs, MaterialParameters, MaterialTangent,
    PointCoefficients, ReferenceView, StoredWeights, Undamaged, UnitWeights,
};
use super::{BreakingCoefficientPass, CriticalStretchFastPath, FusedCriticalStretch};
use crate::damage::StretchLimit;
use crate::model::point_chunks::for_each_chunk;
use crate::model::with_volume_rule;
use crate::model::{
    BondVolumes, FieldCarrier, FieldDeclaration, KeyDoc, ModelDeclaration, Reach, TangentSupport,
    VolumeRule,
};
use crate::parameter_list::error::DeckError;
use crate::parameter_list::reader::{Ctx, ListReader};
use crate::tangent::{
    assemble, BlockTangent, ForceState, OrdinaryBond, PointIndex, Scalar, TangentError,
    TangentMethod,
};
use crate::vector_width::wide_vectors_available;
use std::sync::atomic::{AtomicUsize, Ordering};

#[cfg(target_arch = "x86_64")]
mod rows_avx2;

/// `Compute Partial Stress`.
const COMPUTE_PARTIAL_STRESS: KeyDoc = KeyDoc {
    key: "Compute Partial Stress",
    meaning: "Peridigm's switch for `Partial_Stress`; accepted without effect (peridyn computes \
              it whenever an output lists it)",
    unit: "true/false",
    default: "false",
};

/// `Apply Shear Correction Factor` of `Elastic`.
const SHEAR_CORRECTION: KeyDoc = KeyDoc {
    key: "Apply Shear Correction Factor",
    meaning: "scale μ pointwise by the shear-correction factor of the point's neighbourhood \
              (Peridigm's `Elastic` reads the key and ignores it)",
    unit: "true/false",
    default: "false",
};

/// `Hourglass Coefficient`, which decks carry on `Elastic` materials.
const HOURGLASS_WITHOUT_EFFECT: KeyDoc = KeyDoc {
    key: "Hourglass Coefficient",
    meaning: "accepted without effect: only correspondence models have hourglass control",
    unit: "—",
    default: "—",
};

/// Deck parameters of `Elastic` besides the keys every model shares.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinearPeridynamicSolidParameters {
    /// K and μ from the elastic pair.
    pub elastic: ElasticConstants,
    /// `Compute Partial Stress` (no effect: `Partial_Stress` is computed whenever an output
    /// lists it).
    pub compute_partial_stress: bool,
    /// `Apply Shear Correction Factor` (module docs).
    pub shear_correction: bool,
}

impl MaterialParameters for LinearPeridynamicSolidParameters {
    fn bulk_modulus(&self) -> Option<f64> {
        Some(self.elastic.bulk_modulus)
    }
}

/// The LPS material of one block (see the module docs for the formulas).
#[derive(Debug, Clone)]
pub struct LinearPeridynamicSolid {
    block: BlockData,
    shear_modulus: f64,
    influence: InfluenceFunction,
    /// Block-local row starts into `weights`.
    local_offsets: Vec<usize>,
    /// ω per block bond; `None` for `One` (nothing to store).
    weights: Option<Vec<f64>>,
    /// m per block point (same order as the block's points).
    weighted_volume: Vec<f64>,
    /// Whether `prepare` probes the shear-correction factor of every point.
    shear_correction: bool,
    /// The shear-correction factor s per block point (same order as the block's points); empty
    /// when the deck does not ask for it.
    correction: Vec<f64>,
}

impl MaterialKeys for LinearPeridynamicSolid {
    type Parameters = LinearPeridynamicSolidParameters;

    /// `Elastic`: state-based (the dilatation of both ends enters every bond force, so the
    /// force reaches two hops); keeps the weighted volume (fixed by the reference
    /// configuration) and the dilatation (recomputed in every evaluation) per point.
    const DECLARATION: ModelDeclaration = ModelDeclaration {
        deck_name: "Elastic",
        aliases: &["Elastic Partial Volume"],
        deck_keys: &[
            DENSITY,
            ELASTIC[0],
            ELASTIC[1],
            ELASTIC[2],
            ELASTIC[3],
            TANGENT,
            AUTOMATIC_DIFFERENTIATION,
            PROBE_LENGTH,
            COMPUTE_PARTIAL_STRESS,
            SHEAR_CORRECTION,
            THERMAL_EXPANSION,
            HOURGLASS_WITHOUT_EFFECT,
        ],
        reach: Reach::TwoHop,
        fields: &[
            FieldDeclaration {
                name: "Weighted_Volume",
                carrier: FieldCarrier::Point,
                bytes_per_value: 8,
                staged: false,
            },
            FieldDeclaration {
                name: "Dilatation",
                carrier: FieldCarrier::Point,
                bytes_per_value: 8,
                staged: false,
            },
        ],
        outputs: &["Weighted_Volume", "Dilatation", "Partial_Stress"],
        tangent: TangentSupport::Analytic,
        thermal_strain: true,
        small_displacement: false,
        example: "Density: 2.0\nBulk Modulus: 3.0\nShear Modulus: 1.7",
    };

    // Peridigm's `Elastic Partial Volume` (a -DUSE_PV build) is the LPS of `Elastic` whose
    // bond volumes are the element–horizon intersections when the discretization computes
    // them, else the cells: the block's quadrature rule (`Full Volume` unless the block or the
    // discretization's `Element-Horizon Intersection Partial Volume Scheme` says otherwise)
    // does exactly that for every material, hence the alias.
    fn read(
        ctx: &mut Ctx,
        list: &mut ListReader,
    ) -> Result<LinearPeridynamicSolidParameters, DeckError> {
        let elastic = super::elastic_constants::read(ctx, list)?;
        list.without_effect(
            HOURGLASS_WITHOUT_EFFECT.key,
            "only correspondence models have hourglass control",
        );
        let compute_partial_stress = list.flag_without_effect(
            ctx,
            COMPUTE_PARTIAL_STRESS.key,
            false,
            true,
            "peridyn computes Partial_Stress whenever an output lists it",
        )?;
        let shear_correction = list.bool_or(ctx, SHEAR_CORRECTION.key, false)?;
        if let Some(f) = list.peek(SHEAR_CORRECTION.key).filter(|_| shear_correction) {
            ctx.warn(
                f.line(),
                &f.path,
                "peridyn applies the shear-correction factor to this Elastic material \
                 (Peridigm's Elastic reads the key and ignores it, so results differ from \
                 Peridigm's near surfaces)",
            );
        }
        Ok(LinearPeridynamicSolidParameters {
            elastic,
            compute_partial_stress,
            shear_correction,
        })
    }
}

impl MaterialModel for LinearPeridynamicSolid {
    fn build(
        block: &BlockInput,
        parameters: &LinearPeridynamicSolidParameters,
    ) -> Result<Box<dyn Material>, MaterialError> {
        Ok(Box::new(
            Self::new(block, &parameters.elastic)?
                .with_shear_correction(parameters.shear_correction),
        ))
    }
}

impl LinearPeridynamicSolid {
    /// The same material, applying the shear-correction factor (module docs) when `on`.
    pub fn with_shear_correction(mut self, on: bool) -> Self {
        self.shear_correction = on;
        self
    }

    /// Validates the parameters (ρ, K, μ, δ positive and finite); ω from `block`.
    pub fn new(block: &BlockInput, elastic: &ElasticConstants) -> Result<Self, MaterialError> {
        let data = BlockData::new(
            &Self::DECLARATION,
            block.density,
            elastic.bulk_modulus,
            block.horizon,
        )?;
        Ok(Self {
            block: data,
            shear_modulus: super::positive("Shear Modulus", elastic.shear_modulus)?,
            influence: block.influence.clone(),
            local_offsets: vec![0],
            weights: None,
            weighted_volume: Vec::new(),
            shear_correction: false,
            correction: Vec::new(),
        })
    }

    /// The free thermal strain α ΔT of every point, when this block has α and the run has
    /// point temperatures (the thermal bond loops then run).
    fn thermal_strain<'a>(&self, current: &CurrentView<'a>) -> Option<&'a [f64]> {
        self.block.thermal_expansion()?;
        current.history.thermal().map(|t| &t.strain[..])
    }

    /// Weighted volume m of each block point (Peridigm's `Weighted_Volume`), in the order of
    /// the block's points; empty before setup.
    pub fn weighted_volume(&self) -> &[f64] {
        &self.weighted_volume
    }
}

/// Runs `$body` with `$w` bound to the block's ω access and `$d` to the damage access, one
/// match per call, so each of the four combinations gets its own monomorphized bond loop.
macro_rules! with_bond_data {
    ($weights:expr, $damage:expr, |$w:ident, $d:ident| $body:expr) => {
        match ($weights, $damage) {
            (None, None) => {
                let ($w, $d) = (UnitWeights, Undamaged);
                $body
            }
            (None, Some(damage)) => {
                let ($w, $d) = (UnitWeights, Damaged(damage));
                $body
            }
            (Some(weights), None) => {
                let ($w, $d) = (StoredWeights(weights), Undamaged);
                $body
            }
            (Some(weights), Some(damage)) => {
                let ($w, $d) = (StoredWeights(weights), Damaged(damage));
                $body
            }
        }
    };
}

/// What the LPS loops read, bundled once per call; `V` is the quadrature rule the hot loops
/// are compiled for.
struct Rows<'a, V> {
    reference: &'a ReferenceView<'a>,
    /// w_ij ([`VolumeRule`]).
    volume: V,
    current: &'a CurrentView<'a>,
    points: &'a [u32],
    local_offsets: &'a [usize],
    weighted_volume: &'a [f64],
    bulk: f64,
    shear: f64,
    /// s per block point, or empty (s = 1).
    correction: &'a [f64],
    /// The force pass runs over a subset of `points` ([`Material::restrict_forces`]), whose
    /// chunks are not contiguous runs of `points`.
    force_subset: bool,
    /// Run the AVX2 builds of the loops ([`wide_vectors_available`]).
    wide: bool,
}

impl<V: VolumeRule> Rows<'_, V> {
    /// Block-local index of the chunk's first point (chunks are contiguous runs of `points`).
    fn first_local(&self, chunk: &[u32]) -> usize {
        self.points.partition_point(|&p| p < chunk[0])
    }

    /// θ_i and the published coefficients of the chunk's points, after the bonds `breaker`
    /// breaks (if any) in their rows; returns the directed bonds broken.
    ///
    /// Each row is taken [`LANES`] bonds at a time: the per-bond terms are computed lane by
    /// lane (vectorized: the square roots dominate), then added one by one in bond order, so
    /// θ is bitwise the plain running sum `Σ_j ω (1−d) ζ e V_j` whatever the vector width.
    ///
    /// # Safety
    /// The contract of `breaker` ([`RowBreaker`]) for the rows of `chunk`.
    #[inline(always)]
    unsafe fn dilatation<W: BondWeights, D: Integrity, B: RowBreaker>(
        &self,
        chunk: &[u32],
        base: usize,
        out: &mut [PointCoefficients],
        weights: W,
        damage: D,
        breaker: B,
    ) -> usize {
        let bonds = self.reference.bonds;
        let volume = self.volume;
        let y = self.current.position;
        let k0 = self.first_local(chunk);
        let points = gather_bound(bonds, y.len(), volume, damage);
        let mut broken = 0;
        for (k, &i) in (k0..).zip(chunk) {
            let i = i as usize;
            let yi = y[i];
            let range = bonds.range(i);
            let local = self.local_offsets[k];
            let (neighbors, lengths) = checked_row(bonds, range.clone(), points);
            let mut sum = 0.0;
            // Lane arrays stay in registers (written and read within one group of LANES); the
            // tail bonds are groups of one.
            macro_rules! group {
                ($start:expr, $width:expr) => {{
                    let start: usize = $start;
                    let width: usize = $width;
                    let mut squared = [0.0; LANES];
                    let mut zeta = [0.0; LANES];
                    let mut neighbor_volume = [0.0; LANES];
                    for lane in 0..width {
                        // SAFETY: start + lane < the row's length, and the row is checked
                        // (`checked_row`, `gather_bound`).
                        let (_, yj, z, w) = unsafe {
                            gather(neighbors, lengths, y, volume, range.start, start + lane)
                        };
                        let (dx, dy, dz) = (yj[0] - yi[0], yj[1] - yi[1], yj[2] - yi[2]);
                        // q = dx*dx + dy*dy + dz*dz, the number the damage models test.
                        squared[lane] = dx * dx + dy * dy + dz * dz;
                        zeta[lane] = z;
                        neighbor_volume[lane] = w;
                    }
                    if let Some(limit) = breaker.limit() {
                        // The filter of every lane first, with no branch (it vectorizes); the
                        // lanes are visited one by one only when one of them may break.
                        let mut filtered = [false; LANES];
                        for lane in 0..width {
                            filtered[lane] = limit.certainly_intact(squared[lane], zeta[lane]);
                        }
                        if !filtered[..width].iter().fold(true, |all, &f| all & f) {
                            for lane in 0..width {
                                if !filtered[lane] {
                                    let b = range.start + start + lane;
                                    // SAFETY: b is in the row of a point of this chunk (the
                                    // caller's contract).
                                    if unsafe { breaker.damage(b) } < 1.0
                                        && limit.exceeded(squared[lane], zeta[lane])
                                    {
                                        // SAFETY: as above.
                                        unsafe { breaker.break_bond(b) };
                                        broken += 1;
                                    }
                                }
                            }
                        }
                    }
                    // Read after the breaking above, and apart from the arithmetic below so
                    // that it has no indexing (bounds checks would keep it scalar).
                    let mut weight = [0.0; LANES];
                    for lane in 0..width {
                        // SAFETY: the bond is in the row, below `bonds.neighbor.len()`
                        // (`gather_bound`).
                        weight[lane] = weights.weight(local + start + lane)
                            * unsafe { damage.intact_unchecked(range.start + start + lane) };
                    }
                    let mut term = [0.0; LANES];
                    for lane in 0..width {
                        term[lane] = dilatation_term(
                            weight[lane],
                            zeta[lane],
                            squared[lane],
                            neighbor_volume[lane],
                        );
                    }
                    for &t in &term[..width] {
                        sum += t;
                    }
                }};
            }
            let full = neighbors.len() - neighbors.len() % LANES;
            for start in (0..full).step_by(LANES) {
                group!(start, LANES);
            }
            for start in full..neighbors.len() {
                group!(start, 1);
            }
            out[i - base] = self.point_coefficients(k, sum);
        }
        broken
    }

    /// θ = 3 Σ/m of block point k from its row's sum Σ = Σ_j ω (1−d) ζ e V_j, and its force
    /// coefficients A = (3K − 5μ) θ/m, B = 15μ/m (all zero when m = 0).
    #[inline(always)]
    fn point_coefficients(&self, k: usize, sum: f64) -> PointCoefficients {
        let m = self.weighted_volume[k];
        if m > 0.0 {
            let theta = 3.0 * sum / m;
            let shear = corrected_shear(self.shear, self.correction, k);
            PointCoefficients {
                dilatation: theta,
                isotropic: (3.0 * self.bulk - 5.0 * shear) * theta / m,
                deviatoric: 15.0 * shear / m,
            }
        } else {
            PointCoefficients::default()
        }
    }

    /// Block-local index of point `i`, the `n`-th of a force chunk whose first point has
    /// block-local index `k0` (when the forced points are all of them).
    #[inline(always)]
    fn force_local(&self, k0: usize, n: usize, i: u32) -> usize {
        if self.force_subset {
            self.points.partition_point(|&p| p < i)
        } else {
            k0 + n
        }
    }

    /// [`Rows::dilatation`] built for AVX2 when [`Rows::wide`], else for the baseline target;
    /// bitwise the same result (same IEEE operations in the same order, no fused
    /// multiply-add).
    ///
    /// # Safety
    /// As [`Rows::dilatation`].
    #[inline(always)]
    unsafe fn dilatation_dispatch<W: BondWeights, D: Integrity, B: RowBreaker>(
        &self,
        chunk: &[u32],
        base: usize,
        out: &mut [PointCoefficients],
        weights: W,
        damage: D,
        breaker: B,
    ) -> usize {
        #[cfg(target_arch = "x86_64")]
        if self.wide {
            // SAFETY: AVX2 was detected at run time; the rest as the caller guarantees.
            return unsafe { self.dilatation_avx2(chunk, base, out, weights, damage, breaker) };
        }
        // SAFETY: as the caller guarantees.
        unsafe { self.dilatation(chunk, base, out, weights, damage, breaker) }
    }

    /// [`Rows::dilatation`] with AVX2: each row by the intrinsics loop
    /// `rows_avx2::dilatation_sum` (bitwise the staged loop's sum).
    ///
    /// # Safety
    /// As [`Rows::dilatation`], and the CPU supports AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn dilatation_avx2<W: BondWeights, D: Integrity, B: RowBreaker>(
        &self,
        chunk: &[u32],
        base: usize,
        out: &mut [PointCoefficients],
        weights: W,
        damage: D,
        breaker: B,
    ) -> usize {
        let bonds = self.reference.bonds;
        let points = gather_bound(bonds, self.current.position.len(), self.volume, damage);
        let k0 = self.first_local(chunk);
        let mut broken = 0;
        for (k, &i) in (k0..).zip(chunk) {
            let i = i as usize;
            // SAFETY: AVX2 is enabled here; `points` is from `gather_bound`; the breaker's
            // contract is the caller's.
            let sum = unsafe {
                rows_avx2::dilatation_sum(
                    self,
                    i,
                    self.local_offsets[k],
                    points,
                    weights,
                    damage,
                    breaker,
                    &mut broken,
                )
            };
            out[i - base] = self.point_coefficients(k, sum);
        }
        broken
    }

    /// The dilatation pass over every block point with the bond breaking of `fused`; returns
    /// the directed bonds broken.
    fn fused_dilatation<W: BondWeights>(
        &self,
        coefficients: &mut [PointCoefficients],
        weights: W,
        fused: FusedCriticalStretch,
    ) -> usize {
        let broken = AtomicUsize::new(0);
        for_each_chunk(
            self.points,
            coefficients,
            &|i| i as usize,
            &|chunk: &[u32], base: usize, out: &mut [PointCoefficients]| {
                // SAFETY: the caller gives `fused` a pointer to the whole bond-damage array,
                // borrowed mutably for this call; each chunk touches only the rows of its own
                // points (the `RowBreaker` contract).
                let newly =
                    unsafe { self.dilatation_dispatch(chunk, base, out, weights, fused, fused) };
                broken.fetch_add(newly, Ordering::Relaxed);
            },
        );
        broken.into_inner()
    }

    /// `F_i += Σ_j (1−d) ω [(A_i + A_j) ζ + (1−d)(B_i + B_j) e] V_j M_ij` with A = isotropic,
    /// B = deviatoric coefficients; coincident deformed points contribute nothing. Grouped as
    /// [`Rows::dilatation`]: the bond terms are computed lane by lane and added in bond order,
    /// so F is bitwise the plain running sum.
    #[inline(always)]
    fn add_force<W: BondWeights, D: Integrity>(
        &self,
        coefficients: &[PointCoefficients],
        chunk: &[u32],
        base: usize,
        out: &mut [[f64; 3]],
        weights: W,
        damage: D,
    ) {
        let bonds = self.reference.bonds;
        let volume = self.volume;
        let y = self.current.position;
        let k0 = self.first_local(chunk);
        // Every neighbour indexes both `y` and `coefficients`.
        let points = gather_bound(bonds, y.len().min(coefficients.len()), volume, damage);
        for (n, &i) in chunk.iter().enumerate() {
            let k = self.force_local(k0, n, i);
            let i = i as usize;
            let yi = y[i];
            let own = coefficients[i];
            let range = bonds.range(i);
            let local = self.local_offsets[k];
            let (neighbors, lengths) = checked_row(bonds, range.clone(), points);
            let (mut fx, mut fy, mut fz) = (0.0, 0.0, 0.0);
            // Lane arrays stay in registers (written and read within one group of LANES); the
            // tail bonds are groups of one.
            macro_rules! group {
                ($start:expr, $width:expr) => {{
                    let start: usize = $start;
                    let width: usize = $width;
                    let mut d = [[0.0; LANES]; 3];
                    let mut zeta = [0.0; LANES];
                    let mut neighbor_volume = [0.0; LANES];
                    let mut other_isotropic = [0.0; LANES];
                    let mut other_deviatoric = [0.0; LANES];
                    // Read here, in the gather, so that the arithmetic below has no indexing
                    // (bounds checks would keep it scalar).
                    let mut intact = [0.0; LANES];
                    let mut omega = [0.0; LANES];
                    for lane in 0..width {
                        // SAFETY: start + lane < the row's length, and the row is checked
                        // (`checked_row`, `gather_bound`, j < coefficients.len()).
                        let (j, yj, z, w) = unsafe {
                            gather(neighbors, lengths, y, volume, range.start, start + lane)
                        };
                        for c in 0..3 {
                            d[c][lane] = yj[c] - yi[c];
                        }
                        zeta[lane] = z;
                        neighbor_volume[lane] = w;
                        // SAFETY: as above.
                        let other = unsafe { coefficients.get_unchecked(j) };
                        other_isotropic[lane] = other.isotropic;
                        other_deviatoric[lane] = other.deviatoric;
                        // SAFETY: as above.
                        intact[lane] =
                            unsafe { damage.intact_unchecked(range.start + start + lane) };
                        omega[lane] = weights.weight(local + start + lane);
                    }
                    let mut part = [[0.0; LANES]; 3];
                    for lane in 0..width {
                        let (dx, dy, dz) = (d[0][lane], d[1][lane], d[2][lane]);
                        let scale = force_scale(
                            intact[lane] * omega[lane],
                            intact[lane],
                            own.isotropic + other_isotropic[lane],
                            own.deviatoric + other_deviatoric[lane],
                            zeta[lane],
                            (dx * dx + dy * dy + dz * dz).sqrt(),
                            neighbor_volume[lane],
                        );
                        part[0][lane] = scale * dx;
                        part[1][lane] = scale * dy;
                        part[2][lane] = scale * dz;
                    }
                    for lane in 0..width {
                        fx += part[0][lane];
                        fy += part[1][lane];
                        fz += part[2][lane];
                    }
                }};
            }
            let full = neighbors.len() - neighbors.len() % LANES;
            for start in (0..full).step_by(LANES) {
                group!(start, LANES);
            }
            for start in full..neighbors.len() {
                group!(start, 1);
            }
            let f = &mut out[i - base];
            f[0] += fx;
            f[1] += fy;
            f[2] += fz;
        }
    }

    /// [`Rows::add_force`] built for AVX2 when [`Rows::wide`], else for the baseline target
    /// (bitwise the same result, as [`Rows::dilatation_dispatch`]).
    #[inline(always)]
    fn add_force_dispatch<W: BondWeights, D: Integrity>(
        &self,
        coefficients: &[PointCoefficients],
        chunk: &[u32],
        base: usize,
        out: &mut [[f64; 3]],
        weights: W,
        damage: D,
    ) {
        #[cfg(target_arch = "x86_64")]
        if self.wide {
            // SAFETY: AVX2 was detected at run time.
            unsafe { self.add_force_avx2(coefficients, chunk, base, out, weights, damage) };
            return;
        }
        self.add_force(coefficients, chunk, base, out, weights, damage);
    }

    /// [`Rows::add_force`] with AVX2: each row by the intrinsics loop `rows_avx2::force_sum`
    /// (bitwise the staged loop's force).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn add_force_avx2<W: BondWeights, D: Integrity>(
        &self,
        coefficients: &[PointCoefficients],
        chunk: &[u32],
        base: usize,
        out: &mut [[f64; 3]],
        weights: W,
        damage: D,
    ) {
        let bonds = self.reference.bonds;
        let y = self.current.position;
        let points = gather_bound(bonds, y.len().min(coefficients.len()), self.volume, damage);
        let k0 = self.first_local(chunk);
        for (n, &i) in chunk.iter().enumerate() {
            let k = self.force_local(k0, n, i);
            let i = i as usize;
            // SAFETY: AVX2 is enabled here; `points` is from `gather_bound` over both arrays
            // the row reads.
            let f = unsafe {
                rows_avx2::force_sum(
                    self,
                    coefficients,
                    i,
                    self.local_offsets[k],
                    points,
                    weights,
                    damage,
                )
            };
            let out = &mut out[i - base];
            for c in 0..3 {
                out[c] += f[c];
            }
        }
    }

    /// `W_i = K θ²/2 + (α/2) Σ_j (1−d) ω (e − ε_i ζ − θζ/3)² V_j`, α = 15μ/m, ε the free
    /// thermal strain (0 without `strain`).
    #[allow(clippy::too_many_arguments)]
    fn energy<W: BondWeights, D: Integrity>(
        &self,
        strain: Option<&[f64]>,
        coefficients: &[PointCoefficients],
        chunk: &[u32],
        base: usize,
        out: &mut [f64],
        weights: W,
        damage: D,
    ) {
        let bonds = self.reference.bonds;
        let y = self.current.position;
        let k0 = self.first_local(chunk);
        for (k, &i) in (k0..).zip(chunk) {
            let i = i as usize;
            let yi = y[i];
            let theta = coefficients[i].dilatation;
            let alpha = coefficients[i].deviatoric;
            let local = self.local_offsets[k];
            let free = strain.map_or(0.0, |s| s[i]);
            let mut sum = 0.0;
            for (n, b) in bonds.range(i).enumerate() {
                let j = bonds.neighbor[b] as usize;
                let yj = y[j];
                let (dx, dy, dz) = (yj[0] - yi[0], yj[1] - yi[1], yj[2] - yi[2]);
                let zeta = bonds.reference_length[b];
                let length = (dx * dx + dy * dy + dz * dz).sqrt();
                let deviatoric = match strain {
                    None => length - zeta - theta * zeta / 3.0,
                    Some(_) => length - zeta - free * zeta - theta * zeta / 3.0,
                };
                sum += damage.intact(b)
                    * weights.weight(local + n)
                    * deviatoric
                    * deviatoric
                    * self.reference.neighbor_volume(b, j);
            }
            out[i - base] = 0.5 * self.bulk * theta * theta + 0.5 * alpha * sum;
        }
    }
}

/// The bond loops with thermal strain (module docs): plain loops, used only by blocks with a
/// `Thermal Expansion Coefficient` in runs with point temperatures.
impl<V: VolumeRule> Rows<'_, V> {
    /// θ_i = (3/m) Σ_j ω (1−d) ζ (e − ε_i ζ) V_j and the published coefficients, ε = α ΔT.
    fn thermal_dilatation<W: BondWeights, D: Integrity>(
        &self,
        strain: &[f64],
        chunk: &[u32],
        base: usize,
        out: &mut [PointCoefficients],
        weights: W,
        damage: D,
    ) {
        let bonds = self.reference.bonds;
        let y = self.current.position;
        let k0 = self.first_local(chunk);
        for (k, &i) in (k0..).zip(chunk) {
            let i = i as usize;
            let local = self.local_offsets[k];
            let mut sum = 0.0;
            for (n, b) in bonds.range(i).enumerate() {
                let j = bonds.neighbor[b] as usize;
                let zeta = bonds.reference_length[b];
                let extension = distance(y[i], y[j]) - zeta - strain[i] * zeta;
                sum += weights.weight(local + n)
                    * damage.intact(b)
                    * zeta
                    * extension
                    * self.reference.neighbor_volume(b, j);
            }
            let m = self.weighted_volume[k];
            out[i - base] = if m > 0.0 {
                let theta = 3.0 * sum / m;
                PointCoefficients {
                    dilatation: theta,
                    isotropic: (3.0 * self.bulk - 5.0 * self.shear) * theta / m,
                    deviatoric: 15.0 * self.shear / m,
                }
            } else {
                PointCoefficients::default()
            };
        }
    }

    /// `F_i += Σ_j (1−d) ω [(A_i + A_j) ζ + (1−d)(B_i (e − ε_i ζ) + B_j (e − ε_j ζ))] V_j M_ij`.
    #[allow(clippy::too_many_arguments)]
    fn thermal_force<W: BondWeights, D: Integrity>(
        &self,
        strain: &[f64],
        coefficients: &[PointCoefficients],
        chunk: &[u32],
        base: usize,
        out: &mut [[f64; 3]],
        weights: W,
        damage: D,
    ) {
        let bonds = self.reference.bonds;
        let y = self.current.position;
        for &i in chunk {
            let k = self.points.partition_point(|&p| p < i);
            let i = i as usize;
            let own = coefficients[i];
            let local = self.local_offsets[k];
            let mut total = [0.0; 3];
            for (n, b) in bonds.range(i).enumerate() {
                let j = bonds.neighbor[b] as usize;
                let length = distance(y[i], y[j]);
                if length == 0.0 {
                    continue;
                }
                let zeta = bonds.reference_length[b];
                let other = coefficients[j];
                let extension = length - zeta;
                let intact = damage.intact(b);
                let t = intact
                    * weights.weight(local + n)
                    * ((own.isotropic + other.isotropic) * zeta
                        + intact
                            * (own.deviatoric * (extension - strain[i] * zeta)
                                + other.deviatoric * (extension - strain[j] * zeta)));
                let scale = t * self.reference.neighbor_volume(b, j) / length;
                for c in 0..3 {
                    total[c] += scale * (y[j][c] - y[i][c]);
                }
            }
            for c in 0..3 {
                out[i - base][c] += total[c];
            }
        }
    }
}

/// Bond `start + n` of a row ([`checked_row`]): its neighbour j, Y_j, ζ and w_ij.
///
/// # Safety
/// `n` is below the row's length, the row `start..` is from [`checked_row`] with a bound
/// `points` from [`gather_bound`] over `y.len()` or less and `volume`.
#[inline(always)]
unsafe fn gather<V: VolumeRule>(
    neighbors: &[u32],
    lengths: &[f64],
    y: &[[f64; 3]],
    volume: V,
    start: usize,
    n: usize,
) -> (usize, [f64; 3], f64, f64) {
    // SAFETY: as the caller guarantees (neighbors and lengths are the same row).
    unsafe {
        let j = *neighbors.get_unchecked(n) as usize;
        (
            j,
            *y.get_unchecked(j),
            *lengths.get_unchecked(n),
            volume.of_unchecked(start + n, j),
        )
    }
}

/// ω (1−d) ζ e V_j, a bond's term of the dilatation sum, with `weight` = ω (1−d) and
/// e = fl(√q) − ζ.
#[inline(always)]
fn dilatation_term(weight: f64, zeta: f64, squared: f64, volume: f64) -> f64 {
    let extension = squared.sqrt() - zeta;
    weight * zeta * extension * volume
}

/// The factor of `Y_j − Y_i` in a bond's force: `t V_j / |Y|` with
/// `t = (1−d) ω [(A_i + A_j) ζ + (1−d)(B_i + B_j) e]`, e = |Y| − ζ, from `scaled` = (1−d) ω,
/// `intact` = 1 − d, the coefficient sums and `length` = |Y|; zero when |Y| is not positive
/// (divided unconditionally so that the lanes need no branch: the inf/NaN of a zero length
/// is discarded).
#[inline(always)]
fn force_scale(
    scaled: f64,
    intact: f64,
    isotropic: f64,
    deviatoric: f64,
    zeta: f64,
    length: f64,
    volume: f64,
) -> f64 {
    let extension = length - zeta;
    let t = scaled * (isotropic * zeta + intact * deviatoric * extension);
    let scale = t * volume / length;
    if length > 0.0 {
        scale
    } else {
        0.0
    }
}

/// |b − a|.
#[inline(always)]
fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    let (dx, dy, dz) = (b[0] - a[0], b[1] - a[1], b[2] - a[2]);
    (dx * dx + dy * dy + dz * dz).sqrt()
}

/// Bonds of a row evaluated together in the LPS loops (the width of an AVX2 vector of f64; the
/// result does not depend on it, since the terms are summed in bond order).
const LANES: usize = 4;

/// The bond breaking the dilatation pass does before it uses each bond.
///
/// # Contract of an implementation that breaks bonds
/// `damage` and `break_bond` access the bond-damage array through a pointer; the pass only
/// calls them for bonds in the rows of the running chunk's points, which no other task reads
/// or writes meanwhile (each point's row belongs to one chunk); the damage reads of the pass
/// go through the same pointer.
trait RowBreaker: Copy + Send + Sync {
    /// The critical stretch to test, `None` when the pass breaks nothing.
    fn limit(self) -> Option<StretchLimit>;

    /// d of bond `b`.
    ///
    /// # Safety
    /// See the trait.
    unsafe fn damage(self, b: usize) -> f32;

    /// Sets d = 1 on bond `b` (this direction only: the other end's row takes the same
    /// decision from the same numbers).
    ///
    /// # Safety
    /// See the trait.
    unsafe fn break_bond(self, b: usize);
}

/// The dilatation pass alone (damage already up to date, or no damage).
#[derive(Clone, Copy)]
struct NoBreaking;

impl RowBreaker for NoBreaking {
    #[inline(always)]
    fn limit(self) -> Option<StretchLimit> {
        None
    }

    unsafe fn damage(self, _b: usize) -> f32 {
        unreachable!("NoBreaking has no limit")
    }

    unsafe fn break_bond(self, _b: usize) {
        unreachable!("NoBreaking has no limit")
    }
}

impl RowBreaker for FusedCriticalStretch {
    #[inline(always)]
    fn limit(self) -> Option<StretchLimit> {
        Some(self.limit)
    }

    #[inline(always)]
    unsafe fn damage(self, b: usize) -> f32 {
        // SAFETY: as the caller guarantees.
        unsafe { self.read(b) }
    }

    #[inline(always)]
    unsafe fn break_bond(self, b: usize) {
        // SAFETY: as the caller guarantees.
        unsafe { FusedCriticalStretch::break_bond(self, b) };
    }
}

/// The LPS force state of one point for the tangent, from its family's positions alone:
/// `θ = (3/m) Σ_n ω (1−d) ζ e V_j`, `t_n = (1−d) ω [A ζ + (1−d) B e]` with
/// `A = (3K − 5μ) θ/m`, `B = 15μ/m`, and `T_n = t_n M_n` (the module docs' formulas).
struct LpsForceState<'a, W, D> {
    bonds: &'a crate::model::BondList,
    volume: BondVolumes<'a>,
    local_offsets: &'a [usize],
    weighted_volume: &'a [f64],
    weights: W,
    damage: D,
    bulk: f64,
    shear: f64,
    /// The free thermal strain α ΔT of every point (module docs), when the block has α and
    /// the run has point temperatures.
    thermal_strain: Option<&'a [f64]>,
    /// s per block point, or empty (s = 1).
    correction: &'a [f64],
}

impl<W: BondWeights, D: Integrity> LpsForceState<'_, W, D> {
    /// e = |Y| − ζ, less the free thermal strain ε_i ζ when there is one.
    #[inline(always)]
    fn extension<T: Scalar>(&self, point: PointIndex, length: T, zeta: f64) -> T {
        match self.thermal_strain {
            None => length - zeta,
            Some(strain) => length - zeta - strain[point.global] * zeta,
        }
    }

    /// m, (3K − 5μ)/m and 15μ/m of the point (μ times its shear-correction factor, if any);
    /// `None` when m = 0 (no force).
    fn moduli(&self, point: PointIndex) -> Option<(f64, f64, f64)> {
        let m = self.weighted_volume[point.local];
        let shear = corrected_shear(self.shear, self.correction, point.local);
        (m > 0.0).then(|| (m, (3.0 * self.bulk - 5.0 * shear) / m, 15.0 * shear / m))
    }
}

/// μ of block point `local`: times its shear-correction factor when `correction` has one.
#[inline(always)]
fn corrected_shear(shear: f64, correction: &[f64], local: usize) -> f64 {
    match correction.get(local) {
        Some(s) => s * shear,
        None => shear,
    }
}

impl<W: BondWeights, D: Integrity> ForceState for LpsForceState<'_, W, D> {
    const BOND_LOCAL: bool = false;
    const ANALYTIC: bool = true;

    fn force_state<T: Scalar>(
        &self,
        point: PointIndex,
        y: &[[T; 3]],
        _only: Option<usize>,
        t: &mut [[T; 3]],
    ) {
        let range = self.bonds.range(point.global);
        let zero = T::from(0.0);
        let Some((m, isotropic_per_theta, deviatoric)) = self.moduli(point) else {
            t.fill([zero; 3]);
            return;
        };
        let local = self.local_offsets[point.local];
        // Pass 1: θ; each bond's length and extension are kept in t[n] for pass 2.
        let mut sum = zero;
        for (n, b) in range.clone().enumerate() {
            let zeta = self.bonds.reference_length[b];
            let d = [0, 1, 2].map(|k| y[n + 1][k] - y[0][k]);
            let squared = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            // A zero length has no derivative; the force kernel gives such a bond no force.
            let length = if squared.re() > 0.0 {
                squared.sqrt()
            } else {
                zero
            };
            let extension = self.extension(point, length, zeta);
            let j = self.bonds.neighbor[b] as usize;
            sum += extension
                * (self.weights.weight(local + n)
                    * self.damage.intact(b)
                    * zeta
                    * self.volume.of(b, j));
            t[n] = [length, extension, zero];
        }
        let theta = sum * (3.0 / m);
        let isotropic = theta * isotropic_per_theta;
        for (n, b) in range.enumerate() {
            let [length, extension, _] = t[n];
            t[n] = if length.re() > 0.0 {
                let zeta = self.bonds.reference_length[b];
                let intact = self.damage.intact(b);
                let scalar = (isotropic * zeta + extension * (intact * deviatoric))
                    * (intact * self.weights.weight(local + n));
                let scale = scalar / length;
                [0, 1, 2].map(|k| (y[n + 1][k] - y[0][k]) * scale)
            } else {
                [zero; 3]
            };
        }
    }

    /// `axial = (1−d)² ω B`, `lateral = t_n/|Y|`, `γ_n = ∂t_n/∂θ = (1−d) ω ζ (3K − 5μ)/m`,
    /// `β_n = ∂θ/∂e_n = (3/m) ω (1−d) ζ V_j`.
    fn ordinary_derivatives(&self, point: PointIndex, y: &[[f64; 3]], out: &mut [OrdinaryBond]) {
        let range = self.bonds.range(point.global);
        let Some((m, isotropic_per_theta, deviatoric)) = self.moduli(point) else {
            out.fill(OrdinaryBond::default());
            return;
        };
        let local = self.local_offsets[point.local];
        // Pass 1: θ, with each bond's length kept in `lateral` and extension in `axial`.
        let mut sum = 0.0;
        for ((n, b), bond) in range.clone().enumerate().zip(out.iter_mut()) {
            let zeta = self.bonds.reference_length[b];
            let d = [0, 1, 2].map(|k| y[n + 1][k] - y[0][k]);
            let length = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let extension = self.extension(point, length, zeta);
            let j = self.bonds.neighbor[b] as usize;
            let factor = self.weights.weight(local + n)
                * self.damage.intact(b)
                * zeta
                * self.volume.of(b, j);
            sum += factor * extension;
            *bond = OrdinaryBond {
                direction: if length > 0.0 {
                    d.map(|c| c / length)
                } else {
                    [0.0; 3]
                },
                axial: extension,
                lateral: length,
                coupling: 0.0,
                weight: 3.0 / m * factor,
            };
        }
        let theta = 3.0 * sum / m;
        let isotropic = theta * isotropic_per_theta;
        for ((n, b), bond) in range.enumerate().zip(out.iter_mut()) {
            let (extension, length) = (bond.axial, bond.lateral);
            if length <= 0.0 {
                // No direction, no force, no derivative (as the force kernel).
                *bond = OrdinaryBond::default();
                continue;
            }
            let zeta = self.bonds.reference_length[b];
            let intact = self.damage.intact(b);
            let omega = self.weights.weight(local + n);
            let scalar = intact * omega * (isotropic * zeta + intact * deviatoric * extension);
            bond.axial = intact * intact * omega * deviatoric;
            bond.lateral = scalar / length;
            bond.coupling = intact * omega * zeta * isotropic_per_theta;
        }
    }
}

impl LinearPeridynamicSolid {
    /// The loops' inputs, with the quadrature rule `volume` compiled in.
    fn rows<'a, V: VolumeRule>(
        &'a self,
        reference: &'a ReferenceView<'a>,
        current: &'a CurrentView<'a>,
        volume: V,
    ) -> Rows<'a, V> {
        Rows {
            reference,
            volume,
            current,
            points: self.block.points(),
            local_offsets: &self.local_offsets,
            weighted_volume: &self.weighted_volume,
            bulk: self.block.bulk_modulus(),
            shear: self.shear_modulus,
            correction: &self.correction,
            force_subset: self.block.force_points().len() < self.block.points().len(),
            wide: wide_vectors_available(),
        }
    }
}

impl Material for LinearPeridynamicSolid {
    fn block(&self) -> &BlockData {
        &self.block
    }

    fn block_mut(&mut self) -> &mut BlockData {
        &mut self.block
    }

    fn prepare(&mut self, reference: &ReferenceView<'_>) -> Result<(), MaterialError> {
        let bonds = reference.bonds;
        let points = self.block.points();
        let horizon = self.block.horizon();
        let weights = if self.influence.is_one() {
            None
        } else {
            Some(self.influence.per_bond(bonds, points, horizon)?)
        };
        let local_offsets = local_offsets(bonds, points);
        let weighted_volume =
            influence_weighted_volumes(reference, points, &local_offsets, weights.as_deref());
        self.correction = if self.shear_correction {
            super::shear_correction::factors(
                reference,
                points,
                &weighted_volume,
                weights.as_deref().map(|w| (w, local_offsets.as_slice())),
            )
        } else {
            Vec::new()
        };
        self.weights = weights;
        self.local_offsets = local_offsets;
        self.weighted_volume = weighted_volume;
        Ok(())
    }

    fn compute_point_coefficients(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        coefficients: &mut [PointCoefficients],
    ) {
        if let Some(strain) = self.thermal_strain(current) {
            let rows = self.rows(reference, current, reference.bond_volumes());
            with_bond_data!(self.weights.as_deref(), current.bond_damage, |w, d| {
                for_each_chunk(
                    self.block.points(),
                    coefficients,
                    &|i| i as usize,
                    &|chunk: &[u32], base: usize, out: &mut [PointCoefficients]| {
                        rows.thermal_dilatation(strain, chunk, base, out, w, d)
                    },
                )
            });
            return;
        }
        with_volume_rule!(reference, |v| {
            let rows = self.rows(reference, current, v);
            with_bond_data!(self.weights.as_deref(), current.bond_damage, |w, d| {
                for_each_chunk(
                    self.block.points(),
                    coefficients,
                    &|i| i as usize,
                    &|chunk: &[u32], base: usize, out: &mut [PointCoefficients]| {
                        // SAFETY: `NoBreaking` touches no damage.
                        unsafe { rows.dilatation_dispatch(chunk, base, out, w, d, NoBreaking) };
                    },
                )
            })
        })
    }

    /// The dilatation pass breaks the bonds of each row (not with thermal expansion: the fused
    /// pass measures e without the thermal strain). Each row decides its own bonds and reads
    /// only its neighbours' positions, so the block need not hold its neighbours: a rank's
    /// layer-1 ghosts, whose neighbours in the outer ghost layer belong to no block's point
    /// list, take the pass as their owner does.
    fn critical_stretch_fast_path(&self) -> Option<CriticalStretchFastPath<'_>> {
        self.block
            .thermal_expansion()
            .is_none()
            .then_some(CriticalStretchFastPath::PointCoefficients(self))
    }

    fn add_force_density(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        coefficients: &[PointCoefficients],
        force_density: &mut [[f64; 3]],
    ) {
        let force_points = self.block.force_points();
        if let Some(strain) = self.thermal_strain(current) {
            let rows = self.rows(reference, current, reference.bond_volumes());
            with_bond_data!(self.weights.as_deref(), current.bond_damage, |w, d| {
                for_each_chunk(
                    force_points,
                    force_density,
                    &|i| i as usize,
                    &|chunk: &[u32], base: usize, out: &mut [[f64; 3]]| {
                        rows.thermal_force(strain, coefficients, chunk, base, out, w, d)
                    },
                )
            });
            return;
        }
        with_volume_rule!(reference, |v| {
            let rows = self.rows(reference, current, v);
            with_bond_data!(self.weights.as_deref(), current.bond_damage, |w, d| {
                for_each_chunk(
                    force_points,
                    force_density,
                    &|i| i as usize,
                    &|chunk: &[u32], base: usize, out: &mut [[f64; 3]]| {
                        rows.add_force_dispatch(coefficients, chunk, base, out, w, d)
                    },
                )
            })
        })
    }

    fn stored_energy_density(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        coefficients: &[PointCoefficients],
        energy_density: &mut [f64],
    ) {
        let rows = self.rows(reference, current, reference.bond_volumes());
        let strain = self.thermal_strain(current);
        with_bond_data!(self.weights.as_deref(), current.bond_damage, |w, d| {
            for_each_chunk(
                self.block.points(),
                energy_density,
                &|i| i as usize,
                &|chunk: &[u32], base: usize, out: &mut [f64]| {
                    rows.energy(strain, coefficients, chunk, base, out, w, d)
                },
            )
        })
    }

    fn tangent(&self) -> Option<&dyn MaterialTangent> {
        Some(self)
    }

    fn outputs(&self) -> Option<&dyn MaterialOutputs> {
        Some(self)
    }
}

impl MaterialTangent for LinearPeridynamicSolid {
    fn add_tangent(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        method: TangentMethod,
        tangent: &mut BlockTangent,
    ) -> Result<(), TangentError> {
        let model = Self::DECLARATION.deck_name;
        with_bond_data!(self.weights.as_deref(), current.bond_damage, |w, d| {
            let kernel = LpsForceState {
                bonds: reference.bonds,
                volume: reference.bond_volumes(),
                local_offsets: &self.local_offsets,
                weighted_volume: &self.weighted_volume,
                weights: w,
                damage: d,
                bulk: self.block.bulk_modulus(),
                shear: self.shear_modulus,
                thermal_strain: self.thermal_strain(current),
                correction: &self.correction,
            };
            assemble(
                &kernel,
                model,
                self.block.points(),
                reference,
                current,
                method,
                tangent,
            )
        })
    }
}

impl MaterialOutputs for LinearPeridynamicSolid {
    fn weighted_volume(&self) -> Option<&[f64]> {
        Some(&self.weighted_volume)
    }

    fn partial_stress(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        out: &mut [[f64; 9]],
    ) {
        use rayon::prelude::*;
        let bonds = reference.bonds;
        with_bond_data!(self.weights.as_deref(), current.bond_damage, |w, d| {
            let kernel = LpsForceState {
                bonds,
                volume: reference.bond_volumes(),
                local_offsets: &self.local_offsets,
                weighted_volume: &self.weighted_volume,
                weights: w,
                damage: d,
                bulk: self.block.bulk_modulus(),
                shear: self.shear_modulus,
                thermal_strain: self.thermal_strain(current),
                correction: &self.correction,
            };
            let stresses: Vec<[f64; 9]> = self
                .block
                .points()
                .par_iter()
                .enumerate()
                .map_init(
                    || (Vec::new(), Vec::new()),
                    |(y, t), (local, &p)| {
                        let p = p as usize;
                        y.clear();
                        y.push(current.position[p]);
                        y.extend(
                            bonds
                                .family(p)
                                .iter()
                                .map(|&j| current.position[j as usize]),
                        );
                        t.clear();
                        t.resize(bonds.family_size(p), [0.0; 3]);
                        kernel.force_state(PointIndex { global: p, local }, y, None, t);
                        let x = reference.position;
                        let mut stress = [0.0; 9];
                        for (force, b) in t.iter().zip(bonds.range(p)) {
                            let j = bonds.neighbor[b] as usize;
                            let v = reference.neighbor_volume(b, j);
                            for r in 0..3 {
                                for c in 0..3 {
                                    stress[3 * r + c] += force[r] * (x[j][c] - x[p][c]) * v;
                                }
                            }
                        }
                        stress
                    },
                )
                .collect();
            for (&p, stress) in self.block.points().iter().zip(stresses) {
                out[p as usize] = stress;
            }
        })
    }
}

impl BreakingCoefficientPass for LinearPeridynamicSolid {
    /// The dilatation pass tests each bond of a row just before it enters θ: the same q and
    /// the same exact test (behind the filter of `StretchLimit::breaks`) as the directed
    /// `Critical Stretch` update, each row deciding its own bonds (both ends of a pair decide
    /// alike, see [`crate::damage::CriticalStretch`]).
    fn compute_point_coefficients_breaking_bonds(
        &self,
        reference: &ReferenceView<'_>,
        position: &[[f64; 3]],
        critical_stretch: f64,
        bond_damage: &mut [f32],
        coefficients: &mut [PointCoefficients],
    ) -> usize {
        assert_eq!(bond_damage.len(), reference.bonds.num_bonds());
        let current = CurrentView {
            position,
            bond_damage: None,
            history: &crate::history::NO_HISTORY,
        };
        let fused = FusedCriticalStretch {
            limit: StretchLimit::new(critical_stretch),
            damage: bond_damage.as_mut_ptr(),
        };
        with_volume_rule!(reference, |v| {
            let rows = self.rows(reference, &current, v);
            match self.weights.as_deref() {
                None => rows.fused_dilatation(coefficients, UnitWeights, fused),
                Some(weights) => rows.fused_dilatation(coefficients, StoredWeights(weights), fused),
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::damage::{CriticalStretch, DamageModel};
    use crate::model::test_support::{brute_force_bonds, random_cloud, Rng};

    #[test]
    fn the_coefficient_kernels_match_the_generic_force_state_sum() {
        // The two-pass kernel (published θ, then t_ij + t_ji) is a fast path of
        // F_i = Σ_j (T_i⟨ξ_ij⟩ − T_j⟨ξ_ji⟩) V_j (`material::generic_force`): the same force to
        // round-off, with symmetric damage and both kinds of ω.
        let mut rng = Rng::new(21);
        let (x, v) = random_cloud(&mut rng, 400, 6.0);
        let bonds = brute_force_bonds(&x, 1.7);
        let y: Vec<[f64; 3]> = x
            .iter()
            .map(|p| p.map(|c| c + 0.05 * (2.0 * rng.uniform() - 1.0)))
            .collect();
        let mut damage = vec![0.0f32; bonds.num_bonds()];
        for i in 0..x.len() {
            for b in bonds.range(i) {
                let j = bonds.neighbor[b] as usize;
                if j > i && rng.uniform() < 0.2 {
                    let back =
                        bonds.offsets[j] + bonds.family(j).binary_search(&(i as u32)).unwrap();
                    let d = if rng.uniform() < 0.5 { 1.0 } else { 0.5 };
                    damage[b] = d;
                    damage[back] = d;
                }
            }
        }
        let reference = ReferenceView {
            bonds: &bonds,
            position: &x,
            volume: &v,
            bond_volume: None,
        };
        let current = CurrentView {
            position: &y,
            bond_damage: Some(&damage),
            history: &crate::history::NO_HISTORY,
        };
        let all: Vec<u32> = (0..x.len() as u32).collect();
        // The shear correction changes μ per point in both the coefficients and the force
        // states, so the two must still agree with it on.
        for (influence, corrected) in [
            (InfluenceFunction::One, false),
            (InfluenceFunction::ParabolicDecay, false),
            (InfluenceFunction::ParabolicDecay, true),
        ] {
            let mut m = LinearPeridynamicSolid::new(
                &crate::material::BlockInput {
                    density: 1.0,
                    horizon: 1.7,
                    influence,
                },
                &crate::material::ElasticConstants {
                    bulk_modulus: 3.0,
                    shear_modulus: 1.3,
                },
            )
            .unwrap()
            .with_shear_correction(corrected);
            crate::material::set_up(&mut m, &reference, all.clone());
            assert_eq!(m.correction.is_empty(), !corrected);
            let mut coefficients = vec![PointCoefficients::default(); x.len()];
            m.compute_point_coefficients(&reference, &current, &mut coefficients);
            let mut fast = vec![[0.0; 3]; x.len()];
            m.add_force_density(&reference, &current, &coefficients, &mut fast);
            let mut generic = vec![[0.0; 3]; x.len()];
            let sum = |out: &mut Vec<[f64; 3]>| {
                with_bond_data!(m.weights.as_deref(), current.bond_damage, |w, d| {
                    let kernel = LpsForceState {
                        bonds: &bonds,
                        volume: BondVolumes::new(&v, None),
                        local_offsets: &m.local_offsets,
                        weighted_volume: &m.weighted_volume,
                        weights: w,
                        damage: d,
                        bulk: 3.0,
                        shear: 1.3,
                        thermal_strain: None,
                        correction: &m.correction,
                    };
                    crate::material::generic_force::add_force_density_from_states(
                        &kernel, &all, &reference, &current, out,
                    )
                })
            };
            sum(&mut generic);
            let largest = fast.iter().flatten().fold(0.0f64, |a, f| a.max(f.abs()));
            assert!(largest > 0.0);
            for (a, b) in fast.iter().flatten().zip(generic.iter().flatten()) {
                assert!((a - b).abs() <= 1e-12 * largest, "{a} vs {b}");
            }
        }
    }

    #[test]
    fn fused_breaking_matches_the_separate_update_bitwise() {
        // 500 random points (rows longer than a group of lanes, with tails), displaced at half
        // and then at the full random field so that the second pass meets broken bonds, with
        // ω = 1 and a stored ω. The dilatation pass that breaks bonds itself must break the
        // same bonds as the `Critical Stretch` update (same count, same damage array) and give
        // the same coefficients bit for bit, and so the same forces. Also for a block that
        // does not hold all its neighbours (a rank's layer-1 ghosts, whose neighbours in the
        // outer ghost layer are in no block's list): the points left of x = 4.
        let mut rng = Rng::new(5);
        let (x, v) = random_cloud(&mut rng, 500, 6.0);
        let bonds = brute_force_bonds(&x, 1.7);
        let y: Vec<[f64; 3]> = x
            .iter()
            .map(|p| p.map(|c| c + 0.08 * (2.0 * rng.uniform() - 1.0)))
            .collect();
        let reference = ReferenceView {
            bonds: &bonds,
            position: &x,
            volume: &v,
            bond_volume: None,
        };
        let all: Vec<u32> = (0..x.len() as u32).collect();
        let left: Vec<u32> = all
            .iter()
            .copied()
            .filter(|&i| x[i as usize][0] < 4.0)
            .collect();
        let open = left.iter().any(|&i| {
            bonds
                .family(i as usize)
                .iter()
                .any(|&j| x[j as usize][0] >= 4.0)
        });
        assert!(
            open,
            "some neighbours of the left points should be right of x = 4"
        );
        // The shear correction changes μ per point in both the coefficients and the force
        // states, so the two must still agree with it on.
        for ((influence, corrected), points) in [
            (InfluenceFunction::One, false),
            (InfluenceFunction::ParabolicDecay, false),
            (InfluenceFunction::ParabolicDecay, true),
        ]
        .into_iter()
        .flat_map(|case| [(case.clone(), &all), (case, &left)])
        {
            let mut m = LinearPeridynamicSolid::new(
                &crate::material::BlockInput {
                    density: 1.0,
                    horizon: 1.7,
                    influence,
                },
                &crate::material::ElasticConstants {
                    bulk_modulus: 3.0,
                    shear_modulus: 1.3,
                },
            )
            .unwrap()
            .with_shear_correction(corrected);
            crate::material::set_up(&mut m, &reference, points.clone());
            assert_eq!(m.correction.is_empty(), !corrected);
            assert!(m.critical_stretch_fast_path().is_some());
            let model = CriticalStretch::new(0.02).unwrap();
            let mut separate = vec![0.0f32; bonds.num_bonds()];
            let mut fused = vec![0.0f32; bonds.num_bonds()];
            let mut total = 0;
            for fraction in [0.5, 1.0] {
                let at: Vec<[f64; 3]> = x
                    .iter()
                    .zip(&y)
                    .map(|(p, q)| [0, 1, 2].map(|k| p[k] + fraction * (q[k] - p[k])))
                    .collect();
                let broken = model.update(&reference, &at, points, &mut separate);
                let mut expected = vec![PointCoefficients::default(); x.len()];
                let current = CurrentView {
                    position: &at,
                    bond_damage: Some(&separate),
                    history: &crate::history::NO_HISTORY,
                };
                m.compute_point_coefficients(&reference, &current, &mut expected);
                let mut coefficients = vec![PointCoefficients::default(); x.len()];
                let fused_broken = m.compute_point_coefficients_breaking_bonds(
                    &reference,
                    &at,
                    0.02,
                    &mut fused,
                    &mut coefficients,
                );
                assert_eq!(fused_broken, broken);
                assert_eq!(fused, separate);
                assert_eq!(coefficients, expected);
                total += broken;
            }
            assert!(total > 0 && total < bonds.num_bonds(), "{total}");
        }
    }

    /// Reference positions, volumes, families and current positions.
    type Cloud = (
        Vec<[f64; 3]>,
        Vec<f64>,
        crate::model::BondList,
        Vec<[f64; 3]>,
    );

    /// 300 random points in a 5-wide box, their δ = 1.6 families, and positions moved by up
    /// to ±0.05 in every direction.
    fn perturbed_cloud(seed: u64) -> Cloud {
        let mut rng = Rng::new(seed);
        let (x, v) = random_cloud(&mut rng, 300, 5.0);
        let bonds = brute_force_bonds(&x, 1.6);
        let y = x
            .iter()
            .map(|p| p.map(|c| c + 0.05 * (2.0 * rng.uniform() - 1.0)))
            .collect();
        (x, v, bonds, y)
    }

    /// The LPS material of the perturbed cloud (δ = 1.6, not set up).
    fn small_material(influence: InfluenceFunction) -> LinearPeridynamicSolid {
        LinearPeridynamicSolid::new(
            &crate::material::BlockInput {
                density: 1.0,
                horizon: 1.6,
                influence,
            },
            &crate::material::ElasticConstants {
                bulk_modulus: 3.0,
                shear_modulus: 1.3,
            },
        )
        .unwrap()
    }

    #[test]
    fn restricted_forces_are_the_kept_points_forces_bitwise() {
        // A rank keeps its owned points (here every third point of a block that is a part of
        // the cloud, with a parabolic influence so that the block-local bond weights matter):
        // their forces are bitwise those of the unrestricted pass, the others are untouched.
        let (x, v, bonds, y) = perturbed_cloud(21);
        let reference = ReferenceView {
            bonds: &bonds,
            position: &x,
            volume: &v,
            bond_volume: None,
        };
        let mut m = small_material(InfluenceFunction::ParabolicDecay);
        let block: Vec<u32> = (0..x.len() as u32).filter(|p| p % 5 != 0).collect();
        crate::material::set_up(&mut m, &reference, block.clone());
        let current = CurrentView {
            position: &y,
            bond_damage: None,
            history: &crate::history::NO_HISTORY,
        };
        let mut c = vec![PointCoefficients::default(); x.len()];
        m.compute_point_coefficients(&reference, &current, &mut c);
        let mut all = vec![[0.0; 3]; x.len()];
        m.add_force_density(&reference, &current, &c, &mut all);
        let kept = |p: u32| p % 3 == 0;
        (&mut m as &mut dyn Material).restrict_forces(&kept);
        let untouched = [7.0, 8.0, 9.0];
        let mut restricted = vec![untouched; x.len()];
        restricted
            .iter_mut()
            .enumerate()
            .filter(|(p, _)| kept(*p as u32) && block.contains(&(*p as u32)))
            .for_each(|(_, f)| *f = [0.0; 3]);
        m.add_force_density(&reference, &current, &c, &mut restricted);
        for p in 0..x.len() as u32 {
            if kept(p) && block.contains(&p) {
                assert_eq!(restricted[p as usize], all[p as usize], "point {p}");
            } else {
                assert_eq!(restricted[p as usize], untouched, "point {p}");
            }
        }
        // Keeping every point is no restriction.
        (&mut m as &mut dyn Material).restrict_forces(&|_| true);
        let mut again = vec![[0.0; 3]; x.len()];
        m.add_force_density(&reference, &current, &c, &mut again);
        assert_eq!(again, all);
    }

    #[test]
    fn the_avx2_rows_are_the_baseline_rows_bitwise() {
        // The AVX2 rows (intrinsics, four bonds per register) against the baseline build of
        // the staged loops: stored ω, fractional damage, rows of every length mod 4, and a
        // critical stretch that breaks bonds in the dilatation pass.
        if !wide_vectors_available() {
            eprintln!("this CPU has no AVX2: only the baseline rows run here");
            return;
        }
        let (x, v, bonds, y) = perturbed_cloud(11);
        let reference = ReferenceView {
            bonds: &bonds,
            position: &x,
            volume: &v,
            bond_volume: None,
        };
        let lengths: std::collections::BTreeSet<usize> =
            (0..x.len()).map(|i| bonds.family_size(i) % 4).collect();
        assert_eq!(lengths.len(), 4, "rows of every length mod 4");
        let all: Vec<u32> = (0..x.len() as u32).collect();
        let mut m = small_material(InfluenceFunction::ParabolicDecay);
        crate::material::set_up(&mut m, &reference, all.clone());
        let weights = StoredWeights(m.weights.as_deref().expect("parabolic ω is stored"));
        let mut damage = vec![0.0f32; bonds.num_bonds()];
        for b in (0..damage.len()).step_by(5) {
            damage[b] = 0.5;
        }
        let current = CurrentView {
            position: &y,
            bond_damage: None,
            history: &crate::history::NO_HISTORY,
        };
        with_volume_rule!(reference, |volume| {
            let run = |wide: bool, stretch: Option<f64>| {
                let mut rows = m.rows(&reference, &current, volume);
                rows.wide = wide;
                let mut coefficients = vec![PointCoefficients::default(); x.len()];
                let mut damage = damage.clone();
                let broken = match stretch {
                    // SAFETY: one chunk holds every row; nothing else touches `damage`.
                    None => unsafe {
                        rows.dilatation_dispatch(
                            &all,
                            0,
                            &mut coefficients,
                            weights,
                            Damaged(&damage),
                            NoBreaking,
                        )
                    },
                    Some(stretch) => {
                        let fused = FusedCriticalStretch {
                            limit: StretchLimit::new(stretch),
                            damage: damage.as_mut_ptr(),
                        };
                        // SAFETY: as above; the pointer is the only access meanwhile.
                        unsafe {
                            rows.dilatation_dispatch(
                                &all,
                                0,
                                &mut coefficients,
                                weights,
                                fused,
                                fused,
                            )
                        }
                    }
                };
                let mut f = vec![[0.0; 3]; x.len()];
                rows.add_force_dispatch(&coefficients, &all, 0, &mut f, weights, Damaged(&damage));
                (coefficients, f, damage, broken)
            };
            for stretch in [None, Some(0.02)] {
                let wide = run(true, stretch);
                assert_eq!(wide, run(false, stretch));
                assert_eq!(wide.3 > 0, stretch.is_some(), "bonds broken: {}", wide.3);
            }
        });
    }

    #[test]
    fn grouped_force_loop_sums_in_bond_order() {
        // The lanes only compute the bond terms; the sums run in bond order, so the force is
        // bitwise the plain running sum written out here (the module docs' formula).
        let (x, v, bonds, y) = perturbed_cloud(9);
        let reference = ReferenceView {
            bonds: &bonds,
            position: &x,
            volume: &v,
            bond_volume: None,
        };
        let mut m = small_material(InfluenceFunction::One);
        crate::material::set_up(&mut m, &reference, (0..x.len() as u32).collect());
        let current = CurrentView {
            position: &y,
            bond_damage: None,
            history: &crate::history::NO_HISTORY,
        };
        let mut c = vec![PointCoefficients::default(); x.len()];
        m.compute_point_coefficients(&reference, &current, &mut c);
        let mut f = vec![[0.0; 3]; x.len()];
        m.add_force_density(&reference, &current, &c, &mut f);
        for i in 0..x.len() {
            let mut sum = 0.0;
            let mut expected = [0.0; 3];
            for b in bonds.range(i) {
                let j = bonds.neighbor[b] as usize;
                let d = [0, 1, 2].map(|k| y[j][k] - y[i][k]);
                let zeta = bonds.reference_length[b];
                let length = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                // ω = 1 and 1 − d = 1: the kernels' factors of 1 are exact, so left out here.
                sum += zeta * (length - zeta) * v[j];
                let t = (c[i].isotropic + c[j].isotropic) * zeta
                    + (c[i].deviatoric + c[j].deviatoric) * (length - zeta);
                let scale = t * v[j] / length;
                for k in 0..3 {
                    expected[k] += scale * d[k];
                }
            }
            let m_i = m.weighted_volume()[i];
            if m_i > 0.0 {
                assert_eq!(c[i].dilatation, 3.0 * sum / m_i, "θ of point {i}");
            }
            assert_eq!(f[i], expected, "force of point {i}");
        }
    }

    #[test]
    fn the_shear_correction_gives_the_shear_modulus_and_keeps_the_bulk_response() {
        // 7³ lattice, δ = 2.2, parabolic ω: the centre's family is the lattice cut by the
        // sphere, whose weighted sums differ from the integrals behind α = 15μ/m. Pure shear
        // ε_xy = γ about the centre has θ = 0 (n_x n_y is odd) and the energy (α/2)‖e^d‖²,
        // which is the continuum's μ ε:ε = 2μγ² only with the correction (module docs of
        // `shear_correction`). An isotropic expansion has e^d = 0, so its energy Kθ²/2 does
        // not depend on the correction.
        let n = 7;
        let x = crate::model::test_support::lattice(n);
        let mut points = crate::model::PointCloud::default();
        for p in &x {
            points.push(*p, 1.0, 0);
        }
        let bonds = brute_force_bonds(&x, 2.2);
        let reference = ReferenceView::of(&bonds, &points);
        let center = (n * n + n + 1) * (n / 2);
        let energy = |corrected: bool, y: &[[f64; 3]]| {
            let mut material = LinearPeridynamicSolid::new(
                &crate::material::BlockInput {
                    density: 1.0,
                    horizon: 2.2,
                    influence: InfluenceFunction::ParabolicDecay,
                },
                &crate::material::ElasticConstants {
                    bulk_modulus: 3.0,
                    shear_modulus: 1.3,
                },
            )
            .unwrap()
            .with_shear_correction(corrected);
            crate::material::set_up(&mut material, &reference, (0..x.len() as u32).collect());
            let current = CurrentView {
                position: y,
                bond_damage: None,
                history: &crate::history::NO_HISTORY,
            };
            let mut coefficients = vec![PointCoefficients::default(); x.len()];
            material.compute_point_coefficients(&reference, &current, &mut coefficients);
            let mut w = vec![0.0; x.len()];
            material.stored_energy_density(&reference, &current, &coefficients, &mut w);
            w[center]
        };
        let gamma = 1e-7;
        let c = x[center];
        let shear: Vec<[f64; 3]> = x
            .iter()
            .map(|p| {
                [
                    p[0] + gamma * (p[1] - c[1]),
                    p[1] + gamma * (p[0] - c[0]),
                    p[2],
                ]
            })
            .collect();
        let continuum = 2.0 * 1.3 * gamma * gamma;
        let without = energy(false, &shear) / continuum;
        assert!(
            (without - 1.0).abs() > 1e-3,
            "nothing to correct: {without}"
        );
        let with = energy(true, &shear) / continuum;
        assert!(
            (with - 1.0).abs() < 1e-5,
            "corrected {with}, uncorrected {without}"
        );
        let expansion: Vec<[f64; 3]> = x.iter().map(|p| p.map(|v| v * 1.001)).collect();
        let (plain, corrected) = (energy(false, &expansion), energy(true, &expansion));
        assert!(
            (corrected / plain - 1.0).abs() < 1e-12,
            "{corrected} vs {plain}"
        );
    }

    #[test]
    fn partial_stress_of_an_isotropic_expansion_is_three_k_epsilon_in_the_bulk() {
        // Y = (1 + ε) X: every bond keeps its direction and e = εζ exactly, so θ = 3ε,
        // e^d = 0 and t = (9Kε/m) ω ζ (module docs). Then Σ_j t M ⊗ ξ V_j =
        // (9Kε/m) Σ_j ω ξ⊗ξ V_j, and a family with the lattice's cubic symmetry and equal
        // volumes has Σ_j ω ξ⊗ξ V_j = (m/3) I: the partial stress is 3Kε I to round-off
        // (the classical pressure of the expansion), at every point with a full family.
        let x = crate::model::test_support::lattice(6);
        let mut points = crate::model::PointCloud::default();
        for p in &x {
            points.push(*p, 1.0, 0);
        }
        let bonds = brute_force_bonds(&x, 1.6);
        let reference = ReferenceView::of(&bonds, &points);
        let mut material = small_material(InfluenceFunction::ParabolicDecay);
        crate::material::set_up(&mut material, &reference, (0..x.len() as u32).collect());
        let epsilon = 1e-3;
        let y: Vec<[f64; 3]> = x.iter().map(|p| p.map(|c| c * (1.0 + epsilon))).collect();
        let current = CurrentView {
            position: &y,
            bond_damage: None,
            history: &crate::history::NO_HISTORY,
        };
        let mut stress = vec![[f64::NAN; 9]; x.len()];
        material.partial_stress(&reference, &current, &mut stress);
        let full = (0..x.len()).map(|i| bonds.family_size(i)).max().unwrap();
        let expected = 3.0 * 3.0 * epsilon;
        let mut checked = 0;
        for (i, s) in stress.iter().enumerate() {
            assert!(s.iter().all(|v| v.is_finite()), "point {i}");
            if bonds.family_size(i) < full {
                continue;
            }
            checked += 1;
            for r in 0..3 {
                for c in 0..3 {
                    let value = if r == c { expected } else { 0.0 };
                    assert!((s[3 * r + c] - value).abs() < 1e-13, "point {i}: {s:?}");
                }
            }
        }
        assert!(checked > 0);
    }

    #[test]
    fn a_row_whose_neighbour_lies_beyond_the_gathered_arrays_is_refused() {
        // The bond loops index the per-point arrays without a check per bond; checked_row is
        // what makes that sound, so a neighbour index at or past the bound must stop it.
        // Two points bonded to each other: row 0 is bond 0 (to point 1), row 1 is bond 1.
        let bonds = crate::model::BondList {
            offsets: vec![0, 1, 2],
            neighbor: vec![1, 0],
            reference_length: vec![1.5, 1.5],
        };
        let (neighbors, lengths) = checked_row(&bonds, 0..1, 2);
        assert_eq!((neighbors, lengths), (&[1][..], &[1.5][..]));
        // Arrays of one point: point 0's neighbour 1 is out of them.
        let refused = std::panic::catch_unwind(|| checked_row(&bonds, 0..1, 1).0.len());
        assert!(refused.is_err());
        assert_eq!(checked_row(&bonds, 1..2, 1).0, &[0][..]);
        // An empty row needs no neighbour in range.
        assert!(checked_row(&bonds, 1..1, 0).0.is_empty());
    }
}
