//! The summary table of `peridyn bench`: medians over the repeats of every configuration.

use std::fmt::Write as _;

use super::bandwidth::{Bandwidth, PMB_BYTES_PER_BOND};
use super::lammps::LammpsRun;
use super::measure::Measurement;
use super::problem::BenchModel;
use super::Series;

/// Median of a non-empty list (mean of the middle two for an even count).
pub fn median(values: &[f64]) -> f64 {
    assert!(!values.is_empty(), "median of an empty list");
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let mid = sorted.len() / 2;
    if sorted.len() % 2 == 1 {
        sorted[mid]
    } else {
        0.5 * (sorted[mid - 1] + sorted[mid])
    }
}

/// A rate in bond evaluations per second, as the table and the progress lines print it.
pub fn format_rate(rate: f64) -> String {
    format!("{rate:.3e}")
}

/// The summary table (medians over repeats).
pub fn table(series: &[Series], bandwidth: &Bandwidth) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "\n{:<16} {:>7} {:>9} {:>12} {:>18} {:>8} {:>14} {:>10} {:>9} {:>16} {:>10} {:>8} {:>13} {:>13}",
        "model",
        "threads",
        "setup s",
        "loop ms/step",
        "bond evals/s/core",
        "cpu use",
        "LAMMPS ms/step",
        "per-core ×",
        "speed-up",
        "evals/CPU-s",
        "per-CPU-s ×",
        "of bound",
        "B/bond plan",
        "B/bond RSS"
    );
    for entry in series {
        let name = format!(
            "{}{}",
            entry.model.lammps_name(),
            if entry.contact { " + contact" } else { "" }
        );
        let lammps = lammps_medians(&entry.lammps);
        let single = entry.runs.first().map(|(_, runs)| {
            median(
                &runs
                    .iter()
                    .map(Measurement::ms_per_step)
                    .collect::<Vec<_>>(),
            )
        });
        for (threads, runs) in &entry.runs {
            // The bandwidth bound is PMB's: its bytes per bond are counted in `bandwidth`.
            let bound = (entry.model == BenchModel::Pmb).then(|| bandwidth.pmb_bound(*threads));
            out.push_str(&row(&name, *threads, runs, single, lammps, bound));
        }
    }
    let _ = writeln!(
        out,
        "bond evals/s/core = directed bonds × steps / loop wall time / threads; per-core × = peridyn per core / LAMMPS (1 proc);\n\
         evals/CPU-s = the same per CPU-second (run CPU time scaled to the loop; LAMMPS: loop × its `% CPU use`); medians of the repeats;\n\
         of bound = directed bonds × steps / loop wall time (all threads) over the PMB bandwidth bound, triad bandwidth ({:.1} GB/s on 1 thread, {:.1} GB/s on {}) / {PMB_BYTES_PER_BOND} B per directed bond;\n\
         B/bond plan = `peridyn check`'s memory estimate / directed bonds; B/bond RSS = peak resident memory of the run above the resident memory before it / directed bonds",
        bandwidth.one_thread * 1e-9,
        bandwidth.all_threads * 1e-9,
        bandwidth.threads
    );
    out
}

/// Medians of LAMMPS's runs of one configuration, when it ran.
#[derive(Debug, Clone, Copy)]
struct LammpsMedians {
    /// Loop milliseconds per step.
    ms_per_step: f64,
    /// The bond count LAMMPS printed in its first run.
    bonds: Option<usize>,
    /// Bond evaluations per CPU-second, when LAMMPS printed its CPU use.
    rate_per_cpu_second: Option<f64>,
}

fn lammps_medians(runs: &[LammpsRun]) -> Option<LammpsMedians> {
    (!runs.is_empty()).then(|| {
        let ms = median(&runs.iter().map(LammpsRun::ms_per_step).collect::<Vec<_>>());
        let cpu_rates: Vec<f64> = runs
            .iter()
            .filter_map(LammpsRun::rate_per_cpu_second)
            .collect();
        LammpsMedians {
            ms_per_step: ms,
            bonds: runs[0].bonds,
            rate_per_cpu_second: (!cpu_rates.is_empty()).then(|| median(&cpu_rates)),
        }
    })
}

/// The table line of one thread count of one configuration; `single` is the one-thread median
/// ms/step of the configuration, for the speed-up.
fn row(
    name: &str,
    threads: usize,
    runs: &[Measurement],
    single: Option<f64>,
    lammps: Option<LammpsMedians>,
    bound: Option<f64>,
) -> String {
    let pick = |f: fn(&Measurement) -> f64| median(&runs.iter().map(f).collect::<Vec<_>>());
    let ms = pick(Measurement::ms_per_step);
    let rate = pick(Measurement::rate_per_core);
    let setup = pick(|m| m.setup_seconds);
    let cpu: Vec<f64> = runs.iter().filter_map(Measurement::cpu_use).collect();
    let cpu = if cpu.is_empty() {
        "n/a".to_string()
    } else {
        format!("{:.0} %", median(&cpu) * 100.0)
    };
    // Per-core ratio: peridyn's rate per core over LAMMPS's (one process), with each
    // code's own bond count.
    let cpu_rates: Vec<f64> = runs
        .iter()
        .filter_map(Measurement::rate_per_cpu_second)
        .collect();
    let cpu_rate = (!cpu_rates.is_empty()).then(|| median(&cpu_rates));
    let cpu_ratio = match (cpu_rate, lammps.and_then(|l| l.rate_per_cpu_second)) {
        (Some(ours), Some(theirs)) => format!("{:.2}", ours / theirs),
        _ => "-".into(),
    };
    let cpu_rate = cpu_rate.map_or("n/a".into(), format_rate);
    let (lammps_ms, ratio) = match lammps {
        Some(LammpsMedians {
            ms_per_step: lammps_ms,
            bonds: lammps_bonds,
            ..
        }) => {
            let bonds = lammps_bonds.unwrap_or(runs[0].bonds) as f64;
            let lammps_rate = bonds / (lammps_ms * 1e-3);
            (
                format!("{lammps_ms:.2}"),
                format!("{:.2}", rate / lammps_rate),
            )
        }
        None => ("-".into(), "-".into()),
    };
    let speedup = match single {
        Some(one) if threads > 1 => format!("{:.2}", one / ms),
        _ => "-".into(),
    };
    let of_bound = bound.map_or("-".into(), |bound| {
        format!("{:.0} %", 100.0 * rate * threads as f64 / bound)
    });
    let planned = pick(Measurement::planned_bytes_per_bond);
    let measured: Vec<f64> = runs
        .iter()
        .filter_map(Measurement::measured_bytes_per_bond)
        .collect();
    let measured = if measured.is_empty() {
        "n/a".to_string()
    } else {
        format!("{:.1}", median(&measured))
    };
    format!(
        "{name:<16} {threads:>7} {setup:>9.2} {ms:>12.2} {:>18} {cpu:>8} {lammps_ms:>14} {ratio:>10} {speedup:>9} {cpu_rate:>16} {cpu_ratio:>10} {of_bound:>8} {planned:>13.1} {measured:>13}\n",
        format_rate(rate)
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_of_odd_and_even_lists() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 3.0, 2.0]), 2.5);
    }
}
