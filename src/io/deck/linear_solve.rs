//! The linear-solver keys of an implicit `Solver` list: peridyn's `Backend`, `Linear Solver`,
//! its preconditioner, tolerances and library parameters, with defaults from Peridigm's
//! `Belos *` keys.

use super::error::DeckError;
use super::parameters::ParameterValue;
use super::reader::{Ctx, ListReader};

/// Linear solver of the implicit integrators (peridyn keys in the `Solver` list; Peridigm's
/// `Belos *` keys choose the default, so its decks keep their meaning).
///
/// | key | values | default |
/// |---|---|---|
/// | `Backend` | `Native`, `Trilinos` (a build with Cargo feature `trilinos`), `PETSc` (feature `petsc`) | `Native` |
/// | `Linear Solver` | `Automatic`, `Direct`, `Cholesky`, `LU`, `CG`, `GMRES`; `Trilinos`: `Automatic` (= `CG`), `CG`, `GMRES`; `PETSc`: all (`Direct`, `LU`, `Cholesky` are MUMPS) | `CG` when the deck gives `Belos Linear Solver: BlockCG`, `GMRES` for `BlockGMRES`, else `Automatic` |
/// | `Linear Solver Preconditioner` | `Native`: `Block 3x3`, `AMG`, `Jacobi`, `None`; `Trilinos`: `Jacobi`, `ILU`, `ML`, `None`; `PETSc`: `Jacobi`, `ILU` (block Jacobi with ILU blocks), `GAMG` (or `AMG`), `Hypre` (BoomerAMG), `None` | `Block 3x3` (`Native`), `ILU` (`Trilinos`, `PETSc`; `GAMG` with `Peridigm Preconditioner: "AMG"`) |
/// | `Linear Solver ILU Level Of Fill` | `Trilinos`/`PETSc` with `ILU`: Ifpack's `fact: level-of-fill`, PETSc's `-sub_pc_factor_levels` | 0 |
/// | `PETSc Options` | `Backend: "PETSc"`: PETSc command-line options (`-ksp_type gmres -pc_type gamg -snes_linesearch_type bt …`) put in PETSc's options database under this list's prefix (its name in lower case and `_`, e.g. `solver_`); they override the keys above | none |
/// | `Linear Solver Tolerance` | relative residual of the Krylov methods | `Belos Relative Tolerance` when given, else 1e-10 |
/// | `Linear Solver Maximum Iterations` | Krylov iteration limit | `Belos Maximum Iterations`, else the number of unknowns |
/// | `Nonlinear Solver` | `QuasiStatic` and `Implicit` lists: `Newton` (peridyn's Newton with the linear solver above) or `SNES` (`Backend: "PETSc"` only: PETSc's SNES `newtonls` drives the iteration on the same residual, its KSP and PC as above; `-snes_*` options in `PETSc Options` reach it). `NOXQuasiStatic` lists on PETSc always run SNES | `Newton` |
/// | `Belos` | a sublist of Belos parameters (`Backend: "Trilinos"`): `Maximum Iterations`, `Convergence Tolerance`, `Num Blocks`, `Maximum Restarts`, `Verbosity`, `Output Frequency`, … (see [`super::belos`]) | none |
///
/// `Direct` is a sparse Cholesky factorization that falls back to LU when the stiffness is not
/// positive definite (after bonds break, or with an unstable material state). `Automatic` is
/// `Direct` up to [`LinearMethod::AUTOMATIC_DIRECT_LIMIT`] unknowns and CG beyond, where the
/// fill-in of a factorization of a three-dimensional peridynamic stiffness costs minutes and
/// gigabytes (a 20,000-point LPS block: over 10 minutes per factorization here, against 10 s
/// for preconditioned CG). Beyond the limit a quasi-static list on the native backend that
/// names no preconditioner is not assembled at all: it runs Jacobian-free Newton–Krylov with
/// AMG ([`crate::backend::factory::automatic_jacobian_free`]).
///
/// `Backend: "Trilinos"` hands the assembled tangent to Belos (`CG` is `BlockCG`, `GMRES` is
/// `BlockGMRES`) with an Ifpack or ML preconditioner; its default preconditioner is ILU(0),
/// which unlike ML needs no knowledge of the unknowns' grouping into points.
#[derive(Debug, Clone, PartialEq)]
pub struct LinearSolve {
    /// `Backend` (and the Trilinos backend's own preconditioner settings).
    pub backend: LinearBackend,
    /// The deck gave `Backend` (otherwise `peridyn run --backend` may choose it).
    pub backend_given: bool,
    /// `Linear Solver`.
    pub method: LinearMethod,
    /// `Linear Solver Preconditioner` of the native Krylov methods (with `Backend:
    /// "Trilinos"` the choice is in [`LinearBackend::Trilinos`] and this stays `Block 3x3`).
    pub preconditioner: LinearPreconditioner,
    /// The deck gave `Linear Solver Preconditioner` (so `peridyn run --backend petsc` carries
    /// a native choice over instead of taking PETSc's default).
    pub preconditioner_given: bool,
    /// `Linear Solver Tolerance`.
    pub relative_tolerance: f64,
    /// `Linear Solver Maximum Iterations` (`None`: the number of unknowns).
    pub maximum_iterations: Option<u64>,
    /// Belos parameters for `Backend: "Trilinos"`: those of Peridigm's `Belos Print Status`,
    /// then the `Belos` sublist's (names and types checked, in file order); each replaces the
    /// value peridyn would set, a later one an earlier one (see [`super::belos`]).
    pub belos_parameters: Vec<(String, ParameterValue)>,
    /// `PETSc Options` for `Backend: "PETSc"` as (option name without its `-`, value) pairs
    /// in deck order; the syntax is checked by the deck reader, the names and values by PETSc
    /// when the run (or `peridyn check`) sets the solver up. Default none.
    pub petsc_options: Vec<(String, Option<String>)>,
    /// `Nonlinear Solver`: who drives the Newton iteration of `QuasiStatic` and `Implicit`
    /// lists. Default [`NonlinearMethod::Newton`].
    pub nonlinear_method: NonlinearMethod,
}

/// `Nonlinear Solver` of `QuasiStatic` and `Implicit` lists.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NonlinearMethod {
    /// `"Newton"` (default): peridyn's Newton with a backtracking line search.
    Newton,
    /// `"SNES"`: PETSc's SNES `newtonls` (`Backend: "PETSc"`, Cargo feature `petsc`).
    Snes,
}

/// `Linear Solver`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LinearMethod {
    /// `"Automatic"` (default): `Direct` for small systems, `CG` for large ones (Jacobian-free
    /// Newton–Krylov with AMG for large quasi-static ones on the native backend).
    Automatic,
    /// `"Direct"`: sparse Cholesky, LU when the matrix is not positive definite.
    Direct,
    /// `"Cholesky"`: sparse Cholesky only (fails on an indefinite stiffness).
    Cholesky,
    /// `"LU"`: sparse LU.
    Lu,
    /// `"CG"`: preconditioned conjugate gradients.
    Cg,
    /// `"GMRES"`: restarted GMRES.
    Gmres,
}

impl LinearMethod {
    /// Largest number of unknowns `Automatic` solves with a sparse factorization.
    pub const AUTOMATIC_DIRECT_LIMIT: usize = 30_000;
}

/// `Backend`: who solves the assembled linear systems.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LinearBackend {
    /// `"Native"` (default): faer factorizations and our own Krylov methods.
    Native,
    /// `"Trilinos"`: Belos through the Trilinos bridge (Cargo feature `trilinos`).
    Trilinos {
        /// `Linear Solver Preconditioner`.
        preconditioner: AlgebraicPreconditioner,
        /// `Linear Solver ILU Level Of Fill` (default 0).
        ilu_fill_level: u32,
    },
    /// `"PETSc"`: KSP/PC and SNES through the PETSc bindings (Cargo feature `petsc`).
    Petsc {
        /// `Linear Solver Preconditioner`.
        preconditioner: PetscPreconditioner,
        /// `Linear Solver ILU Level Of Fill` (default 0).
        ilu_fill_level: u32,
    },
}

impl LinearBackend {
    /// `Backend: "Trilinos"` with its default preconditioner (ILU(0)).
    pub const TRILINOS_DEFAULT: LinearBackend = LinearBackend::Trilinos {
        preconditioner: AlgebraicPreconditioner::Ilu,
        ilu_fill_level: 0,
    };

    /// `Backend: "PETSc"` with its default preconditioner (block Jacobi with ILU(0) blocks,
    /// PETSc's own default).
    pub const PETSC_DEFAULT: LinearBackend = LinearBackend::Petsc {
        preconditioner: PetscPreconditioner::Ilu,
        ilu_fill_level: 0,
    };
}

/// `Linear Solver Preconditioner` values of the Trilinos backend.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AlgebraicPreconditioner {
    /// `"None"`.
    None,
    /// `"Jacobi"`: Ifpack point Jacobi.
    Jacobi,
    /// `"ILU"` (default): Ifpack incomplete LU.
    Ilu,
    /// `"ML"` (or `"AMG"`, the native backend's name for its multigrid, so that a deck keeps
    /// its multigrid when it moves to Trilinos): ML smoothed-aggregation algebraic multigrid.
    Ml,
}

/// `Linear Solver Preconditioner` values of the PETSc backend.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PetscPreconditioner {
    /// `"None"`: `-pc_type none`.
    None,
    /// `"Jacobi"`: `-pc_type jacobi`.
    Jacobi,
    /// `"ILU"` (default): `-pc_type bjacobi` with ILU(k) on each block (one block per process).
    Ilu,
    /// `"GAMG"` (or `"AMG"`): PETSc's smoothed-aggregation multigrid with the rigid-body modes
    /// of the unknowns as its near-null space, on the assembled tangent or (JFNK with
    /// `Peridigm Preconditioner: "AMG"`) the one-hop operator.
    Gamg,
    /// `"Hypre"`: hypre's BoomerAMG (`-pc_type hypre`).
    Hypre,
}

/// `Linear Solver Preconditioner` values of the native backend.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LinearPreconditioner {
    /// `"Block 3x3"`: the inverted diagonal block of each point.
    Block3x3,
    /// `"Jacobi"`: the inverted diagonal.
    Jacobi,
    /// `"None"`.
    None,
    /// `"AMG"`: peridyn's smoothed-aggregation multigrid (additive two-level form) built on the one-hop
    /// PMB-like operator of the model ([`crate::tangent::one_hop_operator`]), built once and
    /// rebuilt only when bonds break or points are held.
    Amg,
}

/// `Belos *` settings of Peridigm's linear solves.
#[derive(Debug, Clone, PartialEq)]
pub struct BelosSettings {
    /// `Belos Linear Solver` — `BlockCG` (default) or `BlockGMRES`.
    pub linear_solver: BelosSolver,
    /// `Belos Maximum Iterations` — default: the number of global rows.
    pub maximum_iterations: Option<u64>,
    /// `Belos Relative Tolerance` — default 1e-4.
    pub relative_tolerance: f64,
    /// `Belos Print Status` — default false; true prints Belos' status tests at every
    /// iteration on `Backend: "Trilinos"` (Belos `Verbosity` errors + warnings + status-test
    /// details, `Output Frequency` 1).
    pub print_status: bool,
}

/// `Belos Linear Solver`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BelosSolver {
    /// `"BlockCG"`.
    BlockCg,
    /// `"BlockGMRES"`.
    BlockGmres,
}

/// Reads the `Belos *` keys; the flag says whether `Belos Linear Solver` was given.
pub(super) fn read_belos(
    ctx: &Ctx,
    list: &mut ListReader,
) -> Result<(BelosSettings, bool), DeckError> {
    let given = list.peek("Belos Linear Solver").is_some();
    let settings = BelosSettings {
        linear_solver: match list.get("Belos Linear Solver") {
            None => BelosSolver::BlockCg,
            Some(f) => match f.choice(ctx, &["BlockCG", "BlockGMRES"])? {
                "BlockGMRES" => BelosSolver::BlockGmres,
                _ => BelosSolver::BlockCg,
            },
        },
        maximum_iterations: list
            .int_opt(ctx, "Belos Maximum Iterations", 1)?
            .map(|v| v as u64),
        relative_tolerance: list
            .positive_opt(ctx, "Belos Relative Tolerance")?
            .unwrap_or(1e-4),
        print_status: list.bool_or(ctx, "Belos Print Status", false)?,
    };
    Ok((settings, given))
}

/// Belos `Verbosity` of Peridigm's `Belos Print Status: true`: `Belos::Errors + Warnings +
/// StatusTestDetails` (0 + 0x1 + 0x20).
const BELOS_STATUS_VERBOSITY: i64 = 0x21;

/// The error for `Backend: "PETSc"` in a build without the backend.
pub(crate) const PETSC_NOT_BUILT: &str = "Backend \"PETSc\" needs a peridyn built with the Cargo feature `petsc` \
     (cargo build --release --features petsc, with PETSc, MPI and libclang installed: see .ci/petsc.sh)";

/// The error for `Backend: "Trilinos"` in a build without the backend.
pub(crate) const TRILINOS_NOT_BUILT: &str = "Backend \"Trilinos\" needs a peridyn built with the Cargo feature `trilinos` \
     (cargo build --release --features trilinos, with Trilinos and MPI installed: see .ci/trilinos.sh); \
     this build has the \"Native\" backend only";

/// Reads the peridyn linear-solver keys of a `Solver` list, with defaults from Peridigm's
/// `Belos` settings when the deck chose a Belos solver.
pub(super) fn read_linear_solve(
    ctx: &mut Ctx,
    list: &mut ListReader,
    belos: Option<(&BelosSettings, bool)>,
) -> Result<LinearSolve, DeckError> {
    let method = read_method(ctx, list, belos)?;
    let backend_given = list.peek("Backend").is_some();
    let preconditioner_given = list.peek("Linear Solver Preconditioner").is_some();
    let chosen = read_backend(ctx, list)?;
    let (backend, preconditioner) = if chosen == Chosen::Petsc {
        read_petsc_preconditioner(ctx, list)?
    } else {
        read_preconditioner(ctx, list, method, chosen == Chosen::Trilinos)?
    };
    // Keys of another backend than the one the list names are ignored, with a warning.
    let elsewhere = |backend: Chosen| backend_given && chosen != backend;
    let petsc_options = read_petsc_options(ctx, list, elsewhere(Chosen::Petsc))?;
    let nonlinear_method = read_nonlinear_method(ctx, list, elsewhere(Chosen::Petsc))?;
    let relative_tolerance = match list.positive_opt(ctx, "Linear Solver Tolerance")? {
        Some(t) => t,
        None => match belos {
            Some((b, true)) => b.relative_tolerance,
            _ => 1e-10,
        },
    };
    let maximum_iterations = match list.int_opt(ctx, "Linear Solver Maximum Iterations", 1)? {
        Some(m) => Some(m as u64),
        None => belos.and_then(|(b, _)| b.maximum_iterations),
    };
    let belos_parameters =
        read_belos_parameters(ctx, list, belos, elsewhere(Chosen::Trilinos), method)?;
    Ok(LinearSolve {
        backend,
        backend_given,
        method,
        preconditioner,
        preconditioner_given,
        relative_tolerance,
        maximum_iterations,
        belos_parameters,
        petsc_options,
        nonlinear_method,
    })
}

/// `Linear Solver`; without it `CG` or `GMRES` when the deck chose a Belos solver
/// (`belos`: Peridigm's settings and whether `Belos Linear Solver` was given), else
/// `Automatic`.
fn read_method(
    ctx: &mut Ctx,
    list: &mut ListReader,
    belos: Option<(&BelosSettings, bool)>,
) -> Result<LinearMethod, DeckError> {
    let belos_method = belos.and_then(|(b, given)| {
        given.then_some(match b.linear_solver {
            BelosSolver::BlockCg => LinearMethod::Cg,
            BelosSolver::BlockGmres => LinearMethod::Gmres,
        })
    });
    Ok(match list.get("Linear Solver") {
        None => belos_method.unwrap_or(LinearMethod::Automatic),
        Some(f) => match f.choice(
            ctx,
            &["Automatic", "Direct", "Cholesky", "LU", "CG", "GMRES"],
        )? {
            "Automatic" => LinearMethod::Automatic,
            "Cholesky" => LinearMethod::Cholesky,
            "LU" => LinearMethod::Lu,
            "CG" => LinearMethod::Cg,
            "GMRES" => LinearMethod::Gmres,
            _ => LinearMethod::Direct,
        },
    })
}

/// `Backend` (default `Native`); a backend this build lacks is an error naming the feature.
fn read_backend(ctx: &mut Ctx, list: &mut ListReader) -> Result<Chosen, DeckError> {
    Ok(match list.get("Backend") {
        None => Chosen::Native,
        Some(f) => match f.choice(ctx, &["Native", "Trilinos", "PETSc"])? {
            "Trilinos" if !cfg!(feature = "trilinos") => {
                return Err(f.err(ctx, TRILINOS_NOT_BUILT));
            }
            "PETSc" if !cfg!(feature = "petsc") => {
                return Err(f.err(ctx, PETSC_NOT_BUILT));
            }
            "Trilinos" => Chosen::Trilinos,
            "PETSc" => Chosen::Petsc,
            _ => Chosen::Native,
        },
    })
}

/// `PETSc Options`, ignored with a warning when the list names another backend
/// (`elsewhere`).
fn read_petsc_options(
    ctx: &mut Ctx,
    list: &mut ListReader,
    elsewhere: bool,
) -> Result<Vec<(String, Option<String>)>, DeckError> {
    let Some(f) = list.get("PETSc Options") else {
        return Ok(Vec::new());
    };
    let text = f.string(ctx)?;
    let options = parse_petsc_options(&text).map_err(|e| f.err(ctx, e))?;
    if elsewhere {
        ctx.warn(
            f.line(),
            &f.path,
            "PETSc Options apply to Backend \"PETSc\" only; ignored",
        );
    }
    Ok(options)
}

/// `Nonlinear Solver` (default `Newton`); `SNES` on a list that names another backend than
/// PETSc (`elsewhere`) is an error.
fn read_nonlinear_method(
    ctx: &mut Ctx,
    list: &mut ListReader,
    elsewhere: bool,
) -> Result<NonlinearMethod, DeckError> {
    Ok(match list.get("Nonlinear Solver") {
        None => NonlinearMethod::Newton,
        Some(f) => match f.choice(ctx, &["Newton", "SNES"])? {
            "SNES" if elsewhere => {
                return Err(f.err(
                    ctx,
                    "Nonlinear Solver \"SNES\" is PETSc's: give Backend \"PETSc\" (or remove the key for peridyn's Newton)",
                ));
            }
            "SNES" => NonlinearMethod::Snes,
            _ => NonlinearMethod::Newton,
        },
    })
}

/// The Belos parameters: those of Peridigm's `Belos Print Status`, then the `Belos`
/// sublist's, which is ignored with a warning when the list names another backend than
/// Trilinos (`elsewhere`).
fn read_belos_parameters(
    ctx: &mut Ctx,
    list: &mut ListReader,
    belos: Option<(&BelosSettings, bool)>,
    elsewhere: bool,
    method: LinearMethod,
) -> Result<Vec<(String, ParameterValue)>, DeckError> {
    let mut belos_parameters = match belos {
        // Peridigm's `Belos Print Status`: status-test output at every iteration.
        Some((b, _)) if b.print_status => vec![
            (
                "Verbosity".to_string(),
                ParameterValue::Int(BELOS_STATUS_VERBOSITY),
            ),
            ("Output Frequency".to_string(), ParameterValue::Int(1)),
        ],
        _ => Vec::new(),
    };
    belos_parameters.extend(match list.get("Belos") {
        None => Vec::new(),
        Some(f) if elsewhere => {
            ctx.warn(
                f.line(),
                &f.path,
                "the Belos parameters apply to Backend \"Trilinos\" only; ignored",
            );
            Vec::new()
        }
        Some(f) => super::belos::read(ctx, &f, method == LinearMethod::Gmres)?,
    });
    Ok(belos_parameters)
}

/// The `Backend` a solver list names.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Chosen {
    Native,
    Trilinos,
    Petsc,
}

/// The options of a `PETSc Options` string: whitespace-separated, each option a `-` followed
/// by a letter and then letters, digits or `_`, optionally followed by one value (a token that
/// is not an option: a negative number such as `-1e-3` is a value). Returns (name without the
/// `-`, value) pairs in order, or what is wrong and how to write it.
pub fn parse_petsc_options(text: &str) -> Result<Vec<(String, Option<String>)>, String> {
    let is_option = |token: &str| {
        token
            .strip_prefix('-')
            .and_then(|name| name.chars().next())
            .is_some_and(|c| c.is_ascii_alphabetic())
    };
    let mut options: Vec<(String, Option<String>)> = Vec::new();
    for token in text.split_whitespace() {
        if is_option(token) {
            let name = &token[1..];
            if !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
                return Err(format!(
                    "\"{token}\" is not a PETSc option name (letters, digits and _ after the -), e.g. \"-ksp_type gmres -pc_type gamg\""
                ));
            }
            options.push((name.to_string(), None));
            continue;
        }
        match options.last_mut() {
            Some((_, value @ None)) => *value = Some(token.to_string()),
            Some((name, Some(previous))) => {
                return Err(format!(
                    "\"{token}\" follows \"-{name} {previous}\": a PETSc option takes one value; start each option with -, e.g. \"-ksp_type gmres -pc_type gamg\""
                ))
            }
            None => {
                return Err(format!(
                    "\"{token}\" is not an option: PETSc options start with -, e.g. \"-ksp_type gmres -pc_type gamg\""
                ))
            }
        }
    }
    Ok(options)
}

/// `Linear Solver Preconditioner` and `Linear Solver ILU Level Of Fill` for the PETSc backend;
/// returns the backend and the native preconditioner (`Block 3x3`, unused on PETSc).
fn read_petsc_preconditioner(
    ctx: &mut Ctx,
    list: &mut ListReader,
) -> Result<(LinearBackend, LinearPreconditioner), DeckError> {
    let preconditioner = match list.get("Linear Solver Preconditioner") {
        None => PetscPreconditioner::Ilu,
        Some(f) => match f.choice(
            ctx,
            &["ILU", "Jacobi", "GAMG", "Hypre", "None", "Block 3x3", "AMG", "ML"],
        )? {
            "ILU" => PetscPreconditioner::Ilu,
            "Jacobi" => PetscPreconditioner::Jacobi,
            "GAMG" | "AMG" => PetscPreconditioner::Gamg,
            "Hypre" => PetscPreconditioner::Hypre,
            "None" => PetscPreconditioner::None,
            other => {
                return Err(f.err(
                    ctx,
                    format!("\"{other}\" is not a PETSc preconditioner; with Backend \"PETSc\" choose \"ILU\", \"GAMG\" (or \"AMG\"), \"Hypre\", \"Jacobi\" or \"None\" (or give -pc_type in PETSc Options)"),
                ))
            }
        },
    };
    let ilu_fill_level = list
        .int_opt(ctx, "Linear Solver ILU Level Of Fill", 0)?
        .map_or(0, |v| v as u32);
    Ok((
        LinearBackend::Petsc {
            preconditioner,
            ilu_fill_level,
        },
        LinearPreconditioner::Block3x3,
    ))
}

/// `Linear Solver Preconditioner` and `Linear Solver ILU Level Of Fill` for the Trilinos
/// backend (`trilinos`) or the native one; returns the backend with its preconditioner
/// settings and the native preconditioner (`Block 3x3` on Trilinos).
fn read_preconditioner(
    ctx: &mut Ctx,
    list: &mut ListReader,
    method: LinearMethod,
    trilinos: bool,
) -> Result<(LinearBackend, LinearPreconditioner), DeckError> {
    let given_preconditioner = match list.get("Linear Solver Preconditioner") {
        None => None,
        Some(f) => Some((
            f.choice(ctx, &["Block 3x3", "Jacobi", "None", "AMG", "ILU", "ML"])?,
            f,
        )),
    };
    let ilu_field = list.get("Linear Solver ILU Level Of Fill");
    let ilu_fill_level = list
        .int_opt(ctx, "Linear Solver ILU Level Of Fill", 0)?
        .map_or(0, |v| v as u32);
    if trilinos {
        if matches!(
            method,
            LinearMethod::Direct | LinearMethod::Cholesky | LinearMethod::Lu
        ) {
            let f = list
                .peek("Linear Solver")
                .expect("a direct method is only chosen by this key");
            return Err(f.err(
                ctx,
                "Backend \"Trilinos\" solves with Belos Krylov methods: use \"CG\", \"GMRES\" or \"Automatic\" \
                 (direct solves are on Backend \"Native\")",
            ));
        }
        let algebraic = match given_preconditioner {
            None | Some(("ILU", _)) => AlgebraicPreconditioner::Ilu,
            Some(("ML" | "AMG", _)) => AlgebraicPreconditioner::Ml,
            Some(("Jacobi", _)) => AlgebraicPreconditioner::Jacobi,
            Some(("None", _)) => AlgebraicPreconditioner::None,
            Some((native, f)) => {
                return Err(f.err(
                    ctx,
                    format!("\"{native}\" is a native preconditioner; with Backend \"Trilinos\" choose \"ILU\", \"ML\", \"Jacobi\" or \"None\""),
                ))
            }
        };
        let backend = LinearBackend::Trilinos {
            preconditioner: algebraic,
            ilu_fill_level,
        };
        return Ok((backend, LinearPreconditioner::Block3x3));
    }
    if let Some((choice @ ("ILU" | "ML"), f)) = given_preconditioner {
        return Err(f.err(
                ctx,
                format!("\"{choice}\" is a Trilinos preconditioner: add Backend: \"Trilinos\" to this solver list, or choose \"Block 3x3\", \"AMG\", \"Jacobi\" or \"None\""),
            ));
    }
    if let Some(f) = ilu_field {
        ctx.warn(
            f.line(),
            &f.path,
            "Linear Solver ILU Level Of Fill applies to Backend \"Trilinos\" only; ignored",
        );
    }
    let preconditioner = match given_preconditioner {
        Some(("Jacobi", _)) => LinearPreconditioner::Jacobi,
        Some(("None", _)) => LinearPreconditioner::None,
        Some(("AMG", _)) => LinearPreconditioner::Amg,
        _ => LinearPreconditioner::Block3x3,
    };
    Ok((LinearBackend::Native, preconditioner))
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::io::deck::{parse_str, DeckFormat};
    use crate::io::deck::{Integrator, PeridigmPreconditioner};
    use std::path::Path;

    /// The linear-solver settings of [`deck`] with `keys`.
    fn linear_solve(keys: &str) -> Result<LinearSolve, DeckError> {
        Ok(deck(keys)?.solvers[0].linear_solve.clone())
    }

    /// A three-point quasi-static bar whose `Solver` list gets `keys`.
    fn deck(keys: &str) -> Result<crate::io::deck::Deck, DeckError> {
        deck_with(keys, "")
    }

    /// [`deck`] whose `QuasiStatic` list also gets `quasi_static_keys`.
    fn deck_with(keys: &str, quasi_static_keys: &str) -> Result<crate::io::deck::Deck, DeckError> {
        parse_str(
            &deck_text(keys, quasi_static_keys),
            DeckFormat::Yaml,
            Path::new("linear.yaml"),
        )
    }

    /// The text of [`deck_with`].
    fn deck_text(keys: &str, quasi_static_keys: &str) -> String {
        three_point_bar_text(&format!(
            "    Final Time: 1.0\n{keys}\n    QuasiStatic:\n      Number of Load Steps: 2\n{quasi_static_keys}"
        ))
    }

    /// A three-point steel bar deck (Elastic, horizon 2) whose `Solver` list holds the lines
    /// `solver_list` (indented as its children), for tests of solver-list keys.
    pub(crate) fn three_point_bar_text(solver_list: &str) -> String {
        format!(
            r#"Peridigm:
  Discretization:
    Type: "PdQuickGrid"
    NeighborhoodType: "Spherical"
    TensorProduct3DMeshGenerator:
      X Origin: 0.0
      Y Origin: 0.0
      Z Origin: 0.0
      X Length: 3.0
      Y Length: 1.0
      Z Length: 1.0
      Number Points X: 3
      Number Points Y: 1
      Number Points Z: 1
  Materials:
    Steel:
      Material Model: "Elastic"
      Density: 7800.0
      Bulk Modulus: 130.0e9
      Shear Modulus: 78.0e9
  Blocks:
    Everything:
      Block Names: "block_1"
      Material: "Steel"
      Horizon: 2
  Solver:
{solver_list}
  Output:
    Output Filename: "bar"
    Output Variables:
      Displacement: true
"#
        )
    }

    /// The warnings of the deck of [`linear_solve`] with `keys`.
    fn warnings(keys: &str) -> Vec<String> {
        deck(keys).unwrap().warnings
    }

    #[test]
    fn the_belos_sublist_is_read_with_belos_types() {
        let settings = linear_solve(
            "    Linear Solver: \"GMRES\"\n    Belos:\n      Maximum Iterations: 7\n      Convergence Tolerance: 1\n      Num Blocks: 30\n      Orthogonalization: \"ICGS\"\n      Flexible Gmres: false",
        )
        .unwrap();
        assert_eq!(
            settings.belos_parameters,
            vec![
                ("Maximum Iterations".to_string(), ParameterValue::Int(7)),
                // Integers are accepted for doubles and stored as doubles (Belos reads a double).
                (
                    "Convergence Tolerance".to_string(),
                    ParameterValue::Double(1.0)
                ),
                ("Num Blocks".to_string(), ParameterValue::Int(30)),
                (
                    "Orthogonalization".to_string(),
                    ParameterValue::String("ICGS".into())
                ),
                ("Flexible Gmres".to_string(), ParameterValue::Bool(false)),
            ]
        );
        assert!(linear_solve("").unwrap().belos_parameters.is_empty());
    }

    #[test]
    fn peridigm_belos_print_status_asks_belos_for_status_output() {
        let deck = deck_with(
            "    Belos:\n      Output Frequency: 5",
            "      Belos Print Status: true",
        )
        .unwrap();
        assert_eq!(
            deck.solvers[0].linear_solve.belos_parameters,
            vec![
                ("Verbosity".to_string(), ParameterValue::Int(0x21)),
                ("Output Frequency".to_string(), ParameterValue::Int(1)),
                // The sublist comes last and wins.
                ("Output Frequency".to_string(), ParameterValue::Int(5)),
            ]
        );
    }

    #[test]
    fn an_unknown_or_mistyped_belos_parameter_is_an_error_with_its_line() {
        let error = linear_solve("    Belos:\n      Maximum Iteration: 7")
            .unwrap_err()
            .to_string();
        assert!(
            error.contains("did you mean \"Maximum Iterations\""),
            "{error}"
        );
        assert!(error.contains("linear.yaml:29"), "{error}");
        assert!(error.contains("Belos → Maximum Iteration"), "{error}");
        let error = linear_solve("    Belos:\n      Output Stream: \"cout\"")
            .unwrap_err()
            .to_string();
        assert!(error.contains("unknown Belos parameter"), "{error}");
        let error = linear_solve("    Belos:\n      Maximum Iterations: 7.5")
            .unwrap_err()
            .to_string();
        assert!(error.contains("expected an integer"), "{error}");
    }

    #[test]
    fn a_belos_parameter_the_chosen_solver_does_not_read_is_a_warning() {
        let cg = warnings("    Linear Solver: \"CG\"\n    Belos:\n      Num Blocks: 30");
        assert!(
            cg.iter()
                .any(|w| w.contains("Num Blocks") && w.contains("only Belos BlockGMRES")),
            "{cg:?}"
        );
        let native = warnings("    Backend: \"Native\"\n    Belos:\n      Maximum Iterations: 7");
        assert!(
            native
                .iter()
                .any(|w| w.contains("Backend \"Trilinos\" only")),
            "{native:?}"
        );
    }

    #[test]
    fn native_is_the_default_backend_with_block_jacobi() {
        let settings = linear_solve("").unwrap();
        assert_eq!(settings.backend, LinearBackend::Native);
        assert_eq!(settings.preconditioner, LinearPreconditioner::Block3x3);
        assert_eq!(settings.method, LinearMethod::Automatic);
    }

    #[test]
    fn amg_is_a_native_preconditioner_for_newton_and_jfnk() {
        let settings = linear_solve("    Linear Solver Preconditioner: \"AMG\"").unwrap();
        assert_eq!(settings.backend, LinearBackend::Native);
        assert_eq!(settings.preconditioner, LinearPreconditioner::Amg);
        let solver = &deck("    Peridigm Preconditioner: \"AMG\"")
            .unwrap()
            .solvers[0];
        assert_eq!(solver.peridigm_preconditioner, PeridigmPreconditioner::Amg);
        let error = linear_solve("    Linear Solver Preconditioner: \"AMGX\"")
            .unwrap_err()
            .to_string();
        assert!(error.contains("AMGX") && error.contains("AMG"), "{error}");
        assert!(error.contains("linear.yaml"), "{error}");
    }

    #[test]
    fn trilinos_preconditioners_need_the_trilinos_backend() {
        let error = linear_solve("    Linear Solver Preconditioner: \"ILU\"")
            .unwrap_err()
            .to_string();
        assert!(error.contains("Backend: \"Trilinos\""), "{error}");
        assert!(error.contains("linear.yaml"), "{error}");
    }

    #[cfg(not(feature = "trilinos"))]
    #[test]
    fn the_trilinos_backend_without_the_feature_names_the_feature() {
        let error = linear_solve("    Backend: \"Trilinos\"")
            .unwrap_err()
            .to_string();
        assert!(error.contains("--features trilinos"), "{error}");
        assert!(error.contains("Backend"), "{error}");
    }

    #[cfg(feature = "trilinos")]
    #[test]
    fn amg_on_the_trilinos_backend_is_ml_and_block_3x3_names_its_alternatives() {
        let amg =
            linear_solve("    Backend: \"Trilinos\"\n    Linear Solver Preconditioner: \"AMG\"")
                .unwrap();
        assert!(
            matches!(
                amg.backend,
                LinearBackend::Trilinos {
                    preconditioner: AlgebraicPreconditioner::Ml,
                    ..
                }
            ),
            "{amg:?}"
        );
        let error = linear_solve(
            "    Backend: \"Trilinos\"\n    Linear Solver Preconditioner: \"Block 3x3\"",
        )
        .unwrap_err()
        .to_string();
        assert!(
            error.contains("\"Block 3x3\" is a native preconditioner") && error.contains("\"ML\""),
            "{error}"
        );
    }

    /// The backend a `NOXQuasiStatic` list gets without a `Backend` key, with `Peridigm
    /// Preconditioner` `preconditioner`.
    fn nox_default_backend(preconditioner: &str) -> LinearBackend {
        let text = deck_text("", "").replace(
            "    QuasiStatic:\n      Number of Load Steps: 2\n",
            &format!(
                "    Peridigm Preconditioner: \"{preconditioner}\"\n    NOXQuasiStatic:\n      Number of Load Steps: 2\n      Direction: {{Method: \"Newton\", Newton: {{Linear Solver: {{Jacobian Operator: \"Matrix-Free\"}}}}}}\n"
            ),
        );
        let deck = parse_str(&text, DeckFormat::Yaml, Path::new("nox.yaml")).unwrap();
        assert!(matches!(
            deck.solvers[0].integrator,
            Integrator::NoxQuasiStatic(_)
        ));
        deck.solvers[0].linear_solve.backend
    }

    /// A deck that asks for peridyn's AMG stays on the native backend in a Trilinos build
    /// (NOX would refuse it); Peridigm's own preconditioner values get NOX.
    #[test]
    fn nox_lists_asking_for_amg_stay_native() {
        assert_eq!(nox_default_backend("AMG"), LinearBackend::Native);
        let peridigm = nox_default_backend("Block 3x3");
        if cfg!(feature = "trilinos") {
            assert_eq!(peridigm, LinearBackend::TRILINOS_DEFAULT);
        } else {
            assert_eq!(peridigm, LinearBackend::Native);
        }
    }

    #[cfg(feature = "trilinos")]
    #[test]
    fn the_trilinos_backend_reads_its_preconditioner_and_fill() {
        let settings = linear_solve("    Backend: \"Trilinos\"").unwrap();
        assert_eq!(
            settings.backend,
            LinearBackend::Trilinos {
                preconditioner: AlgebraicPreconditioner::Ilu,
                ilu_fill_level: 0
            }
        );
        let settings = linear_solve(
            "    Backend: \"Trilinos\"\n    Linear Solver Preconditioner: \"ML\"\n    Linear Solver ILU Level Of Fill: 2",
        )
        .unwrap();
        assert_eq!(
            settings.backend,
            LinearBackend::Trilinos {
                preconditioner: AlgebraicPreconditioner::Ml,
                ilu_fill_level: 2
            }
        );
    }
}
