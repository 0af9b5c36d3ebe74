//! The views of the reference and current configuration that materials and damage models
//! read.

use super::{BondList, PointCloud};
use crate::history::History;

/// The reference configuration of all points (owned and ghost), read by every material.
#[derive(Debug, Clone, Copy)]
pub struct ReferenceView<'a> {
    /// Families (symmetric, directed CSR).
    pub bonds: &'a BondList,
    /// Reference positions X (length).
    pub position: &'a [[f64; 3]],
    /// Cell volumes V (length³).
    pub volume: &'a [f64],
}

impl<'a> ReferenceView<'a> {
    /// The reference configuration of `points` with their families `bonds`.
    pub fn of(bonds: &'a BondList, points: &'a PointCloud) -> Self {
        Self {
            bonds,
            position: &points.position,
            volume: &points.volume,
        }
    }
}

/// The current configuration of all points, as materials and damage models read it.
#[derive(Debug, Clone, Copy)]
pub struct CurrentView<'a> {
    /// Current positions Y = X + u (length).
    pub position: &'a [[f64; 3]],
    /// Bond damage d ∈ [0, 1] per directed bond (same indexing as the bond list), or `None`
    /// when no damage model is active (all bonds intact).
    pub bond_damage: Option<&'a [f32]>,
    /// The materials' history fields (trial values of this evaluation, committed values of
    /// the step's start); [`crate::history::NO_HISTORY`] when no model declares any.
    pub history: &'a History,
}
