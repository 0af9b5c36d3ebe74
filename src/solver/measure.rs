//! What a Newton solve compares with its tolerance: the convergence measures of Peridigm's
//! solvers and of NOX, over the residual of the unknowns.

use crate::solver::implicit::DofMap;

/// The scalar that is compared with the tolerance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ConvergenceMeasure {
    /// Peridigm's `QuasiStatic` measure `‖r‖₂ + 20‖r‖∞` (force units).
    PeridigmQuasiStatic,
    /// `‖r‖₂` (force units), NOX's `NormF`.
    TwoNorm,
    /// Peridigm's Newmark measure `βΔt²·‖r_k/V‖₂`: the residual in force-density units scaled
    /// by βΔt², whose value is `scale = βΔt²`.
    ForceDensity {
        /// βΔt².
        scale: f64,
    },
}

impl ConvergenceMeasure {
    /// The measure of `residual` over the unknowns `dofs`.
    pub fn of(&self, residual: &[f64], dofs: &DofMap, volume: &[f64]) -> f64 {
        match *self {
            ConvergenceMeasure::PeridigmQuasiStatic => {
                norm2(residual) + 20.0 * residual.iter().fold(0.0f64, |m, r| m.max(r.abs()))
            }
            ConvergenceMeasure::TwoNorm => norm2(residual),
            ConvergenceMeasure::ForceDensity { scale } => {
                let sum: f64 = residual
                    .iter()
                    .zip(&dofs.free)
                    .map(|(r, &dof)| (r / volume[dof / 3]).powi(2))
                    .sum();
                scale * sum.sqrt()
            }
        }
    }
}

/// Euclidean norm.
pub fn norm2(values: &[f64]) -> f64 {
    values.iter().map(|v| v * v).sum::<f64>().sqrt()
}
