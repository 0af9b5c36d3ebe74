//! Trilinos backend (feature `trilinos`): Belos Krylov solves of our assembled [`Csr`]
//! matrices, preconditioned by Ifpack or ML, through the `cxx` bridge in [`ffi`] and the shim
//! in `cpp/src/trilinos_linear.cpp`.
//!
//! The first [`TrilinosLinearSolver::solve`] builds an Epetra row map, the graph of the CSR
//! with each row's exact length and an `Epetra_FECrsMatrix` on it; the solver keeps them, and
//! the following solves of a matrix with the same pattern (Newton's iterations, the load steps
//! after) write the new values into that matrix instead of building another one. A matrix of
//! another pattern replaces it. The preconditioner (rebuilt on the new values) and a Belos
//! solver manager are made for each solve. Everything that is decided (validation, method
//! names, the achieved residual, which failure is which [`SolveError`]) happens here; the C++
//! side only adapts types.
//!
//! ML gets the near-null space the caller offers ([`LinearSolver::set_near_null_space`]: the
//! six rigid-body modes for elasticity, over the unknowns that remain once prescribed dofs are
//! eliminated) as `null space: type` = `pre-computed`, and aggregates whole points (`PDE
//! equations` 3) when every point keeps its three unknowns on every rank
//! ([`LinearSolver::set_point_groups`]), single unknowns otherwise. A near-null space whose
//! length is not its modes times the matrix's rows (this rank's rows on several ranks) is a
//! [`SolveError::Breakdown`] naming both lengths, raised before Epetra is asked for anything.
//!
//! The Epetra objects live on an `Epetra_MpiComm` built from the communicator Rust hands over
//! as a Fortran handle ([`crate::mpi_session::fortran_handle`]). MPI is started and finalised on
//! the Rust side ([`crate::mpi_session::MpiSession`]), so a serial run needs no `mpirun`; solves
//! from several threads take turns. `Epetra_SerialComm` is not offered: in
//! Debian's MPI build of Trilinos, ML talks to `MPI_COMM_WORLD` itself unless the Epetra
//! communicator hands it another, and fails without MPI ("ML::ERROR:: -1 …
//! ml_MultiLevelPreconditioner.cpp, line 2644").
//!
//! The matrix handed to [`LinearSolver::solve`] holds every row, as on every process of a
//! peridyn run today, so by default the solve is process-local ([`Communicator::MpiSelf`]:
//! under `mpirun` each process solves the whole system itself). [`Communicator::MpiWorld`]
//! builds the same objects on `MPI_COMM_WORLD`; with a replicated matrix that is only
//! meaningful on one process, so it refuses a larger world until distributed assembly exists.

mod ffi;
pub mod nox;
mod nox_ffi;
pub mod nox_problem;
mod parameters;

use self::ffi::bridge;
use super::fingerprint::Fingerprint;
use super::native::KrylovSettings;
use super::{
    Csr, KrylovReport, LinearResult, LinearSolver, PreconditionerSetup, RankRows, SolveError,
};
use crate::backend::parameters::ParameterValue;
use crate::mpi_session::{fortran_handle, CommScope};
use std::time::Instant;

/// Belos solver manager.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BelosMethod {
    /// `Belos::BlockCGSolMgr` with block size 1 (symmetric positive definite matrices), left
    /// preconditioned.
    BlockCg,
    /// `Belos::BlockGmresSolMgr` with block size 1, right preconditioned (so its residual test
    /// is on the true residual).
    BlockGmres,
}

/// Preconditioner built on the Epetra matrix.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TrilinosPreconditioner {
    /// No preconditioner.
    None,
    /// Ifpack `point relaxation`, one Jacobi sweep: the inverted diagonal.
    Jacobi,
    /// Ifpack `ILU` with `fill_level` levels of fill (`fact: level-of-fill`, 0 = ILU(0)).
    Ilu {
        /// Levels of fill.
        fill_level: u32,
    },
    /// ML smoothed-aggregation algebraic multigrid (`ML_Epetra::SetDefaults("SA")`).
    Ml,
}

/// Which Epetra communicator the objects live on (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Communicator {
    /// `Epetra_MpiComm(MPI_COMM_SELF)` (default): each process solves on its own.
    #[default]
    MpiSelf,
    /// `Epetra_MpiComm(MPI_COMM_WORLD)`, one process only for now.
    MpiWorld,
}

/// Everything a [`TrilinosLinearSolver`] needs.
#[derive(Debug, Clone, PartialEq)]
pub struct TrilinosSettings {
    /// Krylov method.
    pub method: BelosMethod,
    /// Preconditioner.
    pub preconditioner: TrilinosPreconditioner,
    /// Tolerance (relative to ‖b‖), iteration limit and GMRES restart (Belos `Num Blocks`).
    pub krylov: KrylovSettings,
    /// Unknowns per node for ML's aggregation (`PDE equations`) when the caller offers no
    /// point groups ([`LinearSolver::set_point_groups`]): 3 for displacement problems whose
    /// unknowns come in x, y, z triples, 1 otherwise. Default 1.
    pub pde_equations: u32,
    /// Communicator.
    pub communicator: Communicator,
    /// Belos parameters that replace the ones derived from the fields above (the deck's
    /// `Belos` sublist, names and types checked by the deck reader). Default none.
    pub belos_parameters: Vec<(String, ParameterValue)>,
}

impl Default for TrilinosSettings {
    fn default() -> Self {
        Self {
            method: BelosMethod::BlockCg,
            preconditioner: TrilinosPreconditioner::None,
            krylov: KrylovSettings::default(),
            pde_equations: 1,
            communicator: Communicator::MpiSelf,
            belos_parameters: Vec::new(),
        }
    }
}

/// A [`LinearSolver`] that hands each system to Belos (see the module docs).
#[derive(Debug)]
pub struct TrilinosLinearSolver {
    settings: TrilinosSettings,
    /// The near-null space for ML as the caller offered it (row-major, unknowns × modes) and
    /// its modes; checked against each matrix's rows and turned column-major at the solve.
    null_space: Option<(Vec<f64>, usize)>,
    /// Every point group of the coming matrices holds three unknowns (`None`: not offered).
    whole_points: Option<bool>,
    /// The Epetra matrix of the last solve, refilled when the next matrix has its pattern.
    kept: Option<KeptSystem>,
    /// Epetra matrices built so far (refills not counted).
    builds: usize,
    /// Preconditioner setups since [`LinearSolver::take_preconditioner_setup`] last asked.
    setup: PreconditionerSetup,
}

/// An Epetra system kept between solves, with the fingerprint of the CSR pattern it was
/// built from.
struct KeptSystem {
    system: cxx::UniquePtr<bridge::LinearSystem>,
    pattern: u64,
}

impl std::fmt::Debug for KeptSystem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "KeptSystem {{ pattern: {:#x} }}", self.pattern)
    }
}

impl Drop for TrilinosLinearSolver {
    /// The kept Epetra objects are released while this thread has MPI to itself (inside a
    /// solve, which holds the turn already, they are replaced without taking it again).
    fn drop(&mut self) {
        if self.kept.is_some() {
            let _turn = MPI_TURN.lock().unwrap_or_else(|p| p.into_inner());
            self.kept = None;
        }
    }
}

/// The [`Fingerprint`] of the rows, offsets and columns of a CSR pattern: tells a refill of
/// the same pattern from a new one (a collision would need two different patterns of the
/// same system to hash alike, which only adversarial input makes likely).
fn pattern_fingerprint(matrix: &IndexedCsr) -> u64 {
    let mut hash = Fingerprint::default();
    hash.add(u64::from(matrix.distributed));
    hash.add(matrix.rows.len() as u64);
    matrix.rows.iter().for_each(|&r| hash.add(r as u64));
    matrix.offsets.iter().for_each(|&o| hash.add(o as u64));
    matrix.columns.iter().for_each(|&c| hash.add(c as u64));
    hash.value()
}

/// MPI runs with `MPI_THREAD_SERIALIZED` ([`crate::mpi_session::MpiSession`]): solves from
/// several threads (cargo's test harness) take turns, with the PETSc backend's too.
pub(crate) use crate::mpi_session::MPI_TURN;

impl TrilinosLinearSolver {
    /// A solver with these settings; nothing is allocated until the first solve.
    pub fn new(settings: TrilinosSettings) -> Self {
        Self {
            settings,
            null_space: None,
            whole_points: None,
            kept: None,
            builds: 0,
            setup: PreconditionerSetup::default(),
        }
    }

    /// Epetra matrices built so far: one per sparsity pattern met in a row, since a matrix of
    /// the kept pattern is refilled in place.
    pub fn matrices_built(&self) -> usize {
        self.builds
    }

    /// The settings.
    pub fn settings(&self) -> &TrilinosSettings {
        &self.settings
    }

    /// The name reports and errors use, e.g. `Belos BlockCG + ML`.
    pub fn method_name(&self) -> &'static str {
        use BelosMethod::*;
        use TrilinosPreconditioner as P;
        match (self.settings.method, self.settings.preconditioner) {
            (BlockCg, P::None) => "Belos BlockCG",
            (BlockCg, P::Jacobi) => "Belos BlockCG + Ifpack Jacobi",
            (BlockCg, P::Ilu { .. }) => "Belos BlockCG + Ifpack ILU",
            (BlockCg, P::Ml) => "Belos BlockCG + ML",
            (BlockGmres, P::None) => "Belos BlockGMRES",
            (BlockGmres, P::Jacobi) => "Belos BlockGMRES + Ifpack Jacobi",
            (BlockGmres, P::Ilu { .. }) => "Belos BlockGMRES + Ifpack ILU",
            (BlockGmres, P::Ml) => "Belos BlockGMRES + ML",
        }
    }

    fn breakdown(&self, reason: impl Into<String>) -> SolveError {
        SolveError::Breakdown {
            method: self.method_name(),
            reason: reason.into(),
        }
    }

    fn cxx_failure(&self, stage: &str, e: cxx::Exception) -> SolveError {
        self.breakdown(format!("{stage}: {}", e.what()))
    }

    /// [`Self::run_belos`]; when CG breaks down, BlockGMRES takes over for good. CG needs a
    /// positive definite (preconditioned) operator: a stiffness without enough kinematic
    /// conditions is only semidefinite, and an incomplete factorization of it can make the
    /// preconditioned operator indefinite; GMRES does not need definiteness (as sparse LU
    /// takes over from Cholesky on the native backend). On several ranks the breakdown is
    /// seen by every rank alike (it follows from global inner products), so all switch.
    fn run_belos_or_gmres(
        &mut self,
        matrix: &IndexedCsr,
        rhs: &[f64],
        x: &mut [f64],
    ) -> Result<bridge::BelosOutcome, SolveError> {
        // Checked first: a wrong near-null space is no breakdown that GMRES could get past.
        self.check_null_space(matrix.rows.len())?;
        let guess = x.to_vec();
        let _turn = MPI_TURN.lock().unwrap_or_else(|p| p.into_inner());
        match self.run_belos(matrix, rhs, x) {
            Err(SolveError::Breakdown { reason, .. })
                if self.settings.method == BelosMethod::BlockCg =>
            {
                eprintln!(
                    "  note: {}: {}; switching to Belos BlockGMRES",
                    self.method_name(),
                    reason
                        .lines()
                        .rev()
                        .find(|l| !l.trim().is_empty())
                        .unwrap_or("breakdown")
                );
                self.settings.method = BelosMethod::BlockGmres;
                x.copy_from_slice(&guess);
                self.run_belos(matrix, rhs, x)
            }
            other => other,
        }
    }

    /// Builds the Epetra system (or refills the kept one), the preconditioner and runs Belos;
    /// `x` holds the guess on entry and Belos' answer on return.
    fn run_belos(
        &mut self,
        matrix: &IndexedCsr,
        rhs: &[f64],
        x: &mut [f64],
    ) -> Result<bridge::BelosOutcome, SolveError> {
        let distributed = matrix.distributed;
        let scope = if distributed || self.settings.communicator == Communicator::MpiWorld {
            CommScope::World
        } else {
            CommScope::Process
        };
        let communicator =
            fortran_handle(scope).map_err(|e| self.breakdown(format!("MPI: {e}")))?;
        if scope == CommScope::World && !distributed {
            let size = communicator.size;
            if size != 1 {
                return Err(self.breakdown(format!(
                    "MPI_COMM_WORLD has {size} processes, but the matrix holds every row on every process; \
                     distributed solves need distributed assembly (not available yet): run without mpirun \
                     or use the process-local communicator"
                )));
            }
        }
        let pattern = pattern_fingerprint(matrix);
        let refilled = match &mut self.kept {
            Some(kept) if kept.pattern == pattern => Some(bridge::refill_linear_system(
                kept.system.pin_mut(),
                &matrix.rows,
                matrix.offsets,
                matrix.columns,
                matrix.values,
            )),
            _ => None,
        };
        match refilled {
            Some(result) => {
                if let Err(e) = result {
                    self.kept = None;
                    return Err(self.cxx_failure("refilling the Epetra matrix", e));
                }
            }
            None => {
                // The old matrix goes before the new one is built: never two at once.
                self.kept = None;
                let system = bridge::new_linear_system(
                    communicator.handle,
                    &matrix.rows,
                    &matrix.rows,
                    matrix.offsets,
                    matrix.columns,
                    matrix.values,
                )
                .map_err(|e| self.cxx_failure("building the Epetra matrix", e))?;
                self.kept = Some(KeptSystem { system, pattern });
                self.builds += 1;
            }
        }
        let pde_equations = match self.whole_points {
            Some(true) => 3,
            Some(false) => 1,
            None => self.settings.pde_equations,
        };
        let (null_space, modes) = match &self.null_space {
            Some((vectors, modes)) => (column_major(vectors, *modes), *modes),
            None => (Vec::new(), 0),
        };
        let preconditioner = self.settings.preconditioner;
        let kept = self.kept.as_mut().expect("built or refilled above");
        let pinned = kept.system.pin_mut();
        let start = Instant::now();
        let built = match preconditioner {
            TrilinosPreconditioner::None => Ok(None),
            TrilinosPreconditioner::Jacobi => {
                bridge::set_jacobi_preconditioner(pinned, 1).map(|()| None)
            }
            TrilinosPreconditioner::Ilu { fill_level } => {
                bridge::set_ilu_preconditioner(pinned, to_i32(fill_level as usize)).map(|()| None)
            }
            TrilinosPreconditioner::Ml => bridge::set_ml_preconditioner(
                pinned,
                to_i32(pde_equations as usize),
                &null_space,
                to_i32(modes),
            )
            .map(Some),
        };
        let hierarchy = built.map_err(|e| self.cxx_failure("building the preconditioner", e))?;
        if preconditioner != TrilinosPreconditioner::None {
            self.setup.seconds += start.elapsed().as_secs_f64();
        }
        if let Some(ml) = hierarchy {
            self.setup.hierarchies += 1;
            self.setup.levels = usize::try_from(ml.levels).unwrap_or(0);
            self.setup.operator_complexity = ml.operator_complexity;
        }
        let parameters = parameters::flatten(&self.belos_parameters(matrix.unknowns));
        let system = &self.kept.as_ref().expect("built or refilled above").system;
        bridge::belos_solve(
            system,
            self.settings.method == BelosMethod::BlockGmres,
            rhs,
            x,
            &parameters,
        )
        .map_err(|e| self.cxx_failure("Belos", e))
    }

    /// A near-null space offered for ML must hold its modes over exactly the `rows` rows of
    /// the matrix solved (this rank's rows on several ranks): anything else was built for
    /// other unknowns, and ML would read past its end or aggregate with wrong modes.
    fn check_null_space(&self, rows: usize) -> Result<(), SolveError> {
        match &self.null_space {
            Some((vectors, modes)) if vectors.len() != modes * rows => Err(self.breakdown(format!(
                "the near-null space has {} values, but {modes} modes over the matrix's {rows} rows need {}: \
                 it was built for other unknowns than the matrix's",
                vectors.len(),
                modes * rows
            ))),
            _ => Ok(()),
        }
    }

    /// Belos' parameter list for a system of `unknowns` unknowns: block size 1, the Krylov
    /// settings (iteration limit default `unknowns`), residuals scaled by ‖b‖, errors only
    /// printed, then [`TrilinosSettings::belos_parameters`] replacing any of them.
    fn belos_parameters(&self, unknowns: usize) -> Vec<(String, ParameterValue)> {
        use ParameterValue::{Double, Int, String as Text};
        let krylov = &self.settings.krylov;
        let limit = krylov.max_iterations.unwrap_or(unknowns).max(1);
        let mut list = vec![
            ("Block Size", Int(1)),
            ("Maximum Iterations", Int(limit as i64)),
            ("Convergence Tolerance", Double(krylov.relative_tolerance)),
            ("Implicit Residual Scaling", Text("Norm of RHS".into())),
            ("Explicit Residual Scaling", Text("Norm of RHS".into())),
            ("Verbosity", Int(BELOS_ERRORS)),
        ];
        if self.settings.method == BelosMethod::BlockGmres {
            list.push(("Num Blocks", Int(krylov.restart.clamp(1, limit) as i64)));
        }
        let mut list: Vec<(String, ParameterValue)> = list
            .into_iter()
            .map(|(name, value)| (name.to_string(), value))
            .collect();
        for (name, value) in &self.settings.belos_parameters {
            match list.iter_mut().find(|(n, _)| n == name) {
                Some(slot) => slot.1 = value.clone(),
                None => list.push((name.clone(), value.clone())),
            }
        }
        list
    }

    /// The tolerance Belos works to: the deck's `Convergence Tolerance` when given, else the
    /// Krylov settings'.
    fn convergence_tolerance(&self) -> f64 {
        self.settings
            .belos_parameters
            .iter()
            .find_map(|(name, value)| match value {
                ParameterValue::Double(t) if name == "Convergence Tolerance" => Some(*t),
                _ => None,
            })
            .unwrap_or(self.settings.krylov.relative_tolerance)
    }
}

/// `Belos::Errors`, the `Verbosity` that prints errors only.
const BELOS_ERRORS: i64 = 0;

/// A [`Csr`] with the 32-bit row ids Epetra's `int` maps take (offsets and columns are
/// checked against Epetra's range on the C++ side, without a narrowed copy).
struct IndexedCsr<'a> {
    /// The rows are this rank's share of a system over `MPI_COMM_WORLD`.
    distributed: bool,
    /// Unknowns of the whole system (the default Krylov iteration limit).
    unknowns: usize,
    rows: Vec<i32>,
    offsets: &'a [usize],
    columns: &'a [usize],
    values: &'a [f64],
}

impl<'a> IndexedCsr<'a> {
    /// `None` when the row count does not fit in an `i32`.
    fn new(matrix: &'a Csr) -> Option<Self> {
        Some(Self {
            distributed: false,
            unknowns: matrix.nrows,
            rows: (0..i32::try_from(matrix.nrows).ok()?).collect(),
            offsets: &matrix.offsets,
            columns: &matrix.columns,
            values: &matrix.values,
        })
    }
}

/// The row-major `vectors` (rows × `modes`) column-major, one mode after the other, as ML
/// reads a near-null space (the length is checked by the caller).
fn column_major(vectors: &[f64], modes: usize) -> Vec<f64> {
    let rows = vectors.len() / modes;
    let mut columns = vec![0.0; vectors.len()];
    for (row, values) in vectors.chunks_exact(modes).enumerate() {
        for (mode, value) in values.iter().enumerate() {
            columns[mode * rows + row] = *value;
        }
    }
    columns
}

/// Saturating conversion for Belos' and Ifpack's `int` parameters.
fn to_i32(v: usize) -> i32 {
    i32::try_from(v).unwrap_or(i32::MAX)
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|a| a * a).sum::<f64>().sqrt()
}

impl LinearSolver for TrilinosLinearSolver {
    fn describe(&self) -> String {
        self.method_name().to_string()
    }

    /// The Ifpack or ML builds of the solves since the last call (each solve builds its
    /// preconditioner anew, on the refilled matrix), with ML's levels and operator complexity.
    fn take_preconditioner_setup(&mut self) -> PreconditionerSetup {
        std::mem::take(&mut self.setup)
    }

    /// Kept for ML, whose solves refuse it unless it has `count` values for each row of the
    /// matrix; other preconditioners ignore it. `count` 0 offers none (ML then uses its
    /// default, constants per unknown of a point), replacing one offered before.
    fn set_near_null_space(&mut self, modes: &[f64], count: usize) {
        if self.settings.preconditioner != TrilinosPreconditioner::Ml {
            return;
        }
        self.null_space = (count > 0).then(|| (modes.to_vec(), count));
    }

    fn set_point_groups(&mut self, groups: &[usize]) {
        self.whole_points = Some(groups.windows(2).all(|g| g[1] - g[0] == 3));
    }

    /// Belos on `MPI_COMM_WORLD` with this rank's rows. The relative residual reported is
    /// Belos' own (the true residual would need the other ranks' parts).
    fn solve_distributed(&mut self, part: RankRows, rhs: &[f64], x: &mut [f64]) -> LinearResult {
        let RankRows { rows, matrix } = part;
        let n = rows.len();
        if matrix.nrows != n || rhs.len() != n || x.len() != n {
            return Err(self.breakdown(format!(
                "{n} rows owned, a matrix of {} rows, right-hand side {}, solution {}",
                matrix.nrows,
                rhs.len(),
                x.len()
            )));
        }
        let rows: Option<Vec<i32>> = rows.iter().map(|&i| i32::try_from(i).ok()).collect();
        let indexed = IndexedCsr {
            distributed: true,
            unknowns: matrix.ncols,
            rows: rows
                .ok_or_else(|| self.breakdown("the global ids exceed Epetra's 32-bit indices"))?,
            offsets: &matrix.offsets,
            columns: &matrix.columns,
            values: &matrix.values,
        };
        let outcome = self.run_belos_or_gmres(&indexed, rhs, x)?;
        let iterations = usize::try_from(outcome.iterations).unwrap_or(0);
        if !outcome.converged {
            return Err(SolveError::NotConverged {
                method: self.method_name(),
                iterations,
                relative_residual: outcome.achieved_tolerance,
                tolerance: self.convergence_tolerance(),
            });
        }
        Ok(KrylovReport {
            method: self.method_name().to_string(),
            iterations,
            relative_residual: outcome.achieved_tolerance,
        })
    }

    fn solve(&mut self, matrix: &Csr, rhs: &[f64], x: &mut [f64]) -> LinearResult {
        let n = matrix.nrows;
        if matrix.ncols != n || rhs.len() != n || x.len() != n {
            return Err(self.breakdown(format!(
                "the system must be square with matching vectors (matrix {}×{}, right-hand side {}, solution {})",
                matrix.nrows,
                matrix.ncols,
                rhs.len(),
                x.len()
            )));
        }
        for (what, values) in [
            ("the matrix", &matrix.values[..]),
            ("the right-hand side", rhs),
            ("the initial guess", &x[..]),
        ] {
            if !values.iter().all(|v| v.is_finite()) {
                return Err(SolveError::NonFinite {
                    what: format!("{what} given to {}", self.method_name()),
                });
            }
        }
        let rhs_norm = norm(rhs);
        if rhs_norm == 0.0 {
            // A zero right-hand side has the zero solution; Belos would divide by ‖b‖ = 0.
            x.fill(0.0);
            return Ok(KrylovReport {
                method: self.method_name().to_string(),
                iterations: 0,
                relative_residual: 0.0,
            });
        }
        let indexed = IndexedCsr::new(matrix).ok_or_else(|| {
            self.breakdown(format!(
                "{} rows exceed Epetra's 32-bit indices (2³¹ − 1)",
                matrix.nrows
            ))
        })?;
        let outcome = self.run_belos_or_gmres(&indexed, rhs, x)?;
        if !x.iter().all(|v| v.is_finite()) {
            return Err(SolveError::NonFinite {
                what: format!("the solution of {}", self.method_name()),
            });
        }
        // The residual reported is the true one, ‖b − A x‖/‖b‖, computed here rather than
        // Belos' recursively updated estimate.
        let relative_residual = matrix.residual_norm(x, rhs) / rhs_norm;
        let iterations = usize::try_from(outcome.iterations).unwrap_or(0);
        if !outcome.converged {
            return Err(SolveError::NotConverged {
                method: self.method_name(),
                iterations,
                relative_residual,
                tolerance: self.convergence_tolerance(),
            });
        }
        Ok(KrylovReport {
            method: self.method_name().to_string(),
            iterations,
            relative_residual,
        })
    }
}

/// The Epetra mat-vec y = A x of `matrix` on `MPI_COMM_SELF`: lets tests check that the CSR
/// reached Epetra entry for entry.
pub fn epetra_multiply(matrix: &Csr, x: &[f64], y: &mut [f64]) -> Result<(), SolveError> {
    let fail = |reason: String| SolveError::Breakdown {
        method: "Epetra_CrsMatrix::Multiply",
        reason,
    };
    if x.len() != matrix.ncols || y.len() != matrix.nrows || matrix.nrows != matrix.ncols {
        return Err(fail(
            "the matrix must be square with matching vectors".into(),
        ));
    }
    let indexed = IndexedCsr::new(matrix)
        .ok_or_else(|| fail("the matrix exceeds Epetra's 32-bit indices".into()))?;
    let _turn = MPI_TURN.lock().unwrap_or_else(|p| p.into_inner());
    let communicator = fortran_handle(CommScope::Process).map_err(fail)?;
    let system = bridge::new_linear_system(
        communicator.handle,
        &indexed.rows,
        &indexed.rows,
        indexed.offsets,
        indexed.columns,
        indexed.values,
    )
    .map_err(|e| fail(e.what().to_string()))?;
    bridge::multiply(&system, x, y).map_err(|e| fail(e.what().to_string()))
}
