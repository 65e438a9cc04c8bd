//! The objective over a round's surrogates, and the inputs it is uncertain in.

use std::collections::HashMap;

use orch_metamodel::optimise::BoxBounds;
use orch_metamodel::surrogate::Surrogate;
use orch_metamodel::{propagate, propagate_with_error, Distribution, FactorRange, Spread};

use crate::study::{mean_of, Objective, Study};

/// Two-sided 95 % normal quantile.
const Z_95: f64 = 1.959_963_984_540_054;

/// The objective (a weighted sum of responses) over the round's surrogates, in coded
/// units of the round's box.
pub(crate) struct ObjectiveSurface<'a> {
    /// The study's objective.
    pub objective: &'a Objective,
    /// Each response's surrogate.
    pub surfaces: &'a HashMap<String, Surrogate>,
}

impl ObjectiveSurface<'_> {
    /// The objective's value at `x`.
    pub fn value(&self, x: &[f64]) -> f64 {
        self.objective
            .terms
            .iter()
            .map(|(r, w)| w * self.surfaces[r].predict(x))
            .sum()
    }

    /// `sqrt(Σ (w · each(surrogate))²)`: a standard error of the weighted sum of
    /// independent surrogates; `None` when one has none.
    fn combine(&self, each: &dyn Fn(&Surrogate) -> Option<f64>) -> Option<f64> {
        self.objective
            .terms
            .iter()
            .map(|(r, w)| each(&self.surfaces[r]).map(|s| (w * s).powi(2)))
            .sum::<Option<f64>>()
            .map(f64::sqrt)
    }

    /// The standard error of the objective at `x` as an estimate of the mean response
    /// (the surrogates' own error).
    pub fn mean_std(&self, x: &[f64]) -> Option<f64> {
        self.combine(&|s| s.mean_std(x))
    }

    /// The 95 % prediction interval of a new run's objective at `x`: surrogate error and
    /// run-to-run noise.
    pub fn prediction_interval(&self, x: &[f64]) -> Option<(f64, f64)> {
        if let [(response, weight)] = self.objective.terms.as_slice() {
            let i = self.surfaces[response].prediction_interval(x, 0.95)?;
            let (a, b) = (weight * i.low, weight * i.high);
            return Some((a.min(b), a.max(b)));
        }
        let std = self.combine(&|s| s.prediction_interval(x, 0.95).map(|i| i.std_error))?;
        let value = self.value(x);
        Some((value - Z_95 * std, value + Z_95 * std))
    }

    /// The spread of the objective at `optimum` (coded) under the factors `study`
    /// holds at their mean: from the inputs alone, and with the surrogates' own error
    /// drawn at every sample (same seed). `(None, None)` without such factors.
    pub fn spread_at(
        &self,
        study: &Study,
        optimum: &[f64],
        ranges: &[FactorRange],
    ) -> (Option<Spread>, Option<Spread>) {
        // Materials and tolerances have a noise design of their own after the rounds.
        let Some(u) = study
            .uncertainty
            .as_ref()
            .filter(|u| !u.parameters.is_empty())
        else {
            return (None, None);
        };
        let inputs: Vec<Distribution> = u.parameters.iter().map(|(_, d)| *d).collect();
        let at = |sample: &[f64]| {
            let mut x = optimum.to_vec();
            for ((index, _), v) in u.parameters.iter().zip(sample) {
                x[*index] = ranges[*index].to_coded(*v);
            }
            x
        };
        let inputs_only = propagate(&|s| self.value(&at(s)), &inputs, u.samples, u.seed).ok();
        let with_error = |s: &[f64]| {
            let x = at(s);
            (self.value(&x), self.mean_std(&x).unwrap_or(0.0))
        };
        let total = propagate_with_error(&with_error, &inputs, u.samples, u.seed).ok();
        (inputs_only, total)
    }
}

/// What a round is uncertain in: the factors held at their mean while the others are
/// optimised (the optimiser's `bounds` fix them there) and the factors with a
/// manufacturing tolerance.
pub(crate) struct Inputs {
    /// `(factor, distribution in natural units)` held at their mean.
    pub uncertain: Vec<(usize, Distribution)>,
    /// `(factor, standard deviation in natural units)`.
    pub tolerances: Vec<(usize, f64)>,
    /// The coded box with the uncertain factors fixed at their mean.
    pub bounds: BoxBounds,
}

impl Inputs {
    /// The inputs of `study` in a round whose box is `ranges`.
    pub fn of(study: &Study, ranges: &[FactorRange]) -> Inputs {
        let uncertain: Vec<(usize, Distribution)> = study
            .uncertainty
            .iter()
            .flat_map(|u| u.parameters.iter().copied())
            .collect();
        let tolerances = study
            .uncertainty
            .iter()
            .flat_map(|u| u.noise.iter().flat_map(|n| n.tolerances.iter().copied()))
            .collect();
        Inputs {
            bounds: held_at_mean(&uncertain, ranges).with_levels(&study.levels()),
            uncertain,
            tolerances,
        }
    }
}

/// The coded box of `ranges` with each of `uncertain` fixed at its mean.
pub(crate) fn held_at_mean(
    uncertain: &[(usize, Distribution)],
    ranges: &[FactorRange],
) -> BoxBounds {
    let mut bounds = BoxBounds::coded(ranges.len());
    for (index, distribution) in uncertain {
        let centre = ranges[*index]
            .to_coded(mean_of(distribution))
            .clamp(-1.0, 1.0);
        bounds.lower[*index] = centre;
        bounds.upper[*index] = centre;
    }
    bounds
}
