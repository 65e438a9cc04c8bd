//! What the next round runs, and the stopping rule that says there is none.

use std::collections::HashMap;

use orch_metamodel::improvement::probability_within;
use orch_metamodel::propose::{least_certain, shrink_around};
use orch_metamodel::surrogate::Surrogate;
use orch_metamodel::{
    propose_batch, propose_fidelity_batch, FactorRange, FidelityProposal, Goal, KrigingOptions,
    Optimum,
};

use super::objective::{held_at_mean, Inputs, ObjectiveSurface};
use super::Observed;
use crate::study::{nested_points, DesignPoint, Study};

/// The next round's box and design points, and how they were chosen (for the note).
pub(crate) struct NextRound {
    /// Its box, natural units.
    pub ranges: Vec<FactorRange>,
    /// Its design points (test points are added by the caller).
    pub points: Vec<DesignPoint>,
    /// How they were chosen, for people.
    pub how: String,
}

/// The next round after `round`, whose optimum is `optimum` at `natural`: a Kriging
/// objective proposes a kriging-believer batch of expected-improvement points, one
/// per job slot, in the same box; a polynomial one the design again in a box `shrink`
/// times as wide around the optimum (uncertain factors keep their range). Both add
/// `max(1, k/2)` runs where the objective's surrogate is least certain, so that the
/// next round tests it where it knows least.
#[allow(clippy::too_many_arguments)]
pub(crate) fn propose(
    study: &Study,
    surface: &ObjectiveSurface<'_>,
    inputs: &Inputs,
    data: &HashMap<String, Observed>,
    options: &KrigingOptions,
    ranges: &[FactorRange],
    natural: &[f64],
    round: i64,
) -> NextRound {
    let k = ranges.len();
    let objective = surface.objective;
    let goal_of = |weight: f64| match (objective.goal, weight >= 0.0) {
        (goal, true) => goal,
        (Goal::Maximise, false) => Goal::Minimise,
        (Goal::Minimise, false) => Goal::Maximise,
    };
    // Expected improvement weighted by the probability that every constraint holds,
    // each from its own surface's mean and standard error.
    let feasible = |p: &[f64]| {
        objective
            .constraints
            .iter()
            .filter_map(|(name, min, max)| {
                let surface = surface.surfaces.get(name)?;
                Some(probability_within(
                    surface.predict(p),
                    surface.mean_std(p),
                    *min,
                    *max,
                ))
            })
            .product::<f64>()
    };
    if let [(response, weight)] = objective.terms.as_slice() {
        if let Surrogate::CoKriging { model, .. } = &surface.surfaces[response] {
            let costs: Vec<f64> = study.fidelities.iter().map(|f| f.cost).collect();
            let proposals = propose_fidelity_batch(
                model,
                &costs,
                &inputs.bounds,
                study.executor.max_parallel.max(2),
                goal_of(*weight),
                study.seed.wrapping_add(round as u64),
                &feasible,
            );
            if !proposals.is_empty() {
                return fidelity_batch(study, ranges, &proposals);
            }
        }
    }
    let kriging = match objective.terms.as_slice() {
        [(response, weight)] => match &surface.surfaces[response] {
            Surrogate::Kriging { model, .. } => Some((response, model, goal_of(*weight))),
            // A polynomial's next box is the design again around the optimum; a
            // per-level Kriging has no one model to propose a batch from.
            Surrogate::Polynomial(_)
            | Surrogate::KrigingPerLevel(_)
            | Surrogate::CoKriging { .. } => None,
        },
        _ => None,
    };
    let (next_ranges, mut coded, how) = match kriging {
        Some((response, model, goal)) => {
            let batch = study.executor.max_parallel.max(2);
            let (x, y) = &data[response].design;
            let seed = study.seed.wrapping_add(round as u64);
            let points = propose_batch(
                model,
                x,
                y,
                &inputs.bounds,
                batch,
                goal,
                seed,
                options,
                &feasible,
            );
            let how = format!(
                "{} expected-improvement points (a kriging-believer batch, one per job slot) in the same box",
                points.len()
            );
            (ranges.to_vec(), points, how)
        }
        None => {
            let limits: Vec<FactorRange> = study.factors.iter().map(|f| f.range).collect();
            let mut next = study.text_kept_whole(shrink_around(
                natural,
                ranges,
                &limits,
                study.metamodel.shrink,
            ));
            for (index, _) in &inputs.uncertain {
                next[*index] = ranges[*index];
            }
            let design = study
                .coded_design(&study.design)
                .expect("the design was built for round 0");
            let how = format!(
                "a box {} times as wide around the optimum",
                study.metamodel.shrink
            );
            (next, design, how)
        }
    };
    // Where the current surrogate is least certain, in the next box's coded units.
    let to_current = |c: &[f64]| -> Vec<f64> {
        c.iter()
            .zip(&next_ranges)
            .zip(ranges)
            .map(|((c, next), now)| now.to_coded(next.to_natural(*c)))
            .collect()
    };
    let probes = if surface.mean_std(&to_current(&vec![0.0; k])).is_some() {
        least_certain(
            &|c| surface.mean_std(&to_current(c)).unwrap_or(0.0),
            &held_at_mean(&inputs.uncertain, &next_ranges),
            &coded,
            (k / 2).max(1),
            0.25,
            study.seed.wrapping_add(31 * round as u64),
        )
    } else {
        Vec::new()
    };
    let probed = probes.len();
    coded.extend(probes);
    let points = coded
        .into_iter()
        .map(|coded| study.point(coded, &next_ranges))
        .collect();
    // Over fidelity levels the design runs at the first level and nested subsets of
    // it at the others, as in the first round.
    let points = nested_points(points, &study.fidelities);
    NextRound {
        ranges: next_ranges,
        points,
        how: format!(
            "{how}, and {probed} run{} where the surrogate is least certain",
            if probed == 1 { "" } else { "s" }
        ),
    }
}

/// The next round of a co-Kriging objective: each proposed point at its level and
/// every level below (designs stay nested), in the same box.
fn fidelity_batch(
    study: &Study,
    ranges: &[FactorRange],
    proposals: &[FidelityProposal],
) -> NextRound {
    let mut points = Vec::new();
    for level in 0..study.fidelities.len() {
        points.extend(
            proposals
                .iter()
                .filter(|p| p.level >= level)
                .map(|p| DesignPoint {
                    fidelity: level as u32,
                    ..study.point(p.point.clone(), ranges)
                }),
        );
    }
    let mut per_level: Vec<String> = Vec::new();
    for (level, fidelity) in study.fidelities.iter().enumerate() {
        let n = proposals.iter().filter(|p| p.level == level).count();
        if n > 0 {
            per_level.push(format!("{n} up to {}", fidelity.name));
        }
    }
    NextRound {
        ranges: ranges.to_vec(),
        points,
        how: format!(
            "{} points of largest cost-weighted expected improvement over the fidelity levels ({}; each also run at the levels below) in the same box",
            proposals.len(),
            per_level.join(", ")
        ),
    }
}

/// The stopping rule's second half: when this round's surrogate predicts the new
/// optimum better than the previous round's (`before`, natural units) by less than the
/// half-width of its own 95 % confidence interval there, another round would chase
/// the surrogate's noise; says so, or `None` to go on.
pub(crate) fn unresolved_gain(
    before: &[f64],
    ranges: &[FactorRange],
    optimum: &Optimum,
    goal: Goal,
    value: &dyn Fn(&[f64]) -> f64,
    mean_std: &dyn Fn(&[f64]) -> Option<f64>,
) -> Option<String> {
    let previous: Vec<f64> = before
        .iter()
        .zip(ranges)
        .map(|(v, r)| r.to_coded(*v).clamp(-1.0, 1.0))
        .collect();
    let gain = match goal {
        Goal::Maximise => optimum.value - value(&previous),
        Goal::Minimise => value(&previous) - optimum.value,
    };
    let half_width = 1.959_963_984_540_054 * mean_std(&optimum.x)?;
    (gain < half_width).then(|| {
        format!(
            "the surface predicts the new optimum better than the previous round's by {gain:.6}, within its own 95 % interval (±{half_width:.6}); another round would chase noise"
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_gain_within_the_surrogates_own_interval_stops_the_rounds() {
        // value = −(x − 0.2)²; the previous optimum at x = 0 (natural 10 in [0, 20]
        // coded 0) is worse by 0.04 than the new one at x = 0.2.
        let value = |x: &[f64]| -(x[0] - 0.2).powi(2);
        let optimum = orch_metamodel::Optimum {
            x: vec![0.2],
            value: 0.0,
            exact: true,
        };
        let ranges = [FactorRange {
            min: 0.0,
            max: 20.0,
        }];
        // A standard error of 0.05 makes ±0.098: the gain of 0.04 is noise.
        let note = unresolved_gain(&[10.0], &ranges, &optimum, Goal::Maximise, &value, &|_| {
            Some(0.05)
        });
        assert!(note
            .unwrap()
            .contains("within its own 95 % interval (±0.097998)"));
        // A standard error of 0.01 (±0.0196) resolves it: go on.
        assert!(
            unresolved_gain(&[10.0], &ranges, &optimum, Goal::Maximise, &value, &|_| {
                Some(0.01)
            })
            .is_none()
        );
        // Minimising the negative is the same question.
        let negative = |x: &[f64]| -value(x);
        let minimum = orch_metamodel::Optimum {
            value: 0.0,
            ..optimum
        };
        assert!(unresolved_gain(
            &[10.0],
            &ranges,
            &minimum,
            Goal::Minimise,
            &negative,
            &|_| Some(0.05)
        )
        .is_some());
    }
}
