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
//! Where the code is: `shape` (what a query accepts), `grid` and `kd_tree` (the two searches),
//! `assembly` (searched rows to the bond list, direct or mirrored), `avx2` and `bitonic` (the
//! AVX2 kernels of the grid query, the reference lengths and the row sort).
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

mod assembly;
#[cfg(target_arch = "x86_64")]
mod avx2;
#[cfg(target_arch = "x86_64")]
mod bitonic;
mod grid;
mod kd_tree;
mod shape;

use kiddo::{ImmutableKdTree, SquaredEuclidean};
use thiserror::Error;

use super::bond_filter::BondFilter;
use crate::model::BondList;
use assembly::{assemble, assemble_mirrored, split_off_lower};
use grid::{CellGrid, Half, Query};
use kd_tree::KdSearch;
use shape::{BondRules, Queries};

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

#[cfg(test)]
mod tests;
