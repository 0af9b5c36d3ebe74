//! Quadrature rules for family sums: the volume w_ij each bond i→j stands for.
//!
//! Every peridynamic family integral `∫_{H_i} f(ξ) dV` is evaluated as a one-point sum
//! `Σ_j f(ξ_ij) w_ij` over the family of i. The rules differ in w_ij:
//!
//! * **full volume** (`"Full Volume"`, Peridigm's `FV` and default): `w_ij = V_j`, the whole cell
//!   of every neighbour whose centre lies within the horizon δ. No per-bond array exists for it;
//!   the materials read `V_j` as before ([`crate::model::BondVolumes`]).
//! * **PDLAMMPS** (`"PDLAMMPS"`): LAMMPS PERI's linear partial volume. A bond with
//!   `ζ > δ − Δx/2` gets `w = V_j (δ + Δx/2 − ζ)/Δx`, others `V_j`; the family stays `ζ ≤ δ`
//!   (Parks et al., "Implementing peridynamics within a molecular dynamics code", Comput. Phys.
//!   Commun. 179, 2008).
//! * **HHB** (`"HHB"`): the same linear factor (Hu, Ha & Bobaru's partial volume, the
//!   "cubic-cell integration" β of Yu, Xin & Lease, eq. 14), but the family reaches
//!   `ζ ≤ δ + Δx/2`, where the factor falls to 0.
//! * **exact** (`"Exact"`): `w_ij` = the volume of j's cubic cell (side `Δx = V_j^{1/3}`, centred
//!   on X_j, axis-aligned) inside the sphere of radius δ around X_i, computed once at setup to
//!   round-off (a 1-D adaptive integral of a closed-form rectangle∩disc area). The family
//!   reaches every cell that can touch the sphere: `ζ ≤ δ + √3/2 Δx`.
//! * **adaptive** (`"Adaptive"`): the same intersection volume by Yu, Xin & Lease's adaptive
//!   trapezoidal integration with combined relative/absolute error control ("A new method of
//!   adaptive integration with error control for bond-based peridynamics", §4.3): composite
//!   trapezoidal rule over the cell's x and y, the z extent inside the sphere exact, the index n
//!   doubled until `|I_r − I_{r−1}| ≤ EPS·|I_{r−1}|` (or `≤ EPS·V_j` once `|I_{r−1}| ≤ TOL·V_j`,
//!   TOL = 1e-4 as in the paper; the absolute thresholds are scaled by the cell volume so the
//!   test does not depend on the length unit). EPS is the block's `Quadrature Tolerance`
//!   (default 1e-4). The achieved error estimate `|I_r − I_{r−1}|` of every bond is kept
//!   ([`QuadratureSummary`]).
//!
//! All rules assume 3-D cubic cells (Δx from the cell volume's cube root). A rule is symmetric
//! (w_ij = w_ji) when the two cells have the same volume and the two points the same horizon:
//! the intersection of a cube with a sphere is unchanged by swapping their centres (point
//! inversion maps one onto the other). The force kernels use the gather form
//! `F_i = Σ_j (t_ij + t_ji) w_ij M_ij`, which is the formula for any weights; momentum is exactly
//! conserved when `V_i w_ij = V_j w_ji`.

use std::collections::HashMap;

use super::BondList;

/// Largest trapezoidal index n of the adaptive rule (per direction): (n+1)² integration points.
/// A bond that has not met its tolerance by then keeps its last value and its error estimate.
const ADAPTIVE_MAX_INDEX: usize = 1024;

/// TOL of Yu, Xin & Lease §4.3 (relative to the cell volume here): below it the error control
/// switches from relative to absolute.
const ADAPTIVE_SMALL: f64 = 1e-4;

/// The default `Quadrature Tolerance` (EPS) of the adaptive rule (the paper's typical value).
pub const DEFAULT_ADAPTIVE_TOLERANCE: f64 = 1e-4;

/// How the family sums of a block weigh each bond (the block's `Quadrature`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum QuadratureRule {
    /// `w_ij = V_j` (Peridigm's default, `FV`).
    #[default]
    FullVolume,
    /// LAMMPS PERI's linear partial volume near the horizon (family `ζ ≤ δ`).
    PdLammps,
    /// Hu–Ha–Bobaru linear partial volume (family `ζ ≤ δ + Δx/2`).
    Hhb,
    /// The exact volume of the neighbour's cell inside the horizon sphere.
    Exact,
    /// Yu–Xin–Lease adaptive trapezoidal integration of that volume with relative tolerance
    /// `tolerance` (EPS).
    Adaptive {
        /// EPS, the prescribed relative accuracy (dimensionless, > 0).
        tolerance: f64,
    },
}

/// The deck names of the rules (`Blocks → … → Quadrature`), in documentation order.
pub const RULE_NAMES: [&str; 5] = ["Full Volume", "PDLAMMPS", "HHB", "Exact", "Adaptive"];

impl QuadratureRule {
    /// The rule as part of a memo key: a tag per rule and its tolerance (0 for the rules
    /// without one), so that values computed once per rule and shape can be looked up.
    pub fn cache_key(self) -> (u8, f64) {
        match self {
            QuadratureRule::FullVolume => (0, 0.0),
            QuadratureRule::PdLammps => (1, 0.0),
            QuadratureRule::Hhb => (2, 0.0),
            QuadratureRule::Exact => (3, 0.0),
            QuadratureRule::Adaptive { tolerance } => (4, tolerance),
        }
    }

    /// The rule named by `Blocks → … → Quadrature` (one of [`RULE_NAMES`]), the adaptive one
    /// with `tolerance`.
    pub fn from_deck_name(name: &str, tolerance: f64) -> Option<Self> {
        Some(match name {
            "Full Volume" => Self::FullVolume,
            "PDLAMMPS" => Self::PdLammps,
            "HHB" => Self::Hhb,
            "Exact" => Self::Exact,
            "Adaptive" => Self::Adaptive { tolerance },
            _ => return None,
        })
    }

    /// The rule of Peridigm's `Element-Horizon Intersection Partial Volume Scheme`: `FV` full
    /// volume, `PV` (Peridigm's element∩sphere partial volumes) the exact rule, `PDLAMMPS`,
    /// `HHB`.
    pub fn from_peridigm_scheme(scheme: &str) -> Option<Self> {
        Some(match scheme {
            "FV" => Self::FullVolume,
            "PV" => Self::Exact,
            "PDLAMMPS" => Self::PdLammps,
            "HHB" => Self::Hhb,
            _ => return None,
        })
    }

    /// True for the full-volume rule (no per-bond weights are stored).
    pub fn is_full_volume(&self) -> bool {
        matches!(self, Self::FullVolume)
    }

    /// The deck name of the rule.
    pub fn name(&self) -> &'static str {
        match self {
            Self::FullVolume => RULE_NAMES[0],
            Self::PdLammps => RULE_NAMES[1],
            Self::Hhb => RULE_NAMES[2],
            Self::Exact => RULE_NAMES[3],
            Self::Adaptive { .. } => RULE_NAMES[4],
        }
    }

    /// How far the family must reach for a point with horizon `horizon` and cell spacing
    /// `spacing` (length): δ, δ + Δx/2 (HHB), or δ + √3/2·Δx (every cell that can touch the
    /// sphere: exact and adaptive).
    pub fn family_reach(&self, horizon: f64, spacing: f64) -> f64 {
        match self {
            Self::FullVolume | Self::PdLammps => horizon,
            Self::Hhb => horizon + 0.5 * spacing,
            Self::Exact | Self::Adaptive { .. } => horizon + 0.5 * 3f64.sqrt() * spacing,
        }
    }

    /// The quadrature volume of a bond with reference vector `xi` = X_j − X_i (length) from a
    /// point of horizon `horizon` to a neighbour of cell volume `cell_volume` (length³).
    pub fn bond_volume(&self, xi: [f64; 3], horizon: f64, cell_volume: f64) -> BondVolume {
        let exact = |volume| BondVolume {
            volume,
            error_estimate: 0.0,
            converged: true,
        };
        let spacing = cell_volume.cbrt();
        let zeta = (xi[0] * xi[0] + xi[1] * xi[1] + xi[2] * xi[2]).sqrt();
        match *self {
            Self::FullVolume => exact(cell_volume),
            Self::PdLammps | Self::Hhb => {
                let factor = if zeta <= horizon - 0.5 * spacing {
                    1.0
                } else {
                    ((horizon + 0.5 * spacing - zeta) / spacing).clamp(0.0, 1.0)
                };
                exact(cell_volume * factor)
            }
            Self::Exact => exact(cell_sphere_volume(xi, spacing, horizon)),
            Self::Adaptive { tolerance } => {
                adaptive_cell_sphere_volume(xi, spacing, horizon, tolerance)
            }
        }
    }
}

/// One bond's quadrature volume and how well it is known.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BondVolume {
    /// w_ij (length³).
    pub volume: f64,
    /// The adaptive rule's last change `|I_r − I_{r−1}|` (length³); 0 for the closed-form rules.
    pub error_estimate: f64,
    /// False when the adaptive rule stopped at its largest index before meeting its tolerance.
    pub converged: bool,
}

/// What the quadrature setup computed, for the log and `peridyn check`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct QuadratureSummary {
    /// Bonds whose weight differs from the full cell volume.
    pub partial_bonds: usize,
    /// The largest adaptive error estimate relative to the bond's cell volume.
    pub largest_relative_error: f64,
    /// Adaptive bonds that did not meet their tolerance.
    pub unconverged_bonds: usize,
}

/// The per-bond quadrature volumes of `bonds` (global bond index), or `None` when every row's
/// rule is the full volume (no array is allocated then). `rule_of_point[i]` and
/// `horizon_of_point[i]` are the rule and material horizon of point i's block.
pub fn bond_volumes(
    bonds: &BondList,
    position: &[[f64; 3]],
    volume: &[f64],
    rule_of_point: &[QuadratureRule],
    horizon_of_point: &[f64],
) -> Option<(Vec<f64>, QuadratureSummary)> {
    if rule_of_point.iter().all(QuadratureRule::is_full_volume) {
        return None;
    }
    let mut weights = Vec::with_capacity(bonds.num_bonds());
    let mut summary = QuadratureSummary::default();
    // On a regular grid a few hundred bond shapes repeat over every point: each is integrated
    // once, keyed by its rule, horizon, cell volume and its vector in units of the cell
    // spacing rounded to 2⁻³² (so round-off in X_j − X_i does not split equal shapes).
    let mut memo: HashMap<(u8, [u64; 3], [i64; 3]), BondVolume> = HashMap::new();
    for i in 0..bonds.num_points() {
        let rule = rule_of_point[i];
        let (tag, tolerance) = rule.cache_key();
        for b in bonds.range(i) {
            let j = bonds.neighbor[b] as usize;
            let xi = [0, 1, 2].map(|k| position[j][k] - position[i][k]);
            let spacing = volume[j].cbrt();
            let key = (
                tag,
                [horizon_of_point[i], volume[j], tolerance].map(f64::to_bits),
                xi.map(|v| (v / spacing * 4_294_967_296.0).round() as i64),
            );
            let w = *memo
                .entry(key)
                .or_insert_with(|| rule.bond_volume(xi, horizon_of_point[i], volume[j]));
            if w.volume != volume[j] {
                summary.partial_bonds += 1;
            }
            summary.largest_relative_error = summary
                .largest_relative_error
                .max(w.error_estimate / volume[j]);
            summary.unconverged_bonds += usize::from(!w.converged);
            weights.push(w.volume);
        }
    }
    Some((weights, summary))
}

/// The horizon-volume error `(V + Σ_j w_ij) / (4/3 π δ³) − 1` (relative) of `rule` at an
/// interior point of the unit cubic lattice with δ = m: its own cell plus every lattice point
/// within the rule's reach ([`QuadratureRule::family_reach`]). This is what `peridyn
/// quadrature` tabulates.
pub fn lattice_horizon_volume_error(rule: QuadratureRule, m: f64) -> f64 {
    let reach = rule.family_reach(m, 1.0);
    let n = reach.ceil() as i64;
    let mut total = 1.0;
    for a in -n..=n {
        for b in -n..=n {
            for c in -n..=n {
                let xi = [a, b, c].map(|v| v as f64);
                let zeta = (xi[0] * xi[0] + xi[1] * xi[1] + xi[2] * xi[2]).sqrt();
                if zeta > 0.0 && zeta <= reach {
                    total += rule.bond_volume(xi, m, 1.0).volume;
                }
            }
        }
    }
    total / (4.0 / 3.0 * std::f64::consts::PI * m.powi(3)) - 1.0
}

/// `∫_0^y √(r² − t²) dt` for 0 ≤ y ≤ r.
fn circle_primitive(y: f64, r: f64) -> f64 {
    let y = y.min(r);
    0.5 * (y * (r * r - y * y).max(0.0).sqrt() + r * r * (y / r).clamp(-1.0, 1.0).asin())
}

/// Signed area of `[0, a] × [0, b]` inside the disc of radius r centred at the origin (odd in
/// a and in b, so rectangle areas follow by inclusion–exclusion).
fn corner_area(a: f64, b: f64, r: f64) -> f64 {
    if r <= 0.0 || a == 0.0 || b == 0.0 {
        return 0.0;
    }
    let sign = a.signum() * b.signum();
    let (a, b) = (a.abs().min(r), b.abs().min(r));
    if a * a + b * b <= r * r {
        return sign * a * b;
    }
    // For t < t_b = √(r² − b²) the disc's chord is taller than b; beyond, the arc bounds it.
    let t_b = (r * r - b * b).max(0.0).sqrt();
    sign * (b * t_b + circle_primitive(a, r) - circle_primitive(t_b, r))
}

/// Area of the rectangle `[y0, y1] × [z0, z1]` inside the disc of radius r about the origin.
fn rectangle_disc_area(y: [f64; 2], z: [f64; 2], r: f64) -> f64 {
    corner_area(y[1], z[1], r) - corner_area(y[0], z[1], r) - corner_area(y[1], z[0], r)
        + corner_area(y[0], z[0], r)
}

/// Adaptive Simpson integration of `f` over [a, b] to absolute tolerance `tolerance`.
fn adaptive_simpson(f: &dyn Fn(f64) -> f64, a: f64, b: f64, tolerance: f64) -> f64 {
    fn step(
        f: &dyn Fn(f64) -> f64,
        (a, fa): (f64, f64),
        (m, fm): (f64, f64),
        (b, fb): (f64, f64),
        whole: f64,
        tolerance: f64,
        depth: u32,
    ) -> f64 {
        let (lm, rm) = (0.5 * (a + m), 0.5 * (m + b));
        let (flm, frm) = (f(lm), f(rm));
        let left = (m - a) / 6.0 * (fa + 4.0 * flm + fm);
        let right = (b - m) / 6.0 * (fm + 4.0 * frm + fb);
        let difference = left + right - whole;
        if depth == 0 || difference.abs() <= 15.0 * tolerance {
            return left + right + difference / 15.0;
        }
        step(
            f,
            (a, fa),
            (lm, flm),
            (m, fm),
            left,
            0.5 * tolerance,
            depth - 1,
        ) + step(
            f,
            (m, fm),
            (rm, frm),
            (b, fb),
            right,
            0.5 * tolerance,
            depth - 1,
        )
    }
    let m = 0.5 * (a + b);
    let (fa, fm, fb) = (f(a), f(m), f(b));
    let whole = (b - a) / 6.0 * (fa + 4.0 * fm + fb);
    step(f, (a, fa), (m, fm), (b, fb), whole, tolerance, 40)
}

/// The volume (length³) of the axis-aligned cube of side `side` centred at `center` inside
/// the sphere of radius `radius` centred at the origin, to round-off.
///
/// `V = ∫ A(x) dx` with A the closed-form area of the cube's y–z square inside the disc of
/// radius √(R² − x²). A is smooth between the x where that radius crosses a critical distance
/// of the square (an edge line or a corner), so the integral is split there and each piece
/// integrated by adaptive Simpson to 1e-14 of the cube's volume.
pub fn cell_sphere_volume(center: [f64; 3], side: f64, radius: f64) -> f64 {
    let h = 0.5 * side;
    let lo = center.map(|c| c - h);
    let hi = center.map(|c| c + h);
    // Nearest and farthest points of the cube from the sphere's centre.
    let (mut near, mut far) = (0.0, 0.0);
    for k in 0..3 {
        let n = if lo[k] > 0.0 {
            lo[k]
        } else if hi[k] < 0.0 {
            -hi[k]
        } else {
            0.0
        };
        let f = lo[k].abs().max(hi[k].abs());
        near += n * n;
        far += f * f;
    }
    let r2 = radius * radius;
    if near >= r2 {
        return 0.0;
    }
    if far <= r2 {
        return side * side * side;
    }
    let (y, z) = ([lo[1], hi[1]], [lo[2], hi[2]]);
    let area = |x: f64| rectangle_disc_area(y, z, (r2 - x * x).max(0.0).sqrt());
    let (a, b) = (lo[0].max(-radius), hi[0].min(radius));
    // Critical disc radii: the edge lines y = y_k, z = z_l and the corners.
    let mut cuts = vec![a, b];
    let mut critical = vec![0.0];
    critical.extend(y.iter().chain(&z).map(|v| v.abs()));
    for yk in y {
        for zl in z {
            critical.push((yk * yk + zl * zl).sqrt());
        }
    }
    for rho in critical {
        if rho < radius {
            let x = (r2 - rho * rho).sqrt();
            for x in [x, -x] {
                if x > a && x < b {
                    cuts.push(x);
                }
            }
        }
    }
    cuts.sort_by(f64::total_cmp);
    let tolerance = 1e-14 * side * side * side / cuts.len() as f64;
    cuts.windows(2)
        .filter(|w| w[1] > w[0])
        .map(|w| adaptive_simpson(&area, w[0], w[1], tolerance))
        .sum()
}

/// Yu, Xin & Lease's adaptive trapezoidal integration (§4.3) of the same volume as
/// [`cell_sphere_volume`]: composite trapezoidal rule with index n in x and y over the cube
/// (the z extent inside the sphere exact at each point), n = 1, 2, 4, … until the combined
/// relative/absolute test with EPS = `tolerance` passes (see the module docs).
pub fn adaptive_cell_sphere_volume(
    center: [f64; 3],
    side: f64,
    radius: f64,
    tolerance: f64,
) -> BondVolume {
    let h = 0.5 * side;
    let cell = side * side * side;
    let r2 = radius * radius;
    let (z0, z1) = (center[2] - h, center[2] + h);
    let height = |x: f64, y: f64| {
        let q = r2 - x * x - y * y;
        if q <= 0.0 {
            return 0.0;
        }
        let top = q.sqrt();
        (z1.min(top) - z0.max(-top)).max(0.0)
    };
    let trapezoid = |n: usize| {
        let step = side / n as f64;
        let mut sum = 0.0;
        for a in 0..=n {
            let x = center[0] - h + a as f64 * step;
            let wx = if a == 0 || a == n { 0.5 } else { 1.0 };
            for b in 0..=n {
                let y = center[1] - h + b as f64 * step;
                let wy = if b == 0 || b == n { 0.5 } else { 1.0 };
                sum += wx * wy * height(x, y);
            }
        }
        sum * step * step
    };
    // Start at n = 2 and accept no earlier than n = 4: a cell the sphere only grazes can show
    // no height at the 2×2 corner points of n = 1 and at n = 2 alike.
    let mut n = 2;
    let mut previous = trapezoid(n);
    loop {
        n *= 2;
        let current = trapezoid(n);
        let change = (current - previous).abs();
        let met = if previous.abs() > ADAPTIVE_SMALL * cell {
            change <= tolerance * previous.abs()
        } else {
            change <= tolerance * cell
        };
        if met || n >= ADAPTIVE_MAX_INDEX {
            return BondVolume {
                volume: current,
                error_estimate: change,
                converged: met,
            };
        }
        previous = current;
    }
}

#[cfg(test)]
mod tests;
