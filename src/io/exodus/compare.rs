//! Comparing two Exodus results files the way SEACAS `exodiff` does, driven by exodiff's
//! command (`.comp`) files as used in Peridigm's regression suite.
//!
//! Semantics (those of exodiff's command files and `Tolerance` class):
//!
//! * A value pair `(a, b)` is equal when `|a| <= floor` and `|b| <= floor`; otherwise
//!   - `relative v`: different if `|a − b| > v · max(|a|, |b|)` (equal if both are 0);
//!   - `absolute v`: different if `|a − b| > v`;
//!   - `combined v`: different if `|a − b| >= v · max(1, |a|, |b|)`;
//!   - `eigen_relative / eigen_absolute / eigen_combined v`: the same on `|a|` and `|b|`;
//!   - `ignore`: never different.
//!
//!   A NaN in either file is always a difference (exodiff reports NaNs unless told not to).
//! * Without a command file ([`ComparisonSpec::default`]) every global, nodal and element
//!   variable is compared with `relative 1e-6 floor 0`, coordinates with `absolute 1e-6`,
//!   times with `relative 1e-6 floor 1e-15`.
//! * With a command file, only the variable types that have a `… VARIABLES` line are compared.
//!   Under such a line, indented names restrict the comparison to exactly those variables
//!   (each with its own tolerance, or the section's); names prefixed with `!` are excluded;
//!   `(all)` compares every variable, listed ones with their own tolerances. A section line
//!   with no names compares every variable of that type.
//! * `DEFAULT TOLERANCE` sets the tolerance that later section lines start from (and that
//!   `TIME STEPS` and, once given, `COORDINATES` start from); values on a section line
//!   override it for that section, values on a variable line for that variable. A variable
//!   line with a type but no value, e.g. `VELX relative floor 1e-10`, keeps the section value.
//! * Keywords are case-insensitive and may be abbreviated to three letters; variable names
//!   are compared case-insensitively (exodiff's default; `CASE SENSITIVE` switches it off).
//! * Lines end at `#` (comment). A blank line ends a variable list, as in exodiff. exodiff
//!   requires variable lines to start with a tab; we accept any leading whitespace.
//!
//! Files are matched by position: nodes by index, element blocks by id (elements by index
//! inside the block), time steps by index, variables by name.

use std::cmp::Ordering;
use std::fmt;
use std::path::Path;

use super::{ExodusError, ExodusFile};

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

fn names_equal(a: &str, b: &str, ignore_case: bool) -> bool {
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

/// Which kind of quantity a difference is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum QuantityKind {
    /// A node coordinate.
    Coordinate,
    /// The time value of a step.
    Time,
    /// A global variable.
    Global,
    /// A nodal variable.
    Nodal,
    /// An element variable.
    Element,
}

impl fmt::Display for QuantityKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            QuantityKind::Coordinate => "coordinate",
            QuantityKind::Time => "time",
            QuantityKind::Global => "global",
            QuantityKind::Nodal => "nodal",
            QuantityKind::Element => "element",
        })
    }
}

/// The largest difference found for one quantity.
#[derive(Debug, Clone, PartialEq)]
pub struct WorstDifference {
    /// Kind of quantity.
    pub kind: QuantityKind,
    /// Variable name (`X`/`Y`/`Z` for coordinates, `time` for times).
    pub name: String,
    /// Block id for element variables.
    pub block_id: Option<i64>,
    /// 0-based time step, where applicable.
    pub step: Option<usize>,
    /// 0-based node / element-in-block / global-variable index.
    pub index: usize,
    /// Value in the first file.
    pub first: f64,
    /// Value in the second file.
    pub second: f64,
    /// Difference in the tolerance's measure.
    pub difference: f64,
    /// The tolerance applied.
    pub tolerance: Tolerance,
    /// Number of values outside the tolerance.
    pub failures: usize,
    /// Number of values compared.
    pub compared: usize,
}

impl WorstDifference {
    /// Whether any value was outside the tolerance.
    pub fn failed(&self) -> bool {
        self.failures > 0
    }

    /// Difference relative to the tolerance (for ranking; ∞ for any difference at tolerance 0).
    pub fn severity(&self) -> f64 {
        if self.tolerance.value > 0.0 {
            self.difference / self.tolerance.value
        } else if self.difference > 0.0 {
            f64::INFINITY
        } else {
            0.0
        }
    }
}

impl fmt::Display for WorstDifference {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} {}", self.kind, self.name)?;
        if let Some(id) = self.block_id {
            write!(f, " (block {id})")?;
        }
        write!(
            f,
            ": worst difference {:.3e} ({}) at",
            self.difference, self.tolerance
        )?;
        if let Some(step) = self.step {
            write!(f, " step {step},")?;
        }
        write!(
            f,
            " index {}: {:e} vs {:e}",
            self.index, self.first, self.second
        )?;
        if self.failed() {
            write!(f, "; {} of {} values differ", self.failures, self.compared)?;
        }
        Ok(())
    }
}

/// The outcome of [`compare`].
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ComparisonReport {
    /// Worst difference of every compared quantity (coordinate axis, time, variable).
    pub quantities: Vec<WorstDifference>,
    /// Structural mismatches (counts, missing blocks or variables); any one fails.
    pub structural: Vec<String>,
    /// Notes that do not fail the comparison (e.g. variables only in the second file).
    pub warnings: Vec<String>,
}

impl ComparisonReport {
    /// True when there is no structural mismatch and every value is within tolerance.
    pub fn passed(&self) -> bool {
        self.structural.is_empty() && self.quantities.iter().all(|q| !q.failed())
    }

    /// Quantities with values outside tolerance, worst (by difference / tolerance) first.
    pub fn failures(&self) -> Vec<&WorstDifference> {
        let mut failed: Vec<&WorstDifference> =
            self.quantities.iter().filter(|q| q.failed()).collect();
        failed.sort_by(|a, b| {
            b.severity()
                .partial_cmp(&a.severity())
                .unwrap_or(Ordering::Equal)
        });
        failed
    }

    /// The worst difference recorded for `name` (case-insensitive), if compared.
    pub fn quantity(&self, kind: QuantityKind, name: &str) -> Option<&WorstDifference> {
        self.quantities
            .iter()
            .filter(|q| q.kind == kind && q.name.eq_ignore_ascii_case(name))
            .max_by(|a, b| {
                a.severity()
                    .partial_cmp(&b.severity())
                    .unwrap_or(Ordering::Equal)
            })
    }
}

impl fmt::Display for ComparisonReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let failures = self.failures();
        if self.passed() {
            writeln!(
                f,
                "PASSED: {} quantities compared, all within tolerance",
                self.quantities.len()
            )?;
        } else {
            writeln!(
                f,
                "FAILED: {} structural mismatch(es), {} of {} quantities outside tolerance",
                self.structural.len(),
                failures.len(),
                self.quantities.len()
            )?;
        }
        for s in &self.structural {
            writeln!(f, "  mismatch: {s}")?;
        }
        const SHOWN: usize = 10;
        for q in failures.iter().take(SHOWN) {
            writeln!(f, "  DIFF {q}")?;
        }
        if failures.len() > SHOWN {
            writeln!(f, "  … and {} more", failures.len() - SHOWN)?;
        }
        if failures.is_empty() {
            // Closest calls, so a pass can be judged too.
            let mut closest: Vec<&WorstDifference> = self.quantities.iter().collect();
            closest.sort_by(|a, b| {
                b.severity()
                    .partial_cmp(&a.severity())
                    .unwrap_or(Ordering::Equal)
            });
            for q in closest.iter().take(3).filter(|q| q.difference > 0.0) {
                writeln!(f, "  closest: {q}")?;
            }
        }
        for w in &self.warnings {
            writeln!(f, "  warning: {w}")?;
        }
        Ok(())
    }
}

/// Accumulates the worst difference of one quantity.
struct Tracker {
    worst: WorstDifference,
    worst_severity: f64,
}

impl Tracker {
    fn new(kind: QuantityKind, name: &str, block_id: Option<i64>, tolerance: Tolerance) -> Self {
        Tracker {
            worst: WorstDifference {
                kind,
                name: name.to_string(),
                block_id,
                step: None,
                index: 0,
                first: 0.0,
                second: 0.0,
                difference: 0.0,
                tolerance,
                failures: 0,
                compared: 0,
            },
            worst_severity: -1.0,
        }
    }

    /// Adds value pairs; `offset` is the index of the first pair within the quantity.
    fn add(&mut self, step: Option<usize>, offset: usize, first: &[f64], second: &[f64]) {
        let tol = self.worst.tolerance;
        for (i, (&a, &b)) in first.iter().zip(second).enumerate() {
            let index = offset + i;
            let difference = tol.difference(a, b);
            self.worst.compared += 1;
            if tol.exceeded(a, b) {
                self.worst.failures += 1;
            }
            if difference > self.worst_severity {
                self.worst_severity = difference;
                self.worst.step = step;
                self.worst.index = index;
                self.worst.first = a;
                self.worst.second = b;
                self.worst.difference = difference;
            }
        }
    }
}

/// Compares `first` with `second` as exodiff would with `spec` (see the module docs).
///
/// Errors only when reading values fails; differences are reported in the result.
pub fn compare(
    first: &ExodusFile,
    second: &ExodusFile,
    spec: &ComparisonSpec,
) -> Result<ComparisonReport, ExodusError> {
    compare_from(first, second, spec, None)
}

/// [`compare`] with frame k of `first` against frame k + `offset` of `second` when `offset` is
/// given (exodiff's `-TimeStepOffset`): a run that covers part of another's time span (a
/// restarted run against the uninterrupted one). `second` may then have more frames.
pub fn compare_from(
    first: &ExodusFile,
    second: &ExodusFile,
    spec: &ComparisonSpec,
    offset: Option<usize>,
) -> Result<ComparisonReport, ExodusError> {
    let names = |f: &ExodusFile| format!("{}", f.path.display());
    let mut c = Comparison {
        first,
        second,
        offset,
        ignore_case: spec.ignore_case,
        name_a: names(first),
        name_b: names(second),
        report: ComparisonReport::default(),
    };
    let same_nodes = c.coordinates(spec.coordinates);
    let block_pairs = c.blocks();
    c.node_sets();
    let steps = c.times(spec.time_steps);
    let global = c.select(
        QuantityKind::Global,
        &spec.global,
        &first.global_variable_names,
        &second.global_variable_names,
    );
    let nodal = c.select(
        QuantityKind::Nodal,
        &spec.nodal,
        &first.nodal_variable_names,
        &second.nodal_variable_names,
    );
    let element = c.select(
        QuantityKind::Element,
        &spec.element,
        &first.element_variable_names,
        &second.element_variable_names,
    );
    c.global_variables(&global, steps)?;
    if same_nodes {
        c.nodal_variables(&nodal, steps)?;
    }
    c.element_variables(&element, &block_pairs, steps)?;
    Ok(c.report)
}

/// A variable to compare: its index in the first file, in the second, and its tolerance.
type VariablePair = (usize, usize, Tolerance);

/// One comparison under way: the two files and the report so far.
struct Comparison<'a> {
    first: &'a ExodusFile,
    second: &'a ExodusFile,
    /// Frame k of `first` is compared with frame k + offset of `second` (see [`compare_from`]).
    offset: Option<usize>,
    ignore_case: bool,
    /// The files' paths, for messages.
    name_a: String,
    name_b: String,
    report: ComparisonReport,
}

impl Comparison<'_> {
    /// Compares the dimension and the coordinates; returns whether the node counts match (the
    /// nodal variables are compared only then).
    fn coordinates(&mut self, tolerance: Tolerance) -> bool {
        let (first, second) = (self.first, self.second);
        let (name_a, name_b) = (&self.name_a, &self.name_b);
        let report = &mut self.report;
        if first.dimension != second.dimension {
            report.structural.push(format!(
                "spatial dimension {} in {name_a} but {} in {name_b}",
                first.dimension, second.dimension
            ));
        }
        let same_nodes = first.coordinates.len() == second.coordinates.len();
        if !same_nodes {
            report.structural.push(format!(
                "{} nodes in {name_a} but {} in {name_b}",
                first.coordinates.len(),
                second.coordinates.len()
            ));
        } else {
            for (axis, label) in ["X", "Y", "Z"]
                .iter()
                .enumerate()
                .take(first.dimension.max(1))
            {
                let mut t = Tracker::new(QuantityKind::Coordinate, label, None, tolerance);
                let a: Vec<f64> = first.coordinates.iter().map(|c| c[axis]).collect();
                let b: Vec<f64> = second.coordinates.iter().map(|c| c[axis]).collect();
                t.add(None, 0, &a, &b);
                report.quantities.push(t.worst);
            }
        }
        same_nodes
    }

    /// Matches the element blocks by id and compares their sizes, types and connectivity;
    /// returns the (first, second) index pairs of the blocks whose element variables can be
    /// compared.
    fn blocks(&mut self) -> Vec<(usize, usize)> {
        let (first, second) = (self.first, self.second);
        let (name_a, name_b) = (&self.name_a, &self.name_b);
        let report = &mut self.report;
        let mut block_pairs = Vec::new();
        for (ia, block) in first.blocks.iter().enumerate() {
            match second.blocks.iter().position(|b| b.id == block.id) {
                None => report.structural.push(format!(
                    "element block {} of {name_a} is missing in {name_b}",
                    block.id
                )),
                Some(ib) => {
                    let other = &second.blocks[ib];
                    if block.num_elements() != other.num_elements() {
                        report.structural.push(format!(
                            "element block {} has {} elements in {name_a} but {} in {name_b}",
                            block.id,
                            block.num_elements(),
                            other.num_elements()
                        ));
                        continue;
                    }
                    // exodiff's default "short" type check: compare up to the shorter name.
                    let n = block.element_type.len().min(other.element_type.len());
                    if !block.element_type[..n].eq_ignore_ascii_case(&other.element_type[..n]) {
                        report.structural.push(format!(
                            "element block {} is {} in {name_a} but {} in {name_b}",
                            block.id, block.element_type, other.element_type
                        ));
                    }
                    if block.connectivity != other.connectivity {
                        report.structural.push(format!(
                            "element block {} has different connectivity",
                            block.id
                        ));
                    }
                    block_pairs.push((ia, ib));
                }
            }
        }
        for block in &second.blocks {
            if !first.blocks.iter().any(|b| b.id == block.id) {
                report.structural.push(format!(
                    "element block {} of {name_b} is missing in {name_a}",
                    block.id
                ));
            }
        }
        block_pairs
    }

    /// Node sets are compared where both files have them. A set present in only one file is
    /// a warning: Peridigm does not write deck-defined node sets to its results (its gold
    /// files have none) while peridyn does, and the sets carry no results to compare.
    fn node_sets(&mut self) {
        let (name_a, name_b) = (&self.name_a, &self.name_b);
        let report = &mut self.report;
        for set in &self.first.node_sets {
            match self.second.node_sets.iter().find(|s| s.id == set.id) {
                None => report.warnings.push(format!(
                    "node set {} ({}) of {name_a} is not in {name_b}",
                    set.id, set.name
                )),
                Some(other) => {
                    let mut a = set.nodes.clone();
                    let mut b = other.nodes.clone();
                    a.sort_unstable();
                    b.sort_unstable();
                    if a != b {
                        report.structural.push(format!(
                            "node set {} ({}) has different nodes ({} vs {})",
                            set.id,
                            set.name,
                            set.nodes.len(),
                            other.nodes.len()
                        ));
                    }
                }
            }
        }
    }

    /// Compares the step counts and the times of the common steps; returns their number.
    fn times(&mut self, tolerance: Tolerance) -> usize {
        let (first, second) = (self.first, self.second);
        let offset = self.offset.unwrap_or(0);
        let available = second.times.len().saturating_sub(offset);
        let steps = first.times.len().min(available);
        let mismatch = match self.offset {
            None => first.times.len() != second.times.len(),
            Some(_) => first.times.len() > available,
        };
        if mismatch {
            self.report.structural.push(format!(
                "{} time steps in {} but {} in {}",
                first.times.len(),
                self.name_a,
                second.times.len(),
                self.name_b
            ));
        }
        if steps > 0 {
            let mut t = Tracker::new(QuantityKind::Time, "time", None, tolerance);
            for step in 0..steps {
                t.add(
                    Some(step),
                    0,
                    &first.times[step..=step],
                    &second.times[step + offset..=step + offset],
                );
            }
            self.report.quantities.push(t.worst);
        }
        steps
    }

    /// The variables of one kind to compare under `section`, matched by name; listed
    /// variables missing from the first file are mismatches, variables only in the second
    /// file warnings.
    fn select(
        &mut self,
        kind: QuantityKind,
        section: &Option<VariableSection>,
        names_a: &[String],
        names_b: &[String],
    ) -> Vec<VariablePair> {
        let Some(section) = section else {
            return Vec::new();
        };
        let ignore_case = self.ignore_case;
        let (name_a, name_b) = (&self.name_a, &self.name_b);
        let report = &mut self.report;
        for (listed, _) in &section.listed {
            let in_a = names_a.iter().any(|n| names_equal(n, listed, ignore_case));
            let in_b = names_b.iter().any(|n| names_equal(n, listed, ignore_case));
            if !in_a && in_b {
                report.structural.push(format!(
                    "{kind} variable '{listed}' (from the command file) is not in {name_a}"
                ));
            } else if !in_a {
                // Listed but in neither file (e.g. a command file shared by decks that write
                // different variables): there is nothing to compare.
                report.warnings.push(format!(
                    "{kind} variable '{listed}' (from the command file) is in neither file"
                ));
            }
        }
        let mut pairs = Vec::new();
        for (ia, name) in names_a.iter().enumerate() {
            let Some(tol) = section.tolerance_for(name, ignore_case) else {
                continue;
            };
            match names_b
                .iter()
                .position(|n| names_equal(n, name, ignore_case))
            {
                Some(ib) => pairs.push((ia, ib, tol)),
                None => report
                    .structural
                    .push(format!("{kind} variable '{name}' is missing in {name_b}")),
            }
        }
        for name in names_b {
            if section.tolerance_for(name, ignore_case).is_some()
                && !names_a.iter().any(|n| names_equal(n, name, ignore_case))
            {
                report
                    .warnings
                    .push(format!("{kind} variable '{name}' is only in {name_b}"));
            }
        }
        pairs
    }

    /// Compares the selected global variables over the common steps.
    fn global_variables(
        &mut self,
        global: &[VariablePair],
        steps: usize,
    ) -> Result<(), ExodusError> {
        if global.is_empty() {
            return Ok(());
        }
        let (first, second) = (self.first, self.second);
        let mut trackers: Vec<Tracker> = global
            .iter()
            .map(|&(ia, _, tol)| {
                Tracker::new(
                    QuantityKind::Global,
                    &first.global_variable_names[ia],
                    None,
                    tol,
                )
            })
            .collect();
        for step in 0..steps {
            let a = first.global_values(step)?;
            let b = second.global_values(step + self.offset.unwrap_or(0))?;
            for (t, &(ia, ib, _)) in trackers.iter_mut().zip(global) {
                t.add(Some(step), ia, &a[ia..=ia], &b[ib..=ib]);
            }
        }
        self.report
            .quantities
            .extend(trackers.into_iter().map(|t| t.worst));
        Ok(())
    }

    /// Compares the selected nodal variables over the common steps.
    fn nodal_variables(&mut self, nodal: &[VariablePair], steps: usize) -> Result<(), ExodusError> {
        let (first, second) = (self.first, self.second);
        for &(ia, ib, tol) in nodal {
            let mut t = Tracker::new(
                QuantityKind::Nodal,
                &first.nodal_variable_names[ia],
                None,
                tol,
            );
            for step in 0..steps {
                t.add(
                    Some(step),
                    0,
                    &first.nodal_values(step, ia)?,
                    &second.nodal_values(step + self.offset.unwrap_or(0), ib)?,
                );
            }
            self.report.quantities.push(t.worst);
        }
        Ok(())
    }

    /// Compares the selected element variables block by block over the common steps.
    fn element_variables(
        &mut self,
        element: &[VariablePair],
        block_pairs: &[(usize, usize)],
        steps: usize,
    ) -> Result<(), ExodusError> {
        let (first, second) = (self.first, self.second);
        for &(ia, ib, tol) in element {
            let name = &first.element_variable_names[ia];
            for &(ba, bb) in block_pairs {
                let block_id = first.blocks[ba].id;
                let defined_a = first.element_variable_defined[ba][ia];
                let defined_b = second.element_variable_defined[bb][ib];
                if defined_a != defined_b {
                    self.report.structural.push(format!(
                        "element variable '{name}' is defined on block {block_id} in only one file"
                    ));
                    continue;
                }
                if !defined_a {
                    continue;
                }
                let mut t = Tracker::new(QuantityKind::Element, name, Some(block_id), tol);
                for step in 0..steps {
                    let a = first.element_values(step, ia, ba)?.unwrap_or_default();
                    let b = second
                        .element_values(step + self.offset.unwrap_or(0), ib, bb)?
                        .unwrap_or_default();
                    t.add(Some(step), 0, &a, &b);
                }
                self.report.quantities.push(t.worst);
            }
        }
        Ok(())
    }
}
