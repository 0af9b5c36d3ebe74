//! Sorting a row of neighbour indices with a bitonic network in AVX2 registers.
//!
//! The grid visits a query's candidates cell by cell, so a row comes out unsorted; on the 100³
//! lattice sorting the rows was a tenth of the search (`core::slice::sort_unstable`, its
//! comparisons mostly unpredictable branches). Batcher's bitonic sorter (K. E. Batcher,
//! "Sorting networks and their applications", AFIPS 1968) compares fixed pairs in a fixed
//! order, so it has no data-dependent branch, and eight 32-bit lanes go through each
//! compare-exchange at once (`vpminud`/`vpmaxud`). Rows of 61 random indices, alternately in
//! one process on the development machine: 413 ns per row with `sort_unstable`, 115 ns here.
//!
//! A row of n ≤ 128 indices is loaded into the registers of the next size of 8, 16, 32, 64 or
//! 128 lanes (1 to 16 registers), the lanes past n filled with `u32::MAX`, and sorted there;
//! the padding sorts to the end, past the n lanes stored back. Sorting plain integers has only
//! one result, so the row is exactly what `sort_unstable` gives. Longer rows (horizons of more
//! than about four spacings) take `sort_unstable`.
//!
//! The network, for block sizes s = 2, 4, …, N (the form in which every stage puts the smaller
//! value first): a *flip* stage pairs position k of each block with position s − 1 − k, then
//! *half-cleaners* pair k with k + h for h = s/4, …, 1. Within a register the pairs come from
//! one lane permutation, a min, a max and a blend; across registers they are whole registers
//! (the flip reverses the lanes of the partner register).

use std::arch::x86_64::{
    __m256i, _mm256_blend_epi32, _mm256_blendv_epi8, _mm256_cmpgt_epi32, _mm256_loadu_si256,
    _mm256_maskload_epi32, _mm256_maskstore_epi32, _mm256_max_epu32, _mm256_min_epu32,
    _mm256_permutevar8x32_epi32, _mm256_set1_epi32, _mm256_setr_epi32, _mm256_storeu_si256,
};

/// 32-bit lanes per register.
const LANES: usize = 8;

/// Longest row the network sorts.
pub(super) const NETWORK_MAX: usize = 128;

/// Sorts `row` in increasing order.
///
/// # Safety
/// The CPU supports AVX2.
#[target_feature(enable = "avx2")]
pub(super) unsafe fn sort(row: &mut [u32]) {
    // SAFETY (all arms): AVX2, as the caller guarantees; each arm's register count holds the
    // row's length.
    unsafe {
        match row.len() {
            0..=1 => {}
            2..=8 => sort_padded::<1>(row),
            9..=16 => sort_padded::<2>(row),
            17..=32 => sort_padded::<4>(row),
            33..=64 => sort_padded::<8>(row),
            65..=NETWORK_MAX => sort_padded::<16>(row),
            _ => row.sort_unstable(),
        }
    }
}

/// Sorts a row of at most 8·`REGISTERS` indices through `REGISTERS` registers, loaded from
/// and stored to the row directly (a masked load and store for a last, partial register).
///
/// # Safety
/// The CPU supports AVX2; `row.len() <= LANES * REGISTERS <= NETWORK_MAX`.
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn sort_padded<const REGISTERS: usize>(row: &mut [u32]) {
    let n = row.len();
    let (full, rest) = (n / LANES, n % LANES);
    // All ones in the lanes below `rest`: the masked lanes' high bits.
    let partial = _mm256_cmpgt_epi32(
        _mm256_set1_epi32(rest as i32),
        _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7),
    );
    let padding = _mm256_set1_epi32(-1);
    let start = row.as_mut_ptr().cast::<i32>();
    let mut registers = [padding; REGISTERS];
    for (q, register) in registers.iter_mut().enumerate() {
        // SAFETY: below `full` the register's eight lanes lie within the row; at `full` the
        // masked load reads only the `rest` lanes that do (the others neither read nor fault).
        if q < full {
            *register = unsafe { _mm256_loadu_si256(start.add(LANES * q).cast()) };
        } else if q == full && rest > 0 {
            let loaded = unsafe { _mm256_maskload_epi32(start.add(LANES * q), partial) };
            *register = _mm256_blendv_epi8(padding, loaded, partial);
        }
    }
    bitonic_network(&mut registers);
    for (q, register) in registers.iter().enumerate() {
        // SAFETY: as for the loads.
        if q < full {
            unsafe { _mm256_storeu_si256(start.add(LANES * q).cast(), *register) };
        } else if q == full && rest > 0 {
            unsafe { _mm256_maskstore_epi32(start.add(LANES * q), partial, *register) };
        }
    }
}

/// The bitonic network over the 8·`REGISTERS` lanes of `registers`, register q holding
/// positions 8q to 8q + 7: afterwards they are in increasing order.
#[target_feature(enable = "avx2")]
#[inline]
fn bitonic_network<const REGISTERS: usize>(registers: &mut [__m256i; REGISTERS]) {
    // Block sizes 2, 4 and 8 lie within one register: each size's flip, then its half-cleaners
    // (size 4: distance 1; size 8: distances 2 and 1).
    for register in registers.iter_mut() {
        let mut v = *register;
        v = exchange_lanes::<0b1010_1010>(v, permutation(SWAP_NEIGHBOURS));
        v = exchange_lanes::<0b1100_1100>(v, permutation(FLIP_FOURS));
        v = exchange_lanes::<0b1010_1010>(v, permutation(SWAP_NEIGHBOURS));
        v = exchange_lanes::<0b1111_0000>(v, permutation(REVERSED_LANES));
        *register = half_cleaners_within_fours(v);
    }
    // Block sizes 16, 32, …: `span` registers per block.
    let mut span = 2;
    while span <= REGISTERS {
        for block in (0..REGISTERS).step_by(span) {
            for q in 0..span / 2 {
                let (low, high) = (block + q, block + span - 1 - q);
                let partner = reverse(registers[high]);
                let first = registers[low];
                registers[low] = _mm256_min_epu32(first, partner);
                registers[high] = reverse(_mm256_max_epu32(first, partner));
            }
        }
        let mut distance = span / 4;
        while distance >= 1 {
            for block in (0..REGISTERS).step_by(2 * distance) {
                for q in block..block + distance {
                    let (first, second) = (registers[q], registers[q + distance]);
                    registers[q] = _mm256_min_epu32(first, second);
                    registers[q + distance] = _mm256_max_epu32(first, second);
                }
            }
            distance /= 2;
        }
        for register in registers.iter_mut() {
            *register = half_cleaners_within(*register);
        }
        span *= 2;
    }
}

/// The half-cleaners at distances 4, 2 and 1, which lie within one register.
#[target_feature(enable = "avx2")]
#[inline]
fn half_cleaners_within(v: __m256i) -> __m256i {
    half_cleaners_within_fours(exchange_lanes::<0b1111_0000>(v, permutation(SWAP_HALVES)))
}

/// The half-cleaners at distances 2 and 1, which lie within each group of four lanes.
#[target_feature(enable = "avx2")]
#[inline]
fn half_cleaners_within_fours(v: __m256i) -> __m256i {
    let v = exchange_lanes::<0b1100_1100>(v, permutation(SWAP_PAIRS));
    exchange_lanes::<0b1010_1010>(v, permutation(SWAP_NEIGHBOURS))
}

/// Compare-exchange of each lane with lane `partner[lane]`: the lanes set in `HIGHER` keep the
/// larger of the two values, the others the smaller.
#[target_feature(enable = "avx2")]
#[inline]
fn exchange_lanes<const HIGHER: i32>(v: __m256i, partner: __m256i) -> __m256i {
    let other = _mm256_permutevar8x32_epi32(v, partner);
    _mm256_blend_epi32::<HIGHER>(_mm256_min_epu32(v, other), _mm256_max_epu32(v, other))
}

/// A lane permutation: lane k takes lane `lanes[k]`.
#[target_feature(enable = "avx2")]
#[inline]
fn permutation(lanes: [i32; LANES]) -> __m256i {
    let [a, b, c, d, e, f, g, h] = lanes;
    _mm256_setr_epi32(a, b, c, d, e, f, g, h)
}

/// Pairs lane k with lane k ± 1 within each pair of lanes.
const SWAP_NEIGHBOURS: [i32; LANES] = [1, 0, 3, 2, 5, 4, 7, 6];
/// Pairs lane k with lane 3 − k within each group of four.
const FLIP_FOURS: [i32; LANES] = [3, 2, 1, 0, 7, 6, 5, 4];
/// Pairs lane k with lane k ± 4.
const SWAP_HALVES: [i32; LANES] = [4, 5, 6, 7, 0, 1, 2, 3];
/// Pairs lane k with lane k ± 2 within each group of four.
const SWAP_PAIRS: [i32; LANES] = [2, 3, 0, 1, 6, 7, 4, 5];
/// Reverses the eight lanes.
const REVERSED_LANES: [i32; LANES] = [7, 6, 5, 4, 3, 2, 1, 0];

/// `v` with its lanes in reverse order.
#[target_feature(enable = "avx2")]
#[inline]
fn reverse(v: __m256i) -> __m256i {
    _mm256_permutevar8x32_epi32(v, permutation(REVERSED_LANES))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// xorshift64: deterministic test rows.
    fn rows(seed: u64) -> impl FnMut(usize, u32) -> Vec<u32> {
        let mut state = seed;
        move |n, range| {
            (0..n)
                .map(|_| {
                    state ^= state << 13;
                    state ^= state >> 7;
                    state ^= state << 17;
                    (state % u64::from(range)) as u32
                })
                .collect()
        }
    }

    #[test]
    fn the_network_sorts_as_sort_unstable_does() {
        if !crate::vector_width::wide_vectors_available() {
            return;
        }
        let mut row_of = rows(0x2545_f491_4f6c_dd1d);
        // Every length through the network's sizes and past them (sort_unstable there); wide
        // values, repeated values, and the largest indices next to the padding.
        for n in 0..=NETWORK_MAX + 12 {
            for range in [u32::MAX, 7, 200] {
                let mut row = row_of(n, range);
                if range == 7 {
                    row.iter_mut().for_each(|j| *j = u32::MAX - *j);
                }
                let mut expected = row.clone();
                expected.sort_unstable();
                // SAFETY: the CPU reports AVX2.
                unsafe { sort(&mut row) };
                assert_eq!(row, expected, "{n} indices in 0..{range}");
            }
        }
    }

    #[test]
    fn sorted_and_reversed_rows() {
        if !crate::vector_width::wide_vectors_available() {
            return;
        }
        for n in [2, 8, 9, 16, 33, 64, 65, 128] {
            let ascending: Vec<u32> = (0..n as u32).map(|j| 3 * j).collect();
            for mut row in [ascending.clone(), ascending.iter().rev().copied().collect()] {
                // SAFETY: the CPU reports AVX2.
                unsafe { sort(&mut row) };
                assert_eq!(row, ascending, "{n} indices");
            }
        }
    }
}
