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
use super::pattern::{GroupPattern, MAX_GROUP_ROWS};

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
pub(super) fn smooth(a: &Csr, groups: &[usize], tentative: &Csr, spectral_radius: f64) -> Csr {
    let omega = 4.0 / (3.0 * spectral_radius);
    let diagonal = a.diagonal();
    let at = multiply(a, groups, tentative, groups);
    from_groups(tentative.ncols, groups, || {
        |rows: std::ops::Range<usize>| {
            rows.map(|r| merge_rows(tentative.row(r), at.row(r), -omega / diagonal[r]))
                .collect()
        }
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

/// A B, rows shared among rayon's threads (each with its own dense accumulator).
///
/// `row_groups` groups A's rows and `inner_groups` B's rows (= A's columns), as offsets. The
/// rows of a point (or an aggregate) share one column pattern in these operators, so a group's
/// rows are multiplied together and so are the consecutive columns of A that fall in one
/// group of B's rows: the index work of a 3×3 block of A against a row of B is done once, not
/// nine times. For every entry the products a_rk b_kc are added in increasing k, as a
/// row-by-row product adds them, so the result is the same to the bit; a group whose rows
/// differ in pattern is multiplied a row at a time.
pub(super) fn multiply(a: &Csr, row_groups: &[usize], b: &Csr, inner_groups: &[usize]) -> Csr {
    assert_eq!(a.ncols, b.nrows, "inner dimensions differ");
    assert_eq!(
        row_groups.last(),
        Some(&a.nrows),
        "row groups cover A's rows"
    );
    assert_eq!(
        inner_groups.last(),
        Some(&b.nrows),
        "inner groups cover B's rows"
    );
    let b_pattern = GroupPattern::of(b, inner_groups);
    let a_pattern = GroupPattern::of(a, row_groups);
    let b_pattern = &b_pattern;
    from_groups(b.ncols, &a_pattern.row_sets, || {
        let mut product = GroupProduct::new(b.ncols);
        move |rows: std::ops::Range<usize>| product.rows(a, rows, b, b_pattern)
    })
}

/// One thread's dense accumulator of a row set's product: entry (row i of the set, column c)
/// at `sums[c * MAX_GROUP_ROWS + i]`, so a set's sums of one column share a cache line.
struct GroupProduct {
    sums: Vec<f64>,
    used: Vec<bool>,
    columns: Vec<usize>,
    /// Where the set's rows of A start in A's values.
    a_starts: Vec<usize>,
    /// Where the rows of B of the current run start in B's values.
    b_starts: Vec<usize>,
}

impl GroupProduct {
    fn new(ncols: usize) -> Self {
        Self {
            sums: vec![0.0; ncols * MAX_GROUP_ROWS],
            used: vec![false; ncols],
            columns: Vec::new(),
            a_starts: Vec::new(),
            b_starts: Vec::new(),
        }
    }

    /// Rows `rows` (one row set, sharing A's pattern) of A B.
    fn rows(
        &mut self,
        a: &Csr,
        rows: std::ops::Range<usize>,
        b: &Csr,
        b_pattern: &GroupPattern,
    ) -> Vec<(Vec<usize>, Vec<f64>)> {
        let set_rows = rows.len();
        let (a_columns, _) = a.row(rows.start);
        self.a_starts.clear();
        self.a_starts.extend(rows.clone().map(|r| a.offsets[r]));
        let mut p = 0;
        while p < a_columns.len() {
            // The run of A's columns p..p + run whose rows of B share one pattern.
            let k = a_columns[p];
            let set_end = b_pattern.set_end[k];
            let run = a_columns[p..]
                .iter()
                .take_while(|&&column| {
                    column < set_end && b_pattern.set_start[column] == b_pattern.set_start[k]
                })
                .count();
            let b_columns = b.row(k).0;
            self.b_starts.clear();
            self.b_starts
                .extend(a_columns[p..p + run].iter().map(|&kk| b.offsets[kk]));
            for (position, &c) in b_columns.iter().enumerate() {
                if !self.used[c] {
                    self.used[c] = true;
                    self.columns.push(c);
                }
                let sums = &mut self.sums[c * MAX_GROUP_ROWS..c * MAX_GROUP_ROWS + set_rows];
                for (j, &b_start) in self.b_starts.iter().enumerate() {
                    let b_kc = b.values[b_start + position];
                    for (sum, &a_start) in sums.iter_mut().zip(&self.a_starts) {
                        *sum += a.values[a_start + p + j] * b_kc;
                    }
                }
            }
            p += run;
        }
        self.columns.sort_unstable();
        let mut out: Vec<(Vec<usize>, Vec<f64>)> = (0..set_rows)
            .map(|_| (self.columns.clone(), Vec::with_capacity(self.columns.len())))
            .collect();
        for &c in &self.columns {
            self.used[c] = false;
            for (i, (_, values)) in out.iter_mut().enumerate() {
                values.push(std::mem::take(&mut self.sums[c * MAX_GROUP_ROWS + i]));
            }
        }
        self.columns.clear();
        out
    }
}

/// A CSR matrix of `ncols` columns whose rows (each sorted) come in sets (`row_sets`:
/// offsets), each set's rows computed together by a function `new_worker` makes for each
/// rayon worker; a chunk of about [`ROW_CHUNK`] rows at a time (at least one set).
fn from_groups<W>(ncols: usize, row_sets: &[usize], new_worker: impl Fn() -> W + Sync + Send) -> Csr
where
    W: FnMut(std::ops::Range<usize>) -> Vec<(Vec<usize>, Vec<f64>)>,
{
    let nrows = *row_sets.last().expect("sets start at 0");
    let sets = row_sets.len() - 1;
    let mut matrix = Csr {
        nrows,
        ncols,
        offsets: Vec::with_capacity(nrows + 1),
        columns: Vec::new(),
        values: Vec::new(),
    };
    matrix.offsets.push(0);
    let mut first = 0;
    while first < sets {
        let limit = row_sets[first] + ROW_CHUNK;
        let last = first + row_sets[first..sets].partition_point(|&start| start < limit);
        let chunk: Vec<Vec<(Vec<usize>, Vec<f64>)>> = (first..last)
            .into_par_iter()
            .map_init(&new_worker, |worker, set| {
                worker(row_sets[set]..row_sets[set + 1])
            })
            .collect();
        for (columns, values) in chunk.into_iter().flatten() {
            matrix.columns.extend(columns);
            matrix.values.extend(values);
            matrix.offsets.push(matrix.columns.len());
        }
        first = last;
    }
    matrix
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
        let product = multiply(&transpose(&a), &[0, 1, 3], &a, &[0, 2]);
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

    /// A deterministic sparse matrix: entry (r, c) is present when a hash of (r, c, seed)
    /// falls below `density`; a row listed in `shared` takes the pattern of the row above it
    /// (as the rows of a point share theirs), with values of its own.
    fn scattered(nrows: usize, ncols: usize, density: f64, seed: u64, shared: &[usize]) -> Csr {
        let value = |r: usize, c: usize| {
            let h = (r as u64 * 1_000_003 + c as u64 * 7_919 + seed)
                .wrapping_mul(0x9E37_79B9_7F4A_7C15);
            ((h >> 11) as f64) / ((1u64 << 53) as f64)
        };
        let mut m = Csr {
            nrows,
            ncols,
            offsets: vec![0],
            ..Csr::default()
        };
        for r in 0..nrows {
            let mut pattern_row = r;
            while shared.contains(&pattern_row) {
                pattern_row -= 1;
            }
            for c in 0..ncols {
                if value(pattern_row, c + ncols) < density {
                    m.columns.push(c);
                    m.values.push(value(r, c) - 0.5);
                }
            }
            m.offsets.push(m.columns.len());
        }
        m
    }

    #[test]
    fn grouped_products_equal_the_row_by_row_sum_to_the_bit() {
        // Groups of 3 rows sharing a pattern, one group whose rows differ, one of 9 rows (more
        // than MAX_GROUP_ROWS, multiplied a row at a time) and single rows. Every entry must be
        // the sum of a_rk b_kc in increasing k, computed densely here: the same additions in
        // the same order, so the comparison is exact.
        let row_groups = [0, 3, 6, 7, 16, 18];
        let inner_groups = [0, 3, 6, 8, 9, 12, 20];
        let a = scattered(18, 20, 0.45, 1, &[1, 2, 5, 10, 11, 12, 13, 14, 15, 16, 17]);
        let b = scattered(
            20,
            15,
            0.4,
            2,
            &[1, 2, 4, 5, 7, 10, 11, 14, 15, 16, 17, 18, 19],
        );
        // A: 1 + 3 (rows 3 and 4 differ) + 1 + 9 + 1 row sets; B: 1 + 1 + 1 + 1 + 1 + 8 (rows
        // 12 and 13 differ).
        assert_eq!(GroupPattern::of(&a, &row_groups).row_sets.len() - 1, 15);
        assert_eq!(GroupPattern::of(&b, &inner_groups).row_sets.len() - 1, 13);
        let product = multiply(&a, &row_groups, &b, &inner_groups);
        product.assert_valid();
        let (a_dense, b_dense) = (dense(&a), dense(&b));
        let mut expected = vec![vec![0.0; 15]; 18];
        for (r, row) in expected.iter_mut().enumerate() {
            for (k, &a_rk) in a_dense[r].iter().enumerate() {
                if a_rk != 0.0 {
                    for (c, entry) in row.iter_mut().enumerate() {
                        *entry += a_rk * b_dense[k][c];
                    }
                }
            }
        }
        assert_eq!(dense(&product), expected);
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
