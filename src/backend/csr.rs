//! Compressed sparse row matrices: the form in which tangents reach every backend.

use rayon::prelude::*;

use crate::model::point_chunks::for_each_chunk;
use crate::tangent::BlockTangent;

/// A square or rectangular sparse matrix in compressed sparse row form with sorted, unique
/// column indices in each row. Row `r` holds `columns[offsets[r]..offsets[r + 1]]` and the
/// matching `values`. Indices are `usize` so problems past 2³¹ non-zeros (Peridigm's 32-bit
/// limit, its issue #144) need no special build.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Csr {
    /// Number of rows.
    pub nrows: usize,
    /// Number of columns.
    pub ncols: usize,
    /// Row start offsets (length `nrows + 1`, `offsets[0] == 0`).
    pub offsets: Vec<usize>,
    /// Column index of every stored entry, strictly increasing within a row.
    pub columns: Vec<usize>,
    /// Value of every stored entry.
    pub values: Vec<f64>,
}

impl Csr {
    /// Number of stored entries.
    pub fn nnz(&self) -> usize {
        self.values.len()
    }

    /// Bytes held by the index and value arrays (the figure solver reports print as the
    /// tangent's memory).
    pub fn memory_bytes(&self) -> usize {
        self.offsets.len() * std::mem::size_of::<usize>()
            + self.columns.len() * std::mem::size_of::<usize>()
            + self.values.len() * std::mem::size_of::<f64>()
    }

    /// The stored entries of row `r` as (columns, values).
    pub fn row(&self, r: usize) -> (&[usize], &[f64]) {
        let range = self.offsets[r]..self.offsets[r + 1];
        (&self.columns[range.clone()], &self.values[range])
    }

    /// Row `r` of A times x, summed in the row's column order.
    fn row_times(&self, r: usize, x: &[f64]) -> f64 {
        let (columns, values) = self.row(r);
        columns.iter().zip(values).map(|(&c, &v)| v * x[c]).sum()
    }

    /// Panics unless x has a value per column and y one per row (a bug of the caller).
    fn check_product_lengths(&self, x: &[f64], y: &[f64]) {
        check_product_shape(self.nrows, self.ncols, x, y);
    }

    /// y = A x.
    pub fn multiply(&self, x: &[f64], y: &mut [f64]) {
        self.check_product_lengths(x, y);
        for (r, y_r) in y.iter_mut().enumerate() {
            *y_r = self.row_times(r, x);
        }
    }

    /// y = A x, rows shared among rayon's threads once the matrix has at least
    /// [`Csr::PARALLEL_ROWS`] rows (below that, thread hand-off costs more than the product).
    /// Each row is summed by one thread in the same order as [`Csr::multiply`], so the result
    /// is bit-for-bit the serial one.
    pub fn multiply_parallel(&self, x: &[f64], y: &mut [f64]) {
        use rayon::prelude::*;
        if self.nrows < Self::PARALLEL_ROWS {
            self.multiply(x, y);
            return;
        }
        self.check_product_lengths(x, y);
        y.par_iter_mut()
            .with_min_len(1024)
            .enumerate()
            .for_each(|(r, y_r)| {
                *y_r = self.row_times(r, x);
            });
    }

    /// The true residual norm ‖b − A x‖₂ of `x` ([`Csr::multiply_parallel`], summed in row
    /// order), what solvers that work with an updated estimate report instead of it.
    pub fn residual_norm(&self, x: &[f64], b: &[f64]) -> f64 {
        let mut ax = vec![0.0; self.nrows];
        self.multiply_parallel(x, &mut ax);
        b.iter()
            .zip(&ax)
            .map(|(b, a)| (b - a) * (b - a))
            .sum::<f64>()
            .sqrt()
    }

    /// Row count from which [`Csr::multiply_parallel`] uses more than one thread.
    pub const PARALLEL_ROWS: usize = 4096;

    /// The diagonal entries (0 where a row stores none).
    pub fn diagonal(&self) -> Vec<f64> {
        (0..self.nrows.min(self.ncols))
            .map(|r| {
                let (columns, values) = self.row(r);
                columns.binary_search(&r).map_or(0.0, |k| values[k])
            })
            .collect()
    }

    /// Panics unless the structure is consistent (an internal invariant of whoever built it).
    pub fn assert_valid(&self) {
        assert_eq!(self.offsets.len(), self.nrows + 1);
        assert_eq!(self.offsets[0], 0);
        assert_eq!(*self.offsets.last().unwrap(), self.columns.len());
        assert_eq!(self.columns.len(), self.values.len());
        for r in 0..self.nrows {
            let (columns, _) = self.row(r);
            assert!(
                columns.windows(2).all(|w| w[0] < w[1]),
                "row {r} is not sorted"
            );
            assert!(
                columns.iter().all(|&c| c < self.ncols),
                "row {r} has a column out of range"
            );
        }
    }
}

/// A CSR matrix holding only the dense diagonal blocks (row-major per group).
pub fn block_diagonal_csr(groups: &[usize], blocks: &[f64]) -> Csr {
    let n = *groups.last().unwrap_or(&0);
    let mut matrix = Csr {
        nrows: n,
        ncols: n,
        offsets: vec![0],
        columns: Vec::new(),
        values: Vec::new(),
    };
    let mut at = 0;
    for g in groups.windows(2) {
        for _row in g[0]..g[1] {
            for column in g[0]..g[1] {
                matrix.columns.push(column);
                matrix.values.push(blocks[at]);
                at += 1;
            }
            matrix.offsets.push(matrix.columns.len());
        }
    }
    matrix
}

/// The conversion of an assembled tangent to the matrix the backends solve with. It is defined
/// here, beside [`Csr`], so that `tangent` (which the materials use) does not depend on the
/// backends.
impl BlockTangent {
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

/// Panics unless x has a value per column and y one per row of an `nrows` × `ncols` matrix
/// (a bug of the caller of a product y = A x).
pub(crate) fn check_product_shape(nrows: usize, ncols: usize, x: &[f64], y: &[f64]) {
    assert_eq!(x.len(), ncols, "x has the wrong length for this matrix");
    assert_eq!(y.len(), nrows, "y has the wrong length for this matrix");
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn multiply_and_diagonal_of_a_small_matrix() {
        // [[2, 0, 1], [0, 3, 0], [4, 0, 5]] written out by hand.
        let a = Csr {
            nrows: 3,
            ncols: 3,
            offsets: vec![0, 2, 3, 5],
            columns: vec![0, 2, 1, 0, 2],
            values: vec![2.0, 1.0, 3.0, 4.0, 5.0],
        };
        a.assert_valid();
        let mut y = vec![0.0; 3];
        a.multiply(&[1.0, 2.0, 3.0], &mut y);
        // Row sums by hand: 2·1 + 1·3, 3·2, 4·1 + 5·3.
        assert_eq!(y, vec![5.0, 6.0, 19.0]);
        assert_eq!(a.diagonal(), vec![2.0, 3.0, 5.0]);
        assert_eq!(a.nnz(), 5);
    }
}
