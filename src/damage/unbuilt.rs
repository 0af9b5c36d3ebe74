//! Peridigm's damage models whose keys decks may carry but this build does not run: the deck
//! reads and checks their lists, and the set-up refuses them by name. A model that comes to
//! run gets its own file and moves to [`super::DAMAGE_MODELS`].

use super::{DamageEntry, DamageKeys, DamageParameters};
use crate::model::{KeyDoc, ModelDeclaration, Reach, TangentSupport};
use crate::parameter_list::error::DeckError;
use crate::parameter_list::reader::{Ctx, ListReader};

/// Every damage model a deck may name that this build does not run.
pub static UNBUILT_DAMAGE_MODELS: &[DamageEntry] = &[
    DamageEntry::read_only::<JohnsonCook>(),
    DamageEntry::read_only::<VonMisesStress>(),
];

/// The declaration of a damage model this build does not run, reading `deck_keys`.
const fn unbuilt(deck_name: &'static str, deck_keys: &'static [KeyDoc]) -> ModelDeclaration {
    ModelDeclaration {
        deck_name,
        aliases: &[],
        deck_keys,
        reach: Reach::OneHop,
        fields: &[],
        outputs: &[],
        tangent: TangentSupport::None,
        thermal_strain: false,
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

/// `Critical Damage To Neglect Material Point` of both models — default 0.95.
const NEGLECT: &str = "Critical Damage To Neglect Material Point";

/// `"Johnson Cook"`: bond damage from plastic strain over the failure strain
/// `ε_f = d₁ + d₂ exp(−d₃ η)` (needs a bond-associated plastic material).
pub struct JohnsonCook;

/// The deck parameters of `Johnson Cook`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JohnsonCookParameters {
    /// `Damage Parameter 1`, `Damage Parameter 2`, `Damage Parameter 3` (required).
    pub damage_parameters: [f64; 3],
    /// `Critical Damage` (required, in (0, 1]).
    pub critical_damage: f64,
    /// `Threshold Damage` (required, in [0, critical damage)).
    pub threshold_damage: f64,
    /// `Critical Damage To Neglect Material Point` — default 0.95.
    pub critical_damage_to_neglect: f64,
}

impl DamageParameters for JohnsonCookParameters {}

impl DamageKeys for JohnsonCook {
    type Parameters = JohnsonCookParameters;

    const DECLARATION: ModelDeclaration = unbuilt(
        "Johnson Cook",
        &[
            key("Damage Parameter 1"),
            key("Damage Parameter 2"),
            key("Damage Parameter 3"),
            key("Critical Damage"),
            key("Threshold Damage"),
            key(NEGLECT),
        ],
    );

    /// Three damage parameters, 0 ≤ threshold < critical ≤ 1.
    fn read(ctx: &mut Ctx, list: &mut ListReader) -> Result<JohnsonCookParameters, DeckError> {
        let damage_parameters = [
            list.f64_req(ctx, "Damage Parameter 1")?,
            list.f64_req(ctx, "Damage Parameter 2")?,
            list.f64_req(ctx, "Damage Parameter 3")?,
        ];
        let critical = list.require(ctx, "Critical Damage", "a number in (0, 1]")?;
        let critical_damage = critical.positive(ctx)?;
        if critical_damage > 1.0 {
            return Err(critical.err(ctx, format!("must not exceed 1, found {critical_damage}")));
        }
        let threshold = list.require(ctx, "Threshold Damage", "a number below Critical Damage")?;
        let threshold_damage = threshold.non_negative(ctx)?;
        if threshold_damage >= critical_damage {
            return Err(threshold.err(
                ctx,
                format!("must be smaller than Critical Damage ({critical_damage})"),
            ));
        }
        Ok(JohnsonCookParameters {
            damage_parameters,
            critical_damage,
            threshold_damage,
            critical_damage_to_neglect: list.positive_opt(ctx, NEGLECT)?.unwrap_or(0.95),
        })
    }
}

/// `"Von Mises Stress"`: bond damage ramps from 0 at σ_vm/σ_c = threshold to 1 at critical.
pub struct VonMisesStress;

/// The deck parameters of `Von Mises Stress`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VonMisesStressParameters {
    /// `Critical Von Mises Stress` σ_c (required, > 0).
    pub critical_von_mises_stress: f64,
    /// `Critical Damage` — default 1.0.
    pub critical_damage: f64,
    /// `Threshold Damage` — default 0.99.
    pub threshold_damage: f64,
    /// `Critical Damage To Neglect Material Point` — default 0.95.
    pub critical_damage_to_neglect: f64,
}

impl DamageParameters for VonMisesStressParameters {}

impl DamageKeys for VonMisesStress {
    type Parameters = VonMisesStressParameters;

    const DECLARATION: ModelDeclaration = unbuilt(
        "Von Mises Stress",
        &[
            key("Critical Von Mises Stress"),
            key("Critical Damage"),
            key("Threshold Damage"),
            key(NEGLECT),
        ],
    );

    /// The critical stress, and threshold < critical damage (defaults 0.99 and 1).
    fn read(ctx: &mut Ctx, list: &mut ListReader) -> Result<VonMisesStressParameters, DeckError> {
        let critical_von_mises_stress = list.positive_req(ctx, "Critical Von Mises Stress")?;
        let critical_damage = list.positive_opt(ctx, "Critical Damage")?.unwrap_or(1.0);
        let threshold_damage = list
            .non_negative_opt(ctx, "Threshold Damage")?
            .unwrap_or(0.99);
        if threshold_damage >= critical_damage {
            let line = list
                .get("Threshold Damage")
                .or_else(|| list.get("Critical Damage"))
                .map_or(list.line, |f| f.line());
            return Err(ctx.error(
                Some(line),
                &list.path,
                format!("Threshold Damage ({threshold_damage}) must be smaller than Critical Damage ({critical_damage})"),
            ));
        }
        Ok(VonMisesStressParameters {
            critical_von_mises_stress,
            critical_damage,
            threshold_damage,
            critical_damage_to_neglect: list.positive_opt(ctx, NEGLECT)?.unwrap_or(0.95),
        })
    }
}
