//! The force state of a Lagrangian correspondence point for the tangent assembly.

use super::committed::CommittedHistory;
use super::kinematics::Tensor;
use super::{Bond, Correspondence, Family, PointTensors, StressModel};
use crate::tangent::{ForceState, OrdinaryBond, PointIndex, Scalar};

/// The force state of a correspondence point for the tangent assembly: the same update as the
/// force, from the committed history, generic over the scalar.
pub(super) struct CorrespondenceForceState<'a, S: StressModel> {
    pub(super) material: &'a Correspondence<S>,
    pub(super) family: Family<'a>,
    pub(super) committed: CommittedHistory<'a>,
    /// K⁻¹ of each block point (block order; `None` when singular), computed once per
    /// assembly instead of once per perturbed evaluation.
    pub(super) shape_inverses: Vec<Option<Tensor<f64>>>,
}

impl<S: StressModel> ForceState for CorrespondenceForceState<'_, S> {
    const BOND_LOCAL: bool = false;
    const ANALYTIC: bool = false;

    fn force_state<T: Scalar>(
        &self,
        point: PointIndex,
        y: &[[T; 3]],
        _only: Option<usize>,
        t: &mut [[T; 3]],
    ) {
        let zero = T::from(0.0);
        let start = self.committed.start(point.global);
        let update = self.shape_inverses[point.local].and_then(|shape_inverse| {
            self.material
                .point_update(&self.family, point, y, (&start, &shape_inverse))
        });
        let Some(update) = update else {
            t.fill([zero; 3]);
            return;
        };
        let tensors = PointTensors {
            stress_shape: update.stress_shape,
            deformation_gradient: update.deformation_gradient,
        };
        let row_start = self.family.local_offsets[point.local];
        for (n, b) in self.family.bonds.range(point.global).enumerate() {
            let intact = self.family.intact(b);
            let bond = Bond {
                xi: self.family.xi(point.global, b),
                dy: std::array::from_fn(|r| y[n + 1][r] - y[0][r]),
                zeta: self.family.bonds.reference_length[b],
                weight: self.family.weights[row_start + n] * intact,
                intact,
            };
            t[n] = self.material.bond_force_state(&tensors, &bond);
        }
    }

    fn ordinary_derivatives(&self, _point: PointIndex, _y: &[[f64; 3]], _out: &mut [OrdinaryBond]) {
        unreachable!("a correspondence force state is not ordinary (ANALYTIC is false)")
    }
}
