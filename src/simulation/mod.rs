//! A run from start to finish: initial conditions, the deck's solvers in order, outputs, the
//! stability monitor and progress reporting, on one rank ([`run`]) or on N MPI ranks
//! ([`run_distributed`]). Both set up their rank and hand it to the one driver
//! (`driver::Run`), which runs every solver through the same code over
//! [`crate::parallel::Ranks`].

mod agreement;
mod distributed;
mod driver;
mod fields;
mod outputs;
mod restarts;

/// The run error lives in [`crate::error`] (reachable from every module); re-exported here
/// under the name call sites use.
pub use crate::error::RunError;
pub use crate::parallel::{check_distributable, global_families_reason};
pub use distributed::{global_model, run_distributed, GlobalFamilies};
pub use fields::{prepare_compute_classes, Fields, PreparedComputeClass};
pub use outputs::SOLVER_HISTORY_COLUMNS;

use crate::io::deck::Deck;
use crate::model::Model;
use crate::parallel::{Serial, SerialRanks};
use crate::physics::Physics;
use crate::setup;
use crate::state::{History, State};
use driver::Run;
use outputs::RunOutputs;
use std::path::{Path, PathBuf};

/// What a finished run reports.
#[derive(Debug, Clone, Default)]
pub struct RunSummary {
    /// Explicit steps taken over all solvers.
    pub steps: u64,
    /// Wall-clock seconds in the solvers.
    pub solve_seconds: f64,
    /// Wall-clock seconds writing output.
    pub output_seconds: f64,
    /// Files written.
    pub files: Vec<PathBuf>,
    /// Bonds broken during the run.
    pub broken_bonds: usize,
}

/// Energy scale below which the monitor treats changes as round-off: the strain energy of the
/// whole body at a uniform strain of 1e-6 (½ K ε² V summed), with the volume each point
/// counts with (zero for the ghosts of a distributed run, whose ranks sum their shares).
fn energy_floor_of(physics: &Physics, volume: impl Fn(u32) -> f64) -> f64 {
    physics
        .blocks
        .iter()
        .map(|b| {
            let volume: f64 = b.material.points().iter().map(|&p| volume(p)).sum();
            0.5 * b.material.bulk_modulus() * 1e-12 * volume
        })
        .sum()
}

/// Runs every solver list of the deck in order on one state, writing outputs to `dir`.
/// Output frames already written stay valid whatever happens later.
pub fn run(deck: &Deck, model: &Model, dir: &Path) -> Result<RunSummary, RunError> {
    let mut physics = build_physics(deck, model)?;
    let compute_classes =
        prepare_compute_classes(&deck.compute_classes, model).map_err(RunError::Unsupported)?;
    let mut state = initial_state(deck, model, &physics)?;
    let mut ranks = SerialRanks {
        points: model.points.len(),
    };
    let (restarts, start) = match deck.restart {
        Some(_) => {
            let every_point = (0..model.points.len() as u32).collect();
            let (restarts, start) =
                restarts::Restarts::open(deck, model, model, every_point, &Serial, dir)?;
            (Some(restarts), start)
        }
        None => (None, restarts::Start::Fresh),
    };
    let mut summary = RunSummary::default();
    let (restarts, continued) = match (restarts, start) {
        (Some(mut restarts), restarts::Start::Continue(snapshot)) => {
            restarts.apply(&snapshot, model, &physics, &Serial, &mut state)?;
            summary.steps = snapshot.steps;
            summary.broken_bonds = snapshot.broken_bonds as usize;
            let outputs = RunOutputs::one_rank(deck, model, dir, Some(&snapshot))?;
            restarts.resume_at(snapshot);
            (Some(restarts), Some(outputs))
        }
        (Some(mut restarts), restarts::Start::FromState(snapshot)) => {
            restarts.apply(&snapshot, model, &physics, &Serial, &mut state)?;
            restarts.start_from_saved_state();
            (Some(restarts), None)
        }
        (restarts, _) => (restarts, None),
    };
    let outputs = match continued {
        Some(outputs) => outputs,
        None => RunOutputs::one_rank(deck, model, dir, None)?,
    };
    let mut run =
        Run::new(model, &mut ranks, None, &compute_classes, outputs).with_restarts(restarts);
    run.summary = summary;
    run.complete(deck, &mut physics, &mut state)
}

/// The physics of this rank's `model` (the whole model on one rank); a model or key this
/// build cannot run is [`RunError::Unsupported`].
fn build_physics(deck: &Deck, model: &Model) -> Result<Physics, RunError> {
    setup::build_physics(deck, model).map_err(|e| RunError::Unsupported(e.to_string()))
}

/// The state at the first solver's initial time: at rest, with the initial bond damage of the
/// damage models when a block has one (intact bonds, or a pre-crack of `Initial Damage`), no
/// contact search yet and the material history its materials declare, then the deck's initial
/// conditions.
fn initial_state(deck: &Deck, model: &Model, physics: &Physics) -> Result<State, RunError> {
    let t0 = deck.solvers.first().map_or(0.0, |s| s.initial_time);
    let mut state = State::at_rest(&model.points.position, t0, model.boundary.has_body_force())
        .with_bond_damage(physics.has_bond_damage().then(|| model.bonds.num_bonds()))
        .with_contact(physics.contact.as_ref().map(|c| c.initial_state()));
    if let Some(bond_damage) = &mut state.bond_damage {
        physics.initialize_bond_damage(&model.bonds, &model.points, bond_damage.trial_mut());
    }
    state.history = History::allocate(
        physics
            .blocks
            .iter()
            .flat_map(|block| block.material.declaration().fields),
        model.points.len(),
        model.bonds.num_bonds(),
    );
    if model.boundary.has_temperature() {
        let mut history = std::mem::take(&mut state.history).with_thermal(model.points.len());
        if let Some(thermal) = history.thermal_mut() {
            model.boundary.initial_temperature(
                &model.points.position,
                t0,
                &mut thermal.temperature,
                &mut thermal.change,
            )?;
        }
        state.history = history;
    }
    model.boundary.apply_initial(
        &model.points.position,
        t0,
        &mut state.displacement,
        &mut state.velocity,
    )?;
    Ok(state)
}
