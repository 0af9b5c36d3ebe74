//! The per-step exchange of contact partners: owned points whose values another rank reads
//! because one of its owned points lists them as a partner (a contact candidate).
//!
//! Unlike the bond halo ([`super::HaloPlan`]), the partners change with every proximity
//! search, so the plan is rebuilt from the candidate rows of the owned points after each
//! search and used at every force evaluation until the next one.

use super::halo::{Messages, Peer};
use super::{Communicator, HaloVolume};
use std::collections::BTreeMap;

/// Send and receive lists of the partner exchange of one rank, over global point indices.
///
/// Built without messages from the partner rows of this rank's owned points, under the
/// condition that the partner relation is symmetric (j is a partner of i exactly when i is a
/// partner of j), which the contact candidate rule is (see [`PartnerExchange::build`]). Then
/// rank a's receive list from rank b is {j owned by b : j in the row of some i owned by a},
/// and a's send list to b is {i owned by a : the row of i holds some j owned by b}; by
/// symmetry each equals the other side's matching list, in the same (ascending) order.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PartnerExchange {
    rank: usize,
    /// Global indices, ascending within each rank.
    messages: Messages,
}

impl PartnerExchange {
    /// The plan of rank `rank`: `owner[g]` is the rank owning global point g, and `rows`
    /// yields (owned point i, its partners) for the owned points (global indices; rows may be
    /// empty or omitted). The relation given by all ranks' rows must be symmetric, or the two
    /// sides of a message disagree on its length (a broken invariant: the exchange panics or
    /// MPI reports a truncated message).
    pub fn build<'a>(
        rank: usize,
        owner: &[u32],
        rows: impl IntoIterator<Item = (u32, &'a [u32])>,
    ) -> Self {
        let mut sends: BTreeMap<usize, Vec<u32>> = BTreeMap::new();
        let mut receives: BTreeMap<usize, Vec<u32>> = BTreeMap::new();
        for (i, row) in rows {
            debug_assert_eq!(owner[i as usize] as usize, rank, "row of a point not owned");
            for &j in row {
                let r = owner[j as usize] as usize;
                if r != rank {
                    receives.entry(r).or_default().push(j);
                    sends.entry(r).or_default().push(i);
                }
            }
        }
        let peers = |lists: BTreeMap<usize, Vec<u32>>| -> Vec<Peer> {
            lists
                .into_iter()
                .map(|(rank, mut points)| {
                    points.sort_unstable();
                    points.dedup();
                    Peer { rank, points }
                })
                .collect()
        };
        let (sends, receives) = (peers(sends), peers(receives));
        Self {
            rank,
            messages: Messages::new(sends, receives),
        }
    }

    /// This plan's rank.
    pub fn rank(&self) -> usize {
        self.rank
    }

    /// Global indices of the points this rank receives (ascending within each sending rank).
    pub fn received_points(&self) -> impl Iterator<Item = u32> + '_ {
        let receives = self.messages.receives.iter();
        receives.flat_map(|p| p.points.iter().copied())
    }

    /// Points and ranks one exchange involves.
    pub fn volume(&self) -> HaloVolume {
        self.messages.volume()
    }

    /// Sends `width` numbers per sent point, written by `pack(global index, out)`, and hands
    /// every received point's numbers to `unpack(global index, numbers)`. Collective over the
    /// partner ranks (non-blocking messages waited for together).
    pub fn exchange(
        &mut self,
        comm: &dyn Communicator,
        width: usize,
        pack: impl Fn(u32, &mut [f64]),
        mut unpack: impl FnMut(u32, &[f64]),
    ) {
        self.messages.swap(comm, width, pack);
        for (p, numbers) in self.messages.received(width) {
            unpack(p, numbers);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeSet;

    /// 40 points on a line, owned in blocks of 7 by 3 ranks round-robin (0..7 → 0, 7..14 → 1,
    /// …), and the symmetric relation |i − j| ≤ 3 or i + j = 39 (far pairs across the line).
    fn setup() -> (Vec<u32>, Vec<Vec<u32>>) {
        let n = 40u32;
        let owner: Vec<u32> = (0..n).map(|p| (p / 7) % 3).collect();
        let rows: Vec<Vec<u32>> = (0..n)
            .map(|i| {
                (0..n)
                    .filter(|&j| j != i && (i.abs_diff(j) <= 3 || i + j == 39))
                    .collect()
            })
            .collect();
        (owner, rows)
    }

    fn plans(owner: &[u32], rows: &[Vec<u32>]) -> Vec<PartnerExchange> {
        (0..3)
            .map(|r| {
                PartnerExchange::build(
                    r,
                    owner,
                    (0..rows.len() as u32)
                        .filter(|&i| owner[i as usize] as usize == r)
                        .map(|i| (i, rows[i as usize].as_slice())),
                )
            })
            .collect()
    }

    #[test]
    fn every_rank_receives_exactly_the_off_rank_partners_of_its_points() {
        let (owner, rows) = setup();
        for plan in plans(&owner, &rows) {
            let r = plan.rank() as u32;
            let expected: BTreeSet<u32> = (0..40u32)
                .filter(|&i| owner[i as usize] == r)
                .flat_map(|i| rows[i as usize].iter().copied())
                .filter(|&j| owner[j as usize] != r)
                .collect();
            let received: Vec<u32> = plan.received_points().collect();
            assert_eq!(received.len(), expected.len(), "no duplicates");
            assert_eq!(received.iter().copied().collect::<BTreeSet<_>>(), expected);
        }
    }

    #[test]
    fn send_lists_match_the_other_sides_receive_lists() {
        let (owner, rows) = setup();
        let plans = plans(&owner, &rows);
        for a in &plans {
            for send in &a.messages.sends {
                let b = &plans[send.rank];
                let receive = b
                    .messages
                    .receives
                    .iter()
                    .find(|p| p.rank == a.rank)
                    .expect("the receiving side lists the sender");
                assert_eq!(send.points, receive.points);
            }
            assert_eq!(
                a.volume().sent_points,
                plans
                    .iter()
                    .flat_map(|b| &b.messages.receives)
                    .filter(|p| p.rank == a.rank)
                    .map(|p| p.points.len())
                    .sum::<usize>()
            );
        }
    }

    /// Runs every rank's exchange in one process (rank r's packed sends are copied into the
    /// matching receives), with two numbers per point: the owner's (index, 10·index).
    #[test]
    fn an_exchange_hands_every_partner_its_owners_values() {
        let (owner, rows) = setup();
        let plans = plans(&owner, &rows);
        let mut mailbox: BTreeMap<(usize, usize), Vec<f64>> = BTreeMap::new();
        for plan in &plans {
            for peer in &plan.messages.sends {
                let mut buffer = Vec::new();
                for &p in &peer.points {
                    assert_eq!(owner[p as usize] as usize, plan.rank);
                    buffer.extend([f64::from(p), 10.0 * f64::from(p)]);
                }
                mailbox.insert((plan.rank, peer.rank), buffer);
            }
        }
        for plan in &plans {
            let mut seen = 0;
            for peer in &plan.messages.receives {
                let buffer = &mailbox[&(peer.rank, plan.rank)];
                assert_eq!(buffer.len(), 2 * peer.points.len());
                for (k, &p) in peer.points.iter().enumerate() {
                    assert_eq!(
                        buffer[2 * k..2 * k + 2],
                        [f64::from(p), 10.0 * f64::from(p)]
                    );
                    seen += 1;
                }
            }
            assert_eq!(seen, plan.volume().received_points);
        }
    }

    #[test]
    fn one_rank_exchanges_nothing() {
        let (_, rows) = setup();
        let owner = vec![0u32; 40];
        let mut plan = PartnerExchange::build(
            0,
            &owner,
            (0..40u32).map(|i| (i, rows[i as usize].as_slice())),
        );
        assert_eq!(plan.volume(), HaloVolume::default());
        plan.exchange(
            &super::super::Serial,
            2,
            |_, _| panic!("nothing to send"),
            |_, _| panic!("nothing to receive"),
        );
    }
}
