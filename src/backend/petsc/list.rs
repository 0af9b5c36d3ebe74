//! The PETSc settings of an implicit solver list ([`ImplicitSolve`]), and what `peridyn check`
//! shows of them.
//!
//! | solver list | PETSc |
//! |---|---|
//! | `QuasiStatic`, `Implicit` | peridyn's Newton; each correction a KSP solve ([`super::linear`]) |
//! | `QuasiStatic`, `Implicit` with `Nonlinear Solver: "SNES"` | SNES `newtonls` on the assembled tangent ([`super::snes`]), the same KSP and PC |
//! | `NOXQuasiStatic` | SNES `newtonls` ([`super::snes`]); `Jacobian Operator: "Matrix-Free"` with `Peridigm Preconditioner` `Block 3x3` or `None` is `-snes_mf_operator` with the 3×3 block diagonal as preconditioning matrix (PC `none` for `None` unless `Linear Solver Preconditioner` names one), with `AMG` the one-hop operator and its rigid-body near-null space (PC GAMG unless `Linear Solver Preconditioner` or `-pc_type` says otherwise, e.g. `Hypre`) |
//!
//! | `NOXQuasiStatic` with `Direction → Method: "NonlinearCG"` | SNES `ncg` ([`super::snes`], [`ncg`]): NOX's nonlinear CG keys mapped below, on the assembled tangent |
//!
//! NOX's `Direction → Nonlinear CG` keys ([`ncg`]), with NOX's defaults:
//!
//! | NOX key | default | PETSc |
//! |---|---|---|
//! | `Orthogonalize` | `Fletcher-Reeves` | `-snes_ncg_type fr`; `Polak-Ribiere` is `prp` (its β clipped at 0 by NOX and PETSc alike). With a preconditioner PETSc's β takes the products of the preconditioned directions (‖M⁻¹F‖²), NOX's those of M⁻¹F with F |
//! | `Restart Frequency` | 10 | β = 0 every that many iterations (successive SNESSolve calls) |
//! | `Precondition` | `Off` | `On`: each direction from M⁻¹F, M⁻¹ applied as SNES's nonlinear preconditioner (one `newtonls` step on the tangent, a fixed number of Krylov iterations) |
//! | `Linear Solver → Preconditioner` | `None` | `None`: M = I; `AztecOO`: `AztecOO Preconditioner Iterations` (default 1) iterations of the `Aztec Solver` (`GMRES` default, `CG`) with the `Aztec Preconditioner` (`Jacobi` → `jacobi`, `ilu` default → `bjacobi`, `none`); `Ifpack`/`New Ifpack`: one ILU application (`preonly` + `bjacobi`); `ML`: one GAMG cycle (`preonly` + `gamg`) |
//! | `Update Jacobian` | 1 | the tangent rebuilt every that many applications of M (`-npc_snes_lag_jacobian`, persisting across load steps) |
//!
//! The line search is PETSc's `cp` whatever `Line Search → Method` says: NCG's direction is
//! not a descent direction of ‖F‖², which the other line searches decrease, and `cp`'s secant
//! step to F·d = 0 is the step NOX's `NonlinearCG` line search takes. AztecOO's `Jacobi`
//! preconditioner runs 3 Jacobi sweeps by default, PETSc's `jacobi` one: the iterations of M⁻¹
//! differ from NOX's, not the converged answer. `PETSc Options` override all of it
//! (`-snes_ncg_type`, `-snes_linesearch_type`, `-npc_ksp_type`, `-npc_pc_type`, …).
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
use super::snes::{self, NcgBeta, NcgPreconditioner, NcgSettings, SnesJacobian};
use crate::backend::factory::{matrix_free_preconditioner, nox_parameters};
use crate::backend::native::KrylovSettings;
use crate::backend::parameters::{value_at, ParameterValue};
use crate::backend::settings::{
    ImplicitSolve, LinearBackend, LinearMethod, LinearPreconditioner, Nonlinear, NonlinearMethod,
    PetscPreconditioner,
};

/// The PETSc settings of `solve` (a list with `Backend: "PETSc"`) for a system of `unknowns`
/// unknowns (which decides `Automatic`); `None` for a list on another backend.
pub fn settings(solve: &ImplicitSolve, unknowns: usize) -> Option<PetscSettings> {
    let LinearBackend::Petsc {
        preconditioner,
        ilu_fill_level,
    } = solve.linear.backend
    else {
        return None;
    };
    let linear = &solve.linear;
    // The Jacobian-free operator exists only as products: a direct solve could only factor
    // the preconditioning matrix, which is not the Newton operator (its "solution" is one
    // block-Jacobi sweep, on which Newton stalls). Its linear solve is GMRES, as NOX's
    // matrix-free Newton uses, preconditioned by the factored or approximated matrix.
    let matrix_free = runs_on_snes(solve) && snes_jacobian(solve) != SnesJacobian::Assembled;
    // `Peridigm Preconditioner: "None"` with the Jacobian-free operator is no preconditioner,
    // as on the native and Trilinos backends, unless the list names a PC.
    let preconditioner = if matrix_free
        && matrix_free_preconditioner(solve) == Some(LinearPreconditioner::None)
        && !linear.preconditioner_given
    {
        PetscPreconditioner::None
    } else {
        preconditioner
    };
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
        options: DeckOptions::new(&solve.list, linear.petsc_options.clone()),
    })
}

/// A deck key of NOX's nonlinear CG that PETSc cannot map: its path below the solver list
/// and what to give instead.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NcgKeyError {
    /// The key's path below the solver list (`NOXQuasiStatic`, `Direction`, …).
    pub path: Vec<&'static str>,
    /// What is wrong and what to give.
    pub message: String,
}

/// The nonlinear CG of a `NOXQuasiStatic` list with `Direction → Method: "NonlinearCG"`
/// (see the module docs for the keys), `Ok(None)` for any other list.
pub fn ncg(solve: &ImplicitSolve) -> Result<Option<NcgSettings>, NcgKeyError> {
    let Some(nox) = nox_parameters(solve) else {
        return Ok(None);
    };
    if nox.direction_method != "NonlinearCG" {
        return Ok(None);
    }
    const LIST: [&str; 3] = ["NOXQuasiStatic", "Direction", "Nonlinear CG"];
    let tree = &nox.nox;
    let at = |keys: &[&'static str]| {
        let mut path: Vec<&'static str> = LIST[1..].to_vec();
        path.extend_from_slice(keys);
        value_at(tree, &path)
    };
    let error = |keys: &[&'static str], message: String| {
        let mut path = LIST.to_vec();
        path.extend_from_slice(keys);
        NcgKeyError { path, message }
    };
    let text = |keys: &[&'static str], default: &'static str| match at(keys) {
        None => Ok(default.to_string()),
        Some(ParameterValue::String(s)) => Ok(s.clone()),
        Some(_) => Err(error(keys, "must be a string".into())),
    };
    let count = |keys: &[&'static str], default: u64| match at(keys) {
        None => Ok(default),
        Some(ParameterValue::Int(n)) if *n >= 1 => Ok(*n as u64),
        Some(_) => Err(error(keys, "must be an integer ≥ 1".into())),
    };
    let beta = match text(&["Orthogonalize"], "Fletcher-Reeves")?.as_str() {
        "Fletcher-Reeves" => NcgBeta::FletcherReeves,
        "Polak-Ribiere" => NcgBeta::PolakRibiere,
        other => {
            return Err(error(
                &["Orthogonalize"],
                format!("\"{other}\": use \"Fletcher-Reeves\" or \"Polak-Ribiere\" (NOX's two)"),
            ))
        }
    };
    let restart_every = count(&["Restart Frequency"], 10)?;
    let preconditioned = match text(&["Precondition"], "Off")?.as_str() {
        "On" => true,
        "Off" => false,
        other => {
            return Err(error(
                &["Precondition"],
                format!("\"{other}\": use \"On\" or \"Off\""),
            ))
        }
    };
    let jacobian_lag = count(&["Update Jacobian"], 1)?;
    let preconditioner = if !preconditioned {
        None
    } else {
        let linear = ["Linear Solver", "Preconditioner"];
        let (ksp, pc, iterations) = match text(&linear, "None")?.as_str() {
            "None" => (String::new(), String::new(), 0),
            "AztecOO" => {
                let solver_keys = ["Linear Solver", "Aztec Solver"];
                let ksp = match text(&solver_keys, "GMRES")?.as_str() {
                    "GMRES" => "gmres",
                    "CG" => "cg",
                    other => {
                        return Err(error(
                            &solver_keys,
                            format!("\"{other}\" on the PETSc backend: use \"GMRES\" or \"CG\""),
                        ))
                    }
                };
                let pc_keys = ["Linear Solver", "Aztec Preconditioner"];
                let pc = match text(&pc_keys, "ilu")?.as_str() {
                    "Jacobi" => "jacobi",
                    "ilu" => "bjacobi",
                    "none" => "none",
                    other => {
                        return Err(error(
                            &pc_keys,
                            format!("\"{other}\" on the PETSc backend: use \"Jacobi\", \"ilu\" or \"none\""),
                        ))
                    }
                };
                let iterations = count(&["Linear Solver", "AztecOO Preconditioner Iterations"], 1)?;
                (ksp.to_string(), pc.to_string(), iterations)
            }
            "Ifpack" | "New Ifpack" => ("preonly".into(), "bjacobi".into(), 1),
            "ML" => ("preonly".into(), "gamg".into(), 1),
            other => {
                return Err(error(
                    &linear,
                    format!("\"{other}\" on the PETSc backend: use \"None\", \"AztecOO\", \"Ifpack\", \"New Ifpack\" or \"ML\""),
                ))
            }
        };
        (iterations > 0).then_some(NcgPreconditioner {
            ksp,
            pc,
            iterations,
            jacobian_lag,
        })
    };
    Ok(Some(NcgSettings {
        beta,
        restart_every,
        preconditioner,
    }))
}

/// How SNES forms the Newton operator of a `NOXQuasiStatic` list on PETSc (nonlinear CG
/// always assembles: its preconditioner works on the tangent).
pub fn snes_jacobian(solve: &ImplicitSolve) -> SnesJacobian {
    if nox_parameters(solve).is_some_and(|nox| nox.direction_method == "NonlinearCG") {
        return SnesJacobian::Assembled;
    }
    match matrix_free_preconditioner(solve) {
        Some(LinearPreconditioner::Amg) => SnesJacobian::MatrixFreeMultigrid,
        Some(_) => SnesJacobian::MatrixFree,
        None => SnesJacobian::Assembled,
    }
}

/// True when PETSc's SNES solves `solve`: a `NOXQuasiStatic` list on PETSc, or a
/// `QuasiStatic` or `Implicit` list on PETSc with `Nonlinear Solver: "SNES"`.
pub fn runs_on_snes(solve: &ImplicitSolve) -> bool {
    matches!(solve.linear.backend, LinearBackend::Petsc { .. })
        && match solve.nonlinear {
            Nonlinear::Nox(_) => true,
            Nonlinear::Newton { .. } => solve.linear.nonlinear_method == NonlinearMethod::Snes,
        }
}

/// Sets up `solve`'s PETSc objects with its options, without a matrix: their description
/// (`PETSc KSP cg + PC gamg`, or the SNES with its KSP), or PETSc's refusal of an option, for
/// `peridyn check` and the validation `peridyn run` shares with it. `None` for a list on
/// another backend.
pub fn resolve(solve: &ImplicitSolve, unknowns: usize) -> Option<Result<String, String>> {
    let settings = settings(solve, unknowns)?;
    let ncg = match ncg(solve) {
        Ok(ncg) => ncg,
        Err(e) => return Some(Err(format!("{}: {}", e.path.join(" → "), e.message))),
    };
    let result = if runs_on_snes(solve) {
        let line_search = solve.line_search;
        let jacobian = snes_jacobian(solve);
        snes::resolve(&settings, jacobian, line_search, ncg.as_ref()).map(|resolved| match jacobian {
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

/// How `solve` runs on several MPI ranks, for `peridyn check`: the solver PETSc resolves (as
/// [`resolve`]) on `MPI_COMM_WORLD` over a `MATMPIAIJ` of each rank's rows, and what its
/// preconditioner does with them (block Jacobi: one ILU block per rank; the one-hop operator of
/// `Peridigm Preconditioner: "AMG"`: every rank's rows with their couplings to other ranks).
/// `None` for a list on another backend or one whose options PETSc refuses.
pub fn on_ranks(solve: &ImplicitSolve, unknowns: usize) -> Option<String> {
    let resolved = resolve(solve, unknowns)?.ok()?;
    let multigrid_operator =
        runs_on_snes(solve) && snes_jacobian(solve) == SnesJacobian::MatrixFreeMultigrid;
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
        "; the one-hop operator holds the couplings between ranks too"
    } else {
        ""
    };
    Some(format!(
        "{resolved} on MPI_COMM_WORLD (a MATMPIAIJ of each rank's rows): {preconditioner}{operator}; iteration counts change with the rank count"
    ))
}
