//! The hypoelastic (semi-Lagrangian) correspondence models, Peridigm's `Elastic Hypoelastic
//! Correspondence`, `Elastic Plastic Hypoelastic Correspondence` and `Isotropic Hardening
//! Hypoelastic Correspondence` (Peridigm's `Peridigm_HypoelasticCorrespondenceMaterial.cpp`; Behzadinasab & Foster, "A semi-Lagrangian
//! constitutive correspondence framework for peridynamics", J. Mech. Phys. Solids 137 (2020)
//! 103862).
//!
//! The neighbour lists are built once with the block's `Horizon` δ, but the physics sees only
//! the bonds whose **current** length `r = |Δy|` is at most `Actual Horizon` δ_a ≤ δ, weighted
//! by the influence function of the current length, `ω(r, δ_a)`. Per point i, with
//! `w = ω(r, δ_a) (1−d) V_j` over those bonds, Δy = Y_j − Y_i at the end of the step, Δy_n at
//! its start (the committed positions), Δȳ = (Δy + Δy_n)/2 and d the bond damage:
//!
//! 1. the velocity gradient times the step on the midpoint configuration,
//!    `L Δt = (Σ w (Δy − Δy_n)⊗Δȳ) K̄⁻¹`, `K̄ = Σ w Δȳ⊗Δȳ` (the nonlocal gradient of the
//!    displacement increment; for a homogeneous step it is `(F − F_n) F_{n+½}⁻¹`, exactly what
//!    [`super::kinematics`] takes in the Lagrangian models, so a rigid rotation of any size
//!    gives D = 0);
//! 2. the Flanagan–Taylor step and the stress models of the Lagrangian family
//!    ([`super::kinematics::rotate_and_stretch`], [`super::StressModel`]): `Elastic`, J2
//!    perfect plasticity, J2 with linear isotropic hardening, σ = R σ̃ Rᵀ;
//! 3. the deformation gradient integrated in rate form, `F = (I − ½LΔt)⁻¹(I + ½LΔt) F_n`
//!    (exact for homogeneous steps), J = det F;
//! 4. force state `T⟨ξ⟩ = ω(r, δ_a)(1−d) J σ K⁻¹ Δy` with the current shape tensor
//!    `K = Σ w Δy⊗Δy`: the work conjugate of L on the current family per reference volume
//!    (for a homogeneous deformation `J σ K⁻¹ Δy = P K₀⁻¹ ξ`, the Lagrangian force state), and
//!    since `Σ_j w Δy ⊗ σK⁻¹Δy = σ`, angular momentum is conserved;
//! 5. the hourglass term of the Lagrangian family on the bonds inside δ_a,
//!    `T_hg = (1−d) c (−h·Δy)/(ζ |Δy|) Δy`, `h = F ξ − Δy`, with `c = 18 C_hg K/(π δ_a⁴)`.
//!
//! Bonds beyond the block's Horizon in the reference configuration never enter (the neighbour
//! lists are fixed), which is why δ_a may not exceed it.
//!
//! **Where this differs from Peridigm.** Peridigm's implementation of these names
//! (`Peridigm_HypoelasticCorrespondenceMaterial.cpp`) is the bond-associated variant of the
//! paper: it keeps a velocity gradient, rotation and stress per bond. Here the velocity
//! gradient, the rotation and the stress live at the points, as in the Lagrangian family,
//! with the hourglass term that point-level correspondence needs; for homogeneous
//! deformations the two coincide. Peridigm reads no `Hourglass Coefficient` for these models:
//! here it is optional, default 0. `Gradient Order Of Accuracy` other than 1 (Peridigm's
//! higher-order gradients) is refused, and so is a user `Influence Function` expression,
//! since ω of the current length is differentiated for the tangent.
//!
//! **Tangent.** Automatic differentiation of this force code (forward-mode dual numbers), as in
//! the Lagrangian family; `Tangent: "Finite Difference"` differentiates it by central
//! differences. A bond crossing δ_a within a probe makes the force jump there (ω(δ_a) = 1 for
//! `"One"`).
//!
//! **History.** The fields of the Lagrangian family plus the displacement of every point
//! ([`DISPLACEMENT`]), whose committed value gives the positions at the start of the step.

use rayon::prelude::*;

use super::committed::{CommittedHistory, Held};
use super::elastic::ElasticStress;
use super::kinematics::{
    determinant, from_row_major, identity, inverse, lift, rotate_and_stretch, scaled, to_row_major,
    StepStart, Tensor,
};
use super::plastic::{PlasticParameters, PlasticStress};
use super::{
    fields, hourglass_coefficient, tensor_field, well_conditioned, PointStep, PointTensors,
    PointUpdate, StressModel, CORRESPONDENCE_OUTPUTS,
};
use crate::history::History;
use crate::material::keys::{DENSITY, ELASTIC, PROBE_LENGTH, TANGENT};
use crate::material::{
    positive, BlockData, BlockInput, CurrentView, ElasticConstants, InfluenceFunction, Material,
    MaterialError, MaterialKeys, MaterialModel, MaterialOutputs, MaterialParameters,
    MaterialTangent, PointCoefficients, ReferenceView, PERIDIGM_PI,
};
use crate::model::point_chunks::for_each_chunk;
use crate::model::{
    BondList, BondVolumes, FieldCarrier, FieldDeclaration, KeyDoc, ModelDeclaration, Reach,
    TangentSupport,
};
use crate::parameter_list::error::DeckError;
use crate::parameter_list::reader::{Ctx, ListReader};
use crate::tangent::{
    assemble, BlockTangent, ForceState, OrdinaryBond, PointIndex, Scalar, TangentError,
    TangentMethod,
};

/// `Elastic Hypoelastic Correspondence`.
pub(crate) type ElasticHypoelasticCorrespondence = Hypoelastic<ElasticStress>;
/// `Elastic Plastic Hypoelastic Correspondence`: J2 perfect plasticity.
pub(crate) type ElasticPlasticHypoelasticCorrespondence = Hypoelastic<PlasticStress<false>>;
/// `Isotropic Hardening Hypoelastic Correspondence`: J2 with linear isotropic hardening.
pub(crate) type IsotropicHardeningHypoelasticCorrespondence = Hypoelastic<PlasticStress<true>>;

/// The displacement u = Y − X of every point (3 numbers per point, length), written by every
/// hypoelastic block for all points: its committed value is the start of the step.
pub const DISPLACEMENT: &str = "Hypoelastic_Correspondence_Displacement";

/// The fields of the hypoelastic models: those of the Lagrangian family and [`DISPLACEMENT`].
pub const HYPOELASTIC_FIELDS: &[FieldDeclaration] = &[
    tensor_field(fields::DEFORMATION_GRADIENT),
    tensor_field(fields::LEFT_STRETCH),
    tensor_field(fields::ROTATION),
    tensor_field(fields::UNROTATED_STRESS),
    tensor_field(fields::CAUCHY_STRESS),
    tensor_field(fields::STRESS_SHAPE),
    FieldDeclaration {
        name: fields::EQUIVALENT_PLASTIC_STRAIN,
        carrier: FieldCarrier::Point,
        bytes_per_value: 8,
        staged: true,
    },
    FieldDeclaration {
        name: DISPLACEMENT,
        carrier: FieldCarrier::Point,
        bytes_per_value: 24,
        staged: true,
    },
];

/// `Actual Horizon`.
const ACTUAL_HORIZON: KeyDoc = KeyDoc {
    key: "Actual Horizon",
    meaning: "δ_a ≤ the block's `Horizon`: bonds whose current length exceeds it carry nothing",
    unit: "length",
    default: "required",
};

/// `Gradient Order Of Accuracy`.
const GRADIENT_ORDER: KeyDoc = KeyDoc {
    key: "Gradient Order Of Accuracy",
    meaning: "order of the nonlocal gradient; only 1 (Peridigm's default) is implemented",
    unit: "—",
    default: "1",
};

/// `Hourglass Coefficient` of the hypoelastic models (optional: Peridigm's read none).
const HOURGLASS_COEFFICIENT: KeyDoc = KeyDoc {
    key: "Hourglass Coefficient",
    meaning: "C_hg of the hourglass bond constant c = 18 C_hg K/(π δ_a⁴)",
    unit: "—",
    default: "0",
};

/// The deck keys of the hypoelastic models; the elastic one reads the first 10, the perfectly
/// plastic one the first 11.
const HYPOELASTIC_KEYS: &[KeyDoc] = &[
    DENSITY,
    ELASTIC[0],
    ELASTIC[1],
    ELASTIC[2],
    ELASTIC[3],
    ACTUAL_HORIZON,
    GRADIENT_ORDER,
    HOURGLASS_COEFFICIENT,
    TANGENT,
    PROBE_LENGTH,
    super::YIELD_STRESS,
    super::plastic::HARDENING_MODULUS,
];

/// The deck parameters of a hypoelastic correspondence model besides the keys every model
/// shares: the elastic pair, δ_a, the gradient order, C_hg and the stress model's own (`P`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HypoelasticParameters<P> {
    /// K and μ from the elastic pair.
    pub elastic: ElasticConstants,
    /// `Actual Horizon` δ_a (length): the horizon of the physics, measured on the current
    /// configuration; at most the block's `Horizon`, which builds the neighbour lists.
    pub actual_horizon: f64,
    /// `Gradient Order Of Accuracy` (Peridigm's default 1, the only order implemented).
    pub gradient_order_of_accuracy: i64,
    /// `Hourglass Coefficient` C_hg (≥ 0; default 0).
    pub hourglass_coefficient: f64,
    /// The stress model's parameters.
    pub stress: P,
}

impl<P: Clone + PartialEq + std::fmt::Debug + Send + Sync + 'static> MaterialParameters
    for HypoelasticParameters<P>
{
    fn bulk_modulus(&self) -> Option<f64> {
        Some(self.elastic.bulk_modulus)
    }
}

/// A stress model of the Lagrangian family that also has a hypoelastic model.
pub(crate) trait HypoelasticStress: StressModel {
    /// The hypoelastic model's declaration.
    const HYPOELASTIC_DECLARATION: ModelDeclaration;

    /// Reads the stress model's own keys of the hypoelastic model (before δ_a).
    fn read_hypoelastic(ctx: &Ctx, list: &mut ListReader) -> Result<Self::Parameters, DeckError>;
}

/// The keys of the elastic hypoelastic model's example; the plastic ones add theirs.
const EXAMPLE: &str = "Density: 2.0\nBulk Modulus: 3.0\nShear Modulus: 1.7\nActual Horizon: 1.6\n\
                       Hourglass Coefficient: 0.05";

/// The declaration of the hypoelastic model `deck_name` reading the first `keys` keys, with
/// the example `example`.
const fn declaration(
    deck_name: &'static str,
    keys: usize,
    example: &'static str,
) -> ModelDeclaration {
    ModelDeclaration {
        deck_name,
        aliases: &[],
        deck_keys: HYPOELASTIC_KEYS.split_at(keys).0,
        reach: Reach::TwoHop,
        fields: HYPOELASTIC_FIELDS,
        outputs: CORRESPONDENCE_OUTPUTS,
        tangent: TangentSupport::Differentiated,
        thermal_strain: false,
        small_displacement: false,
        example,
    }
}

impl HypoelasticStress for ElasticStress {
    const HYPOELASTIC_DECLARATION: ModelDeclaration =
        declaration("Elastic Hypoelastic Correspondence", 10, EXAMPLE);

    fn read_hypoelastic(_ctx: &Ctx, _list: &mut ListReader) -> Result<(), DeckError> {
        Ok(())
    }
}

impl HypoelasticStress for PlasticStress<false> {
    const HYPOELASTIC_DECLARATION: ModelDeclaration = declaration(
        "Elastic Plastic Hypoelastic Correspondence",
        11,
        "Density: 2.0\nBulk Modulus: 3.0\nShear Modulus: 1.7\nActual Horizon: 1.6\n\
             Hourglass Coefficient: 0.05\nYield Stress: 0.002",
    );

    fn read_hypoelastic(ctx: &Ctx, list: &mut ListReader) -> Result<PlasticParameters, DeckError> {
        Self::read_keys(ctx, list, false)
    }
}

impl HypoelasticStress for PlasticStress<true> {
    const HYPOELASTIC_DECLARATION: ModelDeclaration = declaration(
        "Isotropic Hardening Hypoelastic Correspondence",
        12,
        "Density: 2.0\nBulk Modulus: 3.0\nShear Modulus: 1.7\nActual Horizon: 1.6\n\
             Hourglass Coefficient: 0.05\nYield Stress: 0.002\nHardening Modulus: 0.3",
    );

    fn read_hypoelastic(ctx: &Ctx, list: &mut ListReader) -> Result<PlasticParameters, DeckError> {
        Self::read_keys(ctx, list, false)
    }
}

/// ω of the current bond length, written over the scalar so that the tangent differentiates
/// it (the built-in functions of [`InfluenceFunction`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum CurrentInfluence {
    One,
    ParabolicDecay,
    Gaussian,
}

impl CurrentInfluence {
    fn of(influence: &InfluenceFunction) -> Option<Self> {
        match influence {
            InfluenceFunction::One => Some(Self::One),
            InfluenceFunction::ParabolicDecay => Some(Self::ParabolicDecay),
            InfluenceFunction::Gaussian => Some(Self::Gaussian),
            InfluenceFunction::User(_) => None,
        }
    }

    /// ω(r, δ) for 0 < r ≤ δ, the formulas of [`InfluenceFunction::evaluate`].
    fn weight<T: Scalar>(self, r: T, horizon: f64) -> T {
        match self {
            Self::One => T::from(1.0),
            Self::ParabolicDecay => {
                let x = r * (1.0 / horizon);
                if x.re() < 0.5 {
                    T::from(1.0)
                } else {
                    x * 4.0 - x * x * 4.0
                }
            }
            Self::Gaussian => {
                let width = 0.4 * horizon;
                (-(r * r) * (1.0 / (width * width))).exp()
            }
        }
    }
}

/// A hypoelastic correspondence material of one block (see the module docs).
#[derive(Debug, Clone)]
pub(crate) struct Hypoelastic<S: HypoelasticStress> {
    stress: S,
    /// The block's data; its horizon δ builds the neighbour lists.
    block: BlockData,
    /// `Actual Horizon` δ_a ≤ δ.
    actual_horizon: f64,
    hourglass_coefficient: f64,
    influence: CurrentInfluence,
}

/// What the per-point kinematics read: the reference families, the bond damage and the
/// positions at the start of the step.
struct Family<'a> {
    bonds: &'a BondList,
    /// Reference positions X.
    position: &'a [[f64; 3]],
    volume: BondVolumes<'a>,
    damage: Option<&'a [f32]>,
    /// Committed [`DISPLACEMENT`] (3 per point).
    start_displacement: &'a [f64],
}

impl Family<'_> {
    fn intact(&self, b: usize) -> f64 {
        self.damage.map_or(1.0, |d| 1.0 - f64::from(d[b]))
    }

    /// ξ = X_j − X_i of bond `b` of point `i`.
    fn xi(&self, i: usize, b: usize) -> [f64; 3] {
        let j = self.bonds.neighbor[b] as usize;
        std::array::from_fn(|r| self.position[j][r] - self.position[i][r])
    }

    /// Δy_n = Y_j − Y_i of bond `b` of point `i` at the start of the step.
    fn start_bond(&self, i: usize, b: usize) -> [f64; 3] {
        let j = self.bonds.neighbor[b] as usize;
        let u = self.start_displacement;
        std::array::from_fn(|r| {
            self.position[j][r] + u[3 * j + r] - self.position[i][r] - u[3 * i + r]
        })
    }
}

impl<S: HypoelasticStress> MaterialKeys for Hypoelastic<S> {
    type Parameters = HypoelasticParameters<S::Parameters>;

    const DECLARATION: ModelDeclaration = S::HYPOELASTIC_DECLARATION;

    fn read(ctx: &mut Ctx, list: &mut ListReader) -> Result<Self::Parameters, DeckError> {
        let elastic = crate::material::elastic_constants::read(ctx, list)?;
        let stress = S::read_hypoelastic(ctx, list)?;
        Ok(HypoelasticParameters {
            elastic,
            actual_horizon: list.positive_req(ctx, ACTUAL_HORIZON.key)?,
            gradient_order_of_accuracy: list.int_opt(ctx, GRADIENT_ORDER.key, 1)?.unwrap_or(1),
            hourglass_coefficient: list
                .non_negative_opt(ctx, HOURGLASS_COEFFICIENT.key)?
                .unwrap_or(0.0),
            stress,
        })
    }
}

impl<S: HypoelasticStress> MaterialModel for Hypoelastic<S> {
    fn build(
        block: &BlockInput,
        parameters: &Self::Parameters,
    ) -> Result<Box<dyn Material>, MaterialError> {
        let horizon = positive("Horizon", block.horizon)?;
        let actual_horizon = positive(ACTUAL_HORIZON.key, parameters.actual_horizon)?;
        if actual_horizon > horizon {
            return Err(MaterialError::ActualHorizonBeyondHorizon {
                actual: actual_horizon,
                block: horizon,
            });
        }
        if parameters.gradient_order_of_accuracy != 1 {
            return Err(MaterialError::GradientOrderNotSupported {
                order: parameters.gradient_order_of_accuracy,
            });
        }
        let hourglass_coefficient = hourglass_coefficient(parameters.hourglass_coefficient)?;
        let influence = CurrentInfluence::of(&block.influence).ok_or(
            MaterialError::UserInfluenceNotSupported {
                model: S::HYPOELASTIC_DECLARATION.deck_name,
            },
        )?;
        let stress = S::new(&parameters.elastic, &parameters.stress)?;
        Ok(Box::new(Self {
            stress,
            block: BlockData::new(
                &Self::DECLARATION,
                block.density,
                parameters.elastic.bulk_modulus,
                horizon,
            )?,
            actual_horizon,
            hourglass_coefficient,
            influence,
        }))
    }
}

impl<S: HypoelasticStress> Hypoelastic<S> {
    /// c = 18 C_hg K/(π δ_a⁴), the hourglass bond constant (force/length⁶ per unit stretch).
    fn hourglass_constant(&self) -> f64 {
        18.0 * self.hourglass_coefficient * self.block.bulk_modulus()
            / (PERIDIGM_PI * self.actual_horizon.powi(4))
    }

    /// ω(|Δy|, δ_a) of a bond of current vector `dy`, `None` when it lies beyond δ_a (or has
    /// no length, hence no direction).
    fn weight<T: Scalar>(&self, dy: &[T; 3]) -> Option<T> {
        let squared = dy[0] * dy[0] + dy[1] * dy[1] + dy[2] * dy[2];
        let length_squared = squared.re();
        if length_squared == 0.0 || length_squared > self.actual_horizon * self.actual_horizon {
            return None;
        }
        Some(self.influence.weight(squared.sqrt(), self.actual_horizon))
    }

    fn family<'a>(
        reference: &ReferenceView<'a>,
        current: &CurrentView<'a>,
        history: &'a History,
    ) -> Family<'a> {
        Family {
            bonds: reference.bonds,
            position: reference.position,
            volume: reference.bond_volumes(),
            damage: current.bond_damage,
            start_displacement: history
                .field(DISPLACEMENT)
                .expect("the run allocates every field a hypoelastic model declares")
                .committed(),
        }
    }

    /// The update of point `point` (global index) with its family at `y` (`y[0]` the point,
    /// `y[1 + n]` its n-th neighbour) from the committed `start`; `None` when the bonds inside
    /// δ_a do not span three dimensions.
    fn point_update<T: Scalar>(
        &self,
        family: &Family<'_>,
        point: usize,
        y: &[[T; 3]],
        start: &StepStart,
    ) -> Option<PointUpdate<T>> {
        let mut midpoint_shape = super::kinematics::zero::<T>();
        let mut increment = super::kinematics::zero::<T>();
        let mut current_shape = super::kinematics::zero::<T>();
        for (n, b) in family.bonds.range(point).enumerate() {
            let intact = family.intact(b);
            if intact == 0.0 {
                continue;
            }
            let dy: [T; 3] = std::array::from_fn(|r| y[n + 1][r] - y[0][r]);
            let Some(omega) = self.weight(&dy) else {
                continue;
            };
            let w = omega * (intact * family.volume.of(b, family.bonds.neighbor[b] as usize));
            let dy_start = family.start_bond(point, b);
            let midpoint: [T; 3] = std::array::from_fn(|r| (dy[r] + dy_start[r]) * 0.5);
            for r in 0..3 {
                let wm = w * midpoint[r];
                let wu = w * (dy[r] - dy_start[r]);
                let wy = w * dy[r];
                for c in 0..3 {
                    midpoint_shape[(r, c)] += wm * midpoint[c];
                    increment[(r, c)] += wu * midpoint[c];
                    current_shape[(r, c)] += wy * dy[c];
                }
            }
        }
        let velocity_gradient = increment * inverse(&midpoint_shape)?;
        let current_inverse = inverse(&current_shape)?;
        let step = rotate_and_stretch(&velocity_gradient, start)?;
        let half = scaled(&velocity_gradient, 0.5);
        let relative = inverse(&(identity::<T>() - half))? * (identity::<T>() + half);
        let deformation_gradient = relative * lift::<T>(&start.deformation_gradient);
        let jacobian = determinant(&deformation_gradient);
        let advanced = self.stress.advance(
            &start.stress,
            &step.unrotated_strain_increment,
            &PointStep {
                position: family.position[point],
                duration: start.duration,
            },
        );
        let unrotated_stress = advanced.unrotated;
        let cauchy_stress = step.rotation * unrotated_stress * step.rotation.transpose();
        Some(PointUpdate {
            deformation_gradient,
            left_stretch: step.left_stretch,
            rotation: step.rotation,
            unrotated_stress,
            cauchy_stress,
            stress_shape: (cauchy_stress * current_inverse).map(|x| x * jacobian),
            equivalent_plastic_strain: advanced.equivalent_plastic_strain,
        })
    }

    /// The force state of one bond (force/length⁶) from the side of the point whose
    /// `J σ K⁻¹` and F are `tensors`: ξ and Δy seen from that point, ζ = |ξ|, `intact` = 1 − d.
    fn bond_force_state<T: Scalar>(
        &self,
        tensors: &PointTensors<T>,
        xi: [f64; 3],
        dy: [T; 3],
        zeta: f64,
        intact: f64,
    ) -> [T; 3] {
        let zero = T::from(0.0);
        if intact == 0.0 {
            return [zero; 3];
        }
        let Some(omega) = self.weight(&dy) else {
            return [zero; 3];
        };
        let a = &tensors.stress_shape;
        let w = omega * intact;
        let mut force: [T; 3] = std::array::from_fn(|r| {
            (a[(r, 0)] * dy[0] + a[(r, 1)] * dy[1] + a[(r, 2)] * dy[2]) * w
        });
        if self.hourglass_coefficient > 0.0 {
            let f = &tensors.deformation_gradient;
            let mut departure_dot_dy = zero;
            for r in 0..3 {
                let predicted = f[(r, 0)] * xi[0] + f[(r, 1)] * xi[1] + f[(r, 2)] * xi[2];
                departure_dot_dy += (predicted - dy[r]) * dy[r];
            }
            let length = (dy[0] * dy[0] + dy[1] * dy[1] + dy[2] * dy[2]).sqrt();
            let magnitude =
                -departure_dot_dy * (intact * self.hourglass_constant() / zeta) / length;
            for r in 0..3 {
                force[r] += magnitude * dy[r];
            }
        }
        force
    }

    /// Adds the force density of the block's points: stress and hourglass terms, or the
    /// hourglass term alone.
    fn add_forces(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        force_density: &mut [[f64; 3]],
        with_stress: bool,
    ) {
        let history = current.history;
        let tensor = |name: &str| {
            history
                .field(name)
                .expect("the run allocates every field a hypoelastic model declares")
                .trial()
        };
        let stress_shape = tensor(fields::STRESS_SHAPE);
        let gradient = tensor(fields::DEFORMATION_GRADIENT);
        let at = |values: &[f64], p: usize| from_row_major(&values[9 * p..9 * p + 9]);
        let bonds = reference.bonds;
        let positions = current.position;
        let force_points = self.block.force_points();
        let tensors_of = |p: usize| PointTensors {
            stress_shape: if with_stress {
                at(stress_shape, p)
            } else {
                Tensor::zeros()
            },
            deformation_gradient: at(gradient, p) + identity::<f64>(),
        };
        let intact = |b: usize| current.bond_damage.map_or(1.0, |d| 1.0 - f64::from(d[b]));
        for_each_chunk(
            force_points,
            force_density,
            &|i| i as usize,
            &|chunk: &[u32], base: usize, out: &mut [[f64; 3]]| {
                for &i in chunk {
                    let i = i as usize;
                    let here = tensors_of(i);
                    let mut total = [0.0; 3];
                    for b in bonds.range(i) {
                        let j = bonds.neighbor[b] as usize;
                        let xi: [f64; 3] = std::array::from_fn(|r| {
                            reference.position[j][r] - reference.position[i][r]
                        });
                        let dy: [f64; 3] =
                            std::array::from_fn(|r| positions[j][r] - positions[i][r]);
                        let (zeta, intact) = (bonds.reference_length[b], intact(b));
                        let from_i = self.bond_force_state(&here, xi, dy, zeta, intact);
                        let from_j = self.bond_force_state(
                            &tensors_of(j),
                            xi.map(|x| -x),
                            dy.map(|x| -x),
                            zeta,
                            intact,
                        );
                        let v = reference.neighbor_volume(b, j);
                        for r in 0..3 {
                            total[r] += (from_i[r] - from_j[r]) * v;
                        }
                    }
                    let row = &mut out[i - base];
                    for r in 0..3 {
                        row[r] += total[r];
                    }
                }
            },
        );
    }

    /// The positions of point `p`'s family into `y` (`y[0]` the point).
    fn family_positions(bonds: &BondList, position: &[[f64; 3]], p: usize, y: &mut Vec<[f64; 3]>) {
        y.clear();
        y.push(position[p]);
        y.extend(bonds.family(p).iter().map(|&j| position[j as usize]));
    }
}

impl<S: HypoelasticStress> Material for Hypoelastic<S> {
    fn block(&self) -> &BlockData {
        &self.block
    }

    fn block_mut(&mut self) -> &mut BlockData {
        &mut self.block
    }

    fn prepare(&mut self, reference: &ReferenceView<'_>) -> Result<(), MaterialError> {
        let bonds = reference.bonds;
        // The reference configuration is the first current one: its bonds inside δ_a must
        // span three dimensions.
        let singular = self.block.points().par_iter().find_map_first(|&p| {
            let p = p as usize;
            let mut shape = Tensor::<f64>::zeros();
            let mut inside = 0;
            for b in bonds.range(p) {
                let j = bonds.neighbor[b] as usize;
                let xi: [f64; 3] =
                    std::array::from_fn(|r| reference.position[j][r] - reference.position[p][r]);
                let Some(omega) = self.weight(&xi) else {
                    continue;
                };
                let w = omega * reference.neighbor_volume(b, j);
                if w > 0.0 {
                    inside += 1;
                }
                for r in 0..3 {
                    for c in 0..3 {
                        shape[(r, c)] += w * xi[r] * xi[c];
                    }
                }
            }
            inverse(&shape)
                .filter(|_| well_conditioned(&shape))
                .is_none()
                .then_some((p, inside))
        });
        if let Some((point, intact_bonds)) = singular {
            return Err(MaterialError::SingularShapeTensor {
                point,
                intact_bonds,
            });
        }
        Ok(())
    }

    fn update_history(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        history: &mut History,
    ) {
        let family = Self::family(reference, current, history);
        let committed = CommittedHistory::of(history);
        let updates: Vec<Option<PointUpdate<f64>>> = self
            .block
            .points()
            .par_iter()
            .map_init(Vec::new, |y, &p| {
                let p = p as usize;
                Self::family_positions(family.bonds, current.position, p, y);
                self.point_update(&family, p, y, &committed.start(p))
            })
            .collect();
        // A point without a deformation gradient keeps its committed kinematics and carries
        // no stress (as in the Lagrangian family).
        let mut write =
            |name: &str, held: Held, value: &dyn Fn(&PointUpdate<f64>) -> Tensor<f64>| {
                let field = history
                    .field_mut(name)
                    .expect("the run allocates every field a hypoelastic model declares");
                let (committed, trial) = field.committed_and_trial();
                for (&p, update) in self.block.points().iter().zip(&updates) {
                    let range = 9 * p as usize..9 * p as usize + 9;
                    match (update, held) {
                        (Some(update), _) => {
                            trial[range].copy_from_slice(&to_row_major(&value(update)))
                        }
                        (None, Held::Zero) => trial[range].fill(0.0),
                        (None, Held::Committed) => {
                            trial[range.clone()].copy_from_slice(&committed[range])
                        }
                    }
                }
            };
        let minus_identity = |m: Tensor<f64>| m - identity::<f64>();
        write(fields::DEFORMATION_GRADIENT, Held::Committed, &|u| {
            minus_identity(u.deformation_gradient)
        });
        write(fields::LEFT_STRETCH, Held::Committed, &|u| {
            minus_identity(u.left_stretch)
        });
        write(fields::ROTATION, Held::Committed, &|u| {
            minus_identity(u.rotation)
        });
        write(fields::UNROTATED_STRESS, Held::Committed, &|u| {
            u.unrotated_stress
        });
        write(fields::CAUCHY_STRESS, Held::Zero, &|u| u.cauchy_stress);
        write(fields::STRESS_SHAPE, Held::Zero, &|u| u.stress_shape);
        let field = history
            .field_mut(fields::EQUIVALENT_PLASTIC_STRAIN)
            .expect("the run allocates every field a hypoelastic model declares");
        let (committed, trial) = field.committed_and_trial();
        for (&p, update) in self.block.points().iter().zip(&updates) {
            let p = p as usize;
            trial[p] = update
                .as_ref()
                .map_or(committed[p], |u| u.equivalent_plastic_strain);
        }
        // Every point, not only the block's: the families reach into other blocks, and every
        // hypoelastic block writes the same numbers.
        let displacement = history
            .field_mut(DISPLACEMENT)
            .expect("the run allocates every field a hypoelastic model declares")
            .trial_mut();
        for (p, (y, x)) in current.position.iter().zip(reference.position).enumerate() {
            for r in 0..3 {
                displacement[3 * p + r] = y[r] - x[r];
            }
        }
    }

    fn compute_point_coefficients(
        &self,
        _reference: &ReferenceView<'_>,
        _current: &CurrentView<'_>,
        _coefficients: &mut [PointCoefficients],
    ) {
        // The published numbers of a hypoelastic point are its history fields (J σ K⁻¹ and
        // F), written by `update_history`.
    }

    fn add_force_density(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        _coefficients: &[PointCoefficients],
        force_density: &mut [[f64; 3]],
    ) {
        self.add_forces(reference, current, force_density, true);
    }

    fn stored_energy_density(
        &self,
        _reference: &ReferenceView<'_>,
        _current: &CurrentView<'_>,
        _coefficients: &[PointCoefficients],
        energy_density: &mut [f64],
    ) {
        // A hypoelastic model has no stored-energy function (zero, as for the Lagrangian
        // family).
        for &p in self.block.points() {
            energy_density[p as usize] = 0.0;
        }
    }

    fn tangent(&self) -> Option<&dyn MaterialTangent> {
        Some(self)
    }

    fn outputs(&self) -> Option<&dyn MaterialOutputs> {
        Some(self)
    }
}

impl<S: HypoelasticStress> MaterialTangent for Hypoelastic<S> {
    fn add_tangent(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        method: TangentMethod,
        tangent: &mut BlockTangent,
    ) -> Result<(), TangentError> {
        let kernel = HypoelasticForceState {
            material: self,
            family: Self::family(reference, current, current.history),
            committed: CommittedHistory::of(current.history),
        };
        assemble(
            &kernel,
            Self::DECLARATION.deck_name,
            self.block.points(),
            reference,
            current,
            method,
            tangent,
        )
    }
}

impl<S: HypoelasticStress> MaterialOutputs for Hypoelastic<S> {
    fn add_hourglass_force_density(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        out: &mut [[f64; 3]],
    ) {
        self.add_forces(reference, current, out, false);
    }
}

impl<S: HypoelasticStress> Hypoelastic<S> {
    /// The model's declaration (its stress model's hypoelastic one).
    const DECLARATION: ModelDeclaration = S::HYPOELASTIC_DECLARATION;
}

/// The force state of a hypoelastic point for the tangent assembly: the same update as the
/// force, from the committed history, generic over the scalar.
struct HypoelasticForceState<'a, S: HypoelasticStress> {
    material: &'a Hypoelastic<S>,
    family: Family<'a>,
    committed: CommittedHistory<'a>,
}

impl<S: HypoelasticStress> ForceState for HypoelasticForceState<'_, S> {
    const BOND_LOCAL: bool = false;
    const ANALYTIC: bool = false;

    fn force_state<T: Scalar>(
        &self,
        point: PointIndex,
        y: &[[T; 3]],
        _only: Option<usize>,
        t: &mut [[T; 3]],
    ) {
        let start = self.committed.start(point.global);
        let Some(update) = self
            .material
            .point_update(&self.family, point.global, y, &start)
        else {
            t.fill([T::from(0.0); 3]);
            return;
        };
        let tensors = PointTensors {
            stress_shape: update.stress_shape,
            deformation_gradient: update.deformation_gradient,
        };
        let family = &self.family;
        for (n, b) in family.bonds.range(point.global).enumerate() {
            t[n] = self.material.bond_force_state(
                &tensors,
                family.xi(point.global, b),
                std::array::from_fn(|r| y[n + 1][r] - y[0][r]),
                family.bonds.reference_length[b],
                family.intact(b),
            );
        }
    }

    fn ordinary_derivatives(&self, _point: PointIndex, _y: &[[f64; 3]], _out: &mut [OrdinaryBond]) {
        unreachable!("a hypoelastic force state is not ordinary (ANALYTIC is false)")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_current_weight_is_the_reference_influence_function_of_the_current_length() {
        for (influence, function) in [
            (CurrentInfluence::One, InfluenceFunction::One),
            (
                CurrentInfluence::ParabolicDecay,
                InfluenceFunction::ParabolicDecay,
            ),
            (CurrentInfluence::Gaussian, InfluenceFunction::Gaussian),
        ] {
            assert_eq!(CurrentInfluence::of(&function), Some(influence));
            for r in [0.1, 0.7, 1.0, 1.3, 1.6] {
                let expected = function.evaluate(r, 1.6);
                assert!(
                    (influence.weight(r, 1.6) - expected).abs() < 1e-15,
                    "{influence:?} at {r}"
                );
            }
        }
        assert!(CurrentInfluence::of(&InfluenceFunction::user(|_, _| 1.0)).is_none());
    }
}
