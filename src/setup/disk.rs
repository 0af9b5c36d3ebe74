//! How much a run will write, against the free space of its output folder's file system.
//!
//! A run that fills the disk stops with exit code 6 ([`crate::error::WRITE_FAILED`]) and keeps
//! what it wrote, but hours may be lost by then; `peridyn check` and the start of `peridyn run`
//! estimate the volume first and warn when it exceeds the space the system reports free.
//!
//! The estimate, per Exodus file: frames × (8 bytes × (1 time value + nodal and element
//! components × points + global components)) plus the fixed part (coordinates, maps and
//! blocks: 8 × 3 + 4 × 3 bytes per point). Frames follow Peridigm's schedule (`Output
//! Frequency`, `Initial Output Step`, `Final Output Step`) over one output call for the
//! initial state and one per step: explicit steps of Δt = `Safety Factor` × (`Fixed dt` or
//! Peridigm's stable estimate), load steps of a quasi-static or diffusion list, Newmark steps
//! of `Fixed dt`. It is a lower bound where a run takes more steps than planned (cut-backs of
//! adaptive load stepping, the explicit end of `Switch to Verlet`). With restart on, three
//! restart files of the state's size (the fields the run allocates) can exist at once: the two
//! kept and the one being written.

use crate::io::deck::Deck;
use crate::io::output::{RequestedVariable, Schedule, VariableKind};
use crate::io::output_folder;
use crate::model::Model;
use crate::plan::{DiskPlan, FieldPlan};
use std::path::Path;

/// Restart files that can exist at once: the two kept and the one being written.
const RESTART_FILES_AT_ONCE: u64 = 3;

/// The disk plan of `deck` on `model` writing to `dir`, `fields` being the plan's allocated
/// fields (the state a restart file holds).
pub fn disk_plan(
    deck: &Deck,
    model: &Model,
    fields: &[FieldPlan],
    dir: &Path,
) -> Result<DiskPlan, crate::io::deck::DeckError> {
    let calls = output_calls(deck, model);
    let points = model.points.len() as u64;
    let mut results_bytes = 0u64;
    for output in &deck.outputs {
        let variables = super::report::requested_variables(deck, output)?;
        let schedule = Schedule {
            frequency: output.frequency,
            initial_step: output.initial_output_step,
            final_step: output.final_output_step,
        };
        let frames = frames(&schedule, calls);
        let frame = frame_bytes(&variables, points);
        results_bytes = results_bytes
            .saturating_add(frames.saturating_mul(frame))
            .saturating_add(points * (8 * 3 + 4 * 3));
    }
    let restart_bytes = if deck.restart.is_some() {
        let state: u64 = fields.iter().map(|f| f.bytes).sum();
        state.saturating_mul(RESTART_FILES_AT_ONCE)
    } else {
        0
    };
    Ok(DiskPlan {
        folder: dir.display().to_string(),
        results_bytes,
        restart_bytes,
        available_bytes: output_folder::available_bytes(dir),
    })
}

/// The warning a run plan carries when `disk` will not fit ([`DiskPlan::warning`]).
pub fn warning(disk: &DiskPlan) -> Option<String> {
    disk.warning()
}

/// Output calls of the whole run: one for the initial state and one per planned step.
fn output_calls(deck: &Deck, model: &Model) -> u64 {
    let estimate = super::report::critical_time_step(deck, model);
    let mut calls = 1u64;
    for list in super::solvers::solver_lists(deck) {
        let steps = list
            .integrator
            .planned_steps(list.settings.span(), estimate);
        calls = calls.saturating_add(steps.unwrap_or(0));
    }
    calls
}

/// Frames of `output` over output calls 1..=`calls` (Peridigm's schedule: call c writes when
/// c ≥ `Initial Output Step`, c − 1 ≤ `Final Output Step` and (c − 1) is a multiple of
/// `Output Frequency`).
fn frames(output: &Schedule, calls: u64) -> u64 {
    if output.frequency <= 0 || output.final_step < 0 || calls == 0 {
        return 0;
    }
    let frequency = output.frequency as u64;
    // k = c − 1 runs over [first, last].
    let first = (output.initial_step.max(1) - 1) as u64;
    let last = (calls - 1).min(output.final_step as u64);
    if first > last {
        return 0;
    }
    // Multiples of the frequency in [first, last]; `+ 1` before the subtraction, which can
    // reach zero (no multiple between first and last: a step of 10⁵ s with frequency 100).
    last / frequency + 1 - first.div_ceil(frequency)
}

/// Bytes of one frame: the time value and every component of every variable.
fn frame_bytes(variables: &[RequestedVariable], points: u64) -> u64 {
    let numbers: u64 = variables
        .iter()
        .map(|v| match v.kind {
            VariableKind::NodalVector => 3 * points,
            VariableKind::ElementScalar => points,
            VariableKind::ElementTensor => 9 * points,
            VariableKind::Global => 1,
            VariableKind::GlobalVector => 3,
        })
        .sum();
    8 * (1 + numbers)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Counted one call at a time with the schedule's own rule.
    fn counted(schedule: &Schedule, calls: u64) -> u64 {
        (1..=calls as i64).filter(|&c| schedule.writes(c)).count() as u64
    }

    #[test]
    fn frame_count_follows_the_output_schedule() {
        for (frequency, initial, last) in [
            (1, 1, i64::MAX),
            (10, 1, i64::MAX),
            (7, 5, i64::MAX),
            (3, 1, 20),
            (4, 9, 30),
            (5, 50, 10),
            (0, 1, i64::MAX),
            (100, 3, i64::MAX),
        ] {
            let o = Schedule {
                frequency,
                initial_step: initial,
                final_step: last,
            };
            // 6 calls of (7, 5): k = c − 1 runs over [4, 5], which holds no multiple of 7.
            for calls in [0, 1, 2, 6, 11, 41, 100] {
                assert_eq!(
                    frames(&o, calls),
                    counted(&o, calls),
                    "frequency {frequency}, initial {initial}, final {last}, {calls} calls"
                );
            }
        }
    }

    #[test]
    fn a_frame_holds_every_component_and_the_time() {
        let variables = [
            RequestedVariable {
                name: "Displacement".into(),
                kind: VariableKind::NodalVector,
            },
            RequestedVariable {
                name: "Damage".into(),
                kind: VariableKind::ElementScalar,
            },
            RequestedVariable {
                name: "Reaction".into(),
                kind: VariableKind::GlobalVector,
            },
        ];
        // 8 bytes × (1 time + 3·10 + 10 + 3).
        assert_eq!(frame_bytes(&variables, 10), 8 * 44);
    }

    #[test]
    fn the_warning_names_the_volume_and_the_free_space() {
        let disk = DiskPlan {
            folder: "out".into(),
            results_bytes: 3 << 30,
            restart_bytes: 1 << 30,
            available_bytes: Some(2 << 30),
        };
        let text = warning(&disk).expect("4 GiB do not fit in 2 GiB");
        assert!(
            text.contains("4.0 GiB") && text.contains("2.0 GiB") && text.contains("out"),
            "{text}"
        );
        let room = DiskPlan {
            available_bytes: Some(5 << 30),
            ..disk.clone()
        };
        assert_eq!(warning(&room), None);
        let unknown = DiskPlan {
            available_bytes: None,
            ..disk
        };
        assert_eq!(warning(&unknown), None);
    }
}
