//! The `Verlet` integrator: a solver list of explicit velocity-Verlet steps
//! ([`super::explicit`]) with Peridigm's time step, watched by the stability monitor
//! ([`super::monitor`]), on one rank or N.
//!
//! Δt = `Safety Factor` × (`Fixed dt`, or Peridigm's stable estimate over the owned points of
//! every block, the minimum over the ranks); the list takes ⌊(t_final − t_initial)/Δt⌋ steps.
//! Each step the ranks sum, in one collective, the kinetic energy of the free dofs, the work
//! supplied, whether a step or an output call failed, and whether a stop signal came; an
//! output failure on N ranks waits for that sum ([`super::list_run::Driver::explicit_frame`]).

use super::explicit::{VelocityVerlet, VerletSettings};
use super::integrator::{Integrator, ListSettings, TimeStep};
use super::list_run::{Failure, Inside, ListRun, RestartAt, Stop, Unstable};
use super::monitor::EnergyMonitor;
use super::progress::Progress;
use super::stability;
use crate::interrupt;

/// `Verlet`: explicit velocity-Verlet dynamics.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Verlet {
    /// `Fixed dt` (s): replaces the stable estimate; default none.
    pub fixed_dt: Option<f64>,
    /// `Safety Factor`: multiplies the time step (a fixed one too); default 1.0.
    pub safety_factor: f64,
}

impl Integrator for Verlet {
    fn name(&self) -> &'static str {
        "Verlet"
    }

    fn time_step(&self) -> Option<TimeStep> {
        Some(TimeStep::Stable {
            fixed: self.fixed_dt,
            safety_factor: self.safety_factor,
        })
    }

    fn run(&self, list: &ListSettings, run: &mut ListRun<'_>) -> Result<(), Stop> {
        let estimate = critical_time_step(run);
        let time_step = self.time_step_with(list, estimate);
        let time_step = time_step.map_err(|failure| run.collective(failure))?;
        let steps = list
            .steps(time_step)
            .map_err(|failure| run.collective(failure))?;
        if run.root() {
            eprintln!(
                "{}: Verlet, Δt = {time_step:e} s (stable estimate {}, safety factor {}), {steps} steps",
                list.name,
                estimate.map(|e| format!("{e:e} s")).unwrap_or_else(|| "n/a".into()),
                self.safety_factor
            );
        }
        let mut integrator = VelocityVerlet::new(
            run.model,
            VerletSettings {
                time_step,
                steps,
                initial_time: list.initial_time,
            },
        );
        if let Some(ghosts) = run.ghosts {
            integrator = integrator.with_ghosts(ghosts.to_vec());
        }
        log_contact_search(run, list);
        let mut explicit = Explicit {
            list,
            integrator,
            time_step,
            estimate,
            steps,
            pending: false,
        };
        let (first, monitor) = explicit.start(run)?;
        explicit.steps_from(first, monitor, run)
    }
}

impl Verlet {
    /// Δt of the list: `Safety Factor × (Fixed dt or the stable estimate)`.
    fn time_step_with(&self, list: &ListSettings, estimate: Option<f64>) -> Result<f64, Failure> {
        self.time_step()
            .and_then(|step| step.with_estimate(estimate))
            .ok_or_else(|| {
                Failure::Input(format!(
                    "solver \"{}\": no point has a neighbour, so there is no stable time step; give \"Fixed dt\"",
                    list.name
                ))
            })
    }
}

/// Peridigm's stable time step over the owned points of every block, minimum over ranks
/// (`None` when no point has a neighbour). Collective.
fn critical_time_step(run: &mut ListRun<'_>) -> Option<f64> {
    let model = run.model;
    let reference = run.physics.reference(&model.bonds, &model.points);
    let ranks = &*run.ranks;
    let local = run
        .physics
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
    let global = run.ranks.min(local);
    global.is_finite().then_some(global)
}

/// The contact search's settings at the start of a list (one rank).
fn log_contact_search(run: &ListRun<'_>, list: &ListSettings) {
    if let (1, Some(contact)) = (run.ranks.ranks(), &run.physics.contact) {
        eprintln!(
            "{}: contact: search radius {:e} (skin rule: search again when a point moves {:e}), {} contact points",
            list.name,
            contact.search_radius(),
            0.5 * (contact.search_radius() - contact.max_contact_radius()),
            contact.points().len()
        );
    }
}

/// The contact statistics at the end of an explicit list (rank 0's share on N ranks, with
/// the partner points it received).
fn log_contact(run: &ListRun<'_>, list: &ListSettings) {
    let Some(contact) = run.state.contact.as_ref().filter(|_| run.root()) else {
        return;
    };
    if run.ranks.ranks() == 1 {
        eprintln!("{}: contact: {}", list.name, contact.statistics());
    } else {
        eprintln!(
            "{}: contact (rank 0's share): {}; partner points received from other ranks per step: {} since the last search, at most {}",
            list.name,
            contact.statistics(),
            contact.received_partners().0,
            contact.received_partners().1
        );
    }
}

/// One `Verlet` list being run.
struct Explicit<'a> {
    list: &'a ListSettings,
    integrator: VelocityVerlet,
    time_step: f64,
    estimate: Option<f64>,
    steps: u64,
    /// An output call failed on this rank and the ranks have not agreed on it yet.
    pending: bool,
}

impl Explicit<'_> {
    /// The first step to take and the stability monitor: after the resumed step when the run
    /// continues inside this list; otherwise step 1 after the initial frame, from a saved
    /// state's acceleration (Peridigm's restart: evaluating the forces again would round
    /// differently) or from the forces evaluated at the initial time.
    fn start(&mut self, run: &mut ListRun<'_>) -> Result<(u64, EnergyMonitor), Stop> {
        let resume = run.resume();
        let saved_start = run.index == Some(0) && run.driver.take_saved_start();
        if let Some(resume) = resume {
            let mut monitor = run.driver.energy_monitor(run.ranks, run.physics, run.state);
            if let Some(energies) = resume.monitor {
                monitor.restore(energies);
            }
            run.driver.count(-(resume.step as i64), 0);
            return Ok((resume.step + 1, monitor));
        }
        if saved_start {
            run.state.time = self.list.initial_time;
            run.state.drop_committed();
            run.state.history.set_step_duration(self.time_step);
        } else {
            let initialized =
                self.integrator
                    .initialize_with(run.model, run.physics, run.state, &mut *run.ranks);
            run.agree(initialized)?;
        }
        let monitor = run.driver.energy_monitor(run.ranks, run.physics, run.state);
        self.pending = run
            .driver
            .explicit_frame(&*run.ranks, run.physics, run.state)?;
        Ok((1, monitor))
    }

    /// Steps `first..=steps`, then the end of the list.
    fn steps_from(
        &mut self,
        first: u64,
        mut monitor: EnergyMonitor,
        run: &mut ListRun<'_>,
    ) -> Result<(), Stop> {
        let mut progress = run
            .root()
            .then(|| Progress::new(&self.list.name, self.steps));
        for step in first..=self.steps {
            let done = self.step(step, &mut monitor, run);
            if done.is_err() {
                if let Some(progress) = progress.take() {
                    progress.finish();
                }
            }
            let signalled = done?;
            if let Some(progress) = &mut progress {
                progress.update(step);
            }
            let at = RestartAt {
                index: run.index,
                step,
                inside: Inside::Explicit {
                    monitor: monitor.energies(),
                    steps: step,
                },
                may_be_due: step < self.steps,
            };
            let restart = run
                .driver
                .restart(&*run.ranks, run.physics, run.state, at, signalled)?;
            if signalled {
                if let Some(progress) = progress.take() {
                    progress.finish();
                }
                run.driver.settle(&*run.ranks)?;
                run.driver.count(step as i64, 0);
                let list = (self.list.name.as_str(), step);
                return Err(run.driver.stop_on_signal(
                    &*run.ranks,
                    run.physics,
                    run.state,
                    list,
                    restart,
                ));
            }
        }
        if let Some(progress) = progress {
            progress.finish();
        }
        log_contact(run, self.list);
        run.driver.settle(&*run.ranks)?;
        run.driver.count(self.steps as i64, 0);
        Ok(())
    }

    /// Step `step`: the step, the one collective sum (with the pending output failure and
    /// the stop signal), the stability check and the output call. True when a stop signal
    /// reached a rank.
    fn step(
        &mut self,
        step: u64,
        monitor: &mut EnergyMonitor,
        run: &mut ListRun<'_>,
    ) -> Result<bool, Stop> {
        let result =
            self.integrator
                .step_with(run.model, run.physics, run.state, step, &mut *run.ranks);
        let stop = f64::from(u8::from(interrupt::requested().is_some()));
        let mut sums = match &result {
            Ok(report) => [
                report.free_kinetic_energy,
                report.supplied_work,
                f64::from(u8::from(self.pending)),
                stop,
            ],
            Err(_) => [0.0, 0.0, 1.0, stop],
        };
        run.ranks.sum(&mut sums);
        if sums[2] > 0.0 {
            return Err(run.agree_on_failure(result.err().map(Failure::from)));
        }
        if let Ok(report) = &result {
            run.driver.count(0, report.broken_bonds);
        }
        monitor.add_work(sums[1]);
        if let Err(instability) = monitor.check(step, run.state.time, sums[0]) {
            // The diagnostic's force evaluations need no ghosts on one rank; on N ranks the
            // advice stays generic.
            let measured = (run.ranks.ranks() == 1).then(|| {
                stability::measured_critical_time_step(
                    run.model,
                    run.physics,
                    &run.state.history,
                    stability::MEASURE_ITERATIONS,
                )
            });
            let unstable = Unstable {
                solver: self.list.name.clone(),
                instability,
                time_step: self.time_step,
                estimate: self.estimate,
                measured: measured.flatten(),
            };
            return Err(run.collective(Failure::Unstable(Box::new(unstable))));
        }
        self.pending = run
            .driver
            .explicit_frame(&*run.ranks, run.physics, run.state)?;
        Ok(sums[3] > 0.0)
    }
}
