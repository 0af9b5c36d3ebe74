//! The kinematics of the correspondence models, per point, generic over the scalar type (`f64`
//! for the force, [`num_dual::Dual64`] for the automatic-differentiation tangent):
//!
//! * shape tensor `K = Σ_j ω (1−d) V_j ξ⊗ξ` and deformation gradient
//!   `F = (Σ_j ω (1−d) V_j (Y_j − Y_i)⊗ξ) K⁻¹` (Silling et al. 2007, eq. 136; Peridigm's
//!   `computeShapeTensorInverseAndApproximateDeformationGradient`);
//! * one step of Flanagan & Taylor (1987) from the deformation gradient at the start of the step
//!   `F_n` to the one at its end `F`: the velocity gradient times the step evaluated at the
//!   midpoint configuration, `L Δt = (F − F_n) F_{n+½}⁻¹` with `F_{n+½} = (F + F_n)/2` (what
//!   Peridigm's `Ḟ F⁻¹` becomes when the velocity is the step's displacement over Δt, as in its
//!   quasi-static solver and in velocity Verlet, but at the midpoint), its rate of deformation
//!   `D Δt` and spin `W Δt`, the rotation increment `Ω Δt = w + (tr V·I − V)⁻¹ z` (their
//!   eqs. 10–13), the rotation `R = (I − ½ΩΔt)⁻¹ (I + ½ΩΔt) R_n` and the left stretch
//!   `V = V_n + (L V_n − V_n Ω) Δt`, and the unrotated strain increment `d Δt = Rᵀ (D Δt) R`.
//!
//! Where this differs from Peridigm, and why: Peridigm takes L at the end of the step
//! (`Ḟ F⁻¹`) and rotates by `I + sin θ/θ Ω − (1 − cos θ)/θ² Ω²`. Both are first-order
//! approximations whose error grows with the rotation of a step: a rigid rotation of a step
//! gives a spurious D and a rotation that is not orthogonal to second order. With L at the
//! midpoint, a rigid rotation Q of the step gives `L Δt = 2(Q − I)(Q + I)⁻¹`, which is exactly
//! skew (D = 0), and the Cayley update above then reproduces Q exactly, however large: the
//! model is objective to round-off for any load step (tested with 90° in one step). For the
//! small increments of Peridigm's decks the two agree to second order.
//!
//! Matrices are nalgebra's `Matrix3<T>`; determinants and inverses are written out so that
//! they need only the field operations of `T` (no square roots or trigonometry, so the
//! automatic-differentiation tangent is smooth everywhere, rigid states included).

use nalgebra::Matrix3;

use crate::tangent::Scalar;

/// A 3×3 tensor over `T`.
pub(crate) type Tensor<T> = Matrix3<T>;

/// `m` as a tensor over `T` (constants of the dual-number evaluation).
pub(crate) fn lift<T: Scalar>(m: &Tensor<f64>) -> Tensor<T> {
    m.map(T::from)
}

/// The identity over `T`.
pub(crate) fn identity<T: Scalar>() -> Tensor<T> {
    Tensor::from_fn(|r, c| T::from(if r == c { 1.0 } else { 0.0 }))
}

/// The zero tensor over `T`.
pub(crate) fn zero<T: Scalar>() -> Tensor<T> {
    Tensor::from_fn(|_, _| T::from(0.0))
}

/// `c · m` for a plain number `c`.
pub(crate) fn scaled<T: Scalar>(m: &Tensor<T>, c: f64) -> Tensor<T> {
    m.map(|x| x * c)
}

/// det m.
pub(crate) fn determinant<T: Scalar>(m: &Tensor<T>) -> T {
    m[(0, 0)] * (m[(1, 1)] * m[(2, 2)] - m[(1, 2)] * m[(2, 1)])
        - m[(0, 1)] * (m[(1, 0)] * m[(2, 2)] - m[(1, 2)] * m[(2, 0)])
        + m[(0, 2)] * (m[(1, 0)] * m[(2, 1)] - m[(1, 1)] * m[(2, 0)])
}

/// m⁻¹ by cofactors, or `None` when det m is zero or not finite.
pub(crate) fn inverse<T: Scalar>(m: &Tensor<T>) -> Option<Tensor<T>> {
    let det = determinant(m);
    if det.re() == 0.0 || !det.re().is_finite() {
        return None;
    }
    let c = |r0: usize, c0: usize, r1: usize, c1: usize| {
        m[(r0, c0)] * m[(r1, c1)] - m[(r0, c1)] * m[(r1, c0)]
    };
    let adjugate = Tensor::new(
        c(1, 1, 2, 2),
        c(0, 2, 2, 1),
        c(0, 1, 1, 2),
        c(1, 2, 2, 0),
        c(0, 0, 2, 2),
        c(0, 2, 1, 0),
        c(1, 0, 2, 1),
        c(0, 1, 2, 0),
        c(0, 0, 1, 1),
    );
    let inverse_det = T::from(1.0) / det;
    Some(adjugate.map(|x| x * inverse_det))
}

/// tr m.
pub(crate) fn trace<T: Scalar>(m: &Tensor<T>) -> T {
    m[(0, 0)] + m[(1, 1)] + m[(2, 2)]
}

/// The deviatoric part m − (tr m/3) I.
pub(crate) fn deviator<T: Scalar>(m: &Tensor<T>) -> Tensor<T> {
    let mean = trace(m) * (1.0 / 3.0);
    let mut d = *m;
    for k in 0..3 {
        d[(k, k)] -= mean;
    }
    d
}

/// The state of a point's rotation and stretch at the end of a step, and the strain increment
/// of the step in the unrotated frame.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Step<T: Scalar> {
    /// Left stretch V (V R = F in the polar decomposition, integrated in rate form).
    pub left_stretch: Tensor<T>,
    /// Rotation R.
    pub rotation: Tensor<T>,
    /// Unrotated strain increment d Δt = Rᵀ (D Δt) R (dimensionless).
    pub unrotated_strain_increment: Tensor<T>,
}

/// One Flanagan–Taylor step (see the module docs) from `start` to the deformation gradient
/// `f`. `None` when the midpoint configuration or tr V·I − V is singular (a deformation no
/// solid reaches).
pub(crate) fn flanagan_taylor<T: Scalar>(f: &Tensor<T>, start: &StepStart) -> Option<Step<T>> {
    let f_start = lift::<T>(&start.deformation_gradient);
    let midpoint_inverse = inverse(&scaled(&(f + f_start), 0.5))?;
    rotate_and_stretch(&((f - f_start) * midpoint_inverse), start)
}

/// The Flanagan–Taylor step from `start` given the velocity gradient times the step,
/// `L Δt` (dimensionless), however it was measured: [`flanagan_taylor`] from two deformation
/// gradients, the hypoelastic models from the displacement increments of the current family.
/// `None` when tr V·I − V or I − ½ΩΔt is singular.
pub(crate) fn rotate_and_stretch<T: Scalar>(
    velocity_gradient: &Tensor<T>,
    start: &StepStart,
) -> Option<Step<T>> {
    let velocity_gradient = *velocity_gradient;
    let transposed = velocity_gradient.transpose();
    let rate = scaled(&(velocity_gradient + transposed), 0.5);
    let spin = scaled(&(velocity_gradient - transposed), 0.5);
    let stretch = lift::<T>(&start.left_stretch);
    // z_i = ε_ikj D_jm V_mk (T&F eq. 13); w_i = −½ ε_ijk W_jk (eq. 11).
    let dv = rate * stretch;
    let z = [
        dv[(2, 1)] - dv[(1, 2)],
        dv[(0, 2)] - dv[(2, 0)],
        dv[(1, 0)] - dv[(0, 1)],
    ];
    let w = [
        (spin[(2, 1)] - spin[(1, 2)]) * 0.5,
        (spin[(0, 2)] - spin[(2, 0)]) * 0.5,
        (spin[(1, 0)] - spin[(0, 1)]) * 0.5,
    ];
    let mut shifted = -stretch;
    let tr = trace(&stretch);
    for k in 0..3 {
        shifted[(k, k)] += tr;
    }
    let shifted_inverse = inverse(&shifted)?;
    let omega: [T; 3] = std::array::from_fn(|i| {
        w[i] + shifted_inverse[(i, 0)] * z[0]
            + shifted_inverse[(i, 1)] * z[1]
            + shifted_inverse[(i, 2)] * z[2]
    });
    // Ω_ij = ε_ikj ω_k (T&F eq. 10).
    let zero = T::from(0.0);
    let omega_tensor = Tensor::new(
        zero, -omega[2], omega[1], omega[2], zero, -omega[0], -omega[1], omega[0], zero,
    );
    let half = scaled(&omega_tensor, 0.5);
    let increment = inverse(&(identity::<T>() - half))? * (identity::<T>() + half);
    let rotation = increment * lift::<T>(&start.rotation);
    let left_stretch = stretch + velocity_gradient * stretch - stretch * omega_tensor;
    let unrotated_strain_increment = rotation.transpose() * rate * rotation;
    Some(Step {
        left_stretch,
        rotation,
        unrotated_strain_increment,
    })
}

/// The committed kinematic state of a point at the start of a step.
#[derive(Debug, Clone, Copy)]
pub(crate) struct StepStart {
    /// F_n.
    pub deformation_gradient: Tensor<f64>,
    /// V_n.
    pub left_stretch: Tensor<f64>,
    /// R_n.
    pub rotation: Tensor<f64>,
    /// σ̃_n and ε̄_p at the start of the step.
    pub stress: super::StressState<f64>,
    /// Δt of the step (s).
    pub duration: f64,
    /// The change of the point's temperature over the step, ΔT_{n+1} − ΔT_n (0 in a run
    /// without point temperatures).
    pub temperature_increment: f64,
}

/// A row-major 3×3 array as a tensor.
pub(crate) fn from_row_major(values: &[f64]) -> Tensor<f64> {
    Tensor::from_row_slice(&values[..9])
}

/// A tensor as a row-major 3×3 array.
pub(crate) fn to_row_major(m: &Tensor<f64>) -> [f64; 9] {
    std::array::from_fn(|k| m[(k / 3, k % 3)])
}
