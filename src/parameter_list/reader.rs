//! Typed, checked extraction of values from the [`tree`](super::tree).
//!
//! A [`ListReader`] wraps one list of the deck. Every key the schema code asks for is recorded;
//! when the schema code is done, [`ListReader::finish`] turns every entry nobody asked for into
//! an "unknown key" error with a "did you mean" hint chosen among the keys that were asked for
//! (which are exactly the keys valid at that place).

use std::path::{Path, PathBuf};

use super::error::{DeckError, KeyPath};
use super::tree::{Entry, Node, NodeKind, Scalar, ScalarKind};

/// State shared by the whole read: the file (for messages and relative paths) and warnings.
pub(crate) struct Ctx {
    pub file: PathBuf,
    pub dir: PathBuf,
    pub warnings: Vec<String>,
}

impl Ctx {
    pub fn new(file: &Path) -> Self {
        let dir = file.parent().map(Path::to_path_buf).unwrap_or_default();
        Ctx {
            file: file.to_path_buf(),
            dir,
            warnings: Vec::new(),
        }
    }

    pub fn error(
        &self,
        line: Option<usize>,
        path: &[String],
        message: impl Into<String>,
    ) -> DeckError {
        DeckError::Invalid {
            file: self.file.clone(),
            line,
            key_path: KeyPath(path.to_vec()),
            message: message.into(),
        }
    }

    pub fn warn(&mut self, line: usize, path: &[String], message: impl AsRef<str>) {
        self.warnings.push(format!(
            "{}:{}: {}: {}",
            self.file.display(),
            line,
            KeyPath(path.to_vec()),
            message.as_ref()
        ));
    }

    /// A file name from the deck, relative to the deck's directory unless absolute.
    pub fn resolve(&self, name: &str) -> PathBuf {
        let name = Path::new(name.trim());
        if name.is_absolute() {
            name.to_path_buf()
        } else {
            self.dir.join(name)
        }
    }
}

/// The best "did you mean" candidate for `key` among `candidates`, if any is close enough.
pub(crate) fn suggest<'a>(
    key: &str,
    candidates: impl IntoIterator<Item = &'a str>,
) -> Option<&'a str> {
    let lower = key.to_lowercase();
    let squash = |s: &str| s.to_lowercase().replace([' ', '_', '-'], "");
    let mut best: Option<(&str, f64)> = None;
    for candidate in candidates {
        let c_lower = candidate.to_lowercase();
        let score = if squash(candidate) == squash(key) {
            2.0
        } else {
            strsim::normalized_damerau_levenshtein(&lower, &c_lower)
                .max(strsim::jaro_winkler(&lower, &c_lower) - 0.25)
        };
        if score >= 0.6 && best.is_none_or(|(_, s)| score > s) {
            best = Some((candidate, score));
        }
    }
    best.map(|(c, _)| c)
}

/// One key/value of a list, with its full path, for typed conversion and error messages.
pub(crate) struct Field<'t> {
    pub entry: &'t Entry,
    pub path: Vec<String>,
}

impl<'t> Field<'t> {
    pub fn line(&self) -> usize {
        self.entry.line
    }

    pub fn key(&self) -> &'t str {
        &self.entry.key
    }

    pub fn err(&self, ctx: &Ctx, message: impl Into<String>) -> DeckError {
        ctx.error(Some(self.entry.line), &self.path, message)
    }

    fn scalar(&self, ctx: &Ctx, expected: &str) -> Result<&'t Scalar, DeckError> {
        match &self.entry.value.kind {
            NodeKind::Scalar(s) => Ok(s),
            NodeKind::List(_) => Err(self.err(ctx, format!("expected {expected}, found a list"))),
        }
    }

    /// A finite double; integers are accepted (Peridigm rejects `Horizon: 2`, issue #9; we do
    /// not). Infinity and NaN are refused (a literal beyond ±1.8e308 reads as infinity).
    pub fn f64(&self, ctx: &Ctx) -> Result<f64, DeckError> {
        let s = self.scalar(ctx, "a number")?;
        match s.kind {
            ScalarKind::Double(v) if !v.is_finite() => Err(self.err(
                ctx,
                format!(
                    "{} is not a finite double-precision number (largest: {:e}); give a finite value",
                    s.text.trim(),
                    f64::MAX
                ),
            )),
            ScalarKind::Double(v) => Ok(v),
            ScalarKind::Int(i) => Ok(i as f64),
            ScalarKind::String if super::tree::is_float_literal(s.text.trim()) => Err(self.err(
                ctx,
                format!(
                    "expected a number, found {}; write the number without quotes (XML: type=\"double\")",
                    s.describe()
                ),
            )),
            _ => Err(self.err(ctx, format!("expected a number, found {}", s.describe()))),
        }
    }

    /// A double that must be strictly positive.
    pub fn positive(&self, ctx: &Ctx) -> Result<f64, DeckError> {
        let v = self.f64(ctx)?;
        if v <= 0.0 || !v.is_finite() {
            return Err(self.err(ctx, format!("must be a positive number, found {v}")));
        }
        Ok(v)
    }

    /// A double that must be zero or positive.
    pub fn non_negative(&self, ctx: &Ctx) -> Result<f64, DeckError> {
        let v = self.f64(ctx)?;
        if v < 0.0 || !v.is_finite() {
            return Err(self.err(ctx, format!("must be zero or a positive number, found {v}")));
        }
        Ok(v)
    }

    pub fn i64(&self, ctx: &Ctx) -> Result<i64, DeckError> {
        let s = self.scalar(ctx, "an integer")?;
        match s.kind {
            ScalarKind::Int(i) => Ok(i),
            ScalarKind::Double(_) => Err(self.err(
                ctx,
                format!("expected an integer, found {}; write it without a decimal point (XML: type=\"int\")", s.describe()),
            )),
            ScalarKind::String if super::tree::is_integer_literal(s.text.trim()) => Err(self.err(
                ctx,
                format!("expected an integer, found {}; write it without quotes (XML: type=\"int\")", s.describe()),
            )),
            _ => Err(self.err(ctx, format!("expected an integer, found {}", s.describe()))),
        }
    }

    /// An integer ≥ `min`.
    pub fn int_at_least(&self, ctx: &Ctx, min: i64) -> Result<i64, DeckError> {
        let v = self.i64(ctx)?;
        if v < min {
            return Err(self.err(ctx, format!("must be an integer ≥ {min}, found {v}")));
        }
        Ok(v)
    }

    pub fn bool(&self, ctx: &Ctx) -> Result<bool, DeckError> {
        let s = self.scalar(ctx, "true or false")?;
        match s.kind {
            ScalarKind::Bool(b) => Ok(b),
            ScalarKind::String if matches!(s.text.trim().to_lowercase().as_str(), "true" | "false") => Err(self.err(
                ctx,
                format!("expected true or false, found {}; write it without quotes (XML: type=\"bool\")", s.describe()),
            )),
            _ => Err(self.err(ctx, format!("expected true or false, found {}", s.describe()))),
        }
    }

    /// Any scalar as text (numbers keep their spelling); an empty value is an error.
    pub fn string(&self, ctx: &Ctx) -> Result<String, DeckError> {
        let s = self.scalar(ctx, "a string")?;
        match s.kind {
            ScalarKind::Null => Err(self.err(ctx, "expected a string, found an empty value")),
            _ => Ok(s.text.clone()),
        }
    }

    /// A string that must not be blank.
    pub fn name(&self, ctx: &Ctx) -> Result<String, DeckError> {
        let s = self.string(ctx)?;
        if s.trim().is_empty() {
            return Err(self.err(ctx, "must not be empty"));
        }
        Ok(s.trim().to_string())
    }

    /// One of `choices` (exact spelling); otherwise an error with a suggestion.
    pub fn choice(&self, ctx: &Ctx, choices: &[&'static str]) -> Result<&'static str, DeckError> {
        let s = self.string(ctx)?;
        let s = s.trim();
        if let Some(c) = choices.iter().find(|c| **c == s) {
            return Ok(c);
        }
        Err(self.err(ctx, unknown_value_message(s, choices)))
    }

    /// The value as a list (an empty YAML value counts as an empty list).
    pub fn list(&self, ctx: &Ctx) -> Result<ListReader<'t>, DeckError> {
        match &self.entry.value.kind {
            NodeKind::List(entries) => {
                Ok(ListReader::new(entries, self.path.clone(), self.entry.line))
            }
            NodeKind::Scalar(Scalar {
                kind: ScalarKind::Null,
                ..
            }) => Ok(ListReader::new(&[], self.path.clone(), self.entry.line)),
            NodeKind::Scalar(s) => Err(self.err(
                ctx,
                format!("expected a list of keys, found {}", s.describe()),
            )),
        }
    }

    pub fn is_list(&self) -> bool {
        matches!(self.entry.value.kind, NodeKind::List(_))
    }

    pub fn node(&self) -> &'t Node {
        &self.entry.value
    }
}

/// "unknown value "X"; did you mean "Y"? (valid: A, B, C)"
pub(crate) fn unknown_value_message(value: &str, choices: &[&str]) -> String {
    let list = choices
        .iter()
        .map(|c| format!("\"{c}\""))
        .collect::<Vec<_>>()
        .join(", ");
    match suggest(value, choices.iter().copied()) {
        Some(s) => {
            format!("unknown value \"{value}\"; did you mean \"{s}\"? (valid values: {list})")
        }
        None => format!("unknown value \"{value}\"; valid values are {list}"),
    }
}

/// One list of the deck being read.
pub(crate) struct ListReader<'t> {
    pub path: Vec<String>,
    /// Line of the list's own key (1 for the root).
    pub line: usize,
    entries: &'t [Entry],
    used: Vec<bool>,
    known: Vec<&'static str>,
    /// Keys accepted without effect, with the reason ([`ListReader::without_effect`]).
    without_effect: Vec<(&'static str, &'static str)>,
}

impl<'t> ListReader<'t> {
    pub fn new(entries: &'t [Entry], path: Vec<String>, line: usize) -> Self {
        ListReader {
            path,
            line,
            entries,
            used: vec![false; entries.len()],
            known: Vec::new(),
            without_effect: Vec::new(),
        }
    }

    fn child_path(&self, key: &str) -> Vec<String> {
        let mut p = self.path.clone();
        p.push(key.to_string());
        p
    }

    /// Looks up `key` (marking it as known and, if present, used).
    pub fn get(&mut self, key: &'static str) -> Option<Field<'t>> {
        if !self.known.contains(&key) {
            self.known.push(key);
        }
        let index = self.entries.iter().position(|e| e.key == key)?;
        self.used[index] = true;
        Some(Field {
            entry: &self.entries[index],
            path: self.child_path(key),
        })
    }

    /// Declares keys valid in this list before they are read, so that a missing required key
    /// is not blamed on a valid sibling that happens to look like it (`Search Frequency` is no
    /// misspelt `Search Radius`).
    pub fn expect(&mut self, keys: &[&'static str]) {
        for key in keys {
            if !self.known.contains(key) {
                self.known.push(key);
            }
        }
    }

    /// Accepts `key` in this list although it has no effect here (Peridigm reads it, or its
    /// decks carry it): [`ListReader::finish_with`] warns about it with `why`, as about its own
    /// `ignored` keys.
    pub fn without_effect(&mut self, key: &'static str, why: &'static str) {
        if !self.without_effect.iter().any(|(k, _)| *k == key) {
            self.without_effect.push((key, why));
        }
    }

    /// Looks at `key` without marking it known or used.
    pub fn peek(&self, key: &str) -> Option<Field<'t>> {
        let entry = self.entries.iter().find(|e| e.key == key)?;
        Some(Field {
            entry,
            path: self.child_path(key),
        })
    }

    /// The error for a missing required key. If an unused key of this list is a near miss of
    /// `key` (a typo such as `Densty`) and not itself a key known here (read or
    /// [`expect`](Self::expect)ed), the typo is reported instead, at its own line.
    pub fn missing(&self, ctx: &Ctx, key: &str, what: &str) -> DeckError {
        for (i, e) in self.entries.iter().enumerate() {
            let valid_here = self.known.contains(&e.key.as_str());
            if !self.used[i] && !valid_here && suggest(&e.key, [key]).is_some() {
                return ctx.error(
                    Some(e.line),
                    &self.child_path(&e.key),
                    format!("unknown key; did you mean \"{key}\"? (`{key}` is required here)"),
                );
            }
        }
        let place = if self.path.is_empty() {
            "the top level of the deck".to_string()
        } else {
            format!("the list `{}`", self.path.last().map_or("", |s| s))
        };
        ctx.error(
            Some(self.line),
            &self.child_path(key),
            format!("required key is missing; add `{key}` ({what}) to {place}"),
        )
    }

    pub fn require(
        &mut self,
        ctx: &Ctx,
        key: &'static str,
        what: &str,
    ) -> Result<Field<'t>, DeckError> {
        match self.get(key) {
            Some(f) => Ok(f),
            None => Err(self.missing(ctx, key, what)),
        }
    }

    pub fn f64_req(&mut self, ctx: &Ctx, key: &'static str) -> Result<f64, DeckError> {
        self.require(ctx, key, "a number")?.f64(ctx)
    }

    pub fn f64_opt(&mut self, ctx: &Ctx, key: &'static str) -> Result<Option<f64>, DeckError> {
        self.get(key).map(|f| f.f64(ctx)).transpose()
    }

    pub fn positive_req(&mut self, ctx: &Ctx, key: &'static str) -> Result<f64, DeckError> {
        self.require(ctx, key, "a positive number")?.positive(ctx)
    }

    pub fn positive_opt(&mut self, ctx: &Ctx, key: &'static str) -> Result<Option<f64>, DeckError> {
        self.get(key).map(|f| f.positive(ctx)).transpose()
    }

    pub fn non_negative_opt(
        &mut self,
        ctx: &Ctx,
        key: &'static str,
    ) -> Result<Option<f64>, DeckError> {
        self.get(key).map(|f| f.non_negative(ctx)).transpose()
    }

    pub fn int_req(&mut self, ctx: &Ctx, key: &'static str, min: i64) -> Result<i64, DeckError> {
        self.require(ctx, key, "an integer")?.int_at_least(ctx, min)
    }

    pub fn int_opt(
        &mut self,
        ctx: &Ctx,
        key: &'static str,
        min: i64,
    ) -> Result<Option<i64>, DeckError> {
        self.get(key).map(|f| f.int_at_least(ctx, min)).transpose()
    }

    pub fn bool_or(
        &mut self,
        ctx: &Ctx,
        key: &'static str,
        default: bool,
    ) -> Result<bool, DeckError> {
        Ok(self
            .get(key)
            .map(|f| f.bool(ctx))
            .transpose()?
            .unwrap_or(default))
    }

    /// Reads the flag `key` (default `default`) of a Peridigm feature that has no effect in
    /// peridyn. When the deck sets it to `asks` (the value that would ask Peridigm for the
    /// feature), a warning names the key, its file and line and says why it has no effect
    /// (`why`); the other value is what peridyn does anyway and passes silently.
    pub fn flag_without_effect(
        &mut self,
        ctx: &mut Ctx,
        key: &'static str,
        default: bool,
        asks: bool,
        why: &str,
    ) -> Result<bool, DeckError> {
        let Some(field) = self.get(key) else {
            return Ok(default);
        };
        let value = field.bool(ctx)?;
        if value == asks {
            ctx.warn(
                field.line(),
                &field.path,
                format!("accepted but has no effect: {why}"),
            );
        }
        Ok(value)
    }

    pub fn name_req(&mut self, ctx: &Ctx, key: &'static str) -> Result<String, DeckError> {
        self.require(ctx, key, "a string")?.name(ctx)
    }

    pub fn name_opt(&mut self, ctx: &Ctx, key: &'static str) -> Result<Option<String>, DeckError> {
        self.get(key).map(|f| f.name(ctx)).transpose()
    }

    pub fn list_opt(
        &mut self,
        ctx: &Ctx,
        key: &'static str,
    ) -> Result<Option<ListReader<'t>>, DeckError> {
        self.get(key).map(|f| f.list(ctx)).transpose()
    }

    pub fn list_req(&mut self, ctx: &Ctx, key: &'static str) -> Result<ListReader<'t>, DeckError> {
        self.require(ctx, key, "a list")?.list(ctx)
    }

    /// Every entry in file order, all marked as used (for lists of user-named items).
    pub fn all(&mut self) -> Vec<Field<'t>> {
        self.used.iter_mut().for_each(|u| *u = true);
        self.entries
            .iter()
            .map(|e| Field {
                entry: e,
                path: self.child_path(&e.key),
            })
            .collect()
    }

    /// Entries not asked for so far, in file order, marked as used.
    pub fn take_rest(&mut self) -> Vec<Field<'t>> {
        let mut out = Vec::new();
        for (i, e) in self.entries.iter().enumerate() {
            if !self.used[i] {
                self.used[i] = true;
                out.push(Field {
                    entry: e,
                    path: self.child_path(&e.key),
                });
            }
        }
        out
    }

    /// Ends the reading of this list. Keys in `ignored` (key, why) are accepted with a warning
    /// because Peridigm accepts them but does nothing with them; any other key nobody asked for
    /// is an error with a suggestion. `elsewhere` may explain where an unknown key would be valid.
    pub fn finish_with(
        self,
        ctx: &mut Ctx,
        ignored: &[(&str, &str)],
        elsewhere: impl Fn(&str) -> Option<String>,
    ) -> Result<(), DeckError> {
        for (i, e) in self.entries.iter().enumerate() {
            if self.used[i] {
                continue;
            }
            let path = self.child_path(&e.key);
            let own: &[(&str, &str)] = &self.without_effect;
            if let Some((_, why)) = own.iter().chain(ignored).find(|(k, _)| *k == e.key) {
                ctx.warn(e.line, &path, format!("accepted but has no effect: {why}"));
                continue;
            }
            let mut message = String::from("unknown key");
            // Prefer keys that are valid here and not yet written; a key that is already
            // written is still the best hint for a near miss, with a note.
            let absent = self
                .known
                .iter()
                .copied()
                .filter(|k| !self.entries.iter().any(|x| x.key == *k));
            let suggestion = suggest(&e.key, absent).map(|s| (s, None)).or_else(|| {
                suggest(&e.key, self.known.iter().copied())
                    .map(|s| (s, self.entries.iter().find(|x| x.key == s).map(|x| x.line)))
            });
            if let Some((s, written_at)) = suggestion {
                message.push_str(&format!("; did you mean \"{s}\"?"));
                if let Some(line) = written_at {
                    message.push_str(&format!(" (\"{s}\" is also written on line {line})"));
                }
            } else if let Some(hint) = elsewhere(&e.key) {
                message.push_str(&format!("; {hint}"));
            } else if !self.known.is_empty() {
                let list = self
                    .known
                    .iter()
                    .map(|k| format!("\"{k}\""))
                    .collect::<Vec<_>>()
                    .join(", ");
                message.push_str(&format!("; valid keys here are {list}"));
            }
            if let Some(hint) = elsewhere(&e.key) {
                if !message.contains(&hint) {
                    message.push_str(&format!(" ({hint})"));
                }
            }
            return Err(ctx.error(Some(e.line), &path, message));
        }
        Ok(())
    }

    pub fn finish(self, ctx: &mut Ctx, ignored: &[(&str, &str)]) -> Result<(), DeckError> {
        self.finish_with(ctx, ignored, |_| None)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn suggestions_find_near_misses_only() {
        let keys = ["Density", "Bulk Modulus", "Shear Modulus", "Material Model"];
        assert_eq!(suggest("Densty", keys), Some("Density"));
        assert_eq!(suggest("bulk modulus", keys), Some("Bulk Modulus"));
        assert_eq!(suggest("Shear_Modulus", keys), Some("Shear Modulus"));
        assert_eq!(suggest("Zebra Crossing", keys), None);
    }
}
