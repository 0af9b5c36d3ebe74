//! The set-up of a run on N MPI ranks: the same answers as one rank, one results file. Each
//! rank cuts its subdomain, builds its physics and state, and hands them with its
//! [`SubdomainRanks`] to the one driver that one rank runs too.
//!
//! Every rank holds the points of the whole model (built from the deck by each rank, see
//! [`global_model`]; families only for its own points and ghosts, except in contact decks)
//! and runs on its [`Subdomain`]: owned points plus ghosts whose current positions are refreshed by one halo
//! exchange per step (velocity Verlet) or per residual evaluation (the implicit solvers, on
//! the Trilinos backend: quasi-static load steps and Newmark-β). Each rank evaluates damage and
//! forces of its owned points from exactly the numbers one rank would use, in the same order
//! (see [`crate::parallel`]).
//!
//! Collectives per step: the halo exchange, one sum of (kinetic energy, supplied work, failure
//! count) for the stability monitor and for failure agreement, and, on output steps, one gather
//! per written point field. Rank 0 gathers the point fields in the global run order and writes
//! every file through the ordinary [`crate::io::output::OutputFile`], so the globals (energies, `Block_Data`,
//! `Node_Set_Data`, `Nearest_Point_Data`) are reduced over the same numbers in the same order
//! as on one rank.
//!
//! # Restart files
//! With a `Restart` entry, the ranks open the restart files together before the results files
//! (a continuation keeps the results written so far): every rank reads the newest file and
//! takes the values of its owned points and ghosts, and every file written is gathered on
//! rank 0 in the user's original order (see [`crate::restart`]), so the rank count may change
//! between a run and its continuation. The summary's broken bonds are then counted from the
//! owned rows' damage, with those of the run continued carried over.
//!
//! # Failures
//! Problems every rank sees alike (a solver or feature that cannot run on N ranks, an
//! instability seen by the global monitor) are reported by rank 0 alone. A failure on some
//! ranks only (an expression that fails at one point, an output file rank 0 cannot write) is
//! folded into the next collective: every rank stops at the same step, the lowest failing rank
//! reports its error and the others return [`RunError::OtherRank`] (see `agreement`). A panic ends all ranks
//! through the panic hook of [`crate::parallel::initialize`] (MPI_Abort).

use super::agreement::{agree, collective};
use super::driver::Run;
use super::outputs::{DistributedOutputs, RunOutputs};
use super::restarts::{Restarts, Start};
use super::{build_physics, initial_state, prepare_compute_classes, RunError, RunSummary};
use crate::discretization::FamilyRule;
use crate::io::deck::Deck;
use crate::model::Model;
use crate::neighbors::NeighborhoodRule;
use crate::parallel::{
    check_distributable, global_families_reason, halo_depth, outer_ghosts_need_physics,
    Communicator, Subdomain, SubdomainRanks,
};
use crate::physics::Physics;
use crate::restart::Snapshot;
use crate::setup;
use crate::state::State;
use std::path::Path;

/// Directed bonds of owned rows that are broken (d = 1), summed over ranks. Collective.
fn broken_bonds(comm: &dyn Communicator, sub: &Subdomain, state: &State) -> usize {
    let Some(damage) = state.bond_damage() else {
        return 0;
    };
    let bonds = &sub.model.bonds;
    let local: usize = sub
        .owned()
        .iter()
        .map(|&i| {
            damage[bonds.range(i as usize)]
                .iter()
                .filter(|&&d| d >= 1.0)
                .count()
        })
        .sum();
    let mut count = [local as f64];
    comm.sum(&mut count);
    count[0] as usize
}

/// Where the ranks of a distributed run get their points' families.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum GlobalFamilies {
    /// The global model holds every point's family (contact decks, whose search needs the
    /// global bonds, and the QuickGrid cylinder, whose families come from index space).
    Built,
    /// The global model has no families ([`setup::build_points`]); each rank searches the
    /// rows of its own points and ghosts with this rule ([`Subdomain::searched`]), so no rank
    /// holds the global bond list.
    Searched(NeighborhoodRule),
}

/// The model every rank of a distributed run builds from the deck: points, blocks, node sets
/// and conditions of the whole discretization, and the families only where
/// [`GlobalFamilies::Built`] says they are needed. Fails on every rank alike.
pub fn global_model(deck: &Deck) -> Result<(Model, GlobalFamilies), setup::SetupError> {
    let (mut model, rule) = setup::build_points(deck)?;
    match rule {
        FamilyRule::Search(rule) if global_families_reason(deck).is_none() => {
            Ok((model, GlobalFamilies::Searched(rule)))
        }
        rule => {
            setup::build_families(deck, &mut model, &rule)?;
            Ok((model, GlobalFamilies::Built))
        }
    }
}

/// Runs every solver list of the deck (those [`check_distributable`] accepts) on
/// `comm.size()` ranks. Every rank calls it with the same deck and the global model of
/// [`global_model`]; rank 0 writes the outputs to `dir` and returns the summary with the
/// files.
pub fn run_distributed(
    deck: &Deck,
    global: &Model,
    families: GlobalFamilies,
    dir: &Path,
    comm: &dyn Communicator,
) -> Result<RunSummary, RunError> {
    check_on_ranks(deck, comm)?;
    let compute_classes = prepare_compute_classes(&deck.compute_classes, global)
        .map_err(|e| collective(comm, RunError::Unsupported(e)))?;
    let rank = comm.rank();
    let mut sub = subdomain(deck, global, families, comm)?;
    // The ranks together find what one rank finds in `setup::validate`: each looks at the
    // bonds of its own points, whose ends all have their rows among its points and ghosts.
    let one_way = setup::one_way_bonds::first_one_way_bond(&sub.model, sub.owned())
        .map(|bond| setup::one_way_bonds::refusal(deck, &sub.model, bond));
    agree(
        comm,
        one_way.map_or(Ok(()), |e| Err(RunError::Setup(e.into()))),
    )?;
    let mut bonds = [sub
        .owned()
        .iter()
        .map(|&l| sub.model.bonds.family_size(l as usize) as f64)
        .sum::<f64>()];
    comm.sum(&mut bonds);
    // From here on, failures may differ between ranks: every step agrees.
    let (mut physics, mut state) = agree(comm, rank_physics(deck, global, &sub, rank))?;
    let (restarts, resume, carried) = restart(deck, global, &sub, &physics, comm, dir, &mut state)?;
    let outputs =
        DistributedOutputs::create(deck, global, dir, &compute_classes, rank, resume.as_ref());
    let outputs = agree(comm, outputs)?;
    let restarts = restarts.map(|mut restarts| {
        if let Some(snapshot) = resume {
            restarts.resume_at(snapshot);
        }
        restarts
    });
    if rank == 0 {
        let volume = sub.plan.volume();
        eprintln!(
            "{} bonds; {} ranks, ghost depth {}: rank 0 owns {} points, receives {} ghosts ({} bytes of positions per step) from {} ranks",
            bonds[0],
            comm.size(),
            sub.plan.depth(),
            sub.owned().len(),
            volume.received_points,
            volume.received_bytes(3),
            volume.neighbor_ranks
        );
    }
    let broken_at_start = broken_bonds(comm, &sub, &state);
    let ghosts = sub.ghost_mask();
    let owned = sub.owned().to_vec();
    let Subdomain {
        partition,
        plan,
        model,
    } = &mut sub;
    let mut ranks = SubdomainRanks::new(comm, plan, ghosts.clone(), global, model);
    let outputs = RunOutputs::Ranks {
        outputs,
        partition,
        owned,
    };
    let mut run = Run::new(model, &mut ranks, Some(ghosts), &compute_classes, outputs)
        .with_restarts(restarts);
    run.summary.steps = carried.steps;
    let mut summary = run.complete(deck, &mut physics, &mut state)?;
    summary.broken_bonds =
        carried.broken_bonds + broken_bonds(comm, &sub, &state) - broken_at_start;
    Ok(summary)
}

/// Fails, on every rank alike, for what a deck asks that cannot run on `comm.size()` ranks.
fn check_on_ranks(deck: &Deck, comm: &dyn Communicator) -> Result<(), RunError> {
    crate::setup::solvers::check_ranks(deck, comm.size())
        .and_then(|()| check_distributable(deck, comm.size()))
        .map_err(|e| collective(comm, e.into()))?;
    if let Some((block, rule)) = setup::quadrature::widening_blocks(deck).first() {
        return Err(collective(
            comm,
            RunError::Unsupported(format!(
                "Blocks → {block} → Quadrature \"{}\" on {} ranks is not available: the rule widens the families past the horizon, beyond the ghost layer a rank holds; use \"Full Volume\" or \"PDLAMMPS\", or run on one rank",
                rule.name(),
                comm.size()
            )),
        ));
    }
    if let Some((block, correction)) = setup::surface_correction::corrected_blocks(deck).first() {
        return Err(collective(
            comm,
            RunError::Unsupported(format!(
                "Blocks → {block} → Surface Correction \"{}\" on {} ranks is not available: a bond's factor needs the whole families of both its ends, which a rank's ghost points do not have; remove the key or run on one rank",
                correction.name(),
                comm.size()
            )),
        ));
    }
    Ok(())
}

/// This rank's subdomain of `global`, its families taken from the global model or searched
/// for its own points and ghosts (see [`GlobalFamilies`]). Collective.
fn subdomain(
    deck: &Deck,
    global: &Model,
    families: GlobalFamilies,
    comm: &dyn Communicator,
) -> Result<Subdomain, RunError> {
    let (depth, outer) = (halo_depth(deck), outer_ghosts_need_physics(deck));
    match families {
        GlobalFamilies::Built => Ok(Subdomain::new(
            global,
            comm.size(),
            comm.rank(),
            depth,
            outer,
        )),
        GlobalFamilies::Searched(rule) => {
            Subdomain::searched(global, comm, depth, outer, |points| {
                agree(
                    comm,
                    setup::family_rows(deck, global, rule, points).map_err(RunError::from),
                )
            })
        }
    }
}

/// The physics and initial state of this rank's subdomain: forces of the owned points only,
/// and contact, when the deck has it, searched on the global model. Not collective: its
/// failure may be this rank's alone.
fn rank_physics(
    deck: &Deck,
    global: &Model,
    sub: &Subdomain,
    rank: usize,
) -> Result<(Physics, State), RunError> {
    let mut physics = build_physics(deck, &sub.model)?;
    // Ghost forces are never used: only the owned points' are computed.
    let ghost = sub.ghost_mask();
    physics.restrict_forces(&|p| !ghost[p as usize]);
    // Contact searches the deformed configuration of the whole model: it is built on the
    // global model (global bonds decide who may touch) and keeps its own exchange.
    if physics.contact.is_some() {
        physics.contact = crate::contact::Contact::from_deck(deck, global)
            .map_err(|e| RunError::Unsupported(e.to_string()))?
            .map(|contact| contact.on_ranks(global, &sub.partition, rank, sub.plan.global()));
    }
    let state = initial_state(deck, &sub.model, &physics)?;
    Ok((physics, state))
}

/// The restart files of a deck with a `Restart` entry, opened by all ranks together, with the
/// newest file's values put into `state`: the files, the snapshot a continued run resumes its
/// outputs from, and the steps and broken bonds it carries over. Collective.
///
/// Restart files hold every point in original order, whatever the partition: the run that
/// wrote them may have had another number of ranks.
fn restart(
    deck: &Deck,
    global: &Model,
    sub: &Subdomain,
    physics: &Physics,
    comm: &dyn Communicator,
    dir: &Path,
    state: &mut State,
) -> Result<(Option<Restarts>, Option<Snapshot>, RunSummary), RunError> {
    let mut carried = RunSummary::default();
    if deck.restart.is_none() {
        return Ok((None, None, carried));
    }
    let (mut restarts, start) =
        Restarts::open(deck, global, &sub.model, sub.owned().to_vec(), comm, dir)?;
    let resume = match start {
        Start::Continue(snapshot) => {
            restarts.apply(&snapshot, &sub.model, physics, comm, state)?;
            carried.steps = snapshot.steps;
            carried.broken_bonds = snapshot.broken_bonds as usize;
            restarts.count_broken_bonds(&sub.model, comm, state, carried.broken_bonds);
            Some(snapshot)
        }
        Start::FromState(snapshot) => {
            restarts.apply(&snapshot, &sub.model, physics, comm, state)?;
            restarts.start_from_saved_state();
            restarts.count_broken_bonds(&sub.model, comm, state, 0);
            None
        }
        Start::Fresh => {
            restarts.count_broken_bonds(&sub.model, comm, state, 0);
            None
        }
    };
    Ok((Some(restarts), resume, carried))
}
