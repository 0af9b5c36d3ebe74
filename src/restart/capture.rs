//! Between a run's [`State`] (run order) and a [`Snapshot`] (original order).

use super::{
    bonds_to_original, bonds_to_run, points_to_original, points_to_run, BondOrder, ContactSnapshot,
    HistoryField, Snapshot,
};
use crate::contact::Contact;
use crate::history::FieldCarrier;
use crate::model::Model;
use crate::state::State;

/// Numbers per point or bond of a history field declared with `bytes_per_value`.
fn width(bytes_per_value: u64) -> usize {
    (bytes_per_value / 8).max(1) as usize
}

fn flat(values: &[[f64; 3]]) -> &[f64] {
    values.as_flattened()
}

fn vectors(model: &Model, run: &[[f64; 3]]) -> Vec<[f64; 3]> {
    points_to_original(model, run, 1)
}

/// The evolving part of `state` in original order; the caller fills in the position, hashes
/// and counters.
pub fn capture(
    model: &Model,
    order: &BondOrder,
    contact: Option<&Contact>,
    state: &State,
) -> Snapshot {
    let history = state
        .history
        .fields()
        .map(|(declaration, values)| {
            let w = width(declaration.bytes_per_value);
            let per_bond = declaration.carrier == FieldCarrier::Bond;
            let values = if per_bond {
                bonds_to_original(order, values.committed(), w)
            } else {
                points_to_original(model, values.committed(), w)
            };
            HistoryField {
                name: declaration.name.to_string(),
                per_bond,
                width: w,
                values,
            }
        })
        .collect();
    let contact = match (contact, &state.contact) {
        (Some(contact), Some(contact_state)) => {
            let searched_at = contact_state.searched_at().map(|at| {
                let mut by_run = vec![[f64::NAN; 3]; model.points.len()];
                for (&p, y) in contact.points().iter().zip(at) {
                    by_run[p as usize] = *y;
                }
                let mut original: Vec<(u32, [f64; 3])> = contact
                    .points()
                    .iter()
                    .map(|&p| (model.points.original_id[p as usize], by_run[p as usize]))
                    .collect();
                original.sort_by_key(|&(id, _)| id);
                original.into_iter().map(|(_, y)| y).collect()
            });
            Some(ContactSnapshot {
                searched_at,
                force_density: vectors(model, contact_state.force_density()),
            })
        }
        _ => None,
    };
    Snapshot {
        time: state.time,
        displacement: vectors(model, &state.displacement),
        velocity: vectors(model, &state.velocity),
        acceleration: vectors(model, &state.acceleration),
        force_density: vectors(model, &state.force_density),
        current_position: vectors(model, &state.current_position),
        external_force_density: state
            .external_force_density
            .as_ref()
            .map(|b| vectors(model, b)),
        bond_damage: state
            .bond_damage
            .as_ref()
            .map(|d| bonds_to_original(order, d.committed(), 1)),
        history,
        history_step_duration: state.history.step_duration(),
        contact,
        ..Snapshot::default()
    }
}

/// Puts the evolving part of `snapshot` into `state` (allocated for this run as at its
/// start). Fails, naming the field, when the snapshot does not fit the state: another body,
/// or models declaring other fields.
pub fn apply(
    snapshot: &Snapshot,
    model: &Model,
    order: &BondOrder,
    contact: Option<&Contact>,
    state: &mut State,
) -> Result<(), String> {
    let n = model.points.len();
    let check = |name: &str, len: usize, expected: usize| {
        if len == expected {
            Ok(())
        } else {
            Err(format!(
                "{name} has {len} values in the restart file and {expected} in this run"
            ))
        }
    };
    let put = |name: &str, from: &[[f64; 3]], to: &mut Vec<[f64; 3]>| {
        check(name, from.len(), n)?;
        let mut run = vec![0.0; 3 * n];
        points_to_run(model, flat(from), &mut run, 3);
        for (v, chunk) in to.iter_mut().zip(run.chunks_exact(3)) {
            *v = [chunk[0], chunk[1], chunk[2]];
        }
        Ok::<(), String>(())
    };
    put(
        "displacement",
        &snapshot.displacement,
        &mut state.displacement,
    )?;
    put("velocity", &snapshot.velocity, &mut state.velocity)?;
    put(
        "acceleration",
        &snapshot.acceleration,
        &mut state.acceleration,
    )?;
    put(
        "force_density",
        &snapshot.force_density,
        &mut state.force_density,
    )?;
    put(
        "current_position",
        &snapshot.current_position,
        &mut state.current_position,
    )?;
    match (
        &snapshot.external_force_density,
        &mut state.external_force_density,
    ) {
        (Some(from), Some(to)) => put("external_force_density", from, to)?,
        (None, None) => {}
        _ => return Err("the body force of the restart file and of this run differ".into()),
    }
    match (&snapshot.bond_damage, &mut state.bond_damage) {
        (Some(from), Some(to)) => {
            check("bond_damage", from.len(), to.trial().len())?;
            let mut run = vec![0.0f32; from.len()];
            bonds_to_run(order, from, &mut run, 1);
            to.set_accepted(&run);
        }
        (None, None) => {}
        _ => return Err("bond damage is in only one of the restart file and this run".into()),
    }
    let declared: Vec<String> = state
        .history
        .declared()
        .map(|d| d.name.to_string())
        .collect();
    let stored: Vec<String> = snapshot.history.iter().map(|f| f.name.clone()).collect();
    if declared != stored {
        return Err(format!(
            "the history fields differ: the restart file has [{}], this run's models declare [{}]",
            stored.join(", "),
            declared.join(", ")
        ));
    }
    for field in &snapshot.history {
        let values = state
            .history
            .field_mut(&field.name)
            .expect("the names are equal");
        check(&field.name, field.values.len(), values.trial().len())?;
        let mut run = vec![0.0; field.values.len()];
        if field.per_bond {
            bonds_to_run(order, &field.values, &mut run, field.width);
        } else {
            points_to_run(model, &field.values, &mut run, field.width);
        }
        values.set_accepted(&run);
    }
    state
        .history
        .set_step_duration(snapshot.history_step_duration);
    state.contact = match (contact, &snapshot.contact) {
        (Some(contact), Some(stored)) => {
            check("contact_force_density", stored.force_density.len(), n)?;
            let mut force = vec![[0.0; 3]; n];
            put("contact_force_density", &stored.force_density, &mut force)?;
            let searched_at = match &stored.searched_at {
                Some(at) => {
                    let mut ids: Vec<(u32, u32)> = contact
                        .points()
                        .iter()
                        .map(|&p| (model.points.original_id[p as usize], p))
                        .collect();
                    ids.sort_unstable();
                    check("contact_searched_at", at.len(), ids.len())?;
                    let mut by_run = vec![[0.0; 3]; n];
                    for (&(_, p), y) in ids.iter().zip(at) {
                        by_run[p as usize] = *y;
                    }
                    Some(
                        contact
                            .points()
                            .iter()
                            .map(|&p| by_run[p as usize])
                            .collect::<Vec<_>>(),
                    )
                }
                None => None,
            };
            Some(contact.restored_state(
                model,
                searched_at.as_deref(),
                force,
                &state.current_position,
            ))
        }
        (None, None) => None,
        _ => return Err("contact is in only one of the restart file and this run".into()),
    };
    state.time = snapshot.time;
    Ok(())
}
