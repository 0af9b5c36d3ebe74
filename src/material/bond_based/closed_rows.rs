//! The PMB loop of a closed block, whose families stay inside it: every bond's micromodulus is
//! c, each point sums its row with the bond's own data, breaking its over-stretched bonds on
//! the way when asked ([`Breaker`]); on a CPU with AVX2 the row is the intrinsics loop of
//! [`avx2`] (the parent module's docs).

use super::{bond_scale_squared, BondBased, LANES};
use crate::damage::StretchLimit;
use crate::material::{checked_row, gather_bound, FusedCriticalStretch, Integrity, ReferenceView};
use crate::model::point_chunks::for_each_chunk;
use crate::model::{with_volume_rule, VolumeRule};
use crate::vector_width::wide_vectors_available;

#[cfg(target_arch = "x86_64")]
mod avx2;

impl BondBased {
    /// Adds the force density of the forced points of this closed block to `force_density`,
    /// with the bond breaking of `breaker` in their rows first, on every thread
    /// ([`ClosedRows::chunk`]); returns the directed bonds broken.
    pub(super) fn add_closed_force<D: Integrity, B: Breaker>(
        &self,
        reference: &ReferenceView<'_>,
        position: &[[f64; 3]],
        damage: D,
        breaker: B,
        force_density: &mut [[f64; 3]],
    ) -> usize {
        assert!(force_density.len() >= position.len());
        let rows = ClosedRows {
            bonds: reference.bonds,
            y: position,
            // c/2 doubled: exactly c.
            micromodulus: 2.0 * self.half(),
            wide: wide_vectors_available(),
        };
        let broken = std::sync::atomic::AtomicUsize::new(0);
        with_volume_rule!(reference, |v| {
            let run = |chunk: &[u32], base: usize, out: &mut [[f64; 3]]| {
                // SAFETY: the breaker's contract is the caller's; a chunk reads and writes the
                // damage of its own points' rows only, and no two chunks share a point.
                let n = unsafe { rows.chunk_dispatch(chunk, base, out, v, damage, breaker) };
                broken.fetch_add(n, std::sync::atomic::Ordering::Relaxed);
            };
            for_each_chunk(
                self.block.force_points(),
                force_density,
                &|i| i as usize,
                &run,
            )
        });
        broken.into_inner()
    }
}

/// What the closed-block loop reads, bundled once per call ([`ClosedRows::chunk`]).
#[derive(Clone, Copy)]
pub(super) struct ClosedRows<'a> {
    pub(super) bonds: &'a crate::model::BondList,
    pub(super) y: &'a [[f64; 3]],
    /// c (the block is closed, so c_ij = c).
    pub(super) micromodulus: f64,
    /// Run the AVX2 build of the loop ([`wide_vectors_available`]).
    pub(super) wide: bool,
}

impl ClosedRows<'_> {
    /// Adds the force density of the points of `chunk` to `out` (indexed from `base`) and, with
    /// a `breaker`, breaks their over-stretched bonds first; returns the directed bonds broken.
    /// Over the whole call: builds for AVX2 when [`ClosedRows::wide`], else for the baseline
    /// target (bitwise the same result, as for the gather loop).
    ///
    /// # Safety
    /// The contract of `breaker` ([`Breaker`]) must hold for the rows of `chunk`.
    #[inline(always)]
    pub(super) unsafe fn chunk_dispatch<V: VolumeRule, D: Integrity, B: Breaker>(
        self,
        chunk: &[u32],
        base: usize,
        out: &mut [[f64; 3]],
        volume: V,
        damage: D,
        breaker: B,
    ) -> usize {
        #[cfg(target_arch = "x86_64")]
        if self.wide {
            // SAFETY: AVX2 was detected at run time; the rest as the caller guarantees.
            return unsafe { self.chunk_avx2(chunk, base, out, volume, damage, breaker) };
        }
        // SAFETY: as the caller guarantees.
        unsafe { self.chunk(chunk, base, out, volume, damage, breaker) }
    }

    /// [`ClosedRows::chunk`] with AVX2: each row by the intrinsics loop `avx2::row`
    /// (bitwise the staged loop's force).
    ///
    /// # Safety
    /// As [`ClosedRows::chunk`], and the CPU supports AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn chunk_avx2<V: VolumeRule, D: Integrity, B: Breaker>(
        self,
        chunk: &[u32],
        base: usize,
        out: &mut [[f64; 3]],
        volume: V,
        damage: D,
        breaker: B,
    ) -> usize {
        let bound = gather_bound(self.bonds, self.y.len(), volume, damage);
        let mut broken = 0;
        for &i in chunk {
            let i = i as usize;
            // SAFETY: AVX2 is enabled here; `bound` is from `gather_bound`; the breaker's
            // contract is the caller's.
            let (f, newly) = unsafe { avx2::row(self, i, bound, volume, damage, breaker) };
            broken += newly;
            let out = &mut out[i - base];
            for k in 0..3 {
                out[k] += f[k];
            }
        }
        broken
    }

    /// Adds, for every point i of `chunk`, the force density of its row (see
    /// [`ClosedRows::row`]) to `out` (indexed from `base`); returns the directed bonds broken.
    ///
    /// # Safety
    /// The contract of `breaker` ([`Breaker`]) must hold for the rows of `chunk`.
    #[inline(always)]
    unsafe fn chunk<V: VolumeRule, D: Integrity, B: Breaker>(
        self,
        chunk: &[u32],
        base: usize,
        out: &mut [[f64; 3]],
        volume: V,
        damage: D,
        breaker: B,
    ) -> usize {
        let bound = gather_bound(self.bonds, self.y.len(), volume, damage);
        let mut scratch = RowBlock::default();
        let mut broken = 0;
        for &i in chunk {
            let i = i as usize;
            // SAFETY: `bound` is from `gather_bound`; the breaker's contract is the caller's.
            let (f, newly) = unsafe { self.row(i, bound, volume, damage, breaker, &mut scratch) };
            broken += newly;
            let out = &mut out[i - base];
            for k in 0..3 {
                out[k] += f[k];
            }
        }
        broken
    }

    /// `F_i = Σ_j c (1−d_ij) (|Y| − ζ)/(ζ|Y|) w_ij (Y_j − Y_i)` over the row of point i, and
    /// the directed bonds of the row `breaker` broke first. Every input of a term is the
    /// bond's own (Y_i, Y_j, ζ and d of i→j), so the result depends on the row alone.
    ///
    /// The row is taken in blocks of [`ROW_BLOCK`] bonds, each in loops over plain arrays:
    /// the gather of Y_j and w_ij (scalar loads); Y_j − Y_i and q = |Y_j − Y_i|²; the critical
    /// stretch of `breaker` (when it has one: a branch-free filter over the block, the exact
    /// test only for the bonds it cannot clear, breaking the bond i→j alone); the scale
    /// `s = c (1−d) (|Y| − ζ)/(ζ|Y|)` times w_ij; the sum in [`LANES`] partial sums by row
    /// position, added `(0 + 1) + (2 + 3)`. Loops of independent iterations vectorize and let
    /// the square roots and divisions of many bonds overlap (groups of four bonds gathered,
    /// scaled and summed in one loop measured 20 against 16 ms/step on the bench lattice).
    /// The row's neighbours are checked once ([`checked_row`]), so that its bonds read Y_j,
    /// w_ij and 1 − d without a check each.
    ///
    /// # Safety
    /// `bound` is from [`gather_bound`] over `self.y.len()` (or less), `volume` and `damage`;
    /// the contract of `breaker` ([`Breaker`]) holds for the row of i.
    #[inline(always)]
    unsafe fn row<V: VolumeRule, D: Integrity, B: Breaker>(
        self,
        i: usize,
        bound: usize,
        volume: V,
        damage: D,
        breaker: B,
        scratch: &mut RowBlock,
    ) -> ([f64; 3], usize) {
        let y = self.y;
        let yi = y[i];
        let range = self.bonds.range(i);
        let first = range.start;
        let (neighbors, lengths) = checked_row(self.bonds, range, bound);
        let mut sum = [[0.0; LANES]; 3];
        let mut broken = 0;
        for block_start in (0..neighbors.len()).step_by(ROW_BLOCK) {
            let count = (neighbors.len() - block_start).min(ROW_BLOCK);
            let block_neighbors = &neighbors[block_start..block_start + count];
            let zeta = &lengths[block_start..block_start + count];
            let first = first + block_start;
            let RowBlock { d, squared, weight } = scratch;
            // The gather alone (scalar loads); the arithmetic below runs over whole arrays.
            for (n, &j) in block_neighbors.iter().enumerate() {
                let j = j as usize;
                // SAFETY: j < bound <= y.len(), and below the volume rule's covered points
                // (`checked_row` with `gather_bound`).
                let (yj, w) = unsafe { (*y.get_unchecked(j), volume.of_unchecked(first + n, j)) };
                for k in 0..3 {
                    d[k][n] = yj[k];
                }
                weight[n] = w;
            }
            for n in 0..count {
                for k in 0..3 {
                    d[k][n] -= yi[k];
                }
                // q = dx*dx + dy*dy + dz*dz, the number the damage models test.
                squared[n] = d[0][n] * d[0][n] + d[1][n] * d[1][n] + d[2][n] * d[2][n];
            }
            if let Some(limit) = breaker.limit() {
                // The filter as a reduction over the block (it vectorizes); the rare block with
                // a bond it cannot clear tests that bond again, then exactly.
                let mut all_cleared = true;
                for n in 0..count {
                    all_cleared &= limit.certainly_intact(squared[n], zeta[n]);
                }
                if !all_cleared {
                    for n in 0..count {
                        // SAFETY: the bond is in the row of i (the breaker's contract).
                        if !limit.certainly_intact(squared[n], zeta[n])
                            && unsafe { breaker.damage(first + n) } < 1.0
                            && limit.exceeded(squared[n], zeta[n])
                        {
                            // SAFETY: as above.
                            broken += usize::from(unsafe { breaker.break_bond(first + n) });
                        }
                    }
                }
            }
            for n in 0..count {
                // SAFETY: the bond is in the row, below `bonds.neighbor.len()`, which `damage`
                // covers (`gather_bound`).
                let intact = unsafe { damage.intact_unchecked(first + n) };
                weight[n] *= bond_scale_squared(self.micromodulus * intact, zeta[n], squared[n]);
            }
            // ROW_BLOCK is a multiple of LANES, so bond n of the block is at row position
            // n mod LANES too.
            let full = count - count % LANES;
            for at in (0..full).step_by(LANES) {
                for k in 0..3 {
                    for lane in 0..LANES {
                        sum[k][lane] += weight[at + lane] * d[k][at + lane];
                    }
                }
            }
            for n in full..count {
                for k in 0..3 {
                    sum[k][n - full] += weight[n] * d[k][n];
                }
            }
        }
        (sum.map(|s| (s[0] + s[1]) + (s[2] + s[3])), broken)
    }
}

/// Bonds of a row handled per block of the closed-block loop (an interior row at m = 3 has
/// 122): a multiple of [`LANES`].
const ROW_BLOCK: usize = 64;

/// The arrays of one block of bonds of [`ClosedRows::row`], made once per chunk (zeroing them
/// for every block cost a tenth of the step) and overwritten, up to the block's length, by
/// every block.
struct RowBlock {
    /// Y_j, then Y_j − Y_i, by component.
    d: [[f64; ROW_BLOCK]; 3],
    /// q = |Y_j − Y_i|².
    squared: [f64; ROW_BLOCK],
    /// w_ij, then the bond's s·w_ij.
    weight: [f64; ROW_BLOCK],
}

impl Default for RowBlock {
    fn default() -> Self {
        Self {
            d: [[0.0; ROW_BLOCK]; 3],
            squared: [0.0; ROW_BLOCK],
            weight: [0.0; ROW_BLOCK],
        }
    }
}

/// The bond breaking the closed-block loop does before its forces (see [`ClosedRows::chunk`]).
///
/// # Contract of an implementation that breaks bonds
/// `damage` and `break_bond` access the bond-damage array of the loop's bond list through a
/// pointer; the loop only calls them for the bonds of the rows of the running chunk's points,
/// whose entries no other task reads or writes meanwhile; the damage reads of the force loop
/// go through the same pointer.
pub(super) trait Breaker: Copy + Send + Sync {
    /// The critical stretch to test, `None` when the loop breaks nothing.
    fn limit(self) -> Option<StretchLimit>;

    /// d of bond `b`.
    ///
    /// # Safety
    /// See the trait.
    unsafe fn damage(self, b: usize) -> f32;

    /// Sets d = 1 on bond `b`; returns whether it changed (it was intact or partly damaged).
    ///
    /// # Safety
    /// See the trait.
    unsafe fn break_bond(self, b: usize) -> bool;
}

/// The force loop alone (damage already up to date, or no damage).
#[derive(Clone, Copy)]
pub(super) struct NoBreaking;

impl Breaker for NoBreaking {
    #[inline(always)]
    fn limit(self) -> Option<StretchLimit> {
        None
    }

    unsafe fn damage(self, _b: usize) -> f32 {
        unreachable!("NoBreaking has no limit")
    }

    unsafe fn break_bond(self, _b: usize) -> bool {
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
    unsafe fn break_bond(self, b: usize) -> bool {
        // SAFETY: as the caller guarantees.
        unsafe { FusedCriticalStretch::break_bond(self, b) }
    }
}
