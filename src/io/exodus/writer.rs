//! Writing Exodus II results files in Peridigm's layout.

use std::collections::HashSet;
use std::fs::File;
use std::path::{Path, PathBuf};

use super::netcdf::{
    encode, AttrValue, Attribute, Dimension, Header, NcError, NcFormat, NcType, NcWriter, Variable,
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
    /// Per block and element variable: whether the block has its values.
    block_defines: Vec<Vec<bool>>,
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

    /// A variable without attributes.
    fn plain(&mut self, name: impl Into<String>, dims: Vec<usize>, nc_type: NcType) {
        self.var(name.into(), dims, nc_type, Vec::new());
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

/// The dimensions of an Exodus file, by index into the header's dimension list; `None` where
/// the entity is absent (netCDF-3 cannot have zero-length fixed dimensions).
struct Dims {
    time: usize,
    name: usize,
    num_dim: usize,
    nodes: usize,
    elem: Option<usize>,
    blocks: Option<usize>,
    node_sets: Option<usize>,
    /// Per node set: its length dimension, for sets with nodes.
    node_set_len: Vec<Option<usize>>,
    /// Per block: its element count and nodes-per-element dimensions, for non-empty blocks.
    block_len: Vec<Option<(usize, usize)>>,
    global_vars: Option<usize>,
    nodal_vars: Option<usize>,
    element_vars: Option<usize>,
}

impl HeaderBuilder {
    /// An Offset64 header with the global attributes of an Exodus results file.
    fn new(layout: &OutputLayout, name_len: usize) -> Self {
        let title = truncate(&layout.title, LEN_LINE as usize - 1);
        Self::with_attributes([
            attr("int64_status", AttrValue::Ints(vec![0])),
            attr("title", AttrValue::Text(title.into())),
            attr(
                "maximum_name_length",
                AttrValue::Ints(vec![name_len as i32]),
            ),
        ])
    }

    /// An empty Offset64 header whose global attributes are the Exodus version and word sizes
    /// followed by `more`.
    fn with_attributes(more: impl IntoIterator<Item = Attribute>) -> Self {
        let mut attrs = vec![
            attr("api_version", AttrValue::Floats(vec![EXODUS_VERSION])),
            attr("version", AttrValue::Floats(vec![EXODUS_VERSION])),
            attr("floating_point_word_size", AttrValue::Ints(vec![8])),
            attr("file_size", AttrValue::Ints(vec![1])),
        ];
        attrs.extend(more);
        HeaderBuilder {
            header: Header {
                format: NcFormat::Offset64,
                numrecs: 0,
                dims: Vec::new(),
                attrs,
                vars: Vec::new(),
            },
        }
    }

    /// Declares the dimensions, in the order the Exodus API writes them.
    fn dimensions(&mut self, layout: &OutputLayout, name_len: usize) -> Dims {
        let num_elem: usize = layout.blocks.iter().map(|b| b.nodes.len()).sum();
        self.dim("len_string", LEN_STRING);
        self.dim("len_line", LEN_LINE);
        self.dim("four", 4);
        let time = self.dim("time_step", 0);
        let name = self.dim("len_name", name_len as u64 + 1);
        let num_dim = self.dim("num_dim", 3);
        let nodes = self.dim("num_nodes", layout.coordinates.len() as u64);
        let elem = (num_elem > 0).then(|| self.dim("num_elem", num_elem as u64));
        let blocks =
            (!layout.blocks.is_empty()).then(|| self.dim("num_el_blk", layout.blocks.len() as u64));
        let node_sets = (!layout.node_sets.is_empty())
            .then(|| self.dim("num_node_sets", layout.node_sets.len() as u64));
        let mut node_set_len = vec![None; layout.node_sets.len()];
        for k in sets_with_nodes(layout) {
            node_set_len[k] = Some(self.dim(
                &format!("num_nod_ns{}", k + 1),
                layout.node_sets[k].nodes.len() as u64,
            ));
        }
        let mut block_len = vec![None; layout.blocks.len()];
        for (i, block) in layout.blocks.iter().enumerate() {
            if !block.nodes.is_empty() {
                let n = self.dim(&format!("num_el_in_blk{}", i + 1), block.nodes.len() as u64);
                let per = self.dim(&format!("num_nod_per_el{}", i + 1), 1);
                block_len[i] = Some((n, per));
            }
        }
        let global_vars = (!layout.global_variables.is_empty())
            .then(|| self.dim("num_glo_var", layout.global_variables.len() as u64));
        let nodal_vars = (!layout.nodal_variables.is_empty())
            .then(|| self.dim("num_nod_var", layout.nodal_variables.len() as u64));
        let element_vars = (!layout.element_variables.is_empty() && blocks.is_some())
            .then(|| self.dim("num_elem_var", layout.element_variables.len() as u64));
        Dims {
            time,
            name,
            num_dim,
            nodes,
            elem,
            blocks,
            node_sets,
            node_set_len,
            block_len,
            global_vars,
            nodal_vars,
            element_vars,
        }
    }

    /// Declares the variables of the mesh (times, entity status and ids, coordinates, names,
    /// node sets, connectivity and maps), in the order the Exodus API writes them.
    fn mesh_variables(&mut self, d: &Dims) {
        let id_attr = || vec![attr("name", AttrValue::Text(b"ID".to_vec()))];
        self.plain("time_whole", vec![d.time], NcType::Double);
        if let Some(blocks) = d.blocks {
            self.plain("eb_status", vec![blocks], NcType::Int);
            self.var("eb_prop1".into(), vec![blocks], NcType::Int, id_attr());
        }
        if let Some(sets) = d.node_sets {
            self.plain("ns_status", vec![sets], NcType::Int);
            self.var("ns_prop1".into(), vec![sets], NcType::Int, id_attr());
        }
        for axis in ["coordx", "coordy", "coordz"] {
            self.plain(axis, vec![d.nodes], NcType::Double);
        }
        if let Some(blocks) = d.blocks {
            self.plain("eb_names", vec![blocks, d.name], NcType::Char);
        }
        if let Some(sets) = d.node_sets {
            self.plain("ns_names", vec![sets, d.name], NcType::Char);
        }
        self.plain("coor_names", vec![d.num_dim, d.name], NcType::Char);
        for (k, len) in d.node_set_len.iter().enumerate() {
            if let Some(len) = *len {
                self.plain(format!("node_ns{}", k + 1), vec![len], NcType::Int);
            }
        }
        for (i, len) in d.block_len.iter().enumerate() {
            if let Some((n, per)) = *len {
                let elem_type = vec![attr("elem_type", AttrValue::Text(b"SPHERE".to_vec()))];
                self.var(
                    format!("connect{}", i + 1),
                    vec![n, per],
                    NcType::Int,
                    elem_type,
                );
            }
        }
        self.plain("node_num_map", vec![d.nodes], NcType::Int);
        if let Some(elem) = d.elem {
            self.plain("elem_num_map", vec![elem], NcType::Int);
        }
    }

    /// Declares the result variables (global, nodal, element per block) and their names.
    fn result_variables(&mut self, layout: &OutputLayout, d: &Dims) {
        if let Some(glo) = d.global_vars {
            self.plain("name_glo_var", vec![glo, d.name], NcType::Char);
            self.plain("vals_glo_var", vec![d.time, glo], NcType::Double);
        }
        for k in 0..layout.nodal_variables.len() {
            self.plain(
                format!("vals_nod_var{}", k + 1),
                vec![d.time, d.nodes],
                NcType::Double,
            );
        }
        if let Some(nod) = d.nodal_vars {
            self.plain("name_nod_var", vec![nod, d.name], NcType::Char);
        }
        if let Some(d_var) = d.element_vars {
            self.plain("name_elem_var", vec![d_var, d.name], NcType::Char);
            for (i, len) in d.block_len.iter().enumerate() {
                if let Some((n, _)) = *len {
                    for (k, name) in layout.element_variables.iter().enumerate() {
                        if !layout.blocks[i].defines(name) {
                            continue;
                        }
                        self.plain(
                            format!("vals_elem_var{}eb{}", k + 1, i + 1),
                            vec![d.time, n],
                            NcType::Double,
                        );
                    }
                }
            }
            self.plain(
                "elem_var_tab",
                vec![d.blocks.expect("element variables need blocks"), d_var],
                NcType::Int,
            );
        }
    }
}

/// The length of the longest name in the file, at least Exodus' default width.
fn name_length(layout: &OutputLayout) -> usize {
    layout
        .blocks
        .iter()
        .map(|b| b.name.len())
        .chain(layout.node_sets.iter().map(|s| s.name.len()))
        .chain(layout.nodal_variables.iter().map(String::len))
        .chain(layout.element_variables.iter().map(String::len))
        .chain(layout.global_variables.iter().map(String::len))
        .max()
        .unwrap_or(0)
        .max(DEFAULT_NAME_LEN)
}

/// The indices of the node sets that have nodes (empty ones are null entities).
fn sets_with_nodes(layout: &OutputLayout) -> impl Iterator<Item = usize> + '_ {
    (0..layout.node_sets.len()).filter(|&k| !layout.node_sets[k].nodes.is_empty())
}

/// Writes the data of the fixed (not per-time-step) variables: the mesh, then the names of
/// the result variables and the element variable table.
fn write_fixed(
    nc: &mut NcWriter,
    layout: &OutputLayout,
    d: &Dims,
    width: usize,
) -> Result<(), NcError> {
    write_mesh(nc, layout, d, width)?;
    let mut put = |name: &str, data: Vec<u8>| nc.put_fixed(name, &data);
    if d.global_vars.is_some() {
        put(
            "name_glo_var",
            encode::names(&layout.global_variables, width),
        )?;
    }
    if d.nodal_vars.is_some() {
        put(
            "name_nod_var",
            encode::names(&layout.nodal_variables, width),
        )?;
    }
    if d.element_vars.is_some() {
        put(
            "name_elem_var",
            encode::names(&layout.element_variables, width),
        )?;
        let table = layout.blocks.iter().flat_map(|b| {
            layout
                .element_variables
                .iter()
                .map(|name| i32::from(b.defines(name)))
        });
        put("elem_var_tab", encode::ints(table))?;
    }
    Ok(())
}

/// Creates (truncating) `path` with `header` laid out and written, its fixed data zeroed.
fn create_file(path: &Path, header: Header) -> Result<NcWriter, ExodusError> {
    let file = File::create(path).map_err(|source| ExodusError::Io {
        path: path.to_path_buf(),
        action: "create",
        source,
    })?;
    NcWriter::create(file, header).map_err(|source| ExodusError::NetCdf {
        path: path.to_path_buf(),
        source,
    })
}

/// Writes `<prefix>_status` (1 for an entity with nodes), `<prefix>_prop1` (the ids) and
/// `<prefix>_names` of the blocks (`eb`) or node sets (`ns`), given as (nodes, id, name).
fn write_entities(
    nc: &mut NcWriter,
    prefix: &str,
    entities: Vec<(&[u32], i64, &str)>,
    width: usize,
) -> Result<(), NcError> {
    let status = entities.iter().map(|e| i32::from(!e.0.is_empty()));
    nc.put_fixed(&format!("{prefix}_status"), &encode::ints(status))?;
    let ids = entities.iter().map(|e| e.1 as i32);
    nc.put_fixed(&format!("{prefix}_prop1"), &encode::ints(ids))?;
    let names: Vec<String> = entities.iter().map(|e| e.2.to_string()).collect();
    nc.put_fixed(&format!("{prefix}_names"), &encode::names(&names, width))
}

/// Writes the mesh: block and node set status, ids and names, coordinates, node sets,
/// connectivity and the node and element maps.
fn write_mesh(
    nc: &mut NcWriter,
    layout: &OutputLayout,
    d: &Dims,
    width: usize,
) -> Result<(), NcError> {
    if d.blocks.is_some() {
        let blocks = layout.blocks.iter();
        let entities = blocks.map(|b| (&b.nodes[..], b.id, &b.name[..]));
        write_entities(nc, "eb", entities.collect(), width)?;
    }
    if d.node_sets.is_some() {
        let sets = layout.node_sets.iter();
        let entities = sets.map(|s| (&s.nodes[..], s.id, &s.name[..]));
        write_entities(nc, "ns", entities.collect(), width)?;
    }
    let mut put = |name: &str, data: Vec<u8>| nc.put_fixed(name, &data);
    for (axis, name) in ["coordx", "coordy", "coordz"].iter().enumerate() {
        put(
            name,
            encode::doubles(layout.coordinates.iter().map(|c| c[axis])),
        )?;
    }
    let axes = ["X".to_string(), "Y".to_string(), "Z".to_string()];
    put("coor_names", encode::names(&axes, width))?;
    for k in sets_with_nodes(layout) {
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
    if d.elem.is_some() {
        let ids = layout
            .blocks
            .iter()
            .flat_map(|b| b.nodes.iter().map(|&n| layout.node_ids[n as usize] as i32));
        put("elem_num_map", encode::ints(ids))?;
    }
    Ok(())
}

/// Writes a shell mesh: one element block (id 1) of faces of type `element_type` (`TRI3`,
/// `QUAD4`, `SHELL4`, …) with `nodes_per_face` nodes each, `connectivity` holding 0-based node
/// indices face by face. This is the file an `Exodus Mesh` bond filter reads (a crack surface,
/// e.g. made by a script rather than a mesher).
pub fn write_shell_mesh(
    path: &Path,
    coordinates: &[[f64; 3]],
    element_type: &str,
    nodes_per_face: usize,
    connectivity: &[u32],
) -> Result<(), ExodusError> {
    let bad = |problem: String| ExodusError::BadInput {
        path: path.to_path_buf(),
        problem,
    };
    if coordinates.is_empty() || nodes_per_face == 0 || connectivity.is_empty() {
        return Err(bad("a shell mesh needs nodes and at least one face".into()));
    }
    if connectivity.len() % nodes_per_face != 0 {
        return Err(bad(format!(
            "{} connectivity entries are not a whole number of {nodes_per_face}-node faces",
            connectivity.len()
        )));
    }
    if let Some(&node) = connectivity
        .iter()
        .find(|&&n| n as usize >= coordinates.len())
    {
        return Err(bad(format!(
            "face node {node} does not exist ({} nodes)",
            coordinates.len()
        )));
    }
    let faces = (connectivity.len() / nodes_per_face) as u64;
    let mut b =
        HeaderBuilder::with_attributes([attr("title", AttrValue::Text(b"shell mesh".to_vec()))]);
    b.dim("len_string", LEN_STRING);
    b.dim("len_line", LEN_LINE);
    b.dim("four", 4);
    let time = b.dim("time_step", 0);
    b.dim("len_name", DEFAULT_NAME_LEN as u64 + 1);
    b.dim("num_dim", 3);
    let nodes = b.dim("num_nodes", coordinates.len() as u64);
    b.dim("num_elem", faces);
    let blocks = b.dim("num_el_blk", 1);
    let in_block = b.dim("num_el_in_blk1", faces);
    let per = b.dim("num_nod_per_el1", nodes_per_face as u64);
    b.var("time_whole".into(), vec![time], NcType::Double, vec![]);
    b.var("eb_status".into(), vec![blocks], NcType::Int, vec![]);
    let id = vec![attr("name", AttrValue::Text(b"ID".to_vec()))];
    b.var("eb_prop1".into(), vec![blocks], NcType::Int, id);
    for axis in ["coordx", "coordy", "coordz"] {
        b.var(axis.into(), vec![nodes], NcType::Double, vec![]);
    }
    let kind = vec![attr(
        "elem_type",
        AttrValue::Text(element_type.as_bytes().to_vec()),
    )];
    b.var("connect1".into(), vec![in_block, per], NcType::Int, kind);
    let nc_err = |source: NcError| ExodusError::NetCdf {
        path: path.to_path_buf(),
        source,
    };
    let mut nc = create_file(path, b.header)?;
    let mut put = |name: &str, data: Vec<u8>| nc.put_fixed(name, &data).map_err(nc_err);
    put("eb_status", encode::ints([1]))?;
    put("eb_prop1", encode::ints([1]))?;
    for (axis, name) in ["coordx", "coordy", "coordz"].iter().enumerate() {
        put(name, encode::doubles(coordinates.iter().map(|c| c[axis])))?;
    }
    put(
        "connect1",
        encode::ints(connectivity.iter().map(|&n| n as i32 + 1)),
    )?;
    nc.finish().map_err(nc_err)
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
        validate(layout).map_err(bad)?;

        let name_len = name_length(layout);
        let mut b = HeaderBuilder::new(layout, name_len);
        let dims = b.dimensions(layout, name_len);
        b.mesh_variables(&dims);
        b.result_variables(layout, &dims);

        let mut nc = create_file(path, b.header)?;
        write_fixed(&mut nc, layout, &dims, name_len + 1).map_err(nc_err)?;

        Ok(ExodusWriter {
            path: path.to_path_buf(),
            nc,
            num_nodes: layout.coordinates.len(),
            block_nodes: layout.blocks.iter().map(|b| b.nodes.clone()).collect(),
            block_defines: layout
                .blocks
                .iter()
                .map(|b| {
                    let names = layout.element_variables.iter();
                    names.map(|name| b.defines(name)).collect()
                })
                .collect(),
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
        for (nodes, defines) in self.block_nodes.iter().zip(&self.block_defines) {
            for (field, _) in element.iter().zip(defines).filter(|(_, &d)| d) {
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

    /// Takes over the first `frames` frames of `previous`, an Exodus file with this writer's
    /// layout (the results file of an interrupted run being continued).
    pub fn adopt_frames(&mut self, previous: &Path, frames: u64) -> Result<(), ExodusError> {
        self.nc
            .adopt_records(previous, frames)
            .map_err(|source| ExodusError::NetCdf {
                path: previous.to_path_buf(),
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

/// Checks the blocks or node sets (`kind`) of a layout of `n` nodes, given as (id, the name
/// messages give it, nodes): ids distinct and 32-bit, nodes within range.
fn validate_groups<'a>(
    kind: &str,
    groups: impl Iterator<Item = (i64, String, &'a [u32])>,
    n: usize,
) -> Result<(), String> {
    let mut ids = HashSet::new();
    for (id, label, nodes) in groups {
        if !ids.insert(id) {
            return Err(format!("{kind} id {id} is used twice"));
        }
        if id < i64::from(i32::MIN) || id > i64::from(i32::MAX) {
            return Err(format!("{kind} id {id} does not fit in 32 bits"));
        }
        if let Some(k) = nodes.iter().find(|&&k| k as usize >= n) {
            return Err(format!(
                "{kind} {label} lists node {k} but there are {n} nodes"
            ));
        }
    }
    Ok(())
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
    let blocks = layout.blocks.iter();
    validate_groups(
        "block",
        blocks.map(|b| (b.id, b.id.to_string(), b.nodes.as_slice())),
        n,
    )?;
    let sets = layout.node_sets.iter();
    validate_groups(
        "node set",
        sets.map(|s| (s.id, format!("'{}'", s.name), s.nodes.as_slice())),
        n,
    )?;
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
