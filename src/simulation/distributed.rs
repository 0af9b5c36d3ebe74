//! Runs on N MPI ranks: the same answers as one rank, one results file.
//!
//! Every rank holds the points of the whole model (built from the deck by each rank, see
//! [`global_model`]; families only for its own points and ghosts, except in contact decks)
//! and runs on its [`Subdomain`]: owned points plus ghosts whose current positions are refreshed by one halo
//! exchange per step (velocity Verlet) or per residual evaluation (the implicit solvers, on
//! the Trilinos backend: quasi-static load steps and Newmark-β). Each rank evaluates damage and
//! forces of its owned points from exactly the numbers one rank would use, in the same order
//! (see [`crate::parallel`]).
//!
//! Collectives per step: the halo exchange, one sum of (kinetic energy, supplied work, failure
//! count) for the stability monitor and for failure agreement, and, on output steps, one gather
//! per written point field. Rank 0 gathers the point fields in the global run order and writes
//! every file through the ordinary [`OutputFile`], so the globals (energies, `Block_Data`,
//! `Node_Set_Data`, `Nearest_Point_Data`) are reduced over the same numbers in the same order
//! as on one rank.
//!
//! # Failures
//! Problems every rank sees alike (a solver or feature that cannot run on N ranks, an
//! instability seen by the global monitor) are reported by rank 0 alone. A failure on some
//! ranks only (an expression that fails at one point, an output file rank 0 cannot write) is
//! folded into the next collective: every rank stops at the same step, the lowest failing rank
//! reports its error and the others return [`RunError::OtherRank`]. A panic ends all ranks
//! through the panic hook of [`crate::parallel::initialize`] (MPI_Abort).

use super::{energy_floor_of, prepare_compute_classes, Fields, PreparedComputeClass, Progress};
use super::{RunError, RunSummary};
use crate::backend::SolveError;
use crate::discretization::FamilyRule;
use crate::io::deck::{Deck, Integrator, PointSource, QuickGridGenerator, Solver};
use crate::io::output::{kind_of, FieldSource, OutputFile, Schedule, VariableKind};
use crate::neighbors::NeighborhoodRule;
use crate::parallel::{
    halo_depth, outer_ghosts_need_physics, Communicator, HaloPlan, Partition, Subdomain,
};
use crate::physics::Physics;
use crate::setup::{self, Model};
use crate::solver::collective::Collective;
use crate::solver::explicit::Halo;
use crate::solver::newmark::NewmarkError;
use crate::solver::newton::NewtonReport;
use crate::solver::quasistatic::QuasiStaticError;
use crate::solver::{EnergyMonitor, VelocityVerlet, VerletSettings};
use crate::state::State;
use std::borrow::Cow;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Refuses, before any message is sent, what a distributed run cannot do yet: implicit
/// solvers on the native backend (the distributed linear and nonlinear solves are
/// Trilinos'), and contact in a deck with an implicit
/// solver (contact acts only in `Verlet` steps, where [`crate::contact::Contact::on_ranks`]
/// gives every rank the one-rank candidates and forces).
pub fn check_distributable(deck: &Deck, ranks: usize) -> Result<(), RunError> {
    for solver in &deck.solvers {
        crate::backend::factory::check_ranks(solver, ranks)?;
    }
    if deck.contact.is_some() {
        if let Some(solver) = deck
            .solvers
            .iter()
            .find(|s| !matches!(s.integrator, Integrator::Verlet(_)))
        {
            return Err(RunError::Unsupported(format!(
                "Contact with solver \"{}\" ({}) on {ranks} ranks is not available (contact on several ranks runs in Verlet steps only); run on one rank",
                solver.name,
                solver.integrator.deck_name()
            )));
        }
    }
    Ok(())
}

/// An error every rank has alike: rank 0 reports it, the others stay quiet.
fn collective(comm: &dyn Communicator, error: RunError) -> RunError {
    if comm.rank() == 0 {
        error
    } else {
        RunError::OtherRank {
            rank: 0,
            code: error.exit_code(),
        }
    }
}

/// After a collective sum found `failures > 0`: the lowest failing rank keeps its error, the
/// others get [`RunError::OtherRank`] with that rank's exit code. Collective.
fn agree_on_failure(comm: &dyn Communicator, local: Option<RunError>) -> RunError {
    let rank = comm.rank() as f64;
    let first = comm.min(if local.is_some() { rank } else { f64::INFINITY });
    let code = -comm.min(local.as_ref().map_or(0.0, |e| -f64::from(e.exit_code())));
    match local {
        Some(error) if first == rank => error,
        _ => RunError::OtherRank {
            rank: first as usize,
            code: code as u8,
        },
    }
}

/// Continues when every rank succeeded; otherwise every rank returns an error. Collective.
fn agree<T>(comm: &dyn Communicator, result: Result<T, RunError>) -> Result<T, RunError> {
    let mut failures = [f64::from(u8::from(result.is_err()))];
    comm.sum(&mut failures);
    if failures[0] == 0.0 {
        return result;
    }
    Err(agree_on_failure(comm, result.err()))
}

/// The halo exchange of the current positions, for the integrator.
struct PositionHalo<'a> {
    plan: &'a mut HaloPlan,
    comm: &'a dyn Communicator,
}

impl Halo for PositionHalo<'_> {
    fn refresh(&mut self, current_position: &mut [[f64; 3]]) {
        self.plan.exchange(self.comm, current_position);
    }

    fn communicator(&self) -> Option<&dyn Communicator> {
        Some(self.comm)
    }
}

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
struct DistributedOutputs<'a> {
    /// `Nonlinear_Solver_Iterations` of the last implicit step (none in explicit runs).
    nonlinear_iterations: Option<f64>,
    files: Vec<OutputFile>,
    schedules: Vec<Schedule>,
    calls: i64,
    fields: Vec<(String, Shape)>,
    classes: &'a [PreparedComputeClass],
    seconds: f64,
    /// `<output>_solver.csv` of the implicit steps, on rank 0.
    solver_history: Option<super::SolverHistory>,
}

impl<'a> DistributedOutputs<'a> {
    /// Opens the files on rank 0 (geometry from the global model). Not collective; the caller
    /// agrees on the result.
    fn create(
        deck: &Deck,
        global: &Model,
        dir: &Path,
        classes: &'a [PreparedComputeClass],
        rank: usize,
    ) -> Result<Self, RunError> {
        let fields = fields_to_gather(deck, classes)?;
        let schedules = deck
            .outputs
            .iter()
            .map(|output| Schedule {
                frequency: output.frequency,
                initial_step: output.initial_output_step,
                final_step: output.final_output_step,
            })
            .collect();
        let files = if rank == 0 {
            super::Outputs::create(deck, global, dir)?.files
        } else {
            Vec::new()
        };
        Ok(Self {
            nonlinear_iterations: None,
            files,
            schedules,
            calls: 0,
            fields,
            classes,
            seconds: 0.0,
            solver_history: (rank == 0).then(|| super::SolverHistory::new(deck, dir)),
        })
    }

    /// One implicit step's row of `<output>_solver.csv`, written by rank 0 with the tangent
    /// bytes summed over the ranks (the other columns are global already). Collective (one
    /// sum); a write failure on rank 0 is returned to the caller, which agrees on it.
    fn record(
        &mut self,
        comm: &dyn Communicator,
        time: f64,
        step: usize,
        report: &NewtonReport,
    ) -> Result<(), RunError> {
        let mut tangent_bytes = [report.tangent_bytes as f64];
        comm.sum(&mut tangent_bytes);
        match &mut self.solver_history {
            Some(history) => history.record(time, step, report, tangent_bytes[0]),
            None => Ok(()),
        }
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
        time: f64,
    ) -> Result<(), RunError> {
        let start = Instant::now();
        self.calls += 1;
        let frame = self.schedules.iter().any(|s| s.writes(self.calls));
        let mut gathered = Gathered {
            nonlinear_iterations: self.nonlinear_iterations,
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
        let mut result = Ok(());
        for file in &mut self.files {
            if let Err(error) = file.call(time, &gathered) {
                result = Err(error.into());
                break;
            }
        }
        self.seconds += start.elapsed().as_secs_f64();
        result
    }

    fn finish(self) -> Result<Vec<PathBuf>, RunError> {
        if let Some(history) = self.solver_history {
            history.finish()?;
        }
        let mut paths = Vec::new();
        for file in self.files {
            paths.push(file.path().to_path_buf());
            file.finish()?;
        }
        Ok(paths)
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

/// Peridigm's stable time step over the owned points of every block, minimum over ranks
/// (`None` when no point has a neighbour). Collective.
fn critical_time_step(comm: &dyn Communicator, sub: &Subdomain, physics: &Physics) -> Option<f64> {
    let model = &sub.model;
    let layer = sub.plan.layer();
    let reference = crate::material::ReferenceView {
        bonds: &model.bonds,
        position: &model.points.position,
        volume: &model.points.volume,
    };
    let local = physics
        .blocks
        .iter()
        .filter_map(|block| {
            let material = &block.material;
            let owned: Vec<u32> = material
                .points()
                .iter()
                .copied()
                .filter(|&p| layer[p as usize] == 0)
                .collect();
            crate::material::critical_time_step(
                &reference,
                &owned,
                material.density(),
                material.bulk_modulus(),
                material.horizon(),
            )
        })
        .fold(f64::INFINITY, f64::min);
    let global = comm.min(local);
    global.is_finite().then_some(global)
}

/// Directed bonds of owned rows that are broken (d = 1), summed over ranks. Collective.
fn broken_bonds(comm: &dyn Communicator, sub: &Subdomain, physics: &Physics) -> usize {
    let Some(damage) = &physics.bond_damage else {
        return 0;
    };
    let bonds = &sub.model.bonds;
    let local: usize = sub
        .owned()
        .iter()
        .map(|&i| {
            damage[bonds.range(i as usize)]
                .iter()
                .filter(|&&d| d >= 1.0)
                .count()
        })
        .sum();
    let mut count = [local as f64];
    comm.sum(&mut count);
    count[0] as usize
}

/// Where the ranks of a distributed run get their points' families.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum GlobalFamilies {
    /// The global model holds every point's family (contact decks, whose search needs the
    /// global bonds, and the QuickGrid cylinder, whose families come from index space).
    Built,
    /// The global model has no families ([`setup::build_points`]); each rank searches the
    /// rows of its own points and ghosts with this rule ([`Subdomain::searched`]), so no rank
    /// holds the global bond list.
    Searched(NeighborhoodRule),
}

/// Why every rank of a distributed run of `deck` holds the global families, if it must.
pub fn global_families_reason(deck: &Deck) -> Option<&'static str> {
    let cylinder = matches!(
        &deck.discretization.source,
        PointSource::PdQuickGrid {
            generator: QuickGridGenerator::TensorProductCylinder { .. },
            ..
        }
    );
    if deck.contact.is_some() {
        Some("the contact search reads the global bonds")
    } else if cylinder {
        Some("the QuickGrid cylinder builds them in index space")
    } else {
        None
    }
}

/// The model every rank of a distributed run builds from the deck: points, blocks, node sets
/// and conditions of the whole discretization, and the families only where
/// [`GlobalFamilies::Built`] says they are needed. Fails on every rank alike.
pub fn global_model(deck: &Deck) -> Result<(Model, GlobalFamilies), setup::SetupError> {
    let (mut model, rule) = setup::build_points(deck)?;
    match rule {
        FamilyRule::Search(rule) if global_families_reason(deck).is_none() => {
            Ok((model, GlobalFamilies::Searched(rule)))
        }
        rule => {
            setup::build_families(deck, &mut model, &rule)?;
            Ok((model, GlobalFamilies::Built))
        }
    }
}

/// Runs every solver list of the deck (those [`check_distributable`] accepts) on
/// `comm.size()` ranks. Every rank calls it with the same deck and the global model of
/// [`global_model`]; rank 0 writes the outputs to `dir` and returns the summary with the
/// files.
pub fn run_distributed(
    deck: &Deck,
    global: &Model,
    families: GlobalFamilies,
    dir: &Path,
    comm: &dyn Communicator,
) -> Result<RunSummary, RunError> {
    check_distributable(deck, comm.size()).map_err(|e| collective(comm, e))?;
    let compute_classes = prepare_compute_classes(&deck.compute_classes, global)
        .map_err(|e| collective(comm, RunError::Unsupported(e)))?;
    let rank = comm.rank();
    let (depth, outer) = (halo_depth(deck), outer_ghosts_need_physics(deck));
    let mut sub = match families {
        GlobalFamilies::Built => Subdomain::new(global, comm.size(), rank, depth, outer),
        GlobalFamilies::Searched(rule) => {
            Subdomain::searched(global, comm, depth, outer, |points| {
                agree(
                    comm,
                    setup::family_rows(deck, global, rule, points).map_err(RunError::from),
                )
            })?
        }
    };
    let mut bonds = [sub
        .owned()
        .iter()
        .map(|&l| sub.model.bonds.family_size(l as usize) as f64)
        .sum::<f64>()];
    comm.sum(&mut bonds);
    // From here on, failures may differ between ranks: every step agrees.
    let prepared = (|| -> Result<_, RunError> {
        let mut physics = setup::build_physics(deck, &sub.model)
            .map_err(|e| RunError::Unsupported(e.to_string()))?;
        // Ghost forces are never used: only the owned points' are computed.
        let ghost = sub.ghost_mask();
        physics.restrict_forces(&|p| !ghost[p as usize]);
        // Contact searches the deformed configuration of the whole model: it is built on the
        // global model (global bonds decide who may touch) and keeps its own exchange.
        if physics.contact.is_some() {
            physics.contact = crate::contact::Contact::from_deck(deck, global)
                .map_err(|e| RunError::Unsupported(e.to_string()))?
                .map(|contact| contact.on_ranks(global, &sub.partition, rank, sub.plan.global()));
        }
        let t0 = deck.solvers.first().map_or(0.0, |s| s.initial_time);
        let model = &sub.model;
        let mut state = State::at_rest(&model.points.position, t0, model.boundary.has_body_force());
        model.boundary.apply_initial(
            &model.points.position,
            t0,
            &mut state.displacement,
            &mut state.velocity,
        )?;
        let outputs = DistributedOutputs::create(deck, global, dir, &compute_classes, rank)?;
        Ok((physics, state, outputs))
    })();
    let (mut physics, mut state, mut outputs) = agree(comm, prepared)?;
    if rank == 0 {
        let volume = sub.plan.volume();
        eprintln!(
            "{} bonds; {} ranks, ghost depth {}: rank 0 owns {} points, receives {} ghosts ({} bytes of positions per step) from {} ranks",
            bonds[0],
            comm.size(),
            sub.plan.depth(),
            sub.owned().len(),
            volume.received_points,
            volume.received_bytes(3),
            volume.neighbor_ranks
        );
    }
    let broken_at_start = broken_bonds(comm, &sub, &physics);
    let mut summary = RunSummary::default();
    for (index, solver) in deck.solvers.iter().enumerate() {
        let start = Instant::now();
        let result = match &solver.integrator {
            Integrator::Verlet(verlet) => {
                let estimate = critical_time_step(comm, &sub, &physics);
                verlet_on_ranks(
                    comm,
                    &mut sub,
                    solver,
                    verlet,
                    estimate,
                    &mut physics,
                    &mut state,
                    &mut outputs,
                    &mut summary,
                )
            }
            Integrator::Implicit(implicit) => newmark_on_ranks(
                comm,
                &mut sub,
                global,
                solver,
                implicit,
                &mut physics,
                &mut state,
                &mut outputs,
                &mut summary,
            ),
            _ => quasi_static_on_ranks(
                comm,
                &mut sub,
                global,
                solver,
                index > 0,
                &mut physics,
                &mut state,
                &mut outputs,
                &mut summary,
            ),
        };
        summary.solve_seconds += start.elapsed().as_secs_f64();
        if let Err(error) = result {
            // Frames written so far stay readable.
            let _ = outputs.finish();
            return Err(error);
        }
    }
    summary.broken_bonds = broken_bonds(comm, &sub, &physics) - broken_at_start;
    summary.output_seconds = outputs.seconds;
    summary.solve_seconds -= summary.output_seconds.min(summary.solve_seconds);
    summary.files = agree(comm, outputs.finish())?;
    Ok(summary)
}

/// One `Verlet` solver list on every rank.
#[allow(clippy::too_many_arguments)]
fn verlet_on_ranks(
    comm: &dyn Communicator,
    sub: &mut Subdomain,
    solver: &Solver,
    verlet: &crate::io::deck::Verlet,
    estimate: Option<f64>,
    physics: &mut Physics,
    state: &mut State,
    outputs: &mut DistributedOutputs<'_>,
    summary: &mut RunSummary,
) -> Result<(), RunError> {
    let root = comm.rank() == 0;
    let base = match (verlet.fixed_dt, estimate) {
        (Some(dt), _) | (None, Some(dt)) => dt,
        (None, None) => {
            return Err(collective(comm, RunError::Unsupported(format!(
                "solver \"{}\": no point has a neighbour, so there is no stable time step; give \"Fixed dt\"",
                solver.name
            ))))
        }
    };
    let time_step = verlet.safety_factor * base;
    let steps = ((solver.final_time - solver.initial_time) / time_step)
        .floor()
        .max(0.0) as u64;
    if root {
        eprintln!(
            "{}: Verlet, Δt = {time_step:e} s (stable estimate {}, safety factor {}), {steps} steps",
            solver.name,
            estimate.map(|e| format!("{e:e} s")).unwrap_or_else(|| "n/a".into()),
            verlet.safety_factor
        );
    }
    let ghosts = sub.ghost_mask();
    let Subdomain {
        partition,
        plan,
        model,
    } = sub;
    let (partition, model) = (&*partition, &*model);
    let mut integrator = VelocityVerlet::new(
        model,
        VerletSettings {
            time_step,
            steps,
            initial_time: solver.initial_time,
        },
    )
    .with_ghosts(ghosts);
    let initialized =
        integrator.initialize_with(model, physics, state, &mut PositionHalo { plan, comm });
    agree(comm, initialized.map_err(RunError::from))?;
    let owned = plan.owned().to_vec();
    let local_energy = |physics: &Physics, state: &State| -> f64 {
        let fields = Fields::new(model, physics, state, &[]);
        ["Kinetic_Energy", "Stored_Elastic_Energy"]
            .iter()
            .filter_map(|name| fields.scalar(name))
            .map(|values| owned.iter().map(|&l| values[l as usize]).sum::<f64>())
            .sum()
    };
    let mut energies = [
        local_energy(physics, state),
        energy_floor_of(physics, |p| {
            if plan.layer()[p as usize] == 0 {
                model.points.volume[p as usize]
            } else {
                0.0
            }
        }),
    ];
    comm.sum(&mut energies);
    let mut monitor = EnergyMonitor::new(energies[0], energies[1]);
    let mut pending = {
        let fields = Fields::new(model, physics, state, &[]);
        outputs
            .call(comm, partition, &owned, &fields, state.time)
            .err()
    };
    let mut progress = root.then(|| Progress::new(&solver.name, steps));
    for step in 1..=steps {
        let result = integrator.step_with(
            model,
            physics,
            state,
            step,
            &mut PositionHalo { plan, comm },
        );
        let mut sums = match &result {
            Ok(report) => [
                report.free_kinetic_energy,
                report.supplied_work,
                f64::from(u8::from(pending.is_some())),
            ],
            Err(_) => [0.0, 0.0, 1.0],
        };
        comm.sum(&mut sums);
        if sums[2] > 0.0 {
            if let Some(progress) = progress.take() {
                progress.finish();
            }
            let local = match result {
                Err(error) => Some(error.into()),
                Ok(_) => pending.take(),
            };
            return Err(agree_on_failure(comm, local));
        }
        monitor.add_work(sums[1]);
        if let Err(instability) = monitor.check(step, state.time, sums[0]) {
            if let Some(progress) = progress.take() {
                progress.finish();
            }
            return Err(collective(
                comm,
                RunError::Unstable {
                    solver: solver.name.clone(),
                    instability,
                    time_step,
                    estimate,
                },
            ));
        }
        let fields = Fields::new(model, physics, state, &[]);
        pending = outputs
            .call(comm, partition, &owned, &fields, state.time)
            .err();
        if let Some(progress) = &mut progress {
            progress.update(step);
        }
    }
    if let Some(progress) = progress {
        progress.finish();
    }
    if let (true, Some(contact)) = (root, &physics.contact) {
        eprintln!(
            "{}: contact (rank 0's share): {}; partner points received from other ranks per step: {} since the last search, at most {}",
            solver.name,
            contact.statistics(),
            contact.received_partners().0,
            contact.received_partners().1
        );
    }
    agree(comm, pending.map_or(Ok(()), Err))?;
    summary.steps += steps;
    Ok(())
}

/// The halo exchange, the sums and the ownership queries of an implicit solve on this rank.
struct RankCollective<'a> {
    plan: &'a mut HaloPlan,
    comm: &'a dyn Communicator,
    ghost: Vec<bool>,
    global_points: usize,
    ghost_constrained: Vec<usize>,
}

impl Collective for RankCollective<'_> {
    fn rank(&self) -> usize {
        self.comm.rank()
    }

    fn ranks(&self) -> usize {
        self.comm.size()
    }

    fn refresh(&mut self, field: &mut [[f64; 3]]) {
        self.plan.exchange(self.comm, field);
    }

    fn sum(&mut self, values: &mut [f64]) {
        self.comm.sum(values);
    }

    fn max(&mut self, value: f64) -> f64 {
        -self.comm.min(-value)
    }

    fn is_ghost(&self, p: usize) -> bool {
        self.ghost[p]
    }

    fn global_point(&self, p: usize) -> usize {
        self.plan.global()[p] as usize
    }

    fn global_points(&self) -> usize {
        self.global_points
    }

    fn ghost_constrained_dofs(&self) -> Vec<usize> {
        self.ghost_constrained.clone()
    }
}

/// A subdomain taken apart for an implicit solve: the parts the outputs read, and the
/// collective operations that hold the halo plan.
struct ImplicitRank<'a> {
    partition: &'a Partition,
    model: &'a Model,
    /// Local indices of the owned points.
    owned: Vec<u32>,
    collective_ops: RankCollective<'a>,
}

impl<'a> ImplicitRank<'a> {
    fn new(comm: &'a dyn Communicator, sub: &'a mut Subdomain, global: &Model) -> Self {
        let ghost = sub.ghost_mask();
        let Subdomain {
            partition,
            plan,
            model,
        } = sub;
        let ghost_constrained = ghost_constrained_dofs(global, model, plan, &ghost);
        let owned = plan.owned().to_vec();
        Self {
            partition,
            model,
            owned,
            collective_ops: RankCollective {
                plan,
                comm,
                ghost,
                global_points: global.points.len(),
                ghost_constrained,
            },
        }
    }
}

/// The prescribed dofs of this rank's ghosts (local numbering `3p + c`), from the run-wide
/// conditions: a ghost may sit in a node set whose points this rank does not own.
fn ghost_constrained_dofs(
    global: &Model,
    model: &Model,
    plan: &HaloPlan,
    ghost: &[bool],
) -> Vec<usize> {
    let global_constrained = global.boundary.constrained_dofs();
    (0..model.points.len())
        .filter(|&p| ghost[p])
        .flat_map(|p| {
            let g = plan.global()[p] as usize;
            (0..3).map(move |c| (p, c, 3 * g + c))
        })
        .filter(|(_, _, dof)| global_constrained.binary_search(dof).is_ok())
        .map(|(p, c, _)| 3 * p + c)
        .collect()
}

/// One quasi-static solver list on every rank: the load steps of
/// [`crate::solver::quasistatic`] with Trilinos NOX (`NOXQuasiStatic`) or peridyn's Newton
/// with distributed Belos solves (`QuasiStatic`) over the owned unknowns, the ghosts
/// refreshed before every residual evaluation.
#[allow(clippy::too_many_arguments)]
fn quasi_static_on_ranks(
    comm: &dyn Communicator,
    sub: &mut Subdomain,
    global: &Model,
    solver: &Solver,
    predecessor: bool,
    physics: &mut Physics,
    state: &mut State,
    outputs: &mut DistributedOutputs<'_>,
    summary: &mut RunSummary,
) -> Result<(), RunError> {
    let settings =
        super::quasi_static_settings(solver, predecessor).map_err(|e| collective(comm, e))?;
    let mut nonlinear = super::linear::nonlinear_solver(solver, &sub.model, physics)
        .map_err(|e| collective(comm, e.into()))?;
    let root = comm.rank() == 0;
    if root {
        eprintln!(
            "{}: {}, {} load steps on {} ranks, linear solver: {}",
            solver.name,
            solver.integrator.deck_name(),
            settings.times.len() - 1,
            comm.size(),
            nonlinear.describe()
        );
    }
    let ImplicitRank {
        partition,
        model,
        owned,
        mut collective_ops,
    } = ImplicitRank::new(comm, sub, global);
    state.time = solver.initial_time;
    outputs.nonlinear_iterations = None;
    let initial = (|| -> Result<(), RunError> {
        if let Some(b) = &mut state.external_force_density {
            model
                .boundary
                .body_force(&model.points.position, state.time, b)?;
        }
        Ok(())
    })();
    let pending = {
        let fields = Fields::new(model, physics, state, &[]);
        initial.and(outputs.call(comm, partition, &owned, &fields, state.time))
    };
    agree(comm, pending)?;
    let result = crate::solver::quasistatic::run(
        model,
        physics,
        state,
        &settings,
        nonlinear.as_mut(),
        &mut collective_ops,
        |physics, state, report| -> Result<(), RunError> {
            summary.steps += 1;
            outputs.nonlinear_iterations = Some(report.newton.iterations as f64);
            // Both are collective: each runs on every rank before the agreement.
            let recorded = outputs.record(comm, report.time, report.step, &report.newton);
            let fields = Fields::new(model, physics, state, &[]);
            let written = outputs.call(comm, partition, &owned, &fields, report.time);
            agree(comm, recorded.and(written))
        },
    );
    match result {
        Ok(_) => Ok(()),
        // Every rank stops at the same call; the rank whose evaluation failed reports why.
        Err(RunError::QuasiStatic(QuasiStaticError::Solve {
            source: SolveError::OtherRank,
            ..
        })) => Err(RunError::OtherRank { rank: 0, code: 3 }),
        Err(error @ RunError::QuasiStatic(QuasiStaticError::NotConverged { .. })) => {
            Err(collective(comm, error))
        }
        Err(error) => Err(error),
    }
}

/// One `Implicit` (Newmark-β) solver list on every rank: the steps of
/// [`crate::solver::newmark`] with peridyn's Newton and distributed Belos solves over the
/// owned unknowns, the ghosts refreshed before every residual evaluation.
#[allow(clippy::too_many_arguments)]
fn newmark_on_ranks(
    comm: &dyn Communicator,
    sub: &mut Subdomain,
    global: &Model,
    solver: &Solver,
    implicit: &crate::io::deck::Implicit,
    physics: &mut Physics,
    state: &mut State,
    outputs: &mut DistributedOutputs<'_>,
    summary: &mut RunSummary,
) -> Result<(), RunError> {
    let settings = super::newmark_settings(solver, implicit);
    let mut linear = crate::solver::linear::strategy(solver, &sub.model, physics)
        .map_err(|e| collective(comm, e.into()))?;
    if comm.rank() == 0 {
        eprintln!(
            "{}",
            super::describe_newmark(solver, &settings, &linear.describe(), comm.size())
        );
    }
    let ImplicitRank {
        partition,
        model,
        owned,
        mut collective_ops,
    } = ImplicitRank::new(comm, sub, global);
    state.time = solver.initial_time;
    outputs.nonlinear_iterations = None;
    let written = {
        let fields = Fields::new(model, physics, state, &[]);
        outputs.call(comm, partition, &owned, &fields, state.time)
    };
    agree(comm, written)?;
    let result = crate::solver::newmark::run(
        model,
        physics,
        state,
        &settings,
        &mut linear,
        &mut collective_ops,
        |physics, state, step, report| -> Result<(), RunError> {
            summary.steps += 1;
            outputs.nonlinear_iterations = Some(report.iterations as f64);
            // Both are collective: each runs on every rank before the agreement.
            let recorded = outputs.record(comm, state.time, step as usize, report);
            let fields = Fields::new(model, physics, state, &[]);
            let written = outputs.call(comm, partition, &owned, &fields, state.time);
            agree(comm, recorded.and(written))
        },
    );
    match result {
        Ok(()) => Ok(()),
        // Every rank stops at the same call; the rank whose evaluation failed reports why.
        Err(RunError::Newmark(NewmarkError::Solve {
            source: SolveError::OtherRank,
            ..
        })) => Err(RunError::OtherRank { rank: 0, code: 3 }),
        Err(error @ RunError::Newmark(NewmarkError::NotConverged { .. })) => {
            Err(collective(comm, error))
        }
        Err(error) => Err(error),
    }
}
