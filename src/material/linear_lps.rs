//! Small-displacement linear peridynamic solid, Peridigm's `Linear LPS Partial Volume`
//! (`Peridigm_LinearLPSPVMaterial.cpp`, `linear_lps_pv.cxx` in Peridigm's public repository).
//!
//! The LPS of `Elastic` (Silling et al. 2007) linearized about the reference configuration: a
//! bond's extension is the displacement difference projected on the reference bond, and its
//! force acts along the reference bond. With ξ = X_j − X_i, ζ = |ξ|, n = ξ/ζ and the
//! displacement u = Y − X:
//!
//! * extension `e_ij = n·(u_j − u_i)` (the same number from both ends);
//! * weighted volume `m_i = Σ_j ω ζ² w_ij` (reference configuration, all bonds, computed once
//!   at setup), or the deck's `Analytic Weighted Volume` for every point when `Use Analytic
//!   Weighted Volume: true`;
//! * dilatation `θ_i = (3/m_i) Σ_j ω (1−d) ζ e w_ij`;
//! * scalar force state `t_ij = (1−d)·[ (3K/m − 5μ/m)·ω·θ·ζ + (15μ/m)·ω·e ]`, which for
//!   d = 0 is `(3Kθ/m) ω ζ + (15μ/m) ω (e − θζ/3)`; the bond damage d enters once, as in
//!   Peridigm's `linear_lps_pv.cxx` (`Elastic` squares it on the deviatoric part; the two
//!   differ only on partly damaged bonds, 0 < d < 1);
//! * force density `F_i = Σ_j (t_ij + t_ji) w_ij n_ij` (the gather form of the module docs of
//!   `material`, with the reference direction n in place of the current one M);
//! * stored energy density `W_i = Kθ_i²/2 + (α_i/2) Σ_j (1−d) ω (e − θ_i ζ/3)² w_ij`,
//!   α = 15μ/m, whose derivative is the force for intact bonds.
//!
//! w_ij is the block's quadrature volume of the bond (`Blocks → … → Quadrature`; the cell
//! volume V_j under the default full-volume rule). Peridigm's `Use Partial Volume` and `Use
//! Improved Quadrature` need a special Peridigm build; here either key set to true makes a
//! block without its own `Quadrature` (and without a `Discretization` partial-volume scheme)
//! use the `Exact` rule (the volume of the neighbour's cell inside the horizon sphere), and a
//! block that names its `Quadrature` keeps that rule.
//!
//! Being linear in u, the model is exact only for small displacements: a rigid translation
//! gives no force, an infinitesimal rotation gives a force of second order in the angle, but a
//! finite rotation stretches the projected bonds and gives a force (the price of the
//! linearization, as in Peridigm). The tangent is constant: analytic by default, or automatic
//! or finite differences of the same force state (`Tangent`).
//!
//! A point whose weighted volume is 0 has no dilatation and carries no force. A bond to a
//! block of another state-based model takes that point's published coefficients (θ, m, K, μ)
//! with this model's linearized extension and reference direction.

use super::influence::InfluenceFunction;
use super::keys::{DENSITY, ELASTIC, PROBE_LENGTH, TANGENT};
use super::{
    influence_weighted_volumes, local_offsets, BlockData, BlockInput, CurrentView,
    ElasticConstants, Material, MaterialError, MaterialKeys, MaterialModel, MaterialOutputs,
    MaterialParameters, MaterialTangent, PointCoefficients, ReferenceView,
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

/// `Use Partial Volume`.
const USE_PARTIAL_VOLUME: KeyDoc = KeyDoc {
    key: "Use Partial Volume",
    meaning: "weigh bonds by the neighbour's cell volume inside the horizon: a block without \
              its own `Quadrature` uses the `Exact` rule",
    unit: "true/false",
    default: "false",
};

/// `Use Improved Quadrature`.
const USE_IMPROVED_QUADRATURE: KeyDoc = KeyDoc {
    key: "Use Improved Quadrature",
    meaning: "as `Use Partial Volume`",
    unit: "true/false",
    default: "false",
};

/// `Use Analytic Weighted Volume`.
const USE_ANALYTIC_WEIGHTED_VOLUME: KeyDoc = KeyDoc {
    key: "Use Analytic Weighted Volume",
    meaning: "use `Analytic Weighted Volume` as m at every point instead of the family sum",
    unit: "true/false",
    default: "false",
};

/// `Analytic Weighted Volume`.
const ANALYTIC_WEIGHTED_VOLUME: KeyDoc = KeyDoc {
    key: "Analytic Weighted Volume",
    meaning: "m of every point with `Use Analytic Weighted Volume`",
    unit: "length⁵",
    default: "required with `Use Analytic Weighted Volume`",
};

/// `Verbose`.
const VERBOSE: KeyDoc = KeyDoc {
    key: "Verbose",
    meaning: "Peridigm's diagnostic printing; no effect here",
    unit: "true/false",
    default: "false",
};

/// Deck parameters of `Linear LPS Partial Volume` besides the keys every model shares.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinearLpsParameters {
    /// K and μ from the elastic pair.
    pub elastic: ElasticConstants,
    /// `Use Partial Volume`.
    pub use_partial_volume: bool,
    /// `Use Improved Quadrature`.
    pub use_improved_quadrature: bool,
    /// `Analytic Weighted Volume` m (length⁵) used for every point in place of the family sum,
    /// when the deck sets `Use Analytic Weighted Volume: true`; default `None`.
    pub analytic_weighted_volume: Option<f64>,
    /// `Verbose` (no effect).
    pub verbose: bool,
}

impl MaterialParameters for LinearLpsParameters {
    fn bulk_modulus(&self) -> Option<f64> {
        Some(self.elastic.bulk_modulus)
    }

    fn asks_for_partial_volumes(&self) -> bool {
        self.use_partial_volume || self.use_improved_quadrature
    }
}

/// The small-displacement LPS of one block (see the module docs for the formulas).
#[derive(Debug, Clone)]
pub struct LinearLps {
    block: BlockData,
    shear_modulus: f64,
    influence: InfluenceFunction,
    analytic_weighted_volume: Option<f64>,
    /// Block-local row starts into `weights`.
    local_offsets: Vec<usize>,
    /// ω per block bond (block-local numbering).
    weights: Vec<f64>,
    /// m per block point (same order as the block's points).
    weighted_volume: Vec<f64>,
}

/// `ξ·(u_j − u_i)/|ξ|` and `ξ/|ξ|` of a bond from `i` to `j` (reference `x`, current `y`).
#[inline(always)]
fn linear_extension<T: Scalar>(xi: [f64; 3], yi: [T; 3], yj: [T; 3], zeta: f64) -> (T, [f64; 3]) {
    let n = xi.map(|c| c / zeta);
    let mut e = T::from(0.0);
    for k in 0..3 {
        // u_j − u_i = (Y_j − Y_i) − ξ.
        e += (yj[k] - yi[k] - xi[k]) * n[k];
    }
    (e, n)
}

/// The reference bond vector X_j − X_i.
#[inline(always)]
fn bond_vector(x: &[[f64; 3]], i: usize, j: usize) -> [f64; 3] {
    [0, 1, 2].map(|k| x[j][k] - x[i][k])
}

impl MaterialKeys for LinearLps {
    type Parameters = LinearLpsParameters;

    /// `Linear LPS Partial Volume`: state-based (both ends' dilatations enter every bond force,
    /// so the force reaches two hops); keeps m and θ per point.
    const DECLARATION: ModelDeclaration = ModelDeclaration {
        deck_name: "Linear LPS Partial Volume",
        aliases: &[],
        deck_keys: &[
            DENSITY,
            ELASTIC[0],
            ELASTIC[1],
            ELASTIC[2],
            ELASTIC[3],
            USE_PARTIAL_VOLUME,
            USE_IMPROVED_QUADRATURE,
            USE_ANALYTIC_WEIGHTED_VOLUME,
            ANALYTIC_WEIGHTED_VOLUME,
            VERBOSE,
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
        ],
        outputs: &["Weighted_Volume", "Dilatation"],
        tangent: TangentSupport::Analytic,
        thermal_strain: false,
        small_displacement: true,
        example: "Density: 2.0\nBulk Modulus: 3.0\nShear Modulus: 1.3",
    };

    fn read(ctx: &mut Ctx, list: &mut ListReader) -> Result<LinearLpsParameters, DeckError> {
        let elastic = super::elastic_constants::read(ctx, list)?;
        let analytic = list.bool_or(ctx, USE_ANALYTIC_WEIGHTED_VOLUME.key, false)?;
        Ok(LinearLpsParameters {
            elastic,
            use_partial_volume: list.bool_or(ctx, USE_PARTIAL_VOLUME.key, false)?,
            use_improved_quadrature: list.bool_or(ctx, USE_IMPROVED_QUADRATURE.key, false)?,
            analytic_weighted_volume: if analytic {
                Some(list.positive_req(ctx, ANALYTIC_WEIGHTED_VOLUME.key)?)
            } else {
                None
            },
            verbose: list.bool_or(ctx, VERBOSE.key, false)?,
        })
    }
}

impl MaterialModel for LinearLps {
    fn build(
        block: &BlockInput,
        parameters: &LinearLpsParameters,
    ) -> Result<Box<dyn Material>, MaterialError> {
        Ok(Box::new(Self::new(
            block,
            &parameters.elastic,
            parameters.analytic_weighted_volume,
        )?))
    }
}

impl LinearLps {
    /// Validates the parameters (ρ, K, μ, δ and an analytic m positive and finite); ω from
    /// `block`.
    pub fn new(
        block: &BlockInput,
        elastic: &ElasticConstants,
        analytic_weighted_volume: Option<f64>,
    ) -> Result<Self, MaterialError> {
        let data = BlockData::new(
            &Self::DECLARATION,
            block.density,
            elastic.bulk_modulus,
            block.horizon,
        )?;
        let shear_modulus = super::positive("Shear Modulus", elastic.shear_modulus)?;
        if let Some(m) = analytic_weighted_volume {
            super::positive(ANALYTIC_WEIGHTED_VOLUME.key, m)?;
        }
        Ok(Self {
            block: data,
            shear_modulus,
            influence: block.influence.clone(),
            analytic_weighted_volume,
            local_offsets: vec![0],
            weights: Vec::new(),
            weighted_volume: Vec::new(),
        })
    }

    /// The force state the tangent differentiates (and the force and energy passes evaluate).
    fn kernel<'a>(
        &'a self,
        reference: &'a ReferenceView<'a>,
        damage: Option<&'a [f32]>,
    ) -> LinearLpsForceState<'a> {
        LinearLpsForceState {
            bonds: reference.bonds,
            position: reference.position,
            volume: reference.bond_volumes(),
            local_offsets: &self.local_offsets,
            weighted_volume: &self.weighted_volume,
            weights: &self.weights,
            damage,
            bulk: self.block.bulk_modulus(),
            shear: self.shear_modulus,
        }
    }
}

/// What the bond loops read.
struct LinearLpsForceState<'a> {
    bonds: &'a BondList,
    /// Reference positions X.
    position: &'a [[f64; 3]],
    volume: BondVolumes<'a>,
    local_offsets: &'a [usize],
    weighted_volume: &'a [f64],
    weights: &'a [f64],
    /// Bond damage (global bond index), if a damage model runs.
    damage: Option<&'a [f32]>,
    bulk: f64,
    shear: f64,
}

impl LinearLpsForceState<'_> {
    /// 1 − d of bond `b`.
    #[inline(always)]
    fn intact(&self, b: usize) -> f64 {
        self.damage.map_or(1.0, |d| 1.0 - f64::from(d[b]))
    }

    /// θ of block point `point` at current positions `y` (the point first, then its family).
    fn dilatation<T: Scalar>(&self, point: PointIndex, y: &[[T; 3]]) -> T {
        let m = self.weighted_volume[point.local];
        let mut sum = T::from(0.0);
        if m <= 0.0 {
            return sum;
        }
        let local = self.local_offsets[point.local];
        for (n, b) in self.bonds.range(point.global).enumerate() {
            let j = self.bonds.neighbor[b] as usize;
            let zeta = self.bonds.reference_length[b];
            let xi = bond_vector(self.position, point.global, j);
            let (e, _) = linear_extension(xi, y[0], y[n + 1], zeta);
            sum += e * (self.weights[local + n] * self.intact(b) * zeta * self.volume.of(b, j));
        }
        sum * (3.0 / m)
    }

    /// The published coefficients of a point: θ, (3K − 5μ)θ/m and 15μ/m.
    fn coefficients(&self, point: PointIndex, y: &[[f64; 3]]) -> PointCoefficients {
        let m = self.weighted_volume[point.local];
        if m <= 0.0 {
            return PointCoefficients::default();
        }
        let theta = self.dilatation(point, y);
        PointCoefficients {
            dilatation: theta,
            isotropic: (3.0 * self.bulk - 5.0 * self.shear) * theta / m,
            deviatoric: 15.0 * self.shear / m,
        }
    }
}

impl ForceState for LinearLpsForceState<'_> {
    const BOND_LOCAL: bool = false;
    const ANALYTIC: bool = true;

    fn force_state<T: Scalar>(
        &self,
        point: PointIndex,
        y: &[[T; 3]],
        _only: Option<usize>,
        t: &mut [[T; 3]],
    ) {
        let m = self.weighted_volume[point.local];
        if m <= 0.0 {
            t.fill([T::from(0.0); 3]);
            return;
        }
        let theta = self.dilatation(point, y);
        let isotropic = theta * ((3.0 * self.bulk - 5.0 * self.shear) / m);
        let deviatoric = 15.0 * self.shear / m;
        let local = self.local_offsets[point.local];
        for (n, b) in self.bonds.range(point.global).enumerate() {
            let j = self.bonds.neighbor[b] as usize;
            let zeta = self.bonds.reference_length[b];
            let xi = bond_vector(self.position, point.global, j);
            let (e, direction) = linear_extension(xi, y[0], y[n + 1], zeta);
            let intact = self.intact(b);
            let scalar = (isotropic * zeta + e * deviatoric) * (intact * self.weights[local + n]);
            t[n] = direction.map(|c| scalar * c);
        }
    }

    /// The direction is the reference one (fixed), so `lateral = 0`; `axial = (1−d) ω 15μ/m`,
    /// `γ_n = ∂t_n/∂θ = (1−d) ω ζ (3K − 5μ)/m`, `β_n = ∂θ/∂e_n = (3/m) ω (1−d) ζ w_n`.
    fn ordinary_derivatives(&self, point: PointIndex, _y: &[[f64; 3]], out: &mut [OrdinaryBond]) {
        let m = self.weighted_volume[point.local];
        if m <= 0.0 {
            out.fill(OrdinaryBond::default());
            return;
        }
        let local = self.local_offsets[point.local];
        for ((n, b), bond) in self
            .bonds
            .range(point.global)
            .enumerate()
            .zip(out.iter_mut())
        {
            let j = self.bonds.neighbor[b] as usize;
            let zeta = self.bonds.reference_length[b];
            let omega = self.weights[local + n];
            let intact = self.intact(b);
            *bond = OrdinaryBond {
                direction: bond_vector(self.position, point.global, j).map(|c| c / zeta),
                axial: intact * omega * 15.0 * self.shear / m,
                lateral: 0.0,
                coupling: intact * omega * zeta * (3.0 * self.bulk - 5.0 * self.shear) / m,
                weight: 3.0 / m * omega * intact * zeta * self.volume.of(b, j),
            };
        }
    }
}

impl Material for LinearLps {
    fn block(&self) -> &BlockData {
        &self.block
    }

    fn block_mut(&mut self) -> &mut BlockData {
        &mut self.block
    }

    fn prepare(&mut self, reference: &ReferenceView<'_>) -> Result<(), MaterialError> {
        let bonds = reference.bonds;
        let points = self.block.points();
        let weights = self
            .influence
            .per_bond(bonds, points, self.block.horizon())?;
        let local_offsets = local_offsets(bonds, points);
        let weighted_volume: Vec<f64> = match self.analytic_weighted_volume {
            Some(m) => vec![m; points.len()],
            None => influence_weighted_volumes(reference, points, &local_offsets, Some(&weights)),
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
        let kernel = self.kernel(reference, current.bond_damage);
        let bonds = reference.bonds;
        let points = self.block.points();
        for_each_chunk(
            points,
            coefficients,
            &|i| i as usize,
            &|chunk: &[u32], base: usize, out: &mut [PointCoefficients]| {
                let mut y = Vec::new();
                let k0 = points.partition_point(|&p| p < chunk[0]);
                for (local, &i) in (k0..).zip(chunk) {
                    let global = i as usize;
                    y.clear();
                    y.push(current.position[global]);
                    y.extend(
                        bonds
                            .family(global)
                            .iter()
                            .map(|&j| current.position[j as usize]),
                    );
                    out[global - base] = kernel.coefficients(PointIndex { global, local }, &y);
                }
            },
        );
    }

    fn add_force_density(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        coefficients: &[PointCoefficients],
        force_density: &mut [[f64; 3]],
    ) {
        let kernel = self.kernel(reference, current.bond_damage);
        let bonds = reference.bonds;
        let x = reference.position;
        let y = current.position;
        let points = self.block.points();
        for_each_chunk(
            self.block.force_points(),
            force_density,
            &|i| i as usize,
            &|chunk: &[u32], base: usize, out: &mut [[f64; 3]]| {
                for &i in chunk {
                    let i = i as usize;
                    let local = points
                        .binary_search(&(i as u32))
                        .expect("force points are block points");
                    let row = self.local_offsets[local];
                    let ci = coefficients[i];
                    let mut total = [0.0; 3];
                    for (n, b) in bonds.range(i).enumerate() {
                        let j = bonds.neighbor[b] as usize;
                        let cj = coefficients[j];
                        let zeta = bonds.reference_length[b];
                        let (e, direction) =
                            linear_extension(bond_vector(x, i, j), y[i], y[j], zeta);
                        let intact = kernel.intact(b);
                        // t_ij + t_ji: the same ω, d, ζ and e from both ends.
                        let t = intact
                            * kernel.weights[row + n]
                            * ((ci.isotropic + cj.isotropic) * zeta
                                + (ci.deviatoric + cj.deviatoric) * e);
                        let scale = t * reference.neighbor_volume(b, j);
                        for k in 0..3 {
                            total[k] += scale * direction[k];
                        }
                    }
                    for k in 0..3 {
                        out[i - base][k] += total[k];
                    }
                }
            },
        );
    }

    fn stored_energy_density(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        coefficients: &[PointCoefficients],
        energy_density: &mut [f64],
    ) {
        let bonds = reference.bonds;
        let x = reference.position;
        let y = current.position;
        let kernel = self.kernel(reference, current.bond_damage);
        let points = self.block.points();
        for_each_chunk(
            points,
            energy_density,
            &|i| i as usize,
            &|chunk: &[u32], base: usize, out: &mut [f64]| {
                let k0 = points.partition_point(|&p| p < chunk[0]);
                for (local, &i) in (k0..).zip(chunk) {
                    let i = i as usize;
                    let m = self.weighted_volume[local];
                    if m <= 0.0 {
                        out[i - base] = 0.0;
                        continue;
                    }
                    let theta = coefficients[i].dilatation;
                    let alpha = 15.0 * self.shear_modulus / m;
                    let row = self.local_offsets[local];
                    let mut deviatoric = 0.0;
                    for (n, b) in bonds.range(i).enumerate() {
                        let j = bonds.neighbor[b] as usize;
                        let zeta = bonds.reference_length[b];
                        let (e, _) = linear_extension(bond_vector(x, i, j), y[i], y[j], zeta);
                        let ed = e - theta * zeta / 3.0;
                        deviatoric += kernel.intact(b)
                            * kernel.weights[row + n]
                            * ed
                            * ed
                            * reference.neighbor_volume(b, j);
                    }
                    out[i - base] =
                        0.5 * self.block.bulk_modulus() * theta * theta + 0.5 * alpha * deviatoric;
                }
            },
        );
    }

    fn tangent(&self) -> Option<&dyn MaterialTangent> {
        Some(self)
    }

    fn outputs(&self) -> Option<&dyn MaterialOutputs> {
        Some(self)
    }
}

impl MaterialTangent for LinearLps {
    fn add_tangent(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        method: TangentMethod,
        tangent: &mut BlockTangent,
    ) -> Result<(), TangentError> {
        let kernel = self.kernel(reference, current.bond_damage);
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

impl MaterialOutputs for LinearLps {
    fn weighted_volume(&self) -> Option<&[f64]> {
        Some(&self.weighted_volume)
    }
}

#[cfg(test)]
#[path = "linear_lps_tests.rs"]
mod tests;
