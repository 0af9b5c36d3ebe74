//! Adaptive dynamic relaxation (Kilic & Madenci 2010, "An adaptive dynamic relaxation method
//! for quasi-static simulations using the peridynamic theory", Theor. Appl. Fract. Mech. 53):
//! one load step relaxed to equilibrium by a damped pseudo-dynamics whose fictitious mass makes a unit time step
//! stable, instead of by Newton's method. It needs no linear solve, so it goes on where
//! Newton stalls: a stiffness made singular or indefinite by a growing crack, loose
//! fragments, softening.
//!
//! With unknowns u (the free dofs), force f(u) = −F(u) (N, F the residual of
//! [`crate::backend::problem`]) and Δt = 1, iteration n of one load step is
//!
//! ```text
//! λᵢ        = s · ¼ Σⱼ |Kᵢⱼ|,  s = 1.25                          (fictitious density, N/m)
//! v^{1/2}   = f⁰ / (2λ)                                          (from rest)
//! v^{n+½}   = ((2 − cⁿ) v^{n−½} + 2 fⁿ/λ) / (2 + cⁿ)
//! u^{n+1}   = uⁿ + v^{n+½}
//! cⁿ        = 2 √(uⁿᵀ ¹Kⁿ uⁿ / uⁿᵀ uⁿ),  ¹Kᵢᵢⁿ = −(fᵢⁿ − fᵢⁿ⁻¹) / (λᵢ v_i^{n−½})
//! ```
//!
//! K is the tangent stiffness over the free dofs at the start of the step; it is assembled
//! once per load step and only its row sums are kept. Kilic & Madenci's density ¼Σⱼ|Kᵢⱼ|
//! (their eq. 20, a Gershgorin bound) puts the stiffest mode at the central difference's
//! limit ω_max Δt = 2, where it neither grows nor decays: on a chain of 40 equal springs
//! loaded at its end the relaxation stalled at 16 % of the load after 10⁵ iterations. The
//! margin s = [`DENSITY_MARGIN`] damps that mode; the same chain converges to 10⁻¹¹ of the
//! load in 735 iterations. Bonds that break as the body
//! relaxes soften it, which the bound still covers. cⁿ is the damping of the lowest mode
//! estimated by the Rayleigh quotient of the local diagonal stiffness ¹K (eq. 23–24); it is 0
//! when the quotient is not positive and at most 2 (a larger c only slows the relaxation).
//! Unknowns with no stiffness (λᵢ = 0: a point with no intact bond) do not move.
//!
//! The damage follows every iterate as in Newton's iterations
//! ([`crate::solver::implicit::ImplicitSystem`]): bonds are evaluated from the committed
//! damage of the step's start at each iterate, so the accepted state's damage is the
//! relaxed state's. The step converges when the list's convergence measure reaches the tolerance.
//! [`super::dynamic_relaxation`] load-steps it; `QuasiStatic` hands it a load step Newton
//! failed on (`Switch to Dynamic Relaxation`, [`super::quasistatic`]). On several ranks the sums are collectives of the
//! problem and the ghosts are refreshed before every force evaluation.

use super::newton::{NewtonReport, NewtonSettings, NonlinearSolver};
use super::problem::{Origin, Physical, PhysicsProblem};
use crate::backend::problem::{agree_over, Evaluation, NonlinearProblem};
use crate::backend::SolveError;
use std::time::Instant;

/// Default `Maximum Solver Iterations` of a `DynamicRelaxation` list and of `Switch to
/// Dynamic Relaxation`: relaxation iterations (force evaluations) per load step. The
/// iterations a step needs grow with the body's lowest period in unit steps, about the
/// number of points along its longest dimension times a small factor.
pub const DEFAULT_MAX_ITERATIONS: u64 = 100_000;

/// s of the module docs: the fictitious density is this × Kilic & Madenci's ¼Σⱼ|Kᵢⱼ|, so
/// the stiffest mode sits at ω_max Δt ≤ 2/√s and is damped.
pub const DENSITY_MARGIN: f64 = 1.25;

/// How often (iterations) a `Verbose` list logs the relaxation's residual.
const LOG_EVERY: usize = 1000;

/// Adaptive dynamic relaxation of one load step (the module docs) as a [`NonlinearSolver`]:
/// the solver of `DynamicRelaxation` lists, and the one a `QuasiStatic` list hands a step to
/// when Newton fails on it (`Switch to Dynamic Relaxation`).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct AdaptiveRelaxation {
    /// Iterations per load step when they differ from the list's own limit (the hand-off's
    /// `Maximum Solver Iterations`); `None`: the list's.
    pub max_iterations: Option<u64>,
}

impl NonlinearSolver for AdaptiveRelaxation {
    fn describe(&self) -> String {
        "adaptive dynamic relaxation (Kilic & Madenci 2010), no linear solver".into()
    }

    /// It logs its own summary line after the step.
    fn logs_after_each_iteration(&self) -> bool {
        true
    }

    fn solve(
        &mut self,
        parts: Physical<'_>,
        settings: &NewtonSettings,
    ) -> Result<NewtonReport, SolveError> {
        let settings = NewtonSettings {
            max_iterations: self.max_iterations.unwrap_or(settings.max_iterations),
            ..*settings
        };
        let mut problem = PhysicsProblem::new(parts, settings.measure, Origin::Displacement);
        let mut report = relax(&mut problem, &settings)?;
        report.residual_evaluations = problem.residual_evaluations();
        report.broken_bonds = problem.broken_bonds();
        Ok(report)
    }
}

/// Relaxes `problem` from its current unknowns until its convergence measure is at most
/// `settings.tolerance` or `settings.max_iterations` iterations were taken (the module docs'
/// iteration); on return the problem is at the last iterate. The report counts the
/// iterations as [`NewtonReport::relaxation_iterations`] (no Newton iteration, no linear
/// solve) and keeps the first and the last measure as its residual history.
pub fn relax(
    problem: &mut dyn NonlinearProblem,
    settings: &NewtonSettings,
) -> Result<NewtonReport, SolveError> {
    let start = Instant::now();
    let n = problem.len();
    let mut u = vec![0.0; n];
    problem.unknowns(&mut u);
    let density = fictitious_density(problem, &u)?;
    let mut residual = vec![0.0; n];
    problem.residual(&u, &mut residual, Evaluation::Iterate)?;
    let first = problem.convergence_measure(&residual);
    let mut measure = first;
    let mut velocity = vec![0.0; n];
    let mut previous = vec![0.0; n];
    let mut damping: Option<f64> = None;
    let mut scratch = vec![0.0; n];
    let mut iterations = 0usize;
    while measure > settings.tolerance && (iterations as u64) < settings.max_iterations {
        advance(&mut u, &mut velocity, &residual, &density, damping);
        std::mem::swap(&mut previous, &mut residual);
        problem.residual(&u, &mut residual, Evaluation::Iterate)?;
        iterations += 1;
        measure = problem.convergence_measure(&residual);
        let forces = [&residual[..], &previous[..]];
        damping = Some(rayleigh_damping(
            problem,
            (&u, &velocity),
            forces,
            &density,
            &mut scratch,
        ));
        if settings.verbose && iterations % LOG_EVERY == 0 {
            eprintln!("  relaxation iteration {iterations}: residual = {measure:e}");
        }
    }
    if settings.print_iterations {
        eprintln!("  dynamic relaxation: {iterations} iterations, residual = {measure:e}");
    }
    Ok(NewtonReport {
        converged: measure <= settings.tolerance,
        relaxation_iterations: iterations,
        residual_history: vec![first, measure],
        seconds: start.elapsed().as_secs_f64(),
        tangent_bytes: problem.jacobian_bytes(),
        linear_method: "dynamic relaxation".into(),
        ..NewtonReport::default()
    })
}

/// λᵢ = s·¼ Σⱼ |Kᵢⱼ| of the tangent at `u` over this rank's unknowns (N/m), the density that
/// makes a unit step stable with the margin s = [`DENSITY_MARGIN`] (Kilic & Madenci 2010,
/// eq. 20).
fn fictitious_density(
    problem: &mut dyn NonlinearProblem,
    u: &[f64],
) -> Result<Vec<f64>, SolveError> {
    let stiffness = problem.jacobian(u)?;
    let density: Vec<f64> = (0..stiffness.nrows)
        .map(|row| {
            let entries = stiffness.offsets[row]..stiffness.offsets[row + 1];
            DENSITY_MARGIN
                * 0.25
                * stiffness.values[entries]
                    .iter()
                    .map(|k| k.abs())
                    .sum::<f64>()
        })
        .collect();
    let bad = density
        .iter()
        .position(|d| !d.is_finite())
        .map(|row| SolveError::NonFinite {
            what: format!("the tangent's row sum at unknown {row} (dynamic relaxation's density)"),
        });
    agree_over(problem, bad.map_or(Ok(density), Err))
}

/// One step of the module docs' iteration: v^{n+½} from v^{n−½} (`damping` cⁿ, `None` for the
/// first step from rest) and the force fⁿ = −`residual`, then u^{n+1} = uⁿ + v^{n+½}.
fn advance(
    u: &mut [f64],
    velocity: &mut [f64],
    residual: &[f64],
    density: &[f64],
    damping: Option<f64>,
) {
    for (((u, v), &r), &lambda) in u.iter_mut().zip(velocity).zip(residual).zip(density) {
        if lambda <= 0.0 {
            continue;
        }
        let force = -r;
        *v = match damping {
            None => force / (2.0 * lambda),
            Some(c) => ((2.0 - c) * *v + 2.0 * force / lambda) / (2.0 + c),
        };
        *u += *v;
    }
}

/// cⁿ = 2√(uᵀ¹Ku / uᵀu) clamped to [0, 2], with ¹Kᵢᵢ = −(fᵢⁿ − fᵢⁿ⁻¹)/(λᵢ vᵢ) from
/// `(u, v)`, the forces f = −`residual` at uⁿ and f = −`previous` at uⁿ⁻¹ (`[residual,
/// previous]`) and the density; `scratch` (one value per unknown) holds ¹K u (collective: two
/// sums).
fn rayleigh_damping(
    problem: &mut dyn NonlinearProblem,
    (u, velocity): (&[f64], &[f64]),
    [residual, previous]: [&[f64]; 2],
    density: &[f64],
    scratch: &mut [f64],
) -> f64 {
    for (i, k_u) in scratch.iter_mut().enumerate() {
        let (v, lambda) = (velocity[i], density[i]);
        // f = −residual, so −(fⁿ − fⁿ⁻¹) = residualⁿ − residualⁿ⁻¹.
        *k_u = if v == 0.0 || lambda <= 0.0 {
            0.0
        } else {
            (residual[i] - previous[i]) / (lambda * v) * u[i]
        };
    }
    let numerator = problem.dot(u, scratch);
    let denominator = problem.dot(u, u);
    if numerator > 0.0 && denominator > 0.0 {
        (2.0 * (numerator / denominator).sqrt()).min(2.0)
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests;
