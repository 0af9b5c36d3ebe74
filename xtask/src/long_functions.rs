//! `cargo xtask long-functions`: the functions longer than a limit.

use crate::source::{function_name, item_length, lines, read_text, rust_files, shown};
use std::path::{Path, PathBuf};

/// The command's help.
pub const HELP: &str = "\
usage: cargo xtask long-functions [SRC_DIR] [LIMIT]

Reads every `.rs` file under SRC_DIR (default: src) and prints `lines path::name (line N)` for
each function (methods and nested functions included) of more than LIMIT lines (default 120,
the project's bar for functions that read like their table of contents), from its `fn` line
to its closing brace. Braces in comments, strings and character literals are skipped. Exit
status 1 when one is found.";

/// One function longer than the limit.
pub struct LongFunction {
    /// Its file.
    pub path: PathBuf,
    /// Its name.
    pub name: String,
    /// Its first line, from 1.
    pub line: usize,
    /// Lines from its `fn` line to its closing brace.
    pub length: usize,
}

/// The functions of more than `limit` lines in the `.rs` files under `root`, in file order.
pub fn long_functions(root: &Path, limit: usize) -> Vec<LongFunction> {
    let mut found = Vec::new();
    for path in rust_files(root) {
        let text = read_text(&path);
        let lines = lines(&text);
        for (first, line) in lines.iter().enumerate() {
            let Some(name) = function_name(line) else {
                continue;
            };
            match item_length(&lines, first) {
                Some(length) if length > limit => found.push(LongFunction {
                    path: path.clone(),
                    name: name.to_string(),
                    line: first + 1,
                    length,
                }),
                _ => {}
            }
        }
    }
    found
}

/// Runs the command; returns its exit status.
pub fn main(args: &[String]) -> u8 {
    let root = PathBuf::from(args.first().map_or("src", String::as_str));
    let limit = match args.get(1).map(|text| text.parse::<usize>()) {
        None => 120,
        Some(Ok(limit)) => limit,
        Some(Err(_)) => {
            eprintln!("LIMIT must be a whole number of lines\n\n{HELP}");
            return 2;
        }
    };
    let found = long_functions(&root, limit);
    for function in &found {
        println!(
            "{:5} {}::{} (line {})",
            function.length,
            shown(&function.path),
            function.name,
            function.line
        );
    }
    u8::from(!found.is_empty())
}
