//! Contact on one rank of a distributed run: the same candidates and forces as one rank.
//!
//! # Design
//! Contact partners are whatever points come within the search radius in the *deformed*
//! configuration, not the bond ghosts of [`crate::parallel::HaloPlan`], so contact keeps its
//! own proximity exchange, rebuilt with every search:
//!
//! * **Search** (collective): every rank sends the current positions of its owned contact
//!   points to every rank ([`Communicator::all_gather`]), then searches the candidate rows of
//!   its owned points against all contact points with the same pair test as one rank
//!   ([`super::find_candidates_for`]). "May touch" reads, for each owned point, every point
//!   bonded to it either way in the *global* bond list (its family and the one-way bonds into
//!   it), so it is exact for owned points. Rows are ascending in the global run order, as on
//!   one rank.
//! * **Partner exchange**: from those rows each rank builds a [`PartnerExchange`]: it
//!   receives the positions and velocities of the partners other ranks own and sends its own
//!   points that are partners of theirs. No messages are needed to agree on the lists
//!   because the candidate relation is symmetric (the distance test |y_j − y_i|² ≤ R² reads
//!   the same squares either way round, the block-pair table is symmetric, and so is "bonded
//!   either way").
//! * **Every force evaluation**: one partner exchange (six numbers per partner: position and
//!   the velocity friction reads), then each owned point sums the pair law over its candidate
//!   row in row order ([`super::force_on_point`], shared with one rank), so its force is
//!   bitwise the one-rank force.
//! * **Skin rule**: the largest displacement since the last search is the maximum over ranks
//!   of each rank's owned maximum ([`Communicator::max`]), so every rank searches early at the
//!   same evaluation. Scheduled searches fall on the same steps everywhere.
//!
//! # Cost
//! A search moves 3 numbers per contact point to every rank (O(N) received per rank, O(N·P)
//! in all) and builds a cell grid over all contact points on every rank (O(N) work per rank).
//! That is acceptable for now because searches are rare (every `Search Frequency` steps, or
//! when a point has moved a quarter of the contact radius) and every rank already holds the
//! whole model (O(N) memory), while the per-step work and messages scale with the owned
//! points and their partners. A search against a halo of neighbouring subdomains' bounding
//! boxes grown by R would make it O(N/P + surface).

use super::PointData;
use super::{
    find_candidates_for, force_on_point, max_displacement, Contact, ContactState, OneWayBonds,
};
use crate::model::BondList;
use crate::model::Model;
use crate::parallel::{Communicator, Partition, PartnerExchange};
use rayon::prelude::*;
use std::time::Instant;

/// What the contact of one rank keeps besides the serial state (global numbering unless said).
#[derive(Debug, Clone)]
pub(super) struct OnRanks {
    rank: usize,
    /// Owning rank of every point.
    owner: Vec<u32>,
    /// Contact points owned here: global indices (ascending) and their local indices.
    owned_global: Vec<u32>,
    owned_local: Vec<u32>,
    /// Contact points of every rank, rank after rank: the layout of the search gather.
    gather_order: Vec<u32>,
    /// Numbers each rank contributes to the search gather (3 per owned contact point).
    gather_counts: Vec<usize>,
    /// Block, horizon and volume of every point.
    block: Vec<u32>,
    horizon: Vec<f64>,
    volume: Vec<f64>,
    /// Rows of the owned contact points: every point bonded to them either way (ascending);
    /// the other rows are empty.
    bonded: BondList,
    no_one_way: OneWayBonds,
}

impl OnRanks {
    /// Local indices of the contact points owned here (ascending).
    pub(super) fn owned_local(&self) -> &[u32] {
        &self.owned_local
    }

    /// The rank's part of [`Contact::initial_state`]: no partners yet.
    pub(super) fn initial_state(&self) -> RankState {
        let n = self.owner.len();
        RankState {
            current: vec![[0.0; 3]; n],
            velocity: vec![[0.0; 3]; n],
            partners: PartnerExchange::default(),
            max_received: 0,
            received: Vec::new(),
        }
    }
}

/// What the contact of one rank changes during a run besides the serial state (global
/// numbering): the partner exchange of the last search and its buffers.
#[derive(Debug, Clone)]
pub(super) struct RankState {
    /// Positions and velocities; valid at owned contact points and received partners.
    current: Vec<[f64; 3]>,
    velocity: Vec<[f64; 3]>,
    partners: PartnerExchange,
    /// Largest number of partners received from other ranks after any search.
    max_received: usize,
    /// Scratch of the partner exchange: received (point, position, velocity).
    received: Vec<(u32, [f64; 6])>,
}

impl ContactState {
    /// The rank's partner exchange.
    fn rank_state(&mut self) -> &mut RankState {
        self.ranks
            .as_deref_mut()
            .expect("the contact state of a serial run has no ranks")
    }

    /// Partner points this rank receives at each force evaluation since the last search, and
    /// the most after any search (0 in serial runs).
    pub fn received_partners(&self) -> (usize, usize) {
        self.ranks.as_ref().map_or((0, 0), |r| {
            (r.partners.volume().received_points, r.max_received)
        })
    }
}

impl Contact {
    /// Turns the contact of the *global* model (from [`Contact::from_deck`] with the model
    /// every rank holds) into rank `rank`'s share: `partition` is the run's partition and
    /// `local_points[l]` the global index of local point l of the rank's model (increasing).
    /// Forces are then kept in the local numbering ([`ContactState::force_density`]) and
    /// filled at owned points only; the rank must call [`Contact::compute_force_on_ranks`] and
    /// [`Contact::scheduled_search_on_ranks`] instead of the serial methods.
    ///
    /// Cost: a search moves 3 numbers per contact point to every rank and grids all contact
    /// points on every rank (O(N) per rank, acceptable while searches are rare and every rank
    /// holds the whole model anyway); each force evaluation moves 6 numbers per off-rank
    /// partner and does the work of the owned points only. Memory: O(N) per rank (positions,
    /// velocities, blocks, horizons and volumes of all points in global numbering).
    pub fn on_ranks(
        mut self,
        global: &Model,
        partition: &Partition,
        rank: usize,
        local_points: &[u32],
    ) -> Self {
        let n = global.points.len();
        assert_eq!(partition.owner.len(), n, "partition of another model");
        let mine = |g: u32| partition.owner[g as usize] as usize == rank;
        let owned_global: Vec<u32> = self.points.iter().copied().filter(|&g| mine(g)).collect();
        let owned_local: Vec<u32> = owned_global
            .iter()
            .map(|&g| {
                local_points
                    .binary_search(&g)
                    .expect("owned points are local") as u32
            })
            .collect();
        let mut is_contact = vec![false; n];
        for &p in &self.points {
            is_contact[p as usize] = true;
        }
        let per_rank: Vec<Vec<u32>> = partition
            .owned
            .iter()
            .map(|points| {
                let mut points: Vec<u32> = points
                    .iter()
                    .copied()
                    .filter(|&g| is_contact[g as usize])
                    .collect();
                points.sort_unstable();
                points
            })
            .collect();
        let gather_counts = per_rank.iter().map(|p| 3 * p.len()).collect();
        let gather_order = per_rank.concat();
        let mut bonded = BondList {
            offsets: Vec::with_capacity(n + 1),
            neighbor: Vec::new(),
            reference_length: Vec::new(),
        };
        bonded.offsets.push(0);
        let mut cursor = owned_global.iter().peekable();
        for i in 0..n {
            if cursor.peek().is_some_and(|&&g| g as usize == i) {
                cursor.next();
                let mut row: Vec<u32> = global
                    .bonds
                    .family(i)
                    .iter()
                    .chain(self.one_way_bonds.into_point(i))
                    .copied()
                    .collect();
                row.sort_unstable();
                row.dedup();
                bonded
                    .reference_length
                    .resize(bonded.reference_length.len() + row.len(), 0.0);
                bonded.neighbor.extend(row);
            }
            bonded.offsets.push(bonded.neighbor.len());
        }
        self.one_way_bonds = OneWayBonds::none(0);
        self.force_points = local_points.len();
        self.ranks = Some(Box::new(OnRanks {
            rank,
            owner: partition.owner.clone(),
            owned_global,
            owned_local,
            gather_order,
            gather_counts,
            block: global.points.block.clone(),
            horizon: global.horizon.clone(),
            volume: global.points.volume.clone(),
            bonded,
            no_one_way: OneWayBonds::none(n),
        }));
        self
    }

    /// True for the contact of one rank of a distributed run ([`Contact::on_ranks`]).
    pub fn is_on_ranks(&self) -> bool {
        self.ranks.is_some()
    }

    /// Searches now (collective): gathers the positions of all contact points from `current`
    /// (this rank's local positions), searches the rows of the owned points and rebuilds the
    /// partner exchange.
    pub fn search_on_ranks(
        &self,
        state: &mut ContactState,
        comm: &dyn Communicator,
        current: &[[f64; 3]],
    ) {
        let start = Instant::now();
        let ranks = self.on_ranks_part();
        let exchange = state.rank_state();
        let mut mine = Vec::with_capacity(3 * ranks.owned_local.len());
        for &l in &ranks.owned_local {
            mine.extend_from_slice(&current[l as usize]);
        }
        let all = comm.all_gather(&mine, &ranks.gather_counts);
        for (k, &g) in ranks.gather_order.iter().enumerate() {
            exchange.current[g as usize] = [all[3 * k], all[3 * k + 1], all[3 * k + 2]];
        }
        let block = &ranks.block;
        let list = find_candidates_for(
            &self.points,
            &ranks.owned_global,
            &exchange.current,
            self.search_radius,
            self.backend,
            Some((&ranks.bonded, &ranks.no_one_way)),
            |i, j| self.pair_model[block[i] as usize * self.blocks + block[j] as usize].is_some(),
        );
        exchange.partners = PartnerExchange::build(
            ranks.rank,
            &ranks.owner,
            ranks
                .owned_global
                .iter()
                .map(|&g| (g, list.row(g as usize))),
        );
        exchange.max_received = exchange
            .max_received
            .max(exchange.partners.volume().received_points);
        state.searched_at = ranks
            .owned_local
            .iter()
            .map(|&l| current[l as usize])
            .collect();
        state.searched(list, start.elapsed().as_secs_f64());
    }

    /// The rank's share of the contact.
    fn on_ranks_part(&self) -> &OnRanks {
        self.ranks
            .as_deref()
            .expect("the contact of a serial run has no ranks")
    }

    /// [`Contact::scheduled_search`] on one rank (collective; the schedule is the same on
    /// every rank).
    pub fn scheduled_search_on_ranks(
        &self,
        state: &mut ContactState,
        comm: &dyn Communicator,
        step: u64,
        current: &[[f64; 3]],
    ) {
        if step % self.search_frequency == 0 {
            self.search_on_ranks(state, comm, current);
            state.statistics.scheduled_searches += 1;
        }
    }

    /// The skin rule over all ranks (collective): true when no search ran yet or some contact
    /// point of any rank moved more than (R − r_c,max)/2 since the last search.
    pub fn needs_search_on_ranks(
        &self,
        state: &ContactState,
        comm: &dyn Communicator,
        current: &[[f64; 3]],
    ) -> bool {
        if state.candidates.is_none() {
            return true;
        }
        let owned = &self.on_ranks_part().owned_local;
        let local = max_displacement(owned, &state.searched_at, current);
        2.0 * comm.max(local) > self.search_radius - self.max_contact_radius
    }

    /// [`Contact::compute_force`] on one rank (collective): searches first when the skin rule
    /// asks any rank to, exchanges the partners' positions and velocities, and sums the force
    /// of every owned contact point over its candidate row. `current` and `velocity` are the
    /// local arrays (owned entries must be up to date; ghost entries are not read). Returns the
    /// force density in local numbering (zero at ghosts).
    pub fn compute_force_on_ranks<'s>(
        &self,
        state: &'s mut ContactState,
        comm: &dyn Communicator,
        current: &[[f64; 3]],
        velocity: &[[f64; 3]],
    ) -> &'s [[f64; 3]] {
        if state.candidates.is_none() {
            self.search_on_ranks(state, comm, current);
            state.statistics.initial_searches += 1;
        } else if self.needs_search_on_ranks(state, comm, current) {
            self.search_on_ranks(state, comm, current);
            state.statistics.early_searches += 1;
        }
        let reject_beyond = self.reject_beyond();
        let ranks = self.on_ranks_part();
        let exchange = state
            .ranks
            .as_deref_mut()
            .expect("the contact state of a serial run has no ranks");
        for (&g, &l) in ranks.owned_global.iter().zip(&ranks.owned_local) {
            exchange.current[g as usize] = current[l as usize];
            exchange.velocity[g as usize] = velocity[l as usize];
        }
        exchange.received.clear();
        {
            let (y, v, received) = (
                &exchange.current,
                &exchange.velocity,
                &mut exchange.received,
            );
            exchange.partners.exchange(
                comm,
                6,
                |p, out| {
                    out[..3].copy_from_slice(&y[p as usize]);
                    out[3..].copy_from_slice(&v[p as usize]);
                },
                |p, values| received.push((p, std::array::from_fn(|k| values[k]))),
            );
        }
        for &(p, values) in &exchange.received {
            exchange.current[p as usize] = [values[0], values[1], values[2]];
            exchange.velocity[p as usize] = [values[3], values[4], values[5]];
        }
        let candidates = state.candidates.as_ref().expect("searched above");
        let laws = self.laws();
        let points = PointData {
            block: &ranks.block,
            horizon: &ranks.horizon,
            volume: &ranks.volume,
            current: &exchange.current,
            velocity: &exchange.velocity,
        };
        let forces: Vec<([f64; 3], usize)> = ranks
            .owned_global
            .par_iter()
            .map(|&g| {
                force_on_point(
                    laws,
                    points,
                    reject_beyond,
                    g as usize,
                    candidates.row(g as usize),
                )
            })
            .collect();
        state.force_density.fill([0.0; 3]);
        let mut touching = 0;
        for (&l, (force, count)) in ranks.owned_local.iter().zip(forces) {
            state.force_density[l as usize] = force;
            touching += count;
        }
        state.statistics.pairs_in_contact = touching / 2;
        &state.force_density
    }
}
