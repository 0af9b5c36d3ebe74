//! Invariant and hand-computed checks shared by all materials.

use super::*;
use crate::damage::{CriticalStretch, DamageModel};
use crate::model::test_support::{brute_force_bonds, lattice, random_cloud, Rng};

const PI: f64 = std::f64::consts::PI;

fn pmb(bulk: f64, horizon: f64) -> Box<dyn Material> {
    Box::new(
        BondBased::new(
            &crate::material::BlockInput {
                density: 2.0,
                horizon,
                influence: crate::material::InfluenceFunction::One,
            },
            &crate::material::BondBasedParameters {
                bulk_modulus: bulk,
                planar_thickness: None,
            },
        )
        .unwrap(),
    )
}

fn lps(bulk: f64, shear: f64, horizon: f64, influence: InfluenceFunction) -> Box<dyn Material> {
    Box::new(
        LinearPeridynamicSolid::new(
            &crate::material::BlockInput {
                density: 2.0,
                horizon,
                influence,
            },
            &crate::material::ElasticConstants {
                bulk_modulus: bulk,
                shear_modulus: shear,
            },
        )
        .unwrap(),
    )
}

/// One material per kind; the LPS uses a non-trivial ω so the stored-weight path is covered.
fn every_material(horizon: f64) -> Vec<Box<dyn Material>> {
    vec![
        pmb(3.0, horizon),
        lps(3.0, 1.7, horizon, InfluenceFunction::One),
        lps(3.0, 1.7, horizon, InfluenceFunction::ParabolicDecay),
    ]
}

struct Body {
    x: Vec<[f64; 3]>,
    v: Vec<f64>,
    bonds: BondList,
}

impl Body {
    fn new(x: Vec<[f64; 3]>, v: Vec<f64>, horizon: f64) -> Self {
        let bonds = brute_force_bonds(&x, horizon);
        Self { x, v, bonds }
    }

    fn reference(&self) -> ReferenceView<'_> {
        ReferenceView {
            bonds: &self.bonds,
            position: &self.x,
            volume: &self.v,
            bond_volume: None,
        }
    }

    fn all(&self) -> Vec<u32> {
        (0..self.x.len() as u32).collect()
    }
}

/// Force density, published coefficients and energy density of `blocks` (each already set up
/// on its points) at current positions `y`.
fn evaluate(
    body: &Body,
    blocks: &[Box<dyn Material>],
    y: &[[f64; 3]],
    damage: Option<&[f32]>,
) -> (Vec<[f64; 3]>, Vec<PointCoefficients>, Vec<f64>) {
    let n = body.x.len();
    let reference = body.reference();
    let current = CurrentView {
        position: y,
        bond_damage: damage,
        history: &crate::history::NO_HISTORY,
    };
    let mut coefficients = vec![PointCoefficients::default(); n];
    for m in blocks {
        m.compute_point_coefficients(&reference, &current, &mut coefficients);
    }
    let mut force = vec![[0.0; 3]; n];
    let mut energy = vec![f64::NAN; n];
    for m in blocks {
        m.add_force_density(&reference, &current, &coefficients, &mut force);
        m.stored_energy_density(&reference, &current, &coefficients, &mut energy);
    }
    (force, coefficients, energy)
}

fn set_up(body: &Body, mut material: Box<dyn Material>) -> Box<dyn Material> {
    crate::material::set_up(&mut material, &body.reference(), body.all());
    material
}

fn norm(a: [f64; 3]) -> f64 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

fn max_norm(f: &[[f64; 3]]) -> f64 {
    f.iter().map(|&a| norm(a)).fold(0.0, f64::max)
}

fn displaced(rng: &mut Rng, x: &[[f64; 3]], amplitude: f64) -> Vec<[f64; 3]> {
    x.iter()
        .map(|p| {
            [
                p[0] + amplitude * rng.normal(),
                p[1] + amplitude * rng.normal(),
                p[2] + amplitude * rng.normal(),
            ]
        })
        .collect()
}

fn affine(x: &[[f64; 3]], f: [[f64; 3]; 3], shift: [f64; 3]) -> Vec<[f64; 3]> {
    x.iter()
        .map(|p| {
            let mut y = shift;
            for r in 0..3 {
                for c in 0..3 {
                    y[r] += f[r][c] * p[c];
                }
            }
            y
        })
        .collect()
}

/// Rotation by `angle` about the unit axis `a` (Rodrigues).
fn rotation(a: [f64; 3], angle: f64) -> [[f64; 3]; 3] {
    let (s, c) = angle.sin_cos();
    let t = 1.0 - c;
    [
        [
            t * a[0] * a[0] + c,
            t * a[0] * a[1] - s * a[2],
            t * a[0] * a[2] + s * a[1],
        ],
        [
            t * a[0] * a[1] + s * a[2],
            t * a[1] * a[1] + c,
            t * a[1] * a[2] - s * a[0],
        ],
        [
            t * a[0] * a[2] - s * a[1],
            t * a[1] * a[2] + s * a[0],
            t * a[2] * a[2] + c,
        ],
    ]
}

#[test]
fn rigid_motion_gives_zero_force() {
    // Any rigid motion keeps every |Y_j − Y_i| = ζ, so e = 0, θ = 0 and every t = 0; the only
    // force left is round-off, compared with the force of a 1e-3 random displacement.
    let mut rng = Rng::new(1);
    let (x, v) = random_cloud(&mut rng, 300, 5.0);
    let body = Body::new(x, v, 1.6);
    let strained = displaced(&mut rng, &body.x, 1e-3);
    let n = 1.0 / 3f64.sqrt();
    let motions = [
        affine(&body.x, rotation([1.0, 0.0, 0.0], 0.0), [3.0, -1.0, 0.5]),
        affine(&body.x, rotation([n, n, n], PI / 6.0), [0.0, 0.0, 0.0]),
        affine(&body.x, rotation([0.0, 0.6, 0.8], 2.0), [10.0, 20.0, -5.0]),
    ];
    for material in every_material(1.6) {
        let blocks = [set_up(&body, material)];
        let scale = max_norm(&evaluate(&body, &blocks, &strained, None).0);
        assert!(scale > 0.0);
        for y in &motions {
            let (f, c, w) = evaluate(&body, &blocks, y, None);
            assert!(
                max_norm(&f) <= 1e-9 * scale,
                "{}: {} vs {scale}",
                blocks[0].model_name(),
                max_norm(&f)
            );
            assert!(c.iter().all(|c| c.dilatation.abs() < 1e-12));
            assert!(w.iter().all(|&w| w.abs() < 1e-20 * scale));
        }
    }
}

#[test]
fn linear_and_angular_momentum_are_conserved() {
    // Pair forces are equal and opposite along the deformed bond: Σ_i F_i V_i = 0 and
    // Σ_i Y_i × F_i V_i = 0, also with (symmetric) broken bonds.
    let mut rng = Rng::new(2);
    let (x, v) = random_cloud(&mut rng, 300, 5.0);
    let body = Body::new(x, v, 1.6);
    let y = displaced(&mut rng, &body.x, 0.02);
    let mut damage = vec![0.0f32; body.bonds.num_bonds()];
    let broken =
        CriticalStretch::new(0.01)
            .unwrap()
            .update(&body.reference(), &y, &body.all(), &mut damage);
    assert!(broken > 0 && broken < damage.len());
    for material in every_material(1.6) {
        let blocks = [set_up(&body, material)];
        for d in [None, Some(&damage[..])] {
            let (f, _, _) = evaluate(&body, &blocks, &y, d);
            let mut momentum = [0.0; 3];
            let mut angular = [0.0; 3];
            let mut magnitude = 0.0;
            for ((fi, yi), vi) in f.iter().zip(&y).zip(&body.v) {
                let p = [fi[0] * vi, fi[1] * vi, fi[2] * vi];
                for k in 0..3 {
                    momentum[k] += p[k];
                }
                angular[0] += yi[1] * p[2] - yi[2] * p[1];
                angular[1] += yi[2] * p[0] - yi[0] * p[2];
                angular[2] += yi[0] * p[1] - yi[1] * p[0];
                magnitude += norm(p) * (1.0 + norm(*yi));
            }
            assert!(norm(momentum) < 1e-13 * magnitude, "{momentum:?}");
            assert!(norm(angular) < 1e-13 * magnitude, "{angular:?}");
        }
    }
}

#[test]
fn two_point_pair_force_is_antisymmetric() {
    // F_0 V_0 = −F_1 V_1 for any two points, volumes and deformation.
    let body = Body::new(vec![[0.0; 3], [0.6, 0.7, -0.2]], vec![2.0, 0.5], 1.5);
    let y = vec![[0.1, 0.0, 0.0], [0.9, 0.5, 0.1]];
    for material in every_material(1.5) {
        let blocks = [set_up(&body, material)];
        let (f, _, _) = evaluate(&body, &blocks, &y, None);
        for (f0, f1) in f[0].iter().zip(&f[1]) {
            let (a, b) = (f0 * 2.0, f1 * 0.5);
            assert!((a + b).abs() <= 1e-14 * a.abs().max(1.0), "{a} {b}");
        }
        assert!(norm(f[0]) > 0.0);
    }
}

#[test]
fn pmb_two_point_force_and_energy_by_hand() {
    // ζ = 1, δ = 1.5, K = 3 → c = 18K/(πδ⁴) = 54/(π·5.0625); Y_1 = (1.1, 0, 0) → s = 0.1.
    // F_0 = c s V_1 (+x) with V_1 = 0.5; F_1 = −c s V_0 with V_0 = 2.
    let body = Body::new(vec![[0.0; 3], [1.0, 0.0, 0.0]], vec![2.0, 0.5], 1.5);
    let blocks = [set_up(&body, pmb(3.0, 1.5))];
    let y = vec![[0.0; 3], [1.1, 0.0, 0.0]];
    let (f, _, w) = evaluate(&body, &blocks, &y, None);
    let c = 54.0 / (PI * 5.0625);
    let s = (1.1 - 1.0) / 1.0;
    assert!((f[0][0] - c * s * 0.5).abs() < 1e-14 * c);
    assert!((f[1][0] + c * s * 2.0).abs() < 1e-14 * c);
    assert_eq!((f[0][1], f[0][2]), (0.0, 0.0));
    // Energy: pair force P = c s V_0 V_1, extension e = s ζ; a linear spring stores ½ P e,
    // and Σ_i W_i V_i must equal it (W_i = ¼ c s² ζ V_j).
    let p = c * s * 2.0 * 0.5;
    let stored = w[0] * 2.0 + w[1] * 0.5;
    assert!(
        (stored - 0.5 * p * s).abs() < 1e-14 * p,
        "{stored} vs {}",
        0.5 * p * s
    );
    // A broken bond carries neither force nor energy.
    let broken = [1.0f32, 1.0];
    let (f, _, w) = evaluate(&body, &blocks, &y, Some(&broken));
    assert_eq!((f[0], f[1], w[0], w[1]), ([0.0; 3], [0.0; 3], 0.0, 0.0));
}

#[test]
fn pmb_planar_micromodulus() {
    // Plane strain/stress: c = 12K/(π h δ³); K = 3, h = 0.5, δ = 2 → 36/(π·0.5·8) = 9/π.
    let m = BondBased::new(
        &crate::material::BlockInput {
            density: 1.0,
            horizon: 2.0,
            influence: crate::material::InfluenceFunction::One,
        },
        &crate::material::BondBasedParameters {
            bulk_modulus: 3.0,
            planar_thickness: Some(0.5),
        },
    )
    .unwrap();
    assert!((m.micromodulus() - 9.0 / PI).abs() < 1e-15);
}

#[test]
fn lps_two_point_force_by_hand() {
    // ω = 1, ζ = 1, 1D pair along x with extension e: m_0 = ζ²V_1, θ_0 = 3ζeV_1/m_0 = 3e, and
    // t_01 = (3K − 5μ)θ_0ζ/m_0 + 15μe/m_0 = (9K − 15μ + 15μ)e/V_1 = 9Ke/V_1 (μ cancels);
    // likewise t_10 = 9Ke/V_0. F_0 = (t_01 + t_10) V_1 = 9Ke(1 + V_1/V_0) along +x.
    let (k, mu, e) = (3.0, 1.7, 0.1);
    let body = Body::new(vec![[0.0; 3], [1.0, 0.0, 0.0]], vec![2.0, 0.5], 1.5);
    let blocks = [set_up(&body, lps(k, mu, 1.5, InfluenceFunction::One))];
    let y = vec![[0.0; 3], [1.0 + e, 0.0, 0.0]];
    let (f, c, _) = evaluate(&body, &blocks, &y, None);
    let e = 1.1 - 1.0; // the extension as the kernel sees it
    assert!((c[0].dilatation - 3.0 * e).abs() < 1e-15);
    let expected = 9.0 * k * e * (1.0 + 0.5 / 2.0);
    assert!((f[0][0] - expected).abs() < 1e-13 * expected, "{:?}", f[0]);
    assert!((f[1][0] * 0.5 + f[0][0] * 2.0).abs() < 1e-13 * expected);
}

#[test]
fn lps_user_influence_enters_weighted_volume() {
    // ω = 1/ζ (Peridigm's test deck "1.0/zeta"): m_0 = ω ζ² V_1 = ζ V_1 = 2 · 0.5 = 1.
    let body = Body::new(vec![[0.0; 3], [2.0, 0.0, 0.0]], vec![2.0, 0.5], 2.5);
    let mut m = LinearPeridynamicSolid::new(
        &crate::material::BlockInput {
            density: 1.0,
            horizon: 2.5,
            influence: InfluenceFunction::user(|zeta, _| 1.0 / zeta),
        },
        &crate::material::ElasticConstants {
            bulk_modulus: 1.0,
            shear_modulus: 1.0,
        },
    )
    .unwrap();
    crate::material::set_up(&mut m, &body.reference(), body.all());
    assert_eq!(m.weighted_volume(), &[1.0, 4.0]); // m_1 = ζ V_0 = 2 · 2
}

#[test]
fn lps_isotropic_extension_gives_three_epsilon_everywhere() {
    // Y = (1+ε)X ⇒ |Y_j − Y_i| = (1+ε)ζ, e = εζ exactly in exact arithmetic (for any ε, the
    // map is linear), so θ_i = (3/m_i) Σ ω ζ (εζ) V_j = 3ε·(Σ ω ζ² V_j)/m_i = 3ε for every
    // point — boundary points included, because m_i uses the same family. Only round-off
    // remains.
    let x = lattice(7);
    let v = vec![1.0; x.len()];
    let body = Body::new(x, v, 2.1);
    for influence in [InfluenceFunction::One, InfluenceFunction::Gaussian] {
        let blocks = [set_up(&body, lps(3.0, 1.7, 2.1, influence))];
        for eps in [1e-4, 0.5] {
            let s = 1.0 + eps;
            let y = affine(
                &body.x,
                [[s, 0.0, 0.0], [0.0, s, 0.0], [0.0, 0.0, s]],
                [0.0; 3],
            );
            let (_, c, _) = evaluate(&body, &blocks, &y, None);
            for (i, ci) in c.iter().enumerate() {
                assert!(
                    (ci.dilatation - 3.0 * eps).abs() < 1e-13,
                    "point {i}, ε = {eps}: θ = {}",
                    ci.dilatation
                );
            }
        }
    }
}

#[test]
fn homogeneous_deformation_gives_zero_force_on_interior_point() {
    // 9³ lattice, δ = 2.1 (32 neighbours). The centre point (4,4,4) has a family symmetric
    // under ξ → −ξ; under Y = F X + c the bonds ±ξ have the same e and opposite directions.
    // For LPS the neighbours' θ enters too: all neighbours of the centre lie within 2.1 of it,
    // hence at least 2 cells from the boundary, so their own families are complete and their
    // θ equals the centre's. The force at the centre is then zero up to round-off, while
    // surface points carry the unbalanced force used as the scale.
    let x = lattice(9);
    let v = vec![1.0; x.len()];
    let body = Body::new(x, v, 2.1);
    let centre = 4 + 9 * 4 + 81 * 4;
    let f_matrix = [
        [1.02, 0.01, -0.03],
        [0.005, 0.97, 0.02],
        [0.01, -0.02, 1.05],
    ];
    let y = affine(&body.x, f_matrix, [0.3, -0.2, 0.1]);
    for material in every_material(2.1) {
        let blocks = [set_up(&body, material)];
        let (f, _, _) = evaluate(&body, &blocks, &y, None);
        let scale = max_norm(&f);
        assert!(scale > 0.0);
        assert!(
            norm(f[centre]) < 1e-12 * scale,
            "{:?} vs {scale}",
            f[centre]
        );
    }
}

/// Σ_k W_k V_k at positions `y`.
fn total_energy(
    body: &Body,
    blocks: &[Box<dyn Material>],
    y: &[[f64; 3]],
    d: Option<&[f32]>,
) -> f64 {
    let (_, _, w) = evaluate(body, blocks, y, d);
    w.iter().zip(&body.v).map(|(w, v)| w * v).sum()
}

/// Checks F_i V_i = −∂E/∂Y_i by central differences at a few points.
fn assert_force_is_energy_gradient(
    body: &Body,
    blocks: &[Box<dyn Material>],
    y: &[[f64; 3]],
    d: Option<&[f32]>,
) {
    let (f, _, _) = evaluate(body, blocks, y, d);
    let scale = max_norm(&f) * body.v.iter().cloned().fold(0.0, f64::max);
    let h = 1e-6;
    for i in [0, 7, 31, body.x.len() - 1] {
        for k in 0..3 {
            let mut plus = y.to_vec();
            plus[i][k] += h;
            let mut minus = y.to_vec();
            minus[i][k] -= h;
            let gradient = (total_energy(body, blocks, &plus, d)
                - total_energy(body, blocks, &minus, d))
                / (2.0 * h);
            let force = f[i][k] * body.v[i];
            assert!(
                (force + gradient).abs() < 1e-6 * scale,
                "{}: point {i} dof {k}: F V = {force}, −∂E/∂Y = {}",
                blocks[0].model_name(),
                -gradient
            );
        }
    }
}

#[test]
fn force_is_the_gradient_of_stored_energy() {
    // For intact bonds both models are hyperelastic: the force density is −(1/V_i) ∂E/∂Y_i
    // with E = Σ_k W_k V_k (for LPS because Σ_j ω e^d ζ V_j = 0, see the module docs). This
    // ties the force formula, the reverse half t_ji and the energy density together. PMB
    // energy is also exact with 0/1 damage (broken springs simply drop out).
    let mut rng = Rng::new(3);
    let (x, v) = random_cloud(&mut rng, 120, 4.0);
    let body = Body::new(x, v, 1.6);
    let y = displaced(&mut rng, &body.x, 0.05);
    for material in every_material(1.6) {
        let blocks = [set_up(&body, material)];
        assert_force_is_energy_gradient(&body, &blocks, &y, None);
    }
    let mut damage = vec![0.0f32; body.bonds.num_bonds()];
    CriticalStretch::new(0.02)
        .unwrap()
        .update(&body.reference(), &y, &body.all(), &mut damage);
    let blocks = [set_up(&body, pmb(3.0, 1.6))];
    assert_force_is_energy_gradient(&body, &blocks, &y, Some(&damage));
}

#[test]
fn blocks_with_different_constants_stay_consistent() {
    // Two blocks split at x = 2 with different constants; bonds across the interface use each
    // side's published coefficients, so momentum is conserved and the force is still the
    // gradient of the total stored energy.
    let mut rng = Rng::new(4);
    let (x, v) = random_cloud(&mut rng, 150, 4.0);
    let body = Body::new(x, v, 1.6);
    let y = displaced(&mut rng, &body.x, 0.05);
    let (left, right): (Vec<u32>, Vec<u32>) = body
        .all()
        .into_iter()
        .partition(|&i| body.x[i as usize][0] < 2.0);
    let pairs: [(Box<dyn Material>, Box<dyn Material>); 2] = [
        (pmb(3.0, 1.6), pmb(7.0, 1.6)),
        (
            lps(3.0, 1.7, 1.6, InfluenceFunction::ParabolicDecay),
            lps(9.0, 0.4, 1.6, InfluenceFunction::ParabolicDecay),
        ),
    ];
    for (mut a, mut b) in pairs {
        crate::material::set_up(&mut a, &body.reference(), left.clone());
        crate::material::set_up(&mut b, &body.reference(), right.clone());
        let blocks = [a, b];
        assert_force_is_energy_gradient(&body, &blocks, &y, None);
        let (f, _, _) = evaluate(&body, &blocks, &y, None);
        let mut momentum = [0.0; 3];
        let mut magnitude = 0.0;
        for (fi, vi) in f.iter().zip(&body.v) {
            for k in 0..3 {
                momentum[k] += fi[k] * vi;
            }
            magnitude += norm(*fi) * vi;
        }
        assert!(norm(momentum) < 1e-13 * magnitude);
    }
}

#[test]
fn critical_time_step_of_two_points_by_hand() {
    // ρ = 2, K = 3, δ = 1.5, ζ = 1: c = 18K/(πδ⁴) = 54/(π·5.0625).
    // Δt_0 = sqrt(2ρ/(V_1 c/ζ)) with V_1 = 0.5, Δt_1 = sqrt(2ρ/(V_0 c/ζ)) with V_0 = 2; the
    // minimum is Δt_1 = sqrt(4/(2c)). Point 2 is far away (no neighbours): no bound, ignored.
    let body = Body::new(
        vec![[0.0; 3], [1.0, 0.0, 0.0], [10.0, 0.0, 0.0]],
        vec![2.0, 0.5, 1.0],
        1.5,
    );
    let c = 54.0 / (PI * 5.0625);
    let expected = (4.0 / (2.0 * c)).sqrt();
    for material in every_material(1.5) {
        let m = set_up(&body, material);
        let dt = m.critical_time_step(&body.reference()).unwrap();
        assert!(
            (dt - expected).abs() < 1e-15 * expected,
            "{dt} vs {expected}"
        );
    }
    let isolated = critical_time_step(&body.reference(), &[2], 2.0, 3.0, 1.5);
    assert_eq!(isolated, None);
}

#[test]
fn invalid_parameters_are_errors_naming_the_key() {
    let err = BondBased::new(
        &crate::material::BlockInput {
            density: -1.0,
            horizon: 1.0,
            influence: crate::material::InfluenceFunction::One,
        },
        &crate::material::BondBasedParameters {
            bulk_modulus: 1.0,
            planar_thickness: None,
        },
    )
    .unwrap_err();
    assert!(err.to_string().contains("`Density`"), "{err}");
    let err = LinearPeridynamicSolid::new(
        &crate::material::BlockInput {
            density: 1.0,
            horizon: 1.0,
            influence: InfluenceFunction::One,
        },
        &crate::material::ElasticConstants {
            bulk_modulus: 1.0,
            shear_modulus: f64::NAN,
        },
    )
    .unwrap_err();
    assert!(err.to_string().contains("`Shear Modulus`"), "{err}");
}
