//! The conformance suite of the damage registry: every model of [`DAMAGE_MODELS`] is read from
//! its declared example through the deck and built by the set-up on two representative
//! materials (the LPS, whose dilatation pass breaks bonds, and the PMB, whose force pass does),
//! on the body of the material suite (`material/conformance/tests.rs`), and checked:
//!
//! * its declaration: the example reads without warnings, its keys are declared and
//!   documented, the built model reports the declaration, thermal strain as declared;
//! * rigid motion breaks no bond and gives zero force;
//! * with bonds breaking, the forces conserve linear and angular momentum;
//! * a rejected step gives back the committed bond damage, and the retried step is that of a
//!   run that never tried the rejected one;
//! * the restart file's round trip gives back the bond damage and the next step;
//! * on N ranks (when the deck runs on ranks) the owned points' forces, which read the damage
//!   their bonds got, are bitwise the one-rank run's.

use crate::damage::{DamageEntry, DAMAGE_MODELS};
use crate::material::conformance_tests::{
    assert_keys_documented_and_declared, deck, forces_on_ranks, largest, momentum_defects,
    rigid_motions, Body,
};
use crate::material::{material_entry, MaterialEntry};

/// Every damage model of the registry on each representative material.
fn cases() -> impl Iterator<Item = (String, &'static DamageEntry, &'static MaterialEntry)> {
    let materials = ["Elastic", "Elastic Bond Based"].map(|m| material_entry(m).unwrap());
    DAMAGE_MODELS.iter().flat_map(move |damage| {
        materials.into_iter().map(move |material| {
            let name = format!("{} on {}", damage.deck_name(), material.deck_name());
            (name, damage, material)
        })
    })
}

/// The body of `damage` on `material`.
fn body_of(dir: &std::path::Path, damage: &DamageEntry, material: &MaterialEntry) -> Body {
    Body::new(deck(dir, material, Some(damage)))
}

/// The trial bond damage of `body`.
fn damage(body: &Body) -> Vec<f32> {
    body.state.bond_damage().unwrap().to_vec()
}

#[test]
fn every_damage_model_reads_its_example_and_reports_its_declaration() {
    let dir = tempfile::tempdir().unwrap();
    for (name, entry, material) in cases() {
        let declaration = entry.declaration;
        assert_keys_documented_and_declared(&name, declaration);
        let deck = deck(dir.path(), material, Some(entry));
        assert!(deck.warnings.is_empty(), "{name}: {:?}", deck.warnings);
        assert!(std::ptr::eq(deck.damage_models[0].model, entry), "{name}");
        let mut body = Body::new(deck);
        let model = body.physics.blocks[0].damage.as_mut().unwrap();
        assert_eq!(model.declaration(), declaration, "{name}");
        let taken = model.set_thermal_expansion(1e-5);
        assert_eq!(taken.is_ok(), declaration.thermal_strain, "{name}");
    }
}

#[test]
fn rigid_motion_breaks_no_bond_and_gives_zero_force() {
    let dir = tempfile::tempdir().unwrap();
    for (name, entry, material) in cases() {
        let mut body = body_of(dir.path(), entry, material);
        let initial = damage(&body);
        let strained = body.perturbed(1, 2e-3);
        let scale = largest(&body.force(&strained));
        assert!(scale > 0.0, "{name}");
        assert_eq!(
            damage(&body),
            initial,
            "{name}: a 2e-3 strain breaks no bond"
        );
        body.state.restore();
        for y in rigid_motions(&body, 0.6) {
            let f = body.force(&y);
            assert_eq!(damage(&body), initial, "{name}");
            assert!(
                largest(&f) <= 1e-9 * scale,
                "{name}: {} vs {scale}",
                largest(&f)
            );
            body.state.restore();
        }
    }
}

#[test]
fn with_bonds_breaking_the_forces_conserve_linear_and_angular_momentum() {
    let dir = tempfile::tempdir().unwrap();
    for (name, entry, material) in cases() {
        let mut body = body_of(dir.path(), entry, material);
        let initial = damage(&body);
        let y = body.perturbed(2, 0.1);
        let f = body.force(&y);
        let now = damage(&body);
        // Initial Damage breaks its bonds when the run starts, the others under the strain.
        assert!(
            now.iter().any(|&d| d > 0.0) && (now != initial || initial.iter().any(|&d| d > 0.0)),
            "{name}: no bond is broken"
        );
        let (linear, angular) = momentum_defects(&body, &y, &f);
        assert!(linear < 1e-13, "{name}: linear {linear}");
        assert!(angular < 1e-13, "{name}: angular {angular}");
    }
}

#[test]
fn a_rejected_step_gives_back_the_committed_bond_damage() {
    let dir = tempfile::tempdir().unwrap();
    for (name, entry, material) in cases() {
        let mut body = body_of(dir.path(), entry, material);
        let mut twin = body_of(dir.path(), entry, material);
        let start = body.perturbed(3, 0.06);
        for b in [&mut body, &mut twin] {
            b.force(&start);
            b.commit();
        }
        let committed = damage(&body);
        body.force(&body.perturbed(5, 0.15));
        body.state.restore();
        assert_eq!(damage(&body), committed, "{name}");
        let y = body.perturbed(6, 0.1);
        assert_eq!(body.force(&y), twin.force(&y), "{name}");
        assert_eq!(damage(&body), damage(&twin), "{name}");
    }
}

#[test]
fn the_restart_round_trip_gives_back_the_bond_damage_and_the_next_step() {
    let dir = tempfile::tempdir().unwrap();
    for (name, entry, material) in cases() {
        let mut body = body_of(dir.path(), entry, material);
        let start = body.perturbed(7, 0.1);
        body.force(&start);
        body.commit();
        let mut resumed = body_of(dir.path(), entry, material);
        body.restart_into(&mut resumed);
        assert_eq!(damage(&resumed), damage(&body), "{name}");
        let y = body.perturbed(8, 0.1);
        assert_eq!(resumed.force(&y), body.force(&y), "{name}");
        assert_eq!(damage(&resumed), damage(&body), "{name}");
    }
}

#[test]
fn on_ranks_the_owned_forces_are_those_of_one_rank_bitwise() {
    let dir = tempfile::tempdir().unwrap();
    let mut ran = 0;
    for (name, entry, material) in cases() {
        let mut body = body_of(dir.path(), entry, material);
        let y = body.perturbed(10, 0.1);
        let one = body.force(&y);
        for ranks in [2, 3] {
            let Some(many) = forces_on_ranks(&body, ranks, &y) else {
                continue;
            };
            ran += 1;
            assert!(one == many, "{name} on {ranks} ranks");
        }
    }
    assert!(ran > 0, "no damage model runs on ranks");
}
