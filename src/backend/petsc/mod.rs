//! PETSc backend (feature `petsc`): KSP/PC solves of our assembled [`Csr`](super::Csr)
//! matrices behind the [`LinearSolver`](super::LinearSolver) seam ([`linear`]), and SNES
//! Newton (line search, or Jacobian-free with `-snes_mf_operator`) on a
//! [`NonlinearProblem`](super::problem::NonlinearProblem) ([`snes`]), configured by a solver
//! list's keys ([`list`]) and its `PETSc Options` string ([`options`]).
//!
//! **Why bindgen and not the `cxx` shim of the Trilinos backend.** PETSc is a C library: its
//! API is plain functions on opaque handles returning an error code, with no exceptions,
//! templates or C++ types to adapt. bindgen turns its headers into exactly those `extern "C"`
//! declarations (an allow-list in `build.rs` keeps only the ~80 functions used), so there is no
//! C++ to compile and nothing to keep in step by hand; every call's code goes through
//! [`runtime::check`], which gives a Rust `Err` with PETSc's message. The one direction cxx
//! would help with — PETSc calling Rust — is a C function pointer plus a `void*` context, which
//! Rust writes directly (`extern "C" fn` with `catch_unwind`, see [`snes`]).
//!
//! PETSc is found by pkg-config (`petsc`), with `PETSC_DIR`/`PETSC_ARCH` pointing pkg-config at
//! a cluster's own build; see `build.rs`. Debian 12's `libpetsc-real-dev` (PETSc 3.18) has
//! MUMPS, hypre and GAMG, all used here.
//!
//! Initialisation, finalisation and the error handler are in [`runtime`]. On one process the
//! objects live on `MPI_COMM_SELF` over arrays peridyn owns; on several MPI ranks they live on
//! `MPI_COMM_WORLD`: each rank's unknowns become a contiguous range of PETSc rows, the tangent
//! a `MATMPIAIJ` of every rank's rows ([`layout`]), and KSP ([`linear`]) and SNES ([`snes`])
//! run across the ranks, SNES calling the residual that refreshes the ghosts.

pub mod layout;
pub mod linear;
pub mod list;
pub mod options;
pub mod runtime;
pub mod snes;
mod sys;

pub use linear::{KspMethod, PetscLinearSolver, PetscSettings};
pub use options::DeckOptions;
pub use runtime::PetscError;
