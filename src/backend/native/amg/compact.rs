//! The hierarchy's matrices as a cycle applies them: 32-bit values, and 32-bit column indices
//! stored once for each set of rows that shares them (the rows of a point or of an aggregate,
//! see [`pattern`](super::pattern)): about 5.3 bytes an entry on the finest level's transfers,
//! 4.7 on the coarse levels, instead of [`Csr`]'s 16.
//!
//! Applying the hierarchy is a handful of sparse products per Krylov iteration, each bound by
//! memory bandwidth, and the hierarchy is the largest thing an AMG-preconditioned
//! Jacobian-free run holds. Single precision is enough for a preconditioner: M⁻¹ only steers
//! the Krylov method, whose residuals are computed in double precision, and the products here
//! accumulate in double precision. Setup works on [`Csr`] in double precision throughout and
//! converts each matrix once it is final.

use rayon::prelude::*;

use super::super::super::csr::check_product_shape;
use super::super::super::{Csr, SolveError};
use super::pattern::GroupPattern;

/// A CSR matrix with `f32` values and `u32` columns shared by row sets (see the module docs).
#[derive(Debug, Clone)]
pub(super) struct CompactCsr {
    pub nrows: usize,
    pub ncols: usize,
    /// Row r's values are `values[offsets[r]..offsets[r + 1]]`.
    offsets: Vec<usize>,
    values: Vec<f32>,
    /// Row r's columns are those of its set, `set_of_row[r]`.
    set_of_row: Vec<u32>,
    /// Set k's columns are `columns[column_offsets[k]..column_offsets[k + 1]]`.
    column_offsets: Vec<usize>,
    columns: Vec<u32>,
}

impl CompactCsr {
    /// `a`, whose rows are grouped by `groups` (offsets; the rows of a group usually share
    /// their columns), with its values rounded to single precision.
    ///
    /// Errors (`Breakdown`): more rows or columns than 32-bit indices reach (2³² unknowns on
    /// one process, far beyond its memory).
    pub fn new(a: &Csr, groups: &[usize]) -> Result<Self, SolveError> {
        if u32::try_from(a.ncols.max(a.nrows)).is_err() {
            return Err(SolveError::Breakdown {
                method: "AMG",
                reason: format!(
                    "{} unknowns on one process exceed the 32-bit indices of the hierarchy; \
                     run on more MPI ranks",
                    a.ncols.max(a.nrows)
                ),
            });
        }
        let pattern = GroupPattern::of(a, groups);
        let mut set_of_row = vec![0u32; a.nrows];
        let mut column_offsets = Vec::with_capacity(pattern.row_sets.len());
        let mut columns = Vec::new();
        column_offsets.push(0);
        for (set, rows) in pattern.row_sets.windows(2).enumerate() {
            columns.extend(a.row(rows[0]).0.iter().map(|&c| c as u32));
            column_offsets.push(columns.len());
            set_of_row[rows[0]..rows[1]].fill(set as u32);
        }
        Ok(Self {
            nrows: a.nrows,
            ncols: a.ncols,
            offsets: a.offsets.clone(),
            values: a.values.iter().map(|&v| v as f32).collect(),
            set_of_row,
            column_offsets,
            columns,
        })
    }

    /// Number of stored entries.
    pub fn nnz(&self) -> usize {
        self.values.len()
    }

    /// Bytes held.
    pub fn memory_bytes(&self) -> usize {
        8 * (self.offsets.len() + self.column_offsets.len())
            + 4 * (self.values.len() + self.set_of_row.len() + self.columns.len())
    }

    /// y = A x, each row summed in double precision in its column order by one thread, so
    /// the result does not depend on the thread count.
    pub fn multiply_parallel(&self, x: &[f64], y: &mut [f64]) {
        check_product_shape(self.nrows, self.ncols, x, y);
        let row_times = |r: usize| -> f64 {
            let set = self.set_of_row[r] as usize;
            let columns = &self.columns[self.column_offsets[set]..self.column_offsets[set + 1]];
            columns
                .iter()
                .zip(&self.values[self.offsets[r]..self.offsets[r + 1]])
                .map(|(&c, &v)| f64::from(v) * x[c as usize])
                .sum()
        };
        if self.nrows < Csr::PARALLEL_ROWS {
            y.iter_mut()
                .enumerate()
                .for_each(|(r, y)| *y = row_times(r));
        } else {
            y.par_iter_mut()
                .with_min_len(1024)
                .enumerate()
                .for_each(|(r, y)| *y = row_times(r));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_product_is_the_double_precision_product_of_the_rounded_values() {
        // A = [[1/3, 0, 2], [0, 5, 0]]: 1/3 is not a single-precision number, so the product
        // row 0 is f32(1/3)·x₀ + 2·x₂ exactly, not x₀/3 + 2·x₂.
        let a = Csr {
            nrows: 2,
            ncols: 3,
            offsets: vec![0, 2, 3],
            columns: vec![0, 2, 1],
            values: vec![1.0 / 3.0, 2.0, 5.0],
        };
        let compact = CompactCsr::new(&a, &[0, 1, 2]).unwrap();
        let mut y = [0.0; 2];
        compact.multiply_parallel(&[3.0, 7.0, 0.5], &mut y);
        assert_eq!(y, [f64::from((1.0f64 / 3.0) as f32) * 3.0 + 1.0, 35.0]);
        assert_eq!(compact.nnz(), 3);
        // Offsets 3 × 8 B, set offsets 3 × 8 B, values 3 × 4 B, sets of rows 2 × 4 B, columns
        // 3 × 4 B.
        assert_eq!(compact.memory_bytes(), 24 + 24 + 12 + 8 + 12);
    }

    #[test]
    fn rows_of_a_group_share_their_columns_and_a_differing_group_keeps_its_own() {
        // Rows 0–2 (one group) share columns {0, 2, 3}; rows 3–4 (another group) differ.
        let a = Csr {
            nrows: 5,
            ncols: 4,
            offsets: vec![0, 3, 6, 9, 10, 12],
            columns: vec![0, 2, 3, 0, 2, 3, 0, 2, 3, 1, 1, 3],
            values: vec![
                1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0, 11.0, 12.0,
            ],
        };
        let compact = CompactCsr::new(&a, &[0, 3, 5]).unwrap();
        // One set of three rows, two sets of one: 3 + 1 + 2 stored columns for 12 entries.
        assert_eq!(compact.columns.len(), 6);
        let x = [0.5, -1.0, 2.0, 0.25];
        let mut y = [0.0; 5];
        compact.multiply_parallel(&x, &mut y);
        // All values are single-precision numbers, so the product is the exact CSR one.
        let mut expected = [0.0; 5];
        a.multiply(&x, &mut expected);
        assert_eq!(y, expected);
    }
}
