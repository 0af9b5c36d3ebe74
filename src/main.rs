//! `peridyn`: run, check and compare peridynamics simulations from Peridigm-style decks.
//!
//! Exit codes: 0 success, 2 invalid input (deck, mesh, node sets), 3 solver failure or
//! instability, 1 anything else (including deck features this build cannot run yet).
//!
//! Built with the `mpi` feature, `mpirun -np N peridyn run deck.yaml` runs explicit decks on
//! N ranks ([`peridyn::simulation::run_distributed`]); every rank reads the deck, only rank 0
//! prints and writes files. One rank (with or without mpirun) takes the serial path.

mod cli;

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use peridyn::io::deck::{self, DeckError};
use peridyn::io::exodus::{compare_from, ComparisonSpec, ExodusFile};
use peridyn::setup::{self, SetupError};
use peridyn::simulation;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "peridyn",
    version,
    about = "Peridynamics with Peridigm-compatible input decks"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run a simulation deck (YAML or Peridigm XML).
    Run {
        /// The input deck.
        deck: PathBuf,
        /// Folder for the output files (default: the current folder).
        #[arg(long, default_value = ".")]
        output_dir: PathBuf,
        /// Worker threads (default: all cores).
        #[arg(long)]
        threads: Option<usize>,
        /// Backend of the implicit solver lists that do not name one with their `Backend`
        /// key: `native` (the default for QuasiStatic and Implicit), `trilinos` (the default
        /// for NOXQuasiStatic in a build with the feature) or `petsc` (feature `petsc`).
        #[arg(long, value_enum)]
        backend: Option<BackendChoice>,
        /// Change one deck value before the run: `KEY PATH=VALUE`, keys in the deck's
        /// spelling joined by `.` (e.g. `Solver.Verlet.Safety Factor=0.5`); may be repeated.
        #[arg(long = "set", value_name = "KEY PATH=VALUE")]
        set: Vec<String>,
    },
    /// Validate a deck and print the run plan: sizes, physics, fields, memory, time step.
    Check {
        /// The input deck.
        deck: PathBuf,
        /// Change one deck value before checking, as `run --set` does; may be repeated.
        #[arg(long = "set", value_name = "KEY PATH=VALUE")]
        set: Vec<String>,
        /// Print the plan as one JSON object.
        #[arg(long)]
        json: bool,
        /// The backend `run --backend` would give the implicit solver lists that do not name
        /// one, so the plan shows the solver that run would resolve.
        #[arg(long, value_enum)]
        backend: Option<BackendChoice>,
        /// The folder `run` would write to, whose free space the plan compares with what the
        /// run will write (default: the current folder).
        #[arg(long, default_value = ".")]
        output_dir: PathBuf,
    },
    /// Compare two Exodus files like SEACAS exodiff (tolerances from a .comp command file).
    Diff {
        /// The file to check.
        a: PathBuf,
        /// The reference file.
        b: PathBuf,
        /// exodiff command file with tolerances (default: exodiff's defaults).
        #[arg(long)]
        comp: Option<PathBuf>,
        /// Further files whose frames continue A (one file per solver, as SEACAS `conjoin`
        /// joins them); may be repeated.
        #[arg(long = "then")]
        then: Vec<PathBuf>,
        /// Compare A's frames with B's from the frame of B at A's first time (a restarted run
        /// against the uninterrupted one, which has more frames).
        #[arg(long)]
        align_times: bool,
    },
    /// Time the explicit-dynamics speed check (the LAMMPS PERI problem); optionally run LAMMPS.
    Bench(cli::bench::BenchArgs),
    /// Young's modulus of a tensile run from its gauge and grip-reaction globals (CSV).
    Modulus(cli::modulus::ModulusArgs),
    /// Write the dog-bone tensile specimen of Littlewood's roadmap chapter (2016, §18.8.2):
    /// points, node sets and a deck.
    Dogbone(cli::dogbone::DogboneArgs),
    /// Run a deck over a grid of variations; report cost and error per variant (table, CSV,
    /// PNG plots of error against wall time).
    Study(cli::study::StudyArgs),
    /// The horizon-volume error of every quadrature rule against m = δ/Δx (Markdown table).
    Quadrature(cli::quadrature::QuadratureArgs),
}

/// `peridyn run --backend`.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
enum BackendChoice {
    /// faer factorizations and peridyn's own Krylov methods.
    Native,
    /// Belos, and NOX for NOXQuasiStatic (Cargo feature `trilinos`).
    Trilinos,
    /// KSP, and SNES for NOXQuasiStatic (Cargo feature `petsc`).
    Petsc,
}

/// Failure classes that decide the exit code.
#[derive(Debug, thiserror::Error)]
enum Failure {
    #[error("{0}")]
    InvalidInput(String),
    #[error("{0}")]
    Unsupported(String),
    #[error("{0}")]
    Differs(String),
    /// Another rank reports this failure; exit with its code without printing.
    #[cfg_attr(not(feature = "mpi"), allow(dead_code))]
    #[error("")]
    Quiet(u8),
    /// A failure with its own exit code (a run's [`simulation::RunError`]).
    #[error("{1}")]
    WithCode(u8, String),
}

/// The exit code of an error (see the crate docs).
fn exit_code(error: &anyhow::Error) -> u8 {
    match error.downcast_ref::<Failure>() {
        Some(Failure::InvalidInput(_)) => 2,
        Some(Failure::Differs(_)) => 1,
        Some(Failure::Unsupported(_)) => 1,
        Some(Failure::Quiet(code)) | Some(Failure::WithCode(code, _)) => *code,
        None => 1,
    }
}

fn invalid(error: impl std::fmt::Display) -> anyhow::Error {
    Failure::InvalidInput(error.to_string()).into()
}

fn load(path: &Path, set: &[String]) -> Result<deck::Deck> {
    let overrides = set
        .iter()
        .map(|text| deck::Override::parse(text).map_err(|e| invalid(format!("--set {e}"))))
        .collect::<Result<Vec<_>>>()?;
    deck::load_with(path, &overrides).map_err(|e: DeckError| invalid(e))
}

/// Loads a deck with the `--set` overrides and applies `peridyn run --backend` to its
/// implicit solver lists.
fn load_with_backend(
    path: &Path,
    set: &[String],
    backend: Option<BackendChoice>,
) -> Result<deck::Deck> {
    let mut deck = load(path, set)?;
    if let Some(choice) = backend {
        let backend = match choice {
            BackendChoice::Native => deck::LinearBackend::Native,
            BackendChoice::Trilinos => deck::LinearBackend::TRILINOS_DEFAULT,
            BackendChoice::Petsc => deck::LinearBackend::PETSC_DEFAULT,
        };
        let mut warnings = Vec::new();
        for solver in &mut deck.solvers {
            let warning = solver
                .choose_backend(backend)
                .map_err(|e| invalid(format!("{}: --backend: {e}", path.display())))?;
            if let Some(warning) = warning {
                warnings.push((solver.name.clone(), warning));
            }
        }
        for (list, warning) in warnings {
            deck.warn_at(&[&list, "Linear Solver Preconditioner"], &warning);
        }
    }
    Ok(deck)
}

/// The deck's warnings (keys accepted without effect, repeated keys, …), as `check` prints
/// them, on standard error before a run starts.
fn print_warnings(deck: &deck::Deck) {
    for warning in &deck.warnings {
        eprintln!("warning: {warning}");
    }
}

fn build(deck: &deck::Deck) -> Result<peridyn::model::Model> {
    setup::build(deck).map_err(|e: SetupError| invalid(e))
}

fn check(
    path: &Path,
    set: &[String],
    json: bool,
    output_dir: &Path,
    backend: Option<BackendChoice>,
) -> Result<()> {
    let deck = load_with_backend(path, set, backend)?;
    let model = build(&deck)?;
    let plan = setup::plan(&deck, &model).map_err(invalid)?;
    let disk = setup::disk::disk_plan(&deck, &model, &plan.fields, output_dir).map_err(invalid)?;
    let plan = plan.with_disk(disk);
    if json {
        emit(&format!("{}\n", serde_json::to_string_pretty(&plan)?))
    } else {
        emit(&plan.to_string())
    }
}

fn run(
    path: &Path,
    set: &[String],
    output_dir: &Path,
    threads: Option<usize>,
    backend: Option<BackendChoice>,
) -> Result<()> {
    if let Some(threads) = threads {
        check_thread_count(threads)?;
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build_global()
            .context("cannot set up the thread pool")?;
    }
    // The session lives to the end of the run: dropping it finalizes MPI.
    #[cfg(any(feature = "mpi", feature = "trilinos", feature = "petsc"))]
    let _mpi = peridyn::mpi_session::MpiSession::start();
    #[cfg(feature = "mpi")]
    if _mpi.is_some() {
        use peridyn::parallel::Communicator;
        let comm = peridyn::parallel::MpiCommunicator::world();
        if comm.size() > 1 {
            return run_on_ranks(path, set, output_dir, backend, &comm);
        }
    }
    let deck = load_with_backend(path, set, backend)?;
    print_warnings(&deck);
    // Before the body is built: a folder the run cannot write to fails at once.
    peridyn::io::output_folder::prepare(output_dir)
        .map_err(|e| Failure::WithCode(peridyn::io::output_folder::EXIT_CODE, e.to_string()))?;
    let model = build(&deck)?;
    // The checks `check` makes, in the same order; the plan's fields size the restart files.
    let plan = setup::plan(&deck, &model).map_err(invalid)?;
    for warning in setup::bondless_warnings(&deck, &model) {
        eprintln!("warning: {warning}");
    }
    let unsupported = setup::unsupported_features(&deck);
    if !unsupported.is_empty() {
        return Err(Failure::Unsupported(format!(
            "{}: this build cannot run this deck yet; missing: {}",
            path.display(),
            unsupported.join(", ")
        ))
        .into());
    }
    eprintln!(
        "{}: {} points, {} bonds",
        path.display(),
        model.points.len(),
        model.bonds.num_bonds()
    );
    warn_of_disk_space(&deck, &model, &plan.fields, output_dir)?;
    install_stop_handlers()?;
    match simulation::run(&deck, &model, output_dir) {
        Ok(summary) => {
            eprintln!(
                "done: {} steps in {:.2} s (+ {:.2} s output), {} bonds broken",
                summary.steps, summary.solve_seconds, summary.output_seconds, summary.broken_bonds
            );
            for file in &summary.files {
                eprintln!("wrote {}", file.display());
            }
            Ok(())
        }
        Err(error) => Err(Failure::WithCode(error.exit_code(), error.to_string()).into()),
    }
}

/// Warns, as `check` does, when the results and restart files will not fit in the free space
/// of the output folder's file system (the run still starts: the estimate may be pessimistic,
/// and space may be freed while it runs).
fn warn_of_disk_space(
    deck: &deck::Deck,
    model: &peridyn::model::Model,
    fields: &[peridyn::plan::FieldPlan],
    dir: &Path,
) -> Result<()> {
    let disk = setup::disk::disk_plan(deck, model, fields, dir).map_err(invalid)?;
    if let Some(warning) = setup::disk::warning(&disk) {
        eprintln!("warning: {warning}");
    }
    Ok(())
}

/// From here on SIGINT and SIGTERM stop the run after its current step
/// ([`peridyn::interrupt`]); during setup they still end the process at once.
fn install_stop_handlers() -> Result<()> {
    peridyn::interrupt::install().context("cannot install the SIGINT/SIGTERM handlers")
}

/// Most worker threads per core `--threads` accepts: more only add switching (1,000 threads
/// on 2 cores made a 0.25 s run take 47 s).
const MAX_THREADS_PER_CORE: usize = 4;

/// `--threads` must be at least 1 and at most [`MAX_THREADS_PER_CORE`] per core.
fn check_thread_count(threads: usize) -> Result<()> {
    let cores = std::thread::available_parallelism().map_or(1, usize::from);
    let most = MAX_THREADS_PER_CORE * cores;
    if threads == 0 || threads > most {
        return Err(invalid(format!(
            "--threads {threads}: give 1 to {most} ({cores} cores here, at most {MAX_THREADS_PER_CORE} threads per core)"
        )));
    }
    Ok(())
}

/// `run` on N > 1 MPI ranks. Every rank reads the deck and builds the model, so bad input
/// fails on every rank alike before any message is sent; rank 0 alone prints it.
///
/// Every failure reaches all ranks together (the run agrees on failures at its
/// collectives), so the reporting rank prints its message *before* the ranks meet once more
/// and leave: mpirun ends the whole job as soon as one rank exits with an error, which could
/// otherwise kill the reporting rank before it has printed.
#[cfg(feature = "mpi")]
fn run_on_ranks(
    path: &Path,
    set: &[String],
    output_dir: &Path,
    backend: Option<BackendChoice>,
    comm: &dyn peridyn::parallel::Communicator,
) -> Result<()> {
    let result = run_on_ranks_collectively(path, set, output_dir, backend, comm);
    let code = match &result {
        Ok(()) => return result,
        Err(error) => {
            if !matches!(error.downcast_ref::<Failure>(), Some(Failure::Quiet(_))) {
                eprintln!("error: {error:#}");
            }
            exit_code(error)
        }
    };
    // The meeting point: a one-number sum over the ranks.
    comm.sum(&mut [0.0]);
    Err(Failure::Quiet(code).into())
}

#[cfg(feature = "mpi")]
fn run_on_ranks_collectively(
    path: &Path,
    set: &[String],
    output_dir: &Path,
    backend: Option<BackendChoice>,
    comm: &dyn peridyn::parallel::Communicator,
) -> Result<()> {
    use peridyn::simulation::RunError;
    let rank = comm.rank();
    // Errors all ranks share are printed by rank 0 only.
    let shared = |error: anyhow::Error| -> anyhow::Error {
        if rank == 0 {
            error
        } else {
            Failure::Quiet(exit_code(&error)).into()
        }
    };
    let deck = load_with_backend(path, set, backend).map_err(shared)?;
    if rank == 0 {
        print_warnings(&deck);
    }
    let (model, families) = simulation::global_model(&deck).map_err(|e| shared(invalid(e)))?;
    setup::validate_points(&deck, &model).map_err(|e| shared(invalid(e)))?;
    let unsupported = setup::unsupported_features(&deck);
    if !unsupported.is_empty() {
        return Err(shared(
            Failure::Unsupported(format!(
                "{}: this build cannot run this deck yet; missing: {}",
                path.display(),
                unsupported.join(", ")
            ))
            .into(),
        ));
    }
    // Only rank 0 writes; the others learn of a failure through the sum.
    let created = if rank == 0 {
        peridyn::io::output_folder::prepare(output_dir).err()
    } else {
        None
    };
    let mut failed = [f64::from(u8::from(created.is_some()))];
    comm.sum(&mut failed);
    if let Some(error) = created {
        return Err(
            Failure::WithCode(peridyn::io::output_folder::EXIT_CODE, error.to_string()).into(),
        );
    }
    if failed[0] > 0.0 {
        return Err(Failure::Quiet(peridyn::io::output_folder::EXIT_CODE).into());
    }
    if rank == 0 {
        eprintln!(
            "{}: {} points, {} ranks",
            path.display(),
            model.points.len(),
            comm.size()
        );
    }
    install_stop_handlers()?;
    match simulation::run_distributed(&deck, &model, families, output_dir, comm) {
        Ok(summary) => {
            if rank == 0 {
                eprintln!(
                    "done: {} steps in {:.2} s (+ {:.2} s output), {} bonds broken",
                    summary.steps,
                    summary.solve_seconds,
                    summary.output_seconds,
                    summary.broken_bonds
                );
                for file in &summary.files {
                    eprintln!("wrote {}", file.display());
                }
            }
            Ok(())
        }
        Err(error @ RunError::OtherRank { .. }) if rank != 0 => {
            Err(Failure::Quiet(error.exit_code()).into())
        }
        Err(error) if rank == 0 => {
            Err(Failure::WithCode(error.exit_code(), error.to_string()).into())
        }
        Err(error) => {
            Err(Failure::WithCode(error.exit_code(), format!("rank {rank}: {error}")).into())
        }
    }
}

fn diff(
    a: &Path,
    then: &[PathBuf],
    b: &Path,
    comp: Option<&Path>,
    align_times: bool,
) -> Result<()> {
    let spec = match comp {
        Some(path) => ComparisonSpec::from_file(path).map_err(invalid)?,
        None => ComparisonSpec::default(),
    };
    let mut parts = vec![a];
    parts.extend(then.iter().map(PathBuf::as_path));
    let first = ExodusFile::open_conjoined(&parts).map_err(invalid)?;
    let second = ExodusFile::open(b).map_err(invalid)?;
    // The frame of B nearest A's first time; the time comparison reports how near it is.
    let offset = align_times.then(|| {
        let start = first.times.first().copied().unwrap_or(0.0);
        (0..second.times.len())
            .min_by(|&i, &j| {
                let (di, dj) = (
                    (second.times[i] - start).abs(),
                    (second.times[j] - start).abs(),
                );
                di.total_cmp(&dj)
            })
            .unwrap_or(0)
    });
    let report = compare_from(&first, &second, &spec, offset).map_err(invalid)?;
    emit(&report.to_string())?;
    if report.passed() {
        Ok(())
    } else {
        Err(Failure::Differs(format!("{} and {} differ", a.display(), b.display())).into())
    }
}

/// Writes to standard output; a closed pipe (`peridyn diff … | head`) is not an error.
fn emit(text: &str) -> Result<()> {
    use std::io::Write;
    match std::io::stdout().lock().write_all(text.as_bytes()) {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        other => Ok(other?),
    }
}

/// `peridyn deck.yaml` runs the deck, as `Peridigm deck.yaml` does.
fn arguments() -> Vec<std::ffi::OsString> {
    let mut args: Vec<std::ffi::OsString> = std::env::args_os().collect();
    if let Some(first) = args.get(1).and_then(|a| a.to_str()) {
        let lower = first.to_ascii_lowercase();
        if lower.ends_with(".yaml") || lower.ends_with(".yml") || lower.ends_with(".xml") {
            args.insert(1, "run".into());
        }
    }
    args
}

fn main() -> ExitCode {
    let cli = Cli::parse_from(arguments());
    let result = match &cli.command {
        Command::Run {
            deck,
            output_dir,
            threads,
            backend,
            set,
        } => run(deck, set, output_dir, *threads, *backend),
        Command::Check {
            deck,
            set,
            json,
            output_dir,
            backend,
        } => check(deck, set, *json, output_dir, *backend),
        Command::Diff {
            a,
            b,
            comp,
            then,
            align_times,
        } => diff(a, then, b, comp.as_deref(), *align_times),
        Command::Bench(args) => cli::bench::main(args).map_err(Into::into),
        Command::Modulus(args) => cli::modulus::main(args)
            .map_err(invalid)
            .and_then(|table| emit(&table)),
        Command::Dogbone(args) => cli::dogbone::main(args)
            .map_err(invalid)
            .and_then(|summary| emit(&summary)),
        Command::Quadrature(args) => cli::quadrature::main(args)
            .map_err(invalid)
            .and_then(|table| emit(&table)),
        Command::Study(args) => cli::study::main(args)
            .map_err(|e| match e {
                cli::study::StudyError::Input(message) => invalid(message),
                other => anyhow::Error::msg(other.to_string()),
            })
            .and_then(|table| emit(&table)),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            if !matches!(error.downcast_ref::<Failure>(), Some(Failure::Quiet(_))) {
                eprintln!("error: {error:#}");
            }
            ExitCode::from(exit_code(&error))
        }
    }
}
