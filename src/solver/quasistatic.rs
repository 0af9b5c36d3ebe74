//! Quasi-static load stepping (`QuasiStatic`, and `NOXQuasiStatic` on the native backend):
//! the prescribed displacements and body forces are applied in load steps, and each step is
//! solved for equilibrium `V ⊙ (f_int(u) + b) = 0` over the free dofs by Newton's method.
//!
//! One load step from t_n to t_{n+1} (Peridigm's `executeQuasiStatic` in
//! `src/core/Peridigm.cpp`, with our own Newton):
//! 1. u = u_n plus the prescribed increments g(t_{n+1}) − g(t_n); the free dofs get the
//!    predictor `v_prev·Δt` (the last accepted step's velocity; not on the first step unless
//!    `Initialize Predictor From Previous Solver`, never with `Disable Heuristics`);
//! 2. body force and time-dependent damage parameters at t_{n+1};
//! 3. tolerance: `Absolute Tolerance`, or `Relative Tolerance × ‖reaction‖₂` with the reaction
//!    V·f at the prescribed dofs of this first state (when nothing is prescribed, or the
//!    reaction is zero, the norm of the applied body force V·b is the reference instead, and
//!    when that is zero too, the first residual);
//! 4. Newton ([`super::newton`]); bonds broken by unconverged iterates heal until the step is
//!    accepted;
//! 5. accepted when converged, or — Peridigm's rule, with a warning — when the measure is within
//!    100× the tolerance; otherwise, with `Adaptive Load-Stepping`, the step is cut in half and
//!    redone (bounded, and never below what floating point can halve), else the state goes
//!    back to the last accepted step and the solve
//!    returns [`QuasiStaticError::NotConverged`] (the run stops with exit code 3, or continues
//!    explicitly with `Switch to Verlet`); with `Switch to Dynamic Relaxation` a step Newton
//!    cannot solve is not cut but started again from its beginning and relaxed instead
//!    ([`crate::solver::relaxation`]), and the run goes on with Newton at the next step;
//! 6. with `Maximum fraction of bonds broken in one step`, a converged step that broke more
//!    than that fraction of the bonds is cut in half and redone while cuts are allowed and
//!    the step is longer than the shortest load step cut `Maximum load step reductions in one
//!    step` times, so the load at which a crack starts is found to that resolution;
//! 7. on acceptance: `v = (u − u_n)/Δt`, damage committed, output.
//!
//! During a step the current positions are `(X + u_n) + (u − u_n)`, rounded as Peridigm
//! rounds them ([`State::step_start`]).

use crate::backend::SolveError;
use crate::boundary::BoundaryError;
use crate::model::Model;
use crate::physics::Physics;
use crate::solver::collective::{any_failed, Collective};
use crate::solver::implicit::{apply_loads_at, DofMap, ImplicitSystem};
use crate::solver::newton::{ConvergenceMeasure, NewtonReport, NewtonSettings, NonlinearSolver};
use crate::solver::problem::Physical;
use crate::solver::relaxation::AdaptiveRelaxation;
use crate::state::State;
use std::time::Instant;

/// Peridigm accepts an unconverged load step whose measure is below this multiple of the
/// tolerance (with a warning).
pub const ACCEPTANCE_FACTOR: f64 = 100.0;

/// Default bound on halvings of one load step when `Maximum load step reductions in one step`
/// is not given.
pub const DEFAULT_REDUCTIONS_IN_ONE_STEP: u64 = 10;

/// How a quasi-static list divides its time into load steps.
#[derive(Debug, Clone, PartialEq)]
pub enum LoadSteps {
    /// `Number of Load Steps` (≥ 1): equal increments from the initial to the final time.
    Count(u64),
    /// `Time Steps`: the load steps' end times, increasing, the first the list's start.
    Times(Vec<f64>),
}

/// `Adaptive Load-Stepping`: how a load step that does not converge is cut.
#[derive(Debug, Clone, PartialEq)]
pub struct AdaptiveLoadStepping {
    /// `Maximum load step reductions in one step` (default
    /// [`DEFAULT_REDUCTIONS_IN_ONE_STEP`]).
    pub max_reductions_in_one_step: Option<u64>,
    /// `Maximum total load step reductions` (default unbounded).
    pub max_total_reductions: Option<u64>,
    /// `Reduce all remaining load steps`: a cut halves every later step too.
    pub reduce_all_remaining_load_steps: bool,
    /// `Maximum fraction of bonds broken in one step` (0 < f ≤ 1): a step that breaks more
    /// than this fraction of the body's directed bonds is cut; default none.
    pub max_broken_fraction: Option<f64>,
}

/// Settings of one quasi-static solver list.
#[derive(Debug, Clone, PartialEq)]
pub struct QuasiStaticSettings {
    /// Load-step end times, starting with the initial time.
    pub times: Vec<f64>,
    /// Newton iterations per load step.
    pub max_iterations: u64,
    /// `Relative Tolerance`.
    pub relative_tolerance: f64,
    /// `Absolute Tolerance` (replaces the relative one when given).
    pub absolute_tolerance: Option<f64>,
    /// The convergence measure (Peridigm's for `QuasiStatic`, ‖r‖₂ for `NOXQuasiStatic`).
    pub measure: ConvergenceMeasure,
    /// Use the previous step's velocity as predictor (off with `Disable Heuristics`).
    pub predictor: bool,
    /// Also predict the first load step (`Initialize Predictor From Previous Solver`).
    pub predict_first_step: bool,
    /// Line search (off with `Disable Heuristics`).
    pub line_search: bool,
    /// Print every Newton iteration.
    pub verbose: bool,
    /// `Adaptive Load-Stepping`.
    pub adaptive: Option<AdaptiveLoadStepping>,
    /// `Switch to Dynamic Relaxation`: relaxes a step Newton failed on and could not cut;
    /// default none.
    pub relaxation: Option<AdaptiveRelaxation>,
    /// Where to start: `None` at the first load step of `times`; a position saved in a
    /// restart file ([`LoadStepReport::position`]) continues from there.
    pub resume: Option<LoadStepPosition>,
}

/// Where a quasi-static list stands after an accepted step: its load-step times with the cuts
/// made so far, the next step and the counts that decide the next cut and the predictor.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LoadStepPosition {
    /// Load-step end times, the cuts included (s).
    pub times: Vec<f64>,
    /// The next step goes from `times[next − 1]` to `times[next]`.
    pub next: usize,
    /// Cuts made so far in the list.
    pub total_cuts: u64,
    /// Steps accepted so far in the list.
    pub accepted: usize,
}

/// The load-step end times of a `Number of Load Steps` / `Time Steps` setting.
pub fn load_step_times(steps: &LoadSteps, initial: f64, last: f64) -> Vec<f64> {
    match steps {
        LoadSteps::Count(n) => {
            let n = *n as usize;
            (0..=n)
                .map(|k| initial + (last - initial) * k as f64 / n as f64)
                .collect()
        }
        LoadSteps::Times(times) => times.clone(),
    }
}

/// Why a quasi-static solve stopped.
#[derive(Debug, thiserror::Error)]
pub enum QuasiStaticError {
    /// A load step did not converge and could not be cut further.
    #[error(
        "load step {step} (t = {from:e} → {to:e}) did not converge: residual {measure:.4e} after {iterations} Newton iterations, \
         tolerance {tolerance:.4e}. Increase \"Maximum Solver Iterations\", use more load steps, or add \"Adaptive Load-Stepping\"; \
         output up to the last accepted step is valid"
    )]
    NotConverged {
        /// 1-based load step.
        step: usize,
        /// Start time of the step.
        from: f64,
        /// End time of the step.
        to: f64,
        /// Final measure.
        measure: f64,
        /// Tolerance.
        tolerance: f64,
        /// Newton iterations taken.
        iterations: usize,
    },
    /// The linear algebra failed (singular stiffness, non-finite residual).
    #[error("load step {step} (t = {time:e}): {source}")]
    Solve {
        /// 1-based load step.
        step: usize,
        /// End time of the step.
        time: f64,
        /// What failed.
        source: SolveError,
    },
    /// A boundary-condition expression failed.
    #[error(transparent)]
    Boundary(#[from] BoundaryError),
}

/// One accepted load step, for the log, output and the solver history.
#[derive(Debug, Clone, PartialEq)]
pub struct LoadStepReport {
    /// 1-based number of the accepted step.
    pub step: usize,
    /// End time.
    pub time: f64,
    /// Tolerance used.
    pub tolerance: f64,
    /// The Newton report.
    pub newton: NewtonReport,
    /// Load-step halvings before this step was accepted.
    pub cuts: u64,
    /// Where the list stands after this step (what a restart file keeps).
    pub position: LoadStepPosition,
}

/// Runs the load steps of `settings` from the current state, calling `on_step` after every
/// accepted step (the state then holds u, v = Δu/Δt, forces and committed damage at its end;
/// `on_step` gets the ranks back for the collectives of its outputs).
pub fn run<E: From<QuasiStaticError>>(
    model: &Model,
    physics: &mut Physics,
    state: &mut State,
    settings: &QuasiStaticSettings,
    nonlinear: &mut dyn NonlinearSolver,
    collective: &mut dyn Collective,
    mut on_step: impl FnMut(&Physics, &State, &mut dyn Collective, &LoadStepReport) -> Result<(), E>,
) -> Result<Vec<LoadStepReport>, E> {
    let stepping = LoadStepping {
        model,
        settings,
        constrained: model.boundary.constrained_dofs(),
        break_limit: BreakLimit::of(settings, model, collective),
        // On several ranks every rank runs this loop in step; rank 0 alone writes the log.
        root: collective.rank() == 0,
    };
    let mut schedule = match &settings.resume {
        Some(position) => LoadSchedule {
            times: position.times.clone(),
            k: position.next,
            cuts_this_step: 0,
            total_cuts: position.total_cuts,
        },
        None => LoadSchedule {
            times: settings.times.clone(),
            k: 1,
            cuts_this_step: 0,
            total_cuts: 0,
        },
    };
    // Steps accepted before this call (a list resumed from a restart file).
    let accepted_before = settings.resume.as_ref().map_or(0, |p| p.accepted);
    let mut reports = Vec::new();
    let run_start = Instant::now();
    while let Some((number, from, to)) = schedule.current() {
        let step_start = Instant::now();
        let step = LoadStep {
            number,
            from,
            to,
            start_displacement: state.displacement.clone(),
            start_velocity: state.velocity.clone(),
        };
        state.step_start = Some(step.start_displacement.clone());
        state.history.set_step_duration(to - from);
        let mut system = ImplicitSystem::new(
            DofMap::new(model.points.len(), &stepping.constrained, &[]),
            state,
        );
        let predict = settings.predictor
            && (accepted_before + reports.len() > 0 || settings.predict_first_step);
        let tolerance = stepping.begin(&step, physics, state, &mut system, predict, collective)?;
        let parts = Physical {
            system: &mut system,
            model,
            physics,
            state,
            collective,
            constrained: &stepping.constrained,
        };
        let mut report = nonlinear.solve(parts, &stepping.newton_settings(tolerance));
        // With `Switch to Dynamic Relaxation` a step Newton cannot solve is relaxed rather than
        // cut: after a fracture Newton may fail at every step, and cutting each one first
        // would shrink the steps without end.
        let relaxation = settings
            .relaxation
            .filter(|_| needs_relaxation(&report, tolerance));
        let failed = failure(&report, tolerance).filter(|_| relaxation.is_none());
        let too_many_broken = || stepping.too_many_broken(&report, &step);
        if let Some(reason) = failed.or_else(too_many_broken) {
            if schedule.cut(settings) {
                if stepping.root {
                    eprintln!("Warning: {reason}; cutting the load step in half and redoing it.");
                }
                step.restore(state);
                continue;
            }
        }
        if let Some(relaxation) = relaxation {
            let newton = report.map_err(|source| source.to_string());
            report = stepping.relax(
                &step,
                relaxation,
                newton,
                (&mut *physics, &mut *state, &mut *collective),
                predict,
            );
        }
        let report = report.map_err(|source| step.solve_error(source))?;
        stepping.accept_or_stop(&step, state, &report, tolerance)?;
        step.commit(state);
        if stepping.root {
            let logged = nonlinear.logs_after_each_iteration();
            log_accepted(&report, logged, step_start, run_start);
        }
        let cuts = schedule.accept();
        let accepted = LoadStepReport {
            step: accepted_before + reports.len() + 1,
            time: to,
            tolerance,
            newton: report,
            cuts,
            position: LoadStepPosition {
                times: schedule.times.clone(),
                next: schedule.k,
                total_cuts: schedule.total_cuts,
                accepted: accepted_before + reports.len() + 1,
            },
        };
        on_step(physics, state, collective, &accepted)?;
        reports.push(accepted);
    }
    Ok(reports)
}

/// Peridigm's closing lines of an accepted step: the last residual (unless the solver logged
/// it, as NOX and the relaxation, of a handed step too, do) and the step's and run's time.
fn log_accepted(report: &NewtonReport, logged: bool, step_start: Instant, run_start: Instant) {
    if !logged && report.relaxation_iterations == 0 {
        eprintln!(
            "  iteration {}: residual = {:e}",
            report.iterations + 1,
            final_measure(report)
        );
    }
    eprintln!(
        "  cpu time for load step = {:.3} sec., cumulative cpu time = {:.3} sec.",
        step_start.elapsed().as_secs_f64(),
        run_start.elapsed().as_secs_f64()
    );
}

/// What every load step of one run reads.
struct LoadStepping<'a> {
    model: &'a Model,
    settings: &'a QuasiStaticSettings,
    /// Prescribed dofs (`3·p + component`), sorted.
    constrained: Vec<usize>,
    /// `Maximum fraction of bonds broken in one step`, when the list has it.
    break_limit: Option<BreakLimit>,
    /// This rank writes the log (rank 0).
    root: bool,
}

/// The load-step times with the cuts made so far, and the step being solved.
struct LoadSchedule {
    times: Vec<f64>,
    /// The step being solved: from `times[k − 1]` to `times[k]` (1-based).
    k: usize,
    cuts_this_step: u64,
    total_cuts: u64,
}

/// One load step being solved: its number, times and where it started.
struct LoadStep {
    /// 1-based number among the steps tried (cut steps count once per half).
    number: usize,
    from: f64,
    to: f64,
    /// u and v at the start of the step (what a redone or rejected step goes back to).
    start_displacement: Vec<[f64; 3]>,
    start_velocity: Vec<[f64; 3]>,
}

impl LoadSchedule {
    /// The step to solve (number, start and end time), `None` after the last.
    fn current(&self) -> Option<(usize, f64, f64)> {
        (self.k < self.times.len()).then(|| (self.k, self.times[self.k - 1], self.times[self.k]))
    }

    /// Halves the current step when `Adaptive Load-Stepping` allows one more cut; false
    /// when it does not.
    fn cut(&mut self, settings: &QuasiStaticSettings) -> bool {
        let (from, to) = (self.times[self.k - 1], self.times[self.k]);
        let middle = 0.5 * (from + to);
        // A step too short to halve in floating point stays as it is (its velocity Δu/Δt
        // would divide by zero).
        if !can_cut(settings, self.cuts_this_step, self.total_cuts)
            || middle <= from
            || middle >= to
        {
            return false;
        }
        cut(&mut self.times, self.k, settings);
        self.cuts_this_step += 1;
        self.total_cuts += 1;
        true
    }

    /// Moves on after the current step was accepted; returns the cuts it took.
    fn accept(&mut self) -> u64 {
        self.k += 1;
        std::mem::take(&mut self.cuts_this_step)
    }
}

impl LoadStepping<'_> {
    /// Steps 1–3 of the module docs: the loads at the end of the step, the predictor when
    /// `predict`, and the tolerance (logged). Every rank stops when a condition fails on one.
    fn begin(
        &self,
        step: &LoadStep,
        physics: &mut Physics,
        state: &mut State,
        system: &mut ImplicitSystem,
        predict: bool,
        collective: &mut dyn Collective,
    ) -> Result<f64, QuasiStaticError> {
        let (from, to) = (step.from, step.to);
        let loads = set_loads(
            self.model,
            physics,
            state,
            &step.start_displacement,
            from,
            to,
        );
        // A condition may fail at some points only, hence on some ranks only: all stop.
        if any_failed(collective, loads.is_err()) {
            return Err(loads
                .err()
                .unwrap_or_else(|| step.solve_error(SolveError::OtherRank)));
        }
        if predict {
            let dt = to - from;
            for &dof in &system.dofs.free {
                state.displacement[dof / 3][dof % 3] += step.start_velocity[dof / 3][dof % 3] * dt;
            }
        }
        collective.refresh(&mut state.displacement);
        let tolerance = tolerance(
            system,
            self.model,
            physics,
            state,
            self.settings,
            &self.constrained,
            collective,
        )
        .map_err(|source| step.solve_error(source))?;
        if self.root {
            let k = step.number;
            eprintln!(
                "Load step {k}, initial time = {from:e}, final time = {to:e}, convergence criterion = {tolerance:e}"
            );
        }
        Ok(tolerance)
    }

    /// Why a solved step broke too many bonds (`Maximum fraction of bonds broken in one
    /// step`), if it did and is longer than the shortest step the cuts allow: a break that
    /// happens however short the step is accepted there (otherwise every step after the last
    /// accepted one would be cut again, without end).
    fn too_many_broken(
        &self,
        report: &Result<NewtonReport, SolveError>,
        step: &LoadStep,
    ) -> Option<String> {
        let limit = self.break_limit.as_ref()?;
        if step.to - step.from <= limit.shortest_step * (1.0 + 1e-9) {
            return None;
        }
        let broken = report.as_ref().ok()?.broken_bonds;
        let fraction = broken as f64 / limit.bonds.max(1) as f64;
        (fraction > limit.fraction).then(|| {
            format!(
                "{broken} bonds broke in the step, {fraction:.3e} of the body's {}, above the Maximum fraction of bonds broken in one step {:e}",
                limit.bonds, limit.fraction
            )
        })
    }

    /// `Switch to Dynamic Relaxation`: the step Newton failed on (`newton`: its report, or why
    /// it failed) is started again and relaxed; the report is the relaxation's with Newton's
    /// iterations, linear iterations, evaluations and time added.
    fn relax(
        &self,
        step: &LoadStep,
        mut relaxation: AdaptiveRelaxation,
        newton: Result<NewtonReport, String>,
        (physics, state, collective): (&mut Physics, &mut State, &mut dyn Collective),
        predict: bool,
    ) -> Result<NewtonReport, SolveError> {
        if self.root {
            let why = match &newton {
                Ok(r) => format!(
                    "residual {:.4e} after {} iterations",
                    final_measure(r),
                    r.iterations
                ),
                Err(reason) => reason.clone(),
            };
            eprintln!("Warning: Newton did not solve load step {} ({why}); relaxing it instead (Switch to Dynamic Relaxation).", step.number);
        }
        step.restore(state);
        let mut system = ImplicitSystem::new(
            DofMap::new(self.model.points.len(), &self.constrained, &[]),
            state,
        );
        let tolerance = self
            .begin(step, physics, state, &mut system, predict, collective)
            .map_err(|failure| SolveError::Breakdown {
                method: "dynamic relaxation",
                reason: failure.to_string(),
            })?;
        let parts = Physical {
            system: &mut system,
            model: self.model,
            physics,
            state,
            collective,
            constrained: &self.constrained,
        };
        let mut relaxed = relaxation.solve(parts, &self.newton_settings(tolerance))?;
        if let Ok(newton) = newton {
            relaxed.iterations = newton.iterations;
            relaxed.linear_iterations = newton.linear_iterations;
            relaxed.residual_evaluations += newton.residual_evaluations;
            relaxed.seconds += newton.seconds;
            relaxed.tangent_bytes = relaxed.tangent_bytes.max(newton.tangent_bytes);
        }
        Ok(relaxed)
    }

    /// Newton's settings for a step with `tolerance`.
    fn newton_settings(&self, tolerance: f64) -> NewtonSettings {
        NewtonSettings {
            max_iterations: self.settings.max_iterations,
            tolerance,
            measure: self.settings.measure,
            line_search: self.settings.line_search,
            print_iterations: self.root,
            verbose: self.settings.verbose && self.root,
        }
    }

    /// Rule 5 of the module docs for a step that could not be cut: an unconverged step within
    /// [`ACCEPTANCE_FACTOR`] × `tolerance` is accepted with a warning; otherwise the state goes
    /// back to the start of the step (what a `Switch to Verlet` continues from, and what the
    /// output already shows) and the run stops.
    fn accept_or_stop(
        &self,
        step: &LoadStep,
        state: &mut State,
        report: &NewtonReport,
        tolerance: f64,
    ) -> Result<(), QuasiStaticError> {
        if report.converged {
            return Ok(());
        }
        let measure = final_measure(report);
        if measure < ACCEPTANCE_FACTOR * tolerance {
            eprintln!("Warning:  Accepting current solution and progressing to next load step.");
            return Ok(());
        }
        step.restore(state);
        state.update_current_position(&self.model.points.position);
        state.time = step.from;
        Err(QuasiStaticError::NotConverged {
            step: step.number,
            from: step.from,
            to: step.to,
            measure,
            tolerance,
            iterations: report.iterations,
        })
    }
}

impl LoadStep {
    /// A failure of the linear algebra in this step.
    fn solve_error(&self, source: SolveError) -> QuasiStaticError {
        QuasiStaticError::Solve {
            step: self.number,
            time: self.to,
            source,
        }
    }

    /// Puts the state back to the start of the step (it is redone, or the run stops).
    fn restore(&self, state: &mut State) {
        state.restore();
        state.step_start = None;
        state.displacement.copy_from_slice(&self.start_displacement);
        state.velocity.copy_from_slice(&self.start_velocity);
    }

    /// Step 6 of the module docs: v = (u − u_n)/Δt, the time, and the staged fields committed.
    fn commit(&self, state: &mut State) {
        let dt = self.to - self.from;
        for (v, (u, u0)) in state
            .velocity
            .iter_mut()
            .zip(state.displacement.iter().zip(&self.start_displacement))
        {
            *v = [0, 1, 2].map(|c| (u[c] - u0[c]) / dt);
        }
        state.time = self.to;
        state.commit();
        state.step_start = None;
    }
}

/// Why Newton's answer cannot be taken as it is (an error, or not converged), if so.
fn failure(report: &Result<NewtonReport, SolveError>, tolerance: f64) -> Option<String> {
    match report {
        Err(source) => Some(source.to_string()),
        Ok(r) if !r.converged => Some(format!(
            "residual {:.4e} above the tolerance {tolerance:.4e} after {} iterations",
            r.residual_history.last().unwrap_or(&f64::INFINITY),
            r.iterations
        )),
        Ok(_) => None,
    }
}

/// True when Newton's answer to a step can be neither accepted nor cut: an error of the
/// solve (singular, broken down; not a condition that failed) or a measure above
/// [`ACCEPTANCE_FACTOR`] × `tolerance`.
fn needs_relaxation(report: &Result<NewtonReport, SolveError>, tolerance: f64) -> bool {
    match report {
        Err(_) => true,
        Ok(r) => !r.converged && final_measure(r) >= ACCEPTANCE_FACTOR * tolerance,
    }
}

/// `Maximum fraction of bonds broken in one step` of a list, with what it is measured against.
struct BreakLimit {
    /// The fraction.
    fraction: f64,
    /// Directed bonds of the body, summed over the ranks.
    bonds: usize,
    /// The shortest step a cut may leave: the shortest load step of the list halved
    /// `Maximum load step reductions in one step` times.
    shortest_step: f64,
}

impl BreakLimit {
    /// The limit of `settings`, `None` without the key. Collective when the key is given (the
    /// ranks' bonds are summed); every rank reads the same deck, so all of them call it.
    fn of(
        settings: &QuasiStaticSettings,
        model: &Model,
        collective: &mut dyn Collective,
    ) -> Option<Self> {
        let adaptive = settings.adaptive.as_ref()?;
        let fraction = adaptive.max_broken_fraction?;
        let halvings = adaptive
            .max_reductions_in_one_step
            .unwrap_or(DEFAULT_REDUCTIONS_IN_ONE_STEP);
        let shortest_load_step = settings
            .times
            .windows(2)
            .map(|w| w[1] - w[0])
            .fold(f64::INFINITY, f64::min);
        let owned: usize = (0..model.points.len())
            .filter(|&p| !collective.is_ghost(p))
            .map(|p| model.bonds.family_size(p))
            .sum();
        let mut bonds = [owned as f64];
        collective.sum(&mut bonds);
        Some(Self {
            fraction,
            bonds: bonds[0] as usize,
            shortest_step: shortest_load_step / 2f64.powi(halvings.min(60) as i32),
        })
    }
}

/// The last convergence measure of a Newton solve (∞ without one).
fn final_measure(report: &NewtonReport) -> f64 {
    *report.residual_history.last().unwrap_or(&f64::INFINITY)
}

/// Sets u = u_n + prescribed increments, the body force and the damage time for the step.
fn set_loads(
    model: &Model,
    physics: &mut Physics,
    state: &mut State,
    start_displacement: &[[f64; 3]],
    from: f64,
    to: f64,
) -> Result<(), QuasiStaticError> {
    let positions = &model.points.position;
    state.displacement.copy_from_slice(start_displacement);
    let displacement = &mut state.displacement;
    model
        .boundary
        .prescribed_increments(positions, start_displacement, from, to, |p, c, du| {
            displacement[p][c] += du
        })?;
    apply_loads_at(model, physics, state, to)?;
    Ok(())
}

/// The step's tolerance (rule 3 of the module docs). The norms are over the points this rank
/// owns, summed over the ranks (the ghosts' positions must be current).
fn tolerance(
    system: &mut ImplicitSystem,
    model: &Model,
    physics: &mut Physics,
    state: &mut State,
    settings: &QuasiStaticSettings,
    constrained: &[usize],
    collective: &mut dyn Collective,
) -> Result<f64, SolveError> {
    if let Some(absolute) = settings.absolute_tolerance {
        return Ok(absolute);
    }
    let mut residual = vec![0.0; system.dofs.len()];
    system.residual(model, physics, state, &mut residual)?;
    let volume = &model.points.volume;
    let owned = |dof: &usize| !collective.is_ghost(dof / 3);
    let reaction: f64 = constrained
        .iter()
        .filter(|dof| owned(dof))
        .map(|&dof| (volume[dof / 3] * state.force_density[dof / 3][dof % 3]).powi(2))
        .sum();
    let applied: f64 = state.external_force_density.as_ref().map_or(0.0, |b| {
        (0..3 * b.len())
            .filter(|dof| owned(dof))
            .map(|dof| (volume[dof / 3] * b[dof / 3][dof % 3]).powi(2))
            .sum()
    });
    let mut squares = [reaction, applied];
    collective.sum(&mut squares);
    let mut reference = squares[0].sqrt();
    if reference == 0.0 {
        reference = squares[1].sqrt();
    }
    if reference == 0.0 {
        // Only reached with nothing prescribed and no body force; the measure of the first
        // residual over the owned unknowns, for which a serial run is the case that matters.
        reference = settings.measure.of(&residual, &system.dofs, volume);
    }
    Ok(settings.relative_tolerance * reference)
}

fn can_cut(settings: &QuasiStaticSettings, in_step: u64, total: u64) -> bool {
    settings.adaptive.as_ref().is_some_and(|a| {
        in_step
            < a.max_reductions_in_one_step
                .unwrap_or(DEFAULT_REDUCTIONS_IN_ONE_STEP)
            && a.max_total_reductions.is_none_or(|m| total < m)
    })
}

/// Halves step k (inserts its midpoint); with `Reduce all remaining load steps` every later
/// step is halved too.
fn cut(times: &mut Vec<f64>, k: usize, settings: &QuasiStaticSettings) {
    let all = settings
        .adaptive
        .as_ref()
        .is_some_and(|a| a.reduce_all_remaining_load_steps);
    let end = if all { times.len() } else { k + 1 };
    let mut refined = times[..k].to_vec();
    for w in k..end {
        refined.push(0.5 * (times[w - 1] + times[w]));
        refined.push(times[w]);
    }
    refined.extend_from_slice(&times[end..]);
    *times = refined;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn load_step_times_divide_the_interval_evenly() {
        assert_eq!(
            load_step_times(&LoadSteps::Count(4), 0.0, 2.0),
            vec![0.0, 0.5, 1.0, 1.5, 2.0]
        );
        let listed = LoadSteps::Times(vec![0.0, 0.25, 1.0]);
        assert_eq!(load_step_times(&listed, 0.0, 1.0), vec![0.0, 0.25, 1.0]);
    }

    fn adaptive(all: bool) -> QuasiStaticSettings {
        QuasiStaticSettings {
            times: vec![],
            max_iterations: 10,
            relative_tolerance: 1e-6,
            absolute_tolerance: None,
            measure: ConvergenceMeasure::TwoNorm,
            predictor: true,
            predict_first_step: false,
            line_search: true,
            verbose: false,
            resume: None,
            relaxation: None,
            adaptive: Some(AdaptiveLoadStepping {
                max_reductions_in_one_step: Some(2),
                max_total_reductions: Some(3),
                reduce_all_remaining_load_steps: all,
                max_broken_fraction: None,
            }),
        }
    }

    #[test]
    fn cutting_halves_one_step_or_all_remaining_ones() {
        let mut times = vec![0.0, 1.0, 2.0, 3.0];
        cut(&mut times, 2, &adaptive(false));
        assert_eq!(times, vec![0.0, 1.0, 1.5, 2.0, 3.0]);
        let mut times = vec![0.0, 1.0, 2.0, 3.0];
        cut(&mut times, 2, &adaptive(true));
        assert_eq!(times, vec![0.0, 1.0, 1.5, 2.0, 2.5, 3.0]);
    }

    #[test]
    fn cuts_are_bounded_per_step_and_in_total() {
        let s = adaptive(false);
        assert!(can_cut(&s, 1, 1));
        assert!(!can_cut(&s, 2, 2), "two cuts in one step is the limit");
        assert!(!can_cut(&s, 0, 3), "three cuts in total is the limit");
        let mut none = s.clone();
        none.adaptive = None;
        assert!(!can_cut(&none, 0, 0));
    }
}
