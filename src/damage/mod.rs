//! Bond damage: which bonds still carry force.
//!
//! Bond damage d ∈ [0, 1] is one `f32` per directed bond, indexed like the bond list, and
//! exists only when a block has a damage model (`f32` rather than a bitset because Peridigm's
//! other models — von Mises, Johnson–Cook — ramp d continuously; the benchmark
//! `material_kernels` measures what reading it costs the force loops).
//!
//! Ordering (Peridigm's `Peridigm::computeInternalForce`): the damage update runs **before** the force in every
//! evaluation, so a bond that exceeds its limit carries no force in the same evaluation.
//! Implicit solvers that let bonds broken in an unconverged iterate heal keep a copy of the
//! array at the start of the step and restore it; the models themselves only ever increase d.

// The registry's conformance suite; under a `tests` file name, as every test module, so the
// import-circle check reads it as tests.
#[cfg(test)]
#[path = "conformance/tests.rs"]
mod conformance_tests;
mod critical_stretch;
mod initial_damage;
mod interface_aware;
pub(crate) mod keys;
mod registry;
mod stretch_kernel;
mod time_dependent_critical_stretch;
mod unbuilt;

pub use critical_stretch::{
    critical_stretch_from_energy_release_rate, CriticalStretch, CriticalStretchLimit,
    CriticalStretchParameters,
};
pub use initial_damage::{InitialDamage, InitialDamageParameters};
pub use interface_aware::{rank_deficient_points, InterfaceAware, InterfaceAwareParameters};
pub use registry::{
    damage_entry, deck_damage_model, deck_damage_models, DamageBlock, DamageEntry,
    DamageParameters, BOND_DAMAGE, DAMAGE_MODELS, POINT_CRITICAL_STRETCH,
};
pub(crate) use registry::{DamageBuild, DamageKeys};
pub use time_dependent_critical_stretch::{TimeDependentCriticalStretch, TimeDependentParameters};
pub use unbuilt::{JohnsonCookParameters, VonMisesStressParameters, UNBUILT_DAMAGE_MODELS};

pub(crate) use stretch_kernel::{break_stretched_rows, StretchLimit};

/// `value` if it is a finite number, else the error naming `key`.
fn finite(key: &'static str, value: f64) -> Result<f64, DamageError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(DamageError::NotFinite { key, value })
    }
}

use crate::model::point_chunks::for_each_chunk;
use crate::model::ReferenceView;
use crate::model::{BondList, ModelDeclaration};

/// Invalid damage-model parameters. Messages name the deck key; the deck layer adds the file
/// and line.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DamageError {
    /// A parameter that must be a positive finite number is not.
    #[error("damage model parameter `{key}` must be a positive finite number, got {value}")]
    NotPositive {
        /// Deck key, e.g. `Critical Stretch`.
        key: &'static str,
        /// The offending value.
        value: f64,
    },
    /// A time-dependent parameter could not be evaluated.
    #[error("Time Dependent Critical Stretch at t = {time}: {message}")]
    Expression {
        /// The time of the evaluation.
        time: f64,
        /// What went wrong.
        message: String,
    },
    /// The deck gives a `Thermal Expansion Coefficient` to a model without thermal strain.
    #[error(
        "damage model parameter `Thermal Expansion Coefficient` is not supported by the \
         \"{model}\" damage model; remove the key"
    )]
    ThermalExpansionNotSupported {
        /// The `Damage Model` string.
        model: &'static str,
    },
    /// A parameter that must be a finite number is not.
    #[error("damage model parameter `{key}` must be a finite number, got {value}")]
    NotFinite {
        /// Deck key, e.g. `Thermal Expansion Coefficient`.
        key: &'static str,
        /// The offending value.
        value: f64,
    },
    /// A parameter the model needs was not given.
    #[error("damage model parameter `{key}` is required by this damage model")]
    Missing {
        /// Deck key, e.g. `Critical Stretch`.
        key: &'static str,
    },
}

impl DamageError {
    /// The deck key of the model's list the error is about, when the set-up places it there
    /// rather than at the list (an expression's evaluation, at the expression).
    pub fn key(&self) -> Option<&'static str> {
        match self {
            DamageError::Expression { .. } => Some("Time Dependent Critical Stretch"),
            _ => None,
        }
    }
}

/// A damage model for one block. Object-safe; one instance per block.
pub trait DamageModel: Send + Sync {
    /// What the model declares about itself: the declaration of its registry entry
    /// ([`DAMAGE_MODELS`]).
    fn declaration(&self) -> &'static ModelDeclaration;

    /// Peridigm's `Damage Model` string, e.g. `"Critical Stretch"`.
    fn model_name(&self) -> &'static str {
        self.declaration().deck_name
    }

    /// Sets the time of the next update (models with time-dependent parameters evaluate them
    /// here, once per step). The default does nothing.
    fn set_time(&mut self, _time: f64) -> Result<(), DamageError> {
        Ok(())
    }

    /// Prepares faster updates of the rows of `points` (strictly increasing) of
    /// `reference.bonds`, e.g. a pair-once loop that tests each pair of the block once and
    /// writes both directions. Later [`DamageModel::update`] calls with these points and this
    /// bond list use it and take exactly the same decisions; calls with other points fall back
    /// to the general loop. The default does nothing.
    fn prepare(&mut self, _reference: &ReferenceView<'_>, _points: &[u32]) {}

    /// The critical stretch s_c when this model is exactly the constant `Critical Stretch`
    /// rule (one limit for every bond, nothing else): a bond breaks for good once
    /// `(fl(√q) − ζ)/ζ > s_c`, q = `dx*dx + dy*dy + dz*dz` of `Y_j − Y_i`. A material whose
    /// bond pass already computes q may then take these decisions itself
    /// ([`crate::material::Material::critical_stretch_fast_path`]) instead of this model's separate
    /// pass over the bonds. `None` (the default) keeps the separate pass.
    fn fusable_critical_stretch(&self) -> Option<f64> {
        None
    }

    /// Sets the damage the rows of `points` (strictly increasing) start the run with, in
    /// `bond_damage` (the whole array, intact on entry; only those rows are written). Called
    /// once, before the first force evaluation; `Initial Damage` breaks its pre-crack here.
    /// The default leaves every bond intact.
    fn initialize(
        &self,
        _reference: &ReferenceView<'_>,
        _points: &[u32],
        _bond_damage: &mut [f32],
    ) {
    }

    /// Sets the model's `Thermal Expansion Coefficient` α: the stretch a bond of point i is
    /// tested with becomes `s − α ΔT_i` ([`DamageModel::update_at_temperature`]). The default
    /// refuses it, naming the model.
    fn set_thermal_expansion(&mut self, coefficient: f64) -> Result<(), DamageError> {
        let _ = coefficient;
        Err(DamageError::ThermalExpansionNotSupported {
            model: self.model_name(),
        })
    }

    /// [`DamageModel::update`] in a run with point temperatures: `temperature_change` is ΔT
    /// of every point. A model with a `Thermal Expansion Coefficient` tests `s − α ΔT_i`; the
    /// default (a model without one) ignores the temperature.
    fn update_at_temperature(
        &self,
        reference: &ReferenceView<'_>,
        current_position: &[[f64; 3]],
        temperature_change: &[f64],
        points: &[u32],
        bond_damage: &mut [f32],
    ) -> usize {
        let _ = temperature_change;
        self.update(reference, current_position, points, bond_damage)
    }

    /// Updates the damage of the bonds in the rows of `points` (strictly increasing global
    /// indices) from the current positions `current_position` (all points). `bond_damage` is
    /// the whole array (global bond numbering); only the rows of `points` are written.
    /// Returns the number of bonds that broke in this call.
    fn update(
        &self,
        reference: &ReferenceView<'_>,
        current_position: &[[f64; 3]],
        points: &[u32],
        bond_damage: &mut [f32],
    ) -> usize;
}

/// Peridigm's point `Damage` for stretch-based models: the mean bond damage of the point's
/// family, Σ_j d_ij / n_i (= broken/total bonds for 0/1 damage); 0 for a point without
/// bonds. Writes `damage[i]` for every `i` in `points` (global point numbering).
pub fn point_damage(bonds: &BondList, bond_damage: &[f32], points: &[u32], damage: &mut [f64]) {
    for_each_chunk(
        points,
        damage,
        &|i| i as usize,
        &|chunk: &[u32], base: usize, out: &mut [f64]| {
            for &i in chunk {
                let i = i as usize;
                let row = &bond_damage[bonds.range(i)];
                out[i - base] = if row.is_empty() {
                    0.0
                } else {
                    row.iter().map(|&d| f64::from(d)).sum::<f64>() / row.len() as f64
                };
            }
        },
    );
}
