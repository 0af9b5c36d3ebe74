//! What a variant run cost: wall and CPU time and peak memory of the child process (from
//! `wait4`, which returns the child's resource usage as it is reaped), steps from the run's
//! log, Newton and Krylov iterations from its `<output>_solver.csv`.

use std::path::Path;
use std::process::Child;
use std::time::Instant;

/// How the child process ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Exit {
    /// Exited with this code (`peridyn run`'s exit codes: 0 success, 2 invalid input, 3
    /// solver failure or instability, 1 anything else).
    Code(i32),
    /// Killed by this signal.
    Signal(i32),
}

/// Resource usage of one run; `None` where the platform or the run does not tell.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Cost {
    /// Wall-clock time from spawning the child to reaping it (s).
    pub wall_seconds: f64,
    /// User + system CPU time of the child (s).
    pub cpu_seconds: Option<f64>,
    /// Peak resident memory of the child (bytes).
    pub peak_rss_bytes: Option<u64>,
    /// Steps of all solver lists (`done: N steps` in the run's log).
    pub steps: Option<u64>,
    /// Newton iterations summed over the implicit steps (`Newton_Iterations` of the solver
    /// CSV; `None` for explicit runs, which write no solver CSV).
    pub newton_iterations: Option<u64>,
    /// Krylov iterations summed over the implicit steps (`Linear_Iterations`).
    pub krylov_iterations: Option<u64>,
}

/// Waits for `child` (started at `start`) and measures its wall time, CPU time and peak RSS.
#[cfg(unix)]
pub fn wait(child: Child, start: Instant) -> std::io::Result<(Exit, Cost)> {
    let pid = child.id() as libc::pid_t;
    let mut status: libc::c_int = 0;
    // SAFETY: `rusage` is a plain C struct of integers, for which all-zero is a valid value.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    loop {
        // SAFETY: `pid` is a child this process spawned and has not reaped (the `Child` is
        // never waited on through std); `status` and `usage` are valid for writes.
        let reaped = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
        if reaped == pid {
            break;
        }
        let error = std::io::Error::last_os_error();
        if error.kind() != std::io::ErrorKind::Interrupted {
            return Err(error);
        }
    }
    let wall_seconds = start.elapsed().as_secs_f64();
    drop(child);
    let exit = if libc::WIFEXITED(status) {
        Exit::Code(libc::WEXITSTATUS(status))
    } else if libc::WIFSIGNALED(status) {
        Exit::Signal(libc::WTERMSIG(status))
    } else {
        Exit::Code(-1)
    };
    let seconds = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    // Linux reports ru_maxrss in KiB, macOS in bytes.
    let rss_unit = if cfg!(target_os = "macos") { 1 } else { 1024 };
    Ok((
        exit,
        Cost {
            wall_seconds,
            cpu_seconds: Some(seconds(usage.ru_utime) + seconds(usage.ru_stime)),
            peak_rss_bytes: Some(usage.ru_maxrss.max(0) as u64 * rss_unit),
            ..Cost::default()
        },
    ))
}

/// Waits for `child`; without `wait4` only the wall time is known.
#[cfg(not(unix))]
pub fn wait(mut child: Child, start: Instant) -> std::io::Result<(Exit, Cost)> {
    let status = child.wait()?;
    Ok((
        Exit::Code(status.code().unwrap_or(-1)),
        Cost {
            wall_seconds: start.elapsed().as_secs_f64(),
            ..Cost::default()
        },
    ))
}

/// What the run's log (its standard error) says: `done: N steps …`, `N points, M bonds` and
/// the last `error: …` line.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LogSummary {
    /// Steps of the finished run.
    pub steps: Option<u64>,
    /// Points of the body.
    pub points: Option<u64>,
    /// The run's error message, when it failed.
    pub error: Option<String>,
    /// The stable time step estimate of the first Verlet list (`stable estimate X s`).
    pub stable_estimate: Option<f64>,
    /// The files the run wrote (`wrote PATH`), in order.
    pub files: Vec<std::path::PathBuf>,
}

/// Reads the lines `peridyn run` prints (see `run` in `src/main.rs`).
pub fn read_log(text: &str) -> LogSummary {
    let mut summary = LogSummary::default();
    for line in text.lines() {
        if let Some((_, rest)) = line.split_once("(stable estimate ") {
            if summary.stable_estimate.is_none() {
                summary.stable_estimate =
                    rest.split_whitespace().next().and_then(|e| e.parse().ok());
            }
        }
        if let Some(rest) = line.strip_prefix("done: ") {
            summary.steps = rest.split_whitespace().next().and_then(|n| n.parse().ok());
        } else if let Some(rest) = line.strip_prefix("wrote ") {
            summary.files.push(rest.trim().into());
        } else if let Some(rest) = line.strip_prefix("error: ") {
            summary.error = Some(rest.trim().to_string());
        } else if let Some((_, counts)) = line.rsplit_once(": ") {
            let words: Vec<&str> = counts.split_whitespace().collect();
            if let [n, "points,", _, "bonds"] = words.as_slice() {
                summary.points = n.parse().ok();
            }
        }
    }
    summary
}

/// Sums of `Newton_Iterations` and `Linear_Iterations` over the rows of a solver CSV; `None`
/// when the file does not exist (an explicit run) or lacks the column.
pub fn solver_iterations(path: &Path) -> (Option<u64>, Option<u64>) {
    let Ok(text) = std::fs::read_to_string(path) else {
        return (None, None);
    };
    let mut lines = text.lines();
    let Some(header) = lines.next() else {
        return (None, None);
    };
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    let column = |name: &str| names.iter().position(|n| *n == name);
    let (newton, krylov) = (column("Newton_Iterations"), column("Linear_Iterations"));
    let mut sums = (newton.map(|_| 0u64), krylov.map(|_| 0u64));
    for line in lines.filter(|l| !l.trim().is_empty()) {
        let cells: Vec<&str> = line.split(',').collect();
        let value = |k: Option<usize>| -> u64 {
            k.and_then(|k| cells.get(k))
                .and_then(|c| c.trim().parse::<f64>().ok())
                .map_or(0, |v| v.max(0.0) as u64)
        };
        if let Some(sum) = sums.0.as_mut() {
            *sum += value(newton);
        }
        if let Some(sum) = sums.1.as_mut() {
            *sum += value(krylov);
        }
    }
    sums
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_log_gives_steps_points_and_the_error() {
        let log = "bar.yaml: 250 points, 4000 bonds\n\
                   Solver: Verlet, Δt = 1e-6 s (stable estimate 1.25e-6 s, safety factor 0.8), 9 steps\n\
                   done: 123 steps in 0.01 s (+ 0.00 s output), 0 bonds broken\n\
                   wrote out/bar.e\n";
        let summary = read_log(log);
        assert_eq!(summary.steps, Some(123));
        assert_eq!(summary.points, Some(250));
        assert_eq!(summary.stable_estimate, Some(1.25e-6));
        assert_eq!(summary.error, None);
        assert_eq!(summary.files, [std::path::PathBuf::from("out/bar.e")]);
        let failed = read_log("bar.yaml: 8 points, 0 bonds\nerror: the run became unstable\n");
        assert_eq!(failed.steps, None);
        assert_eq!(failed.error.as_deref(), Some("the run became unstable"));
    }

    #[test]
    fn solver_iterations_are_summed_over_the_steps() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bar_solver.csv");
        std::fs::write(
            &path,
            "Time,Step,Newton_Iterations,Linear_Iterations\n0.5,1,3,40\n1.0,2,2,25\n",
        )
        .unwrap();
        assert_eq!(solver_iterations(&path), (Some(5), Some(65)));
        assert_eq!(
            solver_iterations(&dir.path().join("none.csv")),
            (None, None)
        );
    }

    #[cfg(unix)]
    #[test]
    fn a_child_is_measured_and_its_exit_code_kept() {
        let start = Instant::now();
        let child = std::process::Command::new("sh")
            .args(["-c", "exit 3"])
            .spawn()
            .unwrap();
        let (exit, cost) = wait(child, start).unwrap();
        assert_eq!(exit, Exit::Code(3));
        assert!(cost.cpu_seconds.is_some() && cost.peak_rss_bytes.unwrap() > 0);
    }
}
