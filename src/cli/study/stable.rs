//! `peridyn study DECK --stable-dt`: the largest stable time step of an explicit deck, found by
//! bisection on the `Safety Factor` of its first `Verlet` list. Each trial is a child run like
//! a study's variant, and the run's own stability monitor decides: exit code 3 (the monitor
//! stopped the run) is unstable, a run to the final time is stable. The result is reported
//! against the Silling–Askari estimate the run prints (Δt = Safety Factor × estimate, so the
//! ratio of the stable step to the estimate is the Safety Factor itself).
//!
//! The search starts at Safety Factor 1, doubles (or halves) until it has a stable and an
//! unstable factor, then bisects until they differ by less than the relative tolerance. A run
//! is only watched up to the deck's `Final Time`: a step just above the limit grows slowly and
//! may not trip the monitor in a short run, so the bracket's unstable end is the sound bound.

use peridyn::io::deck::{Deck, Variation};
use peridyn::setup::solvers::solver_lists;
use peridyn::solver::integrator::TimeStep;

use super::grid::Variant;
use super::runner::{self, Outcome, Setup};
use super::table::{number, Cell, Table};
use super::StudyError;

/// Factors beyond which the search gives up (2⁶ above or below the estimate).
const FARTHEST: f64 = 64.0;

/// One trial run.
#[derive(Debug, Clone)]
pub struct Trial {
    /// The Safety Factor tried.
    pub safety_factor: f64,
    /// The run's outcome.
    pub outcome: Outcome,
}

impl Trial {
    /// True when the run reached its final time.
    pub fn stable(&self) -> bool {
        self.outcome.failure.is_none()
    }
}

/// The key path of the first explicit list's `Safety Factor` (the list whose time step
/// scales the stable estimate), or why the deck has none to vary.
pub fn safety_factor_path(deck: &Deck) -> Result<Vec<String>, String> {
    let (list, fixed) = solver_lists(deck)
        .into_iter()
        .find_map(|list| match list.integrator.time_step()? {
            TimeStep::Stable { fixed, .. } => Some((list, fixed)),
            TimeStep::Fixed(_) => None,
        })
        .ok_or_else(|| {
            format!(
                "{}: --stable-dt needs an explicit deck (a solver list with a Verlet sublist)",
                deck.path.display()
            )
        })?;
    let (name, integrator) = (&list.settings.name, list.integrator.name());
    if fixed.is_some() {
        return Err(format!(
            "{}: {name} → {integrator} → Fixed dt: --stable-dt scales the stable estimate; remove Fixed dt",
            deck.path.display(),
        ));
    }
    Ok(vec![
        name.clone(),
        integrator.to_string(),
        "Safety Factor".to_string(),
    ])
}

/// Runs the bisection; returns the trials in order.
pub fn search(setup: &Setup, path: &[String], tolerance: f64) -> Result<Vec<Trial>, StudyError> {
    let mut trials: Vec<Trial> = Vec::new();
    let mut run = |safety_factor: f64| -> Result<bool, StudyError> {
        let variations = [Variation {
            path: path.to_vec(),
            linked: Vec::new(),
            values: vec![format!("{safety_factor}")],
            line: None,
        }];
        let trial_setup = Setup {
            executable: setup.executable.clone(),
            deck: setup.deck,
            folder: setup.folder,
            threads: setup.threads,
            variations: &variations,
            measures: &[],
        };
        let variant = Variant {
            index: trials.len(),
            values: variations[0].values.clone(),
        };
        let outcome = runner::run_one(&trial_setup, variant);
        let trial = Trial {
            safety_factor,
            outcome,
        };
        let stable = trial.stable();
        eprintln!(
            "study: Safety Factor {safety_factor}: {}",
            if stable { "stable" } else { "unstable" }
        );
        if let Some(reason) = &trial.outcome.failure {
            if !reason.starts_with("unstable") {
                return Err(StudyError::Output(format!(
                    "Safety Factor {safety_factor}: the run failed for another reason than instability: {reason}"
                )));
            }
        }
        trials.push(trial);
        Ok(stable)
    };
    let (mut stable, mut unstable) = (None::<f64>, None::<f64>);
    let mut factor = 1.0;
    while stable.is_none() || unstable.is_none() {
        if !(1.0 / FARTHEST..=FARTHEST).contains(&factor) {
            return Err(StudyError::Output(format!(
                "no stable and unstable Safety Factor between 1/{FARTHEST} and {FARTHEST}: \
                 lengthen the deck's Final Time so that an unstable step has time to grow"
            )));
        }
        if run(factor)? {
            stable = Some(factor);
            factor *= 2.0;
        } else {
            unstable = Some(factor);
            factor /= 2.0;
        }
    }
    let (mut low, mut high) = (stable.unwrap_or(1.0), unstable.unwrap_or(1.0));
    while (high - low) / low > tolerance {
        let middle = 0.5 * (low + high);
        if run(middle)? {
            low = middle;
        } else {
            high = middle;
        }
    }
    Ok(trials)
}

/// The bracket of the trials: (largest stable, smallest unstable) Safety Factor.
pub fn bracket(trials: &[Trial]) -> (Option<f64>, Option<f64>) {
    let stable = trials
        .iter()
        .filter(|t| t.stable())
        .map(|t| t.safety_factor)
        .fold(None, |best: Option<f64>, f| {
            Some(best.map_or(f, |b| b.max(f)))
        });
    let unstable = trials
        .iter()
        .filter(|t| !t.stable())
        .map(|t| t.safety_factor)
        .fold(None, |best: Option<f64>, f| {
            Some(best.map_or(f, |b| b.min(f)))
        });
    (stable, unstable)
}

/// The table of the trials.
pub fn table(trials: &[Trial]) -> Table {
    let header = [
        "trial",
        "Safety Factor",
        "dt_s",
        "status",
        "steps",
        "wall_s",
        "reason",
        "folder",
    ]
    .map(String::from)
    .to_vec();
    let rows = trials
        .iter()
        .enumerate()
        .map(|(k, t)| {
            let dt = t.outcome.stable_estimate.map(|e| e * t.safety_factor);
            vec![
                Cell::new(k.to_string()),
                Cell::new(format!("{}", t.safety_factor)),
                Cell::new(dt.map_or_else(String::new, |d| format!("{d:.4e}"))),
                Cell::new(if t.stable() { "stable" } else { "unstable" }),
                Cell::new(
                    t.outcome
                        .cost
                        .steps
                        .map_or_else(String::new, |s| s.to_string()),
                ),
                Cell::new(number(Some(t.outcome.cost.wall_seconds))),
                Cell {
                    short: String::new(),
                    full: t.outcome.failure.clone().unwrap_or_default(),
                },
                Cell::new(t.outcome.folder.display().to_string()),
            ]
        })
        .collect();
    Table {
        header,
        rows,
        csv_only: vec![6, 7],
    }
}

/// The summary lines under the table.
pub fn summary(trials: &[Trial]) -> String {
    let estimate = trials.iter().find_map(|t| t.outcome.stable_estimate);
    let (stable, unstable) = bracket(trials);
    let mut out = String::new();
    if let (Some(low), Some(high)) = (stable, unstable) {
        out.push_str(&format!(
            "largest stable Safety Factor: between {low} (stable to the final time) and {high} (unstable)\n"
        ));
        if let Some(estimate) = estimate {
            out.push_str(&format!(
                "largest stable time step: {:.4e} to {:.4e} s, {low}–{high} × the Silling–Askari estimate {estimate:.4e} s\n",
                low * estimate,
                high * estimate
            ));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cli::study::cost::Cost;
    use std::path::PathBuf;

    fn trial(safety_factor: f64, stable: bool) -> Trial {
        Trial {
            safety_factor,
            outcome: Outcome {
                variant: Variant {
                    index: 0,
                    values: Vec::new(),
                },
                folder: PathBuf::new(),
                cost: Cost::default(),
                points: None,
                stable_estimate: Some(1e-6),
                values: Vec::new(),
                failure: (!stable).then(|| "unstable or not converged (exit 3)".to_string()),
            },
        }
    }

    #[test]
    fn the_bracket_is_the_largest_stable_and_smallest_unstable_factor() {
        let trials = [
            trial(1.0, true),
            trial(2.0, true),
            trial(4.0, false),
            trial(3.0, false),
            trial(2.5, true),
        ];
        assert_eq!(bracket(&trials), (Some(2.5), Some(3.0)));
        let text = summary(&trials);
        assert!(
            text.contains("between 2.5 (stable to the final time) and 3 (unstable)"),
            "{text}"
        );
        assert!(text.contains("2.5000e-6 to 3.0000e-6 s"), "{text}");
    }
}
