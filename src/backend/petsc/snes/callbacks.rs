//! The C callbacks of a SNES solve and the Rust context they reach through their `void*`:
//! F, the Jacobian (or the preconditioning matrix it refills), the matrix-free probes and
//! peridyn's convergence test. A callback never unwinds into C ([`Context::guard`]).

use std::ffi::c_void;
use std::panic::{catch_unwind, AssertUnwindSafe};

use super::super::layout::DistributedMatrix;
use super::super::runtime::{check, PetscError};
use super::super::sys;
use super::{failure, SnesJacobian};
use crate::backend::problem::{Evaluation, NonlinearProblem};
use crate::backend::{Csr, SolveError};

/// The Rust side of one SNES solve, reached from the C callbacks through their `void*`.
pub(super) struct Context<'a> {
    pub(super) problem: &'a mut dyn NonlinearProblem,
    pub(super) jacobian: SnesJacobian,
    /// The preconditioning matrix's arrays (PETSc works on `values` in place).
    pub(super) values: Vec<f64>,
    /// `values[k] = source[order[k]]` (columns sorted within rows).
    pub(super) order: Vec<usize>,
    /// The pattern's row offsets and (sorted) columns, to refill the one-hop operator.
    pub(super) offsets: Vec<usize>,
    pub(super) columns: Vec<usize>,
    /// [`NonlinearProblem::preconditioning_version`] of the one-hop operator in `values`.
    pub(super) operator_version: usize,
    /// On several ranks, the `MATMPIAIJ` that `values` are copied into (PETSc cannot work on
    /// them in place there).
    pub(super) distributed: Option<DistributedMatrix>,
    pub(super) tolerance: f64,
    pub(super) max_iterations: u64,
    /// Iterations done by the earlier SNESSolve calls of a restarted nonlinear CG.
    pub(super) iteration_offset: u64,
    pub(super) history: Vec<f64>,
    pub(super) print_iterations: bool,
    /// The first error a callback met.
    pub(super) error: Option<SolveError>,
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
pub(super) unsafe extern "C" fn form_function(
    _snes: sys::SNES,
    x: sys::PetscVec,
    f: sys::PetscVec,
    context: *mut c_void,
) -> sys::PetscErrorCode {
    evaluate(context, x, f, Evaluation::Iterate)
}

/// The matrix-free operator's function: F at a finite-difference probe, damage frozen.
pub(super) unsafe extern "C" fn probe_function(
    context: *mut c_void,
    x: sys::PetscVec,
    f: sys::PetscVec,
) -> sys::PetscErrorCode {
    evaluate(context, x, f, Evaluation::Probe)
}

/// SNES's Jacobian: refills the preconditioning matrix (the tangent, or its 3×3 blocks).
pub(super) unsafe extern "C" fn form_jacobian(
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

pub(super) fn no_operator() -> SolveError {
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
pub(super) unsafe extern "C" fn converged(
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
