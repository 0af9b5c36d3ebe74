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

/// Everything a model declares besides its constructor: its deck name and keys, its reach,
/// its fields and the output variables it provides.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ModelDeclaration {
    /// Peridigm's model name as written in decks (`Material Model` or `Damage Model`).
    pub deck_name: &'static str,
    /// The deck keys the model reads, besides the model name (documentation and `check`).
    pub deck_keys: &'static [&'static str],
    /// How far the force of a point reaches.
    pub reach: Reach,
    /// The fields the model keeps.
    pub fields: &'static [FieldDeclaration],
    /// The output variables only this kind of model provides (Peridigm's names).
    pub outputs: &'static [&'static str],
}
