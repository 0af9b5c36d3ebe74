//! Mitchell's ordinary state-based plasticity, Peridigm's `Elastic Plastic` material
//! (J. A. Mitchell, "A nonlocal, ordinary, state-based plasticity model for peridynamics",
//! SAND2011-3166; Peridigm's `elastic_plastic.cxx`).
//!
//! The LPS split of the extension state e = |Y| − ζ into a spherical part θζ/3 and a
//! deviatoric part e^d = e − θζ/3, with the deviatoric part split again into an elastic and a
//! plastic part, e^d = e^{de} + e^{dp}. With ω ≡ 1 (the model is defined for it; another
//! `Influence Function` is refused), per point i:
//!
//! * weighted volume `m = Σ_j ζ² V_j` (reference configuration, all bonds), α = 15μ/m;
//! * dilatation `θ = (3/m) Σ_j (1−d) ζ e V_j`;
//! * trial deviatoric force state `t^d_tr = α (e^d − e^{dp}_n)` from the plastic extension
//!   committed at the start of the step, with the norm `‖t^d_tr‖² = Σ_j (1−d)² (t^d_tr)² V_j`
//!   (damage enters the norm, as in Peridigm);
//! * yield function `f = ‖t^d_tr‖²/2 − ψ₀`, with ψ₀ from the yield stress σ_y of J2 plasticity
//!   (matching the von Mises yield surface for any homogeneous deformation of the continuum):
//!   `ψ₀ = 25 σ_y² / (8π δ⁵)` in 3-D, `ψ₀ = 75 σ_y² / (8π h δ⁴)` with `Planar Problem` and
//!   `Thickness` h;
//! * if f ≤ 0 the step is elastic: `t^d = t^d_tr`, `e^{dp}_{n+1} = e^{dp}_n`, `λ_{n+1} = λ_n`;
//!   otherwise the return to the yield surface ‖t^d‖ = √(2ψ₀) gives
//!   `Δλ = (‖t^d_tr‖/√(2ψ₀) − 1)/α`, `t^d = √(2ψ₀) t^d_tr/‖t^d_tr‖`,
//!   `e^{dp}_{n+1} = e^{dp}_n + Δλ t^d`, `λ_{n+1} = λ_n + Δλ`;
//! * scalar force state `t = (1−d)·[3Kθ/m · ζ + (1−d) t^d]`.
//!
//! Since `α (e^d − e^{dp}_{n+1}) = t^d_tr − αΔλ t^d = t^d` in both branches, the deviatoric
//! force is α times the elastic part of the deviatoric extension left after the step. The force
//! pass uses that form, `t = (1−d)·[3Kθ/m · ζ + (1−d) α (e − θζ/3 − e^{dp}_{n+1})]`, so that a
//! point reads only its neighbours' published coefficients (θ, m through
//! [`PointCoefficients`], with the LPS meaning) and the plastic extension of the reverse bond.
//! The tangent differentiates the return map itself (from the committed e^{dp}_n), by
//! automatic differentiation (Peridigm's default) or finite differences.
//!
//! `Disable Plasticity: true` makes the yield stress infinite (Peridigm sets it to the largest
//! double): the model is then the LPS with ω = 1. Peridigm computes the planar ψ₀ into a
//! variable that shadows the 3-D one and is never read, so its `Planar Problem` runs use the
//! 3-D ψ₀; here the planar value is used.
//!
//! **History.** `Deviatoric_Plastic_Extension` (per bond) and `Lambda` (per point) are staged
//! fields of the run's [`History`]: each force evaluation computes their trial values from the
//! committed ones, and only an accepted step commits them.
//!
//! **Other blocks.** A bond to a point of another model is evaluated from that point's side with
//! its published LPS coefficients and the plastic extension stored for the reverse bond (zero
//! for a model without one); the other model's own force pass does not see this block's
//! plastic extension (only an `Elastic` neighbour evaluates such bonds, exactly while this side
//! stays elastic).
//!
//! Not provided: `Thermal Expansion Coefficient`, runs on several MPI ranks (the ranks do not
//! exchange material history yet).

use rayon::prelude::*;

use super::keys::{AUTOMATIC_DIFFERENTIATION, DENSITY, ELASTIC, PROBE_LENGTH, TANGENT};
use super::{
    local_offsets, BlockData, BlockInput, CurrentView, ElasticConstants, Material, MaterialError,
    MaterialKeys, MaterialModel, MaterialOutputs, MaterialParameters, MaterialTangent,
    PointCoefficients, ReferenceView,
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

pub(super) mod hardening;
mod return_map;
#[cfg(test)]
pub(super) mod tests;

pub use hardening::ElasticPlasticHardening;
use return_map::{Kernel, PointResponse};

/// The staged fields of the model.
pub mod fields {
    /// e^{dp}, the deviatoric plastic extension of each bond (length).
    pub const DEVIATORIC_PLASTIC_EXTENSION: &str = "Deviatoric_Plastic_Extension";
    /// λ = Σ Δλ, the accumulated plastic multiplier of each point (length⁷/force; Peridigm's
    /// `Lambda`).
    pub const LAMBDA: &str = "Lambda";
}

/// A bond without a reverse bond (one-way bonds of variable horizons).
pub(super) const NO_REVERSE: usize = usize::MAX;

/// `Elastic Plastic` for one block (see the module docs for the formulas); with a hardening
/// modulus and a shear-correction factor it is `Elastic Plastic Hardening`
/// ([`ElasticPlasticHardening`]).
#[derive(Debug, Clone)]
pub struct ElasticPlastic {
    block: BlockData,
    shear_modulus: f64,
    /// ψ₀ (force²/length⁹); `None` with `Disable Plasticity`.
    yield_value: Option<f64>,
    /// H of the yield surface ψ₀ + Hλ (0: perfect plasticity, `Elastic Plastic`).
    hardening_modulus: f64,
    /// Whether `prepare` probes the shear-correction factor of every point.
    shear_correction: bool,
    /// The shear-correction factor s per block point (same order as the block's points),
    /// scaling α and ψ₀ ([`super::shear_correction`]); empty when the model applies none.
    correction: Vec<f64>,
    /// m per block point (same order as the block's points).
    weighted_volume: Vec<f64>,
    /// Block-local row starts into `reverse`.
    local_offsets: Vec<usize>,
    /// For each block bond i→j, the global index of j→i ([`NO_REVERSE`] when j has no bond
    /// to i).
    reverse: Vec<usize>,
}

/// `Yield Stress`.
pub(super) const YIELD_STRESS: KeyDoc = KeyDoc {
    key: "Yield Stress",
    meaning: "σ_y, giving the yield value ψ₀ = 25σ_y²/(8πδ⁵) (75σ_y²/(8πhδ⁴) when planar)",
    unit: "pressure",
    default: "required",
};

/// `Disable Plasticity`.
pub(super) const DISABLE_PLASTICITY: KeyDoc = KeyDoc {
    key: "Disable Plasticity",
    meaning: "an infinite yield stress: the model is then the LPS with ω = 1",
    unit: "true/false",
    default: "false",
};

/// `Planar Problem`.
const PLANAR_PROBLEM: KeyDoc = KeyDoc {
    key: "Planar Problem",
    meaning: "the planar yield value ψ₀ = 75σ_y²/(8πhδ⁴) with `Thickness` h",
    unit: "true/false",
    default: "false",
};

/// `Thickness`.
const THICKNESS: KeyDoc = KeyDoc {
    key: "Thickness",
    meaning: "thickness h of a `Planar Problem`",
    unit: "length",
    default: "required when planar",
};

/// `Apply Shear Correction Factor`, which `Elastic Plastic` accepts without effect.
const SHEAR_CORRECTION_WITHOUT_EFFECT: KeyDoc = KeyDoc {
    key: "Apply Shear Correction Factor",
    meaning: "accepted without effect: the Elastic Plastic model never applies a shear \
              correction",
    unit: "true/false",
    default: "—",
};

/// The deck parameters of the plastic state-based models besides the keys every model
/// shares.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlasticityInput {
    /// K and μ from the elastic pair.
    pub elastic: ElasticConstants,
    /// `Yield Stress` σ_y (pressure).
    pub yield_stress: f64,
    /// `Disable Plasticity`: the yield stress is infinite.
    pub disabled: bool,
    /// `Hardening Modulus` H of `Elastic Plastic Hardening` (units of ψ per unit of λ,
    /// force³/length¹⁶, as Peridigm reads it); 0 for `Elastic Plastic`.
    pub hardening_modulus: f64,
    /// `Thickness` h of an `Elastic Plastic` `Planar Problem`; `None` in 3D.
    pub planar_thickness: Option<f64>,
    /// `Apply Shear Correction Factor` (`Elastic Plastic Hardening`, default true; false for
    /// `Elastic Plastic`).
    pub shear_correction: bool,
}

impl MaterialParameters for PlasticityInput {
    fn bulk_modulus(&self) -> Option<f64> {
        Some(self.elastic.bulk_modulus)
    }

    fn planar_thickness(&self) -> Option<f64> {
        self.planar_thickness
    }
}

/// ψ₀ = 25σ_y²/(8πδ⁵) in 3-D, 75σ_y²/(8πhδ⁴) in a plane of thickness h (module docs).
pub fn yield_value(yield_stress: f64, horizon: f64, thickness: Option<f64>) -> f64 {
    use std::f64::consts::PI;
    let squared = yield_stress * yield_stress;
    match thickness {
        None => 25.0 * squared / (8.0 * PI * horizon.powi(5)),
        Some(h) => 75.0 * squared / (8.0 * PI * h * horizon.powi(4)),
    }
}

/// The fields of both plastic state-based models: m and θ per point (not staged), the staged
/// plastic extension per bond and λ per point.
const FIELDS: &[FieldDeclaration] = &[
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
    FieldDeclaration {
        name: fields::DEVIATORIC_PLASTIC_EXTENSION,
        carrier: FieldCarrier::Bond,
        bytes_per_value: 8,
        staged: true,
    },
    FieldDeclaration {
        name: fields::LAMBDA,
        carrier: FieldCarrier::Point,
        bytes_per_value: 8,
        staged: true,
    },
];

impl MaterialKeys for ElasticPlastic {
    type Parameters = PlasticityInput;

    /// `Elastic Plastic`: state-based (two hops), keeps m and θ per point (not staged) and the
    /// staged plastic extension per bond and λ per point.
    const DECLARATION: ModelDeclaration = ModelDeclaration {
        deck_name: "Elastic Plastic",
        aliases: &[],
        deck_keys: &[
            DENSITY,
            ELASTIC[0],
            ELASTIC[1],
            ELASTIC[2],
            ELASTIC[3],
            YIELD_STRESS,
            DISABLE_PLASTICITY,
            PLANAR_PROBLEM,
            THICKNESS,
            TANGENT,
            AUTOMATIC_DIFFERENTIATION,
            PROBE_LENGTH,
            SHEAR_CORRECTION_WITHOUT_EFFECT,
        ],
        reach: Reach::TwoHop,
        fields: FIELDS,
        outputs: &["Weighted_Volume", "Dilatation", "Lambda"],
        tangent: TangentSupport::Differentiated,
        thermal_strain: false,
        small_displacement: false,
        example: "Density: 2.0\nBulk Modulus: 3.0\nShear Modulus: 1.0\nYield Stress: 0.001",
    };

    fn read(ctx: &mut Ctx, list: &mut ListReader) -> Result<PlasticityInput, DeckError> {
        let elastic = super::elastic_constants::read(ctx, list)?;
        list.without_effect(
            SHEAR_CORRECTION_WITHOUT_EFFECT.key,
            "the Elastic Plastic model never applies a shear correction",
        );
        let yield_stress = list.positive_req(ctx, YIELD_STRESS.key)?;
        let planar = list.bool_or(ctx, PLANAR_PROBLEM.key, false)?;
        let disabled = list.bool_or(ctx, DISABLE_PLASTICITY.key, false)?;
        Ok(PlasticityInput {
            elastic,
            yield_stress,
            disabled,
            hardening_modulus: 0.0,
            planar_thickness: if planar {
                Some(list.positive_req(ctx, THICKNESS.key)?)
            } else {
                None
            },
            shear_correction: false,
        })
    }
}

impl MaterialModel for ElasticPlastic {
    fn build(
        block: &BlockInput,
        parameters: &PlasticityInput,
    ) -> Result<Box<dyn Material>, MaterialError> {
        Ok(Box::new(Self::of_model(
            &Self::DECLARATION,
            block,
            parameters,
        )?))
    }
}

impl ElasticPlastic {
    /// The model `declaration` names (`Elastic Plastic`, or `Elastic Plastic Hardening` with
    /// its hardening modulus and shear correction), validated: ρ, K, μ, δ, σ_y and the
    /// thickness positive and finite, H finite and ≥ 0, ω `One`.
    pub(super) fn of_model(
        declaration: &'static ModelDeclaration,
        block: &BlockInput,
        plasticity: &PlasticityInput,
    ) -> Result<Self, MaterialError> {
        if !block.influence.is_one() {
            return Err(MaterialError::InfluenceNotSupported {
                model: declaration.deck_name,
            });
        }
        let yield_stress = super::positive(YIELD_STRESS.key, plasticity.yield_stress)?;
        let horizon = super::positive("Horizon", block.horizon)?;
        let thickness = plasticity
            .planar_thickness
            .map(|h| super::positive(THICKNESS.key, h))
            .transpose()?;
        let hardening_modulus = plasticity.hardening_modulus;
        if !(hardening_modulus.is_finite() && hardening_modulus >= 0.0) {
            return Err(MaterialError::NotNonNegative {
                key: "Hardening Modulus",
                value: hardening_modulus,
            });
        }
        let data = BlockData::new(
            declaration,
            block.density,
            plasticity.elastic.bulk_modulus,
            horizon,
        )?;
        Ok(Self {
            block: data,
            shear_modulus: super::positive("Shear Modulus", plasticity.elastic.shear_modulus)?,
            yield_value: (!plasticity.disabled)
                .then(|| yield_value(yield_stress, horizon, thickness)),
            hardening_modulus,
            shear_correction: plasticity.shear_correction,
            correction: Vec::new(),
            weighted_volume: Vec::new(),
            local_offsets: vec![0],
            reverse: Vec::new(),
        })
    }

    fn kernel<'a>(
        &'a self,
        reference: &ReferenceView<'a>,
        damage: Option<&'a [f32]>,
        lambda: &'a [f64],
    ) -> Kernel<'a> {
        Kernel {
            bonds: reference.bonds,
            volume: reference.bond_volumes(),
            damage,
            weighted_volume: &self.weighted_volume,
            bulk_modulus: self.block.bulk_modulus(),
            shear_modulus: self.shear_modulus,
            yield_value: self.yield_value,
            hardening_modulus: self.hardening_modulus,
            correction: &self.correction,
            lambda,
        }
    }

    /// The committed and trial values of a field the run allocates for this model.
    fn staged<'h>(history: &'h mut History, name: &str) -> (&'h [f64], &'h mut [f64]) {
        history
            .field_mut(name)
            .expect("the run allocates every field an Elastic Plastic block declares")
            .committed_and_trial()
    }
}

impl Material for ElasticPlastic {
    fn block(&self) -> &BlockData {
        &self.block
    }

    fn block_mut(&mut self) -> &mut BlockData {
        &mut self.block
    }

    fn prepare(&mut self, reference: &ReferenceView<'_>) -> Result<(), MaterialError> {
        let bonds = reference.bonds;
        let points = self.block.points();
        self.weighted_volume = unit_weighted_volumes(reference, points);
        self.local_offsets = local_offsets(bonds, points);
        self.reverse = reverse_bonds(bonds, points);
        self.correction = if self.shear_correction {
            super::shear_correction::factors(reference, points, &self.weighted_volume, None)
        } else {
            Vec::new()
        };
        Ok(())
    }

    fn update_history(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        history: &mut History,
    ) {
        // λ_n is read while the plastic extension is written: a copy, needed only to harden.
        let lambda = if self.hardening_modulus > 0.0 {
            Self::staged(history, fields::LAMBDA).0.to_vec()
        } else {
            Vec::new()
        };
        let kernel = self.kernel(reference, current.bond_damage, &lambda);
        let bonds = reference.bonds;
        let (committed, trial) = Self::staged(history, fields::DEVIATORIC_PLASTIC_EXTENSION);
        let responses: Vec<Option<PointResponse<f64>>> = self
            .block
            .points()
            .par_iter()
            .enumerate()
            .map_init(Vec::new, |y, (local, &p)| {
                let point = PointIndex {
                    global: p as usize,
                    local,
                };
                let alpha = kernel.alpha(point)?;
                family_positions(bonds, current.position, point.global, y);
                Some(kernel.respond(point, y, alpha, &committed[bonds.range(point.global)]))
            })
            .collect();
        for_each_chunk(
            self.block.points(),
            trial,
            &|i| bonds.offsets[i as usize],
            &|chunk: &[u32], base: usize, out: &mut [f64]| {
                let mut y = Vec::new();
                let first = self.block.points().partition_point(|&p| p < chunk[0]);
                for (local, &p) in (first..).zip(chunk) {
                    let point = PointIndex {
                        global: p as usize,
                        local,
                    };
                    let range = bonds.range(point.global);
                    let start = &committed[range.clone()];
                    let row = &mut out[range.start - base..range.end - base];
                    let (Some(response), Some(alpha)) = (responses[local], kernel.alpha(point))
                    else {
                        row.copy_from_slice(start);
                        continue;
                    };
                    if response.delta_lambda == 0.0 {
                        row.copy_from_slice(start);
                        continue;
                    }
                    family_positions(bonds, current.position, point.global, &mut y);
                    for (n, b) in range.enumerate() {
                        let zeta = bonds.reference_length[b];
                        let deviatoric = Kernel::trial_deviatoric(
                            alpha,
                            &kernel.stretch(&y, n, b),
                            response.dilatation,
                            zeta,
                            start[n],
                        ) * response.scale;
                        row[n] = start[n] + response.delta_lambda * deviatoric;
                    }
                }
            },
        );
        let (committed, trial) = Self::staged(history, fields::LAMBDA);
        for (&p, response) in self.block.points().iter().zip(&responses) {
            let p = p as usize;
            trial[p] = committed[p] + response.map_or(0.0, |r| r.delta_lambda);
        }
    }

    fn compute_point_coefficients(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        coefficients: &mut [PointCoefficients],
    ) {
        let kernel = self.kernel(reference, current.bond_damage, &[]);
        let bonds = reference.bonds;
        for_each_chunk(
            self.block.points(),
            coefficients,
            &|i| i as usize,
            &|chunk: &[u32], base: usize, out: &mut [PointCoefficients]| {
                let mut y = Vec::new();
                let first = self.block.points().partition_point(|&p| p < chunk[0]);
                for (local, &p) in (first..).zip(chunk) {
                    let point = PointIndex {
                        global: p as usize,
                        local,
                    };
                    let m = self.weighted_volume[local];
                    out[point.global - base] = if m > 0.0 {
                        family_positions(bonds, current.position, point.global, &mut y);
                        let theta = kernel.dilatation(point, &y);
                        match self.correction.get(local) {
                            None => PointCoefficients {
                                dilatation: theta,
                                isotropic: (3.0 * self.block.bulk_modulus()
                                    - 5.0 * self.shear_modulus)
                                    * theta
                                    / m,
                                deviatoric: 15.0 * self.shear_modulus / m,
                            },
                            // A + Bθ/3 = 3Kθ/m with B = α = s·15μ/m.
                            Some(&s) => {
                                let alpha = s * (15.0 * self.shear_modulus / m);
                                PointCoefficients {
                                    dilatation: theta,
                                    isotropic: 3.0 * self.block.bulk_modulus() * theta / m
                                        - alpha * theta / 3.0,
                                    deviatoric: alpha,
                                }
                            }
                        }
                    } else {
                        PointCoefficients::default()
                    };
                }
            },
        );
    }

    /// `F_i = Σ_j (t_ij + t_ji) V_j M_ij` with, from either end with its coefficients A
    /// (isotropic), B = α (deviatoric) and θ, `t = (1−d)[(A + Bθ/3) ζ + (1−d) B (e − θζ/3 −
    /// e^{dp}_{n+1})]` (module docs; A + Bθ/3 = 3Kθ/m).
    fn add_force_density(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        coefficients: &[PointCoefficients],
        force_density: &mut [[f64; 3]],
    ) {
        let bonds = reference.bonds;
        let plastic = current
            .history
            .field(fields::DEVIATORIC_PLASTIC_EXTENSION)
            .expect("the run allocates every field an Elastic Plastic block declares")
            .trial();
        let kernel = self.kernel(reference, current.bond_damage, &[]);
        let y = current.position;
        let force_points = self.block.force_points();
        let scalar =
            |c: &PointCoefficients, zeta: f64, extension: f64, intact: f64, plastic: f64| {
                let deviatoric = extension - c.dilatation * zeta / 3.0 - plastic;
                intact
                    * ((c.isotropic + c.deviatoric * c.dilatation / 3.0) * zeta
                        + intact * c.deviatoric * deviatoric)
            };
        for_each_chunk(
            force_points,
            force_density,
            &|i| i as usize,
            &|chunk: &[u32], base: usize, out: &mut [[f64; 3]]| {
                for &i in chunk {
                    let i = i as usize;
                    let local =
                        self.local_offsets[self.block.points().partition_point(|&p| p < i as u32)];
                    let mut total = [0.0; 3];
                    for (n, b) in bonds.range(i).enumerate() {
                        let j = bonds.neighbor[b] as usize;
                        let d = [0, 1, 2].map(|k| y[j][k] - y[i][k]);
                        let length = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                        if length == 0.0 {
                            continue;
                        }
                        let zeta = bonds.reference_length[b];
                        let extension = length - zeta;
                        let intact = kernel.intact(b);
                        let back = self.reverse[local + n];
                        let plastic_back = if back == NO_REVERSE {
                            0.0
                        } else {
                            plastic[back]
                        };
                        let t = scalar(&coefficients[i], zeta, extension, intact, plastic[b])
                            + scalar(&coefficients[j], zeta, extension, intact, plastic_back);
                        let scale = t * reference.neighbor_volume(b, j) / length;
                        for k in 0..3 {
                            total[k] += scale * d[k];
                        }
                    }
                    for k in 0..3 {
                        out[i - base][k] += total[k];
                    }
                }
            },
        );
    }

    /// W = kθ²/2 + (α/2) Σ_j (1−d) (e^d − e^{dp})² V_j: the LPS energy of the elastic part of
    /// the deviatoric extension (Mitchell 2011, eq. for the elastic free energy), with the
    /// plastic extension of the last force evaluation.
    fn stored_energy_density(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        coefficients: &[PointCoefficients],
        energy_density: &mut [f64],
    ) {
        let bonds = reference.bonds;
        let plastic = current
            .history
            .field(fields::DEVIATORIC_PLASTIC_EXTENSION)
            .expect("the run allocates every field an Elastic Plastic block declares")
            .trial();
        let kernel = self.kernel(reference, current.bond_damage, &[]);
        let y = current.position;
        for &i in self.block.points() {
            let i = i as usize;
            let c = &coefficients[i];
            let mut sum = 0.0;
            for b in bonds.range(i) {
                let j = bonds.neighbor[b] as usize;
                let d = [0, 1, 2].map(|k| y[j][k] - y[i][k]);
                let length = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                let zeta = bonds.reference_length[b];
                let elastic = length - zeta - c.dilatation * zeta / 3.0 - plastic[b];
                sum += kernel.intact(b) * elastic * elastic * reference.neighbor_volume(b, j);
            }
            energy_density[i] = 0.5 * self.block.bulk_modulus() * c.dilatation * c.dilatation
                + 0.5 * c.deviatoric * sum;
        }
    }

    fn tangent(&self) -> Option<&dyn MaterialTangent> {
        Some(self)
    }

    fn outputs(&self) -> Option<&dyn MaterialOutputs> {
        Some(self)
    }
}

impl MaterialTangent for ElasticPlastic {
    fn add_tangent(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        method: TangentMethod,
        tangent: &mut BlockTangent,
    ) -> Result<(), TangentError> {
        let lambda = current
            .history
            .field(fields::LAMBDA)
            .expect("the run allocates every field an Elastic Plastic block declares")
            .committed();
        let kernel = ElasticPlasticForceState {
            kernel: self.kernel(reference, current.bond_damage, lambda),
            committed: current
                .history
                .field(fields::DEVIATORIC_PLASTIC_EXTENSION)
                .expect("the run allocates every field an Elastic Plastic block declares")
                .committed(),
        };
        assemble(
            &kernel,
            self.block.declaration().deck_name,
            self.block.points(),
            reference,
            current,
            method,
            tangent,
        )
    }
}

impl MaterialOutputs for ElasticPlastic {
    fn weighted_volume(&self) -> Option<&[f64]> {
        Some(&self.weighted_volume)
    }
}

/// The weighted volume m_i = Σ_j ζ_ij² V_j of each of `points` with ω ≡ 1 (reference
/// configuration, no damage), the m of the models that fix ω = 1 as Peridigm's
/// `Elastic Plastic` and `Viscoelastic` do.
pub(super) fn unit_weighted_volumes(reference: &ReferenceView<'_>, points: &[u32]) -> Vec<f64> {
    let bonds = reference.bonds;
    points
        .iter()
        .map(|&i| {
            bonds
                .range(i as usize)
                .map(|b| {
                    let zeta = bonds.reference_length[b];
                    zeta * zeta * reference.neighbor_volume(b, bonds.neighbor[b] as usize)
                })
                .sum()
        })
        .collect()
}

/// For each bond i→j of the rows of `points` (block-local order), the global index of j→i
/// ([`NO_REVERSE`] when j has no bond to i).
pub(super) fn reverse_bonds(bonds: &BondList, points: &[u32]) -> Vec<usize> {
    // Rows are sorted, so the reverse bond is found by binary search.
    points
        .iter()
        .flat_map(|&i| {
            bonds.family(i as usize).iter().map(move |&j| {
                bonds
                    .family(j as usize)
                    .binary_search(&i)
                    .map_or(NO_REVERSE, |k| bonds.offsets[j as usize] + k)
            })
        })
        .collect()
}

/// The positions of point `p`'s family into `y` (`y[0]` the point).
pub(super) fn family_positions(
    bonds: &BondList,
    position: &[[f64; 3]],
    p: usize,
    y: &mut Vec<[f64; 3]>,
) {
    y.clear();
    y.push(position[p]);
    y.extend(bonds.family(p).iter().map(|&j| position[j as usize]));
}

/// The force state of a point for the tangent: the return map from the committed plastic
/// extension and `t = (1−d)[3Kθ/m · ζ + (1−d) t^d]`, generic over the scalar.
struct ElasticPlasticForceState<'a> {
    kernel: Kernel<'a>,
    /// e^{dp}_n of every bond.
    committed: &'a [f64],
}

impl ForceState for ElasticPlasticForceState<'_> {
    const BOND_LOCAL: bool = false;
    const ANALYTIC: bool = false;

    fn force_state<T: Scalar>(
        &self,
        point: PointIndex,
        y: &[[T; 3]],
        _only: Option<usize>,
        t: &mut [[T; 3]],
    ) {
        let kernel = &self.kernel;
        let zero = T::from(0.0);
        let Some(alpha) = kernel.alpha(point) else {
            t.fill([zero; 3]);
            return;
        };
        let range = kernel.bonds.range(point.global);
        let plastic = &self.committed[range.clone()];
        let response = kernel.respond(point, y, alpha, plastic);
        let pressure =
            response.dilatation * (3.0 * kernel.bulk_modulus / kernel.weighted_volume[point.local]);
        for (n, b) in range.enumerate() {
            let stretch = kernel.stretch(y, n, b);
            t[n] = if stretch.length.re() > 0.0 {
                let zeta = kernel.bonds.reference_length[b];
                let intact = kernel.intact(b);
                let deviatoric = Kernel::trial_deviatoric(
                    alpha,
                    &stretch,
                    response.dilatation,
                    zeta,
                    plastic[n],
                ) * response.scale;
                let scalar = (pressure * zeta + deviatoric * intact) * intact;
                let scale = scalar / stretch.length;
                [0, 1, 2].map(|k| (y[n + 1][k] - y[0][k]) * scale)
            } else {
                [zero; 3]
            };
        }
    }

    fn ordinary_derivatives(&self, _point: PointIndex, _y: &[[f64; 3]], _out: &mut [OrdinaryBond]) {
        unreachable!("Elastic Plastic has no closed-form tangent (ANALYTIC is false)")
    }
}
