//! The AVX2 build of the closed-block row sum ([`ClosedRows::row`]), written with intrinsics.
//!
//! [`ClosedRows::row`] stages each block of bonds through arrays so that the compiler
//! vectorizes its loops; built for AVX2 it still spent 38 instructions per directed bond on the
//! bench lattice, most of them moving the staged values in and out of memory. Here four bonds
//! at a time stay in registers from the loads of Y_j to the partial sums.
//!
//! The result is bitwise that of [`ClosedRows::row`]: every bond evaluates the same IEEE
//! operations in the same order (q = (dx² + dy²) + dz², s = (c(1−d)·(|Y| − ζ))/(ζ|Y|), zero
//! when |Y| is not positive, then w·s, then the products added to partial sum n mod 4), the
//! critical-stretch filter and the exact test are those of
//! [`StretchLimit`](crate::damage::StretchLimit), and the partial
//! sums are combined `(0 + 1) + (2 + 3)`. The last `len mod 4` bonds of a row take the scalar
//! formulas of the same operations.

// LANES is the staged loop's: the partial sums must be the same (`lanes` returns four).
use super::{Breaker, ClosedRows};
use crate::material::avx2::{bond_lanes, broadcast, exceeding_lanes, lanes, BondLanes};
use crate::material::bond_based::{bond_scale_squared, LANES};
use crate::material::{checked_row, Integrity};
use crate::model::VolumeRule;
use std::arch::x86_64::{
    _mm256_add_pd, _mm256_and_pd, _mm256_cmp_pd, _mm256_div_pd, _mm256_loadu_pd, _mm256_mul_pd,
    _mm256_set1_pd, _mm256_setzero_pd, _mm256_sqrt_pd, _mm256_sub_pd, _CMP_GT_OQ,
};

/// [`ClosedRows::row`] with four bonds per register.
///
/// # Safety
/// The CPU supports AVX2; `bound` is from [`crate::material::gather_bound`] over
/// `rows.y.len()` (or less), `volume` and `damage`; the contract of `breaker` ([`Breaker`])
/// holds for the row of i.
#[target_feature(enable = "avx2")]
pub(super) unsafe fn row<V: VolumeRule, D: Integrity, B: Breaker>(
    rows: ClosedRows<'_>,
    i: usize,
    bound: usize,
    volume: V,
    damage: D,
    breaker: B,
) -> ([f64; 3], usize) {
    let yi = rows.y[i];
    let range = rows.bonds.range(i);
    let first = range.start;
    let (neighbors, lengths) = checked_row(rows.bonds, range, bound);
    let coordinates = rows.y.as_ptr().cast::<f64>();
    let origin = broadcast(yi);
    let micromodulus = _mm256_set1_pd(rows.micromodulus);
    let zero = _mm256_setzero_pd();
    let mut sum = [zero; 3];
    let mut broken = 0;
    let full = neighbors.len() - neighbors.len() % LANES;
    for at in (0..full).step_by(LANES) {
        let bond = first + at;
        // SAFETY: at + 4 <= full <= the row's length (both arrays); every neighbour is below
        // `bound` <= y.len() (`checked_row`).
        let BondLanes {
            zeta, d, squared, ..
        } = unsafe { bond_lanes(neighbors, lengths, at, coordinates, &origin) };
        if let Some(limit) = breaker.limit() {
            let exceeding = exceeding_lanes(limit, squared, zeta);
            for lane in (0..LANES).filter(|lane| exceeding & (1 << lane) != 0) {
                // SAFETY: the bond is in the row of i (the breaker's contract).
                if unsafe { breaker.damage(bond + lane) } < 1.0 {
                    // SAFETY: as above.
                    broken += usize::from(unsafe { breaker.break_bond(bond + lane) });
                }
            }
        }
        let mut intact = [0.0; LANES];
        let mut weight = [0.0; LANES];
        for lane in 0..LANES {
            // SAFETY: the bonds are in the row, below `bonds.neighbor.len()`, which `damage`
            // and `volume` cover, and their neighbours are below `bound` (`gather_bound`).
            unsafe {
                intact[lane] = damage.intact_unchecked(bond + lane);
                weight[lane] = volume.of_unchecked(bond + lane, neighbors[at + lane] as usize);
            }
        }
        // SAFETY: `intact` holds four f64.
        let pair = _mm256_mul_pd(micromodulus, unsafe { _mm256_loadu_pd(intact.as_ptr()) });
        let length = _mm256_sqrt_pd(squared);
        let scale = _mm256_div_pd(
            _mm256_mul_pd(pair, _mm256_sub_pd(length, zeta)),
            _mm256_mul_pd(zeta, length),
        );
        // s where |Y| > 0, +0 elsewhere (as `bond_scale_squared`).
        let scale = _mm256_and_pd(scale, _mm256_cmp_pd::<_CMP_GT_OQ>(length, zero));
        // SAFETY: `weight` holds four f64.
        let weight = _mm256_mul_pd(unsafe { _mm256_loadu_pd(weight.as_ptr()) }, scale);
        for k in 0..3 {
            sum[k] = _mm256_add_pd(sum[k], _mm256_mul_pd(weight, d[k]));
        }
    }
    let mut sum = [lanes(sum[0]), lanes(sum[1]), lanes(sum[2])];
    for n in full..neighbors.len() {
        let (b, j) = (first + n, neighbors[n] as usize);
        let yj = rows.y[j];
        let d = [yj[0] - yi[0], yj[1] - yi[1], yj[2] - yi[2]];
        let squared = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        let zeta = lengths[n];
        if let Some(limit) = breaker.limit() {
            // SAFETY: the bond is in the row of i (the breaker's contract).
            if !limit.certainly_intact(squared, zeta)
                && unsafe { breaker.damage(b) } < 1.0
                && limit.exceeded(squared, zeta)
            {
                // SAFETY: as above.
                broken += usize::from(unsafe { breaker.break_bond(b) });
            }
        }
        // SAFETY: as for the lanes above.
        let (intact, weight) = unsafe { (damage.intact_unchecked(b), volume.of_unchecked(b, j)) };
        let weight = weight * bond_scale_squared(rows.micromodulus * intact, zeta, squared);
        for k in 0..3 {
            sum[k][n - full] += weight * d[k];
        }
    }
    let total = |s: [f64; LANES]| (s[0] + s[1]) + (s[2] + s[3]);
    ([total(sum[0]), total(sum[1]), total(sum[2])], broken)
}
