//! Parallel loops over a sorted set of points that write disjoint parts of global arrays.
//!
//! A block's points are a strictly increasing list of global point indices. Each point owns
//! one entry of a per-point array and one row of a per-bond array, so splitting the list in
//! two also splits those arrays in two at the first point of the right half: recursive
//! `rayon::join` on that split gives every task exclusive `&mut` access to exactly its points'
//! data, with no atomics, no unsafe code and no allocation.

/// Data that can be cut in two at a position (a mutable slice, or a tuple of them cut at the
/// same position).
pub(crate) trait Splittable: Sized + Send {
    /// Cuts at `at` (relative to the start of `self`).
    fn split(self, at: usize) -> (Self, Self);
}

impl<T: Send> Splittable for &mut [T] {
    fn split(self, at: usize) -> (Self, Self) {
        self.split_at_mut(at)
    }
}

impl<A: Splittable, B: Splittable> Splittable for (A, B) {
    fn split(self, at: usize) -> (Self, Self) {
        let (a0, a1) = self.0.split(at);
        let (b0, b1) = self.1.split(at);
        ((a0, b0), (a1, b1))
    }
}

/// Calls `leaf(chunk, base, data)` on disjoint chunks of `points` in parallel.
///
/// `points` must be strictly increasing; `start(i)` is where point `i`'s data begins in the
/// full arrays (`i` for per-point arrays, `offsets[i]` for bond rows) and must be
/// non-decreasing in `i`. `data` covers the full arrays from position 0; each leaf receives the
/// part beginning at `base = start(chunk[0])` (index its own point `i` at `start(i) − base`).
pub(crate) fn for_each_chunk<S, P, L>(points: &[u32], data: S, start: &P, leaf: &L)
where
    S: Splittable,
    P: Fn(u32) -> usize + Sync,
    L: Fn(&[u32], usize, S) + Sync,
{
    if points.is_empty() {
        return;
    }
    // Enough chunks for load balance (families near surfaces are smaller), few enough that
    // task overhead stays negligible next to ~100 bonds per point.
    let threads = rayon::current_num_threads().max(1);
    let grain = (points.len() / (16 * threads)).clamp(64, 4096);
    recurse(points, data, 0, start, leaf, grain);
}

fn recurse<S, P, L>(points: &[u32], data: S, base: usize, start: &P, leaf: &L, grain: usize)
where
    S: Splittable,
    P: Fn(u32) -> usize + Sync,
    L: Fn(&[u32], usize, S) + Sync,
{
    if points.len() <= grain {
        // Drop the data before the first point so that the leaf sees `base = start(first)`.
        let first = start(points[0]);
        let (_, mine) = data.split(first - base);
        leaf(points, first, mine);
        return;
    }
    let mid = points.len() / 2;
    let cut = start(points[mid]);
    let (left_data, right_data) = data.split(cut - base);
    let (left, right) = points.split_at(mid);
    rayon::join(
        || recurse(left, left_data, base, start, leaf, grain),
        || recurse(right, right_data, cut, start, leaf, grain),
    );
}

/// Greedy first-fit colouring of work items by the chunks (of some array) they write: items of
/// one colour write disjoint chunks, so each colour can run in parallel and the colours one
/// after the other, with a fixed order of every sum (the result is the same for any thread
/// count).
pub(crate) struct WriteColouring {
    /// `taken[colour][chunk]`: an item of that colour writes into `chunk`.
    taken: Vec<Vec<bool>>,
    chunks: usize,
}

impl WriteColouring {
    /// No colours yet, over an array of `chunks` chunks.
    pub(crate) fn new(chunks: usize) -> Self {
        Self {
            taken: Vec::new(),
            chunks,
        }
    }

    /// The first colour none of whose items writes any of `writes` (chunk numbers below
    /// `chunks`), opening a new colour when every existing one conflicts; marks `writes` as
    /// written by that colour. A new colour's number equals the number of colours before it.
    pub(crate) fn assign(&mut self, writes: &[u32]) -> usize {
        let colour = match self
            .taken
            .iter()
            .position(|t| writes.iter().all(|&w| !t[w as usize]))
        {
            Some(colour) => colour,
            None => {
                self.taken.push(vec![false; self.chunks]);
                self.taken.len() - 1
            }
        };
        for &w in writes {
            self.taken[colour][w as usize] = true;
        }
        colour
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_listed_point_gets_its_own_row_once() {
        // 10 000 points with rows of length i % 5; the set is every third point.
        let n = 10_000usize;
        let mut offsets = vec![0usize];
        for i in 0..n {
            offsets.push(offsets[i] + i % 5);
        }
        let points: Vec<u32> = (0..n as u32).step_by(3).collect();
        let mut rows = vec![0u32; offsets[n]];
        let mut per_point = vec![0u32; n];
        let mut twice = vec![0u32; n];
        for_each_chunk(
            &points,
            (&mut per_point[..], &mut twice[..]),
            &|i| i as usize,
            &|chunk, base, (a, b): (&mut [u32], &mut [u32])| {
                for &i in chunk {
                    a[i as usize - base] += i + 1;
                    b[i as usize - base] += 2 * (i + 1);
                }
            },
        );
        for_each_chunk(
            &points,
            &mut rows[..],
            &|i| offsets[i as usize],
            &|chunk, base, data: &mut [u32]| {
                for &i in chunk {
                    let i = i as usize;
                    for v in &mut data[offsets[i] - base..offsets[i + 1] - base] {
                        *v += i as u32 + 1;
                    }
                }
            },
        );
        for i in 0..n {
            let expected = if i % 3 == 0 { i as u32 + 1 } else { 0 };
            assert_eq!(per_point[i], expected);
            assert_eq!(twice[i], 2 * expected);
            for &v in &rows[offsets[i]..offsets[i + 1]] {
                assert_eq!(v, expected);
            }
        }
    }

    #[test]
    fn write_colouring_separates_items_that_write_the_same_chunk() {
        let mut colouring = WriteColouring::new(4);
        // {0,1} and {2} share nothing: one colour; {1,2} meets both: a second colour; {3}
        // fits the first again (first fit); {0,3} meets the first (which now writes 0–3) but
        // not the second ({1,2}).
        assert_eq!(colouring.assign(&[0, 1]), 0);
        assert_eq!(colouring.assign(&[2]), 0);
        assert_eq!(colouring.assign(&[1, 2]), 1);
        assert_eq!(colouring.assign(&[3]), 0);
        assert_eq!(colouring.assign(&[0, 3]), 1);
    }
}
