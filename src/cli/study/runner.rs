//! Running the variants: each one a `peridyn run --set …` child process in its own folder
//! (`variant_<k>`, its standard output and error in `run.log`), up to `jobs` at once. A run
//! that fails, blows up or is killed is an outcome like any other, never an abort of the study.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::Mutex;
use std::time::Instant;

use peridyn::io::deck::Variation;
use peridyn::io::exodus::ExodusFile;

use super::cost::{self, Cost, Exit};
use super::grid::Variant;
use super::measure::Measure;

/// What every variant shares.
pub struct Setup<'a> {
    /// The `peridyn` executable (this one).
    pub executable: PathBuf,
    /// The deck, as given on the command line.
    pub deck: &'a Path,
    /// The study's folder; each variant writes to a subfolder.
    pub folder: &'a Path,
    /// Worker threads of each run.
    pub threads: usize,
    /// The variations.
    pub variations: &'a [Variation],
    /// The measured quantities.
    pub measures: &'a [Measure],
}

/// The result of one variant.
#[derive(Debug, Clone)]
pub struct Outcome {
    /// The variant.
    pub variant: Variant,
    /// Its output folder.
    pub folder: PathBuf,
    /// What the run cost.
    pub cost: Cost,
    /// Points of the body (from the run's log).
    pub points: Option<u64>,
    /// The Silling–Askari stable time step estimate of an explicit run (s, from its log).
    pub stable_estimate: Option<f64>,
    /// Each measure's value, or why it could not be read.
    pub values: Vec<Result<f64, String>>,
    /// Why the variant failed (`None`: it ran to the end and every value is finite).
    pub failure: Option<String>,
}

/// Runs `variants`, `jobs` at a time, and returns their outcomes in grid order.
pub fn run_all(setup: &Setup, variants: Vec<Variant>, jobs: usize) -> Vec<Outcome> {
    let total = variants.len();
    let queue = Mutex::new(variants.into_iter());
    let outcomes = Mutex::new(Vec::with_capacity(total));
    std::thread::scope(|scope| {
        for _ in 0..jobs.max(1) {
            scope.spawn(|| loop {
                let next = queue.lock().map(|mut q| q.next()).unwrap_or(None);
                let Some(variant) = next else { break };
                let outcome = run_one(setup, variant);
                eprintln!(
                    "study: {} {}",
                    outcome.folder.display(),
                    outcome.failure.as_deref().unwrap_or("ok")
                );
                if let Ok(mut done) = outcomes.lock() {
                    done.push(outcome);
                }
            });
        }
    });
    let mut outcomes = outcomes.into_inner().unwrap_or_default();
    outcomes.sort_by_key(|o| o.variant.index);
    outcomes
}

/// Runs one variant to its end and reads its cost and measures.
pub fn run_one(setup: &Setup, variant: Variant) -> Outcome {
    let folder = setup.folder.join(format!("variant_{:03}", variant.index));
    let mut outcome = Outcome {
        variant,
        folder: folder.clone(),
        cost: Cost::default(),
        points: None,
        stable_estimate: None,
        values: Vec::new(),
        failure: None,
    };
    let log_path = folder.join("run.log");
    let started = std::fs::create_dir_all(&folder)
        .and_then(|()| std::fs::File::create(&log_path))
        .and_then(|log| Ok((log.try_clone()?, log)))
        .and_then(|(out, err)| {
            let mut command = Command::new(&setup.executable);
            command
                .arg("run")
                .arg(setup.deck)
                .arg("--output-dir")
                .arg(&folder)
                .arg("--threads")
                .arg(setup.threads.to_string());
            for set in outcome.variant.set_arguments(setup.variations) {
                command.arg("--set").arg(set);
            }
            let start = Instant::now();
            let child = command
                .stdin(Stdio::null())
                .stdout(out)
                .stderr(err)
                .spawn()?;
            cost::wait(child, start)
        });
    let (exit, measured) = match started {
        Ok(result) => result,
        Err(e) => {
            outcome.failure = Some(format!("cannot run: {e}"));
            return outcome;
        }
    };
    outcome.cost = measured;
    let log = cost::read_log(&std::fs::read_to_string(&log_path).unwrap_or_default());
    outcome.cost.steps = log.steps;
    outcome.points = log.points;
    outcome.stable_estimate = log.stable_estimate;
    let (newton, krylov) =
        solver_csv(&folder).map_or((None, None), |p| cost::solver_iterations(&p));
    outcome.cost.newton_iterations = newton;
    outcome.cost.krylov_iterations = krylov;
    let reason = || {
        log.error
            .clone()
            .unwrap_or_else(|| format!("see {}", log_path.display()))
    };
    outcome.failure = match exit {
        Exit::Code(0) => None,
        Exit::Code(3) => Some(format!("unstable or not converged (exit 3): {}", reason())),
        Exit::Code(code) => Some(format!("failed (exit {code}): {}", reason())),
        Exit::Signal(signal) => Some(format!("killed by signal {signal}")),
    };
    if outcome.failure.is_some() || setup.measures.is_empty() {
        return outcome;
    }
    let results = log.files.iter().find(|f| {
        matches!(
            f.extension().and_then(|e| e.to_str()),
            Some("e") | Some("h")
        )
    });
    outcome.values = match results.map(|path| ExodusFile::open(path)) {
        Some(Ok(file)) => setup.measures.iter().map(|m| m.evaluate(&file)).collect(),
        Some(Err(e)) => vec![Err(e.to_string()); setup.measures.len()],
        None => vec![
            Err("the run wrote no Exodus results (no Output list)".to_string());
            setup.measures.len()
        ],
    };
    if let Some((measure, _)) = setup
        .measures
        .iter()
        .zip(&outcome.values)
        .find(|(_, v)| matches!(v, Ok(x) if !x.is_finite()))
    {
        outcome.failure = Some(format!("{} is not finite (NaN or infinite)", measure.label));
    }
    outcome
}

/// The `<output>_solver.csv` an implicit run writes into its folder, if any.
fn solver_csv(folder: &Path) -> Option<PathBuf> {
    std::fs::read_dir(folder)
        .ok()?
        .filter_map(Result::ok)
        .map(|e| e.path())
        .find(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.ends_with("_solver.csv"))
        })
}
