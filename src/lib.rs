//! # peridyn
//!
//! Peridynamics in Rust, compatible with Peridigm's input decks.
#![warn(missing_docs)]

pub mod bench;
pub mod boundary;
pub mod damage;
pub mod discretization;
pub mod expression;
pub mod io;
pub mod material;
pub mod model;
pub mod neighbors;
pub mod physics;
pub mod plan;
pub mod setup;
pub mod simulation;
pub mod solver;
pub mod state;
