//! Explicit dynamics against known answers: a two-point oscillator against the exact discrete
//! velocity-Verlet recurrence, the wave speed of a bar, energy conservation, and the
//! stability monitor.

use peridyn::io::deck::{parse_str, DeckFormat};
use peridyn::io::exodus::ExodusFile;
use peridyn::setup;
use peridyn::simulation::{self, RunError, RunSummary};
use std::path::Path;

fn run_deck(dir: &Path, text: &str) -> Result<RunSummary, RunError> {
    let origin = dir.join("deck.yaml");
    std::fs::write(&origin, text).unwrap();
    let deck = parse_str(text, DeckFormat::Yaml, &origin).expect("deck loads");
    let model = setup::build(&deck).expect("model builds");
    simulation::run(&deck, &model, dir)
}

/// Two points one unit apart, the second displaced by `stretch` along the bond, no other
/// loading; output every step.
fn two_point_deck(material: &str, dt: f64, steps: usize) -> String {
    format!(
        r#"Peridigm:
  Discretization:
    Type: "Text File"
    Input Mesh File: "two_points.txt"
  Materials:
    Stuff:
      {material}
      Density: 1.0
  Blocks:
    Both:
      Block Names: "block_1"
      Material: "Stuff"
      Horizon: 1.5
  Boundary Conditions:
    Right Node Set: "2"
    Stretch:
      Type: "Initial Displacement"
      Node Set: "Right Node Set"
      Coordinate: "x"
      Value: "0.01"
  Solver:
    Final Time: {final_time}
    Verlet:
      Fixed dt: {dt}
  Output:
    Output Filename: "two_points"
    Output Frequency: 1
    Output Variables:
      Displacement: true
"#,
        final_time = dt * steps as f64 + 0.5 * dt
    )
}

/// Exact velocity-Verlet iterates of ë = −ω²e from e(0) = e0, ė(0) = 0.
fn verlet_recurrence(omega2: f64, dt: f64, e0: f64, steps: usize) -> Vec<f64> {
    let (mut e, mut v) = (e0, 0.0);
    let mut out = vec![e];
    for _ in 0..steps {
        let a = -omega2 * e;
        let half = v + 0.5 * dt * a;
        e += dt * half;
        v = half + 0.5 * dt * (-omega2 * e);
        out.push(e);
    }
    out
}

fn check_oscillator(material: &str, omega2: f64, dt: f64) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("two_points.txt"),
        "0 0 0 1 1.0\n1 0 0 1 1.0\n",
    )
    .unwrap();
    let steps = 1000;
    run_deck(dir.path(), &two_point_deck(material, dt, steps)).expect("run succeeds");
    let file = ExodusFile::open(&dir.path().join("two_points.e")).unwrap();
    assert_eq!(file.times.len(), steps + 1);
    let expected = verlet_recurrence(omega2, dt, 0.01, steps);
    let mut worst: f64 = 0.0;
    for (step, e_exact) in expected.iter().enumerate() {
        let ux = file.nodal_values(step, 0).unwrap();
        // Relative displacement of the pair = extension of the bond (motion stays on the axis).
        worst = worst.max((ux[1] - ux[0] - e_exact).abs());
    }
    // The force is exactly linear in e for motion along the bond, so the run must follow the
    // recurrence to round-off; |Y| − ζ loses ~1e-14 of the 1e-2 amplitude per evaluation.
    assert!(
        worst < 1e-11,
        "largest deviation from the Verlet recurrence: {worst:e}"
    );
}

#[test]
fn two_point_pmb_oscillator_follows_discrete_verlet() {
    // PMB: c = 18K/(πδ⁴); each point feels c·(e/ζ)·V toward the other, so the extension obeys
    // ë = −ω²e with ω² = 2cV/(ζρ) (ζ = V = ρ = K = 1, δ = 1.5).
    let c = 18.0 / (std::f64::consts::PI * 1.5f64.powi(4));
    check_oscillator(
        "Material Model: \"Elastic Bond Based\"\n      Bulk Modulus: 1.0",
        2.0 * c,
        0.05,
    );
}

#[test]
fn two_point_microplastic_oscillator_below_yield_is_the_pmb_oscillator() {
    // `Microplastic Bond Based` with the PMB constants above and s_Y = 0.02: the 1 % stretch
    // never reaches yield, s̄ stays 0 through the explicit commits, and the run is the PMB
    // oscillator.
    let c = 18.0 / (std::f64::consts::PI * 1.5f64.powi(4));
    check_oscillator(
        "Material Model: \"Microplastic Bond Based\"\n      Bulk Modulus: 1.0\n      Yield Stretch: 0.02",
        2.0 * c,
        0.05,
    );
}

#[test]
fn two_point_lps_oscillator_follows_discrete_verlet() {
    // LPS with one bond: m = ζ²V, θ = 3e/ζ, t = (3K − 5μ)θζ/m + 15μe/m = 9Ke/(ζ²V) from each
    // end, so each point feels 2·9Ke/ζ² and ë = −ω²e with ω² = 36K/(ζ²ρ) = 36.
    check_oscillator(
        "Material Model: \"Elastic\"\n      Bulk Modulus: 1.0\n      Shear Modulus: 0.6",
        36.0,
        0.01,
    );
}

/// A 1 m × 5 cm × 5 cm steel bar of 100 × 5 × 5 points; its left face moves at 1 m/s from t = 0.
fn bar_deck(output: &str) -> String {
    let (nx, ny, nz) = (100, 5, 5);
    let left: Vec<String> = (0..nz)
        .flat_map(|k| (0..ny).map(move |j| (1 + nx * (j + ny * k)).to_string()))
        .collect();
    format!(
        r#"Peridigm:
  Discretization:
    Type: "PdQuickGrid"
    NeighborhoodType: "Spherical"
    TensorProduct3DMeshGenerator:
      X Origin: 0.0
      Y Origin: -0.025
      Z Origin: -0.025
      X Length: 1.0
      Y Length: 0.05
      Z Length: 0.05
      Number Points X: {nx}
      Number Points Y: {ny}
      Number Points Z: {nz}
  Materials:
    Steel:
      Material Model: "Elastic"
      Density: 7800.0
      Young's Modulus: 200.0e9
      Poisson's Ratio: 0.3
  Blocks:
    Bar:
      Block Names: "block_1"
      Material: "Steel"
      Horizon: 0.03015
  Boundary Conditions:
    Left Node Set: "{left}"
    Push:
      Type: "Prescribed Displacement"
      Node Set: "Left Node Set"
      Coordinate: "x"
      Value: "1.0*t"
  Solver:
    Final Time: 0.00015
    Verlet:
      Safety Factor: 0.8
  Compute Class Parameters:
    Station:
      Compute Class: "Nearest_Point_Data"
      X: 0.505
      Y: 0.0
      Z: 0.0
      Variable: "Velocity"
      Output Label: "Station_Velocity"
  Output:
    Output Filename: "{output}"
    Output Frequency: 1
    Output Variables:
      Station_Velocity: true
"#,
        left = left.join(" ")
    )
}

#[test]
fn step_wave_arrives_at_the_bar_speed() {
    let dir = tempfile::tempdir().unwrap();
    run_deck(dir.path(), &bar_deck("bar")).expect("run succeeds");
    let history = std::fs::read_to_string(dir.path().join("bar.csv")).unwrap();
    let mut lines = history.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let column = header
        .iter()
        .position(|h| *h == "Station_VelocityX")
        .unwrap();
    // The step in particle velocity (1 m/s) reaches the station at x = 0.505 m when its
    // velocity passes half the step.
    let arrival = lines
        .map(|l| {
            l.split(',')
                .map(|v| v.parse::<f64>().unwrap())
                .collect::<Vec<_>>()
        })
        .find(|row| row[column] > 0.5)
        .map(|row| row[0])
        .expect("the wave reaches the station");
    // Bar wave speed c = √(E/ρ) = √(200e9/7800) = 5064 m/s over 0.505 − 0.005 = 0.5 m
    // (from the driven face's points to the station) → 98.7 µs. Lattice dispersion and the
    // softer LPS surface layer of a 5-point-wide bar allow a few percent.
    let expected = 0.5 / (200.0e9f64 / 7800.0).sqrt();
    let error = (arrival - expected).abs() / expected;
    assert!(
        error < 0.04,
        "arrival {arrival:e} s vs {expected:e} s ({:.1} %)",
        100.0 * error
    );
}

/// A free 6×6×6 block set spinning and shearing by its initial velocity.
fn block_deck(material: &str, time_step: &str, final_time: f64) -> String {
    format!(
        r#"Peridigm:
  Discretization:
    Type: "PdQuickGrid"
    NeighborhoodType: "Spherical"
    TensorProduct3DMeshGenerator:
      X Origin: -3.0
      Y Origin: -3.0
      Z Origin: -3.0
      X Length: 6.0
      Y Length: 6.0
      Z Length: 6.0
      Number Points X: 6
      Number Points Y: 6
      Number Points Z: 6
  Materials:
    Stuff:
      {material}
      Density: 1.0
  Blocks:
    All:
      Block Names: "block_1"
      Material: "Stuff"
      Horizon: 2.015
  Boundary Conditions:
    All Node Set: "{all}"
    Vx:
      Type: "Initial Velocity"
      Node Set: "All Node Set"
      Coordinate: "x"
      Value: "0.001*y*y"
    Vy:
      Type: "Initial Velocity"
      Node Set: "All Node Set"
      Coordinate: "y"
      Value: "0.002*sin(x)"
  Solver:
    Final Time: {final_time}
    Verlet:
      {time_step}
  Output:
    Output Filename: "block"
    Output Frequency: 10
    Output Variables:
      Global_Kinetic_Energy: true
      Global_Stored_Elastic_Energy: true
"#,
        all = (1..=216)
            .map(|i| i.to_string())
            .collect::<Vec<_>>()
            .join(" ")
    )
}

const LPS: &str = "Material Model: \"Elastic\"\n      Bulk Modulus: 1.0\n      Shear Modulus: 0.6";
const PMB: &str = "Material Model: \"Elastic Bond Based\"\n      Bulk Modulus: 1.0";

fn energies(dir: &Path) -> Vec<f64> {
    let history = std::fs::read_to_string(dir.join("block.csv")).unwrap();
    history
        .lines()
        .skip(1)
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            v[1] + v[2]
        })
        .collect()
}

#[test]
fn energy_is_conserved_over_1000_steps() {
    let dir = tempfile::tempdir().unwrap();
    // Δt = 0.05 is about a tenth of the stable estimate for this block (K = ρ = 1, Δx = 1);
    // 1000 steps.
    run_deck(dir.path(), &block_deck(LPS, "Fixed dt: 0.05", 50.0 + 0.025)).expect("stable");
    let e = energies(dir.path());
    assert_eq!(e.len(), 101);
    let drift = e.iter().map(|x| (x - e[0]).abs()).fold(0.0, f64::max) / e[0];
    // Velocity Verlet conserves a shadow energy: the error oscillates at O((ωΔt)²) ≈ 1e-3 of
    // the energy for ωΔt ≈ 0.1, without secular drift.
    assert!(drift < 2e-3, "relative energy error {drift:e}");
}

#[test]
fn monitor_stays_quiet_at_1_2_times_the_estimate() {
    for material in [LPS, PMB] {
        let dir = tempfile::tempdir().unwrap();
        // The Silling–Askari estimate is conservative in 3D (the lattice limit is about twice
        // it), so 1.2× must run stably to the end: with Δt ≈ 1.2 × 0.51 = 0.61 (LPS) that is
        // about 1600 steps for a final time of 1000.
        let result = run_deck(
            dir.path(),
            &block_deck(material, "Safety Factor: 1.2", 1000.0),
        );
        let summary = result.unwrap_or_else(|e| panic!("{material}: {e}"));
        assert!(summary.steps > 1000, "{} steps", summary.steps);
    }
}

#[test]
fn monitor_stops_a_run_far_above_the_limit() {
    let dir = tempfile::tempdir().unwrap();
    let error = run_deck(dir.path(), &block_deck(LPS, "Safety Factor: 5.0", 500.0))
        .expect_err("5× the stable step must blow up");
    assert_eq!(error.exit_code(), 3);
    let message = error.to_string();
    assert!(message.contains("unstable at step"), "{message}");
    assert!(message.contains("Safety Factor"), "{message}");
    // The output written before the blow-up is a valid file with finite energies.
    let e = energies(dir.path());
    assert!(!e.is_empty() && e.iter().all(|x| x.is_finite()), "{e:?}");
    assert!(ExodusFile::open(&dir.path().join("block.h")).is_ok());
}

/// A brittle plate (block 1, critical stretch) with an unbreakable block (block 2) bonded to
/// its top and driven down into it.
fn bonded_blocks_deck() -> (String, String) {
    let mut mesh = String::new();
    for k in 0..2 {
        for j in 0..6 {
            for i in 0..6 {
                mesh += &format!("{i} {j} {k} 1 1.0\n");
            }
        }
    }
    for k in 2..4 {
        for j in 2..4 {
            for i in 2..4 {
                mesh += &format!("{i} {j} {k} 2 1.0\n");
            }
        }
    }
    let ids: Vec<String> = (73..=80).map(|i| i.to_string()).collect();
    let deck = format!(
        r#"Peridigm:
  Discretization:
    Type: "Text File"
    Input Mesh File: "blocks.txt"
  Materials:
    Stuff:
      Material Model: "Elastic"
      Density: 1.0
      Bulk Modulus: 1.0
      Shear Modulus: 0.6
  Damage Models:
    Brittle:
      Damage Model: "Critical Stretch"
      Critical Stretch: 0.01
  Blocks:
    Plate:
      Block Names: "block_1"
      Material: "Stuff"
      Damage Model: "Brittle"
      Horizon: 2.015
    Punch:
      Block Names: "block_2"
      Material: "Stuff"
      Horizon: 2.015
  Boundary Conditions:
    Punch Node Set: "{ids}"
    Push:
      Type: "Initial Velocity"
      Node Set: "Punch Node Set"
      Coordinate: "z"
      Value: "-0.2"
  Solver:
    Final Time: 30.0
    Verlet:
      Safety Factor: 0.5
  Output:
    Output Filename: "block"
    Output Frequency: 5
    Output Variables:
      Global_Kinetic_Energy: true
      Global_Stored_Elastic_Energy: true
"#,
        ids = ids.join(" ")
    );
    (deck, mesh)
}

#[test]
fn bonds_between_a_brittle_and_an_unbreakable_block_break_from_both_ends() {
    let dir = tempfile::tempdir().unwrap();
    let (deck, mesh) = bonded_blocks_deck();
    std::fs::write(dir.path().join("blocks.txt"), mesh).unwrap();
    let summary = run_deck(dir.path(), &deck).expect("stable run");
    assert!(summary.broken_bonds > 0, "the punch must break bonds");
    let e = energies(dir.path());
    // Breaking bonds only removes energy: the body never holds more than it started with
    // (the punch's kinetic energy), up to the Verlet energy error. A bond broken at the
    // plate's end but intact at the punch's end would keep pulling with half a spring that has
    // no energy, and the energy grows several-fold.
    let most = e.iter().copied().fold(0.0, f64::max);
    assert!(most <= 1.02 * e[0], "energy rose from {} to {most}", e[0]);
}

#[test]
fn an_energy_release_rate_gives_the_same_run_as_its_critical_stretch() {
    // s0 = √(5G0/(9Kδ)) (Silling–Askari): with K = 1, δ = 2.015 and s0 = 0.01,
    // G0 = s0²·9Kδ/5 = 1e-4 · 9 · 2.015 / 5 = 3.627e-4. Both decks must break the same bonds
    // and give the same energies.
    let (deck, mesh) = bonded_blocks_deck();
    let g0 = 0.01f64.powi(2) * 9.0 * 2.015 / 5.0;
    let by_energy = deck.replace(
        "Critical Stretch: 0.01",
        &format!("Critical Energy Release Rate: {g0:e}"),
    );
    assert_ne!(deck, by_energy);
    let mut results = Vec::new();
    for text in [&deck, &by_energy] {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("blocks.txt"), &mesh).unwrap();
        let summary = run_deck(dir.path(), text).expect("run");
        results.push((summary.broken_bonds, energies(dir.path())));
    }
    assert!(results[0].0 > 0);
    assert_eq!(results[0].0, results[1].0);
    for (a, b) in results[0].1.iter().zip(&results[1].1) {
        assert!((a - b).abs() <= 1e-12 * a.abs(), "{a} vs {b}");
    }
}
