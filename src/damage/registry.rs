//! The one list of the damage models this build runs (see `material::MATERIALS` for the
//! material models): each model is a type in its own file that implements [`DamageKeys`] (its
//! declaration with documented keys, its typed parameters and their reader) and
//! [`DamageBuild`] (its builder), and has one line in [`DAMAGE_MODELS`].

use std::fmt;
use std::sync::Arc;

use super::{
    CriticalStretch, DamageError, DamageModel, InitialDamage, InterfaceAware,
    TimeDependentCriticalStretch,
};
use crate::model::{BondFilter, FieldCarrier, FieldDeclaration, ModelDeclaration};
use crate::parameter_list::error::DeckError;
use crate::parameter_list::reader::{Ctx, ListReader};
use crate::parameter_list::TypedParameters;

/// Bond damage d ∈ [0, 1] per directed bond, staged: the implicit solvers restore it when a
/// load step is rejected. Every damage model keeps it.
pub const BOND_DAMAGE: FieldDeclaration = FieldDeclaration {
    name: "Bond_Damage",
    carrier: FieldCarrier::Bond,
    bytes_per_value: 4,
    staged: true,
};

/// Peridigm's `Critical_Stretch` point field of `Interface Aware`: s_c on the points of the
/// blocks that use the model, 0 elsewhere. The builder fills it over all blocks (one field
/// for the whole model) for every model that declares it.
pub const POINT_CRITICAL_STRETCH: FieldDeclaration = FieldDeclaration {
    name: "Critical_Stretch",
    carrier: FieldCarrier::Point,
    bytes_per_value: 8,
    staged: false,
};

/// What the set-up resolves for a damage model of one block, besides the model's own
/// parameters: the block's material and horizon, the run's start, and what the model needs
/// from the whole model or from files.
#[derive(Debug, Clone, Default)]
pub struct DamageBlock {
    /// The block material's bulk modulus K.
    pub bulk_modulus: f64,
    /// The block's horizon δ.
    pub horizon: f64,
    /// The time of the first step (where time-dependent parameters are first evaluated).
    pub initial_time: f64,
    /// The [`POINT_CRITICAL_STRETCH`] field, when the model declares it.
    pub point_critical_stretch: Option<Arc<[f64]>>,
    /// The geometry of the parameters' bond filters ([`DamageParameters::bond_filters`]),
    /// shell meshes already read.
    pub bond_filters: Vec<crate::neighbors::BondFilter>,
}

/// The parameters of one damage model, read from its deck list by its reader and kept in the
/// deck (typed by the model, seen through this trait elsewhere).
pub trait DamageParameters: TypedParameters {
    /// The critical stretch s_c the deck gives as a number, for the point field of the models
    /// that declare [`POINT_CRITICAL_STRETCH`]; `None` (the default) otherwise.
    fn critical_stretch(&self) -> Option<f64> {
        None
    }

    /// The bond filters whose geometry the set-up builds for the model
    /// ([`DamageBlock::bond_filters`]); none by default.
    fn bond_filters(&self) -> &[BondFilter] {
        &[]
    }
}

/// A damage model as decks name it: its declaration and its typed parameters, read from its
/// deck list.
pub(crate) trait DamageKeys: 'static {
    /// The model's parameters.
    type Parameters: DamageParameters + Clone + PartialEq;

    /// What the model declares about itself.
    const DECLARATION: ModelDeclaration;

    /// Reads the model's keys from its list (every key one of the declaration's); errors name
    /// the file, key path and line.
    fn read(ctx: &mut Ctx, list: &mut ListReader) -> Result<Self::Parameters, DeckError>;
}

/// A damage model this build runs: [`DamageKeys`] and the builder of one block's model.
pub(crate) trait DamageBuild: DamageKeys {
    /// The model of one block (validated: errors name the deck key).
    fn build(
        block: &DamageBlock,
        parameters: &Self::Parameters,
    ) -> Result<Box<dyn DamageModel>, DamageError>;
}

/// Reads the parameters of a model from its deck list.
type ReadParameters = fn(&mut Ctx, &mut ListReader) -> Result<Arc<dyn DamageParameters>, DeckError>;

/// Builds one block's model from its parameters.
type Build = fn(&DamageBlock, &dyn DamageParameters) -> Result<Box<dyn DamageModel>, DamageError>;

/// One damage model of the registry.
#[derive(Clone, Copy)]
pub struct DamageEntry {
    /// What the model declares about itself.
    pub declaration: &'static ModelDeclaration,
    read: ReadParameters,
    build: Option<Build>,
}

fn read_erased<M: DamageKeys>(
    ctx: &mut Ctx,
    list: &mut ListReader,
) -> Result<Arc<dyn DamageParameters>, DeckError> {
    Ok(Arc::new(M::read(ctx, list)?))
}

fn build_erased<M: DamageBuild>(
    block: &DamageBlock,
    parameters: &dyn DamageParameters,
) -> Result<Box<dyn DamageModel>, DamageError> {
    let parameters = parameters
        .as_any()
        .downcast_ref::<M::Parameters>()
        .expect("the deck read these parameters with the same registry entry");
    M::build(block, parameters)
}

impl DamageEntry {
    /// The entry of the model `M`, which this build runs.
    pub(crate) const fn of<M: DamageBuild>() -> Self {
        Self {
            declaration: const { &M::DECLARATION },
            read: read_erased::<M>,
            build: Some(build_erased::<M>),
        }
    }

    /// The entry of a model whose keys decks may carry but this build does not run.
    pub(crate) const fn read_only<M: DamageKeys>() -> Self {
        Self {
            declaration: const { &M::DECLARATION },
            read: read_erased::<M>,
            build: None,
        }
    }

    /// Peridigm's `Damage Model` string of the model.
    pub fn deck_name(&self) -> &'static str {
        self.declaration.deck_name
    }

    /// True when this build runs the model.
    pub fn is_built(&self) -> bool {
        self.build.is_some()
    }

    /// Reads the model's parameters from its deck list ([`DamageKeys::read`]).
    pub(crate) fn read(
        &self,
        ctx: &mut Ctx,
        list: &mut ListReader,
    ) -> Result<Arc<dyn DamageParameters>, DeckError> {
        (self.read)(ctx, list)
    }

    /// Builds one block's model from `parameters` (read by this entry); `None` for a model
    /// this build does not run.
    pub fn build(
        &self,
        block: &DamageBlock,
        parameters: &dyn DamageParameters,
    ) -> Option<Result<Box<dyn DamageModel>, DamageError>> {
        Some((self.build?)(block, parameters))
    }
}

impl fmt::Debug for DamageEntry {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_tuple("DamageEntry")
            .field(&self.declaration.deck_name)
            .finish()
    }
}

impl PartialEq for DamageEntry {
    fn eq(&self, other: &Self) -> bool {
        self.declaration == other.declaration
    }
}

/// Every damage model this build runs, one line each (in the order decks' error messages list
/// them).
pub static DAMAGE_MODELS: &[DamageEntry] = &[
    DamageEntry::of::<CriticalStretch>(),
    DamageEntry::of::<TimeDependentCriticalStretch>(),
    DamageEntry::of::<InterfaceAware>(),
    DamageEntry::of::<InitialDamage>(),
];

/// The entry of the model called `deck_name` in decks (`Damage Model`), if this build runs it.
pub fn damage_entry(deck_name: &str) -> Option<&'static DamageEntry> {
    DAMAGE_MODELS
        .iter()
        .find(|entry| entry.declaration.deck_name == deck_name)
}

/// Every model a deck may name: those of [`DAMAGE_MODELS`], then Peridigm's models this build
/// reads but does not run ([`super::unbuilt::UNBUILT_DAMAGE_MODELS`]).
pub fn deck_damage_models() -> impl Iterator<Item = &'static DamageEntry> {
    DAMAGE_MODELS
        .iter()
        .chain(super::unbuilt::UNBUILT_DAMAGE_MODELS)
}

/// The model a deck's `Damage Model: "name"` means, built or not.
pub fn deck_damage_model(name: &str) -> Option<&'static DamageEntry> {
    deck_damage_models().find(|entry| entry.declaration.answers_to(name))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn deck_names_are_unique_and_every_model_keeps_bond_damage() {
        let names: Vec<&str> = deck_damage_models().map(DamageEntry::deck_name).collect();
        for (k, name) in names.iter().enumerate() {
            assert!(!names[..k].contains(name), "{name} listed twice");
        }
        for entry in DAMAGE_MODELS {
            let name = entry.deck_name();
            assert!(entry.is_built(), "{name}");
            assert!(entry.declaration.fields.contains(&BOND_DAMAGE), "{name}");
            assert!(std::ptr::eq(damage_entry(name).unwrap(), entry));
            assert!(std::ptr::eq(deck_damage_model(name).unwrap(), entry));
        }
        assert!(damage_entry("Johnson Cook").is_none());
        assert!(!deck_damage_model("Johnson Cook").unwrap().is_built());
    }
}
