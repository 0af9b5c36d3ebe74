//! What the MPI test files share: running the built `peridyn` under `mpirun`.
// Each test crate that includes this module uses only part of it.
#![allow(dead_code)]

use std::path::Path;
use std::process::{Command, Output};

/// The `peridyn` binary cargo built for these tests.
pub const PERIDYN: &str = env!("CARGO_BIN_EXE_peridyn");

/// `timeout 300 mpirun -np <ranks> --oversubscribe peridyn <args>` in `dir`, as root if need
/// be (OpenMPI refuses root without the two variables). The timeout turns a hang into a
/// failure.
pub fn mpirun(dir: &Path, ranks: usize, args: &[&str]) -> Output {
    Command::new("timeout")
        .args([
            "300",
            "mpirun",
            "-np",
            &ranks.to_string(),
            "--oversubscribe",
        ])
        .arg(PERIDYN)
        .args(args)
        .current_dir(dir)
        .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        .output()
        .expect("mpirun starts (install openmpi-bin: see .ci/mpi.sh)")
}

/// Panics with both output streams unless the command succeeded.
pub fn assert_success(output: &Output, what: &str) {
    assert!(
        output.status.success(),
        "{what} failed ({}):\n{}\n{}",
        output.status,
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    );
}

/// exodiff command file: every variable, coordinates and times within 1e-12 relative with no
/// floor (the bar of the MPI issue; the runs compared with it are in fact bitwise equal).
pub const STRICT: &str = "DEFAULT TOLERANCE relative 1.0E-12 floor 0.0
COORDINATES absolute 0.0
TIME STEPS relative 1.0E-12 floor 0.0
GLOBAL VARIABLES
NODAL VARIABLES
ELEMENT VARIABLES
";

/// `peridyn diff ranks<ranks>/<file> ranks1/<file> --comp <comp>` in `dir`: the run on
/// `ranks` ranks against the one-rank run. Returns the finished command.
pub fn diff_against_one_rank(dir: &Path, ranks: usize, file: &str, comp: &str) -> Output {
    Command::new(PERIDYN)
        .args([
            "diff",
            &format!("ranks{ranks}/{file}"),
            &format!("ranks1/{file}"),
            "--comp",
            comp,
        ])
        .current_dir(dir)
        .output()
        .unwrap()
}

/// `peridyn run <deck> --output-dir ranks<ranks>` under `mpirun` in `dir`; panics with the log
/// unless it succeeded, and returns the log (standard error).
pub fn run_on_ranks(dir: &Path, ranks: usize, deck: &str, what: &str) -> String {
    let out = format!("ranks{ranks}");
    let output = mpirun(dir, ranks, &["run", deck, "--output-dir", &out]);
    let log = String::from_utf8_lossy(&output.stderr).into_owned();
    assert!(output.status.success(), "{what} on {ranks} ranks: {log}");
    log
}
