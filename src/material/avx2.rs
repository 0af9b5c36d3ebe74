//! Building blocks of the bond loops written with AVX2 intrinsics (x86_64 only): four bonds
//! of a row per 256-bit register, their neighbours' per-point values loaded one by one into
//! the lanes (on the AMD Zen 3 this was measured on, `vgatherdpd` made the PMB loop 1.3 times
//! and the LPS force loop 1.5 times slower than scalar loads).
//!
//! The loops built from these give bitwise the results of the baseline loops they replace:
//! each helper is one IEEE operation per lane, in the order the baseline writes it.

use crate::damage::StretchLimit;
use std::arch::x86_64::{
    __m256d, _mm256_add_pd, _mm256_and_pd, _mm256_cmp_pd, _mm256_loadu_pd, _mm256_movemask_pd,
    _mm256_mul_pd, _mm256_set1_pd, _mm256_set_pd, _mm256_storeu_pd, _mm256_sub_pd, _CMP_GE_OQ,
    _CMP_LE_OQ,
};

/// Bonds per register.
pub(crate) const LANES: usize = 4;

/// The neighbours `neighbors[0..4]` as indices.
///
/// # Safety
/// `neighbors` points to four readable u32.
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn neighbor_lanes(neighbors: *const u32) -> [usize; LANES] {
    // SAFETY: as the caller guarantees.
    unsafe { [0, 1, 2, 3].map(|lane| *neighbors.add(lane) as usize) }
}

/// Element `field` of the records of three f64 (coordinates, [`PointCoefficients`]) of the
/// neighbours `j`.
///
/// [`PointCoefficients`]: crate::material::PointCoefficients
///
/// # Safety
/// Every neighbour's record is in the array starting at `records`.
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) unsafe fn load_field(records: *const f64, j: &[usize; LANES], field: usize) -> __m256d {
    // SAFETY: as the caller guarantees.
    unsafe {
        _mm256_set_pd(
            *records.add(3 * j[3] + field),
            *records.add(3 * j[2] + field),
            *records.add(3 * j[1] + field),
            *records.add(3 * j[0] + field),
        )
    }
}

/// Y_j − Y_i by component for the neighbours `j` of the coordinate array starting at
/// `coordinates`, with `origin` = Y_i broadcast.
///
/// # Safety
/// Every neighbour is a point of the coordinate array.
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn loaded_differences(
    coordinates: *const f64,
    j: &[usize; LANES],
    origin: &[__m256d; 3],
) -> [__m256d; 3] {
    // SAFETY: as the caller guarantees.
    unsafe {
        [
            _mm256_sub_pd(load_field(coordinates, j, 0), origin[0]),
            _mm256_sub_pd(load_field(coordinates, j, 1), origin[1]),
            _mm256_sub_pd(load_field(coordinates, j, 2), origin[2]),
        ]
    }
}

/// Four bonds of a row in registers ([`bond_lanes`]).
pub(crate) struct BondLanes {
    /// The neighbours j.
    pub j: [usize; LANES],
    /// ζ.
    pub zeta: __m256d,
    /// Y_j − Y_i by component.
    pub d: [__m256d; 3],
    /// q = |Y_j − Y_i|² ([`squared_length`]).
    pub squared: __m256d,
}

/// The bonds at row positions `at..at + 4` of a row (`neighbors` and `lengths` as
/// [`checked_row`](crate::material::checked_row) gives them), with Y_i = `origin` and the
/// coordinates at `coordinates`.
///
/// # Safety
/// `at + 4` is at most the length of both slices; every neighbour is a point of the
/// coordinate array.
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) unsafe fn bond_lanes(
    neighbors: &[u32],
    lengths: &[f64],
    at: usize,
    coordinates: *const f64,
    origin: &[__m256d; 3],
) -> BondLanes {
    // SAFETY: as the caller guarantees.
    unsafe {
        let j = neighbor_lanes(neighbors.as_ptr().add(at));
        let d = loaded_differences(coordinates, &j, origin);
        BondLanes {
            j,
            zeta: _mm256_loadu_pd(lengths.as_ptr().add(at)),
            squared: squared_length(&d),
            d,
        }
    }
}

/// Y_i broadcast by component.
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn broadcast(yi: [f64; 3]) -> [__m256d; 3] {
    [
        _mm256_set1_pd(yi[0]),
        _mm256_set1_pd(yi[1]),
        _mm256_set1_pd(yi[2]),
    ]
}

/// q = dx*dx + dy*dy + dz*dz (left to right, no fused multiply-add), the number the damage
/// models test.
#[target_feature(enable = "avx2")]
#[inline]
fn squared_length(d: &[__m256d; 3]) -> __m256d {
    _mm256_add_pd(
        _mm256_add_pd(_mm256_mul_pd(d[0], d[0]), _mm256_mul_pd(d[1], d[1])),
        _mm256_mul_pd(d[2], d[2]),
    )
}

/// The lanes [`StretchLimit::certainly_intact`] clears, as bits 0–3.
#[target_feature(enable = "avx2")]
#[inline]
fn cleared_lanes(limit: StretchLimit, squared: __m256d, zeta: __m256d) -> i32 {
    let z2 = _mm256_mul_pd(zeta, zeta);
    let below = _mm256_cmp_pd::<_CMP_LE_OQ>(
        squared,
        _mm256_mul_pd(z2, _mm256_set1_pd(limit.intact_factor())),
    );
    let normal = _mm256_cmp_pd::<_CMP_GE_OQ>(z2, _mm256_set1_pd(f64::MIN_POSITIVE));
    _mm256_movemask_pd(_mm256_and_pd(below, normal))
}

/// The lanes (bits 0–3) whose stretch exceeds the limit, by the exact test
/// [`StretchLimit::exceeded`] on the lanes the filter [`cleared_lanes`] does not clear (the
/// decisions of the staged loops' `certainly_intact`-then-`exceeded`); usually 0 at once.
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn exceeding_lanes(limit: StretchLimit, squared: __m256d, zeta: __m256d) -> i32 {
    let cleared = cleared_lanes(limit, squared, zeta);
    if cleared == 0b1111 {
        return 0;
    }
    let (q, z) = (lanes(squared), lanes(zeta));
    let mut exceeding = 0;
    for lane in 0..LANES {
        if cleared & (1 << lane) == 0 && limit.exceeded(q[lane], z[lane]) {
            exceeding |= 1 << lane;
        }
    }
    exceeding
}

/// The four lanes of a register.
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn lanes(v: __m256d) -> [f64; LANES] {
    let mut out = [0.0; LANES];
    // SAFETY: `out` holds four f64.
    unsafe { _mm256_storeu_pd(out.as_mut_ptr(), v) };
    out
}
