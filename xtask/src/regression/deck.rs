//! One regression deck: check, run, compare each output with its gold file.

use super::{first_line, name_of, output_or_error, Outcome, Runner};
use crate::json::Json;
use crate::process::Scratch;
use std::path::{Path, PathBuf};

/// The gold file and the exodiff command file of one output file name (e.g. `Bar.e`).
pub fn gold_and_comp(test_dir: &Path, output_file: &str) -> (Option<PathBuf>, Option<PathBuf>) {
    let file = Path::new(output_file);
    let stem = file
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let suffix = file
        .extension()
        .map(|e| format!(".{}", e.to_string_lossy()))
        .unwrap_or_default();
    let gold = test_dir.join(format!("{stem}_gold{suffix}"));
    let mut comp = Some(test_dir.join(format!("{stem}.comp")));
    if !comp.as_ref().is_some_and(|c| c.exists()) {
        let named = test_dir.join(format!("{}.comp", name_of(test_dir)));
        comp = if named.exists() {
            Some(named)
        } else {
            let comps = comp_files(test_dir);
            (comps.len() == 1).then(|| comps[0].clone())
        };
    }
    (gold.exists().then_some(gold), comp)
}

fn comp_files(test_dir: &Path) -> Vec<PathBuf> {
    let mut comps: Vec<PathBuf> = std::fs::read_dir(test_dir)
        .map(|entries| entries.flatten().map(|e| e.path()).collect())
        .unwrap_or_default();
    comps.retain(|p| p.extension().is_some_and(|e| e == "comp"));
    comps.sort();
    comps
}

/// `--comp FILE` when there is a command file.
pub fn comp_args(comp: &Option<PathBuf>) -> Vec<String> {
    match comp {
        Some(c) => vec!["--comp".into(), shown(c)],
        None => Vec::new(),
    }
}

/// Why a deck could not run: no scratch folder for its outputs in the temporary folder.
pub fn no_scratch_folder(error: &std::io::Error) -> String {
    format!(
        "cannot create a scratch folder in {} ({error}); set TMPDIR to a writable folder",
        std::env::temp_dir().display()
    )
}

/// A path as an argument.
pub fn shown(path: &Path) -> String {
    path.to_string_lossy().into_owned()
}

/// Copies every file a deck wrote into `<keep>/<test>/<deck stem>/` (for before/after
/// comparisons).
pub fn keep_outputs(scratch: &Path, keep: Option<&Path>, label: &str) {
    let Some(keep) = keep else {
        return;
    };
    let target = keep.join(label.replace(".yaml", "").replace(".xml", ""));
    if target.exists() {
        let _ = std::fs::remove_dir_all(&target);
    }
    if let Err(e) = crate::process::copy_tree(scratch, &target) {
        eprintln!(
            "error: cannot keep the outputs in {}: {e}",
            target.display()
        );
    }
}

/// The output file names of a run plan.
pub fn output_files(plan: &Json) -> Vec<String> {
    plan.get("outputs")
        .map(|outputs| {
            outputs
                .items()
                .iter()
                .map(|o| o.get("file").and_then(Json::text).unwrap_or("").to_string())
                .collect()
        })
        .unwrap_or_default()
}

/// The first unsupported feature of a run plan, when it lists any.
pub fn unsupported(plan: &Json) -> Option<String> {
    plan.get("unsupported")
        .and_then(|u| u.items().first())
        .map(Json::shown)
}

/// Reads the plan `peridyn check --json` printed; a plan that is not JSON stops the command
/// as an uncaught error stopped the Python runner.
pub fn plan_of(stdout: &str, deck: &Path) -> Json {
    crate::json::parse(stdout).unwrap_or_else(|e| {
        eprintln!(
            "error: the plan `peridyn check --json {}` printed is not JSON: {e}",
            deck.display()
        );
        std::process::exit(1)
    })
}

/// Runs one deck and compares its outputs; None when a command ran past the time limit.
pub fn run_deck(runner: &Runner, deck: &Path) -> Option<Outcome> {
    let test_dir = deck.parent().unwrap_or(Path::new("."));
    let label = format!("{}/{}", name_of(test_dir), name_of(deck));
    // `check --backend` resolves the solver lists as `run --backend` will.
    let mut args = vec!["check".into(), shown(deck), "--json".into()];
    args.extend(runner.backend_args());
    let check = runner.peridyn(&args)?;
    if check.code != 0 {
        if check.code == 2 {
            let message = first_line(&check.stderr);
            if message.contains("No such file or directory") && message.contains("Input Mesh File")
            {
                return Some((
                    "SKIP",
                    label,
                    "its mesh file is not in this Peridigm snapshot".into(),
                    false,
                ));
            }
            return Some(("FAIL", label, format!("does not load: {message}"), true));
        }
        let why = format!(
            "check crashed (exit {}): {}",
            check.code,
            first_line(&check.stderr)
        );
        return Some(("FAIL", label, why, true));
    }
    let plan = plan_of(&check.stdout, deck);
    if let Some(feature) = unsupported(&plan) {
        return Some(("UNSUPPORTED", label, feature, false));
    }
    let scratch = match Scratch::new("peridyn-regression-") {
        Ok(scratch) => scratch,
        Err(e) => return Some(("FAIL", label, no_scratch_folder(&e), false)),
    };
    let ranks = runner.options.ranks;
    let mut command = vec![
        runner.binary.clone(),
        "run".into(),
        shown(deck),
        "--output-dir".into(),
    ];
    command.push(shown(scratch.path()));
    command.extend(runner.backend_args());
    if ranks > 1 {
        let launcher = [
            "mpirun".to_string(),
            "-np".into(),
            ranks.to_string(),
            "--oversubscribe".into(),
        ];
        command.splice(0..0, launcher);
    }
    let run = runner.run(command)?;
    keep_outputs(scratch.path(), runner.options.keep.as_deref(), &label);
    if run.code != 0 {
        let needle = format!("on {ranks} ranks");
        let refusal = crate::source::lines(&run.stderr)
            .into_iter()
            .find(|line| line.contains(&needle))
            .map(str::trim);
        if let (true, 1, Some(refusal)) = (ranks > 1, run.code, refusal) {
            // A deck peridyn runs on one rank only says so before any message is sent.
            let reason = refusal.split_once(": ").map_or(refusal, |(_, r)| r);
            return Some(("UNSUPPORTED", label, reason.to_string(), false));
        }
        let crashed = !(1..=3).contains(&run.code);
        return Some((
            "FAIL",
            label,
            format!("run exit {}: {}", run.code, first_line(&run.stderr)),
            crashed,
        ));
    }
    compare_outputs(runner, deck, test_dir, &plan, scratch.path(), label)
}

/// Compares a finished run's outputs with the gold files of its folder.
fn compare_outputs(
    runner: &Runner,
    deck: &Path,
    test_dir: &Path,
    plan: &Json,
    scratch: &Path,
    label: String,
) -> Option<Outcome> {
    let mut compared = 0;
    let outputs = output_files(plan);
    for file in &outputs {
        let produced = scratch.join(file);
        let (gold, comp) = gold_and_comp(test_dir, file);
        let Some(gold) = gold else {
            continue;
        };
        if !produced.exists() {
            return Some(("FAIL", label, format!("{file} was not written"), false));
        }
        let mut args = vec!["diff".into(), shown(&produced), shown(&gold)];
        args.extend(comp_args(&comp));
        let result = runner.peridyn(&args)?;
        if result.code != 0 {
            return Some((
                "FAIL",
                label,
                format!("{file}: {}", first_line(output_or_error(&result))),
                false,
            ));
        }
        compared += 1;
    }
    if compared == 0 {
        // One gold file for a deck that writes one file per solver: Peridigm's test joins
        // the outputs in time (SEACAS conjoin) before comparing; `peridyn diff --then` does.
        let stem = deck
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let joined = test_dir.join(format!("{stem}_gold.e"));
        let files: Vec<PathBuf> = outputs
            .iter()
            .filter(|f| f.ends_with(".e"))
            .map(|f| scratch.join(f))
            .collect();
        if joined.exists() && files.len() > 1 && files.iter().all(|f| f.exists()) {
            let (_, comp) = gold_and_comp(test_dir, &format!("{stem}.e"));
            let mut args = vec!["diff".into(), shown(&files[0])];
            for f in &files[1..] {
                args.extend(["--then".into(), shown(f)]);
            }
            args.push(shown(&joined));
            args.extend(comp_args(&comp));
            let result = runner.peridyn(&args)?;
            if result.code != 0 {
                let why = format!("joined outputs: {}", first_line(output_or_error(&result)));
                return Some(("FAIL", label, why, false));
            }
            compared = 1;
        }
    }
    if compared == 0 {
        return Some(("NOGOLD", label, String::new(), false));
    }
    Some(("PASS", label, String::new(), false))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_command_file_is_the_outputs_the_folders_or_the_only_one() {
        let scratch = Scratch::new("xtask-gold-").unwrap();
        let dir = scratch.path().join("Bar_QS");
        std::fs::create_dir(&dir).unwrap();
        std::fs::write(dir.join("Bar_gold.e"), "").unwrap();
        std::fs::write(dir.join("other.comp"), "").unwrap();
        assert_eq!(
            gold_and_comp(&dir, "Bar.e"),
            (Some(dir.join("Bar_gold.e")), Some(dir.join("other.comp")))
        );
        std::fs::write(dir.join("Bar_QS.comp"), "").unwrap();
        assert_eq!(
            gold_and_comp(&dir, "Bar.e").1,
            Some(dir.join("Bar_QS.comp"))
        );
        std::fs::write(dir.join("Bar.comp"), "").unwrap();
        assert_eq!(gold_and_comp(&dir, "Bar.e").1, Some(dir.join("Bar.comp")));
        std::fs::remove_file(dir.join("Bar.comp")).unwrap();
        std::fs::remove_file(dir.join("Bar_QS.comp")).unwrap();
        std::fs::write(dir.join("third.comp"), "").unwrap();
        assert_eq!(gold_and_comp(&dir, "Wave.e"), (None, None));
    }
}
