//! Expressions: each one re-emitted for evalexpr with RTCompiler's arithmetic (see the parent
//! module), its identifiers and calls checked, then built and type-checked.

use evalexpr::{DefaultNumericTypes, Value};

use super::{
    did_you_mean, matching_parenthesis, ExprFacts, Kind, Purpose, Result, Token, Translator,
    BINARY_OPERATORS, KEYWORDS, MAX_EXPRESSION_TOKENS,
};
use crate::expression::functions::{self, RandomStream};
use crate::expression::program::{
    describe_evaluation_error, describe_value, evaluate_tree, CompiledExpr,
};
use crate::expression::ExpressionError;

impl Translator<'_, '_> {
    /// Translates one sub-expression, builds its evalexpr tree and type-checks it.
    pub(super) fn compile_expression(
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
