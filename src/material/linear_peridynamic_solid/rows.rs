//! The LPS bond loops (the formulas are the parent module's): the dilatation pass, which may
//! break each bond just before it enters θ ([`RowBreaker`]), the force pass and the stored
//! energy. The hot passes take a row [`LANES`] bonds at a time and have AVX2 builds in
//! [`avx2`]; the loops with thermal strain are in `super::thermal`.

use super::{corrected_shear, LinearPeridynamicSolid};
use crate::damage::StretchLimit;
use crate::material::{
    checked_row, gather_bound, BondWeights, CurrentView, FusedCriticalStretch, Integrity,
    PointCoefficients, ReferenceView,
};
use crate::model::point_chunks::for_each_chunk;
use crate::model::VolumeRule;
use crate::vector_width::wide_vectors_available;
use std::sync::atomic::{AtomicUsize, Ordering};

#[cfg(target_arch = "x86_64")]
mod avx2;

/// What the LPS loops read, bundled once per call; `V` is the quadrature rule the hot loops
/// are compiled for.
pub(super) struct Rows<'a, V> {
    pub(super) reference: &'a ReferenceView<'a>,
    /// w_ij ([`VolumeRule`]).
    pub(super) volume: V,
    pub(super) current: &'a CurrentView<'a>,
    pub(super) points: &'a [u32],
    pub(super) local_offsets: &'a [usize],
    pub(super) weighted_volume: &'a [f64],
    pub(super) bulk: f64,
    pub(super) shear: f64,
    /// s per block point, or empty (s = 1).
    pub(super) correction: &'a [f64],
    /// The free thermal strain α ΔT of every point (parent module docs), when the block has α
    /// and the run has point temperatures; the thermal loops ([`Rows::thermal`]) read it, and
    /// the stored energy.
    pub(super) thermal_strain: Option<&'a [f64]>,
    /// The force pass runs over a subset of `points` ([`Material::restrict_forces`]), whose
    /// chunks are not contiguous runs of `points`.
    pub(super) force_subset: bool,
    /// Run the AVX2 builds of the loops ([`wide_vectors_available`]).
    pub(super) wide: bool,
}

impl<V: VolumeRule> Rows<'_, V> {
    /// Block-local index of the chunk's first point (chunks are contiguous runs of `points`).
    pub(super) fn first_local(&self, chunk: &[u32]) -> usize {
        self.points.partition_point(|&p| p < chunk[0])
    }

    /// θ_i and the published coefficients of the chunk's points, after the bonds `breaker`
    /// breaks (if any) in their rows; returns the directed bonds broken.
    ///
    /// Each row is taken [`LANES`] bonds at a time: the per-bond terms are computed lane by
    /// lane (vectorized: the square roots dominate), then added one by one in bond order, so
    /// θ is bitwise the plain running sum `Σ_j ω (1−d) ζ e V_j` whatever the vector width.
    ///
    /// # Safety
    /// The contract of `breaker` ([`RowBreaker`]) for the rows of `chunk`.
    #[inline(always)]
    unsafe fn dilatation<W: BondWeights, D: Integrity, B: RowBreaker>(
        &self,
        chunk: &[u32],
        base: usize,
        out: &mut [PointCoefficients],
        weights: W,
        damage: D,
        breaker: B,
    ) -> usize {
        let bonds = self.reference.bonds;
        let volume = self.volume;
        let y = self.current.position;
        let k0 = self.first_local(chunk);
        let points = gather_bound(bonds, y.len(), volume, damage);
        let mut broken = 0;
        for (k, &i) in (k0..).zip(chunk) {
            let i = i as usize;
            let yi = y[i];
            let range = bonds.range(i);
            let local = self.local_offsets[k];
            let (neighbors, lengths) = checked_row(bonds, range.clone(), points);
            let mut sum = 0.0;
            // Lane arrays stay in registers (written and read within one group of LANES); the
            // tail bonds are groups of one.
            macro_rules! group {
                ($start:expr, $width:expr) => {{
                    let start: usize = $start;
                    let width: usize = $width;
                    let mut squared = [0.0; LANES];
                    let mut zeta = [0.0; LANES];
                    let mut neighbor_volume = [0.0; LANES];
                    for lane in 0..width {
                        // SAFETY: start + lane < the row's length, and the row is checked
                        // (`checked_row`, `gather_bound`).
                        let (_, yj, z, w) = unsafe {
                            gather(neighbors, lengths, y, volume, range.start, start + lane)
                        };
                        let (dx, dy, dz) = (yj[0] - yi[0], yj[1] - yi[1], yj[2] - yi[2]);
                        // q = dx*dx + dy*dy + dz*dz, the number the damage models test.
                        squared[lane] = dx * dx + dy * dy + dz * dz;
                        zeta[lane] = z;
                        neighbor_volume[lane] = w;
                    }
                    if let Some(limit) = breaker.limit() {
                        // The filter of every lane first, with no branch (it vectorizes); the
                        // lanes are visited one by one only when one of them may break.
                        let mut filtered = [false; LANES];
                        for lane in 0..width {
                            filtered[lane] = limit.certainly_intact(squared[lane], zeta[lane]);
                        }
                        if !filtered[..width].iter().fold(true, |all, &f| all & f) {
                            for lane in 0..width {
                                if !filtered[lane] {
                                    let b = range.start + start + lane;
                                    // SAFETY: b is in the row of a point of this chunk (the
                                    // caller's contract).
                                    if unsafe { breaker.damage(b) } < 1.0
                                        && limit.exceeded(squared[lane], zeta[lane])
                                    {
                                        // SAFETY: as above.
                                        unsafe { breaker.break_bond(b) };
                                        broken += 1;
                                    }
                                }
                            }
                        }
                    }
                    // Read after the breaking above, and apart from the arithmetic below so
                    // that it has no indexing (bounds checks would keep it scalar).
                    let mut weight = [0.0; LANES];
                    for lane in 0..width {
                        // SAFETY: the bond is in the row, below `bonds.neighbor.len()`
                        // (`gather_bound`).
                        weight[lane] = weights.weight(local + start + lane)
                            * unsafe { damage.intact_unchecked(range.start + start + lane) };
                    }
                    let mut term = [0.0; LANES];
                    for lane in 0..width {
                        term[lane] = dilatation_term(
                            weight[lane],
                            zeta[lane],
                            squared[lane],
                            neighbor_volume[lane],
                        );
                    }
                    for &t in &term[..width] {
                        sum += t;
                    }
                }};
            }
            let full = neighbors.len() - neighbors.len() % LANES;
            for start in (0..full).step_by(LANES) {
                group!(start, LANES);
            }
            for start in full..neighbors.len() {
                group!(start, 1);
            }
            out[i - base] = self.point_coefficients(k, sum);
        }
        broken
    }

    /// θ = 3 Σ/m of block point k from its row's sum Σ = Σ_j ω (1−d) ζ e V_j, and its force
    /// coefficients A = (3K − 5μ) θ/m, B = 15μ/m (all zero when m = 0).
    #[inline(always)]
    fn point_coefficients(&self, k: usize, sum: f64) -> PointCoefficients {
        let m = self.weighted_volume[k];
        if m > 0.0 {
            let theta = 3.0 * sum / m;
            let shear = corrected_shear(self.shear, self.correction, k);
            PointCoefficients {
                dilatation: theta,
                isotropic: (3.0 * self.bulk - 5.0 * shear) * theta / m,
                deviatoric: 15.0 * shear / m,
            }
        } else {
            PointCoefficients::default()
        }
    }

    /// Block-local index of point `i`, the `n`-th of a force chunk whose first point has
    /// block-local index `k0` (when the forced points are all of them).
    #[inline(always)]
    fn force_local(&self, k0: usize, n: usize, i: u32) -> usize {
        if self.force_subset {
            self.points.partition_point(|&p| p < i)
        } else {
            k0 + n
        }
    }

    /// [`Rows::dilatation`] built for AVX2 when [`Rows::wide`], else for the baseline target;
    /// bitwise the same result (same IEEE operations in the same order, no fused
    /// multiply-add).
    ///
    /// # Safety
    /// As [`Rows::dilatation`].
    #[inline(always)]
    pub(super) unsafe fn dilatation_dispatch<W: BondWeights, D: Integrity, B: RowBreaker>(
        &self,
        chunk: &[u32],
        base: usize,
        out: &mut [PointCoefficients],
        weights: W,
        damage: D,
        breaker: B,
    ) -> usize {
        #[cfg(target_arch = "x86_64")]
        if self.wide {
            // SAFETY: AVX2 was detected at run time; the rest as the caller guarantees.
            return unsafe { self.dilatation_avx2(chunk, base, out, weights, damage, breaker) };
        }
        // SAFETY: as the caller guarantees.
        unsafe { self.dilatation(chunk, base, out, weights, damage, breaker) }
    }

    /// [`Rows::dilatation`] with AVX2: each row by the intrinsics loop
    /// `avx2::dilatation_sum` (bitwise the staged loop's sum).
    ///
    /// # Safety
    /// As [`Rows::dilatation`], and the CPU supports AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn dilatation_avx2<W: BondWeights, D: Integrity, B: RowBreaker>(
        &self,
        chunk: &[u32],
        base: usize,
        out: &mut [PointCoefficients],
        weights: W,
        damage: D,
        breaker: B,
    ) -> usize {
        let bonds = self.reference.bonds;
        let points = gather_bound(bonds, self.current.position.len(), self.volume, damage);
        let k0 = self.first_local(chunk);
        let mut broken = 0;
        for (k, &i) in (k0..).zip(chunk) {
            let i = i as usize;
            // SAFETY: AVX2 is enabled here; `points` is from `gather_bound`; the breaker's
            // contract is the caller's.
            let sum = unsafe {
                avx2::dilatation_sum(
                    self,
                    i,
                    self.local_offsets[k],
                    points,
                    weights,
                    damage,
                    breaker,
                    &mut broken,
                )
            };
            out[i - base] = self.point_coefficients(k, sum);
        }
        broken
    }

    /// The dilatation pass over every block point with the bond breaking of `fused`; returns
    /// the directed bonds broken.
    pub(super) fn fused_dilatation<W: BondWeights>(
        &self,
        coefficients: &mut [PointCoefficients],
        weights: W,
        fused: FusedCriticalStretch,
    ) -> usize {
        let broken = AtomicUsize::new(0);
        for_each_chunk(
            self.points,
            coefficients,
            &|i| i as usize,
            &|chunk: &[u32], base: usize, out: &mut [PointCoefficients]| {
                // SAFETY: the caller gives `fused` a pointer to the whole bond-damage array,
                // borrowed mutably for this call; each chunk touches only the rows of its own
                // points (the `RowBreaker` contract).
                let newly =
                    unsafe { self.dilatation_dispatch(chunk, base, out, weights, fused, fused) };
                broken.fetch_add(newly, Ordering::Relaxed);
            },
        );
        broken.into_inner()
    }

    /// `F_i += Σ_j (1−d) ω [(A_i + A_j) ζ + (1−d)(B_i + B_j) e] V_j M_ij` with A = isotropic,
    /// B = deviatoric coefficients; coincident deformed points contribute nothing. Grouped as
    /// [`Rows::dilatation`]: the bond terms are computed lane by lane and added in bond order,
    /// so F is bitwise the plain running sum.
    #[inline(always)]
    fn add_force<W: BondWeights, D: Integrity>(
        &self,
        coefficients: &[PointCoefficients],
        chunk: &[u32],
        base: usize,
        out: &mut [[f64; 3]],
        weights: W,
        damage: D,
    ) {
        let bonds = self.reference.bonds;
        let volume = self.volume;
        let y = self.current.position;
        let k0 = self.first_local(chunk);
        // Every neighbour indexes both `y` and `coefficients`.
        let points = gather_bound(bonds, y.len().min(coefficients.len()), volume, damage);
        for (n, &i) in chunk.iter().enumerate() {
            let k = self.force_local(k0, n, i);
            let i = i as usize;
            let yi = y[i];
            let own = coefficients[i];
            let range = bonds.range(i);
            let local = self.local_offsets[k];
            let (neighbors, lengths) = checked_row(bonds, range.clone(), points);
            let (mut fx, mut fy, mut fz) = (0.0, 0.0, 0.0);
            // Lane arrays stay in registers (written and read within one group of LANES); the
            // tail bonds are groups of one.
            macro_rules! group {
                ($start:expr, $width:expr) => {{
                    let start: usize = $start;
                    let width: usize = $width;
                    let mut d = [[0.0; LANES]; 3];
                    let mut zeta = [0.0; LANES];
                    let mut neighbor_volume = [0.0; LANES];
                    let mut other_isotropic = [0.0; LANES];
                    let mut other_deviatoric = [0.0; LANES];
                    // Read here, in the gather, so that the arithmetic below has no indexing
                    // (bounds checks would keep it scalar).
                    let mut intact = [0.0; LANES];
                    let mut omega = [0.0; LANES];
                    for lane in 0..width {
                        // SAFETY: start + lane < the row's length, and the row is checked
                        // (`checked_row`, `gather_bound`, j < coefficients.len()).
                        let (j, yj, z, w) = unsafe {
                            gather(neighbors, lengths, y, volume, range.start, start + lane)
                        };
                        for c in 0..3 {
                            d[c][lane] = yj[c] - yi[c];
                        }
                        zeta[lane] = z;
                        neighbor_volume[lane] = w;
                        // SAFETY: as above.
                        let other = unsafe { coefficients.get_unchecked(j) };
                        other_isotropic[lane] = other.isotropic;
                        other_deviatoric[lane] = other.deviatoric;
                        // SAFETY: as above.
                        intact[lane] =
                            unsafe { damage.intact_unchecked(range.start + start + lane) };
                        omega[lane] = weights.weight(local + start + lane);
                    }
                    let mut part = [[0.0; LANES]; 3];
                    for lane in 0..width {
                        let (dx, dy, dz) = (d[0][lane], d[1][lane], d[2][lane]);
                        let scale = force_scale(
                            intact[lane] * omega[lane],
                            intact[lane],
                            own.isotropic + other_isotropic[lane],
                            own.deviatoric + other_deviatoric[lane],
                            zeta[lane],
                            (dx * dx + dy * dy + dz * dz).sqrt(),
                            neighbor_volume[lane],
                        );
                        part[0][lane] = scale * dx;
                        part[1][lane] = scale * dy;
                        part[2][lane] = scale * dz;
                    }
                    for lane in 0..width {
                        fx += part[0][lane];
                        fy += part[1][lane];
                        fz += part[2][lane];
                    }
                }};
            }
            let full = neighbors.len() - neighbors.len() % LANES;
            for start in (0..full).step_by(LANES) {
                group!(start, LANES);
            }
            for start in full..neighbors.len() {
                group!(start, 1);
            }
            let f = &mut out[i - base];
            f[0] += fx;
            f[1] += fy;
            f[2] += fz;
        }
    }

    /// [`Rows::add_force`] built for AVX2 when [`Rows::wide`], else for the baseline target
    /// (bitwise the same result, as [`Rows::dilatation_dispatch`]).
    #[inline(always)]
    pub(super) fn add_force_dispatch<W: BondWeights, D: Integrity>(
        &self,
        coefficients: &[PointCoefficients],
        chunk: &[u32],
        base: usize,
        out: &mut [[f64; 3]],
        weights: W,
        damage: D,
    ) {
        #[cfg(target_arch = "x86_64")]
        if self.wide {
            // SAFETY: AVX2 was detected at run time.
            unsafe { self.add_force_avx2(coefficients, chunk, base, out, weights, damage) };
            return;
        }
        self.add_force(coefficients, chunk, base, out, weights, damage);
    }

    /// [`Rows::add_force`] with AVX2: each row by the intrinsics loop `avx2::force_sum`
    /// (bitwise the staged loop's force).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn add_force_avx2<W: BondWeights, D: Integrity>(
        &self,
        coefficients: &[PointCoefficients],
        chunk: &[u32],
        base: usize,
        out: &mut [[f64; 3]],
        weights: W,
        damage: D,
    ) {
        let bonds = self.reference.bonds;
        let y = self.current.position;
        let points = gather_bound(bonds, y.len().min(coefficients.len()), self.volume, damage);
        let k0 = self.first_local(chunk);
        for (n, &i) in chunk.iter().enumerate() {
            let k = self.force_local(k0, n, i);
            let i = i as usize;
            // SAFETY: AVX2 is enabled here; `points` is from `gather_bound` over both arrays
            // the row reads.
            let f = unsafe {
                avx2::force_sum(
                    self,
                    coefficients,
                    i,
                    self.local_offsets[k],
                    points,
                    weights,
                    damage,
                )
            };
            let out = &mut out[i - base];
            for c in 0..3 {
                out[c] += f[c];
            }
        }
    }

    /// `W_i = K θ²/2 + (α/2) Σ_j (1−d) ω (e − ε_i ζ − θζ/3)² V_j`, α = 15μ/m, ε the free
    /// thermal strain (0 without `strain`).
    pub(super) fn energy<W: BondWeights, D: Integrity>(
        &self,
        coefficients: &[PointCoefficients],
        chunk: &[u32],
        base: usize,
        out: &mut [f64],
        weights: W,
        damage: D,
    ) {
        let strain = self.thermal_strain;
        let bonds = self.reference.bonds;
        let y = self.current.position;
        let k0 = self.first_local(chunk);
        for (k, &i) in (k0..).zip(chunk) {
            let i = i as usize;
            let yi = y[i];
            let theta = coefficients[i].dilatation;
            let alpha = coefficients[i].deviatoric;
            let local = self.local_offsets[k];
            let free = strain.map_or(0.0, |s| s[i]);
            let mut sum = 0.0;
            for (n, b) in bonds.range(i).enumerate() {
                let j = bonds.neighbor[b] as usize;
                let yj = y[j];
                let (dx, dy, dz) = (yj[0] - yi[0], yj[1] - yi[1], yj[2] - yi[2]);
                let zeta = bonds.reference_length[b];
                let length = (dx * dx + dy * dy + dz * dz).sqrt();
                let deviatoric = match strain {
                    None => length - zeta - theta * zeta / 3.0,
                    Some(_) => length - zeta - free * zeta - theta * zeta / 3.0,
                };
                sum += damage.intact(b)
                    * weights.weight(local + n)
                    * deviatoric
                    * deviatoric
                    * self.reference.neighbor_volume(b, j);
            }
            out[i - base] = 0.5 * self.bulk * theta * theta + 0.5 * alpha * sum;
        }
    }
}

/// Bond `start + n` of a row ([`checked_row`]): its neighbour j, Y_j, ζ and w_ij.
///
/// # Safety
/// `n` is below the row's length, the row `start..` is from [`checked_row`] with a bound
/// `points` from [`gather_bound`] over `y.len()` or less and `volume`.
#[inline(always)]
unsafe fn gather<V: VolumeRule>(
    neighbors: &[u32],
    lengths: &[f64],
    y: &[[f64; 3]],
    volume: V,
    start: usize,
    n: usize,
) -> (usize, [f64; 3], f64, f64) {
    // SAFETY: as the caller guarantees (neighbors and lengths are the same row).
    unsafe {
        let j = *neighbors.get_unchecked(n) as usize;
        (
            j,
            *y.get_unchecked(j),
            *lengths.get_unchecked(n),
            volume.of_unchecked(start + n, j),
        )
    }
}

/// ω (1−d) ζ e V_j, a bond's term of the dilatation sum, with `weight` = ω (1−d) and
/// e = fl(√q) − ζ.
#[inline(always)]
fn dilatation_term(weight: f64, zeta: f64, squared: f64, volume: f64) -> f64 {
    let extension = squared.sqrt() - zeta;
    weight * zeta * extension * volume
}

/// The factor of `Y_j − Y_i` in a bond's force: `t V_j / |Y|` with
/// `t = (1−d) ω [(A_i + A_j) ζ + (1−d)(B_i + B_j) e]`, e = |Y| − ζ, from `scaled` = (1−d) ω,
/// `intact` = 1 − d, the coefficient sums and `length` = |Y|; zero when |Y| is not positive
/// (divided unconditionally so that the lanes need no branch: the inf/NaN of a zero length
/// is discarded).
#[inline(always)]
fn force_scale(
    scaled: f64,
    intact: f64,
    isotropic: f64,
    deviatoric: f64,
    zeta: f64,
    length: f64,
    volume: f64,
) -> f64 {
    let extension = length - zeta;
    let t = scaled * (isotropic * zeta + intact * deviatoric * extension);
    let scale = t * volume / length;
    if length > 0.0 {
        scale
    } else {
        0.0
    }
}

/// Bonds of a row evaluated together in the LPS loops (the width of an AVX2 vector of f64; the
/// result does not depend on it, since the terms are summed in bond order).
const LANES: usize = 4;

/// The bond breaking the dilatation pass does before it uses each bond.
///
/// # Contract of an implementation that breaks bonds
/// `damage` and `break_bond` access the bond-damage array through a pointer; the pass only
/// calls them for bonds in the rows of the running chunk's points, which no other task reads
/// or writes meanwhile (each point's row belongs to one chunk); the damage reads of the pass
/// go through the same pointer.
pub(super) trait RowBreaker: Copy + Send + Sync {
    /// The critical stretch to test, `None` when the pass breaks nothing.
    fn limit(self) -> Option<StretchLimit>;

    /// d of bond `b`.
    ///
    /// # Safety
    /// See the trait.
    unsafe fn damage(self, b: usize) -> f32;

    /// Sets d = 1 on bond `b` (this direction only: the other end's row takes the same
    /// decision from the same numbers).
    ///
    /// # Safety
    /// See the trait.
    unsafe fn break_bond(self, b: usize);
}

/// The dilatation pass alone (damage already up to date, or no damage).
#[derive(Clone, Copy)]
pub(super) struct NoBreaking;

impl RowBreaker for NoBreaking {
    #[inline(always)]
    fn limit(self) -> Option<StretchLimit> {
        None
    }

    unsafe fn damage(self, _b: usize) -> f32 {
        unreachable!("NoBreaking has no limit")
    }

    unsafe fn break_bond(self, _b: usize) {
        unreachable!("NoBreaking has no limit")
    }
}

impl RowBreaker for FusedCriticalStretch {
    #[inline(always)]
    fn limit(self) -> Option<StretchLimit> {
        Some(self.limit)
    }

    #[inline(always)]
    unsafe fn damage(self, b: usize) -> f32 {
        // SAFETY: as the caller guarantees.
        unsafe { self.read(b) }
    }

    #[inline(always)]
    unsafe fn break_bond(self, b: usize) {
        // SAFETY: as the caller guarantees.
        unsafe { FusedCriticalStretch::break_bond(self, b) };
    }
}

impl LinearPeridynamicSolid {
    /// The loops' inputs, with the quadrature rule `volume` compiled in.
    pub(super) fn rows<'a, V: VolumeRule>(
        &'a self,
        reference: &'a ReferenceView<'a>,
        current: &'a CurrentView<'a>,
        volume: V,
    ) -> Rows<'a, V> {
        Rows {
            reference,
            volume,
            current,
            points: self.block.points(),
            local_offsets: &self.local_offsets,
            weighted_volume: &self.weighted_volume,
            bulk: self.block.bulk_modulus(),
            shear: self.shear_modulus,
            correction: &self.correction,
            thermal_strain: self.thermal_strain(current),
            force_subset: self.block.force_points().len() < self.block.points().len(),
            wide: wide_vectors_available(),
        }
    }
}
