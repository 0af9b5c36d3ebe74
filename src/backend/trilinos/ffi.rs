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

    /// The shape of the ML hierarchy `set_ml_preconditioner` built.
    struct MlHierarchy {
        /// Levels, the finest and the coarsest included.
        levels: i32,
        /// ML's operator complexity: the levels' entries over the finest level's.
        operator_complexity: f64,
    }

    /// Type of one Teuchos parameter.
    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    enum ParameterKind {
        /// `std::string`.
        Text,
        /// `double`.
        Double,
        /// `int`.
        Int,
        /// `bool`.
        Bool,
    }

    /// One entry of a Teuchos `ParameterList` (Belos', NOX's): the sublist names leading to it,
    /// its name and its value.
    struct Parameter {
        /// Sublists from the top of the list, outermost first.
        path: Vec<String>,
        /// Parameter name.
        name: String,
        /// Which of the value fields holds the value.
        kind: ParameterKind,
        /// Value of a `Text` parameter.
        text: String,
        /// Value of a `Double` parameter.
        number: f64,
        /// Value of an `Int` parameter.
        integer: i32,
        /// Value of a `Bool` parameter.
        flag: bool,
    }

    unsafe extern "C++" {
        include!("peridyn/trilinos_linear.hpp");

        /// Communicator, row map, matrix and preconditioner of one system.
        type LinearSystem;

        /// Row map over `owned_rows` on the communicator with the Fortran handle
        /// `communicator` (`MPI_Comm_c2f`), and an `Epetra_FECrsMatrix` filled from the CSR
        /// rows `row_gids` (on a fixed graph when every row is owned).
        fn new_linear_system(
            communicator: i32,
            owned_rows: &[i32],
            row_gids: &[i32],
            row_offsets: &[usize],
            column_gids: &[usize],
            values: &[f64],
        ) -> Result<UniquePtr<LinearSystem>>;

        /// New values for the matrix, in the order of the CSR it was built from (same
        /// pattern); the storage is reused and the preconditioner dropped.
        fn refill_linear_system(
            system: Pin<&mut LinearSystem>,
            row_gids: &[i32],
            row_offsets: &[usize],
            column_gids: &[usize],
            values: &[f64],
        ) -> Result<()>;

        /// y = A x over the owned rows.
        fn multiply(system: &LinearSystem, x: &[f64], y: &mut [f64]) -> Result<()>;

        /// Ifpack point Jacobi.
        fn set_jacobi_preconditioner(system: Pin<&mut LinearSystem>, sweeps: i32) -> Result<()>;
        /// Ifpack ILU(k).
        fn set_ilu_preconditioner(system: Pin<&mut LinearSystem>, fill_level: i32) -> Result<()>;
        /// ML smoothed aggregation with `pde_equations` unknowns per node and, unless
        /// `null_space` is empty, the near-null space of `modes` column-major vectors; returns
        /// the hierarchy's shape.
        fn set_ml_preconditioner(
            system: Pin<&mut LinearSystem>,
            pde_equations: i32,
            null_space: &[f64],
            modes: i32,
        ) -> Result<MlHierarchy>;

        /// Belos BlockCG (`gmres` false) or BlockGMRES with the parameter list built from
        /// `parameters` (every setting comes from Rust).
        fn belos_solve(
            system: &LinearSystem,
            gmres: bool,
            rhs: &[f64],
            x: &mut [f64],
            parameters: &[Parameter],
        ) -> Result<BelosOutcome>;
    }
}
