//! Without the `hdf5` feature a deck that asks for restart files is refused by `check` and
//! `run` alike, with exit code 2, the key, and how to get a build that has them.
#![cfg(not(feature = "hdf5"))]

use std::process::Command;

const DECK: &str = r#"Peridigm:
  Discretization:
    Type: "PdQuickGrid"
    NeighborhoodType: "Spherical"
    TensorProduct3DMeshGenerator:
      X Origin: 0.0
      Y Origin: 0.0
      Z Origin: 0.0
      X Length: 4.0
      Y Length: 1.0
      Z Length: 1.0
      Number Points X: 4
      Number Points Y: 1
      Number Points Z: 1
  Materials:
    Steel:
      Material Model: "Elastic"
      Density: 7800.0
      Bulk Modulus: 130.0e9
      Shear Modulus: 78.0e9
  Blocks:
    All:
      Block Names: "block_1"
      Material: "Steel"
      Horizon: 1.5
  Restart:
    Restart: true
  Solver:
    Final Time: 1.0e-6
    Verlet:
      Fixed dt: 1.0e-7
"#;

#[test]
fn a_deck_asking_for_restart_names_the_feature_and_the_install_line() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("deck.yaml"), DECK).unwrap();
    for command in ["check", "run"] {
        let out = Command::new(env!("CARGO_BIN_EXE_peridyn"))
            .args([command, "deck.yaml"])
            .current_dir(dir.path())
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{command}: {stderr}");
        for needed in [
            "deck.yaml:26",
            "Restart",
            "`hdf5` feature",
            "apt-get install libhdf5-dev",
            "cargo build --release --features hdf5",
        ] {
            assert!(
                stderr.contains(needed),
                "{command}: no {needed:?} in {stderr}"
            );
        }
        assert!(!dir.path().join("restart-000001").exists());
    }
}
