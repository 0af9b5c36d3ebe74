//! Builds the solver objects of an implicit solver list once [`crate::backend::factory`] has
//! decided which backend runs it (and refused what cannot run here).
//!
//! * `QuasiStatic` and `Implicit`: the peridyn `Linear Solver` keys ([`LinearSolve`]) on the
//!   native backend; `Direct` is sparse Cholesky, with sparse LU taking over for good once the
//!   stiffness is found not positive definite. `Linear Solver Preconditioner: "AMG"` with `CG`
//!   or `GMRES` is [`LinearStrategy::Multigrid`]. `Automatic` above the direct-solve limit
//!   makes a quasi-static list that names no preconditioner Jacobian-free with AMG
//!   ([`factory::automatic_jacobian_free`]).
//! * `NOXQuasiStatic` on the native backend: `Direction → Newton → Linear Solver → Jacobian
//!   Operator: "Matrix-Free"` together with `Peridigm Preconditioner: "Block 3x3"`, `"AMG"` or
//!   `"None"` selects Jacobian-free Newton–Krylov ([`factory::matrix_free_preconditioner`]:
//!   `Matrix-Free` with `Full Tangent` still assembles); anything else is Newton with the assembled tangent and the
//!   `Linear Solver` keys.
//! * `Backend: "Trilinos"` (feature `trilinos`): `NOXQuasiStatic` is solved by NOX itself
//!   ([`super::nox_newton`]; the default for `NOXQuasiStatic` in a build with the feature);
//!   `QuasiStatic` and `Implicit` hand their assembled tangent to Belos
//!   (`TrilinosLinearSolver`) with the Ifpack/ML preconditioner of the deck.
//! * `Backend: "PETSc"` (feature `petsc`): `NOXQuasiStatic` is solved by SNES
//!   ([`super::snes_newton`]); `QuasiStatic` and `Implicit` hand their assembled tangent to a
//!   KSP (`PetscLinearSolver`) configured by the deck's keys and `PETSc Options`, or with
//!   `Nonlinear Solver: "SNES"` are solved by SNES too. Both run on N MPI ranks.

use crate::backend::factory::{self, jacobian_free_preconditioner, NonlinearBackend};
use crate::backend::native::{
    KrylovSettings, NativeLinearSolver, NativeMethod, NativeSolverSettings, PreconditionerKind,
};
use crate::backend::settings::{
    AlgebraicPreconditioner, ImplicitSolve, LinearBackend, LinearMethod, LinearPreconditioner,
    LinearSolve,
};
use crate::backend::Unsupported;
use crate::solver::multigrid::MultigridCache;
use crate::solver::newton::{LinearStrategy, NonlinearSolver};

/// The smallest Krylov tolerance Jacobian-free solves use: a finite-difference directional
/// derivative is accurate to about √ε ≈ 1e-8 relative, so asking for less only wastes
/// iterations.
pub const MATRIX_FREE_TOLERANCE_FLOOR: f64 = 1e-7;

/// The nonlinear solver of a quasi-static solver list `solve`: NOX for `NOXQuasiStatic` on the
/// Trilinos backend, otherwise peridyn's Newton with [`strategy`]. `global_points` counts the
/// points of all ranks: the choices `Automatic` makes by the size of the system must be the
/// same on every rank and the same as on one.
pub fn nonlinear_solver(
    solve: &ImplicitSolve,
    global_points: usize,
) -> Result<Box<dyn NonlinearSolver>, Unsupported> {
    match factory::nonlinear_backend(solve)? {
        NonlinearBackend::Nox => nox_solver(solve),
        NonlinearBackend::Snes => snes_solver(solve, global_points),
        NonlinearBackend::Newton => Ok(Box::new(strategy(solve, global_points)?)),
    }
}

#[cfg(feature = "trilinos")]
fn nox_solver(solve: &ImplicitSolve) -> Result<Box<dyn NonlinearSolver>, Unsupported> {
    Ok(Box::new(super::nox_newton::NoxNewton::new(solve)?))
}

#[cfg(not(feature = "trilinos"))]
fn nox_solver(solve: &ImplicitSolve) -> Result<Box<dyn NonlinearSolver>, Unsupported> {
    Err(factory::trilinos_not_built(&solve.list))
}

#[cfg(feature = "petsc")]
fn snes_solver(
    solve: &ImplicitSolve,
    global_points: usize,
) -> Result<Box<dyn NonlinearSolver>, Unsupported> {
    Ok(Box::new(super::snes_newton::SnesNewton::new(
        solve,
        3 * global_points,
    )?))
}

#[cfg(not(feature = "petsc"))]
fn snes_solver(
    solve: &ImplicitSolve,
    _global_points: usize,
) -> Result<Box<dyn NonlinearSolver>, Unsupported> {
    Err(factory::petsc_not_built(&solve.list))
}

/// KSP through the PETSc bindings with the deck's keys and `PETSc Options`.
#[cfg(feature = "petsc")]
fn petsc_strategy(
    solve: &ImplicitSolve,
    global_points: usize,
) -> Result<LinearStrategy, Unsupported> {
    use crate::backend::petsc::{list, PetscLinearSolver};
    let settings = list::settings(solve, 3 * global_points)
        .ok_or_else(|| factory::petsc_not_built(&solve.list))?;
    Ok(LinearStrategy::Assembled(Box::new(PetscLinearSolver::new(
        settings,
    ))))
}

#[cfg(not(feature = "petsc"))]
fn petsc_strategy(
    solve: &ImplicitSolve,
    _global_points: usize,
) -> Result<LinearStrategy, Unsupported> {
    Err(factory::petsc_not_built(&solve.list))
}

/// The linear strategy of `solve` (see the module docs) for a model of `global_points`
/// points on all ranks together.
pub fn strategy(
    solve: &ImplicitSolve,
    global_points: usize,
) -> Result<LinearStrategy, Unsupported> {
    let settings = &solve.linear;
    let krylov = KrylovSettings {
        relative_tolerance: settings.relative_tolerance,
        max_iterations: settings.maximum_iterations.map(|m| m as usize),
        ..KrylovSettings::default()
    };
    if let Some(preconditioner) = jacobian_free_preconditioner(solve, global_points) {
        return Ok(LinearStrategy::MatrixFree {
            krylov: KrylovSettings {
                relative_tolerance: krylov.relative_tolerance.max(MATRIX_FREE_TOLERANCE_FLOOR),
                ..krylov
            },
            preconditioner,
            multigrid: MultigridCache::default(),
            automatic: factory::matrix_free_preconditioner(solve).is_none(),
        });
    }
    if let LinearBackend::Petsc { .. } = settings.backend {
        return petsc_strategy(solve, global_points);
    }
    if let LinearBackend::Trilinos {
        preconditioner,
        ilu_fill_level,
    } = settings.backend
    {
        return trilinos_strategy(solve, settings, krylov, preconditioner, ilu_fill_level);
    }
    let preconditioner = match settings.preconditioner {
        LinearPreconditioner::Block3x3 => PreconditionerKind::BlockJacobi,
        LinearPreconditioner::Jacobi => PreconditionerKind::Jacobi,
        // Direct methods ignore the preconditioner; the Krylov ones go to `Multigrid` below.
        LinearPreconditioner::None | LinearPreconditioner::Amg => PreconditionerKind::None,
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
        LinearMethod::Automatic if 3 * global_points <= LinearMethod::AUTOMATIC_DIRECT_LIMIT => {
            LinearMethod::Direct
        }
        LinearMethod::Automatic => LinearMethod::Cg,
        chosen => chosen,
    };
    if settings.preconditioner == LinearPreconditioner::Amg {
        let method = match method {
            LinearMethod::Cg => Some(NativeMethod::Cg),
            LinearMethod::Gmres => Some(NativeMethod::Gmres),
            _ => None,
        };
        if let Some(method) = method {
            return Ok(LinearStrategy::Multigrid {
                method,
                krylov,
                multigrid: MultigridCache::default(),
            });
        }
    }
    // `Direct` is Cholesky with LU taking over for good once the stiffness is found not
    // positive definite.
    let (method, fallback) = match method {
        LinearMethod::Automatic => unreachable!("resolved above"),
        LinearMethod::Direct => (NativeMethod::Cholesky, Some(NativeMethod::Lu)),
        LinearMethod::Cholesky => (NativeMethod::Cholesky, None),
        LinearMethod::Lu => (NativeMethod::Lu, None),
        LinearMethod::Cg => (NativeMethod::Cg, None),
        LinearMethod::Gmres => (NativeMethod::Gmres, None),
    };
    Ok(LinearStrategy::Native {
        solver: native(method),
        fallback: fallback.map(native),
    })
}

/// Belos through the Trilinos bridge: `CG` and `Automatic` are `BlockCG` (the stiffness is
/// symmetric), `GMRES` is `BlockGMRES`. ML gets the rigid-body modes and the point groups
/// from Newton at each solve; `PDE equations` 1 here is only its fallback without groups (the
/// reduced system drops prescribed components, so points carry one to three unknowns).
#[cfg(feature = "trilinos")]
fn trilinos_strategy(
    solve: &ImplicitSolve,
    settings: &LinearSolve,
    krylov: KrylovSettings,
    preconditioner: AlgebraicPreconditioner,
    ilu_fill_level: u32,
) -> Result<LinearStrategy, Unsupported> {
    use crate::backend::trilinos::{
        BelosMethod, Communicator, TrilinosLinearSolver, TrilinosPreconditioner, TrilinosSettings,
    };
    factory::check_trilinos_method(solve)?;
    let method = match settings.method {
        LinearMethod::Gmres => BelosMethod::BlockGmres,
        _ => BelosMethod::BlockCg,
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
            belos_parameters: settings.belos_parameters.clone(),
        }),
    )))
}

/// Without the `trilinos` feature the backend does not exist (the deck reader already refuses
/// the key; this covers settings built in code).
#[cfg(not(feature = "trilinos"))]
fn trilinos_strategy(
    solve: &ImplicitSolve,
    _settings: &LinearSolve,
    _krylov: KrylovSettings,
    _preconditioner: AlgebraicPreconditioner,
    _ilu_fill_level: u32,
) -> Result<LinearStrategy, Unsupported> {
    Err(factory::trilinos_not_built(&solve.list))
}
