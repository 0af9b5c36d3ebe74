//! Subcommands of the `peridyn` binary that are more than a call into the library.

pub mod bench;
pub mod dogbone;
pub mod modulus;
pub mod quadrature;
pub mod study;
