//! Kriging (Gaussian-process regression) surrogates over coded factors.
//!
//! # Model
//!
//! A response observed at coded points `x_i ∈ [-1, 1]^k` is modelled as
//! `y_i = f(x_i)ᵀβ + Z(x_i) + ε_i`: a trend of known regressors `f` (a constant, or a
//! constant and the factors) with unknown coefficients `β`, a zero-mean stationary
//! Gaussian process `Z` of variance `σ²` and correlation `R(x, x')`, and independent
//! noise `ε_i` of variance `τ²` (the *nugget*). This is *universal kriging*
//! (Rasmussen & Williams 2006, §2.7; Santner, Williams & Notz 2003, ch. 3).
//!
//! The correlation is anisotropic: with `h² = Σ_j ((x_j − x'_j) / ℓ_j)²`,
//! - squared exponential: `R = exp(−h²/2)` (infinitely smooth surfaces);
//! - Matérn 5/2: `R = (1 + √5 h + 5h²/3) exp(−√5 h)` (twice differentiable surfaces;
//!   the usual default in computer experiments, better conditioned).
//!
//! Responses are standardised internally (mean 0, sample standard deviation 1) so the
//! hyperparameters' bounds and starting points do not depend on the response's units;
//! every number the API returns is in response units.
//!
//! # Estimation
//!
//! With `C = σ²K`, `K = R + g I` and `g = τ²/σ²`, the generalised least-squares
//! coefficients `β̂ = (FᵀK⁻¹F)⁻¹FᵀK⁻¹y` and (when `g` is a free ratio) `σ̂² = Q/n` with
//! `Q = (y − Fβ̂)ᵀK⁻¹(y − Fβ̂)` are closed form, leaving the *concentrated* (profile)
//! log-likelihood `−½ [n ln σ̂² + ln|K| + n + n ln 2π]` to be maximised over the log
//! length scales (and `ln g` when the nugget is fitted). When the noise variance `τ²`
//! is given (fixed, or pooled from replicates) the ratio `g` depends on `σ²`, so
//! `ln σ²` joins the searched parameters and the full likelihood
//! `−½ [n ln σ² + ln|K| + Q/σ² + n ln 2π]` is maximised instead (R&W §5.4.1).
//!
//! The search is a bounded quasi-Newton (projected BFGS) in log space with the
//! likelihood's analytic gradient ([`crate::kriging_search`]), from several starts (the
//! first at a default, the rest from a seeded Latin hypercube over a central part of the
//! box), every start run to convergence, in parallel; the best wins. Log length scales
//! are bounded to `[10⁻², 10²]` coded units.
//!
//! # Prediction
//!
//! The posterior mean is `f(x)ᵀβ̂ + r(x)ᵀK⁻¹(y − Fβ̂)`, with `r` the correlations to
//! the runs. The posterior variance of the latent (noise-free) surface includes the
//! uncertainty of `β̂` (the universal-kriging term):
//! `σ² [1 − rᵀK⁻¹r + uᵀ(FᵀK⁻¹F)⁻¹u]`, `u = f(x) − FᵀK⁻¹r` (R&W eq. 2.42).
//!
//! # Leave-one-out
//!
//! With hyperparameters held fixed, the leave-one-out residuals follow without refitting
//! from the inverse of the augmented (bordered) kriging system (Dubrule 1983; R&W
//! §5.4.2 for the known-mean case): its top-left block is
//! `P = K⁻¹ − K⁻¹F(FᵀK⁻¹F)⁻¹FᵀK⁻¹`, and `y_i − ŷ_{−i} = (P y)_i / P_ii` with variance
//! `σ² / P_ii`. The trend is re-estimated without run `i`, exactly.
//!
//! # Conditioning
//!
//! `K` is factored by Cholesky. When that fails, or the factor's diagonal shows a
//! condition number above 10¹³, a *jitter* (an extra noise ratio) is added to the
//! diagonal, starting at 10⁻¹² and growing tenfold up to 10⁻⁶; beyond that the fit is
//! refused with [`KrigingError::IllConditioned`]. The jitter used is recorded.
//!
//! References: C. E. Rasmussen and C. K. I. Williams, *Gaussian Processes for Machine
//! Learning*, MIT Press, 2006. O. Dubrule, "Cross validation of kriging in a unique
//! neighborhood", *Mathematical Geology* 15 (1983) 687–699. D. R. Jones, M. Schonlau and
//! W. J. Welch, "Efficient global optimization of expensive black-box functions",
//! *J. Global Optimization* 13 (1998) 455–492.

use nalgebra::{Cholesky, DMatrix, DVector, Dyn};
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use crate::kriging_search::{bounded_bfgs, Likelihood};

/// The correlation function of the Gaussian process.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kernel {
    /// Matérn with smoothness 5/2: surfaces twice differentiable. The default.
    Matern52,
    /// Squared exponential (Gaussian): infinitely smooth surfaces.
    SquaredExponential,
}

impl Kernel {
    /// Correlation at scaled squared distance `h² = Σ_j ((x_j − x'_j) / ℓ_j)²`.
    #[inline]
    pub fn correlation(self, scaled_distance_squared: f64) -> f64 {
        match self {
            Kernel::SquaredExponential => (-0.5 * scaled_distance_squared).exp(),
            Kernel::Matern52 => {
                let s = (5.0 * scaled_distance_squared).sqrt();
                (1.0 + s + s * s / 3.0) * (-s).exp()
            }
        }
    }
}

/// The regression trend under the Gaussian process.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Trend {
    /// An unknown constant (ordinary kriging).
    Constant,
    /// A constant plus one coefficient per factor (universal kriging).
    Linear,
}

impl Trend {
    /// Number of trend coefficients for `n_factors` factors.
    pub fn n_terms(self, n_factors: usize) -> usize {
        match self {
            Trend::Constant => 1,
            Trend::Linear => 1 + n_factors,
        }
    }

    /// Writes the regressors at `x` into `out` (length [`Trend::n_terms`]).
    fn row_into(self, x: &[f64], out: &mut [f64]) {
        out[0] = 1.0;
        if self == Trend::Linear {
            out[1..].copy_from_slice(x);
        }
    }
}

/// How the noise variance (nugget) is chosen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Nugget {
    /// Fitted by maximum likelihood as a ratio to the process variance, bounded below
    /// by 10⁻¹⁴ and above by 10². The floor is that low on purpose: a smooth,
    /// noise-free response sampled densely (100 runs in two factors) wants long
    /// length scales and almost no nugget, and a floor of 10⁻¹⁰ cost Branin at 100 runs
    /// 140 log-likelihood units and a factor 9 in held-out error.
    Fitted,
    /// A given noise variance, in response units²; 0 makes the surface interpolate.
    Fixed(f64),
    /// The pure-error variance pooled from replicated runs (identical coded points),
    /// held fixed; [`Nugget::Fitted`] when no point is replicated. See
    /// [`pure_error_variance`].
    FromReplicates,
}

/// Choices for [`Kriging::fit`].
#[derive(Debug, Clone, PartialEq)]
pub struct KrigingOptions {
    /// Correlation function.
    pub kernel: Kernel,
    /// Regression trend.
    pub trend: Trend,
    /// Noise variance.
    pub nugget: Nugget,
    /// Starts of the likelihood search (at least 1 is used).
    pub starts: usize,
    /// Seed of the starts' generator; the same seed gives the same fit.
    pub seed: u64,
    /// Length scales (coded units, one per factor) of an earlier fit of the same
    /// response, such as the previous round's: tried as one more start, since the
    /// likelihood of a few more runs is usually highest near where it was.
    pub previous_length_scales: Option<Vec<f64>>,
}

impl Default for KrigingOptions {
    /// Matérn 5/2, constant trend, nugget from replicates, 8 starts, seed 0.
    fn default() -> KrigingOptions {
        KrigingOptions {
            kernel: Kernel::Matern52,
            trend: Trend::Constant,
            nugget: Nugget::FromReplicates,
            starts: 8,
            seed: 0,
            previous_length_scales: None,
        }
    }
}

/// Why a Kriging model cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum KrigingError {
    /// Too few runs for the trend and a process variance.
    #[error("{runs} runs cannot fit a Kriging model with {trend_terms} trend terms; it needs at least {needed}: add runs or use Trend::Constant")]
    TooFewRuns {
        /// Runs given.
        runs: usize,
        /// Trend coefficients.
        trend_terms: usize,
        /// Runs needed.
        needed: usize,
    },
    /// Points and responses do not match in number.
    #[error("{points} points but {responses} responses; give one response per point")]
    Mismatch {
        /// Number of points.
        points: usize,
        /// Number of responses.
        responses: usize,
    },
    /// A point has the wrong number of coordinates, or there are no factors.
    #[error("point {index} has {found} coordinates, expected {expected} (at least 1); give every point one coded value per factor")]
    Dimensions {
        /// Index of the point.
        index: usize,
        /// Coordinates expected.
        expected: usize,
        /// Coordinates found.
        found: usize,
    },
    /// A response or coordinate is NaN or infinite.
    #[error("{what} of run {index} is not a finite number ({value}); remove the run or repair its value")]
    NotFinite {
        /// Index of the run.
        index: usize,
        /// Which value: "response" or "coordinate j".
        what: String,
        /// The value.
        value: f64,
    },
    /// All responses are equal, so there is nothing for a process to explain.
    #[error("all {runs} responses equal {value}; a surrogate adds nothing, use the constant")]
    ConstantResponse {
        /// Runs.
        runs: usize,
        /// The common value.
        value: f64,
    },
    /// A given hyperparameter is out of range.
    #[error("{name} = {value} is invalid: {expected}")]
    BadHyperparameter {
        /// Which hyperparameter.
        name: &'static str,
        /// Its value.
        value: f64,
        /// What it must be.
        expected: &'static str,
    },
    /// The points cannot estimate the trend (a factor does not vary).
    #[error("the points cannot estimate the {trend:?} trend (some factor does not vary across the runs); use Trend::Constant or vary every factor")]
    TrendNotEstimable {
        /// The trend.
        trend: Trend,
    },
    /// The correlation matrix stays singular even with the largest jitter.
    #[error("the correlation matrix is ill-conditioned (condition number at least {condition_estimate:.3e}) even with a jitter of {jitter:e}; use a nugget (Nugget::Fitted or Nugget::Fixed), remove duplicate or nearly coincident points, or shorten the length scales")]
    IllConditioned {
        /// Lower bound on the 2-norm condition number from the last Cholesky factor,
        /// `(max L_ii / min L_ii)²`; infinite when the factorisation broke down.
        condition_estimate: f64,
        /// The largest jitter tried, as a ratio to the process variance.
        jitter: f64,
    },
}

/// A fitted Kriging surrogate over coded factors. All values it returns are in
/// response units.
#[derive(Debug, Clone)]
pub struct Kriging {
    kernel: Kernel,
    trend: Trend,
    n_factors: usize,
    /// Coded points, row-major `n × k`.
    points: Vec<f64>,
    /// Coded points divided by the length scales, row-major.
    scaled_points: Vec<f64>,
    responses: Vec<f64>,
    length_scales: Vec<f64>,
    inverse_length_scales: Vec<f64>,
    y_std: f64,
    /// Process variance, standardised units.
    process_variance: f64,
    /// Noise variance, standardised units.
    noise_variance: f64,
    /// Whether the trend's last regressor is a covariate given at prediction.
    has_covariate: bool,
    jitter: f64,
    factor: Factor,
    /// Trend coefficients in response units (intercept includes the mean).
    trend_coefficients: Vec<f64>,
    /// `K⁻¹(y − Fβ̂)` in response units.
    weights: Vec<f64>,
    log_likelihood: f64,
}

/// The factored kriging system for one set of hyperparameters (standardised units).
#[derive(Debug, Clone)]
pub(crate) struct Factor {
    /// Lower Cholesky factor of `K = R + (g + jitter) I`.
    pub(crate) l: DMatrix<f64>,
    /// Jitter added to the diagonal (ratio to the process variance).
    jitter: f64,
    /// `L⁻¹F`.
    whitened_trend: DMatrix<f64>,
    /// Cholesky of `FᵀK⁻¹F`.
    trend_gram: Cholesky<f64, Dyn>,
    /// GLS trend coefficients.
    beta: DVector<f64>,
    /// `L⁻¹(y − Fβ̂)`.
    pub(crate) whitened_residual: DVector<f64>,
    /// `ln |K|`.
    log_det: f64,
}

impl Factor {
    /// `Q = (y − Fβ̂)ᵀK⁻¹(y − Fβ̂)`.
    pub(crate) fn quadratic_form(&self) -> f64 {
        self.whitened_residual.norm_squared()
    }
}

/// Diagonal-ratio condition estimate above which a factor is refused.
const MAX_CONDITION: f64 = 1e13;
/// First jitter tried.
const FIRST_JITTER: f64 = 1e-12;
/// Largest jitter tried.
const MAX_JITTER: f64 = 1e-6;
/// Bounds of the length scales, coded units.
const LENGTH_SCALE_BOUNDS: (f64, f64) = (1e-2, 1e2);
/// Bounds of a fitted noise ratio `τ²/σ²`.
const NOISE_RATIO_BOUNDS: (f64, f64) = (1e-14, 1e2);
/// Bounds of the process variance when the noise variance is fixed, standardised units.
const PROCESS_VARIANCE_BOUNDS: (f64, f64) = (1e-6, 1e4);

/// The pooled pure-error variance of replicated runs and its degrees of freedom:
/// `Σ_groups Σ (y − ȳ_g)² / Σ_groups (n_g − 1)` over groups of identical coded points.
/// `None` when no point is replicated. In response units².
pub fn pure_error_variance(x: &[Vec<f64>], y: &[f64]) -> Option<(f64, usize)> {
    let mut order: Vec<usize> = (0..x.len().min(y.len())).collect();
    let compare = |a: &usize, b: &usize| {
        x[*a]
            .iter()
            .zip(&x[*b])
            .map(|(p, q)| p.total_cmp(q))
            .find(|o| o.is_ne())
            .unwrap_or(std::cmp::Ordering::Equal)
    };
    order.sort_by(compare);
    let (mut sum_squares, mut dof) = (0.0, 0usize);
    let mut start = 0;
    while start < order.len() {
        let mut end = start + 1;
        while end < order.len() && x[order[end]] == x[order[start]] {
            end += 1;
        }
        if end - start > 1 {
            let group = &order[start..end];
            let mean = group.iter().map(|&i| y[i]).sum::<f64>() / group.len() as f64;
            sum_squares += group.iter().map(|&i| (y[i] - mean).powi(2)).sum::<f64>();
            dof += group.len() - 1;
        }
        start = end;
    }
    (dof > 0).then(|| (sum_squares / dof as f64, dof))
}

/// Checks points and responses; returns the number of factors.
fn validate(
    x: &[Vec<f64>],
    y: &[f64],
    trend: Trend,
    extra_terms: usize,
) -> Result<usize, KrigingError> {
    if x.len() != y.len() {
        return Err(KrigingError::Mismatch {
            points: x.len(),
            responses: y.len(),
        });
    }
    let k = x.first().map_or(0, Vec::len);
    for (index, point) in x.iter().enumerate() {
        if point.len() != k || k == 0 {
            return Err(KrigingError::Dimensions {
                index,
                expected: k,
                found: point.len(),
            });
        }
        if let Some((j, &value)) = point.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(KrigingError::NotFinite {
                index,
                what: format!("coordinate {j}"),
                value,
            });
        }
    }
    if let Some((index, &value)) = y.iter().enumerate().find(|(_, v)| !v.is_finite()) {
        return Err(KrigingError::NotFinite {
            index,
            what: "response".to_string(),
            value,
        });
    }
    let p = trend.n_terms(k) + extra_terms;
    if x.len() < p + 1 {
        return Err(KrigingError::TooFewRuns {
            runs: x.len(),
            trend_terms: p,
            needed: p + 1,
        });
    }
    Ok(k)
}

/// A covariate, when given, has one value per response.
fn check_covariate(covariate: Option<&[f64]>, y: &[f64]) -> Result<(), KrigingError> {
    match covariate {
        Some(c) if c.len() != y.len() => Err(KrigingError::Mismatch {
            points: c.len(),
            responses: y.len(),
        }),
        _ => Ok(()),
    }
}

/// Mean and sample standard deviation.
fn mean_and_std(y: &[f64]) -> (f64, f64) {
    let n = y.len() as f64;
    let mean = y.iter().sum::<f64>() / n;
    let var = y.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
    (mean, var.sqrt())
}

/// Cholesky factor of `k` with the smallest jitter (from none, then 10⁻¹² growing
/// tenfold) that factors it with a condition estimate below [`MAX_CONDITION`].
fn cholesky_with_jitter(k: &DMatrix<f64>) -> Result<(DMatrix<f64>, f64), KrigingError> {
    let n = k.nrows();
    let scale = (0..n).map(|i| k[(i, i)]).fold(0.0, f64::max);
    let mut jitter = 0.0;
    loop {
        let mut m = k.clone();
        if jitter > 0.0 {
            for i in 0..n {
                m[(i, i)] += jitter * scale;
            }
        }
        let estimate = match Cholesky::new(m) {
            Some(c) => {
                let l = c.unpack();
                let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
                for i in 0..n {
                    lo = lo.min(l[(i, i)]);
                    hi = hi.max(l[(i, i)]);
                }
                let estimate = (hi / lo).powi(2);
                if estimate.is_finite() && estimate <= MAX_CONDITION {
                    return Ok((l, jitter * scale));
                }
                estimate
            }
            None => f64::INFINITY,
        };
        let next = if jitter == 0.0 {
            FIRST_JITTER
        } else {
            jitter * 10.0
        };
        if next > MAX_JITTER * (1.0 + 1e-9) {
            return Err(KrigingError::IllConditioned {
                condition_estimate: estimate,
                jitter: jitter * scale,
            });
        }
        jitter = next;
    }
}

/// Builds and factors the kriging system for standardised responses `ys` at `points`
/// (row-major, `k` columns), given inverse length scales and the noise ratio `g`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn factorise(
    points: &[f64],
    k: usize,
    ys: &[f64],
    kernel: Kernel,
    trend: Trend,
    covariate: Option<&[f64]>,
    inverse_length_scales: &[f64],
    noise_ratio: f64,
) -> Result<Factor, KrigingError> {
    let n = ys.len();
    let mut kmat = DMatrix::<f64>::zeros(n, n);
    let scaled: Vec<f64> = points
        .chunks_exact(k)
        .flat_map(|p| p.iter().zip(inverse_length_scales).map(|(x, w)| x * w))
        .collect();
    for i in 0..n {
        let a = &scaled[i * k..(i + 1) * k];
        kmat[(i, i)] = 1.0 + noise_ratio;
        for j in 0..i {
            let b = &scaled[j * k..(j + 1) * k];
            let d2: f64 = a.iter().zip(b).map(|(p, q)| (p - q) * (p - q)).sum();
            let r = kernel.correlation(d2);
            kmat[(i, j)] = r;
            kmat[(j, i)] = r;
        }
    }
    let (l, jitter) = cholesky_with_jitter(&kmat)?;
    let p = trend.n_terms(k) + usize::from(covariate.is_some());
    let mut f = DMatrix::<f64>::zeros(n, p);
    let mut row = vec![0.0; p];
    for i in 0..n {
        regressors_into(
            trend,
            &points[i * k..(i + 1) * k],
            covariate.map(|c| c[i]),
            &mut row,
        );
        for (j, v) in row.iter().enumerate() {
            f[(i, j)] = *v;
        }
    }
    let whitened_trend = l
        .solve_lower_triangular(&f)
        .expect("the Cholesky factor has a positive diagonal");
    let whitened_y = l
        .solve_lower_triangular(&DVector::from_column_slice(ys))
        .expect("the Cholesky factor has a positive diagonal");
    let gram = whitened_trend.tr_mul(&whitened_trend);
    let trend_gram = Cholesky::new(gram).ok_or(KrigingError::TrendNotEstimable { trend })?;
    {
        let lg = trend_gram.l_dirty();
        let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
        for i in 0..p {
            lo = lo.min(lg[(i, i)]);
            hi = hi.max(lg[(i, i)]);
        }
        let estimate = (hi / lo).powi(2);
        if estimate.is_nan() || estimate >= 1e12 {
            return Err(KrigingError::TrendNotEstimable { trend });
        }
    }
    let beta = trend_gram.solve(&whitened_trend.tr_mul(&whitened_y));
    let whitened_residual = whitened_y - &whitened_trend * &beta;
    let log_det = 2.0 * (0..n).map(|i| l[(i, i)].ln()).sum::<f64>();
    Ok(Factor {
        l,
        jitter,
        whitened_trend,
        trend_gram,
        beta,
        whitened_residual,
        log_det,
    })
}

/// The regressors at `x`: the trend's, then the covariate's value when there is one
/// (`out` has room for both).
fn regressors_into(trend: Trend, x: &[f64], covariate: Option<f64>, out: &mut [f64]) {
    let p = trend.n_terms(x.len());
    trend.row_into(x, &mut out[..p]);
    if let Some(c) = covariate {
        out[p] = c;
    }
}

/// `−ln L` (standardised units) for process variance `s2` and the factor of
/// `K = R + (τ²/s2) I`.
pub(crate) fn negative_log_likelihood(factor: &Factor, n: usize, s2: f64) -> f64 {
    let n = n as f64;
    0.5 * (n * s2.ln()
        + factor.log_det
        + factor.quadratic_form() / s2
        + n * (2.0 * std::f64::consts::PI).ln())
}

/// What the likelihood search varies besides the log length scales.
#[derive(Debug, Clone, Copy)]
pub(crate) enum NoiseSearch {
    /// The noise ratio `g` is fixed (0 for an interpolating fit); σ² concentrated out.
    FixedRatio(f64),
    /// `ln g` is searched; σ² concentrated out.
    FittedRatio,
    /// The noise variance (standardised) is fixed; `ln σ²` is searched.
    FixedVariance(f64),
}

impl Kriging {
    /// Fits a Kriging model to responses `y` at coded points `x`, estimating the
    /// length scales (and the noise ratio or process variance, see [`Nugget`]) by
    /// maximum likelihood from `options.starts` seeded starts.
    pub fn fit(
        x: &[Vec<f64>],
        y: &[f64],
        options: &KrigingOptions,
    ) -> Result<Kriging, KrigingError> {
        Kriging::fit_with_covariate(x, y, None, options)
    }

    /// [`Kriging::fit`] with one more regressor in the trend, `covariate[i]` at run
    /// `i`: a lower fidelity's prediction in co-Kriging ([`crate::co_kriging`]). Its
    /// coefficient is the last trend coefficient, and the model must then be asked
    /// with [`Kriging::predict_given`] and [`Kriging::predict_variance_given`].
    pub(crate) fn fit_with_covariate(
        x: &[Vec<f64>],
        y: &[f64],
        covariate: Option<&[f64]>,
        options: &KrigingOptions,
    ) -> Result<Kriging, KrigingError> {
        let k = validate(x, y, options.trend, usize::from(covariate.is_some()))?;
        check_covariate(covariate, y)?;
        let n = y.len();
        let (y_mean, y_std) = mean_and_std(y);
        if y_std <= 0.0 {
            return Err(KrigingError::ConstantResponse {
                runs: n,
                value: y[0],
            });
        }
        let ys: Vec<f64> = y.iter().map(|v| (v - y_mean) / y_std).collect();
        let points: Vec<f64> = x.iter().flatten().copied().collect();
        let search = match options.nugget {
            Nugget::Fixed(v) => fixed_noise(v, y_std)?,
            Nugget::Fitted => NoiseSearch::FittedRatio,
            Nugget::FromReplicates => match pure_error_variance(x, y) {
                Some((v, _)) => fixed_noise(v, y_std)?,
                None => NoiseSearch::FittedRatio,
            },
        };
        let (kernel, trend) = (options.kernel, options.trend);

        // Parameters: ln ℓ_1..ln ℓ_k, then ln g or ln σ² when searched.
        let mut lower = vec![LENGTH_SCALE_BOUNDS.0.ln(); k];
        let mut upper = vec![LENGTH_SCALE_BOUNDS.1.ln(); k];
        let mut start_lower = vec![0.1f64.ln(); k];
        let mut start_upper = vec![3.0f64.ln(); k];
        let mut default_start = vec![0.5f64.ln(); k];
        match search {
            NoiseSearch::FixedRatio(_) => {}
            NoiseSearch::FittedRatio => {
                lower.push(NOISE_RATIO_BOUNDS.0.ln());
                upper.push(NOISE_RATIO_BOUNDS.1.ln());
                start_lower.push(1e-8f64.ln());
                start_upper.push(1e-1f64.ln());
                default_start.push(1e-4f64.ln());
            }
            NoiseSearch::FixedVariance(tau2) => {
                lower.push(PROCESS_VARIANCE_BOUNDS.0.ln());
                upper.push(PROCESS_VARIANCE_BOUNDS.1.ln());
                start_lower.push(0.1f64.ln());
                start_upper.push(3.0f64.ln());
                default_start.push((1.0 - tau2).max(0.1).ln());
            }
        }
        let likelihood = Likelihood {
            points: &points,
            k,
            ys: &ys,
            kernel,
            trend,
            covariate,
            search,
        };
        let mut starts = start_points(
            &default_start,
            &start_lower,
            &start_upper,
            options.starts.max(1),
            options.seed,
        );
        if let Some(previous) = options
            .previous_length_scales
            .as_ref()
            .filter(|l| l.len() == k && l.iter().all(|v| v.is_finite() && *v > 0.0))
        {
            let mut start: Vec<f64> = previous.iter().map(|l| l.ln()).collect();
            start.extend_from_slice(&default_start[k..]);
            starts.push(start);
        }
        let best = multistart_bfgs(&likelihood, &starts, &lower, &upper);

        let inverse: Vec<f64> = best[..k].iter().map(|t| (-t).exp()).collect();
        let (ratio, fixed_s2) = match search {
            NoiseSearch::FixedRatio(g) => (g, None),
            NoiseSearch::FittedRatio => (best[k].exp(), None),
            NoiseSearch::FixedVariance(tau2) => {
                let s2 = best[k].exp();
                (tau2 / s2, Some(s2))
            }
        };
        let factor = factorise(&points, k, &ys, kernel, trend, covariate, &inverse, ratio)?;
        let s2 = fixed_s2.unwrap_or_else(|| factor.quadratic_form() / n as f64);
        if s2.is_nan() || s2 <= 0.0 {
            return Err(KrigingError::ConstantResponse {
                runs: n,
                value: y[0],
            });
        }
        let mut model = Kriging::assemble(
            kernel,
            trend,
            k,
            points,
            y.to_vec(),
            inverse,
            (y_mean, y_std),
            s2,
            ratio * s2,
            factor,
        );
        model.has_covariate = covariate.is_some();
        Ok(model)
    }

    /// Builds a Kriging model with given hyperparameters, nothing estimated but the
    /// trend coefficients (by GLS): `length_scales` in coded units (one per factor),
    /// `process_variance` σ² and `noise_variance` τ² in response units². Used to refit
    /// on changed data without re-estimating (leave-one-out by brute force, a
    /// kriging-believer batch).
    pub fn with_hyperparameters(
        x: &[Vec<f64>],
        y: &[f64],
        kernel: Kernel,
        trend: Trend,
        length_scales: &[f64],
        process_variance: f64,
        noise_variance: f64,
    ) -> Result<Kriging, KrigingError> {
        Kriging::with_hyperparameters_given(
            x,
            y,
            None,
            kernel,
            trend,
            length_scales,
            process_variance,
            noise_variance,
        )
    }

    /// [`Kriging::with_hyperparameters`] with a covariate in the trend, as
    /// [`Kriging::fit_with_covariate`] has.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn with_hyperparameters_given(
        x: &[Vec<f64>],
        y: &[f64],
        covariate: Option<&[f64]>,
        kernel: Kernel,
        trend: Trend,
        length_scales: &[f64],
        process_variance: f64,
        noise_variance: f64,
    ) -> Result<Kriging, KrigingError> {
        let k = validate(x, y, trend, usize::from(covariate.is_some()))?;
        check_covariate(covariate, y)?;
        if length_scales.len() != k {
            return Err(KrigingError::BadHyperparameter {
                name: "number of length scales",
                value: length_scales.len() as f64,
                expected: "one length scale per factor",
            });
        }
        if let Some(&value) = length_scales.iter().find(|l| !(l.is_finite() && **l > 0.0)) {
            return Err(KrigingError::BadHyperparameter {
                name: "length scale",
                value,
                expected: "a finite positive number of coded units",
            });
        }
        if !(process_variance.is_finite() && process_variance > 0.0) {
            return Err(KrigingError::BadHyperparameter {
                name: "process variance",
                value: process_variance,
                expected: "a finite positive variance in response units²",
            });
        }
        if !(noise_variance.is_finite() && noise_variance >= 0.0) {
            return Err(KrigingError::BadHyperparameter {
                name: "noise variance",
                value: noise_variance,
                expected: "a finite variance ≥ 0 in response units²",
            });
        }
        let (y_mean, mut y_std) = mean_and_std(y);
        if y_std <= 0.0 {
            y_std = 1.0;
        }
        let ys: Vec<f64> = y.iter().map(|v| (v - y_mean) / y_std).collect();
        let points: Vec<f64> = x.iter().flatten().copied().collect();
        let inverse: Vec<f64> = length_scales.iter().map(|l| 1.0 / l).collect();
        let s2 = process_variance / (y_std * y_std);
        let tau2 = noise_variance / (y_std * y_std);
        let factor = factorise(
            &points,
            k,
            &ys,
            kernel,
            trend,
            covariate,
            &inverse,
            tau2 / s2,
        )?;
        let mut model = Kriging::assemble(
            kernel,
            trend,
            k,
            points,
            y.to_vec(),
            inverse,
            (y_mean, y_std),
            s2,
            tau2,
            factor,
        );
        model.has_covariate = covariate.is_some();
        Ok(model)
    }

    /// This model's kernel, trend and hyperparameters on other data: see
    /// [`Kriging::with_hyperparameters`].
    pub fn refit(&self, x: &[Vec<f64>], y: &[f64]) -> Result<Kriging, KrigingError> {
        Kriging::with_hyperparameters(
            x,
            y,
            self.kernel,
            self.trend,
            &self.length_scales,
            self.process_variance(),
            self.noise_variance(),
        )
    }

    #[allow(clippy::too_many_arguments)]
    fn assemble(
        kernel: Kernel,
        trend: Trend,
        k: usize,
        points: Vec<f64>,
        responses: Vec<f64>,
        inverse_length_scales: Vec<f64>,
        (y_mean, y_std): (f64, f64),
        s2: f64,
        tau2: f64,
        factor: Factor,
    ) -> Kriging {
        let n = responses.len();
        let alpha = factor
            .l
            .tr_solve_lower_triangular(&factor.whitened_residual)
            .expect("the Cholesky factor has a positive diagonal");
        let weights: Vec<f64> = alpha.iter().map(|a| a * y_std).collect();
        let mut trend_coefficients: Vec<f64> = factor.beta.iter().map(|b| b * y_std).collect();
        trend_coefficients[0] += y_mean;
        let scaled_points: Vec<f64> = points
            .chunks_exact(k)
            .flat_map(|p| p.iter().zip(&inverse_length_scales).map(|(x, w)| x * w))
            .collect();
        let log_likelihood = -negative_log_likelihood(&factor, n, s2) - n as f64 * y_std.ln();
        Kriging {
            kernel,
            trend,
            n_factors: k,
            points,
            scaled_points,
            responses,
            length_scales: inverse_length_scales.iter().map(|w| 1.0 / w).collect(),
            inverse_length_scales,
            y_std,
            process_variance: s2,
            noise_variance: tau2,
            has_covariate: false,
            jitter: factor.jitter,
            factor,
            trend_coefficients,
            weights,
            log_likelihood,
        }
    }

    /// Posterior mean at coded point `x`, in response units. Allocates nothing.
    pub fn predict(&self, x: &[f64]) -> f64 {
        self.predict_given(x, None)
    }

    /// Posterior mean at coded point `x` where the trend's covariate (if the model has
    /// one) takes the value `covariate`.
    pub(crate) fn predict_given(&self, x: &[f64], covariate: Option<f64>) -> f64 {
        debug_assert_eq!(covariate.is_some(), self.has_covariate);
        let k = self.n_factors;
        let mut value = self.trend_coefficients[0];
        if self.trend == Trend::Linear {
            value += self.trend_coefficients[1..=k]
                .iter()
                .zip(x)
                .map(|(b, v)| b * v)
                .sum::<f64>();
        }
        if let Some(c) = covariate {
            value += self.trend_coefficients[self.trend_coefficients.len() - 1] * c;
        }
        let w = &self.inverse_length_scales;
        let sum: f64 = self
            .scaled_points
            .chunks_exact(k)
            .zip(&self.weights)
            .map(|(p, a)| {
                let d2: f64 = (0..k).map(|j| (x[j] * w[j] - p[j]).powi(2)).sum();
                a * self.kernel.correlation(d2)
            })
            .sum();
        value + sum
    }

    /// Posterior variance of the latent (noise-free) surface at coded point `x`, in
    /// response units², including the trend coefficients' estimation uncertainty
    /// (hyperparameters taken as known); never negative.
    pub fn predict_variance(&self, x: &[f64]) -> f64 {
        self.predict_variance_given(x, None)
    }

    /// [`Kriging::predict_variance`] where the trend's covariate takes the value
    /// `covariate`.
    pub(crate) fn predict_variance_given(&self, x: &[f64], covariate: Option<f64>) -> f64 {
        debug_assert_eq!(covariate.is_some(), self.has_covariate);
        let k = self.n_factors;
        let w = &self.inverse_length_scales;
        let mut r = DVector::from_iterator(
            self.responses.len(),
            self.scaled_points.chunks_exact(k).map(|p| {
                let d2: f64 = (0..k).map(|j| (x[j] * w[j] - p[j]).powi(2)).sum();
                self.kernel.correlation(d2)
            }),
        );
        self.factor.l.solve_lower_triangular_mut(&mut r);
        let explained = r.norm_squared();
        let p = self.trend.n_terms(k) + usize::from(covariate.is_some());
        let mut f = vec![0.0; p];
        regressors_into(self.trend, x, covariate, &mut f);
        let u = DVector::from_vec(f) - self.factor.whitened_trend.tr_mul(&r);
        let trend_term = u.dot(&self.factor.trend_gram.solve(&u));
        let variance = self.process_variance * (1.0 - explained + trend_term);
        (variance * self.y_std * self.y_std).max(0.0)
    }

    /// Noise (nugget) variance τ² in response units², excluding any jitter.
    pub fn noise_variance(&self) -> f64 {
        self.noise_variance * self.y_std * self.y_std
    }

    /// Process variance σ² in response units².
    pub fn process_variance(&self) -> f64 {
        self.process_variance * self.y_std * self.y_std
    }

    /// Length scales ℓ_j in coded units, one per factor.
    pub fn length_scales(&self) -> &[f64] {
        &self.length_scales
    }

    /// Jitter added to the correlation matrix's diagonal to factor it, as a ratio to
    /// the process variance (0 when none was needed).
    pub fn jitter(&self) -> f64 {
        self.jitter
    }

    /// The kernel.
    pub fn kernel(&self) -> Kernel {
        self.kernel
    }

    /// The trend.
    pub fn trend(&self) -> Trend {
        self.trend
    }

    /// Trend coefficients in response units (intercept first, then one per factor for
    /// a linear trend, then a co-Kriging level's covariate's).
    pub fn trend_coefficients(&self) -> &[f64] {
        &self.trend_coefficients
    }

    /// Log-likelihood of the responses (in their own units) at the hyperparameters,
    /// with the trend coefficients at their GLS estimate.
    pub fn log_likelihood(&self) -> f64 {
        self.log_likelihood
    }

    /// Number of runs.
    pub fn n_runs(&self) -> usize {
        self.responses.len()
    }

    /// Leave-one-out residuals `y_i − ŷ_{−i}` (response units) in closed form, with
    /// the hyperparameters held fixed and the trend re-estimated without each run.
    pub fn loo_residuals(&self) -> Vec<f64> {
        let (p_diag, _) = self.loo_diagonal();
        let alpha_std = self.weights.iter().map(|w| w / self.y_std);
        alpha_std
            .zip(&p_diag)
            .map(|(a, d)| self.y_std * a / d)
            .collect()
    }

    /// Variances of the leave-one-out residuals `y_i − ŷ_{−i}` (response units²):
    /// the predictive variance of observation `i` from the other runs, latent variance
    /// plus noise variance.
    pub fn loo_variances(&self) -> Vec<f64> {
        let (p_diag, _) = self.loo_diagonal();
        let scale = self.process_variance * self.y_std * self.y_std;
        p_diag.iter().map(|d| scale / d).collect()
    }

    /// Diagonal of `P = K⁻¹ − K⁻¹F(FᵀK⁻¹F)⁻¹FᵀK⁻¹` and `K⁻¹`'s diagonal.
    fn loo_diagonal(&self) -> (Vec<f64>, Vec<f64>) {
        let n = self.responses.len();
        let l = &self.factor.l;
        let l_inverse = l
            .solve_lower_triangular(&DMatrix::identity(n, n))
            .expect("the Cholesky factor has a positive diagonal");
        let k_inverse_diag: Vec<f64> = (0..n).map(|i| l_inverse.column(i).norm_squared()).collect();
        // K⁻¹F = L⁻ᵀ(L⁻¹F).
        let g = l
            .tr_solve_lower_triangular(&self.factor.whitened_trend)
            .expect("the Cholesky factor has a positive diagonal");
        let p_diag = (0..n)
            .map(|i| {
                let gi = g.row(i).transpose();
                k_inverse_diag[i] - gi.dot(&self.factor.trend_gram.solve(&gi))
            })
            .collect();
        (p_diag, k_inverse_diag)
    }

    /// Coded points of the runs, one `Vec` per run.
    pub fn points(&self) -> Vec<Vec<f64>> {
        self.points
            .chunks_exact(self.n_factors)
            .map(<[f64]>::to_vec)
            .collect()
    }

    /// Responses of the runs.
    pub fn responses(&self) -> &[f64] {
        &self.responses
    }
}

/// The search for a fixed noise variance `v` (response units²).
fn fixed_noise(v: f64, y_std: f64) -> Result<NoiseSearch, KrigingError> {
    if !(v.is_finite() && v >= 0.0) {
        return Err(KrigingError::BadHyperparameter {
            name: "noise variance",
            value: v,
            expected: "a finite variance ≥ 0 in response units²",
        });
    }
    Ok(if v == 0.0 {
        NoiseSearch::FixedRatio(0.0)
    } else {
        NoiseSearch::FixedVariance(v / (y_std * y_std))
    })
}

/// The starts of the likelihood search: `default_start`, then `starts − 1` points of
/// a seeded Latin hypercube in `[start_lower, start_upper]`.
fn start_points(
    default_start: &[f64],
    start_lower: &[f64],
    start_upper: &[f64],
    starts: usize,
    seed: u64,
) -> Vec<Vec<f64>> {
    let d = default_start.len();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut initial = vec![default_start.to_vec()];
    let others = starts - 1;
    if others > 0 {
        let columns: Vec<Vec<usize>> = (0..d)
            .map(|_| {
                let mut c: Vec<usize> = (0..others).collect();
                c.shuffle(&mut rng);
                c
            })
            .collect();
        initial.extend((0..others).map(|s| {
            (0..d)
                .map(|j| {
                    let u = (columns[j][s] as f64 + rng.random::<f64>()) / others as f64;
                    start_lower[j] + u * (start_upper[j] - start_lower[j])
                })
                .collect::<Vec<f64>>()
        }));
    }
    initial
}

/// The best of a bounded BFGS search of `likelihood` from every start, each run to
/// convergence (see [`crate::kriging_search`]). The starts run in parallel; the
/// result does not depend on the number of threads (ties go to the earlier start).
fn multistart_bfgs(
    likelihood: &Likelihood<'_>,
    starts: &[Vec<f64>],
    lower: &[f64],
    upper: &[f64],
) -> Vec<f64> {
    let f = |theta: &[f64], gradient: bool| likelihood.value_and_gradient(theta, gradient);
    let found: Vec<(Vec<f64>, f64)> = starts
        .par_iter()
        .map(|start| bounded_bfgs(&f, start, lower, upper, 200))
        .collect();
    found
        .into_iter()
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(x, _)| x)
        .expect("at least one start")
}

#[cfg(test)]
#[path = "kriging_tests.rs"]
mod tests;
