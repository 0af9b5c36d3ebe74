use super::*;
use std::f64::consts::PI;

/// Lattice vectors ξ = (a, b, c)·Δx − `offset` of every cell that can touch the sphere of
/// radius δ (centre distance ≤ δ + √3/2·Δx), the point itself excluded when `offset` = 0.
fn lattice(spacing: f64, horizon: f64, offset: [f64; 3]) -> Vec<[f64; 3]> {
    let reach = horizon + 0.5 * 3f64.sqrt() * spacing;
    let n = (reach / spacing).ceil() as i64 + 1;
    let mut out = Vec::new();
    for a in -n..=n {
        for b in -n..=n {
            for c in -n..=n {
                let xi = [a, b, c].map(|v| v as f64 * spacing);
                let xi = [0, 1, 2].map(|k| xi[k] - offset[k]);
                let zeta = (xi[0] * xi[0] + xi[1] * xi[1] + xi[2] * xi[2]).sqrt();
                if zeta > 0.0 && zeta <= reach {
                    out.push(xi);
                }
            }
        }
    }
    out
}

#[test]
fn exact_partial_volumes_reproduce_the_horizon_sphere() {
    // The cells tile space, so Σ_j |cell_j ∩ sphere| over every cell (the point's own cell
    // included, whose whole volume lies inside when δ ≥ √3/2·Δx) is the sphere's volume
    // 4/3 π δ³ exactly; the issue asks for 1e-4 relative at m = 3 for an interior point.
    for (m, offset) in [(3.0, [0.0; 3]), (3.0, [0.3, -0.1, 0.2]), (4.5, [0.0; 3])] {
        let spacing = 0.7;
        let horizon = m * spacing;
        // With an offset the point's own cell (n = 0) is one of the lattice vectors.
        let own = if offset == [0.0; 3] {
            cell_sphere_volume([0.0; 3], spacing, horizon)
        } else {
            0.0
        };
        let total: f64 = own
            + lattice(spacing, horizon, offset)
                .iter()
                .map(|&xi| {
                    QuadratureRule::Exact
                        .bond_volume(xi, horizon, spacing.powi(3))
                        .volume
                })
                .sum::<f64>();
        let sphere = 4.0 / 3.0 * PI * horizon.powi(3);
        let error = (total - sphere).abs() / sphere;
        assert!(
            error < 1e-10,
            "m = {m}, offset {offset:?}: relative error {error:e}"
        );
    }
}

#[test]
fn exact_cell_volume_matches_closed_forms() {
    // A sphere of radius R ≤ side centred at a corner of the cube fills one octant of it:
    // (1/8)(4/3)πR³.
    let (side, radius) = (2.0, 1.5);
    let v = cell_sphere_volume([1.0, 1.0, 1.0], side, radius);
    let octant = PI * radius.powi(3) / 6.0;
    assert!((v - octant).abs() < 1e-12 * octant, "{v} vs {octant}");
    // Centred on a face's centre with R ≤ side/2: a hemisphere, (2/3)πR³.
    let v = cell_sphere_volume([1.0, 0.0, 0.0], side, 0.8);
    let hemisphere = 2.0 / 3.0 * PI * 0.8f64.powi(3);
    assert!(
        (v - hemisphere).abs() < 1e-12 * hemisphere,
        "{v} vs {hemisphere}"
    );
    // A cube wholly inside, and one wholly outside.
    assert_eq!(cell_sphere_volume([0.5, 0.0, 0.0], 1.0, 3.0), 1.0);
    assert_eq!(cell_sphere_volume([5.0, 0.0, 0.0], 1.0, 3.0), 0.0);
    // A slab cap: the cube [0, 4]×[−2, 2]² about a sphere of radius 1 centred at x = 0 holds
    // the half ball only (the sphere never reaches the cube's y, z faces): (2/3)π.
    let v = cell_sphere_volume([2.0, 0.0, 0.0], 4.0, 1.0);
    assert!((v - 2.0 / 3.0 * PI).abs() < 1e-12);
}

#[test]
fn full_volume_counts_the_lattice_points_in_the_sphere() {
    // Brute force: the points of the cubic lattice with 0 < |ξ| ≤ δ each carry their whole
    // cell, so Σ w = N·Δx³ with N counted directly.
    let (spacing, horizon) = (0.5, 1.5);
    let mut count = 0;
    let mut total = 0.0;
    for xi in lattice(spacing, horizon, [0.0; 3]) {
        let zeta = (xi[0] * xi[0] + xi[1] * xi[1] + xi[2] * xi[2]).sqrt();
        if zeta <= horizon {
            count += 1;
            total += QuadratureRule::FullVolume
                .bond_volume(xi, horizon, spacing.powi(3))
                .volume;
        }
    }
    // m = 3: the 122 lattice points of Z³ with 0 < |n|² ≤ 9 (r₃ sums: 6+12+8+6+24+24+12+30
    // = 122 for |n|² = 1…9).
    assert_eq!(count, 122);
    assert_eq!(total, 122.0 * spacing.powi(3));
}

#[test]
fn adaptive_integration_meets_its_tolerance() {
    // Each bond's adaptive volume against the exact one, within EPS of its cell volume (a
    // sliver cell the sphere barely reaches may stop at the largest index before its relative
    // test passes; its absolute error is still far below EPS·V). Summed over the horizon the
    // error must also be within EPS of 4/3 π δ³.
    let (spacing, horizon) = (1.0, 3.0);
    let cell = spacing * spacing * spacing;
    for tolerance in [1e-3, 1e-4, 1e-5] {
        let rule = QuadratureRule::Adaptive { tolerance };
        let mut total = cell;
        for xi in lattice(spacing, horizon, [0.0; 3]) {
            let adaptive = rule.bond_volume(xi, horizon, cell);
            let exact = cell_sphere_volume(xi, spacing, horizon);
            let bound = tolerance * exact.max(cell);
            assert!(
                (adaptive.volume - exact).abs() <= bound,
                "EPS {tolerance}: bond {xi:?}: {} vs exact {exact}",
                adaptive.volume
            );
            total += adaptive.volume;
        }
        let sphere = 4.0 / 3.0 * PI * horizon.powi(3);
        assert!((total - sphere).abs() <= tolerance * sphere);
    }
}

#[test]
fn linear_partial_volume_factors() {
    // β = (δ + Δx/2 − ζ)/Δx between δ − Δx/2 and δ + Δx/2 (Parks et al. 2008; Yu, Xin &
    // Lease eq. 14). δ = 3, Δx = 1: ζ = 2.5 → 1, ζ = 2.75 → 0.75, ζ = 3 → ½, ζ = 3.5 → 0.
    let cell = 1.0;
    for rule in [QuadratureRule::PdLammps, QuadratureRule::Hhb] {
        for (zeta, factor) in [(1.0, 1.0), (2.5, 1.0), (2.75, 0.75), (3.0, 0.5), (3.5, 0.0)] {
            let w = rule.bond_volume([zeta, 0.0, 0.0], 3.0, cell).volume;
            assert!((w - factor).abs() < 1e-15, "{rule:?} ζ = {zeta}: {w}");
        }
    }
    assert_eq!(QuadratureRule::PdLammps.family_reach(3.0, 1.0), 3.0);
    assert_eq!(QuadratureRule::Hhb.family_reach(3.0, 1.0), 3.5);
}

#[test]
fn exact_weights_are_symmetric() {
    // Inverting through the midpoint maps cell_j ∩ sphere_i onto cell_i ∩ sphere_j.
    let xi = [1.3, -2.1, 0.4];
    let back = xi.map(|v| -v);
    let forward = cell_sphere_volume(xi, 1.0, 2.9);
    let reverse = cell_sphere_volume(back, 1.0, 2.9);
    assert!(forward > 0.0 && forward < 1.0);
    assert!((forward - reverse).abs() < 1e-14);
}

#[test]
fn linear_partial_volumes_reproduce_the_papers_cubic_cell_table() {
    // Yu, Xin & Lease, Table 1, "CCI" column: horizon sphere volumes by cubic-cell integration
    // with δ = 18h, exact 4/3 π 18³ = 24429.0 h³. Relative errors from the tabulated volumes:
    // Δx = δ/3: 22476.7, δ/4: 21857.9, δ/5: 22483.1, δ/6: 23234.1. The family ends at δ and
    // the partial factor is PDLAMMPS's; the paper prints 5 digits, so 1e-4 relative.
    for (m, volume) in [
        (3.0, 22476.7),
        (4.0, 21857.9),
        (5.0, 22483.1),
        (6.0, 23234.1),
    ] {
        let expected = volume / (4.0 / 3.0 * PI * 18f64.powi(3)) - 1.0;
        let got = lattice_horizon_volume_error(QuadratureRule::PdLammps, m);
        assert!(
            (got - expected).abs() < 1e-4,
            "m = {m}: {got} vs {expected}"
        );
    }
}
