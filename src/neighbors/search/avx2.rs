//! The AVX2 builds of the search's two hot loops.
//!
//! **The query's runs** ([`CellGrid::append_run_packed`]): eight candidate slots at a time,
//! the ball test gives an 8-bit mask, and the accepted point indices are packed to the front
//! of one 256-bit register by a permutation looked up from that mask ([`PACK_TABLE`]) and
//! stored at the end of the row in one go. The baseline build writes a byte mask and then
//! compacts the row one slot at a time with a store and a dependent index update per
//! candidate; on the 60³ lattice that compaction was about a fifth of the query's time. Here
//! it is one permute, one store and one popcount per eight candidates. The ball test is the
//! baseline's, operation for operation (q = (dx² + dy²) + dz² ≤ r², no fused multiply-add),
//! and the pack keeps slot order, so the rows are the same, element for element (a test
//! compares the two builds).
//!
//! **The reference lengths** of the filled rows ([`reference_lengths_wide`]): four bonds per
//! square root instruction instead of one, the same operations per bond, so the same lengths.

use super::grid::{CellGrid, Half, PACKED_LANES};
use super::shape::reference_lengths_from;
use std::arch::x86_64::{
    __m256d, __m256i, _mm256_add_pd, _mm256_castsi256_ps, _mm256_cmp_pd, _mm256_cmpgt_epi32,
    _mm256_loadu_pd, _mm256_loadu_si256, _mm256_movemask_pd, _mm256_movemask_ps, _mm256_mul_pd,
    _mm256_permutevar8x32_epi32, _mm256_set1_epi32, _mm256_set1_pd, _mm256_set_pd, _mm256_sqrt_pd,
    _mm256_storeu_pd, _mm256_storeu_si256, _mm256_sub_pd, _mm256_xor_si256, _CMP_LE_OQ,
};
use std::ops::Range;

/// For each 8-bit accept mask, the lanes whose bit is set, in increasing order, then zeros:
/// the permutation that packs the accepted lanes to the front.
static PACK_TABLE: [[u32; PACKED_LANES]; 1 << PACKED_LANES] = pack_table();

const fn pack_table() -> [[u32; PACKED_LANES]; 1 << PACKED_LANES] {
    let mut table = [[0u32; PACKED_LANES]; 1 << PACKED_LANES];
    let mut mask = 0;
    while mask < table.len() {
        let mut next = 0;
        let mut lane = 0;
        while lane < PACKED_LANES {
            if mask & (1 << lane) != 0 {
                table[mask][next] = lane as u32;
                next += 1;
            }
            lane += 1;
        }
        mask += 1;
    }
    table
}

impl CellGrid {
    /// Appends the points of the sorted slots `run` within the ball of squared radius
    /// `radius_squared` about `p` to `row`, in slot order; with [`Half::Upper`], only those of
    /// index above `i`, returning how many of index below `i` it found.
    ///
    /// # Safety
    /// The CPU supports AVX2; `run` lies within the grid's slots (the coordinate and index
    /// arrays extend [`PACKED_LANES`] − 1 entries beyond the last slot, so the last group of
    /// eight may read past `run.end`; those lanes are masked off).
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(super) unsafe fn append_run_packed(
        &self,
        run: Range<usize>,
        p: [f64; 3],
        radius_squared: f64,
        i: usize,
        half: Half,
        row: &mut Vec<u32>,
    ) -> usize {
        debug_assert!(run.end + PACKED_LANES - 1 <= self.index.len());
        // Room for a full store after the last accepted point.
        row.reserve(run.len() + PACKED_LANES);
        let used = row.len();
        let out = row.as_mut_ptr();
        let mut accepted = 0;
        let mut lower = 0;
        let (px, py, pz) = (
            _mm256_set1_pd(p[0]),
            _mm256_set1_pd(p[1]),
            _mm256_set1_pd(p[2]),
        );
        let radius_squared = _mm256_set1_pd(radius_squared);
        // Unsigned index comparisons as signed ones on values with the top bit flipped.
        let flip = _mm256_set1_epi32(i32::MIN);
        let own = _mm256_xor_si256(_mm256_set1_epi32(i as u32 as i32), flip);
        let (x, y, z) = (self.x.as_ptr(), self.y.as_ptr(), self.z.as_ptr());
        let index = self.index.as_ptr();
        let mut k = run.start;
        while k < run.end {
            // SAFETY: k + 8 ≤ run.end + 7 ≤ the arrays' length (the caller's contract); the
            // store lands within the capacity reserved above (accepted ≤ run.len()).
            unsafe {
                let mut within = ball_lanes(x, y, z, k, px, py, pz, radius_squared)
                    | ball_lanes(x, y, z, k + 4, px, py, pz, radius_squared) << 4;
                let left = run.end - k;
                if left < PACKED_LANES {
                    within &= (1 << left) - 1;
                }
                let indices = _mm256_loadu_si256(index.add(k).cast::<__m256i>());
                let keep = match half {
                    Half::Both => within,
                    Half::Upper => {
                        let flipped = _mm256_xor_si256(indices, flip);
                        let above = lane_mask(_mm256_cmpgt_epi32(flipped, own));
                        let below = lane_mask(_mm256_cmpgt_epi32(own, flipped));
                        lower += (within & below).count_ones() as usize;
                        within & above
                    }
                };
                let order = _mm256_loadu_si256(PACK_TABLE[keep as usize].as_ptr().cast());
                _mm256_storeu_si256(
                    out.add(used + accepted).cast::<__m256i>(),
                    _mm256_permutevar8x32_epi32(indices, order),
                );
                accepted += keep.count_ones() as usize;
            }
            k += PACKED_LANES;
        }
        // SAFETY: the first `accepted` entries after `used` were written above.
        unsafe { row.set_len(used + accepted) };
        lower
    }
}

/// `lengths[n]` = |X_j − X_i| for the neighbours j = `row[n]` of point i, four at a time:
/// ((dx² + dy²) + dz²)^½ with d = X_j − X_i, as the baseline loop evaluates it.
///
/// # Safety
/// The CPU supports AVX2.
#[target_feature(enable = "avx2")]
pub(super) unsafe fn reference_lengths_wide(
    positions: &[[f64; 3]],
    i: usize,
    row: &[u32],
    lengths: &mut [f64],
) {
    assert_eq!(row.len(), lengths.len());
    let x = positions[i];
    let full = row.len() - row.len() % 4;
    for (bonds, out) in row[..full].chunks_exact(4).zip(lengths.chunks_exact_mut(4)) {
        let p = [0, 1, 2, 3].map(|lane| positions[bonds[lane] as usize]);
        let d = [0, 1, 2].map(|k| {
            _mm256_sub_pd(
                _mm256_set_pd(p[3][k], p[2][k], p[1][k], p[0][k]),
                _mm256_set1_pd(x[k]),
            )
        });
        // SAFETY: `out` holds four f64.
        unsafe { _mm256_storeu_pd(out.as_mut_ptr(), _mm256_sqrt_pd(squared_lengths(d))) };
    }
    reference_lengths_from(positions, i, row, lengths, full);
}

/// The 4-bit mask of the slots `at..at + 4` whose point lies within the ball about (px, py,
/// pz): q = (dx² + dy²) + dz² ≤ r², as `squared_length` evaluates it.
///
/// # Safety
/// The CPU supports AVX2; the three arrays hold `at + 4` entries.
// A SIMD kernel inlined into the packing loop of `append_run_packed`: its eight arguments are
// that loop's three coordinate pointers, its slot and the query's four broadcast registers,
// which a struct would only carry under another name (and the loop is kept as it was measured).
#[allow(clippy::too_many_arguments)]
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn ball_lanes(
    x: *const f64,
    y: *const f64,
    z: *const f64,
    at: usize,
    px: __m256d,
    py: __m256d,
    pz: __m256d,
    radius_squared: __m256d,
) -> u32 {
    // SAFETY: the caller's contract.
    let d = unsafe {
        [
            _mm256_sub_pd(_mm256_loadu_pd(x.add(at)), px),
            _mm256_sub_pd(_mm256_loadu_pd(y.add(at)), py),
            _mm256_sub_pd(_mm256_loadu_pd(z.add(at)), pz),
        ]
    };
    _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_LE_OQ>(
        squared_lengths(d),
        radius_squared,
    )) as u32
}

/// q = (dx² + dy²) + dz² per lane, as `squared_length` evaluates it (no fused multiply-add):
/// the number both the ball test and the reference lengths take.
#[target_feature(enable = "avx2")]
#[inline]
fn squared_lengths(d: [__m256d; 3]) -> __m256d {
    _mm256_add_pd(
        _mm256_add_pd(_mm256_mul_pd(d[0], d[0]), _mm256_mul_pd(d[1], d[1])),
        _mm256_mul_pd(d[2], d[2]),
    )
}

/// The 8-bit mask of the 32-bit lanes of `v` whose top bit is set (a comparison's result).
#[target_feature(enable = "avx2")]
#[inline]
fn lane_mask(v: __m256i) -> u32 {
    _mm256_movemask_ps(_mm256_castsi256_ps(v)) as u32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pack_table_lists_each_masks_lanes_in_order() {
        assert_eq!(PACK_TABLE[0], [0; 8]);
        assert_eq!(PACK_TABLE[0b1111_1111], [0, 1, 2, 3, 4, 5, 6, 7]);
        assert_eq!(PACK_TABLE[0b1010_0110], [1, 2, 5, 7, 0, 0, 0, 0]);
        for (mask, lanes) in PACK_TABLE.iter().enumerate() {
            let set = (mask as u32).count_ones() as usize;
            assert!(lanes[..set].windows(2).all(|w| w[0] < w[1]));
            assert!(lanes[..set].iter().all(|&l| mask & (1 << l) != 0));
        }
    }

    #[test]
    fn the_wide_lengths_are_the_baseline_lengths_bitwise() {
        if !crate::vector_width::wide_vectors_available() {
            return;
        }
        // Irrational-looking coordinates so the square roots round; rows of every length
        // from 0 to 11 (full groups and tails).
        let positions: Vec<[f64; 3]> = (0..40)
            .map(|k| {
                let t = k as f64;
                [
                    (t * 0.731).sin() * 3.1,
                    (t * 1.37).cos() * 0.77,
                    t.sqrt() * 1e-3,
                ]
            })
            .collect();
        for length in 0..12 {
            let row: Vec<u32> = (0..length).map(|n| (7 * n as u32 + 3) % 40).collect();
            let mut wide = vec![0.0; length];
            let mut baseline = vec![0.0; length];
            // SAFETY: the CPU reports AVX2 (checked above).
            unsafe { reference_lengths_wide(&positions, 5, &row, &mut wide) };
            reference_lengths_from(&positions, 5, &row, &mut baseline, 0);
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&wide), bits(&baseline), "row of {length}");
        }
    }
}
