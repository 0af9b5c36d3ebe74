//! Run-time expressions: boundary-condition values, variable horizons, user influence
//! functions, time-dependent critical stretch and friction coefficients.
//!
//! Peridigm evaluates these strings with Trilinos' RTCompiler (`PG_RuntimeCompiler::Function`);
//! this module accepts the same language (Peridigm's `Peridigm_BoundaryCondition.cpp` hands
//! each `Value` string to it):
//!
//! * the result is the variable `value`; text that never mentions `value` is a bare expression
//!   and is read as `value = <text>` (so `"-0.1*t/0.00005"` and `"value = -0.1*t/0.00005;"` are
//!   the same);
//! * statements end with `;` (the last one may omit it); blocks `{ … }`, written `\{ … \}` in
//!   YAML decks (both spellings are accepted); `if (…) … else if (…) … else …`;
//! * temporaries: `r = sqrt(x*x + y*y);` or declared `double r = …;` (`float`, `int` too; `int`
//!   truncates like C); compound assignments `+= -= *= /=`; `//` and `/* */` comments;
//! * operators `+ - * / %`, `^` (power), `< <= > >= == !=`, `&& || !`; functions `fabs sin cos
//!   tan sqrt tanh sinh cosh log log10 exp asin acos atan atan2 pow erf erfc rand drand`, plus the
//!   C functions `abs floor ceil min max`.
//!
//! Arithmetic is in double precision throughout: `1/2` is 0.5, as in RTCompiler.
//!
//! **Power and unary minus follow RTCompiler, not the usual maths convention:** negation binds
//! tighter than `^` and `^` is right-associative, so `-2^2` = (−2)² = 4, `-x^2` = x², and
//! `2^3^2` = 2^9 = 512. Write `-(x^2)` or `0 - x^2` for −x². This keeps decks that run in
//! Peridigm giving the same numbers here.
//!
//! Differences from RTCompiler, all rejected with an error rather than computed differently
//! except the last: no loops, no `?:`, comparisons cannot be used as 0/1 numbers in arithmetic
//! (`(x>0)*2` is an error: use if/else), and `%` is the floating-point remainder (`fmod`) where
//! RTCompiler truncates both operands to integers first (identical for integer operands).
//!
//! **Random numbers.** `drand()` is uniform in [0, 1) and `rand()` is an integer in
//! `[0, 2147483647]` (C `rand()` with glibc's `RAND_MAX`). They come from a counter-based
//! generator (SplitMix64) seeded by a hash of the expression text and of the variable values
//! passed to [`Expression::eval`]; the k-th draw within one evaluation uses counter k. The same
//! expression evaluated at the same point and time therefore always gives the same numbers, in
//! any run, with any number of threads and in any evaluation order, while different points,
//! times or expressions give independent numbers.
//!
//! Parsing and evaluation of the arithmetic itself is done by the `evalexpr` crate; this module
//! only translates the statement structure and checks names (see `translate.rs`).

mod functions;
mod program;
mod translate;

#[cfg(test)]
mod tests;

use std::sync::Arc;

use functions::RandomStream;
pub use functions::RAND_MAX;
use program::Program;

/// Variables of boundary and initial conditions and body forces: reference coordinates
/// `x y z` of the point and time `t`.
pub const SPACE_TIME: &[&str] = &["x", "y", "z", "t"];
/// Variables of a variable horizon (`Blocks → Horizon` given as a string): reference
/// coordinates `x y z`.
pub const SPACE: &[&str] = &["x", "y", "z"];
/// Variables of a user-defined influence function (`Discretization → Influence Function` other
/// than `One`/`Parabolic Decay`/`Gaussian`): bond reference length `zeta` and `horizon`.
pub const INFLUENCE: &[&str] = &["zeta", "horizon"];
/// Variable of time-dependent parameters (`Time Dependent Critical Stretch`, `Friction
/// Coefficient` of `Time Dependent Short Range Force`): time `t`.
pub const TIME: &[&str] = &["t"];

/// Why an expression was rejected. Every message quotes the expression (whitespace compacted,
/// long texts shortened) and says where and what to change.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ExpressionError {
    /// The text is not valid in the expression language.
    #[error("expression \"{expression}\" does not parse at {location}: {problem}")]
    Syntax {
        /// The expression as written (compacted).
        expression: String,
        /// Position of the problem, e.g. "column 7" or "line 2, column 3".
        location: String,
        /// What is wrong.
        problem: String,
    },
    /// A name that is neither a variable of this kind of expression nor an assigned temporary.
    #[error(
        "expression \"{expression}\" uses unknown variable `{name}` at {location}{hint}; \
         the variables available here are {allowed} (plus temporaries you assign first)"
    )]
    UnknownVariable {
        /// The expression as written (compacted).
        expression: String,
        /// The unknown name.
        name: String,
        /// Position of the name.
        location: String,
        /// The variables of this kind of expression, e.g. "`x`, `y`, `z`, `t`".
        allowed: String,
        /// " (did you mean `x`?)" or empty.
        hint: String,
    },
    /// A call of a function that does not exist.
    #[error(
        "expression \"{expression}\" calls unknown function `{name}` at {location}{hint}; \
         available functions: fabs, abs, sin, cos, tan, asin, acos, atan, atan2, sinh, cosh, tanh, \
         sqrt, exp, log, log10, pow, floor, ceil, min, max, erf, erfc, rand, drand"
    )]
    UnknownFunction {
        /// The expression as written (compacted).
        expression: String,
        /// The unknown name.
        name: String,
        /// Position of the call.
        location: String,
        /// " (did you mean `sin`?)", a note on RTCompiler-only functions, or empty.
        hint: String,
    },
    /// A function called with the wrong number of arguments.
    #[error(
        "expression \"{expression}\" calls `{name}` at {location} with {found} argument(s), \
         but it takes {expected}"
    )]
    ArgumentCount {
        /// The expression as written (compacted).
        expression: String,
        /// The function.
        name: String,
        /// Position of the call.
        location: String,
        /// Arguments the function takes.
        expected: usize,
        /// Arguments given.
        found: usize,
    },
    /// A part of the expression that does not produce a number where one is needed (or a
    /// condition where one is needed).
    #[error("expression \"{expression}\": `{fragment}` at {location} cannot be used: {problem}")]
    NotANumber {
        /// The expression as written (compacted).
        expression: String,
        /// The offending sub-expression.
        fragment: String,
        /// Position of the sub-expression.
        location: String,
        /// What it evaluates to instead, and what to do.
        problem: String,
    },
    /// A temporary (or `value`) read on a path where it has not been assigned yet.
    #[error(
        "expression \"{expression}\" reads `{name}` at {location} before it is assigned \
         (on at least one path through the if/else branches); assign it first"
    )]
    Unassigned {
        /// The expression as written (compacted).
        expression: String,
        /// The variable read too early.
        name: String,
        /// Position of the read.
        location: String,
    },
    /// `value` is not assigned on every path.
    #[error("expression \"{expression}\" does not always produce a result: {problem}")]
    MissingValue {
        /// The expression as written (compacted).
        expression: String,
        /// Which situation (never assigned / only on some branches) and the fix.
        problem: String,
    },
    /// [`Expression::eval`] was given the wrong number of variable values (a programming
    /// error in the caller, reported rather than panicking).
    #[error("expression \"{expression}\" needs {expected} variable value(s) ({names}) but was given {found}")]
    ValueCount {
        /// The expression as written (compacted).
        expression: String,
        /// Number of variables it was parsed with.
        expected: usize,
        /// Their names, in order.
        names: String,
        /// Number of values given.
        found: usize,
    },
}

/// A parsed, precompiled expression. Cheap to clone (shared program) and safe to evaluate
/// from many threads at once.
#[derive(Debug, Clone)]
pub struct Expression {
    source: String,
    /// Compacted source for error messages.
    quoted: String,
    /// Seeds the random stream (see the module docs).
    source_hash: u64,
    program: Arc<Program>,
    constant: Option<f64>,
}

impl Expression {
    /// Parses `source` for the given variables (one of [`SPACE_TIME`], [`SPACE`],
    /// [`INFLUENCE`], [`TIME`], or any list of distinct identifiers other than `value`).
    ///
    /// Every problem the text can have is found here, including unknown variables and
    /// functions, type errors and branches that leave `value` unset, so that a deck fails
    /// before the run starts.
    ///
    /// # Panics
    /// If `variables` contains `value` or a duplicate (a programming error, not user input).
    pub fn parse(source: &str, variables: &[&str]) -> Result<Self, ExpressionError> {
        for (index, variable) in variables.iter().enumerate() {
            assert!(
                *variable != "value" && !variables[..index].contains(variable),
                "expression variables must be distinct and not `value`: {variables:?}"
            );
        }
        let text = translate::Source::new(source);
        let program = translate::compile(&text, variables)?;
        let mut expression = Self {
            source: source.to_string(),
            quoted: text.quoted,
            source_hash: functions::stable_hash(source),
            program: Arc::new(program),
            constant: None,
        };
        if !expression.program.uses_random && !expression.program.used_inputs.contains(&true) {
            let unused_inputs = vec![0.0; variables.len()];
            expression.constant = Some(expression.eval(&unused_inputs)?);
        }
        Ok(expression)
    }

    /// Evaluates the expression; `values` are the variables in the order given to
    /// [`Expression::parse`] (e.g. `[x, y, z, t]` for [`SPACE_TIME`]).
    ///
    /// Arithmetic never fails (a negative `sqrt` gives NaN as in C); errors only report a
    /// wrong number of values.
    pub fn eval(&self, values: &[f64]) -> Result<f64, ExpressionError> {
        let program = &*self.program;
        if values.len() != program.input_count {
            return Err(ExpressionError::ValueCount {
                expression: self.quoted.clone(),
                expected: program.input_count,
                names: program.slot_names[..program.input_count].join(", "),
                found: values.len(),
            });
        }
        let random = if program.uses_random {
            RandomStream::new(self.source_hash, values)
        } else {
            RandomStream::new(0, &[])
        };
        program.run(values, &random, &self.quoted)
    }

    /// Whether the expression reads `variable` anywhere. Callers use it to hoist work, e.g. a
    /// boundary condition that does not use `x y z` is evaluated once per time step, not per
    /// point. Unknown names give `false`.
    pub fn uses(&self, variable: &str) -> bool {
        let program = &*self.program;
        program.slot_names[..program.input_count]
            .iter()
            .zip(&program.used_inputs)
            .any(|(name, used)| *used && name == variable)
    }

    /// The value when it depends on no variable and calls neither `rand` nor `drand`
    /// (e.g. `"0.0"`, `"2*3"`, `"r = 2; value = r*r;"`), computed once at parse time.
    pub fn constant_value(&self) -> Option<f64> {
        self.constant
    }

    /// The text exactly as given to [`Expression::parse`].
    pub fn source(&self) -> &str {
        &self.source
    }
}

impl std::fmt::Display for Expression {
    fn fmt(&self, formatter: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        formatter.write_str(&self.source)
    }
}
