//! Which rank owns which point: recursive coordinate bisection (RCB).
//!
//! The point set is cut in two along the longest extent of its bounding box, at the position
//! where the weights on each side are in the ratio of the number of ranks each side gets;
//! each side is cut again until every part has one rank. Weights are family sizes (the work of
//! a point in the bond loops is proportional to its number of bonds), plus one so that points
//! without bonds still count.
//!
//! The result depends only on the positions, the weights and the number of parts (ties in a
//! coordinate are broken by point index), so every rank computes the same partition without
//! communicating.

use crate::model::BondList;

/// The owner rank of every point, and each rank's points.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Partition {
    /// `owner[i]`: rank that owns point `i` (run order).
    pub owner: Vec<u32>,
    /// `owned[r]`: the points of rank `r`, strictly increasing.
    pub owned: Vec<Vec<u32>>,
}

impl Partition {
    /// Number of parts (ranks).
    pub fn parts(&self) -> usize {
        self.owned.len()
    }

    /// Everything on one rank.
    pub fn single(points: usize) -> Self {
        Self {
            owner: vec![0; points],
            owned: vec![(0..points as u32).collect()],
        }
    }

    /// Recursive coordinate bisection of `positions` into `parts` parts with `weights` (one
    /// per point, ≥ 0). `parts` must be at least 1 (a broken invariant otherwise).
    pub fn bisect(positions: &[[f64; 3]], weights: &[f64], parts: usize) -> Self {
        assert!(parts >= 1, "a partition needs at least one part");
        assert_eq!(positions.len(), weights.len());
        let mut owner = vec![0u32; positions.len()];
        let mut points: Vec<u32> = (0..positions.len() as u32).collect();
        bisect(positions, weights, &mut points, 0, parts, &mut owner);
        let mut owned = vec![Vec::new(); parts];
        for (i, &r) in owner.iter().enumerate() {
            owned[r as usize].push(i as u32);
        }
        Self { owner, owned }
    }

    /// [`Partition::bisect`] with the weights of peridyn's bond loops: `1 + family size`.
    pub fn of_bonds(positions: &[[f64; 3]], bonds: &BondList, parts: usize) -> Self {
        let weights: Vec<f64> = (0..positions.len())
            .map(|i| 1.0 + bonds.family_size(i) as f64)
            .collect();
        Self::bisect(positions, &weights, parts)
    }
}

/// Assigns `points` to ranks `first..first + parts`.
fn bisect(
    positions: &[[f64; 3]],
    weights: &[f64],
    points: &mut [u32],
    first: u32,
    parts: usize,
    owner: &mut [u32],
) {
    if parts == 1 || points.len() <= 1 {
        // With more parts than points, the surplus ranks own nothing (a valid, if idle, run).
        for &p in points.iter() {
            owner[p as usize] = first;
        }
        return;
    }
    let mut low = [f64::INFINITY; 3];
    let mut high = [f64::NEG_INFINITY; 3];
    for &p in points.iter() {
        for k in 0..3 {
            low[k] = low[k].min(positions[p as usize][k]);
            high[k] = high[k].max(positions[p as usize][k]);
        }
    }
    // Longest extent; the first axis wins a tie, so the choice is deterministic.
    let mut axis = 0;
    for k in 1..3 {
        if high[k] - low[k] > high[axis] - low[axis] {
            axis = k;
        }
    }
    points.sort_unstable_by(|&a, &b| {
        positions[a as usize][axis]
            .total_cmp(&positions[b as usize][axis])
            .then(a.cmp(&b))
    });
    let left_parts = parts / 2;
    let total: f64 = points.iter().map(|&p| weights[p as usize]).sum();
    let target = total * left_parts as f64 / parts as f64;
    // The cut after `split` points whose left weight is closest to the target; each side keeps
    // at least one point when there are enough points for the parts.
    let mut best = (f64::INFINITY, 1usize);
    let mut running = 0.0;
    for (k, &p) in points.iter().enumerate() {
        running += weights[p as usize];
        let split = k + 1;
        if split >= points.len() {
            break;
        }
        let miss = (running - target).abs();
        if miss < best.0 {
            best = (miss, split);
        }
    }
    let split = best.1;
    let (left, right) = points.split_at_mut(split);
    bisect(positions, weights, left, first, left_parts, owner);
    bisect(
        positions,
        weights,
        right,
        first + left_parts as u32,
        parts - left_parts,
        owner,
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lattice(nx: usize, ny: usize, nz: usize) -> Vec<[f64; 3]> {
        let mut x = Vec::new();
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    x.push([i as f64, j as f64, k as f64]);
                }
            }
        }
        x
    }

    #[test]
    fn every_point_is_owned_once_and_parts_are_balanced() {
        let x = lattice(12, 5, 3);
        let w = vec![1.0; x.len()];
        for parts in 1..=7 {
            let p = Partition::bisect(&x, &w, parts);
            assert_eq!(p.parts(), parts);
            let mut seen = vec![0; x.len()];
            for (r, owned) in p.owned.iter().enumerate() {
                assert!(owned.windows(2).all(|w| w[0] < w[1]));
                for &i in owned {
                    seen[i as usize] += 1;
                    assert_eq!(p.owner[i as usize], r as u32);
                }
            }
            assert!(seen.iter().all(|&s| s == 1));
            // Unit weights: each cut misses its target by less than one point, and the
            // targets split 180 points in the ratio of the ranks, so every part is within
            // ⌈log2 parts⌉ points of 180/parts.
            let ideal = x.len() as f64 / parts as f64;
            let slack = (parts as f64).log2().ceil() + 1.0;
            for owned in &p.owned {
                assert!(
                    (owned.len() as f64 - ideal).abs() <= slack,
                    "{parts} parts: {} points, ideal {ideal}",
                    owned.len()
                );
            }
        }
    }

    #[test]
    fn the_first_cut_is_across_the_longest_extent() {
        // A 12 × 5 × 3 bar: two parts split x at 6 (the midpoint of 12 columns).
        let x = lattice(12, 5, 3);
        let p = Partition::bisect(&x, &vec![1.0; x.len()], 2);
        for (i, xi) in x.iter().enumerate() {
            assert_eq!(p.owner[i], u32::from(xi[0] >= 6.0));
        }
    }

    #[test]
    fn weights_move_the_cut() {
        // Weight 3 on the left half (x < 6) and 1 on the right: total 3·90 + 90 = 360, so
        // the cut falls where the left side holds 180 = 4 columns × 15 points × 3, at x = 4.
        let x = lattice(12, 5, 3);
        let w: Vec<f64> = x
            .iter()
            .map(|p| if p[0] < 6.0 { 3.0 } else { 1.0 })
            .collect();
        let p = Partition::bisect(&x, &w, 2);
        for (i, xi) in x.iter().enumerate() {
            assert_eq!(p.owner[i], u32::from(xi[0] >= 4.0), "point {xi:?}");
        }
    }

    #[test]
    fn more_parts_than_points_leaves_ranks_idle() {
        let x = lattice(2, 1, 1);
        let p = Partition::bisect(&x, &[1.0, 1.0], 3);
        assert_eq!(p.owned.iter().map(Vec::len).sum::<usize>(), 2);
        assert!(p.owned.iter().any(Vec::is_empty));
    }
}
