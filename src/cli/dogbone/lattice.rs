//! A cubic lattice over the dog-bone: cells of edge h, each cell that meets the body becomes
//! one point at the centroid of its part inside the body, with that part's volume. The cell
//! volumes so sum to the body's volume, and interior points sit on the lattice.
//!
//! Cells are laid symmetrically about the mid-planes. Along y, z and the gauge width, the
//! number of cells is ⌈extent / h⌉, which leaves the outer cells at least half inside; across
//! the wider grips the cell count keeps the parity of the gauge's so the columns line up.

use super::geometry::DogBone;

/// One point of the discretization.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LatticePoint {
    /// Position (centroid of the cell's part inside the body).
    pub position: [f64; 3],
    /// Volume of that part.
    pub volume: f64,
    /// Cell index along x, y, z.
    pub cell: [usize; 3],
}

/// Cell faces along one axis: `cells` cells of edge `h`, symmetric about 0.
fn faces(cells: usize, h: f64) -> Vec<f64> {
    (0..=cells)
        .map(|k| (k as f64 - cells as f64 / 2.0) * h)
        .collect()
}

/// ⌈extent / h⌉ (at least 1), with a small allowance for round-off.
fn cells_across(extent: f64, h: f64) -> usize {
    ((extent / h - 1e-9).ceil() as usize).max(1)
}

/// The cell faces along x, y and z for spacing `h`.
fn lattice_faces(bone: &DogBone, h: f64) -> [Vec<f64>; 3] {
    let gauge = cells_across(bone.gauge_width, h);
    let mut across = cells_across(bone.grip_width, h);
    if across % 2 != gauge % 2 {
        across += 1;
    }
    [
        faces(across, h),
        faces(cells_across(bone.length, h), h),
        faces(cells_across(bone.thickness, h), h),
    ]
}

/// Cells whose clipped area is below this fraction of h² are round-off, not body.
const MIN_AREA_FRACTION: f64 = 1e-9;

/// The in-plane cells (x index, y index) that meet the body, for the faces of `h`.
fn plane_cells(bone: &DogBone, h: f64, faces: &[Vec<f64>; 3]) -> Vec<(usize, usize)> {
    let mut cells = Vec::new();
    for j in 0..faces[1].len() - 1 {
        let (y0, y1) = (faces[1][j], faces[1][j + 1]);
        // The half-width grows with |y|: its largest value in the row is at the far face.
        let widest = bone.half_width(y0.abs().max(y1.abs()).min(bone.length / 2.0));
        for i in 0..faces[0].len() - 1 {
            let (x0, x1) = (faces[0][i], faces[0][i + 1]);
            if x1 > -widest && x0 < widest {
                let clipped = bone.clip([x0, x1], [y0, y1]);
                if clipped.area > MIN_AREA_FRACTION * h * h {
                    cells.push((i, j));
                }
            }
        }
    }
    cells
}

/// Number of points the lattice of spacing `h` gives.
pub fn point_count(bone: &DogBone, h: f64) -> usize {
    let faces = lattice_faces(bone, h);
    plane_cells(bone, h, &faces).len() * (faces[2].len() - 1)
}

/// The spacing whose lattice has the point count nearest `target`: bisection on h between
/// 0.6 and 1.6 times (V / target)^⅓. Where the number of layers through the thickness jumps,
/// the nearest reachable count is taken.
pub fn spacing_for(bone: &DogBone, target: usize) -> f64 {
    let estimate = (bone.volume() / target as f64).cbrt();
    let (mut fine, mut coarse) = (0.6 * estimate, 1.6 * estimate);
    for _ in 0..60 {
        let middle = 0.5 * (fine + coarse);
        if point_count(bone, middle) > target {
            fine = middle;
        } else {
            coarse = middle;
        }
    }
    let miss = |h: f64| point_count(bone, h).abs_diff(target);
    if miss(fine) < miss(coarse) {
        fine
    } else {
        coarse
    }
}

/// The points of the lattice of spacing `h`, ordered by y row, then x column, then z layer.
pub fn points(bone: &DogBone, h: f64) -> Vec<LatticePoint> {
    let faces = lattice_faces(bone, h);
    let half_thickness = bone.thickness / 2.0;
    let layers: Vec<(f64, f64)> = faces[2]
        .windows(2)
        .map(|f| {
            let (low, high) = (f[0].max(-half_thickness), f[1].min(half_thickness));
            (high - low, 0.5 * (low + high))
        })
        .collect();
    let mut points = Vec::new();
    for (i, j) in plane_cells(bone, h, &faces) {
        let clipped = bone.clip(
            [faces[0][i], faces[0][i + 1]],
            [faces[1][j], faces[1][j + 1]],
        );
        for (k, &(depth, z)) in layers.iter().enumerate() {
            points.push(LatticePoint {
                position: [clipped.x, clipped.y, z],
                volume: clipped.area * depth,
                cell: [i, j, k],
            });
        }
    }
    points
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn outer_cells_are_at_least_half_inside() {
        for h in [0.05, 0.0787, 0.0926, 0.11] {
            let [_, y, z] = lattice_faces(&DogBone::ROADMAP, h);
            let outer_y = (DogBone::ROADMAP.length / 2.0 - y[y.len() - 2]) / h;
            let outer_z = (DogBone::ROADMAP.thickness / 2.0 - z[z.len() - 2]) / h;
            assert!(
                outer_y > 0.5 - 1e-9 && outer_y <= 1.0 + 1e-9,
                "{h}: {outer_y}"
            );
            assert!(
                outer_z > 0.5 - 1e-9 && outer_z <= 1.0 + 1e-9,
                "{h}: {outer_z}"
            );
        }
    }

    #[test]
    fn volumes_sum_to_the_body_and_points_lie_inside() {
        let bone = DogBone::ROADMAP;
        let h = spacing_for(&bone, 3000);
        let points = points(&bone, h);
        assert_eq!(points.len(), point_count(&bone, h));
        let total: f64 = points.iter().map(|p| p.volume).sum();
        assert!((total / bone.volume() - 1.0).abs() < 1e-4, "{total}");
        for p in &points {
            assert!(p.volume > 0.0 && p.volume <= h * h * h * (1.0 + 1e-12));
            let [x, y, z] = p.position;
            assert!(x.abs() <= bone.half_width(y) + 1e-12 && z.abs() <= bone.thickness / 2.0);
        }
    }
}
