//! Checks of the correspondence family: homogeneous deformations against closed forms,
//! objectivity, invariance, the tangent against finite differences, singular shape tensors.

use std::sync::Arc;

use super::hypoelastic::HypoelasticParameters;
use super::kinematics::{from_row_major, Tensor};
use super::*;
use crate::material::BlockInput;
use crate::model::test_support::{brute_force_bonds, lattice, Rng};
use crate::model::PointCloud;
use crate::physics::{BlockPhysics, Configuration, Physics};
use crate::tangent::BlockPattern;

const BULK: f64 = 3.0;
const SHEAR: f64 = 1.7;
const HORIZON: f64 = 1.8;

/// A 6×6×6 lattice (spacing 1, volumes 0.8–1.2) of one `Elastic Correspondence` block.
struct Body {
    points: PointCloud,
    bonds: BondList,
    physics: Physics,
    history: History,
    damage: Option<Vec<f32>>,
}

/// K = BULK, μ = SHEAR.
const ELASTIC: ElasticConstants = ElasticConstants {
    bulk_modulus: BULK,
    shear_modulus: SHEAR,
};

/// ρ = 2, block horizon `horizon`, parabolic ω.
fn block(horizon: f64) -> BlockInput {
    BlockInput {
        density: 2.0,
        horizon,
        influence: InfluenceFunction::ParabolicDecay,
    }
}

/// The parameters of a Lagrangian correspondence model with the lattice body's moduli.
fn parameters<P>(hourglass: f64, stress: P) -> CorrespondenceParameters<P> {
    CorrespondenceParameters {
        elastic: ELASTIC,
        hourglass_coefficient: hourglass,
        stress,
    }
}

fn material(hourglass: f64) -> Box<dyn Material> {
    ElasticCorrespondence::build(&block(HORIZON), &parameters(hourglass, ())).unwrap()
}

impl Body {
    fn new(hourglass: f64) -> Self {
        Self::with(material(hourglass))
    }

    /// The lattice body of material `m`, steps of 1 s.
    fn with(m: Box<dyn Material>) -> Self {
        Self::with_bonds(m, HORIZON)
    }

    /// The lattice body of material `m` with its neighbour lists built with `horizon`.
    fn with_bonds(mut m: Box<dyn Material>, horizon: f64) -> Self {
        let mut rng = Rng::new(11);
        let x = lattice(6);
        let mut points = PointCloud::default();
        for p in &x {
            points.push(*p, 0.8 + 0.4 * rng.uniform(), 0);
        }
        let bonds = brute_force_bonds(&x, horizon);
        let reference = ReferenceView::of(&bonds, &points);
        crate::material::set_up(&mut m, &reference, (0..x.len() as u32).collect());
        let fields = m.declaration().fields;
        let physics = Physics::new(
            vec![BlockPhysics {
                material: m,
                damage: None,
            }],
            &points,
            &bonds,
        );
        let mut history = History::allocate(fields, x.len(), bonds.num_bonds());
        history.set_step_duration(1.0);
        Self {
            points,
            bonds,
            physics,
            history,
            damage: None,
        }
    }

    /// Force density at `y` (advancing the trial history from the committed one).
    fn force(&mut self, y: &[[f64; 3]]) -> Vec<[f64; 3]> {
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

    fn tensor_field(&self, name: &str, p: usize) -> Tensor<f64> {
        from_row_major(&self.history.field(name).unwrap().trial()[9 * p..9 * p + 9])
    }

    fn affine(&self, f: &Tensor<f64>) -> Vec<[f64; 3]> {
        self.points
            .position
            .iter()
            .map(|x| std::array::from_fn(|r| (0..3).map(|c| f[(r, c)] * x[c]).sum()))
            .collect()
    }

    /// Points whose whole family and their families have full lattice families (far enough
    /// from the surface that the force of a homogeneous deformation vanishes by symmetry).
    fn deep_interior(&self) -> Vec<usize> {
        let full = self.bonds.family_size(self.points.len() / 2 + 18);
        (0..self.points.len())
            .filter(|&i| {
                self.bonds.family_size(i) == full
                    && self
                        .bonds
                        .family(i)
                        .iter()
                        .all(|&j| self.bonds.family_size(j as usize) == full)
            })
            .collect()
    }

    fn commit(&mut self) {
        self.history.each_for_tests(|f| f.commit());
    }
}

fn max_difference(a: &Tensor<f64>, b: &Tensor<f64>) -> f64 {
    (a - b).abs().max()
}

/// For a homogeneous deformation reached in one step from the reference state, the midpoint
/// rule gives `L Δt = (F − I)((F + I)/2)⁻¹`; the expected stresses below are worked out by
/// hand from it (module docs of `kinematics` and `elastic`).
fn check_homogeneous(f: Tensor<f64>, expected: Tensor<f64>, hourglass: f64) {
    check_homogeneous_of(Body::new(hourglass), f, expected);
}

/// [`check_homogeneous`] on `body`.
fn check_homogeneous_of(mut body: Body, f: Tensor<f64>, expected: Tensor<f64>) {
    let y = body.affine(&f);
    let force = body.force(&y);
    let scale = expected.abs().max();
    // Round-off of F (≈1e-16 of |F| per operation) times the modulus bounds the error of σ.
    let round_off = 1e-12 * BULK;
    for p in 0..body.points.len() {
        let gradient = body.tensor_field(fields::DEFORMATION_GRADIENT, p) + Tensor::identity();
        assert!(max_difference(&gradient, &f) < 1e-13, "F at point {p}");
        let sigma = body.tensor_field(fields::CAUCHY_STRESS, p);
        assert!(
            max_difference(&sigma, &expected) <= round_off,
            "σ at point {p}: {sigma} ≠ {expected}"
        );
    }
    let mut hourglass_force = vec![[0.0; 3]; body.points.len()];
    body.physics.hourglass_force_density(
        &body.bonds,
        &body.points,
        &y,
        None,
        &body.history,
        &mut hourglass_force,
    );
    let largest_hourglass = hourglass_force
        .iter()
        .flatten()
        .fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(
        largest_hourglass < 1e-12 * scale,
        "hourglass force {largest_hourglass}"
    );
    for i in body.deep_interior() {
        let magnitude = force[i].iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(
            magnitude < 1e-11 * scale,
            "force at interior point {i}: {magnitude}"
        );
    }
}

#[test]
fn uniaxial_strain_gives_the_closed_form_stress_and_no_hourglass_force() {
    let e = 1e-3;
    let g = 2.0 * e / (2.0 + e);
    let f = Tensor::from_diagonal(&nalgebra::Vector3::new(1.0 + e, 1.0, 1.0));
    let lateral = (BULK - 2.0 * SHEAR / 3.0) * g;
    let expected = Tensor::from_diagonal(&nalgebra::Vector3::new(
        (BULK + 4.0 * SHEAR / 3.0) * g,
        lateral,
        lateral,
    ));
    check_homogeneous(f, expected, 0.02);
    // Hooke's law of the small strain, to the order of the strain.
    assert!(((BULK + 4.0 * SHEAR / 3.0) * g / ((BULK + 4.0 * SHEAR / 3.0) * e) - 1.0).abs() < e);
}

#[test]
fn simple_shear_gives_shear_stress_mu_gamma() {
    // L Δt = γ e_x⊗e_y exactly (its square vanishes), D = γ/2 (e_x⊗e_y + e_y⊗e_x), and the
    // rotation cancels in σ = R (2μ Rᵀ D R) Rᵀ = 2μ D: σ_xy = σ_yx = μγ, all else 0.
    let gamma = 2e-3;
    let mut f = Tensor::identity();
    f[(0, 1)] = gamma;
    let mut expected = Tensor::zeros();
    expected[(0, 1)] = SHEAR * gamma;
    expected[(1, 0)] = SHEAR * gamma;
    check_homogeneous(f, expected, 0.02);
}

#[test]
fn isotropic_expansion_gives_pressure_three_k_strain() {
    let e = -2e-3;
    let g = 2.0 * e / (2.0 + e);
    let f = Tensor::identity() * (1.0 + e);
    check_homogeneous(f, Tensor::identity() * (3.0 * BULK * g), 0.02);
}

fn rotation_about_z(angle: f64) -> Tensor<f64> {
    let (s, c) = angle.sin_cos();
    Tensor::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
}

#[test]
fn a_rigid_rotation_of_ninety_degrees_in_one_step_gives_no_stress_and_no_force() {
    let q = rotation_about_z(std::f64::consts::FRAC_PI_2);
    let mut body = Body::new(0.02);
    let y = body.affine(&q);
    let force = body.force(&y);
    for (p, force) in force.iter().enumerate() {
        let sigma = body.tensor_field(fields::CAUCHY_STRESS, p);
        assert!(sigma.abs().max() < 1e-14, "σ at point {p}: {sigma}");
        assert!(force.iter().all(|v| v.abs() < 1e-13), "force at point {p}");
        let rotation = body.tensor_field(fields::ROTATION, p) + Tensor::identity();
        assert!(max_difference(&rotation, &q) < 1e-14, "R at point {p}");
    }
}

#[test]
fn a_stretch_then_a_ninety_degree_rotation_rotates_the_stress_exactly() {
    let e = 1e-3;
    let g = 2.0 * e / (2.0 + e);
    let stretch = Tensor::from_diagonal(&nalgebra::Vector3::new(1.0 + e, 1.0, 1.0));
    let mut body = Body::new(0.02);
    body.force(&body.affine(&stretch));
    body.commit();
    let q = rotation_about_z(std::f64::consts::FRAC_PI_2);
    body.force(&body.affine(&(q * stretch)));
    let lateral = (BULK - 2.0 * SHEAR / 3.0) * g;
    let unrotated = Tensor::from_diagonal(&nalgebra::Vector3::new(
        (BULK + 4.0 * SHEAR / 3.0) * g,
        lateral,
        lateral,
    ));
    let expected = q * unrotated * q.transpose();
    for p in 0..body.points.len() {
        let sigma = body.tensor_field(fields::CAUCHY_STRESS, p);
        // Round-off of F times the modulus, as in `check_homogeneous`.
        assert!(
            max_difference(&sigma, &expected) < 1e-12 * BULK,
            "σ at point {p}"
        );
        let kept = body.tensor_field(fields::UNROTATED_STRESS, p);
        assert!(
            max_difference(&kept, &unrotated) < 1e-12 * BULK,
            "σ̃ at point {p}"
        );
    }
}

/// Displacements of up to ±0.02 spacings around a small stretch, so every term is exercised.
fn perturbed(body: &Body, seed: u64) -> Vec<[f64; 3]> {
    let mut rng = Rng::new(seed);
    let stretch = Tensor::from_diagonal(&nalgebra::Vector3::new(1.002, 0.999, 1.0));
    body.affine(&stretch)
        .into_iter()
        .map(|y| y.map(|c| c + 0.04 * (rng.uniform() - 0.5)))
        .collect()
}

#[test]
fn translation_gives_no_force_and_the_forces_conserve_momentum() {
    let mut body = Body::new(0.05);
    let shifted: Vec<[f64; 3]> = body
        .points
        .position
        .iter()
        .map(|x| [x[0] + 0.3, x[1] - 1.1, x[2] + 2.0])
        .collect();
    let force = body.force(&shifted);
    assert!(force.iter().flatten().all(|v| v.abs() < 1e-13));
    let y = perturbed(&body, 5);
    let force = body.force(&y);
    let largest = force.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(largest > 1e-4, "the perturbed state must carry force");
    for k in 0..3 {
        let total: f64 = force
            .iter()
            .zip(&body.points.volume)
            .map(|(f, v)| f[k] * v)
            .sum();
        assert!(
            total.abs() < 1e-12 * largest * body.points.len() as f64,
            "momentum {k}: {total}"
        );
    }
}

/// max over entries |J_AD − J_FD| / max |J_FD|, the FD tangent from central differences of the
/// force itself (each probe advancing the trial history from the same committed one).
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
                history: &body.history,
            },
            TangentMethod::AutomaticDifferentiation,
            &mut tangent,
        )
        .unwrap();
    let h = 1e-6;
    let mut largest = 0.0f64;
    let mut worst = 0.0f64;
    // A few columns spread over the body (interior and surface points).
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
    let mut body = Body::new(0.05);
    // A committed step with stress, then a trial state away from it.
    let start = perturbed(&body, 2);
    body.force(&start);
    body.commit();
    let y = perturbed(&body, 9);
    let error = tangent_error(&mut body, &y);
    assert!(error < 1e-6, "relative error {error}");
}

#[test]
fn the_tangent_matches_finite_differences_with_damaged_bonds() {
    let mut body = Body::new(0.05);
    let mut rng = Rng::new(4);
    let bonds = &body.bonds;
    let mut damage = vec![0.0f32; bonds.num_bonds()];
    for i in 0..bonds.num_points() {
        for b in bonds.range(i) {
            let j = bonds.neighbor[b] as usize;
            if j > i && rng.uniform() < 0.2 {
                let back = bonds.offsets[j] + bonds.family(j).binary_search(&(i as u32)).unwrap();
                damage[b] = 1.0;
                damage[back] = 1.0;
            }
        }
    }
    body.damage = Some(damage);
    let y = perturbed(&body, 6);
    let error = tangent_error(&mut body, &y);
    assert!(error < 1e-6, "relative error {error}");
}

#[test]
fn coplanar_points_have_a_singular_shape_tensor_named_at_setup() {
    // One layer of points: every family lies in the plane z = 0.
    let x: Vec<[f64; 3]> = lattice(4).into_iter().filter(|p| p[2] == 0.0).collect();
    let mut points = PointCloud::default();
    for p in &x {
        points.push(*p, 1.0, 0);
    }
    let bonds = brute_force_bonds(&x, HORIZON);
    let mut m = material(0.0);
    let error = m
        .setup(
            &ReferenceView::of(&bonds, &points),
            (0..x.len() as u32).collect(),
        )
        .unwrap_err();
    assert!(
        matches!(error, MaterialError::SingularShapeTensor { point: 0, intact_bonds } if intact_bonds == bonds.family_size(0)),
        "{error:?}"
    );
}

#[test]
fn a_point_whose_bonds_all_broke_carries_no_stress_and_the_force_stays_finite() {
    let mut body = Body::new(0.05);
    let p = 0;
    let mut damage = vec![0.0f32; body.bonds.num_bonds()];
    for b in body.bonds.range(p) {
        let j = body.bonds.neighbor[b] as usize;
        let back = body.bonds.offsets[j] + body.bonds.family(j).binary_search(&(p as u32)).unwrap();
        damage[b] = 1.0;
        damage[back] = 1.0;
    }
    body.damage = Some(damage);
    let y = perturbed(&body, 8);
    let force = body.force(&y);
    assert!(force.iter().flatten().all(|v| v.is_finite()));
    assert_eq!(force[p], [0.0; 3]);
    assert_eq!(body.tensor_field(fields::CAUCHY_STRESS, p), Tensor::zeros());
}

/// J2 with the constants of the issue's check: E = 211 GPa, ν = 0 (μ = E/2, K = E/3),
/// σ_y = 460 MPa, H = 5 GPa.
fn j2(flaw: Option<crate::material::Flaw>) -> plastic::J2 {
    plastic::J2 {
        bulk_modulus: 211e9 / 3.0,
        shear_modulus: 211e9 / 2.0,
        yield_stress: 460e6,
        hardening_modulus: 5e9,
        flaw,
    }
}

/// A point at reference position `position`, over a step of 1 s.
fn at(position: [f64; 3]) -> PointStep {
    PointStep {
        position,
        duration: 1.0,
    }
}

fn uniaxial_strain(e: f64) -> Tensor<f64> {
    Tensor::from_diagonal(&nalgebra::Vector3::new(e, 0.0, 0.0))
}

fn von_mises(s: &Tensor<f64>) -> f64 {
    let d = kinematics::deviator(s);
    (1.5 * d.iter().map(|x| x * x).sum::<f64>()).sqrt()
}

#[test]
fn j2_hardening_under_uniaxial_strain_matches_the_closed_form() {
    // With ν = 0 the trial von Mises stress of a uniaxial strain ε is 2με, and the radial
    // return gives σ_vm = Y + H(2με − Y)/(3μ + H): 781.0 MPa at ε = 10 % (issue 13's figures).
    let model = j2(None);
    let start = StressState {
        unrotated: Tensor::zeros(),
        equivalent_plastic_strain: 0.0,
    };
    let end = model.advance(&start, &uniaxial_strain(0.1), &at([0.0; 3]));
    let (mu, y, h): (f64, f64, f64) = (211e9 / 2.0, 460e6, 5e9);
    let expected = y + h * (2.0 * mu * 0.1 - y) / (3.0 * mu + h);
    assert!((expected / 1e6 - 781.0).abs() < 0.05, "{expected}");
    assert!((von_mises(&end.unrotated) - expected).abs() < 1e-9 * expected);
    let plastic = (2.0 * mu * 0.1 - y) / (3.0 * mu + h);
    assert!((end.equivalent_plastic_strain - plastic).abs() < 1e-15);
}

#[test]
fn j2_yields_at_the_closed_form_strain() {
    // Uniaxial strain with ν = 0: σ_vm = 2με, so yield at ε_y = Y/(2μ).
    let model = j2(None);
    let start = StressState {
        unrotated: Tensor::zeros(),
        equivalent_plastic_strain: 0.0,
    };
    let yield_strain = 460e6 / 211e9;
    let below = model.advance(
        &start,
        &uniaxial_strain(0.999 * yield_strain),
        &at([0.0; 3]),
    );
    assert_eq!(below.equivalent_plastic_strain, 0.0);
    assert!((von_mises(&below.unrotated) - 0.999 * 460e6).abs() < 1e-6);
    let above = model.advance(
        &start,
        &uniaxial_strain(1.001 * yield_strain),
        &at([0.0; 3]),
    );
    assert!(above.equivalent_plastic_strain > 0.0);
    // Committed in two increments the same total strain gives the same state (linear
    // hardening, radial path).
    let half = model.advance(&start, &uniaxial_strain(0.05), &at([0.0; 3]));
    let two_steps = model.advance(&half, &uniaxial_strain(0.05), &at([0.0; 3]));
    let one_step = model.advance(&start, &uniaxial_strain(0.1), &at([0.0; 3]));
    assert!(max_difference(&two_steps.unrotated, &one_step.unrotated) < 1e-6 * 781e6);
}

#[test]
fn a_flaw_lowers_the_yield_stress_where_it_sits() {
    let flaw = crate::material::Flaw {
        location: [1.0, 0.0, 0.0],
        size: 0.5,
        magnitude: 0.5,
    };
    let model = j2(Some(flaw));
    let start = StressState {
        unrotated: Tensor::zeros(),
        equivalent_plastic_strain: 0.0,
    };
    let strain = uniaxial_strain(0.8 * 460e6 / 211e9);
    let at_flaw = model.advance(&start, &strain, &at([1.0, 0.0, 0.0]));
    let far = model.advance(&start, &strain, &at([5.0, 0.0, 0.0]));
    assert!(at_flaw.equivalent_plastic_strain > 0.0);
    assert_eq!(far.equivalent_plastic_strain, 0.0);
}

#[test]
fn the_plastic_tangent_matches_finite_differences_while_yielding() {
    // Moduli of the lattice body; a yield stress low enough that the perturbed state yields.
    let mut body = Body::new(0.05);
    let plastic = PlasticParameters {
        yield_stress: 2e-3,
        hardening_modulus: 0.3,
        flaw: None,
    };
    let mut m =
        IsotropicHardeningCorrespondence::build(&block(HORIZON), &parameters(0.05, plastic))
            .unwrap();
    crate::material::set_up(
        &mut m,
        &ReferenceView::of(&body.bonds, &body.points),
        (0..body.points.len() as u32).collect(),
    );
    body.physics = Physics::new(
        vec![BlockPhysics {
            material: m,
            damage: None,
        }],
        &body.points,
        &body.bonds,
    );
    let start = perturbed(&body, 2);
    body.force(&start);
    body.commit();
    let y = perturbed(&body, 9);
    body.force(&y);
    let yielding = body
        .history
        .field(fields::EQUIVALENT_PLASTIC_STRAIN)
        .unwrap()
        .trial()
        .iter()
        .filter(|&&e| e > 0.0)
        .count();
    assert!(yielding > body.points.len() / 4, "{yielding} points yield");
    let error = tangent_error(&mut body, &y);
    assert!(error < 1e-6, "relative error {error}");
}

/// Needleman's model with the J2 constants of [`j2`] (E = 211 GPa, ν = 0, σ_y = 460 MPa) and
/// the given N, m, ε̇_ref, ε₀ (ε₁ = 1e30: no softening term).
fn needleman(
    strain_hardening_exponent: f64,
    rate_hardening_exponent: f64,
    reference_strain_rate: f64,
    reference_strain_0: f64,
) -> NeedlemanStress {
    NeedlemanStress {
        bulk_modulus: 211e9 / 3.0,
        shear_modulus: 211e9 / 2.0,
        yield_stress: 460e6,
        parameters: NeedlemanParameters {
            strain_hardening_exponent,
            rate_hardening_exponent,
            reference_strain_rate,
            reference_strain_0,
            reference_strain_1: 1e30,
        },
        flaw: None,
    }
}

fn unstressed() -> StressState<f64> {
    StressState {
        unrotated: Tensor::zeros(),
        equivalent_plastic_strain: 0.0,
    }
}

#[test]
fn needleman_without_rate_dependence_is_the_hardening_radial_return() {
    // m = 0, N = 1, ε₁ → ∞: Y = σ_y (1 + ε̄_p/ε₀), linear hardening with H = σ_y/ε₀. With
    // ε₀ = 460 MPa / 5 GPa = 0.092, H = 5 GPa and issue 13's closed form applies:
    // σ_vm = Y + H(2με − Y)/(3μ + H) = 781.0 MPa at ε = 10 %, ε̄_p = (2με − Y)/(3μ + H).
    let model = needleman(1.0, 0.0, 1.0, 460e6 / 5e9);
    let end = model.advance(&unstressed(), &uniaxial_strain(0.1), &at([0.0; 3]));
    let (mu, y, h): (f64, f64, f64) = (211e9 / 2.0, 460e6, 5e9);
    let expected = y + h * (2.0 * mu * 0.1 - y) / (3.0 * mu + h);
    assert!((expected / 1e6 - 781.0).abs() < 0.05, "{expected}");
    assert!((von_mises(&end.unrotated) - expected).abs() < 1e-9 * expected);
    let plastic = (2.0 * mu * 0.1 - y) / (3.0 * mu + h);
    assert!((end.equivalent_plastic_strain - plastic).abs() < 1e-12);
    // Below σ_y (trial σ_vm = 2με with ν = 0) the step is elastic.
    let below = model.advance(
        &unstressed(),
        &uniaxial_strain(0.99 * y / (2.0 * mu)),
        &at([0.0; 3]),
    );
    assert_eq!(below.equivalent_plastic_strain, 0.0);
}

#[test]
fn needleman_with_linear_rate_hardening_matches_its_closed_form() {
    // N = 0, m = 1, ε₁ → ∞: Y = σ_y √(2/3) Δλ/(Δt ε̇_ref), so g(Δλ) = |s_tr| − (2μ + c) Δλ
    // with c = (2/3) σ_y/(Δt ε̇_ref) (module docs of `viscoplastic`): Δλ = |s_tr|/(2μ + c),
    // σ_vm = q_tr c/(2μ + c) and ε̄_p = (2/3) q_tr/(2μ + c), q_tr = 2με under uniaxial strain
    // with ν = 0. ε = 1 %, ε̇_ref = 1e-3/s, Δt = 1 s: c = 306.67 GPa, σ_vm = 1.2500 GPa.
    let model = needleman(0.0, 1.0, 1e-3, 1.0);
    let (mu, y, e): (f64, f64, f64) = (211e9 / 2.0, 460e6, 0.01);
    let end = model.advance(&unstressed(), &uniaxial_strain(e), &at([0.0; 3]));
    let c = 2.0 / 3.0 * y / 1e-3;
    let trial = 2.0 * mu * e;
    let expected = trial * c / (2.0 * mu + c);
    assert!((expected / 1e9 - 1.2500).abs() < 5e-5, "{expected}");
    assert!((von_mises(&end.unrotated) - expected).abs() < 1e-9 * expected);
    let plastic = 2.0 / 3.0 * trial / (2.0 * mu + c);
    assert!((end.equivalent_plastic_strain - plastic).abs() < 1e-12);
    // Rate hardening: the same strain in half the time meets a stiffer flow stress.
    let fast = model.advance(
        &unstressed(),
        &uniaxial_strain(e),
        &PointStep {
            position: [0.0; 3],
            duration: 0.5,
        },
    );
    assert!(von_mises(&fast.unrotated) > von_mises(&end.unrotated));
}

#[test]
fn needleman_flows_only_when_time_passes() {
    // With m > 0 a step of no duration leaves no time for viscous flow: the trial stands.
    let model = needleman(0.1, 0.05, 1.0, 0.01);
    let strain = uniaxial_strain(0.01);
    let instant = PointStep {
        position: [0.0; 3],
        duration: 0.0,
    };
    let end = model.advance(&unstressed(), &strain, &instant);
    assert_eq!(end.equivalent_plastic_strain, 0.0);
    // Trial von Mises stress 2με (ν = 0).
    assert!((von_mises(&end.unrotated) - 211e9 * 0.01).abs() < 1e-6 * 211e9 * 0.01);
    let flowing = model.advance(&unstressed(), &strain, &at([0.0; 3]));
    assert!(flowing.equivalent_plastic_strain > 0.0);
}

/// A `Viscoplastic Needleman Correspondence` block with the lattice body's moduli and a yield
/// stress low enough that the perturbed states yield.
fn needleman_body() -> Body {
    Body::with(
        ViscoplasticNeedlemanCorrespondence::build(
            &block(HORIZON),
            &parameters(
                0.05,
                NeedlemanInput {
                    yield_stress: 2e-3,
                    parameters: NeedlemanParameters {
                        strain_hardening_exponent: 0.2,
                        rate_hardening_exponent: 0.1,
                        reference_strain_rate: 1.0,
                        reference_strain_0: 0.01,
                        reference_strain_1: 1.0,
                    },
                    flaw: None,
                },
            ),
        )
        .unwrap(),
    )
}

fn yielding_points(body: &Body) -> usize {
    body.history
        .field(fields::EQUIVALENT_PLASTIC_STRAIN)
        .unwrap()
        .trial()
        .iter()
        .filter(|&&e| e > 0.0)
        .count()
}

#[test]
fn the_needleman_tangent_matches_finite_differences_undamaged_and_damaged() {
    let mut body = needleman_body();
    let start = perturbed(&body, 2);
    body.force(&start);
    body.commit();
    let y = perturbed(&body, 9);
    body.force(&y);
    assert!(yielding_points(&body) > body.points.len() / 4);
    let error = tangent_error(&mut body, &y);
    assert!(error < 1e-6, "relative error {error}");

    let mut rng = Rng::new(4);
    let bonds = &body.bonds;
    let mut damage = vec![0.0f32; bonds.num_bonds()];
    for i in 0..bonds.num_points() {
        for b in bonds.range(i) {
            let j = bonds.neighbor[b] as usize;
            if j > i && rng.uniform() < 0.2 {
                let back = bonds.offsets[j] + bonds.family(j).binary_search(&(i as u32)).unwrap();
                damage[b] = 1.0;
                damage[back] = 1.0;
            }
        }
    }
    body.damage = Some(damage);
    let error = tangent_error(&mut body, &y);
    assert!(error < 1e-6, "relative error with damage {error}");
}

#[test]
fn needleman_conserves_momentum_and_a_rigid_rotation_gives_no_stress() {
    let mut body = needleman_body();
    let y = perturbed(&body, 5);
    let force = body.force(&y);
    assert!(yielding_points(&body) > 0);
    let largest = force.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    for k in 0..3 {
        let total: f64 = force
            .iter()
            .zip(&body.points.volume)
            .map(|(f, v)| f[k] * v)
            .sum();
        assert!(
            total.abs() < 1e-12 * largest * body.points.len() as f64,
            "momentum {k}: {total}"
        );
    }
    let q = rotation_about_z(std::f64::consts::FRAC_PI_2);
    let rotated = body.affine(&q);
    let force = body.force(&rotated);
    assert!(force.iter().flatten().all(|v| v.abs() < 1e-13));
    for p in 0..body.points.len() {
        let sigma = body.tensor_field(fields::CAUCHY_STRESS, p);
        assert!(sigma.abs().max() < 1e-14, "σ at point {p}: {sigma}");
    }
    assert_eq!(yielding_points(&body), 0);
}

/// A one-block QuickGrid deck (4×4×4 points) with the material list `material`.
fn deck_with(material: &str) -> crate::io::deck::Deck {
    crate::io::deck::parse_str(
        &deck_text(material),
        crate::io::deck::DeckFormat::Yaml,
        std::path::Path::new("deck.yaml"),
    )
    .unwrap()
}

#[test]
fn the_keys_of_peridigms_needleman_verification_decks_load_and_build() {
    // The keys of Peridigm's ViscoplasticNeedlemanFullyPrescribedTension_WithFlaw deck
    // (Peridigm's test/verification folder): every one is read, none is a warning, and the model builds.
    let deck = deck_with(
        r#"      Material Model: "Viscoplastic Needleman Correspondence"
      Density: 7800.0
      Young's Modulus: 200.0e9
      Poisson's Ratio: 0.3
      Hourglass Coefficient: 0.0
      Yield Stress: 150.0e6
      Strain Hardening Exponent: 0.2
      Rate Hardening Exponent: 0.05
      Reference Strain Rate: 0.001
      Reference Strain 0: 0.001
      Reference Strain 1: 100.0
      Enable Flaw: true
      Flaw Location X: 0.5
      Flaw Location Y: 0.5
      Flaw Location Z: 0.5
      Flaw Size: 0.2
      Flaw Magnitude: 0.1"#,
    );
    assert!(deck.warnings.is_empty(), "{:?}", deck.warnings);
    assert!(crate::setup::report::unsupported_features(&deck).is_empty());
    let model = crate::setup::build(&deck).unwrap();
    let physics = crate::setup::build_physics(&deck, &model).unwrap();
    assert_eq!(
        physics.blocks[0].material.model_name(),
        "Viscoplastic Needleman Correspondence"
    );
}

// ---------------------------------------------------------------------------------------
// The hypoelastic (semi-Lagrangian) models.

/// `Actual Horizon` of the hypoelastic checks: between √2 and √3 lattice spacings, so that the
/// block horizon 1.8 holds the √3 bonds and the physics does not.
const ACTUAL_HORIZON: f64 = 1.6;

/// The parameters of a hypoelastic model with the lattice body's moduli, `Actual Horizon`
/// `actual_horizon` and the stress model's parameters `stress`.
fn hypoelastic<P>(hourglass: f64, actual_horizon: f64, stress: P) -> HypoelasticParameters<P> {
    HypoelasticParameters {
        elastic: ELASTIC,
        actual_horizon,
        gradient_order_of_accuracy: 1,
        hourglass_coefficient: hourglass,
        stress,
    }
}

/// The lattice body of `Elastic Hypoelastic Correspondence` (block horizon 1.8, Actual
/// Horizon 1.6).
fn hypoelastic_body(hourglass: f64) -> Body {
    Body::with(
        ElasticHypoelasticCorrespondence::build(
            &block(HORIZON),
            &hypoelastic(hourglass, ACTUAL_HORIZON, ()),
        )
        .unwrap(),
    )
}

#[test]
fn hypoelastic_homogeneous_deformations_give_hookes_stress() {
    // The closed forms of the Lagrangian checks above: for a homogeneous step the
    // semi-Lagrangian L Δt is (F − I)((F + I)/2)⁻¹ as well (module docs of `hypoelastic`).
    let e = 1e-3;
    let g = 2.0 * e / (2.0 + e);
    let f = Tensor::from_diagonal(&nalgebra::Vector3::new(1.0 + e, 1.0, 1.0));
    let lateral = (BULK - 2.0 * SHEAR / 3.0) * g;
    let expected = Tensor::from_diagonal(&nalgebra::Vector3::new(
        (BULK + 4.0 * SHEAR / 3.0) * g,
        lateral,
        lateral,
    ));
    check_homogeneous_of(hypoelastic_body(0.02), f, expected);

    // Simple shear: σ_xy = σ_yx = μγ (see `simple_shear_gives_shear_stress_mu_gamma`).
    let gamma = 2e-3;
    let mut f = Tensor::identity();
    f[(0, 1)] = gamma;
    let mut expected = Tensor::zeros();
    expected[(0, 1)] = SHEAR * gamma;
    expected[(1, 0)] = SHEAR * gamma;
    check_homogeneous_of(hypoelastic_body(0.02), f, expected);

    // Isotropic compression: pressure 3Kg.
    let e = -2e-3;
    let g = 2.0 * e / (2.0 + e);
    check_homogeneous_of(
        hypoelastic_body(0.02),
        Tensor::identity() * (1.0 + e),
        Tensor::identity() * (3.0 * BULK * g),
    );
}

#[test]
fn hypoelastic_rigid_rotation_of_ninety_degrees_gives_no_stress_and_no_force() {
    let q = rotation_about_z(std::f64::consts::FRAC_PI_2);
    let mut body = hypoelastic_body(0.02);
    let y = body.affine(&q);
    let force = body.force(&y);
    for (p, force) in force.iter().enumerate() {
        let sigma = body.tensor_field(fields::CAUCHY_STRESS, p);
        assert!(sigma.abs().max() < 1e-14, "σ at point {p}: {sigma}");
        assert!(force.iter().all(|v| v.abs() < 1e-13), "force at point {p}");
        let rotation = body.tensor_field(fields::ROTATION, p) + Tensor::identity();
        assert!(max_difference(&rotation, &q) < 1e-14, "R at point {p}");
    }
}

#[test]
fn hypoelastic_stretch_then_ninety_degree_rotation_rotates_the_stress_exactly() {
    // Uniaxial strain e, committed, then a rigid rotation Q of 90° in one step: σ̃ stays the
    // uniaxial Hooke stress of g = 2e/(2 + e) and σ = Q σ̃ Qᵀ (as in the Lagrangian check).
    let e = 1e-3;
    let g = 2.0 * e / (2.0 + e);
    let stretch = Tensor::from_diagonal(&nalgebra::Vector3::new(1.0 + e, 1.0, 1.0));
    let mut body = hypoelastic_body(0.02);
    body.force(&body.affine(&stretch));
    body.commit();
    let q = rotation_about_z(std::f64::consts::FRAC_PI_2);
    let force = body.force(&body.affine(&(q * stretch)));
    let lateral = (BULK - 2.0 * SHEAR / 3.0) * g;
    let unrotated = Tensor::from_diagonal(&nalgebra::Vector3::new(
        (BULK + 4.0 * SHEAR / 3.0) * g,
        lateral,
        lateral,
    ));
    let expected = q * unrotated * q.transpose();
    for p in 0..body.points.len() {
        let sigma = body.tensor_field(fields::CAUCHY_STRESS, p);
        // Round-off of F times the modulus, as in `check_homogeneous`.
        assert!(
            max_difference(&sigma, &expected) < 1e-12 * BULK,
            "σ at point {p}: {sigma} ≠ {expected}"
        );
        let kept = body.tensor_field(fields::UNROTATED_STRESS, p);
        assert!(
            max_difference(&kept, &unrotated) < 1e-12 * BULK,
            "σ̃ at point {p}"
        );
        // F is integrated in rate form and is exact for homogeneous steps.
        let gradient = body.tensor_field(fields::DEFORMATION_GRADIENT, p) + Tensor::identity();
        assert!(
            max_difference(&gradient, &(q * stretch)) < 1e-13,
            "F at point {p}"
        );
    }
    for i in body.deep_interior() {
        let magnitude = force[i].iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(magnitude < 1e-11 * BULK * g, "force at interior point {i}");
    }
}

#[test]
fn hypoelastic_translation_gives_no_force_and_the_forces_conserve_momentum() {
    let mut body = hypoelastic_body(0.05);
    let shifted: Vec<[f64; 3]> = body
        .points
        .position
        .iter()
        .map(|x| [x[0] + 0.3, x[1] - 1.1, x[2] + 2.0])
        .collect();
    let force = body.force(&shifted);
    assert!(force.iter().flatten().all(|v| v.abs() < 1e-13));
    let y = perturbed(&body, 5);
    let force = body.force(&y);
    let largest = force.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(largest > 1e-4, "the perturbed state must carry force");
    for k in 0..3 {
        let total: f64 = force
            .iter()
            .zip(&body.points.volume)
            .map(|(f, v)| f[k] * v)
            .sum();
        assert!(
            total.abs() < 1e-12 * largest * body.points.len() as f64,
            "momentum {k}: {total}"
        );
    }
}

/// Random bond damage (20 % of the pairs broken, both directions).
fn broken_pairs(bonds: &BondList, seed: u64) -> Vec<f32> {
    let mut rng = Rng::new(seed);
    let mut damage = vec![0.0f32; bonds.num_bonds()];
    for i in 0..bonds.num_points() {
        for b in bonds.range(i) {
            let j = bonds.neighbor[b] as usize;
            if j > i && rng.uniform() < 0.2 {
                let back = bonds.offsets[j] + bonds.family(j).binary_search(&(i as u32)).unwrap();
                damage[b] = 1.0;
                damage[back] = 1.0;
            }
        }
    }
    damage
}

#[test]
fn the_hypoelastic_tangent_matches_finite_differences_undamaged_and_damaged() {
    // The perturbed states move bonds by at most ±0.04: the √2 bonds stay inside the Actual
    // Horizon 1.6 and the √3 ones outside, so no bond crosses it within a probe.
    let mut body = hypoelastic_body(0.05);
    let start = perturbed(&body, 2);
    body.force(&start);
    body.commit();
    let y = perturbed(&body, 9);
    let error = tangent_error(&mut body, &y);
    assert!(error < 1e-6, "relative error {error}");
    body.damage = Some(broken_pairs(&body.bonds, 4));
    let error = tangent_error(&mut body, &y);
    assert!(error < 1e-6, "relative error with damage {error}");
}

#[test]
fn the_hypoelastic_plastic_tangent_matches_finite_differences_while_yielding() {
    let input = hypoelastic(
        0.05,
        ACTUAL_HORIZON,
        PlasticParameters {
            yield_stress: 2e-3,
            hardening_modulus: 0.3,
            flaw: None,
        },
    );
    let mut body = Body::with(
        IsotropicHardeningHypoelasticCorrespondence::build(&block(HORIZON), &input).unwrap(),
    );
    let start = perturbed(&body, 2);
    body.force(&start);
    body.commit();
    let y = perturbed(&body, 9);
    body.force(&y);
    assert!(yielding_points(&body) > body.points.len() / 4);
    let error = tangent_error(&mut body, &y);
    assert!(error < 1e-6, "relative error {error}");
    // Perfect plasticity through the same kinematics.
    let mut body = Body::with(
        ElasticPlasticHypoelasticCorrespondence::build(&block(HORIZON), &input).unwrap(),
    );
    body.force(&start);
    body.commit();
    body.force(&y);
    assert!(yielding_points(&body) > body.points.len() / 4);
    let error = tangent_error(&mut body, &y);
    assert!(error < 1e-6, "relative error (perfect plasticity) {error}");
}

#[test]
fn hypoelastic_j2_hardening_under_uniaxial_strain_reaches_the_closed_form() {
    // The constants of `j2` (E = 211 GPa, ν = 0, σ_y = 460 MPa, H = 5 GPa) and the closed
    // form of `j2_hardening_under_uniaxial_strain_matches_the_closed_form`:
    // σ_vm = Y + H(2μg − Y)/(3μ + H) = 781.0 MPa at an unrotated strain increment g = 10 %,
    // reached in one step by F = diag(1 + e, 1, 1) with 2e/(2 + e) = g (midpoint rule).
    let (mu, y, h, g): (f64, f64, f64, f64) = (211e9 / 2.0, 460e6, 5e9, 0.1);
    let input = HypoelasticParameters {
        elastic: ElasticConstants {
            bulk_modulus: 211e9 / 3.0,
            shear_modulus: mu,
        },
        ..hypoelastic(
            0.0,
            ACTUAL_HORIZON,
            PlasticParameters {
                yield_stress: y,
                hardening_modulus: h,
                flaw: None,
            },
        )
    };
    let mut body = Body::with(
        IsotropicHardeningHypoelasticCorrespondence::build(&block(HORIZON), &input).unwrap(),
    );
    let e = 2.0 * g / (2.0 - g);
    let f = Tensor::from_diagonal(&nalgebra::Vector3::new(1.0 + e, 1.0, 1.0));
    body.force(&body.affine(&f));
    let expected = y + h * (2.0 * mu * g - y) / (3.0 * mu + h);
    assert!((expected / 1e6 - 781.0).abs() < 0.05, "{expected}");
    let plastic = (2.0 * mu * g - y) / (3.0 * mu + h);
    let equivalent = body
        .history
        .field(fields::EQUIVALENT_PLASTIC_STRAIN)
        .unwrap()
        .trial()
        .to_vec();
    for (p, &equivalent) in equivalent.iter().enumerate() {
        let sigma = body.tensor_field(fields::CAUCHY_STRESS, p);
        assert!(
            (von_mises(&sigma) - expected).abs() < 1e-9 * expected,
            "σ_vm at point {p}: {}",
            von_mises(&sigma)
        );
        assert!((equivalent - plastic).abs() < 1e-12, "ε̄_p at point {p}");
    }
}

#[test]
fn bonds_beyond_the_actual_horizon_carry_nothing() {
    // Neighbour lists with δ = 1.8 and Actual Horizon 1.6 give the forces of lists built with
    // δ = 1.6 (the √3 bonds, ≈ 1.73 ± 0.04 long here, drop out), and differ from Actual
    // Horizon 1.8, where they count.
    let build = |horizon: f64, actual: f64| {
        ElasticHypoelasticCorrespondence::build(&block(horizon), &hypoelastic(0.05, actual, ()))
            .unwrap()
    };
    let mut wide = Body::with_bonds(build(HORIZON, ACTUAL_HORIZON), HORIZON);
    let mut narrow = Body::with_bonds(build(ACTUAL_HORIZON, ACTUAL_HORIZON), ACTUAL_HORIZON);
    let mut full = Body::with_bonds(build(HORIZON, HORIZON), HORIZON);
    assert!(wide.bonds.num_bonds() > narrow.bonds.num_bonds());
    let y = perturbed(&wide, 3);
    let (a, b, c) = (wide.force(&y), narrow.force(&y), full.force(&y));
    let largest = b.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    let difference = |u: &[[f64; 3]], v: &[[f64; 3]]| {
        u.iter()
            .flatten()
            .zip(v.iter().flatten())
            .fold(0.0f64, |m, (p, q)| m.max((p - q).abs()))
    };
    // Round-off of sums over the same bonds.
    assert!(
        difference(&a, &b) < 1e-12 * largest,
        "{}",
        difference(&a, &b)
    );
    assert!(
        difference(&c, &b) > 1e-2 * largest,
        "{}",
        difference(&c, &b)
    );
}

#[test]
fn the_actual_horizon_is_measured_on_the_current_configuration() {
    // Point (2, 2, 2) and its neighbour at (3, 3, 3), √3 ≈ 1.73 apart: beyond the Actual
    // Horizon 1.6 in the reference configuration, inside it once the body is compressed to
    // 0.9 (1.56). Moving that neighbour changes the point's stress only in the second case.
    let mut body = hypoelastic_body(0.05);
    let index = |x: [f64; 3]| body.points.position.iter().position(|p| *p == x).unwrap();
    let (i, j) = (index([2.0, 2.0, 2.0]), index([3.0, 3.0, 3.0]));
    let nudge = [0.01, -0.02, 0.015];
    let mut stress_change = |scale: f64| {
        let stretch = Tensor::from_diagonal(&nalgebra::Vector3::new(scale * 1.001, scale, scale));
        let y = body.affine(&stretch);
        body.force(&y);
        let before = body.tensor_field(fields::CAUCHY_STRESS, i);
        let mut moved = y.clone();
        for r in 0..3 {
            moved[j][r] += nudge[r];
        }
        body.force(&moved);
        let after = body.tensor_field(fields::CAUCHY_STRESS, i);
        (max_difference(&after, &before), before.abs().max())
    };
    let (change, scale) = stress_change(1.0);
    assert!(scale > 0.0);
    assert_eq!(
        change, 0.0,
        "a bond beyond the Actual Horizon shaped the stress"
    );
    // Inside, the nudge moves a bond of weight ω(1.56/1.6) ≈ 0.1 by ~1 % of its length: a
    // change far above the round-off (1e-15 of the stress) of an unchanged family.
    let (change, scale) = stress_change(0.9);
    assert!(change > 1e-6 * scale, "{change} vs {scale}");
}

/// The text of a one-block QuickGrid deck (4×4×4 points, Horizon 0.6) with the material
/// list `material`.
fn deck_text(material: &str) -> String {
    format!(
        r#"Peridigm:
  Discretization:
    Type: "PdQuickGrid"
    NeighborhoodType: "Spherical"
    TensorProduct3DMeshGenerator:
      X Origin: 0.0
      Y Origin: 0.0
      Z Origin: 0.0
      X Length: 1.0
      Y Length: 1.0
      Z Length: 1.0
      Number Points X: 4
      Number Points Y: 4
      Number Points Z: 4
  Materials:
    M:
{material}
  Blocks:
    B: {{Block Names: "block_1", Material: "M", Horizon: 0.6}}
  Solver:
    Final Time: 1.0
    QuasiStatic: {{Number of Load Steps: 1}}
"#
    )
}

/// The three hypoelastic models with the keys of Peridigm's verification deck (reference
/// §3.3: Actual Horizon below the block Horizon) and `extra` keys.
fn hypoelastic_decks(extra: &str) -> Vec<(&'static str, String)> {
    [
        ("Elastic Hypoelastic Correspondence", ""),
        (
            "Elastic Plastic Hypoelastic Correspondence",
            "\n      Yield Stress: 150.0e6",
        ),
        (
            "Isotropic Hardening Hypoelastic Correspondence",
            "\n      Yield Stress: 150.0e6\n      Hardening Modulus: 1.0e9",
        ),
    ]
    .into_iter()
    .map(|(model, plastic)| {
        (
            model,
            format!(
                "      Material Model: \"{model}\"\n      Density: 7800.0\n      Young's Modulus: 200.0e9\n      Poisson's Ratio: 0.3{plastic}{extra}"
            ),
        )
    })
    .collect()
}

/// The error of building the physics of `deck`, which must fail.
fn physics_error(deck: &crate::io::deck::Deck) -> String {
    let points = crate::setup::build(deck).unwrap();
    crate::setup::build_physics(deck, &points)
        .err()
        .expect("the physics must be refused")
        .to_string()
}

#[test]
fn the_hypoelastic_models_load_their_keys_and_build() {
    for (model, material) in hypoelastic_decks(
        "\n      Actual Horizon: 0.5\n      Gradient Order Of Accuracy: 1\n      Hourglass Coefficient: 0.02",
    ) {
        let deck = deck_with(&material);
        assert!(deck.warnings.is_empty(), "{:?}", deck.warnings);
        assert!(crate::setup::report::unsupported_features(&deck).is_empty());
        let points = crate::setup::build(&deck).unwrap();
        let physics = crate::setup::build_physics(&deck, &points).unwrap();
        assert_eq!(physics.blocks[0].material.model_name(), model);
        assert_eq!(physics.blocks[0].material.horizon(), 0.6);
    }
    // Peridigm's decks give no Hourglass Coefficient: it defaults to 0.
    for (model, material) in hypoelastic_decks("\n      Actual Horizon: 0.6") {
        let points_deck = deck_with(&material);
        let points = crate::setup::build(&points_deck).unwrap();
        let physics = crate::setup::build_physics(&points_deck, &points).unwrap();
        assert_eq!(physics.blocks[0].material.model_name(), model);
    }
}

#[test]
fn hypoelastic_deck_mistakes_are_named() {
    for (_, material) in hypoelastic_decks("") {
        let text = deck_text(&material);
        let error = crate::io::deck::parse_str(
            &text,
            crate::io::deck::DeckFormat::Yaml,
            std::path::Path::new("deck.yaml"),
        )
        .expect_err("Actual Horizon is required")
        .to_string();
        assert!(error.contains("Actual Horizon"), "{error}");
    }
    for (_, material) in hypoelastic_decks("\n      Actual Horizon: 0.7") {
        let error = physics_error(&deck_with(&material));
        assert!(
            error.contains("`Actual Horizon` (0.7) is larger than the block's `Horizon` (0.6)"),
            "{error}"
        );
    }
    for (_, material) in
        hypoelastic_decks("\n      Actual Horizon: 0.5\n      Gradient Order Of Accuracy: 2")
    {
        let error = physics_error(&deck_with(&material));
        assert!(
            error.contains("`Gradient Order Of Accuracy` is 2"),
            "{error}"
        );
    }
    let user = BlockInput {
        influence: InfluenceFunction::user(|zeta, _| 1.0 / zeta),
        ..block(HORIZON)
    };
    assert_eq!(
        ElasticHypoelasticCorrespondence::build(&user, &hypoelastic(0.0, ACTUAL_HORIZON, ())).err(),
        Some(MaterialError::UserInfluenceNotSupported {
            model: "Elastic Hypoelastic Correspondence"
        })
    );
}

#[test]
fn a_hypoelastic_bar_under_small_quasi_static_strain_matches_elastic_correspondence() {
    // A 12 × 3 × 3 bar (spacing 1, δ = 2.1) pulled to 0.1 % strain in two load steps, once
    // with `Elastic Correspondence` and once with `Elastic Hypoelastic Correspondence` with
    // Actual Horizon = Horizon. Both start from the same bonds and ω; they differ only by
    // where the gradient is measured (reference vs current family, ω of the current length)
    // and by the force's current-configuration form, all terms of relative order of the strain
    // (1e-3): the displacements must agree to 1 % of the pull, ten times that order (they
    // differ by 5e-4 of it).
    let dir = std::env::temp_dir().join(format!("peridyn-hypoelastic-{}", std::process::id()));
    let run = |model: &str, extra: &str| -> Vec<f64> {
        let out = dir.join(model.replace(' ', "_"));
        std::fs::create_dir_all(&out).unwrap();
        let text = quasi_static_bar(model, extra);
        let origin = out.join("deck.yaml");
        let deck =
            crate::io::deck::parse_str(&text, crate::io::deck::DeckFormat::Yaml, &origin).unwrap();
        let model = crate::setup::build(&deck).unwrap();
        crate::simulation::run(&deck, &model, &out).unwrap();
        let file = crate::io::exodus::ExodusFile::open(&out.join("bar.e")).unwrap();
        let last = file.times.len() - 1;
        ["DisplacementX", "DisplacementY", "DisplacementZ"]
            .iter()
            .flat_map(|name| {
                let index = file
                    .nodal_variable_names
                    .iter()
                    .position(|n| n == name)
                    .unwrap();
                file.nodal_values(last, index).unwrap()
            })
            .collect()
    };
    let lagrangian = run("Elastic Correspondence", "");
    let hypoelastic = run(
        "Elastic Hypoelastic Correspondence",
        "\n      Actual Horizon: 2.1",
    );
    std::fs::remove_dir_all(&dir).ok();
    let pull = 0.011;
    let largest = lagrangian.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!((largest - pull).abs() < 1e-12, "{largest}");
    let difference = lagrangian
        .iter()
        .zip(&hypoelastic)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(difference < 1e-2 * pull, "{difference}");
}

/// The bar of the end-to-end check with material `model` and its `extra` keys.
fn quasi_static_bar(model: &str, extra: &str) -> String {
    let face = |x: usize| -> String {
        (0..9)
            .map(|k| (1 + x + 12 * k).to_string())
            .collect::<Vec<_>>()
            .join(" ")
    };
    format!(
        r#"Peridigm:
  Discretization:
    Type: "PdQuickGrid"
    NeighborhoodType: "Spherical"
    TensorProduct3DMeshGenerator:
      X Origin: 0.0
      Y Origin: 0.0
      Z Origin: 0.0
      X Length: 12.0
      Y Length: 3.0
      Z Length: 3.0
      Number Points X: 12
      Number Points Y: 3
      Number Points Z: 3
  Materials:
    Steel:
      Material Model: "{model}"
      Density: 7800.0
      Young's Modulus: 200.0e9
      Poisson's Ratio: 0.0
      Hourglass Coefficient: 0.02{extra}
  Blocks:
    Bar:
      Block Names: "block_1"
      Material: "Steel"
      Horizon: 2.1
  Boundary Conditions:
    Left Node Set: "{left}"
    Right Node Set: "{right}"
    Hold X: {{Type: "Prescribed Displacement", Node Set: "Left Node Set", Coordinate: "x", Value: "0.0"}}
    Hold Y: {{Type: "Prescribed Displacement", Node Set: "Left Node Set", Coordinate: "y", Value: "0.0"}}
    Hold Z: {{Type: "Prescribed Displacement", Node Set: "Left Node Set", Coordinate: "z", Value: "0.0"}}
    Pull X: {{Type: "Prescribed Displacement", Node Set: "Right Node Set", Coordinate: "x", Value: "0.011*t"}}
    Pull Y: {{Type: "Prescribed Displacement", Node Set: "Right Node Set", Coordinate: "y", Value: "0.0"}}
    Pull Z: {{Type: "Prescribed Displacement", Node Set: "Right Node Set", Coordinate: "z", Value: "0.0"}}
  Solver:
    Final Time: 1.0
    QuasiStatic:
      Number of Load Steps: 2
      Absolute Tolerance: 1.0e-2
      Maximum Solver Iterations: 20
  Output:
    Output Filename: "bar"
    Output Frequency: 1
    Output Variables:
      Displacement: true
"#,
        left = face(0),
        right = face(11),
    )
}
