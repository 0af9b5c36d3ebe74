//! Small deterministic fixtures shared by the material and damage tests.

use crate::model::BondList;

/// SplitMix64: tiny, deterministic, good enough for test fixtures.
pub(crate) struct Rng(u64);

impl Rng {
    pub(crate) fn new(seed: u64) -> Self {
        Self(seed)
    }

    /// Uniform in [0, 1).
    pub(crate) fn uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Standard normal (Box–Muller).
    pub(crate) fn normal(&mut self) -> f64 {
        let u = 1.0 - self.uniform();
        let v = self.uniform();
        (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    }
}

/// `n` points uniformly in a cube of side `size`, volumes uniform in [0.5, 1.5).
pub(crate) fn random_cloud(rng: &mut Rng, n: usize, size: f64) -> (Vec<[f64; 3]>, Vec<f64>) {
    let x = (0..n)
        .map(|_| {
            [
                size * rng.uniform(),
                size * rng.uniform(),
                size * rng.uniform(),
            ]
        })
        .collect();
    let v = (0..n).map(|_| 0.5 + rng.uniform()).collect();
    (x, v)
}

/// Simple-cubic lattice of `n³` points with spacing 1, x fastest.
pub(crate) fn lattice(n: usize) -> Vec<[f64; 3]> {
    let mut x = Vec::with_capacity(n * n * n);
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                x.push([i as f64, j as f64, k as f64]);
            }
        }
    }
    x
}

/// Families by brute force with Peridigm's rule |X_j − X_i|² ≤ δ² (symmetric by construction).
pub(crate) fn brute_force_bonds(x: &[[f64; 3]], horizon: f64) -> BondList {
    let mut bonds = BondList {
        offsets: vec![0],
        ..Default::default()
    };
    for (i, a) in x.iter().enumerate() {
        for (j, b) in x.iter().enumerate() {
            let d2 = (b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2) + (b[2] - a[2]).powi(2);
            if i != j && d2 <= horizon * horizon {
                bonds.neighbor.push(j as u32);
                bonds.reference_length.push(d2.sqrt());
            }
        }
        bonds.offsets.push(bonds.neighbor.len());
    }
    bonds
}
