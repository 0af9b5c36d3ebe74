//! Linear peridynamic solid (LPS, Silling et al. 2007), Peridigm's `Elastic` material
//! (`elastic.cxx`, `material_utilities.cxx`), in its large-deformation
//! form: extensions are measured along the current bond.
//!
//! * weighted volume `m_i = Σ_j ω ζ² V_j`, reference configuration, all bonds (damage
//!   ignored), computed once at setup — Peridigm's rule;
//! * dilatation `θ_i = (3/m_i) Σ_j ω (1−d) ζ e V_j`, `e = |Y_j − Y_i| − ζ`;
//! * scalar force state, exactly as Peridigm codes it (note `(1−d)` squared on the deviatoric
//!   part): `t_ij = (1−d)·[ (3K/m − 5μ/m)·ω·θ·ζ + (1−d)·(15μ/m)·ω·e ]`;
//! * force density `F_i = Σ_j (t_ij + t_ji) V_j M_ij` (see the module docs of `material`),
//!   with t_ji from j's own θ and m;
//! * stored energy density (Peridigm's compute class), `α = 15μ/m`, `e^d = e − θζ/3`:
//!   `W_i = K θ_i²/2 + (α_i/2) Σ_j (1−d) ω (e^d)² V_j`. For intact bonds the force is exactly
//!   `−∂(Σ_k W_k V_k)/∂Y_i / V_i` (checked by a finite-difference test).
//!
//! A point whose weighted volume is 0 (no bonds, or ω = 0 on all of them) has no dilatation and
//! carries no force (Peridigm would divide by zero).
//!
//! * partial stress (Peridigm's `Partial_Stress` output), `Σ_j t_ij M_ij ⊗ ξ_ij V_j`: the
//!   force states of the point's own side only, as `elastic.cxx` sums them. Peridigm fills it
//!   only with `Compute Partial Stress: true`; here it is computed whenever an output asks
//!   for it (the key is accepted and changes nothing else).
//!
//! * thermal strain (`Thermal Expansion Coefficient` α, Peridigm's rule): with the point
//!   temperature change ΔT_i, every extension of point i's side is measured from the freely
//!   expanded bond, `e ← e − αΔT_i ζ`, in θ_i, in t_ij and in the stored energy (t_ji uses
//!   ΔT_j and j's material's α, the free strain published per point,
//!   [`crate::history::Thermal::strain`]). A block with α takes these simple bond loops in every
//!   evaluation while the run has point temperatures; blocks without α, and every run without
//!   temperature conditions, keep the fast loops below unchanged.
//! * shear correction (`Apply Shear Correction Factor: true`, off by default; Peridigm's
//!   `Elastic` reads the key and ignores it): μ is replaced pointwise by s_i μ, s_i the
//!   shear-correction factor of the point's neighbourhood (`super::shear_correction`), so
//!   `α_i = 15 s_i μ/m_i` and the isotropic coefficient is `(3K − 5 s_i μ)θ/m`; the bulk
//!   response is unchanged and the stiffest probed pure shear of every point has modulus μ.

use super::influence::InfluenceFunction;
use super::keys::{
    AUTOMATIC_DIFFERENTIATION, DENSITY, ELASTIC, PROBE_LENGTH, TANGENT, THERMAL_EXPANSION,
};
use super::{
    influence_weighted_volumes, local_offsets, BlockData, BlockInput, CurrentView, Damaged,
    ElasticConstants, Material, MaterialError, MaterialKeys, MaterialModel, MaterialOutputs,
    MaterialParameters, MaterialTangent, PointCoefficients, ReferenceView, StoredWeights,
    Undamaged, UnitWeights,
};
use super::{BreakingCoefficientPass, CriticalStretchFastPath, FusedCriticalStretch};
use crate::damage::StretchLimit;
use crate::model::point_chunks::for_each_chunk;
use crate::model::with_volume_rule;
use crate::model::{
    FieldCarrier, FieldDeclaration, KeyDoc, ModelDeclaration, Reach, TangentSupport,
};
use crate::parameter_list::error::DeckError;
use crate::parameter_list::reader::{Ctx, ListReader};
use crate::tangent::{assemble, BlockTangent, ForceState, PointIndex, TangentError, TangentMethod};

mod force_state;
mod rows;
mod thermal;

use force_state::LpsForceState;
use rows::NoBreaking;

/// `Compute Partial Stress`.
const COMPUTE_PARTIAL_STRESS: KeyDoc = KeyDoc {
    key: "Compute Partial Stress",
    meaning: "Peridigm's switch for `Partial_Stress`; accepted without effect (peridyn computes \
              it whenever an output lists it)",
    unit: "true/false",
    default: "false",
};

/// `Apply Shear Correction Factor` of `Elastic`.
const SHEAR_CORRECTION: KeyDoc = KeyDoc {
    key: "Apply Shear Correction Factor",
    meaning: "scale μ pointwise by the shear-correction factor of the point's neighbourhood \
              (Peridigm's `Elastic` reads the key and ignores it)",
    unit: "true/false",
    default: "false",
};

/// `Hourglass Coefficient`, which decks carry on `Elastic` materials.
const HOURGLASS_WITHOUT_EFFECT: KeyDoc = KeyDoc {
    key: "Hourglass Coefficient",
    meaning: "accepted without effect: only correspondence models have hourglass control",
    unit: "—",
    default: "—",
};

/// Deck parameters of `Elastic` besides the keys every model shares.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinearPeridynamicSolidParameters {
    /// K and μ from the elastic pair.
    pub elastic: ElasticConstants,
    /// `Compute Partial Stress` (no effect: `Partial_Stress` is computed whenever an output
    /// lists it).
    pub compute_partial_stress: bool,
    /// `Apply Shear Correction Factor` (module docs).
    pub shear_correction: bool,
}

impl MaterialParameters for LinearPeridynamicSolidParameters {
    fn bulk_modulus(&self) -> Option<f64> {
        Some(self.elastic.bulk_modulus)
    }
}

/// The LPS material of one block (see the module docs for the formulas).
#[derive(Debug, Clone)]
pub struct LinearPeridynamicSolid {
    block: BlockData,
    shear_modulus: f64,
    influence: InfluenceFunction,
    /// Block-local row starts into `weights`.
    local_offsets: Vec<usize>,
    /// ω per block bond; `None` for `One` (nothing to store).
    weights: Option<Vec<f64>>,
    /// m per block point (same order as the block's points).
    weighted_volume: Vec<f64>,
    /// Whether `prepare` probes the shear-correction factor of every point.
    shear_correction: bool,
    /// The shear-correction factor s per block point (same order as the block's points); empty
    /// when the deck does not ask for it.
    correction: Vec<f64>,
}

impl MaterialKeys for LinearPeridynamicSolid {
    type Parameters = LinearPeridynamicSolidParameters;

    /// `Elastic`: state-based (the dilatation of both ends enters every bond force, so the
    /// force reaches two hops); keeps the weighted volume (fixed by the reference
    /// configuration) and the dilatation (recomputed in every evaluation) per point.
    const DECLARATION: ModelDeclaration = ModelDeclaration {
        deck_name: "Elastic",
        aliases: &["Elastic Partial Volume"],
        deck_keys: &[
            DENSITY,
            ELASTIC[0],
            ELASTIC[1],
            ELASTIC[2],
            ELASTIC[3],
            TANGENT,
            AUTOMATIC_DIFFERENTIATION,
            PROBE_LENGTH,
            COMPUTE_PARTIAL_STRESS,
            SHEAR_CORRECTION,
            THERMAL_EXPANSION,
            HOURGLASS_WITHOUT_EFFECT,
        ],
        reach: Reach::TwoHop,
        fields: &[
            FieldDeclaration {
                name: "Weighted_Volume",
                carrier: FieldCarrier::Point,
                bytes_per_value: 8,
                staged: false,
            },
            FieldDeclaration {
                name: "Dilatation",
                carrier: FieldCarrier::Point,
                bytes_per_value: 8,
                staged: false,
            },
        ],
        outputs: &["Weighted_Volume", "Dilatation", "Partial_Stress"],
        tangent: TangentSupport::Analytic,
        thermal_strain: true,
        small_displacement: false,
        example: "Density: 2.0\nBulk Modulus: 3.0\nShear Modulus: 1.7",
    };

    // Peridigm's `Elastic Partial Volume` (a -DUSE_PV build) is the LPS of `Elastic` whose
    // bond volumes are the element–horizon intersections when the discretization computes
    // them, else the cells: the block's quadrature rule (`Full Volume` unless the block or the
    // discretization's `Element-Horizon Intersection Partial Volume Scheme` says otherwise)
    // does exactly that for every material, hence the alias.
    fn read(
        ctx: &mut Ctx,
        list: &mut ListReader,
    ) -> Result<LinearPeridynamicSolidParameters, DeckError> {
        let elastic = super::elastic_constants::read(ctx, list)?;
        list.without_effect(
            HOURGLASS_WITHOUT_EFFECT.key,
            "only correspondence models have hourglass control",
        );
        let compute_partial_stress = list.flag_without_effect(
            ctx,
            COMPUTE_PARTIAL_STRESS.key,
            false,
            true,
            "peridyn computes Partial_Stress whenever an output lists it",
        )?;
        let shear_correction = list.bool_or(ctx, SHEAR_CORRECTION.key, false)?;
        if let Some(f) = list.peek(SHEAR_CORRECTION.key).filter(|_| shear_correction) {
            ctx.warn(
                f.line(),
                &f.path,
                "peridyn applies the shear-correction factor to this Elastic material \
                 (Peridigm's Elastic reads the key and ignores it, so results differ from \
                 Peridigm's near surfaces)",
            );
        }
        Ok(LinearPeridynamicSolidParameters {
            elastic,
            compute_partial_stress,
            shear_correction,
        })
    }
}

impl MaterialModel for LinearPeridynamicSolid {
    fn build(
        block: &BlockInput,
        parameters: &LinearPeridynamicSolidParameters,
    ) -> Result<Box<dyn Material>, MaterialError> {
        Ok(Box::new(
            Self::new(block, &parameters.elastic)?
                .with_shear_correction(parameters.shear_correction),
        ))
    }
}

impl LinearPeridynamicSolid {
    /// The same material, applying the shear-correction factor (module docs) when `on`.
    pub fn with_shear_correction(mut self, on: bool) -> Self {
        self.shear_correction = on;
        self
    }

    /// Validates the parameters (ρ, K, μ, δ positive and finite); ω from `block`.
    pub fn new(block: &BlockInput, elastic: &ElasticConstants) -> Result<Self, MaterialError> {
        let data = BlockData::new(
            &Self::DECLARATION,
            block.density,
            elastic.bulk_modulus,
            block.horizon,
        )?;
        Ok(Self {
            block: data,
            shear_modulus: super::positive("Shear Modulus", elastic.shear_modulus)?,
            influence: block.influence.clone(),
            local_offsets: vec![0],
            weights: None,
            weighted_volume: Vec::new(),
            shear_correction: false,
            correction: Vec::new(),
        })
    }

    /// The free thermal strain α ΔT of every point, when this block has α and the run has
    /// point temperatures (the thermal bond loops then run).
    fn thermal_strain<'a>(&self, current: &CurrentView<'a>) -> Option<&'a [f64]> {
        self.block.thermal_expansion()?;
        current.history.thermal().map(|t| &t.strain[..])
    }

    /// Weighted volume m of each block point (Peridigm's `Weighted_Volume`), in the order of
    /// the block's points; empty before setup.
    pub fn weighted_volume(&self) -> &[f64] {
        &self.weighted_volume
    }
}

/// Runs `$body` with `$w` bound to the block's ω access and `$d` to the damage access, one
/// match per call, so each of the four combinations gets its own monomorphized bond loop.
macro_rules! with_bond_data {
    ($weights:expr, $damage:expr, |$w:ident, $d:ident| $body:expr) => {
        match ($weights, $damage) {
            (None, None) => {
                let ($w, $d) = (UnitWeights, Undamaged);
                $body
            }
            (None, Some(damage)) => {
                let ($w, $d) = (UnitWeights, Damaged(damage));
                $body
            }
            (Some(weights), None) => {
                let ($w, $d) = (StoredWeights(weights), Undamaged);
                $body
            }
            (Some(weights), Some(damage)) => {
                let ($w, $d) = (StoredWeights(weights), Damaged(damage));
                $body
            }
        }
    };
}

/// μ of block point `local`: times its shear-correction factor when `correction` has one.
#[inline(always)]
fn corrected_shear(shear: f64, correction: &[f64], local: usize) -> f64 {
    match correction.get(local) {
        Some(s) => s * shear,
        None => shear,
    }
}

impl Material for LinearPeridynamicSolid {
    fn block(&self) -> &BlockData {
        &self.block
    }

    fn block_mut(&mut self) -> &mut BlockData {
        &mut self.block
    }

    fn prepare(&mut self, reference: &ReferenceView<'_>) -> Result<(), MaterialError> {
        let bonds = reference.bonds;
        let points = self.block.points();
        let horizon = self.block.horizon();
        let weights = if self.influence.is_one() {
            None
        } else {
            Some(self.influence.per_bond(bonds, points, horizon)?)
        };
        let local_offsets = local_offsets(bonds, points);
        let weighted_volume =
            influence_weighted_volumes(reference, points, &local_offsets, weights.as_deref());
        self.correction = if self.shear_correction {
            super::shear_correction::factors(
                reference,
                points,
                &weighted_volume,
                weights.as_deref().map(|w| (w, local_offsets.as_slice())),
            )
        } else {
            Vec::new()
        };
        self.weights = weights;
        self.local_offsets = local_offsets;
        self.weighted_volume = weighted_volume;
        Ok(())
    }

    fn compute_point_coefficients(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        coefficients: &mut [PointCoefficients],
    ) {
        let plain = self.rows(reference, current, reference.bond_volumes());
        if let Some(thermal) = plain.thermal() {
            with_bond_data!(self.weights.as_deref(), current.bond_damage, |w, d| {
                for_each_chunk(
                    self.block.points(),
                    coefficients,
                    &|i| i as usize,
                    &|chunk: &[u32], base: usize, out: &mut [PointCoefficients]| {
                        thermal.dilatation(chunk, base, out, w, d)
                    },
                )
            });
            return;
        }
        with_volume_rule!(reference, |v| {
            let rows = self.rows(reference, current, v);
            with_bond_data!(self.weights.as_deref(), current.bond_damage, |w, d| {
                for_each_chunk(
                    self.block.points(),
                    coefficients,
                    &|i| i as usize,
                    &|chunk: &[u32], base: usize, out: &mut [PointCoefficients]| {
                        // SAFETY: `NoBreaking` touches no damage.
                        unsafe { rows.dilatation_dispatch(chunk, base, out, w, d, NoBreaking) };
                    },
                )
            })
        })
    }

    /// The dilatation pass breaks the bonds of each row (not with thermal expansion: the fused
    /// pass measures e without the thermal strain). Each row decides its own bonds and reads
    /// only its neighbours' positions, so the block need not hold its neighbours: a rank's
    /// layer-1 ghosts, whose neighbours in the outer ghost layer belong to no block's point
    /// list, take the pass as their owner does.
    fn critical_stretch_fast_path(&self) -> Option<CriticalStretchFastPath<'_>> {
        self.block
            .thermal_expansion()
            .is_none()
            .then_some(CriticalStretchFastPath::PointCoefficients(self))
    }

    fn add_force_density(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        coefficients: &[PointCoefficients],
        force_density: &mut [[f64; 3]],
    ) {
        let force_points = self.block.force_points();
        let plain = self.rows(reference, current, reference.bond_volumes());
        if let Some(thermal) = plain.thermal() {
            with_bond_data!(self.weights.as_deref(), current.bond_damage, |w, d| {
                for_each_chunk(
                    force_points,
                    force_density,
                    &|i| i as usize,
                    &|chunk: &[u32], base: usize, out: &mut [[f64; 3]]| {
                        thermal.add_force(coefficients, chunk, base, out, w, d)
                    },
                )
            });
            return;
        }
        with_volume_rule!(reference, |v| {
            let rows = self.rows(reference, current, v);
            with_bond_data!(self.weights.as_deref(), current.bond_damage, |w, d| {
                for_each_chunk(
                    force_points,
                    force_density,
                    &|i| i as usize,
                    &|chunk: &[u32], base: usize, out: &mut [[f64; 3]]| {
                        rows.add_force_dispatch(coefficients, chunk, base, out, w, d)
                    },
                )
            })
        })
    }

    fn stored_energy_density(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        coefficients: &[PointCoefficients],
        energy_density: &mut [f64],
    ) {
        let rows = self.rows(reference, current, reference.bond_volumes());
        with_bond_data!(self.weights.as_deref(), current.bond_damage, |w, d| {
            for_each_chunk(
                self.block.points(),
                energy_density,
                &|i| i as usize,
                &|chunk: &[u32], base: usize, out: &mut [f64]| {
                    rows.energy(coefficients, chunk, base, out, w, d)
                },
            )
        })
    }

    fn tangent(&self) -> Option<&dyn MaterialTangent> {
        Some(self)
    }

    fn outputs(&self) -> Option<&dyn MaterialOutputs> {
        Some(self)
    }
}

impl MaterialTangent for LinearPeridynamicSolid {
    fn add_tangent(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        method: TangentMethod,
        tangent: &mut BlockTangent,
    ) -> Result<(), TangentError> {
        let model = Self::DECLARATION.deck_name;
        with_bond_data!(self.weights.as_deref(), current.bond_damage, |w, d| {
            let kernel = LpsForceState {
                bonds: reference.bonds,
                volume: reference.bond_volumes(),
                local_offsets: &self.local_offsets,
                weighted_volume: &self.weighted_volume,
                weights: w,
                damage: d,
                bulk: self.block.bulk_modulus(),
                shear: self.shear_modulus,
                thermal_strain: self.thermal_strain(current),
                correction: &self.correction,
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
        })
    }
}

impl MaterialOutputs for LinearPeridynamicSolid {
    fn weighted_volume(&self) -> Option<&[f64]> {
        Some(&self.weighted_volume)
    }

    fn partial_stress(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        out: &mut [[f64; 9]],
    ) {
        use rayon::prelude::*;
        let bonds = reference.bonds;
        with_bond_data!(self.weights.as_deref(), current.bond_damage, |w, d| {
            let kernel = LpsForceState {
                bonds,
                volume: reference.bond_volumes(),
                local_offsets: &self.local_offsets,
                weighted_volume: &self.weighted_volume,
                weights: w,
                damage: d,
                bulk: self.block.bulk_modulus(),
                shear: self.shear_modulus,
                thermal_strain: self.thermal_strain(current),
                correction: &self.correction,
            };
            let stresses: Vec<[f64; 9]> = self
                .block
                .points()
                .par_iter()
                .enumerate()
                .map_init(
                    || (Vec::new(), Vec::new()),
                    |(y, t), (local, &p)| {
                        let p = p as usize;
                        y.clear();
                        y.push(current.position[p]);
                        y.extend(
                            bonds
                                .family(p)
                                .iter()
                                .map(|&j| current.position[j as usize]),
                        );
                        t.clear();
                        t.resize(bonds.family_size(p), [0.0; 3]);
                        kernel.force_state(PointIndex { global: p, local }, y, None, t);
                        let x = reference.position;
                        let mut stress = [0.0; 9];
                        for (force, b) in t.iter().zip(bonds.range(p)) {
                            let j = bonds.neighbor[b] as usize;
                            let v = reference.neighbor_volume(b, j);
                            for r in 0..3 {
                                for c in 0..3 {
                                    stress[3 * r + c] += force[r] * (x[j][c] - x[p][c]) * v;
                                }
                            }
                        }
                        stress
                    },
                )
                .collect();
            for (&p, stress) in self.block.points().iter().zip(stresses) {
                out[p as usize] = stress;
            }
        })
    }
}

impl BreakingCoefficientPass for LinearPeridynamicSolid {
    /// The dilatation pass tests each bond of a row just before it enters θ: the same q and
    /// the same exact test (behind the filter of `StretchLimit::breaks`) as the directed
    /// `Critical Stretch` update, each row deciding its own bonds (both ends of a pair decide
    /// alike, see [`crate::damage::CriticalStretch`]).
    fn compute_point_coefficients_breaking_bonds(
        &self,
        reference: &ReferenceView<'_>,
        position: &[[f64; 3]],
        critical_stretch: f64,
        bond_damage: &mut [f32],
        coefficients: &mut [PointCoefficients],
    ) -> usize {
        assert_eq!(bond_damage.len(), reference.bonds.num_bonds());
        let current = CurrentView {
            position,
            bond_damage: None,
            history: &crate::history::NO_HISTORY,
        };
        let fused = FusedCriticalStretch {
            limit: StretchLimit::new(critical_stretch),
            damage: bond_damage.as_mut_ptr(),
        };
        with_volume_rule!(reference, |v| {
            let rows = self.rows(reference, &current, v);
            match self.weights.as_deref() {
                None => rows.fused_dilatation(coefficients, UnitWeights, fused),
                Some(weights) => rows.fused_dilatation(coefficients, StoredWeights(weights), fused),
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::damage::{CriticalStretch, DamageModel};
    use crate::material::checked_row;
    use crate::model::test_support::{brute_force_bonds, random_cloud, Rng};
    use crate::model::BondVolumes;
    use crate::vector_width::wide_vectors_available;

    #[test]
    fn the_coefficient_kernels_match_the_generic_force_state_sum() {
        // The two-pass kernel (published θ, then t_ij + t_ji) is a fast path of
        // F_i = Σ_j (T_i⟨ξ_ij⟩ − T_j⟨ξ_ji⟩) V_j (`material::generic_force`): the same force to
        // round-off, with symmetric damage and both kinds of ω.
        let mut rng = Rng::new(21);
        let (x, v) = random_cloud(&mut rng, 400, 6.0);
        let bonds = brute_force_bonds(&x, 1.7);
        let y: Vec<[f64; 3]> = x
            .iter()
            .map(|p| p.map(|c| c + 0.05 * (2.0 * rng.uniform() - 1.0)))
            .collect();
        let mut damage = vec![0.0f32; bonds.num_bonds()];
        for i in 0..x.len() {
            for b in bonds.range(i) {
                let j = bonds.neighbor[b] as usize;
                if j > i && rng.uniform() < 0.2 {
                    let back =
                        bonds.offsets[j] + bonds.family(j).binary_search(&(i as u32)).unwrap();
                    let d = if rng.uniform() < 0.5 { 1.0 } else { 0.5 };
                    damage[b] = d;
                    damage[back] = d;
                }
            }
        }
        let reference = ReferenceView {
            bonds: &bonds,
            position: &x,
            volume: &v,
            bond_volume: None,
        };
        let current = CurrentView {
            position: &y,
            bond_damage: Some(&damage),
            history: &crate::history::NO_HISTORY,
        };
        let all: Vec<u32> = (0..x.len() as u32).collect();
        // The shear correction changes μ per point in both the coefficients and the force
        // states, so the two must still agree with it on.
        for (influence, corrected) in [
            (InfluenceFunction::One, false),
            (InfluenceFunction::ParabolicDecay, false),
            (InfluenceFunction::ParabolicDecay, true),
        ] {
            let mut m = LinearPeridynamicSolid::new(
                &crate::material::BlockInput {
                    density: 1.0,
                    horizon: 1.7,
                    influence,
                },
                &crate::material::ElasticConstants {
                    bulk_modulus: 3.0,
                    shear_modulus: 1.3,
                },
            )
            .unwrap()
            .with_shear_correction(corrected);
            crate::material::set_up(&mut m, &reference, all.clone());
            assert_eq!(m.correction.is_empty(), !corrected);
            let mut coefficients = vec![PointCoefficients::default(); x.len()];
            m.compute_point_coefficients(&reference, &current, &mut coefficients);
            let mut fast = vec![[0.0; 3]; x.len()];
            m.add_force_density(&reference, &current, &coefficients, &mut fast);
            let mut generic = vec![[0.0; 3]; x.len()];
            let sum = |out: &mut Vec<[f64; 3]>| {
                with_bond_data!(m.weights.as_deref(), current.bond_damage, |w, d| {
                    let kernel = LpsForceState {
                        bonds: &bonds,
                        volume: BondVolumes::new(&v, None),
                        local_offsets: &m.local_offsets,
                        weighted_volume: &m.weighted_volume,
                        weights: w,
                        damage: d,
                        bulk: 3.0,
                        shear: 1.3,
                        thermal_strain: None,
                        correction: &m.correction,
                    };
                    crate::material::generic_force::add_force_density_from_states(
                        &kernel, &all, &reference, &current, out,
                    )
                })
            };
            sum(&mut generic);
            let largest = fast.iter().flatten().fold(0.0f64, |a, f| a.max(f.abs()));
            assert!(largest > 0.0);
            for (a, b) in fast.iter().flatten().zip(generic.iter().flatten()) {
                assert!((a - b).abs() <= 1e-12 * largest, "{a} vs {b}");
            }
        }
    }

    #[test]
    fn fused_breaking_matches_the_separate_update_bitwise() {
        // 500 random points (rows longer than a group of lanes, with tails), displaced at half
        // and then at the full random field so that the second pass meets broken bonds, with
        // ω = 1 and a stored ω. The dilatation pass that breaks bonds itself must break the
        // same bonds as the `Critical Stretch` update (same count, same damage array) and give
        // the same coefficients bit for bit, and so the same forces. Also for a block that
        // does not hold all its neighbours (a rank's layer-1 ghosts, whose neighbours in the
        // outer ghost layer are in no block's list): the points left of x = 4.
        let mut rng = Rng::new(5);
        let (x, v) = random_cloud(&mut rng, 500, 6.0);
        let bonds = brute_force_bonds(&x, 1.7);
        let y: Vec<[f64; 3]> = x
            .iter()
            .map(|p| p.map(|c| c + 0.08 * (2.0 * rng.uniform() - 1.0)))
            .collect();
        let reference = ReferenceView {
            bonds: &bonds,
            position: &x,
            volume: &v,
            bond_volume: None,
        };
        let all: Vec<u32> = (0..x.len() as u32).collect();
        let left: Vec<u32> = all
            .iter()
            .copied()
            .filter(|&i| x[i as usize][0] < 4.0)
            .collect();
        let open = left.iter().any(|&i| {
            bonds
                .family(i as usize)
                .iter()
                .any(|&j| x[j as usize][0] >= 4.0)
        });
        assert!(
            open,
            "some neighbours of the left points should be right of x = 4"
        );
        // The shear correction changes μ per point in both the coefficients and the force
        // states, so the two must still agree with it on.
        for ((influence, corrected), points) in [
            (InfluenceFunction::One, false),
            (InfluenceFunction::ParabolicDecay, false),
            (InfluenceFunction::ParabolicDecay, true),
        ]
        .into_iter()
        .flat_map(|case| [(case.clone(), &all), (case, &left)])
        {
            let mut m = LinearPeridynamicSolid::new(
                &crate::material::BlockInput {
                    density: 1.0,
                    horizon: 1.7,
                    influence,
                },
                &crate::material::ElasticConstants {
                    bulk_modulus: 3.0,
                    shear_modulus: 1.3,
                },
            )
            .unwrap()
            .with_shear_correction(corrected);
            crate::material::set_up(&mut m, &reference, points.clone());
            assert_eq!(m.correction.is_empty(), !corrected);
            assert!(m.critical_stretch_fast_path().is_some());
            let model = CriticalStretch::new(0.02).unwrap();
            let mut separate = vec![0.0f32; bonds.num_bonds()];
            let mut fused = vec![0.0f32; bonds.num_bonds()];
            let mut total = 0;
            for fraction in [0.5, 1.0] {
                let at: Vec<[f64; 3]> = x
                    .iter()
                    .zip(&y)
                    .map(|(p, q)| [0, 1, 2].map(|k| p[k] + fraction * (q[k] - p[k])))
                    .collect();
                let broken = model.update(&reference, &at, points, &mut separate);
                let mut expected = vec![PointCoefficients::default(); x.len()];
                let current = CurrentView {
                    position: &at,
                    bond_damage: Some(&separate),
                    history: &crate::history::NO_HISTORY,
                };
                m.compute_point_coefficients(&reference, &current, &mut expected);
                let mut coefficients = vec![PointCoefficients::default(); x.len()];
                let fused_broken = m.compute_point_coefficients_breaking_bonds(
                    &reference,
                    &at,
                    0.02,
                    &mut fused,
                    &mut coefficients,
                );
                assert_eq!(fused_broken, broken);
                assert_eq!(fused, separate);
                assert_eq!(coefficients, expected);
                total += broken;
            }
            assert!(total > 0 && total < bonds.num_bonds(), "{total}");
        }
    }

    /// Reference positions, volumes, families and current positions.
    type Cloud = (
        Vec<[f64; 3]>,
        Vec<f64>,
        crate::model::BondList,
        Vec<[f64; 3]>,
    );

    /// 300 random points in a 5-wide box, their δ = 1.6 families, and positions moved by up
    /// to ±0.05 in every direction.
    fn perturbed_cloud(seed: u64) -> Cloud {
        let mut rng = Rng::new(seed);
        let (x, v) = random_cloud(&mut rng, 300, 5.0);
        let bonds = brute_force_bonds(&x, 1.6);
        let y = x
            .iter()
            .map(|p| p.map(|c| c + 0.05 * (2.0 * rng.uniform() - 1.0)))
            .collect();
        (x, v, bonds, y)
    }

    /// The LPS material of the perturbed cloud (δ = 1.6, not set up).
    fn small_material(influence: InfluenceFunction) -> LinearPeridynamicSolid {
        LinearPeridynamicSolid::new(
            &crate::material::BlockInput {
                density: 1.0,
                horizon: 1.6,
                influence,
            },
            &crate::material::ElasticConstants {
                bulk_modulus: 3.0,
                shear_modulus: 1.3,
            },
        )
        .unwrap()
    }

    #[test]
    fn restricted_forces_are_the_kept_points_forces_bitwise() {
        // A rank keeps its owned points (here every third point of a block that is a part of
        // the cloud, with a parabolic influence so that the block-local bond weights matter):
        // their forces are bitwise those of the unrestricted pass, the others are untouched.
        let (x, v, bonds, y) = perturbed_cloud(21);
        let reference = ReferenceView {
            bonds: &bonds,
            position: &x,
            volume: &v,
            bond_volume: None,
        };
        let mut m = small_material(InfluenceFunction::ParabolicDecay);
        let block: Vec<u32> = (0..x.len() as u32).filter(|p| p % 5 != 0).collect();
        crate::material::set_up(&mut m, &reference, block.clone());
        let current = CurrentView {
            position: &y,
            bond_damage: None,
            history: &crate::history::NO_HISTORY,
        };
        let mut c = vec![PointCoefficients::default(); x.len()];
        m.compute_point_coefficients(&reference, &current, &mut c);
        let mut all = vec![[0.0; 3]; x.len()];
        m.add_force_density(&reference, &current, &c, &mut all);
        let kept = |p: u32| p % 3 == 0;
        (&mut m as &mut dyn Material).restrict_forces(&kept);
        let untouched = [7.0, 8.0, 9.0];
        let mut restricted = vec![untouched; x.len()];
        restricted
            .iter_mut()
            .enumerate()
            .filter(|(p, _)| kept(*p as u32) && block.contains(&(*p as u32)))
            .for_each(|(_, f)| *f = [0.0; 3]);
        m.add_force_density(&reference, &current, &c, &mut restricted);
        for p in 0..x.len() as u32 {
            if kept(p) && block.contains(&p) {
                assert_eq!(restricted[p as usize], all[p as usize], "point {p}");
            } else {
                assert_eq!(restricted[p as usize], untouched, "point {p}");
            }
        }
        // Keeping every point is no restriction.
        (&mut m as &mut dyn Material).restrict_forces(&|_| true);
        let mut again = vec![[0.0; 3]; x.len()];
        m.add_force_density(&reference, &current, &c, &mut again);
        assert_eq!(again, all);
    }

    #[test]
    fn the_avx2_rows_are_the_baseline_rows_bitwise() {
        // The AVX2 rows (intrinsics, four bonds per register) against the baseline build of
        // the staged loops: stored ω, fractional damage, rows of every length mod 4, and a
        // critical stretch that breaks bonds in the dilatation pass.
        if !wide_vectors_available() {
            eprintln!("this CPU has no AVX2: only the baseline rows run here");
            return;
        }
        let (x, v, bonds, y) = perturbed_cloud(11);
        let reference = ReferenceView {
            bonds: &bonds,
            position: &x,
            volume: &v,
            bond_volume: None,
        };
        let lengths: std::collections::BTreeSet<usize> =
            (0..x.len()).map(|i| bonds.family_size(i) % 4).collect();
        assert_eq!(lengths.len(), 4, "rows of every length mod 4");
        let all: Vec<u32> = (0..x.len() as u32).collect();
        let mut m = small_material(InfluenceFunction::ParabolicDecay);
        crate::material::set_up(&mut m, &reference, all.clone());
        let weights = StoredWeights(m.weights.as_deref().expect("parabolic ω is stored"));
        let mut damage = vec![0.0f32; bonds.num_bonds()];
        for b in (0..damage.len()).step_by(5) {
            damage[b] = 0.5;
        }
        let current = CurrentView {
            position: &y,
            bond_damage: None,
            history: &crate::history::NO_HISTORY,
        };
        with_volume_rule!(reference, |volume| {
            let run = |wide: bool, stretch: Option<f64>| {
                let mut rows = m.rows(&reference, &current, volume);
                rows.wide = wide;
                let mut coefficients = vec![PointCoefficients::default(); x.len()];
                let mut damage = damage.clone();
                let broken = match stretch {
                    // SAFETY: one chunk holds every row; nothing else touches `damage`.
                    None => unsafe {
                        rows.dilatation_dispatch(
                            &all,
                            0,
                            &mut coefficients,
                            weights,
                            Damaged(&damage),
                            NoBreaking,
                        )
                    },
                    Some(stretch) => {
                        let fused = FusedCriticalStretch {
                            limit: StretchLimit::new(stretch),
                            damage: damage.as_mut_ptr(),
                        };
                        // SAFETY: as above; the pointer is the only access meanwhile.
                        unsafe {
                            rows.dilatation_dispatch(
                                &all,
                                0,
                                &mut coefficients,
                                weights,
                                fused,
                                fused,
                            )
                        }
                    }
                };
                let mut f = vec![[0.0; 3]; x.len()];
                rows.add_force_dispatch(&coefficients, &all, 0, &mut f, weights, Damaged(&damage));
                (coefficients, f, damage, broken)
            };
            for stretch in [None, Some(0.02)] {
                let wide = run(true, stretch);
                assert_eq!(wide, run(false, stretch));
                assert_eq!(wide.3 > 0, stretch.is_some(), "bonds broken: {}", wide.3);
            }
        });
    }

    #[test]
    fn grouped_force_loop_sums_in_bond_order() {
        // The lanes only compute the bond terms; the sums run in bond order, so the force is
        // bitwise the plain running sum written out here (the module docs' formula).
        let (x, v, bonds, y) = perturbed_cloud(9);
        let reference = ReferenceView {
            bonds: &bonds,
            position: &x,
            volume: &v,
            bond_volume: None,
        };
        let mut m = small_material(InfluenceFunction::One);
        crate::material::set_up(&mut m, &reference, (0..x.len() as u32).collect());
        let current = CurrentView {
            position: &y,
            bond_damage: None,
            history: &crate::history::NO_HISTORY,
        };
        let mut c = vec![PointCoefficients::default(); x.len()];
        m.compute_point_coefficients(&reference, &current, &mut c);
        let mut f = vec![[0.0; 3]; x.len()];
        m.add_force_density(&reference, &current, &c, &mut f);
        for i in 0..x.len() {
            let mut sum = 0.0;
            let mut expected = [0.0; 3];
            for b in bonds.range(i) {
                let j = bonds.neighbor[b] as usize;
                let d = [0, 1, 2].map(|k| y[j][k] - y[i][k]);
                let zeta = bonds.reference_length[b];
                let length = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                // ω = 1 and 1 − d = 1: the kernels' factors of 1 are exact, so left out here.
                sum += zeta * (length - zeta) * v[j];
                let t = (c[i].isotropic + c[j].isotropic) * zeta
                    + (c[i].deviatoric + c[j].deviatoric) * (length - zeta);
                let scale = t * v[j] / length;
                for k in 0..3 {
                    expected[k] += scale * d[k];
                }
            }
            let m_i = m.weighted_volume()[i];
            if m_i > 0.0 {
                assert_eq!(c[i].dilatation, 3.0 * sum / m_i, "θ of point {i}");
            }
            assert_eq!(f[i], expected, "force of point {i}");
        }
    }

    #[test]
    fn the_shear_correction_gives_the_shear_modulus_and_keeps_the_bulk_response() {
        // 7³ lattice, δ = 2.2, parabolic ω: the centre's family is the lattice cut by the
        // sphere, whose weighted sums differ from the integrals behind α = 15μ/m. Pure shear
        // ε_xy = γ about the centre has θ = 0 (n_x n_y is odd) and the energy (α/2)‖e^d‖²,
        // which is the continuum's μ ε:ε = 2μγ² only with the correction (module docs of
        // `shear_correction`). An isotropic expansion has e^d = 0, so its energy Kθ²/2 does
        // not depend on the correction.
        let n = 7;
        let x = crate::model::test_support::lattice(n);
        let mut points = crate::model::PointCloud::default();
        for p in &x {
            points.push(*p, 1.0, 0);
        }
        let bonds = brute_force_bonds(&x, 2.2);
        let reference = ReferenceView::of(&bonds, &points);
        let center = (n * n + n + 1) * (n / 2);
        let energy = |corrected: bool, y: &[[f64; 3]]| {
            let mut material = LinearPeridynamicSolid::new(
                &crate::material::BlockInput {
                    density: 1.0,
                    horizon: 2.2,
                    influence: InfluenceFunction::ParabolicDecay,
                },
                &crate::material::ElasticConstants {
                    bulk_modulus: 3.0,
                    shear_modulus: 1.3,
                },
            )
            .unwrap()
            .with_shear_correction(corrected);
            crate::material::set_up(&mut material, &reference, (0..x.len() as u32).collect());
            let current = CurrentView {
                position: y,
                bond_damage: None,
                history: &crate::history::NO_HISTORY,
            };
            let mut coefficients = vec![PointCoefficients::default(); x.len()];
            material.compute_point_coefficients(&reference, &current, &mut coefficients);
            let mut w = vec![0.0; x.len()];
            material.stored_energy_density(&reference, &current, &coefficients, &mut w);
            w[center]
        };
        let gamma = 1e-7;
        let c = x[center];
        let shear: Vec<[f64; 3]> = x
            .iter()
            .map(|p| {
                [
                    p[0] + gamma * (p[1] - c[1]),
                    p[1] + gamma * (p[0] - c[0]),
                    p[2],
                ]
            })
            .collect();
        let continuum = 2.0 * 1.3 * gamma * gamma;
        let without = energy(false, &shear) / continuum;
        assert!(
            (without - 1.0).abs() > 1e-3,
            "nothing to correct: {without}"
        );
        let with = energy(true, &shear) / continuum;
        assert!(
            (with - 1.0).abs() < 1e-5,
            "corrected {with}, uncorrected {without}"
        );
        let expansion: Vec<[f64; 3]> = x.iter().map(|p| p.map(|v| v * 1.001)).collect();
        let (plain, corrected) = (energy(false, &expansion), energy(true, &expansion));
        assert!(
            (corrected / plain - 1.0).abs() < 1e-12,
            "{corrected} vs {plain}"
        );
    }

    #[test]
    fn partial_stress_of_an_isotropic_expansion_is_three_k_epsilon_in_the_bulk() {
        // Y = (1 + ε) X: every bond keeps its direction and e = εζ exactly, so θ = 3ε,
        // e^d = 0 and t = (9Kε/m) ω ζ (module docs). Then Σ_j t M ⊗ ξ V_j =
        // (9Kε/m) Σ_j ω ξ⊗ξ V_j, and a family with the lattice's cubic symmetry and equal
        // volumes has Σ_j ω ξ⊗ξ V_j = (m/3) I: the partial stress is 3Kε I to round-off
        // (the classical pressure of the expansion), at every point with a full family.
        let x = crate::model::test_support::lattice(6);
        let mut points = crate::model::PointCloud::default();
        for p in &x {
            points.push(*p, 1.0, 0);
        }
        let bonds = brute_force_bonds(&x, 1.6);
        let reference = ReferenceView::of(&bonds, &points);
        let mut material = small_material(InfluenceFunction::ParabolicDecay);
        crate::material::set_up(&mut material, &reference, (0..x.len() as u32).collect());
        let epsilon = 1e-3;
        let y: Vec<[f64; 3]> = x.iter().map(|p| p.map(|c| c * (1.0 + epsilon))).collect();
        let current = CurrentView {
            position: &y,
            bond_damage: None,
            history: &crate::history::NO_HISTORY,
        };
        let mut stress = vec![[f64::NAN; 9]; x.len()];
        material.partial_stress(&reference, &current, &mut stress);
        let full = (0..x.len()).map(|i| bonds.family_size(i)).max().unwrap();
        let expected = 3.0 * 3.0 * epsilon;
        let mut checked = 0;
        for (i, s) in stress.iter().enumerate() {
            assert!(s.iter().all(|v| v.is_finite()), "point {i}");
            if bonds.family_size(i) < full {
                continue;
            }
            checked += 1;
            for r in 0..3 {
                for c in 0..3 {
                    let value = if r == c { expected } else { 0.0 };
                    assert!((s[3 * r + c] - value).abs() < 1e-13, "point {i}: {s:?}");
                }
            }
        }
        assert!(checked > 0);
    }

    #[test]
    fn a_row_whose_neighbour_lies_beyond_the_gathered_arrays_is_refused() {
        // The bond loops index the per-point arrays without a check per bond; checked_row is
        // what makes that sound, so a neighbour index at or past the bound must stop it.
        // Two points bonded to each other: row 0 is bond 0 (to point 1), row 1 is bond 1.
        let bonds = crate::model::BondList {
            offsets: vec![0, 1, 2],
            neighbor: vec![1, 0],
            reference_length: vec![1.5, 1.5],
        };
        let (neighbors, lengths) = checked_row(&bonds, 0..1, 2);
        assert_eq!((neighbors, lengths), (&[1][..], &[1.5][..]));
        // Arrays of one point: point 0's neighbour 1 is out of them.
        let refused = std::panic::catch_unwind(|| checked_row(&bonds, 0..1, 1).0.len());
        assert!(refused.is_err());
        assert_eq!(checked_row(&bonds, 1..2, 1).0, &[0][..]);
        // An empty row needs no neighbour in range.
        assert!(checked_row(&bonds, 1..1, 0).0.is_empty());
    }
}
