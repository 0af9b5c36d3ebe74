//! How time advances. Every solver calls the one internal-force path in [`crate::physics`].

pub mod explicit;
pub mod monitor;

pub use explicit::{VelocityVerlet, VerletSettings};
pub use monitor::{EnergyMonitor, Instability};
