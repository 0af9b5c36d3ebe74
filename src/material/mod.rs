//! Physics of the bulk material: constitutive models and their shared helpers.
//!
//! # How a material is driven
//! One [`Material`] instance serves one block. After [`Material::setup`] (which stores the
//! block's points and evaluates everything that depends only on the reference configuration:
//! influence weights ω per bond, LPS weighted volume m per point), every force evaluation is
//!
//! 1. damage update (the `damage` module);
//! 2. [`Material::compute_point_coefficients`] of every block (LPS: dilatation θ), then the
//!    per-point numbers are exchanged across ranks;
//! 3. [`Material::add_force_density`] of every block.
//!
//! # Force convention (Peridigm's, `material_utilities.cxx`)
//! The unknown is force density. Peridigm visits each directed bond i→j with the scalar force
//! state t_ij computed from i's state and adds `t_ij M_ij V_j` to F_i and `−t_ij M_ij V_i` to
//! F_j, where `M_ij = (Y_j − Y_i)/|Y_j − Y_i|`. Collecting both visits of a pair at point i
//! gives the gather form used here (each point sums its own row; no atomics):
//!
//! `F_i = Σ_j (t_ij + t_ji) V_j M_ij`.
//!
//! t_ji is evaluated from j's published [`PointCoefficients`], so bonds between blocks of the
//! same model with different constants are exact. The bond list must be symmetric (j in i's
//! family iff i in j's), with the same ω from both ends; bonds between a bond-based and a
//! state-based block would need the two coefficient meanings mixed and are not supported yet.

#[cfg(target_arch = "x86_64")]
mod avx2;
mod block;
mod bond_based;
// The registry's conformance suite; under a `tests` file name, as every test module, so the
// import-circle check reads it as tests.
#[cfg(test)]
#[path = "conformance/tests.rs"]
pub(crate) mod conformance_tests;
mod correspondence;
mod elastic_constants;
mod elastic_plastic;
#[cfg(test)]
pub(crate) mod generic_force;
mod influence;
pub(crate) mod keys;
mod linear_lps;
mod linear_peridynamic_solid;
mod microplastic;
mod pals;
#[cfg(test)]
mod quadrature_tests;
mod registry;
mod shear_correction;
#[cfg(test)]
mod surface_correction_tests;
mod unbuilt;
mod viscoelastic;

pub use block::BlockData;
pub use bond_based::{BondBased, BondBasedParameters};
pub use correspondence::{
    fields as correspondence_fields, CorrespondenceParameters, Flaw, NeedlemanInput,
    NeedlemanParameters, PlasticParameters, CORRESPONDENCE_FIELDS, CORRESPONDENCE_OUTPUTS,
    HYPOELASTIC_DISPLACEMENT, HYPOELASTIC_FIELDS,
};
pub(crate) use correspondence::{
    ElasticCorrespondence, ElasticHypoelasticCorrespondence, ElasticPlasticCorrespondence,
    ElasticPlasticHypoelasticCorrespondence, IsotropicHardeningCorrespondence,
    IsotropicHardeningHypoelasticCorrespondence, ViscoplasticNeedlemanCorrespondence,
};
pub use elastic_constants::{ElasticConstants, ElasticInput, PlanarAssumption};
pub use elastic_plastic::{
    fields as elastic_plastic_fields, yield_value, ElasticPlastic, ElasticPlasticHardening,
    PlasticityInput,
};
pub use influence::{InfluenceFunction, UserInfluence};
pub use linear_lps::{LinearLps, LinearLpsParameters};
pub use linear_peridynamic_solid::{LinearPeridynamicSolid, LinearPeridynamicSolidParameters};
pub use microplastic::{
    fields as microplastic_fields, permanent_stretch, MicroplasticBondBased, MicroplasticParameters,
};
pub use pals::{Multipliers, Pals, PalsInfluence, PalsParameters, MULTIPLIERS};
pub use registry::{
    deck_model, deck_model_names, deck_models, material_entry, BlockInput, MaterialEntry,
    MaterialParameters, MATERIALS,
};
pub(crate) use registry::{MaterialKeys, MaterialModel};
pub use shear_correction::PROBE_SHEAR;
pub use unbuilt::{BondAssociatedParameters, BondAssociatedPlasticity, UNBUILT_MATERIALS};
pub use viscoelastic::{fields as viscoelastic_fields, Viscoelastic, ViscoelasticInput};

use rayon::prelude::*;

use crate::model::{BondList, VolumeRule};
pub use crate::model::{CurrentView, ReferenceView};
#[cfg(doc)]
use crate::model::{ModelDeclaration, Reach};
use crate::tangent::{BlockTangent, TangentError, TangentMethod};

/// Invalid material parameters or reference data. Messages name the deck key; the deck layer
/// adds the file and line.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MaterialError {
    /// A parameter that must be a positive finite number is not.
    #[error("material parameter `{key}` must be a positive finite number, got {value}")]
    NotPositive {
        /// Deck key, e.g. `Density`.
        key: &'static str,
        /// The offending value.
        value: f64,
    },
    /// A parameter that must be a finite number is not.
    #[error("material parameter `{key}` must be a finite number, got {value}")]
    NotFinite {
        /// Deck key, e.g. `Thermal Expansion Coefficient`.
        key: &'static str,
        /// The offending value.
        value: f64,
    },
    /// A parameter that must be a finite number ≥ 0 is not.
    #[error("material parameter `{key}` must be a finite number ≥ 0, got {value}")]
    NotNonNegative {
        /// Deck key, e.g. `Hourglass Coefficient`.
        key: &'static str,
        /// The offending value.
        value: f64,
    },
    /// A point's intact bonds do not span three dimensions, so a correspondence model has no
    /// shape tensor (and no deformation gradient) there.
    #[error(
        "point {point} has a singular shape tensor: its {intact_bonds} intact bond(s) do not \
         span three dimensions (a correspondence model needs at least three non-coplanar \
         bonds); enlarge the horizon or refine the discretization there"
    )]
    SingularShapeTensor {
        /// The point's number in the input (1-based, as in the mesh or text file).
        point: usize,
        /// Its bonds with ω > 0 and no damage.
        intact_bonds: usize,
    },
    /// A parameter that must lie in [0, 1] does not.
    #[error("material parameter `{key}` must be a number in [0, 1], got {value}")]
    NotInUnitInterval {
        /// Deck key, e.g. `lambda_i`.
        key: &'static str,
        /// The offending value.
        value: f64,
    },
    /// A parameter the model needs was not given.
    #[error("material parameter `{key}` is required by this material model")]
    Missing {
        /// Deck key, e.g. `Shear Modulus`.
        key: &'static str,
    },
    /// The model is defined only for ω = 1 and the deck sets another `Influence Function`.
    #[error(
        "material model \"{model}\" is defined only for the influence function \"One\" \
         (ω = 1); remove `Influence Function` from the `Discretization` list"
    )]
    InfluenceNotSupported {
        /// Peridigm's `Material Model` string.
        model: &'static str,
    },
    /// `Actual Horizon` exceeds the block's `Horizon`, which builds the neighbour lists: the
    /// bonds between the two would be missing.
    #[error(
        "material parameter `Actual Horizon` ({actual}) is larger than the block's `Horizon` \
         ({block}); the neighbour lists are built with the block's Horizon, so give an Actual \
         Horizon no larger than it (or enlarge the block's Horizon)"
    )]
    ActualHorizonBeyondHorizon {
        /// `Actual Horizon`.
        actual: f64,
        /// The block's `Horizon`.
        block: f64,
    },
    /// `Gradient Order Of Accuracy` asks for a gradient this build does not compute.
    #[error(
        "material parameter `Gradient Order Of Accuracy` is {order}, but only first-order \
         gradients (1, Peridigm's default) are implemented; remove the key or set it to 1"
    )]
    GradientOrderNotSupported {
        /// The order the deck asks for.
        order: i64,
    },
    /// The model differentiates ω of the current bond length, which a user expression does
    /// not allow.
    #[error(
        "material model \"{model}\" weighs bonds by their current length and differentiates \
         the weight for its tangent, which a user `Influence Function` expression does not \
         allow; use \"One\", \"Parabolic Decay\" or \"Gaussian\""
    )]
    UserInfluenceNotSupported {
        /// Peridigm's `Material Model` string.
        model: &'static str,
    },
    /// A model that evaluates both ends of every bond of its block itself (`Pals`) found a bond
    /// between its block and another block.
    #[error(
        "point {point} is bonded across the boundary of a \"{model}\" block, which needs every \
         bond of its points to stay inside the block; give the bonded points one block or \
         separate the blocks by more than the horizon"
    )]
    BondLeavesBlock {
        /// Peridigm's `Material Model` string.
        model: &'static str,
        /// The point (run index; the set-up renames it by its input number).
        point: usize,
    },
    /// A point's bonds do not determine the influence-function corrections of the model
    /// (`Pals`: a singular 6×6 Lagrange-multiplier system).
    #[error(
        "point {point} has {bonds} bond(s), too few or too regular to fit the \"{model}\" \
         influence functions (the Lagrange-multiplier system is singular); enlarge the horizon \
         or refine the discretization there"
    )]
    SingularInfluenceSystem {
        /// Peridigm's `Material Model` string.
        model: &'static str,
        /// The point (run index; the set-up renames it by its input number).
        point: usize,
        /// Its number of bonds.
        bonds: usize,
    },
    /// The deck gives a `Thermal Expansion Coefficient` to a model without thermal strain.
    #[error(
        "material parameter `Thermal Expansion Coefficient` is not supported by the \"{model}\" \
         material model (Peridigm applies thermal strain only to \"Elastic\" and \"Elastic \
         Correspondence\"); remove the key or choose one of those models"
    )]
    ThermalExpansionNotSupported {
        /// The `Material Model` string.
        model: &'static str,
    },
    /// The influence function gave a negative or non-finite weight.
    #[error(
        "the `Influence Function` gives ω = {value} for bond length ζ = {zeta} with horizon \
         {horizon}; it must be finite and ≥ 0 for every bond in the family"
    )]
    InvalidInfluence {
        /// Reference bond length ζ.
        zeta: f64,
        /// Horizon δ.
        horizon: f64,
        /// ω(ζ, δ).
        value: f64,
    },
}

/// Checks that a deck parameter is positive and finite.
pub(crate) fn positive(key: &'static str, value: f64) -> Result<f64, MaterialError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(MaterialError::NotPositive { key, value })
    }
}

/// Checks that a deck parameter is a finite number.
pub(crate) fn finite(key: &'static str, value: f64) -> Result<f64, MaterialError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(MaterialError::NotFinite { key, value })
    }
}

/// `method` if a material with an analytic tangent can use it: the finite-difference probe,
/// when given, must be a positive finite number.
pub(crate) fn checked_tangent_method(method: TangentMethod) -> Result<TangentMethod, TangentError> {
    match method {
        TangentMethod::FiniteDifference { probe: Some(value) }
            if !(value.is_finite() && value > 0.0) =>
        {
            Err(TangentError::InvalidProbe { value })
        }
        _ => Ok(method),
    }
}

/// `method` for a material whose tangent is differentiated from its force code (automatic or
/// finite differences): `Analytic` is refused naming `model`, the probe is checked as in
/// [`checked_tangent_method`].
pub(crate) fn checked_differentiated_tangent_method(
    model: &'static str,
    method: TangentMethod,
) -> Result<TangentMethod, TangentError> {
    if method == TangentMethod::Analytic {
        return Err(TangentError::NoAnalytic { model });
    }
    checked_tangent_method(method)
}

/// Numbers a material publishes for each of its points before the force pass, so that the
/// force pass of the point's neighbours (in any block, on any rank) can evaluate the bond force
/// from this point's side.
///
/// Scalar force state on a bond i→j with extension e = |Y| − ζ, damage d and weight ω:
/// * state-based (LPS): `t_ij = (1−d)·ω·[isotropic_i·ζ + (1−d)·deviatoric_i·e]` with
///   `isotropic = (3K − 5μ)θ/m`, `deviatoric = 15μ/m`;
/// * bond-based (PMB): `t_ij = isotropic_i·(1−d)·e/ζ` with `isotropic = c/2`
///   (half the micromodulus, because each pair is visited from both ends);
/// * `Pals`: `t_ij = (1−d)·[isotropic_i·ω_ij·ζ + deviatoric_i·σ_ij·(e − θ_i ζ/3)]` with
///   `isotropic = p` (its pressure) and `deviatoric = 2μ`, ω and σ the point's own per-bond
///   influence functions.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PointCoefficients {
    /// Dilatation θ (dimensionless); 0 for bond-based materials.
    pub dilatation: f64,
    /// Coefficient of the isotropic part (see the type's docs).
    pub isotropic: f64,
    /// Coefficient of the deviatoric part (see the type's docs); 0 for bond-based materials.
    pub deviatoric: f64,
}

/// A constitutive model for one block. Object-safe: the run holds `Box<dyn Material>` per
/// block; the bond loops inside are monomorphized (no virtual call per bond).
///
/// The core every model writes: its [`BlockData`], its reference-configuration set-up, its
/// passes (coefficients, force, stored energy) and, with history, the history update. What
/// only some models can do is a capability they return: [`Material::tangent`],
/// [`Material::outputs`], [`Material::critical_stretch_fast_path`]; thermal strain is declared
/// ([`ModelDeclaration::thermal_strain`]) and its α kept in the block data. The accessors every
/// model shares (ρ, K, δ, points, tangent method, …) are written once over the block data
/// (`impl dyn Material`, in `block.rs`).
///
/// Every per-point slice argument is indexed by global point index and every per-bond slice by
/// global bond index; a material reads all points but writes only the entries of its own.
pub trait Material: Send + Sync {
    /// The block's shared data.
    fn block(&self) -> &BlockData;

    /// The block's shared data, for the set-up.
    fn block_mut(&mut self) -> &mut BlockData;

    /// Evaluates everything that depends only on the reference configuration for the block's
    /// points ([`BlockData::points`], stored by `setup` just before): influence weights ω per
    /// bond, LPS weighted volume m per point, and the like. Fails on reference data the model
    /// cannot use (a singular shape tensor, a bond leaving a closed block).
    fn prepare(&mut self, reference: &ReferenceView<'_>) -> Result<(), MaterialError>;

    /// The points' 0-based numbers in the input (indexed by run order), given before the
    /// set-up. A model whose reference-configuration sums must round as Peridigm's, which adds
    /// a family in input order, keeps them (`Pals`); the default ignores them.
    fn input_numbering(&mut self, original_id: &[u32]) {
        let _ = original_id;
    }

    /// Advances the block's history fields ([`crate::history::History`]) to the configuration
    /// `current` (positions and bond damage; its `history` is empty here): reads their
    /// committed values (the start of the step) and writes their trial values. Runs in every
    /// force evaluation before [`Material::compute_point_coefficients`]; the force pass and
    /// the tangent then read the trial values through [`CurrentView::history`]. Materials
    /// without history (the default) do nothing.
    fn update_history(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        history: &mut crate::history::History,
    ) {
        let _ = (reference, current, history);
    }

    /// Writes the [`PointCoefficients`] of the block's points into `coefficients`.
    fn compute_point_coefficients(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        coefficients: &mut [PointCoefficients],
    );

    /// Adds the internal force density F_i (force/length³) of every block point to
    /// `force_density`, reading the neighbours' `coefficients` (all points, filled by their
    /// blocks' [`Material::compute_point_coefficients`]).
    fn add_force_density(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        coefficients: &[PointCoefficients],
        force_density: &mut [[f64; 3]],
    );

    /// Writes the stored elastic energy density W_i (energy/length³) of every block point
    /// (Peridigm's `Stored_Elastic_Energy_Density`; `Stored_Elastic_Energy` is W_i·V_i).
    fn stored_energy_density(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        coefficients: &[PointCoefficients],
        energy_density: &mut [f64],
    );

    /// The model's tangent, when it has one (its kind is declared,
    /// [`ModelDeclaration::tangent`]); `None` (the default): explicit solvers only.
    fn tangent(&self) -> Option<&dyn MaterialTangent> {
        None
    }

    /// The outputs the model computes itself beyond force and energy (weighted volume,
    /// partial stress, hourglass force, its own point fields); `None` (the default): none.
    fn outputs(&self) -> Option<&dyn MaterialOutputs> {
        None
    }

    /// The material's fast path for a constant critical stretch, when it has one for this
    /// block: the pass in which it can take the decisions of a constant critical stretch
    /// ([`crate::damage::DamageModel::fusable_critical_stretch`]) itself, saving the damage
    /// model's own pass over the bonds. [`crate::physics::Physics`] takes it only for a block
    /// without bonds to another block (their damage is made symmetric between the damage
    /// update and the bond passes); a material may ask more. Default `None`: the separate
    /// damage pass.
    fn critical_stretch_fast_path(&self) -> Option<CriticalStretchFastPath<'_>> {
        None
    }
}

/// The tangent of a material model (a capability: [`Material::tangent`]).
pub trait MaterialTangent: Send + Sync {
    /// Adds the tangent contribution of the force states of the block's points,
    /// `∂(V f)/∂u` at `current` with its bond damage held fixed, to `tangent`, computed by
    /// `method` (see [`crate::tangent`]). The pattern must hold every pair of points sharing
    /// a family of a block point (one hop suffices for a model of reach [`Reach::OneHop`]).
    fn add_tangent(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        method: TangentMethod,
        tangent: &mut BlockTangent,
    ) -> Result<(), TangentError>;
}

/// The outputs a material model computes itself (a capability: [`Material::outputs`]); each
/// method's default is "not provided".
pub trait MaterialOutputs: Send + Sync {
    /// Weighted volume m of each block point in the order of [`BlockData::points`]
    /// (Peridigm's `Weighted_Volume`), for state-based models.
    fn weighted_volume(&self) -> Option<&[f64]> {
        None
    }

    /// The values of the point output `name` (a name of the declaration's `outputs` that the
    /// model keeps itself, e.g. `Pals`' `Lagrange_Multiplier_Dilatation_1`) for each block
    /// point in the order of [`BlockData::points`]; `None` for names the model does not
    /// provide this way.
    fn point_output(&self, name: &str) -> Option<Vec<f64>> {
        let _ = name;
        None
    }

    /// Writes Peridigm's `Partial_Stress` of the block's points into `out` (row-major,
    /// pressure): `Σ_j T_ij ⊗ ξ_ij V_j`, T_ij the force state of the bond from the point's own
    /// side (force/length⁶), as Peridigm's `Elastic` sums it. The default leaves `out` as it
    /// is.
    fn partial_stress(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        out: &mut [[f64; 9]],
    ) {
        let _ = (reference, current, out);
    }

    /// Adds the hourglass-control part of the force density of the block's points
    /// (Peridigm's `Hourglass_Force_Density`) to `out`; the default adds nothing.
    fn add_hourglass_force_density(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        out: &mut [[f64; 3]],
    ) {
        let _ = (reference, current, out);
    }
}

/// Where a material folds the constant critical-stretch test into its own bond passes
/// ([`Material::critical_stretch_fast_path`]). Either way every intact bond of the block whose
/// stretch exceeds the critical stretch breaks (d = 1) just before its bond is first used,
/// with exactly the decisions of the separate `Critical Stretch` update, and the results are
/// bitwise those of the update followed by the ordinary passes.
#[derive(Clone, Copy)]
pub enum CriticalStretchFastPath<'a> {
    /// A state-based material breaks its bonds in its point-coefficient (dilatation) pass.
    PointCoefficients(&'a dyn BreakingCoefficientPass),
    /// A bond-based material (no coefficient pass) breaks its bonds in its force pass.
    Force(&'a dyn BreakingForcePass),
}

/// [`Material::compute_point_coefficients`] with the critical-stretch test folded in.
pub trait BreakingCoefficientPass: Send + Sync {
    /// Writes the block's [`PointCoefficients`] as the separate damage update followed by
    /// [`Material::compute_point_coefficients`] would (bitwise), breaking every intact bond
    /// whose stretch exceeds `critical_stretch` in `bond_damage` (all bonds, global
    /// numbering). Returns the directed bonds broken.
    fn compute_point_coefficients_breaking_bonds(
        &self,
        reference: &ReferenceView<'_>,
        position: &[[f64; 3]],
        critical_stretch: f64,
        bond_damage: &mut [f32],
        coefficients: &mut [PointCoefficients],
    ) -> usize;
}

/// [`Material::add_force_density`] with the critical-stretch test folded in.
pub trait BreakingForcePass: Send + Sync {
    /// Adds the block's force density as the separate damage update followed by
    /// [`Material::add_force_density`] would (bitwise), breaking every intact bond whose
    /// stretch exceeds `critical_stretch` in `bond_damage`. Returns the directed bonds broken.
    fn add_force_density_breaking_bonds(
        &self,
        reference: &ReferenceView<'_>,
        position: &[[f64; 3]],
        critical_stretch: f64,
        bond_damage: &mut [f32],
        coefficients: &[PointCoefficients],
        force_density: &mut [[f64; 3]],
    ) -> usize;
}

/// The value of π in Peridigm's critical-time-step formula (`Peridigm_CriticalTimeStep.cpp`).
pub const PERIDIGM_PI: f64 = std::f64::consts::PI;

/// Peridigm's stable time step estimate (`Peridigm_CriticalTimeStep.cpp`), the
/// Silling–Askari bond-based bound applied to every material:
///
/// `Δt_i = sqrt(2ρ / Σ_j V_j c/ζ_ij)` with `c = 18K/(πδ⁴)`, and `Δt = min_i Δt_i`.
///
/// Peridigm gives points without neighbours Δt_i = 1e50 ("no bound"); here they are skipped,
/// and `None` means that no point of the set has a neighbour (no bound at all). The caller
/// takes the minimum over blocks (and ranks) and applies the `Safety Factor`.
pub fn critical_time_step(
    reference: &ReferenceView<'_>,
    points: &[u32],
    density: f64,
    bulk_modulus: f64,
    horizon: f64,
) -> Option<f64> {
    // Peridigm evaluates c = 18K/(3.14159265·δ·δ·δ·δ) with π cut to 9 digits, in this order;
    // decks with a `Safety Factor` get the time step from this number, and Peridigm's gold
    // files compare times to 1e-14, so the same value is computed here.
    let micromodulus = 18.0 * bulk_modulus / (PERIDIGM_PI * horizon * horizon * horizon * horizon);
    let bonds = reference.bonds;
    points
        .par_iter()
        .filter_map(|&i| {
            let range = bonds.range(i as usize);
            if range.is_empty() {
                return None;
            }
            let stiffness: f64 = range
                .map(|b| {
                    reference.neighbor_volume(b, bonds.neighbor[b] as usize) * micromodulus
                        / bonds.reference_length[b]
                })
                .sum();
            Some((2.0 * density / stiffness).sqrt())
        })
        .reduce_with(f64::min)
}

/// Per-bond ω inside the bond loops: either 1 (nothing stored) or a stored block-local array.
pub(crate) trait BondWeights: Copy + Send + Sync {
    /// ω of block-local bond `local`.
    fn weight(self, local: usize) -> f64;
}

/// ω = 1 for every bond (`Influence Function: One`).
#[derive(Clone, Copy)]
pub(crate) struct UnitWeights;

impl BondWeights for UnitWeights {
    #[inline(always)]
    fn weight(self, _local: usize) -> f64 {
        1.0
    }
}

/// ω stored per bond, block-local numbering.
#[derive(Clone, Copy)]
pub(crate) struct StoredWeights<'a>(pub &'a [f64]);

impl BondWeights for StoredWeights<'_> {
    #[inline(always)]
    fn weight(self, local: usize) -> f64 {
        self.0[local]
    }
}

/// 1 − d of a bond inside the bond loops: all intact (no damage model) or read from the array.
pub(crate) trait Integrity: Copy + Send + Sync {
    /// 1 − d of global bond `bond`.
    fn intact(self, bond: usize) -> f64;

    /// True when [`Integrity::intact_unchecked`] may read every bond below `bonds` (checked
    /// once, so that the bonds of a loop need no check each).
    fn covers(self, bonds: usize) -> bool;

    /// [`Integrity::intact`] without a bounds check.
    ///
    /// # Safety
    /// `bond < bonds` for some `bonds` with `self.covers(bonds)`.
    #[inline(always)]
    unsafe fn intact_unchecked(self, bond: usize) -> f64 {
        self.intact(bond)
    }
}

/// No damage model: every bond intact.
#[derive(Clone, Copy)]
pub(crate) struct Undamaged;

impl Integrity for Undamaged {
    #[inline(always)]
    fn intact(self, _bond: usize) -> f64 {
        1.0
    }

    #[inline(always)]
    fn covers(self, _bonds: usize) -> bool {
        true
    }
}

/// Bond damage array (global bond numbering).
#[derive(Clone, Copy)]
pub(crate) struct Damaged<'a>(pub &'a [f32]);

impl Integrity for Damaged<'_> {
    #[inline(always)]
    fn intact(self, bond: usize) -> f64 {
        1.0 - f64::from(self.0[bond])
    }

    #[inline(always)]
    fn covers(self, bonds: usize) -> bool {
        bonds <= self.0.len()
    }

    #[inline(always)]
    unsafe fn intact_unchecked(self, bond: usize) -> f64 {
        // SAFETY: bond < bonds <= len (the caller's `covers`).
        1.0 - f64::from(unsafe { *self.0.get_unchecked(bond) })
    }
}

/// A constant critical stretch tested inside a material's bond loop (PMB's closed-block force
/// loop, LPS's dilatation pass), with the bond-damage array the loop both reads (as its
/// [`Integrity`]) and writes, through one pointer. Each material's breaking trait states which
/// entries a task may touch; tasks touch disjoint entries, which is what makes sharing the
/// pointer across threads sound.
#[derive(Clone, Copy)]
pub(crate) struct FusedCriticalStretch {
    /// The critical stretch test.
    pub(crate) limit: crate::damage::StretchLimit,
    /// The bond-damage array (global bond numbering).
    pub(crate) damage: *mut f32,
}

// SAFETY: tasks only touch disjoint entries through the pointer (the contract of the
// material's breaking trait).
unsafe impl Send for FusedCriticalStretch {}
unsafe impl Sync for FusedCriticalStretch {}

impl FusedCriticalStretch {
    /// d of bond `b`.
    ///
    /// # Safety
    /// No other task writes entry `b` meanwhile, and `b` is a bond of the array.
    #[inline(always)]
    pub(crate) unsafe fn read(self, b: usize) -> f32 {
        // SAFETY: as the caller guarantees.
        unsafe { *self.damage.add(b) }
    }

    /// Sets d = 1 on bond `b`; returns whether it was intact or partly damaged before.
    ///
    /// # Safety
    /// No other task reads or writes entry `b` meanwhile, and `b` is a bond of the array.
    #[inline(always)]
    pub(crate) unsafe fn break_bond(self, b: usize) -> bool {
        // SAFETY: as the caller guarantees.
        unsafe {
            let entry = self.damage.add(b);
            let changed = *entry < 1.0;
            *entry = 1.0;
            changed
        }
    }
}

impl Integrity for FusedCriticalStretch {
    #[inline(always)]
    fn intact(self, bond: usize) -> f64 {
        // SAFETY: the bond loops read only entries of their own task's bonds, which no other
        // task writes (the breaking traits' contracts); the pointer covers every bond.
        1.0 - f64::from(unsafe { self.read(bond) })
    }

    /// Always: the pointer covers every bond (and [`Integrity::intact`] has no check).
    #[inline(always)]
    fn covers(self, _bonds: usize) -> bool {
        true
    }
}

/// The number of points the bond loops may gather from without a check per bond: `points`
/// (the length of the per-point arrays they index) or fewer, as far as the volume rule covers
/// ([`VolumeRule::covered_points`]). Panics unless the per-bond arrays (reference lengths,
/// damage: [`Integrity::covers`]) cover the whole bond list. Checked once per call.
#[inline(always)]
pub(crate) fn gather_bound<V: VolumeRule, D: Integrity>(
    bonds: &BondList,
    points: usize,
    volume: V,
    damage: D,
) -> usize {
    let all = bonds.neighbor.len();
    assert!(
        all <= bonds.reference_length.len() && damage.covers(all),
        "bond arrays shorter than the bond list"
    );
    points.min(volume.covered_points(all))
}

/// The neighbours and reference lengths of the bonds `range`, after checking once that every
/// neighbour is a point below `points` (a maximum over the row, which vectorizes), so that
/// the bonds of the row may index the per-point arrays without a check each.
#[inline(always)]
pub(crate) fn checked_row(
    bonds: &BondList,
    range: std::ops::Range<usize>,
    points: usize,
) -> (&[u32], &[f64]) {
    let neighbors = &bonds.neighbor[range.clone()];
    let highest = neighbors.iter().fold(0, |m, &j| m.max(j));
    assert!(
        neighbors.is_empty() || (highest as usize) < points,
        "neighbour index out of range"
    );
    (neighbors, &bonds.reference_length[range])
}

/// The points of `points` for which `keep` is true, or `None` when that is all of them
/// ([`Material::restrict_forces`]).
pub(crate) fn kept_points(points: &[u32], keep: &dyn Fn(u32) -> bool) -> Option<Vec<u32>> {
    let kept: Vec<u32> = points.iter().copied().filter(|&p| keep(p)).collect();
    (kept.len() < points.len()).then_some(kept)
}

/// Block-local bond offsets: `local[k]` is where point `points[k]`'s row starts in arrays
/// that store only the block's bonds (length `points.len() + 1`).
pub(crate) fn local_offsets(bonds: &BondList, points: &[u32]) -> Vec<usize> {
    let mut offsets = Vec::with_capacity(points.len() + 1);
    let mut total = 0;
    offsets.push(0);
    for &i in points {
        total += bonds.family_size(i as usize);
        offsets.push(total);
    }
    offsets
}

/// The weighted volume m_i = Σ_j ω_ij ζ_ij² w_ij of each of `points` (length⁵; reference
/// configuration, no damage; Silling et al. 2007, eq. 88), with w_ij the bond's quadrature
/// volume and ω the block-local influence `weights` indexed through `local_offsets`
/// ([`local_offsets`]), or ω ≡ 1 when `weights` is `None`. The m of the LPS-family models.
pub(crate) fn influence_weighted_volumes(
    reference: &ReferenceView<'_>,
    points: &[u32],
    local_offsets: &[usize],
    weights: Option<&[f64]>,
) -> Vec<f64> {
    let bonds = reference.bonds;
    points
        .iter()
        .zip(local_offsets)
        .map(|(&i, &local)| {
            bonds
                .range(i as usize)
                .enumerate()
                .map(|(n, b)| {
                    let omega = weights.map_or(1.0, |w| w[local + n]);
                    let zeta = bonds.reference_length[b];
                    omega * zeta * zeta * reference.neighbor_volume(b, bonds.neighbor[b] as usize)
                })
                .sum()
        })
        .collect()
}

/// Panics unless `points` is a strictly increasing list of valid point indices (an internal
/// invariant of the block set-up, not user input).
pub(crate) fn assert_point_set(points: &[u32], num_points: usize) {
    assert!(
        points.windows(2).all(|w| w[0] < w[1]),
        "a block's points must be strictly increasing"
    );
    if let Some(&last) = points.last() {
        assert!(
            (last as usize) < num_points,
            "block point {last} is outside the {num_points} points"
        );
    }
}

/// A concrete material or a boxed one, as the tests hold them.
#[cfg(test)]
pub(crate) trait AsMaterial {
    /// The material as a trait object.
    fn as_material(&mut self) -> &mut dyn Material;
}

#[cfg(test)]
impl<M: Material> AsMaterial for M {
    fn as_material(&mut self) -> &mut dyn Material {
        self
    }
}

#[cfg(test)]
impl AsMaterial for Box<dyn Material> {
    fn as_material(&mut self) -> &mut dyn Material {
        &mut **self
    }
}

/// Sets up `material` on `points` (tests of concrete models reach the shared set-up of
/// `dyn Material` through this).
#[cfg(test)]
pub(crate) fn set_up(
    material: &mut impl AsMaterial,
    reference: &ReferenceView<'_>,
    points: Vec<u32>,
) {
    material
        .as_material()
        .setup(reference, points)
        .expect("the test's body sets up");
}

#[cfg(test)]
mod tests;
// Thermal-strain tests of several models (LPS, correspondence, the refusals); under a `tests`
// file name, as every test module, so the import-circle check reads them as tests.
#[cfg(test)]
#[path = "thermal/tests.rs"]
mod thermal_tests;
