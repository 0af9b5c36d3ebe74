//! The snapshot of a body split over ranks is the snapshot of the whole body, and every rank
//! takes back the values of its owned points and ghosts (threads as ranks).

use super::{apply, capture, gather, gather_bonds, model_hash, Snapshot};
use crate::io::deck::{parse_str, Deck, DeckFormat};
use crate::model::Model;
use crate::parallel::thread_comm::ThreadComm;
use crate::parallel::{Communicator, Serial, Subdomain};
use crate::state::State;

/// A 10 × 2 × 2 LPS bar with critical-stretch damage (horizon 2.1 at spacing 1: rows of up
/// to 20 bonds, two ghost layers on N ranks).
fn deck() -> (tempfile::TempDir, Deck) {
    let dir = tempfile::tempdir().unwrap();
    let text = r#"Peridigm:
  Discretization:
    Type: "PdQuickGrid"
    TensorProduct3DMeshGenerator:
      Type: "PdQuickGrid"
      X Origin: 0.0
      Y Origin: 0.0
      Z Origin: 0.0
      X Length: 10.0
      Y Length: 2.0
      Z Length: 2.0
      Number Points X: 10
      Number Points Y: 2
      Number Points Z: 2
  Materials:
    M: {Material Model: "Elastic", Density: 1.0, Bulk Modulus: 1.0, Shear Modulus: 0.5}
  Damage Models:
    D: {Damage Model: "Critical Stretch", Critical Stretch: 0.01}
  Blocks:
    B: {Block Names: "block_1", Material: "M", Damage Model: "D", Horizon: 2.1}
  Solver:
    Final Time: 1.0
    Verlet: {Fixed dt: 0.1}
"#;
    let deck = parse_str(text, DeckFormat::Yaml, &dir.path().join("deck.yaml")).unwrap();
    (dir, deck)
}

/// Values that tell every point and bond apart, as functions of original ids only: the same
/// on one rank and on N whatever the numbering.
fn point_value(id: u32) -> [f64; 3] {
    let x = f64::from(id);
    [x, 0.5 + x / 3.0, -x * x]
}

fn bond_value(id: u32, far: u32) -> f32 {
    (id * 31 + far * 7) as f32 / 1024.0
}

/// A state of `model` filled with [`point_value`] and [`bond_value`].
fn state_of(model: &Model) -> State {
    let original = &model.points.original_id;
    let mut state = State::at_rest(&model.points.position, 0.25, false)
        .with_bond_damage(Some(model.bonds.num_bonds()));
    for (p, &id) in original.iter().enumerate() {
        state.displacement[p] = point_value(id);
        state.velocity[p] = point_value(id + 1);
    }
    let damage: Vec<f32> = (0..model.points.len())
        .flat_map(|p| {
            model
                .bonds
                .family(p)
                .iter()
                .map(move |&j| bond_value(original[p], original[j as usize]))
        })
        .collect();
    if let Some(d) = &mut state.bond_damage {
        d.set_accepted(&damage);
    }
    state
}

/// 3 ranks, two ghost layers, the outer one in the blocks (its rows cut to local points).
const RANKS: usize = 3;

fn subdomain(global: &Model, rank: usize) -> Subdomain {
    Subdomain::new(global, RANKS, rank, 2, true)
}

#[test]
fn the_shares_of_three_ranks_gather_to_the_one_rank_snapshot() {
    let (_dir, deck) = deck();
    let global = crate::setup::build(&deck).unwrap();
    let every_point: Vec<u32> = (0..global.points.len() as u32).collect();
    let one = gather(
        &Serial,
        capture(&global, &every_point, None, &state_of(&global)),
    )
    .unwrap();
    let one_hash = model_hash(
        &deck,
        &global,
        &gather_bonds(&Serial, &global, &every_point).unwrap(),
    );
    // Original order: point k holds the values of original id k, and its row lists its far
    // ends by increasing id.
    for (k, u) in one.displacement.iter().enumerate() {
        assert_eq!(*u, point_value(k as u32));
    }
    let offsets = one.bonds.offsets();
    for id in 0..global.points.len() {
        let row = &one.bonds.neighbor[offsets[id]..offsets[id + 1]];
        assert!(row.windows(2).all(|w| w[0] < w[1]), "{row:?}");
    }
    let on_ranks: Vec<(Option<Snapshot>, Option<u64>)> = ThreadComm::run(RANKS, |comm| {
        let sub = subdomain(&global, comm.rank());
        let state = state_of(&sub.model);
        let snapshot = gather(comm, capture(&sub.model, sub.owned(), None, &state));
        let hash = gather_bonds(comm, &sub.model, sub.owned())
            .map(|bonds| model_hash(&deck, &global, &bonds));
        (snapshot, hash)
    });
    let (snapshot, hash) = &on_ranks[0];
    assert!(snapshot.as_ref() == Some(&one));
    assert_eq!(*hash, Some(one_hash));
    assert!(on_ranks[1..]
        .iter()
        .all(|(s, h)| s.is_none() && h.is_none()));
}

#[test]
fn every_rank_takes_the_values_of_its_owned_points_and_ghosts() {
    let (_dir, deck) = deck();
    let global = crate::setup::build(&deck).unwrap();
    let every_point: Vec<u32> = (0..global.points.len() as u32).collect();
    let snapshot = gather(
        &Serial,
        capture(&global, &every_point, None, &state_of(&global)),
    )
    .unwrap();
    for rank in 0..RANKS {
        let sub = subdomain(&global, rank);
        let model = &sub.model;
        let ghosts = sub.ghost_mask().iter().filter(|&&g| g).count();
        assert!(ghosts > 0, "rank {rank} has no ghosts to test");
        let mut state = State::at_rest(&model.points.position, 0.0, false)
            .with_bond_damage(Some(model.bonds.num_bonds()));
        let contact = apply(&snapshot, model, sub.owned(), None, &mut state).unwrap();
        assert!(contact.is_none());
        assert_eq!(state.time, 0.25);
        let expected = state_of(model);
        assert_eq!(state.displacement, expected.displacement);
        assert_eq!(state.velocity, expected.velocity);
        assert_eq!(
            state.bond_damage.as_ref().unwrap().committed(),
            expected.bond_damage.as_ref().unwrap().committed(),
            "rank {rank}"
        );
    }
}

#[test]
fn a_snapshot_of_another_body_is_refused_naming_what_differs() {
    let (_dir, deck) = deck();
    let global = crate::setup::build(&deck).unwrap();
    let every_point: Vec<u32> = (0..global.points.len() as u32).collect();
    let mut snapshot = gather(
        &Serial,
        capture(&global, &every_point, None, &state_of(&global)),
    )
    .unwrap();
    // Point 1's first bond now leads to a point it has no bond with in this body.
    snapshot.bonds.neighbor[0] = global.points.len() as u32 - 1;
    let mut state = state_of(&global);
    let error = apply(&snapshot, &global, &every_point, None, &mut state).unwrap_err();
    assert!(error.contains("is not in the restart file"), "{error}");
}
