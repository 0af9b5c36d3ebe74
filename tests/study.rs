//! `peridyn study` through the command line: a 2 × 2 grid over a tiny explicit bar with the
//! CSV and plots it writes, the error against a closed-form value, a variant that blows up as a
//! row of the table, and an unknown key path as invalid input. Also `run --set`, which the
//! study's variants use.

use std::path::Path;
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

/// Impact speed of the struck end (m/s).
const SPEED: f64 = 10.0;

/// A 10 × 4 × 4 steel bar (160 points, spacing 0.1 m, δ = 3.01 spacings) whose 16 points at
/// x = 0 start at `SPEED` along x. The `Study` section varies the Safety Factor and measures
/// the mean x-velocity of all points against its exact value.
fn deck() -> String {
    let end: Vec<String> = (0..16).map(|k| (1 + 10 * k).to_string()).collect();
    format!(
        "Peridigm:
  Discretization:
    Type: \"PdQuickGrid\"
    NeighborhoodType: \"Spherical\"
    TensorProduct3DMeshGenerator:
      X Origin: 0.0
      Y Origin: 0.0
      Z Origin: 0.0
      X Length: 1.0
      Y Length: 0.4
      Z Length: 0.4
      Number Points X: 10
      Number Points Y: 4
      Number Points Z: 4
  Materials:
    Steel:
      Material Model: \"Elastic\"
      Density: 7800.0
      Young's Modulus: 200.0e9
      Poisson's Ratio: 0.3
  Blocks:
    Bar:
      Block Names: \"block_1\"
      Material: \"Steel\"
      Horizon: 0.301
  Boundary Conditions:
    End Node Set: \"{}\"
    Impact:
      Type: \"Initial Velocity\"
      Node Set: \"End Node Set\"
      Coordinate: \"x\"
      Value: \"{SPEED}\"
  Solver:
    Initial Time: 0.0
    Final Time: 2.0e-3
    Verlet:
      Safety Factor: 0.8
  Output:
    Output Filename: \"bar\"
    Output Frequency: 50
    Output Variables:
      Displacement: true
      Velocity: true
  Study:
    Vary:
      \"Solver.Verlet.Safety Factor\": \"0.5, 0.8\"
    Measure:
      Momentum: \"mean:VelocityX@all={}\"
    Jobs: 2
",
        end.join(" "),
        exact_mean_velocity()
    )
}

/// No external force acts and internal forces come in equal and opposite bond pairs, so the
/// momentum Σ ρ V v stays that of the start: 16 of the 160 equal-volume points at `SPEED`,
/// the mean velocity of all points is 16/160 × SPEED = 1.0 m/s at every time.
fn exact_mean_velocity() -> f64 {
    16.0 / 160.0 * SPEED
}

fn write_deck(dir: &Path) {
    std::fs::write(dir.join("bar.yaml"), deck()).unwrap();
}

/// Splits one CSV line with RFC 4180 quotes.
fn cells(line: &str) -> Vec<String> {
    let mut out = vec![String::new()];
    let mut quoted = false;
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '"' if quoted && chars.peek() == Some(&'"') => {
                chars.next();
                out.last_mut().unwrap().push('"');
            }
            '"' => quoted = !quoted,
            ',' if !quoted => out.push(String::new()),
            _ => out.last_mut().unwrap().push(c),
        }
    }
    out
}

/// The study's CSV as (header, rows).
fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = cells(lines.next().unwrap());
    (header, lines.map(cells).collect())
}

fn column(header: &[String], name: &str) -> usize {
    header
        .iter()
        .position(|h| h == name)
        .unwrap_or_else(|| panic!("no column {name} in {header:?}"))
}

#[test]
fn a_deck_with_a_study_section_still_checks_and_runs() {
    let dir = tempfile::tempdir().unwrap();
    write_deck(dir.path());
    let check = peridyn(&["check", "bar.yaml"], dir.path());
    assert!(check.status.success(), "{}", text(&check.stderr));
    let run = peridyn(&["run", "bar.yaml", "--output-dir", "out"], dir.path());
    assert!(run.status.success(), "{}", text(&run.stderr));
    assert!(dir.path().join("out/bar.e").exists());
}

#[test]
fn run_set_changes_a_deck_value() {
    let dir = tempfile::tempdir().unwrap();
    write_deck(dir.path());
    // 20 × the stable estimate: the stability monitor stops the run (exit 3).
    let args = [
        "run",
        "bar.yaml",
        "--output-dir",
        "out",
        "--set",
        "Solver.Verlet.Safety Factor=20",
    ];
    let run = peridyn(&args, dir.path());
    assert_eq!(run.status.code(), Some(3), "{}", text(&run.stderr));
    assert!(text(&run.stderr).contains("safety factor 20"));
}

#[test]
fn a_two_by_two_study_writes_one_row_per_variant_and_the_errors() {
    let dir = tempfile::tempdir().unwrap();
    write_deck(dir.path());
    let args = [
        "study",
        "bar.yaml",
        "--vary",
        "Blocks.Bar.Horizon=0.201,0.301",
        "--measure",
        "mean:DisplacementX@End Node Set",
        "--output-dir",
        "grid",
    ];
    let output = peridyn(&args, dir.path());
    let stdout = text(&output.stdout);
    assert!(output.status.success(), "{}", text(&output.stderr));
    assert!(
        stdout.contains("Momentum: error against the exact value 1e0"),
        "{stdout}"
    );
    let (header, rows) = read_csv(&dir.path().join("grid/study.csv"));
    assert_eq!(rows.len(), 4, "{rows:?}");
    let (safety, horizon) = (column(&header, "Safety Factor"), column(&header, "Horizon"));
    let grid: Vec<(&str, &str)> = rows
        .iter()
        .map(|r| (r[safety].as_str(), r[horizon].as_str()))
        .collect();
    // The deck's variation first (slowest), then the command line's.
    assert_eq!(
        grid,
        [
            ("0.5", "0.201"),
            ("0.5", "0.301"),
            ("0.8", "0.201"),
            ("0.8", "0.301")
        ]
    );
    let momentum = column(&header, "Momentum");
    let momentum_error = column(&header, "Momentum error");
    let steps = column(&header, "steps");
    for row in &rows {
        assert_eq!(row[column(&header, "status")], "ok", "{row:?}");
        let value: f64 = row[momentum].parse().unwrap();
        assert!((value - exact_mean_velocity()).abs() < 1e-12, "{row:?}");
        let error: f64 = row[momentum_error].parse().unwrap();
        assert!(error < 1e-12, "{row:?}");
        assert!(row[steps].parse::<u64>().unwrap() > 0, "{row:?}");
        assert!(row[column(&header, "peak_MiB")].parse::<f64>().unwrap() > 0.0);
    }
    // A smaller Safety Factor takes more steps for the same final time.
    let count = |k: usize| rows[k][steps].parse::<u64>().unwrap();
    assert!(count(0) > count(2) && count(1) > count(3), "{rows:?}");
    // The displacement's reference is the last run (all have 160 points): its error is 0, a
    // different horizon gives a different answer.
    let displacement = column(&header, "mean:DisplacementX@End Node Set error");
    assert_eq!(rows[3][displacement], "0");
    assert!(
        rows[2][displacement].parse::<f64>().unwrap() > 1e-3,
        "{rows:?}"
    );
    let plot = std::fs::read(
        dir.path()
            .join("grid/error_mean_DisplacementX_End_Node_Set.png"),
    )
    .unwrap();
    assert_eq!(&plot[1..4], b"PNG");
    for k in 0..4 {
        let folder = dir.path().join(format!("grid/variant_{k:03}"));
        assert!(folder.join("bar.e").exists() && folder.join("run.log").exists());
    }
}

#[test]
fn a_variant_that_blows_up_is_a_row_with_its_reason() {
    let dir = tempfile::tempdir().unwrap();
    write_deck(dir.path());
    // Replaces the deck's variation of the same key; 20 × the stable estimate blows up.
    let args = [
        "study",
        "bar.yaml",
        "--vary",
        "Solver.Verlet.Safety Factor=0.8,20",
        "--output-dir",
        "unstable",
    ];
    let output = peridyn(&args, dir.path());
    assert!(output.status.success(), "{}", text(&output.stderr));
    let (header, rows) = read_csv(&dir.path().join("unstable/study.csv"));
    assert_eq!(rows.len(), 2, "{rows:?}");
    let (status, reason) = (column(&header, "status"), column(&header, "reason"));
    assert_eq!(rows[0][status], "ok");
    assert_eq!(rows[1][status], "unstable");
    assert!(
        rows[1][reason].contains("the run became unstable"),
        "{rows:?}"
    );
    assert_eq!(rows[1][column(&header, "Momentum")], "");
}

#[test]
fn an_unknown_key_path_is_invalid_input_naming_it_and_the_line() {
    let dir = tempfile::tempdir().unwrap();
    write_deck(dir.path());
    let blocks_line = deck().lines().position(|l| l == "  Blocks:").unwrap() + 1;
    let args = ["study", "bar.yaml", "--vary", "Blocks.Rod.Horizon=0.2,0.3"];
    let output = peridyn(&args, dir.path());
    let stderr = text(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("Blocks.Rod.Horizon")
            && stderr.contains(&format!("bar.yaml:{blocks_line}:"))
            && stderr.contains("\"Bar\""),
        "{stderr}"
    );
    assert!(!dir.path().join("study_bar").exists(), "nothing ran");
}

#[test]
fn stable_dt_brackets_the_measured_stability_limit() {
    let dir = tempfile::tempdir().unwrap();
    write_deck(dir.path());
    let args = ["study", "bar.yaml", "--stable-dt", "--output-dir", "dt"];
    let output = peridyn(&args, dir.path());
    let stdout = text(&output.stdout);
    assert!(output.status.success(), "{}", text(&output.stderr));
    let (header, rows) = read_csv(&dir.path().join("dt/stable_dt.csv"));
    let (factor, dt, status, reason) = (
        column(&header, "Safety Factor"),
        column(&header, "dt_s"),
        column(&header, "status"),
        column(&header, "reason"),
    );
    let value = |row: &Vec<String>, k: usize| row[k].parse::<f64>().unwrap();
    let stable: Vec<&Vec<String>> = rows.iter().filter(|r| r[status] == "stable").collect();
    let unstable: Vec<&Vec<String>> = rows.iter().filter(|r| r[status] == "unstable").collect();
    assert!(!stable.is_empty() && !unstable.is_empty(), "{rows:?}");
    let low = stable.iter().map(|r| value(r, dt)).fold(0.0, f64::max);
    let high = unstable
        .iter()
        .map(|r| value(r, dt))
        .fold(f64::INFINITY, f64::min);
    let (low_factor, high_factor) = (
        stable.iter().map(|r| value(r, factor)).fold(0.0, f64::max),
        unstable
            .iter()
            .map(|r| value(r, factor))
            .fold(f64::INFINITY, f64::min),
    );
    // Bisection to the default tolerance of 2 %.
    assert!(
        low < high && (high_factor - low_factor) / low_factor <= 0.02,
        "{rows:?}"
    );
    // Velocity Verlet on ρü = −Ku is stable for Δt < 2/ω_max. The monitor's message of an
    // unstable trial quotes 2/ω_max measured by power iteration on the undeformed body
    // (src/solver/stability.rs: an upper bound within a few per cent), so the bracket found by
    // running must hold it, widened by those few per cent.
    let quoted = &unstable[0][reason];
    let measured: f64 = quoted
        .split("the largest stable step is ")
        .nth(1)
        .and_then(|rest| rest.split_whitespace().next())
        .and_then(|number| number.parse().ok())
        .unwrap_or_else(|| panic!("no measured step in {quoted}"));
    assert!(
        0.97 * low <= measured && measured <= 1.03 * high,
        "bracket {low:e}..{high:e} s, measured {measured:e} s"
    );
    assert!(
        stdout.contains("largest stable Safety Factor: between"),
        "{stdout}"
    );
    assert!(stdout.contains("Silling–Askari estimate"), "{stdout}");
}
