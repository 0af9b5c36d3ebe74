//! Restart files (feature `hdf5`): a run continued from one writes exactly the files an
//! uninterrupted run writes, byte for byte; a changed body is refused; SIGINT leaves a restart
//! file the next run continues from; a second deck starts from the state the first one ended
//! with (Peridigm's restart).
#![cfg(all(unix, feature = "hdf5"))]

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::Duration;

use peridyn::io::exodus::ExodusFile;

/// Exit code of a clean stop on a signal (README, "Exit codes").
const STOPPED: i32 = 4;

fn peridyn(dir: &Path, deck: &str) -> Output {
    Command::new(env!("CARGO_BIN_EXE_peridyn"))
        .args(["run", deck, "--output-dir", "out"])
        .current_dir(dir)
        .output()
        .expect("peridyn starts")
}

fn run_ok(dir: &Path, deck: &str) -> String {
    let out = peridyn(dir, deck);
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(out.status.success(), "{deck} failed:\n{stderr}");
    stderr
}

/// The restart directories of `dir/out`, oldest first.
fn restart_dirs(dir: &Path) -> Vec<PathBuf> {
    peridyn::restart::directories(&dir.join("out"))
        .into_iter()
        .map(|(_, p)| p)
        .collect()
}

/// Values of nodal variable `name` at frame `step`.
fn nodal(file: &ExodusFile, name: &str, step: usize) -> Vec<f64> {
    let index = file.nodal_variable_index(name).unwrap();
    file.nodal_values(step, index).unwrap()
}

/// Copies every file `dir/out/<name>` of the straight run for later comparison.
fn keep(dir: &Path, names: &[&str]) -> Vec<Vec<u8>> {
    names
        .iter()
        .map(|n| std::fs::read(dir.join("out").join(n)).unwrap())
        .collect()
}

/// Runs `deck.yaml` in `dir` straight through, then again from its newest restart file
/// written inside the run (the one written at the end is removed, as if the run had been
/// killed after the step of the one kept), and asserts that the files `names` come out byte
/// for byte the same. Returns how many frames the first file has.
fn continued_equals_straight(dir: &Path, names: &[&str]) -> usize {
    run_ok(dir, "deck.yaml");
    let straight = keep(dir, names);
    let dirs = restart_dirs(dir);
    assert!(
        dirs.len() >= 2,
        "expected a restart inside the run and one at its end: {dirs:?}"
    );
    std::fs::remove_dir_all(dirs.last().unwrap()).unwrap();
    let stderr = run_ok(dir, "deck.yaml");
    assert!(stderr.contains("restart: continuing from"), "{stderr}");
    for (name, before) in names.iter().zip(&straight) {
        let after = std::fs::read(dir.join("out").join(name)).unwrap();
        assert!(
            &after == before,
            "{name} differs after the continuation ({} against {} bytes)",
            after.len(),
            before.len()
        );
    }
    ExodusFile::open(&dir.join("out").join(names[0]))
        .unwrap()
        .times
        .len()
}

/// A text mesh: a 6×6×2 target plate (block 2, critical-stretch damage) and a 2×2×2
/// projectile (block 1) flying at it along x, with short-range contact between the blocks.
fn impact_deck(dir: &Path, final_time: f64, restart: &str) {
    let mut mesh = String::new();
    let h = 1.0e-3;
    let volume = h * h * h;
    for k in 0..2 {
        for j in 0..6 {
            for i in 0..2 {
                let (x, y, z) = (i as f64 * h, j as f64 * h, k as f64 * h);
                mesh += &format!("{x:e} {y:e} {z:e} 2 {volume:e}\n");
            }
        }
    }
    for k in 0..2 {
        for j in 0..2 {
            for i in 0..2 {
                let (x, y, z) = (
                    -3.0 * h + i as f64 * h,
                    2.0 * h + j as f64 * h,
                    k as f64 * h,
                );
                mesh += &format!("{x:e} {y:e} {z:e} 1 {volume:e}\n");
            }
        }
    }
    std::fs::write(dir.join("mesh.txt"), mesh).unwrap();
    let projectile: Vec<String> = (25..=32).map(|id| id.to_string()).collect();
    std::fs::write(dir.join("projectile.txt"), projectile.join("\n") + "\n").unwrap();
    let deck = format!(
        r#"Peridigm:
  Discretization:
    Type: "Text File"
    Input Mesh File: "mesh.txt"
  Materials:
    Target:
      Material Model: "Elastic"
      Density: 2200.0
      Bulk Modulus: 14.9e9
      Shear Modulus: 8.94e9
    Projectile:
      Material Model: "Elastic"
      Density: 7700.0
      Bulk Modulus: 160.0e9
      Shear Modulus: 79.3e9
  Damage Models:
    Stretch:
      Damage Model: "Critical Stretch"
      Critical Stretch: 0.002
  Blocks:
    Projectile:
      Block Names: "block_1"
      Material: "Projectile"
      Horizon: 1.51e-3
    Target:
      Block Names: "block_2"
      Material: "Target"
      Damage Model: "Stretch"
      Horizon: 1.51e-3
  Contact:
    Search Radius: 1.2e-3
    Search Frequency: 7
    Models:
      Repulsion:
        Contact Model: "Short Range Force"
        Contact Radius: 0.6e-3
        Spring Constant: 2.0e12
    Interactions:
      Projectile on Target:
        First Block: "block_1"
        Second Block: "block_2"
        Contact Model: "Repulsion"
  Boundary Conditions:
    Projectile Node Set: "projectile.txt"
    Launch:
      Type: "Initial Velocity"
      Node Set: "Projectile Node Set"
      Coordinate: "x"
      Value: "200.0"
{restart}  Solver:
    Initial Time: 0.0
    Final Time: {final_time:e}
    Verlet:
      Fixed dt: 2.0e-8
  Output:
    Output Filename: "impact"
    Output Frequency: 25
    Output Variables:
      Displacement: true
      Velocity: true
      Damage: true
      Global_Kinetic_Energy: true
"#
    );
    std::fs::write(dir.join("deck.yaml"), deck).unwrap();
}

/// Explicit dynamics with damage and contact: continued from a restart written every 300
/// steps, the Exodus file and the CSV of globals are those of the straight run, byte for byte;
/// and the run really breaks bonds and makes contact (else the test would prove little).
#[test]
fn explicit_impact_with_damage_and_contact_continues_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    // 1000 steps of 2e-8 s: the projectile (200 m/s) crosses its 2 mm gap in 1e-5 s = 500 steps.
    impact_deck(dir.path(), 2.0e-5, "  Restart:\n    Frequency: 300\n");
    let frames = continued_equals_straight(dir.path(), &["impact.e", "impact.csv"]);
    assert_eq!(frames, 1000 / 25 + 1);
    let file = ExodusFile::open(&dir.path().join("out/impact.e")).unwrap();
    let last = file.times.len() - 1;
    let damage_index = file.element_variable_index("Damage").unwrap();
    let damage: Vec<f64> = (0..file.blocks.len())
        .filter_map(|b| file.element_values(last, damage_index, b).unwrap())
        .flatten()
        .collect();
    assert!(
        damage.iter().any(|&d| d > 0.0),
        "no bond broke: the impact is too weak to test damage"
    );
    let velocity = nodal(&file, "VelocityX", last);
    assert!(
        velocity[24..].iter().all(|&v| v < 200.0),
        "the projectile was not slowed by contact: {:?}",
        &velocity[24..]
    );
}

/// Quasi-static load steps with adaptive cut-back: a step Newton cannot finish is halved, and
/// the continuation goes on with the cut schedule, writing the straight run's file.
#[test]
fn quasi_static_with_cut_back_continues_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let text = quasi_static_bar::bar_deck(
        "    Final Time: 1.0
    QuasiStatic:
      Number of Load Steps: {steps}
      Absolute Tolerance: 1.0
      Maximum Solver Iterations: 4
      Adaptive Load-Stepping:
        Maximum load step reductions in one step: 6",
        3.6,
        2.0,
        2,
    )
    .replace("  Solver:\n", "  Restart:\n    Frequency: 2\n  Solver:\n");
    std::fs::write(dir.path().join("deck.yaml"), text).unwrap();
    let frames = continued_equals_straight(dir.path(), &["bar.e"]);
    // Two load steps of which at least one was cut: more frames than 1 + 2.
    assert!(frames > 3, "no step was cut ({frames} frames)");
}

/// A `DynamicRelaxation` list with a restart file every 3 of its 8 load steps, on the bar
/// pulled 30 % with shear (the steps are long relaxations): continued from the file written
/// after step 6, it relaxes steps 7 and 8 again and writes the straight run's file.
#[test]
fn dynamic_relaxation_continues_bit_for_bit_from_a_restart_inside_its_list() {
    let dir = tempfile::tempdir().unwrap();
    let text = quasi_static_bar::bar_deck(
        "    Final Time: 1.0
    DynamicRelaxation:
      Number of Load Steps: {steps}
      Absolute Tolerance: 1.0",
        3.6,
        2.0,
        8,
    )
    .replace("  Solver:\n", "  Restart:\n    Frequency: 3\n  Solver:\n");
    std::fs::write(dir.path().join("deck.yaml"), text).unwrap();
    let frames = continued_equals_straight(dir.path(), &["bar.e"]);
    assert_eq!(frames, 9, "the initial frame and one per load step");
}

/// An `Implicit` (Newmark-β) list with a restart file every 7 of its 20 steps: continued from
/// the one written inside the list (after step 14), it goes on with step 15 and writes the
/// straight run's file. The right face is pulled at 0.5 m/s, so a wave runs along the bar (at
/// √(K/ρ) ≈ 4 km/s it crosses the 12 m bar in 3 ms, longer than the 2 ms run) and every step
/// differs from the last.
#[test]
fn newmark_continues_bit_for_bit_from_a_restart_inside_its_list() {
    let dir = tempfile::tempdir().unwrap();
    let text = quasi_static_bar::bar_deck(
        "    Final Time: 2.0e-3
    Implicit:
      Fixed dt: 1.0e-4
      Absolute Tolerance: 1.0e-8
      Maximum Solver Iterations: 20",
        0.5,
        0.0,
        0,
    )
    .replace("  Solver:\n", "  Restart:\n    Frequency: 7\n  Solver:\n");
    std::fs::write(dir.path().join("deck.yaml"), text).unwrap();
    let frames = continued_equals_straight(dir.path(), &["bar.e"]);
    // The initial frame and one per step.
    assert_eq!(frames, 21);
    let file = ExodusFile::open(&dir.path().join("out/bar.e")).unwrap();
    let first = nodal(&file, "DisplacementX", 15);
    let last = nodal(&file, "DisplacementX", 20);
    assert!(first != last, "the bar did not move after the restart");
}

/// SIGINT during an explicit run writes a restart file and says how to continue; running the
/// deck again continues from it to the file an uninterrupted run writes.
#[test]
fn a_run_stopped_by_sigint_continues_to_the_same_final_file() {
    let straight = tempfile::tempdir().unwrap();
    // 20,000 steps: long enough to be interrupted part-way.
    impact_deck(straight.path(), 4.0e-4, "  Restart: true\n");
    run_ok(straight.path(), "deck.yaml");
    let expected = keep(straight.path(), &["impact.e", "impact.csv"]);

    let dir = tempfile::tempdir().unwrap();
    impact_deck(dir.path(), 4.0e-4, "  Restart: true\n");
    let mut child = Command::new(env!("CARGO_BIN_EXE_peridyn"))
        .args(["run", "deck.yaml", "--output-dir", "out"])
        .current_dir(dir.path())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let stderr = child.stderr.take().unwrap();
    let mut lines = BufReader::new(stderr).lines();
    let mut seen = Vec::new();
    for line in lines.by_ref() {
        let line = line.unwrap();
        let started = line.contains("Verlet, Δt");
        seen.push(line);
        if started {
            break;
        }
    }
    std::thread::sleep(Duration::from_millis(300));
    // kill(2) rather than the `kill` program, which a minimal system lacks (Debian's `procps`).
    let pid = libc::pid_t::try_from(child.id()).expect("a process id fits pid_t");
    // SAFETY: kill(2) only reads its two integer arguments; the child is not yet reaped (it is
    // waited for below), so the id still names this run.
    let sent = unsafe { libc::kill(pid, libc::SIGINT) };
    assert_eq!(sent, 0, "kill: {}", std::io::Error::last_os_error());
    seen.extend(lines.map_while(Result::ok));
    let status = child.wait().unwrap();
    let stderr = seen.join("\n");
    assert_eq!(status.code(), Some(STOPPED), "{stderr}");
    assert!(
        stderr.contains("The state is saved in") && stderr.contains("run the same deck again"),
        "{stderr}"
    );
    assert_eq!(restart_dirs(dir.path()).len(), 1, "{stderr}");

    let resumed = run_ok(dir.path(), "deck.yaml");
    assert!(resumed.contains("restart: continuing from"), "{resumed}");
    let after = keep(dir.path(), &["impact.e", "impact.csv"]);
    assert!(after[0] == expected[0], "the Exodus files differ");
    assert!(after[1] == expected[1], "the CSV files differ");
}

/// A restart file written for another body is refused with exit code 2, naming what changed.
#[test]
fn a_changed_deck_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    impact_deck(dir.path(), 2.0e-6, "  Restart: true\n");
    run_ok(dir.path(), "deck.yaml");
    let text = std::fs::read_to_string(dir.path().join("deck.yaml")).unwrap();
    let changed = text.replace("Bulk Modulus: 14.9e9", "Bulk Modulus: 15.0e9");
    assert_ne!(text, changed);
    std::fs::write(dir.path().join("deck.yaml"), changed).unwrap();
    let out = peridyn(dir.path(), "deck.yaml");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("was written for another body") && stderr.contains("restart-000001"),
        "{stderr}"
    );
}

/// A finished run's deck run again: its restart holds the final time, which is not the first
/// solver's Initial Time, so the run is refused (as Peridigm does) with what to do.
#[test]
fn a_finished_run_is_not_run_again_over_its_restart() {
    let dir = tempfile::tempdir().unwrap();
    impact_deck(dir.path(), 2.0e-6, "  Restart: true\n");
    run_ok(dir.path(), "deck.yaml");
    let out = peridyn(dir.path(), "deck.yaml");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("this deck's run is complete"), "{stderr}");
}

/// Peridigm's restart: a second deck whose solver starts at the first one's final time
/// continues its state; its frames are the straight run's from then on, bit for bit: the
/// saved acceleration is used rather than evaluated again, and contact searches again at the
/// positions of its last search.
#[test]
fn a_second_deck_starts_from_the_state_the_first_ended_with() {
    let straight = tempfile::tempdir().unwrap();
    impact_deck(straight.path(), 2.0e-5, "");
    run_ok(straight.path(), "deck.yaml");
    let full = ExodusFile::open(&straight.path().join("out/impact.e")).unwrap();

    let dir = tempfile::tempdir().unwrap();
    impact_deck(dir.path(), 1.0e-5, "  Restart: true\n");
    run_ok(dir.path(), "deck.yaml");
    let text = std::fs::read_to_string(dir.path().join("deck.yaml")).unwrap();
    let second = text
        .replace("Initial Time: 0.0", "Initial Time: 1.0e-5")
        .replace("Final Time: 1e-5", "Final Time: 2e-5")
        .replace("\"impact\"", "\"impact_2\"");
    std::fs::write(dir.path().join("second.yaml"), second).unwrap();
    let stderr = run_ok(dir.path(), "second.yaml");
    assert!(
        stderr.contains("restart: starting from the state"),
        "{stderr}"
    );
    let part = ExodusFile::open(&dir.path().join("out/impact_2.e")).unwrap();
    // 500 steps, a frame every 25 and the initial one: the last 21 frames of the straight run.
    assert_eq!(part.times.len(), 21);
    let offset = full.times.len() - part.times.len();
    for (k, &t) in part.times.iter().enumerate() {
        assert!(
            (t - full.times[offset + k]).abs() <= 1e-18,
            "{t} against {}",
            full.times[offset + k]
        );
        for name in ["DisplacementX", "VelocityX"] {
            assert_eq!(
                nodal(&part, name, k),
                nodal(&full, name, offset + k),
                "{name} at frame {k}"
            );
        }
    }
}

mod quasi_static_bar;
