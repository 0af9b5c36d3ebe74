//! PETSc's life in the process and its errors: the one place that initialises and finalises
//! PETSc, and turns every error code into a Rust `Err` carrying PETSc's own message.
//!
//! * MPI comes first ([`crate::mpi_session`]): [`Turn::take`] asks for a communicator, which
//!   starts MPI when nobody has, then calls `PetscInitializeNoArguments` once (PETSc sees MPI
//!   running and leaves it alone: `PetscFinalize` will not finalise it). peridyn's command-line
//!   arguments are not PETSc's, so none are passed; `PETSC_OPTIONS` in the environment still
//!   reaches the options database.
//! * `PetscFinalize` is registered with [`crate::mpi_session::before_finalize`], so a
//!   `peridyn run` holding an [`MpiSession`](crate::mpi_session::MpiSession) ends PETSc just before
//!   MPI. A process without a session (tests) never finalises either, as for MPI.
//! * PETSc's signal handler is switched off (`-no_signal_handler`): SIGINT and SIGTERM belong to
//!   [`crate::interrupt`].
//! * Errors: PETSc's default handler prints a traceback to stderr; ours
//!   ([`error_handler`]) keeps the first message of the error instead and returns the code,
//!   so every call wrapped in [`check`] becomes `Err(PetscError)` with that message. A PETSc
//!   call made while PETSc calls Rust (a SNES residual) reports a Rust failure by returning a
//!   non-zero code from the callback, never by unwinding (see [`super::snes`]).
//!
//! PETSc is not thread-safe and MPI runs `MPI_THREAD_SERIALIZED`: every PETSc call happens
//! while a [`Turn`] is held, which holds [`crate::mpi_session::MPI_TURN`] (shared with the
//! Trilinos backend).

use std::cell::RefCell;
use std::ffi::{c_char, c_int, c_void, CStr};
use std::sync::MutexGuard;

use super::sys;
use crate::mpi_session::{before_finalize, fortran_handle, CommScope, MPI_TURN};

/// A PETSc error: the code and PETSc's message (the function that raised it included).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{message} (PETSc error {code})")]
pub struct PetscError {
    /// PETSc's error code (`PETSC_ERR_*`).
    pub code: i32,
    /// PETSc's message.
    pub message: String,
}

thread_local! {
    /// The message of the error being propagated on this thread (set by [`error_handler`] when
    /// the error is raised, taken by [`check`] when it reaches us).
    static LAST_ERROR: RefCell<Option<String>> = const { RefCell::new(None) };
}

/// The PETSc error handler: keeps the first message of an error (PETSc calls the handler again
/// at every level the error passes through) and returns the code without printing. The
/// signature is PETSc's `PetscErrorHandler`.
unsafe extern "C" fn error_handler(
    _comm: sys::MPI_Comm,
    _line: c_int,
    function: *const c_char,
    _file: *const c_char,
    code: sys::PetscErrorCode,
    kind: sys::PetscErrorType,
    message: *const c_char,
    _context: *mut c_void,
) -> sys::PetscErrorCode {
    let text = |p: *const c_char| {
        if p.is_null() {
            String::new()
        } else {
            // SAFETY: PETSc passes NUL-terminated strings valid for the call.
            unsafe { CStr::from_ptr(p) }
                .to_string_lossy()
                .trim()
                .to_string()
        }
    };
    if kind == sys::PetscErrorType_PETSC_ERROR_INITIAL {
        let message = text(message);
        let function = text(function);
        let full = match (message.is_empty(), function.is_empty()) {
            (false, false) => format!("{message} (in {function})"),
            (false, true) => message,
            (true, _) => format!("error in {function}"),
        };
        LAST_ERROR.with(|last| *last.borrow_mut() = Some(full));
    }
    code
}

/// `Ok` for PETSc's success code, otherwise the error with the message PETSc raised.
pub fn check(code: sys::PetscErrorCode) -> Result<(), PetscError> {
    let message = LAST_ERROR.with(|last| last.borrow_mut().take());
    if code == 0 {
        return Ok(());
    }
    Err(PetscError {
        code,
        message: message.unwrap_or_else(|| "PETSc reported an error without a message".into()),
    })
}

/// Exclusive use of PETSc (and MPI) for the holder, with PETSc initialised.
pub struct Turn {
    _mpi: MutexGuard<'static, ()>,
}

impl Turn {
    /// Waits for PETSc to be free, starting MPI and PETSc first when nobody has.
    pub fn take() -> Result<Self, PetscError> {
        let guard = MPI_TURN.lock().unwrap_or_else(|p| p.into_inner());
        fortran_handle(CommScope::Process).map_err(|e| PetscError {
            code: -1,
            message: format!("MPI: {e}"),
        })?;
        let mut initialized = sys::PetscBool_PETSC_FALSE;
        // SAFETY: queries a flag; allowed before PetscInitialize.
        check(unsafe { sys::PetscInitialized(&mut initialized) })?;
        if initialized == sys::PetscBool_PETSC_FALSE {
            let mut finalized = sys::PetscBool_PETSC_FALSE;
            // SAFETY: as above.
            check(unsafe { sys::PetscFinalized(&mut finalized) })?;
            if finalized != sys::PetscBool_PETSC_FALSE {
                return Err(PetscError {
                    code: -1,
                    message: "PETSc has been finalised (the MPI session ended)".into(),
                });
            }
            // SAFETY: MPI is running (above); the options database may be written before
            // PetscInitialize, and PETSc is initialised once (under the lock).
            unsafe {
                check(sys::PetscOptionsInsertString(
                    std::ptr::null_mut(),
                    c"-no_signal_handler".as_ptr(),
                ))?;
                check(sys::PetscInitializeNoArguments())?;
                check(sys::PetscPushErrorHandler(
                    Some(error_handler),
                    std::ptr::null_mut(),
                ))?;
            }
            before_finalize(finalize);
        }
        Ok(Self { _mpi: guard })
    }

    /// MPI_COMM_SELF, the communicator of the process-local objects.
    pub fn comm_self(&self) -> sys::MPI_Comm {
        // SAFETY: reads rsmpi's handle of the predefined communicator, valid while MPI runs.
        unsafe { mpi::ffi::RSMPI_COMM_SELF }
    }

    /// MPI_COMM_WORLD, the communicator of the objects of a system distributed over the ranks
    /// (PETSc's `PETSC_COMM_WORLD`, which PETSc took from the running MPI).
    pub fn comm_world(&self) -> sys::MPI_Comm {
        // SAFETY: as above.
        unsafe { mpi::ffi::RSMPI_COMM_WORLD }
    }
}

/// True while PETSc objects may be destroyed (PETSc initialised and not yet finalised).
pub fn alive() -> bool {
    let mut initialized = sys::PetscBool_PETSC_FALSE;
    let mut finalized = sys::PetscBool_PETSC_FALSE;
    // SAFETY: flag queries, valid at any time.
    unsafe {
        sys::PetscInitialized(&mut initialized);
        sys::PetscFinalized(&mut finalized);
    }
    initialized != sys::PetscBool_PETSC_FALSE && finalized == sys::PetscBool_PETSC_FALSE
}

/// `PetscFinalize`, run by the MPI session before `MPI_Finalize`.
fn finalize() {
    let _turn = MPI_TURN.lock().unwrap_or_else(|p| p.into_inner());
    if alive() {
        // SAFETY: PETSc is initialised and not finalised; objects still alive are only
        // leaked (their Drop checks `alive` first).
        let code = unsafe { sys::PetscFinalize() };
        if let Err(e) = check(code) {
            eprintln!("Warning: PetscFinalize: {e}");
        }
    }
}

/// A string PETSc handed out (a type name), copied.
pub(super) fn owned_string(p: *const c_char) -> String {
    if p.is_null() {
        return String::new();
    }
    // SAFETY: PETSc's type names are NUL-terminated and live as long as their object.
    unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
}
