//! Node-set conditions: prescribed displacement, initial displacement and velocity, body force,
//! prescribed and initial temperature.
//!
//! Values are expressions in `x y z t` (reference coordinates of the point and time), compiled
//! once. Expressions that do not use `x`, `y` or `z` are evaluated once per application instead
//! of once per point.

use crate::expression::{Expression, SPACE_TIME};

/// What a condition acts on (Peridigm's `Type`, normalised).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ConditionKind {
    /// `Prescribed Displacement`: the component follows g(t) at every step.
    PrescribedDisplacement,
    /// `Initial Displacement`: u = g(x, y, z, t₀) once at the start.
    InitialDisplacement,
    /// `Initial Velocity`: v = g(x, y, z, t₀) once at the start.
    InitialVelocity,
    /// `Body Force`: external force density b = g(x, y, z, t) (force per volume), every step.
    BodyForce,
    /// `Prescribed Temperature`: T = g(x, y, z, t) and ΔT = g(x, y, z, t) − g(x, y, z, 0), every
    /// step (Peridigm's rule: the change is measured from the value at t = 0).
    PrescribedTemperature,
    /// `Initial Temperature`: T = g(x, y, z, t₀) once at the start (ΔT stays 0 there).
    InitialTemperature,
}

/// One condition on one component of one node set.
#[derive(Debug, Clone)]
pub struct Condition {
    /// Name of the deck entry.
    pub name: String,
    /// What it prescribes.
    pub kind: ConditionKind,
    /// Points (run order) it applies to.
    pub points: Vec<u32>,
    /// Component 0, 1, 2 for x, y, z.
    pub component: usize,
    /// The value g(x, y, z, t).
    pub value: Expression,
}

impl Condition {
    /// Evaluates g at every point of the set for time `t`, calling `apply(point, value)`.
    ///
    /// Hoists the evaluation out of the point loop when g does not depend on position.
    pub fn for_each_value(
        &self,
        positions: &[[f64; 3]],
        t: f64,
        mut apply: impl FnMut(usize, f64),
    ) -> Result<(), BoundaryError> {
        self.for_each_value_at(positions, [t], |p, [value]| apply(p, value))
    }

    /// Evaluates g at each of `times` for every point of the set, calling
    /// `apply(point, [g(t₀), g(t₁), …])`; the evaluation is hoisted out of the point loop when
    /// g does not depend on position.
    fn for_each_value_at<const N: usize>(
        &self,
        positions: &[[f64; 3]],
        times: [f64; N],
        mut apply: impl FnMut(usize, [f64; N]),
    ) -> Result<(), BoundaryError> {
        let depends_on_position = ["x", "y", "z"].iter().any(|v| self.value.uses(v));
        let eval = |x: [f64; 3], t: f64| {
            let value = self.value.eval(&[x[0], x[1], x[2], t]).map_err(|source| {
                BoundaryError::Evaluation {
                    condition: self.name.clone(),
                    time: t,
                    message: source.to_string(),
                }
            })?;
            if value.is_finite() {
                return Ok(value);
            }
            let place = if depends_on_position {
                format!("at the point ({}, {}, {})", x[0], x[1], x[2])
            } else {
                "at every point of its node set".to_string()
            };
            Err(BoundaryError::Evaluation {
                condition: self.name.clone(),
                time: t,
                message: format!(
                    "its value \"{}\" is {value} {place}; a condition must give a finite number, so fix the expression",
                    self.value.source()
                ),
            })
        };
        let at_times = |x: [f64; 3]| -> Result<[f64; N], BoundaryError> {
            let mut values = [0.0; N];
            for (value, &t) in values.iter_mut().zip(&times) {
                *value = eval(x, t)?;
            }
            Ok(values)
        };
        if !depends_on_position {
            let values = at_times([0.0; 3])?;
            for &p in &self.points {
                apply(p as usize, values);
            }
            return Ok(());
        }
        for &p in &self.points {
            apply(p as usize, at_times(positions[p as usize])?);
        }
        Ok(())
    }
}

/// The variables boundary expressions may use, in evaluation order.
pub const VARIABLES: &[&str] = SPACE_TIME;

/// Errors while applying conditions.
#[derive(Debug, thiserror::Error)]
pub enum BoundaryError {
    /// An expression failed at run time (e.g. produced a non-number).
    #[error("boundary condition \"{condition}\" at t = {time}: {message}")]
    Evaluation {
        /// Deck entry name.
        condition: String,
        /// Time of the evaluation.
        time: f64,
        /// What went wrong.
        message: String,
    },
}

/// All conditions of a run, grouped by kind.
#[derive(Debug, Clone, Default)]
pub struct BoundaryConditions {
    /// Every condition in deck order.
    pub conditions: Vec<Condition>,
}

impl BoundaryConditions {
    fn of_kind(&self, kind: ConditionKind) -> impl Iterator<Item = &Condition> {
        self.conditions.iter().filter(move |c| c.kind == kind)
    }

    /// True when a body force is present (the external force field is only allocated then).
    pub fn has_body_force(&self) -> bool {
        self.of_kind(ConditionKind::BodyForce).next().is_some()
    }

    /// True when a temperature condition is present (the point temperatures are only
    /// allocated then).
    pub fn has_temperature(&self) -> bool {
        self.conditions.iter().any(|c| {
            matches!(
                c.kind,
                ConditionKind::PrescribedTemperature | ConditionKind::InitialTemperature
            )
        })
    }

    /// Applies `Initial Temperature` at time `t0` to `temperature`, then `Prescribed
    /// Temperature` at `t0` ([`BoundaryConditions::temperature`]).
    pub fn initial_temperature(
        &self,
        positions: &[[f64; 3]],
        t0: f64,
        temperature: &mut [f64],
        change: &mut [f64],
    ) -> Result<(), BoundaryError> {
        for c in self.of_kind(ConditionKind::InitialTemperature) {
            c.for_each_value(positions, t0, |p, v| temperature[p] = v)?;
        }
        self.temperature(positions, t0, temperature, change)
    }

    /// `Prescribed Temperature` at time `t`: T = g(t) and ΔT = g(t) − g(0) at every point of
    /// each condition's node set (a later condition overrides an earlier one on shared points).
    pub fn temperature(
        &self,
        positions: &[[f64; 3]],
        t: f64,
        temperature: &mut [f64],
        change: &mut [f64],
    ) -> Result<(), BoundaryError> {
        for c in self.of_kind(ConditionKind::PrescribedTemperature) {
            c.for_each_value_at(positions, [0.0, t], |p, [start, now]| {
                temperature[p] = now;
                change[p] = now - start;
            })?;
        }
        Ok(())
    }

    /// `Prescribed Temperature` at time `t` into the history's point temperatures
    /// ([`BoundaryConditions::temperature`]); nothing when the run has none.
    pub fn apply_temperature(
        &self,
        positions: &[[f64; 3]],
        t: f64,
        history: &mut crate::history::History,
    ) -> Result<(), BoundaryError> {
        match history.thermal_mut() {
            Some(thermal) => {
                self.temperature(positions, t, &mut thermal.temperature, &mut thermal.change)
            }
            None => Ok(()),
        }
    }

    /// Applies initial displacement and velocity at time `t0`.
    pub fn apply_initial(
        &self,
        positions: &[[f64; 3]],
        t0: f64,
        displacement: &mut [[f64; 3]],
        velocity: &mut [[f64; 3]],
    ) -> Result<(), BoundaryError> {
        for c in self.of_kind(ConditionKind::InitialDisplacement) {
            c.for_each_value(positions, t0, |p, v| displacement[p][c.component] = v)?;
        }
        for c in self.of_kind(ConditionKind::InitialVelocity) {
            c.for_each_value(positions, t0, |p, v| velocity[p][c.component] = v)?;
        }
        Ok(())
    }

    /// Prescribed-displacement increments from `t_from` to `t_to`, Peridigm's rule: the
    /// increment is g(t_to) − g(t_from); when that is exactly zero (g constant in time) it is
    /// g(t_to) − u, so a constant non-zero value is enforced (as a jump at the first step).
    /// Calls `apply(point, component, increment)`.
    pub fn prescribed_increments(
        &self,
        positions: &[[f64; 3]],
        displacement: &[[f64; 3]],
        t_from: f64,
        t_to: f64,
        mut apply: impl FnMut(usize, usize, f64),
    ) -> Result<(), BoundaryError> {
        for c in self.of_kind(ConditionKind::PrescribedDisplacement) {
            c.for_each_value_at(positions, [t_from, t_to], |p, [from, to]| {
                let increment = to - from;
                let increment = if increment == 0.0 {
                    to - displacement[p][c.component]
                } else {
                    increment
                };
                apply(p, c.component, increment);
            })?;
        }
        Ok(())
    }

    /// Points and components whose displacement is prescribed (kinematic dofs), as `3·p + c`.
    pub fn constrained_dofs(&self) -> Vec<usize> {
        let mut dofs: Vec<usize> = self
            .of_kind(ConditionKind::PrescribedDisplacement)
            .flat_map(|c| c.points.iter().map(move |&p| 3 * p as usize + c.component))
            .collect();
        dofs.sort_unstable();
        dofs.dedup();
        dofs
    }

    /// Fills the external force density with the body forces at time `t` (zero elsewhere).
    pub fn body_force(
        &self,
        positions: &[[f64; 3]],
        t: f64,
        force_density: &mut [[f64; 3]],
    ) -> Result<(), BoundaryError> {
        force_density.iter_mut().for_each(|f| *f = [0.0; 3]);
        for c in self.of_kind(ConditionKind::BodyForce) {
            c.for_each_value(positions, t, |p, v| force_density[p][c.component] += v)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn condition(
        kind: ConditionKind,
        points: Vec<u32>,
        component: usize,
        value: &str,
    ) -> Condition {
        Condition {
            name: "test".into(),
            kind,
            points,
            component,
            value: Expression::parse(value, VARIABLES).unwrap(),
        }
    }

    #[test]
    fn ramp_gives_increments_and_constant_values_are_enforced() {
        let positions = [[0.0; 3], [1.0, 0.0, 0.0]];
        let bcs = BoundaryConditions {
            conditions: vec![
                condition(ConditionKind::PrescribedDisplacement, vec![0], 0, "2.0*t"),
                condition(ConditionKind::PrescribedDisplacement, vec![1], 1, "0.5"),
            ],
        };
        let displacement = [[0.0; 3], [0.0, 0.1, 0.0]];
        let mut seen = Vec::new();
        bcs.prescribed_increments(&positions, &displacement, 1.0, 1.5, |p, c, du| {
            seen.push((p, c, du))
        })
        .unwrap();
        // Ramp: g(1.5) − g(1.0) = 3 − 2 = 1. Constant 0.5: the increment in time is 0, so
        // Peridigm enforces the value: 0.5 − u = 0.5 − 0.1 = 0.4.
        assert_eq!(seen[0], (0, 0, 1.0));
        assert_eq!(seen[1].0, 1);
        assert!((seen[1].2 - 0.4).abs() < 1e-15);
        assert_eq!(bcs.constrained_dofs(), vec![0, 4]);
    }

    #[test]
    fn prescribed_temperature_is_measured_from_t_zero_and_uses_x_y_z_t() {
        let positions = [[2.0, 0.0, 0.0], [3.0, 1.0, 0.0], [4.0, 0.0, 0.5]];
        let bcs = BoundaryConditions {
            conditions: vec![
                condition(
                    ConditionKind::InitialTemperature,
                    vec![0, 1, 2],
                    0,
                    "300 + x",
                ),
                condition(
                    ConditionKind::PrescribedTemperature,
                    vec![1, 2],
                    0,
                    "if(t < 1) { value = 20 + y + 10*t; } else { value = 30 + y + z^2; }",
                ),
            ],
        };
        assert!(bcs.has_temperature());
        let mut temperature = [0.0; 3];
        let mut change = [0.0; 3];
        bcs.initial_temperature(&positions, 0.0, &mut temperature, &mut change)
            .unwrap();
        // Point 0: T = 300 + 2 (initial only). Points 1, 2: the prescribed g(x, y, z, 0) =
        // 20 + y overrides the initial value; ΔT = g(0) − g(0) = 0.
        assert_eq!(temperature, [302.0, 21.0, 20.0]);
        assert_eq!(change, [0.0; 3]);
        bcs.temperature(&positions, 0.5, &mut temperature, &mut change)
            .unwrap();
        // g(0.5) = 20 + y + 5: ΔT = 5 on both; point 0 keeps its values.
        assert_eq!(temperature, [302.0, 26.0, 25.0]);
        assert_eq!(change, [0.0, 5.0, 5.0]);
        bcs.temperature(&positions, 2.0, &mut temperature, &mut change)
            .unwrap();
        // g(2) = 30 + y + z² (the `^` power of Peridigm's parser): 31, 30.25; minus g(0).
        assert_eq!(temperature, [302.0, 31.0, 30.25]);
        assert_eq!(change, [0.0, 10.0, 10.25]);
        let mechanical = BoundaryConditions {
            conditions: vec![condition(ConditionKind::BodyForce, vec![0], 0, "1")],
        };
        assert!(!mechanical.has_temperature());
    }

    #[test]
    fn body_force_and_initial_conditions_use_reference_positions() {
        let positions = [[2.0, 0.0, 0.0], [3.0, 0.0, 0.0]];
        let bcs = BoundaryConditions {
            conditions: vec![
                condition(ConditionKind::BodyForce, vec![0, 1], 0, "10*x + t"),
                condition(ConditionKind::InitialVelocity, vec![1], 2, "-x"),
            ],
        };
        let mut b = [[9.0; 3]; 2];
        bcs.body_force(&positions, 0.5, &mut b).unwrap();
        // b_x = 10x + t: 20.5 and 30.5; other components cleared to zero.
        assert_eq!(b, [[20.5, 0.0, 0.0], [30.5, 0.0, 0.0]]);
        let mut u = [[0.0; 3]; 2];
        let mut v = [[0.0; 3]; 2];
        bcs.apply_initial(&positions, 0.0, &mut u, &mut v).unwrap();
        assert_eq!(v[1], [0.0, 0.0, -3.0]);
        assert_eq!(v[0], [0.0; 3]);
    }
}
