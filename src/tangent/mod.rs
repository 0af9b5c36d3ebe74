//! ∂f/∂u: the tangent stiffness in 3×3 blocks per point pair, its sparsity pattern and its
//! conversion to the scalar [`Csr`](crate::backend::Csr) the backends solve with (DESIGN §5).
