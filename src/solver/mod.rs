//! How time advances. Every solver calls the one internal-force path in [`crate::physics`].

pub mod collective;
pub mod explicit;
pub mod implicit;
pub mod jfnk;
pub mod linear;
pub mod measure;
pub mod monitor;
pub mod multigrid;
pub mod newmark;
pub mod newton;
#[cfg(feature = "trilinos")]
pub mod nox_newton;
pub mod problem;
pub mod quasistatic;

pub use explicit::{VelocityVerlet, VerletSettings};
pub use monitor::{EnergyMonitor, Instability};
