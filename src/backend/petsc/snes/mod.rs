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

mod callbacks;
mod method;

use std::ffi::c_void;

use mpi::topology::{Communicator as _, SimpleCommunicator};

use super::layout::{sum_over_ranks, Columns, DistributedMatrix, Layout};
use super::linear::{set_near_null_space, PetscSettings};
use super::runtime::{check, PetscError, Turn};
use super::sys;
use crate::backend::problem::{Evaluation, NonlinearProblem};
use crate::backend::{block_diagonal_csr, Csr, SolveError};
use callbacks::{converged, form_function, form_jacobian, no_operator, probe_function, Context};
use method::{describe, reason_name, set_method};

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

/// The PETSc objects of one solve.
struct Objects {
    snes: sys::SNES,
    matrix: sys::Mat,
    solution: sys::PetscVec,
    residual: sys::PetscVec,
    /// F of nonlinear CG's preconditioner (null without one).
    npc_residual: sys::PetscVec,
}

impl Objects {
    /// No object yet.
    fn empty() -> Self {
        Self {
            snes: std::ptr::null_mut(),
            matrix: std::ptr::null_mut(),
            solution: std::ptr::null_mut(),
            residual: std::ptr::null_mut(),
            npc_residual: std::ptr::null_mut(),
        }
    }
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
    let (pattern, near_null_space) = preconditioning_matrix(problem, settings.jacobian, &x)?;
    // Block size 3 (GAMG aggregates whole points) when every point kept its three unknowns.
    let mut whole_points = problem.groups().windows(2).all(|g| g[1] - g[0] == 3);
    if distributed {
        whole_points = sum_over_ranks(f64::from(u8::from(!whole_points))) == 0.0;
    }
    let mut arrays = SortedPattern::of(&pattern)?;
    let mut context = Context {
        problem: &mut *problem,
        jacobian: settings.jacobian,
        values: arrays.order.iter().map(|&k| pattern.values[k]).collect(),
        offsets: pattern.offsets.clone(),
        columns: arrays.order.iter().map(|&k| pattern.columns[k]).collect(),
        order: std::mem::take(&mut arrays.order),
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
    let mut objects = Objects::empty();
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
    let snes_setup = SnesSetup {
        turn: &turn,
        layout: layout.as_ref(),
        settings,
        near_null_space: near_null_space.as_ref(),
        whole_points,
        rows: n,
        columns: pattern.ncols,
    };
    // SAFETY: every object is created on the run's communicator (MPI_COMM_SELF on one process)
    // and destroyed by `objects`' Drop; on one process the matrix works on `arrays` and
    // `context.values`, which outlive it; the callbacks get `context`, which outlives
    // SNESSolve.
    let setup = unsafe {
        snes_setup
            .create_matrix(&mut objects, &mut arrays, context_pointer)
            .and_then(|()| snes_setup.configure(&mut objects, context_pointer))
    };
    let method = match setup {
        Ok(method) => method,
        Err(e) => {
            drop(objects);
            options.clear(&turn, &settings.linear.option_defaults());
            return Err(failure("setting up SNES", e));
        }
    };
    // SAFETY: the objects are live; `context` is reached only through the callbacks while
    // SNESSolve runs.
    let solved = unsafe { run_solves(&objects, context_pointer, settings, &mut x) };
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
    let counts = solved.map_err(|e| failure("SNESSolve", e))?;
    let mut f = vec![0.0; n];
    problem.residual(&x, &mut f, Evaluation::Iterate)?;
    Ok(SnesReport {
        converged: counts.reason == sys::SNESConvergedReason_SNES_CONVERGED_FNORM_ABS,
        iterations: usize::try_from(counts.iterations).unwrap_or(0),
        linear_iterations: usize::try_from(counts.linear_iterations).unwrap_or(0),
        history,
        method,
        reason: reason_name(counts.reason),
    })
}

/// The matrix the preconditioner is built from, at the unknowns `x`: the tangent, its 3×3
/// block diagonal, or the one-hop operator with its near-null space (vectors, count).
fn preconditioning_matrix(
    problem: &mut dyn NonlinearProblem,
    jacobian: SnesJacobian,
    x: &[f64],
) -> Result<(Csr, Option<NullSpace>), SolveError> {
    Ok(match jacobian {
        SnesJacobian::Assembled => (problem.jacobian(x)?, None),
        SnesJacobian::MatrixFree => {
            let groups = problem.groups().to_vec();
            let entries = groups.windows(2).map(|g| (g[1] - g[0]).pow(2)).sum();
            (block_diagonal_csr(&groups, &vec![0.0; entries]), None)
        }
        SnesJacobian::MatrixFreeMultigrid => {
            let operator = problem
                .preconditioning_operator()?
                .ok_or_else(no_operator)?;
            (operator.matrix, Some((operator.null_space, operator.modes)))
        }
    })
}

/// A near-null space: its vectors, row-major over the unknowns, and their count.
type NullSpace = (Vec<f64>, usize);

/// A pattern's arrays as PETSc takes them: columns sorted within each row.
struct SortedPattern {
    /// `sorted[k] = pattern[order[k]]`.
    order: Vec<usize>,
    offsets: Vec<sys::PetscInt>,
    columns: Vec<sys::PetscInt>,
    rows: sys::PetscInt,
}

impl SortedPattern {
    fn of(pattern: &Csr) -> Result<Self, SolveError> {
        let n = pattern.nrows;
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
        let offsets = pattern
            .offsets
            .iter()
            .map(|&o| index(o))
            .collect::<Result<_, _>>()?;
        let columns = order
            .iter()
            .map(|&k| index(pattern.columns[k]))
            .collect::<Result<_, _>>()?;
        Ok(Self {
            order,
            offsets,
            columns,
            rows: index(n)?,
        })
    }
}

/// What setting up one solve's PETSc objects reads.
struct SnesSetup<'a> {
    turn: &'a Turn,
    layout: Option<&'a Layout>,
    settings: &'a SnesSettings<'a>,
    /// The one-hop operator's near-null space (vectors, count).
    near_null_space: Option<&'a NullSpace>,
    /// Every point of every rank kept its three unknowns.
    whole_points: bool,
    /// This process's unknowns.
    rows: usize,
    /// Columns of the preconditioning matrix.
    columns: usize,
}

impl SnesSetup<'_> {
    /// The run's communicator: `MPI_COMM_WORLD` on several ranks, else `MPI_COMM_SELF`.
    fn comm(&self) -> sys::MPI_Comm {
        match self.layout {
            Some(_) => self.turn.comm_world(),
            None => self.turn.comm_self(),
        }
    }

    /// The preconditioning matrix (over `arrays` and the context's values on one process, a
    /// `MATMPIAIJ` on several ranks), the solution and residual vectors, and the near-null
    /// space.
    ///
    /// # Safety
    /// `context` is the solve's live `Context`; `arrays` outlive `objects`.
    unsafe fn create_matrix(
        &self,
        objects: &mut Objects,
        arrays: &mut SortedPattern,
        context: *mut c_void,
    ) -> Result<(), PetscError> {
        let context = &mut *(context as *mut Context);
        let n = self.rows;
        match self.layout {
            Some(layout) => {
                let sorted = Csr {
                    nrows: n,
                    ncols: self.columns,
                    offsets: context.offsets.clone(),
                    columns: context.columns.clone(),
                    values: context.values.clone(),
                };
                let numbering = match self.settings.jacobian {
                    SnesJacobian::Assembled | SnesJacobian::MatrixFreeMultigrid => Columns::Global,
                    SnesJacobian::MatrixFree => Columns::Local,
                };
                let matrix = DistributedMatrix::new(self.turn, layout, &sorted, numbering)?;
                objects.matrix = matrix.matrix;
                context.distributed = Some(matrix);
                objects.solution = layout.vector(self.turn)?;
                objects.residual = layout.vector(self.turn)?;
            }
            None => {
                let comm = self.comm();
                check(sys::MatCreateSeqAIJWithArrays(
                    comm,
                    arrays.rows,
                    arrays.rows,
                    arrays.offsets.as_mut_ptr(),
                    arrays.columns.as_mut_ptr(),
                    context.values.as_mut_ptr(),
                    &mut objects.matrix,
                ))?;
                check(sys::VecCreateSeq(comm, arrays.rows, &mut objects.solution))?;
                check(sys::VecCreateSeq(comm, arrays.rows, &mut objects.residual))?;
            }
        }
        if let Some((modes, count)) = self.near_null_space {
            if self.whole_points {
                check(sys::MatSetBlockSize(objects.matrix, 3))?;
            }
            set_near_null_space(self.turn, objects.matrix, modes, *count, n, self.layout)?;
        }
        Ok(())
    }

    /// The SNES: its method, F and the Jacobian (the preconditioner's too for a
    /// preconditioned nonlinear CG), peridyn's convergence test and iteration limit, the
    /// matrix-free operator, the KSP and PC, then the options database; returns its
    /// description.
    ///
    /// # Safety
    /// `context` is the solve's live `Context`, `objects` hold the matrix and vectors.
    unsafe fn configure(
        &self,
        objects: &mut Objects,
        context: *mut c_void,
    ) -> Result<String, PetscError> {
        let settings = self.settings;
        check(sys::SNESCreate(self.comm(), &mut objects.snes))?;
        let snes = objects.snes;
        let prefix = settings.linear.options.c_prefix();
        check(sys::SNESSetOptionsPrefix(snes, prefix.as_ptr()))?;
        let npc = set_method(snes, settings.ncg, settings.line_search)?;
        set_callbacks(snes, objects.residual, objects.matrix, context)?;
        if let Some(npc) = npc {
            // The preconditioner's Newton step needs F and the tangent: the same callbacks on
            // the same matrix, F into a vector of its own.
            check(sys::VecDuplicate(
                objects.residual,
                &mut objects.npc_residual,
            ))?;
            set_callbacks(npc, objects.npc_residual, objects.matrix, context)?;
        }
        check(sys::SNESSetConvergenceTest(
            snes,
            Some(converged),
            context,
            None,
        ))?;
        set_iteration_limit(snes, chunk(settings, 0))?;
        // A Krylov solve stopped at its limit still gives a direction; the line search and
        // the convergence test judge the step (as peridyn's inexact Newton does).
        check(sys::SNESSetMaxLinearSolveFailures(snes, sys::PetscInt::MAX))?;
        let unknowns = self.layout.map_or(self.rows, Layout::global);
        configure_linear(
            self.turn,
            snes,
            settings.linear,
            settings.jacobian,
            unknowns,
        )?;
        match npc {
            // SNESNCG's setup needs the solution vector, which only SNESSolve hands over;
            // the preconditioner reads its options there too, and here for `describe`.
            Some(npc) => check(sys::SNESSetFromOptions(npc))?,
            None if settings.ncg.is_some() => {}
            None => check(sys::SNESSetUp(snes))?,
        }
        if settings.jacobian != SnesJacobian::Assembled {
            probe_with_residual(snes, objects.matrix, context)?;
        }
        describe(snes, settings.ncg, &settings.linear.options)
    }
}

/// The Newton operator of `snes` (Jacobian-free unless `jacobian` assembles it), its KSP and
/// PC from `linear` for `unknowns` unknowns, then the options database over all of it.
///
/// # Safety
/// `snes` is live.
unsafe fn configure_linear(
    turn: &Turn,
    snes: sys::SNES,
    linear: &PetscSettings,
    jacobian: SnesJacobian,
    unknowns: usize,
) -> Result<(), PetscError> {
    if jacobian != SnesJacobian::Assembled {
        check(sys::SNESSetUseMatrixFree(
            snes,
            sys::PetscBool_PETSC_TRUE,
            sys::PetscBool_PETSC_FALSE,
        ))?;
    }
    let mut ksp: sys::KSP = std::ptr::null_mut();
    check(sys::SNESGetKSP(snes, &mut ksp))?;
    linear.configure(turn, ksp, unknowns, false)?;
    check(sys::SNESSetFromOptions(snes))
}

/// Gives `snes` the function F (into `residual`) and the Jacobian callback on `matrix`.
///
/// # Safety
/// The objects are live; `context` is the solve's live `Context`.
unsafe fn set_callbacks(
    snes: sys::SNES,
    residual: sys::PetscVec,
    matrix: sys::Mat,
    context: *mut c_void,
) -> Result<(), PetscError> {
    check(sys::SNESSetFunction(
        snes,
        residual,
        Some(form_function),
        context,
    ))?;
    check(sys::SNESSetJacobian(
        snes,
        matrix,
        matrix,
        Some(form_jacobian),
        context,
    ))
}

/// Sets the iteration limit of the next SNESSolve call (no other PETSc test).
///
/// # Safety
/// `snes` is live.
unsafe fn set_iteration_limit(snes: sys::SNES, limit: u64) -> Result<(), PetscError> {
    let limit = sys::PetscInt::try_from(limit).unwrap_or(sys::PetscInt::MAX);
    check(sys::SNESSetTolerances(
        snes,
        0.0,
        0.0,
        0.0,
        limit,
        sys::PetscInt::MAX,
    ))
}

/// The matrix-free operator's probes call F with damage frozen ([`Evaluation::Probe`]).
///
/// # Safety
/// `snes` is set up; `context` is the solve's live `Context`.
unsafe fn probe_with_residual(
    snes: sys::SNES,
    matrix: sys::Mat,
    context: *mut c_void,
) -> Result<(), PetscError> {
    let mut operator: sys::Mat = std::ptr::null_mut();
    check(sys::SNESGetJacobian(
        snes,
        &mut operator,
        std::ptr::null_mut(),
        std::ptr::null_mut(),
        std::ptr::null_mut(),
    ))?;
    if operator != matrix {
        check(sys::MatMFFDSetFunction(
            operator,
            Some(probe_function),
            context,
        ))?;
    }
    Ok(())
}

/// What the SNESSolve calls of one solve did.
struct SolveCounts {
    iterations: sys::PetscInt,
    linear_iterations: sys::PetscInt,
    reason: sys::SNESConvergedReason,
}

/// Solves from `x` and leaves the last iterate in `x`: Newton in one SNESSolve call, a
/// restarted nonlinear CG in calls of at most `restart_every` iterations, each restarting
/// from the residual direction.
///
/// # Safety
/// The objects are set up; `context` is the solve's live `Context`.
unsafe fn run_solves(
    objects: &Objects,
    context: *mut c_void,
    settings: &SnesSettings,
    x: &mut [f64],
) -> Result<SolveCounts, PetscError> {
    let n = x.len();
    let mut data: *mut f64 = std::ptr::null_mut();
    check(sys::VecGetArray(objects.solution, &mut data))?;
    std::slice::from_raw_parts_mut(data, n).copy_from_slice(x);
    check(sys::VecRestoreArray(objects.solution, &mut data))?;
    let mut counts = SolveCounts {
        iterations: 0,
        linear_iterations: 0,
        reason: 0,
    };
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
        check(sys::SNESGetConvergedReason(
            objects.snes,
            &mut counts.reason,
        ))?;
        done += u64::try_from(chunk_iterations).unwrap_or(0);
        counts.linear_iterations += chunk_linear;
        let restart = settings.ncg.is_some()
            && counts.reason == sys::SNESConvergedReason_SNES_DIVERGED_MAX_IT
            && done < settings.max_iterations;
        if !restart {
            break Ok(());
        }
        (*(context as *mut Context)).iteration_offset = done;
        set_iteration_limit(objects.snes, chunk(settings, done))?;
    };
    counts.iterations = sys::PetscInt::try_from(done).unwrap_or(sys::PetscInt::MAX);
    check(sys::VecGetArray(objects.solution, &mut data))?;
    x.copy_from_slice(std::slice::from_raw_parts(data, n));
    check(sys::VecRestoreArray(objects.solution, &mut data))?;
    result.map(|()| counts)
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
            configure_linear(&turn, snes, linear, jacobian, 1)?;
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
