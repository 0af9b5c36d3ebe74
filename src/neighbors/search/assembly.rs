//! From searched rows to the compressed-sparse-row [`BondList`]: blocks of consecutive points
//! are searched in parallel into block-local buffers with their rows sorted there, then the
//! final arrays are filled block by block, each by the thread that owns it (first touch
//! there), with the reference lengths. [`assemble`] searches every row in full;
//! [`assemble_mirrored`] searches the upper half of each row and mirrors it into the lower.

use std::ops::Range;

use rayon::prelude::*;

use super::shape::reference_lengths_from;
use super::NeighborSearchError;
#[cfg(target_arch = "x86_64")]
use super::{avx2, bitonic};
use crate::model::BondList;

/// Points per parallel work item: large enough to amortise scheduling, small enough to balance
/// two to a few dozen threads on 1e5–1e7 points.
const BLOCK: usize = 8192;

/// The blocks of consecutive indices `0..n`, [`BLOCK`] each (the last one shorter).
fn blocks_of(n: usize) -> Vec<Range<usize>> {
    (0..n)
        .step_by(BLOCK)
        .map(|s| s..(s + BLOCK).min(n))
        .collect()
}

/// Sorted families of one block of consecutive points.
struct BlockRows {
    counts: Vec<u32>,
    neighbors: Vec<u32>,
}

/// Splits `data` into consecutive mutable pieces of the given lengths.
fn split_by_lengths<'a, T>(mut data: &'a mut [T], lengths: &[usize]) -> Vec<&'a mut [T]> {
    let mut pieces = Vec::with_capacity(lengths.len());
    for &length in lengths {
        let (head, tail) = data.split_at_mut(length);
        pieces.push(head);
        data = tail;
    }
    pieces
}

/// The CSR offsets of `n` rows of the lengths `counts`; an error when their bonds (4 bytes of
/// neighbour and 8 of length each) could not be addressed.
fn offsets_of(
    n: usize,
    counts: impl Iterator<Item = usize>,
) -> Result<Vec<usize>, NeighborSearchError> {
    let mut offsets = Vec::with_capacity(n + 1);
    offsets.push(0usize);
    let mut total = 0usize;
    for count in counts {
        total += count;
        offsets.push(total);
    }
    if total > isize::MAX as usize / 12 {
        return Err(NeighborSearchError::TooManyBonds(total as u128));
    }
    Ok(offsets)
}

/// Builds the CSR in one search pass: blocks of consecutive points are searched in parallel into
/// block-local buffers (`find_row` appends the unsorted neighbours of point i), rows sorted
/// there; then the final arrays are filled block by block with the reference lengths.
///
/// A count-then-fill scheme would avoid the buffers (≈ 4 bytes per bond extra) but search
/// twice; searching is the dearer part.
pub(super) fn assemble<S, I, F>(
    positions: &[[f64; 3]],
    rows: Option<&[u32]>,
    init: I,
    find_row: F,
) -> Result<BondList, NeighborSearchError>
where
    I: Fn() -> S + Sync + Send,
    F: Fn(&mut S, usize, &mut Vec<u32>) + Sync + Send,
{
    let n = rows.map_or(positions.len(), <[u32]>::len);
    let point = |k: usize| rows.map_or(k, |rows| rows[k] as usize);
    let blocks = blocks_of(n);
    let searched: Vec<BlockRows> = blocks
        .par_iter()
        .map_init(
            || (init(), Vec::with_capacity(1024), 0usize),
            |(state, row, last_size), block| {
                let mut counts = Vec::with_capacity(block.len());
                // The previous block's size is a good guess for this one's (same region).
                let mut neighbors = Vec::with_capacity(*last_size + *last_size / 8);
                for k in block.clone() {
                    row.clear();
                    find_row(state, point(k), row);
                    sort_row(row);
                    counts.push(row.len() as u32);
                    neighbors.extend_from_slice(row);
                }
                *last_size = neighbors.len();
                BlockRows { counts, neighbors }
            },
        )
        .collect();

    let counts = searched.iter().flat_map(|block| &block.counts);
    let offsets = offsets_of(n, counts.map(|&c| c as usize))?;
    // calloc: pages are zeroed lazily, so first touch happens in the parallel fill below.
    let mut neighbor = vec![0u32; offsets[n]];
    let mut reference_length = vec![0.0f64; offsets[n]];
    let block_bonds: Vec<usize> = searched.iter().map(|b| b.neighbors.len()).collect();
    let neighbor_pieces = split_by_lengths(&mut neighbor, &block_bonds);
    let length_pieces = split_by_lengths(&mut reference_length, &block_bonds);
    searched
        .into_par_iter()
        .zip(blocks)
        .zip(neighbor_pieces.into_par_iter().zip(length_pieces))
        .for_each(|((rows, block), (neighbors, lengths))| {
            neighbors.copy_from_slice(&rows.neighbors);
            let mut start = 0;
            for (k, &count) in block.zip(&rows.counts) {
                let end = start + count as usize;
                reference_lengths(
                    positions,
                    point(k),
                    &rows.neighbors[start..end],
                    &mut lengths[start..end],
                );
                start = end;
            }
        });
    Ok(BondList {
        offsets,
        neighbor,
        reference_length,
    })
}

/// Sorts a row of neighbour indices in increasing order: with AVX2 by a sorting network
/// ([`bitonic`], no data-dependent branches), else by `sort_unstable`; the same row either way.
fn sort_row(row: &mut [u32]) {
    if row.is_sorted() {
        return;
    }
    #[cfg(target_arch = "x86_64")]
    if crate::vector_width::wide_vectors_available() {
        // SAFETY: the CPU reports AVX2.
        return unsafe { bitonic::sort(row) };
    }
    row.sort_unstable();
}

/// `lengths[n]` = |X_j − X_i| for the neighbours j = `row[n]` of point i: with AVX2 four at
/// a time ([`avx2::reference_lengths_wide`], the same operations, so the same lengths).
///
/// Out of line, as it was compiled when the search was one file: inlined into the fills it
/// cost 40³ 2.035e9 → 2.047e9 instructions (cachegrind, the module doc's three searches).
#[inline(never)]
fn reference_lengths(positions: &[[f64; 3]], i: usize, row: &[u32], lengths: &mut [f64]) {
    #[cfg(target_arch = "x86_64")]
    if crate::vector_width::wide_vectors_available() {
        // SAFETY: the CPU reports AVX2.
        return unsafe { avx2::reference_lengths_wide(positions, i, row, lengths) };
    }
    reference_lengths_from(positions, i, row, lengths, 0);
}

/// How many neighbours of a sorted upper row lie in `block`, the row's own block of points:
/// they come first, the later blocks' neighbours after them.
fn in_block(row: &[u32], block: &Range<usize>) -> usize {
    row.partition_point(|&j| (j as usize) < block.end)
}

/// Keeps the neighbours of point i above i in `row` and returns how many were below.
pub(super) fn split_off_lower(i: usize, row: &mut Vec<u32>) -> usize {
    let before = row.len();
    row.retain(|&j| j as usize > i);
    before - row.len()
}

/// The upper half of the families of one block of consecutive points (mirrored assembly).
struct UpperRows {
    /// Per point: how many neighbours have a smaller index (they arrive by mirroring).
    lower_counts: Vec<u32>,
    /// Per point: how many neighbours have a larger index.
    upper_counts: Vec<u32>,
    /// The points' upper neighbours, row after row, each row sorted.
    upper: Vec<u32>,
    /// The mirror images of the upper bonds into later blocks, by destination block (entry
    /// `k` is block `this + 1 + k`): `[j − first point of the destination block, i − first
    /// point of this block]` for every bond i→j with j in that block, in increasing i. 16 bits
    /// suffice because [`BLOCK`] ≤ 2¹⁶. Bonds within the block need no record: the fill reads
    /// them from `upper`, whose rows list their own block's points first.
    mirrored: Vec<Vec<[u16; 2]>>,
}

const _: () = assert!(
    BLOCK <= 1 << 16,
    "mirror records store block-local indices in u16"
);

/// [`assemble`] for a symmetric neighbour test ([`super::is_mirrorable`]): `find_upper` appends
/// the neighbours of point i with a larger index, unsorted, and returns how many have a smaller
/// one, so each point sorts only half its row; every kept bond i→j whose j lies in a later
/// block is also recorded for that block as the mirrored bond j→i. Then each block of rows is
/// filled by the thread that owns it (first touch there). The result is the full search's,
/// bond for bond: the lower count a point finds itself equals the mirrored bonds it receives,
/// which is checked.
pub(super) fn assemble_mirrored<S, I, F>(
    positions: &[[f64; 3]],
    init: I,
    find_upper: F,
) -> Result<BondList, NeighborSearchError>
where
    I: Fn() -> S + Sync + Send,
    F: Fn(&mut S, usize, &mut Vec<u32>) -> usize + Sync + Send,
{
    let n = positions.len();
    let blocks = blocks_of(n);
    let searched = search_upper_rows(&blocks, init, find_upper);
    let counts = searched.iter().flat_map(|block| {
        let lower_and_upper = block.lower_counts.iter().zip(&block.upper_counts);
        lower_and_upper.map(|(&lower, &upper)| lower as usize + upper as usize)
    });
    let offsets = offsets_of(n, counts)?;
    // calloc: pages are zeroed lazily, so first touch happens in the parallel fill below.
    let mut neighbor = vec![0u32; offsets[n]];
    let mut reference_length = vec![0.0f64; offsets[n]];
    let block_bonds: Vec<usize> = blocks
        .iter()
        .map(|block| offsets[block.end] - offsets[block.start])
        .collect();
    let neighbor_pieces = split_by_lengths(&mut neighbor, &block_bonds);
    let length_pieces = split_by_lengths(&mut reference_length, &block_bonds);
    let offsets_ref = &offsets;
    let searched_ref = &searched;
    // Block d of rows is filled by the thread that owns it: first the mirrored bonds, taken
    // from the earlier blocks in increasing order and, within one, in increasing i; then, row
    // by row in increasing i, the row's own upper part, whose bonds within the block are
    // mirrored into the later rows as it goes; so each row's lower part comes out sorted
    // without a sort.
    blocks
        .into_par_iter()
        .enumerate()
        .zip(neighbor_pieces.into_par_iter().zip(length_pieces))
        .for_each(|((d, block), (neighbors, lengths))| {
            let base = offsets_ref[block.start];
            let mut cursor: Vec<usize> = block.clone().map(|i| offsets_ref[i] - base).collect();
            for (b, source) in searched_ref[..d].iter().enumerate() {
                let Some(records) = source.mirrored.get(d - b - 1) else {
                    continue;
                };
                let first = b * BLOCK;
                for &[j, i] in records {
                    let slot = &mut cursor[j as usize];
                    neighbors[*slot] = (first + i as usize) as u32;
                    *slot += 1;
                }
            }
            let own = &searched_ref[d];
            let mut taken = 0;
            for (k, i) in block.clone().enumerate() {
                let lower = own.lower_counts[k] as usize;
                let upper = &own.upper[taken..taken + own.upper_counts[k] as usize];
                taken += upper.len();
                let start = offsets_ref[i] - base;
                // Row i's lower part is complete: the earlier blocks' records came above, and
                // this block's rows before i have mirrored their bonds into it.
                assert_eq!(
                    cursor[k],
                    start + lower,
                    "point {i}: the neighbour test is not symmetric"
                );
                let end = start + lower + upper.len();
                neighbors[start + lower..end].copy_from_slice(upper);
                // The sorted upper row holds this block's points first; each receives i after
                // every earlier block's points and after this block's smaller indices.
                for &j in &upper[..in_block(upper, &block)] {
                    let slot = &mut cursor[j as usize - block.start];
                    neighbors[*slot] = i as u32;
                    *slot += 1;
                }
                reference_lengths(
                    positions,
                    i,
                    &neighbors[start..end],
                    &mut lengths[start..end],
                );
            }
        });
    Ok(BondList {
        offsets,
        neighbor,
        reference_length,
    })
}

/// The search of [`assemble_mirrored`]: the upper rows of every block, sorted, with their
/// lower counts and the mirror records of the bonds into later blocks.
fn search_upper_rows<S, I, F>(blocks: &[Range<usize>], init: I, find_upper: F) -> Vec<UpperRows>
where
    I: Fn() -> S + Sync + Send,
    F: Fn(&mut S, usize, &mut Vec<u32>) -> usize + Sync + Send,
{
    blocks
        .par_iter()
        .enumerate()
        .map_init(
            || (init(), Vec::with_capacity(1024), 0usize),
            |(state, row, last_size), (b, block)| {
                let mut lower_counts = Vec::with_capacity(block.len());
                let mut upper_counts = Vec::with_capacity(block.len());
                let mut upper = Vec::with_capacity(*last_size + *last_size / 8);
                let mut mirrored: Vec<Vec<[u16; 2]>> = Vec::new();
                for i in block.clone() {
                    row.clear();
                    let below = find_upper(state, i, row);
                    sort_row(row);
                    lower_counts.push(below as u32);
                    upper_counts.push(row.len() as u32);
                    upper.extend_from_slice(row);
                    let source = (i - block.start) as u16;
                    for &j in &row[in_block(row, block)..] {
                        let j = j as usize;
                        let k = j / BLOCK - b - 1;
                        if k >= mirrored.len() {
                            mirrored.resize_with(k + 1, Vec::new);
                        }
                        mirrored[k].push([(j % BLOCK) as u16, source]);
                    }
                }
                *last_size = upper.len();
                UpperRows {
                    lower_counts,
                    upper_counts,
                    upper,
                    mirrored,
                }
            },
        )
        .collect()
}
