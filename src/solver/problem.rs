//! peridyn's physics as a [`NonlinearProblem`]: the adapter through which every nonlinear
//! backend (peridyn's Newton, NOX) solves a load step or time step without seeing the model,
//! the physics or the ranks.
//!
//! The unknowns are the free dofs of the points this rank owns, minus those of held points
//! (too few intact bonds for a stiffness, `RANK_DEFICIENT_NODES`); F = −r with r the residual
//! of [`ImplicitSystem::residual`]; every evaluation first refreshes the ghosts, and failures
//! and reductions are agreed over the ranks through the [`Collective`].

use crate::backend::fingerprint::Fingerprint;
use crate::backend::native::{
    one_hop_operator, pmb_micromodulus, rigid_body_modes, OneHopInput, Stencil,
};
use crate::backend::problem::{Evaluation, NonlinearProblem, PreconditioningOperator};
use crate::backend::{Csr, SolveError};
use crate::model::Model;
use crate::physics::Physics;
use crate::solver::collective::{
    agree, any_failed, deficient_points, global_dof, owned_unknowns, Collective, ColumnMap,
};
use crate::solver::implicit::ImplicitSystem;
use crate::solver::measure::ConvergenceMeasure;
use crate::state::State;

/// What the unknowns are measured from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Origin {
    /// x = u, the displacements (peridyn's Newton).
    Displacement,
    /// x = X + u, the current coordinates (NOX: its matrix-free probe is scaled by ‖x‖,
    /// which must not vanish at the start of a load step).
    Coordinates,
}

/// The physics one implicit solve works on.
pub struct Physical<'a> {
    /// The nonlinear system of the step (unknowns, committed damage, tangent).
    pub system: &'a mut ImplicitSystem,
    /// The model.
    pub model: &'a Model,
    /// The physics (bond damage evolves with the iterates).
    pub physics: &'a mut Physics,
    /// The state; left at the last point the problem was moved to.
    pub state: &'a mut State,
    /// Halo exchange and reductions over the ranks.
    pub collective: &'a mut dyn Collective,
    /// Prescribed dofs (`3·p + component`, local numbering), sorted.
    pub constrained: &'a [usize],
}

/// [`Physical`] as a [`NonlinearProblem`].
pub struct PhysicsProblem<'a> {
    parts: Physical<'a>,
    measure: ConvergenceMeasure,
    /// X of every unknown when the unknowns are coordinates.
    reference: Option<Vec<f64>>,
    /// Held points (local indices, sorted).
    held: Vec<u32>,
    global_ids: Option<Vec<usize>>,
    /// The tangent's columns on several ranks, built on the first Jacobian.
    columns: Option<ColumnMap>,
    /// Bonds broken on this rank by the last iterate evaluation.
    broken_bonds: usize,
    evaluations_before: usize,
}

impl<'a> PhysicsProblem<'a> {
    /// The problem over `parts` with no point held, its convergence measure `measure`. On
    /// several ranks the unknowns become this rank's owned free dofs; on one rank they stay
    /// those of `parts.system`.
    pub fn new(parts: Physical<'a>, measure: ConvergenceMeasure, origin: Origin) -> Self {
        let evaluations_before = parts.system.residual_evaluations;
        let mut problem = Self {
            parts,
            measure,
            reference: None,
            held: Vec::new(),
            global_ids: None,
            columns: None,
            broken_bonds: 0,
            evaluations_before,
        };
        if problem.parts.collective.ranks() > 1 {
            problem.set_unknowns();
        }
        if origin == Origin::Coordinates {
            problem.set_reference();
        }
        problem
    }

    /// Holds the points that have too few intact bonds now, for the whole solve (for solvers
    /// that cannot change their unknowns mid-solve).
    pub fn hold_deficient_points(&mut self) {
        let deficient = deficient_points(
            self.parts.model,
            self.parts.state,
            &mut *self.parts.collective,
        );
        self.hold(deficient);
    }

    /// Bonds broken by the last iterate evaluation, summed over the ranks (collective).
    pub fn broken_bonds(&mut self) -> usize {
        let mut broken = [self.broken_bonds as f64];
        self.parts.collective.sum(&mut broken);
        broken[0] as usize
    }

    /// Residual evaluations since the problem was made.
    pub fn residual_evaluations(&self) -> usize {
        self.parts.system.residual_evaluations - self.evaluations_before
    }

    /// The held points this rank owns, as 1-based original ids.
    pub fn held_points(&self) -> Vec<u32> {
        self.held
            .iter()
            .filter(|&&p| !self.parts.collective.is_ghost(p as usize))
            .map(|&p| self.parts.model.points.original_id[p as usize] + 1)
            .collect()
    }

    /// Holds `points` (noting the ones newly held that this rank owns) and renumbers the
    /// unknowns.
    fn hold(&mut self, points: Vec<u32>) {
        let collective = &*self.parts.collective;
        for &p in points
            .iter()
            .filter(|p| self.held.binary_search(p).is_err() && !collective.is_ghost(**p as usize))
        {
            eprintln!(
                "  note: point {} has too few intact bonds for a stiffness; its displacement is held (RANK_DEFICIENT_NODES)",
                self.parts.model.points.original_id[p as usize] + 1
            );
        }
        self.held = points;
        self.set_unknowns();
        if self.reference.is_some() {
            self.set_reference();
        }
    }

    /// The unknowns of this rank with the current held points.
    fn set_unknowns(&mut self) {
        let parts = &mut self.parts;
        parts.system.dofs = owned_unknowns(
            parts.model,
            parts.constrained,
            &self.held,
            &*parts.collective,
        );
        self.columns = None;
        self.global_ids = (parts.collective.ranks() > 1).then(|| {
            parts
                .system
                .dofs
                .free
                .iter()
                .map(|&d| global_dof(&*parts.collective, d))
                .collect()
        });
    }

    fn set_reference(&mut self) {
        let mut reference = vec![0.0; self.parts.system.dofs.len()];
        self.parts
            .system
            .dofs
            .gather(&self.parts.model.points.position, &mut reference);
        self.reference = Some(reference);
    }

    fn agree<T>(&mut self, result: Result<T, SolveError>) -> Result<T, SolveError> {
        agree(&mut *self.parts.collective, result)
    }

    /// r (not F) at the state, with or without damage evolving.
    fn evaluate(&mut self, f: &mut [f64], evaluation: Evaluation) -> Result<(), SolveError> {
        let Physical {
            system,
            model,
            physics,
            state,
            ..
        } = &mut self.parts;
        match evaluation {
            Evaluation::Probe => {
                system.residual_keeping_damage(model, physics, state, f, false)?;
            }
            Evaluation::Iterate => self.broken_bonds = system.residual(model, physics, state, f)?,
        }
        Ok(())
    }

    fn stiffness(&mut self) -> Result<Csr, SolveError> {
        let Physical {
            system,
            model,
            physics,
            state,
            collective,
            constrained,
        } = &mut self.parts;
        if collective.ranks() == 1 {
            return system.stiffness(model, physics, state);
        }
        let map = match &self.columns {
            Some(map) => map,
            None => self.columns.insert(ColumnMap::new(
                model,
                constrained,
                &self.held,
                &**collective,
            )),
        };
        map.stiffness(system, model, physics, state, &**collective)
    }
}

impl NonlinearProblem for PhysicsProblem<'_> {
    fn len(&self) -> usize {
        self.parts.system.dofs.len()
    }

    fn ranks(&self) -> usize {
        self.parts.collective.ranks()
    }

    fn global_ids(&self) -> Option<&[usize]> {
        self.global_ids.as_deref()
    }

    fn unknowns(&self, x: &mut [f64]) {
        self.parts
            .system
            .dofs
            .gather(&self.parts.state.displacement, x);
        if let Some(reference) = &self.reference {
            for (x, reference) in x.iter_mut().zip(reference) {
                *x += reference;
            }
        }
    }

    fn move_to(&mut self, x: &[f64]) {
        let parts = &mut self.parts;
        match &self.reference {
            Some(reference) => {
                let moved: Vec<f64> = x.iter().zip(reference).map(|(x, r)| x - r).collect();
                parts
                    .system
                    .dofs
                    .scatter(&moved, &mut parts.state.displacement);
            }
            None => parts.system.dofs.scatter(x, &mut parts.state.displacement),
        }
        parts.collective.refresh(&mut parts.state.displacement);
        parts
            .state
            .update_current_position(&parts.model.points.position);
    }

    fn residual(
        &mut self,
        x: &[f64],
        f: &mut [f64],
        evaluation: Evaluation,
    ) -> Result<(), SolveError> {
        self.move_to(x);
        let result = self.evaluate(f, evaluation);
        self.agree(result)?;
        f.iter_mut().for_each(|v| *v = -*v);
        Ok(())
    }

    fn jacobian(&mut self, x: &[f64]) -> Result<Csr, SolveError> {
        self.move_to(x);
        let result = self.stiffness();
        self.agree(result)
    }

    fn jacobian_bytes(&self) -> usize {
        self.parts.system.tangent_bytes
    }

    fn groups(&self) -> &[usize] {
        &self.parts.system.dofs.groups
    }

    fn block_diagonal(&mut self, x: &[f64]) -> Result<Vec<f64>, SolveError> {
        self.move_to(x);
        let parts = &self.parts;
        let result = parts
            .system
            .block_diagonal(parts.model, parts.physics, parts.state);
        self.agree(result)
    }

    fn group_label(&self, group: usize) -> String {
        let dofs = &self.parts.system.dofs;
        format!(
            "point {}",
            self.parts.model.points.original_id[dofs.free[dofs.groups[group]] / 3] + 1
        )
    }

    fn any_failed(&mut self, failed: bool) -> bool {
        any_failed(&mut *self.parts.collective, failed)
    }

    fn dot(&mut self, a: &[f64], b: &[f64]) -> f64 {
        let mut sum = [a.iter().zip(b).map(|(a, b)| a * b).sum::<f64>()];
        self.parts.collective.sum(&mut sum);
        sum[0]
    }

    fn convergence_measure(&mut self, f: &[f64]) -> f64 {
        let volume = &self.parts.model.points.volume;
        let dofs = &self.parts.system.dofs;
        if self.parts.collective.ranks() == 1 {
            return self.measure.of(f, dofs, volume);
        }
        let scaled: Vec<f64> = match self.measure {
            ConvergenceMeasure::ForceDensity { .. } => f
                .iter()
                .zip(&dofs.free)
                .map(|(r, &dof)| r / volume[dof / 3])
                .collect(),
            _ => Vec::new(),
        };
        match self.measure {
            ConvergenceMeasure::PeridigmQuasiStatic => {
                let largest = f.iter().fold(0.0f64, |m, r| m.max(r.abs()));
                let largest = self.parts.collective.max(largest);
                self.dot(f, f).sqrt() + 20.0 * largest
            }
            ConvergenceMeasure::TwoNorm => self.dot(f, f).sqrt(),
            ConvergenceMeasure::ForceDensity { scale } => scale * self.dot(&scaled, &scaled).sqrt(),
        }
    }

    fn probe_scale(&self) -> f64 {
        self.parts
            .state
            .current_position
            .iter()
            .flat_map(|y| y.iter())
            .fold(0.0f64, |m, y| m.max(y.abs()))
            .max(f64::MIN_POSITIVE)
    }

    fn update_unknowns(&mut self) -> Result<bool, SolveError> {
        let deficient = deficient_points(
            self.parts.model,
            self.parts.state,
            &mut *self.parts.collective,
        );
        if deficient == self.held {
            return Ok(false);
        }
        self.hold(deficient);
        Ok(true)
    }

    /// The one-hop PMB-like operator of [`crate::backend::native::one_hop_operator`] with each
    /// block's bulk modulus and horizon, the current bond damage and, for Newmark, the mass
    /// term; the six rigid-body modes as its near-null space. On several ranks it is
    /// assembled, as the tangent is ([`ColumnMap`]), over the free dofs of the owned and ghost
    /// points, and the owned rows are kept with global columns: each owned point's row holds
    /// its bonds to the other ranks' points too, so the operator is the one-rank operator's
    /// rows whatever the partition.
    fn preconditioning_operator(&mut self) -> Result<Option<PreconditioningOperator>, SolveError> {
        if self.parts.collective.ranks() > 1 && self.columns.is_none() {
            let Physical {
                model,
                collective,
                constrained,
                ..
            } = &self.parts;
            self.columns = Some(ColumnMap::new(
                model,
                constrained,
                &self.held,
                &**collective,
            ));
        }
        let Physical {
            system,
            model,
            physics,
            state,
            collective,
            ..
        } = &self.parts;
        let micromodulus: Vec<f64> = model
            .points
            .block
            .iter()
            .map(|&b| {
                let material = &physics.blocks[b as usize].material;
                pmb_micromodulus(material.bulk_modulus(), material.horizon())
            })
            .collect();
        let mass: Option<Vec<f64>> = system.inertia.as_ref().map(|inertia| {
            physics
                .density
                .iter()
                .zip(&model.points.volume)
                .map(|(rho, v)| rho * v * inertia.factor)
                .collect()
        });
        // One rank: the unknowns themselves; several: owned and ghost free dofs.
        let dofs = match &self.columns {
            Some(columns) if collective.ranks() > 1 => &columns.dofs,
            _ => &system.dofs,
        };
        let matrix = one_hop_operator(&OneHopInput {
            position: &model.points.position,
            volume: &model.points.volume,
            bonds: &model.bonds,
            micromodulus: &micromodulus,
            bond_damage: state.bond_damage(),
            diagonal_shift: mass.as_deref(),
            dof_index: &dofs.index,
            unknowns: dofs.len(),
            stencil: Stencil::Nearest,
        });
        let matrix = match &self.columns {
            Some(columns) if collective.ranks() > 1 => {
                columns.owned_rows(&matrix, 3 * collective.global_points())
            }
            _ => matrix,
        };
        Ok(Some(PreconditioningOperator {
            matrix,
            null_space: rigid_body_modes(&model.points.position, &system.dofs.free),
            modes: 6,
        }))
    }

    fn near_null_space(&self) -> Option<(Vec<f64>, usize)> {
        let Physical { system, model, .. } = &self.parts;
        Some((
            rigid_body_modes(&model.points.position, &system.dofs.free),
            6,
        ))
    }

    /// The unknowns, the bond damage and the inertia factor: everything
    /// [`Self::preconditioning_operator`] reads that can change during a run (positions,
    /// volumes, bonds and moduli are the reference configuration's).
    fn preconditioning_version(&mut self) -> usize {
        let Physical {
            system,
            state,
            collective,
            ..
        } = &mut self.parts;
        let mut fingerprint = Fingerprint::default();
        fingerprint.add(system.dofs.free.len() as u64);
        system
            .dofs
            .free
            .iter()
            .for_each(|&dof| fingerprint.add(dof as u64));
        if let Some(damage) = state.bond_damage() {
            damage.chunks(2).for_each(|pair| {
                fingerprint.add(pair.iter().fold(0, |w, d| w << 32 | u64::from(d.to_bits())))
            });
        }
        if let Some(inertia) = &system.inertia {
            fingerprint.add(inertia.factor.to_bits());
        }
        agreed(fingerprint, &mut **collective) as usize
    }
}

/// The sum of every rank's `fingerprint` (collective), in two 32-bit halves so that f64 sums
/// stay exact.
fn agreed(fingerprint: Fingerprint, collective: &mut dyn Collective) -> u64 {
    let hash = fingerprint.value();
    if collective.ranks() == 1 {
        return hash;
    }
    let mut halves = [(hash >> 32) as f64, (hash & 0xffff_ffff) as f64];
    collective.sum(&mut halves);
    (halves[0] as u64) << 32 ^ halves[1] as u64
}
