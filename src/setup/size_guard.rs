//! Refusing a body whose points and bonds cannot fit in the memory this run may use
//! ([`crate::plan::usable_memory_bytes`]: the machine's, or less under `ulimit -v` or a batch
//! job's memory limit), before they are allocated: a typo such as `Number Points X: 100000`,
//! or a horizon of 10⁶ point spacings, would otherwise abort on a failed allocation or spend
//! minutes building bonds. The error names the key at fault: the horizon when the same points
//! with a customary horizon would fit, the point count (or the mesh file) otherwise.
//!
//! The estimate is a floor: [`LEAST_BYTES_PER_POINT`] per point and [`LEAST_BYTES_PER_BOND`]
//! per directed bond, with at most N − 1 bonds a point. Where the memory size cannot be read
//! (not Linux), nothing is refused.

use crate::discretization::{cells_per_horizon, CylinderGrid};
use crate::io::deck::{Deck, DeckError, Horizon};
use crate::model::PointCloud;

/// Bytes a point needs at least in a run (reference data, the kinematic fields and the force),
/// and a directed bond (neighbour index and reference length): the floor of the run plan's
/// estimate, used before anything is allocated.
const LEAST_BYTES_PER_POINT: u128 = 120;
/// See [`LEAST_BYTES_PER_POINT`].
const LEAST_BYTES_PER_BOND: u128 = 12;

/// The horizon, in point spacings, that peridynamic models customarily use (Peridigm's
/// examples and the literature: δ ≈ 3Δx): a body that would fit with it is refused for its
/// horizon, not for its points.
const CUSTOMARY_SPACINGS: f64 = 3.0;

/// Points sampled by [`refuse_mesh_beyond_memory`] at most, and the most distance tests it
/// makes (sampled points × all points): a few milliseconds.
const MOST_SAMPLES: usize = 1000;
/// See [`MOST_SAMPLES`].
const MOST_TESTS: usize = 20_000_000;

/// Points with about `family` bonds each.
#[derive(Debug, Clone, Copy)]
struct Estimate {
    points: u128,
    family: u128,
}

impl Estimate {
    fn bytes(&self) -> u128 {
        self.points * (LEAST_BYTES_PER_POINT + self.family * LEAST_BYTES_PER_BOND)
    }

    /// The memory need, and the memory this run may use, for a message.
    fn need(&self, memory: u64) -> String {
        format!(
            "{} points with about {} bonds each need at least {} of memory, more than the {} this run may use (the machine's memory, or a lower `ulimit -v` or batch-job limit)",
            self.points,
            self.family,
            crate::plan::format_bytes(u64::try_from(self.bytes()).unwrap_or(u64::MAX)),
            crate::plan::format_bytes(memory)
        )
    }
}

/// Lattice points within a ball of `ratio` spacings: ⌈4/3·π·ratio³⌉ (ratio capped at 10⁶,
/// beyond any body's point count).
fn ball(ratio: f64) -> u128 {
    let ratio = ratio.min(1e6);
    (4.0 / 3.0 * std::f64::consts::PI * ratio.powi(3)).ceil() as u128
}

/// Bonds a point of a lattice of `cells` cells of size `spacing` has in its horizon, about:
/// the points of a ball of δ/Δ spacings (Δ the smallest cell size), but never more than the
/// box of ±[`cells_per_horizon`] cells along each axis holds besides the point itself, which
/// is at most N − 1.
fn lattice_family(horizon: f64, spacing: [f64; 3], cells: [u128; 3]) -> u128 {
    let smallest = spacing.iter().copied().fold(f64::INFINITY, f64::min);
    let window: u128 = (0..3)
        .map(|k| {
            let count = usize::try_from(cells[k]).unwrap_or(usize::MAX);
            let reach = cells_per_horizon(horizon, spacing[k], count) as u128;
            cells[k].min(2 * reach + 1)
        })
        .product();
    ball(horizon / smallest).min(window.saturating_sub(1))
}

/// The deck block with the largest constant horizon (expressions are not known before the
/// points are), and that horizon.
fn largest_constant_horizon(deck: &Deck) -> Option<(&str, f64)> {
    deck.blocks
        .iter()
        .filter_map(|b| match b.horizon {
            Horizon::Constant(h) => Some((b.name.as_str(), h)),
            Horizon::Expression(_) => None,
        })
        .max_by(|a, b| a.1.total_cmp(&b.1))
}

/// The error for `estimate`: at the block's `Horizon` when the points would fit with a
/// customary horizon (`customary` bonds a point), else at `points_key` with `points_advice`.
fn refusal(
    deck: &Deck,
    estimate: Estimate,
    customary: u128,
    horizon: Option<(&str, f64, f64)>,
    points_key: &[&str],
    points_advice: &str,
) -> DeckError {
    let memory = crate::plan::usable_memory_bytes().unwrap_or(u64::MAX);
    let with_customary = Estimate {
        family: customary.min(estimate.family),
        ..estimate
    };
    match horizon {
        Some((block, value, spacing)) if with_customary.bytes() <= u128::from(memory) => deck
            .error_at(
                &["Blocks", block, "Horizon"],
                format!(
                    "a horizon of {value} is {:.3e} point spacings ({spacing:e}): {}; peridynamic models use a horizon of about {CUSTOMARY_SPACINGS} spacings ({:e})",
                    value / spacing,
                    estimate.need(memory),
                    CUSTOMARY_SPACINGS * spacing
                ),
            ),
        _ => deck.error_at(
            points_key,
            format!("{}; {points_advice}", estimate.need(memory)),
        ),
    }
}

/// True when `estimate` fits in the memory this run may use (or its size cannot be read).
fn fits(estimate: Estimate) -> bool {
    crate::plan::usable_memory_bytes().is_none_or(|memory| estimate.bytes() <= u128::from(memory))
}

/// Refuses a lattice of `cells` cells of size `spacing` (a QuickGrid generator, in index
/// space) beyond memory, at the largest constant horizon; `points_key` and `points_advice` say
/// what to change when the points themselves are too many.
fn refuse_lattice_beyond_memory(
    deck: &Deck,
    cells: [u128; 3],
    spacing: [f64; 3],
    points_key: &[&str],
    points_advice: &str,
) -> Result<(), DeckError> {
    let smallest = spacing.iter().copied().fold(f64::INFINITY, f64::min);
    let horizon = largest_constant_horizon(deck);
    let estimate = Estimate {
        points: cells.iter().product(),
        family: horizon.map_or(0, |(_, h)| lattice_family(h, spacing, cells)),
    };
    if fits(estimate) {
        return Ok(());
    }
    let customary = lattice_family(CUSTOMARY_SPACINGS * smallest, spacing, cells);
    Err(refusal(
        deck,
        estimate,
        customary,
        horizon.map(|(block, h)| (block, h, smallest)),
        points_key,
        points_advice,
    ))
}

/// Refuses a QuickGrid box (`TensorProduct3DMeshGenerator`) beyond memory before generating it.
pub(super) fn refuse_grid_beyond_memory(
    deck: &Deck,
    length: &[f64; 3],
    number_of_points: &[u64; 3],
) -> Result<(), DeckError> {
    let [nx, ny, nz] = number_of_points;
    refuse_lattice_beyond_memory(
        deck,
        number_of_points.map(u128::from),
        [0, 1, 2].map(|k| length[k] / number_of_points[k] as f64),
        &[
            "Discretization",
            "TensorProduct3DMeshGenerator",
            "Number Points X",
        ],
        &format!("{nx} × {ny} × {nz} points are too many for this machine; use fewer points"),
    )
}

/// Refuses a QuickGrid cylinder (`TensorProductCylinderMeshGenerator`) beyond memory before
/// generating it. Its families are windows of ±n rings, rays and axial cells (index space).
pub(super) fn refuse_cylinder_beyond_memory(
    deck: &Deck,
    grid: &CylinderGrid,
) -> Result<(), DeckError> {
    let mean_radius = 0.5 * (grid.inner_radius + grid.outer_radius);
    let rays = grid.rays() as u128;
    let axial = grid.axial_cells() as u128;
    refuse_lattice_beyond_memory(
        deck,
        [grid.rings as u128, rays, axial],
        [
            grid.radial_spacing(),
            2.0 * std::f64::consts::PI / rays as f64 * mean_radius,
            grid.length / axial as f64,
        ],
        &["Discretization", "TensorProductCylinderMeshGenerator", "Number Points Radius"],
        &format!(
            "{} rings × {rays} rays × {axial} axial cells are too many for this machine; use fewer rings (Number Points Radius sets all three counts)",
            grid.rings
        ),
    )
}

/// Refuses a mesh (`Text File`, `Exodus`) whose bonds cannot fit in memory, before the
/// neighbour search. Nothing to do when N points with N − 1 bonds each fit; otherwise the
/// families of evenly spaced sample points are counted by brute force (|ξ|² ≤ δ², the
/// search's inclusive sphere, within the block when `same_block` says so; bond filters, which
/// only remove bonds, are left out), and their mean stands for every point's.
pub(super) fn refuse_mesh_beyond_memory(
    deck: &Deck,
    points: &PointCloud,
    horizons: &[f64],
    block_entry: &[usize],
    same_block: bool,
) -> Result<(), DeckError> {
    let n = points.len();
    let whole = Estimate {
        points: n as u128,
        family: n.saturating_sub(1) as u128,
    };
    if fits(whole) {
        return Ok(());
    }
    let samples = (MOST_TESTS / n).clamp(1, MOST_SAMPLES).min(n);
    let mut counted = 0u128;
    // Per deck block: sampled bonds and the sampled points' horizon-to-spacing ratio.
    let mut by_entry: Vec<(u128, f64, f64)> = vec![(0, 0.0, 0.0); block_entry.len()];
    for s in 0..samples {
        let i = s * n / samples;
        let x = points.position[i];
        let reach = horizons[i] * horizons[i];
        let family = (0..n)
            .filter(|&j| j != i && (!same_block || points.block[j] == points.block[i]))
            .filter(|&j| {
                let y = points.position[j];
                (y[0] - x[0]).powi(2) + (y[1] - x[1]).powi(2) + (y[2] - x[2]).powi(2) <= reach
            })
            .count() as u128;
        counted += family;
        let entry = &mut by_entry[points.block[i] as usize];
        entry.0 += family;
        entry.1 = entry.1.max(horizons[i]);
        entry.2 = entry.2.max(points.volume[i].cbrt());
    }
    let estimate = Estimate {
        points: n as u128,
        family: counted / samples as u128,
    };
    if fits(estimate) {
        return Ok(());
    }
    // The block whose sampled points have the most bonds, its largest sampled horizon, and
    // the cube root of its largest sampled volume as its spacing.
    let (block, &(_, horizon, spacing)) = by_entry
        .iter()
        .enumerate()
        .max_by_key(|(_, e)| e.0)
        .expect("a mesh has a block");
    let name = &deck.blocks[block_entry[block]].name;
    let customary = ball(CUSTOMARY_SPACINGS);
    Err(refusal(
        deck,
        estimate,
        customary,
        Some((name, horizon, spacing)),
        &["Discretization", "Input Mesh File"],
        "the mesh has too many points for this machine; use a coarser mesh",
    ))
}
