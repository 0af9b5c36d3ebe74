//! Newton's method on an [`ImplicitSystem`] with a backtracking line search; the iteration
//! shared by quasi-statics (QuasiStatic, NOXQuasiStatic) and Newmark-β.
//!
//! Each iteration solves `K Δ = r` (K = −∂r/∂u over the unknowns, assembled or matrix-free)
//! and moves to `u + αΔ`. The line search is a real one: α = 1 first, then quadratic
//! interpolation of g(α) = ‖r(u + αΔ)‖² from g(0), g'(0) = −2‖r‖² (exact for a Newton
//! direction) and the last trial, kept within [0.1, 0.5] of the previous α, until the Armijo
//! condition g(α) ≤ (1 − 2·10⁻⁴α) g(0) holds — at most [`MAX_BACKTRACKS`] extra residuals
//! where Peridigm's scan may spend sixty.

use crate::backend::native::{
    cg_matrix_free, gmres_matrix_free, KrylovSettings, NativeLinearSolver, NativeMethod,
};
use crate::backend::problem::{Evaluation, NonlinearProblem};
use crate::backend::settings::LinearPreconditioner;
use crate::backend::{Csr, KrylovReport, LinearResult, LinearSolver, RankRows, SolveError};
use crate::solver::jfnk;
pub use crate::solver::measure::{norm2, ConvergenceMeasure};
use crate::solver::multigrid::{MultigridCache, PreconditionerReport};
use crate::solver::problem::{Origin, Physical, PhysicsProblem};
use std::time::Instant;

/// Backtracking steps of the line search after the full step.
pub const MAX_BACKTRACKS: usize = 8;

/// Sufficient-decrease constant of the Armijo condition.
const ARMIJO: f64 = 1e-4;

/// Newton settings of one solve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NewtonSettings {
    /// Linear solves allowed.
    pub max_iterations: u64,
    /// Converged when the measure is ≤ this.
    pub tolerance: f64,
    /// What is compared with the tolerance.
    pub measure: ConvergenceMeasure,
    /// Backtracking line search (off: always the full step, `Disable Heuristics`).
    pub line_search: bool,
    /// Print `  iteration i: residual = …` at the top of every iteration (Peridigm's log).
    pub print_iterations: bool,
    /// Also print each linear solve (method, iterations, relative residual).
    pub verbose: bool,
}

/// How the Newton correction is solved.
pub enum LinearStrategy {
    /// Assemble K and solve with a native solver; `fallback` (sparse LU behind the `Direct`
    /// choice) takes over for the rest of the run when `solver` breaks down, e.g. Cholesky on
    /// a stiffness that damage made indefinite.
    Native {
        /// The first choice.
        solver: NativeLinearSolver,
        /// Used after the first choice broke down.
        fallback: Option<NativeLinearSolver>,
    },
    /// Assemble K and hand it to another backend's solver.
    Assembled(Box<dyn LinearSolver>),
    /// Assemble K and solve with native CG or GMRES preconditioned by the additive
    /// two-level smoothed-aggregation multigrid ([`crate::backend::native::Cycle::Additive`])
    /// on the problem's one-hop operator (`Linear Solver
    /// Preconditioner: "AMG"`), built once and rebuilt when bonds break or points are held.
    Multigrid {
        /// [`NativeMethod::Cg`] or [`NativeMethod::Gmres`].
        method: NativeMethod,
        /// Tolerance, iteration limit and restart.
        krylov: KrylovSettings,
        /// The hierarchy, kept across the Newton solves of the run.
        multigrid: MultigridCache,
    },
    /// Jacobian-free Newton–Krylov: GMRES on the directional derivative
    /// `K v ≈ (r(u) − r(u + εv))/ε`, with ε = λ·max|Y|/‖v‖∞, λ = 10⁻⁷ (about √ε_mach: the
    /// probe moves the largest component by λ times the largest coordinate, which balances
    /// truncation against the round-off of forces computed from positions Y), and the damage
    /// of the current iterate held fixed during the probes. NOX's rule λ(λ + ‖u‖/‖v‖) is not
    /// used: with u = 0 at the start of a load step and a preconditioned v of size 1/stiffness
    /// its probe vanishes below round-off. No tangent is
    /// assembled; the preconditioner needs only the 3×3 diagonal blocks.
    MatrixFree {
        /// GMRES settings.
        krylov: KrylovSettings,
        /// `Block 3x3` (inverted diagonal blocks), `Jacobi`, `None` or `AMG`.
        preconditioner: LinearPreconditioner,
        /// The AMG hierarchy (with `AMG`), kept across the Newton solves of the run.
        multigrid: MultigridCache,
        /// Chosen by `Linear Solver: "Automatic"` for a large quasi-static deck
        /// ([`crate::backend::factory::automatic_jacobian_free`]) rather than named by the
        /// deck; the description says so.
        automatic: bool,
    },
}

impl LinearStrategy {
    /// The restart length of the GMRES this strategy runs (0 when it runs none).
    pub fn gmres_restart(&self) -> usize {
        match self {
            LinearStrategy::Native {
                solver: NativeLinearSolver::Gmres(gmres),
                ..
            } => gmres.settings.restart,
            LinearStrategy::Multigrid {
                method: NativeMethod::Gmres,
                krylov,
                ..
            }
            | LinearStrategy::MatrixFree { krylov, .. } => krylov.restart,
            _ => 0,
        }
    }

    /// The AMG hierarchy this strategy keeps between Newton solves (an empty cache for the
    /// strategies without one); give it back with [`LinearStrategy::keep_multigrid`].
    fn take_multigrid(&mut self) -> MultigridCache {
        match self {
            LinearStrategy::Multigrid { multigrid, .. }
            | LinearStrategy::MatrixFree { multigrid, .. } => std::mem::take(multigrid),
            _ => MultigridCache::default(),
        }
    }

    /// Keeps `cache` for the next Newton solve (dropped by strategies without AMG).
    fn keep_multigrid(&mut self, cache: MultigridCache) {
        if let LinearStrategy::Multigrid { multigrid, .. }
        | LinearStrategy::MatrixFree { multigrid, .. } = self
        {
            *multigrid = cache;
        }
    }

    /// A short description for the log.
    pub fn describe(&self) -> String {
        match self {
            LinearStrategy::Native { solver, fallback } => {
                let name = match solver {
                    NativeLinearSolver::Cholesky(_) => "native sparse Cholesky".to_string(),
                    NativeLinearSolver::Lu(_) => "native sparse LU".to_string(),
                    NativeLinearSolver::Cg(cg) => {
                        format!("native CG + {}", cg.preconditioner.label())
                    }
                    NativeLinearSolver::Gmres(g) => {
                        format!("native GMRES + {}", g.preconditioner.label())
                    }
                };
                match fallback {
                    Some(_) => format!("{name} (sparse LU if not positive definite)"),
                    None => name,
                }
            }
            LinearStrategy::Assembled(solver) => solver.describe(),
            LinearStrategy::Multigrid { method, .. } => format!(
                "native {} + AMG (smoothed aggregation on the one-hop operator)",
                match method {
                    NativeMethod::Gmres => "GMRES",
                    _ => "CG",
                }
            ),
            LinearStrategy::MatrixFree {
                preconditioner,
                automatic,
                ..
            } => format!(
                "Jacobian-free Newton–Krylov (GMRES, preconditioner {}){}",
                match preconditioner {
                    LinearPreconditioner::Block3x3 => "Block 3x3",
                    LinearPreconditioner::Jacobi => "Jacobi",
                    LinearPreconditioner::None => "none",
                    LinearPreconditioner::Amg => "AMG",
                },
                if *automatic {
                    format!(
                        ", chosen by Linear Solver \"Automatic\" above {} unknowns (name a Linear Solver or its preconditioner for an assembled tangent)",
                        crate::backend::settings::LinearMethod::AUTOMATIC_DIRECT_LIMIT
                    )
                } else {
                    String::new()
                }
            ),
        }
    }
}

/// A Krylov solve that stopped at its iteration limit having reduced the residual by at least
/// [`INEXACT_ACCEPTANCE`] still gives a descent direction for the line search (inexact
/// Newton), so it is used with a note instead of failing the step.
fn accept_inexact(result: LinearResult) -> LinearResult {
    match result {
        Err(SolveError::NotConverged {
            method,
            iterations,
            relative_residual,
            tolerance,
        }) if relative_residual <= INEXACT_ACCEPTANCE => {
            eprintln!(
                "  note: {method} stopped at {iterations} iterations with relative residual {relative_residual:.2e} (tolerance {tolerance:.1e}); using it as an inexact Newton step"
            );
            Ok(KrylovReport {
                method: method.to_string(),
                iterations,
                relative_residual,
            })
        }
        other => other,
    }
}

/// Largest relative linear residual accepted from an unconverged Krylov solve.
pub const INEXACT_ACCEPTANCE: f64 = 0.1;

/// Solves the assembled system with the native solver, switching to the fallback for good
/// when the first choice breaks down.
fn solve_native(
    solver: &mut NativeLinearSolver,
    fallback: &mut Option<NativeLinearSolver>,
    groups: &[usize],
    matrix: &Csr,
    rhs: &[f64],
    x: &mut [f64],
) -> LinearResult {
    solver.set_groups(groups.to_vec());
    match solver.solve(matrix, rhs, x) {
        Err(SolveError::Breakdown { method, reason }) if fallback.is_some() => {
            eprintln!("  note: {method}: {reason}; switching to sparse LU");
            *solver = fallback.take().expect("checked above");
            x.iter_mut().for_each(|v| *v = 0.0);
            solver.solve(matrix, rhs, x)
        }
        other => other,
    }
}

/// What one Newton solve did (the per-step solver report).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct NewtonReport {
    /// True when the measure reached the tolerance.
    pub converged: bool,
    /// Linear solves taken (Newton iterations).
    pub iterations: usize,
    /// Dynamic relaxation iterations ([`crate::solver::relaxation`]): of a `DynamicRelaxation`
    /// step, or of a step Newton handed to it; 0 when Newton solved the step.
    pub relaxation_iterations: usize,
    /// Krylov iterations summed over the linear solves.
    pub linear_iterations: usize,
    /// Measure after every iteration (the first entry is the starting residual).
    pub residual_history: Vec<f64>,
    /// Residual evaluations, line search included.
    pub residual_evaluations: usize,
    /// Wall-clock seconds.
    pub seconds: f64,
    /// Bonds broken in the accepted iterate relative to the start of the step.
    pub broken_bonds: usize,
    /// Points whose dofs were held because they had too few intact bonds (original ids).
    pub held_points: Vec<u32>,
    /// Bytes of the assembled tangent (0 when none was assembled).
    pub tangent_bytes: usize,
    /// Last linear-solver method name.
    pub linear_method: String,
    /// Preconditioner setup time, AMG hierarchy shape and GMRES restart of the solve.
    pub preconditioner: PreconditionerReport,
}

/// Runs Newton from `state.displacement` (prescribed dofs already set) on the physics as a
/// [`PhysicsProblem`] ([`solve_problem`]); on return the state holds the last iterate,
/// consistent forces and damage, and the report counts broken bonds and held points.
///
/// On several ranks (`collective`), the unknowns are the free dofs of the points this rank
/// owns, every residual evaluation first refreshes the ghosts, and norms and decisions are
/// global.
pub fn solve(
    parts: Physical<'_>,
    linear: &mut LinearStrategy,
    settings: &NewtonSettings,
) -> Result<NewtonReport, SolveError> {
    let mut problem = PhysicsProblem::new(parts, settings.measure, Origin::Displacement);
    let mut report = solve_problem(&mut problem, linear, settings)?;
    report.residual_evaluations = problem.residual_evaluations();
    report.broken_bonds = problem.broken_bonds();
    report.held_points = problem.held_points();
    Ok(report)
}

/// Runs Newton on `problem` from its current unknowns; on return the problem is at the last
/// iterate. A non-converged solve is a report with `converged == false`; errors are failures
/// of the linear algebra or non-finite values. The report's physics fields (broken bonds,
/// held points, residual evaluations) are left for the caller, which knows the physics.
///
/// On several ranks the correction comes from a distributed assembled solve
/// ([`LinearSolver::solve_distributed`], the Trilinos or PETSc backend) over the problem's
/// global ids.
pub fn solve_problem(
    problem: &mut dyn NonlinearProblem,
    linear: &mut LinearStrategy,
    settings: &NewtonSettings,
) -> Result<NewtonReport, SolveError> {
    let start = Instant::now();
    if problem.ranks() > 1 && !matches!(linear, LinearStrategy::Assembled(_)) {
        return Err(SolveError::Breakdown {
            method: "Newton",
            reason: "on several ranks peridyn's Newton solves its corrections with Backend \"Trilinos\" (Belos) or \"PETSc\" (KSP)".into(),
        });
    }
    let mut report = NewtonReport::default();
    let mut multigrid = linear.take_multigrid();
    multigrid.begin_solve(settings.verbose);
    let mut x = vec![0.0; problem.len()];
    problem.unknowns(&mut x);
    let mut residual = vec![0.0; problem.len()];
    problem.residual(&x, &mut residual, Evaluation::Iterate)?;
    let mut measure = problem.convergence_measure(&residual);
    report.residual_history.push(measure);
    while measure > settings.tolerance && (report.iterations as u64) < settings.max_iterations {
        // Peridigm's log: the residual at the top of every iteration, numbered from 1.
        if settings.print_iterations {
            eprintln!(
                "  iteration {}: residual = {measure:e}",
                report.iterations + 1
            );
        }
        if problem.update_unknowns()? {
            x = vec![0.0; problem.len()];
            problem.unknowns(&mut x);
            residual = vec![0.0; problem.len()];
            problem.residual(&x, &mut residual, Evaluation::Iterate)?;
            measure = problem.convergence_measure(&residual);
            if measure <= settings.tolerance {
                break;
            }
        }
        let mut correction = vec![0.0; problem.len()];
        let linear_report = correct(
            problem,
            linear,
            &mut multigrid,
            &x,
            &residual,
            &mut correction,
        )?;
        report.tangent_bytes = report.tangent_bytes.max(problem.jacobian_bytes());
        report.linear_iterations += linear_report.iterations;
        report.linear_method = linear_report.method.clone();
        report.iterations += 1;
        measure = line_search(problem, &mut x, &mut residual, &correction, settings)?;
        report.residual_history.push(measure);
        if settings.verbose {
            eprintln!(
                "    linear solve: {}, {} iterations, relative residual {:.2e}",
                linear_report.method, linear_report.iterations, linear_report.relative_residual
            );
        }
    }
    report.converged = measure <= settings.tolerance;
    report.preconditioner = multigrid.report();
    linear.keep_multigrid(multigrid);
    if let LinearStrategy::Assembled(solver) = linear {
        report
            .preconditioner
            .add_assembled(solver.take_preconditioner_setup());
    }
    if report.iterations > 0 {
        report.preconditioner.gmres_restart = linear.gmres_restart();
    }
    report.seconds = start.elapsed().as_secs_f64();
    Ok(report)
}

/// The Newton correction Δ of J Δ = −F at `x` (`residual` holds F); `multigrid` keeps the
/// AMG hierarchy between corrections.
fn correct(
    problem: &mut dyn NonlinearProblem,
    linear: &mut LinearStrategy,
    multigrid: &mut MultigridCache,
    x: &[f64],
    residual: &[f64],
    correction: &mut [f64],
) -> LinearResult {
    let rhs: Vec<f64> = residual.iter().map(|f| -f).collect();
    match linear {
        LinearStrategy::Native { solver, fallback } => {
            let matrix = problem.jacobian(x)?;
            let groups = problem.groups().to_vec();
            solve_native(solver, fallback, &groups, &matrix, &rhs, correction)
        }
        LinearStrategy::Assembled(solver) => {
            let matrix = problem.jacobian(x)?;
            // On several ranks the modes are this rank's rows (PETSc's GAMG takes them so).
            if let Some((modes, count)) = problem.near_null_space() {
                solver.set_near_null_space(&modes, count);
            }
            solver.set_point_groups(problem.groups());
            let result = match problem.global_ids() {
                Some(rows) => {
                    let part = RankRows {
                        rows,
                        matrix: &matrix,
                    };
                    solver.solve_distributed(part, &rhs, correction)
                }
                None => solver.solve(&matrix, &rhs, correction),
            };
            accept_inexact(result)
        }
        LinearStrategy::Multigrid { method, krylov, .. } => {
            let matrix = problem.jacobian(x)?;
            let amg = multigrid.hierarchy(problem)?;
            let mut apply = |v: &[f64], y: &mut [f64]| {
                matrix.multiply_parallel(v, y);
                Ok(())
            };
            let precondition = |r: &[f64], z: &mut [f64]| amg.apply(r, z);
            let krylov_method = match method {
                NativeMethod::Gmres => gmres_matrix_free,
                _ => cg_matrix_free,
            };
            accept_inexact(krylov_method(
                &mut apply,
                &precondition,
                &rhs,
                correction,
                krylov,
            ))
        }
        LinearStrategy::MatrixFree {
            krylov,
            preconditioner,
            ..
        } => accept_inexact(jfnk::solve(
            problem,
            krylov,
            *preconditioner,
            multigrid,
            x,
            &rhs,
            correction,
        )),
    }
}

/// Moves the unknowns from x₀ to x₀ + αΔ with the line search of the module docs; leaves
/// the problem, `x` and `residual` at the accepted point and returns its measure.
fn line_search(
    problem: &mut dyn NonlinearProblem,
    x: &mut [f64],
    residual: &mut [f64],
    correction: &[f64],
    settings: &NewtonSettings,
) -> Result<f64, SolveError> {
    let start = x.to_vec();
    let g0 = problem.dot(residual, residual);
    let mut alpha = 1.0;
    let mut best: Option<(f64, f64)> = None;
    let backtracks = if settings.line_search {
        MAX_BACKTRACKS
    } else {
        0
    };
    let step = |x: &mut [f64], alpha: f64| {
        for ((t, s), d) in x.iter_mut().zip(&start).zip(correction) {
            *t = s + alpha * d;
        }
    };
    for attempt in 0..=backtracks {
        step(x, alpha);
        problem.residual(x, residual, Evaluation::Iterate)?;
        let g = problem.dot(residual, residual);
        if g <= (1.0 - 2.0 * ARMIJO * alpha) * g0 || attempt == backtracks && best.is_none() {
            return Ok(problem.convergence_measure(residual));
        }
        if best.is_none_or(|(_, g_best)| g < g_best) {
            best = Some((alpha, g));
        }
        if attempt == backtracks {
            break;
        }
        let curvature = (g - g0 + 2.0 * g0 * alpha) / (alpha * alpha);
        let minimizer = if curvature > 0.0 {
            g0 / curvature
        } else {
            0.5 * alpha
        };
        alpha = minimizer.clamp(0.1 * alpha, 0.5 * alpha);
    }
    // No trial met the Armijo condition: take the best one seen (the driver decides whether
    // the step converged).
    let (alpha, _) = best.expect("at least one trial was evaluated");
    step(x, alpha);
    problem.residual(x, residual, Evaluation::Iterate)?;
    Ok(problem.convergence_measure(residual))
}

/// A nonlinear solver for one load step: from the state on entry (prescribed dofs set, the
/// predictor applied) to an equilibrium of `system`, leaving the state at its last iterate with
/// consistent forces and damage.
pub trait NonlinearSolver {
    /// A short description for the log.
    fn describe(&self) -> String;

    /// True when the solver logs the residual after each iteration (NOX, as Peridigm prints
    /// it), so the load-step driver does not add the closing `iteration i: residual` line
    /// that peridyn's Newton, which logs at the top of each iteration, needs.
    fn logs_after_each_iteration(&self) -> bool {
        false
    }

    /// Solves the step's system over `parts`; a solve that stops unconverged is a report with
    /// `converged == false`. On several ranks, `parts.collective` holds the halo exchange and
    /// the reductions.
    fn solve(
        &mut self,
        parts: Physical<'_>,
        settings: &NewtonSettings,
    ) -> Result<NewtonReport, SolveError>;
}

/// peridyn's own Newton iteration ([`solve`]) with this linear strategy.
impl NonlinearSolver for LinearStrategy {
    fn describe(&self) -> String {
        LinearStrategy::describe(self)
    }

    fn solve(
        &mut self,
        parts: Physical<'_>,
        settings: &NewtonSettings,
    ) -> Result<NewtonReport, SolveError> {
        solve(parts, self, settings)
    }
}
