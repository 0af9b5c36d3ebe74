//! Results output: which variables a deck may request, and writing them to Exodus and CSV.
//!
//! Peridigm's conventions: vector point fields are nodal variables written as `NameX/Y/Z`,
//! scalar point fields are element variables (one SPHERE element per point), tensors are
//! element variables `NameXX … NameZZ`, and globals are global variables. An output list
//! that requests only globals writes `<Output Filename>.h`, otherwise `<Output Filename>.e`;
//! globals also go to `<Output Filename>.csv`. Frames are written when
//! `(call − 1) % frequency == 0`, where call 1 is the initial state and every explicit step
//! or accepted load step is one call (Peridigm's `Peridigm_OutputManager_ExodusII.cpp`).

use crate::io::exodus::{ExodusError, ExodusWriter, OutputBlock, OutputLayout, OutputNodeSet};
use crate::io::history::{HistoryError, HistoryWriter};
use std::borrow::Cow;
use std::path::{Path, PathBuf};

/// How a requested variable is stored in the results file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VariableKind {
    /// Point vector → nodal variables `NameX`, `NameY`, `NameZ`.
    NodalVector,
    /// Point scalar → one element variable.
    ElementScalar,
    /// Point 3×3 tensor → element variables `NameXX` … `NameZZ` (row-major).
    ElementTensor,
    /// One number per frame → one global variable.
    Global,
    /// Three numbers per frame → global variables `NameX`, `NameY`, `NameZ`.
    GlobalVector,
}

/// Peridigm's output names and how each is stored. Names requested through compute-class
/// parameters (`Block_Data`, `Node_Set_Data`, `Nearest_Point_Data`) are globals named by
/// their `Output Label` and are not in this table.
pub const CATALOG: &[(&str, VariableKind)] = &[
    ("Displacement", VariableKind::NodalVector),
    ("Velocity", VariableKind::NodalVector),
    ("Acceleration", VariableKind::NodalVector),
    ("Force", VariableKind::NodalVector),
    ("Force_Density", VariableKind::NodalVector),
    ("Contact_Force", VariableKind::NodalVector),
    ("Contact_Force_Density", VariableKind::NodalVector),
    ("External_Force_Density", VariableKind::NodalVector),
    ("Coordinates", VariableKind::NodalVector),
    ("Model_Coordinates", VariableKind::NodalVector),
    ("Linear_Momentum", VariableKind::NodalVector),
    ("Angular_Momentum", VariableKind::NodalVector),
    ("Hourglass_Force_Density", VariableKind::NodalVector),
    ("Volume", VariableKind::ElementScalar),
    ("Radius", VariableKind::ElementScalar),
    ("Horizon", VariableKind::ElementScalar),
    ("Element_Id", VariableKind::ElementScalar),
    ("Block_Id", VariableKind::ElementScalar),
    ("Proc_Num", VariableKind::ElementScalar),
    ("Number_Of_Neighbors", VariableKind::ElementScalar),
    ("Dilatation", VariableKind::ElementScalar),
    ("Weighted_Volume", VariableKind::ElementScalar),
    ("Damage", VariableKind::ElementScalar),
    ("Kinetic_Energy", VariableKind::ElementScalar),
    ("Stored_Elastic_Energy", VariableKind::ElementScalar),
    ("Stored_Elastic_Energy_Density", VariableKind::ElementScalar),
    ("Lambda", VariableKind::ElementScalar),
    ("Temperature", VariableKind::ElementScalar),
    ("Temperature_Change", VariableKind::ElementScalar),
    ("Surface_Correction_Factor", VariableKind::ElementScalar),
    ("Critical_Stretch", VariableKind::ElementScalar),
    ("Von_Mises_Stress", VariableKind::ElementScalar),
    ("Equivalent_Plastic_Strain", VariableKind::ElementScalar),
    ("Deformation_Gradient", VariableKind::ElementTensor),
    ("Shape_Tensor_Inverse", VariableKind::ElementTensor),
    ("Partial_Stress", VariableKind::ElementTensor),
    ("Cauchy_Stress", VariableKind::ElementTensor),
    ("Unrotated_Cauchy_Stress", VariableKind::ElementTensor),
    ("Green_Lagrange_Strain", VariableKind::ElementTensor),
    ("Neighborhood_Volume", VariableKind::ElementScalar),
    ("Undamaged_Weighted_Volume", VariableKind::ElementScalar),
    ("Normalized_Weighted_Volume", VariableKind::ElementScalar),
    ("Dilatation_Normalization", VariableKind::ElementScalar),
    ("Deviatoric_Normalization", VariableKind::ElementScalar),
    (
        "Lagrange_Multiplier_Dilatation_1",
        VariableKind::ElementScalar,
    ),
    (
        "Lagrange_Multiplier_Dilatation_2",
        VariableKind::ElementScalar,
    ),
    (
        "Lagrange_Multiplier_Dilatation_3",
        VariableKind::ElementScalar,
    ),
    (
        "Lagrange_Multiplier_Dilatation_4",
        VariableKind::ElementScalar,
    ),
    (
        "Lagrange_Multiplier_Dilatation_5",
        VariableKind::ElementScalar,
    ),
    (
        "Lagrange_Multiplier_Dilatation_6",
        VariableKind::ElementScalar,
    ),
    (
        "Lagrange_Multiplier_Deviatoric_1",
        VariableKind::ElementScalar,
    ),
    (
        "Lagrange_Multiplier_Deviatoric_2",
        VariableKind::ElementScalar,
    ),
    (
        "Lagrange_Multiplier_Deviatoric_3",
        VariableKind::ElementScalar,
    ),
    (
        "Lagrange_Multiplier_Deviatoric_4",
        VariableKind::ElementScalar,
    ),
    (
        "Lagrange_Multiplier_Deviatoric_5",
        VariableKind::ElementScalar,
    ),
    (
        "Lagrange_Multiplier_Deviatoric_6",
        VariableKind::ElementScalar,
    ),
    ("Pals_Pressure", VariableKind::ElementScalar),
    ("Jacobian_Determinant", VariableKind::ElementScalar),
    ("Stress_Triaxiality", VariableKind::ElementScalar),
    ("Broken_Bond_Volume_Averaged", VariableKind::ElementScalar),
    ("Flying_Point_Flag", VariableKind::ElementScalar),
    ("Concentration", VariableKind::ElementScalar),
    ("Flux_Divergence", VariableKind::ElementScalar),
    ("Flux_Density", VariableKind::ElementScalar),
    ("Fluid_Pressure_U", VariableKind::ElementScalar),
    ("Fluid_Pressure_Y", VariableKind::ElementScalar),
    ("Fluid_Pressure_V", VariableKind::ElementScalar),
    ("Left_Stretch_Tensor", VariableKind::ElementTensor),
    ("Rotation_Tensor", VariableKind::ElementTensor),
    ("Unrotated_Rate_Of_Deformation", VariableKind::ElementTensor),
    ("Velocity_Gradient", VariableKind::ElementTensor),
    ("Global_Kinetic_Energy", VariableKind::Global),
    ("Global_Stored_Elastic_Energy", VariableKind::Global),
    ("Global_Linear_Momentum", VariableKind::GlobalVector),
    ("Global_Angular_Momentum", VariableKind::GlobalVector),
    ("Nonlinear_Solver_Iterations", VariableKind::Global),
];

/// The kind of a catalogue name (exact spelling, as Peridigm requires).
pub fn kind_of(name: &str) -> Option<VariableKind> {
    CATALOG.iter().find(|(n, _)| *n == name).map(|&(_, k)| k)
}

/// The catalogue name closest to `name`, for "did you mean" hints.
pub fn closest_name(name: &str) -> Option<&'static str> {
    CATALOG
        .iter()
        .map(|(n, _)| {
            (
                strsim::jaro_winkler(&n.to_lowercase(), &name.to_lowercase()),
                *n,
            )
        })
        .filter(|(score, _)| *score > 0.8)
        .max_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, n)| n)
}

/// One requested variable with its storage kind.
#[derive(Debug, Clone, PartialEq)]
pub struct RequestedVariable {
    /// Name as requested (catalogue name or compute-class label).
    pub name: String,
    /// Storage.
    pub kind: VariableKind,
}

/// What a simulation can report at output time. Point fields are in run order; the writer
/// reorders them to the user's original order.
pub trait FieldSource {
    /// A point vector field, or `None` if this run does not have it.
    fn vector(&self, name: &str) -> Option<Cow<'_, [[f64; 3]]>>;
    /// A point scalar field.
    fn scalar(&self, name: &str) -> Option<Cow<'_, [f64]>>;
    /// A point tensor field (row-major 3×3).
    fn tensor(&self, name: &str) -> Option<Cow<'_, [[f64; 9]]>>;
    /// A global value (including compute-class labels).
    fn global(&self, name: &str) -> Option<f64>;
    /// A global vector.
    fn global_vector(&self, name: &str) -> Option<[f64; 3]>;
}

/// Errors while writing results.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// The Exodus file failed.
    #[error(transparent)]
    Exodus(#[from] ExodusError),
    /// The CSV history failed.
    #[error(transparent)]
    History(#[from] HistoryError),
    /// The run has no values for a requested variable (a bug in the run plan).
    #[error("{file}: the run has no values for output variable {name}")]
    Missing {
        /// File being written.
        file: String,
        /// Variable name.
        name: String,
    },
}

impl OutputError {
    /// True when the operating system refused a write (or the read of a continued run's
    /// previous file): a full disk, a quota or file-size limit, a vanished folder; false for
    /// a results layout that does not fit the data.
    pub fn is_write_failure(&self) -> bool {
        use crate::io::exodus::netcdf::NcError;
        matches!(
            self,
            OutputError::Exodus(
                ExodusError::Io { .. }
                    | ExodusError::NetCdf {
                        source: NcError::Io(_),
                        ..
                    }
            ) | OutputError::History(HistoryError::Io { .. })
        )
    }
}

/// When to write, per Peridigm's counting.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Schedule {
    /// `Output Frequency` (−1 or 0: never).
    pub frequency: i64,
    /// `Initial Output Step` (default 1): no frame for earlier calls.
    pub initial_step: i64,
    /// `Final Output Step`: no frame for later calls.
    pub final_step: i64,
}

impl Schedule {
    /// True when call `call` (1 = initial state) writes a frame. Peridigm compares the call
    /// count with `Initial Output Step` but the step number (call − 1) with `Final Output
    /// Step`, so `Final Output Step: 20` still writes the state after step 20.
    pub fn writes(&self, call: i64) -> bool {
        self.frequency > 0
            && call >= self.initial_step
            && call - 1 <= self.final_step
            && (call - 1) % self.frequency == 0
    }

    /// True when a run stopping after call `call` must add a frame so that its last state is in
    /// the file: the call lies in the file's output window and did not write a frame.
    pub fn needs_last_frame(&self, call: i64) -> bool {
        self.frequency > 0
            && call >= self.initial_step
            && call - 1 <= self.final_step
            && !self.writes(call)
    }
}

/// The geometry every results file shares, in the user's original point order.
#[derive(Debug, Clone)]
pub struct OutputGeometry {
    /// Reference coordinates in original order.
    pub coordinates: Vec<[f64; 3]>,
    /// `run_index[k]` = run-order index of original point k.
    pub run_index: Vec<u32>,
    /// Blocks: (id, name, original indices of their points).
    pub blocks: Vec<(i64, String, Vec<u32>)>,
    /// Per block (same order as `blocks`), the output variables its material does not have
    /// though another material model does (e.g. `Lambda` on an `Elastic` block beside an
    /// `Elastic Plastic` one): Peridigm defines a material's element variables only on the
    /// blocks of that material. Missing entries lack nothing.
    pub block_lacks: Vec<Vec<&'static str>>,
    /// Node sets: (name, original indices).
    pub node_sets: Vec<(String, Vec<u32>)>,
}

/// The element columns (`Name`, or `NameXX`… of a tensor) of the requested variables that a
/// block lacks.
fn undefined_columns(variables: &[RequestedVariable], lacks: Option<&Vec<&str>>) -> Vec<String> {
    let Some(lacks) = lacks else {
        return Vec::new();
    };
    let mut columns = Vec::new();
    for v in variables
        .iter()
        .filter(|v| lacks.contains(&v.name.as_str()))
    {
        match v.kind {
            VariableKind::ElementScalar => columns.push(v.name.clone()),
            VariableKind::ElementTensor => columns.extend(components(&v.name, &TENSOR)),
            _ => {}
        }
    }
    columns
}

/// Moves `path`, a results file of an interrupted run, to `<path>.before-restart` and returns
/// that path; a copy set aside by an earlier attempt that stopped before finishing is used as
/// it is.
fn set_aside(path: &Path) -> Result<PathBuf, ExodusError> {
    let mut name = path.as_os_str().to_owned();
    name.push(".before-restart");
    let aside = PathBuf::from(name);
    if aside.exists() {
        return Ok(aside);
    }
    std::fs::rename(path, &aside).map_err(|source| ExodusError::Io {
        path: path.to_path_buf(),
        action: "find the results file of the run being continued (restart)",
        source,
    })?;
    Ok(aside)
}

/// What one results file holds and when it writes frames (one deck `Output` list).
#[derive(Debug, Clone, PartialEq)]
pub struct OutputRequest<'a> {
    /// `Output Filename`: the files are `<base>.e` (or `.h`, see [`OutputFile::file_name`])
    /// and, with globals, `<base>.csv`.
    pub base: &'a str,
    /// The Exodus title.
    pub title: &'a str,
    /// When frames are written.
    pub schedule: Schedule,
    /// The variables, in the deck's order.
    pub variables: Vec<RequestedVariable>,
}

/// How far the files of an interrupted run had come, as its restart file records.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Progress {
    /// Output calls counted.
    pub calls: i64,
    /// Exodus frames written.
    pub frames: u64,
    /// CSV rows written.
    pub rows: usize,
}

/// One open results file (one deck `Output` list).
pub struct OutputFile {
    path: PathBuf,
    schedule: Schedule,
    variables: Vec<RequestedVariable>,
    exodus: ExodusWriter,
    history: Option<HistoryWriter>,
    globals: Vec<String>,
    calls: i64,
    run_index: Vec<u32>,
}

fn components(name: &str, suffixes: &[&str]) -> Vec<String> {
    suffixes.iter().map(|s| format!("{name}{s}")).collect()
}

const XYZ: [&str; 3] = ["X", "Y", "Z"];
const TENSOR: [&str; 9] = ["XX", "XY", "XZ", "YX", "YY", "YZ", "ZX", "ZY", "ZZ"];

impl OutputFile {
    /// File name Peridigm would write for this list: `.h` when every variable is global.
    pub fn file_name(base: &str, variables: &[RequestedVariable]) -> String {
        let only_globals = !variables.is_empty()
            && variables
                .iter()
                .all(|v| matches!(v.kind, VariableKind::Global | VariableKind::GlobalVector));
        format!("{base}.{}", if only_globals { "h" } else { "e" })
    }

    /// Creates `<dir>/<base>.e` (or `.h`) and, when globals are requested, `<dir>/<base>.csv`.
    pub fn create(
        dir: &Path,
        request: OutputRequest,
        geometry: &OutputGeometry,
    ) -> Result<Self, OutputError> {
        let OutputRequest {
            base,
            title,
            schedule,
            variables,
        } = request;
        let mut nodal = Vec::new();
        let mut element = Vec::new();
        let mut globals = Vec::new();
        for v in &variables {
            match v.kind {
                VariableKind::NodalVector => nodal.extend(components(&v.name, &XYZ)),
                VariableKind::ElementScalar => element.push(v.name.clone()),
                VariableKind::ElementTensor => element.extend(components(&v.name, &TENSOR)),
                VariableKind::Global => globals.push(v.name.clone()),
                VariableKind::GlobalVector => globals.extend(components(&v.name, &XYZ)),
            }
        }
        let path = dir.join(Self::file_name(base, &variables));
        let layout = if nodal.is_empty() && element.is_empty() && !globals.is_empty() {
            // A history file (`.h`): Peridigm writes globals over a one-point placeholder mesh
            // (one node at the origin, one SPHERE element in block 1); so does peridyn, so that
            // such files compare node for node with Peridigm's.
            OutputLayout {
                title: title.to_string(),
                coordinates: vec![[0.0; 3]],
                node_ids: vec![1],
                blocks: vec![OutputBlock {
                    id: 1,
                    name: String::new(),
                    nodes: vec![0],
                    undefined: Vec::new(),
                }],
                node_sets: Vec::new(),
                nodal_variables: nodal,
                element_variables: element,
                global_variables: globals.clone(),
            }
        } else {
            OutputLayout {
                title: title.to_string(),
                coordinates: geometry.coordinates.clone(),
                node_ids: (1..=geometry.coordinates.len() as i64).collect(),
                blocks: geometry
                    .blocks
                    .iter()
                    .enumerate()
                    .map(|(b, (id, name, nodes))| OutputBlock {
                        id: *id,
                        name: name.clone(),
                        nodes: nodes.clone(),
                        undefined: undefined_columns(&variables, geometry.block_lacks.get(b)),
                    })
                    .collect(),
                node_sets: geometry
                    .node_sets
                    .iter()
                    .enumerate()
                    .map(|(k, (name, nodes))| OutputNodeSet {
                        id: k as i64 + 1,
                        name: name.clone(),
                        nodes: nodes.clone(),
                    })
                    .collect(),
                nodal_variables: nodal,
                element_variables: element,
                global_variables: globals.clone(),
            }
        };
        let exodus = ExodusWriter::create(&path, &layout)?;
        let history = if globals.is_empty() {
            None
        } else {
            Some(HistoryWriter::create(
                &dir.join(format!("{base}.csv")),
                &globals,
            )?)
        };
        Ok(Self {
            path,
            schedule,
            variables,
            exodus,
            history,
            globals,
            calls: 0,
            run_index: geometry.run_index.clone(),
        })
    }

    /// [`OutputFile::create`] for a run that continues an interrupted one from a restart file:
    /// the files written so far are set aside, created anew, given back their first
    /// `progress.frames` frames and `progress.rows` CSV rows, and the call count is set to
    /// `progress.calls`, so the continued file is the one an uninterrupted run writes.
    pub fn create_continuing(
        dir: &Path,
        request: OutputRequest,
        geometry: &OutputGeometry,
        progress: Progress,
    ) -> Result<Self, OutputError> {
        let Progress {
            calls,
            frames,
            rows,
        } = progress;
        let exodus_path = dir.join(Self::file_name(request.base, &request.variables));
        let csv_path = dir.join(format!("{}.csv", request.base));
        let has_globals = request
            .variables
            .iter()
            .any(|v| matches!(v.kind, VariableKind::Global | VariableKind::GlobalVector));
        let exodus_prior = set_aside(&exodus_path)?;
        let csv_prior = if has_globals {
            Some(set_aside(&csv_path)?)
        } else {
            None
        };
        let mut file = Self::create(dir, request, geometry)?;
        file.exodus.adopt_frames(&exodus_prior, frames)?;
        if let (Some(history), Some(prior)) = (&mut file.history, &csv_prior) {
            history.adopt_rows(prior, rows)?;
        }
        file.calls = calls;
        for prior in std::iter::once(&exodus_prior).chain(&csv_prior) {
            std::fs::remove_file(prior).map_err(|source| ExodusError::Io {
                path: prior.clone(),
                action: "remove the set-aside copy",
                source,
            })?;
        }
        Ok(file)
    }

    /// Output calls counted so far.
    pub fn calls(&self) -> i64 {
        self.calls
    }

    /// CSV rows written so far (0 without globals).
    pub fn rows_written(&self) -> usize {
        self.history.as_ref().map_or(0, HistoryWriter::rows_written)
    }

    /// Path of the results file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Frames written so far.
    pub fn frames_written(&self) -> usize {
        self.exodus.frames_written()
    }

    /// Counts one output call (initial state, explicit step or accepted load step) and writes a
    /// frame when the schedule says so. Returns whether a frame was written.
    pub fn call(&mut self, time: f64, source: &dyn FieldSource) -> Result<bool, OutputError> {
        self.calls += 1;
        if !self.schedule.writes(self.calls) {
            return Ok(false);
        }
        self.write_frame(time, source)?;
        Ok(true)
    }

    /// Writes a frame of the state of the last call unless that call wrote one already (or the
    /// file never writes frames): the last frame of a run stopped between two scheduled frames.
    /// Returns whether a frame was written.
    pub fn write_last(&mut self, time: f64, source: &dyn FieldSource) -> Result<bool, OutputError> {
        if !self.schedule.needs_last_frame(self.calls) {
            return Ok(false);
        }
        self.write_frame(time, source)?;
        Ok(true)
    }

    fn missing(&self, name: &str) -> OutputError {
        OutputError::Missing {
            file: self.path.display().to_string(),
            name: name.to_string(),
        }
    }

    fn write_frame(&mut self, time: f64, source: &dyn FieldSource) -> Result<(), OutputError> {
        let mut nodal: Vec<Vec<f64>> = Vec::new();
        let mut element: Vec<Vec<f64>> = Vec::new();
        let mut globals: Vec<f64> = Vec::with_capacity(self.globals.len());
        for v in &self.variables {
            match v.kind {
                VariableKind::NodalVector => {
                    let field = source
                        .vector(&v.name)
                        .ok_or_else(|| self.missing(&v.name))?;
                    push_columns(&mut nodal, &field, &self.run_index);
                }
                VariableKind::ElementScalar => {
                    let field = source
                        .scalar(&v.name)
                        .ok_or_else(|| self.missing(&v.name))?;
                    element.push(self.run_index.iter().map(|&r| field[r as usize]).collect());
                }
                VariableKind::ElementTensor => {
                    let field = source
                        .tensor(&v.name)
                        .ok_or_else(|| self.missing(&v.name))?;
                    push_columns(&mut element, &field, &self.run_index);
                }
                VariableKind::Global => globals.push(
                    source
                        .global(&v.name)
                        .ok_or_else(|| self.missing(&v.name))?,
                ),
                VariableKind::GlobalVector => globals.extend(
                    source
                        .global_vector(&v.name)
                        .ok_or_else(|| self.missing(&v.name))?,
                ),
            }
        }
        let nodal_refs: Vec<&[f64]> = nodal.iter().map(Vec::as_slice).collect();
        let element_refs: Vec<&[f64]> = element.iter().map(Vec::as_slice).collect();
        self.exodus
            .write_frame(time, &nodal_refs, &element_refs, &globals)?;
        if let Some(history) = &mut self.history {
            history.write_row(time, &globals)?;
        }
        Ok(())
    }

    /// Closes the files.
    pub fn finish(self) -> Result<(), OutputError> {
        self.exodus.finish()?;
        if let Some(history) = self.history {
            history.finish()?;
        }
        Ok(())
    }
}

/// Appends the `W` component columns of the point field `field` (run order) to `columns`,
/// each in original order (`run_index[k]` is original point k's run index).
fn push_columns<const W: usize>(
    columns: &mut Vec<Vec<f64>>,
    field: &[[f64; W]],
    run_index: &[u32],
) {
    let column = |c: usize| run_index.iter().map(|&r| field[r as usize][c]).collect();
    columns.extend((0..W).map(column));
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::exodus::ExodusFile;

    #[test]
    fn schedule_follows_peridigm_counting() {
        // Frequency 3: calls 1 (initial state), 4, 7 write.
        let s = Schedule {
            frequency: 3,
            initial_step: 1,
            final_step: i64::MAX,
        };
        let written: Vec<i64> = (1..=8).filter(|&c| s.writes(c)).collect();
        assert_eq!(written, vec![1, 4, 7]);
        // Default −1 writes nothing (Peridigm's default).
        let never = Schedule { frequency: -1, ..s };
        assert!((1..100).all(|c| !never.writes(c)));
    }

    #[test]
    fn catalogue_lookup_and_suggestions() {
        assert_eq!(kind_of("Displacement"), Some(VariableKind::NodalVector));
        assert_eq!(kind_of("displacement"), None);
        assert_eq!(closest_name("Displacment"), Some("Displacement"));
        assert_eq!(
            closest_name("Number_of_Neighbours"),
            Some("Number_Of_Neighbors")
        );
    }

    struct Fixed;
    impl FieldSource for Fixed {
        fn vector(&self, name: &str) -> Option<Cow<'_, [[f64; 3]]>> {
            (name == "Displacement").then(|| Cow::Owned(vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]))
        }
        fn scalar(&self, name: &str) -> Option<Cow<'_, [f64]>> {
            (name == "Volume").then(|| Cow::Owned(vec![10.0, 20.0]))
        }
        fn tensor(&self, _: &str) -> Option<Cow<'_, [[f64; 9]]>> {
            None
        }
        fn global(&self, name: &str) -> Option<f64> {
            (name == "Global_Kinetic_Energy").then_some(7.0)
        }
        fn global_vector(&self, _: &str) -> Option<[f64; 3]> {
            None
        }
    }

    #[test]
    fn frames_are_written_in_original_order() {
        let dir = tempfile::tempdir().unwrap();
        // Run order is the reverse of the original order.
        let geometry = OutputGeometry {
            coordinates: vec![[0.0; 3], [1.0, 0.0, 0.0]],
            run_index: vec![1, 0],
            blocks: vec![(1, "block_1".into(), vec![0, 1])],
            block_lacks: Vec::new(),
            node_sets: vec![("Left".into(), vec![0])],
        };
        let variables = ["Displacement", "Volume", "Global_Kinetic_Energy"]
            .iter()
            .map(|n| RequestedVariable {
                name: n.to_string(),
                kind: kind_of(n).unwrap(),
            })
            .collect();
        let schedule = Schedule {
            frequency: 2,
            initial_step: 1,
            final_step: i64::MAX,
        };
        let request = OutputRequest {
            base: "out",
            title: "test",
            schedule,
            variables,
        };
        let mut file = OutputFile::create(dir.path(), request, &geometry).unwrap();
        for step in 0..3 {
            file.call(step as f64, &Fixed).unwrap();
        }
        let path = file.path().to_path_buf();
        file.finish().unwrap();
        let read = ExodusFile::open(&path).unwrap();
        // Calls 1 and 3 write (frequency 2).
        assert_eq!(read.times, vec![0.0, 2.0]);
        assert_eq!(
            read.nodal_variable_names,
            vec!["DisplacementX", "DisplacementY", "DisplacementZ"]
        );
        // Original node 0 is run point 1: DisplacementX = 4.
        assert_eq!(read.nodal_values(0, 0).unwrap(), vec![4.0, 1.0]);
        assert_eq!(
            read.element_values(1, 0, 0).unwrap(),
            Some(vec![20.0, 10.0])
        );
        assert_eq!(read.global_values(0).unwrap(), vec![7.0]);
        let csv = std::fs::read_to_string(dir.path().join("out.csv")).unwrap();
        assert!(csv.starts_with("Time,Global_Kinetic_Energy"));
        assert_eq!(csv.lines().count(), 3);
    }
}
