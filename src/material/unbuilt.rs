//! Peridigm's material models whose keys decks may carry but this build does not run: the
//! deck reads and checks their lists (so a deck's mistakes are found at load, and `peridyn
//! check` lists what is missing), and the set-up refuses them by name. A model that comes to
//! run gets its own file and moves to [`super::MATERIALS`].

use super::keys::{AUTOMATIC_DIFFERENTIATION, DENSITY, ELASTIC, THERMAL_EXPANSION};
use super::{ElasticConstants, MaterialEntry, MaterialKeys, MaterialParameters};
use crate::model::{KeyDoc, ModelDeclaration, Reach, TangentSupport};
use crate::parameter_list::error::DeckError;
use crate::parameter_list::reader::{Ctx, ListReader};

/// Every model a deck may name that this build does not run.
pub static UNBUILT_MATERIALS: &[MaterialEntry] = &[
    MaterialEntry::read_only::<BondAssociated<0>>(),
    MaterialEntry::read_only::<BondAssociated<1>>(),
    MaterialEntry::read_only::<BondAssociated<2>>(),
    MaterialEntry::read_only::<MultiphysicsElastic>(),
    MaterialEntry::read_only::<VectorPoisson>(),
    MaterialEntry::read_only::<Diffusion>(),
];

/// The declaration of a model this build does not run, reading `deck_keys`.
const fn unbuilt(
    deck_name: &'static str,
    deck_keys: &'static [KeyDoc],
    thermal_strain: bool,
) -> ModelDeclaration {
    ModelDeclaration {
        deck_name,
        aliases: &[],
        deck_keys,
        reach: Reach::TwoHop,
        fields: &[],
        outputs: &[],
        tangent: TangentSupport::None,
        thermal_strain,
        small_displacement: false,
        example: "",
    }
}

/// A key read as Peridigm reads it, documented only by its name (the model does not run
/// here).
const fn key(key: &'static str) -> KeyDoc {
    KeyDoc {
        key,
        meaning: "read as Peridigm reads it (the model does not run in this build)",
        unit: "—",
        default: "—",
    }
}

/// The bond-associated correspondence models: `Elastic Bond Associated Correspondence` (0),
/// `Elastic Plastic Bond Associated Correspondence` (1), `Isotropic Hardening Bond Associated
/// Correspondence` (2).
pub struct BondAssociated<const KIND: u8>;

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

/// The deck parameters of a bond-associated correspondence model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BondAssociatedParameters {
    /// K and μ from the elastic pair.
    pub elastic: ElasticConstants,
    /// Which of the three models, with its plastic parameters.
    pub plasticity: BondAssociatedPlasticity,
    /// `Gradient Order Of Accuracy` — default 1.
    pub gradient_order_of_accuracy: i64,
}

impl MaterialParameters for BondAssociatedParameters {
    fn bulk_modulus(&self) -> Option<f64> {
        Some(self.elastic.bulk_modulus)
    }
}

/// The keys of the bond-associated models (the elastic one reads the first 6, the perfectly
/// plastic one the first 7).
const BOND_ASSOCIATED_KEYS: &[KeyDoc] = &[
    DENSITY,
    ELASTIC[0],
    ELASTIC[1],
    ELASTIC[2],
    ELASTIC[3],
    key("Gradient Order Of Accuracy"),
    key("Yield Stress"),
    key("Hardening Rule"),
    key("Hardening Parameters"),
];

impl<const KIND: u8> MaterialKeys for BondAssociated<KIND> {
    type Parameters = BondAssociatedParameters;

    const DECLARATION: ModelDeclaration = match KIND {
        0 => unbuilt(
            "Elastic Bond Associated Correspondence",
            BOND_ASSOCIATED_KEYS.split_at(6).0,
            false,
        ),
        1 => unbuilt(
            "Elastic Plastic Bond Associated Correspondence",
            BOND_ASSOCIATED_KEYS.split_at(7).0,
            false,
        ),
        _ => unbuilt(
            "Isotropic Hardening Bond Associated Correspondence",
            BOND_ASSOCIATED_KEYS,
            false,
        ),
    };

    fn read(ctx: &mut Ctx, list: &mut ListReader) -> Result<BondAssociatedParameters, DeckError> {
        let elastic = super::elastic_constants::read(ctx, list)?;
        let plasticity = match KIND {
            0 => BondAssociatedPlasticity::Elastic,
            1 => BondAssociatedPlasticity::PerfectlyPlastic {
                yield_stress: list.positive_req(ctx, "Yield Stress")?,
            },
            _ => read_hardening(ctx, list)?,
        };
        Ok(BondAssociatedParameters {
            elastic,
            plasticity,
            gradient_order_of_accuracy: list
                .int_opt(ctx, "Gradient Order Of Accuracy", 1)?
                .unwrap_or(1),
        })
    }
}

/// `Hardening Rule` and its `Hardening Parameters` sublist.
fn read_hardening(
    ctx: &mut Ctx,
    list: &mut ListReader,
) -> Result<BondAssociatedPlasticity, DeckError> {
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
    Ok(plasticity)
}

/// `Multiphysics Elastic`: `Elastic` plus a fluid-pressure unknown (needs `Multiphysics: 1`).
pub struct MultiphysicsElastic;

/// The fluid keys of `Multiphysics Elastic`, in the order they are read: the first five must
/// be positive.
const FLUID_KEYS: [&str; 9] = [
    "Fluid density",
    "Fluid compressibility",
    "Fluid dynamic viscosity",
    "Permeability",
    "Max permeability",
    "Permeability alpha",
    "Permeability curve inflection damage",
    "Fluid Reynolds viscosity temperature effect",
    "Fluid linear thermal expansion",
];

/// The deck parameters of `Multiphysics Elastic`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MultiphysicsParameters {
    /// K and μ from the elastic pair.
    pub elastic: ElasticConstants,
    /// The values of [`FLUID_KEYS`], in their order.
    pub fluid: [f64; 9],
    /// `Apply Shear Correction Factor` — default false.
    pub shear_correction: bool,
}

impl MaterialParameters for MultiphysicsParameters {
    fn bulk_modulus(&self) -> Option<f64> {
        Some(self.elastic.bulk_modulus)
    }

    fn requires_multiphysics(&self) -> bool {
        true
    }
}

impl MaterialKeys for MultiphysicsElastic {
    type Parameters = MultiphysicsParameters;

    const DECLARATION: ModelDeclaration = unbuilt(
        "Multiphysics Elastic",
        &[
            DENSITY,
            ELASTIC[0],
            ELASTIC[1],
            ELASTIC[2],
            ELASTIC[3],
            THERMAL_EXPANSION,
            AUTOMATIC_DIFFERENTIATION,
            key(FLUID_KEYS[0]),
            key(FLUID_KEYS[1]),
            key(FLUID_KEYS[2]),
            key(FLUID_KEYS[3]),
            key(FLUID_KEYS[4]),
            key(FLUID_KEYS[5]),
            key(FLUID_KEYS[6]),
            key(FLUID_KEYS[7]),
            key(FLUID_KEYS[8]),
            key("Apply Shear Correction Factor"),
        ],
        true,
    );

    fn read(ctx: &mut Ctx, list: &mut ListReader) -> Result<MultiphysicsParameters, DeckError> {
        let elastic = super::elastic_constants::read(ctx, list)?;
        list.without_effect(
            "Multiphysics",
            "the multiphysics switch is the top-level `Multiphysics: 1`",
        );
        let mut fluid = [0.0; 9];
        for (k, (value, key)) in fluid.iter_mut().zip(FLUID_KEYS).enumerate() {
            *value = if k < 5 {
                list.positive_req(ctx, key)?
            } else {
                list.f64_req(ctx, key)?
            };
        }
        Ok(MultiphysicsParameters {
            elastic,
            fluid,
            shear_correction: list.bool_or(ctx, "Apply Shear Correction Factor", false)?,
        })
    }
}

/// `Vector Poisson`: Peridigm's test operator, without parameters.
pub struct VectorPoisson;

/// The (empty) parameters of `Vector Poisson`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoParameters;

impl MaterialParameters for NoParameters {
    fn bulk_modulus(&self) -> Option<f64> {
        None
    }
}

impl MaterialKeys for VectorPoisson {
    type Parameters = NoParameters;

    const DECLARATION: ModelDeclaration = unbuilt("Vector Poisson", &[], false);

    fn read(_ctx: &mut Ctx, _list: &mut ListReader) -> Result<NoParameters, DeckError> {
        Ok(NoParameters)
    }
}

/// `Diffusion`: nonlocal diffusion of a scalar (temperature).
pub struct Diffusion;

/// The deck parameters of `Diffusion`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiffusionParameters {
    /// `Coefficient` (required, > 0).
    pub coefficient: f64,
    /// `Use Improved Quadrature` — default false.
    pub use_improved_quadrature: bool,
}

impl MaterialParameters for DiffusionParameters {
    fn bulk_modulus(&self) -> Option<f64> {
        None
    }
}

impl MaterialKeys for Diffusion {
    type Parameters = DiffusionParameters;

    const DECLARATION: ModelDeclaration = unbuilt(
        "Diffusion",
        &[key("Coefficient"), key("Use Improved Quadrature")],
        false,
    );

    fn read(ctx: &mut Ctx, list: &mut ListReader) -> Result<DiffusionParameters, DeckError> {
        Ok(DiffusionParameters {
            coefficient: list.positive_req(ctx, "Coefficient")?,
            use_improved_quadrature: list.bool_or(ctx, "Use Improved Quadrature", false)?,
        })
    }
}
