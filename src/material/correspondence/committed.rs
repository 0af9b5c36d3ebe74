//! The committed history of the correspondence fields, which both the Lagrangian and the
//! hypoelastic models read at the start of each point's step.

use super::kinematics::{from_row_major, identity, StepStart};
use super::{fields, StressState};
use crate::history::History;

/// What a history field holds for a point without a deformation gradient.
#[derive(Clone, Copy)]
pub(super) enum Held {
    /// Its committed value (kinematics and unrotated stress stay where they were).
    Committed,
    /// Zero (it carries no stress).
    Zero,
}

/// The committed history of the correspondence fields, looked up once per evaluation.
#[derive(Clone, Copy)]
pub(super) struct CommittedHistory<'a> {
    pub(super) deformation_gradient: &'a [f64],
    pub(super) left_stretch: &'a [f64],
    pub(super) rotation: &'a [f64],
    pub(super) unrotated_stress: &'a [f64],
    pub(super) equivalent_plastic_strain: &'a [f64],
    /// Δt of the step.
    pub(super) duration: f64,
    /// ΔT now and at the step's start, in a run with point temperatures.
    pub(super) temperature: Option<(&'a [f64], &'a [f64])>,
}

impl<'a> CommittedHistory<'a> {
    pub(super) fn of(history: &'a History) -> Self {
        let committed = |name: &str| {
            history
                .field(name)
                .expect("the run allocates every field a correspondence model declares")
                .committed()
        };
        Self {
            deformation_gradient: committed(fields::DEFORMATION_GRADIENT),
            left_stretch: committed(fields::LEFT_STRETCH),
            rotation: committed(fields::ROTATION),
            unrotated_stress: committed(fields::UNROTATED_STRESS),
            equivalent_plastic_strain: committed(fields::EQUIVALENT_PLASTIC_STRAIN),
            duration: history.step_duration(),
            temperature: history
                .thermal()
                .map(|t| (&t.change[..], t.evaluated.committed())),
        }
    }

    /// The committed start of the step of point `p` (global index).
    pub(super) fn start(&self, p: usize) -> StepStart {
        let read = |values: &[f64]| from_row_major(&values[9 * p..9 * p + 9]);
        StepStart {
            deformation_gradient: read(self.deformation_gradient) + identity::<f64>(),
            left_stretch: read(self.left_stretch) + identity::<f64>(),
            rotation: read(self.rotation) + identity::<f64>(),
            stress: StressState {
                unrotated: read(self.unrotated_stress),
                equivalent_plastic_strain: self.equivalent_plastic_strain[p],
            },
            duration: self.duration,
            temperature_increment: self
                .temperature
                .map_or(0.0, |(now, start)| now[p] - start[p]),
        }
    }
}
