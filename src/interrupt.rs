//! Clean stops on SIGINT and SIGTERM.
//!
//! A cluster's scheduler sends SIGTERM before it kills a job at its wall-time limit, and a user
//! at a terminal presses Ctrl-C. The first such signal only raises a flag: the driver finishes
//! the step (explicit) or load step (implicit) it is in, writes an output frame of that state in
//! every results file, closes the files and exits with [`EXIT_CODE`]. A second signal ends the
//! process at once with the shell's convention, 128 + the signal number (the results files then
//! hold every frame completed before it, as after SIGKILL).
//!
//! On N ranks each rank reads its own flag; the driver sums the flags in a collective it makes
//! anyway at every step, so every rank stops after the same step even when the signal reached
//! only some of them.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, OnceLock};

/// Exit code of a run stopped cleanly by SIGINT or SIGTERM (its files are complete up to the
/// step it stopped after).
pub const EXIT_CODE: u8 = 4;

/// The flags the signal handlers set: whether a stop was requested, and by which signal.
struct Flags {
    requested: Arc<AtomicBool>,
    signal: Arc<AtomicUsize>,
}

static FLAGS: OnceLock<Flags> = OnceLock::new();

/// Installs the handlers (once per process; later calls do nothing). Until it is called, a
/// signal has its default effect.
pub fn install() -> std::io::Result<()> {
    if FLAGS.get().is_some() {
        return Ok(());
    }
    let flags = Flags {
        requested: Arc::new(AtomicBool::new(false)),
        signal: Arc::new(AtomicUsize::new(0)),
    };
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        // The exit-if-already-set handler is registered first, so that the first signal only
        // sets the flag and the second finds it set.
        signal_hook::flag::register_conditional_shutdown(
            signal,
            128 + signal,
            Arc::clone(&flags.requested),
        )?;
        signal_hook::flag::register_usize(signal, Arc::clone(&flags.signal), signal as usize)?;
        signal_hook::flag::register(signal, Arc::clone(&flags.requested))?;
    }
    let _ = FLAGS.set(flags);
    Ok(())
}

/// The signal that asked this process to stop, if one did.
pub fn requested() -> Option<Signal> {
    let flags = FLAGS.get()?;
    if !flags.requested.load(Ordering::Relaxed) {
        return None;
    }
    Some(match flags.signal.load(Ordering::Relaxed) as i32 {
        signal_hook::consts::SIGINT => Signal::Interrupt,
        _ => Signal::Terminate,
    })
}

/// A signal that stops a run cleanly.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Signal {
    /// SIGINT (Ctrl-C).
    Interrupt,
    /// SIGTERM (a scheduler's stop, `kill`).
    Terminate,
}

impl std::fmt::Display for Signal {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Signal::Interrupt => "SIGINT",
            Signal::Terminate => "SIGTERM",
        })
    }
}
