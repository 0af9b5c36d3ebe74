//! Geometry a double cannot carry through a run, refused before any point is generated or
//! bond built: points that coincide because their coordinates round to the same value (a
//! `Y Origin` of −10³⁰⁸ with points 0.2 apart), and lengths or volumes whose products
//! overflow or underflow (a `Y Length` of 10³⁰⁸ gives volumes whose mass is infinite).
//!
//! The bound: every length (coordinate, point spacing, horizon) within
//! [[`SMALLEST_LENGTH`], [`LARGEST_LENGTH`]] in the deck's units, every volume within their
//! cubes. The run forms a length to the fourth power at most (the bond-based micromodulus
//! 18K/(πδ⁴)) and volumes times moduli or densities; within 10^±50 these stay far inside the
//! double range (10^±308), and no body needs more in any unit (10⁵⁰ m is about 10²⁴ times
//! the observable universe).

use crate::discretization::CylinderGrid;
use crate::io::deck::{Deck, DeckError};
use crate::model::PointCloud;

/// The largest length peridyn computes with, in the deck's units (see the module docs).
pub(super) const LARGEST_LENGTH: f64 = 1e50;
/// The smallest length peridyn computes with, in the deck's units (see the module docs).
pub(super) const SMALLEST_LENGTH: f64 = 1e-50;

/// Units in the last place a point spacing must span at least where the coordinates are
/// largest: 100 keeps every spacing within 1 % of its value after rounding.
const LEAST_ULPS: f64 = 100.0;

const AXES: [&str; 3] = ["X", "Y", "Z"];

/// The length at `key` must lie within the bound (`what` names it in the message).
fn length_in_range(deck: &Deck, key: &[&str], what: &str, value: f64) -> Result<(), DeckError> {
    if value.abs() <= LARGEST_LENGTH {
        return Ok(());
    }
    Err(deck.error_at(
        key,
        format!(
            "{what} {value:e} is beyond the lengths peridyn computes with (at most {LARGEST_LENGTH:e} in the deck's units): the volumes, and products such as δ⁴ and volume × density, would overflow a double; give it in the deck's units (metres or millimetres)"
        ),
    ))
}

/// A point spacing must lie above [`SMALLEST_LENGTH`].
fn spacing_in_range(deck: &Deck, key: &[&str], what: &str, spacing: f64) -> Result<(), DeckError> {
    if spacing >= SMALLEST_LENGTH {
        return Ok(());
    }
    Err(deck.error_at(
        key,
        format!(
            "{what} gives points {spacing:e} apart, below the smallest spacing peridyn computes with ({SMALLEST_LENGTH:e} in the deck's units): the volumes, and products such as δ⁴, would underflow to 0; give the length in the deck's units (metres or millimetres)"
        ),
    ))
}

/// True when points `spacing` apart stay apart, and evenly spaced, where the coordinate's
/// magnitude reaches `far` (both finite).
fn distinguishable(spacing: f64, far: f64) -> bool {
    spacing > LEAST_ULPS * f64::EPSILON * far
}

/// The error for points whose `axis` coordinates (a letter, e.g. "y") round together where
/// they reach `at`: named at `key`, which should be moved nearer 0.
fn coinciding(deck: &Deck, key: &[&str], axis: &str, spacing: f64, at: f64) -> DeckError {
    let precision = at.abs() * f64::EPSILON;
    deck.error_at(
        key,
        format!(
            "at {axis} = {at:e} a double tells values apart only {precision:.1e} or more apart, so points {spacing:.3e} apart get {axis} coordinates that round to the same or unevenly spaced values: the points coincide; move this key nearer 0 (the body's place does not change its behaviour)"
        ),
    )
}

/// `TensorProduct3DMeshGenerator`: along each axis the origin and length within the bound,
/// the spacing `length / points` above [`SMALLEST_LENGTH`], and the cell centres apart.
pub(super) fn check_box(
    deck: &Deck,
    origin: &[f64; 3],
    length: &[f64; 3],
    number_of_points: &[u64; 3],
) -> Result<(), DeckError> {
    const LIST: &str = "TensorProduct3DMeshGenerator";
    for k in 0..3 {
        let origin_key = format!("{} Origin", AXES[k]);
        let length_key = format!("{} Length", AXES[k]);
        let points_key = format!("Number Points {}", AXES[k]);
        let origin_path = ["Discretization", LIST, origin_key.as_str()];
        let length_path = ["Discretization", LIST, length_key.as_str()];
        let spacing = length[k] / number_of_points[k] as f64;
        let end = origin[k] + length[k];
        let far = origin[k].abs().max(end.abs());
        if far.is_finite() && number_of_points[k] > 1 && !distinguishable(spacing, far) {
            let at_fault = if origin[k].abs() >= length[k] {
                origin_path
            } else {
                ["Discretization", LIST, points_key.as_str()]
            };
            let axis = AXES[k].to_lowercase();
            let at = if origin[k].abs() >= end.abs() {
                origin[k]
            } else {
                end
            };
            return Err(coinciding(deck, &at_fault, &axis, spacing, at));
        }
        length_in_range(deck, &origin_path, "the origin", origin[k])?;
        length_in_range(deck, &length_path, "the length", length[k])?;
        spacing_in_range(
            deck,
            &length_path,
            &format!("{length_key} / {points_key}"),
            spacing,
        )?;
    }
    Ok(())
}

/// `TensorProductCylinderMeshGenerator`: the radii, length, ring centre and z origin within
/// the bound, the radial and axial spacings above [`SMALLEST_LENGTH`], and the points apart.
pub(super) fn check_cylinder(deck: &Deck, grid: &CylinderGrid) -> Result<(), DeckError> {
    let key = |name: &'static str| ["Discretization", "TensorProductCylinderMeshGenerator", name];
    length_in_range(deck, &key("Outer Radius"), "the radius", grid.outer_radius)?;
    length_in_range(deck, &key("Cylinder Length"), "the length", grid.length)?;
    length_in_range(deck, &key("Z Origin"), "the origin", grid.z_origin)?;
    let radial = grid.radial_spacing();
    let axial = grid.length / grid.axial_cells() as f64;
    spacing_in_range(
        deck,
        &key("Number Points Radius"),
        "the radii and Number Points Radius",
        radial,
    )?;
    spacing_in_range(deck, &key("Cylinder Length"), "the length", axial)?;
    for (k, name) in [(0, "Ring Center x"), (1, "Ring Center y")] {
        length_in_range(deck, &key(name), "the centre", grid.center[k])?;
        let far = grid.center[k].abs() + grid.outer_radius;
        if !distinguishable(radial, far) {
            let at = grid.center[k];
            return Err(coinciding(deck, &key(name), ["x", "y"][k], radial, at));
        }
    }
    let end = grid.z_origin + grid.length;
    if !distinguishable(axial, grid.z_origin.abs().max(end.abs())) {
        let at = if grid.z_origin.abs() >= end.abs() {
            grid.z_origin
        } else {
            end
        };
        return Err(coinciding(deck, &key("Z Origin"), "z", axial, at));
    }
    Ok(())
}

/// A mesh's points (`Text File`, `Exodus`): every coordinate within the bound and every
/// volume within its cubes, named by the point's number in the mesh (1-based).
pub(super) fn check_mesh_points(deck: &Deck, points: &PointCloud) -> Result<(), DeckError> {
    let key = ["Discretization", "Input Mesh File"];
    let least_volume = SMALLEST_LENGTH.powi(3);
    let most_volume = LARGEST_LENGTH.powi(3);
    for (i, (x, &volume)) in points.position.iter().zip(&points.volume).enumerate() {
        let number = points.original_id[i] + 1;
        if let Some(c) = x.iter().find(|c| c.abs() > LARGEST_LENGTH) {
            return Err(deck.error_at(
                &key,
                format!(
                    "point {number} has the coordinate {c:e}, beyond the lengths peridyn computes with (at most {LARGEST_LENGTH:e} in the deck's units): products such as bond length⁴ would overflow a double; give the mesh in metres or millimetres"
                ),
            ));
        }
        if !(least_volume..=most_volume).contains(&volume) {
            return Err(deck.error_at(
                &key,
                format!(
                    "point {number} has the volume {volume:e}, outside the volumes peridyn computes with ({least_volume:e} to {most_volume:e} in the deck's units): products such as volume × density would overflow or underflow a double; give the mesh in metres or millimetres"
                ),
            ));
        }
    }
    Ok(())
}
