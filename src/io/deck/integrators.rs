//! The integrator sublist of a `Solver` list (`Verlet`, `QuasiStatic`, `NOXQuasiStatic`,
//! `Implicit`, `ImplicitDiffusion`, and peridyn's `DynamicRelaxation`): its keys and the final
//! time it implies.

use super::error::DeckError;
use super::linear_solve::{read_belos, BelosSettings};
use super::parameters::{to_parameter_value, ParameterValue};
use super::reader::{Ctx, Field, ListReader};

/// The integrator sublist of a solver.
#[derive(Debug, Clone, PartialEq)]
pub enum Integrator {
    /// `Verlet` — explicit velocity Verlet.
    Verlet(Verlet),
    /// `QuasiStatic` — Peridigm's own Newton–Raphson with line search.
    QuasiStatic(QuasiStatic),
    /// `NOXQuasiStatic` — Newton through NOX.
    NoxQuasiStatic(NoxQuasiStatic),
    /// `Implicit` — Newmark-β dynamics.
    Implicit(Implicit),
    /// `ImplicitDiffusion` — Newton on temperature.
    ImplicitDiffusion(ImplicitDiffusion),
    /// `DynamicRelaxation` — load steps relaxed by adaptive dynamic relaxation (peridyn's;
    /// Peridigm has none).
    DynamicRelaxation(DynamicRelaxation),
}

/// `Verlet` sublist.
#[derive(Debug, Clone, PartialEq)]
pub struct Verlet {
    /// `Fixed dt` (> 0) — overrides the computed stable time step; default none.
    pub fixed_dt: Option<f64>,
    /// `Safety Factor` (> 0) — multiplies the time step (also a fixed one); default 1.0.
    pub safety_factor: f64,
}

/// How a quasi-static run is divided into load steps.
#[derive(Debug, Clone, PartialEq)]
pub enum LoadSteps {
    /// `Number of Load Steps` (≥ 1): equal increments from initial to final time.
    Count(u64),
    /// `Time Steps`: an increasing list of times (whitespace-separated in the deck).
    Times(Vec<f64>),
}

/// `QuasiStatic` sublist.
#[derive(Debug, Clone, PartialEq)]
pub struct QuasiStatic {
    /// `Number of Load Steps` or `Time Steps` (exactly one, required).
    pub load_steps: LoadSteps,
    /// `Maximum Solver Iterations` — Newton iterations per load step; default 10.
    pub maximum_solver_iterations: u64,
    /// `Relative Tolerance` — criterion `tol·‖reaction‖₂`; default 1e-6.
    pub relative_tolerance: f64,
    /// `Absolute Tolerance` — if present, used instead of the relative one.
    pub absolute_tolerance: Option<f64>,
    /// `Damped Newton Diagonal Scale Factor` — default 1.0001.
    pub damped_newton_diagonal_scale_factor: f64,
    /// `Damped Newton Diagonal Shift Factor` — default 1e-5.
    pub damped_newton_diagonal_shift_factor: f64,
    /// `Belos *` keys.
    pub belos: BelosSettings,
    /// `Adaptive Load-Stepping` — cut load steps that do not converge; default off.
    pub adaptive_load_stepping: Option<AdaptiveLoadStepping>,
}

/// `QuasiStatic → Adaptive Load-Stepping`.
#[derive(Debug, Clone, PartialEq)]
pub struct AdaptiveLoadStepping {
    /// `Maximum load step reductions in one step` (≥ 0).
    pub max_reductions_in_one_step: Option<u64>,
    /// `Maximum total load step reductions` (≥ 0).
    pub max_total_reductions: Option<u64>,
    /// `Reduce all remaining load steps` — default false.
    pub reduce_all_remaining_load_steps: bool,
    /// `Adaptive output frequency` — default false.
    pub adaptive_output_frequency: bool,
    /// `Switch to Verlet` — continue explicitly when cutting fails.
    pub switch_to_verlet: Option<SwitchToVerlet>,
    /// `Switch to Dynamic Relaxation` (peridyn's) — relax a step Newton fails on when cutting
    /// fails, then go on with Newton.
    pub switch_to_dynamic_relaxation: Option<SwitchToDynamicRelaxation>,
    /// `Maximum fraction of bonds broken in one step` (peridyn's; 0 < f ≤ 1) — cut a step that
    /// breaks more than this fraction of the directed bonds; default none.
    pub max_broken_fraction: Option<f64>,
}

/// `Adaptive Load-Stepping → Switch to Dynamic Relaxation`.
#[derive(Debug, Clone, PartialEq)]
pub struct SwitchToDynamicRelaxation {
    /// `Maximum Solver Iterations` (≥ 1) — relaxation iterations for the step; default
    /// 100,000.
    pub maximum_solver_iterations: u64,
}

/// `DynamicRelaxation` sublist (peridyn's).
#[derive(Debug, Clone, PartialEq)]
pub struct DynamicRelaxation {
    /// `Number of Load Steps` or `Time Steps` (exactly one, required).
    pub load_steps: LoadSteps,
    /// `Maximum Solver Iterations` — relaxation iterations per load step; default 100,000.
    pub maximum_solver_iterations: u64,
    /// `Relative Tolerance` — criterion `tol·‖reaction‖₂`, as `QuasiStatic`; default 1e-6.
    pub relative_tolerance: f64,
    /// `Absolute Tolerance` — if present, used instead of the relative one.
    pub absolute_tolerance: Option<f64>,
    /// `Adaptive Load-Stepping` — as `QuasiStatic`'s, without `Switch to Dynamic Relaxation`.
    pub adaptive_load_stepping: Option<AdaptiveLoadStepping>,
}

/// Relaxation iterations per load step when the deck gives none (the value of
/// `crate::solver::relaxation::DEFAULT_MAX_ITERATIONS`, which the deck reader does not import).
const RELAXATION_ITERATIONS: i64 = 100_000;

/// `Adaptive Load-Stepping → Switch to Verlet`.
#[derive(Debug, Clone, PartialEq)]
pub struct SwitchToVerlet {
    /// `Fixed dt` (> 0); default: computed stable step.
    pub fixed_dt: Option<f64>,
    /// `Safety Factor` (> 0); default 1.0.
    pub safety_factor: f64,
    /// `Output Frequency` (≥ 1); default none.
    pub output_frequency: Option<u64>,
}

/// `NOXQuasiStatic` sublist. Peridigm's own keys are typed; every other key is handed to NOX.
#[derive(Debug, Clone, PartialEq)]
pub struct NoxQuasiStatic {
    /// `Number of Load Steps` or `Time Steps` (exactly one, required).
    pub load_steps: LoadSteps,
    /// `Max Solver Iterations` — default 50 (note the spelling differs from QuasiStatic).
    pub max_solver_iterations: u64,
    /// `Relative Tolerance` — default 1e-6.
    pub relative_tolerance: f64,
    /// `Absolute Tolerance` — default none.
    pub absolute_tolerance: Option<f64>,
    /// `Verbose` — default false.
    pub verbose: bool,
    /// `Max Age Of Prec` — preconditioner reuse count; default 200.
    pub max_age_of_prec: u64,
    /// `Preconditioner Reuse Policy` — default none.
    pub preconditioner_reuse_policy: Option<String>,
    /// `Direction → Method` — `Newton` or `NonlinearCG` (required; also left in `nox`).
    pub direction_method: String,
    /// Every other key of the list (NOX parameters: `Nonlinear Solver`, `Direction`,
    /// `Line Search`, `Printing`, ...), in file order.
    pub nox: Vec<(String, ParameterValue)>,
}

/// `Implicit` sublist (Newmark-β).
#[derive(Debug, Clone, PartialEq)]
pub struct Implicit {
    /// `Fixed dt` (required, > 0).
    pub fixed_dt: f64,
    /// `Beta` β — default 0.25.
    pub beta: f64,
    /// `Gamma` γ — default 0.5.
    pub gamma: f64,
    /// `Absolute Tolerance` — default 1e-6.
    pub absolute_tolerance: f64,
    /// `Maximum Solver Iterations` — default 10.
    pub maximum_solver_iterations: u64,
}

/// `ImplicitDiffusion` sublist.
#[derive(Debug, Clone, PartialEq)]
pub struct ImplicitDiffusion {
    /// `Number of Load Steps` or `Time Steps` (exactly one, required).
    pub load_steps: LoadSteps,
    /// `Maximum Solver Iterations` — default 10.
    pub maximum_solver_iterations: u64,
    /// `Relative Tolerance` — default 1e-6.
    pub relative_tolerance: f64,
    /// `Absolute Tolerance` — default none.
    pub absolute_tolerance: Option<f64>,
    /// `Belos *` keys.
    pub belos: BelosSettings,
}

/// Top-level NOX parameter names (never reported as typos).
const NOX_TOP_LEVEL: &[&str] = &[
    "Nonlinear Solver",
    "Direction",
    "Line Search",
    "Printing",
    "Solver Options",
    "Trust Region",
    "Status Tests",
    "Tensor",
    "Thyra Group Options",
    "Inexact Trust Region",
];

/// Peridigm's own keys in `NOXQuasiStatic`.
const NOX_PERIDIGM_KEYS: &[&str] = &[
    "Number of Load Steps",
    "Time Steps",
    "Max Solver Iterations",
    "Relative Tolerance",
    "Absolute Tolerance",
    "Verbose",
    "Max Age Of Prec",
    "Preconditioner Reuse Policy",
];

/// The integrator sublists a solver list may hold.
const INTEGRATORS: &[&str] = &[
    "Verlet",
    "QuasiStatic",
    "NOXQuasiStatic",
    "Implicit",
    "ImplicitDiffusion",
    "DynamicRelaxation",
];

/// The one integrator sublist of a solver list (none or several is an error).
pub(super) fn only_integrator<'t>(
    ctx: &Ctx,
    list: &mut ListReader<'t>,
) -> Result<Field<'t>, DeckError> {
    let mut present: Vec<Field> = INTEGRATORS.iter().filter_map(|k| list.get(k)).collect();
    match present.len() {
        0 => Err(ctx.error(
            Some(list.line),
            &list.path,
            format!(
                "no time integrator; add exactly one of the sublists {}",
                INTEGRATORS.join(", ")
            ),
        )),
        1 => Ok(present.remove(0)),
        _ => {
            let names = present
                .iter()
                .map(|f| f.key())
                .collect::<Vec<_>>()
                .join(", ");
            Err(present[1].err(ctx, format!("a solver list holds exactly one integrator, found {names}; put each in its own Solver list (they run in file order)")))
        }
    }
}

/// An integrator sublist as read, with the solver's final time it implies.
pub(super) struct ReadIntegrator {
    pub(super) integrator: Integrator,
    pub(super) final_time: f64,
    /// The deck gave `Belos Linear Solver` (QuasiStatic only).
    pub(super) belos_given: bool,
}

/// Reads the integrator sublist `field` of the solver list `list`; `final_given` is the list's
/// `Final Time`.
pub(super) fn read_integrator(
    ctx: &mut Ctx,
    list: &ListReader,
    field: &Field,
    final_given: Option<f64>,
) -> Result<ReadIntegrator, DeckError> {
    let mut integ = field.list(ctx)?;
    let mut belos_given = false;
    let (integrator, final_time) = match field.key() {
        "Verlet" => {
            let v = Verlet {
                fixed_dt: integ.positive_opt(ctx, "Fixed dt")?,
                safety_factor: integ.positive_opt(ctx, "Safety Factor")?.unwrap_or(1.0),
            };
            integ.finish(ctx, &[])?;
            (Integrator::Verlet(v), final_given.unwrap_or(1.0))
        }
        "QuasiStatic" => {
            let (q, last, given) = read_quasi_static(ctx, integ)?;
            belos_given = given;
            let final_time = final_time_for_steps(ctx, list, final_given, last)?;
            (Integrator::QuasiStatic(q), final_time)
        }
        "NOXQuasiStatic" => {
            let (n, last) = read_nox_quasi_static(ctx, &mut integ)?;
            let final_time = final_time_for_steps(ctx, list, final_given, last)?;
            (Integrator::NoxQuasiStatic(n), final_time)
        }
        "Implicit" => {
            let i = Implicit {
                fixed_dt: integ.positive_req(ctx, "Fixed dt")?,
                beta: integ.positive_opt(ctx, "Beta")?.unwrap_or(0.25),
                gamma: integ.positive_opt(ctx, "Gamma")?.unwrap_or(0.5),
                absolute_tolerance: integ
                    .positive_opt(ctx, "Absolute Tolerance")?
                    .unwrap_or(1e-6),
                maximum_solver_iterations: integ
                    .int_opt(ctx, "Maximum Solver Iterations", 1)?
                    .unwrap_or(10) as u64,
            };
            integ.finish(ctx, &[])?;
            let Some(final_time) = final_given else {
                return Err(list.missing(
                    ctx,
                    "Final Time",
                    "a number; the Implicit integrator needs it",
                ));
            };
            (Integrator::Implicit(i), final_time)
        }
        "ImplicitDiffusion" => {
            let (load_steps, last) = read_load_steps(ctx, &mut integ)?;
            let d = ImplicitDiffusion {
                load_steps,
                maximum_solver_iterations: integ
                    .int_opt(ctx, "Maximum Solver Iterations", 1)?
                    .unwrap_or(10) as u64,
                relative_tolerance: integ
                    .positive_opt(ctx, "Relative Tolerance")?
                    .unwrap_or(1e-6),
                absolute_tolerance: integ.positive_opt(ctx, "Absolute Tolerance")?,
                belos: read_belos(ctx, &mut integ)?.0,
            };
            integ.finish(ctx, &[])?;
            let final_time = final_time_for_steps(ctx, list, final_given, last)?;
            (Integrator::ImplicitDiffusion(d), final_time)
        }
        "DynamicRelaxation" => {
            let (d, last) = read_dynamic_relaxation(ctx, integ)?;
            let final_time = final_time_for_steps(ctx, list, final_given, last)?;
            (Integrator::DynamicRelaxation(d), final_time)
        }
        _ => unreachable!("only integrator names are looked up"),
    };
    Ok(ReadIntegrator {
        integrator,
        final_time,
        belos_given,
    })
}

/// Reads a `QuasiStatic` sublist; also returns the last listed load-step time and whether
/// `Belos Linear Solver` was given.
fn read_quasi_static(
    ctx: &mut Ctx,
    mut integ: ListReader,
) -> Result<(QuasiStatic, Option<f64>, bool), DeckError> {
    let (load_steps, last) = read_load_steps(ctx, &mut integ)?;
    let adaptive = integ.get("Adaptive Load-Stepping");
    let maximum_solver_iterations = integ
        .int_opt(ctx, "Maximum Solver Iterations", 1)?
        .unwrap_or(10) as u64;
    let relative_tolerance = integ
        .positive_opt(ctx, "Relative Tolerance")?
        .unwrap_or(1e-6);
    let absolute_tolerance = integ.positive_opt(ctx, "Absolute Tolerance")?;
    let damped_newton_diagonal_scale_factor = integ
        .positive_opt(ctx, "Damped Newton Diagonal Scale Factor")?
        .unwrap_or(1.0001);
    let damped_newton_diagonal_shift_factor = integ
        .non_negative_opt(ctx, "Damped Newton Diagonal Shift Factor")?
        .unwrap_or(1e-5);
    let (belos, belos_given) = read_belos(ctx, &mut integ)?;
    let q = QuasiStatic {
        load_steps,
        maximum_solver_iterations,
        relative_tolerance,
        absolute_tolerance,
        damped_newton_diagonal_scale_factor,
        damped_newton_diagonal_shift_factor,
        belos,
        adaptive_load_stepping: adaptive.map(|f| read_adaptive(ctx, &f)).transpose()?,
    };
    integ.finish(ctx, &[])?;
    Ok((q, last, belos_given))
}

/// Reads a `DynamicRelaxation` sublist; also returns the last listed load-step time.
fn read_dynamic_relaxation(
    ctx: &mut Ctx,
    mut integ: ListReader,
) -> Result<(DynamicRelaxation, Option<f64>), DeckError> {
    let (load_steps, last) = read_load_steps(ctx, &mut integ)?;
    let adaptive = integ.get("Adaptive Load-Stepping");
    if let Some(adaptive) = &adaptive {
        if let Some(f) = adaptive.list(ctx)?.peek("Switch to Dynamic Relaxation") {
            return Err(f.err(
                ctx,
                "a DynamicRelaxation list relaxes every step already; remove Switch to Dynamic Relaxation (or use it in a QuasiStatic list)",
            ));
        }
    }
    let d = DynamicRelaxation {
        load_steps,
        maximum_solver_iterations: integ
            .int_opt(ctx, "Maximum Solver Iterations", 1)?
            .unwrap_or(RELAXATION_ITERATIONS) as u64,
        relative_tolerance: integ
            .positive_opt(ctx, "Relative Tolerance")?
            .unwrap_or(1e-6),
        absolute_tolerance: integ.positive_opt(ctx, "Absolute Tolerance")?,
        adaptive_load_stepping: adaptive.map(|f| read_adaptive(ctx, &f)).transpose()?,
    };
    integ.finish(ctx, &[])?;
    Ok((d, last))
}

/// Reads a `NOXQuasiStatic` sublist: Peridigm's own keys typed, every other key kept for NOX;
/// also returns the last listed load-step time.
fn read_nox_quasi_static(
    ctx: &mut Ctx,
    integ: &mut ListReader,
) -> Result<(NoxQuasiStatic, Option<f64>), DeckError> {
    let (load_steps, last) = read_load_steps(ctx, integ)?;
    let direction_method = read_direction_method(ctx, integ)?;
    if let Some(f) = integ.get("Maximum Solver Iterations") {
        return Err(f.err(ctx, "NOXQuasiStatic spells this \"Max Solver Iterations\" (QuasiStatic uses \"Maximum Solver Iterations\")"));
    }
    let max_solver_iterations = integ
        .int_opt(ctx, "Max Solver Iterations", 1)?
        .unwrap_or(50) as u64;
    let relative_tolerance = integ
        .positive_opt(ctx, "Relative Tolerance")?
        .unwrap_or(1e-6);
    let absolute_tolerance = integ.positive_opt(ctx, "Absolute Tolerance")?;
    let verbose = integ.bool_or(ctx, "Verbose", false)?;
    let max_age_of_prec = integ.int_opt(ctx, "Max Age Of Prec", 1)?.unwrap_or(200) as u64;
    let preconditioner_reuse_policy = integ.name_opt(ctx, "Preconditioner Reuse Policy")?;
    // NOX accepts any parameter, so the rest is handed on; but a near miss of one of
    // Peridigm's own keys is almost certainly a typo that would be silently ignored.
    let rest = integ.take_rest();
    for f in &rest {
        if NOX_TOP_LEVEL.contains(&f.key()) {
            continue;
        }
        if let Some(s) = super::reader::suggest(f.key(), NOX_PERIDIGM_KEYS.iter().copied()) {
            return Err(f.err(ctx, format!("unknown key; did you mean \"{s}\"?")));
        }
    }
    let n = NoxQuasiStatic {
        load_steps,
        max_solver_iterations,
        relative_tolerance,
        absolute_tolerance,
        verbose,
        max_age_of_prec,
        preconditioner_reuse_policy,
        direction_method,
        nox: rest
            .into_iter()
            .map(|f| (f.key().to_string(), to_parameter_value(f.entry)))
            .collect(),
    };
    Ok((n, last))
}

/// `NOXQuasiStatic → Direction → Method`, read in place: the `Direction` list itself stays
/// in the list for NOX.
fn read_direction_method(ctx: &mut Ctx, integ: &mut ListReader) -> Result<String, DeckError> {
    let direction = integ.peek("Direction");
    let method = direction
        .as_ref()
        .and_then(|d| d.node().as_list())
        .and_then(|entries| entries.iter().find(|e| e.key == "Method"));
    match (&direction, method) {
        (None, _) => Err(integ.missing(
            ctx,
            "Direction",
            "a list with Method: \"Newton\" or \"NonlinearCG\"",
        )),
        (Some(d), None) => {
            let d = d.list(ctx)?;
            Err(d.missing(ctx, "Method", "\"Newton\" or \"NonlinearCG\""))
        }
        (Some(d), Some(entry)) => {
            let mut path = d.path.clone();
            path.push("Method".into());
            let f = Field { entry, path };
            Ok(f.choice(ctx, &["Newton", "NonlinearCG"])?.to_string())
        }
    }
}

/// Reads `Number of Load Steps` / `Time Steps`; returns the steps and the last listed time.
fn read_load_steps(
    ctx: &Ctx,
    list: &mut ListReader,
) -> Result<(LoadSteps, Option<f64>), DeckError> {
    let count = list.get("Number of Load Steps");
    let times = list.get("Time Steps");
    match (count, times) {
        (Some(_), Some(t)) => Err(t.err(
            ctx,
            "give either \"Number of Load Steps\" or \"Time Steps\", not both",
        )),
        (None, None) => Err(list.missing(
            ctx,
            "Number of Load Steps",
            "an integer ≥ 1; or a \"Time Steps\" list",
        )),
        (Some(c), None) => Ok((LoadSteps::Count(c.int_at_least(ctx, 1)? as u64), None)),
        (None, Some(t)) => {
            let text = t.string(ctx)?;
            let mut values = Vec::new();
            for token in text.split_whitespace() {
                let ok =
                    super::tree::is_float_literal(token) || super::tree::is_integer_literal(token);
                match token.parse::<f64>() {
                    Ok(v) if ok => values.push(v),
                    _ => {
                        return Err(t.err(
                            ctx,
                            format!(
                            "\"{token}\" is not a number; Time Steps is a list of increasing times"
                        ),
                        ))
                    }
                }
            }
            if values.len() < 2 {
                return Err(t.err(
                    ctx,
                    "Time Steps needs at least two times (the start and one step)",
                ));
            }
            if let Some(w) = values.windows(2).find(|w| w[1] <= w[0]) {
                return Err(t.err(
                    ctx,
                    format!(
                        "Time Steps must increase strictly; {} is followed by {}",
                        w[0], w[1]
                    ),
                ));
            }
            let last = values.last().copied();
            Ok((LoadSteps::Times(values), last))
        }
    }
}

fn read_adaptive(ctx: &mut Ctx, field: &Field) -> Result<AdaptiveLoadStepping, DeckError> {
    let mut list = field.list(ctx)?;
    let switch_to_verlet = match list.list_opt(ctx, "Switch to Verlet")? {
        None => None,
        Some(mut s) => {
            let v = SwitchToVerlet {
                fixed_dt: s.positive_opt(ctx, "Fixed dt")?,
                safety_factor: s.positive_opt(ctx, "Safety Factor")?.unwrap_or(1.0),
                output_frequency: s.int_opt(ctx, "Output Frequency", 1)?.map(|v| v as u64),
            };
            s.finish(ctx, &[])?;
            Some(v)
        }
    };
    let switch_to_dynamic_relaxation = match list.list_opt(ctx, "Switch to Dynamic Relaxation")? {
        None => None,
        Some(mut s) => {
            let iterations = s.int_opt(ctx, "Maximum Solver Iterations", 1)?;
            s.finish(ctx, &[])?;
            Some(SwitchToDynamicRelaxation {
                maximum_solver_iterations: iterations.unwrap_or(RELAXATION_ITERATIONS) as u64,
            })
        }
    };
    if let (Some(_), Some(_)) = (&switch_to_verlet, &switch_to_dynamic_relaxation) {
        let message = "give either Switch to Verlet or Switch to Dynamic Relaxation: a failed step goes to one of them";
        return Err(list
            .peek("Switch to Dynamic Relaxation")
            .map_or_else(|| field.err(ctx, message), |f| f.err(ctx, message)));
    }
    let max_broken_fraction = match list.get("Maximum fraction of bonds broken in one step") {
        None => None,
        Some(f) => match f.positive(ctx)? {
            fraction if fraction <= 1.0 => Some(fraction),
            _ => return Err(f.err(ctx, "a fraction of the bonds: a number in (0, 1]")),
        },
    };
    let out = AdaptiveLoadStepping {
        max_reductions_in_one_step: list
            .int_opt(ctx, "Maximum load step reductions in one step", 0)?
            .map(|v| v as u64),
        max_total_reductions: list
            .int_opt(ctx, "Maximum total load step reductions", 0)?
            .map(|v| v as u64),
        reduce_all_remaining_load_steps: list.bool_or(
            ctx,
            "Reduce all remaining load steps",
            false,
        )?,
        adaptive_output_frequency: list.bool_or(ctx, "Adaptive output frequency", false)?,
        switch_to_verlet,
        switch_to_dynamic_relaxation,
        max_broken_fraction,
    };
    list.finish(ctx, &[])?;
    Ok(out)
}

fn final_time_for_steps(
    ctx: &Ctx,
    list: &ListReader,
    given: Option<f64>,
    last_listed: Option<f64>,
) -> Result<f64, DeckError> {
    match (given, last_listed) {
        (Some(t), _) => Ok(t),
        (None, Some(t)) => Ok(t),
        (None, None) => Err(list.missing(
            ctx,
            "Final Time",
            "a number; load steps divide the time from Initial Time to Final Time",
        )),
    }
}

impl Integrator {
    /// The integrator sublist name, as written in decks.
    pub fn deck_name(&self) -> &'static str {
        match self {
            Integrator::Verlet(_) => "Verlet",
            Integrator::QuasiStatic(_) => "QuasiStatic",
            Integrator::NoxQuasiStatic(_) => "NOXQuasiStatic",
            Integrator::Implicit(_) => "Implicit",
            Integrator::ImplicitDiffusion(_) => "ImplicitDiffusion",
            Integrator::DynamicRelaxation(_) => "DynamicRelaxation",
        }
    }

    /// True for the solvers that need a tangent stiffness matrix (what the deck-level rules
    /// ask before the integrators are built: `--backend` moves only these lists).
    pub fn is_implicit(&self) -> bool {
        match self {
            Integrator::Verlet(_) => false,
            Integrator::QuasiStatic(_)
            | Integrator::NoxQuasiStatic(_)
            | Integrator::Implicit(_)
            | Integrator::ImplicitDiffusion(_)
            | Integrator::DynamicRelaxation(_) => true,
        }
    }
}
