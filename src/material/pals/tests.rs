//! Checks of `Pals`: the Lagrange-multiplier constraints on a surface point, Hooke's stress at
//! an interior point, rigid motion, momentum, the force as the gradient of the stored energy,
//! and the tangent against finite differences, with and without broken bonds.

use std::sync::Arc;

use super::*;
use crate::history::History;
use crate::material::LinearPeridynamicSolid;
use crate::model::test_support::{brute_force_bonds, lattice, Rng};
use crate::model::PointCloud;
use crate::physics::{BlockPhysics, Configuration, Physics};
use crate::tangent::BlockPattern;

const BULK: f64 = 3.0;
const SHEAR: f64 = 1.2;

/// `Pals` with ρ = 2, K = BULK, μ = SHEAR, horizon `horizon` and `influence` (both `One`
/// when `None`).
fn pals(horizon: f64, influence: Option<PalsInfluence>) -> Pals {
    let block = BlockInput {
        density: 2.0,
        horizon,
        influence: InfluenceFunction::One,
    };
    let parameters = PalsParameters {
        elastic: ElasticConstants {
            bulk_modulus: BULK,
            shear_modulus: SHEAR,
        },
        influence: influence.unwrap_or_default(),
    };
    Pals::new(&block, &parameters).unwrap()
}

/// A body of one `Pals` block.
struct Body {
    points: PointCloud,
    bonds: BondList,
    material: Pals,
    physics: Physics,
    damage: Option<Vec<f32>>,
}

impl Body {
    /// The n³ lattice of spacing 1; unit volumes when `seed` is `None`, else volumes in 0.8–1.2.
    fn new(n: usize, horizon: f64, seed: Option<u64>, influence: Option<PalsInfluence>) -> Self {
        let x = lattice(n);
        let mut rng = seed.map(Rng::new);
        let mut points = PointCloud::default();
        for p in &x {
            let volume = rng.as_mut().map_or(1.0, |r| 0.8 + 0.4 * r.uniform());
            points.push(*p, volume, 0);
        }
        let bonds = brute_force_bonds(&x, horizon);
        let mut material = pals(horizon, influence);
        crate::material::set_up(
            &mut material,
            &ReferenceView::of(&bonds, &points),
            (0..x.len() as u32).collect(),
        );
        let physics = Physics::new(
            vec![BlockPhysics {
                material: Box::new(material.clone()),
                damage: None,
            }],
            &points,
            &bonds,
        );
        Self {
            points,
            bonds,
            material,
            physics,
            damage: None,
        }
    }

    /// Breaks about a fifth of the pairs (both directions).
    fn break_some_bonds(&mut self, seed: u64) {
        let mut rng = Rng::new(seed);
        let bonds = &self.bonds;
        let mut damage = vec![0.0f32; bonds.num_bonds()];
        for i in 0..bonds.num_points() {
            for b in bonds.range(i) {
                let j = bonds.neighbor[b] as usize;
                if j > i && rng.uniform() < 0.2 {
                    let back =
                        bonds.offsets[j] + bonds.family(j).binary_search(&(i as u32)).unwrap();
                    damage[b] = 1.0;
                    damage[back] = 1.0;
                }
            }
        }
        self.damage = Some(damage);
    }

    fn force(&mut self, y: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let mut f = vec![[0.0; 3]; y.len()];
        self.physics.internal_force_with_damage_fixed(
            &self.bonds,
            &self.points,
            y,
            self.damage.as_deref(),
            &mut History::empty(),
            &mut f,
        );
        f
    }

    /// Σ_i W_i V_i at `y`.
    fn energy(&mut self, y: &[[f64; 3]]) -> f64 {
        self.force(y);
        let mut w = vec![0.0; y.len()];
        self.physics.stored_energy_density(
            &self.bonds,
            &self.points,
            y,
            self.damage.as_deref(),
            &History::empty(),
            &mut w,
        );
        w.iter().zip(&self.points.volume).map(|(w, v)| w * v).sum()
    }

    /// The vector force states T⟨ξ⟩ of point `p`'s bonds at `y` (the code the tangent
    /// differentiates).
    fn force_states(&self, p: usize, y: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let reference = ReferenceView::of(&self.bonds, &self.points);
        let kernel = PalsForceState {
            kernel: self.material.kernel(&reference, self.damage.as_deref()),
        };
        let mut family = Vec::new();
        family_positions(&self.bonds, y, p, &mut family);
        let mut t = vec![[0.0; 3]; self.bonds.family_size(p)];
        let point = PointIndex {
            global: p,
            local: p,
        };
        kernel.force_state(point, &family, None, &mut t);
        t
    }

    /// θ of point `p` at `y`.
    fn dilatation(&self, p: usize, y: &[[f64; 3]]) -> f64 {
        let reference = ReferenceView::of(&self.bonds, &self.points);
        let kernel = self.material.kernel(&reference, self.damage.as_deref());
        let mut family = Vec::new();
        family_positions(&self.bonds, y, p, &mut family);
        let point = PointIndex {
            global: p,
            local: p,
        };
        kernel.state(point, &family).dilatation
    }

    /// Y = X + ε X (a small homogeneous strain about the origin).
    fn strained(&self, strain: [[f64; 3]; 3]) -> Vec<[f64; 3]> {
        self.points
            .position
            .iter()
            .map(|x| [0, 1, 2].map(|k| x[k] + (0..3).map(|l| strain[k][l] * x[l]).sum::<f64>()))
            .collect()
    }
}

fn magnitude(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

fn perturbed(body: &Body, seed: u64, amplitude: f64) -> Vec<[f64; 3]> {
    let mut rng = Rng::new(seed);
    body.points
        .position
        .iter()
        .map(|x| x.map(|c| c * 1.002 + amplitude * (rng.uniform() - 0.5)))
        .collect()
}

/// A general small strain (every component non-zero, trace 1.1e-6).
const STRAIN: [[f64; 3]; 3] = [
    [1.0e-6, 0.3e-6, -0.2e-6],
    [0.3e-6, -0.4e-6, 0.5e-6],
    [-0.2e-6, 0.5e-6, 0.5e-6],
];

#[test]
fn the_constraints_hold_to_round_off_at_a_corner_where_the_lps_dilatation_is_wrong() {
    // A corner of the 9³ lattice with δ = 3: its family is one octant of the sphere.
    let influence = PalsInfluence {
        dilatation: InfluenceFunction::Gaussian,
        deviatoric: InfluenceFunction::ParabolicDecay,
    };
    let body = Body::new(9, 3.0, Some(7), Some(influence));
    let corner = 0;
    let bonds = &body.bonds;
    let x = body.points.position[corner];
    let mut dilatation = [0.0; MULTIPLIERS];
    let mut deviatoric = [0.0; MULTIPLIERS];
    let mut scale = [0.0f64; 2];
    for (n, b) in bonds.range(corner).enumerate() {
        let j = bonds.neighbor[b] as usize;
        let xi = [0, 1, 2].map(|k| body.points.position[j][k] - x[k]);
        let v = body.points.volume[j];
        let (g, q) = (dilatation_modes(xi), deviatoric_modes(xi));
        for k in 0..MULTIPLIERS {
            dilatation[k] += body.material.omega[n] * g[k] * v;
            deviatoric[k] += body.material.sigma[n] * q[k] * v;
            scale[0] = scale[0].max((body.material.omega[n] * g[k] * v).abs());
            scale[1] = scale[1].max((body.material.sigma[n] * q[k] * v).abs());
        }
    }
    // Σ ω ξ⊗ξ V = I and Σ σ s_k² V = ε⁽ᵏ⁾_dev : ε⁽ᵏ⁾_dev (module docs; Mitchell, Silling,
    // Littlewood 2015), to round-off of sums of ~40 terms. For a unit stretch along x,
    // ε_dev = diag(2/3, −1/3, −1/3) and ε_dev : ε_dev = 4/9 + 1/9 + 1/9 = 2/3; for a unit
    // engineering shear e_x⊗e_y + e_y⊗e_x, ε_dev = ε and ε : ε = 1 + 1 = 2.
    let identity = [1.0, 1.0, 1.0, 0.0, 0.0, 0.0];
    let deviatoric_norms = [2.0 / 3.0, 2.0 / 3.0, 2.0 / 3.0, 2.0, 2.0, 2.0];
    for k in 0..MULTIPLIERS {
        assert!(
            (dilatation[k] - identity[k]).abs() < 1e-13 * scale[0],
            "dilatation mode {k}: {}",
            dilatation[k]
        );
        assert!(
            (deviatoric[k] - deviatoric_norms[k]).abs() < 1e-13 * scale[1],
            "deviatoric mode {k}: {}",
            deviatoric[k]
        );
    }
    // Hence the dilatation of a small homogeneous strain is its trace (to O(ε²)) even here.
    let y = body.strained(STRAIN);
    let trace = STRAIN[0][0] + STRAIN[1][1] + STRAIN[2][2];
    let theta = body.dilatation(corner, &y);
    assert!((theta / trace - 1.0).abs() < 1e-5, "{theta} vs {trace}");
    // The LPS at the same corner (θ = (3/m) Σ ζ e V) sees the shears of the octant as volume
    // change: its dilatation is off by far more.
    let mut lps = LinearPeridynamicSolid::new(
        &crate::material::BlockInput {
            density: 2.0,
            horizon: 3.0,
            influence: InfluenceFunction::Gaussian,
        },
        &crate::material::ElasticConstants {
            bulk_modulus: BULK,
            shear_modulus: SHEAR,
        },
    )
    .unwrap();
    let reference = ReferenceView::of(&body.bonds, &body.points);
    crate::material::set_up(
        &mut lps,
        &reference,
        (0..body.points.len() as u32).collect(),
    );
    let mut coefficients = vec![PointCoefficients::default(); y.len()];
    let current = CurrentView {
        position: &y,
        bond_damage: None,
        history: &crate::history::NO_HISTORY,
    };
    lps.compute_point_coefficients(&reference, &current, &mut coefficients);
    let lps_theta = coefficients[corner].dilatation;
    assert!(
        (lps_theta / trace - 1.0).abs() > 0.1,
        "LPS {lps_theta} vs {trace}"
    );
}

#[test]
fn an_interior_point_carries_hookes_stress_under_homogeneous_strain() {
    // The centre of the 9³ lattice (unit volumes) with δ = 3: its family is a whole ball with
    // the lattice's cubic symmetry. The partial stress Σ_j T⟨ξ⟩ ⊗ ξ V_j of a homogeneous small
    // strain ε is then Hooke's K tr ε I + 2μ ε_dev, the continuum stress of the LPS (Silling
    // et al. 2007, §15), here exactly to O(ε²) for the discrete family: the dilatation
    // constraint gives Σ p ω ξ⊗ξ V = p I; cubic symmetry leaves the moment
    // S_abcd = Σ σ ξ_a ξ_b ξ_c ξ_d/ζ² V two constants A = S_xxxx, B = S_xxyy, which the
    // deviatoric constraints fix to A − B = 1 (axial modes) and 4B = 2 (shear modes), so
    // S = ½(δ_ab δ_cd + δ_ac δ_bd + δ_ad δ_bc); then Σ σ e^d ξ⊗ξ/ζ V = S : ε_dev = ε_dev, and
    // m = 15/2, Σ σ ζ e V = (5/2) tr ε give p = K tr ε.
    let body = Body::new(9, 3.0, None, None);
    let center = 4 * (81 + 9 + 1);
    let y = body.strained(STRAIN);
    let t = body.force_states(center, &y);
    let bonds = &body.bonds;
    let mut stress = [[0.0; 3]; 3];
    for (n, b) in bonds.range(center).enumerate() {
        let j = bonds.neighbor[b] as usize;
        let xi = [0, 1, 2].map(|k| body.points.position[j][k] - body.points.position[center][k]);
        for k in 0..3 {
            for l in 0..3 {
                stress[k][l] += t[n][k] * xi[l] * body.points.volume[j];
            }
        }
    }
    let trace = STRAIN[0][0] + STRAIN[1][1] + STRAIN[2][2];
    let mut largest = 0.0f64;
    let mut worst = 0.0f64;
    for k in 0..3 {
        for l in 0..3 {
            let identity = if k == l { 1.0 } else { 0.0 };
            let deviatoric = STRAIN[k][l] - identity * trace / 3.0;
            let hooke = BULK * trace * identity + 2.0 * SHEAR * deviatoric;
            largest = largest.max(hooke.abs());
            worst = worst.max((stress[k][l] - hooke).abs());
        }
    }
    // O(ε) = 1e-6 relative from the geometric non-linearity of |Y| − ζ.
    assert!(worst < 1e-5 * largest, "{stress:?}");
}

#[test]
fn rigid_motion_gives_no_force() {
    let mut body = Body::new(6, 1.8, Some(3), None);
    let (s, c) = (0.6f64.sin(), 0.6f64.cos());
    let y: Vec<[f64; 3]> = body
        .points
        .position
        .iter()
        .map(|x| {
            [
                c * x[0] - s * x[1] + 3.0,
                s * x[0] + c * x[1] - 1.0,
                x[2] + 0.5,
            ]
        })
        .collect();
    let force = body.force(&y);
    let largest = force.iter().map(|f| magnitude(*f)).fold(0.0, f64::max);
    // The same motion stretched by 0.1 % gives forces of order K·1e-3·(ω ζ² V sums ≈ 1).
    let stretched: Vec<[f64; 3]> = y.iter().map(|p| p.map(|c| 1.001 * c)).collect();
    let loaded = body.force(&stretched);
    let reference = loaded.iter().map(|f| magnitude(*f)).fold(0.0, f64::max);
    assert!(reference > 1e-4, "{reference}");
    // Round-off of |Y| − ζ (≈1e-15 per bond) times the moduli over a family.
    assert!(largest < 1e-11, "{largest}");
}

#[test]
fn the_forces_conserve_linear_and_angular_momentum() {
    for damaged in [false, true] {
        let mut body = Body::new(6, 1.8, Some(8), None);
        if damaged {
            body.break_some_bonds(4);
        }
        let y = perturbed(&body, 2, 0.05);
        let force = body.force(&y);
        let mut linear = [0.0; 3];
        let mut angular = [0.0; 3];
        let mut scale = 0.0;
        for (i, f) in force.iter().enumerate() {
            let v = body.points.volume[i];
            let p = y[i];
            for k in 0..3 {
                linear[k] += v * f[k];
            }
            angular[0] += v * (p[1] * f[2] - p[2] * f[1]);
            angular[1] += v * (p[2] * f[0] - p[0] * f[2]);
            angular[2] += v * (p[0] * f[1] - p[1] * f[0]);
            scale += v * magnitude(*f) * (1.0 + magnitude(p));
        }
        assert!(scale > 0.0);
        assert!(magnitude(linear) < 1e-13 * scale, "{linear:?}");
        assert!(magnitude(angular) < 1e-13 * scale, "{angular:?}");
    }
}

#[test]
fn the_force_is_the_gradient_of_the_stored_energy() {
    // F_i V_i = −∂(Σ_k W_k V_k)/∂y_i (module docs): checks the gather of both ends' force
    // states and the energy together, with and without broken bonds.
    for damaged in [false, true] {
        let mut body = Body::new(5, 1.8, Some(12), None);
        if damaged {
            body.break_some_bonds(6);
        }
        let y = perturbed(&body, 5, 0.05);
        let force = body.force(&y);
        let h = 1e-6;
        let mut largest = 0.0f64;
        let mut worst = 0.0f64;
        for i in [0usize, 31, 62, 124] {
            for k in 0..3 {
                let mut plus = y.clone();
                plus[i][k] += h;
                let mut minus = y.clone();
                minus[i][k] -= h;
                let gradient = (body.energy(&plus) - body.energy(&minus)) / (2.0 * h);
                let expected = -gradient;
                let got = force[i][k] * body.points.volume[i];
                largest = largest.max(expected.abs());
                worst = worst.max((got - expected).abs());
            }
        }
        assert!(largest > 0.0);
        assert!(worst < 1e-6 * largest, "{worst} of {largest}");
    }
}

/// max |J_AD − J_FD| / max |J_FD| over a few columns, the FD tangent from central differences
/// of the force itself.
fn tangent_error(body: &mut Body, y: &[[f64; 3]]) -> f64 {
    let pattern = Arc::new(BlockPattern::two_hop(&body.bonds));
    let mut tangent = BlockTangent::zeros(pattern);
    body.physics
        .tangent_with(
            &body.bonds,
            &body.points,
            Configuration {
                position: y,
                bond_damage: body.damage.as_deref(),
                history: &History::empty(),
            },
            TangentMethod::AutomaticDifferentiation,
            &mut tangent,
        )
        .unwrap();
    let h = 1e-7;
    let mut largest = 0.0f64;
    let mut worst = 0.0f64;
    for j in [0usize, 43, 100, 129, 215] {
        for l in 0..3 {
            let mut plus = y.to_vec();
            plus[j][l] += h;
            let mut minus = y.to_vec();
            minus[j][l] -= h;
            let (fp, fm) = (body.force(&plus), body.force(&minus));
            for i in 0..y.len() {
                for k in 0..3 {
                    let fd = body.points.volume[i] * (fp[i][k] - fm[i][k]) / (2.0 * h);
                    let ad = tangent.block(i, j).map_or(0.0, |b| b[k][l]);
                    largest = largest.max(fd.abs());
                    worst = worst.max((ad - fd).abs());
                }
            }
        }
    }
    assert!(largest > 0.0);
    worst / largest
}

#[test]
fn the_automatic_differentiation_tangent_matches_finite_differences() {
    let mut body = Body::new(6, 1.8, Some(11), None);
    let y = perturbed(&body, 9, 0.05);
    let error = tangent_error(&mut body, &y);
    assert!(error < 1e-6, "relative error {error}");
}

#[test]
fn the_tangent_matches_finite_differences_with_broken_bonds() {
    let influence = PalsInfluence {
        dilatation: InfluenceFunction::ParabolicDecay,
        deviatoric: InfluenceFunction::Gaussian,
    };
    let mut body = Body::new(6, 1.8, Some(11), Some(influence));
    body.break_some_bonds(4);
    let y = perturbed(&body, 9, 0.05);
    let error = tangent_error(&mut body, &y);
    assert!(error < 1e-6, "relative error {error}");
}

#[test]
fn a_bond_to_another_block_and_a_singular_family_are_errors() {
    // Three points in a plane, all bonded: point 0 sees (1, 1, 0) and (1, 2, 0), which span
    // the a², b², 2ab modes with two bonds only (c is degenerate and dropped).
    let x = vec![[0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [1.0, 2.0, 0.0]];
    let mut points = PointCloud::default();
    for p in &x {
        points.push(*p, 1.0, 0);
    }
    let bonds = brute_force_bonds(&x, 3.0);
    let reference = ReferenceView::of(&bonds, &points);
    let mut material = pals(3.0, None);
    let error = (&mut material as &mut dyn Material)
        .setup(&reference, vec![0, 1, 2])
        .unwrap_err();
    assert_eq!(
        error,
        MaterialError::SingularInfluenceSystem {
            model: "Pals",
            point: 0,
            bonds: 2,
        }
    );
    assert!(error.to_string().contains("enlarge the horizon"), "{error}");
    let error = (&mut material as &mut dyn Material)
        .setup(&reference, vec![0, 1])
        .unwrap_err();
    assert!(
        matches!(error, MaterialError::BondLeavesBlock { model: "Pals", .. }),
        "{error:?}"
    );
}

#[test]
fn a_one_layer_mesh_drops_the_modes_it_does_not_span() {
    // A single layer z = 0: every bond has c = 0, so the multipliers of c², 2ac, 2bc are zero
    // and the in-plane constraints still hold.
    let mut x = Vec::new();
    for j in 0..7 {
        for i in 0..7 {
            x.push([i as f64, j as f64, 0.0]);
        }
    }
    let mut points = PointCloud::default();
    for p in &x {
        points.push(*p, 1.0, 0);
    }
    let bonds = brute_force_bonds(&x, 2.5);
    let reference = ReferenceView::of(&bonds, &points);
    let mut material = pals(2.5, None);
    crate::material::set_up(&mut material, &reference, (0..x.len() as u32).collect());
    for (i, m) in material.multipliers().iter().enumerate() {
        for k in [2, 4, 5] {
            assert_eq!(m.dilatation[k], 0.0);
            assert_eq!(m.deviatoric[k], 0.0);
        }
        let mut sum = [0.0; 3];
        let base = material.local_offsets[i];
        for (n, b) in bonds.range(i).enumerate() {
            let j = bonds.neighbor[b] as usize;
            let g = dilatation_modes([0, 1, 2].map(|k| x[j][k] - x[i][k]));
            for (s, k) in sum.iter_mut().zip([0, 1, 3]) {
                *s += material.omega[base + n] * g[k];
            }
        }
        // Σ ω a² = Σ ω b² = 1, Σ ω 2ab = 0 (unit volumes).
        for (s, target) in sum.iter().zip([1.0, 1.0, 0.0]) {
            assert!((s - target).abs() < 1e-12, "point {i}: {sum:?}");
        }
    }
}
