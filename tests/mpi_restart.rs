//! Restart files on N MPI ranks (features `mpi` and `hdf5`): a restart file holds every point
//! in the user's original order, so a run stopped on 2 ranks continues on 3 ranks or on 1,
//! and a file one rank wrote continues on 2, each to the Exodus file of the uninterrupted run.
//!
//! Why bitwise equality is the right bar: peridyn's explicit runs on N ranks are already
//! bit-identical to one rank (each rank evaluates damage, forces and contact of its owned
//! points from the same numbers in the same order, and rank 0 writes every file from fields
//! gathered in the global order: `tests/mpi_explicit.rs`, `tests/mpi_contact.rs`), and a
//! continuation restores every number the next step reads, so nothing may differ in any bit.
//!
//! Needs `mpirun` (OpenMPI: `.ci/mpi.sh`) and HDF5 (`.ci/hdf5.sh`). Every run is wrapped in
//! `timeout`, so a hang fails the test instead of blocking it.
#![cfg(all(unix, feature = "mpi", feature = "hdf5"))]

mod mpi_support;

use mpi_support::{assert_success, mpirun};

use peridyn::io::exodus::ExodusFile;
use peridyn::restart::{self, Snapshot};
use std::path::{Path, PathBuf};

/// Points of the target plate (block 1), numbered first in the mesh file.
const TARGET_POINTS: usize = 10 * 10 * 3;

/// The impact of `tests/mpi_contact.rs` ending at 0.027 ms, with restart files every 200
/// steps: a steel plate (10 × 10 × 3 points, LPS, critical stretch 0.005) struck by a
/// 6 × 6 × 6-point steel cube moving down at 100 mm/ms and sideways at 20 mm/ms, with
/// short-range contact and friction. Units mm, ms, g, MPa. Δt = 0.8 × the stable estimate,
/// 7.04e-5 ms (426 steps to 0.03 ms in `tests/mpi_contact.rs`), gives 383 steps; the gap of
/// 1.2 mm closes after about 1.2/100 ms = 170 steps, so at step 200 the bodies are in contact
/// (the frames of steps 175 and 225 show no contact force, that of step 200 does) and bonds
/// break; the restart files are written after step 200 and at the end.
fn impact_deck(dir: &Path) {
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
    let text = r#"Peridigm:
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
      Value: "-100.0"
    Sideways:
      Type: "Initial Velocity"
      Node Set: "Projectile Node Set"
      Coordinate: "x"
      Value: "20.0"
  Restart:
    Frequency: 200
  Solver:
    Final Time: 0.027
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
"#;
    std::fs::write(dir.join("impact.yaml"), text).unwrap();
}

/// `peridyn run impact.yaml --output-dir <out>` on `ranks` ranks; returns the log.
fn run(dir: &Path, ranks: usize, out: &str) -> String {
    let output = mpirun(dir, ranks, &["run", "impact.yaml", "--output-dir", out]);
    assert_success(&output, &format!("{out} on {ranks} ranks"));
    String::from_utf8_lossy(&output.stderr).into_owned()
}

/// The restart directories of `dir/out`, oldest first.
fn restart_dirs(dir: &Path, out: &str) -> Vec<PathBuf> {
    restart::directories(&dir.join(out))
        .into_iter()
        .map(|(_, p)| p)
        .collect()
}

/// A copy of the output folder `from` as `to` without its newest restart directory (the one
/// written at the end of the run): what a run killed after its first restart file left.
/// Returns the restart file kept.
fn stopped_copy(dir: &Path, from: &str, to: &str) -> PathBuf {
    let (from, to) = (dir.join(from), dir.join(to));
    std::fs::create_dir(&to).unwrap();
    for entry in std::fs::read_dir(&from).unwrap() {
        let path = entry.unwrap().path();
        if path.is_file() {
            std::fs::copy(&path, to.join(path.file_name().unwrap())).unwrap();
        }
    }
    let dirs = restart_dirs(dir, from.file_name().unwrap().to_str().unwrap());
    assert_eq!(dirs.len(), 2, "{dirs:?}");
    let kept = &dirs[0];
    let copy = to.join(kept.file_name().unwrap());
    std::fs::create_dir(&copy).unwrap();
    std::fs::copy(kept.join(restart::FILE_NAME), copy.join(restart::FILE_NAME)).unwrap();
    kept.join(restart::FILE_NAME)
}

fn read(path: &Path) -> Snapshot {
    restart::read(path).unwrap_or_else(|e| panic!("{e}"))
}

/// The results files of a run: the Exodus file and the CSV of its globals.
const RESULTS: [&str; 2] = ["impact.e", "impact.csv"];

/// The results files of the run in `dir/out`.
fn results(dir: &Path, out: &str) -> Vec<Vec<u8>> {
    RESULTS
        .iter()
        .map(|name| std::fs::read(dir.join(out).join(name)).unwrap())
        .collect()
}

/// Asserts that the results files in `out` are byte for byte the straight one-rank run's.
fn assert_same_results(dir: &Path, out: &str, straight: &[Vec<u8>], what: &str) {
    for ((name, after), before) in RESULTS.iter().zip(results(dir, out)).zip(straight) {
        assert!(
            &after == before,
            "{what}: {name} differs from the straight run ({} against {} bytes)",
            after.len(),
            before.len()
        );
    }
}

#[test]
fn a_run_stopped_on_two_ranks_continues_on_three_and_on_one_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    impact_deck(dir);
    let log = run(dir, 1, "straight");
    assert!(log.contains(" 383 steps"), "{log}");
    let straight = results(dir, "straight");
    // Restart files after step 200 and at the end.
    let log = run(dir, 2, "two");
    assert!(!log.contains("restart: "), "{log}");
    assert_same_results(dir, "two", &straight, "the straight run on 2 ranks");

    // The files 1 and 2 ranks wrote after step 200 hold the same numbers: the format does not
    // depend on the partition. Only the stability monitor's energies are sums over the ranks
    // in another order (they decide nothing but whether the run is stable), so they agree to
    // rounding: 1e-12 relative.
    let written_by_one = stopped_copy(dir, "straight", "one-to-two");
    let written_by_two = stopped_copy(dir, "two", "two-to-three");
    stopped_copy(dir, "two", "two-to-one");
    let (mut one, mut two) = (read(&written_by_one), read(&written_by_two));
    assert_eq!(one.position.step, 200);
    assert!(
        one.bond_damage
            .as_ref()
            .is_some_and(|d| d.iter().any(|&d| d > 0.0)),
        "no bond broke by step 200"
    );
    assert!(
        one.contact
            .as_ref()
            .is_some_and(|c| c.force_density.iter().any(|f| f != &[0.0; 3])),
        "no contact force at step 200"
    );
    let (m1, m2) = (one.monitor.take().unwrap(), two.monitor.take().unwrap());
    for (a, b) in m1.iter().zip(&m2) {
        assert!(
            (a - b).abs() <= 1e-12 * a.abs().max(b.abs()),
            "{m1:?} {m2:?}"
        );
    }
    assert!(one == two, "the restart files of 1 and 2 ranks differ");

    // Continued on 3 ranks and on 1 from the file 2 ranks wrote, and on 2 from the file one
    // rank wrote: the straight run's file each time.
    for (ranks, out) in [(3, "two-to-three"), (1, "two-to-one"), (2, "one-to-two")] {
        let log = run(dir, ranks, out);
        assert!(log.contains("restart: continuing from"), "{log}");
        assert!(log.contains("step 200"), "{log}");
        assert_same_results(dir, out, &straight, out);
    }

    // The run did what the test needs: bonds broke and contact slowed the projectile (its mean
    // downward speed, 100 at the start, ends below half of it: nothing else slows it).
    let file = ExodusFile::open(&dir.join("two-to-three/impact.e")).unwrap();
    let last = file.times.len() - 1;
    let vz = file.nodal_variable_index("VelocityZ").unwrap();
    let values = file.nodal_values(last, vz).unwrap();
    let projectile: Vec<f64> = file
        .node_ids
        .iter()
        .zip(values)
        .filter(|(&id, _)| id > TARGET_POINTS as i64)
        .map(|(_, v)| v)
        .collect();
    let mean = projectile.iter().sum::<f64>() / projectile.len() as f64;
    assert!(mean > -50.0, "mean z velocity at the end {mean}");
}
