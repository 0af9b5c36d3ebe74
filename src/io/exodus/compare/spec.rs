//! What to compare and with which tolerances: exodiff's `Tolerance` semantics and its command
//! (`.comp`) files.

use std::fmt;
use std::path::Path;

use super::super::ExodusError;

/// How a difference is measured.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ToleranceKind {
    /// `|a − b| / max(|a|, |b|)`.
    Relative,
    /// `|a − b|`.
    Absolute,
    /// `|a − b| / max(1, |a|, |b|)` (exodiff's "combined").
    Combined,
    /// Relative difference of the absolute values.
    EigenRelative,
    /// Absolute difference of the absolute values.
    EigenAbsolute,
    /// Combined difference of the absolute values.
    EigenCombined,
    /// Never a difference.
    Ignore,
}

impl ToleranceKind {
    fn name(self) -> &'static str {
        match self {
            ToleranceKind::Relative => "relative",
            ToleranceKind::Absolute => "absolute",
            ToleranceKind::Combined => "combined",
            ToleranceKind::EigenRelative => "eigen_relative",
            ToleranceKind::EigenAbsolute => "eigen_absolute",
            ToleranceKind::EigenCombined => "eigen_combined",
            ToleranceKind::Ignore => "ignore",
        }
    }

    /// exodiff's keyword, abbreviated to at least 3 (eigen_*: 7) letters.
    fn parse(token: &str) -> Option<Self> {
        let t = token.to_ascii_lowercase();
        [
            (ToleranceKind::Relative, "relative", 3),
            (ToleranceKind::Absolute, "absolute", 3),
            (ToleranceKind::Combined, "combined", 3),
            (ToleranceKind::EigenRelative, "eigen_relative", 7),
            (ToleranceKind::EigenAbsolute, "eigen_absolute", 7),
            (ToleranceKind::EigenCombined, "eigen_combined", 7),
            (ToleranceKind::Ignore, "ignore", 3),
        ]
        .into_iter()
        .find(|(_, word, min)| abbreviates(&t, word, *min))
        .map(|(kind, _, _)| kind)
    }
}

/// A tolerance: kind, value and floor (see the module documentation for the formulas).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tolerance {
    /// How the difference is measured.
    pub kind: ToleranceKind,
    /// Largest accepted difference.
    pub value: f64,
    /// Values with `|a| <= floor` and `|b| <= floor` are equal.
    pub floor: f64,
}

impl Tolerance {
    /// exodiff's default for variables: relative 1e-6, floor 0.
    pub const DEFAULT_VARIABLES: Tolerance = Tolerance {
        kind: ToleranceKind::Relative,
        value: 1e-6,
        floor: 0.0,
    };
    /// exodiff's default for coordinates: absolute 1e-6, floor 0.
    pub const DEFAULT_COORDINATES: Tolerance = Tolerance {
        kind: ToleranceKind::Absolute,
        value: 1e-6,
        floor: 0.0,
    };
    /// exodiff's default for times: relative 1e-6, floor 1e-15.
    pub const DEFAULT_TIMES: Tolerance = Tolerance {
        kind: ToleranceKind::Relative,
        value: 1e-6,
        floor: 1e-15,
    };

    /// The difference in this tolerance's measure (0 below the floor, +∞ for NaN).
    pub fn difference(&self, a: f64, b: f64) -> f64 {
        if self.kind == ToleranceKind::Ignore {
            return 0.0;
        }
        if a.is_nan() || b.is_nan() {
            return f64::INFINITY;
        }
        if a.abs() <= self.floor && b.abs() <= self.floor {
            return 0.0;
        }
        let (x, y) = match self.kind {
            ToleranceKind::EigenRelative
            | ToleranceKind::EigenAbsolute
            | ToleranceKind::EigenCombined => (a.abs(), b.abs()),
            _ => (a, b),
        };
        let delta = (x - y).abs();
        let max = x.abs().max(y.abs());
        match self.kind {
            ToleranceKind::Relative | ToleranceKind::EigenRelative => {
                if max == 0.0 {
                    0.0
                } else {
                    delta / max
                }
            }
            ToleranceKind::Absolute | ToleranceKind::EigenAbsolute => delta,
            ToleranceKind::Combined | ToleranceKind::EigenCombined => delta / max.max(1.0),
            ToleranceKind::Ignore => 0.0,
        }
    }

    /// Whether `a` and `b` differ beyond this tolerance.
    pub fn exceeded(&self, a: f64, b: f64) -> bool {
        if self.kind == ToleranceKind::Ignore {
            return false;
        }
        let d = self.difference(a, b);
        match self.kind {
            // exodiff uses `>=` for the combined measure and `>` otherwise.
            ToleranceKind::Combined | ToleranceKind::EigenCombined => d >= self.value && d > 0.0,
            _ => d > self.value,
        }
    }
}

impl fmt::Display for Tolerance {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.kind == ToleranceKind::Ignore {
            return write!(f, "ignore");
        }
        write!(f, "{} {:e}", self.kind.name(), self.value)?;
        if self.floor > 0.0 {
            write!(f, " floor {:e}", self.floor)?;
        }
        Ok(())
    }
}

/// Which variables of one type are compared, and how.
#[derive(Debug, Clone, PartialEq)]
pub struct VariableSection {
    /// Tolerance of variables without their own.
    pub default: Tolerance,
    /// `(all)`: compare every variable even though some are listed.
    pub all: bool,
    /// Listed variables and their tolerances.
    pub listed: Vec<(String, Tolerance)>,
    /// Variables excluded with `!name`.
    pub excluded: Vec<String>,
}

impl VariableSection {
    /// Every variable with `tolerance`.
    pub fn all_with(tolerance: Tolerance) -> Self {
        VariableSection {
            default: tolerance,
            all: true,
            listed: Vec::new(),
            excluded: Vec::new(),
        }
    }

    /// Tolerance for variable `name`, or `None` if it is not compared.
    pub fn tolerance_for(&self, name: &str, ignore_case: bool) -> Option<Tolerance> {
        let same = |a: &str| names_equal(a, name, ignore_case);
        if self.excluded.iter().any(|n| same(n)) {
            return None;
        }
        if let Some((_, tol)) = self.listed.iter().find(|(n, _)| same(n)) {
            return Some(*tol);
        }
        (self.all || self.listed.is_empty()).then_some(self.default)
    }
}

/// Whether two variable names are the same (ASCII case aside when `ignore_case`).
pub(super) fn names_equal(a: &str, b: &str, ignore_case: bool) -> bool {
    if ignore_case {
        a.eq_ignore_ascii_case(b)
    } else {
        a == b
    }
}

/// What to compare and with which tolerances (an exodiff command file).
#[derive(Debug, Clone, PartialEq)]
pub struct ComparisonSpec {
    /// Tolerance on node coordinates.
    pub coordinates: Tolerance,
    /// Tolerance on the time values.
    pub time_steps: Tolerance,
    /// Global variables, `None`: not compared.
    pub global: Option<VariableSection>,
    /// Nodal variables, `None`: not compared.
    pub nodal: Option<VariableSection>,
    /// Element variables, `None`: not compared.
    pub element: Option<VariableSection>,
    /// Compare variable names case-insensitively (exodiff's default).
    pub ignore_case: bool,
}

impl Default for ComparisonSpec {
    /// exodiff without a command file: everything, relative 1e-6 for variables, absolute 1e-6
    /// for coordinates, relative 1e-6 with floor 1e-15 for times.
    fn default() -> Self {
        ComparisonSpec {
            coordinates: Tolerance::DEFAULT_COORDINATES,
            time_steps: Tolerance::DEFAULT_TIMES,
            global: Some(VariableSection::all_with(Tolerance::DEFAULT_VARIABLES)),
            nodal: Some(VariableSection::all_with(Tolerance::DEFAULT_VARIABLES)),
            element: Some(VariableSection::all_with(Tolerance::DEFAULT_VARIABLES)),
            ignore_case: true,
        }
    }
}

/// `token` is an abbreviation of `word` with at least `min` letters (case already lowered).
fn abbreviates(token: &str, word: &str, min: usize) -> bool {
    token.len() >= min.min(word.len()) && word.starts_with(token)
}

/// Splits a command-file line into tokens (whitespace, `=` and `,` separate; `#` starts a
/// comment).
fn tokens(line: &str) -> Vec<&str> {
    let code = line.split('#').next().unwrap_or("");
    code.split(|c: char| c.is_whitespace() || c == '=' || c == ',')
        .filter(|t| !t.is_empty())
        .collect()
}

struct Parser<'a> {
    path: &'a Path,
    line: usize,
}

impl Parser<'_> {
    fn error(&self, problem: impl Into<String>) -> ExodusError {
        ExodusError::CommandFile {
            path: self.path.to_path_buf(),
            line: self.line,
            problem: problem.into(),
        }
    }

    fn number(&self, token: Option<&str>, what: &str) -> Result<f64, ExodusError> {
        let token = token.ok_or_else(|| self.error(format!("expected a {what} value")))?;
        let value: f64 = token
            .parse()
            .map_err(|_| self.error(format!("'{token}' is not a number ({what})")))?;
        if !value.is_finite() || value < 0.0 {
            return Err(self.error(format!("{what} must be a non-negative number, got {token}")));
        }
        Ok(value)
    }

    /// Parses `[kind] [value] [floor f]` starting from `base`. With `value_required`, a kind
    /// must be followed by a value (section and default lines); on variable lines a kind may
    /// be followed directly by `floor`, keeping the base value (exodiff's rule).
    fn tolerance(
        &self,
        words: &[&str],
        base: Tolerance,
        value_required: bool,
    ) -> Result<Tolerance, ExodusError> {
        let mut tol = base;
        let mut rest = words.iter().copied().peekable();
        let is_floor = |t: &str| abbreviates(&t.to_ascii_lowercase(), "floor", 3);
        if let Some(&first) = rest.peek() {
            if let Some(kind) = ToleranceKind::parse(first) {
                rest.next();
                tol.kind = kind;
                if kind == ToleranceKind::Ignore {
                    tol.value = 0.0;
                } else if value_required || rest.peek().is_some_and(|t| !is_floor(t)) {
                    tol.value = self.number(rest.next(), "tolerance")?;
                }
            } else if !is_floor(first) {
                tol.value = self.number(rest.next(), "tolerance")?;
            }
        }
        if let Some(word) = rest.next() {
            if !is_floor(word) {
                return Err(self.error(format!(
                    "unexpected '{word}'; expected 'floor <value>' or the end of the line"
                )));
            }
            tol.floor = self.number(rest.next(), "floor")?;
        }
        if let Some(extra) = rest.next() {
            return Err(self.error(format!("unexpected '{extra}' at the end of the line")));
        }
        Ok(tol)
    }
}

impl ComparisonSpec {
    /// Reads and parses an exodiff command file.
    pub fn from_file(path: &Path) -> Result<Self, ExodusError> {
        let text = std::fs::read_to_string(path).map_err(|source| ExodusError::Io {
            path: path.to_path_buf(),
            action: "read",
            source,
        })?;
        Self::parse_named(&text, path)
    }

    /// Parses the text of an exodiff command file (see the module documentation).
    pub fn parse(text: &str) -> Result<Self, ExodusError> {
        Self::parse_named(text, Path::new("<command file>"))
    }

    fn parse_named(text: &str, path: &Path) -> Result<Self, ExodusError> {
        let mut reader = CommandFileReader::new(path);
        for (number, raw) in text.lines().enumerate() {
            reader.parser.line = number + 1;
            reader.line(raw)?;
        }
        reader.finish()
    }
}

/// An exodiff command file being read line by line.
struct CommandFileReader<'a> {
    parser: Parser<'a>,
    spec: ComparisonSpec,
    default_tol: Tolerance,
    default_given: bool,
    /// Which section indented variable lines belong to (0 global, 1 nodal, 2 element).
    open_section: Option<usize>,
    sections: [Option<VariableSection>; 3],
}

impl<'a> CommandFileReader<'a> {
    fn new(path: &'a Path) -> Self {
        CommandFileReader {
            parser: Parser { path, line: 0 },
            spec: ComparisonSpec {
                coordinates: Tolerance::DEFAULT_COORDINATES,
                time_steps: Tolerance::DEFAULT_TIMES,
                global: None,
                nodal: None,
                element: None,
                ignore_case: true,
            },
            default_tol: Tolerance::DEFAULT_VARIABLES,
            default_given: false,
            open_section: None,
            sections: [None, None, None],
        }
    }

    /// Reads one line: blank, comment, variable line (indented) or command.
    fn line(&mut self, raw: &str) -> Result<(), ExodusError> {
        let words = tokens(raw);
        let indented = raw.starts_with(|c: char| c.is_whitespace());
        let comment_only = raw.trim_start().starts_with('#');
        if raw.trim().is_empty() {
            self.open_section = None; // exodiff ends a variable list at a blank line
            return Ok(());
        }
        if comment_only {
            return Ok(());
        }
        if indented {
            return self.variable_line(&words);
        }
        self.open_section = None;
        self.command(raw, &words)
    }

    /// An indented line of a variable section: a name with its tolerance, or `!name`.
    fn variable_line(&mut self, words: &[&str]) -> Result<(), ExodusError> {
        let Some(index) = self.open_section else {
            return Err(self
                .parser
                .error("indented variable line outside a GLOBAL/NODAL/ELEMENT VARIABLES section"));
        };
        let section = self.sections[index].as_mut().expect("open section exists");
        let name = words[0];
        if let Some(excluded) = name.strip_prefix('!') {
            if !excluded.is_empty() {
                section.excluded.push(excluded.to_string());
            }
            return Ok(());
        }
        let tol = self.parser.tolerance(&words[1..], section.default, false)?;
        section.listed.push((name.to_string(), tol));
        Ok(())
    }

    /// A command line (not indented).
    fn command(&mut self, raw: &str, words: &[&str]) -> Result<(), ExodusError> {
        let parser = &self.parser;
        let first = words[0].to_ascii_lowercase();
        let second = words
            .get(1)
            .map(|w| w.to_ascii_lowercase())
            .unwrap_or_default();
        if abbreviates(&first, "default", 3) && abbreviates(&second, "tolerance", 3) {
            self.default_tol = parser.tolerance(&words[2..], self.default_tol, true)?;
            self.default_given = true;
        } else if abbreviates(&first, "coordinates", 4) {
            let base = if self.default_given {
                self.default_tol
            } else {
                Tolerance::DEFAULT_COORDINATES
            };
            self.spec.coordinates = parser.tolerance(&words[1..], base, true)?;
        } else if first == "time" && abbreviates(&second, "steps", 4) {
            self.spec.time_steps = parser.tolerance(&words[2..], self.default_tol, true)?;
        } else if abbreviates(&second, "variables", 3)
            && (abbreviates(&first, "global", 4)
                || abbreviates(&first, "nodal", 4)
                || abbreviates(&first, "element", 4))
        {
            self.section_line(&first, words)?;
        } else if abbreviates(&first, "ignore", 3) && abbreviates(&second, "case", 3) {
            self.spec.ignore_case = true;
        } else if abbreviates(&first, "case", 3) && abbreviates(&second, "sensitive", 3) {
            self.spec.ignore_case = false;
        } else if (abbreviates(&first, "max", 3) && abbreviates(&second, "names", 3))
            || (abbreviates(&first, "return", 3) && abbreviates(&second, "status", 3))
        {
            // No limit on names here, and the status is always returned: nothing to do.
        } else {
            return Err(parser.error(format!(
                "unsupported or unknown command '{}'; supported: DEFAULT TOLERANCE, \
                 COORDINATES, TIME STEPS, GLOBAL/NODAL/ELEMENT VARIABLES, IGNORE CASE, \
                 CASE SENSITIVE",
                raw.trim()
            )));
        }
        Ok(())
    }

    /// `GLOBAL/NODAL/ELEMENT VARIABLES [(all)] [tolerance]`: opens the section.
    fn section_line(&mut self, first: &str, words: &[&str]) -> Result<(), ExodusError> {
        let index = if first.starts_with("glo") {
            0
        } else if first.starts_with("nod") {
            1
        } else {
            2
        };
        let mut rest = &words[2..];
        let mut all = false;
        if let Some(w) = rest.first() {
            if w.eq_ignore_ascii_case("(all)") || w.eq_ignore_ascii_case("all") {
                all = true;
                rest = &rest[1..];
            }
        }
        let default = self.parser.tolerance(rest, self.default_tol, true)?;
        self.sections[index] = Some(VariableSection {
            default,
            all,
            listed: Vec::new(),
            excluded: Vec::new(),
        });
        self.open_section = Some(index);
        Ok(())
    }

    /// Applies exodiff's rules on the finished sections and returns the specification.
    fn finish(mut self) -> Result<ComparisonSpec, ExodusError> {
        for section in self.sections.iter_mut().flatten() {
            // Only exclusions: everything else is compared (exodiff's rule).
            if section.listed.is_empty() {
                section.all = true;
            } else if !section.all && !section.excluded.is_empty() {
                return Err(self
                    .parser
                    .error("a variable list mixes included and !excluded names without '(all)'"));
            }
        }
        let [global, nodal, element] = self.sections;
        self.spec.global = global;
        self.spec.nodal = nodal;
        self.spec.element = element;
        Ok(self.spec)
    }
}
