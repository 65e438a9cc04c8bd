//! Least-squares response surfaces and their quality (SCIENCE.md §5).
//!
//! The model matrix `X` (runs × terms) is factored once by a column-pivoted QR to
//! find its rank: a design that cannot separate two terms is refused, naming the
//! aliased terms. Then a thin QR `X = QR` gives the coefficients `β = R⁻¹Qᵀy`, the
//! leverages `h_ii = ‖Q_i‖²` (the hat matrix's diagonal), the leave-one-out residuals
//! `e_i / (1 − h_ii)` without refitting, and the coefficients' standard errors from
//! `(XᵀX)⁻¹ = R⁻¹R⁻ᵀ`.
//!
//! `(XᵀX)⁻¹` is kept in the fit, so that the variance of the fitted surface at a new point
//! `x₀` (row `x₀` of the model matrix) is `s² x₀ᵀ(XᵀX)⁻¹x₀`. With `t = t_{(1+c)/2, n−p}`,
//! the two-sided `c` interval is
//!
//! - for the mean response at `x₀` (a confidence interval): `ŷ₀ ± t s √(x₀ᵀ(XᵀX)⁻¹x₀)`;
//! - for one new observation at `x₀` (a prediction interval): `ŷ₀ ± t s √(1 + x₀ᵀ(XᵀX)⁻¹x₀)`,
//!
//! as in Montgomery, Peck & Vining, *Introduction to Linear Regression Analysis*, 5th ed.,
//! Wiley 2012, §3.4–3.5. Both assume independent, normal errors of one variance; a
//! deterministic simulation has no such errors, and there the intervals measure only how
//! far the surface misses the runs.

use nalgebra::{DMatrix, DVector};

use crate::basis::Basis;
use crate::student::student_t_quantile;

/// Why a surface cannot be fitted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FitError {
    /// Fewer runs than terms.
    #[error("{runs} runs cannot fit {terms} terms; add runs or lower the order")]
    TooFewRuns {
        /// Runs.
        runs: usize,
        /// Terms.
        terms: usize,
    },
    /// The design cannot tell some terms apart.
    #[error("the design cannot separate the terms {}: they are aliased with others; use a design that varies them independently (e.g. a central composite) or drop them", aliased.join(", "))]
    RankDeficient {
        /// Names of the terms found dependent on the others.
        aliased: Vec<String>,
    },
    /// Points and responses do not match.
    #[error("{points} points but {responses} responses")]
    Mismatch {
        /// Number of points.
        points: usize,
        /// Number of responses.
        responses: usize,
    },
    /// A response is NaN or infinite.
    #[error("response {index} is not a finite number ({value})")]
    NotFinite {
        /// Index of the run.
        index: usize,
        /// Its value.
        value: f64,
    },
}

/// A fitted response surface over coded factors.
#[derive(Debug, Clone, PartialEq)]
pub struct Fit {
    /// The basis.
    pub basis: Basis,
    /// Term names.
    pub names: Vec<String>,
    /// One coefficient per term.
    pub coefficients: Vec<f64>,
    /// Coefficients' standard errors (when runs exceed terms).
    pub standard_errors: Option<Vec<f64>>,
    /// Coefficients divided by their standard errors.
    pub t_values: Option<Vec<f64>>,
    /// The quality of the fit on its own runs.
    pub quality: Quality,
    /// Residuals `y − ŷ` of the runs.
    pub residuals: Vec<f64>,
    /// Leverages (hat matrix diagonal) of the runs.
    pub leverages: Vec<f64>,
    /// `(XᵀX)⁻¹`, terms × terms, row-major, in the squared inverse units of the terms: the
    /// coefficients' covariance divided by the residual variance. Kept for the intervals of
    /// [`Fit::confidence_interval`] and [`Fit::prediction_interval`]; `None` when runs equal
    /// terms, as then there is no residual variance to scale it by.
    pub unscaled_covariance: Option<Vec<f64>>,
}

/// A two-sided interval around the fitted surface's value at one point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Interval {
    /// The surface's value `ŷ₀` at the point, in the response's units.
    pub estimate: f64,
    /// Standard error of `ŷ₀` (confidence interval) or of `y₀ − ŷ₀` (prediction
    /// interval), in the response's units.
    pub std_error: f64,
    /// Lower end, `ŷ₀ − t · std_error`.
    pub low: f64,
    /// Upper end, `ŷ₀ + t · std_error`.
    pub high: f64,
    /// Residual degrees of freedom `n − p` of the t quantile.
    pub degrees_of_freedom: f64,
}

/// Measures of a fit on the runs it was fitted to.
#[derive(Debug, Clone, PartialEq)]
pub struct Quality {
    /// Runs.
    pub runs: usize,
    /// Terms.
    pub terms: usize,
    /// ANOVA `R² = 1 − SS_res / SS_tot`.
    pub r2: f64,
    /// Adjusted `R²` (when runs exceed terms).
    pub adjusted_r2: Option<f64>,
    /// Residual standard deviation `sqrt(SS_res / (n − p))`.
    pub residual_std: Option<f64>,
    /// Leave-one-out residuals (when no run has leverage 1).
    pub loo_residuals: Option<Vec<f64>>,
    /// PRESS, the sum of squared leave-one-out residuals.
    pub press: Option<f64>,
    /// `σ_cross`: RMS of leave-one-out residuals over the responses' sample standard
    /// deviation, in %.
    pub sigma_cross_percent: Option<f64>,
    /// `R²` from `σ_cross` as SCIENCE.md defines it from σ: `1 − (σ_cross/100)²`.
    pub r2_cross: Option<f64>,
}

/// Quality on held-out test points.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TestQuality {
    /// `σ_test_rel`: RMS prediction error over the test responses' sample standard
    /// deviation, in %.
    pub sigma_test_rel_percent: f64,
    /// `R² = 1 − (σ_test_rel / 100)²`.
    pub r2: f64,
}

/// Leverage above this counts as 1: the run is fitted exactly and has no LOO residual.
const SATURATED_LEVERAGE: f64 = 1.0 - 1e-10;

/// Sample standard deviation (n − 1).
fn sample_std(values: &[f64]) -> f64 {
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
}

/// `σ_test_rel` and its `R²` of any surface `predict` on held-out points (coded `x`,
/// observed `y`); `None` with fewer than two test points or no spread among them.
pub fn test_quality(
    predict: &dyn Fn(&[f64]) -> f64,
    x: &[Vec<f64>],
    y: &[f64],
) -> Option<TestQuality> {
    if x.len() != y.len() || y.len() < 2 {
        return None;
    }
    let spread = sample_std(y);
    if spread <= 0.0 {
        return None;
    }
    let mse = x
        .iter()
        .zip(y)
        .map(|(p, v)| (predict(p) - v).powi(2))
        .sum::<f64>()
        / y.len() as f64;
    let sigma = 100.0 * mse.sqrt() / spread;
    Some(TestQuality {
        sigma_test_rel_percent: sigma,
        r2: 1.0 - (sigma / 100.0).powi(2),
    })
}

impl Fit {
    /// Fits `basis` to responses `y` at coded points `x`; `factor_names` name terms.
    pub fn new(
        basis: Basis,
        factor_names: &[String],
        x: &[Vec<f64>],
        y: &[f64],
    ) -> Result<Fit, FitError> {
        if x.len() != y.len() {
            return Err(FitError::Mismatch {
                points: x.len(),
                responses: y.len(),
            });
        }
        if let Some((index, &value)) = y.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(FitError::NotFinite { index, value });
        }
        let (n, p) = (x.len(), basis.len());
        if n < p {
            return Err(FitError::TooFewRuns { runs: n, terms: p });
        }
        let names = basis.names(factor_names);
        let rows: Vec<f64> = x.iter().flat_map(|point| basis.row(point)).collect();
        let matrix = DMatrix::from_row_slice(n, p, &rows);

        // Rank from a column-pivoted QR: |R_kk| falls below a tolerance after the rank.
        let pivoted = matrix.clone().col_piv_qr();
        let r_pivoted = pivoted.r();
        let largest = r_pivoted[(0, 0)].abs();
        let tolerance = largest * 1e-10 * (n.max(p) as f64);
        let rank = (0..p)
            .filter(|&k| r_pivoted[(k, k)].abs() > tolerance)
            .count();
        if rank < p {
            let mut order =
                DMatrix::from_row_slice(1, p, &(0..p).map(|i| i as f64).collect::<Vec<_>>());
            pivoted.p().permute_columns(&mut order);
            let aliased = (rank..p)
                .map(|k| names[order[(0, k)] as usize].clone())
                .collect();
            return Err(FitError::RankDeficient { aliased });
        }

        let qr = matrix.qr();
        let (q, r) = (qr.q(), qr.r());
        let y_vector = DVector::from_column_slice(y);
        let coefficients = r
            .solve_upper_triangular(&(q.transpose() * &y_vector))
            .expect("R is invertible at full rank");
        let fitted = q.clone() * (q.transpose() * &y_vector);
        let residuals: Vec<f64> = (0..n).map(|i| y[i] - fitted[i]).collect();
        let leverages: Vec<f64> = (0..n).map(|i| q.row(i).norm_squared()).collect();

        let mean = y.iter().sum::<f64>() / n as f64;
        let ss_tot: f64 = y.iter().map(|v| (v - mean).powi(2)).sum();
        let ss_res: f64 = residuals.iter().map(|e| e * e).sum();
        let r2 = if ss_tot > 0.0 {
            1.0 - ss_res / ss_tot
        } else {
            1.0
        };
        let dof = n - p;
        let residual_variance = (dof > 0).then(|| ss_res / dof as f64);
        let adjusted_r2 = (dof > 0 && ss_tot > 0.0)
            .then(|| 1.0 - (ss_res / dof as f64) / (ss_tot / (n - 1) as f64));

        let loo_residuals: Option<Vec<f64>> =
            leverages.iter().all(|&h| h < SATURATED_LEVERAGE).then(|| {
                residuals
                    .iter()
                    .zip(&leverages)
                    .map(|(e, h)| e / (1.0 - h))
                    .collect()
            });
        let press = loo_residuals
            .as_ref()
            .map(|l| l.iter().map(|e| e * e).sum::<f64>());
        let spread = if n > 1 { sample_std(y) } else { 0.0 };
        let sigma_cross_percent = press
            .filter(|_| spread > 0.0)
            .map(|press| 100.0 * (press / n as f64).sqrt() / spread);
        let r2_cross = sigma_cross_percent.map(|s| 1.0 - (s / 100.0).powi(2));

        let (standard_errors, t_values, unscaled_covariance) = match residual_variance {
            Some(variance) => {
                let r_inverse = r
                    .solve_upper_triangular(&DMatrix::identity(p, p))
                    .expect("R is invertible at full rank");
                // (XᵀX)⁻¹ = R⁻¹R⁻ᵀ; its diagonal is the squared row norms of R⁻¹.
                let covariance = &r_inverse * r_inverse.transpose();
                let errors: Vec<f64> = (0..p)
                    .map(|j| (variance * covariance[(j, j)].max(0.0)).sqrt())
                    .collect();
                let t = coefficients
                    .iter()
                    .zip(&errors)
                    .map(|(b, s)| {
                        if *s > 0.0 {
                            b / s
                        } else {
                            f64::INFINITY * b.signum()
                        }
                    })
                    .collect();
                let row_major = (0..p)
                    .flat_map(|i| (0..p).map(move |j| (i, j)))
                    .map(|(i, j)| covariance[(i, j)])
                    .collect();
                (Some(errors), Some(t), Some(row_major))
            }
            None => (None, None, None),
        };

        Ok(Fit {
            names,
            coefficients: coefficients.iter().copied().collect(),
            standard_errors,
            t_values,
            quality: Quality {
                runs: n,
                terms: p,
                r2,
                adjusted_r2,
                residual_std: residual_variance.map(f64::sqrt),
                loo_residuals,
                press,
                sigma_cross_percent,
                r2_cross,
            },
            residuals,
            leverages,
            unscaled_covariance,
            basis,
        })
    }

    /// The surface's value at coded point `x`.
    pub fn predict(&self, x: &[f64]) -> f64 {
        self.basis
            .row(x)
            .iter()
            .zip(&self.coefficients)
            .map(|(t, b)| t * b)
            .sum()
    }

    /// The two-sided `confidence` (e.g. 0.95) interval for the *mean* response at coded
    /// point `x`: `ŷ₀ ± t_{(1+c)/2, n−p} · s · √(x₀ᵀ(XᵀX)⁻¹x₀)`, where `x₀` is the basis
    /// evaluated at `x`. It says where the true surface lies, if the model's form is
    /// right. `None` when runs equal terms (no residual variance), when `confidence` is
    /// not inside (0, 1), or when `x` has the wrong number of factors or a non-finite
    /// coordinate.
    pub fn confidence_interval(&self, x: &[f64], confidence: f64) -> Option<Interval> {
        self.interval(x, confidence, 0.0)
    }

    /// The two-sided `confidence` (e.g. 0.95) interval for *one new observation* at coded
    /// point `x`: `ŷ₀ ± t_{(1+c)/2, n−p} · s · √(1 + x₀ᵀ(XᵀX)⁻¹x₀)`. It is wider than
    /// [`Fit::confidence_interval`] by the new run's own scatter, and is what a single
    /// further simulation at `x` is expected to land in. `None` in the same cases.
    pub fn prediction_interval(&self, x: &[f64], confidence: f64) -> Option<Interval> {
        self.interval(x, confidence, 1.0)
    }

    /// The interval with `extra` (0 or 1) residual variances added to the estimate's.
    fn interval(&self, x: &[f64], confidence: f64, extra: f64) -> Option<Interval> {
        if !(confidence > 0.0 && confidence < 1.0)
            || x.len() != self.basis.n_factors
            || x.iter().any(|v| !v.is_finite())
        {
            return None;
        }
        let covariance = self.unscaled_covariance.as_ref()?;
        let residual_std = self.quality.residual_std?;
        let row = self.basis.row(x);
        let p = row.len();
        let quadratic: f64 = (0..p)
            .map(|i| {
                let inner: f64 = (0..p).map(|j| covariance[i * p + j] * row[j]).sum();
                row[i] * inner
            })
            .sum();
        let std_error = residual_std * (quadratic.max(0.0) + extra).sqrt();
        let degrees_of_freedom = (self.quality.runs - self.quality.terms) as f64;
        let t = student_t_quantile(0.5 + 0.5 * confidence, degrees_of_freedom);
        let estimate: f64 = row.iter().zip(&self.coefficients).map(|(t, b)| t * b).sum();
        Some(Interval {
            estimate,
            std_error,
            low: estimate - t * std_error,
            high: estimate + t * std_error,
            degrees_of_freedom,
        })
    }

    /// `σ_test_rel` and its `R²` on held-out points (coded `x`, observed `y`); `None`
    /// with fewer than two test points or no spread among them.
    pub fn test(&self, x: &[Vec<f64>], y: &[f64]) -> Option<TestQuality> {
        test_quality(&|p| self.predict(p), x, y)
    }

    /// Terms other than the constant, ordered by |t| (largest first): the Pareto
    /// chart of standardised effects. Empty when there are no t-values.
    pub fn effects(&self) -> Vec<(String, f64)> {
        let Some(t) = &self.t_values else {
            return Vec::new();
        };
        let mut effects: Vec<(String, f64)> = self
            .names
            .iter()
            .zip(t)
            .zip(&self.basis.terms)
            .filter(|(_, term)| term.iter().any(|&e| e > 0))
            .map(|((name, t), _)| (name.clone(), *t))
            .collect();
        effects.sort_by(|a, b| b.1.abs().total_cmp(&a.1.abs()));
        effects
    }
}

#[cfg(test)]
#[path = "fit_tests.rs"]
mod tests;
