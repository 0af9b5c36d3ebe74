//! The crate's run error: why a run stopped early, and the process exit code it maps to.
//!
//! It lives at the crate root so that every module can name it without importing
//! `simulation` (which imports the solvers); [`crate::simulation`] re-exports it under its
//! old path. Modules below the driver (backends, solver choice) return their own error types,
//! which convert into [`RunError`] with `?`.

use crate::backend::Unsupported;
use crate::boundary::BoundaryError;
use crate::io::output::OutputError;
use crate::setup;
use crate::solver::monitor::{EnergyMonitor, Instability};
use crate::solver::newmark::NewmarkError;
use crate::solver::quasistatic::QuasiStaticError;

/// Why a run stopped early.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// Writing results failed.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// A boundary-condition expression failed during the run.
    #[error(transparent)]
    Boundary(#[from] BoundaryError),
    /// A solver needs something this build does not have.
    #[error("{0}")]
    Unsupported(String),
    /// A quasi-static solve failed (exit code 3).
    #[error(transparent)]
    QuasiStatic(#[from] QuasiStaticError),
    /// The discretization failed while the ranks of a distributed run searched their
    /// families (exit code 2, as bad input found before a run).
    #[error(transparent)]
    Setup(#[from] setup::SetupError),
    /// A Newmark-β solve failed (exit code 3).
    #[error(transparent)]
    Newmark(#[from] NewmarkError),
    /// The explicit run became unstable (exit code 3).
    #[error(
        "the run became unstable at step {} of solver \"{solver}\" (t = {:.4e} s): kinetic energy {:.4e} exceeds {}× the energy supplied to the body ({:.4e}). \
         The time step was {time_step:.4e} s; Peridigm's stable estimate is {estimate}. \
         Reduce \"Safety Factor\" (e.g. 0.5) or give a smaller \"Fixed dt\". \
         Output written up to the last frame before the failure is valid.",
        instability.step, instability.time, instability.kinetic_energy, EnergyMonitor::GROWTH_LIMIT, instability.budget,
        estimate = .estimate.map(|e| format!("{e:.4e} s")).unwrap_or_else(|| "not available".into())
    )]
    Unstable {
        /// Solver list name.
        solver: String,
        /// What the monitor saw.
        instability: Instability,
        /// Δt used.
        time_step: f64,
        /// The stable estimate.
        estimate: Option<f64>,
    },
    /// Another rank of a distributed run failed (or reports an error all ranks share); that
    /// rank prints the message, this one stops quietly with the same exit code.
    #[error("rank {rank} stopped the run; its message is above")]
    OtherRank {
        /// The rank that reports the failure.
        rank: usize,
        /// Its exit code.
        code: u8,
    },
}

impl RunError {
    /// Process exit code: 3 for solver failures and instabilities, 1 otherwise (for
    /// [`RunError::OtherRank`], the code of the rank that failed).
    pub fn exit_code(&self) -> u8 {
        match self {
            RunError::Unstable { .. } | RunError::QuasiStatic(_) | RunError::Newmark(_) => 3,
            RunError::OtherRank { code, .. } => *code,
            RunError::Setup(_) => 2,
            _ => 1,
        }
    }
}

/// What cannot run where (a build feature, a backend, a rank count) is a run error with exit
/// code 1 and the factory's message unchanged.
impl From<Unsupported> for RunError {
    fn from(error: Unsupported) -> Self {
        RunError::Unsupported(error.0)
    }
}
