//! Derived outputs computed from the model and the state on request.

mod classes;
mod deformation_gradient;

pub use classes::{prepare_compute_classes, PreparedComputeClass};
pub use deformation_gradient::{deformation_gradient, shape_tensor_inverse};
