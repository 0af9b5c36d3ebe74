//! `Linear LPS Partial Volume`: rigid motion (translation exact, rotation to second order, a
//! finite rotation not force-free), momentum, tangent against finite differences, isotropic
//! extension under every quadrature rule, agreement with `Elastic` to first order, and the
//! analytic weighted volume.

use super::*;
use crate::material::LinearPeridynamicSolid;
use crate::model::quadrature::{self, QuadratureRule};
use crate::model::test_support::{brute_force_bonds, lattice, random_cloud, Rng};
use crate::tangent::BlockPattern;
use std::sync::Arc;

const BULK: f64 = 3.0;
const SHEAR: f64 = 1.3;

/// The block input of the tests' material: ρ = 1, `horizon`, `influence`.
fn block(horizon: f64, influence: InfluenceFunction) -> BlockInput {
    BlockInput {
        density: 1.0,
        horizon,
        influence,
    }
}

/// K = BULK, μ = SHEAR.
const ELASTIC: ElasticConstants = ElasticConstants {
    bulk_modulus: BULK,
    shear_modulus: SHEAR,
};

/// Points, cell volumes, families and (optional) per-bond quadrature volumes and damage.
struct Body {
    x: Vec<[f64; 3]>,
    v: Vec<f64>,
    bonds: BondList,
    bond_volume: Option<Vec<f64>>,
    damage: Option<Vec<f32>>,
}

impl Body {
    /// 200 random points in a 5-wide box with δ = 1.6 families (cell volumes in [0.5, 1.5)).
    fn random(seed: u64) -> Self {
        let mut rng = Rng::new(seed);
        let (x, v) = random_cloud(&mut rng, 200, 5.0);
        let bonds = brute_force_bonds(&x, 1.6);
        Self {
            x,
            v,
            bonds,
            bond_volume: None,
            damage: None,
        }
    }

    /// A 7³ unit lattice with horizon `horizon` and the families and bond volumes of `rule`.
    fn lattice(rule: QuadratureRule, horizon: f64) -> Self {
        let x = lattice(7);
        let v = vec![1.0; x.len()];
        let bonds = brute_force_bonds(&x, rule.family_reach(horizon, 1.0));
        let rules = vec![rule; x.len()];
        let horizons = vec![horizon; x.len()];
        let bond_volume =
            quadrature::bond_volumes(&bonds, &x, &v, &rules, &horizons).map(|(w, _)| w);
        Self {
            x,
            v,
            bonds,
            bond_volume,
            damage: None,
        }
    }

    fn reference(&self) -> ReferenceView<'_> {
        ReferenceView {
            bonds: &self.bonds,
            position: &self.x,
            volume: &self.v,
            bond_volume: self.bond_volume.as_deref(),
        }
    }

    fn set_up(&self, mut material: Box<dyn Material>) -> Box<dyn Material> {
        crate::material::set_up(
            &mut material,
            &self.reference(),
            (0..self.x.len() as u32).collect(),
        );
        material
    }

    /// Force density, coefficients and energy density at `y`.
    fn evaluate(
        &self,
        material: &dyn Material,
        y: &[[f64; 3]],
    ) -> (Vec<[f64; 3]>, Vec<PointCoefficients>, Vec<f64>) {
        let n = self.x.len();
        let reference = self.reference();
        let current = CurrentView {
            position: y,
            bond_damage: self.damage.as_deref(),
            history: &crate::history::NO_HISTORY,
        };
        let mut coefficients = vec![PointCoefficients::default(); n];
        material.compute_point_coefficients(&reference, &current, &mut coefficients);
        let mut force = vec![[0.0; 3]; n];
        material.add_force_density(&reference, &current, &coefficients, &mut force);
        let mut energy = vec![0.0; n];
        material.stored_energy_density(&reference, &current, &coefficients, &mut energy);
        (force, coefficients, energy)
    }

    fn force(&self, material: &dyn Material, y: &[[f64; 3]]) -> Vec<[f64; 3]> {
        self.evaluate(material, y).0
    }

    /// Damages about a fifth of the pairs (both directions): half of them broken (d = 1),
    /// half partly (d = 0.4, where the single factor 1 − d of the force state shows).
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
                    let d = if rng.uniform() < 0.5 { 1.0 } else { 0.4 };
                    damage[b] = d;
                    damage[back] = d;
                }
            }
        }
        self.damage = Some(damage);
    }
}

fn linear(horizon: f64, influence: InfluenceFunction) -> Box<dyn Material> {
    Box::new(LinearLps::new(&block(horizon, influence), &ELASTIC, None).unwrap())
}

fn max_norm(f: &[[f64; 3]]) -> f64 {
    f.iter()
        .map(|a| (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt())
        .fold(0.0, f64::max)
}

/// Y = X + u(X) for every point.
fn moved(x: &[[f64; 3]], mut u: impl FnMut([f64; 3]) -> [f64; 3]) -> Vec<[f64; 3]> {
    x.iter()
        .map(|&p| {
            let d = u(p);
            [p[0] + d[0], p[1] + d[1], p[2] + d[2]]
        })
        .collect()
}

/// Rotation by `angle` about the unit axis `a` (Rodrigues), applied about the point `c`.
fn rotated(x: &[[f64; 3]], a: [f64; 3], angle: f64, c: [f64; 3]) -> Vec<[f64; 3]> {
    let (s, co) = angle.sin_cos();
    x.iter()
        .map(|p| {
            let r = [p[0] - c[0], p[1] - c[1], p[2] - c[2]];
            let dot = a[0] * r[0] + a[1] * r[1] + a[2] * r[2];
            let cross = [
                a[1] * r[2] - a[2] * r[1],
                a[2] * r[0] - a[0] * r[2],
                a[0] * r[1] - a[1] * r[0],
            ];
            [0, 1, 2].map(|k| c[k] + r[k] * co + cross[k] * s + a[k] * dot * (1.0 - co))
        })
        .collect()
}

fn random_displacement(x: &[[f64; 3]], amplitude: f64, seed: u64) -> Vec<[f64; 3]> {
    let mut rng = Rng::new(seed);
    moved(x, |_| {
        [0; 3].map(|_| amplitude * (2.0 * rng.uniform() - 1.0))
    })
}

#[test]
fn a_translation_gives_no_force() {
    // e = n·(u_j − u_i) = 0 for u constant, so θ = 0 and every t = 0: the force is zero up
    // to the round-off of Y − X.
    let body = Body::random(3);
    let material = body.set_up(linear(1.6, InfluenceFunction::ParabolicDecay));
    let y = moved(&body.x, |_| [0.3, -1.7, 2.2]);
    let (force, coefficients, energy) = body.evaluate(material.as_ref(), &y);
    // The stiffness scale: the force of a 1e-3 stretch, against which round-off is measured.
    let stretch = body.force(material.as_ref(), &moved(&body.x, |p| p.map(|c| 1e-3 * c)));
    let scale = max_norm(&stretch);
    assert!(scale > 0.0);
    assert!(max_norm(&force) < 1e-9 * scale, "{}", max_norm(&force));
    assert!(coefficients.iter().all(|c| c.dilatation.abs() < 1e-12));
    assert!(energy.iter().all(|w| w.abs() < 1e-20));
}

#[test]
fn an_infinitesimal_rotation_gives_a_force_of_second_order_and_a_finite_one_does_not_vanish() {
    // For u = (R − I)X with R a rotation by φ about the unit axis a,
    // e = n·(R − I)ξ = −ζ (1 − cos φ)(1 − (n·a)²): second order in φ. So the force halves
    // twice when φ halves (ratio 4 to O(φ²)), and is far below the force of a strain φ.
    let body = Body::random(5);
    let material = body.set_up(linear(1.6, InfluenceFunction::One));
    let axis = {
        let a = [1.0f64, 2.0, -0.5];
        let norm = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
        a.map(|c| c / norm)
    };
    let centre = [2.5, 2.5, 2.5];
    let phi = 1e-3;
    let small = max_norm(&body.force(material.as_ref(), &rotated(&body.x, axis, phi, centre)));
    let half = max_norm(&body.force(
        material.as_ref(),
        &rotated(&body.x, axis, phi / 2.0, centre),
    ));
    let ratio = small / half;
    assert!((ratio - 4.0).abs() < 1e-3, "ratio {ratio}");
    let strain = max_norm(&body.force(material.as_ref(), &moved(&body.x, |p| p.map(|c| phi * c))));
    assert!(small < 10.0 * phi * strain, "{small} vs {strain}");

    // A finite rotation (0.5 rad) is not force-free in the linearized model: its projected
    // "strain" is −(1 − cos φ)(I − a⊗a), and a 7³ lattice's centre (a family with cubic
    // symmetry, Σ ω ζ² n⊗n V = (m/3) I) sees θ = its trace = −2(1 − cos φ) exactly.
    let grid = Body::lattice(QuadratureRule::FullVolume, 2.0);
    let material = grid.set_up(linear(2.0, InfluenceFunction::One));
    let angle = 0.5;
    let y = rotated(&grid.x, axis, angle, [3.0; 3]);
    let (force, coefficients, energy) = grid.evaluate(material.as_ref(), &y);
    let centre = 3 + 7 * 3 + 49 * 3;
    let expected = -2.0 * (1.0 - angle.cos());
    let theta = coefficients[centre].dilatation;
    assert!(
        (theta - expected).abs() < 1e-12,
        "θ = {theta}, expected {expected}"
    );
    assert!(energy[centre] > 0.0);
    assert!(
        max_norm(&force) > 1e-2 * BULK * (1.0 - angle.cos()),
        "{}",
        max_norm(&force)
    );
}

#[test]
fn linear_and_angular_momentum_are_conserved() {
    // Each pair's force is (t_ij + t_ji) V_i V_j n_ij on i and its negative on j (full
    // volumes, symmetric), along the reference bond: Σ V_i F_i = 0 and Σ V_i X_i × F_i = 0.
    let mut body = Body::random(7);
    body.break_some_bonds(8);
    let material = body.set_up(linear(1.6, InfluenceFunction::Gaussian));
    let y = random_displacement(&body.x, 0.05, 9);
    let force = body.force(material.as_ref(), &y);
    let mut linear_sum = [0.0; 3];
    let mut angular = [0.0; 3];
    let mut scale = 0.0f64;
    for ((f, x), v) in force.iter().zip(&body.x).zip(&body.v) {
        for k in 0..3 {
            linear_sum[k] += v * f[k];
        }
        angular[0] += v * (x[1] * f[2] - x[2] * f[1]);
        angular[1] += v * (x[2] * f[0] - x[0] * f[2]);
        angular[2] += v * (x[0] * f[1] - x[1] * f[0]);
        scale = scale.max(v * (f[0].abs() + f[1].abs() + f[2].abs()));
    }
    assert!(scale > 0.0);
    for k in 0..3 {
        assert!(
            linear_sum[k].abs() < 1e-12 * scale * 200.0,
            "{linear_sum:?}"
        );
        assert!(angular[k].abs() < 1e-12 * scale * 1000.0, "{angular:?}");
    }
}

/// Largest |analytic − central difference| of ∂(V_i F_i)/∂u_j over a few columns, relative to
/// the largest entry.
fn tangent_error(
    body: &Body,
    material: &dyn Material,
    y: &[[f64; 3]],
    method: TangentMethod,
) -> f64 {
    let reference = body.reference();
    let current = CurrentView {
        position: y,
        bond_damage: body.damage.as_deref(),
        history: &crate::history::NO_HISTORY,
    };
    let mut tangent = BlockTangent::zeros(Arc::new(BlockPattern::two_hop(&body.bonds)));
    material
        .add_tangent(&reference, &current, method, &mut tangent)
        .unwrap();
    // The model is linear: a central difference is exact up to round-off for any probe.
    let h = 1e-4;
    let (mut largest, mut worst) = (0.0f64, 0.0f64);
    for j in [0usize, 17, 60, 99, 131, 199] {
        for l in 0..3 {
            let mut plus = y.to_vec();
            plus[j][l] += h;
            let mut minus = y.to_vec();
            minus[j][l] -= h;
            let (fp, fm) = (body.force(material, &plus), body.force(material, &minus));
            for i in 0..y.len() {
                for k in 0..3 {
                    let fd = body.v[i] * (fp[i][k] - fm[i][k]) / (2.0 * h);
                    let exact = tangent.block(i, j).map_or(0.0, |b| b[k][l]);
                    largest = largest.max(fd.abs());
                    worst = worst.max((exact - fd).abs());
                }
            }
        }
    }
    assert!(largest > 0.0);
    worst / largest
}

#[test]
fn the_tangent_matches_finite_differences_of_the_force() {
    for damaged in [false, true] {
        let mut body = Body::random(11);
        if damaged {
            body.break_some_bonds(12);
        }
        let material = body.set_up(linear(1.6, InfluenceFunction::ParabolicDecay));
        let y = random_displacement(&body.x, 0.05, 13);
        for method in [
            TangentMethod::Analytic,
            TangentMethod::AutomaticDifferentiation,
            TangentMethod::FiniteDifference { probe: Some(1e-5) },
        ] {
            let error = tangent_error(&body, material.as_ref(), &y, method);
            assert!(error < 1e-8, "{method:?}, damaged {damaged}: {error}");
        }
    }
}

#[test]
fn the_force_is_the_gradient_of_the_stored_energy() {
    // Σ_k W_k V_k is quadratic in u; its central difference is exact up to round-off and
    // must equal −V_i F_i (intact bonds).
    let body = Body::random(15);
    let material = body.set_up(linear(1.6, InfluenceFunction::One));
    let y = random_displacement(&body.x, 0.05, 16);
    let force = body.force(material.as_ref(), &y);
    let total = |y: &[[f64; 3]]| -> f64 {
        let (_, _, w) = body.evaluate(material.as_ref(), y);
        w.iter().zip(&body.v).map(|(w, v)| w * v).sum()
    };
    let h = 1e-4;
    let scale = max_norm(&force);
    for i in [0usize, 50, 123] {
        for k in 0..3 {
            let mut plus = y.clone();
            plus[i][k] += h;
            let mut minus = y.clone();
            minus[i][k] -= h;
            let gradient = (total(&plus) - total(&minus)) / (2.0 * h);
            let expected = -body.v[i] * force[i][k];
            assert!(
                (gradient - expected).abs() < 1e-7 * scale,
                "point {i}, {k}: {gradient} vs {expected}"
            );
        }
    }
}

#[test]
fn isotropic_extension_gives_three_epsilon_under_every_rule() {
    // u = εX gives e = n·εξ = εζ on every bond, so θ = (3/m) Σ ω ζ (εζ) w = 3ε with
    // m = Σ ω ζ² w from the same weights, at every point with bonds, whatever the rule.
    let strain = 1e-3;
    for rule in [
        QuadratureRule::FullVolume,
        QuadratureRule::PdLammps,
        QuadratureRule::Hhb,
        QuadratureRule::Exact,
        QuadratureRule::Adaptive { tolerance: 1e-4 },
    ] {
        let body = Body::lattice(rule, 2.0);
        assert_eq!(body.bond_volume.is_none(), rule.is_full_volume());
        for influence in [InfluenceFunction::One, InfluenceFunction::ParabolicDecay] {
            let material = body.set_up(linear(2.0, influence));
            let y = moved(&body.x, |p| p.map(|c| strain * c));
            let (_, coefficients, _) = body.evaluate(material.as_ref(), &y);
            for (i, c) in coefficients.iter().enumerate() {
                assert!(
                    (c.dilatation - 3.0 * strain).abs() < 1e-14,
                    "{rule:?}, point {i}: θ = {}",
                    c.dilatation
                );
            }
        }
    }
}

#[test]
fn a_small_stretch_matches_elastic_to_first_order() {
    // Under an isotropic extension `Elastic`'s e = |Y| − ζ = εζ is the linear one, and its
    // direction M = n: the two models give the same force to round-off. Under a uniaxial
    // stretch ε along x, |Y| − ζ = εζ n_x² + O(ε²) and M = n + O(ε), so the forces differ by
    // O(ε²) against forces of O(ε): a relative difference of O(ε), at every point, under
    // every quadrature rule.
    for rule in [QuadratureRule::FullVolume, QuadratureRule::Exact] {
        let body = Body::lattice(rule, 2.0);
        let linear = body.set_up(linear(2.0, InfluenceFunction::One));
        let elastic = body.set_up(Box::new(
            LinearPeridynamicSolid::new(
                &crate::material::BlockInput {
                    density: 1.0,
                    horizon: 2.0,
                    influence: InfluenceFunction::One,
                },
                &crate::material::ElasticConstants {
                    bulk_modulus: BULK,
                    shear_modulus: SHEAR,
                },
            )
            .unwrap(),
        ));
        for (epsilon, uniaxial) in [(1e-3, false), (1e-4, true), (1e-5, true)] {
            let y = moved(&body.x, |p| {
                if uniaxial {
                    [epsilon * p[0], 0.0, 0.0]
                } else {
                    p.map(|c| epsilon * c)
                }
            });
            let (a, ca, wa) = body.evaluate(linear.as_ref(), &y);
            let (b, cb, wb) = body.evaluate(elastic.as_ref(), &y);
            let scale = max_norm(&b);
            assert!(scale > 0.0);
            let difference: Vec<[f64; 3]> = a
                .iter()
                .zip(&b)
                .map(|(p, q)| [0, 1, 2].map(|k| p[k] - q[k]))
                .collect();
            let relative = max_norm(&difference) / scale;
            let bound = if uniaxial { 10.0 * epsilon } else { 1e-9 };
            assert!(relative < bound, "{rule:?}, ε {epsilon}: {relative}");
            for i in 0..body.x.len() {
                assert!((ca[i].dilatation - cb[i].dilatation).abs() <= bound * epsilon * 3.0);
                assert!((wa[i] - wb[i]).abs() <= bound * wb[i].abs().max(1e-30) + 1e-30);
            }
        }
    }
}

#[test]
fn the_analytic_weighted_volume_replaces_m() {
    // With m given, θ = (3/m_given) Σ ω ζ e w = (m_family/m_given)·θ_family, and the
    // deviatoric coefficient is 15μ/m_given.
    let body = Body::random(17);
    let family = body.set_up(linear(1.6, InfluenceFunction::One));
    let given = 4.0 * std::f64::consts::PI * 1.6f64.powi(5) / 5.0;
    let analytic = body.set_up(Box::new(
        LinearLps::new(&block(1.6, InfluenceFunction::One), &ELASTIC, Some(given)).unwrap(),
    ));
    assert!(analytic
        .weighted_volume()
        .unwrap()
        .iter()
        .all(|&m| m == given));
    let y = random_displacement(&body.x, 0.05, 18);
    let (_, a, _) = body.evaluate(analytic.as_ref(), &y);
    let (_, f, _) = body.evaluate(family.as_ref(), &y);
    let m = family.weighted_volume().unwrap();
    for i in 0..body.x.len() {
        if m[i] == 0.0 {
            continue;
        }
        let expected = f[i].dilatation * m[i] / given;
        assert!((a[i].dilatation - expected).abs() < 1e-12 * (1.0 + expected.abs()));
        assert!((a[i].deviatoric - 15.0 * SHEAR / given).abs() < 1e-15);
    }
}

#[test]
fn invalid_parameters_name_the_key() {
    let error = LinearLps::new(&block(1.0, InfluenceFunction::One), &ELASTIC, Some(-1.0)).err();
    assert_eq!(
        error,
        Some(MaterialError::NotPositive {
            key: "Analytic Weighted Volume",
            value: -1.0
        })
    );
}
