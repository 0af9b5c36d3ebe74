//! The `cxx` bridge to `cpp/include/peridyn/trilinos_nox.hpp`: NOX's Newton solver on Epetra
//! vectors, with the residual, the tangent values and the preconditioner values computed by
//! Rust callbacks on [`NoxProblem`]. Kept apart from the linear-solver bridge so an edit to
//! one does not recompile the other's C++.
//!
//! This file holds everything the C++ side calls ([`NoxProblem`] and the
//! [`NonlinearCallbacks`] it forwards to); [`super::nox`] drives the solve and imports it,
//! never the other way round.

use crate::backend::SolveError;

/// What NOX asks of the problem.
pub trait NonlinearCallbacks {
    /// F(x) into `f`. `probe` is true when NOX evaluates F for a finite-difference or
    /// matrix-free directional derivative rather than at an iterate.
    fn residual(&mut self, x: &[f64], f: &mut [f64], probe: bool) -> Result<(), SolveError>;
    /// The values of ∂F/∂x at x, in the order of [`NoxLayout::jacobian`](super::nox::NoxLayout::jacobian); `Ok(false)` keeps
    /// the previous values.
    fn jacobian(&mut self, x: &[f64], values: &mut [f64]) -> Result<bool, SolveError>;
    /// The values of the preconditioner matrix at x, in the order of
    /// [`NoxLayout::preconditioner`](super::nox::NoxLayout::preconditioner); `Ok(false)` keeps the previous values.
    fn preconditioner(&mut self, x: &[f64], values: &mut [f64]) -> Result<bool, SolveError>;
    /// Called after every nonlinear iteration (1-based) with ‖F‖₂.
    fn iteration_done(&mut self, iteration: usize, residual_norm: f64);
}

/// The Rust object the C++ side calls back; it keeps the first callback error so that the
/// caller sees the real cause rather than NOX's generic fill failure.
pub struct NoxProblem<'a> {
    callbacks: &'a mut dyn NonlinearCallbacks,
    error: Option<SolveError>,
}

impl<'a> NoxProblem<'a> {
    /// The bridge object over `callbacks`, no error kept yet.
    pub(super) fn new(callbacks: &'a mut dyn NonlinearCallbacks) -> Self {
        Self {
            callbacks,
            error: None,
        }
    }

    /// The first callback error, if any (the real cause of a failed NOX solve).
    pub(super) fn into_error(self) -> Option<SolveError> {
        self.error
    }

    fn keep<T>(&mut self, result: Result<T, SolveError>) -> Result<T, String> {
        result.map_err(|e| {
            let message = e.to_string();
            self.error.get_or_insert(e);
            message
        })
    }

    pub(super) fn residual(&mut self, x: &[f64], f: &mut [f64], probe: bool) -> Result<(), String> {
        let result = self.callbacks.residual(x, f, probe);
        self.keep(result)
    }

    pub(super) fn jacobian(&mut self, x: &[f64], values: &mut [f64]) -> Result<bool, String> {
        let result = self.callbacks.jacobian(x, values);
        self.keep(result)
    }

    pub(super) fn preconditioner(&mut self, x: &[f64], values: &mut [f64]) -> Result<bool, String> {
        let result = self.callbacks.preconditioner(x, values);
        self.keep(result)
    }

    pub(super) fn iteration_done(&mut self, iteration: i32, residual_norm: f64) {
        self.callbacks
            .iteration_done(usize::try_from(iteration).unwrap_or(0), residual_norm);
    }
}

#[cxx::bridge(namespace = "peridyn::trilinos")]
pub(crate) mod bridge {
    /// How the Newton system is built.
    struct NoxLayout {
        /// Fortran handle (`MPI_Comm_c2f`) of the communicator the objects live on:
        /// `MPI_COMM_WORLD` when the rows are this rank's share of a distributed system,
        /// else `MPI_COMM_SELF`.
        communicator: i32,
        /// Sublists leading to the linear-solver parameters of the chosen direction (e.g.
        /// `Direction`, `Newton`, `Linear Solver`).
        linear_solver_path: Vec<String>,
        /// Matrix-free Jacobian (`NOX::Epetra::MatrixFree`) instead of the assembled tangent.
        matrix_free: bool,
        /// CSR offsets and global columns of the assembled tangent (empty when matrix-free).
        jacobian_offsets: Vec<i32>,
        /// See `jacobian_offsets`.
        jacobian_columns: Vec<i32>,
        /// CSR offsets and global columns of the preconditioner matrix of a matrix-free
        /// solve (empty: none).
        preconditioner_offsets: Vec<i32>,
        /// See `preconditioner_offsets`.
        preconditioner_columns: Vec<i32>,
        /// The preconditioner matrix holds the inverse itself and is applied by a product
        /// (NOX `User Defined`); otherwise NOX's AztecOO/Ifpack/ML factor it.
        preconditioner_is_inverse: bool,
        /// ML smoothed aggregation is built on the preconditioner matrix (applied as NOX's
        /// `User Defined` preconditioner) and rebuilt each time its values are refilled.
        multigrid: bool,
        /// With `multigrid`: use the matrix and ML the `NoxMultigrid` passed to `nox_solve`
        /// kept from an earlier solve (same unknowns, same operator), when it holds them.
        reuse_multigrid: bool,
        /// ML's near-null space, column-major (`null_space_modes` vectors over this rank's
        /// unknowns); empty: ML's default.
        null_space: Vec<f64>,
        /// See `null_space`.
        null_space_modes: i32,
        /// ML's `PDE equations` on this rank (3: every point keeps three unknowns); the
        /// smallest over the ranks is used.
        pde_equations: i32,
        /// NOX status test `NormF` (two-norm, absolute, unscaled).
        tolerance: f64,
        /// NOX status test `MaxIters`.
        max_iterations: i32,
    }

    /// What NOX did.
    struct NoxOutcome {
        /// The status tests ended with `Converged`.
        converged: bool,
        /// Nonlinear iterations (`solver->step()` calls).
        iterations: i32,
        /// Krylov iterations summed over the solve (`Total Number of Linear Iterations`).
        linear_iterations: i32,
        /// ‖F‖₂ at the returned solution.
        residual_norm: f64,
        /// ML hierarchies built during the solve (0 without `multigrid`).
        preconditioner_setups: i32,
        /// Wall-clock seconds spent building them.
        preconditioner_seconds: f64,
        /// Levels of the last hierarchy.
        multigrid_levels: i32,
        /// ML's operator complexity of the last hierarchy.
        operator_complexity: f64,
    }

    extern "Rust" {
        /// The Rust side of one nonlinear solve.
        type NoxProblem<'a>;

        /// F(x) into `f`; `probe` when NOX evaluates it for a finite-difference or
        /// matrix-free directional derivative (damage stays frozen then).
        fn residual(self: &mut NoxProblem<'_>, x: &[f64], f: &mut [f64], probe: bool)
            -> Result<()>;
        /// Tangent values at x in the order of the layout's CSR; false when the values kept
        /// from the previous call are to be reused.
        fn jacobian(self: &mut NoxProblem<'_>, x: &[f64], values: &mut [f64]) -> Result<bool>;
        /// Preconditioner values at x in the order of the layout's CSR; false to reuse.
        fn preconditioner(self: &mut NoxProblem<'_>, x: &[f64], values: &mut [f64])
            -> Result<bool>;
        /// Called after every nonlinear iteration with ‖F‖₂.
        fn iteration_done(self: &mut NoxProblem<'_>, iteration: i32, residual_norm: f64);
    }

    unsafe extern "C++" {
        include!("peridyn/trilinos_nox.hpp");
        include!("peridyn/src/backend/trilinos/ffi.rs.h");

        /// One NOX parameter (the type is the linear bridge's).
        type Parameter = crate::backend::trilinos::ffi::bridge::Parameter;

        /// The preconditioner matrix and ML hierarchy kept between solves.
        type NoxMultigrid;

        /// An empty `NoxMultigrid`.
        fn new_nox_multigrid() -> UniquePtr<NoxMultigrid>;

        /// Runs NOX from `x` (the initial guess; the solution on return) over the rows
        /// `owned_rows` of an `Epetra_MpiComm` on the layout's communicator, with the NOX
        /// parameter list built from `parameters`; a multigrid preconditioner lives in
        /// `kept` (reused from it with the layout's `reuse_multigrid`).
        fn nox_solve(
            problem: &mut NoxProblem<'_>,
            owned_rows: &[i32],
            layout: &NoxLayout,
            parameters: &[Parameter],
            x: &mut [f64],
            kept: Pin<&mut NoxMultigrid>,
        ) -> Result<NoxOutcome>;
    }
}
