//! The k-d tree search (kiddo's `ImmutableKdTree`, queried through its allocation-free visitor
//! with per-thread scratch), for point clouds a cell grid would cover with too many empty cells.

use kiddo::{ImmutableKdTree, SquaredEuclidean};

use super::shape::{difference, squared_length, BondRules, Shape};

/// The k-d tree search.
pub(super) struct KdSearch<'a> {
    pub(super) tree: &'a ImmutableKdTree<f64, 3>,
    pub(super) positions: &'a [[f64; 3]],
    pub(super) pad: f64,
}

type KdScratch = kiddo::kd_tree::QueryScratch<kiddo::stem_strategy::Eytzinger, f64, 3>;

impl KdSearch<'_> {
    /// Appends the neighbours of point i, unsorted, to `row`.
    pub(super) fn neighbours(
        &self,
        scratch: &mut KdScratch,
        i: usize,
        shape: Shape,
        rules: &BondRules,
        row: &mut Vec<u32>,
    ) {
        let p = self.positions[i];
        // Search radius: the ball's, or the box's half-diagonal.
        let radius = match shape {
            Shape::Ball { radius_squared } => radius_squared.sqrt(),
            Shape::Box { half, .. } => squared_length(half).sqrt(),
        } + self.pad;
        self.tree
            .query(&p)
            .within::<SquaredEuclidean<f64>>(radius * radius)
            .unsorted()
            .without_distances()
            .with_scratch(scratch)
            .visit(|found| {
                let j = found.item as usize;
                if shape.contains(difference(p, self.positions[j])) && j != i && rules.allows(i, j)
                {
                    row.push(j as u32);
                }
            });
    }
}
