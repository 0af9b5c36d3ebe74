//! What a restart file keeps of contact ([`crate::restart`]): the positions of the last
//! search and the last contact force. The candidate list is not stored: the search is a
//! function of the positions it was made at, so searching again at them rebuilds it exactly.

use super::{Contact, ContactState};
use crate::model::Model;

impl ContactState {
    /// Positions of the contact points ([`Contact::points`] order) at the last search; `None`
    /// before the first.
    pub fn searched_at(&self) -> Option<&[[f64; 3]]> {
        self.candidates
            .as_ref()
            .map(|_| self.searched_at.as_slice())
    }
}

impl Contact {
    /// The state of a serial run whose last search was made with the contact points at
    /// `searched_at` ([`Contact::points`] order; `None`: no search yet) and whose last contact
    /// force density was `force_density`: the search is made again at those positions.
    /// `current` gives the positions of the other points (the search reads only contact points).
    pub fn restored_state(
        &self,
        model: &Model,
        searched_at: Option<&[[f64; 3]]>,
        force_density: Vec<[f64; 3]>,
        current: &[[f64; 3]],
    ) -> ContactState {
        let mut state = self.initial_state();
        state.force_density = force_density;
        if let Some(searched_at) = searched_at {
            let mut positions = current.to_vec();
            for (&p, y) in self.points.iter().zip(searched_at) {
                positions[p as usize] = *y;
            }
            self.search(&mut state, model, &positions);
        }
        state
    }
}
