//! KSP solves of a system distributed over the MPI ranks: each rank hands over the rows of its
//! unknowns (global ids, the tangent's columns global ids too), which become one `MATMPIAIJ`
//! on `MPI_COMM_WORLD` in PETSc's numbering ([`Layout`]); the right-hand side and solution are
//! `VECMPI`s over the caller's arrays (`VecPlaceArray`, nothing copied).
//!
//! As on one process, the objects are kept while the pattern stays (values refilled, the PC's
//! symbolic setup kept) and rebuilt when it changes; the near-null space (GAMG) is
//! orthonormalised with inner products over all ranks. The KSP and PC are the deck's, but a
//! preconditioner works on the rank's rows: `bjacobi` takes one ILU block per rank (`PCILU`
//! itself does not run on `MATMPIAIJ`), `jacobi`, GAMG, hypre and MUMPS run across ranks, so
//! iteration counts depend on the rank count while the answer agrees to the Krylov tolerance.
//!
//! Every decision that leads to a collective call (a bad input, a zero right-hand side, a new
//! pattern) is agreed over the ranks first, so that no rank waits in a collective another one
//! skipped: the rank that found the problem reports it, the others return
//! [`SolveError::OtherRank`]. The relative residual reported is the true one, ‖b − Ax‖/‖b‖
//! over all ranks (`MatMult` and `VecNorm`).

use mpi::topology::{Communicator as _, SimpleCommunicator};

use super::super::layout::{sum_over_ranks, Columns, DistributedMatrix, Layout};
use super::super::runtime::{check, PetscError, Turn};
use super::super::sys;
use super::{indefinite, petsc_failure, set_near_null_space, KspMethod, PetscLinearSolver};
use crate::backend::{Csr, KrylovReport, LinearResult, RankRows, SolveError};

/// The PETSc objects of one distributed sparsity pattern.
pub(in crate::backend::petsc) struct DistributedSystem {
    ksp: sys::KSP,
    rhs: sys::PetscVec,
    solution: sys::PetscVec,
    /// b − Ax after the solve.
    work: sys::PetscVec,
    matrix: DistributedMatrix,
    layout: Layout,
    /// The pattern it was built for (to detect a new one).
    rows: Vec<usize>,
    offsets: Vec<usize>,
    columns: Vec<usize>,
}

impl DistributedSystem {
    fn same_pattern(&self, rows: &[usize], matrix: &Csr) -> bool {
        self.rows == rows && self.offsets == matrix.offsets && self.columns == matrix.columns
    }
}

impl Drop for DistributedSystem {
    /// Destroys the PETSc objects (the caller holds the turn); the layout follows as a field.
    fn drop(&mut self) {
        if !super::super::runtime::alive() {
            return;
        }
        // SAFETY: null or live objects created by `build`; Destroy nulls the handles.
        unsafe {
            sys::KSPDestroy(&mut self.ksp);
            sys::VecDestroy(&mut self.rhs);
            sys::VecDestroy(&mut self.solution);
            sys::VecDestroy(&mut self.work);
            sys::MatDestroy(&mut self.matrix.matrix);
        }
    }
}

/// True on any rank when `local` holds on this one (collective).
fn on_any_rank(local: bool) -> bool {
    sum_over_ranks(f64::from(u8::from(local))) > 0.0
}

fn is_rank_zero() -> bool {
    SimpleCommunicator::world().rank() == 0
}

impl PetscLinearSolver {
    /// [`crate::backend::LinearSolver::solve_distributed`] (see the module docs).
    pub(super) fn solve_on_ranks(
        &mut self,
        RankRows { rows, matrix }: RankRows,
        rhs: &[f64],
        x: &mut [f64],
    ) -> LinearResult {
        let n = rows.len();
        let turn = Turn::take().map_err(|e| petsc_failure("starting PETSc", e))?;
        let mut local_error = None;
        if matrix.nrows != n || rhs.len() != n || x.len() != n {
            local_error = Some(SolveError::Breakdown {
                method: "PETSc KSP",
                reason: format!(
                    "{n} rows owned, a matrix of {} rows, right-hand side {}, solution {}",
                    matrix.nrows,
                    rhs.len(),
                    x.len()
                ),
            });
        }
        if local_error.is_none() {
            local_error = self.non_finite(matrix, rhs, x);
        }
        if on_any_rank(local_error.is_some()) {
            return Err(local_error.unwrap_or(SolveError::OtherRank));
        }
        let rhs_norm = sum_over_ranks(rhs.iter().map(|b| b * b).sum()).sqrt();
        if rhs_norm == 0.0 {
            x.fill(0.0);
            return Ok(KrylovReport {
                method: self.method_name(),
                iterations: 0,
                relative_residual: 0.0,
            });
        }
        let same = self
            .distributed
            .as_ref()
            .is_some_and(|s| s.same_pattern(rows, matrix));
        if on_any_rank(!same) {
            self.distributed = None;
            let system = self.build_distributed(&turn, rows, matrix);
            // PETSc's errors in collective calls are raised on every rank alike.
            let system = system.map_err(|e| petsc_failure("building the matrix and KSP", e))?;
            self.distributed = Some(system);
        }
        let system = self.distributed.as_ref().expect("built above");
        system
            .matrix
            .set_values(&matrix.values)
            .map_err(|e| petsc_failure("filling the matrix", e))?;
        let guess = x.to_vec();
        let (mut reason, mut iterations, mut residual) =
            run(system, rhs, x).map_err(|e| petsc_failure("KSPSolve", e))?;
        // The converged reason follows from global inner products: every rank switches alike.
        if indefinite(reason) && self.settings.method == KspMethod::Cg {
            self.switch_to_gmres(system.ksp, reason, is_rank_zero())?;
            let system = self.distributed.as_ref().expect("built above");
            x.copy_from_slice(&guess);
            (reason, iterations, residual) =
                run(system, rhs, x).map_err(|e| petsc_failure("KSPSolve", e))?;
        }
        if !self.unused_reported {
            self.unused_reported = true;
            if is_rank_zero() {
                self.settings.options.warn_unused(&turn);
            }
        }
        drop(turn);
        self.outcome((reason, iterations), residual / rhs_norm)
    }

    /// Builds the distributed objects for this pattern (collective).
    fn build_distributed(
        &mut self,
        turn: &Turn,
        rows: &[usize],
        matrix: &Csr,
    ) -> Result<DistributedSystem, PetscError> {
        let layout = Layout::new(turn, rows.len(), Some(rows))?;
        let petsc_matrix = DistributedMatrix::new(turn, &layout, matrix, Columns::Global)?;
        let mut system = DistributedSystem {
            ksp: std::ptr::null_mut(),
            rhs: std::ptr::null_mut(),
            solution: std::ptr::null_mut(),
            work: std::ptr::null_mut(),
            matrix: petsc_matrix,
            layout,
            rows: rows.to_vec(),
            offsets: matrix.offsets.clone(),
            columns: matrix.columns.clone(),
        };
        if let Some((modes, count)) = &self.near_null_space {
            set_near_null_space(
                turn,
                system.matrix.matrix,
                modes,
                *count,
                rows.len(),
                Some(&system.layout),
            )?;
        }
        system.rhs = system.layout.vector_without_array(turn)?;
        system.solution = system.layout.vector_without_array(turn)?;
        system.work = system.layout.vector(turn)?;
        // SAFETY: a KSP on the world communicator, destroyed with `system`.
        unsafe {
            check(sys::KSPCreate(turn.comm_world(), &mut system.ksp))?;
            check(sys::KSPSetOperators(
                system.ksp,
                system.matrix.matrix,
                system.matrix.matrix,
            ))?;
        }
        let resolved = self
            .settings
            .configure(turn, system.ksp, system.layout.global(), true)?;
        self.resolved = Some(resolved);
        Ok(system)
    }
}

/// KSPSolve on `system` with its refilled values (collective); returns the converged reason,
/// the iterations and ‖b − Ax‖ over all ranks.
fn run(
    system: &DistributedSystem,
    rhs: &[f64],
    x: &mut [f64],
) -> Result<(sys::KSPConvergedReason, usize, f64), PetscError> {
    let matrix = system.matrix.matrix;
    let mut reason: sys::KSPConvergedReason = 0;
    let mut iterations: sys::PetscInt = 0;
    let mut residual = f64::NAN;
    // SAFETY: the vectors point at `rhs` and `x` only between Place and Reset, which both
    // outlive the solve; every object is `system`'s.
    unsafe {
        check(sys::MatAssemblyBegin(
            matrix,
            sys::MatAssemblyType_MAT_FINAL_ASSEMBLY,
        ))?;
        check(sys::MatAssemblyEnd(
            matrix,
            sys::MatAssemblyType_MAT_FINAL_ASSEMBLY,
        ))?;
        check(sys::KSPSetOperators(system.ksp, matrix, matrix))?;
        check(sys::VecPlaceArray(system.rhs, rhs.as_ptr()))?;
        check(sys::VecPlaceArray(system.solution, x.as_mut_ptr()))?;
        let solved = check(sys::KSPSolve(system.ksp, system.rhs, system.solution))
            .and_then(|()| check(sys::MatMult(matrix, system.solution, system.work)))
            .and_then(|()| check(sys::VecAYPX(system.work, -1.0, system.rhs)))
            .and_then(|()| {
                check(sys::VecNorm(
                    system.work,
                    sys::NormType_NORM_2,
                    &mut residual,
                ))
            });
        check(sys::VecResetArray(system.rhs))?;
        check(sys::VecResetArray(system.solution))?;
        solved?;
        check(sys::KSPGetConvergedReason(system.ksp, &mut reason))?;
        check(sys::KSPGetIterationNumber(system.ksp, &mut iterations))?;
    }
    Ok((reason, usize::try_from(iterations).unwrap_or(0), residual))
}
