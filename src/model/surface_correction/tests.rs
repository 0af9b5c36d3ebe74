use super::*;
use crate::model::quadrature;
use crate::model::test_support::{brute_force_bonds, lattice};

/// Positions, cell volumes, families and quadrature volumes (`None`: full cell volumes).
type Body = (Vec<[f64; 3]>, Vec<f64>, BondList, Option<Vec<f64>>);

/// The families, cell volumes and quadrature volumes of an `n`³ unit lattice under `rule`
/// with horizon `horizon`.
fn body(n: usize, rule: QuadratureRule, horizon: f64) -> Body {
    let x = lattice(n);
    let v = vec![1.0; x.len()];
    let bonds = brute_force_bonds(&x, rule.family_reach(horizon, 1.0));
    let rules = vec![rule; x.len()];
    let horizons = vec![horizon; x.len()];
    let weights = quadrature::bond_volumes(&bonds, &x, &v, &rules, &horizons).map(|(w, _)| w);
    (x, v, bonds, weights)
}

fn factors(
    n: usize,
    rule: QuadratureRule,
    horizon: f64,
    correction: SurfaceCorrection,
) -> (BondList, Vec<f64>) {
    let (x, v, bonds, weights) = body(n, rule, horizon);
    let count = x.len();
    let g = point_factors(
        &bonds,
        &x,
        BondVolumes::new(&v, weights.as_deref()),
        &vec![correction; count],
        &vec![rule; count],
        &vec![horizon; count],
        &v,
    );
    (bonds, g)
}

#[test]
fn bulk_measure_of_the_full_volume_lattice_by_hand() {
    // δ = 2.01 on the unit lattice: the shells |n|² = 1, 2, 3, 4 (6, 12, 8, 6 points).
    // P = Σ n⊗n/|n|³ is isotropic on a cubic lattice (trace/3 on the diagonal), so
    // p¹ = Σ 1/|n| / 3.
    let shells = [(1.0f64, 6.0), (2.0, 12.0), (3.0, 8.0), (4.0, 6.0)];
    let inverse: f64 = shells.iter().map(|(r2, k)| k / r2.sqrt()).sum();
    let rule = QuadratureRule::FullVolume;
    let p = SurfaceCorrection::ForceNormalization.bulk_measure(rule, 2.01, 1.0);
    assert!(
        (p - inverse / 3.0).abs() < 1e-12 * p,
        "{p} vs {}",
        inverse / 3.0
    );
    // Scaling: spacing h multiplies ξ by h and w by h³, so Σ w ξ⊗ξ/|ξ|³ by h².
    let h = 1e-3;
    let p_h = SurfaceCorrection::ForceNormalization.bulk_measure(rule, 2.01 * h, h);
    assert!((p_h / (h * h) - p).abs() < 1e-9 * p);
}

#[test]
fn a_point_with_a_whole_family_keeps_factor_one_and_face_points_stiffen() {
    // On a lattice, a point whose family is complete sums the bulk lattice's terms: g = 1 up
    // to the order of the sum. Removing bonds never raises P's largest eigenvalue (P loses
    // positive semi-definite terms), so g ≥ 1; a point on a face loses bonds in the face's
    // plane too, so its largest eigenvalue drops and g > 1. (A point one layer in may keep
    // g = 1: with δ = 2.01 it loses only the bond straight across, which adds nothing to the
    // in-plane eigenvalue.)
    for (rule, horizon, n) in [
        (QuadratureRule::FullVolume, 2.01, 7),
        (QuadratureRule::PdLammps, 2.01, 7),
        (QuadratureRule::Exact, 2.01, 7),
    ] {
        // The size of a whole family: the lattice points within the rule's reach.
        let reach = rule.family_reach(horizon, 1.0);
        let full = (-3i32..=3)
            .flat_map(|a| (-3i32..=3).flat_map(move |b| (-3i32..=3).map(move |c| [a, b, c])))
            .filter(|n| {
                let r2 = f64::from(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
                r2 > 0.0 && r2 <= reach * reach
            })
            .count();
        let (bonds, g) = factors(n, rule, horizon, SurfaceCorrection::ForceNormalization);
        let x = lattice(n);
        let mut interior = 0;
        for (i, &g) in g.iter().enumerate() {
            assert!(g >= 1.0 - 1e-12, "{rule:?}: point {i} g = {g}");
            if bonds.family_size(i) == full {
                interior += 1;
                assert!((g - 1.0).abs() < 1e-12, "{rule:?}: interior g = {g}");
            }
            if x[i].iter().any(|&c| c == 0.0 || c == (n - 1) as f64) {
                assert!(g > 1.0 + 1e-3, "{rule:?}: face point {i} g = {g}");
            }
        }
        assert!(interior >= 1, "{rule:?}: no interior point");
    }
}

#[test]
fn bond_factors_are_the_symmetric_mean_of_the_ends() {
    let (bonds, g) = factors(
        6,
        QuadratureRule::FullVolume,
        2.01,
        SurfaceCorrection::ForceNormalization,
    );
    let mut weights = vec![1.0; bonds.num_bonds()];
    scale_bond_volumes(&bonds, &g, &mut weights);
    for i in 0..bonds.num_points() {
        for b in bonds.range(i) {
            let j = bonds.neighbor[b] as usize;
            let back = bonds.range(j).start + bonds.family(j).binary_search(&(i as u32)).unwrap();
            assert_eq!(weights[b], weights[back]);
            assert_eq!(weights[b], 0.5 * (g[i] + g[j]));
        }
    }
}

#[test]
fn a_corner_point_is_normalized_by_its_largest_eigenvalue() {
    // Eq. (36) of Macek & Silling: g = p¹_∞ / p¹. Check against P assembled independently at
    // the corner (0, 0, 0) of a 5³ lattice (δ = 2.01): its family is the octant n ≥ 0.
    let (_, g) = factors(
        5,
        QuadratureRule::FullVolume,
        2.01,
        SurfaceCorrection::ForceNormalization,
    );
    let mut p = nalgebra::Matrix3::<f64>::zeros();
    for a in 0..=2i32 {
        for b in 0..=2i32 {
            for c in 0..=2i32 {
                let r2 = f64::from(a * a + b * b + c * c);
                if r2 == 0.0 || r2 > 2.01 * 2.01 {
                    continue;
                }
                let n = nalgebra::Vector3::new(f64::from(a), f64::from(b), f64::from(c));
                p += n * n.transpose() / r2.powf(1.5);
            }
        }
    }
    // The octant's P is invariant under permutations of the axes: (1, 1, 1) is an
    // eigenvector, and its eigenvalue (the largest, every entry being positive) is the row sum.
    let largest = p.row(0).sum();
    let bulk =
        SurfaceCorrection::ForceNormalization.bulk_measure(QuadratureRule::FullVolume, 2.01, 1.0);
    assert!(
        (g[0] - bulk / largest).abs() < 1e-12 * g[0],
        "{} vs {}",
        g[0],
        bulk / largest
    );
}
