//! `cargo xtask refactor-check`: the same decks with the binary before and after a change,
//! every output file compared byte for byte.

use crate::regression::Options;
use std::os::unix::process::ExitStatusExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

/// The command's help.
pub const HELP: &str = "\
usage: cargo xtask refactor-check BEFORE_BIN AFTER_BIN [--backend trilinos] [--ranks N] [--out DIR]

Proves a refactor changed nothing: runs Peridigm's regression decks and peridyn's examples
with a binary built before the change and one built after it, and compares every output
file byte for byte (cargo xtask compare-outputs; solver wall times aside).

Both binaries must be built with the same features (e.g. `--features trilinos` for
`--backend trilinos`, `--features mpi,trilinos` for `--ranks 2`). The regression decks are
read from ../shared/peridigm beside the repository, or from $PERIDIGM_DATA (a folder holding
Peridigm's test/regression). Outputs are kept in DIR/before and DIR/after, the examples' logs
(which hold timings) in DIR/logs-before and DIR/logs-after (default DIR: a new temporary
folder). Exit status 0 when every output file is identical.";

/// The examples that run in seconds (the fragmenting cylinder takes about a minute).
const EXAMPLES: [&str; 3] = ["wave_in_bar", "quasi_static_tension", "disk_impact"];

struct CheckOptions {
    before: PathBuf,
    after: PathBuf,
    backend: Option<String>,
    ranks: usize,
    out: Option<PathBuf>,
}

fn parse(args: &[String]) -> Result<CheckOptions, String> {
    let [before, after, rest @ ..] = args else {
        return Err(String::new());
    };
    let mut options = CheckOptions {
        before: absolute(Path::new(before)),
        after: absolute(Path::new(after)),
        backend: None,
        ranks: 1,
        out: None,
    };
    let mut k = 0;
    while k < rest.len() {
        let value = rest
            .get(k + 1)
            .ok_or(format!("{} needs a value", rest[k]))?;
        match rest[k].as_str() {
            "--backend" => options.backend = Some(value.clone()),
            "--ranks" => {
                options.ranks = value
                    .parse()
                    .map_err(|_| format!("--ranks {value}: not a number"))?
            }
            "--out" => options.out = Some(absolute(Path::new(value))),
            other => return Err(format!("unknown option {other}")),
        }
        k += 2;
    }
    Ok(options)
}

fn absolute(path: &Path) -> PathBuf {
    if path.is_absolute() {
        return path.to_path_buf();
    }
    std::env::current_dir().map_or_else(|_| path.to_path_buf(), |cwd| cwd.join(path))
}

/// Runs the command; returns its exit status.
pub fn main(args: &[String]) -> u8 {
    let options = match parse(args) {
        Ok(options) => options,
        Err(message) => {
            eprintln!("{message}\n\n{HELP}");
            return 2;
        }
    };
    let scratch;
    let out = match &options.out {
        Some(out) => out.clone(),
        None => match crate::process::Scratch::new("refactor-check-") {
            Ok(folder) => {
                scratch = folder;
                // Kept: the outputs are the evidence when something differs.
                let path = scratch.path().to_path_buf();
                std::mem::forget(scratch);
                path
            }
            Err(e) => {
                eprintln!("error: no temporary folder: {e}");
                return 2;
            }
        },
    };
    let repository = crate::repository();
    let data = std::env::var_os("PERIDIGM_DATA").map_or_else(
        || repository.join("..").join("shared").join("peridigm"),
        |d| absolute(Path::new(&d)),
    );
    for (side, binary) in [("before", &options.before), ("after", &options.after)] {
        if let Err(status) = run_side(&options, &repository, &data, &out, side, binary) {
            return status;
        }
    }
    let comparison = crate::compare_outputs::compare(&out.join("before"), &out.join("after"));
    crate::compare_outputs::report(&comparison)
}

/// Runs the regression decks and the examples with one binary into `out/<side>`.
fn run_side(
    options: &CheckOptions,
    repository: &Path,
    data: &Path,
    out: &Path,
    side: &str,
    binary: &Path,
) -> Result<(), u8> {
    let outputs = out.join(side);
    let logs = out.join(format!("logs-{side}"));
    let _ = std::fs::remove_dir_all(&outputs);
    let _ = std::fs::remove_dir_all(&logs);
    let created =
        std::fs::create_dir_all(outputs.join("examples")).and(std::fs::create_dir_all(&logs));
    if let Err(e) = created {
        eprintln!("error: cannot create {}: {e}", outputs.display());
        return Err(2);
    }
    if data.is_dir() {
        let regression = Options {
            peridigm: data.to_path_buf(),
            peridyn: Some(binary.to_string_lossy().into_owned()),
            ranks: options.ranks,
            backend: options.backend.clone(),
            timeout: Duration::from_secs(600),
            strict: false,
            min_pass: 0,
            filter: String::new(),
            keep: Some(outputs.join("regression")),
        };
        // Only the closing total is shown, as the script showed `| tail -1`.
        let mut last = String::new();
        let status = crate::regression::run(&regression, &mut |line| last = line.to_string());
        println!("{last}");
        if status != 0 {
            return Err(status);
        }
    }
    for deck in EXAMPLES {
        if deck == "disk_impact" && !repository.join("examples/disk_impact.txt").exists() {
            continue;
        }
        if let Some(code) = run_example(options, repository, binary, deck, &outputs, &logs) {
            println!("{side}: {deck} exit {code}");
        }
    }
    Ok(())
}

/// Runs one example from the repository's top folder, its log to `logs/<deck>.log`; the exit
/// code when it failed.
fn run_example(
    options: &CheckOptions,
    repository: &Path,
    binary: &Path,
    deck: &str,
    outputs: &Path,
    logs: &Path,
) -> Option<i32> {
    let mut command = if options.ranks > 1 {
        let mut mpirun = Command::new("mpirun");
        mpirun
            .args(["-np", &options.ranks.to_string(), "--oversubscribe"])
            .arg(binary);
        mpirun
    } else {
        Command::new(binary)
    };
    command
        .arg("run")
        .arg(format!("examples/{deck}.yaml"))
        .arg("--output-dir")
        .arg(outputs.join("examples").join(deck));
    if let Some(backend) = &options.backend {
        command.args(["--backend", backend]);
    }
    let log = std::fs::File::create(logs.join(format!("{deck}.log"))).ok()?;
    let log_err = log.try_clone().ok()?;
    let status = command
        .current_dir(repository)
        .stdin(Stdio::null())
        .stdout(log)
        .stderr(log_err)
        .status();
    match status {
        Ok(status) if status.success() => None,
        // As the shell's `$?` shows it: 128 + the signal's number for a signal.
        Ok(status) => Some(
            status
                .code()
                .unwrap_or_else(|| 128 + status.signal().unwrap_or(0)),
        ),
        Err(_) => Some(127),
    }
}
