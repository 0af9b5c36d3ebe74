//! `cargo xtask peridigm-regression`: Peridigm's regression decks against its gold files.

mod deck;
mod series;

use crate::process::Finished;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// The command's help.
pub const HELP: &str = "\
usage: cargo xtask peridigm-regression [PERIDIGM] [--peridyn BIN] [--ranks N]
                                       [--backend {native,trilinos,petsc}] [--timeout S]
                                       [--strict] [--min-pass N] [--filter NAME] [--keep KEEP]

Run Peridigm's regression decks with peridyn and compare with Peridigm's gold files.

For every deck under <peridigm>/test/regression (sorted), prints one line:
  PASS         <test>/<deck>                       all outputs within the .comp tolerances
  FAIL         <test>/<deck>  <why>                a load error, a run error or a difference
  UNSUPPORTED  <test>/<deck>  <feature>            peridyn cannot run this deck yet (exact feature)
  NOGOLD       <test>/<deck>                       ran, but the snapshot has no gold file to compare
  SKIP         <test>/<deck>  <why>                the snapshot lacks an input file the deck needs
and a closing total. The decks are read from their own folder; outputs go to a scratch folder.

A folder with decks `<name>_Run1`, `<name>_Run2`, ... and `<name>_FullSimulation` is a restart
series (Peridigm's `Contact_Perforation_With_Restart`): the Run decks run one after the other in
one scratch folder (each continues from the restart files the one before wrote), and each Run
deck's outputs are compared, with the folder's .comp tolerances, with the frames of the
uninterrupted FullSimulation run at the same times (`peridyn diff --align-times`).

Exit status: 0 unless a deck crashed peridyn or failed to load (a bug either way);
with --strict also non-zero when any deck FAILs against its gold file; with --min-pass N
non-zero when fewer than N decks PASS (CI uses it so a deck that passed cannot silently stop).

positional arguments:
  PERIDIGM            Peridigm data folder (default: ../shared/peridigm beside the repository)

options:
  --peridyn BIN       peridyn binary (default: target/release or target/debug)
  --ranks N           run each deck on this many MPI ranks
  --backend B         backend of the implicit solver lists that do not name one
                      (peridyn run --backend): native, trilinos or petsc
  --timeout S         seconds per command (default 600)
  --strict            exit non-zero when any deck FAILs
  --min-pass N        exit non-zero when fewer decks PASS
  --filter NAME       only tests whose folder name contains this
  --keep KEEP         copy every deck's output files to KEEP/<test>/<deck>/
                      (compare two builds with cargo xtask compare-outputs)";

/// The options of one regression run.
#[derive(Clone, Debug)]
pub struct Options {
    /// Peridigm's data folder (holding `test/regression`).
    pub peridigm: PathBuf,
    /// The peridyn binary to run.
    pub peridyn: Option<String>,
    /// MPI ranks per deck.
    pub ranks: usize,
    /// `--backend` handed to `peridyn check` and `peridyn run`.
    pub backend: Option<String>,
    /// Limit per command.
    pub timeout: Duration,
    /// Whether any FAIL is an error.
    pub strict: bool,
    /// Fewer passing decks is an error.
    pub min_pass: usize,
    /// Only test folders whose name contains this.
    pub filter: String,
    /// Where to copy every deck's outputs.
    pub keep: Option<PathBuf>,
}

/// One deck's line: status, `<test>/<deck>`, why, and whether peridyn crashed or the deck
/// failed to load (a bug either way).
pub type Outcome = (&'static str, String, String, bool);

/// How one deck's (or series') commands are run: the binary and the options.
pub struct Runner<'a> {
    binary: String,
    options: &'a Options,
}

impl Runner<'_> {
    /// `--backend B` when one was given.
    fn backend_args(&self) -> Vec<String> {
        match &self.options.backend {
            Some(b) => vec!["--backend".into(), b.clone()],
            None => Vec::new(),
        }
    }

    /// Runs `peridyn <args>`; None past the time limit.
    fn peridyn(&self, args: &[String]) -> Option<Finished> {
        let mut command = vec![self.binary.clone()];
        command.extend_from_slice(args);
        self.run(command)
    }

    fn run(&self, command: Vec<String>) -> Option<Finished> {
        match crate::process::run_limited(&command, self.options.timeout) {
            Ok(finished) => finished,
            Err(e) => Some(Finished {
                code: 127,
                stdout: String::new(),
                stderr: format!("cannot start {}: {e}", command[0]),
            }),
        }
    }
}

/// The first line of a text that is not blank, without its surrounding whitespace.
pub fn first_line(text: &str) -> String {
    crate::source::lines(text)
        .into_iter()
        .map(str::trim)
        .find(|line| !line.is_empty())
        .unwrap_or("")
        .to_string()
}

/// The stdout of a command when it printed any, else its stderr (Python's `stdout or stderr`).
pub fn output_or_error(done: &Finished) -> &str {
    if done.stdout.is_empty() {
        &done.stderr
    } else {
        &done.stdout
    }
}

fn find_binary(explicit: Option<&str>) -> String {
    if let Some(binary) = explicit {
        return binary.to_string();
    }
    let repository = crate::repository();
    for profile in ["release", "debug"] {
        let candidate = repository.join("target").join(profile).join("peridyn");
        if candidate.exists() {
            return candidate.to_string_lossy().into_owned();
        }
    }
    let on_path = std::env::var_os("PATH").and_then(|paths| {
        std::env::split_paths(&paths)
            .map(|folder| folder.join("peridyn"))
            .find(|candidate| candidate.is_file())
    });
    on_path.map_or_else(|| "peridyn".into(), |p| p.to_string_lossy().into_owned())
}

/// Runs the command; returns its exit status.
pub fn main(args: &[String]) -> u8 {
    match parse(args) {
        Ok(options) => run(&options, &mut |line| println!("{line}")),
        Err(message) => {
            eprintln!("{message}\n\n{HELP}");
            2
        }
    }
}

fn parse(args: &[String]) -> Result<Options, String> {
    let mut options = Options {
        peridigm: crate::repository()
            .parent()
            .map_or_else(|| PathBuf::from(".."), Path::to_path_buf)
            .join("shared")
            .join("peridigm"),
        peridyn: None,
        ranks: 1,
        backend: None,
        timeout: Duration::from_secs(600),
        strict: false,
        min_pass: 0,
        filter: String::new(),
        keep: None,
    };
    let mut positional = Vec::new();
    let mut k = 0;
    while k < args.len() {
        let (flag, inline) = match args[k].split_once('=') {
            Some((flag, value)) if flag.starts_with("--") => (flag, Some(value.to_string())),
            _ => (args[k].as_str(), None),
        };
        let mut value = || -> Result<String, String> {
            if let Some(v) = inline.clone() {
                return Ok(v);
            }
            k += 1;
            args.get(k)
                .cloned()
                .ok_or(format!("argument {flag}: expected one argument"))
        };
        match flag {
            "-h" | "--help" => return Err(String::new()),
            "--peridyn" => options.peridyn = Some(value()?),
            "--ranks" => options.ranks = number(flag, &value()?)?,
            "--backend" => options.backend = Some(backend(&value()?)?),
            "--timeout" => options.timeout = seconds(&value()?)?,
            "--strict" => options.strict = true,
            "--min-pass" => options.min_pass = number(flag, &value()?)?,
            "--filter" => options.filter = value()?,
            "--keep" => options.keep = Some(PathBuf::from(value()?)),
            other if other.starts_with("--") => {
                return Err(format!("unrecognized arguments: {other}"))
            }
            other => positional.push(other.to_string()),
        }
        k += 1;
    }
    match positional.len() {
        0 => {}
        1 => options.peridigm = PathBuf::from(&positional[0]),
        _ => {
            return Err(format!(
                "unrecognized arguments: {}",
                positional[1..].join(" ")
            ))
        }
    }
    Ok(options)
}

fn number(flag: &str, text: &str) -> Result<usize, String> {
    text.parse()
        .map_err(|_| format!("argument {flag}: invalid int value: '{text}'"))
}

fn seconds(text: &str) -> Result<Duration, String> {
    text.parse::<f64>()
        .ok()
        .and_then(|s| Duration::try_from_secs_f64(s).ok())
        .ok_or(format!("argument --timeout: invalid float value: '{text}'"))
}

fn backend(text: &str) -> Result<String, String> {
    if ["native", "trilinos", "petsc"].contains(&text) {
        Ok(text.to_string())
    } else {
        Err(format!(
            "argument --backend: invalid choice: '{text}' (choose from 'native', 'trilinos', 'petsc')"
        ))
    }
}

/// Runs every selected deck, handing each printed line to `print`; returns the exit status.
pub fn run(options: &Options, print: &mut dyn FnMut(&str)) -> u8 {
    let root = options.peridigm.join("test").join("regression");
    if !root.is_dir() {
        eprintln!(
            "error: {} is not a folder; give the Peridigm data folder as the first argument",
            root.display()
        );
        return 2;
    }
    let runner = Runner {
        binary: find_binary(options.peridyn.as_deref()),
        options,
    };
    let statuses = ["PASS", "FAIL", "UNSUPPORTED", "NOGOLD", "SKIP"];
    let mut counts = [0usize; 5];
    let mut broken = false;
    for test_dir in test_folders(&root, &options.filter) {
        for (status, label, why, crashed) in run_folder(&runner, &test_dir) {
            counts[statuses.iter().position(|s| *s == status).unwrap_or(1)] += 1;
            broken |= crashed;
            print(format!("{status:<12} {label:<70} {why}").trim_end());
        }
    }
    print(&format!(
        "regression: {} pass, {} fail, {} unsupported, {} without gold, {} skipped",
        counts[0], counts[1], counts[2], counts[3], counts[4]
    ));
    if broken || (options.strict && counts[1] > 0) {
        return 1;
    }
    if counts[0] < options.min_pass {
        eprintln!(
            "error: {} decks pass, fewer than the {} expected",
            counts[0], options.min_pass
        );
        return 1;
    }
    0
}

fn test_folders(root: &Path, filter: &str) -> Vec<PathBuf> {
    let mut folders: Vec<PathBuf> = std::fs::read_dir(root)
        .map(|entries| entries.flatten().map(|e| e.path()).collect())
        .unwrap_or_default();
    folders.retain(|p| p.is_dir() && name_of(p).contains(filter));
    folders.sort();
    folders
}

/// The last component of a path, as text.
pub fn name_of(path: &Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// The outcomes of one test folder: its decks one by one, the Run decks of a restart series
/// together.
fn run_folder(runner: &Runner, test_dir: &Path) -> Vec<Outcome> {
    let mut decks: Vec<PathBuf> = std::fs::read_dir(test_dir)
        .map(|entries| entries.flatten().map(|e| e.path()).collect())
        .unwrap_or_default();
    decks.retain(|p| p.extension().is_some_and(|e| e == "xml" || e == "yaml"));
    decks.sort();
    let restart = series::restart_series(&decks);
    let mut lines = Vec::new();
    for deck in &decks {
        if restart
            .as_ref()
            .is_some_and(|(_, runs)| runs.contains(deck))
        {
            continue;
        }
        lines.push(deck::run_deck(runner, deck).unwrap_or_else(|| {
            (
                "FAIL",
                format!("{}/{}", name_of(test_dir), name_of(deck)),
                "timed out".into(),
                false,
            )
        }));
    }
    if let Some((full, runs)) = restart {
        match series::run_restart_series(runner, &full, &runs) {
            Some(outcomes) => lines.extend(outcomes),
            None => lines.extend(runs.iter().map(|d| {
                (
                    "FAIL",
                    format!("{}/{}", name_of(test_dir), name_of(d)),
                    "timed out".to_string(),
                    false,
                )
            })),
        }
    }
    lines
}

#[cfg(test)]
mod tests {
    use super::*;

    fn words(text: &str) -> Vec<String> {
        text.split_whitespace().map(String::from).collect()
    }

    #[test]
    fn options_read_as_the_python_runner_read_them() {
        let options = parse(&words(
            "data --ranks 2 --backend=petsc --min-pass 33 --strict --keep k",
        ))
        .unwrap();
        assert_eq!(options.peridigm, PathBuf::from("data"));
        assert_eq!(
            (options.ranks, options.backend.as_deref(), options.min_pass),
            (2, Some("petsc"), 33)
        );
        assert!(options.strict);
        assert_eq!(options.keep, Some(PathBuf::from("k")));
        assert!(parse(&words("--backend cuda"))
            .unwrap_err()
            .contains("invalid choice"));
        assert!(parse(&words("--ranks"))
            .unwrap_err()
            .contains("expected one argument"));
        assert!(parse(&words("--bogus")).is_err());
    }

    #[test]
    fn first_lines_skip_blank_ones() {
        assert_eq!(first_line("\n  \n  error: x  \nmore"), "error: x");
        assert_eq!(first_line(""), "");
    }
}
