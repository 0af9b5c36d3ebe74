//! Exodus II files: reading meshes and results, writing results, comparing results.
//!
//! Exodus II is a data model on top of netCDF. Peridigm's meshes (`*.g`) and results (`*.e`,
//! `*.h`) are netCDF-3 "64-bit offset" files; [`netcdf`] implements that container in pure
//! Rust so the default build needs no C library. The Exodus layer maps the model onto it:
//!
//! * nodes: `coordx/y/z` (`num_nodes`), ids in `node_num_map` (1-based);
//! * element blocks: `connect<b>` (`num_el_in_blk<b>` × `num_nod_per_el<b>`, attribute
//!   `elem_type`), ids in `eb_prop1`, names in `eb_names`, attributes in `attrib<b>`;
//! * node sets: `node_ns<k>` (1-based node indices), ids in `ns_prop1`, names in `ns_names`;
//! * results per time step (`time_whole` along the unlimited `time_step` dimension):
//!   `vals_nod_var<k>`, `vals_elem_var<k>eb<b>` (only where `elem_var_tab` says defined) and
//!   `vals_glo_var`, with names in `name_nod_var`, `name_elem_var`, `name_glo_var`.
//!
//! Peridigm writes one `SPHERE` element per point, vector fields as nodal variables
//! (`DisplacementX/Y/Z`) and scalar point fields as element variables; [`ExodusWriter`]
//! produces the same layout from an [`OutputLayout`].

pub mod compare;
pub mod netcdf;
mod reader;
mod writer;

use std::path::PathBuf;

use thiserror::Error;

pub use compare::{compare, compare_from, ComparisonReport, ComparisonSpec};
pub use reader::{ElementBlock, ExodusFile, NodeSetData};
pub use writer::{write_shell_mesh, ExodusWriter};

/// Errors while reading, writing or comparing Exodus files. Every variant names the file.
#[derive(Debug, Error)]
pub enum ExodusError {
    /// The netCDF container is unreadable (not netCDF, truncated, malformed, I/O failure).
    #[error("{path}: {source}")]
    NetCdf {
        /// The file.
        path: PathBuf,
        /// What the netCDF layer found.
        source: netcdf::NcError,
    },
    /// The file could not be opened or created.
    #[error("{path}: cannot {action}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// "open", "create", …
        action: &'static str,
        /// The operating system error.
        source: std::io::Error,
    },
    /// The netCDF file is fine but the Exodus content is inconsistent.
    #[error("{path}: invalid Exodus data: {problem}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        problem: String,
    },
    /// A request does not fit the file (step, variable or block index out of range).
    #[error("{path}: {problem}")]
    OutOfRange {
        /// The file.
        path: PathBuf,
        /// What was asked and what exists.
        problem: String,
    },
    /// Data handed to the writer does not match the layout.
    #[error("{path}: cannot write: {problem}")]
    BadInput {
        /// The file being written.
        path: PathBuf,
        /// What does not match.
        problem: String,
    },
    /// An exodiff command (`.comp`) file could not be parsed.
    #[error("{path}:{line}: {problem}")]
    CommandFile {
        /// The command file (or `<text>` when parsed from a string).
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What is wrong and what was expected.
        problem: String,
    },
}

/// One element block of a results file: one `SPHERE` element per listed point.
#[derive(Debug, Clone, PartialEq)]
pub struct OutputBlock {
    /// Exodus block id (`eb_prop1`), e.g. 1 for Peridigm's `block_1`.
    pub id: i64,
    /// Block name (`eb_names`), e.g. `block_1`; may be empty.
    pub name: String,
    /// 0-based indices of the points (nodes) in this block, in output order.
    pub nodes: Vec<u32>,
    /// Element variables of the layout not defined on this block (its truth-table entries are
    /// 0 and it has no values of them), e.g. `Lambda` on a block whose material has none.
    pub undefined: Vec<String>,
}

/// One node set of a results file.
#[derive(Debug, Clone, PartialEq)]
pub struct OutputNodeSet {
    /// Exodus node set id (`ns_prop1`).
    pub id: i64,
    /// Node set name (`ns_names`).
    pub name: String,
    /// 0-based node indices.
    pub nodes: Vec<u32>,
}

impl OutputBlock {
    /// True when element variable `name` has values on this block.
    pub fn defines(&self, name: &str) -> bool {
        !self.nodes.is_empty() && !self.undefined.iter().any(|u| u == name)
    }
}

/// Everything about a results file that does not change between frames.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct OutputLayout {
    /// Exodus title (at most 80 characters are kept, the `len_line` limit).
    pub title: String,
    /// Reference coordinates of node k; nodes are points in the user's original order.
    pub coordinates: Vec<[f64; 3]>,
    /// Global ids written to `node_num_map` and (per element, via its node) `elem_num_map`;
    /// 1-based, must fit in 32 bits.
    pub node_ids: Vec<i64>,
    /// Element blocks; one `SPHERE` element per listed node.
    pub blocks: Vec<OutputBlock>,
    /// Node sets.
    pub node_sets: Vec<OutputNodeSet>,
    /// Nodal variable names (`name_nod_var`), e.g. `DisplacementX`.
    pub nodal_variables: Vec<String>,
    /// Element variable names (`name_elem_var`), defined on every non-empty block except
    /// where [`OutputBlock::undefined`] lists them.
    pub element_variables: Vec<String>,
    /// Global variable names (`name_glo_var`).
    pub global_variables: Vec<String>,
}

#[cfg(test)]
mod tests;
