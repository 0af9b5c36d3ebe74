//! Jacobian-free Newton–Krylov: the Newton correction from GMRES on finite-difference
//! directional derivatives of the one residual, `K v ≈ (r(u) − r(u + εv))/ε`, preconditioned by
//! the inverted 3×3 diagonal blocks of the tangent (or their diagonal, or nothing), or by the
//! additive two-level smoothed-aggregation multigrid on the one-hop operator (`AMG`). No tangent is
//! assembled, which is what keeps memory near that of an explicit run (the one-hop operator
//! and its hierarchy are O(bonds)).

use crate::backend::native::{
    gmres_matrix_free, KrylovSettings, Preconditioner, PreconditionerOperator,
};
use crate::backend::problem::{Evaluation, NonlinearProblem};
use crate::backend::settings::LinearPreconditioner;
use crate::backend::{block_diagonal_csr, LinearResult, SolveError};
use crate::solver::multigrid::MultigridCache;
use std::time::Instant;

/// One Jacobian-free solve of `J Δ = rhs` (rhs = −F) at the iterate `x` (see
/// [`LinearStrategy::MatrixFree`](crate::solver::newton::LinearStrategy::MatrixFree)): J v is
/// (F(x + εv) − F(x))/ε with ε = λ·[`NonlinearProblem::probe_scale`]/‖v‖∞, λ = 10⁻⁷. The
/// problem is back at `x` on return.
pub fn solve(
    problem: &mut dyn NonlinearProblem,
    krylov: &KrylovSettings,
    preconditioner: LinearPreconditioner,
    multigrid: &mut MultigridCache,
    x: &[f64],
    rhs: &[f64],
    correction: &mut [f64],
) -> LinearResult {
    const LAMBDA: f64 = 1e-7;
    let n = problem.len();
    let operator = match preconditioner {
        LinearPreconditioner::None | LinearPreconditioner::Amg => None,
        kind => {
            let start = Instant::now();
            let blocks = problem.block_diagonal(x)?;
            let matrix = block_diagonal_csr(problem.groups(), &blocks);
            let choice = match kind {
                LinearPreconditioner::Jacobi => Preconditioner::Jacobi,
                _ => Preconditioner::BlockJacobi {
                    groups: problem.groups().to_vec(),
                },
            };
            let operator = PreconditionerOperator::build(&choice, &matrix)?;
            multigrid.add_setup_seconds(start.elapsed().as_secs_f64());
            Some(operator)
        }
    };
    let amg = match preconditioner {
        LinearPreconditioner::Amg => Some(multigrid.hierarchy(problem)?),
        _ => None,
    };
    // Forces are computed from positions Y, whose round-off is ε_mach·|Y|, so the probe is
    // scaled by the largest coordinate, not by ‖u‖ (which is 0 at the start of a load step).
    let position_scale = problem.probe_scale();
    let mut probe = vec![0.0; n];
    let mut probe_residual = vec![0.0; n];
    let mut apply = |v: &[f64], out: &mut [f64]| -> Result<(), SolveError> {
        let v_max = v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        if v_max == 0.0 {
            out.iter_mut().for_each(|o| *o = 0.0);
            return Ok(());
        }
        let epsilon = LAMBDA * position_scale / v_max;
        for ((p, b), d) in probe.iter_mut().zip(x).zip(v) {
            *p = b + epsilon * d;
        }
        problem.residual(&probe, &mut probe_residual, Evaluation::Probe)?;
        // rhs = −F(x), so J v ≈ (F(probe) − F(x))/ε = (rhs + F(probe))/ε.
        for ((o, r0), f) in out.iter_mut().zip(rhs).zip(&probe_residual) {
            *o = (r0 + f) / epsilon;
        }
        Ok(())
    };
    let identity = |r: &[f64], z: &mut [f64]| z.copy_from_slice(r);
    let report = match (&operator, amg) {
        (Some(op), _) => {
            gmres_matrix_free(&mut apply, &|r, z| op.apply(r, z), rhs, correction, krylov)
        }
        (None, Some(amg)) => {
            gmres_matrix_free(&mut apply, &|r, z| amg.apply(r, z), rhs, correction, krylov)
        }
        (None, None) => gmres_matrix_free(&mut apply, &identity, rhs, correction, krylov),
    };
    problem.move_to(x);
    report
}
