//! The integrator seam: every solver list runs through one trait, [`Integrator`], and the
//! run's driver (`crate::simulation`) knows no integrator by name. It runs the deck's
//! [`SolverList`]s in order over one state, giving each its [`ListRun`]: the model, the ranks,
//! and the [`Driver`] services that keep the run's outputs, restart files and log.
//!
//! `crate::setup::solvers` is the one factory that maps a deck's solver list to its
//! integrator with typed parameters. Everything else asks the integrator: whether it is
//! implicit and how it solves ([`Integrator::solve`], which the backend factory reads),
//! its time step, the steps it plans, whether it runs on several ranks, and what of it this
//! build cannot run.
//!
//! An integrator may hand a failed step to another one ([`HandOff`]): `Switch to Verlet` of
//! `QuasiStatic` lists continues explicitly from the last accepted load step to the list's
//! final time; any integrator can be handed a step the same way.

use super::list_run::{Failure, ListRun, Stop};
use super::{step_count, MAX_STEPS};
use crate::backend::factory;
use crate::backend::settings::ImplicitSolve;
use crate::backend::Unsupported;
use std::fmt;

/// The keys every solver list has, besides its integrator.
#[derive(Debug, Clone, PartialEq)]
pub struct ListSettings {
    /// The list's name (`Solver`, `Solver1`, …).
    pub name: String,
    /// `Initial Time` (s).
    pub initial_time: f64,
    /// `Final Time` (s).
    pub final_time: f64,
    /// `Verbose`: extra norms per iteration.
    pub verbose: bool,
    /// The predictor and line searches are on (off with `Disable Heuristics`).
    pub heuristics: bool,
    /// The first load step is predicted too: `Initialize Predictor From Previous Solver` in a
    /// list that has a list before it.
    pub predict_first_step: bool,
}

impl ListSettings {
    /// Seconds from the initial to the final time.
    pub fn span(&self) -> f64 {
        self.final_time - self.initial_time
    }

    /// The step count of the list advancing by `time_step` ([`step_count`]), or the failure
    /// naming the list when there is no sensible count.
    pub fn steps(&self, time_step: f64) -> Result<u64, Failure> {
        let span = self.span();
        step_count(span, time_step).ok_or_else(|| {
            Failure::Input(format!(
                "solver \"{}\": {span:e} s at a time step of {time_step:e} s is more than {MAX_STEPS:e} steps, or the time step is zero; check Final Time, Initial Time and the time step",
                self.name
            ))
        })
    }
}

/// One solver list: its keys and its integrator.
#[derive(Debug)]
pub struct SolverList {
    /// The keys every list has.
    pub settings: ListSettings,
    /// Its integrator, with its typed parameters.
    pub integrator: Box<dyn Integrator>,
}

/// How an integrator that advances by a time step chooses it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TimeStep {
    /// Δt = `safety_factor` × (`fixed`, or the stable time step estimated from the model):
    /// explicit integrators (`Verlet`: `Safety Factor`, `Fixed dt`).
    Stable {
        /// The time step the deck fixes instead of the estimate (s).
        fixed: Option<f64>,
        /// The factor on it.
        safety_factor: f64,
    },
    /// A time step the deck fixes (s).
    Fixed(f64),
}

impl TimeStep {
    /// Δt with the stable estimate `estimate` (s); `None` when it needs an estimate and there
    /// is none (no point has a neighbour).
    pub fn with_estimate(self, estimate: Option<f64>) -> Option<f64> {
        match self {
            TimeStep::Stable {
                fixed,
                safety_factor,
            } => fixed.or(estimate).map(|dt| safety_factor * dt),
            TimeStep::Fixed(dt) => Some(dt),
        }
    }

    /// The deck key that sets Δt: `Fixed dt` when the deck fixes it, else `Safety Factor`
    /// (the factor on the stable estimate), for an error that blames the time step.
    pub fn deck_key(self) -> &'static str {
        match self {
            TimeStep::Stable { fixed: None, .. } => "Safety Factor",
            TimeStep::Stable { fixed: Some(_), .. } | TimeStep::Fixed(_) => "Fixed dt",
        }
    }

    /// True when Δt comes from the stable estimate (no fixed value).
    pub fn needs_estimate(self) -> bool {
        matches!(self, TimeStep::Stable { fixed: None, .. })
    }
}

/// A time integrator of solver lists: what it is, what it needs, and how it runs.
///
/// Adding one is its file (its typed parameters, this trait, its tests), its `mod` line in
/// [`crate::solver`], the reading of its deck sublist in the deck reader, and one line in the
/// factory `crate::setup::solvers`.
pub trait Integrator: fmt::Debug {
    /// Its name as decks write its sublist (`Verlet`, `QuasiStatic`, …), for the log and
    /// `peridyn check`.
    fn name(&self) -> &'static str;

    /// How it solves its nonlinear systems with peridyn's backends (which
    /// [`crate::backend::factory`] maps to a backend); `None` for explicit integrators.
    fn solve(&self) -> Option<&ImplicitSolve> {
        None
    }

    /// True when it solves for equilibrium or implicit dynamics (a tangent or its products)
    /// rather than stepping explicitly: `peridyn check` then plans the tangent, its pattern
    /// and the exchanges of implicit solves. Default: it has a [`Integrator::solve`].
    fn is_implicit(&self) -> bool {
        self.solve().is_some()
    }

    /// Its time step, when it advances by one; `None` for load-stepped integrators.
    fn time_step(&self) -> Option<TimeStep> {
        None
    }

    /// The steps (output calls) it plans over `span` seconds with the stable time step
    /// `estimate`, for `peridyn check`'s disk plan; `None` when unknown. Default: the steps of
    /// its [`Integrator::time_step`] ([`step_count`]).
    fn planned_steps(&self, span: f64, estimate: Option<f64>) -> Option<u64> {
        step_count(span, self.time_step()?.with_estimate(estimate)?)
    }

    /// Refuses to run list `list` on `ranks` ranks when this build cannot. Default: explicit
    /// integrators run on any number of ranks, implicit ones need a distributed backend
    /// ([`factory::check_ranks`]).
    fn check_ranks(&self, list: &str, ranks: usize) -> Result<(), Unsupported> {
        match self.solve() {
            Some(solve) => factory::check_ranks(solve, ranks),
            None if self.is_implicit() && ranks > 1 => {
                Err(factory::not_on_ranks(list, self.name(), ranks))
            }
            None => Ok(()),
        }
    }

    /// What of it this build cannot run, for `peridyn check`'s list of unsupported features.
    /// Default: what the native backend cannot do of its solve
    /// ([`factory::native_limitation`]).
    fn unavailable(&self) -> Option<String> {
        self.solve().and_then(factory::native_limitation)
    }

    /// How it treats a step that fails or breaks too many bonds (cuts, hand-offs), one line
    /// each, for `peridyn check`'s plan; empty by default.
    fn step_strategy(&self) -> Vec<String> {
        Vec::new()
    }

    /// Runs list `list` from its initial time, or from where the run resumes inside it
    /// ([`ListRun::resume`]), to its final time. On failure every rank stops with the error
    /// the driver holds ([`Stop`]).
    fn run(&self, list: &ListSettings, run: &mut ListRun<'_>) -> Result<(), Stop>;
}

/// The integrator a failed step is handed to, and what the deck calls the hand-off.
#[derive(Debug)]
pub struct HandOff {
    /// The deck's name of the hand-off (`Switch to Verlet`), which names the list it runs.
    pub label: &'static str,
    /// The integrator that continues.
    pub integrator: Box<dyn Integrator>,
}

impl HandOff {
    /// Continues list `list` after `failure` with the handed integrator, from the current
    /// time (the start of the failed step) to the list's final time, as the list
    /// `"<name> (<label>)"`; it neither writes nor resumes restart files inside it.
    pub fn run(
        &self,
        list: &ListSettings,
        failure: &dyn fmt::Display,
        run: &mut ListRun<'_>,
    ) -> Result<(), Stop> {
        let time = run.state.time;
        if run.root() {
            eprintln!(
                "Warning: {failure}\n{}: switching to {} from t = {time:e} to the solver's final time {:e}",
                list.name,
                self.integrator.name(),
                list.final_time
            );
        }
        let handed = ListSettings {
            name: format!("{} ({})", list.name, self.label),
            initial_time: time,
            ..list.clone()
        };
        self.integrator.run(&handed, &mut run.handed())
    }
}

/// An integrator the deck names that this build cannot run (`ImplicitDiffusion`): `peridyn
/// check` lists it, and a run stops at it.
#[derive(Debug, Clone, PartialEq)]
pub struct Unavailable {
    /// Its deck name.
    pub name: &'static str,
    /// Whether it is implicit (what `peridyn check` plans for it).
    pub implicit: bool,
    /// The steps (output calls) it would take (`peridyn check`'s disk plan).
    pub planned_steps: Option<u64>,
}

impl Integrator for Unavailable {
    fn name(&self) -> &'static str {
        self.name
    }

    fn is_implicit(&self) -> bool {
        self.implicit
    }

    fn planned_steps(&self, _span: f64, _estimate: Option<f64>) -> Option<u64> {
        self.planned_steps
    }

    fn unavailable(&self) -> Option<String> {
        Some(format!("solver {}", self.name))
    }

    fn run(&self, list: &ListSettings, run: &mut ListRun<'_>) -> Result<(), Stop> {
        let message = format!(
            "solver \"{}\": {} is not available in this build",
            list.name, self.name
        );
        Err(run.collective(Failure::Unsupported(message)))
    }
}
