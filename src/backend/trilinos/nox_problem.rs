//! NOX on a [`NonlinearProblem`]: the layout (Jacobian pattern, preconditioner pattern,
//! global rows) read from the problem, and the callbacks NOX makes answered by it — the
//! Jacobian refreshed every `update_every`-th request, the preconditioner blocks after
//! `max_age` reuses, inverted here when NOX applies them by a product.

use super::nox::{self, NonlinearCallbacks, NoxLayout, NoxReport, Pattern, PreconditionerMatrix};
use crate::backend::native::invert_dense;
use crate::backend::problem::{agree_over, Evaluation, NonlinearProblem};
use crate::backend::{block_diagonal_csr, SolveError};
use crate::io::deck::ParameterValue;

/// The preconditioner of a matrix-free NOX solve.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MatrixFreePreconditioner {
    /// NOX `Preconditioner: "None"`: nothing is assembled.
    None,
    /// `User Defined`: the inverted diagonal blocks, applied by a product.
    InvertedBlocks,
    /// `AztecOO`, `Ifpack`, `New Ifpack`, `ML`: the diagonal blocks, factored by the library.
    Blocks,
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
}

/// Solves `problem` with NOX from its current unknowns; on return the problem has been
/// evaluated (as an iterate) at NOX's solution, whatever NOX evaluated last.
pub fn solve(
    problem: &mut dyn NonlinearProblem,
    settings: &NoxSettings,
) -> Result<NoxSolve, SolveError> {
    let n = problem.len();
    let mut x = vec![0.0; n];
    problem.unknowns(&mut x);
    let layout = layout(problem, settings, &x)?;
    let mut callbacks = ProblemCallbacks {
        problem: &mut *problem,
        jacobian: settings.jacobian,
        jacobian_requests: 0,
        preconditioner_age: None,
        history: Vec::new(),
        print_iterations: settings.print_iterations,
    };
    let report = nox::solve(&mut callbacks, &layout, settings.parameters, &mut x)?;
    let history = callbacks.history;
    let mut residual = vec![0.0; n];
    problem.residual(&x, &mut residual, Evaluation::Iterate)?;
    Ok(NoxSolve { report, history })
}

/// The Newton system NOX builds for `problem` at `x`.
fn layout(
    problem: &mut dyn NonlinearProblem,
    settings: &NoxSettings,
    x: &[f64],
) -> Result<NoxLayout, SolveError> {
    let global_rows = problem.global_ids().map(<[usize]>::to_vec);
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
            })
        }
        _ => None,
    };
    Ok(NoxLayout {
        linear_solver_path: settings.linear_solver_path.to_vec(),
        jacobian,
        preconditioner,
        tolerance: settings.tolerance,
        max_iterations: settings.max_iterations,
        global_rows,
    })
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
