use super::*;
use crate::backend::Csr;
use crate::solver::newton::ConvergenceMeasure;

/// A chain of `n` unknowns joined by springs: a spring of stiffness `k[0]` from a fixed wall
/// to unknown 0, then `k[i]` between unknowns i − 1 and i, and a load `load` (N) on the last
/// one. F(x) = Kx − p; the exact answer is xᵢ = load · Σ_{j ≤ i} 1/kⱼ (every spring carries
/// the load).
struct SpringChain {
    k: Vec<f64>,
    load: f64,
    groups: Vec<usize>,
    evaluations: usize,
    /// The point F was last evaluated at (where `relax` ends).
    last: Vec<f64>,
}

impl SpringChain {
    fn new(k: Vec<f64>, load: f64) -> Self {
        let groups = (0..=k.len()).collect();
        Self {
            k,
            load,
            groups,
            evaluations: 0,
            last: Vec::new(),
        }
    }

    fn exact(&self) -> Vec<f64> {
        self.k
            .iter()
            .scan(0.0, |x, k| {
                *x += self.load / k;
                Some(*x)
            })
            .collect()
    }

    fn stiffness(&self) -> Csr {
        let n = self.k.len();
        let (mut offsets, mut columns, mut values) = (vec![0], Vec::new(), Vec::new());
        for i in 0..n {
            let right = self.k.get(i + 1).copied().unwrap_or(0.0);
            if i > 0 {
                columns.push(i - 1);
                values.push(-self.k[i]);
            }
            columns.push(i);
            values.push(self.k[i] + right);
            if i + 1 < n {
                columns.push(i + 1);
                values.push(-right);
            }
            offsets.push(columns.len());
        }
        Csr {
            nrows: n,
            ncols: n,
            offsets,
            columns,
            values,
        }
    }
}

impl NonlinearProblem for SpringChain {
    fn len(&self) -> usize {
        self.k.len()
    }
    fn ranks(&self) -> usize {
        1
    }
    fn global_ids(&self) -> Option<&[usize]> {
        None
    }
    fn unknowns(&self, x: &mut [f64]) {
        x.fill(0.0);
    }
    fn move_to(&mut self, _: &[f64]) {}
    fn residual(&mut self, x: &[f64], f: &mut [f64], _: Evaluation) -> Result<(), SolveError> {
        self.evaluations += 1;
        self.last = x.to_vec();
        self.stiffness().multiply(x, f);
        *f.last_mut().expect("a chain has unknowns") -= self.load;
        Ok(())
    }
    fn jacobian(&mut self, _: &[f64]) -> Result<Csr, SolveError> {
        Ok(self.stiffness())
    }
    fn jacobian_bytes(&self) -> usize {
        0
    }
    fn groups(&self) -> &[usize] {
        &self.groups
    }
    fn block_diagonal(&mut self, _: &[f64]) -> Result<Vec<f64>, SolveError> {
        Ok(Vec::new())
    }
    fn group_label(&self, group: usize) -> String {
        format!("unknown {group}")
    }
    fn dot(&mut self, a: &[f64], b: &[f64]) -> f64 {
        a.iter().zip(b).map(|(a, b)| a * b).sum()
    }
    fn any_failed(&mut self, failed: bool) -> bool {
        failed
    }
    fn convergence_measure(&mut self, f: &[f64]) -> f64 {
        f.iter().map(|f| f * f).sum::<f64>().sqrt()
    }
    fn probe_scale(&self) -> f64 {
        1.0
    }
}

fn settings(tolerance: f64, max_iterations: u64) -> NewtonSettings {
    NewtonSettings {
        max_iterations,
        tolerance,
        measure: ConvergenceMeasure::TwoNorm,
        line_search: false,
        print_iterations: false,
        verbose: false,
    }
}

fn largest_error(x: &[f64], exact: &[f64]) -> f64 {
    x.iter()
        .zip(exact)
        .map(|(x, e)| (x - e).abs())
        .fold(0.0, f64::max)
}

#[test]
fn a_uniform_spring_chain_relaxes_to_the_exact_answer() {
    let mut chain = SpringChain::new(vec![1.0e9; 40], 1.0e3);
    let report = relax(&mut chain, &settings(1e-11 * 1.0e3, 100_000)).unwrap();
    assert!(report.converged, "{report:?}");
    let exact = chain.exact();
    // ‖Kx − p‖ ≤ 1e-11 P = 1e-8 N bounds the error by 1e-8 N / λ_min(K); λ_min of a fixed-free
    // chain of 40 springs is 4k sin²(π/162) = 1.50e6 N/m (numpy's eigvalsh agrees), so the
    // error is at most 6.7e-15 m against x_max = 4e-5 m: 1.7e-10 of it.
    assert!(
        largest_error(&chain.last, &exact) < 1e-8 * exact[39],
        "{:?} against {exact:?}",
        chain.last
    );
    // Each iteration is one force evaluation plus the first.
    assert_eq!(chain.evaluations, report.relaxation_iterations + 1);
    assert_eq!(report.iterations, 0, "no Newton iteration");
}

#[test]
fn stiff_and_soft_springs_relax_without_blowing_up() {
    // Stiffnesses three orders apart: λ per unknown follows its own springs, so the stiff
    // part does not limit the soft part's steps.
    let k: Vec<f64> = (0..30)
        .map(|i| if i % 3 == 0 { 1.0e12 } else { 1.0e9 })
        .collect();
    let mut chain = SpringChain::new(k, 5.0e2);
    let exact = chain.exact();
    // ‖Kx − p‖ ≤ 5e-8 N and λ_min(K) = 4.11e6 N/m (numpy's eigvalsh) bound the error by
    // 1.2e-14 m against x_max = 1.0e-5 m.
    let report = relax(&mut chain, &settings(1e-10 * 5.0e2, 200_000)).unwrap();
    assert!(report.converged, "{report:?}");
    assert!(
        largest_error(&chain.last, &exact) < 1e-8 * exact[29],
        "{:?} against {exact:?}",
        chain.last
    );
}

#[test]
fn an_iteration_limit_reports_an_unconverged_step() {
    let mut chain = SpringChain::new(vec![1.0; 50], 1.0);
    let report = relax(&mut chain, &settings(1e-12, 10)).unwrap();
    assert!(!report.converged);
    assert_eq!(report.relaxation_iterations, 10);
    assert!(report.residual_history[1] < report.residual_history[0]);
}

#[test]
fn damping_is_zero_without_a_positive_quotient_and_at_most_two() {
    let mut chain = SpringChain::new(vec![1.0; 2], 1.0);
    let density = [1.0, 1.0];
    // The force rose where the body moved: negative local stiffness, no damping.
    let c = rayleigh_damping(
        &mut chain,
        (&[1.0, 1.0], &[1.0, 1.0]),
        [&[-1.0, -1.0], &[0.0, 0.0]],
        &density,
        &mut [0.0; 2],
    );
    assert_eq!(c, 0.0);
    // A local stiffness far above λ: clamped at 2.
    let c = rayleigh_damping(
        &mut chain,
        (&[1.0, 1.0], &[1.0, 1.0]),
        [&[100.0, 100.0], &[0.0, 0.0]],
        &density,
        &mut [0.0; 2],
    );
    assert_eq!(c, 2.0);
    // ¹K = 0.25 on both: c = 2·√0.25 = 1.
    let c = rayleigh_damping(
        &mut chain,
        (&[1.0, 2.0], &[1.0, 1.0]),
        [&[0.25, 0.25], &[0.0, 0.0]],
        &density,
        &mut [0.0; 2],
    );
    assert!((c - 1.0).abs() < 1e-15, "{c}");
}
