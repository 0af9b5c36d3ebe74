//! Shared set-up of the kernel benchmarks: the LAMMPS comparison lattice (30³ simple-cubic
//! points, spacing 1, δ = 3.015, Morton order), its families, deterministic displacements,
//! process CPU time and medians.
#![allow(dead_code)]

use peridyn::model::BondList;

/// Points per edge of the lattice.
pub const SIDE: usize = 30;
/// Horizon δ in lattice spacings (LAMMPS's `m = 3.015`).
pub const HORIZON: f64 = 3.015;

pub fn spread_bits(mut v: u64) -> u64 {
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
pub fn lattice() -> Vec<[f64; 3]> {
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
pub fn families(x: &[[f64; 3]]) -> BondList {
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
pub fn displaced(x: &[[f64; 3]], amplitude: f64) -> Vec<[f64; 3]> {
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

/// Process CPU seconds (user + system, all threads) from `/proc/self/stat` (Linux, fields 14
/// and 15 in USER_HZ = 100 ticks); NaN elsewhere. On a shared machine CPU time is steadier
/// than wall time: it does not count the time the process waits for a core.
pub fn cpu_seconds() -> f64 {
    let read = || -> Option<f64> {
        let text = std::fs::read_to_string("/proc/self/stat").ok()?;
        let fields: Vec<&str> = text[text.rfind(')')? + 1..].split_whitespace().collect();
        Some((fields.get(11)?.parse::<f64>().ok()? + fields.get(12)?.parse::<f64>().ok()?) / 100.0)
    };
    read().unwrap_or(f64::NAN)
}

/// Median of the repeats.
pub fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    let mid = values.len() / 2;
    if values.len() % 2 == 1 {
        values[mid]
    } else {
        0.5 * (values[mid - 1] + values[mid])
    }
}
