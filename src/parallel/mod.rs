//! Who owns which point: the partition of the points over MPI ranks, the ghost (halo) points
//! each rank reads, and the communicator that moves data between ranks.
//!
//! # How a distributed run is laid out
//! Every rank reads the deck and builds the global [`crate::model::Model`] without families
//! ([`crate::setup::build_points`]: points, blocks, node sets, conditions; O(points) memory),
//! so bad input fails on every rank the same way before any message is sent. Then
//! [`Subdomain::searched`]:
//! 1. weighs the points by family size (each rank searches a 1/ranks slice, one all-gather)
//!    and cuts them by recursive coordinate bisection ([`Partition::bisect`]; every rank
//!    computes the same cut);
//! 2. searches the families of its owned points, which name the layer-1 ghosts (the off-rank
//!    points one bond away), then theirs, which name the layer-2 ghosts when [`halo_depth`]
//!    is 2, then the outer layer's;
//! 3. tells every owner which of its points it holds as ghosts ([`HaloPlan::from_ghosts`]);
//! 4. builds the rank's own [`crate::model::Model`] over owned + ghost points, numbered in the
//!    global run order (so every row keeps its bond order and every per-point sum its order
//!    of operations).
//!
//! No rank holds the global bond list. Contact decks and the QuickGrid cylinder do (contact
//! searches need the global bonds; the cylinder's families come from index space): there
//! [`Subdomain::new`] cuts the subdomain out of the global families with [`Partition::of_bonds`]
//! and [`HaloPlan::build`], without messages, to the same result.
//!
//! # Ghost depth, and why no dilatation exchange is needed
//! The materials and damage models are set up over the owned points and the ghosts (at depth 2
//! the outer layer only when blocks differ in damage model, see
//! [`outer_ghosts_need_physics`]), each ghost's row holding the bonds to other local points. Before each force evaluation the
//! current positions of the ghosts are exchanged (owner → ghosts); everything else a ghost
//! needs is recomputed locally, from the same inputs in the same order as on its owner, so it
//! is bitwise the owner's value:
//! * bond damage of a row is a function of the two end positions only (critical stretch), so
//!   ghost rows break exactly when the owner's rows do, and the reverse bond that the
//!   multi-block interface rule reads (`max(d_ij, d_ji)`) is present locally;
//! * a state-based (LPS) force on an owned point i reads the dilatation θ_j of every
//!   neighbour j. With depth 2, the one-hop ghosts' rows are complete (their neighbours are
//!   local), so θ_j is computed locally — a second ghost layer of positions instead of a
//!   second exchange per step (the force path of [`crate::physics`] has no hook between its
//!   dilatation and force passes, and one exchange per step costs one latency instead of two);
//! * a bond-based (PMB) force reads only the neighbours' positions and the constant c/2 they
//!   publish, so depth 1 suffices.
//!
//! Forces and accelerations of ghosts are never used (their rows may be truncated).
//! No force is accumulated from ghosts to owners: every owned point's force is the gather over
//! its complete row, so [`HaloPlan`] has no `accumulate` step.
//!
//! # Contact
//! Contact partners are the points within the contact radius in the *deformed*
//! configuration, which the bond ghosts do not cover. Contact keeps its own exchange, rebuilt
//! with every proximity search: the search gathers the positions of all contact points on
//! every rank ([`Communicator::all_gather`]), each rank searches the rows of its owned points,
//! and a [`PartnerExchange`] then moves the positions and velocities of the off-rank partners
//! at every force evaluation until the next search (see [`crate::contact`], "On N ranks",
//! and [`crate::contact::Contact::on_ranks`]).
//!
//! # One interface to the other ranks
//! A run and its solvers talk to the other ranks through [`Ranks`] alone: reductions, the
//! refresh of the ghosts' positions, and which local points are ghosts. [`SerialRanks`] is the
//! one-rank implementation (every operation free), [`SubdomainRanks`] one rank of a
//! distributed run. Underneath, a [`Communicator`] moves the messages (MPI, or threads in unit
//! tests); [`Serial`] is the one-rank communicator: reductions return their argument,
//! exchanges have no neighbours.

mod halo;
#[cfg(feature = "mpi")]
mod mpi;
mod partition;
mod partner;
mod ranks;
mod rules;
mod subdomain;
#[cfg(test)]
pub(crate) mod thread_comm;

pub use halo::{HaloPlan, HaloValue, HaloVolume};
#[cfg(feature = "mpi")]
pub use mpi::MpiCommunicator;
pub use partition::Partition;
pub use partner::PartnerExchange;
pub use ranks::{first_failure, Ranks, SerialRanks, SubdomainRanks};
pub use rules::{check_distributable, global_families_reason};
pub use subdomain::{halo_depth, outer_ghosts_need_physics, Subdomain};

/// The message transport between the ranks, under [`Ranks`]. Every method except [`Communicator::rank`],
/// [`Communicator::size`] and [`Communicator::abort`] is collective: all ranks call it, in
/// the same order, or the run hangs.
pub trait Communicator {
    /// This rank, 0-based.
    fn rank(&self) -> usize;

    /// Number of ranks.
    fn size(&self) -> usize;

    /// Element-wise sum over all ranks, in place (every rank gets the result).
    fn sum(&self, values: &mut [f64]);

    /// Minimum over all ranks (every rank gets the result).
    fn min(&self, value: f64) -> f64;

    /// Point-to-point exchange: sends `sends[k].1` to rank `sends[k].0` and receives
    /// `receives[k].1` (whose length the caller knows) from rank `receives[k].0`, all posted
    /// non-blocking and waited for together. Both sides list the same pairs.
    fn exchange(&self, sends: &[(usize, &[f64])], receives: &mut [(usize, &mut [f64])]);

    /// Gathers `local` of every rank on rank 0: `counts[r]` values from rank r, concatenated
    /// in rank order. Rank 0 gets `Some`, the others `None`.
    fn gather(&self, local: &[f64], counts: &[usize]) -> Option<Vec<f64>>;

    /// Gathers `local` of every rank on every rank: `counts[r]` values from rank r,
    /// concatenated in rank order (MPI_Allgatherv). `counts` is the same on every rank and
    /// `counts[self.rank()] == local.len()`.
    fn all_gather(&self, local: &[f64], counts: &[usize]) -> Vec<f64>;

    /// Maximum over all ranks (every rank gets the result).
    fn max(&self, value: f64) -> f64 {
        -self.min(-value)
    }

    /// Ends every rank at once (MPI_Abort): the last resort when ranks can no longer agree.
    fn abort(&self, code: i32) -> !;
}

/// The one-rank communicator: no messages, no overhead.
#[derive(Debug, Clone, Copy, Default)]
pub struct Serial;

impl Communicator for Serial {
    fn rank(&self) -> usize {
        0
    }

    fn size(&self) -> usize {
        1
    }

    fn sum(&self, _values: &mut [f64]) {}

    fn min(&self, value: f64) -> f64 {
        value
    }

    fn exchange(&self, sends: &[(usize, &[f64])], receives: &mut [(usize, &mut [f64])]) {
        assert!(
            sends.is_empty() && receives.is_empty(),
            "a one-rank run has no neighbours to exchange with"
        );
    }

    fn gather(&self, local: &[f64], counts: &[usize]) -> Option<Vec<f64>> {
        assert_eq!(counts, [local.len()]);
        Some(local.to_vec())
    }

    fn all_gather(&self, local: &[f64], counts: &[usize]) -> Vec<f64> {
        assert_eq!(counts, [local.len()]);
        local.to_vec()
    }

    fn abort(&self, code: i32) -> ! {
        std::process::exit(code)
    }
}
