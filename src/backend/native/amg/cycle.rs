//! The pieces of one V-cycle: a Chebyshev smoother preconditioned by block Jacobi, and the
//! dense LU of the coarsest operator.
//!
//! The smoother works in a [`Scratch`] the hierarchy keeps, so applying a V-cycle allocates
//! nothing: a Krylov solve applies it once per iteration, hundreds of times a Newton step.
//!
//! Chebyshev (degree [`CHEBYSHEV_DEGREE`]) on D⁻¹A, D the inverted diagonal blocks of the
//! level's groups, targets the upper part [λ_max/[`CHEBYSHEV_RATIO`], 1.1 λ_max] of its
//! spectrum: the smooth rest is the coarse level's job. A polynomial in D⁻¹A is self-adjoint
//! in the A inner product, so the same smoother before and after the coarse correction keeps
//! the V-cycle symmetric (usable by CG), and unlike Gauss–Seidel every step is a matrix
//! product and a block-diagonal solve, both parallel.

use super::super::super::{Csr, SolveError};
use super::super::preconditioner::{Preconditioner, PreconditionerOperator};
use super::compact::CompactCsr;

/// Smoothing steps before and after the coarse correction.
pub(super) const CHEBYSHEV_DEGREE: usize = 2;

/// λ_max / λ_min of the interval the smoother damps.
pub(super) const CHEBYSHEV_RATIO: f64 = 30.0;

/// The smoother of one level.
#[derive(Debug, Clone)]
pub(super) struct Chebyshev {
    block_jacobi: PreconditionerOperator,
    /// Estimated largest eigenvalue of D⁻¹A.
    lambda_max: f64,
}

impl Chebyshev {
    /// The smoother of `a` with block Jacobi over `groups`, its λ_max estimated by power
    /// iteration.
    pub fn new(a: &Csr, groups: &[usize]) -> Result<Self, SolveError> {
        let block_jacobi = block_jacobi(a, groups)?;
        let lambda_max = spectral_radius(a, |r, z| block_jacobi.apply(r, z));
        if !(lambda_max.is_finite() && lambda_max > 0.0) {
            return Err(not_positive_definite(
                "the block-Jacobi-scaled operator has no positive eigenvalue",
            ));
        }
        Ok(Self {
            block_jacobi,
            lambda_max,
        })
    }

    /// Bytes held (the inverted diagonal blocks).
    pub fn memory_bytes(&self) -> usize {
        self.block_jacobi.memory_bytes()
    }

    /// Improves x towards A x = b with [`CHEBYSHEV_DEGREE`] Chebyshev steps, working in
    /// `scratch` (sized for `a`'s rows by [`Scratch::new`]).
    pub fn smooth(&self, a: &CompactCsr, b: &[f64], x: &mut [f64], scratch: &mut Scratch) {
        let upper = 1.1 * self.lambda_max;
        let lower = self.lambda_max / CHEBYSHEV_RATIO;
        let (theta, delta) = (0.5 * (upper + lower), 0.5 * (upper - lower));
        let sigma = theta / delta;
        let Scratch { r, z, ax, d } = scratch;
        residual(a, b, x, ax, r);
        self.block_jacobi.apply(r, z);
        d.iter_mut().zip(z.iter()).for_each(|(d, z)| *d = z / theta);
        let mut rho = 1.0 / sigma;
        for _ in 1..CHEBYSHEV_DEGREE {
            x.iter_mut().zip(d.iter()).for_each(|(x, d)| *x += d);
            residual(a, b, x, ax, r);
            self.block_jacobi.apply(r, z);
            let rho_next = 1.0 / (2.0 * sigma - rho);
            for (d, z) in d.iter_mut().zip(z.iter()) {
                *d = rho_next * rho * *d + 2.0 * rho_next / delta * z;
            }
            rho = rho_next;
        }
        x.iter_mut().zip(d.iter()).for_each(|(x, d)| *x += d);
    }
}

/// The inverted diagonal blocks of `a` over `groups` (block Jacobi's D⁻¹).
pub(super) fn block_jacobi(
    a: &Csr,
    groups: &[usize],
) -> Result<PreconditionerOperator, SolveError> {
    PreconditionerOperator::build(
        &Preconditioner::BlockJacobi {
            groups: groups.to_vec(),
        },
        a,
    )
}

/// The vectors one [`Chebyshev::smooth`] works in: residual r, preconditioned residual z,
/// the product A x and the step d, each of the level's unknowns.
#[derive(Debug, Clone)]
pub(super) struct Scratch {
    r: Vec<f64>,
    z: Vec<f64>,
    ax: Vec<f64>,
    d: Vec<f64>,
}

impl Scratch {
    /// Scratch for a level of `n` unknowns.
    pub fn new(n: usize) -> Self {
        Self {
            r: vec![0.0; n],
            z: vec![0.0; n],
            ax: vec![0.0; n],
            d: vec![0.0; n],
        }
    }

    /// Bytes held.
    pub fn memory_bytes(&self) -> usize {
        8 * (self.r.len() + self.z.len() + self.ax.len() + self.d.len())
    }
}

/// r = b − A x (`ax` is scratch).
fn residual(a: &CompactCsr, b: &[f64], x: &[f64], ax: &mut [f64], r: &mut [f64]) {
    a.multiply_parallel(x, ax);
    for ((r, b), ax) in r.iter_mut().zip(b).zip(ax.iter()) {
        *r = b - ax;
    }
}

/// ρ(M⁻¹A) estimated by [`POWER_ITERATIONS`] power iterations from a fixed start vector
/// (deterministic, so runs repeat exactly). Power iteration approaches ρ from below; the
/// callers' margins (1.1 λ_max for Chebyshev, 4/3 in ω) absorb that.
pub(super) fn spectral_radius(a: &Csr, inverse: impl Fn(&[f64], &mut [f64])) -> f64 {
    const POWER_ITERATIONS: usize = 15;
    let n = a.nrows;
    // A start vector with components of both signs and varied size (golden-ratio sequence)
    // overlaps every eigenvector of a generic matrix.
    let mut v: Vec<f64> = (0..n)
        .map(|i| ((i as f64 * 0.618_033_988_749_895).fract() - 0.5) + 1e-3)
        .collect();
    let mut av = vec![0.0; n];
    let mut w = vec![0.0; n];
    let mut estimate = 0.0;
    for _ in 0..POWER_ITERATIONS {
        let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        if norm == 0.0 || !norm.is_finite() {
            return estimate;
        }
        v.iter_mut().for_each(|x| *x /= norm);
        a.multiply_parallel(&v, &mut av);
        inverse(&av, &mut w);
        estimate = w.iter().map(|x| x * x).sum::<f64>().sqrt();
        std::mem::swap(&mut v, &mut w);
    }
    estimate
}

/// The error of an operator AMG cannot precondition.
pub(super) fn not_positive_definite(reason: impl Into<String>) -> SolveError {
    SolveError::Breakdown {
        method: "AMG",
        reason: format!(
            "{}: the preconditioning operator is not symmetric positive definite (a body with no prescribed displacement, or a model with no stiffness)",
            reason.into()
        ),
    }
}

/// The LU factors (partial pivoting) of the dense coarsest operator.
#[derive(Debug, Clone)]
pub(super) struct DenseLu {
    n: usize,
    /// L (unit diagonal, below) and U (on and above), row-major.
    factors: Vec<f64>,
    pivots: Vec<usize>,
}

impl DenseLu {
    /// Factors `a`. A pivot below 10⁻¹² of the largest diagonal entry means a singular
    /// operator, which no preconditioner can invert: an error.
    pub fn new(a: &Csr) -> Result<Self, SolveError> {
        let n = a.nrows;
        let mut factors = vec![0.0; n * n];
        for r in 0..n {
            let (columns, values) = a.row(r);
            for (&c, &v) in columns.iter().zip(values) {
                factors[r * n + c] = v;
            }
        }
        let scale = (0..n).fold(0.0f64, |m, i| m.max(factors[i * n + i].abs()));
        let mut pivots = vec![0; n];
        for k in 0..n {
            let pivot = (k..n)
                .max_by(|&i, &j| {
                    factors[i * n + k]
                        .abs()
                        .total_cmp(&factors[j * n + k].abs())
                })
                .expect("k < n");
            let magnitude = factors[pivot * n + k].abs();
            if magnitude.is_nan() || magnitude <= 1e-12 * scale {
                return Err(not_positive_definite(format!(
                    "the coarsest operator ({n} unknowns) is singular"
                )));
            }
            pivots[k] = pivot;
            if pivot != k {
                for c in 0..n {
                    factors.swap(k * n + c, pivot * n + c);
                }
            }
            let diagonal = factors[k * n + k];
            for i in k + 1..n {
                let l = factors[i * n + k] / diagonal;
                factors[i * n + k] = l;
                if l != 0.0 {
                    for c in k + 1..n {
                        factors[i * n + c] -= l * factors[k * n + c];
                    }
                }
            }
        }
        Ok(Self { n, factors, pivots })
    }

    /// Bytes held (the n² factors and n pivots).
    pub fn memory_bytes(&self) -> usize {
        self.factors.len() * 8 + self.pivots.len() * std::mem::size_of::<usize>()
    }

    /// x = A⁻¹ b.
    pub fn solve(&self, b: &[f64], x: &mut [f64]) {
        let n = self.n;
        x.copy_from_slice(b);
        for k in 0..n {
            x.swap(k, self.pivots[k]);
        }
        for i in 0..n {
            let sum: f64 = (0..i).map(|c| self.factors[i * n + c] * x[c]).sum();
            x[i] -= sum;
        }
        for i in (0..n).rev() {
            let sum: f64 = (i + 1..n).map(|c| self.factors[i * n + c] * x[c]).sum();
            x[i] = (x[i] - sum) / self.factors[i * n + i];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dense_lu_solves_a_system_that_needs_pivoting() {
        // [[0, 1], [2, 3]] x = [1, 8] has x = (2.5, 1).
        let a = Csr {
            nrows: 2,
            ncols: 2,
            offsets: vec![0, 1, 3],
            columns: vec![1, 0, 1],
            values: vec![1.0, 2.0, 3.0],
        };
        let lu = DenseLu::new(&a).unwrap();
        let mut x = vec![0.0; 2];
        lu.solve(&[1.0, 8.0], &mut x);
        assert!(
            (x[0] - 2.5).abs() < 1e-14 && (x[1] - 1.0).abs() < 1e-14,
            "{x:?}"
        );
    }

    #[test]
    fn a_singular_coarse_operator_is_an_error() {
        let a = Csr {
            nrows: 2,
            ncols: 2,
            offsets: vec![0, 2, 4],
            columns: vec![0, 1, 0, 1],
            values: vec![1.0, -1.0, -1.0, 1.0],
        };
        let error = DenseLu::new(&a).unwrap_err();
        assert!(error.to_string().contains("singular"), "{error}");
    }
}
