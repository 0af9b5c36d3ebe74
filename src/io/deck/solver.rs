//! Top-level lists whose name contains `Solver`: time span, common switches, one integrator.

use super::error::DeckError;
use super::parameters::{to_parameter_value, ParameterValue};
use super::reader::{Ctx, Field, ListReader};

/// One `Solver*` list. Several run one after the other in file order, state carried over.
#[derive(Debug, Clone, PartialEq)]
pub struct Solver {
    /// The list's name (`Solver`, `Solver1`, ...).
    pub name: String,
    /// `Initial Time` — default 0.0.
    pub initial_time: f64,
    /// `Final Time` (> `Initial Time`) — default 1.0 for Verlet; required for Implicit and for
    /// load-step counts; with a `Time Steps` list it defaults to the last listed time.
    pub final_time: f64,
    /// `Verbose` — extra norms per iteration; default false.
    pub verbose: bool,
    /// `Disable Heuristics` — no predictor, no damping, line-search α = 1; default false.
    pub disable_heuristics: bool,
    /// `Initialize Predictor From Previous Solver` — default false.
    pub initialize_predictor_from_previous_solver: bool,
    /// `Jacobian Diagnostics` — print asymmetry and conditioning estimates; default false.
    pub jacobian_diagnostics: bool,
    /// `Peridigm Preconditioner` — `Full Tangent` (default), `Block 3x3`, `None`, or peridyn's
    /// `AMG` (JFNK preconditioned by multigrid on the one-hop operator).
    pub peridigm_preconditioner: PeridigmPreconditioner,
    /// `Solve For Displacement/Temperature/Concentration/Pressure` — which unknowns exist
    /// (Peridigm reads them from the first solver only).
    pub solve_for: SolveFor,
    /// The integrator sublist (exactly one).
    pub integrator: Integrator,
    /// How implicit solvers solve their linear systems (peridyn keys, see [`LinearSolve`]).
    pub linear_solve: LinearSolve,
}

/// Linear solver of the implicit integrators (peridyn keys in the `Solver` list; Peridigm's
/// `Belos *` keys choose the default, so its decks keep their meaning).
///
/// | key | values | default |
/// |---|---|---|
/// | `Backend` | `Native`, `Trilinos` (a build with Cargo feature `trilinos`), `PETSc` (feature `petsc`) | `Native` |
/// | `Linear Solver` | `Automatic`, `Direct`, `Cholesky`, `LU`, `CG`, `GMRES`; `Trilinos`: `Automatic` (= `CG`), `CG`, `GMRES`; `PETSc`: all (`Direct`, `LU`, `Cholesky` are MUMPS) | `CG` when the deck gives `Belos Linear Solver: BlockCG`, `GMRES` for `BlockGMRES`, else `Automatic` |
/// | `Linear Solver Preconditioner` | `Native`: `Block 3x3`, `AMG`, `Jacobi`, `None`; `Trilinos`: `Jacobi`, `ILU`, `ML`, `None`; `PETSc`: `Jacobi`, `ILU` (block Jacobi with ILU blocks), `GAMG` (or `AMG`), `Hypre` (BoomerAMG), `None` | `Block 3x3` (`Native`), `ILU` (`Trilinos`, `PETSc`; `GAMG` with `Peridigm Preconditioner: "AMG"`) |
/// | `Linear Solver ILU Level Of Fill` | `Trilinos`/`PETSc` with `ILU`: Ifpack's `fact: level-of-fill`, PETSc's `-sub_pc_factor_levels` | 0 |
/// | `PETSc Options` | `Backend: "PETSc"`: PETSc command-line options (`-ksp_type gmres -pc_type gamg -snes_linesearch_type bt …`) put in PETSc's options database under this list's prefix (its name in lower case and `_`, e.g. `solver_`); they override the keys above | none |
/// | `Linear Solver Tolerance` | relative residual of the Krylov methods | `Belos Relative Tolerance` when given, else 1e-10 |
/// | `Linear Solver Maximum Iterations` | Krylov iteration limit | `Belos Maximum Iterations`, else the number of unknowns |
/// | `Nonlinear Solver` | `QuasiStatic` and `Implicit` lists: `Newton` (peridyn's Newton with the linear solver above) or `SNES` (`Backend: "PETSc"` only: PETSc's SNES `newtonls` drives the iteration on the same residual, its KSP and PC as above; `-snes_*` options in `PETSc Options` reach it). `NOXQuasiStatic` lists on PETSc always run SNES | `Newton` |
/// | `Belos` | a sublist of Belos parameters (`Backend: "Trilinos"`): `Maximum Iterations`, `Convergence Tolerance`, `Num Blocks`, `Maximum Restarts`, `Verbosity`, `Output Frequency`, … (see [`super::belos`]) | none |
///
/// `Direct` is a sparse Cholesky factorization that falls back to LU when the stiffness is not
/// positive definite (after bonds break, or with an unstable material state). `Automatic` is
/// `Direct` up to [`LinearMethod::AUTOMATIC_DIRECT_LIMIT`] unknowns and CG beyond, where the
/// fill-in of a factorization of a three-dimensional peridynamic stiffness costs minutes and
/// gigabytes (a 20,000-point LPS block: over 10 minutes per factorization here, against 10 s
/// for preconditioned CG). Beyond the limit a quasi-static list on the native backend that
/// names no preconditioner is not assembled at all: it runs Jacobian-free Newton–Krylov with
/// AMG ([`crate::backend::factory::automatic_jacobian_free`]).
///
/// `Backend: "Trilinos"` hands the assembled tangent to Belos (`CG` is `BlockCG`, `GMRES` is
/// `BlockGMRES`) with an Ifpack or ML preconditioner; its default preconditioner is ILU(0),
/// which unlike ML needs no knowledge of the unknowns' grouping into points.
#[derive(Debug, Clone, PartialEq)]
pub struct LinearSolve {
    /// `Backend` (and the Trilinos backend's own preconditioner settings).
    pub backend: LinearBackend,
    /// The deck gave `Backend` (otherwise `peridyn run --backend` may choose it).
    pub backend_given: bool,
    /// `Linear Solver`.
    pub method: LinearMethod,
    /// `Linear Solver Preconditioner` of the native Krylov methods (with `Backend:
    /// "Trilinos"` the choice is in [`LinearBackend::Trilinos`] and this stays `Block 3x3`).
    pub preconditioner: LinearPreconditioner,
    /// The deck gave `Linear Solver Preconditioner` (so `peridyn run --backend petsc` carries
    /// a native choice over instead of taking PETSc's default).
    pub preconditioner_given: bool,
    /// `Linear Solver Tolerance`.
    pub relative_tolerance: f64,
    /// `Linear Solver Maximum Iterations` (`None`: the number of unknowns).
    pub maximum_iterations: Option<u64>,
    /// Belos parameters for `Backend: "Trilinos"`: those of Peridigm's `Belos Print Status`,
    /// then the `Belos` sublist's (names and types checked, in file order); each replaces the
    /// value peridyn would set, a later one an earlier one (see [`super::belos`]).
    pub belos_parameters: Vec<(String, ParameterValue)>,
    /// `PETSc Options` for `Backend: "PETSc"` as (option name without its `-`, value) pairs
    /// in deck order; the syntax is checked by the deck reader, the names and values by PETSc
    /// when the run (or `peridyn check`) sets the solver up. Default none.
    pub petsc_options: Vec<(String, Option<String>)>,
    /// `Nonlinear Solver`: who drives the Newton iteration of `QuasiStatic` and `Implicit`
    /// lists. Default [`NonlinearMethod::Newton`].
    pub nonlinear_method: NonlinearMethod,
}

/// `Nonlinear Solver` of `QuasiStatic` and `Implicit` lists.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NonlinearMethod {
    /// `"Newton"` (default): peridyn's Newton with a backtracking line search.
    Newton,
    /// `"SNES"`: PETSc's SNES `newtonls` (`Backend: "PETSc"`, Cargo feature `petsc`).
    Snes,
}

/// `Linear Solver`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LinearMethod {
    /// `"Automatic"` (default): `Direct` for small systems, `CG` for large ones (Jacobian-free
    /// Newton–Krylov with AMG for large quasi-static ones on the native backend).
    Automatic,
    /// `"Direct"`: sparse Cholesky, LU when the matrix is not positive definite.
    Direct,
    /// `"Cholesky"`: sparse Cholesky only (fails on an indefinite stiffness).
    Cholesky,
    /// `"LU"`: sparse LU.
    Lu,
    /// `"CG"`: preconditioned conjugate gradients.
    Cg,
    /// `"GMRES"`: restarted GMRES.
    Gmres,
}

impl LinearMethod {
    /// Largest number of unknowns `Automatic` solves with a sparse factorization.
    pub const AUTOMATIC_DIRECT_LIMIT: usize = 30_000;
}

/// `Backend`: who solves the assembled linear systems.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LinearBackend {
    /// `"Native"` (default): faer factorizations and our own Krylov methods.
    Native,
    /// `"Trilinos"`: Belos through the Trilinos bridge (Cargo feature `trilinos`).
    Trilinos {
        /// `Linear Solver Preconditioner`.
        preconditioner: AlgebraicPreconditioner,
        /// `Linear Solver ILU Level Of Fill` (default 0).
        ilu_fill_level: u32,
    },
    /// `"PETSc"`: KSP/PC and SNES through the PETSc bindings (Cargo feature `petsc`).
    Petsc {
        /// `Linear Solver Preconditioner`.
        preconditioner: PetscPreconditioner,
        /// `Linear Solver ILU Level Of Fill` (default 0).
        ilu_fill_level: u32,
    },
}

impl LinearBackend {
    /// `Backend: "Trilinos"` with its default preconditioner (ILU(0)).
    pub const TRILINOS_DEFAULT: LinearBackend = LinearBackend::Trilinos {
        preconditioner: AlgebraicPreconditioner::Ilu,
        ilu_fill_level: 0,
    };

    /// `Backend: "PETSc"` with its default preconditioner (block Jacobi with ILU(0) blocks,
    /// PETSc's own default).
    pub const PETSC_DEFAULT: LinearBackend = LinearBackend::Petsc {
        preconditioner: PetscPreconditioner::Ilu,
        ilu_fill_level: 0,
    };
}

impl Solver {
    /// Chooses the backend of an implicit solver list whose deck did not (`peridyn run
    /// --backend`). Direct methods exist on the native backend only, so a list asking for one
    /// cannot move to Trilinos. On PETSc the list's native preconditioner choice carries over
    /// ([`Solver::petsc_preconditioner`]); returns a warning about the `Linear Solver
    /// Preconditioner` key when the choice has no PETSc counterpart.
    pub fn choose_backend(&mut self, backend: LinearBackend) -> Result<Option<String>, String> {
        if self.linear_solve.backend_given || matches!(self.integrator, Integrator::Verlet(_)) {
            return Ok(None);
        }
        let mut warning = None;
        let backend = match backend {
            LinearBackend::Petsc { ilu_fill_level, .. } => {
                let (preconditioner, refused) = self.petsc_preconditioner();
                warning = refused;
                LinearBackend::Petsc {
                    preconditioner,
                    ilu_fill_level,
                }
            }
            other => other,
        };
        if matches!(backend, LinearBackend::Petsc { .. }) && !cfg!(feature = "petsc") {
            return Err(PETSC_NOT_BUILT.to_string());
        }
        if matches!(backend, LinearBackend::Trilinos { .. }) {
            if !cfg!(feature = "trilinos") {
                return Err(TRILINOS_NOT_BUILT.to_string());
            }
            if matches!(
                self.linear_solve.method,
                LinearMethod::Direct | LinearMethod::Cholesky | LinearMethod::Lu
            ) {
                return Err(format!(
                    "solver \"{}\" asks for a direct linear solver, which only Backend \"Native\" has",
                    self.name
                ));
            }
        }
        self.linear_solve.backend = backend;
        Ok(warning)
    }

    /// The PETSc preconditioner of a native list moved to PETSc by `peridyn run --backend
    /// petsc`, the same a list naming `Backend: "PETSc"` gets from the same keys:
    ///
    /// | native `Linear Solver Preconditioner` | PETSc |
    /// |---|---|
    /// | not given | `ILU` (block Jacobi with ILU(0) blocks); `GAMG` with `Peridigm Preconditioner: "AMG"` |
    /// | `Jacobi` | `jacobi` |
    /// | `None` | `none` |
    /// | `AMG` | `gamg` with the rigid-body near-null space |
    /// | `Block 3x3` | `ILU`, and the returned warning: PETSc's point-block Jacobi needs every point to keep three unknowns, which prescribed dofs break |
    pub fn petsc_preconditioner(&self) -> (PetscPreconditioner, Option<String>) {
        let linear = &self.linear_solve;
        if !linear.preconditioner_given {
            let preconditioner = match self.peridigm_preconditioner {
                PeridigmPreconditioner::Amg => PetscPreconditioner::Gamg,
                _ => PetscPreconditioner::Ilu,
            };
            return (preconditioner, None);
        }
        match linear.preconditioner {
            LinearPreconditioner::Jacobi => (PetscPreconditioner::Jacobi, None),
            LinearPreconditioner::None => (PetscPreconditioner::None, None),
            LinearPreconditioner::Amg => (PetscPreconditioner::Gamg, None),
            LinearPreconditioner::Block3x3 => (
                PetscPreconditioner::Ilu,
                Some(
                    "\"Block 3x3\" has no PETSc counterpart (PETSc's point-block Jacobi needs every point to keep three unknowns, which prescribed dofs break): \
                     `--backend petsc` preconditions with block Jacobi and ILU(0) blocks instead; to choose, give Backend: \"PETSc\" with Linear Solver Preconditioner \"ILU\", \"Jacobi\", \"GAMG\", \"Hypre\" or \"None\""
                        .to_string(),
                ),
            ),
        }
    }
}

/// `Linear Solver Preconditioner` values of the Trilinos backend.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AlgebraicPreconditioner {
    /// `"None"`.
    None,
    /// `"Jacobi"`: Ifpack point Jacobi.
    Jacobi,
    /// `"ILU"` (default): Ifpack incomplete LU.
    Ilu,
    /// `"ML"` (or `"AMG"`, the native backend's name for its multigrid, so that a deck keeps
    /// its multigrid when it moves to Trilinos): ML smoothed-aggregation algebraic multigrid.
    Ml,
}

/// `Linear Solver Preconditioner` values of the PETSc backend.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PetscPreconditioner {
    /// `"None"`: `-pc_type none`.
    None,
    /// `"Jacobi"`: `-pc_type jacobi`.
    Jacobi,
    /// `"ILU"` (default): `-pc_type bjacobi` with ILU(k) on each block (one block per process).
    Ilu,
    /// `"GAMG"` (or `"AMG"`): PETSc's smoothed-aggregation multigrid with the rigid-body modes
    /// of the unknowns as its near-null space, on the assembled tangent or (JFNK with
    /// `Peridigm Preconditioner: "AMG"`) the one-hop operator.
    Gamg,
    /// `"Hypre"`: hypre's BoomerAMG (`-pc_type hypre`).
    Hypre,
}

/// `Linear Solver Preconditioner` values of the native backend.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LinearPreconditioner {
    /// `"Block 3x3"`: the inverted diagonal block of each point.
    Block3x3,
    /// `"Jacobi"`: the inverted diagonal.
    Jacobi,
    /// `"None"`.
    None,
    /// `"AMG"`: peridyn's smoothed-aggregation multigrid (additive two-level form) built on the one-hop
    /// PMB-like operator of the model ([`crate::tangent::one_hop_operator`]), built once and
    /// rebuilt only when bonds break or points are held.
    Amg,
}

/// Which fields are unknowns.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SolveFor {
    /// `Solve For Displacement` — default true.
    pub displacement: bool,
    /// `Solve For Temperature` — default false.
    pub temperature: bool,
    /// `Solve For Concentration` — default false.
    pub concentration: bool,
    /// `Solve For Pressure` — default false.
    pub pressure: bool,
}

/// `Peridigm Preconditioner`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PeridigmPreconditioner {
    /// `"Full Tangent"` (default): the assembled tangent.
    FullTangent,
    /// `"Block 3x3"`: inverted 3×3 diagonal blocks of the tangent.
    Block3x3,
    /// `"None"`.
    None,
    /// `"AMG"` (peridyn): with `Jacobian Operator: "Matrix-Free"`, JFNK preconditioned by
    /// multigrid on the one-hop operator, so no tangent is ever assembled: peridyn's own on
    /// the native backend (the default for such a list), ML with the rigid-body modes through
    /// NOX with `Backend: "Trilinos"`, GAMG with `Backend: "PETSc"`.
    Amg,
}

/// The integrator sublist of a solver.
#[derive(Debug, Clone, PartialEq)]
pub enum Integrator {
    /// `Verlet` — explicit velocity Verlet.
    Verlet(Verlet),
    /// `QuasiStatic` — Peridigm's own Newton–Raphson with line search.
    QuasiStatic(QuasiStatic),
    /// `NOXQuasiStatic` — Newton through NOX.
    NoxQuasiStatic(NoxQuasiStatic),
    /// `Implicit` — Newmark-β dynamics.
    Implicit(Implicit),
    /// `ImplicitDiffusion` — Newton on temperature.
    ImplicitDiffusion(ImplicitDiffusion),
}

/// `Verlet` sublist.
#[derive(Debug, Clone, PartialEq)]
pub struct Verlet {
    /// `Fixed dt` (> 0) — overrides the computed stable time step; default none.
    pub fixed_dt: Option<f64>,
    /// `Safety Factor` (> 0) — multiplies the time step (also a fixed one); default 1.0.
    pub safety_factor: f64,
}

/// How a quasi-static run is divided into load steps.
#[derive(Debug, Clone, PartialEq)]
pub enum LoadSteps {
    /// `Number of Load Steps` (≥ 1): equal increments from initial to final time.
    Count(u64),
    /// `Time Steps`: an increasing list of times (whitespace-separated in the deck).
    Times(Vec<f64>),
}

/// `Belos *` settings of Peridigm's linear solves.
#[derive(Debug, Clone, PartialEq)]
pub struct BelosSettings {
    /// `Belos Linear Solver` — `BlockCG` (default) or `BlockGMRES`.
    pub linear_solver: BelosSolver,
    /// `Belos Maximum Iterations` — default: the number of global rows.
    pub maximum_iterations: Option<u64>,
    /// `Belos Relative Tolerance` — default 1e-4.
    pub relative_tolerance: f64,
    /// `Belos Print Status` — default false; true prints Belos' status tests at every
    /// iteration on `Backend: "Trilinos"` (Belos `Verbosity` errors + warnings + status-test
    /// details, `Output Frequency` 1).
    pub print_status: bool,
}

/// `Belos Linear Solver`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BelosSolver {
    /// `"BlockCG"`.
    BlockCg,
    /// `"BlockGMRES"`.
    BlockGmres,
}

/// `QuasiStatic` sublist.
#[derive(Debug, Clone, PartialEq)]
pub struct QuasiStatic {
    /// `Number of Load Steps` or `Time Steps` (exactly one, required).
    pub load_steps: LoadSteps,
    /// `Maximum Solver Iterations` — Newton iterations per load step; default 10.
    pub maximum_solver_iterations: u64,
    /// `Relative Tolerance` — criterion `tol·‖reaction‖₂`; default 1e-6.
    pub relative_tolerance: f64,
    /// `Absolute Tolerance` — if present, used instead of the relative one.
    pub absolute_tolerance: Option<f64>,
    /// `Damped Newton Diagonal Scale Factor` — default 1.0001.
    pub damped_newton_diagonal_scale_factor: f64,
    /// `Damped Newton Diagonal Shift Factor` — default 1e-5.
    pub damped_newton_diagonal_shift_factor: f64,
    /// `Belos *` keys.
    pub belos: BelosSettings,
    /// `Adaptive Load-Stepping` — cut load steps that do not converge; default off.
    pub adaptive_load_stepping: Option<AdaptiveLoadStepping>,
}

/// `QuasiStatic → Adaptive Load-Stepping`.
#[derive(Debug, Clone, PartialEq)]
pub struct AdaptiveLoadStepping {
    /// `Maximum load step reductions in one step` (≥ 0).
    pub max_reductions_in_one_step: Option<u64>,
    /// `Maximum total load step reductions` (≥ 0).
    pub max_total_reductions: Option<u64>,
    /// `Reduce all remaining load steps` — default false.
    pub reduce_all_remaining_load_steps: bool,
    /// `Adaptive output frequency` — default false.
    pub adaptive_output_frequency: bool,
    /// `Switch to Verlet` — continue explicitly when cutting fails.
    pub switch_to_verlet: Option<SwitchToVerlet>,
}

/// `Adaptive Load-Stepping → Switch to Verlet`.
#[derive(Debug, Clone, PartialEq)]
pub struct SwitchToVerlet {
    /// `Fixed dt` (> 0); default: computed stable step.
    pub fixed_dt: Option<f64>,
    /// `Safety Factor` (> 0); default 1.0.
    pub safety_factor: f64,
    /// `Output Frequency` (≥ 1); default none.
    pub output_frequency: Option<u64>,
}

/// `NOXQuasiStatic` sublist. Peridigm's own keys are typed; every other key is handed to NOX.
#[derive(Debug, Clone, PartialEq)]
pub struct NoxQuasiStatic {
    /// `Number of Load Steps` or `Time Steps` (exactly one, required).
    pub load_steps: LoadSteps,
    /// `Max Solver Iterations` — default 50 (note the spelling differs from QuasiStatic).
    pub max_solver_iterations: u64,
    /// `Relative Tolerance` — default 1e-6.
    pub relative_tolerance: f64,
    /// `Absolute Tolerance` — default none.
    pub absolute_tolerance: Option<f64>,
    /// `Verbose` — default false.
    pub verbose: bool,
    /// `Max Age Of Prec` — preconditioner reuse count; default 200.
    pub max_age_of_prec: u64,
    /// `Preconditioner Reuse Policy` — default none.
    pub preconditioner_reuse_policy: Option<String>,
    /// `Direction → Method` — `Newton` or `NonlinearCG` (required; also left in `nox`).
    pub direction_method: String,
    /// Every other key of the list (NOX parameters: `Nonlinear Solver`, `Direction`,
    /// `Line Search`, `Printing`, ...), in file order.
    pub nox: Vec<(String, ParameterValue)>,
}

/// `Implicit` sublist (Newmark-β).
#[derive(Debug, Clone, PartialEq)]
pub struct Implicit {
    /// `Fixed dt` (required, > 0).
    pub fixed_dt: f64,
    /// `Beta` β — default 0.25.
    pub beta: f64,
    /// `Gamma` γ — default 0.5.
    pub gamma: f64,
    /// `Absolute Tolerance` — default 1e-6.
    pub absolute_tolerance: f64,
    /// `Maximum Solver Iterations` — default 10.
    pub maximum_solver_iterations: u64,
}

/// `ImplicitDiffusion` sublist.
#[derive(Debug, Clone, PartialEq)]
pub struct ImplicitDiffusion {
    /// `Number of Load Steps` or `Time Steps` (exactly one, required).
    pub load_steps: LoadSteps,
    /// `Maximum Solver Iterations` — default 10.
    pub maximum_solver_iterations: u64,
    /// `Relative Tolerance` — default 1e-6.
    pub relative_tolerance: f64,
    /// `Absolute Tolerance` — default none.
    pub absolute_tolerance: Option<f64>,
    /// `Belos *` keys.
    pub belos: BelosSettings,
}

/// Top-level NOX parameter names (never reported as typos).
const NOX_TOP_LEVEL: &[&str] = &[
    "Nonlinear Solver",
    "Direction",
    "Line Search",
    "Printing",
    "Solver Options",
    "Trust Region",
    "Status Tests",
    "Tensor",
    "Thyra Group Options",
    "Inexact Trust Region",
];

/// Peridigm's own keys in `NOXQuasiStatic`.
const NOX_PERIDIGM_KEYS: &[&str] = &[
    "Number of Load Steps",
    "Time Steps",
    "Max Solver Iterations",
    "Relative Tolerance",
    "Absolute Tolerance",
    "Verbose",
    "Max Age Of Prec",
    "Preconditioner Reuse Policy",
];

const INTEGRATORS: [&str; 5] = [
    "Verlet",
    "QuasiStatic",
    "NOXQuasiStatic",
    "Implicit",
    "ImplicitDiffusion",
];

/// Reads `Number of Load Steps` / `Time Steps`; returns the steps and the last listed time.
fn read_load_steps(
    ctx: &Ctx,
    list: &mut ListReader,
) -> Result<(LoadSteps, Option<f64>), DeckError> {
    let count = list.get("Number of Load Steps");
    let times = list.get("Time Steps");
    match (count, times) {
        (Some(_), Some(t)) => Err(t.err(
            ctx,
            "give either \"Number of Load Steps\" or \"Time Steps\", not both",
        )),
        (None, None) => Err(list.missing(
            ctx,
            "Number of Load Steps",
            "an integer ≥ 1; or a \"Time Steps\" list",
        )),
        (Some(c), None) => Ok((LoadSteps::Count(c.int_at_least(ctx, 1)? as u64), None)),
        (None, Some(t)) => {
            let text = t.string(ctx)?;
            let mut values = Vec::new();
            for token in text.split_whitespace() {
                let ok =
                    super::tree::is_float_literal(token) || super::tree::is_integer_literal(token);
                match token.parse::<f64>() {
                    Ok(v) if ok => values.push(v),
                    _ => {
                        return Err(t.err(
                            ctx,
                            format!(
                            "\"{token}\" is not a number; Time Steps is a list of increasing times"
                        ),
                        ))
                    }
                }
            }
            if values.len() < 2 {
                return Err(t.err(
                    ctx,
                    "Time Steps needs at least two times (the start and one step)",
                ));
            }
            if let Some(w) = values.windows(2).find(|w| w[1] <= w[0]) {
                return Err(t.err(
                    ctx,
                    format!(
                        "Time Steps must increase strictly; {} is followed by {}",
                        w[0], w[1]
                    ),
                ));
            }
            let last = values.last().copied();
            Ok((LoadSteps::Times(values), last))
        }
    }
}

/// Reads the `Belos *` keys; the flag says whether `Belos Linear Solver` was given.
fn read_belos(ctx: &Ctx, list: &mut ListReader) -> Result<(BelosSettings, bool), DeckError> {
    let given = list.peek("Belos Linear Solver").is_some();
    let settings = BelosSettings {
        linear_solver: match list.get("Belos Linear Solver") {
            None => BelosSolver::BlockCg,
            Some(f) => match f.choice(ctx, &["BlockCG", "BlockGMRES"])? {
                "BlockGMRES" => BelosSolver::BlockGmres,
                _ => BelosSolver::BlockCg,
            },
        },
        maximum_iterations: list
            .int_opt(ctx, "Belos Maximum Iterations", 1)?
            .map(|v| v as u64),
        relative_tolerance: list
            .positive_opt(ctx, "Belos Relative Tolerance")?
            .unwrap_or(1e-4),
        print_status: list.bool_or(ctx, "Belos Print Status", false)?,
    };
    Ok((settings, given))
}

/// Belos `Verbosity` of Peridigm's `Belos Print Status: true`: `Belos::Errors + Warnings +
/// StatusTestDetails` (0 + 0x1 + 0x20).
const BELOS_STATUS_VERBOSITY: i64 = 0x21;

/// The error for `Backend: "PETSc"` in a build without the backend.
pub(crate) const PETSC_NOT_BUILT: &str = "Backend \"PETSc\" needs a peridyn built with the Cargo feature `petsc` \
     (cargo build --release --features petsc, with PETSc, MPI and libclang installed: see .ci/petsc.sh)";

/// The error for `Backend: "Trilinos"` in a build without the backend.
pub(crate) const TRILINOS_NOT_BUILT: &str = "Backend \"Trilinos\" needs a peridyn built with the Cargo feature `trilinos` \
     (cargo build --release --features trilinos, with Trilinos and MPI installed: see .ci/trilinos.sh); \
     this build has the \"Native\" backend only";

/// Reads the peridyn linear-solver keys of a `Solver` list, with defaults from Peridigm's
/// `Belos` settings when the deck chose a Belos solver.
fn read_linear_solve(
    ctx: &mut Ctx,
    list: &mut ListReader,
    belos: Option<(&BelosSettings, bool)>,
) -> Result<LinearSolve, DeckError> {
    let belos_method = belos.and_then(|(b, given)| {
        given.then_some(match b.linear_solver {
            BelosSolver::BlockCg => LinearMethod::Cg,
            BelosSolver::BlockGmres => LinearMethod::Gmres,
        })
    });
    let method = match list.get("Linear Solver") {
        None => belos_method.unwrap_or(LinearMethod::Automatic),
        Some(f) => match f.choice(
            ctx,
            &["Automatic", "Direct", "Cholesky", "LU", "CG", "GMRES"],
        )? {
            "Automatic" => LinearMethod::Automatic,
            "Cholesky" => LinearMethod::Cholesky,
            "LU" => LinearMethod::Lu,
            "CG" => LinearMethod::Cg,
            "GMRES" => LinearMethod::Gmres,
            _ => LinearMethod::Direct,
        },
    };
    let backend_given = list.peek("Backend").is_some();
    let preconditioner_given = list.peek("Linear Solver Preconditioner").is_some();
    let chosen = match list.get("Backend") {
        None => Chosen::Native,
        Some(f) => match f.choice(ctx, &["Native", "Trilinos", "PETSc"])? {
            "Trilinos" if !cfg!(feature = "trilinos") => {
                return Err(f.err(ctx, TRILINOS_NOT_BUILT));
            }
            "PETSc" if !cfg!(feature = "petsc") => {
                return Err(f.err(ctx, PETSC_NOT_BUILT));
            }
            "Trilinos" => Chosen::Trilinos,
            "PETSc" => Chosen::Petsc,
            _ => Chosen::Native,
        },
    };
    let trilinos = chosen == Chosen::Trilinos;
    let (backend, preconditioner) = if chosen == Chosen::Petsc {
        read_petsc_preconditioner(ctx, list)?
    } else {
        read_preconditioner(ctx, list, method, trilinos)?
    };
    let petsc_options = match list.get("PETSc Options") {
        None => Vec::new(),
        Some(f) => {
            let text = f.string(ctx)?;
            let options = parse_petsc_options(&text).map_err(|e| f.err(ctx, e))?;
            if backend_given && chosen != Chosen::Petsc {
                ctx.warn(
                    f.line(),
                    &f.path,
                    "PETSc Options apply to Backend \"PETSc\" only; ignored",
                );
            }
            options
        }
    };
    let nonlinear_method = match list.get("Nonlinear Solver") {
        None => NonlinearMethod::Newton,
        Some(f) => match f.choice(ctx, &["Newton", "SNES"])? {
            "SNES" if backend_given && chosen != Chosen::Petsc => {
                return Err(f.err(
                    ctx,
                    "Nonlinear Solver \"SNES\" is PETSc's: give Backend \"PETSc\" (or remove the key for peridyn's Newton)",
                ));
            }
            "SNES" => NonlinearMethod::Snes,
            _ => NonlinearMethod::Newton,
        },
    };
    let relative_tolerance = match list.positive_opt(ctx, "Linear Solver Tolerance")? {
        Some(t) => t,
        None => match belos {
            Some((b, true)) => b.relative_tolerance,
            _ => 1e-10,
        },
    };
    let maximum_iterations = match list.int_opt(ctx, "Linear Solver Maximum Iterations", 1)? {
        Some(m) => Some(m as u64),
        None => belos.and_then(|(b, _)| b.maximum_iterations),
    };
    let mut belos_parameters = match belos {
        // Peridigm's `Belos Print Status`: status-test output at every iteration.
        Some((b, _)) if b.print_status => vec![
            (
                "Verbosity".to_string(),
                ParameterValue::Int(BELOS_STATUS_VERBOSITY),
            ),
            ("Output Frequency".to_string(), ParameterValue::Int(1)),
        ],
        _ => Vec::new(),
    };
    belos_parameters.extend(match list.get("Belos") {
        None => Vec::new(),
        Some(f) if backend_given && !trilinos => {
            ctx.warn(
                f.line(),
                &f.path,
                "the Belos parameters apply to Backend \"Trilinos\" only; ignored",
            );
            Vec::new()
        }
        Some(f) => super::belos::read(ctx, &f, method == LinearMethod::Gmres)?,
    });
    Ok(LinearSolve {
        backend,
        backend_given,
        method,
        preconditioner,
        preconditioner_given,
        relative_tolerance,
        maximum_iterations,
        belos_parameters,
        petsc_options,
        nonlinear_method,
    })
}

/// The `Backend` a solver list names.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Chosen {
    Native,
    Trilinos,
    Petsc,
}

/// The options of a `PETSc Options` string: whitespace-separated, each option a `-` followed
/// by a letter and then letters, digits or `_`, optionally followed by one value (a token that
/// is not an option: a negative number such as `-1e-3` is a value). Returns (name without the
/// `-`, value) pairs in order, or what is wrong and how to write it.
pub fn parse_petsc_options(text: &str) -> Result<Vec<(String, Option<String>)>, String> {
    let is_option = |token: &str| {
        token
            .strip_prefix('-')
            .and_then(|name| name.chars().next())
            .is_some_and(|c| c.is_ascii_alphabetic())
    };
    let mut options: Vec<(String, Option<String>)> = Vec::new();
    for token in text.split_whitespace() {
        if is_option(token) {
            let name = &token[1..];
            if !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
                return Err(format!(
                    "\"{token}\" is not a PETSc option name (letters, digits and _ after the -), e.g. \"-ksp_type gmres -pc_type gamg\""
                ));
            }
            options.push((name.to_string(), None));
            continue;
        }
        match options.last_mut() {
            Some((_, value @ None)) => *value = Some(token.to_string()),
            Some((name, Some(previous))) => {
                return Err(format!(
                    "\"{token}\" follows \"-{name} {previous}\": a PETSc option takes one value; start each option with -, e.g. \"-ksp_type gmres -pc_type gamg\""
                ))
            }
            None => {
                return Err(format!(
                    "\"{token}\" is not an option: PETSc options start with -, e.g. \"-ksp_type gmres -pc_type gamg\""
                ))
            }
        }
    }
    Ok(options)
}

/// `Linear Solver Preconditioner` and `Linear Solver ILU Level Of Fill` for the PETSc backend;
/// returns the backend and the native preconditioner (`Block 3x3`, unused on PETSc).
fn read_petsc_preconditioner(
    ctx: &mut Ctx,
    list: &mut ListReader,
) -> Result<(LinearBackend, LinearPreconditioner), DeckError> {
    let preconditioner = match list.get("Linear Solver Preconditioner") {
        None => PetscPreconditioner::Ilu,
        Some(f) => match f.choice(
            ctx,
            &["ILU", "Jacobi", "GAMG", "Hypre", "None", "Block 3x3", "AMG", "ML"],
        )? {
            "ILU" => PetscPreconditioner::Ilu,
            "Jacobi" => PetscPreconditioner::Jacobi,
            "GAMG" | "AMG" => PetscPreconditioner::Gamg,
            "Hypre" => PetscPreconditioner::Hypre,
            "None" => PetscPreconditioner::None,
            other => {
                return Err(f.err(
                    ctx,
                    format!("\"{other}\" is not a PETSc preconditioner; with Backend \"PETSc\" choose \"ILU\", \"GAMG\" (or \"AMG\"), \"Hypre\", \"Jacobi\" or \"None\" (or give -pc_type in PETSc Options)"),
                ))
            }
        },
    };
    let ilu_fill_level = list
        .int_opt(ctx, "Linear Solver ILU Level Of Fill", 0)?
        .map_or(0, |v| v as u32);
    Ok((
        LinearBackend::Petsc {
            preconditioner,
            ilu_fill_level,
        },
        LinearPreconditioner::Block3x3,
    ))
}

/// `Linear Solver Preconditioner` and `Linear Solver ILU Level Of Fill` for the Trilinos
/// backend (`trilinos`) or the native one; returns the backend with its preconditioner
/// settings and the native preconditioner (`Block 3x3` on Trilinos).
fn read_preconditioner(
    ctx: &mut Ctx,
    list: &mut ListReader,
    method: LinearMethod,
    trilinos: bool,
) -> Result<(LinearBackend, LinearPreconditioner), DeckError> {
    let given_preconditioner = match list.get("Linear Solver Preconditioner") {
        None => None,
        Some(f) => Some((
            f.choice(ctx, &["Block 3x3", "Jacobi", "None", "AMG", "ILU", "ML"])?,
            f,
        )),
    };
    let ilu_field = list.get("Linear Solver ILU Level Of Fill");
    let ilu_fill_level = list
        .int_opt(ctx, "Linear Solver ILU Level Of Fill", 0)?
        .map_or(0, |v| v as u32);
    if trilinos {
        if matches!(
            method,
            LinearMethod::Direct | LinearMethod::Cholesky | LinearMethod::Lu
        ) {
            let f = list
                .peek("Linear Solver")
                .expect("a direct method is only chosen by this key");
            return Err(f.err(
                ctx,
                "Backend \"Trilinos\" solves with Belos Krylov methods: use \"CG\", \"GMRES\" or \"Automatic\" \
                 (direct solves are on Backend \"Native\")",
            ));
        }
        let algebraic = match given_preconditioner {
            None | Some(("ILU", _)) => AlgebraicPreconditioner::Ilu,
            Some(("ML" | "AMG", _)) => AlgebraicPreconditioner::Ml,
            Some(("Jacobi", _)) => AlgebraicPreconditioner::Jacobi,
            Some(("None", _)) => AlgebraicPreconditioner::None,
            Some((native, f)) => {
                return Err(f.err(
                    ctx,
                    format!("\"{native}\" is a native preconditioner; with Backend \"Trilinos\" choose \"ILU\", \"ML\", \"Jacobi\" or \"None\""),
                ))
            }
        };
        let backend = LinearBackend::Trilinos {
            preconditioner: algebraic,
            ilu_fill_level,
        };
        return Ok((backend, LinearPreconditioner::Block3x3));
    }
    if let Some((choice @ ("ILU" | "ML"), f)) = given_preconditioner {
        return Err(f.err(
                ctx,
                format!("\"{choice}\" is a Trilinos preconditioner: add Backend: \"Trilinos\" to this solver list, or choose \"Block 3x3\", \"AMG\", \"Jacobi\" or \"None\""),
            ));
    }
    if let Some(f) = ilu_field {
        ctx.warn(
            f.line(),
            &f.path,
            "Linear Solver ILU Level Of Fill applies to Backend \"Trilinos\" only; ignored",
        );
    }
    let preconditioner = match given_preconditioner {
        Some(("Jacobi", _)) => LinearPreconditioner::Jacobi,
        Some(("None", _)) => LinearPreconditioner::None,
        Some(("AMG", _)) => LinearPreconditioner::Amg,
        _ => LinearPreconditioner::Block3x3,
    };
    Ok((LinearBackend::Native, preconditioner))
}

fn read_adaptive(ctx: &mut Ctx, field: &Field) -> Result<AdaptiveLoadStepping, DeckError> {
    let mut list = field.list(ctx)?;
    let switch_to_verlet = match list.list_opt(ctx, "Switch to Verlet")? {
        None => None,
        Some(mut s) => {
            let v = SwitchToVerlet {
                fixed_dt: s.positive_opt(ctx, "Fixed dt")?,
                safety_factor: s.positive_opt(ctx, "Safety Factor")?.unwrap_or(1.0),
                output_frequency: s.int_opt(ctx, "Output Frequency", 1)?.map(|v| v as u64),
            };
            s.finish(ctx, &[])?;
            Some(v)
        }
    };
    let out = AdaptiveLoadStepping {
        max_reductions_in_one_step: list
            .int_opt(ctx, "Maximum load step reductions in one step", 0)?
            .map(|v| v as u64),
        max_total_reductions: list
            .int_opt(ctx, "Maximum total load step reductions", 0)?
            .map(|v| v as u64),
        reduce_all_remaining_load_steps: list.bool_or(
            ctx,
            "Reduce all remaining load steps",
            false,
        )?,
        adaptive_output_frequency: list.bool_or(ctx, "Adaptive output frequency", false)?,
        switch_to_verlet,
    };
    list.finish(ctx, &[])?;
    Ok(out)
}

/// Reads one `Solver*` list; `first` tells whether it is the first one (which alone decides the
/// `Solve For *` switches in Peridigm).
pub(crate) fn read(ctx: &mut Ctx, field: &Field, first: bool) -> Result<Solver, DeckError> {
    let mut list = field.list(ctx)?;
    let integrator_field = only_integrator(ctx, &mut list)?;
    let initial_time = list.f64_opt(ctx, "Initial Time")?.unwrap_or(0.0);
    let final_field = list.get("Final Time");
    let final_given = final_field.as_ref().map(|f| f.f64(ctx)).transpose()?;
    let read = read_integrator(ctx, &list, &integrator_field, final_given)?;
    if read.final_time <= initial_time {
        let line = final_field.as_ref().map_or(list.line, |f| f.line());
        let mut path = list.path.clone();
        path.push("Final Time".into());
        return Err(ctx.error(
            Some(line),
            &path,
            format!(
                "Final Time ({}) must be larger than Initial Time ({initial_time})",
                read.final_time
            ),
        ));
    }
    let peridigm_preconditioner = read_peridigm_preconditioner(ctx, &mut list)?;
    let solve_for = read_solve_for(ctx, &mut list, first)?;
    let integrator = read.integrator;
    let belos = match &integrator {
        Integrator::QuasiStatic(q) => Some((&q.belos, read.belos_given)),
        _ => None,
    };
    let preconditioner_given = list.peek("Linear Solver Preconditioner").is_some();
    let mut linear_solve = read_linear_solve(ctx, &mut list, belos)?;
    // On PETSc, `Peridigm Preconditioner: "AMG"` is GAMG on the one-hop operator unless the
    // list names another PC.
    if let LinearBackend::Petsc { preconditioner, .. } = &mut linear_solve.backend {
        if peridigm_preconditioner == PeridigmPreconditioner::Amg && !preconditioner_given {
            *preconditioner = PetscPreconditioner::Gamg;
        }
    }
    // A Peridigm deck that names NOX gets NOX when this build has it; `Peridigm Preconditioner:
    // "AMG"` is peridyn's own multigrid (no Peridigm deck has it), so such a list stays native.
    if matches!(integrator, Integrator::NoxQuasiStatic(_))
        && !linear_solve.backend_given
        && peridigm_preconditioner != PeridigmPreconditioner::Amg
        && cfg!(feature = "trilinos")
    {
        linear_solve.backend = LinearBackend::TRILINOS_DEFAULT;
    }
    let solver = Solver {
        name: field.key().to_string(),
        initial_time,
        final_time: read.final_time,
        verbose: list.bool_or(ctx, "Verbose", false)?,
        disable_heuristics: list.bool_or(ctx, "Disable Heuristics", false)?,
        initialize_predictor_from_previous_solver: list.bool_or(
            ctx,
            "Initialize Predictor From Previous Solver",
            false,
        )?,
        jacobian_diagnostics: list.flag_without_effect(
            ctx,
            "Jacobian Diagnostics",
            false,
            true,
            "peridyn prints no Jacobian diagnostics",
        )?,
        peridigm_preconditioner,
        solve_for,
        integrator,
        linear_solve,
    };
    list.finish(ctx, &[])?;
    Ok(solver)
}

/// The one integrator sublist of a solver list (none or several is an error).
fn only_integrator<'t>(ctx: &Ctx, list: &mut ListReader<'t>) -> Result<Field<'t>, DeckError> {
    let mut present: Vec<Field> = INTEGRATORS.iter().filter_map(|k| list.get(k)).collect();
    match present.len() {
        0 => Err(ctx.error(
            Some(list.line),
            &list.path,
            "no time integrator; add exactly one of the sublists Verlet, QuasiStatic, NOXQuasiStatic, Implicit, ImplicitDiffusion",
        )),
        1 => Ok(present.remove(0)),
        _ => {
            let names = present.iter().map(|f| f.key()).collect::<Vec<_>>().join(", ");
            Err(present[1].err(ctx, format!("a solver list holds exactly one integrator, found {names}; put each in its own Solver list (they run in file order)")))
        }
    }
}

/// An integrator sublist as read, with the solver's final time it implies.
struct ReadIntegrator {
    integrator: Integrator,
    final_time: f64,
    /// The deck gave `Belos Linear Solver` (QuasiStatic only).
    belos_given: bool,
}

/// Reads the integrator sublist `field` of the solver list `list`; `final_given` is the list's
/// `Final Time`.
fn read_integrator(
    ctx: &mut Ctx,
    list: &ListReader,
    field: &Field,
    final_given: Option<f64>,
) -> Result<ReadIntegrator, DeckError> {
    let mut integ = field.list(ctx)?;
    let mut belos_given = false;
    let (integrator, final_time) = match field.key() {
        "Verlet" => {
            let v = Verlet {
                fixed_dt: integ.positive_opt(ctx, "Fixed dt")?,
                safety_factor: integ.positive_opt(ctx, "Safety Factor")?.unwrap_or(1.0),
            };
            integ.finish(ctx, &[])?;
            (Integrator::Verlet(v), final_given.unwrap_or(1.0))
        }
        "QuasiStatic" => {
            let (q, last, given) = read_quasi_static(ctx, integ)?;
            belos_given = given;
            let final_time = final_time_for_steps(ctx, list, final_given, last)?;
            (Integrator::QuasiStatic(q), final_time)
        }
        "NOXQuasiStatic" => {
            let (n, last) = read_nox_quasi_static(ctx, &mut integ)?;
            let final_time = final_time_for_steps(ctx, list, final_given, last)?;
            (Integrator::NoxQuasiStatic(n), final_time)
        }
        "Implicit" => {
            let i = Implicit {
                fixed_dt: integ.positive_req(ctx, "Fixed dt")?,
                beta: integ.positive_opt(ctx, "Beta")?.unwrap_or(0.25),
                gamma: integ.positive_opt(ctx, "Gamma")?.unwrap_or(0.5),
                absolute_tolerance: integ
                    .positive_opt(ctx, "Absolute Tolerance")?
                    .unwrap_or(1e-6),
                maximum_solver_iterations: integ
                    .int_opt(ctx, "Maximum Solver Iterations", 1)?
                    .unwrap_or(10) as u64,
            };
            integ.finish(ctx, &[])?;
            let Some(final_time) = final_given else {
                return Err(list.missing(
                    ctx,
                    "Final Time",
                    "a number; the Implicit integrator needs it",
                ));
            };
            (Integrator::Implicit(i), final_time)
        }
        "ImplicitDiffusion" => {
            let (load_steps, last) = read_load_steps(ctx, &mut integ)?;
            let d = ImplicitDiffusion {
                load_steps,
                maximum_solver_iterations: integ
                    .int_opt(ctx, "Maximum Solver Iterations", 1)?
                    .unwrap_or(10) as u64,
                relative_tolerance: integ
                    .positive_opt(ctx, "Relative Tolerance")?
                    .unwrap_or(1e-6),
                absolute_tolerance: integ.positive_opt(ctx, "Absolute Tolerance")?,
                belos: read_belos(ctx, &mut integ)?.0,
            };
            integ.finish(ctx, &[])?;
            let final_time = final_time_for_steps(ctx, list, final_given, last)?;
            (Integrator::ImplicitDiffusion(d), final_time)
        }
        _ => unreachable!("only integrator names are looked up"),
    };
    Ok(ReadIntegrator {
        integrator,
        final_time,
        belos_given,
    })
}

/// Reads a `QuasiStatic` sublist; also returns the last listed load-step time and whether
/// `Belos Linear Solver` was given.
fn read_quasi_static(
    ctx: &mut Ctx,
    mut integ: ListReader,
) -> Result<(QuasiStatic, Option<f64>, bool), DeckError> {
    let (load_steps, last) = read_load_steps(ctx, &mut integ)?;
    let adaptive = integ.get("Adaptive Load-Stepping");
    let maximum_solver_iterations = integ
        .int_opt(ctx, "Maximum Solver Iterations", 1)?
        .unwrap_or(10) as u64;
    let relative_tolerance = integ
        .positive_opt(ctx, "Relative Tolerance")?
        .unwrap_or(1e-6);
    let absolute_tolerance = integ.positive_opt(ctx, "Absolute Tolerance")?;
    let damped_newton_diagonal_scale_factor = integ
        .positive_opt(ctx, "Damped Newton Diagonal Scale Factor")?
        .unwrap_or(1.0001);
    let damped_newton_diagonal_shift_factor = integ
        .non_negative_opt(ctx, "Damped Newton Diagonal Shift Factor")?
        .unwrap_or(1e-5);
    let (belos, belos_given) = read_belos(ctx, &mut integ)?;
    let q = QuasiStatic {
        load_steps,
        maximum_solver_iterations,
        relative_tolerance,
        absolute_tolerance,
        damped_newton_diagonal_scale_factor,
        damped_newton_diagonal_shift_factor,
        belos,
        adaptive_load_stepping: adaptive.map(|f| read_adaptive(ctx, &f)).transpose()?,
    };
    integ.finish(ctx, &[])?;
    Ok((q, last, belos_given))
}

/// Reads a `NOXQuasiStatic` sublist: Peridigm's own keys typed, every other key kept for NOX;
/// also returns the last listed load-step time.
fn read_nox_quasi_static(
    ctx: &mut Ctx,
    integ: &mut ListReader,
) -> Result<(NoxQuasiStatic, Option<f64>), DeckError> {
    let (load_steps, last) = read_load_steps(ctx, integ)?;
    let direction_method = read_direction_method(ctx, integ)?;
    if let Some(f) = integ.get("Maximum Solver Iterations") {
        return Err(f.err(ctx, "NOXQuasiStatic spells this \"Max Solver Iterations\" (QuasiStatic uses \"Maximum Solver Iterations\")"));
    }
    let max_solver_iterations = integ
        .int_opt(ctx, "Max Solver Iterations", 1)?
        .unwrap_or(50) as u64;
    let relative_tolerance = integ
        .positive_opt(ctx, "Relative Tolerance")?
        .unwrap_or(1e-6);
    let absolute_tolerance = integ.positive_opt(ctx, "Absolute Tolerance")?;
    let verbose = integ.bool_or(ctx, "Verbose", false)?;
    let max_age_of_prec = integ.int_opt(ctx, "Max Age Of Prec", 1)?.unwrap_or(200) as u64;
    let preconditioner_reuse_policy = integ.name_opt(ctx, "Preconditioner Reuse Policy")?;
    // NOX accepts any parameter, so the rest is handed on; but a near miss of one of
    // Peridigm's own keys is almost certainly a typo that would be silently ignored.
    let rest = integ.take_rest();
    for f in &rest {
        if NOX_TOP_LEVEL.contains(&f.key()) {
            continue;
        }
        if let Some(s) = super::reader::suggest(f.key(), NOX_PERIDIGM_KEYS.iter().copied()) {
            return Err(f.err(ctx, format!("unknown key; did you mean \"{s}\"?")));
        }
    }
    let n = NoxQuasiStatic {
        load_steps,
        max_solver_iterations,
        relative_tolerance,
        absolute_tolerance,
        verbose,
        max_age_of_prec,
        preconditioner_reuse_policy,
        direction_method,
        nox: rest
            .into_iter()
            .map(|f| (f.key().to_string(), to_parameter_value(f.entry)))
            .collect(),
    };
    Ok((n, last))
}

/// `NOXQuasiStatic → Direction → Method`, read in place: the `Direction` list itself stays
/// in the list for NOX.
fn read_direction_method(ctx: &mut Ctx, integ: &mut ListReader) -> Result<String, DeckError> {
    let direction = integ.peek("Direction");
    let method = direction
        .as_ref()
        .and_then(|d| d.node().as_list())
        .and_then(|entries| entries.iter().find(|e| e.key == "Method"));
    match (&direction, method) {
        (None, _) => Err(integ.missing(
            ctx,
            "Direction",
            "a list with Method: \"Newton\" or \"NonlinearCG\"",
        )),
        (Some(d), None) => {
            let d = d.list(ctx)?;
            Err(d.missing(ctx, "Method", "\"Newton\" or \"NonlinearCG\""))
        }
        (Some(d), Some(entry)) => {
            let mut path = d.path.clone();
            path.push("Method".into());
            let f = Field { entry, path };
            Ok(f.choice(ctx, &["Newton", "NonlinearCG"])?.to_string())
        }
    }
}

/// `Peridigm Preconditioner` (default `Full Tangent`; `AMG` is peridyn's).
fn read_peridigm_preconditioner(
    ctx: &mut Ctx,
    list: &mut ListReader,
) -> Result<PeridigmPreconditioner, DeckError> {
    Ok(match list.get("Peridigm Preconditioner") {
        None => PeridigmPreconditioner::FullTangent,
        Some(f) => match f.choice(ctx, &["Full Tangent", "Block 3x3", "None", "AMG"])? {
            "Block 3x3" => PeridigmPreconditioner::Block3x3,
            "AMG" => PeridigmPreconditioner::Amg,
            "None" => PeridigmPreconditioner::None,
            _ => PeridigmPreconditioner::FullTangent,
        },
    })
}

/// The `Solve For *` switches; only the `first` solver list decides them (as in Peridigm), a
/// later one gets a warning.
fn read_solve_for(
    ctx: &mut Ctx,
    list: &mut ListReader,
    first: bool,
) -> Result<SolveFor, DeckError> {
    let mut solve_for = SolveFor {
        displacement: true,
        temperature: false,
        concentration: false,
        pressure: false,
    };
    for (key, slot) in [
        ("Solve For Displacement", &mut solve_for.displacement),
        ("Solve For Temperature", &mut solve_for.temperature),
        ("Solve For Concentration", &mut solve_for.concentration),
        ("Solve For Pressure", &mut solve_for.pressure),
    ] {
        if let Some(f) = list.get(key) {
            *slot = f.bool(ctx)?;
            if !first {
                ctx.warn(f.line(), &f.path, "only the first solver list decides which fields are solved for (as in Peridigm); this setting is ignored");
            }
        }
    }
    Ok(solve_for)
}

fn final_time_for_steps(
    ctx: &Ctx,
    list: &ListReader,
    given: Option<f64>,
    last_listed: Option<f64>,
) -> Result<f64, DeckError> {
    match (given, last_listed) {
        (Some(t), _) => Ok(t),
        (None, Some(t)) => Ok(t),
        (None, None) => Err(list.missing(
            ctx,
            "Final Time",
            "a number; load steps divide the time from Initial Time to Final Time",
        )),
    }
}

impl Integrator {
    /// The integrator sublist name, as written in decks.
    pub fn deck_name(&self) -> &'static str {
        match self {
            Integrator::Verlet(_) => "Verlet",
            Integrator::QuasiStatic(_) => "QuasiStatic",
            Integrator::NoxQuasiStatic(_) => "NOXQuasiStatic",
            Integrator::Implicit(_) => "Implicit",
            Integrator::ImplicitDiffusion(_) => "ImplicitDiffusion",
        }
    }

    /// True for the solvers that need a tangent stiffness matrix.
    pub fn is_implicit(&self) -> bool {
        !matches!(self, Integrator::Verlet(_))
    }
}

#[cfg(test)]
pub(super) mod linear_solve_tests {
    use super::*;
    use crate::io::deck::{parse_str, DeckFormat};
    use std::path::Path;

    /// The linear-solver settings of [`deck`] with `keys`.
    fn linear_solve(keys: &str) -> Result<LinearSolve, DeckError> {
        Ok(deck(keys)?.solvers[0].linear_solve.clone())
    }

    /// A three-point quasi-static bar whose `Solver` list gets `keys`.
    fn deck(keys: &str) -> Result<crate::io::deck::Deck, DeckError> {
        deck_with(keys, "")
    }

    /// [`deck`] whose `QuasiStatic` list also gets `quasi_static_keys`.
    fn deck_with(keys: &str, quasi_static_keys: &str) -> Result<crate::io::deck::Deck, DeckError> {
        parse_str(
            &deck_text(keys, quasi_static_keys),
            DeckFormat::Yaml,
            Path::new("linear.yaml"),
        )
    }

    /// The text of [`deck_with`].
    fn deck_text(keys: &str, quasi_static_keys: &str) -> String {
        three_point_bar_text(&format!(
            "    Final Time: 1.0\n{keys}\n    QuasiStatic:\n      Number of Load Steps: 2\n{quasi_static_keys}"
        ))
    }

    /// A three-point steel bar deck (Elastic, horizon 2) whose `Solver` list holds the lines
    /// `solver_list` (indented as its children), for tests of solver-list keys.
    pub(crate) fn three_point_bar_text(solver_list: &str) -> String {
        format!(
            r#"Peridigm:
  Discretization:
    Type: "PdQuickGrid"
    NeighborhoodType: "Spherical"
    TensorProduct3DMeshGenerator:
      X Origin: 0.0
      Y Origin: 0.0
      Z Origin: 0.0
      X Length: 3.0
      Y Length: 1.0
      Z Length: 1.0
      Number Points X: 3
      Number Points Y: 1
      Number Points Z: 1
  Materials:
    Steel:
      Material Model: "Elastic"
      Density: 7800.0
      Bulk Modulus: 130.0e9
      Shear Modulus: 78.0e9
  Blocks:
    Everything:
      Block Names: "block_1"
      Material: "Steel"
      Horizon: 2
  Solver:
{solver_list}
  Output:
    Output Filename: "bar"
    Output Variables:
      Displacement: true
"#
        )
    }

    /// The warnings of the deck of [`linear_solve`] with `keys`.
    fn warnings(keys: &str) -> Vec<String> {
        deck(keys).unwrap().warnings
    }

    #[test]
    fn the_belos_sublist_is_read_with_belos_types() {
        let settings = linear_solve(
            "    Linear Solver: \"GMRES\"\n    Belos:\n      Maximum Iterations: 7\n      Convergence Tolerance: 1\n      Num Blocks: 30\n      Orthogonalization: \"ICGS\"\n      Flexible Gmres: false",
        )
        .unwrap();
        assert_eq!(
            settings.belos_parameters,
            vec![
                ("Maximum Iterations".to_string(), ParameterValue::Int(7)),
                // Integers are accepted for doubles and stored as doubles (Belos reads a double).
                (
                    "Convergence Tolerance".to_string(),
                    ParameterValue::Double(1.0)
                ),
                ("Num Blocks".to_string(), ParameterValue::Int(30)),
                (
                    "Orthogonalization".to_string(),
                    ParameterValue::String("ICGS".into())
                ),
                ("Flexible Gmres".to_string(), ParameterValue::Bool(false)),
            ]
        );
        assert!(linear_solve("").unwrap().belos_parameters.is_empty());
    }

    #[test]
    fn peridigm_belos_print_status_asks_belos_for_status_output() {
        let deck = deck_with(
            "    Belos:\n      Output Frequency: 5",
            "      Belos Print Status: true",
        )
        .unwrap();
        assert_eq!(
            deck.solvers[0].linear_solve.belos_parameters,
            vec![
                ("Verbosity".to_string(), ParameterValue::Int(0x21)),
                ("Output Frequency".to_string(), ParameterValue::Int(1)),
                // The sublist comes last and wins.
                ("Output Frequency".to_string(), ParameterValue::Int(5)),
            ]
        );
    }

    #[test]
    fn an_unknown_or_mistyped_belos_parameter_is_an_error_with_its_line() {
        let error = linear_solve("    Belos:\n      Maximum Iteration: 7")
            .unwrap_err()
            .to_string();
        assert!(
            error.contains("did you mean \"Maximum Iterations\""),
            "{error}"
        );
        assert!(error.contains("linear.yaml:29"), "{error}");
        assert!(error.contains("Belos → Maximum Iteration"), "{error}");
        let error = linear_solve("    Belos:\n      Output Stream: \"cout\"")
            .unwrap_err()
            .to_string();
        assert!(error.contains("unknown Belos parameter"), "{error}");
        let error = linear_solve("    Belos:\n      Maximum Iterations: 7.5")
            .unwrap_err()
            .to_string();
        assert!(error.contains("expected an integer"), "{error}");
    }

    #[test]
    fn a_belos_parameter_the_chosen_solver_does_not_read_is_a_warning() {
        let cg = warnings("    Linear Solver: \"CG\"\n    Belos:\n      Num Blocks: 30");
        assert!(
            cg.iter()
                .any(|w| w.contains("Num Blocks") && w.contains("only Belos BlockGMRES")),
            "{cg:?}"
        );
        let native = warnings("    Backend: \"Native\"\n    Belos:\n      Maximum Iterations: 7");
        assert!(
            native
                .iter()
                .any(|w| w.contains("Backend \"Trilinos\" only")),
            "{native:?}"
        );
    }

    #[test]
    fn native_is_the_default_backend_with_block_jacobi() {
        let settings = linear_solve("").unwrap();
        assert_eq!(settings.backend, LinearBackend::Native);
        assert_eq!(settings.preconditioner, LinearPreconditioner::Block3x3);
        assert_eq!(settings.method, LinearMethod::Automatic);
    }

    #[test]
    fn amg_is_a_native_preconditioner_for_newton_and_jfnk() {
        let settings = linear_solve("    Linear Solver Preconditioner: \"AMG\"").unwrap();
        assert_eq!(settings.backend, LinearBackend::Native);
        assert_eq!(settings.preconditioner, LinearPreconditioner::Amg);
        let solver = &deck("    Peridigm Preconditioner: \"AMG\"")
            .unwrap()
            .solvers[0];
        assert_eq!(solver.peridigm_preconditioner, PeridigmPreconditioner::Amg);
        let error = linear_solve("    Linear Solver Preconditioner: \"AMGX\"")
            .unwrap_err()
            .to_string();
        assert!(error.contains("AMGX") && error.contains("AMG"), "{error}");
        assert!(error.contains("linear.yaml"), "{error}");
    }

    #[test]
    fn trilinos_preconditioners_need_the_trilinos_backend() {
        let error = linear_solve("    Linear Solver Preconditioner: \"ILU\"")
            .unwrap_err()
            .to_string();
        assert!(error.contains("Backend: \"Trilinos\""), "{error}");
        assert!(error.contains("linear.yaml"), "{error}");
    }

    #[cfg(not(feature = "trilinos"))]
    #[test]
    fn the_trilinos_backend_without_the_feature_names_the_feature() {
        let error = linear_solve("    Backend: \"Trilinos\"")
            .unwrap_err()
            .to_string();
        assert!(error.contains("--features trilinos"), "{error}");
        assert!(error.contains("Backend"), "{error}");
    }

    #[cfg(feature = "trilinos")]
    #[test]
    fn amg_on_the_trilinos_backend_is_ml_and_block_3x3_names_its_alternatives() {
        let amg =
            linear_solve("    Backend: \"Trilinos\"\n    Linear Solver Preconditioner: \"AMG\"")
                .unwrap();
        assert!(
            matches!(
                amg.backend,
                LinearBackend::Trilinos {
                    preconditioner: AlgebraicPreconditioner::Ml,
                    ..
                }
            ),
            "{amg:?}"
        );
        let error = linear_solve(
            "    Backend: \"Trilinos\"\n    Linear Solver Preconditioner: \"Block 3x3\"",
        )
        .unwrap_err()
        .to_string();
        assert!(
            error.contains("\"Block 3x3\" is a native preconditioner") && error.contains("\"ML\""),
            "{error}"
        );
    }

    /// The backend a `NOXQuasiStatic` list gets without a `Backend` key, with `Peridigm
    /// Preconditioner` `preconditioner`.
    fn nox_default_backend(preconditioner: &str) -> LinearBackend {
        let text = deck_text("", "").replace(
            "    QuasiStatic:\n      Number of Load Steps: 2\n",
            &format!(
                "    Peridigm Preconditioner: \"{preconditioner}\"\n    NOXQuasiStatic:\n      Number of Load Steps: 2\n      Direction: {{Method: \"Newton\", Newton: {{Linear Solver: {{Jacobian Operator: \"Matrix-Free\"}}}}}}\n"
            ),
        );
        let deck = parse_str(&text, DeckFormat::Yaml, Path::new("nox.yaml")).unwrap();
        assert!(matches!(
            deck.solvers[0].integrator,
            Integrator::NoxQuasiStatic(_)
        ));
        deck.solvers[0].linear_solve.backend
    }

    /// A deck that asks for peridyn's AMG stays on the native backend in a Trilinos build
    /// (NOX would refuse it); Peridigm's own preconditioner values get NOX.
    #[test]
    fn nox_lists_asking_for_amg_stay_native() {
        assert_eq!(nox_default_backend("AMG"), LinearBackend::Native);
        let peridigm = nox_default_backend("Block 3x3");
        if cfg!(feature = "trilinos") {
            assert_eq!(peridigm, LinearBackend::TRILINOS_DEFAULT);
        } else {
            assert_eq!(peridigm, LinearBackend::Native);
        }
    }

    #[cfg(feature = "trilinos")]
    #[test]
    fn the_trilinos_backend_reads_its_preconditioner_and_fill() {
        let settings = linear_solve("    Backend: \"Trilinos\"").unwrap();
        assert_eq!(
            settings.backend,
            LinearBackend::Trilinos {
                preconditioner: AlgebraicPreconditioner::Ilu,
                ilu_fill_level: 0
            }
        );
        let settings = linear_solve(
            "    Backend: \"Trilinos\"\n    Linear Solver Preconditioner: \"ML\"\n    Linear Solver ILU Level Of Fill: 2",
        )
        .unwrap();
        assert_eq!(
            settings.backend,
            LinearBackend::Trilinos {
                preconditioner: AlgebraicPreconditioner::Ml,
                ilu_fill_level: 2
            }
        );
    }
}
