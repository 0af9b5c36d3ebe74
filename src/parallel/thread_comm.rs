//! An in-process [`Communicator`] for unit tests: ranks are threads of one test, messages go
//! through one first-in-first-out mailbox per (sender, receiver) pair. Collectives match as
//! long as every rank calls them in the same order, as with MPI.

use super::Communicator;
use std::collections::VecDeque;
use std::sync::{Arc, Condvar, Mutex};

struct Mailboxes {
    size: usize,
    /// Queue `from * size + to`.
    queues: Mutex<Vec<VecDeque<Vec<f64>>>>,
    arrived: Condvar,
}

/// One rank of a threaded test run.
pub struct ThreadComm {
    rank: usize,
    boxes: Arc<Mailboxes>,
}

impl ThreadComm {
    /// Runs `body` on `size` threads, one per rank, and returns their results in rank order.
    pub fn run<T: Send>(size: usize, body: impl Fn(&ThreadComm) -> T + Sync) -> Vec<T> {
        let boxes = Arc::new(Mailboxes {
            size,
            queues: Mutex::new(vec![VecDeque::new(); size * size]),
            arrived: Condvar::new(),
        });
        std::thread::scope(|scope| {
            let handles: Vec<_> = (0..size)
                .map(|rank| {
                    let comm = ThreadComm {
                        rank,
                        boxes: Arc::clone(&boxes),
                    };
                    let body = &body;
                    scope.spawn(move || body(&comm))
                })
                .collect();
            handles
                .into_iter()
                .map(|h| h.join().expect("a rank panicked"))
                .collect()
        })
    }

    fn send(&self, to: usize, data: &[f64]) {
        let mut queues = self.boxes.queues.lock().unwrap();
        queues[self.rank * self.boxes.size + to].push_back(data.to_vec());
        self.boxes.arrived.notify_all();
    }

    fn receive(&self, from: usize) -> Vec<f64> {
        let mut queues = self.boxes.queues.lock().unwrap();
        loop {
            if let Some(data) = queues[from * self.boxes.size + self.rank].pop_front() {
                return data;
            }
            queues = self.boxes.arrived.wait(queues).unwrap();
        }
    }
}

impl Communicator for ThreadComm {
    fn rank(&self) -> usize {
        self.rank
    }

    fn size(&self) -> usize {
        self.boxes.size
    }

    fn sum(&self, values: &mut [f64]) {
        let width = values.len();
        let all = self.all_gather(values, &vec![width; self.size()]);
        for (k, value) in values.iter_mut().enumerate() {
            *value = (0..self.size()).map(|r| all[r * width + k]).sum();
        }
    }

    fn min(&self, value: f64) -> f64 {
        let all = self.all_gather(&[value], &vec![1; self.size()]);
        all.into_iter().fold(f64::INFINITY, f64::min)
    }

    fn exchange(&self, sends: &[(usize, &[f64])], receives: &mut [(usize, &mut [f64])]) {
        for (to, data) in sends {
            self.send(*to, data);
        }
        for (from, buffer) in receives.iter_mut() {
            let data = self.receive(*from);
            assert_eq!(data.len(), buffer.len(), "message size from rank {from}");
            buffer.copy_from_slice(&data);
        }
    }

    fn gather(&self, local: &[f64], counts: &[usize]) -> Option<Vec<f64>> {
        let all = self.all_gather(local, counts);
        (self.rank == 0).then_some(all)
    }

    fn all_gather(&self, local: &[f64], counts: &[usize]) -> Vec<f64> {
        assert_eq!(counts[self.rank], local.len());
        for to in (0..self.size()).filter(|&r| r != self.rank) {
            self.send(to, local);
        }
        let mut all = Vec::with_capacity(counts.iter().sum());
        for (from, &count) in counts.iter().enumerate() {
            if from == self.rank {
                all.extend_from_slice(local);
            } else {
                let data = self.receive(from);
                assert_eq!(data.len(), count);
                all.extend(data);
            }
        }
        all
    }

    fn abort(&self, code: i32) -> ! {
        panic!("rank {} aborted with code {code}", self.rank)
    }
}
