//! Proportional microplastic bond-based material, peridyn's `Microplastic Bond Based` (Peridigm
//! has no such model).
//!
//! R. W. Macek and S. A. Silling, "Peridynamics via finite element analysis", Finite Elements in
//! Analysis and Design 43 (2007), eqs. 19–21 and Fig. 2: the PMB spring of `Elastic Bond Based`
//! with a permanent set per bond. With the bond stretch `s = (|Y| − ζ)/ζ` and the permanent
//! stretch s̄ of the bond, the pair force density is
//!
//! `f = c (1−d) (s − s̄) M`, `M = (Y_j − Y_i)/|Y_j − Y_i|`,
//!
//! c the PMB micromodulus (18K/(πδ⁴) in 3D, 12K/(π h δ³) with `Plane Strain`/`Plane Stress`
//! and `Height` h: the constants and their validation are `Elastic Bond Based`'s), and s̄ evolves
//! elastic–perfectly-plastically with the yield stretch s_Y (`Yield Stretch`), in tension and in
//! compression alike (eq. 21): s̄(0) = 0 and `ds̄/dt = ds/dt` while the bond is on its yield
//! surface `|s − s̄| = s_Y` and is loaded further, `ds̄/dt = 0` otherwise, so that
//! `−c s_Y ≤ f ≤ c s_Y` always. (The text of eq. 21 as printed states the two cases the other
//! way round; the bound it derives from them and Fig. 2 fix the meaning used here.) Over a step
//! from the committed s̄_n to the stretch s this is the return map
//!
//! `s̄ = s − s_Y` if `s − s̄_n > s_Y`, `s̄ = s + s_Y` if `s − s̄_n < −s_Y`, else `s̄ = s̄_n`.
//!
//! The paper's eq. 50 relates s_Y to a measured ultimate tensile stress: `s_Y ≈ σ_ut/(2E)`.
//!
//! **History.** s̄ is one number per directed bond (`Permanent_Stretch`), a staged field of the
//! run's [`History`]: each force evaluation computes its trial value from the committed one, and
//! only an accepted step (every explicit step, an accepted load step of the implicit solvers)
//! commits it. Both directions of a pair see the same stretch bits (the coordinate difference
//! only changes sign), so they carry the same s̄ and the pair force stays antisymmetric.
//!
//! **Damage.** Any damage model acts on the bond as on PMB: `Critical Stretch` tests the total
//! stretch s (eq. 24 of the paper). The separate damage pass runs (PMB's fused pair loop is
//! not used: it does not know s̄).
//!
//! **Tangent.** The derivative of the force after the return map, from the committed s̄_n: an
//! elastic bond is PMB's spring with `s − s̄` for s; a yielding bond has no axial stiffness (its
//! force is ±c s_Y) and keeps the rotation stiffness of its force. Analytic by default, or by
//! automatic or finite differences of the same force state.
//!
//! **Blocks.** Every bond of a block's points must stay inside the block (a bond to another
//! model would be evaluated by that model without s̄); a mesh that bonds it to another block is
//! refused at set-up.

use super::bond_based::PMB_KEYS;
use super::keys::{PROBE_LENGTH, TANGENT};
use super::{
    BlockData, BlockInput, BondBasedParameters, CurrentView, Damaged, Integrity, Material,
    MaterialError, MaterialKeys, MaterialModel, MaterialParameters, MaterialTangent,
    PointCoefficients, ReferenceView, Undamaged,
};
use crate::history::History;
use crate::model::point_chunks::for_each_chunk;
use crate::model::{
    BondList, FieldCarrier, FieldDeclaration, KeyDoc, ModelDeclaration, Reach, TangentSupport,
};
use crate::parameter_list::error::DeckError;
use crate::parameter_list::reader::{Ctx, ListReader};
use crate::tangent::{
    assemble, BlockTangent, ForceState, OrdinaryBond, PointIndex, Scalar, TangentError,
    TangentMethod,
};

/// The staged field of the model.
pub mod fields {
    /// s̄, the permanent stretch of each directed bond (dimensionless).
    pub const PERMANENT_STRETCH: &str = "Permanent_Stretch";
}

/// `Yield Stretch`.
const YIELD_STRETCH: KeyDoc = KeyDoc {
    key: "Yield Stretch",
    meaning:
        "s_Y: a bond's force stays within ±c s_Y (about σ_ut/(2E), Macek & Silling 2007, eq. 50)",
    unit: "—",
    default: "required",
};

/// Deck parameters of `Microplastic Bond Based`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MicroplasticParameters {
    /// The PMB constants, as `Elastic Bond Based` reads them.
    pub pmb: BondBasedParameters,
    /// `Yield Stretch` s_Y (dimensionless, > 0).
    pub yield_stretch: f64,
}

impl MaterialParameters for MicroplasticParameters {
    fn bulk_modulus(&self) -> Option<f64> {
        Some(self.pmb.bulk_modulus)
    }

    fn planar_thickness(&self) -> Option<f64> {
        self.pmb.planar_thickness
    }
}

/// `Microplastic Bond Based` for one block (see the module docs for the formulas).
#[derive(Debug, Clone)]
pub struct MicroplasticBondBased {
    block: BlockData,
    /// c (force/length⁶ in 3D), as `Elastic Bond Based`'s.
    micromodulus: f64,
    /// s_Y (dimensionless, > 0).
    yield_stretch: f64,
}

/// The return map of one bond (module docs): the permanent stretch after a step from the
/// committed value `committed` to the stretch `stretch`, with yield stretch `yield_stretch`.
pub fn permanent_stretch(committed: f64, stretch: f64, yield_stretch: f64) -> f64 {
    let elastic = stretch - committed;
    if elastic > yield_stretch {
        stretch - yield_stretch
    } else if elastic < -yield_stretch {
        stretch + yield_stretch
    } else {
        committed
    }
}

/// The stretch `(|Y_j − Y_i| − ζ)/ζ` of a bond and its deformed length (the same operations
/// from either end).
#[inline(always)]
fn stretch_of(yi: [f64; 3], yj: [f64; 3], zeta: f64) -> (f64, f64) {
    let d = [yj[0] - yi[0], yj[1] - yi[1], yj[2] - yi[2]];
    let length = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    ((length - zeta) / zeta, length)
}

impl MaterialKeys for MicroplasticBondBased {
    type Parameters = MicroplasticParameters;

    /// `Microplastic Bond Based`: a bond's force depends on its two ends and its own permanent
    /// stretch (one hop); the staged `Permanent_Stretch` per bond.
    const DECLARATION: ModelDeclaration = ModelDeclaration {
        deck_name: "Microplastic Bond Based",
        aliases: &[],
        deck_keys: &[
            PMB_KEYS[0],
            PMB_KEYS[1],
            PMB_KEYS[2],
            PMB_KEYS[3],
            PMB_KEYS[4],
            PMB_KEYS[5],
            YIELD_STRETCH,
            TANGENT,
            PROBE_LENGTH,
        ],
        reach: Reach::OneHop,
        fields: &[FieldDeclaration {
            name: fields::PERMANENT_STRETCH,
            carrier: FieldCarrier::Bond,
            bytes_per_value: 8,
            staged: true,
        }],
        outputs: &[],
        tangent: TangentSupport::Analytic,
        thermal_strain: false,
        small_displacement: false,
        example: "Density: 2.0\nBulk Modulus: 3.0\nYield Stretch: 0.01",
    };

    fn read(ctx: &mut Ctx, list: &mut ListReader) -> Result<MicroplasticParameters, DeckError> {
        Ok(MicroplasticParameters {
            pmb: BondBasedParameters::read(ctx, list, Self::DECLARATION.deck_name)?,
            yield_stretch: list.positive_req(ctx, YIELD_STRETCH.key)?,
        })
    }
}

impl MaterialModel for MicroplasticBondBased {
    fn build(
        block: &BlockInput,
        parameters: &MicroplasticParameters,
    ) -> Result<Box<dyn Material>, MaterialError> {
        Ok(Box::new(Self::new(block, parameters)?))
    }
}

impl MicroplasticBondBased {
    /// Validates the parameters (those of `Elastic Bond Based`, and s_Y positive and finite).
    pub fn new(
        block: &BlockInput,
        parameters: &MicroplasticParameters,
    ) -> Result<Self, MaterialError> {
        let data = BlockData::new(
            &Self::DECLARATION,
            block.density,
            parameters.pmb.bulk_modulus,
            block.horizon,
        )?;
        Ok(Self {
            micromodulus: parameters.pmb.micromodulus(data.horizon())?,
            yield_stretch: super::positive(YIELD_STRETCH.key, parameters.yield_stretch)?,
            block: data,
        })
    }

    /// Micromodulus c (force/length⁶ in 3D), as `Elastic Bond Based`'s.
    pub fn micromodulus(&self) -> f64 {
        self.micromodulus
    }

    /// Yield stretch s_Y.
    pub fn yield_stretch(&self) -> f64 {
        self.yield_stretch
    }

    fn permanent(history: &History) -> &crate::history::Staged<f64> {
        history
            .field(fields::PERMANENT_STRETCH)
            .expect("the run allocates every field a Microplastic Bond Based block declares")
    }

    /// The force state the tangent differentiates, with the bond damage `damage`.
    fn force_state<'a, D: Integrity>(
        &'a self,
        bonds: &'a BondList,
        damage: D,
        committed: &'a [f64],
    ) -> MicroplasticForceState<'a, D> {
        MicroplasticForceState {
            bonds,
            half: 0.5 * self.micromodulus(),
            yield_stretch: self.yield_stretch,
            damage,
            committed,
        }
    }

    fn add_force<D: Integrity>(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        damage: D,
        force_density: &mut [[f64; 3]],
    ) {
        let bonds = reference.bonds;
        let y = current.position;
        let permanent = Self::permanent(current.history).trial();
        let c = self.micromodulus();
        for_each_chunk(
            self.block.force_points(),
            force_density,
            &|i| i as usize,
            &|chunk: &[u32], base: usize, out: &mut [[f64; 3]]| {
                for &i in chunk {
                    let i = i as usize;
                    let mut total = [0.0; 3];
                    for b in bonds.range(i) {
                        let j = bonds.neighbor[b] as usize;
                        let (s, length) = stretch_of(y[i], y[j], bonds.reference_length[b]);
                        if length == 0.0 {
                            continue;
                        }
                        let scale = c
                            * damage.intact(b)
                            * (s - permanent[b])
                            * reference.neighbor_volume(b, j)
                            / length;
                        for k in 0..3 {
                            total[k] += scale * (y[j][k] - y[i][k]);
                        }
                    }
                    for k in 0..3 {
                        out[i - base][k] += total[k];
                    }
                }
            },
        );
    }
}

/// The force state of one point: `T_n = (c/2)(1−d)(s − s̄) M` from its own side (the
/// neighbour's force state adds the other half), with s̄ the return map from the committed
/// permanent stretch.
struct MicroplasticForceState<'a, D> {
    bonds: &'a BondList,
    half: f64,
    yield_stretch: f64,
    damage: D,
    /// s̄_n of every bond.
    committed: &'a [f64],
}

impl<D: Integrity> ForceState for MicroplasticForceState<'_, D> {
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
            t[n] = if squared.re() > 0.0 {
                let length = squared.sqrt();
                let trial = (length - zeta) * (1.0 / zeta) - self.committed[b];
                // s − s̄ after the return map: the trial value while elastic, ±s_Y (no longer
                // depending on the motion) while yielding.
                let elastic = if trial.re() > self.yield_stretch {
                    T::from(self.yield_stretch)
                } else if trial.re() < -self.yield_stretch {
                    T::from(-self.yield_stretch)
                } else {
                    trial
                };
                let scale = elastic * (self.half * self.damage.intact(b)) / length;
                d.map(|c| c * scale)
            } else {
                [T::from(0.0); 3]
            };
        }
    }

    /// `∂T_n/∂Y_j = a (1−d) [k M⊗M/ζ + (s − s̄)/|Y| (I − M⊗M)]` with a = c/2, k = 1 for an
    /// elastic bond and 0 for a yielding one.
    fn ordinary_derivatives(&self, point: PointIndex, y: &[[f64; 3]], out: &mut [OrdinaryBond]) {
        let range = self.bonds.range(point.global);
        for ((n, b), bond) in range.enumerate().zip(out.iter_mut()) {
            let zeta = self.bonds.reference_length[b];
            let (s, length) = stretch_of(y[0], y[n + 1], zeta);
            *bond = if length > 0.0 {
                let a = self.half * self.damage.intact(b);
                let trial = s - self.committed[b];
                let yielding = trial.abs() > self.yield_stretch;
                let elastic = trial.clamp(-self.yield_stretch, self.yield_stretch);
                let d = [0, 1, 2].map(|k| y[n + 1][k] - y[0][k]);
                OrdinaryBond {
                    direction: d.map(|c| c / length),
                    axial: if yielding { 0.0 } else { a / zeta },
                    lateral: a * elastic / length,
                    coupling: 0.0,
                    weight: 0.0,
                }
            } else {
                OrdinaryBond::default()
            };
        }
    }
}

impl Material for MicroplasticBondBased {
    fn block(&self) -> &BlockData {
        &self.block
    }

    fn block_mut(&mut self) -> &mut BlockData {
        &mut self.block
    }

    fn prepare(&mut self, reference: &ReferenceView<'_>) -> Result<(), MaterialError> {
        if let Some(point) = self.block.point_bonded_outside(reference.bonds) {
            return Err(MaterialError::BondLeavesBlock {
                model: Self::DECLARATION.deck_name,
                point: point as usize,
            });
        }
        Ok(())
    }

    fn update_history(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        history: &mut History,
    ) {
        let bonds = reference.bonds;
        let y = current.position;
        let yield_stretch = self.yield_stretch;
        let (committed, trial) = history
            .field_mut(fields::PERMANENT_STRETCH)
            .expect("the run allocates every field a Microplastic Bond Based block declares")
            .committed_and_trial();
        for_each_chunk(
            self.block.points(),
            trial,
            &|i| bonds.offsets[i as usize],
            &|chunk: &[u32], base: usize, out: &mut [f64]| {
                for &i in chunk {
                    let i = i as usize;
                    for b in bonds.range(i) {
                        let j = bonds.neighbor[b] as usize;
                        let (s, _) = stretch_of(y[i], y[j], bonds.reference_length[b]);
                        out[b - base] = permanent_stretch(committed[b], s, yield_stretch);
                    }
                }
            },
        );
    }

    /// c/2 per point, as PMB publishes (no deformation-dependent coefficients).
    fn compute_point_coefficients(
        &self,
        _reference: &ReferenceView<'_>,
        _current: &CurrentView<'_>,
        coefficients: &mut [PointCoefficients],
    ) {
        let published = PointCoefficients {
            dilatation: 0.0,
            isotropic: 0.5 * self.micromodulus(),
            deviatoric: 0.0,
        };
        for &i in self.block.points() {
            coefficients[i as usize] = published;
        }
    }

    /// `F_i = Σ_j c (1−d) (s − s̄) V_j M_ij` with the trial s̄ of this evaluation.
    fn add_force_density(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        _coefficients: &[PointCoefficients],
        force_density: &mut [[f64; 3]],
    ) {
        match current.bond_damage {
            None => self.add_force(reference, current, Undamaged, force_density),
            Some(d) => self.add_force(reference, current, Damaged(d), force_density),
        }
    }

    /// `W_i = Σ_j ¼ c (1−d) (s − s̄)² ζ V_j`: the energy stored in the elastic part of each
    /// spring, half to each end (as PMB's `¼ c s² ζ`).
    fn stored_energy_density(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        _coefficients: &[PointCoefficients],
        energy_density: &mut [f64],
    ) {
        let bonds = reference.bonds;
        let y = current.position;
        let permanent = Self::permanent(current.history).trial();
        let c = self.micromodulus();
        for &i in self.block.points() {
            let i = i as usize;
            let mut w = 0.0;
            for b in bonds.range(i) {
                let j = bonds.neighbor[b] as usize;
                let zeta = bonds.reference_length[b];
                let (s, _) = stretch_of(y[i], y[j], zeta);
                let intact = current.bond_damage.map_or(1.0, |d| 1.0 - f64::from(d[b]));
                let elastic = s - permanent[b];
                w += 0.25 * c * intact * elastic * elastic * zeta * reference.neighbor_volume(b, j);
            }
            energy_density[i] = w;
        }
    }

    fn tangent(&self) -> Option<&dyn MaterialTangent> {
        Some(self)
    }
}

impl MaterialTangent for MicroplasticBondBased {
    fn add_tangent(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        method: TangentMethod,
        tangent: &mut BlockTangent,
    ) -> Result<(), TangentError> {
        let model = Self::DECLARATION.deck_name;
        let bonds = reference.bonds;
        let committed = Self::permanent(current.history).committed();
        match current.bond_damage {
            None => assemble(
                &self.force_state(bonds, Undamaged, committed),
                model,
                self.block.points(),
                reference,
                current,
                method,
                tangent,
            ),
            Some(d) => assemble(
                &self.force_state(bonds, Damaged(d), committed),
                model,
                self.block.points(),
                reference,
                current,
                method,
                tangent,
            ),
        }
    }
}

#[cfg(test)]
mod tests;
