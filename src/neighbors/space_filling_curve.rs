//! Point ordering along a Morton (Z-order) space-filling curve.
//!
//! Points that are close in space get close indices, so a family's neighbours sit in a few
//! nearby cache lines and the neighbour search, force loops and sparse matrices touch memory
//! almost sequentially. Points are renumbered once, after reading; `original_id` keeps the
//! input order, in which every output is written.

use rayon::prelude::*;

/// Bits per axis of the Morton key: 3 × 21 = 63 bits fit a `u64`.
const BITS_PER_AXIS: u32 = 21;

/// Permutation that sorts `positions` along a Morton curve: new point `k` is old point
/// `order[k]` (the convention of [`crate::model::PointCloud::permute`]).
///
/// The curve lives on the bounding **cube** of the points (same scale on all axes, so the
/// ordering is isotropic) divided into 2²¹ cells per axis; points sharing a cell keep their input
/// order, which makes the result deterministic. Non-finite coordinates are placed in cell 0.
pub fn space_filling_curve_order(positions: &[[f64; 3]]) -> Vec<u32> {
    assert!(
        positions.len() <= u32::MAX as usize,
        "point indices are u32; {} points do not fit",
        positions.len()
    );
    if positions.is_empty() {
        return Vec::new();
    }
    let (lo, hi) = bounding_box(positions);
    let extent = (0..3).map(|k| hi[k] - lo[k]).fold(0.0_f64, f64::max);
    let cells = (1u64 << BITS_PER_AXIS) as f64;
    // Largest coordinate maps to cells − 1, not cells.
    let scale = if extent > 0.0 {
        (cells - 1.0) / extent
    } else {
        0.0
    };
    let mut keyed: Vec<(u64, u32)> = positions
        .par_iter()
        .enumerate()
        .map(|(i, p)| {
            let cell = |k: usize| {
                let c = ((p[k] - lo[k]) * scale).floor();
                // NaN casts to 0; out-of-range cannot occur for finite input but is clamped.
                (c as u64).min((1u64 << BITS_PER_AXIS) - 1)
            };
            (morton_key(cell(0), cell(1), cell(2)), i as u32)
        })
        .collect();
    keyed.par_sort_unstable();
    keyed.into_iter().map(|(_, i)| i).collect()
}

fn bounding_box(positions: &[[f64; 3]]) -> ([f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in positions {
        for k in 0..3 {
            if p[k].is_finite() {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
    }
    for k in 0..3 {
        if lo[k] > hi[k] {
            lo[k] = 0.0;
            hi[k] = 0.0;
        }
    }
    (lo, hi)
}

/// Interleaves the low 21 bits of x, y, z as …z₁y₁x₁z₀y₀x₀.
fn morton_key(x: u64, y: u64, z: u64) -> u64 {
    spread_bits(x) | (spread_bits(y) << 1) | (spread_bits(z) << 2)
}

/// Moves bit b of `v` (b < 21) to bit 3b.
fn spread_bits(v: u64) -> u64 {
    let mut v = v & 0x1f_ffff;
    v = (v | (v << 32)) & 0x001f_0000_0000_ffff;
    v = (v | (v << 16)) & 0x001f_0000_ff00_00ff;
    v = (v | (v << 8)) & 0x100f_00f0_0f00_f00f;
    v = (v | (v << 4)) & 0x10c3_0c30_c30c_30c3;
    v = (v | (v << 2)) & 0x1249_2492_4924_9249;
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spread_bits_moves_each_bit_to_three_times_its_place() {
        for b in 0..BITS_PER_AXIS {
            assert_eq!(spread_bits(1 << b), 1 << (3 * b), "bit {b}");
        }
        assert_eq!(morton_key(1, 0, 0), 0b001);
        assert_eq!(morton_key(0, 1, 0), 0b010);
        assert_eq!(morton_key(0, 0, 1), 0b100);
        assert_eq!(morton_key(3, 0, 0), 0b001_001);
    }

    fn lattice(n: usize) -> Vec<[f64; 3]> {
        // x fastest, then y, then z: PdQuickGrid's input order.
        let mut points = Vec::with_capacity(n * n * n);
        for k in 0..n {
            for j in 0..n {
                for i in 0..n {
                    points.push([i as f64, j as f64, k as f64]);
                }
            }
        }
        points
    }

    #[test]
    fn order_is_a_permutation() {
        let points = lattice(7);
        let order = space_filling_curve_order(&points);
        let mut seen = vec![false; points.len()];
        for &i in &order {
            assert!(!seen[i as usize], "index {i} twice");
            seen[i as usize] = true;
        }
        assert!(seen.iter().all(|&s| s));
        assert!(space_filling_curve_order(&[]).is_empty());
        assert_eq!(space_filling_curve_order(&[[1.0, 2.0, 3.0]]), vec![0]);
    }

    #[test]
    fn near_points_get_near_indices() {
        // Index distance |Δ| over the 6-neighbour bonds of a 32³ lattice. In x-fastest input
        // order a third of the bonds have Δ = 1, 32 and 1024 each: median 32, geometric mean
        // 2^((0+5+10)/3) = 32. The arithmetic mean is useless here: Morton's rare jumps across
        // large blocks make it exactly as large as the input order's, (1 + n + n²)/3 = 352.3.
        // A Morton order keeps half of the bonds inside 2×2×2 blocks (Δ ∈ {1,2,4}): median 4,
        // geometric mean ≈ 2^3.42 ≈ 10.7 (computed independently with a short script).
        let n = 32;
        let points = lattice(n);
        let order = space_filling_curve_order(&points);
        let mut new_index = vec![0usize; points.len()];
        for (new, &old) in order.iter().enumerate() {
            new_index[old as usize] = new;
        }
        let id = |i: usize, j: usize, k: usize| i + n * (j + n * k);
        let mut input_gaps = Vec::new();
        let mut curve_gaps = Vec::new();
        for k in 0..n {
            for j in 0..n {
                for i in 0..n {
                    let a = id(i, j, k);
                    let mut neighbours = Vec::new();
                    if i + 1 < n {
                        neighbours.push(id(i + 1, j, k));
                    }
                    if j + 1 < n {
                        neighbours.push(id(i, j + 1, k));
                    }
                    if k + 1 < n {
                        neighbours.push(id(i, j, k + 1));
                    }
                    for b in neighbours {
                        input_gaps.push(b.abs_diff(a));
                        curve_gaps.push(new_index[b].abs_diff(new_index[a]));
                    }
                }
            }
        }
        let median = |gaps: &mut Vec<usize>| {
            gaps.sort_unstable();
            gaps[gaps.len() / 2]
        };
        let log_mean = |gaps: &[usize]| {
            gaps.iter().map(|&g| (g as f64).log2()).sum::<f64>() / gaps.len() as f64
        };
        assert_eq!(median(&mut input_gaps), 32);
        assert!((log_mean(&input_gaps) - 5.0).abs() < 1e-12);
        assert_eq!(median(&mut curve_gaps), 4);
        let curve_log_mean = log_mean(&curve_gaps);
        assert!(
            curve_log_mean < 3.5,
            "Morton log2 mean gap {curve_log_mean}"
        );
    }
}
