//! Errors raised while reading an input deck.

use std::fmt;
use std::path::PathBuf;

/// A key path inside a deck, e.g. `Materials → Steel → Density`.
///
/// The root list (`Peridigm:` in YAML, the unnamed `<ParameterList>` in XML) is not part of the
/// path.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct KeyPath(pub Vec<String>);

impl KeyPath {
    /// The path as a slice of key names.
    pub fn keys(&self) -> &[String] {
        &self.0
    }
}

impl fmt::Display for KeyPath {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.0.is_empty() {
            return f.write_str("(top level)");
        }
        f.write_str(&self.0.join(" → "))
    }
}

/// Everything that can go wrong while loading a deck.
///
/// Every message names the file; problems with the content also name the key path and the line
/// where the key was written, then say what is wrong and what to do.
#[derive(Debug, thiserror::Error)]
pub enum DeckError {
    /// The deck file could not be read from disk.
    #[error("{file}: cannot read the input deck: {source}")]
    Io {
        /// The deck file.
        file: PathBuf,
        /// The operating-system error.
        #[source]
        source: std::io::Error,
    },
    /// The file extension does not name a deck format.
    #[error(
        "{file}: unknown input deck format; the file name must end in .yaml, .yml or .xml \
         (the old .peridigm format is not read: convert it with Peridigm's scripts/peridigm_to_yaml.py)"
    )]
    UnknownFormat {
        /// The deck file.
        file: PathBuf,
    },
    /// The text is not well-formed YAML or XML.
    #[error("{file}:{line}:{column}: malformed {format}: {message}")]
    Syntax {
        /// The deck file.
        file: PathBuf,
        /// `"YAML"` or `"XML"`.
        format: &'static str,
        /// 1-based line of the problem.
        line: usize,
        /// 1-based column of the problem.
        column: usize,
        /// What the parser reported.
        message: String,
    },
    /// The deck is well-formed but its content is wrong (unknown key, wrong type, bad value,
    /// missing key, dangling reference, ...).
    #[error("{}", invalid_message(file, *line, key_path, message))]
    Invalid {
        /// The deck file.
        file: PathBuf,
        /// 1-based line of the offending key (or of the enclosing list for a missing key).
        line: Option<usize>,
        /// Where in the deck the problem is.
        key_path: KeyPath,
        /// What is wrong and what to do.
        message: String,
    },
}

fn invalid_message(
    file: &std::path::Path,
    line: Option<usize>,
    path: &KeyPath,
    msg: &str,
) -> String {
    match line {
        Some(line) => format!("{}:{}: {}: {}", file.display(), line, path, msg),
        None => format!("{}: {}: {}", file.display(), path, msg),
    }
}

impl DeckError {
    /// The 1-based line the error refers to, when known.
    pub fn line(&self) -> Option<usize> {
        match self {
            DeckError::Syntax { line, .. } => Some(*line),
            DeckError::Invalid { line, .. } => *line,
            _ => None,
        }
    }

    /// The key path the error refers to (content errors only).
    pub fn key_path(&self) -> Option<&KeyPath> {
        match self {
            DeckError::Invalid { key_path, .. } => Some(key_path),
            _ => None,
        }
    }
}
