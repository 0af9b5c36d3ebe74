//! How the ranks of a run agree on failures, so that no rank waits in a collective for a rank
//! that left. On one rank every rule here returns its argument.
//!
//! Problems every rank sees alike (a solver or feature that cannot run on N ranks, an
//! instability seen by the global monitor) are reported by rank 0 alone ([`collective`]). A
//! failure on some ranks only (an expression that fails at one point, an output file rank 0
//! cannot write) is folded into the next collective ([`agree`]): every rank stops at the same
//! step, the lowest failing rank reports its error and the others return
//! [`RunError::OtherRank`].

use super::RunError;
use crate::parallel::{first_failure, Communicator};

/// An error every rank has alike: rank 0 reports it, the others stay quiet.
pub(super) fn collective(comm: &dyn Communicator, error: RunError) -> RunError {
    if comm.rank() == 0 {
        error
    } else {
        RunError::OtherRank {
            rank: 0,
            code: error.exit_code(),
        }
    }
}

/// After a collective sum found a failure: the lowest failing rank keeps its error, the
/// others get [`RunError::OtherRank`] with that rank's exit code. Collective.
pub(super) fn agree_on_failure(comm: &dyn Communicator, local: Option<RunError>) -> RunError {
    let rank = comm.rank();
    let (first, code) = first_failure(comm, local.as_ref().map(RunError::exit_code));
    match local {
        Some(error) if first == rank => error,
        _ => RunError::OtherRank { rank: first, code },
    }
}

/// Continues when every rank succeeded; otherwise every rank returns an error. Collective.
pub(super) fn agree<T>(
    comm: &dyn Communicator,
    result: Result<T, RunError>,
) -> Result<T, RunError> {
    let mut failures = [f64::from(u8::from(result.is_err()))];
    comm.sum(&mut failures);
    if failures[0] == 0.0 {
        return result;
    }
    Err(agree_on_failure(comm, result.err()))
}
