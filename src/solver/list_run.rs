//! What an integrator gets to run a solver list: the model, the ranks and the run's
//! [`Driver`], whose services keep what outlives the list: output frames, the solver CSV,
//! restart files, the run's counts, and how the ranks agree on a failure.
//!
//! Failures an integrator finds are [`Failure`]s; it hands them to the driver, which agrees
//! on them with the other ranks ([`ListRun::collective`], [`ListRun::agree`],
//! [`ListRun::agree_on_failure`]: every rank stops at the same step, one reports) and returns
//! the [`Stop`] that ends the list. The driver's own failures (a results or restart file that
//! cannot be written, a stop signal) are [`Stop`]s already.

use super::monitor::{EnergyMonitor, Instability};
use super::newmark::NewmarkError;
use super::newton::NewtonReport;
use super::quasistatic::{LoadStepPosition, QuasiStaticError};
use crate::backend::Unsupported;
use crate::boundary::BoundaryError;
use crate::model::Model;
use crate::parallel::Ranks;
use crate::physics::Physics;
use crate::state::State;
use std::path::PathBuf;

/// Why an integrator stops a list, before the ranks agree on it.
#[derive(Debug, thiserror::Error)]
pub enum Failure {
    /// A quasi-static solve failed.
    #[error(transparent)]
    QuasiStatic(#[from] QuasiStaticError),
    /// A Newmark-β solve failed.
    #[error(transparent)]
    Newmark(#[from] NewmarkError),
    /// A boundary-condition expression failed or gave a non-finite value.
    #[error(transparent)]
    Boundary(#[from] BoundaryError),
    /// The list needs something this build does not have.
    #[error("{0}")]
    Unsupported(String),
    /// Input found invalid once the run knows the body (a step count out of range).
    #[error("{0}")]
    Input(String),
    /// The explicit run became unstable.
    #[error("the run became unstable in solver \"{}\"", .0.solver)]
    Unstable(Box<Unstable>),
}

impl From<Unsupported> for Failure {
    fn from(unsupported: Unsupported) -> Self {
        Failure::Unsupported(unsupported.0)
    }
}

/// An explicit list that became unstable: what the monitor saw and the time steps, for the
/// advice the run's error gives.
#[derive(Debug, Clone, PartialEq)]
pub struct Unstable {
    /// The solver list.
    pub solver: String,
    /// What the monitor saw.
    pub instability: Instability,
    /// Δt used (s).
    pub time_step: f64,
    /// Peridigm's stable estimate (s).
    pub estimate: Option<f64>,
    /// The largest stable step measured on the linearised body ([`super::stability`]; one
    /// rank only).
    pub measured: Option<f64>,
}

/// The run stops: every rank agreed, and the error inside is the one the driver reports (its
/// own error type, which the integrators below the driver need not name).
#[derive(Debug)]
pub struct Stop(pub Box<dyn std::error::Error>);

/// Why a step loop of [`super::quasistatic`] or [`super::newmark`] ended early: a stop the
/// driver made after a step, or the loop's own failure `F`, on which the ranks agree next.
#[derive(Debug)]
pub enum Halt<F> {
    /// The driver stopped the run.
    Stopped(Stop),
    /// The loop failed.
    Failed(F),
}

impl<F> From<F> for Halt<F> {
    fn from(failure: F) -> Self {
        Halt::Failed(failure)
    }
}

/// Where a list resumes inside itself, from a restart file.
#[derive(Debug, Clone, PartialEq)]
pub struct Resume {
    /// The last step completed before the file was written (1-based; the list goes on with
    /// the next).
    pub step: u64,
    /// The stability monitor's energies at that step (explicit lists).
    pub monitor: Option<[f64; 2]>,
    /// The load schedule at that step (load-stepped lists).
    pub load_steps: Option<LoadStepPosition>,
}

/// Where in a solver list a restart file is written.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Inside<'a> {
    /// Between two lists, or after a step whose position is its number alone (`Implicit`).
    Boundary,
    /// After a step of an explicit list: the monitor's energies and the steps of the list
    /// so far (not yet in the run's count).
    Explicit {
        /// [`EnergyMonitor::energies`].
        monitor: [f64; 2],
        /// Steps of this list so far.
        steps: u64,
    },
    /// After an accepted load step of a load-stepped list.
    LoadSteps(&'a LoadStepPosition),
}

/// A restart file the integrator offers to write after a step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RestartAt<'a> {
    /// The list's place among the deck's lists ([`ListRun::index`]).
    pub index: Option<usize>,
    /// The step just completed (1-based).
    pub step: u64,
    /// Where in the list.
    pub inside: Inside<'a>,
    /// The file may be due by `Frequency` or `Wall Clock Interval` (false after a list's last
    /// time step, which the boundary file after the list records).
    pub may_be_due: bool,
}

/// An accepted step of an implicit list, for the driver's bookkeeping.
#[derive(Debug, Clone, Copy)]
pub struct ImplicitStep<'a> {
    /// The solver list's name.
    pub list: &'a str,
    /// The step's end time (s).
    pub time: f64,
    /// What Newton did.
    pub newton: &'a NewtonReport,
    /// The restart file it offers.
    pub restart: RestartAt<'a>,
}

/// The run's services to an integrator. Methods that take the ranks are collective: every
/// rank calls them in the same order.
pub trait Driver {
    /// Where list `index` resumes, when the run continues inside it from a restart file
    /// (asked once).
    fn resume(&mut self, index: usize) -> Option<Resume>;

    /// True (once) when the run starts from a saved state (Peridigm's restart): the first
    /// explicit list then takes the saved acceleration instead of evaluating the forces again.
    fn take_saved_start(&mut self) -> bool;

    /// Forgets the last Newton iteration count (the `Nonlinear_Solver_Iterations` output).
    fn clear_iterations(&mut self);

    /// One output call after `ready` (the frame's loads) held, agreed over the ranks.
    fn frame(
        &mut self,
        ranks: &mut dyn Ranks,
        physics: &Physics,
        state: &State,
        ready: Result<(), Failure>,
    ) -> Result<(), Stop>;

    /// One output call of an explicit step: on one rank a failure stops at once; on N ranks
    /// it stays pending (no collective here) until [`Driver::settle`] or
    /// [`Driver::agree_on_failure`]. True when a failure is pending.
    fn explicit_frame(
        &mut self,
        ranks: &dyn Ranks,
        physics: &Physics,
        state: &State,
    ) -> Result<bool, Stop>;

    /// Agrees on the pending failure of [`Driver::explicit_frame`].
    fn settle(&mut self, ranks: &dyn Ranks) -> Result<(), Stop>;

    /// After an accepted implicit step: counts it, records its row of the solver CSV, makes
    /// its output call, writes the restart file it offers when due, and stops the run when a
    /// signal came.
    fn implicit_step(
        &mut self,
        ranks: &mut dyn Ranks,
        physics: &Physics,
        state: &State,
        step: &ImplicitStep,
    ) -> Result<(), Stop>;

    /// Writes the restart file `at` when it is due, or whenever the run has restart files when
    /// a stop signal reached a rank (`signalled`); its directory, or `None` when none was
    /// written (no restart files, a handed list, not due).
    fn restart(
        &mut self,
        ranks: &dyn Ranks,
        physics: &Physics,
        state: &State,
        at: RestartAt,
        signalled: bool,
    ) -> Result<Option<PathBuf>, Stop>;

    /// After a step a stop signal made the last (step `step` of list `list`, after which the
    /// restart file `restart` was written, if any): the frame of that step is added to every
    /// results file and the run stops.
    fn stop_on_signal(
        &mut self,
        ranks: &dyn Ranks,
        physics: &Physics,
        state: &State,
        list_step: (&str, u64),
        restart: Option<PathBuf>,
    ) -> Stop;

    /// The stability monitor from the kinetic and stored energy of the owned points and the
    /// energy floor, summed over the ranks.
    fn energy_monitor(
        &mut self,
        ranks: &mut dyn Ranks,
        physics: &Physics,
        state: &State,
    ) -> EnergyMonitor;

    /// Adds `steps` explicit steps and `broken_bonds` broken bonds to the run's counts
    /// (negative steps: those a resumed list takes again).
    fn count(&mut self, steps: i64, broken_bonds: usize);

    /// A failure every rank has alike: rank 0 reports it.
    fn collective(&mut self, ranks: &dyn Ranks, failure: Failure) -> Stop;

    /// After a collective found a failure: the lowest failing rank reports its `local`
    /// failure (or the pending output failure when it has none).
    fn agree_on_failure(&mut self, ranks: &dyn Ranks, local: Option<Failure>) -> Stop;

    /// Continues when `result` holds on every rank.
    fn agree(&mut self, ranks: &dyn Ranks, result: Result<(), Failure>) -> Result<(), Stop>;
}

/// A solver list being run on one rank (of one or N): the body and its state, what its
/// integrator reads, and the driver it reports to.
pub struct ListRun<'a> {
    /// This rank's model: the whole model on one rank, owned points and ghosts on N.
    pub model: &'a Model,
    /// The models and conditions acting on it.
    pub physics: &'a mut Physics,
    /// The state the list advances.
    pub state: &'a mut State,
    /// The other ranks.
    pub ranks: &'a mut dyn Ranks,
    /// `ghosts[p]` for every local point of a distributed run, `None` on one rank.
    pub ghosts: Option<&'a [bool]>,
    /// The run's services.
    pub driver: &'a mut dyn Driver,
    /// The list's place among the deck's lists (what restart files record); `None` for the
    /// list a failed step was handed to ([`super::integrator::HandOff`]), which neither writes
    /// nor resumes restart files.
    pub index: Option<usize>,
}

impl ListRun<'_> {
    /// True on rank 0, which writes the log.
    pub fn root(&self) -> bool {
        self.ranks.rank() == 0
    }

    /// `" on N ranks"` for the log lines of a distributed run, empty on one rank.
    pub fn on_ranks(&self) -> String {
        match self.ranks.ranks() {
            1 => String::new(),
            n => format!(" on {n} ranks"),
        }
    }

    /// Where this list resumes inside itself, if the run continues there (asked once).
    pub fn resume(&mut self) -> Option<Resume> {
        self.index.and_then(|index| self.driver.resume(index))
    }

    /// The same list's run for the integrator a failed step is handed to.
    pub fn handed(&mut self) -> ListRun<'_> {
        ListRun {
            model: self.model,
            physics: &mut *self.physics,
            state: &mut *self.state,
            ranks: &mut *self.ranks,
            ghosts: self.ghosts,
            driver: &mut *self.driver,
            index: None,
        }
    }

    /// [`Driver::collective`].
    pub fn collective(&mut self, failure: impl Into<Failure>) -> Stop {
        self.driver.collective(&*self.ranks, failure.into())
    }

    /// [`Driver::agree`].
    pub fn agree(&mut self, result: Result<(), impl Into<Failure>>) -> Result<(), Stop> {
        self.driver.agree(&*self.ranks, result.map_err(Into::into))
    }

    /// [`Driver::agree_on_failure`].
    pub fn agree_on_failure(&mut self, local: Option<Failure>) -> Stop {
        self.driver.agree_on_failure(&*self.ranks, local)
    }
}
