//! Named sets of points, from the deck or from the mesh.

use std::collections::BTreeMap;

/// Node sets by name, each a sorted list of point indices (run order, 0-based).
///
/// Names are kept as written; lookups also accept Peridigm's normalised form (upper case,
/// spaces as underscores), because Peridigm treats `Node Set One` and `NODE_SET_ONE` alike.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct NodeSets {
    sets: BTreeMap<String, Vec<u32>>,
}

/// Peridigm's normalisation of node-set and BC type names (`tidy_string`): upper case, spaces
/// replaced by underscores, so `"Node Set One"` and `"NODE_SET_ONE"` name the same set.
pub fn normalize_name(name: &str) -> String {
    name.trim().to_uppercase().replace(' ', "_")
}

impl NodeSets {
    /// Inserts (or replaces) a set; the indices are sorted and de-duplicated.
    pub fn insert(&mut self, name: impl Into<String>, mut points: Vec<u32>) {
        points.sort_unstable();
        points.dedup();
        self.sets.insert(name.into(), points);
    }

    /// The set called `name` (exact, or equal after Peridigm's normalisation).
    pub fn get(&self, name: &str) -> Option<&[u32]> {
        if let Some(points) = self.sets.get(name) {
            return Some(points);
        }
        let wanted = normalize_name(name);
        self.sets
            .iter()
            .find(|(key, _)| normalize_name(key) == wanted)
            .map(|(_, points)| points.as_slice())
    }

    /// True when a set of that name exists.
    pub fn contains(&self, name: &str) -> bool {
        self.get(name).is_some()
    }

    /// All sets in name order.
    pub fn iter(&self) -> impl Iterator<Item = (&str, &[u32])> {
        self.sets.iter().map(|(k, v)| (k.as_str(), v.as_slice()))
    }

    /// Number of sets.
    pub fn len(&self) -> usize {
        self.sets.len()
    }

    /// True when there are no sets.
    pub fn is_empty(&self) -> bool {
        self.sets.is_empty()
    }

    /// Renumbers every set after the points were permuted: `new_index_of[old] = new`.
    pub fn renumber(&mut self, new_index_of: &[u32]) {
        for points in self.sets.values_mut() {
            for p in points.iter_mut() {
                *p = new_index_of[*p as usize];
            }
            points.sort_unstable();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lookup_uses_peridigm_normalisation() {
        let mut sets = NodeSets::default();
        sets.insert("Node Set One", vec![3, 1, 1]);
        assert_eq!(sets.get("NODE_SET_ONE"), Some(&[1u32, 3][..]));
        assert_eq!(sets.get("node set one"), Some(&[1u32, 3][..]));
        assert!(sets.get("Node Set Two").is_none());
    }
}
