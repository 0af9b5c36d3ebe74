//! A restart series: Run decks one after the other, each against the uninterrupted run.

use super::deck::{
    comp_args, gold_and_comp, keep_outputs, no_scratch_folder, output_files, plan_of, shown,
    unsupported,
};
use super::{first_line, name_of, output_or_error, Outcome, Runner};
use crate::process::Scratch;
use std::path::{Path, PathBuf};

/// The number N of a deck stem ending in `_RunN`.
fn run_number(stem: &str) -> Option<u64> {
    let (_, digits) = stem.rsplit_once("_Run")?;
    (!digits.is_empty() && digits.bytes().all(|b| b.is_ascii_digit()))
        .then(|| digits.parse().ok())?
}

fn stem_of(deck: &Path) -> String {
    deck.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// The uninterrupted deck and the Run decks (in run order) of a restart series in one
/// folder, or None.
pub fn restart_series(decks: &[PathBuf]) -> Option<(PathBuf, Vec<PathBuf>)> {
    let mut runs: Vec<PathBuf> = decks
        .iter()
        .filter(|d| run_number(&stem_of(d)).is_some())
        .cloned()
        .collect();
    let full: Vec<&PathBuf> = decks
        .iter()
        .filter(|d| stem_of(d).ends_with("_FullSimulation"))
        .collect();
    if runs.is_empty() || full.len() != 1 {
        return None;
    }
    runs.sort_by_key(|d| run_number(&stem_of(d)));
    Some((full[0].clone(), runs))
}

/// Checks every deck of the series; the plans, or the outcome every Run deck gets when one
/// cannot run. None past the time limit.
fn plans(
    runner: &Runner,
    full: &Path,
    runs: &[PathBuf],
    all_runs: &dyn Fn(&'static str, String, bool) -> Vec<Outcome>,
) -> Option<Result<Vec<crate::json::Json>, Vec<Outcome>>> {
    let mut plans = Vec::new();
    for deck in std::iter::once(&full.to_path_buf()).chain(runs) {
        let mut args = vec!["check".into(), shown(deck), "--json".into()];
        args.extend(runner.backend_args());
        let check = runner.peridyn(&args)?;
        if check.code == 2 && check.stderr.contains("`hdf5` feature") {
            return Some(Err(all_runs(
                "UNSUPPORTED",
                "Restart (a build without the `hdf5` feature)".into(),
                false,
            )));
        }
        if check.code != 0 {
            let why = format!(
                "{} does not load: {}",
                name_of(deck),
                first_line(&check.stderr)
            );
            return Some(Err(all_runs("FAIL", why, check.code != 2)));
        }
        let plan = plan_of(&check.stdout, deck);
        if let Some(feature) = unsupported(&plan) {
            return Some(Err(all_runs("UNSUPPORTED", feature, false)));
        }
        plans.push(plan);
    }
    Some(Ok(plans))
}

/// Runs the Run decks of a restart series in one folder and compares each with the
/// uninterrupted run; one outcome per Run deck. None past the time limit.
pub fn run_restart_series(runner: &Runner, full: &Path, runs: &[PathBuf]) -> Option<Vec<Outcome>> {
    let test_dir = full.parent().unwrap_or(Path::new("."));
    let labels: Vec<String> = runs
        .iter()
        .map(|d| format!("{}/{}", name_of(test_dir), name_of(d)))
        .collect();
    let all_runs = |status: &'static str, why: String, crashed: bool| -> Vec<Outcome> {
        labels
            .iter()
            .map(|label| (status, label.clone(), why.clone(), crashed))
            .collect()
    };
    if runner.options.ranks > 1 {
        return Some(all_runs(
            "UNSUPPORTED",
            "restart files are written by one-process runs only".into(),
            false,
        ));
    }
    let plans = match plans(runner, full, runs, &all_runs)? {
        Ok(plans) => plans,
        Err(outcomes) => return Some(outcomes),
    };
    let (straight, series) = match (
        Scratch::new("peridyn-regression-"),
        Scratch::new("peridyn-regression-"),
    ) {
        (Ok(straight), Ok(series)) => (straight, series),
        (Err(e), _) | (_, Err(e)) => return Some(all_runs("FAIL", no_scratch_folder(&e), false)),
    };
    let mut args = vec![
        "run".into(),
        shown(full),
        "--output-dir".into(),
        shown(straight.path()),
    ];
    args.extend(runner.backend_args());
    let run = runner.peridyn(&args)?;
    if run.code != 0 {
        let why = format!(
            "the uninterrupted run {} failed: {}",
            name_of(full),
            first_line(&run.stderr)
        );
        return Some(all_runs("FAIL", why, !(1..=3).contains(&run.code)));
    }
    let full_files: Vec<PathBuf> = output_files(&plans[0])
        .iter()
        .map(|f| straight.path().join(f))
        .collect();
    let mut results = Vec::new();
    let mut failed: Option<String> = None;
    for ((deck, label), plan) in runs.iter().zip(&labels).zip(&plans[1..]) {
        if let Some(why) = &failed {
            results.push(("FAIL", label.clone(), why.clone(), false));
            continue;
        }
        let mut args = vec![
            "run".into(),
            shown(deck),
            "--output-dir".into(),
            shown(series.path()),
        ];
        args.extend(runner.backend_args());
        let run = runner.peridyn(&args)?;
        if run.code != 0 {
            failed = Some(format!("{} failed before it", name_of(deck)));
            let why = format!("run exit {}: {}", run.code, first_line(&run.stderr));
            results.push(("FAIL", label.clone(), why, !(1..=3).contains(&run.code)));
            continue;
        }
        let why = against_full(
            runner,
            test_dir,
            full,
            &full_files,
            &output_files(plan),
            series.path(),
        )?;
        results.push((
            if why.is_empty() { "PASS" } else { "FAIL" },
            label.clone(),
            why,
            false,
        ));
    }
    let keep = runner.options.keep.as_deref();
    keep_outputs(
        series.path(),
        keep,
        &format!("{}/{}_series", name_of(test_dir), stem_of(full)),
    );
    keep_outputs(
        straight.path(),
        keep,
        &format!("{}/{}", name_of(test_dir), stem_of(full)),
    );
    Some(results)
}

/// Why one Run deck's outputs differ from the uninterrupted run's frames at the same times
/// (empty when they agree). None past the time limit.
fn against_full(
    runner: &Runner,
    test_dir: &Path,
    full: &Path,
    full_files: &[PathBuf],
    outputs: &[String],
    series: &Path,
) -> Option<String> {
    for (k, file) in outputs.iter().enumerate() {
        let produced = series.join(file);
        if k >= full_files.len() || !produced.exists() {
            return Some(format!(
                "{file} was not written or has no counterpart in {}",
                name_of(full)
            ));
        }
        let (_, comp) = gold_and_comp(test_dir, &name_of(&full_files[k]));
        let mut args = vec![
            "diff".into(),
            shown(&produced),
            shown(&full_files[k]),
            "--align-times".into(),
        ];
        args.extend(comp_args(&comp));
        let result = runner.peridyn(&args)?;
        if result.code != 0 {
            let why = first_line(output_or_error(&result));
            return Some(format!("{file} against {}: {why}", name_of(&full_files[k])));
        }
    }
    Some(String::new())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_series_needs_run_decks_and_one_uninterrupted_deck() {
        let decks: Vec<PathBuf> = [
            "P_FullSimulation.yaml",
            "P_Run10.yaml",
            "P_Run2.yaml",
            "P_Runx.yaml",
        ]
        .iter()
        .map(PathBuf::from)
        .collect();
        let (full, runs) = restart_series(&decks).unwrap();
        assert_eq!(full, PathBuf::from("P_FullSimulation.yaml"));
        assert_eq!(
            runs,
            vec![PathBuf::from("P_Run2.yaml"), PathBuf::from("P_Run10.yaml")]
        );
        assert!(restart_series(&decks[1..]).is_none());
    }
}
