//! The one list of the material models this build runs.
//!
//! Each entry pairs a model's [`ModelDeclaration`] (deck name and keys, reach, fields,
//! outputs) with its constructor. The builder (`setup::build_physics`), `peridyn check`, the
//! ghost depth of ranks and the tangent pattern all ask this list; nothing else names a model.
//! Adding a model is its file, one line in [`MATERIALS`] and its tests.

use super::{
    BondBased, ElasticCorrespondence, ElasticHypoelasticCorrespondence, ElasticPlastic,
    ElasticPlasticCorrespondence, ElasticPlasticHardening, ElasticPlasticHypoelasticCorrespondence,
    ElasticStress, HardeningPlasticStress, HypoelasticStress, InfluenceFunction,
    IsotropicHardeningCorrespondence, IsotropicHardeningHypoelasticCorrespondence, LinearLps,
    LinearPeridynamicSolid, Material, MaterialError, MicroplasticBondBased, NeedlemanStress, Pals,
    PalsInfluence, PerfectlyPlasticStress, PlasticityInput, StressModel, Viscoelastic,
    ViscoelasticInput, ViscoplasticNeedlemanCorrespondence,
};
use crate::model::ModelDeclaration;

/// The deck values every constructor may read, resolved by the builder from the block and its
/// `Materials` entry.
#[derive(Debug, Clone)]
pub struct MaterialInput {
    /// `Density` ρ (mass/length³).
    pub density: f64,
    /// The block's `Horizon` δ (length).
    pub horizon: f64,
    /// Bulk modulus K (pressure): from two elastic constants, or for bond-based models from
    /// `Bulk Modulus` / `Young's Modulus` with the model's fixed Poisson's ratio.
    pub bulk_modulus: f64,
    /// Shear modulus μ (pressure) when the deck gives two elastic constants; `None` for
    /// bond-based models, whose Poisson's ratio is fixed.
    pub shear_modulus: Option<f64>,
    /// `Height` h of a `Plane Strain`/`Plane Stress` bond-based model, or `Thickness` h of a
    /// `Planar Problem`; `None` in 3D.
    pub planar_thickness: Option<f64>,
    /// `Yield Stress`, `Disable Plasticity` and `Hardening Modulus` of the state-based plastic
    /// models (`None` for other models).
    pub plasticity: Option<PlasticityInput>,
    /// `Apply Shear Correction Factor`, with the model's default resolved (true for `Elastic
    /// Plastic Hardening`, false elsewhere): the ordinary state-based models that support it
    /// scale α by the pointwise shear-correction factor.
    pub shear_correction: bool,
    /// `lambda_i` and `tau b` of `Viscoelastic` (`None` for other models).
    pub viscoelastic: Option<ViscoelasticInput>,
    /// `Discretization → Influence Function` ω(ζ, δ).
    pub influence: InfluenceFunction,
    /// The parameters of a correspondence model (`None` for other models).
    pub correspondence: Option<CorrespondenceInput>,
    /// The two base influence functions of `Pals` (`None` for other models, and for `Pals`
    /// Peridigm's default `One` for both).
    pub pals: Option<PalsInfluence>,
    /// `Yield Stretch` s_Y of `Microplastic Bond Based` (`None` for other models).
    pub yield_stretch: Option<f64>,
    /// `Analytic Weighted Volume` m of `Linear LPS Partial Volume` when the deck sets `Use
    /// Analytic Weighted Volume: true` (length⁵; `None` otherwise: m from the family).
    pub analytic_weighted_volume: Option<f64>,
}

/// The deck parameters of a correspondence model besides its elastic constants.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CorrespondenceInput {
    /// `Hourglass Coefficient` C_hg (dimensionless, ≥ 0).
    pub hourglass_coefficient: f64,
    /// `Yield Stress` σ_y (pressure) of the plastic models.
    pub yield_stress: Option<f64>,
    /// `Hardening Modulus` H (pressure) of `Isotropic Hardening Correspondence`.
    pub hardening_modulus: Option<f64>,
    /// `Enable Flaw` with its parameters.
    pub flaw: Option<super::Flaw>,
    /// The flow-stress parameters of `Viscoplastic Needleman Correspondence`.
    pub viscoplastic: Option<super::NeedlemanParameters>,
    /// The semi-Lagrangian parameters of the hypoelastic correspondence models.
    pub hypoelastic: Option<HypoelasticInput>,
}

/// The deck parameters of the hypoelastic (semi-Lagrangian) correspondence models.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HypoelasticInput {
    /// `Actual Horizon` δ_a (length): the horizon of the physics, measured on the current
    /// configuration; at most the block's `Horizon`, which builds the neighbour lists.
    pub actual_horizon: f64,
    /// `Gradient Order Of Accuracy` (Peridigm's default 1, the only order implemented).
    pub gradient_order_of_accuracy: i64,
}

impl MaterialInput {
    /// μ, for models that need it.
    pub fn required_shear_modulus(&self) -> Result<f64, MaterialError> {
        self.shear_modulus.ok_or(MaterialError::Missing {
            key: "Shear Modulus",
        })
    }

    /// The correspondence parameters, or a clear error naming `key` when the model needs them.
    pub fn required_correspondence(
        &self,
        key: &'static str,
    ) -> Result<&CorrespondenceInput, MaterialError> {
        self.correspondence
            .as_ref()
            .ok_or(MaterialError::Missing { key })
    }
}

/// Builds a model's material for one block from the resolved deck values.
pub type MaterialConstructor = fn(&MaterialInput) -> Result<Box<dyn Material>, MaterialError>;

/// One material model of this build.
#[derive(Debug, Clone, Copy)]
pub struct MaterialEntry {
    /// What the model declares about itself.
    pub declaration: &'static ModelDeclaration,
    /// Its constructor.
    pub build: MaterialConstructor,
}

/// Every material model this build runs, one entry each.
pub static MATERIALS: &[MaterialEntry] = &[
    MaterialEntry {
        declaration: &BondBased::DECLARATION,
        build: BondBased::build,
    },
    MaterialEntry {
        declaration: &LinearPeridynamicSolid::DECLARATION,
        build: LinearPeridynamicSolid::build,
    },
    MaterialEntry {
        declaration: &LinearLps::DECLARATION,
        build: LinearLps::build,
    },
    MaterialEntry {
        declaration: &ElasticPlastic::DECLARATION,
        build: ElasticPlastic::build,
    },
    MaterialEntry {
        declaration: &MicroplasticBondBased::DECLARATION,
        build: MicroplasticBondBased::build,
    },
    MaterialEntry {
        declaration: &ElasticPlasticHardening::DECLARATION,
        build: ElasticPlasticHardening::build,
    },
    MaterialEntry {
        declaration: &Viscoelastic::DECLARATION,
        build: Viscoelastic::build,
    },
    MaterialEntry {
        declaration: &Pals::DECLARATION,
        build: Pals::build,
    },
    MaterialEntry {
        declaration: &<ElasticStress as StressModel>::DECLARATION,
        build: ElasticCorrespondence::build,
    },
    MaterialEntry {
        declaration: &<PerfectlyPlasticStress as StressModel>::DECLARATION,
        build: ElasticPlasticCorrespondence::build,
    },
    MaterialEntry {
        declaration: &<HardeningPlasticStress as StressModel>::DECLARATION,
        build: IsotropicHardeningCorrespondence::build,
    },
    MaterialEntry {
        declaration: &<NeedlemanStress as StressModel>::DECLARATION,
        build: ViscoplasticNeedlemanCorrespondence::build,
    },
    MaterialEntry {
        declaration: &<ElasticStress as HypoelasticStress>::HYPOELASTIC_DECLARATION,
        build: ElasticHypoelasticCorrespondence::build,
    },
    MaterialEntry {
        declaration: &<PerfectlyPlasticStress as HypoelasticStress>::HYPOELASTIC_DECLARATION,
        build: ElasticPlasticHypoelasticCorrespondence::build,
    },
    MaterialEntry {
        declaration: &<HardeningPlasticStress as HypoelasticStress>::HYPOELASTIC_DECLARATION,
        build: IsotropicHardeningHypoelasticCorrespondence::build,
    },
];

/// The entry of the model called `deck_name` in decks (`Material Model`), if this build runs it.
pub fn material_entry(deck_name: &str) -> Option<&'static MaterialEntry> {
    MATERIALS
        .iter()
        .find(|entry| entry.declaration.deck_name == deck_name)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn deck_names_are_unique_and_the_built_material_reports_its_declaration() {
        for (k, entry) in MATERIALS.iter().enumerate() {
            let name = entry.declaration.deck_name;
            assert!(
                MATERIALS[..k]
                    .iter()
                    .all(|other| other.declaration.deck_name != name),
                "{name} listed twice"
            );
            let input = MaterialInput {
                density: 1.0,
                horizon: 1.0,
                bulk_modulus: 1.0,
                shear_modulus: Some(1.0),
                planar_thickness: None,
                plasticity: Some(PlasticityInput {
                    yield_stress: 1.0,
                    disabled: false,
                    hardening_modulus: 0.0,
                }),
                shear_correction: false,
                viscoelastic: Some(ViscoelasticInput {
                    lambda_i: 0.5,
                    tau_b: 1.0,
                }),
                influence: InfluenceFunction::One,
                correspondence: Some(CorrespondenceInput {
                    hourglass_coefficient: 0.0,
                    yield_stress: Some(1.0),
                    hardening_modulus: Some(0.1),
                    flaw: None,
                    viscoplastic: Some(super::super::NeedlemanParameters {
                        strain_hardening_exponent: 0.1,
                        rate_hardening_exponent: 0.02,
                        reference_strain_rate: 1.0,
                        reference_strain_0: 0.01,
                        reference_strain_1: 1.0,
                    }),
                    hypoelastic: Some(HypoelasticInput {
                        actual_horizon: 1.0,
                        gradient_order_of_accuracy: 1,
                    }),
                }),
                pals: None,
                yield_stretch: Some(0.01),
                analytic_weighted_volume: None,
            };
            let material = (entry.build)(&input).unwrap();
            assert_eq!(material.model_name(), name);
            assert_eq!(material.declaration(), entry.declaration);
            assert!(std::ptr::eq(material_entry(name).unwrap(), entry));
        }
        assert!(material_entry("Linear LPS Partial Volume").is_some());
    }

    #[test]
    fn a_model_that_needs_the_shear_modulus_says_so() {
        let input = MaterialInput {
            density: 1.0,
            horizon: 1.0,
            bulk_modulus: 1.0,
            shear_modulus: None,
            planar_thickness: None,
            plasticity: None,
            shear_correction: false,
            viscoelastic: None,
            influence: InfluenceFunction::One,
            correspondence: None,
            pals: None,
            yield_stretch: None,
            analytic_weighted_volume: None,
        };
        let error = (material_entry("Elastic").unwrap().build)(&input).err();
        assert_eq!(
            error,
            Some(MaterialError::Missing {
                key: "Shear Modulus"
            })
        );
    }
}
