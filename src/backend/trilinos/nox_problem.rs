//! NOX on a [`NonlinearProblem`]: the layout (Jacobian pattern, preconditioner pattern,
//! global rows) read from the problem, and the callbacks NOX makes answered by it — the
//! Jacobian refreshed every `update_every`-th request, the preconditioner blocks after
//! `max_age` reuses, inverted here when NOX applies them by a product.
//!
//! With [`MatrixFreePreconditioner::Multigrid`] the preconditioner matrix is the problem's
//! one-hop operator ([`NonlinearProblem::preconditioning_operator`]) and ML is built on it
//! with the rigid-body near-null space; the operator is refilled, and ML rebuilt, only when
//! [`NonlinearProblem::preconditioning_version`] changed since the last build (bonds broke,
//! points were held): the rule of the native multigrid ([`crate::solver::multigrid`]). The
//! matrix and ML outlive the NOX solve in a [`KeptMultigrid`], so the next load step over the
//! same unknowns and operator reuses the hierarchy instead of building it again.

use std::time::Instant;

use super::nox::{
    self, MultigridKeep, NearNullSpace, NonlinearCallbacks, NoxLayout, NoxReport, Pattern,
    PreconditionerMatrix,
};
use crate::backend::native::invert_dense;
use crate::backend::parameters::ParameterValue;
use crate::backend::problem::{agree_over, Evaluation, NonlinearProblem};
use crate::backend::Csr;
use crate::backend::{block_diagonal_csr, SolveError};

/// The preconditioner of a matrix-free NOX solve.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MatrixFreePreconditioner {
    /// NOX `Preconditioner: "None"`: nothing is assembled.
    None,
    /// `User Defined`: the inverted diagonal blocks, applied by a product.
    InvertedBlocks,
    /// `AztecOO`, `Ifpack`, `New Ifpack`, `ML`: the diagonal blocks, factored by the library.
    Blocks,
    /// `Peridigm Preconditioner: "AMG"`: ML smoothed aggregation on the one-hop operator with
    /// the rigid-body modes, applied as NOX's `User Defined` preconditioner.
    Multigrid,
}

/// How the Newton system is formed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NoxJacobian {
    /// The assembled Jacobian, recomputed on every `update_every`-th request.
    Assembled {
        /// `Direction → Nonlinear CG → Update Jacobian` (1 for Newton).
        update_every: u64,
    },
    /// `NOX::Epetra::MatrixFree`.
    MatrixFree {
        /// Its preconditioner.
        preconditioner: MatrixFreePreconditioner,
        /// `Max Age Of Prec`: reuses of the preconditioner before it is recomputed.
        max_age: u64,
    },
}

/// One NOX solve's configuration.
#[derive(Debug, Clone, Copy)]
pub struct NoxSettings<'a> {
    /// The deck's NOX parameter list.
    pub parameters: &'a [(String, ParameterValue)],
    /// Sublists holding the linear-solver parameters of the chosen direction.
    pub linear_solver_path: &'a [String],
    /// How the Newton system is formed.
    pub jacobian: NoxJacobian,
    /// Converged when ‖F‖₂ ≤ this (N).
    pub tolerance: f64,
    /// NOX `MaxIters`.
    pub max_iterations: u64,
    /// Print `  iteration i: residual L2 norm = …` after every iteration (Peridigm's log).
    pub print_iterations: bool,
}

/// What a NOX solve of a problem did.
#[derive(Debug, Clone, PartialEq)]
pub struct NoxSolve {
    /// NOX's own report.
    pub report: NoxReport,
    /// ‖F‖₂ of the first residual, then after each iteration.
    pub history: Vec<f64>,
    /// Seconds spent assembling the one-hop operator for ML (0 without
    /// [`MatrixFreePreconditioner::Multigrid`]); ML's own setup is in the report.
    pub operator_seconds: f64,
}

/// The ML hierarchy of [`MatrixFreePreconditioner::Multigrid`] solves, kept from one NOX
/// solve (load step) to the next, with what it was built for.
#[derive(Debug, Default)]
pub struct KeptMultigrid {
    keep: MultigridKeep,
    built: Option<BuiltFor>,
}

/// What the kept hierarchy was built on.
#[derive(Debug)]
struct BuiltFor {
    /// The unknowns (their count, and their global ids on several ranks).
    unknowns: usize,
    global_rows: Option<Vec<usize>>,
    /// [`NonlinearProblem::preconditioning_version`] of the operator ML was built on.
    version: usize,
    /// The preconditioner matrix's pattern (for refills after bonds break).
    pattern: Pattern,
    null_space: NearNullSpace,
}

/// Solves `problem` with NOX from its current unknowns; on return the problem has been
/// evaluated (as an iterate) at NOX's solution, whatever NOX evaluated last. A multigrid
/// preconditioner is taken from `kept` when it was built for the same unknowns and operator,
/// and left there for the next solve.
pub fn solve(
    problem: &mut dyn NonlinearProblem,
    settings: &NoxSettings,
    kept: &mut KeptMultigrid,
) -> Result<NoxSolve, SolveError> {
    let n = problem.len();
    let mut x = vec![0.0; n];
    problem.unknowns(&mut x);
    let (layout, operator) = layout(problem, settings, &x, kept.built.take())?;
    let mut callbacks = ProblemCallbacks {
        problem: &mut *problem,
        jacobian: settings.jacobian,
        jacobian_requests: 0,
        preconditioner_age: None,
        operator,
        history: Vec::new(),
        print_iterations: settings.print_iterations,
    };
    let report = nox::solve_keeping(
        &mut callbacks,
        &layout,
        settings.parameters,
        &mut x,
        &mut kept.keep,
    )?;
    let history = callbacks.history;
    let operator_seconds = callbacks.operator.as_ref().map_or(0.0, |o| o.seconds);
    // Kept only once ML was built on the operator (a solve that needed no linear solve
    // built none).
    kept.built = match (callbacks.operator, layout.preconditioner) {
        (
            Some(OneHop {
                version: Some(version),
                pattern,
                ..
            }),
            Some(PreconditionerMatrix {
                multigrid: Some(null_space),
                ..
            }),
        ) => Some(BuiltFor {
            unknowns: n,
            global_rows: layout.global_rows,
            version,
            pattern,
            null_space,
        }),
        _ => None,
    };
    let mut residual = vec![0.0; n];
    problem.residual(&x, &mut residual, Evaluation::Iterate)?;
    Ok(NoxSolve {
        report,
        history,
        operator_seconds,
    })
}

/// The one-hop operator of a [`MatrixFreePreconditioner::Multigrid`] solve.
struct OneHop {
    /// The pattern NOX's matrix was built with (the first operator's).
    pattern: Pattern,
    /// Values waiting for the first preconditioner request (the first operator, assembled
    /// for the layout).
    first_values: Option<Vec<f64>>,
    /// [`NonlinearProblem::preconditioning_version`] of the values in NOX's matrix (`None`:
    /// not filled yet).
    version: Option<usize>,
    /// The version of the first operator.
    first_version: usize,
    /// Seconds spent assembling operators.
    seconds: f64,
}

fn no_operator() -> SolveError {
    SolveError::Breakdown {
        method: "NOX + ML",
        reason: "Peridigm Preconditioner \"AMG\" needs the one-hop preconditioning operator, which this problem does not offer".into(),
    }
}

/// The values of `operator` in the order of `pattern` (the first operator's): bonds that broke
/// since only remove entries, which stay as zeros. An entry outside the pattern is an error.
fn values_in_pattern(operator: &Csr, pattern: &Pattern) -> Result<Vec<f64>, SolveError> {
    if operator.offsets == pattern.offsets && operator.columns == pattern.columns {
        return Ok(operator.values.clone());
    }
    let rows = pattern.offsets.len() - 1;
    if operator.nrows != rows {
        return Err(SolveError::Breakdown {
            method: "NOX + ML",
            reason: format!(
                "a preconditioning operator of {} rows for {rows} unknowns",
                operator.nrows
            ),
        });
    }
    let mut values = vec![0.0; pattern.columns.len()];
    for r in 0..rows {
        let slots = pattern.offsets[r]..pattern.offsets[r + 1];
        for k in operator.offsets[r]..operator.offsets[r + 1] {
            let column = operator.columns[k];
            let slot = slots
                .clone()
                .find(|&s| pattern.columns[s] == column)
                .ok_or_else(|| SolveError::Breakdown {
                    method: "NOX + ML",
                    reason: format!(
                        "the preconditioning operator gained the entry ({r}, {column}) outside its first pattern"
                    ),
                })?;
            values[slot] += operator.values[k];
        }
    }
    Ok(values)
}

/// The Newton system NOX builds for `problem` at `x`, and with
/// [`MatrixFreePreconditioner::Multigrid`] the one-hop operator it starts from.
/// `built` is what a kept ML hierarchy was built for: reused when the unknowns and the
/// operator's version are still those.
fn layout(
    problem: &mut dyn NonlinearProblem,
    settings: &NoxSettings,
    x: &[f64],
    built: Option<BuiltFor>,
) -> Result<(NoxLayout, Option<OneHop>), SolveError> {
    let global_rows = problem.global_ids().map(<[usize]>::to_vec);
    let mut one_hop = None;
    let jacobian = match settings.jacobian {
        NoxJacobian::Assembled { .. } => {
            let matrix = problem.jacobian(x)?;
            Some(Pattern {
                offsets: matrix.offsets,
                columns: matrix.columns,
            })
        }
        NoxJacobian::MatrixFree { .. } => None,
    };
    let preconditioner = match settings.jacobian {
        NoxJacobian::MatrixFree {
            preconditioner:
                kind @ (MatrixFreePreconditioner::Blocks | MatrixFreePreconditioner::InvertedBlocks),
            ..
        } => {
            let groups = problem.groups();
            let blocks = block_diagonal_csr(groups, &vec![0.0; block_entries(groups)]);
            let columns = match &global_rows {
                Some(ids) => blocks.columns.iter().map(|&c| ids[c]).collect(),
                None => blocks.columns,
            };
            Some(PreconditionerMatrix {
                pattern: Pattern {
                    offsets: blocks.offsets,
                    columns,
                },
                is_inverse: kind == MatrixFreePreconditioner::InvertedBlocks,
                multigrid: None,
            })
        }
        NoxJacobian::MatrixFree {
            preconditioner: MatrixFreePreconditioner::Multigrid,
            ..
        } => {
            let start = Instant::now();
            let first_version = problem.preconditioning_version();
            let reusable = built.filter(|b| {
                b.unknowns == problem.len()
                    && b.global_rows == global_rows
                    && b.version == first_version
            });
            if let Some(b) = reusable {
                one_hop = Some(OneHop {
                    pattern: b.pattern.clone(),
                    first_values: None,
                    version: Some(b.version),
                    first_version,
                    seconds: 0.0,
                });
                return Ok((
                    NoxLayout {
                        linear_solver_path: settings.linear_solver_path.to_vec(),
                        jacobian: None,
                        preconditioner: Some(PreconditionerMatrix {
                            pattern: b.pattern,
                            is_inverse: false,
                            multigrid: Some(NearNullSpace {
                                reuse_kept: true,
                                ..b.null_space
                            }),
                        }),
                        tolerance: settings.tolerance,
                        max_iterations: settings.max_iterations,
                        global_rows,
                    },
                    one_hop,
                ));
            }
            let operator = problem.preconditioning_operator();
            let operator = agree_over(&mut *problem, operator)?;
            let operator = agree_over(&mut *problem, operator.ok_or_else(no_operator))?;
            let whole_points = problem.groups().windows(2).all(|g| g[1] - g[0] == 3);
            let pattern = Pattern {
                offsets: operator.matrix.offsets,
                columns: operator.matrix.columns,
            };
            one_hop = Some(OneHop {
                pattern: pattern.clone(),
                first_values: Some(operator.matrix.values),
                version: None,
                first_version,
                seconds: start.elapsed().as_secs_f64(),
            });
            Some(PreconditionerMatrix {
                pattern,
                is_inverse: false,
                multigrid: Some(NearNullSpace {
                    vectors: operator.null_space,
                    modes: operator.modes,
                    whole_points,
                    reuse_kept: false,
                }),
            })
        }
        _ => None,
    };
    Ok((
        NoxLayout {
            linear_solver_path: settings.linear_solver_path.to_vec(),
            jacobian,
            preconditioner,
            tolerance: settings.tolerance,
            max_iterations: settings.max_iterations,
            global_rows,
        },
        one_hop,
    ))
}

/// Entries of the dense diagonal blocks of `groups`.
fn block_entries(groups: &[usize]) -> usize {
    groups.windows(2).map(|g| (g[1] - g[0]).pow(2)).sum()
}

/// The callbacks of one NOX solve, answered by the problem.
struct ProblemCallbacks<'a> {
    problem: &'a mut dyn NonlinearProblem,
    jacobian: NoxJacobian,
    jacobian_requests: u64,
    /// Reuses of the current preconditioner (`None`: not computed yet).
    preconditioner_age: Option<u64>,
    /// The one-hop operator of a multigrid-preconditioned solve.
    operator: Option<OneHop>,
    /// ‖F‖₂ of the first residual, then after each iteration.
    history: Vec<f64>,
    print_iterations: bool,
}

impl ProblemCallbacks<'_> {
    /// The preconditioner blocks at x, inverted when NOX applies them by a product.
    fn preconditioner_values(
        &mut self,
        kind: MatrixFreePreconditioner,
        x: &[f64],
        values: &mut [f64],
    ) -> Result<(), SolveError> {
        let blocks = self.problem.block_diagonal(x)?;
        if kind != MatrixFreePreconditioner::InvertedBlocks {
            return copy_values(&blocks, values);
        }
        let mut at = 0;
        for (group, g) in self.problem.groups().windows(2).enumerate() {
            let size = g[1] - g[0];
            let block = &blocks[at..at + size * size];
            let inverse = invert_dense(block, size).ok_or_else(|| SolveError::Breakdown {
                method: "Block 3x3 preconditioner",
                reason: format!(
                    "the diagonal block of {} is singular",
                    self.problem.group_label(group)
                ),
            })?;
            values[at..at + size * size].copy_from_slice(&inverse);
            at += size * size;
        }
        Ok(())
    }
}

impl ProblemCallbacks<'_> {
    /// The one-hop operator's values into `values` when its version changed since NOX's
    /// matrix was filled (true: ML is to be rebuilt), nothing otherwise (false: ML is kept).
    fn one_hop_values(&mut self, values: &mut [f64]) -> Result<bool, SolveError> {
        let version = self.problem.preconditioning_version();
        let operator = self.operator.as_mut().ok_or_else(no_operator)?;
        if operator.version == Some(version) {
            return Ok(false);
        }
        let start = Instant::now();
        let fresh = match operator.first_values.take() {
            Some(first) if version == operator.first_version => first,
            _ => {
                let matrix = self
                    .problem
                    .preconditioning_operator()?
                    .ok_or_else(no_operator)?
                    .matrix;
                values_in_pattern(&matrix, &operator.pattern)?
            }
        };
        copy_values(&fresh, values)?;
        operator.version = Some(version);
        operator.seconds += start.elapsed().as_secs_f64();
        Ok(true)
    }
}

fn copy_values(from: &[f64], to: &mut [f64]) -> Result<(), SolveError> {
    if from.len() != to.len() {
        return Err(SolveError::Breakdown {
            method: "NOX",
            reason: format!(
                "{} matrix values for a pattern of {} entries",
                from.len(),
                to.len()
            ),
        });
    }
    to.copy_from_slice(from);
    Ok(())
}

impl NonlinearCallbacks for ProblemCallbacks<'_> {
    fn residual(&mut self, x: &[f64], f: &mut [f64], probe: bool) -> Result<(), SolveError> {
        let evaluation = if probe {
            Evaluation::Probe
        } else {
            Evaluation::Iterate
        };
        self.problem.residual(x, f, evaluation)?;
        if self.history.is_empty() && !probe {
            self.history.push(self.problem.dot(f, f).sqrt());
        }
        Ok(())
    }

    fn jacobian(&mut self, x: &[f64], values: &mut [f64]) -> Result<bool, SolveError> {
        let NoxJacobian::Assembled { update_every } = self.jacobian else {
            return Ok(false);
        };
        self.jacobian_requests += 1;
        if (self.jacobian_requests - 1) % update_every != 0 {
            return Ok(false);
        }
        let matrix = self.problem.jacobian(x)?;
        let copied = copy_values(&matrix.values, values);
        agree_over(&mut *self.problem, copied)?;
        Ok(true)
    }

    fn preconditioner(&mut self, x: &[f64], values: &mut [f64]) -> Result<bool, SolveError> {
        let NoxJacobian::MatrixFree {
            preconditioner,
            max_age,
        } = self.jacobian
        else {
            return Ok(false);
        };
        if preconditioner == MatrixFreePreconditioner::Multigrid {
            let result = self.one_hop_values(values);
            return agree_over(&mut *self.problem, result);
        }
        match self.preconditioner_age {
            Some(age) if age < max_age => {
                self.preconditioner_age = Some(age + 1);
                return Ok(false);
            }
            _ => self.preconditioner_age = Some(0),
        }
        let result = self.preconditioner_values(preconditioner, x, values);
        agree_over(&mut *self.problem, result)?;
        Ok(true)
    }

    fn iteration_done(&mut self, iteration: usize, residual_norm: f64) {
        self.history.push(residual_norm);
        if self.print_iterations {
            eprintln!("  iteration {iteration}: residual L2 norm = {residual_norm:e}");
        }
    }
}
