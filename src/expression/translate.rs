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

use evalexpr::{DefaultNumericTypes, Value};

use super::functions::{self, RandomStream};
use super::program::{describe_evaluation_error, describe_value, evaluate_tree};
use super::program::{CompiledExpr, Program, Stmt};
use super::ExpressionError;

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

fn lex(source: &Source) -> Result<Vec<Token>> {
    let text = source.text;
    let bytes = text.as_bytes();
    let mut tokens = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        let byte = bytes[i];
        let next = bytes.get(i + 1).copied();
        if byte.is_ascii_whitespace() {
            i += 1;
        } else if byte == b'/' && next == Some(b'/') {
            i = text[i..]
                .find('\n')
                .map_or(bytes.len(), |newline| i + newline);
        } else if byte == b'/' && next == Some(b'*') {
            match text[i + 2..].find("*/") {
                Some(end) => i += end + 4,
                None => return Err(source.syntax(i, "comment `/*` is never closed by `*/`")),
            }
        } else if byte == b'\\' && matches!(next, Some(b'{') | Some(b'}')) {
            // YAML decks escape braces; the deck reader may or may not have removed the `\`.
            let brace = if next == Some(b'{') { "{" } else { "}" };
            tokens.push(Token {
                kind: Kind::Punctuation,
                text: brace.to_string(),
                start: i,
                end: i + 2,
            });
            i += 2;
        } else if byte.is_ascii_digit()
            || (byte == b'.' && next.is_some_and(|b| b.is_ascii_digit()))
        {
            let token = lex_number(source, i)?;
            i = token.end;
            tokens.push(token);
        } else if byte.is_ascii_alphabetic() || byte == b'_' {
            let start = i;
            while i < bytes.len() && (bytes[i].is_ascii_alphanumeric() || bytes[i] == b'_') {
                i += 1;
            }
            tokens.push(Token {
                kind: Kind::Identifier,
                text: text[start..i].to_string(),
                start,
                end: i,
            });
        } else if let Some(pair) = TWO_CHAR_PUNCTUATION
            .iter()
            .find(|pair| text[i..].starts_with(**pair))
        {
            tokens.push(Token {
                kind: Kind::Punctuation,
                text: pair.to_string(),
                start: i,
                end: i + 2,
            });
            i += 2;
        } else if ONE_CHAR_PUNCTUATION.as_bytes().contains(&byte) {
            tokens.push(Token {
                kind: Kind::Punctuation,
                text: char::from(byte).to_string(),
                start: i,
                end: i + 1,
            });
            i += 1;
        } else {
            return Err(unexpected_character(source, i));
        }
    }
    Ok(tokens)
}

/// The number literal starting at byte `start` (digits, an optional fraction and exponent);
/// a literal running into letters (`2x`) is an error.
fn lex_number(source: &Source, start: usize) -> Result<Token> {
    let text = source.text;
    let bytes = text.as_bytes();
    let mut i = start;
    while i < bytes.len() && bytes[i].is_ascii_digit() {
        i += 1;
    }
    if i < bytes.len() && bytes[i] == b'.' {
        i += 1;
        while i < bytes.len() && bytes[i].is_ascii_digit() {
            i += 1;
        }
    }
    if i < bytes.len() && matches!(bytes[i], b'e' | b'E') {
        let mut j = i + 1;
        if j < bytes.len() && matches!(bytes[j], b'+' | b'-') {
            j += 1;
        }
        if j < bytes.len() && bytes[j].is_ascii_digit() {
            i = j;
            while i < bytes.len() && bytes[i].is_ascii_digit() {
                i += 1;
            }
        }
    }
    if i < bytes.len() && (bytes[i].is_ascii_alphanumeric() || matches!(bytes[i], b'_' | b'.')) {
        let mut end = i;
        while end < bytes.len()
            && (bytes[end].is_ascii_alphanumeric() || matches!(bytes[end], b'_' | b'.'))
        {
            end += 1;
        }
        return Err(source.syntax(
            start,
            format!(
                "`{}` is not a number (write `2*x`, not `2x`; exponents as `1.5e-3`)",
                &text[start..end]
            ),
        ));
    }
    let literal = &text[start..i];
    let number: f64 = literal
        .parse()
        .map_err(|_| source.syntax(start, format!("`{literal}` is not a valid number")))?;
    if !number.is_finite() {
        return Err(source.syntax(start, format!("`{literal}` is too large for a double")));
    }
    Ok(Token {
        kind: Kind::Number(number),
        text: literal.to_string(),
        start,
        end: i,
    })
}

/// The error for a character no token starts with, with a hint for the common C/C++ ones.
fn unexpected_character(source: &Source, i: usize) -> ExpressionError {
    let text = source.text;
    let character = text[i..].chars().next().unwrap_or('?');
    let hint = match character {
        '&' => " (logical and is `&&`)",
        '|' => " (logical or is `||`)",
        ':' if text[i..].starts_with("::") => {
            " (call functions by their plain name, e.g. `sin(x)`)"
        }
        '?' | ':' => " (the `?:` operator is not supported; use if/else)",
        '[' | ']' => " (arrays are not supported)",
        _ => "",
    };
    source.syntax(i, format!("unexpected character `{character}`{hint}"))
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
    let mut tokens = lex(source)?;
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
            (Kind::Identifier, "true" | "false") => Err(self.source.syntax(
                token.start,
                format!(
                    "expected a statement such as `value = 0.1*t;` but found `{}`",
                    token.text
                ),
            )),
            (Kind::Identifier, _) => self.assignment(&token, assigned, body),
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

    /// Translates one sub-expression, builds its evalexpr tree and type-checks it.
    fn compile_expression(
        &mut self,
        tokens: &[Token],
        assigned: &[bool],
        purpose: Purpose,
    ) -> Result<usize> {
        if tokens.len() > MAX_EXPRESSION_TOKENS {
            return Err(self.source.syntax(
                tokens[0].start,
                format!(
                    "this part is longer than {MAX_EXPRESSION_TOKENS} symbols; split it with temporaries"
                ),
            ));
        }
        let mut facts = ExprFacts::default();
        let text = self.expression(tokens, assigned, &mut facts)?;
        let fragment = self.source.fragment(tokens);
        let start = tokens.iter().map(|token| token.start).min().unwrap_or(0);
        let location = self.source.location(start);
        let node =
            evalexpr::build_operator_tree::<DefaultNumericTypes>(&text).map_err(|error| {
                self.source.syntax(
                    start,
                    format!("`{fragment}` is not a valid expression ({error})"),
                )
            })?;

        // Types do not depend on values (floats in, floats or booleans out), so one trial run
        // with arbitrary values finds every type error now instead of at the first time step.
        let trial_slots = vec![Value::Float(1.0); self.slot_names.len()];
        let trial = evaluate_tree(
            &node,
            &self.slot_names,
            &trial_slots,
            &RandomStream::new(0, &[]),
        );
        let not_a_number = |problem: String| ExpressionError::NotANumber {
            expression: self.source.quoted.clone(),
            fragment: fragment.clone(),
            location: location.clone(),
            problem,
        };
        let trial = trial.map_err(|error| not_a_number(describe_evaluation_error(&error)))?;
        match (&trial, purpose) {
            (Value::Float(_), _) | (Value::Boolean(_), Purpose::Condition) => {}
            (other, _) => {
                return Err(not_a_number(format!(
                    "it evaluates to {}, but a number is needed here",
                    describe_value(other)
                )))
            }
        }

        self.exprs
            .push(if facts.reads_variables || facts.draws_random {
                CompiledExpr::Tree {
                    node,
                    fragment,
                    location,
                }
            } else {
                CompiledExpr::Constant(trial)
            });
        Ok(self.exprs.len() - 1)
    }

    /// `operand (binary-operator operand)*`, re-emitted as evalexpr text.
    fn expression(
        &mut self,
        tokens: &[Token],
        assigned: &[bool],
        facts: &mut ExprFacts,
    ) -> Result<String> {
        let mut text = String::new();
        let mut index = 0;
        loop {
            index = self.power_chain(tokens, index, assigned, facts, &mut text)?;
            let Some(token) = tokens.get(index) else {
                return Ok(text);
            };
            if token.kind == Kind::Punctuation && BINARY_OPERATORS.contains(&token.text.as_str()) {
                if index + 1 == tokens.len() {
                    return Err(self.source.syntax(
                        token.start,
                        format!("missing operand after `{}`", token.text),
                    ));
                }
                text.push(' ');
                text.push_str(&token.text);
                text.push(' ');
                index += 1;
            } else {
                return Err(self.unexpected_after_operand(token));
            }
        }
    }

    fn unexpected_after_operand(&self, token: &Token) -> ExpressionError {
        let problem = match (token.kind, token.text.as_str()) {
            (Kind::Punctuation, ")") => String::from("`)` without a matching `(`"),
            (Kind::Punctuation, "=" | "+=" | "-=" | "*=" | "/=") => format!(
                "`{}` cannot be used inside an expression (compare with `==`)",
                token.text
            ),
            (Kind::Punctuation, ",") => {
                String::from("`,` is only allowed between function arguments")
            }
            (Kind::Identifier, keyword) if KEYWORDS.contains(&keyword) => {
                format!("missing `;` before `{keyword}`")
            }
            _ => format!("missing operator (such as `*`) before `{}`", token.text),
        };
        self.source.syntax(token.start, problem)
    }

    /// `operand (^ operand)*`, emitted right-associatively (RTCompiler's `^`).
    fn power_chain(
        &mut self,
        tokens: &[Token],
        start: usize,
        assigned: &[bool],
        facts: &mut ExprFacts,
        text: &mut String,
    ) -> Result<usize> {
        let (first, first_is_unary, mut index) = self.operand(tokens, start, assigned, facts)?;
        let mut parts = vec![(first, first_is_unary)];
        while let Some(caret) = tokens.get(index).filter(|token| token.is("^")) {
            if index + 1 == tokens.len() {
                return Err(self
                    .source
                    .syntax(caret.start, "missing exponent after `^`"));
            }
            let (part, is_unary, next) = self.operand(tokens, index + 1, assigned, facts)?;
            parts.push((part, is_unary));
            index = next;
        }
        if parts.len() == 1 {
            text.push_str(&parts[0].0);
            return Ok(index);
        }
        // A unary operand is parenthesised so that negation applies before `^`, as in
        // RTCompiler; a chain is nested to the right.
        let wrap =
            |(part, is_unary): (String, bool)| if is_unary { format!("({part})") } else { part };
        let mut chain = parts
            .pop()
            .map(wrap)
            .expect("a power chain has at least two operands");
        let mut chain_is_power = false;
        while let Some(part) = parts.pop() {
            chain = if chain_is_power {
                format!("{}^({chain})", wrap(part))
            } else {
                format!("{}^{chain}", wrap(part))
            };
            chain_is_power = true;
        }
        text.push_str(&chain);
        Ok(index)
    }

    /// One operand: unary operators followed by a number, variable, call or parenthesised
    /// expression. Returns the emitted text, whether it starts with a unary operator, and the
    /// index after it.
    fn operand(
        &mut self,
        tokens: &[Token],
        index: usize,
        assigned: &[bool],
        facts: &mut ExprFacts,
    ) -> Result<(String, bool, usize)> {
        let at = tokens.get(index).map_or(0, |token| token.start);
        self.enter(at)?;
        let result = self.unguarded_operand(tokens, index, assigned, facts);
        self.nesting -= 1;
        result
    }

    fn unguarded_operand(
        &mut self,
        tokens: &[Token],
        index: usize,
        assigned: &[bool],
        facts: &mut ExprFacts,
    ) -> Result<(String, bool, usize)> {
        let Some(token) = tokens.get(index) else {
            let at = tokens.last().map_or(0, |token| token.end);
            return Err(self.source.syntax(at, "an operand is missing at the end"));
        };
        let followed_by_parenthesis = tokens.get(index + 1).is_some_and(|next| next.is("("));
        match token.kind {
            Kind::Punctuation if token.text == "-" || token.text == "!" => {
                if index + 1 == tokens.len() {
                    return Err(self.source.syntax(
                        token.start,
                        format!("missing operand after `{}`", token.text),
                    ));
                }
                let (inner, inner_is_unary, next) =
                    self.operand(tokens, index + 1, assigned, facts)?;
                let inner = if inner_is_unary {
                    format!("({inner})")
                } else {
                    inner
                };
                Ok((format!("{}{inner}", token.text), true, next))
            }
            Kind::Punctuation if token.text == "+" => {
                if index + 1 == tokens.len() {
                    return Err(self.source.syntax(token.start, "missing operand after `+`"));
                }
                self.operand(tokens, index + 1, assigned, facts)
            }
            Kind::Punctuation if token.text == "(" => {
                let close = matching_parenthesis(self.source, tokens, index)?;
                if close == index + 1 {
                    return Err(self.source.syntax(token.start, "empty parentheses `()`"));
                }
                let inner = self.expression(&tokens[index + 1..close], assigned, facts)?;
                Ok((format!("({inner})"), false, close + 1))
            }
            // `{:?}` always prints a decimal point or exponent, so evalexpr reads a float.
            Kind::Number(number) => Ok((format!("{number:?}"), false, index + 1)),
            Kind::Identifier if followed_by_parenthesis => {
                self.call(tokens, index, assigned, facts)
            }
            Kind::Identifier => {
                self.variable(token, assigned, facts)?;
                Ok((token.text.clone(), false, index + 1))
            }
            Kind::Punctuation => {
                let problem = match token.text.as_str() {
                    ")" => String::from(
                        "`)` without a matching `(` or an operand is missing before it",
                    ),
                    "," => String::from("an operand is missing before `,`"),
                    other => format!(
                        "expected a number, variable, function call or `(` but found `{other}`"
                    ),
                };
                Err(self.source.syntax(token.start, problem))
            }
        }
    }

    fn variable(&mut self, token: &Token, assigned: &[bool], facts: &mut ExprFacts) -> Result<()> {
        let name = token.text.as_str();
        if KEYWORDS.contains(&name) {
            return Err(self.source.syntax(
                token.start,
                format!("`{name}` cannot appear inside an expression"),
            ));
        }
        let Some(slot) = self.slot(name) else {
            if functions::find(name).is_some() {
                return Err(self.source.syntax(
                    token.start,
                    format!("`{name}` is a function; call it as `{name}(...)`"),
                ));
            }
            let hint = did_you_mean(name, self.slot_names.iter().map(String::as_str))
                .map(|candidate| format!(" (did you mean `{candidate}`?)"))
                .unwrap_or_default();
            let allowed = if self.input_count == 0 {
                String::from("none")
            } else {
                self.slot_names[..self.input_count]
                    .iter()
                    .map(|name| format!("`{name}`"))
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            return Err(ExpressionError::UnknownVariable {
                expression: self.source.quoted.clone(),
                name: name.to_string(),
                location: self.source.location(token.start),
                allowed,
                hint,
            });
        };
        if !assigned[slot] {
            return Err(ExpressionError::Unassigned {
                expression: self.source.quoted.clone(),
                name: name.to_string(),
                location: self.source.location(token.start),
            });
        }
        if slot < self.input_count {
            self.used_inputs[slot] = true;
        }
        facts.reads_variables = true;
        Ok(())
    }

    fn call(
        &mut self,
        tokens: &[Token],
        index: usize,
        assigned: &[bool],
        facts: &mut ExprFacts,
    ) -> Result<(String, bool, usize)> {
        let name_token = &tokens[index];
        let name = name_token.text.as_str();
        let close = matching_parenthesis(self.source, tokens, index + 1)?;
        let Some(function) = functions::find(name) else {
            if self.slot(name).is_some() {
                return Err(self.source.syntax(
                    name_token.start,
                    format!(
                        "`{name}` is a variable, not a function; write `{name}*(...)` to multiply"
                    ),
                ));
            }
            if KEYWORDS.contains(&name) {
                return Err(self.source.syntax(
                    name_token.start,
                    format!("`{name}` cannot appear inside an expression"),
                ));
            }
            let hint = if functions::RTCOMPILER_ONLY.contains(&name) {
                format!(" (Peridigm's RTCompiler has `{name}`, but peridyn does not support it)")
            } else {
                did_you_mean(
                    name,
                    functions::FUNCTIONS.iter().map(|function| function.name),
                )
                .map(|candidate| format!(" (did you mean `{candidate}`?)"))
                .unwrap_or_default()
            };
            return Err(ExpressionError::UnknownFunction {
                expression: self.source.quoted.clone(),
                name: name.to_string(),
                location: self.source.location(name_token.start),
                hint,
            });
        };

        let inside = &tokens[index + 2..close];
        let mut arguments: Vec<&[Token]> = Vec::new();
        if !inside.is_empty() {
            let mut depth = 0usize;
            let mut argument_start = 0;
            for (offset, token) in inside.iter().enumerate() {
                if token.is("(") {
                    depth += 1;
                } else if token.is(")") {
                    depth -= 1;
                } else if token.is(",") && depth == 0 {
                    arguments.push(&inside[argument_start..offset]);
                    argument_start = offset + 1;
                }
            }
            arguments.push(&inside[argument_start..]);
        }
        if let Some(empty) = arguments.iter().position(|argument| argument.is_empty()) {
            let at = if empty == 0 {
                tokens[index + 1].end
            } else {
                arguments[empty - 1].last().map_or(0, |token| token.end)
            };
            return Err(self
                .source
                .syntax(at, format!("an argument of `{name}` is empty")));
        }
        if arguments.len() != function.arity {
            return Err(ExpressionError::ArgumentCount {
                expression: self.source.quoted.clone(),
                name: name.to_string(),
                location: self.source.location(name_token.start),
                expected: function.arity,
                found: arguments.len(),
            });
        }
        let mut emitted = Vec::with_capacity(arguments.len());
        for argument in arguments {
            emitted.push(self.expression(argument, assigned, facts)?);
        }
        if functions::is_random(name) {
            facts.draws_random = true;
            self.uses_random = true;
        }
        Ok((format!("{name}({})", emitted.join(", ")), false, close + 1))
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
