//! What runs where: the one place that maps an implicit solver list's settings
//! ([`ImplicitSolve`], from its deck keys with `peridyn run --backend` already applied) and the
//! rank count to a backend, and says in one message what this build or rank count cannot run.
//!
//! | solver list                     | `Backend: "Native"`             | `Backend: "Trilinos"`        | `Backend: "PETSc"`             |
//! |---------------------------------|---------------------------------|------------------------------|--------------------------------|
//! | `QuasiStatic`, `Implicit`       | peridyn Newton, native linear   | peridyn Newton, Belos        | peridyn Newton, KSP            |
//! | … with `Nonlinear Solver: "SNES"` | refused (needs PETSc)         | refused (needs PETSc)        | SNES Newton, KSP               |
//! | `NOXQuasiStatic`                | peridyn Newton (JFNK or native) | Trilinos NOX                 | SNES (Newton or JFNK)          |
//! | `Verlet`                        | explicit, any rank count        | explicit, any rank count     | explicit, any rank count       |
//!
//! On several ranks every implicit list needs `Backend: "Trilinos"` or `Backend: "PETSc"` in a
//! build with that feature (the distributed linear and nonlinear solves are Trilinos' Belos
//! and NOX, or PETSc's KSP and SNES on `MATMPIAIJ`); the native backend solves on one
//! process. The Trilinos backend has no direct linear solver. The solver modules build the
//! objects ([`crate::solver::linear`]); this module only decides.

use super::parameters::{string_at, value_at, ParameterValue};
use super::settings::{
    ImplicitSolve, LinearBackend, LinearMethod, LinearPreconditioner, Nonlinear, NonlinearMethod,
    NoxParameters, PeridigmPreconditioner,
};
use super::Unsupported;

/// Which nonlinear backend solves an implicit solver list.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NonlinearBackend {
    /// peridyn's Newton ([`crate::solver::newton`]) with a linear strategy.
    Newton,
    /// Trilinos NOX (`NOXQuasiStatic` on the Trilinos backend).
    Nox,
    /// PETSc SNES (`NOXQuasiStatic` on the PETSc backend, `Nonlinear Solver: "SNES"`).
    Snes,
}

/// The nonlinear backend of `solve`: NOX for `NOXQuasiStatic` on the Trilinos backend, SNES
/// for `NOXQuasiStatic` on the PETSc backend and for `QuasiStatic` and `Implicit` lists with
/// `Nonlinear Solver: "SNES"`, otherwise peridyn's Newton. Fails when the choice needs a
/// feature this build lacks, or SNES is asked for on another backend.
pub fn nonlinear_backend(solve: &ImplicitSolve) -> Result<NonlinearBackend, Unsupported> {
    let on_petsc = matches!(solve.linear.backend, LinearBackend::Petsc { .. });
    let nox = matches!(solve.nonlinear, Nonlinear::Nox(_));
    let snes_asked = solve.linear.nonlinear_method == NonlinearMethod::Snes && !nox;
    if snes_asked && !on_petsc {
        return Err(Unsupported(format!(
            "solver \"{}\": Nonlinear Solver \"SNES\" is PETSc's: give Backend \"PETSc\" (or `peridyn run --backend petsc`), or remove the key for peridyn's Newton",
            solve.list
        )));
    }
    if snes_asked || (nox && on_petsc) {
        if !cfg!(feature = "petsc") {
            return Err(petsc_not_built(&solve.list));
        }
        return Ok(NonlinearBackend::Snes);
    }
    if !runs_on_nox(solve) {
        return Ok(NonlinearBackend::Newton);
    }
    if !cfg!(feature = "trilinos") {
        return Err(trilinos_not_built(&solve.list));
    }
    Ok(NonlinearBackend::Nox)
}

/// The NOX parameters of a `NOXQuasiStatic` list, `None` for other lists.
pub fn nox_parameters(solve: &ImplicitSolve) -> Option<&NoxParameters> {
    match &solve.nonlinear {
        Nonlinear::Nox(nox) => Some(nox),
        Nonlinear::Newton { .. } => None,
    }
}

/// True when `solve` is a `NOXQuasiStatic` list on the Trilinos backend (solved by NOX).
pub fn runs_on_nox(solve: &ImplicitSolve) -> bool {
    nox_parameters(solve).is_some() && on_trilinos(&solve.linear.backend)
}

fn on_trilinos(backend: &LinearBackend) -> bool {
    matches!(backend, LinearBackend::Trilinos { .. })
}

/// The refusal of `Backend "Trilinos"` in a build without the feature, for solver list `list`.
pub fn trilinos_not_built(list: &str) -> Unsupported {
    Unsupported(format!(
        "solver \"{list}\": Backend \"Trilinos\" needs a peridyn built with the Cargo feature `trilinos` \
         (cargo build --release --features trilinos; see .ci/trilinos.sh)"
    ))
}

/// The refusal of `Backend "PETSc"` in a build without the feature, for solver list `list`.
pub fn petsc_not_built(list: &str) -> Unsupported {
    Unsupported(format!(
        "solver \"{list}\": Backend \"PETSc\" needs a peridyn built with the Cargo feature `petsc` \
         (cargo build --release --features petsc; see .ci/petsc.sh)"
    ))
}

/// Refuses a direct linear method on the Trilinos backend (Belos is CG or GMRES).
pub fn check_trilinos_method(solve: &ImplicitSolve) -> Result<(), Unsupported> {
    if solve.linear.method.is_direct() {
        return Err(Unsupported(format!(
            "solver \"{}\": Backend \"Trilinos\" solves with Belos CG or GMRES, not a direct method",
            solve.list
        )));
    }
    Ok(())
}

/// Refuses the implicit list `solve` on `ranks` > 1 ranks unless the Trilinos or PETSc
/// backend, built in, solves it.
pub fn check_ranks(solve: &ImplicitSolve, ranks: usize) -> Result<(), Unsupported> {
    let backend = &solve.linear.backend;
    let distributable = (on_trilinos(backend) && cfg!(feature = "trilinos"))
        || (matches!(backend, LinearBackend::Petsc { .. }) && cfg!(feature = "petsc"));
    if ranks <= 1 || distributable {
        return Ok(());
    }
    Err(not_on_ranks(&solve.list, solve.integrator, ranks))
}

/// The refusal of an implicit list (solver list `list`, integrator `integrator`) on `ranks`
/// ranks without a distributed backend.
pub fn not_on_ranks(list: &str, integrator: &str, ranks: usize) -> Unsupported {
    Unsupported(format!(
        "solver \"{list}\": {integrator} on {ranks} ranks needs the Trilinos or PETSc backend (QuasiStatic, NOXQuasiStatic or Implicit with Backend \"Trilinos\" or \"PETSc\", \
         or `peridyn run --backend trilinos` or `--backend petsc`, in a build with the feature mpi and that backend's feature); the native backend runs on one rank"
    ))
}

/// NOX's name of the deck's `Direction → Method` (`Newton` or `Nonlinear CG`), which is also
/// the sublist holding its linear-solver keys.
pub fn nox_direction(solve: &ImplicitSolve, method: &str) -> Result<&'static str, Unsupported> {
    match method {
        "Newton" => Ok("Newton"),
        "NonlinearCG" => Ok("Nonlinear CG"),
        other => Err(Unsupported(format!(
            "solver \"{}\": NOXQuasiStatic → Direction → Method \"{other}\": use \"Newton\" or \"NonlinearCG\" (Peridigm's two)",
            solve.list
        ))),
    }
}

/// What of `solve` the native backend cannot run, for `peridyn check` (a `NOXQuasiStatic`
/// direction other than Newton needs NOX itself or PETSc's SNESNCG).
pub fn native_limitation(solve: &ImplicitSolve) -> Option<String> {
    let nox = nox_parameters(solve)?;
    (nox.direction_method != "Newton" && solve.linear.backend == LinearBackend::Native).then(|| {
        format!(
            "NOXQuasiStatic Direction Method \"{}\" on the native backend (it needs Trilinos NOX or PETSc's SNESNCG: Backend \"Trilinos\" or \"PETSc\" in a build with that feature)",
            nox.direction_method
        )
    })
}

/// The preconditioner of a Jacobian-free Newton–Krylov solve when `solve` asks for one
/// (`NOXQuasiStatic` with `Jacobian Operator: "Matrix-Free"` and `Peridigm Preconditioner`
/// `Block 3x3`, `AMG` or `None`; Peridigm's rule in `executeNOXQuasiStatic`,
/// `src/core/Peridigm.cpp`: `Matrix-Free` with `Full Tangent` still assembles), `None` when
/// the solver assembles its tangent.
pub fn matrix_free_preconditioner(solve: &ImplicitSolve) -> Option<LinearPreconditioner> {
    let nox = nox_parameters(solve)?;
    let matrix_free =
        string_at(&nox.nox, &NoxParameters::JACOBIAN_OPERATOR).is_some_and(|s| s == "Matrix-Free");
    match (matrix_free, solve.peridigm_preconditioner) {
        (true, PeridigmPreconditioner::Block3x3) => Some(LinearPreconditioner::Block3x3),
        (true, PeridigmPreconditioner::None) => Some(LinearPreconditioner::None),
        (true, PeridigmPreconditioner::Amg) => Some(LinearPreconditioner::Amg),
        _ => None,
    }
}

/// True when `Linear Solver: "Automatic"` makes the quasi-static `solve` over `points`
/// points (all ranks together) Jacobian-free Newton–Krylov with AMG: a `QuasiStatic` list, or
/// a `NOXQuasiStatic` list on peridyn's Newton without a `Jacobian Operator` key, on the native
/// backend with peridyn's Newton, `Automatic` above [`LinearMethod::AUTOMATIC_DIRECT_LIMIT`]
/// unknowns and no `Linear Solver Preconditioner` key. Past that limit a factorization is out
/// of reach, and of the strategies left it is the fastest and, after Jacobian-free + block 3×3
/// (1.4× less memory, 3.3× slower at 160,000 points), the leanest: it assembles no tangent
/// (on the 20,000-point LPS tension block 4.7 s and 0.35 GB against 42.8 s and 2.8 GB for
/// assembled CG + block 3×3, the former `Automatic`). A deck that names its linear solver,
/// its preconditioner or NOX's Jacobian operator gets what it names.
pub fn automatic_jacobian_free(solve: &ImplicitSolve, points: usize) -> bool {
    let settings = &solve.linear;
    let quasi_static = match &solve.nonlinear {
        Nonlinear::Newton { quasi_static } => *quasi_static,
        Nonlinear::Nox(nox) => {
            value_at(&nox.nox, &NoxParameters::JACOBIAN_OPERATOR).is_none()
                && nox.direction_method == "Newton"
        }
    };
    quasi_static
        && settings.backend == LinearBackend::Native
        && settings.nonlinear_method == NonlinearMethod::Newton
        && settings.method == LinearMethod::Automatic
        && !settings.preconditioner_given
        && 3 * points > LinearMethod::AUTOMATIC_DIRECT_LIMIT
        && nonlinear_backend(solve) == Ok(NonlinearBackend::Newton)
}

/// The preconditioner of the Jacobian-free Newton–Krylov solve of `solve` over `points`
/// points (all ranks together): the deck's ([`matrix_free_preconditioner`]), or AMG when
/// `Automatic` chooses it ([`automatic_jacobian_free`]); `None` when the solver assembles its
/// tangent.
pub fn jacobian_free_preconditioner(
    solve: &ImplicitSolve,
    points: usize,
) -> Option<LinearPreconditioner> {
    matrix_free_preconditioner(solve)
        .or_else(|| automatic_jacobian_free(solve, points).then_some(LinearPreconditioner::Amg))
}

/// True when `solve` preconditions with peridyn's AMG on the one-hop operator (so that
/// `peridyn check` plans its memory): Jacobian-free with `Peridigm Preconditioner: "AMG"` or
/// by [`automatic_jacobian_free`], or `Linear Solver Preconditioner: "AMG"` on the native
/// backend with a Krylov method (`CG`, `GMRES`, or `Automatic` above
/// [`LinearMethod::AUTOMATIC_DIRECT_LIMIT`] dofs, `points` the model's points, all ranks
/// together), the choice [`crate::solver::linear::strategy`] makes.
pub fn uses_multigrid(solve: &ImplicitSolve, points: usize) -> bool {
    if let Some(preconditioner) = jacobian_free_preconditioner(solve, points) {
        return preconditioner == LinearPreconditioner::Amg;
    }
    let settings = &solve.linear;
    settings.backend == LinearBackend::Native
        && settings.preconditioner == LinearPreconditioner::Amg
        && match settings.method {
            LinearMethod::Cg | LinearMethod::Gmres => true,
            LinearMethod::Automatic => 3 * points > LinearMethod::AUTOMATIC_DIRECT_LIMIT,
            _ => false,
        }
}

/// NOX's default `Size of Krylov Subspace`: the restart of AztecOO's GMRES in
/// `NOX::Epetra::LinearSystemAztecOO` when the linear solver list does not give one.
pub const NOX_KRYLOV_SUBSPACE: usize = 300;

/// NOX's default linear `Max Iterations` (`NOX::Epetra::LinearSystemAztecOO`).
pub const NOX_MAX_LINEAR_ITERATIONS: usize = 400;

/// The restart of AztecOO's GMRES under NOX's linear solver list at `linear_solver_path` in
/// the NOX tree `nox`: its `Size of Krylov Subspace` (a positive integer), else
/// [`NOX_KRYLOV_SUBSPACE`]; `None` when its `Aztec Solver` is not `GMRES` (NOX's default).
pub fn nox_gmres_restart(
    nox: &[(String, ParameterValue)],
    linear_solver_path: &[&str],
) -> Option<usize> {
    let key = |name: &str| value_at(nox, &[linear_solver_path, &[name]].concat());
    match key("Aztec Solver") {
        None => {}
        Some(ParameterValue::String(s)) if s == "GMRES" => {}
        Some(_) => return None,
    }
    match key("Size of Krylov Subspace") {
        Some(ParameterValue::Int(n)) if *n > 0 => usize::try_from(*n).ok(),
        _ => Some(NOX_KRYLOV_SUBSPACE),
    }
}

/// The GMRES of the Jacobian-free Newton–Krylov solve of `solve` over `unknowns` unknowns,
/// as (restart, iteration limit), for planning its basis; `None` when `solve` is not
/// Jacobian-free or its Krylov method is not GMRES. NOX (`NOXQuasiStatic` on Trilinos) runs
/// AztecOO with its linear solver list's `Size of Krylov Subspace` and `Max Iterations`
/// (NOX's defaults 300 and 400); peridyn's own JFNK and the other backends restart at
/// [`super::native::KrylovSettings`]' default with `Linear Solver Maximum Iterations` (default
/// `unknowns`) as the limit.
pub fn matrix_free_gmres(solve: &ImplicitSolve, unknowns: usize) -> Option<(usize, usize)> {
    jacobian_free_preconditioner(solve, unknowns / 3)?;
    if let (true, Some(nox)) = (runs_on_nox(solve), nox_parameters(solve)) {
        // Jacobian-free solves are Newton's (`matrix_free_preconditioner` reads this path).
        let path = ["Direction", "Newton", "Linear Solver"];
        let restart = nox_gmres_restart(&nox.nox, &path)?;
        let limit = match value_at(&nox.nox, &[&path[..], &["Max Iterations"]].concat()) {
            Some(ParameterValue::Int(n)) if *n > 0 => usize::try_from(*n).unwrap_or(usize::MAX),
            _ => NOX_MAX_LINEAR_ITERATIONS,
        };
        return Some((restart, limit));
    }
    let restart = super::native::KrylovSettings::default().restart;
    let limit = solve
        .linear
        .maximum_iterations
        .map_or(unknowns, |m| usize::try_from(m).unwrap_or(usize::MAX));
    Some((restart, limit))
}
