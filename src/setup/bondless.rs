//! Blocks whose points have no bond, because the horizon is smaller than the distance between
//! the points (a `Horizon` of 10⁻¹² spacings, a typo of the exponent): such points carry no
//! force, so a run of them computes nothing a peridynamic body does. Each such block gets a
//! warning naming it and its `Horizon` ([`warnings`], printed by `check` and `run`); where
//! nothing could move ([`refuse_motionless`]) it is an error.

use crate::io::deck::{BoundaryConditionKind, Deck, DeckError, Integrator};
use crate::model::Model;

/// The model blocks (indices into `model.blocks`) that have points, none of them with a bond.
fn bondless_blocks(model: &Model) -> Vec<usize> {
    let offsets = &model.bonds.offsets;
    model
        .blocks
        .iter()
        .enumerate()
        .filter(|(_, block)| {
            !block.points.is_empty()
                && block
                    .points
                    .iter()
                    .all(|&p| offsets[p as usize + 1] == offsets[p as usize])
        })
        .map(|(index, _)| index)
        .collect()
}

/// The key of block `index`'s `Horizon`, and what is wrong with it: the horizon (the largest
/// of its points'), the spacing (the cube root of its points' mean volume) and the advice.
fn finding(deck: &Deck, model: &Model, index: usize) -> ([String; 3], String, String) {
    let block = &model.blocks[index];
    let points = &block.points;
    let horizon = points
        .iter()
        .map(|&p| model.horizon[p as usize])
        .fold(0.0, f64::max);
    let volume: f64 = points
        .iter()
        .map(|&p| model.points.volume[p as usize])
        .sum();
    let spacing = (volume / points.len() as f64).cbrt();
    let key = [
        "Blocks".to_string(),
        deck.blocks[block.deck_block].name.clone(),
        "Horizon".to_string(),
    ];
    let what = format!(
        "no point of block \"{}\" has a neighbour within its horizon {horizon:e}: its points are about {spacing:e} apart (the cube root of their volume), so they carry no force",
        block.info.name
    );
    let advice = format!("make the horizon about 3 spacings ({:e})", 3.0 * spacing);
    (key, what, advice)
}

/// The error or warning about the key `key`.
fn at(deck: &Deck, key: &[String; 3], message: String) -> DeckError {
    let key: Vec<&str> = key.iter().map(String::as_str).collect();
    deck.error_at(&key, message)
}

/// One warning (`file:line: Blocks → NAME → Horizon: …`) for every block without a bond.
pub fn warnings(deck: &Deck, model: &Model) -> Vec<String> {
    bondless_blocks(model)
        .into_iter()
        .map(|index| {
            let (key, what, advice) = finding(deck, model, index);
            at(
                deck,
                &key,
                format!("{what} and move only as the conditions move them; {advice}"),
            )
            .to_string()
        })
        .collect()
}

/// Refuses blocks without a bond where nothing could move: under a quasi-static solver, which
/// finds no equilibrium for points without stiffness; and anywhere when no point of the body
/// has a bond and neither a condition (displacement, velocity, body force) nor contact moves
/// any point.
pub(super) fn refuse_motionless(deck: &Deck, model: &Model) -> Result<(), DeckError> {
    let bondless = bondless_blocks(model);
    let Some(&first) = bondless.first() else {
        return Ok(());
    };
    let quasi_static = deck.solvers.iter().find(|solver| {
        matches!(
            solver.integrator,
            Integrator::QuasiStatic(_) | Integrator::NoxQuasiStatic(_)
        )
    });
    if let Some(solver) = quasi_static {
        let (key, what, advice) = finding(deck, model, first);
        return Err(at(
            deck,
            &key,
            format!(
                "{what}; the quasi-static solver \"{}\" finds no equilibrium for them, so nothing in this block could move but what a condition prescribes; {advice}",
                solver.name
            ),
        ));
    }
    let moved = deck.contact.is_some()
        || deck.boundary_conditions.conditions.iter().any(|bc| {
            matches!(
                bc.kind,
                BoundaryConditionKind::PrescribedDisplacement
                    | BoundaryConditionKind::InitialDisplacement
                    | BoundaryConditionKind::InitialVelocity
                    | BoundaryConditionKind::BodyForce
            )
        });
    if model.bonds.num_bonds() == 0 && !moved {
        let (key, what, advice) = finding(deck, model, first);
        return Err(at(
            deck,
            &key,
            format!(
                "{what}, no point of the body has a bond, and no condition or contact moves a point: nothing could move in this run; {advice}"
            ),
        ));
    }
    Ok(())
}
