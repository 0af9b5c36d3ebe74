//! The cell-grid search: points bucketed by a counting sort into a uniform grid, coordinates
//! in structure-of-arrays form, and each query's candidates read as one run of x-adjacent cells
//! per row of cells its shape touches, with a vectorised distance test (see the search's module
//! documentation for the measurements behind each choice).

use std::ops::{Range, RangeInclusive};

use rayon::prelude::*;

use super::shape::{squared_length, BondRules, Queries, Shape};

/// Points bucketed into a uniform grid of cells, sorted by cell (x fastest), coordinates copied
/// into structure-of-arrays form for vectorised distance tests.
pub(super) struct CellGrid {
    origin: [f64; 3],
    cell_size: [f64; 3],
    inverse_cell_size: [f64; 3],
    dims: [usize; 3],
    /// `start[c]..start[c + 1]` are the sorted slots of cell c.
    start: Vec<u32>,
    pub(super) x: Vec<f64>,
    pub(super) y: Vec<f64>,
    pub(super) z: Vec<f64>,
    /// Original point index of each sorted slot.
    pub(super) index: Vec<u32>,
    pad: f64,
}

/// Cells per median reach. Finer cells waste fewer candidates (289 per query at 2, 557 at 1 on
/// the 100³ lattice with δ = 3.015Δx) but add rows of cells; 1, 1.5, 2 and 3 measured within
/// noise of each other there (2.7–2.8 s single-threaded, 3 slightly worse), 1.5 marginally best.
const CELLS_PER_REACH: f64 = 1.5;

impl CellGrid {
    fn cell_size_guess(queries: &Queries) -> [f64; 3] {
        let n = queries.horizons.len();
        // Median reach per axis: robust against a few points with a huge horizon.
        let mut size = [0.0; 3];
        for (k, s) in size.iter_mut().enumerate() {
            let stride = (n / 4096).max(1);
            let mut reaches: Vec<f64> = (0..n)
                .step_by(stride)
                .map(|i| queries.shape(i).reach()[k])
                .collect();
            let middle = reaches.len() / 2;
            let (_, median, _) = reaches.select_nth_unstable_by(middle, f64::total_cmp);
            *s = (*median + queries.pad) / CELLS_PER_REACH;
        }
        size
    }

    fn bounds(positions: &[[f64; 3]]) -> ([f64; 3], [f64; 3]) {
        positions.iter().fold(
            ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]),
            |(lo, hi), p| {
                (
                    std::array::from_fn(|k| lo[k].min(p[k])),
                    std::array::from_fn(|k| hi[k].max(p[k])),
                )
            },
        )
    }

    fn dims_for(lo: [f64; 3], hi: [f64; 3], cell_size: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|k| {
            if cell_size[k] > 0.0 {
                ((hi[k] - lo[k]) / cell_size[k]).floor() + 1.0
            } else {
                f64::INFINITY
            }
        })
    }

    /// Number of cells the grid would have with its preferred cell size.
    pub(super) fn cells_needed(positions: &[[f64; 3]], queries: &Queries) -> f64 {
        let (lo, hi) = Self::bounds(positions);
        let dims = Self::dims_for(lo, hi, Self::cell_size_guess(queries));
        dims.iter().product()
    }

    // Inlined into the search's set-up as when the search was one file (one call site).
    #[inline]
    pub(super) fn new(positions: &[[f64; 3]], queries: &Queries, max_cells: usize) -> Self {
        let (lo, hi) = Self::bounds(positions);
        let mut cell_size = Self::cell_size_guess(queries);
        for k in 0..3 {
            if cell_size[k] <= 0.0 {
                // Zero horizons: any cell size works; use the extent.
                cell_size[k] = (hi[k] - lo[k]).max(f64::MIN_POSITIVE);
            }
        }
        // Enlarge cells uniformly until the grid fits the budget.
        loop {
            let dims = Self::dims_for(lo, hi, cell_size);
            if dims.iter().product::<f64>() <= max_cells as f64 {
                break;
            }
            cell_size = cell_size.map(|s| s * 1.5);
        }
        let dims = Self::dims_for(lo, hi, cell_size).map(|d| d as usize);
        let inverse_cell_size = cell_size.map(|s| 1.0 / s);
        let mut grid = CellGrid {
            origin: lo,
            cell_size,
            inverse_cell_size,
            dims,
            start: Vec::new(),
            x: Vec::new(),
            y: Vec::new(),
            z: Vec::new(),
            index: Vec::new(),
            pad: queries.pad,
        };
        grid.bucket(positions);
        grid
    }

    #[inline(always)]
    fn cell_coordinate(&self, k: usize, value: f64) -> usize {
        // Truncation is floor for c ≥ 0; negative values and NaN saturate to 0 in the cast,
        // which is the clamp we want anyway (and avoids a libm `floor` call on baseline x86-64).
        let c = (value - self.origin[k]) * self.inverse_cell_size[k];
        (c as usize).min(self.dims[k] - 1)
    }

    fn cell_of(&self, p: [f64; 3]) -> usize {
        let c: [usize; 3] = std::array::from_fn(|k| self.cell_coordinate(k, p[k]));
        c[0] + self.dims[0] * (c[1] + self.dims[1] * c[2])
    }

    fn bucket(&mut self, positions: &[[f64; 3]]) {
        let cells = self.dims.iter().product::<usize>();
        let cell: Vec<u32> = positions
            .par_iter()
            .map(|&p| self.cell_of(p) as u32)
            .collect();
        let mut start = vec![0u32; cells + 1];
        for &c in &cell {
            start[c as usize + 1] += 1;
        }
        for c in 0..cells {
            start[c + 1] += start[c];
        }
        let n = positions.len();
        let mut next = start.clone();
        let mut index = vec![0u32; n];
        for (i, &c) in cell.iter().enumerate() {
            let slot = &mut next[c as usize];
            index[*slot as usize] = i as u32;
            *slot += 1;
        }
        let gather = |k: usize| -> Vec<f64> {
            index
                .par_iter()
                .map(|&i| positions[i as usize][k])
                .collect()
        };
        self.x = gather(0);
        self.y = gather(1);
        self.z = gather(2);
        self.index = index;
        // The AVX2 query reads whole groups of eight slots; the lanes past a run's end are
        // masked off, whatever they hold.
        for values in [&mut self.x, &mut self.y, &mut self.z] {
            values.resize(n + PACKED_LANES - 1, 0.0);
        }
        self.index.resize(n + PACKED_LANES - 1, 0);
        self.start = start;
    }

    /// Distance from `value` to the closed interval of cell `c` along axis k (0 inside).
    #[inline(always)]
    fn gap_to_cell(&self, k: usize, value: f64, c: usize) -> f64 {
        let low = self.origin[k] + c as f64 * self.cell_size[k];
        let high = low + self.cell_size[k];
        (low - value).max(value - high).max(0.0)
    }

    /// The runs of sorted slots that contain every point the query shape at `p` can accept
    /// (and more): one run of x-adjacent cells per row of cells the shape touches.
    #[inline(always)]
    fn candidates(&self, p: [f64; 3], shape: &Shape) -> CandidateRuns<'_> {
        let reach = shape.reach().map(|r| r + self.pad);
        let z = self.cells_within(2, p[2], reach[2]);
        let y = self.cells_within(1, p[1], reach[1]);
        CandidateRuns {
            grid: self,
            p,
            reach,
            ball: matches!(shape, Shape::Ball { .. }),
            z,
            y: y.clone(),
            y_of_plane: y,
            cz: None,
            gap_z: 0.0,
        }
    }

    /// The cells along axis k that hold coordinates within `half` of `value`.
    #[inline(always)]
    fn cells_within(&self, k: usize, value: f64, half: f64) -> RangeInclusive<usize> {
        self.cell_coordinate(k, value - half)..=self.cell_coordinate(k, value + half)
    }
}

/// The runs of [`CellGrid::candidates`], plane of cells (z) by row of cells (y). An iterator
/// rather than a callback: the AVX2 build of [`CellGrid::neighbours`] must inline the loop
/// over the runs, and a closure would be compiled apart, for the baseline CPU.
struct CandidateRuns<'a> {
    grid: &'a CellGrid,
    p: [f64; 3],
    /// Reach of the shape plus the grid's pad, per axis.
    reach: [f64; 3],
    ball: bool,
    /// The planes not yet visited.
    z: RangeInclusive<usize>,
    /// The rows of the current plane not yet visited.
    y: RangeInclusive<usize>,
    /// All rows of a plane.
    y_of_plane: RangeInclusive<usize>,
    /// The current plane (`None` before the first).
    cz: Option<usize>,
    /// The ball's distance to the current plane of cells (0 for a box).
    gap_z: f64,
}

impl Iterator for CandidateRuns<'_> {
    type Item = Range<usize>;

    #[inline(always)]
    fn next(&mut self) -> Option<Range<usize>> {
        let grid = self.grid;
        let p = self.p;
        loop {
            let cz = match (self.cz, self.y.next()) {
                (Some(cz), Some(cy)) => {
                    let half_x = if self.ball {
                        // Narrow the x run to the sphere's chord over this row of cells.
                        let gap_y = (grid.gap_to_cell(1, p[1], cy) - grid.pad).max(0.0);
                        let left =
                            self.reach[0] * self.reach[0] - gap_y * gap_y - self.gap_z * self.gap_z;
                        if left < 0.0 {
                            continue;
                        }
                        left.sqrt()
                    } else {
                        self.reach[0]
                    };
                    let xs = grid.cells_within(0, p[0], half_x);
                    let row = grid.dims[0] * (cy + grid.dims[1] * cz);
                    let first = grid.start[row + xs.start()] as usize;
                    let last = grid.start[row + xs.end() + 1] as usize;
                    if first < last {
                        return Some(first..last);
                    }
                    continue;
                }
                _ => self.z.next()?,
            };
            self.cz = Some(cz);
            self.y = self.y_of_plane.clone();
            self.gap_z = if self.ball {
                (grid.gap_to_cell(2, p[2], cz) - grid.pad).max(0.0)
            } else {
                0.0
            };
        }
    }
}

/// Which neighbours of point i [`CellGrid::neighbours`] appends.
#[derive(Clone, Copy, PartialEq)]
pub(super) enum Half {
    /// All of them.
    Both,
    /// Those with a larger index, counting those with a smaller one (mirrored assembly).
    Upper,
}

/// One query of [`CellGrid::neighbours`]: point i at `p`, its shape, the bond rules, and which
/// half of its neighbours to append.
#[derive(Clone, Copy)]
pub(super) struct Query<'r> {
    pub(super) i: usize,
    pub(super) p: [f64; 3],
    pub(super) shape: Shape,
    pub(super) rules: &'r BondRules<'r>,
    pub(super) half: Half,
}

impl CellGrid {
    /// Appends the neighbours of the query's point that its `half` asks for, unsorted, to
    /// `row`; returns how many neighbours with a smaller index it left out (0 for
    /// [`Half::Both`]).
    pub(super) fn neighbours(&self, query: Query, row: &mut Vec<u32>) -> usize {
        #[cfg(target_arch = "x86_64")]
        if crate::vector_width::wide_vectors_available() {
            // SAFETY: the CPU reports AVX2.
            return unsafe { self.neighbours_avx2(query, row) };
        }
        self.neighbours_inlined::<false>(query, row)
    }

    /// [`CellGrid::neighbours`] built with AVX2: the accept masks take four candidates per
    /// instruction instead of two, and the accepted ones are packed eight at a time
    /// (`avx2`). The same IEEE operations (no FMA), so the same neighbours.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    pub(super) fn neighbours_avx2(&self, query: Query, row: &mut Vec<u32>) -> usize {
        self.neighbours_inlined::<true>(query, row)
    }

    /// The query; with `PACKED` (the AVX2 build only), each run of the hot path goes through
    /// [`CellGrid::append_run_packed`].
    #[inline(always)]
    pub(super) fn neighbours_inlined<const PACKED: bool>(
        &self,
        query: Query,
        row: &mut Vec<u32>,
    ) -> usize {
        let Query {
            i,
            p,
            shape,
            rules,
            half,
        } = query;
        let mut lower = 0;
        match shape {
            Shape::Ball { radius_squared } if rules.is_trivial() => {
                // The hot path. Per run of slots: a vectorisable pass computes the accept mask,
                // then a branch-free compaction writes every candidate and advances past the
                // accepted ones. Self is taken out at the end.
                let mut mask = [0u8; MASK_CHUNK];
                for run in self.candidates(p, &shape) {
                    #[cfg(target_arch = "x86_64")]
                    if PACKED {
                        // SAFETY: `PACKED` is set only by the AVX2 build; the run is within
                        // the grid's slots, which `bucket` pads for it.
                        lower +=
                            unsafe { self.append_run_packed(run, p, radius_squared, i, half, row) };
                        continue;
                    }
                    for start in run.clone().step_by(MASK_CHUNK) {
                        let end = (start + MASK_CHUNK).min(run.end);
                        let length = end - start;
                        let (x, y, z) = (
                            &self.x[start..end],
                            &self.y[start..end],
                            &self.z[start..end],
                        );
                        let index = &self.index[start..end];
                        match half {
                            Half::Both => {
                                for (m, ((&a, &b), &c)) in
                                    mask[..length].iter_mut().zip(x.iter().zip(y).zip(z))
                                {
                                    let xi = [a - p[0], b - p[1], c - p[2]];
                                    *m = (squared_length(xi) <= radius_squared) as u8;
                                }
                            }
                            // The index test in the same branch-free pass: leaving the lower
                            // neighbours out afterwards was a branch per bond that the
                            // space-filling order makes unpredictable.
                            Half::Upper => {
                                for (m, (((&a, &b), &c), &j)) in mask[..length]
                                    .iter_mut()
                                    .zip(x.iter().zip(y).zip(z).zip(index))
                                {
                                    let xi = [a - p[0], b - p[1], c - p[2]];
                                    let within = squared_length(xi) <= radius_squared;
                                    lower += usize::from(within & ((j as usize) < i));
                                    *m = (within & (j as usize > i)) as u8;
                                }
                            }
                        }
                        let used = row.len();
                        row.extend_from_slice(index);
                        let out = &mut row[used..];
                        let mut accepted = 0;
                        for k in 0..length {
                            out[accepted] = out[k];
                            accepted += mask[k] as usize;
                        }
                        row.truncate(used + accepted);
                    }
                }
                if half == Half::Both {
                    if let Some(own) = row.iter().position(|&j| j as usize == i) {
                        row.swap_remove(own);
                    }
                }
            }
            _ => {
                for slot in self.candidates(p, &shape).flatten() {
                    let j = self.index[slot] as usize;
                    let xi = [
                        self.x[slot] - p[0],
                        self.y[slot] - p[1],
                        self.z[slot] - p[2],
                    ];
                    if shape.contains(xi) && j != i && rules.allows(i, j) {
                        if half == Half::Upper && j < i {
                            lower += 1;
                        } else {
                            row.push(j as u32);
                        }
                    }
                }
            }
        }
        lower
    }
}

/// Slots whose accept mask is computed in one vectorised pass.
const MASK_CHUNK: usize = 64;

/// Slots the AVX2 query tests and packs at a time (eight 32-bit indices per register).
pub(super) const PACKED_LANES: usize = 8;
