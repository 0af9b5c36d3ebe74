//! What an implicit solve needs from the run when it is distributed over MPI ranks: the halo
//! exchange of a point field, sums over ranks, and which local points are ghosts. A serial run
//! passes [`SerialRun`], whose operations are free; a distributed run passes its halo plan and
//! communicator (see `simulation::distributed`).
//!
//! Every method except the queries is collective: all ranks call it in the same order.

/// The collective operations and the ownership queries of an implicit solve.
pub trait Collective {
    /// This rank (0-based).
    fn rank(&self) -> usize;
    /// Number of ranks.
    fn ranks(&self) -> usize;
    /// Overwrites the ghost entries of a point field with their owners' values.
    fn refresh(&mut self, field: &mut [[f64; 3]]);
    /// Element-wise sum over the ranks, in place.
    fn sum(&mut self, values: &mut [f64]);
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
pub struct SerialRun {
    /// Points of the model.
    pub points: usize,
}

impl Collective for SerialRun {
    fn rank(&self) -> usize {
        0
    }

    fn ranks(&self) -> usize {
        1
    }

    fn refresh(&mut self, _field: &mut [[f64; 3]]) {}

    fn sum(&mut self, _values: &mut [f64]) {}

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
