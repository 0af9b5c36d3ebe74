//! Damage-update throughput on the LAMMPS comparison lattice (`shared/bench/lammps`): 30³
//! simple-cubic points, spacing 1, δ = 3.015 (2 929 168 directed bonds), Morton order.
//!
//! Cases: `Critical Stretch` s_c = 5e-4 with displacements far below it (nothing breaks, the
//! common case of a step), with displacements that break a few percent of the bonds (broken
//! bonds are skipped afterwards, as in a run), and `Interface Aware` with the same limit on every
//! point; the first two again without [`DamageModel::prepare`] (the directed loop that tests
//! every bond from both ends). Prints directed bonds per second per core (wall) and per CPU-second (steadier on a
//! shared machine) for 1 and 2 rayon threads, medians of `DAMAGE_KERNELS_REPEAT` (default 3)
//! runs of 100 updates. No assertions on time. Run: `cargo bench --bench damage_kernels`.

use std::hint::black_box;
use std::sync::Arc;
use std::time::Instant;

use peridyn::damage::{CriticalStretch, DamageModel, InterfaceAware};
use peridyn::material::ReferenceView;

mod common;

use common::{cpu_seconds, displaced, families, lattice, median, SIDE};

const UPDATES: usize = 100;
const CRITICAL_STRETCH: f64 = 5e-4;

fn main() {
    let x = lattice();
    let volume = vec![1.0; x.len()];
    let bonds = families(&x);
    let reference = ReferenceView {
        bonds: &bonds,
        position: &x,
        volume: &volume,
        bond_volume: None,
    };
    let num_bonds = bonds.num_bonds();
    let points: Vec<u32> = (0..x.len() as u32).collect();
    println!(
        "lattice {SIDE}³ = {} points, {num_bonds} directed bonds, {UPDATES} updates per run",
        x.len()
    );
    // Relative displacements of neighbours are at most 2√3·amplitude per unit of ζ ≥ 1:
    // 3.5e-5 < s_c for the intact case; 8e-4 breaks a few percent of the bonds.
    let intact = displaced(&x, 1e-5);
    let cracked = displaced(&x, 8e-4);
    let directed = CriticalStretch::new(CRITICAL_STRETCH).unwrap();
    let mut critical_stretch = directed.clone();
    critical_stretch.prepare(&reference, &points);
    assert!(critical_stretch.is_prepared());
    let mut interface_aware =
        InterfaceAware::new(CRITICAL_STRETCH, Arc::from(vec![CRITICAL_STRETCH; x.len()])).unwrap();
    interface_aware.prepare(&reference, &points);
    let cases: [(&str, &dyn DamageModel, &[[f64; 3]]); 5] = [
        ("critical stretch, none break", &critical_stretch, &intact),
        ("critical stretch, some broken", &critical_stretch, &cracked),
        ("interface aware, none break", &interface_aware, &intact),
        ("directed loop, none break", &directed, &intact),
        ("directed loop, some broken", &directed, &cracked),
    ];
    let repeats: usize = std::env::var("DAMAGE_KERNELS_REPEAT")
        .ok()
        .and_then(|r| r.parse().ok())
        .unwrap_or(3);
    println!(
        "{:<34} {:>8} {:>10} {:>12} {:>20} {:>20}",
        "case", "threads", "broken %", "ms/update", "bonds/s/core", "bonds/CPU-s"
    );
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            for (name, model, y) in cases {
                let mut damage = vec![0.0f32; num_bonds];
                // Warm-up: breaks what the displacements break, so that the timed updates see
                // the steady state of a run (broken bonds stay broken and are skipped).
                let broken = model.update(&reference, y, &points, &mut damage);
                let runs: Vec<(f64, f64)> = (0..repeats)
                    .map(|_| {
                        let cpu = cpu_seconds();
                        let start = Instant::now();
                        for _ in 0..UPDATES {
                            black_box(model.update(&reference, y, &points, &mut damage));
                        }
                        (start.elapsed().as_secs_f64(), cpu_seconds() - cpu)
                    })
                    .collect();
                let work = (num_bonds * UPDATES) as f64;
                let wall = median(runs.iter().map(|r| r.0).collect());
                let cpu_rate = median(runs.iter().map(|r| work / r.1).collect());
                println!(
                    "{name:<34} {threads:>8} {:>10.2} {:>12.3} {:>20.3e} {:>20.3e}",
                    100.0 * broken as f64 / num_bonds as f64,
                    wall * 1e3 / UPDATES as f64,
                    work / wall / threads as f64,
                    cpu_rate
                );
            }
        });
    }
}
