use super::*;
use crate::model::test_support::Rng;
use crate::neighbors::{Disk, RectangularPlane};

fn random_cloud(n: usize, seed: u64) -> Vec<[f64; 3]> {
    let mut random = Rng::new(seed);
    (0..n)
        .map(|_| [random.uniform(), random.uniform(), random.uniform()])
        .collect()
}

/// Cell-centred lattice x0 + (i+½)h, x fastest (PdQuickGrid order).
fn lattice(n: usize, h: f64) -> Vec<[f64; 3]> {
    let mut points = Vec::with_capacity(n * n * n);
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                points.push([
                    (i as f64 + 0.5) * h,
                    (j as f64 + 0.5) * h,
                    (k as f64 + 0.5) * h,
                ]);
            }
        }
    }
    points
}

fn search<'a>(
    positions: &'a [[f64; 3]],
    horizons: &'a [f64],
    blocks: &'a [u32],
    rule: NeighborhoodRule,
) -> FamilySearch<'a> {
    FamilySearch {
        positions,
        horizons,
        blocks,
        rule,
        omit_bonds_between_blocks: false,
        filters: &[],
    }
}

#[cfg(target_arch = "x86_64")]
#[test]
fn the_avx2_grid_search_is_the_baseline_search() {
    // The AVX2 build of `CellGrid::neighbours` against the baseline build, row by row, in
    // both halves: the same neighbours in the same order and the same lower counts, on a
    // random cloud with points at the horizon's edge of a lattice mixed in.
    if !crate::vector_width::wide_vectors_available() {
        return;
    }
    let mut positions = random_cloud(1500, 11);
    positions.extend(lattice(8, 0.125));
    let horizons = vec![0.125 * 3.015; positions.len()];
    let blocks = vec![0; positions.len()];
    let s = search(&positions, &horizons, &blocks, NeighborhoodRule::Sphere);
    let queries = Queries::new(&s);
    let rules = BondRules::new(&s, queries.pad);
    let grid = CellGrid::new(&positions, &queries, MAX_CELLS_PER_POINT * positions.len());
    let (mut wide, mut baseline) = (Vec::new(), Vec::new());
    let mut accepted = 0;
    for half in [Half::Both, Half::Upper] {
        for (i, &p) in positions.iter().enumerate() {
            wide.clear();
            baseline.clear();
            let query = Query {
                i,
                p,
                shape: queries.shape(i),
                rules: &rules,
                half,
            };
            // SAFETY: the CPU reports AVX2 (checked above).
            let lower_wide = unsafe { grid.neighbours_avx2(query, &mut wide) };
            let lower_baseline = grid.neighbours_inlined::<false>(query, &mut baseline);
            assert_eq!(wide, baseline, "point {i}");
            assert_eq!(lower_wide, lower_baseline, "point {i}");
            accepted += wide.len();
        }
    }
    assert!(accepted > 10 * positions.len(), "{accepted}");
}

/// Reference families from the rule's definition, written independently of the search code:
/// every ordered pair tested, rows naturally sorted.
fn brute_force(s: &FamilySearch) -> Vec<Vec<u32>> {
    let n = s.positions.len();
    (0..n)
        .map(|i| {
            let a = s.positions[i];
            let delta = s.horizons[i];
            (0..n)
                .filter(|&j| j != i)
                .filter(|&j| {
                    let b = s.positions[j];
                    let xi = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
                    let d2 = xi[0] * xi[0] + xi[1] * xi[1] + xi[2] * xi[2];
                    let geometric = match s.rule {
                        NeighborhoodRule::Sphere => d2 <= delta * delta,
                        NeighborhoodRule::LatticeBox {
                            spacing,
                            cells,
                            spherical,
                        } => {
                            (0..3).all(|k| {
                                let ratio = delta / spacing[k];
                                let mut reach = ratio.floor();
                                if ratio - reach >= 0.5 {
                                    reach += 1.0;
                                }
                                let reach = reach.min(cells[k] as f64);
                                (xi[k] / spacing[k]).round().abs() <= reach
                            }) && (!spherical || d2 < delta * delta)
                        }
                    };
                    geometric
                        && (!s.omit_bonds_between_blocks || s.blocks[i] == s.blocks[j])
                        && !s.filters.iter().any(|f| f.cuts(a, b))
                })
                .map(|j| j as u32)
                .collect()
        })
        .collect()
}

fn rows(bonds: &BondList) -> Vec<Vec<u32>> {
    (0..bonds.num_points())
        .map(|i| bonds.family(i).to_vec())
        .collect()
}

const BACKENDS: [SearchBackend; 3] = [
    SearchBackend::Auto,
    SearchBackend::CellGrid,
    SearchBackend::KdTree,
];

/// Runs every backend, checks CSR invariants and reference lengths, and returns the rows
/// (all backends must agree).
fn families(s: &FamilySearch) -> Vec<Vec<u32>> {
    let mut result: Option<Vec<Vec<u32>>> = None;
    for backend in BACKENDS {
        let bonds = find_families_with(s, backend).unwrap();
        assert_eq!(bonds.offsets.len(), s.positions.len() + 1);
        assert_eq!(bonds.reference_length.len(), bonds.neighbor.len());
        for i in 0..bonds.num_points() {
            let family = bonds.family(i);
            assert!(family.windows(2).all(|w| w[0] < w[1]), "row {i} not sorted");
            assert!(!family.contains(&(i as u32)), "self in row {i}");
            for (b, &j) in bonds.range(i).zip(family) {
                let (x, y) = (s.positions[i], s.positions[j as usize]);
                let length =
                    ((y[0] - x[0]).powi(2) + (y[1] - x[1]).powi(2) + (y[2] - x[2]).powi(2)).sqrt();
                assert_eq!(bonds.reference_length[b], length);
            }
        }
        let r = rows(&bonds);
        if let Some(previous) = &result {
            assert_eq!(previous, &r, "{backend:?} differs");
        }
        result = Some(r);
    }
    result.unwrap()
}

/// The mirrored assembly must give exactly the bond list of the direct one (each row
/// searched in full and sorted): same rows, same order, bitwise the same lengths.
fn assert_mirrored_equals_direct(s: &FamilySearch) {
    assert!(
        is_mirrorable(s, None),
        "the case must take the mirrored path"
    );
    for backend in [SearchBackend::CellGrid, SearchBackend::KdTree] {
        let direct = find_rows_assembled(s, backend, None, false).unwrap();
        let mirrored = find_rows_assembled(s, backend, None, true).unwrap();
        assert_eq!(mirrored.offsets, direct.offsets, "{backend:?}");
        assert_eq!(mirrored.neighbor, direct.neighbor, "{backend:?}");
        let bits =
            |b: &BondList| -> Vec<u64> { b.reference_length.iter().map(|l| l.to_bits()).collect() };
        assert_eq!(bits(&mirrored), bits(&direct), "{backend:?}");
    }
}

#[test]
fn mirrored_assembly_equals_direct_search() {
    // Irregular points, several blocks of the assembly (BLOCK = 8192 points would need a
    // bigger cloud, so the search runs on a 9000-point sparse cloud with a small horizon
    // to stay quick: ≈ 4 neighbours per point, rows crossing the block boundary).
    let positions = random_cloud(9000, 21);
    let horizons = vec![0.05; positions.len()];
    let blocks = vec![0u32; positions.len()];
    let s = search(&positions, &horizons, &blocks, NeighborhoodRule::Sphere);
    assert!(find_families(&s).num_bonds() > 20_000);
    assert_mirrored_equals_direct(&s);
    // Omitted cross-block bonds: the block test is symmetric, so it mirrors too.
    let positions = random_cloud(800, 5);
    let horizons = vec![0.15; positions.len()];
    let blocks: Vec<u32> = positions.iter().map(|p| (p[1] > 0.4) as u32).collect();
    let mut s = search(&positions, &horizons, &blocks, NeighborhoodRule::Sphere);
    s.omit_bonds_between_blocks = true;
    assert_mirrored_equals_direct(&s);
    // Lattices, in lattice order and shuffled into another order: the ball and both
    // QuickGrid box rules.
    let h = 0.1;
    let mut positions = lattice(8, h);
    let horizons = vec![3.015 * h; positions.len()];
    let blocks = vec![0; positions.len()];
    for shuffled in [false, true] {
        if shuffled {
            let mut random = Rng::new(3);
            for k in (1..positions.len()).rev() {
                let other = (random.uniform() * (k + 1) as f64) as usize;
                positions.swap(k, other.min(k));
            }
        }
        let mut rules = vec![NeighborhoodRule::Sphere];
        for spherical in [false, true] {
            rules.push(NeighborhoodRule::LatticeBox {
                spacing: [h; 3],
                cells: [8; 3],
                spherical,
            });
        }
        for rule in rules {
            assert_mirrored_equals_direct(&search(&positions, &horizons, &blocks, rule));
        }
    }
}

#[test]
fn only_symmetric_searches_are_mirrored() {
    let positions = random_cloud(50, 1);
    let blocks = vec![0; 50];
    let mut horizons = vec![0.2; 50];
    let plane =
        RectangularPlane::new([0.0, 1.0, 0.0], [0.1, 0.5, 0.2], [1.0, 0.0, 0.0], 0.5, 0.6).unwrap();
    let filters = [BondFilter::from(plane)];
    let mut s = search(&positions, &horizons, &blocks, NeighborhoodRule::Sphere);
    assert!(is_mirrorable(&s, None));
    assert!(!is_mirrorable(&s, Some(&[0, 1])));
    s.filters = &filters;
    assert!(!is_mirrorable(&s, None));
    horizons[7] = 0.21;
    let s = search(&positions, &horizons, &blocks, NeighborhoodRule::Sphere);
    assert!(!is_mirrorable(&s, None));
}

#[test]
fn reference_lengths_agree_bitwise_in_both_directions() {
    let positions = random_cloud(2000, 7);
    let horizons = vec![0.12; positions.len()];
    let blocks = vec![0u32; positions.len()];
    let s = search(&positions, &horizons, &blocks, NeighborhoodRule::Sphere);
    let bonds = find_families(&s);
    for i in 0..bonds.num_points() {
        for b in bonds.range(i) {
            let j = bonds.neighbor[b] as usize;
            let k = bonds.offsets[j] + bonds.family(j).binary_search(&(i as u32)).unwrap();
            assert_eq!(
                bonds.reference_length[b].to_bits(),
                bonds.reference_length[k].to_bits()
            );
        }
    }
}

#[test]
fn interior_family_sizes_on_cubic_lattice() {
    // Integer vectors v with |v|² ≤ 3.015² = 9.09, by |v|² = 0..9 (sums of three squares):
    // 1 + 6 + 12 + 8 + 6 + 24 + 24 + 0 + 12 + 30 = 123; minus self → 122. The 30 at |v|² = 9
    // are the 6 axis vectors of length 3 and the 24 permutations of (±2, ±2, ±1).
    let counted = (-3i32..=3)
        .flat_map(|a| {
            (-3i32..=3).flat_map(move |b| (-3i32..=3).map(move |c| a * a + b * b + c * c))
        })
        .filter(|&d2| d2 != 0 && (d2 as f64) <= 3.015 * 3.015)
        .count();
    assert_eq!(counted, 122);

    let h = 0.25;
    let n = 9; // centre (4,4,4) has 4 ≥ 3 cells on every side: a full interior family
    let positions = lattice(n, h);
    let centre = 4 + n * (4 + n * 4);
    let horizons = vec![3.015 * h; positions.len()];
    let blocks = vec![0; positions.len()];
    let size = |rule| families(&search(&positions, &horizons, &blocks, rule))[centre].len();
    assert_eq!(size(NeighborhoodRule::Sphere), 122);
    // Box: n = floor(3.015) = 3 (fraction 0.015 < 0.5), (2·3 + 1)³ − 1 = 342.
    let lattice_rule = |spherical| NeighborhoodRule::LatticeBox {
        spacing: [h; 3],
        cells: [n; 3],
        spherical,
    };
    assert_eq!(size(lattice_rule(false)), 342);
    // Spherical: strict |ξ|² < δ². Lattice |ξ|²/h² are integers and 3.015² = 9.090225 is
    // not, so no point sits on the sphere and < and ≤ agree: 122 again.
    assert_eq!(size(lattice_rule(true)), 122);
}

#[test]
fn lattice_box_rounds_half_up_and_caps() {
    // δ = 2.5h: fraction exactly 0.5 rounds up → n = 3, box 7³ − 1 = 342 in the interior.
    // δ = 2.49h → n = 2, 5³ − 1 = 124.
    let h = 0.5;
    let n = 9;
    let positions = lattice(n, h);
    let centre = 4 + n * (4 + n * 4);
    let blocks = vec![0; positions.len()];
    let rule = NeighborhoodRule::LatticeBox {
        spacing: [h; 3],
        cells: [n; 3],
        spherical: false,
    };
    for (ratio, expected) in [(2.5, 342), (2.49, 124)] {
        let horizons = vec![ratio * h; positions.len()];
        let s = search(&positions, &horizons, &blocks, rule);
        let got = families(&s);
        assert_eq!(got[centre].len(), expected, "δ/h = {ratio}");
        assert_eq!(got, brute_force(&s));
    }
    // Cap: 3 cells in z, δ = 10h → n_z capped at 3, n_x = n_y = 3 cells cap too: on a 3×3×3
    // lattice every point sees all 26 others.
    let positions = lattice(3, h);
    let horizons = vec![10.0 * h; positions.len()];
    let blocks = vec![0; positions.len()];
    let rule = NeighborhoodRule::LatticeBox {
        spacing: [h; 3],
        cells: [3; 3],
        spherical: false,
    };
    let got = families(&search(&positions, &horizons, &blocks, rule));
    assert!(got.iter().all(|f| f.len() == 26));
}

#[test]
fn variable_horizons_give_asymmetric_families() {
    // Points on the x axis at 0, 1, 3 with δ = 1, 2, 0.5 (all exactly representable):
    // 0 reaches 1 (distance 1 ≤ 1) but not 3; 1 reaches 0 and 3 (distances 1, 2 ≤ 2);
    // 3 reaches nobody (nearest is 2 away > 0.5).
    let positions = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [3.0, 0.0, 0.0]];
    let horizons = [1.0, 2.0, 0.5];
    let blocks = [0; 3];
    let s = search(&positions, &horizons, &blocks, NeighborhoodRule::Sphere);
    assert_eq!(families(&s), vec![vec![1], vec![0, 2], vec![]]);
}

#[test]
fn neighbour_exactly_at_horizon_is_included() {
    // (0.75, 1, 0) is at distance exactly 1.25 from the origin (0.5625 + 1 = 1.5625 = 1.25²,
    // all exact in binary). With δ = 1.25 it is a neighbour; with the next smaller double it
    // is not.
    let positions = [[0.0, 0.0, 0.0], [0.75, 1.0, 0.0]];
    let blocks = [0; 2];
    let horizons = [1.25, 1.25];
    let s = search(&positions, &horizons, &blocks, NeighborhoodRule::Sphere);
    assert_eq!(families(&s), vec![vec![1], vec![0]]);
    let below = f64::from_bits(1.25f64.to_bits() - 1);
    let horizons = [below, below];
    let s = search(&positions, &horizons, &blocks, NeighborhoodRule::Sphere);
    assert_eq!(families(&s), vec![Vec::<u32>::new(), vec![]]);
}

#[test]
fn omitting_bonds_between_blocks_removes_exactly_cross_block_bonds() {
    let positions = random_cloud(600, 7);
    let horizons = vec![0.15; positions.len()];
    let blocks: Vec<u32> = positions
        .iter()
        .map(|p| (p[0] > 0.5) as u32 + (p[2] > 0.7) as u32)
        .collect();
    let mut s = search(&positions, &horizons, &blocks, NeighborhoodRule::Sphere);
    let all = families(&s);
    s.omit_bonds_between_blocks = true;
    let omitted = families(&s);
    let mut cross = 0;
    for i in 0..positions.len() {
        let same: Vec<u32> = all[i]
            .iter()
            .copied()
            .filter(|&j| blocks[j as usize] == blocks[i])
            .collect();
        cross += all[i].len() - same.len();
        assert_eq!(omitted[i], same, "row {i}");
    }
    assert!(
        cross > 100,
        "the test needs cross-block bonds, found {cross}"
    );
    assert_eq!(omitted, brute_force(&s));
}

#[test]
fn bond_filters_remove_exactly_the_crossing_bonds() {
    let positions = random_cloud(700, 11);
    let horizons = vec![0.16; positions.len()];
    let blocks = vec![0; positions.len()];
    let plane =
        RectangularPlane::new([0.0, 1.0, 0.0], [0.1, 0.5, 0.2], [1.0, 0.0, 0.0], 0.5, 0.6).unwrap();
    let normal = [1.0, 1.0, 0.5];
    let disk = Disk::new([0.6, 0.4, 0.5], normal, 0.25).unwrap();
    let filters = [BondFilter::from(plane), BondFilter::from(disk)];
    let mut s = search(&positions, &horizons, &blocks, NeighborhoodRule::Sphere);
    let unfiltered = families(&s);
    s.filters = &filters;
    let filtered = families(&s);
    assert_eq!(filtered, brute_force(&s));
    let removed: usize = unfiltered
        .iter()
        .zip(&filtered)
        .map(|(a, b)| a.len() - b.len())
        .sum();
    assert!(removed > 100, "the test needs cut bonds, found {removed}");
    // Constant horizon: families must stay symmetric (j ∈ N(i) ⇔ i ∈ N(j)).
    for (i, family) in filtered.iter().enumerate() {
        for &j in family {
            assert!(
                filtered[j as usize].binary_search(&(i as u32)).is_ok(),
                "{i}→{j} one-way"
            );
        }
    }
}

#[test]
fn agrees_with_brute_force_on_random_cloud_with_variable_horizons() {
    let positions = random_cloud(1500, 3);
    let mut random = Rng::new(99);
    let horizons: Vec<f64> = (0..positions.len())
        .map(|_| 0.05 + 0.15 * random.uniform())
        .collect();
    let blocks = vec![0; positions.len()];
    let s = search(&positions, &horizons, &blocks, NeighborhoodRule::Sphere);
    let got = families(&s);
    assert_eq!(got, brute_force(&s));
    let asymmetric = got.iter().enumerate().any(|(i, f)| {
        f.iter()
            .any(|&j| got[j as usize].binary_search(&(i as u32)).is_err())
    });
    assert!(asymmetric, "variable horizons should give one-way bonds");
}

#[test]
fn rows_of_some_points_are_their_rows_of_the_full_search() {
    // Variable horizons (one-way bonds) and both search structures: a rank's rows must be
    // bitwise the full search's, lengths included, in the order asked for.
    let positions = random_cloud(1500, 7);
    let mut random = Rng::new(11);
    let horizons: Vec<f64> = (0..positions.len())
        .map(|_| 0.05 + 0.15 * random.uniform())
        .collect();
    let blocks = vec![0; positions.len()];
    let s = search(&positions, &horizons, &blocks, NeighborhoodRule::Sphere);
    let all = try_find_families(&s).unwrap();
    let points: Vec<u32> = (0..positions.len() as u32).rev().step_by(7).collect();
    for rows in [
        try_find_families_of(&s, &points).unwrap(),
        find_rows_with(&s, SearchBackend::KdTree, Some(&points)).unwrap(),
        find_rows_with(&s, SearchBackend::CellGrid, Some(&points)).unwrap(),
    ] {
        assert_eq!(rows.num_points(), points.len());
        for (k, &p) in points.iter().enumerate() {
            assert_eq!(rows.family(k), all.family(p as usize));
            let (mine, full) = (rows.range(k), all.range(p as usize));
            assert_eq!(
                rows.reference_length[mine], all.reference_length[full],
                "point {p}"
            );
        }
    }
    assert_eq!(try_find_families_of(&s, &[]).unwrap().num_bonds(), 0);
}

#[test]
fn agrees_with_brute_force_on_lattice_rules_and_clustered_cloud() {
    let h = 0.1;
    let positions = lattice(8, h);
    let horizons = vec![2.2 * h; positions.len()];
    let blocks = vec![0; positions.len()];
    for spherical in [false, true] {
        let rule = NeighborhoodRule::LatticeBox {
            spacing: [h; 3],
            cells: [8; 3],
            spherical,
        };
        let s = search(&positions, &horizons, &blocks, rule);
        assert_eq!(families(&s), brute_force(&s));
    }
    // Two tight clusters far apart: a grid at the horizon's scale would need ~1e12 cells, so
    // Auto takes the tree and the forced grid enlarges its cells; both must stay exact.
    let mut positions = random_cloud(400, 5);
    for p in positions.iter_mut().skip(200) {
        p[0] += 1e4;
    }
    let horizons = vec![0.2; positions.len()];
    let blocks = vec![0; positions.len()];
    let s = search(&positions, &horizons, &blocks, NeighborhoodRule::Sphere);
    assert!(CellGrid::cells_needed(&positions, &Queries::new(&s)) > 1e6);
    assert_eq!(families(&s), brute_force(&s));
}

#[test]
fn degenerate_inputs() {
    let s = search(&[], &[], &[], NeighborhoodRule::Sphere);
    assert_eq!(find_families(&s).offsets, vec![0]);
    // Zero horizons and coincident points: nobody is a neighbour except coincident points
    // (distance 0 ≤ 0).
    let positions = [[1.0, 1.0, 1.0], [1.0, 1.0, 1.0], [2.0, 1.0, 1.0]];
    let horizons = [0.0; 3];
    let blocks = [0; 3];
    let s = search(&positions, &horizons, &blocks, NeighborhoodRule::Sphere);
    assert_eq!(families(&s), vec![vec![1], vec![0], vec![]]);
}

#[test]
fn invalid_input_is_an_error() {
    let positions = [[0.0; 3], [1.0, 0.0, 0.0]];
    let blocks = [0; 2];
    let bad = |horizons: &[f64]| {
        try_find_families(&search(
            &positions,
            horizons,
            &blocks,
            NeighborhoodRule::Sphere,
        ))
    };
    assert!(matches!(
        bad(&[1.0, -1.0]),
        Err(NeighborSearchError::BadHorizon { point: 1, .. })
    ));
    assert!(matches!(
        bad(&[f64::NAN, 1.0]),
        Err(NeighborSearchError::BadHorizon { point: 0, .. })
    ));
    assert!(matches!(
        bad(&[1.0]),
        Err(NeighborSearchError::LengthMismatch { .. })
    ));
    let positions = [[0.0, f64::INFINITY, 0.0], [1.0, 0.0, 0.0]];
    let horizons = [1.0; 2];
    let result = try_find_families(&search(
        &positions,
        &horizons,
        &blocks,
        NeighborhoodRule::Sphere,
    ));
    assert!(matches!(
        result,
        Err(NeighborSearchError::NonFinitePosition { point: 0, .. })
    ));
    let rule = NeighborhoodRule::LatticeBox {
        spacing: [1.0, 0.0, 1.0],
        cells: [2; 3],
        spherical: false,
    };
    let positions = [[0.0; 3], [1.0, 0.0, 0.0]];
    let result = try_find_families(&search(&positions, &horizons, &blocks, rule));
    assert!(matches!(result, Err(NeighborSearchError::BadSpacing(_))));
    assert!(result.unwrap_err().to_string().contains("spacing"));
}
