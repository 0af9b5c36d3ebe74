//! Whether the bond loops run their AVX2 builds.
//!
//! The hot loops (PMB and LPS forces, the critical-stretch pass, the contact grid scan, the
//! cell-grid neighbour search) are compiled twice: for the x86-64 baseline (SSE2) and with AVX2
//! enabled, which gives the compiler 256-bit vectors (four `f64` square roots or divisions at
//! once); the AVX2 rows of PMB's closed blocks and of LPS are written with intrinsics
//! (`material::avx2`). Both builds do the same IEEE operations in the same order and fuse no
//! multiply-add (FMA is not enabled), so they give bitwise the same results; the AVX2 one is
//! only faster.

use std::sync::OnceLock;

/// True when the AVX2 builds may run: an x86-64 CPU that reports AVX2, unless
/// `PERIDYN_NO_WIDE_VECTORS` is set in the environment (for comparisons). Decided once per
/// process: reading the environment at every force evaluation cost time and could race with C
/// libraries (MPI, PETSc) that set variables from other threads.
pub(crate) fn wide_vectors_available() -> bool {
    static WIDE: OnceLock<bool> = OnceLock::new();
    *WIDE.get_or_init(|| {
        #[cfg(target_arch = "x86_64")]
        {
            std::is_x86_feature_detected!("avx2")
                && std::env::var_os("PERIDYN_NO_WIDE_VECTORS").is_none()
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            false
        }
    })
}
