//! Multi-fidelity Kriging: the recursive autoregressive co-Kriging of Le Gratiet &
//! Garnier (2014), after Kennedy & O'Hagan (2000), and where to run next at which
//! fidelity.
//!
//! # Model
//!
//! Fidelity levels `t = 0 … s` run the same question at rising cost and accuracy (orch's
//! kernel then LIGGGHTS, or a coarse then a fine particle count). Level 0 is a Kriging
//! model of its own runs. Each higher level is its predecessor scaled, plus an
//! independent Gaussian process for what the predecessor misses:
//!
//! `y_t(x) = ρ_t ỹ_{t−1}(x) + δ_t(x)`,
//!
//! where `ỹ_{t−1}` is level `t−1`'s posterior (conditioned on its runs) and `δ_t` a
//! Kriging model with its own length scales, process variance and nugget. With the
//! runs of level `t` a subset of those of level `t−1` (*nested* designs), the joint
//! likelihood splits into one Kriging likelihood per level, so each level is fitted on
//! its own runs: `ρ_t` is one more trend coefficient of `δ_t`, beside the constant (or
//! linear) trend, with regressor `ỹ_{t−1}(x_i)` at run `i`, and estimated by
//! generalised least squares with the others. The prediction is
//!
//! - mean `μ_t(x) = ρ̂_t μ_{t−1}(x) + μ_δt(x)`;
//! - variance `s²_t(x) = ρ̂_t² s²_{t−1}(x) + s²_δt(x)`, where `s²_δt` is the universal
//!   Kriging variance of `δ_t` with regressors `(1, μ_{t−1}(x))`, so it carries the
//!   uncertainty of `ρ̂_t` too (Le Gratiet & Garnier 2014, §3).
//!
//! The formulas are exact for nested designs; for others they are the usual
//! approximation (the predecessor's posterior mean stands in for its value). Each
//! level's noise is its own: with `Nugget::FromReplicates`, the pure-error variance of
//! that level's replicates.
//!
//! The *learned correlation* between level `t−1` and `t` is their prior correlation at a
//! point, `ρ_t σ_{t−1} / √(ρ_t² σ²_{t−1} + σ²_δt)`, with `σ²_{t−1}` level `t−1`'s
//! prior variance (σ² of level 0, then recursively). Near 1 the cheap level explains
//! the expensive one up to a scale; near 0 it teaches nothing.
//!
//! # Where to run next, and at which fidelity
//!
//! The augmented expected improvement of Huang, Allen, Notz & Miller (2006) weighs the
//! top level's expected improvement over the *effective best* (the best of `μ ± s` at
//! the top level's runs, so noise is not chased) by what a run at level `l` is worth:
//!
//! `AEI(x, l) = EI_s(x) · corr(Y_l(x), Y_s(x)) · (1 − τ_l / √(s²_l(x) + τ²_l)) · C_s / C_l`,
//!
//! with the posterior correlation `corr = (Π_{t>l} ρ_t) s_l(x) / s_s(x)`, `τ²_l` level
//! `l`'s noise variance and `C_l` the cost of a run at level `l` *with the runs below it*
//! (designs stay nested: a point run at level `l` runs at every level below too).
//!
//! References: M. C. Kennedy and A. O'Hagan, "Predicting the output from a complex
//! computer code when fast approximations are available", *Biometrika* 87 (2000) 1–13.
//! L. Le Gratiet and J. Garnier, "Recursive co-kriging model for design of computer
//! experiments with multiple levels of fidelity", *Int. J. Uncertainty Quantification*
//! 4 (2014) 365–386. D. Huang, T. T. Allen, W. I. Notz and R. A. Miller, "Sequential
//! kriging optimization using multiple-fidelity evaluations", *Structural and
//! Multidisciplinary Optimization* 32 (2006) 369–382. A. I. J. Forrester, A. Sóbester
//! and A. J. Keane, "Multi-fidelity optimization via surrogate modelling", *Proc. R.
//! Soc. A* 463 (2007) 3251–3269.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::improvement::{expected_improvement, Feasibility, MIN_SEPARATION};
use crate::kriging::{Kernel, Kriging, KrigingError, KrigingOptions, Trend};
use crate::nelder_mead::{nelder_mead, Stop};
use crate::optimise::{BoxBounds, Goal};

/// Why a co-Kriging model cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CoKrigingError {
    /// No fidelity level was given.
    #[error("a co-Kriging model needs runs at one fidelity level at least")]
    NoLevels,
    /// One level's model failed.
    #[error("fidelity level {level}: {source}")]
    Level {
        /// The level (0 the cheapest).
        level: usize,
        /// Why its Kriging model failed.
        source: KrigingError,
    },
    /// Hyperparameters were given for another number of levels than runs.
    #[error("runs at {runs} fidelity levels but hyperparameters for {hyperparameters}; give one set per level")]
    Levels {
        /// Levels with runs.
        runs: usize,
        /// Levels with hyperparameters.
        hyperparameters: usize,
    },
    /// The lower level predicts the same value at every run of this level, so the
    /// scale factor ρ cannot be estimated.
    #[error("fidelity level {level}: the level below predicts the same value at all {runs} of its runs, so the scale between the levels cannot be estimated; run this level at points where the level below differs")]
    FlatPredecessor {
        /// The level.
        level: usize,
        /// Its runs.
        runs: usize,
    },
}

/// One level's Kriging hyperparameters (of `δ_t` above level 0), in response units.
#[derive(Debug, Clone, PartialEq)]
pub struct LevelHyperparameters {
    /// Length scales, coded units, one per factor.
    pub length_scales: Vec<f64>,
    /// Process variance σ², response units².
    pub process_variance: f64,
    /// Noise (nugget) variance τ², response units².
    pub noise_variance: f64,
}

/// One fidelity level's runs: coded points and responses.
#[derive(Debug, Clone, Copy)]
pub struct LevelRuns<'a> {
    /// Coded points, one per run.
    pub x: &'a [Vec<f64>],
    /// Responses, one per run.
    pub y: &'a [f64],
}

/// One level of a fitted model.
#[derive(Debug, Clone)]
struct Level {
    /// Kriging of this level; above level 0 its trend's last regressor is the
    /// predecessor's standardised prediction.
    model: Kriging,
    /// Mean and standard deviation by which the predecessor's prediction is
    /// standardised before it enters the trend (conditioning); none at level 0.
    covariate_scale: Option<(f64, f64)>,
}

/// A fitted recursive co-Kriging model over fidelity levels, cheapest first. Values
/// are in response units; predictions are of the top (most faithful) level unless a
/// level is named.
#[derive(Debug, Clone)]
pub struct CoKriging {
    levels: Vec<Level>,
}

impl CoKriging {
    /// Fits one Kriging model per level, cheapest first, each above the first with the
    /// level below's prediction as a trend regressor (see the module docs). The same
    /// `options` serve every level (its seed offset by the level).
    pub fn fit(
        runs: &[LevelRuns<'_>],
        options: &KrigingOptions,
    ) -> Result<CoKriging, CoKrigingError> {
        CoKriging::build(runs, |t, level, covariate| {
            let level_options = KrigingOptions {
                seed: options.seed.wrapping_add(t as u64),
                ..options.clone()
            };
            Kriging::fit_with_covariate(level.x, level.y, covariate, &level_options)
        })
    }

    /// The model with every level's hyperparameters given (one per level, cheapest
    /// first), nothing searched: the trend coefficients and `ρ` by generalised least
    /// squares. Rebuilds a stored model on its runs.
    pub fn with_hyperparameters(
        runs: &[LevelRuns<'_>],
        kernel: Kernel,
        trend: Trend,
        levels: &[LevelHyperparameters],
    ) -> Result<CoKriging, CoKrigingError> {
        if levels.len() != runs.len() {
            return Err(CoKrigingError::Levels {
                runs: runs.len(),
                hyperparameters: levels.len(),
            });
        }
        CoKriging::build(runs, |t, level, covariate| {
            let h = &levels[t];
            Kriging::with_hyperparameters_given(
                level.x,
                level.y,
                covariate,
                kernel,
                trend,
                &h.length_scales,
                h.process_variance,
                h.noise_variance,
            )
        })
    }

    /// The levels fitted in turn by `fit_level(level, runs, covariate)`.
    fn build(
        runs: &[LevelRuns<'_>],
        fit_level: impl Fn(usize, &LevelRuns<'_>, Option<&[f64]>) -> Result<Kriging, KrigingError>,
    ) -> Result<CoKriging, CoKrigingError> {
        if runs.is_empty() {
            return Err(CoKrigingError::NoLevels);
        }
        let mut fitted = CoKriging { levels: Vec::new() };
        for (t, level) in runs.iter().enumerate() {
            let fail = |source| CoKrigingError::Level { level: t, source };
            if t == 0 {
                let model = fit_level(0, level, None).map_err(fail)?;
                fitted.levels.push(Level {
                    model,
                    covariate_scale: None,
                });
                continue;
            }
            let below: Vec<f64> = level
                .x
                .iter()
                .map(|p| fitted.predict_level(t - 1, p).0)
                .collect();
            let n = below.len().max(1) as f64;
            let mean = below.iter().sum::<f64>() / n;
            let std = (below.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n).sqrt();
            if std.is_nan() || std <= 1e-12 * mean.abs().max(1e-300) {
                return Err(CoKrigingError::FlatPredecessor {
                    level: t,
                    runs: below.len(),
                });
            }
            let covariate: Vec<f64> = below.iter().map(|v| (v - mean) / std).collect();
            let model = fit_level(t, level, Some(&covariate)).map_err(fail)?;
            fitted.levels.push(Level {
                model,
                covariate_scale: Some((mean, std)),
            });
        }
        Ok(fitted)
    }

    /// Each level's hyperparameters, cheapest first: what
    /// [`CoKriging::with_hyperparameters`] takes.
    pub fn hyperparameters(&self) -> Vec<LevelHyperparameters> {
        self.levels
            .iter()
            .map(|l| LevelHyperparameters {
                length_scales: l.model.length_scales().to_vec(),
                process_variance: l.model.process_variance(),
                noise_variance: l.model.noise_variance(),
            })
            .collect()
    }

    /// Number of fidelity levels.
    pub fn n_levels(&self) -> usize {
        self.levels.len()
    }

    /// Index of the top (most faithful) level.
    pub fn top(&self) -> usize {
        self.levels.len() - 1
    }

    /// Posterior mean and variance (response units, units²) of level `level` at coded
    /// point `x`.
    pub fn predict_level(&self, level: usize, x: &[f64]) -> (f64, f64) {
        self.predict_up_to(level, x)[level]
    }

    /// Posterior mean and variance of every level from 0 to `level` at `x`, in one
    /// pass up the levels.
    fn predict_up_to(&self, level: usize, x: &[f64]) -> Vec<(f64, f64)> {
        let first = &self.levels[0].model;
        let (mut mean, mut variance) = (first.predict(x), first.predict_variance(x));
        let mut each = Vec::with_capacity(level + 1);
        each.push((mean, variance.max(0.0)));
        for t in 1..=level {
            let rho = self
                .scale_factor(t)
                .expect("levels above 0 have a scale factor");
            let Level {
                model,
                covariate_scale,
            } = &self.levels[t];
            let (c_mean, c_std) = covariate_scale.expect("levels above 0 have a covariate");
            let c = (mean - c_mean) / c_std;
            let delta_variance = model.predict_variance_given(x, Some(c));
            mean = model.predict_given(x, Some(c));
            variance = rho * rho * variance + delta_variance;
            each.push((mean, variance.max(0.0)));
        }
        each
    }

    /// Posterior mean of the top level at `x`, in response units.
    pub fn predict(&self, x: &[f64]) -> f64 {
        self.predict_level(self.top(), x).0
    }

    /// Posterior variance of the top level's latent surface at `x`, response units².
    pub fn predict_variance(&self, x: &[f64]) -> f64 {
        self.predict_level(self.top(), x).1
    }

    /// `ρ_t`, by which level `t`'s model scales level `t − 1`'s (response units of
    /// level `t` per unit of level `t − 1`); `None` for level 0.
    pub fn scale_factor(&self, level: usize) -> Option<f64> {
        let Level {
            model,
            covariate_scale,
        } = &self.levels[level];
        let (_, c_std) = (*covariate_scale)?;
        let beta = model.trend_coefficients();
        Some(beta[beta.len() - 1] / c_std)
    }

    /// The prior variance of level `level` at a point: `σ²_0`, then
    /// `ρ_t² σ²_{t−1} + σ²_δt`.
    fn prior_variance(&self, level: usize) -> f64 {
        let mut variance = self.levels[0].model.process_variance();
        for t in 1..=level {
            let rho = self
                .scale_factor(t)
                .expect("levels above 0 have a scale factor");
            variance = rho * rho * variance + self.levels[t].model.process_variance();
        }
        variance
    }

    /// The learned prior correlation between level `level − 1` and `level` at a point
    /// (see the module docs); `None` for level 0.
    pub fn correlation(&self, level: usize) -> Option<f64> {
        let rho = self.scale_factor(level)?;
        let below = self.prior_variance(level - 1);
        let here = self.prior_variance(level);
        (here > 0.0).then(|| rho * below.sqrt() / here.sqrt())
    }

    /// Level `level`'s own Kriging model: its length scales, noise and process
    /// variance are those of `δ_t` above level 0. Its predictions are not the level's
    /// (ask [`CoKriging::predict_level`]).
    pub fn level_model(&self, level: usize) -> &Kriging {
        &self.levels[level].model
    }

    /// Leave-one-out residuals of the top level's runs (lower levels held as fitted).
    pub fn loo_residuals(&self) -> Vec<f64> {
        self.levels[self.top()].model.loo_residuals()
    }
}

/// Runs whose points carry their fidelity level as a last coordinate (0 the cheapest),
/// split by level: points without it and responses, one pair per level up to the
/// highest present. How a study's runs reach [`crate::surrogate::Surrogate`].
pub fn split_by_level(x: &[Vec<f64>], y: &[f64]) -> Vec<(Vec<Vec<f64>>, Vec<f64>)> {
    let level_of = |p: &[f64]| p.last().map_or(0, |l| l.round().max(0.0) as usize);
    let n_levels = x.iter().map(|p| level_of(p) + 1).max().unwrap_or(0);
    let mut split = vec![(Vec::new(), Vec::new()); n_levels];
    for (p, v) in x.iter().zip(y) {
        let (xs, ys) = &mut split[level_of(p)];
        xs.push(p[..p.len() - 1].to_vec());
        ys.push(*v);
    }
    split
}

/// The nested subset of `m` of `points`: greedy maximin, starting from the point
/// nearest their centroid and adding each time the point farthest from those already
/// chosen (ties to the earlier index). Returns indices into `points`, in the order
/// chosen; all of them when `m ≥ points.len()`.
pub fn nested_subset(points: &[Vec<f64>], m: usize) -> Vec<usize> {
    let n = points.len();
    if m >= n {
        return (0..n).collect();
    }
    if m == 0 {
        return Vec::new();
    }
    let k = points[0].len();
    let centroid: Vec<f64> = (0..k)
        .map(|j| points.iter().map(|p| p[j]).sum::<f64>() / n as f64)
        .collect();
    let distance2 =
        |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(p, q)| (p - q).powi(2)).sum::<f64>();
    let first = (0..n)
        .min_by(|&a, &b| {
            distance2(&points[a], &centroid).total_cmp(&distance2(&points[b], &centroid))
        })
        .expect("at least one point");
    let mut chosen = vec![first];
    let mut nearest: Vec<f64> = points
        .iter()
        .map(|p| distance2(p, &points[first]))
        .collect();
    while chosen.len() < m {
        let next = (0..n)
            .filter(|i| !chosen.contains(i))
            .max_by(|&a, &b| nearest[a].total_cmp(&nearest[b]).then(b.cmp(&a)))
            .expect("fewer chosen than points");
        chosen.push(next);
        for (i, d) in nearest.iter_mut().enumerate() {
            *d = d.min(distance2(&points[i], &points[next]));
        }
    }
    chosen
}

/// A proposed run: where, at which fidelity level, and its augmented expected
/// improvement per unit of top-level cost.
#[derive(Debug, Clone, PartialEq)]
pub struct FidelityProposal {
    /// Coded point.
    pub point: Vec<f64>,
    /// The fidelity level to run it at (and every level below, to keep designs nested).
    pub level: usize,
    /// Its augmented expected improvement (response units, per cost of a top-level run).
    pub value: f64,
}

/// The effective best of the top level (Huang et al. 2006): the best of `μ ∓ s` over its
/// runs, so a lucky noisy observation does not set the bar.
fn effective_best(model: &CoKriging, goal: Goal) -> f64 {
    let top = model.level_model(model.top());
    let values = top.points().into_iter().map(|p| {
        let (mean, variance) = model.predict_level(model.top(), &p);
        match goal {
            Goal::Minimise => mean + variance.sqrt(),
            Goal::Maximise => mean - variance.sqrt(),
        }
    });
    match goal {
        Goal::Minimise => values.fold(f64::INFINITY, f64::min),
        Goal::Maximise => values.fold(f64::NEG_INFINITY, f64::max),
    }
}

/// The augmented expected improvement of a run at `level` and `x` (module docs);
/// `costs[l]` is the cost of one run at level `l` alone, in any unit.
pub fn augmented_expected_improvement(
    model: &CoKriging,
    costs: &[f64],
    x: &[f64],
    level: usize,
    best: f64,
    goal: Goal,
) -> f64 {
    let top = model.top();
    // Every level's prediction from one pass: the top's and the proposed level's.
    let each = model.predict_up_to(top, x);
    let (mean, variance) = each[top];
    let improvement = expected_improvement(mean, variance.sqrt(), best, goal);
    if improvement <= 0.0 {
        return 0.0;
    }
    let (_, level_variance) = each[level];
    let correlation = if level == top {
        1.0
    } else if variance > 0.0 {
        let rho: f64 = (level + 1..=top)
            .filter_map(|t| model.scale_factor(t))
            .product();
        (rho * level_variance.sqrt() / variance.sqrt())
            .abs()
            .min(1.0)
    } else {
        0.0
    };
    let noise = model.level_model(level).noise_variance();
    let noise_term = if noise > 0.0 {
        1.0 - noise.sqrt() / (level_variance + noise).sqrt()
    } else {
        1.0
    };
    let cumulative = |l: usize| costs[..=l].iter().sum::<f64>();
    improvement * correlation * noise_term * cumulative(top) / cumulative(level)
}

/// The run with the largest augmented expected improvement over `bounds` and every
/// level (`costs` one per level, cheapest first), weighted by the probability
/// `feasible` that constraints hold: a dense seeded random candidate set per level,
/// its best few polished by a bounded Nelder–Mead. `None` when nothing improves.
pub fn propose_fidelity(
    model: &CoKriging,
    costs: &[f64],
    bounds: &BoxBounds,
    goal: Goal,
    seed: u64,
    feasible: Feasibility<'_>,
) -> Option<FidelityProposal> {
    propose_apart(model, costs, bounds, goal, seed, feasible, &[])
}

/// A batch of `batch` runs by the kriging-believer heuristic over levels: propose
/// ([`propose_fidelity`]), pretend the model's means there were observed at the
/// proposed level and every level below (designs stay nested), rebuild with the same
/// hyperparameters, and repeat. No proposal lies within [`MIN_SEPARATION`] of the box
/// of a run or of another proposal; fewer than `batch` when nothing improves.
#[allow(clippy::too_many_arguments)]
pub fn propose_fidelity_batch(
    model: &CoKriging,
    costs: &[f64],
    bounds: &BoxBounds,
    batch: usize,
    goal: Goal,
    seed: u64,
    feasible: Feasibility<'_>,
) -> Vec<FidelityProposal> {
    let mut current = model.clone();
    let mut proposed: Vec<FidelityProposal> = Vec::with_capacity(batch);
    for round in 0..batch {
        let mut taken: Vec<Vec<f64>> = (0..current.n_levels())
            .flat_map(|t| current.level_model(t).points())
            .collect();
        taken.extend(proposed.iter().map(|p| p.point.clone()));
        let Some(proposal) = propose_apart(
            &current,
            costs,
            bounds,
            goal,
            seed.wrapping_add(round as u64),
            feasible,
            &taken,
        ) else {
            break;
        };
        let mut runs: Vec<(Vec<Vec<f64>>, Vec<f64>)> = (0..current.n_levels())
            .map(|t| {
                let m = current.level_model(t);
                (m.points(), m.responses().to_vec())
            })
            .collect();
        for (t, (x, y)) in runs.iter_mut().enumerate().take(proposal.level + 1) {
            x.push(proposal.point.clone());
            y.push(current.predict_level(t, &proposal.point).0);
        }
        proposed.push(proposal);
        let level_runs: Vec<LevelRuns<'_>> = runs.iter().map(|(x, y)| LevelRuns { x, y }).collect();
        let first = current.level_model(0);
        match CoKriging::with_hyperparameters(
            &level_runs,
            first.kernel(),
            first.trend(),
            &current.hyperparameters(),
        ) {
            Ok(believed) => current = believed,
            Err(_) => break,
        }
    }
    proposed
}

/// [`propose_fidelity`] keeping [`MIN_SEPARATION`] of the box from every point of `taken`.
fn propose_apart(
    model: &CoKriging,
    costs: &[f64],
    bounds: &BoxBounds,
    goal: Goal,
    seed: u64,
    feasible: Feasibility<'_>,
    taken: &[Vec<f64>],
) -> Option<FidelityProposal> {
    assert_eq!(costs.len(), model.n_levels(), "one cost per fidelity level");
    let k = bounds.lower.len();
    let apart = |p: &[f64]| {
        taken.iter().all(|q| {
            let d2: f64 = (0..k)
                .map(|j| {
                    let width = bounds.upper[j] - bounds.lower[j];
                    if width > 0.0 {
                        ((p[j] - q[j]) / width).powi(2)
                    } else {
                        0.0
                    }
                })
                .sum();
            d2.sqrt() >= MIN_SEPARATION
        })
    };
    let best = effective_best(model, goal);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let candidates: Vec<Vec<f64>> = (0..1000 + 500 * k)
        .map(|_| {
            (0..k)
                .map(|j| rng.random_range(bounds.lower[j]..=bounds.upper[j]))
                .collect::<Vec<f64>>()
        })
        .filter(|p| apart(p))
        .collect();
    let step: Vec<f64> = (0..k)
        .map(|j| 0.05 * (bounds.upper[j] - bounds.lower[j]))
        .collect();
    let mut found: Option<FidelityProposal> = None;
    for level in 0..model.n_levels() {
        // Zero inside a taken point's neighbourhood, so the local search stays out.
        let negative = |p: &[f64]| {
            if !apart(p) {
                return 0.0;
            }
            -augmented_expected_improvement(model, costs, p, level, best, goal) * feasible(p)
        };
        let mut scored: Vec<(f64, &Vec<f64>)> =
            candidates.iter().map(|p| (negative(p), p)).collect();
        scored.sort_by(|a, b| a.0.total_cmp(&b.0));
        for &(start_value, start) in scored.iter().take(4) {
            let polished = nelder_mead(
                &negative,
                start,
                &step,
                &bounds.lower,
                &bounds.upper,
                Stop {
                    max_evaluations: 100 * (k + 1),
                    f_tolerance: 1e-12,
                    x_tolerance: 1e-10,
                },
            );
            let (point, value) = if polished.1 <= start_value {
                polished
            } else {
                (start.clone(), start_value)
            };
            let value = -value;
            if value > 0.0 && found.as_ref().is_none_or(|f| value > f.value) {
                found = Some(FidelityProposal {
                    point,
                    level,
                    value,
                });
            }
        }
    }
    found
}

#[cfg(test)]
#[path = "co_kriging_tests.rs"]
mod tests;
