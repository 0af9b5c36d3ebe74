//! Thermal strain of the materials that take a `Thermal Expansion Coefficient` (`Elastic`,
//! `Elastic Correspondence`): free thermal expansion of a cube carries no force at any point
//! (interior or surface), a fully held body carries the closed-form thermal force, the LPS
//! tangent with thermal strain is the derivative of its force (the models without thermal strain
//! refuse the key: the registry's conformance suite checks every model's declaration).

use std::sync::Arc;

use super::*;
use crate::history::{History, Staged};
use crate::model::test_support::{brute_force_bonds, lattice};
use crate::model::PointCloud;
use crate::physics::{BlockPhysics, Configuration, Physics};
use crate::tangent::BlockPattern;

const BULK: f64 = 3.0;
const SHEAR: f64 = 1.7;
const ALPHA: f64 = 2.0e-5;

const ELASTIC: ElasticConstants = ElasticConstants {
    bulk_modulus: BULK,
    shear_modulus: SHEAR,
};

fn lps(alpha: Option<f64>) -> Box<dyn Material> {
    let block = BlockInput {
        density: 2.0,
        horizon: 1.8,
        influence: InfluenceFunction::ParabolicDecay,
    };
    let mut m: Box<dyn Material> = Box::new(LinearPeridynamicSolid::new(&block, &ELASTIC).unwrap());
    if let Some(alpha) = alpha {
        m.set_thermal_expansion(alpha).unwrap();
    }
    m
}

fn correspondence(alpha: Option<f64>) -> Box<dyn Material> {
    let block = BlockInput {
        density: 2.0,
        horizon: 1.8,
        influence: InfluenceFunction::One,
    };
    let parameters = CorrespondenceParameters {
        elastic: ELASTIC,
        hourglass_coefficient: 0.1,
        stress: (),
    };
    let mut m = ElasticCorrespondence::build(&block, &parameters).unwrap();
    if let Some(alpha) = alpha {
        m.set_thermal_expansion(alpha).unwrap();
    }
    m
}

/// A 5³ lattice (spacing 1, unit volumes) of one block of `material`, with point temperatures.
struct Body {
    points: PointCloud,
    bonds: BondList,
    physics: Physics,
    history: History,
}

impl Body {
    fn new(mut material: Box<dyn Material>) -> Self {
        let x = lattice(5);
        let mut points = PointCloud::default();
        for p in &x {
            points.push(*p, 1.0, 0);
        }
        let bonds = brute_force_bonds(&x, 1.8);
        crate::material::set_up(
            &mut material,
            &ReferenceView::of(&bonds, &points),
            (0..x.len() as u32).collect(),
        );
        let history = History::allocate(material.declaration().fields, x.len(), bonds.num_bonds())
            .with_thermal(x.len());
        let physics = Physics::new(
            vec![BlockPhysics {
                material,
                damage: None,
            }],
            &points,
            &bonds,
        );
        Self {
            points,
            bonds,
            physics,
            history,
        }
    }

    /// Sets ΔT = `change` at every point.
    fn heat(&mut self, change: f64) {
        self.history.thermal_mut().unwrap().change.fill(change);
    }

    fn force(&mut self, y: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let mut f = vec![[0.0; 3]; y.len()];
        self.physics.internal_force_with_damage_fixed(
            &self.bonds,
            &self.points,
            y,
            None,
            &mut self.history,
            &mut f,
        );
        f
    }

    /// Accepts the step (as the state does).
    fn commit(&mut self) {
        self.history.each(Staged::commit);
    }

    /// Y = X + ε (X − X₀), X₀ the lattice's first point.
    fn expanded(&self, strain: f64) -> Vec<[f64; 3]> {
        self.points
            .position
            .iter()
            .map(|x| x.map(|c| c + strain * c))
            .collect()
    }
}

fn largest(f: &[[f64; 3]]) -> f64 {
    f.iter().flatten().fold(0.0f64, |m, c| m.max(c.abs()))
}

#[test]
fn lps_free_thermal_expansion_carries_no_force_at_any_point() {
    // Y = (1 + αΔT) X stretches every bond by αΔT ζ, exactly the free thermal extension of both
    // ends: e − αΔT ζ = 0 in θ and in every t_ij, at surface points as in the interior. The
    // scale is the force of the same expansion without heating (surface points carry it).
    let delta_t = 50.0;
    let strain = ALPHA * delta_t;
    let mut body = Body::new(lps(Some(ALPHA)));
    let y = body.expanded(strain);
    let mechanical = largest(&body.force(&y));
    assert!(mechanical > 0.0);
    body.heat(delta_t);
    let thermal = body.force(&y);
    // Round-off of |Y| − ζ − αΔTζ (≈1e-16 ζ) against an extension of 1e-3 ζ.
    assert!(
        largest(&thermal) < 1e-10 * mechanical,
        "{}",
        largest(&thermal)
    );
    // Heated in place, every point is compressed by the free extension it cannot take.
    let held = body.force(&body.points.position.clone());
    assert!((largest(&held) / mechanical - 1.0).abs() < 1e-9);
}

#[test]
fn a_fully_held_lps_body_carries_the_closed_form_thermal_force() {
    // With Y = X and ΔT everywhere, e = 0, so at every point (surface points too, m being the
    // point's own family sum) θ_i = (3/m_i) Σ_j ω ζ (−αΔT ζ) V_j = −3αΔT, and
    // t_ij = ω[(3K − 5μ)θ_i/m_i ζ + (15μ/m_i)(−αΔT ζ)] = −9K αΔT ω ζ/m_i.
    // F_i = Σ_j (t_ij + t_ji) V_j M_ij with M_ij = ξ/ζ: the force density of the held body.
    let delta_t = -40.0;
    let mut body = Body::new(lps(Some(ALPHA)));
    body.heat(delta_t);
    let x = body.points.position.clone();
    let force = body.force(&x);
    let omega = InfluenceFunction::ParabolicDecay;
    let weight = |zeta: f64| omega.evaluate(zeta, 1.8);
    let bonds = &body.bonds;
    let m: Vec<f64> = (0..x.len())
        .map(|i| {
            bonds
                .range(i)
                .map(|b| weight(bonds.reference_length[b]) * bonds.reference_length[b].powi(2))
                .sum()
        })
        .collect();
    let strain = ALPHA * delta_t;
    for i in 0..x.len() {
        let mut expected = [0.0; 3];
        for b in bonds.range(i) {
            let j = bonds.neighbor[b] as usize;
            let zeta = bonds.reference_length[b];
            let t = -9.0 * BULK * strain * weight(zeta) * zeta * (1.0 / m[i] + 1.0 / m[j]);
            for k in 0..3 {
                expected[k] += t * (x[j][k] - x[i][k]) / zeta;
            }
        }
        for k in 0..3 {
            assert!(
                (force[i][k] - expected[k]).abs() < 1e-10 * 9.0 * BULK * strain.abs(),
                "point {i}: {:?} vs {expected:?}",
                force[i]
            );
        }
    }
    // Cooled (ΔT < 0) and held, the body pulls its surface points inwards.
    let corner = force[0];
    assert!(corner.iter().all(|&c| c > 0.0), "{corner:?}");
}

#[test]
fn correspondence_free_thermal_expansion_leaves_only_a_second_order_stress() {
    // F = (1 + ε)I at every point (correspondence reproduces affine motion exactly, surface
    // points too). The stress update takes d Δt − αΔ(ΔT) I; over the steps d Δt sums to the
    // logarithmic-like strain, Σ (λ_{k+1} − λ_k)/λ_mid ≈ ln(1 + ε) = ε − ε²/2, so with αΔT = ε
    // the stress left is about 3K ε²/2, a fraction ε/2 = 5e-4 of the mechanical one.
    let delta_t = 50.0;
    let strain = ALPHA * delta_t;
    let steps = 4;
    let mut mechanical = Body::new(correspondence(Some(ALPHA)));
    let mut heated = Body::new(correspondence(Some(ALPHA)));
    let (mut f_mechanical, mut f_heated) = (Vec::new(), Vec::new());
    for k in 1..=steps {
        let fraction = k as f64 / steps as f64;
        let y = heated.expanded(strain * fraction);
        heated.heat(delta_t * fraction);
        f_heated = heated.force(&y);
        heated.commit();
        f_mechanical = mechanical.force(&y);
        mechanical.commit();
    }
    let scale = largest(&f_mechanical);
    assert!(scale > 0.0);
    let left = largest(&f_heated) / scale;
    assert!(left < strain, "relative force left {left}");
    // The hypoelastic residual is there (the check above is not vacuous), of the order ε/2.
    assert!(left > 0.05 * strain, "relative force left {left}");
}

#[test]
fn a_rejected_step_does_not_move_the_start_temperature_of_the_correspondence_update() {
    // ΔT_n is staged with the history: a trial with another temperature, restored, leaves the
    // next trial exactly as in a run that never tried it.
    let mut body = Body::new(correspondence(Some(ALPHA)));
    let mut twin = Body::new(correspondence(Some(ALPHA)));
    for b in [&mut body, &mut twin] {
        b.heat(10.0);
        let y = b.expanded(10.0 * ALPHA);
        b.force(&y);
        b.commit();
    }
    body.heat(80.0);
    body.force(&body.expanded(3e-4));
    body.history.each(Staged::restore);
    for b in [&mut body, &mut twin] {
        b.heat(20.0);
    }
    let y = body.expanded(5e-4);
    assert_eq!(body.force(&y), twin.force(&y));
}

#[test]
fn the_lps_tangent_with_thermal_strain_is_the_derivative_of_the_force() {
    let mut body = Body::new(lps(Some(ALPHA)));
    let n = body.points.len();
    // Non-uniform ΔT, so that t_ij and t_ji see different thermal strains.
    for (p, change) in body
        .history
        .thermal_mut()
        .unwrap()
        .change
        .iter_mut()
        .enumerate()
    {
        *change = 30.0 + 7.0 * (p % 11) as f64;
    }
    let y: Vec<[f64; 3]> = body
        .points
        .position
        .iter()
        .enumerate()
        .map(|(p, x)| [0, 1, 2].map(|k| x[k] * 1.001 + 1e-3 * (((p * 7 + k * 3) % 5) as f64)))
        .collect();
    body.force(&y);
    let pattern = Arc::new(BlockPattern::two_hop(&body.bonds));
    for method in [
        TangentMethod::Analytic,
        TangentMethod::AutomaticDifferentiation,
    ] {
        let mut tangent = BlockTangent::zeros(pattern.clone());
        body.physics
            .tangent_with(
                &body.bonds,
                &body.points,
                Configuration {
                    position: &y,
                    bond_damage: None,
                    history: &body.history,
                },
                method,
                &mut tangent,
            )
            .unwrap();
        let h = 1e-6;
        let (mut worst, mut scale) = (0.0f64, 0.0f64);
        for j in [0usize, 31, 62, 124] {
            for l in 0..3 {
                let mut plus = y.clone();
                plus[j][l] += h;
                let mut minus = y.clone();
                minus[j][l] -= h;
                let (fp, fm) = (body.force(&plus), body.force(&minus));
                for i in 0..n {
                    for k in 0..3 {
                        let fd = body.points.volume[i] * (fp[i][k] - fm[i][k]) / (2.0 * h);
                        let exact = tangent.block(i, j).map_or(0.0, |b| b[k][l]);
                        scale = scale.max(fd.abs());
                        worst = worst.max((exact - fd).abs());
                    }
                }
            }
        }
        assert!(scale > 0.0);
        assert!(worst < 1e-6 * scale, "{method:?}: {worst} of {scale}");
    }
}
