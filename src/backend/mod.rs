//! Who does the linear algebra: the traits every backend implements and the matrix form they
//! receive. Backends never see physics: they get a [`Csr`] matrix and vectors, or a residual
//! callback, and return a solution with a report; what an implicit solver list asks of them
//! comes as [`settings::ImplicitSolve`], never as deck types.

mod csr;
pub mod factory;
pub(crate) mod fingerprint;
pub mod native;
pub mod parameters;
#[cfg(feature = "petsc")]
pub mod petsc;
pub mod problem;
pub mod settings;
#[cfg(feature = "trilinos")]
pub mod trilinos;

pub use csr::{block_diagonal_csr, Csr};

/// Why a linear or nonlinear solve did not produce an answer. Convergence failure is a value
/// the load-stepping driver acts on (it cuts the step), not a panic.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SolveError {
    /// An iterative method stopped at its iteration limit above its tolerance.
    #[error(
        "{method} did not converge in {iterations} iterations (relative residual {relative_residual:.3e}, \
         tolerance {tolerance:.1e})"
    )]
    NotConverged {
        /// Method name, e.g. `CG`.
        method: &'static str,
        /// Iterations taken.
        iterations: usize,
        /// ‖b − Ax‖/‖b‖ reached.
        relative_residual: f64,
        /// Requested relative tolerance.
        tolerance: f64,
    },
    /// The matrix is singular or not of the kind the method needs (e.g. not positive definite
    /// for Cholesky or CG).
    #[error("{method}: {reason}")]
    Breakdown {
        /// Method name.
        method: &'static str,
        /// What went wrong, for the log.
        reason: String,
    },
    /// A collective solve stopped because the solve failed on another MPI rank, which reports
    /// the reason.
    #[error("the solve failed on another rank")]
    OtherRank,
    /// A residual, matrix entry or solution component is NaN or infinite.
    #[error("non-finite value in {what}")]
    NonFinite {
        /// Where it appeared, e.g. `the residual`.
        what: String,
    },
}

/// What this build, backend or rank count cannot run, as the one message the user sees (the
/// deck's solver named, the way out given). The driver turns it into its run error (exit
/// code 1) unchanged.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct Unsupported(pub String);

/// This rank's rows of a matrix distributed over the MPI ranks.
#[derive(Debug, Clone, Copy)]
pub struct RankRows<'a> {
    /// The rows' global ids.
    pub rows: &'a [usize],
    /// One row per id; its columns are global ids.
    pub matrix: &'a Csr,
}

/// A linear solve's report, or why it produced no answer.
pub type LinearResult = Result<KrylovReport, SolveError>;

/// What a linear solve did, for the log and the CSV history.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct KrylovReport {
    /// Method used, e.g. `CG + block Jacobi` or `sparse Cholesky`.
    pub method: String,
    /// Iterations (1 for a direct solve).
    pub iterations: usize,
    /// Final ‖b − Ax‖/‖b‖.
    pub relative_residual: f64,
}

/// What an assembled linear solver spent building its preconditioners since it was last
/// asked ([`LinearSolver::take_preconditioner_setup`]): the `Preconditioner_*` and `AMG_*`
/// columns of the solver CSV for assembled Newton.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PreconditionerSetup {
    /// Wall-clock seconds spent building preconditioners.
    pub seconds: f64,
    /// Multigrid hierarchies built (0 without multigrid).
    pub hierarchies: usize,
    /// Levels of the last multigrid hierarchy, the finest and the coarsest included (0
    /// without multigrid).
    pub levels: usize,
    /// Operator complexity of the last multigrid hierarchy: the levels' entries over the
    /// finest level's (0 without multigrid).
    pub operator_complexity: f64,
}

/// Solves A x = b for one matrix. Implementations may keep a factorization or preconditioner
/// between calls on the same pattern.
pub trait LinearSolver {
    /// What the solver is, for the log (e.g. `Belos BlockCG + ML`).
    fn describe(&self) -> String {
        "external backend".to_string()
    }

    /// Solves `matrix · x = rhs`; `x` holds the initial guess on entry (iterative methods) and
    /// the solution on return.
    fn solve(&mut self, matrix: &Csr, rhs: &[f64], x: &mut [f64]) -> LinearResult;
    /// What building preconditioners cost since the last call, and the shape of the last
    /// multigrid hierarchy; the counters start again at zero. The default reports nothing
    /// (solvers whose preconditioner setup is part of their solve, unseparated).
    fn take_preconditioner_setup(&mut self) -> PreconditionerSetup {
        PreconditionerSetup::default()
    }

    /// Offers the near-null space of the matrices to come (row-major, unknowns × `count`:
    /// the rigid-body modes for elasticity), for algebraic multigrid preconditioners; the
    /// default ignores it.
    fn set_near_null_space(&mut self, modes: &[f64], count: usize) {
        let _ = (modes, count);
    }

    /// Offers how the unknowns of the matrices to come group into points (offsets: group g
    /// holds unknowns `groups[g]..groups[g + 1]`, one to three each, as
    /// [`problem::NonlinearProblem::groups`]), for algebraic multigrid preconditioners that
    /// aggregate whole points; the default ignores it.
    fn set_point_groups(&mut self, groups: &[usize]) {
        let _ = groups;
    }

    /// Solves a system distributed over the MPI ranks (collective): this rank holds the rows
    /// `part` and the matching entries of `rhs` and `x`. Solvers that run on one process
    /// only say so.
    fn solve_distributed(&mut self, part: RankRows, rhs: &[f64], x: &mut [f64]) -> LinearResult {
        let _ = (part, rhs, x);
        Err(SolveError::Breakdown {
            method: "linear solver",
            reason: format!(
                "{} solves on one process; on several ranks use Backend \"Trilinos\"",
                self.describe()
            ),
        })
    }
}
