//! Writing Exodus II results files in Peridigm's layout.

use std::collections::HashSet;
use std::fs::File;
use std::path::{Path, PathBuf};

use super::netcdf::{
    encode, AttrValue, Attribute, Dimension, Header, NcFormat, NcType, NcWriter, Variable,
};
use super::{ExodusError, OutputLayout};

/// Exodus `len_string` and `len_line` (fixed by the Exodus API for QA/info records and titles).
const LEN_STRING: u64 = 33;
const LEN_LINE: u64 = 81;
/// Exodus' default name width is 32 characters (+ NUL); longer names widen `len_name` up to
/// the API's hard limit of 255 characters.
const DEFAULT_NAME_LEN: usize = 32;
const MAX_NAME_LEN: usize = 255;
/// The Exodus API version whose file layout we produce: the same entities and names as the
/// gold files of Peridigm's regression suite (written by Exodus 5.15–5.26).
const EXODUS_VERSION: f32 = 5.22;

/// Writes an Exodus II results file frame by frame.
///
/// The header, coordinates, blocks, node sets, maps and names are written by [`Self::create`];
/// [`Self::write_frame`] appends one time step and then updates the netCDF record count, so
/// the file is a complete, readable Exodus file after every frame even if the run dies later.
#[derive(Debug)]
pub struct ExodusWriter {
    path: PathBuf,
    nc: NcWriter,
    num_nodes: usize,
    /// Per block: node indices, for splitting element fields.
    block_nodes: Vec<Vec<u32>>,
    num_nodal: usize,
    num_element: usize,
    num_global: usize,
}

fn dim(name: impl Into<String>, len: u64) -> Dimension {
    Dimension {
        name: name.into(),
        len,
    }
}

struct HeaderBuilder {
    header: Header,
}

impl HeaderBuilder {
    fn dim(&mut self, name: &str, len: u64) -> usize {
        self.header.dims.push(dim(name, len));
        self.header.dims.len() - 1
    }

    fn var(&mut self, name: String, dims: Vec<usize>, nc_type: NcType, attrs: Vec<Attribute>) {
        self.header.vars.push(Variable {
            name,
            dims,
            attrs,
            nc_type,
            begin: 0,
        });
    }
}

impl ExodusWriter {
    /// Creates (truncating) `path` and writes everything that does not change over time.
    ///
    /// Empty blocks and node sets are written as Exodus "null" entities (status 0, no data),
    /// because netCDF-3 cannot have zero-length fixed dimensions.
    pub fn create(path: &Path, layout: &OutputLayout) -> Result<Self, ExodusError> {
        let bad = |problem: String| ExodusError::BadInput {
            path: path.to_path_buf(),
            problem,
        };
        let nc_err = |source| ExodusError::NetCdf {
            path: path.to_path_buf(),
            source,
        };
        let num_nodes = layout.coordinates.len();
        validate(layout).map_err(bad)?;

        let name_len = layout
            .blocks
            .iter()
            .map(|b| b.name.len())
            .chain(layout.node_sets.iter().map(|s| s.name.len()))
            .chain(layout.nodal_variables.iter().map(String::len))
            .chain(layout.element_variables.iter().map(String::len))
            .chain(layout.global_variables.iter().map(String::len))
            .max()
            .unwrap_or(0)
            .max(DEFAULT_NAME_LEN);
        let num_elem: usize = layout.blocks.iter().map(|b| b.nodes.len()).sum();
        let sets_with_nodes: Vec<usize> = (0..layout.node_sets.len())
            .filter(|&k| !layout.node_sets[k].nodes.is_empty())
            .collect();

        let mut b = HeaderBuilder {
            header: Header {
                format: NcFormat::Offset64,
                numrecs: 0,
                dims: Vec::new(),
                attrs: vec![
                    attr("api_version", AttrValue::Floats(vec![EXODUS_VERSION])),
                    attr("version", AttrValue::Floats(vec![EXODUS_VERSION])),
                    attr("floating_point_word_size", AttrValue::Ints(vec![8])),
                    attr("file_size", AttrValue::Ints(vec![1])),
                    attr("int64_status", AttrValue::Ints(vec![0])),
                    attr(
                        "title",
                        AttrValue::Text(truncate(&layout.title, LEN_LINE as usize - 1).into()),
                    ),
                    attr(
                        "maximum_name_length",
                        AttrValue::Ints(vec![name_len as i32]),
                    ),
                ],
                vars: Vec::new(),
            },
        };
        b.dim("len_string", LEN_STRING);
        b.dim("len_line", LEN_LINE);
        b.dim("four", 4);
        let d_time = b.dim("time_step", 0);
        let d_name = b.dim("len_name", name_len as u64 + 1);
        let d_num_dim = b.dim("num_dim", 3);
        let d_nodes = b.dim("num_nodes", num_nodes as u64);
        let d_elem = (num_elem > 0).then(|| b.dim("num_elem", num_elem as u64));
        let d_blk =
            (!layout.blocks.is_empty()).then(|| b.dim("num_el_blk", layout.blocks.len() as u64));
        let d_ns = (!layout.node_sets.is_empty())
            .then(|| b.dim("num_node_sets", layout.node_sets.len() as u64));
        let mut d_ns_len = vec![None; layout.node_sets.len()];
        for &k in &sets_with_nodes {
            d_ns_len[k] = Some(b.dim(
                &format!("num_nod_ns{}", k + 1),
                layout.node_sets[k].nodes.len() as u64,
            ));
        }
        let mut d_blk_len = vec![None; layout.blocks.len()];
        for (i, block) in layout.blocks.iter().enumerate() {
            if !block.nodes.is_empty() {
                let n = b.dim(&format!("num_el_in_blk{}", i + 1), block.nodes.len() as u64);
                let per = b.dim(&format!("num_nod_per_el{}", i + 1), 1);
                d_blk_len[i] = Some((n, per));
            }
        }
        let d_glo = (!layout.global_variables.is_empty())
            .then(|| b.dim("num_glo_var", layout.global_variables.len() as u64));
        let d_nod_var = (!layout.nodal_variables.is_empty())
            .then(|| b.dim("num_nod_var", layout.nodal_variables.len() as u64));
        let d_elem_var = (!layout.element_variables.is_empty() && d_blk.is_some())
            .then(|| b.dim("num_elem_var", layout.element_variables.len() as u64));

        let id_attr = || vec![attr("name", AttrValue::Text(b"ID".to_vec()))];
        b.var("time_whole".into(), vec![d_time], NcType::Double, vec![]);
        if let Some(d) = d_blk {
            b.var("eb_status".into(), vec![d], NcType::Int, vec![]);
            b.var("eb_prop1".into(), vec![d], NcType::Int, id_attr());
        }
        if let Some(d) = d_ns {
            b.var("ns_status".into(), vec![d], NcType::Int, vec![]);
            b.var("ns_prop1".into(), vec![d], NcType::Int, id_attr());
        }
        for axis in ["coordx", "coordy", "coordz"] {
            b.var(axis.into(), vec![d_nodes], NcType::Double, vec![]);
        }
        if let Some(d) = d_blk {
            b.var("eb_names".into(), vec![d, d_name], NcType::Char, vec![]);
        }
        if let Some(d) = d_ns {
            b.var("ns_names".into(), vec![d, d_name], NcType::Char, vec![]);
        }
        b.var(
            "coor_names".into(),
            vec![d_num_dim, d_name],
            NcType::Char,
            vec![],
        );
        for (k, d) in d_ns_len.iter().enumerate() {
            if let Some(d) = *d {
                b.var(format!("node_ns{}", k + 1), vec![d], NcType::Int, vec![]);
            }
        }
        for (i, d) in d_blk_len.iter().enumerate() {
            if let Some((n, per)) = *d {
                let elem_type = vec![attr("elem_type", AttrValue::Text(b"SPHERE".to_vec()))];
                b.var(
                    format!("connect{}", i + 1),
                    vec![n, per],
                    NcType::Int,
                    elem_type,
                );
            }
        }
        b.var("node_num_map".into(), vec![d_nodes], NcType::Int, vec![]);
        if let Some(d) = d_elem {
            b.var("elem_num_map".into(), vec![d], NcType::Int, vec![]);
        }
        if let Some(d) = d_glo {
            b.var("name_glo_var".into(), vec![d, d_name], NcType::Char, vec![]);
            b.var(
                "vals_glo_var".into(),
                vec![d_time, d],
                NcType::Double,
                vec![],
            );
        }
        for k in 0..layout.nodal_variables.len() {
            b.var(
                format!("vals_nod_var{}", k + 1),
                vec![d_time, d_nodes],
                NcType::Double,
                vec![],
            );
        }
        if let Some(d) = d_nod_var {
            b.var("name_nod_var".into(), vec![d, d_name], NcType::Char, vec![]);
        }
        if let Some(d_var) = d_elem_var {
            b.var(
                "name_elem_var".into(),
                vec![d_var, d_name],
                NcType::Char,
                vec![],
            );
            for (i, d) in d_blk_len.iter().enumerate() {
                if let Some((n, _)) = *d {
                    for k in 0..layout.element_variables.len() {
                        b.var(
                            format!("vals_elem_var{}eb{}", k + 1, i + 1),
                            vec![d_time, n],
                            NcType::Double,
                            vec![],
                        );
                    }
                }
            }
            b.var(
                "elem_var_tab".into(),
                vec![d_blk.expect("element variables need blocks"), d_var],
                NcType::Int,
                vec![],
            );
        }

        let file = File::create(path).map_err(|source| ExodusError::Io {
            path: path.to_path_buf(),
            action: "create",
            source,
        })?;
        let mut nc = NcWriter::create(file, b.header).map_err(nc_err)?;
        let width = name_len + 1;

        let mut put = |name: &str, data: Vec<u8>| nc.put_fixed(name, &data);
        let result = (|| {
            if d_blk.is_some() {
                let status = layout.blocks.iter().map(|b| i32::from(!b.nodes.is_empty()));
                put("eb_status", encode::ints(status))?;
                put(
                    "eb_prop1",
                    encode::ints(layout.blocks.iter().map(|b| b.id as i32)),
                )?;
                let names: Vec<String> = layout.blocks.iter().map(|b| b.name.clone()).collect();
                put("eb_names", encode::names(&names, width))?;
            }
            if d_ns.is_some() {
                let status = layout
                    .node_sets
                    .iter()
                    .map(|s| i32::from(!s.nodes.is_empty()));
                put("ns_status", encode::ints(status))?;
                put(
                    "ns_prop1",
                    encode::ints(layout.node_sets.iter().map(|s| s.id as i32)),
                )?;
                let names: Vec<String> = layout.node_sets.iter().map(|s| s.name.clone()).collect();
                put("ns_names", encode::names(&names, width))?;
            }
            for (axis, name) in ["coordx", "coordy", "coordz"].iter().enumerate() {
                put(
                    name,
                    encode::doubles(layout.coordinates.iter().map(|c| c[axis])),
                )?;
            }
            let axes = ["X".to_string(), "Y".to_string(), "Z".to_string()];
            put("coor_names", encode::names(&axes, width))?;
            for &k in &sets_with_nodes {
                let nodes = layout.node_sets[k].nodes.iter().map(|&n| n as i32 + 1);
                put(&format!("node_ns{}", k + 1), encode::ints(nodes))?;
            }
            for (i, block) in layout.blocks.iter().enumerate() {
                if !block.nodes.is_empty() {
                    let nodes = block.nodes.iter().map(|&n| n as i32 + 1);
                    put(&format!("connect{}", i + 1), encode::ints(nodes))?;
                }
            }
            put(
                "node_num_map",
                encode::ints(layout.node_ids.iter().map(|&id| id as i32)),
            )?;
            if d_elem.is_some() {
                let ids = layout
                    .blocks
                    .iter()
                    .flat_map(|b| b.nodes.iter().map(|&n| layout.node_ids[n as usize] as i32));
                put("elem_num_map", encode::ints(ids))?;
            }
            if d_glo.is_some() {
                put(
                    "name_glo_var",
                    encode::names(&layout.global_variables, width),
                )?;
            }
            if d_nod_var.is_some() {
                put(
                    "name_nod_var",
                    encode::names(&layout.nodal_variables, width),
                )?;
            }
            if d_elem_var.is_some() {
                put(
                    "name_elem_var",
                    encode::names(&layout.element_variables, width),
                )?;
                let table = layout.blocks.iter().flat_map(|b| {
                    let defined = i32::from(!b.nodes.is_empty());
                    std::iter::repeat_n(defined, layout.element_variables.len())
                });
                put("elem_var_tab", encode::ints(table))?;
            }
            Ok(())
        })();
        result.map_err(nc_err)?;

        Ok(ExodusWriter {
            path: path.to_path_buf(),
            nc,
            num_nodes,
            block_nodes: layout.blocks.iter().map(|b| b.nodes.clone()).collect(),
            num_nodal: layout.nodal_variables.len(),
            num_element: layout.element_variables.len(),
            num_global: layout.global_variables.len(),
        })
    }

    /// Appends one time step.
    ///
    /// `nodal[v][node]` and `element[v][node]` are indexed by node (the writer splits element
    /// fields per block); `global[v]` holds one value per global variable. After the data the
    /// record count in the header is updated, so the file stays valid if a later frame fails.
    pub fn write_frame(
        &mut self,
        time: f64,
        nodal: &[&[f64]],
        element: &[&[f64]],
        global: &[f64],
    ) -> Result<(), ExodusError> {
        let bad = |problem: String| ExodusError::BadInput {
            path: self.path.clone(),
            problem,
        };
        if nodal.len() != self.num_nodal {
            return Err(bad(format!(
                "{} nodal fields given, the layout declares {}",
                nodal.len(),
                self.num_nodal
            )));
        }
        if element.len() != self.num_element {
            return Err(bad(format!(
                "{} element fields given, the layout declares {}",
                element.len(),
                self.num_element
            )));
        }
        if global.len() != self.num_global {
            return Err(bad(format!(
                "{} global values given, the layout declares {}",
                global.len(),
                self.num_global
            )));
        }
        for (kind, fields) in [("nodal", nodal), ("element", element)] {
            if let Some((v, f)) = fields
                .iter()
                .enumerate()
                .find(|(_, f)| f.len() != self.num_nodes)
            {
                return Err(bad(format!(
                    "{kind} field {v} has {} values, expected one per node ({})",
                    f.len(),
                    self.num_nodes
                )));
            }
        }
        // Slabs in header order: time_whole, vals_glo_var, vals_nod_var*, vals_elem_var*eb*.
        let mut slabs = vec![encode::doubles([time])];
        if self.num_global > 0 {
            slabs.push(encode::doubles(global.iter().copied()));
        }
        for field in nodal {
            slabs.push(encode::doubles(field.iter().copied()));
        }
        for nodes in self.block_nodes.iter().filter(|n| !n.is_empty()) {
            for field in element {
                slabs.push(encode::doubles(nodes.iter().map(|&n| field[n as usize])));
            }
        }
        self.nc
            .append_record(&slabs)
            .map_err(|source| ExodusError::NetCdf {
                path: self.path.clone(),
                source,
            })
    }

    /// Number of frames (time steps) written so far.
    pub fn frames_written(&self) -> usize {
        self.nc.numrecs() as usize
    }

    /// Flushes the file to disk. Dropping the writer without calling this still leaves a valid
    /// file with every completed frame; `finish` additionally reports late I/O errors.
    pub fn finish(self) -> Result<(), ExodusError> {
        let path = self.path;
        self.nc
            .finish()
            .map_err(|source| ExodusError::NetCdf { path, source })
    }
}

fn attr(name: &str, value: AttrValue) -> Attribute {
    Attribute {
        name: name.to_string(),
        value,
    }
}

fn truncate(text: &str, max: usize) -> &str {
    if text.len() <= max {
        return text;
    }
    let mut end = max;
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    &text[..end]
}

/// Checks the layout; the message says what to fix.
fn validate(layout: &OutputLayout) -> Result<(), String> {
    let n = layout.coordinates.len();
    if n == 0 {
        return Err("the layout has no nodes (points)".to_string());
    }
    if n > i32::MAX as usize {
        return Err(format!("{n} nodes exceed the 32-bit Exodus index range"));
    }
    if layout.node_ids.len() != n {
        return Err(format!(
            "{} node ids for {n} coordinates",
            layout.node_ids.len()
        ));
    }
    if let Some(id) = layout
        .node_ids
        .iter()
        .find(|&&id| id < 1 || id > i64::from(i32::MAX))
    {
        return Err(format!("node id {id} is outside 1..=2147483647"));
    }
    let in_range = |nodes: &[u32]| nodes.iter().find(|&&k| k as usize >= n).copied();
    let mut ids = HashSet::new();
    for block in &layout.blocks {
        if !ids.insert(block.id) {
            return Err(format!("block id {} is used twice", block.id));
        }
        if block.id < i64::from(i32::MIN) || block.id > i64::from(i32::MAX) {
            return Err(format!("block id {} does not fit in 32 bits", block.id));
        }
        if let Some(k) = in_range(&block.nodes) {
            return Err(format!(
                "block {} lists node {k} but there are {n} nodes",
                block.id
            ));
        }
    }
    let mut ids = HashSet::new();
    for set in &layout.node_sets {
        if !ids.insert(set.id) {
            return Err(format!("node set id {} is used twice", set.id));
        }
        if set.id < i64::from(i32::MIN) || set.id > i64::from(i32::MAX) {
            return Err(format!("node set id {} does not fit in 32 bits", set.id));
        }
        if let Some(k) = in_range(&set.nodes) {
            return Err(format!(
                "node set '{}' lists node {k} but there are {n} nodes",
                set.name
            ));
        }
    }
    for (kind, names) in [
        ("nodal", &layout.nodal_variables),
        ("element", &layout.element_variables),
        ("global", &layout.global_variables),
    ] {
        let mut seen = HashSet::new();
        for name in names {
            if name.is_empty() {
                return Err(format!("a {kind} variable has an empty name"));
            }
            if !seen.insert(name.as_str()) {
                return Err(format!("{kind} variable '{name}' is listed twice"));
            }
        }
    }
    let names = layout
        .blocks
        .iter()
        .map(|b| &b.name)
        .chain(layout.node_sets.iter().map(|s| &s.name))
        .chain(&layout.nodal_variables)
        .chain(&layout.element_variables)
        .chain(&layout.global_variables);
    for name in names {
        if name.len() > MAX_NAME_LEN {
            return Err(format!(
                "name '{name}' is {} bytes long; Exodus allows at most {MAX_NAME_LEN}",
                name.len()
            ));
        }
        if name.contains('\0') {
            return Err(format!("name {name:?} contains a NUL character"));
        }
    }
    Ok(())
}
