//! LAMMPS on the same problem: finding `lmp`, running it, reading its screen output.

use std::path::{Path, PathBuf};
use std::process::Command;

use super::problem::BenchModel;
use super::BenchError;

/// What LAMMPS printed about one run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LammpsRun {
    /// `Loop time of X on P procs for N steps`: X.
    pub loop_seconds: f64,
    /// P.
    pub procs: usize,
    /// N.
    pub steps: u64,
    /// `total # of bonds = B`, if printed.
    pub bonds: Option<usize>,
    /// `C% CPU use`, if printed.
    pub cpu_percent: Option<f64>,
}

impl LammpsRun {
    /// Loop milliseconds per step.
    pub fn ms_per_step(&self) -> f64 {
        self.loop_seconds * 1e3 / self.steps as f64
    }

    /// Directed bond evaluations per CPU-second: `bonds / (loop × CPU use)`, when LAMMPS
    /// printed both.
    pub fn rate_per_cpu_second(&self) -> Option<f64> {
        let cpu = self.loop_seconds * self.cpu_percent? / 100.0;
        let bonds = self.bonds? as f64;
        (cpu > 0.0).then(|| bonds * self.steps as f64 / cpu)
    }
}

/// Reads LAMMPS's screen output: the `Loop time of X on P procs for N steps ...` line (required),
/// `total # of bonds = B` and `C% CPU use ...` (optional).
pub fn parse_lammps_output(text: &str) -> Option<LammpsRun> {
    let mut run = None;
    let mut bonds = None;
    let mut cpu_percent = None;
    for line in text.lines() {
        let line = line.trim();
        if let Some(rest) = line.strip_prefix("Loop time of ") {
            let words: Vec<&str> = rest.split_whitespace().collect();
            // X on P procs for N steps ...
            if words.len() >= 6 && words[1] == "on" && words[3] == "procs" && words[4] == "for" {
                let loop_seconds = words[0].parse().ok()?;
                let procs = words[2].parse().ok()?;
                let steps = words[5].parse().ok()?;
                run = Some((loop_seconds, procs, steps));
            }
        } else if let Some(rest) = line.strip_prefix("total # of bonds =") {
            bonds = rest.trim().parse().ok();
        } else if let Some((percent, _)) = line.split_once("% CPU use") {
            cpu_percent = percent.trim().parse().ok();
        }
    }
    let (loop_seconds, procs, steps) = run?;
    Some(LammpsRun {
        loop_seconds,
        procs,
        steps,
        bonds,
        cpu_percent,
    })
}

/// `name` on `PATH`, if any.
pub fn find_on_path(name: &str) -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .map(|dir| dir.join(name))
        .find(|candidate| candidate.is_file())
}

/// Runs `lmp -in <input> -var model <model> -var n <n> -log none` on one process with one
/// OpenMP thread, in the system's temporary folder.
pub fn run_lammps(
    lmp: &Path,
    input: &Path,
    model: BenchModel,
    points_per_edge: usize,
) -> Result<LammpsRun, BenchError> {
    let output = Command::new(lmp)
        .arg("-in")
        .arg(input)
        .args(["-var", "model", model.lammps_name()])
        .args(["-var", "n", &points_per_edge.to_string()])
        .args(["-log", "none"])
        .env("OMP_NUM_THREADS", "1")
        .current_dir(std::env::temp_dir())
        .output()
        .map_err(|e| BenchError::Lammps(format!("cannot start {}: {e}", lmp.display())))?;
    let stdout = String::from_utf8_lossy(&output.stdout);
    if !output.status.success() {
        let stderr = String::from_utf8_lossy(&output.stderr);
        return Err(BenchError::Lammps(format!(
            "{} -in {} failed ({}): {}{}",
            lmp.display(),
            input.display(),
            output.status,
            stdout.lines().rev().take(5).collect::<Vec<_>>().join(" | "),
            stderr.trim()
        )));
    }
    parse_lammps_output(&stdout).ok_or_else(|| {
        BenchError::Lammps(format!(
            "no `Loop time of ... on ... procs for ... steps` line in the output of {}",
            lmp.display()
        ))
    })
}

/// The default LAMMPS input: `in.pdcheck` in `../shared/bench/lammps` beside the checkout, where
/// the development machines keep it.
pub fn default_lammps_input() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/bench/lammps/in.pdcheck")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_lammps_screen_output() {
        // Lines as LAMMPS 2022 prints them for in.pdcheck.
        let text = "  total # of bonds = 2929168\n\
                    Loop time of 4.41234 on 1 procs for 100 steps with 27000 atoms\n\
                    \n\
                    99.7% CPU use with 1 MPI tasks x 1 OpenMP threads\n";
        let run = parse_lammps_output(text).unwrap();
        assert_eq!(run.loop_seconds, 4.41234);
        assert_eq!(run.procs, 1);
        assert_eq!(run.steps, 100);
        assert_eq!(run.bonds, Some(2_929_168));
        assert_eq!(run.cpu_percent, Some(99.7));
        assert!((run.ms_per_step() - 44.1234).abs() < 1e-9);
        assert!(parse_lammps_output("ERROR: Unknown pair style\n").is_none());
    }
}
