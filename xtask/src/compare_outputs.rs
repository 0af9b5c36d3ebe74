//! `cargo xtask compare-outputs`: two trees of run outputs, file by file.

use crate::source::lines;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// The command's help.
pub const HELP: &str = "\
usage: cargo xtask compare-outputs BEFORE_DIR AFTER_DIR

Compare two trees of run outputs file by file: byte-identical, or say where they differ.

Used to prove that a refactor changed nothing: run the regression decks (or any decks) with
the old and the new binary, keeping their outputs (`cargo xtask peridigm-regression --keep
DIR`), then compare the two trees. Every file must exist in both trees and be byte-identical,
except for the columns of `*_solver.csv` that measure the machine rather than the answer
(`Seconds`, `Preconditioner_Setup_Seconds`), which are dropped before comparing. Prints one
line per problem and `N files compared, M differences`. Exit status 0 when everything
matches, 1 otherwise.";

/// The columns of a solver CSV that measure the machine, not the answer.
const MACHINE_COLUMNS: [&str; 2] = ["Seconds", "Preconditioner_Setup_Seconds"];

/// What two trees' comparison found.
pub struct Comparison {
    /// Files present in both trees.
    pub compared: usize,
    /// One line per file missing from a side or differing.
    pub problems: Vec<String>,
}

/// Compares every file of the two trees.
pub fn compare(before: &Path, after: &Path) -> Comparison {
    let files_before = files_under(before);
    let files_after = files_under(after);
    let mut problems = Vec::new();
    for rel in files_before.difference(&files_after) {
        problems.push(format!("only before: {}", rel.display()));
    }
    for rel in files_after.difference(&files_before) {
        problems.push(format!("only after:  {}", rel.display()));
    }
    let mut compared = 0;
    for rel in files_before.intersection(&files_after) {
        compared += 1;
        if !same(&before.join(rel), &after.join(rel)) {
            problems.push(format!("differs:     {}", rel.display()));
        }
    }
    Comparison { compared, problems }
}

/// Runs the command; returns its exit status.
pub fn main(args: &[String]) -> u8 {
    if args.len() != 2 {
        eprintln!("{HELP}");
        return 2;
    }
    report(&compare(Path::new(&args[0]), Path::new(&args[1])))
}

/// Prints a comparison; returns the exit status it means.
pub fn report(comparison: &Comparison) -> u8 {
    for line in &comparison.problems {
        println!("{line}");
    }
    println!(
        "{} files compared, {} differences",
        comparison.compared,
        comparison.problems.len()
    );
    u8::from(!comparison.problems.is_empty())
}

/// The files under `root` (symbolic links to files included), relative to it, in path order.
fn files_under(root: &Path) -> BTreeSet<PathBuf> {
    let mut found = BTreeSet::new();
    let mut folders = vec![root.to_path_buf()];
    while let Some(folder) = folders.pop() {
        let Ok(entries) = std::fs::read_dir(&folder) else {
            continue;
        };
        for entry in entries.flatten() {
            let path = entry.path();
            let is_link = entry.file_type().is_ok_and(|kind| kind.is_symlink());
            if path.is_dir() && !is_link {
                folders.push(path);
            } else if path.is_file() {
                if let Ok(rel) = path.strip_prefix(root) {
                    found.insert(rel.to_path_buf());
                }
            }
        }
    }
    found
}

fn same(a: &Path, b: &Path) -> bool {
    let name = a
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let (Ok(bytes_a), Ok(bytes_b)) = (std::fs::read(a), std::fs::read(b)) else {
        return false;
    };
    if name.ends_with("_solver.csv") {
        return solver_csv_without_timings(&bytes_a) == solver_csv_without_timings(&bytes_b);
    }
    bytes_a == bytes_b
}

/// A solver CSV's rows without the columns of [`MACHINE_COLUMNS`] (chosen by the header).
fn solver_csv_without_timings(bytes: &[u8]) -> Vec<String> {
    let text = String::from_utf8_lossy(bytes);
    let rows = lines(&text);
    let Some(header) = rows.first() else {
        return Vec::new();
    };
    let keep: Vec<usize> = header
        .split(',')
        .enumerate()
        .filter(|(_, name)| !MACHINE_COLUMNS.contains(&name.trim()))
        .map(|(k, _)| k)
        .collect();
    rows.iter()
        .map(|row| {
            let cells: Vec<&str> = row.split(',').collect();
            let kept: Vec<&str> = keep.iter().filter_map(|&k| cells.get(k).copied()).collect();
            kept.join(",")
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn timing_columns_of_solver_csvs_are_dropped() {
        let a = b"Time,Seconds,Newton\n1,0.5,3\n";
        let b = b"Time,Seconds,Newton\n1,0.7,3\n";
        let c = b"Time,Seconds,Newton\n1,0.5,4\n";
        assert_eq!(solver_csv_without_timings(a), solver_csv_without_timings(b));
        assert_ne!(solver_csv_without_timings(a), solver_csv_without_timings(c));
        assert_eq!(solver_csv_without_timings(a), vec!["Time,Newton", "1,3"]);
    }
}
