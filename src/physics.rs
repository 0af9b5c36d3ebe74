//! The one internal-force path every solver calls, so that explicit and implicit runs share one
//! residual: damage, then the per-point coefficient pass (LPS dilatation), then the force pass,
//! block by block.

use crate::damage::{point_damage, DamageModel};
use crate::history::{History, NO_HISTORY};
use crate::material::{
    CriticalStretchFastPath, CurrentView, Material, PointCoefficients, ReferenceView,
};
use crate::model::{BondList, PointCloud, Reach};
use crate::tangent::{BlockPattern, BlockTangent, TangentError, TangentMethod};

/// The physics of one block.
pub struct BlockPhysics {
    /// The block's material (set up with the block's points).
    pub material: Box<dyn Material>,
    /// The block's damage model, if any.
    pub damage: Option<Box<dyn DamageModel>>,
}

/// Materials and damage of all blocks, with the scratch they share.
pub struct Physics {
    /// One entry per model block (same order as the model's blocks).
    pub blocks: Vec<BlockPhysics>,
    /// Published per-point coefficients (all points).
    pub coefficients: Vec<PointCoefficients>,
    /// Density of every point (from its block's material).
    pub density: Vec<f64>,
    /// Short-range contact, only when the deck has a `Contact` section (its settings; the
    /// last search and force are the state's, [`crate::state::State::contact`]).
    pub contact: Option<crate::contact::Contact>,
    /// The quadrature volume w_ij of every directed bond (global bond index), `None` when
    /// every block uses the full cell volume ([`crate::model::quadrature`]). Every view of
    /// the reference configuration this type builds carries it.
    bond_volume: Option<Vec<f64>>,
    /// Both directions (i→j, j→i) of every bond that joins two blocks when damage is active.
    /// Each block's damage model only updates its own rows, so without this a bond between a
    /// breakable and an unbreakable block would break from one end only: half a spring that
    /// still pulls, whose force no longer derives from an energy (a ball bonded to a brittle
    /// disk gains kinetic energy from nothing). Such pairs are given the larger damage of the
    /// two directions after every damage update.
    interface_bonds: Vec<(u32, u32)>,
    /// Per block: true when no pair of [`Physics::interface_bonds`] has a bond in the block's
    /// rows, so nothing between the damage update and the bond passes reads or writes them
    /// and the block may break its bonds in its own bond pass ([`fused_pass`]).
    free_of_interface_bonds: Vec<bool>,
}

/// The (bond, reverse bond) pairs of bonds that join different blocks (each pair once), and
/// per block whether none of them lies in its rows (`blocks` blocks).
fn interface_bonds(
    points: &PointCloud,
    bonds: &BondList,
    blocks: usize,
) -> (Vec<(u32, u32)>, Vec<bool>) {
    let mut pairs = Vec::new();
    let mut free = vec![true; blocks];
    // `points.block` names every local point's block, also that of a rank's outer ghost layer,
    // which is in no block's point list (`crate::parallel::Subdomain`): a bond to such a ghost
    // of the same block is no interface bond.
    for i in 0..bonds.num_points() {
        for b in bonds.range(i) {
            let j = bonds.neighbor[b] as usize;
            if j <= i || points.block[i] == points.block[j] {
                continue;
            }
            // Rows are sorted, so the reverse bond is found by binary search; a one-way bond
            // (variable horizons) has no reverse and nothing to keep consistent.
            if let Ok(k) = bonds.family(j).binary_search(&(i as u32)) {
                pairs.push((b as u32, (bonds.offsets[j] + k) as u32));
                free[points.block[i] as usize] = false;
                free[points.block[j] as usize] = false;
            }
        }
    }
    (pairs, free)
}

/// The critical stretch and the material's fast path of a block that breaks its bonds in its
/// own bond pass: its damage model is the constant `Critical Stretch` rule, its material
/// offers the pass, and none of its bonds is an interface bond (`free_of_interface_bonds`),
/// whose damage [`Physics`] makes symmetric between the damage update and the bond passes.
fn fused_pass(
    block: &BlockPhysics,
    free_of_interface_bonds: bool,
) -> Option<(f64, CriticalStretchFastPath<'_>)> {
    if !free_of_interface_bonds {
        return None;
    }
    let limit = block.damage.as_ref()?.fusable_critical_stretch()?;
    Some((limit, block.material.critical_stretch_fast_path()?))
}

impl Physics {
    /// Assembles blocks (materials already set up) for `points`, and computes the constant
    /// coefficients of materials that have no dilatation pass. The bond damage lives in the
    /// state ([`crate::state::State::bond_damage`]), allocated when
    /// [`Physics::has_bond_damage`].
    pub fn new(blocks: Vec<BlockPhysics>, points: &PointCloud, bonds: &BondList) -> Self {
        Self::with_bond_volume(blocks, points, bonds, None)
    }

    /// [`Physics::new`] with the per-bond quadrature volumes `bond_volume` (global bond index
    /// of `bonds`; `None`: full cell volumes), which the blocks' materials must have been set
    /// up with.
    pub fn with_bond_volume(
        blocks: Vec<BlockPhysics>,
        points: &PointCloud,
        bonds: &BondList,
        bond_volume: Option<Vec<f64>>,
    ) -> Self {
        let density = points
            .block
            .iter()
            .map(|&b| blocks[b as usize].material.density())
            .collect();
        let (interface_bonds, free_of_interface_bonds) =
            if blocks.iter().any(|b| b.damage.is_some()) {
                interface_bonds(points, bonds, blocks.len())
            } else {
                (Vec::new(), vec![true; blocks.len()])
            };
        let mut physics = Self {
            blocks,
            coefficients: vec![PointCoefficients::default(); points.len()],
            interface_bonds,
            free_of_interface_bonds,
            density,
            contact: None,
            bond_volume,
        };
        let reference =
            ReferenceView::of(bonds, points).with_bond_volume(physics.bond_volume.as_deref());
        let current = CurrentView {
            position: &points.position,
            bond_damage: None,
            history: &NO_HISTORY,
        };
        for block in &physics.blocks {
            if !block.material.needs_dilatation() {
                block.material.compute_point_coefficients(
                    &reference,
                    &current,
                    &mut physics.coefficients,
                );
            }
        }
        physics
    }

    /// Lets the damage model of every block that does not break its bonds in its material's
    /// pass ([`Physics::internal_force`]) prepare its updates ([`DamageModel::prepare`]). The
    /// others never run their update, so a plan would only cost set-up time and memory (the
    /// pair-once plan of `Critical Stretch` took 4 % of a 100-step run of the LAMMPS bench
    /// deck).
    pub fn prepare_damage_updates(&mut self, bonds: &BondList, points: &PointCloud) {
        let reference =
            ReferenceView::of(bonds, points).with_bond_volume(self.bond_volume.as_deref());
        for (block, &free) in self.blocks.iter_mut().zip(&self.free_of_interface_bonds) {
            if fused_pass(block, free).is_some() {
                continue;
            }
            if let Some(damage) = &mut block.damage {
                damage.prepare(&reference, block.material.points());
            }
        }
    }

    /// True when block `block` breaks its bonds in its material's own bond pass instead of in
    /// a separate damage update ([`Physics::internal_force`]).
    pub fn breaks_bonds_in_material_pass(&self, block: usize) -> bool {
        fused_pass(&self.blocks[block], self.free_of_interface_bonds[block]).is_some()
    }

    /// The reference configuration of `points` with families `bonds`, carrying the bond
    /// quadrature volumes.
    pub fn reference<'a>(
        &'a self,
        bonds: &'a BondList,
        points: &'a PointCloud,
    ) -> ReferenceView<'a> {
        ReferenceView::of(bonds, points).with_bond_volume(self.bond_volume.as_deref())
    }

    /// The quadrature-volume accessor of every bond (cell volumes of `points` under the
    /// full-volume rule).
    pub fn bond_volumes<'a>(&'a self, points: &'a PointCloud) -> crate::model::BondVolumes<'a> {
        crate::model::BondVolumes::new(&points.volume, self.bond_volume.as_deref())
    }

    /// Peridigm's `Neighborhood_Volume` of every point: Σ_j w_ij over its family (length³).
    pub fn neighborhood_volume(&self, bonds: &BondList, points: &PointCloud) -> Vec<f64> {
        let volumes = self.bond_volumes(points);
        (0..bonds.num_points())
            .map(|i| {
                bonds
                    .range(i)
                    .map(|b| volumes.of(b, bonds.neighbor[b] as usize))
                    .sum()
            })
            .collect()
    }

    /// Sets the time of the next force evaluation for time-dependent damage parameters.
    pub fn set_time(&mut self, time: f64) -> Result<(), crate::damage::DamageError> {
        for block in &mut self.blocks {
            if let Some(damage) = &mut block.damage {
                damage.set_time(time)?;
            }
        }
        Ok(())
    }

    /// Sets the damage the bonds start the run with (`bond_damage` intact on entry): each
    /// block's damage model initialises its rows ([`DamageModel::initialize`], e.g. the
    /// pre-crack of `Initial Damage`), then the two directions of every bond between blocks
    /// take the larger value, as after every update.
    pub fn initialize_bond_damage(
        &self,
        bonds: &BondList,
        points: &PointCloud,
        bond_damage: &mut [f32],
    ) {
        let reference = self.reference(bonds, points);
        for block in &self.blocks {
            if let Some(damage) = &block.damage {
                damage.initialize(&reference, block.material.points(), bond_damage);
            }
        }
        self.make_interface_bonds_agree(bond_damage);
    }

    /// Gives both directions of every bond between two blocks the larger of their damages.
    fn make_interface_bonds_agree(&self, bond_damage: &mut [f32]) {
        for &(forward, backward) in &self.interface_bonds {
            let (f, b) = (forward as usize, backward as usize);
            let larger = bond_damage[f].max(bond_damage[b]);
            bond_damage[f] = larger;
            bond_damage[b] = larger;
        }
    }

    /// True when some block has a damage model, so the state carries bond damage.
    pub fn has_bond_damage(&self) -> bool {
        self.blocks.iter().any(|b| b.damage.is_some())
    }

    /// True when any material has a dilatation pass.
    pub fn state_based(&self) -> bool {
        self.blocks.iter().any(|b| b.material.needs_dilatation())
    }

    /// Internal force density at the current positions `current` (force/length³). The bond
    /// damage (`Some` exactly when [`Physics::has_bond_damage`]) is updated first, so a bond
    /// that exceeds its limit carries no force in this evaluation (Peridigm's order). Returns
    /// the number of bonds that broke.
    ///
    /// A block whose damage model is the constant `Critical Stretch` rule and whose material
    /// can fold that test into its first bond pass
    /// ([`Material::critical_stretch_fast_path`]) breaks its bonds there instead of in a separate
    /// pass: the same decisions, taken just before each bond is first used, so the damage and
    /// forces are exactly those of the separate update.
    pub fn internal_force(
        &mut self,
        bonds: &BondList,
        points: &PointCloud,
        current: &[[f64; 3]],
        bond_damage: Option<&mut [f32]>,
        history: &mut History,
        force_density: &mut [[f64; 3]],
    ) -> usize {
        let reference =
            ReferenceView::of(bonds, points).with_bond_volume(self.bond_volume.as_deref());
        let mut broken = 0;
        self.publish_thermal_strain(history);
        let Some(bond_damage) = bond_damage else {
            self.internal_force_with_damage_fixed(
                bonds,
                points,
                current,
                None,
                history,
                force_density,
            );
            return 0;
        };
        // The critical stretch and fast path of each block that breaks its bonds in its own
        // bond pass.
        let fused: Vec<Option<(f64, CriticalStretchFastPath<'_>)>> = self
            .blocks
            .iter()
            .zip(&self.free_of_interface_bonds)
            .map(|(block, &free)| fused_pass(block, free))
            .collect();
        for (block, fused) in self.blocks.iter().zip(&fused) {
            if let (Some(damage), None) = (&block.damage, fused) {
                let points = block.material.points();
                broken += match history.thermal() {
                    None => damage.update(&reference, current, points, bond_damage),
                    Some(thermal) => damage.update_at_temperature(
                        &reference,
                        current,
                        &thermal.change,
                        points,
                        bond_damage,
                    ),
                };
            }
        }
        self.make_interface_bonds_agree(bond_damage);
        self.update_history(&reference, current, Some(&bond_damage[..]), history);
        let history = &*history;
        // Fused blocks have no bond to another block, so nothing above reads or writes their
        // rows, and their passes below see the damage as a separate update would leave it.
        for (block, fused) in self.blocks.iter().zip(&fused) {
            match fused {
                Some((limit, CriticalStretchFastPath::PointCoefficients(pass))) => {
                    broken += pass.compute_point_coefficients_breaking_bonds(
                        &reference,
                        current,
                        *limit,
                        bond_damage,
                        &mut self.coefficients,
                    );
                }
                _ if block.material.needs_dilatation() => {
                    let view = CurrentView {
                        position: current,
                        bond_damage: Some(&bond_damage[..]),
                        history,
                    };
                    block.material.compute_point_coefficients(
                        &reference,
                        &view,
                        &mut self.coefficients,
                    );
                }
                _ => {}
            }
        }
        force_density.iter_mut().for_each(|f| *f = [0.0; 3]);
        for (block, fused) in self.blocks.iter().zip(&fused) {
            match fused {
                Some((limit, CriticalStretchFastPath::Force(pass))) => {
                    broken += pass.add_force_density_breaking_bonds(
                        &reference,
                        current,
                        *limit,
                        bond_damage,
                        &self.coefficients,
                        force_density,
                    );
                }
                _ => {
                    let view = CurrentView {
                        position: current,
                        bond_damage: Some(&bond_damage[..]),
                        history,
                    };
                    block.material.add_force_density(
                        &reference,
                        &view,
                        &self.coefficients,
                        force_density,
                    );
                }
            }
        }
        broken
    }

    /// Lets every block skip the force of the points for which `keep` is false
    /// ([`crate::material::Material::restrict_forces`]; a rank keeps its owned points).
    pub fn restrict_forces(&mut self, keep: &dyn Fn(u32) -> bool) {
        for block in &mut self.blocks {
            block.material.restrict_forces(keep);
        }
    }

    /// Internal force density at `current` with the bond damage left as it is (no bond breaks).
    /// Implicit solvers use it for the probes of Jacobian-free directional derivatives.
    pub fn internal_force_with_damage_fixed(
        &mut self,
        bonds: &BondList,
        points: &PointCloud,
        current: &[[f64; 3]],
        bond_damage: Option<&[f32]>,
        history: &mut History,
        force_density: &mut [[f64; 3]],
    ) {
        let reference =
            ReferenceView::of(bonds, points).with_bond_volume(self.bond_volume.as_deref());
        self.publish_thermal_strain(history);
        self.update_history(&reference, current, bond_damage, history);
        let view = CurrentView {
            position: current,
            bond_damage,
            history,
        };
        for block in &self.blocks {
            if block.material.needs_dilatation() {
                block.material.compute_point_coefficients(
                    &reference,
                    &view,
                    &mut self.coefficients,
                );
            }
        }
        force_density.iter_mut().for_each(|f| *f = [0.0; 3]);
        for block in &self.blocks {
            block
                .material
                .add_force_density(&reference, &view, &self.coefficients, force_density);
        }
    }

    /// The free thermal strain α ΔT of every point, α the `Thermal Expansion Coefficient` of
    /// the point's material (0 without one), from the temperature change the conditions set
    /// ([`crate::history::Thermal::strain`]), and ΔT as this evaluation sees it
    /// ([`crate::history::Thermal::evaluated`]); nothing in a run without point temperatures.
    fn publish_thermal_strain(&self, history: &mut History) {
        let Some(thermal) = history.thermal_mut() else {
            return;
        };
        for block in &self.blocks {
            let alpha = block.material.thermal_expansion().unwrap_or(0.0);
            for &p in block.material.points() {
                let p = p as usize;
                thermal.strain[p] = alpha * thermal.change[p];
            }
        }
        thermal
            .evaluated
            .trial_mut()
            .copy_from_slice(&thermal.change);
    }

    /// Advances every block's history fields to `current` (committed values read, trial values
    /// written; [`crate::material::Material::update_history`]).
    fn update_history(
        &self,
        reference: &ReferenceView<'_>,
        current: &[[f64; 3]],
        bond_damage: Option<&[f32]>,
        history: &mut History,
    ) {
        let view = CurrentView {
            position: current,
            bond_damage,
            history: &NO_HISTORY,
        };
        for block in &self.blocks {
            block.material.update_history(reference, &view, history);
        }
    }

    /// Stored elastic energy density of every point at `current` with `bond_damage` (uses the
    /// coefficients of the last force evaluation at the same positions).
    pub fn stored_energy_density(
        &self,
        bonds: &BondList,
        points: &PointCloud,
        current: &[[f64; 3]],
        bond_damage: Option<&[f32]>,
        history: &History,
        energy_density: &mut [f64],
    ) {
        let reference = self.reference(bonds, points);
        let view = CurrentView {
            position: current,
            bond_damage,
            history,
        };
        for block in &self.blocks {
            block.material.stored_energy_density(
                &reference,
                &view,
                &self.coefficients,
                energy_density,
            );
        }
    }

    /// Peridigm's `Partial_Stress` of every point at `current` with `bond_damage` and the
    /// point temperatures of `history` ([`crate::material::Material::partial_stress`]; zero
    /// where the model has none).
    pub fn partial_stress(
        &self,
        bonds: &BondList,
        points: &PointCloud,
        current: &[[f64; 3]],
        bond_damage: Option<&[f32]>,
        history: &History,
        out: &mut [[f64; 9]],
    ) {
        let reference = self.reference(bonds, points);
        let view = CurrentView {
            position: current,
            bond_damage,
            history,
        };
        out.fill([0.0; 9]);
        for block in &self.blocks {
            block.material.partial_stress(&reference, &view, out);
        }
    }

    /// The hourglass-control force density of every point (correspondence models; zero
    /// elsewhere) at `current` with `bond_damage`, from the history of the last force
    /// evaluation.
    pub fn hourglass_force_density(
        &self,
        bonds: &BondList,
        points: &PointCloud,
        current: &[[f64; 3]],
        bond_damage: Option<&[f32]>,
        history: &History,
        out: &mut [[f64; 3]],
    ) {
        let reference = self.reference(bonds, points);
        let view = CurrentView {
            position: current,
            bond_damage,
            history,
        };
        for block in &self.blocks {
            block
                .material
                .add_hourglass_force_density(&reference, &view, out);
        }
    }

    /// Point damage (broken fraction of each family) from `bond_damage`; zero without damage
    /// models.
    pub fn point_damage(&self, bonds: &BondList, bond_damage: Option<&[f32]>, damage: &mut [f64]) {
        damage.iter_mut().for_each(|d| *d = 0.0);
        if let Some(bond_damage) = bond_damage {
            for block in &self.blocks {
                point_damage(bonds, bond_damage, block.material.points(), damage);
            }
        }
    }

    /// Peridigm's critical time step over all blocks (`None` if no point has a neighbour).
    pub fn critical_time_step(&self, bonds: &BondList, points: &PointCloud) -> Option<f64> {
        let reference = self.reference(bonds, points);
        self.blocks
            .iter()
            .filter_map(|b| b.material.critical_time_step(&reference))
            .reduce(f64::min)
    }
}

/// The deformed configuration a tangent is taken at: current positions and the bond damage
/// held fixed.
#[derive(Debug, Clone, Copy)]
pub struct Configuration<'a> {
    /// Current positions Y = X + u (length), all points.
    pub position: &'a [[f64; 3]],
    /// Bond damage per directed bond, when some block has a damage model.
    pub bond_damage: Option<&'a [f32]>,
    /// The materials' history (the tangent differentiates the trial update from the
    /// committed values).
    pub history: &'a History,
}

impl<'a> Configuration<'a> {
    /// The materials' view of this configuration.
    fn view(self) -> CurrentView<'a> {
        CurrentView {
            position: self.position,
            bond_damage: self.bond_damage,
            history: self.history,
        }
    }
}

/// The tangent stiffness ∂(V f)/∂u for implicit solvers (see [`crate::tangent`]).
impl Physics {
    /// The block pattern the materials need: the widest declared reach of the blocks'
    /// materials ([`Reach::OneHop`]: [`BlockPattern::one_hop`], else
    /// [`BlockPattern::two_hop`]).
    pub fn tangent_pattern(&self, bonds: &BondList) -> BlockPattern {
        let reach = self
            .blocks
            .iter()
            .map(|b| b.material.declaration().reach)
            .max()
            .unwrap_or(Reach::OneHop);
        match reach {
            Reach::OneHop => BlockPattern::one_hop(bonds),
            Reach::TwoHop => BlockPattern::two_hop(bonds),
        }
    }

    /// Assembles `J = ∂(V f)/∂u` (force/length) in `configuration` (its bond damage held
    /// fixed: damage is not updated here), each block by the method chosen in
    /// the deck ([`crate::material::Material::tangent_method`]; analytic by default). The
    /// pattern of `tangent` must come from [`Physics::tangent_pattern`]. Points without an
    /// intact bond get zero rows. On error the contents of `tangent` are unspecified.
    pub fn tangent(
        &self,
        bonds: &BondList,
        points: &PointCloud,
        configuration: Configuration<'_>,
        tangent: &mut BlockTangent,
    ) -> Result<(), TangentError> {
        self.assemble_tangent(bonds, points, configuration, None, tangent)
    }

    /// As [`Physics::tangent`] with `method` for every block (tests and cross-checks).
    pub fn tangent_with(
        &self,
        bonds: &BondList,
        points: &PointCloud,
        configuration: Configuration<'_>,
        method: TangentMethod,
        tangent: &mut BlockTangent,
    ) -> Result<(), TangentError> {
        self.assemble_tangent(bonds, points, configuration, Some(method), tangent)
    }

    /// Only the 3×3 diagonal blocks J_ii (block-Jacobi preconditioning, JFNK), in point
    /// order, without allocating the full pattern. Each point's force state is still
    /// differentiated in full (its diagonal block gathers the derivatives of its neighbours'
    /// force states too).
    pub fn block_diagonal_tangent(
        &self,
        bonds: &BondList,
        points: &PointCloud,
        configuration: Configuration<'_>,
    ) -> Result<Vec<[[f64; 3]; 3]>, TangentError> {
        let pattern = std::sync::Arc::new(BlockPattern::diagonal(points.len()));
        let mut tangent = BlockTangent::zeros(pattern);
        self.assemble_tangent(bonds, points, configuration, None, &mut tangent)?;
        Ok(tangent.blocks)
    }

    fn assemble_tangent(
        &self,
        bonds: &BondList,
        points: &PointCloud,
        configuration: Configuration<'_>,
        method: Option<TangentMethod>,
        tangent: &mut BlockTangent,
    ) -> Result<(), TangentError> {
        let reference = self.reference(bonds, points);
        let view = configuration.view();
        tangent.fill_zero();
        for block in &self.blocks {
            let method = method.unwrap_or_else(|| block.material.tangent_method());
            block
                .material
                .add_tangent(&reference, &view, method, tangent)
                .map_err(|e| match e {
                    TangentError::NonFinite { point, .. } => TangentError::NonFinite {
                        point,
                        input_id: points.original_id.get(point).map(|&id| id as usize + 1),
                    },
                    other => other,
                })?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::damage::CriticalStretch;
    use crate::material::{InfluenceFunction, LinearPeridynamicSolid};
    use crate::model::test_support::{brute_force_bonds, lattice};

    /// Physics of a 5³ lattice (spacing 1, δ = 1.8) whose points `block_of` labels, every
    /// block LPS with a constant critical stretch, set up on the points `listed` accepts.
    fn lattice_physics(
        blocks: u32,
        block_of: impl Fn([f64; 3]) -> u32,
        listed: impl Fn([f64; 3]) -> bool,
    ) -> Physics {
        let x = lattice(5);
        let mut points = PointCloud::default();
        for &p in &x {
            points.push(p, 1.0, block_of(p));
        }
        let bonds = brute_force_bonds(&x, 1.8);
        let reference = ReferenceView::of(&bonds, &points);
        let blocks = (0..blocks)
            .map(|b| {
                let mut material = LinearPeridynamicSolid::new(
                    &crate::material::BlockInput {
                        density: 1.0,
                        horizon: 1.8,
                        influence: InfluenceFunction::One,
                    },
                    &crate::material::ElasticConstants {
                        bulk_modulus: 1.0,
                        shear_modulus: 0.5,
                    },
                )
                .unwrap();
                let members = (0..x.len() as u32)
                    .filter(|&i| points.block[i as usize] == b && listed(x[i as usize]))
                    .collect();
                crate::material::set_up(&mut material, &reference, members);
                BlockPhysics {
                    material: Box::new(material),
                    damage: Some(Box::new(CriticalStretch::new(0.01).unwrap())),
                }
            })
            .collect();
        Physics::new(blocks, &points, &bonds)
    }

    #[test]
    fn a_block_breaks_its_bonds_in_its_own_pass_unless_a_bond_joins_another_block() {
        let whole = lattice_physics(1, |_| 0, |_| true);
        assert!(whole.breaks_bonds_in_material_pass(0));
        // A rank's outer ghost layer: points of the block in no block's list. Bonds to them
        // join no other block, so the pass stays fused.
        let without_shell = lattice_physics(1, |_| 0, |p| p[0] < 3.0);
        assert!(without_shell.breaks_bonds_in_material_pass(0));
        // Two bonded blocks: the interface bonds' damage is made symmetric between the update
        // and the bond passes, so neither block may decide its bonds in its own pass.
        let split = lattice_physics(2, |p| u32::from(p[0] > 2.0), |_| true);
        assert!(!split.breaks_bonds_in_material_pass(0));
        assert!(!split.breaks_bonds_in_material_pass(1));
    }
}
