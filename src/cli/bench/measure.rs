//! One timed peridyn run of the benchmark deck.

use std::path::Path;
use std::time::Instant;

use peridyn::io::deck::{self, DeckFormat};
use peridyn::setup;
use peridyn::simulation;

use super::problem::{deck_yaml, BenchModel};
use super::BenchError;

/// One peridyn run of the benchmark.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measurement {
    /// Rayon threads.
    pub threads: usize,
    /// Points in the model.
    pub points: usize,
    /// Directed bonds in the model.
    pub bonds: usize,
    /// Steps taken.
    pub steps: u64,
    /// Seconds from the deck text to the first step: parsing, discretization, families,
    /// materials, initial conditions and the initial force evaluation.
    pub setup_seconds: f64,
    /// Seconds in the time-step loop.
    pub loop_seconds: f64,
    /// Process CPU seconds (all threads) over the whole `simulation::run` call, when the
    /// platform reports it; compare with `run_wall_seconds × threads`.
    pub run_cpu_seconds: Option<f64>,
    /// Wall seconds of the whole `simulation::run` call (physics set-up + loop).
    pub run_wall_seconds: f64,
    /// Bonds broken during the run.
    pub broken_bonds: usize,
    /// Peak resident memory of the process from the deck text to the end of the run, bytes
    /// (`VmHWM` of `/proc/self/status`, reset before the run through `/proc/self/clear_refs`);
    /// `None` where Linux does not report it or the reset is refused.
    pub peak_rss_bytes: Option<u64>,
    /// Resident memory just before the deck text was read (the binary, the pool, the bench's
    /// own arrays), bytes.
    pub rss_before_bytes: Option<u64>,
    /// The memory `peridyn check` plans for the run ([`peridyn::plan::RunPlan::memory_total`]),
    /// bytes.
    pub planned_bytes: u64,
}

impl Measurement {
    /// Loop milliseconds per step.
    pub fn ms_per_step(&self) -> f64 {
        self.loop_seconds * 1e3 / self.steps as f64
    }

    /// Directed bond evaluations per second per core: bonds × steps / loop time / threads.
    pub fn rate_per_core(&self) -> f64 {
        self.bonds as f64 * self.steps as f64 / self.loop_seconds / self.threads as f64
    }

    /// Directed bond evaluations per CPU-second of the loop, estimated as the run's CPU time
    /// scaled by loop wall / run wall (the loop is nearly all of the run). On a shared
    /// machine this is steadier than the wall-clock rate: it does not count time spent waiting
    /// for a core (it does count rayon's idle spinning).
    pub fn rate_per_cpu_second(&self) -> Option<f64> {
        let cpu = self.run_cpu_seconds? * self.loop_seconds / self.run_wall_seconds;
        (cpu > 0.0).then(|| self.bonds as f64 * self.steps as f64 / cpu)
    }

    /// CPU use of the run as a fraction of `threads` busy cores (1.0 = every thread busy).
    pub fn cpu_use(&self) -> Option<f64> {
        self.run_cpu_seconds
            .map(|cpu| cpu / self.run_wall_seconds / self.threads as f64)
    }

    /// Planned bytes per directed bond: everything `peridyn check` plans (per point and per
    /// bond) divided by the directed bonds.
    pub fn planned_bytes_per_bond(&self) -> f64 {
        self.planned_bytes as f64 / self.bonds as f64
    }

    /// Measured bytes per directed bond: the run's peak resident memory above the resident
    /// memory before it started, divided by the directed bonds.
    pub fn measured_bytes_per_bond(&self) -> Option<f64> {
        let grown = self.peak_rss_bytes?.saturating_sub(self.rss_before_bytes?);
        Some(grown as f64 / self.bonds as f64)
    }
}

/// A `kB` field of `/proc/self/status` (`VmRSS`, `VmHWM`) in bytes; `None` off Linux.
fn status_bytes(field: &str) -> Option<u64> {
    let text = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = text.lines().find(|l| l.starts_with(field))?;
    let kib: u64 = line[field.len()..]
        .trim_start_matches(':')
        .trim()
        .trim_end_matches("kB")
        .trim()
        .parse()
        .ok()?;
    Some(kib * 1024)
}

/// Gives the heap memory that earlier runs freed back to the system (glibc keeps freed chunks
/// of its arenas resident), so that the next run's growth above the resident memory before it
/// counts what that run holds, not what it reuses.
fn release_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: malloc_trim only returns free heap pages to the system; it touches no live
    // allocation.
    unsafe {
        libc::malloc_trim(0);
    }
}

/// Resets the peak resident memory (`VmHWM`) to the current one: writing 5 to
/// `/proc/self/clear_refs` does that (Linux ≥ 4.0). False when refused.
fn reset_peak_rss() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

/// Process CPU time (user + system, all threads) in seconds, from `/proc/self/stat` (Linux;
/// fields 14 and 15 in clock ticks of `USER_HZ`, which Linux fixes at 100 for this file).
/// `None` elsewhere.
fn process_cpu_seconds() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/self/stat").ok()?;
    // The command name (field 2) may contain spaces; the fields after it start after ')'.
    let rest = &text[text.rfind(')')? + 1..];
    let fields: Vec<&str> = rest.split_whitespace().collect();
    // `rest` starts at field 3 (state), so field 14 is at index 11.
    let user: f64 = fields.get(11)?.parse().ok()?;
    let system: f64 = fields.get(12)?.parse().ok()?;
    Some((user + system) / 100.0)
}

/// A fresh pool of `threads` rayon threads.
pub fn thread_pool(threads: usize) -> Result<rayon::ThreadPool, BenchError> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| BenchError::Pool {
            threads,
            message: e.to_string(),
        })
}

/// Runs the benchmark deck once on a fresh pool of `threads` rayon threads, exactly as
/// `peridyn run` would (no output files are requested, so nothing is written).
pub fn measure(
    model: BenchModel,
    points_per_edge: usize,
    steps: u64,
    contact: bool,
    threads: usize,
) -> Result<Measurement, BenchError> {
    let pool = thread_pool(threads)?;
    pool.install(|| {
        release_freed_memory();
        let rss_before_bytes = status_bytes("VmRSS");
        let peak_reset = reset_peak_rss();
        let start = Instant::now();
        let text = deck_yaml(model, points_per_edge, steps, contact);
        let deck = deck::parse_str(&text, DeckFormat::Yaml, Path::new("<bench deck>"))
            .map_err(|e| BenchError::Deck(e.to_string()))?;
        let missing = setup::unsupported_features(&deck);
        if !missing.is_empty() {
            return Err(BenchError::Unsupported(missing.join(", ")));
        }
        let built = setup::build(&deck).map_err(|e| BenchError::Deck(e.to_string()))?;
        let build_seconds = start.elapsed().as_secs_f64();
        // Planned outside the timed set-up (`peridyn run` does not plan).
        let planned_bytes = setup::plan(&deck, &built)
            .map_err(|e| BenchError::Deck(e.to_string()))?
            .memory_total;
        let cpu_before = process_cpu_seconds();
        let run_start = Instant::now();
        let summary = simulation::run(&deck, &built, &std::env::temp_dir())?;
        let run_wall_seconds = run_start.elapsed().as_secs_f64();
        let run_cpu_seconds = match (cpu_before, process_cpu_seconds()) {
            (Some(before), Some(after)) => Some(after - before),
            _ => None,
        };
        Ok(Measurement {
            threads,
            points: built.points.len(),
            bonds: built.bonds.num_bonds(),
            steps: summary.steps,
            setup_seconds: build_seconds + (run_wall_seconds - summary.solve_seconds),
            loop_seconds: summary.solve_seconds,
            run_cpu_seconds,
            run_wall_seconds,
            broken_bonds: summary.broken_bonds,
            peak_rss_bytes: status_bytes("VmHWM").filter(|_| peak_reset),
            rss_before_bytes,
            planned_bytes,
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn short_run_takes_the_requested_steps_and_breaks_bonds() {
        // 8³ block, 5 steps: the slab interface moves apart at 30 m/s, so after one step of
        // 5e-8 s the bonds across it stretch by 1.5e-6 m over ζ ≥ 1 mm, i.e. s ≥ 1.5e-3 minus
        // the (smaller) elastic response, above the critical stretch 5e-4: bonds must break.
        for model in [BenchModel::Pmb, BenchModel::Lps] {
            let m = measure(model, 8, 5, false, 1).unwrap();
            assert_eq!(m.steps, 5);
            assert_eq!(m.points, 512);
            assert!(m.broken_bonds > 0, "{model:?}: no bond broke");
            assert!(m.loop_seconds > 0.0 && m.rate_per_core() > 0.0);
        }
    }
}
