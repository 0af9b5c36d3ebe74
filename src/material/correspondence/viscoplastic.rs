//! `Viscoplastic Needleman Correspondence`'s stress model: rate-dependent J2 plasticity with
//! Needleman's flow stress (Peridigm's `updateElasticViscoplasticCauchyStress`,
//! `correspondence.cxx`):
//!
//! `Y(ε̄_p, ε̇_p) = σ_y (1 + ε̄_p/ε₀)^N / (1 + (ε̄_p/ε₁)²) · (ε̇_p/ε̇_ref)^m`,
//!
//! σ_y the `Yield Stress` (reduced by the flaw, as in the hardening model), N the `Strain
//! Hardening Exponent`, m the `Rate Hardening Exponent`, ε̇_ref the `Reference Strain Rate`,
//! ε₀ and ε₁ the `Reference Strain 0` and `1`.
//!
//! **Return map.** The elastic trial `σ̃_tr = σ̃_n + 2μ dev(d Δt) + K tr(d Δt) I` with deviator
//! s_tr and von Mises stress q_tr = √(3/2)|s_tr| is kept when q_tr < σ_y (Peridigm's test).
//! Otherwise the deviator returns radially, `s = s_tr − 2μ Δλ s_tr/|s_tr|`, with the plastic
//! multiplier Δλ ≥ 0 the root of the consistency condition
//!
//! `g(Δλ) = |s_tr| − 2μ Δλ − √(2/3) Y(ε̄_p,n + √(2/3) Δλ, √(2/3) Δλ/Δt) = 0`
//!
//! (|s| = √(2/3) Y: the returned stress lies on the rate-dependent yield surface), and
//! `ε̄_p = ε̄_p,n + √(2/3) Δλ`. g(0) = |s_tr| > 0 when m > 0 (no flow stress without flow) and
//! g(|s_tr|/(2μ)) = −√(2/3) Y ≤ 0, so a root lies in between; it is bracketed and bisected to
//! round-off. With m = 0 the model is rate independent and g(0) ≤ 0 means an elastic step.
//! With m > 0 and Δt = 0 (a force evaluation in which no time passes, e.g. at rest before the
//! first step) no viscous flow can happen: the step is elastic.
//!
//! **Tangent.** Δλ is found on `f64`; its derivative follows from the implicit function
//! theorem, one Newton step on the generic scalar from the converged root:
//! `Δλ ← Δλ − g(Δλ)/g′(Δλ)` with g′ from a dual number. The automatic-differentiation tangent
//! is then the consistent tangent of the return map.
//!
//! **Where this differs from Peridigm, and why.** Peridigm (i) replaces |s_tr| in g by
//! `|s_n| + 2μ s_tr:Δe/|s_tr|` (equal under proportional loading, where s_n ∥ s_tr), (ii) adds
//! Δλ rather than √(2/3) Δλ to ε̄_p inside its bisection while the yield function and the
//! final update use √(2/3) Δλ, (iii) stops the bisection at a relative change of 1e-6, and
//! (iv) updates ε̄_p afterwards by projecting the plastic strain increment on the mean of the
//! start and end stress directions. Here one consistent definition is used throughout, so the
//! stress is exactly on the yield surface at the ε̄_p that is stored, and the rate-independent
//! limit (m = 0) is exactly the radial return of J2 plasticity with the same flow stress. Under
//! proportional loading and small steps the two agree.

use num_dual::Dual64;

use super::elastic::elastic_trial;
use super::kinematics::{deviator, trace, Tensor};
use super::plastic::{ENABLE_FLAW, FLAW_LOCATION, FLAW_MAGNITUDE, FLAW_SIZE};
use super::{PointStep, StressModel, StressState, HOURGLASS_COEFFICIENT, YIELD_STRESS};
use crate::material::keys::{DENSITY, ELASTIC, PROBE_LENGTH, TANGENT};
use crate::material::{positive, ElasticConstants, Flaw, MaterialError};
use crate::model::{KeyDoc, ModelDeclaration, Reach, TangentSupport};
use crate::parameter_list::error::DeckError;
use crate::parameter_list::reader::{Ctx, ListReader};
use crate::tangent::Scalar;

/// `Strain Hardening Exponent`.
const STRAIN_HARDENING_EXPONENT: KeyDoc = KeyDoc {
    key: "Strain Hardening Exponent",
    meaning: "N of the flow stress's hardening factor (1 + ε̄_p/ε₀)^N",
    unit: "—",
    default: "required",
};

/// `Rate Hardening Exponent`.
const RATE_HARDENING_EXPONENT: KeyDoc = KeyDoc {
    key: "Rate Hardening Exponent",
    meaning: "m ≥ 0 of the rate factor (ε̇_p/ε̇_ref)^m; 0 is rate independent",
    unit: "—",
    default: "required",
};

/// `Reference Strain Rate`.
const REFERENCE_STRAIN_RATE: KeyDoc = KeyDoc {
    key: "Reference Strain Rate",
    meaning: "ε̇_ref of the rate factor",
    unit: "1/time",
    default: "required",
};

/// `Reference Strain 0`.
const REFERENCE_STRAIN_0: KeyDoc = KeyDoc {
    key: "Reference Strain 0",
    meaning: "ε₀ of the hardening factor",
    unit: "—",
    default: "required",
};

/// `Reference Strain 1`.
const REFERENCE_STRAIN_1: KeyDoc = KeyDoc {
    key: "Reference Strain 1",
    meaning: "ε₁ of the softening factor 1/(1 + (ε̄_p/ε₁)²)",
    unit: "—",
    default: "required",
};

/// √(2/3), the factor between the deviatoric norm and the von Mises measure.
const SQRT_TWO_THIRDS: f64 = 0.816_496_580_927_726;

/// The deck parameters of Needleman's flow stress besides `Yield Stress`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NeedlemanParameters {
    /// `Strain Hardening Exponent` N (dimensionless).
    pub strain_hardening_exponent: f64,
    /// `Rate Hardening Exponent` m (dimensionless, ≥ 0; 0 is rate independent).
    pub rate_hardening_exponent: f64,
    /// `Reference Strain Rate` ε̇_ref (1/s, > 0).
    pub reference_strain_rate: f64,
    /// `Reference Strain 0` ε₀ (dimensionless, > 0).
    pub reference_strain_0: f64,
    /// `Reference Strain 1` ε₁ (dimensionless, > 0).
    pub reference_strain_1: f64,
}

/// The deck parameters of `Viscoplastic Needleman Correspondence` besides the elastic pair.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NeedlemanInput {
    /// `Yield Stress` σ_y (pressure).
    pub yield_stress: f64,
    /// N, m, ε̇_ref, ε₀, ε₁.
    pub parameters: NeedlemanParameters,
    /// `Enable Flaw` with its parameters.
    pub flaw: Option<Flaw>,
}

/// Rate-dependent J2 plasticity with Needleman's flow stress (module docs).
#[derive(Debug, Clone, Copy)]
pub(crate) struct NeedlemanStress {
    /// K (pressure).
    pub(crate) bulk_modulus: f64,
    /// μ (pressure).
    pub(crate) shear_modulus: f64,
    /// σ_y (pressure).
    pub(crate) yield_stress: f64,
    /// N, m, ε̇_ref, ε₀, ε₁.
    pub(crate) parameters: NeedlemanParameters,
    /// The flaw, if any.
    pub(crate) flaw: Option<Flaw>,
}

/// The flow stress of one point over one step, as a function of Δλ.
struct FlowStress<'a> {
    parameters: &'a NeedlemanParameters,
    /// σ_y at the point (flaw included).
    yield_stress: f64,
    /// ε̄_p,n.
    start_strain: f64,
    /// Δt.
    duration: f64,
}

impl FlowStress<'_> {
    /// Y at the multiplier `multiplier` (Δλ), generic so that its derivative comes from a dual
    /// number.
    fn at<D: Scalar>(&self, multiplier: D) -> D {
        let p = self.parameters;
        let strain = multiplier * SQRT_TWO_THIRDS + self.start_strain;
        let ratio = strain / p.reference_strain_1;
        let hardening = (strain / p.reference_strain_0 + 1.0).powf(p.strain_hardening_exponent)
            / (ratio * ratio + 1.0);
        let rate = if p.rate_hardening_exponent == 0.0 {
            D::one()
        } else {
            (multiplier * (SQRT_TWO_THIRDS / (self.duration * p.reference_strain_rate)))
                .powf(p.rate_hardening_exponent)
        };
        hardening * rate * self.yield_stress
    }
}

impl NeedlemanStress {
    /// g(Δλ) of the module docs for the trial norm `norm` (|s_tr|).
    fn consistency<D: Scalar>(&self, flow: &FlowStress<'_>, norm: D, multiplier: D) -> D {
        norm - multiplier * (2.0 * self.shear_modulus) - flow.at(multiplier) * SQRT_TWO_THIRDS
    }

    /// The root of g in [0, |s_tr|/(2μ)] by bisection to round-off, `None` when the step is
    /// elastic (g(0) ≤ 0).
    fn multiplier(&self, flow: &FlowStress<'_>, norm: f64) -> Option<f64> {
        let g = |multiplier: f64| self.consistency(flow, norm, multiplier);
        if g(0.0) <= 0.0 {
            return None;
        }
        let (mut low, mut high) = (0.0, norm / (2.0 * self.shear_modulus));
        // Each halving gains a bit; 200 halvings reach adjacent floating-point numbers from
        // any bracket.
        for _ in 0..200 {
            let middle = 0.5 * (low + high);
            if middle <= low || middle >= high {
                break;
            }
            if g(middle) > 0.0 {
                low = middle;
            } else {
                high = middle;
            }
        }
        Some(0.5 * (low + high))
    }
}

impl StressModel for NeedlemanStress {
    type Parameters = NeedlemanInput;

    const DECLARATION: ModelDeclaration = ModelDeclaration {
        deck_name: "Viscoplastic Needleman Correspondence",
        aliases: &[],
        deck_keys: &[
            DENSITY,
            ELASTIC[0],
            ELASTIC[1],
            ELASTIC[2],
            ELASTIC[3],
            HOURGLASS_COEFFICIENT,
            YIELD_STRESS,
            STRAIN_HARDENING_EXPONENT,
            RATE_HARDENING_EXPONENT,
            REFERENCE_STRAIN_RATE,
            REFERENCE_STRAIN_0,
            REFERENCE_STRAIN_1,
            ENABLE_FLAW,
            FLAW_LOCATION[0],
            FLAW_LOCATION[1],
            FLAW_LOCATION[2],
            FLAW_SIZE,
            FLAW_MAGNITUDE,
            TANGENT,
            PROBE_LENGTH,
        ],
        reach: Reach::TwoHop,
        fields: super::CORRESPONDENCE_FIELDS,
        outputs: super::CORRESPONDENCE_OUTPUTS,
        tangent: TangentSupport::Differentiated,
        thermal_strain: false,
        small_displacement: false,
        example: "Density: 2.0\nBulk Modulus: 3.0\nShear Modulus: 1.7\nHourglass Coefficient: 0.05\nYield Stress: 0.002\nStrain Hardening Exponent: 0.2\nRate Hardening Exponent: 0.1\nReference Strain Rate: 1.0\nReference Strain 0: 0.01\nReference Strain 1: 1.0",
    };

    fn read(ctx: &mut Ctx, list: &mut ListReader) -> Result<NeedlemanInput, DeckError> {
        Ok(NeedlemanInput {
            yield_stress: list.positive_req(ctx, YIELD_STRESS.key)?,
            parameters: NeedlemanParameters {
                strain_hardening_exponent: list.f64_req(ctx, STRAIN_HARDENING_EXPONENT.key)?,
                rate_hardening_exponent: list.f64_req(ctx, RATE_HARDENING_EXPONENT.key)?,
                reference_strain_rate: list.positive_req(ctx, REFERENCE_STRAIN_RATE.key)?,
                reference_strain_0: list.positive_req(ctx, REFERENCE_STRAIN_0.key)?,
                reference_strain_1: list.positive_req(ctx, REFERENCE_STRAIN_1.key)?,
            },
            flaw: Flaw::read(ctx, list)?,
        })
    }

    fn new(elastic: &ElasticConstants, input: &NeedlemanInput) -> Result<Self, MaterialError> {
        let parameters = input.parameters;
        if !(parameters.rate_hardening_exponent.is_finite()
            && parameters.rate_hardening_exponent >= 0.0)
        {
            return Err(MaterialError::NotNonNegative {
                key: RATE_HARDENING_EXPONENT.key,
                value: parameters.rate_hardening_exponent,
            });
        }
        positive(REFERENCE_STRAIN_RATE.key, parameters.reference_strain_rate)?;
        positive(REFERENCE_STRAIN_0.key, parameters.reference_strain_0)?;
        positive(REFERENCE_STRAIN_1.key, parameters.reference_strain_1)?;
        Ok(Self {
            bulk_modulus: positive("Bulk Modulus", elastic.bulk_modulus)?,
            shear_modulus: positive("Shear Modulus", elastic.shear_modulus)?,
            yield_stress: positive(YIELD_STRESS.key, input.yield_stress)?,
            parameters,
            flaw: input.flaw,
        })
    }

    fn advance<T: Scalar>(
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
        let elastic = StressState {
            unrotated: trial,
            equivalent_plastic_strain: T::from(start.equivalent_plastic_strain),
        };
        let yield_stress = Flaw::reduced(self.flaw.as_ref(), self.yield_stress, step.position);
        let s = deviator(&trial);
        let norm = s.iter().fold(T::from(0.0), |sum, &x| sum + x * x).sqrt();
        let rate_dependent = self.parameters.rate_hardening_exponent > 0.0;
        if norm.re() / SQRT_TWO_THIRDS < yield_stress || (rate_dependent && step.duration <= 0.0) {
            return elastic;
        }
        let flow = FlowStress {
            parameters: &self.parameters,
            yield_stress,
            start_strain: start.equivalent_plastic_strain,
            duration: step.duration,
        };
        let Some(root) = self.multiplier(&flow, norm.re()) else {
            return elastic;
        };
        // Implicit function theorem: one Newton step on T from the converged root carries
        // dΔλ = −(∂g/∂s_tr)/(∂g/∂Δλ) into the scalar's derivative part.
        let slope = self
            .consistency(&flow, Dual64::from(norm.re()), Dual64::new(root, 1.0))
            .eps;
        // A flat g (softening exactly cancelling 2μ) has no unique root to differentiate:
        // the multiplier is then held fixed.
        let multiplier = if slope != 0.0 && slope.is_finite() {
            T::from(root) - self.consistency(&flow, norm, T::from(root)) / slope
        } else {
            T::from(root)
        };
        let scale = T::from(1.0) - multiplier * (2.0 * self.shear_modulus) / norm;
        let mean = trace(&trial) * (1.0 / 3.0);
        let mut unrotated = s.map(|x| x * scale);
        for k in 0..3 {
            unrotated[(k, k)] += mean;
        }
        StressState {
            unrotated,
            equivalent_plastic_strain: multiplier * SQRT_TWO_THIRDS
                + start.equivalent_plastic_strain,
        }
    }
}
