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
        let single = entry.runs.first().map(|(_, runs)| &runs[..]);
        for (threads, runs) in &entry.runs {
            // The bandwidth bound is PMB's: its bytes per bond are counted in `bandwidth`.
            let bound = (entry.model == BenchModel::Pmb).then(|| bandwidth.pmb_bound(*threads));
            out.push_str(&row(&name, *threads, runs, single, &entry.lammps, bound));
        }
    }
    let _ = writeln!(
        out,
        "bond evals/s/core = directed bonds × steps / loop wall time / threads; per-core × = peridyn per core / LAMMPS (1 proc);\n\
         evals/CPU-s = the same per CPU-second (run CPU time scaled to the loop; LAMMPS: loop × its `% CPU use`); medians of the repeats;\n\
         per-core ×, per-CPU-s × and speed-up (1-thread / N-thread loop time) pair the runs of the same repeat, which ran one after the other, and take the median of the pairs' ratios;\n\
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
}

fn lammps_medians(runs: &[LammpsRun]) -> Option<LammpsMedians> {
    (!runs.is_empty()).then(|| {
        let ms = median(&runs.iter().map(LammpsRun::ms_per_step).collect::<Vec<_>>());
        LammpsMedians {
            ms_per_step: ms,
            bonds: runs[0].bonds,
        }
    })
}

/// The median over the repeats of `ratio(ours[k], theirs[k])`: pairing the runs of one repeat,
/// which ran one after the other, keeps a ratio of two codes or two thread counts apart from
/// the drift of a shared machine's speed between repeats (a ratio of medians may take its two
/// medians from different repeats). `None` when there is no pair.
fn paired_median<A, B>(
    ours: &[A],
    theirs: &[B],
    ratio: impl Fn(&A, &B) -> Option<f64>,
) -> Option<f64> {
    let ratios: Vec<f64> = ours
        .iter()
        .zip(theirs)
        .filter_map(|(a, b)| ratio(a, b))
        .collect();
    (!ratios.is_empty()).then(|| median(&ratios))
}

/// The table line of one thread count of one configuration; `single` holds the one-thread runs
/// of the configuration, for the speed-up, and `lammps` LAMMPS's runs (one per repeat, when it
/// ran).
fn row(
    name: &str,
    threads: usize,
    runs: &[Measurement],
    single: Option<&[Measurement]>,
    lammps_runs: &[LammpsRun],
    bound: Option<f64>,
) -> String {
    let lammps = lammps_medians(lammps_runs);
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
    let cpu_ratio = paired_median(runs, lammps_runs, |ours, theirs| {
        Some(ours.rate_per_cpu_second()? / theirs.rate_per_cpu_second()?)
    })
    .map_or("-".into(), |r| format!("{r:.2}"));
    let cpu_rate = cpu_rate.map_or("n/a".into(), format_rate);
    let (lammps_ms, ratio) = match lammps {
        Some(LammpsMedians {
            ms_per_step: lammps_ms,
            bonds: lammps_bonds,
            ..
        }) => {
            let bonds = lammps_bonds.unwrap_or(runs[0].bonds) as f64;
            let ratio = paired_median(runs, lammps_runs, |ours, theirs| {
                Some(ours.rate_per_core() / (bonds / (theirs.ms_per_step() * 1e-3)))
            });
            (
                format!("{lammps_ms:.2}"),
                ratio.map_or("-".into(), |r| format!("{r:.2}")),
            )
        }
        None => ("-".into(), "-".into()),
    };
    let speedup = match single {
        Some(one) if threads > 1 => paired_median(one, runs, |one, many| {
            Some(one.ms_per_step() / many.ms_per_step())
        })
        .map_or("-".into(), |r| format!("{r:.2}")),
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
    fn paired_ratios_resist_drift_between_repeats() {
        // One-thread loops of 10, 20, 40 ms and two-thread loops of 5, 21, 20 ms: the machine
        // slowed down in the second repeat for the two-thread run and in the third for both.
        // Pairs give 2, 0.95 and 2 (median 2); the ratio of medians, 20/20, gives 1.
        let one = [10.0, 20.0, 40.0];
        let two = [5.0, 21.0, 20.0];
        let paired = paired_median(&one, &two, |a, b| Some(a / b));
        assert_eq!(paired, Some(2.0));
        assert_eq!(median(&one) / median(&two), 1.0);
        assert_eq!(paired_median(&one, &[] as &[f64], |a, b| Some(a / b)), None);
        assert_eq!(paired_median(&one, &two, |_, _| None), None);
    }

    #[test]
    fn median_of_odd_and_even_lists() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 3.0, 2.0]), 2.5);
    }
}
