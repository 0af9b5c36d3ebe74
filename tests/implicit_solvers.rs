//! Implicit solvers against known answers: Newmark-β on a two-point oscillator against the
//! exact Newmark recurrence, quasi-static bars solved by every native strategy, quadratic
//! convergence of Newton, load-step cutting and a load the body cannot carry.

use peridyn::io::deck::{parse_str, DeckFormat};
use peridyn::io::exodus::ExodusFile;
use peridyn::setup;
use peridyn::solver::collective::SerialRun;
use peridyn::solver::implicit::{DofMap, ImplicitSystem};
use peridyn::solver::newton::{self, ConvergenceMeasure, NewtonSettings};
use peridyn::solver::problem::Physical;
use peridyn::state::State;
use std::path::Path;

mod quasi_static_bar;
use quasi_static_bar::{bar_deck, run_deck, solver_report};

/// Index of a nodal variable component (`DisplacementX` …) in an output file.
fn nodal(file: &ExodusFile, name: &str) -> usize {
    file.nodal_variable_names
        .iter()
        .position(|n| n == name)
        .unwrap_or_else(|| panic!("no nodal variable {name}"))
}

/// Two points one unit apart (ρ = V = ζ = 1) moving apart at ±0.005 along the bond.
fn newmark_deck(beta: f64, gamma: f64, dt: f64, steps: usize) -> String {
    format!(
        r#"Peridigm:
  Discretization:
    Type: "Text File"
    Input Mesh File: "two_points.txt"
  Materials:
    Stuff:
      Material Model: "Elastic Bond Based"
      Bulk Modulus: 1.0
      Density: 1.0
  Blocks:
    Both:
      Block Names: "block_1"
      Material: "Stuff"
      Horizon: 1.5
  Boundary Conditions:
    Left Node Set: "1"
    Right Node Set: "2"
    Left Velocity:
      Type: "Initial Velocity"
      Node Set: "Left Node Set"
      Coordinate: "x"
      Value: "-0.005"
    Right Velocity:
      Type: "Initial Velocity"
      Node Set: "Right Node Set"
      Coordinate: "x"
      Value: "0.005"
  Solver:
    Final Time: {final_time}
    Implicit:
      Fixed dt: {dt}
      Beta: {beta}
      Gamma: {gamma}
      Absolute Tolerance: 1.0e-15
      Maximum Solver Iterations: 5
  Output:
    Output Filename: "two_points"
    Output Frequency: 1
    Output Variables:
      Displacement: true
      Velocity: true
"#,
        final_time = dt * steps as f64 + 0.5 * dt
    )
}

/// Newmark-β iterates (extension e, rate ė) of ë = −ω²e from e(0) = 0, ė(0) = v0, a(0) = 0:
/// ẽ = e + Δt ė + ½Δt²(1 − 2β)a, e' = ẽ/(1 + βΔt²ω²), a' = −ω²e', ė' = ė + Δt((1 − γ)a + γa').
fn newmark_recurrence(
    omega2: f64,
    dt: f64,
    beta: f64,
    gamma: f64,
    v0: f64,
    steps: usize,
) -> Vec<(f64, f64)> {
    let (mut e, mut v, mut a) = (0.0, v0, 0.0);
    let mut out = vec![(e, v)];
    for _ in 0..steps {
        let predictor = e + dt * v + 0.5 * dt * dt * (1.0 - 2.0 * beta) * a;
        let e_next = predictor / (1.0 + beta * dt * dt * omega2);
        let a_next = -omega2 * e_next;
        v += dt * ((1.0 - gamma) * a + gamma * a_next);
        e = e_next;
        a = a_next;
        out.push((e, v));
    }
    out
}

#[test]
fn newmark_two_point_oscillator_follows_the_newmark_recurrence_and_conserves_energy() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("two_points.txt"),
        "0 0 0 1 1.0\n1 0 0 1 1.0\n",
    )
    .unwrap();
    let (beta, gamma, dt, steps) = (0.25, 0.5, 0.2, 200);
    run_deck(dir.path(), &newmark_deck(beta, gamma, dt, steps)).expect("run succeeds");
    let file = ExodusFile::open(&dir.path().join("two_points.e")).unwrap();
    assert_eq!(file.times.len(), steps + 1);
    // PMB along the bond: each point feels c·e (c = 18K/(πδ⁴), V = ζ = 1), so the extension
    // obeys ë = −2c e; its initial rate is 0.005 − (−0.005) = 0.01.
    let c = 18.0 / (std::f64::consts::PI * 1.5f64.powi(4));
    let omega2 = 2.0 * c;
    let expected = newmark_recurrence(omega2, dt, beta, gamma, 0.01, steps);
    let (ux, vx) = (nodal(&file, "DisplacementX"), nodal(&file, "VelocityX"));
    let mut worst: f64 = 0.0;
    let energy = |e: f64, v: f64| 0.5 * v * v + 0.5 * omega2 * e * e;
    let initial_energy = energy(0.0, 0.01);
    let mut worst_energy: f64 = 0.0;
    for (step, &(e, _)) in expected.iter().enumerate() {
        let u = file.nodal_values(step, ux).unwrap();
        let w = file.nodal_values(step, vx).unwrap();
        worst = worst.max((u[1] - u[0] - e).abs());
        let simulated = energy(u[1] - u[0], w[1] - w[0]);
        worst_energy = worst_energy.max((simulated - initial_energy).abs() / initial_energy);
    }
    // The force is linear in e along the bond and Newton solves each step to round-off (the
    // tolerance 1e-15 is below the 1e-2 amplitude's last digits), so the run follows the
    // recurrence to round-off.
    assert!(
        worst < 1e-12,
        "largest deviation from the Newmark recurrence: {worst:e}"
    );
    // The average-acceleration rule (β = ¼, γ = ½) conserves ½ė² + ½ω²e² exactly for a
    // linear oscillator; what is left is round-off.
    assert!(
        worst_energy < 1e-10,
        "relative energy drift {worst_energy:e}"
    );
}

const QUASI_STATIC: &str = "    Final Time: 1.0
    QuasiStatic:
      Number of Load Steps: {steps}
      Absolute Tolerance: 1.0
      Maximum Solver Iterations: 20";

/// Final displacement of every point and the final force field from a bar run.
fn final_fields(dir: &Path) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
    let file = ExodusFile::open(&dir.join("bar.e")).unwrap();
    let last = file.times.len() - 1;
    let read = |prefix: &str| -> Vec<[f64; 3]> {
        let c: Vec<Vec<f64>> = ["X", "Y", "Z"]
            .iter()
            .map(|x| {
                file.nodal_values(last, nodal(&file, &format!("{prefix}{x}")))
                    .unwrap()
            })
            .collect();
        (0..c[0].len())
            .map(|i| [c[0][i], c[1][i], c[2][i]])
            .collect()
    };
    (read("Displacement"), read("Force"))
}

fn solve_bar(solver: &str, pull: f64, shear: f64, steps: usize) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
    let dir = tempfile::tempdir().unwrap();
    run_deck(dir.path(), &bar_deck(solver, pull, shear, steps)).expect("quasi-static run succeeds");
    final_fields(dir.path())
}

fn largest_difference(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    a.iter()
        .zip(b)
        .flat_map(|(x, y)| (0..3).map(move |k| (x[k] - y[k]).abs()))
        .fold(0.0, f64::max)
}

#[test]
fn quasi_static_bar_is_the_same_for_every_native_strategy_and_its_reactions_balance() {
    let (pull, shear) = (0.012, 0.004);
    let (direct, force) = solve_bar(QUASI_STATIC, pull, shear, 2);
    let scale = pull;
    // Equilibrium: the free points carry no net force, so the reactions on the two faces are
    // equal and opposite (Σ V f = 0 over the body, pairwise antisymmetric bond forces).
    let sum = |points: std::ops::Range<usize>| -> [f64; 3] {
        let mut s = [0.0; 3];
        for i in points {
            for k in 0..3 {
                s[k] += force[i][k];
            }
        }
        s
    };
    let total = sum(0..force.len());
    let left: [f64; 3] = (0..9).fold([0.0; 3], |mut s, k| {
        for c in 0..3 {
            s[c] += force[12 * k][c];
        }
        s
    });
    let right: [f64; 3] = (0..9).fold([0.0; 3], |mut s, k| {
        for c in 0..3 {
            s[c] += force[12 * k + 11][c];
        }
        s
    });
    // In tension the bar pulls its held left face towards +x and its pulled right face back.
    assert!(
        left[0] > 0.0 && right[0] < 0.0,
        "the bar is in tension: {left:?} {right:?}"
    );
    for c in 0..3 {
        assert!(
            (left[c] + right[c]).abs() < 1e-6 * right[0].abs(),
            "reactions {left:?} vs {right:?}"
        );
        assert!(
            total[c].abs() < 1e-6 * right[0].abs(),
            "net force {total:?}"
        );
    }
    for strategy in [
        "    Final Time: 1.0
    Linear Solver: \"CG\"
    Linear Solver Preconditioner: \"Block 3x3\"
    Linear Solver Tolerance: 1.0e-12
    QuasiStatic:
      Number of Load Steps: {steps}
      Absolute Tolerance: 1.0
      Maximum Solver Iterations: 20",
        "    Final Time: 1.0
    Linear Solver: \"GMRES\"
    Linear Solver Preconditioner: \"Jacobi\"
    Linear Solver Tolerance: 1.0e-12
    QuasiStatic:
      Number of Load Steps: {steps}
      Absolute Tolerance: 1.0
      Maximum Solver Iterations: 20",
        "    Final Time: 1.0
    Linear Solver: \"LU\"
    QuasiStatic:
      Number of Load Steps: {steps}
      Absolute Tolerance: 1.0
      Maximum Solver Iterations: 20",
        "    Final Time: 1.0
    Linear Solver: \"CG\"
    Linear Solver Preconditioner: \"AMG\"
    Linear Solver Tolerance: 1.0e-12
    QuasiStatic:
      Number of Load Steps: {steps}
      Absolute Tolerance: 1.0
      Maximum Solver Iterations: 20",
        "    Final Time: 1.0
    Linear Solver: \"GMRES\"
    Linear Solver Preconditioner: \"AMG\"
    Linear Solver Tolerance: 1.0e-12
    QuasiStatic:
      Number of Load Steps: {steps}
      Absolute Tolerance: 1.0
      Maximum Solver Iterations: 20",
        "    Final Time: 1.0
    Peridigm Preconditioner: \"AMG\"
    NOXQuasiStatic:
      Number of Load Steps: {steps}
      Absolute Tolerance: 1.0
      Max Solver Iterations: 30
      Direction:
        Method: \"Newton\"
        Newton:
          Linear Solver:
            Jacobian Operator: \"Matrix-Free\"",
        "    Final Time: 1.0
    Peridigm Preconditioner: \"Block 3x3\"
    NOXQuasiStatic:
      Number of Load Steps: {steps}
      Absolute Tolerance: 1.0
      Max Solver Iterations: 30
      Direction:
        Method: \"Newton\"
        Newton:
          Linear Solver:
            Jacobian Operator: \"Matrix-Free\"",
    ] {
        let (other, _) = solve_bar(strategy, pull, shear, 2);
        let difference = largest_difference(&direct, &other);
        // Every strategy stops at ‖r‖₂ + 20‖r‖∞ ≤ 1 N (1e-9 of the 3.5e9 N reaction; the
        // round-off floor of this residual is ~1e-2 N) on a body whose stiffness is ~1e11 N/m,
        // so their answers agree to ~1e-11 m; 1e-8 relative to the 0.012 pull is looser than
        // that and far tighter than any wrong answer.
        assert!(
            difference < 1e-8 * scale,
            "strategy\n{strategy}\ndiffers from the direct solve by {difference:e}"
        );
    }
}

#[test]
fn newton_converges_quadratically_on_a_large_stretch_and_shear() {
    // A 30 % pull with a shear of a sixth of the bar's length in one load step: the force is
    // strongly nonlinear in u, and Newton starts from the undeformed interior.
    let text = bar_deck(QUASI_STATIC, 3.6, 2.0, 1);
    let dir = tempfile::tempdir().unwrap();
    let origin = dir.path().join("deck.yaml");
    let deck = parse_str(&text, DeckFormat::Yaml, &origin).unwrap();
    let model = setup::build(&deck).unwrap();
    let mut physics = setup::build_physics(&deck, &model).unwrap();
    let mut state = State::at_rest(&model.points.position, 0.0, false)
        .with_bond_damage(physics.has_bond_damage().then(|| model.bonds.num_bonds()));
    let constrained = model.boundary.constrained_dofs();
    let start = state.displacement.clone();
    {
        let displacement = &mut state.displacement;
        model
            .boundary
            .prescribed_increments(&model.points.position, &start, 0.0, 1.0, |p, c, du| {
                displacement[p][c] += du
            })
            .unwrap();
    }
    let mut system = ImplicitSystem::new(
        DofMap::new(model.points.len(), &constrained, &[]),
        &mut state,
    );
    let list = peridyn::setup::solvers::solver_list(&deck.solvers[0], false);
    let solve = list.integrator.solve().expect("an implicit list");
    let mut linear = peridyn::solver::linear::strategy(solve, model.points.len()).unwrap();
    let settings = NewtonSettings {
        max_iterations: 25,
        tolerance: 0.0,
        measure: ConvergenceMeasure::TwoNorm,
        line_search: true,
        print_iterations: true,
        verbose: true,
    };
    let mut serial = SerialRun {
        points: model.points.len(),
    };
    let parts = Physical {
        system: &mut system,
        model: &model,
        physics: &mut physics,
        state: &mut state,
        collective: &mut serial,
        constrained: &constrained,
    };
    let report = newton::solve(parts, &mut linear, &settings).unwrap();
    let r = &report.residual_history;
    eprintln!("residual history: {r:?}");
    // Order estimates p_k = ln(r_{k+1}/r_k) / ln(r_k/r_{k−1}) over the iterations where the
    // residual is between 1e-1 and 1e-11 of the start (the asymptotic range above round-off).
    let r0 = r[0];
    let orders: Vec<f64> = (1..r.len() - 1)
        .filter(|&k| r[k] < 1e-1 * r0 && r[k + 1] > 1e-11 * r0)
        .map(|k| (r[k + 1] / r[k]).ln() / (r[k] / r[k - 1]).ln())
        .collect();
    eprintln!("order estimates: {orders:?}");
    // Quadratic convergence: the order reaches ≈ 2 once Newton is in its basin (an exact
    // tangent; an inexact one would give 1).
    let best = orders.iter().cloned().fold(0.0, f64::max);
    assert!(best > 1.8, "no quadratic step in {r:?} (orders {orders:?})");
    assert!(
        *r.last().unwrap() < 1e-9 * r0,
        "Newton did not reach round-off: {r:?}"
    );
}

#[test]
fn a_body_that_cannot_carry_its_load_stops_with_exit_code_3_and_valid_output() {
    // Body force on a bar held nowhere: no equilibrium exists (rigid-body motion is free), so
    // the stiffness is singular and both factorizations fail.
    let text = bar_deck(QUASI_STATIC, 0.0, 0.0, 1)
        .replace("Type: \"Prescribed Displacement\"", "Type: \"Body Force\"")
        .replace("Value: \"0*t\"", "Value: \"1.0e6\"");
    let dir = tempfile::tempdir().unwrap();
    let error = run_deck(dir.path(), &text).expect_err("no equilibrium exists");
    assert_eq!(error.exit_code(), 3, "{error}");
    let file = ExodusFile::open(&dir.path().join("bar.e")).expect("the output stays readable");
    assert_eq!(file.times, vec![0.0], "only the initial frame was written");
}

/// A 30 % pull with shear in one load step that Newton cannot finish in 4 iterations.
const HARD_STEP: &str = "    Final Time: 1.0
    QuasiStatic:
      Number of Load Steps: {steps}
      Absolute Tolerance: 1.0
      Maximum Solver Iterations: 4
      Adaptive Load-Stepping:
        Maximum load step reductions in one step: 6";

#[test]
fn a_load_step_that_cannot_converge_is_cut_and_then_succeeds() {
    let dir = tempfile::tempdir().unwrap();
    run_deck(dir.path(), &bar_deck(HARD_STEP, 3.6, 2.0, 1)).expect("the cut steps converge");
    let file = ExodusFile::open(&dir.path().join("bar.e")).unwrap();
    // Every accepted step is written: the one step became several shorter ones, ending at 1.
    assert!(
        file.times.len() > 2,
        "the step was not cut: times {:?}",
        file.times
    );
    assert_eq!(*file.times.last().unwrap(), 1.0);
    assert!(file.times.windows(2).all(|w| w[1] > w[0]));
    let (cut, _) = final_fields(dir.path());
    // The elastic answer does not depend on the path: 16 even steps with a generous iteration
    // limit reach the same equilibrium (both to ‖r‖ ≤ 1 N on a ~1e11 N/m body).
    let (reference, _) = solve_bar(&QUASI_STATIC.replace("20", "40"), 3.6, 2.0, 16);
    let difference = largest_difference(&cut, &reference);
    assert!(difference < 1e-8 * 3.6, "cut run differs by {difference:e}");
}

#[test]
fn a_load_step_that_cannot_converge_without_adaptive_stepping_stops_with_exit_code_3() {
    let dir = tempfile::tempdir().unwrap();
    let deck = bar_deck(HARD_STEP, 3.6, 2.0, 1).replace(
        "      Adaptive Load-Stepping:\n        Maximum load step reductions in one step: 6",
        "",
    );
    let error = run_deck(dir.path(), &deck).expect_err("one step of 4 iterations is not enough");
    assert_eq!(error.exit_code(), 3);
    let message = error.to_string();
    assert!(
        message.contains("load step 1") && message.contains("did not converge"),
        "{message}"
    );
    let file = ExodusFile::open(&dir.path().join("bar.e")).expect("the output stays readable");
    assert_eq!(file.times, vec![0.0]);
}

#[test]
fn switch_to_verlet_continues_explicitly_when_cutting_is_not_allowed() {
    let dir = tempfile::tempdir().unwrap();
    // No cut allowed: the one hard step fails, the state goes back to t = 0 and Verlet
    // carries the prescribed motion to the final time.
    let deck = bar_deck(HARD_STEP, 3.6, 2.0, 1).replace(
        "Maximum load step reductions in one step: 6",
        "Maximum load step reductions in one step: 0\n        Switch to Verlet:\n          Safety Factor: 0.5",
    );
    let summary = run_deck(dir.path(), &deck).expect("the explicit continuation finishes");
    let file = ExodusFile::open(&dir.path().join("bar.e")).unwrap();
    // Verlet with Δt = 0.5 × the stable estimate of a steel bar (~1e-4 s at unit spacing)
    // takes thousands of steps over 1 s; every one is a frame after the initial QS frame.
    assert!(summary.steps > 100, "{summary:?}");
    assert_eq!(file.times[0], 0.0);
    assert!(*file.times.last().unwrap() <= 1.0 && *file.times.last().unwrap() > 0.99);
}

#[test]
fn a_point_without_bonds_is_held_instead_of_making_the_stiffness_singular() {
    let dir = tempfile::tempdir().unwrap();
    // A 6 × 2 × 2 bar (ids 1–24, x fastest) and one point far away (id 25) with no family.
    let mut mesh = String::new();
    for k in 0..2 {
        for j in 0..2 {
            for i in 0..6 {
                mesh.push_str(&format!("{i} {j} {k} 1 1.0\n"));
            }
        }
    }
    mesh.push_str("100 0 0 1 1.0\n");
    std::fs::write(dir.path().join("bar.txt"), mesh).unwrap();
    let ids = |x: usize| -> String {
        (0..4)
            .map(|r| (1 + x + 6 * r).to_string())
            .collect::<Vec<_>>()
            .join(" ")
    };
    let deck = format!(
        r#"Peridigm:
  Discretization:
    Type: "Text File"
    Input Mesh File: "bar.txt"
  Materials:
    Steel:
      Material Model: "Elastic"
      Density: 7800.0
      Bulk Modulus: 130.0e9
      Shear Modulus: 78.0e9
  Blocks:
    Bar:
      Block Names: "block_1"
      Material: "Steel"
      Horizon: 1.8
  Boundary Conditions:
    Left Node Set: "{left}"
    Right Node Set: "{right}"
    Hold X: {{Type: "Prescribed Displacement", Node Set: "Left Node Set", Coordinate: "x", Value: "0.0"}}
    Hold Y: {{Type: "Prescribed Displacement", Node Set: "Left Node Set", Coordinate: "y", Value: "0.0"}}
    Hold Z: {{Type: "Prescribed Displacement", Node Set: "Left Node Set", Coordinate: "z", Value: "0.0"}}
    Pull X: {{Type: "Prescribed Displacement", Node Set: "Right Node Set", Coordinate: "x", Value: "0.001*t"}}
  Solver:
    Final Time: 1.0
    QuasiStatic:
      Number of Load Steps: 1
      Absolute Tolerance: 1.0
      Maximum Solver Iterations: 10
  Output:
    Output Filename: "bar"
    Output Frequency: 1
    Output Variables:
      Displacement: true
"#,
        left = ids(0),
        right = ids(5)
    );
    run_deck(dir.path(), &deck).expect("the isolated point is held, not singular");
    let file = ExodusFile::open(&dir.path().join("bar.e")).unwrap();
    let ux = file.nodal_values(1, nodal(&file, "DisplacementX")).unwrap();
    // Output is in input order: the isolated point is the last one and stays where it was;
    // the pulled face moved by the prescribed 0.001.
    assert_eq!(ux[24], 0.0);
    assert!((ux[5] - 0.001).abs() < 1e-15);
}

#[test]
fn the_solver_report_shows_one_amg_setup_for_the_run_and_the_gmres_restart() {
    // Jacobian-free Newton–Krylov + AMG on the bar (no damage model, so no bond breaks): the
    // hierarchy is built at the first linear solve of the run and reused by every later
    // Newton iteration and load step (its inputs, the unknowns and the damage, never change).
    let jfnk_amg = "    Final Time: 1.0
    Peridigm Preconditioner: \"AMG\"
    NOXQuasiStatic:
      Number of Load Steps: {steps}
      Absolute Tolerance: 1.0
      Max Solver Iterations: 30
      Direction:
        Method: \"Newton\"
        Newton:
          Linear Solver:
            Jacobian Operator: \"Matrix-Free\"";
    let dir = tempfile::tempdir().unwrap();
    run_deck(dir.path(), &bar_deck(jfnk_amg, 0.012, 0.004, 2)).expect("JFNK + AMG runs");
    let rows = solver_report(dir.path(), "bar");
    assert_eq!(rows.len(), 2, "{rows:?}");
    // The first step starts from rest and needs several Newton iterations (the second
    // starts from the predictor and may need one): one setup served them all, and the
    // second step built none.
    assert!(rows[0]["Newton_Iterations"] >= 2.0, "{rows:?}");
    assert_eq!(rows[0]["Preconditioner_Setups"], 1.0, "{rows:?}");
    assert!(rows[0]["Preconditioner_Setup_Seconds"] > 0.0, "{rows:?}");
    assert_eq!(rows[1]["Preconditioner_Setups"], 0.0, "{rows:?}");
    assert_eq!(rows[1]["Preconditioner_Setup_Seconds"], 0.0, "{rows:?}");
    for row in &rows {
        assert_eq!(row["Broken_Bonds"], 0.0, "{row:?}");
        // 99 free points × 3 = 297 unknowns, below the 1000-unknown coarse limit: the
        // hierarchy is the one-hop operator itself, solved by LU (1 level, complexity 1);
        // the second step reports the hierarchy it reused.
        assert_eq!(row["AMG_Levels"], 1.0, "{row:?}");
        assert_eq!(row["AMG_Operator_Complexity"], 1.0, "{row:?}");
        // KrylovSettings' default restart (Peridigm's BlockGMRES default).
        assert_eq!(row["GMRES_Restart"], 500.0, "{row:?}");
        assert_eq!(row["Tangent_Bytes"], 0.0, "{row:?}");
    }
    // A direct solve has no preconditioner to report.
    let direct = "    Final Time: 1.0
    Linear Solver: \"LU\"
    QuasiStatic:
      Number of Load Steps: {steps}
      Absolute Tolerance: 1.0
      Maximum Solver Iterations: 20";
    let dir = tempfile::tempdir().unwrap();
    run_deck(dir.path(), &bar_deck(direct, 0.012, 0.004, 1)).expect("LU runs");
    let row = &solver_report(dir.path(), "bar")[0];
    for column in [
        "Preconditioner_Setup_Seconds",
        "Preconditioner_Setups",
        "AMG_Levels",
        "AMG_Operator_Complexity",
        "GMRES_Restart",
    ] {
        assert_eq!(row[column], 0.0, "{column}: {row:?}");
    }
}

#[test]
fn check_plans_the_amg_operator_and_hierarchy_only_for_decks_that_ask_for_amg() {
    let parts = |solver: &str| -> Vec<(String, u64)> {
        let dir = tempfile::tempdir().unwrap();
        let text = bar_deck(solver, 0.012, 0.0, 1);
        let origin = dir.path().join("deck.yaml");
        let deck = parse_str(&text, DeckFormat::Yaml, &origin).unwrap();
        let model = setup::build(&deck).unwrap();
        let plan = setup::plan(&deck, &model).unwrap();
        plan.memory.into_iter().map(|m| (m.part, m.bytes)).collect()
    };
    let jfnk_amg = parts(
        "    Final Time: 1.0
    Peridigm Preconditioner: \"AMG\"
    NOXQuasiStatic:
      Number of Load Steps: 1
      Direction:
        Method: \"Newton\"
        Newton:
          Linear Solver:
            Jacobian Operator: \"Matrix-Free\"",
    );
    let names: Vec<&str> = jfnk_amg.iter().map(|(p, _)| p.as_str()).collect();
    for part in [
        "one-hop operator (AMG setup)",
        "AMG setup products",
        "AMG hierarchy",
        "GMRES basis (at most)",
    ] {
        assert!(names.contains(&part), "{part} missing from {names:?}");
    }
    // The bar has 108 points, 324 dofs: the basis holds min(restart 500, iteration limit =
    // the 324 dofs) + 1 = 325 vectors of 324 values of 8 bytes.
    let basis = jfnk_amg
        .iter()
        .find(|(p, _)| p == "GMRES basis (at most)")
        .unwrap()
        .1;
    assert_eq!(basis, 325 * 324 * 8);
    // Assembled CG + AMG plans the tangent and the AMG, and no GMRES basis.
    let cg_amg = parts(
        "    Final Time: 1.0
    Linear Solver: \"CG\"
    Linear Solver Preconditioner: \"AMG\"
    QuasiStatic:
      Number of Load Steps: 1",
    );
    let names: Vec<&str> = cg_amg.iter().map(|(p, _)| p.as_str()).collect();
    assert!(names.contains(&"AMG hierarchy"), "{names:?}");
    assert!(!names.contains(&"GMRES basis (at most)"), "{names:?}");
    // A direct solve ignores the AMG preconditioner, so nothing is planned for it.
    let direct = parts(
        "    Final Time: 1.0
    Linear Solver: \"LU\"
    Linear Solver Preconditioner: \"AMG\"
    QuasiStatic:
      Number of Load Steps: 1",
    );
    assert!(direct.iter().all(|(p, _)| !p.contains("AMG")), "{direct:?}");
}

#[test]
fn check_plans_the_gmres_basis_with_the_restart_nox_runs() {
    // The planned GMRES basis of a Jacobian-free NOXQuasiStatic list on the Trilinos backend,
    // or `None` when nothing is planned for it; `linear_keys` go into NOX's linear solver list.
    let basis = |linear_keys: &str| -> Option<u64> {
        let solver = format!(
            "    Final Time: 1.0
    Peridigm Preconditioner: \"Block 3x3\"
    NOXQuasiStatic:
      Number of Load Steps: 1
      Direction:
        Method: \"Newton\"
        Newton:
          Linear Solver:
            Jacobian Operator: \"Matrix-Free\"{linear_keys}"
        );
        let dir = tempfile::tempdir().unwrap();
        let text = bar_deck(&solver, 0.012, 0.0, 1);
        let mut deck = parse_str(&text, DeckFormat::Yaml, &dir.path().join("deck.yaml")).unwrap();
        // What `Backend: "Trilinos"` reads to, set here so that a build without the feature
        // plans it too (NOX runs the list).
        deck.solvers[0].linear_solve.backend = peridyn::io::deck::LinearBackend::TRILINOS_DEFAULT;
        let model = setup::build(&deck).unwrap();
        let plan = setup::plan(&deck, &model).unwrap();
        plan.memory
            .into_iter()
            .find(|m| m.part == "GMRES basis (at most)")
            .map(|m| m.bytes)
    };
    // The bar's 108 points have 324 dofs of 8 bytes. NOX's AztecOO GMRES restarts at its
    // `Size of Krylov Subspace`, 300 by default (NOX::Epetra::LinearSystemAztecOO), and stops
    // at `Max Iterations`, 400 by default: min(300, 400) + 1 vectors, not the native 500.
    assert_eq!(basis(""), Some(301 * 324 * 8));
    assert_eq!(
        basis("\n            Size of Krylov Subspace: 50"),
        Some(51 * 324 * 8)
    );
    // An iteration limit below the restart bounds the basis.
    assert_eq!(
        basis("\n            Size of Krylov Subspace: 50\n            Max Iterations: 20"),
        Some(21 * 324 * 8)
    );
    // AztecOO's CG keeps no GMRES basis.
    assert_eq!(basis("\n            Aztec Solver: \"CG\""), None);
}
