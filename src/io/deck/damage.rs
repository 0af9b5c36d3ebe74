//! `Damage Models` list: one entry per named damage model, each with a `Damage Model` and its
//! keys. The model names and keys belong to the models: the damage registry
//! ([`crate::damage::deck_damage_model`]) says which model a name means, and the model's own
//! reader takes its keys from the list.

use std::sync::Arc;

use super::error::DeckError;
use super::reader::{Ctx, Field};
use crate::damage::{deck_damage_model, deck_damage_models, DamageEntry, DamageParameters};

/// One named damage model (an entry of `Damage Models`).
#[derive(Debug, Clone)]
pub struct DamageModel {
    /// The name of the list; blocks refer to it with `Damage Model`.
    pub name: String,
    /// `Damage Model`: the registry entry of the model (built by this build or not).
    pub model: &'static DamageEntry,
    /// The model's own parameters, typed by the model ([`DamageModel::parameters`] gets them
    /// back).
    pub parameters: Arc<dyn DamageParameters>,
}

impl PartialEq for DamageModel {
    fn eq(&self, other: &Self) -> bool {
        self.name == other.name
            && self.model == other.model
            && self.parameters.same_as(other.parameters.as_any())
    }
}

impl DamageModel {
    /// The model's parameters as the model's own type `T`, `None` when the model keeps
    /// another type.
    pub fn parameters<T: DamageParameters>(&self) -> Option<&T> {
        self.parameters.as_any().downcast_ref::<T>()
    }
}

/// The parameters of all damage models (a model reads its own; the others are ignored with a
/// warning).
const DAMAGE_KEYS: &[&str] = &[
    "Critical Stretch",
    "Critical Energy Release Rate",
    "Time Dependent Critical Stretch",
    "Thermal Expansion Coefficient",
    "Bond Filters",
    "Damage Parameter 1",
    "Damage Parameter 2",
    "Damage Parameter 3",
    "Critical Damage",
    "Threshold Damage",
    "Critical Damage To Neglect Material Point",
    "Critical Von Mises Stress",
];

pub(crate) fn read(ctx: &mut Ctx, field: &Field) -> Result<DamageModel, DeckError> {
    let mut list = field.list(ctx)?;
    let names: Vec<&'static str> = deck_damage_models().map(DamageEntry::deck_name).collect();
    let name = list
        .require(ctx, "Damage Model", "the damage law")?
        .choice(ctx, &names)?;
    let model = deck_damage_model(name).expect("choice() returns a registered name");
    let parameters = model.read(ctx, &mut list)?;
    // Peridigm does not validate damage-model lists, so a deck may carry the parameters of
    // another model (left over after switching models): a warning, not an error.
    let ignored: Vec<(&str, &str)> = DAMAGE_KEYS
        .iter()
        .map(|key| (*key, "a parameter of other damage models, not of this one"))
        .collect();
    list.finish(ctx, &ignored)?;
    Ok(DamageModel {
        name: field.key().to_string(),
        model,
        parameters,
    })
}
