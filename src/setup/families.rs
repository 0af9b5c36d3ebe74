//! Building the bond list for each kind of discretization.

use super::SetupError;
use crate::discretization::{read_shell_faces, FamilyRule};
use crate::io::deck::{BondFilterShape, Deck, OmitBonds};
use crate::model::{BondList, PointCloud};
use crate::neighbors::{
    try_find_families, try_find_families_of, BondFilter, Disk, FamilySearch, NeighborhoodRule,
    RectangularPlane, TriangleMesh,
};

/// The deck's `Discretization → Bond Filters` as geometry.
fn bond_filters(deck: &Deck) -> Result<Vec<BondFilter>, SetupError> {
    deck.discretization
        .bond_filters
        .iter()
        .map(|filter| {
            let key = ["Discretization", "Bond Filters", filter.name.as_str()];
            build_bond_filter(deck, &key, filter)
        })
        .collect()
}

/// One bond filter of the deck as geometry; `key` is the path of its list, for messages. An
/// `Exodus Mesh` filter reads its shell mesh here (quadrilaterals become two triangles).
pub(super) fn build_bond_filter(
    deck: &Deck,
    key: &[&str],
    filter: &crate::io::deck::BondFilter,
) -> Result<BondFilter, SetupError> {
    let built = match &filter.shape {
        BondFilterShape::RectangularPlane {
            normal,
            lower_left_corner,
            bottom_unit_vector,
            bottom_length,
            side_length,
        } => RectangularPlane::new(
            *normal,
            *lower_left_corner,
            *bottom_unit_vector,
            *bottom_length,
            *side_length,
        )
        .map(BondFilter::RectangularPlane),
        BondFilterShape::Disk {
            center,
            normal,
            radius,
        } => Disk::new(*center, *normal, *radius).map(BondFilter::Disk),
        BondFilterShape::ExodusMesh { file_name } => {
            let file_key: Vec<&str> = key.iter().copied().chain(["File Name"]).collect();
            let faces =
                read_shell_faces(file_name).map_err(|e| deck.error_at(&file_key, e.to_string()))?;
            TriangleMesh::new(&faces).map(BondFilter::TriangleMesh)
        }
    };
    Ok(built.map_err(|e| deck.error_at(key, e.to_string()))?)
}

/// Families in run order. `order[new] = old` and `run_index[old] = new` relate run order to the
/// generator's order (needed by the cylinder, whose families are built in index space).
pub(super) fn build(
    deck: &Deck,
    rule: &FamilyRule,
    points: &PointCloud,
    horizon: &[f64],
    order: &[u32],
    run_index: &[u32],
) -> Result<BondList, SetupError> {
    let search_rule = match rule {
        FamilyRule::Search(search_rule) => *search_rule,
        FamilyRule::Cylinder { grid, spherical } => {
            let generated = grid.families(horizon[0], *spherical);
            return Ok(renumber(
                &generated.offsets,
                &generated.neighbor,
                points,
                order,
                run_index,
            ));
        }
    };
    search_rows(deck, search_rule, points, horizon, None)
}

/// The families of `rows` alone (see [`super::family_rows`]).
pub(super) fn rows(
    deck: &Deck,
    rule: NeighborhoodRule,
    points: &PointCloud,
    horizon: &[f64],
    rows: &[u32],
) -> Result<BondList, SetupError> {
    search_rows(deck, rule, points, horizon, Some(rows))
}

/// The searched families of `rows`, or of every point.
fn search_rows(
    deck: &Deck,
    rule: NeighborhoodRule,
    points: &PointCloud,
    horizon: &[f64],
    rows: Option<&[u32]>,
) -> Result<BondList, SetupError> {
    let filters = bond_filters(deck)?;
    let search = FamilySearch {
        positions: &points.position,
        horizons: horizon,
        blocks: &points.block,
        rule,
        omit_bonds_between_blocks: deck.discretization.omit_bonds_between_blocks == OmitBonds::All,
        filters: &filters,
    };
    match rows {
        None => try_find_families(&search),
        Some(rows) => try_find_families_of(&search, rows),
    }
    .map_err(|e| deck.error_at(&["Discretization"], e.to_string()).into())
}

/// Converts families given in generator order to run order, rows sorted.
fn renumber(
    offsets: &[usize],
    neighbor: &[u32],
    points: &PointCloud,
    order: &[u32],
    run_index: &[u32],
) -> BondList {
    let mut bonds = BondList {
        offsets: Vec::with_capacity(offsets.len()),
        neighbor: Vec::with_capacity(neighbor.len()),
        reference_length: Vec::with_capacity(neighbor.len()),
    };
    bonds.offsets.push(0);
    for (new, &old) in order.iter().enumerate() {
        let start = bonds.neighbor.len();
        let old = old as usize;
        bonds.neighbor.extend(
            neighbor[offsets[old]..offsets[old + 1]]
                .iter()
                .map(|&j| run_index[j as usize]),
        );
        bonds.neighbor[start..].sort_unstable();
        let x = points.position[new];
        for k in start..bonds.neighbor.len() {
            let y = points.position[bonds.neighbor[k] as usize];
            let length =
                ((y[0] - x[0]).powi(2) + (y[1] - x[1]).powi(2) + (y[2] - x[2]).powi(2)).sqrt();
            bonds.reference_length.push(length);
        }
        bonds.offsets.push(bonds.neighbor.len());
    }
    bonds
}
