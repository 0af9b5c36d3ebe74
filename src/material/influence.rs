//! Influence functions ω(ζ, δ): the weight a state-based material gives each bond.
//!
//! Peridigm has one global choice, `Discretization → Influence Function` (default `"One"`),
//! see `Peridigm_InfluenceFunction.hpp`. Any other string is an expression in
//! `zeta` and `horizon`; the expression module compiles it into a closure handed to
//! [`InfluenceFunction::user`].
//!
//! ω is a property of the reference configuration, so materials evaluate it once per bond at
//! setup ([`InfluenceFunction::per_bond`]) and never inside the time loop. The hypoelastic
//! correspondence models are the exception: they weigh each bond by the built-in function of
//! its current length, evaluated in every force evaluation.

use std::fmt;
use std::sync::Arc;

use crate::model::BondList;

use super::MaterialError;

/// A user-supplied ω(ζ, δ) (reference bond length, horizon) → weight.
pub type UserInfluence = Arc<dyn Fn(f64, f64) -> f64 + Send + Sync>;

/// The influence function ω(ζ, δ) of a state-based material.
#[derive(Clone, Default)]
pub enum InfluenceFunction {
    /// `"One"` (Peridigm's default): ω = 1 for every bond.
    #[default]
    One,
    /// `"Parabolic Decay"`: with x = ζ/δ, ω = 1 for x < ½, ω = −4x² + 4x for ½ ≤ x ≤ 1
    /// (continuous at x = ½ where both give 1, and 0 at x = 1), ω = 0 for x > 1.
    ParabolicDecay,
    /// `"Gaussian"`: ω = exp(−ζ²/(0.4δ)²) (no cut-off; the family ends at δ anyway).
    Gaussian,
    /// Any other deck string, compiled by the expression module into a closure of
    /// (ζ, δ). Peridigm example: `"1.0/zeta"`.
    User(UserInfluence),
}

impl fmt::Debug for InfluenceFunction {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::One => f.write_str("One"),
            Self::ParabolicDecay => f.write_str("ParabolicDecay"),
            Self::Gaussian => f.write_str("Gaussian"),
            Self::User(_) => f.write_str("User(<closure>)"),
        }
    }
}

/// Two built-in functions are equal when they are the same function; two user functions when
/// they are the same closure.
impl PartialEq for InfluenceFunction {
    fn eq(&self, other: &Self) -> bool {
        match (self, other) {
            (Self::User(a), Self::User(b)) => Arc::ptr_eq(a, b),
            _ => std::mem::discriminant(self) == std::mem::discriminant(other),
        }
    }
}

impl InfluenceFunction {
    /// The built-in function named by a deck string (`"One"`, `"Parabolic Decay"`,
    /// `"Gaussian"`, spelled exactly as Peridigm spells them), or `None` for any other string,
    /// which Peridigm treats as an expression (give it to the expression module, then to
    /// [`InfluenceFunction::user`]).
    pub fn from_deck_name(name: &str) -> Option<Self> {
        match name {
            "One" => Some(Self::One),
            "Parabolic Decay" => Some(Self::ParabolicDecay),
            "Gaussian" => Some(Self::Gaussian),
            _ => None,
        }
    }

    /// A user influence function ω(ζ, δ).
    pub fn user(function: impl Fn(f64, f64) -> f64 + Send + Sync + 'static) -> Self {
        Self::User(Arc::new(function))
    }

    /// True for `One`, which materials exploit by storing no per-bond weights at all.
    pub fn is_one(&self) -> bool {
        matches!(self, Self::One)
    }

    /// ω(ζ, δ) for reference bond length `zeta` and horizon `horizon`.
    pub fn evaluate(&self, zeta: f64, horizon: f64) -> f64 {
        match self {
            Self::One => 1.0,
            Self::ParabolicDecay => {
                let x = zeta / horizon;
                if x < 0.5 {
                    1.0
                } else if x <= 1.0 {
                    -4.0 * x * x + 4.0 * x
                } else {
                    0.0
                }
            }
            Self::Gaussian => {
                let width = 0.4 * horizon;
                (-(zeta * zeta) / (width * width)).exp()
            }
            Self::User(function) => function(zeta, horizon),
        }
    }

    /// ω of every bond in the rows of `points`, concatenated in that order (the block-local bond
    /// numbering materials use). Errors when a (user) function gives a negative or non-finite
    /// weight, naming the bond length, so a deck mistake never turns into NaN forces later.
    pub fn per_bond(
        &self,
        bonds: &BondList,
        points: &[u32],
        horizon: f64,
    ) -> Result<Vec<f64>, MaterialError> {
        let count: usize = points.iter().map(|&i| bonds.family_size(i as usize)).sum();
        let mut weights = Vec::with_capacity(count);
        for &i in points {
            for &zeta in &bonds.reference_length[bonds.range(i as usize)] {
                let omega = self.evaluate(zeta, horizon);
                if !(omega.is_finite() && omega >= 0.0) {
                    return Err(MaterialError::InvalidInfluence {
                        zeta,
                        horizon,
                        value: omega,
                    });
                }
                weights.push(omega);
            }
        }
        Ok(weights)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn built_in_values_match_peridigm_formulas() {
        let h = 2.0;
        assert_eq!(InfluenceFunction::One.evaluate(1.7, h), 1.0);
        let p = InfluenceFunction::ParabolicDecay;
        // x = 0.25 < ½ → 1.
        assert_eq!(p.evaluate(0.5, h), 1.0);
        // x = ½ → −4·¼ + 4·½ = 1 (continuous).
        assert_eq!(p.evaluate(1.0, h), 1.0);
        // x = 0.75 → −4·0.5625 + 3 = 0.75.
        assert!((p.evaluate(1.5, h) - 0.75).abs() < 1e-15);
        // x = 1 → 0, beyond the horizon → 0.
        assert_eq!(p.evaluate(2.0, h), 0.0);
        assert_eq!(p.evaluate(2.5, h), 0.0);
        // Gaussian at ζ = 0.4δ: exp(−1).
        let g = InfluenceFunction::Gaussian.evaluate(0.8, h);
        assert!((g - (-1.0f64).exp()).abs() < 1e-15);
        let u = InfluenceFunction::user(|zeta, _| 1.0 / zeta);
        assert_eq!(u.evaluate(4.0, h), 0.25);
    }

    #[test]
    fn deck_names_are_exact() {
        assert!(InfluenceFunction::from_deck_name("One").unwrap().is_one());
        assert!(matches!(
            InfluenceFunction::from_deck_name("Parabolic Decay"),
            Some(InfluenceFunction::ParabolicDecay)
        ));
        assert!(matches!(
            InfluenceFunction::from_deck_name("Gaussian"),
            Some(InfluenceFunction::Gaussian)
        ));
        assert!(InfluenceFunction::from_deck_name("1.0/zeta").is_none());
    }

    #[test]
    fn per_bond_follows_rows_and_rejects_bad_user_weights() {
        // Rows: point 0 → {1, 2} with ζ = 1, 2; point 1 → {0} with ζ = 1.
        let bonds = BondList {
            offsets: vec![0, 2, 3, 3],
            neighbor: vec![1, 2, 0],
            reference_length: vec![1.0, 2.0, 1.0],
        };
        let w = InfluenceFunction::user(|zeta, _| 1.0 / zeta)
            .per_bond(&bonds, &[1, 0], 3.0)
            .unwrap();
        assert_eq!(w, vec![1.0, 1.0, 0.5]);
        let err = InfluenceFunction::user(|zeta, _| 1.0 - zeta)
            .per_bond(&bonds, &[0], 3.0)
            .unwrap_err();
        assert!(err.to_string().contains("Influence Function"), "{err}");
    }
}
