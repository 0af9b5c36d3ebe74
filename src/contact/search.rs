//! Proximity search for contact candidates in the current configuration, with the skin rule.

use crate::model::BondList;
use crate::neighbors::{
    find_families_with, FamilySearch, NeighborhoodRule, SearchBackend, MAX_CELLS_PER_POINT,
};
use crate::vector_width::wide_vectors_available;
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

/// For every point i, the points j with a bond j → i but no bond i → j (one-way bonds, e.g.
/// between blocks of different horizons; empty for symmetric families). With i's own family
/// these are all the points bonded to i in either direction, so the contact search can strike
/// them out without looking into the neighbours' families.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct OneWayBonds {
    /// Row starts, one row per point.
    offsets: Vec<usize>,
    /// The j of each row, ascending.
    from: Vec<u32>,
}

impl OneWayBonds {
    /// The one-way bonds of `bonds`. O(bonds) when every row is sorted (one merge pass: the
    /// rows are visited in order, and a cursor per row walks its lower neighbours in the same
    /// order as their rows are visited), O(bonds·log) otherwise.
    pub fn new(bonds: &BondList) -> Self {
        let n = bonds.num_points();
        let mut pairs: Vec<(u32, u32)> = Vec::new(); // (i, j): j → i exists, i → j does not
        let sorted = (0..n).all(|i| bonds.family(i).windows(2).all(|w| w[0] < w[1]));
        if sorted {
            // cursor[j]: the next lower neighbour (< j) of j's row not yet matched.
            let mut cursor: Vec<usize> = (0..n).map(|j| bonds.offsets[j]).collect();
            for i in 0..n {
                for &j in bonds.family(i).iter().filter(|&&j| j as usize > i) {
                    let j = j as usize;
                    let lower_end =
                        bonds.offsets[j] + bonds.family(j).partition_point(|&k| (k as usize) < j);
                    // Lower neighbours k < i of j's row that k's row (already visited) did not
                    // match: one-way j → k.
                    while cursor[j] < lower_end && (bonds.neighbor[cursor[j]] as usize) < i {
                        pairs.push((bonds.neighbor[cursor[j]], j as u32));
                        cursor[j] += 1;
                    }
                    if cursor[j] < lower_end && bonds.neighbor[cursor[j]] as usize == i {
                        cursor[j] += 1;
                    } else {
                        pairs.push((j as u32, i as u32));
                    }
                }
            }
            for (j, &unmatched) in cursor.iter().enumerate() {
                let lower_end =
                    bonds.offsets[j] + bonds.family(j).partition_point(|&k| (k as usize) < j);
                for c in unmatched..lower_end {
                    pairs.push((bonds.neighbor[c], j as u32));
                }
            }
        } else {
            for i in 0..n {
                for &j in bonds.family(i) {
                    if !bonds.family(j as usize).contains(&(i as u32)) {
                        pairs.push((j, i as u32));
                    }
                }
            }
        }
        pairs.sort_unstable();
        pairs.dedup();
        let mut offsets = vec![0usize; n + 1];
        for &(i, _) in &pairs {
            offsets[i as usize + 1] += 1;
        }
        for k in 0..n {
            offsets[k + 1] += offsets[k];
        }
        Self {
            offsets,
            from: pairs.into_iter().map(|(_, j)| j).collect(),
        }
    }

    /// No one-way bonds among `points` points (for a bond list whose rows already hold every
    /// point bonded either way).
    pub fn none(points: usize) -> Self {
        Self {
            offsets: vec![0; points + 1],
            from: Vec::new(),
        }
    }

    /// The points j with a bond j → i but none i → j (ascending).
    pub fn into_point(&self, i: usize) -> &[u32] {
        &self.from[self.offsets[i]..self.offsets[i + 1]]
    }

    /// Number of one-way bonds.
    pub fn len(&self) -> usize {
        self.from.len()
    }

    /// True when every bond has its reverse.
    pub fn is_empty(&self) -> bool {
        self.from.is_empty()
    }
}

/// Searches the points `subset` (ascending run indices) at positions `current` for pairs within
/// `radius` (|y_j − y_i|² ≤ R², evaluated as `dx*dx + dy*dy + dz*dz` with d = y_j − y_i) and
/// keeps those that are not bonded in the reference configuration (in either one's family of
/// `bonded.0`, whose one-way bonds are `bonded.1`, when given) and that `allowed(i, j)`
/// accepts. Points whose position is not finite
/// are left out (the run is unstable anyway and the energy monitor reports it).
///
/// With [`SearchBackend::Auto`] (when the grid needs at most
/// [`MAX_CELLS_PER_POINT`](crate::neighbors::MAX_CELLS_PER_POINT) cells per point) or
/// [`SearchBackend::CellGrid`], a cell grid of cell size ≥ R/2 made for this search: each
/// point scans the 125 cells around its own (distance tests branch-free in runs), bonded points are struck out with a per-task marker array
/// (no per-pair binary search), and the few survivors are sorted. Otherwise the family search
/// of [`crate::neighbors`] (k-d tree for strongly clustered clouds) is run on the current
/// positions with the horizon set to R. Both give the same list.
pub fn find_candidates(
    subset: &[u32],
    current: &[[f64; 3]],
    radius: f64,
    backend: SearchBackend,
    bonded: Option<(&BondList, &OneWayBonds)>,
    allowed: impl Fn(usize, usize) -> bool + Sync,
) -> CandidateList {
    find_candidates_for(subset, subset, current, radius, backend, bonded, allowed)
}

/// [`find_candidates`] with rows only for the points `rows_for` (ascending, a part of
/// `subset`): their candidates among all of `subset`, exactly the rows [`find_candidates`]
/// gives them (the pair test reads only the two points). The other rows are empty. `bonded`
/// is read only in the rows of `rows_for` (a bond list whose other rows are empty will do).
/// One rank of a distributed run searches the rows of its owned points against every point.
pub fn find_candidates_for(
    subset: &[u32],
    rows_for: &[u32],
    current: &[[f64; 3]],
    radius: f64,
    backend: SearchBackend,
    bonded: Option<(&BondList, &OneWayBonds)>,
    allowed: impl Fn(usize, usize) -> bool + Sync,
) -> CandidateList {
    let bonds = bonded.map(|(bonds, _)| bonds);
    let finite = |p: &u32| current[*p as usize].iter().all(|c| c.is_finite());
    let searched: Vec<u32> = subset.iter().copied().filter(finite).collect();
    let row_points: Vec<u32> = if std::ptr::eq(subset, rows_for) {
        searched.clone()
    } else {
        rows_for.iter().copied().filter(finite).collect()
    };
    let not_bonded = |i: usize, j: usize| match bonds {
        Some(bonds) => {
            bonds.family(i).binary_search(&(j as u32)).is_err()
                && bonds.family(j).binary_search(&(i as u32)).is_err()
        }
        None => true,
    };
    let rows = match backend {
        SearchBackend::KdTree => None,
        SearchBackend::Auto => CellGrid::new(&searched, current, radius, false),
        SearchBackend::CellGrid => CellGrid::new(&searched, current, radius, true),
    }
    .map(|grid| grid.rows(&row_points, current, radius, bonded, &allowed))
    .unwrap_or_else(|| {
        general_rows(&searched, &row_points, current, radius, backend, |i, j| {
            not_bonded(i, j) && allowed(i, j)
        })
    });
    let n = current.len();
    let mut offsets = vec![0usize; n + 1];
    for (a, row) in rows.iter().enumerate() {
        offsets[row_points[a] as usize + 1] = row.len();
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

/// The candidate rows of `row_points` (a part of `searched`) among `searched`, through the
/// family search of [`crate::neighbors`].
fn general_rows(
    searched: &[u32],
    row_points: &[u32],
    current: &[[f64; 3]],
    radius: f64,
    backend: SearchBackend,
    keep: impl Fn(usize, usize) -> bool + Sync,
) -> Vec<Vec<u32>> {
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
    row_points
        .par_iter()
        .map(|&i| {
            let a = searched
                .binary_search(&i)
                .expect("row points are searched points");
            let i = i as usize;
            found
                .family(a)
                .iter()
                .map(|&b| searched[b as usize])
                .filter(|&j| keep(i, j as usize))
                .collect()
        })
        .collect()
}

/// Points per task of the grid search.
const GRID_CHUNK: usize = 512;

/// Cells per search radius: a point scans the (2·CELLS_PER_RADIUS + 1)³ cells around its
/// own. Two per radius scan about 15.6 R³ of space per point instead of 27 R³ with one.
const CELLS_PER_RADIUS: usize = 2;

/// Slots whose distance test is evaluated together, branch-free, before the survivors are
/// examined one by one.
const MASK_RUN: usize = 64;

/// A uniform grid of cubic cells of side h ≥ R/[`CELLS_PER_RADIUS`] over the searched points, x fastest, with the
/// points' positions copied in cell order (structure of arrays, so that the scan of a run of
/// cells reads contiguous memory).
struct CellGrid {
    origin: [f64; 3],
    cell_size: f64,
    dims: [usize; 3],
    /// `cell_start[c]..cell_start[c + 1]`: the slots of cell c.
    cell_start: Vec<usize>,
    /// Per slot: point index and coordinates.
    index: Vec<u32>,
    x: Vec<f64>,
    y: Vec<f64>,
    z: Vec<f64>,
}

impl CellGrid {
    /// The grid for `searched` (finite positions), or `None` when the radius is not a positive
    /// finite number, or the grid would need more than
    /// [`MAX_CELLS_PER_POINT`](crate::neighbors::MAX_CELLS_PER_POINT) cells per point and
    /// `enlarge` is false (with `enlarge`, cells grow until the budget holds).
    fn new(searched: &[u32], current: &[[f64; 3]], radius: f64, enlarge: bool) -> Option<Self> {
        if !(radius.is_finite() && radius > 0.0) || searched.is_empty() {
            return None;
        }
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for &p in searched {
            let y = current[p as usize];
            for k in 0..3 {
                lo[k] = lo[k].min(y[k]);
                hi[k] = hi[k].max(y[k]);
            }
        }
        // Cells a little larger than R/CELLS_PER_RADIUS: two points within R then lie at most
        // CELLS_PER_RADIUS cells apart on every axis even after the rounding of
        // (y − origin)/h (relative errors ~1e-16 of the coordinates, far below the 1e-9
        // margin).
        let magnitude = (0..3)
            .map(|k| lo[k].abs().max(hi[k].abs()))
            .fold(0.0, f64::max);
        let mut cell_size = (radius * (1.0 + 1e-9) + 1e-9 * magnitude) / CELLS_PER_RADIUS as f64;
        let budget = (MAX_CELLS_PER_POINT * searched.len() + 4096) as f64;
        let dims = loop {
            let dims: [f64; 3] =
                std::array::from_fn(|k| ((hi[k] - lo[k]) / cell_size).floor() + 1.0);
            if dims.iter().product::<f64>() <= budget {
                break dims.map(|d| d as usize);
            }
            if !enlarge {
                return None;
            }
            cell_size *= 1.5;
        };
        let cells = dims[0] * dims[1] * dims[2];
        let mut grid = Self {
            origin: lo,
            cell_size,
            dims,
            cell_start: vec![0; cells + 1],
            index: vec![0; searched.len()],
            x: vec![0.0; searched.len()],
            y: vec![0.0; searched.len()],
            z: vec![0.0; searched.len()],
        };
        let cell_of: Vec<usize> = searched
            .iter()
            .map(|&p| grid.linear(grid.cell(current[p as usize])))
            .collect();
        for &c in &cell_of {
            grid.cell_start[c + 1] += 1;
        }
        for c in 0..cells {
            grid.cell_start[c + 1] += grid.cell_start[c];
        }
        let mut fill = grid.cell_start[..cells].to_vec();
        for (&p, &c) in searched.iter().zip(&cell_of) {
            let slot = fill[c];
            fill[c] += 1;
            let y = current[p as usize];
            grid.index[slot] = p;
            grid.x[slot] = y[0];
            grid.y[slot] = y[1];
            grid.z[slot] = y[2];
        }
        Some(grid)
    }

    /// Integer cell coordinates of position `y` (inside the bounding box).
    #[inline(always)]
    fn cell(&self, y: [f64; 3]) -> [usize; 3] {
        std::array::from_fn(|k| {
            (((y[k] - self.origin[k]) / self.cell_size) as usize).min(self.dims[k] - 1)
        })
    }

    #[inline(always)]
    fn linear(&self, c: [usize; 3]) -> usize {
        c[0] + self.dims[0] * (c[1] + self.dims[1] * c[2])
    }

    /// The candidate row of every searched point (ascending).
    fn rows(
        &self,
        searched: &[u32],
        current: &[[f64; 3]],
        radius: f64,
        bonded: Option<(&BondList, &OneWayBonds)>,
        allowed: &(impl Fn(usize, usize) -> bool + Sync),
    ) -> Vec<Vec<u32>> {
        let query = RowQuery {
            current,
            radius_squared: radius * radius,
            bonded,
            allowed,
        };
        let n = current.len();
        let wide = wide_vectors_available();
        searched
            .par_chunks(GRID_CHUNK)
            .map_init(
                // marker[j] == i: j is bonded to i, either way (the marker of a point is its
                // own index, so the array never needs clearing).
                || vec![u32::MAX; n],
                |marker, chunk| {
                    let mut rows = Vec::with_capacity(chunk.len());
                    for &i in chunk {
                        rows.push(self.row_dispatch(i, &query, marker, wide));
                    }
                    rows
                },
            )
            .flatten()
            .collect()
    }

    /// [`CellGrid::row`] built for AVX2 when `wide`, else for the baseline target (the same
    /// list: the same IEEE operations decide).
    #[inline(always)]
    fn row_dispatch(
        &self,
        i: u32,
        query: &RowQuery<impl Fn(usize, usize) -> bool>,
        marker: &mut [u32],
        wide: bool,
    ) -> Vec<u32> {
        #[cfg(target_arch = "x86_64")]
        if wide {
            // SAFETY: `wide` is true only when the CPU reports AVX2 at run time.
            return unsafe { self.row_avx2(i, query, marker) };
        }
        let _ = wide;
        self.row(i, query, marker)
    }

    /// [`CellGrid::row`] with AVX2 enabled (4-wide distance tests).
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn row_avx2(
        &self,
        i: u32,
        query: &RowQuery<impl Fn(usize, usize) -> bool>,
        marker: &mut [u32],
    ) -> Vec<u32> {
        self.row(i, query, marker)
    }

    /// Candidates of point `i` (ascending).
    #[inline(always)]
    fn row(
        &self,
        i: u32,
        query: &RowQuery<impl Fn(usize, usize) -> bool>,
        marker: &mut [u32],
    ) -> Vec<u32> {
        let RowQuery {
            current,
            radius_squared,
            bonded,
            allowed,
        } = *query;
        let p = current[i as usize];
        if let Some((bonds, one_way)) = bonded {
            for &j in bonds
                .family(i as usize)
                .iter()
                .chain(one_way.into_point(i as usize))
            {
                marker[j as usize] = i;
            }
        }
        let c = self.cell(p);
        let reach = CELLS_PER_RADIUS;
        let span = |k: usize| c[k].saturating_sub(reach)..=(c[k] + reach).min(self.dims[k] - 1);
        let mut row = Vec::new();
        for cz in span(2) {
            for cy in span(1) {
                let xs = span(0);
                let first = self.cell_start[self.linear([*xs.start(), cy, cz])];
                let last = self.cell_start[self.linear([*xs.end(), cy, cz]) + 1];
                for run in (first..last).step_by(MASK_RUN) {
                    let end = (run + MASK_RUN).min(last);
                    let (x, y, z) = (&self.x[run..end], &self.y[run..end], &self.z[run..end]);
                    // One bit per slot within R, so that the loop over the survivors (a
                    // quarter of the slots) has no hard-to-predict branch per slot.
                    let mut inside = 0u64;
                    for (k, ((&a, &b), &c)) in x.iter().zip(y).zip(z).enumerate() {
                        let d = [a - p[0], b - p[1], c - p[2]];
                        inside |=
                            u64::from(d[0] * d[0] + d[1] * d[1] + d[2] * d[2] <= radius_squared)
                                << k;
                    }
                    while inside != 0 {
                        let k = inside.trailing_zeros() as usize;
                        inside &= inside - 1;
                        let j = self.index[run + k];
                        if j != i && marker[j as usize] != i && allowed(i as usize, j as usize) {
                            row.push(j);
                        }
                    }
                }
            }
        }
        row.sort_unstable();
        row
    }
}

/// What every candidate row of one grid search asks: within R of which positions, skipping
/// which bonded pairs, keeping which pairs.
struct RowQuery<'q, F> {
    /// Current positions of all points.
    current: &'q [[f64; 3]],
    /// R², the squared search radius.
    radius_squared: f64,
    /// The bond list and its one-way bonds: pairs bonded either way are not candidates.
    bonded: Option<(&'q BondList, &'q OneWayBonds)>,
    /// The pair filter `allowed(i, j)`.
    allowed: &'q F,
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

    /// Deterministic uniform numbers in [0, 1) (xorshift).
    fn uniform(state: &mut u64) -> f64 {
        *state ^= *state << 13;
        *state ^= *state >> 7;
        *state ^= *state << 17;
        (*state >> 11) as f64 / (1u64 << 53) as f64
    }

    /// 1500 random points in a 6 × 6 × 3 box, one duplicated and one far away.
    fn random_cloud() -> Vec<[f64; 3]> {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut current: Vec<[f64; 3]> = (0..1500)
            .map(|_| {
                [
                    6.0 * uniform(&mut state),
                    6.0 * uniform(&mut state),
                    3.0 * uniform(&mut state),
                ]
            })
            .collect();
        current[10] = current[11];
        current[20] = [40.0, -3.0, 1.0];
        current
    }

    fn distance2(current: &[[f64; 3]], i: usize, j: usize) -> f64 {
        let d: [f64; 3] = std::array::from_fn(|k| current[j][k] - current[i][k]);
        d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
    }

    /// Families within 0.8 by brute force, with the bonds j → 3 (j > 3) dropped so that the
    /// bonds 3 → j are one-way.
    fn families_with_one_way_bonds(current: &[[f64; 3]]) -> BondList {
        let n = current.len();
        let mut bonds = BondList {
            offsets: vec![0],
            ..Default::default()
        };
        for i in 0..n {
            for j in 0..n {
                // One-way: 3 → its neighbours only from 3's side (drop the reverse).
                if i != j && distance2(current, i, j) <= 0.64 && !(j == 3 && i > 3) {
                    bonds.neighbor.push(j as u32);
                    bonds.reference_length.push(distance2(current, i, j).sqrt());
                }
            }
            bonds.offsets.push(bonds.neighbor.len());
        }
        bonds
    }

    /// The candidate rows by brute force: pairs of `subset` within 1.1, not bonded either
    /// way, that `keep` keeps.
    fn brute_force_rows(
        current: &[[f64; 3]],
        bonds: &BondList,
        subset: &[u32],
        keep: impl Fn(usize, usize) -> bool,
    ) -> Vec<Vec<u32>> {
        let mut expected = vec![Vec::new(); current.len()];
        for &i in subset {
            for &j in subset {
                let (i, j) = (i as usize, j as usize);
                let bonded =
                    bonds.family(i).contains(&(j as u32)) || bonds.family(j).contains(&(i as u32));
                if i != j && distance2(current, i, j) <= 1.1 * 1.1 && !bonded && keep(i, j) {
                    expected[i].push(j as u32);
                }
            }
        }
        expected
    }

    /// A bond list that holds only the rows of `part`, bonded either way (what a rank of a
    /// distributed run passes).
    fn part_bond_list(bonds: &BondList, one_way: &OneWayBonds, part: &[u32]) -> BondList {
        let n = bonds.offsets.len() - 1;
        let mut part_bonds = BondList {
            offsets: vec![0],
            ..Default::default()
        };
        for i in 0..n {
            if part.binary_search(&(i as u32)).is_ok() {
                let mut row: Vec<u32> = bonds
                    .family(i)
                    .iter()
                    .chain(one_way.into_point(i))
                    .copied()
                    .collect();
                row.sort_unstable();
                part_bonds
                    .reference_length
                    .resize(part_bonds.reference_length.len() + row.len(), 1.0);
                part_bonds.neighbor.extend(row);
            }
            part_bonds.offsets.push(part_bonds.neighbor.len());
        }
        part_bonds
    }

    #[test]
    fn grid_and_tree_find_the_brute_force_list_without_bonded_pairs() {
        // 1500 random points in a 6 × 6 × 3 box (some duplicated, some far away), families
        // within 0.8 (brute force, one bond made one-way), contact radius 1.1, a filter that
        // drops pairs whose indices sum to a multiple of 7: every backend must give exactly
        // the brute-force rows.
        let current = random_cloud();
        let n = current.len();
        let bonds = families_with_one_way_bonds(&current);
        let keep = |i: usize, j: usize| (i + j) % 7 != 0;
        let subset: Vec<u32> = (0..n as u32).filter(|p| p % 5 != 4).collect();
        let expected = brute_force_rows(&current, &bonds, &subset, keep);
        assert!(expected.iter().map(Vec::len).sum::<usize>() > 1000);
        assert!(bonds
            .family(3)
            .iter()
            .any(|&j| !bonds.family(j as usize).contains(&3)));
        let one_way = OneWayBonds::new(&bonds);
        // The bonds 3 → j with j > 3 lost their reverse: 3 appears in those j's lists only.
        for j in 0..n {
            let expected: Vec<u32> = (0..n as u32)
                .filter(|&k| {
                    bonds.family(k as usize).contains(&(j as u32)) && !bonds.family(j).contains(&k)
                })
                .collect();
            assert_eq!(one_way.into_point(j), &expected[..], "point {j}");
        }
        assert!(!one_way.is_empty());
        for backend in [
            SearchBackend::Auto,
            SearchBackend::CellGrid,
            SearchBackend::KdTree,
        ] {
            let list = find_candidates(
                &subset,
                &current,
                1.1,
                backend,
                Some((&bonds, &one_way)),
                keep,
            );
            for (i, row) in expected.iter().enumerate() {
                assert_eq!(list.row(i), &row[..], "{backend:?}, point {i}");
            }
            // Rows of a part only (one rank's points), with a bond list that holds only
            // their rows: the same rows for the part, empty rows elsewhere.
            let part: Vec<u32> = subset.iter().copied().filter(|p| p % 3 == 1).collect();
            let part_bonds = part_bond_list(&bonds, &one_way, &part);
            let list = find_candidates_for(
                &subset,
                &part,
                &current,
                1.1,
                backend,
                Some((&part_bonds, &OneWayBonds::none(n))),
                keep,
            );
            for (i, row) in expected.iter().enumerate() {
                let expected_row: &[u32] = if part.binary_search(&(i as u32)).is_ok() {
                    row
                } else {
                    &[]
                };
                assert_eq!(list.row(i), expected_row, "part, {backend:?}, point {i}");
            }
        }
    }

    #[test]
    fn finds_every_allowed_pair_within_the_radius_in_both_rows() {
        let current = [
            [0.0, 0.0, 0.0],
            [0.5, 0.0, 0.0],
            [1.2, 0.0, 0.0],
            [0.0, 0.9, 0.0],
        ];
        let all = [0u32, 1, 2, 3];
        for backend in [
            SearchBackend::Auto,
            SearchBackend::CellGrid,
            SearchBackend::KdTree,
        ] {
            let list = find_candidates(&all, &current, 1.0, backend, None, |i, j| i + j != 3);
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
        let list = find_candidates(
            &[0, 2, 3],
            &current,
            1.0,
            SearchBackend::Auto,
            None,
            |_, _| true,
        );
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
