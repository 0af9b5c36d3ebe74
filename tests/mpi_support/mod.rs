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
