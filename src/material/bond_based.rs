//! Prototype microelastic brittle material (PMB), Peridigm's `Elastic Bond Based`.
//!
//! Micromodulus `c = 18K/(πδ⁴)` in 3D (Silling & Askari 2005), `c = 12K/(π h δ³)` for
//! `Plane Strain`/`Plane Stress` with thickness h = `Height` (reference §1.3). The pair force
//! density is `c·s·(1−d)` along the deformed bond, stretch `s = (|Y| − ζ)/ζ`:
//!
//! `F_i = Σ_j c·s·(1−d)·V_j·M_ij`, `M_ij = (Y_j − Y_i)/|Y_j − Y_i|`.
//!
//! Peridigm visits each directed bond with `t = ½·c·s·(1−d)` from both ends; the gather here
//! sums `t_ij + t_ji = (c_i/2 + c_j/2)·s·(1−d)`, the same total, and stays exact when the two
//! ends belong to blocks with different micromoduli.
//!
//! # Two force loops
//! * A block whose families stay inside it (every single-block model) with symmetric families
//!   evaluates each pair once ([`PairPlan`]: half the square roots and divisions), then lets
//!   every point gather its row.
//! * Otherwise each point gathers its own row (`for_each_chunk`), reading c_j/2 per neighbour.
//!
//! # Why a point's force depends only on its row
//! A distributed run (see [`crate::parallel`]) builds on each rank a local model over its own
//! points and one layer of ghosts, numbered in the global order, and must produce bitwise the
//! forces of the one-rank model on the owned points. Floating-point sums depend on their order,
//! so the force of a point must be a sum whose terms *and* order are fixed by data both models
//! share: the point's row (an owned point's row is its whole family, in the global order) and
//! the states of the two ends of each bond. Both loops are built so:
//! * the gather adds the bonds of the row in row order, in four interleaved partial sums
//!   combined `(0 + 1) + (2 + 3)`; each term reads only the bond and its two ends;
//! * the pair-once plan first stores, for every pair, the scale
//!   `s = c (1−d) (|Y| − ζ)/(ζ|Y|)` computed from the lower end i (the lower point of a pair
//!   is the same in every model, since local numbering follows the global one) with
//!   `d = Y_j − Y_i`, the bond i→j's ζ and damage — nothing else. Then every point gathers its
//!   row as above, term `s V_j (Y_j − Y_i)`. Seen from j the difference `Y_i − Y_j` is exactly
//!   `−(Y_j − Y_i)` (IEEE subtraction is antisymmetric) and q = |d|² is the same number, so
//!   both ends use bitwise the same s and each end's force is a function of its row alone.
//!
//! Neither pass depends on how the points are cut into tasks, on the thread count or on
//! which other points the model holds. The earlier plan added `−f` into F_j while visiting i,
//! in an order set by chunks of the block's points, which differ between the global and a
//! rank's model (about 2e-7 relative on a 2,560-point bar). A ghost's row may lack the bonds
//! to points outside the rank (so its force is wrong and is never used), but every pair the
//! local model holds has both bonds there (rows are cut to local points on both ends), so the
//! plan is built as on one rank.
//!
//! The square roots and divisions are vectorized (built for AVX2 when the CPU has it, with
//! bitwise the same result as the baseline build). On the LAMMPS comparison lattice (30³,
//! m = 3.015) the one-pass pair loop (which scattered −f into F_j) measured 3.4–4.2e8 directed
//! bond evaluations per second on one core of the 2-vCPU EPYC test machine, against 2.4e8 for
//! the earlier one-bond-at-a-time gather (`benches/material_kernels.rs`). The two passes cost
//! about a quarter more per step than that one-pass loop (`peridyn bench`, PMB on one thread:
//! 13.3 against 10.8 ms/step, run back to back): the gather pass reads every bond's scale and
//! neighbour again. Two alternatives measured slower: per-bond weights with the reverse weight
//! scattered into the other row (27 ms/step; the scatter spans a megabyte of rows), and
//! gathering each point inside the pair pass as soon as its pairs are known (17–23 ms/step).
//!
//! # Stored energy
//! The PMB pair potential (energy per V_i·V_j) is `w = ½·c·s²·ζ`, since `∂w/∂|Y| = c·s` is the
//! pair force density above. The body's energy counts each pair once:
//! `E = Σ_{pairs} ½ c s² ζ (1−d) V_i V_j = ½ Σ_i Σ_j ½ c s² ζ (1−d) V_i V_j` (directed sum
//! counts each pair twice). Giving each point half of each of its bonds,
//! `W_i = Σ_j ¼·c·s²·ζ·(1−d)·V_j` makes `Σ_i W_i V_i = E` exactly. (The `(1−d)` factor is
//! exact for 0/1 damage; for fractional damage it is the energy of the softened spring.)

use super::{
    assert_point_set, checked_row, checked_tangent_method, gather_bound, kept_points, positive,
    CurrentView, Damaged, Integrity, Material, MaterialError, MaterialInput, PointCoefficients,
    ReferenceView, Undamaged,
};
use super::{BreakingForcePass, CriticalStretchFastPath, FusedCriticalStretch};
use crate::damage::StretchLimit;
use crate::model::point_chunks::for_each_chunk;
use crate::model::{with_volume_rule, ModelDeclaration, Reach, VolumeRule};
use crate::tangent::{
    assemble, BlockTangent, ForceState, OrdinaryBond, PointIndex, Scalar, TangentError,
    TangentMethod,
};

/// Deck parameters of `Elastic Bond Based`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BondBasedParameters {
    /// `Density` ρ (mass/length³).
    pub density: f64,
    /// Bulk modulus K (pressure), from `Bulk Modulus` or `Young's Modulus` with ν forced to ¼
    /// (3D, plane strain) or ⅓ (plane stress) as Peridigm does.
    pub bulk_modulus: f64,
    /// Horizon δ of the block (length).
    pub horizon: f64,
    /// `Height` h for `Plane Strain`/`Plane Stress` (then c = 12K/(π h δ³)); `None` in 3D.
    pub planar_thickness: Option<f64>,
}

/// The PMB material of one block (see the module docs for the formulas).
#[derive(Debug, Clone)]
pub struct BondBased {
    parameters: BondBasedParameters,
    micromodulus: f64,
    points: Vec<u32>,
    /// Every neighbour of every block point is itself a block point, so every bond's
    /// micromodulus is this block's c (decided in `setup`).
    closed: bool,
    /// Pair-once evaluation plan, when the block is closed, its rows strictly increasing and
    /// every bond has its reverse; the plan then also breaks each pair in both directions
    /// ([`Material::critical_stretch_fast_path`]).
    pairs: Option<PairPlan>,
    /// The pair plan's per-pair scale buffer, kept between calls (a model of 10⁶ bonds needs
    /// 4 MB, which would otherwise be allocated and faulted in at every step).
    pair_scratch: PairScratch,
    /// How the tangent is computed (default analytic).
    tangent: TangentMethod,
    /// The points whose force is computed, when fewer than `points`
    /// ([`Material::restrict_forces`]).
    force_points: Option<Vec<u32>>,
}

impl BondBased {
    /// `Elastic Bond Based`: a bond's force depends on its two ends only; no fields beyond
    /// the reference data, no outputs of its own.
    pub const DECLARATION: ModelDeclaration = ModelDeclaration {
        deck_name: "Elastic Bond Based",
        deck_keys: &[
            "Density",
            "Bulk Modulus",
            "Young's Modulus",
            "Plane Strain",
            "Plane Stress",
            "Height",
            "Tangent",
            "Finite Difference Probe Length",
        ],
        reach: Reach::OneHop,
        fields: &[],
        outputs: &[],
    };

    /// The registry's constructor: ρ, K, δ and the planar height from `input`.
    pub fn build(input: &MaterialInput) -> Result<Box<dyn Material>, MaterialError> {
        Ok(Box::new(Self::new(BondBasedParameters {
            density: input.density,
            bulk_modulus: input.bulk_modulus,
            horizon: input.horizon,
            planar_thickness: input.planar_thickness,
        })?))
    }

    /// Validates the parameters (all positive and finite) and computes the micromodulus.
    pub fn new(parameters: BondBasedParameters) -> Result<Self, MaterialError> {
        positive("Density", parameters.density)?;
        positive("Bulk Modulus", parameters.bulk_modulus)?;
        positive("Horizon", parameters.horizon)?;
        let k = parameters.bulk_modulus;
        let delta = parameters.horizon;
        let micromodulus = match parameters.planar_thickness {
            None => 18.0 * k / (std::f64::consts::PI * delta.powi(4)),
            Some(h) => 12.0 * k / (std::f64::consts::PI * positive("Height", h)? * delta.powi(3)),
        };
        Ok(Self {
            parameters,
            micromodulus,
            points: Vec::new(),
            closed: false,
            pairs: None,
            pair_scratch: PairScratch::default(),
            force_points: None,
            tangent: TangentMethod::Analytic,
        })
    }

    /// Micromodulus c (force/length⁶ in 3D): 18K/(πδ⁴), or 12K/(π h δ³) when planar.
    pub fn micromodulus(&self) -> f64 {
        self.micromodulus
    }

    fn half(&self) -> f64 {
        0.5 * self.micromodulus
    }

    /// The block's points and those whose force is computed.
    fn pass_points(&self) -> PassPoints<'_> {
        PassPoints {
            block: &self.points,
            gather: self.force_points.as_deref(),
        }
    }
}

/// Bonds of one row evaluated together: the loop body works on `[f64; LANES]` arrays so that
/// the compiler turns the square roots, divisions and products into vector instructions
/// (the scalar divide/square-root unit, not memory, limits a one-bond-at-a-time loop). The
/// lanes keep separate partial sums, added `(0 + 1) + (2 + 3)` at the end of the row, so the
/// result does not depend on the vector width the compiler picks.
const LANES: usize = 4;

/// `a_i + a_j` (= c_ij, with a = c/2 published per point) of the bonds of one row.
trait PairStiffness: Copy {
    /// c_ij of the bond to neighbour `j`.
    fn of(self, j: usize) -> f64;
}

/// Every neighbour belongs to this block, so c_ij = c for every bond (no per-neighbour read).
#[derive(Clone, Copy)]
struct Uniform(f64);

impl PairStiffness for Uniform {
    #[inline(always)]
    fn of(self, _j: usize) -> f64 {
        self.0
    }
}

/// Neighbours may belong to other blocks: c_ij = c_i/2 + (published c_j/2).
#[derive(Clone, Copy)]
struct Mixed<'a> {
    own_half: f64,
    coefficients: &'a [PointCoefficients],
}

impl PairStiffness for Mixed<'_> {
    #[inline(always)]
    fn of(self, j: usize) -> f64 {
        self.own_half + self.coefficients[j].isotropic
    }
}

/// What the PMB bond loops read, bundled once per call.
struct Rows<'a> {
    reference: &'a ReferenceView<'a>,
    current: &'a CurrentView<'a>,
    coefficients: &'a [PointCoefficients],
    /// c/2 of this block's points.
    own_half: f64,
}

/// The force-density contribution of one bond: `c_ij (1−d) V_j (|Y| − ζ)/(ζ|Y|)` times
/// `Y_j − Y_i` (the caller multiplies by the components). Coincident deformed points
/// (|Y| = 0) have no direction and contribute nothing (Peridigm would produce NaN); the
/// division is still evaluated so that the lane loop has no branch (its inf/NaN is discarded).
#[inline(always)]
fn bond_scale(pair: f64, zeta: f64, dx: f64, dy: f64, dz: f64) -> f64 {
    let length = (dx * dx + dy * dy + dz * dz).sqrt();
    let scale = pair * (length - zeta) / (zeta * length);
    if length > 0.0 {
        scale
    } else {
        0.0
    }
}

/// [`bond_scale`] from the squared length q = `dx*dx + dy*dy + dz*dz` (the same operations,
/// so the same result).
#[inline(always)]
fn bond_scale_squared(pair: f64, zeta: f64, squared: f64) -> f64 {
    let length = squared.sqrt();
    let scale = pair * (length - zeta) / (zeta * length);
    if length > 0.0 {
        scale
    } else {
        0.0
    }
}

/// The bond-list row of one point.
#[derive(Clone, Copy)]
struct BondRow<'a> {
    /// Global bond index of the row's first bond.
    first_bond: usize,
    /// The neighbours j, in row order.
    neighbors: &'a [u32],
    /// The reference lengths ζ of the row's bonds (length).
    lengths: &'a [f64],
}

/// `F_i = Σ_j c_ij (1−d) w_ij (|Y| − ζ)/(ζ|Y|) (Y_j − Y_i)` over the bond-list `row` of the
/// point at `yi` (w_ij the bond's quadrature volume, V_j under the full-volume rule).
#[inline(always)]
fn row_force<V: VolumeRule, D: Integrity, K: PairStiffness>(
    yi: [f64; 3],
    row: BondRow<'_>,
    y: &[[f64; 3]],
    volume: V,
    damage: D,
    stiffness: K,
) -> [f64; 3] {
    let BondRow {
        first_bond,
        neighbors,
        lengths,
    } = row;
    let mut sum = [[0.0; LANES]; 3];
    let full = neighbors.len() - neighbors.len() % LANES;
    for start in (0..full).step_by(LANES) {
        let mut d = [[0.0; LANES]; 3];
        let mut pair = [0.0; LANES];
        let mut zeta = [0.0; LANES];
        for lane in 0..LANES {
            let n = start + lane;
            let j = neighbors[n] as usize;
            let yj = y[j];
            for k in 0..3 {
                d[k][lane] = yj[k] - yi[k];
            }
            pair[lane] =
                stiffness.of(j) * damage.intact(first_bond + n) * volume.of(first_bond + n, j);
            zeta[lane] = lengths[n];
        }
        for lane in 0..LANES {
            let scale = bond_scale(pair[lane], zeta[lane], d[0][lane], d[1][lane], d[2][lane]);
            for k in 0..3 {
                sum[k][lane] += scale * d[k][lane];
            }
        }
    }
    for n in full..neighbors.len() {
        let lane = n - full;
        let j = neighbors[n] as usize;
        let yj = y[j];
        let d = [yj[0] - yi[0], yj[1] - yi[1], yj[2] - yi[2]];
        let pair = stiffness.of(j) * damage.intact(first_bond + n) * volume.of(first_bond + n, j);
        let scale = bond_scale(pair, lengths[n], d[0], d[1], d[2]);
        for k in 0..3 {
            sum[k][lane] += scale * d[k];
        }
    }
    sum.map(|s| (s[0] + s[1]) + (s[2] + s[3]))
}

/// True when the force loop may use its AVX2 build (x86-64 CPUs that report AVX2; the answer
/// is cached by the standard library). `PERIDYN_NO_WIDE_VECTORS` set in the environment forces
/// the baseline build (for comparisons).
fn wide_vectors_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::is_x86_feature_detected!("avx2")
            && std::env::var_os("PERIDYN_NO_WIDE_VECTORS").is_none()
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

impl Rows<'_> {
    /// Adds the force density of the chunk's points (see [`row_force`]), with w_ij by the
    /// quadrature rule `volume`.
    #[inline(always)]
    fn add_force<V: VolumeRule, D: Integrity, K: PairStiffness>(
        &self,
        chunk: &[u32],
        base: usize,
        out: &mut [[f64; 3]],
        volume: V,
        damage: D,
        stiffness: K,
    ) {
        let bonds = self.reference.bonds;
        let y = self.current.position;
        for &i in chunk {
            let i = i as usize;
            let range = bonds.range(i);
            let row = BondRow {
                first_bond: range.start,
                neighbors: &bonds.neighbor[range.clone()],
                lengths: &bonds.reference_length[range],
            };
            let f = row_force(y[i], row, y, volume, damage, stiffness);
            let out = &mut out[i - base];
            for k in 0..3 {
                out[k] += f[k];
            }
        }
    }

    /// [`Rows::add_force`] compiled for 256-bit vectors when `wide` (checked by
    /// [`wide_vectors_available`]), for the baseline target otherwise. Both give bitwise the same
    /// result: the lanes do the same IEEE operations in the same order, and no multiply-add is
    /// fused (FMA is not enabled).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn add_force_dispatch<V: VolumeRule, D: Integrity, K: PairStiffness>(
        &self,
        chunk: &[u32],
        base: usize,
        out: &mut [[f64; 3]],
        volume: V,
        damage: D,
        stiffness: K,
        wide: bool,
    ) {
        #[cfg(target_arch = "x86_64")]
        if wide {
            // SAFETY: `wide` is true only when the CPU reports AVX2 at run time.
            unsafe { self.add_force_avx2(chunk, base, out, volume, damage, stiffness) };
            return;
        }
        let _ = wide;
        self.add_force(chunk, base, out, volume, damage, stiffness);
    }

    /// [`Rows::add_force`] with AVX2 enabled, so the `LANES` loop becomes 4-wide square roots and
    /// divisions (twice the width of the x86-64 baseline's SSE2).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn add_force_avx2<V: VolumeRule, D: Integrity, K: PairStiffness>(
        &self,
        chunk: &[u32],
        base: usize,
        out: &mut [[f64; 3]],
        volume: V,
        damage: D,
        stiffness: K,
    ) {
        self.add_force(chunk, base, out, volume, damage, stiffness);
    }

    /// `W_i = Σ_j ¼ c_ij s² ζ (1−d) w_ij = Σ_j ¼ (a_i + a_j)(1−d) e²/ζ w_ij`.
    fn energy<D: Integrity>(&self, chunk: &[u32], base: usize, out: &mut [f64], damage: D) {
        let bonds = self.reference.bonds;
        let y = self.current.position;
        for &i in chunk {
            let i = i as usize;
            let yi = y[i];
            let mut w = 0.0;
            for b in bonds.range(i) {
                let j = bonds.neighbor[b] as usize;
                let yj = y[j];
                let (dx, dy, dz) = (yj[0] - yi[0], yj[1] - yi[1], yj[2] - yi[2]);
                let zeta = bonds.reference_length[b];
                let extension = (dx * dx + dy * dy + dz * dz).sqrt() - zeta;
                let c_pair = self.own_half + self.coefficients[j].isotropic;
                w += 0.25 * c_pair * damage.intact(b) * extension * extension / zeta
                    * self.reference.neighbor_volume(b, j);
            }
            out[i - base] = w;
        }
    }
}

/// A reusable buffer behind a lock, so that `&self` force calls can keep it. Cloning a
/// material gives the clone an empty buffer of its own.
#[derive(Default)]
struct PairScratch(std::sync::Mutex<Vec<f64>>);

impl PairScratch {
    /// The kept buffer (empty when another call holds it or a call panicked while holding it).
    fn take(&self) -> Vec<f64> {
        self.0
            .try_lock()
            .map(|mut kept| std::mem::take(&mut *kept))
            .unwrap_or_default()
    }

    /// Keeps `buffer` for the next call.
    fn keep(&self, buffer: Vec<f64>) {
        if let Ok(mut kept) = self.0.try_lock() {
            *kept = buffer;
        }
    }
}

impl Clone for PairScratch {
    fn clone(&self) -> Self {
        Self::default()
    }
}

impl std::fmt::Debug for PairScratch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("PairScratch")
    }
}

/// Points per task of the pair pass: fixes only how the work is shared among threads, never a
/// result (every pair's scale is written by exactly one task, into its own slot).
const PAIR_CHUNK: usize = 256;

/// Pair-once ("half list") evaluation of a closed block with symmetric families, in two
/// passes that make every point's force a function of its own row (see the module docs):
///
/// 1. *pair pass*: every pair i < j is evaluated once, from the row of its lower point i: the
///    critical-stretch decision (when fused), then the scale
///    `s_ij = c (1−d_ij) (|Y| − ζ)/(ζ|Y|)` into the pair's slot of a per-pair buffer. Each
///    square root and division serves two directed bonds.
/// 2. *gather pass*: every point i sums its row, in row order, `s_ij V_j (Y_j − Y_i)`, reading
///    the slot of the pair each bond belongs to.
///
/// Neither pass writes an entry that another task reads or writes, so no colouring is
/// needed: pass 1 writes the slots of its own points' upper pairs (and the damage of those
/// pairs), pass 2 writes the force of its own points.
#[derive(Debug, Clone)]
struct PairPlan {
    /// For the k-th block point i: the first bond of i's row whose neighbour is > i (rows are
    /// strictly increasing, so the bonds from there to the row end are exactly the upper
    /// pairs).
    upper_start: Vec<usize>,
    /// Pairs are numbered by lower point (in block order), then by row position: the k-th
    /// block point's upper pairs are `pair_start[k]..pair_start[k + 1]`.
    pair_start: Vec<usize>,
    /// Where the k-th block point's row starts in `pair_of_bond` (block-local bond offsets).
    row_start: Vec<usize>,
    /// The pair of every bond of the block's rows (block-local bond numbering): i→j and j→i
    /// name the same pair.
    pair_of_bond: Vec<u32>,
}

impl PairPlan {
    /// The plan for a closed block, or `None` when some row is not strictly increasing or some
    /// bond lacks its reverse (then the block gathers, which needs neither).
    fn new(bonds: &crate::model::BondList, points: &[u32]) -> Option<Self> {
        let mut upper_start = Vec::with_capacity(points.len());
        let mut pair_start = Vec::with_capacity(points.len() + 1);
        let mut pairs = 0;
        pair_start.push(pairs);
        for &i in points {
            let row = bonds.family(i as usize);
            if !row.windows(2).all(|w| w[0] < w[1]) {
                return None;
            }
            let upper = row.partition_point(|&j| j <= i);
            upper_start.push(bonds.offsets[i as usize] + upper);
            pairs += row.len() - upper;
            pair_start.push(pairs);
        }
        if u32::try_from(pairs).is_err() {
            return None;
        }
        let mut position = vec![u32::MAX; bonds.num_points()];
        for (k, &i) in points.iter().enumerate() {
            position[i as usize] = k as u32;
        }
        let row_start = super::local_offsets(bonds, points);
        let mut pair_of_bond = Vec::with_capacity(row_start[points.len()]);
        let mut lower_bonds = 0;
        for (k, &i) in points.iter().enumerate() {
            let row = bonds.range(i as usize);
            // Lower bonds j < i: the pair sits in j's upper part, at i's place in j's row.
            for b in row.start..upper_start[k] {
                let j = bonds.neighbor[b] as usize;
                let kj = position[j];
                if kj == u32::MAX {
                    return None;
                }
                let kj = kj as usize;
                let upper = upper_start[kj] - bonds.offsets[j];
                let at = bonds.family(j).binary_search(&i).ok()?;
                if at < upper {
                    return None;
                }
                pair_of_bond.push((pair_start[kj] + at - upper) as u32);
                lower_bonds += 1;
            }
            pair_of_bond.extend((pair_start[k]..pair_start[k + 1]).map(|p| p as u32));
        }
        // Each lower bond found a distinct upper bond (its reverse); as many lower as upper
        // bonds means every upper bond has its reverse too.
        if lower_bonds != pairs {
            return None;
        }
        Some(Self {
            upper_start,
            pair_start,
            row_start,
            pair_of_bond,
        })
    }

    /// Number of pairs (slots of the scale buffer).
    fn num_pairs(&self) -> usize {
        self.pair_start[self.pair_start.len() - 1]
    }

    /// Adds the force density of every point of the block (of the points to gather alone,
    /// when a subset) to `force_density`, breaking first the bonds `breaker` breaks in every
    /// pair; returns the directed bonds broken. `scale` is scratch space (resized here); the
    /// gather reads w_ij by the quadrature rule `volume` (the pairs' scales do not involve it).
    #[allow(clippy::too_many_arguments)]
    fn run<V: VolumeRule, D: Integrity, B: Breaker>(
        &self,
        points: PassPoints<'_>,
        scale: &mut Vec<f64>,
        force_density: &mut [[f64; 3]],
        rows: PairRows<'_>,
        volume: V,
        damage: D,
        breaker: B,
    ) -> usize {
        use rayon::prelude::*;
        let PassPoints {
            block: points,
            gather,
        } = points;
        assert!(force_density.len() >= rows.y.len());
        scale.resize(self.num_pairs(), 0.0);
        // The per-bond arrays checked once here, each row's upper neighbours once by the pair
        // loop.
        let bound = gather_bound(rows.bonds, rows.y.len(), volume, damage);
        // Pass 1: each task owns the scale slots of its points' upper pairs.
        let mut tasks = Vec::with_capacity(points.len().div_ceil(PAIR_CHUNK));
        let mut rest = &mut scale[..];
        for first in (0..points.len()).step_by(PAIR_CHUNK) {
            let end = (first + PAIR_CHUNK).min(points.len());
            let (mine, tail) = rest.split_at_mut(self.pair_start[end] - self.pair_start[first]);
            tasks.push((first..end, mine));
            rest = tail;
        }
        let broken = tasks
            .into_par_iter()
            .map(|(range, out)| {
                // SAFETY: the breaker's contract is the caller's; each pair (and its two
                // damage entries) belongs to the one task of its lower point.
                unsafe {
                    rows.chunk_dispatch(
                        &points[range.clone()],
                        &self.upper_start[range],
                        out,
                        bound,
                        damage,
                        breaker,
                    )
                }
            })
            .sum::<usize>();
        // Pass 2: each point gathers its row.
        let scale = &scale[..];
        let gathered = |chunk: &[u32], base: usize, out: &mut [[f64; 3]]| {
            let first = points.partition_point(|&p| p < chunk[0]);
            for (n, &i) in chunk.iter().enumerate() {
                // A subset's chunks are not contiguous runs of the block's points.
                let k = match gather {
                    Some(_) => points.partition_point(|&p| p < i),
                    None => first + n,
                };
                let i = i as usize;
                let f = gathered_row(
                    rows.y[i],
                    rows.bonds.offsets[i],
                    rows.bonds.family(i),
                    &self.pair_of_bond[self.row_start[k]..self.row_start[k + 1]],
                    scale,
                    rows.y,
                    volume,
                );
                let out = &mut out[i - base];
                for k in 0..3 {
                    out[k] += f[k];
                }
            }
        };
        let gather_points = gather.unwrap_or(points);
        for_each_chunk(gather_points, force_density, &|i| i as usize, &gathered);
        broken
    }
}

/// `F_i = Σ_n s_n w_ij (Y_j − Y_i)` over the row of point i in row order (`pairs[n]` is the
/// scale slot of its n-th bond, `first_bond` the global index of its first), in `LANES`
/// partial sums added `(0 + 1) + (2 + 3)` as [`row_force`] does (independent sums keep the
/// adds from waiting on each other). The pair's scale s does not involve the volume, so
/// quadrature weights (symmetric or not) enter here alone, exactly as in [`row_force`].
#[inline(always)]
fn gathered_row<V: VolumeRule>(
    yi: [f64; 3],
    first_bond: usize,
    neighbors: &[u32],
    pairs: &[u32],
    scale: &[f64],
    y: &[[f64; 3]],
    volume: V,
) -> [f64; 3] {
    let mut sum = [[0.0; LANES]; 3];
    let term = |n: usize, j: u32, p: u32| {
        let j = j as usize;
        let w = scale[p as usize] * volume.of(first_bond + n, j);
        let yj = y[j];
        [0, 1, 2].map(|k| w * (yj[k] - yi[k]))
    };
    let mut neighbor_blocks = neighbors.chunks_exact(LANES);
    let mut pair_blocks = pairs.chunks_exact(LANES);
    for (block, (js, ps)) in (&mut neighbor_blocks).zip(&mut pair_blocks).enumerate() {
        for lane in 0..LANES {
            let t = term(block * LANES + lane, js[lane], ps[lane]);
            for k in 0..3 {
                sum[k][lane] += t[k];
            }
        }
    }
    let full = neighbors.len() - neighbors.len() % LANES;
    let rest = neighbor_blocks
        .remainder()
        .iter()
        .zip(pair_blocks.remainder());
    for (lane, (&j, &p)) in rest.enumerate() {
        let t = term(full + lane, j, p);
        for k in 0..3 {
            sum[k][lane] += t[k];
        }
    }
    sum.map(|s| (s[0] + s[1]) + (s[2] + s[3]))
}

/// The points a pair pass serves: the block's points, whose upper pairs it computes, and
/// the subset whose force it gathers (all of them when `None`).
#[derive(Clone, Copy)]
struct PassPoints<'a> {
    block: &'a [u32],
    gather: Option<&'a [u32]>,
}

/// What the pair loop reads.
#[derive(Clone, Copy)]
struct PairRows<'a> {
    bonds: &'a crate::model::BondList,
    y: &'a [[f64; 3]],
    /// c (the block is closed, so c_ij = c).
    micromodulus: f64,
    /// Run the AVX2 build of the loop ([`wide_vectors_available`]).
    wide: bool,
}

impl PairRows<'_> {
    /// [`PairRows::chunk`] built for AVX2 when [`PairRows::wide`], else for the baseline
    /// target (the same result bitwise, as for the gather loop).
    ///
    /// # Safety
    /// As [`PairRows::chunk`].
    #[inline(always)]
    unsafe fn chunk_dispatch<D: Integrity, B: Breaker>(
        self,
        points: &[u32],
        upper_start: &[usize],
        out: &mut [f64],
        bound: usize,
        damage: D,
        breaker: B,
    ) -> usize {
        #[cfg(target_arch = "x86_64")]
        if self.wide {
            // SAFETY: AVX2 was detected at run time; the rest as the caller guarantees.
            return unsafe { self.chunk_avx2(points, upper_start, out, bound, damage, breaker) };
        }
        // SAFETY: as the caller guarantees.
        unsafe { self.chunk(points, upper_start, out, bound, damage, breaker) }
    }

    /// [`PairRows::chunk`] with AVX2 enabled.
    ///
    /// # Safety
    /// As [`PairRows::chunk`], and the CPU supports AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn chunk_avx2<D: Integrity, B: Breaker>(
        self,
        points: &[u32],
        upper_start: &[usize],
        out: &mut [f64],
        bound: usize,
        damage: D,
        breaker: B,
    ) -> usize {
        // SAFETY: as the caller guarantees.
        unsafe { self.chunk(points, upper_start, out, bound, damage, breaker) }
    }

    /// For every point i of the chunk and every upper neighbour j > i, in order: first the
    /// critical stretch test of `breaker` (if any), then `s = c (1−d) (|Y| − ζ)/(ζ|Y|)` into
    /// `out` (the chunk's pair slots, consecutive). The inputs are those of the pair alone
    /// (Y_i, Y_j, ζ and d of the bond i→j), so s does not depend on which points share the
    /// chunk. Returns the directed bonds broken. Each row's upper neighbours are checked once
    /// against `bound` ([`checked_row`]), so that its bonds read Y_j and 1 − d without a check
    /// each.
    ///
    /// # Safety
    /// The contract of `breaker` ([`Breaker`]) must hold; `bound` is from [`gather_bound`]
    /// over `self.y.len()` (or less) and `damage`.
    #[inline(always)]
    unsafe fn chunk<D: Integrity, B: Breaker>(
        self,
        points: &[u32],
        upper_start: &[usize],
        out: &mut [f64],
        bound: usize,
        damage: D,
        breaker: B,
    ) -> usize {
        let bonds = self.bonds;
        let y = self.y;
        // Per block of a row's upper bonds: gather the squared lengths (scalar); if bonds may
        // break, filter them (vectorized) and give the few the filter cannot clear the exact
        // test; then compute every bond's scale in a loop over plain arrays, which the
        // compiler vectorizes (the square roots and divisions dominate).
        let mut squared = [0.0; PAIR_BLOCK];
        let mut pair = [0.0; PAIR_BLOCK];
        let mut suspect = [false; PAIR_BLOCK];
        let mut broken = 0;
        let mut slot = 0;
        for (&i, &first) in points.iter().zip(upper_start) {
            let i = i as usize;
            let end = bonds.offsets[i + 1];
            let yi = y[i];
            let (row_neighbors, row_lengths) = checked_row(bonds, first..end, bound);
            for block_start in (first..end).step_by(PAIR_BLOCK) {
                let block_end = (block_start + PAIR_BLOCK).min(end);
                let count = block_end - block_start;
                let neighbors = &row_neighbors[block_start - first..block_end - first];
                let lengths = &row_lengths[block_start - first..block_end - first];
                // q = dx*dx + dy*dy + dz*dz with d = Y_j − Y_i: the very number the damage
                // models test and whose square root the force uses.
                for (n, &j) in neighbors.iter().enumerate() {
                    // SAFETY: j < bound <= y.len() (`checked_row`, the caller's `bound`).
                    let yj = unsafe { *y.get_unchecked(j as usize) };
                    let d = [yj[0] - yi[0], yj[1] - yi[1], yj[2] - yi[2]];
                    squared[n] = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
                }
                if let Some(limit) = breaker.limit() {
                    let mut any = false;
                    for n in 0..count {
                        suspect[n] = !limit.certainly_intact(squared[n], lengths[n]);
                        any |= suspect[n];
                    }
                    if any {
                        for n in (0..count).filter(|&n| suspect[n]) {
                            let b = block_start + n;
                            // SAFETY: b is an upper pair of a point of this chunk (the
                            // breaker's contract).
                            if unsafe { breaker.damage(b) } < 1.0
                                && limit.exceeded(squared[n], lengths[n])
                            {
                                // SAFETY: as above.
                                broken += unsafe {
                                    breaker.break_pair(bonds, i, neighbors[n] as usize, b)
                                };
                            }
                        }
                    }
                }
                for (n, pair) in pair[..count].iter_mut().enumerate() {
                    // SAFETY: the bond is in the row, below `bonds.neighbor.len()`, which
                    // `damage` covers (the caller's `bound` is from `gather_bound`).
                    *pair = self.micromodulus * unsafe { damage.intact_unchecked(block_start + n) };
                }
                let out = &mut out[slot..slot + count];
                for n in 0..count {
                    out[n] = bond_scale_squared(pair[n], lengths[n], squared[n]);
                }
                slot += count;
            }
        }
        debug_assert_eq!(slot, out.len());
        broken
    }
}

/// The bond breaking a pair loop does before its forces (see [`PairRows::chunk`]).
///
/// # Contract of an implementation that breaks bonds
/// `damage` and `break_pair` access the bond-damage array of the loop's bond list through a
/// pointer; the pair loop only calls them for upper bonds i→j (i < j) of the points of the
/// running chunk, whose entries (and those of their reverse bonds j→i) no other task reads or
/// writes meanwhile; the damage reads of the force loop go through the same pointer.
trait Breaker: Copy + Send + Sync {
    /// The critical stretch to test, `None` when the loop breaks nothing.
    fn limit(self) -> Option<StretchLimit>;

    /// d of bond `b`.
    ///
    /// # Safety
    /// See the trait.
    unsafe fn damage(self, b: usize) -> f32;

    /// Breaks the pair (i, j) through bond `b` (i→j): d = 1 in both directions. Returns the
    /// directed bonds that changed.
    ///
    /// # Safety
    /// See the trait.
    unsafe fn break_pair(
        self,
        bonds: &crate::model::BondList,
        i: usize,
        j: usize,
        b: usize,
    ) -> usize;
}

/// The force loop alone (damage already up to date, or no damage).
#[derive(Clone, Copy)]
struct NoBreaking;

impl Breaker for NoBreaking {
    #[inline(always)]
    fn limit(self) -> Option<StretchLimit> {
        None
    }

    unsafe fn damage(self, _b: usize) -> f32 {
        unreachable!("NoBreaking has no limit")
    }

    unsafe fn break_pair(
        self,
        _bonds: &crate::model::BondList,
        _i: usize,
        _j: usize,
        _b: usize,
    ) -> usize {
        unreachable!("NoBreaking has no limit")
    }
}

impl Breaker for FusedCriticalStretch {
    #[inline(always)]
    fn limit(self) -> Option<StretchLimit> {
        Some(self.limit)
    }

    #[inline(always)]
    unsafe fn damage(self, b: usize) -> f32 {
        // SAFETY: as the caller guarantees.
        unsafe { self.read(b) }
    }

    #[inline(never)]
    unsafe fn break_pair(
        self,
        bonds: &crate::model::BondList,
        i: usize,
        j: usize,
        b: usize,
    ) -> usize {
        let back = bonds.offsets[j]
            + bonds
                .family(j)
                .binary_search(&(i as u32))
                .expect("fused blocks have symmetric families (checked in setup)");
        // SAFETY: both entries belong to the running chunk (the caller's contract).
        unsafe {
            self.break_bond(b);
            1 + usize::from(self.break_bond(back))
        }
    }
}

/// The PMB force state of one point for the tangent: `T_n = a_i (1−d) (|Y| − ζ)/ζ · M` with
/// a_i = c/2 (this point's half of the pair stiffness; the neighbour's force state adds its
/// own half, as in the gather `c_ij = a_i + a_j`).
struct PmbForceState<'a, D> {
    bonds: &'a crate::model::BondList,
    half: f64,
    damage: D,
}

impl<D: Integrity> ForceState for PmbForceState<'_, D> {
    const BOND_LOCAL: bool = true;
    const ANALYTIC: bool = true;

    fn force_state<T: Scalar>(
        &self,
        point: PointIndex,
        y: &[[T; 3]],
        only: Option<usize>,
        t: &mut [[T; 3]],
    ) {
        let range = self.bonds.range(point.global);
        let selected = match only {
            Some(n) => n..n + 1,
            None => 0..range.len(),
        };
        for n in selected {
            let b = range.start + n;
            let zeta = self.bonds.reference_length[b];
            let d = [0, 1, 2].map(|k| y[n + 1][k] - y[0][k]);
            let squared = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            // Coincident points carry no force (as in the force kernel).
            t[n] = if squared.re() > 0.0 {
                let length = squared.sqrt();
                let scale = (length - zeta) * (self.half * self.damage.intact(b) / zeta) / length;
                d.map(|c| c * scale)
            } else {
                [T::from(0.0); 3]
            };
        }
    }

    /// `∂T_n/∂Y_j = a (1−d) [M⊗M/ζ + (|Y| − ζ)/(ζ|Y|) (I − M⊗M)] = −∂T_n/∂Y_i`: the bond's
    /// axial stiffness along M and the pre-stress term across it; no θ.
    fn ordinary_derivatives(&self, point: PointIndex, y: &[[f64; 3]], out: &mut [OrdinaryBond]) {
        let range = self.bonds.range(point.global);
        for ((n, b), bond) in range.enumerate().zip(out.iter_mut()) {
            let zeta = self.bonds.reference_length[b];
            let d = [0, 1, 2].map(|k| y[n + 1][k] - y[0][k]);
            let length = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            *bond = if length > 0.0 {
                let a = self.half * self.damage.intact(b);
                OrdinaryBond {
                    direction: d.map(|c| c / length),
                    axial: a / zeta,
                    lateral: a * (length - zeta) / (zeta * length),
                    coupling: 0.0,
                    weight: 0.0,
                }
            } else {
                OrdinaryBond::default()
            };
        }
    }
}

/// Upper bonds of a row handled per block of the pair loop (an interior row at m = 3 has 61).
const PAIR_BLOCK: usize = 64;

impl Material for BondBased {
    fn declaration(&self) -> &'static ModelDeclaration {
        &Self::DECLARATION
    }

    fn density(&self) -> f64 {
        self.parameters.density
    }

    fn bulk_modulus(&self) -> f64 {
        self.parameters.bulk_modulus
    }

    fn horizon(&self) -> f64 {
        self.parameters.horizon
    }

    fn setup(
        &mut self,
        reference: &ReferenceView<'_>,
        points: Vec<u32>,
    ) -> Result<(), MaterialError> {
        assert_point_set(&points, reference.bonds.num_points());
        let bonds = reference.bonds;
        let mut member = vec![false; bonds.num_points()];
        for &i in &points {
            member[i as usize] = true;
        }
        self.closed = points
            .iter()
            .all(|&i| bonds.family(i as usize).iter().all(|&j| member[j as usize]));
        self.pairs = if self.closed {
            PairPlan::new(bonds, &points)
        } else {
            None
        };
        self.points = points;
        self.force_points = None;
        Ok(())
    }

    fn points(&self) -> &[u32] {
        &self.points
    }

    fn restrict_forces(&mut self, keep: &dyn Fn(u32) -> bool) {
        self.force_points = kept_points(&self.points, keep);
    }

    fn compute_point_coefficients(
        &self,
        _reference: &ReferenceView<'_>,
        _current: &CurrentView<'_>,
        coefficients: &mut [PointCoefficients],
    ) {
        let published = PointCoefficients {
            dilatation: 0.0,
            isotropic: self.half(),
            deviatoric: 0.0,
        };
        for &i in &self.points {
            coefficients[i as usize] = published;
        }
    }

    fn add_force_density(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        coefficients: &[PointCoefficients],
        force_density: &mut [[f64; 3]],
    ) {
        let rows = Rows {
            reference,
            current,
            coefficients,
            own_half: self.half(),
        };
        let uniform = Uniform(2.0 * self.half());
        let mixed = Mixed {
            own_half: self.half(),
            coefficients,
        };
        let wide = wide_vectors_available();
        if let Some(plan) = &self.pairs {
            let pairs = PairRows {
                bonds: reference.bonds,
                y: current.position,
                micromodulus: uniform.0,
                wide,
            };
            let scale = &mut self.pair_scratch.take();
            with_volume_rule!(reference, |v| match current.bond_damage {
                None => plan.run(
                    self.pass_points(),
                    scale,
                    force_density,
                    pairs,
                    v,
                    Undamaged,
                    NoBreaking,
                ),
                Some(d) => plan.run(
                    self.pass_points(),
                    scale,
                    force_density,
                    pairs,
                    v,
                    Damaged(d),
                    NoBreaking,
                ),
            });
            self.pair_scratch.keep(std::mem::take(scale));
            return;
        }
        let closed = self.closed;
        let force_points = self.force_points.as_deref().unwrap_or(&self.points);
        with_volume_rule!(reference, |v| {
            let run = |chunk: &[u32], base: usize, out: &mut [[f64; 3]]| match (
                current.bond_damage,
                closed,
            ) {
                (None, true) => {
                    rows.add_force_dispatch(chunk, base, out, v, Undamaged, uniform, wide)
                }
                (None, false) => {
                    rows.add_force_dispatch(chunk, base, out, v, Undamaged, mixed, wide)
                }
                (Some(d), true) => {
                    rows.add_force_dispatch(chunk, base, out, v, Damaged(d), uniform, wide)
                }
                (Some(d), false) => {
                    rows.add_force_dispatch(chunk, base, out, v, Damaged(d), mixed, wide)
                }
            };
            for_each_chunk(force_points, force_density, &|i| i as usize, &run)
        })
    }

    /// The pair plan breaks each pair in both directions in the force pass (only when the
    /// plan exists: the block is closed with symmetric families).
    fn critical_stretch_fast_path(&self) -> Option<CriticalStretchFastPath<'_>> {
        self.pairs
            .is_some()
            .then_some(CriticalStretchFastPath::Force(self))
    }

    fn tangent_method(&self) -> TangentMethod {
        self.tangent
    }

    fn set_tangent_method(&mut self, method: TangentMethod) -> Result<(), TangentError> {
        self.tangent = checked_tangent_method(method)?;
        Ok(())
    }

    fn add_tangent(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        method: TangentMethod,
        tangent: &mut BlockTangent,
    ) -> Result<(), TangentError> {
        let model = self.model_name();
        let (bonds, half) = (reference.bonds, self.half());
        match current.bond_damage {
            None => {
                let kernel = PmbForceState {
                    bonds,
                    half,
                    damage: Undamaged,
                };
                assemble(
                    &kernel,
                    model,
                    &self.points,
                    reference,
                    current,
                    method,
                    tangent,
                )
            }
            Some(d) => {
                let kernel = PmbForceState {
                    bonds,
                    half,
                    damage: Damaged(d),
                };
                assemble(
                    &kernel,
                    model,
                    &self.points,
                    reference,
                    current,
                    method,
                    tangent,
                )
            }
        }
    }

    fn stored_energy_density(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        coefficients: &[PointCoefficients],
        energy_density: &mut [f64],
    ) {
        let rows = Rows {
            reference,
            current,
            coefficients,
            own_half: self.half(),
        };
        let run = |chunk: &[u32], base: usize, out: &mut [f64]| match current.bond_damage {
            None => rows.energy(chunk, base, out, Undamaged),
            Some(d) => rows.energy(chunk, base, out, Damaged(d)),
        };
        for_each_chunk(&self.points, energy_density, &|i| i as usize, &run);
    }
}

impl BreakingForcePass for BondBased {
    /// The pair-once loop tests each pair just before its force: same q, same exact test
    /// (behind the filter of `StretchLimit::breaks`), both directions written at once, as the
    /// pair-once `Critical Stretch` update; the force then reads the updated damage, so forces
    /// and damage are bitwise those of the separate update followed by the force.
    fn add_force_density_breaking_bonds(
        &self,
        reference: &ReferenceView<'_>,
        position: &[[f64; 3]],
        critical_stretch: f64,
        bond_damage: &mut [f32],
        _coefficients: &[PointCoefficients],
        force_density: &mut [[f64; 3]],
    ) -> usize {
        let plan = self
            .pairs
            .as_ref()
            .expect("the fast path is offered only with a pair plan");
        assert_eq!(bond_damage.len(), reference.bonds.num_bonds());
        let pairs = PairRows {
            bonds: reference.bonds,
            y: position,
            // As `add_force_density` (c/2 doubled: exactly c).
            micromodulus: 2.0 * self.half(),
            wide: wide_vectors_available(),
        };
        let fused = FusedCriticalStretch {
            limit: StretchLimit::new(critical_stretch),
            damage: bond_damage.as_mut_ptr(),
        };
        // The `Breaker` contract holds: `bond_damage` is borrowed mutably for this call and
        // covers every bond; the chunk of point i reads and writes only the entries of i's
        // upper bonds and of their reverses, which belong to no other chunk (each pair has
        // one lower point, and the block is closed with symmetric families: the plan exists).
        let scale = &mut self.pair_scratch.take();
        let broken = with_volume_rule!(reference, |v| plan.run(
            self.pass_points(),
            scale,
            force_density,
            pairs,
            v,
            fused,
            fused,
        ));
        self.pair_scratch.keep(std::mem::take(scale));
        broken
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::damage::{CriticalStretch, DamageModel};
    use crate::model::test_support::{brute_force_bonds, random_cloud, Rng};
    use crate::model::BondList;

    fn material() -> BondBased {
        BondBased::new(BondBasedParameters {
            density: 2.0,
            bulk_modulus: 3.0,
            horizon: 1.6,
            planar_thickness: None,
        })
        .unwrap()
    }

    /// Reference positions, volumes, bonds, current positions, bond damage.
    type Body = (Vec<[f64; 3]>, Vec<f64>, BondList, Vec<[f64; 3]>, Vec<f32>);

    #[test]
    fn the_pair_once_force_matches_the_generic_force_state_sum() {
        // The pair-once kernel is a fast path of F_i = Σ_j (T_i⟨ξ_ij⟩ − T_j⟨ξ_ji⟩) V_j
        // (`material::generic_force`): same force to round-off, with damage.
        let (x, v, bonds, y, damage) = body();
        let reference = ReferenceView {
            bonds: &bonds,
            position: &x,
            volume: &v,
            bond_volume: None,
        };
        let all: Vec<u32> = (0..x.len() as u32).collect();
        let mut m = material();
        m.setup(&reference, all.clone()).unwrap();
        let current = CurrentView {
            position: &y,
            bond_damage: Some(&damage),
            history: &crate::history::NO_HISTORY,
        };
        let coefficients = vec![PointCoefficients::default(); x.len()];
        let mut fast = vec![[0.0; 3]; x.len()];
        m.add_force_density(&reference, &current, &coefficients, &mut fast);
        let kernel = PmbForceState {
            bonds: &bonds,
            half: m.half(),
            damage: Damaged(&damage),
        };
        let mut generic = vec![[0.0; 3]; x.len()];
        crate::material::generic_force::add_force_density_from_states(
            &kernel,
            &all,
            &reference,
            &current,
            &mut generic,
        );
        let largest = fast.iter().flatten().fold(0.0f64, |a, f| a.max(f.abs()));
        assert!(largest > 0.0);
        for (a, b) in fast.iter().flatten().zip(generic.iter().flatten()) {
            assert!((a - b).abs() <= 1e-12 * largest, "{a} vs {b}");
        }
    }

    /// 600 random points (more than two pair-plan chunks), random volumes, displaced by up
    /// to 0.1, with bonds above stretch 0.02 broken.
    fn body() -> Body {
        let mut rng = Rng::new(11);
        let (x, v) = random_cloud(&mut rng, 600, 7.0);
        displaced(rng, x, v)
    }

    /// 1,500 random points in a 30 × 3 × 3 bar numbered along x, like a run's space-filling
    /// order: a chunk of 256 points then spans about 5 units of x (three horizons), so the
    /// earlier one-pass plan gave neighbouring chunks different colours and summed each
    /// point's force in an order set by where the chunk boundaries fall. Displaced and
    /// damaged as [`body`].
    fn bar() -> Body {
        let mut rng = Rng::new(12);
        let (cube, v) = random_cloud(&mut rng, 1500, 1.0);
        let mut x: Vec<[f64; 3]> = cube
            .iter()
            .map(|p| [30.0 * p[0], 3.0 * p[1], 3.0 * p[2]])
            .collect();
        x.sort_by(|a, b| a[0].total_cmp(&b[0]));
        displaced(rng, x, v)
    }

    fn displaced(mut rng: Rng, x: Vec<[f64; 3]>, v: Vec<f64>) -> Body {
        let bonds = brute_force_bonds(&x, 1.6);
        let y: Vec<[f64; 3]> = x
            .iter()
            .map(|p| p.map(|c| c + 0.1 * (2.0 * rng.uniform() - 1.0)))
            .collect();
        let reference = ReferenceView {
            bonds: &bonds,
            position: &x,
            volume: &v,
            bond_volume: None,
        };
        let mut damage = vec![0.0f32; bonds.num_bonds()];
        let all: Vec<u32> = (0..x.len() as u32).collect();
        CriticalStretch::new(0.02)
            .unwrap()
            .update(&reference, &y, &all, &mut damage);
        assert!(damage.iter().any(|&d| d > 0.0) && damage.contains(&0.0));
        (x, v, bonds, y, damage)
    }

    fn force(
        blocks: &[&BondBased],
        reference: &ReferenceView<'_>,
        y: &[[f64; 3]],
        damage: &[f32],
    ) -> Vec<[f64; 3]> {
        let n = y.len();
        let current = CurrentView {
            position: y,
            bond_damage: Some(damage),
            history: &crate::history::NO_HISTORY,
        };
        let mut coefficients = vec![PointCoefficients::default(); n];
        for m in blocks {
            m.compute_point_coefficients(reference, &current, &mut coefficients);
        }
        let mut f = vec![[0.0; 3]; n];
        for m in blocks {
            m.add_force_density(reference, &current, &coefficients, &mut f);
        }
        f
    }

    #[test]
    fn pair_once_plan_matches_the_gather_loop() {
        // One closed block takes the pair-once path; the same constants split over two blocks
        // take the gather path (c_ij = c/2 + c/2 = c exactly). The two sum the same bond forces
        // in different orders, so they agree to round-off: relative 1e-12 of the largest
        // force (each entry sums ~60 terms of that size with 1e-16 rounding each).
        let (x, v, bonds, y, damage) = body();
        let reference = ReferenceView {
            bonds: &bonds,
            position: &x,
            volume: &v,
            bond_volume: None,
        };
        let mut whole = material();
        whole
            .setup(&reference, (0..x.len() as u32).collect())
            .unwrap();
        assert!(whole.pairs.is_some());
        let (left, right): (Vec<u32>, Vec<u32>) =
            (0..x.len() as u32).partition(|&i| x[i as usize][0] < 3.5);
        let mut a = material();
        let mut b = material();
        a.setup(&reference, left).unwrap();
        b.setup(&reference, right).unwrap();
        assert!(a.pairs.is_none() && b.pairs.is_none());
        let pair_once = force(&[&whole], &reference, &y, &damage);
        let gathered = force(&[&a, &b], &reference, &y, &damage);
        let largest = gathered
            .iter()
            .flatten()
            .fold(0.0f64, |m, f| m.max(f.abs()));
        assert!(largest > 0.0);
        for (p, g) in pair_once.iter().zip(&gathered) {
            for k in 0..3 {
                assert!((p[k] - g[k]).abs() <= 1e-12 * largest, "{p:?} vs {g:?}");
            }
        }
    }

    #[test]
    fn pair_once_result_is_the_same_for_every_thread_count() {
        // Every point gathers its own row in row order, whatever the threads.
        let (x, v, bonds, y, damage) = body();
        let reference = ReferenceView {
            bonds: &bonds,
            position: &x,
            volume: &v,
            bond_volume: None,
        };
        let mut m = material();
        m.setup(&reference, (0..x.len() as u32).collect()).unwrap();
        let run = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| force(&[&m], &reference, &y, &damage))
        };
        let one = run(1);
        assert_eq!(one, run(2));
        assert_eq!(one, run(3));
    }

    #[test]
    fn every_bond_and_its_reverse_name_the_same_pair() {
        let (x, _, bonds, _, _) = body();
        let points: Vec<u32> = (0..x.len() as u32).collect();
        let plan = PairPlan::new(&bonds, &points).unwrap();
        let mut bonds_of_pair = vec![Vec::new(); plan.num_pairs()];
        for i in 0..x.len() {
            for (n, b) in bonds.range(i).enumerate() {
                let p = plan.pair_of_bond[plan.row_start[i] + n] as usize;
                let j = bonds.neighbor[b] as usize;
                bonds_of_pair[p].push((i.min(j), i.max(j)));
                // A point's own pairs are its upper bonds, numbered in row order.
                if j > i {
                    assert_eq!(p, plan.pair_start[i] + (b - plan.upper_start[i]));
                }
            }
        }
        // Every pair is named by exactly its two directed bonds.
        for named in &bonds_of_pair {
            assert_eq!(named.len(), 2);
            assert_eq!(named[0], named[1]);
        }
        assert_eq!(2 * plan.num_pairs(), bonds.num_bonds());
    }

    /// The force of every point as the module docs define it, written plainly: row order, four
    /// partial sums by position, each pair's scale from its lower end with the lower-to-upper
    /// bond's ζ and damage.
    fn row_ordered_reference(
        bonds: &BondList,
        v: &[f64],
        y: &[[f64; 3]],
        damage: &[f32],
        c: f64,
    ) -> Vec<[f64; 3]> {
        (0..y.len())
            .map(|i| {
                let mut sum = [[0.0f64; 4]; 3];
                for (n, b) in bonds.range(i).enumerate() {
                    let j = bonds.neighbor[b] as usize;
                    let (lower, upper) = (i.min(j), i.max(j));
                    let upper_bond = bonds.offsets[lower]
                        + bonds.family(lower).binary_search(&(upper as u32)).unwrap();
                    let zeta = bonds.reference_length[upper_bond];
                    let d = [0, 1, 2].map(|k| y[upper][k] - y[lower][k]);
                    let length = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                    let intact = 1.0 - f64::from(damage[upper_bond]);
                    let s = if length > 0.0 {
                        c * intact * (length - zeta) / (zeta * length)
                    } else {
                        0.0
                    };
                    for k in 0..3 {
                        sum[k][n % 4] += s * v[j] * (y[j][k] - y[i][k]);
                    }
                }
                sum.map(|s| (s[0] + s[1]) + (s[2] + s[3]))
            })
            .collect()
    }

    #[test]
    fn pair_once_force_is_the_row_ordered_sum_bitwise() {
        let (x, v, bonds, y, damage) = body();
        let reference = ReferenceView {
            bonds: &bonds,
            position: &x,
            volume: &v,
            bond_volume: None,
        };
        let mut m = material();
        m.setup(&reference, (0..x.len() as u32).collect()).unwrap();
        assert!(m.pairs.is_some());
        let expected = row_ordered_reference(&bonds, &v, &y, &damage, m.micromodulus());
        assert_eq!(force(&[&m], &reference, &y, &damage), expected);
    }

    /// A rank's view of the bar: the points with 8 ≤ x < 20 ("owned") and their neighbours
    /// ("ghosts"), numbered in increasing global order, every row cut to local points (a
    /// ghost's row loses its bonds to points outside), as `parallel::Subdomain` builds it.
    /// Returns the local points (global indices) and the local bond list; `bond_of[l]` is the
    /// global bond of local bond l.
    fn sub_selection(
        x: &[[f64; 3]],
        bonds: &BondList,
    ) -> (Vec<u32>, Vec<bool>, BondList, Vec<usize>) {
        let owned: Vec<bool> = x.iter().map(|p| (8.0..20.0).contains(&p[0])).collect();
        let mut local = vec![false; x.len()];
        for i in (0..x.len()).filter(|&i| owned[i]) {
            local[i] = true;
            for &j in bonds.family(i) {
                local[j as usize] = true;
            }
        }
        let points: Vec<u32> = (0..x.len() as u32).filter(|&i| local[i as usize]).collect();
        let mut local_of = vec![u32::MAX; x.len()];
        for (l, &g) in points.iter().enumerate() {
            local_of[g as usize] = l as u32;
        }
        let mut sub = BondList {
            offsets: vec![0],
            ..Default::default()
        };
        let mut bond_of = Vec::new();
        for &g in &points {
            for b in bonds.range(g as usize) {
                let l = local_of[bonds.neighbor[b] as usize];
                if l != u32::MAX {
                    sub.neighbor.push(l);
                    sub.reference_length.push(bonds.reference_length[b]);
                    bond_of.push(b);
                }
            }
            sub.offsets.push(sub.neighbor.len());
        }
        let owned_local = points.iter().map(|&g| owned[g as usize]).collect();
        (points, owned_local, sub, bond_of)
    }

    #[test]
    fn owned_forces_and_damage_are_those_of_the_whole_body_bitwise() {
        // The sub-selection holds the owned rows whole and the ghost rows cut, and its plan
        // cuts the points into other chunks than the whole body's (it has fewer points, and
        // they are renumbered). The owned forces and damage must nevertheless be the same
        // bits, with damage broken by the fused loop over two loadings (half, then the full
        // random displacement) as in `fused_breaking_matches_the_separate_update_bitwise`.
        let (x, v, bonds, y, _) = bar();
        let (points, owned, sub_bonds, bond_of) = sub_selection(&x, &bonds);
        let pick = |values: &[[f64; 3]]| -> Vec<[f64; 3]> {
            points.iter().map(|&g| values[g as usize]).collect()
        };
        let sub_x = pick(&x);
        let sub_v: Vec<f64> = points.iter().map(|&g| v[g as usize]).collect();
        // More than one pair-pass task locally, and fewer points than the whole body.
        assert!(points.len() > PAIR_CHUNK && points.len() < x.len());
        assert!(owned.contains(&true) && owned.contains(&false));
        let whole_reference = ReferenceView {
            bonds: &bonds,
            position: &x,
            volume: &v,
            bond_volume: None,
        };
        let sub_reference = ReferenceView {
            bonds: &sub_bonds,
            position: &sub_x,
            volume: &sub_v,
            bond_volume: None,
        };
        let mut whole = material();
        whole
            .setup(&whole_reference, (0..x.len() as u32).collect())
            .unwrap();
        let mut sub = material();
        sub.setup(&sub_reference, (0..points.len() as u32).collect())
            .unwrap();
        assert!(
            whole.critical_stretch_fast_path().is_some()
                && sub.critical_stretch_fast_path().is_some()
        );
        // The same rank computing the forces of some of its owned points only (a distributed
        // run keeps the owned ones; every other one here, so that the kept points are not a
        // contiguous run of the block): every pair is still decided, the others' forces are
        // left alone.
        let kept = |l: usize| owned[l] && l % 2 == 0;
        let mut owned_only = sub.clone();
        owned_only.restrict_forces(&|l| kept(l as usize));
        let mut owned_only_damage = vec![0.0f32; sub_bonds.num_bonds()];
        let coefficients = vec![PointCoefficients::default(); x.len()];
        let mut whole_damage = vec![0.0f32; bonds.num_bonds()];
        let mut sub_damage = vec![0.0f32; sub_bonds.num_bonds()];
        let mut broken = 0;
        for fraction in [0.5, 1.0] {
            let at: Vec<[f64; 3]> = x
                .iter()
                .zip(&y)
                .map(|(p, q)| [0, 1, 2].map(|k| p[k] + fraction * (q[k] - p[k])))
                .collect();
            let sub_at = pick(&at);
            let mut whole_force = vec![[0.0; 3]; x.len()];
            broken += whole.add_force_density_breaking_bonds(
                &whole_reference,
                &at,
                0.02,
                &mut whole_damage,
                &coefficients,
                &mut whole_force,
            );
            let mut sub_force = vec![[0.0; 3]; points.len()];
            sub.add_force_density_breaking_bonds(
                &sub_reference,
                &sub_at,
                0.02,
                &mut sub_damage,
                &coefficients[..points.len()],
                &mut sub_force,
            );
            for (l, &g) in points.iter().enumerate() {
                if owned[l] {
                    assert_eq!(sub_force[l], whole_force[g as usize], "point {g}");
                }
            }
            // Every local bond (ghost rows too) is decided as in the whole body.
            for (l, &b) in bond_of.iter().enumerate() {
                assert_eq!(sub_damage[l], whole_damage[b]);
            }
            // The separate force call (damage already updated) gives the same bits again.
            let again = force(&[&sub], &sub_reference, &sub_at, &sub_damage);
            assert_eq!(again, sub_force);
            let untouched = [7.0, 8.0, 9.0];
            let mut owned_only_force: Vec<[f64; 3]> = (0..points.len())
                .map(|l| if kept(l) { [0.0; 3] } else { untouched })
                .collect();
            owned_only.add_force_density_breaking_bonds(
                &sub_reference,
                &sub_at,
                0.02,
                &mut owned_only_damage,
                &coefficients[..points.len()],
                &mut owned_only_force,
            );
            assert_eq!(owned_only_damage, sub_damage);
            for l in 0..points.len() {
                let expected = if kept(l) { sub_force[l] } else { untouched };
                assert_eq!(owned_only_force[l], expected, "local point {l}");
            }
        }
        assert!(broken > 0 && broken < bonds.num_bonds(), "{broken}");
    }

    #[test]
    fn rows_without_their_reverse_fall_back_to_the_gather_loop() {
        // 0 → 1 and 1 → 0, 2 → 0 without 0 → 2: the pair (0, 2) has one bond only.
        let bonds = BondList {
            offsets: vec![0, 1, 2, 3],
            neighbor: vec![1, 0, 0],
            reference_length: vec![1.0, 1.0, 2.0],
        };
        assert!(PairPlan::new(&bonds, &[0, 1, 2]).is_none());
        // And the other way round: 0 → 2 without 2 → 0.
        let bonds = BondList {
            offsets: vec![0, 2, 3, 3],
            neighbor: vec![1, 2, 0],
            reference_length: vec![1.0, 2.0, 1.0],
        };
        assert!(PairPlan::new(&bonds, &[0, 1, 2]).is_none());
        let symmetric = BondList {
            offsets: vec![0, 2, 3, 4],
            neighbor: vec![1, 2, 0, 0],
            reference_length: vec![1.0, 2.0, 1.0, 2.0],
        };
        assert!(PairPlan::new(&symmetric, &[0, 1, 2]).is_some());
    }

    #[test]
    fn fused_breaking_matches_the_separate_update_bitwise() {
        // Two evaluations, at half and then at the full random displacement, so that the
        // second meets bonds already broken by the first. Fused or separate, the same bonds
        // must break (same count, same damage array) and the forces must be the same bits:
        // the fused loop takes the exact test on the same q and reads the updated damage.
        let (x, v, bonds, y, _) = body();
        let reference = ReferenceView {
            bonds: &bonds,
            position: &x,
            volume: &v,
            bond_volume: None,
        };
        let mut m = material();
        m.setup(&reference, (0..x.len() as u32).collect()).unwrap();
        assert!(m.critical_stretch_fast_path().is_some());
        let all: Vec<u32> = (0..x.len() as u32).collect();
        let model = CriticalStretch::new(0.02).unwrap();
        let mut coefficients = vec![PointCoefficients::default(); x.len()];
        let current = CurrentView {
            position: &x,
            bond_damage: None,
            history: &crate::history::NO_HISTORY,
        };
        m.compute_point_coefficients(&reference, &current, &mut coefficients);
        let mut separate = vec![0.0f32; bonds.num_bonds()];
        let mut fused = vec![0.0f32; bonds.num_bonds()];
        let mut total = 0;
        for fraction in [0.5, 1.0] {
            let at: Vec<[f64; 3]> = x
                .iter()
                .zip(&y)
                .map(|(p, q)| [0, 1, 2].map(|k| p[k] + fraction * (q[k] - p[k])))
                .collect();
            let broken = model.update(&reference, &at, &all, &mut separate);
            let expected = force(&[&m], &reference, &at, &separate);
            let mut f = vec![[0.0; 3]; x.len()];
            let fused_broken = m.add_force_density_breaking_bonds(
                &reference,
                &at,
                0.02,
                &mut fused,
                &coefficients,
                &mut f,
            );
            assert_eq!(fused_broken, broken);
            assert_eq!(fused, separate);
            assert_eq!(f, expected);
            total += broken;
        }
        assert!(total > 0 && total < bonds.num_bonds(), "{total}");
    }

    #[test]
    fn open_blocks_do_not_fuse() {
        // A block with bonds to another block leaves its damage to the damage model (the
        // physics symmetrises interface bonds between the update and the force).
        let (x, v, bonds, _, _) = body();
        let reference = ReferenceView {
            bonds: &bonds,
            position: &x,
            volume: &v,
            bond_volume: None,
        };
        let left: Vec<u32> = (0..x.len() as u32)
            .filter(|&i| x[i as usize][0] < 3.5)
            .collect();
        let mut m = material();
        m.setup(&reference, left).unwrap();
        assert!(m.critical_stretch_fast_path().is_none());
    }

    #[test]
    fn unsorted_rows_fall_back_to_the_gather_loop() {
        let bonds = BondList {
            offsets: vec![0, 2, 3, 4],
            neighbor: vec![2, 1, 0, 0],
            reference_length: vec![2.0, 1.0, 1.0, 2.0],
        };
        assert!(PairPlan::new(&bonds, &[0, 1, 2]).is_none());
    }
}
