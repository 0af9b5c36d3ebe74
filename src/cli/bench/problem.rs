//! The benchmark problem: the deck of LAMMPS's `in.pdcheck` written as Peridigm YAML.

use std::fmt::Write as _;
use std::path::Path;

use peridyn::io::deck::{self, DeckFormat};
use peridyn::setup;

/// Lattice spacing of the LAMMPS problem (m).
pub const SPACING: f64 = 1.0e-3;
/// Horizon δ = 3.015 × spacing (m), LAMMPS's `m = 3.015`.
pub const HORIZON: f64 = 3.015e-3;
/// Time step (s), LAMMPS's `timestep 5.0e-8`.
pub const TIME_STEP: f64 = 5.0e-8;

/// The `Contact` section of the "+ contact" variant, mirroring LAMMPS's built-in short-range
/// force: contact radius 0.9 mm (LAMMPS uses `min(0.9·|X_j − X_i|, 1.35·lc)`, 0.9 mm for
/// nearest neighbours), and the same stiffness: Peridigm's force is `9k_s/(πδ⁴)·(r_c − r)/δ·V`,
/// LAMMPS's `15·18K/(πδ⁴)·(r_c − r)/δ·V`, so `k_s = 30 K = 1.44e12 Pa`. The search radius is
/// LAMMPS's neighbour cut-off δ + skin (3.515 mm), refreshed every 20 steps.
pub const CONTACT_SECTION: &str = r#"  Contact:
    Search Radius: 3.515e-3
    Search Frequency: 20
    Models:
      Short Range:
        Contact Model: "Short Range Force"
        Contact Radius: 0.9e-3
        Spring Constant: 1.44e12
        Friction Coefficient: 0.0
    Interactions:
      Self Contact:
        Contact Model: "Short Range"
"#;

/// A material model of the benchmark.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum BenchModel {
    /// `Elastic Bond Based` (PMB), LAMMPS `peri/pmb`.
    Pmb,
    /// `Elastic` (linear peridynamic solid), LAMMPS `peri/lps`.
    Lps,
}

impl BenchModel {
    /// The value of LAMMPS's `-var model` for this model.
    pub fn lammps_name(self) -> &'static str {
        match self {
            BenchModel::Pmb => "pmb",
            BenchModel::Lps => "lps",
        }
    }

    /// The material list of the deck: E = 72 GPa (with ν forced to ¼ by PMB, as Peridigm
    /// does, so K = E/(3(1 − 2ν)) = 48 GPa in both models), ρ = 2440 kg/m³.
    fn material_yaml(self) -> &'static str {
        match self {
            BenchModel::Pmb => {
                "      Material Model: \"Elastic Bond Based\"\n      Density: 2440.0\n      Young's Modulus: 72.0e9\n"
            }
            BenchModel::Lps => {
                "      Material Model: \"Elastic\"\n      Density: 2440.0\n      Young's Modulus: 72.0e9\n      Poisson's Ratio: 0.25\n"
            }
        }
    }
}

/// The deck of the LAMMPS problem as Peridigm YAML: an `n`³ block of spacing [`SPACING`],
/// `steps` steps of [`TIME_STEP`], and the [`CONTACT_SECTION`] when `contact` is set.
///
/// The final time is `(steps + ½)·Δt` so that Peridigm's step count `floor(t_final/Δt)` is
/// `steps` whatever the rounding of the division.
pub fn deck_yaml(model: BenchModel, points_per_edge: usize, steps: u64, contact: bool) -> String {
    let n = points_per_edge;
    let length = n as f64 * SPACING;
    // QuickGrid ids are 1-based, x fastest: id = 1 + i + n·j + n²·k. LAMMPS's region `fast`
    // is x < 9.5 lattice units, i.e. i < 10 (i < n/3 in general, at least one layer).
    let fast_layers = (n / 3).max(1);
    let mut ids = String::with_capacity(n * n * fast_layers * 7);
    for k in 0..n {
        for j in 0..n {
            for i in 0..fast_layers {
                if !ids.is_empty() {
                    ids.push(' ');
                }
                let _ = write!(ids, "{}", 1 + i + n * j + n * n * k);
            }
        }
    }
    let final_time = (steps as f64 + 0.5) * TIME_STEP;
    let mut text = format!(
        r#"Peridigm:
  Discretization:
    Type: "PdQuickGrid"
    NeighborhoodType: "Spherical"
    TensorProduct3DMeshGenerator:
      X Origin: 0.0
      Y Origin: 0.0
      Z Origin: 0.0
      X Length: {length:e}
      Y Length: {length:e}
      Z Length: {length:e}
      Number Points X: {n}
      Number Points Y: {n}
      Number Points Z: {n}
  Materials:
    Glass:
{material}  Damage Models:
    Brittle:
      Damage Model: "Critical Stretch"
      Critical Stretch: 5.0e-4
  Blocks:
    Block:
      Block Names: "block_1"
      Material: "Glass"
      Damage Model: "Brittle"
      Horizon: {HORIZON:e}
  Boundary Conditions:
    Fast Node Set: "{ids}"
    Launch:
      Type: "Initial Velocity"
      Node Set: "Fast Node Set"
      Coordinate: "x"
      Value: "-30.0"
  Solver:
    Initial Time: 0.0
    Final Time: {final_time:e}
    Verlet:
      Fixed dt: {TIME_STEP:e}
"#,
        material = model.material_yaml(),
    );
    if contact {
        text.push_str(CONTACT_SECTION);
    }
    text
}

/// Whether this build can run the deck with the [`CONTACT_SECTION`]; `Err` carries the
/// missing features when it cannot.
pub fn contact_supported(model: BenchModel, points_per_edge: usize) -> Result<(), String> {
    let text = deck_yaml(model, points_per_edge, 1, true);
    let deck = deck::parse_str(&text, DeckFormat::Yaml, Path::new("<bench deck>"))
        .map_err(|e| e.to_string())?;
    let missing = setup::unsupported_features(&deck);
    if missing.is_empty() {
        Ok(())
    } else {
        Err(missing.join(", "))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Directed bonds LAMMPS reports for the 30³ problem (`total # of bonds = 2929168`).
    const LAMMPS_BONDS_30: usize = 2_929_168;

    #[test]
    fn deck_reproduces_the_lammps_lattice_and_launch() {
        // 30³ block: LAMMPS reports `total # of bonds = 2929168` for in.pdcheck, and the
        // interior family of a sphere of radius 3.015 spacings on a cubic lattice has 122
        // points (the lattice points within 3.015 spacings of a point, itself excluded).
        let text = deck_yaml(BenchModel::Pmb, 30, 100, false);
        let deck = deck::parse_str(&text, DeckFormat::Yaml, Path::new("<test>")).unwrap();
        assert!(setup::unsupported_features(&deck).is_empty());
        let model = setup::build(&deck).unwrap();
        assert_eq!(model.points.len(), 27_000);
        assert_eq!(model.bonds.num_bonds(), LAMMPS_BONDS_30);
        let largest = (0..model.points.len())
            .map(|i| model.bonds.family_size(i))
            .max()
            .unwrap();
        assert_eq!(largest, 122);
        // The launched set is x < 10 mm (LAMMPS region `fast`: x < 9.5 lattice units from the
        // first point at 0.5 mm, i.e. the first 10 layers): 10 × 30 × 30 points.
        let fast = model.node_sets.get("Fast Node Set").unwrap();
        assert_eq!(fast.len(), 9_000);
        for &p in fast {
            assert!(model.points.position[p as usize][0] < 10.0e-3);
        }
        let slow_minimum = (0..model.points.len() as u32)
            .filter(|p| !fast.contains(p))
            .map(|p| model.points.position[p as usize][0])
            .fold(f64::INFINITY, f64::min);
        assert!(slow_minimum > 10.0e-3);
    }

    #[test]
    fn final_time_gives_exactly_the_requested_step_count() {
        for steps in [1u64, 3, 100, 1000, 12345] {
            let final_time = (steps as f64 + 0.5) * TIME_STEP;
            assert_eq!((final_time / TIME_STEP).floor() as u64, steps);
        }
    }

    #[test]
    fn contact_row_is_a_deck_section() {
        let with = deck_yaml(BenchModel::Pmb, 4, 1, true);
        let without = deck_yaml(BenchModel::Pmb, 4, 1, false);
        assert_eq!(with, format!("{without}{CONTACT_SECTION}"));
        let deck = deck::parse_str(&with, DeckFormat::Yaml, Path::new("<test>")).unwrap();
        assert!(deck.contact.is_some());
    }
}
