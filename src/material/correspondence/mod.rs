//! Correspondence models (Silling et al. 2007, §15; Peridigm's `correspondence.cxx`): a
//! classical stress model evaluated at every point from a nonlocal deformation gradient, turned
//! back into a force state.
//!
//! Per point i, with ξ = X_j − X_i, Δy = Y_j − Y_i, ζ = |ξ|, ω the influence function and d the
//! bond damage:
//!
//! 1. shape tensor `K = Σ_j ω (1−d) V_j ξ⊗ξ`, deformation gradient
//!    `F = (Σ_j ω (1−d) V_j Δy⊗ξ) K⁻¹` ([`kinematics`]);
//! 2. the Flanagan–Taylor step from the committed `F_n, V_n, R_n` gives the rotation R and the
//!    unrotated strain increment `d Δt` ([`kinematics::flanagan_taylor`]);
//! 3. the stress model advances the unrotated Cauchy stress σ̃ ([`StressModel`]), which is
//!    rotated, `σ = R σ̃ Rᵀ`, and turned into the first Piola–Kirchhoff stress `P = J σ F⁻ᵀ`;
//! 4. force state `T⟨ξ⟩ = ω (1−d) P K⁻¹ ξ + T_hg⟨ξ⟩`, with Peridigm's hourglass term
//!    `T_hg = (1−d) c (−h·Δy)/(ζ |Δy|) Δy`, `h = F ξ − Δy` (the bond's departure from the affine
//!    prediction), `c = 18 C_hg K/(π δ⁴)`;
//! 5. force density `F_i = Σ_j (T_i⟨ξ_ij⟩ − T_j⟨ξ_ji⟩) V_j`.
//!
//! **Damage.** Peridigm hard-wires d = 0 in the shape tensor, the deformation gradient and the
//! hourglass force of these models (its issue #87); here the bond damage enters all three, so a
//! broken bond carries no force of either kind and no longer shapes F. Without a damage model
//! the two agree.
//!
//! **Singular shape tensors.** A point whose intact bonds do not span three dimensions has no
//! deformation gradient. At setup (no damage yet) that is an error naming the point and its
//! intact-bond count. During a run (bonds broken) the point carries no stress and no hourglass
//! force of its own; the implicit solvers hold points with too few intact bonds.
//!
//! **History.** F, V, R (stored as their difference from the identity, so that a fresh history
//! is the undeformed state), σ̃, σ and `P K⁻¹` are staged point fields of the run's
//! [`crate::history::History`]: each force evaluation advances them from the committed values of
//! the step's start, and a step's acceptance commits them.
//!
//! The hypoelastic (semi-Lagrangian) models, which measure the deformation on the current
//! configuration with `Actual Horizon`, share the stress models and history of this family:
//! [`hypoelastic`].
//!
//! **Thermal strain** (`Elastic Correspondence` with `Thermal Expansion Coefficient` α, as
//! Peridigm's `updateElasticCauchyStress`): the stress model advances with the unrotated strain
//! increment less the free thermal strain of the step, `d Δt − α (ΔT_{n+1} − ΔT_n) I`, ΔT the
//! temperature change of the point; ΔT_n is the value of the step's start, staged with the
//! history ([`crate::history::Thermal::evaluated`]). The increments sum to a logarithmic
//! strain, so a free body heated uniformly settles at the stretch e^{αΔT} (held at 1 + αΔT it
//! keeps a stress of order K (αΔT)²).
//!
//! Not yet supported: runs on several MPI ranks (the ranks do not exchange material history
//! yet).

pub(crate) mod kinematics;

mod committed;
mod elastic;
mod force_state;
mod hypoelastic;
mod plastic;
#[cfg(test)]
mod tests;
mod viscoplastic;

pub(crate) use elastic::ElasticStress;
pub(crate) use hypoelastic::{
    ElasticHypoelasticCorrespondence, ElasticPlasticHypoelasticCorrespondence,
    IsotropicHardeningHypoelasticCorrespondence,
};
pub use hypoelastic::{DISPLACEMENT as HYPOELASTIC_DISPLACEMENT, HYPOELASTIC_FIELDS};
pub use plastic::{Flaw, PlasticParameters};
pub(crate) use plastic::{HardeningPlasticStress, PerfectlyPlasticStress};
pub(crate) use viscoplastic::NeedlemanStress;
pub use viscoplastic::{NeedlemanInput, NeedlemanParameters};

use rayon::prelude::*;

use self::committed::{CommittedHistory, Held};
use self::force_state::CorrespondenceForceState;
use self::kinematics::{
    determinant, flanagan_taylor, from_row_major, identity, inverse, lift, to_row_major, StepStart,
    Tensor,
};
use super::influence::InfluenceFunction;
use super::keys::non_negative_req;
use super::{
    local_offsets, BlockData, BlockInput, CurrentView, ElasticConstants, Material, MaterialError,
    MaterialKeys, MaterialModel, MaterialOutputs, MaterialParameters, MaterialTangent,
    PointCoefficients, ReferenceView, PERIDIGM_PI,
};
use crate::history::History;
use crate::model::point_chunks::for_each_chunk;
use crate::model::{
    BondList, BondVolumes, FieldCarrier, FieldDeclaration, KeyDoc, ModelDeclaration,
};
use crate::parameter_list::error::DeckError;
use crate::parameter_list::reader::{Ctx, ListReader};
use crate::tangent::{assemble, BlockTangent, PointIndex, Scalar, TangentError, TangentMethod};

/// `Hourglass Coefficient` of the Lagrangian correspondence models.
pub(crate) const HOURGLASS_COEFFICIENT: KeyDoc = KeyDoc {
    key: "Hourglass Coefficient",
    meaning: "C_hg of the hourglass bond constant c = 18 C_hg K/(π δ⁴)",
    unit: "—",
    default: "required",
};

/// `Yield Stress` of the plastic correspondence models.
pub(crate) const YIELD_STRESS: KeyDoc = KeyDoc {
    key: "Yield Stress",
    meaning: "σ_y, the uniaxial yield stress of J2 plasticity",
    unit: "pressure",
    default: "required",
};

/// The deck parameters of a correspondence model besides the keys every model shares: the
/// elastic pair, the hourglass coefficient and the stress model's own (`P`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CorrespondenceParameters<P> {
    /// K and μ from the elastic pair.
    pub elastic: ElasticConstants,
    /// `Hourglass Coefficient` C_hg (dimensionless, ≥ 0).
    pub hourglass_coefficient: f64,
    /// The stress model's parameters.
    pub stress: P,
}

impl<P: Clone + PartialEq + std::fmt::Debug + Send + Sync + 'static> MaterialParameters
    for CorrespondenceParameters<P>
{
    fn bulk_modulus(&self) -> Option<f64> {
        Some(self.elastic.bulk_modulus)
    }
}

/// `value` if it is a finite number ≥ 0, else the error naming the hourglass coefficient.
fn hourglass_coefficient(value: f64) -> Result<f64, MaterialError> {
    if value.is_finite() && value >= 0.0 {
        Ok(value)
    } else {
        Err(MaterialError::NotNonNegative {
            key: HOURGLASS_COEFFICIENT.key,
            value,
        })
    }
}

/// `Elastic Correspondence`: the correspondence family with the hypoelastic stress model.
pub(crate) type ElasticCorrespondence = Correspondence<ElasticStress>;
/// `Elastic Plastic Correspondence`: J2 perfect plasticity.
pub(crate) type ElasticPlasticCorrespondence = Correspondence<PerfectlyPlasticStress>;
/// `Isotropic Hardening Correspondence`: J2 with linear isotropic hardening.
pub(crate) type IsotropicHardeningCorrespondence = Correspondence<HardeningPlasticStress>;
/// `Viscoplastic Needleman Correspondence`: rate-dependent J2 with Needleman's flow stress.
pub(crate) type ViscoplasticNeedlemanCorrespondence = Correspondence<NeedlemanStress>;

/// What a stress model advances at a point over a step.
#[derive(Debug, Clone, Copy)]
pub(crate) struct StressState<T: Scalar> {
    /// Unrotated Cauchy stress σ̃ (pressure).
    pub unrotated: Tensor<T>,
    /// Equivalent plastic strain ε̄_p (dimensionless; stays 0 in elastic models).
    pub equivalent_plastic_strain: T,
}

/// The constitutive part of a correspondence model: how the unrotated Cauchy stress (and its
/// internal variable) advance over a step.
pub(crate) trait StressModel: std::fmt::Debug + Clone + Send + Sync + 'static {
    /// The stress model's own deck parameters.
    type Parameters: std::fmt::Debug + Clone + PartialEq + Send + Sync + 'static;

    /// What the model declares (deck name and keys, fields, outputs, thermal strain: Peridigm
    /// gives it only to the elastic model).
    const DECLARATION: ModelDeclaration;

    /// Reads the stress model's own keys (after the elastic pair and the hourglass
    /// coefficient).
    fn read(ctx: &mut Ctx, list: &mut ListReader) -> Result<Self::Parameters, DeckError>;

    /// The model's constants from K and μ and its own parameters (validated).
    fn new(
        elastic: &ElasticConstants,
        parameters: &Self::Parameters,
    ) -> Result<Self, MaterialError>;

    /// The state at the end of the step from the state at its start and the unrotated strain
    /// increment `d Δt` (dimensionless), at the point and over the step of `step`, generic
    /// over the scalar for the AD tangent.
    fn advance<T: Scalar>(
        &self,
        start: &StressState<f64>,
        increment: &Tensor<T>,
        step: &PointStep,
    ) -> StressState<T>;
}

/// Where and over how long a stress model advances a point.
#[derive(Debug, Clone, Copy)]
pub(crate) struct PointStep {
    /// The point's reference position X (length; models with a flaw).
    pub position: [f64; 3],
    /// Δt of the step (s; rate-dependent models), [`History::step_duration`].
    pub duration: f64,
}

/// The staged point fields of every correspondence model (9 numbers per point, row-major).
pub mod fields {
    /// F − I.
    pub const DEFORMATION_GRADIENT: &str = "Correspondence_Deformation_Gradient";
    /// V − I (left stretch).
    pub const LEFT_STRETCH: &str = "Correspondence_Left_Stretch";
    /// R − I (rotation).
    pub const ROTATION: &str = "Correspondence_Rotation";
    /// σ̃, Peridigm's `Unrotated_Cauchy_Stress`.
    pub const UNROTATED_STRESS: &str = "Unrotated_Cauchy_Stress";
    /// σ, Peridigm's `Cauchy_Stress`.
    pub const CAUCHY_STRESS: &str = "Cauchy_Stress";
    /// P K⁻¹, read by the neighbours' force pass.
    pub const STRESS_SHAPE: &str = "Correspondence_Piola_Stress_Shape_Inverse";
    /// ε̄_p, Peridigm's `Equivalent_Plastic_Strain` (one number per point).
    pub const EQUIVALENT_PLASTIC_STRAIN: &str = "Equivalent_Plastic_Strain";
}

/// The declaration of a staged 3×3 point field.
const fn tensor_field(name: &'static str) -> FieldDeclaration {
    FieldDeclaration {
        name,
        carrier: FieldCarrier::Point,
        bytes_per_value: 72,
        staged: true,
    }
}

/// The fields every correspondence model keeps.
pub const CORRESPONDENCE_FIELDS: &[FieldDeclaration] = &[
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
];

/// The outputs every correspondence model provides.
pub const CORRESPONDENCE_OUTPUTS: &[&str] = &[
    "Cauchy_Stress",
    "Unrotated_Cauchy_Stress",
    "Von_Mises_Stress",
    "Hourglass_Force_Density",
    "Equivalent_Plastic_Strain",
];

/// A correspondence material of one block (see the module docs).
#[derive(Debug, Clone)]
pub(crate) struct Correspondence<S: StressModel> {
    stress: S,
    block: BlockData,
    hourglass_coefficient: f64,
    influence: InfluenceFunction,
    /// Block-local row starts into `weights`.
    local_offsets: Vec<usize>,
    /// ω per block bond.
    weights: Vec<f64>,
}

/// What one point's update produces (generic over the scalar for the tangent).
#[derive(Debug, Clone, Copy)]
struct PointUpdate<T: Scalar> {
    deformation_gradient: Tensor<T>,
    left_stretch: Tensor<T>,
    rotation: Tensor<T>,
    unrotated_stress: Tensor<T>,
    cauchy_stress: Tensor<T>,
    /// P K⁻¹.
    stress_shape: Tensor<T>,
    equivalent_plastic_strain: T,
}

impl<S: StressModel> MaterialKeys for Correspondence<S> {
    type Parameters = CorrespondenceParameters<S::Parameters>;

    const DECLARATION: ModelDeclaration = S::DECLARATION;

    fn read(ctx: &mut Ctx, list: &mut ListReader) -> Result<Self::Parameters, DeckError> {
        Ok(CorrespondenceParameters {
            elastic: super::elastic_constants::read(ctx, list)?,
            hourglass_coefficient: non_negative_req(ctx, list, HOURGLASS_COEFFICIENT.key)?,
            stress: S::read(ctx, list)?,
        })
    }
}

impl<S: StressModel> MaterialModel for Correspondence<S> {
    fn build(
        block: &BlockInput,
        parameters: &Self::Parameters,
    ) -> Result<Box<dyn Material>, MaterialError> {
        let hourglass_coefficient = hourglass_coefficient(parameters.hourglass_coefficient)?;
        let stress = S::new(&parameters.elastic, &parameters.stress)?;
        Ok(Box::new(Self {
            stress,
            block: BlockData::new(
                &Self::DECLARATION,
                block.density,
                parameters.elastic.bulk_modulus,
                block.horizon,
            )?,
            hourglass_coefficient,
            influence: block.influence.clone(),
            local_offsets: vec![0],
            weights: Vec::new(),
        }))
    }
}

impl<S: StressModel> Correspondence<S> {
    /// c = 18 C_hg K/(π δ⁴), the hourglass bond constant (force/length⁶ per unit stretch).
    fn hourglass_constant(&self) -> f64 {
        18.0 * self.hourglass_coefficient * self.block.bulk_modulus()
            / (PERIDIGM_PI * self.block.horizon().powi(4))
    }

    fn family<'a>(
        &'a self,
        reference: &ReferenceView<'a>,
        current: &CurrentView<'a>,
    ) -> Family<'a> {
        Family {
            bonds: reference.bonds,
            position: reference.position,
            volume: reference.bond_volumes(),
            local_offsets: &self.local_offsets,
            weights: &self.weights,
            damage: current.bond_damage,
        }
    }

    /// The update of point `point` with its family at `y` (`y[0]` the point, `y[1 + n]` its n-th
    /// neighbour) from the committed `start`, given its shape tensor's inverse
    /// ([`Family::shape_inverse`]); `None` when its deformation gradient is singular.
    fn point_update<T: Scalar>(
        &self,
        family: &Family<'_>,
        point: PointIndex,
        y: &[[T; 3]],
        (start, shape_inverse): (&StepStart, &Tensor<f64>),
    ) -> Option<PointUpdate<T>> {
        let mut first_term = kinematics::zero::<T>();
        for (n, b) in family.bonds.range(point.global).enumerate() {
            let weight = family.weight(point, n, b);
            if weight == 0.0 {
                continue;
            }
            let xi = family.xi(point.global, b);
            for r in 0..3 {
                let dy = (y[n + 1][r] - y[0][r]) * weight;
                for c in 0..3 {
                    first_term[(r, c)] += dy * xi[c];
                }
            }
        }
        let deformation_gradient = first_term * lift::<T>(shape_inverse);
        let f_inverse = inverse(&deformation_gradient)?;
        let step = flanagan_taylor(&deformation_gradient, start)?;
        let mut increment = step.unrotated_strain_increment;
        if let Some(alpha) = self.block.thermal_expansion() {
            let free = alpha * start.temperature_increment;
            for k in 0..3 {
                increment[(k, k)] -= free;
            }
        }
        let advanced = self.stress.advance(
            &start.stress,
            &increment,
            &PointStep {
                position: family.position[point.global],
                duration: start.duration,
            },
        );
        let unrotated_stress = advanced.unrotated;
        let cauchy_stress = step.rotation * unrotated_stress * step.rotation.transpose();
        let jacobian = determinant(&deformation_gradient);
        let piola = (cauchy_stress * f_inverse.transpose()).map(|x| x * jacobian);
        Some(PointUpdate {
            deformation_gradient,
            left_stretch: step.left_stretch,
            rotation: step.rotation,
            unrotated_stress,
            cauchy_stress,
            stress_shape: piola * lift::<T>(shape_inverse),
            equivalent_plastic_strain: advanced.equivalent_plastic_strain,
        })
    }

    /// The force state of one bond from the side of the point whose `P K⁻¹` and F are
    /// `tensors` (force/length⁶).
    fn bond_force_state<T: Scalar>(&self, tensors: &PointTensors<T>, bond: &Bond<T>) -> [T; 3] {
        let (xi, dy) = (bond.xi, bond.dy);
        let a = &tensors.stress_shape;
        let mut force: [T; 3] = std::array::from_fn(|r| {
            (a[(r, 0)] * xi[0] + a[(r, 1)] * xi[1] + a[(r, 2)] * xi[2]) * bond.weight
        });
        let length_squared = dy[0] * dy[0] + dy[1] * dy[1] + dy[2] * dy[2];
        if self.hourglass_coefficient > 0.0 && bond.intact > 0.0 && length_squared.re() > 0.0 {
            let f = &tensors.deformation_gradient;
            let mut departure_dot_dy = T::from(0.0);
            for r in 0..3 {
                let predicted = f[(r, 0)] * xi[0] + f[(r, 1)] * xi[1] + f[(r, 2)] * xi[2];
                departure_dot_dy += (predicted - dy[r]) * dy[r];
            }
            let magnitude = -departure_dot_dy
                * (bond.intact * self.hourglass_constant() / bond.zeta)
                / length_squared.sqrt();
            for r in 0..3 {
                force[r] += magnitude * dy[r];
            }
        }
        force
    }

    /// The positions of point `p`'s family into `y` (`y[0]` the point).
    fn family_positions(bonds: &BondList, position: &[[f64; 3]], p: usize, y: &mut Vec<[f64; 3]>) {
        y.clear();
        y.push(position[p]);
        y.extend(bonds.family(p).iter().map(|&j| position[j as usize]));
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
                .expect("the run allocates every field a correspondence model declares")
                .trial()
        };
        let stress_shape = tensor(fields::STRESS_SHAPE);
        let gradient = tensor(fields::DEFORMATION_GRADIENT);
        let at = |values: &[f64], p: usize| from_row_major(&values[9 * p..9 * p + 9]);
        let family = self.family(reference, current);
        let force_points = self.block.force_points();
        let positions = current.position;
        let tensors_of = |p: usize| PointTensors {
            stress_shape: if with_stress {
                at(stress_shape, p)
            } else {
                Tensor::zeros()
            },
            deformation_gradient: at(gradient, p) + identity::<f64>(),
        };
        for_each_chunk(
            force_points,
            force_density,
            &|i| i as usize,
            &|chunk: &[u32], base: usize, out: &mut [[f64; 3]]| {
                for &i in chunk {
                    let i = i as usize;
                    let here = tensors_of(i);
                    let mut total = [0.0; 3];
                    let row_start = self.local_row_start(i);
                    for (n, b) in family.bonds.range(i).enumerate() {
                        let j = family.bonds.neighbor[b] as usize;
                        let intact = family.intact(b);
                        let bond = Bond {
                            xi: family.xi(i, b),
                            dy: std::array::from_fn(|r| positions[j][r] - positions[i][r]),
                            zeta: family.bonds.reference_length[b],
                            weight: self.weights[row_start + n] * intact,
                            intact,
                        };
                        let from_i = self.bond_force_state(&here, &bond);
                        let from_j = self.bond_force_state(&tensors_of(j), &bond.reversed());
                        let v = family.volume.of(b, j);
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

    /// Where global point `i`'s bonds start in the block-local bond arrays (`i` is a block
    /// point).
    fn local_row_start(&self, i: usize) -> usize {
        let k = self
            .block
            .points()
            .binary_search(&(i as u32))
            .expect("the force pass visits only block points");
        self.local_offsets[k]
    }
}

/// What a point contributes to the force states of its bonds.
struct PointTensors<T: Scalar> {
    /// P K⁻¹ (zero for the hourglass force alone).
    stress_shape: Tensor<T>,
    /// F.
    deformation_gradient: Tensor<T>,
}

/// One bond seen from one of its ends.
struct Bond<T: Scalar> {
    /// ξ = X_j − X_i.
    xi: [f64; 3],
    /// Δy = Y_j − Y_i.
    dy: [T; 3],
    /// ζ = |ξ|.
    zeta: f64,
    /// ω (1 − d).
    weight: f64,
    /// 1 − d.
    intact: f64,
}

impl<T: Scalar> Bond<T> {
    /// The same bond seen from its other end (ξ and Δy reversed).
    fn reversed(&self) -> Self {
        Self {
            xi: self.xi.map(|x| -x),
            dy: self.dy.map(|x| -x),
            ..*self
        }
    }
}

/// What the per-point kinematics read: the reference families, ω and the bond damage.
struct Family<'a> {
    bonds: &'a BondList,
    position: &'a [[f64; 3]],
    volume: BondVolumes<'a>,
    local_offsets: &'a [usize],
    weights: &'a [f64],
    damage: Option<&'a [f32]>,
}

impl Family<'_> {
    fn xi(&self, i: usize, b: usize) -> [f64; 3] {
        let j = self.bonds.neighbor[b] as usize;
        std::array::from_fn(|r| self.position[j][r] - self.position[i][r])
    }

    fn intact(&self, b: usize) -> f64 {
        self.damage.map_or(1.0, |d| 1.0 - f64::from(d[b]))
    }

    /// ω (1−d) V_j of the n-th bond `b` of `point`.
    fn weight(&self, point: PointIndex, n: usize, b: usize) -> f64 {
        let omega = self.weights[self.local_offsets[point.local] + n];
        omega * self.intact(b) * self.volume.of(b, self.bonds.neighbor[b] as usize)
    }

    /// K⁻¹ of `point`, `None` when K is singular.
    fn shape_inverse(&self, point: PointIndex) -> Option<Tensor<f64>> {
        inverse(&self.shape_tensor(point).0)
    }

    /// K of `point` and its number of intact bonds.
    fn shape_tensor(&self, point: PointIndex) -> (Tensor<f64>, usize) {
        let mut shape = Tensor::<f64>::zeros();
        let mut intact = 0;
        for (n, b) in self.bonds.range(point.global).enumerate() {
            let weight = self.weight(point, n, b);
            if weight > 0.0 {
                intact += 1;
            }
            let xi = self.xi(point.global, b);
            for r in 0..3 {
                for c in 0..3 {
                    shape[(r, c)] += weight * xi[r] * xi[c];
                }
            }
        }
        (shape, intact)
    }
}

impl<S: StressModel> Material for Correspondence<S> {
    fn block(&self) -> &BlockData {
        &self.block
    }

    fn block_mut(&mut self) -> &mut BlockData {
        &mut self.block
    }

    fn prepare(&mut self, reference: &ReferenceView<'_>) -> Result<(), MaterialError> {
        let bonds = reference.bonds;
        let points = self.block.points();
        self.weights = self
            .influence
            .per_bond(bonds, points, self.block.horizon())?;
        self.local_offsets = local_offsets(bonds, points);
        let undamaged = CurrentView {
            position: reference.position,
            bond_damage: None,
            history: &crate::history::NO_HISTORY,
        };
        let family = self.family(reference, &undamaged);
        let singular = self
            .block
            .points()
            .par_iter()
            .enumerate()
            .find_map_first(|(local, &p)| {
                let point = PointIndex {
                    global: p as usize,
                    local,
                };
                let (shape, intact_bonds) = family.shape_tensor(point);
                inverse(&shape)
                    .filter(|_| well_conditioned(&shape))
                    .is_none()
                    .then_some((p as usize, intact_bonds))
            });
        match singular {
            Some((point, intact_bonds)) => Err(MaterialError::SingularShapeTensor {
                point,
                intact_bonds,
            }),
            None => Ok(()),
        }
    }

    fn update_history(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        history: &mut History,
    ) {
        let family = self.family(reference, current);
        let committed = CommittedHistory::of(history);
        let updates: Vec<Option<PointUpdate<f64>>> = self
            .block
            .points()
            .par_iter()
            .enumerate()
            .map_init(Vec::new, |y, (local, &p)| {
                let p = p as usize;
                Self::family_positions(family.bonds, current.position, p, y);
                let point = PointIndex { global: p, local };
                let shape_inverse = family.shape_inverse(point)?;
                let start = committed.start(p);
                self.point_update(&family, point, y, (&start, &shape_inverse))
            })
            .collect();
        // A point without a deformation gradient keeps its committed kinematics and carries
        // no stress.
        let mut write =
            |name: &str, held: Held, value: &dyn Fn(&PointUpdate<f64>) -> Tensor<f64>| {
                let field = history
                    .field_mut(name)
                    .expect("the run allocates every field a correspondence model declares");
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
            .expect("the run allocates every field a correspondence model declares");
        let (committed, trial) = field.committed_and_trial();
        for (&p, update) in self.block.points().iter().zip(&updates) {
            let p = p as usize;
            trial[p] = update
                .as_ref()
                .map_or(committed[p], |u| u.equivalent_plastic_strain);
        }
    }

    fn compute_point_coefficients(
        &self,
        _reference: &ReferenceView<'_>,
        _current: &CurrentView<'_>,
        _coefficients: &mut [PointCoefficients],
    ) {
        // The published numbers of a correspondence point are its history fields (P K⁻¹ and
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
        // Hypoelastic models have no stored-energy function; Peridigm's correspondence
        // materials write none either (zero).
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

impl<S: StressModel> MaterialTangent for Correspondence<S> {
    fn add_tangent(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        method: TangentMethod,
        tangent: &mut BlockTangent,
    ) -> Result<(), TangentError> {
        let family = self.family(reference, current);
        let shape_inverses = self
            .block
            .points()
            .par_iter()
            .enumerate()
            .map(|(local, &p)| {
                family.shape_inverse(PointIndex {
                    global: p as usize,
                    local,
                })
            })
            .collect();
        let kernel = CorrespondenceForceState {
            material: self,
            family,
            committed: CommittedHistory::of(current.history),
            shape_inverses,
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

impl<S: StressModel> MaterialOutputs for Correspondence<S> {
    fn add_hourglass_force_density(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        out: &mut [[f64; 3]],
    ) {
        self.add_forces(reference, current, out, false);
    }
}

/// A shape tensor far enough from singular to invert reliably: det K above 1e-12 of the cube
/// of its mean eigenvalue (tr K/3)³. Below it the bonds are (nearly) coplanar.
fn well_conditioned(shape: &Tensor<f64>) -> bool {
    let mean = kinematics::trace(shape) / 3.0;
    determinant(shape) > 1e-12 * mean * mean * mean
}
