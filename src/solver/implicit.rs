//! What every implicit solver shares: which dofs are unknowns, the one residual built on the
//! internal-force path, and the stiffness matrix over the unknowns.
//!
//! # Kinematic dofs are eliminated
//! Prescribed displacements are set in the displacement field before a solve and their rows
//! and columns are dropped from the system, so the linear solvers see only free dofs. Peridigm
//! instead keeps them, zeroes their rows and columns and writes the mean absolute diagonal on
//! the diagonal; both give the same solution, but elimination keeps the matrix SPD without a
//! scale to choose, makes the system smaller, and leaves no artificial eigenvalue to slow CG.
//!
//! # Units
//! The residual is in force units, `r_k = V_i (f_i + b_i − ρ a_i)_k` (the inertia term only for
//! Newmark-β), and the stiffness is `K = −∂r/∂u` in force/length, so residual and matrix agree
//! (Peridigm's Newmark, `executeImplicit` in `src/core/Peridigm.cpp`, mixes force density in
//! the residual with force in the Jacobian). Multiplying rows by V keeps K symmetric.

use crate::backend::{Csr, SolveError};
use crate::boundary::BoundaryError;
use crate::model::Model;
use crate::physics::{Configuration, Physics};
use crate::state::{Staged, State};
use crate::tangent::BlockTangent;

/// Which dofs are unknowns and where they sit in the reduced vectors.
#[derive(Debug, Clone, PartialEq)]
pub struct DofMap {
    /// Global dof (`3·point + component`) of every unknown, increasing.
    pub free: Vec<usize>,
    /// Reduced index of every global dof, `None` for prescribed or held dofs.
    pub index: Vec<Option<usize>>,
    /// Unknowns grouped by point: group k is `free[groups[k]..groups[k + 1]]` (≤ 3 dofs), the
    /// blocks of the block-Jacobi preconditioner.
    pub groups: Vec<usize>,
}

impl DofMap {
    /// Unknowns of `num_points` points: every dof except the `constrained` ones (sorted global
    /// dofs) and all three dofs of every point in `held` (sorted point indices).
    pub fn new(num_points: usize, constrained: &[usize], held: &[u32]) -> Self {
        let mut index = vec![None; 3 * num_points];
        let mut free = Vec::with_capacity(3 * num_points);
        let mut groups = vec![0];
        let (mut c, mut h) = (0, 0);
        for point in 0..num_points {
            while h < held.len() && (held[h] as usize) < point {
                h += 1;
            }
            let point_held = h < held.len() && held[h] as usize == point;
            for component in 0..3 {
                let dof = 3 * point + component;
                while c < constrained.len() && constrained[c] < dof {
                    c += 1;
                }
                let prescribed = c < constrained.len() && constrained[c] == dof;
                if !prescribed && !point_held {
                    index[dof] = Some(free.len());
                    free.push(dof);
                }
            }
            if *groups.last().unwrap() != free.len() {
                groups.push(free.len());
            }
        }
        Self {
            free,
            index,
            groups,
        }
    }

    /// Number of unknowns.
    pub fn len(&self) -> usize {
        self.free.len()
    }

    /// True when nothing is unknown.
    pub fn is_empty(&self) -> bool {
        self.free.is_empty()
    }

    /// Copies the unknowns out of a point field.
    pub fn gather(&self, field: &[[f64; 3]], out: &mut [f64]) {
        for (o, &dof) in out.iter_mut().zip(&self.free) {
            *o = field[dof / 3][dof % 3];
        }
    }

    /// Writes the unknowns into a point field (other dofs untouched).
    pub fn scatter(&self, values: &[f64], field: &mut [[f64; 3]]) {
        for (&v, &dof) in values.iter().zip(&self.free) {
            field[dof / 3][dof % 3] = v;
        }
    }
}

/// Newmark-β terms of the residual: `a = (u − ũ)/(βΔt²)`.
#[derive(Debug, Clone)]
pub struct Inertia {
    /// Predictor ũ = u_n + Δt v_n + ½Δt²(1 − 2β) a_n.
    pub predictor: Vec<[f64; 3]>,
    /// 1/(βΔt²).
    pub factor: f64,
}

/// The nonlinear system of one load step or time step: unknowns and the reusable tangent.
///
/// The state's staged fields (bond damage, material history) keep their committed values
/// from the start of the step: every residual evaluation starts from them, so bonds broken by
/// an unconverged iterate heal until the step is accepted and the driver commits the state
/// (Peridigm's rule: `src/core/Peridigm_ModelEvaluator.cpp` resets bond damage to the step's
/// start before every evaluation).
pub struct ImplicitSystem {
    /// Unknowns.
    pub dofs: DofMap,
    /// Inertia terms (Newmark-β), none for quasi-statics.
    pub inertia: Option<Inertia>,
    tangent: Option<BlockTangent>,
    /// Residual evaluations so far (for the solver report).
    pub residual_evaluations: usize,
    /// Bytes of the last assembled tangent and its reduced CSR copy.
    pub tangent_bytes: usize,
}

impl ImplicitSystem {
    /// A system over `dofs` that starts from the state's staged fields as they are now: they
    /// become the committed values ([`State::keep_committed`]).
    pub fn new(dofs: DofMap, state: &mut State) -> Self {
        state.keep_committed();
        Self {
            dofs,
            inertia: None,
            tangent: None,
            residual_evaluations: 0,
            tangent_bytes: 0,
        }
    }

    /// Residual at `state.displacement` over the unknowns (force units). Damage restarts from
    /// the committed state and is updated by this evaluation; `state.force_density` and
    /// `state.current_position` are left consistent with the displacement. Returns the number
    /// of bonds broken relative to the committed state.
    pub fn residual(
        &mut self,
        model: &Model,
        physics: &mut Physics,
        state: &mut State,
        residual: &mut [f64],
    ) -> Result<usize, SolveError> {
        state.restore();
        self.residual_keeping_damage(model, physics, state, residual, true)
    }

    /// Residual with the damage left as it is (`update_damage = false` freezes it: used for
    /// the directional derivatives of Jacobian-free Newton–Krylov, where a probe must not
    /// break bonds).
    pub fn residual_keeping_damage(
        &mut self,
        model: &Model,
        physics: &mut Physics,
        state: &mut State,
        residual: &mut [f64],
        update_damage: bool,
    ) -> Result<usize, SolveError> {
        self.residual_evaluations += 1;
        state.update_current_position(&model.points.position);
        let broken = if update_damage {
            super::explicit::internal_force(model, physics, state)
        } else {
            physics.internal_force_with_damage_fixed(
                &model.bonds,
                &model.points,
                &state.current_position,
                state.bond_damage.as_ref().map(Staged::trial),
                &mut state.history,
                &mut state.force_density,
            );
            0
        };
        let volume = &model.points.volume;
        let external = state.external_force_density.as_deref();
        for (r, &dof) in residual.iter_mut().zip(&self.dofs.free) {
            let (p, k) = (dof / 3, dof % 3);
            let mut force = state.force_density[p][k] + external.map_or(0.0, |b| b[p][k]);
            if let Some(inertia) = &self.inertia {
                let acceleration =
                    (state.displacement[p][k] - inertia.predictor[p][k]) * inertia.factor;
                force -= physics.density[p] * acceleration;
            }
            *r = volume[p] * force;
        }
        if let Some(bad) = residual.iter().position(|r| !r.is_finite()) {
            let dof = self.dofs.free[bad];
            return Err(SolveError::NonFinite {
                what: format!(
                    "the residual (point {}, component {})",
                    model.points.original_id[dof / 3] + 1,
                    ["x", "y", "z"][dof % 3]
                ),
            });
        }
        Ok(broken)
    }

    /// Stiffness `K = −∂r/∂u` over the unknowns at the positions of the last residual
    /// evaluation, with the damage of that evaluation.
    pub fn stiffness(
        &mut self,
        model: &Model,
        physics: &Physics,
        state: &State,
    ) -> Result<Csr, SolveError> {
        let tangent = match &mut self.tangent {
            Some(t) => t,
            None => self.tangent.insert(BlockTangent::zeros(std::sync::Arc::new(
                physics.tangent_pattern(&model.bonds),
            ))),
        };
        physics
            .tangent(&model.bonds, &model.points, configuration(state), tangent)
            .map_err(|e| SolveError::Breakdown {
                method: "tangent",
                reason: e.to_string(),
            })?;
        let mut matrix = tangent.to_csr(&self.dofs.index, -1.0);
        if let Some(inertia) = &self.inertia {
            // ∂(−V ρ a)/∂u = −V ρ/(βΔt²) on the diagonal, so K gains +V ρ/(βΔt²).
            for (row, &dof) in self.dofs.free.iter().enumerate() {
                let p = dof / 3;
                let (start, end) = (matrix.offsets[row], matrix.offsets[row + 1]);
                let k = matrix.columns[start..end]
                    .binary_search(&row)
                    .expect("the tangent pattern holds every diagonal entry");
                matrix.values[start + k] +=
                    model.points.volume[p] * physics.density[p] * inertia.factor;
            }
        }
        self.tangent_bytes = tangent.memory_bytes() + matrix.memory_bytes();
        Ok(matrix)
    }

    /// Diagonal 3×3 blocks of K over the unknowns, grouped as [`DofMap::groups`], for the
    /// block-Jacobi preconditioner of matrix-free solves (no full tangent is assembled).
    pub fn block_diagonal(
        &self,
        model: &Model,
        physics: &Physics,
        state: &State,
    ) -> Result<Vec<f64>, SolveError> {
        let blocks = physics
            .block_diagonal_tangent(&model.bonds, &model.points, configuration(state))
            .map_err(|e| SolveError::Breakdown {
                method: "tangent",
                reason: e.to_string(),
            })?;
        // Each group's dense block, row-major, sized by the group (≤ 3×3).
        let mut out = Vec::new();
        for g in 0..self.dofs.groups.len() - 1 {
            let dofs = &self.dofs.free[self.dofs.groups[g]..self.dofs.groups[g + 1]];
            let p = dofs[0] / 3;
            for &row in dofs {
                for &column in dofs {
                    let mut value = -blocks[p][row % 3][column % 3];
                    if row == column {
                        if let Some(inertia) = &self.inertia {
                            value += model.points.volume[p] * physics.density[p] * inertia.factor;
                        }
                    }
                    out.push(value);
                }
            }
        }
        Ok(out)
    }
}

/// The configuration of the last force evaluation: current positions and trial bond damage.
fn configuration(state: &State) -> Configuration<'_> {
    Configuration {
        position: &state.current_position,
        bond_damage: state.bond_damage(),
        history: &state.history,
    }
}

/// Sets the time-dependent loads of an implicit step ending at `time`: the body force, the
/// prescribed temperature and the parameters of time-dependent damage models. A failing expression is reported like a failing
/// boundary-condition expression.
pub fn apply_loads_at(
    model: &Model,
    physics: &mut Physics,
    state: &mut State,
    time: f64,
) -> Result<(), BoundaryError> {
    if let Some(b) = &mut state.external_force_density {
        model.boundary.body_force(&model.points.position, time, b)?;
    }
    model
        .boundary
        .apply_temperature(&model.points.position, time, &mut state.history)?;
    physics
        .set_time(time)
        .map_err(|e| BoundaryError::Evaluation {
            condition: "Damage Models".into(),
            time,
            message: e.to_string(),
        })
}

/// Points whose intact bonds are too few for a stiffness of their own: none at all, or (when
/// bonds can break) at most two, which leaves rotations about the bond line free (Peridigm's
/// `RANK_DEFICIENT_NODES`). Their dofs are held at their current displacement.
pub fn rank_deficient_points(model: &Model, bond_damage: Option<&[f32]>) -> Vec<u32> {
    let bonds = &model.bonds;
    match bond_damage {
        Some(damage) => {
            let all: Vec<u32> = (0..bonds.num_points() as u32).collect();
            crate::damage::rank_deficient_points(bonds, damage, &all)
        }
        None => (0..bonds.num_points())
            .filter(|&i| bonds.family_size(i) == 0)
            .map(|i| i as u32)
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dof_map_drops_prescribed_dofs_and_held_points() {
        // 3 points; dof 1 (point 0, y) prescribed; point 1 held entirely.
        let map = DofMap::new(3, &[1], &[1]);
        assert_eq!(map.free, vec![0, 2, 6, 7, 8]);
        assert_eq!(map.groups, vec![0, 2, 5]);
        assert_eq!(map.index[1], None);
        assert_eq!(map.index[3], None);
        assert_eq!(map.index[6], Some(2));
        let mut field = vec![[0.0; 3]; 3];
        map.scatter(&[1.0, 2.0, 3.0, 4.0, 5.0], &mut field);
        assert_eq!(field, vec![[1.0, 0.0, 2.0], [0.0; 3], [3.0, 4.0, 5.0]]);
        let mut back = vec![0.0; 5];
        map.gather(&field, &mut back);
        assert_eq!(back, vec![1.0, 2.0, 3.0, 4.0, 5.0]);
    }
}
