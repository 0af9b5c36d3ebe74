//! The assembled tangent in 3×3 blocks (its conversion to the scalar CSR matrix the backends
//! solve with, `BlockTangent::to_csr`, lives with that matrix in `backend/csr.rs`).

use std::sync::Arc;

use rayon::prelude::*;

use super::{Block, BlockPattern};

/// J_ij = ∂(V_i f_i)/∂u_j: the Jacobian of the residual r_i = V_i (f_i + b_i) with respect to
/// the displacement (force/length), one 3×3 block per pattern entry. For an elastic body it is
/// symmetric and negative semi-definite; the stiffness the linear solvers see is K = −J.
///
/// `blocks[pattern.offsets()[i] + p]` is block (i, `pattern.row(i)[p]`), and within a block
/// `block[k][l] = ∂(V_i f_i)_k / ∂(u_j)_l`.
#[derive(Debug, Clone)]
pub struct BlockTangent {
    /// The sparsity pattern (shared: one pattern serves every assembly of a run).
    pub pattern: Arc<BlockPattern>,
    /// One block per pattern entry, in pattern order.
    pub blocks: Vec<Block>,
}

impl BlockTangent {
    /// All blocks zero.
    pub fn zeros(pattern: Arc<BlockPattern>) -> Self {
        let blocks = vec![[[0.0; 3]; 3]; pattern.num_blocks()];
        Self { pattern, blocks }
    }

    /// Block (i, j), or `None` when the pattern does not store it.
    pub fn block(&self, i: usize, j: usize) -> Option<&Block> {
        self.pattern.position(i, j).map(|p| &self.blocks[p])
    }

    /// Sets every block to zero (keeps the pattern and the allocation).
    pub fn fill_zero(&mut self) {
        self.blocks.par_iter_mut().for_each(|b| *b = [[0.0; 3]; 3]);
    }

    /// Bytes held by the blocks and the pattern.
    pub fn memory_bytes(&self) -> usize {
        self.blocks.len() * std::mem::size_of::<Block>() + self.pattern.memory_bytes()
    }
}
