//! Format-neutral tree of a deck: nested named lists of typed scalars, each with its line.
//!
//! Both the YAML and the XML reader produce this tree, so everything after parsing is shared
//! and the two formats give identical [`Deck`](crate::io::deck::Deck)s.

use std::collections::HashMap;

/// Deepest nesting of lists a deck may have. Peridigm's decks nest at most 6 deep (`Solver →
/// NOXQuasiStatic → Direction → Newton → Linear Solver → Belos`); the bound keeps a malformed or
/// hostile deck from exhausting the stack of everything that walks the tree.
pub(crate) const MAX_NESTING: usize = 32;

/// The message for a deck nested deeper than [`MAX_NESTING`].
pub(crate) fn too_deep_message() -> String {
    format!(
        "lists nested more than {MAX_NESTING} deep; a Peridigm deck nests at most 6 deep, so a \
         list is probably indented one level too far or never closed"
    )
}

/// Type of a scalar, following Teuchos' rules: YAML infers it from the literal (quoted → string,
/// digits only → int, decimal point or exponent → double, `true`/`false` → bool), XML states it
/// in the `type` attribute.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum ScalarKind {
    String,
    Int(i64),
    Double(f64),
    Bool(bool),
    /// An empty YAML value (`Key:` with nothing after it, `~`, `null`).
    Null,
}

/// A scalar with the text exactly as written (after unescaping).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Scalar {
    pub text: String,
    pub kind: ScalarKind,
}

impl Scalar {
    /// Words for error messages: "the string \"abc\"", "the integer 3", ...
    pub fn describe(&self) -> String {
        match self.kind {
            ScalarKind::String => format!("the string \"{}\"", self.text),
            ScalarKind::Int(_) => format!("the integer {}", self.text),
            ScalarKind::Double(_) => format!("the number {}", self.text),
            ScalarKind::Bool(_) => format!("the boolean {}", self.text),
            ScalarKind::Null => "an empty value".to_string(),
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub(crate) enum NodeKind {
    List(Vec<Entry>),
    Scalar(Scalar),
}

/// A value in the tree with the 1-based line where it starts.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Node {
    pub line: usize,
    pub kind: NodeKind,
}

/// One named entry of a list, with the line of its key.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Entry {
    pub key: String,
    pub line: usize,
    pub value: Node,
}

impl Node {
    pub fn as_list(&self) -> Option<&[Entry]> {
        match &self.kind {
            NodeKind::List(entries) => Some(entries),
            _ => None,
        }
    }
}

/// Infers the type of a plain (unquoted) YAML scalar the way Teuchos' YAML reader does.
pub(crate) fn infer_plain_scalar(text: &str) -> Scalar {
    let kind = match text {
        "" | "~" | "null" | "Null" | "NULL" => ScalarKind::Null,
        "true" | "True" | "TRUE" => ScalarKind::Bool(true),
        "false" | "False" | "FALSE" => ScalarKind::Bool(false),
        _ => {
            if is_integer_literal(text) {
                match text.parse::<i64>() {
                    Ok(i) => ScalarKind::Int(i),
                    // Too large for an int: Teuchos would fail too; a double keeps the value.
                    Err(_) => text
                        .parse::<f64>()
                        .map(ScalarKind::Double)
                        .unwrap_or(ScalarKind::String),
                }
            } else if is_float_literal(text) {
                text.parse::<f64>()
                    .map(ScalarKind::Double)
                    .unwrap_or(ScalarKind::String)
            } else {
                ScalarKind::String
            }
        }
    };
    Scalar {
        text: text.to_string(),
        kind,
    }
}

/// `[+-]?[0-9]+`
pub(crate) fn is_integer_literal(text: &str) -> bool {
    let digits = text.strip_prefix(['+', '-']).unwrap_or(text);
    !digits.is_empty() && digits.bytes().all(|b| b.is_ascii_digit())
}

/// `[+-]?([0-9]+(\.[0-9]*)?|\.[0-9]+)([eE][+-]?[0-9]+)?` — decimal literals only, so words such
/// as `inf` or `nan` (which Rust's `f64::from_str` would accept) stay strings.
pub(crate) fn is_float_literal(text: &str) -> bool {
    let s = text.strip_prefix(['+', '-']).unwrap_or(text);
    let (mantissa, exponent) = match s.find(['e', 'E']) {
        Some(i) => (&s[..i], Some(&s[i + 1..])),
        None => (s, None),
    };
    let (int_part, frac_part) = match mantissa.find('.') {
        Some(i) => (&mantissa[..i], Some(&mantissa[i + 1..])),
        None => (mantissa, None),
    };
    let all_digits = |p: &str| p.bytes().all(|b| b.is_ascii_digit());
    let mantissa_ok = all_digits(int_part)
        && frac_part.is_none_or(all_digits)
        && (!int_part.is_empty() || frac_part.is_some_and(|f| !f.is_empty()));
    let exponent_ok = exponent.is_none_or(|e| {
        let e = e.strip_prefix(['+', '-']).unwrap_or(e);
        !e.is_empty() && all_digits(e)
    });
    mantissa_ok && exponent_ok
}

/// Records the line of every key path in the tree (root excluded), for
/// [`Deck::line_of`](crate::io::deck::Deck::line_of).
pub(crate) fn index_lines(entries: &[Entry]) -> HashMap<Vec<String>, usize> {
    fn walk(entries: &[Entry], prefix: &mut Vec<String>, out: &mut HashMap<Vec<String>, usize>) {
        for entry in entries {
            prefix.push(entry.key.clone());
            out.insert(prefix.clone(), entry.line);
            if let NodeKind::List(children) = &entry.value.kind {
                walk(children, prefix, out);
            }
            prefix.pop();
        }
    }
    let mut out = HashMap::new();
    walk(entries, &mut Vec::new(), &mut out);
    out
}

/// Byte offset → 1-based (line, column) lookup.
pub(crate) struct LineMap {
    starts: Vec<usize>,
}

impl LineMap {
    pub fn new(text: &str) -> Self {
        let mut starts = vec![0];
        starts.extend(
            text.bytes()
                .enumerate()
                .filter(|(_, b)| *b == b'\n')
                .map(|(i, _)| i + 1),
        );
        LineMap { starts }
    }

    pub fn line_col(&self, offset: usize) -> (usize, usize) {
        let line_index = self
            .starts
            .partition_point(|&s| s <= offset)
            .saturating_sub(1);
        (line_index + 1, offset - self.starts[line_index] + 1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plain_scalars_follow_teuchos_typing() {
        assert_eq!(infer_plain_scalar("2").kind, ScalarKind::Int(2));
        assert_eq!(infer_plain_scalar("-17").kind, ScalarKind::Int(-17));
        assert_eq!(infer_plain_scalar("2.0").kind, ScalarKind::Double(2.0));
        assert_eq!(
            infer_plain_scalar("14.90e9").kind,
            ScalarKind::Double(14.90e9)
        );
        assert_eq!(infer_plain_scalar(".10").kind, ScalarKind::Double(0.1));
        assert_eq!(infer_plain_scalar("1e-5").kind, ScalarKind::Double(1e-5));
        assert_eq!(infer_plain_scalar("true").kind, ScalarKind::Bool(true));
        assert_eq!(infer_plain_scalar("inf").kind, ScalarKind::String);
        assert_eq!(infer_plain_scalar("1.0.0").kind, ScalarKind::String);
        assert_eq!(infer_plain_scalar("block_1").kind, ScalarKind::String);
        assert_eq!(infer_plain_scalar("").kind, ScalarKind::Null);
    }

    #[test]
    fn line_map_is_one_based() {
        let map = LineMap::new("ab\ncd\n\nef");
        assert_eq!(map.line_col(0), (1, 1));
        assert_eq!(map.line_col(4), (2, 2));
        assert_eq!(map.line_col(7), (4, 1));
    }
}
