//! Between one rank's [`State`] (its points in run order) and the snapshot of the whole body
//! (original order): [`capture`] takes the rank's [`Share`] for [`super::gather`], [`apply`]
//! puts a snapshot's values into the rank's points, owned and ghosts. One rank owns every
//! point.

use super::{BondStructure, ContactSnapshot, HistoryField, Snapshot};
use crate::contact::Contact;
use crate::history::FieldCarrier;
use crate::model::Model;
use crate::parallel::Communicator;
use crate::state::State;

/// Numbers per point or bond of a history field declared with `bytes_per_value`.
fn width(bytes_per_value: u64) -> usize {
    (bytes_per_value / 8).max(1) as usize
}

/// One rank's part of a snapshot: its owned points in the order of `ids`. `part` holds the
/// snapshot's fields for these points only (every point field in `ids` order; the rows of
/// their bonds in `ids` order, each row by the far end's original id; `part.bonds` those rows'
/// structure; the contact force of these points, and the search positions of the contact
/// points `contact_ids`). Position, hashes and counters are left at their defaults.
#[derive(Debug, Clone, Default)]
pub struct Share {
    /// Original ids of the owned points.
    pub ids: Vec<u32>,
    /// Original ids of the owned contact points whose search positions
    /// `part.contact.searched_at` holds (in that order).
    pub contact_ids: Vec<u32>,
    /// The values.
    pub part: Snapshot,
}

/// The local bonds of the rows of `owned`, row after row, each row ordered by the original id
/// of its far end; with the rows' structure in original ids.
fn owned_bonds(model: &Model, owned: &[u32]) -> (Vec<usize>, BondStructure) {
    let original = &model.points.original_id;
    let mut order = Vec::new();
    let mut bonds = BondStructure::default();
    for &p in owned {
        let range = model.bonds.range(p as usize);
        let family = model.bonds.family(p as usize);
        let mut local: Vec<usize> = (0..family.len()).collect();
        local.sort_by_key(|&j| original[family[j] as usize]);
        bonds.family_size.push(family.len() as u32);
        bonds
            .neighbor
            .extend(local.iter().map(|&j| original[family[j] as usize]));
        order.extend(local.into_iter().map(|j| range.start + j));
    }
    (order, bonds)
}

/// The bond structure of the rows of `owned` (local indices of complete rows), for the model
/// hash ([`super::gather_bonds`]).
pub(super) fn owned_structure(model: &Model, owned: &[u32]) -> (Vec<u32>, BondStructure) {
    let ids = owned
        .iter()
        .map(|&p| model.points.original_id[p as usize])
        .collect();
    (ids, owned_bonds(model, owned).1)
}

/// The evolving part of `state` at the points `owned` (local indices of points whose rows are
/// complete: every point on one rank, the owned points on N).
pub fn capture(model: &Model, owned: &[u32], contact: Option<&Contact>, state: &State) -> Share {
    let (order, bonds) = owned_bonds(model, owned);
    let points = |values: &[f64], width: usize| -> Vec<f64> {
        let mut out = Vec::with_capacity(owned.len() * width);
        for &p in owned {
            let p = p as usize;
            out.extend_from_slice(&values[p * width..(p + 1) * width]);
        }
        out
    };
    let vectors = |values: &[[f64; 3]]| -> Vec<[f64; 3]> {
        owned.iter().map(|&p| values[p as usize]).collect()
    };
    fn rows<T: Copy>(order: &[usize], values: &[T], width: usize) -> Vec<T> {
        let mut out = Vec::with_capacity(order.len() * width);
        for &b in order {
            out.extend_from_slice(&values[b * width..(b + 1) * width]);
        }
        out
    }
    let history = state
        .history
        .fields()
        .map(|(declaration, values)| {
            let w = width(declaration.bytes_per_value);
            let per_bond = declaration.carrier == FieldCarrier::Bond;
            let values = if per_bond {
                rows(&order, values.committed(), w)
            } else {
                points(values.committed(), w)
            };
            HistoryField {
                name: declaration.name.to_string(),
                per_bond,
                width: w,
                values,
            }
        })
        .collect();
    let mut contact_ids = Vec::new();
    let contact = match (contact, &state.contact) {
        (Some(contact), Some(contact_state)) => {
            let searched = contact.searched_points();
            contact_ids = searched
                .iter()
                .map(|&p| model.points.original_id[p as usize])
                .collect();
            Some(ContactSnapshot {
                points: Vec::new(),
                searched_at: contact_state.searched_at().map(<[_]>::to_vec),
                force_density: vectors(contact_state.force_density()),
            })
        }
        _ => None,
    };
    let ids = owned
        .iter()
        .map(|&p| model.points.original_id[p as usize])
        .collect();
    Share {
        ids,
        contact_ids,
        part: Snapshot {
            time: state.time,
            displacement: vectors(&state.displacement),
            velocity: vectors(&state.velocity),
            acceleration: vectors(&state.acceleration),
            force_density: vectors(&state.force_density),
            current_position: vectors(&state.current_position),
            bonds,
            external_force_density: state.external_force_density.as_deref().map(vectors),
            bond_damage: state
                .bond_damage
                .as_ref()
                .map(|d| rows(&order, d.committed(), 1)),
            history,
            history_step_duration: state.history.step_duration(),
            contact,
            ..Snapshot::default()
        },
    }
}

/// What [`restore_contact`] needs to rebuild contact's state: the search positions of the
/// contact points this rank searches ([`Contact::searched_points`] order; `None` before the
/// first search) and the contact force of every local point (zero at ghosts).
#[derive(Debug, Clone)]
pub struct ContactRestore {
    searched_at: Option<Vec<[f64; 3]>>,
    force_density: Vec<[f64; 3]>,
}

/// Puts the evolving part of `snapshot` into `state` (allocated for this rank's `model` as at
/// its start): every local point, owned or ghost, takes the values of its original id, every
/// local bond those of the bond between the same two original ids. `owned` are the local
/// indices of the owned points (contact forces are kept there only, as a run keeps them).
/// Fails, naming the field, when the snapshot does not fit: another body, or models declaring
/// other fields. Not collective; contact's state is rebuilt afterwards by [`restore_contact`],
/// which is (on N ranks).
pub fn apply(
    snapshot: &Snapshot,
    model: &Model,
    owned: &[u32],
    contact: Option<&Contact>,
    state: &mut State,
) -> Result<Option<ContactRestore>, String> {
    let n = snapshot.bonds.family_size.len();
    if let Some(&beyond) = model
        .points
        .original_id
        .iter()
        .find(|&&id| id as usize >= n)
    {
        return Err(format!(
            "the restart file has {n} points and this run's point {} is beyond them",
            beyond + 1
        ));
    }
    apply_points(snapshot, model, state)?;
    let source = bond_sources(&snapshot.bonds, model)?;
    match (&snapshot.bond_damage, &mut state.bond_damage) {
        (Some(from), Some(to)) => {
            check("bond_damage", from.len(), snapshot.bonds.neighbor.len())?;
            let run: Vec<f32> = source.iter().map(|&b| from[b]).collect();
            to.set_accepted(&run);
        }
        (None, None) => {}
        _ => return Err("bond damage is in only one of the restart file and this run".into()),
    }
    apply_history(snapshot, model, &source, state)?;
    state.time = snapshot.time;
    contact_restore(snapshot, model, owned, contact)
}

/// Ok when a field of the restart file has the `expected` number of values.
fn check(name: &str, len: usize, expected: usize) -> Result<(), String> {
    if len == expected {
        Ok(())
    } else {
        Err(format!(
            "{name} has {len} values in the restart file and {expected} were expected"
        ))
    }
}

/// The point vectors of [`apply`]: kinematics, force and body force.
fn apply_points(snapshot: &Snapshot, model: &Model, state: &mut State) -> Result<(), String> {
    let n = snapshot.bonds.family_size.len();
    let original = &model.points.original_id;
    let put = |name: &str, from: &[[f64; 3]], to: &mut [[f64; 3]]| {
        check(name, from.len(), n)?;
        for (v, &id) in to.iter_mut().zip(original) {
            *v = from[id as usize];
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
        (Some(from), Some(to)) => put("external_force_density", from, to),
        (None, None) => Ok(()),
        _ => Err("the body force of the restart file and of this run differ".into()),
    }
}

/// The material history fields of [`apply`]: per point, or per bond through `source` (see
/// [`bond_sources`]).
fn apply_history(
    snapshot: &Snapshot,
    model: &Model,
    source: &[usize],
    state: &mut State,
) -> Result<(), String> {
    let n = snapshot.bonds.family_size.len();
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
        let w = field.width;
        let (count, picks): (usize, Vec<usize>) = if field.per_bond {
            (snapshot.bonds.neighbor.len(), source.to_vec())
        } else {
            let original = &model.points.original_id;
            (n, original.iter().map(|&id| id as usize).collect())
        };
        check(&field.name, field.values.len(), count * w)?;
        let mut run = Vec::with_capacity(picks.len() * w);
        for k in picks {
            run.extend_from_slice(&field.values[k * w..(k + 1) * w]);
        }
        check(&field.name, run.len(), values.trial().len())?;
        values.set_accepted(&run);
    }
    state
        .history
        .set_step_duration(snapshot.history_step_duration);
    Ok(())
}

/// What [`restore_contact`] needs from the snapshot: the contact force of the owned points and
/// the search positions of the contact points this rank searches.
fn contact_restore(
    snapshot: &Snapshot,
    model: &Model,
    owned: &[u32],
    contact: Option<&Contact>,
) -> Result<Option<ContactRestore>, String> {
    let n = snapshot.bonds.family_size.len();
    let original = &model.points.original_id;
    match (contact, &snapshot.contact) {
        (Some(contact), Some(stored)) => {
            check("contact_force_density", stored.force_density.len(), n)?;
            let mut force_density = vec![[0.0; 3]; model.points.len()];
            for &p in owned {
                force_density[p as usize] = stored.force_density[original[p as usize] as usize];
            }
            let searched_at = match &stored.searched_at {
                Some(at) => {
                    check("contact_searched_at", at.len(), stored.points.len())?;
                    let positions = contact
                        .searched_points()
                        .iter()
                        .map(|&p| {
                            let id = original[p as usize];
                            stored
                                .points
                                .binary_search(&id)
                                .map(|k| at[k])
                                .map_err(|_| {
                                    format!(
                                        "point {} takes part in contact in this run only",
                                        id + 1
                                    )
                                })
                        })
                        .collect::<Result<Vec<_>, String>>()?;
                    Some(positions)
                }
                None => None,
            };
            Ok(Some(ContactRestore {
                searched_at,
                force_density,
            }))
        }
        (None, None) => Ok(None),
        _ => Err("contact is in only one of the restart file and this run".into()),
    }
}

/// For every local bond of `model`, the index of the same bond (the same two original ids) in
/// the snapshot's `bonds`. A local row may be a part of its point's row (the outer ghosts of a
/// rank keep only their bonds to local points).
fn bond_sources(bonds: &BondStructure, model: &Model) -> Result<Vec<usize>, String> {
    let offsets = bonds.offsets();
    let original = &model.points.original_id;
    let mut source = Vec::with_capacity(model.bonds.num_bonds());
    for p in 0..model.points.len() {
        let id = original[p] as usize;
        let row = &bonds.neighbor[offsets[id]..offsets[id + 1]];
        for &j in model.bonds.family(p) {
            let far = original[j as usize];
            let k = row.binary_search(&far).map_err(|_| {
                format!(
                    "the bond between points {} and {} is not in the restart file",
                    id + 1,
                    far + 1
                )
            })?;
            source.push(offsets[id] + k);
        }
    }
    Ok(source)
}

/// Rebuilds contact's state from what [`apply`] took from the snapshot: the search is made
/// again at the stored positions, which gives the candidates of the run that wrote the file.
/// Collective on N ranks (the search is).
pub fn restore_contact(
    restore: ContactRestore,
    model: &Model,
    contact: &Contact,
    comm: &dyn Communicator,
    state: &mut State,
) {
    state.contact = Some(contact.restored_state(
        model,
        comm,
        restore.searched_at.as_deref(),
        restore.force_density,
        &state.current_position,
    ));
}
