//! Peridigm's `Elastic Plastic Hardening`: Mitchell's ordinary state-based plasticity
//! ([`super::ElasticPlastic`], whose kernel, fields, force pass and tangent it shares) with
//! linear isotropic hardening and, by default, the pointwise shear-correction factor
//! (`super::super::shear_correction`).
//!
//! **Yield function with hardening.** With the accumulated plastic multiplier λ (Peridigm's
//! `Lambda`) the yield surface grows linearly,
//!
//! `f(t^d, λ) = ‖t^d‖²/2 − ψ(λ)`, `ψ(λ) = ψ₀ + H λ`,
//!
//! ψ₀ from the yield stress as in `Elastic Plastic` (`25σ_y²/(8πδ⁵)`, times the factor s when
//! the shear correction is on) and H the deck's `Hardening Modulus` (units of ψ per unit of λ,
//! used as Peridigm reads it). The flow rule is the same, `Δe^{dp} = Δλ t^d`, so a step from
//! the committed e^{dp}_n, λ_n with trial force `t^d_tr = α(e^d − e^{dp}_n)` gives
//!
//! `t^d = α(e^d − e^{dp}_n − Δλ t^d) = t^d_tr − αΔλ t^d`, i.e. `t^d = t^d_tr/(1 + αΔλ)`,
//!
//! and the consistency condition `‖t^d‖²/2 = ψ₀ + H(λ_n + Δλ)` becomes, with
//! `T = ‖t^d_tr‖²/2` and `P = ψ₀ + Hλ_n`,
//!
//! `(P + HΔλ)(1 + αΔλ)² = T`,
//!
//! a cubic in Δλ. Its left side grows strictly for Δλ ≥ 0 and is P < T at Δλ = 0 when the
//! trial state is outside the surface, so it has exactly one positive root, the smallest. In
//! the variable z = 1/(1 + αΔλ) ∈ (0, 1] (the factor t^d = z t^d_tr) and with h = H/α it is the
//! depressed cubic
//!
//! `T z³ − (P − h) z − h = 0`,
//!
//! whose root in (0, 1] is its largest real root (three real roots sum to 0, so a root above
//! 1 would need two and leave the third negative), solved in closed form (Cardano when the
//! discriminant is positive, the trigonometric form otherwise) and polished by one Newton step
//! on the same cubic. The Newton step also carries the derivative of the root for the
//! automatic-differentiation tangent: from the root z₀ of the values, `z = z₀ − φ(z₀)/φ'(z₀)`
//! evaluated in dual numbers has value z₀ and derivative `−∂φ/∂T · dT / φ'`, the implicit
//! derivative of the root. Then `Δλ = (1/z − 1)/α`.
//!
//! **H = 0** makes the cubic the quadratic `P(1 + αΔλ)² = T`, i.e. `Δλ = (‖t^d_tr‖/√(2ψ₀) −
//! 1)/α` and `t^d = √(2ψ₀) t^d_tr/‖t^d_tr‖`: `Elastic Plastic`'s return map, which the kernel
//! then runs itself (Peridigm's cubic divides by H and has no H = 0 case).
//!
//! Differences from Peridigm: the shear-correction factor is s, not Peridigm's 1/s (see the
//! shear-correction module), and it scales ψ₀ by s rather than s²; the tangent is automatic
//! differentiation by default (Peridigm: finite differences unless `Apply Automatic
//! Differentiation Jacobian: true`), since it is the exact derivative of the same return map.

use super::{ElasticPlastic, PlasticityInput, DISABLE_PLASTICITY, FIELDS, YIELD_STRESS};
use crate::material::keys::{
    non_negative_req, AUTOMATIC_DIFFERENTIATION, DENSITY, ELASTIC, PROBE_LENGTH, TANGENT,
};
use crate::material::{BlockInput, Material, MaterialError, MaterialKeys, MaterialModel};
use crate::model::{KeyDoc, ModelDeclaration, Reach, TangentSupport};
use crate::parameter_list::error::DeckError;
use crate::parameter_list::reader::{Ctx, ListReader};
use crate::tangent::Scalar;

/// `Hardening Modulus`.
const HARDENING_MODULUS: KeyDoc = KeyDoc {
    key: "Hardening Modulus",
    meaning: "H of the yield surface ψ₀ + Hλ (units of ψ per unit of λ, as Peridigm reads it)",
    unit: "force³/length¹⁶",
    default: "required",
};

/// `Apply Shear Correction Factor` of `Elastic Plastic Hardening`.
const SHEAR_CORRECTION: KeyDoc = KeyDoc {
    key: "Apply Shear Correction Factor",
    meaning: "scale α and ψ₀ pointwise by the shear-correction factor s of the neighbourhood",
    unit: "true/false",
    default: "true",
};

/// `Elastic Plastic Hardening` (module docs): an [`ElasticPlastic`] with a hardening modulus
/// and the shear-correction factor.
pub struct ElasticPlasticHardening;

impl MaterialKeys for ElasticPlasticHardening {
    type Parameters = PlasticityInput;

    /// `Elastic Plastic Hardening`: the fields and reach of `Elastic Plastic`.
    const DECLARATION: ModelDeclaration = ModelDeclaration {
        deck_name: "Elastic Plastic Hardening",
        aliases: &[],
        deck_keys: &[
            DENSITY,
            ELASTIC[0],
            ELASTIC[1],
            ELASTIC[2],
            ELASTIC[3],
            YIELD_STRESS,
            HARDENING_MODULUS,
            DISABLE_PLASTICITY,
            SHEAR_CORRECTION,
            TANGENT,
            AUTOMATIC_DIFFERENTIATION,
            PROBE_LENGTH,
        ],
        reach: Reach::TwoHop,
        fields: FIELDS,
        outputs: &["Weighted_Volume", "Dilatation", "Lambda"],
        tangent: TangentSupport::Differentiated,
        thermal_strain: false,
        small_displacement: false,
        example: "Density: 2.0\nBulk Modulus: 3.0\nShear Modulus: 1.0\nYield Stress: 0.001\nHardening Modulus: 1.0e-8",
    };

    fn read(ctx: &mut Ctx, list: &mut ListReader) -> Result<PlasticityInput, DeckError> {
        let elastic = crate::material::elastic_constants::read(ctx, list)?;
        Ok(PlasticityInput {
            elastic,
            yield_stress: list.positive_req(ctx, YIELD_STRESS.key)?,
            hardening_modulus: non_negative_req(ctx, list, HARDENING_MODULUS.key)?,
            disabled: list.bool_or(ctx, DISABLE_PLASTICITY.key, false)?,
            planar_thickness: None,
            shear_correction: list.bool_or(ctx, SHEAR_CORRECTION.key, true)?,
        })
    }
}

impl MaterialModel for ElasticPlasticHardening {
    fn build(
        block: &BlockInput,
        parameters: &PlasticityInput,
    ) -> Result<Box<dyn Material>, MaterialError> {
        Ok(Box::new(Self::material(block, parameters)?))
    }
}

impl ElasticPlasticHardening {
    /// The model as an [`ElasticPlastic`] (validated as `Elastic Plastic`, and H finite and
    /// ≥ 0).
    pub fn material(
        block: &BlockInput,
        parameters: &PlasticityInput,
    ) -> Result<ElasticPlastic, MaterialError> {
        ElasticPlastic::of_model(&Self::DECLARATION, block, parameters)
    }
}

/// The factor z = 1/(1 + αΔλ) of a plastic step with hardening (module docs): the root in
/// (0, 1] of `T z³ − (P − h) z − h = 0`, with `trial` = T = ‖t^d_tr‖²/2 (any scalar: its
/// derivative is carried through), `surface` = P = sψ₀ + Hλ_n < T and `h` = H/α > 0.
pub(super) fn return_scale<T: Scalar>(trial: T, surface: f64, h: f64) -> T {
    let z = largest_root(trial.re(), surface, h);
    let a = surface - h;
    let residual = trial * (z * z * z) - (a * z + h);
    let slope = trial * (3.0 * z * z) - a;
    -(residual / slope) + z
}

/// The largest real root of `t z³ − a z − h = 0` (a = P − h), t > 0, in closed form: the
/// depressed cubic `z³ + pz + q = 0` with p = −a/t, q = −h/t.
fn largest_root(t: f64, surface: f64, h: f64) -> f64 {
    let p = -(surface - h) / t;
    let q = -h / t;
    let discriminant = (q / 2.0).powi(2) + (p / 3.0).powi(3);
    if discriminant > 0.0 {
        // One real root (Cardano), A + B with A = ∛(−q/2 + √D) > 0 (no cancellation: −q/2 > 0)
        // and B = −p/(3A).
        let first = (-q / 2.0 + discriminant.sqrt()).cbrt();
        first - p / (3.0 * first)
    } else {
        // Three real roots (p < 0): 2√(−p/3) cos(φ/3 − 2πk/3), the largest at k = 0.
        let r = (-p / 3.0).sqrt();
        let cosine = ((3.0 * q) / (2.0 * p) * (-3.0 / p).sqrt()).clamp(-1.0, 1.0);
        2.0 * r * (cosine.acos() / 3.0).cos()
    }
}

#[cfg(test)]
#[path = "hardening_tests.rs"]
mod tests;
