//! The metamodel stage: after a round's jobs are final, fit a surface per response on
//! the design points (and measure it on the held-out test points), find the
//! objective's optimum in the round's box subject to its constraints, propagate the
//! uncertain factors through the objective's surfaces at the optimum, and decide on
//! the next round (a box `shrink` times as wide around the optimum) or stop. All of it
//! is recorded in one transaction with the next round's jobs, so a crash either loses
//! the whole analysis (and it is redone) or none of it. A study with two or more
//! objectives gets a Pareto front and its compromise point instead ([`pareto`]).

use std::collections::HashMap;
use std::path::Path;

use orch_metamodel::optimise::BoxBounds;
use orch_metamodel::propose::{converged, least_certain, shrink_around};
use orch_metamodel::robust::Scenarios;
use orch_metamodel::surrogate::{choose, Choice, Surrogate};
use orch_metamodel::{
    lack_of_fit, optimise_subject_to, propagate, propagate_with_error, propose_batch,
    student_t_quantile, BasisKind, Constraint, Design, Distribution, FactorRange, Goal,
};

use crate::store::{
    CandidateScore, Decision, FitRecord, JobState, LackOfFitRow, RoundRecord, Store, StoreError,
};
use crate::study::{mean_of, DesignPoint, Objective, Study};
use crate::surfaces;

pub mod pareto;

/// A function of the coded factors: a constrained response's surface, or a quantile of
/// it under the uncertain inputs.
type Predictor<'a> = Box<dyn Fn(&[f64]) -> f64 + 'a>;

/// Scenarios of the uncertain inputs every candidate design is judged on by a robust
/// objective or a probabilistic bound (the final probabilities use the study's
/// `uncertainty.samples`, at most 10^5).
pub const ROBUST_SCENARIOS: usize = 256;

/// What happened after a round.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Advance {
    /// A new round's jobs are waiting.
    NextRound(i64),
    /// Nothing more to run; the note says why.
    Done(String),
}

/// The responses fitted after each round: the objective's, then the study's list, or
/// the equipment's headline responses when the study names none.
pub fn fitted_responses(study: &Study) -> Vec<String> {
    let mut names = study
        .objective
        .as_ref()
        .map(Objective::responses)
        .unwrap_or_default();
    for response in study.shown_responses() {
        if !names.contains(&response) {
            names.push(response);
        }
    }
    names
}

/// Analyses the latest round if it is complete and not yet analysed.
pub async fn advance(
    store: &Store,
    study_id: i64,
    study: &Study,
    runs_dir: &Path,
) -> Result<Advance, StoreError> {
    let round = store.latest_round(study_id).await?;
    if store.round_decided(study_id, round).await? {
        return Ok(Advance::Done("every round is analysed".into()));
    }
    let round_points: std::collections::HashSet<i64> = store
        .points(study_id)
        .await?
        .into_iter()
        .filter(|p| p.round == round)
        .map(|p| p.id)
        .collect();
    if store
        .jobs(study_id)
        .await?
        .iter()
        .any(|j| round_points.contains(&j.point_id) && !j.state().is_final())
    {
        return Ok(Advance::Done(format!(
            "round {round} still has unfinished jobs"
        )));
    }
    let record = analyse(store, study_id, study, round).await?;
    let outcome = match record.next {
        Some(_) => Advance::NextRound(round + 1),
        None => Advance::Done(record.note.clone()),
    };
    store
        .record_round(study, study_id, &record, runs_dir)
        .await?;
    Ok(outcome)
}

/// Coded points and observed values of one response: the design runs the round fits
/// (its own and earlier rounds' inside its box) and its own held-out test runs.
struct Observed {
    design: (Vec<Vec<f64>>, Vec<f64>),
    test: (Vec<Vec<f64>>, Vec<f64>),
}

async fn observed(
    store: &Store,
    study_id: i64,
    round: i64,
    responses: &[String],
) -> Result<HashMap<String, Observed>, StoreError> {
    let design_runs = surfaces::design_runs(store, study_id)
        .await?
        .remove(&round)
        .unwrap_or_default();
    let test_points: HashMap<i64, Vec<f64>> = store
        .points(study_id)
        .await?
        .into_iter()
        .filter(|p| p.round == round && p.purpose == "test")
        .map(|p| (p.id, p.coded))
        .collect();
    let values = store.responses(study_id).await?;
    let test_jobs: Vec<_> = store
        .jobs(study_id)
        .await?
        .into_iter()
        .filter(|j| test_points.contains_key(&j.point_id) && j.state() == JobState::Succeeded)
        .collect();
    let mut out = HashMap::new();
    for response in responses {
        let design = surfaces::observed(&design_runs, response);
        let mut test = (vec![], vec![]);
        for job in &test_jobs {
            if let Some(value) = values.get(&job.id).and_then(|v| v.get(response)) {
                test.0.push(test_points[&job.point_id].clone());
                test.1.push(*value);
            }
        }
        out.insert(
            response.clone(),
            Observed {
                design: (design.coded, design.y),
                test,
            },
        );
    }
    Ok(out)
}

async fn analyse(
    store: &Store,
    study_id: i64,
    study: &Study,
    round: i64,
) -> Result<RoundRecord, StoreError> {
    let ranges = store.round_ranges(study_id, round).await?;
    let limits: Vec<FactorRange> = study.factors.iter().map(|f| f.range).collect();
    let names: Vec<String> = study.factors.iter().map(|f| f.name.clone()).collect();
    let k = names.len();
    let basis_name = match study.metamodel.basis {
        BasisKind::Legendre => "legendre",
        BasisKind::Monomial => "monomial",
    };
    let responses = fitted_responses(study);
    let data = observed(store, study_id, round, &responses).await?;
    let options = study.metamodel.kriging_options(study.seed);
    let mut fits = Vec::new();
    for response in &responses {
        let observed = &data[response];
        let (x, y) = (&observed.design.0, &observed.design.1);
        let choice = choose(
            study.metamodel.model,
            study.metamodel.basis,
            &names,
            x,
            y,
            &options,
        );
        fits.push(fit_record(
            response, basis_name, observed, choice, study.seed,
        ));
    }

    let mut record = RoundRecord {
        round,
        fits,
        optimum: None,
        optimum_interval: None,
        uncertainty: None,
        uncertainty_total: None,
        front: Vec::new(),
        decision: Decision::LastRound,
        note: String::new(),
        next: None,
    };
    let Some(objective) = &study.objective else {
        record.note = "the study has no objective".into();
        return Ok(record);
    };
    let surfaces: HashMap<String, Surrogate> = record
        .fits
        .iter()
        .filter_map(|f| {
            f.result
                .as_ref()
                .ok()
                .map(|fit| (f.response.clone(), fit.clone()))
        })
        .collect();
    if let Some(missing) = objective
        .responses()
        .into_iter()
        .find(|r| !surfaces.contains_key(r))
    {
        let why = record
            .fits
            .iter()
            .find(|f| f.response == missing)
            .and_then(|f| f.result.as_ref().err().cloned())
            .unwrap_or_default();
        record.decision = Decision::NoOptimum;
        record.note = format!("no surface for {missing}: {why}");
        return Ok(record);
    }
    if objective.is_pareto() {
        let previous = previous_optimum(store, study_id, round).await?;
        pareto::analyse_front(study, objective, &ranges, &surfaces, previous, &mut record);
        return Ok(record);
    }
    let value = |x: &[f64]| {
        objective
            .terms
            .iter()
            .map(|(r, w)| w * surfaces[r].predict(x))
            .sum::<f64>()
    };
    // The objective's standard error as an estimate of the mean response, and its 95 %
    // prediction interval for a new run: the weighted sum of independent surrogates.
    let combine = |each: &dyn Fn(&Surrogate) -> Option<f64>| {
        objective
            .terms
            .iter()
            .map(|(r, w)| each(&surfaces[r]).map(|s| (w * s).powi(2)))
            .sum::<Option<f64>>()
            .map(f64::sqrt)
    };
    let mean_std = |x: &[f64]| combine(&|s| s.mean_std(x));
    let prediction_interval = |x: &[f64]| -> Option<(f64, f64)> {
        if let [(response, weight)] = objective.terms.as_slice() {
            let i = surfaces[response].prediction_interval(x, 0.95)?;
            let (a, b) = (weight * i.low, weight * i.high);
            return Some((a.min(b), a.max(b)));
        }
        let std = combine(&|s| s.prediction_interval(x, 0.95).map(|i| i.std_error))?;
        let z = 1.959_963_984_540_054;
        Some((value(x) - z * std, value(x) + z * std))
    };

    // Uncertain factors are held at their mean while the design factors are optimised.
    let mut bounds = BoxBounds::coded(k);
    let uncertain: Vec<(usize, Distribution)> = study
        .uncertainty
        .iter()
        .flat_map(|u| u.parameters.iter().copied())
        .collect();
    for (index, distribution) in &uncertain {
        let centre = ranges[*index]
            .to_coded(mean_of(distribution))
            .clamp(-1.0, 1.0);
        bounds.lower[*index] = centre;
        bounds.upper[*index] = centre;
    }
    // Robust design and probabilistic bounds judge every candidate on one set of
    // scenarios of the uncertain factors and tolerances (common random numbers).
    let tolerances: Vec<(usize, f64)> = study
        .uncertainty
        .iter()
        .flat_map(|u| u.noise.iter().flat_map(|n| n.tolerances.iter().copied()))
        .collect();
    let scenarios = (objective.robust.is_some()
        || objective.probabilities.iter().any(Option::is_some))
    .then(|| {
        Scenarios::draw(
            &uncertain,
            &tolerances,
            &ranges,
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
            let fit = &surfaces[response];
            match (probability, &scenarios) {
                (Some(p), Some(scenarios)) => {
                    let z = student_t_quantile(1.0 - p, 1e9);
                    let sign = if min.is_some() { -1.0 } else { 1.0 };
                    Box::new(move |x: &[f64]| {
                        let (mean, std) = scenarios.moments(&|y| fit.predict(y), x);
                        mean + sign * z * std
                    }) as Box<dyn Fn(&[f64]) -> f64>
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
            .all(|r| surfaces[r].is_quadratic());
    let (mut optimum, feasible) = optimise_subject_to(
        &robust_value,
        exact,
        &constraints,
        objective.goal,
        &bounds,
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
    if let Some(samples) = scenarios.as_ref().and_then(|_| {
        let samples = study
            .uncertainty
            .as_ref()
            .map_or(0, |u| u.samples)
            .min(100_000);
        Scenarios::draw(
            &uncertain,
            &tolerances,
            &ranges,
            samples.max(ROBUST_SCENARIOS),
            study.seed.wrapping_add(0xfa11),
        )
        .ok()
    }) {
        for ((response, min, max), probability) in
            objective.constraints.iter().zip(&objective.probabilities)
        {
            let (Some(allowed), Some(limit)) = (probability, max.or(*min)) else {
                continue;
            };
            let fit = &surfaces[response];
            let above = max.is_some();
            let (p, se) = samples.exceedance(&|x| fit.predict(x), &optimum.x, limit, above);
            robustness.push(format!(
                "P[{response} {} {limit}] = {p:.4} ± {se:.4} ({} samples; allowed {allowed})",
                if above { ">" } else { "<" },
                samples.len()
            ));
        }
    }
    let natural: Vec<f64> = optimum
        .x
        .iter()
        .zip(&ranges)
        .map(|(c, r)| r.to_natural(*c))
        .collect();
    let objective_name = objective.name();

    // Factors held at their mean are sampled here; materials and tolerances have a
    // noise design of their own after the rounds.
    if let Some(u) = study
        .uncertainty
        .as_ref()
        .filter(|u| !u.parameters.is_empty())
    {
        let inputs: Vec<Distribution> = u.parameters.iter().map(|(_, d)| *d).collect();
        let at_optimum = |sample: &[f64]| {
            let mut x = optimum.x.clone();
            for ((index, _), v) in u.parameters.iter().zip(sample) {
                x[*index] = ranges[*index].to_coded(*v);
            }
            value(&x)
        };
        if let Ok(spread) = propagate(&at_optimum, &inputs, u.samples, u.seed) {
            record.uncertainty = Some((objective_name.clone(), spread, u.seed));
        }
        // The same draws with the surrogates' own error sampled at each point.
        let with_error = |sample: &[f64]| {
            let mut x = optimum.x.clone();
            for ((index, _), v) in u.parameters.iter().zip(sample) {
                x[*index] = ranges[*index].to_coded(*v);
            }
            (value(&x), mean_std(&x).unwrap_or(0.0))
        };
        record.uncertainty_total =
            propagate_with_error(&with_error, &inputs, u.samples, u.seed).ok();
    }
    record.optimum_interval = prediction_interval(&optimum.x);
    let goal = match objective.goal {
        Goal::Minimise => "minimise",
        Goal::Maximise => "maximise",
    };
    record.optimum = Some((objective_name, goal, optimum.clone(), natural.clone()));
    // What each constrained response is predicted to be there, against its bound.
    let at_bounds: Vec<String> = objective
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
    if !feasible {
        record.decision = Decision::NoOptimum;
        record.note = format!(
            "no point of the box satisfies the objective's constraints; the best compromise reaches {}",
            at_bounds.join(", ")
        );
        return Ok(record);
    }
    let mut constrained = if at_bounds.is_empty() {
        String::new()
    } else {
        format!("; at the optimum {}", at_bounds.join(", "))
    };
    for line in &robustness {
        constrained.push_str("; ");
        constrained.push_str(line);
    }

    let previous = if round > 0 {
        store
            .rounds(study_id)
            .await?
            .into_iter()
            .find(|r| r.round == round - 1)
            .and_then(|r| r.optimum)
    } else {
        None
    };
    if round + 1 >= study.rounds as i64 {
        record.note = format!(
            "round {} of {} was the last{constrained}",
            round + 1,
            study.rounds
        );
    } else if let Some((_, _, before, _)) = previous
        .as_ref()
        .filter(|p| converged(p.2, optimum.value, study.metamodel.tolerance))
    {
        record.decision = Decision::Converged;
        record.note = format!(
            "the predicted optimum moved from {before:.6} to {:.6}, less than {} %{constrained}",
            optimum.value,
            study.metamodel.tolerance * 100.0
        );
    } else if let Some(note) = previous.as_ref().and_then(|(_, _, _, before)| {
        unresolved_gain(before, &ranges, &optimum, objective.goal, &value, &mean_std)
    }) {
        record.decision = Decision::Converged;
        record.note = format!("{note}{constrained}");
    } else {
        // A Kriging objective proposes by expected improvement in the same box; a
        // polynomial one zooms in: the design again in a box `shrink` times as wide
        // around the optimum (uncertain factors keep their range).
        let kriging = match objective.terms.as_slice() {
            [(response, weight)] => match &surfaces[response] {
                Surrogate::Kriging { model, .. } => {
                    let goal = match (objective.goal, *weight >= 0.0) {
                        (goal, true) => goal,
                        (Goal::Maximise, false) => Goal::Minimise,
                        (Goal::Minimise, false) => Goal::Maximise,
                    };
                    Some((response, model, goal))
                }
                Surrogate::Polynomial(_) => None,
            },
            _ => None,
        };
        let (next_ranges, mut next_coded, how) = match kriging {
            Some((response, model, goal)) => {
                let batch = study.executor.max_parallel.max(2);
                let (x, y) = &data[response].design;
                let seed = study.seed.wrapping_add(round as u64);
                let points = propose_batch(model, x, y, &bounds, batch, goal, seed, &options);
                let how = format!(
                    "{} expected-improvement points (a kriging-believer batch, one per job slot) in the same box",
                    points.len()
                );
                (ranges.clone(), points, how)
            }
            None => {
                let mut next_ranges =
                    shrink_around(&natural, &ranges, &limits, study.metamodel.shrink);
                for (index, _) in &uncertain {
                    next_ranges[*index] = ranges[*index];
                }
                let design =
                    Design::build(&study.design, k).expect("the design was built for round 0");
                let how = format!(
                    "a box {} times as wide around the optimum",
                    study.metamodel.shrink
                );
                (next_ranges, design.points, how)
            }
        };
        // Always a few runs where the objective's surrogate is least certain, so that
        // the next round tests it where it knows least.
        let to_current = |coded: &[f64]| -> Vec<f64> {
            coded
                .iter()
                .zip(&next_ranges)
                .zip(&ranges)
                .map(|((c, next), now)| now.to_coded(next.to_natural(*c)))
                .collect()
        };
        let mut next_bounds = BoxBounds::coded(k);
        for (index, distribution) in &uncertain {
            let centre = next_ranges[*index]
                .to_coded(mean_of(distribution))
                .clamp(-1.0, 1.0);
            next_bounds.lower[*index] = centre;
            next_bounds.upper[*index] = centre;
        }
        let probes = if mean_std(&to_current(&vec![0.0; k])).is_some() {
            least_certain(
                &|c| mean_std(&to_current(c)).unwrap_or(0.0),
                &next_bounds,
                &next_coded,
                (k / 2).max(1),
                0.25,
                study.seed.wrapping_add(31 * round as u64),
            )
        } else {
            Vec::new()
        };
        let probed = probes.len();
        next_coded.extend(probes);
        let to_point = |coded: Vec<f64>| DesignPoint {
            natural: coded
                .iter()
                .zip(&next_ranges)
                .map(|(c, r)| r.to_natural(*c))
                .collect(),
            coded,
        };
        let next_points = next_coded.into_iter().map(to_point).collect();
        let next_tests = study.test_points(round + 1, &next_ranges);
        record.decision = Decision::NextRound;
        record.note = format!(
            "round {}: {how}, and {probed} run{} where the surrogate is least certain{constrained}",
            round + 2,
            if probed == 1 { "" } else { "s" }
        );
        record.next = Some((next_ranges, next_points, next_tests));
    }
    Ok(record)
}

/// The value of the previous round's optimum (a compromise point's first objective),
/// if there is a previous round and it has one.
async fn previous_optimum(
    store: &Store,
    study_id: i64,
    round: i64,
) -> Result<Option<f64>, StoreError> {
    if round == 0 {
        return Ok(None);
    }
    Ok(store
        .rounds(study_id)
        .await?
        .into_iter()
        .find(|r| r.round == round - 1)
        .and_then(|r| r.optimum)
        .map(|o| o.2))
}

/// What the store keeps of one response's model choice on a round's runs.
fn fit_record(
    response: &str,
    basis_name: &str,
    observed: &Observed,
    choice: Result<Choice, String>,
    seed: u64,
) -> FitRecord {
    let (x, y) = (&observed.design.0, &observed.design.1);
    let mut record = FitRecord {
        response: response.to_string(),
        basis: basis_name.to_string(),
        order: 0,
        runs: y.len(),
        result: Err(String::new()),
        test: None,
        model: None,
        spec: None,
        candidates: Vec::new(),
        lack_of_fit: None,
        sensitivities: Vec::new(),
    };
    let choice = match choice {
        Ok(choice) => choice,
        Err(why) => {
            record.result = Err(why);
            return record;
        }
    };
    let surrogate = choice.surrogate;
    record.candidates = choice
        .candidates
        .iter()
        .enumerate()
        .map(|(i, c)| CandidateScore {
            model: c.name.clone(),
            parameters: c.parameters,
            loo_rmse: c.loo_rmse,
            chosen: i == choice.chosen,
            note: match (&c.note, i == choice.chosen && !choice.by_prognosis) {
                (_, true) => {
                    Some("kept without a score: no candidate could be cross-validated".into())
                }
                (note, false) => note.clone(),
            },
        })
        .collect();
    record.model = Some(choice.candidates[choice.chosen].name.clone());
    record.spec = Some(surfaces::spec_json(&surrogate.spec()));
    record.order = surrogate.polynomial().map_or(0, |fit| fit.basis.order);
    record.lack_of_fit = surrogate
        .polynomial()
        .and_then(|fit| lack_of_fit(fit, x, y))
        .map(|l| LackOfFitRow {
            f: l.f,
            p: l.p_value,
            lack_of_fit_dof: l.dof_lack_of_fit,
            pure_error_dof: l.dof_pure_error,
        });
    record.sensitivities = surfaces::sensitivities(&surrogate, seed);
    record.test = surrogate
        .test(&observed.test.0, &observed.test.1)
        .map(|quality| (observed.test.1.len(), quality));
    record.result = Ok(surrogate);
    record
}

/// The stopping rule's second half: when this round's surrogate predicts the new
/// optimum better than the previous round's (`before`, natural units) by less than the
/// half-width of its own 95 % confidence interval there, another round would chase
/// the surrogate's noise; says so, or `None` to go on.
fn unresolved_gain(
    before: &[f64],
    ranges: &[FactorRange],
    optimum: &orch_metamodel::Optimum,
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

/// Test support: a study stored from `text` whose round-0 jobs all succeeded with the
/// results `results(coded point, job index)` gives, ready to be analysed.
#[cfg(test)]
pub(crate) mod testing {
    use std::collections::HashMap;
    use std::path::{Path, PathBuf};

    use crate::store::{JobResults, Store};
    use crate::study::Study;

    /// The stored study, its store and folder.
    pub(crate) struct RoundRun {
        /// Holds the store and the runs.
        pub dir: tempfile::TempDir,
        /// The store.
        pub store: Store,
        /// The study's id.
        pub id: i64,
        /// The study.
        pub study: Study,
    }

    impl RoundRun {
        /// The study's run folder.
        pub(crate) fn runs_dir(&self) -> PathBuf {
            self.dir.path().join("runs").join(&self.study.name)
        }
    }

    /// Stores `text` and marks every job of round 0 succeeded with `results`.
    pub(crate) async fn round_run(
        text: &str,
        results: impl Fn(&[f64], usize) -> JobResults,
    ) -> RoundRun {
        let dir = tempfile::tempdir().unwrap();
        let store = Store::open(dir.path()).await.unwrap();
        let study = Study::from_text(Path::new("study.yaml"), text, None).unwrap();
        let id = store
            .insert_study(&study, Path::new("study.yaml"), &dir.path().join("runs"))
            .await
            .unwrap();
        let coded: HashMap<i64, Vec<f64>> = store
            .points(id)
            .await
            .unwrap()
            .into_iter()
            .map(|p| (p.id, p.coded))
            .collect();
        for (k, job) in store.jobs(id).await.unwrap().iter().enumerate() {
            store.mark_rendered(job.id).await.unwrap();
            store.mark_running(job.id, "1:1", 0.0).await.unwrap();
            let results = results(&coded[&job.point_id], k);
            store.mark_succeeded(job.id, 0, &results).await.unwrap();
        }
        RoundRun {
            dir,
            store,
            id,
            study,
        }
    }
}

#[cfg(test)]
mod tests {

    use super::*;
    use crate::store::JobResults;

    /// Two factors, a constrained objective, held-out test points, two rounds.
    const STUDY: &str = "\
name: surfaces
solver: liggghts
factors:
  - {name: outlet_diameter, min: 0.020, max: 0.028}
  - {name: amplitude, min: 0.0, max: 0.0008}
design: {type: central_composite, alpha: face_centred}
objective:
  weights: {discharge_rate: 1.0}
  goal: maximise
  constraints: [{response: segregation_ratio, max: 1.2}]
metamodel: {test_points: 4}
rounds: 2
";

    /// Known surfaces in coded units: the rate peaks at (0.5, 0); segregation grows with x0.
    fn responses(coded: &[f64]) -> Vec<(String, f64)> {
        vec![
            (
                "discharge_rate".into(),
                1.0 - (coded[0] - 0.5).powi(2) - coded[1].powi(2),
            ),
            ("segregation_ratio".into(), 1.0 + coded[0]),
        ]
    }

    #[tokio::test]
    async fn a_round_with_known_surfaces_gives_the_constrained_optimum_and_the_next_box() {
        let run = testing::round_run(STUDY, |coded, _| JobResults {
            responses: responses(coded),
            series: vec![],
            note: None,
        })
        .await;
        let (store, id, study) = (&run.store, run.id, &run.study);
        let jobs = store.jobs(id).await.unwrap();
        assert_eq!(jobs.len(), 9 + 4);
        assert_eq!(jobs.iter().filter(|j| j.name.starts_with('t')).count(), 4);

        let advanced = advance(store, id, study, &run.runs_dir()).await.unwrap();
        assert_eq!(advanced, Advance::NextRound(1));
        let rounds = store.rounds(id).await.unwrap();
        let first = &rounds[0];
        let rate = first
            .fits
            .iter()
            .find(|f| f.response == "discharge_rate")
            .unwrap();
        assert!(
            (rate.r2.unwrap() - 1.0).abs() < 1e-12,
            "an exact quadratic is fitted exactly"
        );
        assert_eq!(rate.runs, 9);
        assert_eq!(rate.test_runs, 4);
        assert!(rate.sigma_test.unwrap() < 1e-6, "{:?}", rate.sigma_test);
        // The unconstrained maximum (x0 = 0.5) violates R1/R2 ≤ 1.2; the optimum sits on x0 = 0.2.
        let (name, goal, value, natural) = first.optimum.clone().unwrap();
        assert_eq!(
            (name.as_str(), goal.as_str()),
            ("discharge_rate", "maximise")
        );
        let coded_x0 = (natural[0] - 0.024) / 0.004;
        assert!((coded_x0 - 0.2).abs() < 1e-3, "x0 = {coded_x0}");
        assert!((natural[1] - 0.0004).abs() < 1e-6, "{natural:?}");
        assert!((value - (1.0 - 0.09)).abs() < 1e-3, "{value}");
        // The next round: half as wide around the optimum, with its own test points.
        assert_eq!(first.decision.as_ref().unwrap().0, Decision::NextRound);
        // The constrained response's predicted value there, against its bound.
        let note = &first.decision.as_ref().unwrap().1;
        assert!(
            note.ends_with("; at the optimum segregation_ratio = 1.200000 (bound ≤ 1.2)"),
            "{note}"
        );
        let next = &rounds[1].ranges;
        assert!(((next[0].min + next[0].max) / 2.0 - natural[0]).abs() < 1e-12);
        assert!(((next[0].max - next[0].min) - 0.004).abs() < 1e-12);
        let pending: Vec<_> = store
            .jobs(id)
            .await
            .unwrap()
            .into_iter()
            .filter(|j| j.state() == JobState::Pending)
            .collect();
        // The design's 9 runs, 1 where the surrogate is least certain, 4 test points.
        assert_eq!(pending.len(), 9 + 1 + 4);
        assert!(pending.iter().any(|j| j.name == "r1-t000r0"));
        assert!(note.starts_with("round 2: a box 0.5 times as wide around the optimum, and 1 run where the surrogate is least certain"), "{note}");
        // Round 1 is not analysed before its jobs ran; round 0 is never analysed twice.
        assert!(!store.round_decided(id, 1).await.unwrap());
        assert_eq!(store.rounds(id).await.unwrap()[0], rounds[0]);
    }

    /// A bound no point of the box meets: segregation = 1 + x0 ≥ 0 everywhere.
    const INFEASIBLE: &str = "\
name: infeasible
solver: liggghts
factors:
  - {name: outlet_diameter, min: 0.020, max: 0.028}
  - {name: amplitude, min: 0.0, max: 0.0008}
design: {type: central_composite, alpha: face_centred}
objective:
  response: discharge_rate
  goal: maximise
  constraints: [{response: segregation_ratio, max: -0.5}]
";

    #[tokio::test]
    async fn an_infeasible_bound_says_the_best_value_reached() {
        let run = testing::round_run(INFEASIBLE, |coded, _| JobResults {
            responses: responses(coded),
            series: vec![],
            note: None,
        })
        .await;
        let (store, id) = (&run.store, run.id);
        advance(store, id, &run.study, &run.runs_dir())
            .await
            .unwrap();
        let rounds = store.rounds(id).await.unwrap();
        let (decision, note) = rounds[0].decision.clone().unwrap();
        assert_eq!(decision, Decision::NoOptimum);
        // The best compromise is the lowest segregation the box allows: 1 + (−1) = 0.
        let reached = note
            .strip_prefix("no point of the box satisfies the objective's constraints; the best compromise reaches segregation_ratio = ")
            .and_then(|rest| rest.strip_suffix(" (bound ≤ -0.5)"))
            .unwrap_or_else(|| panic!("{note}"));
        assert!(reached.parse::<f64>().unwrap().abs() < 1e-3, "{note}");
    }

    /// Three centre replicates (pure error), an uncertain amplitude, no bounds.
    const REPLICATED: &str = "\
name: replicated
solver: liggghts
factors:
  - {name: outlet_diameter, min: 0.020, max: 0.028}
  - {name: amplitude, min: 0.0, max: 0.0008}
design: {type: central_composite, alpha: face_centred, center_points: 3}
objective: {response: discharge_rate, goal: maximise}
uncertainty:
  samples: 20000
  seed: 5
  parameters: [{name: amplitude, distribution: normal, mean: 0.0004, std: 0.0001}]
";

    #[tokio::test]
    async fn a_round_keeps_its_model_choice_lack_of_fit_sobol_indices_and_honest_bounds() {
        // rate = 0.75 + x0 − x0² − x1² plus scatter of ±0.01: in Legendre terms
        // P1(x0) − ⅔P2(x0) − ⅔P2(x1), whose Sobol indices over the box are exactly
        // S(x0) = (1/3 + 4/45) / (23/45) = 19/23 and S(x1) = 4/23 (no interaction).
        let scatter = [
            0.01, -0.01, 0.005, -0.005, 0.0, 0.008, -0.008, 0.003, -0.003, 0.006, -0.006,
        ];
        let run = testing::round_run(REPLICATED, |coded, k| JobResults {
            responses: vec![(
                "discharge_rate".into(),
                1.0 - (coded[0] - 0.5).powi(2) - coded[1].powi(2) + scatter[k % scatter.len()],
            )],
            series: vec![],
            note: None,
        })
        .await;
        let (store, id) = (&run.store, run.id);
        advance(store, id, &run.study, &run.runs_dir())
            .await
            .unwrap();
        let round = &store.rounds(id).await.unwrap()[0];
        let fit = &round.fits[0];

        // Four candidates, one chosen: a quadratic on a quadratic.
        assert_eq!(fit.candidates.len(), 4, "{:?}", fit.candidates);
        assert_eq!(fit.candidates.iter().filter(|c| c.chosen).count(), 1);
        let model = fit.model.as_deref().unwrap();
        assert!(model.starts_with("quadratic"), "{model}");
        assert!(fit.candidates[3].model.starts_with("kriging"));
        // The stored spec rebuilds the same surface from the stored runs.
        let runs = surfaces::design_runs(store, id).await.unwrap();
        let observed = surfaces::observed(&runs[&0], "discharge_rate");
        let names = ["outlet_diameter".to_string(), "amplitude".to_string()];
        let rebuilt = surfaces::refit(fit, &names, &observed).unwrap();
        let press = rebuilt.quality().press.unwrap();
        assert!((press - fit.press.unwrap()).abs() <= 1e-12 * press.max(1.0));

        // Three centre replicates give 2 pure-error degrees of freedom.
        let lack_of_fit = fit.lack_of_fit.unwrap();
        assert_eq!(lack_of_fit.pure_error_dof, 2);
        assert!(lack_of_fit.p > 0.05, "{lack_of_fit:?}");

        // Exact Sobol indices of the Legendre surface, close to the analytic ones.
        assert_eq!(fit.sensitivities.len(), 2);
        assert_eq!(fit.sensitivities[0].method, "analytic");
        assert!(
            (fit.sensitivities[0].first.0 - 19.0 / 23.0).abs() < 0.02,
            "{:?}",
            fit.sensitivities
        );
        assert!(
            (fit.sensitivities[1].total.0 - 4.0 / 23.0).abs() < 0.02,
            "{:?}",
            fit.sensitivities
        );

        // The optimum's prediction interval holds its value; the spread with the
        // surrogate's error is wider than the input-only one.
        let value = round.optimum.as_ref().unwrap().2;
        let (low, high) = round.optimum_interval.unwrap();
        assert!(
            low < value && value < high && high - low < 0.2,
            "[{low}, {high}] around {value}"
        );
        let (inputs, total) = (round.uncertainty.unwrap(), round.uncertainty_total.unwrap());
        assert!(total.std > inputs.std, "{total:?} vs {inputs:?}");
        // At a maximum the input spread cannot push the rate above it; only the
        // surrogate's error can.
        assert!(total.q975 > inputs.q975, "{total:?} vs {inputs:?}");
    }

    /// Two objectives traded off in two factors, two rounds.
    const FRONT: &str = "\
name: front
solver: liggghts
factors:
  - {name: outlet_diameter, min: 0.020, max: 0.028}
  - {name: amplitude, min: 0.0, max: 0.0008}
design: {type: central_composite, alpha: face_centred}
objective:
  objectives:
    - {response: discharge_rate, goal: maximise}
    - {response: segregation_ratio, goal: minimise}
  front_points: 11
rounds: 2
";

    /// The rate's maximum and the segregation's minimum, coded: with equal, isotropic
    /// curvatures the Pareto set is the segment between them.
    const P: [f64; 2] = [0.5, 0.3];
    const Q: [f64; 2] = [-0.3, -0.1];

    fn front_responses(coded: &[f64]) -> Vec<(String, f64)> {
        let d = |c: [f64; 2]| (coded[0] - c[0]).powi(2) + (coded[1] - c[1]).powi(2);
        vec![
            ("discharge_rate".into(), 1.0 - d(P)),
            ("segregation_ratio".into(), 1.0 + 2.0 * d(Q)),
        ]
    }

    /// Where `x` lies along P→Q (0 at P, 1 at Q) and how far it is off the segment.
    fn along_segment(x: &[f64]) -> (f64, f64) {
        let d = [Q[0] - P[0], Q[1] - P[1]];
        let t = ((x[0] - P[0]) * d[0] + (x[1] - P[1]) * d[1]) / (d[0] * d[0] + d[1] * d[1]);
        let c = t.clamp(0.0, 1.0);
        let off = (x[0] - P[0] - c * d[0]).hypot(x[1] - P[1] - c * d[1]);
        (t, off)
    }

    #[tokio::test]
    async fn a_two_objective_round_stores_its_front_and_samples_it_next_round() {
        let run = testing::round_run(FRONT, |coded, _| JobResults {
            responses: front_responses(coded),
            series: vec![],
            note: None,
        })
        .await;
        let (store, id, study) = (&run.store, run.id, &run.study);
        // The analysis is pure and seeded: the same record as advance() stores.
        let analysed = analyse(store, id, study, 0).await.unwrap();
        let advanced = advance(store, id, study, &run.runs_dir()).await.unwrap();
        assert_eq!(advanced, Advance::NextRound(1));
        let rounds = store.rounds(id).await.unwrap();
        let first = &rounds[0];
        // The store round-trips the front exactly.
        assert_eq!(first.front, analysed.front);
        let front = &first.front;
        assert!(front.len() >= 8, "{} points: {front:?}", front.len());

        // Every point, coded again through the round's box, lies on the segment P–Q.
        let box0 = &first.ranges;
        let coded = |natural: &[f64]| -> Vec<f64> {
            natural
                .iter()
                .zip(box0)
                .map(|(v, r)| r.to_coded(*v))
                .collect()
        };
        let mut along = Vec::new();
        for point in front {
            let (t, off) = along_segment(&coded(&point.natural));
            assert!(off < 1e-2, "{point:?} is {off} off the segment");
            assert!((-1e-2..=1.0 + 1e-2).contains(&t), "{point:?} at t = {t}");
            along.push(t);
            let names: Vec<&str> = point.objectives.iter().map(|o| o.0.as_str()).collect();
            assert_eq!(names, ["discharge_rate", "segregation_ratio"]);
            assert_eq!(point.objectives[1].1, "minimise");
        }
        // From the rate's best end (P) to the segregation's (Q): both objectives fall.
        assert!(
            along[0] < 1e-2 && along[along.len() - 1] > 1.0 - 1e-2,
            "{along:?}"
        );
        assert!(front
            .windows(2)
            .all(|w| w[1].objectives[0].2 < w[0].objectives[0].2
                && w[1].objectives[1].2 < w[0].objectives[1].2));

        // One compromise point, on the segment, about its middle (each objective scaled
        // by its range over the front, the two are symmetric there).
        let compromises: Vec<_> = front.iter().filter(|p| p.compromise).collect();
        assert_eq!(compromises.len(), 1);
        let compromise = compromises[0];
        let (t, off) = along_segment(&coded(&compromise.natural));
        assert!(off < 1e-2 && (t - 0.5).abs() < 0.1, "t = {t}, off = {off}");
        // Stored as the round's optimum.
        let (name, goal, value, natural) = first.optimum.clone().unwrap();
        assert_eq!(
            (name.as_str(), goal.as_str()),
            ("discharge_rate vs segregation_ratio", "pareto")
        );
        assert_eq!(natural, compromise.natural);
        assert_eq!(value, compromise.objectives[0].2);
        assert_eq!(first.decision.as_ref().unwrap().0, Decision::NextRound);

        // The next box: half as wide, centred on the compromise point.
        let next = &rounds[1].ranges;
        for (i, r) in next.iter().enumerate() {
            assert!(
                ((r.min + r.max) / 2.0 - natural[i]).abs() < 1e-12,
                "{next:?}"
            );
            let width = box0[i].max - box0[i].min;
            assert!(((r.max - r.min) - width / 2.0).abs() < 1e-12, "{next:?}");
        }
        // Its design: the 9 runs of the CCD, then 5 front points recoded into it (the
        // compromise point is its centre run already).
        let points: Vec<_> = store
            .points(id)
            .await
            .unwrap()
            .into_iter()
            .filter(|p| p.round == 1 && p.purpose == "design")
            .collect();
        assert_eq!(points.len(), 9 + 5);
        for extra in &points[9..] {
            let on_front = front.iter().any(|f| {
                f.natural
                    .iter()
                    .zip(&extra.natural)
                    .zip(next)
                    .all(|((a, b), r)| (a - b).abs() < 1e-9 * (r.max - r.min))
            });
            assert!(on_front, "{extra:?} is no front point");
            assert!(!extra.natural.iter().zip(&natural).all(|(a, b)| a == b));
            for ((c, v), r) in extra.coded.iter().zip(&extra.natural).zip(next) {
                assert!(c.abs() <= 1.0 && (r.to_coded(*v) - c).abs() < 1e-9);
            }
        }
        // Its jobs wait; the text summary names the front and its compromise point.
        let pending = store
            .jobs(id)
            .await
            .unwrap()
            .into_iter()
            .filter(|j| j.state() == JobState::Pending)
            .count();
        assert_eq!(pending, 14);
        let factors = store.factors(id).await.unwrap();
        let runs = surfaces::design_runs(store, id).await.unwrap();
        let text = crate::status::rounds_summary(&rounds, &factors, &runs);
        assert!(
            text.contains(&format!(
                "  Pareto front of {} points; compromise point: discharge_rate = ",
                front.len()
            )),
            "{text}"
        );
        assert!(
            text.contains("  compromise point (pareto discharge_rate vs segregation_ratio): discharge_rate = "),
            "{text}"
        );
    }

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

    /// Kriging forced, three job slots, two rounds.
    const KRIGING: &str = "\
name: kriging
solver: liggghts
executor: {max_parallel: 3}
factors:
  - {name: outlet_diameter, min: 0.020, max: 0.028}
  - {name: amplitude, min: 0.0, max: 0.0008}
design: {type: latin_hypercube, samples: 12, seed: 4}
objective: {response: discharge_rate, goal: minimise}
metamodel: {model: kriging}
rounds: 2
";

    #[tokio::test]
    async fn a_kriging_objective_proposes_one_expected_improvement_point_per_job_slot_in_the_same_box(
    ) {
        // A bowl with its minimum inside the box at coded (0.3, −0.4).
        let run = testing::round_run(KRIGING, |coded, _| JobResults {
            responses: vec![(
                "discharge_rate".into(),
                (coded[0] - 0.3).powi(2) + (coded[1] + 0.4).powi(2),
            )],
            series: vec![],
            note: None,
        })
        .await;
        let (store, id) = (&run.store, run.id);
        assert_eq!(
            advance(store, id, &run.study, &run.runs_dir())
                .await
                .unwrap(),
            Advance::NextRound(1)
        );
        let rounds = store.rounds(id).await.unwrap();
        let (_, note) = rounds[0].decision.clone().unwrap();
        assert!(
            note.starts_with("round 2: 3 expected-improvement points (a kriging-believer batch, one per job slot) in the same box, and 1 run where the surrogate is least certain"),
            "{note}"
        );
        assert_eq!(
            rounds[0].fits[0].model.as_deref(),
            Some("kriging, Matérn 5/2, constant trend")
        );
        // The same box; four new design points, the expected-improvement ones near the
        // minimum.
        assert_eq!(rounds[1].ranges, rounds[0].ranges);
        let points: Vec<_> = store
            .points(id)
            .await
            .unwrap()
            .into_iter()
            .filter(|p| p.round == 1)
            .collect();
        assert_eq!(points.len(), 4);
        let near = points
            .iter()
            .filter(|p| (p.coded[0] - 0.3).hypot(p.coded[1] + 0.4) < 0.5)
            .count();
        assert!(near >= 1, "{points:?}");
    }

    /// The outlet is designed; the amplitude is uncertain, N(0.0004, 0.0001) m, which is
    /// 0.25 in coded units around the centre of its range.
    fn robust_study(objective: &str) -> String {
        format!(
            "\
name: robust
solver: liggghts
factors:
  - {{name: outlet_diameter, min: 0.020, max: 0.028}}
  - {{name: amplitude, min: 0.0, max: 0.0008}}
design: {{type: central_composite, alpha: face_centred, center_points: 3}}
objective: {objective}
uncertainty:
  samples: 100000
  seed: 2
  parameters: [{{name: amplitude, distribution: normal, mean: 0.0004, std: 0.0001}}]
"
        )
    }

    #[tokio::test]
    async fn a_robust_objective_trades_the_mean_for_a_smaller_spread() {
        // rate = x0 − x0²/2 + x0·x1: at the amplitude's mean the best outlet is the box's
        // edge (x0 = 1), but the spread is 0.25·|x0|, so mean − 2·std = x0 − x0²/2 − 0.5·x0
        // peaks at x0 = 0.5.
        let text = robust_study("{response: discharge_rate, goal: maximise, robust: {k: 2}}");
        let run = testing::round_run(&text, |c, _| JobResults {
            responses: vec![(
                "discharge_rate".into(),
                c[0] - 0.5 * c[0] * c[0] + c[0] * c[1],
            )],
            series: vec![],
            note: None,
        })
        .await;
        advance(&run.store, run.id, &run.study, &run.runs_dir())
            .await
            .unwrap();
        let round = &run.store.rounds(run.id).await.unwrap()[0];
        let (_, _, value, natural) = round.optimum.clone().unwrap();
        let x0 = (natural[0] - 0.024) / 0.004;
        assert!((x0 - 0.5).abs() < 0.05, "x0 = {x0}");
        // The stored value is the surface's at the robust optimum (amplitude at its mean).
        assert!((value - (x0 - 0.5 * x0 * x0)).abs() < 1e-6, "{value}");
        let note = &round.decision.as_ref().unwrap().1;
        assert!(note.contains("robust optimum: mean "), "{note}");
        assert!(note.contains("256 scenarios), mean − 2·std = "), "{note}");
    }

    #[tokio::test]
    async fn a_probabilistic_bound_holds_with_its_probability_at_the_optimum() {
        // Maximise x0 subject to P[x0 + x1 > 0.5] ≤ 0.05 with x1 ~ N(0, 0.25) (coded):
        // x0 + 1.645·0.25 ≤ 0.5, so x0 = 0.089, where the probability is 5 %.
        let text = robust_study(
            "{response: discharge_rate, goal: maximise, constraints: [{response: segregation_ratio, max: 0.5, probability: 0.05}]}",
        );
        let run = testing::round_run(&text, |c, _| JobResults {
            responses: vec![
                ("discharge_rate".into(), c[0]),
                ("segregation_ratio".into(), c[0] + c[1]),
            ],
            series: vec![],
            note: None,
        })
        .await;
        advance(&run.store, run.id, &run.study, &run.runs_dir())
            .await
            .unwrap();
        let round = &run.store.rounds(run.id).await.unwrap()[0];
        let x0 = (round.optimum.as_ref().unwrap().3[0] - 0.024) / 0.004;
        assert!(
            (x0 - 0.0888).abs() < 0.03,
            "x0 = {x0}: {:?}",
            round.decision
        );
        let note = &round.decision.as_ref().unwrap().1;
        let p: f64 = note
            .split("P[segregation_ratio > 0.5] = ")
            .nth(1)
            .and_then(|rest| rest.split(' ').next())
            .and_then(|p| p.parse().ok())
            .unwrap_or_else(|| panic!("{note}"));
        assert!((p - 0.05).abs() < 0.015, "{note}");
        assert!(note.contains("(100000 samples; allowed 0.05)"), "{note}");
    }
}
