//! `Elastic Correspondence`'s stress model: hypoelastic isotropic elasticity in the unrotated
//! frame (Peridigm's `updateElasticCauchyStress`, `correspondence.cxx`):
//!
//! `σ̃_{n+1} = σ̃_n + 2μ dev(d Δt) + K tr(d Δt) I`,
//!
//! with K the bulk and μ the shear modulus. For a deformation reached in one step from the
//! reference state this is Hooke's law of the rotated logarithmic-like strain increment; over
//! many steps it is the usual hypoelastic rate form.

use super::kinematics::{deviator, lift, trace, Tensor};
use super::{PointStep, StressModel, StressState, HOURGLASS_COEFFICIENT};
use crate::material::keys::{DENSITY, ELASTIC, PROBE_LENGTH, TANGENT, THERMAL_EXPANSION};
use crate::material::{positive, ElasticConstants, MaterialError};
use crate::model::{ModelDeclaration, Reach, TangentSupport};
use crate::parameter_list::error::DeckError;
use crate::parameter_list::reader::{Ctx, ListReader};
use crate::tangent::Scalar;

/// Hypoelastic isotropic elasticity (K, μ).
#[derive(Debug, Clone, Copy)]
pub(crate) struct ElasticStress {
    /// Bulk modulus K (pressure).
    pub bulk_modulus: f64,
    /// Shear modulus μ (pressure).
    pub shear_modulus: f64,
}

impl StressModel for ElasticStress {
    type Parameters = ();

    const DECLARATION: ModelDeclaration = ModelDeclaration {
        deck_name: "Elastic Correspondence",
        aliases: &[],
        deck_keys: &[
            DENSITY,
            ELASTIC[0],
            ELASTIC[1],
            ELASTIC[2],
            ELASTIC[3],
            HOURGLASS_COEFFICIENT,
            THERMAL_EXPANSION,
            TANGENT,
            PROBE_LENGTH,
        ],
        reach: Reach::TwoHop,
        fields: super::CORRESPONDENCE_FIELDS,
        outputs: super::CORRESPONDENCE_OUTPUTS,
        tangent: TangentSupport::Differentiated,
        thermal_strain: true,
        small_displacement: false,
        example: "Density: 2.0\nBulk Modulus: 3.0\nShear Modulus: 1.7\nHourglass Coefficient: 0.05",
    };

    fn read(_ctx: &mut Ctx, _list: &mut ListReader) -> Result<(), DeckError> {
        Ok(())
    }

    fn new(elastic: &ElasticConstants, _parameters: &()) -> Result<Self, MaterialError> {
        Ok(Self {
            bulk_modulus: positive("Bulk Modulus", elastic.bulk_modulus)?,
            shear_modulus: positive("Shear Modulus", elastic.shear_modulus)?,
        })
    }

    fn advance<T: Scalar>(
        &self,
        start: &StressState<f64>,
        increment: &Tensor<T>,
        _step: &PointStep,
    ) -> StressState<T> {
        StressState {
            unrotated: elastic_trial(
                &start.unrotated,
                increment,
                self.bulk_modulus,
                self.shear_modulus,
            ),
            equivalent_plastic_strain: T::from(start.equivalent_plastic_strain),
        }
    }
}

/// `σ̃_n + 2μ dev(d Δt) + K tr(d Δt) I`: the elastic update (and the elastic trial of the
/// plastic models).
pub(crate) fn elastic_trial<T: Scalar>(
    start: &Tensor<f64>,
    increment: &Tensor<T>,
    bulk_modulus: f64,
    shear_modulus: f64,
) -> Tensor<T> {
    let volumetric = trace(increment) * bulk_modulus;
    let mut stress = lift::<T>(start) + deviator(increment).map(|x| x * (2.0 * shear_modulus));
    for k in 0..3 {
        stress[(k, k)] += volumetric;
    }
    stress
}
