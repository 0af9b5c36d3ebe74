//! The restart files of a run: when the driver writes them, and how a run picks up the newest
//! one ([`crate::restart`] holds what is in them).
//!
//! Written, when the deck has a `Restart` entry: after every solver list (Peridigm's moment),
//! every `Frequency` steps and after the first step past each `Wall Clock Interval`
//! (explicit and quasi-static lists), and when a signal stops the run.
//!
//! Read at the start: the newest `restart-NNNNNN` of the output folder. Its body must be this
//! deck's ([`crate::restart::model_hash`]), or the run is refused. Then:
//! - **continuation**: the deck's solver lists are those that wrote the file and it was
//!   written before their end: the run continues at the solver list and step it names, and
//!   the results files written so far are kept up to that step and continued, so the files
//!   end as an uninterrupted run writes them;
//! - **Peridigm's restart**: otherwise (other solver lists, e.g. a second deck whose solver
//!   starts where the first one ended), the state is taken as the start of the deck, whose
//!   first solver's `Initial Time` must equal the file's time; results files start anew.

use super::outputs::RunOutputs;
use super::{RunError, RunSummary};
use crate::io::deck::Deck;
use crate::model::Model;
use crate::physics::Physics;
use crate::restart::{self, BondOrder, LoadSchedule, Position, Snapshot};
use crate::solver::quasistatic::LoadStepPosition;
use crate::state::State;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The restart files of a run with restart on.
pub(super) struct Restarts {
    dir: PathBuf,
    every_steps: Option<u64>,
    every_seconds: Option<f64>,
    last_write: Instant,
    next_number: u64,
    model_hash: u64,
    solvers_hash: u64,
    order: BondOrder,
    /// Where a continued run resumes, until the solver list it names takes it.
    resume: Option<Snapshot>,
    /// The first solver list to run.
    first_solver: usize,
    /// The run starts from a saved state (Peridigm's restart) and its first list has not
    /// taken it yet.
    saved_start: bool,
}

/// How a run starts with restart on.
pub(super) enum Start {
    /// No restart file: from the deck's initial conditions.
    Fresh,
    /// Peridigm's restart: the deck starts from the file's state.
    FromState(Snapshot),
    /// A continuation of the run that wrote the file (results files continued).
    Continue(Snapshot),
}

impl Restarts {
    /// The restart files of a run of `deck` on `model` writing to `dir`, and how it starts:
    /// from the newest restart directory in `dir`, if any. Fails, saying what to do, when that
    /// file is unreadable or belongs to another body, or when neither way of starting fits it.
    pub fn open(deck: &Deck, model: &Model, dir: &Path) -> Result<(Self, Start), RunError> {
        let settings = deck.restart.unwrap_or_default();
        let found = restart::directories(dir);
        let mut restarts = Self {
            dir: dir.to_path_buf(),
            every_steps: settings.every_steps,
            every_seconds: settings.every_seconds,
            last_write: Instant::now(),
            next_number: found.last().map_or(1, |(n, _)| n + 1),
            model_hash: restart::model_hash(deck, model),
            solvers_hash: restart::solvers_hash(deck),
            order: BondOrder::of(model),
            resume: None,
            first_solver: 0,
            saved_start: false,
        };
        let Some((_, newest)) = found.last() else {
            return Ok((restarts, Start::Fresh));
        };
        let file = newest.join(restart::FILE_NAME);
        let snapshot = restart::read(&file).map_err(|e| {
            RunError::Restart(format!(
                "cannot read the newest restart file: {e}. Remove {} to resume from the one before it, or every restart-* folder in {} to start over",
                newest.display(),
                dir.display()
            ))
        })?;
        if snapshot.displacement.len() != model.points.len() {
            return Err(RunError::Restart(format!(
                "{} was written for a body of {} points, but this deck's mesh now has {}: the mesh file has changed since. Restore the mesh it was written with, or remove the restart-* folders in {} to start over",
                file.display(),
                snapshot.displacement.len(),
                model.points.len(),
                dir.display()
            )));
        }
        if snapshot.model_hash != restarts.model_hash {
            return Err(RunError::Restart(format!(
                "{} was written for another body: the deck's mesh, materials, damage models, blocks, contact or boundary conditions have changed since (hash {:016x}, this deck {:016x}). Restore the deck it was written with, or remove the restart-* folders in {} to start over",
                file.display(),
                snapshot.model_hash,
                restarts.model_hash,
                dir.display()
            )));
        }
        if snapshot.solvers_hash == restarts.solvers_hash
            && snapshot.position.solver < deck.solvers.len()
        {
            restarts.first_solver = snapshot.position.solver;
            eprintln!(
                "restart: continuing from {} (solver \"{}\", step {}, t = {:e} s)",
                newest.display(),
                deck.solvers[snapshot.position.solver].name,
                snapshot.position.step,
                snapshot.time
            );
            return Ok((restarts, Start::Continue(snapshot)));
        }
        let initial = deck.solvers.first().map_or(0.0, |s| s.initial_time);
        let scale = initial
            .abs()
            .max(snapshot.time.abs())
            .max(f64::MIN_POSITIVE);
        if (initial - snapshot.time).abs() > 1e-12 * scale {
            let complete = snapshot.solvers_hash == restarts.solvers_hash;
            return Err(RunError::Restart(format!(
                "{} holds the state at t = {:e} s, but the first solver of this deck starts at Initial Time {:e} s{}. Give the first solver Initial Time {:e} to continue from it, or remove the restart-* folders in {} to start over",
                file.display(),
                snapshot.time,
                initial,
                if complete { " (this deck's run is complete)" } else { "" },
                snapshot.time,
                dir.display()
            )));
        }
        eprintln!(
            "restart: starting from the state in {} (t = {:e} s)",
            newest.display(),
            snapshot.time
        );
        Ok((restarts, Start::FromState(snapshot)))
    }

    /// Puts the state of `snapshot` into `state`.
    pub fn apply(
        &self,
        snapshot: &Snapshot,
        model: &Model,
        physics: &Physics,
        state: &mut State,
    ) -> Result<(), RunError> {
        restart::apply(snapshot, model, &self.order, physics.contact.as_ref(), state).map_err(
            |problem| {
                RunError::Restart(format!(
                    "the restart file does not fit this run: {problem}; remove the restart-* folders in {} to start over",
                    self.dir.display()
                ))
            },
        )
    }

    /// From now on the run resumes at the position of `snapshot`.
    pub fn resume_at(&mut self, snapshot: Snapshot) {
        self.resume = Some(snapshot);
    }

    /// Marks the run as starting from a saved state (Peridigm's restart).
    pub fn start_from_saved_state(&mut self) {
        self.saved_start = true;
    }

    /// True (once) when the run starts from a saved state: the first explicit list then
    /// takes the saved acceleration instead of evaluating the forces again, as the
    /// uninterrupted run would go on.
    pub fn take_saved_start(&mut self) -> bool {
        std::mem::take(&mut self.saved_start)
    }

    /// True when solver list `index` is before the one a continued run starts with.
    pub fn skips(&self, index: usize) -> bool {
        index < self.first_solver
    }

    /// The position to resume solver list `index` at, if the run continues inside it.
    pub fn take_resume(&mut self, index: usize) -> Option<Snapshot> {
        match &self.resume {
            Some(s) if s.position.solver == index && s.position.step > 0 => self.resume.take(),
            _ => None,
        }
    }

    /// True when step `step` of a list (1-based; accepted load step of a quasi-static one)
    /// is followed by a restart file: every `Frequency` steps, or once `Wall Clock Interval`
    /// has passed since the last.
    pub fn due(&self, step: u64) -> bool {
        self.every_steps.is_some_and(|n| step % n == 0)
            || self
                .every_seconds
                .is_some_and(|s| self.last_write.elapsed().as_secs_f64() >= s)
    }

    /// Writes the next restart directory: `state` at `position`, with the output counters of
    /// `outputs`, the summary so far, and inside a list its load schedule or monitor.
    #[allow(clippy::too_many_arguments)]
    pub fn write(
        &mut self,
        model: &Model,
        physics: &Physics,
        state: &State,
        outputs: &RunOutputs,
        summary: &RunSummary,
        position: Position,
        inside: Inside,
    ) -> Result<PathBuf, RunError> {
        let mut snapshot = restart::capture(model, &self.order, physics.contact.as_ref(), state);
        snapshot.model_hash = self.model_hash;
        snapshot.solvers_hash = self.solvers_hash;
        snapshot.position = position;
        let (outputs, solver_rows) = outputs.positions();
        snapshot.outputs = outputs;
        snapshot.solver_rows = solver_rows;
        snapshot.steps = summary.steps;
        snapshot.broken_bonds = summary.broken_bonds as u64;
        match inside {
            Inside::Boundary => {}
            Inside::Explicit { monitor, steps } => {
                snapshot.monitor = Some(monitor);
                snapshot.steps += steps;
            }
            Inside::QuasiStatic(position) => {
                snapshot.load_schedule = Some(LoadSchedule {
                    times: position.times.clone(),
                    next: position.next,
                    total_cuts: position.total_cuts,
                    accepted: position.accepted,
                });
            }
        }
        let directory = restart::write_directory(&self.dir, self.next_number, &snapshot)
            .map_err(|e| RunError::RestartWrite(format!("cannot write a restart file: {e}")))?;
        self.next_number += 1;
        self.last_write = Instant::now();
        Ok(directory)
    }
}

/// Where in a solver list a restart file is written.
pub(super) enum Inside<'a> {
    /// Between two lists.
    Boundary,
    /// After a step of an explicit list: the monitor's energies and the steps of the list
    /// so far (not yet in the summary).
    Explicit {
        /// [`crate::solver::EnergyMonitor::energies`].
        monitor: [f64; 2],
        /// Steps of this list so far.
        steps: u64,
    },
    /// After an accepted load step of a quasi-static list.
    QuasiStatic(&'a LoadStepPosition),
}

/// The quasi-static position of a snapshot written inside a list.
pub(super) fn load_step_position(schedule: &LoadSchedule) -> LoadStepPosition {
    LoadStepPosition {
        times: schedule.times.clone(),
        next: schedule.next,
        total_cuts: schedule.total_cuts,
        accepted: schedule.accepted,
    }
}
