//! Top-level lists whose name contains `Solver`: time span, common switches, one integrator
//! ([`super::integrators`]) and the linear-solver keys ([`super::linear_solve`]).

use super::error::DeckError;
use super::integrators::{only_integrator, read_integrator, Integrator};
use super::linear_solve::{
    read_linear_solve, LinearBackend, LinearMethod, LinearPreconditioner, LinearSolve,
    PetscPreconditioner, PETSC_NOT_BUILT, TRILINOS_NOT_BUILT,
};
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

impl Solver {
    /// Chooses the backend of an implicit solver list whose deck did not (`peridyn run
    /// --backend`). Direct methods exist on the native backend only, so a list asking for one
    /// cannot move to Trilinos. On PETSc the list's native preconditioner choice carries over
    /// ([`Solver::petsc_preconditioner`]); returns a warning about the `Linear Solver
    /// Preconditioner` key when the choice has no PETSc counterpart.
    pub fn choose_backend(&mut self, backend: LinearBackend) -> Result<Option<String>, String> {
        if self.linear_solve.backend_given || !self.integrator.is_implicit() {
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
