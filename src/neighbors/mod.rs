//! Neighbour search: every point's family (bonds), bond filters and point ordering.
//!
//! [`find_families`] turns positions, horizons and blocks into the CSR [`BondList`] with the
//! neighbour criterion of the discretization ([`NeighborhoodRule`]), Peridigm's
//! `Omit Bonds Between Blocks` and its bond filters ([`BondFilter`]).
//! [`space_filling_curve_order`] renumbers points for locality before the search.
//!
//! [`BondList`]: crate::model::BondList

mod bond_filter;
mod search;
mod space_filling_curve;

pub use bond_filter::{
    BondFilter, BondFilterError, Disk, RectangularPlane, Triangle, TriangleMesh, TRIANGLE_TOLERANCE,
};
pub use search::{
    find_families, find_families_with, try_find_families, try_find_families_of, FamilySearch,
    NeighborSearchError, NeighborhoodRule, SearchBackend, MAX_CELLS_PER_POINT,
};
pub use space_filling_curve::space_filling_curve_order;
