//! The materials under a surface correction ([`crate::model::surface_correction`]): the
//! energy density of surface points against the bulk, rigid motion, momentum, and a bar's
//! stiffness against the classical value.

use super::*;
use crate::model::quadrature::{self, QuadratureRule};
use crate::model::surface_correction::{self, SurfaceCorrection};
use crate::model::test_support::{brute_force_bonds, Rng};
use crate::model::BondVolumes;

/// m ≈ 2 on the unit lattice (off the lattice shell at 2, so no bond sits on the horizon).
const HORIZON: f64 = 2.01;

/// An `n[0]×n[1]×n[2]` unit lattice with the quadrature volumes of `rule`, scaled by the
/// factors of `correction`.
struct Body {
    n: [usize; 3],
    x: Vec<[f64; 3]>,
    v: Vec<f64>,
    bonds: BondList,
    weights: Option<Vec<f64>>,
}

impl Body {
    fn new(n: [usize; 3], rule: QuadratureRule, correction: SurfaceCorrection) -> Self {
        let mut x = Vec::new();
        for k in 0..n[2] {
            for j in 0..n[1] {
                for i in 0..n[0] {
                    x.push([i as f64, j as f64, k as f64]);
                }
            }
        }
        let count = x.len();
        let v = vec![1.0; count];
        let bonds = brute_force_bonds(&x, rule.family_reach(HORIZON, 1.0));
        let rules = vec![rule; count];
        let horizons = vec![HORIZON; count];
        let mut weights =
            quadrature::bond_volumes(&bonds, &x, &v, &rules, &horizons).map(|(w, _)| w);
        if correction.is_active() {
            let g = surface_correction::point_factors(
                &bonds,
                &x,
                BondVolumes::new(&v, weights.as_deref()),
                &vec![correction; count],
                &rules,
                &horizons,
                &v,
            );
            let mut w = weights.unwrap_or_else(|| vec![1.0; bonds.num_bonds()]);
            surface_correction::scale_bond_volumes(&bonds, &g, &mut w);
            weights = Some(w);
        }
        Self {
            n,
            x,
            v,
            bonds,
            weights,
        }
    }

    fn index(&self, i: usize, j: usize, k: usize) -> usize {
        i + self.n[0] * (j + self.n[1] * k)
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

    /// Force density and energy density at `y`.
    fn evaluate(&self, material: &dyn Material, y: &[[f64; 3]]) -> (Vec<[f64; 3]>, Vec<f64>) {
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
        (force, energy)
    }

    /// The positions after the affine displacement u = diag(`stretch`)·X.
    fn stretched(&self, stretch: [f64; 3]) -> Vec<[f64; 3]> {
        self.x
            .iter()
            .map(|p| [0, 1, 2].map(|k| p[k] * (1.0 + stretch[k])))
            .collect()
    }
}

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

fn lps() -> Box<dyn Material> {
    Box::new(
        LinearPeridynamicSolid::new(
            &crate::material::BlockInput {
                density: 1.0,
                horizon: HORIZON,
                influence: InfluenceFunction::One,
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
fn a_face_point_recovers_the_bulk_energy_density() {
    // A 9×9×5 plate: the centre of its z = 0 face, (4, 4, 0), is a flat free surface; the
    // point (4, 4, 2) has its whole family (HORIZON < 3) and is the bulk. The largest
    // eigenvalue of P at a face point is in the plane of the face, so the test is a uniaxial
    // extension along x. Measured (face/bulk energy density): 0.858 without correction,
    // 1.055 with it. Force normalization equalizes P's largest eigenvalue, not this energy,
    // and each bond takes the mean factor of its two ends (the face point's neighbours one
    // layer in have smaller factors), so the corrected value is not exactly 1: the test
    // asserts it within 6 % and at most half the uncorrected error.
    let strain = 1e-6;
    let mut ratios = [0.0; 2];
    for (k, c) in [
        SurfaceCorrection::None,
        SurfaceCorrection::ForceNormalization,
    ]
    .into_iter()
    .enumerate()
    {
        let body = Body::new([9, 9, 5], QuadratureRule::FullVolume, c);
        let material = body.set_up(pmb(2.0));
        let (_, energy) = body.evaluate(&*material, &body.stretched([strain, 0.0, 0.0]));
        let (face, bulk) = (body.index(4, 4, 0), body.index(4, 4, 2));
        ratios[k] = energy[face] / energy[bulk];
    }
    eprintln!("face/bulk energy density without, with correction: {ratios:?}");
    assert!((ratios[1] - 1.0).abs() < 0.06, "{ratios:?}");
    assert!(
        (ratios[1] - 1.0).abs() < 0.5 * (ratios[0] - 1.0).abs(),
        "{ratios:?}"
    );
}

#[test]
fn corrected_bonds_keep_rigid_motion_force_free_and_momentum() {
    // The factors are symmetric per bond (mean of the ends) and the cells equal, so
    // V_i w_ij = V_j w_ji still holds and Σ_i F_i V_i = 0 for any deformation; a rigid
    // rotation and translation stretches no bond.
    let (s, c) = (0.6f64.sin(), 0.6f64.cos());
    let mut rng = Rng::new(11);
    let correction = SurfaceCorrection::ForceNormalization;
    {
        for rule in [QuadratureRule::FullVolume, QuadratureRule::Exact] {
            let body = Body::new([6, 5, 4], rule, correction);
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
            for material in [pmb(2.0), lps()] {
                let material = body.set_up(material);
                let (deformed, _) = body.evaluate(&*material, &shaken);
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
                for m in momentum {
                    assert!(
                        m.abs() < 1e-9 * scale,
                        "{correction:?} {rule:?}: Σ F V = {momentum:?}"
                    );
                }
                let (rigid, _) = body.evaluate(&*material, &rotated);
                for f in rigid.iter().flatten() {
                    assert!(
                        f.abs() < 1e-11 * scale,
                        "{correction:?} {rule:?}: rigid force {f}"
                    );
                }
            }
        }
    }
}

#[test]
fn a_corrected_bar_is_closer_to_the_classical_stiffness() {
    // A 16×4×4 bar (every point within δ of a side) under the classical uniaxial-stress field
    // u = ε (X, −ν Y, −ν Z), ν = 1/4 (PMB's Poisson's ratio). Its strain energy is
    // ½ E ε² V with E = 3K(1 − 2ν) = 1.5 K; the same value follows from the PMB continuum
    // W = ¼ c ∫ s² ζ dV with s = n·Hn and ∫ (n·Hn)² dΩ = 4π/15 ((tr H)² + 2 H:H) = 2π/3 ε².
    // E_eff = 2 Σ W_i V_i / (ε² V) measures the discrete bar's stiffness. Measured
    // E_eff/E − 1 without and with the correction: full volume −14.2 % and +10.9 % (its bulk
    // lattice alone is +6.2 % stiff in this field: Σ (n·Hn)² |n| over the lattice points
    // within 2.01 against the continuum integral), exact partial volumes −19.5 % and +5.9 %.
    let (bulk, strain, nu) = (2.0, 1e-6, 0.25);
    let youngs = 1.5 * bulk;
    for rule in [QuadratureRule::FullVolume, QuadratureRule::Exact] {
        let mut errors = Vec::new();
        for correction in [
            SurfaceCorrection::None,
            SurfaceCorrection::ForceNormalization,
        ] {
            let body = Body::new([16, 4, 4], rule, correction);
            let material = body.set_up(pmb(bulk));
            let (_, energy) = body.evaluate(
                &*material,
                &body.stretched([strain, -nu * strain, -nu * strain]),
            );
            let total: f64 = energy.iter().zip(&body.v).map(|(w, v)| w * v).sum();
            let volume: f64 = body.v.iter().sum();
            let effective = 2.0 * total / (strain * strain * volume);
            errors.push(effective / youngs - 1.0);
        }
        eprintln!("{rule:?}: E_eff/E − 1 without, with correction = {errors:?}");
        assert!(errors[1].abs() < errors[0].abs(), "{rule:?}: {errors:?}");
    }
}
