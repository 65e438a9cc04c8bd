//! The round of a multi-objective study (`objective: {objectives: [...]}`): instead of
//! one optimum, the Pareto front of the objectives' surrogates over the round's box.
//!
//! 1. The front is found by [`orch_metamodel::pareto_front`] (ε-constraint) over the
//!    round's box, uncertain factors held at their mean as a single objective holds
//!    them.
//! 2. Constraints are applied by filtering: a front point whose constrained surrogates
//!    break a bound is dropped (the front itself is not recomputed under the bounds,
//!    so a bound that cuts the front leaves fewer points).
//! 3. The **compromise point** is the front point closest (Euclidean) to the utopia
//!    point, every objective scaled by its range over the front ([`compromise`]). It is
//!    stored as the round's optimum, named `a vs b` with goal `pareto` and the first
//!    objective's value, so status, report and recommendation treat it as one.
//! 4. At it, the first objective's prediction interval and Monte Carlo spread are
//!    computed as for a single objective.
//! 5. The next round's box is shrunk around the compromise point; its design gets, as
//!    extra design points, up to `min(front_points, 5)` front points that lie inside
//!    the new box, spread evenly along the front ([`front_samples`]).
//!
//! Stopping: the last round ends the study; the study converges when the compromise
//! point's first objective value moves by less than the tolerance. The single
//! objective's second rule (a gain within the surrogate's own interval) is not applied:
//! a compromise point is the optimum of no single objective, so its "gain" in one of
//! them has no sign to judge.

use std::collections::HashMap;

use orch_metamodel::propose::{converged, shrink_around};
use orch_metamodel::surrogate::Surrogate;
use orch_metamodel::{
    pareto_front, propagate, propagate_with_error, Distribution, FactorRange, Goal, Optimum,
    ParetoPoint,
};

use crate::store::{Decision, FrontPoint, RoundRecord};
use crate::study::{DesignPoint, Objective, Study};

/// Front points added to the next round's design at most (fewer when the study asks
/// for fewer front points, or fewer lie inside the next box).
pub const MAX_FRONT_SAMPLES: usize = 5;

/// The goal's name in the store.
fn goal_name(goal: Goal) -> &'static str {
    match goal {
        Goal::Minimise => "minimise",
        Goal::Maximise => "maximise",
    }
}

/// The index of the compromise point of a front: the row of `values` (one value per
/// goal) closest to the utopia point (each objective's best value over the rows), with
/// each objective's distance divided by its range over the rows (an objective equal on
/// every row counts 0). The first such row wins a tie; `None` for no rows.
pub fn compromise(values: &[Vec<f64>], goals: &[Goal]) -> Option<usize> {
    let scales: Vec<(f64, f64)> = (0..goals.len())
        .map(|j| {
            let (low, high) = values
                .iter()
                .map(|row| row[j])
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
                    (l.min(v), h.max(v))
                });
            let best = match goals[j] {
                Goal::Minimise => low,
                Goal::Maximise => high,
            };
            (best, high - low)
        })
        .collect();
    let distance = |row: &[f64]| -> f64 {
        row.iter()
            .zip(&scales)
            .map(|(v, (best, range))| {
                if *range > 0.0 {
                    ((v - best) / range).powi(2)
                } else {
                    0.0
                }
            })
            .sum::<f64>()
    };
    (0..values.len()).min_by(|&a, &b| distance(&values[a]).total_cmp(&distance(&values[b])))
}

/// Up to `count` of the points of `front` whose natural values lie in `ranges` (a
/// relative slack of 1e-9), spread evenly along the front, recoded into `ranges` and
/// clamped to [−1, 1]; points equal to one of `taken` (coded, 1e-6) are left out.
pub fn front_samples(
    front: &[FrontPoint],
    ranges: &[FactorRange],
    count: usize,
    taken: &[DesignPoint],
    levels: &[u32],
) -> Vec<DesignPoint> {
    let inside: Vec<Vec<f64>> = front
        .iter()
        .filter_map(|p| {
            let coded: Vec<f64> = p
                .natural
                .iter()
                .zip(ranges)
                .map(|(v, r)| r.to_coded(*v))
                .collect();
            coded
                .iter()
                .all(|c| c.abs() <= 1.0 + 1e-9)
                .then(|| coded.iter().map(|c| c.clamp(-1.0, 1.0)).collect())
        })
        .filter(|coded: &Vec<f64>| {
            !taken
                .iter()
                .any(|t| t.coded.iter().zip(coded).all(|(a, b)| (a - b).abs() < 1e-6))
        })
        .collect();
    let n = inside.len();
    let picked: Vec<usize> = match (n, count) {
        (_, 0) | (0, _) => Vec::new(),
        (n, count) if n <= count => (0..n).collect(),
        (_, 1) => vec![n / 2],
        (n, count) => (0..count)
            .map(|i| (i as f64 * (n - 1) as f64 / (count - 1) as f64).round() as usize)
            .collect(),
    };
    picked
        .into_iter()
        .map(|i| DesignPoint::in_box(inside[i].clone(), ranges, levels))
        .collect()
}

/// Fills `record` for a multi-objective round: its front, compromise point (as the
/// optimum), the first objective's interval and spread there, and the decision with
/// the next round (see the module doc). `surfaces` holds every response the objective
/// needs; `previous` is the previous round's optimum value, if any.
pub(super) fn analyse_front(
    study: &Study,
    objective: &Objective,
    ranges: &[FactorRange],
    surfaces: &HashMap<String, Surrogate>,
    previous: Option<f64>,
    record: &mut RoundRecord,
) {
    let to_natural = |coded: &[f64]| -> Vec<f64> { study.point(coded.to_vec(), ranges).natural };

    // Uncertain factors are held at their mean, as for a single objective.
    let super::Inputs {
        uncertain, bounds, ..
    } = super::Inputs::of(study, ranges);

    let fits: Vec<&Surrogate> = objective
        .objectives
        .iter()
        .map(|(r, _)| &surfaces[r])
        .collect();
    // One closure per objective (all of one type), then the objectives on them.
    let predictors: Vec<_> = fits.iter().map(|s| move |x: &[f64]| s.predict(x)).collect();
    let functions: Vec<orch_metamodel::pareto::Objective<'_>> = predictors
        .iter()
        .map(|p| p as &dyn Fn(&[f64]) -> f64)
        .collect();
    let goals: Vec<Goal> = objective.objectives.iter().map(|(_, g)| *g).collect();
    let found = pareto_front(
        &functions,
        &goals,
        &bounds,
        objective.front_points,
        study.seed,
    );
    let satisfies = |x: &[f64]| {
        objective.constraints.iter().all(|(response, min, max)| {
            let v = surfaces[response].predict(x);
            let slack = 1e-9 * (1.0 + v.abs());
            min.is_none_or(|m| v >= m - slack) && max.is_none_or(|m| v <= m + slack)
        })
    };
    let n_found = found.len();
    let front: Vec<ParetoPoint> = found.into_iter().filter(|p| satisfies(&p.x)).collect();
    let values: Vec<Vec<f64>> = front.iter().map(|p| p.values.clone()).collect();
    let Some(chosen) = compromise(&values, &goals) else {
        record.decision = Decision::NoOptimum;
        record.note = format!(
            "none of the {n_found} points of the Pareto front satisfies the objective's constraints; relax a bound or widen a factor's range"
        );
        return;
    };
    record.front = front
        .iter()
        .enumerate()
        .map(|(i, p)| FrontPoint {
            objectives: objective
                .objectives
                .iter()
                .zip(&p.values)
                .map(|((r, g), v)| (r.clone(), goal_name(*g).to_string(), *v))
                .collect(),
            coded: p.x.clone(),
            natural: to_natural(&p.x),
            compromise: i == chosen,
        })
        .collect();
    let at = &front[chosen];
    let natural = to_natural(&at.x);
    let optimum = Optimum {
        x: at.x.clone(),
        value: at.values[0],
        exact: false,
    };

    // The first objective's interval and spread at the compromise point.
    let first = fits[0];
    record.optimum_interval = first
        .prediction_interval(&optimum.x, 0.95)
        .map(|i| (i.low, i.high));
    spread_at_compromise(
        study,
        first,
        &optimum.x,
        ranges,
        &objective.objectives[0].0,
        record,
    );
    record.optimum = Some((objective.name(), "pareto", optimum.clone(), natural.clone()));

    let at_point: Vec<String> = objective
        .objectives
        .iter()
        .zip(&at.values)
        .map(|((r, _), v)| format!("{r} = {v:.6}"))
        .collect();
    let summary = format!(
        "Pareto front of {}; compromise point {}",
        crate::status::points(front.len()),
        at_point.join(", ")
    );
    let round = record.round;
    let first_name = &objective.objectives[0].0;
    if round + 1 >= study.rounds as i64 {
        record.decision = Decision::LastRound;
        record.note = format!(
            "round {} of {} was the last; {summary}",
            round + 1,
            study.rounds
        );
    } else if let Some(before) =
        previous.filter(|before| converged(*before, optimum.value, study.metamodel.tolerance))
    {
        record.decision = Decision::Converged;
        record.note = format!(
            "{first_name} at the compromise point moved from {before:.6} to {:.6}, less than {} %; {summary}",
            optimum.value,
            study.metamodel.tolerance * 100.0
        );
    } else {
        let (next_ranges, next_points, n_samples) = next_box_and_points(
            study,
            objective,
            &record.front,
            &natural,
            ranges,
            &uncertain,
        );
        let next_tests = study.test_points(round + 1, &next_ranges);
        record.decision = Decision::NextRound;
        record.note = format!(
            "round {} in a box {} times as wide around the compromise point, with {n_samples} front points added to its design; {summary}",
            round + 2,
            study.metamodel.shrink
        );
        record.next = Some((next_ranges, next_points, next_tests));
    }
}

/// The spread of the first objective at the compromise point `x` (coded) under the
/// uncertain factors, without and with the surface's own error.
fn spread_at_compromise(
    study: &Study,
    first: &Surrogate,
    x: &[f64],
    ranges: &[FactorRange],
    first_name: &str,
    record: &mut RoundRecord,
) {
    if let Some(u) = &study.uncertainty {
        let inputs: Vec<Distribution> = u.parameters.iter().map(|(_, d)| *d).collect();
        let point = |sample: &[f64]| {
            let mut x = x.to_vec();
            for ((index, _), v) in u.parameters.iter().zip(sample) {
                x[*index] = ranges[*index].to_coded(*v);
            }
            x
        };
        if let Ok(spread) = propagate(
            &|s: &[f64]| first.predict(&point(s)),
            &inputs,
            u.samples,
            u.seed,
        ) {
            record.uncertainty = Some((first_name.to_string(), spread, u.seed));
        }
        let with_error = |s: &[f64]| {
            let x = point(s);
            (first.predict(&x), first.mean_std(&x).unwrap_or(0.0))
        };
        record.uncertainty_total =
            propagate_with_error(&with_error, &inputs, u.samples, u.seed).ok();
    }
}

/// The next round's box around the compromise point (`natural`; uncertain factors
/// keep their range), its design and the front points sampled into it, nested over
/// fidelity levels; and how many front points were added.
fn next_box_and_points(
    study: &Study,
    objective: &Objective,
    front: &[FrontPoint],
    natural: &[f64],
    ranges: &[FactorRange],
    uncertain: &[(usize, Distribution)],
) -> (Vec<FactorRange>, Vec<DesignPoint>, usize) {
    let limits: Vec<FactorRange> = study.factors.iter().map(|f| f.range).collect();
    // Design factors zoom in around the compromise point; uncertain ones keep their range.
    let mut next_ranges = study.text_kept_whole(shrink_around(
        natural,
        ranges,
        &limits,
        study.metamodel.shrink,
    ));
    for (index, _) in uncertain {
        next_ranges[*index] = ranges[*index];
    }
    let design = study
        .coded_design(&study.design)
        .expect("the design was built for round 0");
    let mut next_points: Vec<DesignPoint> = design
        .into_iter()
        .map(|coded| study.point(coded, &next_ranges))
        .collect();
    let samples = front_samples(
        front,
        &next_ranges,
        objective.front_points.min(MAX_FRONT_SAMPLES),
        &next_points,
        &study.levels(),
    );
    let n_samples = samples.len();
    next_points.extend(samples);
    // Over fidelity levels, nested subsets of them run at the higher levels.
    let next_points = crate::study::nested_points(next_points, &study.fidelities);
    (next_ranges, next_points, n_samples)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_compromise_is_closest_to_utopia_in_scaled_objectives() {
        // Maximise the first, minimise the second; ranges 10 and 1.
        let values = vec![
            vec![10.0, 1.0],
            vec![8.0, 0.3],
            vec![5.0, 0.1],
            vec![0.0, 0.0],
        ];
        // Scaled distances²: 1, 0.04 + 0.09 = 0.13, 0.25 + 0.01 = 0.26, 1.
        assert_eq!(
            compromise(&values, &[Goal::Maximise, Goal::Minimise]),
            Some(1)
        );
        // A single point, a constant objective, nothing.
        assert_eq!(compromise(&[vec![1.0, 2.0]], &[Goal::Minimise; 2]), Some(0));
        assert_eq!(
            compromise(
                &[vec![1.0, 2.0], vec![0.0, 2.0]],
                &[Goal::Minimise, Goal::Minimise]
            ),
            Some(1)
        );
        assert_eq!(compromise(&[], &[Goal::Minimise]), None);
    }

    fn point(natural: &[f64]) -> FrontPoint {
        FrontPoint {
            natural: natural.to_vec(),
            ..FrontPoint::default()
        }
    }

    #[test]
    fn front_samples_are_spread_inside_the_box_without_repeats() {
        let ranges = [FactorRange { min: 0.0, max: 1.0 }];
        // Eleven points from −0.5 to 1.5 in steps of 0.2: five lie in [0, 1] (0.1 … 0.9),
        // of which 0.5 is already a design point; three of the other four are spread.
        let front: Vec<FrontPoint> = (0..11).map(|i| point(&[-0.5 + 0.2 * i as f64])).collect();
        let taken = [DesignPoint {
            coded: vec![0.0],
            natural: vec![0.5],
            fidelity: 0,
        }];
        let samples = front_samples(&front, &ranges, 3, &taken, &[]);
        let natural: Vec<f64> = samples.iter().map(|p| p.natural[0]).collect();
        assert_eq!(natural.len(), 3, "{natural:?}");
        assert!((natural[0] - 0.1).abs() < 1e-9, "{natural:?}");
        assert!((natural[2] - 0.9).abs() < 1e-9, "{natural:?}");
        assert!(samples.iter().all(|p| p.coded[0].abs() <= 1.0));
        assert!(natural.iter().all(|v| (v - 0.5).abs() > 1e-9));
        assert!(front_samples(&front, &ranges, 0, &[], &[]).is_empty());
        assert_eq!(front_samples(&front[..2], &ranges, 5, &[], &[]).len(), 0);
    }
}
