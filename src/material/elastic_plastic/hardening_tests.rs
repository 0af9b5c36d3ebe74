//! Checks of `Elastic Plastic Hardening`: the closed-form root of the hardening cubic, the
//! reduction to `Elastic Plastic` at H = 0, hardening along ψ₀ + Hλ under homogeneous shear of
//! an interior point with elastic unloading and a permanent plastic extension, the
//! shear-correction factor, rigid motion, momentum, staged history and the tangent.

use super::super::tests::{
    block, continuum_yield_shear, diagonal_bond, elastic_plastic, input, magnitude, perturbed,
    tangent_error, yielding_body_of, Body, CENTER, HORIZON, N, YIELD_STRESS,
};
use super::super::{fields, yield_value, ElasticPlastic, PlasticityInput};
use super::*;

const SHEAR: f64 = 1.0;

/// `Elastic Plastic Hardening` with hardening modulus `h` and the shear correction `on`.
fn hardening(horizon: f64, h: f64, on: bool) -> ElasticPlastic {
    let parameters = PlasticityInput {
        hardening_modulus: h,
        shear_correction: on,
        ..input(YIELD_STRESS, false)
    };
    ElasticPlasticHardening::material(&block(horizon), &parameters).unwrap()
}

/// The consistency condition of a plastic step, `(P + HΔλ)(1 + αΔλ)² − T`, relative to T.
fn consistency_residual(trial: f64, surface: f64, h: f64, alpha: f64, delta: f64) -> f64 {
    let hardening = h * alpha;
    ((surface + hardening * delta) * (1.0 + alpha * delta).powi(2) - trial) / trial
}

#[test]
fn the_closed_form_root_solves_the_hardening_cubic_in_both_branches() {
    // Cases of T/P from just past yield to far past it and h/P from tiny to large, which
    // exercise both the one-real-root (Cardano) and the three-real-root (trigonometric)
    // branch; the discriminant's sign is recorded to prove both ran.
    let alpha = 0.3;
    let mut branches = [0usize; 2];
    for &ratio in &[1.000001, 1.01, 1.5, 4.0, 100.0, 1e6] {
        for &h_over_p in &[1e-9, 1e-4, 0.1, 1.0, 10.0, 1e4] {
            let surface = 2.5;
            let trial = ratio * surface;
            let h = h_over_p * surface;
            let (p, q): (f64, f64) = (-(surface - h) / trial, -h / trial);
            branches[usize::from((q / 2.0).powi(2) + (p / 3.0).powi(3) > 0.0)] += 1;
            let z = return_scale(trial, surface, h);
            assert!(
                z > 0.0 && z <= 1.0,
                "z = {z} for T/P {ratio}, h/P {h_over_p}"
            );
            let delta = (1.0 / z - 1.0) / alpha;
            assert!(delta >= 0.0);
            // The cubic in z to round-off (relative to the size of its terms).
            let terms = trial * z.powi(3) + (surface - h).abs() * z + h;
            let residual = (trial * z.powi(3) - (surface - h) * z - h) / terms;
            assert!(
                residual.abs() < 1e-15,
                "T/P {ratio}, h/P {h_over_p}: residual {residual}"
            );
            // The positive root is unique (the cubic grows for Δλ ≥ 0), so bisection on the
            // Δλ form finds the same one.
            let (mut low, mut high) = (0.0, delta.max(1.0) * 4.0);
            for _ in 0..200 {
                let mid = 0.5 * (low + high);
                if consistency_residual(trial, surface, h, alpha, mid) > 0.0 {
                    high = mid;
                } else {
                    low = mid;
                }
            }
            // Compared as αΔλ = 1/z − 1: z is exact to round-off, so αΔλ carries an absolute
            // error of a few ε (a relative one of ε/(αΔλ) just past yield).
            assert!(
                (alpha * (delta - low)).abs() <= 1e-14 * (1.0 + alpha * low),
                "closed form {delta} vs bisection {low}"
            );
        }
    }
    assert!(branches[0] > 0 && branches[1] > 0, "{branches:?}");
}

#[test]
fn the_dual_root_carries_the_implicit_derivative() {
    use num_dual::Dual64;
    // dz/dT from the implicit function theorem on φ(z, T) = T z³ − (P − h) z − h = 0:
    // dz/dT = −z³ / (3T z² − (P − h)).
    let (surface, h) = (2.0, 0.7);
    let trial = Dual64::new(9.0, 1.0);
    let z = return_scale(trial, surface, h);
    let value = z.re;
    let expected = -value.powi(3) / (3.0 * 9.0 * value * value - (surface - h));
    assert!(
        (z.eps / expected - 1.0).abs() < 1e-12,
        "{} vs {expected}",
        z.eps
    );
}

#[test]
fn with_zero_hardening_the_model_is_elastic_plastic_bitwise() {
    let mut plastic = Body::of(6, 1.8, Some(4), elastic_plastic(1.8, YIELD_STRESS, false));
    let mut hard = Body::of(6, 1.8, Some(4), hardening(1.8, 0.0, false));
    assert_eq!(
        hard.material.block().declaration().deck_name,
        "Elastic Plastic Hardening"
    );
    for (step, amplitude) in [0.02, 0.05, 0.03].into_iter().enumerate() {
        let y = perturbed(&plastic, 7 + step as u64, amplitude);
        assert_eq!(plastic.force(&y), hard.force(&y), "step {step}");
        assert_eq!(plastic.history, hard.history, "step {step}");
        plastic.commit();
        hard.commit();
    }
    assert!(plastic
        .field(fields::LAMBDA)
        .committed()
        .iter()
        .any(|&l| l > 0.0));
}

#[test]
fn a_small_hardening_modulus_approaches_elastic_plastic() {
    // The cubic's root is continuous in H: with H → 0 the plastic multiplier of a step tends
    // to Elastic Plastic's (the H = 0 branch of the kernel), the difference of order H.
    let mut plastic = Body::of(6, 1.8, Some(4), elastic_plastic(1.8, YIELD_STRESS, false));
    let y = perturbed(&plastic, 7, 0.05);
    plastic.force(&y);
    let reference = plastic.field(fields::LAMBDA).trial().to_vec();
    // H/(ψ₀α_i) ≤ `scale` at every point with α = 15μ/m at the largest m.
    let largest = plastic
        .material
        .weighted_volume
        .iter()
        .fold(0.0, |a: f64, &m| a.max(m));
    let alpha = 15.0 * SHEAR / largest;
    let psi = yield_value(YIELD_STRESS, 1.8, None);
    // (P + HΔλ)(1 + αΔλ)² = T moves P by (H/α)·αΔλ: the change in λ is of first order in H.
    let mut differences = Vec::new();
    for scale in [1e-4, 1e-6, 1e-8] {
        let mut hard = Body::of(6, 1.8, Some(4), hardening(1.8, scale * psi * alpha, false));
        hard.force(&y);
        let lambda = hard.field(fields::LAMBDA).trial();
        let worst = reference
            .iter()
            .zip(lambda)
            .filter(|(r, _)| **r > 0.0)
            .map(|(r, l)| (l / r - 1.0).abs())
            .fold(0.0, f64::max);
        assert!(worst > 0.0 && worst < 1.0, "H/(ψ₀α) = {scale}: {worst}");
        differences.push(worst);
    }
    for pair in differences.windows(2) {
        let order = pair[1] / pair[0];
        assert!((0.005..0.02).contains(&order), "{differences:?}");
    }
}

/// α(e − θζ/3 − e^{dp}) of every bond of `p` at `y`, from the stored trial plastic extension
/// (independent of the return map: the force form of the module docs).
fn deviatoric_forces(body: &Body, p: usize, y: &[[f64; 3]]) -> Vec<f64> {
    let alpha = body.material.correction.get(p).copied().unwrap_or(1.0) * 15.0 * SHEAR
        / body.material.weighted_volume[p];
    let range = body.bonds.range(p);
    let plastic = &body.field(fields::DEVIATORIC_PLASTIC_EXTENSION).trial()[range.clone()];
    let stretch = |b: usize| {
        let j = body.bonds.neighbor[b] as usize;
        magnitude([0, 1, 2].map(|k| y[j][k] - y[p][k])) - body.bonds.reference_length[b]
    };
    let m = body.material.weighted_volume[p];
    let theta: f64 = range
        .clone()
        .map(|b| {
            let j = body.bonds.neighbor[b] as usize;
            3.0 * body.bonds.reference_length[b] * stretch(b) * body.points.volume[j] / m
        })
        .sum();
    range
        .enumerate()
        .map(|(n, b)| {
            alpha * (stretch(b) - theta * body.bonds.reference_length[b] / 3.0 - plastic[n])
        })
        .collect()
}

/// Pure shear in steps of γ_Y/4 up to 3γ_Y of the centre of the 13³ lattice (δ = 6, no shear
/// correction), hardening modulus H = ψ₀α (so λ = 1/α doubles ψ); returns the body, H and per
/// step (λ, ‖t^d‖²/2, the diagonal bond's force).
fn harden_in_steps() -> (Body, f64, Vec<(f64, f64, f64)>) {
    let psi = yield_value(YIELD_STRESS, HORIZON, None);
    let probe = Body::of(N, HORIZON, None, hardening(HORIZON, 0.0, false));
    let alpha = 15.0 * SHEAR / probe.material.weighted_volume[CENTER];
    let h = psi * alpha;
    let mut body = Body::of(N, HORIZON, None, hardening(HORIZON, h, false));
    let bond = diagonal_bond(&body, CENTER);
    let gamma_y = continuum_yield_shear();
    let mut steps = Vec::new();
    for k in 1..=12 {
        let y = body.pure_shear(CENTER, 0.25 * k as f64 * gamma_y);
        body.force(&y);
        let td = deviatoric_forces(&body, CENTER, &y);
        let range = body.bonds.range(CENTER);
        let norm: f64 = td
            .iter()
            .zip(range)
            .map(|(t, b)| t * t * body.points.volume[body.bonds.neighbor[b] as usize])
            .sum();
        let lambda = body.field(fields::LAMBDA).trial()[CENTER];
        steps.push((
            lambda,
            0.5 * norm,
            magnitude(body.force_states(CENTER, &y)[bond]),
        ));
        body.commit();
    }
    (body, h, steps)
}

#[test]
fn an_interior_point_hardens_along_psi0_plus_h_lambda() {
    let (_, h, steps) = harden_in_steps();
    let psi = yield_value(YIELD_STRESS, HORIZON, None);
    let plastic: Vec<_> = steps.iter().filter(|s| s.0 > 0.0).collect();
    assert!(plastic.len() >= 6, "{steps:?}");
    for (lambda, energy, _) in &plastic {
        // On the yield surface after every plastic step: ‖t^d‖²/2 = ψ₀ + Hλ.
        let surface = psi + h * lambda;
        assert!(
            (energy / surface - 1.0).abs() < 1e-10,
            "‖t^d‖²/2 = {energy} vs ψ₀ + Hλ = {surface}"
        );
    }
    // λ grows at every plastic step and the surface with it (ψ doubles at λ = 1/α here).
    for pair in plastic.windows(2) {
        assert!(pair[1].0 > pair[0].0);
    }
    // Under proportional shear every bond's deviatoric force keeps its direction, so the
    // diagonal bond's force (θ = O(γ²): pure shear) scales as ‖t^d‖ = √(2(ψ₀ + Hλ)).
    let first = plastic[0];
    for step in &plastic[1..] {
        let expected = ((psi + h * step.0) / (psi + h * first.0)).sqrt();
        let measured = step.2 / first.2;
        assert!(
            (measured / expected - 1.0).abs() < 2e-3,
            "force ratio {measured} vs √ψ ratio {expected}"
        );
    }
    // Elastic steps below yield: λ stays 0.
    assert_eq!(steps[0].0, 0.0);
}

#[test]
fn hardening_unloads_elastically_and_keeps_its_plastic_extension() {
    let (mut body, _, steps) = harden_in_steps();
    let bond = diagonal_bond(&body, CENTER);
    let gamma_y = continuum_yield_shear();
    let lambda = body.field(fields::LAMBDA).committed()[CENTER];
    let row = body.bonds.range(CENTER);
    let plastic =
        body.field(fields::DEVIATORIC_PLASTIC_EXTENSION).committed()[row.clone()].to_vec();
    // Back by γ_Y/2: no new plastic flow, the plastic extension stays, and the force falls
    // with the elastic slope of the first step (γ_Y/4 gave steps[0].2).
    let y = body.pure_shear(CENTER, 2.5 * gamma_y);
    body.force(&y);
    assert_eq!(body.field(fields::LAMBDA).trial()[CENTER], lambda);
    assert_eq!(
        &body.field(fields::DEVIATORIC_PLASTIC_EXTENSION).trial()[row.clone()],
        plastic.as_slice()
    );
    let unloaded = magnitude(body.force_states(CENTER, &y)[bond]);
    let slope = (steps[11].2 - unloaded) / (0.5 * gamma_y);
    let elastic_slope = steps[0].2 / (0.25 * gamma_y);
    assert!(
        (slope / elastic_slope - 1.0).abs() < 1e-3,
        "{slope} vs {elastic_slope}"
    );
    // The plastic extension is what remains: at the shear where the deviatoric force of the
    // diagonal bond vanishes, its extension is e^{dp} (θ = O(γ²) there).
    let td = deviatoric_forces(&body, CENTER, &y)[bond];
    let elastic_part = td / (15.0 * SHEAR / body.material.weighted_volume[CENTER]);
    let zeta = body.bonds.reference_length[row.start + bond];
    // e ≈ ζγ/2 along the diagonal (ε_xy = γ/2, M = (1, 1, 0)/√2): e − e^{dp} = elastic part.
    let set = 2.0 * (2.5 * gamma_y * zeta / 2.0 - elastic_part) / zeta;
    let y = body.pure_shear(CENTER, set);
    body.force(&y);
    assert_eq!(body.field(fields::LAMBDA).trial()[CENTER], lambda);
    let remaining = deviatoric_forces(&body, CENTER, &y)[bond];
    assert!(remaining.abs() < 2e-3 * td.abs(), "{remaining} vs {td}");
    assert!(plastic[bond] > 0.0);
}

#[test]
fn the_shear_correction_restores_the_shear_modulus_of_a_lattice_point() {
    // A 7³ lattice with δ = 2.2: the centre's family is the lattice cut by the sphere, whose
    // sums differ from the sphere's integrals, and the point in the middle of the z = 0 face
    // has a half family. Pure shear ε_xy = γ about the point gives θ = 0 by symmetry (n_x n_y
    // is odd in x) and the deviatoric energy (α/2)‖e^d‖², which the correction makes 2μγ²
    // (the continuum's μ ε:ε). The three probed modes of the centre are alike (cubic symmetry);
    // for the face point the xy mode is checked when it is the stiffest.
    let n = 7;
    let horizon = 2.2;
    let center = (n * n + n + 1) * (n / 2);
    let face = n / 2 + n * (n / 2);
    let corrected = Body::of(n, horizon, None, hardening(horizon, 0.0, true));
    let plain = Body::of(n, horizon, None, hardening(horizon, 0.0, false));
    let gamma = 1e-7;
    for p in [center, face] {
        let s = corrected.material.correction[p];
        assert!(
            (s - 1.0).abs() > 1e-3,
            "point {p}: s = {s} corrects nothing here"
        );
        let c = corrected.points.position[p];
        let y: Vec<[f64; 3]> = corrected
            .points
            .position
            .iter()
            .map(|x| {
                [
                    x[0] + gamma * (x[1] - c[1]),
                    x[1] + gamma * (x[0] - c[0]),
                    x[2],
                ]
            })
            .collect();
        let energy = |body: &Body| {
            let td = deviatoric_forces(body, p, &y);
            let alpha = body.material.correction.get(p).copied().unwrap_or(1.0) * 15.0 * SHEAR
                / body.material.weighted_volume[p];
            let norm: f64 = td
                .iter()
                .zip(body.bonds.range(p))
                .map(|(t, b)| t * t * body.points.volume[body.bonds.neighbor[b] as usize])
                .sum();
            norm / (2.0 * alpha)
        };
        let continuum = 2.0 * SHEAR * gamma * gamma;
        let without = energy(&plain) / continuum;
        assert!(
            (without - 1.0).abs() > 1e-3,
            "point {p}: uncorrected ratio {without}"
        );
        // The factor probes the stiffest of three modes; xy is the stiffest at both points
        // (cubic symmetry at the centre; at the face the xy mode keeps its full in-plane
        // neighbours), so it is restored exactly (to O(γ) of the deformed lengths).
        let with = energy(&corrected) / continuum;
        assert!(
            (with - 1.0).abs() < 1e-5,
            "point {p}: corrected ratio {with}, s = {s}"
        );
        // The correction is s = 1/(uncorrected ratio).
        assert!((s * without - 1.0).abs() < 1e-5, "{s} · {without}");
    }
}

#[test]
fn rigid_motion_gives_no_force() {
    let psi = yield_value(YIELD_STRESS, 1.8, None);
    let mut body = Body::of(6, 1.8, Some(3), hardening(1.8, psi * 0.3, true));
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

#[test]
fn the_forces_conserve_linear_and_angular_momentum_while_hardening() {
    let psi = yield_value(YIELD_STRESS, 1.8, None);
    let mut body = Body::of(6, 1.8, Some(8), hardening(1.8, psi * 0.3, true));
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
fn a_rejected_step_leaves_the_committed_history_and_the_next_trial_unchanged() {
    let psi = yield_value(YIELD_STRESS, 2.5, None);
    let make = || Body::of(7, 2.5, Some(5), hardening(2.5, psi * 0.2, true));
    let (mut body, mut twin) = (make(), make());
    let gamma_y = continuum_yield_shear();
    let center = (7 * 7 + 7 + 1) * 3;
    for b in [&mut body, &mut twin] {
        b.force(&b.pure_shear(center, 2.0 * gamma_y));
        b.commit();
    }
    let committed = body.history.clone();
    body.force(&body.pure_shear(center, 4.0 * gamma_y));
    assert!(
        body.field(fields::LAMBDA).trial()[center]
            > committed.field(fields::LAMBDA).unwrap().trial()[center]
    );
    body.history.each_for_tests(|f| f.restore());
    assert_eq!(body.history, committed);
    let y = body.pure_shear(center, 3.0 * gamma_y);
    assert_eq!(body.force(&y), twin.force(&y));
    assert_eq!(body.history, twin.history);
}

#[test]
fn the_automatic_differentiation_tangent_matches_finite_differences_while_hardening() {
    let psi = yield_value(YIELD_STRESS, 1.8, None);
    for damaged in [false, true] {
        let (mut body, y) = yielding_body_of(damaged, hardening(1.8, psi * 0.3, true));
        let error = tangent_error(&mut body, &y);
        assert!(error < 1e-5, "damaged {damaged}: relative error {error}");
    }
}

#[test]
fn the_automatic_differentiation_tangent_matches_finite_differences_when_elastic() {
    // A trial state inside the yield surface (the committed step yielded, the trial unloads a
    // little): the elastic branch of the same kernel.
    let psi = yield_value(YIELD_STRESS, 1.8, None);
    let mut body = Body::of(6, 1.8, Some(11), hardening(1.8, psi * 0.3, true));
    let mut rng = crate::model::test_support::Rng::new(6);
    let y: Vec<[f64; 3]> = body
        .points
        .position
        .iter()
        .map(|x| x.map(|c| c + 1e-5 * (rng.uniform() - 0.5)))
        .collect();
    body.force(&y);
    assert!(body.field(fields::LAMBDA).trial().iter().all(|&l| l == 0.0));
    let error = tangent_error(&mut body, &y);
    assert!(error < 1e-5, "relative error {error}");
}
