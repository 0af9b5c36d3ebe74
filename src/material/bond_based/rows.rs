//! The PMB loops of an open block, whose bonds may end in other blocks: each point gathers its
//! own row, reading c_j/2 per neighbour (the parent module's docs).

use super::{bond_scale, LANES};
use crate::material::{CurrentView, Integrity, PointCoefficients, ReferenceView};
use crate::model::VolumeRule;

/// The pair stiffness of an open block's bonds, whose neighbours may belong to other blocks:
/// c_ij = a_i + a_j with a = c/2 published per point.
#[derive(Clone, Copy)]
struct Mixed<'a> {
    own_half: f64,
    coefficients: &'a [PointCoefficients],
}

impl Mixed<'_> {
    /// c_ij of the bond to neighbour `j`.
    #[inline(always)]
    fn of(self, j: usize) -> f64 {
        self.own_half + self.coefficients[j].isotropic
    }
}

/// What the PMB bond loops read, bundled once per call.
pub(super) struct Rows<'a> {
    pub(super) reference: &'a ReferenceView<'a>,
    pub(super) current: &'a CurrentView<'a>,
    pub(super) coefficients: &'a [PointCoefficients],
    /// c/2 of this block's points.
    pub(super) own_half: f64,
}

/// The bond-list row of one point.
#[derive(Clone, Copy)]
struct BondRow<'a> {
    /// Global bond index of the row's first bond.
    first_bond: usize,
    /// The neighbours j, in row order.
    neighbors: &'a [u32],
    /// The reference lengths ζ of the row's bonds (length).
    lengths: &'a [f64],
}

/// `F_i = Σ_j c_ij (1−d) w_ij (|Y| − ζ)/(ζ|Y|) (Y_j − Y_i)` over the bond-list `row` of the
/// point at `yi` (w_ij the bond's quadrature volume, V_j under the full-volume rule).
#[inline(always)]
fn row_force<V: VolumeRule, D: Integrity>(
    yi: [f64; 3],
    row: BondRow<'_>,
    y: &[[f64; 3]],
    volume: V,
    damage: D,
    stiffness: Mixed<'_>,
) -> [f64; 3] {
    let BondRow {
        first_bond,
        neighbors,
        lengths,
    } = row;
    let mut sum = [[0.0; LANES]; 3];
    let full = neighbors.len() - neighbors.len() % LANES;
    for start in (0..full).step_by(LANES) {
        let mut d = [[0.0; LANES]; 3];
        let mut pair = [0.0; LANES];
        let mut zeta = [0.0; LANES];
        for lane in 0..LANES {
            let n = start + lane;
            let j = neighbors[n] as usize;
            let yj = y[j];
            for k in 0..3 {
                d[k][lane] = yj[k] - yi[k];
            }
            pair[lane] =
                stiffness.of(j) * damage.intact(first_bond + n) * volume.of(first_bond + n, j);
            zeta[lane] = lengths[n];
        }
        for lane in 0..LANES {
            let scale = bond_scale(pair[lane], zeta[lane], d[0][lane], d[1][lane], d[2][lane]);
            for k in 0..3 {
                sum[k][lane] += scale * d[k][lane];
            }
        }
    }
    for n in full..neighbors.len() {
        let lane = n - full;
        let j = neighbors[n] as usize;
        let yj = y[j];
        let d = [yj[0] - yi[0], yj[1] - yi[1], yj[2] - yi[2]];
        let pair = stiffness.of(j) * damage.intact(first_bond + n) * volume.of(first_bond + n, j);
        let scale = bond_scale(pair, lengths[n], d[0], d[1], d[2]);
        for k in 0..3 {
            sum[k][lane] += scale * d[k];
        }
    }
    sum.map(|s| (s[0] + s[1]) + (s[2] + s[3]))
}

impl Rows<'_> {
    /// c_ij of this block's bonds.
    #[inline(always)]
    fn pair_stiffness(&self) -> Mixed<'_> {
        Mixed {
            own_half: self.own_half,
            coefficients: self.coefficients,
        }
    }

    /// Adds the force density of the chunk's points (see [`row_force`]), with w_ij by the
    /// quadrature rule `volume`.
    #[inline(always)]
    fn add_force<V: VolumeRule, D: Integrity>(
        &self,
        chunk: &[u32],
        base: usize,
        out: &mut [[f64; 3]],
        volume: V,
        damage: D,
    ) {
        let stiffness = self.pair_stiffness();
        let bonds = self.reference.bonds;
        let y = self.current.position;
        for &i in chunk {
            let i = i as usize;
            let range = bonds.range(i);
            let row = BondRow {
                first_bond: range.start,
                neighbors: &bonds.neighbor[range.clone()],
                lengths: &bonds.reference_length[range],
            };
            let f = row_force(y[i], row, y, volume, damage, stiffness);
            let out = &mut out[i - base];
            for k in 0..3 {
                out[k] += f[k];
            }
        }
    }

    /// [`Rows::add_force`] compiled for 256-bit vectors when `wide` (checked by
    /// [`wide_vectors_available`]), for the baseline target otherwise. Both give bitwise the same
    /// result: the lanes do the same IEEE operations in the same order, and no multiply-add is
    /// fused (FMA is not enabled).
    #[inline(always)]
    pub(super) fn add_force_dispatch<V: VolumeRule, D: Integrity>(
        &self,
        chunk: &[u32],
        base: usize,
        out: &mut [[f64; 3]],
        volume: V,
        damage: D,
        wide: bool,
    ) {
        #[cfg(target_arch = "x86_64")]
        if wide {
            // SAFETY: `wide` is true only when the CPU reports AVX2 at run time.
            unsafe { self.add_force_avx2(chunk, base, out, volume, damage) };
            return;
        }
        let _ = wide;
        self.add_force(chunk, base, out, volume, damage);
    }

    /// [`Rows::add_force`] with AVX2 enabled, so the `LANES` loop becomes 4-wide square roots and
    /// divisions (twice the width of the x86-64 baseline's SSE2).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn add_force_avx2<V: VolumeRule, D: Integrity>(
        &self,
        chunk: &[u32],
        base: usize,
        out: &mut [[f64; 3]],
        volume: V,
        damage: D,
    ) {
        self.add_force(chunk, base, out, volume, damage);
    }

    /// `W_i = Σ_j ¼ c_ij s² ζ (1−d) w_ij = Σ_j ¼ (a_i + a_j)(1−d) e²/ζ w_ij`.
    pub(super) fn energy<D: Integrity>(
        &self,
        chunk: &[u32],
        base: usize,
        out: &mut [f64],
        damage: D,
    ) {
        let stiffness = self.pair_stiffness();
        let bonds = self.reference.bonds;
        let y = self.current.position;
        for &i in chunk {
            let i = i as usize;
            let yi = y[i];
            let mut w = 0.0;
            for b in bonds.range(i) {
                let j = bonds.neighbor[b] as usize;
                let yj = y[j];
                let (dx, dy, dz) = (yj[0] - yi[0], yj[1] - yi[1], yj[2] - yi[2]);
                let zeta = bonds.reference_length[b];
                let extension = (dx * dx + dy * dy + dz * dz).sqrt() - zeta;
                let c_pair = stiffness.of(j);
                w += 0.25 * c_pair * damage.intact(b) * extension * extension / zeta
                    * self.reference.neighbor_volume(b, j);
            }
            out[i - base] = w;
        }
    }
}
