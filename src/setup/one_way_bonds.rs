//! One-way bonds: a bond i → j whose reverse j → i does not exist, because the horizons of i
//! and j differ (blocks of different `Horizon`, or a horizon given as an expression of
//! position) and |ξ| lies between them.
//!
//! Peridigm keeps such bonds and applies each directed bond's force to both ends. peridyn's
//! force kernels gather every pair from both ends instead (`F_i = Σ_j (t_ij + t_ji) V_j M_ij`,
//! the module docs of `crate::material`), which holds only when every bond has its reverse:
//! with a one-way bond the body's momentum is not kept (a free bar of two blocks, horizons
//! 0.5025 and 0.8, pushed at one end: over 510 Verlet steps its momentum wandered between 0.4
//! and 1.3 times the initial one), and the tangent has no reverse block to assemble. Until the kernels carry directed bonds, a deck whose families
//! hold a one-way bond is refused at the `Horizon` that reaches too far, before anything runs,
//! on one rank and on N ranks alike.

use rayon::prelude::*;

use crate::io::deck::{Deck, DeckError};
use crate::model::{BondList, Model};

/// The first bond i → j of `model` (i taken from `points` in order, j in i's row) whose
/// reverse is not in j's row: i, and the bond's index in `model.bonds`. Every j bonded from a point of `points` must have its row in
/// the model (a rank's owned points and ghosts: a ghost's row keeps its bonds to the rank's
/// points).
///
/// Only bonds whose ends differ in block or horizon are looked up: the neighbour rules are
/// symmetric in the two ends for one horizon (|X_j − X_i|² is the same number both ways, the
/// lattice box and the bond filters test the segment), so within a block of one horizon every
/// bond has its reverse. The rows looked into are sorted once, so the check costs
/// O(bonds + looked-into rows · log family) however large and unsorted the families are.
pub fn first_one_way_bond(model: &Model, points: &[u32]) -> Option<(u32, usize)> {
    first_in(&model.bonds, &model.points.block, &model.horizon, points)
}

/// [`first_one_way_bond`] of `bonds` whose points have blocks `block` and horizons `horizon`.
fn first_in(
    bonds: &BondList,
    block: &[u32],
    horizon: &[f64],
    points: &[u32],
) -> Option<(u32, usize)> {
    let looked_up = |i: usize, j: usize| block[j] != block[i] || horizon[j] != horizon[i];
    let mut targets: Vec<u32> = points
        .par_iter()
        .flat_map_iter(|&i| {
            let i = i as usize;
            bonds
                .family(i)
                .iter()
                .copied()
                .filter(move |&j| looked_up(i, j as usize))
        })
        .collect();
    if targets.is_empty() {
        return None;
    }
    targets.par_sort_unstable();
    targets.dedup();
    let sorted: Vec<Vec<u32>> = targets
        .par_iter()
        .map(|&j| {
            let mut row = bonds.family(j as usize).to_vec();
            row.sort_unstable();
            row
        })
        .collect();
    // `targets` holds every j looked up below, each with its sorted row.
    let bonds_back = |j: u32, i: u32| {
        targets
            .binary_search(&j)
            .is_ok_and(|k| sorted[k].binary_search(&i).is_ok())
    };
    points.par_iter().find_map_first(|&i| {
        bonds
            .range(i as usize)
            .find(|&b| {
                let j = bonds.neighbor[b];
                looked_up(i as usize, j as usize) && !bonds_back(j, i)
            })
            .map(|b| (i, b))
    })
}

/// The refusal of the one-way bond `bond` (index in `model.bonds`) of point `i`, at the
/// `Horizon` of i's block: the horizon that reaches j when j's does not reach back.
pub fn refusal(deck: &Deck, model: &Model, (i, bond): (u32, usize)) -> DeckError {
    let (i, j) = (i as usize, model.bonds.neighbor[bond] as usize);
    let distance = model.bonds.reference_length[bond];
    let block_of = |p: usize| &model.blocks[model.points.block[p] as usize];
    let (from, to) = (block_of(i), block_of(j));
    let entry = &deck.blocks[from.deck_block].name;
    let point = |p: usize| {
        format!(
            "point {} of block \"{}\" (horizon {:e})",
            model.points.original_id[p] + 1,
            block_of(p).info.name,
            model.horizon[p]
        )
    };
    let advice = if from.deck_block == to.deck_block {
        "give the block one horizon (a number, not an expression of position)".to_string()
    } else {
        format!(
            "give the blocks \"{}\" and \"{}\" the same horizon, or set `Discretization → Omit Bonds Between Blocks: \"All\"`",
            from.info.name, to.info.name
        )
    };
    deck.error_at(
        &["Blocks", entry, "Horizon"],
        format!(
            "{} bonds to {} at distance {distance:e}, which does not bond back: peridyn's force kernels need every bond to have its reverse (horizons that differ between bonded points are not supported yet); {advice}",
            point(i),
            point(j)
        ),
    )
}

/// Refuses a model (one process, every family built) with a one-way bond.
pub fn refuse_one_way_bonds(deck: &Deck, model: &Model) -> Result<(), DeckError> {
    let all: Vec<u32> = (0..model.points.len() as u32).collect();
    match first_one_way_bond(model, &all) {
        Some(bond) => Err(refusal(deck, model, bond)),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rows of 3 points on a line, spacing 1: 0 ↔ 1, and 2 → 1 one-way (2's horizon reaches
    /// 1, 1's does not reach 2).
    fn bonds_with_one_way() -> BondList {
        BondList {
            offsets: vec![0, 1, 2, 3],
            neighbor: vec![1, 0, 1],
            reference_length: vec![1.0, 1.0, 1.0],
        }
    }

    #[test]
    fn a_bond_without_its_reverse_is_found_from_the_point_that_holds_it() {
        let bonds = bonds_with_one_way();
        let (block, horizon) = ([0, 0, 0], [1.5, 1.5, 2.5]);
        let one_way = |points: &[u32]| {
            first_in(&bonds, &block, &horizon, points).map(|(i, b)| (i, bonds.neighbor[b]))
        };
        assert_eq!(one_way(&[0, 1, 2]), Some((2, 1)));
        // Point 1's only bond (to 0) has its reverse; point 2 is not searched.
        assert_eq!(one_way(&[0, 1]), None);
    }

    #[test]
    fn symmetric_families_in_any_row_order_have_no_one_way_bond() {
        // 0 ↔ 1, 0 ↔ 2, 1 ↔ 2, rows unsorted.
        let bonds = BondList {
            offsets: vec![0, 2, 4, 6],
            neighbor: vec![2, 1, 2, 0, 1, 0],
            reference_length: vec![2.0, 1.0, 1.0, 1.0, 1.0, 2.0],
        };
        // Every bond is looked up: the points lie in different blocks.
        assert_eq!(first_in(&bonds, &[0, 1, 2], &[2.0; 3], &[0, 1, 2]), None);
    }
}
