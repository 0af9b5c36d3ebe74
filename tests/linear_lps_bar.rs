//! `Linear LPS Partial Volume` decks run: the quasi-static bar of `implicit_solvers` under a
//! small pull gives `Elastic`'s displacements to first order in the strain, with the full
//! volume and, with `Use Partial Volume: true`, with the `Exact` rule that key selects.

mod quasi_static_bar;
use quasi_static_bar::{bar_deck, final_displacement, run_deck};

const QUASI_STATIC: &str = "    Final Time: 1.0
    QuasiStatic:
      Number of Load Steps: {steps}
      Absolute Tolerance: 1.0e-3
      Maximum Solver Iterations: 20";

/// The bar pulled by 1e-3 (mean strain ≈ 1e-4) with the material model line `model` and the
/// extra block lines `block`; the final displacement of every point.
fn pulled_bar(model: &str, block: &str) -> Vec<f64> {
    let text = bar_deck(QUASI_STATIC, 1e-3, 0.0, 1)
        .replace("Material Model: \"Elastic\"", model)
        .replace("Horizon: 2.1", &format!("Horizon: 2.1{block}"));
    let dir = tempfile::tempdir().unwrap();
    run_deck(dir.path(), &text).expect("the bar runs");
    final_displacement(dir.path())
}

/// max |a − b| / max |b|.
fn relative_difference(a: &[f64], b: &[f64]) -> f64 {
    let scale = b.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(scale > 0.0);
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (p, q)| m.max((p - q).abs()))
        / scale
}

#[test]
fn a_linear_lps_bar_matches_elastic_to_first_order_in_the_strain() {
    // The linearized extension and direction differ from `Elastic`'s by O(ε) relative
    // (ε ≈ 1e-4 here, the displacement gradient of a 1e-3 pull over 12 lengths): the
    // displacements agree to O(ε) relative (measured: about 3e-6).
    let linear = pulled_bar("Material Model: \"Linear LPS Partial Volume\"", "");
    let elastic = pulled_bar("Material Model: \"Elastic\"", "");
    let full = relative_difference(&linear, &elastic);
    assert!(full < 1e-4, "full volume: {full}");

    // `Use Partial Volume: true` without a block `Quadrature` is the `Exact` rule.
    let partial = pulled_bar(
        "Material Model: \"Linear LPS Partial Volume\"\n      Use Partial Volume: true",
        "",
    );
    let exact = pulled_bar(
        "Material Model: \"Elastic\"",
        "\n      Quadrature: \"Exact\"",
    );
    let with_rule = relative_difference(&partial, &exact);
    assert!(with_rule < 1e-4, "exact rule: {with_rule}");
    // ... and not the full volume: the rule changes the bar's displacements by about 1e-2.
    let against_full = relative_difference(&partial, &elastic);
    assert!(
        against_full > 10.0 * with_rule,
        "{against_full} vs {with_rule}"
    );
}
