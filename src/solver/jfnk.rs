//! Jacobian-free Newton–Krylov: the Newton correction from GMRES on finite-difference
//! directional derivatives of the one residual, `K v ≈ (r(u) − r(u + εv))/ε`, preconditioned by
//! the inverted 3×3 diagonal blocks of the tangent (or their diagonal, or nothing). No tangent
//! is assembled, which is what keeps memory near that of an explicit run.

use crate::backend::native::{
    gmres_matrix_free, KrylovSettings, Preconditioner, PreconditionerOperator,
};
use crate::backend::{Csr, KrylovReport, SolveError};
use crate::io::deck::LinearPreconditioner;
use crate::physics::Physics;
use crate::setup::Model;
use crate::solver::implicit::ImplicitSystem;
use crate::state::State;

/// One Jacobian-free solve of `K Δ = r` at the current iterate (see
/// [`LinearStrategy::MatrixFree`](crate::solver::newton::LinearStrategy::MatrixFree)). The state is back at the iterate on return.
#[allow(clippy::too_many_arguments)]
pub fn solve(
    system: &mut ImplicitSystem,
    model: &Model,
    physics: &mut Physics,
    state: &mut State,
    krylov: &KrylovSettings,
    preconditioner: LinearPreconditioner,
    residual: &[f64],
    correction: &mut [f64],
) -> Result<KrylovReport, SolveError> {
    const LAMBDA: f64 = 1e-7;
    let n = system.dofs.len();
    let operator = match preconditioner {
        LinearPreconditioner::None => None,
        kind => {
            let blocks = system.block_diagonal(model, physics, state)?;
            let matrix = block_diagonal_csr(&system.dofs.groups, &blocks);
            let choice = match kind {
                LinearPreconditioner::Jacobi => Preconditioner::Jacobi,
                _ => Preconditioner::BlockJacobi {
                    groups: system.dofs.groups.clone(),
                },
            };
            Some(PreconditionerOperator::build(&choice, &matrix)?)
        }
    };
    let mut base = vec![0.0; n];
    system.dofs.gather(&state.displacement, &mut base);
    // Forces are computed from positions Y, whose round-off is ε_mach·|Y|, so the probe is
    // scaled by the largest coordinate, not by ‖u‖ (which is 0 at the start of a load step).
    let position_scale = state
        .current_position
        .iter()
        .flat_map(|y| y.iter())
        .fold(0.0f64, |m, y| m.max(y.abs()))
        .max(f64::MIN_POSITIVE);
    let mut probe = vec![0.0; n];
    let mut probe_residual = vec![0.0; n];
    let mut apply = |v: &[f64], out: &mut [f64]| -> Result<(), SolveError> {
        let v_max = v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        if v_max == 0.0 {
            out.iter_mut().for_each(|o| *o = 0.0);
            return Ok(());
        }
        let epsilon = LAMBDA * position_scale / v_max;
        for ((p, b), d) in probe.iter_mut().zip(&base).zip(v) {
            *p = b + epsilon * d;
        }
        system.dofs.scatter(&probe, &mut state.displacement);
        system.residual_keeping_damage(model, physics, state, &mut probe_residual, false)?;
        for ((o, r0), r) in out.iter_mut().zip(residual).zip(&probe_residual) {
            *o = (r0 - r) / epsilon;
        }
        Ok(())
    };
    let identity = |r: &[f64], z: &mut [f64]| z.copy_from_slice(r);
    let report = match &operator {
        Some(op) => gmres_matrix_free(
            &mut apply,
            &|r, z| op.apply(r, z),
            residual,
            correction,
            krylov,
        ),
        None => gmres_matrix_free(&mut apply, &identity, residual, correction, krylov),
    };
    system.dofs.scatter(&base, &mut state.displacement);
    state.update_current_position(&model.points.position);
    report
}

/// A CSR matrix holding only the dense diagonal blocks (row-major per group).
pub(crate) fn block_diagonal_csr(groups: &[usize], blocks: &[f64]) -> Csr {
    let n = *groups.last().unwrap_or(&0);
    let mut matrix = Csr {
        nrows: n,
        ncols: n,
        offsets: vec![0],
        columns: Vec::new(),
        values: Vec::new(),
    };
    let mut at = 0;
    for g in groups.windows(2) {
        for _row in g[0]..g[1] {
            for column in g[0]..g[1] {
                matrix.columns.push(column);
                matrix.values.push(blocks[at]);
                at += 1;
            }
            matrix.offsets.push(matrix.columns.len());
        }
    }
    matrix
}
