//! What a constitutive or damage model declares about itself, so that the rest of the run
//! (rank halos, tangent patterns, `peridyn check`, output catalogues) asks the model's registry
//! entry instead of matching its name.

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

/// What a field of a model is attached to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FieldCarrier {
    /// One value per point.
    Point,
    /// One value per directed bond, indexed like the bond list.
    Bond,
}

impl FieldCarrier {
    /// The word `peridyn check` prints for the carrier.
    pub fn name(self) -> &'static str {
        match self {
            FieldCarrier::Point => "point",
            FieldCarrier::Bond => "bond",
        }
    }
}

/// A field a model keeps between force evaluations.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FieldDeclaration {
    /// The field's name (Peridigm's, where it has one), e.g. `Weighted_Volume`.
    pub name: &'static str,
    /// Point or bond field.
    pub carrier: FieldCarrier,
    /// Bytes of one value (8 for `f64`, 4 for `f32`).
    pub bytes_per_value: u64,
    /// True when the field evolves with the deformation and is staged: a trial value during a
    /// load step, committed on acceptance and restored on rejection (bond damage). False for
    /// fields fixed by the reference configuration or recomputed from the current one in every
    /// evaluation (LPS weighted volume and dilatation).
    pub staged: bool,
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
