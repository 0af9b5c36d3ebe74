//! Geometry to points: QuickGrid generators, text files and Exodus meshes.
//!
//! Every discretization produces a [`Discretization`]: points in input order (their original
//! ids), the blocks they belong to, node sets the mesh defines, and the rule by which their
//! families are built ([`FamilyRule`]).

mod cylinder;
mod exodus_mesh;
mod node_set_file;
mod shell_mesh;
mod tensor_product;
mod text_file;

pub use cylinder::{CylinderGrid, IndexFamilies};
pub use exodus_mesh::{read_exodus_mesh, ExodusMesh};
pub use node_set_file::{parse_node_id, read_node_set_file, read_node_set_file_lines, NodeSetFile};
pub use shell_mesh::read_shell_faces;
pub use tensor_product::{cells_per_horizon, TensorProductGrid};
pub use text_file::{parse_text_mesh, read_text_mesh, TextMesh};

use crate::model::{BlockInfo, NodeSets, PointCloud};
use crate::neighbors::NeighborhoodRule;
use std::path::PathBuf;

/// How families are formed for a discretization.
#[derive(Debug, Clone, PartialEq)]
pub enum FamilyRule {
    /// A neighbour search over positions: the inclusive sphere |ξ|² ≤ δ² for Text File and
    /// Exodus meshes, Peridigm's box rule for the QuickGrid box (see [`NeighborhoodRule`]).
    Search(NeighborhoodRule),
    /// QuickGrid cylinder: families in (ring, ray, axial) index space.
    Cylinder {
        /// The generator, which also builds the families.
        grid: CylinderGrid,
        /// Strict spherical filter on top of the index window.
        spherical: bool,
    },
}

/// Points, blocks and mesh node sets as read or generated, before neighbour search.
#[derive(Debug, Clone, PartialEq)]
pub struct Discretization {
    /// Points in input order.
    pub points: PointCloud,
    /// Blocks; `points.block` indexes this list.
    pub blocks: Vec<BlockInfo>,
    /// Node sets the mesh itself defines (Exodus); point indices are input order.
    pub node_sets: NodeSets,
    /// How to build families.
    pub family_rule: FamilyRule,
}

impl Discretization {
    /// Smallest element radius `(3V/4π)^(1/3)` over all points (Peridigm's probe-length and
    /// search-radius scale).
    pub fn min_element_radius(&self) -> f64 {
        (0..self.points.len())
            .map(|i| self.points.radius(i))
            .fold(f64::INFINITY, f64::min)
    }
}

/// Problems reading or generating a discretization. Every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    /// The file could not be read.
    #[error("{}: cannot read: {source}. Check the path (relative paths are relative to the deck's folder).", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating-system error.
        source: std::io::Error,
    },
    /// A line of a text mesh or node-set file is malformed.
    #[error("{}:{line}: {message}", path.display())]
    Syntax {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// The file defines no points.
    #[error("{}: the mesh has no points", path.display())]
    Empty {
        /// The file.
        path: PathBuf,
    },
    /// An Exodus file could not be read (the message names the file).
    #[error(transparent)]
    ExodusFile(#[from] crate::io::exodus::ExodusError),
    /// An Exodus mesh could not be used.
    #[error("{}: {message}", path.display())]
    Exodus {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
}
