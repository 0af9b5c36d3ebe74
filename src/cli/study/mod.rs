//! `peridyn study DECK`: runs a deck over a grid of variations and reports, per variant, what
//! it cost and how accurate it was, so users see what a finer grid, another solver or a larger
//! time step buys.
//!
//! * Variations (`--vary 'KEY PATH=V1,V2,…'`, repeated, and the deck's `Study → Vary`, which a
//!   `--vary` of the same key path replaces): any key
//!   of the deck, by its path in the deck's own spelling with keys joined by `.`, including keys
//!   inside `Solver` lists and `Blocks`. The grid is their product; every value is checked
//!   against the deck before anything runs (an unknown key path is invalid input, exit 2, with
//!   the deck's file, line and key path).
//! * Each variant is a child `peridyn run --set …` in `<folder>/variant_<k>` (its log in
//!   `run.log`), up to `--jobs` at once; a failure, a blow-up or a NaN is a row with its reason.
//! * Cost: wall time, CPU time (user + system) and peak resident memory of the child, steps, and
//!   the Newton and Krylov iterations of implicit runs (`<output>_solver.csv`).
//! * Error: of each `--measure` (see [`measure`]) at the final frame of the run's Exodus
//!   results, against the measure's `=EXACT` value or the finest run.
//! * Output: the table on standard output, `<folder>/study.csv`, and per measure
//!   `<folder>/error_<measure>.png` (error against wall time, Pareto front marked).
//!
//! The study itself exits 0 when every variant has a row, whatever the rows say; 2 for
//! invalid input; 1 when its folder cannot be written.

mod cost;
mod grid;
mod measure;
mod plot;
mod runner;
mod stable;
mod table;

use std::path::{Path, PathBuf};

use peridyn::io::deck::{self, Variation};

use measure::{Measure, Reference};
use runner::Outcome;
use table::{number, Cell, Table};

/// Command-line options of `peridyn study`.
#[derive(Debug, Clone, clap::Args)]
pub struct StudyArgs {
    /// The deck (YAML or XML). Its `Study` section, if any, gives variations and measures too.
    pub deck: PathBuf,
    /// A variation, `KEY PATH=V1,V2,…` (e.g. `Blocks.My Block.Horizon=0.2,0.3`); may be
    /// repeated: the study runs every combination. Keys that change together: `KEY PATH &
    /// KEY PATH=A1 & B1,A2 & B2`.
    #[arg(long = "vary", value_name = "KEY PATH=V1,V2,…")]
    pub vary: Vec<String>,
    /// A measured quantity at the final frame: `global:NAME` (a global variable),
    /// `mean:FIELD@NODE SET` (a nodal variable's mean over a node set, `@all` for every
    /// point) or `modulus:AREA[:AXIS]` (Young's modulus of a tensile test, as `peridyn
    /// modulus`), with `=EXACT` for an analytic value (default reference: the finest run);
    /// may be repeated.
    #[arg(long = "measure", value_name = "MEASURE")]
    pub measure: Vec<String>,
    /// Runs at once (default: cores / threads per run).
    #[arg(long)]
    pub jobs: Option<usize>,
    /// Worker threads of each run (default 1).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Folder of the study's runs, CSV and plots (default: `study_<deck name>`).
    #[arg(long)]
    pub output_dir: Option<PathBuf>,
    /// Instead of a grid: find the largest stable time step of an explicit deck by bisection
    /// on its Safety Factor (the run's stability monitor decides), against the stable estimate.
    #[arg(long, conflicts_with_all = ["vary", "measure"])]
    pub stable_dt: bool,
    /// `--stable-dt`: stop when the stable and unstable Safety Factors differ by less than
    /// this fraction.
    #[arg(long, default_value_t = 0.02)]
    pub tolerance: f64,
}

/// Why a study could not be carried out.
#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    /// Bad deck, variation or measure (exit 2).
    #[error("{0}")]
    Input(String),
    /// The study's folder or files cannot be written (exit 1).
    #[error("{0}")]
    Output(String),
}

/// Runs the study and returns the table for the terminal.
pub fn main(args: &StudyArgs) -> Result<String, StudyError> {
    let input = StudyError::Input;
    let deck = deck::load(&args.deck).map_err(|e| input(e.to_string()))?;
    if args.stable_dt {
        return stable_dt(args, &deck);
    }
    let section = deck.study.clone().unwrap_or_default();
    let variations = variations(args, &section)?;
    let measures = measures(args, &section)?;
    grid::check(&args.deck, &variations).map_err(input)?;
    let (threads, jobs) = workers(args, &section)?;
    let (folder, executable) = prepare(args)?;
    let variants = grid::product(&variations);
    eprintln!(
        "study: {} variant(s) of {}, {jobs} at a time, {threads} thread(s) each, in {}",
        variants.len(),
        args.deck.display(),
        folder.display()
    );
    let setup = runner::Setup {
        executable,
        deck: &args.deck,
        folder: &folder,
        threads,
        variations: &variations,
        measures: &measures,
    };
    let outcomes = runner::run_all(&setup, variants, jobs);
    let references: Vec<Option<Reference>> = measures
        .iter()
        .enumerate()
        .map(|(m, measure)| {
            let runs: Vec<(Option<u64>, Option<f64>)> =
                outcomes.iter().map(|o| (o.points, value(o, m))).collect();
            measure::reference(measure.exact, &runs)
        })
        .collect();
    let table = build_table(&variations, &measures, &outcomes, &references);
    let csv = write_csv(&folder, "study.csv", &table)?;
    let mut report = table.render();
    report.push('\n');
    for (measure, reference) in measures.iter().zip(&references) {
        report.push_str(&describe_reference(measure, reference.as_ref(), &outcomes));
    }
    report.push_str(&format!("wrote {}\n", csv.display()));
    for (m, measure) in measures.iter().enumerate() {
        if let Some(reference) = references[m] {
            report.push_str(&plot_errors(&folder, m, measure, reference, &outcomes)?);
        }
    }
    Ok(report)
}

/// The deck's `Study → Vary` entries with the command line's `--vary` ones: a `--vary` of a
/// key path the deck varies too replaces the deck's; a key path varied twice is invalid input.
fn variations(args: &StudyArgs, section: &deck::Study) -> Result<Vec<Variation>, StudyError> {
    let input = StudyError::Input;
    let mut variations = section.variations.clone();
    let mut given = Vec::new();
    for text in &args.vary {
        let variation = Variation::parse(text).map_err(|e| input(format!("--vary {e}")))?;
        if given.contains(&variation.path) {
            return Err(input(format!(
                "--vary: the key path \"{}\" is varied twice; give all its values in one --vary",
                variation.name()
            )));
        }
        given.push(variation.path.clone());
        // The command line replaces the deck's variation of the same key.
        match variations.iter_mut().find(|v| v.path == variation.path) {
            Some(from_deck) => *from_deck = variation,
            None => variations.push(variation),
        }
    }
    for (k, variation) in variations.iter().enumerate() {
        if variations[..k].iter().any(|v| v.path == variation.path) {
            return Err(input(format!(
                "{}: Study → Vary: the key path \"{}\" is varied twice; give all its values in one entry",
                args.deck.display(),
                variation.name()
            )));
        }
    }
    Ok(variations)
}

/// The deck's `Study → Measure` entries, then the command line's `--measure` ones.
fn measures(args: &StudyArgs, section: &deck::Study) -> Result<Vec<Measure>, StudyError> {
    let input = StudyError::Input;
    let mut measures = Vec::new();
    for (label, text) in &section.measures {
        measures.push(Measure::parse(label, text).map_err(|e| {
            input(format!(
                "{}: Study → Measure → {label}: {e}",
                args.deck.display()
            ))
        })?);
    }
    for text in &args.measure {
        let label = text.split('=').next().unwrap_or(text).trim();
        measures.push(Measure::parse(label, text).map_err(|e| input(format!("--measure {e}")))?);
    }
    Ok(measures)
}

/// Threads per run and runs at once: the command line's, else the deck's, else one thread per
/// run and as many runs as the cores hold.
fn workers(args: &StudyArgs, section: &deck::Study) -> Result<(usize, usize), StudyError> {
    let threads = args.threads.or(section.threads).unwrap_or(1);
    let cores = std::thread::available_parallelism().map_or(1, usize::from);
    let jobs = args
        .jobs
        .or(section.jobs)
        .unwrap_or((cores / threads.max(1)).max(1));
    if threads == 0 || jobs == 0 {
        return Err(StudyError::Input(
            "--threads and --jobs must be at least 1".to_string(),
        ));
    }
    Ok((threads, jobs))
}

/// `<folder>/<name>`, written with the table's CSV.
fn write_csv(folder: &Path, name: &str, table: &Table) -> Result<PathBuf, StudyError> {
    let csv = folder.join(name);
    std::fs::write(&csv, table.csv())
        .map_err(|e| StudyError::Output(format!("{}: cannot write: {e}", csv.display())))?;
    Ok(csv)
}

/// The report's line on what `measure`'s errors are measured against.
fn describe_reference(
    measure: &Measure,
    reference: Option<&Reference>,
    outcomes: &[Outcome],
) -> String {
    match reference {
        Some(Reference::Exact(value)) => {
            format!(
                "{}: error against the exact value {value:e}\n",
                measure.label
            )
        }
        Some(Reference::Finest { value, run }) => format!(
            "{}: error against the finest run, variant {} ({} points): {value:e}\n",
            measure.label,
            outcomes[*run].variant.index,
            outcomes[*run]
                .points
                .map_or_else(|| "?".to_string(), |p| p.to_string())
        ),
        None => format!("{}: no run gave a value\n", measure.label),
    }
}

/// Draws `<folder>/error_<measure>.png`, the error of measure `m` against wall time, and
/// returns the report's line on it.
fn plot_errors(
    folder: &Path,
    m: usize,
    measure: &Measure,
    reference: Reference,
    outcomes: &[Outcome],
) -> Result<String, StudyError> {
    let points: Vec<(f64, f64)> = outcomes
        .iter()
        .filter_map(|o| {
            value(o, m).map(|v| (o.cost.wall_seconds, measure::error(v, reference.value())))
        })
        .collect();
    let path = folder.join(format!("error_{}.png", slug(&measure.label)));
    let drawn = plot::error_against_time(&path, &points).map_err(|e| {
        StudyError::Output(format!("{}: cannot write the plot: {e}", path.display()))
    })?;
    Ok(if drawn > 0 {
        format!("wrote {}\n", path.display())
    } else {
        format!("{}: no run with a positive error, no plot\n", measure.label)
    })
}

/// The study's folder (created) and the `peridyn` executable the variants run.
fn prepare(args: &StudyArgs) -> Result<(PathBuf, PathBuf), StudyError> {
    let folder = args.output_dir.clone().unwrap_or_else(|| {
        let stem = args
            .deck
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or("deck");
        PathBuf::from(format!("study_{stem}"))
    });
    std::fs::create_dir_all(&folder).map_err(|e| {
        StudyError::Output(format!(
            "{}: cannot create the folder: {e}",
            folder.display()
        ))
    })?;
    let executable = std::env::current_exe()
        .map_err(|e| StudyError::Output(format!("cannot find the peridyn executable: {e}")))?;
    Ok((folder, executable))
}

/// `--stable-dt`: the bisection of [`stable`], its table, `stable_dt.csv` and the bracket.
fn stable_dt(args: &StudyArgs, deck: &deck::Deck) -> Result<String, StudyError> {
    let path = stable::safety_factor_path(deck).map_err(StudyError::Input)?;
    if !(args.tolerance > 0.0 && args.tolerance < 1.0) {
        return Err(StudyError::Input(format!(
            "--tolerance {}: give a fraction between 0 and 1, e.g. 0.02",
            args.tolerance
        )));
    }
    let threads = args.threads.unwrap_or(1);
    if threads == 0 {
        return Err(StudyError::Input(
            "--threads must be at least 1".to_string(),
        ));
    }
    let (folder, executable) = prepare(args)?;
    eprintln!(
        "study: largest stable Safety Factor of {} ({}), in {}",
        args.deck.display(),
        path.join(" → "),
        folder.display()
    );
    let setup = runner::Setup {
        executable,
        deck: &args.deck,
        folder: &folder,
        threads,
        variations: &[],
        measures: &[],
    };
    let trials = stable::search(&setup, &path, args.tolerance)?;
    let table = stable::table(&trials);
    let csv = write_csv(&folder, "stable_dt.csv", &table)?;
    let mut report = table.render();
    report.push('\n');
    report.push_str(&stable::summary(&trials));
    report.push_str(&format!("wrote {}\n", csv.display()));
    Ok(report)
}

/// The value of measure `m` of a successful run.
fn value(outcome: &Outcome, m: usize) -> Option<f64> {
    if outcome.failure.is_some() {
        return None;
    }
    outcome.values.get(m).and_then(|v| v.as_ref().ok()).copied()
}

/// `label` with every character but letters and digits replaced by `_`, for file names.
fn slug(label: &str) -> String {
    label
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect()
}

/// A variation's column name: its last key, or the whole path when two share a last key.
fn column_name(variations: &[Variation], k: usize) -> String {
    let last = variations[k].path.last().cloned().unwrap_or_default();
    let shared = variations
        .iter()
        .filter(|v| v.path.last() == Some(&last))
        .count()
        > 1;
    if shared {
        variations[k].name()
    } else {
        last
    }
}

/// The status word of a failure reason (see [`runner::run_one`]).
fn status(failure: Option<&str>) -> &'static str {
    match failure {
        None => "ok",
        Some(reason) if reason.starts_with("unstable") => "unstable",
        Some(reason) if reason.starts_with("killed") => "killed",
        Some(reason) if reason.contains("not finite") => "nan",
        Some(_) => "failed",
    }
}

/// Terminal width of the reason column.
const REASON_WIDTH: usize = 60;

fn build_table(
    variations: &[Variation],
    measures: &[Measure],
    outcomes: &[Outcome],
    references: &[Option<Reference>],
) -> Table {
    let mut header = vec!["variant".to_string()];
    header.extend((0..variations.len()).map(|k| column_name(variations, k)));
    header.extend(
        [
            "status", "points", "wall_s", "cpu_s", "peak_MiB", "steps", "newton", "krylov",
        ]
        .map(String::from),
    );
    for measure in measures {
        header.push(measure.label.clone());
        header.push(format!("{} error", measure.label));
    }
    header.push("reason".to_string());
    header.push("folder".to_string());
    let count = |n: Option<u64>| n.map_or_else(String::new, |n| n.to_string());
    let rows = outcomes
        .iter()
        .map(|o| {
            let mut row = vec![Cell::new(o.variant.index.to_string())];
            row.extend(o.variant.values.iter().map(Cell::new));
            row.push(Cell::new(status(o.failure.as_deref())));
            row.push(Cell::new(count(o.points)));
            row.push(Cell::new(number(Some(o.cost.wall_seconds))));
            row.push(Cell::new(number(o.cost.cpu_seconds)));
            row.push(Cell::new(number(
                o.cost.peak_rss_bytes.map(|b| b as f64 / 1048576.0),
            )));
            row.push(Cell::new(count(o.cost.steps)));
            row.push(Cell::new(count(o.cost.newton_iterations)));
            row.push(Cell::new(count(o.cost.krylov_iterations)));
            let mut reasons: Vec<String> = o.failure.iter().cloned().collect();
            for (m, measure) in measures.iter().enumerate() {
                match (o.failure.is_none(), o.values.get(m)) {
                    (true, Some(Ok(v))) => {
                        row.push(Cell {
                            short: format!("{v:.6e}"),
                            full: format!("{v:e}"),
                        });
                        let error = references[m].map(|r| measure::error(*v, r.value()));
                        row.push(Cell::new(number(error)));
                    }
                    (true, Some(Err(why))) => {
                        reasons.push(format!("{}: {why}", measure.label));
                        row.push(Cell::new(""));
                        row.push(Cell::new(""));
                    }
                    _ => {
                        row.push(Cell::new(""));
                        row.push(Cell::new(""));
                    }
                }
            }
            let reason = reasons.join("; ");
            let short = if reason.chars().count() > REASON_WIDTH {
                let cut: String = reason.chars().take(REASON_WIDTH - 1).collect();
                format!("{cut}…")
            } else {
                reason.clone()
            };
            row.push(Cell {
                short,
                full: reason,
            });
            row.push(Cell::new(o.folder.display().to_string()));
            row
        })
        .collect();
    let folder_column = header.len() - 1;
    Table {
        header,
        rows,
        csv_only: vec![folder_column],
    }
}
