//! Faults around a run: an output folder that is missing, cannot be created or is not
//! writable (exit code 5, nothing computed); a disk that fills up before or during the run
//! (exit code 6, the message says what failed, the frames written before stay readable with
//! peridyn's own reader); a mesh file changed between a run and its restart (exit code 2,
//! naming what changed).
#![cfg(unix)]

use std::path::Path;
use std::process::{Command, Output};

use peridyn::io::exodus::ExodusFile;

/// Exit code of an output folder that cannot be created or written to (README, "Exit codes").
const FOLDER_UNUSABLE: i32 = 5;
/// Exit code of a write that failed during the run (README, "Exit codes").
const WRITE_FAILED: i32 = 6;
/// Exit code of invalid input, a restart file that does not fit the deck included.
#[cfg(feature = "hdf5")]
const INVALID_INPUT: i32 = 2;

/// Points of the bar: 10 × 2 × 2 on a 1 mm grid.
const NX: usize = 10;
const NYZ: usize = 2;

/// `x y z block volume` lines of the bar (Peridigm's text mesh), in id order.
fn bar_mesh() -> Vec<String> {
    let mut lines = Vec::new();
    for i in 0..NX {
        for j in 0..NYZ {
            for k in 0..NYZ {
                lines.push(format!(
                    "{:e} {:e} {:e} 1 1.0e-9",
                    0.0005 + 0.001 * i as f64,
                    0.0005 + 0.001 * j as f64,
                    0.0005 + 0.001 * k as f64
                ));
            }
        }
    }
    lines
}

/// A 40-point steel bar whose left end is pushed: 40 explicit steps of a fixed 1e-8 s (well
/// below the stable step of a 1 mm grid of steel, ~1e-7 s), a frame after every step (41
/// frames), `restart` appended to the deck.
fn bar_deck(dir: &Path, restart: &str) {
    let left: Vec<String> = (1..=NYZ * NYZ).map(|id| id.to_string()).collect();
    let deck = format!(
        r#"Peridigm:
  Discretization:
    Type: "Text File"
    Input Mesh File: "bar.txt"
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
      Horizon: 0.003015
  Boundary Conditions:
    Left Node Set: "{left}"
    Push:
      Type: "Initial Velocity"
      Node Set: "Left Node Set"
      Coordinate: "x"
      Value: "1.0"
  Solver:
    Final Time: 4.05e-7
    Verlet:
      Fixed dt: 1.0e-8
  Output:
    Output Filename: "bar"
    Output Frequency: 1
    Output Variables:
      Displacement: true
      Velocity: true
{restart}"#,
        left = left.join(" ")
    );
    std::fs::write(dir.join("deck.yaml"), deck).unwrap();
    std::fs::write(dir.join("bar.txt"), bar_mesh().join("\n") + "\n").unwrap();
}

fn peridyn_in(dir: &Path, output_dir: &str) -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_peridyn"));
    command
        .args(["run", "deck.yaml", "--output-dir", output_dir])
        .current_dir(dir);
    command
}

fn finished(output: Output) -> (Option<i32>, String) {
    (
        output.status.code(),
        String::from_utf8_lossy(&output.stderr).to_string(),
    )
}

fn run(dir: &Path, output_dir: &str) -> (Option<i32>, String) {
    finished(
        peridyn_in(dir, output_dir)
            .output()
            .expect("peridyn starts"),
    )
}

/// A missing `--output-dir` is created with its parents, as `mkdir -p` would.
#[test]
fn a_missing_output_folder_is_created() {
    let dir = tempfile::tempdir().unwrap();
    bar_deck(dir.path(), "");
    let (code, stderr) = run(dir.path(), "results/run1");
    assert_eq!(code, Some(0), "{stderr}");
    let file = ExodusFile::open(&dir.path().join("results/run1/bar.e")).unwrap();
    assert_eq!(file.times.len(), 41);
}

/// An output folder that cannot be created (its parent is a file) is exit code 5 before any
/// computing, naming the folder and the option to change.
#[test]
fn an_output_folder_that_cannot_be_created_is_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    bar_deck(dir.path(), "");
    std::fs::write(dir.path().join("results"), b"a file, not a folder").unwrap();
    let (code, stderr) = run(dir.path(), "results/run1");
    assert_eq!(code, Some(FOLDER_UNUSABLE), "{stderr}");
    assert!(
        stderr.contains("cannot create the output folder results/run1")
            && stderr.contains("--output-dir"),
        "{stderr}"
    );
    assert!(
        !stderr.contains("points,"),
        "refused before the setup: {stderr}"
    );
}

/// A read-only output folder is exit code 5 before any computing. Root writes into a folder
/// whatever its mode; there the folder is `/sys` (sysfs, where no file can be created), and
/// where even that takes a file the test has nothing to inject and says so.
#[test]
fn a_read_only_output_folder_is_refused_at_once() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    bar_deck(dir.path(), "");
    let out = dir.path().join("out");
    std::fs::create_dir(&out).unwrap();
    std::fs::set_permissions(&out, std::fs::Permissions::from_mode(0o555)).unwrap();
    let folder = if std::fs::write(out.join("probe"), b"").is_err() {
        "out"
    } else if std::fs::write("/sys/peridyn-probe", b"").is_err() {
        "/sys"
    } else {
        println!("skipped: this process writes into a 0555 folder and into /sys, so there is no unwritable folder to give the run");
        return;
    };
    let (code, stderr) = run(dir.path(), folder);
    std::fs::set_permissions(&out, std::fs::Permissions::from_mode(0o755)).unwrap();
    assert_eq!(code, Some(FOLDER_UNUSABLE), "{stderr}");
    assert!(
        stderr.contains(&format!("the output folder {folder} is not writable"))
            && stderr.contains("chmod u+w"),
        "{stderr}"
    );
    assert!(
        !stderr.contains("points,"),
        "refused before the setup: {stderr}"
    );
}

/// A disk that is full from the start: the results file is `/dev/full` (through a symbolic
/// link), where every write fails with ENOSPC. Exit code 6 with the operating system's reason
/// and the file's name.
#[test]
fn a_full_disk_is_exit_code_6_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    bar_deck(dir.path(), "");
    let out = dir.path().join("out");
    std::fs::create_dir(&out).unwrap();
    std::os::unix::fs::symlink("/dev/full", out.join("bar.e")).unwrap();
    let (code, stderr) = run(dir.path(), "out");
    assert_eq!(code, Some(WRITE_FAILED), "{stderr}");
    assert!(
        stderr.contains("bar.e")
            && stderr.contains("No space left on device")
            && stderr.contains("Free space"),
        "{stderr}"
    );
}

/// The disk fills up part-way through the run: the child's file-size limit (RLIMIT_FSIZE, with
/// SIGXFSZ ignored so that the write returns EFBIG instead of killing it) stops the results
/// file at half the size of the complete one. Exit code 6, and the file opens with peridyn's
/// reader holding the frames completed before the failure, each equal bit for bit to the
/// complete run's frame.
///
/// Only in a build without MPI: a binary with MPI (features `mpi`, `trilinos`, `petsc`) starts
/// it even on one process, and OpenMPI's start-up (PMIx) writes shared-memory files larger than
/// the limit, so MPI_Init aborts before the run begins. The `/dev/full` test above covers a
/// full disk in those builds.
#[test]
#[cfg(not(any(feature = "mpi", feature = "trilinos", feature = "petsc")))]
fn a_disk_full_part_way_keeps_the_earlier_frames_readable() {
    use std::os::unix::process::CommandExt;

    let dir = tempfile::tempdir().unwrap();
    bar_deck(dir.path(), "");
    let (code, stderr) = run(dir.path(), "complete");
    assert_eq!(code, Some(0), "{stderr}");
    let complete_path = dir.path().join("complete/bar.e");
    let complete = ExodusFile::open(&complete_path).unwrap();
    assert_eq!(complete.times.len(), 41);
    let limit = std::fs::metadata(&complete_path).unwrap().len() / 2;

    let mut command = peridyn_in(dir.path(), "limited");
    // SAFETY: between fork and exec only async-signal-safe calls (signal, setrlimit) are made.
    unsafe {
        command.pre_exec(move || {
            libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
            let limit = libc::rlimit {
                rlim_cur: limit as libc::rlim_t,
                rlim_max: limit as libc::rlim_t,
            };
            if libc::setrlimit(libc::RLIMIT_FSIZE, &limit) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
    let (code, stderr) = finished(command.output().expect("peridyn starts"));
    assert_eq!(code, Some(WRITE_FAILED), "{stderr}");
    assert!(
        stderr.contains("bar.e")
            && stderr.contains("File too large")
            && stderr.contains("holds the frames completed before this one"),
        "{stderr}"
    );
    let partial = ExodusFile::open(&dir.path().join("limited/bar.e")).unwrap();
    let frames = partial.times.len();
    assert!(
        frames > 5 && frames < 41,
        "{frames} frames in half the file"
    );
    let index = partial.nodal_variable_index("DisplacementX").unwrap();
    for step in 0..frames {
        assert_eq!(partial.times[step], complete.times[step]);
        assert_eq!(
            partial.nodal_values(step, index).unwrap(),
            complete.nodal_values(step, index).unwrap(),
            "frame {step}"
        );
    }
}

/// A mesh file changed between a run and its restart is refused with exit code 2: a point
/// added is named by the point counts, a point moved by the body's hash.
#[cfg(feature = "hdf5")]
#[test]
fn a_mesh_changed_under_a_restart_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    bar_deck(dir.path(), "  Restart: true\n");
    let (code, stderr) = run(dir.path(), "out");
    assert_eq!(code, Some(0), "{stderr}");

    let mut moved = bar_mesh();
    moved[7] = moved[7].replacen("1.5e-3", "1.5000001e-3", 1);
    assert_ne!(moved, bar_mesh(), "one coordinate moved");
    std::fs::write(dir.path().join("bar.txt"), moved.join("\n") + "\n").unwrap();
    let (code, stderr) = run(dir.path(), "out");
    assert_eq!(code, Some(INVALID_INPUT), "{stderr}");
    assert!(
        stderr.contains("was written for another body") && stderr.contains("mesh"),
        "{stderr}"
    );

    let mut grown = bar_mesh();
    grown.push("1.05e-2 5e-4 5e-4 1 1.0e-9".into());
    std::fs::write(dir.path().join("bar.txt"), grown.join("\n") + "\n").unwrap();
    let (code, stderr) = run(dir.path(), "out");
    assert_eq!(code, Some(INVALID_INPUT), "{stderr}");
    assert!(
        stderr.contains("was written for a body of 40 points, but this deck's mesh now has 41"),
        "{stderr}"
    );
}

fn check_json(dir: &Path, output_dir: &str) -> serde_json::Value {
    let output = Command::new(env!("CARGO_BIN_EXE_peridyn"))
        .args(["check", "deck.yaml", "--json", "--output-dir", output_dir])
        .current_dir(dir)
        .output()
        .expect("peridyn starts");
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    serde_json::from_slice(&output.stdout).expect("check --json prints JSON")
}

/// The plan's estimate of the results file against the file a run writes: the frames are
/// counted exactly (41 of 8 × (1 + 6 × 40) bytes), the fixed part is estimated from the
/// points alone (the netCDF header, names and node sets are left out), so the file is a
/// little larger than the estimate.
#[test]
fn the_results_estimate_matches_the_file_written() {
    let dir = tempfile::tempdir().unwrap();
    bar_deck(dir.path(), "");
    let (code, stderr) = run(dir.path(), "out");
    assert_eq!(code, Some(0), "{stderr}");
    let written = std::fs::metadata(dir.path().join("out/bar.e"))
        .unwrap()
        .len();
    let plan = check_json(dir.path(), "out");
    let disk = &plan["disk"];
    let estimate = disk["results_bytes"].as_u64().unwrap();
    assert_eq!(disk["restart_bytes"].as_u64(), Some(0));
    assert!(disk["available_bytes"].as_u64().is_some_and(|b| b > 0));
    let frames = 41 * 8 * (1 + 6 * 40);
    assert!(estimate >= frames, "{estimate} < {frames}");
    assert!(
        estimate <= written && written <= estimate + 16 * 1024,
        "estimate {estimate} bytes, file {written} bytes"
    );
}

/// A run of 10⁹ steps with a frame after each (about 1.9 TB of results: 10⁹ × 8 × 241 bytes)
/// exceeds the free space of any test machine: `check` lists the warning, and `run` prints it
/// before it starts (here it then stops at once: its results file is /dev/full).
#[test]
fn the_plan_warns_when_the_results_will_not_fit() {
    let dir = tempfile::tempdir().unwrap();
    bar_deck(dir.path(), "");
    let deck = std::fs::read_to_string(dir.path().join("deck.yaml")).unwrap();
    let long = deck.replace("Final Time: 4.05e-7", "Final Time: 10.0");
    assert_ne!(deck, long);
    std::fs::write(dir.path().join("deck.yaml"), long).unwrap();

    let plan = check_json(dir.path(), "out");
    let estimate = plan["disk"]["results_bytes"].as_u64().unwrap();
    assert!(estimate >= 1_000_000_000 * 8 * 241, "{estimate}");
    let warnings = plan["warnings"].to_string();
    assert!(
        warnings.contains("the run will write about")
            && warnings.contains("is free on the file system of out"),
        "{warnings}"
    );

    let out = dir.path().join("out");
    std::fs::create_dir(&out).unwrap();
    std::os::unix::fs::symlink("/dev/full", out.join("bar.e")).unwrap();
    let (code, stderr) = run(dir.path(), "out");
    assert_eq!(code, Some(WRITE_FAILED), "{stderr}");
    assert!(
        stderr.contains("warning: the run will write about"),
        "{stderr}"
    );
}
