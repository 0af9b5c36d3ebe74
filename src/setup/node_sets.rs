//! Node sets from the deck (id lists or files) and from the mesh.

use super::SetupError;
use crate::discretization::read_node_set_file_lines;
use crate::io::deck::{Deck, NodeSetSource};
use crate::model::NodeSets;

/// All node sets in input order (0-based point indices), and the names that came from the mesh.
/// Deck ids are 1-based; an id beyond the number of points is an error naming the deck key.
/// Deck sets are added after mesh sets; a deck set with exactly a mesh set's name replaces it.
pub(super) fn collect(
    deck: &Deck,
    mesh_sets: &NodeSets,
    num_points: usize,
) -> Result<(NodeSets, Vec<String>), SetupError> {
    let mut sets = NodeSets::default();
    let mut mesh_names = Vec::new();
    for (name, points) in mesh_sets.iter() {
        sets.insert(name, points.to_vec());
        mesh_names.push(name.to_string());
    }
    for definition in &deck.boundary_conditions.node_sets {
        let key = ["Boundary Conditions", definition.name.as_str()];
        // For a file, where each id is written (`file:line: `), for messages.
        let (ids, places): (Vec<u64>, Vec<String>) = match &definition.source {
            NodeSetSource::Ids(ids) => (ids.clone(), Vec::new()),
            NodeSetSource::File(path) => {
                let file = read_node_set_file_lines(path).map_err(|e| {
                    deck.error_at(&key, format!("cannot use the node-set file: {e}"))
                })?;
                let places = file
                    .lines
                    .iter()
                    .map(|line| format!("{}:{line}: ", path.display()))
                    .collect();
                (file.ids, places)
            }
        };
        let first_id = u64::from(!deck.boundary_conditions.zero_based_ids);
        let last_id = num_points as u64 + first_id - 1;
        let mut points = Vec::with_capacity(ids.len());
        for (k, id) in ids.into_iter().enumerate() {
            if id < first_id || id > last_id {
                let place = places.get(k).map_or("", String::as_str);
                return Err(deck
                    .error_at(
                        &key,
                        format!(
                            "{place}node id {id} is out of range: the discretization has {num_points} points, numbered {first_id} to {last_id}; correct or remove the id"
                        ),
                    )
                    .into());
            }
            points.push((id - first_id) as u32);
        }
        sets.insert(definition.name.clone(), points);
    }
    Ok((sets, mesh_names))
}
