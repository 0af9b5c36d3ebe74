//! The compiled form of an expression and its execution.
//!
//! A program is a list of statements (assignments and if/else) whose right-hand sides and
//! conditions are precompiled evalexpr operator trees. Variables live in numbered slots: the
//! caller's variables first (in the caller's order), then `value`, then temporaries. evalexpr
//! asks for variables by name; [`SlotContext`] answers with a linear scan over the handful of
//! slot names, so no hashing happens per evaluation.

use evalexpr::error::EvalexprResultValue;
use evalexpr::{Context, DefaultNumericTypes, EvalexprError, EvalexprResult, Node, Value};

use super::functions::{self, RandomStream};
use super::ExpressionError;

/// One precompiled sub-expression (a right-hand side or an `if` condition).
#[derive(Debug, Clone)]
pub(crate) enum CompiledExpr {
    /// Reads no variable and draws no random number: folded when parsing.
    Constant(Value),
    /// Evaluated by evalexpr at every run.
    Tree {
        node: Node<DefaultNumericTypes>,
        /// The user's text of this sub-expression, for error messages.
        fragment: String,
        /// Where the fragment starts in the user's text ("column 7", "line 2, column 3").
        location: String,
    },
}

/// A statement of the C-like language.
#[derive(Debug, Clone)]
pub(crate) enum Stmt {
    /// `slot = exprs[expr]`; `truncate` for variables declared `int` (C converts by truncation).
    Assign {
        slot: usize,
        expr: usize,
        truncate: bool,
    },
    /// `if (exprs[condition]) { then_branch } else { else_branch }`.
    If {
        condition: usize,
        then_branch: Vec<Stmt>,
        else_branch: Vec<Stmt>,
    },
}

/// A whole compiled expression.
#[derive(Debug, Clone)]
pub(crate) struct Program {
    /// Caller variables, then `value`, then temporaries.
    pub slot_names: Vec<String>,
    /// Number of caller variables (the first slots).
    pub input_count: usize,
    /// Slot of `value`, the result.
    pub value_slot: usize,
    pub exprs: Vec<CompiledExpr>,
    pub body: Vec<Stmt>,
    /// Which caller variables are read anywhere.
    pub used_inputs: Vec<bool>,
    /// Whether `rand()` or `drand()` is called anywhere.
    pub uses_random: bool,
}

/// Slots kept on the stack; programs with more variables fall back to a heap vector.
const INLINE_SLOTS: usize = 12;

impl Program {
    /// Runs the program for one set of caller variable values (already length-checked).
    pub(crate) fn run(
        &self,
        inputs: &[f64],
        random: &RandomStream,
        quoted_source: &str,
    ) -> Result<f64, ExpressionError> {
        let count = self.slot_names.len();
        let mut inline: [Value; INLINE_SLOTS];
        let mut heap: Vec<Value>;
        let slots: &mut [Value] = if count <= INLINE_SLOTS {
            inline = std::array::from_fn(|_| Value::Float(0.0));
            &mut inline[..count]
        } else {
            heap = vec![Value::Float(0.0); count];
            &mut heap[..]
        };
        for (slot, input) in slots.iter_mut().zip(inputs) {
            *slot = Value::Float(*input);
        }
        self.execute(&self.body, slots, random, quoted_source)?;
        match slots[self.value_slot] {
            Value::Float(result) => Ok(result),
            // Compilation proved `value` is assigned on every path and every assignment stores
            // a float, so anything else is a bug in this module.
            ref other => panic!("expression result slot holds {other:?} after execution"),
        }
    }

    fn execute(
        &self,
        statements: &[Stmt],
        slots: &mut [Value],
        random: &RandomStream,
        quoted_source: &str,
    ) -> Result<(), ExpressionError> {
        for statement in statements {
            match statement {
                Stmt::Assign {
                    slot,
                    expr,
                    truncate,
                } => {
                    let number = self.number(*expr, slots, random, quoted_source)?;
                    slots[*slot] = Value::Float(if *truncate { number.trunc() } else { number });
                }
                Stmt::If {
                    condition,
                    then_branch,
                    else_branch,
                } => {
                    let branch = if self.condition(*condition, slots, random, quoted_source)? {
                        then_branch
                    } else {
                        else_branch
                    };
                    self.execute(branch, slots, random, quoted_source)?;
                }
            }
        }
        Ok(())
    }

    fn value_of(
        &self,
        expr: usize,
        slots: &[Value],
        random: &RandomStream,
        quoted_source: &str,
    ) -> Result<Value, ExpressionError> {
        match &self.exprs[expr] {
            CompiledExpr::Constant(value) => Ok(value.clone()),
            CompiledExpr::Tree {
                node,
                fragment,
                location,
            } => evaluate_tree(node, &self.slot_names, slots, random).map_err(|error| {
                ExpressionError::NotANumber {
                    expression: quoted_source.to_string(),
                    fragment: fragment.clone(),
                    location: location.clone(),
                    problem: describe_evaluation_error(&error),
                }
            }),
        }
    }

    fn number(
        &self,
        expr: usize,
        slots: &[Value],
        random: &RandomStream,
        quoted_source: &str,
    ) -> Result<f64, ExpressionError> {
        match self.value_of(expr, slots, random, quoted_source)? {
            Value::Float(number) => Ok(number),
            other => Err(self.type_error(expr, &other, quoted_source)),
        }
    }

    /// C semantics: a number is true when non-zero.
    fn condition(
        &self,
        expr: usize,
        slots: &[Value],
        random: &RandomStream,
        quoted_source: &str,
    ) -> Result<bool, ExpressionError> {
        match self.value_of(expr, slots, random, quoted_source)? {
            Value::Boolean(truth) => Ok(truth),
            Value::Float(number) => Ok(number != 0.0),
            other => Err(self.type_error(expr, &other, quoted_source)),
        }
    }

    fn type_error(&self, expr: usize, found: &Value, quoted_source: &str) -> ExpressionError {
        let (fragment, location) = match &self.exprs[expr] {
            CompiledExpr::Tree {
                fragment, location, ..
            } => (fragment.clone(), location.clone()),
            CompiledExpr::Constant(_) => (String::new(), String::from("(constant)")),
        };
        ExpressionError::NotANumber {
            expression: quoted_source.to_string(),
            fragment,
            location,
            problem: format!("it evaluates to {}, not a number", describe_value(found)),
        }
    }
}

/// Evaluates one operator tree with the given slot values.
pub(crate) fn evaluate_tree(
    node: &Node<DefaultNumericTypes>,
    names: &[String],
    slots: &[Value],
    random: &RandomStream,
) -> EvalexprResult<Value> {
    node.eval_with_context(&SlotContext {
        names,
        slots,
        random,
    })
}

/// Answers evalexpr's variable and function look-ups from the slots of one run.
struct SlotContext<'a> {
    names: &'a [String],
    slots: &'a [Value],
    random: &'a RandomStream,
}

impl Context for SlotContext<'_> {
    type NumericTypes = DefaultNumericTypes;

    fn get_value(&self, identifier: &str) -> Option<&Value> {
        self.names
            .iter()
            .position(|name| name == identifier)
            .map(|slot| &self.slots[slot])
    }

    fn call_function(&self, identifier: &str, argument: &Value) -> EvalexprResultValue {
        functions::call(identifier, argument, self.random)
    }

    /// evalexpr's own builtins (`if`, `typeof`, `str::…`) are not part of Peridigm's language.
    fn are_builtin_functions_disabled(&self) -> bool {
        true
    }

    fn set_builtin_functions_disabled(&mut self, disabled: bool) -> EvalexprResult<()> {
        if disabled {
            Ok(())
        } else {
            Err(EvalexprError::BuiltinFunctionsCannotBeEnabled)
        }
    }
}

/// Describes a value the way a deck author thinks of it.
pub(crate) fn describe_value(value: &Value) -> String {
    match value {
        Value::Boolean(truth) => {
            format!("`{truth}` (the result of a comparison or logical operator)")
        }
        // Types are what matter here; the value itself comes from a trial run.
        Value::Float(_) => String::from("a number"),
        Value::Tuple(items) => format!("a list of {} values", items.len()),
        Value::Empty => String::from("nothing"),
        other => format!("{other}"),
    }
}

/// Turns evalexpr's type errors into advice in the deck author's terms.
pub(crate) fn describe_evaluation_error(error: &EvalexprError) -> String {
    match error {
        EvalexprError::ExpectedBoolean { actual } => format!(
            "`&&`, `||` and `!` need comparisons such as `x > 0`, but got {}",
            describe_value(actual)
        ),
        EvalexprError::ExpectedFloat { actual }
        | EvalexprError::ExpectedNumber { actual }
        | EvalexprError::ExpectedNumberOrString { actual } => format!(
            "a number is needed but got {}; comparisons cannot be used as 0/1 numbers here, use if/else instead",
            describe_value(actual)
        ),
        EvalexprError::WrongTypeCombination { .. } => String::from(
            "it mixes a comparison result (true/false) with numbers; comparisons cannot be used as 0/1 numbers here, use if/else instead",
        ),
        other => format!("{other}"),
    }
}
