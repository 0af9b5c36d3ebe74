//! Peridigm's `PdQuickGrid → TensorProductCylinderMeshGenerator`: a hollow cylinder of
//! cell-centred points in (ring, ray, axial) index space.

use super::tensor_product::cells_per_horizon;
use crate::model::PointCloud;
use std::f64::consts::PI;

/// A hollow cylinder along z, split into `rings` radial cells of equal thickness Δr,
/// `rays` angular cells and `axial_cells` cells along the axis.
///
/// The counts follow Peridigm's generator so that decks give the same points:
/// `rays = floor(2π / (Δr/R̄)) + 1` with R̄ the mean radius (cells roughly square at R̄),
/// `axial_cells = floor(L/Δr) + 1`. Point (ring i, ray j, axial k) sits at radius
/// `r_i = R_in + (i+½)Δr`, angle `θ_j = (j+½)·2π/rays`, height `z_k = z0 + (k+½)Δz`, has
/// volume `r_i Δr Δθ Δz`, and global id `i + j·rings + k·rings·rays`.
///
/// Difference from Peridigm: Peridigm reads `Ring Center x/y` but its generator ignores
/// them (the cylinder is always centred on the z axis); peridyn shifts the points by the centre.
#[derive(Debug, Clone, PartialEq)]
pub struct CylinderGrid {
    /// Inner radius R_in (may be 0 only if `rings` cells still have positive radius).
    pub inner_radius: f64,
    /// Outer radius R_out > R_in.
    pub outer_radius: f64,
    /// Cylinder length L along z.
    pub length: f64,
    /// Number of radial cells (`Number Points Radius`).
    pub rings: usize,
    /// Axis position in the x–y plane (`Ring Center x`, `Ring Center y`).
    pub center: [f64; 2],
    /// Start of the cylinder along z (`Z Origin`).
    pub z_origin: f64,
}

/// A family list in original (generator) ids, CSR form.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct IndexFamilies {
    /// Row starts, one more than the number of points.
    pub offsets: Vec<usize>,
    /// Neighbour ids (generator order).
    pub neighbor: Vec<u32>,
}

impl CylinderGrid {
    /// Radial cell size Δr.
    pub fn radial_spacing(&self) -> f64 {
        (self.outer_radius - self.inner_radius) / self.rings as f64
    }

    /// Number of angular cells (rays).
    pub fn rays(&self) -> usize {
        let mean_radius = 0.5 * (self.inner_radius + self.outer_radius);
        let d_theta = self.radial_spacing() / mean_radius;
        (2.0 * PI / d_theta) as usize + 1
    }

    /// Number of cells along the axis.
    pub fn axial_cells(&self) -> usize {
        (self.length / self.radial_spacing()) as usize + 1
    }

    fn angular_spacing(&self) -> f64 {
        2.0 * PI / self.rays() as f64
    }

    fn axial_spacing(&self) -> f64 {
        self.length / self.axial_cells() as f64
    }

    /// Total number of points.
    pub fn num_points(&self) -> usize {
        self.rings * self.rays() * self.axial_cells()
    }

    fn radius(&self, ring: usize) -> f64 {
        self.inner_radius + (ring as f64 + 0.5) * self.radial_spacing()
    }

    fn position(&self, ring: usize, ray: usize, axial: usize) -> [f64; 3] {
        let r = self.radius(ring);
        let theta = (ray as f64 + 0.5) * self.angular_spacing();
        [
            self.center[0] + r * theta.cos(),
            self.center[1] + r * theta.sin(),
            self.z_origin + (axial as f64 + 0.5) * self.axial_spacing(),
        ]
    }

    /// Generates the points in Peridigm's global-id order, all in block index 0.
    pub fn generate(&self) -> PointCloud {
        let (rings, rays, axial) = (self.rings, self.rays(), self.axial_cells());
        let cell_base = self.radial_spacing() * self.angular_spacing() * self.axial_spacing();
        let mut cloud = PointCloud::default();
        for k in 0..axial {
            for j in 0..rays {
                for i in 0..rings {
                    cloud.push(self.position(i, j, k), self.radius(i) * cell_base, 0);
                }
            }
        }
        cloud
    }

    /// Smallest element radius `(3V/4π)^(1/3)` (innermost ring).
    pub fn element_radius(&self) -> f64 {
        let cell = self.radial_spacing() * self.angular_spacing() * self.axial_spacing();
        (3.0 * self.radius(0) * cell / (4.0 * PI)).cbrt()
    }

    /// Families the way Peridigm's generator builds them, in index space: ±n_r rings
    /// (clipped at the inner and outer surface), ±n_θ rays (wrapping around; n_θ from the
    /// arc length Δθ·R̄ at the mean radius), ±n_z axial cells (clipped), where each n is
    /// [`cells_per_horizon`]. With `spherical`, only neighbours with |ξ|² < δ² are kept
    /// (Peridigm's strict test). Peridigm would list a neighbour twice when 2n_θ+1 exceeds
    /// the number of rays; here the angular window is capped at one full turn instead.
    pub fn families(&self, horizon: f64, spherical: bool) -> IndexFamilies {
        let (rings, rays, axial) = (self.rings, self.rays(), self.axial_cells());
        let mean_radius = 0.5 * (self.inner_radius + self.outer_radius);
        let n_r = cells_per_horizon(horizon, self.radial_spacing(), rings);
        let n_theta = cells_per_horizon(horizon, self.angular_spacing() * mean_radius, rays);
        let n_z = cells_per_horizon(horizon, self.axial_spacing(), axial);
        let angular_window = (2 * n_theta + 1).min(rays);
        let id = |i: usize, j: usize, k: usize| (i + j * rings + k * rings * rays) as u32;
        let clipped = |index: usize, n: usize, count: usize| {
            index.saturating_sub(n)..(index + n + 1).min(count)
        };
        let mut families = IndexFamilies {
            offsets: vec![0],
            neighbor: Vec::new(),
        };
        for k in 0..axial {
            for j in 0..rays {
                for i in 0..rings {
                    let here = self.position(i, j, k);
                    for kk in clipped(k, n_z, axial) {
                        for step in 0..angular_window {
                            let jj = (j + rays - n_theta.min(rays) + step) % rays;
                            for ii in clipped(i, n_r, rings) {
                                if (ii, jj, kk) == (i, j, k) {
                                    continue;
                                }
                                if spherical {
                                    let there = self.position(ii, jj, kk);
                                    let d2: f64 =
                                        (0..3).map(|a| (there[a] - here[a]).powi(2)).sum();
                                    if d2 >= horizon * horizon {
                                        continue;
                                    }
                                }
                                families.neighbor.push(id(ii, jj, kk));
                            }
                        }
                    }
                    families.offsets.push(families.neighbor.len());
                }
            }
        }
        families
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tutorial_cylinder() -> CylinderGrid {
        // Fragmenting-cylinder tutorial geometry: R_in 0.020 m, R_out 0.025 m, L 0.1 m.
        CylinderGrid {
            inner_radius: 0.020,
            outer_radius: 0.025,
            length: 0.1,
            rings: 5,
            center: [0.0, 0.0],
            z_origin: 0.0,
        }
    }

    #[test]
    fn counts_follow_peridigm_rules() {
        let grid = tutorial_cylinder();
        // Δr = 0.001, R̄ = 0.0225 → Δθ = 0.001/0.0225, rays = floor(2π·22.5) + 1 = floor(141.37) + 1 = 142.
        assert_eq!(grid.rays(), 142);
        // axial = floor(L/Δr) + 1. In double precision Δr = (0.025 − 0.020)/5 =
        // 0.0009999999999999998, so L/Δr = 99.99999999999999 → 99 + 1 = 100 (as Peridigm's C++).
        assert_eq!(grid.axial_cells(), 100);
        assert_eq!(grid.num_points(), 5 * 142 * 100);
    }

    #[test]
    fn volumes_sum_to_the_annulus_volume() {
        let grid = tutorial_cylinder();
        let cloud = grid.generate();
        let total: f64 = cloud.volume.iter().sum();
        // Σ r_i Δr Δθ Δz over all cells = π (R_out² − R_in²) L exactly (midpoint rule is exact for r).
        let exact = PI * (0.025f64.powi(2) - 0.020f64.powi(2)) * 0.1;
        assert!((total - exact).abs() < 1e-12 * exact);
    }

    #[test]
    fn points_lie_at_their_ring_radius() {
        let grid = CylinderGrid {
            center: [1.0, -2.0],
            ..tutorial_cylinder()
        };
        let cloud = grid.generate();
        // id 3 = ring 3, ray 0, axial 0 → r = 0.020 + 3.5·0.001
        let p = cloud.position[3];
        let r = ((p[0] - 1.0).powi(2) + (p[1] + 2.0).powi(2)).sqrt();
        assert!((r - 0.0235).abs() < 1e-12);
    }

    #[test]
    fn families_are_symmetric_and_wrap_around() {
        let grid = tutorial_cylinder();
        let families = grid.families(0.00301, true);
        let n = grid.num_points();
        let mut pairs = std::collections::HashSet::new();
        for i in 0..n {
            for &j in &families.neighbor[families.offsets[i]..families.offsets[i + 1]] {
                pairs.insert((i as u32, j));
            }
        }
        assert!(pairs.iter().all(|&(i, j)| pairs.contains(&(j, i))));
        // Ray 0 neighbours the last ray (the ring closes): point (ring 0, ray 0, z 0)
        // must see (ring 0, ray rays−1, z 0), whose id is (rays−1)·rings.
        let last_ray = ((grid.rays() - 1) * grid.rings) as u32;
        assert!(pairs.contains(&(0, last_ray)));
    }
}
