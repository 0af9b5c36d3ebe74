//! The materials under every quadrature rule ([`crate::model::quadrature`]): LPS dilatation of
//! an isotropic extension, PMB bulk energy against each rule's lattice constant, and rigid
//! motion.

use super::*;
use crate::model::quadrature::{self, QuadratureRule};
use crate::model::test_support::{brute_force_bonds, lattice, Rng};

const PI: f64 = std::f64::consts::PI;

/// m = 3 on the unit lattice.
const HORIZON: f64 = 3.0;

fn rules() -> [QuadratureRule; 5] {
    [
        QuadratureRule::FullVolume,
        QuadratureRule::PdLammps,
        QuadratureRule::Hhb,
        QuadratureRule::Exact,
        QuadratureRule::Adaptive { tolerance: 1e-4 },
    ]
}

/// A 9³ unit lattice (the centre point's widest family, δ + √3/2 ≈ 3.87, stays inside) with
/// the families and bond volumes of `rule`.
struct Body {
    x: Vec<[f64; 3]>,
    v: Vec<f64>,
    bonds: BondList,
    weights: Option<Vec<f64>>,
}

impl Body {
    fn new(rule: QuadratureRule) -> Self {
        let x = lattice(9);
        let v = vec![1.0; x.len()];
        let bonds = brute_force_bonds(&x, rule.family_reach(HORIZON, 1.0));
        let rules = vec![rule; x.len()];
        let horizons = vec![HORIZON; x.len()];
        let weights = quadrature::bond_volumes(&bonds, &x, &v, &rules, &horizons).map(|(w, _)| w);
        assert_eq!(weights.is_none(), rule.is_full_volume());
        Self {
            x,
            v,
            bonds,
            weights,
        }
    }

    fn reference(&self) -> ReferenceView<'_> {
        ReferenceView {
            bonds: &self.bonds,
            position: &self.x,
            volume: &self.v,
            bond_volume: self.weights.as_deref(),
        }
    }

    fn set_up(&self, mut material: Box<dyn Material>) -> Box<dyn Material> {
        let all = (0..self.x.len() as u32).collect();
        crate::material::set_up(&mut material, &self.reference(), all);
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
            bond_damage: None,
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
}

const CENTER: usize = 4 + 9 * 4 + 81 * 4;

fn pmb(bulk: f64) -> Box<dyn Material> {
    Box::new(
        BondBased::new(
            &crate::material::BlockInput {
                density: 1.0,
                horizon: HORIZON,
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

fn lps(influence: InfluenceFunction) -> Box<dyn Material> {
    Box::new(
        LinearPeridynamicSolid::new(
            &crate::material::BlockInput {
                density: 1.0,
                horizon: HORIZON,
                influence,
            },
            &crate::material::ElasticConstants {
                bulk_modulus: 3.0,
                shear_modulus: 1.7,
            },
        )
        .unwrap(),
    )
}

#[test]
fn lps_isotropic_extension_is_exact_under_every_rule() {
    // θ = (3/m) Σ ω ζ e w with e = εζ and m = Σ ω ζ² w from the same weights: θ = 3ε at
    // every point with bonds, whatever the weights (surface points included).
    let strain = 1e-3;
    for rule in rules() {
        let body = Body::new(rule);
        let y: Vec<[f64; 3]> = body
            .x
            .iter()
            .map(|p| p.map(|c| (1.0 + strain) * c))
            .collect();
        for influence in [InfluenceFunction::One, InfluenceFunction::ParabolicDecay] {
            let material = body.set_up(lps(influence));
            let (_, coefficients, _) = body.evaluate(&*material, &y);
            for (i, c) in coefficients.iter().enumerate() {
                assert!(
                    (c.dilatation - 3.0 * strain).abs() < 1e-12,
                    "{rule:?}: point {i} θ = {}",
                    c.dilatation
                );
            }
        }
    }
}

/// The weight rule's lattice constant for PMB bulk energy, by brute force over the lattice:
/// `Σ_{n ∈ Z³, 0 < |n|} |n| β(n) / (π m⁴)` (Δx = 1, δ = m), the discrete `Σ ζ w` over its
/// continuum value `∫_H |ξ| dV = π δ⁴`. β from the stated formulas: 1 for |n| ≤ m (full
/// volume); `clamp((m + ½ − |n|), 0, 1)` for |n| ≤ m (PDLAMMPS) or |n| ≤ m + ½ (HHB).
fn lattice_constant(rule: QuadratureRule) -> f64 {
    let m = HORIZON;
    let reach = m + 1.0;
    let mut sum = 0.0;
    for a in -4i32..=4 {
        for b in -4i32..=4 {
            for c in -4i32..=4 {
                let zeta = f64::from(a * a + b * b + c * c).sqrt();
                if zeta == 0.0 || zeta > reach {
                    continue;
                }
                let linear = (m + 0.5 - zeta).clamp(0.0, 1.0);
                let beta = match rule {
                    QuadratureRule::FullVolume => f64::from(u8::from(zeta <= m)),
                    QuadratureRule::PdLammps if zeta <= m => linear,
                    QuadratureRule::Hhb => linear,
                    _ => 0.0,
                };
                sum += zeta * beta;
            }
        }
    }
    sum / (PI * m.powi(4))
}

#[test]
fn pmb_bulk_energy_ratio_is_the_lattice_constant() {
    // Isotropic extension ε: W = Σ_j ¼ c ε² ζ w_j (module docs of `bond_based`), and the
    // continuum W = ¼ c ε² π δ⁴ = (9/2) K ε² with c = 18K/(πδ⁴). So W / ((9/2) K ε²) is the
    // rule's Σ ζ w / (π δ⁴) at the interior centre point.
    let (bulk, strain) = (2.0, 1e-3);
    let continuum = 4.5 * bulk * strain * strain;
    for rule in [
        QuadratureRule::FullVolume,
        QuadratureRule::PdLammps,
        QuadratureRule::Hhb,
    ] {
        let body = Body::new(rule);
        let y: Vec<[f64; 3]> = body
            .x
            .iter()
            .map(|p| p.map(|c| (1.0 + strain) * c))
            .collect();
        let material = body.set_up(pmb(bulk));
        let (_, _, energy) = body.evaluate(&*material, &y);
        let ratio = energy[CENTER] / continuum;
        let expected = lattice_constant(rule);
        assert!(
            (ratio - expected).abs() < 1e-9 * expected,
            "{rule:?}: {ratio} vs lattice constant {expected}"
        );
    }
    // Exact: the same sum with w = |cell_n ∩ sphere| (the function the tiling test of
    // `model::quadrature` checks against 4/3 π δ³), over every cell the sphere reaches.
    let reach = QuadratureRule::Exact.family_reach(HORIZON, 1.0);
    let mut sum = 0.0;
    for a in -4i32..=4 {
        for b in -4i32..=4 {
            for c in -4i32..=4 {
                let xi = [a, b, c].map(f64::from);
                let zeta = (xi[0] * xi[0] + xi[1] * xi[1] + xi[2] * xi[2]).sqrt();
                if zeta > 0.0 && zeta <= reach {
                    sum += zeta * quadrature::cell_sphere_volume(xi, 1.0, HORIZON);
                }
            }
        }
    }
    let expected = sum / (PI * HORIZON.powi(4));
    let body = Body::new(QuadratureRule::Exact);
    let y: Vec<[f64; 3]> = body
        .x
        .iter()
        .map(|p| p.map(|c| (1.0 + strain) * c))
        .collect();
    let material = body.set_up(pmb(bulk));
    let (_, _, energy) = body.evaluate(&*material, &y);
    let ratio = energy[CENTER] / continuum;
    assert!(
        (ratio - expected).abs() < 1e-9 * expected,
        "exact: {ratio} vs {expected}"
    );
}

#[test]
fn partial_volumes_keep_rigid_motion_force_free_and_momentum() {
    // A rigid rotation and translation stretches no bond: zero force under any weights.
    // Equal cells and one horizon make every rule symmetric (w_ij = w_ji), so Σ_i F_i V_i = 0
    // for any deformation.
    let (s, c) = (0.6f64.sin(), 0.6f64.cos());
    let mut rng = Rng::new(7);
    for rule in [QuadratureRule::Exact, QuadratureRule::Hhb] {
        let body = Body::new(rule);
        let weights = body.weights.as_ref().unwrap();
        for i in 0..body.x.len() {
            for b in body.bonds.range(i) {
                let j = body.bonds.neighbor[b] as usize;
                let back = body.bonds.range(j).start
                    + body.bonds.family(j).binary_search(&(i as u32)).unwrap();
                assert!((weights[b] - weights[back]).abs() < 1e-14, "{rule:?}");
            }
        }
        let rotated: Vec<[f64; 3]> = body
            .x
            .iter()
            .map(|p| {
                [
                    c * p[0] - s * p[1] + 0.3,
                    s * p[0] + c * p[1] - 1.1,
                    p[2] + 0.2,
                ]
            })
            .collect();
        let shaken: Vec<[f64; 3]> = body
            .x
            .iter()
            .map(|p| p.map(|v| v + 0.01 * rng.normal()))
            .collect();
        for material in [pmb(2.0), lps(InfluenceFunction::One)] {
            let material = body.set_up(material);
            let (deformed, _, _) = body.evaluate(&*material, &shaken);
            let scale = deformed
                .iter()
                .flatten()
                .fold(0.0f64, |a, f| a.max(f.abs()));
            assert!(scale > 0.0);
            let mut momentum = [0.0; 3];
            for (f, v) in deformed.iter().zip(&body.v) {
                for k in 0..3 {
                    momentum[k] += f[k] * v;
                }
            }
            for k in 0..3 {
                assert!(
                    momentum[k].abs() < 1e-9 * scale,
                    "{rule:?}: Σ F V = {momentum:?}"
                );
            }
            let (rigid, _, _) = body.evaluate(&*material, &rotated);
            for f in rigid.iter().flatten() {
                assert!(f.abs() < 1e-11 * scale, "{rule:?}: rigid force {f}");
            }
        }
    }
}
