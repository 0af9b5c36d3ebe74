//! Native linear solvers on a tangent-like system: `cargo bench --bench linear_solvers`.
//!
//! A = L ⊗ S: L the 7-point Laplacian on an n³ grid with homogeneous Dirichlet walls
//! (diagonal 6, neighbours −1), S a fixed SPD 3×3 block that couples and scales each point's
//! three dofs as an elastic point stiffness does. n = 27 gives 59 049 dofs and 1.2 M non-zeros.
//! b pseudo-random in [−½, ½), zero initial guess, Krylov tolerance 1e-10 (the native default). Each method solves
//! twice: the first solve includes the direct methods' symbolic analysis, the second reuses it
//! as Newton does. Prints numbers only; no assertions.
//! Environment: `LINEAR_BENCH_N` grid edge (default 27), `LINEAR_BENCH_METHODS` comma-separated
//! name fragments to run only some methods (e.g. `cg,gmres`).

use std::time::Instant;

use peridyn::backend::native::{
    ConjugateGradient, Gmres, KrylovSettings, Preconditioner, SparseCholesky, SparseLu,
};
use peridyn::backend::{Csr, LinearSolver};

/// Point stiffness block: SPD (leading minors 4, 0.76, 6.768), condition number ≈ 50.
const BLOCK: [[f64; 3]; 3] = [[4.0, 1.8, 0.6], [1.8, 1.0, 0.3], [0.6, 0.3, 9.0]];

fn laplacian_times_block(n: usize) -> Csr {
    let points = n * n * n;
    let index = |i: usize, j: usize, k: usize| (k * n + j) * n + i;
    let mut offsets = Vec::with_capacity(3 * points + 1);
    let mut columns = Vec::with_capacity(3 * 7 * 3 * points);
    let mut values = Vec::with_capacity(3 * 7 * 3 * points);
    offsets.push(0);
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                // Neighbours in increasing point order so columns come out sorted.
                let mut stencil = Vec::with_capacity(7);
                if k > 0 {
                    stencil.push((index(i, j, k - 1), -1.0));
                }
                if j > 0 {
                    stencil.push((index(i, j - 1, k), -1.0));
                }
                if i > 0 {
                    stencil.push((index(i - 1, j, k), -1.0));
                }
                stencil.push((index(i, j, k), 6.0));
                if i + 1 < n {
                    stencil.push((index(i + 1, j, k), -1.0));
                }
                if j + 1 < n {
                    stencil.push((index(i, j + 1, k), -1.0));
                }
                if k + 1 < n {
                    stencil.push((index(i, j, k + 1), -1.0));
                }
                for row in BLOCK {
                    for &(q, l) in &stencil {
                        for (c, s) in row.iter().enumerate() {
                            columns.push(3 * q + c);
                            values.push(l * s);
                        }
                    }
                    offsets.push(columns.len());
                }
            }
        }
    }
    let matrix = Csr {
        nrows: 3 * points,
        ncols: 3 * points,
        offsets,
        columns,
        values,
    };
    matrix.assert_valid();
    matrix
}

fn run(name: &str, solver: &mut dyn LinearSolver, matrix: &Csr, rhs: &[f64]) {
    if let Ok(filter) = std::env::var("LINEAR_BENCH_METHODS") {
        if !filter
            .split(',')
            .any(|wanted| name.to_lowercase().contains(&wanted.trim().to_lowercase()))
        {
            return;
        }
    }
    for attempt in ["first", "second"] {
        let mut x = vec![0.0; rhs.len()];
        let start = Instant::now();
        let result = solver.solve(matrix, rhs, &mut x);
        let seconds = start.elapsed().as_secs_f64();
        match result {
            Ok(report) => println!(
                "{name:<26} {attempt:<6} {seconds:>8.3} s  {:>5} iterations  residual {:.2e}  ({})",
                report.iterations, report.relative_residual, report.method
            ),
            Err(error) => println!("{name:<26} {attempt:<6} {seconds:>8.3} s  failed: {error}"),
        }
    }
}

fn main() {
    let n: usize = std::env::var("LINEAR_BENCH_N")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(27);
    let matrix = laplacian_times_block(n);
    // Pseudo-random load (xorshift): a uniform b excites only the grid's symmetric modes and
    // flatters the Krylov iteration counts.
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let rhs: Vec<f64> = (0..matrix.nrows)
        .map(|_| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        })
        .collect();
    println!(
        "{}³ grid × 3 dofs: {} rows, {} non-zeros, {} rayon threads",
        n,
        matrix.nrows,
        matrix.nnz(),
        rayon::current_num_threads()
    );
    let settings = KrylovSettings::default();
    let blocks = Preconditioner::block_jacobi_uniform(matrix.nrows, 3);
    run("sparse Cholesky", &mut SparseCholesky::new(), &matrix, &rhs);
    run("sparse LU", &mut SparseLu::new(), &matrix, &rhs);
    run(
        "CG + Jacobi",
        &mut ConjugateGradient::new(settings, Preconditioner::Jacobi),
        &matrix,
        &rhs,
    );
    run(
        "CG + block Jacobi",
        &mut ConjugateGradient::new(settings, blocks.clone()),
        &matrix,
        &rhs,
    );
    run(
        "GMRES(500) + Jacobi",
        &mut Gmres::new(settings, Preconditioner::Jacobi),
        &matrix,
        &rhs,
    );
    run(
        "GMRES(500) + block Jacobi",
        &mut Gmres::new(settings, blocks),
        &matrix,
        &rhs,
    );
}
