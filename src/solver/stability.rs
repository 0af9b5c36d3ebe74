//! The largest stable velocity-Verlet time step of a body, measured rather than estimated.
//!
//! Peridigm's estimate (Silling & Askari 2005, eq. 21 generalised to each material's bond
//! stiffness) bounds each point's row of the bond-based stiffness. It is exact for two points
//! joined by one PMB bond and conservative (by about 2×) inside a bond-based lattice, but it is
//! not a bound for state-based models whose dilatation term outweighs the bond term: an LPS body
//! with ν → −0.5 (shear stiffness six times the bulk) or a point with only one or two bonds
//! (its weighted volume m is tiny, and the dilatation term grows as 1/m). There the run blows up
//! at the estimated step, and a Safety Factor of 0.5 may not save it.
//!
//! Velocity Verlet on the linearised equations ρü = −K u is stable for Δt < 2/ω_max, with
//! ω²_max the largest eigenvalue of ρ⁻¹K. The eigenvalue is found by power iteration on
//! Jacobian-vector products of the internal force (directional finite differences at the
//! reference configuration, bond damage held), in the mass-weighted inner product in which ρ⁻¹K is
//! symmetric. Power iteration approaches ω²_max from below, so the step it gives is an upper
//! bound that tightens with the iterations; [`MEASURE_ITERATIONS`] puts it within a few per
//! cent on the bodies of the tests.

use crate::history::History;
use crate::model::Model;
use crate::physics::Physics;

/// Power iterations of [`measured_critical_time_step`]: each costs one force evaluation.
pub const MEASURE_ITERATIONS: usize = 200;

/// Relative change of the Rayleigh quotient below which the iteration stops early.
const CONVERGED: f64 = 1e-6;

/// The largest stable velocity-Verlet Δt (s) of the body linearised at its reference
/// configuration with the given material history, 2/ω_max; `None` when the body has no
/// stiffness (no bonds). Costs at most `iterations` force evaluations on this rank's points.
pub fn measured_critical_time_step(
    model: &Model,
    physics: &mut Physics,
    history: &History,
    iterations: usize,
) -> Option<f64> {
    let n = model.points.len();
    let reference = &model.points.position;
    let volume = &model.points.volume;
    let density = physics.density.clone();
    let mass = |i: usize| density[i] * volume[i];
    // Each evaluation starts from the given history, so that no probe changes the next.
    let evaluate = |physics: &mut Physics, at: &[[f64; 3]], force: &mut [[f64; 3]]| {
        let mut scratch = history.clone();
        physics.internal_force_with_damage_fixed(
            &model.bonds,
            &model.points,
            at,
            None,
            &mut scratch,
            force,
        );
    };
    let mut base = vec![[0.0; 3]; n];
    evaluate(physics, reference, &mut base);
    // Probe displacements of 1e-7 of the smallest horizon: linear for every model, far above
    // round-off of the positions.
    let size = model.horizon.iter().copied().fold(f64::INFINITY, f64::min);
    if !size.is_finite() || size <= 0.0 {
        return None;
    }
    let epsilon = 1e-7 * size;
    let mut vector = starting_vector(n);
    normalise(&mut vector, &mass);
    let mut probe = vec![[0.0; 3]; n];
    let mut force = vec![[0.0; 3]; n];
    let mut next = vec![[0.0; 3]; n];
    let mut previous = 0.0;
    let mut largest = 0.0_f64;
    for _ in 0..iterations {
        let scale = epsilon / max_abs(&vector);
        for i in 0..n {
            for k in 0..3 {
                probe[i][k] = reference[i][k] + scale * vector[i][k];
            }
        }
        evaluate(physics, &probe, &mut force);
        // (ρ⁻¹K v)_i = −(f(X + s v) − f(X))_i / (s ρ_i).
        for i in 0..n {
            for k in 0..3 {
                next[i][k] = -(force[i][k] - base[i][k]) / (scale * density[i]);
            }
        }
        let rayleigh: f64 = (0..n)
            .map(|i| mass(i) * (0..3).map(|k| vector[i][k] * next[i][k]).sum::<f64>())
            .sum();
        largest = largest.max(rayleigh);
        if !normalise(&mut next, &mass) {
            break;
        }
        std::mem::swap(&mut vector, &mut next);
        if (rayleigh - previous).abs() <= CONVERGED * rayleigh.abs() {
            break;
        }
        previous = rayleigh;
    }
    (largest > 0.0 && largest.is_finite()).then(|| 2.0 / largest.sqrt())
}

/// A start with every mode in it, the highest included: a fixed pseudo-random vector (the
/// same on every run, so the figure is reproducible).
fn starting_vector(n: usize) -> Vec<[f64; 3]> {
    let mut seed: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut next = move || {
        // SplitMix64 (Steele, Lea & Flood 2014).
        seed = seed.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = seed;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    (0..n).map(|_| [next(), next(), next()]).collect()
}

fn max_abs(vector: &[[f64; 3]]) -> f64 {
    vector
        .iter()
        .flat_map(|v| v.iter())
        .fold(0.0_f64, |m, x| m.max(x.abs()))
}

/// Scales `vector` to unit mass-weighted norm; false when it is zero or not finite.
fn normalise(vector: &mut [[f64; 3]], mass: &dyn Fn(usize) -> f64) -> bool {
    let norm: f64 = vector
        .iter()
        .enumerate()
        .map(|(i, v)| mass(i) * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]))
        .sum::<f64>()
        .sqrt();
    if !(norm > 0.0 && norm.is_finite()) {
        return false;
    }
    vector
        .iter_mut()
        .for_each(|v| v.iter_mut().for_each(|x| *x /= norm));
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `nx`×1×1 row of unit cells (ρ = 2, K = 3, μ = 1.8 for LPS, δ = 1.5) of material
    /// `model`, with its physics and initial history.
    fn row(nx: usize, model: &str) -> (Model, Physics, History) {
        let shear = if model == "Elastic" {
            "\n      Shear Modulus: 1.8"
        } else {
            ""
        };
        let text = format!(
            r#"Peridigm:
  Discretization:
    Type: "PdQuickGrid"
    NeighborhoodType: "Spherical"
    TensorProduct3DMeshGenerator:
      X Origin: 0.0
      Y Origin: 0.0
      Z Origin: 0.0
      X Length: {nx}.0
      Y Length: 1.0
      Z Length: 1.0
      Number Points X: {nx}
      Number Points Y: 1
      Number Points Z: 1
  Materials:
    M:
      Material Model: "{model}"
      Density: 2.0
      Bulk Modulus: 3.0{shear}
  Blocks:
    B: {{Block Names: "block_1", Material: "M", Horizon: 1.5}}
  Solver:
    Final Time: 1.0
    Verlet: {{Safety Factor: 0.8}}
"#
        );
        let deck = crate::setup::solvers::deck_from_yaml(&text);
        let model = crate::setup::build(&deck).unwrap();
        let physics = crate::setup::build_physics(&deck, &model).unwrap();
        let history = History::allocate(
            physics
                .blocks
                .iter()
                .flat_map(|block| block.material.declaration().fields),
            model.points.len(),
            model.bonds.num_bonds(),
        );
        (model, physics, history)
    }

    fn peridigm_estimate(model: &Model) -> f64 {
        let reference = crate::material::ReferenceView::of(&model.bonds, &model.points);
        let points: Vec<u32> = (0..model.points.len() as u32).collect();
        crate::material::critical_time_step(&reference, &points, 2.0, 3.0, 1.5).unwrap()
    }

    #[test]
    fn two_points_joined_by_one_pmb_bond_have_the_closed_form_limit() {
        // One spring between two masses: ρ ü_rel = −2 (c V/ζ) u_rel with c = 18K/(πδ⁴), V = 1,
        // ζ = 1, so ω² = 2cV/(ρζ) and the Verlet limit is 2/ω, which is also Peridigm's
        // estimate sqrt(2ρζ/(cV)) (exact for this body, Silling & Askari 2005).
        let (model, mut physics, history) = row(2, "Elastic Bond Based");
        let c = 18.0 * 3.0 / (std::f64::consts::PI * 1.5_f64.powi(4));
        let expected = 2.0 / (2.0 * c / 2.0_f64).sqrt();
        let measured =
            measured_critical_time_step(&model, &mut physics, &history, MEASURE_ITERATIONS)
                .unwrap();
        assert!(
            (measured - expected).abs() < 1e-6 * expected,
            "{measured} vs {expected}"
        );
        assert!((peridigm_estimate(&model) - expected).abs() < 1e-12 * expected);
    }

    #[test]
    fn peridigm_estimate_is_conservative_for_a_pmb_chain_but_not_for_two_lps_points() {
        // A PMB chain: every point's row bound holds, so the measured limit is at least the
        // estimate (Gershgorin).
        let (model, mut physics, history) = row(12, "Elastic Bond Based");
        let measured =
            measured_critical_time_step(&model, &mut physics, &history, MEASURE_ITERATIONS)
                .unwrap();
        assert!(measured >= peridigm_estimate(&model), "{measured}");
        // Two LPS points: m = ζ²V = 1, so the dilatation term 9K/m per bond (against the bond
        // term c/ζ ≈ 3.4) makes the body several times stiffer than the estimate assumes.
        let (model, mut physics, history) = row(2, "Elastic");
        let measured =
            measured_critical_time_step(&model, &mut physics, &history, MEASURE_ITERATIONS)
                .unwrap();
        assert!(measured < 0.5 * peridigm_estimate(&model), "{measured}");
    }

    #[test]
    fn a_body_without_bonds_has_no_limit() {
        let (model, mut physics, history) = row(1, "Elastic Bond Based");
        assert_eq!(
            measured_critical_time_step(&model, &mut physics, &history, MEASURE_ITERATIONS),
            None
        );
    }
}
