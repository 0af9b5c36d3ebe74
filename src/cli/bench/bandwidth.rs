//! The machine's memory bandwidth, measured by the bench itself, and the bound it puts on PMB.
//!
//! # Stream bandwidth
//! A STREAM-like *triad* `a[k] = b[k] + s·c[k]` over three `f64` arrays, each at least eight
//! times the last-level cache (and at least 64 MiB), so every pass streams from memory. Bytes
//! are counted as STREAM counts them: 24 per element (two 8-byte reads, one 8-byte write; the
//! cache's read-for-ownership of `a` is not counted). The best of [`PASSES`] passes is kept, on
//! one thread and on every thread of the pool (each thread streams its own contiguous pieces,
//! first touched by the thread pool that later streams them).
//!
//! # The PMB bound
//! A step of peridyn's PMB (the closed-block loop, see `material::bond_based`) streams per
//! directed bond, counting only the per-bond arrays (per-point data is ≈ 1/120 of it on the
//! bench's 122-neighbour families and mostly cache-resident): the neighbour index (4 B), the
//! reference length ζ (8 B) and the bond damage (4 B, read, and written where a bond breaks),
//! so [`PMB_BYTES_PER_BOND`] = 16 B, and with a stream bandwidth `B` (bytes/s) no PMB step can
//! evaluate more than `B / 16` directed bonds per second. The bench prints the evaluations per
//! second it reaches and their fraction of that bound: on one thread against the one-thread
//! bandwidth, on N threads against the all-thread bandwidth.

use std::time::Instant;

use rayon::prelude::*;

/// Bytes a PMB step streams per directed bond evaluation (module docs: neighbour index, ζ and
/// damage).
pub const PMB_BYTES_PER_BOND: f64 = 16.0;

/// Timed passes per measurement; the best counts (as in STREAM).
const PASSES: usize = 5;

/// Elements per parallel piece: large enough that scheduling is negligible.
const PIECE: usize = 1 << 16;

/// Triad bandwidths in bytes per second.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bandwidth {
    /// One thread.
    pub one_thread: f64,
    /// All threads of the pool it was measured on.
    pub all_threads: f64,
    /// That pool's threads.
    pub threads: usize,
    /// Bytes of each of the three arrays.
    pub array_bytes: usize,
}

impl Bandwidth {
    /// The bandwidth that bounds a run on `threads` threads: the one-thread figure for one
    /// thread, the all-thread figure otherwise.
    pub fn for_threads(&self, threads: usize) -> f64 {
        if threads <= 1 {
            self.one_thread
        } else {
            self.all_threads
        }
    }

    /// The most directed PMB bond evaluations per second (all threads together) that
    /// `threads` threads can stream: bandwidth / [`PMB_BYTES_PER_BOND`].
    pub fn pmb_bound(&self, threads: usize) -> f64 {
        self.for_threads(threads) / PMB_BYTES_PER_BOND
    }
}

/// The largest cache of CPU 0 in bytes, from Linux's sysfs (`None` elsewhere or unreadable).
fn last_level_cache_bytes() -> Option<usize> {
    let folder = std::path::Path::new("/sys/devices/system/cpu/cpu0/cache");
    std::fs::read_dir(folder)
        .ok()?
        .filter_map(|entry| std::fs::read_to_string(entry.ok()?.path().join("size")).ok())
        .filter_map(|size| parse_cache_size(size.trim()))
        .max()
}

/// `32768K`, `1M` or a plain byte count, as sysfs writes cache sizes.
fn parse_cache_size(text: &str) -> Option<usize> {
    let (digits, unit) = match text.char_indices().find(|(_, c)| !c.is_ascii_digit()) {
        Some((at, _)) => text.split_at(at),
        None => (text, ""),
    };
    let value: usize = digits.parse().ok()?;
    let unit = match unit {
        "" => 1,
        "K" => 1 << 10,
        "M" => 1 << 20,
        "G" => 1 << 30,
        _ => return None,
    };
    value.checked_mul(unit)
}

/// Bytes of each triad array for a last-level cache of `cache` bytes: eight times the cache,
/// at least 64 MiB, at most 1 GiB (unknown cache: 256 MiB).
fn array_bytes_for(cache: Option<usize>) -> usize {
    cache.map_or(256 << 20, |c| c.saturating_mul(8).clamp(64 << 20, 1 << 30))
}

/// Measures the triad bandwidth on one thread and on every thread of the current rayon pool.
pub fn measure_bandwidth() -> Bandwidth {
    let array_bytes = array_bytes_for(last_level_cache_bytes());
    let n = array_bytes / 8;
    let mut a = vec![0.0f64; n];
    let mut b = vec![0.0f64; n];
    let mut c = vec![0.0f64; n];
    // First touch in the pool's threads, in the pieces they stream later.
    a.par_chunks_mut(PIECE)
        .zip(b.par_chunks_mut(PIECE))
        .zip(c.par_chunks_mut(PIECE))
        .for_each(|((a, b), c)| {
            a.fill(1.0);
            b.fill(2.0);
            c.fill(0.5);
        });
    let bytes = 24.0 * n as f64;
    let best = |run: &mut dyn FnMut()| -> f64 {
        run(); // warm-up: page tables, frequency
        (0..PASSES)
            .map(|_| {
                let start = Instant::now();
                run();
                bytes / start.elapsed().as_secs_f64()
            })
            .fold(0.0, f64::max)
    };
    let scalar = std::hint::black_box(3.0);
    let one_thread = best(&mut || {
        triad(&mut a, &b, &c, scalar);
        std::hint::black_box(&mut a);
    });
    let all_threads = best(&mut || {
        a.par_chunks_mut(PIECE)
            .zip(b.par_chunks(PIECE))
            .zip(c.par_chunks(PIECE))
            .for_each(|((a, b), c)| triad(a, b, c, scalar));
        std::hint::black_box(&mut a);
    });
    Bandwidth {
        one_thread,
        all_threads,
        threads: rayon::current_num_threads(),
        array_bytes,
    }
}

/// `a = b + s·c`, element by element (vectorised by the compiler).
fn triad(a: &mut [f64], b: &[f64], c: &[f64], s: f64) {
    for ((a, &b), &c) in a.iter_mut().zip(b).zip(c) {
        *a = b + s * c;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cache_sizes_parse_as_sysfs_writes_them() {
        assert_eq!(parse_cache_size("32K"), Some(32 * 1024));
        assert_eq!(parse_cache_size("32768K"), Some(32 << 20));
        assert_eq!(parse_cache_size("1M"), Some(1 << 20));
        assert_eq!(parse_cache_size("4096"), Some(4096));
        assert_eq!(parse_cache_size("12Q"), None);
        assert_eq!(parse_cache_size(""), None);
    }

    #[test]
    fn arrays_are_much_larger_than_the_cache_and_bounded() {
        // 32 MiB cache → 8 × 32 MiB = 256 MiB; a small cache still gets 64 MiB; a huge one is
        // capped at 1 GiB.
        assert_eq!(array_bytes_for(Some(32 << 20)), 256 << 20);
        assert_eq!(array_bytes_for(Some(1 << 20)), 64 << 20);
        assert_eq!(array_bytes_for(Some(1 << 30)), 1 << 30);
        assert_eq!(array_bytes_for(None), 256 << 20);
    }

    #[test]
    fn bound_is_bandwidth_over_bytes_per_bond() {
        // 16 GB/s over 16 B per bond: 1e9 evaluations/s; one thread uses the one-thread figure.
        let b = Bandwidth {
            one_thread: 8e9,
            all_threads: 16e9,
            threads: 2,
            array_bytes: 0,
        };
        assert_eq!(b.pmb_bound(2), 1e9);
        assert_eq!(b.pmb_bound(1), 0.5e9);
    }
}
