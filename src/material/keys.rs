//! The deck keys several material models share, documented once, and the reader of the keys
//! every model's list may carry whatever its model (`Density`, the tangent keys, `Thermal
//! Expansion Coefficient`): which of them a model takes is what its declaration lists.

use crate::model::{KeyDoc, ModelDeclaration};
use crate::parameter_list::error::DeckError;
use crate::parameter_list::reader::{Ctx, ListReader};
use crate::tangent::TangentMethod;

/// `Density`.
pub const DENSITY: KeyDoc = KeyDoc {
    key: "Density",
    meaning: "mass density ρ",
    unit: "mass/length³",
    default: "required",
};

/// `Bulk Modulus` (one of the elastic pair).
pub const BULK_MODULUS: KeyDoc = KeyDoc {
    key: "Bulk Modulus",
    meaning: "bulk modulus K; give exactly two of K, μ, E, ν",
    unit: "pressure",
    default: "two of four",
};

/// `Shear Modulus` (one of the elastic pair).
pub const SHEAR_MODULUS: KeyDoc = KeyDoc {
    key: "Shear Modulus",
    meaning: "shear modulus μ; give exactly two of K, μ, E, ν",
    unit: "pressure",
    default: "two of four",
};

/// `Young's Modulus` (one of the elastic pair).
pub const YOUNGS_MODULUS: KeyDoc = KeyDoc {
    key: "Young's Modulus",
    meaning: "Young's modulus E; give exactly two of K, μ, E, ν",
    unit: "pressure",
    default: "two of four",
};

/// `Poisson's Ratio` (one of the elastic pair).
pub const POISSONS_RATIO: KeyDoc = KeyDoc {
    key: "Poisson's Ratio",
    meaning: "Poisson's ratio ν, strictly between −1 and ½; give exactly two of K, μ, E, ν",
    unit: "—",
    default: "two of four",
};

/// `Tangent` (peridyn's key).
pub const TANGENT: KeyDoc = KeyDoc {
    key: "Tangent",
    meaning: "how the implicit solvers' tangent is computed: \"Analytic\", \"Automatic \
              Differentiation\" or \"Finite Difference\"",
    unit: "a name",
    default: "the model's (its page says which)",
};

/// `Apply Automatic Differentiation Jacobian` (Peridigm's switch of the tangent).
pub const AUTOMATIC_DIFFERENTIATION: KeyDoc = KeyDoc {
    key: "Apply Automatic Differentiation Jacobian",
    meaning: "Peridigm's tangent switch: true asks for automatic differentiation, false for \
              finite differences",
    unit: "true/false",
    default: "the model's tangent",
};

/// `Finite Difference Probe Length`.
pub const PROBE_LENGTH: KeyDoc = KeyDoc {
    key: "Finite Difference Probe Length",
    meaning: "probe ε of the finite-difference tangent",
    unit: "length",
    default: "10⁻⁶ × the smallest element radius",
};

/// `Thermal Expansion Coefficient`.
pub const THERMAL_EXPANSION: KeyDoc = KeyDoc {
    key: "Thermal Expansion Coefficient",
    meaning: "α: the free thermal strain α ΔT of a point whose temperature changed by ΔT",
    unit: "1/temperature",
    default: "none (no thermal strain)",
};

/// The four elastic constants, of which a model with an elastic pair takes exactly two.
pub const ELASTIC: [KeyDoc; 4] = [BULK_MODULUS, SHEAR_MODULUS, YOUNGS_MODULUS, POISSONS_RATIO];

/// The keys every model's list may carry, read before the model's own keys.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct SharedKeys {
    /// `Density` (required by every model that declares it).
    pub density: Option<f64>,
    /// `Thermal Expansion Coefficient`, for a model that declares thermal strain.
    pub thermal_expansion_coefficient: Option<f64>,
    /// `Finite Difference Probe Length`.
    pub finite_difference_probe_length: Option<f64>,
    /// The tangent the deck asks for (`Tangent`, or the one implied by `Apply Automatic
    /// Differentiation Jacobian`); `None`: the model's default.
    pub tangent: Option<TangentMethod>,
}

impl SharedKeys {
    /// Reads the shared keys of the model `declaration` (`model` is the name the deck gave
    /// it): `Density` when declared; `Thermal Expansion Coefficient`, an error for a model
    /// without thermal strain; the tangent keys of every model.
    pub(crate) fn read(
        ctx: &Ctx,
        list: &mut ListReader,
        declaration: &ModelDeclaration,
        model: &str,
    ) -> Result<Self, DeckError> {
        let density = match declaration.key(DENSITY.key) {
            Some(_) => Some(list.positive_req(ctx, DENSITY.key)?),
            None => None,
        };
        if let Some(f) = list.get(THERMAL_EXPANSION.key) {
            if !declaration.thermal_strain {
                return Err(f.err(
                    ctx,
                    format!(
                        "the \"{model}\" material model has no thermal strain; \"Thermal \
                         Expansion Coefficient\" is taken only by \"Elastic\" and \"Elastic \
                         Correspondence\" (remove the key or choose one of them)"
                    ),
                ));
            }
        }
        let thermal_expansion_coefficient = list.f64_opt(ctx, THERMAL_EXPANSION.key)?;
        let finite_difference_probe_length = list.positive_opt(ctx, PROBE_LENGTH.key)?;
        let tangent = read_tangent(ctx, list, finite_difference_probe_length)?;
        if declaration.key(AUTOMATIC_DIFFERENTIATION.key).is_some() {
            list.get(AUTOMATIC_DIFFERENTIATION.key);
        }
        Ok(Self {
            density,
            thermal_expansion_coefficient,
            finite_difference_probe_length,
            tangent,
        })
    }
}

/// `Tangent`, or the method implied by an explicit `Apply Automatic Differentiation Jacobian`
/// (checked here; a model that declares the key takes it, any other leaves it to the warning
/// about other models' keys). Both present and disagreeing is an error at `Tangent`.
fn read_tangent(
    ctx: &Ctx,
    list: &mut ListReader,
    probe: Option<f64>,
) -> Result<Option<TangentMethod>, DeckError> {
    let finite_difference = TangentMethod::FiniteDifference { probe };
    let peridigm = match list.peek(AUTOMATIC_DIFFERENTIATION.key) {
        Some(f) if f.bool(ctx)? => Some(TangentMethod::AutomaticDifferentiation),
        Some(_) => Some(finite_difference),
        None => None,
    };
    let Some(field) = list.get(TANGENT.key) else {
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

/// An error at `key` when the deck gives it: the model `model` does not support it (Peridigm
/// stops with an error there too).
pub(crate) fn refuse(
    ctx: &Ctx,
    list: &ListReader,
    model: &str,
    key: &'static str,
) -> Result<(), DeckError> {
    match list.peek(key) {
        Some(f) => Err(f.err(
            ctx,
            format!(
                "the \"{model}\" material model does not support `{key}` (Peridigm refuses it \
                 too); remove the key"
            ),
        )),
        None => Ok(()),
    }
}

/// A required number ≥ 0 at `key`.
pub(crate) fn non_negative_req(
    ctx: &Ctx,
    list: &mut ListReader,
    key: &'static str,
) -> Result<f64, DeckError> {
    list.require(ctx, key, "a number ≥ 0")?.non_negative(ctx)
}
