//! `Materials` list: one entry per named material, each with a `Material Model` and its keys.
//!
//! The model names and their keys belong to the models: the material registry
//! ([`crate::material::deck_model`]) says which model a name means, and the model's own reader
//! takes its keys from the list. This file reads what every list has (the model's name, the
//! shared keys its declaration lists) and ends the list: Peridigm ignores the parameters of
//! other models (its material lists are not validated), so decks carry them, e.g.
//! `Hourglass Coefficient` on an `Elastic` material: a warning, not an error.

use super::error::DeckError;
use super::reader::{Ctx, Field};
use crate::material::keys::{SharedKeys, DENSITY, ELASTIC};
use crate::material::{deck_model, deck_model_names, MaterialEntry, MaterialParameters};
use crate::tangent::TangentMethod;
use std::sync::Arc;

pub use crate::material::Flaw;

/// One named material (an entry of `Materials`).
#[derive(Debug, Clone)]
pub struct Material {
    /// The name of the material's list; blocks refer to it with `Material`.
    pub name: String,
    /// `Material Model`: the registry entry of the model (built by this build or not,
    /// [`MaterialEntry::is_built`]).
    pub model: &'static MaterialEntry,
    /// The model's own parameters, typed by the model ([`Material::parameters`] gets them
    /// back).
    pub parameters: Arc<dyn MaterialParameters>,
    /// `Density` ρ (mass per volume, > 0); required by every mechanical model, absent for
    /// `Diffusion` and `Vector Poisson`.
    pub density: Option<f64>,
    /// `Thermal Expansion Coefficient` α (per degree); thermal strain `α ΔT` when present.
    /// Only for the models that declare thermal strain; any other model with the key is an
    /// error naming it.
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

impl PartialEq for Material {
    fn eq(&self, other: &Self) -> bool {
        self.name == other.name
            && self.model == other.model
            && self.parameters.same_as(other.parameters.as_any())
            && self.density == other.density
            && self.thermal_expansion_coefficient == other.thermal_expansion_coefficient
            && self.finite_difference_probe_length == other.finite_difference_probe_length
            && self.tangent == other.tangent
    }
}

impl Material {
    /// The model's parameters as the model's own type `T`, `None` when the material's model
    /// keeps another type.
    pub fn parameters<T: MaterialParameters>(&self) -> Option<&T> {
        self.parameters.as_any().downcast_ref::<T>()
    }

    /// Bulk modulus K of a mechanical model (from its elastic constants, or a bond-based
    /// model's own modulus); `None` for `Diffusion` and `Vector Poisson`.
    pub fn bulk_modulus(&self) -> Option<f64> {
        self.parameters.bulk_modulus()
    }

    /// The thickness h of a planar model (`Height` of a planar bond-based model, `Thickness`
    /// of an `Elastic Plastic` `Planar Problem`); `None` in 3D.
    pub fn planar_thickness(&self) -> Option<f64> {
        self.parameters.planar_thickness()
    }

    /// True when the model asks for partial-volume weights itself (`Linear LPS Partial
    /// Volume` with `Use Partial Volume` or `Use Improved Quadrature`): a block without its
    /// own `Quadrature` then uses the `Exact` rule.
    pub fn asks_for_partial_volumes(&self) -> bool {
        self.parameters.asks_for_partial_volumes()
    }
}

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

/// Keys that some model accepts and Peridigm's example decks carry on others: an unread one is
/// a warning, not an error.
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
    let model_name = model_field.choice(ctx, &deck_model_names())?;
    let model = deck_model(model_name).expect("choice() returns a registered name");
    if let Some(h) = list.peek("Horizon") {
        return Err(h.err(ctx, "the horizon is not a material parameter; set `Horizon` in the block that uses this material"));
    }
    let shared = SharedKeys::read(ctx, &mut list, model.declaration, model_name)?;
    let parameters = model.read(ctx, &mut list)?;
    let ignored: Vec<(&str, &str)> = MODEL_KEYS
        .iter()
        .map(|key| {
            (
                *key,
                "a parameter of other material models, not of this one",
            )
        })
        .collect();
    let elastic_or_density = |key: &str| key == DENSITY.key || ELASTIC.iter().any(|k| k.key == key);
    list.finish_with(ctx, &ignored, |key| {
        (MODEL_KEYS.contains(&key) || elastic_or_density(key))
            .then(|| format!("\"{key}\" is not a parameter of the \"{model_name}\" material model"))
    })?;
    Ok(Material {
        name: field.key().to_string(),
        model,
        parameters,
        density: shared.density,
        thermal_expansion_coefficient: shared.thermal_expansion_coefficient,
        finite_difference_probe_length: shared.finite_difference_probe_length,
        tangent: shared.tangent,
    })
}
