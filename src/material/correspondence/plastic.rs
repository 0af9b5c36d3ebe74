//! J2 plasticity of the correspondence family, Peridigm's `Elastic Plastic Correspondence`
//! (perfect plasticity) and `Isotropic Hardening Correspondence` (linear isotropic hardening,
//! optional flaw), reference §1.3.
//!
//! Radial return in the unrotated frame (Simo & Hughes 1998, box 3.1): the elastic trial
//! `σ̃_tr = σ̃_n + 2μ dev(d Δt) + K tr(d Δt) I` with deviator s_tr and von Mises stress
//! `q_tr = √(3/2 s_tr:s_tr)` is admissible when `q_tr ≤ σ_y + H ε̄_p,n`; otherwise
//!
//! `Δε̄_p = (q_tr − σ_y − H ε̄_p,n)/(3μ + H)`, `s = (1 − 3μ Δε̄_p/q_tr) s_tr`,
//! `ε̄_p = ε̄_p,n + Δε̄_p`,
//!
//! with H = 0 for perfect plasticity. With `Enable Flaw` the yield stress at reference position
//! X is `σ_y (1 − A exp(−|X − X_f|²/s²))` (`Flaw Magnitude` A, `Flaw Location X/Y/Z` X_f,
//! `Flaw Size` s).
//!
//! Written over the generic scalar, the return map's derivative is the consistent tangent of
//! the active branch (the automatic-differentiation tangent).

use super::elastic::elastic_trial;
use super::kinematics::{deviator, trace, Tensor};
use super::{PointStep, StressModel, StressState};
use crate::material::{positive, MaterialError, MaterialInput};
use crate::model::{ModelDeclaration, Reach};
use crate::tangent::Scalar;

/// Gaussian flaw that lowers the yield stress: σ_y·(1 − A·exp(−|X − X_f|²/s²)) (Peridigm's
/// `Enable Flaw` keys).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Flaw {
    /// `Flaw Location X/Y/Z` X_f (length).
    pub location: [f64; 3],
    /// `Flaw Size` s (length, > 0).
    pub size: f64,
    /// `Flaw Magnitude` A (dimensionless).
    pub magnitude: f64,
}

impl Flaw {
    /// `yield_stress` at reference position `x`: σ_y (1 − A exp(−|X − X_f|²/s²)) with a flaw,
    /// σ_y without one.
    pub(crate) fn reduced(flaw: Option<&Flaw>, yield_stress: f64, x: [f64; 3]) -> f64 {
        match flaw {
            Some(flaw) => {
                let distance_squared: f64 = (0..3).map(|k| (x[k] - flaw.location[k]).powi(2)).sum();
                let reduction =
                    flaw.magnitude * (-distance_squared / (flaw.size * flaw.size)).exp();
                yield_stress * (1.0 - reduction)
            }
            None => yield_stress,
        }
    }
}

/// The constants of J2 plasticity with linear isotropic hardening.
#[derive(Debug, Clone, Copy)]
pub(crate) struct J2 {
    /// K (pressure).
    pub(crate) bulk_modulus: f64,
    /// μ (pressure).
    pub(crate) shear_modulus: f64,
    /// σ_y (pressure).
    pub(crate) yield_stress: f64,
    /// H (pressure).
    pub(crate) hardening_modulus: f64,
    /// The flaw, if any.
    pub(crate) flaw: Option<Flaw>,
}

impl J2 {
    fn new(
        input: &MaterialInput,
        yield_stress: f64,
        hardening_modulus: f64,
        flaw: Option<Flaw>,
    ) -> Result<Self, MaterialError> {
        if !(hardening_modulus.is_finite() && hardening_modulus >= 0.0) {
            return Err(MaterialError::NotNonNegative {
                key: "Hardening Modulus",
                value: hardening_modulus,
            });
        }
        Ok(Self {
            bulk_modulus: positive("Bulk Modulus", input.bulk_modulus)?,
            shear_modulus: positive("Shear Modulus", input.required_shear_modulus()?)?,
            yield_stress: positive("Yield Stress", yield_stress)?,
            hardening_modulus,
            flaw,
        })
    }

    /// σ_y at reference position `x`, reduced by the flaw when there is one.
    fn yield_stress_at(&self, x: [f64; 3]) -> f64 {
        Flaw::reduced(self.flaw.as_ref(), self.yield_stress, x)
    }

    /// The radial return (module docs).
    pub(crate) fn advance<T: Scalar>(
        &self,
        start: &StressState<f64>,
        increment: &Tensor<T>,
        step: &PointStep,
    ) -> StressState<T> {
        let trial = elastic_trial(
            &start.unrotated,
            increment,
            self.bulk_modulus,
            self.shear_modulus,
        );
        let flow_stress = self.yield_stress_at(step.position)
            + self.hardening_modulus * start.equivalent_plastic_strain;
        let s = deviator(&trial);
        let squared = s.iter().fold(T::from(0.0), |sum, &x| sum + x * x) * 1.5;
        if squared.re() <= flow_stress * flow_stress {
            return StressState {
                unrotated: trial,
                equivalent_plastic_strain: T::from(start.equivalent_plastic_strain),
            };
        }
        let von_mises = squared.sqrt();
        let increment_plastic =
            (von_mises - flow_stress) * (1.0 / (3.0 * self.shear_modulus + self.hardening_modulus));
        let scale = T::from(1.0) - increment_plastic * (3.0 * self.shear_modulus) / von_mises;
        let mean = trace(&trial) * (1.0 / 3.0);
        let mut unrotated = s.map(|x| x * scale);
        for k in 0..3 {
            unrotated[(k, k)] += mean;
        }
        StressState {
            unrotated,
            equivalent_plastic_strain: increment_plastic + start.equivalent_plastic_strain,
        }
    }
}

/// J2 plasticity as a correspondence stress model: `Isotropic Hardening Correspondence` when
/// `HARDENING` (`Yield Stress`, `Hardening Modulus`, optional flaw), `Elastic Plastic
/// Correspondence` (perfect plasticity, `Yield Stress`) otherwise.
#[derive(Debug, Clone, Copy)]
pub(crate) struct PlasticStress<const HARDENING: bool>(pub(crate) J2);

/// `Elastic Plastic Correspondence`.
pub(crate) type PerfectlyPlasticStress = PlasticStress<false>;
/// `Isotropic Hardening Correspondence`.
pub(crate) type HardeningPlasticStress = PlasticStress<true>;

/// The keys of the perfectly plastic model; the hardening model adds its own after them.
const PLASTIC_KEYS: &[&str] = &[
    "Density",
    "Bulk Modulus",
    "Shear Modulus",
    "Young's Modulus",
    "Poisson's Ratio",
    "Hourglass Coefficient",
    "Yield Stress",
    "Tangent",
    "Finite Difference Probe Length",
    "Hardening Modulus",
    "Enable Flaw",
    "Flaw Location X",
    "Flaw Location Y",
    "Flaw Location Z",
    "Flaw Size",
    "Flaw Magnitude",
];

impl<const HARDENING: bool> StressModel for PlasticStress<HARDENING> {
    const DECLARATION: ModelDeclaration = ModelDeclaration {
        deck_name: if HARDENING {
            "Isotropic Hardening Correspondence"
        } else {
            "Elastic Plastic Correspondence"
        },
        deck_keys: if HARDENING {
            PLASTIC_KEYS
        } else {
            PLASTIC_KEYS.split_at(9).0
        },
        reach: Reach::TwoHop,
        fields: super::CORRESPONDENCE_FIELDS,
        outputs: super::CORRESPONDENCE_OUTPUTS,
    };

    fn from_input(input: &MaterialInput) -> Result<Self, MaterialError> {
        let parameters = input.required_correspondence("Yield Stress")?;
        let yield_stress = parameters.yield_stress.ok_or(MaterialError::Missing {
            key: "Yield Stress",
        })?;
        if !HARDENING {
            return Ok(Self(J2::new(input, yield_stress, 0.0, None)?));
        }
        let hardening_modulus = parameters.hardening_modulus.ok_or(MaterialError::Missing {
            key: "Hardening Modulus",
        })?;
        Ok(Self(J2::new(
            input,
            yield_stress,
            hardening_modulus,
            parameters.flaw,
        )?))
    }

    fn advance<T: Scalar>(
        &self,
        start: &StressState<f64>,
        increment: &Tensor<T>,
        step: &PointStep,
    ) -> StressState<T> {
        self.0.advance(start, increment, step)
    }
}
