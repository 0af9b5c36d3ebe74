//! Preconditioners for the native Krylov methods: M ≈ A whose inverse is cheap to apply.
//! They are rebuilt from the matrix values on every solve (O(rows) work), since Newton changes
//! the values between solves even when the pattern stays.

use std::str::FromStr;

use super::super::{Csr, SolveError};
use super::UnknownChoice;

/// Which M⁻¹ the Krylov methods apply.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum Preconditioner {
    /// M = I.
    #[default]
    None,
    /// M = diag(A): each dof scaled by its own stiffness.
    Jacobi,
    /// M = the dense diagonal blocks of A given by `groups` offsets: block k couples dofs
    /// `groups[k]..groups[k + 1]` — one point's remaining free dofs (at most 3) after
    /// prescribed ones are eliminated, so the 3×3 point stiffness (Peridigm's "Block 3x3") is
    /// inverted exactly. `groups` starts at 0, increases strictly and ends at the row count.
    BlockJacobi {
        /// Block start offsets, length = number of blocks + 1.
        groups: Vec<usize>,
    },
}

impl Preconditioner {
    /// Short name for reports, e.g. `block Jacobi`.
    pub fn label(&self) -> &'static str {
        match self {
            Self::None => "no preconditioner",
            Self::Jacobi => "Jacobi",
            Self::BlockJacobi { .. } => "block Jacobi",
        }
    }

    /// Block Jacobi over consecutive blocks of `block_size` dofs (the last one shorter when
    /// `dofs` is not a multiple), e.g. 3 dofs per point when no dof is prescribed.
    pub fn block_jacobi_uniform(dofs: usize, block_size: usize) -> Self {
        assert!(block_size > 0, "block size must be positive");
        let mut groups: Vec<usize> = (0..dofs).step_by(block_size).collect();
        groups.push(dofs);
        Self::BlockJacobi { groups }
    }
}

/// The preconditioner choice as a deck names it, before the dof groups are known.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PreconditionerKind {
    /// See [`Preconditioner::None`].
    #[default]
    None,
    /// See [`Preconditioner::Jacobi`].
    Jacobi,
    /// See [`Preconditioner::BlockJacobi`].
    BlockJacobi,
}

impl PreconditionerKind {
    /// Names accepted by [`FromStr`] (case and separators ignored).
    pub const NAMES: &'static [&'static str] = &["None", "Jacobi", "Block Jacobi", "Block 3x3"];

    /// The preconditioner for this kind; `groups` (block offsets, see
    /// [`Preconditioner::BlockJacobi`]) is used only by block Jacobi.
    pub fn with_groups(self, groups: Vec<usize>) -> Preconditioner {
        match self {
            Self::None => Preconditioner::None,
            Self::Jacobi => Preconditioner::Jacobi,
            Self::BlockJacobi => Preconditioner::BlockJacobi { groups },
        }
    }
}

impl FromStr for PreconditionerKind {
    type Err = UnknownChoice;

    /// Accepts `None`, `Jacobi`, `Block Jacobi` and Peridigm's `Block 3x3`.
    fn from_str(name: &str) -> Result<Self, Self::Err> {
        match super::normalize_name(name).as_str() {
            "none" => Ok(Self::None),
            "jacobi" | "diagonal" => Ok(Self::Jacobi),
            "blockjacobi" | "block3x3" => Ok(Self::BlockJacobi),
            _ => Err(UnknownChoice {
                what: "preconditioner",
                given: name.to_string(),
                expected: Self::NAMES,
            }),
        }
    }
}

/// A preconditioner built from one matrix's values: applies z = M⁻¹ r. Usable directly as the
/// `preconditioner` closure of the matrix-free methods, e.g. a JFNK solve preconditioned by a
/// Rust-assembled approximate tangent.
#[derive(Debug, Clone)]
pub struct PreconditionerOperator {
    label: &'static str,
    inverse: Inverse,
    notes: Vec<String>,
}

#[derive(Debug, Clone)]
enum Inverse {
    Identity,
    /// 1/Aᵢᵢ per dof.
    Diagonal(Vec<f64>),
    /// Inverted blocks stored row-major one after another, block k at `starts[k]`.
    Blocks {
        groups: Vec<usize>,
        starts: Vec<usize>,
        inverses: Vec<f64>,
    },
}

impl PreconditionerOperator {
    /// Builds M⁻¹ for `matrix`. A zero diagonal entry is replaced by 1 (that dof is left
    /// unpreconditioned) and a singular diagonal block falls back to Jacobi on that block;
    /// both leave a line in [`PreconditionerOperator::notes`] instead of producing NaN.
    ///
    /// Errors: `NonFinite` for a non-finite diagonal entry, `Breakdown` when block offsets do
    /// not describe the matrix's rows (a caller bug reported as a value, not a panic).
    pub fn build(choice: &Preconditioner, matrix: &Csr) -> Result<Self, SolveError> {
        let label = choice.label();
        let mut notes = Vec::new();
        let inverse = match choice {
            Preconditioner::None => Inverse::Identity,
            Preconditioner::Jacobi => {
                let diagonal = matrix.diagonal();
                Inverse::Diagonal(jacobi_inverse(&diagonal, 0, &mut notes)?)
            }
            Preconditioner::BlockJacobi { groups } => {
                check_groups(groups, matrix.nrows)?;
                block_inverses(matrix, groups, &mut notes)?
            }
        };
        Ok(Self {
            label,
            inverse,
            notes,
        })
    }

    /// Short name for reports, e.g. `block Jacobi`.
    pub fn label(&self) -> &'static str {
        self.label
    }

    /// Bytes held by the inverse (offsets and inverted blocks, or the inverted diagonal).
    pub fn memory_bytes(&self) -> usize {
        let word = std::mem::size_of::<usize>();
        match &self.inverse {
            Inverse::Identity => 0,
            Inverse::Diagonal(inverse) => inverse.len() * 8,
            Inverse::Blocks {
                groups,
                starts,
                inverses,
            } => (groups.len() + starts.len()) * word + inverses.len() * 8,
        }
    }

    /// What was adjusted while building (zero pivots, singular blocks), for the log.
    pub fn notes(&self) -> &[String] {
        &self.notes
    }

    /// z = M⁻¹ r.
    pub fn apply(&self, r: &[f64], z: &mut [f64]) {
        match &self.inverse {
            Inverse::Identity => z.copy_from_slice(r),
            Inverse::Diagonal(inverse) => {
                for ((z_i, r_i), d_i) in z.iter_mut().zip(r).zip(inverse) {
                    *z_i = r_i * d_i;
                }
            }
            Inverse::Blocks {
                groups,
                starts,
                inverses,
            } => {
                for (k, window) in groups.windows(2).enumerate() {
                    let (begin, end) = (window[0], window[1]);
                    let size = end - begin;
                    let block = &inverses[starts[k]..starts[k] + size * size];
                    for i in 0..size {
                        z[begin + i] = (0..size).map(|j| block[i * size + j] * r[begin + j]).sum();
                    }
                }
            }
        }
    }
}

/// 1/d for each entry of `diagonal`, 1 where d = 0 (with a note); `offset` shifts the dof
/// numbers in notes when `diagonal` is one block's.
fn jacobi_inverse(
    diagonal: &[f64],
    offset: usize,
    notes: &mut Vec<String>,
) -> Result<Vec<f64>, SolveError> {
    diagonal
        .iter()
        .enumerate()
        .map(|(i, &d)| {
            if !d.is_finite() {
                Err(SolveError::NonFinite {
                    what: format!("the matrix diagonal (row {})", offset + i),
                })
            } else if d == 0.0 {
                notes.push(format!(
                    "Jacobi: row {} has a zero diagonal entry; left unpreconditioned",
                    offset + i
                ));
                Ok(1.0)
            } else {
                Ok(1.0 / d)
            }
        })
        .collect()
}

fn check_groups(groups: &[usize], rows: usize) -> Result<(), SolveError> {
    let consistent = groups.first() == Some(&0)
        && groups.last() == Some(&rows)
        && groups.windows(2).all(|w| w[0] < w[1]);
    if consistent || (rows == 0 && groups.iter().all(|&g| g == 0)) {
        Ok(())
    } else {
        Err(SolveError::Breakdown {
            method: "block Jacobi",
            reason: format!(
                "block offsets must start at 0, increase strictly and end at the row count {rows}; \
                 got {} offsets from {:?} to {:?}",
                groups.len(),
                groups.first(),
                groups.last()
            ),
        })
    }
}

fn block_inverses(
    matrix: &Csr,
    groups: &[usize],
    notes: &mut Vec<String>,
) -> Result<Inverse, SolveError> {
    let mut starts = Vec::with_capacity(groups.len().saturating_sub(1));
    let mut inverses = Vec::new();
    let mut block = Vec::new();
    for window in groups.windows(2) {
        let (begin, end) = (window[0], window[1]);
        let size = end - begin;
        block.clear();
        block.resize(size * size, 0.0);
        for i in 0..size {
            let (columns, values) = matrix.row(begin + i);
            let first = columns.partition_point(|&c| c < begin);
            for (&c, &v) in columns[first..].iter().zip(&values[first..]) {
                if c >= end {
                    break;
                }
                if !v.is_finite() {
                    return Err(SolveError::NonFinite {
                        what: format!("the matrix (row {}, column {c})", begin + i),
                    });
                }
                block[i * size + (c - begin)] = v;
            }
        }
        starts.push(inverses.len());
        match invert_dense(&block, size) {
            Some(inverse) => inverses.extend_from_slice(&inverse),
            None => {
                notes.push(format!(
                    "block Jacobi: the {size}×{size} diagonal block of dofs {begin}..{end} is \
                     singular; Jacobi used on that block"
                ));
                let diagonal: Vec<f64> = (0..size).map(|i| block[i * size + i]).collect();
                let diagonal_inverse = jacobi_inverse(&diagonal, begin, notes)?;
                let mut inverse = vec![0.0; size * size];
                for (i, d) in diagonal_inverse.into_iter().enumerate() {
                    inverse[i * size + i] = d;
                }
                inverses.extend_from_slice(&inverse);
            }
        }
    }
    Ok(Inverse::Blocks {
        groups: groups.to_vec(),
        starts,
        inverses,
    })
}

/// Inverse of a small row-major dense matrix by Gauss–Jordan elimination with partial
/// pivoting; `None` when a pivot is below 1e-14 × the block's largest entry (numerically
/// singular: the inverse would amplify rounding by more than 10¹⁴).
pub fn invert_dense(matrix: &[f64], size: usize) -> Option<Vec<f64>> {
    let scale = matrix.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if scale == 0.0 {
        return None;
    }
    let mut a = matrix.to_vec();
    let mut inverse = vec![0.0; size * size];
    for i in 0..size {
        inverse[i * size + i] = 1.0;
    }
    for column in 0..size {
        let pivot_row = (column..size)
            .max_by(|&p, &q| {
                a[p * size + column]
                    .abs()
                    .total_cmp(&a[q * size + column].abs())
            })
            .expect("a non-empty pivot range");
        let pivot = a[pivot_row * size + column];
        if pivot.abs() <= 1e-14 * scale {
            return None;
        }
        if pivot_row != column {
            for j in 0..size {
                a.swap(pivot_row * size + j, column * size + j);
                inverse.swap(pivot_row * size + j, column * size + j);
            }
        }
        for j in 0..size {
            a[column * size + j] /= pivot;
            inverse[column * size + j] /= pivot;
        }
        for row in 0..size {
            if row == column {
                continue;
            }
            let factor = a[row * size + column];
            if factor == 0.0 {
                continue;
            }
            for j in 0..size {
                a[row * size + j] -= factor * a[column * size + j];
                inverse[row * size + j] -= factor * inverse[column * size + j];
            }
        }
    }
    Some(inverse)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dense_to_csr(rows: &[&[f64]]) -> Csr {
        let n = rows.len();
        let mut csr = Csr {
            nrows: n,
            ncols: n,
            offsets: vec![0],
            ..Csr::default()
        };
        for row in rows {
            for (c, &v) in row.iter().enumerate() {
                if v != 0.0 {
                    csr.columns.push(c);
                    csr.values.push(v);
                }
            }
            csr.offsets.push(csr.columns.len());
        }
        csr
    }

    #[test]
    fn block_jacobi_inverts_each_block_exactly() {
        // Blocks [[4, 1], [2, 3]] (det 10, inverse [[0.3, −0.1], [−0.2, 0.4]]) and [5];
        // the off-block entry 7 must be ignored.
        let a = dense_to_csr(&[&[4.0, 1.0, 7.0], &[2.0, 3.0, 0.0], &[0.0, 0.0, 5.0]]);
        let m = PreconditionerOperator::build(
            &Preconditioner::BlockJacobi {
                groups: vec![0, 2, 3],
            },
            &a,
        )
        .unwrap();
        let mut z = vec![0.0; 3];
        m.apply(&[1.0, 1.0, 10.0], &mut z);
        // Inverse rows times (1, 1): 0.3 − 0.1, −0.2 + 0.4; 10/5.
        let expected = [0.2, 0.2, 2.0];
        for (z_i, e_i) in z.iter().zip(expected) {
            assert!((z_i - e_i).abs() < 1e-15, "{z:?}");
        }
        assert!(m.notes().is_empty());
    }

    #[test]
    fn a_singular_block_falls_back_to_jacobi_with_a_note() {
        // [[1, 1], [1, 1]] has determinant 0; its diagonal (1, 1) is still usable.
        let a = dense_to_csr(&[&[1.0, 1.0], &[1.0, 1.0]]);
        let m =
            PreconditionerOperator::build(&Preconditioner::BlockJacobi { groups: vec![0, 2] }, &a)
                .unwrap();
        let mut z = vec![0.0; 2];
        m.apply(&[3.0, 4.0], &mut z);
        assert_eq!(z, vec![3.0, 4.0]);
        assert_eq!(m.notes().len(), 1);
        assert!(m.notes()[0].contains("singular"), "{:?}", m.notes());
    }

    #[test]
    fn zero_diagonal_is_left_unpreconditioned_and_bad_groups_are_errors() {
        let a = dense_to_csr(&[&[0.0, 1.0], &[1.0, 2.0]]);
        let m = PreconditionerOperator::build(&Preconditioner::Jacobi, &a).unwrap();
        let mut z = vec![0.0; 2];
        m.apply(&[3.0, 4.0], &mut z);
        assert_eq!(z, vec![3.0, 2.0]);
        assert_eq!(m.notes().len(), 1);
        let bad = Preconditioner::BlockJacobi { groups: vec![0, 1] };
        assert!(matches!(
            PreconditionerOperator::build(&bad, &a),
            Err(SolveError::Breakdown { .. })
        ));
    }

    #[test]
    fn names_parse_including_peridigm_block_3x3() {
        assert_eq!(
            "Block 3x3".parse::<PreconditionerKind>().unwrap(),
            PreconditionerKind::BlockJacobi
        );
        assert_eq!(
            "jacobi".parse::<PreconditionerKind>().unwrap(),
            PreconditionerKind::Jacobi
        );
        let error = "ILU".parse::<PreconditionerKind>().unwrap_err();
        assert!(error.to_string().contains("Block Jacobi"), "{error}");
        assert_eq!(
            Preconditioner::block_jacobi_uniform(7, 3),
            Preconditioner::BlockJacobi {
                groups: vec![0, 3, 6, 7]
            }
        );
    }
}
