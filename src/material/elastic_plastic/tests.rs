//! Checks of `Elastic Plastic`: the yield point against the continuum identity, perfect
//! plasticity, elastic unloading and the permanent plastic extension under homogeneous shear of
//! an interior point; rigid motion, momentum, staged history, and the tangent against finite
//! differences.

use std::sync::Arc;

use super::*;
use crate::material::{InfluenceFunction, LinearPeridynamicSolid};
use crate::model::test_support::{brute_force_bonds, lattice, Rng};
use crate::model::PointCloud;
use crate::physics::{BlockPhysics, Configuration, Physics};
use crate::tangent::BlockPattern;

const BULK: f64 = 3.0;
const SHEAR: f64 = 1.0;

/// ρ = 2, `horizon`, ω = 1.
pub(super) fn block(horizon: f64) -> BlockInput {
    BlockInput {
        density: 2.0,
        horizon,
        influence: InfluenceFunction::One,
    }
}

/// K = BULK, μ = SHEAR, σ_y `yield_stress` (infinite when `disabled`), no hardening.
pub(super) fn input(yield_stress: f64, disabled: bool) -> PlasticityInput {
    PlasticityInput {
        elastic: ElasticConstants {
            bulk_modulus: BULK,
            shear_modulus: SHEAR,
        },
        yield_stress,
        disabled,
        hardening_modulus: 0.0,
        planar_thickness: None,
        shear_correction: false,
    }
}

/// `Elastic Plastic` of [`block`] and [`input`].
pub(super) fn elastic_plastic(horizon: f64, yield_stress: f64, disabled: bool) -> ElasticPlastic {
    ElasticPlastic::of_model(
        &ElasticPlastic::DECLARATION,
        &block(horizon),
        &input(yield_stress, disabled),
    )
    .unwrap()
}

/// An n³ lattice (spacing 1) of one `Elastic Plastic` block, with its staged history.
pub(super) struct Body {
    pub(super) points: PointCloud,
    pub(super) bonds: BondList,
    pub(super) material: ElasticPlastic,
    pub(super) physics: Physics,
    pub(super) history: History,
    pub(super) damage: Option<Vec<f32>>,
}

impl Body {
    /// Unit volumes when `seed` is `None`, else volumes in 0.8–1.2.
    fn new(n: usize, horizon: f64, yield_stress: f64, seed: Option<u64>) -> Self {
        let material = elastic_plastic(horizon, yield_stress, false);
        Self::of(n, horizon, seed, material)
    }

    /// The body of [`Body::new`] made of `material` (not set up yet).
    pub(super) fn of(
        n: usize,
        horizon: f64,
        seed: Option<u64>,
        mut material: ElasticPlastic,
    ) -> Self {
        let x = lattice(n);
        let mut rng = seed.map(Rng::new);
        let mut points = PointCloud::default();
        for p in &x {
            let volume = rng.as_mut().map_or(1.0, |r| 0.8 + 0.4 * r.uniform());
            points.push(*p, volume, 0);
        }
        let bonds = brute_force_bonds(&x, horizon);
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
        let history = History::allocate(
            ElasticPlastic::DECLARATION.fields,
            x.len(),
            bonds.num_bonds(),
        );
        Self {
            points,
            bonds,
            material,
            physics,
            history,
            damage: None,
        }
    }

    /// Force density at `y`, advancing the trial history from the committed one.
    pub(super) fn force(&mut self, y: &[[f64; 3]]) -> Vec<[f64; 3]> {
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

    pub(super) fn commit(&mut self) {
        self.history.each_for_tests(|f| f.commit());
    }

    pub(super) fn field(&self, name: &str) -> &Staged<f64> {
        self.history.field(name).unwrap()
    }

    /// The vector force states T⟨ξ⟩ of point `p`'s bonds at `y`, from the committed history
    /// (the code the tangent differentiates).
    pub(super) fn force_states(&self, p: usize, y: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let reference = ReferenceView::of(&self.bonds, &self.points);
        let kernel = ElasticPlasticForceState {
            kernel: self.material.kernel(
                &reference,
                self.damage.as_deref(),
                self.field(fields::LAMBDA).committed(),
            ),
            committed: self.field(fields::DEVIATORIC_PLASTIC_EXTENSION).committed(),
        };
        let mut family = Vec::new();
        family_positions(&self.bonds, y, p, &mut family);
        let mut t = vec![[0.0; 3]; self.bonds.family_size(p)];
        kernel.force_state(
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

    /// The return map of point `p` at `y` from the committed history.
    pub(super) fn response(&self, p: usize, y: &[[f64; 3]]) -> PointResponse<f64> {
        let reference = ReferenceView::of(&self.bonds, &self.points);
        let kernel = self.material.kernel(
            &reference,
            self.damage.as_deref(),
            self.field(fields::LAMBDA).committed(),
        );
        let point = PointIndex {
            global: p,
            local: p,
        };
        let mut family = Vec::new();
        family_positions(&self.bonds, y, p, &mut family);
        let committed = self.field(fields::DEVIATORIC_PLASTIC_EXTENSION).committed();
        kernel.respond(
            point,
            &family,
            kernel.alpha(point).unwrap(),
            &committed[self.bonds.range(p)],
        )
    }

    /// Pure shear ε_xy = γ/2 about point `center`: u = (γ/2)(y − y_c, x − x_c, 0).
    pub(super) fn pure_shear(&self, center: usize, gamma: f64) -> Vec<[f64; 3]> {
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
}

use crate::history::Staged;

/// The centre of a 13³ lattice with δ = 6: its whole family (about 900 bonds) is a full sphere.
pub(super) const N: usize = 13;
pub(super) const CENTER: usize = (N * N + N + 1) * (N / 2);
pub(super) const HORIZON: f64 = 6.0;
pub(super) const YIELD_STRESS: f64 = 1e-3;

/// J2 (von Mises) yield in pure shear: σ_vm = √3 τ = √3 μ γ (Hooke τ = μγ), so the continuum
/// yields at γ_Y = σ_y/(√3 μ); ψ₀ = 25σ_y²/(8πδ⁵) is built to reproduce it (module docs,
/// Mitchell 2011 §4).
pub(super) fn continuum_yield_shear() -> f64 {
    YIELD_STRESS / (3.0f64.sqrt() * SHEAR)
}

pub(super) fn magnitude(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// The bond of point `p` to the neighbour at offset (2, 2, 0): along the stretched diagonal of
/// the shear.
pub(super) fn diagonal_bond(body: &Body, p: usize) -> usize {
    let target = p + 2 + 2 * N;
    body.bonds
        .family(p)
        .iter()
        .position(|&j| j as usize == target)
        .unwrap()
}

#[test]
fn psi0_is_the_closed_form_in_3d_and_in_a_plane() {
    // 25·2²/(8π·0.5⁵) = 100·32/(8π) = 400/π; 75·2²/(8π·0.1·0.5⁴) = 300/(0.05π) = 6000/π.
    let pi = std::f64::consts::PI;
    assert!((yield_value(2.0, 0.5, None) / (400.0 / pi) - 1.0).abs() < 1e-15);
    assert!((yield_value(2.0, 0.5, Some(0.1)) / (6000.0 / pi) - 1.0).abs() < 1e-14);
}

#[test]
fn an_interior_point_in_pure_shear_yields_where_psi0_says() {
    let mut body = Body::new(N, HORIZON, YIELD_STRESS, None);
    let gamma_y = continuum_yield_shear();
    // In a plastic step t^d = scale · t^d_tr with scale = √(2ψ₀)/‖t^d_tr‖, and ‖t^d_tr‖ grows in
    // proportion to γ from a fresh history, so the discrete yield shear is γ · scale.
    let probe = 2.0 * gamma_y;
    let response = body.response(CENTER, &body.pure_shear(CENTER, probe));
    assert!(response.delta_lambda > 0.0);
    let discrete = probe * response.scale;
    // The lattice sums replace the integrals of the identity (a sphere of radius 6 cells, whose
    // quadrature error here is 0.08 %).
    assert!(
        (discrete / gamma_y - 1.0).abs() < 0.005,
        "discrete yield shear {discrete} vs continuum {gamma_y}"
    );
    // The staged path agrees: no plastic multiplier just below, some just above.
    body.force(&body.pure_shear(CENTER, 0.99 * discrete));
    assert_eq!(body.field(fields::LAMBDA).trial()[CENTER], 0.0);
    body.force(&body.pure_shear(CENTER, 1.01 * discrete));
    assert!(body.field(fields::LAMBDA).trial()[CENTER] > 0.0);
}

/// Monotonic pure shear in steps of γ_Y/4 up to 3γ_Y, each step committed; returns the body and
/// the diagonal bond's force magnitude after each step.
fn load_in_steps() -> (Body, Vec<f64>) {
    let mut body = Body::new(N, HORIZON, YIELD_STRESS, None);
    let bond = diagonal_bond(&body, CENTER);
    let gamma_y = continuum_yield_shear();
    let mut forces = Vec::new();
    for k in 1..=12 {
        let y = body.pure_shear(CENTER, 0.25 * k as f64 * gamma_y);
        body.force(&y);
        forces.push(magnitude(body.force_states(CENTER, &y)[bond]));
        body.commit();
    }
    (body, forces)
}

#[test]
fn perfect_plasticity_holds_the_force_after_yield() {
    let (body, forces) = load_in_steps();
    // Elastic steps (γ ≤ 3γ_Y/4 < discrete yield): the force grows in proportion to γ.
    for k in 1..3 {
        let ratio = forces[k] / forces[0] / (k + 1) as f64;
        assert!((ratio - 1.0).abs() < 1e-3, "step {k}: {ratio}");
    }
    // Plastic steps (γ ≥ 3γ_Y/2): under proportional loading t^d stays on the yield surface
    // with a fixed direction, so the force no longer changes (to the second order in γ).
    for k in 6..12 {
        let change = forces[k] / forces[5] - 1.0;
        assert!(change.abs() < 1e-3, "step {k}: relative change {change}");
    }
    // Capped: at 3γ_Y/2 the elastic response would be 6× the first step's force; yield near γ_Y
    // keeps it near 4×.
    assert!(forces[5] < 0.8 * 6.0 * forces[0], "{forces:?}");
    assert!(body.field(fields::LAMBDA).committed()[CENTER] > 0.0);
}

#[test]
fn unloading_is_elastic_and_the_plastic_extension_remains() {
    let (mut body, forces) = load_in_steps();
    let bond = diagonal_bond(&body, CENTER);
    let gamma_y = continuum_yield_shear();
    let lambda = body.field(fields::LAMBDA).committed()[CENTER];
    let row = body.bonds.range(CENTER);
    let plastic = body.field(fields::DEVIATORIC_PLASTIC_EXTENSION).committed()[row.start + bond];

    // Back by γ_Y/2: no new plastic flow, and the force falls with the elastic slope of the
    // first step (γ_Y/4 gave forces[0]).
    let y = body.pure_shear(CENTER, 2.5 * gamma_y);
    body.force(&y);
    assert_eq!(body.field(fields::LAMBDA).trial()[CENTER], lambda);
    let unloaded = magnitude(body.force_states(CENTER, &y)[bond]);
    let slope = (forces[11] - unloaded) / (0.5 * gamma_y);
    let elastic_slope = forces[0] / (0.25 * gamma_y);
    assert!(
        (slope / elastic_slope - 1.0).abs() < 1e-3,
        "{slope} vs {elastic_slope}"
    );

    // Back to the shear γ₀ = 3γ_Y − γ* (γ* the discrete yield shear), less than the elastic
    // range 2γ* away: the deviatoric force of proportional loading vanishes there, and what is
    // left of the bond's extension is its plastic part, e^{dp} = e(γ₀) ≈ ζ γ₀/2 (e ≈ ζ M·εM with
    // M = (1, 1, 0)/√2 and ε_xy = γ/2), with no new plastic flow.
    let fresh = Body::new(N, HORIZON, YIELD_STRESS, None);
    let probe = 2.0 * gamma_y;
    let discrete_yield = probe
        * fresh
            .response(CENTER, &fresh.pure_shear(CENTER, probe))
            .scale;
    let set = 3.0 * gamma_y - discrete_yield;
    let y = body.pure_shear(CENTER, set);
    body.force(&y);
    assert_eq!(body.field(fields::LAMBDA).trial()[CENTER], lambda);
    let trial = body.field(fields::DEVIATORIC_PLASTIC_EXTENSION).trial()[row.start + bond];
    assert_eq!(trial, plastic);
    let remaining = magnitude(body.force_states(CENTER, &y)[bond]);
    assert!(
        remaining < 2e-3 * forces[11],
        "{remaining} vs {}",
        forces[11]
    );
    let zeta = body.bonds.reference_length[row.start + bond];
    let expected = zeta * set / 2.0;
    assert!(
        (plastic / expected - 1.0).abs() < 2e-3,
        "{plastic} vs {expected}"
    );
}

#[test]
fn a_rejected_step_leaves_the_committed_history_and_the_next_trial_unchanged() {
    let gamma_y = continuum_yield_shear();
    let mut body = Body::new(7, 2.5, YIELD_STRESS, Some(5));
    let mut twin = Body::new(7, 2.5, YIELD_STRESS, Some(5));
    let center = (7 * 7 + 7 + 1) * 3;
    for b in [&mut body, &mut twin] {
        b.force(&b.pure_shear(center, 2.0 * gamma_y));
        b.commit();
    }
    let committed = body.history.clone();
    // A trial step that yields further, then rejected (the state restores its staged fields).
    body.force(&body.pure_shear(center, 4.0 * gamma_y));
    assert!(
        body.field(fields::LAMBDA).trial()[center]
            > committed.field(fields::LAMBDA).unwrap().trial()[center]
    );
    body.history.each_for_tests(|f| f.restore());
    assert_eq!(body.history, committed);
    // The retried step is exactly the one of a run that never tried the rejected one.
    let y = body.pure_shear(center, 3.0 * gamma_y);
    assert_eq!(body.force(&y), twin.force(&y));
    assert_eq!(body.history, twin.history);
}

#[test]
fn rigid_motion_gives_no_force() {
    let mut body = Body::new(6, 1.8, YIELD_STRESS, Some(3));
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
    // Round-off of |Y| − ζ (≈1e-15 per bond) times α ζ V over a family.
    assert!(largest < 1e-11, "{largest}");
    assert!(body.field(fields::LAMBDA).trial().iter().all(|&l| l == 0.0));
}

pub(super) fn perturbed(body: &Body, seed: u64, amplitude: f64) -> Vec<[f64; 3]> {
    let mut rng = Rng::new(seed);
    body.points
        .position
        .iter()
        .map(|x| x.map(|c| c * 1.002 + amplitude * (rng.uniform() - 0.5)))
        .collect()
}

#[test]
fn the_forces_conserve_linear_and_angular_momentum_while_yielding() {
    let mut body = Body::new(6, 1.8, 1e-3, Some(8));
    let y = perturbed(&body, 2, 0.05);
    let force = body.force(&y);
    let yielding = body
        .field(fields::LAMBDA)
        .trial()
        .iter()
        .filter(|&&l| l > 0.0)
        .count();
    assert!(yielding > body.points.len() / 4, "{yielding} points yield");
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
fn without_plasticity_the_model_is_the_linear_peridynamic_solid() {
    let body = Body::new(6, 1.8, 1e-3, Some(9));
    let reference = ReferenceView::of(&body.bonds, &body.points);
    let mut disabled = elastic_plastic(1.8, 1e-3, true);
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
    let all: Vec<u32> = (0..body.points.len() as u32).collect();
    crate::material::set_up(&mut disabled, &reference, all.clone());
    crate::material::set_up(&mut lps, &reference, all);
    let force_of = |material: Box<dyn Material>, history: &mut History| {
        let mut physics = Physics::new(
            vec![BlockPhysics {
                material,
                damage: None,
            }],
            &body.points,
            &body.bonds,
        );
        let y = perturbed(&body, 4, 0.1);
        let mut f = vec![[0.0; 3]; y.len()];
        physics.internal_force_with_damage_fixed(
            &body.bonds,
            &body.points,
            &y,
            None,
            history,
            &mut f,
        );
        let mut energy = vec![0.0; y.len()];
        physics.stored_energy_density(&body.bonds, &body.points, &y, None, history, &mut energy);
        (f, energy)
    };
    let mut history = History::allocate(
        ElasticPlastic::DECLARATION.fields,
        body.points.len(),
        body.bonds.num_bonds(),
    );
    let (plastic, plastic_energy) = force_of(Box::new(disabled), &mut history);
    let (elastic, elastic_energy) = force_of(Box::new(lps), &mut History::empty());
    let scale = elastic.iter().map(|f| magnitude(*f)).fold(0.0, f64::max);
    for (a, b) in plastic.iter().zip(&elastic) {
        assert!(magnitude([a[0] - b[0], a[1] - b[1], a[2] - b[2]]) < 1e-12 * scale);
    }
    // No plastic extension: the stored energy is LPS's kθ²/2 + (α/2) Σ (e^d)² V_j.
    let energy_scale = elastic_energy.iter().fold(0.0f64, |m, w| m.max(w.abs()));
    assert!(energy_scale > 0.0);
    for (a, b) in plastic_energy.iter().zip(&elastic_energy) {
        assert!((a - b).abs() < 1e-12 * energy_scale, "{a} vs {b}");
    }
    assert!(history
        .field(fields::LAMBDA)
        .unwrap()
        .trial()
        .iter()
        .all(|&l| l == 0.0));
}

/// max |J_AD − J_FD| / max |J_FD| over a few columns, the FD tangent from central differences
/// of the force itself (each probe advancing the trial history from the same committed one).
pub(super) fn tangent_error(body: &mut Body, y: &[[f64; 3]]) -> f64 {
    let pattern = Arc::new(BlockPattern::two_hop(&body.bonds));
    let mut tangent = BlockTangent::zeros(pattern);
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

/// A body with a committed plastic step and a trial state that yields at most points.
fn yielding_body(damaged: bool) -> (Body, Vec<[f64; 3]>) {
    let material = elastic_plastic(1.8, 1e-3, false);
    yielding_body_of(damaged, material)
}

/// [`yielding_body`] made of `material` (6³ lattice, δ = 1.8, σ_y = 1e-3, not set up yet).
pub(super) fn yielding_body_of(damaged: bool, material: ElasticPlastic) -> (Body, Vec<[f64; 3]>) {
    let mut body = Body::of(6, 1.8, Some(11), material);
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
    let start = perturbed(&body, 2, 0.02);
    body.force(&start);
    body.commit();
    let y = perturbed(&body, 9, 0.05);
    body.force(&y);
    let yielding = body
        .field(fields::LAMBDA)
        .trial()
        .iter()
        .zip(body.field(fields::LAMBDA).committed())
        .filter(|(t, c)| t > c)
        .count();
    assert!(yielding > body.points.len() / 4, "{yielding} points yield");
    (body, y)
}

#[test]
fn the_automatic_differentiation_tangent_matches_finite_differences_while_yielding() {
    let (mut body, y) = yielding_body(false);
    let error = tangent_error(&mut body, &y);
    assert!(error < 1e-5, "relative error {error}");
}

#[test]
fn the_tangent_matches_finite_differences_with_broken_bonds() {
    let (mut body, y) = yielding_body(true);
    let error = tangent_error(&mut body, &y);
    assert!(error < 1e-5, "relative error {error}");
}
