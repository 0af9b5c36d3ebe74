//! `DynamicRelaxation`: adaptive dynamic relaxation (Kilic & Madenci 2010, "An adaptive
//! dynamic relaxation method for quasi-static simulations using the peridynamic theory",
//! Theor. Appl. Fract. Mech. 53), load-stepped like `QuasiStatic`: each load step is relaxed
//! to equilibrium by a damped pseudo-dynamics whose fictitious mass makes a unit time step
//! stable, instead of by Newton's method. It needs no linear solve, so it goes on where
//! Newton stalls: a stiffness made singular or indefinite by a growing crack, loose
//! fragments, softening.
//!
//! [`AdaptiveRelaxation`] ([`super::relaxation`]) relaxes each step: the iteration, its
//! fictitious density and damping are documented there. The load stepping, its cuts
//! (`Adaptive Load-Stepping`), the tolerance (Peridigm's measure, as `QuasiStatic`), output
//! and restart files are [`LoadStepped`]'s, so a `DynamicRelaxation` list runs, resumes and
//! reports as a `QuasiStatic` list does, on one rank or N.

use super::integrator::{HandOff, Integrator, ListSettings};
use super::list_run::{ListRun, Stop};
use super::load_stepped::{planned_load_steps, step_strategy, LoadStepped};
use super::newton::ConvergenceMeasure;
use super::quasistatic::{self, AdaptiveLoadStepping, LoadSteps, QuasiStaticSettings};
use super::relaxation::AdaptiveRelaxation;
use crate::backend::Unsupported;

/// `DynamicRelaxation`: load steps relaxed by [`AdaptiveRelaxation`].
#[derive(Debug)]
pub struct DynamicRelaxation {
    /// `Number of Load Steps` or `Time Steps`.
    pub load_steps: LoadSteps,
    /// `Maximum Solver Iterations`: relaxation iterations per load step; default
    /// [`super::relaxation::DEFAULT_MAX_ITERATIONS`].
    pub max_iterations: u64,
    /// `Relative Tolerance`: the criterion is this × ‖reaction‖₂ (as `QuasiStatic`); default
    /// 1e-6.
    pub relative_tolerance: f64,
    /// `Absolute Tolerance` (N): replaces the relative one when given.
    pub absolute_tolerance: Option<f64>,
    /// `Adaptive Load-Stepping`: cut load steps that do not converge or break too many bonds;
    /// default off.
    pub adaptive: Option<AdaptiveLoadStepping>,
    /// Where a step that does not converge and cannot be cut goes (`Switch to Verlet`);
    /// default none: the run stops.
    pub hand_off: Option<HandOff>,
}

impl Integrator for DynamicRelaxation {
    fn name(&self) -> &'static str {
        "DynamicRelaxation"
    }

    /// It assembles the tangent once per load step for the fictitious density.
    fn is_implicit(&self) -> bool {
        true
    }

    fn planned_steps(&self, _span: f64, _estimate: Option<f64>) -> Option<u64> {
        Some(planned_load_steps(&self.load_steps))
    }

    /// No linear solve: it runs on any number of ranks with any build.
    fn check_ranks(&self, _list: &str, _ranks: usize) -> Result<(), Unsupported> {
        Ok(())
    }

    fn unavailable(&self) -> Option<String> {
        None
    }

    fn step_strategy(&self) -> Vec<String> {
        let mut lines = vec![format!(
            "each load step relaxed by adaptive dynamic relaxation, at most {} iterations; no linear solver",
            self.max_iterations
        )];
        lines.extend(step_strategy(
            self.adaptive.as_ref(),
            None,
            self.hand_off.as_ref(),
        ));
        lines
    }

    fn run(&self, list: &ListSettings, run: &mut ListRun<'_>) -> Result<(), Stop> {
        let settings = QuasiStaticSettings {
            times: quasistatic::load_step_times(
                &self.load_steps,
                list.initial_time,
                list.final_time,
            ),
            max_iterations: self.max_iterations,
            relative_tolerance: self.relative_tolerance,
            absolute_tolerance: self.absolute_tolerance,
            measure: ConvergenceMeasure::PeridigmQuasiStatic,
            predictor: list.heuristics,
            predict_first_step: list.predict_first_step,
            line_search: false,
            verbose: list.verbose,
            adaptive: self.adaptive.clone(),
            relaxation: None,
            resume: None,
        };
        let stepped = LoadStepped {
            name: "DynamicRelaxation",
            settings,
            hand_off: self.hand_off.as_ref(),
        };
        stepped.run(list, &mut AdaptiveRelaxation::default(), run)
    }
}
