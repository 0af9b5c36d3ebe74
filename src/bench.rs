//! `peridyn bench`: the explicit-dynamics speed check against LAMMPS's PERI package.
//!
//! The problem is the one of `shared/bench/lammps/in.pdcheck`: a 30 × 30 × 30 simple-cubic
//! block (spacing 1 mm, cell-centred QuickGrid points), horizon δ = 3.015 mm with spherical
//! QuickGrid families (122-point interior family, 2 929 168 directed bonds, LAMMPS's
//! `total # of bonds`), glass-like constants E = 72 GPa, ν = 0.25 (K = 48 GPa), ρ = 2440 kg/m³,
//! `Critical Stretch` 5e-4, the third of the block with x index < 10 launched at −30 m/s in x,
//! Δt = 5e-8 s, 100 steps, no output.
//!
//! The deck is written as YAML text and goes through the same path as `peridyn run`
//! ([`crate::io::deck::parse_str`], [`setup::build`], [`simulation::run`]), so the figures
//! include everything a user's run does per step (damage, force, Verlet updates, the stability
//! monitor). Set-up (families, materials, initial force) is timed apart from the step loop,
//! whose time is [`simulation::RunSummary::solve_seconds`].
//!
//! Throughput is quoted as LAMMPS's README does: directed bond evaluations per second per core,
//! `bonds × steps / loop seconds / threads`. Nothing here asserts on time.
//!
//! # Differences from the LAMMPS input that remain
//! * LAMMPS's `peri/*` styles add a short-range contact force over a half neighbour list in the
//!   same loop; the "+ contact" rows add a Peridigm `Contact` section ([`CONTACT_SECTION`]).
//!   LAMMPS rebuilds its neighbour list only when an atom has moved half the skin
//!   (`neigh_modify every 1 check yes`); Peridigm's `Search Frequency` searches every 20 steps
//!   regardless, so the "+ contact" rows include five searches per 100 steps that LAMMPS skips.
//! * LAMMPS's PMB breaks a bond at `s00 − α·min(stretch)`; Peridigm's `Critical Stretch` at
//!   `s00`. LAMMPS's LPS uses ω = 1/ζ; Peridigm's default influence function is ω = 1.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use crate::io::deck::{self, DeckFormat};
use crate::setup;
use crate::simulation;

/// Lattice spacing of the LAMMPS problem (m).
pub const SPACING: f64 = 1.0e-3;
/// Horizon δ = 3.015 × spacing (m), LAMMPS's `m = 3.015`.
pub const HORIZON: f64 = 3.015e-3;
/// Time step (s), LAMMPS's `timestep 5.0e-8`.
pub const TIME_STEP: f64 = 5.0e-8;
/// Directed bonds LAMMPS reports for the 30³ problem (`total # of bonds = 2929168`).
pub const LAMMPS_BONDS_30: usize = 2_929_168;

/// The `Contact` section of the "+ contact" variant, mirroring LAMMPS's built-in short-range
/// force: contact radius 0.9 mm (LAMMPS uses `min(0.9·|X_j − X_i|, 1.35·lc)`, 0.9 mm for
/// nearest neighbours), and the same stiffness: Peridigm's force is `9k_s/(πδ⁴)·(r_c − r)/δ·V`,
/// LAMMPS's `15·18K/(πδ⁴)·(r_c − r)/δ·V`, so `k_s = 30 K = 1.44e12 Pa`. The search radius is
/// LAMMPS's neighbour cut-off δ + skin (3.515 mm), refreshed every 20 steps.
pub const CONTACT_SECTION: &str = r#"  Contact:
    Search Radius: 3.515e-3
    Search Frequency: 20
    Models:
      Short Range:
        Contact Model: "Short Range Force"
        Contact Radius: 0.9e-3
        Spring Constant: 1.44e12
        Friction Coefficient: 0.0
    Interactions:
      Self Contact:
        Contact Model: "Short Range"
"#;

/// A material model of the benchmark.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum BenchModel {
    /// `Elastic Bond Based` (PMB), LAMMPS `peri/pmb`.
    Pmb,
    /// `Elastic` (linear peridynamic solid), LAMMPS `peri/lps`.
    Lps,
}

impl BenchModel {
    /// The value of LAMMPS's `-var model` for this model.
    pub fn lammps_name(self) -> &'static str {
        match self {
            BenchModel::Pmb => "pmb",
            BenchModel::Lps => "lps",
        }
    }

    /// The material list of the deck: E = 72 GPa (with ν forced to ¼ by PMB, as Peridigm
    /// does, so K = E/(3(1 − 2ν)) = 48 GPa in both models), ρ = 2440 kg/m³.
    fn material_yaml(self) -> &'static str {
        match self {
            BenchModel::Pmb => {
                "      Material Model: \"Elastic Bond Based\"\n      Density: 2440.0\n      Young's Modulus: 72.0e9\n"
            }
            BenchModel::Lps => {
                "      Material Model: \"Elastic\"\n      Density: 2440.0\n      Young's Modulus: 72.0e9\n      Poisson's Ratio: 0.25\n"
            }
        }
    }
}

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
    /// The LAMMPS input (default: `../shared/bench/lammps/in.pdcheck` next to the repository).
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

/// The deck of the LAMMPS problem as Peridigm YAML: an `n`³ block of spacing [`SPACING`],
/// `steps` steps of [`TIME_STEP`], and the [`CONTACT_SECTION`] when `contact` is set.
///
/// The final time is `(steps + ½)·Δt` so that Peridigm's step count `floor(t_final/Δt)` is
/// `steps` whatever the rounding of the division.
pub fn deck_yaml(model: BenchModel, points_per_edge: usize, steps: u64, contact: bool) -> String {
    let n = points_per_edge;
    let length = n as f64 * SPACING;
    // QuickGrid ids are 1-based, x fastest: id = 1 + i + n·j + n²·k. LAMMPS's region `fast`
    // is x < 9.5 lattice units, i.e. i < 10 (i < n/3 in general, at least one layer).
    let fast_layers = (n / 3).max(1);
    let mut ids = String::with_capacity(n * n * fast_layers * 7);
    for k in 0..n {
        for j in 0..n {
            for i in 0..fast_layers {
                if !ids.is_empty() {
                    ids.push(' ');
                }
                let _ = write!(ids, "{}", 1 + i + n * j + n * n * k);
            }
        }
    }
    let final_time = (steps as f64 + 0.5) * TIME_STEP;
    let mut text = format!(
        r#"Peridigm:
  Discretization:
    Type: "PdQuickGrid"
    NeighborhoodType: "Spherical"
    TensorProduct3DMeshGenerator:
      X Origin: 0.0
      Y Origin: 0.0
      Z Origin: 0.0
      X Length: {length:e}
      Y Length: {length:e}
      Z Length: {length:e}
      Number Points X: {n}
      Number Points Y: {n}
      Number Points Z: {n}
  Materials:
    Glass:
{material}  Damage Models:
    Brittle:
      Damage Model: "Critical Stretch"
      Critical Stretch: 5.0e-4
  Blocks:
    Block:
      Block Names: "block_1"
      Material: "Glass"
      Damage Model: "Brittle"
      Horizon: {HORIZON:e}
  Boundary Conditions:
    Fast Node Set: "{ids}"
    Launch:
      Type: "Initial Velocity"
      Node Set: "Fast Node Set"
      Coordinate: "x"
      Value: "-30.0"
  Solver:
    Initial Time: 0.0
    Final Time: {final_time:e}
    Verlet:
      Fixed dt: {TIME_STEP:e}
"#,
        material = model.material_yaml(),
    );
    if contact {
        text.push_str(CONTACT_SECTION);
    }
    text
}

/// One peridyn run of the benchmark.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measurement {
    /// Rayon threads.
    pub threads: usize,
    /// Points in the model.
    pub points: usize,
    /// Directed bonds in the model.
    pub bonds: usize,
    /// Steps taken.
    pub steps: u64,
    /// Seconds from the deck text to the first step: parsing, discretization, families,
    /// materials, initial conditions and the initial force evaluation.
    pub setup_seconds: f64,
    /// Seconds in the time-step loop.
    pub loop_seconds: f64,
    /// Process CPU seconds (all threads) over the whole `simulation::run` call, when the
    /// platform reports it; compare with `run_wall_seconds × threads`.
    pub run_cpu_seconds: Option<f64>,
    /// Wall seconds of the whole `simulation::run` call (physics set-up + loop).
    pub run_wall_seconds: f64,
    /// Bonds broken during the run.
    pub broken_bonds: usize,
}

impl Measurement {
    /// Loop milliseconds per step.
    pub fn ms_per_step(&self) -> f64 {
        self.loop_seconds * 1e3 / self.steps as f64
    }

    /// Directed bond evaluations per second per core: bonds × steps / loop time / threads.
    pub fn rate_per_core(&self) -> f64 {
        self.bonds as f64 * self.steps as f64 / self.loop_seconds / self.threads as f64
    }

    /// Directed bond evaluations per CPU-second of the loop, estimated as the run's CPU time
    /// scaled by loop wall / run wall (the loop is nearly all of the run). On a shared
    /// machine this is steadier than the wall-clock rate: it does not count time spent waiting
    /// for a core (it does count rayon's idle spinning).
    pub fn rate_per_cpu_second(&self) -> Option<f64> {
        let cpu = self.run_cpu_seconds? * self.loop_seconds / self.run_wall_seconds;
        (cpu > 0.0).then(|| self.bonds as f64 * self.steps as f64 / cpu)
    }

    /// CPU use of the run as a fraction of `threads` busy cores (1.0 = every thread busy).
    pub fn cpu_use(&self) -> Option<f64> {
        self.run_cpu_seconds
            .map(|cpu| cpu / self.run_wall_seconds / self.threads as f64)
    }
}

/// Process CPU time (user + system, all threads) in seconds, from `/proc/self/stat` (Linux;
/// fields 14 and 15 in clock ticks of `USER_HZ`, which Linux fixes at 100 for this file).
/// `None` elsewhere.
fn process_cpu_seconds() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/self/stat").ok()?;
    // The command name (field 2) may contain spaces; the fields after it start after ')'.
    let rest = &text[text.rfind(')')? + 1..];
    let fields: Vec<&str> = rest.split_whitespace().collect();
    // `rest` starts at field 3 (state), so field 14 is at index 11.
    let user: f64 = fields.get(11)?.parse().ok()?;
    let system: f64 = fields.get(12)?.parse().ok()?;
    Some((user + system) / 100.0)
}

/// Whether this build can run the deck with the [`CONTACT_SECTION`]; `Err` carries the
/// missing features when it cannot.
pub fn contact_supported(model: BenchModel, points_per_edge: usize) -> Result<(), String> {
    let text = deck_yaml(model, points_per_edge, 1, true);
    let deck = deck::parse_str(&text, DeckFormat::Yaml, Path::new("<bench deck>"))
        .map_err(|e| e.to_string())?;
    let missing = setup::unsupported_features(&deck);
    if missing.is_empty() {
        Ok(())
    } else {
        Err(missing.join(", "))
    }
}

/// Runs the benchmark deck once on a fresh pool of `threads` rayon threads, exactly as
/// `peridyn run` would (no output files are requested, so nothing is written).
pub fn measure(
    model: BenchModel,
    points_per_edge: usize,
    steps: u64,
    contact: bool,
    threads: usize,
) -> Result<Measurement, BenchError> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| BenchError::Pool {
            threads,
            message: e.to_string(),
        })?;
    pool.install(|| {
        let start = Instant::now();
        let text = deck_yaml(model, points_per_edge, steps, contact);
        let deck = deck::parse_str(&text, DeckFormat::Yaml, Path::new("<bench deck>"))
            .map_err(|e| BenchError::Deck(e.to_string()))?;
        let missing = setup::unsupported_features(&deck);
        if !missing.is_empty() {
            return Err(BenchError::Unsupported(missing.join(", ")));
        }
        let built = setup::build(&deck).map_err(|e| BenchError::Deck(e.to_string()))?;
        let build_seconds = start.elapsed().as_secs_f64();
        let cpu_before = process_cpu_seconds();
        let run_start = Instant::now();
        let summary = simulation::run(&deck, &built, &std::env::temp_dir())?;
        let run_wall_seconds = run_start.elapsed().as_secs_f64();
        let run_cpu_seconds = match (cpu_before, process_cpu_seconds()) {
            (Some(before), Some(after)) => Some(after - before),
            _ => None,
        };
        Ok(Measurement {
            threads,
            points: built.points.len(),
            bonds: built.bonds.num_bonds(),
            steps: summary.steps,
            setup_seconds: build_seconds + (run_wall_seconds - summary.solve_seconds),
            loop_seconds: summary.solve_seconds,
            run_cpu_seconds,
            run_wall_seconds,
            broken_bonds: summary.broken_bonds,
        })
    })
}

/// What LAMMPS printed about one run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LammpsRun {
    /// `Loop time of X on P procs for N steps`: X.
    pub loop_seconds: f64,
    /// P.
    pub procs: usize,
    /// N.
    pub steps: u64,
    /// `total # of bonds = B`, if printed.
    pub bonds: Option<usize>,
    /// `C% CPU use`, if printed.
    pub cpu_percent: Option<f64>,
}

impl LammpsRun {
    /// Loop milliseconds per step.
    pub fn ms_per_step(&self) -> f64 {
        self.loop_seconds * 1e3 / self.steps as f64
    }

    /// Directed bond evaluations per CPU-second: `bonds / (loop × CPU use)`, when LAMMPS
    /// printed both.
    pub fn rate_per_cpu_second(&self) -> Option<f64> {
        let cpu = self.loop_seconds * self.cpu_percent? / 100.0;
        let bonds = self.bonds? as f64;
        (cpu > 0.0).then(|| bonds * self.steps as f64 / cpu)
    }
}

/// Reads LAMMPS's screen output: the `Loop time of X on P procs for N steps ...` line (required),
/// `total # of bonds = B` and `C% CPU use ...` (optional).
pub fn parse_lammps_output(text: &str) -> Option<LammpsRun> {
    let mut run = None;
    let mut bonds = None;
    let mut cpu_percent = None;
    for line in text.lines() {
        let line = line.trim();
        if let Some(rest) = line.strip_prefix("Loop time of ") {
            let words: Vec<&str> = rest.split_whitespace().collect();
            // X on P procs for N steps ...
            if words.len() >= 6 && words[1] == "on" && words[3] == "procs" && words[4] == "for" {
                let loop_seconds = words[0].parse().ok()?;
                let procs = words[2].parse().ok()?;
                let steps = words[5].parse().ok()?;
                run = Some((loop_seconds, procs, steps));
            }
        } else if let Some(rest) = line.strip_prefix("total # of bonds =") {
            bonds = rest.trim().parse().ok();
        } else if let Some((percent, _)) = line.split_once("% CPU use") {
            cpu_percent = percent.trim().parse().ok();
        }
    }
    let (loop_seconds, procs, steps) = run?;
    Some(LammpsRun {
        loop_seconds,
        procs,
        steps,
        bonds,
        cpu_percent,
    })
}

/// `name` on `PATH`, if any.
fn find_on_path(name: &str) -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .map(|dir| dir.join(name))
        .find(|candidate| candidate.is_file())
}

/// Runs `lmp -in <input> -var model <model> -var n <n> -log none` on one process with one
/// OpenMP thread, in the system's temporary folder.
pub fn run_lammps(
    lmp: &Path,
    input: &Path,
    model: BenchModel,
    points_per_edge: usize,
) -> Result<LammpsRun, BenchError> {
    let output = Command::new(lmp)
        .arg("-in")
        .arg(input)
        .args(["-var", "model", model.lammps_name()])
        .args(["-var", "n", &points_per_edge.to_string()])
        .args(["-log", "none"])
        .env("OMP_NUM_THREADS", "1")
        .current_dir(std::env::temp_dir())
        .output()
        .map_err(|e| BenchError::Lammps(format!("cannot start {}: {e}", lmp.display())))?;
    let stdout = String::from_utf8_lossy(&output.stdout);
    if !output.status.success() {
        let stderr = String::from_utf8_lossy(&output.stderr);
        return Err(BenchError::Lammps(format!(
            "{} -in {} failed ({}): {}{}",
            lmp.display(),
            input.display(),
            output.status,
            stdout.lines().rev().take(5).collect::<Vec<_>>().join(" | "),
            stderr.trim()
        )));
    }
    parse_lammps_output(&stdout).ok_or_else(|| {
        BenchError::Lammps(format!(
            "no `Loop time of ... on ... procs for ... steps` line in the output of {}",
            lmp.display()
        ))
    })
}

/// Median of a non-empty list (mean of the middle two for an even count).
pub fn median(values: &[f64]) -> f64 {
    assert!(!values.is_empty(), "median of an empty list");
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let mid = sorted.len() / 2;
    if sorted.len() % 2 == 1 {
        sorted[mid]
    } else {
        0.5 * (sorted[mid - 1] + sorted[mid])
    }
}

/// The default LAMMPS input: `../shared/bench/lammps/in.pdcheck` relative to the repository.
fn default_lammps_input() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/bench/lammps/in.pdcheck")
}

/// All runs of one (model, contact) configuration.
struct Series {
    model: BenchModel,
    contact: bool,
    /// Per thread count: its runs.
    runs: Vec<(usize, Vec<Measurement>)>,
    lammps: Vec<LammpsRun>,
}

fn format_rate(rate: f64) -> String {
    format!("{rate:.3e}")
}

/// Runs the benchmark described by `args`, printing progress and the table to stdout.
pub fn main(args: &BenchArgs) -> Result<(), BenchError> {
    if args.threads == 0 || args.steps == 0 || args.repeat == 0 || args.points_per_edge < 2 {
        return Err(BenchError::Options(
            "--threads, --steps and --repeat must be at least 1, --points-per-edge at least 2"
                .into(),
        ));
    }
    let mut thread_counts = vec![1];
    if args.threads > 1 {
        thread_counts.push(args.threads);
    }
    let lammps = if args.lammps {
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
            Some(lmp) => Some((lmp, input)),
            None => {
                println!("LAMMPS: `lmp` is not on PATH; running peridyn only");
                None
            }
        }
    } else {
        None
    };
    let n = args.points_per_edge;
    println!(
        "peridyn bench: {n}³ simple-cubic block, spacing 1 mm, δ = 3.015 mm, {} steps of Δt = 5e-8 s, {} repeats, threads {:?}, rayon pools built per run",
        args.steps, args.repeat, thread_counts
    );
    let mut series = Vec::new();
    for model in args.model.models() {
        series.push(Series {
            model,
            contact: false,
            runs: thread_counts.iter().map(|&t| (t, Vec::new())).collect(),
            lammps: Vec::new(),
        });
        match contact_supported(model, n) {
            Ok(()) => series.push(Series {
                model,
                contact: true,
                runs: thread_counts.iter().map(|&t| (t, Vec::new())).collect(),
                lammps: Vec::new(),
            }),
            Err(missing) => println!(
                "{} + contact: not available in this build ({missing})",
                model.lammps_name()
            ),
        }
    }
    // Alternate: every repeat visits every configuration once, LAMMPS right after peridyn's
    // one-thread run of the same model, so slow phases of the shared machine hit both.
    for repeat in 1..=args.repeat {
        for entry in &mut series {
            for (threads, runs) in &mut entry.runs {
                let m = measure(entry.model, n, args.steps, entry.contact, *threads)?;
                println!(
                    "  [{repeat}/{}] peridyn {}{} {} thread(s): setup {:.2} s, loop {:.2} ms/step, {} bond evals/s/core, cpu use {}, {} bonds broken",
                    args.repeat,
                    entry.model.lammps_name(),
                    if entry.contact { " + contact" } else { "" },
                    threads,
                    m.setup_seconds,
                    m.ms_per_step(),
                    format_rate(m.rate_per_core()),
                    m.cpu_use().map_or("n/a".into(), |u| format!("{:.0} %", u * 100.0)),
                    m.broken_bonds
                );
                runs.push(m);
                if *threads == 1 && !entry.contact {
                    if let Some((lmp, input)) = &lammps {
                        let run = run_lammps(lmp, input, entry.model, n)?;
                        println!(
                            "  [{repeat}/{}] LAMMPS  peri/{} 1 proc: loop {:.2} ms/step, cpu use {}",
                            args.repeat,
                            entry.model.lammps_name(),
                            run.ms_per_step(),
                            run.cpu_percent.map_or("n/a".into(), |c| format!("{c:.0} %"))
                        );
                        entry.lammps.push(run);
                    }
                }
            }
        }
    }
    print!("{}", table(&series));
    Ok(())
}

/// The summary table (medians over repeats).
fn table(series: &[Series]) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "\n{:<16} {:>7} {:>9} {:>12} {:>18} {:>8} {:>14} {:>10} {:>9} {:>16} {:>10}",
        "model",
        "threads",
        "setup s",
        "loop ms/step",
        "bond evals/s/core",
        "cpu use",
        "LAMMPS ms/step",
        "per-core ×",
        "speed-up",
        "evals/CPU-s",
        "per-CPU-s ×"
    );
    for entry in series {
        let name = format!(
            "{}{}",
            entry.model.lammps_name(),
            if entry.contact { " + contact" } else { "" }
        );
        let lammps = (!entry.lammps.is_empty()).then(|| {
            let ms = median(
                &entry
                    .lammps
                    .iter()
                    .map(LammpsRun::ms_per_step)
                    .collect::<Vec<_>>(),
            );
            let bonds = entry.lammps[0].bonds;
            let cpu_rates: Vec<f64> = entry
                .lammps
                .iter()
                .filter_map(LammpsRun::rate_per_cpu_second)
                .collect();
            let cpu_rate = (!cpu_rates.is_empty()).then(|| median(&cpu_rates));
            (ms, bonds, cpu_rate)
        });
        let single = entry.runs.first().map(|(_, runs)| {
            median(
                &runs
                    .iter()
                    .map(Measurement::ms_per_step)
                    .collect::<Vec<_>>(),
            )
        });
        for (threads, runs) in &entry.runs {
            let pick = |f: fn(&Measurement) -> f64| median(&runs.iter().map(f).collect::<Vec<_>>());
            let ms = pick(Measurement::ms_per_step);
            let rate = pick(Measurement::rate_per_core);
            let setup = pick(|m| m.setup_seconds);
            let cpu: Vec<f64> = runs.iter().filter_map(Measurement::cpu_use).collect();
            let cpu = if cpu.is_empty() {
                "n/a".to_string()
            } else {
                format!("{:.0} %", median(&cpu) * 100.0)
            };
            // Per-core ratio: peridyn's rate per core over LAMMPS's (one process), with each
            // code's own bond count.
            let cpu_rates: Vec<f64> = runs
                .iter()
                .filter_map(Measurement::rate_per_cpu_second)
                .collect();
            let cpu_rate = (!cpu_rates.is_empty()).then(|| median(&cpu_rates));
            let cpu_ratio = match (cpu_rate, lammps.and_then(|l| l.2)) {
                (Some(ours), Some(theirs)) => format!("{:.2}", ours / theirs),
                _ => "-".into(),
            };
            let cpu_rate = cpu_rate.map_or("n/a".into(), format_rate);
            let (lammps_ms, ratio) = match lammps {
                Some((lammps_ms, lammps_bonds, _)) => {
                    let bonds = lammps_bonds.unwrap_or(runs[0].bonds) as f64;
                    let lammps_rate = bonds / (lammps_ms * 1e-3);
                    (
                        format!("{lammps_ms:.2}"),
                        format!("{:.2}", rate / lammps_rate),
                    )
                }
                None => ("-".into(), "-".into()),
            };
            let speedup = match single {
                Some(one) if *threads > 1 => format!("{:.2}", one / ms),
                _ => "-".into(),
            };
            let _ = writeln!(
                out,
                "{name:<16} {threads:>7} {setup:>9.2} {ms:>12.2} {:>18} {cpu:>8} {lammps_ms:>14} {ratio:>10} {speedup:>9} {cpu_rate:>16} {cpu_ratio:>10}",
                format_rate(rate)
            );
        }
    }
    let _ = writeln!(
        out,
        "bond evals/s/core = directed bonds × steps / loop wall time / threads; per-core × = peridyn per core / LAMMPS (1 proc);\n\
         evals/CPU-s = the same per CPU-second (run CPU time scaled to the loop; LAMMPS: loop × its `% CPU use`); medians of the repeats"
    );
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn deck_reproduces_the_lammps_lattice_and_launch() {
        // 30³ block: LAMMPS reports `total # of bonds = 2929168` for in.pdcheck, and the
        // interior family of a sphere of radius 3.015 spacings on a cubic lattice has 122
        // points (README of shared/bench/lammps).
        let text = deck_yaml(BenchModel::Pmb, 30, 100, false);
        let deck = deck::parse_str(&text, DeckFormat::Yaml, Path::new("<test>")).unwrap();
        assert!(setup::unsupported_features(&deck).is_empty());
        let model = setup::build(&deck).unwrap();
        assert_eq!(model.points.len(), 27_000);
        assert_eq!(model.bonds.num_bonds(), LAMMPS_BONDS_30);
        let largest = (0..model.points.len())
            .map(|i| model.bonds.family_size(i))
            .max()
            .unwrap();
        assert_eq!(largest, 122);
        // The launched set is x < 10 mm (LAMMPS region `fast`: x < 9.5 lattice units from the
        // first point at 0.5 mm, i.e. the first 10 layers): 10 × 30 × 30 points.
        let fast = model.node_sets.get("Fast Node Set").unwrap();
        assert_eq!(fast.len(), 9_000);
        for &p in fast {
            assert!(model.points.position[p as usize][0] < 10.0e-3);
        }
        let slow_minimum = (0..model.points.len() as u32)
            .filter(|p| !fast.contains(p))
            .map(|p| model.points.position[p as usize][0])
            .fold(f64::INFINITY, f64::min);
        assert!(slow_minimum > 10.0e-3);
    }

    #[test]
    fn short_run_takes_the_requested_steps_and_breaks_bonds() {
        // 8³ block, 5 steps: the slab interface moves apart at 30 m/s, so after one step of
        // 5e-8 s the bonds across it stretch by 1.5e-6 m over ζ ≥ 1 mm, i.e. s ≥ 1.5e-3 minus
        // the (smaller) elastic response, above the critical stretch 5e-4: bonds must break.
        for model in [BenchModel::Pmb, BenchModel::Lps] {
            let m = measure(model, 8, 5, false, 1).unwrap();
            assert_eq!(m.steps, 5);
            assert_eq!(m.points, 512);
            assert!(m.broken_bonds > 0, "{model:?}: no bond broke");
            assert!(m.loop_seconds > 0.0 && m.rate_per_core() > 0.0);
        }
    }

    #[test]
    fn final_time_gives_exactly_the_requested_step_count() {
        for steps in [1u64, 3, 100, 1000, 12345] {
            let final_time = (steps as f64 + 0.5) * TIME_STEP;
            assert_eq!((final_time / TIME_STEP).floor() as u64, steps);
        }
    }

    #[test]
    fn reads_lammps_screen_output() {
        // Lines as LAMMPS 2022 prints them for in.pdcheck.
        let text = "  total # of bonds = 2929168\n\
                    Loop time of 4.41234 on 1 procs for 100 steps with 27000 atoms\n\
                    \n\
                    99.7% CPU use with 1 MPI tasks x 1 OpenMP threads\n";
        let run = parse_lammps_output(text).unwrap();
        assert_eq!(run.loop_seconds, 4.41234);
        assert_eq!(run.procs, 1);
        assert_eq!(run.steps, 100);
        assert_eq!(run.bonds, Some(2_929_168));
        assert_eq!(run.cpu_percent, Some(99.7));
        assert!((run.ms_per_step() - 44.1234).abs() < 1e-9);
        assert!(parse_lammps_output("ERROR: Unknown pair style\n").is_none());
    }

    #[test]
    fn median_of_odd_and_even_lists() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 3.0, 2.0]), 2.5);
    }

    #[test]
    fn contact_row_is_a_deck_section() {
        let with = deck_yaml(BenchModel::Pmb, 4, 1, true);
        let without = deck_yaml(BenchModel::Pmb, 4, 1, false);
        assert_eq!(with, format!("{without}{CONTACT_SECTION}"));
        let deck = deck::parse_str(&with, DeckFormat::Yaml, Path::new("<test>")).unwrap();
        assert!(deck.contact.is_some());
    }
}
