//! Quasi-static solves on several MPI ranks (features `mpi` and `trilinos`): Trilinos NOX over
//! the owned unknowns, with the ghosts refreshed inside every residual evaluation, gives the
//! one-rank answer on 2 and 3 ranks, with the assembled tangent and Jacobian-free, and so does
//! peridyn's own Newton with distributed Belos solves, quasi-static (`QuasiStatic`) and
//! Newmark-β (`Implicit`); a load step that fails over to `Switch to Verlet` continues on 2
//! ranks bitwise as on one.
#![cfg(all(feature = "mpi", feature = "trilinos"))]

mod mpi_support;
mod quasi_static_bar;

use mpi_support::{diff_against_one_rank, mpirun, run_on_ranks};
use peridyn::io::exodus::ExodusFile;

/// exodiff command file: 1e-8 relative everywhere (the bar for implicit runs), with
/// floors below which values are round-off: 1e-14 m for displacements (the pull is 0.012 m)
/// and 1 N for forces, far below the reactions (1e5–1e8 N) and above the interior residuals
/// the Newton tolerances (0.01 N for NOX, 0.05 N for QuasiStatic) leave, whose size depends on
/// the iterate.
const RELATIVE: &str = "DEFAULT TOLERANCE relative 1.0E-8 floor 1.0E-14
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
/// as in [`RELATIVE`]; forces to 0.01 N absolute. Inside the bar the force is no residual here
/// but the inertial force ρVa (≈ 600 N), and two converged answers differ there by their Newton
/// residuals: the residual stops at ≈ 2e-3 N (the log's measure 2e-11 over βΔt² = 1e-8), the
/// round-off of terms ρV/(βΔt²)·u ≈ 8e8 N, so no solver gets these forces to 1e-8 relative.
/// A wrong ghost or a missed row moves forces by 1e4 N and more.
const NEWMARK: &str = "DEFAULT TOLERANCE relative 1.0E-8 floor 1.0E-14
COORDINATES absolute 0.0
TIME STEPS relative 1.0E-12 floor 0.0
GLOBAL VARIABLES
NODAL VARIABLES
\tForceX absolute 1.0E-2
\tForceY absolute 1.0E-2
\tForceZ absolute 1.0E-2
ELEMENT VARIABLES
";

/// The shared LPS bar (108 points, two load steps) as a NOXQuasiStatic deck on the Trilinos
/// backend with `solver_keys` and the NOX `Linear Solver` keys `linear`.
fn deck(solver_keys: &str, linear: &str) -> String {
    let solver = format!(
        "    Final Time: 1.0\n    Backend: \"Trilinos\"\n{solver_keys}\n    NOXQuasiStatic:\n      Number of Load Steps: {{steps}}\n      Absolute Tolerance: 1.0e-2\n      Max Solver Iterations: 20\n      Direction:\n        Method: \"Newton\"\n        Newton:\n          Linear Solver:\n{linear}"
    );
    quasi_static_bar::bar_deck(&solver, 0.012, 0.004, 2)
}

/// Runs `text` on 1, 2 and 3 ranks and compares the results files with the exodiff command
/// file `comp`; `last_step` is the log line of the last step, which rank 0 alone prints.
fn same_answer_on_one_two_and_three_ranks(name: &str, text: &str, comp: &str, last_step: &str) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("bar.yaml"), text).unwrap();
    std::fs::write(dir.path().join("relative.comp"), comp).unwrap();
    for ranks in 1..=3 {
        let log = run_on_ranks(dir.path(), ranks, "bar.yaml", name);
        // Only rank 0 reports.
        assert_eq!(log.matches("done:").count(), 1, "{log}");
        assert_eq!(log.matches(last_step).count(), 1, "{log}");
    }
    // The per-step solver report is written on every rank count, rank 0 writing for all: the
    // same steps and Newton iterations, and the same first residual (a global norm of the
    // input, so only its summation order depends on the ranks). Later residuals start from
    // answers that agree only to the solver tolerance, and the linear iterations and residual
    // evaluations follow from each rank preconditioning its own rows.
    let report = |ranks: usize| -> Vec<Vec<f64>> {
        let path = dir.path().join(format!("ranks{ranks}/bar_solver.csv"));
        let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path:?}: {e}"));
        text.lines()
            .skip(1)
            .map(|line| line.split(',').map(|v| v.parse().unwrap()).collect())
            .collect()
    };
    let one = report(1);
    assert!(!one.is_empty());
    // Every step converged: fewer Newton iterations than the decks' limits (10 and 20), not
    // accepted at the limit.
    assert!(
        one.iter().all(|row| row[2] < 10.0),
        "{name}: a step ran to its iteration limit on one rank: {one:?}"
    );
    for ranks in 2..=3 {
        let many = report(ranks);
        assert_eq!(
            many.len(),
            one.len(),
            "{name}: solver report rows on {ranks} ranks"
        );
        for (a, b) in many.iter().zip(&one) {
            // Time, Step, Newton_Iterations.
            for column in [0, 1, 2] {
                assert_eq!(
                    a[column], b[column],
                    "{name}: {ranks} ranks, column {column}"
                );
            }
        }
        let (first_many, first_one) = (many[0][5], one[0][5]);
        assert!(
            (first_many - first_one).abs() <= 1e-12 * first_one.abs(),
            "{name}: first residual {first_many} on {ranks} ranks, {first_one} on one"
        );
    }
    for ranks in 2..=3 {
        let output = diff_against_one_rank(dir.path(), ranks, "bar.e", "relative.comp");
        assert!(
            output.status.success(),
            "{name}: {ranks} ranks differ from one:\n{}{}",
            String::from_utf8_lossy(&output.stdout),
            String::from_utf8_lossy(&output.stderr)
        );
    }
}

#[test]
fn nox_newton_gives_the_one_rank_answer_on_two_and_three_ranks() {
    let text = deck(
        "",
        "            Preconditioner: \"Ifpack\"\n            Tolerance: 1.0e-10",
    );
    same_answer_on_one_two_and_three_ranks("NOX Newton", &text, RELATIVE, "Load step 2,");
}

#[test]
fn jacobian_free_nox_gives_the_one_rank_answer_on_two_and_three_ranks() {
    let text = deck(
        "    Peridigm Preconditioner: \"Block 3x3\"",
        "            Jacobian Operator: \"Matrix-Free\"\n            Preconditioner: \"User Defined\"",
    );
    same_answer_on_one_two_and_three_ranks("NOX JFNK", &text, RELATIVE, "Load step 2,");
}

#[test]
fn quasi_static_newton_with_belos_gives_the_one_rank_answer_on_two_and_three_ranks() {
    // Peridigm's quasi-static measure ‖r‖ + 20·max|r| stops at about 1.1e-2 N here, the
    // round-off of bond forces near 1e10 N; 5e-2 is reached in 2–3 iterations on any rank
    // count, and the comparison's 1 N floor for forces stays above it.
    let solver = "    Final Time: 1.0\n    Backend: \"Trilinos\"\n    Linear Solver: \"CG\"\n    Linear Solver Preconditioner: \"ILU\"\n    Linear Solver Tolerance: 1.0e-12\n    QuasiStatic:\n      Number of Load Steps: {steps}\n      Absolute Tolerance: 5.0e-2\n      Maximum Solver Iterations: 20";
    let text = quasi_static_bar::bar_deck(solver, 0.012, 0.004, 2);
    same_answer_on_one_two_and_three_ranks("QuasiStatic + Belos", &text, RELATIVE, "Load step 2,");
}

#[test]
fn newmark_with_belos_gives_the_one_rank_answer_on_two_and_three_ranks() {
    // Ten Newmark-β steps of 0.2 ms while the right end moves at 5 m/s along x and 2 m/s
    // along y: the pull reaches the far end of the 12 m steel bar (wave speed ≈ 5.2 km/s)
    // within the run, so inertia and stiffness both shape the answer.
    let solver = "    Final Time: 0.002\n    Backend: \"Trilinos\"\n    Linear Solver: \"CG\"\n    Linear Solver Preconditioner: \"ILU\"\n    Linear Solver Tolerance: 1.0e-12\n    Implicit:\n      Fixed dt: 0.0002\n      Absolute Tolerance: 1.0e-10\n      Maximum Solver Iterations: 10";
    let text = quasi_static_bar::bar_deck(solver, 5.0, 2.0, 1);
    same_answer_on_one_two_and_three_ranks("Newmark-β + Belos", &text, NEWMARK, "Time step 10,");
}

#[test]
fn a_nan_condition_on_one_rank_stops_every_rank_with_its_exit_code() {
    let dir = tempfile::tempdir().unwrap();
    // √(0.75 − t) is NaN at t = 1: the second load step's prescribed shear, on the right end,
    // which one rank owns; the others must stop too, at the same step, with that rank's exit
    // code 2 (invalid input: the condition).
    let text = deck(
        "    Peridigm Preconditioner: \"Block 3x3\"",
        "            Jacobian Operator: \"Matrix-Free\"\n            Preconditioner: \"User Defined\"",
    )
    .replace("Value: \"0.004*t\"", "Value: \"0.004*t*sqrt(0.75-t)\"");
    assert!(text.contains("sqrt(0.75-t)"));
    std::fs::write(dir.path().join("nan.yaml"), text).unwrap();
    let output = mpirun(dir.path(), 2, &["run", "nan.yaml", "--output-dir", "out"]);
    let log = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{log}");
    assert!(
        log.contains("boundary condition \"Pull Y\" at t = 1"),
        "{log}"
    );
}

#[test]
fn switch_to_verlet_gives_the_one_rank_answer_on_two_ranks() {
    // One load step that cannot converge (one Newton iteration towards 1e-12 N, below the
    // round-off of the bond forces) and may not be cut: every rank goes back to t = 0 and
    // Verlet carries the pull to the final time, through the same driver on any rank count.
    let solver = "    Final Time: 0.002\n    Backend: \"Trilinos\"\n    Linear Solver: \"CG\"\n    Linear Solver Preconditioner: \"ILU\"\n    Linear Solver Tolerance: 1.0e-12\n    QuasiStatic:\n      Number of Load Steps: {steps}\n      Absolute Tolerance: 1.0e-12\n      Maximum Solver Iterations: 1\n      Adaptive Load-Stepping:\n        Maximum load step reductions in one step: 0\n        Switch to Verlet:\n          Safety Factor: 0.5";
    let text = quasi_static_bar::bar_deck(solver, 3.6, 2.0, 1);
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("bar.yaml"), text).unwrap();
    for ranks in 1..=2 {
        let log = run_on_ranks(dir.path(), ranks, "bar.yaml", "switch to Verlet");
        assert_eq!(log.matches("switching to Verlet").count(), 1, "{log}");
    }
    let one = ExodusFile::open(&dir.path().join("ranks1/bar.e")).unwrap();
    let two = ExodusFile::open(&dir.path().join("ranks2/bar.e")).unwrap();
    // The initial frame, then one frame per Verlet step (Δt ≈ 5e-5 s over 2 ms).
    assert!(one.times.len() > 10, "{:?}", one.times);
    assert_eq!(one.times, two.times);
    assert_eq!(one.nodal_variable_names, two.nodal_variable_names);
    for step in 0..one.times.len() {
        assert_eq!(
            one.global_values(step).unwrap(),
            two.global_values(step).unwrap()
        );
        for v in 0..one.nodal_variable_names.len() {
            assert_eq!(
                one.nodal_values(step, v).unwrap(),
                two.nodal_values(step, v).unwrap(),
                "{} at frame {step}",
                one.nodal_variable_names[v]
            );
        }
    }
}
