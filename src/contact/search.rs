//! Proximity search for contact candidates in the current configuration, with the skin rule.

use crate::neighbors::{find_families_with, FamilySearch, NeighborhoodRule, SearchBackend};
use rayon::prelude::*;

/// Every point's contact candidates: the points within the search radius R at the last search
/// that it may touch (interaction defined, not bonded). Both directions are stored (j in i's
/// row and i in j's), so each point gathers its own force without write conflicts.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CandidateList {
    /// Row starts, one row per point of the model (rows of points without contact are empty).
    pub offsets: Vec<usize>,
    /// Candidate point indices (run order), each row ascending.
    pub neighbor: Vec<u32>,
}

impl CandidateList {
    /// Candidates of point `i`.
    pub fn row(&self, i: usize) -> &[u32] {
        &self.neighbor[self.offsets[i]..self.offsets[i + 1]]
    }

    /// Number of distinct candidate pairs (each stored twice).
    pub fn pairs(&self) -> usize {
        self.neighbor.len() / 2
    }
}

/// Searches the points `subset` (ascending run indices) at positions `current` for pairs within
/// `radius` (|y_j − y_i| ≤ R) and keeps those `allowed(i, j)` accepts. Points whose position is
/// not finite are left out (the run is unstable anyway and the energy monitor reports it).
///
/// The search is the family search of [`crate::neighbors`] (cell grid, or k-d tree for strongly
/// clustered clouds) run on the current positions with the horizon set to R.
pub fn find_candidates(
    subset: &[u32],
    current: &[[f64; 3]],
    radius: f64,
    backend: SearchBackend,
    allowed: impl Fn(usize, usize) -> bool + Sync,
) -> CandidateList {
    let searched: Vec<u32> = subset
        .iter()
        .copied()
        .filter(|&p| current[p as usize].iter().all(|c| c.is_finite()))
        .collect();
    let positions: Vec<[f64; 3]> = searched.iter().map(|&p| current[p as usize]).collect();
    let horizons = vec![radius; searched.len()];
    let blocks = vec![0u32; searched.len()];
    let found = find_families_with(
        &FamilySearch {
            positions: &positions,
            horizons: &horizons,
            blocks: &blocks,
            rule: NeighborhoodRule::Sphere,
            omit_bonds_between_blocks: false,
            filters: &[],
        },
        backend,
    )
    .unwrap_or_else(|e| panic!("contact search on validated positions failed: {e}"));
    let rows: Vec<Vec<u32>> = (0..searched.len())
        .into_par_iter()
        .map(|a| {
            let i = searched[a] as usize;
            found
                .family(a)
                .iter()
                .map(|&b| searched[b as usize])
                .filter(|&j| allowed(i, j as usize))
                .collect()
        })
        .collect();
    let n = current.len();
    let mut offsets = vec![0usize; n + 1];
    for (a, row) in rows.iter().enumerate() {
        offsets[searched[a] as usize + 1] = row.len();
    }
    for k in 0..n {
        offsets[k + 1] += offsets[k];
    }
    let mut neighbor = Vec::with_capacity(offsets[n]);
    for row in rows {
        neighbor.extend_from_slice(&row);
    }
    CandidateList { offsets, neighbor }
}

/// Largest displacement of any point of `subset` between `previous` (its positions at the last
/// search, in subset order) and `current`. Non-finite positions count as infinitely far.
pub fn max_displacement(subset: &[u32], previous: &[[f64; 3]], current: &[[f64; 3]]) -> f64 {
    subset
        .par_iter()
        .zip(previous.par_iter())
        .map(|(&p, y0)| {
            let y = current[p as usize];
            let d2: f64 = (0..3).map(|k| (y[k] - y0[k]).powi(2)).sum();
            if d2.is_nan() {
                f64::INFINITY
            } else {
                d2
            }
        })
        .reduce(|| 0.0, f64::max)
        .sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_every_allowed_pair_within_the_radius_in_both_rows() {
        let current = [
            [0.0, 0.0, 0.0],
            [0.5, 0.0, 0.0],
            [1.2, 0.0, 0.0],
            [0.0, 0.9, 0.0],
        ];
        let all = [0u32, 1, 2, 3];
        for backend in [SearchBackend::CellGrid, SearchBackend::KdTree] {
            let list = find_candidates(&all, &current, 1.0, backend, |i, j| i + j != 3);
            // Pairs within 1.0: (0,1) 0.5, (1,2) 0.7, (0,3) 0.9 (excluded: 0+3 = 3), (1,3) 1.03 no.
            assert_eq!(list.row(0), &[1]);
            assert_eq!(list.row(1), &[0]);
            assert_eq!(list.row(2), &[] as &[u32]);
            assert_eq!(list.row(3), &[] as &[u32]);
            // (1,2) is excluded by the filter too (1 + 2 = 3).
            assert_eq!(list.pairs(), 1);
        }
    }

    #[test]
    fn subset_only_and_non_finite_points_skipped() {
        let current = [
            [0.0; 3],
            [0.1, 0.0, 0.0],
            [0.2, 0.0, 0.0],
            [f64::NAN, 0.0, 0.0],
        ];
        let list = find_candidates(&[0, 2, 3], &current, 1.0, SearchBackend::Auto, |_, _| true);
        assert_eq!(list.row(0), &[2]);
        assert_eq!(list.row(1), &[] as &[u32]);
        assert_eq!(list.row(2), &[0]);
        assert_eq!(list.row(3), &[] as &[u32]);
        assert_eq!(
            max_displacement(&[0, 3], &[[0.0; 3], [0.0; 3]], &current),
            f64::INFINITY
        );
        assert_eq!(
            max_displacement(&[1, 2], &[[0.0; 3], [0.0; 3]], &current),
            0.2
        );
    }
}
