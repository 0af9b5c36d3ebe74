//! Where a run's results go: one file per deck `Output` list and the implicit solvers'
//! `<output>_solver.csv`. On one rank the files read the fields directly; on N ranks every
//! rank counts the output calls, the point fields of a frame are gathered on rank 0 in the
//! global run order and rank 0 writes every file through the same [`OutputFile`], so the
//! globals (energies, `Block_Data`, `Node_Set_Data`, `Nearest_Point_Data`) are reduced over the
//! same numbers in the same order as on one rank.

use super::{Fields, PreparedComputeClass, RunError};
use crate::io::deck::Deck;
use crate::io::history::HistoryWriter;
use crate::io::output::{
    kind_of, FieldSource, OutputError, OutputFile, OutputGeometry, OutputRequest, Progress,
    Schedule, VariableKind,
};
use crate::model::Model;
use crate::parallel::{Communicator, Partition, Ranks};
use crate::restart::{OutputPosition, Snapshot};
use crate::setup;
use crate::solver::newton::NewtonReport;
use std::borrow::Cow;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The outputs of a run on one rank or on N.
pub(super) enum RunOutputs<'a> {
    /// One rank: the files read the fields directly.
    OneRank {
        /// The results files.
        outputs: Outputs,
        /// `<output>_solver.csv`.
        history: SolverHistory,
    },
    /// One rank of N: point fields gathered on rank 0, which writes.
    Ranks {
        /// The files (open on rank 0) and the gather.
        outputs: DistributedOutputs<'a>,
        /// Who owns which point.
        partition: &'a Partition,
        /// Local indices of this rank's owned points.
        owned: Vec<u32>,
    },
}

impl<'a> RunOutputs<'a> {
    /// The files of a one-rank run of `deck` on `model`, in `dir`; with `resume`, the files of
    /// the interrupted run being continued, kept up to where the restart file says.
    pub(super) fn one_rank(
        deck: &Deck,
        model: &Model,
        dir: &Path,
        resume: Option<&Snapshot>,
    ) -> Result<Self, RunError> {
        let mut history = SolverHistory::new(deck, dir);
        if let Some(snapshot) = resume {
            history.continue_from(snapshot.solver_rows as usize)?;
        }
        Ok(Self::OneRank {
            outputs: Outputs::create(deck, model, dir, resume.map(|s| &s.outputs[..]))?,
            history,
        })
    }

    /// Where every results file stands (output calls, frames, CSV rows) and the rows of
    /// `<output>_solver.csv`, for a restart file.
    pub(super) fn positions(&self) -> (Vec<OutputPosition>, u64) {
        let (files, solver_rows) = match self {
            Self::OneRank { outputs, history } => (&outputs.files, history.rows()),
            Self::Ranks { outputs, .. } => (
                &outputs.files,
                outputs
                    .solver_history
                    .as_ref()
                    .map_or(0, SolverHistory::rows),
            ),
        };
        let positions = files
            .iter()
            .map(|f| OutputPosition {
                calls: f.calls(),
                frames: f.frames_written() as u64,
                rows: f.rows_written() as u64,
            })
            .collect();
        (positions, solver_rows as u64)
    }

    /// One output call at the time of `fields.state`. Collective on N ranks; a failure to
    /// write (on rank 0) is returned to the caller, which agrees on it at a collective.
    pub(super) fn call(&mut self, ranks: &dyn Ranks, fields: &Fields<'_>) -> Result<(), RunError> {
        match self {
            Self::OneRank { outputs, .. } => outputs.call(fields),
            Self::Ranks {
                outputs,
                partition,
                owned,
            } => outputs.call(ranks.communicator(), partition, owned, fields),
        }
    }

    /// One implicit step's row of `<output>_solver.csv`, with the tangent bytes summed over
    /// the ranks (the other columns are global already). Collective on N ranks, like
    /// [`RunOutputs::call`] (on one rank the sum is the rank's own bytes); rank 0 writes.
    pub(super) fn record(
        &mut self,
        ranks: &mut dyn Ranks,
        time: f64,
        step: usize,
        report: &NewtonReport,
    ) -> Result<(), RunError> {
        let mut tangent_bytes = [report.tangent_bytes as f64];
        ranks.sum(&mut tangent_bytes);
        let history = match self {
            Self::OneRank { history, .. } => Some(history),
            Self::Ranks { outputs, .. } => outputs.solver_history.as_mut(),
        };
        match history {
            Some(history) => history.record(time, step, report, tangent_bytes[0]),
            None => Ok(()),
        }
    }

    /// Adds a frame of `fields.state` to every file whose schedule skipped the last call: the
    /// last state of a run stopped on a signal. Collective on N ranks, like
    /// [`RunOutputs::call`].
    pub(super) fn last_frame(
        &mut self,
        ranks: &dyn Ranks,
        fields: &Fields<'_>,
    ) -> Result<(), RunError> {
        match self {
            Self::OneRank { outputs, .. } => outputs.last_frame(fields),
            Self::Ranks {
                outputs,
                partition,
                owned,
            } => outputs.last_frame(ranks.communicator(), partition, owned, fields),
        }
    }

    /// The results files (none on ranks other than 0 of a distributed run).
    pub(super) fn paths(&self) -> Vec<PathBuf> {
        let files = match self {
            Self::OneRank { outputs, .. } => &outputs.files,
            Self::Ranks { outputs, .. } => &outputs.files,
        };
        files.iter().map(|f| f.path().to_path_buf()).collect()
    }

    /// Wall-clock seconds spent writing.
    pub(super) fn seconds(&self) -> f64 {
        match self {
            Self::OneRank { outputs, .. } => outputs.seconds,
            Self::Ranks { outputs, .. } => outputs.seconds,
        }
    }

    /// Closes every file; returns the paths of the results files (none on ranks other than 0).
    pub(super) fn finish(self) -> Result<Vec<PathBuf>, RunError> {
        match self {
            Self::OneRank { outputs, history } => {
                let files = outputs.finish()?;
                history.finish()?;
                Ok(files)
            }
            Self::Ranks { outputs, .. } => outputs.finish(),
        }
    }
}

/// Per model block, the output variables of other material models that its own material does
/// not provide ([`OutputGeometry::block_lacks`]).
fn block_lacks(deck: &Deck, model: &Model) -> Vec<Vec<&'static str>> {
    let provided = |block: &crate::model::ModelBlock| -> &'static [&'static str] {
        let entry = &deck.blocks[block.deck_block];
        deck.material(&entry.material)
            .and_then(|m| crate::material::material_entry(m.model.deck_name()))
            .map_or(&[], |e| e.declaration.outputs)
    };
    let all: Vec<&'static str> = model.blocks.iter().flat_map(provided).copied().collect();
    model
        .blocks
        .iter()
        .map(|block| {
            let own = provided(block);
            let mut lacks: Vec<&'static str> =
                all.iter().copied().filter(|v| !own.contains(v)).collect();
            lacks.sort_unstable();
            lacks.dedup();
            lacks
        })
        .collect()
}

/// The outputs of a one-rank run, one file per deck `Output` list.
pub(super) struct Outputs {
    files: Vec<OutputFile>,
    seconds: f64,
}

impl Outputs {
    fn create(
        deck: &Deck,
        model: &Model,
        dir: &Path,
        resume: Option<&[OutputPosition]>,
    ) -> Result<Self, RunError> {
        if let Some(positions) = resume {
            if positions.len() != deck.outputs.len() {
                return Err(RunError::Input(format!(
                    "the restart file counts {} output lists and the deck has {}; a run continued from a restart file needs the deck it was written with",
                    positions.len(),
                    deck.outputs.len()
                )));
            }
        }
        let n = model.points.len();
        let mut coordinates = vec![[0.0; 3]; n];
        for (k, &run) in model.run_index.iter().enumerate() {
            coordinates[k] = model.points.position[run as usize];
        }
        let original = |points: &[u32]| -> Vec<u32> {
            let mut ids: Vec<u32> = points
                .iter()
                .map(|&p| model.points.original_id[p as usize])
                .collect();
            ids.sort_unstable();
            ids
        };
        let geometry = OutputGeometry {
            coordinates,
            run_index: model.run_index.clone(),
            blocks: model
                .blocks
                .iter()
                .map(|b| (b.info.id, b.info.name.clone(), original(&b.points)))
                .collect(),
            block_lacks: block_lacks(deck, model),
            node_sets: model
                .node_sets
                .iter()
                .map(|(name, points)| (name.to_string(), original(points)))
                .collect(),
        };
        let mut files = Vec::new();
        for (k, output) in deck.outputs.iter().enumerate() {
            let variables = setup::report::requested_variables(deck, output)
                .map_err(|e| RunError::Unsupported(e.to_string()))?;
            let request = OutputRequest {
                base: &output.filename,
                title: "peridyn",
                schedule: schedule(output),
                variables,
            };
            let file = match resume {
                Some(positions) => {
                    let progress = Progress {
                        calls: positions[k].calls,
                        frames: positions[k].frames,
                        rows: positions[k].rows as usize,
                    };
                    OutputFile::create_continuing(dir, request, &geometry, progress)?
                }
                None => OutputFile::create(dir, request, &geometry)?,
            };
            files.push(file);
        }
        Ok(Self {
            files,
            seconds: 0.0,
        })
    }

    fn call(&mut self, fields: &Fields) -> Result<(), RunError> {
        let start = Instant::now();
        write_files(&mut self.files, fields.state.time, fields, OutputFile::call)?;
        self.seconds += start.elapsed().as_secs_f64();
        Ok(())
    }

    fn last_frame(&mut self, fields: &Fields) -> Result<(), RunError> {
        let start = Instant::now();
        write_files(
            &mut self.files,
            fields.state.time,
            fields,
            OutputFile::write_last,
        )?;
        self.seconds += start.elapsed().as_secs_f64();
        Ok(())
    }

    fn finish(self) -> Result<Vec<PathBuf>, RunError> {
        finish_files(self.files)
    }
}

/// How a results file takes the state at a time: [`OutputFile::call`] or
/// [`OutputFile::write_last`].
type WriteFrame = fn(&mut OutputFile, f64, &dyn FieldSource) -> Result<bool, OutputError>;

/// Has every file `write` the state of `source` at `time`; stops at the first failure.
fn write_files(
    files: &mut [OutputFile],
    time: f64,
    source: &dyn FieldSource,
    write: WriteFrame,
) -> Result<(), OutputError> {
    for file in files {
        write(file, time, source)?;
    }
    Ok(())
}

/// Closes every file; returns their paths.
fn finish_files(files: Vec<OutputFile>) -> Result<Vec<PathBuf>, RunError> {
    let mut paths = Vec::new();
    for file in files {
        paths.push(file.path().to_path_buf());
        file.finish()?;
    }
    Ok(paths)
}

/// When the file of a deck `Output` list writes frames.
fn schedule(output: &crate::io::deck::Output) -> Schedule {
    Schedule {
        frequency: output.frequency,
        initial_step: output.initial_output_step,
        final_step: output.final_output_step,
    }
}

/// The per-step report of the implicit solvers, `<output>_solver.csv` beside the first
/// output file (`peridyn.csv` names when the deck has no output), created at the first step.
pub(super) struct SolverHistory {
    path: PathBuf,
    writer: Option<HistoryWriter>,
}

impl SolverHistory {
    fn new(deck: &Deck, dir: &Path) -> Self {
        let name = deck
            .outputs
            .first()
            .map_or_else(|| "peridyn".to_string(), |o| o.filename.clone());
        Self {
            path: dir.join(format!("{name}_solver.csv")),
            writer: None,
        }
    }

    /// One row: the Newton report of the step that ended at `time`, with the tangent's
    /// bytes over all ranks.
    fn record(
        &mut self,
        time: f64,
        step: usize,
        report: &NewtonReport,
        tangent_bytes: f64,
    ) -> Result<(), RunError> {
        let unavailable =
            |e: crate::io::history::HistoryError| RunError::Unsupported(e.to_string());
        if self.writer.is_none() {
            let names: Vec<String> = SOLVER_HISTORY_COLUMNS
                .iter()
                .map(|s| s.to_string())
                .collect();
            self.writer = Some(HistoryWriter::create(&self.path, &names).map_err(unavailable)?);
        }
        let first = report.residual_history.first().copied().unwrap_or(0.0);
        let last = report.residual_history.last().copied().unwrap_or(0.0);
        let row = [
            step as f64,
            report.iterations as f64,
            report.linear_iterations as f64,
            report.residual_evaluations as f64,
            first,
            last,
            report.seconds,
            tangent_bytes,
            report.broken_bonds as f64,
            report.preconditioner.setup_seconds,
            report.preconditioner.setups as f64,
            report.preconditioner.levels as f64,
            report.preconditioner.operator_complexity,
            report.preconditioner.gmres_restart as f64,
            report.relaxation_iterations as f64,
        ];
        self.writer
            .as_mut()
            .expect("created above")
            .write_row(time, &row)
            .map_err(unavailable)
    }

    /// Rows written so far.
    fn rows(&self) -> usize {
        self.writer.as_ref().map_or(0, HistoryWriter::rows_written)
    }

    /// Continues the file of an interrupted run: creates it now with the first `rows` rows
    /// of the one written so far (none: it is created at the first step, as usual).
    fn continue_from(&mut self, rows: usize) -> Result<(), RunError> {
        if rows == 0 {
            return Ok(());
        }
        let unavailable = |e: String| RunError::Unsupported(e);
        let mut name = self.path.as_os_str().to_owned();
        name.push(".before-restart");
        let aside = PathBuf::from(name);
        if !aside.exists() {
            std::fs::rename(&self.path, &aside).map_err(|e| {
                unavailable(format!(
                    "{}: cannot find the solver report of the run being continued: {e}",
                    self.path.display()
                ))
            })?;
        }
        let names: Vec<String> = SOLVER_HISTORY_COLUMNS
            .iter()
            .map(|s| s.to_string())
            .collect();
        let mut writer =
            HistoryWriter::create(&self.path, &names).map_err(|e| unavailable(e.to_string()))?;
        writer
            .adopt_rows(&aside, rows)
            .map_err(|e| unavailable(e.to_string()))?;
        std::fs::remove_file(&aside)
            .map_err(|e| unavailable(format!("{}: cannot remove: {e}", aside.display())))?;
        self.writer = Some(writer);
        Ok(())
    }

    /// Closes the file, if a step wrote one.
    fn finish(self) -> Result<(), RunError> {
        match self.writer {
            Some(writer) => writer
                .finish()
                .map_err(|e| RunError::Unsupported(e.to_string())),
            None => Ok(()),
        }
    }
}

/// Columns of the implicit solver report (`<output>_solver.csv`, after `Time`); five from
/// `Preconditioner_Setup_Seconds` are [`crate::solver::multigrid::PreconditionerReport`];
/// `Relaxation_Iterations` is nonzero when dynamic relaxation solved the step
/// ([`crate::solver::relaxation`]).
pub const SOLVER_HISTORY_COLUMNS: [&str; 15] = [
    "Step",
    "Newton_Iterations",
    "Linear_Iterations",
    "Residual_Evaluations",
    "Initial_Residual",
    "Final_Residual",
    "Seconds",
    "Tangent_Bytes",
    "Broken_Bonds",
    "Preconditioner_Setup_Seconds",
    "Preconditioner_Setups",
    "AMG_Levels",
    "AMG_Operator_Complexity",
    "GMRES_Restart",
    "Relaxation_Iterations",
];

/// How a gathered point field is stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Shape {
    Vector,
    Scalar,
    Tensor,
}

impl Shape {
    fn width(self) -> usize {
        match self {
            Shape::Vector => 3,
            Shape::Scalar => 1,
            Shape::Tensor => 9,
        }
    }
}

/// Point fields gathered on rank 0 in the global run order.
struct Gathered<'a> {
    nonlinear_iterations: Option<f64>,
    vectors: BTreeMap<String, Vec<[f64; 3]>>,
    scalars: BTreeMap<String, Vec<f64>>,
    tensors: BTreeMap<String, Vec<[f64; 9]>>,
    classes: &'a [PreparedComputeClass],
}

impl FieldSource for Gathered<'_> {
    fn vector(&self, name: &str) -> Option<Cow<'_, [[f64; 3]]>> {
        self.vectors.get(name).map(|v| Cow::Borrowed(v.as_slice()))
    }

    fn scalar(&self, name: &str) -> Option<Cow<'_, [f64]>> {
        self.scalars.get(name).map(|v| Cow::Borrowed(v.as_slice()))
    }

    fn tensor(&self, name: &str) -> Option<Cow<'_, [[f64; 9]]>> {
        self.tensors.get(name).map(|v| Cow::Borrowed(v.as_slice()))
    }

    fn global(&self, name: &str) -> Option<f64> {
        super::fields::global_value(self, self.classes, self.nonlinear_iterations, name)
    }

    fn global_vector(&self, name: &str) -> Option<[f64; 3]> {
        super::fields::global_vector_value(self, self.classes, name)
    }
}

/// The point fields the deck's outputs read, with their shapes.
fn fields_to_gather(
    deck: &Deck,
    classes: &[PreparedComputeClass],
) -> Result<Vec<(String, Shape)>, RunError> {
    let mut wanted: BTreeMap<String, Shape> = BTreeMap::new();
    let shape_of = |name: &str| match kind_of(name) {
        Some(VariableKind::NodalVector) => Some(Shape::Vector),
        Some(VariableKind::ElementScalar) => Some(Shape::Scalar),
        Some(VariableKind::ElementTensor) => Some(Shape::Tensor),
        _ => None,
    };
    for output in &deck.outputs {
        let variables = setup::report::requested_variables(deck, output)
            .map_err(|e| RunError::Unsupported(e.to_string()))?;
        for variable in variables {
            let name = variable.name.as_str();
            let point_field = match name {
                "Global_Kinetic_Energy" => Some("Kinetic_Energy"),
                "Global_Stored_Elastic_Energy" => Some("Stored_Elastic_Energy"),
                "Global_Linear_Momentum" => Some("Linear_Momentum"),
                "Global_Angular_Momentum" => Some("Angular_Momentum"),
                "Nonlinear_Solver_Iterations" => None,
                _ => match variable.kind {
                    VariableKind::Global | VariableKind::GlobalVector => classes
                        .iter()
                        .find(|c| c.label == name)
                        .map(|c| c.variable.as_str()),
                    _ => Some(name),
                },
            };
            if let Some(field) = point_field {
                if let Some(shape) = shape_of(field) {
                    wanted.insert(field.to_string(), shape);
                }
            }
        }
    }
    Ok(wanted.into_iter().collect())
}

/// The results files of a distributed run: open on rank 0; every rank counts the calls.
pub(super) struct DistributedOutputs<'a> {
    files: Vec<OutputFile>,
    schedules: Vec<Schedule>,
    calls: i64,
    fields: Vec<(String, Shape)>,
    classes: &'a [PreparedComputeClass],
    seconds: f64,
    /// `<output>_solver.csv` of the implicit steps, on rank 0.
    solver_history: Option<SolverHistory>,
}

impl<'a> DistributedOutputs<'a> {
    /// Opens the files on rank 0 (geometry from the global model); with `resume`, the files
    /// of the interrupted run being continued, kept up to where the restart file says. Not
    /// collective; the caller agrees on the result.
    pub(super) fn create(
        deck: &Deck,
        global: &Model,
        dir: &Path,
        classes: &'a [PreparedComputeClass],
        rank: usize,
        resume: Option<&Snapshot>,
    ) -> Result<Self, RunError> {
        let fields = fields_to_gather(deck, classes)?;
        let schedules = deck.outputs.iter().map(schedule).collect();
        let positions = resume.map(|s| &s.outputs[..]);
        let (files, solver_history) = if rank == 0 {
            let mut history = SolverHistory::new(deck, dir);
            if let Some(snapshot) = resume {
                history.continue_from(snapshot.solver_rows as usize)?;
            }
            (
                Outputs::create(deck, global, dir, positions)?.files,
                Some(history),
            )
        } else {
            (Vec::new(), None)
        };
        // Every file counts every call, so the first file's count is every file's.
        let calls = positions
            .and_then(|p| p.first())
            .map_or(0, |position| position.calls);
        Ok(Self {
            files,
            schedules,
            calls,
            fields,
            classes,
            seconds: 0.0,
            solver_history,
        })
    }

    /// Counts one output call; on a frame, gathers the point fields (collective) and rank 0
    /// writes. A write failure on rank 0 is returned to the caller, which must still take part
    /// in the next collective.
    fn call(
        &mut self,
        comm: &dyn Communicator,
        partition: &Partition,
        owned: &[u32],
        local: &Fields<'_>,
    ) -> Result<(), RunError> {
        let start = Instant::now();
        self.calls += 1;
        let frame = self.schedules.iter().any(|s| s.writes(self.calls));
        let gathered = self.gather(comm, partition, owned, local, frame);
        let written = write_files(
            &mut self.files,
            local.state.time,
            &gathered,
            OutputFile::call,
        );
        self.seconds += start.elapsed().as_secs_f64();
        written.map_err(RunError::from)
    }

    /// Adds a frame of the last call's state to every file whose schedule skipped that call
    /// ([`Schedule::needs_last_frame`]); gathers the point fields when any file needs it.
    /// Collective.
    fn last_frame(
        &mut self,
        comm: &dyn Communicator,
        partition: &Partition,
        owned: &[u32],
        local: &Fields<'_>,
    ) -> Result<(), RunError> {
        let start = Instant::now();
        let frame = self
            .schedules
            .iter()
            .any(|s| s.needs_last_frame(self.calls));
        let gathered = self.gather(comm, partition, owned, local, frame);
        let time = local.state.time;
        let written = write_files(&mut self.files, time, &gathered, OutputFile::write_last);
        self.seconds += start.elapsed().as_secs_f64();
        written.map_err(RunError::from)
    }

    /// The point fields of a frame gathered on rank 0 when `frame` (collective then; every
    /// rank decides `frame` alike), or only the globals' sources when not.
    fn gather(
        &self,
        comm: &dyn Communicator,
        partition: &Partition,
        owned: &[u32],
        local: &Fields<'_>,
        frame: bool,
    ) -> Gathered<'a> {
        let mut gathered = Gathered {
            nonlinear_iterations: local.nonlinear_iterations,
            vectors: BTreeMap::new(),
            scalars: BTreeMap::new(),
            tensors: BTreeMap::new(),
            classes: self.classes,
        };
        if frame {
            for (name, shape) in &self.fields {
                let values = gather_field(comm, partition, owned, local, name, *shape);
                if let Some(values) = values {
                    match shape {
                        Shape::Vector => {
                            gathered.vectors.insert(
                                name.clone(),
                                values.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
                            );
                        }
                        Shape::Scalar => {
                            gathered.scalars.insert(name.clone(), values);
                        }
                        Shape::Tensor => {
                            gathered.tensors.insert(
                                name.clone(),
                                values
                                    .chunks_exact(9)
                                    .map(|c| std::array::from_fn(|k| c[k]))
                                    .collect(),
                            );
                        }
                    }
                }
            }
        }
        gathered
    }

    fn finish(self) -> Result<Vec<PathBuf>, RunError> {
        if let Some(history) = self.solver_history {
            history.finish()?;
        }
        finish_files(self.files)
    }
}

/// One point field of the owned points, gathered on rank 0 in the global run order
/// (`Proc_Num` is the owning rank). Collective; `None` on the other ranks. A field the run
/// does not have is gathered as zeros, and the writer reports it as missing when it is asked
/// for it (as one rank does).
fn gather_field(
    comm: &dyn Communicator,
    partition: &Partition,
    owned: &[u32],
    local: &Fields<'_>,
    name: &str,
    shape: Shape,
) -> Option<Vec<f64>> {
    let width = shape.width();
    let mut values = Vec::with_capacity(owned.len() * width);
    match shape {
        Shape::Vector => match local.vector(name) {
            Some(field) => owned
                .iter()
                .for_each(|&l| values.extend_from_slice(&field[l as usize])),
            None => values.resize(owned.len() * width, 0.0),
        },
        Shape::Scalar if name == "Proc_Num" => values.resize(owned.len(), comm.rank() as f64),
        Shape::Scalar => match local.scalar(name) {
            Some(field) => owned.iter().for_each(|&l| values.push(field[l as usize])),
            None => values.resize(owned.len(), 0.0),
        },
        Shape::Tensor => match local.tensor(name) {
            Some(field) => owned
                .iter()
                .for_each(|&l| values.extend_from_slice(&field[l as usize])),
            None => values.resize(owned.len() * width, 0.0),
        },
    }
    let counts: Vec<usize> = partition
        .owned
        .iter()
        .map(|points| points.len() * width)
        .collect();
    let all = comm.gather(&values, &counts)?;
    let mut global = vec![0.0; partition.owner.len() * width];
    let mut offset = 0;
    for points in &partition.owned {
        for &g in points {
            let g = g as usize;
            global[g * width..(g + 1) * width].copy_from_slice(&all[offset..offset + width]);
            offset += width;
        }
    }
    Some(global)
}
