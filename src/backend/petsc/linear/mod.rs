//! KSP linear solves of our assembled [`Csr`] matrices behind the [`LinearSolver`] seam.
//!
//! The first solve builds a `MATSEQAIJ` matrix over arrays peridyn owns
//! (`MatCreateSeqAIJWithArrays`: PETSc works on them in place), the KSP with its PC, and two
//! vectors without storage that [`LinearSolver::solve`] points at the caller's right-hand side
//! and solution (`VecPlaceArray`): nothing is copied but the matrix values. Later solves on the
//! same pattern (every Newton iteration of a run) only refill the values, so PETSc keeps its
//! objects, the preconditioner's symbolic setup (ILU's pattern, MUMPS' analysis) included; a
//! new pattern (unknowns held, bonds broken) rebuilds them.
//!
//! | deck (`Linear Solver`, `Linear Solver Preconditioner`) | KSP | PC |
//! |---|---|---|
//! | `CG`, `Automatic` | `cg` | `none`, `jacobi`, `bjacobi` (ILU(k) blocks), `gamg`, `hypre` |
//! | `GMRES` | `gmres` (restart 500, as the native GMRES) | as above |
//! | `Direct`, `LU` | `preonly` | `lu` by MUMPS |
//! | `Cholesky` | `preonly` | `cholesky` by MUMPS |
//!
//! GAMG gets the rigid-body modes of the unknowns as its near-null space when the caller
//! supplies them ([`LinearSolver::set_near_null_space`]; peridyn's Newton does), orthonormalised
//! here. The deck's `PETSc Options` override all of the above ([`super::options`]). As on the
//! Trilinos backend, CG that finds the operator indefinite hands over to GMRES for good.
//!
//! On several MPI ranks ([`LinearSolver::solve_distributed`]) the same KSP and PC run on
//! `MPI_COMM_WORLD` over a `MATMPIAIJ` of every rank's rows ([`distributed`]).

mod distributed;

use super::layout::{sum_over_ranks, Layout};
use super::options::DeckOptions;
use super::runtime::{check, owned_string, PetscError, Turn};
use super::sys;
use crate::backend::native::KrylovSettings;
use crate::backend::settings::PetscPreconditioner;
use crate::backend::{Csr, KrylovReport, LinearResult, LinearSolver, RankRows, SolveError};

/// The KSP method.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum KspMethod {
    /// `KSPCG`: the stiffness is symmetric.
    Cg,
    /// `KSPGMRES` with the Krylov settings' restart.
    Gmres,
    /// `KSPPREONLY` + MUMPS LU.
    Lu,
    /// `KSPPREONLY` + MUMPS Cholesky (symmetric positive definite matrices).
    Cholesky,
}

/// Everything a [`PetscLinearSolver`] needs.
#[derive(Debug, Clone, PartialEq)]
pub struct PetscSettings {
    /// KSP method.
    pub method: KspMethod,
    /// PC of the Krylov methods (direct methods ignore it).
    pub preconditioner: PetscPreconditioner,
    /// Levels of fill of the ILU blocks (default 0).
    pub ilu_fill_level: u32,
    /// Tolerance, iteration limit, GMRES restart.
    pub krylov: KrylovSettings,
    /// The solver list's `PETSc Options` and prefix.
    pub options: DeckOptions,
}

impl PetscSettings {
    /// KSP and PC type names from the deck's keys (before the options database).
    fn type_names(&self) -> (&'static std::ffi::CStr, &'static std::ffi::CStr) {
        let pc = match self.method {
            KspMethod::Lu => c"lu",
            KspMethod::Cholesky => c"cholesky",
            KspMethod::Cg | KspMethod::Gmres => match self.preconditioner {
                PetscPreconditioner::None => c"none",
                PetscPreconditioner::Jacobi => c"jacobi",
                PetscPreconditioner::Ilu => c"bjacobi",
                PetscPreconditioner::Gamg => c"gamg",
                PetscPreconditioner::Hypre => c"hypre",
            },
        };
        let ksp = match self.method {
            KspMethod::Cg => c"cg",
            KspMethod::Gmres => c"gmres",
            KspMethod::Lu | KspMethod::Cholesky => c"preonly",
        };
        (ksp, pc)
    }

    /// The settings only the options database carries: ILU's fill in the blocks.
    pub(super) fn option_defaults(&self) -> Vec<(&'static str, String)> {
        match (self.method, self.preconditioner) {
            (KspMethod::Cg | KspMethod::Gmres, PetscPreconditioner::Ilu)
                if self.ilu_fill_level > 0 =>
            {
                vec![("sub_pc_factor_levels", self.ilu_fill_level.to_string())]
            }
            _ => Vec::new(),
        }
    }

    /// Sets the KSP's types, tolerances and options (deck options last); returns the
    /// resolved `KSP type + PC type`. `unknowns` sets the default iteration limit;
    /// `nonzero_guess` starts Krylov methods from the vector's contents (never `preonly`,
    /// which PETSc refuses with a guess). CG stops on the true residual ‖b − Ax‖/‖b‖, as the
    /// native and Trilinos backends do (PETSc's default is the preconditioned one), unless the
    /// deck sets `-ksp_norm_type`.
    pub(super) fn configure(
        &self,
        turn: &Turn,
        ksp: sys::KSP,
        unknowns: usize,
        nonzero_guess: bool,
    ) -> Result<String, PetscError> {
        let (ksp_type, pc_type) = self.type_names();
        let krylov = &self.krylov;
        let limit = krylov.max_iterations.unwrap_or(unknowns).max(1);
        let prefix = self.options.c_prefix();
        self.options.insert(turn, &self.option_defaults())?;
        let mut pc: sys::PC = std::ptr::null_mut();
        // SAFETY: `ksp` is a live KSP; strings are NUL-terminated and outlive the calls.
        unsafe {
            check(sys::KSPSetOptionsPrefix(ksp, prefix.as_ptr()))?;
            check(sys::KSPSetType(ksp, ksp_type.as_ptr()))?;
            check(sys::KSPGetPC(ksp, &mut pc))?;
            check(sys::PCSetType(pc, pc_type.as_ptr()))?;
            if matches!(self.method, KspMethod::Lu | KspMethod::Cholesky) {
                check(sys::PCFactorSetMatSolverType(pc, c"mumps".as_ptr()))?;
            }
            check(sys::KSPSetTolerances(
                ksp,
                krylov.relative_tolerance,
                PETSC_DEFAULT_REAL,
                PETSC_DEFAULT_REAL,
                sys::PetscInt::try_from(limit).unwrap_or(sys::PetscInt::MAX),
            ))?;
            if self.method == KspMethod::Gmres {
                check(sys::KSPGMRESSetRestart(
                    ksp,
                    sys::PetscInt::try_from(krylov.restart.clamp(1, limit)).unwrap_or(30),
                ))?;
            }
            check(sys::KSPSetFromOptions(ksp))?;
            let mut resolved: sys::KSPType = std::ptr::null();
            check(sys::KSPGetType(ksp, &mut resolved))?;
            let resolved = owned_string(resolved);
            let guess = nonzero_guess && resolved != "preonly";
            check(sys::KSPSetInitialGuessNonzero(
                ksp,
                if guess {
                    sys::PetscBool_PETSC_TRUE
                } else {
                    sys::PetscBool_PETSC_FALSE
                },
            ))?;
            if resolved == "cg" && !self.options.gives("ksp_norm_type") {
                check(sys::KSPSetNormType(
                    ksp,
                    sys::KSPNormType_KSP_NORM_UNPRECONDITIONED,
                ))?;
            }
        }
        resolved_types(ksp)
    }
}

/// A [`LinearSolver`] on PETSc's KSP (see the module docs).
pub struct PetscLinearSolver {
    settings: PetscSettings,
    system: Option<System>,
    /// The objects of a system distributed over the ranks.
    distributed: Option<distributed::DistributedSystem>,
    /// Row-major unknowns × modes, and the number of modes.
    near_null_space: Option<(Vec<f64>, usize)>,
    /// `KSP type + PC type` after the options were applied.
    resolved: Option<String>,
    unused_reported: bool,
}

/// The PETSc objects of one sparsity pattern, and the arrays the matrix lives in.
struct System {
    ksp: sys::KSP,
    matrix: sys::Mat,
    rhs: sys::PetscVec,
    solution: sys::PetscVec,
    /// The pattern it was built for (to detect a new one).
    offsets: Vec<usize>,
    columns: Vec<usize>,
    /// PETSc's copies: row offsets, columns sorted within each row, values in that order.
    petsc_offsets: Vec<sys::PetscInt>,
    petsc_columns: Vec<sys::PetscInt>,
    petsc_values: Vec<f64>,
    /// `petsc_values[k] = matrix.values[order[k]]`.
    order: Vec<usize>,
}

fn petsc_failure(stage: &str, e: PetscError) -> SolveError {
    SolveError::Breakdown {
        method: "PETSc KSP",
        reason: format!("{stage}: {e}"),
    }
}

impl PetscLinearSolver {
    /// A solver with these settings; nothing is allocated until the first solve.
    pub fn new(settings: PetscSettings) -> Self {
        Self {
            settings,
            system: None,
            distributed: None,
            near_null_space: None,
            resolved: None,
            unused_reported: false,
        }
    }

    /// The settings.
    pub fn settings(&self) -> &PetscSettings {
        &self.settings
    }

    /// Builds the PETSc objects for `matrix`'s pattern.
    fn build(&self, turn: &Turn, matrix: &Csr) -> Result<System, PetscError> {
        let n = matrix.nrows;
        let too_big = || PetscError {
            code: -1,
            message: format!(
                "{n} rows and {} entries exceed PETSc's {}-bit indices",
                matrix.nnz(),
                8 * std::mem::size_of::<sys::PetscInt>()
            ),
        };
        let mut order = Vec::with_capacity(matrix.nnz());
        for r in 0..n {
            let mut row: Vec<usize> = (matrix.offsets[r]..matrix.offsets[r + 1]).collect();
            row.sort_by_key(|&k| matrix.columns[k]);
            order.extend(row);
        }
        let narrow =
            |v: &mut dyn Iterator<Item = usize>| -> Result<Vec<sys::PetscInt>, PetscError> {
                v.map(|i| sys::PetscInt::try_from(i).map_err(|_| too_big()))
                    .collect()
            };
        let mut system = System {
            ksp: std::ptr::null_mut(),
            matrix: std::ptr::null_mut(),
            rhs: std::ptr::null_mut(),
            solution: std::ptr::null_mut(),
            offsets: matrix.offsets.clone(),
            columns: matrix.columns.clone(),
            petsc_offsets: narrow(&mut matrix.offsets.iter().copied())?,
            petsc_columns: narrow(&mut order.iter().map(|&k| matrix.columns[k]))?,
            petsc_values: order.iter().map(|&k| matrix.values[k]).collect(),
            order,
        };
        let rows = sys::PetscInt::try_from(n).map_err(|_| too_big())?;
        let comm = turn.comm_self();
        // SAFETY: the arrays live in `system` as long as the matrix (they are never resized);
        // the objects are created on MPI_COMM_SELF while PETSc runs. On failure the partly
        // built system is destroyed.
        let built = unsafe {
            (|| {
                check(sys::MatCreateSeqAIJWithArrays(
                    comm,
                    rows,
                    rows,
                    system.petsc_offsets.as_mut_ptr(),
                    system.petsc_columns.as_mut_ptr(),
                    system.petsc_values.as_mut_ptr(),
                    &mut system.matrix,
                ))?;
                if let Some((modes, count)) = &self.near_null_space {
                    set_near_null_space(turn, system.matrix, modes, *count, n, None)?;
                }
                check(sys::VecCreateSeqWithArray(
                    comm,
                    1,
                    rows,
                    std::ptr::null(),
                    &mut system.rhs,
                ))?;
                check(sys::VecCreateSeqWithArray(
                    comm,
                    1,
                    rows,
                    std::ptr::null(),
                    &mut system.solution,
                ))?;
                check(sys::KSPCreate(comm, &mut system.ksp))?;
                check(sys::KSPSetOperators(
                    system.ksp,
                    system.matrix,
                    system.matrix,
                ))?;
                Ok(())
            })()
        };
        if let Err(e) = built {
            system.destroy();
            return Err(e);
        }
        Ok(system)
    }

    /// KSPSolve on the current system; returns (converged reason, iterations).
    fn run_ksp(
        &mut self,
        turn: &Turn,
        rhs: &[f64],
        x: &mut [f64],
    ) -> Result<(sys::KSPConvergedReason, usize), PetscError> {
        let system = self.system.as_mut().expect("built before the solve");
        let mut reason: sys::KSPConvergedReason = 0;
        let mut iterations: sys::PetscInt = 0;
        // SAFETY: the vectors point at `rhs` and `x` only between Place and Reset, which both
        // outlive the solve; the matrix arrays are `system`'s.
        unsafe {
            check(sys::MatAssemblyBegin(
                system.matrix,
                sys::MatAssemblyType_MAT_FINAL_ASSEMBLY,
            ))?;
            check(sys::MatAssemblyEnd(
                system.matrix,
                sys::MatAssemblyType_MAT_FINAL_ASSEMBLY,
            ))?;
            check(sys::KSPSetOperators(
                system.ksp,
                system.matrix,
                system.matrix,
            ))?;
            check(sys::VecPlaceArray(system.rhs, rhs.as_ptr()))?;
            check(sys::VecPlaceArray(system.solution, x.as_mut_ptr()))?;
            let solved = check(sys::KSPSolve(system.ksp, system.rhs, system.solution));
            check(sys::VecResetArray(system.rhs))?;
            check(sys::VecResetArray(system.solution))?;
            solved?;
            check(sys::KSPGetConvergedReason(system.ksp, &mut reason))?;
            check(sys::KSPGetIterationNumber(system.ksp, &mut iterations))?;
        }
        if !self.unused_reported {
            self.unused_reported = true;
            self.settings.options.warn_unused(turn);
        }
        Ok((reason, usize::try_from(iterations).unwrap_or(0)))
    }

    /// The name reports use: the resolved types once known, else the deck's choice.
    pub fn method_name(&self) -> String {
        match &self.resolved {
            Some(resolved) => resolved.clone(),
            None => {
                let (ksp, pc) = self.settings.type_names();
                format!(
                    "PETSc KSP {} + PC {}",
                    ksp.to_string_lossy(),
                    pc.to_string_lossy()
                )
            }
        }
    }

    /// Creates a KSP with the deck's settings and options without a matrix (what `peridyn
    /// check` shows and validates): the resolved `KSP type + PC type`, or PETSc's refusal.
    pub fn resolve(&self) -> Result<String, PetscError> {
        let turn = Turn::take()?;
        let mut ksp: sys::KSP = std::ptr::null_mut();
        // SAFETY: a KSP created and destroyed here, on MPI_COMM_SELF.
        unsafe { check(sys::KSPCreate(turn.comm_self(), &mut ksp))? };
        let result = self.settings.configure(&turn, ksp, 1, true);
        // SAFETY: `ksp` was created above.
        unsafe { sys::KSPDestroy(&mut ksp) };
        self.settings
            .options
            .clear(&turn, &self.settings.option_defaults());
        result
    }
}

/// `PETSC_DEFAULT` as a real argument.
pub(super) const PETSC_DEFAULT_REAL: f64 = -2.0;

/// `PETSc KSP <type> + PC <type>` of a configured KSP.
pub(super) fn resolved_types(ksp: sys::KSP) -> Result<String, PetscError> {
    let mut ksp_type: sys::KSPType = std::ptr::null();
    let mut pc: sys::PC = std::ptr::null_mut();
    let mut pc_type: sys::PCType = std::ptr::null();
    // SAFETY: `ksp` is live; the type names belong to it.
    unsafe {
        check(sys::KSPGetType(ksp, &mut ksp_type))?;
        check(sys::KSPGetPC(ksp, &mut pc))?;
        check(sys::PCGetType(pc, &mut pc_type))?;
    }
    Ok(format!(
        "PETSc KSP {} + PC {}",
        owned_string(ksp_type),
        owned_string(pc_type)
    ))
}

/// Attaches the orthonormalised `count` modes (row-major, `n` × `count`) to `matrix` as its
/// near-null space (GAMG's aggregation basis). With a `layout` the matrix is distributed, the
/// modes are this rank's rows and the orthonormalisation's inner products are over all ranks
/// (collective).
pub(super) fn set_near_null_space(
    turn: &Turn,
    matrix: sys::Mat,
    modes: &[f64],
    count: usize,
    n: usize,
    layout: Option<&Layout>,
) -> Result<(), PetscError> {
    let basis = orthonormal_columns(modes, count, n, layout.is_some());
    let rows = sys::PetscInt::try_from(n).unwrap_or(sys::PetscInt::MAX);
    let comm = match layout {
        Some(_) => turn.comm_world(),
        None => turn.comm_self(),
    };
    let mut vectors: Vec<sys::PetscVec> = Vec::with_capacity(basis.len());
    let result = (|| {
        for column in &basis {
            let mut v: sys::PetscVec = std::ptr::null_mut();
            let mut data: *mut f64 = std::ptr::null_mut();
            // SAFETY: a new vector of n entries, written through its array between Get and
            // Restore.
            unsafe {
                match layout {
                    Some(layout) => v = layout.vector(turn)?,
                    None => check(sys::VecCreateSeq(comm, rows, &mut v))?,
                }
                vectors.push(v);
                check(sys::VecGetArray(v, &mut data))?;
                std::slice::from_raw_parts_mut(data, n).copy_from_slice(column);
                check(sys::VecRestoreArray(v, &mut data))?;
            }
        }
        let mut space: sys::MatNullSpace = std::ptr::null_mut();
        // SAFETY: the vectors are live; the null space takes its own references, and the
        // matrix its own reference to the null space.
        unsafe {
            check(sys::MatNullSpaceCreate(
                comm,
                sys::PetscBool_PETSC_FALSE,
                sys::PetscInt::try_from(vectors.len()).unwrap_or(0),
                vectors.as_ptr(),
                &mut space,
            ))?;
            let set = check(sys::MatSetNearNullSpace(matrix, space));
            sys::MatNullSpaceDestroy(&mut space);
            set
        }
    })();
    for v in &mut vectors {
        // SAFETY: created above, destroyed once.
        unsafe { sys::VecDestroy(v) };
    }
    result
}

/// Modified Gram–Schmidt on the columns of the row-major `n` × `count` array; columns that
/// are (numerically) dependent on the earlier ones are dropped (e.g. the modes of a component
/// that is prescribed everywhere). With `distributed` the rows are this rank's share and the
/// inner products are summed over the ranks (collective), so every rank keeps the same columns.
fn orthonormal_columns(modes: &[f64], count: usize, n: usize, distributed: bool) -> Vec<Vec<f64>> {
    let dot = |a: &[f64], b: &[f64]| {
        let local: f64 = a.iter().zip(b).map(|(x, y)| x * y).sum();
        if distributed {
            sum_over_ranks(local)
        } else {
            local
        }
    };
    let mut basis: Vec<Vec<f64>> = Vec::new();
    for j in 0..count {
        let mut v: Vec<f64> = (0..n).map(|i| modes[i * count + j]).collect();
        let original = dot(&v, &v).sqrt();
        for b in &basis {
            let d = dot(&v, b);
            v.iter_mut().zip(b).for_each(|(a, c)| *a -= d * c);
        }
        let norm = dot(&v, &v).sqrt();
        if norm > 1e-10 * original && norm > 0.0 {
            v.iter_mut().for_each(|a| *a /= norm);
            basis.push(v);
        }
    }
    basis
}

impl System {
    /// Destroys the PETSc objects (PETSc must be alive and the caller hold the turn).
    fn destroy(&mut self) {
        // SAFETY: each pointer is null or a live object created by `build`; PETSc's Destroy
        // functions accept null and null the pointer.
        unsafe {
            sys::KSPDestroy(&mut self.ksp);
            sys::MatDestroy(&mut self.matrix);
            sys::VecDestroy(&mut self.rhs);
            sys::VecDestroy(&mut self.solution);
        }
    }

    fn same_pattern(&self, matrix: &Csr) -> bool {
        self.offsets == matrix.offsets && self.columns == matrix.columns
    }
}

impl Drop for PetscLinearSolver {
    fn drop(&mut self) {
        if let Some(system) = self.distributed.take() {
            if let Ok(turn) = Turn::take() {
                drop(system);
                self.settings
                    .options
                    .clear(&turn, &self.settings.option_defaults());
            }
        }
        let Some(mut system) = self.system.take() else {
            return;
        };
        if let Ok(turn) = Turn::take() {
            if super::runtime::alive() {
                system.destroy();
                self.settings
                    .options
                    .clear(&turn, &self.settings.option_defaults());
            }
        }
    }
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|a| a * a).sum::<f64>().sqrt()
}

/// PETSc's name of a negative (diverged) KSP reason.
fn diverged_reason(reason: sys::KSPConvergedReason) -> &'static str {
    match reason {
        sys::KSPConvergedReason_KSP_DIVERGED_NULL => "KSP_DIVERGED_NULL",
        sys::KSPConvergedReason_KSP_DIVERGED_ITS => "KSP_DIVERGED_ITS",
        sys::KSPConvergedReason_KSP_DIVERGED_DTOL => "KSP_DIVERGED_DTOL",
        sys::KSPConvergedReason_KSP_DIVERGED_BREAKDOWN => "KSP_DIVERGED_BREAKDOWN",
        sys::KSPConvergedReason_KSP_DIVERGED_BREAKDOWN_BICG => "KSP_DIVERGED_BREAKDOWN_BICG",
        sys::KSPConvergedReason_KSP_DIVERGED_NONSYMMETRIC => "KSP_DIVERGED_NONSYMMETRIC",
        sys::KSPConvergedReason_KSP_DIVERGED_INDEFINITE_PC => "KSP_DIVERGED_INDEFINITE_PC",
        sys::KSPConvergedReason_KSP_DIVERGED_NANORINF => "KSP_DIVERGED_NANORINF",
        sys::KSPConvergedReason_KSP_DIVERGED_INDEFINITE_MAT => "KSP_DIVERGED_INDEFINITE_MAT",
        sys::KSPConvergedReason_KSP_DIVERGED_PC_FAILED => "KSP_DIVERGED_PC_FAILED",
        _ => "diverged",
    }
}

impl LinearSolver for PetscLinearSolver {
    fn describe(&self) -> String {
        self.method_name()
    }

    /// KSP on `MPI_COMM_WORLD` over every rank's rows (see [`distributed`]).
    fn solve_distributed(&mut self, part: RankRows, rhs: &[f64], x: &mut [f64]) -> LinearResult {
        self.solve_on_ranks(part, rhs, x)
    }

    fn set_near_null_space(&mut self, modes: &[f64], count: usize) {
        if self.settings.preconditioner != PetscPreconditioner::Gamg {
            return;
        }
        let changed = self
            .near_null_space
            .as_ref()
            .is_none_or(|(m, c)| *c != count || m[..] != modes[..]);
        if changed {
            self.near_null_space = Some((modes.to_vec(), count));
            // The matrix holds the old space: rebuild at the next solve.
            if let Some(mut system) = self.system.take() {
                if let Ok(_turn) = Turn::take() {
                    system.destroy();
                }
            }
            if let Some(system) = self.distributed.take() {
                if let Ok(_turn) = Turn::take() {
                    drop(system);
                }
            }
        }
    }

    fn solve(&mut self, matrix: &Csr, rhs: &[f64], x: &mut [f64]) -> LinearResult {
        self.check_system(matrix, rhs, x)?;
        let rhs_norm = norm(rhs);
        if rhs_norm == 0.0 {
            x.fill(0.0);
            return Ok(KrylovReport {
                method: self.method_name(),
                iterations: 0,
                relative_residual: 0.0,
            });
        }
        let turn = Turn::take().map_err(|e| petsc_failure("starting PETSc", e))?;
        self.prepare(&turn, matrix)?;
        let guess = x.to_vec();
        let (mut reason, mut iterations) = self
            .run_ksp(&turn, rhs, x)
            .map_err(|e| petsc_failure("KSPSolve", e))?;
        if indefinite(reason) && self.settings.method == KspMethod::Cg {
            let ksp = self.system.as_ref().expect("built above").ksp;
            self.switch_to_gmres(ksp, reason, true)?;
            x.copy_from_slice(&guess);
            (reason, iterations) = self
                .run_ksp(&turn, rhs, x)
                .map_err(|e| petsc_failure("KSPSolve", e))?;
        }
        drop(turn);
        self.report(matrix, rhs, x, rhs_norm, (reason, iterations))
    }
}

impl PetscLinearSolver {
    /// Refuses a system that is not square with matching vectors, or holds a non-finite
    /// value.
    fn check_system(&self, matrix: &Csr, rhs: &[f64], x: &[f64]) -> Result<(), SolveError> {
        let n = matrix.nrows;
        if matrix.ncols != n || rhs.len() != n || x.len() != n {
            return Err(SolveError::Breakdown {
                method: "PETSc KSP",
                reason: format!(
                    "the system must be square with matching vectors (matrix {}×{}, right-hand side {}, solution {})",
                    matrix.nrows,
                    matrix.ncols,
                    rhs.len(),
                    x.len()
                ),
            });
        }
        self.non_finite(matrix, rhs, x).map_or(Ok(()), Err)
    }

    /// The first of the matrix, the right-hand side and the initial guess that holds a
    /// non-finite value, as the error that names it.
    fn non_finite(&self, matrix: &Csr, rhs: &[f64], x: &[f64]) -> Option<SolveError> {
        let parts = [
            ("the matrix", &matrix.values[..]),
            ("the right-hand side", rhs),
            ("the initial guess", x),
        ];
        let (what, _) = parts
            .into_iter()
            .find(|(_, values)| !values.iter().all(|v| v.is_finite()))?;
        Some(SolveError::NonFinite {
            what: format!("{what} given to {}", self.method_name()),
        })
    }

    /// The PETSc matrix and KSP for `matrix`: kept from the last solve on the same pattern,
    /// else built and configured; the values copied in.
    fn prepare(&mut self, turn: &Turn, matrix: &Csr) -> Result<(), SolveError> {
        if self
            .system
            .as_ref()
            .is_some_and(|s| !s.same_pattern(matrix))
        {
            if let Some(mut old) = self.system.take() {
                old.destroy();
            }
        }
        if self.system.is_none() {
            let system = self
                .build(turn, matrix)
                .map_err(|e| petsc_failure("building the matrix and KSP", e))?;
            let ksp = system.ksp;
            self.system = Some(system);
            let resolved = self
                .settings
                .configure(turn, ksp, matrix.nrows, true)
                .map_err(|e| petsc_failure("setting up the KSP", e))?;
            self.resolved = Some(resolved);
        }
        let system = self.system.as_mut().expect("built above");
        for (slot, &k) in system.petsc_values.iter_mut().zip(&system.order) {
            *slot = matrix.values[k];
        }
        Ok(())
    }

    /// CG met an indefinite operator (`reason`): the KSP `ksp` becomes GMRES for this and
    /// every later solve; `announce` prints why (rank 0 of several).
    pub(super) fn switch_to_gmres(
        &mut self,
        ksp: sys::KSP,
        reason: sys::KSPConvergedReason,
        announce: bool,
    ) -> Result<(), SolveError> {
        if announce {
            eprintln!(
                "  note: {}: {}; switching to GMRES",
                self.method_name(),
                diverged_reason(reason)
            );
        }
        self.settings.method = KspMethod::Gmres;
        // SAFETY: a live KSP; the type change keeps operators and PC.
        check(unsafe { sys::KSPSetType(ksp, c"gmres".as_ptr()) })
            // GMRES with a left preconditioner measures the preconditioned residual.
            .and_then(|()| {
                // SAFETY: as above.
                check(unsafe { sys::KSPSetNormType(ksp, sys::KSPNormType_KSP_NORM_DEFAULT) })
            })
            .and_then(|()| resolved_types(ksp))
            .map(|r| self.resolved = Some(r))
            .map_err(|e| petsc_failure("switching to GMRES", e))
    }

    /// The report of a solve that stopped with `reason` after `iterations`: the true
    /// relative residual ‖b − A x‖/‖b‖, or the failure.
    fn report(
        &self,
        matrix: &Csr,
        rhs: &[f64],
        x: &[f64],
        rhs_norm: f64,
        (reason, iterations): (sys::KSPConvergedReason, usize),
    ) -> LinearResult {
        if !x.iter().all(|v| v.is_finite()) {
            return Err(SolveError::NonFinite {
                what: format!("the solution of {}", self.method_name()),
            });
        }
        let residual = matrix.residual_norm(x, rhs);
        self.outcome((reason, iterations), residual / rhs_norm)
    }

    /// The report of a solve that stopped with `reason` after `iterations` at the true
    /// relative residual `relative_residual`, or its failure: the iteration limit, another
    /// reason of PETSc's, or a non-finite residual.
    pub(super) fn outcome(
        &self,
        (reason, iterations): (sys::KSPConvergedReason, usize),
        relative_residual: f64,
    ) -> LinearResult {
        if reason == sys::KSPConvergedReason_KSP_DIVERGED_ITS {
            return Err(SolveError::NotConverged {
                method: "PETSc KSP",
                iterations,
                relative_residual,
                tolerance: self.settings.krylov.relative_tolerance,
            });
        }
        if reason < 0 || !relative_residual.is_finite() {
            return Err(SolveError::Breakdown {
                method: "PETSc KSP",
                reason: format!(
                    "{} stopped with {} after {iterations} iterations (relative residual {relative_residual:.3e})",
                    self.method_name(),
                    diverged_reason(reason)
                ),
            });
        }
        Ok(KrylovReport {
            method: self.method_name(),
            iterations: iterations.max(1),
            relative_residual,
        })
    }
}

/// True when CG stopped on an operator or preconditioner that is not positive definite (or a
/// breakdown), which GMRES may still solve.
pub(super) fn indefinite(reason: sys::KSPConvergedReason) -> bool {
    matches!(
        reason,
        sys::KSPConvergedReason_KSP_DIVERGED_INDEFINITE_PC
            | sys::KSPConvergedReason_KSP_DIVERGED_INDEFINITE_MAT
            | sys::KSPConvergedReason_KSP_DIVERGED_BREAKDOWN
    )
}
