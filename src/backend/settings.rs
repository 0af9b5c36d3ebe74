//! What an implicit solver list asks of the backends: who drives its Newton iteration, how
//! its linear systems are solved (backend, method, preconditioner, tolerances and the
//! library parameters handed on), and the Peridigm keys that choose a Jacobian-free solve.
//!
//! `crate::setup::solvers` builds these from a deck's solver list (the deck reader documents
//! the keys and their defaults); [`super::factory`] decides from them which backend runs the
//! list, and the solver modules build its objects.

use super::parameters::ParameterValue;

/// How an implicit solver list solves its nonlinear systems: everything the backend factory
/// and the nonlinear and linear solvers read of it.
#[derive(Debug, Clone, PartialEq)]
pub struct ImplicitSolve {
    /// The solver list's name (`Solver`, `Solver2`, …), for messages and PETSc's option
    /// prefix.
    pub list: String,
    /// The integrator's name as decks write it (`QuasiStatic`, …), for messages.
    pub integrator: &'static str,
    /// Who drives the Newton iteration.
    pub nonlinear: Nonlinear,
    /// The linear solves.
    pub linear: LinearSolve,
    /// `Peridigm Preconditioner`.
    pub peridigm_preconditioner: PeridigmPreconditioner,
    /// Line searches allowed (off with `Disable Heuristics`).
    pub line_search: bool,
    /// The list's `Verbose`.
    pub verbose: bool,
}

/// The nonlinear iteration a list asks for.
#[derive(Debug, Clone, PartialEq)]
pub enum Nonlinear {
    /// `QuasiStatic` (`quasi_static`) and `Implicit` lists: peridyn's Newton, or PETSc's SNES
    /// with `Nonlinear Solver: "SNES"` ([`LinearSolve::nonlinear_method`]).
    Newton {
        /// Load-stepped to equilibrium (no inertia): `Linear Solver: "Automatic"` may make a
        /// large one Jacobian-free.
        quasi_static: bool,
    },
    /// `NOXQuasiStatic`: NOX's parameter list (NOX itself on Trilinos, SNES on PETSc,
    /// peridyn's Newton on the native backend).
    Nox(NoxParameters),
}

/// The `NOXQuasiStatic` keys the solvers read: Peridigm's own, and NOX's list.
#[derive(Debug, Clone, PartialEq)]
pub struct NoxParameters {
    /// `Direction → Method`: `Newton` or `NonlinearCG`.
    pub direction_method: String,
    /// `Max Age Of Prec`: uses of a Jacobian-free preconditioner before it is rebuilt.
    pub max_age_of_prec: u64,
    /// The list's `Verbose`.
    pub verbose: bool,
    /// NOX's parameter list (`Direction`, `Line Search`, `Printing`, …), in file order.
    pub nox: Vec<(String, ParameterValue)>,
}

impl NoxParameters {
    /// The path of NOX's `Jacobian Operator` key of Newton's linear solver.
    pub const JACOBIAN_OPERATOR: [&'static str; 4] =
        ["Direction", "Newton", "Linear Solver", "Jacobian Operator"];
}

/// Linear solver of an implicit list.
#[derive(Debug, Clone, PartialEq)]
pub struct LinearSolve {
    /// The backend (and the Trilinos and PETSc backends' preconditioner settings).
    pub backend: LinearBackend,
    /// The deck named the backend (otherwise `peridyn run --backend` may have chosen it).
    pub backend_given: bool,
    /// `Linear Solver`.
    pub method: LinearMethod,
    /// The native backend's preconditioner (`Block 3x3` on the other backends, unused).
    pub preconditioner: LinearPreconditioner,
    /// The deck named the preconditioner (otherwise defaults may follow `Peridigm
    /// Preconditioner` or the problem's size).
    pub preconditioner_given: bool,
    /// Relative residual of the Krylov methods.
    pub relative_tolerance: f64,
    /// Krylov iteration limit (`None`: the number of unknowns).
    pub maximum_iterations: Option<u64>,
    /// Belos parameters for the Trilinos backend, each replacing the value peridyn would set,
    /// a later one an earlier one.
    pub belos_parameters: Vec<(String, ParameterValue)>,
    /// PETSc options for the PETSc backend, as (name without its `-`, value) pairs in deck
    /// order, put in PETSc's options database under the list's prefix.
    pub petsc_options: Vec<(String, Option<String>)>,
    /// Who drives the Newton iteration of `QuasiStatic` and `Implicit` lists.
    pub nonlinear_method: NonlinearMethod,
}

/// `Nonlinear Solver` of `QuasiStatic` and `Implicit` lists.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NonlinearMethod {
    /// peridyn's Newton with a backtracking line search (default).
    Newton,
    /// PETSc's SNES `newtonls` (PETSc backend).
    Snes,
}

/// `Linear Solver`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LinearMethod {
    /// `Direct` for small systems, `CG` for large ones (Jacobian-free Newton–Krylov with AMG
    /// for large quasi-static ones on the native backend).
    Automatic,
    /// Sparse Cholesky, LU when the matrix is not positive definite.
    Direct,
    /// Sparse Cholesky only (fails on an indefinite stiffness).
    Cholesky,
    /// Sparse LU.
    Lu,
    /// Preconditioned conjugate gradients.
    Cg,
    /// Restarted GMRES.
    Gmres,
}

impl LinearMethod {
    /// Largest number of unknowns `Automatic` solves with a sparse factorization: beyond it
    /// the fill-in of a factorization of a three-dimensional peridynamic stiffness costs
    /// minutes and gigabytes (a 20,000-point LPS block: over 10 minutes per factorization,
    /// against 10 s for preconditioned CG).
    pub const AUTOMATIC_DIRECT_LIMIT: usize = 30_000;

    /// True for the sparse factorizations (`Direct`, `Cholesky`, `LU`).
    pub fn is_direct(self) -> bool {
        matches!(
            self,
            LinearMethod::Direct | LinearMethod::Cholesky | LinearMethod::Lu
        )
    }
}

/// Who solves the assembled linear systems.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LinearBackend {
    /// faer factorizations and peridyn's own Krylov methods.
    Native,
    /// Belos through the Trilinos bridge (Cargo feature `trilinos`).
    Trilinos {
        /// Its preconditioner.
        preconditioner: AlgebraicPreconditioner,
        /// ILU level of fill (default 0).
        ilu_fill_level: u32,
    },
    /// KSP/PC and SNES through the PETSc bindings (Cargo feature `petsc`).
    Petsc {
        /// Its preconditioner.
        preconditioner: PetscPreconditioner,
        /// ILU level of fill (default 0).
        ilu_fill_level: u32,
    },
}

/// Preconditioners of the Trilinos backend.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AlgebraicPreconditioner {
    /// None.
    None,
    /// Ifpack point Jacobi.
    Jacobi,
    /// Ifpack incomplete LU (default).
    Ilu,
    /// ML smoothed-aggregation algebraic multigrid.
    Ml,
}

/// Preconditioners of the PETSc backend.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PetscPreconditioner {
    /// `-pc_type none`.
    None,
    /// `-pc_type jacobi`.
    Jacobi,
    /// `-pc_type bjacobi` with ILU(k) on each block (one block per process; default).
    Ilu,
    /// PETSc's smoothed-aggregation multigrid with the rigid-body modes of the unknowns as its
    /// near-null space, on the assembled tangent or (Jacobian-free with `Peridigm
    /// Preconditioner: "AMG"`) the one-hop operator.
    Gamg,
    /// hypre's BoomerAMG (`-pc_type hypre`).
    Hypre,
}

/// Preconditioners of the native backend.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LinearPreconditioner {
    /// The inverted diagonal block of each point.
    Block3x3,
    /// The inverted diagonal.
    Jacobi,
    /// None.
    None,
    /// peridyn's smoothed-aggregation multigrid (additive two-level form) built on the
    /// one-hop PMB-like operator of the model (`crate::tangent::one_hop_operator`), built once
    /// and rebuilt only when bonds break or points are held.
    Amg,
}

/// `Peridigm Preconditioner`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PeridigmPreconditioner {
    /// The assembled tangent (default).
    FullTangent,
    /// Inverted 3×3 diagonal blocks of the tangent.
    Block3x3,
    /// None.
    None,
    /// peridyn's: with `Jacobian Operator: "Matrix-Free"`, Jacobian-free Newton–Krylov
    /// preconditioned by multigrid on the one-hop operator, so that no tangent is assembled.
    Amg,
}
