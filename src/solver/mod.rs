//! How time advances. Every solver calls the one internal-force path in [`crate::physics`].
//!
//! A solver list runs through its [`Integrator`] ([`integrator`]): [`verlet::Verlet`],
//! [`load_stepped::QuasiStatic`] (`QuasiStatic`, `NOXQuasiStatic`),
//! [`implicit_dynamics::Newmark`] (`Implicit`), [`dynamic_relaxation::DynamicRelaxation`]
//! (`DynamicRelaxation`); the driver gives it a [`list_run::ListRun`].

pub mod collective;
pub mod dynamic_relaxation;
pub mod explicit;
pub mod implicit;
pub mod implicit_dynamics;
pub mod integrator;
pub mod jfnk;
pub mod linear;
pub mod list_run;
pub mod load_stepped;
pub mod measure;
pub mod monitor;
pub mod multigrid;
pub mod newmark;
pub mod newton;
#[cfg(feature = "trilinos")]
pub mod nox_newton;
pub mod problem;
pub mod progress;
pub mod quasistatic;
pub mod relaxation;
#[cfg(feature = "petsc")]
pub mod snes_newton;
pub mod stability;
pub mod verlet;

pub use explicit::{VelocityVerlet, VerletSettings};
pub use integrator::{Integrator, ListSettings, SolverList};
pub use monitor::{EnergyMonitor, Instability};

/// Most time steps a `Verlet` or `Implicit` solver list may take: 10¹² (at a microsecond a
/// step, eleven days). A larger count comes from a mistyped `Final Time` or `Fixed dt`, or from
/// a stable time step of zero, and would only fill the disk with frames at one instant.
pub const MAX_STEPS: u64 = 1_000_000_000_000;

/// Steps of `time_step` in `span` as Peridigm counts them, `floor(span/Δt)`; `None` when the
/// count is not a finite number within [`MAX_STEPS`] (a zero, infinite or NaN Δt included).
pub fn step_count(span: f64, time_step: f64) -> Option<u64> {
    let steps = (span / time_step).floor().max(0.0);
    (steps.is_finite() && time_step > 0.0 && steps <= MAX_STEPS as f64).then_some(steps as u64)
}
