//! # peridyn
//!
//! Peridynamics in Rust, reading Peridigm's input decks. A body is a cloud of material points;
//! each point interacts with every point within its horizon δ through bonds, and the equation
//! of motion is an integral over those bonds instead of a PDE, so cracks need no special
//! treatment (Silling 2000).
//!
//! ## Glossary
//! - **point**: a material point with reference position X, volume V, block and horizon δ.
//! - **family**: the points within δ of a point; **bond**: one (point, neighbour) pair, stored
//!   from both ends (directed), with reference length ζ = |X_j − X_i|.
//! - **stretch** s = (|Y_j − Y_i| − ζ)/ζ, with Y = X + u the current position.
//! - **force density**: force per unit volume, the unknown of Peridigm's equations; a point's
//!   force is force density × V.
//! - **weighted volume** m and **dilatation** θ: the per-point numbers of state-based models (LPS).
//! - **block**: a group of points sharing a material and damage model (`block_<id>` in meshes).
//! - **node set**: a named list of points that boundary conditions and compute classes refer to.
//! - **run order / original id**: points are renumbered along a space-filling curve for speed;
//!   the original id (input order, 1-based in decks and files) is what users see.
//!
//! ## Module map
//! Each module answers one question; none imports another that imports it back
//! (`cargo xtask import-circles` checks).
//!
//! | module | question it answers |
//! |---|---|
//! | [`io::deck`] | what did the user ask for? (Peridigm YAML/XML decks, validated once) |
//! | `parameter_list` | how is one list of a deck read? (the key tree with its lines, typed reading with "did you mean" errors), for the deck and for the models that read their own keys |
//! | [`discretization`] | where are the points? (QuickGrid generators, text files, Exodus meshes) |
//! | [`neighbors`] | who bonds with whom? (family search, bond filters, space-filling-curve order) |
//! | [`setup`] | deck → [`model::Model`] and the blocks' physics; the run plan `peridyn check` prints |
//! | [`model`] | the immutable description: [`model::Model`], points, node sets, bond lists, and what models declare about themselves ([`model::ModelDeclaration`]) |
//! | [`state`] | where is the body now? Everything that evolves: kinematics, forces, bond damage and material history as staged (trial/committed) fields |
//! | [`history`] | staged (trial/committed) fields, the materials' history and the declarations of model fields |
//! | [`material`], [`damage`] | the physics of bonds (PMB, LPS, the correspondence family, critical stretch); [`material::MATERIALS`] and [`damage::DAMAGE_MODELS`] are the one list of models |
//! | [`contact`] | short-range forces between points that are not bonded |
//! | [`physics`] | the one internal-force path every solver calls |
//! | [`compute`] | derived outputs such as the deformation gradient |
//! | [`boundary`] | prescribed displacements, initial conditions, body forces |
//! | [`expression`] | Peridigm's C-like expressions in x, y, z, t |
//! | [`solver`] | how time advances (velocity Verlet and its stability monitor; quasi-static Newton load stepping, Newmark-β, Jacobian-free Newton–Krylov); [`solver::problem`] wraps the physics as a physics-free nonlinear problem |
//! | [`tangent`] | ∂f/∂u in 3×3 blocks: patterns, analytic / automatic-differentiation / finite-difference assembly |
//! | [`backend`] | who does the linear algebra: the `Csr` matrix, the `LinearSolver` trait, the physics-free [`backend::problem::NonlinearProblem`] every nonlinear backend solves, [`backend::factory`] (what runs where), native direct and Krylov solvers, Trilinos |
//! | [`restart`] | where a run stands, in a file a later run continues from (HDF5, feature `hdf5`) |
//! | [`simulation`] | a run from start to end: one driver for one rank and N ranks, outputs, progress |
//! | [`io::exodus`], [`io::output`], [`io::history`] | results in Exodus II and CSV, and exodiff-style comparison |
//! | [`plan`] | what `peridyn check` reports |
//! | [`parallel`] | who owns which point on N MPI ranks: RCB partition, ghost (halo) plan, the one [`parallel::Ranks`] interface (serial: the no-op [`parallel::SerialRanks`]), what runs on ranks |
//! | `mpi_session` | who starts and finalises MPI (features `mpi` or `trilinos`), and which communicator handle C++ libraries get |
//! | [`error`] | why a run stopped ([`error::RunError`], with its exit code) |
//!
//! ## Life of an explicit step (velocity Verlet, Peridigm's order)
//! 1. half kick `v += ½Δt a`;
//! 2. prescribed displacements: at constrained dofs `v = (g(t_{n+1}) − g(t_n))/Δt`;
//! 3. drift `u += Δt v`, `Y = X + u`;
//! 4. body force at t_{n+1};
//! 5. ghost positions refreshed ([`parallel::Ranks::refresh`]; nothing on one rank);
//! 6. damage (bonds beyond their limit break before the force is computed);
//! 7. internal force density (materials with history first advance it from its committed
//!    values, state-based models compute their dilatation);
//! 8. contact force (when the deck has a `Contact` section);
//! 9. the state commits (explicit steps accept every step; bond damage keeps no copy, so this
//!    is free; material history copies its trial values);
//! 10. `a = (f + f_contact + b)/ρ`, second half kick;
//! 11. stability monitor and outputs.
//!
//! ## Life of a Newton step (quasi-static load step or Newmark-β step)
//! 1. prescribed displacements and body force at the end of the step; free dofs get the
//!    predictor; the state keeps a committed copy of its staged fields;
//! 2. residual `r = V ⊙ (f + b [− ρa])` over the free dofs through the same force path (the
//!    state restores its staged fields first, so bonds broken by an unconverged iterate heal);
//! 3. stiffness `K = −∂r/∂u` assembled in 3×3 blocks (or only its diagonal blocks for
//!    Jacobian-free Newton–Krylov), linear solve `K Δ = r`; the nonlinear backend (peridyn's
//!    Newton or NOX) sees only the [`backend::problem::NonlinearProblem`];
//! 4. line search on ‖r‖, repeat until the measure meets the tolerance; then velocities, the
//!    state commits, output.
//!
//! ## Example
//! ```no_run
//! use std::path::Path;
//! let deck = peridyn::io::deck::load(Path::new("examples/wave_in_bar.yaml"))?;
//! let model = peridyn::setup::build(&deck)?;
//! println!("{} points, {} bonds", model.points.len(), model.bonds.num_bonds());
//! let summary = peridyn::simulation::run(&deck, &model, Path::new("out"))?;
//! println!("{} steps", summary.steps);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![warn(missing_docs)]

pub mod backend;
pub mod boundary;
pub mod compute;
pub mod contact;
pub mod damage;
pub mod discretization;
pub mod error;
pub mod expression;
pub mod history;
pub mod interrupt;
pub mod io;
pub mod material;
pub mod model;
#[cfg(any(feature = "mpi", feature = "trilinos", feature = "petsc"))]
pub mod mpi_session;
pub mod neighbors;
pub mod parallel;
mod parameter_list;
pub mod physics;
pub mod plan;
pub mod restart;
pub mod setup;
pub mod simulation;
pub mod solver;
pub mod state;
pub mod tangent;
mod vector_width;
