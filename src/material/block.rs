//! What every material of a block keeps, whatever its model: the block's points (and those
//! whose force is computed), ρ, K, δ, the tangent method and the thermal expansion coefficient.
//! A model embeds one [`BlockData`] and returns it from [`Material::block`]; the accessors of
//! [`Material`] that every model shares are written once, here.

use super::{critical_time_step, CurrentView, Material, MaterialError, ReferenceView};
use crate::model::{BondList, ModelDeclaration, Reach, TangentSupport};
use crate::tangent::{BlockTangent, TangentError, TangentMethod};

/// The data every material of a block keeps (module docs).
#[derive(Debug, Clone)]
pub struct BlockData {
    declaration: &'static ModelDeclaration,
    density: f64,
    bulk_modulus: f64,
    horizon: f64,
    points: Vec<u32>,
    /// The points whose force is computed, when fewer than `points`
    /// ([`Material::restrict_forces`]).
    force_points: Option<Vec<u32>>,
    /// The other points of the block (empty unless `force_points` is set).
    unforced_points: Vec<u32>,
    tangent: TangentMethod,
    thermal_expansion: Option<f64>,
}

impl BlockData {
    /// The data of a block of the model `declaration` with `Density` ρ, bulk modulus K and
    /// horizon δ (each a positive finite number), no points yet, the model's default tangent
    /// and no thermal expansion.
    pub fn new(
        declaration: &'static ModelDeclaration,
        density: f64,
        bulk_modulus: f64,
        horizon: f64,
    ) -> Result<Self, MaterialError> {
        Ok(Self {
            declaration,
            density: super::positive("Density", density)?,
            bulk_modulus: super::positive("Bulk Modulus", bulk_modulus)?,
            horizon: super::positive("Horizon", horizon)?,
            points: Vec::new(),
            force_points: None,
            unforced_points: Vec::new(),
            tangent: match declaration.tangent {
                TangentSupport::Analytic => TangentMethod::Analytic,
                TangentSupport::Differentiated => TangentMethod::AutomaticDifferentiation,
                TangentSupport::None => TangentMethod::FiniteDifference { probe: None },
            },
            thermal_expansion: None,
        })
    }

    /// What the model declares about itself.
    pub fn declaration(&self) -> &'static ModelDeclaration {
        self.declaration
    }

    /// Mass density ρ (`Density`).
    pub fn density(&self) -> f64 {
        self.density
    }

    /// Bulk modulus K (pressure).
    pub fn bulk_modulus(&self) -> f64 {
        self.bulk_modulus
    }

    /// Horizon δ of the block (length).
    pub fn horizon(&self) -> f64 {
        self.horizon
    }

    /// The block's points (strictly increasing global indices).
    pub fn points(&self) -> &[u32] {
        &self.points
    }

    /// The points whose force the force pass computes: all of [`BlockData::points`] unless
    /// [`Material::restrict_forces`] kept fewer.
    pub fn force_points(&self) -> &[u32] {
        self.force_points.as_deref().unwrap_or(&self.points)
    }

    /// The block's points whose force is not computed (empty unless restricted).
    pub fn unforced_points(&self) -> &[u32] {
        &self.unforced_points
    }

    /// Block-local index of the block point `point` (a global index).
    pub fn local(&self, point: u32) -> usize {
        self.points.partition_point(|&p| p < point)
    }

    /// The first block point bonded to a point outside the block in `bonds`, `None` when every
    /// family stays inside the block (the block is closed).
    pub(crate) fn point_bonded_outside(&self, bonds: &BondList) -> Option<u32> {
        let mut member = vec![false; bonds.num_points()];
        for &i in &self.points {
            member[i as usize] = true;
        }
        self.points.iter().copied().find(|&i| {
            bonds
                .family(i as usize)
                .iter()
                .any(|&j| !member[j as usize])
        })
    }

    /// The tangent method of the block (`Tangent`, or the model's default).
    pub fn tangent_method(&self) -> TangentMethod {
        self.tangent
    }

    /// `Thermal Expansion Coefficient` α (per degree), when the deck gives one.
    pub fn thermal_expansion(&self) -> Option<f64> {
        self.thermal_expansion
    }

    /// Stores the block's points (strictly increasing, below `num_points`) and computes every
    /// point's force again.
    fn set_points(&mut self, points: Vec<u32>, num_points: usize) {
        super::assert_point_set(&points, num_points);
        self.points = points;
        self.force_points = None;
        self.unforced_points.clear();
    }

    fn restrict_forces(&mut self, keep: &dyn Fn(u32) -> bool) {
        self.force_points = super::kept_points(&self.points, keep);
        self.unforced_points = match &self.force_points {
            Some(_) => self.points.iter().copied().filter(|&p| !keep(p)).collect(),
            None => Vec::new(),
        };
    }

    /// Chooses the block's tangent method: a model with a closed form takes any method, one
    /// differentiated from its force code refuses `Analytic`, one without a tangent refuses
    /// every method; a finite-difference probe must be a positive finite number.
    fn set_tangent_method(&mut self, method: TangentMethod) -> Result<(), TangentError> {
        let model = self.declaration.deck_name;
        self.tangent = match self.declaration.tangent {
            TangentSupport::Analytic => super::checked_tangent_method(method)?,
            TangentSupport::Differentiated => {
                super::checked_differentiated_tangent_method(model, method)?
            }
            TangentSupport::None => return Err(TangentError::Unsupported { model }),
        };
        Ok(())
    }

    /// Sets α, refused (naming the model) unless the model declares thermal strain.
    fn set_thermal_expansion(&mut self, coefficient: f64) -> Result<(), MaterialError> {
        if !self.declaration.thermal_strain {
            return Err(MaterialError::ThermalExpansionNotSupported {
                model: self.declaration.deck_name,
            });
        }
        self.thermal_expansion = Some(super::finite("Thermal Expansion Coefficient", coefficient)?);
        Ok(())
    }
}

/// The accessors and lifecycle every material shares, written once over [`Material::block`],
/// and the calls of the optional capabilities ([`Material::tangent`], [`Material::outputs`]),
/// which answer for a model without one.
impl dyn Material + '_ {
    /// What the model declares about itself: the declaration of its registry entry
    /// ([`super::MATERIALS`]).
    pub fn declaration(&self) -> &'static ModelDeclaration {
        self.block().declaration()
    }

    /// Peridigm's `Material Model` string, e.g. `"Elastic"`.
    pub fn model_name(&self) -> &'static str {
        self.declaration().deck_name
    }

    /// Mass density ρ (`Density`).
    pub fn density(&self) -> f64 {
        self.block().density()
    }

    /// Bulk modulus K (used by the critical time step for every model, as in Peridigm).
    pub fn bulk_modulus(&self) -> f64 {
        self.block().bulk_modulus()
    }

    /// Horizon δ of the block.
    pub fn horizon(&self) -> f64 {
        self.block().horizon()
    }

    /// The block's points given to [`Self::setup`].
    pub fn points(&self) -> &[u32] {
        self.block().points()
    }

    /// True when the published [`PointCoefficients`](super::PointCoefficients) depend on the deformation (LPS: the
    /// dilatation pass), so [`Material::compute_point_coefficients`] must run (and be
    /// exchanged across ranks) before every force evaluation. When false they are constant
    /// and computing them once after setup is enough. It is the declared reach: a point's
    /// published numbers depend on its family's deformation exactly when its force reaches
    /// two hops ([`Reach::TwoHop`]).
    pub fn needs_dilatation(&self) -> bool {
        self.declaration().reach == Reach::TwoHop
    }

    /// Stores the block's points (strictly increasing global indices) and evaluates
    /// everything that depends only on the reference configuration
    /// ([`Material::prepare`]). Must be called before the force passes; calling it again
    /// replaces the previous setup.
    pub fn setup(
        &mut self,
        reference: &ReferenceView<'_>,
        points: Vec<u32>,
    ) -> Result<(), MaterialError> {
        self.block_mut()
            .set_points(points, reference.bonds.num_points());
        self.prepare(reference)
    }

    /// From now on [`Material::add_force_density`] may skip the block points for which `keep`
    /// is false, leaving their force density as it was. A rank of a distributed run keeps only
    /// its owned points: its ghosts' forces are never used (their rows may be truncated), while
    /// their other per-point values (dilatation, damage) still are.
    pub fn restrict_forces(&mut self, keep: &dyn Fn(u32) -> bool) {
        self.block_mut().restrict_forces(keep);
    }

    /// The block's `Thermal Expansion Coefficient` α (per degree), when the deck gives one.
    /// The physics publishes the free thermal strain α ΔT_i of every point from it
    /// ([`crate::history::Thermal::strain`]); `None` publishes 0.
    pub fn thermal_expansion(&self) -> Option<f64> {
        self.block().thermal_expansion()
    }

    /// Sets the `Thermal Expansion Coefficient` α of the block; refused, naming the model, by
    /// a model without thermal strain (Peridigm gives it only to some).
    pub fn set_thermal_expansion(&mut self, coefficient: f64) -> Result<(), MaterialError> {
        self.block_mut().set_thermal_expansion(coefficient)
    }

    /// The tangent method chosen for this block (deck `Tangent`, set by
    /// [`Self::set_tangent_method`]); a material without a tangent reports finite
    /// differences, which it cannot do either ([`Self::add_tangent`] says so).
    pub fn tangent_method(&self) -> TangentMethod {
        self.block().tangent_method()
    }

    /// Chooses how [`Self::add_tangent`] computes this block's tangent by default. Fails when
    /// the material cannot use `method` (no analytic form, or no tangent at all) or the
    /// finite-difference probe is not a positive finite number.
    pub fn set_tangent_method(&mut self, method: TangentMethod) -> Result<(), TangentError> {
        self.block_mut().set_tangent_method(method)
    }

    /// Adds the block's tangent contribution by `method` ([`super::MaterialTangent`]); a model
    /// without a tangent says so.
    pub fn add_tangent(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        method: TangentMethod,
        tangent: &mut BlockTangent,
    ) -> Result<(), TangentError> {
        match self.tangent() {
            Some(model) => model.add_tangent(reference, current, method, tangent),
            None => Err(TangentError::Unsupported {
                model: self.model_name(),
            }),
        }
    }

    /// Weighted volume m of each block point in the order of [`Self::points`] (Peridigm's
    /// `Weighted_Volume`), for state-based models; `None` otherwise.
    pub fn weighted_volume(&self) -> Option<&[f64]> {
        self.outputs()?.weighted_volume()
    }

    /// The values of the point output `name` the model keeps itself, per block point in the
    /// order of [`Self::points`]; `None` for names it does not provide this way.
    pub fn point_output(&self, name: &str) -> Option<Vec<f64>> {
        self.outputs()?.point_output(name)
    }

    /// Writes Peridigm's `Partial_Stress` of the block's points into `out`; models without
    /// one leave `out` as it is ([`super::MaterialOutputs::partial_stress`]).
    pub fn partial_stress(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        out: &mut [[f64; 9]],
    ) {
        if let Some(outputs) = self.outputs() {
            outputs.partial_stress(reference, current, out);
        }
    }

    /// Adds the hourglass-control part of the block's force density to `out`; nothing for
    /// models without one ([`super::MaterialOutputs::add_hourglass_force_density`]).
    pub fn add_hourglass_force_density(
        &self,
        reference: &ReferenceView<'_>,
        current: &CurrentView<'_>,
        out: &mut [[f64; 3]],
    ) {
        if let Some(outputs) = self.outputs() {
            outputs.add_hourglass_force_density(reference, current, out);
        }
    }

    /// Peridigm's critical time step over the block's points, see [`critical_time_step`].
    pub fn critical_time_step(&self, reference: &ReferenceView<'_>) -> Option<f64> {
        critical_time_step(
            reference,
            self.points(),
            self.density(),
            self.bulk_modulus(),
            self.horizon(),
        )
    }
}
