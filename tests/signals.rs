//! SIGINT and SIGTERM stop a run cleanly after its current step, with a frame of that step in
//! the results file and exit code 4; a second signal ends it at once (128 + signal); SIGKILL
//! leaves the Exodus file readable up to its last completed frame.
#![cfg(unix)]

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::mpsc::{channel, Receiver};
use std::time::{Duration, Instant};

use peridyn::io::exodus::ExodusFile;

/// Exit code of a clean stop (README, "Exit codes").
const STOPPED: i32 = 4;

/// A run of `deck.yaml` in `dir`, its stderr lines arriving on the receiver.
struct Running {
    child: Child,
    lines: Receiver<String>,
    seen: Vec<String>,
}

impl Running {
    fn start(dir: &Path) -> Self {
        let mut child = Command::new(env!("CARGO_BIN_EXE_peridyn"))
            .args(["run", "deck.yaml", "--output-dir", "out"])
            .current_dir(dir)
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("peridyn starts");
        let stderr = child.stderr.take().expect("stderr is piped");
        let (send, lines) = channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines().map_while(Result::ok) {
                if send.send(line).is_err() {
                    break;
                }
            }
        });
        Self {
            child,
            lines,
            seen: Vec::new(),
        }
    }

    /// Waits (at most 5 minutes, for a slow debug build) for a stderr line containing `needle`:
    /// the solver's header line says the run, and with it the signal handlers, has started.
    fn wait_for(&mut self, needle: &str) {
        let deadline = Instant::now() + Duration::from_secs(300);
        while Instant::now() < deadline {
            match self.lines.recv_timeout(Duration::from_millis(100)) {
                Ok(line) => {
                    let found = line.contains(needle);
                    self.seen.push(line);
                    if found {
                        return;
                    }
                }
                Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {}
                Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => break,
            }
        }
        let _ = self.child.kill();
        panic!(
            "no line with {needle:?}; stderr so far:\n{}",
            self.seen.join("\n")
        );
    }

    /// Sends `signal` (`libc::SIGINT`, …) to the run through the kill(2) system call, so the
    /// tests need no `kill` program (Debian's is in `procps`, which a minimal system lacks).
    fn signal(&self, signal: libc::c_int) {
        let pid = libc::pid_t::try_from(self.child.id()).expect("a process id fits pid_t");
        // SAFETY: kill(2) only reads its two integer arguments; the child is not yet reaped
        // (`finish` waits for it later), so the id still names this run.
        let sent = unsafe { libc::kill(pid, signal) };
        assert_eq!(
            sent,
            0,
            "kill({pid}, {signal}) failed: {}",
            std::io::Error::last_os_error()
        );
    }

    /// The exit status and the whole stderr, killing the run if it has not ended in 5 minutes.
    fn finish(mut self) -> (ExitStatus, String) {
        let deadline = Instant::now() + Duration::from_secs(300);
        let status = loop {
            if let Some(status) = self.child.try_wait().expect("wait works") {
                break status;
            }
            if Instant::now() > deadline {
                let _ = self.child.kill();
                panic!("the run did not stop; stderr:\n{}", self.seen.join("\n"));
            }
            std::thread::sleep(Duration::from_millis(50));
        };
        self.seen.extend(self.lines.iter());
        (status, self.seen.join("\n"))
    }
}

/// An explicit run of a 50×5×5 steel bar pushed at its left face, set to run for about
/// 400,000 steps (minutes), one frame every 10 steps.
fn long_explicit_run(dir: &Path) {
    let deck = r#"Peridigm:
  Discretization:
    Type: "PdQuickGrid"
    NeighborhoodType: "Spherical"
    TensorProduct3DMeshGenerator:
      X Origin: 0.0
      Y Origin: 0.0
      Z Origin: 0.0
      X Length: 0.05
      Y Length: 0.005
      Z Length: 0.005
      Number Points X: 50
      Number Points Y: 5
      Number Points Z: 5
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
    Left Face Node Set: "left.txt"
    Push:
      Type: "Initial Velocity"
      Node Set: "Left Face Node Set"
      Coordinate: "x"
      Value: "1.0"
  Solver:
    Final Time: 0.5
    Verlet:
      Safety Factor: 0.8
  Output:
    Output Filename: "bar"
    Output Frequency: 10
    Output Variables:
      Displacement: true
      Velocity: true
"#;
    std::fs::write(dir.join("deck.yaml"), deck).unwrap();
    write_face_sets(dir, 50, 5, 5);
}

/// A quasi-static tension run of an `nx`×`ny`×`nz` LPS block (1 mm spacing, δ = 3.015 mm,
/// left face held, right face pulled) in `load_steps` Jacobian-free Newton–Krylov load steps,
/// with a frame only every 10 load steps (so the initial state alone is scheduled).
fn quasi_static_run(dir: &Path, (nx, ny, nz): (usize, usize, usize), load_steps: usize) {
    let deck = format!(
        r#"Peridigm:
  Discretization:
    Type: "PdQuickGrid"
    NeighborhoodType: "Spherical"
    TensorProduct3DMeshGenerator:
      X Origin: 0.0
      Y Origin: 0.0
      Z Origin: 0.0
      X Length: {lx}
      Y Length: {ly}
      Z Length: {lz}
      Number Points X: {nx}
      Number Points Y: {ny}
      Number Points Z: {nz}
  Materials:
    Aluminium:
      Material Model: "Elastic"
      Density: 2700.0
      Bulk Modulus: 68.0e9
      Shear Modulus: 26.0e9
  Blocks:
    All:
      Block Names: "block_1"
      Material: "Aluminium"
      Horizon: 0.003015
  Boundary Conditions:
    Left Face Node Set: "left.txt"
    Right Face Node Set: "right.txt"
    Hold X: {{Type: "Prescribed Displacement", Node Set: "Left Face Node Set", Coordinate: "x", Value: "0.0"}}
    Hold Y: {{Type: "Prescribed Displacement", Node Set: "Left Face Node Set", Coordinate: "y", Value: "0.0"}}
    Hold Z: {{Type: "Prescribed Displacement", Node Set: "Left Face Node Set", Coordinate: "z", Value: "0.0"}}
    Pull X: {{Type: "Prescribed Displacement", Node Set: "Right Face Node Set", Coordinate: "x", Value: "4.0e-5*t"}}
  Solver:
    Final Time: 1.0
    Peridigm Preconditioner: "Block 3x3"
    NOXQuasiStatic:
      Number of Load Steps: {load_steps}
      Relative Tolerance: 1.0e-8
      Max Solver Iterations: 10
      Direction: {{Method: "Newton", Newton: {{Linear Solver: {{Jacobian Operator: "Matrix-Free"}}}}}}
  Output:
    Output Filename: "block"
    Output Frequency: 10
    Output Variables:
      Displacement: true
"#,
        lx = nx as f64 * 1e-3,
        ly = ny as f64 * 1e-3,
        lz = nz as f64 * 1e-3,
    );
    std::fs::write(dir.join("deck.yaml"), deck).unwrap();
    write_face_sets(dir, nx, ny, nz);
}

/// `left.txt` and `right.txt`: 1-based ids of the x = min and x = max faces of a
/// tensor-product grid (x varies fastest).
fn write_face_sets(dir: &Path, nx: usize, ny: usize, nz: usize) {
    let rows = 0..ny * nz;
    let left: Vec<String> = rows.clone().map(|r| (r * nx + 1).to_string()).collect();
    let right: Vec<String> = rows.map(|r| ((r + 1) * nx).to_string()).collect();
    std::fs::write(dir.join("left.txt"), left.join("\n") + "\n").unwrap();
    std::fs::write(dir.join("right.txt"), right.join("\n") + "\n").unwrap();
}

/// `(step, time)` from "stopped by SIG… after step N of solver "…" (t = T s)".
fn stopped_at(stderr: &str) -> (usize, f64) {
    let after = stderr
        .split("after step ")
        .nth(1)
        .unwrap_or_else(|| panic!("no stop message in:\n{stderr}"));
    let step = after.split(' ').next().unwrap().parse().unwrap();
    let time = after.split("(t = ").nth(1).unwrap();
    let time = time.split(' ').next().unwrap().parse().unwrap();
    (step, time)
}

#[test]
fn sigterm_finishes_the_explicit_step_and_writes_its_frame() {
    let dir = tempfile::tempdir().unwrap();
    long_explicit_run(dir.path());
    let mut run = Running::start(dir.path());
    run.wait_for("Verlet, Δt");
    std::thread::sleep(Duration::from_millis(300));
    run.signal(libc::SIGTERM);
    let (status, stderr) = run.finish();
    assert_eq!(status.code(), Some(STOPPED), "{stderr}");
    assert!(stderr.contains("stopped by SIGTERM after step"), "{stderr}");
    assert!(stderr.contains("out/bar.e"), "{stderr}");
    let (step, time) = stopped_at(&stderr);
    assert!(step > 0, "{stderr}");

    let file = ExodusFile::open(&dir.path().join("out/bar.e")).unwrap();
    // Frames at calls 1, 11, 21, … (steps 0, 10, 20, …) plus the stop's own frame when its
    // step is not a multiple of 10.
    let scheduled = 1 + step / 10;
    let expected = scheduled + usize::from(step % 10 != 0);
    assert_eq!(file.times.len(), expected, "{stderr}");
    let last = *file.times.last().unwrap();
    // The message prints t with 7 significant digits.
    assert!((last - time).abs() <= 1e-6 * time, "{last} vs {time}");
    let ux = file.nodal_values(file.times.len() - 1, 0).unwrap();
    assert!(ux.iter().all(|u| u.is_finite()));
    assert!(ux.iter().any(|&u| u != 0.0), "the pushed face has moved");
}

#[test]
fn sigint_finishes_the_load_step_and_writes_its_frame() {
    let dir = tempfile::tempdir().unwrap();
    quasi_static_run(dir.path(), (12, 6, 6), 50);
    let mut run = Running::start(dir.path());
    run.wait_for("load steps");
    run.signal(libc::SIGINT);
    let (status, stderr) = run.finish();
    assert_eq!(status.code(), Some(STOPPED), "{stderr}");
    assert!(stderr.contains("stopped by SIGINT after step"), "{stderr}");
    let (step, time) = stopped_at(&stderr);
    assert!((1..50).contains(&step), "{stderr}");
    // Load step k of 50 ends at t = k/50.
    assert!((time - step as f64 / 50.0).abs() < 1e-12, "{stderr}");

    let file = ExodusFile::open(&dir.path().join("out/block.e")).unwrap();
    // The initial frame, the scheduled ones (load steps 10, 20, …) and the stop's own.
    let expected = 1 + step / 10 + usize::from(step % 10 != 0);
    assert_eq!(file.times.len(), expected, "{stderr}");
    assert!((file.times.last().unwrap() - time).abs() < 1e-12);
}

#[test]
fn a_second_signal_ends_the_run_at_once() {
    let dir = tempfile::tempdir().unwrap();
    // Large enough that the first load step takes seconds even in a release build.
    quasi_static_run(dir.path(), (40, 25, 20), 2);
    let mut run = Running::start(dir.path());
    run.wait_for("load steps");
    run.signal(libc::SIGINT);
    std::thread::sleep(Duration::from_millis(200));
    run.signal(libc::SIGINT);
    let (status, stderr) = run.finish();
    // 128 + SIGINT (2), the shell's convention for a process ended by a signal.
    assert_eq!(status.code(), Some(130), "{stderr}");
    assert!(!stderr.contains("stopped by"), "{stderr}");
    // The initial frame was complete before the signals: the file reads.
    let file = ExodusFile::open(&dir.path().join("out/block.e")).unwrap();
    assert_eq!(file.times, vec![0.0]);
}

#[test]
fn sigkill_leaves_the_frames_written_so_far_readable() {
    let dir = tempfile::tempdir().unwrap();
    long_explicit_run(dir.path());
    let mut run = Running::start(dir.path());
    run.wait_for("Verlet, Δt");
    std::thread::sleep(Duration::from_millis(1500));
    run.signal(libc::SIGKILL);
    let (status, stderr) = run.finish();
    assert_eq!(status.code(), None, "killed by a signal: {stderr}");
    let file = ExodusFile::open(&dir.path().join("out/bar.e")).unwrap();
    assert!(file.times.len() > 1, "frames were written before the kill");
    assert!(file.times.windows(2).all(|t| t[0] < t[1]));
    let last = file.times.len() - 1;
    for variable in 0..6 {
        let values = file.nodal_values(last, variable).unwrap();
        assert_eq!(values.len(), 50 * 5 * 5);
        assert!(values.iter().all(|v| v.is_finite()));
    }
}
