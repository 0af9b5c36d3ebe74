//! The PETSc backend (feature `petsc`): KSP solves of a system with a known answer, the
//! quasi-static bar through KSP and SNES against the native direct solve, a Newmark run through
//! KSP, SNES on a small system with a known root, and failures (a NaN residual, a bad option)
//! ending as clean errors with the right exit code.
#![cfg(feature = "petsc")]

mod quasi_static_bar;

use peridyn::backend::native::KrylovSettings;
use peridyn::backend::petsc::snes::{self, SnesJacobian, SnesSettings};
use peridyn::backend::petsc::{DeckOptions, KspMethod, PetscLinearSolver, PetscSettings};
use peridyn::backend::problem::{Evaluation, NonlinearProblem};
use peridyn::backend::settings::PetscPreconditioner;
use peridyn::backend::{Csr, LinearSolver, SolveError};
use quasi_static_bar::{final_displacement, run_deck};
use std::process::Command;

// ---- KSP on a known answer ----

/// tridiag(−1, 2, −1) of size n: the finite-difference −d²/dx² on (0, 1), u(0) = u(1) = 0,
/// h = 1/(n + 1), scaled by h².
fn laplacian_1d(n: usize) -> Csr {
    let mut offsets = vec![0];
    let mut columns = Vec::new();
    let mut values = Vec::new();
    for r in 0..n {
        for c in r.saturating_sub(1)..(r + 2).min(n) {
            columns.push(c);
            values.push(if c == r { 2.0 } else { -1.0 });
        }
        offsets.push(columns.len());
    }
    Csr {
        nrows: n,
        ncols: n,
        offsets,
        columns,
        values,
    }
}

/// −u'' = 1 with u(0) = u(1) = 0 has u(x) = x(1 − x)/2; the centred second difference is
/// exact on quadratics, so tridiag(−1, 2, −1) u = h²·1 has u(x_i) as its solution.
fn laplacian_problem(n: usize) -> (Csr, Vec<f64>, Vec<f64>) {
    let h = 1.0 / (n as f64 + 1.0);
    let exact = (1..=n)
        .map(|i| {
            let x = i as f64 * h;
            x * (1.0 - x) / 2.0
        })
        .collect();
    (laplacian_1d(n), vec![h * h; n], exact)
}

fn settings(
    method: KspMethod,
    preconditioner: PetscPreconditioner,
    options: &str,
) -> PetscSettings {
    PetscSettings {
        method,
        preconditioner,
        ilu_fill_level: 0,
        krylov: KrylovSettings {
            relative_tolerance: 1e-12,
            ..KrylovSettings::default()
        },
        options: DeckOptions::new(
            "KspTest",
            peridyn::io::deck::parse_petsc_options(options).unwrap(),
        ),
    }
}

const N: usize = 100;

/// Solves the Laplacian problem twice (the second time refilling the values of the kept
/// matrix) and checks the closed-form answer; returns the iterations of the first solve.
fn check_known_answer(solver: &mut PetscLinearSolver) -> usize {
    let (matrix, rhs, exact) = laplacian_problem(N);
    let scale = exact.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let mut first = 0;
    for pass in 0..2 {
        let mut x = vec![0.0; N];
        let report = solver
            .solve(&matrix, &rhs, &mut x)
            .unwrap_or_else(|e| panic!("{}: {e}", solver.describe()));
        // Tolerance 1e-12 on the residual and cond(A) ≈ 4(n + 1)²/π² ≈ 4e3 bound the relative
        // error by ~4e-9.
        assert!(
            report.relative_residual <= 1e-11,
            "{}: true relative residual {:e}",
            report.method,
            report.relative_residual
        );
        let error = x
            .iter()
            .zip(&exact)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max)
            / scale;
        assert!(
            error < 1e-8,
            "{} pass {pass}: error {error:e}",
            report.method
        );
        if pass == 0 {
            first = report.iterations;
        }
    }
    first
}

#[test]
fn ksp_cg_gmres_and_mumps_solve_the_laplacian() {
    for (method, preconditioner, expected) in [
        (KspMethod::Cg, PetscPreconditioner::None, "KSP cg + PC none"),
        (
            KspMethod::Cg,
            PetscPreconditioner::Jacobi,
            "KSP cg + PC jacobi",
        ),
        (KspMethod::Cg, PetscPreconditioner::Gamg, "KSP cg + PC gamg"),
        (
            KspMethod::Gmres,
            PetscPreconditioner::Ilu,
            "KSP gmres + PC bjacobi",
        ),
        (
            KspMethod::Cg,
            PetscPreconditioner::Hypre,
            "KSP cg + PC hypre",
        ),
        (
            KspMethod::Lu,
            PetscPreconditioner::Ilu,
            "KSP preonly + PC lu",
        ),
        (
            KspMethod::Cholesky,
            PetscPreconditioner::Ilu,
            "KSP preonly + PC cholesky",
        ),
    ] {
        let mut solver = PetscLinearSolver::new(settings(method, preconditioner, ""));
        let iterations = check_known_answer(&mut solver);
        assert!(
            solver.describe().ends_with(expected),
            "{} is not {expected}",
            solver.describe()
        );
        match (method, preconditioner) {
            // CG ends in at most as many steps as distinct eigenvalues that b excites: b is
            // symmetric about the middle, so at most n/2 (+1 for round-off).
            (KspMethod::Cg, PetscPreconditioner::None | PetscPreconditioner::Jacobi) => {
                assert!(
                    (10..=N / 2 + 1).contains(&iterations),
                    "{expected}: {iterations}"
                )
            }
            // A tridiagonal matrix's ILU(0) is its exact LU: one preconditioned step.
            (KspMethod::Gmres, PetscPreconditioner::Ilu) => {
                assert!(iterations <= 2, "{expected}: {iterations}")
            }
            // Direct solves report one iteration.
            (KspMethod::Lu | KspMethod::Cholesky, _) => assert_eq!(iterations, 1),
            // Multigrid's count does not grow like CG's n/2.
            _ => assert!(iterations <= 20, "{expected}: {iterations}"),
        }
    }
}

#[test]
fn deck_options_override_the_deck_keys() {
    // `-ksp_type gmres -pc_type jacobi` replaces CG + GAMG (with a restart and a limit that
    // let GMRES with a constant-diagonal Jacobi reach 1e-12 on n = 100: about n iterations).
    let mut solver = PetscLinearSolver::new(settings(
        KspMethod::Cg,
        PetscPreconditioner::Gamg,
        "-ksp_type gmres -ksp_gmres_restart 200 -ksp_max_it 400 -pc_type jacobi",
    ));
    check_known_answer(&mut solver);
    assert!(
        solver.describe().ends_with("KSP gmres + PC jacobi"),
        "{}",
        solver.describe()
    );
}

#[test]
fn an_iteration_limit_below_what_cg_needs_is_not_converged() {
    let (matrix, rhs, _) = laplacian_problem(N);
    let mut limited = settings(KspMethod::Cg, PetscPreconditioner::None, "");
    limited.krylov.max_iterations = Some(5);
    let mut solver = PetscLinearSolver::new(limited);
    let mut x = vec![0.0; N];
    match solver.solve(&matrix, &rhs, &mut x) {
        Err(SolveError::NotConverged {
            iterations,
            relative_residual,
            ..
        }) => {
            // Five CG steps on a system that needs ~50 leave most of the residual.
            assert_eq!(iterations, 5);
            assert!(relative_residual > 1e-3, "{relative_residual:e}");
        }
        other => panic!("expected NotConverged, got {other:?}"),
    }
}

#[test]
fn a_nan_in_the_matrix_is_a_non_finite_error() {
    let (mut matrix, rhs, _) = laplacian_problem(10);
    matrix.values[5] = f64::NAN;
    let mut solver = PetscLinearSolver::new(settings(KspMethod::Cg, PetscPreconditioner::Ilu, ""));
    let mut x = vec![0.0; 10];
    match solver.solve(&matrix, &rhs, &mut x) {
        Err(SolveError::NonFinite { what }) => assert!(what.contains("matrix"), "{what}"),
        other => panic!("expected NonFinite, got {other:?}"),
    }
}

#[test]
fn an_unknown_ksp_type_is_petscs_error_with_its_message() {
    let solver = PetscLinearSolver::new(settings(
        KspMethod::Cg,
        PetscPreconditioner::Ilu,
        "-ksp_type no_such_method",
    ));
    let error = solver
        .resolve()
        .expect_err("PETSc refuses an unknown KSP type");
    assert!(error.message.contains("no_such_method"), "{error}");
}

// ---- SNES on a small system with a known root ----

/// F(x) = (x₀³ + x₀ − 2, 2x₁ + x₀ − 5): the unique root is (1, 2) (x₀³ + x₀ increases
/// monotonically and equals 2 at x₀ = 1; then x₁ = (5 − 1)/2). With `nan_from` set, the
/// residual from that evaluation on is a NaN written into F.
struct Cubic {
    x: Vec<f64>,
    evaluations: usize,
    nan_from: Option<usize>,
}

impl NonlinearProblem for Cubic {
    fn len(&self) -> usize {
        2
    }
    fn ranks(&self) -> usize {
        1
    }
    fn global_ids(&self) -> Option<&[usize]> {
        None
    }
    fn unknowns(&self, x: &mut [f64]) {
        x.copy_from_slice(&self.x);
    }
    fn move_to(&mut self, x: &[f64]) {
        self.x.copy_from_slice(x);
    }
    fn residual(&mut self, x: &[f64], f: &mut [f64], _: Evaluation) -> Result<(), SolveError> {
        self.evaluations += 1;
        self.x.copy_from_slice(x);
        if self.nan_from.is_some_and(|k| self.evaluations >= k) {
            return Err(SolveError::NonFinite {
                what: "the test residual".into(),
            });
        }
        f[0] = x[0].powi(3) + x[0] - 2.0;
        f[1] = 2.0 * x[1] + x[0] - 5.0;
        Ok(())
    }
    fn jacobian(&mut self, x: &[f64]) -> Result<Csr, SolveError> {
        Ok(Csr {
            nrows: 2,
            ncols: 2,
            offsets: vec![0, 2, 4],
            columns: vec![0, 1, 0, 1],
            values: vec![3.0 * x[0] * x[0] + 1.0, 0.0, 1.0, 2.0],
        })
    }
    fn jacobian_bytes(&self) -> usize {
        0
    }
    fn groups(&self) -> &[usize] {
        &[0, 2]
    }
    fn block_diagonal(&mut self, x: &[f64]) -> Result<Vec<f64>, SolveError> {
        Ok(vec![3.0 * x[0] * x[0] + 1.0, 0.0, 1.0, 2.0])
    }
    fn group_label(&self, group: usize) -> String {
        format!("group {group}")
    }
    fn dot(&mut self, a: &[f64], b: &[f64]) -> f64 {
        a.iter().zip(b).map(|(x, y)| x * y).sum()
    }
    fn any_failed(&mut self, failed: bool) -> bool {
        failed
    }
    fn convergence_measure(&mut self, f: &[f64]) -> f64 {
        self.dot(f, f).sqrt()
    }
    fn probe_scale(&self) -> f64 {
        1.0
    }
}

fn snes_settings(linear: &PetscSettings, jacobian: SnesJacobian) -> SnesSettings<'_> {
    SnesSettings {
        linear,
        jacobian,
        tolerance: 1e-12,
        max_iterations: 30,
        line_search: true,
        ncg: None,
        print_iterations: false,
        warn_unused: true,
    }
}

#[test]
fn snes_newton_and_jfnk_find_the_root_of_a_small_system() {
    let linear = settings(KspMethod::Gmres, PetscPreconditioner::Ilu, "");
    for jacobian in [SnesJacobian::Assembled, SnesJacobian::MatrixFree] {
        let mut problem = Cubic {
            x: vec![3.0, 0.0],
            evaluations: 0,
            nan_from: None,
        };
        let report = snes::solve(&mut problem, &snes_settings(&linear, jacobian))
            .unwrap_or_else(|e| panic!("{jacobian:?}: {e}"));
        assert!(report.converged, "{jacobian:?}: {report:?}");
        assert!(
            report.method.contains("SNES newtonls (line search bt)"),
            "{}",
            report.method
        );
        // ‖F‖ ≤ 1e-12 with J ≈ diag(4, 2) near the root puts x within ~1e-12 of (1, 2).
        assert!(
            (problem.x[0] - 1.0).abs() < 1e-10 && (problem.x[1] - 2.0).abs() < 1e-10,
            "{jacobian:?}: {:?}",
            problem.x
        );
        // Newton from x₀ = 3 converges quadratically: a handful of iterations.
        assert!(report.iterations <= 12, "{jacobian:?}: {report:?}");
    }
}

#[test]
fn a_nan_residual_inside_snes_is_the_error_snes_returns() {
    let linear = settings(KspMethod::Gmres, PetscPreconditioner::Ilu, "");
    for jacobian in [SnesJacobian::Assembled, SnesJacobian::MatrixFree] {
        // Evaluation 1 is the starting residual; the failure comes inside the iteration.
        let mut problem = Cubic {
            x: vec![3.0, 0.0],
            evaluations: 0,
            nan_from: Some(3),
        };
        match snes::solve(&mut problem, &snes_settings(&linear, jacobian)) {
            Err(SolveError::NonFinite { what }) => assert_eq!(what, "the test residual"),
            other => panic!("{jacobian:?}: expected the callback's NonFinite, got {other:?}"),
        }
    }
}

// ---- Through the deck: the quasi-static bar ----

const PULL: f64 = 0.012;
const SHEAR: f64 = 0.004;

fn bar(solver_keys: &str, integrator: &str) -> String {
    let solver = format!("    Final Time: 1.0\n{solver_keys}\n{integrator}");
    quasi_static_bar::bar_deck(&solver, PULL, SHEAR, 2)
}

fn quasi_static() -> String {
    "    QuasiStatic:\n      Number of Load Steps: {steps}\n      Absolute Tolerance: 1.0\n      Maximum Solver Iterations: 30".to_string()
}

fn nox_quasi_static(linear_solver: &str) -> String {
    format!(
        "    NOXQuasiStatic:\n      Number of Load Steps: {{steps}}\n      Absolute Tolerance: 1.0e-3\n      Max Solver Iterations: 30\n      Direction:\n        Method: \"Newton\"\n        Newton:\n          Linear Solver:\n{linear_solver}"
    )
}

fn largest_difference(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
}

#[test]
fn quasi_static_bar_through_ksp_and_snes_matches_the_native_direct_solve() {
    let dir = tempfile::tempdir().unwrap();
    run_deck(
        dir.path(),
        &bar("    Linear Solver: \"Direct\"", &quasi_static()),
    )
    .expect("native direct run");
    let reference = final_displacement(dir.path());
    let scale = reference.iter().fold(0.0f64, |m, u| m.max(u.abs()));
    // The bar's largest displacement is the 0.012 pull.
    assert!((scale - PULL).abs() < 1e-12, "{scale}");
    let strategies = [
        (
            "KSP CG + GAMG",
            bar(
                "    Backend: \"PETSc\"\n    Linear Solver: \"CG\"\n    Linear Solver Preconditioner: \"GAMG\"\n    Linear Solver Tolerance: 1.0e-12",
                &quasi_static(),
            ),
        ),
        (
            "KSP GMRES + block Jacobi ILU",
            bar(
                "    Backend: \"PETSc\"\n    Linear Solver: \"GMRES\"\n    Linear Solver Preconditioner: \"ILU\"\n    Linear Solver Tolerance: 1.0e-12",
                &quasi_static(),
            ),
        ),
        (
            "KSP MUMPS LU",
            bar(
                "    Backend: \"PETSc\"\n    Linear Solver: \"Direct\"",
                &quasi_static(),
            ),
        ),
        (
            "SNES Newton (assembled, GMRES + ILU)",
            bar(
                "    Backend: \"PETSc\"\n    Linear Solver: \"GMRES\"\n    Linear Solver Tolerance: 1.0e-12",
                &nox_quasi_static("            Jacobian Operator: \"Full Tangent\""),
            ),
        ),
        (
            "SNES JFNK (-snes_mf_operator, 3x3 blocks)",
            bar(
                "    Backend: \"PETSc\"\n    Peridigm Preconditioner: \"Block 3x3\"\n    Linear Solver: \"GMRES\"\n    Linear Solver Tolerance: 1.0e-8",
                &nox_quasi_static("            Jacobian Operator: \"Matrix-Free\""),
            ),
        ),
        (
            // No `Linear Solver`: `Automatic` is GMRES with the Jacobian-free operator (a
            // direct solve of the 3×3 blocks alone made SNES stall).
            "SNES JFNK (-snes_mf_operator, 3x3 blocks, Linear Solver Automatic)",
            bar(
                "    Backend: \"PETSc\"\n    Peridigm Preconditioner: \"Block 3x3\"\n    Linear Solver Tolerance: 1.0e-8",
                &nox_quasi_static("            Jacobian Operator: \"Matrix-Free\""),
            ),
        ),
        (
            "KSP CG + AMG (GAMG on the tangent)",
            bar(
                "    Backend: \"PETSc\"\n    Linear Solver: \"CG\"\n    Linear Solver Preconditioner: \"AMG\"\n    Linear Solver Tolerance: 1.0e-12",
                &quasi_static(),
            ),
        ),
        (
            "SNES JFNK (-snes_mf_operator, GAMG on the one-hop operator)",
            bar(
                "    Backend: \"PETSc\"\n    Peridigm Preconditioner: \"AMG\"\n    Linear Solver: \"GMRES\"\n    Linear Solver Tolerance: 1.0e-8",
                &nox_quasi_static("            Jacobian Operator: \"Matrix-Free\""),
            ),
        ),
        (
            "SNES JFNK (-snes_mf_operator, hypre BoomerAMG on the one-hop operator)",
            bar(
                "    Backend: \"PETSc\"\n    Peridigm Preconditioner: \"AMG\"\n    Linear Solver: \"GMRES\"\n    Linear Solver Tolerance: 1.0e-8\n    PETSc Options: \"-pc_type hypre\"",
                &nox_quasi_static("            Jacobian Operator: \"Matrix-Free\""),
            ),
        ),
    ];
    for (name, deck) in &strategies {
        let dir = tempfile::tempdir().unwrap();
        let summary =
            run_deck(dir.path(), deck).unwrap_or_else(|e| panic!("{name}: the run failed: {e}"));
        assert_eq!(summary.steps, 2, "{name}");
        let difference = largest_difference(&reference, &final_displacement(dir.path()));
        // QuasiStatic runs stop at ‖r‖₂ + 20‖r‖∞ ≤ 1 N (the round-off floor of this residual
        // is ~1e-2 N), the SNES runs at ‖F‖₂ ≤ 1e-3 N, on a stiffness of order 1e11 N/m (bulk
        // modulus 1.3e11 Pa times the 1 m spacing): every answer is within ~1e-11 m of
        // equilibrium, so 1e-8 of the pull is looser than that and far tighter than any wrong
        // answer.
        assert!(
            difference <= 1e-8 * scale,
            "{name} differs from the native direct solve by {difference:e}"
        );
    }
}

// ---- Through the command line ----

fn run_cli(args: &[&str]) -> (Option<i32>, String) {
    let output = Command::new(env!("CARGO_BIN_EXE_peridyn"))
        .args(args)
        .output()
        .unwrap();
    (
        output.status.code(),
        format!(
            "{}{}",
            String::from_utf8_lossy(&output.stdout),
            String::from_utf8_lossy(&output.stderr)
        ),
    )
}

#[test]
fn a_bad_petsc_option_is_exit_code_2_naming_the_key_in_check_and_run() {
    let dir = tempfile::tempdir().unwrap();
    for (options, expected) in [
        ("-ksp_type no_such_method", "no_such_method"),
        ("ksp_type gmres", "start with -"),
    ] {
        let deck = bar(
            &format!("    Backend: \"PETSc\"\n    Linear Solver: \"CG\"\n    PETSc Options: \"{options}\""),
            &quasi_static(),
        );
        let path = dir.path().join("bad.yaml");
        std::fs::write(&path, deck).unwrap();
        let out = dir.path().to_str().unwrap();
        for args in [
            vec!["check", path.to_str().unwrap()],
            vec!["run", path.to_str().unwrap(), "--output-dir", out],
        ] {
            let (code, log) = run_cli(&args);
            assert_eq!(code, Some(2), "{options} ({}): {log}", args[0]);
            assert!(log.contains("PETSc Options"), "names the key: {log}");
            assert!(log.contains(expected), "{options}: {log}");
            assert!(log.contains("bad.yaml"), "names the file: {log}");
        }
    }
}

#[test]
fn check_shows_the_resolved_solver_and_run_warns_about_unused_options() {
    let dir = tempfile::tempdir().unwrap();
    let deck = bar(
        "    Backend: \"PETSc\"\n    Linear Solver: \"CG\"\n    Linear Solver Tolerance: 1.0e-12\n    PETSc Options: \"-pc_type gamg -no_such_option 3\"",
        &quasi_static(),
    );
    let path = dir.path().join("bar.yaml");
    std::fs::write(&path, deck).unwrap();
    let (code, log) = run_cli(&["check", path.to_str().unwrap()]);
    assert_eq!(code, Some(0), "{log}");
    assert!(log.contains("PETSc KSP cg + PC gamg"), "{log}");
    let (code, log) = run_cli(&[
        "run",
        path.to_str().unwrap(),
        "--output-dir",
        dir.path().to_str().unwrap(),
    ]);
    assert_eq!(code, Some(0), "{log}");
    assert!(
        log.contains("Solver → PETSc Options: PETSc did not use -no_such_option"),
        "{log}"
    );
    assert!(!log.contains("-pc_type"), "gamg was used: {log}");
}

#[test]
fn check_shows_how_the_petsc_solver_runs_on_several_ranks() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bar.yaml");
    for (keys, integrator, expected) in [
        (
            "    Backend: \"PETSc\"\n    Linear Solver: \"CG\"",
            quasi_static(),
            "solver           Solver: PETSc KSP cg + PC bjacobi on MPI_COMM_WORLD (a MATMPIAIJ of each rank's rows): block Jacobi, one ILU block per rank;",
        ),
        (
            "    Backend: \"PETSc\"\n    Linear Solver: \"Direct\"",
            quasi_static(),
            "PETSc KSP preonly + PC lu on MPI_COMM_WORLD (a MATMPIAIJ of each rank's rows): MUMPS factors across the ranks;",
        ),
        (
            "    Backend: \"PETSc\"\n    Peridigm Preconditioner: \"AMG\"\n    Linear Solver: \"GMRES\"",
            nox_quasi_static("            Jacobian Operator: \"Matrix-Free\""),
            "KSP gmres + PC gamg, -snes_mf_operator, PC built on the one-hop operator with the rigid-body near-null space on MPI_COMM_WORLD (a MATMPIAIJ of each rank's rows): the preconditioner works across the ranks; the one-hop operator holds the couplings between ranks too;",
        ),
    ] {
        std::fs::write(&path, bar(keys, &integrator)).unwrap();
        let (code, log) = run_cli(&["check", path.to_str().unwrap()]);
        assert_eq!(code, Some(0), "{log}");
        let section = log.split("on several MPI ranks").nth(1).unwrap_or("");
        assert!(section.contains(expected), "{keys}: {log}");
    }
}

#[test]
fn backend_petsc_on_the_command_line_runs_implicit_lists_on_petsc() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bar.yaml");
    std::fs::write(
        &path,
        bar(
            "    Linear Solver: \"GMRES\"\n    Linear Solver Tolerance: 1.0e-12",
            &quasi_static(),
        ),
    )
    .unwrap();
    let (code, log) = run_cli(&[
        "run",
        path.to_str().unwrap(),
        "--output-dir",
        dir.path().to_str().unwrap(),
        "--backend",
        "petsc",
    ]);
    assert_eq!(code, Some(0), "{log}");
    assert!(log.contains("PETSc KSP gmres + PC bjacobi"), "{log}");
}

#[test]
fn backend_petsc_carries_each_native_preconditioner_choice_over() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bar.yaml");
    // Each native `Linear Solver Preconditioner` (and `Peridigm Preconditioner: "AMG"`) on a
    // list without `Backend`, checked as `peridyn run --backend petsc` would resolve it: the
    // PETSc PC a list naming `Backend: "PETSc"` gets from the same choice.
    for (keys, integrator, expected) in [
        ("", quasi_static(), "PETSc KSP cg + PC bjacobi"),
        (
            "    Linear Solver Preconditioner: \"Jacobi\"",
            quasi_static(),
            "PETSc KSP cg + PC jacobi",
        ),
        (
            "    Linear Solver Preconditioner: \"None\"",
            quasi_static(),
            "PETSc KSP cg + PC none",
        ),
        (
            "    Linear Solver Preconditioner: \"AMG\"",
            quasi_static(),
            "PETSc KSP cg + PC gamg",
        ),
        (
            "    Peridigm Preconditioner: \"AMG\"",
            nox_quasi_static("            Jacobian Operator: \"Matrix-Free\""),
            "PC gamg, -snes_mf_operator, PC built on the one-hop operator",
        ),
    ] {
        let keys = format!("    Linear Solver: \"CG\"\n{keys}");
        std::fs::write(&path, bar(keys.trim_end(), &integrator)).unwrap();
        let (code, log) = run_cli(&["check", path.to_str().unwrap(), "--backend", "petsc"]);
        assert_eq!(code, Some(0), "{keys}: {log}");
        assert!(log.contains(expected), "{keys}: {log}");
        assert!(!log.contains("warning"), "{keys}: {log}");
    }
    // `Block 3x3` has no PETSc counterpart: PETSc's default, and a warning naming the key.
    let keys = "    Linear Solver: \"CG\"\n    Linear Solver Preconditioner: \"Block 3x3\"";
    std::fs::write(&path, bar(keys, &quasi_static())).unwrap();
    let (code, log) = run_cli(&["check", path.to_str().unwrap(), "--backend", "petsc"]);
    assert_eq!(code, Some(0), "{log}");
    assert!(log.contains("PETSc KSP cg + PC bjacobi"), "{log}");
    assert!(
        log.contains(
            "Solver → Linear Solver Preconditioner: \"Block 3x3\" has no PETSc counterpart"
        ),
        "{log}"
    );
    // `run` warns alike.
    let out = dir.path().to_str().unwrap();
    let (code, log) = run_cli(&[
        "run",
        path.to_str().unwrap(),
        "--output-dir",
        out,
        "--backend",
        "petsc",
    ]);
    assert_eq!(code, Some(0), "{log}");
    assert!(
        log.contains("\"Block 3x3\" has no PETSc counterpart"),
        "{log}"
    );
}

// ---- Newmark through KSP ----

#[test]
fn newmark_through_ksp_matches_the_native_direct_solve() {
    let implicit = "    Implicit:\n      Fixed dt: 1.0e-4\n      Beta: 0.25\n      Gamma: 0.5\n      Absolute Tolerance: 1.0e-8\n      Maximum Solver Iterations: 20";
    let deck = |keys: &str| {
        let solver = format!("    Final Time: 5.0e-4\n{keys}\n{implicit}");
        quasi_static_bar::bar_deck(&solver, PULL, SHEAR, 1)
            .replace("0.012*t", "24.0*t")
            .replace("0.004*t", "8.0*t")
    };
    let dir = tempfile::tempdir().unwrap();
    run_deck(dir.path(), &deck("    Linear Solver: \"Direct\"")).expect("native direct");
    let reference = final_displacement(dir.path());
    let scale = reference.iter().fold(0.0f64, |m, u| m.max(u.abs()));
    // The right face moves 24 m/s × 5e-4 s = 0.012 m by the end.
    assert!((scale - 0.012).abs() < 1e-9, "{scale}");
    for keys in [
        "    Backend: \"PETSc\"\n    Linear Solver: \"CG\"\n    Linear Solver Preconditioner: \"GAMG\"\n    Linear Solver Tolerance: 1.0e-12",
        "    Backend: \"PETSc\"\n    Linear Solver: \"Direct\"",
    ] {
        let dir = tempfile::tempdir().unwrap();
        run_deck(dir.path(), &deck(keys)).unwrap_or_else(|e| panic!("{keys}: {e}"));
        let difference = largest_difference(&reference, &final_displacement(dir.path()));
        // Both runs stop Newton at the same tolerance on the same equations; the linear solves
        // are exact (MUMPS) or at 1e-12: the displacements agree far below 1e-8 of the motion.
        assert!(difference <= 1e-8 * scale, "{keys}: differs by {difference:e}");
    }
}

// ---- GAMG on the one-hop operator: the rigid-body near-null space is used ----

/// The one-hop PMB operator (c = 1, V = 1) of an n×n×n lattice of spacing 1 with horizon 1.5
/// (face and edge neighbours), the face x = 0 clamped; with the rigid-body modes of its
/// unknowns.
fn clamped_lattice_operator(n: usize) -> (Csr, Vec<f64>) {
    use peridyn::backend::native::{one_hop_operator, rigid_body_modes, OneHopInput, Stencil};
    use peridyn::model::BondList;
    let index = |x: usize, y: usize, z: usize| (x * n + y) * n + z;
    let mut position = Vec::new();
    let mut bonds = BondList {
        offsets: vec![0],
        ..BondList::default()
    };
    for x in 0..n {
        for y in 0..n {
            for z in 0..n {
                position.push([x as f64, y as f64, z as f64]);
                for dx in -1i64..=1 {
                    for dy in -1i64..=1 {
                        for dz in -1i64..=1 {
                            let squared = dx * dx + dy * dy + dz * dz;
                            let (nx, ny, nz) = (x as i64 + dx, y as i64 + dy, z as i64 + dz);
                            let inside = |c: i64| (0..n as i64).contains(&c);
                            if matches!(squared, 1 | 2) && inside(nx) && inside(ny) && inside(nz) {
                                bonds
                                    .neighbor
                                    .push(index(nx as usize, ny as usize, nz as usize) as u32);
                                bonds.reference_length.push((squared as f64).sqrt());
                            }
                        }
                    }
                }
                bonds.offsets.push(bonds.neighbor.len());
            }
        }
    }
    let points = position.len();
    let mut dof_index = vec![None; 3 * points];
    let mut free = Vec::new();
    for (p, x) in position.iter().enumerate() {
        if x[0] > 0.0 {
            for c in 0..3 {
                dof_index[3 * p + c] = Some(free.len());
                free.push(3 * p + c);
            }
        }
    }
    let matrix = one_hop_operator(&OneHopInput {
        position: &position,
        volume: &vec![1.0; points],
        bonds: &bonds,
        micromodulus: &vec![1.0; points],
        bond_damage: None,
        diagonal_shift: None,
        dof_index: &dof_index,
        unknowns: free.len(),
        // The stencil peridyn's solvers hand PETSc; on this lattice (every bond within the
        // unit cube's diagonal) it keeps every bond.
        stencil: Stencil::Nearest,
    });
    (matrix, rigid_body_modes(&position, &free))
}

#[test]
fn gamg_on_the_one_hop_operator_needs_fewer_iterations_with_the_rigid_body_modes() {
    let (matrix, modes) = clamped_lattice_operator(10);
    let n = matrix.nrows;
    // A known answer: x* = a smooth bending-like field, b = K x*.
    let exact: Vec<f64> = (0..n)
        .map(|i| ((i / 3) as f64 * 0.01).sin() + 0.1)
        .collect();
    let mut rhs = vec![0.0; n];
    matrix.multiply_parallel(&exact, &mut rhs);
    let run = |with_modes: bool| {
        let mut solver =
            PetscLinearSolver::new(settings(KspMethod::Cg, PetscPreconditioner::Gamg, ""));
        if with_modes {
            solver.set_near_null_space(&modes, 6);
        }
        let mut x = vec![0.0; n];
        let report = solver.solve(&matrix, &rhs, &mut x).unwrap();
        let error =
            largest_difference(&x, &exact) / exact.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        // Residual 1e-12 relative and cond(K) of the clamped lattice ≲ 1e4 (its size 10
        // squared times the c = 1 stiffness ratio) bound the error near 1e-8.
        assert!(error < 1e-7, "modes {with_modes}: error {error:e}");
        report.iterations
    };
    let with = run(true);
    let without = run(false);
    eprintln!("GAMG iterations: {with} with the rigid-body modes, {without} without");
    assert!(with < without, "{with} with the modes, {without} without");
}

#[test]
fn check_shows_gamg_or_hypre_on_the_one_hop_operator_for_jfnk_with_amg() {
    let dir = tempfile::tempdir().unwrap();
    for (extra, pc) in [
        ("", "PC gamg"),
        ("\n    PETSc Options: \"-pc_type hypre\"", "PC hypre"),
    ] {
        let deck = bar(
            &format!("    Backend: \"PETSc\"\n    Peridigm Preconditioner: \"AMG\"{extra}"),
            &nox_quasi_static("            Jacobian Operator: \"Matrix-Free\""),
        );
        let path = dir.path().join("amg.yaml");
        std::fs::write(&path, deck).unwrap();
        let (code, log) = run_cli(&["check", path.to_str().unwrap()]);
        assert_eq!(code, Some(0), "{log}");
        assert!(
            log.contains(&format!(
                "KSP gmres + {pc}, -snes_mf_operator, PC built on the one-hop operator"
            )),
            "{log}"
        );
    }
}
