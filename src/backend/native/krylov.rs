//! Krylov methods: preconditioned conjugate gradients and restarted GMRES, each written once
//! over an operator callback (`apply`: y = A v) so the same code serves an assembled [`Csr`]
//! tangent and JFNK's matrix-free directional derivative.
//!
//! Convergence test (both methods): the unpreconditioned relative residual
//! ‖b − A x‖₂ / ‖b‖₂ ≤ `relative_tolerance`, confirmed with a freshly computed residual before
//! success is reported, so the figure in the report is the true one and does not depend on the
//! preconditioner's scaling. A zero right-hand side returns x = 0 at once.

use super::super::{Csr, KrylovReport, LinearResult, SolveError};
use super::preconditioner::{Preconditioner, PreconditionerOperator};
use super::{check_finite, check_matrix};

/// Stopping and memory settings shared by CG and GMRES.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KrylovSettings {
    /// Stop when ‖b − A x‖/‖b‖ ≤ this. Default 1e-10: Peridigm's `Implicit` solver uses Belos
    /// at 1e-10, and it keeps an iterative answer as close to a direct one as Newton's own
    /// 1e-6-ish tolerances need. Peridigm's `QuasiStatic` default (`Belos Relative Tolerance`)
    /// is 1e-4; the driver passes the deck's value. JFNK callers should pass their forcing
    /// term: a finite-difference operator is accurate to about √ε ≈ 1e-8 only.
    pub relative_tolerance: f64,
    /// Iteration limit (GMRES: inner iterations summed over restarts). `None` = the number of
    /// rows, Peridigm's `Belos Maximum Iterations` default.
    pub max_iterations: Option<usize>,
    /// GMRES restart length (Krylov vectors kept), default 500 as Peridigm's BlockGMRES. The
    /// basis grows only as far as iterations go, so memory is at most
    /// (restart + 1) × rows × 8 bytes.
    pub restart: usize,
}

impl Default for KrylovSettings {
    fn default() -> Self {
        Self {
            relative_tolerance: 1e-10,
            max_iterations: None,
            restart: 500,
        }
    }
}

impl KrylovSettings {
    fn iteration_limit(&self, rows: usize) -> usize {
        self.max_iterations.unwrap_or(rows.max(1))
    }
}

/// y = A v, the operator callback of the matrix-free methods (an assembled product, or JFNK's
/// finite-difference directional derivative of the residual, which may fail).
pub type Operator<'a> = dyn FnMut(&[f64], &mut [f64]) -> Result<(), SolveError> + 'a;

/// z = M⁻¹ r, the preconditioner callback of the matrix-free methods; must be a fixed linear
/// map during one solve (and symmetric positive definite for CG).
pub type PreconditionerApply<'a> = dyn Fn(&[f64], &mut [f64]) + 'a;

/// The common signature of [`cg_matrix_free`] and [`gmres_matrix_free`].
type KrylovMethod = fn(
    &mut Operator<'_>,
    &PreconditionerApply<'_>,
    &[f64],
    &mut [f64],
    &KrylovSettings,
) -> LinearResult;

/// aᵀb with eight independent partial sums: a single running sum is limited by the latency
/// of one floating-point add per element, eight let the adds pipeline and vectorise. The
/// order is fixed, so results are reproducible.
fn dot(a: &[f64], b: &[f64]) -> f64 {
    const LANES: usize = 8;
    let mut partial = [0.0; LANES];
    let (a_chunks, b_chunks) = (a.chunks_exact(LANES), b.chunks_exact(LANES));
    let tail: f64 = a_chunks
        .remainder()
        .iter()
        .zip(b_chunks.remainder())
        .map(|(x, y)| x * y)
        .sum();
    for (x, y) in a_chunks.zip(b_chunks) {
        for lane in 0..LANES {
            partial[lane] += x[lane] * y[lane];
        }
    }
    partial.iter().sum::<f64>() + tail
}

fn norm(a: &[f64]) -> f64 {
    dot(a, a).sqrt()
}

/// y += alpha x.
fn axpy(alpha: f64, x: &[f64], y: &mut [f64]) {
    for (y_i, x_i) in y.iter_mut().zip(x) {
        *y_i += alpha * x_i;
    }
}

/// r = b − A x (r = b without calling the operator when x = 0, which spares JFNK one
/// residual evaluation for the usual zero initial guess).
fn residual(
    apply: &mut Operator<'_>,
    rhs: &[f64],
    x: &[f64],
    r: &mut [f64],
) -> Result<(), SolveError> {
    if x.iter().all(|&v| v == 0.0) {
        r.copy_from_slice(rhs);
        return Ok(());
    }
    apply(x, r)?;
    for (r_i, b_i) in r.iter_mut().zip(rhs) {
        *r_i = b_i - *r_i;
    }
    Ok(())
}

/// Checks lengths and finiteness of the inputs; returns ‖b‖, or `None` after setting x = 0
/// when b = 0.
fn start(method: &'static str, rhs: &[f64], x: &mut [f64]) -> Result<Option<f64>, SolveError> {
    assert_eq!(
        rhs.len(),
        x.len(),
        "{method}: right-hand side and solution have different lengths"
    );
    check_finite(rhs, "the right-hand side")?;
    check_finite(x, "the initial guess")?;
    let rhs_norm = norm(rhs);
    if rhs_norm == 0.0 {
        x.fill(0.0);
        return Ok(None);
    }
    Ok(Some(rhs_norm))
}

fn converged_zero_rhs(method: &str) -> KrylovReport {
    KrylovReport {
        method: method.to_string(),
        iterations: 0,
        relative_residual: 0.0,
    }
}

/// Preconditioned conjugate gradients for a symmetric positive definite operator (and an SPD
/// preconditioner) given as callbacks: `apply` computes y = A v, `preconditioner` z = M⁻¹ r.
/// `x` holds the initial guess on entry and the last iterate on return, also when an error
/// is returned.
///
/// Errors: `NonFinite` (right-hand side, initial guess, or an operator/preconditioner output),
/// `Breakdown` when pᵀAp ≤ 0 (A not positive definite) or rᵀM⁻¹r < 0 (M not positive
/// definite), `NotConverged` after the iteration limit with the true residual.
pub fn cg_matrix_free(
    apply: &mut Operator<'_>,
    preconditioner: &PreconditionerApply<'_>,
    rhs: &[f64],
    x: &mut [f64],
    settings: &KrylovSettings,
) -> LinearResult {
    const METHOD: &str = "CG";
    let Some(rhs_norm) = start(METHOD, rhs, x)? else {
        return Ok(converged_zero_rhs(METHOD));
    };
    let n = rhs.len();
    let tolerance = settings.relative_tolerance * rhs_norm;
    let limit = settings.iteration_limit(n);
    let mut r = vec![0.0; n];
    let mut z = vec![0.0; n];
    let mut p = vec![0.0; n];
    let mut q = vec![0.0; n];
    residual(apply, rhs, x, &mut r)?;
    check_finite(&r, "the initial residual")?;
    let mut iterations = 0;
    // Whether r was computed as b − A x (not by recurrence) since the last update of x.
    let mut residual_is_true = true;
    let mut restart = true;
    let mut rz = 0.0;
    loop {
        let r_norm = norm(&r);
        if r_norm <= tolerance {
            if residual_is_true {
                return Ok(KrylovReport {
                    method: METHOD.to_string(),
                    iterations,
                    relative_residual: r_norm / rhs_norm,
                });
            }
            // The recurrence drifts from b − A x in floating point; confirm and, if the true
            // residual is still too large, restart the recurrence from it.
            residual(apply, rhs, x, &mut r)?;
            residual_is_true = true;
            restart = true;
            continue;
        }
        if iterations >= limit {
            if !residual_is_true {
                residual(apply, rhs, x, &mut r)?;
            }
            return Err(SolveError::NotConverged {
                method: METHOD,
                iterations,
                relative_residual: norm(&r) / rhs_norm,
                tolerance: settings.relative_tolerance,
            });
        }
        preconditioner(&r, &mut z);
        let rz_new = dot(&r, &z);
        if !rz_new.is_finite() {
            return Err(SolveError::NonFinite {
                what: "the preconditioned residual".to_string(),
            });
        }
        if rz_new <= 0.0 {
            return Err(SolveError::Breakdown {
                method: METHOD,
                reason: format!(
                    "the preconditioner is not positive definite (rᵀM⁻¹r = {rz_new:.3e} at \
                     iteration {iterations}); use GMRES or another preconditioner"
                ),
            });
        }
        if restart {
            p.copy_from_slice(&z);
            restart = false;
        } else {
            let beta = rz_new / rz;
            for (p_i, z_i) in p.iter_mut().zip(&z) {
                *p_i = z_i + beta * *p_i;
            }
        }
        rz = rz_new;
        apply(&p, &mut q)?;
        let pq = dot(&p, &q);
        if !pq.is_finite() {
            return Err(SolveError::NonFinite {
                what: "the matrix-vector product".to_string(),
            });
        }
        if pq <= 0.0 {
            return Err(SolveError::Breakdown {
                method: METHOD,
                reason: format!(
                    "the matrix is not positive definite (pᵀAp = {pq:.3e} at iteration \
                     {iterations}); use GMRES or LU for an indefinite tangent"
                ),
            });
        }
        let alpha = rz / pq;
        axpy(alpha, &p, x);
        axpy(-alpha, &q, &mut r);
        residual_is_true = false;
        iterations += 1;
    }
}

/// Restarted GMRES(m) with right preconditioning, A M⁻¹ y = b, x = M⁻¹ y, so the residual it
/// minimises is the unpreconditioned ‖b − A x‖ the convergence test uses. Arnoldi uses
/// modified Gram–Schmidt without reorthogonalisation: MGS-GMRES is backward stable (Paige,
/// Rozložník & Strakoš, SIAM J. Matrix Anal. Appl. 28, 2006), and a second pass doubled the
/// time of the 59k-row benchmark without changing its iterations. The small least-squares
/// problem is kept triangular with Givens rotations. `apply` computes y = A v, `preconditioner` z = M⁻¹ r (fixed between calls).
/// `x` holds the initial guess on entry and the last iterate on return.
///
/// Errors: `NonFinite` (inputs or an operator/preconditioner output), `Breakdown` when the
/// preconditioned operator is singular on the Krylov space, `NotConverged` after the iteration
/// limit (inner iterations summed over restarts) with the true residual.
pub fn gmres_matrix_free(
    apply: &mut Operator<'_>,
    preconditioner: &PreconditionerApply<'_>,
    rhs: &[f64],
    x: &mut [f64],
    settings: &KrylovSettings,
) -> LinearResult {
    const METHOD: &str = "GMRES";
    let Some(rhs_norm) = start(METHOD, rhs, x)? else {
        return Ok(converged_zero_rhs(METHOD));
    };
    let n = rhs.len();
    let tolerance = settings.relative_tolerance * rhs_norm;
    let limit = settings.iteration_limit(n);
    let restart = settings.restart.max(1);
    let mut r = vec![0.0; n];
    let mut z = vec![0.0; n];
    let mut w = vec![0.0; n];
    residual(apply, rhs, x, &mut r)?;
    let mut beta = norm(&r);
    if !beta.is_finite() {
        return Err(SolveError::NonFinite {
            what: "the initial residual".to_string(),
        });
    }
    let mut iterations = 0;
    // Basis vectors are allocated as the cycle reaches them and reused across restarts.
    let mut basis: Vec<Vec<f64>> = Vec::new();
    loop {
        if beta <= tolerance {
            return Ok(KrylovReport {
                method: METHOD.to_string(),
                iterations,
                relative_residual: beta / rhs_norm,
            });
        }
        if iterations >= limit {
            return Err(SolveError::NotConverged {
                method: METHOD,
                iterations,
                relative_residual: beta / rhs_norm,
                tolerance: settings.relative_tolerance,
            });
        }
        if basis.is_empty() {
            basis.push(vec![0.0; n]);
        }
        for (v_i, r_i) in basis[0].iter_mut().zip(&r) {
            *v_i = r_i / beta;
        }
        let mut least_squares = RotatedLeastSquares::new(beta);
        while least_squares.size() < restart && iterations < limit {
            let j = least_squares.size();
            preconditioner(&basis[j], &mut z);
            apply(&z, &mut w)?;
            let (h, w_norm) = orthogonalise(&basis[..=j], &mut w)?;
            // ‖b − A x‖ for the x this cycle would give now (exact arithmetic).
            let cycle_residual = least_squares.push(h);
            iterations += 1;
            if cycle_residual <= tolerance || w_norm == 0.0 {
                break;
            }
            if basis.len() <= j + 1 {
                basis.push(vec![0.0; n]);
            }
            for (v_i, w_i) in basis[j + 1].iter_mut().zip(&w) {
                *v_i = w_i / w_norm;
            }
        }
        // x += M⁻¹ (V y).
        let y = least_squares.solve(iterations)?;
        w.fill(0.0);
        for (v, y_i) in basis.iter().zip(&y) {
            axpy(*y_i, v, &mut w);
        }
        preconditioner(&w, &mut z);
        axpy(1.0, &z, x);
        check_finite(x, "the GMRES iterate")?;
        residual(apply, rhs, x, &mut r)?;
        beta = norm(&r);
        if !beta.is_finite() {
            return Err(SolveError::NonFinite {
                what: "the residual".to_string(),
            });
        }
    }
}

/// Modified Gram–Schmidt of `w` against the orthonormal `basis` (j + 1 vectors): returns the
/// Hessenberg column (j + 2 entries, the last ‖w‖ after orthogonalisation) and ‖w‖.
fn orthogonalise(basis: &[Vec<f64>], w: &mut [f64]) -> Result<(Vec<f64>, f64), SolveError> {
    let j = basis.len() - 1;
    let mut h = vec![0.0; j + 2];
    for (i, v) in basis.iter().enumerate() {
        let coefficient = dot(w, v);
        h[i] = coefficient;
        axpy(-coefficient, v, w);
    }
    let w_norm = norm(w);
    if !w_norm.is_finite() {
        return Err(SolveError::NonFinite {
            what: "the matrix-vector product".to_string(),
        });
    }
    h[j + 1] = w_norm;
    Ok((h, w_norm))
}

/// The least-squares problem of one GMRES cycle, min ‖β e₁ − H y‖, kept triangular with
/// Givens rotations as the Hessenberg columns arrive.
struct RotatedLeastSquares {
    /// Column j of the Hessenberg matrix (j + 2 entries), rotated into R.
    hessenberg: Vec<Vec<f64>>,
    cosines: Vec<f64>,
    sines: Vec<f64>,
    /// Right-hand side of the least-squares problem, β e₁ rotated.
    g: Vec<f64>,
}

impl RotatedLeastSquares {
    fn new(beta: f64) -> Self {
        Self {
            hessenberg: Vec::new(),
            cosines: Vec::new(),
            sines: Vec::new(),
            g: vec![beta],
        }
    }

    /// Columns so far.
    fn size(&self) -> usize {
        self.hessenberg.len()
    }

    /// Rotates the next column `h` (j + 2 entries) into R; returns |g[j + 1]|, the residual
    /// norm of the least-squares solution with the columns so far.
    fn push(&mut self, mut h: Vec<f64>) -> f64 {
        let j = self.size();
        for i in 0..j {
            let (c, s) = (self.cosines[i], self.sines[i]);
            let (a, b) = (h[i], h[i + 1]);
            h[i] = c * a + s * b;
            h[i + 1] = -s * a + c * b;
        }
        let radius = h[j].hypot(h[j + 1]);
        let (c, s) = if radius == 0.0 {
            (1.0, 0.0)
        } else {
            (h[j] / radius, h[j + 1] / radius)
        };
        h[j] = radius;
        h[j + 1] = 0.0;
        self.cosines.push(c);
        self.sines.push(s);
        self.g.push(-s * self.g[j]);
        self.g[j] *= c;
        self.hessenberg.push(h);
        self.g[j + 1].abs()
    }

    /// Back substitution R y = g; `Breakdown` (after `iterations` in all) when R is singular.
    fn solve(&self, iterations: usize) -> Result<Vec<f64>, SolveError> {
        let size = self.size();
        let (hessenberg, g) = (&self.hessenberg, &self.g);
        let mut y = vec![0.0; size];
        for i in (0..size).rev() {
            let mut sum = g[i];
            for (k, y_k) in y.iter().enumerate().take(size).skip(i + 1) {
                sum -= hessenberg[k][i] * y_k;
            }
            let diagonal = hessenberg[i][i];
            if diagonal == 0.0 {
                return Err(SolveError::Breakdown {
                    method: "GMRES",
                    reason: format!(
                        "the (preconditioned) matrix is singular on the Krylov space after \
                         {iterations} iterations; check the constraints or use LU"
                    ),
                });
            }
            y[i] = sum / diagonal;
        }
        Ok(y)
    }
}

/// Runs `solve` (one of the matrix-free methods) on an assembled matrix with a preconditioner
/// built from it; the report's method names both, e.g. `CG + block Jacobi`.
fn solve_assembled(
    (solve, name): (KrylovMethod, &'static str),
    preconditioner: &Preconditioner,
    matrix: &Csr,
    rhs: &[f64],
    x: &mut [f64],
    settings: &KrylovSettings,
    notes: &mut Vec<String>,
) -> LinearResult {
    check_matrix(name, matrix, rhs, x)?;
    let operator = PreconditionerOperator::build(preconditioner, matrix)?;
    notes.clear();
    notes.extend_from_slice(operator.notes());
    let mut apply = |v: &[f64], y: &mut [f64]| {
        matrix.multiply_parallel(v, y);
        Ok(())
    };
    let mut report = solve(
        &mut apply,
        &|r: &[f64], z: &mut [f64]| operator.apply(r, z),
        rhs,
        x,
        settings,
    )?;
    report.method = match (&preconditioner, notes.len()) {
        (Preconditioner::None, _) => name.to_string(),
        (_, 0) => format!("{name} + {}", operator.label()),
        (_, count) => format!(
            "{name} + {} ({count} fallback{})",
            operator.label(),
            if count == 1 { "" } else { "s" }
        ),
    };
    Ok(report)
}

/// Preconditioned conjugate gradients on an assembled symmetric positive definite matrix
/// (see [`cg_matrix_free`]); the preconditioner is rebuilt from the values on every solve.
#[derive(Debug, Clone, Default)]
pub struct ConjugateGradient {
    /// Stopping settings.
    pub settings: KrylovSettings,
    /// M⁻¹ applied each iteration.
    pub preconditioner: Preconditioner,
    notes: Vec<String>,
}

impl ConjugateGradient {
    /// CG with these settings and preconditioner.
    pub fn new(settings: KrylovSettings, preconditioner: Preconditioner) -> Self {
        Self {
            settings,
            preconditioner,
            notes: Vec::new(),
        }
    }

    /// What the last preconditioner build adjusted (zero pivots, singular blocks).
    pub fn notes(&self) -> &[String] {
        &self.notes
    }
}

impl super::super::LinearSolver for ConjugateGradient {
    fn solve(&mut self, matrix: &Csr, rhs: &[f64], x: &mut [f64]) -> LinearResult {
        solve_assembled(
            (cg_matrix_free, "CG"),
            &self.preconditioner,
            matrix,
            rhs,
            x,
            &self.settings,
            &mut self.notes,
        )
    }
}

/// Restarted GMRES on an assembled matrix, symmetric or not (see [`gmres_matrix_free`]); the
/// preconditioner is rebuilt from the values on every solve.
#[derive(Debug, Clone, Default)]
pub struct Gmres {
    /// Stopping settings and restart length.
    pub settings: KrylovSettings,
    /// M⁻¹ applied on the right.
    pub preconditioner: Preconditioner,
    notes: Vec<String>,
}

impl Gmres {
    /// GMRES with these settings and preconditioner.
    pub fn new(settings: KrylovSettings, preconditioner: Preconditioner) -> Self {
        Self {
            settings,
            preconditioner,
            notes: Vec::new(),
        }
    }

    /// What the last preconditioner build adjusted (zero pivots, singular blocks).
    pub fn notes(&self) -> &[String] {
        &self.notes
    }
}

impl super::super::LinearSolver for Gmres {
    fn solve(&mut self, matrix: &Csr, rhs: &[f64], x: &mut [f64]) -> LinearResult {
        solve_assembled(
            (gmres_matrix_free, "GMRES"),
            &self.preconditioner,
            matrix,
            rhs,
            x,
            &self.settings,
            &mut self.notes,
        )
    }
}
