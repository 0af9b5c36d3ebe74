//! Family (neighbour list) construction.
//!
//! Two search structures give identical results:
//!
//! * a **uniform cell grid** (points bucketed by a counting sort into cells of 1/1.5 of the
//!   median horizon, coordinates copied to structure-of-arrays form; each query scans only the
//!   rows of cells its sphere touches, each row trimmed to the sphere's chord and read as one
//!   contiguous run of x-adjacent cells, with a vectorised distance test). This is the fast path
//!   for the meshes peridynamics uses (near-uniform spacing).
//! * a **k-d tree** (kiddo's `ImmutableKdTree`, queried through its allocation-free visitor with
//!   per-thread scratch), used when a grid would need more than [`MAX_CELLS_PER_POINT`] cells
//!   per point (strongly clustered clouds, tiny horizons in a huge box).
//!
//! Both search once: blocks of consecutive points are searched in parallel (rayon) into
//! block-local buffers with rows sorted there, then the compressed-sparse-row [`BondList`] is
//! filled block by block from the prefix sum of the counts, with the reference lengths. Queries
//! run in point order, so points in space-filling-curve order hit warm cache.
//!
//! When the neighbour test is symmetric (one horizon for all points, no bond filter: every
//! run of a deck with a constant horizon), each point keeps only its neighbours of larger
//! index and counts the others, and every kept bond is mirrored into the other point's row
//! (`assemble_mirrored`): half of every row is sorted, and the mirrored halves arrive in
//! order. The bond list is the same, bond for bond and bit for bit. Counted with callgrind on
//! the 40³ lattice (δ = 3.015Δx, `NEIGHBOR_BENCH_DIRECT` for the direct path): 3.97e9
//! instructions direct, 3.82e9 mirrored (−4 %; sorting halves, the mirror records and their
//! scatter take back most of it). Filtering j > i inside the accept mask instead of after it
//! measured 4.19e9 there (the extra compares run on every candidate, not every neighbour).
//!
//! Cost on the 100³ lattice (δ = 3.015Δx, 1.18e8 bonds), one core of the development machine:
//! ≈ 1.0 s searching, 0.65 s sorting rows (the grid visits points in cell order, not index
//! order), ≈ 0.9 s allocating and filling the 1.4 GB of output; see `benches/neighbor_search.rs`.
//! Of that output cost, first-touch page faults alone take ≈ 0.65 CPU s (4 KiB pages; huge pages
//! are opt-in via madvise on the development machine and their fault time varied 0.2–3 s).
//! On 2026-11-28 the same machine, much slower by then, took 1.0–1.25 s on one thread and
//! 0.54–0.65 s on two to first-touch 1.4 GB of fresh pages (a C program touching one byte per
//! page, ≈ 3 µs per fault, most of it the kernel's fault path under virtualisation): a floor
//! for this search's output that no change inside the search can lower.
//!
//! On CPUs with AVX2 the cell-grid query runs a second build of itself compiled for AVX2
//! (four distance tests per instruction instead of two; the same operations, no FMA, so the
//! same neighbours, as a test checks): 40³ lattice 4.40e9 → 3.76e9 instructions (cachegrind,
//! three searches), 100³ on one thread 0.91 of the baseline build's time (3 alternated pairs);
//! on two threads the output's page faults and memory traffic hide the gain.
//!
//! The mirrored assembly records only the bonds that reach a later block of points: a block's
//! own mirrored bonds are read back from its sorted upper rows. In space-filling-curve order
//! most bonds stay within their block, so most records, their pushes and their pages are gone:
//! 40³ lattice 3.76e9 → 3.51e9 instructions (cachegrind, three searches); 100³ paired medians
//! 0.97 of the time on one thread (3 alternated pairs), 0.93 on two (4 pairs).
//!
//! The AVX2 build also packs each group of eight accepted candidates into the row with one
//! permutation (`avx2`), where the baseline compacts one slot at a time: 40³ lattice 3.51e9 →
//! 2.37e9 instructions; 100³ paired medians 0.89 of the time on one thread, 0.81 on two (4
//! alternated pairs each). And it computes the reference lengths four per square root: 2.37e9
//! → 2.19e9 instructions; 0.89 on one thread, 0.94 on two (4 pairs each).
//!
//! With AVX2 the rows are sorted by a bitonic sorting network in registers (`bitonic`), which
//! has no data-dependent branch, instead of `sort_unstable`: 40³ lattice 2.19e9 → 2.04e9
//! instructions (cachegrind, three searches); 100³ paired medians 0.93 of the time on one
//! thread, 0.97 on two (4 alternated pairs, best of three searches each), where the output's
//! page faults and memory traffic hide most of the gain.
//!
//! Measured and rejected: transparent huge pages for the output (`madvise`), which spare the
//! faults of 4 KiB pages: the first search of a process took 2.85–3.04 s on two threads
//! against 2.16–2.46 s (3 alternated pairs; the kernel clears, and on fragmented memory
//! compacts, 2 MiB pages at first touch); only later searches in the same process gained, and
//! a run searches once. And cells two to four times finer along x alone (the runs stay one per
//! row of cells, trimmed closer to the chord): 40³ −2 to −3 % instructions, 100³ (two times
//! finer) within noise.
//!
//! Measured and rejected: a half stencil for the mirrored search, testing only each cell's
//! slots above the query's index (a suffix: a cell's slots are in increasing index) with the
//! lower counts taken from the mirrored bonds instead, and each in-block pair's length computed
//! once for both rows. 40³: 3.51e9 → 3.40e9 instructions, but no faster on 100³ (3 pairs each
//! way within noise): a query spends its time per run of cells, not per candidate, and
//! splitting runs at cells added back what the skipped candidates saved.
//!
//! Also measured and rejected: a bounding-box tree over runs of consecutive indices (leaves cut
//! at the Morton cells of the point order), visited depth first so rows come out sorted, with an
//! exact count pass and a fill pass straight into the output. It needed fewer distance tests
//! (189 per point against the grid's 289) but short runs and tree bookkeeping made it 3.45 CPU s
//! against the grid's 2.65 on one thread.

#[cfg(target_arch = "x86_64")]
mod avx2;
#[cfg(target_arch = "x86_64")]
mod bitonic;

use std::ops::{Range, RangeInclusive};

use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rayon::prelude::*;
use thiserror::Error;

use super::bond_filter::BondFilter;
use crate::model::BondList;

/// Which points are neighbours (Peridigm decides this per discretization type).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum NeighborhoodRule {
    /// Exodus / Text File: j is a neighbour of i when |X_j − X_i|² ≤ δ_i² (inclusive; δ per
    /// point, so families may be asymmetric with variable horizons).
    Sphere,
    /// PdQuickGrid tensor-product lattice with cell sizes `spacing`: ±n_k cells per axis,
    /// n_k = floor(δ/Δ_k) rounded up when the fractional part ≥ 0.5, capped at `cells[k]`
    /// (cells per axis); with `spherical` also the strict test |ξ|² < δ² (Peridigm
    /// `NeighborhoodType: "Spherical"`).
    ///
    /// "Within n_k cells" is tested as |ξ_k| < (n_k + ½)Δ_k, which is exact for cell-centred
    /// lattice points and immune to rounding in their coordinates.
    LatticeBox {
        /// Cell size Δ per axis (length units), `X/Y/Z Length / Number Points X/Y/Z`.
        spacing: [f64; 3],
        /// Number of cells per axis (`Number Points X/Y/Z`).
        cells: [usize; 3],
        /// Also require |ξ|² < δ² (`NeighborhoodType: "Spherical"`).
        spherical: bool,
    },
}

/// Everything the family search needs. Slices are indexed by point.
#[derive(Debug, Clone)]
pub struct FamilySearch<'a> {
    /// Reference positions X (length units).
    pub positions: &'a [[f64; 3]],
    /// Horizon δ of each point (length units).
    pub horizons: &'a [f64],
    /// Block index of each point (used by `omit_bonds_between_blocks`).
    pub blocks: &'a [u32],
    /// Neighbour criterion.
    pub rule: NeighborhoodRule,
    /// Peridigm `Omit Bonds Between Blocks: All`: no bond joins points of different blocks.
    pub omit_bonds_between_blocks: bool,
    /// Bond filters: a bond whose segment crosses any of them is not created.
    pub filters: &'a [BondFilter],
}

/// Which search structure to use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SearchBackend {
    /// Cell grid unless it would need more than [`MAX_CELLS_PER_POINT`] cells per point, then
    /// the k-d tree.
    #[default]
    Auto,
    /// Uniform cell grid (cells enlarged if the cell budget would be exceeded).
    CellGrid,
    /// kiddo k-d tree.
    KdTree,
}

/// A grid is used while it needs at most this many cells per point (plus a small constant);
/// beyond that the empty cells cost more memory and time than a tree.
pub const MAX_CELLS_PER_POINT: usize = 4;

/// Why the family search input is unusable.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum NeighborSearchError {
    /// Per-point arrays disagree in length.
    #[error("neighbour search: {positions} positions but {horizons} horizons and {blocks} block ids; every point needs one of each")]
    LengthMismatch {
        /// Number of positions.
        positions: usize,
        /// Number of horizons.
        horizons: usize,
        /// Number of block ids.
        blocks: usize,
    },
    /// Point indices are stored as `u32`.
    #[error("neighbour search: {0} points exceed the supported maximum of 4294967295")]
    TooManyPoints(usize),
    /// A position is NaN or infinite.
    #[error("neighbour search: point {point} (0-based) has a non-finite position {position:?}; check the mesh file")]
    NonFinitePosition {
        /// 0-based point index.
        point: usize,
        /// Its coordinates.
        position: [f64; 3],
    },
    /// A horizon is negative, NaN or infinite.
    #[error("neighbour search: point {point} (0-based) at {position:?} has horizon {horizon}; the block's Horizon must be a finite number ≥ 0")]
    BadHorizon {
        /// 0-based point index.
        point: usize,
        /// Its coordinates.
        position: [f64; 3],
        /// The horizon evaluated there.
        horizon: f64,
    },
    /// A lattice spacing is not a positive finite number.
    #[error("neighbour search: lattice spacing {0:?} must be positive in every direction")]
    BadSpacing([f64; 3]),
    /// The neighbour lists would not fit in memory addressable by this machine.
    #[error("neighbour search: {0} bonds do not fit in memory")]
    TooManyBonds(u128),
}

/// Builds every point's family: rows sorted by neighbour index, self never included,
/// `reference_length` = |X_j − X_i| filled.
///
/// # Panics
/// On the inputs [`try_find_families`] rejects (non-finite positions, bad horizons, length
/// mismatch). Data from users should go through [`try_find_families`].
pub fn find_families(search: &FamilySearch) -> BondList {
    try_find_families(search).unwrap_or_else(|error| panic!("{error}"))
}

/// [`find_families`] with input validation and the automatic choice of search structure.
pub fn try_find_families(search: &FamilySearch) -> Result<BondList, NeighborSearchError> {
    find_families_with(search, SearchBackend::Auto)
}

/// [`try_find_families`] with an explicit search structure (for benchmarks and cross-checks;
/// all backends give identical results).
pub fn find_families_with(
    search: &FamilySearch,
    backend: SearchBackend,
) -> Result<BondList, NeighborSearchError> {
    find_rows_with(search, backend, None)
}

/// The families of `points` only: row k of the result is point `points[k]`'s family, exactly
/// the row [`try_find_families`] gives it (neighbour indices stay global). A distributed run
/// builds the rows of its own points and ghosts this way instead of every point's.
///
/// # Panics
/// When an entry of `points` is not a point of the search (a caller's broken invariant).
pub fn try_find_families_of(
    search: &FamilySearch,
    points: &[u32],
) -> Result<BondList, NeighborSearchError> {
    let n = search.positions.len();
    assert!(
        points.iter().all(|&p| (p as usize) < n),
        "family rows requested for points beyond the {n} of the search"
    );
    find_rows_with(search, SearchBackend::Auto, Some(points))
}

/// The rows of `rows` (all points when `None`), searched with `backend`.
fn find_rows_with(
    search: &FamilySearch,
    backend: SearchBackend,
    rows: Option<&[u32]>,
) -> Result<BondList, NeighborSearchError> {
    find_rows_assembled(search, backend, rows, true)
}

/// Whether every pair may be found once and mirrored into the other point's row: the neighbour
/// test must give the same answer from both ends, bit for bit. It does when every point has
/// bitwise the same horizon (the query shape is then the same everywhere, and the tests on
/// ξ = X_j − X_i read only |ξ_k| and |ξ|², which negating ξ leaves bitwise unchanged) and no
/// bond filter is given (a filter's segment test need not be exactly symmetric in its ends);
/// the block test is symmetric. Rows of a subset of points are searched directly.
fn is_mirrorable(search: &FamilySearch, rows: Option<&[u32]>) -> bool {
    rows.is_none()
        && search.filters.is_empty()
        && search
            .horizons
            .windows(2)
            .all(|w| w[0].to_bits() == w[1].to_bits())
}

/// [`find_rows_with`], with the mirrored assembly allowed or not (tests compare the two).
fn find_rows_assembled(
    search: &FamilySearch,
    backend: SearchBackend,
    rows: Option<&[u32]>,
    allow_mirror: bool,
) -> Result<BondList, NeighborSearchError> {
    validate(search)?;
    let mirrored = allow_mirror && is_mirrorable(search, rows);
    let queries = Queries::new(search);
    let n = search.positions.len();
    if n == 0 {
        return Ok(BondList {
            offsets: vec![0],
            ..BondList::default()
        });
    }
    let grid_cells = CellGrid::cells_needed(search.positions, &queries);
    let budget = MAX_CELLS_PER_POINT * n + 4096;
    let use_grid = match backend {
        SearchBackend::Auto => grid_cells <= budget as f64,
        SearchBackend::CellGrid => true,
        SearchBackend::KdTree => false,
    };
    let rules = BondRules::new(search, queries.pad);
    if use_grid {
        let grid = CellGrid::new(search.positions, &queries, budget);
        let query = |i: usize, half: Half| Query {
            i,
            p: search.positions[i],
            shape: queries.shape(i),
            rules: &rules,
            half,
        };
        if mirrored {
            return assemble_mirrored(
                search.positions,
                || (),
                |_, i, row| grid.neighbours(query(i, Half::Upper), row),
            );
        }
        assemble(
            search.positions,
            rows,
            || (),
            |_, i, row| {
                grid.neighbours(query(i, Half::Both), row);
            },
        )
    } else {
        let tree: ImmutableKdTree<f64, 3> = ImmutableKdTree::new_from_slice(search.positions)
            .map_err(|_| NeighborSearchError::TooManyPoints(n))?;
        let kd = KdSearch {
            tree: &tree,
            positions: search.positions,
            pad: queries.pad,
        };
        let scratch = || tree.create_scratch::<SquaredEuclidean<f64>>();
        if mirrored {
            return assemble_mirrored(search.positions, scratch, |scratch, i, row| {
                kd.neighbours(scratch, i, queries.shape(i), &rules, row);
                split_off_lower(i, row)
            });
        }
        assemble(search.positions, rows, scratch, |scratch, i, row| {
            kd.neighbours(scratch, i, queries.shape(i), &rules, row)
        })
    }
}

fn validate(search: &FamilySearch) -> Result<(), NeighborSearchError> {
    let n = search.positions.len();
    if search.horizons.len() != n || search.blocks.len() != n {
        return Err(NeighborSearchError::LengthMismatch {
            positions: n,
            horizons: search.horizons.len(),
            blocks: search.blocks.len(),
        });
    }
    if n > u32::MAX as usize {
        return Err(NeighborSearchError::TooManyPoints(n));
    }
    for (point, (&position, &horizon)) in search.positions.iter().zip(search.horizons).enumerate() {
        if !position.iter().all(|c| c.is_finite()) {
            return Err(NeighborSearchError::NonFinitePosition { point, position });
        }
        if !(horizon.is_finite() && horizon >= 0.0) {
            return Err(NeighborSearchError::BadHorizon {
                point,
                position,
                horizon,
            });
        }
    }
    if let NeighborhoodRule::LatticeBox { spacing, .. } = search.rule {
        if !spacing.iter().all(|s| s.is_finite() && *s > 0.0) {
            return Err(NeighborSearchError::BadSpacing(spacing));
        }
    }
    Ok(())
}

/// Geometric neighbour test of one query point, on ξ = X_j − X_i.
#[derive(Debug, Clone, Copy)]
enum Shape {
    /// |ξ|² ≤ r².
    Ball { radius_squared: f64 },
    /// |ξ_k| < half_k for every axis, and, if `radius_squared` is finite, |ξ|² < r².
    Box { half: [f64; 3], radius_squared: f64 },
}

impl Shape {
    /// The exact neighbour test on ξ = X_j − X_i.
    #[inline(always)]
    fn contains(&self, xi: [f64; 3]) -> bool {
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
    fn reach(&self) -> [f64; 3] {
        match *self {
            Shape::Ball { radius_squared } => [radius_squared.sqrt(); 3],
            Shape::Box { half, .. } => half,
        }
    }
}

/// Per-point query shapes plus the rounding pad of the candidate search.
struct Queries<'a> {
    horizons: &'a [f64],
    rule: NeighborhoodRule,
    /// Added to every reach so that rounding in coordinates never drops a true neighbour from
    /// the candidate set; the exact test decides afterwards.
    pad: f64,
}

impl<'a> Queries<'a> {
    fn new(search: &FamilySearch<'a>) -> Self {
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
    fn shape(&self, i: usize) -> Shape {
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
fn squared_length(d: [f64; 3]) -> f64 {
    d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
}

#[inline(always)]
fn difference(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [b[0] - a[0], b[1] - a[1], b[2] - a[2]]
}

/// Block and bond-filter tests, applied to candidates that pass the geometric test.
struct BondRules<'a> {
    positions: &'a [[f64; 3]],
    blocks: Option<&'a [u32]>,
    /// Filters with their bounding boxes, padded for rounding.
    filters: Vec<(&'a BondFilter, [f64; 3], [f64; 3])>,
}

impl<'a> BondRules<'a> {
    fn new(search: &FamilySearch<'a>, pad: f64) -> Self {
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

    fn is_trivial(&self) -> bool {
        self.blocks.is_none() && self.filters.is_empty()
    }

    #[inline]
    fn allows(&self, i: usize, j: usize) -> bool {
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

/// Points bucketed into a uniform grid of cells, sorted by cell (x fastest), coordinates copied
/// into structure-of-arrays form for vectorised distance tests.
struct CellGrid {
    origin: [f64; 3],
    cell_size: [f64; 3],
    inverse_cell_size: [f64; 3],
    dims: [usize; 3],
    /// `start[c]..start[c + 1]` are the sorted slots of cell c.
    start: Vec<u32>,
    x: Vec<f64>,
    y: Vec<f64>,
    z: Vec<f64>,
    /// Original point index of each sorted slot.
    index: Vec<u32>,
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
    fn cells_needed(positions: &[[f64; 3]], queries: &Queries) -> f64 {
        let (lo, hi) = Self::bounds(positions);
        let dims = Self::dims_for(lo, hi, Self::cell_size_guess(queries));
        dims.iter().product()
    }

    fn new(positions: &[[f64; 3]], queries: &Queries, max_cells: usize) -> Self {
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
enum Half {
    /// All of them.
    Both,
    /// Those with a larger index, counting those with a smaller one (mirrored assembly).
    Upper,
}

/// One query of [`CellGrid::neighbours`]: point i at `p`, its shape, the bond rules, and which
/// half of its neighbours to append.
#[derive(Clone, Copy)]
struct Query<'r> {
    i: usize,
    p: [f64; 3],
    shape: Shape,
    rules: &'r BondRules<'r>,
    half: Half,
}

impl CellGrid {
    /// Appends the neighbours of the query's point that its `half` asks for, unsorted, to
    /// `row`; returns how many neighbours with a smaller index it left out (0 for
    /// [`Half::Both`]).
    fn neighbours(&self, query: Query, row: &mut Vec<u32>) -> usize {
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
    fn neighbours_avx2(&self, query: Query, row: &mut Vec<u32>) -> usize {
        self.neighbours_inlined::<true>(query, row)
    }

    /// The query; with `PACKED` (the AVX2 build only), each run of the hot path goes through
    /// [`CellGrid::append_run_packed`].
    #[inline(always)]
    fn neighbours_inlined<const PACKED: bool>(&self, query: Query, row: &mut Vec<u32>) -> usize {
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
const PACKED_LANES: usize = 8;

/// The k-d tree search.
struct KdSearch<'a> {
    tree: &'a ImmutableKdTree<f64, 3>,
    positions: &'a [[f64; 3]],
    pad: f64,
}

type KdScratch = kiddo::kd_tree::QueryScratch<kiddo::stem_strategy::Eytzinger, f64, 3>;

impl KdSearch<'_> {
    /// Appends the neighbours of point i, unsorted, to `row`.
    fn neighbours(
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

/// Points per parallel work item: large enough to amortise scheduling, small enough to balance
/// two to a few dozen threads on 1e5–1e7 points.
const BLOCK: usize = 8192;

/// Sorted families of one block of consecutive points.
struct BlockRows {
    counts: Vec<u32>,
    neighbors: Vec<u32>,
}

/// Splits `data` into consecutive mutable pieces of the given lengths.
fn split_by_lengths<'a, T>(mut data: &'a mut [T], lengths: &[usize]) -> Vec<&'a mut [T]> {
    let mut pieces = Vec::with_capacity(lengths.len());
    for &length in lengths {
        let (head, tail) = data.split_at_mut(length);
        pieces.push(head);
        data = tail;
    }
    pieces
}

/// Builds the CSR in one search pass: blocks of consecutive points are searched in parallel into
/// block-local buffers (`find_row` appends the unsorted neighbours of point i), rows sorted
/// there; then the final arrays are filled block by block with the reference lengths.
///
/// A count-then-fill scheme would avoid the buffers (≈ 4 bytes per bond extra) but search
/// twice; searching is the dearer part.
fn assemble<S, I, F>(
    positions: &[[f64; 3]],
    rows: Option<&[u32]>,
    init: I,
    find_row: F,
) -> Result<BondList, NeighborSearchError>
where
    I: Fn() -> S + Sync + Send,
    F: Fn(&mut S, usize, &mut Vec<u32>) + Sync + Send,
{
    let n = rows.map_or(positions.len(), <[u32]>::len);
    let point = |k: usize| rows.map_or(k, |rows| rows[k] as usize);
    let blocks: Vec<Range<usize>> = (0..n)
        .step_by(BLOCK)
        .map(|s| s..(s + BLOCK).min(n))
        .collect();
    let searched: Vec<BlockRows> = blocks
        .par_iter()
        .map_init(
            || (init(), Vec::with_capacity(1024), 0usize),
            |(state, row, last_size), block| {
                let mut counts = Vec::with_capacity(block.len());
                // The previous block's size is a good guess for this one's (same region).
                let mut neighbors = Vec::with_capacity(*last_size + *last_size / 8);
                for k in block.clone() {
                    row.clear();
                    find_row(state, point(k), row);
                    sort_row(row);
                    counts.push(row.len() as u32);
                    neighbors.extend_from_slice(row);
                }
                *last_size = neighbors.len();
                BlockRows { counts, neighbors }
            },
        )
        .collect();

    let mut offsets = Vec::with_capacity(n + 1);
    offsets.push(0usize);
    let mut total = 0usize;
    for block in &searched {
        for &c in &block.counts {
            total += c as usize;
            offsets.push(total);
        }
    }
    if total > isize::MAX as usize / 12 {
        return Err(NeighborSearchError::TooManyBonds(total as u128));
    }
    // calloc: pages are zeroed lazily, so first touch happens in the parallel fill below.
    let mut neighbor = vec![0u32; total];
    let mut reference_length = vec![0.0f64; total];
    let block_bonds: Vec<usize> = searched.iter().map(|b| b.neighbors.len()).collect();
    let neighbor_pieces = split_by_lengths(&mut neighbor, &block_bonds);
    let length_pieces = split_by_lengths(&mut reference_length, &block_bonds);
    searched
        .into_par_iter()
        .zip(blocks)
        .zip(neighbor_pieces.into_par_iter().zip(length_pieces))
        .for_each(|((rows, block), (neighbors, lengths))| {
            neighbors.copy_from_slice(&rows.neighbors);
            let mut start = 0;
            for (k, &count) in block.zip(&rows.counts) {
                let end = start + count as usize;
                reference_lengths(
                    positions,
                    point(k),
                    &rows.neighbors[start..end],
                    &mut lengths[start..end],
                );
                start = end;
            }
        });
    Ok(BondList {
        offsets,
        neighbor,
        reference_length,
    })
}

/// Sorts a row of neighbour indices in increasing order: with AVX2 by a sorting network
/// ([`bitonic`], no data-dependent branches), else by `sort_unstable`; the same row either way.
fn sort_row(row: &mut [u32]) {
    if row.is_sorted() {
        return;
    }
    #[cfg(target_arch = "x86_64")]
    if crate::vector_width::wide_vectors_available() {
        // SAFETY: the CPU reports AVX2.
        return unsafe { bitonic::sort(row) };
    }
    row.sort_unstable();
}

/// `lengths[n]` = |X_j − X_i| for the neighbours j = `row[n]` of point i: with AVX2 four at
/// a time ([`avx2::reference_lengths_wide`], the same operations, so the same lengths).
fn reference_lengths(positions: &[[f64; 3]], i: usize, row: &[u32], lengths: &mut [f64]) {
    #[cfg(target_arch = "x86_64")]
    if crate::vector_width::wide_vectors_available() {
        // SAFETY: the CPU reports AVX2.
        return unsafe { avx2::reference_lengths_wide(positions, i, row, lengths) };
    }
    reference_lengths_from(positions, i, row, lengths, 0);
}

/// [`reference_lengths`] from row position `first` on, one bond at a time.
#[inline(always)]
fn reference_lengths_from(
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

/// How many neighbours of a sorted upper row lie in `block`, the row's own block of points:
/// they come first, the later blocks' neighbours after them.
fn in_block(row: &[u32], block: &Range<usize>) -> usize {
    row.partition_point(|&j| (j as usize) < block.end)
}

/// Keeps the neighbours of point i above i in `row` and returns how many were below.
fn split_off_lower(i: usize, row: &mut Vec<u32>) -> usize {
    let before = row.len();
    row.retain(|&j| j as usize > i);
    before - row.len()
}

/// The upper half of the families of one block of consecutive points (mirrored assembly).
struct UpperRows {
    /// Per point: how many neighbours have a smaller index (they arrive by mirroring).
    lower_counts: Vec<u32>,
    /// Per point: how many neighbours have a larger index.
    upper_counts: Vec<u32>,
    /// The points' upper neighbours, row after row, each row sorted.
    upper: Vec<u32>,
    /// The mirror images of the upper bonds into later blocks, by destination block (entry
    /// `k` is block `this + 1 + k`): `[j − first point of the destination block, i − first
    /// point of this block]` for every bond i→j with j in that block, in increasing i. 16 bits
    /// suffice because [`BLOCK`] ≤ 2¹⁶. Bonds within the block need no record: the fill reads
    /// them from `upper`, whose rows list their own block's points first.
    mirrored: Vec<Vec<[u16; 2]>>,
}

const _: () = assert!(
    BLOCK <= 1 << 16,
    "mirror records store block-local indices in u16"
);

/// [`assemble`] for a symmetric neighbour test ([`is_mirrorable`]): `find_upper` appends the
/// neighbours of point i with a larger index, unsorted, and returns how many have a smaller
/// one, so each point sorts only half its row; every kept bond i→j whose j lies in a later
/// block is also recorded for that block as the mirrored bond j→i. Then each block of rows is
/// filled by the thread that owns it (first touch there): first the mirrored bonds, taken from
/// the earlier blocks in increasing order and, within one, in increasing i; then, row by row in
/// increasing i, the row's own upper part, whose bonds within the block are mirrored into the
/// later rows as it goes; so each row's lower part comes out sorted without a sort. The result
/// is the full search's, bond for bond: the lower count a point finds itself equals the
/// mirrored bonds it receives, which is checked.
fn assemble_mirrored<S, I, F>(
    positions: &[[f64; 3]],
    init: I,
    find_upper: F,
) -> Result<BondList, NeighborSearchError>
where
    I: Fn() -> S + Sync + Send,
    F: Fn(&mut S, usize, &mut Vec<u32>) -> usize + Sync + Send,
{
    let n = positions.len();
    let blocks: Vec<Range<usize>> = (0..n)
        .step_by(BLOCK)
        .map(|s| s..(s + BLOCK).min(n))
        .collect();
    let searched: Vec<UpperRows> = blocks
        .par_iter()
        .enumerate()
        .map_init(
            || (init(), Vec::with_capacity(1024), 0usize),
            |(state, row, last_size), (b, block)| {
                let mut lower_counts = Vec::with_capacity(block.len());
                let mut upper_counts = Vec::with_capacity(block.len());
                let mut upper = Vec::with_capacity(*last_size + *last_size / 8);
                let mut mirrored: Vec<Vec<[u16; 2]>> = Vec::new();
                for i in block.clone() {
                    row.clear();
                    let below = find_upper(state, i, row);
                    sort_row(row);
                    lower_counts.push(below as u32);
                    upper_counts.push(row.len() as u32);
                    upper.extend_from_slice(row);
                    let source = (i - block.start) as u16;
                    for &j in &row[in_block(row, block)..] {
                        let j = j as usize;
                        let k = j / BLOCK - b - 1;
                        if k >= mirrored.len() {
                            mirrored.resize_with(k + 1, Vec::new);
                        }
                        mirrored[k].push([(j % BLOCK) as u16, source]);
                    }
                }
                *last_size = upper.len();
                UpperRows {
                    lower_counts,
                    upper_counts,
                    upper,
                    mirrored,
                }
            },
        )
        .collect();

    let mut offsets = Vec::with_capacity(n + 1);
    offsets.push(0usize);
    let mut total = 0usize;
    for block in &searched {
        for (&lower, &upper) in block.lower_counts.iter().zip(&block.upper_counts) {
            total += lower as usize + upper as usize;
            offsets.push(total);
        }
    }
    if total > isize::MAX as usize / 12 {
        return Err(NeighborSearchError::TooManyBonds(total as u128));
    }
    // calloc: pages are zeroed lazily, so first touch happens in the parallel fill below.
    let mut neighbor = vec![0u32; total];
    let mut reference_length = vec![0.0f64; total];
    let block_bonds: Vec<usize> = blocks
        .iter()
        .map(|block| offsets[block.end] - offsets[block.start])
        .collect();
    let neighbor_pieces = split_by_lengths(&mut neighbor, &block_bonds);
    let length_pieces = split_by_lengths(&mut reference_length, &block_bonds);
    let offsets_ref = &offsets;
    let searched_ref = &searched;
    blocks
        .into_par_iter()
        .enumerate()
        .zip(neighbor_pieces.into_par_iter().zip(length_pieces))
        .for_each(|((d, block), (neighbors, lengths))| {
            let base = offsets_ref[block.start];
            let mut cursor: Vec<usize> = block.clone().map(|i| offsets_ref[i] - base).collect();
            for (b, source) in searched_ref[..d].iter().enumerate() {
                let Some(records) = source.mirrored.get(d - b - 1) else {
                    continue;
                };
                let first = b * BLOCK;
                for &[j, i] in records {
                    let slot = &mut cursor[j as usize];
                    neighbors[*slot] = (first + i as usize) as u32;
                    *slot += 1;
                }
            }
            let own = &searched_ref[d];
            let mut taken = 0;
            for (k, i) in block.clone().enumerate() {
                let lower = own.lower_counts[k] as usize;
                let upper = &own.upper[taken..taken + own.upper_counts[k] as usize];
                taken += upper.len();
                let start = offsets_ref[i] - base;
                // Row i's lower part is complete: the earlier blocks' records came above, and
                // this block's rows before i have mirrored their bonds into it.
                assert_eq!(
                    cursor[k],
                    start + lower,
                    "point {i}: the neighbour test is not symmetric"
                );
                let end = start + lower + upper.len();
                neighbors[start + lower..end].copy_from_slice(upper);
                // The sorted upper row holds this block's points first; each receives i after
                // every earlier block's points and after this block's smaller indices.
                for &j in &upper[..in_block(upper, &block)] {
                    let slot = &mut cursor[j as usize - block.start];
                    neighbors[*slot] = i as u32;
                    *slot += 1;
                }
                reference_lengths(
                    positions,
                    i,
                    &neighbors[start..end],
                    &mut lengths[start..end],
                );
            }
        });
    Ok(BondList {
        offsets,
        neighbor,
        reference_length,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::neighbors::{Disk, RectangularPlane};

    /// SplitMix64: small deterministic generator for test clouds.
    struct Random(u64);

    impl Random {
        fn next(&mut self) -> f64 {
            self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            z ^= z >> 31;
            (z >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    fn random_cloud(n: usize, seed: u64) -> Vec<[f64; 3]> {
        let mut random = Random(seed);
        (0..n)
            .map(|_| [random.next(), random.next(), random.next()])
            .collect()
    }

    /// Cell-centred lattice x0 + (i+½)h, x fastest (PdQuickGrid order).
    fn lattice(n: usize, h: f64) -> Vec<[f64; 3]> {
        let mut points = Vec::with_capacity(n * n * n);
        for k in 0..n {
            for j in 0..n {
                for i in 0..n {
                    points.push([
                        (i as f64 + 0.5) * h,
                        (j as f64 + 0.5) * h,
                        (k as f64 + 0.5) * h,
                    ]);
                }
            }
        }
        points
    }

    fn search<'a>(
        positions: &'a [[f64; 3]],
        horizons: &'a [f64],
        blocks: &'a [u32],
        rule: NeighborhoodRule,
    ) -> FamilySearch<'a> {
        FamilySearch {
            positions,
            horizons,
            blocks,
            rule,
            omit_bonds_between_blocks: false,
            filters: &[],
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_avx2_grid_search_is_the_baseline_search() {
        // The AVX2 build of `CellGrid::neighbours` against the baseline build, row by row, in
        // both halves: the same neighbours in the same order and the same lower counts, on a
        // random cloud with points at the horizon's edge of a lattice mixed in.
        if !crate::vector_width::wide_vectors_available() {
            return;
        }
        let mut positions = random_cloud(1500, 11);
        positions.extend(lattice(8, 0.125));
        let horizons = vec![0.125 * 3.015; positions.len()];
        let blocks = vec![0; positions.len()];
        let s = search(&positions, &horizons, &blocks, NeighborhoodRule::Sphere);
        let queries = Queries::new(&s);
        let rules = BondRules::new(&s, queries.pad);
        let grid = CellGrid::new(&positions, &queries, MAX_CELLS_PER_POINT * positions.len());
        let (mut wide, mut baseline) = (Vec::new(), Vec::new());
        let mut accepted = 0;
        for half in [Half::Both, Half::Upper] {
            for (i, &p) in positions.iter().enumerate() {
                wide.clear();
                baseline.clear();
                let query = Query {
                    i,
                    p,
                    shape: queries.shape(i),
                    rules: &rules,
                    half,
                };
                // SAFETY: the CPU reports AVX2 (checked above).
                let lower_wide = unsafe { grid.neighbours_avx2(query, &mut wide) };
                let lower_baseline = grid.neighbours_inlined::<false>(query, &mut baseline);
                assert_eq!(wide, baseline, "point {i}");
                assert_eq!(lower_wide, lower_baseline, "point {i}");
                accepted += wide.len();
            }
        }
        assert!(accepted > 10 * positions.len(), "{accepted}");
    }

    /// Reference families from the rule's definition, written independently of the search code:
    /// every ordered pair tested, rows naturally sorted.
    fn brute_force(s: &FamilySearch) -> Vec<Vec<u32>> {
        let n = s.positions.len();
        (0..n)
            .map(|i| {
                let a = s.positions[i];
                let delta = s.horizons[i];
                (0..n)
                    .filter(|&j| j != i)
                    .filter(|&j| {
                        let b = s.positions[j];
                        let xi = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
                        let d2 = xi[0] * xi[0] + xi[1] * xi[1] + xi[2] * xi[2];
                        let geometric = match s.rule {
                            NeighborhoodRule::Sphere => d2 <= delta * delta,
                            NeighborhoodRule::LatticeBox {
                                spacing,
                                cells,
                                spherical,
                            } => {
                                (0..3).all(|k| {
                                    let ratio = delta / spacing[k];
                                    let mut reach = ratio.floor();
                                    if ratio - reach >= 0.5 {
                                        reach += 1.0;
                                    }
                                    let reach = reach.min(cells[k] as f64);
                                    (xi[k] / spacing[k]).round().abs() <= reach
                                }) && (!spherical || d2 < delta * delta)
                            }
                        };
                        geometric
                            && (!s.omit_bonds_between_blocks || s.blocks[i] == s.blocks[j])
                            && !s.filters.iter().any(|f| f.cuts(a, b))
                    })
                    .map(|j| j as u32)
                    .collect()
            })
            .collect()
    }

    fn rows(bonds: &BondList) -> Vec<Vec<u32>> {
        (0..bonds.num_points())
            .map(|i| bonds.family(i).to_vec())
            .collect()
    }

    const BACKENDS: [SearchBackend; 3] = [
        SearchBackend::Auto,
        SearchBackend::CellGrid,
        SearchBackend::KdTree,
    ];

    /// Runs every backend, checks CSR invariants and reference lengths, and returns the rows
    /// (all backends must agree).
    fn families(s: &FamilySearch) -> Vec<Vec<u32>> {
        let mut result: Option<Vec<Vec<u32>>> = None;
        for backend in BACKENDS {
            let bonds = find_families_with(s, backend).unwrap();
            assert_eq!(bonds.offsets.len(), s.positions.len() + 1);
            assert_eq!(bonds.reference_length.len(), bonds.neighbor.len());
            for i in 0..bonds.num_points() {
                let family = bonds.family(i);
                assert!(family.windows(2).all(|w| w[0] < w[1]), "row {i} not sorted");
                assert!(!family.contains(&(i as u32)), "self in row {i}");
                for (b, &j) in bonds.range(i).zip(family) {
                    let (x, y) = (s.positions[i], s.positions[j as usize]);
                    let length =
                        ((y[0] - x[0]).powi(2) + (y[1] - x[1]).powi(2) + (y[2] - x[2]).powi(2))
                            .sqrt();
                    assert_eq!(bonds.reference_length[b], length);
                }
            }
            let r = rows(&bonds);
            if let Some(previous) = &result {
                assert_eq!(previous, &r, "{backend:?} differs");
            }
            result = Some(r);
        }
        result.unwrap()
    }

    /// The mirrored assembly must give exactly the bond list of the direct one (each row
    /// searched in full and sorted): same rows, same order, bitwise the same lengths.
    fn assert_mirrored_equals_direct(s: &FamilySearch) {
        assert!(
            is_mirrorable(s, None),
            "the case must take the mirrored path"
        );
        for backend in [SearchBackend::CellGrid, SearchBackend::KdTree] {
            let direct = find_rows_assembled(s, backend, None, false).unwrap();
            let mirrored = find_rows_assembled(s, backend, None, true).unwrap();
            assert_eq!(mirrored.offsets, direct.offsets, "{backend:?}");
            assert_eq!(mirrored.neighbor, direct.neighbor, "{backend:?}");
            let bits = |b: &BondList| -> Vec<u64> {
                b.reference_length.iter().map(|l| l.to_bits()).collect()
            };
            assert_eq!(bits(&mirrored), bits(&direct), "{backend:?}");
        }
    }

    #[test]
    fn mirrored_assembly_equals_direct_search() {
        // Irregular points, several blocks of the assembly (BLOCK = 8192 points would need a
        // bigger cloud, so the search runs on a 9000-point sparse cloud with a small horizon
        // to stay quick: ≈ 4 neighbours per point, rows crossing the block boundary).
        let positions = random_cloud(9000, 21);
        let horizons = vec![0.05; positions.len()];
        let blocks = vec![0u32; positions.len()];
        let s = search(&positions, &horizons, &blocks, NeighborhoodRule::Sphere);
        assert!(find_families(&s).num_bonds() > 20_000);
        assert_mirrored_equals_direct(&s);
        // Omitted cross-block bonds: the block test is symmetric, so it mirrors too.
        let positions = random_cloud(800, 5);
        let horizons = vec![0.15; positions.len()];
        let blocks: Vec<u32> = positions.iter().map(|p| (p[1] > 0.4) as u32).collect();
        let mut s = search(&positions, &horizons, &blocks, NeighborhoodRule::Sphere);
        s.omit_bonds_between_blocks = true;
        assert_mirrored_equals_direct(&s);
        // Lattices, in lattice order and shuffled into another order: the ball and both
        // QuickGrid box rules.
        let h = 0.1;
        let mut positions = lattice(8, h);
        let horizons = vec![3.015 * h; positions.len()];
        let blocks = vec![0; positions.len()];
        for shuffled in [false, true] {
            if shuffled {
                let mut random = Random(3);
                for k in (1..positions.len()).rev() {
                    let other = (random.next() * (k + 1) as f64) as usize;
                    positions.swap(k, other.min(k));
                }
            }
            let mut rules = vec![NeighborhoodRule::Sphere];
            for spherical in [false, true] {
                rules.push(NeighborhoodRule::LatticeBox {
                    spacing: [h; 3],
                    cells: [8; 3],
                    spherical,
                });
            }
            for rule in rules {
                assert_mirrored_equals_direct(&search(&positions, &horizons, &blocks, rule));
            }
        }
    }

    #[test]
    fn only_symmetric_searches_are_mirrored() {
        let positions = random_cloud(50, 1);
        let blocks = vec![0; 50];
        let mut horizons = vec![0.2; 50];
        let plane =
            RectangularPlane::new([0.0, 1.0, 0.0], [0.1, 0.5, 0.2], [1.0, 0.0, 0.0], 0.5, 0.6)
                .unwrap();
        let filters = [BondFilter::from(plane)];
        let mut s = search(&positions, &horizons, &blocks, NeighborhoodRule::Sphere);
        assert!(is_mirrorable(&s, None));
        assert!(!is_mirrorable(&s, Some(&[0, 1])));
        s.filters = &filters;
        assert!(!is_mirrorable(&s, None));
        horizons[7] = 0.21;
        let s = search(&positions, &horizons, &blocks, NeighborhoodRule::Sphere);
        assert!(!is_mirrorable(&s, None));
    }

    #[test]
    fn reference_lengths_agree_bitwise_in_both_directions() {
        let positions = random_cloud(2000, 7);
        let horizons = vec![0.12; positions.len()];
        let blocks = vec![0u32; positions.len()];
        let s = search(&positions, &horizons, &blocks, NeighborhoodRule::Sphere);
        let bonds = find_families(&s);
        for i in 0..bonds.num_points() {
            for b in bonds.range(i) {
                let j = bonds.neighbor[b] as usize;
                let k = bonds.offsets[j] + bonds.family(j).binary_search(&(i as u32)).unwrap();
                assert_eq!(
                    bonds.reference_length[b].to_bits(),
                    bonds.reference_length[k].to_bits()
                );
            }
        }
    }

    #[test]
    fn interior_family_sizes_on_cubic_lattice() {
        // Integer vectors v with |v|² ≤ 3.015² = 9.09, by |v|² = 0..9 (sums of three squares):
        // 1 + 6 + 12 + 8 + 6 + 24 + 24 + 0 + 12 + 30 = 123; minus self → 122. The 30 at |v|² = 9
        // are the 6 axis vectors of length 3 and the 24 permutations of (±2, ±2, ±1).
        let counted = (-3i32..=3)
            .flat_map(|a| {
                (-3i32..=3).flat_map(move |b| (-3i32..=3).map(move |c| a * a + b * b + c * c))
            })
            .filter(|&d2| d2 != 0 && (d2 as f64) <= 3.015 * 3.015)
            .count();
        assert_eq!(counted, 122);

        let h = 0.25;
        let n = 9; // centre (4,4,4) has 4 ≥ 3 cells on every side: a full interior family
        let positions = lattice(n, h);
        let centre = 4 + n * (4 + n * 4);
        let horizons = vec![3.015 * h; positions.len()];
        let blocks = vec![0; positions.len()];
        let size = |rule| families(&search(&positions, &horizons, &blocks, rule))[centre].len();
        assert_eq!(size(NeighborhoodRule::Sphere), 122);
        // Box: n = floor(3.015) = 3 (fraction 0.015 < 0.5), (2·3 + 1)³ − 1 = 342.
        let lattice_rule = |spherical| NeighborhoodRule::LatticeBox {
            spacing: [h; 3],
            cells: [n; 3],
            spherical,
        };
        assert_eq!(size(lattice_rule(false)), 342);
        // Spherical: strict |ξ|² < δ². Lattice |ξ|²/h² are integers and 3.015² = 9.090225 is
        // not, so no point sits on the sphere and < and ≤ agree: 122 again.
        assert_eq!(size(lattice_rule(true)), 122);
    }

    #[test]
    fn lattice_box_rounds_half_up_and_caps() {
        // δ = 2.5h: fraction exactly 0.5 rounds up → n = 3, box 7³ − 1 = 342 in the interior.
        // δ = 2.49h → n = 2, 5³ − 1 = 124.
        let h = 0.5;
        let n = 9;
        let positions = lattice(n, h);
        let centre = 4 + n * (4 + n * 4);
        let blocks = vec![0; positions.len()];
        let rule = NeighborhoodRule::LatticeBox {
            spacing: [h; 3],
            cells: [n; 3],
            spherical: false,
        };
        for (ratio, expected) in [(2.5, 342), (2.49, 124)] {
            let horizons = vec![ratio * h; positions.len()];
            let s = search(&positions, &horizons, &blocks, rule);
            let got = families(&s);
            assert_eq!(got[centre].len(), expected, "δ/h = {ratio}");
            assert_eq!(got, brute_force(&s));
        }
        // Cap: 3 cells in z, δ = 10h → n_z capped at 3, n_x = n_y = 3 cells cap too: on a 3×3×3
        // lattice every point sees all 26 others.
        let positions = lattice(3, h);
        let horizons = vec![10.0 * h; positions.len()];
        let blocks = vec![0; positions.len()];
        let rule = NeighborhoodRule::LatticeBox {
            spacing: [h; 3],
            cells: [3; 3],
            spherical: false,
        };
        let got = families(&search(&positions, &horizons, &blocks, rule));
        assert!(got.iter().all(|f| f.len() == 26));
    }

    #[test]
    fn variable_horizons_give_asymmetric_families() {
        // Points on the x axis at 0, 1, 3 with δ = 1, 2, 0.5 (all exactly representable):
        // 0 reaches 1 (distance 1 ≤ 1) but not 3; 1 reaches 0 and 3 (distances 1, 2 ≤ 2);
        // 3 reaches nobody (nearest is 2 away > 0.5).
        let positions = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [3.0, 0.0, 0.0]];
        let horizons = [1.0, 2.0, 0.5];
        let blocks = [0; 3];
        let s = search(&positions, &horizons, &blocks, NeighborhoodRule::Sphere);
        assert_eq!(families(&s), vec![vec![1], vec![0, 2], vec![]]);
    }

    #[test]
    fn neighbour_exactly_at_horizon_is_included() {
        // (0.75, 1, 0) is at distance exactly 1.25 from the origin (0.5625 + 1 = 1.5625 = 1.25²,
        // all exact in binary). With δ = 1.25 it is a neighbour; with the next smaller double it
        // is not.
        let positions = [[0.0, 0.0, 0.0], [0.75, 1.0, 0.0]];
        let blocks = [0; 2];
        let horizons = [1.25, 1.25];
        let s = search(&positions, &horizons, &blocks, NeighborhoodRule::Sphere);
        assert_eq!(families(&s), vec![vec![1], vec![0]]);
        let below = f64::from_bits(1.25f64.to_bits() - 1);
        let horizons = [below, below];
        let s = search(&positions, &horizons, &blocks, NeighborhoodRule::Sphere);
        assert_eq!(families(&s), vec![Vec::<u32>::new(), vec![]]);
    }

    #[test]
    fn omitting_bonds_between_blocks_removes_exactly_cross_block_bonds() {
        let positions = random_cloud(600, 7);
        let horizons = vec![0.15; positions.len()];
        let blocks: Vec<u32> = positions
            .iter()
            .map(|p| (p[0] > 0.5) as u32 + (p[2] > 0.7) as u32)
            .collect();
        let mut s = search(&positions, &horizons, &blocks, NeighborhoodRule::Sphere);
        let all = families(&s);
        s.omit_bonds_between_blocks = true;
        let omitted = families(&s);
        let mut cross = 0;
        for i in 0..positions.len() {
            let same: Vec<u32> = all[i]
                .iter()
                .copied()
                .filter(|&j| blocks[j as usize] == blocks[i])
                .collect();
            cross += all[i].len() - same.len();
            assert_eq!(omitted[i], same, "row {i}");
        }
        assert!(
            cross > 100,
            "the test needs cross-block bonds, found {cross}"
        );
        assert_eq!(omitted, brute_force(&s));
    }

    #[test]
    fn bond_filters_remove_exactly_the_crossing_bonds() {
        let positions = random_cloud(700, 11);
        let horizons = vec![0.16; positions.len()];
        let blocks = vec![0; positions.len()];
        let plane =
            RectangularPlane::new([0.0, 1.0, 0.0], [0.1, 0.5, 0.2], [1.0, 0.0, 0.0], 0.5, 0.6)
                .unwrap();
        let normal = [1.0, 1.0, 0.5];
        let disk = Disk::new([0.6, 0.4, 0.5], normal, 0.25).unwrap();
        let filters = [BondFilter::from(plane), BondFilter::from(disk)];
        let mut s = search(&positions, &horizons, &blocks, NeighborhoodRule::Sphere);
        let unfiltered = families(&s);
        s.filters = &filters;
        let filtered = families(&s);
        assert_eq!(filtered, brute_force(&s));
        let removed: usize = unfiltered
            .iter()
            .zip(&filtered)
            .map(|(a, b)| a.len() - b.len())
            .sum();
        assert!(removed > 100, "the test needs cut bonds, found {removed}");
        // Constant horizon: families must stay symmetric (j ∈ N(i) ⇔ i ∈ N(j)).
        for (i, family) in filtered.iter().enumerate() {
            for &j in family {
                assert!(
                    filtered[j as usize].binary_search(&(i as u32)).is_ok(),
                    "{i}→{j} one-way"
                );
            }
        }
    }

    #[test]
    fn agrees_with_brute_force_on_random_cloud_with_variable_horizons() {
        let positions = random_cloud(1500, 3);
        let mut random = Random(99);
        let horizons: Vec<f64> = (0..positions.len())
            .map(|_| 0.05 + 0.15 * random.next())
            .collect();
        let blocks = vec![0; positions.len()];
        let s = search(&positions, &horizons, &blocks, NeighborhoodRule::Sphere);
        let got = families(&s);
        assert_eq!(got, brute_force(&s));
        let asymmetric = got.iter().enumerate().any(|(i, f)| {
            f.iter()
                .any(|&j| got[j as usize].binary_search(&(i as u32)).is_err())
        });
        assert!(asymmetric, "variable horizons should give one-way bonds");
    }

    #[test]
    fn rows_of_some_points_are_their_rows_of_the_full_search() {
        // Variable horizons (one-way bonds) and both search structures: a rank's rows must be
        // bitwise the full search's, lengths included, in the order asked for.
        let positions = random_cloud(1500, 7);
        let mut random = Random(11);
        let horizons: Vec<f64> = (0..positions.len())
            .map(|_| 0.05 + 0.15 * random.next())
            .collect();
        let blocks = vec![0; positions.len()];
        let s = search(&positions, &horizons, &blocks, NeighborhoodRule::Sphere);
        let all = try_find_families(&s).unwrap();
        let points: Vec<u32> = (0..positions.len() as u32).rev().step_by(7).collect();
        for rows in [
            try_find_families_of(&s, &points).unwrap(),
            find_rows_with(&s, SearchBackend::KdTree, Some(&points)).unwrap(),
            find_rows_with(&s, SearchBackend::CellGrid, Some(&points)).unwrap(),
        ] {
            assert_eq!(rows.num_points(), points.len());
            for (k, &p) in points.iter().enumerate() {
                assert_eq!(rows.family(k), all.family(p as usize));
                let (mine, full) = (rows.range(k), all.range(p as usize));
                assert_eq!(
                    rows.reference_length[mine], all.reference_length[full],
                    "point {p}"
                );
            }
        }
        assert_eq!(try_find_families_of(&s, &[]).unwrap().num_bonds(), 0);
    }

    #[test]
    fn agrees_with_brute_force_on_lattice_rules_and_clustered_cloud() {
        let h = 0.1;
        let positions = lattice(8, h);
        let horizons = vec![2.2 * h; positions.len()];
        let blocks = vec![0; positions.len()];
        for spherical in [false, true] {
            let rule = NeighborhoodRule::LatticeBox {
                spacing: [h; 3],
                cells: [8; 3],
                spherical,
            };
            let s = search(&positions, &horizons, &blocks, rule);
            assert_eq!(families(&s), brute_force(&s));
        }
        // Two tight clusters far apart: a grid at the horizon's scale would need ~1e12 cells, so
        // Auto takes the tree and the forced grid enlarges its cells; both must stay exact.
        let mut positions = random_cloud(400, 5);
        for p in positions.iter_mut().skip(200) {
            p[0] += 1e4;
        }
        let horizons = vec![0.2; positions.len()];
        let blocks = vec![0; positions.len()];
        let s = search(&positions, &horizons, &blocks, NeighborhoodRule::Sphere);
        assert!(CellGrid::cells_needed(&positions, &Queries::new(&s)) > 1e6);
        assert_eq!(families(&s), brute_force(&s));
    }

    #[test]
    fn degenerate_inputs() {
        let s = search(&[], &[], &[], NeighborhoodRule::Sphere);
        assert_eq!(find_families(&s).offsets, vec![0]);
        // Zero horizons and coincident points: nobody is a neighbour except coincident points
        // (distance 0 ≤ 0).
        let positions = [[1.0, 1.0, 1.0], [1.0, 1.0, 1.0], [2.0, 1.0, 1.0]];
        let horizons = [0.0; 3];
        let blocks = [0; 3];
        let s = search(&positions, &horizons, &blocks, NeighborhoodRule::Sphere);
        assert_eq!(families(&s), vec![vec![1], vec![0], vec![]]);
    }

    #[test]
    fn invalid_input_is_an_error() {
        let positions = [[0.0; 3], [1.0, 0.0, 0.0]];
        let blocks = [0; 2];
        let bad = |horizons: &[f64]| {
            try_find_families(&search(
                &positions,
                horizons,
                &blocks,
                NeighborhoodRule::Sphere,
            ))
        };
        assert!(matches!(
            bad(&[1.0, -1.0]),
            Err(NeighborSearchError::BadHorizon { point: 1, .. })
        ));
        assert!(matches!(
            bad(&[f64::NAN, 1.0]),
            Err(NeighborSearchError::BadHorizon { point: 0, .. })
        ));
        assert!(matches!(
            bad(&[1.0]),
            Err(NeighborSearchError::LengthMismatch { .. })
        ));
        let positions = [[0.0, f64::INFINITY, 0.0], [1.0, 0.0, 0.0]];
        let horizons = [1.0; 2];
        let result = try_find_families(&search(
            &positions,
            &horizons,
            &blocks,
            NeighborhoodRule::Sphere,
        ));
        assert!(matches!(
            result,
            Err(NeighborSearchError::NonFinitePosition { point: 0, .. })
        ));
        let rule = NeighborhoodRule::LatticeBox {
            spacing: [1.0, 0.0, 1.0],
            cells: [2; 3],
            spherical: false,
        };
        let positions = [[0.0; 3], [1.0, 0.0, 0.0]];
        let result = try_find_families(&search(&positions, &horizons, &blocks, rule));
        assert!(matches!(result, Err(NeighborSearchError::BadSpacing(_))));
        assert!(result.unwrap_err().to_string().contains("spacing"));
    }
}
