//! [`Ranks`]: the one interface a run and its solvers use to talk to the other ranks, with
//! [`SerialRanks`] for one rank (every operation free) and [`SubdomainRanks`] for one rank of
//! a distributed run (its [`Communicator`] and the halo plan of its [`super::Subdomain`]).
//!
//! The [`Communicator`] underneath is the message transport (MPI, or the threads of a unit
//! test); a run never calls it directly except through [`Ranks::communicator`], for the
//! gathers of its outputs and the exchanges of contact.

use super::{Communicator, HaloPlan, Serial};
use crate::model::Model;

/// What a run and its solvers need from the other ranks: who this rank is, reductions, the
/// refresh of the ghost entries of a point field, and which local points are ghosts.
///
/// Every method except the queries ([`Ranks::rank`], [`Ranks::ranks`], [`Ranks::is_ghost`],
/// [`Ranks::global_point`], [`Ranks::global_points`], [`Ranks::ghost_constrained_dofs`],
/// [`Ranks::communicator`]) is collective: all ranks call it, in the same order, or the run
/// hangs.
pub trait Ranks {
    /// The message transport between the ranks ([`Serial`] on one rank).
    fn communicator(&self) -> &dyn Communicator;

    /// This rank (0-based).
    fn rank(&self) -> usize {
        self.communicator().rank()
    }

    /// Number of ranks.
    fn ranks(&self) -> usize {
        self.communicator().size()
    }

    /// Element-wise sum over the ranks, in place (every rank gets the result).
    fn sum(&mut self, values: &mut [f64]) {
        self.communicator().sum(values);
    }

    /// Smallest value over the ranks.
    fn min(&mut self, value: f64) -> f64 {
        self.communicator().min(value)
    }

    /// Largest value over the ranks.
    fn max(&mut self, value: f64) -> f64 {
        self.communicator().max(value)
    }

    /// Overwrites the ghost entries of a point field with their owners' values.
    fn refresh(&mut self, field: &mut [[f64; 3]]);

    /// True when local point `p` is a ghost (owned by another rank).
    fn is_ghost(&self, p: usize) -> bool;

    /// The run-wide index of local point `p` (the same on every rank).
    fn global_point(&self, p: usize) -> usize;

    /// Number of points of the whole run.
    fn global_points(&self) -> usize;

    /// Prescribed dofs (`3·p + component`, local numbering) of the ghost points, sorted: the
    /// local model lists only the owned points' conditions.
    fn ghost_constrained_dofs(&self) -> Vec<usize>;
}

/// A run on one rank: no ghosts, no messages.
#[derive(Debug, Clone, Copy)]
pub struct SerialRanks {
    /// Points of the model.
    pub points: usize,
}

impl Ranks for SerialRanks {
    fn communicator(&self) -> &dyn Communicator {
        &Serial
    }

    fn rank(&self) -> usize {
        0
    }

    fn ranks(&self) -> usize {
        1
    }

    #[inline(always)]
    fn sum(&mut self, _values: &mut [f64]) {}

    fn min(&mut self, value: f64) -> f64 {
        value
    }

    fn max(&mut self, value: f64) -> f64 {
        value
    }

    #[inline(always)]
    fn refresh(&mut self, _field: &mut [[f64; 3]]) {}

    fn is_ghost(&self, _p: usize) -> bool {
        false
    }

    fn global_point(&self, p: usize) -> usize {
        p
    }

    fn global_points(&self) -> usize {
        self.points
    }

    fn ghost_constrained_dofs(&self) -> Vec<usize> {
        Vec::new()
    }
}

/// One rank of a distributed run: its communicator, and the halo plan and ghosts of its
/// subdomain.
pub struct SubdomainRanks<'a> {
    comm: &'a dyn Communicator,
    plan: &'a mut HaloPlan,
    ghost: Vec<bool>,
    global_points: usize,
    ghost_constrained: Vec<usize>,
}

impl<'a> SubdomainRanks<'a> {
    /// The ranks as seen from the subdomain whose model is `local`, halo plan `plan` and ghost
    /// mask `ghost` (see [`super::Subdomain::ghost_mask`]), cut from the run-wide `global`
    /// model (whose conditions name the prescribed dofs of the ghosts).
    pub fn new(
        comm: &'a dyn Communicator,
        plan: &'a mut HaloPlan,
        ghost: Vec<bool>,
        global: &Model,
        local: &Model,
    ) -> Self {
        let ghost_constrained = ghost_constrained_dofs(global, local, plan, &ghost);
        Self {
            comm,
            plan,
            ghost,
            global_points: global.points.len(),
            ghost_constrained,
        }
    }

    /// The halo plan of the subdomain.
    pub fn plan(&self) -> &HaloPlan {
        self.plan
    }
}

impl Ranks for SubdomainRanks<'_> {
    fn communicator(&self) -> &dyn Communicator {
        self.comm
    }

    fn refresh(&mut self, field: &mut [[f64; 3]]) {
        self.plan.exchange(self.comm, field);
    }

    fn is_ghost(&self, p: usize) -> bool {
        self.ghost[p]
    }

    fn global_point(&self, p: usize) -> usize {
        self.plan.global()[p] as usize
    }

    fn global_points(&self) -> usize {
        self.global_points
    }

    fn ghost_constrained_dofs(&self) -> Vec<usize> {
        self.ghost_constrained.clone()
    }
}

/// The prescribed dofs of a rank's ghosts (local numbering `3p + c`), from the run-wide
/// conditions: a ghost may sit in a node set whose points this rank does not own.
fn ghost_constrained_dofs(
    global: &Model,
    local: &Model,
    plan: &HaloPlan,
    ghost: &[bool],
) -> Vec<usize> {
    let global_constrained = global.boundary.constrained_dofs();
    (0..local.points.len())
        .filter(|&p| ghost[p])
        .flat_map(|p| {
            let g = plan.global()[p] as usize;
            (0..3).map(move |c| (p, c, 3 * g + c))
        })
        .filter(|(_, _, dof)| global_constrained.binary_search(dof).is_ok())
        .map(|(p, c, _)| 3 * p + c)
        .collect()
}

/// After a sum over the ranks found that some failed: the lowest failing rank and the largest
/// exit code of the failing ranks (`local_code` is this rank's, `None` when it did not fail).
/// Collective.
pub fn first_failure(comm: &dyn Communicator, local_code: Option<u8>) -> (usize, u8) {
    let rank = comm.rank() as f64;
    let first = comm.min(if local_code.is_some() {
        rank
    } else {
        f64::INFINITY
    });
    let code = -comm.min(local_code.map_or(0.0, |c| -f64::from(c)));
    (first as usize, code as u8)
}
