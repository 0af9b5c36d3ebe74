//! The AVX2 builds of the two LPS row sums ([`Rows::dilatation`] and [`Rows::add_force`]),
//! written with intrinsics: four bonds per register from the loads of Y_j (and of the
//! neighbour's force coefficients A_j, B_j) to the bond terms, which are then added one by
//! one in bond order, as the staged loops add them.
//!
//! Every bond evaluates the same IEEE operations in the same order as the staged loops (q =
//! (dx² + dy²) + dz², the dilatation term `((ω(1−d)·ζ)·e)·V_j`, the force factor of
//! [`force_scale`]), so θ and the forces are bitwise theirs. The last `len mod 4` bonds of a
//! row take the scalar formulas.
//!
//! Measured and rejected: staging the force row's geometry (Y_j − Y_i and |Y_j − Y_i| of 16
//! groups of four bonds computed first, kept in registers spilled to the stack, then the
//! forces), so the square roots need not wait behind the divisions and sums of earlier bonds.
//! `peridyn run` of the LAMMPS comparison deck with LPS, one thread, alternated with the loop
//! above (2026-11-28): 1.14 and 1.07 times the loop time (medians of 8 pairs each, either
//! order).

use super::{dilatation_term, force_scale, RowBreaker, Rows, LANES};
use crate::material::avx2::{bond_lanes, broadcast, exceeding_lanes, lanes, load_field, BondLanes};
use crate::material::{checked_row, BondWeights, Integrity, PointCoefficients};
use crate::model::VolumeRule;
use std::arch::x86_64::{
    __m256d, _mm256_add_pd, _mm256_and_pd, _mm256_cmp_pd, _mm256_div_pd, _mm256_loadu_pd,
    _mm256_mul_pd, _mm256_set1_pd, _mm256_setzero_pd, _mm256_sqrt_pd, _mm256_sub_pd, _CMP_GT_OQ,
};

/// Element offsets of A (`isotropic`) and B (`deviatoric`) in a [`PointCoefficients`], which
/// is three f64 (loaded as a record of three, like the coordinates).
const ISOTROPIC: usize = std::mem::offset_of!(PointCoefficients, isotropic) / 8;
const DEVIATORIC: usize = std::mem::offset_of!(PointCoefficients, deviatoric) / 8;
const _: () = assert!(std::mem::size_of::<PointCoefficients>() == 3 * 8);

/// Four f64 lanes from an array.
#[target_feature(enable = "avx2")]
#[inline]
fn vector(values: &[f64; LANES]) -> __m256d {
    // SAFETY: `values` holds four f64.
    unsafe { _mm256_loadu_pd(values.as_ptr()) }
}

/// `Σ_j ω (1−d) ζ e V_j` over the row of point i (block-local index of its first bond
/// `local`), added in bond order, after the bonds `breaker` breaks in it (counted in
/// `broken`): the sum of [`Rows::dilatation`].
///
/// # Safety
/// The CPU supports AVX2; `bound` is from [`crate::material::gather_bound`] over the
/// positions' length (or less), the volume rule and `damage`; the contract of `breaker`
/// ([`RowBreaker`]) holds for the row of i.
#[allow(clippy::too_many_arguments)]
#[target_feature(enable = "avx2")]
pub(super) unsafe fn dilatation_sum<V: VolumeRule, W: BondWeights, D: Integrity, B: RowBreaker>(
    rows: &Rows<'_, V>,
    i: usize,
    local: usize,
    bound: usize,
    weights: W,
    damage: D,
    breaker: B,
    broken: &mut usize,
) -> f64 {
    let bonds = rows.reference.bonds;
    let y = rows.current.position;
    let yi = y[i];
    let range = bonds.range(i);
    let first = range.start;
    let (neighbors, lengths) = checked_row(bonds, range, bound);
    let coordinates = y.as_ptr().cast::<f64>();
    let origin = broadcast(yi);
    let mut sum = 0.0;
    let full = neighbors.len() - neighbors.len() % LANES;
    for at in (0..full).step_by(LANES) {
        let bond = first + at;
        // SAFETY: at + 4 <= full <= the row's length (both arrays); every neighbour is below
        // `bound` <= y.len() (`checked_row`).
        let BondLanes { zeta, squared, .. } =
            unsafe { bond_lanes(neighbors, lengths, at, coordinates, &origin) };
        if let Some(limit) = breaker.limit() {
            let exceeding = exceeding_lanes(limit, squared, zeta);
            for lane in (0..LANES).filter(|lane| exceeding & (1 << lane) != 0) {
                // SAFETY: the bond is in the row of i (the breaker's contract).
                if unsafe { breaker.damage(bond + lane) } < 1.0 {
                    // SAFETY: as above.
                    unsafe { breaker.break_bond(bond + lane) };
                    *broken += 1;
                }
            }
        }
        // Read after the breaking above.
        let mut weight = [0.0; LANES];
        let mut volume = [0.0; LANES];
        for lane in 0..LANES {
            // SAFETY: the bonds are in the row, below `bonds.neighbor.len()`, which `damage`
            // and the volume rule cover, and their neighbours are below `bound`.
            unsafe {
                weight[lane] =
                    weights.weight(local + at + lane) * damage.intact_unchecked(bond + lane);
                volume[lane] = rows
                    .volume
                    .of_unchecked(bond + lane, neighbors[at + lane] as usize);
            }
        }
        let extension = _mm256_sub_pd(_mm256_sqrt_pd(squared), zeta);
        let term = _mm256_mul_pd(
            _mm256_mul_pd(_mm256_mul_pd(vector(&weight), zeta), extension),
            vector(&volume),
        );
        for t in lanes(term) {
            sum += t;
        }
    }
    for n in full..neighbors.len() {
        let (b, j) = (first + n, neighbors[n] as usize);
        let yj = y[j];
        let (dx, dy, dz) = (yj[0] - yi[0], yj[1] - yi[1], yj[2] - yi[2]);
        let squared = dx * dx + dy * dy + dz * dz;
        let zeta = lengths[n];
        if let Some(limit) = breaker.limit() {
            // SAFETY: the bond is in the row of i (the breaker's contract).
            if !limit.certainly_intact(squared, zeta)
                && unsafe { breaker.damage(b) } < 1.0
                && limit.exceeded(squared, zeta)
            {
                // SAFETY: as above.
                unsafe { breaker.break_bond(b) };
                *broken += 1;
            }
        }
        // SAFETY: as for the lanes above.
        let (intact, volume) =
            unsafe { (damage.intact_unchecked(b), rows.volume.of_unchecked(b, j)) };
        sum += dilatation_term(weights.weight(local + n) * intact, zeta, squared, volume);
    }
    sum
}

/// `Σ_j t_ij V_j M_ij` over the row of point i (block-local index of its first bond `local`),
/// each component added in bond order: the force of [`Rows::add_force`].
///
/// # Safety
/// The CPU supports AVX2; `bound` is from [`crate::material::gather_bound`] over the least of
/// the positions' and `coefficients`' lengths (or less), the volume rule and `damage`.
#[allow(clippy::too_many_arguments)]
#[target_feature(enable = "avx2")]
pub(super) unsafe fn force_sum<V: VolumeRule, W: BondWeights, D: Integrity>(
    rows: &Rows<'_, V>,
    coefficients: &[PointCoefficients],
    i: usize,
    local: usize,
    bound: usize,
    weights: W,
    damage: D,
) -> [f64; 3] {
    let bonds = rows.reference.bonds;
    let y = rows.current.position;
    let yi = y[i];
    let own = coefficients[i];
    let range = bonds.range(i);
    let first = range.start;
    let (neighbors, lengths) = checked_row(bonds, range, bound);
    let coordinates = y.as_ptr().cast::<f64>();
    let records = coefficients.as_ptr().cast::<f64>();
    let origin = broadcast(yi);
    let own_isotropic = _mm256_set1_pd(own.isotropic);
    let own_deviatoric = _mm256_set1_pd(own.deviatoric);
    let zero = _mm256_setzero_pd();
    let mut total = [0.0; 3];
    let full = neighbors.len() - neighbors.len() % LANES;
    for at in (0..full).step_by(LANES) {
        let bond = first + at;
        // SAFETY: at + 4 <= full <= the row's length (both arrays); every neighbour is below
        // `bound` <= y.len(), coefficients.len().
        let (
            BondLanes {
                zeta, d, squared, ..
            },
            other_isotropic,
            other_deviatoric,
        ) = unsafe {
            let bonds = bond_lanes(neighbors, lengths, at, coordinates, &origin);
            let (isotropic, deviatoric) = (
                load_field(records, &bonds.j, ISOTROPIC),
                load_field(records, &bonds.j, DEVIATORIC),
            );
            (bonds, isotropic, deviatoric)
        };
        let mut intact = [0.0; LANES];
        let mut omega = [0.0; LANES];
        let mut volume = [0.0; LANES];
        for lane in 0..LANES {
            // SAFETY: as for the dilatation sum.
            unsafe {
                intact[lane] = damage.intact_unchecked(bond + lane);
                volume[lane] = rows
                    .volume
                    .of_unchecked(bond + lane, neighbors[at + lane] as usize);
            }
            omega[lane] = weights.weight(local + at + lane);
        }
        let intact = vector(&intact);
        let length = _mm256_sqrt_pd(squared);
        let extension = _mm256_sub_pd(length, zeta);
        let isotropic = _mm256_mul_pd(_mm256_add_pd(own_isotropic, other_isotropic), zeta);
        let deviatoric = _mm256_mul_pd(
            _mm256_mul_pd(intact, _mm256_add_pd(own_deviatoric, other_deviatoric)),
            extension,
        );
        let t = _mm256_mul_pd(
            _mm256_mul_pd(intact, vector(&omega)),
            _mm256_add_pd(isotropic, deviatoric),
        );
        let scale = _mm256_div_pd(_mm256_mul_pd(t, vector(&volume)), length);
        // The factor where |Y| > 0, +0 elsewhere (as `force_scale`).
        let scale = _mm256_and_pd(scale, _mm256_cmp_pd::<_CMP_GT_OQ>(length, zero));
        for c in 0..3 {
            for part in lanes(_mm256_mul_pd(scale, d[c])) {
                total[c] += part;
            }
        }
    }
    for n in full..neighbors.len() {
        let (b, j) = (first + n, neighbors[n] as usize);
        let (yj, other) = (y[j], coefficients[j]);
        let (dx, dy, dz) = (yj[0] - yi[0], yj[1] - yi[1], yj[2] - yi[2]);
        // SAFETY: as for the lanes above.
        let (intact, volume) =
            unsafe { (damage.intact_unchecked(b), rows.volume.of_unchecked(b, j)) };
        let scale = force_scale(
            intact * weights.weight(local + n),
            intact,
            own.isotropic + other.isotropic,
            own.deviatoric + other.deviatoric,
            lengths[n],
            (dx * dx + dy * dy + dz * dz).sqrt(),
            volume,
        );
        total[0] += scale * dx;
        total[1] += scale * dy;
        total[2] += scale * dz;
    }
    total
}
