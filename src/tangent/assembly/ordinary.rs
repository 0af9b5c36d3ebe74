//! The analytic tangent of an *ordinary* force state: the O(n) derivatives of each bond
//! ([`OrdinaryBond`]) and their assembly row by row ([`gather_ordinary`]), each block summed
//! while its row is in cache and written once.

use super::{add_scaled, ForceState, PointIndex};
use crate::model::{BondList, BondVolumes};
use crate::model::{CurrentView, ReferenceView};
use crate::tangent::{Block, BlockTangent, TangentError};

/// The derivatives of one bond of an *ordinary* force state, `T_n = t_n M_n`, whose scalar
/// `t_n(e_n, θ)` depends on the bond's own extension `e_n = |Y_n| − ζ_n` and on one scalar
/// `θ` linear in the family's extensions (LPS: the dilatation; PMB: no θ). With
/// `D_n = axial·M⊗M + lateral·(I − M⊗M)`:
///
/// `∂T_n/∂Y_{j_k} = δ_nk D_n + γ_n β_k M_n ⊗ M_k`, `∂T_n/∂Y_i = −Σ_k ∂T_n/∂Y_{j_k}`.
///
/// The whole point tangent is thus O(n) numbers, and its (n + 1)² blocks are formed while
/// they are added, never stored (the dense path of AD and finite differences stores them).
#[derive(Debug, Clone, Copy, Default)]
pub struct OrdinaryBond {
    /// M_n, the current bond direction (zero for a bond of zero length, which has no force).
    pub direction: [f64; 3],
    /// ∂t_n/∂e_n at fixed θ (force/length⁷).
    pub axial: f64,
    /// t_n/|Y_n|: the rotation stiffness of the pre-stressed bond (force/length⁷).
    pub lateral: f64,
    /// γ_n = ∂t_n/∂θ (force/length⁶).
    pub coupling: f64,
    /// β_n = ∂θ/∂e_n (1/length).
    pub weight: f64,
}

impl OrdinaryBond {
    /// `scale · D_n`.
    #[inline(always)]
    fn stiffness(&self, scale: f64) -> Block {
        let m = self.direction;
        let mut block = [[0.0; 3]; 3];
        for k in 0..3 {
            for l in 0..3 {
                let mm = m[k] * m[l];
                let identity = if k == l { 1.0 } else { 0.0 };
                block[k][l] = scale * (self.axial * mm + self.lateral * (identity - mm));
            }
        }
        block
    }
}

/// `a ⊗ b`.
#[inline(always)]
fn outer(a: [f64; 3], b: [f64; 3]) -> Block {
    a.map(|ak| b.map(|bl| ak * bl))
}

/// The analytic assembly, row by row: every block is summed while its row is in cache and
/// written once (the scatter of the other methods touches each block from every point whose
/// family holds both ends, ~n/5 times on a lattice, which is what limits it).
///
/// Pass 1 stores the [`OrdinaryBond`] derivatives of every bond of the block's points and,
/// per point, `G_i = Σ_n s_n γ_n M_n` and `Q_i = Σ_n β_n M_n` (`s_n = V_i V_{j_n}`,
/// `q_n = β_n M_n`). Pass 2 gives row r the contributions of every block point i whose
/// closed family holds r (see [`OrdinaryBond`] for the derivatives):
/// * i = r: column j_n gets `s_n D_n + G_r ⊗ q_n`, column r gets `−Σ_n s_n D_n − G_r ⊗ Q_r`;
/// * r the m-th neighbour of i, `s = V_i V_r`, `p = −s γ_m M_m` (bond i→r): column i gets
///   `s D_m − p ⊗ Q_i`, column j_k gets `p ⊗ q_k`, and column r also `−s D_m`.
pub(super) fn gather_ordinary<K: ForceState>(
    kernel: &K,
    points: &[u32],
    reference: &ReferenceView<'_>,
    current: &CurrentView<'_>,
    tangent: &mut BlockTangent,
) -> Result<(), TangentError> {
    let bonds = reference.bonds;
    let n_points = bonds.num_points();
    let mut member = vec![false; n_points];
    for &i in points {
        member[i as usize] = true;
    }
    let data = bond_derivatives(kernel, points, reference, current)?;
    let sums = point_sums(points, reference, &data);
    let derivatives = OrdinaryDerivatives {
        bonds,
        volume: reference.volume,
        bond_volume: reference.bond_volumes(),
        data: &data,
        sums: &sums,
        member: &member,
        sorted_rows: (0..n_points).all(|i| bonds.family(i).is_sorted()),
    };
    derivatives.add_rows(tangent)
}

/// Pass 1 of [`gather_ordinary`]: the [`OrdinaryBond`] derivatives of every bond of the
/// block's points (indexed by global bond; entries of other blocks' points stay unused).
fn bond_derivatives<K: ForceState>(
    kernel: &K,
    points: &[u32],
    reference: &ReferenceView<'_>,
    current: &CurrentView<'_>,
) -> Result<Vec<OrdinaryBond>, TangentError> {
    use crate::model::point_chunks::for_each_chunk;
    use std::sync::atomic::{AtomicUsize, Ordering};

    let bonds = reference.bonds;
    let mut data = vec![OrdinaryBond::default(); bonds.num_bonds()];
    let first_bad = AtomicUsize::new(usize::MAX);
    for_each_chunk(
        points,
        &mut data[..],
        &|i| bonds.offsets[i as usize],
        &|chunk: &[u32], base: usize, out: &mut [OrdinaryBond]| {
            let mut y = Vec::new();
            let local0 = points.partition_point(|&p| p < chunk[0]);
            for (local, &i) in (local0..).zip(chunk) {
                let i = i as usize;
                y.clear();
                y.push(current.position[i]);
                y.extend(
                    bonds
                        .family(i)
                        .iter()
                        .map(|&j| current.position[j as usize]),
                );
                let range = bonds.range(i);
                let row = &mut out[range.start - base..range.end - base];
                kernel.ordinary_derivatives(PointIndex { global: i, local }, &y, row);
                let finite = row.iter().all(|b| {
                    b.direction.iter().all(|c| c.is_finite())
                        && [b.axial, b.lateral, b.coupling, b.weight]
                            .iter()
                            .all(|c| c.is_finite())
                });
                if !finite {
                    first_bad.fetch_min(i, Ordering::Relaxed);
                }
            }
        },
    );
    match first_bad.into_inner() {
        usize::MAX => Ok(data),
        bad => Err(TangentError::NonFinite {
            point: bad,
            input_id: None,
        }),
    }
}

/// `q_n = β_n M_n`.
#[inline(always)]
fn weighted(bond: &OrdinaryBond) -> [f64; 3] {
    bond.direction.map(|c| bond.weight * c)
}

/// `[G_i, Q_i]` of the block's points (zero for other points) from pass 1's `data`.
fn point_sums(
    points: &[u32],
    reference: &ReferenceView<'_>,
    data: &[OrdinaryBond],
) -> Vec<[[f64; 3]; 2]> {
    use crate::model::point_chunks::for_each_chunk;

    let bonds = reference.bonds;
    let (volume, bond_volume) = (reference.volume, reference.bond_volumes());
    let mut sums = vec![[[0.0; 3]; 2]; bonds.num_points()];
    for_each_chunk(
        points,
        &mut sums[..],
        &|i| i as usize,
        &|chunk: &[u32], base: usize, out: &mut [[[f64; 3]; 2]]| {
            for &i in chunk {
                let i = i as usize;
                let (mut g, mut q) = ([0.0; 3], [0.0; 3]);
                for b in bonds.range(i) {
                    let bond = &data[b];
                    let w =
                        volume[i] * bond_volume.of(b, bonds.neighbor[b] as usize) * bond.coupling;
                    let qb = weighted(bond);
                    for k in 0..3 {
                        g[k] += w * bond.direction[k];
                        q[k] += qb[k];
                    }
                }
                out[i - base] = [g, q];
            }
        },
    );
    sums
}

/// What pass 2 of [`gather_ordinary`] reads: pass 1's derivatives and the block's points.
struct OrdinaryDerivatives<'a> {
    bonds: &'a BondList,
    /// Volume of every point (length³).
    volume: &'a [f64],
    /// The quadrature volume of every bond.
    bond_volume: BondVolumes<'a>,
    /// The derivatives of every bond of the block's points (global bond index).
    data: &'a [OrdinaryBond],
    /// `[G_i, Q_i]` of every point (zero outside the block).
    sums: &'a [[[f64; 3]; 2]],
    /// Whether each point is one of the block's.
    member: &'a [bool],
    /// Every bond-list row is sorted, so reverse bonds are found by binary search.
    sorted_rows: bool,
}

impl OrdinaryDerivatives<'_> {
    /// Bond index of i→r in i's row.
    fn reverse(&self, i: usize, r: usize) -> usize {
        let family = self.bonds.family(i);
        let found = if self.sorted_rows {
            family.binary_search(&(r as u32)).ok()
        } else {
            family.iter().position(|&j| j as usize == r)
        };
        self.bonds.offsets[i] + found.expect("families are symmetric (j in i's iff i in j's)")
    }

    /// The block points i whose family holds r, each with its bond i→r and that bond's
    /// s = V_i V_r (the quadrature volume of r for i), in the order of r's row.
    fn bonds_into(&self, r: usize) -> impl Iterator<Item = (usize, &OrdinaryBond, f64)> + '_ {
        let members = self.bonds.family(r).iter().map(|&i| i as usize);
        members.filter(|&i| self.member[i]).map(move |i| {
            let m = self.reverse(i, r);
            (i, &self.data[m], self.volume[i] * self.bond_volume.of(m, r))
        })
    }

    /// Pass 2: adds every row that a block point reaches to `tangent`, one task per chunk of
    /// rows.
    fn add_rows(&self, tangent: &mut BlockTangent) -> Result<(), TangentError> {
        use crate::model::point_chunks::for_each_chunk;
        use std::sync::atomic::{AtomicUsize, Ordering};

        let n_points = self.bonds.num_points();
        let pattern = tangent.pattern.clone();
        let offsets = pattern.offsets();
        let diagonal_only = pattern.is_diagonal_only();
        let all: Vec<u32> = (0..n_points as u32).collect();
        let missing = AtomicUsize::new(usize::MAX);
        let missing_column = AtomicUsize::new(usize::MAX);
        for_each_chunk(
            &all,
            &mut tangent.blocks[..],
            &|r| offsets[r as usize],
            &|chunk: &[u32], base: usize, out: &mut [Block]| {
                // slot[c] = position of column c in the current row (u32::MAX: not stored).
                let mut slot = if diagonal_only {
                    Vec::new()
                } else {
                    vec![u32::MAX; n_points]
                };
                for &r in chunk {
                    let r = r as usize;
                    let family = self.bonds.family(r);
                    if !self.member[r] && !family.iter().any(|&i| self.member[i as usize]) {
                        continue;
                    }
                    let row = &mut out[offsets[r] - base..offsets[r + 1] - base];
                    if diagonal_only {
                        self.add_diagonal_block(&mut row[0], r);
                        continue;
                    }
                    let columns = pattern.row(r);
                    for (p, &c) in columns.iter().enumerate() {
                        slot[c as usize] = p as u32;
                    }
                    let lost = self.add_row(r, row, &slot);
                    for &c in columns {
                        slot[c as usize] = u32::MAX;
                    }
                    if let Some(c) = lost {
                        if missing.fetch_min(r, Ordering::Relaxed) > r {
                            missing_column.store(c, Ordering::Relaxed);
                        }
                    }
                }
            },
        );
        let row = missing.into_inner();
        if row != usize::MAX {
            return Err(TangentError::PatternTooSmall {
                row,
                column: missing_column.into_inner(),
            });
        }
        Ok(())
    }

    /// Adds row r's blocks (see [`gather_ordinary`]) to `row`, whose column c sits at
    /// `slot[c]`. Returns a column the pattern lacks, if any.
    #[inline]
    fn add_row(&self, r: usize, row: &mut [Block], slot: &[u32]) -> Option<usize> {
        let (bonds, volume, data, sums) = (self.bonds, self.volume, self.data, self.sums);
        let bond_volume = self.bond_volume;
        let mut lost = None;
        let mut add = |row: &mut [Block], c: usize, block: &Block| match slot[c] {
            u32::MAX => lost = Some(c),
            p => add_scaled(&mut row[p as usize], 1.0, block),
        };
        if self.member[r] {
            let [g, q_total] = sums[r];
            let mut diagonal = outer(g, q_total).map(|l| l.map(|v| -v));
            for b in bonds.range(r) {
                let bond = &data[b];
                let j = bonds.neighbor[b] as usize;
                let d = bond.stiffness(volume[r] * bond_volume.of(b, j));
                let mut block = outer(g, weighted(bond));
                add_scaled(&mut block, 1.0, &d);
                add(row, j, &block);
                add_scaled(&mut diagonal, -1.0, &d);
            }
            add(row, r, &diagonal);
        }
        for (i, bond, s) in self.bonds_into(r) {
            let d = bond.stiffness(s);
            let p = bond.direction.map(|c| -s * bond.coupling * c);
            let mut to_i = d;
            add_scaled(&mut to_i, -1.0, &outer(p, sums[i][1]));
            add(row, i, &to_i);
            add(row, r, &d.map(|l| l.map(|v| -v)));
            if bond.coupling != 0.0 {
                for b in bonds.range(i) {
                    let k = bonds.neighbor[b] as usize;
                    add(row, k, &outer(p, weighted(&data[b])));
                }
            }
        }
        lost
    }

    /// Adds J_rr from the block's points: the column-r terms of [`gather_ordinary`], summed
    /// in the same order, so the block diagonal is bitwise the diagonal of the full tangent.
    fn add_diagonal_block(&self, target: &mut Block, r: usize) {
        let (bonds, volume, data) = (self.bonds, self.volume, self.data);
        let bond_volume = self.bond_volume;
        if self.member[r] {
            let [g, q_total] = self.sums[r];
            let mut diagonal = outer(g, q_total).map(|l| l.map(|v| -v));
            for b in bonds.range(r) {
                let j = bonds.neighbor[b] as usize;
                add_scaled(
                    &mut diagonal,
                    -1.0,
                    &data[b].stiffness(volume[r] * bond_volume.of(b, j)),
                );
            }
            add_scaled(target, 1.0, &diagonal);
        }
        for (_, bond, s) in self.bonds_into(r) {
            let d = bond.stiffness(s);
            add_scaled(target, 1.0, &d.map(|l| l.map(|v| -v)));
            if bond.coupling != 0.0 {
                let p = bond.direction.map(|c| -s * bond.coupling * c);
                add_scaled(target, 1.0, &outer(p, weighted(bond)));
            }
        }
    }
}
