//! The default force path of a material written as a force state ([`ForceState`], the same
//! code the tangent differentiates): every point's vector force states `T_i⟨ξ_ij⟩` are
//! evaluated once, in row order, and each point then gathers
//!
//! `F_i = Σ_j (T_i⟨ξ_ij⟩ − T_j⟨ξ_ji⟩) V_j`
//!
//! through the reverse of each bond (Silling et al. 2007, eq. 9; the force convention of the
//! module docs of `material`). Cost: one force-state evaluation per point and 3 numbers per
//! directed bond of scratch. The hand-tuned kernels of PMB and LPS (row loops with
//! published coefficients) and the correspondence gather (published `P K⁻¹` and F) are fast
//! paths of this sum; it is the reference their tests check them against (built for tests
//! only, as every model of this build has its own gather).
//!
//! Every neighbour of a point of `points` must be in `points` too (a block without bonds to
//! another block), so that both force states of every bond are evaluated.

use crate::model::point_chunks::for_each_chunk;
use crate::model::{BondList, CurrentView, ReferenceView};
use crate::tangent::{ForceState, PointIndex};

/// Adds `F_i` of every point of `points` (strictly increasing) to `force_density`, from the
/// force states of `kernel` at `current`.
pub(crate) fn add_force_density_from_states<K: ForceState>(
    kernel: &K,
    points: &[u32],
    reference: &ReferenceView<'_>,
    current: &CurrentView<'_>,
    force_density: &mut [[f64; 3]],
) {
    let bonds = reference.bonds;
    let states = force_states(kernel, points, bonds, current.position);
    for_each_chunk(
        points,
        force_density,
        &|i| i as usize,
        &|chunk: &[u32], base: usize, out: &mut [[f64; 3]]| {
            for &i in chunk {
                let i = i as usize;
                let mut total = [0.0; 3];
                for b in bonds.range(i) {
                    let j = bonds.neighbor[b] as usize;
                    let back = reverse_bond(bonds, i, j);
                    let v = reference.neighbor_volume(b, j);
                    for k in 0..3 {
                        total[k] += (states[b][k] - states[back][k]) * v;
                    }
                }
                for k in 0..3 {
                    out[i - base][k] += total[k];
                }
            }
        },
    );
}

/// `T_i⟨ξ_ij⟩` of every bond of every point of `points`, indexed like the bond list (zero for
/// the bonds of other points).
fn force_states<K: ForceState>(
    kernel: &K,
    points: &[u32],
    bonds: &BondList,
    position: &[[f64; 3]],
) -> Vec<[f64; 3]> {
    let mut states = vec![[0.0; 3]; bonds.num_bonds()];
    for_each_chunk(
        points,
        &mut states[..],
        &|i| bonds.offsets[i as usize],
        &|chunk: &[u32], base: usize, out: &mut [[f64; 3]]| {
            for &i in chunk {
                let global = i as usize;
                let local = points
                    .binary_search(&i)
                    .expect("the chunk's points are the block's");
                let y: Vec<[f64; 3]> = std::iter::once(position[global])
                    .chain(bonds.family(global).iter().map(|&j| position[j as usize]))
                    .collect();
                let row = bonds.offsets[global] - base..bonds.offsets[global + 1] - base;
                kernel.force_state::<f64>(PointIndex { global, local }, &y, None, &mut out[row]);
            }
        },
    );
    states
}

/// The index of bond j→i (families are sorted and symmetric).
fn reverse_bond(bonds: &BondList, i: usize, j: usize) -> usize {
    let position = bonds
        .family(j)
        .binary_search(&(i as u32))
        .expect("the bond list is symmetric");
    bonds.offsets[j] + position
}
