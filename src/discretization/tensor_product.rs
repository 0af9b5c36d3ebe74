//! Peridigm's `PdQuickGrid → TensorProduct3DMeshGenerator`: a box of cell-centred points.

use crate::model::PointCloud;

/// A box split into `points[k]` equal cells along each axis, one point at each cell centre.
///
/// Deck keys (`TensorProduct3DMeshGenerator`): `X/Y/Z Origin`, `X/Y/Z Length`,
/// `Number Points X/Y/Z`. Point `(i, j, k)` sits at `origin + (index + ½)·Δ` with
/// `Δ = length / points`, has volume `Δx·Δy·Δz`, and global id `i + j·nx + k·nx·ny`
/// (x fastest), exactly as Peridigm numbers QuickGrid points.
#[derive(Debug, Clone, PartialEq)]
pub struct TensorProductGrid {
    /// Corner of the box with the smallest coordinates.
    pub origin: [f64; 3],
    /// Edge lengths of the box.
    pub length: [f64; 3],
    /// Number of cells (points) along each axis.
    pub points: [usize; 3],
}

impl TensorProductGrid {
    /// Cell size Δ along each axis.
    pub fn spacing(&self) -> [f64; 3] {
        [0, 1, 2].map(|k| self.length[k] / self.points[k] as f64)
    }

    /// Total number of points.
    pub fn num_points(&self) -> usize {
        self.points.iter().product()
    }

    /// Generates the points in Peridigm's global-id order, all in block index 0.
    pub fn generate(&self) -> PointCloud {
        let spacing = self.spacing();
        let volume = spacing.iter().product();
        let [nx, ny, nz] = self.points;
        let centre =
            |axis: usize, index: usize| self.origin[axis] + (index as f64 + 0.5) * spacing[axis];
        let mut cloud = PointCloud::default();
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    cloud.push([centre(0, i), centre(1, j), centre(2, k)], volume, 0);
                }
            }
        }
        cloud
    }

    /// Peridigm's minimum element radius for QuickGrid boxes: `(3/(4π)·Δx·Δy·Δz)^(1/3)`.
    pub fn element_radius(&self) -> f64 {
        let volume: f64 = self.spacing().iter().product();
        (3.0 * volume / (4.0 * std::f64::consts::PI)).cbrt()
    }
}

/// Peridigm's one-sided QuickGrid neighbourhood size in cells for a horizon δ and cell size Δ:
/// `n = floor(δ/Δ)`, plus one when the fractional part is ≥ ½, capped at the number of cells.
pub fn cells_per_horizon(horizon: f64, cell_size: f64, num_cells: usize) -> usize {
    let ratio = horizon / cell_size;
    // Beyond the usize range `ratio as usize` saturates and the rounding below would overflow.
    if ratio >= num_cells as f64 {
        return num_cells;
    }
    let mut n = ratio as usize;
    if ratio - n as f64 >= 0.5 {
        n += 1;
    }
    n.min(num_cells)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn points_are_cell_centres_in_x_fastest_order() {
        let grid = TensorProductGrid {
            origin: [0.0, -1.0, 2.0],
            length: [3.0, 2.0, 1.0],
            points: [3, 2, 1],
        };
        let cloud = grid.generate();
        assert_eq!(cloud.len(), 6);
        // Δ = (1, 1, 1): first point at origin + Δ/2, second one step along x.
        assert_eq!(cloud.position[0], [0.5, -0.5, 2.5]);
        assert_eq!(cloud.position[1], [1.5, -0.5, 2.5]);
        // id 3 = i 0 + j 1·nx: one step along y.
        assert_eq!(cloud.position[3], [0.5, 0.5, 2.5]);
        assert!(cloud.volume.iter().all(|&v| v == 1.0));
    }

    #[test]
    fn cells_per_horizon_rounds_at_one_half() {
        // δ/Δ = 3.015 → 3; 2.5 → 3 (fraction ≥ ½ rounds up); 2.49 → 2; capped at 4 cells.
        assert_eq!(cells_per_horizon(3.015, 1.0, 100), 3);
        assert_eq!(cells_per_horizon(2.5, 1.0, 100), 3);
        assert_eq!(cells_per_horizon(2.49, 1.0, 100), 2);
        assert_eq!(cells_per_horizon(10.0, 1.0, 4), 4);
        // A horizon of 10¹⁵⁴ cells (a fuzzed deck) saturates `as usize`: still capped.
        assert_eq!(cells_per_horizon(1e154, 1.0, 4), 4);
        assert_eq!(cells_per_horizon(3.75, 1.0, 4), 4);
    }
}
