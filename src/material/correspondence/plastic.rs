//! J2 plasticity of the correspondence family, Peridigm's `Elastic Plastic Correspondence`
//! (perfect plasticity) and `Isotropic Hardening Correspondence` (linear isotropic hardening,
//! optional flaw), as Peridigm's `Peridigm_ElasticPlasticCorrespondenceMaterial.cpp` and
//! `Peridigm_IsotropicHardeningCorrespondenceMaterial.cpp`.
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
use super::{PointStep, StressModel, StressState, HOURGLASS_COEFFICIENT, YIELD_STRESS};
use crate::material::keys::{non_negative_req, DENSITY, ELASTIC, PROBE_LENGTH, TANGENT};
use crate::material::{positive, ElasticConstants, MaterialError};
use crate::model::{KeyDoc, ModelDeclaration, Reach, TangentSupport};
use crate::parameter_list::error::DeckError;
use crate::parameter_list::reader::{Ctx, ListReader};
use crate::tangent::Scalar;

/// `Hardening Modulus` of J2 plasticity.
pub(super) const HARDENING_MODULUS: KeyDoc = KeyDoc {
    key: "Hardening Modulus",
    meaning: "H of linear isotropic hardening: the flow stress is σ_y + H ε̄_p",
    unit: "pressure",
    default: "required",
};

/// `Enable Flaw`.
pub(super) const ENABLE_FLAW: KeyDoc = KeyDoc {
    key: "Enable Flaw",
    meaning: "lower the yield stress around a point: σ_y (1 − A exp(−|X − X_f|²/s²))",
    unit: "true/false",
    default: "false",
};

/// `Flaw Location X`, `Flaw Location Y`, `Flaw Location Z`.
pub(super) const FLAW_LOCATION: [KeyDoc; 3] = [
    KeyDoc {
        key: "Flaw Location X",
        meaning: "x of the flaw's centre X_f",
        unit: "length",
        default: "required with a flaw",
    },
    KeyDoc {
        key: "Flaw Location Y",
        meaning: "y of the flaw's centre X_f",
        unit: "length",
        default: "required with a flaw",
    },
    KeyDoc {
        key: "Flaw Location Z",
        meaning: "z of the flaw's centre X_f",
        unit: "length",
        default: "required with a flaw",
    },
];

/// `Flaw Size`.
pub(super) const FLAW_SIZE: KeyDoc = KeyDoc {
    key: "Flaw Size",
    meaning: "s, the radius of the Gaussian flaw",
    unit: "length",
    default: "required with a flaw",
};

/// `Flaw Magnitude`.
pub(super) const FLAW_MAGNITUDE: KeyDoc = KeyDoc {
    key: "Flaw Magnitude",
    meaning: "A, the relative reduction of σ_y at the flaw's centre",
    unit: "—",
    default: "required with a flaw",
};

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
    /// `Enable Flaw` with its parameters, when the list enables it.
    pub(super) fn read(ctx: &Ctx, list: &mut ListReader) -> Result<Option<Flaw>, DeckError> {
        if !list.bool_or(ctx, ENABLE_FLAW.key, false)? {
            return Ok(None);
        }
        Ok(Some(Flaw {
            location: [
                list.f64_req(ctx, FLAW_LOCATION[0].key)?,
                list.f64_req(ctx, FLAW_LOCATION[1].key)?,
                list.f64_req(ctx, FLAW_LOCATION[2].key)?,
            ],
            size: list.positive_req(ctx, FLAW_SIZE.key)?,
            magnitude: list.f64_req(ctx, FLAW_MAGNITUDE.key)?,
        }))
    }

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
        elastic: &ElasticConstants,
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
            bulk_modulus: positive("Bulk Modulus", elastic.bulk_modulus)?,
            shear_modulus: positive("Shear Modulus", elastic.shear_modulus)?,
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

/// The deck parameters of J2 plasticity besides the elastic pair.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlasticParameters {
    /// `Yield Stress` σ_y (pressure).
    pub yield_stress: f64,
    /// `Hardening Modulus` H (pressure); 0 for perfect plasticity.
    pub hardening_modulus: f64,
    /// `Enable Flaw` with its parameters (`Isotropic Hardening Correspondence` only).
    pub flaw: Option<Flaw>,
}

impl<const HARDENING: bool> PlasticStress<HARDENING> {
    /// `Yield Stress` and, with hardening, `Hardening Modulus` and (when `flaw`) the flaw.
    pub(super) fn read_keys(
        ctx: &Ctx,
        list: &mut ListReader,
        flaw: bool,
    ) -> Result<PlasticParameters, DeckError> {
        let yield_stress = list.positive_req(ctx, YIELD_STRESS.key)?;
        if !HARDENING {
            return Ok(PlasticParameters {
                yield_stress,
                hardening_modulus: 0.0,
                flaw: None,
            });
        }
        Ok(PlasticParameters {
            yield_stress,
            hardening_modulus: non_negative_req(ctx, list, HARDENING_MODULUS.key)?,
            flaw: if flaw { Flaw::read(ctx, list)? } else { None },
        })
    }
}

impl<const HARDENING: bool> StressModel for PlasticStress<HARDENING> {
    type Parameters = PlasticParameters;

    const DECLARATION: ModelDeclaration = ModelDeclaration {
        deck_name: if HARDENING {
            "Isotropic Hardening Correspondence"
        } else {
            "Elastic Plastic Correspondence"
        },
        aliases: &[],
        deck_keys: if HARDENING {
            &[
                DENSITY,
                ELASTIC[0],
                ELASTIC[1],
                ELASTIC[2],
                ELASTIC[3],
                HOURGLASS_COEFFICIENT,
                YIELD_STRESS,
                HARDENING_MODULUS,
                ENABLE_FLAW,
                FLAW_LOCATION[0],
                FLAW_LOCATION[1],
                FLAW_LOCATION[2],
                FLAW_SIZE,
                FLAW_MAGNITUDE,
                TANGENT,
                PROBE_LENGTH,
            ]
        } else {
            &[
                DENSITY,
                ELASTIC[0],
                ELASTIC[1],
                ELASTIC[2],
                ELASTIC[3],
                HOURGLASS_COEFFICIENT,
                YIELD_STRESS,
                TANGENT,
                PROBE_LENGTH,
            ]
        },
        reach: Reach::TwoHop,
        fields: super::CORRESPONDENCE_FIELDS,
        outputs: super::CORRESPONDENCE_OUTPUTS,
        tangent: TangentSupport::Differentiated,
        thermal_strain: false,
        small_displacement: false,
        example: if HARDENING {
            "Density: 2.0\nBulk Modulus: 3.0\nShear Modulus: 1.7\nHourglass Coefficient: 0.05\n\
             Yield Stress: 0.002\nHardening Modulus: 0.3"
        } else {
            "Density: 2.0\nBulk Modulus: 3.0\nShear Modulus: 1.7\nHourglass Coefficient: 0.05\n\
             Yield Stress: 0.002"
        },
    };

    fn read(ctx: &mut Ctx, list: &mut ListReader) -> Result<PlasticParameters, DeckError> {
        Self::read_keys(ctx, list, true)
    }

    fn new(
        elastic: &ElasticConstants,
        parameters: &PlasticParameters,
    ) -> Result<Self, MaterialError> {
        Ok(Self(J2::new(
            elastic,
            parameters.yield_stress,
            parameters.hardening_modulus,
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
