//! The position-aware linear solid, Peridigm's `Pals` material (J. A. Mitchell, S. A. Silling,
//! D. J. Littlewood, "A position-aware linear solid constitutive model for peridynamics",
//! J. Mech. Mater. Struct. 10(5) 539–557, 2015).
//!
//! The LPS with two influence functions per point instead of one: ω for the dilatation and σ
//! for the deviatoric part, each the deck's base function (`Dilatation Influence Function` ω₀,
//! `Deviatoric Influence Function` σ₀: `One`, `Parabolic Decay` or `Gaussian`, default `One`)
//! plus a correction fitted to the point's own family, so that a point near a free surface
//! responds to homogeneous deformations as the bulk does (no surface effect).
//!
//! **Influence functions.** For a bond ξ = (a, b, c), |ξ| = ζ, with the six strain modes
//! ε⁽¹⁾…ε⁽⁶⁾ = e_x⊗e_x, e_y⊗e_y, e_z⊗e_z, and the shears e_x⊗e_y + e_y⊗e_x, e_x⊗e_z + e_z⊗e_x,
//! e_y⊗e_z + e_z⊗e_y:
//!
//! * `ω(ξ) = ω₀(ζ) + Σ_k λ_k g_k(ξ)` with g = (a², b², c², 2ab, 2ac, 2bc) = ξ·ε⁽ᵏ⁾ξ;
//! * `σ(ξ) = σ₀(ζ) + Σ_k τ_k s_k(ξ)²` with s_k = ξ·ε⁽ᵏ⁾ξ/ζ − ζ tr ε⁽ᵏ⁾/3, the deviatoric
//!   extension of mode k: (a²/ζ − ζ/3, b²/ζ − ζ/3, c²/ζ − ζ/3, 2ab/ζ, 2ac/ζ, 2bc/ζ).
//!
//! The twelve Lagrange multipliers λ, τ of each point (Peridigm's
//! `Lagrange_Multiplier_Dilatation_1..6` and `Lagrange_Multiplier_Deviatoric_1..6`) solve two
//! 6×6 systems, once, in the reference configuration over all bonds:
//!
//! * `Σ_j ω g_k V_j = (1, 1, 1, 0, 0, 0)_k`, i.e. `Σ_j ω ξ⊗ξ V_j = I`: the dilatation of every
//!   small homogeneous strain is its trace;
//! * `Σ_j σ s_k² V_j = (2/3, 2/3, 2/3, 2, 2, 2)_k`, i.e. ε⁽ᵏ⁾_dev : ε⁽ᵏ⁾_dev: the deviatoric
//!   energy of each mode is the classical μ ε_dev : ε_dev.
//!
//! A coordinate direction the family does not span (every bond with c = 0 in a one-layer mesh)
//! has a zero diagonal in the dilatation system; its multipliers are set to zero in both
//! systems (the test is diag/trace < 1e-15, as in Peridigm).
//!
//! **Force.** With extension e = |Y| − ζ, damage d, deviatoric extension e^d = e − θζ/3:
//!
//! * dilatation `θ = Σ_j (1−d) ω ζ e V_j` (ω carries the normalization: no 3/m);
//! * `m = Σ_j (1−d) σ ζ² V_j` and the pressure
//!   `p = (K + 2μm/9) θ − (2μ/3) Σ_j (1−d) σ ζ e V_j` (Peridigm's `Pals_Pressure`);
//! * scalar force state `t = (1−d) [p ω ζ + 2μ σ e^d]`;
//! * stored energy density `W = Kθ²/2 + μ Σ_j (1−d) σ (e^d)² V_j`, of which t is the
//!   derivative with respect to e (so the tangent is symmetric).
//!
//! **Damage.** Peridigm's `Pals` ignores bond damage (its issue #87: a broken bond keeps its
//! force). Here it is honoured as above, in θ, m, the pressure sum, the force state and the
//! energy; the multipliers stay those of the intact reference family (as the LPS keeps the
//! weighted volume of all bonds). Without damage the formulas are Peridigm's.
//!
//! **Published coefficients** ([`PointCoefficients`]): dilatation θ, isotropic = p,
//! deviatoric = 2μ. A bond's force from the neighbour's side reads them with the neighbour's
//! ω and σ on the reverse bond, which this block stores; so every bond of the block must stay
//! inside it (a bond to another block is refused at set-up), and the model runs on one rank
//! (a rank's ghost families may be cut, which would change their multipliers).
//!
//! Influence normalization: Peridigm's `Dilatation_Normalization` and
//! `Deviatoric_Normalization` fields scale the corrected functions by a constant it fixes at 1;
//! they are written as 1. The global `Discretization → Influence Function` is not read (as in
//! Peridigm).
//!
//! Tangent: automatic differentiation of the force state (default) or finite differences
//! (Peridigm uses finite differences for `Pals`).

use rayon::prelude::*;

use super::keys::{AUTOMATIC_DIFFERENTIATION, DENSITY, ELASTIC, PROBE_LENGTH, TANGENT};
use super::{
    local_offsets, BlockData, BlockInput, CurrentView, ElasticConstants, InfluenceFunction,
    Material, MaterialError, MaterialKeys, MaterialModel, MaterialOutputs, MaterialParameters,
    MaterialTangent, PointCoefficients, ReferenceView,
};
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

/// Number of Lagrange multipliers per influence function (one per strain mode).
pub const MULTIPLIERS: usize = 6;

/// The right-hand side of the dilatation constraints, `Σ ω ξ⊗ξ V = I` in the mode order.
const DILATATION_TARGET: [f64; MULTIPLIERS] = [1.0, 1.0, 1.0, 0.0, 0.0, 0.0];

/// The right-hand side of the deviatoric constraints: ε_dev : ε_dev of each unit mode (2/3 for
/// a unit stretch along an axis, 2 for a unit engineering shear).
const DEVIATORIC_TARGET: [f64; MULTIPLIERS] = [2.0 / 3.0, 2.0 / 3.0, 2.0 / 3.0, 2.0, 2.0, 2.0];

/// A diagonal entry of the dilatation system this small relative to its trace marks a
/// direction the family does not span.
const DEGENERATE: f64 = 1e-15;

/// `Dilatation Influence Function`.
const DILATATION_INFLUENCE: KeyDoc = KeyDoc {
    key: "Dilatation Influence Function",
    meaning: "ω₀, the base of the dilatation's influence function: \"One\", \"Parabolic \
              Decay\" or \"Gaussian\" (the discretization's is not read)",
    unit: "a name",
    default: "One",
};

/// `Deviatoric Influence Function`.
const DEVIATORIC_INFLUENCE: KeyDoc = KeyDoc {
    key: "Deviatoric Influence Function",
    meaning: "σ₀, the base of the deviatoric influence function: \"One\", \"Parabolic \
              Decay\" or \"Gaussian\"",
    unit: "a name",
    default: "One",
};

/// The deck parameters of `Pals` besides the keys every model shares.
#[derive(Debug, Clone, PartialEq)]
pub struct PalsParameters {
    /// K and μ from the elastic pair.
    pub elastic: ElasticConstants,
    /// The two base influence functions.
    pub influence: PalsInfluence,
}

impl MaterialParameters for PalsParameters {
    fn bulk_modulus(&self) -> Option<f64> {
        Some(self.elastic.bulk_modulus)
    }
}

/// The two base influence functions of `Pals` (deck `Dilatation Influence Function`,
/// `Deviatoric Influence Function`); Peridigm's default for both is `One`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PalsInfluence {
    /// ω₀(ζ, δ) of the dilatation.
    pub dilatation: InfluenceFunction,
    /// σ₀(ζ, δ) of the deviatoric part.
    pub deviatoric: InfluenceFunction,
}

/// The multipliers of one point: λ (dilatation) and τ (deviatoric), in the mode order of the
/// module docs.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Multipliers {
    /// λ₁…λ₆ (1/length⁷, with V in length³).
    pub dilatation: [f64; MULTIPLIERS],
    /// τ₁…τ₆ (1/length⁷).
    pub deviatoric: [f64; MULTIPLIERS],
}

/// `Pals` for one block (see the module docs for the formulas).
#[derive(Debug, Clone)]
pub struct Pals {
    block: BlockData,
    shear_modulus: f64,
    influence: PalsInfluence,
    /// Per block point (same order as the block's points).
    multipliers: Vec<Multipliers>,
    /// `Σ σ ζ² V` over all bonds per block point (Peridigm's `Weighted_Volume` of `Pals`).
    weighted_volume: Vec<f64>,
    /// Block-local row starts into `omega`, `sigma` and `reverse`.
    local_offsets: Vec<usize>,
    /// ω of each block bond from its point's side.
    omega: Vec<f64>,
    /// σ of each block bond from its point's side.
    sigma: Vec<f64>,
    /// For each block bond i→j, the block-local index of j→i.
    reverse: Vec<usize>,
    /// Every point's number in the input ([`Material::input_numbering`]); empty when not
    /// given (the families are then summed in row order).
    input_id: Vec<u32>,
}

/// The output names of the twelve multipliers, dilatation first.
const MULTIPLIER_OUTPUTS: [&str; 2 * MULTIPLIERS] = [
    "Lagrange_Multiplier_Dilatation_1",
    "Lagrange_Multiplier_Dilatation_2",
    "Lagrange_Multiplier_Dilatation_3",
    "Lagrange_Multiplier_Dilatation_4",
    "Lagrange_Multiplier_Dilatation_5",
    "Lagrange_Multiplier_Dilatation_6",
    "Lagrange_Multiplier_Deviatoric_1",
    "Lagrange_Multiplier_Deviatoric_2",
    "Lagrange_Multiplier_Deviatoric_3",
    "Lagrange_Multiplier_Deviatoric_4",
    "Lagrange_Multiplier_Deviatoric_5",
    "Lagrange_Multiplier_Deviatoric_6",
];

impl MaterialKeys for Pals {
    type Parameters = PalsParameters;

    /// `Pals`: state-based (two hops); keeps the twelve multipliers and the weighted volume
    /// per point (reference configuration), ω and σ per bond, and the dilatation per point
    /// (recomputed in every evaluation).
    const DECLARATION: ModelDeclaration = ModelDeclaration {
        deck_name: "Pals",
        aliases: &[],
        deck_keys: &[
            DENSITY,
            ELASTIC[0],
            ELASTIC[1],
            ELASTIC[2],
            ELASTIC[3],
            DILATATION_INFLUENCE,
            DEVIATORIC_INFLUENCE,
            TANGENT,
            AUTOMATIC_DIFFERENTIATION,
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
                name: "Lagrange_Multipliers",
                carrier: FieldCarrier::Point,
                bytes_per_value: 8 * 2 * MULTIPLIERS as u64,
                staged: false,
            },
            FieldDeclaration {
                name: "Pals_Influence",
                carrier: FieldCarrier::Bond,
                bytes_per_value: 8 * 2 + 8,
                staged: false,
            },
        ],
        outputs: &[
            "Weighted_Volume",
            "Dilatation",
            "Dilatation_Normalization",
            "Deviatoric_Normalization",
            "Lagrange_Multiplier_Dilatation_1",
            "Lagrange_Multiplier_Dilatation_2",
            "Lagrange_Multiplier_Dilatation_3",
            "Lagrange_Multiplier_Dilatation_4",
            "Lagrange_Multiplier_Dilatation_5",
            "Lagrange_Multiplier_Dilatation_6",
            "Lagrange_Multiplier_Deviatoric_1",
            "Lagrange_Multiplier_Deviatoric_2",
            "Lagrange_Multiplier_Deviatoric_3",
            "Lagrange_Multiplier_Deviatoric_4",
            "Lagrange_Multiplier_Deviatoric_5",
            "Lagrange_Multiplier_Deviatoric_6",
        ],
        tangent: TangentSupport::Differentiated,
        thermal_strain: false,
        small_displacement: false,
        example: "Density: 2.0\nBulk Modulus: 3.0\nShear Modulus: 1.2",
    };

    fn read(ctx: &mut Ctx, list: &mut ListReader) -> Result<PalsParameters, DeckError> {
        let elastic = super::elastic_constants::read(ctx, list)?;
        let mut base = |key: &'static str| -> Result<InfluenceFunction, DeckError> {
            Ok(match list.get(key) {
                None => InfluenceFunction::One,
                Some(f) => {
                    let name = f.choice(ctx, &["One", "Parabolic Decay", "Gaussian"])?;
                    InfluenceFunction::from_deck_name(name).expect("a built-in function")
                }
            })
        };
        let influence = PalsInfluence {
            dilatation: base(DILATATION_INFLUENCE.key)?,
            deviatoric: base(DEVIATORIC_INFLUENCE.key)?,
        };
        Ok(PalsParameters { elastic, influence })
    }
}

impl MaterialModel for Pals {
    fn build(
        block: &BlockInput,
        parameters: &PalsParameters,
    ) -> Result<Box<dyn Material>, MaterialError> {
        Ok(Box::new(Self::new(block, parameters)?))
    }
}

impl Pals {
    /// Validates the parameters (ρ, K, μ, δ positive and finite).
    pub fn new(block: &BlockInput, parameters: &PalsParameters) -> Result<Self, MaterialError> {
        let data = BlockData::new(
            &Self::DECLARATION,
            block.density,
            parameters.elastic.bulk_modulus,
            block.horizon,
        )?;
        Ok(Self {
            block: data,
            shear_modulus: super::positive("Shear Modulus", parameters.elastic.shear_modulus)?,
            influence: parameters.influence.clone(),
            multipliers: Vec::new(),
            weighted_volume: Vec::new(),
            local_offsets: vec![0],
            omega: Vec::new(),
            sigma: Vec::new(),
            reverse: Vec::new(),
            input_id: Vec::new(),
        })
    }

    /// The multipliers of each block point, in the order of [`Material::points`].
    pub fn multipliers(&self) -> &[Multipliers] {
        &self.multipliers
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
            local_offsets: &self.local_offsets,
            omega: &self.omega,
            sigma: &self.sigma,
            bulk_modulus: self.block.bulk_modulus(),
            shear_modulus: self.shear_modulus,
        }
    }
}

/// g_k(ξ) = ξ·ε⁽ᵏ⁾ξ of the six modes (module docs).
fn dilatation_modes(xi: [f64; 3]) -> [f64; MULTIPLIERS] {
    let [a, b, c] = xi;
    [a * a, b * b, c * c, 2.0 * a * b, 2.0 * a * c, 2.0 * b * c]
}

/// s_k(ξ), the deviatoric extensions of the six unit modes (module docs).
fn deviatoric_extensions(xi: [f64; 3]) -> [f64; MULTIPLIERS] {
    let [a, b, c] = xi;
    let r = (a * a + b * b + c * c).sqrt();
    let third = r / 3.0;
    [
        a * a / r - third,
        b * b / r - third,
        c * c / r - third,
        2.0 * a * b / r,
        2.0 * a * c / r,
        2.0 * b * c / r,
    ]
}

/// s_k(ξ)², the squared deviatoric extensions of the six unit modes (module docs).
fn deviatoric_modes(xi: [f64; 3]) -> [f64; MULTIPLIERS] {
    deviatoric_extensions(xi).map(|s| s * s)
}

fn dot(a: &[f64; MULTIPLIERS], b: &[f64; MULTIPLIERS]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Solves `a x = b` by Gaussian elimination with partial pivoting; `None` when a pivot
/// vanishes relative to the largest entry of `a` (the family cannot fix the multipliers).
fn solve(
    mut a: [[f64; MULTIPLIERS]; MULTIPLIERS],
    mut b: [f64; MULTIPLIERS],
) -> Option<[f64; MULTIPLIERS]> {
    let scale = a.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    if !(scale.is_finite() && scale > 0.0) {
        return None;
    }
    for col in 0..MULTIPLIERS {
        // The first of equally large candidates, as LAPACK's pivot search takes it: the
        // multipliers that vanish by symmetry are round-off, whose value (compared by
        // Peridigm's regression decks) depends on this choice.
        let mut pivot = col;
        for row in col + 1..MULTIPLIERS {
            if a[row][col].abs() > a[pivot][col].abs() {
                pivot = row;
            }
        }
        let magnitude = a[pivot][col].abs();
        if magnitude.is_nan() || magnitude <= 1e-13 * scale {
            return None;
        }
        a.swap(col, pivot);
        b.swap(col, pivot);
        for row in col + 1..MULTIPLIERS {
            let factor = a[row][col] / a[col][col];
            let (upper, lower) = a.split_at_mut(row);
            for (target, source) in lower[0][col..].iter_mut().zip(&upper[col][col..]) {
                *target -= factor * source;
            }
            b[row] -= factor * b[col];
        }
    }
    let mut x = [0.0; MULTIPLIERS];
    for row in (0..MULTIPLIERS).rev() {
        let tail: f64 = (row + 1..MULTIPLIERS).map(|k| a[row][k] * x[k]).sum();
        x[row] = (b[row] - tail) / a[row][row];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// The multipliers of point `i` from its whole reference family (module docs), or `None` when
/// the family does not determine them. The family is summed in the order of `input_id` (the
/// neighbours' numbers in the input, when given), as Peridigm sums it: the multipliers that
/// vanish by symmetry are round-off whose value depends on that order, and Peridigm's
/// regression decks compare them relatively.
fn point_multipliers(
    reference: &ReferenceView<'_>,
    influence: &PalsInfluence,
    horizon: f64,
    input_id: &[u32],
    i: usize,
) -> Option<Multipliers> {
    let bonds = reference.bonds;
    if bonds.family_size(i) == 0 {
        return Some(Multipliers::default());
    }
    let mut order: Vec<usize> = bonds.range(i).collect();
    if !input_id.is_empty() {
        order.sort_by_key(|&b| input_id[bonds.neighbor[b] as usize]);
    }
    let x = reference.position[i];
    let mut dilatation = [[0.0; MULTIPLIERS]; MULTIPLIERS];
    let mut deviatoric = [[0.0; MULTIPLIERS]; MULTIPLIERS];
    // The base functions' share of each constraint, summed before it is taken from the target
    // (and each term rounded as (σ₀ s) s V): the order of Peridigm's sums, so that the
    // multipliers that vanish by symmetry come out as the same round-off.
    let mut base_dilatation = [0.0; MULTIPLIERS];
    let mut base_deviatoric = [0.0; MULTIPLIERS];
    for b in order {
        let j = bonds.neighbor[b] as usize;
        let xi = [0, 1, 2].map(|k| reference.position[j][k] - x[k]);
        let v = reference.neighbor_volume(b, j);
        let zeta = bonds.reference_length[b];
        let g = dilatation_modes(xi);
        let s = deviatoric_extensions(xi);
        let q = s.map(|s| s * s);
        let omega0 = influence.dilatation.evaluate(zeta, horizon);
        let sigma0 = influence.deviatoric.evaluate(zeta, horizon);
        for r in 0..MULTIPLIERS {
            for c in 0..MULTIPLIERS {
                dilatation[r][c] += g[r] * g[c] * v;
                deviatoric[r][c] += q[r] * q[c] * v;
            }
            base_dilatation[r] += omega0 * g[r] * v;
            base_deviatoric[r] += sigma0 * s[r] * s[r] * v;
        }
    }
    let mut rhs_dilatation = [0, 1, 2, 3, 4, 5].map(|k| DILATATION_TARGET[k] - base_dilatation[k]);
    let mut rhs_deviatoric = [0, 1, 2, 3, 4, 5].map(|k| DEVIATORIC_TARGET[k] - base_deviatoric[k]);
    let trace: f64 = (0..MULTIPLIERS).map(|k| dilatation[k][k]).sum();
    for k in 0..MULTIPLIERS {
        if dilatation[k][k] / trace < DEGENERATE {
            for l in 0..MULTIPLIERS {
                dilatation[k][l] = 0.0;
                dilatation[l][k] = 0.0;
                deviatoric[k][l] = 0.0;
                deviatoric[l][k] = 0.0;
            }
            dilatation[k][k] = 1.0;
            deviatoric[k][k] = 1.0;
            rhs_dilatation[k] = 0.0;
            rhs_deviatoric[k] = 0.0;
        }
    }
    Some(Multipliers {
        dilatation: solve(dilatation, rhs_dilatation)?,
        deviatoric: solve(deviatoric, rhs_deviatoric)?,
    })
}

/// What the force state reads, over any scalar (the force uses f64, the tangent dual numbers).
#[derive(Clone, Copy)]
struct Kernel<'a> {
    bonds: &'a BondList,
    volume: BondVolumes<'a>,
    damage: Option<&'a [f32]>,
    local_offsets: &'a [usize],
    omega: &'a [f64],
    sigma: &'a [f64],
    bulk_modulus: f64,
    shear_modulus: f64,
}

/// θ and p of one point.
#[derive(Clone, Copy, Debug)]
struct PointState<T> {
    dilatation: T,
    pressure: T,
}

impl Kernel<'_> {
    fn intact(&self, b: usize) -> f64 {
        self.damage.map_or(1.0, |d| 1.0 - f64::from(d[b]))
    }

    /// |Y| of the n-th bond of the family at `y` (0 for coincident points, which carry no
    /// force: a zero length has no derivative).
    fn length<T: Scalar>(y: &[[T; 3]], n: usize) -> T {
        let d = [0, 1, 2].map(|k| y[n + 1][k] - y[0][k]);
        let squared = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        if squared.re() > 0.0 {
            squared.sqrt()
        } else {
            T::from(0.0)
        }
    }

    /// θ and p of `point` with its family at `y` (module docs).
    fn state<T: Scalar>(&self, point: PointIndex, y: &[[T; 3]]) -> PointState<T> {
        let base = self.local_offsets[point.local];
        let mut theta = T::from(0.0);
        let mut deviatoric_sum = T::from(0.0);
        let mut m = 0.0;
        for (n, b) in self.bonds.range(point.global).enumerate() {
            let zeta = self.bonds.reference_length[b];
            let j = self.bonds.neighbor[b] as usize;
            let weight = self.intact(b) * zeta * self.volume.of(b, j);
            let extension = Self::length(y, n) - zeta;
            theta += extension * (weight * self.omega[base + n]);
            deviatoric_sum += extension * (weight * self.sigma[base + n]);
            m += weight * zeta * self.sigma[base + n];
        }
        let two_mu = 2.0 * self.shear_modulus;
        PointState {
            dilatation: theta,
            pressure: theta * (self.bulk_modulus + two_mu * m / 9.0)
                - deviatoric_sum * (two_mu / 3.0),
        }
    }
}

/// t = (1−d)[p ω ζ + 2μ σ (e − θζ/3)] (module docs).
fn scalar_force_state(
    c: &PointCoefficients,
    omega: f64,
    sigma: f64,
    zeta: f64,
    extension: f64,
    intact: f64,
) -> f64 {
    intact
        * (c.isotropic * omega * zeta
            + c.deviatoric * sigma * (extension - c.dilatation * zeta / 3.0))
}

impl Material for Pals {
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
        let mut inside = vec![false; bonds.num_points()];
        for &p in points {
            inside[p as usize] = true;
        }
        // Any bond with exactly one end in the block, from either end (one-way bonds of
        // another block's larger horizon included).
        if let Some(point) = (0..bonds.num_points()).find(|&i| {
            bonds
                .family(i)
                .iter()
                .any(|&j| inside[i] != inside[j as usize])
        }) {
            return Err(MaterialError::BondLeavesBlock {
                model: Self::DECLARATION.deck_name,
                point,
            });
        }
        let multipliers: Vec<Option<Multipliers>> = points
            .par_iter()
            .map(|&i| {
                point_multipliers(
                    reference,
                    &self.influence,
                    horizon,
                    &self.input_id,
                    i as usize,
                )
            })
            .collect();
        let mut solved = Vec::with_capacity(points.len());
        for (&i, m) in points.iter().zip(multipliers) {
            solved.push(m.ok_or(MaterialError::SingularInfluenceSystem {
                model: Self::DECLARATION.deck_name,
                point: i as usize,
                bonds: bonds.family_size(i as usize),
            })?);
        }
        let offsets = local_offsets(bonds, points);
        let count = *offsets.last().unwrap_or(&0);
        let (mut omega, mut sigma) = (Vec::with_capacity(count), Vec::with_capacity(count));
        let mut weighted_volume = Vec::with_capacity(points.len());
        let mut reverse = Vec::with_capacity(count);
        for (&i, m) in points.iter().zip(&solved) {
            let i = i as usize;
            let x = reference.position[i];
            let mut sum = 0.0;
            for b in bonds.range(i) {
                let j = bonds.neighbor[b] as usize;
                let xi = [0, 1, 2].map(|k| reference.position[j][k] - x[k]);
                let zeta = bonds.reference_length[b];
                omega.push(
                    self.influence.dilatation.evaluate(zeta, horizon)
                        + dot(&m.dilatation, &dilatation_modes(xi)),
                );
                let s = self.influence.deviatoric.evaluate(zeta, horizon)
                    + dot(&m.deviatoric, &deviatoric_modes(xi));
                sigma.push(s);
                sum += s * zeta * zeta * reference.neighbor_volume(b, j);
                // Rows are sorted, so the reverse bond is found by binary search; j is a block
                // point (checked above).
                let local_j = points.partition_point(|&p| (p as usize) < j);
                let Ok(position) = bonds.family(j).binary_search(&(i as u32)) else {
                    return Err(MaterialError::BondLeavesBlock {
                        model: Self::DECLARATION.deck_name,
                        point: j,
                    });
                };
                reverse.push(offsets[local_j] + position);
            }
            weighted_volume.push(sum);
        }
        self.multipliers = solved;
        self.weighted_volume = weighted_volume;
        self.local_offsets = offsets;
        self.omega = omega;
        self.sigma = sigma;
        self.reverse = reverse;
        Ok(())
    }

    fn input_numbering(&mut self, original_id: &[u32]) {
        self.input_id = original_id.to_vec();
    }

    fn compute_point_coefficients(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        coefficients: &mut [PointCoefficients],
    ) {
        let kernel = self.kernel(reference, current.bond_damage);
        let bonds = reference.bonds;
        let two_mu = 2.0 * self.shear_modulus;
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
                    family_positions(bonds, current.position, point.global, &mut y);
                    let state = kernel.state(point, &y);
                    out[point.global - base] = PointCoefficients {
                        dilatation: state.dilatation,
                        isotropic: state.pressure,
                        deviatoric: two_mu,
                    };
                }
            },
        );
    }

    /// `F_i = Σ_j (t_ij + t_ji) V_j M_ij`, each t from its end's published θ, p, 2μ and its
    /// own ω, σ on the bond (module docs).
    fn add_force_density(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        coefficients: &[PointCoefficients],
        force_density: &mut [[f64; 3]],
    ) {
        let bonds = reference.bonds;
        let kernel = self.kernel(reference, current.bond_damage);
        let y = current.position;
        let force_points = self.block.force_points();
        for_each_chunk(
            force_points,
            force_density,
            &|i| i as usize,
            &|chunk: &[u32], base: usize, out: &mut [[f64; 3]]| {
                for &i in chunk {
                    let local = self.local_offsets[self.block.points().partition_point(|&p| p < i)];
                    let i = i as usize;
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
                        let own = local + n;
                        let back = self.reverse[own];
                        let t = scalar_force_state(
                            &coefficients[i],
                            self.omega[own],
                            self.sigma[own],
                            zeta,
                            extension,
                            intact,
                        ) + scalar_force_state(
                            &coefficients[j],
                            self.omega[back],
                            self.sigma[back],
                            zeta,
                            extension,
                            intact,
                        );
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

    /// W = Kθ²/2 + μ Σ_j (1−d) σ (e^d)² V_j (module docs).
    fn stored_energy_density(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        coefficients: &[PointCoefficients],
        energy_density: &mut [f64],
    ) {
        let bonds = reference.bonds;
        let kernel = self.kernel(reference, current.bond_damage);
        let y = current.position;
        for (local, &i) in self.block.points().iter().enumerate() {
            let i = i as usize;
            let theta = coefficients[i].dilatation;
            let base = self.local_offsets[local];
            let mut sum = 0.0;
            for (n, b) in bonds.range(i).enumerate() {
                let j = bonds.neighbor[b] as usize;
                let d = [0, 1, 2].map(|k| y[j][k] - y[i][k]);
                let length = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                let zeta = bonds.reference_length[b];
                let deviatoric = length - zeta - theta * zeta / 3.0;
                sum += kernel.intact(b)
                    * self.sigma[base + n]
                    * deviatoric
                    * deviatoric
                    * reference.neighbor_volume(b, j);
            }
            energy_density[i] =
                0.5 * self.block.bulk_modulus() * theta * theta + self.shear_modulus * sum;
        }
    }

    fn tangent(&self) -> Option<&dyn MaterialTangent> {
        Some(self)
    }

    fn outputs(&self) -> Option<&dyn MaterialOutputs> {
        Some(self)
    }
}

impl MaterialTangent for Pals {
    fn add_tangent(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        method: TangentMethod,
        tangent: &mut BlockTangent,
    ) -> Result<(), TangentError> {
        let kernel = PalsForceState {
            kernel: self.kernel(reference, current.bond_damage),
        };
        assemble(
            &kernel,
            Self::DECLARATION.deck_name,
            self.block.points(),
            reference,
            current,
            method,
            tangent,
        )
    }
}

impl MaterialOutputs for Pals {
    fn weighted_volume(&self) -> Option<&[f64]> {
        Some(&self.weighted_volume)
    }

    fn point_output(&self, name: &str) -> Option<Vec<f64>> {
        if name == "Dilatation_Normalization" || name == "Deviatoric_Normalization" {
            return Some(vec![1.0; self.block.points().len()]);
        }
        let k = MULTIPLIER_OUTPUTS.iter().position(|&o| o == name)?;
        Some(
            self.multipliers
                .iter()
                .map(|m| {
                    if k < MULTIPLIERS {
                        m.dilatation[k]
                    } else {
                        m.deviatoric[k - MULTIPLIERS]
                    }
                })
                .collect(),
        )
    }
}

/// The positions of point `p`'s family into `y` (`y[0]` the point).
fn family_positions(bonds: &BondList, position: &[[f64; 3]], p: usize, y: &mut Vec<[f64; 3]>) {
    y.clear();
    y.push(position[p]);
    y.extend(bonds.family(p).iter().map(|&j| position[j as usize]));
}

/// The force state of a point for the tangent, `T = t M` with
/// `t = (1−d)[p ω ζ + 2μ σ e^d]`, generic over the scalar.
struct PalsForceState<'a> {
    kernel: Kernel<'a>,
}

impl ForceState for PalsForceState<'_> {
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
        let state = kernel.state(point, y);
        let base = kernel.local_offsets[point.local];
        let two_mu = 2.0 * kernel.shear_modulus;
        for (n, b) in kernel.bonds.range(point.global).enumerate() {
            let length = Kernel::length(y, n);
            t[n] = if length.re() > 0.0 {
                let zeta = kernel.bonds.reference_length[b];
                let deviatoric = length - zeta - state.dilatation * (zeta / 3.0);
                let scalar = (state.pressure * (kernel.omega[base + n] * zeta)
                    + deviatoric * (two_mu * kernel.sigma[base + n]))
                    * kernel.intact(b);
                let scale = scalar / length;
                [0, 1, 2].map(|k| (y[n + 1][k] - y[0][k]) * scale)
            } else {
                [zero; 3]
            };
        }
    }

    fn ordinary_derivatives(&self, _point: PointIndex, _y: &[[f64; 3]], _out: &mut [OrdinaryBond]) {
        unreachable!("Pals has no closed-form tangent (ANALYTIC is false)")
    }
}
