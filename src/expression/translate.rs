//! Translation of Peridigm's C-like expression language into evalexpr programs.
//!
//! The statement layer (`;`, `{ }`, `if`/`else`, declarations, compound assignments) is handled
//! here because evalexpr evaluates `if(c, a, b)` eagerly and has no blocks; every arithmetic
//! expression is handed to evalexpr, which parses and evaluates it. Before that, each
//! expression's tokens are re-emitted with three adjustments so that evalexpr computes what
//! RTCompiler computes:
//!
//! * integer literals become floats (`1/2` is 0.5 as in RTCompiler, not evalexpr's integer 0);
//! * `^` is made right-associative (`2^3^2` = 2^9 = 512) and binds more loosely than unary minus
//!   (`-2^2` = (−2)² = 4), matching RTCompiler's operator table (negation precedence 11,
//!   exponent 8, right-associative), by inserting parentheses;
//! * unary `+` is dropped (evalexpr has none).
//!
//! The same walk checks every identifier (unknown variable or function, use before assignment,
//! argument counts) so that mistakes are reported at parse time with their position.

use super::program::{CompiledExpr, Program, Stmt};
use super::ExpressionError;

mod expressions;
mod lex;

/// Words that have a meaning in the statement language and cannot name a variable.
const KEYWORDS: &[&str] = &[
    "if", "else", "for", "while", "do", "return", "switch", "break", "continue", "double", "float",
    "int", "true", "false",
];

/// Statement keywords of C that RTCompiler knows but peridyn does not implement.
const UNSUPPORTED_STATEMENTS: &[&str] = &[
    "for", "while", "do", "return", "switch", "break", "continue",
];

/// Type names accepted in declarations (`double r = ...;`).
const TYPE_NAMES: &[&str] = &["double", "float", "int"];

/// Operators that combine two operands; `^` is handled separately (see module docs).
const BINARY_OPERATORS: &[&str] = &[
    "+", "-", "*", "/", "%", "<", "<=", ">", ">=", "==", "!=", "&&", "||",
];

const ASSIGNMENT_OPERATORS: &[&str] = &["=", "+=", "-=", "*=", "/="];

const TWO_CHAR_PUNCTUATION: &[&str] = &["<=", ">=", "==", "!=", "&&", "||", "+=", "-=", "*=", "/="];
const ONE_CHAR_PUNCTUATION: &str = "+-*/%^<>!=(){},;";

#[derive(Debug, Clone, Copy, PartialEq)]
enum Kind {
    Number(f64),
    Identifier,
    Punctuation,
}

#[derive(Debug, Clone)]
struct Token {
    kind: Kind,
    /// Identifier or punctuation as written (`{` also for an escaped `\{`); number literal text.
    text: String,
    /// Byte range in the user's text; empty for tokens we synthesise.
    start: usize,
    end: usize,
}

impl Token {
    fn is(&self, punctuation: &str) -> bool {
        self.kind == Kind::Punctuation && self.text == punctuation
    }

    fn is_identifier(&self, name: &str) -> bool {
        self.kind == Kind::Identifier && self.text == name
    }

    fn synthetic(kind: Kind, text: &str, at: usize) -> Self {
        Self {
            kind,
            text: text.to_string(),
            start: at,
            end: at,
        }
    }
}

/// The user's text and how to point into it.
pub(crate) struct Source<'a> {
    text: &'a str,
    /// The text as quoted in error messages.
    pub quoted: String,
}

impl<'a> Source<'a> {
    pub(crate) fn new(text: &'a str) -> Self {
        Self {
            text,
            quoted: quote(text),
        }
    }

    /// "column 7" for one-line text, "line 3, column 7" otherwise (1-based, in characters).
    fn location(&self, byte: usize) -> String {
        let byte = byte.min(self.text.len());
        let before = &self.text[..byte];
        let line = before.matches('\n').count() + 1;
        let line_start = before.rfind('\n').map_or(0, |newline| newline + 1);
        let column = before[line_start..].chars().count() + 1;
        if self.text.trim_end().contains('\n') {
            format!("line {line}, column {column}")
        } else {
            format!("column {column}")
        }
    }

    fn syntax(&self, byte: usize, problem: impl Into<String>) -> ExpressionError {
        ExpressionError::Syntax {
            expression: self.quoted.clone(),
            location: self.location(byte),
            problem: problem.into(),
        }
    }

    fn fragment(&self, tokens: &[Token]) -> String {
        let start = tokens.iter().map(|token| token.start).min().unwrap_or(0);
        let end = tokens.iter().map(|token| token.end).max().unwrap_or(start);
        quote(&self.text[start..end.max(start)])
    }
}

/// Whitespace runs collapsed, cut to a readable length: long multi-line programs would otherwise
/// drown the actual message.
fn quote(text: &str) -> String {
    const LIMIT: usize = 120;
    let compact = text.split_whitespace().collect::<Vec<_>>().join(" ");
    if compact.chars().count() > LIMIT {
        let cut: String = compact.chars().take(LIMIT - 3).collect();
        format!("{cut}...")
    } else {
        compact
    }
}

/// Best-matching name for a did-you-mean hint, if any is close enough.
fn did_you_mean<'n>(name: &str, candidates: impl Iterator<Item = &'n str>) -> Option<&'n str> {
    let lower = name.to_lowercase();
    candidates
        .filter_map(|candidate| {
            let candidate_lower = candidate.to_lowercase();
            let edits = strsim::normalized_damerau_levenshtein(&lower, &candidate_lower);
            // Jaro-Winkler favours a shared prefix, which breaks ties such as `sine` → `sin`
            // rather than `sinh` (one edit each).
            let prefix = strsim::jaro_winkler(&lower, &candidate_lower);
            (edits >= 0.5).then_some((edits + prefix, candidate))
        })
        .max_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, candidate)| candidate)
}

/// What a sub-expression is used for, which fixes the type it must have.
#[derive(Clone, Copy, PartialEq)]
enum Purpose {
    /// Right-hand side of an assignment: must be a number.
    Number,
    /// `if` condition: a comparison, or a number (non-zero is true, as in C).
    Condition,
}

/// Facts about one sub-expression gathered while translating it.
#[derive(Default)]
struct ExprFacts {
    reads_variables: bool,
    draws_random: bool,
}

struct Translator<'s, 'a> {
    source: &'s Source<'a>,
    tokens: Vec<Token>,
    position: usize,
    /// Caller variables, `value`, temporaries.
    slot_names: Vec<String>,
    input_count: usize,
    /// Temporaries declared `int`.
    integer_slots: Vec<bool>,
    exprs: Vec<CompiledExpr>,
    used_inputs: Vec<bool>,
    uses_random: bool,
    /// Current depth of nested statements and operands, bounded by [`MAX_NESTING`].
    nesting: usize,
}

/// Deepest nesting of blocks, parentheses and calls accepted; far beyond any real deck, it
/// keeps pathological input from exhausting the stack (here or in evalexpr).
const MAX_NESTING: usize = 128;

/// Longest sub-expression accepted, in tokens (the largest Peridigm deck has ~200); evalexpr
/// evaluates recursively, so unbounded chains could exhaust a worker thread's stack.
const MAX_EXPRESSION_TOKENS: usize = 1000;

/// Compiles `text` into a program over `inputs` (see the module docs for the language).
pub(crate) fn compile(source: &Source, inputs: &[&str]) -> Result<Program> {
    let mut tokens = lex::lex(source)?;
    // Peridigm's rule: text without the word `value` is a bare expression for it.
    if !tokens.iter().any(|token| token.is_identifier("value")) {
        tokens.splice(
            0..0,
            [
                Token::synthetic(Kind::Identifier, "value", 0),
                Token::synthetic(Kind::Punctuation, "=", 0),
            ],
        );
    }

    let mut slot_names: Vec<String> = inputs.iter().map(|name| name.to_string()).collect();
    slot_names.push(String::from("value"));
    let mut integer_slots = vec![false; slot_names.len()];
    // Temporaries are the names that are assigned or declared anywhere; whether each read
    // happens after an assignment is checked path by path while translating.
    for (index, token) in tokens.iter().enumerate() {
        let declared_type = index
            .checked_sub(1)
            .map(|previous| &tokens[previous])
            .filter(|previous| {
                previous.kind == Kind::Identifier && TYPE_NAMES.contains(&previous.text.as_str())
            });
        let assigned = tokens.get(index + 1).is_some_and(|next| {
            next.kind == Kind::Punctuation && ASSIGNMENT_OPERATORS.contains(&next.text.as_str())
        });
        if token.kind != Kind::Identifier
            || KEYWORDS.contains(&token.text.as_str())
            || !(assigned || declared_type.is_some())
        {
            continue;
        }
        let slot = match slot_names.iter().position(|name| *name == token.text) {
            Some(slot) => slot,
            None => {
                slot_names.push(token.text.clone());
                integer_slots.push(false);
                slot_names.len() - 1
            }
        };
        if declared_type.is_some_and(|type_name| type_name.text == "int") {
            integer_slots[slot] = true;
        }
    }

    let value_slot = inputs.len();
    let mut translator = Translator {
        source,
        tokens,
        position: 0,
        input_count: inputs.len(),
        integer_slots,
        exprs: Vec::new(),
        used_inputs: vec![false; inputs.len()],
        uses_random: false,
        nesting: 0,
        slot_names,
    };
    let mut assigned = vec![false; translator.slot_names.len()];
    assigned[..inputs.len()].fill(true);
    let body = translator.statements(&mut assigned, None)?;
    if !assigned[value_slot] {
        let ever_assigned = translator.tokens.windows(2).any(|pair| {
            pair[0].is_identifier("value")
                && pair[1].kind == Kind::Punctuation
                && ASSIGNMENT_OPERATORS.contains(&pair[1].text.as_str())
        });
        let problem = if ever_assigned {
            "`value` is assigned only on some paths (an `if` without `else`, or a branch that skips it); \
             assign it before the `if` or in every branch"
        } else {
            "`value` is never assigned; write e.g. `value = 0.1*t;`"
        };
        return Err(ExpressionError::MissingValue {
            expression: source.quoted.clone(),
            problem: problem.to_string(),
        });
    }
    Ok(Program {
        slot_names: translator.slot_names,
        input_count: translator.input_count,
        value_slot,
        exprs: translator.exprs,
        body,
        used_inputs: translator.used_inputs,
        uses_random: translator.uses_random,
    })
}

type Result<T> = std::result::Result<T, ExpressionError>;

impl Translator<'_, '_> {
    fn peek(&self) -> Option<&Token> {
        self.tokens.get(self.position)
    }

    fn end_position(&self) -> usize {
        self.source.text.trim_end().len()
    }

    /// Statements up to the end of the text, or up to and including the `}` closing `opening`.
    fn statements(&mut self, assigned: &mut [bool], opening: Option<usize>) -> Result<Vec<Stmt>> {
        let mut body = Vec::new();
        loop {
            match self.peek() {
                None => {
                    return match opening {
                        Some(at) => Err(self.source.syntax(at, "this `{` is never closed by `}`")),
                        None => Ok(body),
                    }
                }
                Some(token) if token.is("}") => {
                    if opening.is_none() {
                        return Err(self
                            .source
                            .syntax(token.start, "`}` without a matching `{`"));
                    }
                    self.position += 1;
                    return Ok(body);
                }
                Some(_) => self.statement(assigned, &mut body)?,
            }
        }
    }

    fn statement(&mut self, assigned: &mut [bool], body: &mut Vec<Stmt>) -> Result<()> {
        let at = self.peek().map_or(self.end_position(), |token| token.start);
        self.enter(at)?;
        let result = self.unguarded_statement(assigned, body);
        self.nesting -= 1;
        result
    }

    /// Counts one more level of nesting, refusing input nested deeper than [`MAX_NESTING`].
    fn enter(&mut self, at: usize) -> Result<()> {
        if self.nesting >= MAX_NESTING {
            return Err(self.source.syntax(
                at,
                format!("nested more than {MAX_NESTING} levels deep; simplify with temporaries"),
            ));
        }
        self.nesting += 1;
        Ok(())
    }

    fn unguarded_statement(&mut self, assigned: &mut [bool], body: &mut Vec<Stmt>) -> Result<()> {
        let Some(token) = self.peek().cloned() else {
            return Err(self
                .source
                .syntax(self.end_position(), "a statement is missing at the end"));
        };
        if token.is("}") {
            return Err(self
                .source
                .syntax(token.start, "a statement is missing before `}`"));
        }
        self.position += 1;
        match (token.kind, token.text.as_str()) {
            (Kind::Punctuation, ";") => Ok(()),
            (Kind::Punctuation, "{") => {
                let inner = self.statements(assigned, Some(token.start))?;
                body.extend(inner);
                Ok(())
            }
            (Kind::Identifier, "if") => self.if_statement(&token, assigned, body),
            (Kind::Identifier, "else") => Err(self
                .source
                .syntax(token.start, "`else` without a matching `if`")),
            (Kind::Identifier, keyword) if UNSUPPORTED_STATEMENTS.contains(&keyword) => {
                Err(self.source.syntax(
                    token.start,
                    format!(
                        "`{keyword}` statements are not supported; use assignments and if/else"
                    ),
                ))
            }
            (Kind::Identifier, type_name) if TYPE_NAMES.contains(&type_name) => {
                self.declaration(&token, assigned, body)
            }
            (Kind::Identifier, name) if !matches!(name, "true" | "false") => {
                self.assignment(&token, assigned, body)
            }
            _ => Err(self.source.syntax(
                token.start,
                format!(
                    "expected a statement such as `value = 0.1*t;` but found `{}`",
                    token.text
                ),
            )),
        }
    }

    fn if_statement(
        &mut self,
        keyword: &Token,
        assigned: &mut [bool],
        body: &mut Vec<Stmt>,
    ) -> Result<()> {
        if !self.peek().is_some_and(|token| token.is("(")) {
            return Err(self.source.syntax(
                keyword.end,
                "`if` must be followed by a condition in parentheses",
            ));
        }
        let open = self.position;
        let close = self.matching_parenthesis(open)?;
        let condition_tokens = self.tokens[open + 1..close].to_vec();
        if condition_tokens.is_empty() {
            return Err(self
                .source
                .syntax(self.tokens[open].start, "the `if` condition is empty"));
        }
        let condition = self.compile_expression(&condition_tokens, assigned, Purpose::Condition)?;
        self.position = close + 1;

        let mut then_assigned = assigned.to_vec();
        let mut then_branch = Vec::new();
        self.statement(&mut then_assigned, &mut then_branch)?;
        let mut else_assigned = assigned.to_vec();
        let mut else_branch = Vec::new();
        if self.peek().is_some_and(|token| token.is_identifier("else")) {
            self.position += 1;
            self.statement(&mut else_assigned, &mut else_branch)?;
        }
        for (slot, is_assigned) in assigned.iter_mut().enumerate() {
            *is_assigned = then_assigned[slot] && else_assigned[slot];
        }
        body.push(Stmt::If {
            condition,
            then_branch,
            else_branch,
        });
        Ok(())
    }

    fn declaration(
        &mut self,
        type_name: &Token,
        assigned: &mut [bool],
        body: &mut Vec<Stmt>,
    ) -> Result<()> {
        let Some(name) = self
            .peek()
            .cloned()
            .filter(|token| token.kind == Kind::Identifier)
        else {
            return Err(self.source.syntax(
                type_name.end,
                format!("a variable name must follow `{}`", type_name.text),
            ));
        };
        if KEYWORDS.contains(&name.text.as_str()) {
            return Err(self.source.syntax(
                name.start,
                format!("`{}` is reserved and cannot name a variable", name.text),
            ));
        }
        if let Some(slot) = self
            .slot(&name.text)
            .filter(|slot| *slot <= self.input_count)
        {
            return Err(self.source.syntax(
                name.start,
                format!(
                    "`{}` is provided by peridyn and cannot be declared",
                    self.slot_names[slot]
                ),
            ));
        }
        self.position += 1;
        match self.peek() {
            Some(token) if token.is(";") => {
                // `double a;` declares without a value: reading `a` before assigning it is an error.
                self.position += 1;
                Ok(())
            }
            Some(token) if token.is("=") => self.assignment(&name, assigned, body),
            Some(token) if token.is(",") => Err(self
                .source
                .syntax(token.start, "declare one variable per statement")),
            _ => Err(self.source.syntax(
                name.end,
                format!(
                    "expected `=` or `;` after `{} {}`",
                    type_name.text, name.text
                ),
            )),
        }
    }

    fn assignment(
        &mut self,
        target: &Token,
        assigned: &mut [bool],
        body: &mut Vec<Stmt>,
    ) -> Result<()> {
        let operator = match self.peek() {
            Some(token)
                if token.kind == Kind::Punctuation
                    && ASSIGNMENT_OPERATORS.contains(&token.text.as_str()) =>
            {
                token.clone()
            }
            Some(token) if token.is("(") => {
                return Err(self.source.syntax(
                    target.start,
                    format!(
                    "a call on its own does nothing; assign its result, e.g. `value = {}(...);`",
                    target.text
                ),
                ))
            }
            _ => {
                return Err(self.source.syntax(
                    target.end,
                    format!(
                        "expected `=` after `{}` (statements look like `value = 0.1*t;`)",
                        target.text
                    ),
                ))
            }
        };
        let slot = self
            .slot(&target.text)
            .expect("every assignment target was registered as a slot before translation");
        self.position += 1;
        let start = self.position;
        let end = self.tokens[start..]
            .iter()
            .position(|token| token.is(";") || token.is("{") || token.is("}"))
            .map_or(self.tokens.len(), |offset| start + offset);
        if self.tokens.get(end).is_some_and(|token| token.is("{")) {
            return Err(self
                .source
                .syntax(self.tokens[end].start, "missing `;` before `{`"));
        }
        let mut right_side = self.tokens[start..end].to_vec();
        if right_side.is_empty() {
            return Err(self.source.syntax(
                operator.end,
                format!("missing expression after `{}`", operator.text),
            ));
        }
        if operator.text != "=" {
            // `a op= e` is `a = a op (e)`.
            let binary = &operator.text[..1];
            let first = right_side[0].start;
            let last = right_side[right_side.len() - 1].end;
            right_side.insert(0, Token::synthetic(Kind::Punctuation, "(", first));
            right_side.push(Token::synthetic(Kind::Punctuation, ")", last));
            right_side.insert(
                0,
                Token::synthetic(Kind::Punctuation, binary, operator.start),
            );
            right_side.insert(0, target.clone());
        }
        let expr = self.compile_expression(&right_side, assigned, Purpose::Number)?;
        self.position = if self.tokens.get(end).is_some_and(|token| token.is(";")) {
            end + 1
        } else {
            end
        };
        assigned[slot] = true;
        body.push(Stmt::Assign {
            slot,
            expr,
            truncate: self.integer_slots[slot],
        });
        Ok(())
    }

    fn slot(&self, name: &str) -> Option<usize> {
        self.slot_names
            .iter()
            .position(|slot_name| slot_name == name)
    }

    /// Index of the `)` matching the `(` at `open` (indices into `self.tokens`).
    fn matching_parenthesis(&self, open: usize) -> Result<usize> {
        matching_parenthesis(self.source, &self.tokens, open)
    }
}

/// Index of the `)` matching the `(` at `open`.
fn matching_parenthesis(source: &Source, tokens: &[Token], open: usize) -> Result<usize> {
    let mut depth = 0usize;
    for (index, token) in tokens.iter().enumerate().skip(open) {
        if token.is("(") {
            depth += 1;
        } else if token.is(")") {
            depth -= 1;
            if depth == 0 {
                return Ok(index);
            }
        }
    }
    Err(source.syntax(tokens[open].start, "this `(` is never closed by `)`"))
}
