//! Surface correction: per-bond factors that restore the bulk stiffness of points whose
//! family is cut by a free surface.
//!
//! A material constant calibrated for a full horizon sphere (PMB's `c = 18K/(πδ⁴)`) makes a
//! point near a surface too soft: part of its sphere is empty. The correction multiplies the
//! quadrature volume of every bond by a factor g_ij ≥ 1 computed once at setup, so every
//! family sum of every material reads `g_ij · w_ij` through the one accessor
//! ([`crate::model::BondVolumes`]).
//!
//! # Force normalization (`"Force Normalization"`)
//! Macek & Silling, "Peridynamics via finite element analysis", Finite Elements in Analysis and
//! Design 43 (2007) 1169–1178, section "Force normalization at surfaces", eqs. (35)–(36): with
//! the stiffness tensor of a point held against its fixed neighbours,
//!
//! `P(X_i) = Σ_j C(ξ_ij) w_ij`, `C(ξ) = ξ⊗ξ/|ξ|³` (eq. 41 without the constant c),
//!
//! and p¹ its largest eigenvalue, the point's spring constant is scaled by
//! `g_i = p¹_∞ / p¹(X_i)` (eq. 36), where p¹_∞ is the same eigenvalue for a point deep inside
//! a large body. The paper's C is that of the proportional (bond-based) material; it is used
//! here for every material, since only the ratio enters.
//!
//! # The bulk value and the bond factor
//! The bulk value p¹_∞ of a point is summed over the simple cubic lattice of the
//! point's own spacing Δx = V_i^{1/3} with its horizon and its block's quadrature rule, every
//! lattice point within the rule's reach ([`QuadratureRule::family_reach`]). On a uniform grid
//! a point whose family is complete sums exactly the same terms, so its factor is 1 (to
//! round-off). On an irregular point cloud the lattice is a stand-in for the bulk, as the
//! partial-volume rules already assume cubic cells.
//!
//! A bond's factor is the mean of its two ends, `g_ij = (g_i + g_j)/2` — the paper's rule for
//! a spring joining two different spring constants (eq. 30). It is symmetric, so a rule with
//! `V_i w_ij = V_j w_ji` keeps it after the correction and momentum stays conserved. A point
//! of a block without correction has g = 1: bonds between two such points are unchanged.
//!
//! The family is taken as built: bond filters and `Omit Bonds Between Blocks` cut families and
//! so make surfaces the correction compensates; bonds broken later do not change the factors.
//!
//! For state-based materials (LPS and its relatives) the weighted volume m = Σ ω ζ² w already
//! rescales each family to its own size: the factors enter m and the force sums alike and
//! largely cancel. The correction is meant for bond-based materials.

use std::collections::HashMap;

use super::quadrature::QuadratureRule;
use super::{BondList, BondVolumes};

/// How a block corrects the stiffness of its points near surfaces
/// (`Blocks → … → Surface Correction`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SurfaceCorrection {
    /// No correction (the default).
    #[default]
    None,
    /// Macek & Silling's force normalization: ratio of the largest eigenvalues of the
    /// point-stiffness tensor P, bulk over the point's own.
    ForceNormalization,
}

/// The deck names of the corrections (`Blocks → … → Surface Correction`).
pub const CORRECTION_NAMES: [&str; 2] = ["None", "Force Normalization"];

impl SurfaceCorrection {
    /// The correction named `name` (one of [`CORRECTION_NAMES`]).
    pub fn from_deck_name(name: &str) -> Option<Self> {
        Some(match name {
            "None" => Self::None,
            "Force Normalization" => Self::ForceNormalization,
            _ => return None,
        })
    }

    /// The deck name.
    pub fn name(&self) -> &'static str {
        match self {
            Self::None => CORRECTION_NAMES[0],
            Self::ForceNormalization => CORRECTION_NAMES[1],
        }
    }

    /// True unless the correction is [`SurfaceCorrection::None`].
    pub fn is_active(&self) -> bool {
        !matches!(self, Self::None)
    }

    /// The quantity the correction compares (length²) of one family: its bonds' reference
    /// vectors `xi` with quadrature volumes `weight`.
    fn measure(&self, bonds: impl Iterator<Item = ([f64; 3], f64)>) -> f64 {
        match self {
            Self::None => 0.0,
            Self::ForceNormalization => {
                let mut p = nalgebra::Matrix3::<f64>::zeros();
                for (xi, w) in bonds {
                    let zeta2 = xi[0] * xi[0] + xi[1] * xi[1] + xi[2] * xi[2];
                    let scale = w / (zeta2 * zeta2.sqrt());
                    for a in 0..3 {
                        for b in 0..3 {
                            p[(a, b)] += scale * xi[a] * xi[b];
                        }
                    }
                }
                p.symmetric_eigenvalues().max()
            }
        }
    }

    /// The bulk value of [`Self::measure`]: every point of the simple cubic lattice of
    /// spacing `spacing` within `rule`'s reach, weighted by `rule` with horizon `horizon`.
    pub fn bulk_measure(&self, rule: QuadratureRule, horizon: f64, spacing: f64) -> f64 {
        let reach = rule.family_reach(horizon, spacing);
        let n = (reach / spacing).ceil() as i64;
        let cell = spacing * spacing * spacing;
        let mut lattice = Vec::new();
        for a in -n..=n {
            for b in -n..=n {
                for c in -n..=n {
                    let xi = [a, b, c].map(|v| v as f64 * spacing);
                    let zeta2 = xi[0] * xi[0] + xi[1] * xi[1] + xi[2] * xi[2];
                    if zeta2 > 0.0 && zeta2 <= reach * reach {
                        lattice.push((xi, rule.bond_volume(xi, horizon, cell).volume));
                    }
                }
            }
        }
        self.measure(lattice.into_iter())
    }
}

/// What the correction computed, for `peridyn check`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CorrectionSummary {
    /// Points of corrected blocks whose factor differs from 1 by more than 1e-9.
    pub corrected_points: usize,
    /// The smallest and largest point factor g_i over corrected blocks.
    pub factor_range: [f64; 2],
}

/// The point factors g_i: `correction_of_point[i]`'s bulk measure over the measure of i's
/// family (with the quadrature volumes `volumes`), 1 for points of uncorrected blocks and
/// points without bonds. `rule_of_point[i]`, `horizon_of_point[i]` and `cell_volume[i]` give
/// the bulk lattice of point i.
pub fn point_factors(
    bonds: &BondList,
    position: &[[f64; 3]],
    volumes: BondVolumes<'_>,
    correction_of_point: &[SurfaceCorrection],
    rule_of_point: &[QuadratureRule],
    horizon_of_point: &[f64],
    cell_volume: &[f64],
) -> Vec<f64> {
    // One bulk lattice sum per distinct (correction, rule, horizon, cell volume).
    let mut bulk: HashMap<(u8, u8, [u64; 3]), f64> = HashMap::new();
    (0..bonds.num_points())
        .map(|i| {
            let correction = correction_of_point[i];
            if !correction.is_active() || bonds.range(i).is_empty() {
                return 1.0;
            }
            let rule = rule_of_point[i];
            let (rule_tag, tolerance) = rule.cache_key();
            let key = (
                correction as u8,
                rule_tag,
                [horizon_of_point[i], cell_volume[i], tolerance].map(f64::to_bits),
            );
            let reference = *bulk.entry(key).or_insert_with(|| {
                correction.bulk_measure(rule, horizon_of_point[i], cell_volume[i].cbrt())
            });
            let own = correction.measure(bonds.range(i).map(|b| {
                let j = bonds.neighbor[b] as usize;
                (
                    [0, 1, 2].map(|k| position[j][k] - position[i][k]),
                    volumes.of(b, j),
                )
            }));
            if own > 0.0 {
                reference / own
            } else {
                1.0
            }
        })
        .collect()
}

/// Multiplies every bond's quadrature volume `weights[b]` by `(g_i + g_j)/2` (`factor` per
/// point).
pub fn scale_bond_volumes(bonds: &BondList, factor: &[f64], weights: &mut [f64]) {
    for i in 0..bonds.num_points() {
        for b in bonds.range(i) {
            let j = bonds.neighbor[b] as usize;
            weights[b] *= 0.5 * (factor[i] + factor[j]);
        }
    }
}

/// The summary of `factor` over the points whose correction is active.
pub fn summarize(factor: &[f64], correction_of_point: &[SurfaceCorrection]) -> CorrectionSummary {
    let mut summary = CorrectionSummary {
        corrected_points: 0,
        factor_range: [f64::INFINITY, f64::NEG_INFINITY],
    };
    for (g, c) in factor.iter().zip(correction_of_point) {
        if c.is_active() {
            summary.corrected_points += usize::from((g - 1.0).abs() > 1e-9);
            summary.factor_range = [
                summary.factor_range[0].min(*g),
                summary.factor_range[1].max(*g),
            ];
        }
    }
    summary
}

#[cfg(test)]
mod tests;
