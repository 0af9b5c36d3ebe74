//! The hierarchy's matrices as a cycle applies them: 32-bit column indices and 32-bit values,
//! 8 bytes an entry instead of [`Csr`]'s 16.
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

/// A CSR matrix with `u32` columns and `f32` values (see the module docs).
#[derive(Debug, Clone)]
pub(super) struct CompactCsr {
    pub nrows: usize,
    pub ncols: usize,
    offsets: Vec<usize>,
    columns: Vec<u32>,
    values: Vec<f32>,
}

impl CompactCsr {
    /// `a` with its values rounded to single precision.
    ///
    /// Errors (`Breakdown`): more columns than 32-bit indices reach (2³² unknowns on one
    /// process, far beyond its memory).
    pub fn new(a: &Csr) -> Result<Self, SolveError> {
        if u32::try_from(a.ncols).is_err() {
            return Err(SolveError::Breakdown {
                method: "AMG",
                reason: format!(
                    "{} unknowns on one process exceed the 32-bit column indices of the \
                     hierarchy; run on more MPI ranks",
                    a.ncols
                ),
            });
        }
        Ok(Self {
            nrows: a.nrows,
            ncols: a.ncols,
            offsets: a.offsets.clone(),
            columns: a.columns.iter().map(|&c| c as u32).collect(),
            values: a.values.iter().map(|&v| v as f32).collect(),
        })
    }

    /// Number of stored entries.
    pub fn nnz(&self) -> usize {
        self.values.len()
    }

    /// Bytes held.
    pub fn memory_bytes(&self) -> usize {
        8 * self.offsets.len() + 4 * self.columns.len() + 4 * self.values.len()
    }

    /// y = A x, each row summed in double precision in its column order by one thread, so
    /// the result does not depend on the thread count.
    pub fn multiply_parallel(&self, x: &[f64], y: &mut [f64]) {
        check_product_shape(self.nrows, self.ncols, x, y);
        let row_times = |r: usize| -> f64 {
            let range = self.offsets[r]..self.offsets[r + 1];
            self.columns[range.clone()]
                .iter()
                .zip(&self.values[range])
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
        let compact = CompactCsr::new(&a).unwrap();
        let mut y = [0.0; 2];
        compact.multiply_parallel(&[3.0, 7.0, 0.5], &mut y);
        assert_eq!(y, [f64::from((1.0f64 / 3.0) as f32) * 3.0 + 1.0, 35.0]);
        assert_eq!(compact.nnz(), 3);
        assert_eq!(compact.memory_bytes(), 8 * 3 + 4 * 3 + 4 * 3);
    }
}
