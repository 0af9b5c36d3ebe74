//! The process's MPI environment (features `mpi`, `trilinos` or `petsc`, rsmpi): the one place
//! that starts and finalises MPI, and hands communicators to C++ libraries as Fortran handles.
//!
//! The distributed run's communicator is [`crate::parallel::MpiCommunicator`] (feature `mpi`);
//! this module only owns the environment, so the backends and the ranks both depend on it and
//! not on each other.
//!
//! A program holds an [`MpiSession`] for its whole run (`peridyn run` does): MPI starts when
//! it is created and is finalised when it is dropped, which a process under `mpirun` must do
//! before it exits. Trilinos' `Epetra_MpiComm` needs MPI even on one process, so a build with
//! `trilinos` alone starts it too.
//!
//! Code that asks for a communicator ([`fortran_handle`]) in a process that holds no session
//! — a test, a library user — starts MPI for the rest of the process instead. That MPI is
//! never finalised, which is harmless for a process not started by `mpirun` (a singleton);
//! a program run under `mpirun` must hold a session.
//!
//! MPI is started with `MPI_THREAD_SERIALIZED`: only one thread calls MPI at a time, but not
//! always the same one (the Trilinos and PETSc backends may be called from any thread, taking
//! turns through [`MPI_TURN`]; the test harness runs tests on several threads).
//!
//! A library that must be shut down while MPI still runs (PETSc's `PetscFinalize`) registers
//! its shutdown with [`before_finalize`]; the session runs it just before `MPI_Finalize`.

use std::sync::{Mutex, OnceLock};

use mpi::environment::Universe;
use mpi::raw::AsRaw;
use mpi::topology::{Communicator as _, SimpleCommunicator};
use mpi::Threading;

/// MPI for the lifetime of this value: started by [`MpiSession::start`], finalised on drop
/// (after the shutdowns registered with [`before_finalize`]).
pub struct MpiSession {
    _universe: Universe,
}

/// MPI runs with `MPI_THREAD_SERIALIZED`: the backends' calls into MPI and into libraries that
/// call it (Trilinos, PETSc) hold this lock, so solves from several threads take turns.
pub static MPI_TURN: Mutex<()> = Mutex::new(());

/// Shutdowns to run before MPI is finalised, in the order registered.
static BEFORE_FINALIZE: Mutex<Vec<fn()>> = Mutex::new(Vec::new());

/// Runs `shutdown` when the process's [`MpiSession`] ends, before `MPI_Finalize` (once per
/// registration; a process without a session never finalises MPI, see the module docs).
pub fn before_finalize(shutdown: fn()) {
    BEFORE_FINALIZE
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .push(shutdown);
}

impl Drop for MpiSession {
    fn drop(&mut self) {
        let shutdowns =
            std::mem::take(&mut *BEFORE_FINALIZE.lock().unwrap_or_else(|p| p.into_inner()));
        for shutdown in shutdowns {
            shutdown();
        }
    }
}

impl MpiSession {
    /// Starts MPI. `None` when MPI was already started (by another session, or by
    /// [`fortran_handle`] in a process without one).
    ///
    /// On more than one rank a panic on any rank ends all ranks (`MPI_Abort`) after printing
    /// its message, instead of leaving the others waiting in a collective.
    pub fn start() -> Option<Self> {
        let universe = start_mpi()?;
        if SimpleCommunicator::world().size() > 1 {
            let previous = std::panic::take_hook();
            std::panic::set_hook(Box::new(move |info| {
                previous(info);
                SimpleCommunicator::world().abort(101);
            }));
        }
        Some(Self {
            _universe: universe,
        })
    }
}

fn start_mpi() -> Option<Universe> {
    mpi::initialize_with_threading(Threading::Serialized).map(|(universe, _)| universe)
}

/// Which communicator a C++ library gets.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CommScope {
    /// `MPI_COMM_WORLD`: every rank of the run.
    World,
    /// `MPI_COMM_SELF`: this process alone.
    Process,
}

/// A communicator as its Fortran handle (`MPI_Comm_c2f`): a plain integer every MPI
/// implementation turns back into its `MPI_Comm` with `MPI_Comm_f2c`, so it crosses an FFI
/// boundary without knowing whether `MPI_Comm` is a pointer (OpenMPI) or an `int` (MPICH).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FortranComm {
    /// The handle.
    pub handle: i32,
    /// Number of processes in the communicator.
    pub size: usize,
}

/// The Fortran handle of `scope`'s communicator. Starts MPI for the rest of the process when
/// nobody has (see the module docs); fails once MPI has been finalised.
pub fn fortran_handle(scope: CommScope) -> Result<FortranComm, String> {
    static STARTED_HERE: OnceLock<Option<Universe>> = OnceLock::new();
    if !mpi::environment::is_initialized() {
        STARTED_HERE.get_or_init(start_mpi);
    }
    if mpi::environment::is_finalized() {
        return Err("MPI has been finalised (the MpiSession holding it was dropped)".into());
    }
    let communicator = match scope {
        CommScope::World => SimpleCommunicator::world(),
        CommScope::Process => SimpleCommunicator::self_comm(),
    };
    // SAFETY: MPI is initialised and not finalised (checked above), and the handle is one
    // of the predefined communicators, valid until MPI_Finalize.
    let handle = unsafe { mpi::ffi::RSMPI_Comm_c2f(communicator.as_raw()) };
    Ok(FortranComm {
        handle,
        size: usize::try_from(communicator.size()).unwrap_or(0),
    })
}
