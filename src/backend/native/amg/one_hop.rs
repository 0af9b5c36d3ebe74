//! The one-hop preconditioning operator: a PMB-like stiffness over the bonds of the family
//! lists, cheap to assemble for every material, and the rigid-body modes that span its
//! kernel.
//!
//! Bond (i, j) with reference vector ξ = X_j − X_i contributes the 3×3 block
//! k_ij = c_ij (1 − d_ij) V_i V_j (ξ⊗ξ)/|ξ|³ (N/m) to K_ii and −k_ij to K_ij: the linearised
//! PMB bond force with ω = 1, the micromodulus c_ij = ½(c_i + c_j) of the two points' blocks,
//! c = 18K/(πδ⁴) (the PMB constant of [`crate::material::bond_based`], K the block's bulk
//! modulus) and d_ij the bond damage. For bond-based materials this is the small-strain
//! tangent; for state-based and correspondence materials it is a spectrally equivalent
//! stand-in with ~family-size blocks a row instead of the two-hop tangent's ~family².
//!
//! The reference direction is used (not the current one): it is exact at small strain,
//! which is where quasi-static load steps live, it needs no re-assembly when points move,
//! and a preconditioner only has to be close, not exact. The operator is symmetric positive
//! semi-definite, zero exactly on the six rigid-body modes of the linearisation, and positive
//! definite once enough dofs are prescribed; its rows and columns are the unknowns of a
//! [`DofMap`](crate::solver::implicit::DofMap) (prescribed and held dofs eliminated).

use rayon::prelude::*;

use crate::backend::Csr;
use crate::model::BondList;

/// What the one-hop operator is assembled from (per-point slices indexed by point, per-bond
/// slices by bond of `bonds`).
pub struct OneHopInput<'a> {
    /// Reference coordinates X (m).
    pub position: &'a [[f64; 3]],
    /// Cell volumes V (m³).
    pub volume: &'a [f64],
    /// The family lists.
    pub bonds: &'a BondList,
    /// Micromodulus c of every point's block (N/m⁶ in 3-D), see [`pmb_micromodulus`].
    pub micromodulus: &'a [f64],
    /// Bond damage d ∈ [0, 1] (`None`: no bond is damaged).
    pub bond_damage: Option<&'a [f32]>,
    /// Added to each point's diagonal block times the identity (N/m), e.g. Newmark's
    /// ρV/(βΔt²); `None` for quasi-statics.
    pub diagonal_shift: Option<&'a [f64]>,
    /// Unknown of every dof `3·point + component`, `None` for prescribed or held dofs.
    pub dof_index: &'a [Option<usize>],
    /// Number of unknowns.
    pub unknowns: usize,
    /// Which bonds of each family the operator keeps.
    pub stencil: Stencil,
}

/// The bonds of a family the one-hop operator is assembled over.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Stencil {
    /// Every bond of the family: ~4/3 π m³ blocks a row (≈ 120 at m = δ/Δx = 3), the closest
    /// stand-in for the model's tangent.
    Family,
    /// The point's nearest shells only: bonds no longer than [`NEAREST_SHELLS`] × the point's
    /// shortest bond (the 26 lattice neighbours of a cubic grid, whatever the horizon). Each
    /// kept bond is scaled by f_ij = ½(f_i + f_j), f_i = Σ_family |ξ|V_j / Σ_kept |ξ|V_j, so
    /// that a uniform dilatation stores the same energy as with [`Stencil::Family`] (every
    /// bond stretches by the same amount then, and a bond stores energy ∝ |ξ|, see the module
    /// docs). Long waves see the same bulk stiffness; waves shorter than δ see a stiffer
    /// operator than the model, by at most about m²: spectrally equivalent with constants
    /// independent of the point spacing at fixed m, at a fraction of the entries.
    #[default]
    Nearest,
}

/// [`Stencil::Nearest`] keeps bonds up to this multiple of the point's shortest bond: above
/// √3 (the cube diagonal of a cubic lattice) and below 2 (the second axial shell).
pub const NEAREST_SHELLS: f64 = 1.8;

/// PMB's micromodulus c = 18K/(πδ⁴) (N/m⁶) for bulk modulus K (Pa) and horizon δ (m).
pub fn pmb_micromodulus(bulk_modulus: f64, horizon: f64) -> f64 {
    18.0 * bulk_modulus / (std::f64::consts::PI * horizon.powi(4))
}

/// Points whose rows are computed in parallel before they are appended to the matrix: the
/// rows in flight stay a small fraction of the operator (about 12 MB at 26 kept bonds a point),
/// so the operator is not held twice while it is assembled.
const ASSEMBLY_CHUNK: usize = 4096;

/// The operator of the module docs over the unknowns of `input`.
pub fn one_hop_operator(input: &OneHopInput<'_>) -> Csr {
    let points = input.position.len();
    let stencil = kept_bonds(input);
    let capacity: usize = (0..points)
        .into_par_iter()
        .map(|i| entries_at_most(input, &stencil, i))
        .sum();
    let mut matrix = Csr {
        nrows: input.unknowns,
        ncols: input.unknowns,
        offsets: Vec::with_capacity(input.unknowns + 1),
        columns: Vec::with_capacity(capacity),
        values: Vec::with_capacity(capacity),
    };
    matrix.offsets.push(0);
    for first in (0..points).step_by(ASSEMBLY_CHUNK) {
        let rows: Vec<Vec<(Vec<usize>, Vec<f64>)>> = (first..points.min(first + ASSEMBLY_CHUNK))
            .into_par_iter()
            .map(|i| point_rows(input, &stencil, i))
            .collect();
        for (columns, values) in rows.into_iter().flatten() {
            matrix.columns.extend(columns);
            matrix.values.extend(values);
            matrix.offsets.push(matrix.columns.len());
        }
    }
    matrix
}

/// An upper bound of the entries of point i's rows: its free dofs times the free dofs of
/// itself and of every intact kept neighbour (a neighbour listed twice counted twice).
fn entries_at_most(input: &OneHopInput<'_>, stencil: &KeptBonds, i: usize) -> usize {
    let free = |point: usize| {
        (0..3)
            .filter(|&a| input.dof_index[3 * point + a].is_some())
            .count()
    };
    let rows = free(i);
    if rows == 0 {
        return 0;
    }
    let columns: usize = input
        .bonds
        .range(i)
        .filter(|&bond| input.bond_damage.is_none_or(|d| d[bond] < 1.0))
        .map(|bond| (bond, input.bonds.neighbor[bond] as usize))
        .filter(|&(bond, j)| keeps(&stencil.cutoff, i, j, input.bonds.reference_length[bond]))
        .map(|(_, j)| free(j))
        .sum();
    rows * (columns + rows)
}

/// Which bonds the operator keeps and the factor f_i of every point (see [`Stencil`]).
struct KeptBonds {
    /// Bonds no longer than this are kept, per point (m); infinite for [`Stencil::Family`].
    cutoff: Vec<f64>,
    /// f_i (1 for [`Stencil::Family`]).
    scale: Vec<f64>,
}

fn kept_bonds(input: &OneHopInput<'_>) -> KeptBonds {
    let points = input.position.len();
    if input.stencil == Stencil::Family {
        return KeptBonds {
            cutoff: vec![f64::INFINITY; points],
            scale: vec![1.0; points],
        };
    }
    let cutoff: Vec<f64> = (0..points)
        .into_par_iter()
        .map(|i| {
            let lengths = &input.bonds.reference_length[input.bonds.range(i)];
            NEAREST_SHELLS * lengths.iter().copied().fold(f64::INFINITY, f64::min)
        })
        .collect();
    let scale = (0..points)
        .into_par_iter()
        .map(|i| {
            let (mut family, mut kept) = (0.0, 0.0);
            for bond in input.bonds.range(i) {
                let j = input.bonds.neighbor[bond] as usize;
                let length = input.bonds.reference_length[bond];
                let weight = length * input.volume[j];
                family += weight;
                if keeps(&cutoff, i, j, length) {
                    kept += weight;
                }
            }
            if kept > 0.0 {
                family / kept
            } else {
                1.0
            }
        })
        .collect();
    KeptBonds { cutoff, scale }
}

/// Bond (i, j) of reference length `length` is kept when either end keeps it, so that rows i
/// and j agree and the operator stays symmetric.
fn keeps(cutoff: &[f64], i: usize, j: usize, length: f64) -> bool {
    length <= cutoff[i].max(cutoff[j])
}

/// The rows of point i's unknowns (none when all three dofs are eliminated).
fn point_rows(
    input: &OneHopInput<'_>,
    stencil: &KeptBonds,
    i: usize,
) -> Vec<(Vec<usize>, Vec<f64>)> {
    let free: Vec<(usize, usize)> = (0..3)
        .filter_map(|a| input.dof_index[3 * i + a].map(|row| (a, row)))
        .collect();
    if free.is_empty() {
        return Vec::new();
    }
    // (point, block) for the point itself and every intact neighbour, by point index so
    // the columns come out increasing.
    let mut blocks: Vec<(usize, [[f64; 3]; 3])> = Vec::new();
    let mut diagonal = [[0.0; 3]; 3];
    let shift = input.diagonal_shift.map_or(0.0, |s| s[i]);
    (0..3).for_each(|a| diagonal[a][a] = shift);
    for bond in input.bonds.range(i) {
        let intact = 1.0 - input.bond_damage.map_or(0.0, |d| f64::from(d[bond]));
        if intact <= 0.0 {
            continue;
        }
        let j = input.bonds.neighbor[bond] as usize;
        if !keeps(&stencil.cutoff, i, j, input.bonds.reference_length[bond]) {
            continue;
        }
        let xi: [f64; 3] = std::array::from_fn(|a| input.position[j][a] - input.position[i][a]);
        let length = xi.iter().map(|x| x * x).sum::<f64>().sqrt();
        let scale = 0.5
            * (input.micromodulus[i] + input.micromodulus[j])
            * 0.5
            * (stencil.scale[i] + stencil.scale[j])
            * intact
            * input.volume[i]
            * input.volume[j]
            / length.powi(3);
        let k: [[f64; 3]; 3] =
            std::array::from_fn(|a| std::array::from_fn(|b| scale * xi[a] * xi[b]));
        for a in 0..3 {
            for b in 0..3 {
                diagonal[a][b] += k[a][b];
            }
        }
        blocks.push((j, k.map(|row| row.map(|v| -v))));
    }
    blocks.push((i, diagonal));
    blocks.sort_by_key(|&(point, _)| point);
    // A point listed twice in a family (or bonded to itself) adds into one block.
    blocks.dedup_by(|(point, block), (kept_point, kept)| {
        let same = point == kept_point;
        if same {
            for a in 0..3 {
                for b in 0..3 {
                    kept[a][b] += block[a][b];
                }
            }
        }
        same
    });
    free.iter()
        .map(|&(a, _)| {
            let mut columns = Vec::with_capacity(3 * blocks.len());
            let mut values = Vec::with_capacity(3 * blocks.len());
            for (point, block) in &blocks {
                for (b, value) in block[a].iter().enumerate() {
                    if let Some(column) = input.dof_index[3 * point + b] {
                        columns.push(column);
                        values.push(*value);
                    }
                }
            }
            (columns, values)
        })
        .collect()
}

/// The six rigid-body modes (three translations, three rotations about the centroid) on the
/// unknowns `free` (global dofs `3·point + component`), row-major: unknowns × 6. Rotation
/// about axis e_a moves point X by e_a × (X − X̄), in length units of the coordinates.
pub fn rigid_body_modes(position: &[[f64; 3]], free: &[usize]) -> Vec<f64> {
    let count = position.len().max(1) as f64;
    let centroid: [f64; 3] =
        std::array::from_fn(|a| position.iter().map(|x| x[a]).sum::<f64>() / count);
    let mut modes = Vec::with_capacity(6 * free.len());
    for &dof in free {
        let (point, component) = (dof / 3, dof % 3);
        let x: [f64; 3] = std::array::from_fn(|a| position[point][a] - centroid[a]);
        let mut row = [0.0; 6];
        row[component] = 1.0;
        // (e_axis × x)_component for axis = 0, 1, 2.
        let rotation = match component {
            0 => [0.0, x[2], -x[1]],
            1 => [-x[2], 0.0, x[0]],
            _ => [x[1], -x[0], 0.0],
        };
        row[3..].copy_from_slice(&rotation);
        modes.extend_from_slice(&row);
    }
    modes
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two points 2 m apart along x, V = 1 m³, c = 1: k = c V V ξ⊗ξ/|ξ|³ = e_x⊗e_x / 2.
    fn pair(damage: Option<&[f32]>, dof_index: &[Option<usize>], unknowns: usize) -> Csr {
        let bonds = BondList {
            offsets: vec![0, 1, 2],
            neighbor: vec![1, 0],
            reference_length: vec![2.0, 2.0],
        };
        one_hop_operator(&OneHopInput {
            position: &[[0.0; 3], [2.0, 0.0, 0.0]],
            volume: &[1.0, 1.0],
            bonds: &bonds,
            micromodulus: &[1.0, 1.0],
            bond_damage: damage,
            diagonal_shift: None,
            dof_index,
            unknowns,
            stencil: Stencil::Family,
        })
    }

    #[test]
    fn a_bond_contributes_its_axial_stiffness() {
        let all: Vec<Option<usize>> = (0..6).map(Some).collect();
        let k = pair(None, &all, 6);
        k.assert_valid();
        assert_eq!(
            k.row(0),
            (
                &[0, 1, 2, 3, 4, 5][..],
                &[0.5, 0.0, 0.0, -0.5, 0.0, 0.0][..]
            )
        );
        assert_eq!(k.row(4).1, &[0.0; 6][..]);
        // Point 0 prescribed: one 3×3 block remains, the x stiffness 1/2.
        let held: Vec<Option<usize>> = [None, None, None, Some(0), Some(1), Some(2)].to_vec();
        let k = pair(None, &held, 3);
        assert_eq!(k.row(0), (&[0, 1, 2][..], &[0.5, 0.0, 0.0][..]));
    }

    #[test]
    fn a_broken_bond_contributes_nothing() {
        let all: Vec<Option<usize>> = (0..6).map(Some).collect();
        let k = pair(Some(&[1.0, 1.0]), &all, 6);
        assert!(k.values.iter().all(|&v| v == 0.0), "{:?}", k.values);
    }

    #[test]
    fn pmb_micromodulus_is_18k_over_pi_delta_to_the_fourth() {
        let c = pmb_micromodulus(std::f64::consts::PI, 1.0);
        assert!((c - 18.0).abs() < 1e-14);
    }
}
