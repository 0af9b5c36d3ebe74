//! Known-answer tests of the native backend.

use super::*;

/// Builds a Csr from (row, column, value) triplets; duplicates are summed.
fn from_triplets(n: usize, mut triplets: Vec<(usize, usize, f64)>) -> Csr {
    triplets.sort_by_key(|&(r, c, _)| (r, c));
    let mut counts = vec![0; n];
    let mut columns = Vec::new();
    let mut values: Vec<f64> = Vec::new();
    let mut last = None;
    for (r, c, v) in triplets {
        if last == Some((r, c)) {
            *values.last_mut().unwrap() += v;
            continue;
        }
        last = Some((r, c));
        columns.push(c);
        values.push(v);
        counts[r] += 1;
    }
    let mut offsets = vec![0];
    for count in counts {
        offsets.push(offsets.last().unwrap() + count);
    }
    let csr = Csr {
        nrows: n,
        ncols: n,
        offsets,
        columns,
        values,
    };
    csr.assert_valid();
    csr
}

/// tridiag(lower, diagonal, upper) of size n.
fn tridiagonal(n: usize, lower: f64, diagonal: f64, upper: f64) -> Csr {
    let mut triplets = Vec::new();
    for i in 0..n {
        if i > 0 {
            triplets.push((i, i - 1, lower));
        }
        triplets.push((i, i, diagonal));
        if i + 1 < n {
            triplets.push((i, i + 1, upper));
        }
    }
    from_triplets(n, triplets)
}

fn to_dense(matrix: &Csr) -> Vec<Vec<f64>> {
    let mut dense = vec![vec![0.0; matrix.ncols]; matrix.nrows];
    for (r, row) in dense.iter_mut().enumerate() {
        let (columns, values) = matrix.row(r);
        for (&c, &v) in columns.iter().zip(values) {
            row[c] = v;
        }
    }
    dense
}

/// Gaussian elimination with partial pivoting: the independent reference.
fn dense_solve(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Vec<f64> {
    let n = b.len();
    for k in 0..n {
        let p = (k..n)
            .max_by(|&i, &j| a[i][k].abs().total_cmp(&a[j][k].abs()))
            .unwrap();
        a.swap(k, p);
        b.swap(k, p);
        for i in k + 1..n {
            let factor = a[i][k] / a[k][k];
            let pivot_row = a[k].clone();
            for (a_ij, a_kj) in a[i].iter_mut().zip(&pivot_row).skip(k) {
                *a_ij -= factor * a_kj;
            }
            b[i] -= factor * b[k];
        }
    }
    let mut x = vec![0.0; n];
    for i in (0..n).rev() {
        let sum: f64 = (i + 1..n).map(|j| a[i][j] * x[j]).sum();
        x[i] = (b[i] - sum) / a[i][i];
    }
    x
}

/// SplitMix64 in [0, 1): a seeded source so the "random" matrices are the same every run.
struct Random(u64);

impl Random {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Symmetric, about `density` of off-diagonal entries in [−1, 1], diagonal = 1 + Σ|off| so
/// it is strictly diagonally dominant with a positive diagonal, hence SPD (Gershgorin).
fn random_spd(n: usize, density: f64, seed: u64) -> Csr {
    let mut random = Random(seed);
    let mut triplets = Vec::new();
    let mut row_sums = vec![0.0; n];
    for i in 0..n {
        for j in i + 1..n {
            if random.next() < density {
                let v = 2.0 * random.next() - 1.0;
                triplets.push((i, j, v));
                triplets.push((j, i, v));
                row_sums[i] += v.abs();
                row_sums[j] += v.abs();
            }
        }
    }
    for (i, sum) in row_sums.iter().enumerate() {
        triplets.push((i, i, 1.0 + sum));
    }
    from_triplets(n, triplets)
}

fn max_relative_error(x: &[f64], reference: &[f64]) -> f64 {
    let scale = reference.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    x.iter()
        .zip(reference)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()))
        / scale
}

fn settings(tolerance: f64) -> KrylovSettings {
    KrylovSettings {
        relative_tolerance: tolerance,
        ..KrylovSettings::default()
    }
}

/// All four methods, the Krylov ones with the given preconditioner.
fn all_solvers(
    tolerance: f64,
    kind: PreconditionerKind,
    groups: Vec<usize>,
) -> Vec<NativeLinearSolver> {
    [
        NativeMethod::Cholesky,
        NativeMethod::Lu,
        NativeMethod::Cg,
        NativeMethod::Gmres,
    ]
    .into_iter()
    .map(|method| {
        NativeLinearSolver::new(
            &NativeSolverSettings {
                method,
                preconditioner: kind,
                krylov: settings(tolerance),
            },
            groups.clone(),
        )
    })
    .collect()
}

#[test]
fn all_methods_solve_the_1d_poisson_problem_exactly() {
    // tridiag(−1, 2, −1) of size n with b = 1 everywhere is the discrete Poisson problem
    // −u'' = 1 with u(0) = u(n + 1) = 0 on unit spacing; its solution is the parabola
    // u_i = i(n + 1 − i)/2 (i = 1..n), exact for the 3-point stencil because the second
    // difference of a quadratic has no truncation error.
    let n = 60;
    let a = tridiagonal(n, -1.0, 2.0, -1.0);
    let b = vec![1.0; n];
    let exact: Vec<f64> = (1..=n).map(|i| (i * (n + 1 - i)) as f64 / 2.0).collect();
    for kind in [
        PreconditionerKind::None,
        PreconditionerKind::Jacobi,
        PreconditionerKind::BlockJacobi,
    ] {
        for mut solver in all_solvers(1e-13, kind, (0..=n).collect()) {
            let mut x = vec![0.0; n];
            let report = solver.solve(&a, &b, &mut x).unwrap();
            let error = max_relative_error(&x, &exact);
            assert!(error < 1e-10, "{}: error {error:.2e}", report.method);
            assert!(report.relative_residual < 1e-12, "{report:?}");
        }
    }
}

#[test]
fn methods_agree_with_dense_elimination_on_a_random_spd_matrix() {
    let n = 40;
    let a = random_spd(n, 0.15, 7);
    let mut random = Random(11);
    let b: Vec<f64> = (0..n).map(|_| random.next() - 0.5).collect();
    let reference = dense_solve(to_dense(&a), b.clone());
    let groups = Preconditioner::block_jacobi_uniform(n, 3);
    let Preconditioner::BlockJacobi { groups } = groups else {
        unreachable!()
    };
    for kind in [
        PreconditionerKind::None,
        PreconditionerKind::Jacobi,
        PreconditionerKind::BlockJacobi,
    ] {
        for mut solver in all_solvers(1e-12, kind, groups.clone()) {
            let mut x = vec![0.0; n];
            let report = solver.solve(&a, &b, &mut x).unwrap();
            // Diagonal dominance bounds the condition number by (1 + 2 max Σ|off|)/1, small
            // here, so a 1e-12 residual means an error well under 1e-10.
            let error = max_relative_error(&x, &reference);
            assert!(error < 1e-10, "{}: error {error:.2e}", report.method);
        }
    }
}

/// A = P (L ⊗ B) P: L the m-point 1-D Laplacian, B = H diag(1, 10², 10⁴) H a strongly coupled
/// 3×3 block (H = I − ⅔·11ᵀ, a reflection), P scales point p by 10^(p mod 4).
fn badly_scaled_blocks(m: usize) -> Csr {
    let h = |i: usize, j: usize| f64::from(u8::from(i == j)) - 2.0 / 3.0;
    let eigenvalues = [1.0, 1e2, 1e4];
    let block = |i: usize, j: usize| {
        (0..3)
            .map(|k| h(i, k) * eigenvalues[k] * h(k, j))
            .sum::<f64>()
    };
    let scale = |p: usize| 10f64.powi((p % 4) as i32);
    let laplacian = tridiagonal(m, -1.0, 2.0, -1.0);
    let mut triplets = Vec::new();
    for p in 0..m {
        let (columns, values) = laplacian.row(p);
        for (&q, &l) in columns.iter().zip(values) {
            for i in 0..3 {
                for j in 0..3 {
                    triplets.push((3 * p + i, 3 * q + j, scale(p) * scale(q) * l * block(i, j)));
                }
            }
        }
    }
    from_triplets(3 * m, triplets)
}

#[test]
fn block_jacobi_cuts_cg_iterations_on_badly_scaled_coupled_blocks() {
    // Block Jacobi's M = P (2I ⊗ B) P, so M⁻¹A = P⁻¹((L/2) ⊗ I)P: its spectrum is that of L/2
    // (condition ≈ 4m²/π² ≈ 365 for m = 30) with only m distinct eigenvalues, so CG needs at
    // most m iterations in exact arithmetic. Without preconditioning the spectrum spans the
    // 10⁴ of B times the 10⁶ of P² times cond(L) with 3m distinct values; Jacobi removes P
    // but not B's coupling.
    let m = 30;
    let a = badly_scaled_blocks(m);
    let n = a.nrows;
    let mut random = Random(3);
    let b: Vec<f64> = (0..n).map(|_| random.next() - 0.5).collect();
    let iterations = |preconditioner: Preconditioner| {
        let mut cg = ConjugateGradient::new(
            KrylovSettings {
                relative_tolerance: 1e-8,
                max_iterations: Some(20 * n),
                restart: 500,
            },
            preconditioner,
        );
        let mut x = vec![0.0; n];
        match cg.solve(&a, &b, &mut x) {
            Ok(report) => report.iterations,
            Err(SolveError::NotConverged { iterations, .. }) => iterations,
            Err(other) => panic!("{other}"),
        }
    };
    let none = iterations(Preconditioner::None);
    let jacobi = iterations(Preconditioner::Jacobi);
    let block = iterations(Preconditioner::block_jacobi_uniform(n, 3));
    eprintln!("iterations: none {none}, Jacobi {jacobi}, block Jacobi {block}");
    assert!(block <= m + 2, "block Jacobi took {block} iterations");
    assert!(
        block < jacobi && block < none,
        "block {block}, Jacobi {jacobi}, none {none}"
    );
}

#[test]
fn cholesky_of_an_indefinite_matrix_is_a_breakdown() {
    // [[1, 2], [2, 1]] has eigenvalues 3 and −1.
    let a = from_triplets(2, vec![(0, 0, 1.0), (0, 1, 2.0), (1, 0, 2.0), (1, 1, 1.0)]);
    let mut x = vec![0.0; 2];
    let error = SparseCholesky::new()
        .solve(&a, &[1.0, 0.0], &mut x)
        .unwrap_err();
    assert!(
        matches!(&error, SolveError::Breakdown { reason, .. } if reason.contains("not positive definite")),
        "{error}"
    );
    // LU handles it: x = A⁻¹(1, 0) = (−1/3, 2/3) (inverse = [[1, −2], [−2, 1]]/(1 − 4)).
    SparseLu::new().solve(&a, &[1.0, 0.0], &mut x).unwrap();
    assert!(
        (x[0] + 1.0 / 3.0).abs() < 1e-15 && (x[1] - 2.0 / 3.0).abs() < 1e-15,
        "{x:?}"
    );
    // CG notices pᵀAp ≤ 0 with this right-hand side: p₀ = b = (1, 0), pᵀAp = 1 > 0, then
    // p₁ has pᵀAp < 0 (the A-norm is not a norm); GMRES solves it.
    let mut cg = ConjugateGradient::default();
    let mut x = vec![0.0; 2];
    let error = cg.solve(&a, &[1.0, 0.0], &mut x).unwrap_err();
    assert!(
        matches!(error, SolveError::Breakdown { method: "CG", .. }),
        "{error}"
    );
    let mut x = vec![0.0; 2];
    Gmres::default().solve(&a, &[1.0, 0.0], &mut x).unwrap();
    assert!(
        (x[0] + 1.0 / 3.0).abs() < 1e-12 && (x[1] - 2.0 / 3.0).abs() < 1e-12,
        "{x:?}"
    );
}

#[test]
fn cg_with_too_few_iterations_reports_not_converged_with_the_true_residual() {
    let n = 50;
    let a = tridiagonal(n, -1.0, 2.0, -1.0);
    let b = vec![1.0; n];
    let mut cg = ConjugateGradient::new(
        KrylovSettings {
            relative_tolerance: 1e-10,
            max_iterations: Some(3),
            restart: 500,
        },
        Preconditioner::None,
    );
    let mut x = vec![0.0; n];
    let error = cg.solve(&a, &b, &mut x).unwrap_err();
    let SolveError::NotConverged {
        method,
        iterations,
        relative_residual,
        tolerance,
    } = error
    else {
        panic!("{error}")
    };
    assert_eq!((method, iterations, tolerance), ("CG", 3, 1e-10));
    // x holds the last iterate; the reported figure is ‖b − A x‖/‖b‖ for it.
    let mut ax = vec![0.0; n];
    a.multiply(&x, &mut ax);
    let recomputed = ax
        .iter()
        .zip(&b)
        .map(|(p, q)| (q - p).powi(2))
        .sum::<f64>()
        .sqrt()
        / (n as f64).sqrt();
    assert!((relative_residual - recomputed).abs() <= 1e-14 * recomputed);
    assert!(relative_residual > 1e-2, "{relative_residual}");
}

#[test]
fn non_finite_inputs_are_errors_not_nan_answers() {
    let a = tridiagonal(5, -1.0, 2.0, -1.0);
    let mut b = vec![1.0; 5];
    b[2] = f64::NAN;
    for mut solver in all_solvers(1e-10, PreconditionerKind::Jacobi, vec![]) {
        let mut x = vec![0.0; 5];
        let error = solver.solve(&a, &b, &mut x).unwrap_err();
        assert_eq!(
            error,
            SolveError::NonFinite {
                what: "the right-hand side".to_string()
            }
        );
    }
    let mut bad = a.clone();
    bad.values[0] = f64::INFINITY;
    let mut x = vec![0.0; 5];
    let error = Gmres::default().solve(&bad, &[1.0; 5], &mut x).unwrap_err();
    assert!(matches!(error, SolveError::NonFinite { .. }), "{error}");
}

#[test]
fn zero_rhs_returns_zero_at_once() {
    let a = tridiagonal(4, -1.0, 2.0, -1.0);
    let mut cg = ConjugateGradient::default();
    let mut x = vec![5.0; 4];
    let report = cg.solve(&a, &[0.0; 4], &mut x).unwrap();
    assert_eq!(x, vec![0.0; 4]);
    assert_eq!((report.iterations, report.relative_residual), (0, 0.0));
}

#[test]
fn matrix_free_gmres_matches_csr_gmres_on_a_nonsymmetric_matrix() {
    // Upwinded convection–diffusion: tridiag(−1 − c, 2, −1 + c), c = 0.3, not symmetric.
    let n = 80;
    let c = 0.3;
    let a = tridiagonal(n, -1.0 - c, 2.0, -1.0 + c);
    let b: Vec<f64> = (0..n).map(|i| ((i + 1) as f64).sin()).collect();
    let krylov = KrylovSettings {
        relative_tolerance: 1e-12,
        // Restarted GMRES loses the finite-termination property and converges slowly on a
        // diffusion-dominated operator, hence more room than n.
        max_iterations: Some(50 * n),
        // Shorter than n, so restarts are exercised.
        restart: 20,
    };
    let mut assembled = Gmres::new(krylov, Preconditioner::Jacobi);
    let mut x_csr = vec![0.0; n];
    let report = assembled.solve(&a, &b, &mut x_csr).unwrap();
    assert_eq!(report.method, "GMRES + Jacobi");
    assert!(report.iterations > 20, "{report:?}");

    // The same operator as a stencil, never assembled.
    let mut apply = |v: &[f64], y: &mut [f64]| {
        for i in 0..n {
            let left = if i > 0 { (-1.0 - c) * v[i - 1] } else { 0.0 };
            let right = if i + 1 < n {
                (-1.0 + c) * v[i + 1]
            } else {
                0.0
            };
            y[i] = left + 2.0 * v[i] + right;
        }
        Ok(())
    };
    let jacobi = |r: &[f64], z: &mut [f64]| {
        for (z_i, r_i) in z.iter_mut().zip(r) {
            *z_i = r_i / 2.0;
        }
    };
    let mut x_free = vec![0.0; n];
    let free = gmres_matrix_free(&mut apply, &jacobi, &b, &mut x_free, &krylov).unwrap();
    assert_eq!(free.iterations, report.iterations);
    assert!(max_relative_error(&x_free, &x_csr) < 1e-12);
    let reference = dense_solve(to_dense(&a), b.clone());
    assert!(max_relative_error(&x_csr, &reference) < 1e-10);
}

#[test]
fn cholesky_reuses_its_analysis_while_the_pattern_holds() {
    let n = 30;
    let mut solver = SparseCholesky::new();
    let mut x = vec![0.0; n];
    let b = vec![1.0; n];
    for shift in [0.0, 1.0, 2.0] {
        // tridiag(−1, 2 + shift, −1): same pattern, new values, as Newton iterations give.
        let a = tridiagonal(n, -1.0, 2.0 + shift, -1.0);
        solver.solve(&a, &b, &mut x).unwrap();
        let reference = dense_solve(to_dense(&a), b.clone());
        assert!(max_relative_error(&x, &reference) < 1e-12);
    }
    assert_eq!(solver.symbolic_analyses(), 1);
    let a = random_spd(n, 0.2, 5);
    solver.solve(&a, &b, &mut x).unwrap();
    assert_eq!(solver.symbolic_analyses(), 2);
    let reference = dense_solve(to_dense(&a), b.clone());
    assert!(max_relative_error(&x, &reference) < 1e-12);
}

#[test]
fn a_singular_matrix_makes_lu_break_down() {
    // Rows 0 and 1 are equal: rank 1.
    let a = from_triplets(2, vec![(0, 0, 1.0), (0, 1, 1.0), (1, 0, 1.0), (1, 1, 1.0)]);
    let mut x = vec![0.0; 2];
    let error = SparseLu::new().solve(&a, &[1.0, 2.0], &mut x).unwrap_err();
    assert!(
        matches!(
            error,
            SolveError::Breakdown {
                method: "sparse LU",
                ..
            }
        ),
        "{error}"
    );
}

#[test]
fn deck_names_parse_to_methods() {
    assert_eq!("BlockCG".parse::<NativeMethod>().unwrap(), NativeMethod::Cg);
    assert_eq!(
        "Block GMRES".parse::<NativeMethod>().unwrap(),
        NativeMethod::Gmres
    );
    assert_eq!(
        "cholesky".parse::<NativeMethod>().unwrap(),
        NativeMethod::Cholesky
    );
    let error = "MUMPS".parse::<NativeMethod>().unwrap_err();
    assert_eq!(
        error.to_string(),
        "unknown linear solver \"MUMPS\"; expected one of: Cholesky, LU, CG, GMRES, BlockCG, BlockGMRES"
    );
}
