//! The Trilinos backend (feature `trilinos`): Belos solves of known systems with every
//! preconditioner, the Epetra matrix against our own product, failures as `SolveError`, and
//! parity with the native direct solver through a full quasi-static run.
#![cfg(feature = "trilinos")]

use peridyn::backend::native::KrylovSettings;
use peridyn::backend::trilinos::{
    epetra_multiply, BelosMethod, Communicator, TrilinosLinearSolver, TrilinosPreconditioner,
    TrilinosSettings,
};
use peridyn::backend::{Csr, LinearSolver, SolveError};

/// The n × n matrix tridiag(−1, 2, −1): the finite-difference −d²/dx² on (0, 1) with
/// u(0) = u(1) = 0 and h = 1/(n + 1), scaled by h².
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

/// −u'' = 1 with u(0) = u(1) = 0 has u(x) = x(1 − x)/2. The centred second difference is exact
/// on quadratics, so the discrete solution of tridiag(−1, 2, −1) u = h² · 1 equals u at the
/// nodes x_i = i h to round-off.
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

fn settings(method: BelosMethod, preconditioner: TrilinosPreconditioner) -> TrilinosSettings {
    TrilinosSettings {
        method,
        preconditioner,
        krylov: KrylovSettings {
            relative_tolerance: 1e-12,
            ..KrylovSettings::default()
        },
        ..TrilinosSettings::default()
    }
}

fn max_relative_error(x: &[f64], exact: &[f64]) -> f64 {
    let scale = exact.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    x.iter()
        .zip(exact)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max)
        / scale
}

/// Solves the 1-D Laplacian problem and checks the closed-form answer to 1e-8; returns the
/// iterations Belos took.
fn check_known_answer(solver: &mut TrilinosLinearSolver, n: usize) -> usize {
    let (matrix, rhs, exact) = laplacian_problem(n);
    let mut x = vec![0.0; n];
    let report = solver
        .solve(&matrix, &rhs, &mut x)
        .unwrap_or_else(|e| panic!("{} failed: {e}", solver.method_name()));
    assert_eq!(report.method, solver.method_name());
    // Tolerance 1e-12 on ‖b − Ax‖/‖b‖ and cond(A) ≈ 4(n + 1)²/π² ≈ 4e3 for n = 100 bound the
    // relative error by ~4e-9.
    assert!(
        report.relative_residual <= 1e-11,
        "{}: true relative residual {:e}",
        report.method,
        report.relative_residual
    );
    let error = max_relative_error(&x, &exact);
    assert!(error < 1e-8, "{}: error {error:e}", report.method);
    report.iterations
}

const N: usize = 100;

#[test]
fn cg_without_preconditioner_solves_the_laplacian() {
    let mut solver =
        TrilinosLinearSolver::new(settings(BelosMethod::BlockCg, TrilinosPreconditioner::None));
    let iterations = check_known_answer(&mut solver, N);
    // CG ends in at most as many steps as A has distinct eigenvalues (n); b = h²·1 is
    // symmetric about the middle and so lies in the span of the n/2 symmetric eigenvectors.
    assert!(iterations <= N / 2 + 1, "{iterations} iterations");
    assert!(
        iterations >= 10,
        "{iterations} iterations is too few for cond ≈ 4e3"
    );
}

#[test]
fn cg_with_jacobi_solves_the_laplacian_in_the_same_iterations() {
    let mut plain =
        TrilinosLinearSolver::new(settings(BelosMethod::BlockCg, TrilinosPreconditioner::None));
    let mut jacobi = TrilinosLinearSolver::new(settings(
        BelosMethod::BlockCg,
        TrilinosPreconditioner::Jacobi,
    ));
    let plain_iterations = check_known_answer(&mut plain, N);
    let jacobi_iterations = check_known_answer(&mut jacobi, N);
    // The diagonal is constant (2), so Jacobi only rescales and CG's iterates are the same.
    assert!(
        jacobi_iterations.abs_diff(plain_iterations) <= 1,
        "Jacobi {jacobi_iterations} vs none {plain_iterations}"
    );
}

#[test]
fn cg_and_gmres_with_ilu_solve_the_laplacian_at_once() {
    for method in [BelosMethod::BlockCg, BelosMethod::BlockGmres] {
        let mut solver = TrilinosLinearSolver::new(settings(
            method,
            TrilinosPreconditioner::Ilu { fill_level: 0 },
        ));
        let iterations = check_known_answer(&mut solver, N);
        // A tridiagonal matrix's LU factors have no fill, so ILU(0) is its exact LU and one
        // preconditioned iteration solves the system.
        assert!(iterations <= 2, "{}: {iterations}", solver.method_name());
    }
}

#[test]
fn cg_and_gmres_with_ml_solve_the_laplacian() {
    for method in [BelosMethod::BlockCg, BelosMethod::BlockGmres] {
        let mut solver = TrilinosLinearSolver::new(settings(method, TrilinosPreconditioner::Ml));
        let iterations = check_known_answer(&mut solver, N);
        // Multigrid's iteration count does not grow with n like CG's ~n/2.
        assert!(iterations <= 20, "{}: {iterations}", solver.method_name());
    }
}

#[test]
fn mpi_world_communicator_solves_on_a_singleton_without_mpirun() {
    let mut solver = TrilinosLinearSolver::new(TrilinosSettings {
        communicator: Communicator::MpiWorld,
        ..settings(BelosMethod::BlockCg, TrilinosPreconditioner::Ml)
    });
    check_known_answer(&mut solver, N);
    // A second solve reuses the initialised MPI.
    check_known_answer(&mut solver, N);
}

#[test]
fn the_epetra_matrix_multiplies_like_the_csr() {
    // A non-symmetric 4 × 4 matrix with an empty row, so transposed or shifted entries show.
    let matrix = Csr {
        nrows: 4,
        ncols: 4,
        offsets: vec![0, 2, 2, 5, 7],
        columns: vec![0, 3, 0, 1, 2, 1, 3],
        values: vec![1.5, -2.0, 4.0, 0.25, -1.0, 3.0, 7.0],
    };
    let x = [1.0, -2.0, 0.5, 3.0];
    let mut expected = vec![0.0; 4];
    matrix.multiply(&x, &mut expected);
    let mut y = vec![f64::NAN; 4];
    epetra_multiply(&matrix, &x, &mut y).unwrap();
    // Each row is at most three products of exactly representable numbers: bit-equal sums.
    assert_eq!(y, expected);
}

#[test]
fn a_nan_in_the_matrix_is_a_non_finite_error() {
    let (mut matrix, rhs, _) = laplacian_problem(10);
    matrix.values[5] = f64::NAN;
    let mut x = vec![0.0; 10];
    let mut solver = TrilinosLinearSolver::new(settings(
        BelosMethod::BlockCg,
        TrilinosPreconditioner::Ilu { fill_level: 0 },
    ));
    match solver.solve(&matrix, &rhs, &mut x) {
        Err(SolveError::NonFinite { what }) => assert!(what.contains("matrix"), "{what}"),
        other => panic!("expected NonFinite, got {other:?}"),
    }
}

#[test]
fn cg_on_an_indefinite_matrix_hands_over_to_gmres() {
    // diag(1, −2) with b = (1, 1): the first search direction p = b has pᵀAp = 1 − 2 < 0,
    // which Belos' CG reports as a failure of positive definiteness (a C++ exception). The
    // solver then switches to BlockGMRES for good, which needs no definiteness:
    // x = (1, −1/2).
    let matrix = Csr {
        nrows: 2,
        ncols: 2,
        offsets: vec![0, 1, 2],
        columns: vec![0, 1],
        values: vec![1.0, -2.0],
    };
    let mut x = vec![0.0; 2];
    let mut solver =
        TrilinosLinearSolver::new(settings(BelosMethod::BlockCg, TrilinosPreconditioner::None));
    let report = solver.solve(&matrix, &[1.0, 1.0], &mut x).unwrap();
    assert_eq!(report.method, "Belos BlockGMRES");
    assert_eq!(solver.settings().method, BelosMethod::BlockGmres);
    assert!(
        (x[0] - 1.0).abs() < 1e-12 && (x[1] + 0.5).abs() < 1e-12,
        "{x:?}"
    );
}

#[test]
fn a_singular_matrix_fails_cleanly() {
    // The zero matrix: ILU's pivots are all zero, and no x satisfies 0·x = b.
    let matrix = Csr {
        nrows: 3,
        ncols: 3,
        offsets: vec![0, 1, 2, 3],
        columns: vec![0, 1, 2],
        values: vec![0.0; 3],
    };
    for preconditioner in [
        TrilinosPreconditioner::None,
        TrilinosPreconditioner::Ilu { fill_level: 0 },
    ] {
        let mut solver =
            TrilinosLinearSolver::new(settings(BelosMethod::BlockGmres, preconditioner));
        let mut x = vec![0.0; 3];
        let result = solver.solve(&matrix, &[1.0, 2.0, 3.0], &mut x);
        assert!(
            matches!(
                result,
                Err(SolveError::Breakdown { .. }
                    | SolveError::NonFinite { .. }
                    | SolveError::NotConverged { .. })
            ),
            "{}: {result:?}",
            solver.method_name()
        );
    }
}

#[test]
fn an_iteration_limit_below_what_cg_needs_is_not_converged() {
    let (matrix, rhs, _) = laplacian_problem(N);
    let mut solver = TrilinosLinearSolver::new(TrilinosSettings {
        krylov: KrylovSettings {
            relative_tolerance: 1e-12,
            max_iterations: Some(5),
            ..KrylovSettings::default()
        },
        ..settings(BelosMethod::BlockCg, TrilinosPreconditioner::None)
    });
    let mut x = vec![0.0; N];
    match solver.solve(&matrix, &rhs, &mut x) {
        Err(SolveError::NotConverged {
            iterations,
            relative_residual,
            tolerance,
            ..
        }) => {
            // Five CG steps on a system that needs ~50 leave most of the residual.
            assert_eq!(iterations, 5);
            assert!(relative_residual > 1e-3, "{relative_residual:e}");
            assert_eq!(tolerance, 1e-12);
        }
        other => panic!("expected NotConverged, got {other:?}"),
    }
}

// ---- Through the deck: a quasi-static LPS bar, native direct against Belos ----

use peridyn::io::deck::{parse_str, DeckFormat};
use std::process::Command;

mod quasi_static_bar;
use quasi_static_bar::{final_displacement, run_deck};

/// The shared quasi-static bar pulled by `PULL` and `SHEAR` in two load steps, with the
/// `Solver`-level lines `solver` (backend and linear-solver keys).
fn bar_deck(solver: &str, pull: f64, shear: f64) -> String {
    let solver_list = format!(
        "    Final Time: 1.0\n{solver}\n    QuasiStatic:\n      Number of Load Steps: {{steps}}\n      Absolute Tolerance: 1.0\n      Maximum Solver Iterations: 20"
    );
    quasi_static_bar::bar_deck(&solver_list, pull, shear, 2)
}

const PULL: f64 = 0.012;
const SHEAR: f64 = 0.004;

fn largest_difference(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

fn direct_bar() -> Vec<f64> {
    let dir = tempfile::tempdir().unwrap();
    run_deck(
        dir.path(),
        &bar_deck("    Linear Solver: \"Direct\"", PULL, SHEAR),
    )
    .expect("direct run succeeds");
    final_displacement(dir.path())
}

#[test]
fn quasi_static_bar_with_belos_matches_the_native_direct_solve() {
    let direct = direct_bar();
    assert!(direct.iter().any(|u| u.abs() > 0.5 * PULL), "the bar moved");
    for (method, preconditioner) in [
        ("CG", "ILU"),
        ("CG", "ML"),
        ("CG", "Jacobi"),
        ("GMRES", "ILU"),
    ] {
        let solver = format!(
            "    Backend: \"Trilinos\"\n    Linear Solver: \"{method}\"\n    Linear Solver Preconditioner: \"{preconditioner}\"\n    Linear Solver Tolerance: 1.0e-12"
        );
        let dir = tempfile::tempdir().unwrap();
        run_deck(dir.path(), &bar_deck(&solver, PULL, SHEAR))
            .unwrap_or_else(|e| panic!("{method} + {preconditioner}: {e}"));
        let difference = largest_difference(&direct, &final_displacement(dir.path()));
        // Both runs stop Newton at ‖r‖₂ + 20‖r‖∞ ≤ 1 N on a stiffness of ~1e11 N/m (answers
        // within ~1e-11 m), and Belos solves each correction to 1e-12: 1e-8 of the 0.012 pull
        // is looser than both and far tighter than any wrong answer.
        assert!(
            difference < 1e-8 * PULL,
            "{method} + {preconditioner} differs from the direct solve by {difference:e}"
        );
    }
}

#[test]
fn peridyn_run_with_the_trilinos_backend_matches_the_native_direct_solve() {
    let direct = direct_bar();
    let dir = tempfile::tempdir().unwrap();
    let deck = dir.path().join("bar.yaml");
    let solver = "    Backend: \"Trilinos\"\n    Linear Solver: \"CG\"\n    Linear Solver Preconditioner: \"ML\"\n    Linear Solver Tolerance: 1.0e-12";
    std::fs::write(&deck, bar_deck(solver, PULL, SHEAR)).unwrap();
    let output = Command::new(env!("CARGO_BIN_EXE_peridyn"))
        .arg("run")
        .arg(&deck)
        .arg("--output-dir")
        .arg(dir.path())
        .arg("--threads")
        .arg("1")
        .output()
        .unwrap();
    let log = format!(
        "{}{}",
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    );
    assert!(output.status.success(), "peridyn run failed:\n{log}");
    let difference = largest_difference(&direct, &final_displacement(dir.path()));
    // As in the test above.
    assert!(difference < 1e-8 * PULL, "differs by {difference:e}\n{log}");
    // The solver CSV reports ML's builds: Belos refills the matrix at each Newton iteration
    // and ML is rebuilt on it, so a step builds at least one hierarchy per Newton iteration
    // (more if CG broke down and GMRES took over), and its time is counted.
    let csv = std::fs::read_to_string(dir.path().join("bar_solver.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let column = |row: &[&str], name: &str| -> f64 {
        let k = header
            .iter()
            .position(|h| *h == name)
            .unwrap_or_else(|| panic!("no {name} in {header:?}"));
        row[k].parse().unwrap()
    };
    let rows: Vec<&str> = lines.collect();
    // One row per load step of the deck.
    assert_eq!(rows.len(), 2, "{csv}");
    for line in rows {
        let row: Vec<&str> = line.split(',').collect();
        let newton = column(&row, "Newton_Iterations");
        assert!(newton >= 1.0, "{csv}");
        assert!(column(&row, "Preconditioner_Setups") >= newton, "{csv}");
        assert!(column(&row, "AMG_Levels") >= 1.0, "{csv}");
        assert!(column(&row, "Preconditioner_Setup_Seconds") > 0.0, "{csv}");
    }
}

#[test]
fn deck_choices_the_trilinos_backend_cannot_honour_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    for (solver, expected) in [
        (
            "    Backend: \"Trilinos\"\n    Linear Solver: \"LU\"",
            "Belos Krylov methods",
        ),
        (
            "    Backend: \"Trilinos\"\n    Linear Solver Preconditioner: \"Block 3x3\"",
            "native preconditioner",
        ),
        (
            "    Linear Solver Preconditioner: \"ML\"",
            "Backend: \"Trilinos\"",
        ),
    ] {
        let text = bar_deck(solver, PULL, SHEAR);
        let origin = dir.path().join("deck.yaml");
        let error = parse_str(&text, DeckFormat::Yaml, &origin)
            .expect_err(solver)
            .to_string();
        assert!(error.contains(expected), "{solver}: {error}");
        assert!(error.contains("deck.yaml"), "names the file: {error}");
    }
}

// ---- Belos parameters from the deck ----

#[test]
fn a_belos_parameter_replaces_the_setting_peridyn_derives() {
    use peridyn::backend::parameters::ParameterValue;
    let (matrix, rhs, _) = laplacian_problem(N);
    let mut solver = TrilinosLinearSolver::new(TrilinosSettings {
        belos_parameters: vec![
            ("Maximum Iterations".into(), ParameterValue::Int(5)),
            (
                "Convergence Tolerance".into(),
                ParameterValue::Double(1e-13),
            ),
        ],
        ..settings(BelosMethod::BlockCg, TrilinosPreconditioner::None)
    });
    let mut x = vec![0.0; N];
    match solver.solve(&matrix, &rhs, &mut x) {
        Err(SolveError::NotConverged {
            iterations,
            tolerance,
            ..
        }) => {
            // The Krylov settings allow N iterations to 1e-12; the Belos list wins.
            assert_eq!(iterations, 5);
            assert_eq!(tolerance, 1e-13);
        }
        other => panic!("expected NotConverged, got {other:?}"),
    }
}

#[test]
fn a_deck_belos_iteration_limit_reaches_belos() {
    let solver = "    Backend: \"Trilinos\"\n    Linear Solver: \"CG\"\n    Linear Solver Preconditioner: \"None\"\n    Linear Solver Tolerance: 1.0e-12";
    let dir = tempfile::tempdir().unwrap();
    run_deck(dir.path(), &bar_deck(solver, PULL, SHEAR)).expect("the bar solves without the limit");
    let limited = format!("{solver}\n    Belos:\n      Maximum Iterations: 2");
    let dir = tempfile::tempdir().unwrap();
    let error = run_deck(dir.path(), &bar_deck(&limited, PULL, SHEAR))
        .expect_err("two CG iterations cannot solve the bar")
        .to_string();
    assert!(error.contains("2 iterations"), "{error}");
}

// ---- ML with the rigid-body near-null space, and the Epetra matrix kept between solves ----

use peridyn::backend::native::{one_hop_operator, rigid_body_modes, OneHopInput, Stencil};
use peridyn::model::BondList;

/// A PMB block of n × n × n points (spacing 1 m, V = 1 m³, c = 1 N/m⁶, horizon 1.5 m: the 18
/// face and edge neighbours) with the face x = 0 clamped, as the reduced system Newton solves:
/// the stiffness over the free dofs, the point groups, and the six rigid-body modes (row-major).
/// At this horizon the one-hop operator keeps every bond, and for a bond-based material it is
/// the small-strain tangent itself.
fn clamped_pmb_block(n: usize) -> (Csr, Vec<usize>, Vec<f64>) {
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
                            if squared == 0
                                || squared > 2
                                || !(inside(nx) && inside(ny) && inside(nz))
                            {
                                continue;
                            }
                            bonds
                                .neighbor
                                .push(index(nx as usize, ny as usize, nz as usize) as u32);
                            bonds.reference_length.push((squared as f64).sqrt());
                        }
                    }
                }
                bonds.offsets.push(bonds.neighbor.len());
            }
        }
    }
    let points = position.len();
    let mut dof_index = vec![None; 3 * points];
    let (mut free, mut groups) = (Vec::new(), vec![0]);
    for (p, x) in position.iter().enumerate() {
        if x[0] == 0.0 {
            continue;
        }
        for c in 0..3 {
            dof_index[3 * p + c] = Some(free.len());
            free.push(3 * p + c);
        }
        groups.push(free.len());
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
        stencil: Stencil::Family,
    });
    (matrix, groups, rigid_body_modes(&position, &free))
}

/// A smooth load on every free dof of the block (N).
fn smooth_load(unknowns: usize) -> Vec<f64> {
    (0..unknowns)
        .map(|i| [1.0, 0.5, -0.25][i % 3] + (i as f64 * 0.01).sin() * 0.1)
        .collect()
}

#[test]
fn ml_with_the_rigid_body_modes_needs_fewer_cg_iterations_on_a_pmb_block() {
    let (matrix, groups, modes) = clamped_pmb_block(8);
    let rhs = smooth_load(matrix.nrows);
    let solve = |null_space: bool| {
        let mut solver =
            TrilinosLinearSolver::new(settings(BelosMethod::BlockCg, TrilinosPreconditioner::Ml));
        solver.set_point_groups(&groups);
        if null_space {
            solver.set_near_null_space(&modes, 6);
        }
        let mut x = vec![0.0; matrix.nrows];
        let report = solver
            .solve(&matrix, &rhs, &mut x)
            .expect("ML-CG converges");
        // One ML hierarchy per solve. ML's smoothed-aggregation defaults stop coarsening at
        // 128 unknowns ("coarse: max size"), so the block's 1,536 unknowns need at least two
        // levels, and the coarse levels add entries: operator complexity above 1.
        let setup = solver.take_preconditioner_setup();
        assert_eq!(setup.hierarchies, 1, "{setup:?}");
        assert!(setup.levels >= 2, "{setup:?}");
        assert!(setup.operator_complexity > 1.0, "{setup:?}");
        assert!(setup.seconds > 0.0, "{setup:?}");
        // Taken: the next report starts from nothing.
        assert_eq!(solver.take_preconditioner_setup().hierarchies, 0);
        (report.iterations, x)
    };
    let (without, x_without) = solve(false);
    let (with, x_with) = solve(true);
    eprintln!("ML-CG iterations on the clamped 8³ PMB block: {without} with ML's default null space (3 translations), {with} with the 6 rigid-body modes");
    // Both solve to 1e-12 relative; the answers agree far below any wrong answer.
    let scale = x_with.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(largest_difference(&x_with, &x_without) < 1e-8 * scale);
    // The rotations are near-null modes of elasticity that three constant vectors per point
    // do not span: without them the coarse space misses the bending of the block. Measured
    // (Trilinos 13.2, Debian 12, ML with peridyn's Chebyshev smoother): 22 CG iterations with
    // ML's default null space, 18 with the six rigid-body modes (16 and 10 with ML's default
    // Gauss-Seidel).
    assert!(
        with < without,
        "{with} iterations with the modes, {without} without"
    );
}

#[test]
fn a_matrix_of_the_kept_pattern_is_refilled_in_place_and_solved() {
    let (matrix, groups, modes) = clamped_pmb_block(4);
    let rhs = smooth_load(matrix.nrows);
    let mut solver =
        TrilinosLinearSolver::new(settings(BelosMethod::BlockCg, TrilinosPreconditioner::Ml));
    solver.set_point_groups(&groups);
    solver.set_near_null_space(&modes, 6);
    let mut x = vec![0.0; matrix.nrows];
    solver.solve(&matrix, &rhs, &mut x).expect("first solve");
    // Twice the stiffness, same pattern: the same Epetra matrix takes the new values, and the
    // answer halves (K' = 2K ⇒ x' = x/2).
    let mut doubled = matrix.clone();
    doubled.values.iter_mut().for_each(|v| *v *= 2.0);
    let mut half = vec![0.0; matrix.nrows];
    solver
        .solve(&doubled, &rhs, &mut half)
        .expect("refilled solve");
    assert_eq!(solver.matrices_built(), 1);
    let scale = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let halved: Vec<f64> = x.iter().map(|v| v / 2.0).collect();
    // Both solves reach 1e-12 relative residuals on a well-conditioned 4³ block.
    assert!(largest_difference(&half, &halved) < 1e-9 * scale);
    // Another pattern (the 1-D Laplacian) is a new matrix.
    let (laplacian, b, exact) = laplacian_problem(N);
    let mut u = vec![0.0; N];
    solver.set_point_groups(&(0..=N).collect::<Vec<_>>());
    // The Laplacian's near-null space: the constant (the block's modes are for other rows).
    solver.set_near_null_space(&[1.0; N], 1);
    solver.solve(&laplacian, &b, &mut u).expect("new pattern");
    assert_eq!(solver.matrices_built(), 2);
    assert!(max_relative_error(&u, &exact) < 1e-8);
}

#[test]
fn a_near_null_space_for_other_rows_is_refused_by_name() {
    let (matrix, groups, modes) = clamped_pmb_block(4);
    let rhs = smooth_load(matrix.nrows);
    let mut solver =
        TrilinosLinearSolver::new(settings(BelosMethod::BlockCg, TrilinosPreconditioner::Ml));
    solver.set_point_groups(&groups);
    // Six modes over one point too few: built for other unknowns than the matrix's.
    let short = &modes[..modes.len() - 18];
    solver.set_near_null_space(short, 6);
    let mut x = vec![0.0; matrix.nrows];
    let error = solver
        .solve(&matrix, &rhs, &mut x)
        .expect_err("a near-null space of the wrong length")
        .to_string();
    let (values, needed) = (short.len(), 6 * matrix.nrows);
    assert!(
        error.contains("near-null space")
            && error.contains(&format!("{values} values"))
            && error.contains(&format!("{} rows need {needed}", matrix.nrows)),
        "{error}"
    );
    assert!(error.contains("Belos BlockCG + ML"), "{error}");
    assert_eq!(
        solver.matrices_built(),
        0,
        "refused before Epetra was asked"
    );
    // Offering no null space (0 modes) takes the wrong one back: ML's default then solves.
    solver.set_near_null_space(&[], 0);
    solver
        .solve(&matrix, &rhs, &mut x)
        .expect("ML without the modes");
}
