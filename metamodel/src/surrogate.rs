//! One response's surrogate, chosen by how well it predicts runs it did not see.
//!
//! The candidates are polynomials of order 1, 2 and 3 in the study's basis, each pruned
//! by the rule of [`crate::prune`], and a Kriging model ([`crate::kriging`]). Each is
//! scored by its leave-one-out RMSE, `sqrt(PRESS / n)` in the response's unit: the
//! polynomials' from their hat matrix, Kriging's in closed form with its
//! hyperparameters held at their maximum-likelihood values (which makes Kriging's score
//! slightly optimistic; the alternative, refitting the hyperparameters n times, costs n
//! maximisations). A candidate that cannot be scored (too few runs for its terms, a run
//! of leverage one) says why and is not chosen.
//!
//! **The rule.** The candidate with the smallest score wins, except that a simpler one
//! (earlier in the order linear, quadratic, cubic, Kriging) whose score is within the
//! margin of the best is preferred: the margin is the larger of [`PARSIMONY`] and one
//! standard error of the best candidate's mean squared leave-one-out residual (the
//! one-standard-error rule), since a gain that small is within the noise of a
//! leave-one-out estimate and does not pay for the extra parameters. A pruned
//! polynomial is scored with the pruning repeated without each run (up to
//! [`MAX_REPEATED_PRUNING_RUNS`] runs): its own residuals are biased low, because
//! pruning chose its terms by the same PRESS. When no candidate can be scored, the
//! quadratic (else the linear) is kept, and the choice says it was not made by
//! prognosis.
//!
//! This is the prognosis-based choice of optiSLang's Metamodel of Optimal Prognosis
//! (Most & Will 2008) with leave-one-out in place of its split sample; see also Forrester,
//! Sóbester & Keane, *Engineering Design via Surrogate Modelling* (2008), §2.4 and §3.

use rayon::prelude::*;

use crate::basis::{Basis, BasisKind};
use crate::co_kriging::{
    split_by_level, CoKriging, CoKrigingError, LevelHyperparameters, LevelRuns,
};
use crate::fit::{test_quality, Fit, FitError, Interval, Quality, TestQuality};
use crate::kriging::{Kernel, Kriging, KrigingError, KrigingOptions, Trend};
use crate::levels::{combination_of, numeric_part};
use crate::per_level::{KrigingPerLevel, PerLevelError};
use crate::propagate::Distribution;
use crate::prune::prune;
use crate::sobol::{legendre_sobol, sobol_indices, Estimate, SobolIndices};
use crate::student::student_t_quantile;

/// A simpler candidate whose leave-one-out RMSE is within this fraction of the best
/// one's is chosen over it.
pub const PARSIMONY: f64 = 0.05;

/// The most runs Kriging is fitted to. Its likelihood search factorises the n × n
/// correlation matrix (n³/3 flops, 8 n² bytes) at every step of several Nelder–Mead
/// starts: at 10^4 runs that is 800 MB and 3·10^11 flops per step. Above this the model
/// choice compares the polynomials only, and its Kriging candidate says why.
pub const MAX_KRIGING_RUNS: usize = 500;

/// Which surrogate a study asks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModelChoice {
    /// The best of pruned polynomials of order 1–3 and Kriging by leave-one-out RMSE.
    Auto,
    /// The complete polynomial of this order (1–3), nothing dropped.
    Polynomial {
        /// Total order.
        order: u32,
    },
    /// Kriging with the study's kernel and trend.
    Kriging,
}

/// A fitted surrogate of one response over coded factors.
// A round holds one per response: a few hundred bytes each, not worth a box.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone)]
pub enum Surrogate {
    /// A least-squares polynomial (complete or pruned).
    Polynomial(Fit),
    /// A Gaussian-process model, with its quality on the runs it was fitted to.
    Kriging {
        /// The model.
        model: Box<Kriging>,
        /// R², leave-one-out residuals, σ_cross, as for a polynomial.
        quality: Quality,
    },
    /// One Gaussian-process model per combination of the text factors' levels.
    KrigingPerLevel(Box<KrigingPerLevel>),
    /// Co-Kriging over fidelity levels, predicting the top level.
    CoKriging {
        /// The model.
        model: Box<CoKriging>,
        /// Its quality on the top level's runs (σ_cross from their leave-one-out
        /// residuals with the levels below held).
        quality: Quality,
    },
}

/// Enough to rebuild a surrogate on the same runs without searching again.
#[derive(Debug, Clone, PartialEq)]
pub enum ModelSpec {
    /// A polynomial with exactly these terms.
    Polynomial {
        /// Basis kind.
        kind: BasisKind,
        /// Levels of each factor, 0 for numeric ([`crate::levels`]); empty if none.
        levels: Vec<u32>,
        /// Exponents of each kept term.
        terms: Vec<Vec<u32>>,
    },
    /// A Kriging model with these hyperparameters.
    Kriging {
        /// Kernel.
        kernel: Kernel,
        /// Trend.
        trend: Trend,
        /// Length scales in coded units, one per factor.
        length_scales: Vec<f64>,
        /// Process variance σ² in the response's unit squared.
        process_variance: f64,
        /// Noise (nugget) variance in the response's unit squared.
        noise_variance: f64,
    },
    /// One Kriging model per combination of the text factors' levels.
    KrigingPerLevel {
        /// Levels of each factor, 0 for numeric.
        levels: Vec<u32>,
        /// Each combination (one level per text factor, 0-based) and its model's
        /// [`ModelSpec::Kriging`].
        models: Vec<(Vec<u32>, ModelSpec)>,
    },
    /// Co-Kriging over fidelity levels with these hyperparameters, cheapest first.
    CoKriging {
        /// Kernel of every level.
        kernel: Kernel,
        /// Trend of every level (plus `ρ` above level 0).
        trend: Trend,
        /// Each level's hyperparameters.
        levels: Vec<LevelHyperparameters>,
    },
}

/// Why no surrogate of a response could be fitted, or a stored one rebuilt.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SurrogateError {
    /// A polynomial could not be fitted.
    #[error(transparent)]
    Polynomial(#[from] FitError),
    /// A Kriging model could not be fitted.
    #[error(transparent)]
    Kriging(#[from] KrigingError),
    /// Kriging per combination of text levels could not be fitted.
    #[error(transparent)]
    PerLevel(#[from] PerLevelError),
    /// Co-Kriging over fidelity levels could not be fitted.
    #[error(transparent)]
    CoKriging(#[from] CoKrigingError),
    /// Co-Kriging needs runs at every level from 0 to the highest present.
    #[error("no run at fidelity level {level}; every level needs runs")]
    MissingLevel {
        /// The level without runs (0 the cheapest).
        level: usize,
    },
    /// Kriging is not fitted to more than [`MAX_KRIGING_RUNS`] runs.
    #[error("not fitted: {runs} runs, more than the {MAX_KRIGING_RUNS} Kriging is fitted to (its cost grows as the cube of the runs)")]
    TooManyRunsForKriging {
        /// Runs given.
        runs: usize,
    },
    /// A stored per-level model held a model that is not Kriging.
    #[error("a per-level model must be Kriging")]
    PerLevelNotKriging,
    /// No candidate of the model choice could be fitted.
    #[error("no surrogate could be fitted ({})", reasons.join("; "))]
    NoCandidate {
        /// Each candidate's `name: why`.
        reasons: Vec<String>,
    },
}

/// How one candidate did.
#[derive(Debug, Clone, PartialEq)]
pub struct Candidate {
    /// Its name, e.g. `quadratic, 5 of 6 terms`.
    pub name: String,
    /// Parameters it fitted.
    pub parameters: usize,
    /// Leave-one-out RMSE in the response's unit, when it could be scored.
    pub loo_rmse: Option<f64>,
    /// Why it has no score or no fit.
    pub note: Option<String>,
}

/// The chosen surrogate and the table it was chosen from.
#[derive(Debug, Clone)]
pub struct Choice {
    /// The surrogate the round uses.
    pub surrogate: Surrogate,
    /// Every candidate, in the order linear, quadratic, cubic, Kriging.
    pub candidates: Vec<Candidate>,
    /// Index of the chosen one in `candidates`.
    pub chosen: usize,
    /// True when it was chosen by its score, false when no candidate had one.
    pub by_prognosis: bool,
}

/// Co-Kriging over fidelity levels as the one candidate of a choice: runs carry their
/// level as a last coordinate ([`Surrogate::fit_co_kriging`]); its score is the top
/// level's leave-one-out RMSE, and its name says each level's learned scale `ρ` and
/// correlation with the level below.
pub fn choose_co_kriging(
    x: &[Vec<f64>],
    y: &[f64],
    kriging: &KrigingOptions,
) -> Result<Choice, SurrogateError> {
    let surrogate = Surrogate::fit_co_kriging(x, y, kriging)?;
    let Surrogate::CoKriging { model, quality } = &surrogate else {
        unreachable!("fit_co_kriging gives co-Kriging");
    };
    let candidate = Candidate {
        name: co_kriging_name(model),
        parameters: surrogate.parameters(),
        loo_rmse: quality
            .press
            .map(|press| (press / quality.runs.max(1) as f64).sqrt()),
        note: None,
    };
    Ok(Choice {
        surrogate,
        candidates: vec![candidate],
        chosen: 0,
        by_prognosis: true,
    })
}

/// `co-Kriging over 2 fidelity levels, Matérn 5/2, constant trend; level 1: ρ = 1.98,
/// correlation 0.97`.
pub fn co_kriging_name(model: &CoKriging) -> String {
    let first = model.level_model(0);
    let mut name = format!(
        "co-kriging over {} fidelity levels, {}",
        model.n_levels(),
        kriging_name(first.kernel(), first.trend()).trim_start_matches("kriging, ")
    );
    for level in 1..model.n_levels() {
        let (rho, correlation) = (model.scale_factor(level), model.correlation(level));
        if let (Some(rho), Some(correlation)) = (rho, correlation) {
            name.push_str(&format!(
                "; level {level}: ρ = {rho:.3}, correlation {correlation:.3}"
            ));
        }
    }
    name
}

/// Fits the surrogate `model` asks for to responses `y` at coded points `x`;
/// `kind` is the polynomials' basis, `levels` the text factors' levels (empty or 0
/// for numeric factors, see [`crate::levels`]) and `kriging` Kriging's settings. The
/// error says why no candidate could be fitted at all.
pub fn choose(
    model: ModelChoice,
    kind: BasisKind,
    factor_names: &[String],
    levels: &[u32],
    x: &[Vec<f64>],
    y: &[f64],
    kriging: &KrigingOptions,
) -> Result<Choice, SurrogateError> {
    let k = factor_names.len();
    let mut fitted: Vec<(Candidate, Option<Surrogate>)> = Vec::new();
    // Per candidate, the leave-one-out residuals it is scored by, when they are not its
    // surrogate's own (a pruned polynomial's, with the pruning repeated without each run).
    let mut repeated: Vec<Option<Vec<f64>>> = Vec::new();
    let orders: Vec<(u32, bool)> = match model {
        ModelChoice::Auto => vec![(1, true), (2, true), (3, true)],
        ModelChoice::Polynomial { order } => vec![(order, false)],
        ModelChoice::Kriging => vec![],
    };
    for (order, pruned) in orders {
        let basis = Basis::complete_with_levels(kind, k, levels, order);
        let full = basis.len();
        let result = if pruned {
            prune(basis.clone(), factor_names, x, y)
        } else {
            Fit::new(basis.clone(), factor_names, x, y)
        };
        let honest = match (&result, pruned) {
            (Ok(_), true) => pruned_leave_one_out(&basis, factor_names, x, y),
            _ => None,
        };
        let rmse = |r: &[f64]| (r.iter().map(|e| e * e).sum::<f64>() / r.len() as f64).sqrt();
        repeated.push(honest.clone());
        fitted.push(match result {
            Ok(fit) => {
                let candidate = Candidate {
                    name: polynomial_name(order, fit.coefficients.len(), full),
                    parameters: fit.coefficients.len(),
                    loo_rmse: match &honest {
                        Some(residuals) => Some(rmse(residuals)),
                        None => fit.quality.press.map(|p| (p / y.len() as f64).sqrt()),
                    },
                    note: fit
                        .quality
                        .press
                        .is_none()
                        .then(|| "a run of leverage 1 leaves no leave-one-out residual".into()),
                };
                (candidate, Some(Surrogate::Polynomial(fit)))
            }
            Err(e) => (
                Candidate {
                    name: polynomial_name(order, full, full),
                    parameters: full,
                    loo_rmse: None,
                    note: Some(e.to_string()),
                },
                None,
            ),
        });
    }
    if matches!(model, ModelChoice::Auto | ModelChoice::Kriging) {
        repeated.push(None);
        fitted.push(kriging_candidate(levels, x, y, kriging));
    }

    let scored = |i: usize| {
        fitted[i]
            .1
            .as_ref()
            .and(fitted[i].0.loo_rmse)
            .filter(|v| v.is_finite())
    };
    let best = (0..fitted.len())
        .filter(|&i| scored(i).is_some())
        .min_by(|&a, &b| scored(a).unwrap().total_cmp(&scored(b).unwrap()));
    let (chosen, by_prognosis) = match best {
        Some(best) => {
            let residuals = repeated[best].as_ref().or_else(|| {
                fitted[best]
                    .1
                    .as_ref()
                    .and_then(|s| s.quality().loo_residuals.as_ref())
            });
            let margin = simpler_is_as_good_below(fitted[best].0.loo_rmse, residuals);
            (
                (0..fitted.len())
                    .find(|&i| scored(i).is_some_and(|v| v <= margin))
                    .expect("the best candidate is within its own margin"),
                true,
            )
        }
        None => {
            // Nothing scored: the quadratic, else any candidate that fitted.
            let order_of_preference = [1, 0, 2, 3];
            let Some(i) = order_of_preference
                .iter()
                .copied()
                .filter(|&i| i < fitted.len())
                .chain(0..fitted.len())
                .find(|&i| fitted[i].1.is_some())
            else {
                let reasons: Vec<String> = fitted
                    .iter()
                    .map(|(c, _)| format!("{}: {}", c.name, c.note.clone().unwrap_or_default()))
                    .collect();
                return Err(SurrogateError::NoCandidate { reasons });
            };
            (i, false)
        }
    };
    let surrogate = fitted[chosen]
        .1
        .clone()
        .expect("the chosen candidate fitted");
    Ok(Choice {
        surrogate,
        candidates: fitted.into_iter().map(|(c, _)| c).collect(),
        chosen,
        by_prognosis,
    })
}

/// Kriging (one model per level of the text factors) as a candidate of the model
/// choice: its leave-one-out error, or why it was not fitted.
fn kriging_candidate(
    levels: &[u32],
    x: &[Vec<f64>],
    y: &[f64],
    kriging: &KrigingOptions,
) -> (Candidate, Option<Surrogate>) {
    let has_text = levels.iter().any(|&l| l > 0);
    let mut name = kriging_name(kriging.kernel, kriging.trend);
    if has_text {
        name.push_str(", one per level");
    }
    let fit = if y.len() > MAX_KRIGING_RUNS {
        Err(SurrogateError::TooManyRunsForKriging { runs: y.len() })
    } else if has_text {
        KrigingPerLevel::fit(levels, x, y, kriging)
            .map(|m| Surrogate::KrigingPerLevel(Box::new(m)))
            .map_err(SurrogateError::from)
    } else {
        Kriging::fit(x, y, kriging)
            .map(|m| Surrogate::kriging(m, y))
            .map_err(SurrogateError::from)
    };
    match fit {
        Ok(surrogate) => {
            let quality = surrogate.quality();
            let candidate = Candidate {
                name,
                parameters: surrogate.parameters(),
                loo_rmse: quality.press.map(|p| (p / y.len() as f64).sqrt()),
                note: None,
            };
            (candidate, Some(surrogate))
        }
        Err(e) => (
            Candidate {
                name,
                parameters: 0,
                loo_rmse: None,
                note: Some(e.to_string()),
            },
            None,
        ),
    }
}

/// Most runs at which a pruned polynomial's leave-one-out residuals are computed by
/// pruning again without each run (`n` prunings); above it, the pruned fit's own
/// (slightly optimistic) residuals are used, whose bias shrinks as runs grow.
pub const MAX_REPEATED_PRUNING_RUNS: usize = 100;

/// The leave-one-out residuals of pruning `basis` and fitting, with the pruning
/// repeated without each run: the pruned model's own residuals are optimistic, since
/// pruning chose its terms to make exactly those small. `None` above
/// [`MAX_REPEATED_PRUNING_RUNS`] runs or when a reduced set of runs cannot be fitted.
fn pruned_leave_one_out(
    basis: &Basis,
    factor_names: &[String],
    x: &[Vec<f64>],
    y: &[f64],
) -> Option<Vec<f64>> {
    if y.len() > MAX_REPEATED_PRUNING_RUNS {
        return None;
    }
    (0..y.len())
        .into_par_iter()
        .map(|i| {
            let xs: Vec<Vec<f64>> = (0..x.len())
                .filter(|&j| j != i)
                .map(|j| x[j].clone())
                .collect();
            let ys: Vec<f64> = (0..y.len()).filter(|&j| j != i).map(|j| y[j]).collect();
            let fit = prune(basis.clone(), factor_names, &xs, &ys).ok()?;
            Some(y[i] - fit.predict(&x[i]))
        })
        .collect()
}

/// The leave-one-out RMSE at or below which a simpler candidate is chosen over the
/// best one (`best`, scored): the larger of [`PARSIMONY`] above its RMSE and one
/// standard error above its mean squared leave-one-out residual (the one-standard-error
/// rule, Hastie, Tibshirani & Friedman, *The Elements of Statistical Learning*, 2nd
/// ed., §7.10). The best candidate's score is biased low when pruning chose its terms
/// by the same PRESS; one standard error of that score is how far below it can fall by
/// chance.
fn simpler_is_as_good_below(loo_rmse: Option<f64>, residuals: Option<&Vec<f64>>) -> f64 {
    let rmse = loo_rmse.unwrap_or(f64::INFINITY);
    let by_parsimony = rmse * (1.0 + PARSIMONY);
    let Some(residuals) = residuals.filter(|r| r.len() > 1) else {
        return by_parsimony;
    };
    let n = residuals.len() as f64;
    let squares: Vec<f64> = residuals.iter().map(|e| e * e).collect();
    let mse = squares.iter().sum::<f64>() / n;
    let spread = (squares.iter().map(|q| (q - mse).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    let by_standard_error = (mse + spread / n.sqrt()).sqrt();
    by_parsimony.max(by_standard_error)
}

fn polynomial_name(order: u32, kept: usize, full: usize) -> String {
    let degree = match order {
        1 => "linear",
        2 => "quadratic",
        3 => "cubic",
        _ => "polynomial",
    };
    if kept == full {
        format!("{degree}, all {full} terms")
    } else {
        format!("{degree}, {kept} of {full} terms")
    }
}

fn kriging_name(kernel: Kernel, trend: Trend) -> String {
    let kernel = match kernel {
        Kernel::Matern52 => "Matérn 5/2",
        Kernel::SquaredExponential => "squared exponential",
    };
    let trend = match trend {
        Trend::Constant => "constant trend",
        Trend::Linear => "linear trend",
    };
    format!("kriging, {kernel}, {trend}")
}

/// R², leave-one-out residuals and σ_cross of a Kriging model on its own runs,
/// defined as for a polynomial ([`Quality`]).
fn kriging_quality(model: &Kriging, y: &[f64], parameters: usize) -> Quality {
    let predictions: Vec<f64> = model.points().iter().map(|x| model.predict(x)).collect();
    quality_from(
        y,
        &predictions,
        model.loo_residuals(),
        parameters,
        model.noise_variance(),
    )
}

/// R², σ_cross and PRESS of a Gaussian-process model from its predictions at its runs
/// and its leave-one-out residuals.
fn quality_from(
    y: &[f64],
    predictions: &[f64],
    loo: Vec<f64>,
    parameters: usize,
    noise_variance: f64,
) -> Quality {
    let n = y.len();
    let mean = y.iter().sum::<f64>() / n as f64;
    let ss_tot: f64 = y.iter().map(|v| (v - mean).powi(2)).sum();
    let ss_res: f64 = predictions
        .iter()
        .zip(y)
        .map(|(p, v)| (v - p).powi(2))
        .sum();
    let press: f64 = loo.iter().map(|e| e * e).sum();
    let spread = if n > 1 {
        (ss_tot / (n - 1) as f64).sqrt()
    } else {
        0.0
    };
    let sigma_cross_percent = (spread > 0.0).then(|| 100.0 * (press / n as f64).sqrt() / spread);
    Quality {
        runs: n,
        terms: parameters,
        r2: if ss_tot > 0.0 {
            1.0 - ss_res / ss_tot
        } else {
            1.0
        },
        adjusted_r2: None,
        residual_std: Some(noise_variance.sqrt()),
        loo_residuals: Some(loo),
        press: Some(press),
        sigma_cross_percent,
        r2_cross: sigma_cross_percent.map(|s| 1.0 - (s / 100.0).powi(2)),
    }
}

impl Surrogate {
    /// A co-Kriging surrogate fitted to runs whose points carry their fidelity level as
    /// a last coordinate (0 the cheapest, every level from 0 to the highest present);
    /// it predicts the top level over the other coordinates.
    pub fn fit_co_kriging(
        x: &[Vec<f64>],
        y: &[f64],
        options: &KrigingOptions,
    ) -> Result<Surrogate, SurrogateError> {
        let split = split_by_level(x, y);
        if let Some(level) = split.iter().position(|(x, _)| x.is_empty()) {
            return Err(SurrogateError::MissingLevel { level });
        }
        let runs: Vec<LevelRuns<'_>> = split.iter().map(|(x, y)| LevelRuns { x, y }).collect();
        CoKriging::fit(&runs, options)
            .map(|model| Surrogate::co_kriging(model, &split[split.len() - 1].1))
            .map_err(SurrogateError::from)
    }

    /// A co-Kriging surrogate with its quality on the top level's responses `y_top`.
    pub fn co_kriging(model: CoKriging, y_top: &[f64]) -> Surrogate {
        let top = model.level_model(model.top());
        let predictions: Vec<f64> = top.points().iter().map(|p| model.predict(p)).collect();
        let mut quality = quality_from(
            y_top,
            &predictions,
            model.loo_residuals(),
            co_kriging_parameters(&model),
            top.noise_variance(),
        );
        // They are the top level's alone, not one per run fitted: kept out of the
        // per-run views.
        quality.loo_residuals = None;
        Surrogate::CoKriging {
            model: Box::new(model),
            quality,
        }
    }

    /// A Kriging surrogate with its quality on the responses `y` it was fitted to.
    pub fn kriging(model: Kriging, y: &[f64]) -> Surrogate {
        let parameters = kriging_parameters(&model);
        let quality = kriging_quality(&model, y, parameters);
        Surrogate::Kriging {
            model: Box::new(model),
            quality,
        }
    }

    /// Its value at coded point `x`, in the response's unit.
    pub fn predict(&self, x: &[f64]) -> f64 {
        match self {
            Surrogate::Polynomial(fit) => fit.predict(x),
            Surrogate::Kriging { model, .. } => model.predict(x),
            Surrogate::KrigingPerLevel(model) => model.predict(x),
            Surrogate::CoKriging { model, .. } => model.predict(x),
        }
    }

    /// Standard error of its value at `x` as an estimate of the mean response (the
    /// surrogate's own error, without run-to-run noise), in the response's unit;
    /// `None` for a polynomial without residual degrees of freedom.
    pub fn mean_std(&self, x: &[f64]) -> Option<f64> {
        match self {
            Surrogate::Polynomial(fit) => fit.confidence_interval(x, 0.95).map(|i| i.std_error),
            Surrogate::Kriging { model, .. } => Some(model.predict_variance(x).max(0.0).sqrt()),
            Surrogate::KrigingPerLevel(model) => Some(model.mean_std(x)),
            Surrogate::CoKriging { model, .. } => Some(model.predict_variance(x).max(0.0).sqrt()),
        }
    }

    /// The interval that holds a new run at `x` with probability `confidence`:
    /// surrogate error and run-to-run noise. A polynomial's uses Student's t with its
    /// residual degrees of freedom; Kriging's the normal quantile of its posterior.
    pub fn prediction_interval(&self, x: &[f64], confidence: f64) -> Option<Interval> {
        match self {
            Surrogate::Polynomial(fit) => fit.prediction_interval(x, confidence),
            Surrogate::Kriging { model, .. } => Some(normal_interval(
                model.predict(x),
                model.predict_variance(x) + model.noise_variance(),
                confidence,
            )),
            Surrogate::KrigingPerLevel(model) => Some(model.prediction_interval(x, confidence)),
            Surrogate::CoKriging { model, .. } => Some(normal_interval(
                model.predict(x),
                model.predict_variance(x) + model.level_model(model.top()).noise_variance(),
                confidence,
            )),
        }
    }

    /// `σ_test_rel` and its `R²` on held-out points (coded `x`, observed `y`).
    pub fn test(&self, x: &[Vec<f64>], y: &[f64]) -> Option<TestQuality> {
        test_quality(&|p| self.predict(p), x, y)
    }

    /// Quality on the runs it was fitted to.
    pub fn quality(&self) -> &Quality {
        match self {
            Surrogate::Polynomial(fit) => &fit.quality,
            Surrogate::Kriging { quality, .. } => quality,
            Surrogate::KrigingPerLevel(model) => model.quality(),
            Surrogate::CoKriging { quality, .. } => quality,
        }
    }

    /// Parameters it fitted: terms, or Kriging's trend terms, length scales, process
    /// variance and nugget.
    pub fn parameters(&self) -> usize {
        match self {
            Surrogate::Polynomial(fit) => fit.coefficients.len(),
            Surrogate::Kriging { model, .. } => kriging_parameters(model),
            Surrogate::KrigingPerLevel(model) => model.parameters(),
            Surrogate::CoKriging { model, .. } => co_kriging_parameters(model),
        }
    }

    /// The polynomial, when it is one.
    pub fn polynomial(&self) -> Option<&Fit> {
        match self {
            Surrogate::Polynomial(fit) => Some(fit),
            Surrogate::Kriging { .. }
            | Surrogate::KrigingPerLevel(_)
            | Surrogate::CoKriging { .. } => None,
        }
    }

    /// True for a polynomial of total order two or less, whose optimum in a box is
    /// found exactly.
    pub fn is_quadratic(&self) -> bool {
        matches!(self, Surrogate::Polynomial(fit) if fit.basis.order <= 2)
    }

    /// Sobol indices of each factor with the factors uniform over the coded box
    /// `[-1, 1]^k` (the round's box): exact from the coefficients of a Legendre
    /// polynomial (intervals of zero width, `analytic` true), else estimated by
    /// Saltelli–Jansen Monte Carlo with `base_samples` rows seeded by `seed`.
    /// `None` for a surface that does not vary.
    pub fn sobol(&self, base_samples: usize, seed: u64) -> Option<(SobolIndices, bool)> {
        if let Some((first, total)) = self.polynomial().and_then(legendre_sobol) {
            let exact = |v: Vec<f64>| {
                v.into_iter()
                    .map(|value| Estimate {
                        value,
                        low: value,
                        high: value,
                    })
                    .collect()
            };
            let indices = SobolIndices {
                first: exact(first),
                total: exact(total),
                variance: f64::NAN,
                evaluations: 0,
            };
            return Some((indices, true));
        }
        if let Surrogate::Polynomial(fit) = self {
            if fit.basis.kind == BasisKind::Legendre && fit.basis.levels.iter().all(|&l| l == 0) {
                return None; // legendre_sobol found no variance: a constant surface.
            }
        }
        let k = match self {
            Surrogate::Polynomial(fit) => fit.basis.n_factors,
            Surrogate::Kriging { model, .. } => model.length_scales().len(),
            Surrogate::KrigingPerLevel(model) => model.levels().len(),
            Surrogate::CoKriging { model, .. } => model.level_model(0).length_scales().len(),
        };
        let uniform = Distribution::Uniform {
            low: -1.0,
            high: 1.0,
        };
        let predict = |x: &[f64]| self.predict(x);
        sobol_indices(&predict, &vec![uniform; k], base_samples, seed)
            .ok()
            .map(|indices| (indices, false))
    }

    /// What rebuilds it on the same runs without a search.
    pub fn spec(&self) -> ModelSpec {
        match self {
            Surrogate::Polynomial(fit) => ModelSpec::Polynomial {
                kind: fit.basis.kind,
                levels: fit.basis.levels.clone(),
                terms: fit.basis.terms.clone(),
            },
            Surrogate::Kriging { model, .. } => kriging_spec(model),
            Surrogate::KrigingPerLevel(model) => ModelSpec::KrigingPerLevel {
                levels: model.levels().to_vec(),
                models: model
                    .models()
                    .iter()
                    .map(|(c, m)| (c.clone(), kriging_spec(m)))
                    .collect(),
            },
            Surrogate::CoKriging { model, .. } => ModelSpec::CoKriging {
                kernel: model.level_model(0).kernel(),
                trend: model.level_model(0).trend(),
                levels: model.hyperparameters(),
            },
        }
    }

    /// The surrogate `spec` describes, fitted again to `y` at `x`.
    pub fn rebuild(
        spec: &ModelSpec,
        factor_names: &[String],
        x: &[Vec<f64>],
        y: &[f64],
    ) -> Result<Surrogate, SurrogateError> {
        match spec {
            ModelSpec::Polynomial {
                kind,
                levels,
                terms,
            } => {
                let basis =
                    Basis::from_terms_with_levels(*kind, factor_names.len(), levels, terms.clone());
                Fit::new(basis, factor_names, x, y)
                    .map(Surrogate::Polynomial)
                    .map_err(SurrogateError::from)
            }
            ModelSpec::Kriging {
                kernel,
                trend,
                length_scales,
                process_variance,
                noise_variance,
            } => Kriging::with_hyperparameters(
                x,
                y,
                *kernel,
                *trend,
                length_scales,
                *process_variance,
                *noise_variance,
            )
            .map(|model| Surrogate::kriging(model, y))
            .map_err(SurrogateError::from),
            ModelSpec::KrigingPerLevel { levels, models } => {
                // Each combination's hyperparameters, carried by a model fitted to its
                // own runs with them.
                let combination_runs = |c: &[u32]| -> (Vec<Vec<f64>>, Vec<f64>) {
                    x.iter()
                        .zip(y)
                        .filter(|(p, _)| combination_of(levels, p) == c)
                        .map(|(p, v)| (numeric_part(levels, p), *v))
                        .unzip()
                };
                let mut carriers = Vec::new();
                for (combination, spec) in models {
                    let (xs, ys) = combination_runs(combination);
                    let Surrogate::Kriging { model, .. } =
                        Surrogate::rebuild(spec, factor_names, &xs, &ys)?
                    else {
                        return Err(SurrogateError::PerLevelNotKriging);
                    };
                    carriers.push((combination.clone(), *model));
                }
                KrigingPerLevel::with_hyperparameters(levels, &carriers, x, y)
                    .map(|m| Surrogate::KrigingPerLevel(Box::new(m)))
                    .map_err(SurrogateError::from)
            }
            ModelSpec::CoKriging {
                kernel,
                trend,
                levels,
            } => {
                let split = split_by_level(x, y);
                let runs: Vec<LevelRuns<'_>> =
                    split.iter().map(|(x, y)| LevelRuns { x, y }).collect();
                CoKriging::with_hyperparameters(&runs, *kernel, *trend, levels)
                    .map(|model| Surrogate::co_kriging(model, &split[split.len() - 1].1))
                    .map_err(SurrogateError::from)
            }
        }
    }
}

fn kriging_spec(model: &Kriging) -> ModelSpec {
    ModelSpec::Kriging {
        kernel: model.kernel(),
        trend: model.trend(),
        length_scales: model.length_scales().to_vec(),
        process_variance: model.process_variance(),
        noise_variance: model.noise_variance(),
    }
}

/// The `confidence` interval of a Gaussian prediction with mean `estimate` and
/// variance `variance` (surrogate error and noise; negative round-off taken as 0).
pub(crate) fn normal_interval(estimate: f64, variance: f64, confidence: f64) -> Interval {
    let std_error = variance.max(0.0).sqrt();
    // The normal quantile, as Student's t with a very large ν.
    let z = student_t_quantile(0.5 + 0.5 * confidence, 1e9);
    Interval {
        estimate,
        std_error,
        low: estimate - z * std_error,
        high: estimate + z * std_error,
        degrees_of_freedom: f64::INFINITY,
    }
}

fn co_kriging_parameters(model: &CoKriging) -> usize {
    // Each level's Kriging parameters, and ρ above level 0.
    (0..model.n_levels())
        .map(|t| kriging_parameters(model.level_model(t)) + usize::from(t > 0))
        .sum()
}

fn kriging_parameters(model: &Kriging) -> usize {
    let trend = match model.trend() {
        Trend::Constant => 1,
        Trend::Linear => 1 + model.length_scales().len(),
    };
    trend + model.length_scales().len() + 2
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::{Design, DesignKind};

    fn names(k: usize) -> Vec<String> {
        (0..k).map(|i| format!("x{i}")).collect()
    }

    /// The automatic choice in the Legendre basis over `k` numeric factors.
    fn auto(k: usize, x: &[Vec<f64>], y: &[f64]) -> Result<Choice, SurrogateError> {
        choose(
            ModelChoice::Auto,
            BasisKind::Legendre,
            &names(k),
            &[],
            x,
            y,
            &KrigingOptions::default(),
        )
    }

    fn lhs(k: usize, n: usize, seed: u64) -> Vec<Vec<f64>> {
        Design::build(
            &DesignKind::LatinHypercube {
                samples: n,
                seed,
                candidates: 20,
            },
            k,
        )
        .unwrap()
        .points
    }

    #[test]
    fn kriging_is_not_fitted_to_more_runs_than_its_limit_and_a_polynomial_is_chosen() {
        // A quadratic in one factor at MAX_KRIGING_RUNS + 1 evenly spaced points.
        let n = MAX_KRIGING_RUNS + 1;
        let x: Vec<Vec<f64>> = (0..n)
            .map(|i| vec![-1.0 + 2.0 * i as f64 / (n - 1) as f64])
            .collect();
        let y: Vec<f64> = x.iter().map(|p| 1.0 + p[0] - 0.5 * p[0] * p[0]).collect();
        let choice = auto(1, &x, &y).unwrap();
        let kriging = choice.candidates.last().unwrap();
        assert!(kriging.name.starts_with("kriging"), "{}", kriging.name);
        assert_eq!(kriging.loo_rmse, None);
        let note = kriging.note.as_deref().unwrap();
        assert!(note.contains(&format!("{n} runs")), "{note}");
        assert!(matches!(choice.surrogate, Surrogate::Polynomial(_)));
        let asked_for_kriging = choose(
            ModelChoice::Kriging,
            BasisKind::Legendre,
            &names(1),
            &[],
            &x,
            &y,
            &KrigingOptions::default(),
        );
        let error = asked_for_kriging.unwrap_err();
        assert!(
            matches!(&error, SurrogateError::NoCandidate { reasons }
                if reasons.len() == 1 && reasons[0].contains("not fitted")),
            "{error}"
        );
    }

    #[test]
    fn with_a_text_factor_the_polynomial_has_indicators_and_kriging_is_one_per_level() {
        // x numeric, m text with 3 levels: a level shift and a level-dependent slope.
        let numeric: Vec<Vec<f64>> = (0..9).map(|i| vec![-1.0 + i as f64 / 4.0]).collect();
        let x = crate::levels::cross(&[0, 3], 2, &numeric);
        let shift = [0.0, 2.0, -1.0];
        let slope = [1.0, -0.5, 0.3];
        let y: Vec<f64> = x
            .iter()
            .map(|p| {
                let l = crate::levels::level_of(p[1], 3) as usize;
                shift[l] + slope[l] * p[0] + 0.4 * p[0] * p[0]
            })
            .collect();
        let choice = choose(
            ModelChoice::Auto,
            BasisKind::Legendre,
            &names(2),
            &[0, 3],
            &x,
            &y,
            &KrigingOptions::default(),
        )
        .unwrap();
        let Surrogate::Polynomial(fit) = &choice.surrogate else {
            panic!("{:?}", choice.candidates);
        };
        assert!(fit.quality.r2 > 1.0 - 1e-12);
        assert!(fit.names.iter().any(|n| n == "x1[3]"), "{:?}", fit.names);
        // Its spec rebuilds it with the levels.
        let again = Surrogate::rebuild(&choice.surrogate.spec(), &names(2), &x, &y).unwrap();
        assert!((again.predict(&[0.3, 0.0]) - (2.0 - 0.15 + 0.036)).abs() < 1e-9);
        let kriging = choice.candidates.last().unwrap();
        assert!(kriging.name.ends_with("one per level"), "{kriging:?}");
        assert!(kriging.loo_rmse.is_some(), "{kriging:?}");
        // Asked for Kriging: one model per level, rebuilt from its spec.
        let asked = choose(
            ModelChoice::Kriging,
            BasisKind::Legendre,
            &names(2),
            &[0, 3],
            &x,
            &y,
            &KrigingOptions::default(),
        )
        .unwrap();
        assert!(matches!(asked.surrogate, Surrogate::KrigingPerLevel(_)));
        let again = Surrogate::rebuild(&asked.surrogate.spec(), &names(2), &x, &y).unwrap();
        for p in [[0.3, -1.0], [0.3, 0.0], [-0.6, 1.0]] {
            assert!((again.predict(&p) - asked.surrogate.predict(&p)).abs() < 1e-9);
        }
    }

    #[test]
    fn a_plane_is_modelled_by_the_linear_candidate() {
        // y = 1 + 2 x0 − x1 with normal noise (σ = 0.01, seeded): the higher orders only
        // fit noise, so the simplest within the margin wins.
        use rand::SeedableRng;
        use rand_distr::Distribution as _;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let noise = rand_distr::Normal::new(0.0, 0.01).unwrap();
        let x = lhs(2, 20, 1);
        let y: Vec<f64> = x
            .iter()
            .map(|p| 1.0 + 2.0 * p[0] - p[1] + noise.sample(&mut rng))
            .collect();
        let choice = auto(2, &x, &y).unwrap();
        assert_eq!(choice.candidates.len(), 4);
        assert_eq!(choice.chosen, 0, "{:?}", choice.candidates);
        assert!(choice.by_prognosis);
        assert!(choice.candidates[0].name.starts_with("linear"));
        assert!(choice.candidates[3].name.starts_with("kriging"));
    }

    /// Picks of the automatic choice over 20 noise draws of a true quadratic in 3
    /// factors on 30 runs, and on the real Branin at 30 runs.
    #[test]
    fn a_noisy_quadratic_gets_the_quadratic_and_branin_gets_kriging() {
        use rand::SeedableRng;
        use rand_distr::{Distribution as _, Normal};
        let x = lhs(3, 30, 5);
        let truth = |p: &[f64]| {
            1.0 + p[0] - 0.5 * p[1] + 0.3 * p[2] + 0.8 * p[0] * p[0] - 0.6 * p[1] * p[2]
                + 0.4 * p[2] * p[2]
        };
        let mut picks = std::collections::BTreeMap::new();
        for draw in 0..20u64 {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(100 + draw);
            let noise = Normal::new(0.0, 0.15).unwrap();
            let y: Vec<f64> = x
                .iter()
                .map(|p| truth(p) + noise.sample(&mut rng))
                .collect();
            let choice = auto(3, &x, &y).unwrap();
            let name = choice.candidates[choice.chosen].name.clone();
            *picks
                .entry(name.split(',').next().unwrap().to_string())
                .or_insert(0) += 1;
        }
        eprintln!("picks over 20 draws: {picks:?}");
        assert!(
            picks.get("quadratic").copied().unwrap_or(0) >= 17,
            "{picks:?}"
        );
        let branin = |p: &[f64]| {
            let (a, b) = (7.5 * (p[0] + 1.0) - 5.0, 7.5 * (p[1] + 1.0));
            let pi = std::f64::consts::PI;
            (b - 5.1 / (4.0 * pi * pi) * a * a + 5.0 / pi * a - 6.0).powi(2)
                + 10.0 * (1.0 - 1.0 / (8.0 * pi)) * a.cos()
                + 10.0
        };
        let x = lhs(2, 30, 6);
        let y: Vec<f64> = x.iter().map(|p| branin(p)).collect();
        let choice = auto(2, &x, &y).unwrap();
        assert!(
            matches!(choice.surrogate, Surrogate::Kriging { .. }),
            "{:?}",
            choice.candidates
        );
    }

    #[test]
    fn a_function_no_low_polynomial_can_follow_is_given_to_kriging() {
        // Branin-like ripples: sin(3 x0) cos(2 x1) + x0² over 30 points.
        let x = lhs(2, 30, 2);
        let f = |p: &[f64]| (3.0 * p[0]).sin() * (2.0 * p[1]).cos() * 2.0 + p[0] * p[0];
        let y: Vec<f64> = x.iter().map(|p| f(p)).collect();
        let choice = auto(2, &x, &y).unwrap();
        assert!(
            matches!(choice.surrogate, Surrogate::Kriging { .. }),
            "{:?}",
            choice.candidates
        );
        // Its prognosis beats every polynomial's by more than the margin.
        let kriging = choice.candidates[3].loo_rmse.unwrap();
        for c in &choice.candidates[..3] {
            assert!(c.loo_rmse.unwrap() > kriging * (1.0 + PARSIMONY), "{c:?}");
        }
    }

    #[test]
    fn a_forced_polynomial_is_the_complete_one_and_rebuilds_from_its_spec() {
        let x = lhs(2, 12, 3);
        let y: Vec<f64> = x.iter().map(|p| 1.0 + p[0] + 0.5 * p[0] * p[1]).collect();
        let choice = choose(
            ModelChoice::Polynomial { order: 2 },
            BasisKind::Monomial,
            &names(2),
            &[],
            &x,
            &y,
            &KrigingOptions::default(),
        )
        .unwrap();
        assert_eq!(choice.candidates.len(), 1);
        assert_eq!(choice.candidates[0].name, "quadratic, all 6 terms");
        let again = Surrogate::rebuild(&choice.surrogate.spec(), &names(2), &x, &y).unwrap();
        for p in &x {
            assert_eq!(again.predict(p), choice.surrogate.predict(p));
        }
    }

    #[test]
    fn a_kriging_surrogate_rebuilds_from_its_spec_without_a_search() {
        let x = lhs(2, 15, 4);
        let y: Vec<f64> = x.iter().map(|p| (2.0 * p[0]).sin() + p[1]).collect();
        let choice = choose(
            ModelChoice::Kriging,
            BasisKind::Legendre,
            &names(2),
            &[],
            &x,
            &y,
            &KrigingOptions::default(),
        )
        .unwrap();
        let again = Surrogate::rebuild(&choice.surrogate.spec(), &names(2), &x, &y).unwrap();
        let probe = [0.31, -0.42];
        assert!((again.predict(&probe) - choice.surrogate.predict(&probe)).abs() < 1e-9);
        // Its prediction interval holds the surrogate's error and the nugget.
        let interval = choice.surrogate.prediction_interval(&probe, 0.95).unwrap();
        let mean_std = choice.surrogate.mean_std(&probe).unwrap();
        assert!(interval.std_error >= mean_std);
        assert!((interval.high - interval.estimate - 1.959964 * interval.std_error).abs() < 1e-5);
    }

    #[test]
    fn too_few_runs_for_every_candidate_is_an_error_naming_each() {
        let x = vec![vec![0.0, 0.0], vec![1.0, 0.0]];
        let y = vec![1.0, 2.0];
        let error = choose(
            ModelChoice::Polynomial { order: 2 },
            BasisKind::Legendre,
            &names(2),
            &[],
            &x,
            &y,
            &KrigingOptions::default(),
        )
        .unwrap_err();
        assert!(
            matches!(error, SurrogateError::NoCandidate { .. }),
            "{error}"
        );
        assert!(
            error.to_string().starts_with(
                "no surrogate could be fitted (quadratic, all 6 terms: 2 runs cannot fit 6 terms"
            ),
            "{error}"
        );
    }

    #[test]
    fn co_kriging_rebuilds_from_its_spec_to_the_same_predictions() {
        // Two levels over one factor, the level as the last coordinate.
        let cheap: Vec<Vec<f64>> = (0..9).map(|i| vec![-1.0 + 0.25 * i as f64, 0.0]).collect();
        let dear: Vec<Vec<f64>> = [0, 3, 5, 8]
            .iter()
            .map(|&i| vec![cheap[i][0], 1.0])
            .collect();
        let f = |u: f64| (3.0 * u).sin() + u;
        let x: Vec<Vec<f64>> = cheap.iter().chain(&dear).cloned().collect();
        let y: Vec<f64> = x
            .iter()
            .map(|p| {
                if p[1] == 0.0 {
                    0.5 * f(p[0]) - 0.2
                } else {
                    f(p[0])
                }
            })
            .collect();
        let fitted = Surrogate::fit_co_kriging(&x, &y, &KrigingOptions::default()).unwrap();
        let spec = fitted.spec();
        assert!(matches!(spec, ModelSpec::CoKriging { ref levels, .. } if levels.len() == 2));
        let rebuilt = Surrogate::rebuild(&spec, &names(1), &x, &y).unwrap();
        for u in [-0.9, -0.3, 0.1, 0.77] {
            let (a, b) = (fitted.predict(&[u]), rebuilt.predict(&[u]));
            assert!((a - b).abs() < 1e-9 * (1.0 + a.abs()), "{u}: {a} vs {b}");
            assert!((a - f(u)).abs() < 0.05, "{u}: {a} vs {}", f(u));
        }
        assert_eq!(
            fitted.quality().runs,
            4,
            "quality is of the top level's runs"
        );
        assert!(fitted.quality().loo_residuals.is_none());
        let missing: Vec<Vec<f64>> = dear.clone();
        let error =
            Surrogate::fit_co_kriging(&missing, &y[9..], &KrigingOptions::default()).unwrap_err();
        assert_eq!(error, SurrogateError::MissingLevel { level: 0 });
        assert!(
            error.to_string().contains("no run at fidelity level 0"),
            "{error}"
        );
    }
}
