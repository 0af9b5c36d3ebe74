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
mod progress;

pub use distributed::{
    check_distributable, global_families_reason, global_model, run_distributed, GlobalFamilies,
};
pub use fields::{prepare_compute_classes, Fields, PreparedComputeClass};
pub use outputs::SOLVER_HISTORY_COLUMNS;

use crate::boundary::BoundaryError;
use crate::io::deck::Deck;
use crate::io::output::OutputError;
use crate::parallel::SerialRanks;
use crate::physics::Physics;
use crate::setup::{self, Model};
use crate::solver::newmark::NewmarkError;
use crate::solver::quasistatic::QuasiStaticError;
use crate::solver::{EnergyMonitor, Instability};
use crate::state::{History, State};
use driver::Run;
use outputs::RunOutputs;
use std::path::{Path, PathBuf};

/// Why a run stopped early.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// Writing results failed.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// A boundary-condition expression failed during the run.
    #[error(transparent)]
    Boundary(#[from] BoundaryError),
    /// A solver needs something this build does not have.
    #[error("{0}")]
    Unsupported(String),
    /// A quasi-static solve failed (exit code 3).
    #[error(transparent)]
    QuasiStatic(#[from] QuasiStaticError),
    /// The discretization failed while the ranks of a distributed run searched their
    /// families (exit code 2, as bad input found before a run).
    #[error(transparent)]
    Setup(#[from] setup::SetupError),
    /// A Newmark-β solve failed (exit code 3).
    #[error(transparent)]
    Newmark(#[from] NewmarkError),
    /// The explicit run became unstable (exit code 3).
    #[error(
        "the run became unstable at step {} of solver \"{solver}\" (t = {:.4e} s): kinetic energy {:.4e} exceeds {}× the energy supplied to the body ({:.4e}). \
         The time step was {time_step:.4e} s; Peridigm's stable estimate is {estimate}. \
         Reduce \"Safety Factor\" (e.g. 0.5) or give a smaller \"Fixed dt\". \
         Output written up to the last frame before the failure is valid.",
        instability.step, instability.time, instability.kinetic_energy, EnergyMonitor::GROWTH_LIMIT, instability.budget,
        estimate = .estimate.map(|e| format!("{e:.4e} s")).unwrap_or_else(|| "not available".into())
    )]
    Unstable {
        /// Solver list name.
        solver: String,
        /// What the monitor saw.
        instability: Instability,
        /// Δt used.
        time_step: f64,
        /// The stable estimate.
        estimate: Option<f64>,
    },
    /// Another rank of a distributed run failed (or reports an error all ranks share); that
    /// rank prints the message, this one stops quietly with the same exit code.
    #[error("rank {rank} stopped the run; its message is above")]
    OtherRank {
        /// The rank that reports the failure.
        rank: usize,
        /// Its exit code.
        code: u8,
    },
}

impl RunError {
    /// Process exit code: 3 for solver failures and instabilities, 1 otherwise (for
    /// [`RunError::OtherRank`], the code of the rank that failed).
    pub fn exit_code(&self) -> u8 {
        match self {
            RunError::Unstable { .. } | RunError::QuasiStatic(_) | RunError::Newmark(_) => 3,
            RunError::OtherRank { code, .. } => *code,
            RunError::Setup(_) => 2,
            _ => 1,
        }
    }
}

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
    let mut physics =
        setup::build_physics(deck, model).map_err(|e| RunError::Unsupported(e.to_string()))?;
    let compute_classes =
        prepare_compute_classes(&deck.compute_classes, model).map_err(RunError::Unsupported)?;
    let mut state = initial_state(deck, model, &physics)?;
    let mut ranks = SerialRanks {
        points: model.points.len(),
    };
    let mut run = Run {
        model,
        ranks: &mut ranks,
        ghosts: None,
        compute_classes: &compute_classes,
        outputs: RunOutputs::one_rank(deck, model, dir)?,
        summary: RunSummary::default(),
        nonlinear_iterations: None,
    };
    match run.solve(deck, &mut physics, &mut state) {
        Ok(()) => run.finish(),
        Err(error) => Err(run.abandon(error)),
    }
}

/// The state at the first solver's initial time: at rest, with intact bond damage when a block
/// has a damage model and the material history its materials declare, then the deck's initial
/// conditions.
fn initial_state(deck: &Deck, model: &Model, physics: &Physics) -> Result<State, RunError> {
    let t0 = deck.solvers.first().map_or(0.0, |s| s.initial_time);
    let mut state = State::at_rest(&model.points.position, t0, model.boundary.has_body_force())
        .with_bond_damage(physics.has_bond_damage().then(|| model.bonds.num_bonds()));
    state.history = History::allocate(
        physics
            .blocks
            .iter()
            .flat_map(|block| block.material.declaration().fields),
        model.points.len(),
        model.bonds.num_bonds(),
    );
    model.boundary.apply_initial(
        &model.points.position,
        t0,
        &mut state.displacement,
        &mut state.velocity,
    )?;
    Ok(state)
}
