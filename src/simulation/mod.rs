//! A run from start to finish: initial conditions, the deck's solvers in order, outputs, the
//! stability monitor and progress reporting.

mod distributed;
mod fields;

/// The run error lives in [`crate::error`] (reachable from every module); re-exported here
/// under the name call sites use.
pub use crate::error::RunError;
pub use distributed::{
    check_distributable, global_families_reason, global_model, run_distributed, GlobalFamilies,
};
pub use fields::{prepare_compute_classes, Fields, PreparedComputeClass};

use crate::io::deck::{Deck, Integrator, Solver};
use crate::io::history::HistoryWriter;
use crate::io::output::{FieldSource, OutputFile, OutputGeometry, Schedule};
use crate::physics::Physics;
use crate::setup::{self, Model};
use crate::solver::collective::SerialRun;
use crate::solver::newmark::{self, NewmarkSettings};
use crate::solver::newton::{ConvergenceMeasure, NewtonReport};
use crate::solver::quasistatic::{self, QuasiStaticError, QuasiStaticSettings};
use crate::solver::{linear, EnergyMonitor, VelocityVerlet, VerletSettings};
use crate::state::State;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What a finished run reports.
#[derive(Debug, Clone, Default)]
pub struct RunSummary {
    /// Explicit steps taken over all solvers.
    pub steps: u64,
    /// Wall-clock seconds in the solvers.
    pub solve_seconds: f64,
    /// Wall-clock seconds writing output.
    pub output_seconds: f64,
    /// Files written.
    pub files: Vec<PathBuf>,
    /// Bonds broken during the run.
    pub broken_bonds: usize,
}

/// Prints progress on a terminal as a bar, otherwise as plain lines every 10 %.
struct Progress {
    bar: Option<indicatif::ProgressBar>,
    total: u64,
    next_report: u64,
}

impl Progress {
    fn new(label: &str, total: u64) -> Self {
        let bar = std::io::stderr().is_terminal().then(|| {
            let bar = indicatif::ProgressBar::new(total);
            if let Ok(style) = indicatif::ProgressStyle::with_template(
                "{msg} [{bar:40}] {pos}/{len} steps, {elapsed_precise} elapsed, ETA {eta}",
            ) {
                bar.set_style(style.progress_chars("=> "));
            }
            bar.set_message(label.to_string());
            bar
        });
        Self {
            bar,
            total,
            next_report: 1,
        }
    }

    fn update(&mut self, step: u64) {
        if let Some(bar) = &self.bar {
            bar.set_position(step);
        } else if self.total > 0 && step * 10 >= self.next_report * self.total {
            eprintln!(
                "  step {step}/{} ({}%)",
                self.total,
                step * 100 / self.total
            );
            self.next_report = step * 10 / self.total + 1;
        }
    }

    fn finish(self) {
        if let Some(bar) = self.bar {
            bar.finish();
        }
    }
}

/// The outputs of a run, one file per deck `Output` list.
struct Outputs {
    files: Vec<OutputFile>,
    seconds: f64,
}

impl Outputs {
    fn create(deck: &Deck, model: &Model, dir: &Path) -> Result<Self, RunError> {
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
            node_sets: model
                .node_sets
                .iter()
                .map(|(name, points)| (name.to_string(), original(points)))
                .collect(),
        };
        let mut files = Vec::new();
        for output in &deck.outputs {
            let variables = setup::report::requested_variables(deck, output)
                .map_err(|e| RunError::Unsupported(e.to_string()))?;
            let schedule = Schedule {
                frequency: output.frequency,
                initial_step: output.initial_output_step,
                final_step: output.final_output_step,
            };
            files.push(OutputFile::create(
                dir,
                &output.filename,
                "peridyn",
                schedule,
                variables,
                &geometry,
            )?);
        }
        Ok(Self {
            files,
            seconds: 0.0,
        })
    }

    fn call(&mut self, time: f64, fields: &Fields) -> Result<(), RunError> {
        let start = Instant::now();
        for file in &mut self.files {
            file.call(time, fields)?;
        }
        self.seconds += start.elapsed().as_secs_f64();
        Ok(())
    }

    fn finish(self) -> Result<Vec<PathBuf>, RunError> {
        let mut paths = Vec::new();
        for file in self.files {
            paths.push(file.path().to_path_buf());
            file.finish()?;
        }
        Ok(paths)
    }
}

/// Energy scale below which the monitor treats changes as round-off: the strain energy of the
/// whole body at a uniform strain of 1e-6 (½ K ε² V summed).
fn energy_floor(model: &Model, physics: &Physics) -> f64 {
    energy_floor_of(physics, |p| model.points.volume[p as usize])
}

/// [`energy_floor`] with the volume each point counts with (zero for the ghosts of a
/// distributed run, whose ranks sum their shares).
fn energy_floor_of(physics: &Physics, volume: impl Fn(u32) -> f64) -> f64 {
    physics
        .blocks
        .iter()
        .map(|b| {
            let volume: f64 = b.material.points().iter().map(|&p| volume(p)).sum();
            0.5 * b.material.bulk_modulus() * 1e-12 * volume
        })
        .sum()
}

/// Runs every solver list of the deck in order on one state, writing outputs to `dir`.
/// Output frames already written stay valid whatever happens later.
pub fn run(deck: &Deck, model: &Model, dir: &Path) -> Result<RunSummary, RunError> {
    let mut physics =
        setup::build_physics(deck, model).map_err(|e| RunError::Unsupported(e.to_string()))?;
    let compute_classes =
        prepare_compute_classes(&deck.compute_classes, model).map_err(RunError::Unsupported)?;
    let t0 = deck.solvers.first().map_or(0.0, |s| s.initial_time);
    let mut state = State::at_rest(&model.points.position, t0, model.boundary.has_body_force());
    model.boundary.apply_initial(
        &model.points.position,
        t0,
        &mut state.displacement,
        &mut state.velocity,
    )?;
    let mut run = Run {
        model,
        compute_classes: &compute_classes,
        outputs: Outputs::create(deck, model, dir)?,
        solver_history: SolverHistory::new(deck, dir),
        summary: RunSummary::default(),
        nonlinear_iterations: None,
    };
    let estimate = physics.critical_time_step(&model.bonds, &model.points);
    for (index, solver) in deck.solvers.iter().enumerate() {
        let start = Instant::now();
        let result = match &solver.integrator {
            Integrator::Verlet(verlet) => {
                run.verlet(solver, verlet, estimate, &mut physics, &mut state)
            }
            Integrator::QuasiStatic(_) | Integrator::NoxQuasiStatic(_) => {
                let predecessor = index > 0;
                run.quasi_static(solver, predecessor, &mut physics, &mut state)
            }
            Integrator::Implicit(implicit) => {
                run.newmark(solver, implicit, &mut physics, &mut state)
            }
            Integrator::ImplicitDiffusion(_) => Err(RunError::Unsupported(format!(
                "solver \"{}\": ImplicitDiffusion is not available in this build",
                solver.name
            ))),
        };
        run.summary.solve_seconds += start.elapsed().as_secs_f64();
        if let Err(error) = result {
            // Frames written so far stay readable; close the files before reporting.
            run.outputs.finish()?;
            return Err(error);
        }
    }
    let mut summary = run.summary;
    summary.output_seconds = run.outputs.seconds;
    summary.solve_seconds -= summary.output_seconds.min(summary.solve_seconds);
    summary.files = run.outputs.finish()?;
    run.solver_history.finish()?;
    Ok(summary)
}

/// A run in progress: what every solver writes to.
struct Run<'a> {
    model: &'a Model,
    compute_classes: &'a [PreparedComputeClass],
    outputs: Outputs,
    solver_history: SolverHistory,
    summary: RunSummary,
    /// Newton iterations of the last accepted implicit step (`Nonlinear_Solver_Iterations`).
    nonlinear_iterations: Option<f64>,
}

impl Run<'_> {
    fn output(&mut self, physics: &Physics, state: &State) -> Result<(), RunError> {
        let mut fields = Fields::new(self.model, physics, state, self.compute_classes);
        fields.nonlinear_iterations = self.nonlinear_iterations;
        self.outputs.call(state.time, &fields)
    }

    /// Appends one implicit step's solver report to `<output>_solver.csv`.
    fn record(&mut self, time: f64, step: usize, report: &NewtonReport) -> Result<(), RunError> {
        let tangent_bytes = report.tangent_bytes as f64;
        self.solver_history
            .record(time, step, report, tangent_bytes)
    }

    fn verlet(
        &mut self,
        solver: &Solver,
        verlet: &crate::io::deck::Verlet,
        estimate: Option<f64>,
        physics: &mut Physics,
        state: &mut State,
    ) -> Result<(), RunError> {
        let model = self.model;
        let base = match (verlet.fixed_dt, estimate) {
            (Some(dt), _) | (None, Some(dt)) => dt,
            (None, None) => {
                return Err(RunError::Unsupported(format!(
                    "solver \"{}\": no point has a neighbour, so there is no stable time step; give \"Fixed dt\"",
                    solver.name
                )))
            }
        };
        let time_step = verlet.safety_factor * base;
        let steps = ((solver.final_time - solver.initial_time) / time_step)
            .floor()
            .max(0.0) as u64;
        eprintln!(
            "{}: Verlet, Δt = {time_step:e} s (stable estimate {}, safety factor {}), {steps} steps",
            solver.name,
            estimate.map(|e| format!("{e:e} s")).unwrap_or_else(|| "n/a".into()),
            verlet.safety_factor
        );
        let mut integrator = VelocityVerlet::new(
            model,
            VerletSettings {
                time_step,
                steps,
                initial_time: solver.initial_time,
            },
        );
        if let Some(contact) = &physics.contact {
            eprintln!(
                "{}: contact: search radius {:e} (skin rule: search again when a point moves {:e}), {} contact points",
                solver.name,
                contact.search_radius(),
                0.5 * (contact.search_radius() - contact.max_contact_radius()),
                contact.points().len()
            );
        }
        integrator.initialize(model, physics, state)?;
        let initial_energy = {
            let fields = Fields::new(model, physics, state, self.compute_classes);
            ["Global_Kinetic_Energy", "Global_Stored_Elastic_Energy"]
                .iter()
                .filter_map(|name| FieldSource::global(&fields, name))
                .sum::<f64>()
        };
        let mut monitor = EnergyMonitor::new(initial_energy, energy_floor(model, physics));
        self.output(physics, state)?;
        let mut progress = Progress::new(&solver.name, steps);
        for step in 1..=steps {
            let report = integrator.step(model, physics, state, step)?;
            self.summary.broken_bonds += report.broken_bonds;
            monitor.add_work(report.supplied_work);
            if let Err(instability) = monitor.check(step, state.time, report.free_kinetic_energy) {
                progress.finish();
                return Err(RunError::Unstable {
                    solver: solver.name.clone(),
                    instability,
                    time_step,
                    estimate,
                });
            }
            self.output(physics, state)?;
            progress.update(step);
        }
        progress.finish();
        if let Some(contact) = &physics.contact {
            eprintln!("{}: contact: {}", solver.name, contact.statistics());
        }
        self.summary.steps += steps;
        Ok(())
    }

    fn quasi_static(
        &mut self,
        solver: &Solver,
        predecessor: bool,
        physics: &mut Physics,
        state: &mut State,
    ) -> Result<(), RunError> {
        let settings = quasi_static_settings(solver, predecessor)?;
        let mut nonlinear = linear::nonlinear_solver(solver, self.model, physics)?;
        eprintln!(
            "{}: {}, {} load steps, linear solver: {}",
            solver.name,
            solver.integrator.deck_name(),
            settings.times.len() - 1,
            nonlinear.describe()
        );
        state.time = solver.initial_time;
        self.nonlinear_iterations = None;
        // The initial frame shows the body force at the initial time, as Peridigm writes it.
        if let Some(b) = &mut state.external_force_density {
            self.model
                .boundary
                .body_force(&self.model.points.position, state.time, b)?;
        }
        self.output(physics, state)?;
        let result = quasistatic::run(
            self.model,
            physics,
            state,
            &settings,
            nonlinear.as_mut(),
            &mut SerialRun {
                points: self.model.points.len(),
            },
            |physics, state, report| -> Result<(), RunError> {
                self.nonlinear_iterations = Some(report.newton.iterations as f64);
                self.summary.broken_bonds += report.newton.broken_bonds;
                self.summary.steps += 1;
                self.record(report.time, report.step, &report.newton)?;
                self.output(physics, state)
            },
        );
        let switch = settings
            .adaptive
            .as_ref()
            .and_then(|a| a.switch_to_verlet.clone());
        match (result, switch) {
            (Ok(_), _) => Ok(()),
            (
                Err(RunError::QuasiStatic(error @ QuasiStaticError::NotConverged { .. })),
                Some(verlet),
            ) => {
                eprintln!(
                    "Warning: {error}\n{}: switching to Verlet from t = {:e} to the solver's final time {:e}",
                    solver.name, state.time, solver.final_time
                );
                let explicit = Solver {
                    name: format!("{} (Switch to Verlet)", solver.name),
                    initial_time: state.time,
                    integrator: Integrator::Verlet(crate::io::deck::Verlet {
                        fixed_dt: verlet.fixed_dt,
                        safety_factor: verlet.safety_factor,
                    }),
                    ..solver.clone()
                };
                let estimate = physics.critical_time_step(&self.model.bonds, &self.model.points);
                let Integrator::Verlet(settings) = &explicit.integrator else {
                    unreachable!("built above")
                };
                self.verlet(&explicit, settings, estimate, physics, state)
            }
            (Err(error), _) => Err(error),
        }
    }

    fn newmark(
        &mut self,
        solver: &Solver,
        implicit: &crate::io::deck::Implicit,
        physics: &mut Physics,
        state: &mut State,
    ) -> Result<(), RunError> {
        let settings = newmark_settings(solver, implicit);
        let steps = settings.steps;
        let mut linear = linear::strategy(solver, self.model, physics)?;
        eprintln!(
            "{}",
            describe_newmark(solver, &settings, &linear.describe(), 1)
        );
        state.time = solver.initial_time;
        self.nonlinear_iterations = None;
        self.output(physics, state)?;
        newmark::run(
            self.model,
            physics,
            state,
            &settings,
            &mut linear,
            &mut SerialRun {
                points: self.model.points.len(),
            },
            |physics, state, step, report| -> Result<(), RunError> {
                self.nonlinear_iterations = Some(report.iterations as f64);
                self.summary.broken_bonds += report.broken_bonds;
                self.record(state.time, step as usize, report)?;
                self.output(physics, state)
            },
        )?;
        self.summary.steps += steps;
        Ok(())
    }
}

/// The Newmark-β settings of an `Implicit` list; the step count is
/// `floor((t_final − t_initial)/Δt)`, as Peridigm counts it.
fn newmark_settings(solver: &Solver, implicit: &crate::io::deck::Implicit) -> NewmarkSettings {
    NewmarkSettings {
        time_step: implicit.fixed_dt,
        steps: ((solver.final_time - solver.initial_time) / implicit.fixed_dt)
            .floor()
            .max(0.0) as u64,
        initial_time: solver.initial_time,
        beta: implicit.beta,
        gamma: implicit.gamma,
        tolerance: implicit.absolute_tolerance,
        max_iterations: implicit.maximum_solver_iterations,
        verbose: solver.verbose,
    }
}

/// The log line that opens a Newmark-β solver list.
fn describe_newmark(
    solver: &Solver,
    settings: &NewmarkSettings,
    linear_solver: &str,
    ranks: usize,
) -> String {
    let on_ranks = if ranks > 1 {
        format!(" on {ranks} ranks")
    } else {
        String::new()
    };
    format!(
        "{}: Implicit (Newmark-β, β = {}, γ = {}), Δt = {:e} s, {} steps{on_ranks}, linear solver: {linear_solver}",
        solver.name, settings.beta, settings.gamma, settings.time_step, settings.steps
    )
}

/// The per-step report of the implicit solvers, `<output>_solver.csv` beside the first
/// output file (`peridyn.csv` names when the deck has no output), created at the first step.
struct SolverHistory {
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
        ];
        self.writer
            .as_mut()
            .expect("created above")
            .write_row(time, &row)
            .map_err(unavailable)
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

/// Columns of the implicit solver report (`<output>_solver.csv`, after `Time`).
pub const SOLVER_HISTORY_COLUMNS: [&str; 9] = [
    "Step",
    "Newton_Iterations",
    "Linear_Iterations",
    "Residual_Evaluations",
    "Initial_Residual",
    "Final_Residual",
    "Seconds",
    "Tangent_Bytes",
    "Broken_Bonds",
];

/// The quasi-static settings of a `QuasiStatic` or `NOXQuasiStatic` list.
fn quasi_static_settings(
    solver: &Solver,
    predecessor: bool,
) -> Result<QuasiStaticSettings, RunError> {
    let heuristics = !solver.disable_heuristics;
    let (load_steps, max_iterations, relative, absolute, measure, adaptive) = match &solver
        .integrator
    {
        Integrator::QuasiStatic(q) => (
            &q.load_steps,
            q.maximum_solver_iterations,
            q.relative_tolerance,
            q.absolute_tolerance,
            ConvergenceMeasure::PeridigmQuasiStatic,
            q.adaptive_load_stepping.clone(),
        ),
        Integrator::NoxQuasiStatic(n) => {
            let on_nox = matches!(
                solver.linear_solve.backend,
                crate::io::deck::LinearBackend::Trilinos { .. }
            );
            if n.direction_method != "Newton" && !on_nox {
                return Err(RunError::Unsupported(format!(
                        "solver \"{}\": NOXQuasiStatic Direction → Method \"{}\" needs Trilinos NOX (a build with feature `trilinos` and Backend \"Trilinos\"); the native backend has Newton only",
                        solver.name, n.direction_method
                    )));
            }
            (
                &n.load_steps,
                n.max_solver_iterations,
                n.relative_tolerance,
                n.absolute_tolerance,
                ConvergenceMeasure::TwoNorm,
                None,
            )
        }
        _ => unreachable!("only quasi-static integrators come here"),
    };
    Ok(QuasiStaticSettings {
        times: quasistatic::load_step_times(load_steps, solver.initial_time, solver.final_time),
        max_iterations,
        relative_tolerance: relative,
        absolute_tolerance: absolute,
        measure,
        predictor: heuristics,
        predict_first_step: predecessor && solver.initialize_predictor_from_previous_solver,
        line_search: heuristics,
        verbose: solver.verbose,
        adaptive,
    })
}
