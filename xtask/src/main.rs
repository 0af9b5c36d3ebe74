//! peridyn's developer tools, run as `cargo xtask <command>` from anywhere in the repository.
//!
//! | command | what it answers |
//! |---|---|
//! | `refactor-check` | did a change leave every output file byte-identical? |
//! | `compare-outputs` | are two trees of run outputs the same, file by file? |
//! | `peridigm-regression` | do Peridigm's regression decks pass against its gold files? |
//! | `import-circles` | does any module import one that imports it back? |
//! | `long-functions` | which functions are longer than a limit? |
//! | `rooms` | does every source file and function stay a size a person can hold? |
//!
//! Standard library only, so CI compiles it in seconds. `scripts/check_exodus.py`,
//! `scripts/fuzz-decks` and `scripts/implicit-scaling` stay in Python (the developer guide
//! says why).
#![warn(missing_docs)]

mod compare_outputs;
mod import_circles;
mod json;
mod long_functions;
mod process;
mod refactor_check;
mod regression;
mod rooms;
mod source;

use std::path::PathBuf;
use std::process::ExitCode;

const USAGE: &str = "\
usage: cargo xtask <command> [arguments]

commands:
  refactor-check BEFORE_BIN AFTER_BIN [--backend B] [--ranks N] [--out DIR]
                        run the regression decks and quick examples with both binaries and
                        compare every output file byte for byte
  compare-outputs BEFORE_DIR AFTER_DIR
                        compare two trees of run outputs file by file
  peridigm-regression [PERIDIGM_DIR] [--peridyn BIN] [--ranks N] [--backend B] [--timeout S]
                      [--strict] [--min-pass N] [--filter NAME] [--keep DIR]
                        run Peridigm's regression decks against their gold files
  import-circles [SRC_DIR]
                        list modules that import each other (exit 1 when there is one)
  long-functions [SRC_DIR] [LIMIT]
                        list functions longer than LIMIT lines (default 120)
  rooms [--allow FILE] [DIR...]
                        files over 900 lines without their tests, functions over 120 lines,
                        too_many_arguments allowances outside SIMD kernels
  help [COMMAND]        this text, or a command's own help

Run `cargo xtask help COMMAND` for a command's details.";

/// The repository's top folder (this crate lives in `xtask/` inside it).
pub fn repository() -> PathBuf {
    let manifest = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    manifest.parent().map(PathBuf::from).unwrap_or(manifest)
}

fn main() -> ExitCode {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    if args.is_empty() {
        eprintln!("{USAGE}");
        return ExitCode::from(2);
    }
    let command = args.remove(0);
    let status = match command.as_str() {
        "refactor-check" => refactor_check::main(&args),
        "compare-outputs" => compare_outputs::main(&args),
        "peridigm-regression" => regression::main(&args),
        "import-circles" => import_circles::main(&args),
        "long-functions" => long_functions::main(&args),
        "rooms" => rooms::main(&args),
        "help" | "--help" | "-h" => help(args.first().map(String::as_str)),
        other => {
            eprintln!("unknown command `{other}`\n\n{USAGE}");
            2
        }
    };
    ExitCode::from(status)
}

fn help(command: Option<&str>) -> u8 {
    let text = match command {
        Some("refactor-check") => refactor_check::HELP,
        Some("compare-outputs") => compare_outputs::HELP,
        Some("peridigm-regression") => regression::HELP,
        Some("import-circles") => import_circles::HELP,
        Some("long-functions") => long_functions::HELP,
        Some("rooms") => rooms::HELP,
        _ => USAGE,
    };
    println!("{text}");
    0
}
