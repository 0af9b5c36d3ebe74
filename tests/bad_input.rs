//! Input a fuzzing pass of mutated decks found mishandled (hangs, aborts, a wrong exit code or
//! a message blaming the wrong key). Each is now an error with exit code 2 that names the file,
//! the key and its line, the same in `check` and in `run`.

use std::path::Path;
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

/// A valid deck: a 3×3×3 text mesh (unit spacing, listed in `MESH`), LPS, an initial velocity
/// on the x = 0 face, 12 Verlet steps.
const DECK: &str = r#"Peridigm:
  Discretization:
    Type: "Text File"
    Input Mesh File: "mesh.txt"
  Materials:
    Steel:
      Material Model: "Elastic"
      Density: 7800.0
      Bulk Modulus: 130.0e9
      Shear Modulus: 78.0e9
  Blocks:
    Everything:
      Block Names: "block_1"
      Material: "Steel"
      Horizon: 1.75
  Boundary Conditions:
    Left Node Set: "left.txt"
    Push:
      Type: "Initial Velocity"
      Node Set: "Left Node Set"
      Coordinate: "x"
      Value: "1.0"
  Solver:
    Initial Time: 0.0
    Final Time: 1.0e-3
    Verlet:
      Safety Factor: 0.8
  Output:
    Output Filename: "out"
    Output Frequency: 100
    Output Variables:
      Displacement: true
"#;

/// `x y z block volume` of a 3×3×3 unit lattice, x fastest.
fn mesh() -> String {
    let mut text = String::from("# x y z block volume\n");
    for k in 0..3 {
        for j in 0..3 {
            for i in 0..3 {
                text.push_str(&format!("{i}.0 {j}.0 {k}.0 1 1.0\n"));
            }
        }
    }
    text
}

/// The ids (1-based) of the x = 0 points of [`mesh`].
fn left_ids() -> String {
    (0..9).map(|n| format!("{}\n", 3 * n + 1)).collect()
}

/// A folder holding `deck.yaml` (DECK with `from` replaced by `to`), the mesh and the node set.
fn folder_with(from: &str, to: &str) -> tempfile::TempDir {
    assert!(DECK.contains(from), "test setup: {from:?} not in DECK");
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("deck.yaml"), DECK.replacen(from, to, 1)).unwrap();
    std::fs::write(dir.path().join("mesh.txt"), mesh()).unwrap();
    std::fs::write(dir.path().join("left.txt"), left_ids()).unwrap();
    dir
}

fn line_of(text: &str, needle: &str) -> usize {
    text.lines().position(|l| l.contains(needle)).unwrap() + 1
}

/// `check` and `run` of the folder's deck both exit with 2 and a message that starts with
/// `deck.yaml:LINE:` and holds every piece of `expected`.
fn assert_refused_alike(dir: &Path, line: usize, expected: &[&str]) {
    assert_refused_by(peridyn, dir, line, expected);
}

/// [`assert_refused_alike`] with peridyn started by `start`.
fn assert_refused_by(
    start: fn(&[&str], &Path) -> Output,
    dir: &Path,
    line: usize,
    expected: &[&str],
) {
    for args in [
        &["check", "deck.yaml"][..],
        &["run", "deck.yaml", "--output-dir", "out"][..],
    ] {
        let output = start(args, dir);
        let message = stderr(&output);
        assert_eq!(output.status.code(), Some(2), "{args:?}: {message}");
        assert!(
            message.contains(&format!("deck.yaml:{line}:")),
            "{args:?}: line {line} not named: {message}"
        );
        for part in expected {
            assert!(
                message.contains(part),
                "{args:?}: {part:?} missing: {message}"
            );
        }
    }
}

#[test]
fn the_valid_deck_runs() {
    let dir = folder_with("Safety Factor: 0.8", "Safety Factor: 0.8");
    let output = peridyn(&["run", "deck.yaml", "--output-dir", "out"], dir.path());
    assert!(output.status.success(), "{}", stderr(&output));
}

/// Finding 1: a repeated mesh line gave Δt = 0 and a run that wrote frames at t = 0 forever.
#[test]
fn coincident_points_are_named() {
    let dir = folder_with("Safety Factor: 0.8", "Safety Factor: 0.8");
    let mut text = mesh();
    text.push_str("1.0 1.0 0.0 1 1.0\n");
    std::fs::write(dir.path().join("mesh.txt"), text).unwrap();
    // (1, 1, 0) is point 1 + 1 + 3·1 = 5 of the lattice; the repeated line is point 28.
    assert_refused_alike(
        dir.path(),
        line_of(DECK, "Input Mesh File"),
        &["points 5 and 28", "(1, 1, 0)"],
    );
}

/// Finding 2: a step count beyond any run, and a Final Time that reads as infinity.
#[test]
fn absurd_or_infinite_final_times_are_refused() {
    let line = line_of(DECK, "Final Time");
    let dir = folder_with("Final Time: 1.0e-3", "Final Time: 1.0e308");
    assert_refused_alike(dir.path(), line, &["Final Time", "1e12 steps"]);
    let dir = folder_with("Final Time: 1.0e-3", "Final Time: 1e999");
    assert_refused_alike(
        dir.path(),
        line,
        &[
            "Final Time",
            "1e999 is not a finite double-precision number",
        ],
    );
}

/// Finding 3: 20,000 nested lists overflowed the stack (SIGABRT) in both formats.
#[test]
fn deep_nesting_is_bounded() {
    let depth = 20_000;
    let mut yaml = DECK.to_string();
    yaml.push_str("  Deep:\n");
    for level in 0..depth {
        yaml.push_str(&format!("{}k:\n", " ".repeat(4 + level)));
    }
    let dir = folder_with("Safety Factor: 0.8", "Safety Factor: 0.8");
    std::fs::write(dir.path().join("deck.yaml"), &yaml).unwrap();
    // The 33rd list opens on the 33rd `k:` line (the deck's own lists count too: Deep is 1).
    let output = peridyn(&["check", "deck.yaml"], dir.path());
    let message = stderr(&output);
    assert_eq!(output.status.code(), Some(2), "{message}");
    assert!(message.contains("nested more than 32 deep"), "{message}");

    let xml = format!(
        "<ParameterList>\n{}{}</ParameterList>\n",
        "<ParameterList name=\"k\">\n".repeat(depth),
        "</ParameterList>\n".repeat(depth)
    );
    std::fs::write(dir.path().join("deck.xml"), xml).unwrap();
    let output = peridyn(&["check", "deck.xml"], dir.path());
    let message = stderr(&output);
    assert_eq!(output.status.code(), Some(2), "{message}");
    // The root list counts as the first of the 32: the 32nd named list, on line 33, is one too
    // many.
    assert!(message.starts_with("error: deck.xml:33:"), "{message}");
    assert!(message.contains("nested more than 32 deep"), "{message}");
}

/// Finding 4: `Number Points X/Y/Z: 100000` aborted on an allocation even in `check`.
#[test]
fn a_grid_beyond_memory_is_refused_before_allocating() {
    let deck = r#"Peridigm:
  Discretization:
    Type: "PdQuickGrid"
    TensorProduct3DMeshGenerator:
      X Origin: 0.0
      Y Origin: 0.0
      Z Origin: 0.0
      X Length: 1.0
      Y Length: 1.0
      Z Length: 1.0
      Number Points X: 100000
      Number Points Y: 100000
      Number Points Z: 100000
  Materials:
    Steel:
      Material Model: "Elastic Bond Based"
      Density: 7800.0
      Bulk Modulus: 130.0e9
  Blocks:
    All:
      Block Names: "block_1"
      Material: "Steel"
      Horizon: 3.0e-5
  Solver:
    Final Time: 1.0e-5
    Verlet:
      Fixed dt: 1.0e-7
"#;
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("deck.yaml"), deck).unwrap();
    let output = peridyn(&["check", "deck.yaml"], dir.path());
    let message = stderr(&output);
    if std::fs::metadata("/proc/meminfo").is_err() {
        // Where the memory size cannot be read, nothing is refused by this rule.
        return;
    }
    assert_eq!(output.status.code(), Some(2), "{message}");
    assert!(
        message.contains("deck.yaml:11:") && message.contains("Number Points X"),
        "{message}"
    );
    // 10¹⁵ points, and δ/Δx = 3 gives ⌈4/3·π·27⌉ = 114 bonds a point.
    assert!(
        message.contains("1000000000000000 points with about 114 bonds"),
        "{message}"
    );
}

/// Finding 5: an empty node-set file made a condition act on nothing, silently.
#[test]
fn an_empty_node_set_used_by_a_condition_is_an_error() {
    let dir = folder_with("Safety Factor: 0.8", "Safety Factor: 0.8");
    std::fs::write(dir.path().join("left.txt"), "").unwrap();
    assert_refused_alike(
        dir.path(),
        line_of(DECK, "      Node Set: \"Left Node Set\""),
        &["Boundary Conditions → Push → Node Set", "has no points"],
    );
}

/// Finding 6: `check` passed a compute class naming an unknown node set, and `run` failed
/// with exit code 1 and no file or line; a misspelt output variable failed `run` with 1.
#[test]
fn check_and_run_validate_alike() {
    let with_class = DECK.replace(
        "      Displacement: true\n",
        "      Displacement: true\n      Left_Sum: true\n  Compute Class Parameters:\n    Left Sum:\n      Compute Class: \"Node_Set_Data\"\n      Calculation Type: \"Sum\"\n      Node Set: \"Nope Node Set\"\n      Variable: \"Displacement\"\n      Output Label: \"Left_Sum\"\n",
    );
    let dir = folder_with("Safety Factor: 0.8", "Safety Factor: 0.8");
    std::fs::write(dir.path().join("deck.yaml"), &with_class).unwrap();
    assert_refused_alike(
        dir.path(),
        line_of(&with_class, "    Left Sum:"),
        &["no node set \"Nope Node Set\""],
    );

    let dir = folder_with(
        "      Displacement: true\n",
        "      Displacement: true\n      Displacment: true\n",
    );
    assert_refused_alike(
        dir.path(),
        line_of(DECK, "      Displacement: true") + 1,
        &["did you mean \"Displacement\""],
    );
}

/// Finding 7: NaN from a condition's expression was blamed on the time step.
#[test]
fn a_non_finite_condition_value_names_the_condition() {
    let line = line_of(DECK, "Value: \"1.0\"");
    let dir = folder_with("Value: \"1.0\"", "Value: \"sqrt(-1)\"");
    assert_refused_alike(
        dir.path(),
        line,
        &["Push → Value", "\"sqrt(-1)\" evaluates to NaN"],
    );

    // Depending on x, it can only be found when evaluated: at the first point, x = 0, where
    // 1e308·10·0 = ∞·0 = NaN.
    let dir = folder_with("Value: \"1.0\"", "Value: \"1e308*10*x\"");
    let output = peridyn(&["run", "deck.yaml", "--output-dir", "out"], dir.path());
    let message = stderr(&output);
    assert_eq!(output.status.code(), Some(2), "{message}");
    assert!(
        message.contains("boundary condition \"Push\"")
            && message.contains("\"1e308*10*x\" is NaN at the point (0, 0, 0)")
            && !message.contains("Safety Factor"),
        "{message}"
    );
}

/// Finding 8: a horizon below the spacing passed `check`, then `run` failed with exit code 1.
#[test]
fn a_horizon_without_neighbours_is_refused_by_check() {
    let line = line_of(DECK, "Horizon: 1.75");
    let dir = folder_with("Horizon: 1.75", "Horizon: 0.5");
    assert_refused_alike(
        dir.path(),
        line,
        &["Blocks → Everything → Horizon", "no point has a neighbour"],
    );
}

/// Finding 10: without `Search Radius`, the valid `Search Frequency` was called a typo of it.
#[test]
fn a_missing_search_radius_is_reported_as_missing() {
    let dir = folder_with(
        "      Safety Factor: 0.8\n",
        "      Safety Factor: 0.8\n  Contact:\n    Search Frequency: 10\n",
    );
    let output = peridyn(&["check", "deck.yaml"], dir.path());
    let message = stderr(&output);
    assert_eq!(output.status.code(), Some(2), "{message}");
    assert!(
        message.contains("Contact → Search Radius: required key is missing"),
        "{message}"
    );
}

/// Finding 11: a byte-order mark, a repeated I/O cause, and `--threads` without a bound.
#[test]
fn byte_order_mark_io_causes_and_thread_count() {
    let dir = folder_with("Safety Factor: 0.8", "Safety Factor: 0.8");
    std::fs::write(dir.path().join("deck.yaml"), format!("\u{feff}{DECK}")).unwrap();
    let output = peridyn(&["check", "deck.yaml"], dir.path());
    assert!(output.status.success(), "{}", stderr(&output));

    // The results file cannot be created (a folder has its name): the cause, printed three
    // times before, is printed once.
    std::fs::create_dir_all(dir.path().join("taken/out.e")).unwrap();
    let output = peridyn(&["run", "deck.yaml", "--output-dir", "taken"], dir.path());
    let message = stderr(&output);
    assert_ne!(output.status.code(), Some(0), "{message}");
    assert_eq!(message.matches("os error").count(), 1, "{message}");

    let output = peridyn(
        &[
            "run",
            "deck.yaml",
            "--output-dir",
            "out",
            "--threads",
            "1000",
        ],
        dir.path(),
    );
    let message = stderr(&output);
    assert_eq!(output.status.code(), Some(2), "{message}");
    assert!(message.contains("--threads 1000: give 1 to"), "{message}");
}

/// Finding 9: for ν = −0.5 and for a two-point LPS body Peridigm's stable-step estimate is not
/// a bound, and the advice "Safety Factor 0.5" failed too. The message now gives the limit
/// measured on the body, and the Safety Factor it suggests runs.
#[test]
fn an_instability_suggests_a_safety_factor_that_runs() {
    let auxetic = DECK
        .replacen(
            "Bulk Modulus: 130.0e9\n      Shear Modulus: 78.0e9",
            "Young's Modulus: 200.0e9\n      Poisson's Ratio: -0.5",
            1,
        )
        .replacen("Final Time: 1.0e-3", "Final Time: 1.0e-2", 1);
    let two_points = DECK.replacen("Final Time: 1.0e-3", "Final Time: 1.0e-2", 1);
    for (deck, mesh_text) in [
        (auxetic, mesh()),
        (
            two_points,
            "# x y z block volume\n0.0 0.0 0.0 1 1.0\n1.0 0.0 0.0 1 1.0\n".to_string(),
        ),
    ] {
        let dir = folder_with("Safety Factor: 0.8", "Safety Factor: 0.8");
        std::fs::write(dir.path().join("deck.yaml"), &deck).unwrap();
        std::fs::write(dir.path().join("mesh.txt"), mesh_text).unwrap();
        // Point 1 is on the x = 0 face of both bodies.
        std::fs::write(dir.path().join("left.txt"), "1\n").unwrap();
        let output = peridyn(&["run", "deck.yaml", "--output-dir", "out"], dir.path());
        let message = stderr(&output);
        assert_eq!(output.status.code(), Some(3), "{message}");
        assert!(message.contains("not a bound for this body"), "{message}");
        let suggested: f64 = message
            .split("give \"Safety Factor\" ")
            .nth(1)
            .and_then(|rest| rest.split(' ').next())
            .and_then(|number| number.parse().ok())
            .unwrap_or_else(|| panic!("no suggested Safety Factor: {message}"));
        assert!(suggested < 0.8, "{message}");
        let retried = deck.replacen(
            "Safety Factor: 0.8",
            &format!("Safety Factor: {suggested}"),
            1,
        );
        std::fs::write(dir.path().join("deck.yaml"), retried).unwrap();
        let output = peridyn(&["run", "deck.yaml", "--output-dir", "out"], dir.path());
        assert!(output.status.success(), "{}", stderr(&output));
    }
}

// Issue 44: a second fuzzing campaign (decks, meshes and node-set files mutated as a careless
// user would) found eight answers that were wrong or blamed the wrong key.

/// This machine's memory (MemTotal), or None where it cannot be read (then nothing is refused
/// for its size).
fn physical_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// `check` and `run` of `deck.yaml` in `dir` with at most 4 GiB of address space, so that a
/// size guard that failed to refuse would end on a failed allocation instead of taking the
/// machine's memory.
fn peridyn_within_4_gib(args: &[&str], dir: &Path) -> Output {
    let mut command = Command::new(env!("CARGO_BIN_EXE_peridyn"));
    command.args(args).current_dir(dir);
    #[cfg(unix)]
    {
        use std::os::unix::process::CommandExt;
        // SAFETY: between fork and exec only setrlimit, which is async-signal-safe, is called.
        unsafe {
            command.pre_exec(|| {
                let limit = libc::rlimit {
                    rlim_cur: 4 << 30,
                    rlim_max: 4 << 30,
                };
                if libc::setrlimit(libc::RLIMIT_AS, &limit) != 0 {
                    return Err(std::io::Error::last_os_error());
                }
                Ok(())
            });
        }
    }
    command.output().expect("peridyn runs")
}

/// [`assert_refused_alike`] within 4 GiB of address space.
fn assert_refused_within_4_gib(dir: &Path, line: usize, expected: &[&str]) {
    assert_refused_by(peridyn_within_4_gib, dir, line, expected);
}

/// Issue 44, finding 1: a mesh deck had no size guard; a horizon of 10⁶ spacings built every
/// bond of every pair of points. Now the families of sampled points are counted first.
#[test]
fn a_mesh_whose_bonds_cannot_fit_is_refused_at_its_horizon() {
    let Some(memory) = physical_memory() else {
        return;
    };
    // N points with N − 1 bonds each need at least N·(120 + 12·(N − 1)) bytes (the guard's
    // floor, src/setup/size_guard.rs): N is chosen to need twice this machine's memory.
    let n = ((2.0 * memory as f64 / 12.0).sqrt()).ceil() as usize + 1;
    let dir = folder_with("Horizon: 1.75", "Horizon: 1.0e6");
    let mut text = String::with_capacity(24 * n);
    // A 100 × 100 × ⌈n/10⁴⌉ unit lattice, x fastest, cut at n points.
    for p in 0..n {
        let (i, j, k) = (p % 100, (p / 100) % 100, p / 10_000);
        text.push_str(&format!("{i} {j} {k} 1 1.0\n"));
    }
    std::fs::write(dir.path().join("mesh.txt"), text).unwrap();
    // A horizon of 10⁶ reaches every point of the lattice (its diagonal is below 200), so every
    // point's family is the other n − 1 points.
    assert_refused_within_4_gib(
        dir.path(),
        line_of(DECK, "Horizon: 1.75"),
        &[
            "Blocks → Everything → Horizon",
            &format!("{n} points with about {} bonds each", n - 1),
            "about 3 spacings",
        ],
    );
}

/// The QuickGrid box of [`grid_deck`]: a unit cube of 5 × 5 × 5 points 0.2 apart.
const QUICKGRID: &str = r#"    Type: "PdQuickGrid"
    TensorProduct3DMeshGenerator:
      X Origin: 0.0
      Y Origin: 0.0
      Z Origin: 0.0
      X Length: 1.0
      Y Length: 1.0
      Z Length: 1.0
      Number Points X: 5
      Number Points Y: 5
      Number Points Z: 5
"#;

/// DECK on the [`QUICKGRID`] cube: a horizon of 3.05 spacings, the initial velocity on the
/// points 1, 6, 11, 16, 21 (x = 0.1, z = 0.1).
fn grid_deck() -> String {
    let text_file = "    Type: \"Text File\"\n    Input Mesh File: \"mesh.txt\"\n";
    assert!(
        DECK.contains(text_file),
        "test setup: DECK reads a text file"
    );
    DECK.replacen(text_file, QUICKGRID, 1)
        .replacen("Horizon: 1.75", "Horizon: 0.61", 1)
        .replacen("\"left.txt\"", "\"1 6 11 16 21\"", 1)
}

/// A folder holding `deck.yaml`: [`grid_deck`] with each `(from, to)` replacement made once.
fn grid_folder(replacements: &[(&str, &str)]) -> tempfile::TempDir {
    let mut deck = grid_deck();
    for (from, to) in replacements {
        assert!(
            deck.contains(from),
            "test setup: {from:?} not in grid_deck()"
        );
        deck = deck.replacen(from, to, 1);
    }
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("deck.yaml"), deck).unwrap();
    dir
}

#[test]
fn the_valid_grid_deck_runs() {
    let dir = grid_folder(&[]);
    let output = peridyn(&["run", "deck.yaml", "--output-dir", "out"], dir.path());
    assert!(output.status.success(), "{}", stderr(&output));
}

/// Issue 44, finding 2: the size guard counted 4,188,790,205 bonds a point for a 125-point
/// cube with a huge horizon, and blamed `Number Points X`. A point has at most N − 1 bonds,
/// and when the horizon is what makes a body too big, the horizon is named.
#[test]
fn the_size_guard_counts_at_most_n_minus_1_bonds_and_names_the_horizon() {
    let dir = grid_folder(&[("Horizon: 0.61", "Horizon: 1.0e12")]);
    let output = peridyn_within_4_gib(&["check", "deck.yaml"], dir.path());
    let plan = String::from_utf8_lossy(&output.stdout);
    assert!(output.status.success(), "{}", stderr(&output));
    // 125 points, each bonded to the 124 others.
    assert!(
        plan.contains("family min/max/mean 124/124/124.00"),
        "{plan}"
    );

    if physical_memory().is_none() {
        return;
    }
    // 100³ points 0.01 apart and a horizon of 100 spacings: Peridigm's box neighbourhood
    // reaches every point (±100 cells), so 10⁶ − 1 bonds a point, 12 TB at 12 bytes a bond;
    // with a horizon of 3 spacings the same points would need 1.5 GB.
    let dir = grid_folder(&[
        ("Number Points X: 5", "Number Points X: 100"),
        ("Number Points Y: 5", "Number Points Y: 100"),
        ("Number Points Z: 5", "Number Points Z: 100"),
        ("Horizon: 0.61", "Horizon: 1.0"),
    ]);
    assert_refused_within_4_gib(
        dir.path(),
        line_of(&grid_deck(), "Horizon: 0.61"),
        &[
            "Blocks → Everything → Horizon",
            "1000000 points with about 999999 bonds each",
            "about 3 spacings",
        ],
    );
}

/// The size guard compares with the memory the run may use, not the machine's alone: under a
/// 4 GiB address-space limit (`ulimit -v`, as a batch job's limit) a body the machine could
/// hold is refused before it is built, instead of dying on a failed allocation midway.
#[test]
fn the_size_guard_honours_the_address_space_limit() {
    if physical_memory().is_none_or(|bytes| bytes <= 4 << 30) {
        return;
    }
    // 160³ = 4,096,000 points 1/160 apart, a horizon of 3.05 spacings: at the guard's floor
    // of 120 bytes a point and 12 a bond (src/setup/size_guard.rs), even the 119 bonds of a
    // ball of 3.05 spacings need 6.3 GB, more than 4 GiB: the message names the limit's
    // 4 GiB, not the machine's larger memory.
    let dir = grid_folder(&[
        ("Number Points X: 5", "Number Points X: 160"),
        ("Number Points Y: 5", "Number Points Y: 160"),
        ("Number Points Z: 5", "Number Points Z: 160"),
        ("Horizon: 0.61", "Horizon: 0.0190625"),
    ]);
    assert_refused_within_4_gib(
        dir.path(),
        line_of(&grid_deck(), "Number Points X: 5"),
        &["4096000 points", "more than the 4.0 GiB this run may use"],
    );
}

/// Issue 44, finding 3: a condition on a vector field without `Coordinate` was taken as x.
#[test]
fn a_vector_condition_without_coordinate_is_refused() {
    for kind in [
        "Initial Velocity",
        "Initial Displacement",
        "Prescribed Displacement",
        "Body Force",
    ] {
        let deck = DECK
            .replacen(
                "Type: \"Initial Velocity\"",
                &format!("Type: \"{kind}\""),
                1,
            )
            .replacen("      Coordinate: \"x\"\n", "", 1);
        let dir = folder_with("Safety Factor: 0.8", "Safety Factor: 0.8");
        std::fs::write(dir.path().join("deck.yaml"), &deck).unwrap();
        // A missing key is reported at the line of its list.
        assert_refused_alike(
            dir.path(),
            line_of(&deck, "    Push:"),
            &[
                "Boundary Conditions → Push → Coordinate",
                "required key is missing",
                &format!("the component this \"{kind}\" sets"),
            ],
        );
    }
}

/// Issue 44, finding 4: with `Y Origin: -1e308` every y rounded to the same value; the zero
/// time step that followed was blamed on `Final Time`.
#[test]
fn points_that_coincide_by_rounding_name_the_origin() {
    let dir = grid_folder(&[("Y Origin: 0.0", "Y Origin: -1e308")]);
    assert_refused_alike(
        dir.path(),
        line_of(&grid_deck(), "Y Origin"),
        &[
            "TensorProduct3DMeshGenerator → Y Origin",
            "the points coincide",
            "move this key nearer 0",
        ],
    );
}

/// Issue 44, finding 5: `Y Length: 1e308` gave volumes whose mass is infinite, found only as a
/// non-finite residual or kinetic energy during the run.
#[test]
fn geometry_beyond_a_double_names_the_key() {
    let dir = grid_folder(&[("Y Length: 1.0", "Y Length: 1e308")]);
    assert_refused_alike(
        dir.path(),
        line_of(&grid_deck(), "Y Length"),
        &[
            "TensorProduct3DMeshGenerator → Y Length",
            "beyond the lengths peridyn computes with",
        ],
    );
    // A horizon of 10¹⁵⁴ (found by scripts/fuzz-decks) overflowed the size guard's count of
    // cells within it in a debug build before the horizon was checked.
    let dir = grid_folder(&[("Horizon: 0.61", "Horizon: 1e154")]);
    assert_refused_alike(
        dir.path(),
        line_of(&grid_deck(), "Horizon: 0.61"),
        &[
            "Blocks → Everything → Horizon",
            "outside the lengths peridyn computes with",
        ],
    );
    // The same in a mesh: point 2's volume.
    let dir = folder_with("Safety Factor: 0.8", "Safety Factor: 0.8");
    let text = mesh().replacen("1.0 0.0 0.0 1 1.0", "1.0 0.0 0.0 1 1.0e300", 1);
    std::fs::write(dir.path().join("mesh.txt"), text).unwrap();
    assert_refused_alike(
        dir.path(),
        line_of(DECK, "Input Mesh File"),
        &["point 2 has the volume 1e300", "outside the volumes"],
    );
}

/// Issue 44, finding 6: `Fixed dt: 1e-320` was reported at `Final Time`.
#[test]
fn a_time_step_too_small_to_run_names_fixed_dt() {
    let dir = folder_with("Safety Factor: 0.8", "Fixed dt: 1e-320");
    assert_refused_alike(
        dir.path(),
        line_of(DECK, "Safety Factor: 0.8"),
        &["Solver → Verlet → Fixed dt", "the time step is at fault"],
    );
    // A normal but tiny time step: the stable estimate would run the span, so the time step is
    // at fault too.
    let dir = folder_with("Safety Factor: 0.8", "Fixed dt: 1e-300");
    assert_refused_alike(
        dir.path(),
        line_of(DECK, "Safety Factor: 0.8"),
        &["Solver → Verlet → Fixed dt", "Peridigm's stable estimate"],
    );
}

/// Issue 44, finding 7: an id out of range in a node-set file, or an empty file, was reported
/// at the deck line naming the set, without the file and its line.
#[test]
fn a_bad_node_set_file_is_named_with_its_line() {
    let dir = folder_with("Safety Factor: 0.8", "Safety Factor: 0.8");
    std::fs::write(dir.path().join("left.txt"), "# ids\n1 4\n99\n").unwrap();
    assert_refused_alike(
        dir.path(),
        line_of(DECK, "Left Node Set: \"left.txt\""),
        &[
            "Boundary Conditions → Left Node Set",
            "left.txt:3: node id 99 is out of range",
            "numbered 1 to 27",
        ],
    );
    std::fs::write(dir.path().join("left.txt"), "# no ids\n").unwrap();
    assert_refused_alike(
        dir.path(),
        line_of(DECK, "      Node Set: \"Left Node Set\""),
        &["has no points (its file", "left.txt lists no node ids)"],
    );
}

/// Issue 44, finding 8: a horizon of 10⁻¹² spacings ran to the end with no bond and no word.
#[test]
fn a_body_without_bonds_is_warned_of_or_refused() {
    // With a Fixed dt (no stable estimate is needed) the run goes on, with a warning in both.
    let dir = folder_with("Horizon: 1.75", "Horizon: 1.75e-12");
    let deck = DECK
        .replacen("Horizon: 1.75", "Horizon: 1.75e-12", 1)
        .replacen("Safety Factor: 0.8", "Fixed dt: 1.0e-5", 1);
    std::fs::write(dir.path().join("deck.yaml"), &deck).unwrap();
    let warning = format!(
        "warning: deck.yaml:{}: Blocks → Everything → Horizon: no point of block \"block_1\" has a neighbour within its horizon 1.75e-12",
        line_of(DECK, "Horizon: 1.75")
    );
    let output = peridyn(&["check", "deck.yaml"], dir.path());
    assert!(output.status.success(), "{}", stderr(&output));
    let plan = String::from_utf8_lossy(&output.stdout);
    assert!(plan.contains(&warning), "{plan}");
    let output = peridyn(&["run", "deck.yaml", "--output-dir", "out"], dir.path());
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(stderr(&output).contains(&warning), "{}", stderr(&output));

    // Nothing moves a point (the condition is gone): an error.
    let still = deck.replacen(
        "Type: \"Initial Velocity\"",
        "Type: \"Initial Temperature\"",
        1,
    );
    std::fs::write(dir.path().join("deck.yaml"), &still).unwrap();
    assert_refused_alike(
        dir.path(),
        line_of(DECK, "Horizon: 1.75"),
        &["nothing could move in this run", "about 3 spacings (3e0)"],
    );

    // A quasi-static solver finds no equilibrium for points without stiffness: an error.
    let quasi_static = deck.replacen(
        "    Verlet:\n      Fixed dt: 1.0e-5\n",
        "    QuasiStatic:\n      Number of Load Steps: 2\n      Absolute Tolerance: 1.0e-6\n      Maximum Solver Iterations: 10\n",
        1,
    );
    assert_ne!(
        quasi_static, deck,
        "test setup: the Verlet list is replaced"
    );
    std::fs::write(dir.path().join("deck.yaml"), &quasi_static).unwrap();
    assert_refused_alike(
        dir.path(),
        line_of(DECK, "Horizon: 1.75"),
        &["the quasi-static solver \"Solver\" finds no equilibrium"],
    );
}

/// The fuzz campaign's trial 589 (CI, seed 1): a block whose horizon reached the points of a
/// block with a smaller horizon made the implicit tangent panic, and explicit runs gain
/// momentum from such one-way bonds. Refused at the far-reaching `Horizon`, on one rank here
/// and on two in tests/mpi_explicit.rs.
#[test]
fn a_horizon_that_reaches_points_that_do_not_reach_back_is_refused() {
    let dir = folder_with("Horizon: 1.75", "Horizon: 1.75");
    // The x = 2 layer becomes block 2, under its own entry with a horizon of 1.2: it bonds
    // along the axes only (spacing 1), while block 1 (1.75) also bonds across diagonals of
    // √2 and √3 into it.
    let mesh: String = mesh()
        .lines()
        .map(|line| match line.strip_prefix("2.0 ") {
            Some(rest) => format!("2.0 {}\n", rest.replace(" 1 1.0", " 2 1.0")),
            None => format!("{line}\n"),
        })
        .collect();
    std::fs::write(dir.path().join("mesh.txt"), &mesh).unwrap();
    let two_blocks = |right_horizon: &str, omit: bool| {
        let deck = DECK.replacen(
            "      Horizon: 1.75\n",
            &format!("      Horizon: 1.75\n    Right:\n      Block Names: \"block_2\"\n      Material: \"Steel\"\n      Horizon: {right_horizon}\n"),
            1,
        );
        if omit {
            deck.replacen(
                "    Input Mesh File: \"mesh.txt\"\n",
                "    Input Mesh File: \"mesh.txt\"\n    Omit Bonds Between Blocks: \"All\"\n",
                1,
            )
        } else {
            deck
        }
    };
    let deck = two_blocks("1.2", false);
    std::fs::write(dir.path().join("deck.yaml"), &deck).unwrap();
    assert_refused_alike(
        dir.path(),
        line_of(&deck, "Horizon: 1.75"),
        &[
            "Blocks → Everything → Horizon",
            "which does not bond back",
            "the same horizon, or set `Discretization → Omit Bonds Between Blocks: \"All\"`",
        ],
    );
    // Horizons that differ but find the same neighbours (no distance of the lattice lies
    // between 1.75 and 1.8), and blocks that do not bond to each other, run.
    for deck in [two_blocks("1.8", false), two_blocks("1.2", true)] {
        std::fs::write(dir.path().join("deck.yaml"), &deck).unwrap();
        let output = peridyn(&["run", "deck.yaml", "--output-dir", "out"], dir.path());
        assert!(output.status.success(), "{}", stderr(&output));
    }
}
