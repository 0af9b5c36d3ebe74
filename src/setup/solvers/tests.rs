//! The deck's solver keys through the factory: the integrators they build, and the backend
//! choices ([`crate::backend::factory`]) those make.

use super::*;
use crate::backend::factory::{
    automatic_jacobian_free, jacobian_free_preconditioner, uses_multigrid,
};
use crate::solver::integrator::TimeStep;

/// The first solver list of a three-point bar deck whose `Solver` list holds the lines
/// `solver_keys` besides `Final Time`.
fn first_list(solver_keys: &str) -> SolverList {
    let text =
        crate::io::deck::three_point_bar_text(&format!("    Final Time: 1.0\n{solver_keys}"));
    let deck = deck::parse_str(
        &text,
        deck::DeckFormat::Yaml,
        std::path::Path::new("automatic.yaml"),
    )
    .unwrap();
    solver_lists(&deck).into_iter().next().unwrap()
}

/// How the first (implicit) list of [`first_list`] solves.
fn solve(solver_keys: &str) -> ImplicitSolve {
    first_list(solver_keys)
        .integrator
        .solve()
        .expect("an implicit list")
        .clone()
}

/// Points whose unknowns are just above and at `Automatic`'s direct-solve limit.
const LARGE: usize = LinearMethod::AUTOMATIC_DIRECT_LIMIT / 3 + 1;
const AT_LIMIT: usize = LinearMethod::AUTOMATIC_DIRECT_LIMIT / 3;

#[test]
fn each_integrator_sublist_builds_its_integrator() {
    let verlet = first_list("    Verlet:\n      Safety Factor: 0.5\n      Fixed dt: 1.0e-3");
    assert_eq!(verlet.integrator.name(), "Verlet");
    assert!(!verlet.integrator.is_implicit());
    assert_eq!(
        verlet.integrator.time_step(),
        Some(TimeStep::Stable {
            fixed: Some(1.0e-3),
            safety_factor: 0.5
        })
    );
    // 1 s at 0.5 × 1 ms.
    assert_eq!(verlet.integrator.planned_steps(1.0, None), Some(2000));
    let quasi_static = first_list("    QuasiStatic:\n      Number of Load Steps: 4");
    assert_eq!(quasi_static.integrator.name(), "QuasiStatic");
    assert!(quasi_static.integrator.is_implicit());
    assert_eq!(quasi_static.integrator.time_step(), None);
    assert_eq!(quasi_static.integrator.planned_steps(1.0, None), Some(4));
    let newmark = first_list("    Implicit:\n      Fixed dt: 0.25");
    assert_eq!(newmark.integrator.name(), "Implicit");
    assert_eq!(newmark.integrator.time_step(), Some(TimeStep::Fixed(0.25)));
    assert_eq!(newmark.integrator.planned_steps(1.0, None), Some(4));
    let diffusion = first_list("    ImplicitDiffusion:\n      Number of Load Steps: 2");
    assert_eq!(
        diffusion.integrator.unavailable().as_deref(),
        Some("solver ImplicitDiffusion")
    );
    assert!(diffusion.integrator.is_implicit());
    assert!(diffusion.integrator.check_ranks("Solver", 2).is_err());
    assert!(verlet.integrator.check_ranks("Solver", 2).is_ok());
}

#[test]
fn the_list_keys_reach_the_typed_settings() {
    let list = first_list(
        "    Initial Time: 0.25\n    Disable Heuristics: true\n    Verbose: true\n    Initialize Predictor From Previous Solver: true\n    QuasiStatic:\n      Number of Load Steps: 2",
    );
    assert_eq!(
        list.settings,
        ListSettings {
            name: "Solver".into(),
            initial_time: 0.25,
            final_time: 1.0,
            verbose: true,
            heuristics: false,
            // The first list has no list before it to predict from.
            predict_first_step: false,
        }
    );
    let solve = list.integrator.solve().unwrap();
    assert!(!solve.line_search);
    assert!(solve.verbose);
    assert_eq!(solve.integrator, "QuasiStatic");
}

#[test]
fn switch_to_verlet_is_a_hand_off_to_a_verlet_integrator() {
    let list = first_list(
        "    QuasiStatic:\n      Number of Load Steps: 2\n      Adaptive Load-Stepping:\n        Switch to Verlet:\n          Safety Factor: 0.5",
    );
    let text = format!("{:?}", list.integrator);
    assert!(
        text.contains("label: \"Switch to Verlet\"")
            && text.contains("Verlet { fixed_dt: None, safety_factor: 0.5 }"),
        "{text}"
    );
}

#[test]
fn automatic_makes_a_large_quasi_static_deck_jacobian_free_with_amg() {
    let quasi_static = solve("    QuasiStatic:\n      Number of Load Steps: 2");
    assert!(automatic_jacobian_free(&quasi_static, LARGE));
    assert_eq!(
        jacobian_free_preconditioner(&quasi_static, LARGE),
        Some(LinearPreconditioner::Amg)
    );
    assert!(uses_multigrid(&quasi_static, LARGE));
    // At the limit a factorization still runs, with the assembled tangent.
    assert!(!automatic_jacobian_free(&quasi_static, AT_LIMIT));
    assert_eq!(jacobian_free_preconditioner(&quasi_static, AT_LIMIT), None);
    // A native NOXQuasiStatic list that names no Jacobian operator is treated alike.
    let nox = solve(
        "    Backend: \"Native\"\n    NOXQuasiStatic:\n      Number of Load Steps: 2\n      Direction: {Method: \"Newton\"}",
    );
    assert!(automatic_jacobian_free(&nox, LARGE));
}

#[test]
fn a_deck_that_names_its_solver_keeps_the_assembled_tangent() {
    let named = [
        "    Linear Solver: \"CG\"\n    QuasiStatic:\n      Number of Load Steps: 2",
        "    Linear Solver Preconditioner: \"Block 3x3\"\n    QuasiStatic:\n      Number of Load Steps: 2",
        "    Linear Solver Preconditioner: \"AMG\"\n    QuasiStatic:\n      Number of Load Steps: 2",
        "    Backend: \"Native\"\n    NOXQuasiStatic:\n      Number of Load Steps: 2\n      Direction: {Method: \"Newton\", Newton: {Linear Solver: {Jacobian Operator: \"Full Tangent\"}}}",
        // Newmark-β dynamics is not quasi-static: its mass term keeps block 3×3 CG cheap.
        "    Implicit:\n      Fixed dt: 0.1",
    ];
    for keys in named {
        let list = solve(keys);
        assert!(!automatic_jacobian_free(&list, LARGE), "{keys}");
    }
    // The AMG the deck names runs on the assembled tangent (CG + AMG), not Jacobian-free.
    let assembled_amg = solve(named[2]);
    assert_eq!(jacobian_free_preconditioner(&assembled_amg, LARGE), None);
    assert!(uses_multigrid(&assembled_amg, LARGE));
    // An explicit Jacobian-free request keeps its own preconditioner.
    let block = solve(
        "    Backend: \"Native\"\n    Peridigm Preconditioner: \"Block 3x3\"\n    NOXQuasiStatic:\n      Number of Load Steps: 2\n      Direction: {Method: \"Newton\", Newton: {Linear Solver: {Jacobian Operator: \"Matrix-Free\"}}}",
    );
    assert!(!automatic_jacobian_free(&block, LARGE));
    assert_eq!(
        jacobian_free_preconditioner(&block, LARGE),
        Some(LinearPreconditioner::Block3x3)
    );
}
