//! Tangent checks: every method against central differences of the force state, the assembled
//! matrix against central differences of the whole internal force, the structural identities
//! of an elastic tangent, the patterns and the CSR conversion.
// Matrix checks read best with explicit row and column indices.
#![allow(clippy::needless_range_loop)]

use crate::history::{History, NO_HISTORY};
use std::sync::Arc;

use super::*;
use crate::material::{
    BondBased, InfluenceFunction, LinearPeridynamicSolid, Material, ReferenceView,
};
use crate::model::test_support::{brute_force_bonds, lattice, random_cloud, Rng};
use crate::model::{BondList, PointCloud};
use crate::physics::{BlockPhysics, Configuration, Physics};

/// δ = 3.015 lattice spacings: the m = 3 horizon of Peridigm's example decks, a little over
/// three so that rounding keeps the points at three spacings.
const HORIZON: f64 = 3.015;

#[derive(Debug, Clone, Copy)]
enum Kind {
    Pmb,
    LpsOne,
    LpsParabolic,
    /// LPS (parabolic ω) with `Apply Shear Correction Factor`: μ differs from point to point.
    LpsCorrected,
}

const KINDS: [Kind; 4] = [
    Kind::Pmb,
    Kind::LpsOne,
    Kind::LpsParabolic,
    Kind::LpsCorrected,
];

fn material(kind: Kind, bulk: f64, shear: f64) -> Box<dyn Material> {
    let lps = |influence, corrected| {
        Box::new(
            LinearPeridynamicSolid::new(
                &crate::material::BlockInput {
                    density: 2.0,
                    horizon: HORIZON,
                    influence,
                },
                &crate::material::ElasticConstants {
                    bulk_modulus: bulk,
                    shear_modulus: shear,
                },
            )
            .unwrap()
            .with_shear_correction(corrected),
        ) as Box<dyn Material>
    };
    match kind {
        Kind::Pmb => Box::new(
            BondBased::new(
                &crate::material::BlockInput {
                    density: 2.0,
                    horizon: HORIZON,
                    influence: crate::material::InfluenceFunction::One,
                },
                &crate::material::BondBasedParameters {
                    bulk_modulus: bulk,
                    planar_thickness: None,
                },
            )
            .unwrap(),
        ),
        Kind::LpsOne => lps(InfluenceFunction::One, false),
        Kind::LpsParabolic => lps(InfluenceFunction::ParabolicDecay, false),
        Kind::LpsCorrected => lps(InfluenceFunction::ParabolicDecay, true),
    }
}

/// A 4×4×4 lattice (spacing 1, volumes in [0.8, 1.2)), its families at δ = 3.015, and a
/// physics whose blocks split the points at x = 1.5 (`split`: two blocks of the same model
/// with different constants, to exercise bonds between blocks) or hold them all.
struct Body {
    points: PointCloud,
    bonds: BondList,
    physics: Physics,
    /// Bond damage held fixed, when a test gives one.
    damage: Option<Vec<f32>>,
}

impl Body {
    fn new(kind: Kind, split: bool) -> Self {
        let mut rng = Rng::new(7);
        let x = lattice(4);
        let mut points = PointCloud::default();
        for p in &x {
            let block = u32::from(split && p[0] > 1.5);
            points.push(*p, 0.8 + 0.4 * rng.uniform(), block);
        }
        let bonds = brute_force_bonds(&x, HORIZON);
        let reference = ReferenceView::of(&bonds, &points);
        let constants: &[(f64, f64)] = if split {
            &[(3.0, 1.7), (5.0, 0.9)]
        } else {
            &[(3.0, 1.7)]
        };
        let blocks = constants
            .iter()
            .enumerate()
            .map(|(b, &(bulk, shear))| {
                let mut m = material(kind, bulk, shear);
                let mine = (0..x.len() as u32)
                    .filter(|&i| points.block[i as usize] == b as u32)
                    .collect();
                m.setup(&reference, mine).unwrap();
                BlockPhysics {
                    material: m,
                    damage: None,
                }
            })
            .collect();
        let physics = Physics::new(blocks, &points, &bonds);
        Self {
            points,
            bonds,
            physics,
            damage: None,
        }
    }

    /// Symmetric bond damage (the same on i→j and j→i, as the damage models produce): about
    /// 15 % of the pairs broken, 15 % at d = ½ and 10 % at d = ¼.
    fn with_damage(mut self) -> Self {
        let mut rng = Rng::new(3);
        let bonds = &self.bonds;
        let mut damage = vec![0.0f32; bonds.num_bonds()];
        for i in 0..bonds.num_points() {
            for b in bonds.range(i) {
                let j = bonds.neighbor[b] as usize;
                if j < i {
                    continue;
                }
                let r = rng.uniform();
                let d = if r < 0.15 {
                    1.0
                } else if r < 0.3 {
                    0.5
                } else if r < 0.4 {
                    0.25
                } else {
                    0.0
                };
                let back = bonds.offsets[j] + bonds.family(j).binary_search(&(i as u32)).unwrap();
                damage[b] = d;
                damage[back] = d;
            }
        }
        self.damage = Some(damage);
        self
    }

    /// The reference positions displaced by up to ±0.05 spacings in every component.
    fn perturbed(&self, seed: u64) -> Vec<[f64; 3]> {
        let mut rng = Rng::new(seed);
        self.points
            .position
            .iter()
            .map(|p| p.map(|c| c + 0.1 * (rng.uniform() - 0.5)))
            .collect()
    }

    /// The configuration at positions `y` with the body's bond damage.
    fn at<'a>(&'a self, y: &'a [[f64; 3]]) -> Configuration<'a> {
        Configuration {
            position: y,
            bond_damage: self.damage.as_deref(),
            history: &NO_HISTORY,
        }
    }

    fn pattern(&self) -> Arc<BlockPattern> {
        Arc::new(self.physics.tangent_pattern(&self.bonds))
    }

    fn tangent(&self, y: &[[f64; 3]], method: TangentMethod) -> BlockTangent {
        let mut t = BlockTangent::zeros(self.pattern());
        self.physics
            .tangent_with(&self.bonds, &self.points, self.at(y), method, &mut t)
            .unwrap();
        t
    }

    /// Residual force V_i f_i of every point at positions `y`.
    fn residual(&mut self, y: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let mut f = vec![[0.0; 3]; y.len()];
        self.physics.internal_force(
            &self.bonds,
            &self.points,
            y,
            self.damage.as_deref_mut(),
            &mut History::empty(),
            &mut f,
        );
        f.iter()
            .zip(&self.points.volume)
            .map(|(f, v)| f.map(|c| c * v))
            .collect()
    }
}

/// The tangent as a dense 3N × 3N matrix (entries outside the pattern are 0).
fn dense(t: &BlockTangent) -> Vec<Vec<f64>> {
    let n = t.pattern.num_points();
    let mut a = vec![vec![0.0; 3 * n]; 3 * n];
    for i in 0..n {
        for (p, &j) in t.pattern.row(i).iter().enumerate() {
            let block = &t.blocks[t.pattern.offsets()[i] + p];
            for k in 0..3 {
                for l in 0..3 {
                    a[3 * i + k][3 * j as usize + l] = block[k][l];
                }
            }
        }
    }
    a
}

fn largest(a: &[Vec<f64>]) -> f64 {
    a.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()))
}

/// max |a − b| / max |b|.
fn relative_difference(a: &[Vec<f64>], b: &[Vec<f64>]) -> f64 {
    let scale = largest(b);
    assert!(scale > 0.0);
    a.iter()
        .flatten()
        .zip(b.iter().flatten())
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
        / scale
}

const CENTRAL: TangentMethod = TangentMethod::FiniteDifference { probe: None };

#[test]
fn analytic_and_automatic_tangents_match_central_differences() {
    // Central differences of the force state with Peridigm's probe (1e-6 × element radius
    // ≈ 6e-7) carry truncation error O(ε²) and round-off ~1e-16·|y|/ε ≈ 1e-9 relative, so
    // the exact derivatives must agree with them to ~1e-6 (the task's bar); analytic and AD
    // are both exact and agree to round-off.
    for kind in KINDS {
        for split in [false, true] {
            let body = Body::new(kind, split).with_damage();
            let y = body.perturbed(11);
            let fd = dense(&body.tangent(&y, CENTRAL));
            let analytic = dense(&body.tangent(&y, TangentMethod::Analytic));
            let ad = dense(&body.tangent(&y, TangentMethod::AutomaticDifferentiation));
            let e_fd = relative_difference(&analytic, &fd);
            let e_ad = relative_difference(&analytic, &ad);
            assert!(
                e_fd < 1e-6,
                "{kind:?} split {split}: analytic vs FD {e_fd:e}"
            );
            assert!(
                e_ad < 1e-12,
                "{kind:?} split {split}: analytic vs AD {e_ad:e}"
            );
        }
    }
}

#[test]
fn assembled_tangent_is_the_derivative_of_the_internal_force() {
    // Column (j, l) of J must equal [R(u + h e_jl) − R(u − h e_jl)]/2h with R = V f from
    // Physics::internal_force: this checks the pattern, the scatter and the force convention
    // F_i = Σ_j (t_ij + t_ji) V_j M_ij, including entries outside the pattern (they must be 0).
    let h = 1e-6;
    for kind in KINDS {
        for split in [false, true] {
            let mut body = Body::new(kind, split).with_damage();
            let y = body.perturbed(5);
            let j = dense(&body.tangent(&y, TangentMethod::Analytic));
            let n = y.len();
            let mut fd = vec![vec![0.0; 3 * n]; 3 * n];
            let mut probe = y.clone();
            for p in 0..n {
                for l in 0..3 {
                    probe[p][l] = y[p][l] + h;
                    let plus = body.residual(&probe);
                    probe[p][l] = y[p][l] - h;
                    let minus = body.residual(&probe);
                    probe[p][l] = y[p][l];
                    let step = (y[p][l] + h) - (y[p][l] - h);
                    for i in 0..n {
                        for k in 0..3 {
                            fd[3 * i + k][3 * p + l] = (plus[i][k] - minus[i][k]) / step;
                        }
                    }
                }
            }
            let e = relative_difference(&j, &fd);
            assert!(e < 1e-6, "{kind:?} split {split}: J vs FD of V f: {e:e}");
        }
    }
}

#[test]
fn tangent_is_symmetric_and_its_rows_sum_to_zero() {
    // Both force states derive from a potential (PMB: ½ a (1−d) s² ζ V_i V_j per bond; LPS:
    // V_i [(3K − 5μ) θ²/6 + (15μ/2m) Σ (1−d)² ω e² V_j]), so J is a Hessian: symmetric, also
    // with partial damage. Forces depend on differences of positions only, so a rigid
    // translation changes nothing: Σ_j J_ij = 0 for every block row.
    for kind in KINDS {
        let body = Body::new(kind, true).with_damage();
        let y = body.perturbed(9);
        let t = body.tangent(&y, TangentMethod::Analytic);
        let a = dense(&t);
        let scale = largest(&a);
        for r in 0..a.len() {
            for c in 0..r {
                assert!(
                    (a[r][c] - a[c][r]).abs() <= 1e-12 * scale,
                    "{kind:?}: J[{r}][{c}] = {} but J[{c}][{r}] = {}",
                    a[r][c],
                    a[c][r]
                );
            }
        }
        for i in 0..t.pattern.num_points() {
            let mut sum = [[0.0; 3]; 3];
            for j in t.pattern.row(i) {
                let b = t.block(i, *j as usize).unwrap();
                for k in 0..3 {
                    for l in 0..3 {
                        sum[k][l] += b[k][l];
                    }
                }
            }
            assert!(
                sum.iter().flatten().all(|v| v.abs() <= 1e-12 * scale),
                "{kind:?}: row {i} sums to {sum:?}"
            );
        }
    }
}

#[test]
fn small_rigid_rotation_is_in_the_null_space_at_the_reference_configuration() {
    // With no deformation every bond force is zero, and a small rotation u = ω × X changes
    // no bond length to first order, so J (ω × X) = 0.
    for kind in KINDS {
        let body = Body::new(kind, false).with_damage();
        let x = body.points.position.clone();
        let t = body.tangent(&x, TangentMethod::Analytic);
        let n = x.len();
        let kept: Vec<Option<usize>> = (0..3 * n).map(Some).collect();
        let j = t.to_csr(&kept, 1.0);
        let omega = [0.3, -0.7, 0.5];
        let u: Vec<f64> = x
            .iter()
            .flat_map(|p| {
                [
                    omega[1] * p[2] - omega[2] * p[1],
                    omega[2] * p[0] - omega[0] * p[2],
                    omega[0] * p[1] - omega[1] * p[0],
                ]
            })
            .collect();
        let mut ju = vec![0.0; 3 * n];
        j.multiply(&u, &mut ju);
        let scale = largest(&dense(&t)) * u.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for (r, v) in ju.iter().enumerate() {
            assert!(v.abs() <= 1e-12 * scale, "{kind:?}: (J u)[{r}] = {v}");
        }
    }
}

#[test]
fn block_diagonal_tangent_is_the_diagonal_of_the_full_tangent() {
    for kind in KINDS {
        let body = Body::new(kind, true).with_damage();
        let y = body.perturbed(2);
        let full = body.tangent(&y, TangentMethod::Analytic);
        let diagonal = body
            .physics
            .block_diagonal_tangent(&body.bonds, &body.points, body.at(&y))
            .unwrap();
        for (i, d) in diagonal.iter().enumerate() {
            let expected = full.block(i, i).unwrap();
            for k in 0..3 {
                for l in 0..3 {
                    // Same terms summed in the same order.
                    assert_eq!(d[k][l], expected[k][l], "{kind:?}: J_{i}{i}");
                }
            }
        }
    }
}

#[test]
fn the_deck_method_of_each_block_is_used() {
    // Physics::tangent follows each material's method: with finite differences chosen it
    // must give exactly what tangent_with(finite differences) gives.
    let mut body = Body::new(Kind::LpsOne, true).with_damage();
    let method = TangentMethod::FiniteDifference { probe: Some(1e-5) };
    for block in &mut body.physics.blocks {
        block.material.set_tangent_method(method).unwrap();
    }
    let y = body.perturbed(4);
    let mut chosen = BlockTangent::zeros(body.pattern());
    body.physics
        .tangent(&body.bonds, &body.points, body.at(&y), &mut chosen)
        .unwrap();
    assert_eq!(chosen.blocks, body.tangent(&y, method).blocks);
    assert_ne!(
        chosen.blocks,
        body.tangent(&y, TangentMethod::Analytic).blocks
    );
}

#[test]
fn result_does_not_depend_on_the_thread_count() {
    // The scatter plan fixes the order of every sum.
    for kind in [Kind::Pmb, Kind::LpsParabolic] {
        let body = Body::new(kind, true).with_damage();
        let y = body.perturbed(8);
        let run = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| body.tangent(&y, TangentMethod::AutomaticDifferentiation))
                .blocks
        };
        let one = run(1);
        assert_eq!(one, run(2));
        assert_eq!(one, run(3));
    }
}

#[test]
fn a_point_whose_bonds_are_all_broken_has_zero_rows_and_columns() {
    for kind in KINDS {
        let mut body = Body::new(kind, false);
        let isolated = 21;
        let mut damage = vec![0.0f32; body.bonds.num_bonds()];
        for b in body.bonds.range(isolated) {
            let j = body.bonds.neighbor[b] as usize;
            let back = body.bonds.offsets[j]
                + body
                    .bonds
                    .family(j)
                    .binary_search(&(isolated as u32))
                    .unwrap();
            damage[b] = 1.0;
            damage[back] = 1.0;
        }
        body.damage = Some(damage);
        let y = body.perturbed(1);
        let a = dense(&body.tangent(&y, TangentMethod::Analytic));
        assert!(largest(&a) > 0.0);
        for k in 0..3 {
            let r = 3 * isolated + k;
            assert!(a[r].iter().all(|&v| v == 0.0), "{kind:?}: row {r}");
            assert!(a.iter().all(|row| row[r] == 0.0), "{kind:?}: column {r}");
        }
    }
}

#[test]
fn a_bond_based_pattern_is_too_small_for_a_state_based_material() {
    let body = Body::new(Kind::LpsOne, false);
    let mut t = BlockTangent::zeros(Arc::new(BlockPattern::one_hop(&body.bonds)));
    // The 4³ lattice at δ = 3.015 has pairs (corner to opposite corner, distance √27 > δ) that
    // only the two-hop pattern holds.
    let err = body
        .physics
        .tangent_with(
            &body.bonds,
            &body.points,
            body.at(&body.points.position),
            TangentMethod::Analytic,
            &mut t,
        )
        .unwrap_err();
    assert!(matches!(err, TangentError::PatternTooSmall { .. }), "{err}");
}

#[test]
fn invalid_probe_lengths_are_rejected() {
    let mut m = material(Kind::Pmb, 3.0, 1.0);
    for value in [0.0, -1e-6, f64::NAN] {
        let err = m
            .set_tangent_method(TangentMethod::FiniteDifference { probe: Some(value) })
            .unwrap_err();
        assert!(matches!(err, TangentError::InvalidProbe { .. }));
    }
    m.set_tangent_method(TangentMethod::AutomaticDifferentiation)
        .unwrap();
    assert_eq!(m.tangent_method(), TangentMethod::AutomaticDifferentiation);
}

#[test]
fn physics_chooses_one_hop_only_when_every_block_is_bond_based() {
    let pmb = Body::new(Kind::Pmb, true);
    assert_eq!(pmb.pattern().as_ref(), &BlockPattern::one_hop(&pmb.bonds));
    let lps = Body::new(Kind::LpsOne, true);
    assert_eq!(lps.pattern().as_ref(), &BlockPattern::two_hop(&lps.bonds));
}

/// 80 random points in a 5³ box with δ = 1.6: families of varied size and some points far
/// apart, so that two-hop rows differ from full rows.
fn random_bonds() -> BondList {
    let mut rng = Rng::new(17);
    let (x, _) = random_cloud(&mut rng, 80, 5.0);
    brute_force_bonds(&x, 1.6)
}

#[test]
fn one_hop_rows_are_the_family_and_the_point() {
    let bonds = random_bonds();
    let pattern = BlockPattern::one_hop(&bonds);
    assert_eq!(pattern.num_points(), bonds.num_points());
    assert_eq!(pattern.num_blocks(), bonds.num_bonds() + bonds.num_points());
    for i in 0..bonds.num_points() {
        let mut expected: Vec<u32> = bonds.family(i).to_vec();
        expected.push(i as u32);
        expected.sort_unstable();
        assert_eq!(pattern.row(i), &expected[..]);
    }
}

#[test]
fn two_hop_rows_are_exactly_the_pairs_sharing_a_closed_family() {
    let bonds = random_bonds();
    let n = bonds.num_points();
    let closed = |j: usize, k: usize| j == k || bonds.family(j).contains(&(k as u32));
    let pattern = BlockPattern::two_hop(&bonds);
    let mut some_pair_left_out = false;
    for i in 0..n {
        let expected: Vec<u32> = (0..n)
            .filter(|&k| (0..n).any(|j| closed(j, i) && closed(j, k)))
            .map(|k| k as u32)
            .collect();
        some_pair_left_out |= expected.len() < n;
        assert_eq!(pattern.row(i), &expected[..], "row {i}");
    }
    assert!(some_pair_left_out, "the fixture must not couple every pair");
}

#[test]
fn diagonal_pattern_holds_one_block_per_point() {
    let pattern = BlockPattern::diagonal(5);
    assert!(pattern.is_diagonal_only());
    assert_eq!(pattern.num_blocks(), 5);
    assert_eq!(pattern.row(3), &[3]);
    assert_eq!(pattern.position(3, 3), Some(3));
    assert_eq!(pattern.position(3, 2), None);
}

/// A tangent on three points (pattern: all pairs but (0, 2) and (2, 0)) with block (i, j)
/// entry (k, l) = 100·(3i + k) + (3j + l), so every scalar entry names its position.
fn labelled_tangent() -> BlockTangent {
    let bonds = BondList {
        offsets: vec![0, 1, 3, 4],
        neighbor: vec![1, 0, 2, 1],
        reference_length: vec![1.0; 4],
    };
    let pattern = Arc::new(BlockPattern::one_hop(&bonds));
    let mut t = BlockTangent::zeros(pattern.clone());
    for i in 0..3 {
        for (p, &j) in pattern.row(i).iter().enumerate() {
            let block = &mut t.blocks[pattern.offsets()[i] + p];
            for k in 0..3 {
                for l in 0..3 {
                    block[k][l] = (100 * (3 * i + k) + 3 * j as usize + l) as f64;
                }
            }
        }
    }
    t
}

#[test]
fn to_csr_drops_eliminated_dofs_and_scales() {
    let t = labelled_tangent();
    // Eliminate dof 1 of point 0 and dofs 0, 2 of point 2; the rest numbered in order.
    let eliminated = [1usize, 6, 8];
    let mut next = 0;
    let index: Vec<Option<usize>> = (0..9)
        .map(|d| {
            (!eliminated.contains(&d)).then(|| {
                next += 1;
                next - 1
            })
        })
        .collect();
    let kept: Vec<usize> = (0..9).filter(|d| !eliminated.contains(d)).collect();
    let csr = t.to_csr(&index, -2.0);
    csr.assert_valid();
    assert_eq!((csr.nrows, csr.ncols), (6, 6));
    let stored = |r: usize, c: usize| (r / 3).abs_diff(c / 3) < 2;
    for (row, &r) in kept.iter().enumerate() {
        let (columns, values) = csr.row(row);
        let expected: Vec<usize> = (0..kept.len()).filter(|&c| stored(r, kept[c])).collect();
        assert_eq!(columns, &expected[..], "row {row}");
        for (&c, &v) in columns.iter().zip(values) {
            assert_eq!(v, -2.0 * (100 * r + kept[c]) as f64);
        }
    }
    // Any numbering of the kept dofs gives the same matrix, permuted.
    let permutation = [4usize, 0, 5, 2, 1, 3];
    let shuffled: Vec<Option<usize>> = index.iter().map(|d| d.map(|r| permutation[r])).collect();
    let other = t.to_csr(&shuffled, -2.0);
    other.assert_valid();
    for row in 0..6 {
        let (columns, values) = csr.row(row);
        let (other_columns, other_values) = other.row(permutation[row]);
        let mut mapped: Vec<(usize, f64)> = columns
            .iter()
            .map(|&c| permutation[c])
            .zip(values.iter().copied())
            .collect();
        mapped.sort_by_key(|&(c, _)| c);
        let other_pairs: Vec<(usize, f64)> = other_columns
            .iter()
            .copied()
            .zip(other_values.iter().copied())
            .collect();
        assert_eq!(mapped, other_pairs);
    }
}

#[test]
fn memory_counts_blocks_and_pattern() {
    let t = labelled_tangent();
    // 7 blocks of 72 bytes, 4 offsets (usize) and 7 columns (u32).
    assert_eq!(
        t.memory_bytes(),
        7 * 72 + 4 * std::mem::size_of::<usize>() + 7 * 4
    );
}

/// A small valid deck (4 × 2 × 2 points, one `Elastic` block) whose material list gets
/// `extra` lines.
fn deck_with(extra: &[&str]) -> String {
    let mut material = String::new();
    for line in extra {
        material.push_str("      ");
        material.push_str(line);
        material.push('\n');
    }
    format!(
        r#"Peridigm:
  Discretization:
    Type: "PdQuickGrid"
    NeighborhoodType: "Spherical"
    TensorProduct3DMeshGenerator:
      X Origin: 0.0
      Y Origin: 0.0
      Z Origin: 0.0
      X Length: 4.0
      Y Length: 2.0
      Z Length: 2.0
      Number Points X: 4
      Number Points Y: 2
      Number Points Z: 2
  Materials:
    Steel:
      Material Model: "Elastic"
      Density: 7800.0
      Bulk Modulus: 130.0e9
      Shear Modulus: 78.0e9
{material}  Blocks:
    Everything:
      Block Names: "block_1"
      Material: "Steel"
      Horizon: 1.5
  Solver:
    Initial Time: 0.0
    Final Time: 1.0
    QuasiStatic:
      Number of Load Steps: 2
      Maximum Solver Iterations: 5
"#
    )
}

fn parse(text: &str) -> Result<crate::io::deck::Deck, crate::io::deck::DeckError> {
    crate::io::deck::parse_str(
        text,
        crate::io::deck::DeckFormat::Yaml,
        std::path::Path::new("tangent.yaml"),
    )
}

/// The tangent method of the (only) block after the deck is set up.
fn method_of_deck(extra: &[&str]) -> TangentMethod {
    let deck = parse(&deck_with(extra)).unwrap();
    let model = crate::setup::build(&deck).unwrap();
    let physics = crate::setup::build_physics(&deck, &model).unwrap();
    physics.blocks[0].material.tangent_method()
}

#[test]
fn deck_selects_the_tangent_method() {
    // No key: analytic (peridyn's default for Elastic, although Peridigm's is AD).
    assert_eq!(method_of_deck(&[]), TangentMethod::Analytic);
    assert_eq!(
        method_of_deck(&[r#"Tangent: "Automatic Differentiation""#]),
        TangentMethod::AutomaticDifferentiation
    );
    assert_eq!(
        method_of_deck(&[
            r#"Tangent: "Finite Difference""#,
            "Finite Difference Probe Length: 1.0e-7"
        ]),
        TangentMethod::FiniteDifference { probe: Some(1e-7) }
    );
    // Peridigm's key, written explicitly, decides when `Tangent` is absent.
    assert_eq!(
        method_of_deck(&["Apply Automatic Differentiation Jacobian: true"]),
        TangentMethod::AutomaticDifferentiation
    );
    assert_eq!(
        method_of_deck(&["Apply Automatic Differentiation Jacobian: false"]),
        TangentMethod::FiniteDifference { probe: None }
    );
    // Both keys, agreeing.
    assert_eq!(
        method_of_deck(&[
            "Apply Automatic Differentiation Jacobian: false",
            r#"Tangent: "Finite Difference""#
        ]),
        TangentMethod::FiniteDifference { probe: None }
    );
}

#[test]
fn deck_tangent_errors_name_the_key_and_the_fix() {
    let text = deck_with(&[r#"Tangent: "Finite Diference""#]);
    let message = parse(&text).unwrap_err().to_string();
    let line = text
        .lines()
        .position(|l| l.contains("Finite Diference"))
        .unwrap()
        + 1;
    assert!(
        message.starts_with(&format!("tangent.yaml:{line}:")),
        "{message}"
    );
    assert!(
        message.contains(r#"did you mean "Finite Difference"?"#),
        "{message}"
    );

    let text = deck_with(&[
        "Apply Automatic Differentiation Jacobian: true",
        r#"Tangent: "Analytic""#,
    ]);
    let message = parse(&text).unwrap_err().to_string();
    assert!(message.contains("contradicts"), "{message}");
    assert!(message.contains("remove one of the two keys"), "{message}");
}

/// Timing of the assembly against one force evaluation on a 20³ LPS block (δ = 3.015
/// spacings, the full setup path so the points are in space-filling-curve order). Not a
/// check: run `cargo test --release --lib tangent::tests::timing -- --ignored --nocapture`.
#[test]
#[ignore]
fn timing_of_the_lps_tangent_on_a_20_cubed_block() {
    use std::time::Instant;
    let text = deck_with(&[]).replace("4.0", "20.0").replace("2.0", "20.0");
    let text = text
        .replace("Number Points X: 4", "Number Points X: 20")
        .replace("Number Points Y: 2", "Number Points Y: 20")
        .replace("Number Points Z: 2", "Number Points Z: 20")
        .replace("Horizon: 1.5", "Horizon: 3.015");
    let deck = parse(&text).unwrap();
    let model = crate::setup::build(&deck).unwrap();
    let mut physics = crate::setup::build_physics(&deck, &model).unwrap();
    let (bonds, points) = (&model.bonds, &model.points);
    let mut rng = Rng::new(1);
    let y: Vec<[f64; 3]> = points
        .position
        .iter()
        .map(|p| p.map(|c| c + 0.01 * (rng.uniform() - 0.5)))
        .collect();
    println!(
        "{} points, {} bonds, {} threads",
        points.len(),
        bonds.num_bonds(),
        rayon::current_num_threads()
    );
    let mut f = vec![[0.0; 3]; points.len()];
    physics.internal_force(bonds, points, &y, None, &mut History::empty(), &mut f);
    let repeats = 20;
    let start = Instant::now();
    for _ in 0..repeats {
        physics.internal_force(bonds, points, &y, None, &mut History::empty(), &mut f);
    }
    let force = start.elapsed().as_secs_f64() / repeats as f64;
    println!(
        "force evaluation (θ pass + force pass): {:.3} ms",
        1e3 * force
    );

    let start = Instant::now();
    let pattern = Arc::new(physics.tangent_pattern(bonds));
    println!(
        "two-hop pattern: {:.3} s, {} blocks ({:.1} per row)",
        start.elapsed().as_secs_f64(),
        pattern.num_blocks(),
        pattern.num_blocks() as f64 / points.len() as f64
    );
    let mut t = BlockTangent::zeros(pattern);
    println!("tangent memory: {:.1} MB", t.memory_bytes() as f64 / 1e6);
    for method in [
        TangentMethod::Analytic,
        TangentMethod::AutomaticDifferentiation,
        CENTRAL,
    ] {
        let repeats = if method == TangentMethod::Analytic {
            3
        } else {
            1
        };
        let start = Instant::now();
        for _ in 0..repeats {
            physics
                .tangent_with(bonds, points, undamaged(&y), method, &mut t)
                .unwrap();
        }
        let seconds = start.elapsed().as_secs_f64() / repeats as f64;
        println!(
            "{:>26} tangent: {:.3} s = {:.0} force evaluations",
            method.deck_name(),
            seconds,
            seconds / force
        );
    }
    let start = Instant::now();
    let kept: Vec<Option<usize>> = (0..3 * points.len()).map(Some).collect();
    let csr = t.to_csr(&kept, -1.0);
    println!(
        "to_csr: {:.3} s, {} non-zeros",
        start.elapsed().as_secs_f64(),
        csr.nnz()
    );
    let start = Instant::now();
    physics
        .block_diagonal_tangent(bonds, points, undamaged(&y))
        .unwrap();
    println!(
        "block diagonal (analytic): {:.3} s",
        start.elapsed().as_secs_f64()
    );
}

/// The configuration at positions `y` with every bond intact.
fn undamaged(y: &[[f64; 3]]) -> Configuration<'_> {
    Configuration {
        position: y,
        bond_damage: None,
        history: &NO_HISTORY,
    }
}
