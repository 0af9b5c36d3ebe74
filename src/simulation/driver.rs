//! The one driver of a run, on one rank or on N: the deck's solver lists in order over one
//! state, each through the same code whatever the number of ranks; only [`Ranks`] and
//! [`RunOutputs`] know how many there are.

use super::agreement::{agree, agree_on_failure, collective};
use super::outputs::RunOutputs;
use super::progress::Progress;
use super::restarts::{load_step_position, Inside, Restarts};
use super::{energy_floor_of, Fields, PreparedComputeClass, RunError, RunSummary};
use crate::backend::SolveError;
use crate::interrupt;
use crate::io::deck::{Deck, Implicit, Integrator, Solver, Verlet};
use crate::io::output::FieldSource;
use crate::model::Model;
use crate::parallel::Ranks;
use crate::physics::Physics;
use crate::restart::Position;
use crate::solver::newmark::{self, NewmarkError, NewmarkSettings};
use crate::solver::newton::ConvergenceMeasure;
use crate::solver::quasistatic::{self, QuasiStaticError, QuasiStaticSettings};
use crate::solver::{
    linear, stability, step_count, EnergyMonitor, VelocityVerlet, VerletSettings, MAX_STEPS,
};
use crate::state::State;
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
    /// Runs every solver list of `deck` in order. On failure the results files are closed
    /// (frames written so far stay readable) and the error returned.
    pub fn solve(
        &mut self,
        deck: &Deck,
        physics: &mut Physics,
        state: &mut State,
    ) -> Result<(), RunError> {
        for (index, solver) in deck.solvers.iter().enumerate() {
            if self.restarts.as_ref().is_some_and(|r| r.skips(index)) {
                continue;
            }
            let start = Instant::now();
            let result = match &solver.integrator {
                Integrator::Verlet(verlet) => {
                    self.verlet(solver, verlet, Some(index), physics, state)
                }
                Integrator::QuasiStatic(_) | Integrator::NoxQuasiStatic(_) => {
                    self.quasi_static(solver, index, physics, state)
                }
                Integrator::Implicit(implicit) => {
                    self.newmark(solver, index, implicit, physics, state)
                }
                Integrator::ImplicitDiffusion(_) => Err(RunError::Unsupported(format!(
                    "solver \"{}\": ImplicitDiffusion is not available in this build",
                    solver.name
                ))),
            };
            self.summary.solve_seconds += start.elapsed().as_secs_f64();
            result?;
            if let Some(restarts) = &mut self.restarts {
                let position = Position {
                    solver: index + 1,
                    step: 0,
                };
                let written = restarts.write(
                    self.ranks.communicator(),
                    self.model,
                    physics,
                    state,
                    &self.outputs,
                    &self.summary,
                    position,
                    Inside::Boundary,
                );
                let directory = agree(self.ranks.communicator(), written)?;
                if self.root() {
                    eprintln!(
                        "{}: restart written to {}",
                        solver.name,
                        directory.display()
                    );
                }
            }
        }
        Ok(())
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

    /// Why a stop inside an explicit list wrote no restart file.
    fn no_restart_reason(&self, index: Option<usize>) -> String {
        match (&self.restarts, index) {
            (None, _) => "the deck has no Restart entry".to_string(),
            (Some(_), _) => {
                "the explicit end of a quasi-static list (Switch to Verlet) writes none".to_string()
            }
        }
    }

    fn root(&self) -> bool {
        self.ranks.rank() == 0
    }

    /// `" on N ranks"` for the log lines of a distributed run, empty on one rank.
    fn on_ranks(&self) -> String {
        match self.ranks.ranks() {
            1 => String::new(),
            n => format!(" on {n} ranks"),
        }
    }

    /// One output call. Collective on N ranks; a failure to write is returned for the caller
    /// to agree on.
    fn output(&mut self, physics: &Physics, state: &State) -> Result<(), RunError> {
        let mut fields = Fields::new(self.model, physics, state, self.compute_classes);
        fields.nonlinear_iterations = self.nonlinear_iterations;
        self.outputs.call(&*self.ranks, &fields)
    }

    /// One `Verlet` solver list, list `index` of the deck (`None` for the explicit end of a
    /// quasi-static list, `Switch to Verlet`, which neither writes nor resumes restart files
    /// inside it).
    fn verlet(
        &mut self,
        solver: &Solver,
        verlet: &Verlet,
        index: Option<usize>,
        physics: &mut Physics,
        state: &mut State,
    ) -> Result<(), RunError> {
        let model = self.model;
        let estimate = self.critical_time_step(physics);
        let time_step = verlet_time_step(solver, verlet, estimate)
            .map_err(|error| collective(self.ranks.communicator(), error))?;
        let steps = run_steps(solver, time_step)
            .map_err(|error| collective(self.ranks.communicator(), error))?;
        let root = self.root();
        if root {
            eprintln!(
                "{}: Verlet, Δt = {time_step:e} s (stable estimate {}, safety factor {}), {steps} steps",
                solver.name,
                estimate.map(|e| format!("{e:e} s")).unwrap_or_else(|| "n/a".into()),
                verlet.safety_factor
            );
        }
        let mut integrator = VelocityVerlet::new(
            model,
            VerletSettings {
                time_step,
                steps,
                initial_time: solver.initial_time,
            },
        );
        if let Some(ghosts) = &self.ghosts {
            integrator = integrator.with_ghosts(ghosts.clone());
        }
        if let (1, Some(contact)) = (self.ranks.ranks(), &physics.contact) {
            eprintln!(
                "{}: contact: search radius {:e} (skin rule: search again when a point moves {:e}), {} contact points",
                solver.name,
                contact.search_radius(),
                0.5 * (contact.search_radius() - contact.max_contact_radius()),
                contact.points().len()
            );
        }
        let resume = match (index, &mut self.restarts) {
            (Some(index), Some(restarts)) => restarts.take_resume(index),
            _ => None,
        };
        let saved_start = index == Some(0)
            && self
                .restarts
                .as_mut()
                .is_some_and(Restarts::take_saved_start);
        let (first, mut monitor, mut pending) = match &resume {
            // Continued from a restart file inside this list: the state, monitor and output
            // frames are those after step k, so the list goes on with step k + 1.
            Some(snapshot) => {
                let mut monitor = self.energy_monitor(physics, state);
                if let Some(energies) = snapshot.monitor {
                    monitor.restore(energies);
                }
                self.summary.steps -= snapshot.position.step.min(self.summary.steps);
                (snapshot.position.step + 1, monitor, None)
            }
            // Started from a saved state (Peridigm's restart): its acceleration is the one the
            // uninterrupted run goes on with, so the forces are not evaluated again (that
            // would round differently); the list starts at its Initial Time.
            None if saved_start => {
                state.time = solver.initial_time;
                state.drop_committed();
                state.history.set_step_duration(time_step);
                let monitor = self.energy_monitor(physics, state);
                (1, monitor, self.output_or_return(physics, state)?)
            }
            None => {
                let initialized = integrator.initialize_with(model, physics, state, self.ranks);
                agree(
                    self.ranks.communicator(),
                    initialized.map_err(RunError::from),
                )?;
                let monitor = self.energy_monitor(physics, state);
                (1, monitor, self.output_or_return(physics, state)?)
            }
        };
        let mut progress = root.then(|| Progress::new(&solver.name, steps));
        for step in first..=steps {
            let result = integrator.step_with(model, physics, state, step, self.ranks);
            let stop = f64::from(u8::from(interrupt::requested().is_some()));
            let mut sums = match &result {
                Ok(report) => [
                    report.free_kinetic_energy,
                    report.supplied_work,
                    f64::from(u8::from(pending.is_some())),
                    stop,
                ],
                Err(_) => [0.0, 0.0, 1.0, stop],
            };
            self.ranks.sum(&mut sums);
            if sums[2] > 0.0 {
                if let Some(progress) = progress.take() {
                    progress.finish();
                }
                let local = match result {
                    Err(error) => Some(error.into()),
                    Ok(_) => pending.take(),
                };
                return Err(agree_on_failure(self.ranks.communicator(), local));
            }
            if let Ok(report) = result {
                self.summary.broken_bonds += report.broken_bonds;
            }
            monitor.add_work(sums[1]);
            if let Err(instability) = monitor.check(step, state.time, sums[0]) {
                if let Some(progress) = progress.take() {
                    progress.finish();
                }
                // The diagnostic's force evaluations need no ghosts on one rank; on N ranks the
                // advice stays generic.
                let measured = (self.ranks.ranks() == 1).then(|| {
                    stability::measured_critical_time_step(
                        model,
                        physics,
                        &state.history,
                        stability::MEASURE_ITERATIONS,
                    )
                });
                let error = RunError::Unstable {
                    solver: solver.name.clone(),
                    instability,
                    time_step,
                    estimate,
                    measured: measured.flatten(),
                };
                return Err(collective(self.ranks.communicator(), error));
            }
            pending = self.output_or_return(physics, state)?;
            if let Some(progress) = &mut progress {
                progress.update(step);
            }
            let signalled = sums[3] > 0.0;
            let restart = match (index, &mut self.restarts) {
                (Some(index), Some(restarts))
                    if signalled
                        || (step < steps && restarts.due(step, self.ranks.communicator())) =>
                {
                    let written = restarts.write(
                        self.ranks.communicator(),
                        model,
                        physics,
                        state,
                        &self.outputs,
                        &self.summary,
                        Position {
                            solver: index,
                            step,
                        },
                        Inside::Explicit {
                            monitor: monitor.energies(),
                            steps: step,
                        },
                    );
                    Some(agree(self.ranks.communicator(), written)?)
                }
                _ => None,
            };
            if signalled {
                if let Some(progress) = progress.take() {
                    progress.finish();
                }
                agree(self.ranks.communicator(), pending.map_or(Ok(()), Err))?;
                self.summary.steps += step;
                let fields = Fields::new(model, physics, state, self.compute_classes);
                let restart = restart.ok_or_else(|| self.no_restart_reason(index));
                return Err(stop_on_signal(
                    &mut self.outputs,
                    &mut *self.ranks,
                    &fields,
                    solver,
                    step,
                    restart,
                ));
            }
        }
        if let Some(progress) = progress {
            progress.finish();
        }
        self.log_contact(solver, state);
        agree(self.ranks.communicator(), pending.map_or(Ok(()), Err))?;
        self.summary.steps += steps;
        Ok(())
    }

    /// One output call of an explicit step: on one rank a failure ends the run at once; on
    /// N ranks it is returned as pending, to be agreed on at the next collective.
    fn output_or_return(
        &mut self,
        physics: &Physics,
        state: &State,
    ) -> Result<Option<RunError>, RunError> {
        match self.output(physics, state) {
            Err(error) if self.ranks.ranks() == 1 => Err(error),
            written => Ok(written.err()),
        }
    }

    /// Peridigm's stable time step over the owned points of every block, minimum over ranks
    /// (`None` when no point has a neighbour). Collective.
    fn critical_time_step(&mut self, physics: &Physics) -> Option<f64> {
        let model = self.model;
        let reference = physics.reference(&model.bonds, &model.points);
        let ranks = &*self.ranks;
        let local = physics
            .blocks
            .iter()
            .filter_map(|block| {
                let material = &block.material;
                let owned: Vec<u32> = material
                    .points()
                    .iter()
                    .copied()
                    .filter(|&p| !ranks.is_ghost(p as usize))
                    .collect();
                crate::material::critical_time_step(
                    &reference,
                    &owned,
                    material.density(),
                    material.bulk_modulus(),
                    material.horizon(),
                )
            })
            .fold(f64::INFINITY, f64::min);
        let global = self.ranks.min(local);
        global.is_finite().then_some(global)
    }

    /// The stability monitor from the kinetic and stored energy of the owned points and the
    /// energy floor, summed over the ranks. Collective.
    fn energy_monitor(&mut self, physics: &Physics, state: &State) -> EnergyMonitor {
        let model = self.model;
        let ranks = &*self.ranks;
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
        self.ranks.sum(&mut energies);
        EnergyMonitor::new(energies[0], energies[1])
    }

    /// The contact statistics at the end of an explicit solver list (rank 0's share on N
    /// ranks, with the partner points it received).
    fn log_contact(&self, solver: &Solver, state: &State) {
        let Some(contact) = state.contact.as_ref().filter(|_| self.root()) else {
            return;
        };
        if self.ranks.ranks() == 1 {
            eprintln!("{}: contact: {}", solver.name, contact.statistics());
        } else {
            eprintln!(
                "{}: contact (rank 0's share): {}; partner points received from other ranks per step: {} since the last search, at most {}",
                solver.name,
                contact.statistics(),
                contact.received_partners().0,
                contact.received_partners().1
            );
        }
    }

    /// One quasi-static solver list: the load steps of [`crate::solver::quasistatic`], on N
    /// ranks with Trilinos NOX or PETSc SNES (`NOXQuasiStatic`) or peridyn's Newton with
    /// distributed Belos or KSP solves (`QuasiStatic`) over the owned unknowns, the ghosts refreshed before every
    /// residual evaluation. An unconverged step continues explicitly with `Switch to Verlet`.
    fn quasi_static(
        &mut self,
        solver: &Solver,
        index: usize,
        physics: &mut Physics,
        state: &mut State,
    ) -> Result<(), RunError> {
        let mut settings = quasi_static_settings(solver, index > 0)
            .map_err(|error| collective(self.ranks.communicator(), error))?;
        let resume = self
            .restarts
            .as_mut()
            .and_then(|restarts| restarts.take_resume(index));
        settings.resume = resume
            .as_ref()
            .and_then(|s| s.load_schedule.as_ref())
            .map(load_step_position);
        let mut nonlinear = linear::nonlinear_solver(solver, self.ranks.global_points())
            .map_err(|error| collective(self.ranks.communicator(), error.into()))?;
        if self.root() {
            eprintln!(
                "{}: {}, {} load steps{}, linear solver: {}",
                solver.name,
                solver.integrator.deck_name(),
                settings.times.len() - 1,
                self.on_ranks(),
                nonlinear.describe()
            );
        }
        self.nonlinear_iterations = None;
        // Continued from a restart file inside this list: the state and the output frames
        // are those after the saved load step.
        if resume.is_none() {
            state.time = solver.initial_time;
            // The initial frame shows the body force (and the temperature) at the initial time,
            // as Peridigm writes it.
            let initial = match &mut state.external_force_density {
                Some(b) => self
                    .model
                    .boundary
                    .body_force(&self.model.points.position, state.time, b)
                    .map_err(RunError::from),
                None => Ok(()),
            };
            let initial = initial.and_then(|()| {
                self.model
                    .boundary
                    .apply_temperature(&self.model.points.position, state.time, &mut state.history)
                    .map_err(RunError::from)
            });
            let written = initial.and_then(|()| self.output(physics, state));
            agree(self.ranks.communicator(), written)?;
        }
        let (model, ranks) = (self.model, &mut *self.ranks);
        let result = quasistatic::run(
            model,
            physics,
            state,
            &settings,
            nonlinear.as_mut(),
            ranks,
            |physics, state, ranks, report| -> Result<(), RunError> {
                self.summary.steps += 1;
                self.summary.broken_bonds += report.newton.broken_bonds;
                self.nonlinear_iterations = Some(report.newton.iterations as f64);
                // Both are collective: each runs on every rank before the agreement.
                let recorded = self
                    .outputs
                    .record(ranks, report.time, report.step, &report.newton);
                let mut fields = Fields::new(model, physics, state, self.compute_classes);
                fields.nonlinear_iterations = self.nonlinear_iterations;
                let written = self.outputs.call(ranks, &fields);
                agree(ranks.communicator(), recorded.and(written))?;
                let step = report.step as u64;
                let stop = signalled(ranks);
                let restart = match &mut self.restarts {
                    Some(restarts) if stop || restarts.due(step, ranks.communicator()) => {
                        let written = restarts.write(
                            ranks.communicator(),
                            model,
                            physics,
                            state,
                            &self.outputs,
                            &self.summary,
                            Position {
                                solver: index,
                                step,
                            },
                            Inside::QuasiStatic(&report.position),
                        );
                        Some(agree(ranks.communicator(), written)?)
                    }
                    _ => None,
                };
                if stop {
                    let restart =
                        restart.ok_or_else(|| "the deck has no Restart entry".to_string());
                    return Err(stop_on_signal(
                        &mut self.outputs,
                        ranks,
                        &fields,
                        solver,
                        step,
                        restart,
                    ));
                }
                Ok(())
            },
        );
        let switch = settings
            .adaptive
            .as_ref()
            .and_then(|a| a.switch_to_verlet.clone());
        match (result, switch) {
            (Ok(_), _) => Ok(()),
            // Every rank stops at the same call; the rank whose evaluation (or condition)
            // failed reports why, and every rank exits with its code.
            (
                Err(RunError::QuasiStatic(QuasiStaticError::Solve {
                    source: SolveError::OtherRank,
                    ..
                })),
                _,
            ) => Err(agree_on_failure(self.ranks.communicator(), None)),
            (
                Err(
                    error @ RunError::QuasiStatic(
                        QuasiStaticError::Solve { .. } | QuasiStaticError::Boundary(_),
                    ),
                ),
                _,
            ) => Err(agree_on_failure(self.ranks.communicator(), Some(error))),
            (
                Err(RunError::QuasiStatic(error @ QuasiStaticError::NotConverged { .. })),
                Some(verlet),
            ) => {
                if self.root() {
                    eprintln!(
                        "Warning: {error}\n{}: switching to Verlet from t = {:e} to the solver's final time {:e}",
                        solver.name, state.time, solver.final_time
                    );
                }
                let explicit = Solver {
                    name: format!("{} (Switch to Verlet)", solver.name),
                    initial_time: state.time,
                    ..solver.clone()
                };
                let settings = Verlet {
                    fixed_dt: verlet.fixed_dt,
                    safety_factor: verlet.safety_factor,
                };
                self.verlet(&explicit, &settings, None, physics, state)
            }
            (Err(error @ RunError::QuasiStatic(QuasiStaticError::NotConverged { .. })), None) => {
                Err(collective(self.ranks.communicator(), error))
            }
            (Err(error), _) => Err(error),
        }
    }

    /// One `Implicit` (Newmark-β) solver list: the steps of [`crate::solver::newmark`] with
    /// peridyn's Newton (or PETSc's SNES with `Nonlinear Solver: "SNES"`), on N ranks with
    /// distributed Belos or KSP solves over the owned unknowns, the ghosts refreshed before
    /// every residual evaluation.
    fn newmark(
        &mut self,
        solver: &Solver,
        index: usize,
        implicit: &Implicit,
        physics: &mut Physics,
        state: &mut State,
    ) -> Result<(), RunError> {
        let mut settings = newmark_settings(solver, implicit)
            .map_err(|error| collective(self.ranks.communicator(), error))?;
        let resume = self
            .restarts
            .as_mut()
            .and_then(|restarts| restarts.take_resume(index));
        if let Some(snapshot) = &resume {
            settings.first_step = snapshot.position.step + 1;
        }
        let mut nonlinear = linear::nonlinear_solver(solver, self.ranks.global_points())
            .map_err(|error| collective(self.ranks.communicator(), error.into()))?;
        if self.root() {
            eprintln!(
                "{}: Implicit (Newmark-β, β = {}, γ = {}), Δt = {:e} s, {} steps{}, linear solver: {}",
                solver.name,
                settings.beta,
                settings.gamma,
                settings.time_step,
                settings.steps,
                self.on_ranks(),
                nonlinear.describe()
            );
        }
        self.nonlinear_iterations = None;
        // Continued from a restart file inside this list: the state and the output frames
        // are those after the saved step.
        if resume.is_none() {
            state.time = solver.initial_time;
            let written = self.output(physics, state);
            agree(self.ranks.communicator(), written)?;
        }
        let (model, ranks) = (self.model, &mut *self.ranks);
        let steps = settings.steps;
        let result = newmark::run(
            model,
            physics,
            state,
            &settings,
            nonlinear.as_mut(),
            ranks,
            |physics, state, ranks, step, report| -> Result<(), RunError> {
                self.summary.steps += 1;
                self.summary.broken_bonds += report.broken_bonds;
                self.nonlinear_iterations = Some(report.iterations as f64);
                // Both are collective: each runs on every rank before the agreement.
                let recorded = self
                    .outputs
                    .record(ranks, state.time, step as usize, report);
                let mut fields = Fields::new(model, physics, state, self.compute_classes);
                fields.nonlinear_iterations = self.nonlinear_iterations;
                let written = self.outputs.call(ranks, &fields);
                agree(ranks.communicator(), recorded.and(written))?;
                let stop = signalled(ranks);
                let restart = match &mut self.restarts {
                    Some(restarts)
                        if stop || (step < steps && restarts.due(step, ranks.communicator())) =>
                    {
                        let written = restarts.write(
                            ranks.communicator(),
                            model,
                            physics,
                            state,
                            &self.outputs,
                            &self.summary,
                            Position {
                                solver: index,
                                step,
                            },
                            Inside::Boundary,
                        );
                        Some(agree(ranks.communicator(), written)?)
                    }
                    _ => None,
                };
                if stop {
                    let restart =
                        restart.ok_or_else(|| "the deck has no Restart entry".to_string());
                    return Err(stop_on_signal(
                        &mut self.outputs,
                        ranks,
                        &fields,
                        solver,
                        step,
                        restart,
                    ));
                }
                Ok(())
            },
        );
        match result {
            Ok(()) => Ok(()),
            // Every rank stops at the same call; the rank whose evaluation (or condition)
            // failed reports why, and every rank exits with its code.
            Err(RunError::Newmark(NewmarkError::Solve {
                source: SolveError::OtherRank,
                ..
            })) => Err(agree_on_failure(self.ranks.communicator(), None)),
            Err(
                error @ RunError::Newmark(NewmarkError::Solve { .. } | NewmarkError::Boundary(_)),
            ) => Err(agree_on_failure(self.ranks.communicator(), Some(error))),
            Err(error @ RunError::Newmark(NewmarkError::NotConverged { .. })) => {
                Err(collective(self.ranks.communicator(), error))
            }
            Err(error) => Err(error),
        }
    }
}

/// True when SIGINT or SIGTERM reached any rank ([`crate::interrupt`]). Collective.
fn signalled(ranks: &mut dyn Ranks) -> bool {
    let mut stop = [f64::from(u8::from(interrupt::requested().is_some()))];
    ranks.sum(&mut stop);
    stop[0] > 0.0
}

/// After the step a signal made the last (`step` of `solver`, its output call made): adds
/// its frame to every file whose schedule skipped it and returns the error that stops the
/// run, reported by rank 0. Collective.
fn stop_on_signal(
    outputs: &mut RunOutputs,
    ranks: &mut dyn Ranks,
    fields: &Fields,
    solver: &Solver,
    step: u64,
    restart: Result<std::path::PathBuf, String>,
) -> RunError {
    let written = outputs.last_frame(&*ranks, fields);
    if let Err(error) = agree(ranks.communicator(), written) {
        return error;
    }
    let error = RunError::Interrupted {
        signal: interrupt::requested(),
        solver: solver.name.clone(),
        step,
        time: fields.state.time,
        files: outputs.paths(),
        restart,
    };
    collective(ranks.communicator(), error)
}

/// Δt of a `Verlet` list: `Safety Factor × (Fixed dt or the stable estimate)`.
fn verlet_time_step(
    solver: &Solver,
    verlet: &Verlet,
    estimate: Option<f64>,
) -> Result<f64, RunError> {
    match (verlet.fixed_dt, estimate) {
        (Some(dt), _) | (None, Some(dt)) => Ok(verlet.safety_factor * dt),
        (None, None) => Err(RunError::Input(format!(
            "solver \"{}\": no point has a neighbour, so there is no stable time step; give \"Fixed dt\"",
            solver.name
        ))),
    }
}

/// The step count of a list advancing by `time_step` ([`step_count`]), or the error naming
/// the list when there is no sensible count.
fn run_steps(solver: &Solver, time_step: f64) -> Result<u64, RunError> {
    let span = solver.final_time - solver.initial_time;
    step_count(span, time_step).ok_or_else(|| {
        RunError::Input(format!(
            "solver \"{}\": {span:e} s at a time step of {time_step:e} s is more than {MAX_STEPS:e} steps, or the time step is zero; check Final Time, Initial Time and the time step",
            solver.name
        ))
    })
}

/// The Newmark-β settings of an `Implicit` list; the step count is
/// `floor((t_final − t_initial)/Δt)`, as Peridigm counts it.
fn newmark_settings(solver: &Solver, implicit: &Implicit) -> Result<NewmarkSettings, RunError> {
    Ok(NewmarkSettings {
        time_step: implicit.fixed_dt,
        steps: run_steps(solver, implicit.fixed_dt)?,
        first_step: 1,
        initial_time: solver.initial_time,
        beta: implicit.beta,
        gamma: implicit.gamma,
        tolerance: implicit.absolute_tolerance,
        max_iterations: implicit.maximum_solver_iterations,
        verbose: solver.verbose,
    })
}

/// The quasi-static settings of a `QuasiStatic` or `NOXQuasiStatic` list.
fn quasi_static_settings(
    solver: &Solver,
    predecessor: bool,
) -> Result<QuasiStaticSettings, RunError> {
    let heuristics = !solver.disable_heuristics;
    let (load_steps, max_iterations, relative, absolute, measure, adaptive) = match &solver
        .integrator
    {
        Integrator::QuasiStatic(q) => (
            &q.load_steps,
            q.maximum_solver_iterations,
            q.relative_tolerance,
            q.absolute_tolerance,
            ConvergenceMeasure::PeridigmQuasiStatic,
            q.adaptive_load_stepping.clone(),
        ),
        Integrator::NoxQuasiStatic(n) => {
            // NOX (Trilinos) and SNESNCG (PETSc) have nonlinear CG; peridyn's own solver is
            // Newton.
            if n.direction_method != "Newton"
                && solver.linear_solve.backend == crate::io::deck::LinearBackend::Native
            {
                return Err(RunError::Unsupported(format!(
                        "solver \"{}\": NOXQuasiStatic Direction → Method \"{}\" needs Trilinos NOX or PETSc's SNESNCG (Backend \"Trilinos\" or \"PETSc\" in a build with that feature); the native backend has Newton only",
                        solver.name, n.direction_method
                    )));
            }
            (
                &n.load_steps,
                n.max_solver_iterations,
                n.relative_tolerance,
                n.absolute_tolerance,
                ConvergenceMeasure::TwoNorm,
                None,
            )
        }
        _ => unreachable!("only quasi-static integrators come here"),
    };
    Ok(QuasiStaticSettings {
        times: quasistatic::load_step_times(load_steps, solver.initial_time, solver.final_time),
        max_iterations,
        relative_tolerance: relative,
        absolute_tolerance: absolute,
        measure,
        predictor: heuristics,
        predict_first_step: predecessor && solver.initialize_predictor_from_previous_solver,
        line_search: heuristics,
        verbose: solver.verbose,
        adaptive,
        resume: None,
    })
}
