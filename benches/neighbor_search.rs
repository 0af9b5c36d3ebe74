//! Family-search throughput: `cargo bench --bench neighbor_search`.
//!
//! 100³ cell-centred lattice, δ = 3.015Δx (122 neighbours in the interior), points in Morton
//! order as the run uses them, on rayon pools of 1 and 2 threads, for the cell-grid and k-d tree
//! backends; then a uniform random cloud of 1e6 points (≈100 neighbours). Times include building
//! the search structure and the CSR with reference lengths. Prints numbers only; no assertions.
//! Environment: `NEIGHBOR_BENCH_N` lattice edge (default 100), `NEIGHBOR_BENCH_BACKEND`
//! (`grid`/`kd`), `NEIGHBOR_BENCH_THREADS` (e.g. `1,2`), `NEIGHBOR_BENCH_SKIP_RANDOM`,
//! `NEIGHBOR_BENCH_VERBOSE` (print every run, not only the best of three),
//! `NEIGHBOR_BENCH_DIRECT` (raise the first point's horizon by one ulp: the search is then no
//! longer symmetric and takes the direct assembly instead of the mirrored one, for comparing
//! the two on otherwise the same work).

use std::time::Instant;

use peridyn::neighbors::{
    find_families_with, space_filling_curve_order, FamilySearch, NeighborhoodRule, SearchBackend,
};

fn lattice(n: usize, h: f64) -> Vec<[f64; 3]> {
    let mut points = Vec::with_capacity(n * n * n);
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                points.push([
                    (i as f64 + 0.5) * h,
                    (j as f64 + 0.5) * h,
                    (k as f64 + 0.5) * h,
                ]);
            }
        }
    }
    points
}

fn random_cloud(n: usize) -> Vec<[f64; 3]> {
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..n).map(|_| [next(), next(), next()]).collect()
}

fn morton(points: Vec<[f64; 3]>) -> Vec<[f64; 3]> {
    let started = Instant::now();
    let order = space_filling_curve_order(&points);
    println!(
        "  space_filling_curve_order: {:.3} s",
        started.elapsed().as_secs_f64()
    );
    order.iter().map(|&i| points[i as usize]).collect()
}

/// CPU seconds used by this process so far (user + system, from /proc/self/stat), so that the
/// figures stay meaningful on a machine shared with other jobs.
fn cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    // Fields after the parenthesised command name; utime and stime are fields 14 and 15.
    let after = stat.rsplit(')').next().unwrap_or("");
    let fields: Vec<&str> = after.split_whitespace().collect();
    let ticks = |k: usize| {
        fields
            .get(k)
            .and_then(|v| v.parse::<f64>().ok())
            .unwrap_or(0.0)
    };
    (ticks(11) + ticks(12)) / 100.0
}

fn env_list(name: &str) -> Option<String> {
    std::env::var(name).ok()
}

fn run(label: &str, positions: &[[f64; 3]], horizon: f64) {
    let mut horizons = vec![horizon; positions.len()];
    if env_list("NEIGHBOR_BENCH_DIRECT").is_some() {
        horizons[0] = f64::from_bits(horizon.to_bits() + 1);
    }
    let blocks = vec![0u32; positions.len()];
    let search = FamilySearch {
        positions,
        horizons: &horizons,
        blocks: &blocks,
        rule: NeighborhoodRule::Sphere,
        omit_bonds_between_blocks: false,
        filters: &[],
    };
    let backends: Vec<SearchBackend> = match env_list("NEIGHBOR_BENCH_BACKEND").as_deref() {
        Some("grid") => vec![SearchBackend::CellGrid],
        Some("kd") => vec![SearchBackend::KdTree],
        _ => vec![SearchBackend::CellGrid, SearchBackend::KdTree],
    };
    let thread_counts: Vec<usize> = match env_list("NEIGHBOR_BENCH_THREADS") {
        Some(t) => t.split(',').filter_map(|v| v.parse().ok()).collect(),
        None => vec![1, 2],
    };
    for &backend in &backends {
        for &threads in &thread_counts {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("rayon pool");
            // Best of three: the machine is shared.
            let mut best = f64::INFINITY;
            let mut best_cpu = f64::INFINITY;
            let mut bonds = 0;
            for _ in 0..3 {
                let started = Instant::now();
                let cpu = cpu_seconds();
                let families = pool
                    .install(|| find_families_with(&search, backend))
                    .expect("valid input");
                best = best.min(started.elapsed().as_secs_f64());
                best_cpu = best_cpu.min(cpu_seconds() - cpu);
                if env_list("NEIGHBOR_BENCH_VERBOSE").is_some() {
                    println!("    run: {:.3} s", started.elapsed().as_secs_f64());
                }
                bonds = families.num_bonds();
                drop(families);
            }
            let n = positions.len() as f64;
            println!(
                "{label} {backend:?} threads={threads}: {best:.3} s wall ({best_cpu:.2} s CPU), {:.3e} points/s, {:.3e} bonds/s, {:.1} bonds/point",
                n / best,
                bonds as f64 / best,
                bonds as f64 / n
            );
        }
    }
}

fn main() {
    let n: usize = std::env::var("NEIGHBOR_BENCH_N")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(100);
    println!("lattice {n}³, δ = 3.015Δx");
    let points = morton(lattice(n, 1.0));
    run("lattice", &points, 3.015);
    let count = n * n * n;
    // ≈100 neighbours: (4/3)π r³ · count = 100.
    let radius = (100.0 / (count as f64 * 4.0 / 3.0 * std::f64::consts::PI)).cbrt();
    if env_list("NEIGHBOR_BENCH_SKIP_RANDOM").is_some() {
        return;
    }
    println!("uniform random cloud, {count} points, r = {radius:.4}");
    let points = morton(random_cloud(count));
    run("random", &points, radius);
}
