//! `peridyn quadrature`: the horizon-volume error of every quadrature rule against the
//! horizon ratio m = δ/Δx (the README table "Quadrature rules").
//!
//! For an interior point of the unit cubic lattice with δ = m, the rule's discrete horizon
//! volume is the point's own cell plus `Σ_j w_ij` over its family
//! ([`lattice_horizon_volume_error`]); the table gives `(V + Σ_j w_ij) / (4/3 π δ³) − 1` in
//! percent. The sphere is what every family
//! integral is normalized against (the micromodulus and the LPS weighted volume assume it), so
//! this error is the scale of the quadrature's error in force and energy.

use peridyn::model::quadrature::{
    lattice_horizon_volume_error, QuadratureRule, DEFAULT_ADAPTIVE_TOLERANCE,
};

/// `peridyn quadrature` arguments.
#[derive(Debug, Clone, clap::Args)]
pub struct QuadratureArgs {
    /// Horizon ratios m = δ/Δx, comma-separated.
    #[arg(long, value_delimiter = ',', default_values_t = [2.0, 3.0, 4.0, 5.0, 6.0])]
    pub ratios: Vec<f64>,
    /// The adaptive rule's tolerance EPS (`Quadrature Tolerance`).
    #[arg(long, default_value_t = DEFAULT_ADAPTIVE_TOLERANCE)]
    pub tolerance: f64,
}

/// The table as Markdown, one row per ratio.
pub fn main(args: &QuadratureArgs) -> Result<String, String> {
    if args
        .ratios
        .iter()
        .any(|m| !(m.is_finite() && *m >= 1.0 && *m <= 20.0))
    {
        return Err("--ratios: every m must be a number from 1 to 20".into());
    }
    if !(args.tolerance.is_finite() && args.tolerance > 0.0) {
        return Err("--tolerance must be a positive number".into());
    }
    let rules = [
        QuadratureRule::FullVolume,
        QuadratureRule::PdLammps,
        QuadratureRule::Hhb,
        QuadratureRule::Exact,
        QuadratureRule::Adaptive {
            tolerance: args.tolerance,
        },
    ];
    let mut out = String::from("| m |");
    for rule in &rules {
        out.push_str(&match rule {
            QuadratureRule::Adaptive { tolerance } => format!(" Adaptive (EPS {tolerance:e}) |"),
            other => format!(" {} |", other.name()),
        });
    }
    out.push_str("\n|---|");
    out.push_str(&"---:|".repeat(rules.len()));
    out.push('\n');
    for &m in &args.ratios {
        out.push_str(&format!("| {m} |"));
        for &rule in &rules {
            out.push_str(&format!(
                " {:+.4} % |",
                100.0 * lattice_horizon_volume_error(rule, m)
            ));
        }
        out.push('\n');
    }
    Ok(out)
}
