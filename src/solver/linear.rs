//! Chooses how an implicit solver solves its Newton corrections, from the deck.
//!
//! * `QuasiStatic` and `Implicit`: the peridyn `Linear Solver` keys ([`LinearSolve`]) on the
//!   native backend; `Direct` is sparse Cholesky, with sparse LU taking over for good once the
//!   stiffness is found not positive definite.
//! * `NOXQuasiStatic` on the native backend: `Direction → Newton → Linear Solver → Jacobian
//!   Operator: "Matrix-Free"` together with `Peridigm Preconditioner: "Block 3x3"` or `"None"`
//!   selects Jacobian-free Newton–Krylov (Peridigm's rule, reference §4.2: `Matrix-Free` with
//!   `Full Tangent` still assembles); anything else is Newton with the assembled tangent and the
//!   `Linear Solver` keys.
//! * `Backend: "Trilinos"` (feature `trilinos`): `NOXQuasiStatic` is solved by NOX itself
//!   ([`super::nox_newton`]; the default for `NOXQuasiStatic` in a build with the feature);
//!   `QuasiStatic` and `Implicit` hand their assembled tangent to Belos
//!   (`TrilinosLinearSolver`) with the Ifpack/ML preconditioner of the deck.

use crate::backend::native::{
    KrylovSettings, NativeLinearSolver, NativeMethod, NativeSolverSettings, PreconditionerKind,
};
use crate::backend::Unsupported;
use crate::io::deck::{
    AlgebraicPreconditioner, Integrator, LinearBackend, LinearMethod, LinearPreconditioner,
    LinearSolve, ParameterValue, PeridigmPreconditioner, Solver,
};
use crate::physics::Physics;
use crate::setup::Model;
use crate::solver::newton::{LinearStrategy, NonlinearSolver};

/// The smallest Krylov tolerance Jacobian-free solves use: a finite-difference directional
/// derivative is accurate to about √ε ≈ 1e-8 relative, so asking for less only wastes
/// iterations.
pub const MATRIX_FREE_TOLERANCE_FLOOR: f64 = 1e-7;

/// The preconditioner of a Jacobian-free Newton–Krylov solve when `solver` asks for one
/// (`NOXQuasiStatic` with `Jacobian Operator: "Matrix-Free"` and `Peridigm Preconditioner`
/// `Block 3x3` or `None`), `None` when the solver assembles its tangent.
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
        _ => None,
    }
}

/// The nonlinear solver of a quasi-static `solver` list: NOX for `NOXQuasiStatic` on the
/// Trilinos backend, otherwise peridyn's Newton with [`strategy`].
pub fn nonlinear_solver(
    solver: &Solver,
    model: &Model,
    physics: &Physics,
) -> Result<Box<dyn NonlinearSolver>, Unsupported> {
    if matches!(solver.integrator, Integrator::NoxQuasiStatic(_))
        && matches!(solver.linear_solve.backend, LinearBackend::Trilinos { .. })
    {
        return nox_solver(solver);
    }
    Ok(Box::new(strategy(solver, model, physics)?))
}

#[cfg(feature = "trilinos")]
fn nox_solver(solver: &Solver) -> Result<Box<dyn NonlinearSolver>, Unsupported> {
    Ok(Box::new(super::nox_newton::NoxNewton::from_deck(solver)?))
}

#[cfg(not(feature = "trilinos"))]
fn nox_solver(solver: &Solver) -> Result<Box<dyn NonlinearSolver>, Unsupported> {
    Err(Unsupported(format!(
        "solver \"{}\": Backend \"Trilinos\" needs a peridyn built with the Cargo feature `trilinos` \
         (cargo build --release --features trilinos; see .ci/trilinos.sh)",
        solver.name
    )))
}

/// The linear strategy of `solver` (see the module docs).
pub fn strategy(
    solver: &Solver,
    model: &Model,
    _physics: &Physics,
) -> Result<LinearStrategy, Unsupported> {
    let settings = &solver.linear_solve;
    let krylov = KrylovSettings {
        relative_tolerance: settings.relative_tolerance,
        max_iterations: settings.maximum_iterations.map(|m| m as usize),
        ..KrylovSettings::default()
    };
    if let Some(preconditioner) = matrix_free_preconditioner(solver) {
        return Ok(LinearStrategy::MatrixFree {
            krylov: KrylovSettings {
                relative_tolerance: krylov.relative_tolerance.max(MATRIX_FREE_TOLERANCE_FLOOR),
                ..krylov
            },
            preconditioner,
        });
    }
    if let LinearBackend::Trilinos {
        preconditioner,
        ilu_fill_level,
    } = settings.backend
    {
        return trilinos_strategy(solver, settings, krylov, preconditioner, ilu_fill_level);
    }
    let preconditioner = match settings.preconditioner {
        LinearPreconditioner::Block3x3 => PreconditionerKind::BlockJacobi,
        LinearPreconditioner::Jacobi => PreconditionerKind::Jacobi,
        LinearPreconditioner::None => PreconditionerKind::None,
    };
    let native = |method| {
        NativeLinearSolver::new(
            &NativeSolverSettings {
                method,
                preconditioner,
                krylov,
            },
            Vec::new(),
        )
    };
    let method = match settings.method {
        LinearMethod::Automatic
            if 3 * model.points.len() <= LinearMethod::AUTOMATIC_DIRECT_LIMIT =>
        {
            LinearMethod::Direct
        }
        LinearMethod::Automatic => LinearMethod::Cg,
        chosen => chosen,
    };
    Ok(match method {
        LinearMethod::Automatic => unreachable!("resolved above"),
        LinearMethod::Direct => LinearStrategy::Native {
            solver: native(NativeMethod::Cholesky),
            fallback: Some(native(NativeMethod::Lu)),
        },
        LinearMethod::Cholesky => LinearStrategy::Native {
            solver: native(NativeMethod::Cholesky),
            fallback: None,
        },
        LinearMethod::Lu => LinearStrategy::Native {
            solver: native(NativeMethod::Lu),
            fallback: None,
        },
        LinearMethod::Cg => LinearStrategy::Native {
            solver: native(NativeMethod::Cg),
            fallback: None,
        },
        LinearMethod::Gmres => LinearStrategy::Native {
            solver: native(NativeMethod::Gmres),
            fallback: None,
        },
    })
}

/// Belos through the Trilinos bridge: `CG` and `Automatic` are `BlockCG` (the stiffness is
/// symmetric), `GMRES` is `BlockGMRES`. ML aggregates single unknowns (`PDE equations` 1):
/// the reduced system drops prescribed components, so points carry one to three unknowns.
#[cfg(feature = "trilinos")]
fn trilinos_strategy(
    solver: &Solver,
    settings: &LinearSolve,
    krylov: KrylovSettings,
    preconditioner: AlgebraicPreconditioner,
    ilu_fill_level: u32,
) -> Result<LinearStrategy, Unsupported> {
    use crate::backend::trilinos::{
        BelosMethod, Communicator, TrilinosLinearSolver, TrilinosPreconditioner, TrilinosSettings,
    };
    let method = match settings.method {
        LinearMethod::Automatic | LinearMethod::Cg => BelosMethod::BlockCg,
        LinearMethod::Gmres => BelosMethod::BlockGmres,
        LinearMethod::Direct | LinearMethod::Cholesky | LinearMethod::Lu => {
            return Err(Unsupported(format!(
                "solver \"{}\": Backend \"Trilinos\" solves with Belos CG or GMRES, not a direct method",
                solver.name
            )))
        }
    };
    let preconditioner = match preconditioner {
        AlgebraicPreconditioner::None => TrilinosPreconditioner::None,
        AlgebraicPreconditioner::Jacobi => TrilinosPreconditioner::Jacobi,
        AlgebraicPreconditioner::Ilu => TrilinosPreconditioner::Ilu {
            fill_level: ilu_fill_level,
        },
        AlgebraicPreconditioner::Ml => TrilinosPreconditioner::Ml,
    };
    Ok(LinearStrategy::Assembled(Box::new(
        TrilinosLinearSolver::new(TrilinosSettings {
            method,
            preconditioner,
            krylov,
            pde_equations: 1,
            communicator: Communicator::MpiSelf,
        }),
    )))
}

/// Without the `trilinos` feature the backend does not exist (the deck reader already refuses
/// the key; this covers settings built in code).
#[cfg(not(feature = "trilinos"))]
fn trilinos_strategy(
    solver: &Solver,
    _settings: &LinearSolve,
    _krylov: KrylovSettings,
    _preconditioner: AlgebraicPreconditioner,
    _ilu_fill_level: u32,
) -> Result<LinearStrategy, Unsupported> {
    Err(Unsupported(format!(
        "solver \"{}\": Backend \"Trilinos\" needs a peridyn built with the Cargo feature `trilinos` \
         (cargo build --release --features trilinos; see .ci/trilinos.sh)",
        solver.name
    )))
}

/// A string parameter at `path` in a NOX parameter tree.
fn nox_string<'a>(tree: &'a [(String, ParameterValue)], path: &[&str]) -> Option<&'a str> {
    let (first, rest) = path.split_first()?;
    let (_, value) = tree.iter().find(|(k, _)| k == first)?;
    match (value, rest.is_empty()) {
        (ParameterValue::String(s), true) => Some(s),
        (ParameterValue::List(children), false) => nox_string(children, rest),
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
}
