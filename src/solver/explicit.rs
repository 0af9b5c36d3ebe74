//! Explicit velocity-Verlet time integration in Peridigm's step order (`executeExplicit` in
//! `src/core/Peridigm.cpp`).
//!
//! One step from t_n to t_{n+1} = t_n + Δt:
//! 1. half kick `v += ½Δt a`;
//! 2. kinematic conditions: at prescribed dofs `v = (g(t_{n+1}) − g(t_n))/Δt`;
//! 3. drift `u += Δt v`;
//! 4. body force at t_{n+1};
//! 5. damage, then internal force at the new positions, then contact (if any);
//! 6. `a = (f_int + f_contact + b)/ρ`, second half kick `v += ½Δt a` (at every dof, as Peridigm
//!    does, so velocities written at prescribed dofs include half a kick).
//!
//! With contact, a step whose number is a multiple of `Search Frequency` first runs the
//! proximity search with the positions at the start of the step (Peridigm's
//! `rebalance(step)`); the skin rule may add one before the contact force (see
//! [`crate::contact`]).
//!
//! # Distributed runs
//! On one rank of a distributed run the model holds owned points and ghosts
//! ([`crate::parallel::Subdomain`]). The integrator is told which points are ghosts
//! ([`VelocityVerlet::with_ghosts`]) and refreshes their current positions through a
//! [`Ranks`] just before each force evaluation; ghosts get zero acceleration (their own forces
//! come from truncated rows and mean nothing) and count in no energy or work sum, so the
//! [`StepReport`] is this rank's share, to be summed over ranks.

use crate::boundary::BoundaryError;
use crate::contact::ContactState;
use crate::model::Model;
use crate::parallel::{Communicator, Ranks, SerialRanks};
use crate::physics::Physics;
use crate::state::{Staged, State};
use rayon::prelude::*;

/// Time-step settings of one `Verlet` solver list.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VerletSettings {
    /// Time step Δt (s): `Safety Factor × (Fixed dt or the stable estimate)`.
    pub time_step: f64,
    /// Number of steps, `floor((t_final − t_initial)/Δt)` (Peridigm's count).
    pub steps: u64,
    /// `Initial Time`.
    pub initial_time: f64,
}

/// What one step did, for the stability monitor and the log.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StepReport {
    /// Kinetic energy of the unconstrained dofs, Σ ½ ρ V v² (energy units).
    pub free_kinetic_energy: f64,
    /// Magnitude of the work supplied in the step by body forces and at prescribed dofs.
    pub supplied_work: f64,
    /// Bonds broken in the step.
    pub broken_bonds: usize,
}

/// Velocity-Verlet integrator with its own scratch.
#[derive(Debug, Clone)]
pub struct VelocityVerlet {
    settings: VerletSettings,
    /// `ghost[i]`: point i is a ghost of a distributed run (`None` in serial runs).
    ghost: Option<Vec<bool>>,
    /// Bit k set when component k of the point is prescribed.
    constrained: Vec<u8>,
    /// The points with a prescribed component (their drift waits for the prescribed
    /// velocities).
    constrained_points: Vec<u32>,
}

impl VelocityVerlet {
    /// An integrator for `model` with `settings`.
    pub fn new(model: &Model, settings: VerletSettings) -> Self {
        let mut constrained = vec![0u8; model.points.len()];
        for dof in model.boundary.constrained_dofs() {
            constrained[dof / 3] |= 1 << (dof % 3);
        }
        let constrained_points = (0..constrained.len() as u32)
            .filter(|&p| constrained[p as usize] != 0)
            .collect();
        Self {
            settings,
            ghost: None,
            constrained,
            constrained_points,
        }
    }

    /// Marks the ghosts of a distributed run (`ghost[i]` for every point of the model): they
    /// get zero acceleration and count in no energy or work sum.
    pub fn with_ghosts(mut self, ghost: Vec<bool>) -> Self {
        self.ghost = Some(ghost);
        self
    }

    /// The settings.
    pub fn settings(&self) -> VerletSettings {
        self.settings
    }

    /// Time at the end of step `step` (1-based), `t_0 + step·Δt`.
    pub fn time_after(&self, step: u64) -> f64 {
        self.settings.initial_time + step as f64 * self.settings.time_step
    }

    /// Evaluates the body force and the internal force at the initial time and sets a₀
    /// consistently. Prescribed displacements act through their increments over each step
    /// (u = g(t) − g(t₀) for a time-varying g, as Peridigm does), so nothing is imposed here.
    pub fn initialize(
        &self,
        model: &Model,
        physics: &mut Physics,
        state: &mut State,
    ) -> Result<(), BoundaryError> {
        let mut ranks = SerialRanks {
            points: model.points.len(),
        };
        self.initialize_with(model, physics, state, &mut ranks)
    }

    /// [`VelocityVerlet::initialize`] with the ghost positions refreshed by `ranks` before the
    /// force evaluation.
    pub fn initialize_with(
        &self,
        model: &Model,
        physics: &mut Physics,
        state: &mut State,
        ranks: &mut dyn Ranks,
    ) -> Result<(), BoundaryError> {
        let t0 = self.settings.initial_time;
        state.time = t0;
        // Explicit steps accept every step: no committed copy of the staged fields is kept
        // (an implicit solver before this one may have kept one), so committing is free.
        state.drop_committed();
        state.history.set_step_duration(self.settings.time_step);
        let positions = &model.points.position;
        // A failure is reported after the force evaluation, whose exchanges and collectives
        // every rank of a distributed run must join (see `step_with`).
        let mut failure = None;
        if let Some(b) = &mut state.external_force_density {
            failure = model.boundary.body_force(positions, t0, b).err();
        }
        if let Err(error) = model
            .boundary
            .apply_temperature(positions, t0, &mut state.history)
        {
            failure.get_or_insert(error);
        }
        state.update_current_position(positions);
        ranks.refresh(&mut state.current_position);
        if let Err(error) = set_damage_time(physics, t0) {
            failure.get_or_insert(error);
        }
        evaluate_acceleration_with(model, physics, state, ranks);
        if let Some(ghost) = &self.ghost {
            for (a, _) in state.acceleration.iter_mut().zip(ghost).filter(|(_, &g)| g) {
                *a = [0.0; 3];
            }
        }
        failure.map_or(Ok(()), Err)
    }

    /// Advances the state by one step; `step` is the 1-based step number in this solver.
    pub fn step(
        &mut self,
        model: &Model,
        physics: &mut Physics,
        state: &mut State,
        step: u64,
    ) -> Result<StepReport, BoundaryError> {
        let mut ranks = SerialRanks {
            points: model.points.len(),
        };
        self.step_with(model, physics, state, step, &mut ranks)
    }

    /// [`VelocityVerlet::step`] with the ghost positions refreshed by `ranks` before the force
    /// evaluation (after the drift and the kinematic conditions).
    pub fn step_with(
        &mut self,
        model: &Model,
        physics: &mut Physics,
        state: &mut State,
        step: u64,
        ranks: &mut dyn Ranks,
    ) -> Result<StepReport, BoundaryError> {
        let t_to = self.time_after(step);
        scheduled_contact_search(model, physics, state, step, ranks);
        // A failing expression (it may fail at one rank's points only) is reported at the end
        // of the step: every rank of a distributed run must still join the halo exchange and
        // the collectives of contact, or the others wait for it forever. The state of a failed
        // step is not used.
        let mut failure = self.kick_and_drift(model, state, t_to);
        if let Some(b) = &mut state.external_force_density {
            if let Err(error) = model.boundary.body_force(&model.points.position, t_to, b) {
                failure.get_or_insert(error);
            }
        }
        if let Err(error) =
            model
                .boundary
                .apply_temperature(&model.points.position, t_to, &mut state.history)
        {
            failure.get_or_insert(error);
        }
        if let Err(error) = set_damage_time(physics, t_to) {
            failure.get_or_insert(error);
        }
        ranks.refresh(&mut state.current_position);
        let broken_bonds = internal_and_contact_force(model, physics, state, ranks);
        state.commit();
        let (free_kinetic_energy, supplied_work) = self.second_half_kick(model, physics, state);
        match failure {
            Some(error) => Err(error),
            None => Ok(StepReport {
                free_kinetic_energy,
                supplied_work,
                broken_bonds,
            }),
        }
    }

    /// The first half kick, the drift and the kinematic conditions, up to time `t_to`: half
    /// kick everywhere and, at points without a prescribed component, the drift in the same
    /// pass over memory; the drift of the other points waits for the velocities the kinematic
    /// conditions prescribe (they touch only those points). Returns a failing prescribed
    /// expression, if any (the step still runs to its end, see [`VelocityVerlet::step_with`]).
    fn kick_and_drift(&self, model: &Model, state: &mut State, t_to: f64) -> Option<BoundaryError> {
        let dt = self.settings.time_step;
        let t_from = state.time;
        let positions = &model.points.position;
        state
            .velocity
            .par_iter_mut()
            .zip(state.acceleration.par_iter())
            .zip(state.displacement.par_iter_mut())
            .zip(state.current_position.par_iter_mut())
            .zip(positions.par_iter())
            .zip(self.constrained.par_iter())
            .for_each(|(((((v, a), u), y), x), &fixed)| {
                for k in 0..3 {
                    v[k] += 0.5 * dt * a[k];
                }
                if fixed == 0 {
                    drift(dt, u, v, y, x);
                }
            });
        let failure = {
            let (displacement, velocity) = (&state.displacement, &mut state.velocity);
            model
                .boundary
                .prescribed_increments(positions, displacement, t_from, t_to, |p, c, du| {
                    velocity[p][c] = du / dt
                })
                .err()
        };
        for &p in &self.constrained_points {
            let p = p as usize;
            drift(
                dt,
                &mut state.displacement[p],
                &state.velocity[p],
                &mut state.current_position[p],
                &positions[p],
            );
        }
        state.time = t_to;
        failure
    }

    /// a = (f_int + f_contact + b)/ρ (as `evaluate_acceleration`), the work, the second half
    /// kick and the kinetic energy in one pass. Returns the kinetic energy of the free
    /// components and the work supplied over the step.
    fn second_half_kick(&self, model: &Model, physics: &Physics, state: &mut State) -> (f64, f64) {
        let dt = self.settings.time_step;
        let volume = &model.points.volume;
        let constrained = &self.constrained;
        let external = state.external_force_density.as_deref();
        let contact = state.contact.as_ref().map(|c| c.force_density());
        let density = &physics.density;
        let force = &state.force_density;
        let ghost = self.ghost.as_deref();
        state
            .velocity
            .par_iter_mut()
            .zip(state.acceleration.par_iter_mut())
            .enumerate()
            .map(|(i, (v, a))| {
                if ghost.is_some_and(|g| g[i]) {
                    *a = [0.0; 3];
                    return (0.0, 0.0);
                }
                let mut kinetic = 0.0;
                let mut work = 0.0;
                for k in 0..3 {
                    let b = external.map_or(0.0, |b| b[i][k]);
                    let c = contact.map_or(0.0, |c| c[i][k]);
                    a[k] = (force[i][k] + c + b) / density[i];
                    let drift = dt * v[k];
                    work += (b * drift * volume[i]).abs();
                    if constrained[i] & (1 << k) != 0 {
                        work += ((force[i][k] + b) * drift * volume[i]).abs();
                    }
                    v[k] += 0.5 * dt * a[k];
                    if constrained[i] & (1 << k) == 0 {
                        kinetic += v[k] * v[k];
                    }
                }
                (0.5 * density[i] * volume[i] * kinetic, work)
            })
            .reduce(|| (0.0, 0.0), |x, y| (x.0 + y.0, x.1 + y.1))
    }
}

/// The drift of one point over Δt = `dt`: Y = (X + u) + Δt v and u += Δt v, in this order of
/// operations, as Peridigm does: the extension e = |Y| − ζ cancels most digits, so the
/// rounding of Y shows in forces.
#[inline(always)]
fn drift(dt: f64, u: &mut [f64; 3], v: &[f64; 3], y: &mut [f64; 3], x: &[f64; 3]) {
    for k in 0..3 {
        y[k] = x[k] + u[k] + dt * v[k];
        u[k] += dt * v[k];
    }
}

/// Contact's scheduled search at the start of step `step` (Peridigm's `Search Frequency`),
/// when the run has contact.
fn scheduled_contact_search(
    model: &Model,
    physics: &Physics,
    state: &mut State,
    step: u64,
    ranks: &dyn Ranks,
) {
    if let Some(contact) = &physics.contact {
        let contact_state = contact_state(&mut state.contact);
        let current = &state.current_position;
        match contact_communicator(contact, ranks) {
            Some(comm) => contact.scheduled_search_on_ranks(contact_state, comm, step, current),
            None => contact.scheduled_search(contact_state, step, model, current),
        }
    }
}

/// The communicator of `ranks` when `contact` is one rank's share of a distributed run
/// (its searches and force evaluations are collective), `None` for serial contact.
fn contact_communicator<'r>(
    contact: &crate::contact::Contact,
    ranks: &'r dyn Ranks,
) -> Option<&'r dyn Communicator> {
    contact.is_on_ranks().then(|| ranks.communicator())
}

/// The contact part of a state whose physics has contact.
fn contact_state(contact: &mut Option<ContactState>) -> &mut ContactState {
    contact
        .as_mut()
        .expect("the state of a run with contact carries its contact state (State::with_contact)")
}

/// The internal force density at the current positions into `state.force_density`, bond
/// damage and material history updated as trial values (what every solver evaluates);
/// returns the bonds broken in the evaluation.
pub(crate) fn internal_force(model: &Model, physics: &mut Physics, state: &mut State) -> usize {
    physics.internal_force(
        &model.bonds,
        &model.points,
        &state.current_position,
        state.bond_damage.as_mut().map(Staged::trial_mut),
        &mut state.history,
        &mut state.force_density,
    )
}

/// Internal force density at `state.current_position` into `state.force_density`, then the
/// contact force (if any, kept by the contact model). Returns broken bonds.
fn internal_and_contact_force(
    model: &Model,
    physics: &mut Physics,
    state: &mut State,
    ranks: &dyn Ranks,
) -> usize {
    let broken = internal_force(model, physics, state);
    if let Some(contact) = &physics.contact {
        let contact_state = contact_state(&mut state.contact);
        let (current, velocity) = (&state.current_position, &state.velocity);
        match contact_communicator(contact, ranks) {
            Some(comm) => {
                contact.compute_force_on_ranks(contact_state, comm, current, velocity);
            }
            None => {
                contact.compute_force(contact_state, model, current, velocity);
            }
        }
    }
    broken
}

/// Passes the time to time-dependent damage models and contact friction coefficients; a
/// failing expression is reported like a failing boundary-condition expression.
fn set_damage_time(physics: &mut Physics, time: f64) -> Result<(), BoundaryError> {
    physics
        .set_time(time)
        .map_err(|e| BoundaryError::Evaluation {
            condition: "Damage Models".into(),
            time,
            message: e.to_string(),
        })?;
    if let Some(contact) = &mut physics.contact {
        contact
            .set_time(time)
            .map_err(|e| BoundaryError::Evaluation {
                condition: format!("Contact → Models → {}", e.model),
                time,
                message: e.message,
            })?;
    }
    Ok(())
}

/// Internal force at the current positions `state.current_position`, then the contact force
/// (if any), and `a = (f_int + f_contact + b)/ρ`. Returns broken bonds.
pub fn evaluate_acceleration(model: &Model, physics: &mut Physics, state: &mut State) -> usize {
    let ranks = SerialRanks {
        points: model.points.len(),
    };
    evaluate_acceleration_with(model, physics, state, &ranks)
}

/// [`evaluate_acceleration`] with the communicator of `ranks` for contact on ranks.
fn evaluate_acceleration_with(
    model: &Model,
    physics: &mut Physics,
    state: &mut State,
    ranks: &dyn Ranks,
) -> usize {
    let broken = internal_and_contact_force(model, physics, state, ranks);
    let contact = state.contact.as_ref().map(|c| c.force_density());
    let external = state.external_force_density.as_deref();
    let density = &physics.density;
    state
        .acceleration
        .par_iter_mut()
        .zip(state.force_density.par_iter())
        .enumerate()
        .for_each(|(i, (a, f))| {
            for k in 0..3 {
                let b = external.map_or(0.0, |b| b[i][k]);
                let c = contact.map_or(0.0, |c| c[i][k]);
                a[k] = (f[k] + c + b) / density[i];
            }
        });
    broken
}
