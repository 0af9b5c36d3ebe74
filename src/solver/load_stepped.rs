//! The load-stepped integrators, `QuasiStatic` and `NOXQuasiStatic` ([`QuasiStatic`]): the
//! load steps of [`super::quasistatic`] solved for equilibrium by a nonlinear solver
//! ([`super::linear`] chooses peridyn's Newton, NOX or SNES), on N ranks with Trilinos NOX or
//! PETSc SNES (`NOXQuasiStatic`) or peridyn's Newton with distributed Belos or KSP solves
//! (`QuasiStatic`) over the owned unknowns, the ghosts refreshed before every residual
//! evaluation.
//!
//! [`LoadStepped`] runs such a list with any [`NonlinearSolver`]: an integrator that relaxes
//! each load step another way plugs its own solver in. A load step that cannot be cut further
//! goes to the list's [`HandOff`] (`Switch to Verlet`) when it has one.

use super::integrator::{HandOff, Integrator, ListSettings};
use super::linear;
use super::list_run::{Failure, Halt, ImplicitStep, Inside, ListRun, RestartAt, Stop};
use super::newton::{ConvergenceMeasure, NonlinearSolver};
use super::quasistatic::{
    self, AdaptiveLoadStepping, LoadSteps, QuasiStaticError, QuasiStaticSettings,
};
use super::relaxation::AdaptiveRelaxation;
use crate::backend::factory::nox_parameters;
use crate::backend::settings::{ImplicitSolve, LinearBackend};
use crate::backend::SolveError;

/// `QuasiStatic`: Peridigm's load-stepped Newton–Raphson with line search; and
/// `NOXQuasiStatic`, the same load steps solved with NOX's parameter list (NOX on Trilinos,
/// SNES on PETSc, peridyn's Newton on the native backend), its own defaults and measure.
#[derive(Debug)]
pub struct QuasiStatic {
    /// `QuasiStatic` or `NOXQuasiStatic`.
    pub name: &'static str,
    /// `Number of Load Steps` or `Time Steps`.
    pub load_steps: LoadSteps,
    /// Newton iterations per load step: `Maximum Solver Iterations` (default 10), `Max
    /// Solver Iterations` for NOX (default 50).
    pub max_iterations: u64,
    /// `Relative Tolerance`: the criterion is this × ‖reaction‖₂; default 1e-6.
    pub relative_tolerance: f64,
    /// `Absolute Tolerance`: replaces the relative one when given.
    pub absolute_tolerance: Option<f64>,
    /// The convergence measure: Peridigm's for `QuasiStatic`, ‖r‖₂ for `NOXQuasiStatic`.
    pub measure: ConvergenceMeasure,
    /// `Adaptive Load-Stepping`: cut load steps that do not converge; default off.
    pub adaptive: Option<AdaptiveLoadStepping>,
    /// Where a step that cannot be cut further goes (`Switch to Verlet`); default none.
    pub hand_off: Option<HandOff>,
    /// `Switch to Dynamic Relaxation`: a step that cannot be cut further is relaxed instead,
    /// and Newton goes on at the next step; default none.
    pub relaxation: Option<AdaptiveRelaxation>,
    /// How each load step is solved.
    pub solve: ImplicitSolve,
}

impl Integrator for QuasiStatic {
    fn name(&self) -> &'static str {
        self.name
    }

    fn solve(&self) -> Option<&ImplicitSolve> {
        Some(&self.solve)
    }

    fn planned_steps(&self, _span: f64, _estimate: Option<f64>) -> Option<u64> {
        Some(planned_load_steps(&self.load_steps))
    }

    fn step_strategy(&self) -> Vec<String> {
        step_strategy(
            self.adaptive.as_ref(),
            self.relaxation,
            self.hand_off.as_ref(),
        )
    }

    fn run(&self, list: &ListSettings, run: &mut ListRun<'_>) -> Result<(), Stop> {
        // NOX (Trilinos) and SNESNCG (PETSc) have nonlinear CG; peridyn's own solver is
        // Newton.
        let native = self.solve.linear.backend == LinearBackend::Native;
        if let Some(nox) = nox_parameters(&self.solve).filter(|_| native) {
            if nox.direction_method != "Newton" {
                return Err(run.collective(Failure::Unsupported(format!(
                    "solver \"{}\": NOXQuasiStatic Direction → Method \"{}\" needs Trilinos NOX or PETSc's SNESNCG (Backend \"Trilinos\" or \"PETSc\" in a build with that feature); the native backend has Newton only",
                    list.name, nox.direction_method
                ))));
            }
        }
        let nonlinear = linear::nonlinear_solver(&self.solve, run.ranks.global_points());
        let mut nonlinear = nonlinear.map_err(|unsupported| run.collective(unsupported))?;
        let stepped = LoadStepped {
            name: self.name,
            settings: self.settings(list),
            hand_off: self.hand_off.as_ref(),
        };
        stepped.run(list, nonlinear.as_mut(), run)
    }
}

impl QuasiStatic {
    /// The load-stepping settings of list `list`.
    fn settings(&self, list: &ListSettings) -> QuasiStaticSettings {
        QuasiStaticSettings {
            times: quasistatic::load_step_times(
                &self.load_steps,
                list.initial_time,
                list.final_time,
            ),
            max_iterations: self.max_iterations,
            relative_tolerance: self.relative_tolerance,
            absolute_tolerance: self.absolute_tolerance,
            measure: self.measure,
            predictor: list.heuristics,
            predict_first_step: list.predict_first_step,
            line_search: list.heuristics,
            verbose: list.verbose,
            adaptive: self.adaptive.clone(),
            relaxation: self.relaxation,
            resume: None,
        }
    }
}

/// What a load-stepped list does with a step that fails or breaks too many bonds, one line
/// each (`peridyn check`): the cuts of `adaptive`, the relaxation of a step Newton failed on,
/// the hand-off of the rest of the list.
pub fn step_strategy(
    adaptive: Option<&AdaptiveLoadStepping>,
    relaxation: Option<AdaptiveRelaxation>,
    hand_off: Option<&HandOff>,
) -> Vec<String> {
    let mut lines = Vec::new();
    if let Some(adaptive) = adaptive {
        let halvings = adaptive
            .max_reductions_in_one_step
            .unwrap_or(quasistatic::DEFAULT_REDUCTIONS_IN_ONE_STEP);
        // With the relaxation, only a step Newton nearly solved is cut (quasistatic.rs).
        let which = match relaxation {
            Some(_) => "a step Newton nearly solves (within 100 × the criterion)",
            None => "a step that does not converge",
        };
        lines.push(match halvings {
            0 => format!("{which} is not cut"),
            n => format!("{which} is cut in half, up to {n} times in a step"),
        });
        if let Some(fraction) = adaptive.max_broken_fraction {
            lines.push(format!(
                "a step that breaks more than {fraction} of the bonds is cut in half, down to 1/2^{halvings} of a load step"
            ));
        }
    }
    if let Some(relaxation) = relaxation {
        let limit = relaxation
            .max_iterations
            .map_or_else(String::new, |n| format!(" (at most {n} iterations)"));
        lines.push(format!(
            "a step Newton cannot solve is relaxed by dynamic relaxation{limit} instead of cut; Newton solves the next"
        ));
    }
    if let Some(hand_off) = hand_off {
        lines.push(format!(
            "a step that cannot be solved or cut hands the rest of the list to {} ({})",
            hand_off.integrator.name(),
            hand_off.label
        ));
    }
    lines
}

/// Output calls a list of `load_steps` plans (for `peridyn check`'s disk plan: the count, or
/// every listed time).
pub fn planned_load_steps(load_steps: &LoadSteps) -> u64 {
    match load_steps {
        LoadSteps::Count(n) => *n,
        LoadSteps::Times(times) => times.len() as u64,
    }
}

/// A load-stepped list: its integrator's name, its settings and where a step that cannot be
/// cut further goes.
pub struct LoadStepped<'a> {
    /// The integrator's name, for the log.
    pub name: &'static str,
    /// The load steps and Newton's settings.
    pub settings: QuasiStaticSettings,
    /// Where a step that cannot be cut further goes; without one the run stops.
    pub hand_off: Option<&'a HandOff>,
}

impl LoadStepped<'_> {
    /// Runs list `list` with `nonlinear` solving each load step: the log line, the initial
    /// frame (unless the run resumes inside the list), the load steps with the driver's
    /// bookkeeping after each, and the failures agreed over the ranks.
    pub fn run(
        mut self,
        list: &ListSettings,
        nonlinear: &mut dyn NonlinearSolver,
        run: &mut ListRun<'_>,
    ) -> Result<(), Stop> {
        let resume = run.resume();
        self.settings.resume = resume.as_ref().and_then(|r| r.load_steps.clone());
        if run.root() {
            eprintln!(
                "{}: {}, {} load steps{}, linear solver: {}",
                list.name,
                self.name,
                self.settings.times.len() - 1,
                run.on_ranks(),
                nonlinear.describe()
            );
        }
        run.driver.clear_iterations();
        if resume.is_none() {
            initial_frame(list, run)?;
        }
        let (index, driver) = (run.index, &mut *run.driver);
        let result = quasistatic::run(
            run.model,
            run.physics,
            run.state,
            &self.settings,
            nonlinear,
            &mut *run.ranks,
            |physics, state, ranks, report| -> Result<(), Halt<QuasiStaticError>> {
                let step = ImplicitStep {
                    list: &list.name,
                    time: report.time,
                    newton: &report.newton,
                    restart: RestartAt {
                        index,
                        step: report.step as u64,
                        inside: Inside::LoadSteps(&report.position),
                        may_be_due: true,
                    },
                };
                driver
                    .implicit_step(ranks, physics, state, &step)
                    .map_err(Halt::Stopped)
            },
        );
        match result {
            Ok(_) => Ok(()),
            Err(Halt::Stopped(stop)) => Err(stop),
            Err(Halt::Failed(failure)) => self.failed(failure, list, run),
        }
    }

    /// After a load step failed: every rank stops at the same call, the rank whose
    /// evaluation (or condition) failed reports why; a step that did not converge goes to
    /// the hand-off when the list has one.
    fn failed(
        &self,
        failure: QuasiStaticError,
        list: &ListSettings,
        run: &mut ListRun<'_>,
    ) -> Result<(), Stop> {
        match failure {
            QuasiStaticError::Solve {
                source: SolveError::OtherRank,
                ..
            } => Err(run.agree_on_failure(None)),
            failure @ (QuasiStaticError::Solve { .. } | QuasiStaticError::Boundary(_)) => {
                Err(run.agree_on_failure(Some(failure.into())))
            }
            failure @ QuasiStaticError::NotConverged { .. } => match self.hand_off {
                Some(hand_off) => hand_off.run(list, &failure, run),
                None => Err(run.collective(failure)),
            },
        }
    }
}

/// The initial frame of a load-stepped list: the body force (and the temperature) at the
/// initial time, as Peridigm writes it.
fn initial_frame(list: &ListSettings, run: &mut ListRun<'_>) -> Result<(), Stop> {
    let state = &mut *run.state;
    state.time = list.initial_time;
    let model = run.model;
    let positions = &model.points.position;
    let initial = match &mut state.external_force_density {
        Some(b) => model.boundary.body_force(positions, state.time, b),
        None => Ok(()),
    };
    let initial = initial.and_then(|()| {
        model
            .boundary
            .apply_temperature(positions, state.time, &mut state.history)
    });
    run.driver.frame(
        run.ranks,
        run.physics,
        run.state,
        initial.map_err(Failure::from),
    )
}
