//! Checks of `Viscoelastic`: relaxation under a step shear against the closed form of the
//! back-extension ODE, λ_i = 0 against the LPS, rigid motion, momentum, staged history and the
//! tangent against finite differences (undamaged and with broken bonds).

use std::sync::Arc;

use super::*;
use crate::material::{InfluenceFunction, LinearPeridynamicSolid};
use crate::model::test_support::{brute_force_bonds, lattice, Rng};
use crate::model::PointCloud;
use crate::physics::{BlockPhysics, Configuration, Physics};
use crate::tangent::BlockPattern;

const BULK: f64 = 3.0;
const SHEAR: f64 = 1.0;
const TAU: f64 = 0.5;

/// `Viscoelastic` with ρ = 2, K = BULK, μ = SHEAR, τ_b = TAU and `lambda_i`.
fn viscoelastic(horizon: f64, lambda_i: f64) -> Viscoelastic {
    let block = BlockInput {
        density: 2.0,
        horizon,
        influence: InfluenceFunction::One,
    };
    let parameters = ViscoelasticInput {
        elastic: ElasticConstants {
            bulk_modulus: BULK,
            shear_modulus: SHEAR,
        },
        lambda_i,
        tau_b: TAU,
    };
    Viscoelastic::new(&block, &parameters).unwrap()
}

/// An n³ lattice (spacing 1) of one `Viscoelastic` block, with its staged history.
struct Body {
    points: PointCloud,
    bonds: BondList,
    material: Viscoelastic,
    physics: Physics,
    history: History,
    damage: Option<Vec<f32>>,
}

impl Body {
    /// Unit volumes when `seed` is `None`, else volumes in 0.8–1.2.
    fn new(n: usize, horizon: f64, lambda_i: f64, seed: Option<u64>) -> Self {
        let x = lattice(n);
        let mut rng = seed.map(Rng::new);
        let mut points = PointCloud::default();
        for p in &x {
            let volume = rng.as_mut().map_or(1.0, |r| 0.8 + 0.4 * r.uniform());
            points.push(*p, volume, 0);
        }
        let bonds = brute_force_bonds(&x, horizon);
        let mut material = viscoelastic(horizon, lambda_i);
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
        let history =
            History::allocate(Viscoelastic::DECLARATION.fields, x.len(), bonds.num_bonds());
        Self {
            points,
            bonds,
            material,
            physics,
            history,
            damage: None,
        }
    }

    /// Force density at `y`, advancing the trial history over a step of `dt`.
    fn force(&mut self, y: &[[f64; 3]], dt: f64) -> Vec<[f64; 3]> {
        self.history.set_step_duration(dt);
        let mut f = vec![[0.0; 3]; y.len()];
        self.physics.internal_force_with_damage_fixed(
            &self.bonds,
            &self.points,
            y,
            self.damage.as_deref(),
            &mut self.history,
            &mut f,
        );
        f
    }

    fn commit(&mut self) {
        self.history.each_for_tests(|f| f.commit());
    }

    fn field(&self, name: &str) -> &crate::history::Staged<f64> {
        self.history.field(name).unwrap()
    }

    /// Pure shear ε_xy = γ/2 about point `center`.
    fn pure_shear(&self, center: usize, gamma: f64) -> Vec<[f64; 3]> {
        let c = self.points.position[center];
        self.points
            .position
            .iter()
            .map(|x| {
                [
                    x[0] + 0.5 * gamma * (x[1] - c[1]),
                    x[1] + 0.5 * gamma * (x[0] - c[0]),
                    x[2],
                ]
            })
            .collect()
    }

    /// The vector force states of point `p`'s bonds at `y` over a step of `dt` from the
    /// committed history (the code the tangent differentiates).
    fn force_states(&self, p: usize, y: &[[f64; 3]], dt: f64) -> Vec<[f64; 3]> {
        let reference = ReferenceView::of(&self.bonds, &self.points);
        let (decay, beta) = step_weights(TAU, dt);
        let state = ViscoelasticForceState {
            material: &self.material,
            kernel: self.material.kernel(&reference, self.damage.as_deref()),
            deviatoric: self.field(fields::DEVIATORIC_EXTENSION).committed(),
            back: self.field(fields::DEVIATORIC_BACK_EXTENSION).committed(),
            decay,
            beta,
        };
        let mut family = Vec::new();
        family_positions(&self.bonds, y, p, &mut family);
        let mut t = vec![[0.0; 3]; self.bonds.family_size(p)];
        state.force_state(
            PointIndex {
                global: p,
                local: p,
            },
            &family,
            None,
            &mut t,
        );
        t
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

#[test]
fn the_step_weights_are_the_exact_integrator_of_the_back_extension_ode() {
    // decay = exp(−Δt/τ), β = 1 − (τ/Δt)(1 − decay): the solution of τ ė^b + e^b = e^d over a
    // step on which e^d rises linearly by 1 from 0 with e^b(0) = 0 is
    // e^b(Δt) = 1 − (τ/Δt)(1 − exp(−Δt/τ)) = β.
    let (decay, beta) = step_weights(TAU, 0.2);
    assert!((decay - (-0.4f64).exp()).abs() < 1e-16);
    assert!((beta - (1.0 - 2.5 * (1.0 - (-0.4f64).exp()))).abs() < 1e-15);
    // No time: nothing absorbed (the limit Δt → 0), and a tiny step stays accurate:
    // β ≈ Δt/(2τ) for Δt ≪ τ.
    assert_eq!(step_weights(TAU, 0.0), (1.0, 0.0));
    let (decay, beta) = step_weights(TAU, 1e-9);
    assert!((1.0 - decay) / 2e-9 - 1.0 < 1e-8);
    assert!((beta / 1e-9 - 1.0).abs() < 1e-6, "{beta}");
}

/// The centre of a 9³ lattice with δ = 3: its whole family is a full sphere.
const N: usize = 9;
const CENTER: usize = (N * N + N + 1) * (N / 2);

/// The bond of `p` to the neighbour at offset (2, 2, 0), along the stretched diagonal.
fn diagonal_bond(body: &Body, p: usize) -> usize {
    let target = p + 2 + 2 * N;
    body.bonds
        .family(p)
        .iter()
        .position(|&j| j as usize == target)
        .unwrap()
}

#[test]
fn a_step_shear_relaxes_as_the_closed_form_of_the_back_extension_ode() {
    // A shear γ applied in the first step (Δt) and held. The ODE τ ė^b + e^b = e^d with e^d
    // rising linearly to E over the first step and then held gives e^b(Δt) = βE and, after,
    // e^b(t) = E − (1 − β)E exp(−(t − Δt)/τ). The deviatoric force α(e^d − λ_i e^b) of each
    // bond is then αE[1 − λ_i + λ_i(1 − β) exp(−(t − Δt)/τ)], which relaxes from αE(1 − λ_iβ)
    // to (1 − λ_i)αE.
    let lambda_i = 0.6;
    let dt = 0.1;
    let mut body = Body::new(N, 3.0, lambda_i, None);
    let bond = diagonal_bond(&body, CENTER);
    let row = body.bonds.range(CENTER);
    let alpha = 15.0 * SHEAR / body.material.weighted_volume[CENTER];
    let y = body.pure_shear(CENTER, 1e-4);
    let (decay, beta) = step_weights(TAU, dt);
    let mut first_force = 0.0;
    let mut extensions = Vec::new();
    for step in 1..=40 {
        let t = step as f64 * dt;
        let states = body.force_states(CENTER, &y, dt);
        body.force(&y, dt);
        if step == 1 {
            extensions = body.field(fields::DEVIATORIC_EXTENSION).trial()[row.clone()].to_vec();
            first_force = magnitude(states[bond]);
        }
        let back = &body.field(fields::DEVIATORIC_BACK_EXTENSION).trial()[row.clone()];
        let relaxing = lambda_i * (1.0 - beta) * (-(t - dt) / TAU).exp();
        for (n, &e) in extensions.iter().enumerate() {
            // The recursion itself, bond by bond, against the closed form (to round-off).
            let expected = e - (1.0 - beta) * e * decay.powi(step - 1);
            assert!(
                (back[n] - expected).abs() <= 1e-12 * e.abs(),
                "step {step}, bond {n}: {} vs {expected}",
                back[n]
            );
        }
        // The bond force, from the model's force state (θ = O(γ²) in pure shear).
        let expected = alpha * extensions[bond] * (1.0 - lambda_i + relaxing);
        let measured = magnitude(states[bond]);
        assert!(
            (measured / expected - 1.0).abs() < 1e-3,
            "step {step}: {measured} vs {expected}"
        );
        body.commit();
    }
    // After 8τ the force has relaxed to (1 − λ_i)/(1 − λ_iβ) of the first step's.
    let last = magnitude(body.force_states(CENTER, &y, dt)[bond]);
    let ratio = last / first_force;
    let expected = (1.0 - lambda_i + lambda_i * (1.0 - beta) * (-40.0 * dt / TAU).exp())
        / (1.0 - lambda_i * beta);
    assert!(
        (ratio / expected - 1.0).abs() < 1e-3,
        "{ratio} vs {expected}"
    );
    assert!(ratio < 0.45, "{ratio}");
}

#[test]
fn without_relaxation_the_model_is_the_linear_peridynamic_solid() {
    let mut body = Body::new(6, 1.8, 0.0, Some(9));
    let reference = ReferenceView::of(&body.bonds, &body.points);
    let mut lps = LinearPeridynamicSolid::new(
        &crate::material::BlockInput {
            density: 2.0,
            horizon: 1.8,
            influence: InfluenceFunction::One,
        },
        &crate::material::ElasticConstants {
            bulk_modulus: BULK,
            shear_modulus: SHEAR,
        },
    )
    .unwrap();
    crate::material::set_up(
        &mut lps,
        &reference,
        (0..body.points.len() as u32).collect(),
    );
    let mut physics = Physics::new(
        vec![BlockPhysics {
            material: Box::new(lps),
            damage: None,
        }],
        &body.points,
        &body.bonds,
    );
    for (step, amplitude) in [0.05, 0.1, 0.02].into_iter().enumerate() {
        let y = perturbed(&body, 4 + step as u64, amplitude);
        let viscous = body.force(&y, 0.3);
        body.commit();
        let mut elastic = vec![[0.0; 3]; y.len()];
        physics.internal_force_with_damage_fixed(
            &body.bonds,
            &body.points,
            &y,
            None,
            &mut History::empty(),
            &mut elastic,
        );
        let scale = elastic.iter().map(|f| magnitude(*f)).fold(0.0, f64::max);
        assert!(scale > 0.0);
        for (a, b) in viscous.iter().zip(&elastic) {
            let difference = magnitude([a[0] - b[0], a[1] - b[1], a[2] - b[2]]);
            assert!(difference < 1e-12 * scale, "step {step}: {difference}");
        }
    }
}

#[test]
fn rigid_motion_gives_no_force() {
    let mut body = Body::new(6, 1.8, 0.7, Some(3));
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
    for _ in 0..3 {
        let force = body.force(&y, 0.2);
        let largest = force.iter().map(|f| magnitude(*f)).fold(0.0, f64::max);
        // Round-off of |Y| − ζ (≈1e-15 per bond) times α ζ V over a family.
        assert!(largest < 1e-11, "{largest}");
        body.commit();
    }
}

#[test]
fn the_forces_conserve_linear_and_angular_momentum_while_relaxing() {
    let mut body = Body::new(6, 1.8, 0.7, Some(8));
    body.force(&perturbed(&body, 1, 0.05), 0.2);
    body.commit();
    let y = perturbed(&body, 2, 0.05);
    let force = body.force(&y, 0.2);
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
    assert!(magnitude(linear) < 1e-13 * scale, "{linear:?}");
    assert!(magnitude(angular) < 1e-13 * scale, "{angular:?}");
}

#[test]
fn a_rejected_step_leaves_the_committed_history_and_the_next_trial_unchanged() {
    let make = || Body::new(6, 1.8, 0.7, Some(5));
    let (mut body, mut twin) = (make(), make());
    for b in [&mut body, &mut twin] {
        let y = perturbed(b, 1, 0.05);
        b.force(&y, 0.2);
        b.commit();
    }
    let committed = body.history.clone();
    body.force(&perturbed(&body, 2, 0.1), 0.2);
    assert_ne!(body.history, committed);
    body.history.each_for_tests(|f| f.restore());
    body.history.set_step_duration(committed.step_duration());
    assert_eq!(body.history, committed);
    let y = perturbed(&body, 3, 0.05);
    assert_eq!(body.force(&y, 0.2), twin.force(&y, 0.2));
    assert_eq!(body.history, twin.history);
}

/// max |J_AD − J_FD| / max |J_FD| over a few columns, the FD tangent from central differences
/// of the force itself (each probe advancing the trial history from the same committed one).
fn tangent_error(body: &mut Body, y: &[[f64; 3]], dt: f64) -> f64 {
    let pattern = Arc::new(BlockPattern::two_hop(&body.bonds));
    let mut tangent = BlockTangent::zeros(pattern);
    body.history.set_step_duration(dt);
    body.physics
        .tangent_with(
            &body.bonds,
            &body.points,
            Configuration {
                position: y,
                bond_damage: body.damage.as_deref(),
                history: &body.history,
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
            let (fp, fm) = (body.force(&plus, dt), body.force(&minus, dt));
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
    for damaged in [false, true] {
        let mut body = Body::new(6, 1.8, 0.7, Some(11));
        if damaged {
            let mut rng = Rng::new(4);
            let bonds = &body.bonds;
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
            body.damage = Some(damage);
        }
        // A committed step with history, then the tangent of the next one; the step's Δt
        // enters through β.
        body.force(&perturbed(&body, 2, 0.02), 0.2);
        body.commit();
        let y = perturbed(&body, 9, 0.05);
        let error = tangent_error(&mut body, &y, 0.2);
        assert!(error < 1e-6, "damaged {damaged}: relative error {error}");
    }
}
