//! Quasi-static solves on several MPI ranks (features `mpi` and `trilinos`): Trilinos NOX over
//! the owned unknowns, with the ghosts refreshed inside every residual evaluation, gives the
//! one-rank answer on 2 and 3 ranks, with the assembled tangent and Jacobian-free, and so does
//! peridyn's own Newton with distributed Belos solves, quasi-static (`QuasiStatic`) and
//! Newmark-β (`Implicit`); a load step that fails over to `Switch to Verlet` continues on 2
//! ranks bitwise as on one.
#![cfg(all(feature = "mpi", feature = "trilinos"))]

mod implicit_ranks;
mod mpi_support;
mod quasi_static_bar;

use implicit_ranks::{same_answer_on_one_two_and_three_ranks, Backend, NEWMARK, RELATIVE};
use mpi_support::{mpirun, run_on_ranks};
use peridyn::io::exodus::ExodusFile;

/// The shared LPS bar (108 points, two load steps) as a NOXQuasiStatic deck on the Trilinos
/// backend with `solver_keys` and the NOX `Linear Solver` keys `linear`.
fn deck(solver_keys: &str, linear: &str) -> String {
    let solver = format!(
        "    Final Time: 1.0\n    Backend: \"Trilinos\"\n{solver_keys}\n    NOXQuasiStatic:\n      Number of Load Steps: {{steps}}\n      Absolute Tolerance: 1.0e-2\n      Max Solver Iterations: 20\n      Direction:\n        Method: \"Newton\"\n        Newton:\n          Linear Solver:\n{linear}"
    );
    quasi_static_bar::bar_deck(&solver, 0.012, 0.004, 2)
}

#[test]
fn nox_newton_gives_the_one_rank_answer_on_two_and_three_ranks() {
    let text = deck(
        "",
        "            Preconditioner: \"Ifpack\"\n            Tolerance: 1.0e-10",
    );
    same_answer_on_one_two_and_three_ranks(
        "NOX Newton",
        &text,
        RELATIVE,
        "Load step 2,",
        Backend::Trilinos,
    );
}

#[test]
fn jacobian_free_nox_gives_the_one_rank_answer_on_two_and_three_ranks() {
    let text = deck(
        "    Peridigm Preconditioner: \"Block 3x3\"",
        "            Jacobian Operator: \"Matrix-Free\"\n            Preconditioner: \"User Defined\"",
    );
    same_answer_on_one_two_and_three_ranks(
        "NOX JFNK",
        &text,
        RELATIVE,
        "Load step 2,",
        Backend::Trilinos,
    );
}

#[test]
fn quasi_static_newton_with_belos_gives_the_one_rank_answer_on_two_and_three_ranks() {
    // Peridigm's quasi-static measure ‖r‖ + 20·max|r| stops at about 1.1e-2 N here, the
    // round-off of bond forces near 1e10 N; 5e-2 is reached in 2–3 iterations on any rank
    // count, and the comparison's 1 N floor for forces stays above it.
    let solver = "    Final Time: 1.0\n    Backend: \"Trilinos\"\n    Linear Solver: \"CG\"\n    Linear Solver Preconditioner: \"ILU\"\n    Linear Solver Tolerance: 1.0e-12\n    QuasiStatic:\n      Number of Load Steps: {steps}\n      Absolute Tolerance: 5.0e-2\n      Maximum Solver Iterations: 20";
    let text = quasi_static_bar::bar_deck(solver, 0.012, 0.004, 2);
    same_answer_on_one_two_and_three_ranks(
        "QuasiStatic + Belos",
        &text,
        RELATIVE,
        "Load step 2,",
        Backend::Trilinos,
    );
}

#[test]
fn newmark_with_belos_gives_the_one_rank_answer_on_two_and_three_ranks() {
    // Ten Newmark-β steps of 0.2 ms while the right end moves at 5 m/s along x and 2 m/s
    // along y: the pull reaches the far end of the 12 m steel bar (wave speed ≈ 5.2 km/s)
    // within the run, so inertia and stiffness both shape the answer.
    let solver = "    Final Time: 0.002\n    Backend: \"Trilinos\"\n    Linear Solver: \"CG\"\n    Linear Solver Preconditioner: \"ILU\"\n    Linear Solver Tolerance: 1.0e-12\n    Implicit:\n      Fixed dt: 0.0002\n      Absolute Tolerance: 1.0e-10\n      Maximum Solver Iterations: 10";
    let text = quasi_static_bar::bar_deck(solver, 5.0, 2.0, 1);
    same_answer_on_one_two_and_three_ranks(
        "Newmark-β + Belos",
        &text,
        NEWMARK,
        "Time step 10,",
        Backend::Trilinos,
    );
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
