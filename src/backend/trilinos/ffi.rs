//! The `cxx` bridge to `cpp/include/peridyn/trilinos_linear.hpp`. Kept alone in this small
//! file because any edit here regenerates the bridge and recompiles the C++ shim. Every
//! fallible C++ function returns `Result`: a C++ exception arrives as `Err` with its message.

#[cxx::bridge(namespace = "peridyn::trilinos")]
pub(crate) mod bridge {
    /// What Belos reports after a solve.
    struct BelosOutcome {
        /// Belos returned `Converged`.
        converged: bool,
        /// Iterations taken.
        iterations: i32,
        /// Belos' achieved tolerance (the largest scaled residual of its status tests).
        achieved_tolerance: f64,
    }

    unsafe extern "C++" {
        include!("peridyn/trilinos_linear.hpp");

        /// Communicator, row map, matrix and preconditioner of one system.
        type LinearSystem;

        /// Initialises MPI (thread level serialized) unless it already is; true when this
        /// call did it.
        fn mpi_initialize() -> Result<bool>;
        /// Size of `MPI_COMM_WORLD`.
        fn mpi_world_size() -> i32;

        /// Row map over `owned_rows` on `MPI_COMM_WORLD` (`mpi_world`) or `MPI_COMM_SELF`, and
        /// an `Epetra_FECrsMatrix` filled from the CSR rows `row_gids`. MPI must be initialised.
        fn new_linear_system(
            mpi_world: bool,
            owned_rows: &[i32],
            row_gids: &[i32],
            row_offsets: &[i32],
            column_gids: &[i32],
            values: &[f64],
        ) -> Result<UniquePtr<LinearSystem>>;

        /// y = A x over the owned rows.
        fn multiply(system: &LinearSystem, x: &[f64], y: &mut [f64]) -> Result<()>;

        /// Ifpack point Jacobi.
        fn set_jacobi_preconditioner(system: Pin<&mut LinearSystem>, sweeps: i32) -> Result<()>;
        /// Ifpack ILU(k).
        fn set_ilu_preconditioner(system: Pin<&mut LinearSystem>, fill_level: i32) -> Result<()>;
        /// ML smoothed aggregation.
        fn set_ml_preconditioner(system: Pin<&mut LinearSystem>, pde_equations: i32) -> Result<()>;

        /// Belos BlockCG (`gmres` false) or BlockGMRES.
        fn belos_solve(
            system: &LinearSystem,
            gmres: bool,
            rhs: &[f64],
            x: &mut [f64],
            relative_tolerance: f64,
            max_iterations: i32,
            gmres_restart: i32,
        ) -> Result<BelosOutcome>;
    }
}
