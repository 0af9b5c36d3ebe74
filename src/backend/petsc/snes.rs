//! SNES Newton on a [`NonlinearProblem`]: PETSc drives the iteration, peridyn answers its
//! callbacks with the problem's own residual and tangent (the one-residual rule: the same
//! [`NonlinearProblem::residual`] the native Newton and NOX call).
//!
//! * SNES `newtonls` with the `bt` (backtracking) line search, `basic` (full steps) with
//!   `Disable Heuristics`; the KSP and PC are the solver list's ([`PetscSettings`]), and the
//!   deck's `PETSc Options` (`-snes_*`, `-ksp_*`, `-pc_*`) override everything;
//! * convergence is peridyn's: the test calls [`NonlinearProblem::convergence_measure`] on F
//!   and stops at the deck's tolerance or iteration limit (PETSc's own tests are replaced);
//! * with [`NcgSettings`] (NOX's `NonlinearCG` direction) SNES `ncg` replaces Newton: the `cp`
//!   line search, a restart every `Restart Frequency` iterations (successive SNESSolve calls,
//!   the convergence test counting across them), and when preconditioned a nonlinear
//!   preconditioner of one `newtonls` step on the assembled tangent ([`NcgPreconditioner`]);
//! * [`SnesJacobian::Assembled`]: the tangent's values are refilled into a `MATSEQAIJ` over
//!   peridyn's arrays at each Jacobian request;
//! * [`SnesJacobian::MatrixFree`]: `-snes_mf_operator`: the operator is PETSc's finite
//!   difference of F (`MATMFFD`), whose probes call F with damage frozen
//!   ([`Evaluation::Probe`], through `MatMFFDSetFunction`); the matrix the PC is built from is
//!   the 3×3 point-block diagonal of the tangent ([`NonlinearProblem::block_diagonal`]), so the
//!   full tangent is never assembled;
//! * [`SnesJacobian::MatrixFreeMultigrid`]: the same `-snes_mf_operator` operator, with the
//!   problem's one-hop operator ([`NonlinearProblem::preconditioning_operator`], the PMB-like
//!   stiffness over the bonds) as the matrix the PC is built from, carrying the rigid-body
//!   modes as its near-null space (`MatSetNearNullSpace`, orthonormalised) and block size 3
//!   when every point keeps its three unknowns: the PC is GAMG by default, hypre's BoomerAMG
//!   with `-pc_type hypre`. The operator is refilled (into the first pattern, which bonds
//!   breaking only thin out) when [`NonlinearProblem::preconditioning_version`] changes, and
//!   otherwise kept, so PETSc keeps the multigrid hierarchy across Newton iterations.
//!
//! On several MPI ranks ([`NonlinearProblem::ranks`] > 1) the SNES, its vectors and matrix live
//! on `MPI_COMM_WORLD` over this rank's unknowns ([`super::layout`]): the assembled tangent
//! and the one-hop operator arrive with global column ids (the one-hop operator's rows hold
//! the bonds to other ranks' points, so GAMG sees the one-rank operator whatever the
//! partition) and become `MATMPIAIJ`s (values copied in at each refill, `MatSetValues`); the
//! 3×3 block diagonal is built over the rank's own unknowns. Every callback is collective:
//! PETSc calls it on all ranks together, and the residual refreshes the ghosts first.
//!
//! The prescribed dofs are not unknowns of the problem (eliminated as on the other backends),
//! so the near-null space is not built with `MatNullSpaceCreateRigidBody` (which needs a
//! coordinate vector in the matrix's point-block layout) but from the problem's rigid-body
//! modes over the remaining unknowns: the same space.
//!
//! Errors: a callback never unwinds into C. It runs inside `catch_unwind`; a Rust error (a
//! non-finite residual, say) is kept in the context and the callback returns `PETSC_ERR_USER`,
//! PETSc unwinds its own stack with error codes, and [`solve`] returns the kept error itself.

use std::ffi::{c_void, CString};

use mpi::topology::{Communicator as _, SimpleCommunicator};
use std::panic::{catch_unwind, AssertUnwindSafe};

use super::layout::{sum_over_ranks, Columns, DistributedMatrix, Layout};
use super::linear::{resolved_types, set_near_null_space, PetscSettings, PETSC_DEFAULT_REAL};
use super::options::DeckOptions;
use super::runtime::{check, owned_string, PetscError, Turn};
use super::sys;
use crate::backend::problem::{Evaluation, NonlinearProblem};
use crate::backend::{block_diagonal_csr, Csr, SolveError};

/// How SNES forms the Newton operator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SnesJacobian {
    /// The assembled tangent, operator and preconditioning matrix alike.
    Assembled,
    /// `-snes_mf_operator` with the 3×3 block diagonal as preconditioning matrix.
    MatrixFree,
    /// `-snes_mf_operator` with the one-hop operator and the rigid-body near-null space as
    /// preconditioning matrix (for GAMG or hypre).
    MatrixFreeMultigrid,
}

/// The β formula of SNES's nonlinear conjugate gradient (`-snes_ncg_type`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NcgBeta {
    /// `fr`, Fletcher–Reeves: β = ‖d_k‖² / ‖d_{k−1}‖² (NOX's `Orthogonalize` default).
    FletcherReeves,
    /// `prp`, Polak–Ribière–Polyak: β = max(0, d_k·(d_k − d_{k−1}) / ‖d_{k−1}‖²).
    PolakRibiere,
}

impl NcgBeta {
    /// PETSc's name (`-snes_ncg_type`).
    pub fn name(self) -> &'static str {
        match self {
            NcgBeta::FletcherReeves => "fr",
            NcgBeta::PolakRibiere => "prp",
        }
    }
}

/// The linear preconditioner M of a preconditioned nonlinear CG: each direction is built
/// from M⁻¹F instead of F. PETSc applies it as a nonlinear preconditioner (`SNESGetNPC`): one
/// `newtonls` step with a full step (line search `basic`) on the assembled tangent, whose KSP
/// runs exactly `iterations` iterations from zero (relative tolerance 0), so x − NPC(x) =
/// M⁻¹F(x) with M⁻¹ that fixed-iteration Krylov solve, as NOX's `AztecOO Preconditioner
/// Iterations` runs its AztecOO solver.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NcgPreconditioner {
    /// KSP type of M⁻¹ (`gmres`, `cg`, `preonly`).
    pub ksp: String,
    /// PC type inside it (`jacobi`, `bjacobi`, `none`).
    pub pc: String,
    /// Krylov iterations of one application (≥ 1).
    pub iterations: u64,
    /// The tangent is rebuilt every this many applications (1: every one), kept across load
    /// steps (`-npc_snes_lag_jacobian` with `-npc_snes_lag_jacobian_persists`).
    pub jacobian_lag: u64,
}

/// SNES's nonlinear conjugate gradient (`SNESNCG`) in place of Newton.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NcgSettings {
    /// The β formula.
    pub beta: NcgBeta,
    /// A steepest-descent restart (β = 0) every this many iterations: SNESNCG has no periodic
    /// restart, so the solve runs as successive SNESSolve calls of at most this many
    /// iterations, each starting from the (preconditioned) residual direction.
    pub restart_every: u64,
    /// `None` for plain NCG (directions from F itself).
    pub preconditioner: Option<NcgPreconditioner>,
}

/// One SNES solve's configuration.
#[derive(Debug, Clone, Copy)]
pub struct SnesSettings<'a> {
    /// KSP, PC and the deck's options.
    pub linear: &'a PetscSettings,
    /// How the operator is formed.
    pub jacobian: SnesJacobian,
    /// Converged when the problem's measure is ≤ this.
    pub tolerance: f64,
    /// Newton iterations allowed.
    pub max_iterations: u64,
    /// `bt` line search (otherwise `basic`); nonlinear CG always uses `cp`.
    pub line_search: bool,
    /// Nonlinear CG instead of Newton (the Jacobian must be [`SnesJacobian::Assembled`]).
    pub ncg: Option<&'a NcgSettings>,
    /// Print `  iteration i: residual = …` after every iteration.
    pub print_iterations: bool,
    /// Warn about `PETSc Options` PETSc did not use, after the solve (the first solve of a
    /// run only, so the warning is given once).
    pub warn_unused: bool,
}

/// What a SNES solve did.
#[derive(Debug, Clone, PartialEq)]
pub struct SnesReport {
    /// The measure reached the tolerance.
    pub converged: bool,
    /// Newton iterations.
    pub iterations: usize,
    /// Krylov iterations summed over the solve.
    pub linear_iterations: usize,
    /// The measure at the start and after each iteration.
    pub history: Vec<f64>,
    /// `PETSc SNES <type> (line search <type>), KSP <type> + PC <type>`.
    pub method: String,
    /// PETSc's converged reason, e.g. `SNES_CONVERGED_FNORM_ABS`.
    pub reason: String,
}

/// The Rust side of one SNES solve, reached from the C callbacks through their `void*`.
struct Context<'a> {
    problem: &'a mut dyn NonlinearProblem,
    jacobian: SnesJacobian,
    /// The preconditioning matrix's arrays (PETSc works on `values` in place).
    values: Vec<f64>,
    /// `values[k] = source[order[k]]` (columns sorted within rows).
    order: Vec<usize>,
    /// The pattern's row offsets and (sorted) columns, to refill the one-hop operator.
    offsets: Vec<usize>,
    columns: Vec<usize>,
    /// [`NonlinearProblem::preconditioning_version`] of the one-hop operator in `values`.
    operator_version: usize,
    /// On several ranks, the `MATMPIAIJ` that `values` are copied into (PETSc cannot work on
    /// them in place there).
    distributed: Option<DistributedMatrix>,
    tolerance: f64,
    max_iterations: u64,
    /// Iterations done by the earlier SNESSolve calls of a restarted nonlinear CG.
    iteration_offset: u64,
    history: Vec<f64>,
    print_iterations: bool,
    /// The first error a callback met.
    error: Option<SolveError>,
}

impl Context<'_> {
    /// Runs `body` for a callback: a Rust error or panic is kept and becomes `PETSC_ERR_USER`.
    fn guard(
        &mut self,
        body: impl FnOnce(&mut Self) -> Result<(), SolveError>,
    ) -> sys::PetscErrorCode {
        let outcome = catch_unwind(AssertUnwindSafe(|| body(self)));
        let error = match outcome {
            Ok(Ok(())) => return 0,
            Ok(Err(e)) => e,
            Err(panic) => SolveError::Breakdown {
                method: "PETSc SNES",
                reason: format!(
                    "a callback panicked: {}",
                    panic
                        .downcast_ref::<&str>()
                        .map(|s| s.to_string())
                        .or_else(|| panic.downcast_ref::<String>().cloned())
                        .unwrap_or_default()
                ),
            },
        };
        self.error.get_or_insert(error);
        PETSC_ERR_USER
    }
}

/// `PETSC_ERR_USER` (petscerror.h): the error code a failed callback returns.
const PETSC_ERR_USER: sys::PetscErrorCode = 83;

/// A read-only view of a PETSc vector's entries for the duration of `body`.
unsafe fn with_read(
    v: sys::PetscVec,
    body: impl FnOnce(&[f64]) -> Result<(), SolveError>,
) -> Result<(), SolveError> {
    let mut n: sys::PetscInt = 0;
    let mut data: *const f64 = std::ptr::null();
    let petsc = |e: PetscError| SolveError::Breakdown {
        method: "PETSc SNES",
        reason: e.to_string(),
    };
    check(sys::VecGetLocalSize(v, &mut n)).map_err(petsc)?;
    check(sys::VecGetArrayRead(v, &mut data)).map_err(petsc)?;
    let slice = std::slice::from_raw_parts(data, usize::try_from(n).unwrap_or(0));
    let result = body(slice);
    check(sys::VecRestoreArrayRead(v, &mut data)).map_err(petsc)?;
    result
}

/// A writable view of a PETSc vector's entries for the duration of `body`.
unsafe fn with_write(
    v: sys::PetscVec,
    body: impl FnOnce(&mut [f64]) -> Result<(), SolveError>,
) -> Result<(), SolveError> {
    let mut n: sys::PetscInt = 0;
    let mut data: *mut f64 = std::ptr::null_mut();
    let petsc = |e: PetscError| SolveError::Breakdown {
        method: "PETSc SNES",
        reason: e.to_string(),
    };
    check(sys::VecGetLocalSize(v, &mut n)).map_err(petsc)?;
    check(sys::VecGetArray(v, &mut data)).map_err(petsc)?;
    let slice = std::slice::from_raw_parts_mut(data, usize::try_from(n).unwrap_or(0));
    let result = body(slice);
    check(sys::VecRestoreArray(v, &mut data)).map_err(petsc)?;
    result
}

/// Evaluates F at `x` into `f` with `evaluation`.
unsafe fn evaluate(
    context: *mut c_void,
    x: sys::PetscVec,
    f: sys::PetscVec,
    evaluation: Evaluation,
) -> sys::PetscErrorCode {
    // SAFETY: `context` is the `Context` `solve` registered, alive during SNESSolve.
    let context = &mut *(context as *mut Context);
    context.guard(|c| {
        let mut input = Vec::new();
        with_read(x, |x| {
            input.extend_from_slice(x);
            Ok(())
        })?;
        with_write(f, |f| c.problem.residual(&input, f, evaluation))
    })
}

/// SNES's function: F at an iterate or line-search trial.
unsafe extern "C" fn form_function(
    _snes: sys::SNES,
    x: sys::PetscVec,
    f: sys::PetscVec,
    context: *mut c_void,
) -> sys::PetscErrorCode {
    evaluate(context, x, f, Evaluation::Iterate)
}

/// The matrix-free operator's function: F at a finite-difference probe, damage frozen.
unsafe extern "C" fn probe_function(
    context: *mut c_void,
    x: sys::PetscVec,
    f: sys::PetscVec,
) -> sys::PetscErrorCode {
    evaluate(context, x, f, Evaluation::Probe)
}

/// SNES's Jacobian: refills the preconditioning matrix (the tangent, or its 3×3 blocks).
unsafe extern "C" fn form_jacobian(
    _snes: sys::SNES,
    x: sys::PetscVec,
    operator: sys::Mat,
    preconditioning: sys::Mat,
    context: *mut c_void,
) -> sys::PetscErrorCode {
    // SAFETY: as in `evaluate`.
    let context = &mut *(context as *mut Context);
    let mut refilled = true;
    let code = context.guard(|c| {
        if c.jacobian == SnesJacobian::MatrixFreeMultigrid {
            refilled = c.refill_operator()?;
            return Ok(());
        }
        let mut input = Vec::new();
        with_read(x, |x| {
            input.extend_from_slice(x);
            Ok(())
        })?;
        let source = match c.jacobian {
            SnesJacobian::Assembled => c.problem.jacobian(&input)?.values,
            SnesJacobian::MatrixFree | SnesJacobian::MatrixFreeMultigrid => {
                c.problem.block_diagonal(&input)?
            }
        };
        if source.len() != c.order.len() {
            return Err(SolveError::Breakdown {
                method: "PETSc SNES",
                reason: format!(
                    "{} matrix values for a pattern of {} entries",
                    source.len(),
                    c.order.len()
                ),
            });
        }
        for (slot, &k) in c.values.iter_mut().zip(&c.order) {
            *slot = source[k];
        }
        c.push_values()
    });
    if code != 0 {
        return code;
    }
    for matrix in [operator, preconditioning] {
        // A preconditioning matrix left as it was is not reassembled, so PETSc keeps its PC
        // (the multigrid hierarchy); the operator always is.
        if matrix == preconditioning && !refilled {
            break;
        }
        // SAFETY: live matrices handed over by SNES; assembling the MFFD operator sets its
        // base point to the new iterate.
        let assembled = sys::MatAssemblyBegin(matrix, sys::MatAssemblyType_MAT_FINAL_ASSEMBLY);
        if assembled != 0 {
            return assembled;
        }
        let assembled = sys::MatAssemblyEnd(matrix, sys::MatAssemblyType_MAT_FINAL_ASSEMBLY);
        if assembled != 0 {
            return assembled;
        }
        if operator == preconditioning {
            break;
        }
    }
    0
}

impl Context<'_> {
    /// Refills the one-hop operator when the problem's changed since it was built (bonds
    /// broke); returns whether it did.
    fn refill_operator(&mut self) -> Result<bool, SolveError> {
        let version = self.problem.preconditioning_version();
        if version == self.operator_version {
            return Ok(false);
        }
        let operator = self
            .problem
            .preconditioning_operator()?
            .ok_or_else(no_operator)?;
        scatter_into_pattern(
            &operator.matrix,
            &self.offsets,
            &self.columns,
            &mut self.values,
        )?;
        self.push_values()?;
        self.operator_version = version;
        Ok(true)
    }

    /// On several ranks, copies `values` into the distributed matrix (on one process PETSc
    /// reads them in place).
    fn push_values(&self) -> Result<(), SolveError> {
        match &self.distributed {
            Some(matrix) => matrix
                .set_values(&self.values)
                .map_err(|e| failure("filling the matrix", e)),
            None => Ok(()),
        }
    }
}

fn no_operator() -> SolveError {
    SolveError::Breakdown {
        method: "PETSc SNES",
        reason: "Peridigm Preconditioner \"AMG\" needs the one-hop preconditioning operator, which this problem does not offer".into(),
    }
}

/// Writes `matrix`'s entries into `values` laid out on the pattern (`offsets`, sorted
/// `columns`), entries of the pattern that `matrix` lacks set to zero.
fn scatter_into_pattern(
    matrix: &Csr,
    offsets: &[usize],
    columns: &[usize],
    values: &mut [f64],
) -> Result<(), SolveError> {
    if matrix.nrows + 1 != offsets.len() {
        return Err(SolveError::Breakdown {
            method: "PETSc SNES",
            reason: format!(
                "a preconditioning operator of {} rows for {} unknowns",
                matrix.nrows,
                offsets.len() - 1
            ),
        });
    }
    values.fill(0.0);
    for r in 0..matrix.nrows {
        let row = &columns[offsets[r]..offsets[r + 1]];
        for k in matrix.offsets[r]..matrix.offsets[r + 1] {
            let column = matrix.columns[k];
            let slot = row.binary_search(&column).map_err(|_| SolveError::Breakdown {
                method: "PETSc SNES",
                reason: format!(
                    "the preconditioning operator gained the entry ({r}, {column}) outside its first pattern"
                ),
            })?;
            values[offsets[r] + slot] += matrix.values[k];
        }
    }
    Ok(())
}

/// peridyn's convergence test: the problem's measure of F against the tolerance.
unsafe extern "C" fn converged(
    snes: sys::SNES,
    iteration: sys::PetscInt,
    _xnorm: sys::PetscReal,
    _step_norm: sys::PetscReal,
    _fnorm: sys::PetscReal,
    reason: *mut sys::SNESConvergedReason,
    context: *mut c_void,
) -> sys::PetscErrorCode {
    // SAFETY: as in `evaluate`.
    let context = &mut *(context as *mut Context);
    let mut f: sys::PetscVec = std::ptr::null_mut();
    let code = sys::SNESGetFunction(snes, &mut f, std::ptr::null_mut(), std::ptr::null_mut());
    if code != 0 {
        return code;
    }
    let mut measure = f64::NAN;
    let code = context.guard(|c| {
        with_read(f, |f| {
            measure = c.problem.convergence_measure(f);
            Ok(())
        })
    });
    if code != 0 {
        return code;
    }
    // A restarted nonlinear CG's later SNESSolve calls begin at the iterate the previous one
    // ended on, whose measure is already in the history.
    let restart = iteration == 0 && context.iteration_offset > 0;
    let iteration = context.iteration_offset + u64::try_from(iteration).unwrap_or(0);
    if !restart {
        context.history.push(measure);
        if context.print_iterations && iteration > 0 {
            eprintln!("  iteration {iteration}: residual = {measure:e}");
        }
    }
    *reason = if !measure.is_finite() {
        sys::SNESConvergedReason_SNES_DIVERGED_FNORM_NAN
    } else if measure <= context.tolerance {
        sys::SNESConvergedReason_SNES_CONVERGED_FNORM_ABS
    } else if iteration >= context.max_iterations {
        sys::SNESConvergedReason_SNES_DIVERGED_MAX_IT
    } else {
        sys::SNESConvergedReason_SNES_CONVERGED_ITERATING
    };
    0
}

/// PETSc's name of a SNES converged reason.
fn reason_name(reason: sys::SNESConvergedReason) -> String {
    match reason {
        sys::SNESConvergedReason_SNES_CONVERGED_FNORM_ABS => "SNES_CONVERGED_FNORM_ABS".into(),
        sys::SNESConvergedReason_SNES_DIVERGED_MAX_IT => "SNES_DIVERGED_MAX_IT".into(),
        sys::SNESConvergedReason_SNES_DIVERGED_FNORM_NAN => "SNES_DIVERGED_FNORM_NAN".into(),
        sys::SNESConvergedReason_SNES_DIVERGED_LINE_SEARCH => "SNES_DIVERGED_LINE_SEARCH".into(),
        sys::SNESConvergedReason_SNES_DIVERGED_LINEAR_SOLVE => "SNES_DIVERGED_LINEAR_SOLVE".into(),
        sys::SNESConvergedReason_SNES_DIVERGED_FUNCTION_COUNT => {
            "SNES_DIVERGED_FUNCTION_COUNT".into()
        }
        other => format!("SNES converged reason {other}"),
    }
}

/// The PETSc objects of one solve.
struct Objects {
    snes: sys::SNES,
    matrix: sys::Mat,
    solution: sys::PetscVec,
    residual: sys::PetscVec,
    /// F of nonlinear CG's preconditioner (null without one).
    npc_residual: sys::PetscVec,
}

impl Drop for Objects {
    fn drop(&mut self) {
        // SAFETY: null or live objects of this solve; the turn is held by `solve` while they
        // live (they are dropped before it).
        unsafe {
            sys::SNESDestroy(&mut self.snes);
            sys::MatDestroy(&mut self.matrix);
            sys::VecDestroy(&mut self.solution);
            sys::VecDestroy(&mut self.residual);
            sys::VecDestroy(&mut self.npc_residual);
        }
    }
}

fn failure(stage: &str, e: PetscError) -> SolveError {
    SolveError::Breakdown {
        method: "PETSc SNES",
        reason: format!("{stage}: {e}"),
    }
}

/// Runs SNES on `problem` from its current unknowns; on return the problem has been
/// evaluated (as an iterate) at SNES's last iterate. A solve that stops unconverged is a
/// report with `converged == false`; errors are callback errors (as raised) and PETSc's.
pub fn solve(
    problem: &mut dyn NonlinearProblem,
    settings: &SnesSettings,
) -> Result<SnesReport, SolveError> {
    let distributed = problem.ranks() > 1;
    let global_ids: Option<Vec<usize>> = problem.global_ids().map(<[usize]>::to_vec);
    let n = problem.len();
    let mut x = vec![0.0; n];
    problem.unknowns(&mut x);
    let operator_version = problem.preconditioning_version();
    let mut near_null_space = None;
    let pattern: Csr = match settings.jacobian {
        SnesJacobian::Assembled => problem.jacobian(&x)?,
        SnesJacobian::MatrixFree => {
            let groups = problem.groups().to_vec();
            let entries = groups.windows(2).map(|g| (g[1] - g[0]).pow(2)).sum();
            block_diagonal_csr(&groups, &vec![0.0; entries])
        }
        SnesJacobian::MatrixFreeMultigrid => {
            let operator = problem
                .preconditioning_operator()?
                .ok_or_else(no_operator)?;
            near_null_space = Some((operator.null_space, operator.modes));
            operator.matrix
        }
    };
    // Block size 3 (GAMG aggregates whole points) when every point kept its three unknowns.
    let mut whole_points = problem.groups().windows(2).all(|g| g[1] - g[0] == 3);
    if distributed {
        whole_points = sum_over_ranks(f64::from(u8::from(!whole_points))) == 0.0;
    }
    let mut order = Vec::with_capacity(pattern.nnz());
    for r in 0..n {
        let mut row: Vec<usize> = (pattern.offsets[r]..pattern.offsets[r + 1]).collect();
        row.sort_by_key(|&k| pattern.columns[k]);
        order.extend(row);
    }
    let index = |v: usize| {
        sys::PetscInt::try_from(v).map_err(|_| SolveError::Breakdown {
            method: "PETSc SNES",
            reason: format!("{n} unknowns exceed PETSc's indices"),
        })
    };
    let mut offsets: Vec<sys::PetscInt> = pattern
        .offsets
        .iter()
        .map(|&o| index(o))
        .collect::<Result<_, _>>()?;
    let mut columns: Vec<sys::PetscInt> = order
        .iter()
        .map(|&k| index(pattern.columns[k]))
        .collect::<Result<_, _>>()?;
    let rows = index(n)?;
    let pattern_columns = pattern.ncols;
    let mut context = Context {
        problem: &mut *problem,
        jacobian: settings.jacobian,
        values: order.iter().map(|&k| pattern.values[k]).collect(),
        offsets: pattern.offsets.clone(),
        columns: order.iter().map(|&k| pattern.columns[k]).collect(),
        order,
        operator_version,
        distributed: None,
        tolerance: settings.tolerance,
        max_iterations: settings.max_iterations,
        iteration_offset: 0,
        history: Vec::new(),
        print_iterations: settings.print_iterations,
        error: None,
    };
    let turn = Turn::take().map_err(|e| failure("starting PETSc", e))?;
    let mut objects = Objects {
        snes: std::ptr::null_mut(),
        matrix: std::ptr::null_mut(),
        solution: std::ptr::null_mut(),
        residual: std::ptr::null_mut(),
        npc_residual: std::ptr::null_mut(),
    };
    let options = &settings.linear.options;
    // On several ranks: the assembled tangent's and the one-hop operator's columns are global
    // ids, the block diagonal's this rank's own unknowns.
    let layout = match distributed {
        true => {
            let ids = match settings.jacobian {
                SnesJacobian::Assembled | SnesJacobian::MatrixFreeMultigrid => {
                    global_ids.as_deref()
                }
                SnesJacobian::MatrixFree => None,
            };
            Some(Layout::new(&turn, n, ids).map_err(|e| failure("laying out the unknowns", e))?)
        }
        false => None,
    };
    let context_pointer = &mut context as *mut Context as *mut c_void;
    // SAFETY: every object is created on the run's communicator (MPI_COMM_SELF on one process)
    // and destroyed by `objects`' Drop; on one process the matrix works on `offsets`,
    // `columns` and `context.values`, which outlive it; the callbacks get `context`, which
    // outlives SNESSolve.
    let setup = unsafe {
        (|| -> Result<String, PetscError> {
            let comm = match layout {
                Some(_) => turn.comm_world(),
                None => turn.comm_self(),
            };
            let context = &mut *(context_pointer as *mut Context);
            match &layout {
                Some(layout) => {
                    let sorted = Csr {
                        nrows: n,
                        ncols: pattern_columns,
                        offsets: context.offsets.clone(),
                        columns: context.columns.clone(),
                        values: context.values.clone(),
                    };
                    let numbering = match settings.jacobian {
                        SnesJacobian::Assembled | SnesJacobian::MatrixFreeMultigrid => {
                            Columns::Global
                        }
                        SnesJacobian::MatrixFree => Columns::Local,
                    };
                    let matrix = DistributedMatrix::new(&turn, layout, &sorted, numbering)?;
                    objects.matrix = matrix.matrix;
                    context.distributed = Some(matrix);
                    objects.solution = layout.vector(&turn)?;
                    objects.residual = layout.vector(&turn)?;
                }
                None => {
                    check(sys::MatCreateSeqAIJWithArrays(
                        comm,
                        rows,
                        rows,
                        offsets.as_mut_ptr(),
                        columns.as_mut_ptr(),
                        context.values.as_mut_ptr(),
                        &mut objects.matrix,
                    ))?;
                    check(sys::VecCreateSeq(comm, rows, &mut objects.solution))?;
                    check(sys::VecCreateSeq(comm, rows, &mut objects.residual))?;
                }
            }
            if let Some((modes, count)) = &near_null_space {
                if whole_points {
                    check(sys::MatSetBlockSize(objects.matrix, 3))?;
                }
                set_near_null_space(&turn, objects.matrix, modes, *count, n, layout.as_ref())?;
            }
            check(sys::SNESCreate(comm, &mut objects.snes))?;
            let snes = objects.snes;
            let prefix = options.c_prefix();
            check(sys::SNESSetOptionsPrefix(snes, prefix.as_ptr()))?;
            let npc = set_method(snes, settings.ncg, settings.line_search)?;
            check(sys::SNESSetFunction(
                snes,
                objects.residual,
                Some(form_function),
                context_pointer,
            ))?;
            check(sys::SNESSetJacobian(
                snes,
                objects.matrix,
                objects.matrix,
                Some(form_jacobian),
                context_pointer,
            ))?;
            if let Some(npc) = npc {
                // The preconditioner's Newton step needs F and the tangent: the same
                // callbacks on the same matrix, F into a vector of its own.
                check(sys::VecDuplicate(
                    objects.residual,
                    &mut objects.npc_residual,
                ))?;
                check(sys::SNESSetFunction(
                    npc,
                    objects.npc_residual,
                    Some(form_function),
                    context_pointer,
                ))?;
                check(sys::SNESSetJacobian(
                    npc,
                    objects.matrix,
                    objects.matrix,
                    Some(form_jacobian),
                    context_pointer,
                ))?;
            }
            check(sys::SNESSetConvergenceTest(
                snes,
                Some(converged),
                context_pointer,
                None,
            ))?;
            let limit = sys::PetscInt::try_from(chunk(settings, 0)).unwrap_or(sys::PetscInt::MAX);
            check(sys::SNESSetTolerances(
                snes,
                0.0,
                0.0,
                0.0,
                limit,
                sys::PetscInt::MAX,
            ))?;
            // A Krylov solve stopped at its limit still gives a direction; the line search
            // and the convergence test judge the step (as peridyn's inexact Newton does).
            check(sys::SNESSetMaxLinearSolveFailures(snes, sys::PetscInt::MAX))?;
            if settings.jacobian != SnesJacobian::Assembled {
                check(sys::SNESSetUseMatrixFree(
                    snes,
                    sys::PetscBool_PETSC_TRUE,
                    sys::PetscBool_PETSC_FALSE,
                ))?;
            }
            let mut ksp: sys::KSP = std::ptr::null_mut();
            check(sys::SNESGetKSP(snes, &mut ksp))?;
            let unknowns = layout.as_ref().map_or(n, Layout::global);
            settings.linear.configure(&turn, ksp, unknowns, false)?;
            check(sys::SNESSetFromOptions(snes))?;
            match npc {
                // SNESNCG's setup needs the solution vector, which only SNESSolve hands over;
                // the preconditioner reads its options there too, and here for `describe`.
                Some(npc) => check(sys::SNESSetFromOptions(npc))?,
                None if settings.ncg.is_some() => {}
                None => check(sys::SNESSetUp(snes))?,
            }
            if settings.jacobian != SnesJacobian::Assembled {
                let mut operator: sys::Mat = std::ptr::null_mut();
                check(sys::SNESGetJacobian(
                    snes,
                    &mut operator,
                    std::ptr::null_mut(),
                    std::ptr::null_mut(),
                    std::ptr::null_mut(),
                ))?;
                if operator != objects.matrix {
                    check(sys::MatMFFDSetFunction(
                        operator,
                        Some(probe_function),
                        context_pointer,
                    ))?;
                }
            }
            describe(snes, settings.ncg, options)
        })()
    };
    let method = match setup {
        Ok(method) => method,
        Err(e) => {
            drop(objects);
            options.clear(&turn, &settings.linear.option_defaults());
            return Err(failure("setting up SNES", e));
        }
    };
    let mut iterations: sys::PetscInt = 0;
    let mut linear_iterations: sys::PetscInt = 0;
    let mut reason: sys::SNESConvergedReason = 0;
    // SAFETY: the vectors are live; `x` is copied in and out through the vector's array;
    // `context` is reached only through the callbacks while SNESSolve runs.
    let solved = unsafe {
        (|| -> Result<(), PetscError> {
            let mut data: *mut f64 = std::ptr::null_mut();
            check(sys::VecGetArray(objects.solution, &mut data))?;
            std::slice::from_raw_parts_mut(data, n).copy_from_slice(&x);
            check(sys::VecRestoreArray(objects.solution, &mut data))?;
            // Newton solves in one call; a restarted nonlinear CG in calls of at most
            // `restart_every` iterations, each restarting from the residual direction.
            let mut done: u64 = 0;
            let result = loop {
                let result = check(sys::SNESSolve(
                    objects.snes,
                    std::ptr::null_mut(),
                    objects.solution,
                ));
                if result.is_err() {
                    break result;
                }
                let mut chunk_iterations: sys::PetscInt = 0;
                let mut chunk_linear: sys::PetscInt = 0;
                check(sys::SNESGetIterationNumber(
                    objects.snes,
                    &mut chunk_iterations,
                ))?;
                check(sys::SNESGetLinearSolveIterations(
                    objects.snes,
                    &mut chunk_linear,
                ))?;
                check(sys::SNESGetConvergedReason(objects.snes, &mut reason))?;
                done += u64::try_from(chunk_iterations).unwrap_or(0);
                linear_iterations += chunk_linear;
                let restart = settings.ncg.is_some()
                    && reason == sys::SNESConvergedReason_SNES_DIVERGED_MAX_IT
                    && done < settings.max_iterations;
                if !restart {
                    break Ok(());
                }
                (*(context_pointer as *mut Context)).iteration_offset = done;
                let limit =
                    sys::PetscInt::try_from(chunk(settings, done)).unwrap_or(sys::PetscInt::MAX);
                check(sys::SNESSetTolerances(
                    objects.snes,
                    0.0,
                    0.0,
                    0.0,
                    limit,
                    sys::PetscInt::MAX,
                ))?;
            };
            iterations = sys::PetscInt::try_from(done).unwrap_or(sys::PetscInt::MAX);
            check(sys::VecGetArray(objects.solution, &mut data))?;
            x.copy_from_slice(std::slice::from_raw_parts(data, n));
            check(sys::VecRestoreArray(objects.solution, &mut data))?;
            result
        })()
    };
    if settings.warn_unused && !(distributed && SimpleCommunicator::world().rank() != 0) {
        options.warn_unused(&turn);
    }
    drop(objects);
    drop(layout);
    options.clear(&turn, &settings.linear.option_defaults());
    drop(turn);
    let history = std::mem::take(&mut context.history);
    if let Some(error) = context.error.take() {
        return Err(error);
    }
    solved.map_err(|e| failure("SNESSolve", e))?;
    let mut f = vec![0.0; n];
    problem.residual(&x, &mut f, Evaluation::Iterate)?;
    Ok(SnesReport {
        converged: reason == sys::SNESConvergedReason_SNES_CONVERGED_FNORM_ABS,
        iterations: usize::try_from(iterations).unwrap_or(0),
        linear_iterations: usize::try_from(linear_iterations).unwrap_or(0),
        history,
        method,
        reason: reason_name(reason),
    })
}

/// The iteration limit of the SNESSolve call that starts after `done` iterations: the rest of
/// the deck's limit, at most one restart period for nonlinear CG.
fn chunk(settings: &SnesSettings, done: u64) -> u64 {
    let rest = settings.max_iterations.saturating_sub(done);
    match settings.ncg {
        Some(ncg) => rest.min(ncg.restart_every.max(1)),
        None => rest,
    }
}

/// Sets `snes`'s method: `newtonls` with the `bt` line search (`basic` without
/// `line_search`), or SNESNCG with the `cp` line search (the step where F·d = 0 along the
/// direction d, by secant steps: for F the gradient of an energy, the exact step of linear
/// CG, which is what NOX's `NonlinearCG` line search computes from one directional
/// derivative) and, when preconditioned, its nonlinear preconditioner (see
/// [`NcgPreconditioner`]), whose SNES is returned for the caller to give it F and the
/// tangent. The options database, read later, overrides all of it.
unsafe fn set_method(
    snes: sys::SNES,
    ncg: Option<&NcgSettings>,
    line_search: bool,
) -> Result<Option<sys::SNES>, PetscError> {
    let mut search: sys::SNESLineSearch = std::ptr::null_mut();
    let Some(ncg) = ncg else {
        check(sys::SNESSetType(snes, c"newtonls".as_ptr()))?;
        check(sys::SNESGetLineSearch(snes, &mut search))?;
        let kind = if line_search { c"bt" } else { c"basic" };
        check(sys::SNESLineSearchSetType(search, kind.as_ptr()))?;
        return Ok(None);
    };
    check(sys::SNESSetType(snes, c"ncg".as_ptr()))?;
    check(sys::SNESNCGSetType(
        snes,
        match ncg.beta {
            NcgBeta::FletcherReeves => sys::SNESNCGType_SNES_NCG_FR,
            NcgBeta::PolakRibiere => sys::SNESNCGType_SNES_NCG_PRP,
        },
    ))?;
    check(sys::SNESGetLineSearch(snes, &mut search))?;
    check(sys::SNESLineSearchSetType(search, c"cp".as_ptr()))?;
    let Some(preconditioner) = &ncg.preconditioner else {
        return Ok(None);
    };
    let mut npc: sys::SNES = std::ptr::null_mut();
    check(sys::SNESGetNPC(snes, &mut npc))?;
    check(sys::SNESSetType(npc, c"newtonls".as_ptr()))?;
    let mut npc_search: sys::SNESLineSearch = std::ptr::null_mut();
    check(sys::SNESGetLineSearch(npc, &mut npc_search))?;
    check(sys::SNESLineSearchSetType(npc_search, c"basic".as_ptr()))?;
    // The Krylov solve stops at its iteration count, which PETSc calls a failure.
    check(sys::SNESSetMaxLinearSolveFailures(npc, sys::PetscInt::MAX))?;
    let lag =
        sys::PetscInt::try_from(preconditioner.jacobian_lag.max(1)).unwrap_or(sys::PetscInt::MAX);
    check(sys::SNESSetLagJacobian(npc, lag))?;
    check(sys::SNESSetLagJacobianPersists(
        npc,
        sys::PetscBool_PETSC_TRUE,
    ))?;
    let mut ksp: sys::KSP = std::ptr::null_mut();
    let mut pc: sys::PC = std::ptr::null_mut();
    let name = |text: &str| {
        CString::new(text).map_err(|_| PetscError {
            code: -1,
            message: format!("the type name {text:?} contains a NUL character"),
        })
    };
    let ksp_type = name(&preconditioner.ksp)?;
    let pc_type = name(&preconditioner.pc)?;
    check(sys::SNESGetKSP(npc, &mut ksp))?;
    check(sys::KSPSetType(ksp, ksp_type.as_ptr()))?;
    check(sys::KSPGetPC(ksp, &mut pc))?;
    check(sys::PCSetType(pc, pc_type.as_ptr()))?;
    check(sys::KSPSetTolerances(
        ksp,
        0.0,
        PETSC_DEFAULT_REAL,
        PETSC_DEFAULT_REAL,
        sys::PetscInt::try_from(preconditioner.iterations.max(1)).unwrap_or(sys::PetscInt::MAX),
    ))?;
    Ok(Some(npc))
}

/// `PETSc SNES <type> (line search <type>), KSP <type> + PC <type>` of a configured SNES;
/// for nonlinear CG `PETSc SNES ncg <β> (line search <type>), restarted every <n>
/// iterations, preconditioned by one newtonls step: KSP <type> + PC <type>, <k> iterations`.
fn describe(
    snes: sys::SNES,
    ncg: Option<&NcgSettings>,
    options: &DeckOptions,
) -> Result<String, PetscError> {
    let Some(ncg) = ncg else {
        return describe_newton(snes);
    };
    let mut snes_type: sys::SNESType = std::ptr::null();
    let mut line_search: sys::SNESLineSearch = std::ptr::null_mut();
    let mut line_search_type: sys::SNESLineSearchType = std::ptr::null();
    // SAFETY: `snes` is live; the names belong to it.
    unsafe {
        check(sys::SNESGetType(snes, &mut snes_type))?;
        check(sys::SNESGetLineSearch(snes, &mut line_search))?;
        check(sys::SNESLineSearchGetType(
            line_search,
            &mut line_search_type,
        ))?;
    }
    let snes_type = owned_string(snes_type);
    if snes_type != "ncg" {
        return describe_newton(snes);
    }
    // PETSc 3.18 has no getter of the β formula: the deck's option, else the deck's key.
    let beta = options
        .options
        .iter()
        .find(|(name, _)| name == "snes_ncg_type")
        .and_then(|(_, value)| value.clone())
        .unwrap_or_else(|| ncg.beta.name().to_string());
    let mut text = format!(
        "PETSc SNES ncg {beta} (line search {}), restarted every {} iterations",
        owned_string(line_search_type),
        ncg.restart_every
    );
    match &ncg.preconditioner {
        None => text.push_str(", unpreconditioned"),
        Some(preconditioner) => {
            let mut npc: sys::SNES = std::ptr::null_mut();
            let mut ksp: sys::KSP = std::ptr::null_mut();
            // SAFETY: `snes` is live and has its preconditioner (set by `set_method`).
            unsafe {
                check(sys::SNESGetNPC(snes, &mut npc))?;
                check(sys::SNESGetKSP(npc, &mut ksp))?;
            }
            text.push_str(&format!(
                ", preconditioned by one newtonls step: {}, {} iterations",
                resolved_types(ksp)?.trim_start_matches("PETSc "),
                preconditioner.iterations
            ));
            if preconditioner.jacobian_lag > 1 {
                text.push_str(&format!(
                    ", tangent rebuilt every {} applications",
                    preconditioner.jacobian_lag
                ));
            }
        }
    }
    Ok(text)
}

/// `PETSc SNES <type> (line search <type>), KSP <type> + PC <type>` of a configured SNES.
fn describe_newton(snes: sys::SNES) -> Result<String, PetscError> {
    let mut snes_type: sys::SNESType = std::ptr::null();
    let mut line_search: sys::SNESLineSearch = std::ptr::null_mut();
    let mut line_search_type: sys::SNESLineSearchType = std::ptr::null();
    let mut ksp: sys::KSP = std::ptr::null_mut();
    // SAFETY: `snes` is live; the names belong to it.
    unsafe {
        check(sys::SNESGetType(snes, &mut snes_type))?;
        check(sys::SNESGetLineSearch(snes, &mut line_search))?;
        check(sys::SNESLineSearchGetType(
            line_search,
            &mut line_search_type,
        ))?;
        check(sys::SNESGetKSP(snes, &mut ksp))?;
    }
    let linear = resolved_types(ksp)?;
    Ok(format!(
        "PETSc SNES {} (line search {}), {}",
        owned_string(snes_type),
        owned_string(line_search_type),
        linear.trim_start_matches("PETSc ")
    ))
}

/// Creates a SNES with the deck's settings and options without solving (what `peridyn check`
/// shows and validates): its description, or PETSc's refusal.
pub fn resolve(
    linear: &PetscSettings,
    jacobian: SnesJacobian,
    line_search: bool,
    ncg: Option<&NcgSettings>,
) -> Result<String, PetscError> {
    let turn = Turn::take()?;
    let mut snes: sys::SNES = std::ptr::null_mut();
    // SAFETY: a SNES created and destroyed here, on MPI_COMM_SELF.
    let result = unsafe {
        (|| {
            check(sys::SNESCreate(turn.comm_self(), &mut snes))?;
            let prefix = linear.options.c_prefix();
            check(sys::SNESSetOptionsPrefix(snes, prefix.as_ptr()))?;
            let npc = set_method(snes, ncg, line_search)?;
            if jacobian != SnesJacobian::Assembled {
                check(sys::SNESSetUseMatrixFree(
                    snes,
                    sys::PetscBool_PETSC_TRUE,
                    sys::PetscBool_PETSC_FALSE,
                ))?;
            }
            let mut ksp: sys::KSP = std::ptr::null_mut();
            check(sys::SNESGetKSP(snes, &mut ksp))?;
            linear.configure(&turn, ksp, 1, false)?;
            check(sys::SNESSetFromOptions(snes))?;
            if let Some(npc) = npc {
                // SNESSetUp would read the preconditioner's options; there is no setup here.
                check(sys::SNESSetFromOptions(npc))?;
            }
            describe(snes, ncg, &linear.options)
        })()
    };
    // SAFETY: created above (or null).
    unsafe { sys::SNESDestroy(&mut snes) };
    linear.options.clear(&turn, &linear.option_defaults());
    result
}
