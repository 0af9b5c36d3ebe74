//! Row sets: the rows of a point (1–3 unknowns) or of an aggregate (its coarse unknowns, at
//! most the six rigid-body modes) share one column pattern in every matrix of a hierarchy,
//! because the one-hop operator couples whole points and the prolongator whole aggregates.
//! Sparse products and stored matrices exploit it: a set's column indices are read (or
//! stored) once for all its rows.

use super::super::super::Csr;

/// Rows of a group taken as one set at most: a larger group's rows are sets of one row.
pub(super) const MAX_GROUP_ROWS: usize = 8;

/// Where a matrix's rows share a column pattern.
pub(super) struct GroupPattern {
    /// Offsets of the row sets: a group of rows with one pattern (of at most
    /// [`MAX_GROUP_ROWS`]), or one row of a group whose rows differ.
    pub row_sets: Vec<usize>,
    /// For each row, the first row of its set.
    pub set_start: Vec<usize>,
    /// For each row, one past the last row of its set.
    pub set_end: Vec<usize>,
}

impl GroupPattern {
    /// The row sets of `m` whose rows are grouped by `groups` (offsets).
    pub fn of(m: &Csr, groups: &[usize]) -> Self {
        assert_eq!(groups.last(), Some(&m.nrows), "the groups cover the rows");
        let mut row_sets = vec![0];
        let mut set_start = vec![0; m.nrows];
        let mut set_end = vec![0; m.nrows];
        for group in groups.windows(2) {
            let (first, end) = (group[0], group[1]);
            let shared = end - first <= MAX_GROUP_ROWS
                && (first + 1..end).all(|r| m.row(r).0 == m.row(first).0);
            let sets: Vec<(usize, usize)> = if shared {
                vec![(first, end)]
            } else {
                (first..end).map(|r| (r, r + 1)).collect()
            };
            for (start, stop) in sets {
                set_start[start..stop].fill(start);
                set_end[start..stop].fill(stop);
                row_sets.push(stop);
            }
        }
        Self {
            row_sets,
            set_start,
            set_end,
        }
    }
}
