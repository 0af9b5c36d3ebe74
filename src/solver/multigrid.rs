//! The multigrid preconditioner of one Newton solve (one load step or time step), and what
//! the preconditioners of that solve cost ([`PreconditionerReport`], columns of the solver
//! CSV).
//!
//! Rebuild policy: the one-hop operator ([`NonlinearProblem::preconditioning_operator`], the
//! PMB-like stiffness) and its AMG hierarchy are built at the first linear solve that needs
//! them and kept by the solver list's strategy for the rest of the run: the following Newton
//! iterations, load steps and time steps reuse it until what the operator is built from
//! changes — the unknowns (a point held), the bond damage (bonds broke, in this step or an
//! earlier one) or the inertia factor ([`NonlinearProblem::preconditioning_version`], a
//! fingerprint of those). Positions do not trigger a rebuild: the operator uses the
//! reference bond directions. Without damage a whole quasi-static run builds one hierarchy.

use std::time::Instant;

use crate::backend::native::{Amg, Cycle};
use crate::backend::problem::NonlinearProblem;
use crate::backend::{PreconditionerSetup, SolveError};

/// What the preconditioners of one Newton solve were and cost: the `Preconditioner_*`,
/// `AMG_*` and `GMRES_Restart` columns of `<output>_solver.csv`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PreconditionerReport {
    /// Wall-clock seconds spent building preconditioners during the solve: for `AMG` the
    /// one-hop operator and its hierarchy, for Jacobian-free Newton–Krylov with `Block 3x3`
    /// or `Jacobi` the diagonal blocks and their inverses, for Belos (`Backend: "Trilinos"`)
    /// the Ifpack or ML builds. 0 where the preconditioner is built inside an assembled
    /// linear solver that does not report it apart (native CG/GMRES + block Jacobi, direct
    /// methods, PETSc), whose time is in `Seconds` only.
    pub setup_seconds: f64,
    /// AMG hierarchies built during the solve (0 when the solve reused the one of an earlier
    /// solve or ran without AMG, 1 when it built one for all its Newton iterations, more
    /// when bonds broke or points were held mid-step; Belos + ML builds one per Newton
    /// iteration, on each new tangent).
    pub setups: usize,
    /// Levels of the last AMG hierarchy, the finest and the coarsest included (0 without
    /// AMG).
    pub levels: usize,
    /// Operator complexity Σ nnz(A_l)/nnz(A_0) of the last AMG hierarchy (0 without AMG).
    pub operator_complexity: f64,
    /// GMRES restart length (Krylov vectors kept; the basis holds at most restart + 1
    /// vectors of the unknowns) of the solve's GMRES, 0 when no GMRES ran.
    pub gmres_restart: usize,
}

impl PreconditionerReport {
    /// Adds what an assembled linear solver (Trilinos, PETSc) spent on its preconditioners in
    /// the solve; its multigrid shape replaces this one's when it built a hierarchy.
    pub fn add_assembled(&mut self, setup: PreconditionerSetup) {
        self.setup_seconds += setup.seconds;
        self.setups += setup.hierarchies;
        if setup.hierarchies > 0 {
            self.levels = setup.levels;
            self.operator_complexity = setup.operator_complexity;
        }
    }
}

/// The hierarchy kept between linear solves, Newton solves included.
#[derive(Debug, Default)]
pub struct MultigridCache {
    /// The hierarchy and the (unknowns, version) it was built for.
    built: Option<(Amg, (usize, usize))>,
    /// Print the hierarchy's summary when it is built.
    verbose: bool,
    /// Setup costs and the hierarchy's shape so far.
    report: PreconditionerReport,
}

impl MultigridCache {
    /// An empty cache; `verbose` logs each setup (levels, sizes, operator complexity).
    pub fn new(verbose: bool) -> Self {
        Self {
            built: None,
            verbose,
            report: PreconditionerReport::default(),
        }
    }

    /// Starts the report of a new Newton solve; the hierarchy is kept. `verbose` logs each
    /// setup.
    pub fn begin_solve(&mut self, verbose: bool) {
        self.verbose = verbose;
        self.report = PreconditionerReport::default();
        if let Some((amg, _)) = &self.built {
            self.report.levels = amg.levels();
            self.report.operator_complexity = amg.operator_complexity();
        }
    }

    /// Setup seconds, setups and the last hierarchy's shape so far in this Newton solve
    /// (`gmres_restart` is the caller's to fill).
    pub fn report(&self) -> PreconditionerReport {
        self.report.clone()
    }

    /// Adds the setup time of a preconditioner built outside the cache (JFNK's block
    /// Jacobi).
    pub fn add_setup_seconds(&mut self, seconds: f64) {
        self.report.setup_seconds += seconds;
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
        let start = Instant::now();
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
            Cycle::Additive,
        )?;
        self.report.setup_seconds += start.elapsed().as_secs_f64();
        self.report.setups += 1;
        self.report.levels = amg.levels();
        self.report.operator_complexity = amg.operator_complexity();
        if self.verbose {
            eprintln!("    preconditioner: {}", amg.describe());
        }
        Ok(&self.built.insert((amg, key)).0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::backend::problem::{Evaluation, PreconditioningOperator};
    use crate::backend::Csr;

    /// F(x) = 2x over two points of three unknowns, whose preconditioning operator 2I is
    /// counted each time it is assembled; `version` plays the bonds broken in the step.
    struct Counted {
        version: usize,
        assembled: usize,
        groups: Vec<usize>,
    }

    impl NonlinearProblem for Counted {
        fn len(&self) -> usize {
            6
        }
        fn ranks(&self) -> usize {
            1
        }
        fn global_ids(&self) -> Option<&[usize]> {
            None
        }
        fn unknowns(&self, x: &mut [f64]) {
            x.fill(0.0);
        }
        fn move_to(&mut self, _: &[f64]) {}
        fn residual(&mut self, x: &[f64], f: &mut [f64], _: Evaluation) -> Result<(), SolveError> {
            f.iter_mut().zip(x).for_each(|(f, x)| *f = 2.0 * x);
            Ok(())
        }
        fn jacobian(&mut self, _: &[f64]) -> Result<Csr, SolveError> {
            Ok(twice_identity())
        }
        fn jacobian_bytes(&self) -> usize {
            0
        }
        fn groups(&self) -> &[usize] {
            &self.groups
        }
        fn block_diagonal(&mut self, _: &[f64]) -> Result<Vec<f64>, SolveError> {
            Ok(Vec::new())
        }
        fn group_label(&self, group: usize) -> String {
            format!("point {group}")
        }
        fn dot(&mut self, a: &[f64], b: &[f64]) -> f64 {
            a.iter().zip(b).map(|(a, b)| a * b).sum()
        }
        fn any_failed(&mut self, failed: bool) -> bool {
            failed
        }
        fn convergence_measure(&mut self, f: &[f64]) -> f64 {
            f.iter().map(|f| f * f).sum::<f64>().sqrt()
        }
        fn probe_scale(&self) -> f64 {
            1.0
        }
        fn preconditioning_operator(
            &mut self,
        ) -> Result<Option<PreconditioningOperator>, SolveError> {
            self.assembled += 1;
            // The six unit vectors span the unknowns: a complete near-null space.
            let null_space = (0..36).map(|k| f64::from(u8::from(k % 7 == 0))).collect();
            Ok(Some(PreconditioningOperator {
                matrix: twice_identity(),
                null_space,
                modes: 6,
            }))
        }
        fn preconditioning_version(&mut self) -> usize {
            self.version
        }
    }

    fn twice_identity() -> Csr {
        Csr {
            nrows: 6,
            ncols: 6,
            offsets: (0..=6).collect(),
            columns: (0..6).collect(),
            values: vec![2.0; 6],
        }
    }

    #[test]
    fn the_hierarchy_is_reused_until_its_inputs_change() {
        let mut problem = Counted {
            version: 0,
            assembled: 0,
            groups: vec![0, 3, 6],
        };
        let mut cache = MultigridCache::new(false);
        // Three Newton iterations with no bond broken: one operator, one hierarchy.
        for _ in 0..3 {
            let amg = cache.hierarchy(&mut problem).unwrap();
            // One V-cycle on 2I is the coarsest LU solve: z = r/2 exactly.
            let mut z = [0.0; 6];
            amg.apply(&[2.0; 6], &mut z);
            assert_eq!(z, [1.0; 6]);
        }
        assert_eq!((problem.assembled, cache.report().setups), (1, 1));
        // A bond breaks: rebuilt once, then reused again.
        problem.version = 1;
        cache.hierarchy(&mut problem).unwrap();
        cache.hierarchy(&mut problem).unwrap();
        let report = cache.report();
        assert_eq!((problem.assembled, report.setups), (2, 2));
        // Six unknowns are below the coarse-level limit: the finest level is the coarsest,
        // so one level of complexity nnz/nnz = 1.
        assert_eq!((report.levels, report.operator_complexity), (1, 1.0));
        assert!(report.setup_seconds >= 0.0);
        // The next load step, nothing changed: reused, and its report counts no setup but
        // describes the hierarchy it used.
        cache.begin_solve(false);
        cache.hierarchy(&mut problem).unwrap();
        let report = cache.report();
        assert_eq!((problem.assembled, report.setups), (2, 0));
        assert_eq!((report.levels, report.setup_seconds), (1, 0.0));
        // Damage changed between the steps: built again.
        problem.version = 2;
        cache.begin_solve(false);
        cache.hierarchy(&mut problem).unwrap();
        assert_eq!((problem.assembled, cache.report().setups), (3, 1));
    }
}
