//! The restart files of a run: when the driver writes them, and how a run picks up the newest
//! one ([`crate::restart`] holds what is in them).
//!
//! Written, when the deck has a `Restart` entry: after every solver list (Peridigm's moment),
//! every `Frequency` steps and after the first step past each `Wall Clock Interval`
//! (explicit, quasi-static and `Implicit` Newmark-β lists), and when a signal stops the run.
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
//!
//! On N ranks every step of this is collective and decided alike on every rank: rank 0 picks
//! the directory and checks the body's hash (it alone gathers the bonds), every rank reads the
//! file and takes its points' values, and the ranks agree on any failure; when a file is due
//! by wall clock, rank 0's clock decides. The number of ranks may differ from the run that
//! wrote the file (see [`crate::restart`]).

use super::agreement::{agree, collective};
use super::{RunError, RunSummary};
use crate::io::deck::Deck;
use crate::model::Model;
use crate::parallel::Communicator;
use crate::physics::Physics;
use crate::restart::{self, LoadSchedule, OutputPosition, Position, Snapshot};
use crate::solver::list_run::{Inside, Resume};
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
    /// The body's hash (rank 0; 0 on the other ranks, which write no file).
    model_hash: u64,
    solvers_hash: u64,
    /// Local indices of the points this rank writes: every point on one rank, the owned ones
    /// on N.
    owned: Vec<u32>,
    /// On N ranks, what to add to the broken bonds counted in the owned rows to get the bonds
    /// broken since the run began (the restart's summary); `None` on one rank, whose summary
    /// counts them step by step.
    broken_offset: Option<i64>,
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

/// Directed bonds of the rows of `owned` that are broken (d = 1).
fn broken_in(model: &Model, owned: &[u32], state: &State) -> usize {
    let Some(damage) = state.bond_damage() else {
        return 0;
    };
    owned
        .iter()
        .map(|&p| {
            damage[model.bonds.range(p as usize)]
                .iter()
                .filter(|&&d| d >= 1.0)
                .count()
        })
        .sum()
}

impl Restarts {
    /// The restart files of a run of `deck` writing to `dir`, and how it starts: from the
    /// newest restart directory in `dir`, if any. `global` is the whole model (points in every
    /// rank), `model` this rank's and `owned` the local indices of its owned points (on one
    /// rank `global` and `model` are the same and every point is owned). Fails on every rank,
    /// saying what to do, when that file is unreadable or belongs to another body, or when
    /// neither way of starting fits it. Collective.
    pub fn open(
        deck: &Deck,
        global: &Model,
        model: &Model,
        owned: Vec<u32>,
        comm: &dyn Communicator,
        dir: &Path,
    ) -> Result<(Self, Start), RunError> {
        let settings = deck.restart.unwrap_or_default();
        let model_hash = restart::gather_bonds(comm, model, &owned)
            .map_or(0, |bonds| restart::model_hash(deck, global, &bonds));
        // Rank 0 picks the directory: every rank then reads the same one.
        let found = restart::directories(dir);
        let mut newest = [if comm.rank() == 0 {
            found.last().map_or(0.0, |&(n, _)| n as f64)
        } else {
            0.0
        }];
        comm.sum(&mut newest);
        let newest = newest[0] as u64;
        let mut restarts = Self {
            dir: dir.to_path_buf(),
            every_steps: settings.every_steps,
            every_seconds: settings.every_seconds,
            last_write: Instant::now(),
            next_number: newest + 1,
            model_hash,
            solvers_hash: restart::solvers_hash(deck),
            owned,
            broken_offset: None,
            resume: None,
            first_solver: 0,
            saved_start: false,
        };
        if newest == 0 {
            return Ok((restarts, Start::Fresh));
        }
        let newest = restart::directory(dir, newest);
        let file = newest.join(restart::FILE_NAME);
        let ranks_note = if comm.size() > 1 {
            " (every rank reads it: the output folder must be on a file system every rank sees)"
        } else {
            ""
        };
        let snapshot = restart::read(&file).map_err(|e| {
            RunError::Restart(format!(
                "cannot read the newest restart file{ranks_note}: {e}. Remove {} to resume from the one before it, or every restart-* folder in {} to start over",
                newest.display(),
                dir.display()
            ))
        });
        let snapshot = agree(comm, snapshot)?;
        let body = if snapshot.displacement.len() != global.points.len() {
            Err(RunError::Restart(format!(
                "{} was written for a body of {} points, but this deck's mesh now has {}: the mesh file has changed since. Restore the mesh it was written with, or remove the restart-* folders in {} to start over",
                file.display(),
                snapshot.displacement.len(),
                global.points.len(),
                dir.display()
            )))
        } else if comm.rank() == 0 && snapshot.model_hash != restarts.model_hash {
            Err(RunError::Restart(format!(
                "{} was written for another body: the deck's mesh, materials, damage models, blocks, contact or boundary conditions have changed since (hash {:016x}, this deck {:016x}). Restore the deck it was written with, or remove the restart-* folders in {} to start over",
                file.display(),
                snapshot.model_hash,
                restarts.model_hash,
                dir.display()
            )))
        } else {
            Ok(())
        };
        agree(comm, body)?;
        let root = comm.rank() == 0;
        if snapshot.solvers_hash == restarts.solvers_hash
            && snapshot.position.solver < deck.solvers.len()
        {
            restarts.first_solver = snapshot.position.solver;
            if root {
                eprintln!(
                    "restart: continuing from {} (solver \"{}\", step {}, t = {:e} s)",
                    newest.display(),
                    deck.solvers[snapshot.position.solver].name,
                    snapshot.position.step,
                    snapshot.time
                );
            }
            return Ok((restarts, Start::Continue(snapshot)));
        }
        let initial = deck.solvers.first().map_or(0.0, |s| s.initial_time);
        let scale = initial
            .abs()
            .max(snapshot.time.abs())
            .max(f64::MIN_POSITIVE);
        if (initial - snapshot.time).abs() > 1e-12 * scale {
            let complete = snapshot.solvers_hash == restarts.solvers_hash;
            // Every rank sees this alike: rank 0 reports it.
            return Err(collective(comm, RunError::Restart(format!(
                "{} holds the state at t = {:e} s, but the first solver of this deck starts at Initial Time {:e} s{}. Give the first solver Initial Time {:e} to continue from it, or remove the restart-* folders in {} to start over",
                file.display(),
                snapshot.time,
                initial,
                if complete { " (this deck's run is complete)" } else { "" },
                snapshot.time,
                dir.display()
            ))));
        }
        if root {
            eprintln!(
                "restart: starting from the state in {} (t = {:e} s)",
                newest.display(),
                snapshot.time
            );
        }
        Ok((restarts, Start::FromState(snapshot)))
    }

    /// Puts the state of `snapshot` into `state` (this rank's points, owned and ghosts).
    /// Collective.
    pub fn apply(
        &self,
        snapshot: &Snapshot,
        model: &Model,
        physics: &Physics,
        comm: &dyn Communicator,
        state: &mut State,
    ) -> Result<(), RunError> {
        let contact = physics.contact.as_ref();
        let applied = restart::apply(snapshot, model, &self.owned, contact, state).map_err(
            |problem| {
                RunError::Restart(format!(
                    "the restart file does not fit this run: {problem}; remove the restart-* folders in {} to start over",
                    self.dir.display()
                ))
            },
        );
        if let (Some(restore), Some(contact)) = (agree(comm, applied)?, contact) {
            restart::restore_contact(restore, model, contact, comm, state);
        }
        Ok(())
    }

    /// On N ranks: the summary's broken bonds are counted from now on as `carried` (those of
    /// the run continued) plus the bonds broken in the owned rows since now. Collective.
    pub fn count_broken_bonds(
        &mut self,
        model: &Model,
        comm: &dyn Communicator,
        state: &State,
        carried: usize,
    ) {
        let mut now = [broken_in(model, &self.owned, state) as f64];
        comm.sum(&mut now);
        self.broken_offset = Some(carried as i64 - now[0] as i64);
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

    /// True when step `step` of a list (1-based: explicit or Newmark-β step, accepted load
    /// step of a quasi-static one)
    /// is followed by a restart file: every `Frequency` steps, or once `Wall Clock Interval`
    /// has passed since the last (by rank 0's clock, so that every rank agrees). Collective
    /// when `Wall Clock Interval` is set.
    pub fn due(&self, step: u64, comm: &dyn Communicator) -> bool {
        if self.every_steps.is_some_and(|n| step % n == 0) {
            return true;
        }
        let Some(interval) = self.every_seconds else {
            return false;
        };
        let mut elapsed = [if comm.rank() == 0 {
            self.last_write.elapsed().as_secs_f64()
        } else {
            0.0
        }];
        comm.sum(&mut elapsed);
        elapsed[0] >= interval
    }

    /// Writes the next restart directory: `state` with where the run stands (`record`).
    /// Every rank's points are gathered on rank 0, which writes; every rank returns the
    /// directory, and rank 0 alone a failure to write (the caller agrees on it). Collective.
    pub fn write(
        &mut self,
        comm: &dyn Communicator,
        model: &Model,
        physics: &Physics,
        state: &State,
        record: Record,
    ) -> Result<PathBuf, RunError> {
        let broken = self.broken_offset.map(|offset| {
            let mut now = [broken_in(model, &self.owned, state) as f64];
            comm.sum(&mut now);
            (now[0] as i64 + offset).max(0) as u64
        });
        let share = restart::capture(model, &self.owned, physics.contact.as_ref(), state);
        let gathered = restart::gather(comm, share);
        let number = self.next_number;
        self.next_number += 1;
        self.last_write = Instant::now();
        let Some(mut snapshot) = gathered else {
            return Ok(restart::directory(&self.dir, number));
        };
        snapshot.model_hash = self.model_hash;
        snapshot.solvers_hash = self.solvers_hash;
        snapshot.position = record.position;
        (snapshot.outputs, snapshot.solver_rows) = record.outputs;
        snapshot.steps = record.summary.steps;
        snapshot.broken_bonds = broken.unwrap_or(record.summary.broken_bonds as u64);
        match record.inside {
            Inside::Boundary => {}
            Inside::Explicit { monitor, steps } => {
                snapshot.monitor = Some(monitor);
                snapshot.steps += steps;
            }
            Inside::LoadSteps(position) => {
                snapshot.load_schedule = Some(LoadSchedule {
                    times: position.times.clone(),
                    next: position.next,
                    total_cuts: position.total_cuts,
                    accepted: position.accepted,
                });
            }
        }
        restart::write_directory(&self.dir, number, &snapshot)
            .map_err(|e| RunError::RestartWrite(format!("cannot write a restart file: {e}")))
    }
}

/// Where the run stands when a restart file is written, besides its state.
pub(super) struct Record<'a> {
    /// The solver list and step.
    pub position: Position,
    /// Where inside the list.
    pub inside: Inside<'a>,
    /// The results files' positions and the solver CSV's rows
    /// ([`super::outputs::RunOutputs::positions`]).
    pub outputs: (Vec<OutputPosition>, u64),
    /// The run's counts so far.
    pub summary: &'a RunSummary,
}

/// Where a snapshot written inside a list resumes it.
pub(super) fn resume_of(snapshot: &Snapshot) -> Resume {
    Resume {
        step: snapshot.position.step,
        monitor: snapshot.monitor,
        load_steps: snapshot
            .load_schedule
            .as_ref()
            .map(|schedule| LoadStepPosition {
                times: schedule.times.clone(),
                next: schedule.next,
                total_cuts: schedule.total_cuts,
                accepted: schedule.accepted,
            }),
    }
}
