//! Reading Exodus II meshes and results.

use std::fs::File;
use std::path::{Path, PathBuf};

use super::netcdf::{NcError, NcReader};
use super::ExodusError;

/// An element block as stored in the file.
#[derive(Debug, Clone, PartialEq)]
pub struct ElementBlock {
    /// Block id (`eb_prop1`).
    pub id: i64,
    /// Block name (`eb_names`), `""` if the file has none.
    pub name: String,
    /// Element type in upper case (`HEX8`, `TETRA`, `SPHERE`, …); `""` for a null block.
    pub element_type: String,
    /// Nodes per element.
    pub nodes_per_element: usize,
    /// Connectivity, flattened element by element, 0-based node indices.
    pub connectivity: Vec<u32>,
    /// Element attributes (`attrib<b>`), flattened element by element (for Peridigm's SPHERE
    /// meshes: radius, volume).
    pub attributes: Vec<f64>,
    /// Attributes per element (0 if none).
    pub attributes_per_element: usize,
    /// Attribute names (`attrib_name<b>`), empty if the file has none.
    pub attribute_names: Vec<String>,
}

impl ElementBlock {
    /// Number of elements in the block.
    pub fn num_elements(&self) -> usize {
        self.connectivity
            .len()
            .checked_div(self.nodes_per_element)
            .unwrap_or(0)
    }
}

/// A node set as stored in the file.
#[derive(Debug, Clone, PartialEq)]
pub struct NodeSetData {
    /// Node set id (`ns_prop1`).
    pub id: i64,
    /// Exodus name, or `nodelist_<id>` if the file has none (Peridigm's naming rule).
    pub name: String,
    /// 0-based node indices in file order.
    pub nodes: Vec<u32>,
}

/// An open Exodus II file: the mesh is read eagerly, results on demand.
#[derive(Debug)]
pub struct ExodusFile {
    /// The file this was read from.
    pub path: PathBuf,
    /// Title (global attribute `title`).
    pub title: String,
    /// Spatial dimension (`num_dim`).
    pub dimension: usize,
    /// Node coordinates; missing components (`num_dim` < 3) are 0.
    pub coordinates: Vec<[f64; 3]>,
    /// Global node ids (`node_num_map`, or 1..=n without one).
    pub node_ids: Vec<i64>,
    /// Global element ids (`elem_num_map`/`elem_map`, or 1..=n without one).
    pub element_ids: Vec<i64>,
    /// Element blocks in file order.
    pub blocks: Vec<ElementBlock>,
    /// Node sets in file order.
    pub node_sets: Vec<NodeSetData>,
    /// Time of every stored step (`time_whole`).
    pub times: Vec<f64>,
    /// Nodal variable names.
    pub nodal_variable_names: Vec<String>,
    /// Element variable names.
    pub element_variable_names: Vec<String>,
    /// Global variable names.
    pub global_variable_names: Vec<String>,
    /// `elem_var_tab[block][variable]`: whether the variable exists on the block.
    pub element_variable_defined: Vec<Vec<bool>>,
    nc: NcReader,
    /// Frames of this file itself; later steps come from `continuations`.
    own_steps: usize,
    /// Files whose frames continue this one (see [`ExodusFile::open_conjoined`]).
    continuations: Vec<ExodusFile>,
}

impl ExodusFile {
    /// Opens `path` and reads the mesh, the names and the times.
    pub fn open(path: &Path) -> Result<Self, ExodusError> {
        let file = File::open(path).map_err(|source| ExodusError::Io {
            path: path.to_path_buf(),
            action: "open",
            source,
        })?;
        let nc = NcReader::open(file).map_err(|source| ExodusError::NetCdf {
            path: path.to_path_buf(),
            source,
        })?;
        Loader { path, nc }.load()
    }

    /// Opens several results files of one run as one time series, like SEACAS `conjoin`:
    /// the mesh and variable names are the first file's, the frames are those of every file
    /// in order. Peridigm's regression tests compare a run that wrote one file per solver
    /// against a single conjoined gold file this way. The files must have the same nodes and
    /// the same variables.
    pub fn open_conjoined(paths: &[&Path]) -> Result<Self, ExodusError> {
        let (first, rest) = paths.split_first().ok_or_else(|| ExodusError::BadInput {
            path: PathBuf::new(),
            problem: "no file to open".into(),
        })?;
        let mut file = Self::open(first)?;
        for path in rest {
            let next = Self::open(path)?;
            let same = next.coordinates.len() == file.coordinates.len()
                && next.nodal_variable_names == file.nodal_variable_names
                && next.element_variable_names == file.element_variable_names
                && next.global_variable_names == file.global_variable_names;
            if !same {
                return Err(ExodusError::BadInput {
                    path: path.to_path_buf(),
                    problem: format!(
                        "cannot continue {}: the nodes or variable names differ",
                        file.path.display()
                    ),
                });
            }
            file.times.extend_from_slice(&next.times);
            file.continuations.push(next);
        }
        Ok(file)
    }

    /// The file holding `step` and the step within it, when it is a continuation.
    fn continuation(&self, step: usize) -> Option<(&ExodusFile, usize)> {
        let mut local = step.checked_sub(self.own_steps)?;
        for next in &self.continuations {
            if local < next.own_steps {
                return Some((next, local));
            }
            local -= next.own_steps;
        }
        None
    }

    fn nc_err(&self, source: NcError) -> ExodusError {
        ExodusError::NetCdf {
            path: self.path.clone(),
            source,
        }
    }

    fn out_of_range(&self, problem: String) -> ExodusError {
        ExodusError::OutOfRange {
            path: self.path.clone(),
            problem,
        }
    }

    fn check_step(&self, step: usize) -> Result<(), ExodusError> {
        if step >= self.times.len() {
            return Err(self.out_of_range(format!(
                "time step {step} requested but the file has {} steps (0-based)",
                self.times.len()
            )));
        }
        Ok(())
    }

    /// Values of nodal variable `variable` (index into `nodal_variable_names`) at `step`
    /// (0-based), one per node.
    pub fn nodal_values(&self, step: usize, variable: usize) -> Result<Vec<f64>, ExodusError> {
        self.check_step(step)?;
        if let Some((file, local)) = self.continuation(step) {
            return file.nodal_values(local, variable);
        }
        let count = self.nodal_variable_names.len();
        if variable >= count {
            return Err(self.out_of_range(format!(
                "nodal variable {variable} requested but the file has {count}"
            )));
        }
        let name = format!("vals_nod_var{}", variable + 1);
        if self.nc.header.var(&name).is_some() {
            return self.nc.f64s(&name, Some(step)).map_err(|e| self.nc_err(e));
        }
        // Old Exodus files store all nodal variables in one `vals_nod_var[time][var][node]`.
        let all = self
            .nc
            .f64s("vals_nod_var", Some(step))
            .map_err(|_| self.nc_err(NcError::MissingVariable(name)))?;
        let n = self.coordinates.len();
        all.get(variable * n..(variable + 1) * n)
            .map(<[f64]>::to_vec)
            .ok_or_else(|| ExodusError::Invalid {
                path: self.path.clone(),
                problem: "vals_nod_var is smaller than num_nod_var × num_nodes".to_string(),
            })
    }

    /// Values of element variable `variable` on block `block` (index into `blocks`) at `step`,
    /// one per element of the block; `None` where `elem_var_tab` marks it undefined.
    pub fn element_values(
        &self,
        step: usize,
        variable: usize,
        block: usize,
    ) -> Result<Option<Vec<f64>>, ExodusError> {
        self.check_step(step)?;
        if let Some((file, local)) = self.continuation(step) {
            return file.element_values(local, variable, block);
        }
        let count = self.element_variable_names.len();
        if variable >= count {
            return Err(self.out_of_range(format!(
                "element variable {variable} requested but the file has {count}"
            )));
        }
        if block >= self.blocks.len() {
            return Err(self.out_of_range(format!(
                "block {block} requested but the file has {} blocks",
                self.blocks.len()
            )));
        }
        if !self.element_variable_defined[block][variable] {
            return Ok(None);
        }
        let name = format!("vals_elem_var{}eb{}", variable + 1, block + 1);
        let values = self
            .nc
            .f64s(&name, Some(step))
            .map_err(|e| self.nc_err(e))?;
        Ok(Some(values))
    }

    /// Values of all global variables at `step`.
    pub fn global_values(&self, step: usize) -> Result<Vec<f64>, ExodusError> {
        self.check_step(step)?;
        if let Some((file, local)) = self.continuation(step) {
            return file.global_values(local);
        }
        if self.global_variable_names.is_empty() {
            return Ok(Vec::new());
        }
        self.nc
            .f64s("vals_glo_var", Some(step))
            .map_err(|e| self.nc_err(e))
    }

    /// Number of elements over all blocks.
    pub fn num_elements(&self) -> usize {
        self.blocks.iter().map(ElementBlock::num_elements).sum()
    }

    /// Index of the nodal variable with this name (exact match).
    pub fn nodal_variable_index(&self, name: &str) -> Option<usize> {
        self.nodal_variable_names.iter().position(|n| n == name)
    }

    /// Index of the element variable with this name (exact match).
    pub fn element_variable_index(&self, name: &str) -> Option<usize> {
        self.element_variable_names.iter().position(|n| n == name)
    }
}

struct Loader<'a> {
    path: &'a Path,
    nc: NcReader,
}

impl Loader<'_> {
    fn nc_err(&self, source: NcError) -> ExodusError {
        ExodusError::NetCdf {
            path: self.path.to_path_buf(),
            source,
        }
    }

    fn invalid(&self, problem: String) -> ExodusError {
        ExodusError::Invalid {
            path: self.path.to_path_buf(),
            problem,
        }
    }

    fn dim(&self, name: &str) -> usize {
        self.nc.header.dim_len(name).unwrap_or(0) as usize
    }

    fn has(&self, name: &str) -> bool {
        self.nc.header.var(name).is_some()
    }

    fn f64s(&self, name: &str) -> Result<Vec<f64>, ExodusError> {
        self.nc.f64s(name, None).map_err(|e| self.nc_err(e))
    }

    fn i64s(&self, name: &str) -> Result<Vec<i64>, ExodusError> {
        self.nc.i64s(name).map_err(|e| self.nc_err(e))
    }

    fn names(&self, var: &str, count: usize) -> Result<Vec<String>, ExodusError> {
        if count == 0 {
            return Ok(Vec::new());
        }
        if !self.has(var) {
            return Ok(vec![String::new(); count]);
        }
        let names = self.nc.strings(var).map_err(|e| self.nc_err(e))?;
        if names.len() != count {
            return Err(self.invalid(format!("{var} has {} names, expected {count}", names.len())));
        }
        Ok(names)
    }

    fn with_len<T>(&self, values: Vec<T>, len: usize, var: &str) -> Result<Vec<T>, ExodusError> {
        if values.len() != len {
            return Err(self.invalid(format!(
                "{var} has {} entries, expected {len}",
                values.len()
            )));
        }
        Ok(values)
    }

    /// 1-based node numbers → 0-based indices, rejecting anything outside 1..=num_nodes.
    fn node_indices(
        &self,
        raw: Vec<i64>,
        num_nodes: usize,
        var: &str,
    ) -> Result<Vec<u32>, ExodusError> {
        raw.into_iter()
            .map(|k| {
                if k < 1 || k as usize > num_nodes {
                    Err(self.invalid(format!("{var} refers to node {k}, outside 1..={num_nodes}")))
                } else {
                    Ok((k - 1) as u32)
                }
            })
            .collect()
    }

    fn ids(&self, var: &str, count: usize) -> Result<Vec<i64>, ExodusError> {
        if self.has(var) {
            self.with_len(self.i64s(var)?, count, var)
        } else {
            Ok((1..=count as i64).collect())
        }
    }

    fn load(self) -> Result<ExodusFile, ExodusError> {
        let title = self
            .nc
            .header
            .attr("title")
            .and_then(|a| a.as_text())
            .unwrap_or_default();
        let dimension = self.dim("num_dim");
        if !(1..=3).contains(&dimension) {
            return Err(self.invalid(format!("num_dim is {dimension}, expected 1, 2 or 3")));
        }
        let num_nodes = self.dim("num_nodes");
        let coordinates = self.coordinates(dimension, num_nodes)?;
        let node_ids = self.ids("node_num_map", num_nodes)?;
        let num_elem = self.dim("num_elem");
        let element_ids = if self.has("elem_num_map") {
            self.ids("elem_num_map", num_elem)?
        } else {
            self.ids("elem_map", num_elem)?
        };
        let blocks = self.blocks(num_nodes)?;
        let total: usize = blocks.iter().map(ElementBlock::num_elements).sum();
        if total != num_elem {
            return Err(self.invalid(format!(
                "blocks hold {total} elements but num_elem is {num_elem}"
            )));
        }
        let node_sets = self.node_sets(num_nodes)?;
        let times = self.times()?;
        let nodal_variable_names = self.names("name_nod_var", self.dim("num_nod_var"))?;
        let element_variable_names = self.names("name_elem_var", self.dim("num_elem_var"))?;
        let global_variable_names = self.names("name_glo_var", self.dim("num_glo_var"))?;
        let element_variable_defined =
            self.element_variable_table(blocks.len(), element_variable_names.len())?;

        let Loader { path, nc } = self;
        let own_steps = times.len();
        Ok(ExodusFile {
            path: path.to_path_buf(),
            title,
            dimension,
            coordinates,
            node_ids,
            element_ids,
            blocks,
            node_sets,
            times,
            nodal_variable_names,
            element_variable_names,
            global_variable_names,
            element_variable_defined,
            own_steps,
            continuations: Vec::new(),
            nc,
        })
    }

    /// Node coordinates, from `coordx`/`coordy`/`coordz` or the old single `coord` array;
    /// missing components are 0.
    fn coordinates(
        &self,
        dimension: usize,
        num_nodes: usize,
    ) -> Result<Vec<[f64; 3]>, ExodusError> {
        let mut coordinates = vec![[0.0; 3]; num_nodes];
        if num_nodes == 0 {
            return Ok(coordinates);
        }
        if self.has("coordx") {
            for (axis, var) in ["coordx", "coordy", "coordz"]
                .iter()
                .take(dimension)
                .enumerate()
            {
                let values = self.with_len(self.f64s(var)?, num_nodes, var)?;
                for (c, v) in coordinates.iter_mut().zip(values) {
                    c[axis] = v;
                }
            }
        } else {
            // Old layout: one `coord[num_dim][num_nodes]` array.
            let all = self.with_len(self.f64s("coord")?, dimension * num_nodes, "coord")?;
            for axis in 0..dimension {
                for (k, c) in coordinates.iter_mut().enumerate() {
                    c[axis] = all[axis * num_nodes + k];
                }
            }
        }
        Ok(coordinates)
    }

    /// The element blocks in file order.
    fn blocks(&self, num_nodes: usize) -> Result<Vec<ElementBlock>, ExodusError> {
        let num_blocks = self.dim("num_el_blk");
        let block_ids = self.ids("eb_prop1", num_blocks)?;
        let block_names = self.names("eb_names", num_blocks)?;
        let mut blocks = Vec::with_capacity(num_blocks);
        for (b, (id, name)) in block_ids.into_iter().zip(block_names).enumerate() {
            blocks.push(self.block(b, id, name, num_nodes)?);
        }
        Ok(blocks)
    }

    /// Element block `b` (0-based): connectivity, type and attributes.
    fn block(
        &self,
        b: usize,
        id: i64,
        name: String,
        num_nodes: usize,
    ) -> Result<ElementBlock, ExodusError> {
        let connect = format!("connect{}", b + 1);
        let n_elem = self.dim(&format!("num_el_in_blk{}", b + 1));
        let per = self.dim(&format!("num_nod_per_el{}", b + 1));
        let (element_type, connectivity) = match self.nc.header.var(&connect) {
            Some(var) if n_elem > 0 => {
                let element_type = var
                    .attrs
                    .iter()
                    .find(|a| a.name == "elem_type")
                    .and_then(|a| a.value.as_text())
                    .unwrap_or_default()
                    .to_uppercase();
                let raw = self.with_len(self.i64s(&connect)?, n_elem * per, &connect)?;
                (element_type, self.node_indices(raw, num_nodes, &connect)?)
            }
            _ => (String::new(), Vec::new()),
        };
        let n_attr = self.dim(&format!("num_att_in_blk{}", b + 1));
        let attrib = format!("attrib{}", b + 1);
        let attributes = if n_attr > 0 && self.has(&attrib) {
            self.with_len(self.f64s(&attrib)?, n_elem * n_attr, &attrib)?
        } else {
            Vec::new()
        };
        let attribute_names = if n_attr > 0 {
            self.names(&format!("attrib_name{}", b + 1), n_attr)?
        } else {
            Vec::new()
        };
        Ok(ElementBlock {
            id,
            name,
            element_type,
            nodes_per_element: if connectivity.is_empty() {
                per.max(1)
            } else {
                per
            },
            connectivity,
            attributes_per_element: if attributes.is_empty() { 0 } else { n_attr },
            attributes,
            attribute_names,
        })
    }

    /// The node sets in file order, named `nodelist_<id>` where the file has no name.
    fn node_sets(&self, num_nodes: usize) -> Result<Vec<NodeSetData>, ExodusError> {
        let num_sets = self.dim("num_node_sets");
        let set_ids = self.ids("ns_prop1", num_sets)?;
        let set_names = self.names("ns_names", num_sets)?;
        let mut node_sets = Vec::with_capacity(num_sets);
        for (k, (id, name)) in set_ids.into_iter().zip(set_names).enumerate() {
            let var = format!("node_ns{}", k + 1);
            let nodes = if self.has(&var) {
                self.node_indices(self.i64s(&var)?, num_nodes, &var)?
            } else {
                Vec::new()
            };
            let name = if name.is_empty() {
                format!("nodelist_{id}")
            } else {
                name
            };
            node_sets.push(NodeSetData { id, name, nodes });
        }
        Ok(node_sets)
    }

    /// The time of every stored step.
    fn times(&self) -> Result<Vec<f64>, ExodusError> {
        let numrecs = self.nc.header.numrecs;
        if !(self.has("time_whole") && numrecs > 0) {
            return Ok(Vec::new());
        }
        (0..numrecs as usize)
            .map(|r| {
                self.nc
                    .f64s("time_whole", Some(r))
                    .map(|v| v.first().copied().unwrap_or(f64::NAN))
                    .map_err(|e| self.nc_err(e))
            })
            .collect()
    }

    /// `elem_var_tab[block][variable]`, or without a table the variables that have values
    /// on each block.
    fn element_variable_table(
        &self,
        num_blocks: usize,
        n_evar: usize,
    ) -> Result<Vec<Vec<bool>>, ExodusError> {
        if n_evar == 0 {
            Ok(vec![Vec::new(); num_blocks])
        } else if self.has("elem_var_tab") {
            let table = self.with_len(
                self.i64s("elem_var_tab")?,
                num_blocks * n_evar,
                "elem_var_tab",
            )?;
            Ok(table
                .chunks(n_evar)
                .map(|row| row.iter().map(|&t| t != 0).collect())
                .collect())
        } else {
            // Without a truth table Exodus defines every variable on every non-empty block.
            Ok((0..num_blocks)
                .map(|b| {
                    (0..n_evar)
                        .map(|v| self.has(&format!("vals_elem_var{}eb{}", v + 1, b + 1)))
                        .collect()
                })
                .collect())
        }
    }
}
