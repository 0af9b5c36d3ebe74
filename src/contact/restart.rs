//! What a restart file keeps of contact ([`crate::restart`]): the positions of the last
//! search and the last contact force. The candidate list is not stored: the search is a
//! function of the positions it was made at, so searching again at them rebuilds it exactly
//! (on N ranks too: the search of [`Contact::search_on_ranks`] gives the one-rank candidates).

use super::{Contact, ContactState};
use crate::model::Model;
use crate::parallel::Communicator;

impl ContactState {
    /// Positions of the contact points ([`Contact::searched_points`] order) at the last
    /// search; `None` before the first.
    pub fn searched_at(&self) -> Option<&[[f64; 3]]> {
        self.candidates
            .as_ref()
            .map(|_| self.searched_at.as_slice())
    }
}

impl Contact {
    /// The contact points whose search positions this rank's state keeps
    /// ([`ContactState::searched_at`]), as indices of the rank's model: every contact point on
    /// one rank, the owned ones on N ([`Contact::on_ranks`]).
    pub fn searched_points(&self) -> &[u32] {
        match &self.ranks {
            Some(ranks) => ranks.owned_local(),
            None => &self.points,
        }
    }

    /// The state of a run whose last search was made with the contact points at
    /// `searched_at` ([`Contact::searched_points`] order; `None`: no search yet) and whose last
    /// contact force density was `force_density` (every point of the rank's `model`): the
    /// search is made again at those positions. `current` gives the positions of the other
    /// points (the search reads only contact points). Collective on N ranks (the search is).
    pub fn restored_state(
        &self,
        model: &Model,
        comm: &dyn Communicator,
        searched_at: Option<&[[f64; 3]]>,
        force_density: Vec<[f64; 3]>,
        current: &[[f64; 3]],
    ) -> ContactState {
        let mut state = self.initial_state();
        state.force_density = force_density;
        if let Some(searched_at) = searched_at {
            let mut positions = current.to_vec();
            for (&p, y) in self.searched_points().iter().zip(searched_at) {
                positions[p as usize] = *y;
            }
            if self.is_on_ranks() {
                self.search_on_ranks(&mut state, comm, &positions);
            } else {
                self.search(&mut state, model, &positions);
            }
        }
        state
    }
}
