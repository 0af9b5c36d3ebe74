//! The short-range force pair law (Silling & Askari's penalty contact, as Peridigm codes it).

/// π in the short-range force. Older Peridigm sources wrote the literal `3.1415` here (2.9e-5
/// stiffer); current Peridigm uses the full π (`PeridigmNS::value_of_pi()`), and its
/// regression gold files (`Contact_Cubes`) agree with the full value to 3e-10 but not with
/// `3.1415` (1.5e-5 velocity differences), so the full value is used.
const PI: f64 = std::f64::consts::PI;

/// Parameters of one `Short Range Force` contact model.
///
/// For two points i, j that may touch (see [`crate::contact`]) at current distance
/// r = |y_j − y_i| < r_c, the force density on i is
///
/// ```text
/// f_i = −c_ij (r_c − r) V_j (n + μ_f t),   c_ij = 9 k_s / π · (1/δ_i⁵ + 1/δ_j⁵)
/// ```
///
/// with n = (y_j − y_i)/r (so the force pushes i away from j), V_j the volume of j, δ the
/// horizon of each point's block and t the unit vector of the
/// tangential relative velocity of i with respect to j: t = w/|w| with
/// w = (v_i − (v_i·n)n) − (v_j − (v_j·n)n), or t = 0 when w = 0. The force on j is the mirror
/// image (i ↔ j), so V_i f_i + V_j f_j = 0: contact conserves linear momentum.
///
/// This is Peridigm's formula: each point of a pair evaluates `9 k_s/(π δ⁴) · (r_c − r)/δ`
/// with its own block's horizon δ and applies it to both points ("half of 18 because both
/// points see the pair"), so with equal horizons c_ij = 18 k_s/(π δ⁵), the bond-based
/// micromodulus 18K/(πδ⁴) per unit length of the gap r_c − r. Peridigm's friction is
/// μ_f·|normal force| against the tangential velocity of each point relative to the pair's mean
/// tangential velocity, which points along −t for i and +t for j as above.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShortRangeForce {
    /// `Contact Radius` r_c (length): points closer than this repel.
    pub contact_radius: f64,
    /// `Spring Constant` k_s (pressure units).
    pub spring_constant: f64,
    /// `Friction Coefficient` μ_f (dimensionless, default 0).
    pub friction_coefficient: f64,
}

/// Positions, velocities, horizon and volume of one point, as the pair law needs them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PairPoint {
    /// Current position y (length).
    pub position: [f64; 3],
    /// Velocity v (length/time); only friction uses it.
    pub velocity: [f64; 3],
    /// Horizon δ of the point's block (length).
    pub horizon: f64,
    /// Volume V (length³).
    pub volume: f64,
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

impl ShortRangeForce {
    /// c_ij = 9 k_s/π · (1/δ_i⁵ + 1/δ_j⁵) (pressure/length⁵); symmetric in i and j.
    pub fn pair_coefficient(&self, horizon_i: f64, horizon_j: f64) -> f64 {
        9.0 * self.spring_constant / PI * (horizon_i.powi(-5) + horizon_j.powi(-5))
    }

    /// Force density on `i` from `j` (force/length³), or `None` when they are at least r_c
    /// apart — or at exactly the same place, where the line of centres is undefined (Peridigm
    /// divides by zero there and aborts on the NaN).
    pub fn force_density_on(&self, i: &PairPoint, j: &PairPoint) -> Option<[f64; 3]> {
        let d = [
            j.position[0] - i.position[0],
            j.position[1] - i.position[1],
            j.position[2] - i.position[2],
        ];
        let r = dot(d, d).sqrt();
        if r >= self.contact_radius || r == 0.0 {
            return None;
        }
        let n = [d[0] / r, d[1] / r, d[2] / r];
        let magnitude =
            self.pair_coefficient(i.horizon, j.horizon) * (self.contact_radius - r) * j.volume;
        let mut direction = n;
        if self.friction_coefficient != 0.0 {
            let (vi_n, vj_n) = (dot(i.velocity, n), dot(j.velocity, n));
            let w: [f64; 3] = std::array::from_fn(|k| {
                (i.velocity[k] - vi_n * n[k]) - (j.velocity[k] - vj_n * n[k])
            });
            let w_norm = dot(w, w).sqrt();
            if w_norm > 0.0 {
                for k in 0..3 {
                    direction[k] += self.friction_coefficient * w[k] / w_norm;
                }
            }
        }
        Some([
            -magnitude * direction[0],
            -magnitude * direction[1],
            -magnitude * direction[2],
        ])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(x: f64, vy: f64) -> PairPoint {
        PairPoint {
            position: [x, 0.0, 0.0],
            velocity: [0.0, vy, 0.0],
            horizon: 0.5,
            volume: 2.0,
        }
    }

    #[test]
    fn magnitude_is_peridigms_formula() {
        let law = ShortRangeForce {
            contact_radius: 0.2,
            spring_constant: 1950.0e3,
            friction_coefficient: 0.0,
        };
        let (a, b) = (point(0.0, 0.0), point(0.15, 0.0));
        let f = law.force_density_on(&a, &b).unwrap();
        // Peridigm, summed over the two evaluations of the pair (one per point, same δ):
        // 2 · 9 k/(π δ⁴) · (r_c − r)/δ · V_j, pushing a towards −x.
        let expected =
            2.0 * 9.0 * 1950.0e3 / (std::f64::consts::PI * 0.5f64.powi(4)) * (0.2 - 0.15) / 0.5
                * 2.0;
        assert!(
            (f[0] + expected).abs() < 1e-9 * expected,
            "{f:?} vs {expected}"
        );
        assert_eq!([f[1], f[2]], [0.0, 0.0]);
    }

    #[test]
    fn friction_opposes_tangential_sliding() {
        let law = ShortRangeForce {
            contact_radius: 0.2,
            spring_constant: 1.0,
            friction_coefficient: 0.3,
        };
        let (a, b) = (point(0.0, 1.0), point(0.1, -1.0));
        let fa = law.force_density_on(&a, &b).unwrap();
        let fb = law.force_density_on(&b, &a).unwrap();
        // Normal part: |f_n| along −x on a; friction μ|f_n| against a's sliding (+y).
        let normal = -fa[0];
        assert!(normal > 0.0);
        assert!((fa[1] + 0.3 * normal).abs() < 1e-12 * normal);
        // Mirror image (equal volumes): equal and opposite.
        for k in 0..3 {
            assert_eq!(fa[k], -fb[k]);
        }
    }

    #[test]
    fn nothing_at_or_beyond_the_contact_radius_or_at_zero_distance() {
        let law = ShortRangeForce {
            contact_radius: 0.2,
            spring_constant: 1.0,
            friction_coefficient: 0.0,
        };
        assert!(law
            .force_density_on(&point(0.0, 0.0), &point(0.2, 0.0))
            .is_none());
        assert!(law
            .force_density_on(&point(0.0, 0.0), &point(0.0, 0.0))
            .is_none());
    }
}
