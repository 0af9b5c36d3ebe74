//! The MPI [`Communicator`] (feature `mpi`, rsmpi).

use super::Communicator;
use mpi::collective::{CommunicatorCollectives, Root, SystemOperation};
use mpi::datatype::PartitionMut;
use mpi::point_to_point::{Destination, Source};
use mpi::topology::{Communicator as _, SimpleCommunicator};

/// `MPI_COMM_WORLD` as a [`Communicator`].
pub struct MpiCommunicator {
    world: SimpleCommunicator,
}

impl MpiCommunicator {
    /// `MPI_COMM_WORLD`; MPI is started by [`crate::mpi_session::MpiSession`].
    pub fn world() -> Self {
        Self {
            world: SimpleCommunicator::world(),
        }
    }
}

impl Communicator for MpiCommunicator {
    fn rank(&self) -> usize {
        self.world.rank() as usize
    }

    fn size(&self) -> usize {
        self.world.size() as usize
    }

    fn sum(&self, values: &mut [f64]) {
        let local = values.to_vec();
        self.world
            .all_reduce_into(&local[..], values, SystemOperation::sum());
    }

    fn min(&self, value: f64) -> f64 {
        let mut result = value;
        self.world
            .all_reduce_into(&value, &mut result, SystemOperation::min());
        result
    }

    fn exchange(&self, sends: &[(usize, &[f64])], receives: &mut [(usize, &mut [f64])]) {
        mpi::request::scope(|scope| {
            let mut requests = Vec::with_capacity(sends.len() + receives.len());
            for (rank, buffer) in receives.iter_mut() {
                requests.push(
                    self.world
                        .process_at_rank(*rank as i32)
                        .immediate_receive_into(scope, &mut **buffer),
                );
            }
            for (rank, buffer) in sends {
                requests.push(
                    self.world
                        .process_at_rank(*rank as i32)
                        .immediate_send(scope, *buffer),
                );
            }
            for request in requests {
                request.wait();
            }
        });
    }

    fn gather(&self, local: &[f64], counts: &[usize]) -> Option<Vec<f64>> {
        let root = self.world.process_at_rank(0);
        if self.world.rank() != 0 {
            root.gather_varcount_into(local);
            return None;
        }
        let (counts_i, displacements) = counts_and_displacements(counts);
        let mut all = vec![0.0; counts.iter().sum()];
        {
            let mut partition = PartitionMut::new(&mut all[..], counts_i, displacements);
            root.gather_varcount_into_root(local, &mut partition);
        }
        Some(all)
    }

    fn all_gather(&self, local: &[f64], counts: &[usize]) -> Vec<f64> {
        assert_eq!(counts[self.rank()], local.len());
        let (counts_i, displacements) = counts_and_displacements(counts);
        let mut all = vec![0.0; counts.iter().sum()];
        {
            let mut partition = PartitionMut::new(&mut all[..], counts_i, displacements);
            self.world.all_gather_varcount_into(local, &mut partition);
        }
        all
    }

    fn abort(&self, code: i32) -> ! {
        self.world.abort(code)
    }
}

/// MPI's counts and displacements of a variable-count gather of `counts` numbers per rank,
/// ranks one after the other.
fn counts_and_displacements(counts: &[usize]) -> (Vec<i32>, Vec<i32>) {
    let counts_i: Vec<i32> = counts.iter().map(|&c| c as i32).collect();
    let displacements: Vec<i32> = counts_i
        .iter()
        .scan(0, |acc, &c| {
            let start = *acc;
            *acc += c;
            Some(start)
        })
        .collect();
    (counts_i, displacements)
}
