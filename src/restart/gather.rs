//! The shares of every rank ([`super::Share`]) collected on rank 0 in the user's original
//! order: the snapshot one rank would capture of the same state, value for value.
//!
//! Every field moves as `f64` through [`Communicator::gather`] (ids, counts and `f32` damage
//! are exact in an `f64`), one gather per field, in the same order on every rank. Rank 0
//! places each rank's values by original id: point values at their id, bond rows at their
//! point's row in [`BondStructure`] order, contact positions by the contact points' ids.

use super::capture::owned_structure;
use super::{BondStructure, ContactSnapshot, HistoryField, Share, Snapshot};
use crate::model::Model;
use crate::parallel::Communicator;

/// Where each rank's values go on rank 0: the ids of the gathered points (rank after rank) and
/// the rows of their bonds.
struct Placement {
    /// Original id of every gathered point.
    ids: Vec<usize>,
    /// Per gathered point: where its row starts among the gathered bonds and in original
    /// order, and its length.
    rows: Vec<(usize, usize, usize)>,
    bonds: usize,
}

impl Placement {
    /// From the gathered ids and family sizes. Panics unless every original id 0..n came
    /// exactly once: the partition is a partition.
    fn new(ids: &[f64], family_size: &[f64]) -> (Self, BondStructure) {
        let n = ids.len();
        let ids: Vec<usize> = ids.iter().map(|&id| id as usize).collect();
        let mut by_id = vec![u32::MAX; n];
        for (&id, &size) in ids.iter().zip(family_size) {
            assert!(by_id[id] == u32::MAX, "point {id} gathered from two ranks");
            by_id[id] = size as u32;
        }
        let structure = BondStructure {
            family_size: by_id,
            neighbor: Vec::new(),
        };
        let offsets = structure.offsets();
        let mut from = 0;
        let rows = ids
            .iter()
            .zip(family_size)
            .map(|(&id, &size)| {
                let row = (from, offsets[id], size as usize);
                from += size as usize;
                row
            })
            .collect();
        let placement = Self {
            ids,
            rows,
            bonds: offsets[n],
        };
        (placement, structure)
    }

    fn points(&self, all: &[f64], width: usize) -> Vec<f64> {
        let mut out = vec![0.0; self.ids.len() * width];
        for (k, &id) in self.ids.iter().enumerate() {
            out[id * width..(id + 1) * width].copy_from_slice(&all[k * width..(k + 1) * width]);
        }
        out
    }

    fn bonds(&self, all: &[f64], width: usize) -> Vec<f64> {
        let mut out = vec![0.0; self.bonds * width];
        for &(from, to, len) in &self.rows {
            out[to * width..(to + len) * width]
                .copy_from_slice(&all[from * width..(from + len) * width]);
        }
        out
    }
}

/// The per-rank counts of the shares: points, bonds and contact points of every rank.
struct Counts(Vec<[usize; 3]>);

impl Counts {
    fn of(comm: &dyn Communicator, points: usize, bonds: usize, contact: usize) -> Self {
        let all = comm.all_gather(
            &[points as f64, bonds as f64, contact as f64],
            &vec![3; comm.size()],
        );
        Self(
            all.chunks_exact(3)
                .map(|c| [c[0] as usize, c[1] as usize, c[2] as usize])
                .collect(),
        )
    }

    fn times(&self, kind: usize, width: usize) -> Vec<usize> {
        self.0.iter().map(|c| c[kind] * width).collect()
    }
}

const POINTS: usize = 0;
const BONDS: usize = 1;
const CONTACT: usize = 2;

fn as_f64<T: Copy + Into<f64>>(values: &[T]) -> Vec<f64> {
    values.iter().map(|&v| v.into()).collect()
}

fn vectors(values: Vec<f64>) -> Vec<[f64; 3]> {
    values.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
}

/// The ids and bond structure of every rank's share on rank 0, with the placement of their
/// values. Collective.
fn gather_structure(
    comm: &dyn Communicator,
    counts: &Counts,
    ids: &[u32],
    bonds: &BondStructure,
) -> Option<(Placement, BondStructure)> {
    let ids = comm.gather(&as_f64(ids), &counts.times(POINTS, 1));
    let sizes = comm.gather(&as_f64(&bonds.family_size), &counts.times(POINTS, 1));
    let neighbor = comm.gather(&as_f64(&bonds.neighbor), &counts.times(BONDS, 1));
    let (ids, sizes, neighbor) = (ids?, sizes?, neighbor?);
    let (placement, mut structure) = Placement::new(&ids, &sizes);
    structure.neighbor = placement
        .bonds(&neighbor, 1)
        .into_iter()
        .map(|id| id as u32)
        .collect();
    Some((placement, structure))
}

/// The bond structure of the whole body on rank 0 (`None` on the others), from the rows of
/// each rank's `owned` points of its `model`: what [`super::model_hash`] reads. Collective.
pub fn gather_bonds(
    comm: &dyn Communicator,
    model: &Model,
    owned: &[u32],
) -> Option<BondStructure> {
    let (ids, bonds) = owned_structure(model, owned);
    let counts = Counts::of(comm, ids.len(), bonds.neighbor.len(), 0);
    gather_structure(comm, &counts, &ids, &bonds).map(|(_, structure)| structure)
}

/// The shares of every rank as one snapshot in original order on rank 0 (`None` on the
/// others). Every rank must hold the same optional fields and history fields (they follow
/// from the deck). Collective.
pub fn gather(comm: &dyn Communicator, share: Share) -> Option<Snapshot> {
    let Share {
        ids,
        contact_ids,
        part,
    } = share;
    let counts = Counts::of(
        comm,
        ids.len(),
        part.bonds.neighbor.len(),
        contact_ids.len(),
    );
    let placed = gather_structure(comm, &counts, &ids, &part.bonds);
    let point_vectors = |values: &[[f64; 3]]| -> Option<Vec<[f64; 3]>> {
        let all = comm.gather(values.as_flattened(), &counts.times(POINTS, 3))?;
        let (placement, _) = placed.as_ref()?;
        Some(vectors(placement.points(&all, 3)))
    };
    let displacement = point_vectors(&part.displacement);
    let velocity = point_vectors(&part.velocity);
    let acceleration = point_vectors(&part.acceleration);
    let force_density = point_vectors(&part.force_density);
    let current_position = point_vectors(&part.current_position);
    let external_force_density = part.external_force_density.as_deref().map(point_vectors);
    let bond_damage = part.bond_damage.as_deref().map(|damage| {
        let all = comm.gather(&as_f64(damage), &counts.times(BONDS, 1))?;
        let (placement, _) = placed.as_ref()?;
        Some(
            placement
                .bonds(&all, 1)
                .into_iter()
                .map(|d| d as f32)
                .collect::<Vec<f32>>(),
        )
    });
    let history: Vec<Option<HistoryField>> = part
        .history
        .iter()
        .map(|field| {
            let kind = if field.per_bond { BONDS } else { POINTS };
            let all = comm.gather(&field.values, &counts.times(kind, field.width))?;
            let (placement, _) = placed.as_ref()?;
            let values = if field.per_bond {
                placement.bonds(&all, field.width)
            } else {
                placement.points(&all, field.width)
            };
            Some(HistoryField {
                values,
                ..field.clone()
            })
        })
        .collect();
    let contact = part.contact.as_ref().map(|contact| {
        let force_density = point_vectors(&contact.force_density);
        let points = comm.gather(&as_f64(&contact_ids), &counts.times(CONTACT, 1));
        let searched_at = contact.searched_at.as_ref().map(|at| {
            comm.gather(at.as_flattened(), &counts.times(CONTACT, 3))
                .map(vectors)
        });
        // Rank 0: the contact points by original id, their search positions alike.
        let points = points?;
        let mut order: Vec<usize> = (0..points.len()).collect();
        order.sort_by_key(|&k| points[k] as u32);
        let searched_at = match searched_at {
            Some(at) => {
                let at = at?;
                Some(order.iter().map(|&k| at[k]).collect())
            }
            None => None,
        };
        Some(ContactSnapshot {
            points: order.iter().map(|&k| points[k] as u32).collect(),
            searched_at,
            force_density: force_density?,
        })
    });
    // Rank 0 from here on: every gather above returned its values there.
    let (_, bonds) = placed?;
    Some(Snapshot {
        time: part.time,
        displacement: displacement?,
        velocity: velocity?,
        acceleration: acceleration?,
        force_density: force_density?,
        current_position: current_position?,
        bonds,
        external_force_density: external_force_density.map(|b| b.expect("gathered on rank 0")),
        bond_damage: bond_damage.map(|d| d.expect("gathered on rank 0")),
        history: history
            .into_iter()
            .map(|f| f.expect("gathered on rank 0"))
            .collect(),
        history_step_duration: part.history_step_duration,
        contact: contact.map(|c| c.expect("gathered on rank 0")),
        ..Snapshot::default()
    })
}
