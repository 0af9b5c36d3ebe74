//! What is simulated: the immutable description of the body after setup.
//!
//! [`Model`] is that description for a run (built by `setup::build` from a deck); it does not
//! change while the run goes on: everything that evolves is in [`crate::state::State`].
//! A [`PointCloud`] holds the material points (structure of arrays), [`BlockInfo`] names the
//! blocks the points belong to, [`NodeSets`] maps deck/mesh node-set names to point indices,
//! and [`BondList`] holds every point's family in compressed-sparse-row form.

mod bond_filters;
mod bonds;
mod declaration;
mod node_sets;
pub(crate) mod point_chunks;
mod points;
pub mod quadrature;
pub mod surface_correction;
#[cfg(test)]
pub(crate) mod test_support;
mod views;

pub(crate) use bond_filters::read_bond_filter;
pub use bond_filters::{BondFilter, BondFilterShape};
pub use bonds::BondList;
pub use declaration::{
    FieldCarrier, FieldDeclaration, KeyDoc, ModelDeclaration, Reach, TangentSupport,
};
pub use node_sets::{normalize_name, NodeSets};
pub use points::{BlockInfo, PointCloud};
pub(crate) use views::with_volume_rule;
pub use views::{
    BondVolumes, CurrentView, FullVolume, PerBondVolume, ReferenceView, VolumeRule, VolumeRules,
};

use crate::boundary::BoundaryConditions;

/// One mesh block with the deck settings that apply to it.
#[derive(Debug, Clone)]
pub struct ModelBlock {
    /// Mesh id and `block_<id>` name.
    pub info: BlockInfo,
    /// Index into `deck.blocks` of the entry that covers this block.
    pub deck_block: usize,
    /// Points of this block (run order, ascending).
    pub points: Vec<u32>,
}

/// The immutable description of a run.
#[derive(Debug, Clone)]
pub struct Model {
    /// Points in run order (sorted along a space-filling curve).
    pub points: PointCloud,
    /// Horizon δ of every point (run order).
    pub horizon: Vec<f64>,
    /// Mesh blocks; `points.block` indexes this list.
    pub blocks: Vec<ModelBlock>,
    /// Node sets from the deck and the mesh (run order).
    pub node_sets: NodeSets,
    /// Names of the node sets that came from the mesh (for reporting).
    pub mesh_node_set_names: Vec<String>,
    /// Families (directed bonds, run order).
    pub bonds: BondList,
    /// `run_index[k]` = run index of the point with original id k.
    pub run_index: Vec<u32>,
    /// Boundary and initial conditions with compiled expressions.
    pub boundary: BoundaryConditions,
    /// Smallest element radius (3V/4π)^(1/3).
    pub min_element_radius: f64,
}
