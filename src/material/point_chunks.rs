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
}
