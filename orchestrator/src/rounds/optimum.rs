//! The optimum of a round's objective: on its value, or robust (mean ∓ k·std under
//! the uncertain inputs), subject to bounds on responses, some of them probabilistic.

use orch_metamodel::robust::Scenarios;
use orch_metamodel::{
    optimise_subject_to, student_t_quantile, Constraint, FactorRange, Goal, Optimum,
};

use super::objective::{Inputs, ObjectiveSurface};
use crate::study::Study;

/// Scenarios of the uncertain inputs every candidate design is judged on by a robust
/// objective or a probabilistic bound (the final probabilities use the study's
/// `uncertainty.samples`, at most 10^5).
pub const ROBUST_SCENARIOS: usize = 256;

/// A function of the coded factors: a constrained response's surface, or a quantile of
/// it under the uncertain inputs.
type Predictor<'a> = Box<dyn Fn(&[f64]) -> f64 + 'a>;

/// What the search found.
pub(crate) struct Found {
    /// The optimum; its value is the objective's at the uncertain inputs' means (also
    /// for a robust objective).
    pub optimum: Optimum,
    /// True when every bound holds there.
    pub feasible: bool,
    /// Each constrained response (or its quantile) there, against its bound.
    pub at_bounds: Vec<String>,
    /// For a robust objective its mean and spread there, and each probabilistic bound's
    /// Monte Carlo probability of being passed.
    pub robustness: Vec<String>,
}

/// The optimum of `surface` in the round's box (`ranges`) over `inputs`' bounds.
pub(crate) fn find(
    study: &Study,
    surface: &ObjectiveSurface<'_>,
    inputs: &Inputs,
    ranges: &[FactorRange],
) -> Found {
    let objective = surface.objective;
    // Robust design and probabilistic bounds judge every candidate on one set of
    // scenarios of the uncertain factors and tolerances (common random numbers).
    let scenarios = (objective.robust.is_some()
        || objective.probabilities.iter().any(Option::is_some))
    .then(|| {
        Scenarios::draw(
            &inputs.uncertain,
            &inputs.tolerances,
            ranges,
            ROBUST_SCENARIOS,
            study.seed.wrapping_add(0x5eed),
        )
        .ok()
    })
    .flatten();
    // One predictor per constrained response: its value, or for a probabilistic bound
    // the quantile that must stay inside it (normal approximation over the scenarios).
    let predictors: Vec<Predictor<'_>> = objective
        .constraints
        .iter()
        .zip(&objective.probabilities)
        .map(|((response, min, _), probability)| {
            let fit = &surface.surfaces[response];
            match (probability, &scenarios) {
                (Some(p), Some(scenarios)) => {
                    let z = student_t_quantile(1.0 - p, 1e9);
                    let sign = if min.is_some() { -1.0 } else { 1.0 };
                    Box::new(move |x: &[f64]| {
                        let (mean, std) = scenarios.moments(&|y| fit.predict(y), x);
                        mean + sign * z * std
                    }) as Predictor<'_>
                }
                _ => Box::new(move |x: &[f64]| fit.predict(x)),
            }
        })
        .collect();
    let constraints: Vec<Constraint> = objective
        .constraints
        .iter()
        .zip(&predictors)
        .map(|((_, min, max), g)| Constraint {
            g: g.as_ref(),
            min: *min,
            max: *max,
        })
        .collect();
    let value = |x: &[f64]| surface.value(x);
    let robust = objective.robust.zip(scenarios.as_ref());
    let robust_value = |x: &[f64]| match robust {
        Some((k, scenarios)) => {
            let (mean, std) = scenarios.moments(&value, x);
            match objective.goal {
                Goal::Maximise => mean - k * std,
                Goal::Minimise => mean + k * std,
            }
        }
        None => value(x),
    };
    let exact = scenarios.is_none()
        && objective
            .responses()
            .iter()
            .all(|r| surface.surfaces[r].is_quadratic());
    let (mut optimum, feasible) = optimise_subject_to(
        &robust_value,
        exact,
        &constraints,
        objective.goal,
        &inputs.bounds,
        study.seed,
    );
    // What a robust optimum gives up for its robustness, and each probabilistic
    // bound's Monte Carlo probability of being passed there.
    let mut robustness = Vec::new();
    if let Some((k, scenarios)) = robust {
        let (mean, std) = scenarios.moments(&value, &optimum.x);
        robustness.push(format!(
            "robust optimum: mean {mean:.6}, std {std:.6} under the uncertain inputs ({} scenarios), mean {} {k}·std = {:.6}",
            scenarios.len(),
            if objective.goal == Goal::Maximise { "−" } else { "+" },
            optimum.value
        ));
        optimum.value = value(&optimum.x);
    }
    if scenarios.is_some() {
        robustness.extend(failure_probabilities(
            study, surface, inputs, ranges, &optimum.x,
        ));
    }
    // What each constrained response is predicted to be there, against its bound.
    let at_bounds = objective
        .constraints
        .iter()
        .zip(&predictors)
        .zip(&objective.probabilities)
        .map(|(((response, min, max), g), probability)| {
            let bound = match (min, max) {
                (Some(min), Some(max)) => format!("bound [{min}, {max}]"),
                (Some(min), None) => format!("bound ≥ {min}"),
                (None, Some(max)) => format!("bound ≤ {max}"),
                (None, None) => "no bound".to_string(),
            };
            let what = match probability {
                Some(p) if min.is_some() => format!("{response}'s {p} quantile"),
                Some(p) => format!("{response}'s {} quantile", 1.0 - p),
                None => response.clone(),
            };
            format!("{what} = {:.6} ({bound})", g(&optimum.x))
        })
        .collect();
    Found {
        optimum,
        feasible,
        at_bounds,
        robustness,
    }
}

/// Each probabilistic bound's probability of being passed at `x`, by Monte Carlo over
/// the study's `uncertainty.samples` (at most 10^5) with its standard error.
fn failure_probabilities(
    study: &Study,
    surface: &ObjectiveSurface<'_>,
    inputs: &Inputs,
    ranges: &[FactorRange],
    x: &[f64],
) -> Vec<String> {
    let objective = surface.objective;
    let samples = study
        .uncertainty
        .as_ref()
        .map_or(0, |u| u.samples)
        .clamp(ROBUST_SCENARIOS, 100_000);
    let Ok(scenarios) = Scenarios::draw(
        &inputs.uncertain,
        &inputs.tolerances,
        ranges,
        samples,
        study.seed.wrapping_add(0xfa11),
    ) else {
        return Vec::new();
    };
    objective
        .constraints
        .iter()
        .zip(&objective.probabilities)
        .filter_map(|((response, min, max), probability)| {
            let (Some(allowed), Some(limit)) = (probability, max.or(*min)) else {
                return None;
            };
            let fit = &surface.surfaces[response];
            let above = max.is_some();
            let (p, se) = scenarios.exceedance(&|y| fit.predict(y), x, limit, above);
            Some(format!(
                "P[{response} {} {limit}] = {p:.4} ± {se:.4} ({} samples; allowed {allowed})",
                if above { ">" } else { "<" },
                scenarios.len()
            ))
        })
        .collect()
}
