//! The quasi-static bar several implicit-solver test files share.
// Each test crate that includes this module uses only part of it.
#![allow(dead_code)]

use peridyn::io::deck::{parse_str, DeckFormat};
use peridyn::io::exodus::ExodusFile;
use peridyn::setup;
use peridyn::simulation::{self, RunError, RunSummary};
use std::path::Path;

/// Loads `text` as a YAML deck written to `dir` and runs it with outputs in `dir`.
pub fn run_deck(dir: &Path, text: &str) -> Result<RunSummary, RunError> {
    let origin = dir.join("deck.yaml");
    std::fs::write(&origin, text).unwrap();
    let deck = parse_str(text, DeckFormat::Yaml, &origin).expect("deck loads");
    let model = setup::build(&deck).expect("model builds");
    simulation::run(&deck, &model, dir)
}

/// An LPS bar of 12 × 3 × 3 points (spacing 1), left face held, right face pulled by `pull`
/// along x (and `shear` along y) in `steps` load steps.
pub fn bar_deck(solver: &str, pull: f64, shear: f64, steps: usize) -> String {
    let face = |x: usize| -> String {
        (0..9)
            .map(|k| (1 + x + 12 * k).to_string())
            .collect::<Vec<_>>()
            .join(" ")
    };
    format!(
        r#"Peridigm:
  Discretization:
    Type: "PdQuickGrid"
    NeighborhoodType: "Spherical"
    TensorProduct3DMeshGenerator:
      X Origin: 0.0
      Y Origin: 0.0
      Z Origin: 0.0
      X Length: 12.0
      Y Length: 3.0
      Z Length: 3.0
      Number Points X: 12
      Number Points Y: 3
      Number Points Z: 3
  Materials:
    Steel:
      Material Model: "Elastic"
      Density: 7800.0
      Bulk Modulus: 130.0e9
      Shear Modulus: 78.0e9
  Blocks:
    Bar:
      Block Names: "block_1"
      Material: "Steel"
      Horizon: 2.1
  Boundary Conditions:
    Left Node Set: "{left}"
    Right Node Set: "{right}"
    Hold X: {{Type: "Prescribed Displacement", Node Set: "Left Node Set", Coordinate: "x", Value: "0.0"}}
    Hold Y: {{Type: "Prescribed Displacement", Node Set: "Left Node Set", Coordinate: "y", Value: "0.0"}}
    Hold Z: {{Type: "Prescribed Displacement", Node Set: "Left Node Set", Coordinate: "z", Value: "0.0"}}
    Pull X: {{Type: "Prescribed Displacement", Node Set: "Right Node Set", Coordinate: "x", Value: "{pull}*t"}}
    Pull Y: {{Type: "Prescribed Displacement", Node Set: "Right Node Set", Coordinate: "y", Value: "{shear}*t"}}
    Pull Z: {{Type: "Prescribed Displacement", Node Set: "Right Node Set", Coordinate: "z", Value: "0.0"}}
  Solver:
{solver}
  Output:
    Output Filename: "bar"
    Output Frequency: 1
    Output Variables:
      Displacement: true
      Force: true
"#,
        left = face(0),
        right = face(11),
        solver = solver.replace("{steps}", &steps.to_string()),
    )
}

/// The displacement of every point at the last frame of `dir/bar.e` (x components of all
/// points, then y, then z).
pub fn final_displacement(dir: &Path) -> Vec<f64> {
    let file = ExodusFile::open(&dir.join("bar.e")).unwrap();
    let last = file.times.len() - 1;
    ["DisplacementX", "DisplacementY", "DisplacementZ"]
        .iter()
        .flat_map(|name| {
            let index = file
                .nodal_variable_names
                .iter()
                .position(|n| n == name)
                .unwrap();
            file.nodal_values(last, index).unwrap()
        })
        .collect()
}

/// The rows of `dir/<name>_solver.csv` (the implicit solver report) as column name → value
/// maps.
pub fn solver_report(dir: &Path, name: &str) -> Vec<std::collections::HashMap<String, f64>> {
    let text = std::fs::read_to_string(dir.join(format!("{name}_solver.csv"))).unwrap();
    let mut lines = text.lines();
    let header: Vec<String> = lines
        .next()
        .unwrap()
        .split(',')
        .map(|s| s.trim().to_string())
        .collect();
    lines
        .map(|line| {
            header
                .iter()
                .cloned()
                .zip(line.split(',').map(|v| v.trim().parse::<f64>().unwrap()))
                .collect()
        })
        .collect()
}
