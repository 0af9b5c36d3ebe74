//! Distributed explicit runs (feature `mpi`): the same deck on 1, 2 and 3 MPI ranks must write
//! the same Exodus file, and decks a distributed run cannot do are refused cleanly.
//!
//! Needs `mpirun` (OpenMPI: `.ci/mpi.sh` installs it). Every run is wrapped in `timeout`, so a
//! hang fails the test instead of blocking it.
#![cfg(feature = "mpi")]

mod mpi_support;

use mpi_support::{assert_success, diff_against_one_rank, mpirun, STRICT};

use peridyn::io::exodus::ExodusFile;
use std::path::Path;

/// A steel-like bar on a 0.5 m lattice, horizon 1.6 m (3.2 spacings), pulled apart from
/// two-column slabs at each end.
struct Bar {
    /// Points along x, y, z.
    points: [usize; 3],
    /// Speed of each end slab (m/s).
    pull_speed: f64,
    final_time: f64,
    output_frequency: usize,
}

/// 10 × 2 × 2 m, 20 × 4 × 4 = 320 points, pulled at 1 m/s until critical-stretch bonds break
/// (s_c = 0.002 is reached after about 0.01 s of the 0.023 s run: the bar's mean strain grows
/// at 2/10 per second). Output every 30 of the 299 steps.
const SHORT_BAR: Bar = Bar {
    points: [20, 4, 4],
    pull_speed: 1.0,
    final_time: 0.023,
    output_frequency: 30,
};

fn bar_deck(dir: &Path, material: &str) -> &'static str {
    bar_deck_of(dir, material, &SHORT_BAR)
}

fn bar_deck_of(dir: &Path, material: &str, bar: &Bar) -> &'static str {
    let [nx, ny, nz] = bar.points;
    let spacing = 0.5;
    // QuickGrid numbers points x fastest: id = 1 + i + nx (j + ny k).
    let slab = |columns: [usize; 2]| -> String {
        let mut ids = Vec::new();
        for k in 0..nz {
            for j in 0..ny {
                for i in columns {
                    ids.push((1 + i + nx * (j + ny * k)).to_string());
                }
            }
        }
        ids.join("\n") + "\n"
    };
    std::fs::write(dir.join("left.txt"), slab([0, 1])).unwrap();
    std::fs::write(dir.join("right.txt"), slab([nx - 2, nx - 1])).unwrap();
    let [lx, ly, lz] = bar.points.map(|n| n as f64 * spacing);
    let [ox, oy, oz] = [lx, ly, lz].map(|l| -0.5 * l);
    let speed = bar.pull_speed;
    let final_time = bar.final_time;
    let frequency = bar.output_frequency;
    let constants = if material == "Elastic" {
        "Bulk Modulus: 1.6e11\n      Shear Modulus: 7.9e10"
    } else {
        "Bulk Modulus: 1.6e11"
    };
    let text = format!(
        r#"Peridigm:
  Discretization:
    Type: "PdQuickGrid"
    TensorProduct3DMeshGenerator:
      Type: "PdQuickGrid"
      X Origin: {ox:?}
      Y Origin: {oy:?}
      Z Origin: {oz:?}
      X Length: {lx:?}
      Y Length: {ly:?}
      Z Length: {lz:?}
      Number Points X: {nx}
      Number Points Y: {ny}
      Number Points Z: {nz}
  Materials:
    M:
      Material Model: "{material}"
      Density: 8000.0
      {constants}
  Damage Models:
    D:
      Damage Model: "Critical Stretch"
      Critical Stretch: 0.002
  Blocks:
    B:
      Block Names: "block_1"
      Material: "M"
      Damage Model: "D"
      Horizon: 1.6
  Boundary Conditions:
    Left Node Set: "left.txt"
    Right Node Set: "right.txt"
    Pull Left:
      Type: "Prescribed Displacement"
      Node Set: "Left Node Set"
      Coordinate: "x"
      Value: "-{speed:?}*t"
    Pull Right:
      Type: "Prescribed Displacement"
      Node Set: "Right Node Set"
      Coordinate: "x"
      Value: "{speed:?}*t"
  Compute Class Parameters:
    Left Reaction:
      Compute Class: "Node_Set_Data"
      Calculation Type: "Sum"
      Node Set: "Left Node Set"
      Variable: "Force"
      Output Label: "Left_Reaction"
    Most Damage:
      Compute Class: "Block_Data"
      Calculation Type: "Maximum"
      Block: "block_1"
      Variable: "Damage"
      Output Label: "Max_Damage"
  Solver:
    Final Time: {final_time:?}
    Verlet:
      Safety Factor: 0.8
  Output:
    Output Filename: "bar"
    Output Frequency: {frequency}
    Output Variables:
      Displacement: true
      Velocity: true
      Acceleration: true
      Force_Density: true
      Damage: true
      Dilatation: true
      Weighted_Volume: true
      Number_Of_Neighbors: true
      Element_Id: true
      Stored_Elastic_Energy: true
      Global_Kinetic_Energy: true
      Global_Stored_Elastic_Energy: true
      Global_Linear_Momentum: true
      Left_Reaction: true
      Max_Damage: true
"#
    );
    std::fs::write(dir.join("bar.yaml"), text).unwrap();
    "bar.yaml"
}

/// Runs the bar on 1, 2 and 3 ranks and compares 2 and 3 with 1 through `peridyn diff`.
fn same_answer_on_any_rank_count(material: &str) {
    same_answer_on_any_rank_count_of(material, &SHORT_BAR);
}

/// Every value of every frame of two Exodus files: the same bits (times, global, nodal and
/// element variables).
fn assert_bitwise_equal(a: &ExodusFile, b: &ExodusFile, what: &str) {
    assert_eq!(a.times, b.times, "{what}: times");
    assert_eq!(a.nodal_variable_names, b.nodal_variable_names, "{what}");
    assert_eq!(a.element_variable_names, b.element_variable_names, "{what}");
    for step in 0..a.times.len() {
        assert_eq!(
            a.global_values(step).unwrap(),
            b.global_values(step).unwrap(),
            "{what}: global variables at frame {step}"
        );
        for (v, name) in a.nodal_variable_names.iter().enumerate() {
            assert_eq!(
                a.nodal_values(step, v).unwrap(),
                b.nodal_values(step, v).unwrap(),
                "{what}: {name} at frame {step}"
            );
        }
        for (v, name) in a.element_variable_names.iter().enumerate() {
            for block in 0..a.blocks.len() {
                assert_eq!(
                    a.element_values(step, v, block).unwrap(),
                    b.element_values(step, v, block).unwrap(),
                    "{what}: {name} on block {block} at frame {step}"
                );
            }
        }
    }
}

fn same_answer_on_any_rank_count_of(material: &str, bar: &Bar) {
    let dir = tempfile::tempdir().unwrap();
    let deck = bar_deck_of(dir.path(), material, bar);
    std::fs::write(dir.path().join("strict.comp"), STRICT).unwrap();
    for ranks in 1..=3 {
        let out = format!("ranks{ranks}");
        let output = mpirun(dir.path(), ranks, &["run", deck, "--output-dir", &out]);
        assert_success(&output, &format!("{material} on {ranks} ranks"));
        let log = String::from_utf8_lossy(&output.stderr);
        // Only rank 0 reports.
        assert_eq!(log.matches("done:").count(), 1, "{log}");
    }
    // The run must exercise damage: some bonds broke by the last frame.
    let reference = ExodusFile::open(&dir.path().join("ranks1/bar.e")).unwrap();
    let damage = reference.element_variable_index("Damage").unwrap();
    let last = reference.times.len() - 1;
    let values = reference
        .element_values(last, damage, 0)
        .unwrap()
        .expect("damage written");
    let broken = values.iter().filter(|&&d| d > 0.0).count();
    assert!(
        broken > 0,
        "no point is damaged: the test would not test damage"
    );
    for ranks in 2..=3 {
        let output = diff_against_one_rank(dir.path(), ranks, "bar.e", "strict.comp");
        assert_success(
            &output,
            &format!("{material}: diff of {ranks} ranks against 1"),
        );
        // Beyond the 1e-12 of the diff: each owned point's force is the sum of its own row in
        // the row's order (bond_based.rs, lps), so the files are the same bits.
        let other = ExodusFile::open(&dir.path().join(format!("ranks{ranks}/bar.e"))).unwrap();
        assert_bitwise_equal(
            &other,
            &reference,
            &format!("{material} on {ranks} ranks against 1"),
        );
    }
}

#[test]
fn lps_bar_breaks_the_same_on_one_two_and_three_ranks() {
    same_answer_on_any_rank_count("Elastic");
}

#[test]
fn pmb_bar_breaks_the_same_on_one_two_and_three_ranks() {
    same_answer_on_any_rank_count("Elastic Bond Based");
}

/// 30 × 4 × 3.5 m, 60 × 8 × 7 = 3,360 points (13 chunks of PMB's 256-point pair pass, so the
/// ranks' local models cut their points into chunks elsewhere than the one-rank model), pulled
/// at 5 m/s so that the bonds next to the slabs reach s_c = 0.002 within the short run (the
/// slab moves 5 m/s × t against points still at rest: s ≈ 5t/ζ with ζ ≥ 0.5 m exceeds 0.002
/// after about 2e-4 s).
const LONG_BAR: Bar = Bar {
    points: [60, 8, 7],
    pull_speed: 5.0,
    final_time: 0.004,
    output_frequency: 10,
};

#[test]
fn pmb_bar_of_many_pair_chunks_breaks_the_same_on_one_two_and_three_ranks() {
    same_answer_on_any_rank_count_of("Elastic Bond Based", &LONG_BAR);
}

#[test]
fn implicit_solvers_are_refused_on_two_ranks_before_any_message() {
    let dir = tempfile::tempdir().unwrap();
    let deck = bar_deck(dir.path(), "Elastic");
    let text = std::fs::read_to_string(dir.path().join(deck)).unwrap();
    let text = text.replace(
        "    Verlet:\n      Safety Factor: 0.8",
        "    QuasiStatic:\n      Number of Load Steps: 2\n      Absolute Tolerance: 1.0",
    );
    std::fs::write(dir.path().join("qs.yaml"), text).unwrap();
    let output = mpirun(dir.path(), 2, &["run", "qs.yaml", "--output-dir", "out"]);
    let log = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success());
    let expected = "solver \"Solver\": QuasiStatic on 2 ranks needs the Trilinos or PETSc backend (QuasiStatic, NOXQuasiStatic or Implicit with Backend \"Trilinos\" or \"PETSc\", or `peridyn run --backend trilinos` or `--backend petsc`, in a build with the feature mpi and that backend's feature); the native backend runs on one rank";
    assert_eq!(log.matches(expected).count(), 1, "{log}");
}

#[test]
fn bad_input_fails_on_every_rank_and_is_printed_once() {
    let dir = tempfile::tempdir().unwrap();
    let deck = bar_deck(dir.path(), "Elastic");
    let text = std::fs::read_to_string(dir.path().join(deck)).unwrap();
    std::fs::write(
        dir.path().join("bad.yaml"),
        text.replace(
            "Node Set: \"Right Node Set\"",
            "Node Set: \"Missing Node Set\"",
        ),
    )
    .unwrap();
    let output = mpirun(dir.path(), 2, &["run", "bad.yaml", "--output-dir", "out"]);
    let log = String::from_utf8_lossy(&output.stderr);
    // Invalid input: exit code 2 (mpirun passes on the first non-zero code).
    assert_eq!(output.status.code(), Some(2), "{log}");
    assert_eq!(log.matches("Missing Node Set").count(), 1, "{log}");
}

#[test]
fn a_nan_condition_on_one_ranks_points_stops_every_rank_with_its_exit_code() {
    // sqrt(−x) is NaN on the right slab (x > 0), which RCB gives to the last rank only: that
    // rank names the condition at step 1 and every rank stops with its exit code 2 (the
    // deck's expression is at fault); the message appears once and nothing hangs.
    let dir = tempfile::tempdir().unwrap();
    let deck = bar_deck(dir.path(), "Elastic Bond Based");
    let text = std::fs::read_to_string(dir.path().join(deck)).unwrap();
    std::fs::write(
        dir.path().join("nan.yaml"),
        text.replace("Value: \"1.0*t\"", "Value: \"sqrt(-x)*t\""),
    )
    .unwrap();
    let output = mpirun(dir.path(), 2, &["run", "nan.yaml", "--output-dir", "out"]);
    let log = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{log}");
    assert_eq!(log.matches("sqrt(-x)*t").count(), 1, "{log}");
    assert!(!log.contains("became unstable"), "{log}");
}

#[test]
fn a_failure_on_rank_zero_alone_stops_every_rank() {
    // The results file cannot be created (a folder has its name): only rank 0 opens files,
    // so only rank 0 fails; the others must learn of it at the next collective, stop, and
    // stay quiet. `timeout` would exit with 124 on a hang. A results file that cannot be
    // written is exit code 6 (README, "Restart and interruptions").
    let dir = tempfile::tempdir().unwrap();
    let deck = bar_deck(dir.path(), "Elastic");
    std::fs::create_dir_all(dir.path().join("out/bar.e")).unwrap();
    let output = mpirun(dir.path(), 3, &["run", deck, "--output-dir", "out"]);
    let log = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(6), "{log}");
    assert_eq!(log.matches("error: ").count(), 1, "{log}");
    assert!(log.contains("bar.e"), "{log}");
}

/// One-way bonds (the right half of the bar, a block of its own, bonds across 1.1 m while
/// the left half's horizon of 1.6 m reaches into it: a left point's family holds right points
/// whose own horizon does not reach back) are refused by the ranks together, at the left
/// block's `Horizon`, as one rank refuses them (tests/bad_input.rs): once, exit code 2,
/// nothing hangs.
#[test]
fn one_way_bonds_are_refused_on_two_ranks_as_on_one() {
    let dir = tempfile::tempdir().unwrap();
    let deck = bar_deck(dir.path(), "Elastic");
    let text = std::fs::read_to_string(dir.path().join(deck)).unwrap();
    // The bar's lattice as a text mesh, in QuickGrid's order (x fastest) so that the node
    // sets keep their ids: cell-centred points of spacing 0.5 on 10 × 2 × 2 m.
    let [nx, ny, nz] = SHORT_BAR.points;
    let mut mesh = String::from("# x y z block volume\n");
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let [x, y, z] = [(i, nx), (j, ny), (k, nz)]
                    .map(|(n, count)| 0.5 * (n as f64 + 0.5) - 0.25 * count as f64);
                let block = if x > 0.0 { 2 } else { 1 };
                mesh.push_str(&format!("{x} {y} {z} {block} 0.125\n"));
            }
        }
    }
    std::fs::write(dir.path().join("bar.txt"), mesh).unwrap();
    let generator_start = text.find("    Type: \"PdQuickGrid\"").unwrap();
    let generator_end = text.find("  Materials:").unwrap();
    let text = format!(
        "{}    Type: \"Text File\"\n    Input Mesh File: \"bar.txt\"\n{}",
        &text[..generator_start],
        &text[generator_end..]
    )
    .replace(
        "      Horizon: 1.6\n",
        "      Horizon: 1.6\n    Right:\n      Block Names: \"block_2\"\n      Material: \"M\"\n      Damage Model: \"D\"\n      Horizon: 1.1\n",
    );
    std::fs::write(dir.path().join("one_way.yaml"), text).unwrap();
    let expected = "which does not bond back";
    for ranks in [1, 2] {
        let output = mpirun(
            dir.path(),
            ranks,
            &["run", "one_way.yaml", "--output-dir", "out"],
        );
        let log = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{ranks} ranks: {log}");
        assert_eq!(log.matches(expected).count(), 1, "{ranks} ranks: {log}");
        assert!(log.contains("Blocks → B → Horizon"), "{ranks} ranks: {log}");
    }
}
