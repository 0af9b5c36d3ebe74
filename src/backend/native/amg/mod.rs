//! Smoothed-aggregation algebraic multigrid (Vaněk, Mandel, Brezina 1996) over point groups of
//! 1–3 unknowns, used as the preconditioner M⁻¹ = one V-cycle of native CG, GMRES and JFNK.
//!
//! Setup, level by level until the operator has at most [`COARSE_UNKNOWNS`] unknowns:
//! 1. aggregate the nodes (points, then aggregates) by strength of connection
//!    ([`aggregation`]);
//! 2. the tentative prolongator T from the near-null space (for elasticity the six rigid-body
//!    modes), orthonormalised per aggregate; the coarse near-null space is its R factor;
//! 3. P = (I − ω D⁻¹A) T, ω = 4/(3ρ(D⁻¹A)) ([`prolongator`]);
//! 4. the Galerkin coarse operator Pᵀ A P.
//!
//! [`Amg::apply`] runs the [`Cycle`] the hierarchy was built for. The V-cycle smooths with
//! Chebyshev on block Jacobi before and after the coarse correction and solves the coarsest
//! operator by dense LU ([`cycle`]). The additive form smooths the finest level with its
//! inverted diagonal blocks only, so that level keeps no operator after setup. Either is a
//! fixed linear, symmetric positive definite map when A is SPD, as CG needs.

mod aggregation;
mod compact;
mod cycle;
mod one_hop;
mod pattern;
mod prolongator;

use super::super::{Csr, SolveError};
use std::cell::RefCell;

use super::preconditioner::PreconditionerOperator;
use compact::CompactCsr;
use cycle::{block_jacobi, not_positive_definite, spectral_radius, Chebyshev, DenseLu, Scratch};
pub use one_hop::{
    one_hop_operator, pmb_micromodulus, rigid_body_modes, OneHopInput, Stencil, NEAREST_SHELLS,
};

/// The coarsest level has at most this many unknowns (solved by dense LU: 8 MB, about
/// 10⁸ flops to factor, once per setup).
pub const COARSE_UNKNOWNS: usize = 1000;

/// At most this many levels (the finest included).
const MAX_LEVELS: usize = 12;

/// Strength threshold θ of [`aggregation`] (relative to a node's strongest coupling).
const STRENGTH_THRESHOLD: f64 = 0.5;

/// A coarsening that keeps more than this fraction of the unknowns has stalled (e.g. every
/// node its own aggregate); the hierarchy stops there.
const STALLED_COARSENING: f64 = 0.8;

/// Entries of the prolongators, restrictions and coarse operators of a hierarchy relative to
/// the entries of the one-hop operator it is built on, (nnz(P) + nnz(R) + Σ_{l≥1} nnz(A_l)) /
/// nnz(A_0): 0.94–1.05 measured with [`Stencil::Nearest`] on lattices of 12³ and 16³ points
/// with δ = 3.015 Δx (Peridigm's usual horizon). With the whole family (`Stencil::Family`) it
/// is about 0.5: more bonds a row, the same aggregates.
const TRANSFER_AND_COARSE_FRACTION: f64 = 1.0;

/// Bytes of a stored entry of the hierarchy's matrices ([`compact`]): a single-precision
/// value (4) and a 32-bit column index shared by the rows of a set, the 3 unknowns of a point
/// in the finest prolongator (4/3) and up to the 6 of an aggregate in the restrictions and
/// coarse operators (4/6): 4.7–5.3, planned at 5.
const HIERARCHY_ENTRY_BYTES: f64 = 5.0;

/// (nnz(P₀) + nnz(A₀P₀)) / nnz(A₀), the finest level's products held with the operator during
/// setup: 1.31 measured on the 20,000-point tension block with [`Stencil::Nearest`] (1.60 M +
/// 4.08 M entries over 4.34 M).
const SETUP_PRODUCTS_FRACTION: f64 = 1.3;

/// Levels of the [`Cycle::Additive`] form, finest first, applied additively before the
/// V-cycle of the levels below. Measured on the 160,000-point tension block (Jacobian-free
/// Newton–Krylov, 4 Newton iterations): 1 level takes 137 GMRES iterations, 2 levels 159 in
/// about the same time (each application is cheaper, there are more), and a V-cycle with
/// one Chebyshev step instead of two below the additive level 142, no faster either.
const ADDITIVE_LEVELS: usize = 1;

/// Bonds a point keeps in [`Stencil::Nearest`] on a cubic lattice: its 6 + 12 + 8 neighbours
/// at Δx, √2Δx and √3Δx (fewer in 2-D and at surfaces, so the plan is an upper bound).
const NEAREST_BONDS: u64 = 26;

/// Points per aggregate at δ ≈ 3Δx (32 measured on the 16³ lattice: 3,840 free points, 118
/// aggregates): each level has 6/(3·32) = 1/16 of the unknowns of the level above.
const POINTS_PER_AGGREGATE: u64 = 32;

/// Planned memory of AMG on the one-hop operator (bytes), printed by `peridyn check`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MultigridMemory {
    /// The one-hop operator, held while the hierarchy is built.
    pub operator: u64,
    /// The finest level's products in double precision (P and A P), held with the operator
    /// while the hierarchy is built.
    pub setup_products: u64,
    /// Everything else the hierarchy holds: prolongators, restrictions, coarse operators,
    /// smoothers, the coarsest LU factors and the V-cycle's workspace.
    pub hierarchy: u64,
}

/// The memory of AMG for `points` points with `bonds` directed bonds (every dof counted as
/// an unknown, so prescribed dofs make it an overestimate by their share, twice: rows and
/// columns):
///
/// * one-hop operator ([`Stencil::Nearest`]), held while the hierarchy is built: n₀ = 3N rows
///   and one 3×3 block per kept bond and per point, at most [`NEAREST_BONDS`] bonds a point,
///   nnz₀ = 9(min(B, 26N) + N) entries of 16 bytes (an 8-byte value and an 8-byte column)
///   plus 8(n₀ + 1) bytes of row offsets;
/// * hierarchy ([`Cycle::Additive`], the form the solvers use): [`TRANSFER_AND_COARSE_FRACTION`]
///   × nnz₀ entries of [`HIERARCHY_ENTRY_BYTES`] (see [`compact`]) for the prolongators,
///   restrictions and coarse operators; 88 bytes a point
///   for the finest level's inverted diagonal blocks; the dense LU of the coarsest level,
///   8n² + 8n bytes, where n is n₀ divided by 16 ([`POINTS_PER_AGGREGATE`]) until it is at
///   most [`COARSE_UNKNOWNS`]; an application's workspace, the finest level's prolongated
///   correction and the coarse levels' vectors, planned as 2 vectors of n₀, 16 n₀ bytes.
///
/// * setup products: while the finest level is built, P and A P are held in double precision
///   next to the operator, [`SETUP_PRODUCTS_FRACTION`] × nnz₀ entries of 16 bytes, freed
///   before the Krylov solve starts.
pub fn multigrid_memory_estimate(points: u64, bonds: u64) -> MultigridMemory {
    let unknowns = 3 * points;
    let entries = one_hop_entries(points, bonds);
    let operator = 16 * entries + 8 * (unknowns + 1);
    let mut coarsest = unknowns;
    while coarsest > COARSE_UNKNOWNS as u64 {
        coarsest = coarsest * 6 / (3 * POINTS_PER_AGGREGATE);
    }
    let hierarchy = (TRANSFER_AND_COARSE_FRACTION * HIERARCHY_ENTRY_BYTES * entries as f64) as u64
        + 88 * points
        + 8 * coarsest * coarsest
        + 8 * coarsest
        + 8 * 2 * unknowns;
    MultigridMemory {
        operator,
        setup_products: (SETUP_PRODUCTS_FRACTION * 16.0 * entries as f64) as u64,
        hierarchy,
    }
}

/// nnz₀ of the one-hop operator of [`multigrid_memory_estimate`].
fn one_hop_entries(points: u64, bonds: u64) -> u64 {
    9 * (bonds.min(NEAREST_BONDS * points) + points)
}

/// How [`Amg::apply`] uses the hierarchy.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Cycle {
    /// One V-cycle from z = 0: Chebyshev smoothing before and after the coarse correction
    /// on every level above the coarsest. For an operator that is the system itself.
    VCycle,
    /// The additive two-level form M⁻¹ = D₀⁻¹ + P₀ V₁ R₀: the finest level's inverted
    /// diagonal blocks plus the prolongated V-cycle V₁ of the coarse levels on the restricted
    /// residual (an additive Schwarz preconditioner with the smoothed-aggregation coarse
    /// space; Toselli & Widlund, *Domain Decomposition Methods*, 2005, ch. 2). The finest
    /// operator is dropped once the coarse levels are built.
    ///
    /// This is the form for a stand-in operator such as the one-hop operator, where smoothing
    /// the finest level with the stand-in tunes it to the wrong high frequencies: measured on
    /// the 20,000-point tension block with the nearest-shells stencil, Krylov iterations per
    /// Newton step fell from 45 (V-cycle) to 34, and each application skips the finest
    /// level's five operator products.
    Additive,
}

/// A level of the additive form: no operator, only what M⁻¹ applies.
#[derive(Debug, Clone)]
struct AdditiveLevel {
    /// D₀⁻¹, the inverted diagonal blocks of the finest operator.
    block_jacobi: PreconditionerOperator,
    prolongator: CompactCsr,
    restriction: CompactCsr,
    /// nnz(A₀), for the operator complexity.
    operator_entries: usize,
}

/// What a level keeps besides its transfers, decided by the [`Cycle`] that will apply it.
enum Kept {
    VCycle {
        operator: CompactCsr,
        smoother: Chebyshev,
    },
    Additive {
        block_jacobi: PreconditionerOperator,
        operator_entries: usize,
    },
}

/// One level above the coarsest.
#[derive(Debug, Clone)]
struct Level {
    operator: CompactCsr,
    smoother: Chebyshev,
    prolongator: CompactCsr,
    restriction: CompactCsr,
}

/// How the coarsest operator is solved: LU when small, the smoother alone when coarsening
/// stalled above [`COARSE_UNKNOWNS`] (a dense factor would be too large).
#[derive(Debug, Clone)]
enum Coarsest {
    Lu(DenseLu),
    Smoother(Chebyshev),
}

/// The multigrid hierarchy of one operator: apply it with [`Amg::apply`].
#[derive(Debug, Clone)]
pub struct Amg {
    /// The finest levels when built for [`Cycle::Additive`] with coarse levels below them.
    additive: Vec<AdditiveLevel>,
    /// The V-cycle's levels above the coarsest, finest first (below `additive`).
    levels: Vec<Level>,
    coarsest_operator: CompactCsr,
    coarsest: Coarsest,
    /// The vectors a V-cycle works in, sized at setup so that [`Amg::apply`] allocates
    /// nothing. A `RefCell` because applying M⁻¹ is logically read-only (`&self`, as the
    /// Krylov methods' preconditioner callback is `Fn`); one application runs at a time.
    workspace: RefCell<Workspace>,
}

/// The vectors of one V-cycle.
#[derive(Debug, Clone)]
struct Workspace {
    /// The additive levels' coarse corrections.
    additive: Vec<CoarseWork>,
    /// One per level of [`Amg::levels`](Amg), finest first.
    levels: Vec<LevelWork>,
    /// The coarsest level's smoother scratch (empty when the coarsest is solved by LU).
    coarsest: Scratch,
}

/// The vectors of one level above the coarsest.
#[derive(Debug, Clone)]
struct LevelWork {
    coarse: CoarseWork,
    /// The level's smoother scratch.
    smoothing: Scratch,
}

/// The vectors of a level's coarse correction.
#[derive(Debug, Clone)]
struct CoarseWork {
    /// b − A x, then the prolongated coarse correction (the level's unknowns).
    residual: Vec<f64>,
    /// The restricted residual: the next level's right-hand side.
    coarse_b: Vec<f64>,
    /// The next level's correction.
    coarse_x: Vec<f64>,
}

impl CoarseWork {
    /// For the transfer between a level and the next through `restriction`.
    fn new(restriction: &CompactCsr) -> Self {
        Self {
            residual: vec![0.0; restriction.ncols],
            coarse_b: vec![0.0; restriction.nrows],
            coarse_x: vec![0.0; restriction.nrows],
        }
    }

    fn memory_bytes(&self) -> usize {
        8 * (self.residual.len() + self.coarse_b.len() + self.coarse_x.len())
    }
}

impl Workspace {
    fn new(
        additive: &[AdditiveLevel],
        levels: &[Level],
        coarsest: &Coarsest,
        coarsest_operator: &CompactCsr,
    ) -> Self {
        Self {
            additive: additive
                .iter()
                .map(|level| CoarseWork::new(&level.restriction))
                .collect(),
            levels: levels
                .iter()
                .map(|level| LevelWork {
                    coarse: CoarseWork::new(&level.restriction),
                    smoothing: Scratch::new(level.operator.nrows),
                })
                .collect(),
            coarsest: Scratch::new(match coarsest {
                Coarsest::Lu(_) => 0,
                Coarsest::Smoother(_) => coarsest_operator.nrows,
            }),
        }
    }

    fn memory_bytes(&self) -> usize {
        let levels: usize = self
            .levels
            .iter()
            .map(|l| l.coarse.memory_bytes() + l.smoothing.memory_bytes())
            .sum();
        let additive: usize = self.additive.iter().map(CoarseWork::memory_bytes).sum();
        additive + levels + self.coarsest.memory_bytes()
    }
}

impl Amg {
    /// The hierarchy of the symmetric positive definite `operator`, whose unknowns are grouped
    /// by `groups` (offsets: group g holds unknowns `groups[g]..groups[g + 1]`, as
    /// [`super::Preconditioner::BlockJacobi`]), with the near-null space `null_space`
    /// (row-major: unknowns × `modes`, e.g. the six rigid-body modes of elasticity), for
    /// applications by `cycle`.
    ///
    /// Each level's products are formed in the order that holds the fewest at once: P, then
    /// A P, then (the level's double-precision operator dropped, a V-cycle level keeping its
    /// single-precision copy) R = Pᵀ and R (A P).
    ///
    /// Errors (`Breakdown`): a non-positive or non-finite diagonal entry (not positive
    /// definite), a singular coarsest operator (e.g. nothing prescribed), or `groups` /
    /// `null_space` that do not describe the operator's rows.
    pub fn new(
        operator: Csr,
        groups: &[usize],
        null_space: &[f64],
        modes: usize,
        cycle: Cycle,
    ) -> Result<Self, SolveError> {
        check_input(&operator, groups, null_space, modes)?;
        let mut additive = Vec::new();
        let additive_levels = match cycle {
            Cycle::VCycle => 0,
            Cycle::Additive => ADDITIVE_LEVELS,
        };
        let mut levels = Vec::new();
        let mut operator = operator;
        let mut groups = groups.to_vec();
        let mut null_space = null_space.to_vec();
        while operator.nrows > COARSE_UNKNOWNS && additive.len() + levels.len() + 1 < MAX_LEVELS {
            let strong = aggregation::strong_neighbours(&operator, &groups, STRENGTH_THRESHOLD);
            let aggregates = aggregation::aggregate(&strong);
            drop(strong);
            let tentative = prolongator::tentative(&groups, &aggregates, &null_space, modes);
            if tentative.prolongator.ncols as f64 > STALLED_COARSENING * operator.nrows as f64 {
                break;
            }
            let diagonal = operator.diagonal();
            let rho = spectral_radius(&operator, |r, z| {
                z.iter_mut()
                    .zip(r)
                    .zip(&diagonal)
                    .for_each(|((z, r), d)| *z = r / d)
            });
            let prolongator = prolongator::smooth(&operator, &groups, &tentative.prolongator, rho);
            let product = prolongator::multiply(&operator, &groups, &prolongator, &groups);
            let kept = if additive.len() < additive_levels {
                Kept::Additive {
                    block_jacobi: block_jacobi(&operator, &groups)?,
                    operator_entries: operator.nnz(),
                }
            } else {
                Kept::VCycle {
                    smoother: Chebyshev::new(&operator, &groups)?,
                    operator: CompactCsr::new(&operator, &groups)?,
                }
            };
            // The level's double-precision operator is not needed past A P.
            drop(std::mem::take(&mut operator));
            let restriction = prolongator::transpose(&prolongator);
            let coarse =
                prolongator::multiply(&restriction, &tentative.coarse_groups, &product, &groups);
            drop(product);
            let (prolongator, restriction) = (
                CompactCsr::new(&prolongator, &groups)?,
                CompactCsr::new(&restriction, &tentative.coarse_groups)?,
            );
            match kept {
                Kept::VCycle { operator, smoother } => levels.push(Level {
                    operator,
                    smoother,
                    prolongator,
                    restriction,
                }),
                Kept::Additive {
                    block_jacobi,
                    operator_entries,
                } => additive.push(AdditiveLevel {
                    block_jacobi,
                    prolongator,
                    restriction,
                    operator_entries,
                }),
            }
            operator = coarse;
            groups = tentative.coarse_groups;
            null_space = tentative.coarse_null_space;
        }
        let coarsest = if operator.nrows <= 4 * COARSE_UNKNOWNS {
            Coarsest::Lu(DenseLu::new(&operator)?)
        } else {
            Coarsest::Smoother(Chebyshev::new(&operator, &groups)?)
        };
        let operator = CompactCsr::new(&operator, &groups)?;
        let workspace = RefCell::new(Workspace::new(&additive, &levels, &coarsest, &operator));
        Ok(Self {
            additive,
            levels,
            coarsest_operator: operator,
            coarsest,
            workspace,
        })
    }

    /// Number of levels, the finest and the coarsest included.
    pub fn levels(&self) -> usize {
        self.additive.len() + self.levels.len() + 1
    }

    /// Σ nnz(A_l) / nnz(A_0): the hierarchy's cycle cost relative to the operator (the
    /// additive levels' operators counted although they are not kept).
    pub fn operator_complexity(&self) -> f64 {
        let entries: Vec<usize> = self
            .additive
            .iter()
            .map(|l| l.operator_entries)
            .chain(self.levels.iter().map(|l| l.operator.nnz()))
            .chain([self.coarsest_operator.nnz()])
            .collect();
        entries.iter().sum::<usize>() as f64 / entries[0].max(1) as f64
    }

    /// Bytes the hierarchy holds: every kept level's operator (with [`Cycle::VCycle`] the
    /// finest is the operator it was built on), prolongator, restriction and smoother, the
    /// coarsest solve and the workspace of an application.
    pub fn memory_bytes(&self) -> usize {
        let additive: usize = self
            .additive
            .iter()
            .map(|l| {
                l.block_jacobi.memory_bytes()
                    + l.prolongator.memory_bytes()
                    + l.restriction.memory_bytes()
            })
            .sum();
        let levels: usize = self
            .levels
            .iter()
            .map(|l| {
                l.operator.memory_bytes()
                    + l.prolongator.memory_bytes()
                    + l.restriction.memory_bytes()
                    + l.smoother.memory_bytes()
            })
            .sum();
        let coarsest = match &self.coarsest {
            Coarsest::Lu(lu) => lu.memory_bytes(),
            Coarsest::Smoother(smoother) => smoother.memory_bytes(),
        };
        additive
            + levels
            + self.coarsest_operator.memory_bytes()
            + coarsest
            + self.workspace.borrow().memory_bytes()
    }

    /// A one-line summary for the log, e.g. `AMG, 3 levels (36000 → 912 unknowns, operator
    /// complexity 1.21)`.
    pub fn describe(&self) -> String {
        let finest = match (self.additive.first(), self.levels.first()) {
            (Some(l), _) => l.prolongator.nrows,
            (None, Some(l)) => l.operator.nrows,
            (None, None) => self.coarsest_operator.nrows,
        };
        format!(
            "AMG, {} levels ({finest} → {} unknowns, operator complexity {:.2})",
            self.levels(),
            self.coarsest_operator.nrows,
            self.operator_complexity()
        )
    }

    /// z = M⁻¹ r for the [`Cycle`] the hierarchy was built for, in the hierarchy's workspace
    /// (no allocation). Without levels above the coarsest it is the coarsest solve.
    pub fn apply(&self, r: &[f64], z: &mut [f64]) {
        let mut workspace = self.workspace.borrow_mut();
        let Workspace {
            additive,
            levels,
            coarsest,
        } = &mut *workspace;
        self.apply_from(0, r, z, additive, levels, coarsest);
    }

    /// z = M⁻¹ r from additive level `depth` down: D⁻¹r + P M⁻¹_coarse(R r) on an additive
    /// level, the V-cycle below them.
    fn apply_from(
        &self,
        depth: usize,
        r: &[f64],
        z: &mut [f64],
        additive_work: &mut [CoarseWork],
        levels: &mut [LevelWork],
        coarsest: &mut Scratch,
    ) {
        match (self.additive.get(depth), additive_work.split_first_mut()) {
            (Some(level), Some((mine, coarser))) => {
                level.block_jacobi.apply(r, z);
                level.restriction.multiply_parallel(r, &mut mine.coarse_b);
                self.apply_from(
                    depth + 1,
                    &mine.coarse_b,
                    &mut mine.coarse_x,
                    coarser,
                    levels,
                    coarsest,
                );
                level
                    .prolongator
                    .multiply_parallel(&mine.coarse_x, &mut mine.residual);
                z.iter_mut().zip(&mine.residual).for_each(|(z, c)| *z += c);
            }
            _ => {
                z.fill(0.0);
                self.cycle(0, r, z, levels, coarsest);
            }
        }
    }

    /// x += P V(b_c): the V-cycle of level `next` on the restricted residual already in
    /// `transfer.coarse_b`, prolongated by `prolongator` through `transfer.residual`.
    fn add_coarse_correction(
        &self,
        next: usize,
        prolongator: &CompactCsr,
        x: &mut [f64],
        transfer: &mut CoarseWork,
        coarser: &mut [LevelWork],
        coarsest_scratch: &mut Scratch,
    ) {
        transfer.coarse_x.fill(0.0);
        self.cycle(
            next,
            &transfer.coarse_b,
            &mut transfer.coarse_x,
            coarser,
            coarsest_scratch,
        );
        prolongator.multiply_parallel(&transfer.coarse_x, &mut transfer.residual);
        x.iter_mut()
            .zip(&transfer.residual)
            .for_each(|(x, c)| *x += c);
    }

    /// One V-cycle on level `depth` of [`Amg::levels`](Amg) from the guess x; `work` holds
    /// the workspace of this level and the coarser ones.
    fn cycle(
        &self,
        depth: usize,
        b: &[f64],
        x: &mut [f64],
        work: &mut [LevelWork],
        coarsest_scratch: &mut Scratch,
    ) {
        let Some(level) = self.levels.get(depth) else {
            match &self.coarsest {
                Coarsest::Lu(lu) => lu.solve(b, x),
                Coarsest::Smoother(smoother) => {
                    smoother.smooth(&self.coarsest_operator, b, x, coarsest_scratch)
                }
            }
            return;
        };
        let (mine, coarser) = work
            .split_first_mut()
            .expect("the workspace has one entry per level above the coarsest");
        let a = &level.operator;
        level.smoother.smooth(a, b, x, &mut mine.smoothing);
        let transfer = &mut mine.coarse;
        a.multiply_parallel(x, &mut transfer.residual);
        transfer
            .residual
            .iter_mut()
            .zip(b)
            .for_each(|(r, b)| *r = b - *r);
        level
            .restriction
            .multiply_parallel(&transfer.residual, &mut transfer.coarse_b);
        self.add_coarse_correction(
            depth + 1,
            &level.prolongator,
            x,
            transfer,
            coarser,
            coarsest_scratch,
        );
        level.smoother.smooth(a, b, x, &mut mine.smoothing);
    }
}

/// Shapes and the diagonal of the input (see [`Amg::new`]).
fn check_input(
    operator: &Csr,
    groups: &[usize],
    null_space: &[f64],
    modes: usize,
) -> Result<(), SolveError> {
    let n = operator.nrows;
    let shape_error = |reason: String| SolveError::Breakdown {
        method: "AMG",
        reason,
    };
    if operator.ncols != n {
        return Err(shape_error(format!(
            "the operator is {n}×{}, not square",
            operator.ncols
        )));
    }
    if groups.first() != Some(&0)
        || groups.last() != Some(&n)
        || groups.windows(2).any(|w| w[0] >= w[1])
    {
        return Err(shape_error(format!(
            "the point groups do not cover the {n} unknowns in increasing order"
        )));
    }
    if modes == 0 || null_space.len() != n * modes {
        return Err(shape_error(format!(
            "the near-null space has {} values, not {modes} modes × {n} unknowns",
            null_space.len()
        )));
    }
    if let Some((row, d)) = operator
        .diagonal()
        .into_iter()
        .enumerate()
        .find(|(_, d)| !(d.is_finite() && *d > 0.0))
    {
        return Err(not_positive_definite(format!(
            "diagonal entry {d:e} at unknown {row}"
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests;
