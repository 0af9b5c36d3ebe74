//! The PETSc settings of a deck's solver list, and what `peridyn check` shows of them.
//!
//! | solver list | PETSc |
//! |---|---|
//! | `QuasiStatic`, `Implicit` | peridyn's Newton; each correction a KSP solve ([`super::linear`]) |
//! | `QuasiStatic`, `Implicit` with `Nonlinear Solver: "SNES"` | SNES `newtonls` on the assembled tangent ([`super::snes`]), the same KSP and PC |
//! | `NOXQuasiStatic` | SNES `newtonls` ([`super::snes`]); `Jacobian Operator: "Matrix-Free"` with `Peridigm Preconditioner` `Block 3x3` or `None` is `-snes_mf_operator` with the 3×3 block diagonal as preconditioning matrix, with `AMG` the one-hop operator and its rigid-body near-null space (PC GAMG unless `Linear Solver Preconditioner` or `-pc_type` says otherwise, e.g. `Hypre`) |
//!
//! `Linear Solver Preconditioner: "AMG"` on the assembled paths (`QuasiStatic`, `Implicit`,
//! SNES with the full tangent) is GAMG on the assembled tangent with the rigid-body
//! near-null space: that matrix is already there, and multigrid on the exact operator needs
//! fewer iterations than on the one-hop stand-in.
//!
//! `Linear Solver`: `CG` is `KSPCG`, `GMRES` `KSPGMRES`; `Direct` and `LU` are MUMPS' LU,
//! `Cholesky` MUMPS' Cholesky; `Automatic` is MUMPS' LU up to
//! [`LinearMethod::AUTOMATIC_DIRECT_LIMIT`] unknowns and CG beyond, as on the native backend.
//! With the Jacobian-free operator (`-snes_mf_operator`) `Automatic`, `Direct`, `LU` and
//! `Cholesky` are GMRES, the Krylov method NOX's matrix-free Newton uses: a direct solve
//! could only factor the preconditioning matrix, not the Newton operator.

use super::linear::{KspMethod, PetscLinearSolver, PetscSettings};
use super::options::DeckOptions;
use super::snes::{self, SnesJacobian};
use crate::backend::factory::matrix_free_preconditioner;
use crate::backend::native::KrylovSettings;
use crate::io::deck::{
    Integrator, LinearBackend, LinearMethod, LinearPreconditioner, NonlinearMethod, Solver,
};

/// The PETSc settings of `solver` (a list with `Backend: "PETSc"`) for a system of `unknowns`
/// unknowns (which decides `Automatic`); `None` for a list on another backend.
pub fn settings(solver: &Solver, unknowns: usize) -> Option<PetscSettings> {
    let LinearBackend::Petsc {
        preconditioner,
        ilu_fill_level,
    } = solver.linear_solve.backend
    else {
        return None;
    };
    let linear = &solver.linear_solve;
    // The Jacobian-free operator exists only as products: a direct solve could only factor
    // the preconditioning matrix, which is not the Newton operator (its "solution" is one
    // block-Jacobi sweep, on which Newton stalls). Its linear solve is GMRES, as NOX's
    // matrix-free Newton uses, preconditioned by the factored or approximated matrix.
    let matrix_free = runs_on_snes(solver) && snes_jacobian(solver) != SnesJacobian::Assembled;
    let method = match linear.method {
        LinearMethod::Direct
        | LinearMethod::Lu
        | LinearMethod::Cholesky
        | LinearMethod::Automatic
            if matrix_free =>
        {
            KspMethod::Gmres
        }
        LinearMethod::Cg => KspMethod::Cg,
        LinearMethod::Gmres => KspMethod::Gmres,
        LinearMethod::Direct | LinearMethod::Lu => KspMethod::Lu,
        LinearMethod::Cholesky => KspMethod::Cholesky,
        LinearMethod::Automatic if unknowns <= LinearMethod::AUTOMATIC_DIRECT_LIMIT => {
            KspMethod::Lu
        }
        LinearMethod::Automatic => KspMethod::Cg,
    };
    Some(PetscSettings {
        method,
        preconditioner,
        ilu_fill_level,
        krylov: KrylovSettings {
            relative_tolerance: linear.relative_tolerance,
            max_iterations: linear.maximum_iterations.map(|m| m as usize),
            ..KrylovSettings::default()
        },
        options: DeckOptions::new(&solver.name, linear.petsc_options.clone()),
    })
}

/// How SNES forms the Newton operator of a `NOXQuasiStatic` list on PETSc.
pub fn snes_jacobian(solver: &Solver) -> SnesJacobian {
    match matrix_free_preconditioner(solver) {
        Some(LinearPreconditioner::Amg) => SnesJacobian::MatrixFreeMultigrid,
        Some(_) => SnesJacobian::MatrixFree,
        None => SnesJacobian::Assembled,
    }
}

/// True when PETSc's SNES solves `solver`: a `NOXQuasiStatic` list on PETSc, or a
/// `QuasiStatic` or `Implicit` list on PETSc with `Nonlinear Solver: "SNES"`.
pub fn runs_on_snes(solver: &Solver) -> bool {
    matches!(solver.linear_solve.backend, LinearBackend::Petsc { .. })
        && match solver.integrator {
            Integrator::NoxQuasiStatic(_) => true,
            Integrator::QuasiStatic(_) | Integrator::Implicit(_) => {
                solver.linear_solve.nonlinear_method == NonlinearMethod::Snes
            }
            _ => false,
        }
}

/// Sets up `solver`'s PETSc objects with its options, without a matrix: their description
/// (`PETSc KSP cg + PC gamg`, or the SNES with its KSP), or PETSc's refusal of an option, for
/// `peridyn check` and the validation `peridyn run` shares with it. `None` for a list on
/// another backend.
pub fn resolve(solver: &Solver, unknowns: usize) -> Option<Result<String, String>> {
    let settings = settings(solver, unknowns)?;
    let result = if runs_on_snes(solver) {
        let line_search = !solver.disable_heuristics;
        let jacobian = snes_jacobian(solver);
        snes::resolve(&settings, jacobian, line_search).map(|resolved| match jacobian {
            SnesJacobian::Assembled => resolved,
            SnesJacobian::MatrixFree => {
                format!("{resolved}, -snes_mf_operator, PC built on the 3x3 block diagonal")
            }
            SnesJacobian::MatrixFreeMultigrid => format!(
                "{resolved}, -snes_mf_operator, PC built on the one-hop operator with the rigid-body near-null space"
            ),
        })
    } else {
        PetscLinearSolver::new(settings).resolve()
    };
    Some(result.map_err(|e| e.message))
}

/// How `solver` runs on several MPI ranks, for `peridyn check`: the solver PETSc resolves (as
/// [`resolve`]) on `MPI_COMM_WORLD` over a `MATMPIAIJ` of each rank's rows, and what its
/// preconditioner does with them (block Jacobi: one ILU block per rank; the one-hop operator of
/// `Peridigm Preconditioner: "AMG"`: the couplings inside each rank only). `None` for a list on
/// another backend or one whose options PETSc refuses.
pub fn on_ranks(solver: &Solver, unknowns: usize) -> Option<String> {
    let resolved = resolve(solver, unknowns)?.ok()?;
    let multigrid_operator =
        runs_on_snes(solver) && snes_jacobian(solver) == SnesJacobian::MatrixFreeMultigrid;
    let pc = resolved
        .split(" + PC ")
        .nth(1)
        .and_then(|rest| rest.split([',', ' ']).next())
        .unwrap_or("");
    let preconditioner = match pc {
        "bjacobi" => "block Jacobi, one ILU block per rank",
        "lu" | "cholesky" => "MUMPS factors across the ranks",
        "none" => "no preconditioner",
        _ => "the preconditioner works across the ranks",
    };
    let operator = if multigrid_operator {
        "; the one-hop operator keeps the couplings inside each rank only"
    } else {
        ""
    };
    Some(format!(
        "{resolved} on MPI_COMM_WORLD (a MATMPIAIJ of each rank's rows): {preconditioner}{operator}; iteration counts change with the rank count"
    ))
}
