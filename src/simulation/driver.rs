//! The one driver of a run, on one rank or on N: the deck's solver lists in order over one
//! state, each run by its integrator ([`crate::solver::integrator`]) through the same code
//! whatever the number of ranks; only [`Ranks`] and [`RunOutputs`] know how many there are.
//!
//! The driver knows no integrator by name. It gives each list a [`ListRun`] whose [`Driver`]
//! services ([`Services`]) keep what outlives the list: the output frames, the solver CSV, the
//! restart files (after every list, and inside one when due), the run's counts and the
//! agreement of the ranks on a failure.

use super::agreement::{agree, agree_on_failure, collective};
use super::outputs::RunOutputs;
use super::restarts::{resume_of, Record, Restarts};
use super::{energy_floor_of, Fields, PreparedComputeClass, RunError, RunSummary};
use crate::interrupt;
use crate::io::deck::Deck;
use crate::io::output::FieldSource;
use crate::model::Model;
use crate::parallel::Ranks;
use crate::physics::Physics;
use crate::restart::Position;
use crate::setup::solvers::solver_lists;
use crate::solver::list_run::{
    Driver, Failure, ImplicitStep, Inside, ListRun, RestartAt, Resume, Stop,
};
use crate::solver::{EnergyMonitor, SolverList};
use crate::state::State;
use std::path::PathBuf;
use std::time::Instant;

/// A run in progress on one rank (of one or N): what every solver reads and writes to.
pub(super) struct Run<'a> {
    /// This rank's model: the whole model on one rank, owned points and ghosts on N.
    pub model: &'a Model,
    /// The other ranks.
    pub ranks: &'a mut dyn Ranks,
    /// `ghost[p]` for every local point of a distributed run, `None` on one rank.
    pub ghosts: Option<Vec<bool>>,
    /// The deck's compute classes.
    pub compute_classes: &'a [PreparedComputeClass],
    /// Where the results go.
    pub outputs: RunOutputs<'a>,
    /// What the run reports at the end.
    pub summary: RunSummary,
    /// Newton iterations of the last accepted implicit step (`Nonlinear_Solver_Iterations`).
    pub nonlinear_iterations: Option<f64>,
    /// The restart files, when the deck asks for them.
    pub restarts: Option<Restarts>,
    /// An output failure of an explicit step on N ranks, not agreed on yet.
    pending: Option<RunError>,
}

impl<'a> Run<'a> {
    /// A run of this rank's `model` that has not started.
    pub fn new(
        model: &'a Model,
        ranks: &'a mut dyn Ranks,
        ghosts: Option<Vec<bool>>,
        compute_classes: &'a [PreparedComputeClass],
        outputs: RunOutputs<'a>,
    ) -> Self {
        Self {
            model,
            ranks,
            ghosts,
            compute_classes,
            outputs,
            summary: RunSummary::default(),
            nonlinear_iterations: None,
            restarts: None,
            pending: None,
        }
    }

    /// The same run writing (and perhaps resuming from) `restarts`.
    pub fn with_restarts(mut self, restarts: Option<Restarts>) -> Self {
        self.restarts = restarts;
        self
    }

    /// Runs every solver list of `deck` in order, then closes the results files: the summary,
    /// or the error to report ([`Run::finish`], [`Run::abandon`]).
    pub fn complete(
        mut self,
        deck: &Deck,
        physics: &mut Physics,
        state: &mut State,
    ) -> Result<RunSummary, RunError> {
        match self.solve(deck, physics, state) {
            Ok(()) => self.finish(),
            Err(error) => Err(self.abandon(error)),
        }
    }
}

impl Run<'_> {
    /// Runs every solver list of `deck` in order ([`solver_lists`]), writing a restart file
    /// after each when the deck asks for them. On failure the results files are closed
    /// (frames written so far stay readable) and the error returned.
    pub fn solve(
        &mut self,
        deck: &Deck,
        physics: &mut Physics,
        state: &mut State,
    ) -> Result<(), RunError> {
        for (index, list) in solver_lists(deck).iter().enumerate() {
            if self.restarts.as_ref().is_some_and(|r| r.skips(index)) {
                continue;
            }
            let start = Instant::now();
            let result = self.run_list(list, index, physics, state);
            self.summary.solve_seconds += start.elapsed().as_secs_f64();
            result?;
            let Some(restarts) = &mut self.restarts else {
                continue;
            };
            let record = Record {
                position: Position {
                    solver: index + 1,
                    step: 0,
                },
                inside: Inside::Boundary,
                outputs: self.outputs.positions(),
                summary: &self.summary,
            };
            let comm = self.ranks.communicator();
            let written = restarts.write(comm, self.model, physics, state, record);
            let directory = agree(comm, written)?;
            if self.ranks.rank() == 0 {
                eprintln!(
                    "{}: restart written to {}",
                    list.settings.name,
                    directory.display()
                );
            }
        }
        Ok(())
    }

    /// Runs list `list`, the deck's list `index`, through its integrator.
    fn run_list(
        &mut self,
        list: &SolverList,
        index: usize,
        physics: &mut Physics,
        state: &mut State,
    ) -> Result<(), RunError> {
        let Run {
            model,
            ranks,
            ghosts,
            compute_classes,
            outputs,
            summary,
            nonlinear_iterations,
            restarts,
            pending,
        } = self;
        let mut services = Services {
            model,
            compute_classes,
            outputs,
            summary,
            nonlinear_iterations,
            restarts,
            pending,
        };
        let mut run = ListRun {
            model,
            physics,
            state,
            ranks: &mut **ranks,
            ghosts: ghosts.as_deref(),
            driver: &mut services,
            index: Some(index),
        };
        list.integrator
            .run(&list.settings, &mut run)
            .map_err(run_error_of)
    }

    /// Closes the results files after `error` (frames written so far stay readable) and
    /// returns the error to report: on one rank a failure to close comes first.
    pub fn abandon(self, error: RunError) -> RunError {
        match (self.ranks.ranks(), self.outputs.finish()) {
            (1, Err(closing)) => closing,
            _ => error,
        }
    }

    /// Closes the results files and completes the summary. Collective.
    pub fn finish(self) -> Result<RunSummary, RunError> {
        let mut summary = self.summary;
        summary.output_seconds = self.outputs.seconds();
        summary.solve_seconds -= summary.output_seconds.min(summary.solve_seconds);
        summary.files = agree(self.ranks.communicator(), self.outputs.finish())?;
        Ok(summary)
    }
}

/// The run error a failure of an integrator is.
fn run_error(failure: Failure) -> RunError {
    match failure {
        Failure::QuasiStatic(error) => RunError::QuasiStatic(error),
        Failure::Newmark(error) => RunError::Newmark(error),
        Failure::Boundary(error) => RunError::Boundary(error),
        Failure::Unsupported(message) => RunError::Unsupported(message),
        Failure::Input(message) => RunError::Input(message),
        Failure::Unstable(unstable) => RunError::Unstable {
            solver: unstable.solver,
            instability: unstable.instability,
            time_step: unstable.time_step,
            estimate: unstable.estimate,
            measured: unstable.measured,
        },
    }
}

/// The stop that carries `error` through the integrator.
fn stop(error: RunError) -> Stop {
    Stop(Box::new(error))
}

/// The run error a stop carries (every stop the driver makes carries one).
fn run_error_of(stop: Stop) -> RunError {
    match stop.0.downcast::<RunError>() {
        Ok(error) => *error,
        Err(other) => RunError::Unsupported(other.to_string()),
    }
}

/// True when SIGINT or SIGTERM reached any rank ([`crate::interrupt`]). Collective.
fn signalled(ranks: &mut dyn Ranks) -> bool {
    let mut stop = [f64::from(u8::from(interrupt::requested().is_some()))];
    ranks.sum(&mut stop);
    stop[0] > 0.0
}

/// The driver's services to the list being run: the parts of [`Run`] that outlive it.
struct Services<'r, 'a> {
    model: &'a Model,
    compute_classes: &'a [PreparedComputeClass],
    outputs: &'r mut RunOutputs<'a>,
    summary: &'r mut RunSummary,
    nonlinear_iterations: &'r mut Option<f64>,
    restarts: &'r mut Option<Restarts>,
    pending: &'r mut Option<RunError>,
}

impl<'a> Services<'_, 'a> {
    /// The fields of an output frame of `state`.
    fn fields<'f>(&self, physics: &'f Physics, state: &'f State) -> Fields<'f>
    where
        'a: 'f,
    {
        let mut fields = Fields::new(self.model, physics, state, self.compute_classes);
        fields.nonlinear_iterations = *self.nonlinear_iterations;
        fields
    }

    /// One output call. Collective on N ranks; a failure to write is returned for the caller
    /// to agree on.
    fn output(
        &mut self,
        ranks: &dyn Ranks,
        physics: &Physics,
        state: &State,
    ) -> Result<(), RunError> {
        let fields = self.fields(physics, state);
        self.outputs.call(ranks, &fields)
    }
}

impl Driver for Services<'_, '_> {
    fn resume(&mut self, index: usize) -> Option<Resume> {
        let snapshot = self.restarts.as_mut()?.take_resume(index)?;
        Some(resume_of(&snapshot))
    }

    fn take_saved_start(&mut self) -> bool {
        self.restarts
            .as_mut()
            .is_some_and(Restarts::take_saved_start)
    }

    fn clear_iterations(&mut self) {
        *self.nonlinear_iterations = None;
    }

    fn frame(
        &mut self,
        ranks: &mut dyn Ranks,
        physics: &Physics,
        state: &State,
        ready: Result<(), Failure>,
    ) -> Result<(), Stop> {
        let written = ready
            .map_err(run_error)
            .and_then(|()| self.output(&*ranks, physics, state));
        agree(ranks.communicator(), written).map_err(stop)
    }

    fn explicit_frame(
        &mut self,
        ranks: &dyn Ranks,
        physics: &Physics,
        state: &State,
    ) -> Result<bool, Stop> {
        match self.output(ranks, physics, state) {
            Err(error) if ranks.ranks() == 1 => Err(stop(error)),
            written => {
                *self.pending = written.err();
                Ok(self.pending.is_some())
            }
        }
    }

    fn settle(&mut self, ranks: &dyn Ranks) -> Result<(), Stop> {
        let pending = self.pending.take().map_or(Ok(()), Err);
        agree(ranks.communicator(), pending).map_err(stop)
    }

    fn implicit_step(
        &mut self,
        ranks: &mut dyn Ranks,
        physics: &Physics,
        state: &State,
        step: &ImplicitStep,
    ) -> Result<(), Stop> {
        let (newton, number) = (step.newton, step.restart.step);
        self.summary.steps += 1;
        self.summary.broken_bonds += newton.broken_bonds;
        *self.nonlinear_iterations = Some(newton.iterations as f64);
        // Both are collective: each runs on every rank before the agreement.
        let recorded = self
            .outputs
            .record(ranks, step.time, number as usize, newton);
        let written = self.output(&*ranks, physics, state);
        agree(ranks.communicator(), recorded.and(written)).map_err(stop)?;
        let signalled = signalled(ranks);
        let restart = self.restart(&*ranks, physics, state, step.restart, signalled)?;
        if signalled {
            let list = (step.list, number);
            return Err(self.stop_on_signal(&*ranks, physics, state, list, restart));
        }
        Ok(())
    }

    fn restart(
        &mut self,
        ranks: &dyn Ranks,
        physics: &Physics,
        state: &State,
        at: RestartAt,
        signalled: bool,
    ) -> Result<Option<PathBuf>, Stop> {
        let comm = ranks.communicator();
        let (Some(index), Some(restarts)) = (at.index, self.restarts.as_mut()) else {
            return Ok(None);
        };
        if !(signalled || (at.may_be_due && restarts.due(at.step, comm))) {
            return Ok(None);
        }
        let record = Record {
            position: Position {
                solver: index,
                step: at.step,
            },
            inside: at.inside,
            outputs: self.outputs.positions(),
            summary: self.summary,
        };
        let written = restarts.write(comm, self.model, physics, state, record);
        agree(comm, written).map(Some).map_err(stop)
    }

    fn stop_on_signal(
        &mut self,
        ranks: &dyn Ranks,
        physics: &Physics,
        state: &State,
        (list, step): (&str, u64),
        restart: Option<PathBuf>,
    ) -> Stop {
        let restart = restart.ok_or_else(|| match self.restarts {
            None => "the deck has no Restart entry".to_string(),
            Some(_) => format!("\"{list}\" continues a failed list and writes none"),
        });
        let comm = ranks.communicator();
        let fields = self.fields(physics, state);
        let written = self.outputs.last_frame(ranks, &fields);
        if let Err(error) = agree(comm, written) {
            return stop(error);
        }
        let error = RunError::Interrupted {
            signal: interrupt::requested(),
            solver: list.to_string(),
            step,
            time: state.time,
            files: self.outputs.paths(),
            restart,
        };
        stop(collective(comm, error))
    }

    fn energy_monitor(
        &mut self,
        ranks: &mut dyn Ranks,
        physics: &Physics,
        state: &State,
    ) -> EnergyMonitor {
        let model = self.model;
        let owned = |p: usize| !ranks.is_ghost(p);
        let fields = Fields::new(model, physics, state, &[]);
        let energy = ["Kinetic_Energy", "Stored_Elastic_Energy"]
            .iter()
            .filter_map(|name| fields.scalar(name))
            .map(|values| {
                (0..values.len())
                    .filter(|&p| owned(p))
                    .map(|p| values[p])
                    .sum::<f64>()
            })
            .sum();
        let floor = energy_floor_of(physics, |p| {
            if owned(p as usize) {
                model.points.volume[p as usize]
            } else {
                0.0
            }
        });
        let mut energies = [energy, floor];
        ranks.sum(&mut energies);
        EnergyMonitor::new(energies[0], energies[1])
    }

    fn count(&mut self, steps: i64, broken_bonds: usize) {
        let steps_now = self.summary.steps;
        self.summary.steps = match u64::try_from(steps) {
            Ok(added) => steps_now + added,
            Err(_) => steps_now - steps.unsigned_abs().min(steps_now),
        };
        self.summary.broken_bonds += broken_bonds;
    }

    fn collective(&mut self, ranks: &dyn Ranks, failure: Failure) -> Stop {
        stop(collective(ranks.communicator(), run_error(failure)))
    }

    fn agree_on_failure(&mut self, ranks: &dyn Ranks, local: Option<Failure>) -> Stop {
        let local = local.map(run_error).or_else(|| self.pending.take());
        stop(agree_on_failure(ranks.communicator(), local))
    }

    fn agree(&mut self, ranks: &dyn Ranks, result: Result<(), Failure>) -> Result<(), Stop> {
        agree(ranks.communicator(), result.map_err(run_error)).map_err(stop)
    }
}
