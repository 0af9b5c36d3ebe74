//! The smoothed-aggregation prolongator P = (I − ω D⁻¹A) T and the sparse products it needs.
//!
//! T, the tentative prolongator, interpolates the near-null space exactly: over aggregate a,
//! the rows of the near-null vectors B_a (its dofs × k modes) are factored B_a = Q_a R_a by
//! modified Gram–Schmidt, T holds Q_a and the coarse near-null space is R_a. A mode that is
//! (numerically) a combination of the previous ones on the aggregate — e.g. rotations on an
//! aggregate of one point — is dropped, so an aggregate has at most k but possibly fewer
//! coarse unknowns. Smoothing with damped Jacobi, ω = 4/(3ρ(D⁻¹A)), widens every column by
//! one hop of A and lowers the energy of the coarse basis (Vaněk, Mandel, Brezina 1996).

use rayon::prelude::*;

use super::super::super::Csr;
use super::aggregation::Aggregates;

/// A mode whose remainder after orthogonalisation is below this fraction of its own norm on
/// the aggregate is dropped there.
const DEPENDENT_MODE: f64 = 1e-8;

/// T with the coarse near-null space and the grouping of the coarse unknowns.
pub(super) struct Tentative {
    pub prolongator: Csr,
    /// Row-major, coarse unknowns × modes.
    pub coarse_null_space: Vec<f64>,
    /// Offsets of every aggregate's coarse unknowns.
    pub coarse_groups: Vec<usize>,
}

/// T from `aggregates` of the nodes of `groups` and the near-null space `null_space`
/// (row-major, rows × `modes`).
pub(super) fn tentative(
    groups: &[usize],
    aggregates: &Aggregates,
    null_space: &[f64],
    modes: usize,
) -> Tentative {
    let rows = *groups.last().expect("groups start at 0");
    let mut entries: Vec<(usize, Vec<(usize, f64)>)> = Vec::with_capacity(rows);
    let mut coarse_null_space = Vec::new();
    let mut coarse_groups = vec![0];
    for members in aggregates.members() {
        let dofs: Vec<usize> = members
            .iter()
            .flat_map(|&node| groups[node]..groups[node + 1])
            .collect();
        let (q, r) = orthonormalise(&dofs, null_space, modes);
        let first = *coarse_groups.last().expect("starts at 0");
        for (local, &dof) in dofs.iter().enumerate() {
            let row = q
                .iter()
                .enumerate()
                .map(|(c, column)| (first + c, column[local]))
                .collect();
            entries.push((dof, row));
        }
        coarse_null_space.extend(r.iter().flatten());
        coarse_groups.push(first + q.len());
    }
    entries.sort_unstable_by_key(|&(dof, _)| dof);
    let mut prolongator = Csr {
        nrows: rows,
        ncols: *coarse_groups.last().expect("starts at 0"),
        offsets: vec![0],
        ..Csr::default()
    };
    for (_, row) in entries {
        for (c, v) in row {
            prolongator.columns.push(c);
            prolongator.values.push(v);
        }
        prolongator.offsets.push(prolongator.columns.len());
    }
    Tentative {
        prolongator,
        coarse_null_space,
        coarse_groups,
    }
}

/// Q (kept columns over `dofs`) and R (kept rows × `modes`, row-major rows) of the modes
/// restricted to `dofs`, by modified Gram–Schmidt with a second pass for accuracy.
fn orthonormalise(
    dofs: &[usize],
    null_space: &[f64],
    modes: usize,
) -> (Vec<Vec<f64>>, Vec<Vec<f64>>) {
    let mut q: Vec<Vec<f64>> = Vec::new();
    let mut r: Vec<Vec<f64>> = Vec::new();
    for mode in 0..modes {
        let mut v: Vec<f64> = dofs.iter().map(|&d| null_space[d * modes + mode]).collect();
        let original = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        let mut coefficients = vec![0.0; q.len()];
        for _ in 0..2 {
            for (column, coefficient) in q.iter().zip(coefficients.iter_mut()) {
                let projection: f64 = column.iter().zip(&v).map(|(a, b)| a * b).sum();
                v.iter_mut()
                    .zip(column)
                    .for_each(|(x, c)| *x -= projection * c);
                *coefficient += projection;
            }
        }
        for (row, coefficient) in r.iter_mut().zip(&coefficients) {
            row[mode] = *coefficient;
        }
        let remainder = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        if remainder > DEPENDENT_MODE * original && remainder > 0.0 {
            v.iter_mut().for_each(|x| *x /= remainder);
            let mut row = vec![0.0; modes];
            row[mode] = remainder;
            q.push(v);
            r.push(row);
        }
    }
    (q, r)
}

/// P = T − ω D⁻¹ (A T) with D = diag(A) and ω = 4/(3ρ), ρ ≈ ρ(D⁻¹A).
pub(super) fn smooth(a: &Csr, tentative: &Csr, spectral_radius: f64) -> Csr {
    let omega = 4.0 / (3.0 * spectral_radius);
    let diagonal = a.diagonal();
    let at = multiply(a, tentative);
    from_rows(a.nrows, tentative.ncols, |rows| {
        rows.into_par_iter()
            .map(|r| merge_rows(tentative.row(r), at.row(r), -omega / diagonal[r]))
            .collect()
    })
}

/// The sorted union of two sorted rows, x + scale·y.
fn merge_rows(x: (&[usize], &[f64]), y: (&[usize], &[f64]), scale: f64) -> (Vec<usize>, Vec<f64>) {
    let (mut columns, mut values) = (Vec::new(), Vec::new());
    let (mut i, mut j) = (0, 0);
    while i < x.0.len() || j < y.0.len() {
        let take_x = j == y.0.len() || (i < x.0.len() && x.0[i] <= y.0[j]);
        let take_y = i == x.0.len() || (j < y.0.len() && y.0[j] <= x.0[i]);
        let mut v = 0.0;
        let column = if take_x { x.0[i] } else { y.0[j] };
        if take_x {
            v += x.1[i];
            i += 1;
        }
        if take_y {
            v += scale * y.1[j];
            j += 1;
        }
        columns.push(column);
        values.push(v);
    }
    (columns, values)
}

/// Rows computed in parallel before they are appended to the matrix: the rows in flight stay
/// a small fraction of a product, so no product is held twice while it is formed.
const ROW_CHUNK: usize = 32768;

/// A CSR matrix of `nrows` × `ncols` whose rows (each sorted) `rows_of` computes, a chunk of
/// row indices at a time.
fn from_rows(
    nrows: usize,
    ncols: usize,
    rows_of: impl Fn(std::ops::Range<usize>) -> Vec<(Vec<usize>, Vec<f64>)>,
) -> Csr {
    let mut matrix = Csr {
        nrows,
        ncols,
        offsets: Vec::with_capacity(nrows + 1),
        columns: Vec::new(),
        values: Vec::new(),
    };
    matrix.offsets.push(0);
    for first in (0..nrows).step_by(ROW_CHUNK) {
        for (columns, values) in rows_of(first..nrows.min(first + ROW_CHUNK)) {
            matrix.columns.extend(columns);
            matrix.values.extend(values);
            matrix.offsets.push(matrix.columns.len());
        }
    }
    matrix
}

/// A B, rows shared among rayon's threads (each with its own dense accumulator).
pub(super) fn multiply(a: &Csr, b: &Csr) -> Csr {
    assert_eq!(a.ncols, b.nrows, "inner dimensions differ");
    from_rows(a.nrows, b.ncols, |rows| {
        rows.into_par_iter()
            .map_init(
                || (vec![0.0; b.ncols], vec![false; b.ncols]),
                |(accumulator, used), r| {
                    let mut columns = Vec::new();
                    let (a_columns, a_values) = a.row(r);
                    for (&k, &a_rk) in a_columns.iter().zip(a_values) {
                        let (b_columns, b_values) = b.row(k);
                        for (&c, &b_kc) in b_columns.iter().zip(b_values) {
                            if !used[c] {
                                used[c] = true;
                                columns.push(c);
                            }
                            accumulator[c] += a_rk * b_kc;
                        }
                    }
                    columns.sort_unstable();
                    let values = columns
                        .iter()
                        .map(|&c| {
                            used[c] = false;
                            std::mem::take(&mut accumulator[c])
                        })
                        .collect();
                    (columns, values)
                },
            )
            .collect()
    })
}

/// Aᵀ.
pub(super) fn transpose(a: &Csr) -> Csr {
    let mut counts = vec![0usize; a.ncols + 1];
    for &c in &a.columns {
        counts[c + 1] += 1;
    }
    for c in 0..a.ncols {
        counts[c + 1] += counts[c];
    }
    let mut next = counts.clone();
    let mut columns = vec![0; a.nnz()];
    let mut values = vec![0.0; a.nnz()];
    for r in 0..a.nrows {
        let (row_columns, row_values) = a.row(r);
        for (&c, &v) in row_columns.iter().zip(row_values) {
            columns[next[c]] = r;
            values[next[c]] = v;
            next[c] += 1;
        }
    }
    Csr {
        nrows: a.ncols,
        ncols: a.nrows,
        offsets: counts,
        columns,
        values,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dense(a: &Csr) -> Vec<Vec<f64>> {
        let mut out = vec![vec![0.0; a.ncols]; a.nrows];
        for (r, row) in out.iter_mut().enumerate() {
            let (columns, values) = a.row(r);
            columns.iter().zip(values).for_each(|(&c, &v)| row[c] = v);
        }
        out
    }

    #[test]
    fn products_and_transposes_match_dense_algebra() {
        // A = [[1, 2, 0], [0, 0, 3]], Aᵀ A = [[1, 2, 0], [2, 4, 0], [0, 0, 9]].
        let a = Csr {
            nrows: 2,
            ncols: 3,
            offsets: vec![0, 2, 3],
            columns: vec![0, 1, 2],
            values: vec![1.0, 2.0, 3.0],
        };
        let product = multiply(&transpose(&a), &a);
        product.assert_valid();
        assert_eq!(
            dense(&product),
            vec![
                vec![1.0, 2.0, 0.0],
                vec![2.0, 4.0, 0.0],
                vec![0.0, 0.0, 9.0]
            ]
        );
    }

    #[test]
    fn the_tentative_prolongator_interpolates_the_near_null_space() {
        // Four 1-dof nodes in two aggregates, modes 1 and x = (0, 1, 2, 3): T R = B exactly.
        let aggregates = Aggregates {
            of_node: vec![0, 0, 1, 1],
            count: 2,
        };
        let null_space = [1.0, 0.0, 1.0, 1.0, 1.0, 2.0, 1.0, 3.0];
        let t = tentative(&[0, 1, 2, 3, 4], &aggregates, &null_space, 2);
        assert_eq!(t.coarse_groups, vec![0, 2, 4]);
        let t_dense = dense(&t.prolongator);
        for (row, expected) in t_dense.iter().zip(null_space.chunks(2)) {
            for mode in 0..2 {
                let value: f64 = (0..4)
                    .map(|c| row[c] * t.coarse_null_space[c * 2 + mode])
                    .sum();
                assert!(
                    (value - expected[mode]).abs() < 1e-14,
                    "{value} vs {expected:?}"
                );
            }
        }
    }

    #[test]
    fn a_mode_dependent_on_an_aggregate_is_dropped() {
        // One node of one dof: the modes 1 and 2 are parallel, one coarse unknown remains.
        let aggregates = Aggregates {
            of_node: vec![0],
            count: 1,
        };
        let t = tentative(&[0, 1], &aggregates, &[1.0, 2.0], 2);
        assert_eq!(t.coarse_groups, vec![0, 1]);
        assert_eq!(t.coarse_null_space, vec![1.0, 2.0]);
    }
}
