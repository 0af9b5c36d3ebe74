//! Force-kernel throughput on the LAMMPS comparison lattice (`shared/bench/lammps`): 30³
//! simple-cubic points, spacing 1, δ = 3.015 (122-point interior family, 2 929 168 directed
//! bonds), points sorted along a Morton curve as the run does, small random displacements.
//!
//! Prints directed bond evaluations per second per core (bonds × evaluations / wall time /
//! threads) and per CPU-second (bonds × evaluations / process CPU time, steadier on a shared
//! machine) for 1 and 2 rayon threads, medians of `MATERIAL_KERNELS_REPEAT` (default 3) runs. One LPS evaluation is the dilatation pass plus the force pass.
//! No assertions on time. Run: `cargo bench --bench material_kernels`.

use std::hint::black_box;
use std::time::Instant;

use peridyn::damage::{CriticalStretch, DamageModel};
use peridyn::material::{
    BondBased, BondBasedParameters, CurrentView, InfluenceFunction, LinearPeridynamicSolid,
    LinearPeridynamicSolidParameters, Material, PointCoefficients, ReferenceView,
};
use peridyn::model::BondList;

const SIDE: usize = 30;
const HORIZON: f64 = 3.015;
const EVALUATIONS: usize = 100;

fn spread_bits(mut v: u64) -> u64 {
    // Interleave: bit k of v moves to bit 3k.
    v &= 0x1f_ffff;
    v = (v | (v << 32)) & 0x1f_0000_0000_ffff;
    v = (v | (v << 16)) & 0x1f_0000_ff00_00ff;
    v = (v | (v << 8)) & 0x100f_00f0_0f00_f00f;
    v = (v | (v << 4)) & 0x10c3_0c30_c30c_30c3;
    v = (v | (v << 2)) & 0x1249_2492_4924_9249;
    v
}

/// Lattice points in Morton order.
fn lattice() -> Vec<[f64; 3]> {
    let mut cells: Vec<(u64, [f64; 3])> = Vec::with_capacity(SIDE * SIDE * SIDE);
    for k in 0..SIDE {
        for j in 0..SIDE {
            for i in 0..SIDE {
                let key = spread_bits(i as u64)
                    | (spread_bits(j as u64) << 1)
                    | (spread_bits(k as u64) << 2);
                cells.push((key, [i as f64, j as f64, k as f64]));
            }
        }
    }
    cells.sort_by_key(|c| c.0);
    cells.into_iter().map(|c| c.1).collect()
}

/// Families with |X_j − X_i|² ≤ δ² through a cell grid of cell size δ.
fn families(x: &[[f64; 3]]) -> BondList {
    let cells_per_side = ((SIDE as f64) / HORIZON).ceil() as usize + 1;
    let cell_of = |p: &[f64; 3]| {
        let c = |v: f64| ((v / HORIZON) as usize).min(cells_per_side - 1);
        (c(p[0]), c(p[1]), c(p[2]))
    };
    let index = |(a, b, c): (usize, usize, usize)| a + cells_per_side * (b + cells_per_side * c);
    let mut grid = vec![Vec::new(); cells_per_side.pow(3)];
    for (n, p) in x.iter().enumerate() {
        grid[index(cell_of(p))].push(n as u32);
    }
    let mut bonds = BondList {
        offsets: vec![0],
        ..Default::default()
    };
    for (i, p) in x.iter().enumerate() {
        let (a, b, c) = cell_of(p);
        let mut row: Vec<u32> = Vec::new();
        for cz in c.saturating_sub(1)..=(c + 1).min(cells_per_side - 1) {
            for cy in b.saturating_sub(1)..=(b + 1).min(cells_per_side - 1) {
                for cx in a.saturating_sub(1)..=(a + 1).min(cells_per_side - 1) {
                    for &j in &grid[index((cx, cy, cz))] {
                        let q = x[j as usize];
                        let d2 =
                            (q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2) + (q[2] - p[2]).powi(2);
                        if j as usize != i && d2 <= HORIZON * HORIZON {
                            row.push(j);
                        }
                    }
                }
            }
        }
        row.sort_unstable();
        for j in row {
            let q = x[j as usize];
            let d2 = (q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2) + (q[2] - p[2]).powi(2);
            bonds.neighbor.push(j);
            bonds.reference_length.push(d2.sqrt());
        }
        bonds.offsets.push(bonds.neighbor.len());
    }
    bonds
}

/// Deterministic small displacements, uniform in ±amplitude.
fn displaced(x: &[[f64; 3]], amplitude: f64) -> Vec<[f64; 3]> {
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    x.iter()
        .map(|p| {
            [
                p[0] + amplitude * next(),
                p[1] + amplitude * next(),
                p[2] + amplitude * next(),
            ]
        })
        .collect()
}

struct Case<'a> {
    name: &'static str,
    material: Box<dyn Material>,
    damage: Option<&'a [f32]>,
}

/// Process CPU seconds (user + system, all threads) from `/proc/self/stat` (Linux, fields 14
/// and 15 in USER_HZ = 100 ticks); NaN elsewhere. On a shared machine CPU time is steadier
/// than wall time: it does not count the time the process waits for a core.
fn cpu_seconds() -> f64 {
    let read = || -> Option<f64> {
        let text = std::fs::read_to_string("/proc/self/stat").ok()?;
        let fields: Vec<&str> = text[text.rfind(')')? + 1..].split_whitespace().collect();
        Some((fields.get(11)?.parse::<f64>().ok()? + fields.get(12)?.parse::<f64>().ok()?) / 100.0)
    };
    read().unwrap_or(f64::NAN)
}

/// (wall, CPU) seconds of `EVALUATIONS` calls of `work`, after one warm-up call (page faults,
/// caches).
fn time_it(mut work: impl FnMut()) -> (f64, f64) {
    work();
    let cpu = cpu_seconds();
    let start = Instant::now();
    for _ in 0..EVALUATIONS {
        work();
    }
    (start.elapsed().as_secs_f64(), cpu_seconds() - cpu)
}

/// One full force evaluation (coefficients when needed, then force).
fn evaluate(
    case: &Case<'_>,
    reference: &ReferenceView<'_>,
    current: &CurrentView<'_>,
    coefficients: &mut [PointCoefficients],
    force: &mut [[f64; 3]],
) {
    force.iter_mut().for_each(|f| *f = [0.0; 3]);
    if case.material.needs_dilatation() {
        case.material
            .compute_point_coefficients(reference, current, coefficients);
    }
    case.material
        .add_force_density(reference, current, coefficients, force);
    black_box(&force);
}

/// Median of the repeats.
fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    let mid = values.len() / 2;
    if values.len() % 2 == 1 {
        values[mid]
    } else {
        0.5 * (values[mid - 1] + values[mid])
    }
}

/// Prints one row: median wall ms per evaluation, median wall rate per core, median rate per
/// CPU-second (the per-core rate the kernel reaches when it has the core to itself).
fn report(name: &str, threads: usize, num_bonds: usize, runs: &[(f64, f64)]) {
    let work = (num_bonds * EVALUATIONS) as f64;
    let wall = median(runs.iter().map(|r| r.0).collect());
    let cpu_rate = median(runs.iter().map(|r| work / r.1).collect());
    println!(
        "{:<32} {:>8} {:>12.2} {:>20.3e} {:>20.3e}",
        name,
        threads,
        wall * 1e3 / EVALUATIONS as f64,
        work / wall / threads as f64,
        cpu_rate
    );
}

fn main() {
    let x = lattice();
    let volume = vec![1.0; x.len()];
    let bonds = families(&x);
    let reference = ReferenceView {
        bonds: &bonds,
        position: &x,
        volume: &volume,
    };
    let y = displaced(&x, 1e-3);
    let num_bonds = bonds.num_bonds();
    println!(
        "lattice {SIDE}³ = {} points, δ = {HORIZON}, {num_bonds} directed bonds, {EVALUATIONS} evaluations",
        x.len()
    );
    let points: Vec<u32> = (0..x.len() as u32).collect();
    let intact = vec![0.0f32; num_bonds];

    // Glass-like constants of the LAMMPS deck: E = 72 GPa, ν = 0.25 → K = 48 GPa, μ = 28.8 GPa.
    let (bulk, shear, density) = (48e9, 28.8e9, 2440.0);
    let make_pmb = || -> Box<dyn Material> {
        Box::new(
            BondBased::new(BondBasedParameters {
                density,
                bulk_modulus: bulk,
                horizon: HORIZON,
                planar_thickness: None,
            })
            .unwrap(),
        )
    };
    let make_lps = |influence: InfluenceFunction| -> Box<dyn Material> {
        Box::new(
            LinearPeridynamicSolid::new(LinearPeridynamicSolidParameters {
                density,
                bulk_modulus: bulk,
                shear_modulus: shear,
                horizon: HORIZON,
                influence,
            })
            .unwrap(),
        )
    };
    let mut cases = vec![
        Case {
            name: "PMB",
            material: make_pmb(),
            damage: None,
        },
        Case {
            name: "PMB + damage array",
            material: make_pmb(),
            damage: Some(&intact),
        },
        Case {
            name: "LPS (ω = One)",
            material: make_lps(InfluenceFunction::One),
            damage: None,
        },
        Case {
            name: "LPS (ω = One) + damage array",
            material: make_lps(InfluenceFunction::One),
            damage: Some(&intact),
        },
        Case {
            name: "LPS (ω = Gaussian, stored)",
            material: make_lps(InfluenceFunction::Gaussian),
            damage: None,
        },
    ];
    // Optional filter for quick runs: `MATERIAL_KERNELS=PMB cargo bench --bench material_kernels`.
    if let Ok(filter) = std::env::var("MATERIAL_KERNELS") {
        cases.retain(|c| c.name.contains(filter.as_str()));
    }
    for case in &mut cases {
        case.material.setup(&reference, points.clone()).unwrap();
    }

    println!(
        "{:<32} {:>8} {:>12} {:>20} {:>20}",
        "kernel", "threads", "ms/eval", "bond evals/s/core", "bond evals/CPU-s"
    );
    let repeats: usize = std::env::var("MATERIAL_KERNELS_REPEAT")
        .ok()
        .and_then(|r| r.parse().ok())
        .unwrap_or(3);
    let n = x.len();
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut coefficients = vec![PointCoefficients::default(); n];
            let mut force = vec![[0.0; 3]; n];
            for case in &cases {
                let current = CurrentView {
                    position: &y,
                    bond_damage: case.damage,
                };
                case.material
                    .compute_point_coefficients(&reference, &current, &mut coefficients);
                // Median of the repeats: the machine is shared.
                let runs: Vec<(f64, f64)> = (0..repeats)
                    .map(|_| {
                        time_it(|| {
                            evaluate(case, &reference, &current, &mut coefficients, &mut force)
                        })
                    })
                    .collect();
                report(case.name, threads, num_bonds, &runs);
            }
            if std::env::var("MATERIAL_KERNELS").is_err() {
                let model = CriticalStretch::new(5e-4).unwrap();
                let mut damage = vec![0.0f32; num_bonds];
                let runs: Vec<(f64, f64)> = (0..repeats)
                    .map(|_| {
                        time_it(|| {
                            black_box(model.update(&reference, &y, &points, &mut damage));
                        })
                    })
                    .collect();
                report("critical stretch update", threads, num_bonds, &runs);
            }
        });
    }
    println!("LAMMPS reference (whole step, 1 core): PMB 6.6e7, LPS 2.5e7 bond evals/s/core");
}
