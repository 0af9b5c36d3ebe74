//! The return map of the elastic-plastic LPS (the parent module's docs), over any scalar: the
//! force uses f64, the tangent dual numbers.

use super::hardening;
use crate::model::{BondList, BondVolumes};
use crate::tangent::{PointIndex, Scalar};

/// What the return map reads, over any scalar (the force uses f64, the tangent dual numbers).
#[derive(Clone, Copy)]
pub(super) struct Kernel<'a> {
    pub(super) bonds: &'a BondList,
    pub(super) volume: BondVolumes<'a>,
    pub(super) damage: Option<&'a [f32]>,
    pub(super) weighted_volume: &'a [f64],
    pub(super) bulk_modulus: f64,
    pub(super) shear_modulus: f64,
    pub(super) yield_value: Option<f64>,
    /// H (0: perfect plasticity).
    pub(super) hardening_modulus: f64,
    /// s per block point, or empty (s = 1).
    pub(super) correction: &'a [f64],
    /// λ_n, the committed plastic multiplier of every point (read only when H > 0).
    pub(super) lambda: &'a [f64],
}

/// A bond seen from its point: deformed length |Y| (0 for coincident points, which carry no
/// force) and extension e = |Y| − ζ.
#[derive(Clone, Copy)]
pub(super) struct Stretch<T> {
    pub(super) length: T,
    pub(super) extension: T,
}

/// The outcome of the return map at one point.
#[derive(Clone, Copy, Debug)]
pub(super) struct PointResponse<T> {
    /// θ.
    pub(super) dilatation: T,
    /// 1 in an elastic step, 1/(1 + αΔλ) in a plastic one (t^d = scale · t^d_tr;
    /// √(2ψ₀)/‖t^d_tr‖ without hardening).
    pub(super) scale: T,
    /// Δλ (0 in an elastic step).
    pub(super) delta_lambda: T,
}

impl Kernel<'_> {
    pub(super) fn intact(&self, b: usize) -> f64 {
        self.damage.map_or(1.0, |d| 1.0 - f64::from(d[b]))
    }

    /// The stretch of the n-th bond `b` of the point whose family is at `y`.
    pub(super) fn stretch<T: Scalar>(&self, y: &[[T; 3]], n: usize, b: usize) -> Stretch<T> {
        let d = [0, 1, 2].map(|k| y[n + 1][k] - y[0][k]);
        let squared = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        // A zero length has no derivative; such a bond carries no force.
        let length = if squared.re() > 0.0 {
            squared.sqrt()
        } else {
            T::from(0.0)
        };
        Stretch {
            length,
            extension: length - self.bonds.reference_length[b],
        }
    }

    /// α = s·15μ/m of `point` (s = 1 without shear correction); `None` when m = 0 (no bonds:
    /// no force).
    pub(super) fn alpha(&self, point: PointIndex) -> Option<f64> {
        let m = self.weighted_volume[point.local];
        (m > 0.0).then(|| {
            let alpha = 15.0 * self.shear_modulus / m;
            match self.correction.get(point.local) {
                Some(s) => s * alpha,
                None => alpha,
            }
        })
    }

    /// The yield value of `point` at the start of the step, s·ψ₀ + Hλ_n; `None` without
    /// plasticity.
    fn yield_surface(&self, point: PointIndex) -> Option<f64> {
        let psi = self.yield_value?;
        let psi = match self.correction.get(point.local) {
            Some(s) => s * psi,
            None => psi,
        };
        Some(if self.hardening_modulus > 0.0 {
            psi + self.hardening_modulus * self.lambda[point.global]
        } else {
            psi
        })
    }

    /// θ = (3/m) Σ (1−d) ζ e V_j (m > 0).
    pub(super) fn dilatation<T: Scalar>(&self, point: PointIndex, y: &[[T; 3]]) -> T {
        let mut sum = T::from(0.0);
        for (n, b) in self.bonds.range(point.global).enumerate() {
            let zeta = self.bonds.reference_length[b];
            let j = self.bonds.neighbor[b] as usize;
            sum += self.stretch(y, n, b).extension * (self.intact(b) * zeta * self.volume.of(b, j));
        }
        sum * (3.0 / self.weighted_volume[point.local])
    }

    /// t^d_tr = α (e − θζ/3 − e^{dp}_n) of bond `b`.
    pub(super) fn trial_deviatoric<T: Scalar>(
        alpha: f64,
        stretch: &Stretch<T>,
        theta: T,
        zeta: f64,
        plastic: f64,
    ) -> T {
        (stretch.extension - theta * (zeta / 3.0) - plastic) * alpha
    }

    /// The return map of `point` (family at `y`) from the committed plastic extension of its
    /// row, `plastic` (module docs).
    pub(super) fn respond<T: Scalar>(
        &self,
        point: PointIndex,
        y: &[[T; 3]],
        alpha: f64,
        plastic: &[f64],
    ) -> PointResponse<T> {
        let theta = self.dilatation(point, y);
        let elastic = PointResponse {
            dilatation: theta,
            scale: T::from(1.0),
            delta_lambda: T::from(0.0),
        };
        let Some(psi) = self.yield_surface(point) else {
            return elastic;
        };
        let mut squared = T::from(0.0);
        for (n, b) in self.bonds.range(point.global).enumerate() {
            let zeta = self.bonds.reference_length[b];
            let j = self.bonds.neighbor[b] as usize;
            let trial =
                Self::trial_deviatoric(alpha, &self.stretch(y, n, b), theta, zeta, plastic[n])
                    * self.intact(b);
            squared += trial * trial * self.volume.of(b, j);
        }
        if squared.re() * 0.5 <= psi {
            return elastic;
        }
        if self.hardening_modulus > 0.0 {
            let scale = hardening::return_scale(squared * 0.5, psi, self.hardening_modulus / alpha);
            return PointResponse {
                dilatation: theta,
                scale,
                delta_lambda: (scale.recip() - 1.0) * (1.0 / alpha),
            };
        }
        let norm = squared.sqrt();
        let surface = (2.0 * psi).sqrt();
        PointResponse {
            dilatation: theta,
            scale: norm.recip() * surface,
            delta_lambda: (norm * (1.0 / surface) - 1.0) * (1.0 / alpha),
        }
    }
}
