//! Variance-based sensitivity: Sobol indices of a function of independent random inputs.
//!
//! The first-order index `S_i = V[E(Y | X_i)] / V(Y)` is the share of the output's
//! variance that input `i` explains alone; the total index
//! `S_Ti = E[V(Y | X_~i)] / V(Y)` is its share including every interaction it takes
//! part in. `S_Ti − S_i` measures those interactions, and `S_Ti ≈ 0` says the input
//! can be fixed anywhere in its range without changing the output.
//!
//! **Monte Carlo estimates** ([`sobol_indices`]) follow the sampling scheme of
//! Saltelli et al. (2010), "Variance based sensitivity analysis of model output.
//! Design and estimator for the total sensitivity index", Comput. Phys. Commun. 181,
//! 259–270. Two independent `N × k` sample matrices `A` and `B` are drawn, and for
//! each input `i` a matrix `A_B^(i)`: `A` with column `i` taken from `B`. The function
//! is evaluated on all of them, `N (k + 2)` times in all. Then, with `V` the sample
//! variance of `f(A)` and `f(B)` together,
//!
//! - first order (Saltelli et al. 2010, Table 2 (b)):
//!   `V_i = (1/N) Σ_j f(B)_j (f(A_B^(i))_j − f(A)_j)`;
//! - total (Jansen 1999, "Analysis of variance designs for model output",
//!   Comput. Phys. Commun. 117, 35–43; Table 2 (f) in Saltelli et al. 2010):
//!   `V_Ti = (1/(2N)) Σ_j (f(A)_j − f(A_B^(i))_j)²`;
//!
//! and `S_i = V_i / V`, `S_Ti = V_Ti / V`. The outputs are first centred on their
//! sample mean; a constant shift leaves both estimators' expectations unchanged but
//! would add noise proportional to the mean to the first-order one. Saltelli et al.
//! draw `A` and `B` from a quasi-random (Sobol') sequence; here they are pseudo-random
//! from a seeded ChaCha8 generator, so the error falls as `N^(-1/2)`, and the same
//! seed gives the same figures.
//!
//! **Confidence intervals** are 95 % percentile bootstrap intervals: the `N` base rows
//! (each row's `f(A)`, `f(B)` and `f(A_B^(i))` together) are resampled with
//! replacement [`BOOTSTRAP_RESAMPLES`] times and the estimators recomputed from the
//! stored values, so the function is not evaluated again. The indices are estimates:
//! a first-order index may come out slightly negative, or above its total index, when
//! the true values are close.
//!
//! **Analytic indices** ([`legendre_sobol`]) of a response surface in Legendre
//! polynomials follow Sudret (2008), "Global sensitivity analysis using polynomial
//! chaos expansions", Reliab. Eng. Syst. Saf. 93, 964–979: with inputs uniform on the
//! coded box the basis is orthogonal, so the variance is a sum of squared coefficients
//! and each index is a partial sum, with no sampling at all.
//!
//! The tests use the function of Ishigami & Homma (1990), "An importance
//! quantification technique in uncertainty analysis for computer models", Proc. ISUMA
//! '90, 398–403, whose indices are known in closed form.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::basis::BasisKind;
use crate::fit::Fit;
use crate::propagate::{Distribution, DistributionError, Sampler};

/// Resamples of the base rows behind each confidence interval.
pub const BOOTSTRAP_RESAMPLES: usize = 200;

/// Fewest base samples [`sobol_indices`] accepts; two-digit indices need 10^4 or more.
pub const MIN_BASE_SAMPLES: usize = 10;

/// An estimated index with its 95 % bootstrap confidence interval (dimensionless).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    /// Point estimate from all base samples.
    pub value: f64,
    /// 2.5 % quantile of the bootstrap estimates.
    pub low: f64,
    /// 97.5 % quantile of the bootstrap estimates.
    pub high: f64,
}

/// First-order and total Sobol indices of every input, in input order.
#[derive(Debug, Clone, PartialEq)]
pub struct SobolIndices {
    /// First-order indices `S_i`: the share of the output's variance due to input `i`
    /// alone.
    pub first: Vec<Estimate>,
    /// Total indices `S_Ti`: the share due to input `i` with all its interactions.
    pub total: Vec<Estimate>,
    /// The output's variance estimated from `f(A)` and `f(B)`, in the output's units
    /// squared.
    pub variance: f64,
    /// Number of calls of the function, `N (k + 2)`.
    pub evaluations: usize,
}

/// Why Sobol indices cannot be estimated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SobolError {
    /// No inputs were given.
    #[error("no inputs: give a distribution for at least one input")]
    NoInputs,
    /// Too few base samples for the estimators and their intervals.
    #[error("{given} base samples are too few; use at least {MIN_BASE_SAMPLES} (10^4 or more for indices to two digits)")]
    TooFewSamples {
        /// The number given.
        given: usize,
    },
    /// An input's distribution is invalid.
    #[error(transparent)]
    Distribution(#[from] DistributionError),
    /// The function returned NaN or an infinity.
    #[error("the function returned {value} at {point:?}; make it finite over the inputs' whole range (a surface extrapolated far outside its box, or a logarithm of a non-positive number?)")]
    NotFinite {
        /// The input values there.
        point: Vec<f64>,
        /// What it returned.
        value: f64,
    },
    /// The output does not vary, so no share of its variance can be attributed.
    #[error("the output's variance is {variance}: it does not vary over the inputs, so Sobol indices are undefined; check that the function depends on its inputs")]
    NoVariance {
        /// The estimated variance.
        variance: f64,
    },
}

/// First-order and total Sobol indices of `f` with independent `inputs`, from
/// `base_samples` (`N`) rows of the Saltelli et al. (2010) scheme, `N (k + 2)`
/// evaluations of `f` in all, with 95 % bootstrap intervals. The generator is seeded
/// with `seed`: the same seed gives the same figures.
///
/// `f` must be `Sync` so that evaluation may be spread over threads later without
/// changing this signature; today it runs on the calling thread.
pub fn sobol_indices(
    f: &(dyn Fn(&[f64]) -> f64 + Sync),
    inputs: &[Distribution],
    base_samples: usize,
    seed: u64,
) -> Result<SobolIndices, SobolError> {
    if inputs.is_empty() {
        return Err(SobolError::NoInputs);
    }
    if base_samples < MIN_BASE_SAMPLES {
        return Err(SobolError::TooFewSamples {
            given: base_samples,
        });
    }
    let samplers = inputs
        .iter()
        .enumerate()
        .map(|(i, d)| Sampler::new(i, *d))
        .collect::<Result<Vec<_>, _>>()?;
    let (n, k) = (base_samples, inputs.len());
    let mut rng = ChaCha8Rng::seed_from_u64(seed);

    let evaluate = |x: &[f64]| {
        let value = f(x);
        if value.is_finite() {
            Ok(value)
        } else {
            Err(SobolError::NotFinite {
                point: x.to_vec(),
                value,
            })
        }
    };
    let mut outputs = Outputs {
        k,
        a: Vec::with_capacity(n),
        b: Vec::with_capacity(n),
        ab: Vec::with_capacity(n * k),
    };
    let (mut a, mut b, mut ab) = (vec![0.0; k], vec![0.0; k], vec![0.0; k]);
    for _ in 0..n {
        for (value, sampler) in a.iter_mut().zip(&samplers) {
            *value = sampler.sample(&mut rng);
        }
        for (value, sampler) in b.iter_mut().zip(&samplers) {
            *value = sampler.sample(&mut rng);
        }
        outputs.a.push(evaluate(&a)?);
        outputs.b.push(evaluate(&b)?);
        for i in 0..k {
            ab.copy_from_slice(&a);
            ab[i] = b[i];
            outputs.ab.push(evaluate(&ab)?);
        }
    }
    // Centre on the sample mean (see the module doc).
    let mean = (outputs.a.iter().sum::<f64>() + outputs.b.iter().sum::<f64>()) / (2 * n) as f64;
    for y in outputs
        .a
        .iter_mut()
        .chain(&mut outputs.b)
        .chain(&mut outputs.ab)
    {
        *y -= mean;
    }

    let point = outputs.indices(0..n);
    if !(point.variance.is_finite() && point.variance > 0.0) {
        return Err(SobolError::NoVariance {
            variance: point.variance,
        });
    }

    let mut first_resampled = vec![Vec::with_capacity(BOOTSTRAP_RESAMPLES); k];
    let mut total_resampled = vec![Vec::with_capacity(BOOTSTRAP_RESAMPLES); k];
    for _ in 0..BOOTSTRAP_RESAMPLES {
        let resample = outputs.indices((0..n).map(|_| rng.random_range(0..n)));
        if resample.variance <= 0.0 {
            continue;
        }
        for i in 0..k {
            first_resampled[i].push(resample.first[i]);
            total_resampled[i].push(resample.total[i]);
        }
    }
    let with_interval = |value: f64, mut resampled: Vec<f64>| {
        resampled.sort_by(f64::total_cmp);
        let quantile = |p: f64| {
            let index = (p * (resampled.len() - 1) as f64).round() as usize;
            resampled[index]
        };
        Estimate {
            value,
            low: quantile(0.025),
            high: quantile(0.975),
        }
    };
    Ok(SobolIndices {
        first: point
            .first
            .iter()
            .zip(first_resampled)
            .map(|(&v, r)| with_interval(v, r))
            .collect(),
        total: point
            .total
            .iter()
            .zip(total_resampled)
            .map(|(&v, r)| with_interval(v, r))
            .collect(),
        variance: point.variance,
        evaluations: n * (k + 2),
    })
}

/// The stored outputs: `f(A)`, `f(B)` per base row and `f(A_B^(i))` row-major (`k` per
/// row), so that a bootstrap resample reads each row's values together.
struct Outputs {
    k: usize,
    a: Vec<f64>,
    b: Vec<f64>,
    ab: Vec<f64>,
}

/// Point estimates from one set of rows.
struct Point {
    first: Vec<f64>,
    total: Vec<f64>,
    variance: f64,
}

impl Outputs {
    /// The estimators over `rows` (with repeats, for a bootstrap resample).
    fn indices(&self, rows: impl Iterator<Item = usize>) -> Point {
        let k = self.k;
        let (mut count, mut sum, mut sum_squares) = (0usize, 0.0, 0.0);
        let mut first = vec![0.0; k];
        let mut total = vec![0.0; k];
        for j in rows {
            let (fa, fb) = (self.a[j], self.b[j]);
            count += 1;
            sum += fa + fb;
            sum_squares += fa * fa + fb * fb;
            for (i, &fab) in self.ab[j * k..(j + 1) * k].iter().enumerate() {
                first[i] += fb * (fab - fa);
                total[i] += (fa - fab) * (fa - fab);
            }
        }
        let n = count as f64;
        let mean = sum / (2.0 * n);
        let variance = (sum_squares - 2.0 * n * mean * mean) / (2.0 * n - 1.0);
        for v in &mut first {
            *v /= n * variance;
        }
        for v in &mut total {
            *v /= 2.0 * n * variance;
        }
        Point {
            first,
            total,
            variance,
        }
    }
}

/// First-order and total Sobol indices `(first, total)` of a Legendre surface, exact
/// for factors independent and uniform on the coded box `[-1, 1]^k` (that is, uniform
/// over their natural ranges), after Sudret (2008).
///
/// Since `∫ P_m P_n dx / 2 = δ_mn / (2n + 1)` on `[-1, 1]`, the term with exponents `e`
/// and coefficient `c` adds `c² Π_j 1 / (2 e_j + 1)` to the variance, and the terms are
/// uncorrelated. Input `j`'s first-order index sums the terms in `j` alone; its total
/// index sums every term with `e_j > 0`. `None` when the basis is not Legendre (use
/// [`sobol_indices`] on [`Fit::predict`] instead) or the surface is constant (its
/// variance below `10^-24` of its coefficients' sum of squares: rounding noise).
pub fn legendre_sobol(fit: &Fit) -> Option<(Vec<f64>, Vec<f64>)> {
    // Indicator terms of text factors are not orthogonal Legendre terms.
    if fit.basis.kind != BasisKind::Legendre || fit.basis.levels.iter().any(|&l| l > 0) {
        return None;
    }
    let k = fit.basis.n_factors;
    let mut variance = 0.0;
    let mut first = vec![0.0; k];
    let mut total = vec![0.0; k];
    for (term, &c) in fit.basis.terms.iter().zip(&fit.coefficients) {
        let active: Vec<usize> = (0..k).filter(|&j| term[j] > 0).collect();
        if active.is_empty() {
            continue;
        }
        let share = c
            * c
            * term
                .iter()
                .map(|&e| 1.0 / (2 * e + 1) as f64)
                .product::<f64>();
        variance += share;
        if let [only] = active[..] {
            first[only] += share;
        }
        for j in active {
            total[j] += share;
        }
    }
    // A constant surface's other coefficients are rounding noise, not variance.
    let scale: f64 = fit.coefficients.iter().map(|c| c * c).sum();
    if !variance.is_finite() || variance <= 1e-24 * scale {
        return None;
    }
    for v in first.iter_mut().chain(&mut total) {
        *v /= variance;
    }
    Some((first, total))
}

#[cfg(test)]
mod tests {
    use std::f64::consts::PI;

    use super::*;
    use crate::basis::Basis;

    fn uniform(low: f64, high: f64) -> Distribution {
        Distribution::Uniform { low, high }
    }

    /// `estimate` is within `tolerance` of `expected`, and its interval contains
    /// `expected` or misses it by at most `slack`.
    fn check(name: &str, estimate: Estimate, expected: f64, tolerance: f64, slack: f64) {
        assert!(
            (estimate.value - expected).abs() < tolerance,
            "{name}: {estimate:?} vs {expected}"
        );
        assert!(
            estimate.low - slack <= expected && expected <= estimate.high + slack,
            "{name}: interval {estimate:?} misses {expected}"
        );
        assert!(estimate.low <= estimate.value && estimate.value <= estimate.high);
    }

    #[test]
    fn ishigami_indices_within_two_hundredths_of_the_closed_forms() {
        // Ishigami & Homma (1990): f = sin x1 + a sin² x2 + b x3⁴ sin x1, x ~ U(−π, π)³.
        let (a, b) = (7.0, 0.1);
        let f = |x: &[f64]| x[0].sin() + a * x[1].sin().powi(2) + b * x[2].powi(4) * x[0].sin();
        let variance = a * a / 8.0 + b * PI.powi(4) / 5.0 + b * b * PI.powi(8) / 18.0 + 0.5;
        let v1 = 0.5 * (1.0 + b * PI.powi(4) / 5.0).powi(2);
        let v2 = a * a / 8.0;
        let v13 = b * b * PI.powi(8) * (1.0 / 18.0 - 1.0 / 50.0);
        let first = [v1 / variance, v2 / variance, 0.0];
        let total = [(v1 + v13) / variance, v2 / variance, v13 / variance];
        // The closed forms give the published values.
        let published_first = [0.3139, 0.4424, 0.0];
        let published_total = [0.5576, 0.4424, 0.2437];
        for i in 0..3 {
            assert!((first[i] - published_first[i]).abs() < 1e-4, "S{}", i + 1);
            assert!((total[i] - published_total[i]).abs() < 1e-4, "ST{}", i + 1);
        }

        let u = uniform(-PI, PI);
        let indices = sobol_indices(&f, &[u, u, u], 100_000, 2010).unwrap();
        assert_eq!(indices.evaluations, 500_000);
        assert!((indices.variance - variance).abs() / variance < 0.02);
        for i in 0..3 {
            check(
                &format!("S{}", i + 1),
                indices.first[i],
                first[i],
                0.02,
                0.01,
            );
            check(
                &format!("ST{}", i + 1),
                indices.total[i],
                total[i],
                0.02,
                0.01,
            );
        }
    }

    #[test]
    fn g_function_indices_match_the_closed_forms() {
        // Sobol's G-function g = Π (|4x_i − 2| + a_i) / (1 + a_i), x ~ U(0, 1)^5
        // (Saltelli et al. 2010, §4): V_i = 1 / (3 (1 + a_i)²), V = Π (1 + V_i) − 1,
        // S_i = V_i / V, S_Ti = V_i Π_{j≠i} (1 + V_j) / V.
        let a = [0.0, 1.0, 4.5, 9.0, 99.0];
        let g = |x: &[f64]| {
            x.iter()
                .zip(&a)
                .map(|(x, a)| ((4.0 * x - 2.0).abs() + a) / (1.0 + a))
                .product::<f64>()
        };
        let partial: Vec<f64> = a
            .iter()
            .map(|a| 1.0 / (3.0 * (1.0 + a) * (1.0 + a)))
            .collect();
        let product: f64 = partial.iter().map(|v| 1.0 + v).product();
        let variance = product - 1.0;
        // Hand-computed: V = 1.3333 · 1.0833 · 1.0110 · 1.0033 · 1.00003 − 1 = 0.4653.
        assert!((variance - 0.4653).abs() < 1e-4);
        let indices = sobol_indices(&g, &[uniform(0.0, 1.0); 5], 50_000, 7).unwrap();
        for (i, v) in partial.iter().enumerate() {
            let first = v / variance;
            let total = v * product / (1.0 + v) / variance;
            check(&format!("S{}", i + 1), indices.first[i], first, 0.02, 0.01);
            check(&format!("ST{}", i + 1), indices.total[i], total, 0.02, 0.01);
        }
        // The first factor dominates: S1 = 0.716.
        assert!((partial[0] / variance - 0.7164).abs() < 1e-4);
    }

    #[test]
    fn a_linear_function_of_normal_and_lognormal_inputs_has_additive_indices() {
        // y = 3 x1 − 2 x2 + x3: V_i = c_i² Var(x_i), S_i = S_Ti = V_i / Σ V.
        // x3 log-normal (μ = 0, σ = 0.5): Var = (e^{σ²} − 1) e^{2μ + σ²}.
        let f = |x: &[f64]| 3.0 * x[0] - 2.0 * x[1] + x[2];
        let inputs = [
            Distribution::Normal {
                mean: 1.0,
                std: 0.5,
            },
            Distribution::Normal {
                mean: -4.0,
                std: 1.0,
            },
            Distribution::LogNormal {
                mu: 0.0,
                sigma: 0.5,
            },
        ];
        let lognormal = (0.25f64.exp() - 1.0) * 0.25f64.exp();
        let parts = [9.0 * 0.25, 4.0, lognormal];
        let variance: f64 = parts.iter().sum();
        let indices = sobol_indices(&f, &inputs, 20_000, 3).unwrap();
        assert!((indices.variance - variance).abs() / variance < 0.03);
        for (i, part) in parts.iter().enumerate() {
            let expected = part / variance;
            check(
                &format!("S{}", i + 1),
                indices.first[i],
                expected,
                0.02,
                0.01,
            );
            // Jansen's estimator of an additive function's total index is exact up to
            // the variance's sampling error.
            check(
                &format!("ST{}", i + 1),
                indices.total[i],
                expected,
                0.02,
                0.01,
            );
        }
        // Seeded: the same seed gives the same figures.
        assert_eq!(
            sobol_indices(&f, &inputs, 100, 3),
            sobol_indices(&f, &inputs, 100, 3)
        );
    }

    /// y = 1 + 2 x1 + x1 x2 + 0.5 x3², fitted exactly in Legendre polynomials of order 2
    /// on a 3³ grid.
    fn exact_fit() -> Fit {
        let y = |x: &[f64]| 1.0 + 2.0 * x[0] + x[0] * x[1] + 0.5 * x[2] * x[2];
        let levels = [-1.0, 0.0, 1.0];
        let mut points = Vec::new();
        for a in levels {
            for b in levels {
                for c in levels {
                    points.push(vec![a, b, c]);
                }
            }
        }
        let responses: Vec<f64> = points.iter().map(|p| y(p)).collect();
        let names: Vec<String> = ["a", "b", "c"].iter().map(|s| s.to_string()).collect();
        Fit::new(
            Basis::complete(BasisKind::Legendre, 3, 2),
            &names,
            &points,
            &responses,
        )
        .unwrap()
    }

    #[test]
    fn legendre_indices_of_an_exact_polynomial_are_its_closed_form_indices() {
        // x ~ U(−1, 1): Var x = 1/3, Var x² = 1/5 − 1/9 = 4/45, Var x1 x2 = 1/9, and the
        // three parts are uncorrelated: V = 4/3 + 1/9 + 1/45 = 66/45.
        // S = (60, 0, 1)/66, ST = (65, 5, 1)/66.
        let (first, total) = legendre_sobol(&exact_fit()).unwrap();
        let expected_first = [60.0 / 66.0, 0.0, 1.0 / 66.0];
        let expected_total = [65.0 / 66.0, 5.0 / 66.0, 1.0 / 66.0];
        for i in 0..3 {
            assert!((first[i] - expected_first[i]).abs() < 1e-12, "{first:?}");
            assert!((total[i] - expected_total[i]).abs() < 1e-12, "{total:?}");
        }
    }

    #[test]
    fn legendre_indices_agree_with_monte_carlo_on_the_same_surface() {
        let fit = exact_fit();
        let (first, total) = legendre_sobol(&fit).unwrap();
        let predict = |x: &[f64]| fit.predict(x);
        let indices = sobol_indices(&predict, &[uniform(-1.0, 1.0); 3], 100_000, 11).unwrap();
        assert!((indices.variance - 66.0 / 45.0).abs() / (66.0 / 45.0) < 0.03);
        for i in 0..3 {
            check(
                &format!("S{}", i + 1),
                indices.first[i],
                first[i],
                0.02,
                0.01,
            );
            check(
                &format!("ST{}", i + 1),
                indices.total[i],
                total[i],
                0.02,
                0.01,
            );
        }
    }

    #[test]
    fn legendre_indices_need_a_legendre_basis_and_a_varying_surface() {
        let x: Vec<Vec<f64>> = (0..5).map(|i| vec![-1.0 + 0.5 * i as f64]).collect();
        let names = ["a".to_string()];
        let monomial = Fit::new(
            Basis::complete(BasisKind::Monomial, 1, 1),
            &names,
            &x,
            &[1.0, 2.0, 3.0, 4.0, 5.0],
        )
        .unwrap();
        assert_eq!(legendre_sobol(&monomial), None);
        let flat = Fit::new(
            Basis::complete(BasisKind::Legendre, 1, 1),
            &names,
            &x,
            &[2.0; 5],
        )
        .unwrap();
        assert_eq!(legendre_sobol(&flat), None);
    }

    #[test]
    fn bad_requests_say_what_to_do() {
        let u = uniform(0.0, 1.0);
        let f = |x: &[f64]| x[0];
        assert_eq!(
            sobol_indices(&f, &[], 100, 0).unwrap_err().to_string(),
            "no inputs: give a distribution for at least one input"
        );
        assert_eq!(
            sobol_indices(&f, &[u], 5, 0).unwrap_err().to_string(),
            "5 base samples are too few; use at least 10 (10^4 or more for indices to two digits)"
        );
        assert_eq!(
            sobol_indices(&f, &[uniform(1.0, 1.0)], 100, 0)
                .unwrap_err()
                .to_string(),
            "input 0: high - low must be positive and finite, got 0"
        );
        assert!(matches!(
            sobol_indices(&|x: &[f64]| x[0].ln() - 1.0, &[uniform(-1.0, 1.0)], 100, 0),
            Err(SobolError::NotFinite { .. })
        ));
        assert!(matches!(
            sobol_indices(&|_: &[f64]| 4.0, &[u, u], 100, 0),
            Err(SobolError::NoVariance { .. })
        ));
    }
}
