//! The `Implicit` integrator: Newmark-β dynamics ([`super::newmark`]), each time step solved
//! by Newton (peridyn's, or PETSc's SNES with `Nonlinear Solver: "SNES"`), on N ranks with
//! distributed Belos or KSP solves over the owned unknowns, the ghosts refreshed before every
//! residual evaluation.

use super::integrator::{Integrator, ListSettings, TimeStep};
use super::list_run::{Halt, ImplicitStep, Inside, ListRun, RestartAt, Stop};
use super::newmark::{self, NewmarkError, NewmarkSettings};
use crate::backend::settings::ImplicitSolve;
use crate::backend::SolveError;

/// `Implicit`: Newmark-β dynamics with a fixed time step.
#[derive(Debug)]
pub struct Newmark {
    /// `Fixed dt` (s).
    pub fixed_dt: f64,
    /// `Beta` β; default 0.25.
    pub beta: f64,
    /// `Gamma` γ; default 0.5.
    pub gamma: f64,
    /// `Absolute Tolerance` on Peridigm's measure; default 1e-6.
    pub absolute_tolerance: f64,
    /// `Maximum Solver Iterations`; default 10.
    pub max_iterations: u64,
    /// How each step is solved.
    pub solve: ImplicitSolve,
}

impl Integrator for Newmark {
    fn name(&self) -> &'static str {
        "Implicit"
    }

    fn solve(&self) -> Option<&ImplicitSolve> {
        Some(&self.solve)
    }

    fn time_step(&self) -> Option<TimeStep> {
        Some(TimeStep::Fixed(self.fixed_dt))
    }

    fn run(&self, list: &ListSettings, run: &mut ListRun<'_>) -> Result<(), Stop> {
        let steps = list
            .steps(self.fixed_dt)
            .map_err(|failure| run.collective(failure))?;
        let mut settings = self.settings(list, steps);
        let resume = run.resume();
        if let Some(resume) = &resume {
            settings.first_step = resume.step + 1;
        }
        let nonlinear = super::linear::nonlinear_solver(&self.solve, run.ranks.global_points());
        let mut nonlinear = nonlinear.map_err(|unsupported| run.collective(unsupported))?;
        if run.root() {
            eprintln!(
                "{}: Implicit (Newmark-β, β = {}, γ = {}), Δt = {:e} s, {} steps{}, linear solver: {}",
                list.name,
                settings.beta,
                settings.gamma,
                settings.time_step,
                settings.steps,
                run.on_ranks(),
                nonlinear.describe()
            );
        }
        run.driver.clear_iterations();
        // Continued from a restart file inside this list: the state and the output frames
        // are those after the saved step.
        if resume.is_none() {
            run.state.time = list.initial_time;
            run.driver
                .frame(run.ranks, run.physics, run.state, Ok(()))?;
        }
        let (index, driver) = (run.index, &mut *run.driver);
        let result = newmark::run(
            run.model,
            run.physics,
            run.state,
            &settings,
            nonlinear.as_mut(),
            &mut *run.ranks,
            |physics, state, ranks, step, report| -> Result<(), Halt<NewmarkError>> {
                let step = ImplicitStep {
                    list: &list.name,
                    time: state.time,
                    newton: report,
                    restart: RestartAt {
                        index,
                        step,
                        inside: Inside::Boundary,
                        may_be_due: step < steps,
                    },
                };
                driver
                    .implicit_step(ranks, physics, state, &step)
                    .map_err(Halt::Stopped)
            },
        );
        // Every rank stops at the same call; the rank whose evaluation (or condition) failed
        // reports why, and every rank exits with its code.
        match result {
            Ok(()) => Ok(()),
            Err(Halt::Stopped(stop)) => Err(stop),
            Err(Halt::Failed(NewmarkError::Solve {
                source: SolveError::OtherRank,
                ..
            })) => Err(run.agree_on_failure(None)),
            Err(Halt::Failed(
                failure @ (NewmarkError::Solve { .. } | NewmarkError::Boundary(_)),
            )) => Err(run.agree_on_failure(Some(failure.into()))),
            Err(Halt::Failed(failure @ NewmarkError::NotConverged { .. })) => {
                Err(run.collective(failure))
            }
        }
    }
}

impl Newmark {
    /// The settings of list `list` of `steps` steps (`floor((t_final − t_initial)/Δt)`, as
    /// Peridigm counts them).
    fn settings(&self, list: &ListSettings, steps: u64) -> NewmarkSettings {
        NewmarkSettings {
            time_step: self.fixed_dt,
            steps,
            first_step: 1,
            initial_time: list.initial_time,
            beta: self.beta,
            gamma: self.gamma,
            tolerance: self.absolute_tolerance,
            max_iterations: self.max_iterations,
            verbose: list.verbose,
        }
    }
}
