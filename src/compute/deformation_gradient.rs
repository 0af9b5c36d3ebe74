//! The deformation gradient of every point, as correspondence models define it.

use crate::model::{BondList, BondVolumes};
use rayon::prelude::*;

type Mat3 = [[f64; 3]; 3];

fn inverse(k: &Mat3) -> Option<Mat3> {
    let det = k[0][0] * (k[1][1] * k[2][2] - k[1][2] * k[2][1])
        - k[0][1] * (k[1][0] * k[2][2] - k[1][2] * k[2][0])
        + k[0][2] * (k[1][0] * k[2][1] - k[1][1] * k[2][0]);
    let scale = k.iter().flatten().map(|v| v.abs()).fold(0.0, f64::max);
    if det.is_nan() || det.abs() <= 1e-12 * scale.powi(3) {
        return None;
    }
    let c = |r: usize, s: usize| {
        k[(r + 1) % 3][(s + 1) % 3] * k[(r + 2) % 3][(s + 2) % 3]
            - k[(r + 1) % 3][(s + 2) % 3] * k[(r + 2) % 3][(s + 1) % 3]
    };
    let mut inv = [[0.0; 3]; 3];
    for (r, row) in inv.iter_mut().enumerate() {
        for (s, value) in row.iter_mut().enumerate() {
            // inverse = adjugate / det; adjugate[r][s] = cofactor[s][r]
            *value = c(s, r) / det;
        }
    }
    Some(inv)
}

/// Peridigm's `Deformation_Gradient` compute class for any material: with the shape tensor
/// `K = Σ_j (1−d) w_ij ξ⊗ξ` and `N = Σ_j (1−d) w_ij (Y_j − Y_i)⊗ξ` over the family (ω = 1,
/// w_ij the bond's quadrature volume, V_j under the default full-volume rule),
/// `F = N K⁻¹`, row-major. F is exact for every homogeneous deformation Y = F₀X + c whatever
/// the weights. A point whose intact bonds do not span three dimensions has no F: its entries
/// are NaN (Peridigm aborts the run instead).
pub fn deformation_gradient(
    bonds: &BondList,
    reference: &[[f64; 3]],
    current: &[[f64; 3]],
    volume: BondVolumes<'_>,
    bond_damage: Option<&[f32]>,
) -> Vec<[f64; 9]> {
    (0..reference.len())
        .into_par_iter()
        .map(|i| {
            let family = Family {
                bonds,
                reference,
                volume,
                bond_damage,
            };
            let Some(k_inv) = inverse(&family.shape_tensor(i)) else {
                return [f64::NAN; 9];
            };
            let mut n = [[0.0; 3]; 3];
            for b in bonds.range(i) {
                let j = bonds.neighbor[b] as usize;
                let weight = family.weight(b);
                let xi = [0, 1, 2].map(|a| reference[j][a] - reference[i][a]);
                let eta = [0, 1, 2].map(|a| current[j][a] - current[i][a]);
                for r in 0..3 {
                    for s in 0..3 {
                        n[r][s] += weight * eta[r] * xi[s];
                    }
                }
            }
            let mut f = [0.0; 9];
            for r in 0..3 {
                for s in 0..3 {
                    f[3 * r + s] = (0..3).map(|t| n[r][t] * k_inv[t][s]).sum();
                }
            }
            f
        })
        .collect()
}

/// Peridigm's `Shape_Tensor_Inverse` (written by its `Deformation_Gradient` compute class):
/// K⁻¹ of every point with the weights of [`deformation_gradient`], row-major (length⁻⁵);
/// NaN where K is singular.
pub fn shape_tensor_inverse(
    bonds: &BondList,
    reference: &[[f64; 3]],
    volume: BondVolumes<'_>,
    bond_damage: Option<&[f32]>,
) -> Vec<[f64; 9]> {
    let family = Family {
        bonds,
        reference,
        volume,
        bond_damage,
    };
    (0..reference.len())
        .into_par_iter()
        .map(|i| match inverse(&family.shape_tensor(i)) {
            Some(k_inv) => std::array::from_fn(|k| k_inv[k / 3][k % 3]),
            None => [f64::NAN; 9],
        })
        .collect()
}

/// The reference families and the weights (1−d) w_ij of both outputs.
struct Family<'a> {
    bonds: &'a BondList,
    reference: &'a [[f64; 3]],
    volume: BondVolumes<'a>,
    bond_damage: Option<&'a [f32]>,
}

impl Family<'_> {
    /// (1−d) w_ij of bond `b`.
    fn weight(&self, b: usize) -> f64 {
        let j = self.bonds.neighbor[b] as usize;
        self.volume.of(b, j) * (1.0 - self.bond_damage.map_or(0.0, |d| f64::from(d[b])))
    }

    /// K = Σ_j (1−d) V_j ξ⊗ξ of point `i`.
    fn shape_tensor(&self, i: usize) -> Mat3 {
        let mut k = [[0.0; 3]; 3];
        for b in self.bonds.range(i) {
            let j = self.bonds.neighbor[b] as usize;
            let weight = self.weight(b);
            let xi = [0, 1, 2].map(|a| self.reference[j][a] - self.reference[i][a]);
            for r in 0..3 {
                for s in 0..3 {
                    k[r][s] += weight * xi[r] * xi[s];
                }
            }
        }
        k
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lattice() -> (Vec<[f64; 3]>, BondList) {
        let mut points = Vec::new();
        for k in 0..3 {
            for j in 0..3 {
                for i in 0..3 {
                    points.push([i as f64, j as f64, k as f64]);
                }
            }
        }
        let mut bonds = BondList {
            offsets: vec![0],
            ..Default::default()
        };
        for (i, x) in points.iter().enumerate() {
            for (j, y) in points.iter().enumerate() {
                let d2: f64 = (0..3).map(|a| (x[a] - y[a]).powi(2)).sum();
                if i != j && d2 <= 2.0 * 2.0 {
                    bonds.neighbor.push(j as u32);
                    bonds.reference_length.push(d2.sqrt());
                }
            }
            bonds.offsets.push(bonds.neighbor.len());
        }
        (points, bonds)
    }

    #[test]
    fn homogeneous_deformations_are_recovered_exactly() {
        let (x, bonds) = lattice();
        let volume = vec![1.0; x.len()];
        // Simple shear plus stretch plus rotation about z by 30°: F0 = R·[[1.1, 0.3, 0], [0, 0.9, 0], [0, 0.2, 1.05]].
        let (c, s) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
        let r = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]];
        let u = [[1.1, 0.3, 0.0], [0.0, 0.9, 0.0], [0.0, 0.2, 1.05]];
        let mut f0 = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                f0[i][j] = (0..3).map(|k| r[i][k] * u[k][j]).sum();
            }
        }
        let y: Vec<[f64; 3]> = x
            .iter()
            .map(|p| [0, 1, 2].map(|i| (0..3).map(|j| f0[i][j] * p[j]).sum::<f64>() + 7.0))
            .collect();
        let f = deformation_gradient(&bonds, &x, &y, BondVolumes::new(&volume, None), None);
        for point in &f {
            for i in 0..3 {
                for j in 0..3 {
                    assert!((point[3 * i + j] - f0[i][j]).abs() < 1e-13, "{point:?}");
                }
            }
        }
    }

    #[test]
    fn the_shape_tensor_inverse_inverts_the_weighted_second_moment_of_the_bonds() {
        let (x, bonds) = lattice();
        let volume = vec![2.0; x.len()];
        let inverses = shape_tensor_inverse(&bonds, &x, BondVolumes::new(&volume, None), None);
        // The centre of the 3×3×3 lattice (index 13) has every neighbour within 2 spacings
        // (all 26 others): its K = Σ V ξ⊗ξ is diagonal with Σ_ξ ξ_x² = 18 lattice units per
        // axis (9 neighbours at ξ_x = ±1 each, so 2·9·1), times V = 2: K = 36 I, K⁻¹ = I/36.
        let centre = &inverses[13];
        for r in 0..3 {
            for s in 0..3 {
                let expected = if r == s { 1.0 / 36.0 } else { 0.0 };
                assert!((centre[3 * r + s] - expected).abs() < 1e-15, "{centre:?}");
            }
        }
        // Every point: K⁻¹ K = I with K summed here independently.
        for (i, k_inv) in inverses.iter().enumerate() {
            let k = |t: usize, s: usize| -> f64 {
                bonds
                    .range(i)
                    .map(|b| {
                        let j = bonds.neighbor[b] as usize;
                        2.0 * (x[j][t] - x[i][t]) * (x[j][s] - x[i][s])
                    })
                    .sum()
            };
            for r in 0..3 {
                for s in 0..3 {
                    let product: f64 = (0..3).map(|t| k_inv[3 * r + t] * k(t, s)).sum();
                    let identity = if r == s { 1.0 } else { 0.0 };
                    assert!((product - identity).abs() < 1e-13, "point {i}");
                }
            }
        }
    }

    #[test]
    fn a_point_without_a_three_dimensional_family_has_no_gradient() {
        let x = vec![[0.0; 3], [1.0, 0.0, 0.0]];
        let bonds = BondList {
            offsets: vec![0, 1, 2],
            neighbor: vec![1, 0],
            reference_length: vec![1.0, 1.0],
        };
        let f = deformation_gradient(&bonds, &x, &x, BondVolumes::new(&[1.0, 1.0], None), None);
        assert!(f[0].iter().all(|v| v.is_nan()));
        let k_inv = shape_tensor_inverse(&bonds, &x, BondVolumes::new(&[1.0, 1.0], None), None);
        assert!(k_inv[0].iter().all(|v| v.is_nan()));
    }
}
