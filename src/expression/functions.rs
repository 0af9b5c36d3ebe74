//! The math functions an expression may call, and the deterministic random stream behind
//! `rand()` / `drand()`.
//!
//! Names follow Trilinos' RTCompiler (the parser Peridigm uses), so decks call `sin(x)`, not
//! evalexpr's `math::sin(x)`. evalexpr's own builtins are switched off: every call goes through
//! [`call`], which keeps the set of accepted names exactly the table below.

use std::cell::Cell;

use evalexpr::{EvalexprError, EvalexprResult, Value};

/// One callable function: its name as written in a deck and how many arguments it takes.
#[derive(Debug, Clone, Copy)]
pub(crate) struct FunctionSpec {
    pub name: &'static str,
    pub arity: usize,
}

const fn spec(name: &'static str, arity: usize) -> FunctionSpec {
    FunctionSpec { name, arity }
}

/// Every function an expression may call. The first block is RTCompiler's math set
/// (`Registrar.C`), the second the C library extras we accept because they cost nothing.
pub(crate) const FUNCTIONS: &[FunctionSpec] = &[
    spec("fabs", 1),
    spec("sin", 1),
    spec("cos", 1),
    spec("tan", 1),
    spec("sqrt", 1),
    spec("tanh", 1),
    spec("sinh", 1),
    spec("cosh", 1),
    spec("log", 1),
    spec("log10", 1),
    spec("exp", 1),
    spec("asin", 1),
    spec("acos", 1),
    spec("atan", 1),
    spec("atan2", 2),
    spec("pow", 2),
    spec("rand", 0),
    spec("drand", 0),
    spec("erf", 1),
    spec("erfc", 1),
    // C library functions RTCompiler does not register; accepted for convenience.
    spec("abs", 1),
    spec("floor", 1),
    spec("ceil", 1),
    spec("min", 2),
    spec("max", 2),
];

/// Functions RTCompiler registers that peridyn deliberately does not provide (I/O, Bessel
/// variants, `gamma` whose meaning differs between C libraries). Naming them gives a clearer
/// error than "unknown function".
pub(crate) const RTCOMPILER_ONLY: &[&str] = &[
    "gamma",
    "j0",
    "j1",
    "i0",
    "i1",
    "gcei",
    "print",
    "printf",
    "scanf",
    "readline",
    "arrayFill",
];

/// Looks a function up by the name written in the expression.
pub(crate) fn find(name: &str) -> Option<&'static FunctionSpec> {
    FUNCTIONS.iter().find(|function| function.name == name)
}

/// Whether calling `name` consumes the random stream (such expressions are never constant).
pub(crate) fn is_random(name: &str) -> bool {
    name == "rand" || name == "drand"
}

/// glibc's `RAND_MAX`: C `rand()` returns integers in `[0, RAND_MAX]`, and so does ours.
pub const RAND_MAX: f64 = 2_147_483_647.0;

/// The random stream of one evaluation.
///
/// Seed rule (documented on [`crate::expression::Expression`]): draw number `k` (counting from
/// 0 within one evaluation) is `splitmix64(seed + (k+1)·φ)` where the seed hashes the expression
/// text and the bit patterns of the variable values passed to `eval`. A value therefore depends
/// only on *what* is evaluated, never on thread scheduling or how often the expression was
/// evaluated before, so runs are reproducible with any number of threads.
pub(crate) struct RandomStream {
    seed: u64,
    draws: Cell<u64>,
}

/// 2^64 / golden ratio, the Weyl increment used by SplitMix64.
const GOLDEN_GAMMA: u64 = 0x9E37_79B9_7F4A_7C15;

impl RandomStream {
    pub(crate) fn new(source_hash: u64, values: &[f64]) -> Self {
        let seed = values.iter().fold(source_hash, |hash, value| {
            splitmix64(hash ^ value.to_bits())
        });
        Self {
            seed,
            draws: Cell::new(0),
        }
    }

    fn next_u64(&self) -> u64 {
        let k = self.draws.get() + 1;
        self.draws.set(k);
        splitmix64(self.seed.wrapping_add(k.wrapping_mul(GOLDEN_GAMMA)))
    }

    /// Uniform in [0, 1): the top 53 bits scaled by 2^-53, so every double of the form m·2^-53
    /// is equally likely.
    fn uniform(&self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Integer-valued like C `rand()`: uniform over `0..=RAND_MAX` (31 bits).
    fn integer(&self) -> f64 {
        (self.next_u64() >> 33) as f64
    }
}

/// SplitMix64 finaliser (Steele, Lea & Flood 2014): a bijective 64-bit mixer whose outputs
/// for consecutive inputs pass BigCrush, used here as a counter-based generator.
fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(GOLDEN_GAMMA);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// FNV-1a over the expression text. Chosen over `std::hash` because its output is fixed by
/// definition, so random streams do not change between Rust releases.
pub(crate) fn stable_hash(text: &str) -> u64 {
    text.bytes().fold(0xCBF2_9CE4_8422_2325, |hash, byte| {
        (hash ^ u64::from(byte)).wrapping_mul(0x0000_0100_0000_01B3)
    })
}

fn number(value: &Value) -> EvalexprResult<f64> {
    match value {
        Value::Float(number) => Ok(*number),
        other => Err(EvalexprError::expected_float(other.clone())),
    }
}

fn two_numbers(argument: &Value) -> EvalexprResult<(f64, f64)> {
    match argument {
        Value::Tuple(items) if items.len() == 2 => Ok((number(&items[0])?, number(&items[1])?)),
        other => Err(EvalexprError::ExpectedFixedLengthTuple {
            expected_length: 2,
            actual: other.clone(),
        }),
    }
}

/// Evaluates function `name` for evalexpr. The argument is a single value for one argument, a
/// tuple for two, `Empty` for none; arity was already checked when the expression was parsed.
pub(crate) fn call(name: &str, argument: &Value, random: &RandomStream) -> EvalexprResult<Value> {
    let unary = |f: fn(f64) -> f64| number(argument).map(|x| Value::Float(f(x)));
    let binary = |f: fn(f64, f64) -> f64| two_numbers(argument).map(|(a, b)| Value::Float(f(a, b)));
    match name {
        "fabs" | "abs" => unary(f64::abs),
        "sin" => unary(f64::sin),
        "cos" => unary(f64::cos),
        "tan" => unary(f64::tan),
        "sqrt" => unary(f64::sqrt),
        "tanh" => unary(f64::tanh),
        "sinh" => unary(f64::sinh),
        "cosh" => unary(f64::cosh),
        "log" => unary(f64::ln),
        "log10" => unary(f64::log10),
        "exp" => unary(f64::exp),
        "asin" => unary(f64::asin),
        "acos" => unary(f64::acos),
        "atan" => unary(f64::atan),
        "atan2" => binary(f64::atan2),
        "pow" => binary(f64::powf),
        "erf" => unary(libm::erf),
        "erfc" => unary(libm::erfc),
        "floor" => unary(f64::floor),
        "ceil" => unary(f64::ceil),
        // C fmin/fmax: a NaN argument is ignored in favour of the other one.
        "min" => binary(f64::min),
        "max" => binary(f64::max),
        "drand" => Ok(Value::Float(random.uniform())),
        "rand" => Ok(Value::Float(random.integer())),
        _ => Err(EvalexprError::FunctionIdentifierNotFound(name.to_string())),
    }
}
