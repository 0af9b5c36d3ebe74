//! The physics-free nonlinear problem every nonlinear backend solves: find the unknowns x
//! with F(x) = 0.
//!
//! * x: this rank's unknowns (the free dofs of the points it owns), in length units (m);
//!   which origin they are measured from (displacements or current coordinates) is the
//!   problem's choice and only shifts x.
//! * F(x): the residual over the unknowns in force units (N), F = −r = −V ⊙ (f_int + b − ρa),
//!   so that the Jacobian J = ∂F/∂x (N/m) is the symmetric stiffness K.
//! * a Newton correction Δ solves J Δ = −F and moves x to x + αΔ.
//!
//! Backends never see physics: peridyn's Newton ([`crate::solver::newton`]), Trilinos NOX
//! ([`crate::backend::trilinos`], feature `trilinos`) and any further backend (a PETSc SNES
//! would map [`NonlinearProblem::residual`] to `SNESSetFunction`, [`NonlinearProblem::jacobian`]
//! to `SNESSetJacobian`, [`NonlinearProblem::global_ids`] to the layout of its `Vec` and
//! `Mat`, and [`NonlinearProblem::dot`] is what `VecDot` computes over the communicator) call
//! these methods only. The implementation that wraps peridyn's physics is
//! [`crate::solver::problem`].
//!
//! On several ranks every method except the queries is collective: all ranks call it in the
//! same order, and a failure on one rank is a failure on all (the others see
//! [`SolveError::OtherRank`]).

use super::{Csr, SolveError};

/// Why F is evaluated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Evaluation {
    /// At an iterate or a line-search trial: the state (damage included) follows x.
    Iterate,
    /// For a finite-difference or matrix-free directional derivative: the state's history
    /// (bond damage) stays as the last iterate left it, so that a probe breaks no bond.
    Probe,
}

/// A nonlinear problem F(x) = 0 over this rank's unknowns (see the module docs for the
/// formula and units).
pub trait NonlinearProblem {
    /// Number of this rank's unknowns.
    fn len(&self) -> usize;

    /// True when this rank has no unknowns.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Number of ranks the problem is distributed over (1: the whole problem is here).
    fn ranks(&self) -> usize;

    /// The global id of each of this rank's unknowns when the problem is distributed (the
    /// row ids of [`NonlinearProblem::jacobian`]), `None` on one rank (ids 0..len).
    fn global_ids(&self) -> Option<&[usize]>;

    /// The current unknowns (the starting guess before a solve) into `x`.
    fn unknowns(&self, x: &mut [f64]);

    /// Moves the problem to `x` without evaluating anything (e.g. back to the iterate after
    /// directional-derivative probes).
    fn move_to(&mut self, x: &[f64]);

    /// F(x) into `f` (N); the problem is left at x.
    fn residual(
        &mut self,
        x: &[f64],
        f: &mut [f64],
        evaluation: Evaluation,
    ) -> Result<(), SolveError>;

    /// J = ∂F/∂x (N/m) at x, assembled: one row per unknown of this rank, columns numbered
    /// as the unknowns (0..len on one rank, global ids on several). Its pattern is the same
    /// at every x while the unknowns do not change.
    fn jacobian(&mut self, x: &[f64]) -> Result<Csr, SolveError>;

    /// Bytes of the last assembled Jacobian and its work copies (0 before the first).
    fn jacobian_bytes(&self) -> usize;

    /// The unknowns grouped by point: group g holds unknowns `groups[g]..groups[g + 1]`
    /// (one to three each, the free components of one point).
    fn groups(&self) -> &[usize];

    /// The dense diagonal blocks of J at x, one per group, row-major (≤ 3×3 each, N/m): the
    /// block-Jacobi preconditioner of matrix-free solves, assembled without the full J.
    fn block_diagonal(&mut self, x: &[f64]) -> Result<Vec<f64>, SolveError>;

    /// What group `group` stands for, for messages (e.g. `point 12`).
    fn group_label(&self, group: usize) -> String;

    /// Σᵢ aᵢbᵢ over the unknowns of all ranks (collective).
    fn dot(&mut self, a: &[f64], b: &[f64]) -> f64;

    /// True when `failed` holds on any rank (collective): a backend's own failure on one
    /// rank must stop all of them.
    fn any_failed(&mut self, failed: bool) -> bool;

    /// The scalar the nonlinear tolerance is compared with, for F over this rank's unknowns
    /// (collective; the measure the deck's solver chose, e.g. ‖F‖₂ + 20‖F‖∞ in N).
    fn convergence_measure(&mut self, f: &[f64]) -> f64;

    /// The size of the state in the unknowns' length units (m), which sets the step of
    /// finite-difference directional derivatives: forces computed from coordinates Y carry
    /// round-off ε_mach·|Y|, so probes move the largest component by λ·this.
    fn probe_scale(&self) -> f64;

    /// Lets the problem change its unknowns between iterations (e.g. hold the dofs of points
    /// that lost their stiffness); returns true when it did, after which the caller re-reads
    /// [`NonlinearProblem::len`] and the unknowns and re-evaluates F. Solvers that cannot
    /// change their unknowns mid-solve do not call it.
    fn update_unknowns(&mut self) -> Result<bool, SolveError> {
        Ok(false)
    }

    /// A sparse symmetric positive (semi-)definite operator spectrally close to J over this
    /// rank's unknowns, with its near-null space, for algebraic multigrid (see
    /// [`PreconditioningOperator`]); `None` when the problem offers none (the default). As
    /// for [`NonlinearProblem::jacobian`], one row per unknown of this rank and columns
    /// numbered as the unknowns: 0..len on one rank, global ids on several (the couplings
    /// to other ranks' unknowns included).
    fn preconditioning_operator(&mut self) -> Result<Option<PreconditioningOperator>, SolveError> {
        Ok(None)
    }

    /// The near-null space of J over this rank's unknowns (row-major, unknowns × modes: the
    /// rigid-body modes for elasticity, m or m/m), and the number of modes, for algebraic
    /// multigrid preconditioners; `None` (the default) when the problem offers none.
    fn near_null_space(&self) -> Option<(Vec<f64>, usize)> {
        None
    }

    /// A fingerprint of what [`NonlinearProblem::preconditioning_operator`] is built from at
    /// the current iterate (e.g. the unknowns and the bond damage), equal on every rank, so a
    /// caller can keep one operator, across Newton iterations and load steps, until it
    /// changes. Collective on several ranks. The default never changes.
    fn preconditioning_version(&mut self) -> usize {
        0
    }
}

/// The operator multigrid preconditioners are built on (N/m), e.g. the one-hop PMB-like
/// stiffness of [`crate::backend::native::one_hop_operator`], and its near-null space.
#[derive(Debug, Clone)]
pub struct PreconditioningOperator {
    /// The operator: rows this rank's unknowns, columns numbered as the unknowns (global ids
    /// on several ranks).
    pub matrix: Csr,
    /// Row-major, unknowns × `modes` (the rigid-body modes for elasticity, m or m/m).
    pub null_space: Vec<f64>,
    /// Number of near-null-space vectors.
    pub modes: usize,
}

/// `result` when it holds on every rank of `problem`; on several ranks a failure anywhere is
/// a failure everywhere, the other ranks seeing [`SolveError::OtherRank`] (collective).
pub fn agree_over<T>(
    problem: &mut (impl NonlinearProblem + ?Sized),
    result: Result<T, SolveError>,
) -> Result<T, SolveError> {
    let failed_somewhere = problem.any_failed(result.is_err());
    match result {
        Ok(_) if failed_somewhere => Err(SolveError::OtherRank),
        other => other,
    }
}
