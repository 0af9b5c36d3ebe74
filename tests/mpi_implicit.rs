//! Quasi-static solves on several MPI ranks (features `mpi` and `trilinos`): Trilinos NOX over
//! the owned unknowns, with the ghosts refreshed inside every residual evaluation, gives the
//! one-rank answer on 2 and 3 ranks, with the assembled tangent and Jacobian-free, and so does
//! peridyn's own Newton with distributed Belos solves, quasi-static (`QuasiStatic`) and
//! Newmark-β (`Implicit`); a load step that fails over to `Switch to Verlet` continues on 2
//! ranks bitwise as on one. The ML strategies (NOX JFNK preconditioned by ML on the one-hop
//! operator, and peridyn's Newton with Belos CG + ML on the assembled tangent) reach the
//! one-rank answer and the native direct answer on 1, 2 and 3 ranks; so does `DynamicRelaxation`,
//! which solves no linear system.
#![cfg(all(feature = "mpi", feature = "trilinos"))]

mod implicit_ranks;
mod mpi_support;
mod quasi_static_bar;

use implicit_ranks::{
    same_answer_on_one_two_and_three_ranks, same_answer_on_one_two_and_three_ranks_in, Backend,
    NEWMARK, RELATIVE,
};
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

/// The bar's pull along x (m), as in [`deck`].
const PULL: f64 = 0.012;

/// The final displacements of the bar of [`deck`] by the native sparse direct solver on one
/// process (peridyn's Newton stopped at 1e-3 N): the reference answer.
fn direct_answer() -> Vec<f64> {
    let solver = "    Final Time: 1.0\n    Linear Solver: \"Direct\"\n    QuasiStatic:\n      Number of Load Steps: {steps}\n      Absolute Tolerance: 1.0e-3\n      Maximum Solver Iterations: 20";
    let dir = tempfile::tempdir().unwrap();
    quasi_static_bar::run_deck(
        dir.path(),
        &quasi_static_bar::bar_deck(solver, PULL, 0.004, 2),
    )
    .expect("the direct run succeeds");
    quasi_static_bar::final_displacement(dir.path())
}

/// Runs `text` on 1, 2 and 3 ranks (the one-rank answer on every rank count, as
/// [`same_answer_on_one_two_and_three_ranks`]) and checks that each rank count's final
/// displacements are the native direct answer within 1e-8 relative; returns the directory of
/// the runs (`ranks<N>/` each).
fn direct_answer_on_one_two_and_three_ranks(name: &str, text: &str) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    same_answer_on_one_two_and_three_ranks_in(
        dir.path(),
        name,
        text,
        RELATIVE,
        "Load step 2,",
        Backend::Trilinos,
    );
    let direct = direct_answer();
    let scale = direct.iter().fold(0.0f64, |m, u| m.max(u.abs()));
    // The bar's largest displacement is the pull of its right end.
    assert!((scale - PULL).abs() < 1e-12, "{scale}");
    for ranks in 1..=3 {
        let answer =
            quasi_static_bar::final_displacement(&dir.path().join(format!("ranks{ranks}")));
        assert_eq!(answer.len(), direct.len(), "{name}: {ranks} ranks");
        let difference = answer
            .iter()
            .zip(&direct)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        // Every run stops at a residual of at most 5e-2 N on a stiffness of order 1e11 N/m
        // (bulk modulus 1.3e11 Pa times the 1 m spacing): each answer is within ~1e-12 m of
        // equilibrium, so 1e-8 of the pull (1.2e-10 m) is the bar with a margin and
        // far tighter than a wrong ghost, null space or global id would leave.
        assert!(
            difference <= 1e-8 * scale,
            "{name} on {ranks} ranks differs from the direct answer by {difference:e}"
        );
        eprintln!(
            "{name} on {ranks} ranks: largest difference to the direct answer {difference:e} m"
        );
    }
    dir
}

#[test]
fn jacobian_free_nox_with_ml_gives_the_direct_answer_on_one_two_and_three_ranks() {
    let text = deck(
        "    Peridigm Preconditioner: \"AMG\"",
        "            Jacobian Operator: \"Matrix-Free\"\n            Tolerance: 1.0e-8",
    );
    let dir = direct_answer_on_one_two_and_three_ranks("NOX JFNK + ML", &text);
    for ranks in 1..=3 {
        let report =
            std::fs::read_to_string(dir.path().join(format!("ranks{ranks}/bar_solver.csv")))
                .unwrap();
        let header: Vec<&str> = report.lines().next().unwrap().split(',').collect();
        let levels = header.iter().position(|h| *h == "AMG_Levels").unwrap();
        let first: Vec<&str> = report.lines().nth(1).unwrap().split(',').collect();
        // ML was built on the distributed one-hop operator: 99 free points × 3 = 297 global
        // unknowns, above ML's coarse size of 128 (SetDefaults "SA"), so at least one
        // coarsening on every rank count.
        let levels: f64 = first[levels].parse().unwrap();
        assert!(levels >= 2.0, "{ranks} ranks: {levels} ML levels\n{report}");
    }
}

#[test]
fn newton_with_belos_and_ml_gives_the_direct_answer_on_one_two_and_three_ranks() {
    // As the Belos + ILU test above, with ML smoothed aggregation on the assembled tangent
    // (the rigid-body modes of this rank's free unknowns as its near-null space).
    let solver = "    Final Time: 1.0\n    Backend: \"Trilinos\"\n    Linear Solver: \"CG\"\n    Linear Solver Preconditioner: \"ML\"\n    Linear Solver Tolerance: 1.0e-12\n    QuasiStatic:\n      Number of Load Steps: {steps}\n      Absolute Tolerance: 5.0e-2\n      Maximum Solver Iterations: 20";
    let text = quasi_static_bar::bar_deck(solver, PULL, 0.004, 2);
    direct_answer_on_one_two_and_three_ranks("QuasiStatic + Belos CG + ML", &text);
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

#[test]
fn dynamic_relaxation_gives_the_one_rank_answer_on_two_and_three_ranks() {
    // No linear solver: the relaxation's sums are the only collectives besides the ghosts'
    // refresh. Its tolerance is 0.03 N, just above the round-off floor of this bar's residual
    // (≈ 1.2e-2 N). The ranks' sums differ in their order only, which changes the damping in
    // its last bits, so the runs stop at different iterates within that tolerance: the
    // displacements agree to RELATIVE's 1e-8, the forces to the residual the tolerance
    // leaves, 0.03 N absolute (the reactions are 1e5–1e8 N; measured: 4e-3 N on 3 ranks).
    let solver = "    Final Time: 1.0\n    DynamicRelaxation:\n      Number of Load Steps: {steps}\n      Absolute Tolerance: 0.03";
    let text = quasi_static_bar::bar_deck(solver, 0.012, 0.004, 2);
    let forces_to_the_tolerance = RELATIVE
        .replace(
            "\tForceX relative 1.0E-8 floor 1.0",
            "\tForceX absolute 3.0E-2",
        )
        .replace(
            "\tForceY relative 1.0E-8 floor 1.0",
            "\tForceY absolute 3.0E-2",
        )
        .replace(
            "\tForceZ relative 1.0E-8 floor 1.0",
            "\tForceZ absolute 3.0E-2",
        );
    assert_eq!(
        forces_to_the_tolerance.matches("absolute 3.0E-2").count(),
        3
    );
    same_answer_on_one_two_and_three_ranks(
        "DynamicRelaxation",
        &text,
        &forces_to_the_tolerance,
        "Load step 2,",
        Backend::Trilinos,
    );
}
