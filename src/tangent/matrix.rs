//! The assembled tangent in 3×3 blocks and its conversion to a scalar CSR matrix.

use std::sync::Arc;

use rayon::prelude::*;

use super::{Block, BlockPattern};
use crate::backend::Csr;
use crate::model::point_chunks::for_each_chunk;

/// J_ij = ∂(V_i f_i)/∂u_j: the Jacobian of the residual r_i = V_i (f_i + b_i) with respect to
/// the displacement (force/length), one 3×3 block per pattern entry. For an elastic body it is
/// symmetric and negative semi-definite; the stiffness the linear solvers see is K = −J.
///
/// `blocks[pattern.offsets()[i] + p]` is block (i, `pattern.row(i)[p]`), and within a block
/// `block[k][l] = ∂(V_i f_i)_k / ∂(u_j)_l`.
#[derive(Debug, Clone)]
pub struct BlockTangent {
    /// The sparsity pattern (shared: one pattern serves every assembly of a run).
    pub pattern: Arc<BlockPattern>,
    /// One block per pattern entry, in pattern order.
    pub blocks: Vec<Block>,
}

impl BlockTangent {
    /// All blocks zero.
    pub fn zeros(pattern: Arc<BlockPattern>) -> Self {
        let blocks = vec![[[0.0; 3]; 3]; pattern.num_blocks()];
        Self { pattern, blocks }
    }

    /// Block (i, j), or `None` when the pattern does not store it.
    pub fn block(&self, i: usize, j: usize) -> Option<&Block> {
        self.pattern.position(i, j).map(|p| &self.blocks[p])
    }

    /// Sets every block to zero (keeps the pattern and the allocation).
    pub fn fill_zero(&mut self) {
        self.blocks.par_iter_mut().for_each(|b| *b = [[0.0; 3]; 3]);
    }

    /// Bytes held by the blocks and the pattern.
    pub fn memory_bytes(&self) -> usize {
        self.blocks.len() * std::mem::size_of::<Block>() + self.pattern.memory_bytes()
    }

    /// Scalar CSR over the kept dofs, every entry multiplied by `scale` (−1 gives the stiffness
    /// K = −J).
    ///
    /// `dof_index[3*i + k]` is the row and column of displacement component k of point i in the
    /// reduced system, or `None` when that dof is eliminated (a prescribed displacement): its
    /// row and column are dropped. The kept dofs must be numbered 0..n_kept, each once; when
    /// the numbering increases with 3i + k (the usual case) the conversion runs in parallel,
    /// otherwise rows are filled one after another and their columns sorted.
    ///
    /// Every entry of a stored block becomes a stored entry (explicit zeros included), so the
    /// structure depends only on the pattern and `dof_index`, not on the values.
    ///
    /// # Panics
    /// If `dof_index` does not have 3 entries per point or its kept numbers are not 0..n_kept
    /// each once (a bug of the caller, not user input).
    pub fn to_csr(&self, dof_index: &[Option<usize>], scale: f64) -> Csr {
        let n = self.pattern.num_points();
        assert_eq!(
            dof_index.len(),
            3 * n,
            "dof_index needs 3 entries per point ({n} points)"
        );
        let kept = check_kept_numbering(dof_index);
        let offsets = self.row_offsets(dof_index, kept);
        let nnz = offsets[kept];
        let mut columns = vec![0usize; nnz];
        let mut values = vec![0.0; nnz];
        let fill = CsrFill {
            tangent: self,
            dof_index,
            scale,
            offsets: &offsets,
        };
        let increasing = dof_index
            .iter()
            .flatten()
            .zip(dof_index.iter().flatten().skip(1))
            .all(|(a, b)| a < b);
        if increasing {
            fill.in_parallel(&mut columns, &mut values);
        } else {
            fill.row_by_row(&mut columns, &mut values);
        }
        Csr {
            nrows: kept,
            ncols: kept,
            offsets,
            columns,
            values,
        }
    }

    /// Row starts of the reduced CSR (`kept + 1` entries): a row's length is the number of
    /// kept components of its point's block columns.
    fn row_offsets(&self, dof_index: &[Option<usize>], kept: usize) -> Vec<usize> {
        let pattern = &*self.pattern;
        let n = pattern.num_points();
        // Kept components per point, so that a row's length is a sum over its block columns.
        let kept_of = |j: usize| dof_index[3 * j..3 * j + 3].iter().flatten().count();
        let row_length: Vec<usize> = (0..n)
            .into_par_iter()
            .map(|i| pattern.row(i).iter().map(|&j| kept_of(j as usize)).sum())
            .collect();
        let mut lengths = vec![0usize; kept];
        for i in 0..n {
            for r in dof_index[3 * i..3 * i + 3].iter().flatten() {
                lengths[*r] = row_length[i];
            }
        }
        let mut offsets = Vec::with_capacity(kept + 1);
        let mut total = 0;
        offsets.push(total);
        for len in &lengths {
            total += len;
            offsets.push(total);
        }
        offsets
    }
}

/// The number of kept dofs, after checking that `dof_index` numbers them 0..kept, each once.
///
/// # Panics
/// If it does not (a bug of the caller, not user input).
fn check_kept_numbering(dof_index: &[Option<usize>]) -> usize {
    let kept = dof_index.iter().flatten().count();
    let mut seen = vec![false; kept];
    for &r in dof_index.iter().flatten() {
        assert!(
            r < kept && !seen[r],
            "dof_index must number the {kept} kept dofs 0..{kept}, each once (found {r})"
        );
        seen[r] = true;
    }
    kept
}

/// The entries of a [`BlockTangent::to_csr`] conversion under way.
struct CsrFill<'a> {
    tangent: &'a BlockTangent,
    dof_index: &'a [Option<usize>],
    scale: f64,
    /// Row starts of the reduced CSR.
    offsets: &'a [usize],
}

impl CsrFill<'_> {
    /// Writes the entries of reduced row `r` (dof k of point i) into the row's slices.
    fn row(&self, i: usize, k: usize, cols: &mut [usize], vals: &mut [f64]) {
        let pattern = &*self.tangent.pattern;
        let mut e = 0;
        let first = pattern.offsets()[i];
        for (p, &j) in pattern.row(i).iter().enumerate() {
            let block = &self.tangent.blocks[first + p];
            for (l, &entry) in block[k].iter().enumerate() {
                if let Some(c) = self.dof_index[3 * j as usize + l] {
                    cols[e] = c;
                    vals[e] = self.scale * entry;
                    e += 1;
                }
            }
        }
        debug_assert_eq!(e, cols.len());
    }

    /// The numbering increases with 3i + k: point i's rows are contiguous and follow point
    /// i−1's, so the arrays split at the first entry of each point's first kept row and the
    /// points fill their rows in parallel.
    fn in_parallel(&self, columns: &mut [usize], values: &mut [f64]) {
        let (dof_index, offsets) = (self.dof_index, self.offsets);
        let n = self.tangent.pattern.num_points();
        let nnz = columns.len();
        let mut start = vec![nnz; n + 1];
        for i in (0..n).rev() {
            start[i] = match dof_index[3 * i..3 * i + 3].iter().flatten().next() {
                Some(&r) => offsets[r],
                None => start[i + 1],
            };
        }
        let points: Vec<u32> = (0..n as u32).collect();
        for_each_chunk(
            &points,
            (columns, values),
            &|i| start[i as usize],
            &|chunk: &[u32], base: usize, (cols, vals): (&mut [usize], &mut [f64])| {
                for &i in chunk {
                    let i = i as usize;
                    for k in 0..3 {
                        if let Some(r) = dof_index[3 * i + k] {
                            let range = offsets[r] - base..offsets[r + 1] - base;
                            self.row(i, k, &mut cols[range.clone()], &mut vals[range]);
                        }
                    }
                }
            },
        );
    }

    /// Any other numbering: rows are filled one after another and their columns sorted.
    fn row_by_row(&self, columns: &mut [usize], values: &mut [f64]) {
        let (dof_index, offsets) = (self.dof_index, self.offsets);
        let n = self.tangent.pattern.num_points();
        let mut order = Vec::new();
        for i in 0..n {
            for k in 0..3 {
                if let Some(r) = dof_index[3 * i + k] {
                    let range = offsets[r]..offsets[r + 1];
                    self.row(
                        i,
                        k,
                        &mut columns[range.clone()],
                        &mut values[range.clone()],
                    );
                    order.clear();
                    order.extend(
                        columns[range.clone()]
                            .iter()
                            .copied()
                            .zip(values[range.clone()].iter().copied()),
                    );
                    order.sort_unstable_by_key(|&(c, _)| c);
                    for (e, (c, v)) in range.zip(order.iter()) {
                        columns[e] = *c;
                        values[e] = *v;
                    }
                }
            }
        }
    }
}
