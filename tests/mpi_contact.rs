//! Short-range contact on N MPI ranks (feature `mpi`): a projectile striking a brittle plate
//! must write the same Exodus file on 1, 2 and 3 ranks, with contact forces acting across rank
//! boundaries and bonds breaking.
//!
//! Needs `mpirun` (OpenMPI: `.ci/mpi.sh` installs it). Every run is wrapped in `timeout`, so a
//! hang fails the test instead of blocking it.
#![cfg(feature = "mpi")]

mod mpi_support;

use mpi_support::{assert_success, diff_against_one_rank, mpirun, STRICT};

use peridyn::io::exodus::ExodusFile;
use std::path::Path;

/// Points of the target plate (block 1), numbered first in the mesh file.
const TARGET_POINTS: usize = 10 * 10 * 3;

/// Initial speed of the projectile towards the plate (mm/ms = m/s), along −z.
const IMPACT_SPEED: f64 = 100.0;

/// A steel plate (block 1, LPS, critical stretch 0.005) of 10 × 10 × 3 points at spacing
/// 0.5 mm, and above it a 6 × 6 × 6-point steel cube (block 2, LPS, unbreakable) 1.6 mm away
/// (more than the horizon 1.5075 mm, so no bonds join them), moving down at 100 mm/ms and
/// sideways at 20 mm/ms (so friction acts). Units mm, ms, g, MPa as Peridigm's Contact_Cubes.
///
/// Contact: radius 0.4 mm, search radius 1 mm, search every 50 steps; the skin rule asks for
/// a search whenever a point has moved (1 − 0.4)/2 = 0.3 mm, i.e. every ~30 steps of
/// 7.04e-5 ms at 100 mm/ms, so both scheduled and early searches run. The gap closes
/// to the contact radius after (1.6 − 0.4)/100 = 0.012 ms (about 170 of the 426 steps), and
/// the impact strain ~ v/c = 100/√(K/ρ) = 100/4082 ≈ 0.025 exceeds the critical stretch.
fn impact_deck(dir: &Path) -> &'static str {
    let h = 0.5;
    let volume = h * h * h;
    let mut mesh = String::new();
    for k in 0..3 {
        for j in 0..10 {
            for i in 0..10 {
                let (x, y, z) = (
                    (f64::from(i) + 0.5) * h,
                    (f64::from(j) + 0.5) * h,
                    (f64::from(k) + 0.5) * h,
                );
                mesh += &format!("{x} {y} {z} 1 {volume}\n");
            }
        }
    }
    let mut projectile = String::new();
    let mut id = TARGET_POINTS;
    for k in 0..6 {
        for j in 0..6 {
            for i in 0..6 {
                let (x, y, z) = (
                    (f64::from(i) + 2.5) * h,
                    (f64::from(j) + 2.5) * h,
                    2.5 * h + 1.6 + f64::from(k) * h,
                );
                mesh += &format!("{x} {y} {z} 2 {volume}\n");
                id += 1;
                projectile += &format!("{id}\n");
            }
        }
    }
    std::fs::write(dir.join("mesh.txt"), mesh).unwrap();
    std::fs::write(dir.join("projectile.txt"), projectile).unwrap();
    let text = format!(
        r#"Peridigm:
  Discretization:
    Type: "Text File"
    Input Mesh File: "mesh.txt"
  Materials:
    Steel:
      Material Model: "Elastic"
      Density: 7.8e-3
      Bulk Modulus: 130.0e3
      Shear Modulus: 78.0e3
  Damage Models:
    Brittle:
      Damage Model: "Critical Stretch"
      Critical Stretch: 0.005
  Blocks:
    Target:
      Block Names: "block_1"
      Material: "Steel"
      Damage Model: "Brittle"
      Horizon: 1.5075
    Projectile:
      Block Names: "block_2"
      Material: "Steel"
      Horizon: 1.5075
  Contact:
    Search Radius: 1.0
    Search Frequency: 50
    Models:
      Penalty:
        Contact Model: "Short Range Force"
        Contact Radius: 0.4
        Spring Constant: 1950.0e3
        Friction Coefficient: 0.2
    Interactions:
      General Contact:
        Contact Model: "Penalty"
  Boundary Conditions:
    Projectile Node Set: "projectile.txt"
    Down:
      Type: "Initial Velocity"
      Node Set: "Projectile Node Set"
      Coordinate: "z"
      Value: "-{IMPACT_SPEED}"
    Sideways:
      Type: "Initial Velocity"
      Node Set: "Projectile Node Set"
      Coordinate: "x"
      Value: "20.0"
  Solver:
    Final Time: 0.03
    Verlet:
      Safety Factor: 0.8
  Output:
    Output Filename: "impact"
    Output Frequency: 25
    Output Variables:
      Displacement: true
      Velocity: true
      Force_Density: true
      Contact_Force_Density: true
      Damage: true
      Dilatation: true
      Global_Kinetic_Energy: true
      Global_Stored_Elastic_Energy: true
"#
    );
    std::fs::write(dir.join("impact.yaml"), text).unwrap();
    "impact.yaml"
}

/// Mean of nodal variable `name` over the projectile's nodes at frame `step`.
fn projectile_mean(file: &ExodusFile, step: usize, name: &str) -> f64 {
    let variable = file.nodal_variable_index(name).expect(name);
    let values = file.nodal_values(step, variable).unwrap();
    let projectile: Vec<f64> = file
        .node_ids
        .iter()
        .zip(values)
        .filter(|(&id, _)| id > TARGET_POINTS as i64)
        .map(|(_, v)| v)
        .collect();
    assert_eq!(projectile.len(), 216);
    projectile.iter().sum::<f64>() / projectile.len() as f64
}

#[test]
fn an_impact_with_contact_and_damage_is_the_same_on_one_two_and_three_ranks() {
    let dir = tempfile::tempdir().unwrap();
    let deck = impact_deck(dir.path());
    std::fs::write(dir.path().join("strict.comp"), STRICT).unwrap();
    for ranks in 1..=3 {
        let out = format!("ranks{ranks}");
        let output = mpirun(dir.path(), ranks, &["run", deck, "--output-dir", &out]);
        assert_success(&output, &format!("{ranks} ranks"));
        let log = String::from_utf8_lossy(&output.stderr);
        assert_eq!(log.matches("done:").count(), 1, "{log}");
        if ranks > 1 {
            // Rank 0's log line: some of its points had contact partners owned by other ranks
            // (or the test would not test the partner exchange).
            let most: usize = log
                .split("partner points received from other ranks per step: ")
                .nth(1)
                .and_then(|rest| rest.split(", at most ").nth(1))
                .and_then(|rest| rest.split_whitespace().next())
                .and_then(|n| n.parse().ok())
                .unwrap_or_else(|| panic!("no contact line in the log:\n{log}"));
            assert!(most > 0, "{log}");
        }
    }
    let reference = ExodusFile::open(&dir.path().join("ranks1/impact.e")).unwrap();
    let last = reference.times.len() - 1;
    // Contact acted: the projectile's mean downward speed, 100 at the start (the initial
    // condition), fell by more than half by the end (nothing else slows it: no bonds join it
    // to the plate and it has no boundary conditions; this deck ends at about 9).
    let start = projectile_mean(&reference, 0, "VelocityZ");
    assert!((start + IMPACT_SPEED).abs() < 1e-12, "{start}");
    let end = projectile_mean(&reference, last, "VelocityZ");
    assert!(
        end > -0.5 * IMPACT_SPEED,
        "mean z velocity at the end {end}"
    );
    // Some plate points are damaged.
    let damage = reference.element_variable_index("Damage").unwrap();
    let values = reference
        .element_values(last, damage, 0)
        .unwrap()
        .expect("damage written");
    let damaged = values.iter().filter(|&&d| d > 0.0).count();
    assert!(damaged > 0, "no plate point is damaged");
    for ranks in 2..=3 {
        let output = diff_against_one_rank(dir.path(), ranks, "impact.e", "strict.comp");
        assert_success(&output, &format!("diff of {ranks} ranks against 1"));
    }
}
