//! ∂f/∂u: the tangent stiffness in 3×3 blocks per point pair, its sparsity pattern and its
//! conversion to the scalar [`Csr`](crate::backend::Csr) the backends solve with.
//!
//! # What is assembled
//! The residual of point i is `r_i = V_i (f_i + b_i)` (force); the tangent is its Jacobian
//! with respect to the displacement, `J_ij = ∂(V_i f_i)/∂u_j` (force/length), stored as one
//! 3×3 block per entry of a [`BlockPattern`] in a [`BlockTangent`]. For an elastic material
//! J is symmetric and negative semi-definite (zero on rigid motions); the implicit solvers
//! hand `K = −J` to the linear solver ([`BlockTangent::to_csr`] with scale −1).
//!
//! J is evaluated at the current positions with the bond damage as it is (damage is not
//! differentiated: a bond breaks between iterations, not inside one).
//!
//! # How (per block, [`TangentMethod`])
//! Each material writes its force state T⟨x_i⟩ once, generically over the scalar type
//! (`f64` or a forward-mode dual number), so that
//! * [`TangentMethod::AutomaticDifferentiation`] differentiates it exactly (3 dual evaluations
//!   per family point, `num-dual`);
//! * [`TangentMethod::FiniteDifference`] perturbs each family dof by ±ε (central differences,
//!   Algorithm 3 of Littlewood's "Roadmap for Software Implementation", 2016; Peridigm's
//!   default probe ε = 1e-6 × the smallest
//!   element radius (3V/4π)^(1/3));
//! * [`TangentMethod::Analytic`] uses the closed form the material writes out (PMB and LPS).
//!
//! The per-point derivatives are scattered into the pattern in parallel (see `assembly`).
//! The entry point is [`crate::physics::Physics::tangent`].

mod assembly;
mod matrix;
mod pattern;

pub(crate) use assembly::{assemble, ForceState, OrdinaryBond, PointIndex, Scalar};
pub use matrix::BlockTangent;
pub use pattern::BlockPattern;

/// One 3×3 block: `block[k][l]` = ∂(force component k)/∂(displacement component l).
pub type Block = [[f64; 3]; 3];

/// How a block's tangent is computed (deck: `Tangent`, or Peridigm's
/// `Apply Automatic Differentiation Jacobian`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TangentMethod {
    /// The closed-form derivative of the material's force state (PMB, LPS). The default for
    /// materials that have one.
    Analytic,
    /// Forward-mode automatic differentiation of the force state (exact to round-off).
    /// Peridigm's default for `Elastic`.
    AutomaticDifferentiation,
    /// Central differences of the force state, ±`probe` on every family dof (Peridigm's
    /// default for every model without AD, e.g. `Elastic Bond Based`).
    FiniteDifference {
        /// ε (length), `Finite Difference Probe Length`; `None` = 1e-6 × the smallest element
        /// radius (3V/4π)^(1/3) over all points, as Peridigm.
        probe: Option<f64>,
    },
}

impl TangentMethod {
    /// The deck spelling of `Tangent` for this method.
    pub fn deck_name(&self) -> &'static str {
        match self {
            TangentMethod::Analytic => "Analytic",
            TangentMethod::AutomaticDifferentiation => "Automatic Differentiation",
            TangentMethod::FiniteDifference { .. } => "Finite Difference",
        }
    }
}

/// Why a tangent could not be assembled.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TangentError {
    /// `Analytic` was asked of a material that has no closed-form tangent.
    #[error(
        "material model \"{model}\" has no analytic tangent; set `Tangent: \"Automatic \
         Differentiation\"` or `Tangent: \"Finite Difference\"` in its material list"
    )]
    NoAnalytic {
        /// Peridigm's `Material Model` string.
        model: &'static str,
    },
    /// The material provides no tangent at all (explicit dynamics only).
    #[error(
        "material model \"{model}\" provides no tangent stiffness, so implicit solvers cannot \
         use it; run it with an explicit solver"
    )]
    Unsupported {
        /// Peridigm's `Material Model` string.
        model: &'static str,
    },
    /// A derivative came out NaN or infinite (e.g. two points pushed onto each other).
    #[error(
        "the tangent stiffness of the force state of point {point} (run order{}) is not finite; \
         the deformation is probably extreme (points pushed onto each other): reduce the load step",
        match input_id { Some(id) => format!(", input id {id}"), None => String::new() }
    )]
    NonFinite {
        /// Run-order index of the point whose force state gave the value.
        point: usize,
        /// The point's 1-based input id (mesh / text-file numbering), when known.
        input_id: Option<usize>,
    },
    /// The pattern lacks a block the material writes (a pattern built for bond-based materials
    /// used with a state-based one). A bug of the caller: use
    /// [`crate::physics::Physics::tangent_pattern`].
    #[error(
        "the tangent pattern has no block ({row}, {column}); build it with \
         Physics::tangent_pattern for these materials"
    )]
    PatternTooSmall {
        /// Block row (point).
        row: usize,
        /// Block column (point).
        column: usize,
    },
    /// A finite-difference probe length that is not a positive finite number.
    #[error("`Finite Difference Probe Length` must be a positive finite number, got {value}")]
    InvalidProbe {
        /// The probe ε.
        value: f64,
    },
}

#[cfg(test)]
mod tests;
