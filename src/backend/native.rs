//! The native backend, always built: faer's sparse Cholesky and LU, and our own
//! CG and restarted GMRES over [`Csr`] or over an operator callback for JFNK, with none,
//! Jacobi or block-Jacobi preconditioning. It is the reference the Trilinos and PETSc
//! backends are compared with.
//!
//! ```
//! use peridyn::backend::native::{NativeLinearSolver, NativeMethod, NativeSolverSettings};
//! use peridyn::backend::{Csr, LinearSolver};
//! // [[4, 1], [1, 3]] x = [1, 2] has x = (1/11, 7/11) by Cramer's rule.
//! let a = Csr { nrows: 2, ncols: 2, offsets: vec![0, 2, 4], columns: vec![0, 1, 0, 1],
//!               values: vec![4.0, 1.0, 1.0, 3.0] };
//! let settings = NativeSolverSettings { method: NativeMethod::Cg, ..Default::default() };
//! let mut solver = NativeLinearSolver::new(&settings, vec![]);
//! let mut x = vec![0.0; 2];
//! let report = solver.solve(&a, &[1.0, 2.0], &mut x)?;
//! assert!((x[0] - 1.0 / 11.0).abs() < 1e-12 && (x[1] - 7.0 / 11.0).abs() < 1e-12);
//! assert_eq!(report.method, "CG");
//! # Ok::<(), peridyn::backend::SolveError>(())
//! ```

mod amg;
mod direct;
mod krylov;
mod preconditioner;

use std::str::FromStr;

pub use amg::{
    multigrid_memory_estimate, one_hop_operator, pmb_micromodulus, rigid_body_modes, Amg, Cycle,
    MultigridMemory, OneHopInput, Stencil, COARSE_UNKNOWNS, NEAREST_SHELLS,
};
pub use direct::{SparseCholesky, SparseLu};
pub use krylov::{
    cg_matrix_free, gmres_matrix_free, ConjugateGradient, Gmres, KrylovSettings, Operator,
    PreconditionerApply,
};
pub use preconditioner::{
    invert_dense, Preconditioner, PreconditionerKind, PreconditionerOperator,
};

use super::{Csr, LinearResult, LinearSolver, SolveError};

/// A deck named a solver or preconditioner this backend does not have.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown {what} \"{given}\"; expected one of: {}", expected.join(", "))]
pub struct UnknownChoice {
    /// What was being chosen, e.g. `linear solver`.
    pub what: &'static str,
    /// The name found in the deck.
    pub given: String,
    /// Accepted names.
    pub expected: &'static [&'static str],
}

/// Lower case without spaces, dashes, underscores or `+`, so `Block-Jacobi` = `block jacobi`.
fn normalize_name(name: &str) -> String {
    name.chars()
        .filter(|c| !matches!(c, ' ' | '-' | '_' | '+'))
        .flat_map(char::to_lowercase)
        .collect()
}

/// `NonFinite` naming `what` if any value is NaN or infinite.
fn check_finite(values: &[f64], what: &str) -> Result<(), SolveError> {
    if values.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(SolveError::NonFinite {
            what: what.to_string(),
        })
    }
}

/// Square, sized like the vectors, finite entries.
fn check_matrix(
    method: &'static str,
    matrix: &Csr,
    rhs: &[f64],
    x: &[f64],
) -> Result<(), SolveError> {
    if matrix.nrows != matrix.ncols {
        return Err(SolveError::Breakdown {
            method,
            reason: format!(
                "the matrix is {}×{}, not square",
                matrix.nrows, matrix.ncols
            ),
        });
    }
    if rhs.len() != matrix.nrows || x.len() != matrix.nrows {
        return Err(SolveError::Breakdown {
            method,
            reason: format!(
                "the matrix has {} rows but the right-hand side has {} and the solution {} entries",
                matrix.nrows,
                rhs.len(),
                x.len()
            ),
        });
    }
    check_finite(&matrix.values, "the matrix")
}

/// Which native method solves the linear systems.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum NativeMethod {
    /// [`SparseCholesky`]: SPD tangents, fastest direct solve.
    Cholesky,
    /// [`SparseLu`]: any non-singular matrix.
    Lu,
    /// [`ConjugateGradient`]: SPD tangents, least memory. The default, as Peridigm's
    /// `Belos Linear Solver: BlockCG`.
    #[default]
    Cg,
    /// [`Gmres`]: non-symmetric or indefinite matrices.
    Gmres,
}

impl NativeMethod {
    /// Names accepted by [`FromStr`] (case and separators ignored), including Peridigm's
    /// `Belos Linear Solver` values.
    pub const NAMES: &'static [&'static str] =
        &["Cholesky", "LU", "CG", "GMRES", "BlockCG", "BlockGMRES"];
}

impl FromStr for NativeMethod {
    type Err = UnknownChoice;

    fn from_str(name: &str) -> Result<Self, Self::Err> {
        match normalize_name(name).as_str() {
            "cholesky" | "llt" => Ok(Self::Cholesky),
            "lu" => Ok(Self::Lu),
            "cg" | "blockcg" | "conjugategradient" | "conjugategradients" => Ok(Self::Cg),
            "gmres" | "blockgmres" => Ok(Self::Gmres),
            _ => Err(UnknownChoice {
                what: "linear solver",
                given: name.to_string(),
                expected: Self::NAMES,
            }),
        }
    }
}

/// What the deck chose for the native backend.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct NativeSolverSettings {
    /// Direct or Krylov method (default CG).
    pub method: NativeMethod,
    /// Preconditioner of the Krylov methods (ignored by direct ones; default none, as
    /// Peridigm's QuasiStatic solver, whose ILU preconditioner is switched off).
    pub preconditioner: PreconditionerKind,
    /// Tolerance, iteration limit and restart of the Krylov methods.
    pub krylov: KrylovSettings,
}

/// One native solver chosen at run time, keeping its factorization analysis or settings
/// between solves.
#[derive(Debug)]
pub enum NativeLinearSolver {
    /// Sparse Cholesky.
    Cholesky(SparseCholesky),
    /// Sparse LU.
    Lu(SparseLu),
    /// Preconditioned CG.
    Cg(ConjugateGradient),
    /// Restarted, right-preconditioned GMRES.
    Gmres(Gmres),
}

impl NativeLinearSolver {
    /// The solver `settings` name; `groups` are the block offsets block Jacobi uses (see
    /// [`Preconditioner::BlockJacobi`]; ignored otherwise).
    pub fn new(settings: &NativeSolverSettings, groups: Vec<usize>) -> Self {
        let preconditioner = settings.preconditioner.with_groups(groups);
        match settings.method {
            NativeMethod::Cholesky => Self::Cholesky(SparseCholesky::new()),
            NativeMethod::Lu => Self::Lu(SparseLu::new()),
            NativeMethod::Cg => Self::Cg(ConjugateGradient::new(settings.krylov, preconditioner)),
            NativeMethod::Gmres => Self::Gmres(Gmres::new(settings.krylov, preconditioner)),
        }
    }

    /// Replaces the block-Jacobi offsets (after the set of prescribed dofs changed); no effect
    /// on other preconditioners or direct methods.
    pub fn set_groups(&mut self, groups: Vec<usize>) {
        let preconditioner = match self {
            Self::Cg(cg) => &mut cg.preconditioner,
            Self::Gmres(gmres) => &mut gmres.preconditioner,
            Self::Cholesky(_) | Self::Lu(_) => return,
        };
        if let Preconditioner::BlockJacobi { groups: current } = preconditioner {
            *current = groups;
        }
    }

    /// What the last preconditioner build adjusted (empty for direct methods).
    pub fn notes(&self) -> &[String] {
        match self {
            Self::Cg(cg) => cg.notes(),
            Self::Gmres(gmres) => gmres.notes(),
            Self::Cholesky(_) | Self::Lu(_) => &[],
        }
    }
}

impl LinearSolver for NativeLinearSolver {
    fn solve(&mut self, matrix: &Csr, rhs: &[f64], x: &mut [f64]) -> LinearResult {
        match self {
            Self::Cholesky(solver) => solver.solve(matrix, rhs, x),
            Self::Lu(solver) => solver.solve(matrix, rhs, x),
            Self::Cg(solver) => solver.solve(matrix, rhs, x),
            Self::Gmres(solver) => solver.solve(matrix, rhs, x),
        }
    }
}

#[cfg(test)]
mod tests;
