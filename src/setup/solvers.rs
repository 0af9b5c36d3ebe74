//! The one factory of integrators: a deck's solver lists as [`SolverList`]s, each with its
//! integrator and typed parameters ([`crate::solver::integrator`]). The solvers and backends
//! read these, never the deck's types; the driver runs them in deck order.
//!
//! Adding an integrator: its deck sublist is read in `crate::io::deck` (a variant of
//! [`deck::Integrator`]), and one arm of [`integrator`] builds it here.

use crate::backend::parameters::ParameterValue;
use crate::backend::settings::{
    AlgebraicPreconditioner, ImplicitSolve, LinearBackend, LinearMethod, LinearPreconditioner,
    LinearSolve, Nonlinear, NonlinearMethod, NoxParameters, PeridigmPreconditioner,
    PetscPreconditioner,
};
use crate::backend::Unsupported;
use crate::io::deck::{self, Deck};
use crate::solver::dynamic_relaxation::DynamicRelaxation;
use crate::solver::implicit_dynamics::Newmark;
use crate::solver::integrator::{HandOff, Integrator, ListSettings, SolverList, Unavailable};
use crate::solver::load_stepped::{planned_load_steps, QuasiStatic};
use crate::solver::newton::ConvergenceMeasure;
use crate::solver::quasistatic::{AdaptiveLoadStepping, LoadSteps};
use crate::solver::relaxation::AdaptiveRelaxation;
use crate::solver::verlet::Verlet;

/// The solver lists of `deck`, in the order they run.
pub fn solver_lists(deck: &Deck) -> Vec<SolverList> {
    deck.solvers
        .iter()
        .enumerate()
        .map(|(index, list)| solver_list(list, index > 0))
        .collect()
}

/// Refuses, before any message is sent, a solver list of `deck` that this build cannot run on
/// `ranks` ranks ([`Integrator::check_ranks`]: implicit lists need the Trilinos or PETSc
/// backend, whose distributed solves run over the owned unknowns).
pub fn check_ranks(deck: &Deck, ranks: usize) -> Result<(), Unsupported> {
    for list in solver_lists(deck) {
        list.integrator.check_ranks(&list.settings.name, ranks)?;
    }
    Ok(())
}

/// The solver list `list` of a deck; `after_another` when a list runs before it.
pub fn solver_list(list: &deck::Solver, after_another: bool) -> SolverList {
    SolverList {
        settings: ListSettings {
            name: list.name.clone(),
            initial_time: list.initial_time,
            final_time: list.final_time,
            verbose: list.verbose,
            heuristics: !list.disable_heuristics,
            predict_first_step: after_another && list.initialize_predictor_from_previous_solver,
        },
        integrator: integrator(list),
    }
}

/// The integrator of the deck's solver list `list`, with its typed parameters.
pub fn integrator(list: &deck::Solver) -> Box<dyn Integrator> {
    match &list.integrator {
        deck::Integrator::Verlet(verlet) => Box::new(self::verlet(verlet)),
        deck::Integrator::QuasiStatic(q) => Box::new(quasi_static(list, q)),
        deck::Integrator::NoxQuasiStatic(nox) => Box::new(nox_quasi_static(list, nox)),
        deck::Integrator::Implicit(implicit) => Box::new(newmark(list, implicit)),
        deck::Integrator::DynamicRelaxation(relaxation) => Box::new(dynamic_relaxation(relaxation)),
        deck::Integrator::ImplicitDiffusion(diffusion) => Box::new(Unavailable {
            name: "ImplicitDiffusion",
            implicit: true,
            planned_steps: Some(planned_load_steps(&load_steps(&diffusion.load_steps))),
        }),
    }
}

fn verlet(verlet: &deck::Verlet) -> Verlet {
    Verlet {
        fixed_dt: verlet.fixed_dt,
        safety_factor: verlet.safety_factor,
    }
}

fn quasi_static(list: &deck::Solver, q: &deck::QuasiStatic) -> QuasiStatic {
    let adaptive = q.adaptive_load_stepping.as_ref();
    QuasiStatic {
        name: "QuasiStatic",
        load_steps: load_steps(&q.load_steps),
        max_iterations: q.maximum_solver_iterations,
        relative_tolerance: q.relative_tolerance,
        absolute_tolerance: q.absolute_tolerance,
        measure: ConvergenceMeasure::PeridigmQuasiStatic,
        adaptive: adaptive.map(adaptive_load_stepping),
        hand_off: adaptive.and_then(switch_to_verlet),
        relaxation: adaptive
            .and_then(|a| a.switch_to_dynamic_relaxation.as_ref())
            .map(|switch| AdaptiveRelaxation {
                max_iterations: Some(switch.maximum_solver_iterations),
            }),
        solve: implicit_solve(
            list,
            "QuasiStatic",
            Nonlinear::Newton { quasi_static: true },
        ),
    }
}

fn dynamic_relaxation(relaxation: &deck::DynamicRelaxation) -> DynamicRelaxation {
    let adaptive = relaxation.adaptive_load_stepping.as_ref();
    DynamicRelaxation {
        load_steps: load_steps(&relaxation.load_steps),
        max_iterations: relaxation.maximum_solver_iterations,
        relative_tolerance: relaxation.relative_tolerance,
        absolute_tolerance: relaxation.absolute_tolerance,
        adaptive: adaptive.map(adaptive_load_stepping),
        hand_off: adaptive.and_then(switch_to_verlet),
    }
}

fn adaptive_load_stepping(adaptive: &deck::AdaptiveLoadStepping) -> AdaptiveLoadStepping {
    AdaptiveLoadStepping {
        max_reductions_in_one_step: adaptive.max_reductions_in_one_step,
        max_total_reductions: adaptive.max_total_reductions,
        reduce_all_remaining_load_steps: adaptive.reduce_all_remaining_load_steps,
        max_broken_fraction: adaptive.max_broken_fraction,
    }
}

/// `Switch to Verlet` of `Adaptive Load-Stepping`: the explicit list a failed step hands the
/// rest of the list to.
fn switch_to_verlet(adaptive: &deck::AdaptiveLoadStepping) -> Option<HandOff> {
    adaptive.switch_to_verlet.as_ref().map(|switch| HandOff {
        label: "Switch to Verlet",
        integrator: Box::new(Verlet {
            fixed_dt: switch.fixed_dt,
            safety_factor: switch.safety_factor,
        }),
    })
}

fn nox_quasi_static(list: &deck::Solver, nox: &deck::NoxQuasiStatic) -> QuasiStatic {
    let parameters = NoxParameters {
        direction_method: nox.direction_method.clone(),
        max_age_of_prec: nox.max_age_of_prec,
        verbose: nox.verbose,
        nox: parameter_tree(&nox.nox),
    };
    QuasiStatic {
        name: "NOXQuasiStatic",
        load_steps: load_steps(&nox.load_steps),
        max_iterations: nox.max_solver_iterations,
        relative_tolerance: nox.relative_tolerance,
        absolute_tolerance: nox.absolute_tolerance,
        measure: ConvergenceMeasure::TwoNorm,
        adaptive: None,
        hand_off: None,
        relaxation: None,
        solve: implicit_solve(list, "NOXQuasiStatic", Nonlinear::Nox(parameters)),
    }
}

fn newmark(list: &deck::Solver, implicit: &deck::Implicit) -> Newmark {
    Newmark {
        fixed_dt: implicit.fixed_dt,
        beta: implicit.beta,
        gamma: implicit.gamma,
        absolute_tolerance: implicit.absolute_tolerance,
        max_iterations: implicit.maximum_solver_iterations,
        solve: implicit_solve(
            list,
            "Implicit",
            Nonlinear::Newton {
                quasi_static: false,
            },
        ),
    }
}

fn load_steps(steps: &deck::LoadSteps) -> LoadSteps {
    match steps {
        deck::LoadSteps::Count(n) => LoadSteps::Count(*n),
        deck::LoadSteps::Times(times) => LoadSteps::Times(times.clone()),
    }
}

/// How the implicit list `list` (integrator `integrator`) solves, with the nonlinear
/// iteration `nonlinear`.
fn implicit_solve(
    list: &deck::Solver,
    integrator: &'static str,
    nonlinear: Nonlinear,
) -> ImplicitSolve {
    ImplicitSolve {
        list: list.name.clone(),
        integrator,
        nonlinear,
        linear: linear_solve(&list.linear_solve),
        peridigm_preconditioner: match list.peridigm_preconditioner {
            deck::PeridigmPreconditioner::FullTangent => PeridigmPreconditioner::FullTangent,
            deck::PeridigmPreconditioner::Block3x3 => PeridigmPreconditioner::Block3x3,
            deck::PeridigmPreconditioner::None => PeridigmPreconditioner::None,
            deck::PeridigmPreconditioner::Amg => PeridigmPreconditioner::Amg,
        },
        line_search: !list.disable_heuristics,
        verbose: list.verbose,
    }
}

/// The deck's linear-solver keys as the backends' settings.
fn linear_solve(linear: &deck::LinearSolve) -> LinearSolve {
    LinearSolve {
        backend: linear_backend(linear.backend),
        backend_given: linear.backend_given,
        method: match linear.method {
            deck::LinearMethod::Automatic => LinearMethod::Automatic,
            deck::LinearMethod::Direct => LinearMethod::Direct,
            deck::LinearMethod::Cholesky => LinearMethod::Cholesky,
            deck::LinearMethod::Lu => LinearMethod::Lu,
            deck::LinearMethod::Cg => LinearMethod::Cg,
            deck::LinearMethod::Gmres => LinearMethod::Gmres,
        },
        preconditioner: match linear.preconditioner {
            deck::LinearPreconditioner::Block3x3 => LinearPreconditioner::Block3x3,
            deck::LinearPreconditioner::Jacobi => LinearPreconditioner::Jacobi,
            deck::LinearPreconditioner::None => LinearPreconditioner::None,
            deck::LinearPreconditioner::Amg => LinearPreconditioner::Amg,
        },
        preconditioner_given: linear.preconditioner_given,
        relative_tolerance: linear.relative_tolerance,
        maximum_iterations: linear.maximum_iterations,
        belos_parameters: parameter_tree(&linear.belos_parameters),
        petsc_options: linear.petsc_options.clone(),
        nonlinear_method: match linear.nonlinear_method {
            deck::NonlinearMethod::Newton => NonlinearMethod::Newton,
            deck::NonlinearMethod::Snes => NonlinearMethod::Snes,
        },
    }
}

fn linear_backend(backend: deck::LinearBackend) -> LinearBackend {
    match backend {
        deck::LinearBackend::Native => LinearBackend::Native,
        deck::LinearBackend::Trilinos {
            preconditioner,
            ilu_fill_level,
        } => LinearBackend::Trilinos {
            preconditioner: match preconditioner {
                deck::AlgebraicPreconditioner::None => AlgebraicPreconditioner::None,
                deck::AlgebraicPreconditioner::Jacobi => AlgebraicPreconditioner::Jacobi,
                deck::AlgebraicPreconditioner::Ilu => AlgebraicPreconditioner::Ilu,
                deck::AlgebraicPreconditioner::Ml => AlgebraicPreconditioner::Ml,
            },
            ilu_fill_level,
        },
        deck::LinearBackend::Petsc {
            preconditioner,
            ilu_fill_level,
        } => LinearBackend::Petsc {
            preconditioner: match preconditioner {
                deck::PetscPreconditioner::None => PetscPreconditioner::None,
                deck::PetscPreconditioner::Jacobi => PetscPreconditioner::Jacobi,
                deck::PetscPreconditioner::Ilu => PetscPreconditioner::Ilu,
                deck::PetscPreconditioner::Gamg => PetscPreconditioner::Gamg,
                deck::PetscPreconditioner::Hypre => PetscPreconditioner::Hypre,
            },
            ilu_fill_level,
        },
    }
}

/// A deck parameter tree (NOX's list, the `Belos` sublist) as the backends take it.
fn parameter_tree(tree: &[(String, deck::ParameterValue)]) -> Vec<(String, ParameterValue)> {
    tree.iter()
        .map(|(name, value)| (name.clone(), parameter(value)))
        .collect()
}

fn parameter(value: &deck::ParameterValue) -> ParameterValue {
    match value {
        deck::ParameterValue::List(children) => ParameterValue::List(parameter_tree(children)),
        deck::ParameterValue::String(s) => ParameterValue::String(s.clone()),
        deck::ParameterValue::Int(i) => ParameterValue::Int(*i),
        deck::ParameterValue::Double(d) => ParameterValue::Double(*d),
        deck::ParameterValue::Bool(b) => ParameterValue::Bool(*b),
    }
}

/// The deck of the YAML text `text`, for the tests of the modules below `setup` that need a
/// whole body (the solvers and backends read no deck types).
#[cfg(test)]
pub(crate) fn deck_from_yaml(text: &str) -> Deck {
    deck::parse_str(
        text,
        deck::DeckFormat::Yaml,
        std::path::Path::new("test.yaml"),
    )
    .expect("deck")
}

/// How the first solver list of the YAML deck `text` solves (it must be implicit), for the
/// tests of the solvers that read it.
#[cfg(all(test, feature = "trilinos"))]
pub(crate) fn first_implicit_solve(text: &str) -> ImplicitSolve {
    let deck = deck_from_yaml(text);
    let list = solver_list(&deck.solvers[0], false);
    list.integrator.solve().expect("an implicit list").clone()
}

#[cfg(test)]
mod tests;
