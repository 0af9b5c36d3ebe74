//! `cargo xtask rooms`: source files and functions a person can hold.

use crate::long_functions::long_functions;
use crate::source::{code_of, item_length, lines, read_text, rust_files, shown};
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// The command's help.
pub const HELP: &str = "\
usage: cargo xtask rooms [--allow FILE] [DIR...]

Checks the `.rs` files under each DIR (default: src and xtask/src) against the project's
rooms:
  - no file over 900 lines, not counting its tests (items under `#[cfg(test)]`, and the
    files of modules declared `#[cfg(test)] mod name;`);
  - no function over 120 lines, from its `fn` line to its closing brace (the count of
    `cargo xtask long-functions`);
  - no `#[allow(clippy::too_many_arguments)]` (or `expect`) outside SIMD kernels: files
    whose module documentation (`//!`) says `SIMD` or `AVX`, where a kernel's arguments are
    the registers and pointers it works on.
Prints one line per breach and a total; exit status 1 when there is one.

An exception is a line of the allow file (default: xtask/rooms-allow.txt, relative to the
repository), `KIND TARGET REASON`, with KIND `file`, `function` or `too-many-arguments`,
TARGET a path relative to the repository (`path::name` for a function), and a REASON of at
least five words saying why the room must stay as it is. An entry that excuses nothing is
itself a breach, so the file cannot hold stale excuses.";

/// A file's line limit without its tests.
const FILE_LIMIT: usize = 900;
/// A function's line limit.
const FUNCTION_LIMIT: usize = 120;
/// Words a justification needs at least.
const REASON_WORDS: usize = 5;

/// One breach of a room: its kind, its target (as the allow file names it) and the message.
struct Breach {
    kind: &'static str,
    target: String,
    message: String,
}

/// Runs the command; returns its exit status.
pub fn main(args: &[String]) -> u8 {
    let repository = crate::repository();
    let mut allow_file = repository.join("xtask").join("rooms-allow.txt");
    let mut roots = Vec::new();
    let mut k = 0;
    while k < args.len() {
        if args[k] == "--allow" {
            k += 1;
            match args.get(k) {
                Some(file) => allow_file = PathBuf::from(file),
                None => {
                    eprintln!("--allow needs a file\n\n{HELP}");
                    return 2;
                }
            }
        } else {
            roots.push(PathBuf::from(&args[k]));
        }
        k += 1;
    }
    if roots.is_empty() {
        roots = vec![repository.join("src"), repository.join("xtask").join("src")];
    }
    let allowed = match read_allow_file(&allow_file) {
        Ok(allowed) => allowed,
        Err(message) => {
            eprintln!("{message}");
            return 2;
        }
    };
    let breaches: Vec<Breach> = roots
        .iter()
        .flat_map(|root| breaches_under(root, &repository))
        .collect();
    judge(
        &breaches,
        &allowed,
        Path::new(&target_of(&allow_file, &repository)),
    )
}

/// Prints the breaches the allow file does not excuse and the entries that excuse nothing.
fn judge(breaches: &[Breach], allowed: &[(String, String, String)], allow_file: &Path) -> u8 {
    let mut used = BTreeSet::new();
    let mut failures = 0;
    let mut excused = 0;
    for breach in breaches {
        match allowed
            .iter()
            .position(|(kind, target, _)| kind == breach.kind && *target == breach.target)
        {
            Some(entry) => {
                used.insert(entry);
                excused += 1;
            }
            None => {
                println!("{}", breach.message);
                failures += 1;
            }
        }
    }
    for (k, (kind, target, _)) in allowed.iter().enumerate() {
        if !used.contains(&k) {
            println!(
                "stale exception in {}: `{kind} {target}` excuses nothing",
                allow_file.display()
            );
            failures += 1;
        }
    }
    println!(
        "rooms: {failures} breaches ({excused} excused by {})",
        allow_file.display()
    );
    u8::from(failures > 0)
}

/// The entries of the allow file: kind, target, reason. A missing file allows nothing.
fn read_allow_file(path: &Path) -> Result<Vec<(String, String, String)>, String> {
    let Ok(text) = std::fs::read_to_string(path) else {
        return Ok(Vec::new());
    };
    let mut entries = Vec::new();
    for (number, line) in lines(&text).iter().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let mut words = line.splitn(3, char::is_whitespace);
        let kind = words.next().unwrap_or("");
        let target = words.next().unwrap_or("");
        let reason = words.next().unwrap_or("").trim();
        if !["file", "function", "too-many-arguments"].contains(&kind) {
            return Err(format!(
                "{}:{}: `{kind}` is not a kind of exception (file, function or too-many-arguments)",
                path.display(),
                number + 1
            ));
        }
        if reason.split_whitespace().count() < REASON_WORDS {
            return Err(format!(
                "{}:{}: the exception for `{target}` needs a reason of at least {REASON_WORDS} words",
                path.display(),
                number + 1
            ));
        }
        entries.push((kind.to_string(), target.to_string(), reason.to_string()));
    }
    Ok(entries)
}

/// A path as the allow file names it: relative to the repository when it lies inside.
fn target_of(path: &Path, repository: &Path) -> String {
    let absolute = if path.is_absolute() {
        path.to_path_buf()
    } else {
        std::env::current_dir().map_or_else(|_| path.to_path_buf(), |cwd| cwd.join(path))
    };
    shown(absolute.strip_prefix(repository).unwrap_or(path))
}

fn breaches_under(root: &Path, repository: &Path) -> Vec<Breach> {
    let mut found = Vec::new();
    let test_files = test_module_files(root);
    for path in rust_files(root) {
        if test_files.contains(&path) {
            continue;
        }
        let text = read_text(&path);
        let target = target_of(&path, repository);
        let size = lines_without_tests(&text);
        if size > FILE_LIMIT {
            let message =
                format!("file      {size:5} lines without tests  {target} (limit {FILE_LIMIT})");
            found.push(Breach {
                kind: "file",
                target: target.clone(),
                message,
            });
        }
        if !says_simd(&text) {
            for line in allowances(&text) {
                let message = format!(
                    "allowance too_many_arguments       {target}:{line} (not a SIMD kernel)"
                );
                found.push(Breach {
                    kind: "too-many-arguments",
                    target: target.clone(),
                    message,
                });
            }
        }
    }
    for function in long_functions(root, FUNCTION_LIMIT) {
        let target = format!(
            "{}::{}",
            target_of(&function.path, repository),
            function.name
        );
        let message = format!(
            "function  {:5} lines                {target} (line {}, limit {FUNCTION_LIMIT})",
            function.length, function.line
        );
        found.push(Breach {
            kind: "function",
            target,
            message,
        });
    }
    found
}

/// Whether a file's module documentation says it holds SIMD kernels.
fn says_simd(text: &str) -> bool {
    lines(text)
        .iter()
        .map(|l| l.trim_start())
        .filter(|l| l.starts_with("//!"))
        .any(|l| l.contains("SIMD") || l.contains("AVX"))
}

/// The line numbers (from 1) of `too_many_arguments` allowances in code.
fn allowances(text: &str) -> Vec<usize> {
    lines(text)
        .iter()
        .enumerate()
        .filter(|(_, line)| {
            let code = code_of(line);
            let attribute = code.trim_start();
            (attribute.starts_with("#[") || attribute.starts_with("#!["))
                && (attribute.contains("allow(") || attribute.contains("expect("))
                && attribute.contains("clippy::too_many_arguments")
        })
        .map(|(k, _)| k + 1)
        .collect()
}

/// The lines of a file that are not tests: every line but those of the items marked
/// `#[cfg(test)]` (from the attribute to the item's closing brace or semicolon). A file whose
/// first attribute is `#![cfg(test)]` is all tests.
fn lines_without_tests(text: &str) -> usize {
    let lines = lines(text);
    if lines.iter().any(|l| code_of(l).trim() == "#![cfg(test)]") {
        return 0;
    }
    let mut count = 0;
    let mut k = 0;
    while k < lines.len() {
        let code = code_of(lines[k]);
        let Some(rest) = code.trim().strip_prefix("#[cfg(test)]") else {
            count += 1;
            k += 1;
            continue;
        };
        let first = if rest.trim().is_empty() { k + 1 } else { k };
        let item = (first..lines.len()).find(|&j| {
            let code = code_of(lines[j]);
            let code = code.trim();
            j == k
                || !(code.is_empty()
                    || code.starts_with("#[")
                    || lines[j].trim_start().starts_with("//"))
        });
        let Some(item) = item else {
            break;
        };
        let length = item_length(&lines, item).unwrap_or(1);
        k = item + length;
    }
    count
}

/// The files of the modules declared `#[cfg(test)] mod name;` under `root` (test-only files).
fn test_module_files(root: &Path) -> BTreeSet<PathBuf> {
    let mut found = BTreeSet::new();
    for path in rust_files(root) {
        let text = read_text(&path);
        let lines = lines(&text);
        for (k, line) in lines.iter().enumerate() {
            if code_of(line).trim() != "#[cfg(test)]" {
                continue;
            }
            let Some(next) = lines.get(k + 1).map(|l| code_of(l)) else {
                continue;
            };
            let declaration = next
                .trim()
                .trim_start_matches("pub ")
                .trim_start_matches("pub(crate) ");
            let Some(name) = declaration
                .strip_prefix("mod ")
                .and_then(|rest| rest.strip_suffix(';'))
            else {
                continue;
            };
            found.extend(module_files(&path, name.trim()));
        }
    }
    found
}

/// Where the module `name` declared in `parent` lives, and every file below it.
fn module_files(parent: &Path, name: &str) -> Vec<PathBuf> {
    let folder = parent.parent().unwrap_or(Path::new("."));
    let stem = parent
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let base = if ["mod", "lib", "main"].contains(&stem.as_str()) {
        folder.to_path_buf()
    } else {
        folder.join(stem)
    };
    let mut files = Vec::new();
    let file = base.join(format!("{name}.rs"));
    if file.is_file() {
        files.push(file);
    }
    let sub = base.join(name);
    if sub.is_dir() {
        files.extend(rust_files(&sub));
    }
    files
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tests_do_not_count_toward_a_file() {
        let text = "fn a() {}\n#[cfg(test)]\n#[allow(unused)]\nmod tests {\n    fn b() {}\n}\nfn c() {}\n#[cfg(test)]\nmod more;\n";
        assert_eq!(lines_without_tests(text), 2);
        assert_eq!(lines_without_tests("#![cfg(test)]\nfn a() {}\n"), 0);
    }

    #[test]
    fn allowances_outside_simd_kernels_are_found() {
        let text = "//! Kernels.\n#[allow(clippy::too_many_arguments)]\nfn f() {}\n// #[allow(clippy::too_many_arguments)]\n";
        assert_eq!(allowances(text), vec![2]);
        assert!(!says_simd(text));
        assert!(says_simd("//! The AVX2 builds of the loops.\n"));
    }
}
