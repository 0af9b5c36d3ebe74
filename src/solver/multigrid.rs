//! The multigrid preconditioner of one Newton solve (one load step or time step): built on
//! the problem's preconditioning operator ([`NonlinearProblem::preconditioning_operator`], the
//! one-hop PMB-like stiffness) at the first linear solve, reused by the following Newton
//! iterations, and rebuilt when the unknowns change (a point held) or bonds break
//! ([`NonlinearProblem::preconditioning_version`]).

use crate::backend::native::Amg;
use crate::backend::problem::NonlinearProblem;
use crate::backend::SolveError;

/// The hierarchy kept between the linear solves of one Newton solve.
#[derive(Debug, Default)]
pub struct MultigridCache {
    /// The hierarchy and the (unknowns, version) it was built for.
    built: Option<(Amg, (usize, usize))>,
    /// Print the hierarchy's summary when it is built.
    verbose: bool,
}

impl MultigridCache {
    /// An empty cache; `verbose` logs each setup (levels, sizes, operator complexity).
    pub fn new(verbose: bool) -> Self {
        Self {
            built: None,
            verbose,
        }
    }

    /// The hierarchy for `problem` as it is now, built if there is none yet or the problem's
    /// operator changed since.
    ///
    /// Errors: `Breakdown` when the problem offers no preconditioning operator or AMG cannot
    /// use it (see [`Amg::new`]).
    pub fn hierarchy(&mut self, problem: &mut dyn NonlinearProblem) -> Result<&Amg, SolveError> {
        let key = (problem.len(), problem.preconditioning_version());
        if self.built.as_ref().is_some_and(|(_, built)| *built == key) {
            return Ok(&self.built.as_ref().expect("checked").0);
        }
        self.built = None;
        let operator =
            problem
                .preconditioning_operator()?
                .ok_or_else(|| SolveError::Breakdown {
                    method: "AMG",
                    reason: "this problem offers no preconditioning operator".into(),
                })?;
        let amg = Amg::new(
            operator.matrix,
            problem.groups(),
            &operator.null_space,
            operator.modes,
        )?;
        if self.verbose {
            eprintln!("    preconditioner: {}", amg.describe());
        }
        Ok(&self.built.insert((amg, key)).0)
    }
}
