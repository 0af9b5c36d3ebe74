//! The one list of the material models this build runs.
//!
//! Each model is one type in its own file that implements [`MaterialModel`]: its declaration
//! (deck name, documented keys, reach, fields, outputs, tangent, thermal strain), its typed
//! parameters and the reader that takes them from its deck list, and its builder. Its line in
//! [`MATERIALS`] makes it a model of the build: the deck reads it by name, the set-up builds it,
//! `peridyn check`, the ghost depth of ranks, the tangent pattern and the user guide's key
//! tables ask this list, and the conformance suite (`conformance_tests.rs`) runs it. Nothing
//! else names a model. Adding a model is its file and one line in [`MATERIALS`].

use std::fmt;
use std::sync::Arc;

use super::{
    BondBased, ElasticCorrespondence, ElasticHypoelasticCorrespondence, ElasticPlastic,
    ElasticPlasticCorrespondence, ElasticPlasticHardening, ElasticPlasticHypoelasticCorrespondence,
    InfluenceFunction, IsotropicHardeningCorrespondence,
    IsotropicHardeningHypoelasticCorrespondence, LinearLps, LinearPeridynamicSolid, Material,
    MaterialError, MicroplasticBondBased, Pals, Viscoelastic, ViscoplasticNeedlemanCorrespondence,
};
use crate::model::ModelDeclaration;
use crate::parameter_list::error::DeckError;
use crate::parameter_list::reader::{Ctx, ListReader};
use crate::parameter_list::TypedParameters;

/// What the set-up gives every model's builder for one block, besides the model's own
/// parameters.
#[derive(Debug, Clone)]
pub struct BlockInput {
    /// `Density` ρ (mass/length³).
    pub density: f64,
    /// The block's `Horizon` δ (length).
    pub horizon: f64,
    /// `Discretization → Influence Function` ω(ζ, δ).
    pub influence: InfluenceFunction,
}

/// The parameters of one material model, read from its deck list by its reader and kept in
/// the deck (typed by the model, seen through this trait elsewhere).
pub trait MaterialParameters: TypedParameters {
    /// Bulk modulus K (pressure) the parameters give, `None` for a model without one.
    fn bulk_modulus(&self) -> Option<f64>;

    /// The thickness h of a planar model (`Height`, `Thickness`); `None` in 3D (the default).
    fn planar_thickness(&self) -> Option<f64> {
        None
    }

    /// True when the model asks for partial-volume weights itself: a block without its own
    /// `Quadrature` then uses the `Exact` rule. Default false.
    fn asks_for_partial_volumes(&self) -> bool {
        false
    }

    /// True when the model needs the deck's top-level `Multiphysics: 1`. Default false.
    fn requires_multiphysics(&self) -> bool {
        false
    }
}

/// A material model as decks name it: its declaration and its typed parameters, read from
/// its deck list.
pub(crate) trait MaterialKeys: 'static {
    /// The model's parameters (its `Material Model` list less the keys every model shares:
    /// `Density`, `Tangent`, `Finite Difference Probe Length`, `Apply Automatic
    /// Differentiation Jacobian`, `Thermal Expansion Coefficient`, which the deck reads by the
    /// declaration).
    type Parameters: MaterialParameters + Clone + PartialEq;

    /// What the model declares about itself.
    const DECLARATION: ModelDeclaration;

    /// Reads the model's own keys from its list (the shared ones are read already); every key
    /// is one of [`Self::DECLARATION`]'s `deck_keys`. Errors name the file, key path and line.
    fn read(ctx: &mut Ctx, list: &mut ListReader) -> Result<Self::Parameters, DeckError>;
}

/// A material model this build runs: [`MaterialKeys`] and the builder of one block's material.
pub(crate) trait MaterialModel: MaterialKeys {
    /// The material of one block from the block's input and the model's parameters
    /// (validated: errors name the deck key).
    fn build(
        block: &BlockInput,
        parameters: &Self::Parameters,
    ) -> Result<Box<dyn Material>, MaterialError>;
}

/// Reads the parameters of a model from its deck list.
type ReadParameters =
    fn(&mut Ctx, &mut ListReader) -> Result<Arc<dyn MaterialParameters>, DeckError>;

/// Builds one block's material from its parameters.
type Build = fn(&BlockInput, &dyn MaterialParameters) -> Result<Box<dyn Material>, MaterialError>;

/// One material model of the registry.
#[derive(Clone, Copy)]
pub struct MaterialEntry {
    /// What the model declares about itself.
    pub declaration: &'static ModelDeclaration,
    read: ReadParameters,
    build: Option<Build>,
}

fn read_erased<M: MaterialKeys>(
    ctx: &mut Ctx,
    list: &mut ListReader,
) -> Result<Arc<dyn MaterialParameters>, DeckError> {
    Ok(Arc::new(M::read(ctx, list)?))
}

fn build_erased<M: MaterialModel>(
    block: &BlockInput,
    parameters: &dyn MaterialParameters,
) -> Result<Box<dyn Material>, MaterialError> {
    let parameters = parameters
        .as_any()
        .downcast_ref::<M::Parameters>()
        .expect("the deck read these parameters with the same registry entry");
    M::build(block, parameters)
}

impl MaterialEntry {
    /// The entry of the model `M`, which this build runs.
    pub(crate) const fn of<M: MaterialModel>() -> Self {
        Self {
            declaration: const { &M::DECLARATION },
            read: read_erased::<M>,
            build: Some(build_erased::<M>),
        }
    }

    /// The entry of a model whose keys decks may carry but this build does not run.
    pub(crate) const fn read_only<M: MaterialKeys>() -> Self {
        Self {
            declaration: const { &M::DECLARATION },
            read: read_erased::<M>,
            build: None,
        }
    }

    /// Peridigm's `Material Model` string of the model.
    pub fn deck_name(&self) -> &'static str {
        self.declaration.deck_name
    }

    /// True when this build runs the model.
    pub fn is_built(&self) -> bool {
        self.build.is_some()
    }

    /// Reads the model's parameters from its deck list ([`MaterialKeys::read`]).
    pub(crate) fn read(
        &self,
        ctx: &mut Ctx,
        list: &mut ListReader,
    ) -> Result<Arc<dyn MaterialParameters>, DeckError> {
        (self.read)(ctx, list)
    }

    /// Builds one block's material from `parameters` (read by this entry); `None` for a model
    /// this build does not run.
    pub fn build(
        &self,
        block: &BlockInput,
        parameters: &dyn MaterialParameters,
    ) -> Option<Result<Box<dyn Material>, MaterialError>> {
        Some((self.build?)(block, parameters))
    }
}

impl fmt::Debug for MaterialEntry {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_tuple("MaterialEntry")
            .field(&self.declaration.deck_name)
            .finish()
    }
}

impl PartialEq for MaterialEntry {
    fn eq(&self, other: &Self) -> bool {
        self.declaration == other.declaration
    }
}

/// Every material model this build runs, one line each (in the order decks' error messages
/// list them).
pub static MATERIALS: &[MaterialEntry] = &[
    MaterialEntry::of::<LinearPeridynamicSolid>(),
    MaterialEntry::of::<ElasticPlastic>(),
    MaterialEntry::of::<ElasticPlasticHardening>(),
    MaterialEntry::of::<Viscoelastic>(),
    MaterialEntry::of::<BondBased>(),
    MaterialEntry::of::<MicroplasticBondBased>(),
    MaterialEntry::of::<Pals>(),
    MaterialEntry::of::<LinearLps>(),
    MaterialEntry::of::<ElasticCorrespondence>(),
    MaterialEntry::of::<ElasticPlasticCorrespondence>(),
    MaterialEntry::of::<IsotropicHardeningCorrespondence>(),
    MaterialEntry::of::<ViscoplasticNeedlemanCorrespondence>(),
    MaterialEntry::of::<ElasticHypoelasticCorrespondence>(),
    MaterialEntry::of::<ElasticPlasticHypoelasticCorrespondence>(),
    MaterialEntry::of::<IsotropicHardeningHypoelasticCorrespondence>(),
];

/// The entry of the model called `deck_name` in decks (`Material Model`), if this build runs it.
pub fn material_entry(deck_name: &str) -> Option<&'static MaterialEntry> {
    MATERIALS
        .iter()
        .find(|entry| entry.declaration.deck_name == deck_name)
}

/// Every model a deck may name: those of [`MATERIALS`], then Peridigm's models this build
/// reads but does not run ([`super::unbuilt::UNBUILT_MATERIALS`]).
pub fn deck_models() -> impl Iterator<Item = &'static MaterialEntry> {
    MATERIALS.iter().chain(super::unbuilt::UNBUILT_MATERIALS)
}

/// The model a deck's `Material Model: "name"` means (by its deck name or an alias), built or
/// not.
pub fn deck_model(name: &str) -> Option<&'static MaterialEntry> {
    deck_models().find(|entry| entry.declaration.answers_to(name))
}

/// Every name a deck may give `Material Model`, each model's deck name followed by its
/// aliases.
pub fn deck_model_names() -> Vec<&'static str> {
    deck_models()
        .flat_map(|entry| {
            std::iter::once(entry.declaration.deck_name)
                .chain(entry.declaration.aliases.iter().copied())
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn deck_names_are_unique_and_each_entry_finds_itself() {
        let names = deck_model_names();
        for (k, name) in names.iter().enumerate() {
            assert!(!names[..k].contains(name), "{name} listed twice");
        }
        for entry in MATERIALS {
            let name = entry.deck_name();
            assert!(entry.is_built(), "{name}");
            assert!(std::ptr::eq(material_entry(name).unwrap(), entry));
            assert!(std::ptr::eq(deck_model(name).unwrap(), entry));
        }
        for entry in super::super::unbuilt::UNBUILT_MATERIALS {
            assert!(!entry.is_built());
            assert!(material_entry(entry.deck_name()).is_none());
        }
        assert_eq!(
            deck_model("Elastic Partial Volume").map(MaterialEntry::deck_name),
            Some("Elastic")
        );
        assert!(material_entry("Linear LPS Partial Volume").is_some());
    }
}
