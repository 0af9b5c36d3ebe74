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
//! * A block whose families stay inside it (every single-block model) evaluates each pair once
//!   and applies it to both ends ([`PairPlan`]: half the square roots and divisions, scatter
//!   made safe by colouring chunks of the space-filling-curve order).
//! * Otherwise each point gathers its own row (`for_each_chunk`), reading c_j/2 per neighbour.
//!
//! Both vectorize the square roots and divisions (built for AVX2 when the CPU has it, with
//! bitwise the same result as the baseline build). On the LAMMPS comparison lattice (30³,
//! m = 3.015) the pair loop measured 3.4–4.2e8 directed bond evaluations per second on one
//! core of the 2-vCPU EPYC test machine, against 2.4e8 for the earlier one-bond-at-a-time
//! gather (`benches/material_kernels.rs`).
//!
//! # Stored energy
//! The PMB pair potential (energy per V_i·V_j) is `w = ½·c·s²·ζ`, since `∂w/∂|Y| = c·s` is the
//! pair force density above. The body's energy counts each pair once:
//! `E = Σ_{pairs} ½ c s² ζ (1−d) V_i V_j = ½ Σ_i Σ_j ½ c s² ζ (1−d) V_i V_j` (directed sum
//! counts each pair twice). Giving each point half of each of its bonds,
//! `W_i = Σ_j ¼·c·s²·ζ·(1−d)·V_j` makes `Σ_i W_i V_i = E` exactly. (The `(1−d)` factor is
//! exact for 0/1 damage; for fractional damage it is the energy of the softened spring.)

use super::point_chunks::{for_each_chunk, WriteColouring};
use super::FusedCriticalStretch;
use super::{
    assert_point_set, checked_tangent_method, positive, CurrentView, Damaged, Integrity, Material,
    MaterialError, PointCoefficients, ReferenceView, Undamaged,
};
use crate::damage::StretchLimit;
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
    /// Pair-once evaluation plan, when the block is closed and its rows are sorted.
    pairs: Option<PairPlan>,
    /// The pair-once plan exists and every bond of the block has its reverse, so the plan can
    /// break a pair in both directions ([`Material::fuses_critical_stretch`]).
    fuses_breaking: bool,
    /// How the tangent is computed (default analytic).
    tangent: TangentMethod,
}

impl BondBased {
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
            fuses_breaking: false,
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

/// `F_i = Σ_j c_ij (1−d) V_j (|Y| − ζ)/(ζ|Y|) (Y_j − Y_i)` over the row of point `i`, whose
/// bonds start at global bond index `first_bond`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn row_force<D: Integrity, K: PairStiffness>(
    yi: [f64; 3],
    first_bond: usize,
    neighbors: &[u32],
    lengths: &[f64],
    y: &[[f64; 3]],
    volume: &[f64],
    damage: D,
    stiffness: K,
) -> [f64; 3] {
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
            pair[lane] = stiffness.of(j) * damage.intact(first_bond + n) * volume[j];
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
        let pair = stiffness.of(j) * damage.intact(first_bond + n) * volume[j];
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
    /// Adds the force density of the chunk's points (see [`row_force`]).
    #[inline(always)]
    fn add_force<D: Integrity, K: PairStiffness>(
        &self,
        chunk: &[u32],
        base: usize,
        out: &mut [[f64; 3]],
        damage: D,
        stiffness: K,
    ) {
        let bonds = self.reference.bonds;
        let y = self.current.position;
        for &i in chunk {
            let i = i as usize;
            let range = bonds.range(i);
            let f = row_force(
                y[i],
                range.start,
                &bonds.neighbor[range.clone()],
                &bonds.reference_length[range],
                y,
                self.reference.volume,
                damage,
                stiffness,
            );
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
    fn add_force_dispatch<D: Integrity, K: PairStiffness>(
        &self,
        chunk: &[u32],
        base: usize,
        out: &mut [[f64; 3]],
        damage: D,
        stiffness: K,
        wide: bool,
    ) {
        #[cfg(target_arch = "x86_64")]
        if wide {
            // SAFETY: `wide` is true only when the CPU reports AVX2 at run time.
            unsafe { self.add_force_avx2(chunk, base, out, damage, stiffness) };
            return;
        }
        let _ = wide;
        self.add_force(chunk, base, out, damage, stiffness);
    }

    /// [`Rows::add_force`] with AVX2 enabled, so the `LANES` loop becomes 4-wide square roots and
    /// divisions (twice the width of the x86-64 baseline's SSE2).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn add_force_avx2<D: Integrity, K: PairStiffness>(
        &self,
        chunk: &[u32],
        base: usize,
        out: &mut [[f64; 3]],
        damage: D,
        stiffness: K,
    ) {
        self.add_force(chunk, base, out, damage, stiffness);
    }

    /// `W_i = Σ_j ¼ c_ij s² ζ (1−d) V_j = Σ_j ¼ (a_i + a_j)(1−d) e²/ζ V_j`.
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
                    * self.reference.volume[j];
            }
            out[i - base] = w;
        }
    }
}

/// Points per chunk of the pair-once plan: about (6.3 spacings)³ of a lattice, about two
/// horizons at m = 3, so a chunk's pairs reach only its spatial neighbours' chunks. Fixed (not
/// tied to the thread count) so that the summation order, hence the result, is the same for
/// every number of threads.
const PAIR_CHUNK: usize = 256;

/// Pair-once ("half list") evaluation of a closed block: every pair i < j is evaluated once,
/// from i's row, and its force added to F_i and subtracted from F_j (Newton's third law), so
/// each square root and division serves two directed bonds.
///
/// # Parallel scatter without atomics
/// The block's points (in run order, which follows a space-filling curve) are cut into chunks
/// of [`PAIR_CHUNK`]. A chunk writes F of its own points and of the chunks its upper
/// neighbours (j > i) fall in: its *write set*. Chunks are coloured greedily so that two chunks
/// of one colour have disjoint write sets; colours run one after another, the chunks of a
/// colour in parallel. Every F entry is therefore written by one task at a time, in an order
/// fixed by the plan.
#[derive(Debug, Clone)]
struct PairPlan {
    /// For the k-th block point i: the first bond of i's row whose neighbour is > i (rows are
    /// sorted, so the bonds from there to the row end are exactly the upper pairs).
    upper_start: Vec<usize>,
    /// Chunks (ranges of positions in the block's point list), grouped by colour.
    colours: Vec<Vec<std::ops::Range<usize>>>,
}

impl PairPlan {
    /// The plan for a closed block, or `None` when some row is not sorted by neighbour index.
    fn new(bonds: &crate::model::BondList, points: &[u32]) -> Option<Self> {
        let mut upper_start = Vec::with_capacity(points.len());
        for &i in points {
            let row = bonds.family(i as usize);
            if !row.is_sorted() {
                return None;
            }
            upper_start.push(bonds.offsets[i as usize] + row.partition_point(|&j| j <= i));
        }
        let chunks = points.len().div_ceil(PAIR_CHUNK);
        let range = |c: usize| c * PAIR_CHUNK..((c + 1) * PAIR_CHUNK).min(points.len());
        let mut chunk_of = vec![u32::MAX; bonds.num_points()];
        for (k, &i) in points.iter().enumerate() {
            chunk_of[i as usize] = (k / PAIR_CHUNK) as u32;
        }
        let mut colours: Vec<Vec<std::ops::Range<usize>>> = Vec::new();
        let mut colouring = WriteColouring::new(chunks);
        for c in 0..chunks {
            let mut writes = vec![c as u32];
            for k in range(c) {
                let end = bonds.offsets[points[k] as usize + 1];
                writes.extend(
                    bonds.neighbor[upper_start[k]..end]
                        .iter()
                        .map(|&j| chunk_of[j as usize]),
                );
            }
            writes.sort_unstable();
            writes.dedup();
            let colour = colouring.assign(&writes);
            if colour == colours.len() {
                colours.push(Vec::new());
            }
            colours[colour].push(range(c));
        }
        Some(Self {
            upper_start,
            colours,
        })
    }

    /// Adds the force density of every pair of the block to `force_density`, breaking first
    /// the bonds `breaker` breaks; returns the directed bonds broken.
    fn run<D: Integrity, B: Breaker>(
        &self,
        points: &[u32],
        force_density: &mut [[f64; 3]],
        rows: PairRows<'_>,
        damage: D,
        breaker: B,
        wide: bool,
    ) -> usize {
        use rayon::prelude::*;
        assert!(force_density.len() >= rows.y.len());
        let out = SharedForce(force_density.as_mut_ptr());
        let mut broken = 0;
        for colour in &self.colours {
            broken += colour
                .par_iter()
                .map(|chunk| {
                    // SAFETY: `out` points to `force_density`, which is borrowed mutably for
                    // this whole call and has an entry for every point. The chunks of one
                    // colour write disjoint sets of entries (the colouring in `new`), colours
                    // run one after another (`sum` returns only when all its tasks are done),
                    // and nothing else reads or writes the array meanwhile. The breaker's
                    // contract is the caller's.
                    unsafe {
                        rows.chunk_dispatch(
                            &points[chunk.clone()],
                            &self.upper_start[chunk.clone()],
                            out,
                            damage,
                            breaker,
                            wide,
                        )
                    }
                })
                .sum::<usize>();
        }
        broken
    }
}

/// The force array shared by the tasks of one colour (see [`PairPlan`] for why their writes
/// never overlap).
#[derive(Clone, Copy)]
struct SharedForce(*mut [f64; 3]);

// SAFETY: the pointer is only written through by tasks whose entries are disjoint (see
// `PairPlan::run`).
unsafe impl Send for SharedForce {}
unsafe impl Sync for SharedForce {}

/// What the pair loop reads.
#[derive(Clone, Copy)]
struct PairRows<'a> {
    bonds: &'a crate::model::BondList,
    volume: &'a [f64],
    y: &'a [[f64; 3]],
    /// c (the block is closed, so c_ij = c).
    micromodulus: f64,
}

impl PairRows<'_> {
    /// [`PairRows::chunk`] built for AVX2 when `wide`, else for the baseline target (the same
    /// result bitwise, as for the gather loop).
    ///
    /// # Safety
    /// As [`PairRows::chunk`].
    #[inline(always)]
    unsafe fn chunk_dispatch<D: Integrity, B: Breaker>(
        self,
        points: &[u32],
        upper_start: &[usize],
        out: SharedForce,
        damage: D,
        breaker: B,
        wide: bool,
    ) -> usize {
        #[cfg(target_arch = "x86_64")]
        if wide {
            // SAFETY: AVX2 was detected at run time; the rest as the caller guarantees.
            return unsafe { self.chunk_avx2(points, upper_start, out, damage, breaker) };
        }
        let _ = wide;
        // SAFETY: as the caller guarantees.
        unsafe { self.chunk(points, upper_start, out, damage, breaker) }
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
        out: SharedForce,
        damage: D,
        breaker: B,
    ) -> usize {
        // SAFETY: as the caller guarantees.
        unsafe { self.chunk(points, upper_start, out, damage, breaker) }
    }

    /// For every point i of the chunk and every upper neighbour j > i: first the critical
    /// stretch test of `breaker` (if any), then `s = c (1−d) (|Y| − ζ)/(ζ|Y|)`,
    /// `F_i += s V_j (Y_j − Y_i)`, `F_j −= s V_i (Y_j − Y_i)`. Returns the directed bonds
    /// broken.
    ///
    /// # Safety
    /// `out` must point to an array with an entry for every point that no one else accesses
    /// while this runs, except tasks whose entries are disjoint from i's and the j's here; and
    /// the contract of `breaker` ([`Breaker`]) must hold.
    #[inline(always)]
    unsafe fn chunk<D: Integrity, B: Breaker>(
        self,
        points: &[u32],
        upper_start: &[usize],
        out: SharedForce,
        damage: D,
        breaker: B,
    ) -> usize {
        let bonds = self.bonds;
        let (y, volume) = (self.y, self.volume);
        // Per block of a row's upper bonds: gather the differences (scalar); if bonds may
        // break, filter them (vectorized) and give the few the filter cannot clear the exact
        // test; then compute every bond's scale in a loop over plain arrays (which the
        // compiler vectorizes: the square roots and divisions dominate), then accumulate F_i
        // and scatter into F_j (scalar, in bond order, so the result does not depend on the
        // vector width).
        let mut d = [[0.0; PAIR_BLOCK]; 3];
        let mut squared = [0.0; PAIR_BLOCK];
        let mut pair = [0.0; PAIR_BLOCK];
        let mut scale = [0.0; PAIR_BLOCK];
        let mut suspect = [false; PAIR_BLOCK];
        let mut broken = 0;
        for (&i, &first) in points.iter().zip(upper_start) {
            let i = i as usize;
            let end = bonds.offsets[i + 1];
            let yi = y[i];
            let vi = volume[i];
            let mut fi = [0.0; 3];
            for block_start in (first..end).step_by(PAIR_BLOCK) {
                let block_end = (block_start + PAIR_BLOCK).min(end);
                let count = block_end - block_start;
                let neighbors = &bonds.neighbor[block_start..block_end];
                let lengths = &bonds.reference_length[block_start..block_end];
                for (n, &j) in neighbors.iter().enumerate() {
                    let yj = y[j as usize];
                    for k in 0..3 {
                        d[k][n] = yj[k] - yi[k];
                    }
                }
                // q = dx*dx + dy*dy + dz*dz: the very number the damage models test and whose
                // square root the force uses.
                for n in 0..count {
                    squared[n] = d[0][n] * d[0][n] + d[1][n] * d[1][n] + d[2][n] * d[2][n];
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
                    *pair = self.micromodulus * damage.intact(block_start + n);
                }
                for n in 0..count {
                    scale[n] = bond_scale_squared(pair[n], lengths[n], squared[n]);
                }
                for (n, &j) in neighbors.iter().enumerate() {
                    let j = j as usize;
                    let (to_i, to_j) = (scale[n] * volume[j], scale[n] * vi);
                    // SAFETY: j is a point of this chunk's write set (see the contract).
                    let fj = unsafe { &mut *out.0.add(j) };
                    for k in 0..3 {
                        fi[k] += to_i * d[k][n];
                        fj[k] -= to_j * d[k][n];
                    }
                }
            }
            // SAFETY: i is a point of this chunk.
            let out_i = unsafe { &mut *out.0.add(i) };
            for k in 0..3 {
                out_i[k] += fi[k];
            }
        }
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
    fn model_name(&self) -> &'static str {
        "Elastic Bond Based"
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

    fn needs_dilatation(&self) -> bool {
        false
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
        // Rows are sorted (the plan checked), so reverse bonds are found by binary search.
        self.fuses_breaking = self.pairs.is_some()
            && points.iter().all(|&i| {
                bonds
                    .family(i as usize)
                    .iter()
                    .all(|&j| bonds.family(j as usize).binary_search(&i).is_ok())
            });
        self.points = points;
        Ok(())
    }

    fn points(&self) -> &[u32] {
        &self.points
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
                volume: reference.volume,
                y: current.position,
                micromodulus: uniform.0,
            };
            match current.bond_damage {
                None => plan.run(
                    &self.points,
                    force_density,
                    pairs,
                    Undamaged,
                    NoBreaking,
                    wide,
                ),
                Some(d) => plan.run(
                    &self.points,
                    force_density,
                    pairs,
                    Damaged(d),
                    NoBreaking,
                    wide,
                ),
            };
            return;
        }
        let closed = self.closed;
        let run = |chunk: &[u32], base: usize, out: &mut [[f64; 3]]| match (
            current.bond_damage,
            closed,
        ) {
            (None, true) => rows.add_force_dispatch(chunk, base, out, Undamaged, uniform, wide),
            (None, false) => rows.add_force_dispatch(chunk, base, out, Undamaged, mixed, wide),
            (Some(d), true) => rows.add_force_dispatch(chunk, base, out, Damaged(d), uniform, wide),
            (Some(d), false) => rows.add_force_dispatch(chunk, base, out, Damaged(d), mixed, wide),
        };
        for_each_chunk(&self.points, force_density, &|i| i as usize, &run);
    }

    fn fuses_critical_stretch(&self) -> bool {
        self.fuses_breaking
    }

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
            .filter(|_| self.fuses_breaking)
            .expect("called only when fuses_critical_stretch() is true");
        assert_eq!(bond_damage.len(), reference.bonds.num_bonds());
        let pairs = PairRows {
            bonds: reference.bonds,
            volume: reference.volume,
            y: position,
            // As `add_force_density` (c/2 doubled: exactly c).
            micromodulus: 2.0 * self.half(),
        };
        let fused = FusedCriticalStretch {
            limit: StretchLimit::new(critical_stretch),
            damage: bond_damage.as_mut_ptr(),
        };
        // The `Breaker` contract holds: `bond_damage` is borrowed mutably for this call and
        // covers every bond; the chunk of point i reads and writes only the entries of i's
        // upper bonds and of their reverses, which belong to no other chunk (each pair has
        // one lower point, and the block is closed with symmetric families).
        plan.run(
            &self.points,
            force_density,
            pairs,
            fused,
            fused,
            wide_vectors_available(),
        )
    }

    fn tangent_is_bond_local(&self) -> bool {
        true
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::damage::{CriticalStretch, DamageModel};
    use crate::material::test_support::{brute_force_bonds, random_cloud, Rng};
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

    /// 600 random points (more than two pair-plan chunks), random volumes, displaced by up
    /// to 0.1, with bonds above stretch 0.02 broken.
    fn body() -> Body {
        let mut rng = Rng::new(11);
        let (x, v) = random_cloud(&mut rng, 600, 7.0);
        let bonds = brute_force_bonds(&x, 1.6);
        let y: Vec<[f64; 3]> = x
            .iter()
            .map(|p| p.map(|c| c + 0.1 * (2.0 * rng.uniform() - 1.0)))
            .collect();
        let reference = ReferenceView {
            bonds: &bonds,
            position: &x,
            volume: &v,
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
        // The plan fixes the summation order (chunks and colours do not depend on threads).
        let (x, v, bonds, y, damage) = body();
        let reference = ReferenceView {
            bonds: &bonds,
            position: &x,
            volume: &v,
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
    fn chunks_of_one_colour_write_disjoint_points() {
        let (x, v, bonds, _, _) = body();
        let reference = ReferenceView {
            bonds: &bonds,
            position: &x,
            volume: &v,
        };
        let points: Vec<u32> = (0..x.len() as u32).collect();
        let plan = PairPlan::new(reference.bonds, &points).unwrap();
        let mut covered = vec![0usize; points.len()];
        for colour in &plan.colours {
            let mut writer = vec![usize::MAX; x.len()];
            for (c, chunk) in colour.iter().enumerate() {
                for k in chunk.clone() {
                    covered[k] += 1;
                    let i = points[k] as usize;
                    let upper = &bonds.neighbor[plan.upper_start[k]..bonds.offsets[i + 1]];
                    assert!(upper.iter().all(|&j| j as usize > i));
                    assert_eq!(
                        upper.len(),
                        bonds.family(i).iter().filter(|&&j| j as usize > i).count()
                    );
                    for p in std::iter::once(i).chain(upper.iter().map(|&j| j as usize)) {
                        assert!(
                            writer[p] == usize::MAX || writer[p] == c,
                            "point {p} written by two chunks of one colour"
                        );
                        writer[p] = c;
                    }
                }
            }
        }
        assert!(
            covered.iter().all(|&n| n == 1),
            "every point in exactly one chunk"
        );
        assert!(plan.colours.len() > 1);
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
        };
        let mut m = material();
        m.setup(&reference, (0..x.len() as u32).collect()).unwrap();
        assert!(m.fuses_critical_stretch());
        let all: Vec<u32> = (0..x.len() as u32).collect();
        let model = CriticalStretch::new(0.02).unwrap();
        let mut coefficients = vec![PointCoefficients::default(); x.len()];
        let current = CurrentView {
            position: &x,
            bond_damage: None,
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
        };
        let left: Vec<u32> = (0..x.len() as u32)
            .filter(|&i| x[i as usize][0] < 3.5)
            .collect();
        let mut m = material();
        m.setup(&reference, left).unwrap();
        assert!(!m.fuses_critical_stretch());
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
