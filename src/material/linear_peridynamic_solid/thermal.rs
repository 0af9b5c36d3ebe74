//! The LPS bond loops with thermal strain (the parent module's docs): plain loops, used only
//! by blocks with a `Thermal Expansion Coefficient` in runs with point temperatures.

use super::rows::Rows;
use crate::material::{BondWeights, Integrity, PointCoefficients};
use crate::model::VolumeRule;

/// The loops' inputs ([`Rows`]) of a block whose points have a free thermal strain: only
/// [`Rows::thermal`] makes one, when there is a strain to subtract.
pub(super) struct ThermalRows<'r, 'a, V> {
    pub(super) rows: &'r Rows<'a, V>,
    /// ε = α ΔT of every point.
    pub(super) strain: &'a [f64],
}

impl<'a, V> Rows<'a, V> {
    /// The thermal loops over these inputs, when the points have a free thermal strain.
    pub(super) fn thermal(&self) -> Option<ThermalRows<'_, 'a, V>> {
        self.thermal_strain
            .map(|strain| ThermalRows { rows: self, strain })
    }
}

impl<V: VolumeRule> ThermalRows<'_, '_, V> {
    /// θ_i = (3/m) Σ_j ω (1−d) ζ (e − ε_i ζ) V_j and the published coefficients, ε = α ΔT.
    pub(super) fn dilatation<W: BondWeights, D: Integrity>(
        &self,
        chunk: &[u32],
        base: usize,
        out: &mut [PointCoefficients],
        weights: W,
        damage: D,
    ) {
        let (rows, strain) = (self.rows, self.strain);
        let bonds = rows.reference.bonds;
        let y = rows.current.position;
        let k0 = rows.first_local(chunk);
        for (k, &i) in (k0..).zip(chunk) {
            let i = i as usize;
            let local = rows.local_offsets[k];
            let mut sum = 0.0;
            for (n, b) in bonds.range(i).enumerate() {
                let j = bonds.neighbor[b] as usize;
                let zeta = bonds.reference_length[b];
                let extension = distance(y[i], y[j]) - zeta - strain[i] * zeta;
                sum += weights.weight(local + n)
                    * damage.intact(b)
                    * zeta
                    * extension
                    * rows.reference.neighbor_volume(b, j);
            }
            let m = rows.weighted_volume[k];
            out[i - base] = if m > 0.0 {
                let theta = 3.0 * sum / m;
                PointCoefficients {
                    dilatation: theta,
                    isotropic: (3.0 * rows.bulk - 5.0 * rows.shear) * theta / m,
                    deviatoric: 15.0 * rows.shear / m,
                }
            } else {
                PointCoefficients::default()
            };
        }
    }

    /// `F_i += Σ_j (1−d) ω [(A_i + A_j) ζ + (1−d)(B_i (e − ε_i ζ) + B_j (e − ε_j ζ))] V_j M_ij`.
    pub(super) fn add_force<W: BondWeights, D: Integrity>(
        &self,
        coefficients: &[PointCoefficients],
        chunk: &[u32],
        base: usize,
        out: &mut [[f64; 3]],
        weights: W,
        damage: D,
    ) {
        let (rows, strain) = (self.rows, self.strain);
        let bonds = rows.reference.bonds;
        let y = rows.current.position;
        for &i in chunk {
            let k = rows.points.partition_point(|&p| p < i);
            let i = i as usize;
            let own = coefficients[i];
            let local = rows.local_offsets[k];
            let mut total = [0.0; 3];
            for (n, b) in bonds.range(i).enumerate() {
                let j = bonds.neighbor[b] as usize;
                let length = distance(y[i], y[j]);
                if length == 0.0 {
                    continue;
                }
                let zeta = bonds.reference_length[b];
                let other = coefficients[j];
                let extension = length - zeta;
                let intact = damage.intact(b);
                let t = intact
                    * weights.weight(local + n)
                    * ((own.isotropic + other.isotropic) * zeta
                        + intact
                            * (own.deviatoric * (extension - strain[i] * zeta)
                                + other.deviatoric * (extension - strain[j] * zeta)));
                let scale = t * rows.reference.neighbor_volume(b, j) / length;
                for c in 0..3 {
                    total[c] += scale * (y[j][c] - y[i][c]);
                }
            }
            for c in 0..3 {
                out[i - base][c] += total[c];
            }
        }
    }
}

/// |b − a|.
#[inline(always)]
fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    let (dx, dy, dz) = (b[0] - a[0], b[1] - a[1], b[2] - a[2]);
    (dx * dx + dy * dy + dz * dz).sqrt()
}
