//! Derived outputs computed from the model and the state on request.

mod deformation_gradient;

pub use deformation_gradient::{deformation_gradient, shape_tensor_inverse};
