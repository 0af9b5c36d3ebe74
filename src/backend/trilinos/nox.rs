//! NOX's Newton solver (`NOX::Epetra`, linear solves by AztecOO) driven by Rust callbacks,
//! through the bridge in [`super::nox_ffi`] and the shim `cpp/src/trilinos_nox.cpp`.
//!
//! The backend knows nothing of peridynamics: a [`NonlinearCallbacks`] gives F(x), the values
//! of an assembled Jacobian ∂F/∂x in a fixed CSR pattern, and the values of a preconditioner
//! matrix; [`solve`] hands them to NOX with the deck's NOX parameter list and returns what NOX
//! did. An error in a callback is kept here, the fill reports failure to NOX, NOX throws, and
//! [`solve`] returns the callback's own [`SolveError`] — no panic or C++ exception crosses the
//! boundary.

pub use super::nox_ffi::NonlinearCallbacks;
use super::nox_ffi::{bridge, NoxProblem};
use super::parameters::flatten;
use super::MPI_TURN;
use crate::backend::parameters::ParameterValue;
use crate::backend::SolveError;
use crate::mpi_session::{fortran_handle, CommScope};

/// A CSR sparsity pattern over the unknowns (global column ids).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Pattern {
    /// Row starts, `rows + 1` entries.
    pub offsets: Vec<usize>,
    /// Column of every entry.
    pub columns: Vec<usize>,
}

/// How the preconditioner matrix of a matrix-free solve is used.
#[derive(Debug, Clone, PartialEq)]
pub struct PreconditionerMatrix {
    /// Its pattern.
    pub pattern: Pattern,
    /// The matrix is the preconditioner's inverse and is applied by a product (NOX
    /// `Preconditioner: "User Defined"`); otherwise the NOX linear-solver `Preconditioner`
    /// (`AztecOO`, `Ifpack`, `New Ifpack`, `ML`) factors it.
    pub is_inverse: bool,
    /// `Some`: ML smoothed aggregation is built on the matrix with this near-null space and
    /// applied as NOX's `User Defined` preconditioner (the parameter list must say so),
    /// rebuilt each time the preconditioner callback refills the values and kept when it
    /// does not; `is_inverse` is then ignored.
    pub multigrid: Option<NearNullSpace>,
}

/// What ML is told about the unknowns of the preconditioner matrix.
#[derive(Debug, Clone, PartialEq)]
pub struct NearNullSpace {
    /// Row-major, unknowns × `modes` (the rigid-body modes for elasticity).
    pub vectors: Vec<f64>,
    /// Number of vectors.
    pub modes: usize,
    /// Every point of this rank keeps its three unknowns, consecutive (ML's `PDE equations`
    /// 3 when this holds on every rank, 1 otherwise).
    pub whole_points: bool,
    /// Use the matrix and ML hierarchy the [`MultigridKeep`] given to [`solve_keeping`] holds
    /// from an earlier solve (the caller vouches that the unknowns and the operator are the
    /// same), when it holds one; otherwise they are built and kept there.
    pub reuse_kept: bool,
}

/// The preconditioner matrix and ML hierarchy of a multigrid-preconditioned solve, kept for
/// the next solve ([`solve_keeping`]).
pub struct MultigridKeep {
    kept: cxx::UniquePtr<bridge::NoxMultigrid>,
}

impl MultigridKeep {
    /// Nothing kept yet.
    pub fn new() -> Self {
        Self {
            kept: bridge::new_nox_multigrid(),
        }
    }
}

impl Default for MultigridKeep {
    fn default() -> Self {
        Self::new()
    }
}

impl std::fmt::Debug for MultigridKeep {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("MultigridKeep")
    }
}

impl Drop for MultigridKeep {
    /// ML and the Epetra matrix are released while this thread has MPI to itself.
    fn drop(&mut self) {
        let _turn = MPI_TURN.lock().unwrap_or_else(|p| p.into_inner());
        drop(std::mem::replace(&mut self.kept, cxx::UniquePtr::null()));
    }
}

/// The Newton system NOX builds.
#[derive(Debug, Clone, PartialEq)]
pub struct NoxLayout {
    /// Sublists holding the linear-solver parameters of the chosen direction, e.g.
    /// `["Direction", "Newton", "Linear Solver"]`.
    pub linear_solver_path: Vec<String>,
    /// `Some`: the assembled Jacobian's pattern. `None`: `NOX::Epetra::MatrixFree`
    /// directional derivatives of F.
    pub jacobian: Option<Pattern>,
    /// Preconditioner matrix of a matrix-free solve.
    pub preconditioner: Option<PreconditionerMatrix>,
    /// Converged when ‖F‖₂ ≤ this (NOX `NormF`, absolute, unscaled).
    pub tolerance: f64,
    /// NOX `MaxIters`.
    pub max_iterations: u64,
    /// The global id of each unknown of this rank when the system is distributed over the
    /// ranks of `MPI_COMM_WORLD` (pattern columns are then global ids too); `None`: the whole
    /// system is on this process (`MPI_COMM_SELF`, ids 0..n). Every callback is then
    /// collective: NOX calls it on all ranks together.
    pub global_rows: Option<Vec<usize>>,
}

/// What NOX did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoxReport {
    /// The status tests ended with `Converged`.
    pub converged: bool,
    /// Nonlinear iterations.
    pub iterations: usize,
    /// Krylov iterations summed over the solve.
    pub linear_iterations: usize,
    /// ‖F‖₂ at the returned x.
    pub residual_norm: f64,
    /// ML hierarchies built on the preconditioner matrix (0 without
    /// [`PreconditionerMatrix::multigrid`]).
    pub multigrid_setups: usize,
    /// Wall-clock seconds ML's setups took.
    pub multigrid_seconds: f64,
    /// Levels of the last ML hierarchy (0 without one).
    pub multigrid_levels: usize,
    /// ML's operator complexity of the last hierarchy (0 without one).
    pub operator_complexity: f64,
}

fn failure(reason: impl Into<String>) -> SolveError {
    SolveError::Breakdown {
        method: "NOX",
        reason: reason.into(),
    }
}

fn narrow(values: &[usize], what: &str) -> Result<Vec<i32>, SolveError> {
    values
        .iter()
        .map(|&v| i32::try_from(v))
        .collect::<Result<_, _>>()
        .map_err(|_| failure(format!("{what} exceed Epetra's 32-bit indices (2³¹ − 1)")))
}

/// Runs NOX on `callbacks` from `x` (the initial guess; NOX's last iterate on return) with
/// the parameter list `parameters` (the deck's NOX keys) and the system `layout`. A solve
/// that stops unconverged is a report with `converged == false`; errors are callback errors
/// (returned as they were raised) and failures inside Trilinos.
pub fn solve(
    callbacks: &mut dyn NonlinearCallbacks,
    layout: &NoxLayout,
    parameters: &[(String, ParameterValue)],
    x: &mut [f64],
) -> Result<NoxReport, SolveError> {
    solve_keeping(callbacks, layout, parameters, x, &mut MultigridKeep::new())
}

/// [`solve`], a multigrid preconditioner ([`PreconditionerMatrix::multigrid`]) living in
/// `kept`: taken from it with [`NearNullSpace::reuse_kept`], built and left there otherwise.
pub fn solve_keeping(
    callbacks: &mut dyn NonlinearCallbacks,
    layout: &NoxLayout,
    parameters: &[(String, ParameterValue)],
    x: &mut [f64],
    kept: &mut MultigridKeep,
) -> Result<NoxReport, SolveError> {
    let n = x.len();
    let rows: Vec<i32> = match &layout.global_rows {
        Some(rows) if rows.len() != n => {
            return Err(failure(format!(
                "{} global row ids for {n} unknowns",
                rows.len()
            )))
        }
        Some(rows) => narrow(rows, "the global ids")?,
        None => narrow(&(0..n).collect::<Vec<_>>(), "the unknowns")?,
    };
    let distributed = layout.global_rows.is_some();
    let csr = |pattern: &Pattern, what: &str| narrow_pattern(pattern, what, n, distributed);
    let (jacobian_offsets, jacobian_columns) = match &layout.jacobian {
        Some(p) => csr(p, "Jacobian")?,
        None => Default::default(),
    };
    let (preconditioner_offsets, preconditioner_columns) = match &layout.preconditioner {
        Some(p) => csr(&p.pattern, "preconditioner")?,
        None => Default::default(),
    };
    let scope = if distributed {
        CommScope::World
    } else {
        CommScope::Process
    };
    // MPI is started with MPI_THREAD_SERIALIZED: calls into it, this one included, take turns.
    let turn = MPI_TURN.lock().unwrap_or_else(|p| p.into_inner());
    let communicator = fortran_handle(scope).map_err(|e| failure(format!("MPI: {e}")))?;
    let multigrid = layout
        .preconditioner
        .as_ref()
        .and_then(|p| p.multigrid.as_ref());
    let bridge_layout = bridge::NoxLayout {
        communicator: communicator.handle,
        linear_solver_path: layout.linear_solver_path.clone(),
        matrix_free: layout.jacobian.is_none(),
        jacobian_offsets,
        jacobian_columns,
        preconditioner_offsets,
        preconditioner_columns,
        preconditioner_is_inverse: layout.preconditioner.as_ref().is_some_and(|p| p.is_inverse),
        multigrid: multigrid.is_some(),
        reuse_multigrid: multigrid.is_some_and(|m| m.reuse_kept),
        null_space_modes: multigrid.map_or(0, |m| i32::try_from(m.modes).unwrap_or(i32::MAX)),
        pde_equations: if multigrid.is_some_and(|m| m.whole_points) {
            3
        } else {
            1
        },
        null_space: multigrid.map_or(Ok(Vec::new()), |space| null_space_columns(space, n))?,
        tolerance: layout.tolerance,
        max_iterations: i32::try_from(layout.max_iterations).unwrap_or(i32::MAX),
    };
    let parameters = flatten(parameters);
    let mut problem = NoxProblem::new(callbacks);
    let outcome = bridge::nox_solve(
        &mut problem,
        &rows,
        &bridge_layout,
        &parameters,
        x,
        kept.kept.pin_mut(),
    );
    drop(turn);
    if let Some(error) = problem.into_error() {
        return Err(error);
    }
    let outcome = outcome.map_err(|e| failure(e.what().to_string()))?;
    Ok(NoxReport {
        converged: outcome.converged,
        iterations: usize::try_from(outcome.iterations).unwrap_or(0),
        linear_iterations: usize::try_from(outcome.linear_iterations).unwrap_or(0),
        residual_norm: outcome.residual_norm,
        multigrid_setups: usize::try_from(outcome.preconditioner_setups).unwrap_or(0),
        multigrid_seconds: outcome.preconditioner_seconds,
        multigrid_levels: usize::try_from(outcome.multigrid_levels).unwrap_or(0),
        operator_complexity: outcome.operator_complexity,
    })
}

/// A pattern over `n` unknowns (its columns global ids when `distributed`) as Epetra's 32-bit
/// offsets and columns, or what is wrong with it (`what` names it).
fn narrow_pattern(
    pattern: &Pattern,
    what: &str,
    n: usize,
    distributed: bool,
) -> Result<(Vec<i32>, Vec<i32>), SolveError> {
    if pattern.offsets.len() != n + 1 || pattern.offsets.last() != Some(&pattern.columns.len()) {
        return Err(failure(format!(
            "the {what} pattern has {} row offsets and {} entries for {n} unknowns",
            pattern.offsets.len(),
            pattern.columns.len()
        )));
    }
    if !distributed && pattern.columns.iter().any(|&c| c >= n) {
        return Err(failure(format!(
            "the {what} pattern has a column beyond {n}"
        )));
    }
    Ok((
        narrow(&pattern.offsets, "the entries")?,
        narrow(&pattern.columns, "the columns")?,
    ))
}

/// The near-null space of `n` unknowns column by column (mode after mode), as ML takes it.
fn null_space_columns(space: &NearNullSpace, n: usize) -> Result<Vec<f64>, SolveError> {
    if space.modes == 0 || space.vectors.len() != n * space.modes {
        return Err(failure(format!(
            "a near-null space of {} values for {n} unknowns and {} modes",
            space.vectors.len(),
            space.modes
        )));
    }
    let mut columns = vec![0.0; space.vectors.len()];
    for (row, values) in space.vectors.chunks_exact(space.modes).enumerate() {
        for (mode, value) in values.iter().enumerate() {
            columns[mode * n + row] = *value;
        }
    }
    Ok(columns)
}
