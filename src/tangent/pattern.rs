//! Which 3×3 blocks of the tangent can be non-zero.

use rayon::prelude::*;

use crate::model::BondList;

/// The block sparsity pattern of a tangent: for every point i (a block row) the sorted list of
/// points j whose displacement can change the force on i, diagonal included.
///
/// Stored in compressed-sparse-row form over points: row i is
/// `columns[offsets[i]..offsets[i + 1]]`, and block number `offsets[i] + p` of a
/// [`BlockTangent`](super::BlockTangent) is the pair (i, `columns[offsets[i] + p]`).
///
/// The families must be symmetric (j in i's family iff i in j's), as the force kernels already
/// require ([`crate::material`] module docs).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BlockPattern {
    offsets: Vec<usize>,
    columns: Vec<u32>,
    /// Built by [`BlockPattern::diagonal`]: only J_ii is wanted and the assembly drops the other
    /// blocks on purpose instead of reporting a pattern that is too small.
    diagonal_only: bool,
}

impl BlockPattern {
    /// Row i = {i} ∪ family(i): every pair joined by a bond. Enough for bond-based materials,
    /// whose bond force depends only on the two ends.
    pub fn one_hop(bonds: &BondList) -> Self {
        let rows = (0..bonds.num_points())
            .into_par_iter()
            .map(|i| {
                let mut row = Vec::with_capacity(bonds.family_size(i) + 1);
                row.push(i as u32);
                row.extend_from_slice(bonds.family(i));
                row.sort_unstable();
                row.dedup();
                row
            })
            .collect();
        Self::from_rows(rows)
    }

    /// Row i = every point that shares a family with i: ⋃ over j ∈ {i} ∪ family(i) of
    /// {j} ∪ family(j). A state-based force state T⟨x_j⟩ (LPS: through the dilatation θ_j)
    /// depends on all of j's family and acts on all of it, so every two points of one closed
    /// family are coupled (Peridigm's `FULL_MATRIX` Jacobian, `Peridigm_Material.hpp`).
    pub fn two_hop(bonds: &BondList) -> Self {
        let n = bonds.num_points();
        let rows = (0..n)
            .into_par_iter()
            .map_init(
                || vec![false; n],
                |mark, i| {
                    let mut row = Vec::new();
                    two_hop_row(bonds, i, mark, &mut row);
                    row.sort_unstable();
                    row
                },
            )
            .collect();
        Self::from_rows(rows)
    }

    /// Row i = {i} only: the pattern of a block-diagonal tangent (block-Jacobi preconditioning).
    /// Assembling into it keeps J_ii and drops every other block.
    pub fn diagonal(num_points: usize) -> Self {
        Self {
            offsets: (0..=num_points).collect(),
            columns: (0..num_points as u32).collect(),
            diagonal_only: true,
        }
    }

    /// Concatenates sorted, duplicate-free rows (built once per run, so a vector per row is
    /// affordable; the columns are 4 bytes per block against 72 for the block values).
    fn from_rows(rows: Vec<Vec<u32>>) -> Self {
        let mut offsets = Vec::with_capacity(rows.len() + 1);
        offsets.push(0);
        for row in &rows {
            offsets.push(offsets.last().unwrap() + row.len());
        }
        let mut columns = Vec::with_capacity(*offsets.last().unwrap());
        for row in rows {
            debug_assert!(row.windows(2).all(|w| w[0] < w[1]));
            columns.extend_from_slice(&row);
        }
        Self {
            offsets,
            columns,
            diagonal_only: false,
        }
    }

    /// Number of points (block rows).
    pub fn num_points(&self) -> usize {
        self.offsets.len() - 1
    }

    /// Number of stored 3×3 blocks.
    pub fn num_blocks(&self) -> usize {
        self.columns.len()
    }

    /// The sorted block columns (point indices) of row `i`.
    pub fn row(&self, i: usize) -> &[u32] {
        &self.columns[self.offsets[i]..self.offsets[i + 1]]
    }

    /// Index of row `i`'s first block in [`BlockTangent::blocks`](super::BlockTangent::blocks)
    /// (`offsets()[num_points]` = [`BlockPattern::num_blocks`]).
    pub fn offsets(&self) -> &[usize] {
        &self.offsets
    }

    /// Index of block (i, j) in [`BlockTangent::blocks`](super::BlockTangent::blocks), if stored.
    pub fn position(&self, i: usize, j: usize) -> Option<usize> {
        let j = u32::try_from(j).ok()?;
        self.row(i)
            .binary_search(&j)
            .ok()
            .map(|p| self.offsets[i] + p)
    }

    /// True for [`BlockPattern::diagonal`].
    pub fn is_diagonal_only(&self) -> bool {
        self.diagonal_only
    }

    /// Bytes held by the index arrays.
    pub fn memory_bytes(&self) -> usize {
        self.offsets.len() * std::mem::size_of::<usize>()
            + self.columns.len() * std::mem::size_of::<u32>()
    }
}

/// Pushes the points of ⋃_{j ∈ {i} ∪ family(i)} ({j} ∪ family(j)) into the cleared `row`
/// (unsorted, unique), using `mark` (all false on entry and on return).
fn two_hop_row(bonds: &BondList, i: usize, mark: &mut [bool], row: &mut Vec<u32>) {
    row.clear();
    let mut add = |k: u32, row: &mut Vec<u32>| {
        if !mark[k as usize] {
            mark[k as usize] = true;
            row.push(k);
        }
    };
    for &j in std::iter::once(&(i as u32)).chain(bonds.family(i)) {
        add(j, row);
        for &k in bonds.family(j as usize) {
            add(k, row);
        }
    }
    for &k in row.iter() {
        mark[k as usize] = false;
    }
}
