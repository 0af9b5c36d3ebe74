//! `Nonlinear Solver: "SNES"` (feature `petsc`): PETSc's SNES drives the Newton iteration of
//! `QuasiStatic` load steps and Newmark-β time steps (`Implicit`) on the same residual as
//! peridyn's Newton, and gives the native direct answer; the key is refused, naming it, where
//! SNES cannot run.
#![cfg(feature = "petsc")]

mod quasi_static_bar;

use quasi_static_bar::final_displacement;
use std::path::Path;
use std::process::Command;

/// `peridyn <args>`: exit code and both output streams.
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

/// Writes `deck` to `dir` and runs it there; panics unless it succeeds; returns the log.
fn run(dir: &Path, deck: &str) -> String {
    let path = dir.join("bar.yaml");
    std::fs::write(&path, deck).unwrap();
    let (code, log) = run_cli(&[
        "run",
        path.to_str().unwrap(),
        "--output-dir",
        dir.to_str().unwrap(),
    ]);
    assert_eq!(code, Some(0), "{log}");
    log
}

fn largest_difference(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
}

/// The bar pulled 0.012 m and sheared 0.004 m in two `QuasiStatic` load steps, with
/// `solver_keys`.
fn quasi_static(solver_keys: &str) -> String {
    let solver = format!("    Final Time: 1.0\n{solver_keys}\n    QuasiStatic:\n      Number of Load Steps: {{steps}}\n      Absolute Tolerance: 1.0\n      Maximum Solver Iterations: 30");
    quasi_static_bar::bar_deck(&solver, 0.012, 0.004, 2)
}

/// Five Newmark-β steps of 0.1 ms while the right face moves at 24 m/s along x and 8 m/s along
/// y, with `solver_keys`.
fn newmark(solver_keys: &str) -> String {
    let solver = format!("    Final Time: 5.0e-4\n{solver_keys}\n    Implicit:\n      Fixed dt: 1.0e-4\n      Beta: 0.25\n      Gamma: 0.5\n      Absolute Tolerance: 1.0e-8\n      Maximum Solver Iterations: 20");
    quasi_static_bar::bar_deck(&solver, 0.012, 0.004, 1)
        .replace("0.012*t", "24.0*t")
        .replace("0.004*t", "8.0*t")
}

#[test]
fn snes_drives_quasi_static_and_newmark_lists_to_the_native_direct_answer() {
    let snes = "    Backend: \"PETSc\"\n    Nonlinear Solver: \"SNES\"\n    Linear Solver: \"GMRES\"\n    Linear Solver Tolerance: 1.0e-12";
    for (name, deck, motion) in [
        // The bar's largest displacement is the 0.012 m pull.
        ("QuasiStatic", quasi_static as fn(&str) -> String, 0.012),
        // The right face moves 24 m/s × 5e-4 s = 0.012 m by the end.
        ("Newmark-β", newmark as fn(&str) -> String, 0.012),
    ] {
        let native = tempfile::tempdir().unwrap();
        run(native.path(), &deck("    Linear Solver: \"Direct\""));
        let reference = final_displacement(native.path());
        let scale = reference.iter().fold(0.0f64, |m, u| m.max(u.abs()));
        assert!((scale - motion).abs() < 1e-9, "{name}: {scale}");
        let dir = tempfile::tempdir().unwrap();
        let log = run(dir.path(), &deck(snes));
        // SNES ran: the log names it as the list's solver.
        assert!(
            log.contains("linear solver: PETSc SNES newtonls (assembled tangent)"),
            "{name}: {log}"
        );
        let difference = largest_difference(&reference, &final_displacement(dir.path()));
        // QuasiStatic: both stop at ‖r‖₂ + 20‖r‖∞ ≤ 1 N on a stiffness of order 1e11 N/m (bulk
        // modulus 1.3e11 Pa times the 1 m spacing), so both are within ~1e-11 m of
        // equilibrium. Newmark-β: both stop at βΔt²‖f + b − ρa‖₂ ≤ 1e-8 on the same equations.
        // 1e-8 of the motion is looser than either and far tighter than a wrong answer.
        assert!(
            difference <= 1e-8 * scale,
            "{name}: SNES differs from the native direct solve by {difference:e}"
        );
    }
}

#[test]
fn check_shows_snes_for_a_quasi_static_list_that_asks_for_it() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bar.yaml");
    std::fs::write(
        &path,
        quasi_static("    Backend: \"PETSc\"\n    Nonlinear Solver: \"SNES\"\n    Linear Solver: \"CG\"\n    PETSc Options: \"-snes_linesearch_type basic\""),
    )
    .unwrap();
    let (code, log) = run_cli(&["check", path.to_str().unwrap()]);
    assert_eq!(code, Some(0), "{log}");
    // The deck's `-snes_linesearch_type` reached the SNES.
    assert!(
        log.contains("PETSc SNES newtonls (line search basic), KSP cg + PC bjacobi"),
        "{log}"
    );
}

#[test]
fn snes_on_another_backend_is_an_error_naming_the_key() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bar.yaml");
    // With a Backend given: a deck error (exit code 2) at the key's line.
    std::fs::write(
        &path,
        quasi_static("    Backend: \"Native\"\n    Nonlinear Solver: \"SNES\""),
    )
    .unwrap();
    let (code, log) = run_cli(&["check", path.to_str().unwrap()]);
    assert_eq!(code, Some(2), "{log}");
    assert!(
        log.contains("Nonlinear Solver \"SNES\" is PETSc's"),
        "{log}"
    );
    assert!(log.contains("bar.yaml"), "{log}");
    // Without one (so `--backend` could still choose PETSc): refused when the run starts.
    std::fs::write(&path, quasi_static("    Nonlinear Solver: \"SNES\"")).unwrap();
    let out = dir.path().to_str().unwrap();
    let (code, log) = run_cli(&["run", path.to_str().unwrap(), "--output-dir", out]);
    assert_ne!(code, Some(0), "{log}");
    assert!(
        log.contains("Nonlinear Solver \"SNES\" is PETSc's"),
        "{log}"
    );
    let (code, log) = run_cli(&[
        "run",
        path.to_str().unwrap(),
        "--output-dir",
        out,
        "--backend",
        "petsc",
    ]);
    assert_eq!(code, Some(0), "{log}");
    assert!(log.contains("PETSc SNES newtonls"), "{log}");
}

/// The bar in two `NOXQuasiStatic` load steps solved by NOX's nonlinear CG keys
/// (`Direction → Method: "NonlinearCG"`), with `nonlinear_cg` the `Nonlinear CG` sublist. The
/// tolerance, ‖F‖₂ ≤ 1e-2 N, is the one the MPI tests give SNES: the round-off of bond forces
/// near 1e10 N leaves ‖F‖₂ near 2e-3 N at best here.
fn nonlinear_cg(nonlinear_cg: &str) -> String {
    let solver = format!(
        "    Final Time: 1.0\n    Backend: \"PETSc\"\n    NOXQuasiStatic:\n      Number of Load Steps: {{steps}}\n      Absolute Tolerance: 1.0e-2\n      Max Solver Iterations: 100\n      Line Search:\n        Method: \"NonlinearCG\"\n      Direction:\n        Method: \"NonlinearCG\"\n        Nonlinear CG:\n{nonlinear_cg}"
    );
    quasi_static_bar::bar_deck(&solver, 0.012, 0.004, 2)
}

/// Peridigm's `Compression_NLCGQS_3x2x2` settings: Fletcher–Reeves, restarted every 15
/// iterations, each direction preconditioned by 15 Jacobi-preconditioned GMRES iterations.
const NLCGQS_KEYS: &str = "          Restart Frequency: 15\n          Precondition: \"On\"\n          Orthogonalize: \"Fletcher-Reeves\"\n          Linear Solver:\n            Aztec Solver: \"GMRES\"\n            Preconditioner: \"AztecOO\"\n            Aztec Preconditioner: \"Jacobi\"\n            AztecOO Preconditioner Iterations: 15";

#[test]
fn snes_nonlinear_cg_reaches_the_native_direct_answer() {
    let native = tempfile::tempdir().unwrap();
    run(
        native.path(),
        &quasi_static("    Linear Solver: \"Direct\""),
    );
    let reference = final_displacement(native.path());
    let scale = reference.iter().fold(0.0f64, |m, u| m.max(u.abs()));
    // The bar's largest displacement is the 0.012 m pull.
    assert!((scale - 0.012).abs() < 1e-9, "{scale}");
    for (name, keys) in [
        ("Fletcher-Reeves, preconditioned", NLCGQS_KEYS.to_string()),
        (
            "Polak-Ribiere, preconditioned",
            NLCGQS_KEYS.replace("Fletcher-Reeves", "Polak-Ribiere"),
        ),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let log = run(dir.path(), &nonlinear_cg(&keys));
        assert!(log.contains("PETSc SNES ncg"), "{name}: {log}");
        let difference = largest_difference(&reference, &final_displacement(dir.path()));
        // The native run stops at ‖r‖₂ + 20‖r‖∞ ≤ 1 N, the NCG one at ‖F‖₂ ≤ 1e-2 N, on a
        // stiffness of order 1e11 N/m: both within ~1e-11 m of equilibrium, so 1e-8 of the
        // motion is looser than either and far tighter than a wrong answer.
        assert!(
            difference <= 1e-8 * scale,
            "{name}: SNES NCG differs from the native direct solve by {difference:e}"
        );
    }
}

#[test]
fn check_shows_the_nonlinear_cg_petsc_makes_of_the_nox_keys() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bar.yaml");
    std::fs::write(&path, nonlinear_cg(NLCGQS_KEYS)).unwrap();
    let (code, log) = run_cli(&["check", path.to_str().unwrap()]);
    assert_eq!(code, Some(0), "{log}");
    // Orthogonalize → fr, Restart Frequency → 15, AztecOO GMRES + Jacobi, 15 iterations.
    assert!(
        log.contains("PETSc SNES ncg fr (line search cp), restarted every 15 iterations, preconditioned by one newtonls step: KSP gmres + PC jacobi, 15 iterations"),
        "{log}"
    );
    // Without `Precondition: "On"` the directions are F itself (NOX's default is "Off").
    std::fs::write(
        &path,
        nonlinear_cg("          Orthogonalize: \"Polak-Ribiere\""),
    )
    .unwrap();
    let (code, log) = run_cli(&["check", path.to_str().unwrap()]);
    assert_eq!(code, Some(0), "{log}");
    // NOX's Restart Frequency default is 10.
    assert!(
        log.contains(
            "PETSc SNES ncg prp (line search cp), restarted every 10 iterations, unpreconditioned"
        ),
        "{log}"
    );
}

#[test]
fn a_nonlinear_cg_key_petsc_cannot_map_is_an_error_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bar.yaml");
    for (keys, expected) in [
        (
            NLCGQS_KEYS.replace("Fletcher-Reeves", "Hestenes-Stiefel"),
            "Orthogonalize: \"Hestenes-Stiefel\": use \"Fletcher-Reeves\" or \"Polak-Ribiere\"",
        ),
        (
            NLCGQS_KEYS.replace("\"Jacobi\"", "\"Neumann\""),
            "Aztec Preconditioner: \"Neumann\" on the PETSc backend",
        ),
    ] {
        std::fs::write(&path, nonlinear_cg(&keys)).unwrap();
        let (code, log) = run_cli(&["check", path.to_str().unwrap()]);
        assert_eq!(code, Some(2), "{log}");
        assert!(log.contains(expected), "{log}");
        assert!(log.contains("bar.yaml"), "{log}");
    }
}
