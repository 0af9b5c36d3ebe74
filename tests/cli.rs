//! The `peridyn` command line: examples, exit codes and error messages for bad input.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn peridyn(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_peridyn"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("peridyn runs")
}

fn stderr(output: &Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}

/// A small valid deck: 4×2×2 QuickGrid bar, LPS, a node set, 20 Verlet steps, one output.
const BASE: &str = r#"Peridigm:
  Discretization:
    Type: "PdQuickGrid"
    TensorProduct3DMeshGenerator:
      X Origin: 0.0
      Y Origin: 0.0
      Z Origin: 0.0
      X Length: 4.0
      Y Length: 2.0
      Z Length: 2.0
      Number Points X: 4
      Number Points Y: 2
      Number Points Z: 2
  Materials:
    Steel:
      Material Model: "Elastic"
      Density: 7800.0
      Bulk Modulus: 130.0e9
      Shear Modulus: 78.0e9
  Blocks:
    All:
      Block Names: "block_1"
      Material: "Steel"
      Horizon: 1.5
  Boundary Conditions:
    Left Node Set: "1 5 9 13"
    Push:
      Type: "Initial Velocity"
      Node Set: "Left Node Set"
      Coordinate: "x"
      Value: "1.0"
  Solver:
    Final Time: 1.0e-5
    Verlet:
      Fixed dt: 5.0e-7
  Output:
    Output Filename: "bar"
    Output Frequency: 5
    Output Variables:
      Displacement: true
      Number_Of_Neighbors: true
      Global_Kinetic_Energy: true
"#;

fn write_deck(dir: &Path, text: &str) -> PathBuf {
    let path = dir.join("deck.yaml");
    std::fs::write(&path, text).unwrap();
    path
}

/// Runs `check` on BASE with `from` replaced by `to` and returns (exit code, stderr).
fn check_with(from: &str, to: &str) -> (i32, String) {
    assert!(BASE.contains(from), "test setup: {from:?} not in BASE");
    let dir = tempfile::tempdir().unwrap();
    write_deck(dir.path(), &BASE.replacen(from, to, 1));
    let output = peridyn(&["check", "deck.yaml"], dir.path());
    (output.status.code().unwrap_or(-1), stderr(&output))
}

fn line_of(text: &str, needle: &str) -> usize {
    text.lines().position(|l| l.contains(needle)).unwrap() + 1
}

fn assert_invalid(from: &str, to: &str, expected: &[&str]) {
    let (code, message) = check_with(from, to);
    assert_eq!(code, 2, "exit code for {to:?}: {message}");
    assert!(!message.contains("panicked"), "{message}");
    assert!(message.contains("deck.yaml"), "file not named: {message}");
    for part in expected {
        assert!(message.contains(part), "{part:?} missing from: {message}");
    }
}

#[test]
fn every_example_passes_check() {
    let examples = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples");
    let mut count = 0;
    for entry in std::fs::read_dir(&examples).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().and_then(|e| e.to_str()) != Some("yaml") {
            continue;
        }
        let output = peridyn(&["check", path.to_str().unwrap()], &examples);
        assert!(
            output.status.success(),
            "{}: {}",
            path.display(),
            stderr(&output)
        );
        let plan = String::from_utf8_lossy(&output.stdout);
        assert!(
            !plan.contains("not supported by this build"),
            "{}: {plan}",
            path.display()
        );
        count += 1;
    }
    assert!(count >= 1, "no example decks found");
}

#[test]
fn check_reports_exact_sizes_as_json() {
    let dir = tempfile::tempdir().unwrap();
    write_deck(dir.path(), BASE);
    let output = peridyn(&["check", "deck.yaml", "--json"], dir.path());
    assert!(output.status.success(), "{}", stderr(&output));
    let plan: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    // 4×2×2 = 16 points with Δ = 1 on every axis. Peridigm's box rule: δ/Δ = 1.5 → floor 1,
    // fraction 0.5 ≥ ½ rounds up → n = 2 cells each way, so the box spans the whole 2×2
    // cross-section and x ± 2: an end point (x index 0 or 3) sees 3·2·2 − 1 = 11 points, an
    // inner one (index 1 or 2) 4·2·2 − 1 = 15. Directed bonds: 8 × 11 + 8 × 15 = 208.
    assert_eq!(plan["points"], 16);
    assert_eq!(plan["bonds"], 208);
    assert_eq!(plan["blocks"][0]["family_min"], 11);
    assert_eq!(plan["blocks"][0]["family_max"], 15);
    assert_eq!(plan["node_sets"][0]["points"], 4);
    assert_eq!(plan["physics"]["state_based"], true);
    assert_eq!(plan["physics"]["contact"], false);
    assert_eq!(plan["outputs"][0]["file"], "bar.e");
    assert_eq!(plan["time_step"]["used"], 5.0e-7);
    // floor(1e-5 / 5e-7) = 20 steps.
    assert_eq!(plan["time_step"]["steps"], 20);
    assert!(plan["unsupported"].as_array().unwrap().is_empty());
    // On several ranks: LPS ("Elastic") reads its neighbours' dilatation, so two ghost
    // layers; an explicit run refreshes only the ghosts' positions, and with no contact each
    // rank searches its own families.
    assert_eq!(plan["parallel"]["ghost_depth"], 2);
    let exchanged = plan["parallel"]["exchanged"].as_array().unwrap();
    assert_eq!(exchanged.len(), 1);
    assert!(exchanged[0]
        .as_str()
        .unwrap()
        .starts_with("ghost positions"));
    assert!(plan["parallel"]["families"]
        .as_str()
        .unwrap()
        .starts_with("searched per rank"));
    assert!(plan["parallel"]["refused"].is_null());
}

#[test]
fn the_parallel_plan_follows_the_material() {
    // Bond-based forces read only a bond's two ends: one ghost layer.
    let (dir, text) = (
        tempfile::tempdir().unwrap(),
        BASE.replace("\"Elastic\"", "\"Elastic Bond Based\"")
            .replace("      Shear Modulus: 78.0e9\n", ""),
    );
    write_deck(dir.path(), &text);
    let output = peridyn(&["check", "deck.yaml", "--json"], dir.path());
    assert!(output.status.success(), "{}", stderr(&output));
    let plan: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    assert_eq!(plan["physics"]["state_based"], false);
    assert_eq!(plan["parallel"]["ghost_depth"], 1);
}

#[test]
fn check_prints_the_planned_memory_per_directed_bond() {
    let dir = tempfile::tempdir().unwrap();
    let text = BASE
        .replace("\"Elastic\"", "\"Elastic Bond Based\"")
        .replace("      Shear Modulus: 78.0e9\n", "");
    write_deck(dir.path(), &text);
    let output = peridyn(&["check", "deck.yaml", "--json"], dir.path());
    assert!(output.status.success(), "{}", stderr(&output));
    let plan: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    // The 208 directed bonds and 16 points of `check_reports_exact_sizes_as_json`. An explicit
    // PMB run holds the points' and the bonds' fields and nothing per pair or per bond beyond
    // them (its closed-block loop reads each bond's own data).
    assert_eq!(plan["bonds"], 208);
    let parts = plan["memory"].as_array().unwrap();
    let names: Vec<&str> = parts.iter().map(|p| p["part"].as_str().unwrap()).collect();
    assert_eq!(names, ["points and state", "bonds"]);
    let total = plan["memory_total"].as_u64().unwrap();
    let sum: u64 = parts.iter().map(|p| p["bytes"].as_u64().unwrap()).sum();
    assert_eq!(total, sum);
    assert_eq!(
        plan["bytes_per_bond"].as_f64().unwrap(),
        total as f64 / 208.0
    );
    // The text form prints it under the memory estimate, one decimal.
    let output = peridyn(&["check", "deck.yaml"], dir.path());
    let stdout = String::from_utf8_lossy(&output.stdout).into_owned();
    let line = stdout
        .lines()
        .find(|l| l.trim_start().starts_with("per directed bond"))
        .unwrap_or_else(|| panic!("no bytes per bond in\n{stdout}"));
    assert!(
        line.ends_with(&format!("{:.1} B", total as f64 / 208.0)),
        "{line}"
    );
}

#[test]
fn run_writes_exodus_and_history_and_the_peridigm_style_alias_works() {
    let dir = tempfile::tempdir().unwrap();
    write_deck(dir.path(), BASE);
    let output = peridyn(&["deck.yaml"], dir.path());
    assert!(output.status.success(), "{}", stderr(&output));
    let file = peridyn::io::exodus::ExodusFile::open(&dir.path().join("bar.e")).unwrap();
    // 20 steps, frequency 5: calls 1 (initial), 6, 11, 16, 21 write → 5 frames.
    assert_eq!(file.times.len(), 5);
    assert_eq!(file.coordinates.len(), 16);
    let history = std::fs::read_to_string(dir.path().join("bar.csv")).unwrap();
    assert_eq!(history.lines().count(), 6);
}

#[test]
fn diff_passes_identical_files_and_fails_different_ones() {
    let dir = tempfile::tempdir().unwrap();
    write_deck(dir.path(), BASE);
    assert!(
        peridyn(&["run", "deck.yaml", "--output-dir", "a"], dir.path())
            .status
            .success()
    );
    let faster = BASE.replace("Value: \"1.0\"", "Value: \"2.0\"");
    write_deck(dir.path(), &faster);
    assert!(
        peridyn(&["run", "deck.yaml", "--output-dir", "b"], dir.path())
            .status
            .success()
    );
    let same = peridyn(&["diff", "a/bar.e", "a/bar.e"], dir.path());
    assert!(
        same.status.success(),
        "{}",
        String::from_utf8_lossy(&same.stdout)
    );
    let different = peridyn(&["diff", "a/bar.e", "b/bar.e"], dir.path());
    assert_eq!(different.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&different.stdout).contains("Displacement"));
}

#[test]
fn malformed_yaml() {
    let (code, message) = check_with("      Density: 7800.0", "      Density: [7800.0");
    assert_eq!(code, 2, "{message}");
    assert!(
        message.contains("deck.yaml") && message.contains("malformed YAML"),
        "{message}"
    );
}

#[test]
fn unknown_key_with_suggestion() {
    let line = line_of(BASE, "Density:");
    assert_invalid(
        "      Density: 7800.0",
        "      Densty: 7800.0",
        &[
            &format!("deck.yaml:{line}"),
            "Materials → Steel → Densty",
            "did you mean \"Density\"",
        ],
    );
}

#[test]
fn missing_required_key() {
    assert_invalid(
        "      Density: 7800.0\n",
        "",
        &["Materials → Steel", "Density"],
    );
}

#[test]
fn wrong_type() {
    assert_invalid(
        "      Density: 7800.0",
        "      Density: \"heavy\"",
        &["Materials → Steel → Density", "number"],
    );
}

#[test]
fn negative_density_and_zero_horizon() {
    assert_invalid(
        "      Density: 7800.0",
        "      Density: -7800.0",
        &["Density", "positive"],
    );
    assert_invalid(
        "      Horizon: 1.5",
        "      Horizon: 0.0",
        &["Blocks → All → Horizon"],
    );
}

#[test]
fn negative_volume_in_a_text_mesh() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("mesh.txt"), "0 0 0 1 1.0\n1 0 0 1 -1.0\n").unwrap();
    let deck = BASE
        .replace(
            "    Type: \"PdQuickGrid\"\n",
            "    Type: \"Text File\"\n    Input Mesh File: \"mesh.txt\"\n",
        )
        .replace(
            "    Left Node Set: \"1 5 9 13\"",
            "    Left Node Set: \"1\"",
        );
    let start = deck.find("    TensorProduct3DMeshGenerator:").unwrap();
    let end = deck.find("  Materials:").unwrap();
    let deck = format!("{}{}", &deck[..start], &deck[end..]);
    write_deck(dir.path(), &deck);
    let output = peridyn(&["check", "deck.yaml"], dir.path());
    let message = stderr(&output);
    assert_eq!(output.status.code(), Some(2), "{message}");
    assert!(
        message.contains("mesh.txt:2") && message.contains("volume"),
        "{message}"
    );
}

#[test]
fn node_set_id_out_of_range() {
    let line = line_of(BASE, "Left Node Set:");
    assert_invalid(
        "    Left Node Set: \"1 5 9 13\"",
        "    Left Node Set: \"1 5 9 17\"",
        &[
            &format!("deck.yaml:{line}"),
            "Left Node Set",
            "17",
            "16 points",
        ],
    );
}

#[test]
fn missing_mesh_and_node_set_files() {
    assert_invalid(
        "    Left Node Set: \"1 5 9 13\"",
        "    Left Node Set: \"no_such_file.txt\"",
        &["Left Node Set", "no_such_file.txt"],
    );
    let deck = BASE.replace(
        "    Type: \"PdQuickGrid\"\n",
        "    Type: \"Exodus\"\n    Input Mesh File: \"absent.g\"\n",
    );
    let start = deck.find("    TensorProduct3DMeshGenerator:").unwrap();
    let end = deck.find("  Materials:").unwrap();
    let deck = format!("{}{}", &deck[..start], &deck[end..]);
    let dir = tempfile::tempdir().unwrap();
    write_deck(dir.path(), &deck);
    let output = peridyn(&["check", "deck.yaml"], dir.path());
    let message = stderr(&output);
    assert_eq!(output.status.code(), Some(2), "{message}");
    assert!(
        message.contains("Input Mesh File") && message.contains("absent.g"),
        "{message}"
    );
}

#[test]
fn block_missing_from_the_mesh() {
    assert_invalid(
        "      Block Names: \"block_1\"",
        "      Block Names: \"block_1 block_2\"",
        &["Blocks → All → Block Names", "block_2"],
    );
}

#[test]
fn expressions_that_do_not_parse_or_use_unknown_variables() {
    assert_invalid(
        "      Value: \"1.0\"",
        "      Value: \"1.0 +* x\"",
        &["Boundary Conditions → Push → Value"],
    );
    assert_invalid(
        "      Value: \"1.0\"",
        "      Value: \"2.0*w\"",
        &["Boundary Conditions → Push → Value", "w"],
    );
}

#[test]
fn unknown_output_variable_with_suggestion() {
    assert_invalid(
        "      Displacement: true",
        "      Displacment: true",
        &[
            "Output → Output Variables → Displacment",
            "did you mean \"Displacement\"",
        ],
    );
}

#[test]
fn empty_block_names() {
    assert_invalid(
        "      Block Names: \"block_1\"",
        "      Block Names: \"\"",
        &["Blocks → All → Block Names"],
    );
}

#[test]
fn critical_stretch_needs_exactly_one_limit() {
    let both = "  Damage Models:\n    Brittle:\n      Damage Model: \"Critical Stretch\"\n      Critical Energy Release Rate: 1.8e5\n      Critical Stretch: 0.001\n  Blocks:";
    assert_invalid(
        "  Blocks:",
        both,
        &["Damage Models → Brittle", "exactly one"],
    );
    let neither =
        "  Damage Models:\n    Brittle:\n      Damage Model: \"Critical Stretch\"\n  Blocks:";
    assert_invalid(
        "  Blocks:",
        neither,
        &["Damage Models → Brittle", "exactly one"],
    );
}

#[test]
fn keys_peridigm_accepts_without_effect_warn_in_check_and_run_and_misspellings_stay_errors() {
    let deck = BASE
        .replacen(
            "  Discretization:\n    Type: \"PdQuickGrid\"\n",
            "  Optimization Based Coupling: true\n  Discretization:\n    Type: \"PdQuickGrid\"\n    Verbose: true\n    Store Exodus Mesh: true\n",
            1,
        )
        .replacen(
            "      Shear Modulus: 78.0e9\n",
            "      Shear Modulus: 78.0e9\n      Compute Partial Stress: true\n      Verbose: true\n",
            1,
        )
        .replacen(
            "    Verlet:\n",
            "    Jacobian Diagnostics: true\n    Verlet:\n",
            1,
        )
        .replacen(
            "    Output Frequency: 5\n",
            "    Output Frequency: 5\n    Bond Family: true\n",
            1,
        );
    let expected = [
        (
            "Optimization Based Coupling:",
            "Optimization Based Coupling",
        ),
        ("    Verbose: true", "Discretization → Verbose"),
        ("Store Exodus Mesh:", "Discretization → Store Exodus Mesh"),
        (
            "Compute Partial Stress:",
            "Materials → Steel → Compute Partial Stress",
        ),
        ("      Verbose: true", "Materials → Steel → Verbose"),
        ("Jacobian Diagnostics:", "Solver → Jacobian Diagnostics"),
        ("Bond Family:", "Output → Bond Family"),
    ];
    let dir = tempfile::tempdir().unwrap();
    write_deck(dir.path(), &deck);
    let check = peridyn(&["check", "deck.yaml"], dir.path());
    assert!(check.status.success(), "{}", stderr(&check));
    let plan = String::from_utf8_lossy(&check.stdout).into_owned();
    let run = peridyn(&["run", "deck.yaml"], dir.path());
    assert!(run.status.success(), "{}", stderr(&run));
    assert!(dir.path().join("bar.e").exists(), "the run went on");
    let log = stderr(&run);
    for (needle, key) in expected {
        // Lines are counted on the deck as written (the first match of the needle).
        let line = line_of(&deck, needle);
        let warning = format!("warning: deck.yaml:{line}: {key}: accepted but has no effect");
        assert!(
            plan.contains(&warning),
            "{warning:?} missing from check:\n{plan}"
        );
        assert!(
            log.contains(&warning),
            "{warning:?} missing from run:\n{log}"
        );
    }
    // A misspelt key is still an error with a hint, not a warning.
    let misspelt = deck.replacen("Bond Family:", "Bond Famly:", 1);
    write_deck(dir.path(), &misspelt);
    let output = peridyn(&["check", "deck.yaml"], dir.path());
    assert_eq!(output.status.code(), Some(2));
    assert!(
        stderr(&output).contains("did you mean \"Bond Family\""),
        "{}",
        stderr(&output)
    );
}

/// The base deck with its material replaced by `material` (the lines after `Material Model`).
fn with_material(material: &str) -> String {
    let elastic = "      Material Model: \"Elastic\"\n      Density: 7800.0\n      Bulk Modulus: 130.0e9\n      Shear Modulus: 78.0e9\n";
    assert!(BASE.contains(elastic));
    BASE.replacen(elastic, material, 1)
}

const HARDENING: &str = "      Material Model: \"Elastic Plastic Hardening\"\n      Density: 7800.0\n      Bulk Modulus: 130.0e9\n      Shear Modulus: 78.0e9\n      Yield Stress: 2.0e8\n      Hardening Modulus: 1.0e9\n";
const VISCOELASTIC: &str = "      Material Model: \"Viscoelastic\"\n      Density: 7800.0\n      Bulk Modulus: 130.0e9\n      Shear Modulus: 78.0e9\n      lambda_i: 0.5\n      tau b: 1.0e-6\n";

#[test]
fn hardening_and_viscoelastic_materials_check_and_run() {
    for (material, name) in [
        (HARDENING, "Elastic Plastic Hardening"),
        (VISCOELASTIC, "Viscoelastic"),
    ] {
        let dir = tempfile::tempdir().unwrap();
        write_deck(dir.path(), &with_material(material));
        let output = peridyn(&["check", "deck.yaml", "--json"], dir.path());
        assert!(output.status.success(), "{name}: {}", stderr(&output));
        let plan: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
        assert_eq!(plan["blocks"][0]["material_model"], name);
        assert_eq!(plan["unsupported"], serde_json::json!([]), "{name}");
        let output = peridyn(&["run", "deck.yaml"], dir.path());
        assert!(output.status.success(), "{name}: {}", stderr(&output));
        assert!(dir.path().join("bar.e").exists(), "{name}");
    }
}

#[test]
fn hardening_and_viscoelastic_keys_are_checked() {
    let cases: [(&str, &str, &str, &[&str]); 6] = [
        (
            HARDENING,
            "      Hardening Modulus: 1.0e9\n",
            "",
            &["Hardening Modulus"],
        ),
        (
            HARDENING,
            "      Hardening Modulus: 1.0e9\n",
            "      Hardening Modulus: -1.0\n",
            &["Hardening Modulus", "zero or a positive number"],
        ),
        (
            HARDENING,
            "      Hardening Modulus: 1.0e9\n",
            "      Hardening Modulus: 1.0e9\n      Thermal Expansion Coefficient: 1.0e-5\n",
            &["Thermal Expansion Coefficient", "has no thermal strain"],
        ),
        (VISCOELASTIC, "      tau b: 1.0e-6\n", "", &["tau b"]),
        (
            VISCOELASTIC,
            "      lambda_i: 0.5\n",
            "      lambda_i: 2.0\n",
            &["lambda_i", "[0, 1]"],
        ),
        (
            VISCOELASTIC,
            "      tau b: 1.0e-6\n",
            "      tau b: 1.0e-6\n      Apply Automatic Differentiation Jacobian: true\n",
            &[
                "Apply Automatic Differentiation Jacobian",
                "does not support",
            ],
        ),
    ];
    for (material, from, to, expected) in cases {
        let text = with_material(&material.replacen(from, to, 1));
        let dir = tempfile::tempdir().unwrap();
        write_deck(dir.path(), &text);
        let output = peridyn(&["check", "deck.yaml"], dir.path());
        let message = stderr(&output);
        assert_eq!(output.status.code(), Some(2), "{to:?}: {message}");
        assert!(!message.contains("panicked"), "{message}");
        assert!(message.contains("deck.yaml"), "file not named: {message}");
        for part in expected {
            assert!(message.contains(part), "{part:?} missing from: {message}");
        }
    }
}

#[test]
fn check_prints_the_surface_correction_and_refuses_it_on_a_planar_material() {
    // Every point of the 4×2×2 bar lies within δ of a surface.
    let dir = tempfile::tempdir().unwrap();
    let spherical = BASE.replacen(
        "Type: \"PdQuickGrid\"\n",
        "Type: \"PdQuickGrid\"\n    NeighborhoodType: \"Spherical\"\n",
        1,
    );
    let text = spherical.replacen(
        "Horizon: 1.5\n",
        "Horizon: 1.5\n      Surface Correction: \"Force Normalization\"\n",
        1,
    );
    write_deck(dir.path(), &text);
    let output = peridyn(&["check", "deck.yaml"], dir.path());
    assert!(output.status.success(), "{}", stderr(&output));
    let plan = String::from_utf8_lossy(&output.stdout);
    assert!(
        plan.contains("surface correction \"Force Normalization\": ")
            && plan.contains(" of 16 points corrected, factors "),
        "{plan}"
    );

    let planar = "Material Model: \"Elastic Bond Based\"\n      Density: 7800.0\n      Bulk Modulus: 130.0e9\n      Plane Strain: true\n      Height: 1.0\n";
    let text = spherical
        .replacen(
            "Material Model: \"Elastic\"\n      Density: 7800.0\n      Bulk Modulus: 130.0e9\n      Shear Modulus: 78.0e9\n",
            planar,
            1,
        )
        .replacen(
            "Horizon: 1.5\n",
            "Horizon: 1.5\n      Surface Correction: \"Force Normalization\"\n",
            1,
        );
    write_deck(dir.path(), &text);
    let output = peridyn(&["check", "deck.yaml"], dir.path());
    let message = stderr(&output);
    assert_eq!(output.status.code(), Some(2), "{message}");
    assert!(
        message.contains(&format!(
            "deck.yaml:{}: Blocks → All → Surface Correction",
            line_of(&text, "Surface Correction")
        )),
        "{message}"
    );
    assert!(message.contains("planar"), "{message}");

    // QuickGrid's default box-shaped families have no spherical bulk to compare with.
    let (code, message) = check_with(
        "Horizon: 1.5\n",
        "Horizon: 1.5\n      Surface Correction: \"Force Normalization\"\n",
    );
    assert_eq!(code, 2, "{message}");
    assert!(message.contains("NeighborhoodType"), "{message}");
}
