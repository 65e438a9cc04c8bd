//! Response surfaces refitted from what the store keeps: each round's succeeded design
//! runs (its own and earlier rounds' inside its box) and the basis and order of its
//! stored fit. The fit is deterministic, so the
//! refit equals the stored one; it also gives what the store does not keep — the
//! leave-one-out predictions, the leverages and the surface between the points — for
//! `orch report` and for the warnings of `orch status` and `orch fit`.

use std::collections::{BTreeMap, HashMap, HashSet};

use orch_metamodel::co_kriging::LevelHyperparameters;
use orch_metamodel::kriging::{Kernel, Trend};
use orch_metamodel::surrogate::{ModelSpec, Surrogate};
use orch_metamodel::{Basis, BasisKind, FactorRange};
use serde_json::json;

use crate::store::{
    JobLink, JobLinkRow, JobState, PointRow, ResponseValues, Sensitivity, Store, StoreError,
    StoredFit,
};

/// One succeeded job on a design point (not a held-out test point).
#[derive(Debug, Clone, PartialEq)]
pub struct Run {
    /// Job name.
    pub job: String,
    /// Coded factor values of its point, in [-1, 1] of its round's box.
    pub coded: Vec<f64>,
    /// Natural factor values (SI units).
    pub natural: Vec<f64>,
    /// Its fidelity level (0 the cheapest).
    pub fidelity: u32,
    /// Its responses, by name.
    pub responses: ResponseValues,
}

impl Run {
    /// The value of the response `name`, if this run has it.
    pub fn response(&self, name: &str) -> Option<f64> {
        self.responses.get(name)
    }
}

/// The observations of one response over a round's design runs.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Observed {
    /// Job names.
    pub jobs: Vec<String>,
    /// Coded points.
    pub coded: Vec<Vec<f64>>,
    /// Natural points.
    pub natural: Vec<Vec<f64>>,
    /// Fidelity level of each run (0 the cheapest).
    pub fidelity: Vec<u32>,
    /// Observed values.
    pub y: Vec<f64>,
}

impl Observed {
    /// Coded points with the fidelity level as a last coordinate: what a co-Kriging
    /// surrogate is fitted to ([`Surrogate::fit_co_kriging`]).
    pub fn coded_with_level(&self) -> Vec<Vec<f64>> {
        self.coded
            .iter()
            .zip(&self.fidelity)
            .map(|(p, &level)| p.iter().copied().chain([f64::from(level)]).collect())
            .collect()
    }
}

/// Succeeded design runs each round's fits use, by round: the round's own and every
/// earlier round's that lie inside its box (a smaller box keeps what was already
/// measured inside it), coded in that round's box.
pub async fn design_runs(
    store: &Store,
    study_id: i64,
) -> Result<BTreeMap<i64, Vec<Run>>, StoreError> {
    let names = store.response_names(study_id).await?;
    design_runs_named(store, study_id, &names).await
}

/// The responses `rounds` fitted, each once, in name order: what their surfaces,
/// verdicts and warnings are judged from.
pub fn fitted_names(rounds: &[crate::store::StoredRound]) -> Vec<String> {
    let mut names: Vec<String> = rounds
        .iter()
        .flat_map(|r| r.fits.iter().map(|f| f.response.clone()))
        .collect();
    names.sort();
    names.dedup();
    names
}

/// [`design_runs`] with only the responses `names` (distinct) read and kept: what a
/// command that judges or refits some responses' surfaces needs.
pub async fn design_runs_named(
    store: &Store,
    study_id: i64,
    names: &[String],
) -> Result<BTreeMap<i64, Vec<Run>>, StoreError> {
    let points = store.points(study_id).await?;
    let responses = store.responses_named(study_id, names).await?;
    let jobs = store.job_links(study_id).await?;
    design_runs_taking(store, study_id, points, jobs, responses).await
}

/// [`design_runs`] from the study's points, jobs and responses (by job id), which it
/// takes over: each run takes its job's values instead of copying them, and what is
/// left is dropped before the rounds' lists are made, so a large study is not held
/// twice.
pub async fn design_runs_taking(
    store: &Store,
    study_id: i64,
    points: Vec<PointRow>,
    jobs: Vec<JobLinkRow>,
    mut responses: BTreeMap<i64, ResponseValues>,
) -> Result<BTreeMap<i64, Vec<Run>>, StoreError> {
    let own = own_design_runs(&points, &jobs, |job_id| {
        responses.remove(&job_id).unwrap_or_default()
    });
    drop((points, jobs, responses));
    by_round(store, study_id, own).await
}

/// [`design_runs`] from the study's points, jobs and responses (by job id) that the
/// caller has already read, so that a command reads each of them once; only the
/// rounds' boxes are read here.
pub async fn design_runs_from(
    store: &Store,
    study_id: i64,
    points: &[PointRow],
    jobs: &[impl JobLink],
    responses: &BTreeMap<i64, ResponseValues>,
) -> Result<BTreeMap<i64, Vec<Run>>, StoreError> {
    let own = own_design_runs(points, jobs, |job_id| {
        responses.get(&job_id).cloned().unwrap_or_default()
    });
    by_round(store, study_id, own).await
}

/// Each round's runs from the runs each round ran itself (`own`): the round's box is
/// read and [`runs_inside`] applied.
async fn by_round(
    store: &Store,
    study_id: i64,
    mut own: BTreeMap<i64, Vec<Run>>,
) -> Result<BTreeMap<i64, Vec<Run>>, StoreError> {
    let rounds: Vec<i64> = own.keys().copied().collect();
    let mut out = BTreeMap::new();
    // Latest round first: no later round still needs a round's own runs when its
    // turn comes, so they move into its list instead of being copied.
    for &round in rounds.iter().rev() {
        let ranges = store.round_ranges(study_id, round).await?;
        let mine = own.remove(&round).unwrap_or_default();
        let mut runs = runs_inside(&own, round, &ranges);
        runs.extend(mine);
        out.insert(round, runs);
    }
    Ok(out)
}

/// The runs of rounds up to `round` whose natural point lies in `ranges` (the
/// round's box), coded in it; the round's own runs keep their stored coding.
pub fn runs_inside(own: &BTreeMap<i64, Vec<Run>>, round: i64, ranges: &[FactorRange]) -> Vec<Run> {
    let inside = |natural: &[f64]| {
        natural.iter().zip(ranges).all(|(v, r)| {
            let slack = 1e-9 * (r.max - r.min).abs();
            *v >= r.min - slack && *v <= r.max + slack
        })
    };
    let mut runs: Vec<Run> = Vec::new();
    for (&earlier, earlier_runs) in own.range(..round) {
        debug_assert!(earlier < round);
        runs.extend(
            earlier_runs
                .iter()
                .filter(|run| inside(&run.natural))
                .map(|run| Run {
                    coded: run
                        .natural
                        .iter()
                        .zip(ranges)
                        .map(|(v, r)| r.to_coded(*v).clamp(-1.0, 1.0))
                        .collect(),
                    ..run.clone()
                }),
        );
    }
    runs.extend(own.get(&round).into_iter().flatten().cloned());
    runs
}

/// Succeeded runs on design points (not held-out test points), by the round that ran
/// them, in job order; `responses_of` gives a job's responses in name order. A run is
/// one observation however many jobs share its identity: a job reused from an earlier
/// one of the study (a point a later round revisits) is left out, since it is a copy,
/// not a replicate.
fn own_design_runs<J: JobLink>(
    points: &[PointRow],
    jobs: &[J],
    mut responses_of: impl FnMut(i64) -> ResponseValues,
) -> BTreeMap<i64, Vec<Run>> {
    let points: HashMap<i64, &PointRow> = points
        .iter()
        .filter(|p| p.purpose == crate::store::PointRole::Design)
        .map(|p| (p.id, p))
        .collect();
    let mut out: BTreeMap<i64, Vec<Run>> = BTreeMap::new();
    // A coupled chain's later DEM and CFD runs replace its earlier ones.
    let superseded = crate::coupling::superseded(jobs);
    let mut identities: HashSet<&str> = HashSet::new();
    for job in jobs {
        let Some(point) = points.get(&job.point_id()) else {
            continue;
        };
        if job.state() != JobState::Succeeded || superseded.contains(&job.id()) {
            continue;
        }
        if job
            .identity()
            .is_some_and(|identity| !identities.insert(identity))
        {
            continue;
        }
        out.entry(point.round).or_default().push(Run {
            responses: responses_of(job.id()),
            job: job.name().to_string(),
            coded: point.coded.clone(),
            natural: point.natural.clone(),
            fidelity: point.fidelity,
        });
    }
    out
}

/// The runs of `runs` that have `response`, as the round's analysis saw them.
pub fn observed(runs: &[Run], response: &str) -> Observed {
    let mut observed = Observed::default();
    for run in runs {
        if let Some(value) = run.response(response) {
            observed.jobs.push(run.job.clone());
            observed.coded.push(run.coded.clone());
            observed.natural.push(run.natural.clone());
            observed.fidelity.push(run.fidelity);
            observed.y.push(value);
        }
    }
    observed
}

/// The basis a stored fit names.
pub fn basis_kind(name: &str) -> Option<BasisKind> {
    match name {
        "legendre" => Some(BasisKind::Legendre),
        "monomial" => Some(BasisKind::Monomial),
        _ => None,
    }
}

/// A surrogate's spec as the store keeps it (JSON).
pub fn spec_json(spec: &ModelSpec) -> String {
    spec_value(spec).to_string()
}

fn spec_value(spec: &ModelSpec) -> serde_json::Value {
    match spec {
        ModelSpec::Polynomial {
            kind,
            levels,
            terms,
        } => json!({
            "model": "polynomial",
            "basis": match kind { BasisKind::Legendre => "legendre", BasisKind::Monomial => "monomial" },
            "levels": levels,
            "terms": terms,
        }),
        ModelSpec::Kriging {
            kernel,
            trend,
            length_scales,
            process_variance,
            noise_variance,
        } => json!({
            "model": "kriging",
            "kernel": kernel_name(*kernel),
            "trend": trend_name(*trend),
            "length_scales": length_scales,
            "process_variance": process_variance,
            "noise_variance": noise_variance,
        }),
        ModelSpec::CoKriging {
            kernel,
            trend,
            levels,
        } => json!({
            "model": "co_kriging",
            "kernel": kernel_name(*kernel),
            "trend": trend_name(*trend),
            "levels": levels
                .iter()
                .map(|l| json!({
                    "length_scales": l.length_scales,
                    "process_variance": l.process_variance,
                    "noise_variance": l.noise_variance,
                }))
                .collect::<Vec<_>>(),
        }),
        ModelSpec::KrigingPerLevel { levels, models } => json!({
            "model": "kriging_per_level",
            "levels": levels,
            "models": models
                .iter()
                .map(|(combination, spec)| json!({"levels": combination, "spec": spec_value(spec)}))
                .collect::<Vec<_>>(),
        }),
    }
}

fn kernel_name(kernel: Kernel) -> &'static str {
    match kernel {
        Kernel::Matern52 => "matern52",
        Kernel::SquaredExponential => "squared_exponential",
    }
}

fn trend_name(trend: Trend) -> &'static str {
    match trend {
        Trend::Constant => "constant",
        Trend::Linear => "linear",
    }
}

/// The spec [`spec_json`] wrote; `None` for text it did not write.
pub fn spec_from_json(text: &str) -> Option<ModelSpec> {
    spec_from_value(&serde_json::from_str(text).ok()?)
}

fn spec_from_value(value: &serde_json::Value) -> Option<ModelSpec> {
    let numbers = |key: &str| -> Option<Vec<f64>> {
        value[key].as_array()?.iter().map(|v| v.as_f64()).collect()
    };
    let small = |v: &serde_json::Value| -> Option<Vec<u32>> {
        v.as_array()?
            .iter()
            .map(|e| e.as_u64().and_then(|e| u32::try_from(e).ok()))
            .collect()
    };
    // Specs stored before text factors have no levels: every factor numeric.
    let levels = || match &value["levels"] {
        serde_json::Value::Null => Some(Vec::new()),
        other => small(other),
    };
    let kernel = || match value["kernel"].as_str()? {
        "matern52" => Some(Kernel::Matern52),
        "squared_exponential" => Some(Kernel::SquaredExponential),
        _ => None,
    };
    let trend = || match value["trend"].as_str()? {
        "constant" => Some(Trend::Constant),
        "linear" => Some(Trend::Linear),
        _ => None,
    };
    match value["model"].as_str()? {
        "polynomial" => Some(ModelSpec::Polynomial {
            kind: basis_kind(value["basis"].as_str()?)?,
            levels: levels()?,
            terms: value["terms"]
                .as_array()?
                .iter()
                .map(small)
                .collect::<Option<_>>()?,
        }),
        "kriging" => Some(ModelSpec::Kriging {
            kernel: kernel()?,
            trend: trend()?,
            length_scales: numbers("length_scales")?,
            process_variance: value["process_variance"].as_f64()?,
            noise_variance: value["noise_variance"].as_f64()?,
        }),
        "co_kriging" => Some(ModelSpec::CoKriging {
            kernel: kernel()?,
            trend: trend()?,
            levels: value["levels"]
                .as_array()?
                .iter()
                .map(|l| {
                    Some(LevelHyperparameters {
                        length_scales: l["length_scales"]
                            .as_array()?
                            .iter()
                            .map(|v| v.as_f64())
                            .collect::<Option<_>>()?,
                        process_variance: l["process_variance"].as_f64()?,
                        noise_variance: l["noise_variance"].as_f64()?,
                    })
                })
                .collect::<Option<_>>()?,
        }),
        "kriging_per_level" => Some(ModelSpec::KrigingPerLevel {
            levels: levels()?,
            models: value["models"]
                .as_array()?
                .iter()
                .map(|m| Some((small(&m["levels"])?, spec_from_value(&m["spec"])?)))
                .collect::<Option<_>>()?,
        }),
        _ => None,
    }
}

/// The stored surrogate again, from its observations: the one its spec names, or
/// (fits stored before specs) the complete polynomial of its basis and order; `None`
/// when it had no surface or cannot be rebuilt.
pub fn refit(fit: &StoredFit, factor_names: &[String], observed: &Observed) -> Option<Surrogate> {
    if fit.error.is_some() {
        return None;
    }
    let spec = match &fit.spec {
        Some(text) => spec_from_json(text)?,
        None => ModelSpec::Polynomial {
            kind: basis_kind(&fit.basis)?,
            levels: Vec::new(),
            terms: Basis::complete(
                basis_kind(&fit.basis)?,
                factor_names.len(),
                u32::try_from(fit.order).ok()?,
            )
            .terms,
        },
    };
    let coded = match spec {
        ModelSpec::CoKriging { .. } => observed.coded_with_level(),
        _ => observed.coded.clone(),
    };
    Surrogate::rebuild(&spec, factor_names, &coded, &observed.y).ok()
}

/// Base samples of the Monte Carlo Sobol indices of a surrogate that has no exact
/// ones: 4096 rows, `4096 (k + 2)` predictions, indices to about ±0.02.
pub const SOBOL_BASE_SAMPLES: usize = 4096;

/// Sobol indices of each factor of `surrogate` over the round's box, as the store
/// keeps them; empty for a surface that does not vary.
pub fn sensitivities(surrogate: &Surrogate, seed: u64) -> Vec<Sensitivity> {
    let Some((indices, analytic)) = surrogate.sobol(SOBOL_BASE_SAMPLES, seed) else {
        return Vec::new();
    };
    let method = if analytic { "analytic" } else { "saltelli" };
    indices
        .first
        .iter()
        .zip(&indices.total)
        .enumerate()
        .map(|(factor, (first, total))| Sensitivity {
            factor,
            method: method.to_string(),
            first: (first.value, first.low, first.high),
            total: (total.value, total.low, total.high),
        })
        .collect()
}

/// Leave-one-out predictions `y_i − e_i`, when every run has a leave-one-out residual.
pub fn loo_predictions(surrogate: &Surrogate, y: &[f64]) -> Option<Vec<f64>> {
    let loo = surrogate.quality().loo_residuals.as_ref()?;
    Some(y.iter().zip(loo).map(|(y, e)| y - e).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(coded: Vec<f64>, value: f64) -> Run {
        Run {
            job: format!("j{}", coded[0]),
            natural: coded.clone(),
            coded,
            fidelity: 0,
            responses: [("y".to_string(), value)].into_iter().collect(),
        }
    }

    #[test]
    fn loo_predictions_of_a_line_through_noisy_points_leave_each_point_out() {
        let runs: Vec<Run> = [(-1.0, 0.0), (-0.5, 1.2), (0.0, 1.9), (0.5, 3.1), (1.0, 4.0)]
            .iter()
            .map(|(x, y)| run(vec![*x], *y))
            .collect();
        let observed = observed(&runs, "y");
        let stored = StoredFit {
            response: "y".into(),
            basis: "monomial".into(),
            order: 1,
            runs: 5,
            r2: None,
            adjusted_r2: None,
            sigma_cross: None,
            r2_cross: None,
            press: None,
            test_runs: 0,
            sigma_test: None,
            r2_test: None,
            error: None,
            terms: vec![],
            ..Default::default()
        };
        let fit = refit(&stored, &["x".to_string()], &observed).unwrap();
        let loo = loo_predictions(&fit, &observed.y).unwrap();
        // The first point predicted by the line through the other four, by hand.
        let (xs, ys) = ([-0.5, 0.0, 0.5, 1.0], [1.2, 1.9, 3.1, 4.0]);
        let (mx, my) = (0.25, 2.55);
        let slope: f64 = xs
            .iter()
            .zip(ys)
            .map(|(x, y)| (x - mx) * (y - my))
            .sum::<f64>()
            / xs.iter().map(|x| (x - mx).powi(2)).sum::<f64>();
        let expected = my + slope * (-1.0 - mx);
        assert!(
            (loo[0] - expected).abs() < 1e-12,
            "{} vs {expected}",
            loo[0]
        );
    }

    #[test]
    fn jobs_that_share_a_run_identity_are_one_observation() {
        use crate::store::JobLinkRow;
        let point = |id: i64, round: i64| PointRow {
            id,
            round,
            idx: 0,
            purpose: crate::store::PointRole::Design,
            fidelity: 0,
            coded: vec![1.0],
            natural: vec![0.028],
        };
        let job = |id: i64, point_id: i64, identity: Option<&str>| JobLinkRow {
            id,
            point_id,
            name: format!("j{id}").into(),
            state: JobState::Succeeded,
            kind: crate::store::JobKind::Design,
            after_job_id: None,
            identity: identity.map(Into::into),
        };
        // Round 0 ran the corner twice (two replicates); round 1 revisited it and
        // reused replicate 0; a job of an earlier version has no identity.
        let points = [point(1, 0), point(2, 1)];
        let jobs = [
            job(1, 1, Some("a")),
            job(2, 1, Some("b")),
            job(3, 2, Some("a")),
            job(4, 2, None),
            job(5, 2, None),
        ];
        let runs = own_design_runs(&points, &jobs, |_| ResponseValues::default());
        let names =
            |round: i64| -> Vec<String> { runs[&round].iter().map(|r| r.job.clone()).collect() };
        assert_eq!(names(0), ["j1", "j2"]);
        assert_eq!(
            names(1),
            ["j4", "j5"],
            "the copy j3 is left out; runs without an identity each count"
        );
    }

    #[test]
    fn a_round_fits_earlier_runs_inside_its_box_recoded_and_its_own_as_stored() {
        let natural_run = |job: &str, natural: f64, coded: f64| Run {
            job: job.into(),
            coded: vec![coded],
            natural: vec![natural],
            fidelity: 0,
            responses: Default::default(),
        };
        // Round 0 over [0, 10]; round 1 over [4, 8].
        let own = BTreeMap::from([
            (
                0,
                vec![
                    natural_run("r0-0", 0.0, -1.0),
                    natural_run("r0-1", 5.0, 0.0),
                    natural_run("r0-2", 8.0, 0.6),
                    natural_run("r0-3", 10.0, 1.0),
                ],
            ),
            (1, vec![natural_run("r1-0", 6.0, 0.0)]),
        ]);
        let box_1 = [FactorRange { min: 4.0, max: 8.0 }];
        let runs = runs_inside(&own, 1, &box_1);
        let jobs: Vec<&str> = runs.iter().map(|r| r.job.as_str()).collect();
        assert_eq!(jobs, ["r0-1", "r0-2", "r1-0"]);
        assert_eq!(runs[0].coded, [-0.5]);
        assert_eq!(runs[1].coded, [1.0]);
        assert_eq!(runs[2].coded, [0.0]);
        // Round 0 sees only its own runs.
        assert_eq!(
            runs_inside(
                &own,
                0,
                &[FactorRange {
                    min: 0.0,
                    max: 10.0
                }]
            )
            .len(),
            4
        );
    }
}
