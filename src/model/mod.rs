//! What is simulated: the immutable description of the body after setup.
//!
//! A [`PointCloud`] holds the material points (structure of arrays), [`BlockInfo`] names the
//! blocks the points belong to, [`NodeSets`] maps deck/mesh node-set names to point indices,
//! and [`BondList`] holds every point's family in compressed-sparse-row form.

mod bonds;
mod declaration;
mod node_sets;
mod points;

pub use bonds::BondList;
pub use declaration::{FieldCarrier, FieldDeclaration, ModelDeclaration, Reach};
pub use node_sets::{normalize_name, NodeSets};
pub use points::{BlockInfo, PointCloud};
