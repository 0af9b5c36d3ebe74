//! What an implicit solve needs from the run when it is distributed over MPI ranks: the halo
//! exchange of a point field, sums over ranks, and which local points are ghosts, all through
//! the run's [`crate::parallel::Ranks`] (here named [`Collective`]). A serial run passes
//! [`SerialRun`], whose operations are free; a distributed run passes its
//! [`crate::parallel::SubdomainRanks`].
//!
//! Every method except the queries is collective: all ranks call it in the same order.

use crate::backend::{Csr, SolveError};
use crate::model::Model;
use crate::physics::Physics;
use crate::solver::implicit::{rank_deficient_points, DofMap, ImplicitSystem};
use crate::state::State;

/// The collective operations and the ownership queries of an implicit solve: the run's
/// [`Ranks`](crate::parallel::Ranks).
pub use crate::parallel::Ranks as Collective;
/// A run on one rank: the no-op [`Collective`].
pub use crate::parallel::SerialRanks as SerialRun;

/// On several ranks every rank fails when one does (collective): the failing rank keeps its
/// error, the others get [`SolveError::OtherRank`], so that no rank waits in a collective for
/// a rank that left.
pub fn agree<T>(
    collective: &mut dyn Collective,
    result: Result<T, SolveError>,
) -> Result<T, SolveError> {
    // Every rank takes part in the sum, the failing ones too.
    let failed_somewhere = any_failed(collective, result.is_err());
    match result {
        Ok(_) if failed_somewhere => Err(SolveError::OtherRank),
        other => other,
    }
}

/// True when `failed` holds on any rank (collective; no message on one rank).
pub fn any_failed(collective: &mut dyn Collective, failed: bool) -> bool {
    if collective.ranks() == 1 {
        return failed;
    }
    let mut failures = [f64::from(u8::from(failed))];
    collective.sum(&mut failures);
    failures[0] > 0.0
}

/// Σ v² over the ranks.
pub fn squared_norm(values: &[f64], collective: &mut dyn Collective) -> f64 {
    let mut sum = [values.iter().map(|v| v * v).sum::<f64>()];
    collective.sum(&mut sum);
    sum[0]
}

/// The rank-deficient points ([`rank_deficient_points`]) as local indices; on several ranks
/// each rank judges the points it owns (ghost rows may be truncated) and the verdicts are
/// shared, so that every rank holds the same points.
pub fn deficient_points(model: &Model, state: &State, collective: &mut dyn Collective) -> Vec<u32> {
    let local = rank_deficient_points(model, state.bond_damage());
    if collective.ranks() == 1 {
        return local;
    }
    let mut flags = vec![0.0; collective.global_points()];
    for &p in local.iter().filter(|&&p| !collective.is_ghost(p as usize)) {
        flags[collective.global_point(p as usize)] = 1.0;
    }
    collective.sum(&mut flags);
    (0..model.points.len() as u32)
        .filter(|&p| flags[collective.global_point(p as usize)] > 0.0)
        .collect()
}

/// The unknowns of this rank: the free dofs of the points it owns, minus those of `held`
/// points (sorted local indices).
pub fn owned_unknowns(
    model: &Model,
    constrained: &[usize],
    held: &[u32],
    collective: &dyn Collective,
) -> DofMap {
    let mut excluded = held.to_vec();
    excluded.extend((0..model.points.len() as u32).filter(|&p| collective.is_ghost(p as usize)));
    excluded.sort_unstable();
    excluded.dedup();
    DofMap::new(model.points.len(), constrained, &excluded)
}

/// The global id `3·(run-wide point) + component` of a local dof.
pub fn global_dof(collective: &dyn Collective, dof: usize) -> usize {
    3 * collective.global_point(dof / 3) + dof % 3
}

/// The tangent of a distributed solve: assembled over the free dofs of owned and ghost
/// points, of which the rows of this rank's unknowns are kept, with global column ids.
pub struct ColumnMap {
    /// Free dofs of all local points.
    pub dofs: DofMap,
    /// Rows of the local tangent that belong to this rank's unknowns, in order.
    kept_rows: Vec<usize>,
    /// Global id of every column.
    global: Vec<usize>,
}

impl ColumnMap {
    /// The columns of a rank whose unknowns exclude the `held` points: every free dof of the
    /// local points, the ghosts' prescribed dofs excluded.
    pub fn new(
        model: &Model,
        constrained: &[usize],
        held: &[u32],
        collective: &dyn Collective,
    ) -> Self {
        let mut prescribed = constrained.to_vec();
        prescribed.extend(collective.ghost_constrained_dofs());
        prescribed.sort_unstable();
        prescribed.dedup();
        let dofs = DofMap::new(model.points.len(), &prescribed, held);
        let kept_rows = dofs
            .free
            .iter()
            .enumerate()
            .filter(|(_, &d)| !collective.is_ghost(d / 3))
            .map(|(row, _)| row)
            .collect();
        let global = dofs
            .free
            .iter()
            .map(|&d| global_dof(collective, d))
            .collect();
        Self {
            dofs,
            kept_rows,
            global,
        }
    }

    /// The kept rows of `matrix` (assembled over [`ColumnMap::dofs`]) with global columns.
    pub fn owned_rows(&self, matrix: &Csr, global_columns: usize) -> Csr {
        let mut out = Csr {
            nrows: self.kept_rows.len(),
            ncols: global_columns,
            offsets: vec![0],
            columns: Vec::new(),
            values: Vec::new(),
        };
        for &row in &self.kept_rows {
            let range = matrix.offsets[row]..matrix.offsets[row + 1];
            out.columns.extend(
                matrix.columns[range.clone()]
                    .iter()
                    .map(|&c| self.global[c]),
            );
            out.values.extend_from_slice(&matrix.values[range]);
            out.offsets.push(out.columns.len());
        }
        out
    }

    /// The stiffness rows of this rank's unknowns (global columns) at the state.
    pub fn stiffness(
        &self,
        system: &mut ImplicitSystem,
        model: &Model,
        physics: &Physics,
        state: &State,
        collective: &dyn Collective,
    ) -> Result<Csr, SolveError> {
        let unknowns = std::mem::replace(&mut system.dofs, self.dofs.clone());
        let matrix = system.stiffness(model, physics, state);
        system.dofs = unknowns;
        Ok(self.owned_rows(&matrix?, 3 * collective.global_points()))
    }
}
