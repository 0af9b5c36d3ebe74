//! YAML decks → [`tree`](super::tree).
//!
//! Uses yaml-rust2's event parser so that every key keeps its line number. Peridigm's own decks
//! write braces inside double-quoted expressions as `\{` / `\}` (accepted by the Trilinos reader,
//! rejected by strict YAML); the backslash is removed before parsing. Removing a character never
//! adds or removes a newline, so line numbers stay right.

use std::path::Path;

use yaml_rust2::parser::{Event, MarkedEventReceiver, Parser};
use yaml_rust2::scanner::{Marker, TScalarStyle};

use super::error::{DeckError, KeyPath};
use super::tree::{
    infer_plain_scalar, too_deep_message, Entry, Node, NodeKind, Scalar, ScalarKind, MAX_NESTING,
};

/// Removes the backslash of `\{` and `\}` (an escaped backslash `\\` is left alone).
pub(crate) fn strip_brace_escapes(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut chars = text.chars().peekable();
    while let Some(c) = chars.next() {
        if c == '\\' {
            match chars.peek() {
                Some('{') | Some('}') => continue,
                Some('\\') => {
                    out.push('\\');
                    out.push(chars.next().unwrap_or('\\'));
                    continue;
                }
                _ => {}
            }
        }
        out.push(c);
    }
    out
}

enum Frame {
    List {
        line: usize,
        entries: Vec<Entry>,
        pending_key: Option<(String, usize)>,
    },
}

struct TreeBuilder<'a> {
    file: &'a Path,
    stack: Vec<Frame>,
    root: Option<Node>,
    error: Option<DeckError>,
    documents: usize,
    warnings: Vec<String>,
}

impl TreeBuilder<'_> {
    fn path(&self) -> KeyPath {
        let mut keys = Vec::new();
        for (depth, frame) in self.stack.iter().enumerate() {
            let Frame::List { pending_key, .. } = frame;
            if let Some((key, _)) = pending_key {
                // The optional `Peridigm:` root is not part of key paths.
                if !(depth == 0 && key == "Peridigm") {
                    keys.push(key.clone());
                }
            }
        }
        KeyPath(keys)
    }

    fn fail(&mut self, line: usize, message: String) {
        if self.error.is_none() {
            self.error = Some(DeckError::Invalid {
                file: self.file.to_path_buf(),
                line: Some(line),
                key_path: self.path(),
                message,
            });
        }
    }

    /// Attaches a finished value to the enclosing list (or makes it the document root).
    fn attach(&mut self, node: Node) {
        match self.stack.last_mut() {
            Some(Frame::List {
                entries,
                pending_key,
                ..
            }) => match pending_key.take() {
                Some((key, line)) => {
                    if let Some(previous) = entries.iter().find(|e| e.key == key) {
                        let previous_line = previous.line;
                        let same_scalar = matches!(
                            (&previous.value.kind, &node.kind),
                            (NodeKind::Scalar(a), NodeKind::Scalar(b)) if a == b
                        );
                        *pending_key = Some((key, line));
                        if same_scalar {
                            let path = self.path();
                            self.warnings.push(format!(
                                "{}:{}: {}: written twice with the same value (first on line {}); the repetition has no effect",
                                self.file.display(),
                                line,
                                path,
                                previous_line
                            ));
                            if let Some(Frame::List { pending_key, .. }) = self.stack.last_mut() {
                                *pending_key = None;
                            }
                            return;
                        }
                        self.fail(
                            line,
                            format!("written twice with different content (first on line {previous_line}); remove one of them"),
                        );
                        return;
                    }
                    entries.push(Entry {
                        key,
                        line,
                        value: node,
                    });
                }
                None => unreachable!("values are attached only after a key"),
            },
            None => {
                if self.root.is_none() {
                    self.root = Some(node);
                }
            }
        }
    }
}

impl MarkedEventReceiver for TreeBuilder<'_> {
    fn on_event(&mut self, event: Event, mark: Marker) {
        if self.error.is_some() {
            return;
        }
        let line = mark.line();
        match event {
            Event::DocumentStart => {
                self.documents += 1;
                if self.documents > 1 {
                    self.fail(
                        line,
                        "a deck must contain exactly one YAML document; remove the second `---`"
                            .into(),
                    );
                }
            }
            Event::MappingStart(..) => {
                if let Some(Frame::List {
                    pending_key: None, ..
                }) = self.stack.last()
                {
                    self.fail(line, "a list cannot be used as a key".into());
                    return;
                }
                if self.stack.len() >= MAX_NESTING {
                    self.fail(line, too_deep_message());
                    return;
                }
                self.stack.push(Frame::List {
                    line,
                    entries: Vec::new(),
                    pending_key: None,
                });
            }
            Event::MappingEnd => {
                let Some(Frame::List { line, entries, .. }) = self.stack.pop() else {
                    unreachable!("the YAML parser balances mapping events")
                };
                self.attach(Node {
                    line,
                    kind: NodeKind::List(entries),
                });
            }
            Event::Scalar(text, style, anchor, _tag) => {
                if anchor != 0 {
                    self.fail(
                        line,
                        "YAML anchors (&name) are not supported in a deck; write the value out"
                            .into(),
                    );
                    return;
                }
                let is_key = matches!(
                    self.stack.last(),
                    Some(Frame::List {
                        pending_key: None,
                        ..
                    })
                );
                if is_key {
                    if let Some(Frame::List { pending_key, .. }) = self.stack.last_mut() {
                        *pending_key = Some((text, line));
                    }
                    return;
                }
                let scalar = match style {
                    TScalarStyle::Plain => infer_plain_scalar(&text),
                    _ => Scalar {
                        text,
                        kind: ScalarKind::String,
                    },
                };
                self.attach(Node {
                    line,
                    kind: NodeKind::Scalar(scalar),
                });
            }
            Event::SequenceStart(..) => {
                self.fail(
                    line,
                    "YAML sequences ([a, b] or `- item`) are not part of a Peridigm deck; \
                     write lists of names or ids as one space-separated string"
                        .into(),
                );
            }
            Event::Alias(_) => {
                self.fail(
                    line,
                    "YAML aliases (*name) are not supported in a deck; write the value out".into(),
                );
            }
            Event::SequenceEnd
            | Event::Nothing
            | Event::StreamStart
            | Event::StreamEnd
            | Event::DocumentEnd => {}
        }
    }
}

/// Parses YAML text into the root list of the deck (the content of `Peridigm:` if present).
/// Also returns warnings (repeated keys with identical values).
pub(crate) fn parse(text: &str, file: &Path) -> Result<(Node, Vec<String>), DeckError> {
    let cleaned = strip_brace_escapes(text);
    let mut builder = TreeBuilder {
        file,
        stack: Vec::new(),
        root: None,
        error: None,
        documents: 0,
        warnings: Vec::new(),
    };
    let mut parser = Parser::new_from_str(&cleaned);
    // Events are pulled one by one rather than through `Parser::load`, which recurses once per
    // nesting level and would overflow the stack on a deck nested thousands deep before the
    // builder could refuse it. After the builder's first error the rest is still scanned, so
    // that a syntax error anywhere is reported as such, as `load` did.
    let pulled = loop {
        match parser.next_token() {
            Ok((event, mark)) => {
                let end = event == Event::StreamEnd;
                if builder.error.is_none() {
                    builder.on_event(event, mark);
                }
                if end {
                    break Ok(());
                }
            }
            Err(e) => break Err(e),
        }
    };
    if let Err(e) = pulled {
        return Err(DeckError::Syntax {
            file: file.to_path_buf(),
            format: "YAML",
            line: e.marker().line(),
            column: e.marker().col() + 1,
            message: e.info().to_string(),
        });
    }
    if let Some(error) = builder.error {
        return Err(error);
    }
    let warnings = std::mem::take(&mut builder.warnings);
    let root = match builder.root {
        Some(root) => root,
        None => {
            return Err(DeckError::Invalid {
                file: file.to_path_buf(),
                line: None,
                key_path: KeyPath::default(),
                message: "the deck is empty; it needs at least Discretization, Materials, Blocks and a Solver list".into(),
            })
        }
    };
    let entries =
        match &root.kind {
            NodeKind::List(entries) => entries,
            NodeKind::Scalar(_) => return Err(DeckError::Invalid {
                file: file.to_path_buf(),
                line: Some(root.line),
                key_path: KeyPath::default(),
                message:
                    "the deck must be a list of `Key: value` entries (usually under `Peridigm:`)"
                        .into(),
            }),
        };
    // Unwrap the optional `Peridigm:` root key.
    if entries.len() == 1 && entries[0].key == "Peridigm" {
        if let NodeKind::List(_) = entries[0].value.kind {
            return Ok((entries[0].value.clone(), warnings));
        }
        // `Peridigm:` with nothing under it.
        return Ok((
            Node {
                line: entries[0].line,
                kind: NodeKind::List(Vec::new()),
            },
            warnings,
        ));
    }
    Ok((root, warnings))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn brace_escapes_are_removed_but_escaped_backslashes_kept() {
        assert_eq!(
            strip_brace_escapes(r#""if(t)\{ v; \}""#),
            r#""if(t){ v; }""#
        );
        assert_eq!(strip_brace_escapes(r"a\\{b"), r"a\\{b");
        assert_eq!(strip_brace_escapes("x\n\\}\ny"), "x\n}\ny");
    }
}
