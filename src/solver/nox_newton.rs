//! `NOXQuasiStatic` through Trilinos NOX (feature `trilinos`): each load step is solved by
//! NOX's Newton or nonlinear-CG solver with the deck's NOX parameter list, on the same
//! residual the native solvers use (every solver evaluates [`crate::physics`]' one residual).
//!
//! What NOX sees (Peridigm's configuration in `executeNOXQuasiStatic`,
//! `src/core/Peridigm.cpp`, with the differences noted):
//! * unknowns: the current coordinates y = X + u of the free dofs (the first guess has the
//!   prescribed increments and the predictor applied); prescribed dofs are eliminated rather
//!   than zeroed rows. Peridigm's unknowns are the increments of the load step, which start at
//!   0; NOX's matrix-free probe is x + ηv with η = λ(λ + ‖x‖/‖v‖), λ = 10⁻⁶, so at x = 0 it
//!   is 10⁻¹²·v, and with a preconditioned v (of size ‖r‖/stiffness) it falls below the
//!   round-off of the coordinates and GMRES breaks down. With coordinates as unknowns the probe
//!   moves them by about λ‖y‖, the scale [`super::jfnk`] uses; F, its norm and the Newton steps
//!   are unchanged;
//! * F = −r = −V ⊙ (f_int + b) over the unknowns (force units), so that ∂F/∂x = K, the
//!   symmetric stiffness; ‖F‖₂ is Peridigm's NOX measure;
//! * status tests: `Combo(OR)` of `FiniteValue`, `NormF(tolerance, unscaled)` and
//!   `MaxIters(Max Solver Iterations)`, as Peridigm builds them;
//! * the Jacobian: the assembled tangent (values refreshed on each `computeJacobian`, every
//!   `Update Jacobian`-th call for nonlinear CG), or with `Jacobian Operator: "Matrix-Free"`
//!   and `Peridigm Preconditioner` `Block 3x3`/`None`, `NOX::Epetra::MatrixFree` directional
//!   derivatives of F with damage frozen during the probes;
//! * the matrix-free preconditioner follows the linear solver's `Preconditioner`: `None`
//!   assembles nothing; `User Defined` applies the inverted 3×3 diagonal blocks of the tangent
//!   by a product; `AztecOO`, `Ifpack`, `New Ifpack` and `ML` factor the (uninverted) blocks;
//!   without the key, `Peridigm Preconditioner: "Block 3x3"` means `User Defined` (NOX's
//!   default would be none, and unpreconditioned JFNK stalls on real problems).
//!   Peridigm fills its matrix with the inverted blocks and hands it to AztecOO's ILU in both
//!   cases, which for `User Defined` preconditions with the blocks themselves instead of their
//!   inverses — its `NOX_QS_MatrixFree_3x3Prec` regression needs 12 Newton iterations where the
//!   block-Jacobi preconditioner needs 3. The blocks are refreshed after `Max Age Of Prec`
//!   reuses;
//! * `Peridigm Preconditioner: "AMG"` (peridyn's, with `Jacobian Operator: "Matrix-Free"`; the
//!   linear solver's `Preconditioner` absent or `ML`): NOX's matrix-free Jacobian
//!   preconditioned by ML smoothed aggregation built on the one-hop operator
//!   ([`crate::backend::problem::NonlinearProblem::preconditioning_operator`]) with the six
//!   rigid-body modes as its near-null space and `PDE equations` 3 when every point keeps its
//!   three unknowns, applied as NOX's `User Defined` preconditioner, kept across load steps and
//!   rebuilt only when bonds broke or points were held, so a run without damage builds it once (see
//!   [`crate::backend::trilinos::nox_problem`]). The solver CSV reports ML's setups,
//!   their time (operator assembly included), levels, operator complexity and AztecOO's GMRES
//!   restart.

use crate::backend::factory;
use crate::backend::parameters::{set_at, value_at as lookup, ParameterValue};
use crate::backend::problem::NonlinearProblem;
use crate::backend::settings::{ImplicitSolve, PeridigmPreconditioner};
use crate::backend::trilinos::nox_problem::{self, KeptMultigrid, NoxSettings};
pub use crate::backend::trilinos::nox_problem::{MatrixFreePreconditioner, NoxJacobian};
use crate::backend::{SolveError, Unsupported};
use crate::solver::multigrid::PreconditionerReport;
use crate::solver::newton::{NewtonReport, NewtonSettings, NonlinearSolver};
use crate::solver::problem::{Origin, Physical, PhysicsProblem};
use std::time::Instant;

/// `NOXQuasiStatic` on the Trilinos backend.
#[derive(Debug)]
pub struct NoxNewton {
    parameters: Vec<(String, ParameterValue)>,
    linear_solver_path: Vec<String>,
    jacobian: NoxJacobian,
    /// The ML hierarchy of `Peridigm Preconditioner: "AMG"`, kept across load steps.
    multigrid: KeptMultigrid,
}

impl NoxNewton {
    /// The NOX solver of a `NOXQuasiStatic` list (see the module docs for the rules).
    pub fn new(solve: &ImplicitSolve) -> Result<Self, Unsupported> {
        let Some(deck) = factory::nox_parameters(solve) else {
            return Err(Unsupported(format!(
                "solver \"{}\": NOX runs NOXQuasiStatic lists only",
                solve.list
            )));
        };
        let direction = factory::nox_direction(solve, &deck.direction_method)?;
        let linear_solver_path: Vec<String> = ["Direction", direction, "Linear Solver"]
            .map(String::from)
            .to_vec();
        let path: Vec<&str> = linear_solver_path.iter().map(String::as_str).collect();
        let linear_key = |key: &str| {
            let mut full = path.clone();
            full.push(key);
            lookup(&deck.nox, &full).cloned()
        };
        let text = |v: Option<ParameterValue>| match v {
            Some(ParameterValue::String(s)) => Some(s),
            _ => None,
        };
        let matrix_free = text(linear_key("Jacobian Operator")).as_deref() == Some("Matrix-Free")
            && solve.peridigm_preconditioner != PeridigmPreconditioner::FullTangent;
        if solve.peridigm_preconditioner == PeridigmPreconditioner::Amg && !matrix_free {
            return Err(Unsupported(format!(
                "solver \"{}\": Peridigm Preconditioner \"AMG\" on NOX preconditions the Jacobian-free Newton–Krylov solve: \
                 add Jacobian Operator: \"Matrix-Free\" to NOXQuasiStatic → Direction → {direction} → Linear Solver, \
                 or choose \"Full Tangent\", \"Block 3x3\" or \"None\"",
                solve.list
            )));
        }
        let jacobian = if matrix_free {
            let preconditioner = match text(linear_key("Preconditioner")).as_deref() {
                // peridyn's multigrid on NOX: ML on the one-hop operator, whatever NOX's own
                // preconditioner key would have been (only ML, or nothing, is consistent).
                None | Some("ML" | "User Defined")
                    if solve.peridigm_preconditioner == PeridigmPreconditioner::Amg =>
                {
                    MatrixFreePreconditioner::Multigrid
                }
                Some(other) if solve.peridigm_preconditioner == PeridigmPreconditioner::Amg => {
                    return Err(Unsupported(format!(
                        "solver \"{}\": Peridigm Preconditioner \"AMG\" is ML on the one-hop operator, but NOXQuasiStatic → Direction → {direction} → Linear Solver → Preconditioner is \"{other}\": \
                         remove that key (or set it to \"ML\"), or choose another Peridigm Preconditioner",
                        solve.list
                    )))
                }
                // Without the key NOX would run unpreconditioned, which stalls on anything
                // real (ffi.md gotcha 9); `Block 3x3` then means what it says, as on the
                // native backend.
                None if solve.peridigm_preconditioner == PeridigmPreconditioner::Block3x3 => {
                    MatrixFreePreconditioner::InvertedBlocks
                }
                None | Some("None") => MatrixFreePreconditioner::None,
                Some("User Defined") => MatrixFreePreconditioner::InvertedBlocks,
                Some("AztecOO" | "Ifpack" | "New Ifpack" | "ML") => {
                    MatrixFreePreconditioner::Blocks
                }
                Some(other) => {
                    return Err(Unsupported(format!(
                        "solver \"{}\": NOXQuasiStatic → Direction → {direction} → Linear Solver → Preconditioner \"{other}\": \
                         use \"None\", \"User Defined\" (the inverted 3×3 blocks), \"AztecOO\", \"Ifpack\", \"New Ifpack\" or \"ML\"",
                        solve.list
                    )))
                }
            };
            NoxJacobian::MatrixFree {
                preconditioner,
                max_age: deck.max_age_of_prec.max(1),
            }
        } else {
            let update_every =
                match lookup(&deck.nox, &["Direction", "Nonlinear CG", "Update Jacobian"]) {
                    Some(ParameterValue::Int(n)) if *n >= 1 => *n as u64,
                    _ => 1,
                };
            NoxJacobian::Assembled { update_every }
        };
        let mut parameters = deck.nox.clone();
        if let NoxJacobian::MatrixFree {
            preconditioner:
                MatrixFreePreconditioner::InvertedBlocks | MatrixFreePreconditioner::Multigrid,
            ..
        } = jacobian
        {
            set_at(
                &mut parameters,
                &path,
                (
                    "Preconditioner",
                    ParameterValue::String("User Defined".into()),
                ),
            );
        }
        if lookup(&parameters, &["Printing", "Output Information"]).is_none() {
            set_printing(&mut parameters, solve.verbose || deck.verbose);
        }
        Ok(Self {
            parameters,
            linear_solver_path,
            jacobian,
            multigrid: KeptMultigrid::default(),
        })
    }

    /// How the Newton system is formed.
    pub fn jacobian(&self) -> NoxJacobian {
        self.jacobian
    }

    /// AztecOO's GMRES restart: the linear solver's `Size of Krylov Subspace`, NOX's default
    /// 300 without it; 0 when its `Aztec Solver` is not GMRES (the default).
    /// `peridyn check` plans the basis with the same rule ([`factory::matrix_free_gmres`]).
    fn gmres_restart(&self) -> usize {
        let path: Vec<&str> = self.linear_solver_path.iter().map(String::as_str).collect();
        factory::nox_gmres_restart(&self.parameters, &path).unwrap_or(0)
    }
}

/// NOX's `Printing → Output Information` when the deck gives none: errors only, or with
/// `Verbose` the iterations, their status tests, the linear solves and warnings (bits of
/// `NOX::Utils::MsgType`: Warning 1, OuterIteration 2, InnerIteration 4,
/// OuterIterationStatusTest 32, LinearSolverDetails 64).
fn set_printing(parameters: &mut Vec<(String, ParameterValue)>, verbose: bool) {
    let level = if verbose { 1 + 2 + 4 + 32 + 64 } else { 0 };
    set_at(
        parameters,
        &["Printing"],
        ("Output Information", ParameterValue::Int(level)),
    );
}

impl NonlinearSolver for NoxNewton {
    fn logs_after_each_iteration(&self) -> bool {
        true
    }

    fn describe(&self) -> String {
        let direction = &self.linear_solver_path[1];
        match self.jacobian {
            NoxJacobian::Assembled { .. } => {
                format!("Trilinos NOX ({direction}, assembled tangent, AztecOO)")
            }
            NoxJacobian::MatrixFree { preconditioner, .. } => format!(
                "Trilinos NOX ({direction}, Jacobian-free, AztecOO, preconditioner {})",
                match preconditioner {
                    MatrixFreePreconditioner::None => "none",
                    MatrixFreePreconditioner::InvertedBlocks => "inverted 3x3 blocks",
                    MatrixFreePreconditioner::Blocks => "3x3 blocks factored by the library",
                    MatrixFreePreconditioner::Multigrid =>
                        "ML smoothed aggregation on the one-hop operator",
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
        // Points with too few bonds for a stiffness are held for the whole NOX solve (NOX
        // cannot change its unknowns mid-solve); on several ranks every rank learns which.
        problem.hold_deficient_points();
        let nox = NoxSettings {
            parameters: &self.parameters,
            linear_solver_path: &self.linear_solver_path,
            jacobian: self.jacobian,
            tolerance: settings.tolerance,
            max_iterations: settings.max_iterations,
            print_iterations: settings.print_iterations,
        };
        let solved = nox_problem::solve(&mut problem, &nox, &mut self.multigrid)?;
        let multigrid = matches!(
            self.jacobian,
            NoxJacobian::MatrixFree {
                preconditioner: MatrixFreePreconditioner::Multigrid,
                ..
            }
        );
        let preconditioner = if multigrid {
            PreconditionerReport {
                setup_seconds: solved.operator_seconds + solved.report.multigrid_seconds,
                setups: solved.report.multigrid_setups,
                levels: solved.report.multigrid_levels,
                operator_complexity: solved.report.operator_complexity,
                gmres_restart: self.gmres_restart(),
            }
        } else {
            PreconditionerReport::default()
        };
        Ok(NewtonReport {
            converged: solved.report.converged,
            iterations: solved.report.iterations,
            linear_iterations: solved.report.linear_iterations,
            residual_history: solved.history,
            residual_evaluations: problem.residual_evaluations(),
            broken_bonds: problem.broken_bonds(),
            held_points: problem.held_points(),
            tangent_bytes: problem.jacobian_bytes(),
            linear_method: "AztecOO (NOX)".to_string(),
            seconds: start.elapsed().as_secs_f64(),
            preconditioner,
            relaxation_iterations: 0,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The NOX solver of a one-block deck whose `Solver` list has `solver_keys` and whose
    /// NOXQuasiStatic `Linear Solver` list has `linear_keys`.
    fn nox_of(solver_keys: &str, linear_keys: &str) -> NoxNewton {
        nox_result(solver_keys, linear_keys).expect("NOX settings")
    }

    /// [`nox_of`] before the settings are accepted.
    fn nox_result(solver_keys: &str, linear_keys: &str) -> Result<NoxNewton, Unsupported> {
        let text = format!(
            r#"Discretization:
  Type: "PdQuickGrid"
  NeighborhoodType: "Spherical"
  TensorProduct3DMeshGenerator: {{X Origin: 0.0, Y Origin: 0.0, Z Origin: 0.0, X Length: 3.0, Y Length: 1.0, Z Length: 1.0, Number Points X: 3, Number Points Y: 1, Number Points Z: 1}}
Materials:
  M: {{Material Model: "Elastic", Density: 1.0, Bulk Modulus: 1.0, Shear Modulus: 1.0}}
Blocks:
  B: {{Block Names: "block_1", Material: "M", Horizon: 1.5}}
Solver:
  Final Time: 1.0
{solver_keys}
  NOXQuasiStatic:
    Number of Load Steps: 1
    Direction:
      Method: "Newton"
      Newton:
        Linear Solver:
{linear_keys}
"#
        );
        NoxNewton::new(&crate::setup::solvers::first_implicit_solve(&text))
    }

    #[test]
    fn amg_is_ml_on_the_one_hop_operator_and_needs_the_matrix_free_operator() {
        let solver = nox_of(
            "  Peridigm Preconditioner: \"AMG\"",
            "          Jacobian Operator: \"Matrix-Free\"",
        );
        assert!(matches!(
            solver.jacobian(),
            NoxJacobian::MatrixFree {
                preconditioner: MatrixFreePreconditioner::Multigrid,
                ..
            }
        ));
        // ML is applied as NOX's user-defined preconditioner, restarting at NOX's 300.
        let path = ["Direction", "Newton", "Linear Solver", "Preconditioner"];
        assert_eq!(
            lookup(&solver.parameters, &path),
            Some(&ParameterValue::String("User Defined".into()))
        );
        assert_eq!(solver.gmres_restart(), 300);
        let Err(error) = nox_result(
            "  Peridigm Preconditioner: \"AMG\"",
            "          Jacobian Operator: \"Have Jacobian\"",
        ) else {
            panic!("NOX accepted AMG with an assembled Jacobian");
        };
        assert!(error.0.contains("Matrix-Free"), "{error}");
        let Err(error) = nox_result(
            "  Peridigm Preconditioner: \"AMG\"",
            "          Jacobian Operator: \"Matrix-Free\"\n          Preconditioner: \"Ifpack\"",
        ) else {
            panic!("NOX accepted AMG with Ifpack");
        };
        assert!(error.0.contains("\"Ifpack\""), "{error}");
    }

    #[test]
    fn peridigm_rules_choose_matrix_free_only_with_a_block_preconditioner() {
        // Peridigm's `executeNOXQuasiStatic`: Matrix-Free with Full Tangent still assembles.
        let full = nox_of(
            "  Peridigm Preconditioner: \"Full Tangent\"",
            "          Jacobian Operator: \"Matrix-Free\"",
        );
        assert_eq!(full.jacobian(), NoxJacobian::Assembled { update_every: 1 });
        let none = nox_of(
            "  Peridigm Preconditioner: \"None\"",
            "          Jacobian Operator: \"Matrix-Free\"",
        );
        assert!(matches!(
            none.jacobian(),
            NoxJacobian::MatrixFree {
                preconditioner: MatrixFreePreconditioner::None,
                max_age: 200
            }
        ));
        let library = nox_of(
            "  Peridigm Preconditioner: \"Block 3x3\"",
            "          Jacobian Operator: \"Matrix-Free\"\n          Preconditioner: \"AztecOO\"",
        );
        assert!(matches!(
            library.jacobian(),
            NoxJacobian::MatrixFree {
                preconditioner: MatrixFreePreconditioner::Blocks,
                ..
            }
        ));
    }

    #[test]
    fn block_3x3_without_a_nox_preconditioner_key_is_user_defined() {
        let solver = nox_of(
            "  Peridigm Preconditioner: \"Block 3x3\"",
            "          Jacobian Operator: \"Matrix-Free\"",
        );
        assert!(matches!(
            solver.jacobian(),
            NoxJacobian::MatrixFree {
                preconditioner: MatrixFreePreconditioner::InvertedBlocks,
                ..
            }
        ));
        let path = ["Direction", "Newton", "Linear Solver", "Preconditioner"];
        assert_eq!(
            lookup(&solver.parameters, &path),
            Some(&ParameterValue::String("User Defined".into()))
        );
        // Quiet NOX unless the deck asks (Output Information 0: errors only).
        assert_eq!(
            lookup(&solver.parameters, &["Printing", "Output Information"]),
            Some(&ParameterValue::Int(0))
        );
    }
}
