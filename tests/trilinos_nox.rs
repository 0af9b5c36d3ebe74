//! NOX through the Trilinos bridge (feature `trilinos`): known roots of a small system, the
//! quasi-static bar solved five ways to the same displacements, and callback failures that
//! end as clean errors.
#![cfg(feature = "trilinos")]

mod quasi_static_bar;

use peridyn::backend::parameters::ParameterValue;
use peridyn::backend::trilinos::nox::{
    self, NonlinearCallbacks, NoxLayout, Pattern, PreconditionerMatrix,
};
use peridyn::backend::SolveError;
use peridyn::io::exodus::ExodusFile;
use quasi_static_bar::{final_displacement, run_deck, solver_report};

/// F(x) = (x₀³ + x₀ − 2, 2x₁ + x₀ − 5): the unique root is (1, 2) (x₀³ + x₀ = 2 holds at
/// x₀ = 1 only, as the left side increases monotonically; then x₁ = (5 − 1)/2).
struct Cubic {
    evaluations: usize,
    fail_at: Option<usize>,
    iterations_seen: usize,
}

impl Cubic {
    fn new(fail_at: Option<usize>) -> Self {
        Self {
            evaluations: 0,
            fail_at,
            iterations_seen: 0,
        }
    }
}

impl NonlinearCallbacks for Cubic {
    fn residual(&mut self, x: &[f64], f: &mut [f64], _probe: bool) -> Result<(), SolveError> {
        self.evaluations += 1;
        if self.fail_at == Some(self.evaluations) {
            return Err(SolveError::NonFinite {
                what: "the test residual".into(),
            });
        }
        f[0] = x[0].powi(3) + x[0] - 2.0;
        f[1] = 2.0 * x[1] + x[0] - 5.0;
        Ok(())
    }

    fn jacobian(&mut self, x: &[f64], values: &mut [f64]) -> Result<bool, SolveError> {
        // Rows in the order of `full_pattern`: (0,0), (0,1), (1,0), (1,1).
        values.copy_from_slice(&[3.0 * x[0] * x[0] + 1.0, 0.0, 1.0, 2.0]);
        Ok(true)
    }

    fn preconditioner(&mut self, x: &[f64], values: &mut [f64]) -> Result<bool, SolveError> {
        // The inverted diagonal of the Jacobian.
        values.copy_from_slice(&[1.0 / (3.0 * x[0] * x[0] + 1.0), 0.5]);
        Ok(true)
    }

    fn iteration_done(&mut self, iteration: usize, _residual_norm: f64) {
        self.iterations_seen = iteration;
    }
}

fn full_pattern() -> Pattern {
    Pattern {
        offsets: vec![0, 2, 4],
        columns: vec![0, 1, 0, 1],
    }
}

fn newton_parameters(linear: Vec<(String, ParameterValue)>) -> Vec<(String, ParameterValue)> {
    let list = |entries: Vec<(String, ParameterValue)>| ParameterValue::List(entries);
    vec![
        (
            "Direction".into(),
            list(vec![
                ("Method".into(), ParameterValue::String("Newton".into())),
                (
                    "Newton".into(),
                    list(vec![("Linear Solver".into(), list(linear))]),
                ),
            ]),
        ),
        (
            "Printing".into(),
            list(vec![("Output Information".into(), ParameterValue::Int(0))]),
        ),
    ]
}

fn layout(jacobian: Option<Pattern>, preconditioner: Option<PreconditionerMatrix>) -> NoxLayout {
    NoxLayout {
        linear_solver_path: ["Direction", "Newton", "Linear Solver"]
            .map(String::from)
            .to_vec(),
        jacobian,
        preconditioner,
        tolerance: 1e-12,
        max_iterations: 30,
        global_rows: None,
    }
}

#[test]
fn nox_newton_finds_the_root_of_a_small_system() {
    let mut problem = Cubic::new(None);
    let mut x = vec![3.0, 0.0];
    let report = nox::solve(
        &mut problem,
        &layout(Some(full_pattern()), None),
        &newton_parameters(Vec::new()),
        &mut x,
    )
    .unwrap();
    assert!(report.converged, "{report:?}");
    // The root (1, 2) of the docs of `Cubic`; NOX stops at ‖F‖ ≤ 1e-12 with a Jacobian of
    // norm ~4, so x is within ~1e-12 of it.
    assert!(
        (x[0] - 1.0).abs() < 1e-10 && (x[1] - 2.0).abs() < 1e-10,
        "{x:?}"
    );
    assert!(report.residual_norm <= 1e-12);
    assert_eq!(problem.iterations_seen, report.iterations);
}

#[test]
fn jacobian_free_nox_with_an_inverse_preconditioner_finds_the_same_root() {
    let mut problem = Cubic::new(None);
    let mut x = vec![3.0, 0.0];
    let linear = vec![(
        "Preconditioner".to_string(),
        ParameterValue::String("User Defined".into()),
    )];
    let diagonal = PreconditionerMatrix {
        pattern: Pattern {
            offsets: vec![0, 1, 2],
            columns: vec![0, 1],
        },
        is_inverse: true,
        multigrid: None,
    };
    let report = nox::solve(
        &mut problem,
        &layout(None, Some(diagonal)),
        &newton_parameters(linear),
        &mut x,
    )
    .unwrap();
    assert!(report.converged, "{report:?}");
    // As above; the directional derivatives are finite differences, but Newton converges on
    // F itself, so the root is as accurate.
    assert!(
        (x[0] - 1.0).abs() < 1e-10 && (x[1] - 2.0).abs() < 1e-10,
        "{x:?}"
    );
    assert!(report.linear_iterations >= report.iterations - 1);
}

#[test]
fn a_failing_residual_callback_is_the_error_nox_returns() {
    // The third evaluation fails: after NOX's first F, inside the first Newton step.
    let mut problem = Cubic::new(Some(3));
    let mut x = vec![3.0, 0.0];
    let error = nox::solve(
        &mut problem,
        &layout(Some(full_pattern()), None),
        &newton_parameters(Vec::new()),
        &mut x,
    )
    .expect_err("the callback failed");
    assert_eq!(
        error,
        SolveError::NonFinite {
            what: "the test residual".into()
        }
    );
}

#[test]
fn a_pattern_that_does_not_fit_the_unknowns_is_refused_before_nox_starts() {
    let mut problem = Cubic::new(None);
    let mut x = vec![3.0, 0.0, 0.0];
    let error = nox::solve(
        &mut problem,
        &layout(Some(full_pattern()), None),
        &newton_parameters(Vec::new()),
        &mut x,
    )
    .expect_err("three unknowns, a two-row pattern");
    assert!(error.to_string().contains("3 unknowns"), "{error}");
    assert_eq!(problem.evaluations, 0);
}

const PULL: f64 = 0.012;
const SHEAR: f64 = 0.004;

/// The shared bar with a `Solver` list made of `solver_keys` and the integrator list
/// `integrator`.
fn bar(solver_keys: &str, integrator: &str) -> String {
    let solver = format!("    Final Time: 1.0\n{solver_keys}\n{integrator}");
    quasi_static_bar::bar_deck(&solver, PULL, SHEAR, 2)
}

fn quasi_static(tolerance_keys: &str) -> String {
    format!(
        "    QuasiStatic:\n      Number of Load Steps: {{steps}}\n      Absolute Tolerance: 1.0e-3\n      Maximum Solver Iterations: 30{tolerance_keys}"
    )
}

fn nox_quasi_static(linear_solver: &str) -> String {
    format!(
        "    NOXQuasiStatic:\n      Number of Load Steps: {{steps}}\n      Absolute Tolerance: 1.0e-3\n      Max Solver Iterations: 30\n      Printing:\n        Output Information: 0\n      Direction:\n        Method: \"Newton\"\n        Newton:\n          Linear Solver:\n{linear_solver}\n      Line Search:\n        Method: \"Polynomial\""
    )
}

#[test]
fn five_strategies_give_the_same_quasi_static_bar() {
    let strategies = [
        (
            "native direct",
            bar("    Linear Solver: \"Direct\"", &quasi_static("")),
        ),
        (
            "native CG + block 3x3",
            bar(
                "    Linear Solver: \"CG\"\n    Linear Solver Tolerance: 1.0e-12",
                &quasi_static(""),
            ),
        ),
        (
            "Belos CG + ML",
            bar(
                "    Backend: \"Trilinos\"\n    Linear Solver: \"CG\"\n    Linear Solver Preconditioner: \"ML\"\n    Linear Solver Tolerance: 1.0e-12",
                &quasi_static(""),
            ),
        ),
        (
            "NOX Newton (assembled, Ifpack)",
            bar(
                "    Backend: \"Trilinos\"",
                &nox_quasi_static(
                    "            Preconditioner: \"Ifpack\"\n            Tolerance: 1.0e-12",
                ),
            ),
        ),
        (
            "NOX JFNK + block 3x3",
            bar(
                "    Backend: \"Trilinos\"\n    Peridigm Preconditioner: \"Block 3x3\"",
                &nox_quasi_static(
                    "            Jacobian Operator: \"Matrix-Free\"\n            Preconditioner: \"User Defined\"\n            Tolerance: 1.0e-8",
                ),
            ),
        ),
    ];
    let mut answers = Vec::new();
    for (name, deck) in &strategies {
        let dir = tempfile::tempdir().unwrap();
        let summary =
            run_deck(dir.path(), deck).unwrap_or_else(|e| panic!("{name}: the run failed: {e}"));
        assert_eq!(summary.steps, 2, "{name}");
        answers.push((name, final_displacement(dir.path())));
    }
    let (_, reference) = &answers[0];
    let scale = reference.iter().fold(0.0f64, |m, u| m.max(u.abs()));
    // The bar's largest displacement is the 0.012 pull.
    assert!((scale - PULL).abs() < 1e-12, "{scale}");
    for (name, answer) in &answers[1..] {
        let difference = reference
            .iter()
            .zip(answer)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        // Every strategy stops at a residual of 1e-3 N on a stiffness of order 1e11 N/m
        // (the bar's bulk modulus 1.3e11 Pa times its 1 m spacing), so each answer is within
        // ~1e-14 m of equilibrium: 1e-8 of the pull is far looser than that and far tighter
        // than any wrong answer.
        assert!(
            difference <= 1e-8 * scale,
            "{name} differs from the native direct solve by {difference:e}"
        );
    }
}

#[test]
fn a_nan_condition_in_a_nox_solve_ends_the_run_with_exit_code_2() {
    let dir = tempfile::tempdir().unwrap();
    // The shear √(0.75 − t) is NaN at t = 1 (the second load step): the condition is named
    // before NOX sees a NaN position (a NaN residual inside NOX is the `Cubic` test above).
    let deck = bar(
        "    Backend: \"Trilinos\"\n    Peridigm Preconditioner: \"Block 3x3\"",
        &nox_quasi_static(
            "            Jacobian Operator: \"Matrix-Free\"\n            Preconditioner: \"User Defined\"",
        ),
    )
    .replace("Value: \"0.004*t\"", "Value: \"0.004*t*sqrt(0.75-t)\"");
    assert!(deck.contains("sqrt(0.75-t)"), "the shear was replaced");
    let path = dir.path().join("nan.yaml");
    std::fs::write(&path, deck).unwrap();
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_peridyn"))
        .arg("run")
        .arg(&path)
        .arg("--output-dir")
        .arg(dir.path())
        .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        .output()
        .unwrap();
    let log = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{log}");
    assert!(
        log.contains("boundary condition \"Pull Y\" at t = 1") && log.contains("sqrt(0.75-t)"),
        "{log}"
    );
    // The first load step was written and the file is still readable.
    let file = ExodusFile::open(&dir.path().join("bar.e")).unwrap();
    assert_eq!(file.times.len(), 2, "the initial frame and load step 1");
}

#[test]
fn nox_jfnk_with_ml_on_the_one_hop_operator_agrees_with_the_native_jfnk_and_amg() {
    // Absolute Tolerance 1 N: a Jacobian-free solve's finite-difference directional
    // derivatives carry ~1e-8 relative noise, so on residuals that start near 4e9 N it cannot
    // reach the 1e-3 N of the assembled strategies above (it stalls just above it).
    let jfnk_amg = |backend: &str| {
        bar(
            &format!("    Backend: \"{backend}\"\n    Peridigm Preconditioner: \"AMG\""),
            &nox_quasi_static(
                "            Jacobian Operator: \"Matrix-Free\"\n            Tolerance: 1.0e-8",
            )
            .replace("Absolute Tolerance: 1.0e-3", "Absolute Tolerance: 1.0"),
        )
    };
    let mut answers = Vec::new();
    let mut reports = Vec::new();
    for backend in ["Native", "Trilinos"] {
        let dir = tempfile::tempdir().unwrap();
        let summary = run_deck(dir.path(), &jfnk_amg(backend))
            .unwrap_or_else(|e| panic!("{backend} JFNK + AMG: {e}"));
        assert_eq!(summary.steps, 2, "{backend}");
        answers.push(final_displacement(dir.path()));
        reports.push(solver_report(dir.path(), "bar"));
    }
    let scale = answers[0].iter().fold(0.0f64, |m, u| m.max(u.abs()));
    assert!((scale - PULL).abs() < 1e-12, "{scale}");
    let difference = answers[0]
        .iter()
        .zip(&answers[1])
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    // Both stop at ‖F‖ ≤ 1 N on a stiffness of order 1e11 N/m (see the test above): each
    // answer is within ~1e-11 m of equilibrium, so 1e-8 of the 0.012 m pull (1.2e-10 m) is the
    // solver tolerance with a margin and far tighter than any wrong answer.
    assert!(
        difference <= 1e-8 * scale,
        "NOX JFNK + ML differs from native JFNK + AMG by {difference:e}"
    );
    let nox = &reports[1];
    assert_eq!(nox.len(), 2, "{nox:?}");
    eprintln!("NOX JFNK + ML solver report: {nox:?}");
    // No damage model, so no bond breaks and no held points: ML is built at the first linear
    // solve of the run and kept by every later Newton iteration and load step (the native
    // multigrid's rule); the second step reports the hierarchy it reused.
    assert!(nox[0]["Newton_Iterations"] >= 2.0, "{nox:?}");
    assert_eq!(nox[0]["Preconditioner_Setups"], 1.0, "{nox:?}");
    assert!(nox[0]["Preconditioner_Setup_Seconds"] > 0.0, "{nox:?}");
    assert_eq!(nox[1]["Preconditioner_Setups"], 0.0, "{nox:?}");
    assert_eq!(nox[1]["Preconditioner_Setup_Seconds"], 0.0, "{nox:?}");
    for row in nox {
        // Converged well before Max Solver Iterations (30).
        assert!(row["Final_Residual"] <= 1.0, "{row:?}");
        assert!(row["Newton_Iterations"] < 30.0, "{row:?}");
        // 99 free points × 3 = 297 unknowns, above ML's coarse size of 128 (SetDefaults
        // "SA"): at least one coarsening, and coarse operators add to the complexity.
        assert!(row["AMG_Levels"] >= 2.0, "{row:?}");
        assert!(row["AMG_Operator_Complexity"] > 1.0, "{row:?}");
        // AztecOO's GMRES with NOX's default Krylov subspace.
        assert_eq!(row["GMRES_Restart"], 300.0, "{row:?}");
        assert_eq!(row["Tangent_Bytes"], 0.0, "{row:?}");
    }
}
