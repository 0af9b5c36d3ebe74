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

/// Exit code of a run that could not write its results or restart files part-way (a full
/// disk, a quota or file-size limit, the output folder removed or made read-only): every
/// results file still opens with the frames completed before the failure.
pub const WRITE_FAILED: u8 = 6;

/// What a results file still holds after a failed write, and what to do.
fn write_advice(error: &OutputError) -> &'static str {
    if error.is_write_failure() {
        ". Writing the results failed (disk full, quota or file-size limit, or the folder became unwritable); every results file holds the frames completed before this one and opens as usual. Free space (or give --output-dir another folder) and run the deck again; with a `Restart` entry it continues from its newest restart folder"
    } else {
        ""
    }
}

/// Why a run stopped early.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// Writing results failed; an I/O failure (a full disk, a quota, the folder gone) is
    /// exit code [`WRITE_FAILED`], with what the files still hold.
    #[error("{error}{advice}", error = .0, advice = write_advice(.0))]
    Output(#[from] OutputError),
    /// A boundary-condition expression failed or gave a non-finite value during the run
    /// (exit code 2: the deck's expression is at fault).
    #[error(transparent)]
    Boundary(#[from] BoundaryError),
    /// A solver needs something this build does not have.
    #[error("{0}")]
    Unsupported(String),
    /// Input found invalid once the run knows the body, where `peridyn check` cannot look
    /// (a distributed run's step count from the families of its ranks); exit code 2.
    #[error("{0}")]
    Input(String),
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
         The time step was {time_step:.4e} s; Peridigm's stable estimate is {estimate}. {advice} \
         Output written up to the last frame before the failure is valid.",
        instability.step, instability.time, instability.kinetic_energy, EnergyMonitor::GROWTH_LIMIT, instability.budget,
        estimate = .estimate.map(|e| format!("{e:.4e} s")).unwrap_or_else(|| "not available".into()),
        advice = unstable_advice(*.time_step, *.estimate, *.measured)
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
        /// The largest stable step measured on the linearised body
        /// ([`crate::solver::stability`]; one rank only).
        measured: Option<f64>,
    },
    /// SIGINT or SIGTERM stopped the run after a completed step; every results file holds a
    /// frame of that step, and with restart on a restart file holds the state
    /// ([`crate::interrupt`], exit code [`crate::interrupt::EXIT_CODE`]).
    #[error(
        "stopped by {} after step {step} of solver \"{solver}\" (t = {time:.6e} s); {}. {}",
        .signal.map_or_else(|| "a stop signal".to_string(), |s| s.to_string()),
        files_message(.files),
        restart_message(.restart)
    )]
    Interrupted {
        /// The signal, when this rank received it (on N ranks it may have reached another).
        signal: Option<crate::interrupt::Signal>,
        /// Solver list name.
        solver: String,
        /// The last completed step (load step of an implicit list) of that list.
        step: u64,
        /// Time of that step, s.
        time: f64,
        /// The results files, each complete up to that step.
        files: Vec<std::path::PathBuf>,
        /// The restart directory written at the stop, or why none was.
        restart: Result<std::path::PathBuf, String>,
    },
    /// A restart file cannot be read or used with this deck (exit code 2: the deck or the
    /// restart directory must change).
    #[error("{0}")]
    Restart(String),
    /// A restart file cannot be written (exit code [`WRITE_FAILED`]): the previous restart
    /// folder and the results files up to the last frame stay valid.
    #[error("{0}. The newest complete restart folder and every results file up to its last frame are intact; free space (or give --output-dir another folder) and run the deck again")]
    RestartWrite(String),
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
    /// Process exit code: 3 for solver failures and instabilities, 2 for invalid input, 4 for a
    /// clean stop on a signal, [`WRITE_FAILED`] when results or restart files cannot be
    /// written, 1 otherwise (for [`RunError::OtherRank`], the code of the rank
    /// that failed).
    pub fn exit_code(&self) -> u8 {
        match self {
            // A condition that fails inside an implicit step is the deck's expression at fault,
            // as in an explicit run.
            RunError::QuasiStatic(QuasiStaticError::Boundary(_))
            | RunError::Newmark(NewmarkError::Boundary(_)) => 2,
            RunError::Unstable { .. } | RunError::QuasiStatic(_) | RunError::Newmark(_) => 3,
            RunError::OtherRank { code, .. } => *code,
            RunError::Setup(_) | RunError::Input(_) | RunError::Boundary(_) => 2,
            RunError::Restart(_) => 2,
            RunError::Output(error) if error.is_write_failure() => WRITE_FAILED,
            RunError::RestartWrite(_) => WRITE_FAILED,
            RunError::Interrupted { .. } => crate::interrupt::EXIT_CODE,
            _ => 1,
        }
    }
}

/// What to change after an instability, from the measured stability limit when there is one:
/// Peridigm's estimate is not a bound for every model (ν near −0.5, points with few bonds), so
/// a fixed "reduce the safety factor" can fail again.
fn unstable_advice(time_step: f64, estimate: Option<f64>, measured: Option<f64>) -> String {
    match (measured, estimate) {
        (Some(limit), _) if time_step < limit => format!(
            "Measured on the undeformed body, the largest stable step is {limit:.4e} s, above \
             the one used: the blow-up comes from the loading, contact or damage rather than \
             the time step alone; check the boundary conditions and material constants."
        ),
        (Some(limit), Some(estimate)) => format!(
            "Measured on the undeformed body, the largest stable step is {limit:.4e} s \
             ({:.2}× Peridigm's estimate, which is not a bound for this body): give \
             \"Safety Factor\" {:.2} or less, or \"Fixed dt\" {:.3e}.",
            limit / estimate,
            0.8 * limit / estimate,
            0.8 * limit
        ),
        (Some(limit), None) => format!(
            "Measured on the undeformed body, the largest stable step is {limit:.4e} s: give \
             \"Fixed dt\" {:.3e} or less.",
            0.8 * limit
        ),
        (None, _) => "Reduce \"Safety Factor\" (e.g. 0.5) or give a smaller \"Fixed dt\".".into(),
    }
}

/// Where an interrupted run's results are: the files, each with a frame of the last step.
fn files_message(files: &[std::path::PathBuf]) -> String {
    if files.is_empty() {
        return "the deck writes no results files".to_string();
    }
    let names: Vec<String> = files.iter().map(|f| f.display().to_string()).collect();
    format!("its last state is the last frame of {}", names.join(", "))
}

/// How to go on after a stop: from the restart file written at it, or from the start.
fn restart_message(restart: &Result<std::path::PathBuf, String>) -> String {
    match restart {
        Ok(directory) => format!(
            "The state is saved in {}: run the same deck again with the same output folder to continue from it",
            directory.display()
        ),
        Err(reason) => format!("No restart file was written ({reason}): running the deck again starts over"),
    }
}

/// What cannot run where (a build feature, a backend, a rank count) is a run error with exit
/// code 1 and the factory's message unchanged.
impl From<Unsupported> for RunError {
    fn from(error: Unsupported) -> Self {
        RunError::Unsupported(error.0)
    }
}
