//! What a query accepts: the geometric test of each point's neighbourhood ([`Shape`], from the
//! horizon and the deck's rule, [`Queries`]) and the block and bond-filter tests applied after
//! it ([`BondRules`]).

use super::{FamilySearch, NeighborhoodRule};
use crate::neighbors::BondFilter;

/// Geometric neighbour test of one query point, on ξ = X_j − X_i.
#[derive(Debug, Clone, Copy)]
pub(super) enum Shape {
    /// |ξ|² ≤ r².
    Ball { radius_squared: f64 },
    /// |ξ_k| < half_k for every axis, and, if `radius_squared` is finite, |ξ|² < r².
    Box { half: [f64; 3], radius_squared: f64 },
}

impl Shape {
    /// The exact neighbour test on ξ = X_j − X_i.
    #[inline(always)]
    pub(super) fn contains(&self, xi: [f64; 3]) -> bool {
        match *self {
            Shape::Ball { radius_squared } => squared_length(xi) <= radius_squared,
            Shape::Box {
                half,
                radius_squared,
            } => {
                xi[0].abs() < half[0]
                    && xi[1].abs() < half[1]
                    && xi[2].abs() < half[2]
                    && squared_length(xi) < radius_squared
            }
        }
    }

    /// Half-extent per axis of the region a candidate must lie in (before padding).
    pub(super) fn reach(&self) -> [f64; 3] {
        match *self {
            Shape::Ball { radius_squared } => [radius_squared.sqrt(); 3],
            Shape::Box { half, .. } => half,
        }
    }
}

/// Per-point query shapes plus the rounding pad of the candidate search.
pub(super) struct Queries<'a> {
    pub(super) horizons: &'a [f64],
    rule: NeighborhoodRule,
    /// Added to every reach so that rounding in coordinates never drops a true neighbour from
    /// the candidate set; the exact test decides afterwards.
    pub(super) pad: f64,
}

impl<'a> Queries<'a> {
    // Inlined into the search's set-up as when the search was one file (one call site).
    #[inline]
    pub(super) fn new(search: &FamilySearch<'a>) -> Self {
        let max_coordinate = search
            .positions
            .iter()
            .flat_map(|p| p.iter())
            .fold(0.0_f64, |m, c| m.max(c.abs()));
        let mut queries = Queries {
            horizons: search.horizons,
            rule: search.rule,
            pad: 0.0,
        };
        let max_reach = (0..search.horizons.len())
            .map(|i| {
                let r = queries.shape(i).reach();
                r[0].max(r[1]).max(r[2])
            })
            .fold(0.0_f64, f64::max);
        queries.pad = 1e-10 * (max_coordinate + max_reach);
        queries
    }

    #[inline]
    pub(super) fn shape(&self, i: usize) -> Shape {
        let horizon = self.horizons[i];
        match self.rule {
            NeighborhoodRule::Sphere => Shape::Ball {
                radius_squared: horizon * horizon,
            },
            NeighborhoodRule::LatticeBox {
                spacing,
                cells,
                spherical,
            } => {
                let half = std::array::from_fn(|k| {
                    // floor(δ/Δ) rounded up from a fractional part of 0.5: floor(δ/Δ + ½).
                    let n = (horizon / spacing[k] + 0.5).floor().min(cells[k] as f64);
                    (n + 0.5) * spacing[k]
                });
                Shape::Box {
                    half,
                    radius_squared: if spherical {
                        horizon * horizon
                    } else {
                        f64::INFINITY
                    },
                }
            }
        }
    }
}

#[inline(always)]
pub(super) fn squared_length(d: [f64; 3]) -> f64 {
    d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
}

#[inline(always)]
pub(super) fn difference(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [b[0] - a[0], b[1] - a[1], b[2] - a[2]]
}

/// `lengths[n]` = |X_j − X_i| for the neighbours j = `row[n]` of point i, from row position
/// `first` on, one bond at a time (the search's reference lengths; its AVX2 build takes four at
/// a time up to the last full group and this for the rest).
#[inline(always)]
pub(super) fn reference_lengths_from(
    positions: &[[f64; 3]],
    i: usize,
    row: &[u32],
    lengths: &mut [f64],
    first: usize,
) {
    let x = positions[i];
    for (length, &j) in lengths[first..].iter_mut().zip(&row[first..]) {
        *length = squared_length(difference(x, positions[j as usize])).sqrt();
    }
}

/// Block and bond-filter tests, applied to candidates that pass the geometric test.
pub(super) struct BondRules<'a> {
    positions: &'a [[f64; 3]],
    blocks: Option<&'a [u32]>,
    /// Filters with their bounding boxes, padded for rounding.
    filters: Vec<(&'a BondFilter, [f64; 3], [f64; 3])>,
}

impl<'a> BondRules<'a> {
    pub(super) fn new(search: &FamilySearch<'a>, pad: f64) -> Self {
        BondRules {
            positions: search.positions,
            blocks: search.omit_bonds_between_blocks.then_some(search.blocks),
            filters: search
                .filters
                .iter()
                .map(|f| {
                    let (lo, hi) = f.bounding_box();
                    let slack = pad
                        + 1e-10
                            * (0..3)
                                .map(|k| lo[k].abs().max(hi[k].abs()))
                                .fold(0.0, f64::max);
                    (f, lo.map(|v| v - slack), hi.map(|v| v + slack))
                })
                .collect(),
        }
    }

    pub(super) fn is_trivial(&self) -> bool {
        self.blocks.is_none() && self.filters.is_empty()
    }

    #[inline]
    pub(super) fn allows(&self, i: usize, j: usize) -> bool {
        if let Some(blocks) = self.blocks {
            if blocks[i] != blocks[j] {
                return false;
            }
        }
        let (a, b) = (self.positions[i], self.positions[j]);
        !self.filters.iter().any(|(filter, lo, hi)| {
            let overlaps = (0..3).all(|k| a[k].min(b[k]) <= hi[k] && a[k].max(b[k]) >= lo[k]);
            overlaps && filter.cuts(a, b)
        })
    }
}
