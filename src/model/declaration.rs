//! What a constitutive or damage model declares about itself, so that the rest of the run
//! (rank halos, tangent patterns, `peridyn check`, output catalogues) asks the model's registry
//! entry instead of matching its name.

pub use crate::history::{FieldCarrier, FieldDeclaration};

/// How far the force of a point reaches through the bonds.
///
/// Ordered: [`Reach::OneHop`] < [`Reach::TwoHop`], so the reach of several models is their
/// maximum.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Reach {
    /// The force on a bond depends only on its two ends (bond-based models, damage rules that
    /// test one bond at a time): a rank needs one ghost layer and the tangent couples only
    /// bonded points.
    OneHop,
    /// The force on a bond depends on the whole families of its two ends (state-based models:
    /// the LPS dilatation, a correspondence deformation gradient), which each point publishes
    /// to its neighbours before the force pass: a rank needs two ghost layers and the tangent
    /// couples neighbours of neighbours.
    TwoHop,
}

impl Reach {
    /// Ghost layers a rank needs for a model of this reach (1 or 2).
    pub fn ghost_layers(self) -> usize {
        match self {
            Reach::OneHop => 1,
            Reach::TwoHop => 2,
        }
    }

    /// The tangent pattern's name as `peridyn check` prints it.
    pub fn pattern_name(self) -> &'static str {
        match self {
            Reach::OneHop => "one-hop",
            Reach::TwoHop => "two-hop",
        }
    }
}

/// One deck key of a model, documented once: its model's reader reads it by this name, and the
/// model's page in the user guide lists it in the key table generated from the registry.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct KeyDoc {
    /// The key as written in decks, e.g. `Yield Stress`.
    pub key: &'static str,
    /// What it sets (one line, with the symbol the model's formulas use).
    pub meaning: &'static str,
    /// Its unit: a dimension such as `pressure` or `length`, `—` for a number without one, or
    /// the kind of value (`true/false`, a name).
    pub unit: &'static str,
    /// Its default, or `required`.
    pub default: &'static str,
}

/// How a material model provides the tangent ∂f/∂u of its block.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TangentSupport {
    /// No tangent: the model runs only with explicit solvers.
    None,
    /// A closed form (the default), automatic or finite differences of the same force state.
    Analytic,
    /// Automatic differentiation of the force code (the default) or finite differences; no
    /// closed form.
    Differentiated,
}

impl TangentSupport {
    /// The words the model pages use for it.
    pub fn describe(self) -> &'static str {
        match self {
            TangentSupport::None => "none (explicit solvers only)",
            TangentSupport::Analytic => {
                "analytic (default), automatic differentiation or finite differences"
            }
            TangentSupport::Differentiated => {
                "automatic differentiation (default) or finite differences"
            }
        }
    }
}

/// Everything a model declares besides its constructor: its deck name and keys, its reach,
/// its fields, the output variables it provides and what else it can do.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ModelDeclaration {
    /// Peridigm's model name as written in decks (`Material Model` or `Damage Model`).
    pub deck_name: &'static str,
    /// Other names decks may give the same model (Peridigm's `Elastic Partial Volume` is
    /// `Elastic`).
    pub aliases: &'static [&'static str],
    /// The deck keys the model reads, besides the model name, in the order its page lists
    /// them.
    pub deck_keys: &'static [KeyDoc],
    /// How far the force of a point reaches.
    pub reach: Reach,
    /// The fields the model keeps.
    pub fields: &'static [FieldDeclaration],
    /// The output variables only this kind of model provides (Peridigm's names).
    pub outputs: &'static [&'static str],
    /// How a material computes its tangent ([`TangentSupport::None`] for damage models).
    pub tangent: TangentSupport,
    /// True when the model takes a `Thermal Expansion Coefficient` (thermal strain α ΔT).
    pub thermal_strain: bool,
    /// True for a small-displacement model, linearized about the reference configuration (a
    /// bond's force along its reference direction): a rigid rotation is force free only to
    /// second order in its angle.
    pub small_displacement: bool,
    /// An example of the model's keys as a deck writes them (YAML lines of its list, without
    /// the model's name), in consistent units for a body of unit point spacing and horizon
    /// 1.8: the user guide shows it, and the registry's conformance suite reads it through the
    /// model's reader and builds the model from it. Empty for a model this build does not run.
    pub example: &'static str,
}

impl ModelDeclaration {
    /// The documentation of the deck key `key`, if the model reads it.
    pub fn key(&self, key: &str) -> Option<&'static KeyDoc> {
        self.deck_keys.iter().find(|doc| doc.key == key)
    }

    /// True when decks may call the model `name` (its deck name or an alias).
    pub fn answers_to(&self, name: &str) -> bool {
        self.deck_name == name || self.aliases.contains(&name)
    }
}
