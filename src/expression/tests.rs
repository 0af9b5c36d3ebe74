//! Tests of the expression language. Expected numbers are worked out by hand in the comments.

use super::*;

const PI: f64 = std::f64::consts::PI;

fn eval_at(source: &str, variables: &[&str], values: &[f64]) -> f64 {
    Expression::parse(source, variables)
        .unwrap_or_else(|error| panic!("{source:?} should parse: {error}"))
        .eval(values)
        .unwrap_or_else(|error| panic!("{source:?} should evaluate: {error}"))
}

/// Evaluates a constant expression (no variables).
fn eval0(source: &str) -> f64 {
    eval_at(source, &[], &[])
}

fn assert_close(actual: f64, expected: f64) {
    let tolerance = 1e-12 * expected.abs().max(1.0);
    assert!(
        (actual - expected).abs() <= tolerance,
        "got {actual:e}, expected {expected:e}"
    );
}

fn parse_error(source: &str, variables: &[&str]) -> ExpressionError {
    match Expression::parse(source, variables) {
        Ok(_) => panic!("{source:?} should be rejected"),
        Err(error) => error,
    }
}

#[test]
fn arithmetic_and_precedence() {
    // 1 + 2*3 - 4/8 = 1 + 6 - 0.5 = 6.5 (* and / before + and -).
    assert_close(eval0("1 + 2*3 - 4/8"), 6.5);
    // (1 + 2)*3 = 9.
    assert_close(eval0("(1 + 2)*3"), 9.0);
    // Left associativity: 10 - 4 - 3 = 3, 24 / 4 / 2 = 3.
    assert_close(eval0("10 - 4 - 3"), 3.0);
    assert_close(eval0("24 / 4 / 2"), 3.0);
    // Unary minus and plus: 2*-3 = -6, - -2 = 2, +5 - +2 = 3.
    assert_close(eval0("2*-3"), -6.0);
    assert_close(eval0("- -2"), 2.0);
    assert_close(eval0("+5 - +2"), 3.0);
    // Peridigm example BC: -0.1*t/0.00005 at t = 0.001 gives -0.1*0.001/0.00005 = -2.
    assert_close(
        eval_at("-0.1*t/0.00005", SPACE_TIME, &[0.0, 0.0, 0.0, 0.001]),
        -2.0,
    );
    // 2*x + y/4 at x = 3, y = 2: 6 + 0.5 = 6.5; variables are bound in the caller's order.
    assert_close(eval_at("2*x + y/4", SPACE_TIME, &[3.0, 2.0, 7.0, 9.0]), 6.5);
    // Number forms: 1E-5*2 = 2e-5, 1.5e+3 = 1500, .5 + 5. = 5.5, 2.5e-1 = 0.25.
    assert_close(eval0("1E-5*2"), 2e-5);
    assert_close(eval0("1.5e+3"), 1500.0);
    assert_close(eval0(".5 + 5."), 5.5);
    assert_close(eval0("2.5e-1"), 0.25);
    // Floating remainder: 7.5 % 2 = 1.5 (fmod).
    assert_close(eval0("7.5 % 2"), 1.5);
    // The `value = ` form and a trailing semicolon give the same result: 0.18 + 0.05*(0+0.4)/0.8 = 0.205.
    assert_close(
        eval_at("value = 0.18 + 0.05*(y+0.4)/0.8", SPACE, &[0.0, 0.0, 0.0]),
        0.205,
    );
    assert_close(
        eval_at("value = 0.18 + 0.05*(y+0.4)/0.8;", SPACE, &[0.0, 0.0, 0.0]),
        0.205,
    );
}

#[test]
fn power_operator_follows_rtcompiler() {
    // Peridigm's centrifugal body force: 1E-5 * 94.25^2 * x at x = 2:
    // 94.25^2 = 8883.0625, times 1e-5 = 0.088830625, times 2 = 0.17766125.
    assert_close(
        eval_at("1E-5 * 94.25^2 * x", SPACE_TIME, &[2.0, 0.0, 0.0, 0.0]),
        0.17766125,
    );
    // ^ binds tighter than *: 2*3^2 = 2*9 = 18; and than /: 18/3^2 = 2.
    assert_close(eval0("2*3^2"), 18.0);
    assert_close(eval0("18/3^2"), 2.0);
    // RTCompiler's negation (precedence 11) binds tighter than ^ (precedence 8):
    // -2^2 = (-2)^2 = 4, and -x^2 at x = 3 is 9.
    assert_close(eval0("-2^2"), 4.0);
    assert_close(eval_at("-x^2", SPACE, &[3.0, 0.0, 0.0]), 9.0);
    // To get -x² write it explicitly: -(x^2) = 0 - x^2 = -9 at x = 3.
    assert_close(eval_at("-(x^2)", SPACE, &[3.0, 0.0, 0.0]), -9.0);
    assert_close(eval_at("0 - x^2", SPACE, &[3.0, 0.0, 0.0]), -9.0);
    // RTCompiler's ^ is right-associative: 2^3^2 = 2^9 = 512 (not 8^2 = 64).
    assert_close(eval0("2^3^2"), 512.0);
    // Negative exponent: 2^-1 = 0.5; chained with unary minus: 2^-1^2 = 2^((-1)^2) = 2.
    assert_close(eval0("2^-1"), 0.5);
    assert_close(eval0("2^-1^2"), 2.0);
    // Powers of calls and groups: sqrt(4)^3 = 8, (1+1)^(1+2) = 8.
    assert_close(eval0("sqrt(4)^3"), 8.0);
    assert_close(eval0("(1+1)^(1+2)"), 8.0);
    // Fragmenting-cylinder velocity at z = 0.1 (z/0.05 - 1 = 1): 200 - 50*1^2 = 150.
    assert_close(
        eval_at(
            "(200 - 50*((z/0.05)-1)^2)",
            SPACE_TIME,
            &[0.0, 0.0, 0.1, 0.0],
        ),
        150.0,
    );
}

#[test]
fn integer_literals_divide_as_doubles() {
    // RTCompiler computes in double: 1/2 = 0.5 (evalexpr alone would give integer 0).
    assert_close(eval0("1/2"), 0.5);
    // 7/2 = 3.5; 3/4*x at x = 2 is 1.5.
    assert_close(eval0("7/2"), 3.5);
    assert_close(eval_at("3/4*x", SPACE, &[2.0, 0.0, 0.0]), 1.5);
    // Integer and float literals compare equal: 1 == 1.0 is true, so value = 1.
    assert_close(
        eval0("if (1 == 1.0) { value = 1; } else { value = 0; }"),
        1.0,
    );
    // Large integer literals stay exact doubles: 2^53 = 9007199254740992.
    assert_close(eval0("9007199254740992"), 9_007_199_254_740_992.0);
}

#[test]
fn every_function() {
    // Values from exact identities: sin(π/6) = 1/2, cos(π/3) = 1/2, tan(π/4) = 1,
    // asin(1/2) = π/6, acos(1/2) = π/3, atan(1) = π/4, atan2(1, -1) = 3π/4.
    assert_close(eval0("sin(3.141592653589793/6)"), 0.5);
    assert_close(eval0("cos(3.141592653589793/3)"), 0.5);
    assert_close(eval0("tan(3.141592653589793/4)"), 1.0);
    assert_close(eval0("asin(0.5)"), PI / 6.0);
    assert_close(eval0("acos(0.5)"), PI / 3.0);
    assert_close(eval0("atan(1)"), PI / 4.0);
    assert_close(eval0("atan2(1, -1)"), 3.0 * PI / 4.0);
    // Hyperbolic at ln 2: sinh = (2 - 1/2)/2 = 0.75, cosh = (2 + 1/2)/2 = 1.25;
    // tanh(ln 3) = (3 - 1/3)/(3 + 1/3) = 0.8.
    assert_close(eval0("sinh(log(2))"), 0.75);
    assert_close(eval0("cosh(log(2))"), 1.25);
    assert_close(eval0("tanh(log(3))"), 0.8);
    // sqrt(16) = 4, exp(0) = 1, log(exp(2)) = 2, log10(1000) = 3, pow(2, 10) = 1024.
    assert_close(eval0("sqrt(16)"), 4.0);
    assert_close(eval0("exp(0)"), 1.0);
    assert_close(eval0("exp(1)"), std::f64::consts::E);
    assert_close(eval0("log(exp(2))"), 2.0);
    assert_close(eval0("log10(1000)"), 3.0);
    assert_close(eval0("pow(2, 10)"), 1024.0);
    // fabs(-2.5) = abs(-2.5) = 2.5; floor(-2.5) = -3; ceil(-2.5) = -2; min/max of 3, -1.
    assert_close(eval0("fabs(-2.5)"), 2.5);
    assert_close(eval0("abs(-2.5)"), 2.5);
    assert_close(eval0("floor(-2.5)"), -3.0);
    assert_close(eval0("ceil(-2.5)"), -2.0);
    assert_close(eval0("min(3, -1)"), -1.0);
    assert_close(eval0("max(3, -1)"), 3.0);
    // erf(0) = 0; erf(0.5) = 0.5204998778130465 and erfc(0.5) = 0.4795001221869535
    // (Abramowitz & Stegun table 7.1; erf + erfc = 1).
    assert_close(eval0("erf(0)"), 0.0);
    assert_close(eval0("erf(0.5)"), 0.520_499_877_813_046_5);
    assert_close(eval0("erfc(0.5)"), 0.479_500_122_186_953_5);
    // Nested calls with expression arguments: pow(sqrt(9), 1+1) = 3^2 = 9.
    assert_close(eval0("pow(sqrt(9), 1+1)"), 9.0);
    // Fragmenting cylinder: (200 - 50*0^2)*cos(atan2(y, x)) at x = y = 1 (z = 0.05):
    // 200 * cos(π/4) = 141.42135623730951.
    assert_close(
        eval_at(
            "(200 - 50*((z/0.05)-1)^2)*cos(atan2(y,x))",
            SPACE_TIME,
            &[1.0, 1.0, 0.05, 0.0],
        ),
        200.0 * (PI / 4.0).cos(),
    );
    // sqrt of a negative number is NaN, as in C, not an error.
    assert!(eval0("sqrt(-1)").is_nan());
}

#[test]
fn if_else_chains() {
    // twist_and_pull.yaml, escaped braces: before t = 0.2 the branch gives 0,
    // after it 1000*(t - 0.2) = 1000*0.1 = 100 at t = 0.3.
    let twist = r" if(t <= 0.2)\{ value = 0.0; \} else\{ value = 1000*(t-0.2); \} ";
    assert_close(eval_at(twist, SPACE_TIME, &[0.0, 0.0, 0.0, 0.1]), 0.0);
    assert!((eval_at(twist, SPACE_TIME, &[0.0, 0.0, 0.0, 0.3]) - 100.0).abs() < 1e-9);
    // Same with plain braces (deck reader removed the backslashes).
    let plain = "if(t <= 0.2) { value = 0.1*t; } else { value = 0.02; }";
    // t = 0.1: 0.1*0.1 = 0.01; t = 0.5: 0.02.
    assert_close(eval_at(plain, SPACE_TIME, &[0.0, 0.0, 0.0, 0.1]), 0.01);
    assert_close(eval_at(plain, SPACE_TIME, &[0.0, 0.0, 0.0, 0.5]), 0.02);
    // The rotation BC of twist_and_pull at x = 1, y = 0, t = 0.1:
    // x*cos(0.15) - y*sin(0.15) - x = cos(0.15) - 1.
    let rotation = r" if(t <= 0.2)\{ value = x*cos(1.5*t)-y*sin(1.5*t)-x; \} else\{ value = x*cos(1.5*0.2)-y*sin(1.5*0.2)-x; \} ";
    assert_close(
        eval_at(rotation, SPACE_TIME, &[1.0, 0.0, 0.0, 0.1]),
        0.15f64.cos() - 1.0,
    );
    // else-if chain: sign function at -2, 0, 5.
    let sign = "if (x < 0) { value = -1; } else if (x == 0) { value = 0; } else { value = 1; }";
    assert_close(eval_at(sign, SPACE, &[-2.0, 0.0, 0.0]), -1.0);
    assert_close(eval_at(sign, SPACE, &[0.0, 0.0, 0.0]), 0.0);
    assert_close(eval_at(sign, SPACE, &[5.0, 0.0, 0.0]), 1.0);
    // Without braces, C style: t = 0.5 → 2*0.5 = 1; t = 3 → 2.
    let unbraced = "if (t < 1) value = 2*t; else value = 2;";
    assert_close(eval_at(unbraced, TIME, &[0.5]), 1.0);
    assert_close(eval_at(unbraced, TIME, &[3.0]), 2.0);
    // XML regression deck (entities already decoded): t = 0.5, y = 2 → -2e-6*0.5 = -1e-6;
    // t = 3 → -2e-6*1 = -2e-6.
    let xml = "if(t<=1){value=-y*1.0e-6*t;} else{value=-y*1.0e-6*1;}";
    assert_close(eval_at(xml, SPACE_TIME, &[0.0, 2.0, 0.0, 0.5]), -1e-6);
    assert_close(eval_at(xml, SPACE_TIME, &[0.0, 2.0, 0.0, 3.0]), -2e-6);
    // Nested if inside else with logical operators:
    // x = 1, y = -1: (x > 0 && !(y > 0)) is true → 10.
    // x = 1, y = 1: first false; (t == 1 || y > 5) with t = 1 true → 20.
    // x = -1, y = 1, t = 0: both false → 30.
    let logic = "if (x > 0 && !(y > 0)) { value = 10; } else { if (t == 1 || y > 5) value = 20; else value = 30; }";
    assert_close(eval_at(logic, SPACE_TIME, &[1.0, -1.0, 0.0, 0.0]), 10.0);
    assert_close(eval_at(logic, SPACE_TIME, &[1.0, 1.0, 0.0, 1.0]), 20.0);
    assert_close(eval_at(logic, SPACE_TIME, &[-1.0, 1.0, 0.0, 0.0]), 30.0);
    // A numeric condition is true when non-zero (C): x = 0 → 2, x = 0.5 → 1.
    let numeric = "if (x) value = 1; else value = 2;";
    assert_close(eval_at(numeric, SPACE, &[0.0, 0.0, 0.0]), 2.0);
    assert_close(eval_at(numeric, SPACE, &[0.5, 0.0, 0.0]), 1.0);
    // Only the taken branch runs: at t = 0 the then-branch's drand() is skipped, so `value`
    // gets the first draw of the stream (counter 1), computed here directly from the seed rule.
    let lazy = Expression::parse(
        "if (t > 1) { a = drand(); } else { a = 0; } value = drand();",
        TIME,
    )
    .unwrap();
    let stream = functions::RandomStream::new(lazy.source_hash, &[0.0]);
    let first_draw = match functions::call("drand", &evalexpr::Value::Empty, &stream).unwrap() {
        evalexpr::Value::Float(draw) => draw,
        other => panic!("drand gave {other:?}"),
    };
    assert_eq!(lazy.eval(&[0.0]).unwrap(), first_draw);
    // At t = 2 the branch draws first, so `value` is the second draw of that point's stream.
    let stream = functions::RandomStream::new(lazy.source_hash, &[2.0]);
    let _skipped = functions::call("drand", &evalexpr::Value::Empty, &stream).unwrap();
    let second_draw = functions::call("drand", &evalexpr::Value::Empty, &stream).unwrap();
    assert_eq!(
        evalexpr::Value::Float(lazy.eval(&[2.0]).unwrap()),
        second_draw
    );
}

#[test]
fn temporaries_and_declarations() {
    // r = sqrt(3² + 4²) = 5, value = 100*3/5 = 60.
    assert_close(
        eval_at(
            "r = sqrt(x*x+y*y); value = 100.0*x/r;",
            SPACE,
            &[3.0, 4.0, 0.0],
        ),
        60.0,
    );
    // Declarations and compound assignment: a = 2; a += 3 → 5; a *= 2 → 10; a -= 1 → 9; a /= 3 → 3.
    assert_close(
        eval0("double a = 2; a += 3; a *= 2; a -= 1; a /= 3; value = a;"),
        3.0,
    );
    // `int` truncates like C: int n = 7/2 → 3 (7/2 = 3.5 truncated); n = -7/2 → -3.
    assert_close(eval0("int n = 7/2; value = n;"), 3.0);
    assert_close(eval0("int n = 1; n = -7/2; value = n;"), -3.0);
    // Declaration without initialiser followed by assignment: b = 4 → value = 8.
    assert_close(eval0("double b; b = 4; value = 2*b;"), 8.0);
    // `value` can be read after it is set (WaveInCube pattern): value = 0 then, inside the if,
    // value = 5 then value = value*2 = 10 when x < 1; stays 0 otherwise.
    let wave = "value = 0.0; if (x < 1.0) { value = 5; value = value * 2; }";
    assert_close(eval_at(wave, SPACE, &[0.5, 0.0, 0.0]), 10.0);
    assert_close(eval_at(wave, SPACE, &[2.0, 0.0, 0.0]), 0.0);
    // A temporary assigned in both branches is definitely assigned afterwards:
    // t = 2 → s = 3 → value = 9; t = 0 → s = 1 → value = 1.
    let both = "if (t > 1) { s = 3; } else { s = 1; } value = s*s;";
    assert_close(eval_at(both, TIME, &[2.0]), 9.0);
    assert_close(eval_at(both, TIME, &[0.0]), 1.0);
    // Comments are ignored: 1 + 2 = 3.
    assert_close(eval0("// the load\nvalue = 1 /* base */ + 2; // done"), 3.0);
    // More than the inline slot count (12) of temporaries: sum of 1..=14 = 105.
    let many: String = (1..=14)
        .map(|i| format!("a{i} = {i}; "))
        .collect::<String>()
        + "value = a1+a2+a3+a4+a5+a6+a7+a8+a9+a10+a11+a12+a13+a14 + 0*x;";
    assert_close(eval_at(&many, SPACE, &[1.0, 0.0, 0.0]), 105.0);
    // Influence function 1/zeta at zeta = 0.25: 4.
    assert_close(eval_at("1.0/zeta", INFLUENCE, &[0.25, 1.0]), 4.0);
    // Parabolic decay written by hand at zeta/horizon = 0.75: -4*0.5625 + 4*0.75 = 0.75.
    let parabolic = "r = zeta/horizon; if (r < 0.5) { value = 1; } else { value = -4*r^2 + 4*r; }";
    assert_close(eval_at(parabolic, INFLUENCE, &[0.75, 1.0]), 0.75);
}

#[test]
fn uses_and_constant_value() {
    let bc = Expression::parse("0.01*x", SPACE_TIME).unwrap();
    assert!(bc.uses("x"));
    assert!(!bc.uses("y") && !bc.uses("t"));
    assert!(!bc.uses("nonexistent"));
    assert_eq!(bc.constant_value(), None);
    assert_eq!(bc.source(), "0.01*x");

    let ramp = Expression::parse("-0.1*t/0.00005", SPACE_TIME).unwrap();
    assert!(ramp.uses("t") && !ramp.uses("x") && !ramp.uses("y") && !ramp.uses("z"));

    // Variables read only inside a branch count.
    let branch =
        Expression::parse("if (t < 1) { value = y; } else { value = 0; }", SPACE_TIME).unwrap();
    assert!(branch.uses("t") && branch.uses("y") && !branch.uses("x"));

    // Constants: "0.0" → 0; "2*3" → 6; temporaries only: r = 2, r*r = 4.
    assert_eq!(
        Expression::parse("0.0", SPACE_TIME)
            .unwrap()
            .constant_value(),
        Some(0.0)
    );
    assert_eq!(
        Expression::parse("2*3", SPACE_TIME)
            .unwrap()
            .constant_value(),
        Some(6.0)
    );
    assert_eq!(
        Expression::parse("r = 2; value = r*r;", SPACE_TIME)
            .unwrap()
            .constant_value(),
        Some(4.0)
    );
    // Random numbers are never constant.
    assert_eq!(
        Expression::parse("drand()", SPACE_TIME)
            .unwrap()
            .constant_value(),
        None
    );
    assert_eq!(
        Expression::parse("rand()*0", SPACE_TIME)
            .unwrap()
            .constant_value(),
        None
    );
    // Constant expressions still evaluate normally with any values.
    assert_eq!(
        Expression::parse("2*3", SPACE_TIME)
            .unwrap()
            .eval(&[1.0, 2.0, 3.0, 4.0])
            .unwrap(),
        6.0
    );
}

#[test]
fn random_numbers_are_reproducible_and_in_range() {
    let noise = Expression::parse("drand()", SPACE_TIME).unwrap();
    let point = [0.1, 0.2, 0.3, 1e-4];
    // Same expression text, same point and time → same number, also from a separate parse.
    let first = noise.eval(&point).unwrap();
    assert_eq!(first, noise.eval(&point).unwrap());
    assert_eq!(
        first,
        Expression::parse("drand()", SPACE_TIME)
            .unwrap()
            .eval(&point)
            .unwrap()
    );
    // Another point or time → another number.
    assert_ne!(first, noise.eval(&[0.1, 0.2, 0.3, 2e-4]).unwrap());
    assert_ne!(first, noise.eval(&[0.1, 0.2, 0.4, 1e-4]).unwrap());
    // Two draws within one evaluation differ: drand() - drand() is non-zero.
    assert_ne!(eval_at("drand() - drand()", SPACE_TIME, &point), 0.0);

    // Range [0, 1) and uniformity: the mean of n uniform draws is 1/2 with standard deviation
    // sqrt(1/12/n) = 0.0029 for n = 10000; 0.015 is five standard deviations.
    let count = 10_000;
    let mut sum = 0.0;
    let mut below_quarter = 0;
    for i in 0..count {
        let draw = noise.eval(&[i as f64, 0.0, 0.0, 0.0]).unwrap();
        assert!((0.0..1.0).contains(&draw), "drand() gave {draw}");
        sum += draw;
        below_quarter += usize::from(draw < 0.25);
    }
    assert!(
        (sum / count as f64 - 0.5).abs() < 0.015,
        "mean {}",
        sum / count as f64
    );
    // P(draw < 1/4) = 1/4; binomial std sqrt(n/4*3/4) = 43, so ±250 is ~6 std.
    assert!(
        (below_quarter as i64 - 2500).abs() < 250,
        "{below_quarter} draws below 0.25"
    );

    // rand(): integers in [0, RAND_MAX] like C; mean RAND_MAX/2.
    let integers = Expression::parse("rand()", TIME).unwrap();
    let mut integer_sum = 0.0;
    for i in 0..count {
        let draw = integers.eval(&[i as f64]).unwrap();
        assert!(
            (0.0..=RAND_MAX).contains(&draw) && draw.fract() == 0.0,
            "rand() gave {draw}"
        );
        integer_sum += draw;
    }
    let mean_fraction = integer_sum / count as f64 / RAND_MAX;
    assert!(
        (mean_fraction - 0.5).abs() < 0.015,
        "rand() mean / RAND_MAX = {mean_fraction}"
    );
}

#[test]
fn syntax_errors_name_the_place() {
    let error = parse_error("value = 1 +", SPACE_TIME);
    assert!(matches!(error, ExpressionError::Syntax { .. }), "{error:?}");
    let message = error.to_string();
    assert!(
        message.contains("\"value = 1 +\"") && message.contains("column 11"),
        "{message}"
    );
    assert!(message.contains("missing operand after `+`"), "{message}");

    // Missing operator between operands (column 3 is `x`).
    let message = parse_error("2 x", SPACE_TIME).to_string();
    assert!(
        message.contains("column 3") && message.contains("missing operator"),
        "{message}"
    );
    // Implicit multiplication is not a number.
    assert!(parse_error("2x", SPACE_TIME)
        .to_string()
        .contains("`2x` is not a number"));
    // Unbalanced parentheses.
    assert!(parse_error("(1+2", SPACE_TIME)
        .to_string()
        .contains("never closed"));
    assert!(parse_error("1+2)", SPACE_TIME)
        .to_string()
        .contains("without a matching `(`"));
    // Unclosed block and stray else.
    assert!(parse_error("if (t < 1) { value = 1;", SPACE_TIME)
        .to_string()
        .contains("never closed by `}`"));
    assert!(parse_error("value = 1; else value = 2;", SPACE_TIME)
        .to_string()
        .contains("`else` without"));
    // Single & and ternary get hints.
    assert!(
        parse_error("if (x > 0 & y > 0) value = 1; else value = 0;", SPACE_TIME)
            .to_string()
            .contains("`&&`")
    );
    assert!(parse_error("x > 0 ? 1 : 2", SPACE_TIME)
        .to_string()
        .contains("use if/else"));
    // Loops are refused explicitly.
    assert!(parse_error(
        "value = 0; for (i = 0; i < 3; i += 1) value += 1;",
        SPACE_TIME
    )
    .to_string()
    .contains("`for` statements are not supported"));
    // Assignment inside a condition.
    assert!(
        parse_error("if (x = 1) value = 1; else value = 2;", SPACE_TIME)
            .to_string()
            .contains("compare with `==`")
    );
    // Pathological input is refused, not a stack overflow: 300 nested parentheses (601
    // symbols, under the length limit), 100 000 nested blocks, and a 100 000-term sum.
    let deep = "(".repeat(300) + "1" + &")".repeat(300);
    assert!(parse_error(&deep, SPACE_TIME)
        .to_string()
        .contains("nested more than"));
    let blocks = "{".repeat(100_000) + "value = 1;" + &"}".repeat(100_000);
    assert!(parse_error(&blocks, SPACE_TIME)
        .to_string()
        .contains("nested more than"));
    let long = vec!["1"; 100_000].join("+");
    assert!(parse_error(&long, SPACE_TIME)
        .to_string()
        .contains("longer than"));
    // Multi-line text reports line and column: `@` is on line 2, column 11.
    let message = parse_error("value = 0;\nvalue = 1 @ 2;", SPACE_TIME).to_string();
    assert!(message.contains("line 2, column 11"), "{message}");
}

#[test]
fn unknown_variables_are_caught_at_parse_time() {
    let error = parse_error("0.1*w", SPACE_TIME);
    assert!(
        matches!(&error, ExpressionError::UnknownVariable { name, .. } if name == "w"),
        "{error:?}"
    );
    let message = error.to_string();
    assert!(
        message.contains("`w`") && message.contains("`x`, `y`, `z`, `t`"),
        "{message}"
    );
    // Case slip gets a suggestion.
    assert!(parse_error("0.1*X", SPACE_TIME)
        .to_string()
        .contains("did you mean `x`?"));
    // `t` is not a variable of a horizon; `zeta` only of influence functions.
    assert!(matches!(
        parse_error("0.5 + t", SPACE),
        ExpressionError::UnknownVariable { .. }
    ));
    assert!(matches!(
        parse_error("1/zeta", SPACE_TIME),
        ExpressionError::UnknownVariable { .. }
    ));
    // Named influence functions are not expressions.
    assert!(matches!(
        parse_error("One", INFLUENCE),
        ExpressionError::UnknownVariable { .. }
    ));
    // A temporary read before assignment, and one assigned only in one branch.
    let error = parse_error("value = r; r = 1;", SPACE_TIME);
    assert!(
        matches!(&error, ExpressionError::Unassigned { name, .. } if name == "r"),
        "{error:?}"
    );
    assert!(matches!(
        parse_error("if (t > 1) { r = 1; } value = r;", SPACE_TIME),
        ExpressionError::Unassigned { .. }
    ));
    // Declared but never assigned.
    assert!(matches!(
        parse_error("double q; value = q;", SPACE_TIME),
        ExpressionError::Unassigned { .. }
    ));
    // Built-in variables cannot be redeclared.
    assert!(parse_error("double x = 1; value = x;", SPACE_TIME)
        .to_string()
        .contains("cannot be declared"));
}

#[test]
fn unknown_functions_get_suggestions() {
    let error = parse_error("sine(x)", SPACE_TIME);
    assert!(
        matches!(&error, ExpressionError::UnknownFunction { name, .. } if name == "sine"),
        "{error:?}"
    );
    assert!(error.to_string().contains("did you mean `sin`?"), "{error}");
    assert!(parse_error("sqr(x)", SPACE_TIME)
        .to_string()
        .contains("did you mean `sqrt`?"));
    // evalexpr's own namespace is not exposed.
    assert!(matches!(
        parse_error("math::sin(x)", SPACE_TIME),
        ExpressionError::Syntax { .. }
    ));
    // RTCompiler-only functions are named as such.
    assert!(parse_error("gamma(x)", SPACE_TIME)
        .to_string()
        .contains("RTCompiler has `gamma`"));
    // Wrong argument counts.
    let error = parse_error("pow(x)", SPACE_TIME);
    assert!(
        matches!(
            error,
            ExpressionError::ArgumentCount {
                expected: 2,
                found: 1,
                ..
            }
        ),
        "{error:?}"
    );
    assert!(matches!(
        parse_error("sin(x, y)", SPACE_TIME),
        ExpressionError::ArgumentCount { .. }
    ));
    assert!(matches!(
        parse_error("drand(1)", SPACE_TIME),
        ExpressionError::ArgumentCount { .. }
    ));
    // A variable used as a function, and a function used as a variable.
    assert!(parse_error("x(1+2)", SPACE_TIME)
        .to_string()
        .contains("is a variable, not a function"));
    assert!(parse_error("sin*2", SPACE_TIME)
        .to_string()
        .contains("is a function"));
}

#[test]
fn missing_value_and_type_errors() {
    // An if without else leaves `value` unset for t >= 1.
    let error = parse_error("if (t < 1) { value = 1; }", SPACE_TIME);
    assert!(
        matches!(error, ExpressionError::MissingValue { .. }),
        "{error:?}"
    );
    assert!(error.to_string().contains("only on some paths"), "{error}");
    // Assigned in the if branch and in the else-if branch but not in the final else.
    assert!(matches!(
        parse_error(
            "if (t < 1) value = 1; else if (t < 2) value = 2; else r = 3;",
            SPACE_TIME
        ),
        ExpressionError::MissingValue { .. }
    ));
    // `value` read before it is assigned.
    let error = parse_error("r = 1; if (value == 1) r = 2; value = r;", SPACE_TIME);
    assert!(
        matches!(&error, ExpressionError::Unassigned { name, .. } if name == "value"),
        "{error:?}"
    );
    // A comparison result used as a number: found at parse time.
    let error = parse_error("(x > 0)*2", SPACE_TIME);
    assert!(
        matches!(error, ExpressionError::NotANumber { .. }),
        "{error:?}"
    );
    assert!(error.to_string().contains("use if/else"), "{error}");
    let error = parse_error("x > 0", SPACE_TIME);
    assert!(
        matches!(error, ExpressionError::NotANumber { .. }),
        "{error:?}"
    );
    // `&&` on numbers.
    assert!(matches!(
        parse_error("if (x && y) value = 1; else value = 0;", SPACE_TIME),
        ExpressionError::NotANumber { .. }
    ));
    // Wrong number of values at evaluation time is an error, not a panic.
    let expression = Expression::parse("x + t", SPACE_TIME).unwrap();
    let error = expression.eval(&[1.0, 2.0]).unwrap_err();
    assert!(
        matches!(
            error,
            ExpressionError::ValueCount {
                expected: 4,
                found: 2,
                ..
            }
        ),
        "{error:?}"
    );
    assert!(error.to_string().contains("x, y, z, t"), "{error}");
}

#[test]
fn expression_is_send_sync_clone() {
    fn assert_traits<T: Send + Sync + Clone>() {}
    assert_traits::<Expression>();
    // Evaluating from several threads gives the same numbers as sequentially,
    // including random draws (they depend on the inputs, not on the order).
    let expression = Expression::parse("x*t + drand()", SPACE_TIME).unwrap();
    let sequential: Vec<f64> = (0..64)
        .map(|i| expression.eval(&[i as f64, 0.0, 0.0, 0.5]).unwrap())
        .collect();
    let parallel: Vec<f64> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..4)
            .map(|chunk| {
                let expression = expression.clone();
                scope.spawn(move || {
                    (chunk * 16..chunk * 16 + 16)
                        .map(|i| expression.eval(&[i as f64, 0.0, 0.0, 0.5]).unwrap())
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|handle| handle.join().unwrap())
            .collect()
    });
    assert_eq!(sequential, parallel);
}

/// Prints the evaluation cost; no assertion (timings depend on the machine and profile).
#[test]
fn evaluation_timing_report() {
    fn nanoseconds_per_eval(source: &str) -> f64 {
        let expression = Expression::parse(source, SPACE_TIME).unwrap();
        let count = 200_000;
        let mut sink = 0.0;
        let start = std::time::Instant::now();
        for i in 0..count {
            let t = i as f64 * 1e-6;
            sink += expression
                .eval(std::hint::black_box(&[0.5, 0.25, 0.125, t]))
                .unwrap();
        }
        let elapsed = start.elapsed();
        std::hint::black_box(sink);
        elapsed.as_nanos() as f64 / count as f64
    }
    let ramp = nanoseconds_per_eval("-0.1*t/0.00005");
    let branch =
        nanoseconds_per_eval(r"if(t <= 0.1) \{ value = 0.1*t; \} else \{ value = 0.02; \}");
    let rotation = nanoseconds_per_eval(
        r" if(t <= 0.2)\{ value = x*cos(1.5*t)-y*sin(1.5*t)-x; \} else\{ value = x*cos(1.5*0.2)-y*sin(1.5*0.2)-x; \} ",
    );
    println!("expression eval: `-0.1*t/0.00005` {ramp:.0} ns, if/else ramp {branch:.0} ns, twist rotation {rotation:.0} ns");
}

/// Every expression string in Peridigm's example and regression decks must parse (and
/// evaluate to a finite number at a generic point). The decks are read from `$PERIDIGM_DATA`,
/// else from `../shared/peridigm` beside the checkout, where CI puts them.
#[test]
fn peridigm_deck_expressions_parse() {
    let root = std::env::var_os("PERIDIGM_DATA").map_or_else(
        || std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/peridigm"),
        std::path::PathBuf::from,
    );
    if !root.is_dir() {
        println!(
            "note: {} not found; skipping the Peridigm deck scan",
            root.display()
        );
        return;
    }
    let mut files = Vec::new();
    let mut pending = vec![root.clone()];
    while let Some(directory) = pending.pop() {
        for entry in std::fs::read_dir(&directory).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                pending.push(path);
            } else if path
                .extension()
                .is_some_and(|extension| extension == "yaml" || extension == "xml")
            {
                files.push(path);
            }
        }
    }
    files.sort();

    let mut checked = 0;
    let mut failures = Vec::new();
    for file in &files {
        let text = std::fs::read_to_string(file).unwrap();
        let is_xml = file.extension().is_some_and(|extension| extension == "xml");
        let found = if is_xml {
            xml_expressions(&text)
        } else {
            yaml_expressions(&text)
        };
        for (key, source) in found {
            let variables = match key.as_str() {
                "Value" => SPACE_TIME,
                "Horizon" => SPACE,
                "Influence Function" => {
                    if ["One", "Parabolic Decay", "Gaussian"].contains(&source.trim()) {
                        continue;
                    }
                    INFLUENCE
                }
                _ => TIME,
            };
            // A point inside the decks' small geometries at an early time (some loads grow like
            // exp(t/1e-8)).
            let values = [0.3, 0.2, 0.1, 1e-9];
            match Expression::parse(&source, variables)
                .and_then(|e| e.eval(&values[..variables.len()]))
            {
                Ok(result) if result.is_finite() => checked += 1,
                Ok(result) => failures.push(format!(
                    "{}: {key} = {source:?} gave {result}",
                    file.display()
                )),
                Err(error) => failures.push(format!("{}: {key}: {error}", file.display())),
            }
        }
    }
    println!(
        "parsed {checked} expressions from {} deck files under {}",
        files.len(),
        root.display()
    );
    assert!(
        failures.is_empty(),
        "deck expressions failed:\n{}",
        failures.join("\n")
    );
    assert!(
        checked > 0,
        "no expressions found under {}; the scanner is broken",
        root.display()
    );
}

const DECK_KEYS: &[&str] = &[
    "Value",
    "Horizon",
    "Influence Function",
    "Time Dependent Critical Stretch",
    "Friction Coefficient",
];

/// `<Parameter name="KEY" ... value="..."/>`, the value possibly spanning lines.
fn xml_expressions(text: &str) -> Vec<(String, String)> {
    let attribute = |element: &str, name: &str| -> Option<String> {
        let start = element.find(&format!(" {name}=\""))? + name.len() + 3;
        let end = start + element[start..].find('"')?;
        Some(element[start..end].to_string())
    };
    let mut found = Vec::new();
    let mut rest = text;
    while let Some(start) = rest.find("<Parameter") {
        let after = &rest[start..];
        let Some(end) = after.find("/>") else { break };
        let element = &after[..end];
        rest = &after[end..];
        let (Some(name), Some(value)) = (attribute(element, "name"), attribute(element, "value"))
        else {
            continue;
        };
        if DECK_KEYS.contains(&name.as_str()) {
            let decoded = value
                .replace("&lt;", "<")
                .replace("&gt;", ">")
                .replace("&quot;", "\"")
                .replace("&apos;", "'")
                .replace("&amp;", "&");
            found.push((name, decoded));
        }
    }
    found
}

/// `KEY: value` lines; quoted values have their quotes removed.
fn yaml_expressions(text: &str) -> Vec<(String, String)> {
    let mut found = Vec::new();
    for line in text.lines() {
        let Some((key, value)) = line.trim_start().split_once(':') else {
            continue;
        };
        if !DECK_KEYS.contains(&key) {
            continue;
        }
        let value = value.trim();
        let value = if let Some(quoted) = value.strip_prefix('"') {
            quoted.rsplit_once('"').map_or(quoted, |(inside, _)| inside)
        } else if let Some(quoted) = value.strip_prefix('\'') {
            quoted
                .rsplit_once('\'')
                .map_or(quoted, |(inside, _)| inside)
        } else {
            value.split(" #").next().unwrap_or(value).trim()
        };
        if !value.is_empty() {
            found.push((key.to_string(), value.to_string()));
        }
    }
    found
}
