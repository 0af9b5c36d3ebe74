//! `peridyn modulus` and `peridyn dogbone` through the command line: known answers, exit codes
//! and messages for bad input, and the generated deck passing `peridyn check`.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn peridyn(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_peridyn"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("peridyn runs")
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// Globals of a bar with gauge points at y = ±1.25 (L₀ = 2.5), pulled in two frames:
/// u_top − u_bottom = 0.0025 and 0.005 give ε = 1e-3 and 2e-3; reactions −3.6e8 and −7.2e8
/// dyne over A = 0.2 cm² give σ = 1.8e9 and 3.6e9, so E = 1.8e12 dyne/cm² (180 GPa) in both.
const RUN: &str =
    "Time,Gage_Top_Initial_PositionX,Gage_Top_Initial_PositionY,Gage_Top_Initial_PositionZ,\
Gage_Bottom_Initial_PositionX,Gage_Bottom_Initial_PositionY,Gage_Bottom_Initial_PositionZ,\
Gage_Top_DisplacementX,Gage_Top_DisplacementY,Gage_Top_DisplacementZ,\
Gage_Bottom_DisplacementX,Gage_Bottom_DisplacementY,Gage_Bottom_DisplacementZ,\
Top_Reaction_ForceX,Top_Reaction_ForceY,Top_Reaction_ForceZ
0.0,0.03,1.25,0,0.03,-1.25,0,0,0,0,0,0,0,0,0,0
0.5,0.03,1.25,0,0.03,-1.25,0,-1e-4,0.00125,0,-1e-4,-0.00125,0,5.0,-3.6e8,0.1
1.0,0.03,1.25,0,0.03,-1.25,0,-2e-4,0.0025,0,-2e-4,-0.0025,0,5.0,-7.2e8,0.1
";

fn run_csv(dir: &Path, contents: &str) -> PathBuf {
    let path = dir.join("run.csv");
    std::fs::write(&path, contents).unwrap();
    path
}

#[test]
fn modulus_prints_e_per_frame_and_writes_the_plot() {
    let dir = tempfile::tempdir().unwrap();
    run_csv(dir.path(), RUN);
    let args = [
        "modulus",
        "run.csv",
        "--area",
        "0.2",
        "--expected",
        "1.8e12",
        "--units",
        "cgs",
        "--plot",
        "curve.png",
    ];
    let output = peridyn(&args, dir.path());
    let stdout = text(&output.stdout);
    assert!(output.status.success(), "{}", text(&output.stderr));
    let rows: Vec<&str> = stdout.lines().skip(2).collect();
    assert_eq!(rows.len(), 2, "{stdout}");
    for row in rows {
        assert!(
            row.contains("1.800000e12") && row.contains("180.00"),
            "{row}"
        );
        assert!(row.contains("+0.00 %"), "{row}");
    }
    let png = std::fs::read(dir.path().join("curve.png")).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
}

#[test]
fn modulus_bad_input_exits_2_naming_file_and_label() {
    let dir = tempfile::tempdir().unwrap();
    let missing = peridyn(&["modulus", "absent.csv", "--area", "0.2"], dir.path());
    assert_eq!(missing.status.code(), Some(2));
    assert!(text(&missing.stderr).contains("absent.csv"));

    run_csv(dir.path(), RUN);
    let label = peridyn(
        &[
            "modulus",
            "run.csv",
            "--area",
            "0.2",
            "--force-label",
            "Grip_Force",
        ],
        dir.path(),
    );
    assert_eq!(label.status.code(), Some(2));
    let message = text(&label.stderr);
    assert!(
        message.contains("run.csv") && message.contains("Grip_ForceY"),
        "{message}"
    );

    run_csv(
        dir.path(),
        &RUN.replace("0.0025,0,-2e-4,-0.0025", "0,0,-2e-4,0"),
    );
    let zero = peridyn(&["modulus", "run.csv", "--area", "0.2"], dir.path());
    assert_eq!(zero.status.code(), Some(2));
    let message = text(&zero.stderr);
    assert!(
        message.contains("run.csv") && message.contains("Gage_Top_Displacement"),
        "{message}"
    );
    assert!(!message.contains("panicked"), "{message}");
}

fn read_dir_sorted(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|entry| {
            let path = entry.unwrap().path();
            let name = path.file_name().unwrap().to_string_lossy().into_owned();
            (name, std::fs::read(&path).unwrap())
        })
        .collect();
    files.sort();
    files
}

#[test]
fn dogbone_deck_passes_check_and_is_deterministic() {
    let dir = tempfile::tempdir().unwrap();
    for out in ["a", "b"] {
        let output = peridyn(
            &["dogbone", "--points", "3000", "--output-dir", out],
            dir.path(),
        );
        assert!(output.status.success(), "{}", text(&output.stderr));
    }
    let first = read_dir_sorted(&dir.path().join("a"));
    assert_eq!(first.len(), 8);
    assert_eq!(first, read_dir_sorted(&dir.path().join("b")));

    let check = peridyn(&["check", "a/dogbone.yaml", "--json"], dir.path());
    assert!(check.status.success(), "{}", text(&check.stderr));
    let plan: serde_json::Value = serde_json::from_slice(&check.stdout).unwrap();
    let points = plan["points"].as_u64().unwrap();
    assert!(points.abs_diff(3000) <= 90, "{points}");
    assert_eq!(plan["unsupported"].as_array().unwrap().len(), 0, "{plan}");
    for set in plan["node_sets"].as_array().unwrap() {
        assert!(set["points"].as_u64().unwrap() > 0, "{set}");
    }
    assert_eq!(plan["blocks"].as_array().unwrap().len(), 3);
}

/// The committed files of `examples/tensile_test` whose names `keep` accepts.
fn committed_example(keep: impl Fn(&str) -> bool) -> Vec<(String, Vec<u8>)> {
    let example = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/tensile_test");
    read_dir_sorted(&example)
        .into_iter()
        .filter(|(name, _)| keep(name))
        .collect()
}

#[test]
fn committed_example_is_what_the_generator_writes() {
    let dir = tempfile::tempdir().unwrap();
    let output = peridyn(&["dogbone", "--points", "5000"], dir.path());
    assert!(output.status.success(), "{}", text(&output.stderr));
    let committed =
        committed_example(|name| name.starts_with("dogbone") && !name.starts_with("dogbone_99k"));
    assert_eq!(committed, read_dir_sorted(dir.path()));
}

/// The paper-size deck and node sets are committed; its 8 MB point file is not (the README
/// has users generate it), so it is left out on both sides.
#[test]
fn committed_paper_size_deck_is_what_the_generator_writes() {
    let dir = tempfile::tempdir().unwrap();
    let output = peridyn(
        &["dogbone", "--points", "99000", "--name", "dogbone_99k"],
        dir.path(),
    );
    assert!(output.status.success(), "{}", text(&output.stderr));
    let not_points = |name: &str| name.starts_with("dogbone_99k") && name != "dogbone_99k.txt";
    let generated: Vec<(String, Vec<u8>)> = read_dir_sorted(dir.path())
        .into_iter()
        .filter(|(name, _)| not_points(name))
        .collect();
    assert_eq!(generated.len(), 7);
    assert_eq!(committed_example(not_points), generated);
}

#[test]
fn dogbone_refuses_too_few_points() {
    let dir = tempfile::tempdir().unwrap();
    let output = peridyn(&["dogbone", "--points", "10"], dir.path());
    assert_eq!(output.status.code(), Some(2));
    assert!(text(&output.stderr).contains("--points 10"));
}
