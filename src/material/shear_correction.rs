//! The pointwise shear-correction factor of the ordinary state-based models (Peridigm's
//! `Apply Shear Correction Factor`, Mitchell's `computeShearCorrectionFactor`), used by
//! `Elastic Plastic Hardening` (on by default) and, when a deck asks for it, `Elastic`.
//!
//! **What it corrects.** The deviatoric modulus of the LPS, α = 15μ/m, is calibrated on the
//! continuum sphere: for a pure shear ε_ab = ε_ba = γ (a ≠ b) the extension of a bond ξ is
//! e = 2γ ξ_a ξ_b/ζ to first order, θ = 0, and `∫ ω ζ² n_a² n_b² dV = m/15` for any radial ω,
//! so `‖e^d‖² = Σ_j ω (e^d)² V_j = 4γ²m/15` and the stored energy `(α/2)‖e^d‖² = 2μγ²` is the
//! continuum's μ ε:ε. A real neighbourhood (a lattice cut by the horizon, a point near a free
//! surface) has sums that differ from the integrals: its `‖e^d‖²` is `c · 4γ²m/15`, so the
//! point's shear modulus is c μ instead of μ. The factor
//!
//! `s = 4γ²m / (15 · max_modes ‖e^d‖²)`
//!
//! probes each neighbourhood with the three pure shears xy, yz, zx of amplitude γ = 1e-6
//! (centred on the point, the point itself not displaced, extensions from the deformed
//! lengths) and takes the stiffest mode; multiplying α by s makes that mode's shear modulus μ
//! again (and the other modes at most μ). s = 1 in the continuum.
//!
//! **Difference from Peridigm.** Peridigm computes the same s and then uses its inverse,
//! 1/s, on α and 1/s² on ψ₀ (its source questions this inversion in a note). That turns a
//! shear modulus c μ into c² μ instead of μ, so it is not used here: α is multiplied by s, and
//! the yield value ψ₀ of the plastic model by s, which keeps the probed mode's yield at the
//! von Mises shear stress σ_y/√3 (the yield condition `α²s²‖e^d‖²/2 = sψ₀` with
//! `‖e^d‖² = (4γ²m/15)/s` is the continuum's `α²(4γ²m/15)/2 = ψ₀`).

use rayon::prelude::*;

use super::ReferenceView;

/// γ of the probing pure shears (Peridigm's value).
pub const PROBE_SHEAR: f64 = 1e-6;

/// The three probing pure shears, as the pairs of axes (a, b) with u_a = γ ξ_b and u_b = γ ξ_a.
const MODES: [(usize, usize); 3] = [(0, 1), (1, 2), (2, 0)];

/// The factor s of every point of `points` (module docs), in the order of `points`, from the
/// reference configuration, the points' weighted volumes m (same order) and, when ω is not 1,
/// ω of every bond of the points' rows in block-local order (`weights`, rows starting at
/// `local_offsets`). Bond damage does not enter (the factor is a property of the
/// reference neighbourhood). A point without bonds, or whose neighbourhood has no shear
/// stiffness at all, gets s = 1.
pub fn factors(
    reference: &ReferenceView<'_>,
    points: &[u32],
    weighted_volume: &[f64],
    weights: Option<(&[f64], &[usize])>,
) -> Vec<f64> {
    let bonds = reference.bonds;
    points
        .par_iter()
        .enumerate()
        .map(|(k, &i)| {
            let i = i as usize;
            let m = weighted_volume[k];
            if m <= 0.0 {
                return 1.0;
            }
            let omega = |n: usize| weights.map_or(1.0, |(w, offsets)| w[offsets[k] + n]);
            let x = reference.position[i];
            let stiffest = MODES
                .iter()
                .map(|&(a, b)| {
                    // Extension of each bond under the mode: the deformed bond is ξ + u(ξ).
                    let extension = |bond: usize| {
                        let j = bonds.neighbor[bond] as usize;
                        let xi = [0, 1, 2].map(|c| reference.position[j][c] - x[c]);
                        let mut y = xi;
                        y[a] += PROBE_SHEAR * xi[b];
                        y[b] += PROBE_SHEAR * xi[a];
                        let length = (y[0] * y[0] + y[1] * y[1] + y[2] * y[2]).sqrt();
                        (length - bonds.reference_length[bond], j)
                    };
                    let mut theta = 0.0;
                    for (n, bond) in bonds.range(i).enumerate() {
                        let (e, j) = extension(bond);
                        theta += omega(n)
                            * bonds.reference_length[bond]
                            * e
                            * reference.neighbor_volume(bond, j);
                    }
                    let theta = 3.0 * theta / m;
                    let mut norm = 0.0;
                    for (n, bond) in bonds.range(i).enumerate() {
                        let (e, j) = extension(bond);
                        let deviatoric = e - theta * bonds.reference_length[bond] / 3.0;
                        norm +=
                            omega(n) * deviatoric * deviatoric * reference.neighbor_volume(bond, j);
                    }
                    norm
                })
                .fold(0.0, f64::max);
            if stiffest > 0.0 {
                4.0 * PROBE_SHEAR * PROBE_SHEAR * m / (15.0 * stiffest)
            } else {
                1.0
            }
        })
        .collect()
}
