//! The ghost points of one rank and the messages that refresh them.

use super::{Communicator, Partition};
use crate::model::BondList;

/// A per-point value that travels in a halo exchange as `WIDTH` f64 numbers.
pub trait HaloValue: Copy {
    /// Numbers per point.
    const WIDTH: usize;
    /// Writes the value into `out` (length `WIDTH`).
    fn pack(&self, out: &mut [f64]);
    /// Reads a value from `input` (length `WIDTH`).
    fn unpack(input: &[f64]) -> Self;
}

impl HaloValue for f64 {
    const WIDTH: usize = 1;
    fn pack(&self, out: &mut [f64]) {
        out[0] = *self;
    }
    fn unpack(input: &[f64]) -> Self {
        input[0]
    }
}

impl HaloValue for [f64; 3] {
    const WIDTH: usize = 3;
    fn pack(&self, out: &mut [f64]) {
        out.copy_from_slice(self);
    }
    fn unpack(input: &[f64]) -> Self {
        [input[0], input[1], input[2]]
    }
}

/// The points one rank exchanges with one other rank.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) struct Peer {
    /// The other rank.
    pub(super) rank: usize,
    /// The points, in the order both sides agree on (the bond halo: local indices in
    /// increasing global index; the partner exchange: global indices, ascending).
    pub(super) points: Vec<u32>,
}

/// The messages of one kind of exchange: the points sent to and received from each other
/// rank, with buffers for their numbers that later exchanges reuse. The bond halo
/// ([`HaloPlan`]) and the contact partner exchange ([`super::PartnerExchange`]) both move their
/// points this way.
#[derive(Debug, Clone, Default, PartialEq)]
pub(super) struct Messages {
    /// Points sent, per rank.
    pub(super) sends: Vec<Peer>,
    /// Points received, per rank.
    pub(super) receives: Vec<Peer>,
    send_buffers: Vec<Vec<f64>>,
    receive_buffers: Vec<Vec<f64>>,
}

impl Messages {
    /// The messages of these send and receive lists.
    pub(super) fn new(sends: Vec<Peer>, receives: Vec<Peer>) -> Self {
        Self {
            send_buffers: vec![Vec::new(); sends.len()],
            receive_buffers: vec![Vec::new(); receives.len()],
            sends,
            receives,
        }
    }

    /// Points and ranks one exchange involves.
    pub(super) fn volume(&self) -> HaloVolume {
        HaloVolume {
            received_points: self.receives.iter().map(|n| n.points.len()).sum(),
            sent_points: self.sends.iter().map(|n| n.points.len()).sum(),
            neighbor_ranks: self.receives.len().max(self.sends.len()),
        }
    }

    /// Sends `width` numbers per sent point, written by `pack(point, out)`, and receives those
    /// of the received points (collective over the partner ranks: non-blocking messages waited
    /// for together); [`Messages::received`] then reads them. Nothing happens on a rank that
    /// exchanges with no other.
    pub(super) fn swap(
        &mut self,
        comm: &dyn Communicator,
        width: usize,
        pack: impl Fn(u32, &mut [f64]),
    ) {
        if self.sends.is_empty() && self.receives.is_empty() {
            return;
        }
        for (peer, buffer) in self.sends.iter().zip(&mut self.send_buffers) {
            buffer.resize(peer.points.len() * width, 0.0);
            for (k, &p) in peer.points.iter().enumerate() {
                pack(p, &mut buffer[k * width..(k + 1) * width]);
            }
        }
        for (peer, buffer) in self.receives.iter().zip(&mut self.receive_buffers) {
            buffer.resize(peer.points.len() * width, 0.0);
        }
        swap_buffers(
            comm,
            self.sends.iter().map(|n| n.rank),
            &self.send_buffers,
            self.receives.iter().map(|n| n.rank),
            &mut self.receive_buffers,
        );
    }

    /// Every received point with its `width` numbers from the last [`Messages::swap`].
    pub(super) fn received(&self, width: usize) -> impl Iterator<Item = (u32, &[f64])> {
        let peers = self.receives.iter().zip(&self.receive_buffers);
        peers.flat_map(move |(peer, buffer)| {
            let numbers = (0..peer.points.len()).map(move |k| &buffer[k * width..(k + 1) * width]);
            peer.points.iter().copied().zip(numbers)
        })
    }
}

/// Points and bytes one exchange moves, for the run log and the scaling report.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct HaloVolume {
    /// Ghost points this rank receives.
    pub received_points: usize,
    /// Owned points this rank sends (a point counts once per rank it goes to).
    pub sent_points: usize,
    /// Ranks this rank exchanges with.
    pub neighbor_ranks: usize,
}

impl HaloVolume {
    /// Bytes received for a field of `width` f64 per point.
    pub fn received_bytes(&self, width: usize) -> usize {
        self.received_points * width * 8
    }
}

/// Rank `rank`'s share of the points: owned points and ghosts (local numbering = the global run
/// order restricted to them), and the send and receive lists of its exchanges.
///
/// Ghost layers: layer 1 are the off-rank points in the rows of owned points; layer 2 (with
/// depth 2) the off-rank points in the rows of layer-1 ghosts that are not already ghosts. Rows
/// are read as stored (directed), so one-way bonds of variable horizons are followed the way
/// the gather loops read them.
#[derive(Debug, Clone, PartialEq)]
pub struct HaloPlan {
    rank: usize,
    depth: usize,
    /// Global index of every local point, strictly increasing.
    global: Vec<u32>,
    /// Layer of every local point: 0 owned, 1 or 2 ghost.
    layer: Vec<u8>,
    /// Local indices of the owned points, increasing.
    owned: Vec<u32>,
    messages: Messages,
}

/// The off-rank points in `rows` not marked yet, marked with `layer` and returned in
/// increasing order. `mine` says which points this rank owns.
pub(super) fn new_ghosts<'a>(
    rows: impl Iterator<Item = &'a [u32]>,
    mine: impl Fn(u32) -> bool,
    mark: &mut [u8],
    layer: u8,
) -> Vec<u32> {
    let mut found = Vec::new();
    for row in rows {
        for &j in row {
            if !mine(j) && mark[j as usize] == 0 {
                mark[j as usize] = layer;
                found.push(j);
            }
        }
    }
    found.sort_unstable();
    found
}

/// Layer-1 and layer-2 ghosts as (global index, layer), sorted by global index.
pub(super) fn layered(first: &[u32], second: &[u32]) -> Vec<(u32, u8)> {
    let mut ghosts: Vec<(u32, u8)> = first
        .iter()
        .map(|&j| (j, 1))
        .chain(second.iter().map(|&k| (k, 2)))
        .collect();
    ghosts.sort_unstable();
    ghosts
}

/// Ghosts of rank `rank` as (global index, layer), sorted by global index. `mark` has one
/// entry per point and is all zero on entry and on return.
fn ghosts_of(
    bonds: &BondList,
    partition: &Partition,
    rank: usize,
    depth: usize,
    mark: &mut [u8],
) -> Vec<(u32, u8)> {
    let mine = |p: u32| partition.owner[p as usize] as usize == rank;
    let owned_rows = partition.owned[rank]
        .iter()
        .map(|&i| bonds.family(i as usize));
    let first = new_ghosts(owned_rows, mine, mark, 1);
    let second = if depth >= 2 {
        new_ghosts(
            first.iter().map(|&j| bonds.family(j as usize)),
            mine,
            mark,
            2,
        )
    } else {
        Vec::new()
    };
    let ghosts = layered(&first, &second);
    for &(p, _) in &ghosts {
        mark[p as usize] = 0;
    }
    ghosts
}

impl HaloPlan {
    /// The plan of rank `rank` for `partition`, with ghosts `depth` (1 or 2) bonds deep.
    ///
    /// Every rank computes the ghost sets of all ranks from the global bond list (no
    /// messages), so the send list to rank r is r's ghosts that this rank owns, in the same
    /// (global) order as r's receive list. Cost: one pass over the bonds of every rank's
    /// owned and layer-1 points.
    pub fn build(bonds: &BondList, partition: &Partition, rank: usize, depth: usize) -> Self {
        assert!(
            (1..=2).contains(&depth),
            "ghost depth must be 1 or 2, got {depth}"
        );
        assert!(rank < partition.parts());
        let mut mark = vec![0u8; bonds.num_points()];
        let all_ghosts: Vec<Vec<(u32, u8)>> = (0..partition.parts())
            .map(|r| ghosts_of(bonds, partition, r, depth, &mut mark))
            .collect();
        let held_elsewhere = (0..partition.parts())
            .filter(|&r| r != rank)
            .map(|r| {
                let mine: Vec<u32> = all_ghosts[r]
                    .iter()
                    .filter(|&&(p, _)| partition.owner[p as usize] as usize == rank)
                    .map(|&(p, _)| p)
                    .collect();
                (r, mine)
            })
            .filter(|(_, points)| !points.is_empty())
            .collect();
        Self::assemble(partition, rank, depth, &all_ghosts[rank], held_elsewhere)
    }

    /// [`HaloPlan::build`] from this rank's own `ghosts` ((global index, layer), sorted), for
    /// a run in which no rank holds the global bond list: each rank tells every owner which of
    /// its points it holds as ghosts. Collective: one all-gather of ranks² counts and one
    /// exchange of the requested indices. Gives the plan [`HaloPlan::build`] gives.
    pub fn from_ghosts(
        partition: &Partition,
        rank: usize,
        depth: usize,
        ghosts: &[(u32, u8)],
        comm: &dyn Communicator,
    ) -> Self {
        assert!(
            (1..=2).contains(&depth),
            "ghost depth must be 1 or 2, got {depth}"
        );
        let parts = partition.parts();
        assert!(rank < parts && comm.size() == parts && comm.rank() == rank);
        let mut requested = vec![Vec::new(); parts];
        for &(p, _) in ghosts {
            // Point indices below 2^53 travel exactly as f64.
            requested[partition.owner[p as usize] as usize].push(f64::from(p));
        }
        let counts: Vec<f64> = requested.iter().map(|r| r.len() as f64).collect();
        // wanted[s * parts + r]: how many of rank r's points rank s holds.
        let wanted = comm.all_gather(&counts, &vec![parts; parts]);
        let send_ranks: Vec<usize> = (0..parts)
            .filter(|&r| r != rank && !requested[r].is_empty())
            .collect();
        let send_buffers: Vec<Vec<f64>> = send_ranks
            .iter()
            .map(|&r| std::mem::take(&mut requested[r]))
            .collect();
        let receive_ranks: Vec<usize> = (0..parts)
            .filter(|&s| s != rank && wanted[s * parts + rank] > 0.0)
            .collect();
        let mut receive_buffers: Vec<Vec<f64>> = receive_ranks
            .iter()
            .map(|&s| vec![0.0; wanted[s * parts + rank] as usize])
            .collect();
        swap_buffers(
            comm,
            send_ranks.into_iter(),
            &send_buffers,
            receive_ranks.iter().copied(),
            &mut receive_buffers,
        );
        let held_elsewhere = receive_ranks
            .into_iter()
            .zip(receive_buffers)
            .map(|(s, points)| (s, points.iter().map(|&p| p as u32).collect()))
            .collect();
        Self::assemble(partition, rank, depth, ghosts, held_elsewhere)
    }

    /// The plan from this rank's `ghosts` and, for every other rank that holds some of this
    /// rank's points, those points (global indices, increasing), in rank order.
    fn assemble(
        partition: &Partition,
        rank: usize,
        depth: usize,
        ghosts: &[(u32, u8)],
        held_elsewhere: Vec<(usize, Vec<u32>)>,
    ) -> Self {
        // Local numbering: owned and own ghosts merged in global order.
        let mut members: Vec<(u32, u8)> = partition.owned[rank]
            .iter()
            .map(|&p| (p, 0u8))
            .chain(ghosts.iter().copied())
            .collect();
        members.sort_unstable();
        let global: Vec<u32> = members.iter().map(|m| m.0).collect();
        let layer: Vec<u8> = members.iter().map(|m| m.1).collect();
        let local_of = |p: u32| -> u32 {
            global
                .binary_search(&p)
                .expect("every exchanged point is local") as u32
        };
        let owned: Vec<u32> = (0..global.len() as u32)
            .filter(|&l| layer[l as usize] == 0)
            .collect();
        let mut receives = Vec::new();
        for r in (0..partition.parts()).filter(|&r| r != rank) {
            let from_r: Vec<u32> = ghosts
                .iter()
                .filter(|&&(p, _)| partition.owner[p as usize] as usize == r)
                .map(|&(p, _)| local_of(p))
                .collect();
            if !from_r.is_empty() {
                receives.push(Peer {
                    rank: r,
                    points: from_r,
                });
            }
        }
        let sends: Vec<Peer> = held_elsewhere
            .into_iter()
            .map(|(r, points)| {
                assert!(
                    points
                        .iter()
                        .all(|&p| partition.owner[p as usize] as usize == rank),
                    "rank {r} asked rank {rank} for points it does not own"
                );
                Peer {
                    rank: r,
                    points: points.into_iter().map(local_of).collect(),
                }
            })
            .collect();
        Self {
            rank,
            depth,
            global,
            layer,
            owned,
            messages: Messages::new(sends, receives),
        }
    }

    /// This plan's rank.
    pub fn rank(&self) -> usize {
        self.rank
    }

    /// Ghost depth (1 or 2 bonds).
    pub fn depth(&self) -> usize {
        self.depth
    }

    /// Global (run-order) index of every local point, strictly increasing.
    pub fn global(&self) -> &[u32] {
        &self.global
    }

    /// Layer of every local point: 0 owned, 1 one bond from an owned point, 2 two bonds.
    pub fn layer(&self) -> &[u8] {
        &self.layer
    }

    /// Local indices of the owned points, increasing.
    pub fn owned(&self) -> &[u32] {
        &self.owned
    }

    /// Global indices of the ghosts, increasing.
    pub fn ghosts(&self) -> Vec<u32> {
        self.global
            .iter()
            .zip(&self.layer)
            .filter(|(_, &l)| l > 0)
            .map(|(&g, _)| g)
            .collect()
    }

    /// Points and ranks one exchange involves.
    pub fn volume(&self) -> HaloVolume {
        self.messages.volume()
    }

    /// Owner → ghosts: copies every owned point's value of `field` (local numbering) into the
    /// ghost entries of the ranks that hold it as a ghost. Collective over the neighbour ranks;
    /// the messages are posted non-blocking and waited for together.
    pub fn exchange<T: HaloValue>(&mut self, comm: &dyn Communicator, field: &mut [T]) {
        assert_eq!(field.len(), self.global.len());
        self.messages
            .swap(comm, T::WIDTH, |p, out| field[p as usize].pack(out));
        for (p, numbers) in self.messages.received(T::WIDTH) {
            field[p as usize] = T::unpack(numbers);
        }
    }
}

/// Sends each packed buffer to its rank and fills each receive buffer (sized by the caller)
/// from its rank, all non-blocking and waited for together (collective). The bond halo and
/// the contact partner exchange both move their points this way.
pub(super) fn swap_buffers(
    comm: &dyn Communicator,
    send_ranks: impl Iterator<Item = usize>,
    send_buffers: &[Vec<f64>],
    receive_ranks: impl Iterator<Item = usize>,
    receive_buffers: &mut [Vec<f64>],
) {
    let sends: Vec<(usize, &[f64])> = send_ranks
        .zip(send_buffers)
        .map(|(rank, b)| (rank, b.as_slice()))
        .collect();
    let mut receives: Vec<(usize, &mut [f64])> = receive_ranks
        .zip(receive_buffers.iter_mut())
        .map(|(rank, b)| (rank, b.as_mut_slice()))
        .collect();
    comm.exchange(&sends, &mut receives);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::test_support::brute_force_bonds;
    use std::collections::BTreeSet;

    /// A 10 × 4 × 1 lattice with unit spacing and bonds within 1.5 (the 8 planar neighbours).
    fn lattice() -> (Vec<[f64; 3]>, BondList) {
        let mut x = Vec::new();
        for j in 0..4 {
            for i in 0..10 {
                x.push([i as f64, j as f64, 0.0]);
            }
        }
        let bonds = brute_force_bonds(&x, 1.5);
        (x, bonds)
    }

    /// Brute force: the points within `depth` bonds of `owned` that are not owned.
    fn expected_ghosts(bonds: &BondList, owned: &BTreeSet<u32>, depth: usize) -> BTreeSet<u32> {
        let mut reached = owned.clone();
        for _ in 0..depth {
            let next: Vec<u32> = reached
                .iter()
                .flat_map(|&i| bonds.family(i as usize).to_vec())
                .collect();
            reached.extend(next);
        }
        reached.difference(owned).copied().collect()
    }

    #[test]
    fn ghost_sets_are_the_points_within_depth_bonds() {
        let (x, bonds) = lattice();
        let partition = Partition::of_bonds(&x, &bonds, 3);
        for depth in 1..=2 {
            for rank in 0..3 {
                let plan = HaloPlan::build(&bonds, &partition, rank, depth);
                let owned: BTreeSet<u32> = partition.owned[rank].iter().copied().collect();
                let ghosts: BTreeSet<u32> = plan.ghosts().into_iter().collect();
                assert_eq!(ghosts, expected_ghosts(&bonds, &owned, depth));
                // Local numbering: the global order, owned points first-class members.
                assert!(plan.global().windows(2).all(|w| w[0] < w[1]));
                let owned_globals: Vec<u32> = plan
                    .owned()
                    .iter()
                    .map(|&l| plan.global()[l as usize])
                    .collect();
                assert_eq!(owned_globals, partition.owned[rank]);
            }
        }
    }

    #[test]
    fn a_strip_cut_in_two_has_one_column_of_ghosts_per_bond() {
        // Two ranks cut the 10-wide strip at x = 5; bonds reach one column (horizon 1.5), so
        // rank 0's ghosts are column x = 5 (4 points) at depth 1 and columns 5 and 6 at depth 2.
        let (x, bonds) = lattice();
        let partition = Partition::of_bonds(&x, &bonds, 2);
        let columns = |plan: &HaloPlan| -> BTreeSet<i64> {
            plan.ghosts()
                .iter()
                .map(|&g| x[g as usize][0] as i64)
                .collect()
        };
        let depth1 = HaloPlan::build(&bonds, &partition, 0, 1);
        assert_eq!(depth1.ghosts().len(), 4);
        assert_eq!(columns(&depth1), BTreeSet::from([5]));
        let depth2 = HaloPlan::build(&bonds, &partition, 0, 2);
        assert_eq!(columns(&depth2), BTreeSet::from([5, 6]));
        assert_eq!(depth2.volume().received_points, 8);
        assert_eq!(depth2.volume().sent_points, 8);
    }

    /// Runs every rank's `exchange` in one process: rank r's sends are copied into the
    /// matching receives of the other ranks (a serial stand-in for MPI with the same pairing).
    fn exchange_all(plans: &mut [HaloPlan], fields: &mut [Vec<[f64; 3]>]) {
        let w = 3;
        let mut mailbox: std::collections::BTreeMap<(usize, usize), Vec<f64>> = Default::default();
        for (plan, field) in plans.iter().zip(fields.iter()) {
            for neighbor in &plan.messages.sends {
                let mut buffer = vec![0.0; neighbor.points.len() * w];
                for (k, &p) in neighbor.points.iter().enumerate() {
                    field[p as usize].pack(&mut buffer[k * w..(k + 1) * w]);
                }
                mailbox.insert((plan.rank, neighbor.rank), buffer);
            }
        }
        for (plan, field) in plans.iter().zip(fields.iter_mut()) {
            for neighbor in &plan.messages.receives {
                let buffer = &mailbox[&(neighbor.rank, plan.rank)];
                assert_eq!(buffer.len(), neighbor.points.len() * w);
                for (k, &p) in neighbor.points.iter().enumerate() {
                    field[p as usize] = <[f64; 3]>::unpack(&buffer[k * w..(k + 1) * w]);
                }
            }
        }
    }

    #[test]
    fn an_exchange_gives_every_ghost_its_owners_value() {
        let (x, bonds) = lattice();
        let partition = Partition::of_bonds(&x, &bonds, 3);
        let mut plans: Vec<HaloPlan> = (0..3)
            .map(|r| HaloPlan::build(&bonds, &partition, r, 2))
            .collect();
        // Owned entries hold the global coordinates; ghosts start as NaN.
        let mut fields: Vec<Vec<[f64; 3]>> = plans
            .iter()
            .map(|plan| {
                plan.global()
                    .iter()
                    .zip(plan.layer())
                    .map(|(&g, &l)| if l == 0 { x[g as usize] } else { [f64::NAN; 3] })
                    .collect()
            })
            .collect();
        exchange_all(&mut plans, &mut fields);
        for (plan, field) in plans.iter().zip(&fields) {
            for (&g, value) in plan.global().iter().zip(field) {
                assert_eq!(*value, x[g as usize]);
            }
        }
    }

    #[test]
    fn one_rank_has_no_ghosts_and_exchanges_nothing() {
        let (x, bonds) = lattice();
        let mut plan = HaloPlan::build(&bonds, &Partition::single(x.len()), 0, 2);
        assert!(plan.ghosts().is_empty());
        let mut field = x.clone();
        plan.exchange(&super::super::Serial, &mut field);
        assert_eq!(field, x);
    }
}
