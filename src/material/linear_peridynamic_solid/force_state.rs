//! The LPS force state of one point from its family's positions alone, which the tangent
//! assembly and the partial stress differentiate and sum (the parent module's formulas).

use super::corrected_shear;
use crate::material::{BondWeights, Integrity};
use crate::model::BondVolumes;
use crate::tangent::{ForceState, OrdinaryBond, PointIndex, Scalar};

/// The LPS force state of one point for the tangent, from its family's positions alone:
/// `θ = (3/m) Σ_n ω (1−d) ζ e V_j`, `t_n = (1−d) ω [A ζ + (1−d) B e]` with
/// `A = (3K − 5μ) θ/m`, `B = 15μ/m`, and `T_n = t_n M_n` (the module docs' formulas).
pub(super) struct LpsForceState<'a, W, D> {
    pub(super) bonds: &'a crate::model::BondList,
    pub(super) volume: BondVolumes<'a>,
    pub(super) local_offsets: &'a [usize],
    pub(super) weighted_volume: &'a [f64],
    pub(super) weights: W,
    pub(super) damage: D,
    pub(super) bulk: f64,
    pub(super) shear: f64,
    /// The free thermal strain α ΔT of every point (module docs), when the block has α and
    /// the run has point temperatures.
    pub(super) thermal_strain: Option<&'a [f64]>,
    /// s per block point, or empty (s = 1).
    pub(super) correction: &'a [f64],
}

impl<W: BondWeights, D: Integrity> LpsForceState<'_, W, D> {
    /// e = |Y| − ζ, less the free thermal strain ε_i ζ when there is one.
    #[inline(always)]
    fn extension<T: Scalar>(&self, point: PointIndex, length: T, zeta: f64) -> T {
        match self.thermal_strain {
            None => length - zeta,
            Some(strain) => length - zeta - strain[point.global] * zeta,
        }
    }

    /// m, (3K − 5μ)/m and 15μ/m of the point (μ times its shear-correction factor, if any);
    /// `None` when m = 0 (no force).
    fn moduli(&self, point: PointIndex) -> Option<(f64, f64, f64)> {
        let m = self.weighted_volume[point.local];
        let shear = corrected_shear(self.shear, self.correction, point.local);
        (m > 0.0).then(|| (m, (3.0 * self.bulk - 5.0 * shear) / m, 15.0 * shear / m))
    }
}

impl<W: BondWeights, D: Integrity> ForceState for LpsForceState<'_, W, D> {
    const BOND_LOCAL: bool = false;
    const ANALYTIC: bool = true;

    fn force_state<T: Scalar>(
        &self,
        point: PointIndex,
        y: &[[T; 3]],
        _only: Option<usize>,
        t: &mut [[T; 3]],
    ) {
        let range = self.bonds.range(point.global);
        let zero = T::from(0.0);
        let Some((m, isotropic_per_theta, deviatoric)) = self.moduli(point) else {
            t.fill([zero; 3]);
            return;
        };
        let local = self.local_offsets[point.local];
        // Pass 1: θ; each bond's length and extension are kept in t[n] for pass 2.
        let mut sum = zero;
        for (n, b) in range.clone().enumerate() {
            let zeta = self.bonds.reference_length[b];
            let d = [0, 1, 2].map(|k| y[n + 1][k] - y[0][k]);
            let squared = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            // A zero length has no derivative; the force kernel gives such a bond no force.
            let length = if squared.re() > 0.0 {
                squared.sqrt()
            } else {
                zero
            };
            let extension = self.extension(point, length, zeta);
            let j = self.bonds.neighbor[b] as usize;
            sum += extension
                * (self.weights.weight(local + n)
                    * self.damage.intact(b)
                    * zeta
                    * self.volume.of(b, j));
            t[n] = [length, extension, zero];
        }
        let theta = sum * (3.0 / m);
        let isotropic = theta * isotropic_per_theta;
        for (n, b) in range.enumerate() {
            let [length, extension, _] = t[n];
            t[n] = if length.re() > 0.0 {
                let zeta = self.bonds.reference_length[b];
                let intact = self.damage.intact(b);
                let scalar = (isotropic * zeta + extension * (intact * deviatoric))
                    * (intact * self.weights.weight(local + n));
                let scale = scalar / length;
                [0, 1, 2].map(|k| (y[n + 1][k] - y[0][k]) * scale)
            } else {
                [zero; 3]
            };
        }
    }

    /// `axial = (1−d)² ω B`, `lateral = t_n/|Y|`, `γ_n = ∂t_n/∂θ = (1−d) ω ζ (3K − 5μ)/m`,
    /// `β_n = ∂θ/∂e_n = (3/m) ω (1−d) ζ V_j`.
    fn ordinary_derivatives(&self, point: PointIndex, y: &[[f64; 3]], out: &mut [OrdinaryBond]) {
        let range = self.bonds.range(point.global);
        let Some((m, isotropic_per_theta, deviatoric)) = self.moduli(point) else {
            out.fill(OrdinaryBond::default());
            return;
        };
        let local = self.local_offsets[point.local];
        // Pass 1: θ, with each bond's length kept in `lateral` and extension in `axial`.
        let mut sum = 0.0;
        for ((n, b), bond) in range.clone().enumerate().zip(out.iter_mut()) {
            let zeta = self.bonds.reference_length[b];
            let d = [0, 1, 2].map(|k| y[n + 1][k] - y[0][k]);
            let length = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let extension = self.extension(point, length, zeta);
            let j = self.bonds.neighbor[b] as usize;
            let factor = self.weights.weight(local + n)
                * self.damage.intact(b)
                * zeta
                * self.volume.of(b, j);
            sum += factor * extension;
            *bond = OrdinaryBond {
                direction: if length > 0.0 {
                    d.map(|c| c / length)
                } else {
                    [0.0; 3]
                },
                axial: extension,
                lateral: length,
                coupling: 0.0,
                weight: 3.0 / m * factor,
            };
        }
        let theta = 3.0 * sum / m;
        let isotropic = theta * isotropic_per_theta;
        for ((n, b), bond) in range.enumerate().zip(out.iter_mut()) {
            let (extension, length) = (bond.axial, bond.lateral);
            if length <= 0.0 {
                // No direction, no force, no derivative (as the force kernel).
                *bond = OrdinaryBond::default();
                continue;
            }
            let zeta = self.bonds.reference_length[b];
            let intact = self.damage.intact(b);
            let omega = self.weights.weight(local + n);
            let scalar = intact * omega * (isotropic * zeta + intact * deviatoric * extension);
            bond.axial = intact * intact * omega * deviatoric;
            bond.lateral = scalar / length;
            bond.coupling = intact * omega * zeta * isotropic_per_theta;
        }
    }
}
