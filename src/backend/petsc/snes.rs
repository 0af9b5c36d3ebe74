//! SNES Newton on a [`NonlinearProblem`]: PETSc drives the iteration, peridyn answers its
//! callbacks with the problem's own residual and tangent (the one-residual rule: the same
//! [`NonlinearProblem::residual`] the native Newton and NOX call).
//!
//! * SNES `newtonls` with the `bt` (backtracking) line search, `basic` (full steps) with
//!   `Disable Heuristics`; the KSP and PC are the solver list's ([`PetscSettings`]), and the
//!   deck's `PETSc Options` (`-snes_*`, `-ksp_*`, `-pc_*`) override everything;
//! * convergence is peridyn's: the test calls [`NonlinearProblem::convergence_measure`] on F
//!   and stops at the deck's tolerance or iteration limit (PETSc's own tests are replaced);
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
//! arrives with global column ids and becomes a `MATMPIAIJ` (values copied in at each Jacobian
//! request, `MatSetValues`); the 3×3 block diagonal and the one-hop operator are built over the
//! rank's own unknowns, so on N ranks the one-hop operator drops the couplings between ranks (a
//! weaker preconditioner of the same Newton operator). Every callback is collective: PETSc calls
//! it on all ranks together, and the residual refreshes the ghosts first.
//!
//! The prescribed dofs are not unknowns of the problem (eliminated as on the other backends),
//! so the near-null space is not built with `MatNullSpaceCreateRigidBody` (which needs a
//! coordinate vector in the matrix's point-block layout) but from the problem's rigid-body
//! modes over the remaining unknowns: the same space.
//!
//! Errors: a callback never unwinds into C. It runs inside `catch_unwind`; a Rust error (a
//! non-finite residual, say) is kept in the context and the callback returns `PETSC_ERR_USER`,
//! PETSc unwinds its own stack with error codes, and [`solve`] returns the kept error itself.

use std::ffi::c_void;

use mpi::topology::{Communicator as _, SimpleCommunicator};
use std::panic::{catch_unwind, AssertUnwindSafe};

use super::layout::{sum_over_ranks, Columns, DistributedMatrix, Layout};
use super::linear::{resolved_types, set_near_null_space, PetscSettings};
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
    /// `bt` line search (otherwise `basic`).
    pub line_search: bool,
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
    context.history.push(measure);
    if context.print_iterations && iteration > 0 {
        eprintln!("  iteration {iteration}: residual = {measure:e}");
    }
    *reason = if !measure.is_finite() {
        sys::SNESConvergedReason_SNES_DIVERGED_FNORM_NAN
    } else if measure <= context.tolerance {
        sys::SNESConvergedReason_SNES_CONVERGED_FNORM_ABS
    } else if u64::try_from(iteration).unwrap_or(0) >= context.max_iterations {
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
    };
    let options = &settings.linear.options;
    // On several ranks: the assembled tangent's columns are global ids, the block diagonal's
    // and the one-hop operator's this rank's own unknowns.
    let layout = match distributed {
        true => {
            let ids = match settings.jacobian {
                SnesJacobian::Assembled => global_ids.as_deref(),
                _ => None,
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
                        SnesJacobian::Assembled => Columns::Global,
                        _ => Columns::Local,
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
            check(sys::SNESSetType(snes, c"newtonls".as_ptr()))?;
            let mut line_search: sys::SNESLineSearch = std::ptr::null_mut();
            check(sys::SNESGetLineSearch(snes, &mut line_search))?;
            let kind = if settings.line_search {
                c"bt"
            } else {
                c"basic"
            };
            check(sys::SNESLineSearchSetType(line_search, kind.as_ptr()))?;
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
            check(sys::SNESSetConvergenceTest(
                snes,
                Some(converged),
                context_pointer,
                None,
            ))?;
            let limit =
                sys::PetscInt::try_from(settings.max_iterations).unwrap_or(sys::PetscInt::MAX);
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
            check(sys::SNESSetUp(snes))?;
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
            describe(snes)
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
    // SAFETY: the vectors are live; `x` is copied in and out through the vector's array.
    let solved = unsafe {
        (|| -> Result<(), PetscError> {
            let mut data: *mut f64 = std::ptr::null_mut();
            check(sys::VecGetArray(objects.solution, &mut data))?;
            std::slice::from_raw_parts_mut(data, n).copy_from_slice(&x);
            check(sys::VecRestoreArray(objects.solution, &mut data))?;
            let result = check(sys::SNESSolve(
                objects.snes,
                std::ptr::null_mut(),
                objects.solution,
            ));
            check(sys::VecGetArray(objects.solution, &mut data))?;
            x.copy_from_slice(std::slice::from_raw_parts(data, n));
            check(sys::VecRestoreArray(objects.solution, &mut data))?;
            result?;
            check(sys::SNESGetIterationNumber(objects.snes, &mut iterations))?;
            check(sys::SNESGetLinearSolveIterations(
                objects.snes,
                &mut linear_iterations,
            ))?;
            check(sys::SNESGetConvergedReason(objects.snes, &mut reason))
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

/// `PETSc SNES <type> (line search <type>), KSP <type> + PC <type>` of a configured SNES.
fn describe(snes: sys::SNES) -> Result<String, PetscError> {
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
) -> Result<String, PetscError> {
    let turn = Turn::take()?;
    let mut snes: sys::SNES = std::ptr::null_mut();
    // SAFETY: a SNES created and destroyed here, on MPI_COMM_SELF.
    let result = unsafe {
        (|| {
            check(sys::SNESCreate(turn.comm_self(), &mut snes))?;
            let prefix = linear.options.c_prefix();
            check(sys::SNESSetOptionsPrefix(snes, prefix.as_ptr()))?;
            check(sys::SNESSetType(snes, c"newtonls".as_ptr()))?;
            let mut line: sys::SNESLineSearch = std::ptr::null_mut();
            check(sys::SNESGetLineSearch(snes, &mut line))?;
            let kind = if line_search { c"bt" } else { c"basic" };
            check(sys::SNESLineSearchSetType(line, kind.as_ptr()))?;
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
            describe(snes)
        })()
    };
    // SAFETY: created above (or null).
    unsafe { sys::SNESDestroy(&mut snes) };
    linear.options.clear(&turn, &linear.option_defaults());
    result
}
