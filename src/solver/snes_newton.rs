//! PETSc's SNES as the nonlinear solver (feature `petsc`) of `NOXQuasiStatic` lists on the
//! PETSc backend, and of `QuasiStatic` and `Implicit` (Newmark-β) lists that ask for it with
//! `Nonlinear Solver: "SNES"`: each load step or time step is solved by SNES Newton with a
//! line search (or Jacobian-free, `-snes_mf_operator`, for `NOXQuasiStatic` with
//! `Jacobian Operator: "Matrix-Free"`; by SNES's nonlinear CG for `Direction → Method:
//! "NonlinearCG"`) on the same residual the native and NOX solvers use (the
//! one residual of [`crate::physics`]), the Newmark inertia included; see
//! [`crate::backend::petsc::snes`] for what SNES sees. On several ranks the SNES runs on
//! `MPI_COMM_WORLD` over the owned unknowns, the ghosts refreshed inside every residual.
//!
//! As for NOX, the unknowns are the current coordinates of the free dofs (the matrix-free
//! probes then move them by a relative amount PETSc's differencing parameter is made for), F
//! is −V ⊙ (f_int + b), and points with too few bonds for a stiffness are held for the whole
//! solve (SNES cannot change its unknowns mid-solve). The convergence test is peridyn's own
//! measure against the load step's tolerance.

use crate::backend::petsc::list;
use crate::backend::petsc::snes::{self, NcgSettings, SnesJacobian, SnesSettings};
use crate::backend::petsc::PetscSettings;
use crate::backend::problem::NonlinearProblem;
use crate::backend::settings::ImplicitSolve;
use crate::backend::{SolveError, Unsupported};
use crate::solver::newton::{NewtonReport, NewtonSettings, NonlinearSolver};
use crate::solver::problem::{Origin, Physical, PhysicsProblem};
use std::time::Instant;

/// `NOXQuasiStatic` on the PETSc backend.
pub struct SnesNewton {
    linear: PetscSettings,
    jacobian: SnesJacobian,
    /// Nonlinear CG (`Direction → Method: "NonlinearCG"`) instead of Newton.
    ncg: Option<NcgSettings>,
    /// The method PETSc resolved at the first solve.
    method: Option<String>,
}

impl SnesNewton {
    /// The SNES solver of a list PETSc's SNES runs ([`list::runs_on_snes`]) over a model of
    /// `unknowns` dofs.
    pub fn new(solve: &ImplicitSolve, unknowns: usize) -> Result<Self, Unsupported> {
        if !list::runs_on_snes(solve) {
            return Err(Unsupported(format!(
                "solver \"{}\": SNES runs NOXQuasiStatic lists on Backend \"PETSc\", and QuasiStatic or Implicit lists there with Nonlinear Solver \"SNES\"",
                solve.list
            )));
        }
        let linear = list::settings(solve, unknowns).ok_or_else(|| {
            Unsupported(format!(
                "solver \"{}\": SNES needs Backend \"PETSc\"",
                solve.list
            ))
        })?;
        let ncg = list::ncg(solve).map_err(|e| {
            Unsupported(format!(
                "solver \"{}\": {}: {}",
                solve.list,
                e.path.join(" → "),
                e.message
            ))
        })?;
        Ok(Self {
            linear,
            jacobian: list::snes_jacobian(solve),
            ncg,
            method: None,
        })
    }

    /// How the Newton operator is formed.
    pub fn jacobian(&self) -> SnesJacobian {
        self.jacobian
    }
}

impl NonlinearSolver for SnesNewton {
    fn logs_after_each_iteration(&self) -> bool {
        true
    }

    fn describe(&self) -> String {
        match &self.method {
            Some(method) => method.clone(),
            None if self.ncg.is_some() => "PETSc SNES ncg (assembled tangent)".to_string(),
            None => format!(
                "PETSc SNES newtonls ({})",
                match self.jacobian {
                    SnesJacobian::Assembled => "assembled tangent",
                    SnesJacobian::MatrixFree =>
                        "Jacobian-free, -snes_mf_operator with the 3x3 block diagonal",
                    SnesJacobian::MatrixFreeMultigrid =>
                        "Jacobian-free, -snes_mf_operator with the one-hop operator",
                }
            ),
        }
    }

    fn solve(
        &mut self,
        parts: Physical<'_>,
        settings: &NewtonSettings,
    ) -> Result<NewtonReport, SolveError> {
        let start = Instant::now();
        let mut problem = PhysicsProblem::new(parts, settings.measure, Origin::Coordinates);
        problem.hold_deficient_points();
        let snes_settings = SnesSettings {
            linear: &self.linear,
            jacobian: self.jacobian,
            tolerance: settings.tolerance,
            max_iterations: settings.max_iterations,
            line_search: settings.line_search,
            ncg: self.ncg.as_ref(),
            print_iterations: settings.print_iterations,
            warn_unused: self.method.is_none(),
        };
        let report = snes::solve(&mut problem, &snes_settings)?;
        self.method = Some(report.method.clone());
        Ok(NewtonReport {
            converged: report.converged,
            iterations: report.iterations,
            linear_iterations: report.linear_iterations,
            residual_history: report.history,
            residual_evaluations: problem.residual_evaluations(),
            broken_bonds: problem.broken_bonds(),
            held_points: problem.held_points(),
            tangent_bytes: problem.jacobian_bytes(),
            linear_method: report.method,
            seconds: start.elapsed().as_secs_f64(),
            preconditioner: Default::default(),
            relaxation_iterations: 0,
        })
    }
}
