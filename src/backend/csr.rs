//! Compressed sparse row matrices: the form in which tangents reach every backend.

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

    /// y = A x.
    pub fn multiply(&self, x: &[f64], y: &mut [f64]) {
        assert_eq!(
            x.len(),
            self.ncols,
            "x has the wrong length for this matrix"
        );
        assert_eq!(
            y.len(),
            self.nrows,
            "y has the wrong length for this matrix"
        );
        for (r, y_r) in y.iter_mut().enumerate() {
            let (columns, values) = self.row(r);
            *y_r = columns.iter().zip(values).map(|(&c, &v)| v * x[c]).sum();
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
        assert_eq!(
            x.len(),
            self.ncols,
            "x has the wrong length for this matrix"
        );
        assert_eq!(
            y.len(),
            self.nrows,
            "y has the wrong length for this matrix"
        );
        y.par_iter_mut()
            .with_min_len(1024)
            .enumerate()
            .for_each(|(r, y_r)| {
                let (columns, values) = self.row(r);
                *y_r = columns.iter().zip(values).map(|(&c, &v)| v * x[c]).sum();
            });
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
