//! The metamodel stage: after a round's jobs are final, fit a surface per response,
//! find the objective's optimum in the round's box, propagate the uncertain factors
//! through the surface at the optimum, and decide on the next round (a box
//! `shrink` times as wide around the optimum) or stop. All of it is recorded in one
//! transaction with the next round's jobs, so a crash either loses the whole analysis
//! (and it is redone) or none of it.

use std::path::Path;

use orch_metamodel::optimise::BoxBounds;
use orch_metamodel::propose::{converged, shrink_around};
use orch_metamodel::{optimise, propagate, Basis, BasisKind, Design, FactorRange, Fit, Goal};

use crate::store::{FitRecord, JobState, RoundRecord, Store, StoreError};
use crate::study::{DesignPoint, Study};

/// What happened after a round.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Advance {
    /// A new round's jobs are waiting.
    NextRound(i64),
    /// Nothing more to run; the note says why.
    Done(String),
}

/// The responses fitted after each round: the study's list, the objective, or a default.
pub fn fitted_responses(study: &Study) -> Vec<String> {
    let mut names = study.responses.clone();
    if let Some(objective) = &study.objective {
        if !names.contains(&objective.response) {
            names.insert(0, objective.response.clone());
        }
    }
    if names.is_empty() {
        names = vec!["discharge_rate".into(), "segregation_ratio".into()];
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

async fn analyse(
    store: &Store,
    study_id: i64,
    study: &Study,
    round: i64,
) -> Result<RoundRecord, StoreError> {
    let ranges = store.round_ranges(study_id, round).await?;
    let limits: Vec<FactorRange> = study.factors.iter().map(|f| f.range).collect();
    let points: std::collections::HashMap<i64, Vec<f64>> = store
        .points(study_id)
        .await?
        .into_iter()
        .filter(|p| p.round == round)
        .map(|p| (p.id, p.coded))
        .collect();
    let responses = store.responses(study_id).await?;
    let jobs: Vec<_> = store
        .jobs(study_id)
        .await?
        .into_iter()
        .filter(|j| points.contains_key(&j.point_id) && j.state() == JobState::Succeeded)
        .collect();
    let names: Vec<String> = study.factors.iter().map(|f| f.name.clone()).collect();
    let k = names.len();
    let basis_name = match study.metamodel.basis {
        BasisKind::Legendre => "legendre",
        BasisKind::Monomial => "monomial",
    };
    let mut fits = Vec::new();
    for response in fitted_responses(study) {
        let (x, y): (Vec<Vec<f64>>, Vec<f64>) = jobs
            .iter()
            .filter_map(|j| {
                responses
                    .get(&j.id)?
                    .get(&response)
                    .map(|v| (points[&j.point_id].clone(), *v))
            })
            .unzip();
        let basis = Basis::complete(study.metamodel.basis, k, study.metamodel.order);
        let result = Fit::new(basis, &names, &x, &y).map_err(|e| e.to_string());
        fits.push(FitRecord {
            response,
            basis: basis_name.into(),
            order: study.metamodel.order,
            runs: y.len(),
            result,
        });
    }

    let mut record = RoundRecord {
        round,
        fits,
        optimum: None,
        uncertainty: None,
        decision: "last_round",
        note: String::new(),
        next: None,
    };
    let Some(objective) = &study.objective else {
        record.note = "the study has no objective".into();
        return Ok(record);
    };
    let fit = match &record
        .fits
        .iter()
        .find(|f| f.response == objective.response)
        .expect("the objective is fitted")
        .result
    {
        Ok(fit) => fit.clone(),
        Err(e) => {
            record.decision = "no_optimum";
            record.note = format!("no surface for {}: {e}", objective.response);
            return Ok(record);
        }
    };

    // Uncertain factors are held at their mean while the design factors are optimised.
    let mut bounds = BoxBounds::coded(k);
    let uncertain: Vec<usize> = study
        .uncertainty
        .iter()
        .flat_map(|u| u.parameters.iter().map(|(i, _)| *i))
        .collect();
    if let Some(u) = &study.uncertainty {
        for (index, distribution) in &u.parameters {
            let centre = ranges[*index]
                .to_coded(mean_of(distribution))
                .clamp(-1.0, 1.0);
            bounds.lower[*index] = centre;
            bounds.upper[*index] = centre;
        }
    }
    let predict = |x: &[f64]| fit.predict(x);
    let optimum = optimise(
        &predict,
        study.metamodel.order <= 2,
        objective.goal,
        &bounds,
        study.seed,
    );
    let natural: Vec<f64> = optimum
        .x
        .iter()
        .zip(&ranges)
        .map(|(c, r)| r.to_natural(*c))
        .collect();

    if let Some(u) = &study.uncertainty {
        let inputs: Vec<_> = u.parameters.iter().map(|(_, d)| *d).collect();
        let at_optimum = |sample: &[f64]| {
            let mut x = optimum.x.clone();
            for ((index, _), value) in u.parameters.iter().zip(sample) {
                x[*index] = ranges[*index].to_coded(*value);
            }
            fit.predict(&x)
        };
        if let Ok(spread) = propagate(&at_optimum, &inputs, u.samples, u.seed) {
            record.uncertainty = Some((objective.response.clone(), spread, u.seed));
        }
    }
    let goal = match objective.goal {
        Goal::Minimise => "minimise",
        Goal::Maximise => "maximise",
    };

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
        record.note = format!("round {} of {} was the last", round + 1, study.rounds);
    } else if let Some((_, _, value, _)) =
        previous.filter(|p| converged(p.2, optimum.value, study.metamodel.tolerance))
    {
        record.decision = "converged";
        record.note = format!(
            "the predicted optimum moved from {value:.6} to {:.6}, less than {} %",
            optimum.value,
            study.metamodel.tolerance * 100.0
        );
    } else {
        // Design factors zoom in around the optimum; uncertain ones keep their range.
        let mut next_ranges = shrink_around(&natural, &ranges, &limits, study.metamodel.shrink);
        for &index in &uncertain {
            next_ranges[index] = ranges[index];
        }
        let design = Design::build(&study.design, k).expect("the design was built for round 0");
        let next_points = design
            .points
            .into_iter()
            .map(|coded| DesignPoint {
                natural: coded
                    .iter()
                    .zip(&next_ranges)
                    .map(|(c, r)| r.to_natural(*c))
                    .collect(),
                coded,
            })
            .collect();
        record.decision = "next_round";
        record.note = format!(
            "round {} in a box {} times as wide around the optimum",
            round + 2,
            study.metamodel.shrink
        );
        record.next = Some((next_ranges, next_points));
    }
    record.optimum = Some((objective.response.clone(), goal, optimum, natural));
    Ok(record)
}

fn mean_of(distribution: &orch_metamodel::Distribution) -> f64 {
    match *distribution {
        orch_metamodel::Distribution::Normal { mean, .. } => mean,
        orch_metamodel::Distribution::Uniform { low, high } => 0.5 * (low + high),
        orch_metamodel::Distribution::LogNormal { mu, sigma } => (mu + 0.5 * sigma * sigma).exp(),
    }
}
