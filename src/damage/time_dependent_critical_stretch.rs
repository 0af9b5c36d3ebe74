//! Peridigm's `Time Dependent Critical Stretch`: critical stretch s_c(t) from an expression.

use super::keys::THERMAL_EXPANSION;
use super::registry::BOND_DAMAGE;
use super::{
    CriticalStretch, DamageBlock, DamageBuild, DamageError, DamageKeys, DamageModel,
    DamageParameters,
};
use crate::expression::{Expression, TIME};
use crate::model::ReferenceView;
use crate::model::{KeyDoc, ModelDeclaration, Reach, TangentSupport};
use crate::parameter_list::error::DeckError;
use crate::parameter_list::reader::{Ctx, ListReader};

/// `Time Dependent Critical Stretch`.
const TIME_DEPENDENT_CRITICAL_STRETCH: KeyDoc = KeyDoc {
    key: "Time Dependent Critical Stretch",
    meaning: "s_c(t), an expression in t evaluated once per step",
    unit: "an expression",
    default: "required",
};

/// The deck parameters of `Time Dependent Critical Stretch`.
#[derive(Debug, Clone, PartialEq)]
pub struct TimeDependentParameters {
    /// `Time Dependent Critical Stretch`: an expression in `t` (checked when read).
    pub critical_stretch: String,
    /// `Thermal Expansion Coefficient` α; default none.
    pub thermal_expansion_coefficient: Option<f64>,
}

impl DamageParameters for TimeDependentParameters {}

/// Critical stretch as a function of time, e.g. `if(t < 7e-5) { value = 50; } else { value =
/// 0.015; }` (Peridigm's `BondBreakingInitialVelocity_TimeDependentCS`). The expression (in
/// `t`) is evaluated once per time step, before the damage update; otherwise the model is
/// [`CriticalStretch`] with the current value.
#[derive(Debug, Clone)]
pub struct TimeDependentCriticalStretch {
    expression: Expression,
    current: CriticalStretch,
}

impl DamageKeys for TimeDependentCriticalStretch {
    type Parameters = TimeDependentParameters;

    /// `Time Dependent Critical Stretch`: as `Critical Stretch`, one bond at a time: one hop.
    const DECLARATION: ModelDeclaration = ModelDeclaration {
        deck_name: "Time Dependent Critical Stretch",
        aliases: &[],
        deck_keys: &[TIME_DEPENDENT_CRITICAL_STRETCH, THERMAL_EXPANSION],
        reach: Reach::OneHop,
        fields: &[BOND_DAMAGE],
        outputs: &["Damage"],
        tangent: TangentSupport::None,
        thermal_strain: true,
        small_displacement: false,
        example: "Time Dependent Critical Stretch: \"if(t < 0.5) { value = 0.02; } else { value = 0.01; }\"",
    };

    /// The expression, parsed here so that a typo is named at its line when the deck loads.
    fn read(ctx: &mut Ctx, list: &mut ListReader) -> Result<TimeDependentParameters, DeckError> {
        let field = list.require(
            ctx,
            TIME_DEPENDENT_CRITICAL_STRETCH.key,
            "an expression in t",
        )?;
        let critical_stretch = field.name(ctx)?;
        Expression::parse(&critical_stretch, TIME).map_err(|e| field.err(ctx, e.to_string()))?;
        Ok(TimeDependentParameters {
            critical_stretch,
            thermal_expansion_coefficient: list.f64_opt(ctx, THERMAL_EXPANSION.key)?,
        })
    }
}

impl DamageBuild for TimeDependentCriticalStretch {
    fn build(
        block: &DamageBlock,
        parameters: &TimeDependentParameters,
    ) -> Result<Box<dyn DamageModel>, DamageError> {
        let expression = Expression::parse(&parameters.critical_stretch, TIME).map_err(|e| {
            DamageError::Expression {
                time: block.initial_time,
                message: e.to_string(),
            }
        })?;
        let mut model = Self::new(expression, block.initial_time)?;
        if let Some(alpha) = parameters.thermal_expansion_coefficient {
            model.set_thermal_expansion(alpha)?;
        }
        Ok(Box::new(model))
    }
}

impl TimeDependentCriticalStretch {
    /// The model at time `t0`; errors when s_c(t0) is not a positive number.
    pub fn new(expression: Expression, t0: f64) -> Result<Self, DamageError> {
        let current = Self::evaluate(&expression, t0)?;
        Ok(Self {
            expression,
            current,
        })
    }

    fn evaluate(expression: &Expression, time: f64) -> Result<CriticalStretch, DamageError> {
        let value = expression
            .eval(&[time])
            .map_err(|e| DamageError::Expression {
                time,
                message: e.to_string(),
            })?;
        CriticalStretch::new(value).map_err(|_| DamageError::Expression {
            time,
            message: format!(
                "the critical stretch evaluates to {value}; it must be a positive number"
            ),
        })
    }

    /// The critical stretch in force.
    pub fn critical_stretch(&self) -> f64 {
        self.current.critical_stretch()
    }
}

impl DamageModel for TimeDependentCriticalStretch {
    fn declaration(&self) -> &'static ModelDeclaration {
        &Self::DECLARATION
    }

    fn set_time(&mut self, time: f64) -> Result<(), DamageError> {
        let next = Self::evaluate(&self.expression, time)?;
        self.current.set_critical_stretch(&next);
        Ok(())
    }

    fn prepare(&mut self, reference: &ReferenceView<'_>, points: &[u32]) {
        self.current.prepare(reference, points);
    }

    fn set_thermal_expansion(&mut self, coefficient: f64) -> Result<(), DamageError> {
        self.current.set_thermal_expansion(coefficient)
    }

    fn update_at_temperature(
        &self,
        reference: &ReferenceView<'_>,
        current_position: &[[f64; 3]],
        temperature_change: &[f64],
        points: &[u32],
        bond_damage: &mut [f32],
    ) -> usize {
        self.current.update_at_temperature(
            reference,
            current_position,
            temperature_change,
            points,
            bond_damage,
        )
    }

    fn update(
        &self,
        reference: &ReferenceView<'_>,
        current_position: &[[f64; 3]],
        points: &[u32],
        bond_damage: &mut [f32],
    ) -> usize {
        self.current
            .update(reference, current_position, points, bond_damage)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::expression::TIME;
    use crate::model::BondList;

    #[test]
    fn the_limit_follows_the_expression_in_time() {
        let expression = Expression::parse(
            "if(t < 1.0) { value = 50.0; } else { value = 0.015; }",
            TIME,
        )
        .unwrap();
        let mut model = TimeDependentCriticalStretch::new(expression, 0.0).unwrap();
        assert_eq!(model.critical_stretch(), 50.0);
        // Two points 1 apart, stretched by 2 %: intact while s_c = 50, broken once s_c = 0.015.
        let x = [[0.0; 3], [1.0, 0.0, 0.0]];
        let y = [[0.0; 3], [1.02, 0.0, 0.0]];
        let bonds = BondList {
            offsets: vec![0, 1, 2],
            neighbor: vec![1, 0],
            reference_length: vec![1.0, 1.0],
        };
        let reference = ReferenceView {
            bonds: &bonds,
            position: &x,
            volume: &[1.0, 1.0],
            bond_volume: None,
        };
        let mut damage = vec![0.0f32; 2];
        assert_eq!(model.update(&reference, &y, &[0, 1], &mut damage), 0);
        model.set_time(1.5).unwrap();
        assert_eq!(model.critical_stretch(), 0.015);
        assert_eq!(model.update(&reference, &y, &[0, 1], &mut damage), 2);
        assert_eq!(damage, vec![1.0, 1.0]);
    }

    #[test]
    fn a_non_positive_value_is_an_error_naming_the_time() {
        let expression = Expression::parse("1.0 - t", TIME).unwrap();
        let mut model = TimeDependentCriticalStretch::new(expression, 0.0).unwrap();
        let error = model.set_time(2.0).unwrap_err().to_string();
        assert!(error.contains("t = 2") && error.contains("-1"), "{error}");
    }
}
