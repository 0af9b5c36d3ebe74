//! `Materials` list: one entry per named material, each with a `Material Model` and its keys.

use super::error::DeckError;
use super::reader::{Ctx, Field, ListReader};
use crate::tangent::TangentMethod;

/// One named material (an entry of `Materials`).
#[derive(Debug, Clone, PartialEq)]
pub struct Material {
    /// The name of the material's list; blocks refer to it with `Material`.
    pub name: String,
    /// `Material Model` and the model's own parameters.
    pub model: MaterialModel,
    /// `Density` ρ (mass per volume, > 0); required by every mechanical model, absent for
    /// `Diffusion` and `Vector Poisson`.
    pub density: Option<f64>,
    /// Exactly two of `Bulk Modulus`, `Shear Modulus`, `Young's Modulus`, `Poisson's Ratio`;
    /// required by every mechanical model except `Elastic Bond Based` (which has its own).
    pub elastic: Option<ElasticConstants>,
    /// `Thermal Expansion Coefficient` α (per degree); thermal strain `α ΔT` when present.
    /// Only for the models that take it (Elastic, Elastic Correspondence, Multiphysics
    /// Elastic); any other model with the key is an error naming it.
    pub thermal_expansion_coefficient: Option<f64>,
    /// `Finite Difference Probe Length` ε for finite-difference tangents (> 0); default
    /// `1e-6 × min element radius`, computed at setup.
    pub finite_difference_probe_length: Option<f64>,
    /// The tangent method the deck asks for explicitly: peridyn's `Tangent` key
    /// (`"Analytic"`, `"Automatic Differentiation"` or `"Finite Difference"`), or Peridigm's
    /// `Apply Automatic Differentiation Jacobian` when written in the deck (true → automatic
    /// differentiation, false → finite differences). Finite differences carry
    /// `Finite Difference Probe Length` (`None`: Peridigm's default, resolved at assembly).
    /// `None` leaves the model's default (analytic for `Elastic` and `Elastic Bond Based`).
    pub tangent: Option<TangentMethod>,
}

/// The elastic constants as given in the deck (exactly two of four), with Peridigm's
/// conversions to bulk modulus K and shear modulus μ (`Material::calculateBulkModulus`,
/// `calculateShearModulus`; 3D formulas).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ElasticConstants {
    /// `Bulk Modulus` K (> 0).
    pub bulk_modulus: Option<f64>,
    /// `Shear Modulus` μ (> 0).
    pub shear_modulus: Option<f64>,
    /// `Young's Modulus` E (> 0).
    pub youngs_modulus: Option<f64>,
    /// `Poisson's Ratio` ν, in (−1, ½).
    pub poissons_ratio: Option<f64>,
}

impl ElasticConstants {
    fn input(&self) -> crate::material::ElasticInput {
        crate::material::ElasticInput {
            bulk_modulus: self.bulk_modulus,
            shear_modulus: self.shear_modulus,
            youngs_modulus: self.youngs_modulus,
            poissons_ratio: self.poissons_ratio,
        }
    }

    fn resolved(&self) -> crate::material::ElasticConstants {
        crate::material::ElasticConstants::from_pair(
            self.input(),
            crate::material::PlanarAssumption::None,
        )
        .unwrap_or_else(|e| unreachable!("validated at load: {e}"))
    }

    /// Bulk modulus K from the two given constants (Peridigm's 3D conversions, see
    /// [`crate::material::ElasticConstants::from_pair`]).
    ///
    /// # Panics
    /// If the constants were not validated (never the case for a value from [`load`](super::load)).
    pub fn bulk_modulus(&self) -> f64 {
        self.resolved().bulk_modulus
    }

    /// Shear modulus μ from the two given constants (Peridigm's conversions).
    ///
    /// # Panics
    /// If the constants were not validated (never the case for a value from [`load`](super::load)).
    pub fn shear_modulus(&self) -> f64 {
        self.resolved().shear_modulus
    }
}

/// `Material Model` and the model-specific parameters (Peridigm 1.5 material factory).
#[derive(Debug, Clone, PartialEq)]
pub enum MaterialModel {
    /// `"Elastic"` — linear peridynamic solid (LPS), ordinary state-based. Peridigm's
    /// `"Elastic Partial Volume"` reads as this model too (its partial volumes are the block's
    /// quadrature rule).
    Elastic {
        /// `Apply Automatic Differentiation Jacobian` — AD tangent; default true.
        automatic_differentiation: bool,
        /// `Compute Partial Stress` — also compute `Partial_Stress`; default false.
        compute_partial_stress: bool,
        /// `Apply Shear Correction Factor` — scale α by the pointwise shear-correction factor;
        /// default false (Peridigm's `Elastic` reads the key but never applies it).
        shear_correction: bool,
    },
    /// `"Elastic Plastic"` — Mitchell's ordinary state-based plasticity (ω ≡ 1).
    ElasticPlastic {
        /// `Yield Stress` σ_y (required, > 0).
        yield_stress: f64,
        /// `Disable Plasticity` — treat σ_y as infinite; default false.
        disable_plasticity: bool,
        /// `Apply Automatic Differentiation Jacobian` — default true.
        automatic_differentiation: bool,
        /// `Planar Problem: true` with `Thickness` h (> 0): 2D yield surface; default off.
        planar_thickness: Option<f64>,
    },
    /// `"Elastic Plastic Hardening"` — as Elastic Plastic with linear isotropic hardening.
    ElasticPlasticHardening {
        /// `Yield Stress` σ_y (required, > 0).
        yield_stress: f64,
        /// `Hardening Modulus` H (required, ≥ 0).
        hardening_modulus: f64,
        /// `Disable Plasticity` — default false.
        disable_plasticity: bool,
        /// `Apply Automatic Differentiation Jacobian` — default **false** for this model.
        automatic_differentiation: bool,
        /// `Apply Shear Correction Factor` — default **true** for this model.
        shear_correction: bool,
    },
    /// `"Viscoelastic"` — standard linear solid on the deviatoric part (ω ≡ 1).
    Viscoelastic {
        /// `lambda_i` λ_i (required, in [0, 1]): fraction of the deviatoric response that relaxes.
        lambda_i: f64,
        /// `tau b` τ_b (required, > 0): relaxation time.
        tau_b: f64,
    },
    /// `"Elastic Bond Based"` — prototype microelastic brittle (PMB) bond-based model; ν is
    /// fixed (¼ in 3D and plane strain, ⅓ in plane stress).
    ElasticBondBased {
        /// Exactly one of `Bulk Modulus` / `Young's Modulus`.
        modulus: BondBasedModulus,
        /// `Plane Strain: true` / `Plane Stress: true` with `Height` h (> 0); default 3D.
        planar: Option<(PlanarKind, f64)>,
    },
    /// `"Microplastic Bond Based"` — peridyn's proportional microplastic bond-based model
    /// (Macek & Silling 2007): the PMB constants of `Elastic Bond Based` and a bond yield
    /// stretch.
    MicroplasticBondBased {
        /// Exactly one of `Bulk Modulus` / `Young's Modulus`, as for `Elastic Bond Based`.
        modulus: BondBasedModulus,
        /// `Plane Strain: true` / `Plane Stress: true` with `Height` h (> 0); default 3D.
        planar: Option<(PlanarKind, f64)>,
        /// `Yield Stretch` s_Y (required, > 0).
        yield_stretch: f64,
    },
    /// `"Pals"` — position-aware linear solid.
    Pals {
        /// `Dilatation Influence Function` — default `One`.
        dilatation_influence: PalsInfluence,
        /// `Deviatoric Influence Function` — default `One`.
        deviatoric_influence: PalsInfluence,
    },
    /// `"Linear LPS Partial Volume"` — small-displacement LPS.
    LinearLpsPartialVolume {
        /// `Use Partial Volume` — default false.
        use_partial_volume: bool,
        /// `Use Improved Quadrature` — default false.
        use_improved_quadrature: bool,
        /// `Use Analytic Weighted Volume: true` with `Analytic Weighted Volume` (> 0); default off.
        analytic_weighted_volume: Option<f64>,
        /// `Verbose` — default false.
        verbose: bool,
    },
    /// `"Elastic Correspondence"` — hypoelastic Cauchy update, Flanagan–Taylor rotation.
    ElasticCorrespondence {
        /// `Hourglass Coefficient` C_hg (required, ≥ 0).
        hourglass_coefficient: f64,
    },
    /// `"Elastic Plastic Correspondence"` — J2 perfect plasticity, radial return.
    ElasticPlasticCorrespondence {
        /// `Hourglass Coefficient` (required, ≥ 0).
        hourglass_coefficient: f64,
        /// `Yield Stress` (required, > 0).
        yield_stress: f64,
    },
    /// `"Isotropic Hardening Correspondence"` — J2 plasticity with linear isotropic hardening.
    IsotropicHardeningCorrespondence {
        /// `Hourglass Coefficient` (required, ≥ 0).
        hourglass_coefficient: f64,
        /// `Yield Stress` (required, > 0).
        yield_stress: f64,
        /// `Hardening Modulus` (required, ≥ 0).
        hardening_modulus: f64,
        /// `Enable Flaw: true` with the flaw parameters; default off.
        flaw: Option<Flaw>,
    },
    /// `"Viscoplastic Needleman Correspondence"` — rate-dependent J2 plasticity.
    ViscoplasticNeedlemanCorrespondence {
        /// `Hourglass Coefficient` (required, ≥ 0).
        hourglass_coefficient: f64,
        /// `Yield Stress` (required, > 0).
        yield_stress: f64,
        /// `Strain Hardening Exponent` (required).
        strain_hardening_exponent: f64,
        /// `Rate Hardening Exponent` (required).
        rate_hardening_exponent: f64,
        /// `Reference Strain Rate` (required, > 0).
        reference_strain_rate: f64,
        /// `Reference Strain 0` (required, > 0).
        reference_strain_0: f64,
        /// `Reference Strain 1` (required, > 0).
        reference_strain_1: f64,
        /// `Enable Flaw: true` with the flaw parameters; default off.
        flaw: Option<Flaw>,
    },
    /// `"Elastic Hypoelastic Correspondence"` and its plastic variants (semi-Lagrangian).
    HypoelasticCorrespondence {
        /// Which of the three hypoelastic models.
        plasticity: CorrespondencePlasticity,
        /// `Actual Horizon` (required, > 0): horizon used by the physics.
        actual_horizon: f64,
        /// `Gradient Order Of Accuracy` — default 1.
        gradient_order_of_accuracy: i64,
        /// `Hourglass Coefficient` (≥ 0) — default 0 (Peridigm's hypoelastic models read
        /// none).
        hourglass_coefficient: f64,
    },
    /// `"Elastic Bond Associated Correspondence"` and its plastic variants.
    BondAssociatedCorrespondence {
        /// Which of the three bond-associated models.
        plasticity: BondAssociatedPlasticity,
        /// `Gradient Order Of Accuracy` — default 1.
        gradient_order_of_accuracy: i64,
    },
    /// `"Multiphysics Elastic"` — Elastic plus a fluid-pressure unknown (needs `Multiphysics: 1`).
    MultiphysicsElastic {
        /// `Fluid density` (required, > 0).
        fluid_density: f64,
        /// `Fluid compressibility` (required, > 0).
        fluid_compressibility: f64,
        /// `Fluid dynamic viscosity` (required, > 0).
        fluid_dynamic_viscosity: f64,
        /// `Permeability` (required, > 0).
        permeability: f64,
        /// `Max permeability` (required, > 0).
        max_permeability: f64,
        /// `Permeability alpha` (required).
        permeability_alpha: f64,
        /// `Permeability curve inflection damage` (required).
        permeability_curve_inflection_damage: f64,
        /// `Fluid Reynolds viscosity temperature effect` (required).
        fluid_reynolds_viscosity_temperature_effect: f64,
        /// `Fluid linear thermal expansion` (required).
        fluid_linear_thermal_expansion: f64,
        /// `Apply Automatic Differentiation Jacobian` — default true.
        automatic_differentiation: bool,
        /// `Apply Shear Correction Factor` — default false.
        shear_correction: bool,
    },
    /// `"Vector Poisson"` — test operator without parameters.
    VectorPoisson,
    /// `"Diffusion"` — nonlocal diffusion of a scalar (temperature).
    Diffusion {
        /// `Coefficient` (required, > 0).
        coefficient: f64,
        /// `Use Improved Quadrature` — default false.
        use_improved_quadrature: bool,
    },
}

/// The modulus of `Elastic Bond Based`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum BondBasedModulus {
    /// `Bulk Modulus` K.
    Bulk(f64),
    /// `Young's Modulus` E (K follows from the fixed ν).
    Young(f64),
}

/// `Plane Strain` or `Plane Stress` for `Elastic Bond Based`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PlanarKind {
    /// `Plane Strain: true`.
    PlaneStrain,
    /// `Plane Stress: true`.
    PlaneStress,
}

/// Influence-function choice of the Pals model.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PalsInfluence {
    /// `"One"`.
    One,
    /// `"Parabolic Decay"`.
    ParabolicDecay,
    /// `"Gaussian"`.
    Gaussian,
}

pub use crate::material::Flaw;

/// Plasticity of the hypoelastic correspondence family.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CorrespondencePlasticity {
    /// `"Elastic Hypoelastic Correspondence"`.
    Elastic,
    /// `"Elastic Plastic Hypoelastic Correspondence"` with `Yield Stress`.
    PerfectlyPlastic {
        /// `Yield Stress` (required, > 0).
        yield_stress: f64,
    },
    /// `"Isotropic Hardening Hypoelastic Correspondence"`.
    IsotropicHardening {
        /// `Yield Stress` (required, > 0).
        yield_stress: f64,
        /// `Hardening Modulus` (required, ≥ 0).
        hardening_modulus: f64,
    },
}

/// Plasticity of the bond-associated correspondence family.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum BondAssociatedPlasticity {
    /// `"Elastic Bond Associated Correspondence"`.
    Elastic,
    /// `"Elastic Plastic Bond Associated Correspondence"` with `Yield Stress`.
    PerfectlyPlastic {
        /// `Yield Stress` (required, > 0).
        yield_stress: f64,
    },
    /// `"Isotropic Hardening Bond Associated Correspondence"`, `Hardening Rule: "Power-law"`,
    /// parameters in the sublist `Hardening Parameters`.
    PowerLaw {
        /// `Yield Stress` (required, > 0).
        yield_stress: f64,
        /// `Hardening Characteristic Strain` (required, > 0).
        hardening_characteristic_strain: f64,
        /// `Hardening Exponent` (required).
        hardening_exponent: f64,
    },
    /// `Hardening Rule: "Saturation type exponential"`, parameters in `Hardening Parameters`.
    SaturationExponential {
        /// `Initial Yield Stress` (required, > 0).
        initial_yield_stress: f64,
        /// `Saturated Yield Stress` (required, > 0).
        saturated_yield_stress: f64,
        /// `Exponential Constant` (required).
        exponential_constant: f64,
        /// `Linear Constant` (required).
        linear_constant: f64,
    },
}

/// Every `Material Model` string we accept.
const MODELS: &[&str] = &[
    "Elastic",
    "Elastic Partial Volume",
    "Elastic Plastic",
    "Elastic Plastic Hardening",
    "Viscoelastic",
    "Elastic Bond Based",
    "Microplastic Bond Based",
    "Pals",
    "Linear LPS Partial Volume",
    "Elastic Correspondence",
    "Elastic Plastic Correspondence",
    "Isotropic Hardening Correspondence",
    "Viscoplastic Needleman Correspondence",
    "Elastic Hypoelastic Correspondence",
    "Elastic Plastic Hypoelastic Correspondence",
    "Isotropic Hardening Hypoelastic Correspondence",
    "Elastic Bond Associated Correspondence",
    "Elastic Plastic Bond Associated Correspondence",
    "Isotropic Hardening Bond Associated Correspondence",
    "Multiphysics Elastic",
    "Vector Poisson",
    "Diffusion",
];

/// Models Peridigm knows only in special builds (or not at all in the public repository).
const UNAVAILABLE: &[(&str, &str)] = &[
    (
        "LCM",
        "exists only in Peridigm builds coupled to Albany (USE_LCM)",
    ),
    (
        "Elastic Correspondence Partial Stress",
        "is not part of the public Peridigm code",
    ),
    (
        "Pressure Dependent Elastic Plastic",
        "is not part of the public Peridigm code",
    ),
];

const ELASTIC_KEYS: [&str; 4] = [
    "Bulk Modulus",
    "Shear Modulus",
    "Young's Modulus",
    "Poisson's Ratio",
];

/// Keys that some model accepts: used to explain an unknown key that belongs to another model.
const MODEL_KEYS: &[&str] = &[
    "Yield Stress",
    "Hardening Modulus",
    "Disable Plasticity",
    "Planar Problem",
    "Thickness",
    "Apply Shear Correction Factor",
    "lambda_i",
    "tau b",
    "Plane Strain",
    "Plane Stress",
    "Height",
    "Hourglass Coefficient",
    "Yield Stretch",
    "Actual Horizon",
    "Gradient Order Of Accuracy",
    "Thermal Expansion Coefficient",
    "Compute Partial Stress",
    "Apply Automatic Differentiation Jacobian",
    "Verbose",
];

fn read_elastic(ctx: &Ctx, list: &mut ListReader) -> Result<ElasticConstants, DeckError> {
    let mut given = Vec::new();
    let mut values = [None; 4];
    for (i, key) in ELASTIC_KEYS.iter().enumerate() {
        if let Some(f) = list.get(key) {
            let v = if i == 3 {
                let nu = f.f64(ctx)?;
                if !(nu > -1.0 && nu < 0.5) {
                    return Err(f.err(
                        ctx,
                        format!("Poisson's ratio must lie strictly between -1 and 0.5, found {nu}"),
                    ));
                }
                nu
            } else {
                f.positive(ctx)?
            };
            values[i] = Some(v);
            given.push(f);
        }
    }
    if given.len() != 2 {
        let names = given
            .iter()
            .map(|f| format!("\"{}\"", f.key()))
            .collect::<Vec<_>>()
            .join(", ");
        let message = format!(
            "exactly two of \"Bulk Modulus\", \"Shear Modulus\", \"Young's Modulus\", \"Poisson's Ratio\" must be given, found {}{}",
            given.len(),
            if given.is_empty() { String::new() } else { format!(" ({names})") }
        );
        return Err(match given.get(2) {
            Some(third) => third.err(ctx, message),
            None => ctx.error(Some(list.line), &list.path, message),
        });
    }
    let constants = ElasticConstants {
        bulk_modulus: values[0],
        shear_modulus: values[1],
        youngs_modulus: values[2],
        poissons_ratio: values[3],
    };
    if let Err(message) = crate::material::ElasticConstants::from_pair(
        constants.input(),
        crate::material::PlanarAssumption::None,
    ) {
        return Err(given[1].err(ctx, message));
    }
    Ok(constants)
}

fn read_flaw(ctx: &Ctx, list: &mut ListReader) -> Result<Option<Flaw>, DeckError> {
    if !list.bool_or(ctx, "Enable Flaw", false)? {
        return Ok(None);
    }
    Ok(Some(Flaw {
        location: [
            list.f64_req(ctx, "Flaw Location X")?,
            list.f64_req(ctx, "Flaw Location Y")?,
            list.f64_req(ctx, "Flaw Location Z")?,
        ],
        size: list.positive_req(ctx, "Flaw Size")?,
        magnitude: list.f64_req(ctx, "Flaw Magnitude")?,
    }))
}

fn non_negative_req(ctx: &Ctx, list: &mut ListReader, key: &'static str) -> Result<f64, DeckError> {
    list.require(ctx, key, "a number ≥ 0")?.non_negative(ctx)
}

pub(crate) fn read(ctx: &mut Ctx, field: &Field) -> Result<Material, DeckError> {
    let mut list = field.list(ctx)?;
    let model_field = list.require(ctx, "Material Model", "the name of the constitutive model")?;
    let model_name = model_field.name(ctx)?;
    if let Some((_, why)) = UNAVAILABLE.iter().find(|(m, _)| *m == model_name) {
        return Err(model_field.err(
            ctx,
            format!("material model \"{model_name}\" {why}; choose another model"),
        ));
    }
    let model_name = model_field.choice(ctx, MODELS)?;
    if let Some(h) = list.peek("Horizon") {
        return Err(h.err(ctx, "the horizon is not a material parameter; set `Horizon` in the block that uses this material"));
    }
    let mechanical = !matches!(model_name, "Diffusion" | "Vector Poisson");
    let density = if mechanical {
        Some(list.positive_req(ctx, "Density")?)
    } else {
        None
    };
    let bond_based = matches!(model_name, "Elastic Bond Based" | "Microplastic Bond Based");
    let elastic = if mechanical && !bond_based {
        Some(read_elastic(ctx, &mut list)?)
    } else {
        None
    };
    // Peridigm applies thermal strain in these models only (and refuses the key in `Elastic
    // Plastic` and `Viscoelastic`); elsewhere the key is an error rather than a load silently
    // dropped.
    let thermal_models = ["Elastic", "Elastic Correspondence", "Multiphysics Elastic"];
    if let Some(f) = list.get("Thermal Expansion Coefficient") {
        if !thermal_models.contains(&model_name) {
            return Err(f.err(
                ctx,
                format!(
                    "the \"{model_name}\" material model has no thermal strain; \"Thermal Expansion Coefficient\" is taken only by \"Elastic\" and \"Elastic Correspondence\" (remove the key or choose one of them)"
                ),
            ));
        }
    }
    let thermal_expansion_coefficient = list.f64_opt(ctx, "Thermal Expansion Coefficient")?;
    let finite_difference_probe_length =
        list.positive_opt(ctx, "Finite Difference Probe Length")?;
    let tangent = read_tangent(ctx, &mut list, finite_difference_probe_length)?;
    let mut ignored: Vec<(&str, &str)> = Vec::new();

    let model = read_model(ctx, &mut list, model_name, &mut ignored)?;
    let model_label = model_name.to_string();
    // Peridigm ignores the parameters of other models (its material lists are not
    // validated), so decks carry them, e.g. `Hourglass Coefficient` on an `Elastic` material:
    // a warning, not an error.
    for key in MODEL_KEYS {
        if !ignored.iter().any(|(k, _)| k == key) {
            ignored.push((key, "a parameter of other material models, not of this one"));
        }
    }
    list.finish_with(ctx, &ignored, |key| {
        if MODEL_KEYS.contains(&key) || ELASTIC_KEYS.contains(&key) || key == "Density" {
            Some(format!(
                "\"{key}\" is not a parameter of the \"{model_label}\" material model"
            ))
        } else {
            None
        }
    })?;
    Ok(Material {
        name: field.key().to_string(),
        model,
        density,
        elastic,
        thermal_expansion_coefficient,
        finite_difference_probe_length,
        tangent,
    })
}

/// The model-specific keys of `model_name` (one of [`MODELS`]); keys the model ignores with a
/// reason are pushed to `ignored`.
fn read_model(
    ctx: &mut Ctx,
    list: &mut ListReader,
    model_name: &str,
    ignored: &mut Vec<(&'static str, &'static str)>,
) -> Result<MaterialModel, DeckError> {
    Ok(match model_name {
        // Peridigm's `Elastic Partial Volume` (a -DUSE_PV build) is the LPS of `Elastic` whose
        // bond volumes are the element–horizon intersections when the discretization computes
        // them, else the cells: the block's quadrature rule (`Full Volume` unless the block or
        // the discretization's `Element-Horizon Intersection Partial Volume Scheme` says
        // otherwise) does exactly that for every material.
        "Elastic" | "Elastic Partial Volume" => {
            ignored.push((
                "Hourglass Coefficient",
                "only correspondence models have hourglass control",
            ));
            MaterialModel::Elastic {
                automatic_differentiation: list.bool_or(
                    ctx,
                    "Apply Automatic Differentiation Jacobian",
                    true,
                )?,
                compute_partial_stress: list.flag_without_effect(
                    ctx,
                    "Compute Partial Stress",
                    false,
                    true,
                    "peridyn computes Partial_Stress whenever an output lists it",
                )?,
                shear_correction: {
                    let on = list.bool_or(ctx, "Apply Shear Correction Factor", false)?;
                    if let Some(f) = list.peek("Apply Shear Correction Factor").filter(|_| on) {
                        ctx.warn(
                            f.line(),
                            &f.path,
                            "peridyn applies the shear-correction factor to this Elastic \
                             material (Peridigm's Elastic reads the key and ignores it, so \
                             results differ from Peridigm's near surfaces)",
                        );
                    }
                    on
                },
            }
        }
        "Elastic Plastic" => read_elastic_plastic(ctx, list, ignored)?,
        "Elastic Plastic Hardening" => MaterialModel::ElasticPlasticHardening {
            yield_stress: list.positive_req(ctx, "Yield Stress")?,
            hardening_modulus: non_negative_req(ctx, list, "Hardening Modulus")?,
            disable_plasticity: list.bool_or(ctx, "Disable Plasticity", false)?,
            automatic_differentiation: list.bool_or(
                ctx,
                "Apply Automatic Differentiation Jacobian",
                false,
            )?,
            shear_correction: list.bool_or(ctx, "Apply Shear Correction Factor", true)?,
        },
        "Viscoelastic" => {
            for key in [
                "Apply Automatic Differentiation Jacobian",
                "Apply Shear Correction Factor",
            ] {
                refuse(ctx, list, model_name, key)?;
            }
            let f = list.require(ctx, "lambda_i", "a number in [0, 1]")?;
            let lambda_i = f.f64(ctx)?;
            if !(0.0..=1.0).contains(&lambda_i) {
                return Err(f.err(ctx, format!("must lie in [0, 1], found {lambda_i}")));
            }
            MaterialModel::Viscoelastic {
                lambda_i,
                tau_b: list.positive_req(ctx, "tau b")?,
            }
        }
        "Elastic Bond Based" => {
            let (modulus, planar) = read_bond_based(ctx, list, model_name)?;
            MaterialModel::ElasticBondBased { modulus, planar }
        }
        "Microplastic Bond Based" => {
            let (modulus, planar) = read_bond_based(ctx, list, model_name)?;
            MaterialModel::MicroplasticBondBased {
                modulus,
                planar,
                yield_stretch: list.positive_req(ctx, "Yield Stretch")?,
            }
        }
        "Pals" => read_pals(ctx, list)?,
        "Linear LPS Partial Volume" => {
            let analytic = list.bool_or(ctx, "Use Analytic Weighted Volume", false)?;
            MaterialModel::LinearLpsPartialVolume {
                use_partial_volume: list.bool_or(ctx, "Use Partial Volume", false)?,
                use_improved_quadrature: list.bool_or(ctx, "Use Improved Quadrature", false)?,
                analytic_weighted_volume: if analytic {
                    Some(list.positive_req(ctx, "Analytic Weighted Volume")?)
                } else {
                    None
                },
                verbose: list.bool_or(ctx, "Verbose", false)?,
            }
        }
        "Elastic Correspondence" => MaterialModel::ElasticCorrespondence {
            hourglass_coefficient: non_negative_req(ctx, list, "Hourglass Coefficient")?,
        },
        "Elastic Plastic Correspondence" => MaterialModel::ElasticPlasticCorrespondence {
            hourglass_coefficient: non_negative_req(ctx, list, "Hourglass Coefficient")?,
            yield_stress: list.positive_req(ctx, "Yield Stress")?,
        },
        "Isotropic Hardening Correspondence" => MaterialModel::IsotropicHardeningCorrespondence {
            hourglass_coefficient: non_negative_req(ctx, list, "Hourglass Coefficient")?,
            yield_stress: list.positive_req(ctx, "Yield Stress")?,
            hardening_modulus: non_negative_req(ctx, list, "Hardening Modulus")?,
            flaw: read_flaw(ctx, list)?,
        },
        "Viscoplastic Needleman Correspondence" => {
            MaterialModel::ViscoplasticNeedlemanCorrespondence {
                hourglass_coefficient: non_negative_req(ctx, list, "Hourglass Coefficient")?,
                yield_stress: list.positive_req(ctx, "Yield Stress")?,
                strain_hardening_exponent: list.f64_req(ctx, "Strain Hardening Exponent")?,
                rate_hardening_exponent: list.f64_req(ctx, "Rate Hardening Exponent")?,
                reference_strain_rate: list.positive_req(ctx, "Reference Strain Rate")?,
                reference_strain_0: list.positive_req(ctx, "Reference Strain 0")?,
                reference_strain_1: list.positive_req(ctx, "Reference Strain 1")?,
                flaw: read_flaw(ctx, list)?,
            }
        }
        "Elastic Hypoelastic Correspondence"
        | "Elastic Plastic Hypoelastic Correspondence"
        | "Isotropic Hardening Hypoelastic Correspondence" => {
            read_hypoelastic(ctx, list, model_name)?
        }
        "Elastic Bond Associated Correspondence"
        | "Elastic Plastic Bond Associated Correspondence"
        | "Isotropic Hardening Bond Associated Correspondence" => {
            read_bond_associated(ctx, list, model_name)?
        }
        "Multiphysics Elastic" => read_multiphysics_elastic(ctx, list, ignored)?,
        "Vector Poisson" => MaterialModel::VectorPoisson,
        "Diffusion" => MaterialModel::Diffusion {
            coefficient: list.positive_req(ctx, "Coefficient")?,
            use_improved_quadrature: list.bool_or(ctx, "Use Improved Quadrature", false)?,
        },
        _ => unreachable!("choice() returns one of MODELS"),
    })
}

/// An error at `key` when the deck gives it: `model_name` does not support it (Peridigm stops
/// with an error there too).
fn refuse(
    ctx: &Ctx,
    list: &mut ListReader,
    model_name: &str,
    key: &'static str,
) -> Result<(), DeckError> {
    match list.peek(key) {
        Some(f) => Err(f.err(
            ctx,
            format!(
                "the \"{model_name}\" material model does not support `{key}` (Peridigm refuses \
                 it too); remove the key"
            ),
        )),
        None => Ok(()),
    }
}

/// `Multiphysics Elastic`: the fluid parameters (the switch itself is top-level).
fn read_multiphysics_elastic(
    ctx: &Ctx,
    list: &mut ListReader,
    ignored: &mut Vec<(&'static str, &'static str)>,
) -> Result<MaterialModel, DeckError> {
    ignored.push((
        "Multiphysics",
        "the multiphysics switch is the top-level `Multiphysics: 1`",
    ));
    Ok(MaterialModel::MultiphysicsElastic {
        fluid_density: list.positive_req(ctx, "Fluid density")?,
        fluid_compressibility: list.positive_req(ctx, "Fluid compressibility")?,
        fluid_dynamic_viscosity: list.positive_req(ctx, "Fluid dynamic viscosity")?,
        permeability: list.positive_req(ctx, "Permeability")?,
        max_permeability: list.positive_req(ctx, "Max permeability")?,
        permeability_alpha: list.f64_req(ctx, "Permeability alpha")?,
        permeability_curve_inflection_damage: list
            .f64_req(ctx, "Permeability curve inflection damage")?,
        fluid_reynolds_viscosity_temperature_effect: list
            .f64_req(ctx, "Fluid Reynolds viscosity temperature effect")?,
        fluid_linear_thermal_expansion: list.f64_req(ctx, "Fluid linear thermal expansion")?,
        automatic_differentiation: list.bool_or(
            ctx,
            "Apply Automatic Differentiation Jacobian",
            true,
        )?,
        shear_correction: list.bool_or(ctx, "Apply Shear Correction Factor", false)?,
    })
}

/// `Elastic Plastic`: yield stress, optionally planar with a `Thickness`.
fn read_elastic_plastic(
    ctx: &Ctx,
    list: &mut ListReader,
    ignored: &mut Vec<(&'static str, &'static str)>,
) -> Result<MaterialModel, DeckError> {
    ignored.push((
        "Apply Shear Correction Factor",
        "the Elastic Plastic model never applies a shear correction",
    ));
    let yield_stress = list.positive_req(ctx, "Yield Stress")?;
    let planar = list.bool_or(ctx, "Planar Problem", false)?;
    Ok(MaterialModel::ElasticPlastic {
        yield_stress,
        disable_plasticity: list.bool_or(ctx, "Disable Plasticity", false)?,
        automatic_differentiation: list.bool_or(
            ctx,
            "Apply Automatic Differentiation Jacobian",
            true,
        )?,
        planar_thickness: if planar {
            Some(list.positive_req(ctx, "Thickness")?)
        } else {
            None
        },
    })
}

/// `Pals`: its two influence functions (default `One`).
fn read_pals(ctx: &Ctx, list: &mut ListReader) -> Result<MaterialModel, DeckError> {
    let influence =
        |ctx: &Ctx, list: &mut ListReader, key: &'static str| -> Result<PalsInfluence, DeckError> {
            Ok(match list.get(key) {
                None => PalsInfluence::One,
                Some(f) => match f.choice(ctx, &["One", "Parabolic Decay", "Gaussian"])? {
                    "Parabolic Decay" => PalsInfluence::ParabolicDecay,
                    "Gaussian" => PalsInfluence::Gaussian,
                    _ => PalsInfluence::One,
                },
            })
        };
    Ok(MaterialModel::Pals {
        dilatation_influence: influence(ctx, list, "Dilatation Influence Function")?,
        deviatoric_influence: influence(ctx, list, "Deviatoric Influence Function")?,
    })
}

/// The PMB constants of `Elastic Bond Based` and `Microplastic Bond Based` (`model`): exactly
/// one modulus, optionally planar with a `Height`.
fn read_bond_based(
    ctx: &Ctx,
    list: &mut ListReader,
    model: &str,
) -> Result<(BondBasedModulus, Option<(PlanarKind, f64)>), DeckError> {
    let k = list.get("Bulk Modulus");
    let e = list.get("Young's Modulus");
    let modulus = match (k, e) {
        (Some(k), None) => BondBasedModulus::Bulk(k.positive(ctx)?),
        (None, Some(e)) => BondBasedModulus::Young(e.positive(ctx)?),
        (Some(_), Some(e)) => {
            return Err(e.err(ctx, format!("{model} takes exactly one of \"Bulk Modulus\" and \"Young's Modulus\" (Poisson's ratio is fixed by the model); remove one")))
        }
        (None, None) => return Err(list.missing(ctx, "Bulk Modulus", "or \"Young's Modulus\"; exactly one of them")),
    };
    for key in ["Shear Modulus", "Poisson's Ratio"] {
        if let Some(f) = list.get(key) {
            return Err(f.err(ctx, format!("\"{key}\" cannot be set for {model}: Poisson's ratio is fixed (1/4 in 3D and plane strain, 1/3 in plane stress); give only \"Bulk Modulus\" or \"Young's Modulus\"")));
        }
    }
    let strain = list.bool_or(ctx, "Plane Strain", false)?;
    let stress = list.bool_or(ctx, "Plane Stress", false)?;
    let planar = match (strain, stress) {
        (true, true) => {
            let f = list.get("Plane Stress").expect("just read");
            return Err(f.err(ctx, "Plane Strain and Plane Stress cannot both be true"));
        }
        (true, false) => Some((PlanarKind::PlaneStrain, list.positive_req(ctx, "Height")?)),
        (false, true) => Some((PlanarKind::PlaneStress, list.positive_req(ctx, "Height")?)),
        (false, false) => None,
    };
    Ok((modulus, planar))
}

/// The three hypoelastic correspondence models (`model_name` says which).
fn read_hypoelastic(
    ctx: &Ctx,
    list: &mut ListReader,
    model_name: &str,
) -> Result<MaterialModel, DeckError> {
    let plasticity = match model_name {
        "Elastic Hypoelastic Correspondence" => CorrespondencePlasticity::Elastic,
        "Elastic Plastic Hypoelastic Correspondence" => {
            CorrespondencePlasticity::PerfectlyPlastic {
                yield_stress: list.positive_req(ctx, "Yield Stress")?,
            }
        }
        _ => CorrespondencePlasticity::IsotropicHardening {
            yield_stress: list.positive_req(ctx, "Yield Stress")?,
            hardening_modulus: non_negative_req(ctx, list, "Hardening Modulus")?,
        },
    };
    Ok(MaterialModel::HypoelasticCorrespondence {
        plasticity,
        actual_horizon: list.positive_req(ctx, "Actual Horizon")?,
        gradient_order_of_accuracy: list
            .int_opt(ctx, "Gradient Order Of Accuracy", 1)?
            .unwrap_or(1),
        hourglass_coefficient: list
            .non_negative_opt(ctx, "Hourglass Coefficient")?
            .unwrap_or(0.0),
    })
}

/// The three bond-associated correspondence models (`model_name` says which).
fn read_bond_associated(
    ctx: &mut Ctx,
    list: &mut ListReader,
    model_name: &str,
) -> Result<MaterialModel, DeckError> {
    let plasticity = match model_name {
        "Elastic Bond Associated Correspondence" => BondAssociatedPlasticity::Elastic,
        "Elastic Plastic Bond Associated Correspondence" => {
            BondAssociatedPlasticity::PerfectlyPlastic {
                yield_stress: list.positive_req(ctx, "Yield Stress")?,
            }
        }
        _ => {
            let rule = list
                .require(
                    ctx,
                    "Hardening Rule",
                    "\"Power-law\" or \"Saturation type exponential\"",
                )?
                .choice(ctx, &["Power-law", "Saturation type exponential"])?;
            let mut params = list.list_req(ctx, "Hardening Parameters")?;
            let plasticity = if rule == "Power-law" {
                BondAssociatedPlasticity::PowerLaw {
                    yield_stress: params.positive_req(ctx, "Yield Stress")?,
                    hardening_characteristic_strain: params
                        .positive_req(ctx, "Hardening Characteristic Strain")?,
                    hardening_exponent: params.f64_req(ctx, "Hardening Exponent")?,
                }
            } else {
                BondAssociatedPlasticity::SaturationExponential {
                    initial_yield_stress: params.positive_req(ctx, "Initial Yield Stress")?,
                    saturated_yield_stress: params.positive_req(ctx, "Saturated Yield Stress")?,
                    exponential_constant: params.f64_req(ctx, "Exponential Constant")?,
                    linear_constant: params.f64_req(ctx, "Linear Constant")?,
                }
            };
            params.finish(ctx, &[])?;
            plasticity
        }
    };
    Ok(MaterialModel::BondAssociatedCorrespondence {
        plasticity,
        gradient_order_of_accuracy: list
            .int_opt(ctx, "Gradient Order Of Accuracy", 1)?
            .unwrap_or(1),
    })
}

/// `Tangent`, or the method implied by an explicit `Apply Automatic Differentiation Jacobian`
/// (peeked, not consumed: the model reads it as before). Both present and disagreeing is an
/// error at `Tangent`.
fn read_tangent(
    ctx: &Ctx,
    list: &mut ListReader,
    probe: Option<f64>,
) -> Result<Option<TangentMethod>, DeckError> {
    let finite_difference = TangentMethod::FiniteDifference { probe };
    let peridigm = match list.peek("Apply Automatic Differentiation Jacobian") {
        Some(f) if f.bool(ctx)? => Some(TangentMethod::AutomaticDifferentiation),
        Some(_) => Some(finite_difference),
        None => None,
    };
    let Some(field) = list.get("Tangent") else {
        return Ok(peridigm);
    };
    let names = [
        TangentMethod::Analytic.deck_name(),
        TangentMethod::AutomaticDifferentiation.deck_name(),
        finite_difference.deck_name(),
    ];
    let name = field.choice(ctx, &names)?;
    let chosen = if name == names[0] {
        TangentMethod::Analytic
    } else if name == names[1] {
        TangentMethod::AutomaticDifferentiation
    } else {
        finite_difference
    };
    match peridigm {
        Some(implied) if implied != chosen => Err(field.err(
            ctx,
            format!(
                "`Tangent: \"{name}\"` contradicts `Apply Automatic Differentiation Jacobian` \
                 (which asks for \"{}\"); remove one of the two keys",
                implied.deck_name()
            ),
        )),
        _ => Ok(Some(chosen)),
    }
}

impl MaterialModel {
    /// The parameters a correspondence model's constructor reads; `None` for other models.
    pub fn correspondence_input(&self) -> Option<crate::material::CorrespondenceInput> {
        use crate::material::CorrespondenceInput;
        let hourglass_coefficient = self.hourglass_coefficient()?;
        let mut input = CorrespondenceInput {
            hourglass_coefficient,
            yield_stress: None,
            hardening_modulus: None,
            flaw: None,
            viscoplastic: None,
            hypoelastic: None,
        };
        match self {
            MaterialModel::HypoelasticCorrespondence {
                plasticity,
                actual_horizon,
                gradient_order_of_accuracy,
                ..
            } => {
                input.hypoelastic = Some(crate::material::HypoelasticInput {
                    actual_horizon: *actual_horizon,
                    gradient_order_of_accuracy: *gradient_order_of_accuracy,
                });
                match *plasticity {
                    CorrespondencePlasticity::Elastic => {}
                    CorrespondencePlasticity::PerfectlyPlastic { yield_stress } => {
                        input.yield_stress = Some(yield_stress);
                    }
                    CorrespondencePlasticity::IsotropicHardening {
                        yield_stress,
                        hardening_modulus,
                    } => {
                        input.yield_stress = Some(yield_stress);
                        input.hardening_modulus = Some(hardening_modulus);
                    }
                }
            }
            MaterialModel::ElasticPlasticCorrespondence { yield_stress, .. } => {
                input.yield_stress = Some(*yield_stress);
            }
            MaterialModel::IsotropicHardeningCorrespondence {
                yield_stress,
                hardening_modulus,
                flaw,
                ..
            } => {
                input.yield_stress = Some(*yield_stress);
                input.hardening_modulus = Some(*hardening_modulus);
                input.flaw = *flaw;
            }
            MaterialModel::ViscoplasticNeedlemanCorrespondence {
                yield_stress,
                strain_hardening_exponent,
                rate_hardening_exponent,
                reference_strain_rate,
                reference_strain_0,
                reference_strain_1,
                flaw,
                ..
            } => {
                input.yield_stress = Some(*yield_stress);
                input.flaw = *flaw;
                input.viscoplastic = Some(crate::material::NeedlemanParameters {
                    strain_hardening_exponent: *strain_hardening_exponent,
                    rate_hardening_exponent: *rate_hardening_exponent,
                    reference_strain_rate: *reference_strain_rate,
                    reference_strain_0: *reference_strain_0,
                    reference_strain_1: *reference_strain_1,
                });
            }
            _ => {}
        }
        Some(input)
    }

    /// The two base influence functions of `Pals`; `None` for other models.
    pub fn pals_input(&self) -> Option<crate::material::PalsInfluence> {
        use crate::material::InfluenceFunction;
        let function = |choice: PalsInfluence| match choice {
            PalsInfluence::One => InfluenceFunction::One,
            PalsInfluence::ParabolicDecay => InfluenceFunction::ParabolicDecay,
            PalsInfluence::Gaussian => InfluenceFunction::Gaussian,
        };
        match *self {
            MaterialModel::Pals {
                dilatation_influence,
                deviatoric_influence,
            } => Some(crate::material::PalsInfluence {
                dilatation: function(dilatation_influence),
                deviatoric: function(deviatoric_influence),
            }),
            _ => None,
        }
    }

    /// `Yield Stress`, `Disable Plasticity` and `Hardening Modulus` (0 for `Elastic Plastic`)
    /// of the state-based plastic models; `None` for other models.
    pub fn plasticity_input(&self) -> Option<crate::material::PlasticityInput> {
        match *self {
            MaterialModel::ElasticPlastic {
                yield_stress,
                disable_plasticity,
                ..
            } => Some(crate::material::PlasticityInput {
                yield_stress,
                disabled: disable_plasticity,
                hardening_modulus: 0.0,
            }),
            MaterialModel::ElasticPlasticHardening {
                yield_stress,
                disable_plasticity,
                hardening_modulus,
                ..
            } => Some(crate::material::PlasticityInput {
                yield_stress,
                disabled: disable_plasticity,
                hardening_modulus,
            }),
            _ => None,
        }
    }

    /// `Yield Stretch` s_Y of `Microplastic Bond Based`; `None` for other models.
    pub fn yield_stretch(&self) -> Option<f64> {
        match *self {
            MaterialModel::MicroplasticBondBased { yield_stretch, .. } => Some(yield_stretch),
            _ => None,
        }
    }

    /// `Analytic Weighted Volume` of `Linear LPS Partial Volume` when `Use Analytic Weighted
    /// Volume` is true; `None` for every other model.
    pub fn analytic_weighted_volume(&self) -> Option<f64> {
        match *self {
            MaterialModel::LinearLpsPartialVolume {
                analytic_weighted_volume,
                ..
            } => analytic_weighted_volume,
            _ => None,
        }
    }

    /// True when the model asks for partial-volume weights itself (`Linear LPS Partial
    /// Volume` with `Use Partial Volume` or `Use Improved Quadrature`): a block without its
    /// own `Quadrature` then uses the `Exact` rule.
    pub fn asks_for_partial_volumes(&self) -> bool {
        matches!(
            *self,
            MaterialModel::LinearLpsPartialVolume {
                use_partial_volume: true,
                ..
            } | MaterialModel::LinearLpsPartialVolume {
                use_improved_quadrature: true,
                ..
            }
        )
    }

    /// `Apply Shear Correction Factor` with the model's default (true for `Elastic Plastic
    /// Hardening`, false for `Elastic`); false for models without the option.
    pub fn shear_correction(&self) -> bool {
        match *self {
            MaterialModel::Elastic {
                shear_correction, ..
            }
            | MaterialModel::ElasticPlasticHardening {
                shear_correction, ..
            } => shear_correction,
            _ => false,
        }
    }

    /// `lambda_i` and `tau b` of `Viscoelastic`; `None` for other models.
    pub fn viscoelastic_input(&self) -> Option<crate::material::ViscoelasticInput> {
        match *self {
            MaterialModel::Viscoelastic { lambda_i, tau_b } => {
                Some(crate::material::ViscoelasticInput { lambda_i, tau_b })
            }
            _ => None,
        }
    }

    /// `Hourglass Coefficient` of a correspondence model; `None` for other models.
    pub fn hourglass_coefficient(&self) -> Option<f64> {
        match self {
            MaterialModel::ElasticCorrespondence {
                hourglass_coefficient,
            }
            | MaterialModel::ElasticPlasticCorrespondence {
                hourglass_coefficient,
                ..
            }
            | MaterialModel::IsotropicHardeningCorrespondence {
                hourglass_coefficient,
                ..
            }
            | MaterialModel::ViscoplasticNeedlemanCorrespondence {
                hourglass_coefficient,
                ..
            }
            | MaterialModel::HypoelasticCorrespondence {
                hourglass_coefficient,
                ..
            } => Some(*hourglass_coefficient),
            _ => None,
        }
    }

    /// The `Material Model` string of this model, as written in decks.
    pub fn deck_name(&self) -> &'static str {
        match self {
            MaterialModel::Elastic { .. } => "Elastic",
            MaterialModel::ElasticPlastic { .. } => "Elastic Plastic",
            MaterialModel::ElasticPlasticHardening { .. } => "Elastic Plastic Hardening",
            MaterialModel::Viscoelastic { .. } => "Viscoelastic",
            MaterialModel::ElasticBondBased { .. } => "Elastic Bond Based",
            MaterialModel::MicroplasticBondBased { .. } => "Microplastic Bond Based",
            MaterialModel::Pals { .. } => "Pals",
            MaterialModel::LinearLpsPartialVolume { .. } => "Linear LPS Partial Volume",
            MaterialModel::ElasticCorrespondence { .. } => "Elastic Correspondence",
            MaterialModel::ElasticPlasticCorrespondence { .. } => "Elastic Plastic Correspondence",
            MaterialModel::IsotropicHardeningCorrespondence { .. } => {
                "Isotropic Hardening Correspondence"
            }
            MaterialModel::ViscoplasticNeedlemanCorrespondence { .. } => {
                "Viscoplastic Needleman Correspondence"
            }
            MaterialModel::HypoelasticCorrespondence { plasticity, .. } => match plasticity {
                CorrespondencePlasticity::Elastic => "Elastic Hypoelastic Correspondence",
                CorrespondencePlasticity::PerfectlyPlastic { .. } => {
                    "Elastic Plastic Hypoelastic Correspondence"
                }
                CorrespondencePlasticity::IsotropicHardening { .. } => {
                    "Isotropic Hardening Hypoelastic Correspondence"
                }
            },
            MaterialModel::BondAssociatedCorrespondence { plasticity, .. } => match plasticity {
                BondAssociatedPlasticity::Elastic => "Elastic Bond Associated Correspondence",
                BondAssociatedPlasticity::PerfectlyPlastic { .. } => {
                    "Elastic Plastic Bond Associated Correspondence"
                }
                BondAssociatedPlasticity::PowerLaw { .. }
                | BondAssociatedPlasticity::SaturationExponential { .. } => {
                    "Isotropic Hardening Bond Associated Correspondence"
                }
            },
            MaterialModel::MultiphysicsElastic { .. } => "Multiphysics Elastic",
            MaterialModel::VectorPoisson => "Vector Poisson",
            MaterialModel::Diffusion { .. } => "Diffusion",
        }
    }

    /// True for ordinary and non-ordinary state-based models (a point's force depends on its
    /// whole family's deformation), false for bond-based ones.
    pub fn is_state_based(&self) -> bool {
        !matches!(
            self,
            MaterialModel::ElasticBondBased { .. }
                | MaterialModel::MicroplasticBondBased { .. }
                | MaterialModel::VectorPoisson
                | MaterialModel::Diffusion { .. }
        )
    }
}

impl Material {
    /// Bulk modulus K of a mechanical model: `Elastic Bond Based`'s own modulus (see
    /// [`BondBasedModulus::bulk_modulus`]), else from the two elastic constants; `None` for
    /// `Diffusion` and `Vector Poisson`.
    pub fn bulk_modulus(&self) -> Option<f64> {
        match &self.model {
            MaterialModel::ElasticBondBased { modulus, planar }
            | MaterialModel::MicroplasticBondBased {
                modulus, planar, ..
            } => Some(modulus.bulk_modulus(planar.map(|(kind, _)| kind))),
            _ => self.elastic.as_ref().map(ElasticConstants::bulk_modulus),
        }
    }

    /// Shear modulus μ when the deck gives two elastic constants (`None` for bond-based
    /// models, whose Poisson's ratio is fixed).
    pub fn shear_modulus(&self) -> Option<f64> {
        self.elastic.as_ref().map(ElasticConstants::shear_modulus)
    }

    /// `Height` h of a planar (`Plane Strain`/`Plane Stress`) bond-based model, or `Thickness`
    /// h of an `Elastic Plastic` `Planar Problem`; `None` in 3D.
    pub fn planar_thickness(&self) -> Option<f64> {
        match &self.model {
            MaterialModel::ElasticBondBased { planar, .. }
            | MaterialModel::MicroplasticBondBased { planar, .. } => {
                planar.map(|(_, height)| height)
            }
            MaterialModel::ElasticPlastic {
                planar_thickness, ..
            } => *planar_thickness,
            _ => None,
        }
    }
}

impl BondBasedModulus {
    /// Bulk modulus K of `Elastic Bond Based`: the given K, or K from E with Peridigm's fixed
    /// Poisson's ratio (¼ in 3D and plane strain, ⅓ in plane stress) and the planar formulas of
    /// [`crate::material::ElasticConstants::from_pair`].
    pub fn bulk_modulus(&self, planar: Option<PlanarKind>) -> f64 {
        match *self {
            BondBasedModulus::Bulk(k) => k,
            BondBasedModulus::Young(e) => {
                let (nu, assumption) = match planar {
                    None => (0.25, crate::material::PlanarAssumption::None),
                    Some(PlanarKind::PlaneStrain) => {
                        (0.25, crate::material::PlanarAssumption::PlaneStrain)
                    }
                    Some(PlanarKind::PlaneStress) => {
                        (1.0 / 3.0, crate::material::PlanarAssumption::PlaneStress)
                    }
                };
                let input = crate::material::ElasticInput {
                    youngs_modulus: Some(e),
                    poissons_ratio: Some(nu),
                    ..Default::default()
                };
                crate::material::ElasticConstants::from_pair(input, assumption)
                    .map(|c| c.bulk_modulus)
                    .unwrap_or_else(|e| unreachable!("E > 0 was validated at load: {e}"))
            }
        }
    }
}
