//! Kriging over text factors: one Gaussian process per combination of levels.
//!
//! A Gaussian process correlates runs by their distance. Between two levels of a text
//! factor (a Hertz or a Hooke contact, mesh A or mesh B) there is no distance: their
//! order in the study file is arbitrary, so any correlation length over a coded
//! level coordinate would be an artefact of that order. Each combination of levels
//! therefore gets its own model over the numeric factors, with its own trend,
//! length scales, variance and nugget, fitted to that combination's runs only. What
//! this gives up is borrowing strength across levels (a model with a fitted
//! between-level correlation could); what it keeps is that nothing depends on how the
//! levels were listed. The polynomial candidates handle text factors with indicator
//! terms instead (see [`crate::basis`]).

use crate::fit::{Interval, Quality};
use crate::kriging::KrigingError;
use crate::kriging::{Kriging, KrigingOptions};
use crate::levels::{combination_of, combinations, numeric_factors, numeric_part};
use crate::surrogate::normal_interval;

/// Why Kriging per combination of text levels cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PerLevelError {
    /// No numeric factor to correlate runs over.
    #[error("every factor is text: Kriging needs a numeric factor to correlate runs over; the polynomials' indicator terms fit text factors")]
    AllText,
    /// A combination of levels has no runs.
    #[error("{combination} has no runs; every combination of levels needs its own")]
    NoRuns {
        /// The combination, as [`combination_name`] writes it.
        combination: String,
    },
    /// No hyperparameters were given for a combination.
    #[error("no model for {combination}")]
    NoModel {
        /// The combination, as [`combination_name`] writes it.
        combination: String,
    },
    /// A combination's Kriging model failed.
    #[error("at {combination}: {source}")]
    Combination {
        /// The combination, as [`combination_name`] writes it.
        combination: String,
        /// Why its model failed.
        source: KrigingError,
    },
}

/// Independent Kriging models, one per combination of the text factors' levels.
#[derive(Debug, Clone)]
pub struct KrigingPerLevel {
    /// Levels of each factor, 0 for numeric ([`crate::levels`]).
    levels: Vec<u32>,
    /// Each combination (one level per text factor) and its model over the numeric
    /// factors.
    models: Vec<(Vec<u32>, Kriging)>,
    /// R², leave-one-out residuals and σ_cross over every run.
    quality: Quality,
}

/// A combination written for people, levels counted from 1: `[1, 3]`.
pub fn combination_name(combination: &[u32]) -> String {
    let levels: Vec<String> = combination.iter().map(|l| (l + 1).to_string()).collect();
    format!("levels [{}]", levels.join(", "))
}

impl KrigingPerLevel {
    /// Fits one model per combination of `levels` to the runs (coded `x`, responses
    /// `y`) at that combination. The error names the combination that could not be
    /// fitted and why.
    pub fn fit(
        levels: &[u32],
        x: &[Vec<f64>],
        y: &[f64],
        options: &KrigingOptions,
    ) -> Result<KrigingPerLevel, PerLevelError> {
        KrigingPerLevel::build(levels, x, y, |combination, xs, ys| {
            Kriging::fit(xs, ys, options).map_err(|source| PerLevelError::Combination {
                combination: combination_name(combination),
                source,
            })
        })
    }

    /// The same kind of model with each combination's hyperparameters given (as
    /// [`KrigingPerLevel::models`] returns them), nothing searched.
    pub fn with_hyperparameters(
        levels: &[u32],
        hyperparameters: &[(Vec<u32>, Kriging)],
        x: &[Vec<f64>],
        y: &[f64],
    ) -> Result<KrigingPerLevel, PerLevelError> {
        KrigingPerLevel::build(levels, x, y, |combination, xs, ys| {
            let (_, model) = hyperparameters
                .iter()
                .find(|(c, _)| c == combination)
                .ok_or_else(|| PerLevelError::NoModel {
                    combination: combination_name(combination),
                })?;
            model
                .refit(xs, ys)
                .map_err(|source| PerLevelError::Combination {
                    combination: combination_name(combination),
                    source,
                })
        })
    }

    fn build(
        levels: &[u32],
        x: &[Vec<f64>],
        y: &[f64],
        fit: impl Fn(&[u32], &[Vec<f64>], &[f64]) -> Result<Kriging, PerLevelError>,
    ) -> Result<KrigingPerLevel, PerLevelError> {
        let k = x.first().map_or(levels.len(), Vec::len);
        if numeric_factors(levels, k).is_empty() {
            return Err(PerLevelError::AllText);
        }
        let at: Vec<Vec<u32>> = x.iter().map(|p| combination_of(levels, p)).collect();
        let mut models = Vec::new();
        let mut loo = vec![0.0; y.len()];
        for combination in combinations(levels) {
            let runs: Vec<usize> = (0..y.len()).filter(|&i| at[i] == combination).collect();
            if runs.is_empty() {
                return Err(PerLevelError::NoRuns {
                    combination: combination_name(&combination),
                });
            }
            let xs: Vec<Vec<f64>> = runs.iter().map(|&i| numeric_part(levels, &x[i])).collect();
            let ys: Vec<f64> = runs.iter().map(|&i| y[i]).collect();
            let model = fit(&combination, &xs, &ys)?;
            for (&i, e) in runs.iter().zip(model.loo_residuals()) {
                loo[i] = e;
            }
            models.push((combination, model));
        }
        let mut fitted = KrigingPerLevel {
            levels: levels.to_vec(),
            models,
            quality: Quality {
                runs: y.len(),
                terms: 0,
                r2: f64::NAN,
                adjusted_r2: None,
                residual_std: None,
                loo_residuals: None,
                press: None,
                sigma_cross_percent: None,
                r2_cross: None,
            },
        };
        fitted.quality = fitted.quality_on(x, y, loo);
        Ok(fitted)
    }

    fn quality_on(&self, x: &[Vec<f64>], y: &[f64], loo: Vec<f64>) -> Quality {
        let n = y.len();
        let mean = y.iter().sum::<f64>() / n as f64;
        let ss_tot: f64 = y.iter().map(|v| (v - mean).powi(2)).sum();
        let ss_res: f64 = x
            .iter()
            .zip(y)
            .map(|(p, v)| (v - self.predict(p)).powi(2))
            .sum();
        let press: f64 = loo.iter().map(|e| e * e).sum();
        let spread = if n > 1 {
            (ss_tot / (n - 1) as f64).sqrt()
        } else {
            0.0
        };
        let sigma_cross_percent =
            (spread > 0.0).then(|| 100.0 * (press / n as f64).sqrt() / spread);
        let pooled_noise = self
            .models
            .iter()
            .map(|(_, m)| m.noise_variance() * m.n_runs() as f64)
            .sum::<f64>()
            / n as f64;
        Quality {
            runs: n,
            terms: self.parameters(),
            r2: if ss_tot > 0.0 {
                1.0 - ss_res / ss_tot
            } else {
                1.0
            },
            adjusted_r2: None,
            residual_std: Some(pooled_noise.sqrt()),
            loo_residuals: Some(loo),
            press: Some(press),
            sigma_cross_percent,
            r2_cross: sigma_cross_percent.map(|s| 1.0 - (s / 100.0).powi(2)),
        }
    }

    /// The model of the combination coded point `x` is at, and `x`'s numeric part.
    fn model_at(&self, x: &[f64]) -> (&Kriging, Vec<f64>) {
        let combination = combination_of(&self.levels, x);
        let model = self
            .models
            .iter()
            .find(|(c, _)| *c == combination)
            .map(|(_, m)| m)
            .expect("every combination of levels has a model");
        (model, numeric_part(&self.levels, x))
    }

    /// Posterior mean at coded point `x`, response units.
    pub fn predict(&self, x: &[f64]) -> f64 {
        let (model, numeric) = self.model_at(x);
        model.predict(&numeric)
    }

    /// Posterior standard deviation of the mean surface at `x`.
    pub fn mean_std(&self, x: &[f64]) -> f64 {
        let (model, numeric) = self.model_at(x);
        model.predict_variance(&numeric).max(0.0).sqrt()
    }

    /// The interval holding a new run at `x` with probability `confidence`.
    pub fn prediction_interval(&self, x: &[f64], confidence: f64) -> Interval {
        let (model, numeric) = self.model_at(x);
        normal_interval(
            model.predict(&numeric),
            model.predict_variance(&numeric).max(0.0) + model.noise_variance(),
            confidence,
        )
    }

    /// Quality over every run.
    pub fn quality(&self) -> &Quality {
        &self.quality
    }

    /// Parameters fitted over all models (trend, length scales, variance, nugget).
    pub fn parameters(&self) -> usize {
        self.models
            .iter()
            .map(|(_, m)| m.trend_coefficients().len() + m.length_scales().len() + 2)
            .sum()
    }

    /// Levels of each factor.
    pub fn levels(&self) -> &[u32] {
        &self.levels
    }

    /// Each combination and its model.
    pub fn models(&self) -> &[(Vec<u32>, Kriging)] {
        &self.models
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::levels::{coded_level, cross};

    /// x numeric, m text with 3 levels: a different curve at each level.
    fn runs() -> (Vec<Vec<f64>>, Vec<f64>) {
        let numeric: Vec<Vec<f64>> = (0..7).map(|i| vec![-1.0 + i as f64 / 3.0]).collect();
        let x = cross(&[0, 3], 2, &numeric);
        let truth = |p: &[f64]| match crate::levels::level_of(p[1], 3) {
            0 => p[0].sin(),
            1 => 5.0 + p[0] * p[0],
            _ => -3.0 * p[0],
        };
        let y = x.iter().map(|p| truth(p)).collect();
        (x, y)
    }

    #[test]
    fn each_level_has_its_own_curve_and_the_levels_do_not_mix() {
        let (x, y) = runs();
        let options = KrigingOptions {
            nugget: crate::kriging::Nugget::Fixed(0.0),
            ..KrigingOptions::default()
        };
        let model = KrigingPerLevel::fit(&[0, 3], &x, &y, &options).unwrap();
        assert_eq!(model.models().len(), 3);
        // Between the runs, each level follows its own curve.
        let at = |v: f64, level: u32| model.predict(&[v, coded_level(level, 3)]);
        assert!((at(0.1, 0) - 0.1f64.sin()).abs() < 0.02, "{}", at(0.1, 0));
        assert!((at(0.1, 1) - 5.01).abs() < 0.05, "{}", at(0.1, 1));
        assert!((at(0.1, 2) + 0.3).abs() < 0.02, "{}", at(0.1, 2));
        assert!(model.quality().r2 > 0.999);
        assert_eq!(model.quality().loo_residuals.as_ref().unwrap().len(), 21);
        // The same model with its hyperparameters, no search, predicts the same.
        let again = KrigingPerLevel::with_hyperparameters(&[0, 3], model.models(), &x, &y).unwrap();
        assert!((again.predict(&[0.1, 0.0]) - at(0.1, 1)).abs() < 1e-9);
    }

    #[test]
    fn a_combination_without_runs_or_a_design_of_text_only_is_refused_with_why() {
        let (x, y) = runs();
        let without_third: Vec<usize> = (0..x.len()).filter(|&i| x[i][1] < 0.5).collect();
        let xs: Vec<Vec<f64>> = without_third.iter().map(|&i| x[i].clone()).collect();
        let ys: Vec<f64> = without_third.iter().map(|&i| y[i]).collect();
        let error =
            KrigingPerLevel::fit(&[0, 3], &xs, &ys, &KrigingOptions::default()).unwrap_err();
        assert_eq!(
            error,
            PerLevelError::NoRuns {
                combination: "levels [3]".into()
            }
        );
        assert_eq!(
            error.to_string(),
            "levels [3] has no runs; every combination of levels needs its own"
        );
        let text_only: Vec<Vec<f64>> = x.iter().map(|p| vec![p[1]]).collect();
        let error =
            KrigingPerLevel::fit(&[3], &text_only, &y, &KrigingOptions::default()).unwrap_err();
        assert_eq!(error, PerLevelError::AllText);
        assert!(
            error.to_string().starts_with("every factor is text"),
            "{error}"
        );
    }
}
