//! The `cxx` bridge to `cpp/include/peridyn/trilinos_nox.hpp`: NOX's Newton solver on Epetra
//! vectors, with the residual, the tangent values and the preconditioner values computed by
//! Rust callbacks on [`NoxProblem`](super::nox::NoxProblem). Kept apart from the linear-solver
//! bridge so an edit to one does not recompile the other's C++.

use super::nox::NoxProblem;

#[cxx::bridge(namespace = "peridyn::trilinos")]
pub(crate) mod bridge {
    /// Type of one NOX parameter.
    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    enum NoxValueKind {
        /// `std::string`.
        Text,
        /// `double`.
        Double,
        /// `int`.
        Int,
        /// `bool`.
        Bool,
    }

    /// One NOX parameter: the sublist names leading to it, its name and its value.
    struct NoxParameter {
        /// Sublists from the top of the NOX list, outermost first.
        path: Vec<String>,
        /// Parameter name.
        name: String,
        /// Which of the value fields holds the value.
        kind: NoxValueKind,
        /// Value of a `Text` parameter.
        text: String,
        /// Value of a `Double` parameter.
        number: f64,
        /// Value of an `Int` parameter.
        integer: i32,
        /// Value of a `Bool` parameter.
        flag: bool,
    }

    /// How the Newton system is built.
    struct NoxLayout {
        /// The objects live on `MPI_COMM_WORLD` (the rows are this rank's share of a
        /// distributed system) rather than `MPI_COMM_SELF`.
        mpi_world: bool,
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

        /// Runs NOX from `x` (the initial guess; the solution on return) over the rows
        /// `owned_rows` of an `Epetra_MpiComm(MPI_COMM_SELF)`, with the NOX parameter list
        /// built from `parameters`. MPI must be initialised.
        fn nox_solve(
            problem: &mut NoxProblem<'_>,
            owned_rows: &[i32],
            layout: &NoxLayout,
            parameters: &[NoxParameter],
            x: &mut [f64],
        ) -> Result<NoxOutcome>;
    }
}
