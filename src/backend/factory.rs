//! What runs where: the one place that maps a deck's solver list (its keys, with
//! `peridyn run --backend` already applied) and the rank count to a backend, and says in one
//! message what this build or rank count cannot run.
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

use super::Unsupported;
use crate::io::deck::{
    Integrator, LinearBackend, LinearMethod, LinearPreconditioner, NonlinearMethod, ParameterValue,
    PeridigmPreconditioner, Solver,
};

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

/// The nonlinear backend of `solver`: NOX for `NOXQuasiStatic` on the Trilinos backend, SNES
/// for `NOXQuasiStatic` on the PETSc backend and for `QuasiStatic` and `Implicit` lists with
/// `Nonlinear Solver: "SNES"`, otherwise peridyn's Newton. Fails when the choice needs a
/// feature this build lacks, or SNES is asked for on another backend.
pub fn nonlinear_backend(solver: &Solver) -> Result<NonlinearBackend, Unsupported> {
    let on_petsc = matches!(solver.linear_solve.backend, LinearBackend::Petsc { .. });
    let snes_asked = solver.linear_solve.nonlinear_method == NonlinearMethod::Snes
        && matches!(
            solver.integrator,
            Integrator::QuasiStatic(_) | Integrator::Implicit(_)
        );
    if snes_asked && !on_petsc {
        return Err(Unsupported(format!(
            "solver \"{}\": Nonlinear Solver \"SNES\" is PETSc's: give Backend \"PETSc\" (or `peridyn run --backend petsc`), or remove the key for peridyn's Newton",
            solver.name
        )));
    }
    if snes_asked || (matches!(solver.integrator, Integrator::NoxQuasiStatic(_)) && on_petsc) {
        if !cfg!(feature = "petsc") {
            return Err(petsc_not_built(solver));
        }
        return Ok(NonlinearBackend::Snes);
    }
    if !runs_on_nox(solver) {
        return Ok(NonlinearBackend::Newton);
    }
    if !cfg!(feature = "trilinos") {
        return Err(trilinos_not_built(solver));
    }
    Ok(NonlinearBackend::Nox)
}

/// True when `solver` is a `NOXQuasiStatic` list on the Trilinos backend (solved by NOX).
pub fn runs_on_nox(solver: &Solver) -> bool {
    matches!(solver.integrator, Integrator::NoxQuasiStatic(_))
        && on_trilinos(&solver.linear_solve.backend)
}

fn on_trilinos(backend: &LinearBackend) -> bool {
    matches!(backend, LinearBackend::Trilinos { .. })
}

/// The refusal of `Backend "Trilinos"` in a build without the feature.
pub fn trilinos_not_built(solver: &Solver) -> Unsupported {
    Unsupported(format!(
        "solver \"{}\": Backend \"Trilinos\" needs a peridyn built with the Cargo feature `trilinos` \
         (cargo build --release --features trilinos; see .ci/trilinos.sh)",
        solver.name
    ))
}

/// The refusal of `Backend "PETSc"` in a build without the feature.
pub fn petsc_not_built(solver: &Solver) -> Unsupported {
    Unsupported(format!(
        "solver \"{}\": Backend \"PETSc\" needs a peridyn built with the Cargo feature `petsc` \
         (cargo build --release --features petsc; see .ci/petsc.sh)",
        solver.name
    ))
}

/// Refuses a direct linear method on the Trilinos backend (Belos is CG or GMRES).
pub fn check_trilinos_method(solver: &Solver) -> Result<(), Unsupported> {
    match solver.linear_solve.method {
        LinearMethod::Direct | LinearMethod::Cholesky | LinearMethod::Lu => Err(Unsupported(format!(
            "solver \"{}\": Backend \"Trilinos\" solves with Belos CG or GMRES, not a direct method",
            solver.name
        ))),
        LinearMethod::Automatic | LinearMethod::Cg | LinearMethod::Gmres => Ok(()),
    }
}

/// Refuses an implicit list on `ranks` > 1 ranks unless the Trilinos or PETSc backend, built
/// in, solves it; `Verlet` runs on any number of ranks.
pub fn check_ranks(solver: &Solver, ranks: usize) -> Result<(), Unsupported> {
    let backend = &solver.linear_solve.backend;
    let distributable = match solver.integrator {
        Integrator::Verlet(_) => true,
        Integrator::QuasiStatic(_) | Integrator::NoxQuasiStatic(_) | Integrator::Implicit(_) => {
            (on_trilinos(backend) && cfg!(feature = "trilinos"))
                || (matches!(backend, LinearBackend::Petsc { .. }) && cfg!(feature = "petsc"))
        }
        Integrator::ImplicitDiffusion(_) => false,
    };
    if ranks <= 1 || distributable {
        return Ok(());
    }
    Err(Unsupported(format!(
        "solver \"{}\": {} on {ranks} ranks needs the Trilinos or PETSc backend (QuasiStatic, NOXQuasiStatic or Implicit with Backend \"Trilinos\" or \"PETSc\", \
         or `peridyn run --backend trilinos` or `--backend petsc`, in a build with the feature mpi and that backend's feature); the native backend runs on one rank",
        solver.name,
        solver.integrator.deck_name()
    )))
}

/// NOX's name of the deck's `Direction → Method` (`Newton` or `Nonlinear CG`), which is also
/// the sublist holding its linear-solver keys.
pub fn nox_direction(solver: &Solver, method: &str) -> Result<&'static str, Unsupported> {
    match method {
        "Newton" => Ok("Newton"),
        "NonlinearCG" => Ok("Nonlinear CG"),
        other => Err(Unsupported(format!(
            "solver \"{}\": NOXQuasiStatic → Direction → Method \"{other}\": use \"Newton\" or \"NonlinearCG\" (Peridigm's two)",
            solver.name
        ))),
    }
}

/// What of `solver` the native backend cannot run, for `peridyn check` (a `NOXQuasiStatic`
/// direction other than Newton needs NOX itself or PETSc's SNESNCG).
pub fn native_limitation(solver: &Solver) -> Option<String> {
    let Integrator::NoxQuasiStatic(nox) = &solver.integrator else {
        return None;
    };
    (nox.direction_method != "Newton" && solver.linear_solve.backend == LinearBackend::Native)
        .then(|| {
            format!(
                "NOXQuasiStatic Direction Method \"{}\" on the native backend (it needs Trilinos NOX or PETSc's SNESNCG: Backend \"Trilinos\" or \"PETSc\" in a build with that feature)",
                nox.direction_method
            )
        })
}

/// The preconditioner of a Jacobian-free Newton–Krylov solve when `solver` asks for one
/// (`NOXQuasiStatic` with `Jacobian Operator: "Matrix-Free"` and `Peridigm Preconditioner`
/// `Block 3x3`, `AMG` or `None`, Peridigm's rule, reference §4.2: `Matrix-Free` with `Full Tangent`
/// still assembles), `None` when the solver assembles its tangent.
pub fn matrix_free_preconditioner(solver: &Solver) -> Option<LinearPreconditioner> {
    let Integrator::NoxQuasiStatic(nox) = &solver.integrator else {
        return None;
    };
    let matrix_free = nox_string(
        &nox.nox,
        &["Direction", "Newton", "Linear Solver", "Jacobian Operator"],
    )
    .is_some_and(|s| s == "Matrix-Free");
    match (matrix_free, solver.peridigm_preconditioner) {
        (true, PeridigmPreconditioner::Block3x3) => Some(LinearPreconditioner::Block3x3),
        (true, PeridigmPreconditioner::None) => Some(LinearPreconditioner::None),
        (true, PeridigmPreconditioner::Amg) => Some(LinearPreconditioner::Amg),
        _ => None,
    }
}

/// True when `Linear Solver: "Automatic"` makes the quasi-static `solver` over `points`
/// points (all ranks together) Jacobian-free Newton–Krylov with AMG: a `QuasiStatic` list, or
/// a `NOXQuasiStatic` list on peridyn's Newton without a `Jacobian Operator` key, on the native
/// backend with peridyn's Newton, `Automatic` above [`LinearMethod::AUTOMATIC_DIRECT_LIMIT`]
/// unknowns and no `Linear Solver Preconditioner` key. Past that limit a factorization is out
/// of reach, and of the strategies left it is the fastest and, after Jacobian-free + block 3×3
/// (1.4× less memory, 3.3× slower at 160,000 points), the leanest: it assembles no tangent
/// (on the 20,000-point LPS tension block 4.7 s and 0.35 GB against 42.8 s and 2.8 GB for
/// assembled CG + block 3×3, the former `Automatic`). A deck that names its linear solver,
/// its preconditioner or NOX's Jacobian operator gets what it names.
pub fn automatic_jacobian_free(solver: &Solver, points: usize) -> bool {
    let settings = &solver.linear_solve;
    let quasi_static = match &solver.integrator {
        Integrator::QuasiStatic(_) => true,
        Integrator::NoxQuasiStatic(nox) => {
            nox_value(
                &nox.nox,
                &["Direction", "Newton", "Linear Solver", "Jacobian Operator"],
            )
            .is_none()
                && nox.direction_method == "Newton"
        }
        _ => false,
    };
    quasi_static
        && settings.backend == LinearBackend::Native
        && settings.nonlinear_method == NonlinearMethod::Newton
        && settings.method == LinearMethod::Automatic
        && !settings.preconditioner_given
        && 3 * points > LinearMethod::AUTOMATIC_DIRECT_LIMIT
        && nonlinear_backend(solver) == Ok(NonlinearBackend::Newton)
}

/// The preconditioner of the Jacobian-free Newton–Krylov solve of `solver` over `points`
/// points (all ranks together): the deck's ([`matrix_free_preconditioner`]), or AMG when
/// `Automatic` chooses it ([`automatic_jacobian_free`]); `None` when the solver assembles its
/// tangent.
pub fn jacobian_free_preconditioner(
    solver: &Solver,
    points: usize,
) -> Option<LinearPreconditioner> {
    matrix_free_preconditioner(solver)
        .or_else(|| automatic_jacobian_free(solver, points).then_some(LinearPreconditioner::Amg))
}

/// True when `solver` preconditions with peridyn's AMG on the one-hop operator (so that
/// `peridyn check` plans its memory): Jacobian-free with `Peridigm Preconditioner: "AMG"` or
/// by [`automatic_jacobian_free`], or `Linear Solver Preconditioner: "AMG"` on the native
/// backend with a Krylov method (`CG`, `GMRES`, or `Automatic` above
/// [`LinearMethod::AUTOMATIC_DIRECT_LIMIT`] dofs, `points` the model's points, all ranks
/// together), the choice [`crate::solver::linear::strategy`] makes.
pub fn uses_multigrid(solver: &Solver, points: usize) -> bool {
    if !solver.integrator.is_implicit() {
        return false;
    }
    if let Some(preconditioner) = jacobian_free_preconditioner(solver, points) {
        return preconditioner == LinearPreconditioner::Amg;
    }
    let settings = &solver.linear_solve;
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
    let key = |name: &str| {
        let mut full = linear_solver_path.to_vec();
        full.push(name);
        nox_value(nox, &full)
    };
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

/// The GMRES of the Jacobian-free Newton–Krylov solve of `solver` over `unknowns` unknowns,
/// as (restart, iteration limit), for planning its basis; `None` when `solver` is not
/// Jacobian-free or its Krylov method is not GMRES. NOX (`NOXQuasiStatic` on Trilinos) runs
/// AztecOO with its linear solver list's `Size of Krylov Subspace` and `Max Iterations`
/// (NOX's defaults 300 and 400); peridyn's own JFNK and the other backends restart at
/// [`super::native::KrylovSettings`]' default with `Linear Solver Maximum Iterations` (default
/// `unknowns`) as the limit.
pub fn matrix_free_gmres(solver: &Solver, unknowns: usize) -> Option<(usize, usize)> {
    jacobian_free_preconditioner(solver, unknowns / 3)?;
    if runs_on_nox(solver) {
        let Integrator::NoxQuasiStatic(nox) = &solver.integrator else {
            return None;
        };
        // Jacobian-free solves are Newton's (`matrix_free_preconditioner` reads this path).
        let path = ["Direction", "Newton", "Linear Solver"];
        let restart = nox_gmres_restart(&nox.nox, &path)?;
        let mut full = path.to_vec();
        full.push("Max Iterations");
        let limit = match nox_value(&nox.nox, &full) {
            Some(ParameterValue::Int(n)) if *n > 0 => usize::try_from(*n).unwrap_or(usize::MAX),
            _ => NOX_MAX_LINEAR_ITERATIONS,
        };
        return Some((restart, limit));
    }
    let restart = super::native::KrylovSettings::default().restart;
    let limit = solver
        .linear_solve
        .maximum_iterations
        .map_or(unknowns, |m| usize::try_from(m).unwrap_or(usize::MAX));
    Some((restart, limit))
}

/// A string parameter at `path` in a NOX parameter tree.
fn nox_string<'a>(tree: &'a [(String, ParameterValue)], path: &[&str]) -> Option<&'a str> {
    match nox_value(tree, path)? {
        ParameterValue::String(s) => Some(s),
        _ => None,
    }
}

/// The parameter (or sublist) at `path` in a NOX parameter tree.
pub fn nox_value<'a>(
    tree: &'a [(String, ParameterValue)],
    path: &[&str],
) -> Option<&'a ParameterValue> {
    let (first, rest) = path.split_first()?;
    let (_, value) = tree.iter().find(|(k, _)| k == first)?;
    match (value, rest.is_empty()) {
        (value, true) => Some(value),
        (ParameterValue::List(children), false) => nox_value(children, rest),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nox_string_follows_the_path() {
        let tree = vec![(
            "Direction".to_string(),
            ParameterValue::List(vec![(
                "Newton".to_string(),
                ParameterValue::List(vec![(
                    "Linear Solver".to_string(),
                    ParameterValue::List(vec![(
                        "Jacobian Operator".to_string(),
                        ParameterValue::String("Matrix-Free".into()),
                    )]),
                )]),
            )]),
        )];
        let path = ["Direction", "Newton", "Linear Solver", "Jacobian Operator"];
        assert_eq!(nox_string(&tree, &path), Some("Matrix-Free"));
        assert_eq!(nox_string(&tree, &["Direction", "Method"]), None);
    }

    /// The first solver list of a three-point bar deck whose `Solver` list holds the lines
    /// `solver_keys` besides `Final Time`.
    fn solver(solver_keys: &str) -> Solver {
        let text =
            crate::io::deck::three_point_bar_text(&format!("    Final Time: 1.0\n{solver_keys}"));
        let deck = crate::io::deck::parse_str(
            &text,
            crate::io::deck::DeckFormat::Yaml,
            std::path::Path::new("automatic.yaml"),
        )
        .unwrap();
        deck.solvers.into_iter().next().unwrap()
    }

    /// Points whose unknowns are just above and at `Automatic`'s direct-solve limit.
    const LARGE: usize = LinearMethod::AUTOMATIC_DIRECT_LIMIT / 3 + 1;
    const AT_LIMIT: usize = LinearMethod::AUTOMATIC_DIRECT_LIMIT / 3;

    #[test]
    fn automatic_makes_a_large_quasi_static_deck_jacobian_free_with_amg() {
        let quasi_static = solver("    QuasiStatic:\n      Number of Load Steps: 2");
        assert!(automatic_jacobian_free(&quasi_static, LARGE));
        assert_eq!(
            jacobian_free_preconditioner(&quasi_static, LARGE),
            Some(LinearPreconditioner::Amg)
        );
        assert!(uses_multigrid(&quasi_static, LARGE));
        // At the limit a factorization still runs, with the assembled tangent.
        assert!(!automatic_jacobian_free(&quasi_static, AT_LIMIT));
        assert_eq!(jacobian_free_preconditioner(&quasi_static, AT_LIMIT), None);
        // A native NOXQuasiStatic list that names no Jacobian operator is treated alike.
        let nox = solver(
            "    Backend: \"Native\"\n    NOXQuasiStatic:\n      Number of Load Steps: 2\n      Direction: {Method: \"Newton\"}",
        );
        assert!(automatic_jacobian_free(&nox, LARGE));
    }

    #[test]
    fn a_deck_that_names_its_solver_keeps_the_assembled_tangent() {
        let named = [
            "    Linear Solver: \"CG\"\n    QuasiStatic:\n      Number of Load Steps: 2",
            "    Linear Solver Preconditioner: \"Block 3x3\"\n    QuasiStatic:\n      Number of Load Steps: 2",
            "    Linear Solver Preconditioner: \"AMG\"\n    QuasiStatic:\n      Number of Load Steps: 2",
            "    Backend: \"Native\"\n    NOXQuasiStatic:\n      Number of Load Steps: 2\n      Direction: {Method: \"Newton\", Newton: {Linear Solver: {Jacobian Operator: \"Full Tangent\"}}}",
            // Newmark-β dynamics is not quasi-static: its mass term keeps block 3×3 CG cheap.
            "    Implicit:\n      Fixed dt: 0.1",
        ];
        for keys in named {
            let list = solver(keys);
            assert!(!automatic_jacobian_free(&list, LARGE), "{keys}");
        }
        // The AMG the deck names runs on the assembled tangent (CG + AMG), not Jacobian-free.
        let assembled_amg = solver(named[2]);
        assert_eq!(jacobian_free_preconditioner(&assembled_amg, LARGE), None);
        assert!(uses_multigrid(&assembled_amg, LARGE));
        // An explicit Jacobian-free request keeps its own preconditioner.
        let block = solver(
            "    Backend: \"Native\"\n    Peridigm Preconditioner: \"Block 3x3\"\n    NOXQuasiStatic:\n      Number of Load Steps: 2\n      Direction: {Method: \"Newton\", Newton: {Linear Solver: {Jacobian Operator: \"Matrix-Free\"}}}",
        );
        assert!(!automatic_jacobian_free(&block, LARGE));
        assert_eq!(
            jacobian_free_preconditioner(&block, LARGE),
            Some(LinearPreconditioner::Block3x3)
        );
    }
}
