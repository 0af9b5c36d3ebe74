//! The deck's compute classes resolved against the model: which points each one reduces over.
//! `peridyn check` and `peridyn run` resolve them alike (a missing block or node set is the
//! same error in both), and the running simulation evaluates them.

use crate::io::deck::{CalculationType, ComputeClass, ComputeClassKind};
use crate::model::Model;

/// A compute class prepared for evaluation: which points it reduces over.
#[derive(Debug, Clone)]
pub struct PreparedComputeClass {
    /// `Output Label`.
    pub label: String,
    /// `Variable`.
    pub variable: String,
    /// Points (run order) reduced over; one point for `Nearest_Point_Data`.
    pub points: Vec<u32>,
    /// Min/max/sum; `None` for `Nearest_Point_Data` (the value at the point).
    pub calculation: Option<CalculationType>,
}

/// Resolves the deck's compute classes against the model (`None` entries are classes with no
/// global output, e.g. `Bond_Visualization`). Errors name the missing block or node set.
pub fn prepare_compute_classes(
    classes: &[ComputeClass],
    model: &Model,
) -> Result<Vec<PreparedComputeClass>, String> {
    let mut prepared = Vec::new();
    for class in classes {
        match &class.kind {
            ComputeClassKind::BlockData {
                block,
                variable,
                calculation_type,
                output_label,
            } => {
                let found = model
                    .blocks
                    .iter()
                    .find(|b| b.info.name == *block)
                    .ok_or_else(|| {
                        format!(
                            "compute class \"{}\": no block \"{block}\" in the mesh",
                            class.name
                        )
                    })?;
                prepared.push(PreparedComputeClass {
                    label: output_label.clone(),
                    variable: variable.clone(),
                    points: found.points.clone(),
                    calculation: Some(*calculation_type),
                });
            }
            ComputeClassKind::NodeSetData {
                node_set,
                variable,
                calculation_type,
                output_label,
            } => {
                let points = model.node_sets.get(node_set).ok_or_else(|| {
                    format!(
                        "compute class \"{}\": no node set \"{node_set}\"",
                        class.name
                    )
                })?;
                prepared.push(PreparedComputeClass {
                    label: output_label.clone(),
                    variable: variable.clone(),
                    points: points.to_vec(),
                    calculation: Some(*calculation_type),
                });
            }
            ComputeClassKind::NearestPointData {
                position,
                variable,
                output_label,
                ..
            } => {
                // Nearest in the reference configuration; ties go to the smallest original id.
                let mut best: Option<(f64, u32, u32)> = None;
                for (i, x) in model.points.position.iter().enumerate() {
                    let d2: f64 = (0..3).map(|k| (x[k] - position[k]).powi(2)).sum();
                    let id = model.points.original_id[i];
                    let better = match best {
                        None => true,
                        Some((bd, bid, _)) => d2 < bd || (d2 == bd && id < bid),
                    };
                    if better {
                        best = Some((d2, id, i as u32));
                    }
                }
                prepared.push(PreparedComputeClass {
                    label: output_label.clone(),
                    variable: variable.clone(),
                    points: best.map(|b| vec![b.2]).unwrap_or_default(),
                    calculation: None,
                });
            }
            ComputeClassKind::BondVisualization { .. } => {}
        }
    }
    Ok(prepared)
}
