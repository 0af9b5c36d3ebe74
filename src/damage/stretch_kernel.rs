//! The bond-stretch test shared by the stretch-based damage models, and its two loops.
//!
//! * The **directed** loop visits every bond of the block's rows, each point's row in its own
//!   task (a gather: no shared writes). It works for any bond list.
//! * The **pair-once** loop ([`PairPlan`]) visits each pair of block points once, from the
//!   lower index, and writes both directions; bonds to points outside the block are visited
//!   from the block's end only, as in the directed loop. It halves the bonds read and tested,
//!   and tests most bonds without a square root or a division (see [`StretchLimit::breaks`]).
//!
//! Both loops take the same decisions: a pair's two directions evaluate the same expression
//! on the same (negated) coordinate differences with the same limit, so they agree bitwise
//! (see [`CriticalStretch`](super::CriticalStretch)); evaluating it once and writing both
//! gives what two evaluations would.

use crate::model::point_chunks::for_each_chunk;
use crate::model::BondList;
use crate::model::ReferenceView;
use crate::vector_width::wide_vectors_available;
use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};

/// 1 − m, the safety factor of the squared-length filter: m = 2⁻³⁰ ≈ 9.3e-10, so 1 − m is
/// exactly representable.
const FILTER_SAFETY: f64 = 1.0 - 1.0 / (1u64 << 30) as f64;

/// A critical stretch s_c with the factor of the squared-length filter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct StretchLimit {
    /// s_c (positive, finite).
    pub stretch: f64,
    /// k = fl(fl(fl(1 + s_c)²)·(1 − m)), or −∞ when that overflows (the filter is then off).
    intact_factor: f64,
}

impl StretchLimit {
    pub(crate) fn new(stretch: f64) -> Self {
        let w = 1.0 + stretch;
        let k = w * w * FILTER_SAFETY;
        Self {
            stretch,
            intact_factor: if k.is_finite() { k } else { f64::NEG_INFINITY },
        }
    }

    /// k, the factor of the squared-length filter ([`StretchLimit::certainly_intact`]).
    #[inline(always)]
    pub(crate) fn intact_factor(self) -> f64 {
        self.intact_factor
    }

    /// True when the filter proves the bond intact: squared length `length_squared` at most
    /// fl(fl(ζ²)·k) with fl(ζ²) normal (see [`StretchLimit::breaks`] for the proof).
    #[inline(always)]
    pub(crate) fn certainly_intact(self, length_squared: f64, zeta: f64) -> bool {
        let z2 = zeta * zeta;
        // `&`, not `&&`: both comparisons are cheap and branch-free, so a loop of them vectorizes.
        (length_squared <= z2 * self.intact_factor) & (z2 >= f64::MIN_POSITIVE)
    }

    /// The exact test `(fl(√q) − ζ)/ζ > s_c`, the expression the models have always used.
    #[inline(always)]
    pub(crate) fn exceeded(self, length_squared: f64, zeta: f64) -> bool {
        (length_squared.sqrt() - zeta) / zeta > self.stretch
    }

    /// True when the bond of reference length `zeta` whose current squared length is
    /// `length_squared` (evaluated as `dx*dx + dy*dy + dz*dz` from the coordinate differences)
    /// breaks: `(fl(√q) − ζ)/ζ > s_c`, the same floating-point expression (and so the same
    /// decision) as always, but the square root and division are only evaluated when the
    /// filter below cannot decide.
    ///
    /// # The filter gives the same decisions, rounding included
    /// Let u = 2⁻⁵³ (unit roundoff), q the squared length (the very number whose square root
    /// the exact test takes), z2 = fl(ζ·ζ) and t = fl(z2·k). The filter declares "intact" only
    /// when `q ≤ t` and z2 ≥ 2⁻¹⁰²² (normal; smaller ζ, and the NaN that ζ = 0 or NaN inputs
    /// produce, always take the exact path). Claim: then the exact test is false.
    ///
    /// 1. Each rounding of a result ≥ 2⁻¹⁰²³ has relative error ≤ 2u (≤ u when normal), and
    ///    1 − m is exact, so with s = s_c: t ≤ ζ²(1 + s)²(1 − m)(1 + 2u)⁶ (five roundings,
    ///    fl(1 + s) counted twice). If t overflows to +∞ the true product exceeds
    ///    f64::MAX ≥ q, and the same bound holds with the true product; k itself is finite or
    ///    −∞ by construction, and −∞ makes `q ≤ t` false.
    /// 2. r = fl(√q) ≤ √q(1 + u) ≤ ζ(1 + s)·A with A = √(1 − m)(1 + 2u)⁴ ≤ (1 − m/2)(1 + 9u)
    ///    < 1 − m/4 (m/4 ≈ 2.3e-10 ≫ 9u ≈ 1e-15).
    /// 3. So r − ζ ≤ ζ·B with B = s − (1 + s)(1 − A) ≤ s − (1 + s)m/4. Rounding is monotone:
    ///    if B ≤ 0 then fl(r − ζ) ≤ 0 and the stretch fl(fl(r − ζ)/ζ) ≤ 0 < s. Otherwise
    ///    fl(r − ζ) ≤ ζB(1 + u) and the stretch is ≤ B(1 + u)² + 2⁻¹⁰⁷⁴ (the last term bounds
    ///    a subnormal rounding) ≤ s − (1 + s)m/4 + 3us + 2⁻¹⁰⁷⁴ < s, since
    ///    (1 + s)m/4 > 3us + 2⁻¹⁰⁷⁴ for every s > 0.
    ///
    /// Every other case (q > t, z2 subnormal, q NaN or +∞) evaluates the exact test, so the
    /// decision is always the exact test's. (No multiply-add is fused: Rust does not contract
    /// floating-point expressions, and FMA is not enabled for these loops.)
    #[inline(always)]
    pub(crate) fn breaks(self, length_squared: f64, zeta: f64) -> bool {
        !self.certainly_intact(length_squared, zeta) && self.exceeded(length_squared, zeta)
    }
}

/// The limit of the bond between points `i` and `j`, or `None` when it never breaks. Must be
/// symmetric (`limit(i, j) == limit(j, i)`) so that both directions of a pair decide alike.
pub(super) trait BondLimit: Sync {
    fn limit(&self, i: usize, j: usize) -> Option<StretchLimit>;
}

/// The same limit for every bond.
impl BondLimit for StretchLimit {
    #[inline(always)]
    fn limit(&self, _i: usize, _j: usize) -> Option<StretchLimit> {
        Some(*self)
    }
}

/// `|b − a|²` as `dx*dx + dy*dy + dz*dz`, evaluated identically for (a, b) and (b, a) (IEEE
/// subtraction is exactly antisymmetric and squaring removes the sign).
#[inline(always)]
fn squared_distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    let (dx, dy, dz) = (b[0] - a[0], b[1] - a[1], b[2] - a[2]);
    dx * dx + dy * dy + dz * dz
}

/// Breaks (d = 1) every intact bond in the rows of `points` whose stretch
/// `(|Y_j − Y_i| − ζ)/ζ` exceeds its limit; returns how many directed bonds broke. Uses the
/// pair-once loop when `plan` was made for these points and this bond list, the directed loop
/// otherwise.
pub(super) fn update_stretch_damage<L: BondLimit>(
    reference: &ReferenceView<'_>,
    current_position: &[[f64; 3]],
    points: &[u32],
    bond_damage: &mut [f32],
    limits: &L,
    plan: Option<&PairPlan>,
) -> usize {
    match plan {
        Some(plan) if plan.fits(reference, points) => {
            plan.run(reference, current_position, bond_damage, limits)
        }
        _ => directed(reference, current_position, points, bond_damage, limits),
    }
}

/// Breaks (d = 1) every intact bond in the rows of `points` whose stretch exceeds `limit`, each
/// row by itself (the directed loop); returns how many directed bonds broke. For the rows a
/// material's fused pass decides without computing their forces.
pub(crate) fn break_stretched_rows(
    reference: &ReferenceView<'_>,
    current_position: &[[f64; 3]],
    points: &[u32],
    bond_damage: &mut [f32],
    limit: StretchLimit,
) -> usize {
    directed(reference, current_position, points, bond_damage, &limit)
}

/// The directed loop: every bond of every row of `points`, a row per point.
fn directed<L: BondLimit>(
    reference: &ReferenceView<'_>,
    current_position: &[[f64; 3]],
    points: &[u32],
    bond_damage: &mut [f32],
    limits: &L,
) -> usize {
    let bonds = reference.bonds;
    let y = current_position;
    let broken = AtomicUsize::new(0);
    for_each_chunk(
        points,
        bond_damage,
        &|i| bonds.offsets[i as usize],
        &|chunk: &[u32], base: usize, rows: &mut [f32]| {
            let mut newly = 0;
            for &i in chunk {
                let i = i as usize;
                let range = bonds.range(i);
                let row = &mut rows[range.start - base..range.end - base];
                let zetas = &bonds.reference_length[range.clone()];
                for ((d, &j), &zeta) in row.iter_mut().zip(&bonds.neighbor[range]).zip(zetas) {
                    if *d >= 1.0 {
                        continue;
                    }
                    let j = j as usize;
                    let Some(limit) = limits.limit(i, j) else {
                        continue;
                    };
                    if limit.breaks(squared_distance(y[i], y[j]), zeta) {
                        *d = 1.0;
                        newly += 1;
                    }
                }
            }
            broken.fetch_add(newly, Ordering::Relaxed);
        },
    );
    broken.into_inner()
}

/// The directed loop with thermal strain (Peridigm's rule,
/// `Peridigm_CriticalStretchDamageModel.cpp`): the bond i→j breaks once `(|Y_j − Y_i| − ζ − α ΔT_i ζ)/ζ` exceeds its limit, ΔT_i the temperature change
/// of point i alone (`temperature_change`, all points), α the damage model's `Thermal
/// Expansion Coefficient`. Each direction decides from its own end's ΔT, so a pair whose ends
/// differ in temperature may break in one direction first, as in Peridigm. Returns the
/// directed bonds broken.
pub(super) fn update_thermal_stretch_damage<L: BondLimit>(
    reference: &ReferenceView<'_>,
    current_position: &[[f64; 3]],
    points: &[u32],
    bond_damage: &mut [f32],
    limits: &L,
    thermal_expansion: f64,
    temperature_change: &[f64],
) -> usize {
    let bonds = reference.bonds;
    let y = current_position;
    let broken = AtomicUsize::new(0);
    for_each_chunk(
        points,
        bond_damage,
        &|i| bonds.offsets[i as usize],
        &|chunk: &[u32], base: usize, rows: &mut [f32]| {
            let mut newly = 0;
            for &i in chunk {
                let i = i as usize;
                let range = bonds.range(i);
                let free = thermal_expansion * temperature_change[i];
                let row = &mut rows[range.start - base..range.end - base];
                let zetas = &bonds.reference_length[range.clone()];
                for ((d, &j), &zeta) in row.iter_mut().zip(&bonds.neighbor[range]).zip(zetas) {
                    if *d >= 1.0 {
                        continue;
                    }
                    let j = j as usize;
                    let Some(limit) = limits.limit(i, j) else {
                        continue;
                    };
                    let length = squared_distance(y[i], y[j]).sqrt();
                    if (length - zeta - free * zeta) / zeta > limit.stretch {
                        *d = 1.0;
                        newly += 1;
                    }
                }
            }
            broken.fetch_add(newly, Ordering::Relaxed);
        },
    );
    broken.into_inner()
}

/// Block points per task of the pair-once loop (load balance: rows near surfaces and late in
/// the order have fewer upper pairs). The result does not depend on it.
const PAIR_CHUNK: usize = 256;

/// 1 + 2⁻⁴⁰: how much larger than fl(ζ²) the recomputed squared reference length may be
/// (see [`Chunk::upper_pairs`]).
const REFERENCE_TOLERANCE: f64 = 1.0 + 1.0 / (1u64 << 40) as f64;

/// Bonds tested together in the pair-once loop's filter (a multiple of every vector width).
const LANES: usize = 8;

/// The pair-once loop of one block, prepared once for a bond list and the block's points.
///
/// Requirements, checked by [`PairPlan::new`] (which declines otherwise): every row of the
/// block is sorted by neighbour index without repeats; every bond between two block points
/// has its reverse (a symmetric family within the block; bonds to other blocks may be one-way);
/// and the squared reference length p recomputed from the reference positions agrees with the
/// stored ζ as [`Chunk::upper_pairs`] needs (it always does when ζ
/// was computed from the same positions, to within a few roundings).
///
/// The loop streams only the neighbour indices of the upper pairs: current and reference
/// positions are small enough to stay in cache, and ζ and the bond damage are read only for
/// the few bonds the filter cannot clear (a bond the filter clears stays as it is, intact or
/// broken).
/// It assumes that both directions of a pair inside the block carry the same damage, which
/// holds from the start and is kept by every damage model (a pair breaks from both ends at
/// once).
#[derive(Debug, Clone, PartialEq)]
pub(super) struct PairPlan {
    /// Size of the bond list the plan was made for.
    num_points: usize,
    num_bonds: usize,
    /// The block's points (strictly increasing).
    points: Vec<u32>,
    /// For the k-th block point i: the first bond of i's row whose neighbour is > i.
    upper_start: Vec<usize>,
    /// For the k-th block point: every neighbour is a block point.
    closed_row: Vec<bool>,
    /// `member[p]`: p is a block point (all points of the bond list).
    member: Vec<bool>,
}

impl PairPlan {
    /// The plan for `points` (strictly increasing) of the bond list and reference positions of
    /// `reference`, or `None` when a requirement (see the type) does not hold, in which case the
    /// directed loop serves.
    pub fn new(reference: &ReferenceView<'_>, points: &[u32]) -> Option<Self> {
        let bonds = reference.bonds;
        let x = reference.position;
        if x.len() != bonds.num_points() {
            return None;
        }
        if !points.windows(2).all(|w| w[0] < w[1]) {
            return None;
        }
        let n = bonds.num_points();
        let mut member = vec![false; n];
        for &p in points {
            *member.get_mut(p as usize)? = true;
        }
        let mut upper_start = Vec::with_capacity(points.len());
        let mut closed_row = Vec::with_capacity(points.len());
        for &i in points {
            let row = bonds.family(i as usize);
            if !row.windows(2).all(|w| w[0] < w[1]) {
                return None;
            }
            let mut closed = true;
            for (b, &j) in bonds.range(i as usize).zip(row) {
                if !member[j as usize] {
                    closed = false;
                } else if bonds.family(j as usize).binary_search(&i).is_err() {
                    return None;
                }
                let p = squared_distance(x[i as usize], x[j as usize]);
                let zeta = bonds.reference_length[b];
                if !(p >= f64::MIN_POSITIVE && p <= zeta * zeta * REFERENCE_TOLERANCE) {
                    return None;
                }
            }
            upper_start.push(bonds.offsets[i as usize] + row.partition_point(|&j| j <= i));
            closed_row.push(closed);
        }
        Some(Self {
            num_points: n,
            num_bonds: bonds.num_bonds(),
            points: points.to_vec(),
            upper_start,
            closed_row,
            member,
        })
    }

    /// True when the plan was made for `points` of a bond list of this size (the bond list
    /// itself must be the one given to [`PairPlan::new`]; the model's never changes).
    fn fits(&self, reference: &ReferenceView<'_>, points: &[u32]) -> bool {
        let bonds = reference.bonds;
        self.num_points == bonds.num_points()
            && reference.position.len() == self.num_points
            && self.num_bonds == bonds.num_bonds()
            && self.points == points
    }

    /// Runs the pair-once loop over the whole block; returns the directed bonds broken.
    fn run<L: BondLimit>(
        &self,
        reference: &ReferenceView<'_>,
        y: &[[f64; 3]],
        bond_damage: &mut [f32],
        limits: &L,
    ) -> usize {
        let bonds = reference.bonds;
        assert_eq!(bond_damage.len(), bonds.num_bonds());
        assert_eq!(y.len(), bonds.num_points());
        let shared = SharedDamage(bond_damage.as_mut_ptr());
        let wide = wide_vectors_available();
        self.points
            .par_chunks(PAIR_CHUNK)
            .zip(self.upper_start.par_chunks(PAIR_CHUNK))
            .zip(self.closed_row.par_chunks(PAIR_CHUNK))
            .map(|((points, upper_start), closed_row)| {
                let chunk = Chunk {
                    points,
                    upper_start,
                    closed_row,
                    member: &self.member,
                    bonds,
                    x: reference.position,
                    y,
                    limits,
                    damage: shared,
                };
                // SAFETY: `shared` points to `bond_damage`, borrowed mutably for this whole
                // call, with an entry for every bond (asserted above). The damage of a pair
                // inside the block (both directions) is read and written only by the task of
                // its lower point (the upper point's task skips the bond to its lower
                // neighbour), and that of a bond to another block only by the task of its
                // block point; so no two tasks touch the same entry.
                unsafe { chunk.dispatch(wide) }
            })
            .sum()
    }
}

/// The bond-damage array shared by the tasks of the pair loop (see [`PairPlan::run`] for why
/// their entries never overlap).
#[derive(Clone, Copy)]
struct SharedDamage(*mut f32);

// SAFETY: tasks only touch disjoint entries through the pointer (see `PairPlan::run`).
unsafe impl Send for SharedDamage {}
unsafe impl Sync for SharedDamage {}

/// One task of the pair loop: a run of consecutive block points.
struct Chunk<'a, L> {
    points: &'a [u32],
    upper_start: &'a [usize],
    closed_row: &'a [bool],
    member: &'a [bool],
    bonds: &'a BondList,
    x: &'a [[f64; 3]],
    y: &'a [[f64; 3]],
    limits: &'a L,
    damage: SharedDamage,
}

impl<L: BondLimit> Chunk<'_, L> {
    /// [`Chunk::run`] built for AVX2 when `wide`, else for the baseline target. Both take the
    /// same decisions: the lanes do the same IEEE operations, and no multiply-add is fused.
    ///
    /// # Safety
    /// As [`Chunk::run`].
    #[inline(always)]
    unsafe fn dispatch(&self, wide: bool) -> usize {
        #[cfg(target_arch = "x86_64")]
        if wide {
            // SAFETY: AVX2 was detected at run time; the rest as the caller guarantees.
            return unsafe { self.run_avx2() };
        }
        let _ = wide;
        // SAFETY: as the caller guarantees.
        unsafe { self.run() }
    }

    /// [`Chunk::run`] with AVX2 enabled (4-wide filter).
    ///
    /// # Safety
    /// As [`Chunk::run`], and the CPU supports AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn run_avx2(&self) -> usize {
        // SAFETY: as the caller guarantees.
        unsafe { self.run() }
    }

    /// Tests the chunk's pairs and its bonds to other blocks; returns the directed bonds broken.
    ///
    /// # Safety
    /// `self.damage` must point to the bond-damage array of `self.bonds`, and no one else may
    /// access the entries this chunk owns (its points' bonds to other blocks, and both
    /// directions of their upper pairs) while this runs.
    #[inline(always)]
    unsafe fn run(&self) -> usize {
        let mut newly = 0;
        for ((&i, &first), &closed) in self
            .points
            .iter()
            .zip(self.upper_start)
            .zip(self.closed_row)
        {
            let i = i as usize;
            newly += if closed {
                // SAFETY: as the caller guarantees.
                unsafe { self.upper_pairs(i, first) }
            } else {
                // SAFETY: as the caller guarantees.
                unsafe { self.mixed_row(i) }
            };
        }
        newly
    }

    /// Breaks the pair (i, j) through bond `b` (i→j): d = 1 in both directions. Returns the
    /// directed bonds that changed.
    ///
    /// # Safety
    /// `b` and the reverse bond are entries this chunk owns.
    #[inline(never)]
    unsafe fn break_pair(&self, i: usize, j: usize, b: usize) -> usize {
        let back = self.bonds.offsets[j]
            + self
                .bonds
                .family(j)
                .binary_search(&(i as u32))
                .expect("PairPlan::new checked that pairs inside the block are symmetric");
        // SAFETY: both entries are owned by this chunk (the caller's contract).
        unsafe {
            *self.damage.0.add(b) = 1.0;
            let reverse = self.damage.0.add(back);
            let changed = usize::from(*reverse < 1.0);
            *reverse = 1.0;
            1 + changed
        }
    }

    /// The upper pairs of a row whose neighbours are all block points: bonds `first..end` of
    /// i's row, filtered `LANES` at a time against the recomputed reference length; only the
    /// bonds the filter cannot clear (rare) read their damage and ζ and take the exact test.
    ///
    /// # The filter
    /// A bond is cleared (certainly intact) when its squared current length q is at most
    /// t = fl(p·k), where p = fl(|X_j − X_i|²) is the squared reference length recomputed from
    /// the reference positions (which stay in cache, unlike the stored ζ). [`PairPlan::new`] checks, for every bond it filters this way, that
    /// p ≥ 2⁻¹⁰²² and p ≤ fl(fl(ζ·ζ)·(1 + 2⁻⁴⁰)), i.e. p ≤ ζ²(1 + 2⁻⁴⁰)(1 + u)², u = 2⁻⁵³.
    ///
    /// Same decisions as the exact test: the proof of [`StretchLimit::breaks`] goes through
    /// with t = fl(p·k) ≤ ζ²(1 + s)²(1 − m)(1 + 2⁻⁴⁰)(1 + 2u)⁸ (four roundings in k, one in
    /// t, three from the check on p); since (1 − m)(1 + 2⁻⁴⁰) ≤ 1 − m(1 − 2⁻¹⁰), step 2
    /// gives A ≤ (1 − m(1 − 2⁻¹⁰)/2)(1 + 2u)⁵ < 1 − m/4 (the slack m/4·(1 − 2⁻⁹) ≈ 2.3e-10
    /// dwarfs 11u ≈ 1.2e-15), and step 3 is unchanged. (p·k ≥ 2⁻¹⁰²³ because p is normal and
    /// k ≥ 1 − m; an overflow of t to +∞ and k = −∞ are handled as in step 1.) A bond that is
    /// not cleared reads its damage and ζ and takes the exact test, so every decision is the
    /// exact test's.
    ///
    /// # Safety
    /// As [`Chunk::run`].
    #[inline(always)]
    unsafe fn upper_pairs(&self, i: usize, first: usize) -> usize {
        let bonds = self.bonds;
        let (x, y) = (self.x, self.y);
        let (xi, yi) = (x[i], y[i]);
        let end = bonds.offsets[i + 1];
        let mut newly = 0;
        let mut start = first;
        while start < end {
            let count = (end - start).min(LANES);
            let neighbors = &bonds.neighbor[start..start + count];
            // One bit per bond the filter cannot clear. Computed straight from registers: lane
            // arrays written one element at a time and read back as vectors stall the loads.
            let mut suspects = 0u32;
            for (n, &j) in neighbors.iter().enumerate() {
                let j = j as usize;
                if let Some(limit) = self.limits.limit(i, j) {
                    let q = squared_distance(yi, y[j]);
                    let p = squared_distance(xi, x[j]);
                    // Not `q > t`: a NaN q must be a suspect (the exact test decides it).
                    let cleared = q <= p * limit.intact_factor;
                    suspects |= u32::from(!cleared) << n;
                }
            }
            while suspects != 0 {
                let n = suspects.trailing_zeros() as usize;
                suspects &= suspects - 1;
                let b = start + n;
                let j = neighbors[n] as usize;
                let limit = self.limits.limit(i, j).expect("suspects have a limit");
                // SAFETY: b is an upper pair of i, owned by this chunk.
                if unsafe { *self.damage.0.add(b) } < 1.0
                    && limit.exceeded(squared_distance(yi, y[j]), bonds.reference_length[b])
                {
                    // SAFETY: as above.
                    newly += unsafe { self.break_pair(i, j, b) };
                }
            }
            start += count;
        }
        newly
    }

    /// A row with neighbours outside the block: upper pairs as in [`Chunk::upper_pairs`], bonds
    /// to other blocks from this end only (directed), lower pairs left to the lower point.
    ///
    /// # Safety
    /// As [`Chunk::run`].
    #[inline(always)]
    unsafe fn mixed_row(&self, i: usize) -> usize {
        let bonds = self.bonds;
        let yi = self.y[i];
        let mut newly = 0;
        for b in bonds.range(i) {
            let j = bonds.neighbor[b] as usize;
            let pair = self.member[j];
            if pair && j < i {
                continue;
            }
            // SAFETY: b is an upper pair of i or a bond to another block: owned by this chunk.
            let entry = unsafe { self.damage.0.add(b) };
            // SAFETY: as above.
            if unsafe { *entry } >= 1.0 {
                continue;
            }
            let Some(limit) = self.limits.limit(i, j) else {
                continue;
            };
            if limit.breaks(squared_distance(yi, self.y[j]), bonds.reference_length[b]) {
                newly += if pair {
                    // SAFETY: as above.
                    unsafe { self.break_pair(i, j, b) }
                } else {
                    // SAFETY: as above.
                    unsafe { *entry = 1.0 };
                    1
                };
            }
        }
        newly
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::test_support::{brute_force_bonds, random_cloud, Rng};

    /// The rule written out plainly: every intact bond of the rows of `points` whose stretch,
    /// evaluated as the models always have, exceeds its limit, breaks.
    fn reference_update<L: BondLimit>(
        bonds: &BondList,
        y: &[[f64; 3]],
        points: &[u32],
        damage: &mut [f32],
        limits: &L,
    ) -> usize {
        let mut broken = 0;
        for &i in points {
            let i = i as usize;
            for b in bonds.range(i) {
                let j = bonds.neighbor[b] as usize;
                let Some(limit) = limits.limit(i, j) else {
                    continue;
                };
                let (dx, dy, dz) = (y[j][0] - y[i][0], y[j][1] - y[i][1], y[j][2] - y[i][2]);
                let length = (dx * dx + dy * dy + dz * dz).sqrt();
                let zeta = bonds.reference_length[b];
                if damage[b] < 1.0 && (length - zeta) / zeta > limit.stretch {
                    damage[b] = 1.0;
                    broken += 1;
                }
            }
        }
        broken
    }

    /// A limit that differs per pair of point classes (symmetric), with "never" for one class.
    struct ByClass(Vec<u8>);

    impl BondLimit for ByClass {
        fn limit(&self, i: usize, j: usize) -> Option<StretchLimit> {
            let (a, b) = (self.0[i], self.0[j]);
            if a == 2 || b == 2 {
                None
            } else {
                Some(StretchLimit::new(if a == b { 0.02 } else { 0.01 }))
            }
        }
    }

    #[test]
    fn filter_never_clears_a_bond_the_exact_test_breaks() {
        // Squared lengths within a few ulps of the filter's threshold t = fl(fl(ζ²)·k) and of
        // the exact threshold ((1 + s)ζ)², for random ζ over 40 decades and s from 1e-12 to
        // 50: whenever the filter says "intact", the exact test must say so too, and `breaks`
        // must equal the exact test everywhere. With m = 0 instead of 2⁻³⁰ this fails.
        let mut rng = Rng::new(3);
        let mut cleared = 0;
        for _ in 0..20_000 {
            let zeta = 10f64.powf(-20.0 + 40.0 * rng.uniform());
            let s = 10f64.powf(-12.0 + 13.7 * rng.uniform());
            let limit = StretchLimit::new(s);
            let exact_threshold = ((1.0 + s) * zeta).powi(2);
            for centre in [zeta * zeta * limit.intact_factor, exact_threshold] {
                for step in -4i64..=4 {
                    let q = f64::from_bits((centre.to_bits() as i64 + step) as u64);
                    let exact = limit.exceeded(q, zeta);
                    assert_eq!(limit.breaks(q, zeta), exact, "ζ = {zeta}, s = {s}, q = {q}");
                    if limit.certainly_intact(q, zeta) {
                        cleared += 1;
                        assert!(!exact, "ζ = {zeta}, s = {s}, q = {q}");
                    }
                    // The reference-length filter with p = fl(ζ²)·(1 + 2⁻⁴⁰), the largest
                    // p that PairPlan::new admits.
                    let p = zeta * zeta * REFERENCE_TOLERANCE;
                    if q <= p * limit.intact_factor {
                        assert!(!exact, "ζ = {zeta}, s = {s}, q = {q}, p = {p}");
                    }
                }
            }
        }
        assert!(
            cleared > 10_000,
            "the filter must clear most of these: {cleared}"
        );
        // Degenerate inputs take the exact path and decide as it does.
        let limit = StretchLimit::new(0.1);
        assert!(!limit.breaks(f64::NAN, 1.0));
        assert!(limit.breaks(f64::INFINITY, 1.0));
        assert!(!limit.breaks(0.0, 0.0), "0/0 is NaN, not > s_c");
        assert!(limit.breaks(1.0, 0.0), "1/0 is +∞");
        // An s_c so large that k overflows switches the filter off.
        let huge = StretchLimit::new(1e200);
        assert_eq!(huge.intact_factor, f64::NEG_INFINITY);
        assert!(huge.breaks(1.0, 1e-250));
    }

    /// Reference positions, volumes, families and a sequence of current positions.
    type Cloud = (Vec<[f64; 3]>, Vec<f64>, BondList, Vec<Vec<[f64; 3]>>);

    /// Random cloud of 500 points, families within 1.3, and four current configurations with
    /// growing random displacements.
    fn cloud(seed: u64) -> Cloud {
        let mut rng = Rng::new(seed);
        let (x, v) = random_cloud(&mut rng, 500, 5.0);
        let bonds = brute_force_bonds(&x, 1.3);
        let mut fields = Vec::new();
        let mut u = vec![[0.0; 3]; x.len()];
        for _ in 0..4 {
            for ui in &mut u {
                for c in ui.iter_mut() {
                    *c += 0.006 * rng.normal();
                }
            }
            fields.push(
                x.iter()
                    .zip(&u)
                    .map(|(p, d)| [p[0] + d[0], p[1] + d[1], p[2] + d[2]])
                    .collect(),
            );
        }
        (x, v, bonds, fields)
    }

    #[test]
    fn pair_once_loop_decides_exactly_as_the_plain_rule() {
        let (x, v, bonds, fields) = cloud(11);
        let reference = ReferenceView {
            bonds: &bonds,
            position: &x,
            volume: &v,
            bond_volume: None,
        };
        let mut rng = Rng::new(5);
        let class: Vec<u8> = (0..x.len()).map(|_| (rng.uniform() * 3.0) as u8).collect();
        let limits = ByClass(class.clone());
        // Block = classes 0 and 1 (rows mixed with class-2 points, and closed rows); the
        // whole cloud as one block; a single class.
        let blocks: Vec<Vec<u32>> = vec![
            (0..x.len() as u32)
                .filter(|&p| class[p as usize] != 2)
                .collect(),
            (0..x.len() as u32).collect(),
            (0..x.len() as u32)
                .filter(|&p| class[p as usize] == 0)
                .collect(),
        ];
        for (k, points) in blocks.iter().enumerate() {
            let plan = PairPlan::new(&reference, points).expect("symmetric sorted families");
            // Both kinds of row are exercised: rows reaching class 2 in the first block, only
            // closed rows in the whole cloud.
            match k {
                0 => assert!(plan.closed_row.iter().any(|&c| !c)),
                1 => assert!(plan.closed_row.iter().all(|&c| c)),
                _ => {}
            }
            let mut expected = vec![0.0f32; bonds.num_bonds()];
            let mut got = expected.clone();
            let mut total = 0;
            for y in &fields {
                let want = reference_update(&bonds, y, points, &mut expected, &limits);
                let have =
                    update_stretch_damage(&reference, y, points, &mut got, &limits, Some(&plan));
                assert_eq!(have, want);
                assert_eq!(got, expected);
                total += want;
            }
            assert!(
                total > 50 && total < bonds.num_bonds() / 2,
                "{total} broken"
            );
        }
    }

    #[test]
    fn plan_declines_what_it_cannot_do_and_the_directed_loop_serves() {
        let (x, v, mut bonds, fields) = cloud(17);
        let points: Vec<u32> = (0..x.len() as u32).collect();
        // A one-way bond: drop the bond 1 → (first neighbour of 1) from 1's row only.
        let j = bonds.neighbor[bonds.offsets[1]];
        bonds.neighbor.remove(bonds.offsets[1]);
        bonds.reference_length.remove(bonds.offsets[1]);
        for o in &mut bonds.offsets[2..] {
            *o -= 1;
        }
        let reference = ReferenceView {
            bonds: &bonds,
            position: &x,
            volume: &v,
            bond_volume: None,
        };
        assert!(PairPlan::new(&reference, &points).is_none(), "j = {j}");
        // A stored length shorter than the positions say (a longer one would be harmless:
        // the filter only needs p ≤ ζ²(1 + 2⁻⁴⁰)(1 + u)²).
        let mut bent = brute_force_bonds(&x, 1.3);
        bent.reference_length[7] *= 1.0 - 1e-9;
        let bent_reference = ReferenceView {
            bonds: &bent,
            position: &x,
            volume: &v,
            bond_volume: None,
        };
        assert!(PairPlan::new(&bent_reference, &points).is_none());
        // Unsorted points.
        let good = brute_force_bonds(&x, 1.3);
        let good_reference = ReferenceView {
            bonds: &good,
            position: &x,
            volume: &v,
            bond_volume: None,
        };
        assert!(PairPlan::new(&good_reference, &[3, 2]).is_none());
        // A plan for other points is not used: the result is still the plain rule's.
        let plan = PairPlan::new(&good_reference, &points[..100]).unwrap();
        let limit = StretchLimit::new(0.02);
        let mut expected = vec![0.0f32; good.num_bonds()];
        let mut got = expected.clone();
        let want = reference_update(&good, &fields[3], &points, &mut expected, &limit);
        let have = update_stretch_damage(
            &good_reference,
            &fields[3],
            &points,
            &mut got,
            &limit,
            Some(&plan),
        );
        assert_eq!((have, &got), (want, &expected));
        // The one-way list through the directed loop.
        let mut expected = vec![0.0f32; bonds.num_bonds()];
        let mut got = expected.clone();
        let want = reference_update(&bonds, &fields[3], &points, &mut expected, &limit);
        let have = update_stretch_damage(&reference, &fields[3], &points, &mut got, &limit, None);
        assert_eq!((have, &got), (want, &expected));
        assert!(want > 0);
    }

    #[test]
    fn pair_once_result_is_the_same_for_every_thread_count() {
        let (x, v, bonds, fields) = cloud(23);
        let reference = ReferenceView {
            bonds: &bonds,
            position: &x,
            volume: &v,
            bond_volume: None,
        };
        let points: Vec<u32> = (0..x.len() as u32).collect();
        let plan = PairPlan::new(&reference, &points).unwrap();
        let limit = StretchLimit::new(0.015);
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                let mut d = vec![0.0f32; bonds.num_bonds()];
                let n: usize = fields
                    .iter()
                    .map(|y| {
                        update_stretch_damage(&reference, y, &points, &mut d, &limit, Some(&plan))
                    })
                    .sum();
                (n, d)
            })
        };
        assert_eq!(run(1), run(3));
    }
}
