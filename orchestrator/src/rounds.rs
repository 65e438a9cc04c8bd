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

use orch_metamodel::propose::converged;
use orch_metamodel::surrogate::{choose, choose_co_kriging, Choice, Surrogate, SurrogateError};
use orch_metamodel::{lack_of_fit, BasisKind, Goal, KrigingOptions, Nugget};

use crate::store::{
    CandidateScore, Decision, FitRecord, JobLinkRow, JobState, LackOfFitRow, RoundRecord, Store,
    StoreError,
};
use crate::study::{Objective, Study};
use crate::surfaces;

mod next;
mod objective;
mod optimum;
pub mod pareto;

use objective::{Inputs, ObjectiveSurface};
pub use optimum::ROBUST_SCENARIOS;

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
    if store.round_has_unfinished_jobs(study_id, round).await? {
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
pub(crate) struct Observed {
    /// `(coded points, values)` of the design runs.
    pub design: (Vec<Vec<f64>>, Vec<f64>),
    /// `(coded points, values)` of the held-out test runs.
    pub test: (Vec<Vec<f64>>, Vec<f64>),
}

async fn observed(
    store: &Store,
    study_id: i64,
    round: i64,
    responses: &[String],
    leveled: bool,
) -> Result<HashMap<String, Observed>, StoreError> {
    // Each of the study's tables is read once. The held-out test runs are taken out
    // first; the design runs then take the rest over (not a copy of it).
    let points = store.points(study_id).await?;
    let values = store.responses_named(study_id, responses).await?;
    let jobs = store.job_links(study_id).await?;
    let test_points: HashMap<i64, &[f64]> = points
        .iter()
        .filter(|p| p.round == round && p.purpose == crate::store::PointRole::Test)
        .map(|p| (p.id, p.coded.as_slice()))
        .collect();
    let test_jobs: Vec<&JobLinkRow> = jobs
        .iter()
        .filter(|j| test_points.contains_key(&j.point_id) && j.state == JobState::Succeeded)
        .collect();
    let mut tests: HashMap<&String, (Vec<Vec<f64>>, Vec<f64>)> = HashMap::new();
    for response in responses {
        let test = tests.entry(response).or_default();
        for job in &test_jobs {
            if let Some(value) = values.get(&job.id).and_then(|v| v.get(response)) {
                test.0.push(test_points[&job.point_id].to_vec());
                test.1.push(value);
            }
        }
    }
    drop((test_points, test_jobs));
    let design_runs = surfaces::design_runs_taking(store, study_id, points, jobs, values)
        .await?
        .remove(&round)
        .unwrap_or_default();
    let mut out = HashMap::new();
    for response in responses {
        let design = surfaces::observed(&design_runs, response);
        // Over fidelity levels a run's level rides as a last coordinate (co-Kriging).
        let coded = if leveled {
            design.coded_with_level()
        } else {
            design.coded
        };
        out.insert(
            response.clone(),
            Observed {
                design: (coded, design.y),
                test: tests.remove(response).unwrap_or_default(),
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
    let responses = fitted_responses(study);
    // A response whose runs also report its 95 % interval (its spec's `interval`, as
    // the hopper's discharge rate has) tells Kriging its run-to-run noise.
    let with_intervals: Vec<String> = responses
        .iter()
        .flat_map(|r| [Some(r.clone()), study.interval_of(r).map(str::to_string)])
        .flatten()
        .collect();
    let leveled = !study.fidelities.is_empty();
    let data = observed(store, study_id, round, &with_intervals, leveled).await?;
    let options = study.metamodel.kriging_options(study.seed);
    let previous = previous_length_scales(store, study_id, round, &ranges).await?;
    let fits = fit_responses(study, &responses, &data, &previous, &options);

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
            .and_then(|f| f.result.as_ref().err())
            .map(ToString::to_string)
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
    let surface = ObjectiveSurface {
        objective,
        surfaces: &surfaces,
    };
    let inputs = Inputs::of(study, &ranges);
    let found = optimum::find(study, &surface, &inputs, &ranges);
    let optimum = found.optimum;
    let natural = study.point(optimum.x.clone(), &ranges).natural;
    let objective_name = objective.name();
    let (spread, total) = surface.spread_at(study, &optimum.x, &ranges);
    if let (Some(spread), Some(u)) = (spread, &study.uncertainty) {
        record.uncertainty = Some((objective_name.clone(), spread, u.seed));
        record.uncertainty_total = total;
    }
    record.optimum_interval = surface.prediction_interval(&optimum.x);
    let goal = match objective.goal {
        Goal::Minimise => "minimise",
        Goal::Maximise => "maximise",
    };
    record.optimum = Some((objective_name, goal, optimum.clone(), natural.clone()));
    if !found.feasible {
        record.decision = Decision::NoOptimum;
        record.note = format!(
            "no point of the box satisfies the objective's constraints; the best compromise reaches {}",
            found.at_bounds.join(", ")
        );
        return Ok(record);
    }
    let mut constrained = if found.at_bounds.is_empty() {
        String::new()
    } else {
        format!("; at the optimum {}", found.at_bounds.join(", "))
    };
    for line in &found.robustness {
        constrained.push_str("; ");
        constrained.push_str(line);
    }

    let previous = previous_round(store, study_id, round)
        .await?
        .and_then(|r| r.optimum);
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
        next::unresolved_gain(
            before,
            &ranges,
            &optimum,
            objective.goal,
            &|x| surface.value(x),
            &|x| surface.mean_std(x),
        )
    }) {
        record.decision = Decision::Converged;
        record.note = format!("{note}{constrained}");
    } else {
        let next = next::propose(
            study, &surface, &inputs, &data, &options, &ranges, &natural, round,
        );
        let tests = study.test_points(round + 1, &next.ranges);
        record.decision = Decision::NextRound;
        record.note = format!("round {}: {}{constrained}", round + 2, next.how);
        record.next = Some((next.ranges, next.points, tests));
    }
    Ok(record)
}

/// Each response's surface on the round's design runs, with the previous round's
/// length scales as a start: co-Kriging over fidelity levels, else the study's model
/// choice, told each run's noise where the runs report their intervals.
fn fit_responses(
    study: &Study,
    responses: &[String],
    data: &HashMap<String, Observed>,
    previous: &HashMap<String, Vec<f64>>,
    options: &KrigingOptions,
) -> Vec<FitRecord> {
    let names: Vec<String> = study.factors.iter().map(|f| f.name.clone()).collect();
    let leveled = !study.fidelities.is_empty();
    let basis_name = match study.metamodel.basis {
        BasisKind::Legendre => "legendre",
        BasisKind::Monomial => "monomial",
    };
    let mut fits = Vec::new();
    for response in responses {
        let observed = &data[response];
        let (x, y) = (&observed.design.0, &observed.design.1);
        let options = KrigingOptions {
            previous_length_scales: previous.get(response).cloned(),
            ..options.clone()
        };
        if leveled {
            // Each level's noise is its own (its replicates', else fitted).
            let choice = choose_co_kriging(x, y, &options);
            fits.push(fit_record(
                response, basis_name, observed, choice, study.seed,
            ));
            continue;
        }
        let intervals = study.interval_of(response).and_then(|name| data.get(name));
        let options = match intervals.and_then(|intervals| noise_from_intervals(x, y, intervals)) {
            Some(variance) => KrigingOptions {
                nugget: Nugget::Fixed(variance),
                ..options
            },
            None => options,
        };
        let choice = choose(
            study.metamodel.model,
            study.metamodel.basis,
            &names,
            &study.levels(),
            x,
            y,
            &options,
        );
        fits.push(fit_record(
            response, basis_name, observed, choice, study.seed,
        ));
    }
    fits
}

/// The round before `round`, as the store holds it (none before the first).
async fn previous_round(
    store: &Store,
    study_id: i64,
    round: i64,
) -> Result<Option<crate::store::StoredRound>, StoreError> {
    if round == 0 {
        return Ok(None);
    }
    Ok(store
        .rounds(study_id)
        .await?
        .into_iter()
        .find(|r| r.round == round - 1))
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

/// The length scales of the previous round's Kriging surfaces, by response, in the
/// coded units of this round's box `ranges`: each likelihood search starts there too.
async fn previous_length_scales(
    store: &Store,
    study_id: i64,
    round: i64,
    ranges: &[orch_metamodel::FactorRange],
) -> Result<HashMap<String, Vec<f64>>, StoreError> {
    if round == 0 {
        return Ok(HashMap::new());
    }
    let Some(before) = store
        .rounds(study_id)
        .await?
        .into_iter()
        .find(|r| r.round == round - 1 && r.ranges.len() == ranges.len())
    else {
        return Ok(HashMap::new());
    };
    let mut out = HashMap::new();
    for fit in &before.fits {
        let spec = fit.spec.as_deref().and_then(surfaces::spec_from_json);
        if let Some(orch_metamodel::surrogate::ModelSpec::Kriging { length_scales, .. }) = spec {
            // A coded unit is half the box's width: rescale to this round's box.
            let rescaled = length_scales
                .iter()
                .zip(before.ranges.iter().zip(ranges))
                .map(|(l, (old, new))| l * (old.max - old.min) / (new.max - new.min))
                .collect();
            out.insert(fit.response.clone(), rescaled);
        }
    }
    Ok(out)
}

/// The run-to-run noise variance of a response whose runs report the half-width of
/// its 95 % interval (`intervals`): the mean of `(half-width / 1.96)²` over the design
/// runs, when every design run reports one and no point is replicated (replicates
/// measure the noise directly, and Kriging takes it from them).
fn noise_from_intervals(x: &[Vec<f64>], y: &[f64], intervals: &Observed) -> Option<f64> {
    let (points, half_widths) = &intervals.design;
    if y.is_empty() || half_widths.len() != y.len() || points.as_slice() != x {
        return None;
    }
    if orch_metamodel::pure_error_variance(x, y).is_some() {
        return None;
    }
    let variance = half_widths
        .iter()
        .map(|h| (h / 1.959_963_984_540_054).powi(2))
        .sum::<f64>()
        / half_widths.len() as f64;
    (variance.is_finite() && variance > 0.0).then_some(variance)
}

/// What the store keeps of one response's model choice on a round's runs.
fn fit_record(
    response: &str,
    basis_name: &str,
    observed: &Observed,
    choice: Result<Choice, SurrogateError>,
    seed: u64,
) -> FitRecord {
    let (x, y) = (&observed.design.0, &observed.design.1);
    let choice = match choice {
        Ok(choice) => choice,
        Err(why) => {
            return FitRecord {
                response: response.to_string(),
                basis: basis_name.to_string(),
                order: 0,
                runs: y.len(),
                result: Err(why),
                test: None,
                model: None,
                spec: None,
                candidates: Vec::new(),
                lack_of_fit: None,
                sensitivities: Vec::new(),
            }
        }
    };
    let Choice {
        surrogate,
        candidates,
        chosen,
        by_prognosis,
    } = choice;
    let candidate_scores = candidates
        .iter()
        .enumerate()
        .map(|(i, c)| CandidateScore {
            model: c.name.clone(),
            parameters: c.parameters,
            loo_rmse: c.loo_rmse,
            chosen: i == chosen,
            note: match (&c.note, i == chosen && !by_prognosis) {
                (_, true) => {
                    Some("kept without a score: no candidate could be cross-validated".into())
                }
                (note, false) => note.clone(),
            },
        })
        .collect();
    FitRecord {
        response: response.to_string(),
        basis: basis_name.to_string(),
        order: surrogate.polynomial().map_or(0, |fit| fit.basis.order),
        runs: y.len(),
        test: surrogate
            .test(&observed.test.0, &observed.test.1)
            .map(|quality| (observed.test.1.len(), quality)),
        model: Some(candidates[chosen].name.clone()),
        spec: Some(surfaces::spec_json(&surrogate.spec())),
        candidates: candidate_scores,
        lack_of_fit: surrogate
            .polynomial()
            .and_then(|fit| lack_of_fit(fit, x, y))
            .map(|l| LackOfFitRow {
                f: l.f,
                p: l.p_value,
                lack_of_fit_dof: l.dof_lack_of_fit,
                pure_error_dof: l.dof_pure_error,
            }),
        sensitivities: surfaces::sensitivities(&surrogate, seed),
        result: Ok(surrogate),
    }
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
            store
                .mark_rendered(job.id, &format!("test run {}", job.id))
                .await
                .unwrap();
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
            .filter(|p| p.round == 1 && p.purpose == crate::store::PointRole::Design)
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

    #[tokio::test]
    async fn a_response_with_its_own_interval_gives_kriging_its_noise() {
        // Every run reports a 95 % half-width of 0.0196 for its rate: noise variance
        // (0.0196 / 1.96)² ≈ 1e-4, which the Kriging surrogate takes as its nugget.
        let run = testing::round_run(KRIGING, |coded, _| JobResults {
            responses: vec![
                (
                    "discharge_rate".into(),
                    (coded[0] - 0.3).powi(2) + (coded[1] + 0.4).powi(2),
                ),
                ("discharge_rate_ci95".into(), 0.0196),
            ],
            series: vec![],
            note: None,
        })
        .await;
        advance(&run.store, run.id, &run.study, &run.runs_dir())
            .await
            .unwrap();
        let round = &run.store.rounds(run.id).await.unwrap()[0];
        let fit = round
            .fits
            .iter()
            .find(|f| f.response == "discharge_rate")
            .unwrap();
        let spec = surfaces::spec_from_json(fit.spec.as_deref().unwrap()).unwrap();
        let orch_metamodel::surrogate::ModelSpec::Kriging { noise_variance, .. } = spec else {
            panic!("{spec:?}")
        };
        let expected = (0.0196f64 / 1.959_963_984_540_054).powi(2);
        assert!(
            (noise_variance - expected).abs() < 1e-15,
            "{noise_variance}"
        );
    }
}
