//! What the implicit MPI test files share (`mpi_implicit` on Trilinos, `mpi_petsc` on PETSc):
//! the exodiff tolerances of an implicit answer on N ranks against one rank, and the run of a
//! deck on 1, 2 and 3 ranks that compares them.
// Each test crate that includes this module uses only part of it.
#![allow(dead_code)]

use crate::mpi_support::{diff_against_one_rank, run_on_ranks};
use std::path::Path;

/// The backend a test runs on, for the checks only one of them needs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Backend {
    /// Trilinos (NOX, Belos).
    Trilinos,
    /// PETSc (SNES, KSP): the log must name PETSc and carry no PETSc warning.
    Petsc,
}

/// exodiff command file: 1e-8 relative everywhere, the bar for implicit runs
/// ("1, 2, 3 ranks agree to the solver tolerance"; the parity bar of the PETSc issue is 1e-8
/// relative), with floors below which values are round-off: 1e-14 m for displacements (the pull
/// is 0.012 m) and 1 N for forces, far below the reactions (1e5–1e8 N) and above the interior
/// residuals the Newton tolerances leave (1e-2 N for NOX and SNES, 5e-2 N for QuasiStatic,
/// whose size depends on the iterate).
pub const RELATIVE: &str = "DEFAULT TOLERANCE relative 1.0E-8 floor 1.0E-14
COORDINATES absolute 0.0
TIME STEPS relative 1.0E-12 floor 0.0
GLOBAL VARIABLES
NODAL VARIABLES
\tForceX relative 1.0E-8 floor 1.0
\tForceY relative 1.0E-8 floor 1.0
\tForceZ relative 1.0E-8 floor 1.0
ELEMENT VARIABLES
";

/// exodiff command file for the Newmark-β runs: 1e-8 relative on displacements and velocities
/// as in [`RELATIVE`]; forces to 0.01 N absolute. Inside the bar the force is the inertial force
/// ρVa (≈ 600 N), and two converged answers differ there by their Newton residuals: the
/// residual stops near 2e-3 N (the measure 1e-10 over βΔt² = 1e-8), the round-off of terms
/// ρV/(βΔt²)·u ≈ 8e8 N. A wrong ghost or a missed row moves forces by 1e4 N and more.
pub const NEWMARK: &str = "DEFAULT TOLERANCE relative 1.0E-8 floor 1.0E-14
COORDINATES absolute 0.0
TIME STEPS relative 1.0E-12 floor 0.0
GLOBAL VARIABLES
NODAL VARIABLES
\tForceX absolute 1.0E-2
\tForceY absolute 1.0E-2
\tForceZ absolute 1.0E-2
ELEMENT VARIABLES
";

/// Runs `text` on 1, 2 and 3 ranks and compares the results files with the exodiff command
/// file `comp`; `last_step` is the log line of the last step, which rank 0 alone prints.
/// Returns the Newton and linear iterations summed over the run, per rank count.
/// The solver report's steps, times and Newton iterations must agree on every rank count.
pub fn same_answer_on_one_two_and_three_ranks(
    name: &str,
    text: &str,
    comp: &str,
    last_step: &str,
    backend: Backend,
) -> Vec<(f64, f64)> {
    let dir = tempfile::tempdir().unwrap();
    same_answer_on_one_two_and_three_ranks_in(dir.path(), name, text, comp, last_step, backend)
}

/// [`same_answer_on_one_two_and_three_ranks`] with the runs kept in `dir` (the results of N
/// ranks in `dir/ranks<N>/bar.e`), for callers that check the answers further.
pub fn same_answer_on_one_two_and_three_ranks_in(
    dir: &Path,
    name: &str,
    text: &str,
    comp: &str,
    last_step: &str,
    backend: Backend,
) -> Vec<(f64, f64)> {
    std::fs::write(dir.join("bar.yaml"), text).unwrap();
    std::fs::write(dir.join("relative.comp"), comp).unwrap();
    for ranks in 1..=3 {
        let log = run_on_ranks(dir, ranks, "bar.yaml", name);
        // Only rank 0 reports.
        assert_eq!(log.matches("done:").count(), 1, "{log}");
        assert_eq!(log.matches(last_step).count(), 1, "{log}");
        if backend == Backend::Petsc {
            assert!(log.contains("PETSc"), "{name}: PETSc did not solve:\n{log}");
            // PETSc's warnings (options left unused) would mean the deck's options missed.
            assert!(!log.contains("Warning"), "{name}: {log}");
        }
    }
    let report = |ranks: usize| -> (Vec<String>, Vec<Vec<f64>>) {
        let path = dir.join(format!("ranks{ranks}/bar_solver.csv"));
        let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path:?}: {e}"));
        let header = text
            .lines()
            .next()
            .unwrap()
            .split(',')
            .map(String::from)
            .collect();
        let rows = text
            .lines()
            .skip(1)
            .map(|line| line.split(',').map(|v| v.parse().unwrap()).collect())
            .collect();
        (header, rows)
    };
    let (header, one) = report(1);
    let column = |name: &str| header.iter().position(|h| h == name).unwrap();
    let (newton, linear) = (column("Newton_Iterations"), column("Linear_Iterations"));
    assert!(!one.is_empty());
    // Every step converged below the decks' iteration limits (10 and 20).
    assert!(
        one.iter().all(|row| row[newton] < 10.0),
        "{name}: a step ran to its iteration limit on one rank: {one:?}"
    );
    let mut totals = vec![];
    for ranks in 1..=3 {
        let (_, many) = report(ranks);
        assert_eq!(
            many.len(),
            one.len(),
            "{name}: solver report rows on {ranks} ranks"
        );
        // The same steps at the same times with the same Newton iterations; the first residual
        // is a global norm of the input, so only its summation order depends on the ranks.
        // Linear iterations follow from each rank preconditioning its own rows.
        for (a, b) in many.iter().zip(&one) {
            for c in [0, 1, newton] {
                assert_eq!(a[c], b[c], "{name}: {ranks} ranks, column {}", header[c]);
            }
        }
        let (first_many, first_one) = (many[0][5], one[0][5]);
        assert!(
            (first_many - first_one).abs() <= 1e-12 * first_one.abs(),
            "{name}: first residual {first_many} on {ranks} ranks, {first_one} on one"
        );
        totals.push((
            many.iter().map(|r| r[newton]).sum(),
            many.iter().map(|r| r[linear]).sum(),
        ));
        if ranks > 1 {
            let output = diff_against_one_rank(dir, ranks, "bar.e", "relative.comp");
            assert!(
                output.status.success(),
                "{name}: {ranks} ranks differ from one:\n{}{}",
                String::from_utf8_lossy(&output.stdout),
                String::from_utf8_lossy(&output.stderr)
            );
        }
    }
    eprintln!("{name}: (Newton, linear) iterations on 1, 2, 3 ranks: {totals:?}");
    totals
}
