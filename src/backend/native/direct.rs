//! Sparse direct solvers from faer: supernodal/simplicial Cholesky (LLᵀ) for SPD tangents and
//! LU with partial pivoting for the rest. The fill-reducing ordering and symbolic analysis are
//! kept while the sparsity pattern stays the same — Newton refactors one pattern many times —
//! and redone when it changes (e.g. bonds broke).
//!
//! The [`Csr`] arrays are handed to faer without copying by reading them as compressed sparse
//! *column* storage, which is the storage of Aᵀ: Cholesky needs no change for a symmetric A, and
//! LU factors Aᵀ and solves with its transpose.

use faer::linalg::solvers::Solve;
use faer::sparse::linalg::{LltError, LuError};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::MatMut;

use super::super::{Csr, KrylovReport, LinearResult, LinearSolver, SolveError};
use super::check_matrix;

/// The sparsity pattern a symbolic analysis was made for.
#[derive(Debug, Clone)]
struct Pattern {
    nrows: usize,
    offsets: Vec<usize>,
    columns: Vec<usize>,
}

impl Pattern {
    fn of(matrix: &Csr) -> Self {
        Self {
            nrows: matrix.nrows,
            offsets: matrix.offsets.clone(),
            columns: matrix.columns.clone(),
        }
    }

    fn matches(&self, matrix: &Csr) -> bool {
        self.nrows == matrix.nrows
            && self.offsets == matrix.offsets
            && self.columns == matrix.columns
    }
}

/// The matrix's arrays seen as faer's column storage of its transpose.
fn transpose_view(matrix: &Csr) -> SparseColMatRef<'_, usize, f64> {
    let symbolic = SymbolicSparseColMatRef::new_checked(
        matrix.ncols,
        matrix.nrows,
        &matrix.offsets,
        None,
        &matrix.columns,
    );
    SparseColMatRef::new(symbolic, &matrix.values)
}

/// ‖b − A x‖/‖b‖ for the report (0 when b = 0).
fn relative_residual(matrix: &Csr, rhs: &[f64], x: &[f64]) -> f64 {
    let residual = matrix.residual_norm(x, rhs);
    let rhs_norm = rhs.iter().map(|b| b * b).sum::<f64>().sqrt();
    if rhs_norm == 0.0 {
        0.0
    } else {
        residual / rhs_norm
    }
}

fn out_of_memory(method: &'static str, error: impl std::fmt::Debug) -> SolveError {
    SolveError::Breakdown {
        method,
        reason: format!(
            "the factorization could not be allocated ({error:?}); use CG or GMRES for this size"
        ),
    }
}

/// Sparse Cholesky A = LLᵀ for symmetric positive definite matrices (the tangent of a stable
/// structure with enough constraints). Reads the upper triangle of each row (the matrix is
/// assumed symmetric, not checked; the report's residual, computed with the full matrix,
/// shows a violation). A matrix that is not positive definite gives `Breakdown`.
#[derive(Debug, Default)]
pub struct SparseCholesky {
    symbolic: Option<(Pattern, faer::sparse::linalg::solvers::SymbolicLlt<usize>)>,
    analyses: usize,
}

impl SparseCholesky {
    /// A solver with no analysis yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// How many symbolic analyses (orderings) were computed so far: one per distinct pattern
    /// met in a row.
    pub fn symbolic_analyses(&self) -> usize {
        self.analyses
    }
}

impl LinearSolver for SparseCholesky {
    fn solve(&mut self, matrix: &Csr, rhs: &[f64], x: &mut [f64]) -> LinearResult {
        const METHOD: &str = "sparse Cholesky";
        check_matrix(METHOD, matrix, rhs, x)?;
        super::check_finite(rhs, "the right-hand side")?;
        let view = transpose_view(matrix);
        let reuse = matches!(&self.symbolic, Some((pattern, _)) if pattern.matches(matrix));
        if !reuse {
            let symbolic = faer::sparse::linalg::solvers::SymbolicLlt::try_new(
                view.symbolic(),
                faer::Side::Lower,
            )
            .map_err(|e| out_of_memory(METHOD, e))?;
            self.symbolic = Some((Pattern::of(matrix), symbolic));
            self.analyses += 1;
        }
        let symbolic = self.symbolic.as_ref().expect("analysed above").1.clone();
        let factor =
            faer::sparse::linalg::solvers::Llt::try_new_with_symbolic(symbolic, view, faer::Side::Lower)
                .map_err(|error| match error {
                    LltError::Numeric(numeric) => SolveError::Breakdown {
                        method: METHOD,
                        reason: format!(
                            "the matrix is not positive definite ({numeric:?} in the fill-reducing \
                             order, {} rows); use LU or GMRES for an indefinite or singular tangent",
                            matrix.nrows
                        ),
                    },
                    LltError::Generic(generic) => out_of_memory(METHOD, generic),
                })?;
        x.copy_from_slice(rhs);
        factor.solve_in_place(MatMut::from_column_major_slice_mut(x, matrix.nrows, 1));
        super::check_finite(x, "the Cholesky solution")?;
        Ok(KrylovReport {
            method: METHOD.to_string(),
            iterations: 1,
            relative_residual: relative_residual(matrix, rhs, x),
        })
    }
}

/// Sparse LU with partial pivoting, for non-symmetric or indefinite matrices (tangents after
/// bond breaking or with follower loads). A structurally or numerically singular matrix gives
/// `Breakdown`.
#[derive(Debug, Default)]
pub struct SparseLu {
    symbolic: Option<(Pattern, faer::sparse::linalg::solvers::SymbolicLu<usize>)>,
    analyses: usize,
}

impl SparseLu {
    /// A solver with no analysis yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// How many symbolic analyses (orderings) were computed so far.
    pub fn symbolic_analyses(&self) -> usize {
        self.analyses
    }
}

impl LinearSolver for SparseLu {
    fn solve(&mut self, matrix: &Csr, rhs: &[f64], x: &mut [f64]) -> LinearResult {
        const METHOD: &str = "sparse LU";
        check_matrix(METHOD, matrix, rhs, x)?;
        super::check_finite(rhs, "the right-hand side")?;
        let view = transpose_view(matrix);
        let reuse = matches!(&self.symbolic, Some((pattern, _)) if pattern.matches(matrix));
        if !reuse {
            let symbolic = faer::sparse::linalg::solvers::SymbolicLu::try_new(view.symbolic())
                .map_err(|e| out_of_memory(METHOD, e))?;
            self.symbolic = Some((Pattern::of(matrix), symbolic));
            self.analyses += 1;
        }
        let symbolic = self.symbolic.as_ref().expect("analysed above").1.clone();
        // The view is Aᵀ, so this is Aᵀ = LU and A x = b is solved with the transposed factors.
        let factor = faer::sparse::linalg::solvers::Lu::try_new_with_symbolic(symbolic, view)
            .map_err(|error| match error {
                LuError::SymbolicSingular { index } => SolveError::Breakdown {
                    method: METHOD,
                    reason: format!(
                        "the matrix is singular (no pivot at elimination step {index} of {}); \
                         check that rigid-body motions are constrained",
                        matrix.nrows
                    ),
                },
                LuError::Generic(generic) => out_of_memory(METHOD, generic),
            })?;
        x.copy_from_slice(rhs);
        factor.solve_transpose_in_place(MatMut::from_column_major_slice_mut(x, matrix.nrows, 1));
        if x.iter().any(|v| !v.is_finite()) {
            // Inputs were finite, so an infinite or NaN answer means a zero pivot.
            return Err(SolveError::Breakdown {
                method: METHOD,
                reason: "the matrix is numerically singular (zero pivot); check that rigid-body \
                         motions are constrained"
                    .to_string(),
            });
        }
        Ok(KrylovReport {
            method: METHOD.to_string(),
            iterations: 1,
            relative_residual: relative_residual(matrix, rhs, x),
        })
    }
}
