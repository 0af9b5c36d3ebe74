//! Prototype microelastic brittle material (PMB), Peridigm's `Elastic Bond Based`.
//!
//! Micromodulus `c = 18K/(πδ⁴)` in 3D (Silling & Askari 2005), `c = 12K/(π h δ³)` for
//! `Plane Strain`/`Plane Stress` with thickness h = `Height` (Peridigm's
//! `elastic_bond_based.cxx`). The pair force density is `c·s·(1−d)` along the deformed bond,
//! stretch `s = (|Y| − ζ)/ζ`:
//!
//! `F_i = Σ_j c·s·(1−d)·V_j·M_ij`, `M_ij = (Y_j − Y_i)/|Y_j − Y_i|`.
//!
//! Peridigm visits each directed bond with `t = ½·c·s·(1−d)` from both ends; the gather here
//! sums `t_ij + t_ji = (c_i/2 + c_j/2)·s·(1−d)`, the same total, and stays exact when the two
//! ends belong to blocks with different micromoduli.
//!
//! # Two force loops
//! * A block whose families stay inside it (every single-block model) is *closed*: every
//!   bond's micromodulus is c, and each point sums its row with the bond's own data
//!   ([`ClosedRows`]), breaking its over-stretched bonds on the way when the block's damage is
//!   a constant critical stretch ([`Material::critical_stretch_fast_path`]).
//! * Otherwise each point gathers its own row (`for_each_chunk`), reading c_j/2 per neighbour.
//!
//! # Why a point's force depends only on its row
//! A distributed run (see [`crate::parallel`]) builds on each rank a local model over its own
//! points and one layer of ghosts, numbered in the global order, and must produce bitwise the
//! forces of the one-rank model on the owned points. Floating-point sums depend on their order,
//! so the force of a point must be a sum whose terms *and* order are fixed by data both models
//! share: the point's row (an owned point's row is its whole family, in the global order) and
//! the states of the two ends of each bond. Both loops add the bonds of the row in row order,
//! in four interleaved partial sums combined `(0 + 1) + (2 + 3)`, and each term reads only the
//! bond (its ζ and damage) and its two ends. So neither depends on how the points are cut
//! into tasks, on the thread count or on which other points the model holds (a ghost's row
//! may lack the bonds to points outside the rank; its force is wrong and never used).
//!
//! The two ends of a pair compute the same scale `s = c (1−d) (|Y| − ζ)/(ζ|Y|)`: seen from j,
//! `Y_i − Y_j` is exactly `−(Y_j − Y_i)` (IEEE subtraction is antisymmetric), so q = |d|² is
//! the same number, ζ is the same number in both directions (`BondList`), and so is the
//! damage of a critical stretch. The forces are therefore exactly antisymmetric pair by pair,
//! and they are bitwise those of the earlier pair-once plan, which computed s once per pair
//! from the lower end and let both rows gather it.
//!
//! # Speed
//! Each directed bond takes its own square root and division (vectorized; on a CPU with AVX2
//! the row is the intrinsics loop of `closed_rows::avx2`, four bonds per register from the loads
//! of Y_j to the partial sums, with bitwise the staged loop's result), twice the pair-once
//! plan's, but in one pass that streams 16 bytes per directed bond (neighbour index, ζ,
//! damage) and holds no per-pair data. The pair-once plan's second pass read every bond's
//! neighbour, pair slot and the pair's scale again (28 bytes per directed bond streamed, 8
//! more held). The earlier designs measured on the LAMMPS comparison lattice (30³, m =
//! 3.015): one pass that scattered −f into F_j (10.8 ms/step on one thread, but its sums
//! depended on the task cut), the pair-once plan with its gather (13.3 ms/step the same day),
//! per-bond weights with the reverse weight scattered into the other row (27 ms/step), and
//! gathering each point inside the pair pass as soon as its pairs are known (17–23 ms/step).
//!
//! # Stored energy
//! The PMB pair potential (energy per V_i·V_j) is `w = ½·c·s²·ζ`, since `∂w/∂|Y| = c·s` is the
//! pair force density above. The body's energy counts each pair once:
//! `E = Σ_{pairs} ½ c s² ζ (1−d) V_i V_j = ½ Σ_i Σ_j ½ c s² ζ (1−d) V_i V_j` (directed sum
//! counts each pair twice). Giving each point half of each of its bonds,
//! `W_i = Σ_j ¼·c·s²·ζ·(1−d)·V_j` makes `Σ_i W_i V_i = E` exactly. (The `(1−d)` factor is
//! exact for 0/1 damage; for fractional damage it is the energy of the softened spring.)

use super::keys::DENSITY;
use super::keys::{PROBE_LENGTH, TANGENT};
use super::{
    BlockData, BlockInput, CurrentView, Damaged, Integrity, Material, MaterialError, MaterialKeys,
    MaterialModel, MaterialParameters, MaterialTangent, PointCoefficients, ReferenceView,
    Undamaged,
};
use super::{BreakingForcePass, CriticalStretchFastPath, FusedCriticalStretch};
use crate::damage::{break_stretched_rows, StretchLimit};
use crate::model::point_chunks::for_each_chunk;
use crate::model::{with_volume_rule, KeyDoc, ModelDeclaration, Reach, TangentSupport};
use crate::parameter_list::error::DeckError;
use crate::parameter_list::reader::{Ctx, ListReader};
use crate::tangent::{
    assemble, BlockTangent, ForceState, OrdinaryBond, PointIndex, Scalar, TangentError,
    TangentMethod,
};
use crate::vector_width::wide_vectors_available;

mod closed_rows;
mod rows;

use closed_rows::NoBreaking;
use rows::Rows;

/// `Bulk Modulus` of the PMB models.
const BULK_MODULUS: KeyDoc = KeyDoc {
    key: "Bulk Modulus",
    meaning: "bulk modulus K; give exactly one of K and E (ν is fixed by the model)",
    unit: "pressure",
    default: "one of two",
};

/// `Young's Modulus` of the PMB models.
const YOUNGS_MODULUS: KeyDoc = KeyDoc {
    key: "Young's Modulus",
    meaning: "Young's modulus E, giving K with ν = ¼ (3D, plane strain) or ⅓ (plane stress)",
    unit: "pressure",
    default: "one of two",
};

/// `Plane Strain`.
const PLANE_STRAIN: KeyDoc = KeyDoc {
    key: "Plane Strain",
    meaning: "a plane-strain body of thickness `Height`: c = 12K/(π h δ³)",
    unit: "true/false",
    default: "false",
};

/// `Plane Stress`.
const PLANE_STRESS: KeyDoc = KeyDoc {
    key: "Plane Stress",
    meaning: "a plane-stress body of thickness `Height`: c = 12K/(π h δ³), ν = ⅓",
    unit: "true/false",
    default: "false",
};

/// `Height`.
const HEIGHT: KeyDoc = KeyDoc {
    key: "Height",
    meaning: "thickness h of a plane-strain or plane-stress body",
    unit: "length",
    default: "required when planar",
};

/// The keys of the PMB constants, shared by `Microplastic Bond Based`.
pub(super) const PMB_KEYS: [KeyDoc; 6] = [
    DENSITY,
    BULK_MODULUS,
    YOUNGS_MODULUS,
    PLANE_STRAIN,
    PLANE_STRESS,
    HEIGHT,
];

/// Deck parameters of `Elastic Bond Based` (the PMB constants, which `Microplastic Bond Based`
/// shares).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BondBasedParameters {
    /// Bulk modulus K (pressure), from `Bulk Modulus` or `Young's Modulus` with ν forced to ¼
    /// (3D, plane strain) or ⅓ (plane stress) as Peridigm does.
    pub bulk_modulus: f64,
    /// `Height` h for `Plane Strain`/`Plane Stress` (then c = 12K/(π h δ³)); `None` in 3D.
    pub planar_thickness: Option<f64>,
}

impl MaterialParameters for BondBasedParameters {
    fn bulk_modulus(&self) -> Option<f64> {
        Some(self.bulk_modulus)
    }

    fn planar_thickness(&self) -> Option<f64> {
        self.planar_thickness
    }
}

impl BondBasedParameters {
    /// The PMB constants of the list of the model `model`: exactly one modulus, optionally
    /// planar with a `Height`.
    pub(super) fn read(ctx: &Ctx, list: &mut ListReader, model: &str) -> Result<Self, DeckError> {
        use super::elastic_constants::{ElasticConstants, ElasticInput, PlanarAssumption};
        let k = list.get(BULK_MODULUS.key);
        let e = list.get(YOUNGS_MODULUS.key);
        let modulus = match (k, e) {
            (Some(k), None) => Ok(k.positive(ctx)?),
            (None, Some(e)) => Err(e.positive(ctx)?),
            (Some(_), Some(e)) => {
                return Err(e.err(ctx, format!("{model} takes exactly one of \"Bulk Modulus\" and \"Young's Modulus\" (Poisson's ratio is fixed by the model); remove one")))
            }
            (None, None) => return Err(list.missing(ctx, BULK_MODULUS.key, "or \"Young's Modulus\"; exactly one of them")),
        };
        for key in ["Shear Modulus", "Poisson's Ratio"] {
            if let Some(f) = list.get(key) {
                return Err(f.err(ctx, format!("\"{key}\" cannot be set for {model}: Poisson's ratio is fixed (1/4 in 3D and plane strain, 1/3 in plane stress); give only \"Bulk Modulus\" or \"Young's Modulus\"")));
            }
        }
        let strain = list.bool_or(ctx, PLANE_STRAIN.key, false)?;
        let stress = list.bool_or(ctx, PLANE_STRESS.key, false)?;
        let (assumption, nu) = match (strain, stress) {
            (true, true) => {
                let f = list.get(PLANE_STRESS.key).expect("just read");
                return Err(f.err(ctx, "Plane Strain and Plane Stress cannot both be true"));
            }
            (true, false) => (PlanarAssumption::PlaneStrain, 0.25),
            (false, true) => (PlanarAssumption::PlaneStress, 1.0 / 3.0),
            (false, false) => (PlanarAssumption::None, 0.25),
        };
        let planar_thickness = match assumption {
            PlanarAssumption::None => None,
            _ => Some(list.positive_req(ctx, HEIGHT.key)?),
        };
        // K from E with the model's fixed ν and the planar formulas of `from_pair`.
        let bulk_modulus = match modulus {
            Ok(k) => k,
            Err(e) => {
                let input = ElasticInput {
                    youngs_modulus: Some(e),
                    poissons_ratio: Some(nu),
                    ..Default::default()
                };
                ElasticConstants::from_pair(input, assumption)
                    .map(|c| c.bulk_modulus)
                    .unwrap_or_else(|e| unreachable!("E > 0 and ν fixed below ½: {e}"))
            }
        };
        Ok(Self {
            bulk_modulus,
            planar_thickness,
        })
    }

    /// Micromodulus c (force/length⁶ in 3D) of a block of horizon δ: 18K/(πδ⁴), or
    /// 12K/(π h δ³) when planar (the height must be a positive finite number).
    pub(super) fn micromodulus(&self, horizon: f64) -> Result<f64, MaterialError> {
        let k = self.bulk_modulus;
        let delta = horizon;
        Ok(match self.planar_thickness {
            None => 18.0 * k / (std::f64::consts::PI * delta.powi(4)),
            Some(h) => {
                12.0 * k / (std::f64::consts::PI * super::positive("Height", h)? * delta.powi(3))
            }
        })
    }
}

/// The PMB material of one block (see the module docs for the formulas).
#[derive(Debug, Clone)]
pub struct BondBased {
    block: BlockData,
    micromodulus: f64,
    /// Every neighbour of every block point is itself a block point, so every bond's
    /// micromodulus is this block's c (decided in `prepare`): the block then runs the
    /// closed-block loop ([`ClosedRows`]), which also breaks bonds
    /// ([`Material::critical_stretch_fast_path`]).
    closed: bool,
}

impl MaterialKeys for BondBased {
    type Parameters = BondBasedParameters;

    /// `Elastic Bond Based`: a bond's force depends on its two ends only; no fields beyond
    /// the reference data, no outputs of its own.
    const DECLARATION: ModelDeclaration = ModelDeclaration {
        deck_name: "Elastic Bond Based",
        aliases: &[],
        deck_keys: &[
            PMB_KEYS[0],
            PMB_KEYS[1],
            PMB_KEYS[2],
            PMB_KEYS[3],
            PMB_KEYS[4],
            PMB_KEYS[5],
            TANGENT,
            PROBE_LENGTH,
        ],
        reach: Reach::OneHop,
        fields: &[],
        outputs: &[],
        tangent: TangentSupport::Analytic,
        thermal_strain: false,
        small_displacement: false,
        example: "Density: 2.0\nBulk Modulus: 3.0",
    };

    fn read(ctx: &mut Ctx, list: &mut ListReader) -> Result<BondBasedParameters, DeckError> {
        BondBasedParameters::read(ctx, list, Self::DECLARATION.deck_name)
    }
}

impl MaterialModel for BondBased {
    fn build(
        block: &BlockInput,
        parameters: &BondBasedParameters,
    ) -> Result<Box<dyn Material>, MaterialError> {
        Ok(Box::new(Self::new(block, parameters)?))
    }
}

impl BondBased {
    /// Validates the parameters (ρ, K, δ and the height positive and finite) and computes the
    /// micromodulus.
    pub fn new(
        block: &BlockInput,
        parameters: &BondBasedParameters,
    ) -> Result<Self, MaterialError> {
        let data = BlockData::new(
            &Self::DECLARATION,
            block.density,
            parameters.bulk_modulus,
            block.horizon,
        )?;
        Ok(Self {
            micromodulus: parameters.micromodulus(data.horizon())?,
            block: data,
            closed: false,
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

/// Bonds of one row evaluated together: the loop body works on `[f64; LANES]` arrays so that
/// the compiler turns the square roots, divisions and products into vector instructions
/// (the scalar divide/square-root unit, not memory, limits a one-bond-at-a-time loop). The
/// lanes keep separate partial sums, added `(0 + 1) + (2 + 3)` at the end of the row, so the
/// result does not depend on the vector width the compiler picks.
const LANES: usize = 4;

/// The force-density contribution of one bond: `c_ij (1−d) V_j (|Y| − ζ)/(ζ|Y|)` times
/// `Y_j − Y_i` (the caller multiplies by the components). Coincident deformed points
/// (|Y| = 0) have no direction and contribute nothing (Peridigm would produce NaN); the
/// division is still evaluated so that the lane loop has no branch (its inf/NaN is discarded).
#[inline(always)]
fn bond_scale(pair: f64, zeta: f64, dx: f64, dy: f64, dz: f64) -> f64 {
    bond_scale_squared(pair, zeta, dx * dx + dy * dy + dz * dz)
}

/// [`bond_scale`] from the squared length q = `dx*dx + dy*dy + dz*dz` (the same operations,
/// so the same result).
#[inline(always)]
fn bond_scale_squared(pair: f64, zeta: f64, squared: f64) -> f64 {
    let length = squared.sqrt();
    let scale = pair * (length - zeta) / (zeta * length);
    if length > 0.0 {
        scale
    } else {
        0.0
    }
}

/// The PMB force state of one point for the tangent: `T_n = a_i (1−d) (|Y| − ζ)/ζ · M` with
/// a_i = c/2 (this point's half of the pair stiffness; the neighbour's force state adds its
/// own half, as in the gather `c_ij = a_i + a_j`).
struct PmbForceState<'a, D> {
    bonds: &'a crate::model::BondList,
    half: f64,
    damage: D,
}

impl<D: Integrity> ForceState for PmbForceState<'_, D> {
    const BOND_LOCAL: bool = true;
    const ANALYTIC: bool = true;

    fn force_state<T: Scalar>(
        &self,
        point: PointIndex,
        y: &[[T; 3]],
        only: Option<usize>,
        t: &mut [[T; 3]],
    ) {
        let range = self.bonds.range(point.global);
        let selected = match only {
            Some(n) => n..n + 1,
            None => 0..range.len(),
        };
        for n in selected {
            let b = range.start + n;
            let zeta = self.bonds.reference_length[b];
            let d = [0, 1, 2].map(|k| y[n + 1][k] - y[0][k]);
            let squared = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            // Coincident points carry no force (as in the force kernel).
            t[n] = if squared.re() > 0.0 {
                let length = squared.sqrt();
                let scale = (length - zeta) * (self.half * self.damage.intact(b) / zeta) / length;
                d.map(|c| c * scale)
            } else {
                [T::from(0.0); 3]
            };
        }
    }

    /// `∂T_n/∂Y_j = a (1−d) [M⊗M/ζ + (|Y| − ζ)/(ζ|Y|) (I − M⊗M)] = −∂T_n/∂Y_i`: the bond's
    /// axial stiffness along M and the pre-stress term across it; no θ.
    fn ordinary_derivatives(&self, point: PointIndex, y: &[[f64; 3]], out: &mut [OrdinaryBond]) {
        let range = self.bonds.range(point.global);
        for ((n, b), bond) in range.enumerate().zip(out.iter_mut()) {
            let zeta = self.bonds.reference_length[b];
            let d = [0, 1, 2].map(|k| y[n + 1][k] - y[0][k]);
            let length = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            *bond = if length > 0.0 {
                let a = self.half * self.damage.intact(b);
                OrdinaryBond {
                    direction: d.map(|c| c / length),
                    axial: a / zeta,
                    lateral: a * (length - zeta) / (zeta * length),
                    coupling: 0.0,
                    weight: 0.0,
                }
            } else {
                OrdinaryBond::default()
            };
        }
    }
}

impl Material for BondBased {
    fn block(&self) -> &BlockData {
        &self.block
    }

    fn block_mut(&mut self) -> &mut BlockData {
        &mut self.block
    }

    fn prepare(&mut self, reference: &ReferenceView<'_>) -> Result<(), MaterialError> {
        self.closed = self.block.point_bonded_outside(reference.bonds).is_none();
        Ok(())
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
        for &i in self.block.points() {
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
        if self.closed {
            match current.bond_damage {
                None => self.add_closed_force(
                    reference,
                    current.position,
                    Undamaged,
                    NoBreaking,
                    force_density,
                ),
                Some(d) => self.add_closed_force(
                    reference,
                    current.position,
                    Damaged(d),
                    NoBreaking,
                    force_density,
                ),
            };
            return;
        }
        let rows = Rows {
            reference,
            current,
            coefficients,
            own_half: self.half(),
        };
        let wide = wide_vectors_available();
        with_volume_rule!(reference, |v| {
            let run = |chunk: &[u32], base: usize, out: &mut [[f64; 3]]| match current.bond_damage {
                None => rows.add_force_dispatch(chunk, base, out, v, Undamaged, wide),
                Some(d) => rows.add_force_dispatch(chunk, base, out, v, Damaged(d), wide),
            };
            for_each_chunk(
                self.block.force_points(),
                force_density,
                &|i| i as usize,
                &run,
            )
        })
    }

    /// The closed-block loop breaks each bond in its own row just before its force (only a
    /// closed block: an open one leaves its interface bonds to the damage model).
    fn critical_stretch_fast_path(&self) -> Option<CriticalStretchFastPath<'_>> {
        self.closed.then_some(CriticalStretchFastPath::Force(self))
    }

    fn tangent(&self) -> Option<&dyn MaterialTangent> {
        Some(self)
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
        for_each_chunk(self.block.points(), energy_density, &|i| i as usize, &run);
    }
}

impl MaterialTangent for BondBased {
    fn add_tangent(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        method: TangentMethod,
        tangent: &mut BlockTangent,
    ) -> Result<(), TangentError> {
        let model = Self::DECLARATION.deck_name;
        let (bonds, half) = (reference.bonds, self.half());
        match current.bond_damage {
            None => {
                let kernel = PmbForceState {
                    bonds,
                    half,
                    damage: Undamaged,
                };
                assemble(
                    &kernel,
                    model,
                    self.block.points(),
                    reference,
                    current,
                    method,
                    tangent,
                )
            }
            Some(d) => {
                let kernel = PmbForceState {
                    bonds,
                    half,
                    damage: Damaged(d),
                };
                assemble(
                    &kernel,
                    model,
                    self.block.points(),
                    reference,
                    current,
                    method,
                    tangent,
                )
            }
        }
    }
}

impl BreakingForcePass for BondBased {
    /// The closed-block loop tests each bond of a row just before its force: the same q, the
    /// same exact test (behind the filter of `StretchLimit::breaks`) as the `Critical Stretch`
    /// update, on the bond alone; the force then reads the updated damage, so forces and
    /// damage are bitwise those of the separate update followed by the force. The rows of
    /// points whose force is not computed ([`Material::restrict_forces`]) are decided too.
    fn add_force_density_breaking_bonds(
        &self,
        reference: &ReferenceView<'_>,
        position: &[[f64; 3]],
        critical_stretch: f64,
        bond_damage: &mut [f32],
        _coefficients: &[PointCoefficients],
        force_density: &mut [[f64; 3]],
    ) -> usize {
        assert!(
            self.closed,
            "the fast path is offered only to closed blocks"
        );
        assert_eq!(bond_damage.len(), reference.bonds.num_bonds());
        let limit = StretchLimit::new(critical_stretch);
        let fused = FusedCriticalStretch {
            limit,
            damage: bond_damage.as_mut_ptr(),
        };
        // The `Breaker` contract holds: `bond_damage` is borrowed mutably for this call and
        // covers every bond, and the chunk of point i reads and writes only the entries of
        // i's row.
        let broken = self.add_closed_force(reference, position, fused, fused, force_density);
        broken
            + break_stretched_rows(
                reference,
                position,
                self.block.unforced_points(),
                bond_damage,
                limit,
            )
    }
}

#[cfg(test)]
mod tests {
    use super::closed_rows::ClosedRows;
    use super::*;
    use crate::damage::{CriticalStretch, DamageModel};
    use crate::model::test_support::{brute_force_bonds, random_cloud, Rng};
    use crate::model::BondList;

    /// The reference view of `bonds` over the points `x` of volumes `v` (full-volume rule).
    fn reference_view<'a>(
        bonds: &'a BondList,
        x: &'a [[f64; 3]],
        v: &'a [f64],
    ) -> ReferenceView<'a> {
        ReferenceView {
            bonds,
            position: x,
            volume: v,
            bond_volume: None,
        }
    }

    fn material() -> BondBased {
        let block = BlockInput {
            density: 2.0,
            horizon: 1.6,
            influence: crate::material::InfluenceFunction::One,
        };
        let parameters = BondBasedParameters {
            bulk_modulus: 3.0,
            planar_thickness: None,
        };
        BondBased::new(&block, &parameters).unwrap()
    }

    use crate::material::set_up;

    /// Reference positions, volumes, bonds, current positions, bond damage.
    type Body = (Vec<[f64; 3]>, Vec<f64>, BondList, Vec<[f64; 3]>, Vec<f32>);

    #[test]
    fn the_closed_block_force_matches_the_generic_force_state_sum() {
        // The closed-block loop is a fast path of F_i = Σ_j (T_i⟨ξ_ij⟩ − T_j⟨ξ_ji⟩) V_j
        // (`material::generic_force`): same force to round-off, with damage.
        let (x, v, bonds, y, damage) = body();
        let reference = reference_view(&bonds, &x, &v);
        let all: Vec<u32> = (0..x.len() as u32).collect();
        let mut m = material();
        set_up(&mut m, &reference, all.clone());
        let current = CurrentView {
            position: &y,
            bond_damage: Some(&damage),
            history: &crate::history::NO_HISTORY,
        };
        let coefficients = vec![PointCoefficients::default(); x.len()];
        let mut fast = vec![[0.0; 3]; x.len()];
        m.add_force_density(&reference, &current, &coefficients, &mut fast);
        let kernel = PmbForceState {
            bonds: &bonds,
            half: m.half(),
            damage: Damaged(&damage),
        };
        let mut generic = vec![[0.0; 3]; x.len()];
        crate::material::generic_force::add_force_density_from_states(
            &kernel,
            &all,
            &reference,
            &current,
            &mut generic,
        );
        let largest = fast.iter().flatten().fold(0.0f64, |a, f| a.max(f.abs()));
        assert!(largest > 0.0);
        for (a, b) in fast.iter().flatten().zip(generic.iter().flatten()) {
            assert!((a - b).abs() <= 1e-12 * largest, "{a} vs {b}");
        }
    }

    /// 600 random points (more than two pair-plan chunks), random volumes, displaced by up
    /// to 0.1, with bonds above stretch 0.02 broken.
    fn body() -> Body {
        let mut rng = Rng::new(11);
        let (x, v) = random_cloud(&mut rng, 600, 7.0);
        displaced(rng, x, v)
    }

    /// 1,500 random points in a 30 × 3 × 3 bar numbered along x, like a run's space-filling
    /// order: a chunk of 256 points then spans about 5 units of x (three horizons), so the
    /// earlier one-pass plan gave neighbouring chunks different colours and summed each
    /// point's force in an order set by where the chunk boundaries fall. Displaced and
    /// damaged as [`body`].
    fn bar() -> Body {
        let mut rng = Rng::new(12);
        let (cube, v) = random_cloud(&mut rng, 1500, 1.0);
        let mut x: Vec<[f64; 3]> = cube
            .iter()
            .map(|p| [30.0 * p[0], 3.0 * p[1], 3.0 * p[2]])
            .collect();
        x.sort_by(|a, b| a[0].total_cmp(&b[0]));
        displaced(rng, x, v)
    }

    fn displaced(mut rng: Rng, x: Vec<[f64; 3]>, v: Vec<f64>) -> Body {
        let bonds = brute_force_bonds(&x, 1.6);
        let y: Vec<[f64; 3]> = x
            .iter()
            .map(|p| p.map(|c| c + 0.1 * (2.0 * rng.uniform() - 1.0)))
            .collect();
        let reference = reference_view(&bonds, &x, &v);
        let mut damage = vec![0.0f32; bonds.num_bonds()];
        let all: Vec<u32> = (0..x.len() as u32).collect();
        CriticalStretch::new(0.02)
            .unwrap()
            .update(&reference, &y, &all, &mut damage);
        assert!(damage.iter().any(|&d| d > 0.0) && damage.contains(&0.0));
        (x, v, bonds, y, damage)
    }

    fn force(
        blocks: &[&BondBased],
        reference: &ReferenceView<'_>,
        y: &[[f64; 3]],
        damage: &[f32],
    ) -> Vec<[f64; 3]> {
        let n = y.len();
        let current = CurrentView {
            position: y,
            bond_damage: Some(damage),
            history: &crate::history::NO_HISTORY,
        };
        let mut coefficients = vec![PointCoefficients::default(); n];
        for m in blocks {
            m.compute_point_coefficients(reference, &current, &mut coefficients);
        }
        let mut f = vec![[0.0; 3]; n];
        for m in blocks {
            m.add_force_density(reference, &current, &coefficients, &mut f);
        }
        f
    }

    #[test]
    fn closed_block_loop_matches_the_gather_loop() {
        // One closed block takes the closed-block loop; the same constants split over two
        // blocks take the gather loop (c_ij = c/2 + c/2 = c exactly). The two multiply the
        // same factors in different orders, so they agree to round-off: relative 1e-12 of the
        // largest force (each entry sums ~60 terms of that size with 1e-16 rounding each).
        let (x, v, bonds, y, damage) = body();
        let reference = reference_view(&bonds, &x, &v);
        let mut whole = material();
        set_up(&mut whole, &reference, (0..x.len() as u32).collect());
        assert!(whole.closed);
        let (left, right): (Vec<u32>, Vec<u32>) =
            (0..x.len() as u32).partition(|&i| x[i as usize][0] < 3.5);
        let mut a = material();
        let mut b = material();
        set_up(&mut a, &reference, left);
        set_up(&mut b, &reference, right);
        assert!(!a.closed && !b.closed);
        let closed = force(&[&whole], &reference, &y, &damage);
        let gathered = force(&[&a, &b], &reference, &y, &damage);
        let largest = gathered
            .iter()
            .flatten()
            .fold(0.0f64, |m, f| m.max(f.abs()));
        assert!(largest > 0.0);
        for (p, g) in closed.iter().zip(&gathered) {
            for k in 0..3 {
                assert!((p[k] - g[k]).abs() <= 1e-12 * largest, "{p:?} vs {g:?}");
            }
        }
    }

    #[test]
    fn closed_block_result_is_the_same_for_every_thread_count() {
        // Every point gathers its own row in row order, whatever the threads.
        let (x, v, bonds, y, damage) = body();
        let reference = reference_view(&bonds, &x, &v);
        let mut m = material();
        set_up(&mut m, &reference, (0..x.len() as u32).collect());
        let run = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| force(&[&m], &reference, &y, &damage))
        };
        let one = run(1);
        assert_eq!(one, run(2));
        assert_eq!(one, run(3));
    }

    /// The force of every point as the module docs define it, written plainly: row order, four
    /// partial sums by position, each bond's scale from its own ζ and damage.
    fn row_ordered_reference(
        bonds: &BondList,
        v: &[f64],
        y: &[[f64; 3]],
        damage: &[f32],
        c: f64,
    ) -> Vec<[f64; 3]> {
        (0..y.len())
            .map(|i| {
                let mut sum = [[0.0f64; 4]; 3];
                for (n, b) in bonds.range(i).enumerate() {
                    let j = bonds.neighbor[b] as usize;
                    let zeta = bonds.reference_length[b];
                    let d = [0, 1, 2].map(|k| y[j][k] - y[i][k]);
                    let length = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                    let intact = 1.0 - f64::from(damage[b]);
                    let s = if length > 0.0 {
                        c * intact * (length - zeta) / (zeta * length)
                    } else {
                        0.0
                    };
                    for k in 0..3 {
                        sum[k][n % 4] += s * v[j] * (y[j][k] - y[i][k]);
                    }
                }
                sum.map(|s| (s[0] + s[1]) + (s[2] + s[3]))
            })
            .collect()
    }

    #[test]
    fn closed_block_force_is_the_row_ordered_sum_bitwise() {
        // Damage made one-sided on some bonds: each direction reads its own.
        let (x, v, bonds, y, mut damage) = body();
        for b in (0..damage.len()).step_by(7) {
            damage[b] = 0.5;
        }
        let reference = reference_view(&bonds, &x, &v);
        let mut m = material();
        set_up(&mut m, &reference, (0..x.len() as u32).collect());
        assert!(m.closed);
        let expected = row_ordered_reference(&bonds, &v, &y, &damage, m.micromodulus());
        assert_eq!(force(&[&m], &reference, &y, &damage), expected);
    }

    /// A rank's view of the bar: the points with 8 ≤ x < 20 ("owned") and their neighbours
    /// ("ghosts"), numbered in increasing global order, every row cut to local points (a
    /// ghost's row loses its bonds to points outside), as `parallel::Subdomain` builds it.
    /// Returns the local points (global indices) and the local bond list; `bond_of[l]` is the
    /// global bond of local bond l.
    fn sub_selection(
        x: &[[f64; 3]],
        bonds: &BondList,
    ) -> (Vec<u32>, Vec<bool>, BondList, Vec<usize>) {
        let owned: Vec<bool> = x.iter().map(|p| (8.0..20.0).contains(&p[0])).collect();
        let mut local = vec![false; x.len()];
        for i in (0..x.len()).filter(|&i| owned[i]) {
            local[i] = true;
            for &j in bonds.family(i) {
                local[j as usize] = true;
            }
        }
        let points: Vec<u32> = (0..x.len() as u32).filter(|&i| local[i as usize]).collect();
        let mut local_of = vec![u32::MAX; x.len()];
        for (l, &g) in points.iter().enumerate() {
            local_of[g as usize] = l as u32;
        }
        let mut sub = BondList {
            offsets: vec![0],
            ..Default::default()
        };
        let mut bond_of = Vec::new();
        for &g in &points {
            for b in bonds.range(g as usize) {
                let l = local_of[bonds.neighbor[b] as usize];
                if l != u32::MAX {
                    sub.neighbor.push(l);
                    sub.reference_length.push(bonds.reference_length[b]);
                    bond_of.push(b);
                }
            }
            sub.offsets.push(sub.neighbor.len());
        }
        let owned_local = points.iter().map(|&g| owned[g as usize]).collect();
        (points, owned_local, sub, bond_of)
    }

    #[test]
    fn owned_forces_and_damage_are_those_of_the_whole_body_bitwise() {
        // The sub-selection holds the owned rows whole and the ghost rows cut, and its plan
        // cuts the points into other chunks than the whole body's (it has fewer points, and
        // they are renumbered). The owned forces and damage must nevertheless be the same
        // bits, with damage broken by the fused loop over two loadings (half, then the full
        // random displacement) as in `fused_breaking_matches_the_separate_update_bitwise`.
        let (x, v, bonds, y, _) = bar();
        let (points, owned, sub_bonds, bond_of) = sub_selection(&x, &bonds);
        let pick = |values: &[[f64; 3]]| -> Vec<[f64; 3]> {
            points.iter().map(|&g| values[g as usize]).collect()
        };
        let sub_x = pick(&x);
        let sub_v: Vec<f64> = points.iter().map(|&g| v[g as usize]).collect();
        assert!(points.len() < x.len());
        assert!(owned.contains(&true) && owned.contains(&false));
        let whole_reference = reference_view(&bonds, &x, &v);
        let sub_reference = reference_view(&sub_bonds, &sub_x, &sub_v);
        let mut whole = material();
        set_up(&mut whole, &whole_reference, (0..x.len() as u32).collect());
        let mut sub = material();
        set_up(&mut sub, &sub_reference, (0..points.len() as u32).collect());
        assert!(
            whole.critical_stretch_fast_path().is_some()
                && sub.critical_stretch_fast_path().is_some()
        );
        // The same rank computing the forces of some of its owned points only (a distributed
        // run keeps the owned ones; every other one here, so that the kept points are not a
        // contiguous run of the block): every pair is still decided, the others' forces are
        // left alone.
        let kept = |l: usize| owned[l] && l % 2 == 0;
        let mut owned_only = sub.clone();
        (&mut owned_only as &mut dyn Material).restrict_forces(&|l| kept(l as usize));
        let mut owned_only_damage = vec![0.0f32; sub_bonds.num_bonds()];
        let coefficients = vec![PointCoefficients::default(); x.len()];
        let mut whole_damage = vec![0.0f32; bonds.num_bonds()];
        let mut sub_damage = vec![0.0f32; sub_bonds.num_bonds()];
        let mut broken = 0;
        for fraction in [0.5, 1.0] {
            let at: Vec<[f64; 3]> = x
                .iter()
                .zip(&y)
                .map(|(p, q)| [0, 1, 2].map(|k| p[k] + fraction * (q[k] - p[k])))
                .collect();
            let sub_at = pick(&at);
            let mut whole_force = vec![[0.0; 3]; x.len()];
            broken += whole.add_force_density_breaking_bonds(
                &whole_reference,
                &at,
                0.02,
                &mut whole_damage,
                &coefficients,
                &mut whole_force,
            );
            let mut sub_force = vec![[0.0; 3]; points.len()];
            sub.add_force_density_breaking_bonds(
                &sub_reference,
                &sub_at,
                0.02,
                &mut sub_damage,
                &coefficients[..points.len()],
                &mut sub_force,
            );
            for (l, &g) in points.iter().enumerate() {
                if owned[l] {
                    assert_eq!(sub_force[l], whole_force[g as usize], "point {g}");
                }
            }
            // Every local bond (ghost rows too) is decided as in the whole body.
            for (l, &b) in bond_of.iter().enumerate() {
                assert_eq!(sub_damage[l], whole_damage[b]);
            }
            // The separate force call (damage already updated) gives the same bits again.
            let again = force(&[&sub], &sub_reference, &sub_at, &sub_damage);
            assert_eq!(again, sub_force);
            let untouched = [7.0, 8.0, 9.0];
            let mut owned_only_force: Vec<[f64; 3]> = (0..points.len())
                .map(|l| if kept(l) { [0.0; 3] } else { untouched })
                .collect();
            owned_only.add_force_density_breaking_bonds(
                &sub_reference,
                &sub_at,
                0.02,
                &mut owned_only_damage,
                &coefficients[..points.len()],
                &mut owned_only_force,
            );
            assert_eq!(owned_only_damage, sub_damage);
            for l in 0..points.len() {
                let expected = if kept(l) { sub_force[l] } else { untouched };
                assert_eq!(owned_only_force[l], expected, "local point {l}");
            }
        }
        assert!(broken > 0 && broken < bonds.num_bonds(), "{broken}");
    }

    #[test]
    fn closed_block_loop_needs_neither_sorted_rows_nor_reverse_bonds() {
        // Row 0 unsorted (2 before 1), 2 → 1 without 1 → 2: each row is summed as it stands.
        let bonds = BondList {
            offsets: vec![0, 2, 3, 5],
            neighbor: vec![2, 1, 0, 0, 1],
            reference_length: vec![2.0, 1.0, 1.0, 2.0, 5f64.sqrt()],
        };
        let x = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 2.0, 0.0]];
        let v = vec![1.0, 0.5, 0.25];
        let y = vec![[0.0, 0.01, 0.0], [1.02, 0.0, 0.0], [0.0, 2.03, 0.01]];
        let damage = vec![0.0f32; 5];
        let reference = reference_view(&bonds, &x, &v);
        let mut m = material();
        set_up(&mut m, &reference, vec![0, 1, 2]);
        assert!(m.closed);
        let expected = row_ordered_reference(&bonds, &v, &y, &damage, m.micromodulus());
        assert!(expected.iter().all(|f| f.iter().any(|&c| c != 0.0)));
        assert_eq!(force(&[&m], &reference, &y, &damage), expected);
    }

    #[test]
    fn fused_breaking_matches_the_separate_update_bitwise() {
        // Two evaluations, at half and then at the full random displacement, so that the
        // second meets bonds already broken by the first. Fused or separate, the same bonds
        // must break (same count, same damage array) and the forces must be the same bits:
        // the fused loop takes the exact test on the same q and reads the updated damage.
        let (x, v, bonds, y, _) = body();
        let reference = reference_view(&bonds, &x, &v);
        let mut m = material();
        set_up(&mut m, &reference, (0..x.len() as u32).collect());
        assert!(m.critical_stretch_fast_path().is_some());
        let all: Vec<u32> = (0..x.len() as u32).collect();
        let model = CriticalStretch::new(0.02).unwrap();
        let mut coefficients = vec![PointCoefficients::default(); x.len()];
        let current = CurrentView {
            position: &x,
            bond_damage: None,
            history: &crate::history::NO_HISTORY,
        };
        m.compute_point_coefficients(&reference, &current, &mut coefficients);
        let mut separate = vec![0.0f32; bonds.num_bonds()];
        let mut fused = vec![0.0f32; bonds.num_bonds()];
        let mut total = 0;
        for fraction in [0.5, 1.0] {
            let at: Vec<[f64; 3]> = x
                .iter()
                .zip(&y)
                .map(|(p, q)| [0, 1, 2].map(|k| p[k] + fraction * (q[k] - p[k])))
                .collect();
            let broken = model.update(&reference, &at, &all, &mut separate);
            let expected = force(&[&m], &reference, &at, &separate);
            let mut f = vec![[0.0; 3]; x.len()];
            let fused_broken = m.add_force_density_breaking_bonds(
                &reference,
                &at,
                0.02,
                &mut fused,
                &coefficients,
                &mut f,
            );
            assert_eq!(fused_broken, broken);
            assert_eq!(fused, separate);
            assert_eq!(f, expected);
            total += broken;
        }
        assert!(total > 0 && total < bonds.num_bonds(), "{total}");
    }

    /// Forces, damage and the count of bonds broken by the closed-block loop over the whole
    /// body, with the AVX2 build of the row or the baseline one, breaking at `stretch` from
    /// `damage` (or, with `None`, reading `damage` and breaking nothing).
    fn closed_rows_result(
        reference: &ReferenceView<'_>,
        y: &[[f64; 3]],
        mut damage: Vec<f32>,
        stretch: Option<f64>,
        wide: bool,
    ) -> (Vec<[f64; 3]>, Vec<f32>, usize) {
        let rows = ClosedRows {
            bonds: reference.bonds,
            y,
            micromodulus: material().micromodulus(),
            wide,
        };
        let all: Vec<u32> = (0..y.len() as u32).collect();
        let mut f = vec![[0.0; 3]; y.len()];
        let broken = with_volume_rule!(reference, |v| match stretch {
            // SAFETY: one chunk holds every row; `damage` outlives the call.
            None => unsafe {
                rows.chunk_dispatch(&all, 0, &mut f, v, Damaged(&damage), NoBreaking)
            },
            Some(stretch) => {
                let fused = FusedCriticalStretch {
                    limit: StretchLimit::new(stretch),
                    damage: damage.as_mut_ptr(),
                };
                // SAFETY: as above; the pointer is the only access to `damage` meanwhile.
                unsafe { rows.chunk_dispatch(&all, 0, &mut f, v, fused, fused) }
            }
        });
        (f, damage, broken)
    }

    #[test]
    fn the_avx2_row_is_the_baseline_row_bitwise() {
        // The AVX2 row (intrinsics, four bonds per register, gathers) against the baseline
        // build of the staged loop: rows of every length mod 4, fractional and full damage,
        // and a critical stretch that breaks bonds on the way.
        if !wide_vectors_available() {
            eprintln!("this CPU has no AVX2: only the baseline row runs here");
            return;
        }
        let (x, v, bonds, y, mut damage) = body();
        for b in (0..damage.len()).step_by(7) {
            damage[b] = 0.5;
        }
        let reference = reference_view(&bonds, &x, &v);
        let lengths: std::collections::BTreeSet<usize> =
            (0..x.len()).map(|i| bonds.family_size(i) % 4).collect();
        assert_eq!(lengths.len(), 4, "rows of every length mod 4");
        for stretch in [None, Some(0.02)] {
            let start = match stretch {
                None => damage.clone(),
                Some(_) => vec![0.0; damage.len()],
            };
            let wide = closed_rows_result(&reference, &y, start.clone(), stretch, true);
            let narrow = closed_rows_result(&reference, &y, start, stretch, false);
            assert_eq!(wide, narrow);
            assert_eq!(wide.2 > 0, stretch.is_some(), "bonds broken: {}", wide.2);
        }
    }

    #[test]
    fn open_blocks_do_not_fuse() {
        // A block with bonds to another block leaves its damage to the damage model (the
        // physics symmetrises interface bonds between the update and the force).
        let (x, v, bonds, _, _) = body();
        let reference = reference_view(&bonds, &x, &v);
        let left: Vec<u32> = (0..x.len() as u32)
            .filter(|&i| x[i as usize][0] < 3.5)
            .collect();
        let mut m = material();
        set_up(&mut m, &reference, left);
        assert!(m.critical_stretch_fast_path().is_none());
    }
}
