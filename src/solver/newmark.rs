//! Implicit dynamics with the Newmark-β method (`Implicit`; Peridigm's `executeImplicit` in
//! `src/core/Peridigm.cpp`, with the differences noted).
//!
//! One step from t_n to t_{n+1} = t_n + Δt:
//! * predictors `ũ = u_n + Δt v_n + ½Δt²(1 − 2β) a_n`, `ṽ = v_n + Δt(1 − γ) a_n`;
//! * unknown u_{n+1} with `a = (u − ũ)/(βΔt²)`, `v = ṽ + γΔt a`; prescribed displacements
//!   follow their increments g(t_{n+1}) − g(t_n) **every step** (Peridigm applies them only at
//!   t = 0, its issue #23), so at those dofs a and v follow from the prescribed motion;
//! * equilibrium `V(f_int(u) + b − ρ a) = 0` over the free dofs by Newton (peridyn's, or
//!   PETSc's SNES with `Nonlinear Solver: "SNES"`), with the consistent
//!   stiffness `K = K_int + Vρ/(βΔt²) I` (force units in residual and matrix alike; Peridigm's
//!   `executeImplicit` mixes force density and force);
//! * convergence: Peridigm's measure `βΔt²·‖f + b − ρa‖₂` (force density) ≤ `Absolute
//!   Tolerance`.
//!
//! The body force is evaluated at t_{n+1}, the time the equilibrium holds at (Peridigm uses
//! t_n; the two agree for constant body forces). The acceleration a_n of the first step is the
//! state's (zero at rest), as in Peridigm.

use crate::backend::SolveError;
use crate::boundary::BoundaryError;
use crate::model::Model;
use crate::physics::Physics;
use crate::solver::collective::{any_failed, Collective};
use crate::solver::implicit::{apply_loads_at, DofMap, ImplicitSystem, Inertia};
use crate::solver::newton::{ConvergenceMeasure, NewtonReport, NewtonSettings, NonlinearSolver};
use crate::solver::problem::Physical;
use crate::state::State;

/// Settings of one `Implicit` solver list.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NewmarkSettings {
    /// Δt (`Fixed dt`).
    pub time_step: f64,
    /// Steps, `floor((t_final − t_initial)/Δt)` as Peridigm counts them.
    pub steps: u64,
    /// The first step to solve: 1, or the step after the one a restart file was written at
    /// (the state is then the one after step `first_step − 1`).
    pub first_step: u64,
    /// `Initial Time`.
    pub initial_time: f64,
    /// β (`Beta`, default 0.25).
    pub beta: f64,
    /// γ (`Gamma`, default 0.5).
    pub gamma: f64,
    /// `Absolute Tolerance` on Peridigm's measure.
    pub tolerance: f64,
    /// `Maximum Solver Iterations`.
    pub max_iterations: u64,
    /// Print every Newton iteration.
    pub verbose: bool,
}

/// Why a Newmark run stopped.
#[derive(Debug, thiserror::Error)]
pub enum NewmarkError {
    /// A step did not reach the tolerance.
    #[error(
        "time step {step} (t = {time:e}) did not converge: residual {measure:.4e} after {iterations} Newton iterations, \
         tolerance {tolerance:.4e}. Use a smaller \"Fixed dt\" or raise \"Maximum Solver Iterations\"; output up to the last step is valid"
    )]
    NotConverged {
        /// 1-based step.
        step: u64,
        /// End time of the step.
        time: f64,
        /// Final measure.
        measure: f64,
        /// Tolerance.
        tolerance: f64,
        /// Iterations taken.
        iterations: usize,
    },
    /// The linear algebra failed.
    #[error("time step {step} (t = {time:e}): {source}")]
    Solve {
        /// 1-based step.
        step: u64,
        /// End time of the step.
        time: f64,
        /// What failed.
        source: SolveError,
    },
    /// A boundary-condition expression failed.
    #[error(transparent)]
    Boundary(#[from] BoundaryError),
}

/// Advances the state `settings.steps` steps, calling `on_step(physics, state, ranks, step,
/// report)` after each.
///
/// On several ranks (`collective`) every rank calls this with its subdomain: the Newton
/// unknowns are the owned free dofs, the ghosts' displacements come from their owners, and
/// rank 0 alone writes the log. [`crate::solver::collective::SerialRun`] runs it on one.
pub fn run<E: From<NewmarkError>>(
    model: &Model,
    physics: &mut Physics,
    state: &mut State,
    settings: &NewmarkSettings,
    nonlinear: &mut dyn NonlinearSolver,
    collective: &mut dyn Collective,
    mut on_step: impl FnMut(&Physics, &State, &mut dyn Collective, u64, &NewtonReport) -> Result<(), E>,
) -> Result<(), E> {
    let constrained = model.boundary.constrained_dofs();
    let (dt, beta, gamma) = (settings.time_step, settings.beta, settings.gamma);
    let positions = &model.points.position;
    let n = model.points.len();
    let root = collective.rank() == 0;
    for step in settings.first_step..=settings.steps {
        let from = settings.initial_time + (step - 1) as f64 * dt;
        let to = settings.initial_time + step as f64 * dt;
        state.history.set_step_duration(dt);
        let u_n = state.displacement.clone();
        let mut predictor = vec![[0.0; 3]; n];
        let mut velocity_predictor = vec![[0.0; 3]; n];
        for i in 0..n {
            for c in 0..3 {
                let (u, v, a) = (u_n[i][c], state.velocity[i][c], state.acceleration[i][c]);
                predictor[i][c] = u + dt * v + 0.5 * dt * dt * (1.0 - 2.0 * beta) * a;
                velocity_predictor[i][c] = v + dt * (1.0 - gamma) * a;
            }
        }
        state.displacement.copy_from_slice(&predictor);
        let displacement = &mut state.displacement;
        let loads = model
            .boundary
            .prescribed_increments(positions, &u_n, from, to, |p, c, du| {
                displacement[p][c] = u_n[p][c] + du
            })
            .and_then(|()| apply_loads_at(model, physics, state, to));
        // A condition may fail at some points only, hence on some ranks only: all stop.
        if any_failed(collective, loads.is_err()) {
            return Err(match loads {
                Err(error) => NewmarkError::Boundary(error),
                Ok(()) => NewmarkError::Solve {
                    step,
                    time: to,
                    source: SolveError::OtherRank,
                },
            }
            .into());
        }
        let factor = 1.0 / (beta * dt * dt);
        let mut system = ImplicitSystem::new(DofMap::new(n, &constrained, &[]), state);
        system.inertia = Some(Inertia { predictor, factor });
        let newton_settings = NewtonSettings {
            max_iterations: settings.max_iterations,
            tolerance: settings.tolerance,
            measure: ConvergenceMeasure::ForceDensity {
                scale: beta * dt * dt,
            },
            line_search: true,
            print_iterations: settings.verbose && root,
            verbose: settings.verbose && root,
        };
        let parts = Physical {
            system: &mut system,
            model,
            physics,
            state,
            collective,
            constrained: &constrained,
        };
        let report =
            nonlinear
                .solve(parts, &newton_settings)
                .map_err(|source| NewmarkError::Solve {
                    step,
                    time: to,
                    source,
                })?;
        let measure = *report.residual_history.last().unwrap_or(&f64::INFINITY);
        if !report.converged {
            return Err(NewmarkError::NotConverged {
                step,
                time: to,
                measure,
                tolerance: settings.tolerance,
                iterations: report.iterations,
            }
            .into());
        }
        // The ghosts take their owners' solution, so that their velocities and accelerations,
        // and the next step's predictor, are the owners' too.
        collective.refresh(&mut state.displacement);
        let inertia = system.inertia.as_ref().expect("set above");
        let kinematics = state
            .acceleration
            .iter_mut()
            .zip(state.velocity.iter_mut())
            .zip(state.displacement.iter().zip(&inertia.predictor))
            .zip(&velocity_predictor);
        for (((a, v), (u, u_predicted)), v_predicted) in kinematics {
            for c in 0..3 {
                a[c] = (u[c] - u_predicted[c]) * factor;
                v[c] = v_predicted[c] + gamma * dt * a[c];
            }
        }
        state.time = to;
        state.commit();
        if root && (settings.verbose || step == settings.steps || step % 100 == 0) {
            eprintln!(
                "Time step {step}, Newton iterations = {}, norm(residual) = {measure:e}",
                report.iterations
            );
        }
        on_step(physics, state, collective, step, &report)?;
    }
    Ok(())
}
