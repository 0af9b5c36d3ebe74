//! Thermal strain in whole runs: `Prescribed Temperature` and `Initial Temperature` set the point
//! temperatures, `Thermal Expansion Coefficient` turns them into free thermal strain. A free
//! cube heated quasi-statically expands by αΔT (`Elastic`; `Elastic Correspondence`, whose
//! strain is logarithmic, by e^{αΔT} − 1) with no force; the force vanishes on a cube driven along the free expansion
//! by Verlet and Newmark runs alike; a fully held bar carries the closed-form thermal force;
//! the keys load and bad ones are errors.

use peridyn::io::deck::{parse_str, DeckFormat};
use peridyn::io::exodus::ExodusFile;
use peridyn::setup;
use peridyn::simulation::{self, RunError, RunSummary};
use std::path::Path;

/// Loads `text` as a YAML deck written to `dir` and runs it with outputs in `dir`.
fn run_deck(dir: &Path, text: &str) -> Result<RunSummary, RunError> {
    let origin = dir.join("deck.yaml");
    std::fs::write(&origin, text).unwrap();
    let deck = parse_str(text, DeckFormat::Yaml, &origin).expect("deck loads");
    let model = setup::build(&deck).expect("model builds");
    simulation::run(&deck, &model, dir)
}

/// The deck's load error, if any.
fn load_error(text: &str) -> Option<String> {
    let dir = tempfile::tempdir().unwrap();
    let origin = dir.path().join("deck.yaml");
    std::fs::write(&origin, text).unwrap();
    parse_str(text, DeckFormat::Yaml, &origin)
        .err()
        .map(|e| e.to_string())
}

const ALPHA: f64 = 2.0e-5;
/// ΔT at t = 1: 20 + 50 t from 20.
const HEATING: f64 = 50.0;
const BULK: f64 = 1.0e4;

/// 1-based ids of the points of the n³ QuickGrid cube (x fastest) with index `axis` = 0.
fn face(n: usize, axis: usize) -> String {
    let mut ids = Vec::new();
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                if [i, j, k][axis] == 0 {
                    ids.push((1 + i + n * j + n * n * k).to_string());
                }
            }
        }
    }
    ids.join(" ")
}

fn all(n: usize) -> String {
    (1..=n * n * n)
        .map(|i| i.to_string())
        .collect::<Vec<_>>()
        .join(" ")
}

/// A 5³ cube of unit cells on [0, 5]³ (points at 0.5 … 4.5) of `material` (a YAML flow
/// mapping of its keys), heated from 20 to 70 degrees over t ∈ [0, 1], with `conditions` and
/// `solver` (YAML lines).
fn cube_deck(material: &str, conditions: &str, solver: &str) -> String {
    format!(
        r#"Peridigm:
  Discretization:
    Type: "PdQuickGrid"
    NeighborhoodType: "Spherical"
    TensorProduct3DMeshGenerator:
      X Origin: 0.0
      Y Origin: 0.0
      Z Origin: 0.0
      X Length: 5.0
      Y Length: 5.0
      Z Length: 5.0
      Number Points X: 5
      Number Points Y: 5
      Number Points Z: 5
  Materials:
    Metal: {material}
  Blocks:
    Cube:
      Block Names: "block_1"
      Material: "Metal"
      Horizon: 1.75
  Boundary Conditions:
    Min X Node Set: "{min_x}"
    Min Y Node Set: "{min_y}"
    Min Z Node Set: "{min_z}"
    All Node Set: "{all}"
    Start: {{Type: "Initial Temperature", Node Set: "All Node Set", Value: "20.0"}}
    Heat: {{Type: "Prescribed Temperature", Node Set: "All Node Set", Value: "20.0 + {heating}*t"}}
{conditions}
  Solver:
{solver}
  Output:
    Output Filename: "cube"
    Output Frequency: 1
    Output Variables:
      Displacement: true
      Force: true
      Temperature: true
      Temperature_Change: true
"#,
        min_x = face(5, 0),
        min_y = face(5, 1),
        min_z = face(5, 2),
        all = all(5),
        heating = HEATING,
    )
}

const LPS: &str = r#"{Material Model: "Elastic", Density: 1.0, Bulk Modulus: 1.0e4, Shear Modulus: 6.0e3, Thermal Expansion Coefficient: 2.0e-5}"#;
const CORRESPONDENCE: &str = r#"{Material Model: "Elastic Correspondence", Density: 1.0, Bulk Modulus: 1.0e4, Shear Modulus: 6.0e3, Hourglass Coefficient: 0.02, Thermal Expansion Coefficient: 2.0e-5}"#;

/// Rollers on the three faces through the origin corner: the free expansion about that corner
/// satisfies them exactly, and they remove the rigid motions.
const ROLLERS: &str = r#"    Roller X: {Type: "Prescribed Displacement", Node Set: "Min X Node Set", Coordinate: "x", Value: "0.0"}
    Roller Y: {Type: "Prescribed Displacement", Node Set: "Min Y Node Set", Coordinate: "y", Value: "0.0"}
    Roller Z: {Type: "Prescribed Displacement", Node Set: "Min Z Node Set", Coordinate: "z", Value: "0.0"}"#;

/// Every point moved along the free expansion u = αΔT(t) (X − X_corner), ΔT(t) = 50 t.
const FREE_EXPANSION: &str = r#"    Expand X: {Type: "Prescribed Displacement", Node Set: "All Node Set", Coordinate: "x", Value: "1.0e-3*t*(x - 0.5)"}
    Expand Y: {Type: "Prescribed Displacement", Node Set: "All Node Set", Coordinate: "y", Value: "1.0e-3*t*(y - 0.5)"}
    Expand Z: {Type: "Prescribed Displacement", Node Set: "All Node Set", Coordinate: "z", Value: "1.0e-3*t*(z - 0.5)"}"#;

const QUASI_STATIC: &str = "    Final Time: 1.0
    QuasiStatic:
      Number of Load Steps: 4
      Absolute Tolerance: 1.0e-9
      Maximum Solver Iterations: 20";

/// A nodal vector field (`prefix` X/Y/Z) of every point at frame `step`.
fn vectors(file: &ExodusFile, prefix: &str, step: usize) -> Vec<[f64; 3]> {
    let c: Vec<Vec<f64>> = ["X", "Y", "Z"]
        .iter()
        .map(|x| {
            let index = file
                .nodal_variable_index(&format!("{prefix}{x}"))
                .unwrap_or_else(|| panic!("no {prefix}{x}"));
            file.nodal_values(step, index).unwrap()
        })
        .collect();
    (0..c[0].len())
        .map(|i| [c[0][i], c[1][i], c[2][i]])
        .collect()
}

fn element(file: &ExodusFile, name: &str, step: usize) -> Vec<f64> {
    let index = file.element_variable_index(name).unwrap();
    file.element_values(step, index, 0).unwrap().unwrap()
}

fn largest(values: &[[f64; 3]]) -> f64 {
    values.iter().flatten().fold(0.0f64, |m, c| m.max(c.abs()))
}

/// Runs the free cube of `material` quasi-statically and checks the final frame: the
/// displacement is `strain` (X − X_corner) within `tolerance` of the largest one (4 strain),
/// the force within `tolerance` of the force scale 3KαΔT (unit cells), the temperatures are
/// those prescribed.
fn free_cube_quasi_static(material: &str, strain: f64, tolerance: f64) {
    let dir = tempfile::tempdir().unwrap();
    run_deck(dir.path(), &cube_deck(material, ROLLERS, QUASI_STATIC)).expect("run succeeds");
    let file = ExodusFile::open(&dir.path().join("cube.e")).unwrap();
    let last = file.times.len() - 1;
    assert_eq!(last, 4);
    let x = vectors(&file, "Displacement", 0);
    assert!(largest(&x) == 0.0);
    let u = vectors(&file, "Displacement", last);
    let force = vectors(&file, "Force", last);
    let mut n = 0;
    for k in 0..5 {
        for j in 0..5 {
            for i in 0..5 {
                let expected = [i, j, k].map(|c| strain * c as f64);
                for c in 0..3 {
                    assert!(
                        (u[n][c] - expected[c]).abs() < tolerance * 4.0 * strain,
                        "point {n}: {:?} vs {expected:?}",
                        u[n]
                    );
                }
                n += 1;
            }
        }
    }
    assert!(
        largest(&force) < tolerance * 3.0 * BULK * ALPHA * HEATING,
        "largest force {}",
        largest(&force)
    );
    // T = 20 + 50 t, ΔT = 50 t (from t = 0) at the last frame, t = 1.
    assert!(element(&file, "Temperature", last)
        .iter()
        .all(|&t| t == 70.0));
    assert!(element(&file, "Temperature_Change", last)
        .iter()
        .all(|&t| t == HEATING));
    assert!(element(&file, "Temperature", 0).iter().all(|&t| t == 20.0));
}

#[test]
fn a_free_lps_cube_heated_quasi_statically_expands_by_alpha_delta_t_without_force() {
    // The LPS force vanishes exactly on the free expansion (e − αΔTζ = 0 on every bond); the
    // solver's absolute tolerance 1e-9 against forces of 3KαΔT = 30 bounds the rest.
    free_cube_quasi_static(LPS, ALPHA * HEATING, 1e-6);
}

#[test]
fn a_free_correspondence_cube_heated_quasi_statically_expands_by_alpha_delta_t() {
    // The hypoelastic update sums the strain increments Δλ/λ_mid of the load steps, the
    // logarithmic strain ln λ to third order in the step; its stress vanishes when that sum
    // equals αΔT = ε, so the free cube settles at the engineering strain e^ε − 1 = ε + ε²/2 + …
    // (ε = 1e-3; ε itself would be 5e-4 off), with no force at equilibrium.
    let strain = (ALPHA * HEATING).exp() - 1.0;
    free_cube_quasi_static(CORRESPONDENCE, strain, 1e-6);
}

/// The force at every frame of a run that drives every point along the free expansion while
/// heating: zero (to round-off) for the LPS.
fn driven_cube_forces(solver: &str) -> Vec<f64> {
    let dir = tempfile::tempdir().unwrap();
    run_deck(dir.path(), &cube_deck(LPS, FREE_EXPANSION, solver)).expect("run succeeds");
    let file = ExodusFile::open(&dir.path().join("cube.e")).unwrap();
    assert!(file.times.len() > 2);
    let change = element(&file, "Temperature_Change", file.times.len() - 1);
    assert!(
        change.iter().all(|&t| (t - HEATING).abs() < 1e-12),
        "{change:?}"
    );
    (0..file.times.len())
        .map(|step| largest(&vectors(&file, "Force", step)))
        .collect()
}

#[test]
fn verlet_and_newmark_runs_see_the_thermal_strain() {
    // The same cube, every point driven along u = αΔT(t)(X − X_corner) while ΔT(t) = 50 t: the
    // free expansion at every instant, so the force vanishes in every frame. Without the
    // thermal strain the final frame would carry the force of a 1e-3 expansion (about
    // 3Kε = 30 on the surface points).
    let verlet = "    Final Time: 1.0
    Verlet:
      Fixed dt: 0.125";
    let newmark = "    Final Time: 1.0
    Implicit:
      Fixed dt: 0.25
      Absolute Tolerance: 1.0e-9
      Maximum Solver Iterations: 10";
    for solver in [verlet, newmark] {
        let forces = driven_cube_forces(solver);
        for (step, force) in forces.iter().enumerate() {
            assert!(
                *force < 1e-9 * 3.0 * BULK * ALPHA * HEATING,
                "{solver}: frame {step}: {force}"
            );
        }
    }
}

/// A 6 × 2 × 2 bar of unit cells (points at 0.5 … 5.5 along x), every point held, cooled by
/// 40 degrees in one Verlet step.
fn held_bar_deck() -> String {
    let ids = (1..=24)
        .map(|i| i.to_string())
        .collect::<Vec<_>>()
        .join(" ");
    format!(
        r#"Peridigm:
  Discretization:
    Type: "PdQuickGrid"
    NeighborhoodType: "Spherical"
    TensorProduct3DMeshGenerator:
      X Origin: 0.0
      Y Origin: 0.0
      Z Origin: 0.0
      X Length: 6.0
      Y Length: 2.0
      Z Length: 2.0
      Number Points X: 6
      Number Points Y: 2
      Number Points Z: 2
  Materials:
    Metal: {LPS}
  Blocks:
    Bar:
      Block Names: "block_1"
      Material: "Metal"
      Horizon: 2.1
  Boundary Conditions:
    All Node Set: "{ids}"
    Hold X: {{Type: "Prescribed Displacement", Node Set: "All Node Set", Coordinate: "x", Value: "0.0"}}
    Hold Y: {{Type: "Prescribed Displacement", Node Set: "All Node Set", Coordinate: "y", Value: "0.0"}}
    Hold Z: {{Type: "Prescribed Displacement", Node Set: "All Node Set", Coordinate: "z", Value: "0.0"}}
    Cool: {{Type: "Prescribed Temperature", Node Set: "All Node Set", Value: "300.0 - 40.0*t/1.0e-3"}}
  Solver:
    Final Time: 1.0e-3
    Verlet:
      Fixed dt: 1.0e-3
  Output:
    Output Filename: "bar"
    Output Frequency: 1
    Output Variables:
      Force: true
"#
    )
}

#[test]
fn a_held_bar_cooled_carries_the_closed_form_thermal_force() {
    // Every point held (Y = X), ΔT = −40 everywhere, ω = 1. Then e = 0 on every bond and, with
    // ε = αΔT, θ_i = (3/m_i) Σ_j ζ (−εζ) V_j = −3ε exactly at every point (m_i = Σ_j ζ² V_j over
    // the point's own family, surface points included), so
    // t_ij = (3K − 5μ)θ_i/m_i ζ + (15μ/m_i)(−εζ) = −9Kε ζ/m_i. The force the right half
    // (x > 3) exerts on the left half is the sum of the forces of the bonds between them:
    // P = Σ_{i right} V_i F_i·x̂ = Σ_{i right, j left} (t_ij + t_ji) V_i V_j (X_j − X_i)·x̂/ζ,
    // a tension (P < 0, pulling towards the left) since the cooled bar is kept from shrinking.
    let dir = tempfile::tempdir().unwrap();
    run_deck(dir.path(), &held_bar_deck()).expect("run succeeds");
    let file = ExodusFile::open(&dir.path().join("bar.e")).unwrap();
    let force = vectors(&file, "Force", file.times.len() - 1);
    let x: Vec<[f64; 3]> = (0..24)
        .map(|n| {
            let (i, j, k) = (n % 6, (n / 6) % 2, n / 12);
            [i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5]
        })
        .collect();
    let horizon: f64 = 2.1;
    let distance = |a: [f64; 3], b: [f64; 3]| -> f64 {
        ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2) + (b[2] - a[2]).powi(2)).sqrt()
    };
    let bonded = |a: usize, b: usize| a != b && distance(x[a], x[b]) <= horizon;
    let m: Vec<f64> = (0..24)
        .map(|i| {
            (0..24)
                .filter(|&j| bonded(i, j))
                .map(|j| distance(x[i], x[j]).powi(2))
                .sum()
        })
        .collect();
    let strain = ALPHA * -40.0;
    let mut expected = 0.0;
    for i in (0..24).filter(|&i| x[i][0] > 3.0) {
        for j in (0..24).filter(|&j| x[j][0] < 3.0 && bonded(i, j)) {
            let zeta = distance(x[i], x[j]);
            let t = -9.0 * BULK * strain * zeta * (1.0 / m[i] + 1.0 / m[j]);
            expected += t * (x[j][0] - x[i][0]) / zeta;
        }
    }
    let measured: f64 = (0..24)
        .filter(|&i| x[i][0] > 3.0)
        .map(|i| force[i][0])
        .sum();
    assert!(expected < 0.0);
    assert!(
        (measured / expected - 1.0).abs() < 1e-10,
        "{measured} vs {expected}"
    );
}

#[test]
fn thermal_keys_load_and_bad_ones_are_errors_naming_the_key() {
    let deck = |material: &str, extra: &str| {
        cube_deck(material, &format!("{ROLLERS}\n{extra}"), QUASI_STATIC)
    };
    assert_eq!(load_error(&deck(LPS, "")), None);
    assert_eq!(load_error(&deck(CORRESPONDENCE, "")), None);
    let pmb = r#"{Material Model: "Elastic Bond Based", Density: 1.0, Bulk Modulus: 1.0e4, Thermal Expansion Coefficient: 2.0e-5}"#;
    let error = load_error(&deck(pmb, "")).expect("refused");
    assert!(
        error.contains("Thermal Expansion Coefficient") && error.contains("Elastic Bond Based"),
        "{error}"
    );
    let word = LPS.replace("2.0e-5", "\"hot\"");
    let error = load_error(&deck(&word, "")).expect("refused");
    assert!(error.contains("Thermal Expansion Coefficient"), "{error}");
    // A scalar field has no direction.
    let sideways = r#"    Tilt: {Type: "Prescribed Temperature", Node Set: "All Node Set", Coordinate: "y", Value: "1.0"}"#;
    let error = load_error(&deck(LPS, sideways)).expect("refused");
    assert!(error.contains("Coordinate"), "{error}");
    // A damage model's coefficient loads on the stretch models and runs.
    let dir = tempfile::tempdir().unwrap();
    let damaged = cube_deck(LPS, ROLLERS, QUASI_STATIC)
        .replace(
            "      Horizon: 1.75\n",
            "      Horizon: 1.75\n      Damage Model: \"Brittle\"\n",
        )
        .replace(
            "  Blocks:\n",
            "  Damage Models:\n    Brittle: {Damage Model: \"Critical Stretch\", Critical Stretch: 0.01, Thermal Expansion Coefficient: 2.0e-5}\n  Blocks:\n",
        );
    run_deck(dir.path(), &damaged).expect("runs");
}

#[test]
fn a_failing_temperature_expression_names_its_condition() {
    let bad = r#"    Broken: {Type: "Prescribed Temperature", Node Set: "All Node Set", Value: "sqrt(-1.0 - t)"}"#;
    let dir = tempfile::tempdir().unwrap();
    let error = run_deck(
        dir.path(),
        &cube_deck(LPS, &format!("{ROLLERS}\n{bad}"), QUASI_STATIC),
    )
    .expect_err("fails")
    .to_string();
    assert!(error.contains("Broken"), "{error}");
}
