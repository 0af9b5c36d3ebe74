//! What is simulated: the immutable description of the body after setup.
//!
//! A [`PointCloud`] holds the material points (structure of arrays), [`BlockInfo`] names the
//! blocks the points belong to, [`NodeSets`] maps deck/mesh node-set names to point indices,
//! and [`BondList`] holds every point's family in compressed-sparse-row form.

mod bonds;
mod declaration;
mod node_sets;
pub(crate) mod point_chunks;
mod points;
#[cfg(test)]
pub(crate) mod test_support;
mod views;

pub use bonds::BondList;
pub use declaration::{FieldCarrier, FieldDeclaration, ModelDeclaration, Reach};
pub use node_sets::{normalize_name, NodeSets};
pub use points::{BlockInfo, PointCloud};
pub use views::{CurrentView, ReferenceView};
