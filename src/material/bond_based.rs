//! Prototype microelastic brittle material (PMB), Peridigm's `Elastic Bond Based`.
//!
//! Micromodulus `c = 18K/(πδ⁴)` in 3D (Silling & Askari 2005), `c = 12K/(π h δ³)` for
//! `Plane Strain`/`Plane Stress` with thickness h = `Height` (reference §1.3). The pair force
//! density is `c·s·(1−d)` along the deformed bond, stretch `s = (|Y| − ζ)/ζ`:
//!
//! `F_i = Σ_j c·s·(1−d)·V_j·M_ij`, `M_ij = (Y_j − Y_i)/|Y_j − Y_i|`.
//!
//! Peridigm visits each directed bond with `t = ½·c·s·(1−d)` from both ends; the gather here
//! sums `t_ij + t_ji = (c_i/2 + c_j/2)·s·(1−d)`, the same total, and stays exact when the two
//! ends belong to blocks with different micromoduli.
//!
//! # Stored energy
//! The PMB pair potential (energy per V_i·V_j) is `w = ½·c·s²·ζ`, since `∂w/∂|Y| = c·s` is the
//! pair force density above. The body's energy counts each pair once:
//! `E = Σ_{pairs} ½ c s² ζ (1−d) V_i V_j = ½ Σ_i Σ_j ½ c s² ζ (1−d) V_i V_j` (directed sum
//! counts each pair twice). Giving each point half of each of its bonds,
//! `W_i = Σ_j ¼·c·s²·ζ·(1−d)·V_j` makes `Σ_i W_i V_i = E` exactly. (The `(1−d)` factor is
//! exact for 0/1 damage; for fractional damage it is the energy of the softened spring.)

use super::point_chunks::for_each_chunk;
use super::{
    assert_point_set, positive, CurrentView, Damaged, Integrity, Material, MaterialError,
    PointCoefficients, ReferenceView, Undamaged,
};

/// Deck parameters of `Elastic Bond Based`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BondBasedParameters {
    /// `Density` ρ (mass/length³).
    pub density: f64,
    /// Bulk modulus K (pressure), from `Bulk Modulus` or `Young's Modulus` with ν forced to ¼
    /// (3D, plane strain) or ⅓ (plane stress) as Peridigm does.
    pub bulk_modulus: f64,
    /// Horizon δ of the block (length).
    pub horizon: f64,
    /// `Height` h for `Plane Strain`/`Plane Stress` (then c = 12K/(π h δ³)); `None` in 3D.
    pub planar_thickness: Option<f64>,
}

/// The PMB material of one block (see the module docs for the formulas).
#[derive(Debug, Clone)]
pub struct BondBased {
    parameters: BondBasedParameters,
    micromodulus: f64,
    points: Vec<u32>,
}

impl BondBased {
    /// Validates the parameters (all positive and finite) and computes the micromodulus.
    pub fn new(parameters: BondBasedParameters) -> Result<Self, MaterialError> {
        positive("Density", parameters.density)?;
        positive("Bulk Modulus", parameters.bulk_modulus)?;
        positive("Horizon", parameters.horizon)?;
        let k = parameters.bulk_modulus;
        let delta = parameters.horizon;
        let micromodulus = match parameters.planar_thickness {
            None => 18.0 * k / (std::f64::consts::PI * delta.powi(4)),
            Some(h) => 12.0 * k / (std::f64::consts::PI * positive("Height", h)? * delta.powi(3)),
        };
        Ok(Self {
            parameters,
            micromodulus,
            points: Vec::new(),
        })
    }

    /// Micromodulus c (force/length⁶ in 3D): 18K/(πδ⁴), or 12K/(π h δ³) when planar.
    pub fn micromodulus(&self) -> f64 {
        self.micromodulus
    }

    fn half(&self) -> f64 {
        0.5 * self.micromodulus
    }
}

/// What the PMB bond loops read, bundled once per call.
struct Rows<'a> {
    reference: &'a ReferenceView<'a>,
    current: &'a CurrentView<'a>,
    coefficients: &'a [PointCoefficients],
    /// c/2 of this block's points.
    own_half: f64,
}

impl Rows<'_> {
    /// `F_i += Σ_j (a_i + a_j)(1−d)(|Y| − ζ)/(ζ|Y|) V_j (Y_j − Y_i)` for the chunk's points,
    /// with `a = c/2` published per point. Coincident deformed points (|Y| = 0) have no
    /// direction and contribute nothing (Peridigm would produce NaN).
    #[inline(always)]
    fn add_force<D: Integrity>(&self, chunk: &[u32], base: usize, out: &mut [[f64; 3]], damage: D) {
        let bonds = self.reference.bonds;
        let volume = self.reference.volume;
        let y = self.current.position;
        let coefficients = self.coefficients;
        for &i in chunk {
            let i = i as usize;
            let yi = y[i];
            let (mut fx, mut fy, mut fz) = (0.0, 0.0, 0.0);
            let range = bonds.range(i);
            let neighbors = &bonds.neighbor[range.clone()];
            let lengths = &bonds.reference_length[range.clone()];
            for (n, (&j, &zeta)) in neighbors.iter().zip(lengths).enumerate() {
                let j = j as usize;
                let yj = y[j];
                let (dx, dy, dz) = (yj[0] - yi[0], yj[1] - yi[1], yj[2] - yi[2]);
                let length = (dx * dx + dy * dy + dz * dz).sqrt();
                let pair = (self.own_half + coefficients[j].isotropic)
                    * damage.intact(range.start + n)
                    * volume[j];
                let scale = if length > 0.0 {
                    pair * (length - zeta) / (zeta * length)
                } else {
                    0.0
                };
                fx += scale * dx;
                fy += scale * dy;
                fz += scale * dz;
            }
            let f = &mut out[i - base];
            f[0] += fx;
            f[1] += fy;
            f[2] += fz;
        }
    }

    /// `W_i = Σ_j ¼ c_ij s² ζ (1−d) V_j = Σ_j ¼ (a_i + a_j)(1−d) e²/ζ V_j`.
    fn energy<D: Integrity>(&self, chunk: &[u32], base: usize, out: &mut [f64], damage: D) {
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
                let c_pair = self.own_half + self.coefficients[j].isotropic;
                w += 0.25 * c_pair * damage.intact(b) * extension * extension / zeta
                    * self.reference.volume[j];
            }
            out[i - base] = w;
        }
    }
}

impl Material for BondBased {
    fn model_name(&self) -> &'static str {
        "Elastic Bond Based"
    }

    fn density(&self) -> f64 {
        self.parameters.density
    }

    fn bulk_modulus(&self) -> f64 {
        self.parameters.bulk_modulus
    }

    fn horizon(&self) -> f64 {
        self.parameters.horizon
    }

    fn needs_dilatation(&self) -> bool {
        false
    }

    fn setup(
        &mut self,
        reference: &ReferenceView<'_>,
        points: Vec<u32>,
    ) -> Result<(), MaterialError> {
        assert_point_set(&points, reference.bonds.num_points());
        self.points = points;
        Ok(())
    }

    fn points(&self) -> &[u32] {
        &self.points
    }

    fn compute_point_coefficients(
        &self,
        _reference: &ReferenceView<'_>,
        _current: &CurrentView<'_>,
        coefficients: &mut [PointCoefficients],
    ) {
        let published = PointCoefficients {
            dilatation: 0.0,
            isotropic: self.half(),
            deviatoric: 0.0,
        };
        for &i in &self.points {
            coefficients[i as usize] = published;
        }
    }

    fn add_force_density(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        coefficients: &[PointCoefficients],
        force_density: &mut [[f64; 3]],
    ) {
        let rows = Rows {
            reference,
            current,
            coefficients,
            own_half: self.half(),
        };
        let run = |chunk: &[u32], base: usize, out: &mut [[f64; 3]]| match current.bond_damage {
            None => rows.add_force(chunk, base, out, Undamaged),
            Some(d) => rows.add_force(chunk, base, out, Damaged(d)),
        };
        for_each_chunk(&self.points, force_density, &|i| i as usize, &run);
    }

    fn stored_energy_density(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        coefficients: &[PointCoefficients],
        energy_density: &mut [f64],
    ) {
        let rows = Rows {
            reference,
            current,
            coefficients,
            own_half: self.half(),
        };
        let run = |chunk: &[u32], base: usize, out: &mut [f64]| match current.bond_damage {
            None => rows.energy(chunk, base, out, Undamaged),
            Some(d) => rows.energy(chunk, base, out, Damaged(d)),
        };
        for_each_chunk(&self.points, energy_density, &|i| i as usize, &run);
    }
}
