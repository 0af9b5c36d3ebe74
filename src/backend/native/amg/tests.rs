//! AMG on PMB operators of cubic lattices (spacing 1, horizon 1.5: the 18 face and edge
//! neighbours), the face x = 0 clamped: the 3-D elasticity-like systems of the issue.

use super::{one_hop_operator, rigid_body_modes, OneHopInput, Stencil};
use super::{Amg, Cycle};
use crate::backend::native::{cg_matrix_free, KrylovSettings, SparseCholesky};
use crate::backend::{Csr, KrylovReport, LinearResult, LinearSolver};
use crate::model::BondList;

/// An n×n×n lattice with its family lists.
struct Lattice {
    position: Vec<[f64; 3]>,
    bonds: BondList,
}

fn lattice(n: usize) -> Lattice {
    lattice_within(n, 1.5)
}

/// An n×n×n lattice whose families hold every point within `horizon` (spacing 1).
fn lattice_within(n: usize, horizon: f64) -> Lattice {
    let index = |x: usize, y: usize, z: usize| (x * n + y) * n + z;
    let mut position = Vec::with_capacity(n * n * n);
    let mut bonds = BondList {
        offsets: vec![0],
        ..BondList::default()
    };
    for x in 0..n {
        for y in 0..n {
            for z in 0..n {
                position.push([x as f64, y as f64, z as f64]);
                for (dx, dy, dz) in offsets(horizon) {
                    let (nx, ny, nz) = (x as i64 + dx, y as i64 + dy, z as i64 + dz);
                    let inside = |c: i64| (0..n as i64).contains(&c);
                    if inside(nx) && inside(ny) && inside(nz) {
                        bonds
                            .neighbor
                            .push(index(nx as usize, ny as usize, nz as usize) as u32);
                        bonds
                            .reference_length
                            .push(((dx * dx + dy * dy + dz * dz) as f64).sqrt());
                    }
                }
                bonds.offsets.push(bonds.neighbor.len());
            }
        }
    }
    Lattice { position, bonds }
}

/// Neighbour offsets within `horizon` (for 1.5: faces, |ξ| = 1, and edges, √2), in
/// lexicographic order.
fn offsets(horizon: f64) -> impl Iterator<Item = (i64, i64, i64)> {
    let reach = horizon.floor() as i64;
    let limit = horizon * horizon;
    (-reach..=reach).flat_map(move |dx| {
        (-reach..=reach).flat_map(move |dy| {
            (-reach..=reach)
                .map(move |dz| (dx, dy, dz))
                .filter(move |&(dx, dy, dz)| {
                    let squared = (dx * dx + dy * dy + dz * dz) as f64;
                    squared > 0.0 && squared <= limit
                })
        })
    })
}

/// The PMB operator of `lattice` with the points of `clamped` held (c = 1, V = 1), its
/// unknowns' point groups and free dofs.
fn operator(
    lattice: &Lattice,
    clamped: impl Fn([f64; 3]) -> bool,
) -> (Csr, Vec<usize>, Vec<usize>) {
    let points = lattice.position.len();
    let mut dof_index = vec![None; 3 * points];
    let (mut free, mut groups) = (Vec::new(), vec![0]);
    for (p, x) in lattice.position.iter().enumerate() {
        if clamped(*x) {
            continue;
        }
        for c in 0..3 {
            dof_index[3 * p + c] = Some(free.len());
            free.push(3 * p + c);
        }
        groups.push(free.len());
    }
    let matrix = one_hop_operator(&OneHopInput {
        position: &lattice.position,
        volume: &vec![1.0; points],
        bonds: &lattice.bonds,
        micromodulus: &vec![1.0; points],
        bond_damage: None,
        diagonal_shift: None,
        dof_index: &dof_index,
        unknowns: free.len(),
        // The stencil peridyn's solvers use (the same as `Family` at horizons below 1.8).
        stencil: Stencil::Nearest,
    });
    (matrix, groups, free)
}

/// The clamped n³ system, its AMG for `cycle` with the first `modes` rigid-body modes, and a
/// smooth load.
fn clamped_system(n: usize, modes: usize, cycle: Cycle) -> (Csr, Amg, Vec<f64>) {
    let lattice = lattice(n);
    let (matrix, groups, free) = operator(&lattice, |x| x[0] == 0.0);
    let all_modes = rigid_body_modes(&lattice.position, &free);
    let null_space: Vec<f64> = all_modes
        .chunks(6)
        .flat_map(|row| row[..modes].to_vec())
        .collect();
    let amg = Amg::new(matrix.clone(), &groups, &null_space, modes, cycle).expect("AMG setup");
    let rhs: Vec<f64> = free
        .iter()
        .map(|&dof| {
            let x = lattice.position[dof / 3];
            [1.0, 0.5, -0.25][dof % 3] + (x[1] + 2.0 * x[2]).sin() * 0.1
        })
        .collect();
    (matrix, amg, rhs)
}

fn amg_cg(matrix: &Csr, amg: &Amg, rhs: &[f64], x: &mut [f64]) -> LinearResult {
    let mut apply = |v: &[f64], y: &mut [f64]| {
        matrix.multiply(v, y);
        Ok(())
    };
    let settings = KrylovSettings {
        relative_tolerance: 1e-10,
        max_iterations: Some(500),
        ..KrylovSettings::default()
    };
    cg_matrix_free(&mut apply, &|r, z| amg.apply(r, z), rhs, x, &settings)
}

fn iterations(n: usize, modes: usize) -> usize {
    let (matrix, amg, rhs) = clamped_system(n, modes, Cycle::VCycle);
    let mut x = vec![0.0; rhs.len()];
    let report = amg_cg(&matrix, &amg, &rhs, &mut x).expect("AMG-CG converges");
    eprintln!(
        "{n}³, {modes} modes: {}, {} CG iterations",
        amg.describe(),
        report.iterations
    );
    report.iterations
}

#[test]
fn amg_preconditioned_cg_reaches_the_direct_solution() {
    let (matrix, amg, rhs) = clamped_system(8, 6, Cycle::VCycle);
    assert!(amg.levels() >= 2, "{}", amg.describe());
    let mut x = vec![0.0; rhs.len()];
    amg_cg(&matrix, &amg, &rhs, &mut x).unwrap();
    let mut direct = vec![0.0; rhs.len()];
    SparseCholesky::new()
        .solve(&matrix, &rhs, &mut direct)
        .unwrap();
    let scale = direct.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let error = x
        .iter()
        .zip(&direct)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    // Relative residual 1e-10 and a condition number below ~1e4 for this 8³ lattice bound
    // the error by ~1e-6 relative; round-off leaves it far smaller.
    assert!(error < 1e-6 * scale, "error {error:e} of {scale:e}");
}

#[test]
fn iteration_counts_stay_flat_as_the_lattice_grows() {
    // Unpreconditioned, CG's count grows like the condition number's square root, i.e. ∝ n
    // for this operator: ×3 from 8³ to 24³. Multigrid with a good near-null space is
    // h-independent in theory; with aggregation the count may still creep (a log factor or
    // one extra level). 1.5× allows that and is half of the growth of a one-level method.
    let small = iterations(8, 6);
    let large = iterations(24, 6);
    let middle = iterations(16, 6);
    assert!(
        middle as f64 <= 1.5 * small as f64 && large as f64 <= 1.5 * small as f64,
        "8³: {small}, 16³: {middle}, 24³: {large} iterations"
    );
}

#[test]
fn without_the_rotations_the_iteration_count_grows() {
    // Translations alone cannot represent the bending of the clamped cube at the coarse
    // levels, so the coarse correction misses the lowest modes: the near-null space is used.
    let translations = iterations(16, 3);
    let rigid_body = iterations(16, 6);
    assert!(
        translations as f64 >= 1.2 * rigid_body as f64,
        "3 modes: {translations}, 6 modes: {rigid_body} iterations"
    );
}

#[test]
fn rigid_body_modes_are_the_kernel_of_the_unconstrained_operator() {
    let lattice = lattice(5);
    let (matrix, _, free) = operator(&lattice, |_| false);
    let modes = rigid_body_modes(&lattice.position, &free);
    let largest_entry = matrix.values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for mode in 0..6 {
        let v: Vec<f64> = modes.chunks(6).map(|row| row[mode]).collect();
        let scale = v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let mut av = vec![0.0; v.len()];
        matrix.multiply(&v, &mut av);
        let largest = av.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        assert!(
            largest < 1e-13 * largest_entry * scale,
            "mode {mode}: ‖A v‖∞ = {largest:e}"
        );
    }
}

#[test]
fn an_operator_without_prescribed_dofs_is_a_clear_error() {
    let lattice = lattice(8);
    let (matrix, groups, free) = operator(&lattice, |_| false);
    let modes = rigid_body_modes(&lattice.position, &free);
    let error = Amg::new(matrix, &groups, &modes, 6, Cycle::VCycle).unwrap_err();
    assert!(
        error
            .to_string()
            .contains("not symmetric positive definite"),
        "{error}"
    );
}

#[test]
fn an_indefinite_operator_is_a_clear_error() {
    let (mut matrix, groups, _) = operator(&lattice(3), |x| x[0] == 0.0);
    matrix.values.iter_mut().for_each(|v| *v = -*v);
    let error = Amg::new(matrix, &groups, &vec![1.0; 54 * 3], 3, Cycle::VCycle).unwrap_err();
    assert!(
        error
            .to_string()
            .contains("not symmetric positive definite"),
        "{error}"
    );
}

#[test]
fn the_planned_memory_is_close_to_what_the_hierarchy_holds() {
    // 12³ points with δ = 3.015 (Peridigm's usual horizon), the face x = 0 clamped.
    let lattice = lattice_within(12, 3.015);
    let (matrix, groups, free) = operator(&lattice, |x| x[0] == 0.0);
    let operator_bytes = matrix.memory_bytes() as f64;
    let modes = rigid_body_modes(&lattice.position, &free);
    // The additive form the solvers use keeps no finest operator.
    let amg = Amg::new(matrix, &groups, &modes, 6, Cycle::Additive).unwrap();
    assert!(amg.levels() >= 2, "{}", amg.describe());
    let hierarchy_bytes = amg.memory_bytes() as f64;
    let planned = super::multigrid_memory_estimate(
        lattice.position.len() as u64,
        lattice.bonds.neighbor.len() as u64,
    );
    let (operator_ratio, hierarchy_ratio) = (
        planned.operator as f64 / operator_bytes,
        planned.hierarchy as f64 / hierarchy_bytes,
    );
    // The estimate counts every dof as an unknown and 26 kept bonds a point; here the
    // clamped face is 1/12 of the points and over half the points lie within 2Δx of a
    // surface, where fewer bonds are kept (measured: the plan is 1.30× the operator), and the
    // measured transfer-and-coarse fraction varies 0.94–1.05 around the 1.0 assumed (12³ and
    // 16³ lattices). A factor 1.5 either way holds both with margin; a wrong formula (a
    // missing factor 9 or 3, the whole family instead of the nearest shells) is off by more.
    assert!(
        (1.0..1.5).contains(&operator_ratio),
        "operator: planned {} B, held {operator_bytes} B",
        planned.operator
    );
    assert!(
        (1.0 / 1.5..1.5).contains(&hierarchy_ratio),
        "hierarchy: planned {} B, held {hierarchy_bytes} B ({})",
        planned.hierarchy,
        amg.describe()
    );
}

#[test]
fn the_reused_workspace_carries_nothing_from_one_application_to_the_next() {
    // 16³ with horizon 1.5: three levels, and a finest level above Csr::PARALLEL_ROWS so the
    // parallel products run too.
    for cycle in [Cycle::VCycle, Cycle::Additive] {
        workspace_carries_nothing(cycle);
    }
}

fn workspace_carries_nothing(cycle: Cycle) {
    let (_, amg, rhs) = clamped_system(16, 6, cycle);
    assert!(amg.levels() >= 3, "{}", amg.describe());
    let fresh = amg.clone();
    let mut first = vec![0.0; rhs.len()];
    amg.apply(&rhs, &mut first);
    // Another right-hand side in between leaves other values in every workspace vector.
    let other: Vec<f64> = rhs
        .iter()
        .enumerate()
        .map(|(i, r)| r * (i % 7) as f64)
        .collect();
    let mut scratch = vec![1.0; rhs.len()];
    amg.apply(&other, &mut scratch);
    let mut again = vec![0.0; rhs.len()];
    amg.apply(&rhs, &mut again);
    let mut from_fresh = vec![0.0; rhs.len()];
    fresh.apply(&rhs, &mut from_fresh);
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&first), bits(&again));
    assert_eq!(bits(&first), bits(&from_fresh));
}

/// The one-hop operator of `lattice` with every dof free and c = V = 1.
fn free_operator(lattice: &Lattice, stencil: Stencil) -> Csr {
    let points = lattice.position.len();
    let dof_index: Vec<Option<usize>> = (0..3 * points).map(Some).collect();
    one_hop_operator(&OneHopInput {
        position: &lattice.position,
        volume: &vec![1.0; points],
        bonds: &lattice.bonds,
        micromodulus: &vec![1.0; points],
        bond_damage: None,
        diagonal_shift: None,
        dof_index: &dof_index,
        unknowns: 3 * points,
        stencil,
    })
}

#[test]
fn the_nearest_stencil_keeps_the_26_lattice_neighbours_and_the_dilatation_energy() {
    // 13³ with δ = 3.015: the centre point (6, 6, 6) and every neighbour of it have whole
    // families, so f is the same at both ends of its bonds.
    let lattice = lattice_within(13, 3.015);
    let centre = (6 * 13 + 6) * 13 + 6;
    // ξᵀ k_ij ξ summed over the centre's bonds: twice the energy a uniform dilatation ε = 1
    // stores in them (bond energy ½ s (ξ·ξ)²/|ξ|³ = ½ s |ξ|, the basis of f in `Stencil`).
    let bond_energy = |k: &Csr| -> (usize, f64) {
        let mut neighbours = std::collections::BTreeSet::new();
        let mut energy = 0.0;
        for a in 0..3 {
            let (columns, values) = k.row(3 * centre + a);
            for (&column, &value) in columns.iter().zip(values) {
                let (point, b) = (column / 3, column % 3);
                if point == centre || value == 0.0 {
                    continue;
                }
                neighbours.insert(point);
                let xi: [f64; 3] = std::array::from_fn(|c| {
                    lattice.position[point][c] - lattice.position[centre][c]
                });
                energy -= xi[a] * value * xi[b];
            }
        }
        (neighbours.len(), energy)
    };
    let (family_bonds, family_energy) = bond_energy(&free_operator(&lattice, Stencil::Family));
    let (nearest_bonds, nearest_energy) = bond_energy(&free_operator(&lattice, Stencil::Nearest));
    // The lattice points within 3.015 of a point, by |ξ|² = 1, 2, 3, 4, 5, 6, 8, 9:
    // 6 + 12 + 8 + 6 + 24 + 24 + 12 + 30.
    assert_eq!(family_bonds, 122);
    // 6 at distance 1, 12 at √2, 8 at √3; the next shell (2) is beyond 1.8.
    assert_eq!(nearest_bonds, 26);
    assert!(
        (nearest_energy - family_energy).abs() <= 1e-12 * family_energy,
        "nearest {nearest_energy}, family {family_energy}"
    );
}

#[test]
fn the_nearest_stencil_is_symmetric_on_an_irregular_lattice() {
    // A 6³ lattice with δ = 3.015, each point moved by up to ±0.2 per axis (a fixed
    // pseudo-random sequence), so the shortest bond and the cutoff differ from point to point.
    let mut lattice = lattice_within(6, 3.015);
    let mut seed: u64 = 0x9e37_79b9_7f4a_7c15;
    for x in lattice.position.iter_mut().flatten() {
        seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
        *x += 0.4 * ((seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5);
    }
    for i in 0..lattice.position.len() {
        for bond in lattice.bonds.range(i) {
            let j = lattice.bonds.neighbor[bond] as usize;
            lattice.bonds.reference_length[bond] = (0..3)
                .map(|a| (lattice.position[j][a] - lattice.position[i][a]).powi(2))
                .sum::<f64>()
                .sqrt();
        }
    }
    let k = free_operator(&lattice, Stencil::Nearest);
    let dense: Vec<Vec<f64>> = (0..k.nrows)
        .map(|r| {
            let mut row = vec![0.0; k.ncols];
            let (columns, values) = k.row(r);
            columns.iter().zip(values).for_each(|(&c, &v)| row[c] = v);
            row
        })
        .collect();
    let largest = k.values.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    for (r, row) in dense.iter().enumerate() {
        for (c, value) in row.iter().enumerate() {
            assert!(
                (value - dense[c][r]).abs() <= 1e-14 * largest,
                "K[{r}][{c}] = {value}, K[{c}][{r}] = {}",
                dense[c][r]
            );
        }
    }
    assert!(k.nnz() < free_operator(&lattice, Stencil::Family).nnz());
}

fn additive_cg(matrix: &Csr, amg: &Amg, rhs: &[f64], x: &mut [f64]) -> KrylovReport {
    let mut apply = |v: &[f64], y: &mut [f64]| {
        matrix.multiply(v, y);
        Ok(())
    };
    let settings = KrylovSettings {
        relative_tolerance: 1e-10,
        max_iterations: Some(500),
        ..KrylovSettings::default()
    };
    cg_matrix_free(&mut apply, &|r, z| amg.apply(r, z), rhs, x, &settings)
        .expect("CG with the additive two-level preconditioner converges")
}

#[test]
fn the_additive_two_level_form_is_symmetric_and_cg_reaches_the_direct_solution() {
    let (matrix, amg, rhs) = clamped_system(8, 6, Cycle::Additive);
    assert!(amg.levels() >= 2, "{}", amg.describe());
    // Symmetry: uᵀ M⁻¹ v = vᵀ M⁻¹ u for two unrelated vectors (CG needs it).
    let v: Vec<f64> = (0..rhs.len())
        .map(|k| ((k * 7) % 11) as f64 - 5.0)
        .collect();
    let (mut mu, mut mv) = (vec![0.0; rhs.len()], vec![0.0; rhs.len()]);
    amg.apply(&rhs, &mut mu);
    amg.apply(&v, &mut mv);
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(a, b)| a * b).sum::<f64>();
    let (uv, vu) = (dot(&rhs, &mv), dot(&v, &mu));
    assert!(
        (uv - vu).abs() <= 1e-12 * uv.abs().max(vu.abs()),
        "{uv} vs {vu}"
    );
    let mut x = vec![0.0; rhs.len()];
    let report = additive_cg(&matrix, &amg, &rhs, &mut x);
    let mut direct = vec![0.0; rhs.len()];
    SparseCholesky::new()
        .solve(&matrix, &rhs, &mut direct)
        .unwrap();
    let scale = direct.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let error = x
        .iter()
        .zip(&direct)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    // As for the V-cycle above: relative residual 1e-10, condition number below ~1e4.
    assert!(error < 1e-6 * scale, "error {error:e} of {scale:e}");
    // The count stays flat as the lattice grows, as the V-cycle's does (measured 34 at 8³,
    // 38 at 16³ and 24³; the V-cycle takes 18–20 on this exact operator, where its smoother
    // is tuned to the right operator): the issue's ±25 %.
    let small = report.iterations;
    let (matrix, amg, rhs) = clamped_system(16, 6, Cycle::Additive);
    let mut x = vec![0.0; rhs.len()];
    let large = additive_cg(&matrix, &amg, &rhs, &mut x).iterations;
    assert!(
        large as f64 <= 1.25 * small as f64,
        "8³: {small}, 16³: {large} iterations"
    );
}
