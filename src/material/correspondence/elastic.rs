//! `Elastic Correspondence`'s stress model: hypoelastic isotropic elasticity in the unrotated
//! frame (Peridigm's `updateElasticCauchyStress`, reference §1.3):
//!
//! `σ̃_{n+1} = σ̃_n + 2μ dev(d Δt) + K tr(d Δt) I`,
//!
//! with K the bulk and μ the shear modulus. For a deformation reached in one step from the
//! reference state this is Hooke's law of the rotated logarithmic-like strain increment; over
//! many steps it is the usual hypoelastic rate form.

use super::kinematics::{deviator, lift, trace, Tensor};
use super::StressModel;
use crate::material::{positive, MaterialError, MaterialInput};
use crate::model::{ModelDeclaration, Reach};
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
    const DECLARATION: ModelDeclaration = ModelDeclaration {
        deck_name: "Elastic Correspondence",
        deck_keys: &[
            "Density",
            "Bulk Modulus",
            "Shear Modulus",
            "Young's Modulus",
            "Poisson's Ratio",
            "Hourglass Coefficient",
            "Tangent",
            "Finite Difference Probe Length",
        ],
        reach: Reach::TwoHop,
        fields: super::CORRESPONDENCE_FIELDS,
        outputs: super::CORRESPONDENCE_OUTPUTS,
    };

    fn from_input(input: &MaterialInput) -> Result<Self, MaterialError> {
        Ok(Self {
            bulk_modulus: positive("Bulk Modulus", input.bulk_modulus)?,
            shear_modulus: positive("Shear Modulus", input.required_shear_modulus()?)?,
        })
    }

    fn unrotated_stress<T: Scalar>(&self, start: &Tensor<f64>, increment: &Tensor<T>) -> Tensor<T> {
        let volumetric = trace(increment) * self.bulk_modulus;
        let mut stress =
            lift::<T>(start) + deviator(increment).map(|x| x * (2.0 * self.shear_modulus));
        for k in 0..3 {
            stress[(k, k)] += volumetric;
        }
        stress
    }
}
