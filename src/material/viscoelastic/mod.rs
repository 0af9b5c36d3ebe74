//! Peridigm's `Viscoelastic` material: Mitchell's standard linear solid on the deviatoric
//! extension of the LPS (Peridigm's `viscoelastic.cxx`), ω ≡ 1.
//!
//! The deviatoric response is a spring α(1 − λ_i) in parallel with a Maxwell element (spring
//! αλ_i, dashpot of relaxation time τ_b), α = 15μ/m. The Maxwell element carries the *back
//! extension* e^b, the part of the deviatoric extension its dashpot has absorbed, which obeys
//!
//! `τ_b ė^b + e^b = e^d`.
//!
//! Per point i, with the LPS dilatation θ = (3/m) Σ_j (1−d) ζ e V_j, m = Σ_j ζ² V_j:
//!
//! * deviatoric extension `e^d = (1−d) e − θζ/3` (Peridigm applies damage inside e^d);
//! * back extension over a step Δt, exact for e^d linear in time across the step:
//!   `e^b_{n+1} = e^d_n (1 − decay) + e^b_n decay + β (e^d_{n+1} − e^d_n)` with
//!   `c₁ = τ_b/Δt`, `decay = exp(−1/c₁)`, `β = 1 − c₁(1 − decay)`; Δt = 0 (no time passes)
//!   leaves e^b unchanged (the limit β → 0, decay → 1);
//! * deviatoric force `t^d = (1 − λ_i) α e^d + λ_i α (e^d − e^b_{n+1}) = α (e^d − λ_i e^b_{n+1})`;
//! * scalar force state `t = (1−d)(3Kθ/m · ζ + t^d)`.
//!
//! For a step strain e^d = E held from t = 0⁺ the ODE gives e^b = E(1 − exp(−t/τ_b)), so the
//! deviatoric force relaxes from αE to (1 − λ_i)αE as `αE(1 − λ_i(1 − exp(−t/τ_b)))`. λ_i = 0
//! is the LPS with ω = 1.
//!
//! **History.** `Deviatoric_Back_Extension` e^b and `Deviatoric_Extension` e^d (per bond) are
//! staged: each force evaluation computes their trial values from the committed ones of the
//! step's start, and only an accepted step commits them. e^d_n is the deviatoric extension of
//! the last accepted step with the damage of that step (Peridigm recomputes it from the previous
//! positions with the current damage; the two agree while no bond breaks in the step).
//! `Viscoelastic_Fraction` (per point) holds λ_i of the viscoelastic points (0 elsewhere), so
//! that a bond between two `Viscoelastic` blocks is evaluated from each side with that side's
//! λ_i and back extension.
//!
//! **Tangent.** The automatic-differentiation derivative of the force at the committed history
//! (e^b_{n+1} depends on the positions through β e^d_{n+1}, so the step's Δt enters);
//! Peridigm uses finite differences (and refuses `Apply Automatic Differentiation Jacobian`,
//! which the deck layer refuses too). A point of another model evaluates a bond to this block
//! from its own side with its own formula (without back extension).
//!
//! Not provided, as in Peridigm: shear correction and thermal expansion (the deck layer
//! refuses both keys). Not provided either: runs on several MPI ranks (the ranks do not
//! exchange material history yet).

use rayon::prelude::*;

use super::elastic_plastic::{family_positions, reverse_bonds, unit_weighted_volumes, NO_REVERSE};
use super::keys::{refuse, DENSITY, ELASTIC, PROBE_LENGTH, TANGENT};
use super::{
    local_offsets, BlockData, BlockInput, CurrentView, ElasticConstants, Material, MaterialError,
    MaterialKeys, MaterialModel, MaterialOutputs, MaterialParameters, MaterialTangent,
    PointCoefficients, ReferenceView,
};
use crate::history::History;
use crate::model::point_chunks::for_each_chunk;
use crate::model::{
    BondList, BondVolumes, FieldCarrier, FieldDeclaration, KeyDoc, ModelDeclaration, Reach,
    TangentSupport,
};
use crate::parameter_list::error::DeckError;
use crate::parameter_list::reader::{Ctx, ListReader};
use crate::tangent::{
    assemble, BlockTangent, ForceState, OrdinaryBond, PointIndex, Scalar, TangentError,
    TangentMethod,
};

#[cfg(test)]
mod tests;

/// The staged fields of the model.
pub mod fields {
    /// e^b, the back extension of each bond (length; Peridigm's name).
    pub const DEVIATORIC_BACK_EXTENSION: &str = "Deviatoric_Back_Extension";
    /// e^d, the deviatoric extension of each bond at the last evaluation (length).
    pub const DEVIATORIC_EXTENSION: &str = "Deviatoric_Extension";
    /// λ_i of each viscoelastic point (0 at other points; dimensionless).
    pub const FRACTION: &str = "Viscoelastic_Fraction";
}

/// `lambda_i`.
const LAMBDA_I: KeyDoc = KeyDoc {
    key: "lambda_i",
    meaning: "λ_i ∈ [0, 1], the fraction of the deviatoric stiffness that relaxes",
    unit: "—",
    default: "required",
};

/// `tau b`.
const TAU_B: KeyDoc = KeyDoc {
    key: "tau b",
    meaning: "τ_b, the relaxation time of the Maxwell element",
    unit: "time",
    default: "required",
};

/// The deck parameters of `Viscoelastic` besides the keys every model shares.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViscoelasticInput {
    /// K and μ from the elastic pair.
    pub elastic: ElasticConstants,
    /// `lambda_i` λ_i ∈ [0, 1]: the fraction of the deviatoric stiffness that relaxes.
    pub lambda_i: f64,
    /// `tau b` τ_b > 0: the relaxation time (time).
    pub tau_b: f64,
}

impl MaterialParameters for ViscoelasticInput {
    fn bulk_modulus(&self) -> Option<f64> {
        Some(self.elastic.bulk_modulus)
    }
}

/// `Viscoelastic` for one block (see the module docs for the formulas).
#[derive(Debug, Clone)]
pub struct Viscoelastic {
    block: BlockData,
    shear_modulus: f64,
    lambda_i: f64,
    tau_b: f64,
    /// m per block point (same order as the block's points).
    weighted_volume: Vec<f64>,
    /// Block-local row starts into `reverse`.
    local_offsets: Vec<usize>,
    /// For each block bond i→j, the global index of j→i ([`NO_REVERSE`] when none).
    reverse: Vec<usize>,
}

/// The decay of the back extension over one step and the weight of the step's increment
/// (module docs): `(decay, β)`; `(1, 0)` when no time passes.
fn step_weights(tau_b: f64, duration: f64) -> (f64, f64) {
    if duration <= 0.0 {
        return (1.0, 0.0);
    }
    // x = 1/c₁ = Δt/τ_b; 1 − decay = −expm1(−x) without the cancellation of 1 − exp(−x).
    let x = duration / tau_b;
    let absorbed = -(-x).exp_m1();
    (1.0 - absorbed, 1.0 - absorbed / x)
}

impl MaterialKeys for Viscoelastic {
    type Parameters = ViscoelasticInput;

    /// `Viscoelastic`: state-based (two hops); m and θ per point (not staged), the staged back
    /// and deviatoric extensions per bond and λ_i per point.
    const DECLARATION: ModelDeclaration = ModelDeclaration {
        deck_name: "Viscoelastic",
        aliases: &[],
        deck_keys: &[
            DENSITY,
            ELASTIC[0],
            ELASTIC[1],
            ELASTIC[2],
            ELASTIC[3],
            LAMBDA_I,
            TAU_B,
            TANGENT,
            PROBE_LENGTH,
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
            FieldDeclaration {
                name: fields::DEVIATORIC_BACK_EXTENSION,
                carrier: FieldCarrier::Bond,
                bytes_per_value: 8,
                staged: true,
            },
            FieldDeclaration {
                name: fields::DEVIATORIC_EXTENSION,
                carrier: FieldCarrier::Bond,
                bytes_per_value: 8,
                staged: true,
            },
            FieldDeclaration {
                name: fields::FRACTION,
                carrier: FieldCarrier::Point,
                bytes_per_value: 8,
                staged: true,
            },
        ],
        outputs: &["Weighted_Volume", "Dilatation"],
        tangent: TangentSupport::Differentiated,
        thermal_strain: false,
        small_displacement: false,
        example: "Density: 2.0\nBulk Modulus: 3.0\nShear Modulus: 1.0\nlambda_i: 0.5\ntau b: 0.5",
    };

    fn read(ctx: &mut Ctx, list: &mut ListReader) -> Result<ViscoelasticInput, DeckError> {
        let model = Self::DECLARATION.deck_name;
        let elastic = super::elastic_constants::read(ctx, list)?;
        for key in [
            "Apply Automatic Differentiation Jacobian",
            "Apply Shear Correction Factor",
        ] {
            refuse(ctx, list, model, key)?;
        }
        let f = list.require(ctx, LAMBDA_I.key, "a number in [0, 1]")?;
        let lambda_i = f.f64(ctx)?;
        if !(0.0..=1.0).contains(&lambda_i) {
            return Err(f.err(ctx, format!("must lie in [0, 1], found {lambda_i}")));
        }
        Ok(ViscoelasticInput {
            elastic,
            lambda_i,
            tau_b: list.positive_req(ctx, TAU_B.key)?,
        })
    }
}

impl MaterialModel for Viscoelastic {
    fn build(
        block: &BlockInput,
        parameters: &ViscoelasticInput,
    ) -> Result<Box<dyn Material>, MaterialError> {
        Ok(Box::new(Self::new(block, parameters)?))
    }
}

impl Viscoelastic {
    /// Validates the parameters (ρ, K, μ, δ, τ_b positive and finite, λ_i in [0, 1], ω `One`).
    pub fn new(block: &BlockInput, parameters: &ViscoelasticInput) -> Result<Self, MaterialError> {
        if !block.influence.is_one() {
            return Err(MaterialError::InfluenceNotSupported {
                model: Self::DECLARATION.deck_name,
            });
        }
        if !(0.0..=1.0).contains(&parameters.lambda_i) {
            return Err(MaterialError::NotInUnitInterval {
                key: LAMBDA_I.key,
                value: parameters.lambda_i,
            });
        }
        let data = BlockData::new(
            &Self::DECLARATION,
            block.density,
            parameters.elastic.bulk_modulus,
            block.horizon,
        )?;
        Ok(Self {
            block: data,
            shear_modulus: super::positive("Shear Modulus", parameters.elastic.shear_modulus)?,
            lambda_i: parameters.lambda_i,
            tau_b: super::positive(TAU_B.key, parameters.tau_b)?,
            weighted_volume: Vec::new(),
            local_offsets: vec![0],
            reverse: Vec::new(),
        })
    }

    fn kernel<'a>(
        &'a self,
        reference: &ReferenceView<'a>,
        damage: Option<&'a [f32]>,
    ) -> Kernel<'a> {
        Kernel {
            bonds: reference.bonds,
            volume: reference.bond_volumes(),
            damage,
            weighted_volume: &self.weighted_volume,
        }
    }

    /// α = 15μ/m of block point `local`; `None` when m = 0 (no bonds: no force).
    fn alpha(&self, local: usize) -> Option<f64> {
        let m = self.weighted_volume[local];
        (m > 0.0).then(|| 15.0 * self.shear_modulus / m)
    }

    fn field<'h>(history: &'h History, name: &str) -> &'h crate::history::Staged<f64> {
        history
            .field(name)
            .expect("the run allocates every field a Viscoelastic block declares")
    }
}

/// What the bond loops read, over any scalar.
#[derive(Clone, Copy)]
struct Kernel<'a> {
    bonds: &'a BondList,
    volume: BondVolumes<'a>,
    damage: Option<&'a [f32]>,
    weighted_volume: &'a [f64],
}

impl Kernel<'_> {
    fn intact(&self, b: usize) -> f64 {
        self.damage.map_or(1.0, |d| 1.0 - f64::from(d[b]))
    }

    /// |Y| of the n-th bond of the family at `y` (0 for coincident points).
    fn length<T: Scalar>(y: &[[T; 3]], n: usize) -> T {
        let d = [0, 1, 2].map(|k| y[n + 1][k] - y[0][k]);
        let squared = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        // A zero length has no derivative; such a bond carries no force.
        if squared.re() > 0.0 {
            squared.sqrt()
        } else {
            T::from(0.0)
        }
    }

    /// θ = (3/m) Σ (1−d) ζ e V_j of `point` (m > 0), family at `y`.
    fn dilatation<T: Scalar>(&self, point: PointIndex, y: &[[T; 3]]) -> T {
        let mut sum = T::from(0.0);
        for (n, b) in self.bonds.range(point.global).enumerate() {
            let zeta = self.bonds.reference_length[b];
            let j = self.bonds.neighbor[b] as usize;
            sum += (Self::length(y, n) - zeta) * (self.intact(b) * zeta * self.volume.of(b, j));
        }
        sum * (3.0 / self.weighted_volume[point.local])
    }

    /// e^d = (1−d) e − θζ/3 of the n-th bond `b` of the family at `y`.
    fn deviatoric<T: Scalar>(&self, y: &[[T; 3]], n: usize, b: usize, theta: T) -> T {
        let zeta = self.bonds.reference_length[b];
        (Self::length(y, n) - zeta) * self.intact(b) - theta * (zeta / 3.0)
    }
}

impl Material for Viscoelastic {
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
        Ok(())
    }

    fn update_history(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        history: &mut History,
    ) {
        let kernel = self.kernel(reference, current.bond_damage);
        let bonds = reference.bonds;
        let (decay, beta) = step_weights(self.tau_b, history.step_duration());
        // e^d_{n+1} of every block bond first (it reads only positions and damage).
        let deviatoric: Vec<Vec<f64>> = self
            .block
            .points()
            .par_iter()
            .enumerate()
            .map_init(Vec::new, |y, (local, &p)| {
                let point = PointIndex {
                    global: p as usize,
                    local,
                };
                if self.weighted_volume[local] <= 0.0 {
                    return Vec::new();
                }
                family_positions(bonds, current.position, point.global, y);
                let theta = kernel.dilatation(point, y);
                bonds
                    .range(point.global)
                    .enumerate()
                    .map(|(n, b)| kernel.deviatoric(y, n, b, theta))
                    .collect()
            })
            .collect();
        let (old_deviatoric, new_deviatoric) = history
            .field_mut(fields::DEVIATORIC_EXTENSION)
            .expect("the run allocates every field a Viscoelastic block declares")
            .committed_and_trial();
        let old_deviatoric = old_deviatoric.to_vec();
        for (&p, row) in self.block.points().iter().zip(&deviatoric) {
            let range = bonds.range(p as usize);
            if row.is_empty() {
                new_deviatoric[range.clone()].copy_from_slice(&old_deviatoric[range]);
            } else {
                new_deviatoric[range].copy_from_slice(row);
            }
        }
        let (old_back, new_back) = history
            .field_mut(fields::DEVIATORIC_BACK_EXTENSION)
            .expect("the run allocates every field a Viscoelastic block declares")
            .committed_and_trial();
        for (&p, row) in self.block.points().iter().zip(&deviatoric) {
            for (n, b) in bonds.range(p as usize).enumerate() {
                new_back[b] = match row.get(n) {
                    Some(&now) => {
                        let before = old_deviatoric[b];
                        before * (1.0 - decay) + old_back[b] * decay + beta * (now - before)
                    }
                    None => old_back[b],
                };
            }
        }
        let (_, fraction) = history
            .field_mut(fields::FRACTION)
            .expect("the run allocates every field a Viscoelastic block declares")
            .committed_and_trial();
        for &p in self.block.points() {
            fraction[p as usize] = self.lambda_i;
        }
    }

    fn compute_point_coefficients(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        coefficients: &mut [PointCoefficients],
    ) {
        let kernel = self.kernel(reference, current.bond_damage);
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
                        PointCoefficients {
                            dilatation: theta,
                            isotropic: (3.0 * self.block.bulk_modulus() - 5.0 * self.shear_modulus)
                                * theta
                                / m,
                            deviatoric: 15.0 * self.shear_modulus / m,
                        }
                    } else {
                        PointCoefficients::default()
                    };
                }
            },
        );
    }

    /// `F_i = Σ_j (t_ij + t_ji) V_j M_ij` with, from either end with its coefficients A
    /// (isotropic), B = α (deviatoric), θ and its λ_i and back extension,
    /// `t = (1−d)[(A + Bθ/3) ζ + B((1−d) e − θζ/3 − λ_i e^b)]` (module docs; A + Bθ/3 = 3Kθ/m).
    fn add_force_density(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        coefficients: &[PointCoefficients],
        force_density: &mut [[f64; 3]],
    ) {
        let bonds = reference.bonds;
        let back = Self::field(current.history, fields::DEVIATORIC_BACK_EXTENSION).trial();
        let fraction = Self::field(current.history, fields::FRACTION).trial();
        let kernel = self.kernel(reference, current.bond_damage);
        let y = current.position;
        let force_points = self.block.force_points();
        let scalar =
            |c: &PointCoefficients, zeta: f64, extension: f64, intact: f64, relaxed: f64| {
                let deviatoric = intact * extension - c.dilatation * zeta / 3.0 - relaxed;
                intact
                    * ((c.isotropic + c.deviatoric * c.dilatation / 3.0) * zeta
                        + c.deviatoric * deviatoric)
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
                        let reverse = self.reverse[local + n];
                        let relaxed_back = if reverse == NO_REVERSE {
                            0.0
                        } else {
                            fraction[j] * back[reverse]
                        };
                        let t = scalar(
                            &coefficients[i],
                            zeta,
                            extension,
                            intact,
                            self.lambda_i * back[b],
                        ) + scalar(&coefficients[j], zeta, extension, intact, relaxed_back);
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

    /// W = kθ²/2 + (α/2) Σ_j [(1 − λ_i)(e^d)² + λ_i (e^d − e^b)²] V_j: the energy of the
    /// equilibrium spring and of the Maxwell spring, with the history of the last force
    /// evaluation.
    fn stored_energy_density(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        coefficients: &[PointCoefficients],
        energy_density: &mut [f64],
    ) {
        let bonds = reference.bonds;
        let back = Self::field(current.history, fields::DEVIATORIC_BACK_EXTENSION).trial();
        let kernel = self.kernel(reference, current.bond_damage);
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
                let deviatoric = kernel.intact(b) * (length - zeta) - c.dilatation * zeta / 3.0;
                let maxwell = deviatoric - back[b];
                sum += ((1.0 - self.lambda_i) * deviatoric * deviatoric
                    + self.lambda_i * maxwell * maxwell)
                    * reference.neighbor_volume(b, j);
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

impl MaterialTangent for Viscoelastic {
    fn add_tangent(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        method: TangentMethod,
        tangent: &mut BlockTangent,
    ) -> Result<(), TangentError> {
        let (decay, beta) = step_weights(self.tau_b, current.history.step_duration());
        let state = ViscoelasticForceState {
            material: self,
            kernel: self.kernel(reference, current.bond_damage),
            deviatoric: Self::field(current.history, fields::DEVIATORIC_EXTENSION).committed(),
            back: Self::field(current.history, fields::DEVIATORIC_BACK_EXTENSION).committed(),
            decay,
            beta,
        };
        assemble(
            &state,
            Self::DECLARATION.deck_name,
            self.block.points(),
            reference,
            current,
            method,
            tangent,
        )
    }
}

impl MaterialOutputs for Viscoelastic {
    fn weighted_volume(&self) -> Option<&[f64]> {
        Some(&self.weighted_volume)
    }
}

/// The force state of a point for the tangent, from the committed history: e^b_{n+1} as a
/// function of the positions, `t = (1−d)(3Kθ/m · ζ + α(e^d − λ_i e^b_{n+1}))`.
struct ViscoelasticForceState<'a> {
    material: &'a Viscoelastic,
    kernel: Kernel<'a>,
    /// e^d_n of every bond.
    deviatoric: &'a [f64],
    /// e^b_n of every bond.
    back: &'a [f64],
    decay: f64,
    beta: f64,
}

impl ForceState for ViscoelasticForceState<'_> {
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
        let material = self.material;
        let zero = T::from(0.0);
        let Some(alpha) = material.alpha(point.local) else {
            t.fill([zero; 3]);
            return;
        };
        let theta = kernel.dilatation(point, y);
        let pressure =
            theta * (3.0 * material.block.bulk_modulus() / kernel.weighted_volume[point.local]);
        for (n, b) in kernel.bonds.range(point.global).enumerate() {
            let length = Kernel::length(y, n);
            t[n] = if length.re() > 0.0 {
                let zeta = kernel.bonds.reference_length[b];
                let deviatoric = kernel.deviatoric(y, n, b, theta);
                let before = self.deviatoric[b];
                let back = (deviatoric - before) * self.beta
                    + (before * (1.0 - self.decay) + self.back[b] * self.decay);
                let scalar = (pressure * zeta + (deviatoric - back * material.lambda_i) * alpha)
                    * kernel.intact(b);
                let scale = scalar / length;
                [0, 1, 2].map(|k| (y[n + 1][k] - y[0][k]) * scale)
            } else {
                [zero; 3]
            };
        }
    }

    fn ordinary_derivatives(&self, _point: PointIndex, _y: &[[f64; 3]], _out: &mut [OrdinaryBond]) {
        unreachable!("Viscoelastic has no closed-form tangent (ANALYTIC is false)")
    }
}
