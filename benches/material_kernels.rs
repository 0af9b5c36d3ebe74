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
    BlockInput, BondBased, BondBasedParameters, CurrentView, ElasticConstants, InfluenceFunction,
    LinearPeridynamicSolid, Material, PointCoefficients, ReferenceView,
};
mod common;

use common::{cpu_seconds, displaced, families, lattice, median, HORIZON, SIDE};

const EVALUATIONS: usize = 100;

struct Case<'a> {
    name: &'static str,
    material: Box<dyn Material>,
    damage: Option<&'a [f32]>,
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
        bond_volume: None,
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
            BondBased::new(
                &BlockInput {
                    density,
                    horizon: HORIZON,
                    influence: InfluenceFunction::One,
                },
                &BondBasedParameters {
                    bulk_modulus: bulk,
                    planar_thickness: None,
                },
            )
            .unwrap(),
        )
    };
    let make_lps = |influence: InfluenceFunction| -> Box<dyn Material> {
        Box::new(
            LinearPeridynamicSolid::new(
                &BlockInput {
                    density,
                    horizon: HORIZON,
                    influence,
                },
                &ElasticConstants {
                    bulk_modulus: bulk,
                    shear_modulus: shear,
                },
            )
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
                    history: &peridyn::state::NO_HISTORY,
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
