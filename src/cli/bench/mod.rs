//! `peridyn bench`: the explicit-dynamics speed check against LAMMPS's PERI package.
//!
//! The problem is the one of the LAMMPS input `in.pdcheck` (`--lammps-input`): a 30 × 30 × 30
//! simple-cubic block (spacing 1 mm, cell-centred QuickGrid points), horizon δ = 3.015 mm with
//! spherical QuickGrid families (122-point interior family, 2 929 168 directed bonds, LAMMPS's
//! `total # of bonds`), glass-like constants E = 72 GPa, ν = 0.25 (K = 48 GPa), ρ = 2440 kg/m³,
//! `Critical Stretch` 5e-4, the third of the block with x index < 10 launched at −30 m/s in x,
//! Δt = 5e-8 s, 100 steps, no output.
//!
//! The deck is written as YAML text and goes through the same path as `peridyn run`
//! ([`peridyn::io::deck::parse_str`], [`peridyn::setup::build`], [`simulation::run`]), so the figures
//! include everything a user's run does per step (damage, force, Verlet updates, the stability
//! monitor). Set-up (families, materials, initial force) is timed apart from the step loop,
//! whose time is [`simulation::RunSummary::solve_seconds`].
//!
//! Throughput is quoted as LAMMPS's README does: directed bond evaluations per second per core,
//! `bonds × steps / loop seconds / threads`. Nothing here asserts on time.
//!
//! Before the runs the bench measures the machine's stream bandwidth (a triad, one thread and
//! all threads; [`bandwidth`]) and prints PMB's rate as a fraction of the bound it puts on
//! PMB, `bandwidth / 16 B per directed bond` (the bytes are counted in [`bandwidth`]). Each run
//! also reports its memory per directed bond: planned (`peridyn check`'s estimate over the
//! bonds) and measured (peak resident memory above the resident memory before the run, over
//! the bonds; freed heap is handed back to the system first).
//!
//! # Differences from the LAMMPS input that remain
//! * LAMMPS's `peri/*` styles add a short-range contact force over a half neighbour list in the
//!   same loop; the "+ contact" rows add a Peridigm `Contact` section ([`problem::CONTACT_SECTION`]).
//!   LAMMPS rebuilds its neighbour list only when an atom has moved half the skin
//!   (`neigh_modify every 1 check yes`); Peridigm's `Search Frequency` searches every 20 steps
//!   regardless, so the "+ contact" rows include five searches per 100 steps that LAMMPS skips.
//! * LAMMPS's PMB breaks a bond at `s00 − α·min(stretch)`; Peridigm's `Critical Stretch` at
//!   `s00`. LAMMPS's LPS uses ω = 1/ζ; Peridigm's default influence function is ω = 1.

mod bandwidth;
mod lammps;
mod measure;
mod problem;
mod table;

use std::path::PathBuf;

use peridyn::simulation;

use bandwidth::{measure_bandwidth, Bandwidth, PMB_BYTES_PER_BOND};
use lammps::{default_lammps_input, find_on_path, run_lammps, LammpsRun};
use measure::{measure, thread_pool, Measurement};
use problem::{contact_supported, BenchModel};
use table::{format_rate, table};

/// `--model` choices.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ModelChoice {
    /// PMB only.
    Pmb,
    /// LPS only.
    Lps,
    /// PMB, then LPS.
    All,
}

impl ModelChoice {
    fn models(self) -> Vec<BenchModel> {
        match self {
            ModelChoice::Pmb => vec![BenchModel::Pmb],
            ModelChoice::Lps => vec![BenchModel::Lps],
            ModelChoice::All => vec![BenchModel::Pmb, BenchModel::Lps],
        }
    }
}

/// Command-line options of `peridyn bench`.
#[derive(Debug, Clone, clap::Args)]
pub struct BenchArgs {
    /// Material model(s) to run.
    #[arg(long, value_enum, default_value = "all")]
    pub model: ModelChoice,
    /// Largest thread count; every model runs with 1 thread and with this many.
    #[arg(long, default_value_t = 2)]
    pub threads: usize,
    /// Time steps per run.
    #[arg(long, default_value_t = 100)]
    pub steps: u64,
    /// Runs per configuration (medians are reported).
    #[arg(long, default_value_t = 3)]
    pub repeat: usize,
    /// Points per edge of the cube (LAMMPS's `-var n`).
    #[arg(long, default_value_t = 30)]
    pub points_per_edge: usize,
    /// Also run LAMMPS (`lmp` on PATH), alternating with peridyn.
    #[arg(long)]
    pub lammps: bool,
    /// The LAMMPS input (default: `in.pdcheck` in `../shared/bench/lammps` beside the
    /// checkout, where the development machines keep it).
    #[arg(long)]
    pub lammps_input: Option<PathBuf>,
}

/// Why the benchmark could not run.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    /// A command-line value is out of range.
    #[error("peridyn bench: {0}")]
    Options(String),
    /// The generated deck was rejected (a bug in the generator or in the deck reader).
    #[error("the benchmark deck was rejected: {0}")]
    Deck(String),
    /// This build cannot run the benchmark deck.
    #[error("this build cannot run the benchmark deck; missing: {0}")]
    Unsupported(String),
    /// The run failed.
    #[error("the benchmark run failed: {0}")]
    Run(#[from] simulation::RunError),
    /// The rayon pool could not be built.
    #[error("cannot build a pool of {threads} threads: {message}")]
    Pool {
        /// Requested threads.
        threads: usize,
        /// rayon's message.
        message: String,
    },
    /// LAMMPS could not be run or its output not understood.
    #[error("LAMMPS: {0}")]
    Lammps(String),
}

/// All runs of one (model, contact) configuration.
struct Series {
    model: BenchModel,
    contact: bool,
    /// Per thread count: its runs.
    runs: Vec<(usize, Vec<Measurement>)>,
    lammps: Vec<LammpsRun>,
}

/// Runs the benchmark described by `args`, printing progress and the table to stdout.
pub fn main(args: &BenchArgs) -> Result<(), BenchError> {
    check_options(args)?;
    let mut thread_counts = vec![1];
    if args.threads > 1 {
        thread_counts.push(args.threads);
    }
    let lammps = find_lammps(args)?;
    let n = args.points_per_edge;
    println!(
        "peridyn bench: {n}³ simple-cubic block, spacing 1 mm, δ = 3.015 mm, {} steps of Δt = 5e-8 s, {} repeats, threads {:?}, rayon pools built per run",
        args.steps, args.repeat, thread_counts
    );
    let bandwidth = measured_bandwidth(args.threads)?;
    let mut series = configurations(args.model, n, &thread_counts);
    // Alternate: every repeat visits every configuration once, LAMMPS right after peridyn's
    // one-thread run of the same model, so slow phases of the shared machine hit both.
    for repeat in 1..=args.repeat {
        for entry in &mut series {
            run_configuration_once(args, repeat, entry, lammps.as_ref(), &bandwidth)?;
        }
    }
    print!("{}", table(&series, &bandwidth));
    Ok(())
}

/// The stream bandwidth on one thread and on `threads`, printed.
fn measured_bandwidth(threads: usize) -> Result<Bandwidth, BenchError> {
    let pool = thread_pool(threads)?;
    let bandwidth = pool.install(measure_bandwidth);
    println!(
        "memory bandwidth (triad over 3 × {} MiB, best of 5): {:.1} GB/s on 1 thread, {:.1} GB/s on {}; PMB bound at {PMB_BYTES_PER_BOND} B per directed bond: {} / {} evals/s",
        bandwidth.array_bytes >> 20,
        bandwidth.one_thread * 1e-9,
        bandwidth.all_threads * 1e-9,
        bandwidth.threads,
        format_rate(bandwidth.pmb_bound(1)),
        format_rate(bandwidth.pmb_bound(bandwidth.threads)),
    );
    Ok(bandwidth)
}

/// Rejects counts the benchmark cannot run with.
fn check_options(args: &BenchArgs) -> Result<(), BenchError> {
    if args.threads == 0 || args.steps == 0 || args.repeat == 0 || args.points_per_edge < 2 {
        return Err(BenchError::Options(
            "--threads, --steps and --repeat must be at least 1, --points-per-edge at least 2"
                .into(),
        ));
    }
    Ok(())
}

/// The LAMMPS executable and input when `--lammps` is given and `lmp` is on `PATH`; a missing
/// input is an error, a missing `lmp` only a notice.
fn find_lammps(args: &BenchArgs) -> Result<Option<(PathBuf, PathBuf)>, BenchError> {
    if !args.lammps {
        return Ok(None);
    }
    let input = args
        .lammps_input
        .clone()
        .unwrap_or_else(default_lammps_input);
    if !input.is_file() {
        return Err(BenchError::Lammps(format!(
            "input {} not found; give --lammps-input",
            input.display()
        )));
    }
    match find_on_path("lmp") {
        Some(lmp) => Ok(Some((lmp, input))),
        None => {
            println!("LAMMPS: `lmp` is not on PATH; running peridyn only");
            Ok(None)
        }
    }
}

/// The (model, contact) configurations to time, each with an empty run list per thread count;
/// the "+ contact" one only where this build can run it.
fn configurations(models: ModelChoice, n: usize, thread_counts: &[usize]) -> Vec<Series> {
    let empty = |model, contact| Series {
        model,
        contact,
        runs: thread_counts.iter().map(|&t| (t, Vec::new())).collect(),
        lammps: Vec::new(),
    };
    let mut series = Vec::new();
    for model in models.models() {
        series.push(empty(model, false));
        match contact_supported(model, n) {
            Ok(()) => series.push(empty(model, true)),
            Err(missing) => println!(
                "{} + contact: not available in this build ({missing})",
                model.lammps_name()
            ),
        }
    }
    series
}

/// One repeat of one configuration: a peridyn run per thread count, and LAMMPS after the
/// one-thread run of a configuration without contact.
fn run_configuration_once(
    args: &BenchArgs,
    repeat: usize,
    entry: &mut Series,
    lammps: Option<&(PathBuf, PathBuf)>,
    bandwidth: &Bandwidth,
) -> Result<(), BenchError> {
    let n = args.points_per_edge;
    for (threads, runs) in &mut entry.runs {
        let m = measure(entry.model, n, args.steps, entry.contact, *threads)?;
        println!(
            "  [{repeat}/{}] peridyn {}{} {} thread(s): setup {:.2} s, loop {:.2} ms/step, {} bond evals/s/core{}, cpu use {}, {} bonds broken, memory {:.1} B/bond planned, {} measured",
            args.repeat,
            entry.model.lammps_name(),
            if entry.contact { " + contact" } else { "" },
            threads,
            m.setup_seconds,
            m.ms_per_step(),
            format_rate(m.rate_per_core()),
            match entry.model {
                BenchModel::Pmb => format!(
                    " ({:.0} % of the bandwidth bound)",
                    100.0 * m.rate_per_core() * *threads as f64 / bandwidth.pmb_bound(*threads)
                ),
                BenchModel::Lps => String::new(),
            },
            m.cpu_use().map_or("n/a".into(), |u| format!("{:.0} %", u * 100.0)),
            m.broken_bonds,
            m.planned_bytes_per_bond(),
            m.measured_bytes_per_bond()
                .map_or("n/a".into(), |b| format!("{b:.1} B/bond")),
        );
        runs.push(m);
        if *threads == 1 && !entry.contact {
            if let Some((lmp, input)) = lammps {
                let run = run_lammps(lmp, input, entry.model, n)?;
                println!(
                    "  [{repeat}/{}] LAMMPS  peri/{} 1 proc: loop {:.2} ms/step, cpu use {}",
                    args.repeat,
                    entry.model.lammps_name(),
                    run.ms_per_step(),
                    run.cpu_percent
                        .map_or("n/a".into(), |c| format!("{c:.0} %"))
                );
                entry.lammps.push(run);
            }
        }
    }
    Ok(())
}
