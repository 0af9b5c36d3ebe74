//! Teuchos `ParameterList` XML decks → [`tree`](super::tree).
//!
//! `<ParameterList name="N">` becomes a list entry `N`, `<Parameter name="N" type="T"
//! value="V"/>` a scalar of type `T` (`string`, `double`, `int`, `bool`). The root
//! `<ParameterList>` (named or not) is the deck itself.

use std::path::Path;

use quick_xml::events::{BytesStart, Event};
use quick_xml::{Reader, XmlVersion};

use super::error::{DeckError, KeyPath};
use super::tree::{
    is_float_literal, is_integer_literal, too_deep_message, Entry, LineMap, Node, NodeKind, Scalar,
    ScalarKind, MAX_NESTING,
};

struct Open {
    name: Option<String>,
    line: usize,
    entries: Vec<Entry>,
}

struct XmlReader<'a> {
    file: &'a Path,
    text: &'a str,
    lines: LineMap,
    stack: Vec<Open>,
    warnings: Vec<String>,
}

impl XmlReader<'_> {
    fn syntax(&self, offset: usize, message: String) -> DeckError {
        let (line, column) = self.lines.line_col(offset.min(self.text.len()));
        DeckError::Syntax {
            file: self.file.to_path_buf(),
            format: "XML",
            line,
            column,
            message,
        }
    }

    fn path(&self, last: Option<&str>) -> KeyPath {
        let mut keys: Vec<String> = self
            .stack
            .iter()
            .skip(1)
            .filter_map(|o| o.name.clone())
            .collect();
        if let Some(last) = last {
            keys.push(last.to_string());
        }
        KeyPath(keys)
    }

    fn invalid(&self, line: usize, last: Option<&str>, message: String) -> DeckError {
        DeckError::Invalid {
            file: self.file.to_path_buf(),
            line: Some(line),
            key_path: self.path(last),
            message,
        }
    }

    /// Returns the attributes `name`, `type`, `value` (others are an error).
    fn attributes(
        &self,
        element: &BytesStart,
        offset: usize,
        line: usize,
    ) -> Result<[Option<String>; 3], DeckError> {
        let mut out: [Option<String>; 3] = [None, None, None];
        for attribute in element.attributes() {
            let attribute = attribute.map_err(|e| self.syntax(offset, e.to_string()))?;
            let value = attribute
                .normalized_value(XmlVersion::Implicit1_0)
                .map_err(|e| self.syntax(offset, e.to_string()))?
                .into_owned();
            let slot = match attribute.key.as_ref() {
                "name" => 0,
                "type" => 1,
                "value" => 2,
                // Teuchos writes these for validators and documentation; they carry no value.
                "docString" | "id" | "validatorId" => continue,
                other => {
                    let other = other.to_string();
                    return Err(self.invalid(
                        line,
                        None,
                        format!("unknown XML attribute `{other}`; use name=, type= and value="),
                    ));
                }
            };
            out[slot] = Some(value);
        }
        Ok(out)
    }

    fn push_entry(&mut self, entry: Entry) -> Result<(), DeckError> {
        let Some(top) = self.stack.last_mut() else {
            unreachable!("entries are pushed inside the root list")
        };
        if let Some(previous) = top.entries.iter().find(|e| e.key == entry.key) {
            let previous_line = previous.line;
            let same_scalar = matches!(
                (&previous.value.kind, &entry.value.kind),
                (NodeKind::Scalar(a), NodeKind::Scalar(b)) if a == b
            );
            if same_scalar {
                // Teuchos keeps the last of two equal definitions; Peridigm's own decks do this.
                let path = self.path(Some(&entry.key));
                self.warnings.push(format!(
                    "{}:{}: {}: written twice with the same value (first on line {}); the repetition has no effect",
                    self.file.display(),
                    entry.line,
                    path,
                    previous_line
                ));
                return Ok(());
            }
            let message = format!(
                "written twice with different content (first on line {previous_line}); Peridigm would silently keep the last one: remove one of them"
            );
            return Err(self.invalid(entry.line, Some(&entry.key), message));
        }
        top.entries.push(entry);
        Ok(())
    }

    fn parameter(
        &self,
        element: &BytesStart,
        offset: usize,
        line: usize,
    ) -> Result<Entry, DeckError> {
        let [name, kind, value] = self.attributes(element, offset, line)?;
        let name = name.ok_or_else(|| {
            self.invalid(line, None, "<Parameter> without a name= attribute".into())
        })?;
        let kind = kind.ok_or_else(|| {
            self.invalid(
                line,
                Some(&name),
                "<Parameter> without a type= attribute; use string, double, int or bool".into(),
            )
        })?;
        let text = value.ok_or_else(|| {
            self.invalid(
                line,
                Some(&name),
                "<Parameter> without a value= attribute".into(),
            )
        })?;
        let trimmed = text.trim();
        let bad = |what: &str| {
            self.invalid(
                line,
                Some(&name),
                format!("value=\"{text}\" is not a valid {what} (type=\"{kind}\")"),
            )
        };
        let scalar_kind = match kind.as_str() {
            "string" => ScalarKind::String,
            "double" | "float" => {
                if !(is_float_literal(trimmed) || is_integer_literal(trimmed)) {
                    return Err(bad("number"));
                }
                ScalarKind::Double(trimmed.parse().map_err(|_| bad("number"))?)
            }
            "int" | "long long" => {
                if !is_integer_literal(trimmed) {
                    return Err(bad("integer"));
                }
                ScalarKind::Int(trimmed.parse().map_err(|_| bad("integer"))?)
            }
            "bool" => match trimmed.to_ascii_lowercase().as_str() {
                // Teuchos' XML reader also takes 1/0 (Peridigm's Compression_NLCGQS deck uses it).
                "true" | "1" | "yes" => ScalarKind::Bool(true),
                "false" | "0" | "no" => ScalarKind::Bool(false),
                _ => return Err(bad("boolean (true or false)")),
            },
            other => {
                return Err(self.invalid(
                    line,
                    Some(&name),
                    format!(
                        "unsupported parameter type \"{other}\"; use string, double, int or bool"
                    ),
                ))
            }
        };
        let text = if matches!(scalar_kind, ScalarKind::String) {
            text
        } else {
            trimmed.to_string()
        };
        Ok(Entry {
            key: name,
            line,
            value: Node {
                line,
                kind: NodeKind::Scalar(Scalar {
                    text,
                    kind: scalar_kind,
                }),
            },
        })
    }

    fn run(mut self) -> Result<(Node, Vec<String>), DeckError> {
        let mut reader = Reader::from_str(self.text);
        reader.config_mut().check_end_names = true;
        let mut root: Option<Node> = None;
        loop {
            let before = reader.buffer_position() as usize;
            let event = reader
                .read_event()
                .map_err(|e| self.syntax(reader.error_position() as usize, e.to_string()))?;
            // The element starts at the first '<' at or after the end of the previous event.
            let start = self.text[before..].find('<').map_or(before, |i| before + i);
            let line = self.lines.line_col(start).0;
            match event {
                Event::Start(_) | Event::Empty(_) if root.is_some() => {
                    return Err(self.syntax(
                        start,
                        "content after the closing </ParameterList> of the deck".into(),
                    ));
                }
                Event::Start(element) => self.start_element(&element, start, line)?,
                Event::Empty(element) => {
                    if let Some(node) = self.empty_element(&element, start, line)? {
                        root = Some(node);
                    }
                }
                Event::End(_) => {
                    if let Some(node) = self.end_element()? {
                        root = Some(node);
                    }
                }
                Event::Text(text) => {
                    if !text.chars().all(char::is_whitespace) {
                        return Err(self.syntax(
                            before,
                            "unexpected text between elements; values go in value=\"...\"".into(),
                        ));
                    }
                }
                Event::GeneralRef(_) | Event::CData(_) => {
                    return Err(self.syntax(
                        start,
                        "unexpected text between elements; values go in value=\"...\"".into(),
                    ));
                }
                Event::Comment(_) | Event::Decl(_) | Event::PI(_) | Event::DocType(_) => {}
                Event::Eof => break,
            }
        }
        if !self.stack.is_empty() {
            return Err(self.syntax(
                self.text.len(),
                "unexpected end of file: a <ParameterList> is not closed".into(),
            ));
        }
        match root {
            Some(root) => Ok((root, self.warnings)),
            None => Err(self.syntax(
                0,
                "no <ParameterList> found; a Peridigm XML deck is one <ParameterList>".into(),
            )),
        }
    }

    /// `<ParameterList name="..">`: opens a list.
    fn start_element(
        &mut self,
        element: &BytesStart,
        start: usize,
        line: usize,
    ) -> Result<(), DeckError> {
        let tag = element.name().as_ref().to_string();
        match tag.as_str() {
            "ParameterList" => {
                let [name, _, _] = self.attributes(element, start, line)?;
                if !self.stack.is_empty() && name.is_none() {
                    return Err(self.invalid(line, None, "nested <ParameterList> without a name= attribute".into()));
                }
                if self.stack.len() >= MAX_NESTING {
                    return Err(self.invalid(line, name.as_deref(), too_deep_message()));
                }
                self.stack.push(Open { name, line, entries: Vec::new() });
                Ok(())
            }
            "Parameter" => {
                Err(self.syntax(start, "<Parameter> must be an empty element: <Parameter name=\"..\" type=\"..\" value=\"..\"/>".into()))
            }
            other => Err(self.unknown_element(other, start)),
        }
    }

    /// `<Parameter .../>` or an empty `<ParameterList .../>`; returns the root when the
    /// empty list is the whole deck.
    fn empty_element(
        &mut self,
        element: &BytesStart,
        start: usize,
        line: usize,
    ) -> Result<Option<Node>, DeckError> {
        let tag = element.name().as_ref().to_string();
        match tag.as_str() {
            "Parameter" => {
                if self.stack.is_empty() {
                    return Err(
                        self.syntax(start, "the deck must start with <ParameterList>".into())
                    );
                }
                let entry = self.parameter(element, start, line)?;
                self.push_entry(entry)?;
            }
            "ParameterList" => {
                let [name, _, _] = self.attributes(element, start, line)?;
                let node = Node {
                    line,
                    kind: NodeKind::List(Vec::new()),
                };
                match name {
                    Some(name) if !self.stack.is_empty() => self.push_entry(Entry {
                        key: name,
                        line,
                        value: node,
                    })?,
                    _ if self.stack.is_empty() => return Ok(Some(node)),
                    _ => {
                        return Err(self.invalid(
                            line,
                            None,
                            "nested <ParameterList> without a name= attribute".into(),
                        ))
                    }
                }
            }
            other => return Err(self.unknown_element(other, start)),
        }
        Ok(None)
    }

    /// `</ParameterList>`: closes the innermost list; returns the root when it is the deck.
    fn end_element(&mut self) -> Result<Option<Node>, DeckError> {
        let Some(open) = self.stack.pop() else {
            unreachable!("quick-xml checks that end tags match start tags")
        };
        let node = Node {
            line: open.line,
            kind: NodeKind::List(open.entries),
        };
        if self.stack.is_empty() {
            return Ok(Some(node));
        }
        let key = open.name.unwrap_or_default();
        self.push_entry(Entry {
            key,
            line: open.line,
            value: node,
        })?;
        Ok(None)
    }

    fn unknown_element(&self, tag: &str, offset: usize) -> DeckError {
        self.syntax(
            offset,
            format!(
                "unknown element <{tag}>; a Peridigm XML deck contains only <ParameterList> and <Parameter>"
            ),
        )
    }
}

/// Parses XML text into the root list of the deck.
///
/// Also returns warnings (repeated keys with identical values).
pub(crate) fn parse(text: &str, file: &Path) -> Result<(Node, Vec<String>), DeckError> {
    XmlReader {
        file,
        text,
        lines: LineMap::new(text),
        stack: Vec::new(),
        warnings: Vec::new(),
    }
    .run()
}
