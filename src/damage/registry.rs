//! The one list of the damage models this build runs (see `material::MATERIALS` for the
//! material models): each entry pairs a model's declaration with its constructor.

use std::sync::Arc;

use super::{
    CriticalStretch, DamageError, DamageModel, InitialDamage, InterfaceAware,
    TimeDependentCriticalStretch,
};
use crate::expression::Expression;
use crate::model::{FieldCarrier, FieldDeclaration, ModelDeclaration};
use crate::neighbors::BondFilter;

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

/// The deck values every constructor may read, resolved by the builder for one block.
#[derive(Debug, Clone, Default)]
pub struct DamageInput {
    /// The block's constant critical stretch s_c: `Critical Stretch`, or derived from
    /// `Critical Energy Release Rate` with the block's bulk modulus and horizon.
    pub critical_stretch: Option<f64>,
    /// `Time Dependent Critical Stretch` s_c(t), compiled (an expression in `t`).
    pub critical_stretch_in_time: Option<Expression>,
    /// The time of the first step (where s_c(t) is first evaluated).
    pub initial_time: f64,
    /// The [`POINT_CRITICAL_STRETCH`] field, when the model declares it.
    pub point_critical_stretch: Option<Arc<[f64]>>,
    /// The `Bond Filters` of `Initial Damage`, as geometry (shell meshes already read).
    pub bond_filters: Vec<BondFilter>,
}

impl DamageInput {
    fn required<T: Clone>(value: &Option<T>, key: &'static str) -> Result<T, DamageError> {
        value.clone().ok_or(DamageError::Missing { key })
    }
}

/// Builds a damage model for one block from the resolved deck values.
pub type DamageConstructor = fn(&DamageInput) -> Result<Box<dyn DamageModel>, DamageError>;

/// One damage model of this build.
#[derive(Debug, Clone, Copy)]
pub struct DamageEntry {
    /// What the model declares about itself.
    pub declaration: &'static ModelDeclaration,
    /// Its constructor.
    pub build: DamageConstructor,
}

fn critical_stretch(input: &DamageInput) -> Result<Box<dyn DamageModel>, DamageError> {
    let s_c = DamageInput::required(&input.critical_stretch, "Critical Stretch")?;
    Ok(Box::new(CriticalStretch::new(s_c)?))
}

fn time_dependent_critical_stretch(
    input: &DamageInput,
) -> Result<Box<dyn DamageModel>, DamageError> {
    let expression = DamageInput::required(
        &input.critical_stretch_in_time,
        "Time Dependent Critical Stretch",
    )?;
    Ok(Box::new(TimeDependentCriticalStretch::new(
        expression,
        input.initial_time,
    )?))
}

fn interface_aware(input: &DamageInput) -> Result<Box<dyn DamageModel>, DamageError> {
    let s_c = DamageInput::required(&input.critical_stretch, "Critical Stretch")?;
    let field = DamageInput::required(&input.point_critical_stretch, "Critical Stretch")?;
    Ok(Box::new(InterfaceAware::new(s_c, field)?))
}

fn initial_damage(input: &DamageInput) -> Result<Box<dyn DamageModel>, DamageError> {
    if input.bond_filters.is_empty() {
        return Err(DamageError::Missing {
            key: "Bond Filters",
        });
    }
    Ok(Box::new(InitialDamage::new(input.bond_filters.clone())))
}

/// Every damage model this build runs, one entry each.
pub static DAMAGE_MODELS: &[DamageEntry] = &[
    DamageEntry {
        declaration: &CriticalStretch::DECLARATION,
        build: critical_stretch,
    },
    DamageEntry {
        declaration: &TimeDependentCriticalStretch::DECLARATION,
        build: time_dependent_critical_stretch,
    },
    DamageEntry {
        declaration: &InterfaceAware::DECLARATION,
        build: interface_aware,
    },
    DamageEntry {
        declaration: &InitialDamage::DECLARATION,
        build: initial_damage,
    },
];

/// The entry of the model called `deck_name` in decks (`Damage Model`), if this build runs it.
pub fn damage_entry(deck_name: &str) -> Option<&'static DamageEntry> {
    DAMAGE_MODELS
        .iter()
        .find(|entry| entry.declaration.deck_name == deck_name)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn deck_names_are_unique_and_every_model_keeps_bond_damage() {
        for (k, entry) in DAMAGE_MODELS.iter().enumerate() {
            let name = entry.declaration.deck_name;
            assert!(
                DAMAGE_MODELS[..k]
                    .iter()
                    .all(|other| other.declaration.deck_name != name),
                "{name} listed twice"
            );
            assert!(entry.declaration.fields.contains(&BOND_DAMAGE), "{name}");
            assert!(std::ptr::eq(damage_entry(name).unwrap(), entry));
        }
        assert!(damage_entry("Johnson Cook").is_none());
    }

    #[test]
    fn constructors_build_their_model_and_name_a_missing_parameter() {
        let input = DamageInput {
            critical_stretch: Some(0.01),
            point_critical_stretch: Some(Arc::from(vec![0.01; 2])),
            ..DamageInput::default()
        };
        for name in ["Critical Stretch", "Interface Aware"] {
            let model = (damage_entry(name).unwrap().build)(&input).unwrap();
            assert_eq!(model.model_name(), name);
            assert_eq!(model.declaration().deck_name, name);
        }
        let error = (damage_entry("Time Dependent Critical Stretch")
            .unwrap()
            .build)(&input)
        .err();
        assert_eq!(
            error.map(|e| e.to_string()),
            Some(
                "damage model parameter `Time Dependent Critical Stretch` is required by this \
                 damage model"
                    .to_string()
            )
        );
        // Initial Damage needs its bond filters.
        let error = (damage_entry("Initial Damage").unwrap().build)(&input).err();
        assert_eq!(
            error.map(|e| e.to_string()),
            Some("damage model parameter `Bond Filters` is required by this damage model".into())
        );
    }
}
