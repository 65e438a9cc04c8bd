//! Rounds of a study and what the metamodel stage concluded from each.

use std::path::Path;

use orch_metamodel::surrogate::{Surrogate, SurrogateError};
use orch_metamodel::{FactorRange, Optimum, Spread, TestQuality};
use sqlx::Row;

use super::rows::parse_state;
use super::{query_error, Decision, Store, StoreError};
use orch_study::{DesignPoint, Study};

/// A fitted (or unfittable) surface of one response, to record.
#[derive(Debug, Clone)]
pub struct FitRecord {
    /// Response name.
    pub response: String,
    /// Basis name (`legendre`, `monomial`).
    pub basis: String,
    /// Order.
    pub order: u32,
    /// Runs available.
    pub runs: usize,
    /// The chosen surrogate, or why there is none (stored as its message, which is
    /// what status and the report show).
    pub result: Result<Surrogate, SurrogateError>,
    /// Held-out test runs and the fit's error on them.
    pub test: Option<(usize, TestQuality)>,
    /// The chosen surrogate's name for people, e.g. `quadratic, 5 of 6 terms`.
    pub model: Option<String>,
    /// JSON that rebuilds the chosen surrogate without a search.
    pub spec: Option<String>,
    /// Every candidate the model choice compared.
    pub candidates: Vec<CandidateScore>,
    /// The lack-of-fit test against replicates, when there are replicates.
    pub lack_of_fit: Option<LackOfFitRow>,
    /// Sobol indices of each factor over the round's box.
    pub sensitivities: Vec<Sensitivity>,
}

/// How one candidate surrogate scored in the automatic model choice.
#[derive(Debug, Clone, PartialEq)]
pub struct CandidateScore {
    /// Its name, e.g. `cubic, 7 of 10 terms` or `kriging, Matérn 5/2, constant trend`.
    pub model: String,
    /// Fitted parameters (terms, or trend terms plus hyperparameters).
    pub parameters: usize,
    /// Root mean square of its leave-one-out residuals, in the response's unit.
    pub loo_rmse: Option<f64>,
    /// True for the one the round uses.
    pub chosen: bool,
    /// Why it has no score, or why it was passed over despite it.
    pub note: Option<String>,
}

/// The lack-of-fit F test of a surface against the pure error of replicate runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LackOfFitRow {
    /// `F = (SS_lof / dof_lof) / (SS_pe / dof_pe)`.
    pub f: f64,
    /// `P(F' ≥ F)` under the hypothesis that the surface's form is right.
    pub p: f64,
    /// Degrees of freedom of the lack of fit.
    pub lack_of_fit_dof: usize,
    /// Degrees of freedom of the pure error.
    pub pure_error_dof: usize,
}

/// Sobol indices of one factor for one response, over the round's box (factors
/// uniform on it), each `(estimate, low, high)` of a 95 % interval.
#[derive(Debug, Clone, PartialEq)]
pub struct Sensitivity {
    /// Index of the factor.
    pub factor: usize,
    /// `analytic` (from Legendre coefficients) or `saltelli` (Monte Carlo).
    pub method: String,
    /// First-order index: the share of the variance the factor explains alone.
    pub first: (f64, f64, f64),
    /// Total index: its share including every interaction.
    pub total: (f64, f64, f64),
}

/// One point of a round's Pareto front (multi-objective studies).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FrontPoint {
    /// Each objective's `(response, goal, predicted value)` there, in the order of the
    /// study file's `objectives:`; the goal is `minimise` or `maximise`.
    pub objectives: Vec<(String, String, f64)>,
    /// The factors, coded in the round's box.
    pub coded: Vec<f64>,
    /// The factors in natural units.
    pub natural: Vec<f64>,
    /// True for the compromise point, the one recorded as the round's optimum.
    pub compromise: bool,
}

/// Everything the analysis of one round decided, recorded at once.
#[derive(Debug, Clone)]
pub struct RoundRecord {
    /// The round analysed.
    pub round: i64,
    /// One per response.
    pub fits: Vec<FitRecord>,
    /// `(response, goal, optimum in coded units, natural values)`.
    pub optimum: Option<(String, &'static str, Optimum, Vec<f64>)>,
    /// The 95 % prediction interval of the objective at the optimum `(low, high)`.
    pub optimum_interval: Option<(f64, f64)>,
    /// `(response, spread, seed)` at the optimum.
    pub uncertainty: Option<(String, Spread, u64)>,
    /// The spread at the optimum with the surrogate's error sampled too.
    pub uncertainty_total: Option<Spread>,
    /// The Pareto front of a multi-objective round, in order along it; empty otherwise.
    pub front: Vec<FrontPoint>,
    /// What the stage decided.
    pub decision: Decision,
    /// Why, for people.
    pub note: String,
    /// The next round's box, design points and test points, when there is one.
    pub next: Option<(Vec<FactorRange>, Vec<DesignPoint>, Vec<DesignPoint>)>,
}

/// An optimum's row: response, goal, value and its prediction interval's ends.
type OptimumRow = (String, String, f64, Option<f64>, Option<f64>);

/// A stored fit.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct StoredFit {
    /// Response.
    pub response: String,
    /// Basis.
    pub basis: String,
    /// Order.
    pub order: i64,
    /// Runs.
    pub runs: i64,
    /// ANOVA R².
    pub r2: Option<f64>,
    /// Adjusted R².
    pub adjusted_r2: Option<f64>,
    /// σ_cross, %.
    pub sigma_cross: Option<f64>,
    /// 1 − (σ_cross/100)².
    pub r2_cross: Option<f64>,
    /// PRESS.
    pub press: Option<f64>,
    /// Held-out runs.
    pub test_runs: i64,
    /// σ_test_rel, %.
    pub sigma_test: Option<f64>,
    /// R² from σ_test_rel.
    pub r2_test: Option<f64>,
    /// Why there is no fit.
    pub error: Option<String>,
    /// `(name, coefficient, standard error, t)`.
    pub terms: Vec<(String, f64, Option<f64>, Option<f64>)>,
    /// The surrogate's name for people (none before version 9: the full polynomial).
    pub model: Option<String>,
    /// JSON that rebuilds the surrogate (none before version 9).
    pub spec: Option<String>,
    /// The candidates the model choice compared.
    pub candidates: Vec<CandidateScore>,
    /// The lack-of-fit test, when there were replicates.
    pub lack_of_fit: Option<LackOfFitRow>,
    /// Sobol indices per factor.
    pub sensitivities: Vec<Sensitivity>,
}

/// A stored round with its conclusions.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct StoredRound {
    /// Round number.
    pub round: i64,
    /// Its box, per factor.
    pub ranges: Vec<FactorRange>,
    /// Its fits.
    pub fits: Vec<StoredFit>,
    /// `(response, goal, value, natural values per factor)`.
    pub optimum: Option<(String, String, f64, Vec<f64>)>,
    /// The 95 % prediction interval of the objective at the optimum.
    pub optimum_interval: Option<(f64, f64)>,
    /// Spread at the optimum through the surface (input uncertainty only).
    pub uncertainty: Option<Spread>,
    /// Spread at the optimum with the surrogate's error sampled too.
    pub uncertainty_total: Option<Spread>,
    /// The Pareto front of a multi-objective round, in order along it; empty otherwise
    /// (and for rounds stored before version 10).
    pub front: Vec<FrontPoint>,
    /// `(decision, note)`.
    pub decision: Option<(Decision, String)>,
}

impl Store {
    /// The latest round that has points.
    pub async fn latest_round(&self, study_id: i64) -> Result<i64, StoreError> {
        sqlx::query_scalar("SELECT COALESCE(MAX(round), 0) FROM points WHERE study_id = ?")
            .bind(study_id)
            .fetch_one(&self.pool)
            .await
            .map_err(query_error("find the latest round"))
    }

    /// True when the analysis of `round` was recorded.
    pub async fn round_decided(&self, study_id: i64, round: i64) -> Result<bool, StoreError> {
        let n: i64 =
            sqlx::query_scalar("SELECT COUNT(*) FROM proposals WHERE study_id = ? AND round = ?")
                .bind(study_id)
                .bind(round)
                .fetch_one(&self.pool)
                .await
                .map_err(query_error("read a round's decision"))?;
        Ok(n > 0)
    }

    /// True when a job on a point of `round` is not final (pending, rendered,
    /// submitted or running); read from the not-final jobs alone (`jobs_by_state`).
    pub async fn round_has_unfinished_jobs(
        &self,
        study_id: i64,
        round: i64,
    ) -> Result<bool, StoreError> {
        static SQL: std::sync::LazyLock<String> = std::sync::LazyLock::new(|| {
            format!(
                "SELECT EXISTS (SELECT 1 FROM jobs j JOIN points p ON p.id = j.point_id
                  WHERE j.study_id = ? AND p.round = ? AND j.state IN ({}))",
                super::rows::state_list(|s| !s.is_final())
            )
        });
        sqlx::query_scalar(&SQL)
            .bind(study_id)
            .bind(round)
            .fetch_one(&self.pool)
            .await
            .map_err(query_error("look for a round's unfinished jobs"))
    }

    /// The box of `round`.
    pub async fn round_ranges(
        &self,
        study_id: i64,
        round: i64,
    ) -> Result<Vec<FactorRange>, StoreError> {
        let rows: Vec<(f64, f64)> = sqlx::query_as(
            "SELECT min, max FROM round_factors WHERE study_id = ? AND round = ? ORDER BY idx",
        )
        .bind(study_id)
        .bind(round)
        .fetch_all(&self.pool)
        .await
        .map_err(query_error("read a round's box"))?;
        Ok(rows
            .into_iter()
            .map(|(min, max)| FactorRange { min, max })
            .collect())
    }

    /// Records a round's fits, optimum, spread and decision, and the next round's box,
    /// points and jobs, in one transaction.
    pub async fn record_round(
        &self,
        study: &Study,
        study_id: i64,
        record: &RoundRecord,
        runs_dir: &Path,
    ) -> Result<(), StoreError> {
        let mut tx = self.begin_write().await?;
        let round = record.round;
        for fit in &record.fits {
            insert_fit(&mut tx, study_id, round, fit).await?;
        }
        insert_optimum_and_spread(&mut tx, study_id, round, record).await?;
        insert_front(&mut tx, study_id, round, &record.front).await?;
        sqlx::query("INSERT INTO proposals (study_id, round, decision, note) VALUES (?, ?, ?, ?)")
            .bind(study_id)
            .bind(round)
            .bind(record.decision)
            .bind(&record.note)
            .execute(&mut *tx)
            .await
            .map_err(query_error("record a decision"))?;
        if let Some((ranges, points, tests)) = &record.next {
            for (idx, range) in ranges.iter().enumerate() {
                sqlx::query("INSERT INTO round_factors (study_id, round, idx, min, max) VALUES (?, ?, ?, ?, ?)")
                    .bind(study_id)
                    .bind(round + 1)
                    .bind(idx as i64)
                    .bind(range.min)
                    .bind(range.max)
                    .execute(&mut *tx)
                    .await
                    .map_err(query_error("record the next round's box"))?;
            }
            for planned in orch_study::plan::plan_round(study, round + 1, points, tests) {
                super::insert_planned(&mut tx, study_id, round + 1, &planned, runs_dir).await?;
            }
        }
        tx.commit()
            .await
            .map_err(query_error("commit a round's analysis"))
    }

    /// Every round of a study with what was concluded from it.
    pub async fn rounds(&self, study_id: i64) -> Result<Vec<StoredRound>, StoreError> {
        let latest = self.latest_round(study_id).await?;
        let mut rounds = Vec::new();
        for round in 0..=latest {
            let ranges = self.round_ranges(study_id, round).await?;
            let fits = self.round_fits(study_id, round).await?;
            let optimum: Option<OptimumRow> = sqlx::query_as(
                "SELECT response, goal, value, interval_low, interval_high FROM optima WHERE study_id = ? AND round = ?",
            )
            .bind(study_id)
            .bind(round)
            .fetch_optional(&self.pool)
            .await
            .map_err(query_error("read an optimum"))?;
            let optimum_interval = optimum.as_ref().and_then(|o| o.3.zip(o.4));
            let optimum = match optimum {
                None => None,
                Some((response, goal, value, _, _)) => {
                    let natural: Vec<f64> = sqlx::query_scalar(
                        "SELECT natural FROM optimum_values WHERE study_id = ? AND round = ? ORDER BY factor_idx",
                    )
                    .bind(study_id)
                    .bind(round)
                    .fetch_all(&self.pool)
                    .await
                    .map_err(query_error("read an optimum"))?;
                    Some((response, goal, value, natural))
                }
            };
            let uncertainty_row = sqlx::query(
                "SELECT samples, mean, std, q025, q975, q05, q95,
                        total_mean, total_std, total_q025, total_q975, total_q05, total_q95
                 FROM uncertainty WHERE study_id = ? AND round = ?",
            )
            .bind(study_id)
            .bind(round)
            .fetch_optional(&self.pool)
            .await
            .map_err(query_error("read an uncertainty"))?;
            let spread_at = |row: &sqlx::sqlite::SqliteRow, at: usize| -> Option<Spread> {
                Some(Spread {
                    samples: row.get::<i64, _>(0) as usize,
                    mean: row.get::<Option<f64>, _>(at)?,
                    std: row.get::<Option<f64>, _>(at + 1)?,
                    q025: row.get::<Option<f64>, _>(at + 2)?,
                    q975: row.get::<Option<f64>, _>(at + 3)?,
                    q05: row.get::<Option<f64>, _>(at + 4)?,
                    q95: row.get::<Option<f64>, _>(at + 5)?,
                })
            };
            let uncertainty = uncertainty_row.as_ref().and_then(|r| spread_at(r, 1));
            let uncertainty_total = uncertainty_row.as_ref().and_then(|r| spread_at(r, 7));
            let decision: Option<(String, String)> = sqlx::query_as(
                "SELECT decision, note FROM proposals WHERE study_id = ? AND round = ?",
            )
            .bind(study_id)
            .bind(round)
            .fetch_optional(&self.pool)
            .await
            .map_err(query_error("read a decision"))?;
            let decision = match decision {
                Some((text, note)) => Some((parse_state("proposals", round, text)?, note)),
                None => None,
            };
            let front = self.front(study_id, round).await?;
            rounds.push(StoredRound {
                round,
                ranges,
                fits,
                optimum,
                optimum_interval,
                uncertainty,
                uncertainty_total,
                front,
                decision,
            });
        }
        Ok(rounds)
    }

    /// The fits of one round, each with its terms, candidates, Sobol indices and
    /// lack-of-fit test.
    async fn round_fits(&self, study_id: i64, round: i64) -> Result<Vec<StoredFit>, StoreError> {
        let fit_rows = sqlx::query(
            "SELECT id, response, basis, ord, runs, r2, adjusted_r2, sigma_cross, r2_cross, press, error,
                    test_runs, sigma_test, r2_test, model, spec, lack_of_fit_f, lack_of_fit_p,
                    lack_of_fit_dof, pure_error_dof
             FROM fits WHERE study_id = ? AND round = ? ORDER BY id",
        )
        .bind(study_id)
        .bind(round)
        .fetch_all(&self.pool)
        .await
        .map_err(query_error("read fits"))?;
        let mut fits = Vec::new();
        for row in fit_rows {
            let id: i64 = row.get(0);
            let terms: Vec<(String, f64, Option<f64>, Option<f64>)> =
                sqlx::query_as("SELECT name, coefficient, std_error, t_value FROM fit_terms WHERE fit_id = ? ORDER BY idx")
                    .bind(id)
                    .fetch_all(&self.pool)
                    .await
                    .map_err(query_error("read a fit's terms"))?;
            let candidates = sqlx::query(
                "SELECT model, parameters, loo_rmse, chosen, note FROM fit_candidates WHERE fit_id = ? ORDER BY idx",
            )
            .bind(id)
            .fetch_all(&self.pool)
            .await
            .map_err(query_error("read a fit's candidates"))?
            .into_iter()
            .map(|r| CandidateScore {
                model: r.get(0),
                parameters: r.get::<i64, _>(1) as usize,
                loo_rmse: r.get(2),
                chosen: r.get(3),
                note: r.get(4),
            })
            .collect();
            let sensitivities = sqlx::query(
                "SELECT factor_idx, method, first, first_low, first_high, total, total_low, total_high
                 FROM sensitivities WHERE fit_id = ? ORDER BY factor_idx",
            )
            .bind(id)
            .fetch_all(&self.pool)
            .await
            .map_err(query_error("read a fit's sensitivities"))?
            .into_iter()
            .map(|r| Sensitivity {
                factor: r.get::<i64, _>(0) as usize,
                method: r.get(1),
                first: (r.get(2), r.get(3), r.get(4)),
                total: (r.get(5), r.get(6), r.get(7)),
            })
            .collect();
            let lack_of_fit = match (
                row.get::<Option<f64>, _>(16),
                row.get::<Option<f64>, _>(17),
                row.get::<Option<i64>, _>(18),
                row.get::<Option<i64>, _>(19),
            ) {
                (Some(f), Some(p), Some(lof), Some(pe)) => Some(LackOfFitRow {
                    f,
                    p,
                    lack_of_fit_dof: lof as usize,
                    pure_error_dof: pe as usize,
                }),
                _ => None,
            };
            fits.push(StoredFit {
                model: row.get(14),
                spec: row.get(15),
                candidates,
                lack_of_fit,
                sensitivities,
                response: row.get(1),
                basis: row.get(2),
                order: row.get(3),
                runs: row.get(4),
                r2: row.get(5),
                adjusted_r2: row.get(6),
                sigma_cross: row.get(7),
                r2_cross: row.get(8),
                press: row.get(9),
                error: row.get(10),
                test_runs: row.get(11),
                sigma_test: row.get(12),
                r2_test: row.get(13),
                terms,
            });
        }
        Ok(fits)
    }

    /// The Pareto front stored for `round`, in order along it; empty when it has none.
    async fn front(&self, study_id: i64, round: i64) -> Result<Vec<FrontPoint>, StoreError> {
        let points: Vec<(i64, bool)> = sqlx::query_as(
            "SELECT idx, compromise FROM pareto_points WHERE study_id = ? AND round = ? ORDER BY idx",
        )
        .bind(study_id)
        .bind(round)
        .fetch_all(&self.pool)
        .await
        .map_err(query_error("read a Pareto front"))?;
        let objectives: Vec<(i64, String, String, f64)> = sqlx::query_as(
            "SELECT idx, response, goal, value FROM pareto_objectives
             WHERE study_id = ? AND round = ? ORDER BY idx, objective_idx",
        )
        .bind(study_id)
        .bind(round)
        .fetch_all(&self.pool)
        .await
        .map_err(query_error("read a Pareto front"))?;
        let factors: Vec<(i64, f64, f64)> = sqlx::query_as(
            "SELECT idx, coded, natural FROM pareto_factors
             WHERE study_id = ? AND round = ? ORDER BY idx, factor_idx",
        )
        .bind(study_id)
        .bind(round)
        .fetch_all(&self.pool)
        .await
        .map_err(query_error("read a Pareto front"))?;
        Ok(points
            .into_iter()
            .map(|(idx, compromise)| FrontPoint {
                objectives: objectives
                    .iter()
                    .filter(|o| o.0 == idx)
                    .map(|(_, r, g, v)| (r.clone(), g.clone(), *v))
                    .collect(),
                coded: factors.iter().filter(|f| f.0 == idx).map(|f| f.1).collect(),
                natural: factors.iter().filter(|f| f.0 == idx).map(|f| f.2).collect(),
                compromise,
            })
            .collect())
    }
}

/// One fit of a round: its figures, its polynomial's terms, the model choice's
/// candidates and its Sobol indices.
async fn insert_fit(
    tx: &mut sqlx::SqliteConnection,
    study_id: i64,
    round: i64,
    fit: &FitRecord,
) -> Result<(), StoreError> {
    let (quality, error) = match &fit.result {
        Ok(s) => (Some(s.quality()), None),
        Err(e) => (None, Some(e.to_string())),
    };
    let terms = fit.result.as_ref().map(|s| s.parameters()).unwrap_or(0);
    let fit_id: i64 = sqlx::query(
        "INSERT INTO fits (study_id, round, response, basis, ord, runs, terms, r2, adjusted_r2, sigma_cross,
                           r2_cross, press, residual_std, error, test_runs, sigma_test, r2_test,
                           model, spec, lack_of_fit_f, lack_of_fit_p, lack_of_fit_dof, pure_error_dof)
         VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?) RETURNING id",
    )
    .bind(study_id)
    .bind(round)
    .bind(&fit.response)
    .bind(&fit.basis)
    .bind(fit.order as i64)
    .bind(fit.runs as i64)
    .bind(terms as i64)
    .bind(quality.map(|q| q.r2))
    .bind(quality.and_then(|q| q.adjusted_r2))
    .bind(quality.and_then(|q| q.sigma_cross_percent))
    .bind(quality.and_then(|q| q.r2_cross))
    .bind(quality.and_then(|q| q.press))
    .bind(quality.and_then(|q| q.residual_std))
    .bind(error)
    .bind(fit.test.map(|t| t.0 as i64).unwrap_or(0))
    .bind(fit.test.map(|t| t.1.sigma_test_rel_percent))
    .bind(fit.test.map(|t| t.1.r2))
    .bind(&fit.model)
    .bind(&fit.spec)
    .bind(fit.lack_of_fit.map(|l| l.f))
    .bind(fit.lack_of_fit.map(|l| l.p))
    .bind(fit.lack_of_fit.map(|l| l.lack_of_fit_dof as i64))
    .bind(fit.lack_of_fit.map(|l| l.pure_error_dof as i64))
    .fetch_one(&mut *tx)
    .await
    .map_err(query_error("record a fit"))?
    .get(0);
    if let Some(f) = fit.result.as_ref().ok().and_then(Surrogate::polynomial) {
        for (idx, (name, coefficient)) in f.names.iter().zip(&f.coefficients).enumerate() {
            sqlx::query("INSERT INTO fit_terms (fit_id, idx, name, coefficient, std_error, t_value) VALUES (?, ?, ?, ?, ?, ?)")
                .bind(fit_id)
                .bind(idx as i64)
                .bind(name)
                .bind(coefficient)
                .bind(f.standard_errors.as_ref().map(|s| s[idx]))
                .bind(f.t_values.as_ref().map(|t| t[idx]).filter(|t| t.is_finite()))
                .execute(&mut *tx)
                .await
                .map_err(query_error("record a fit's terms"))?;
        }
    }
    for (idx, c) in fit.candidates.iter().enumerate() {
        sqlx::query("INSERT INTO fit_candidates (fit_id, idx, model, parameters, loo_rmse, chosen, note) VALUES (?, ?, ?, ?, ?, ?, ?)")
            .bind(fit_id)
            .bind(idx as i64)
            .bind(&c.model)
            .bind(c.parameters as i64)
            .bind(c.loo_rmse.filter(|v| v.is_finite()))
            .bind(c.chosen)
            .bind(&c.note)
            .execute(&mut *tx)
            .await
            .map_err(query_error("record a fit's candidates"))?;
    }
    for s in &fit.sensitivities {
        sqlx::query("INSERT INTO sensitivities (fit_id, factor_idx, method, first, first_low, first_high, total, total_low, total_high) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)")
            .bind(fit_id)
            .bind(s.factor as i64)
            .bind(&s.method)
            .bind(s.first.0)
            .bind(s.first.1)
            .bind(s.first.2)
            .bind(s.total.0)
            .bind(s.total.1)
            .bind(s.total.2)
            .execute(&mut *tx)
            .await
            .map_err(query_error("record a fit's sensitivities"))?;
    }
    Ok(())
}

/// A round's optimum (with its interval and coordinates) and the spread of the
/// response there under the uncertain inputs.
async fn insert_optimum_and_spread(
    tx: &mut sqlx::SqliteConnection,
    study_id: i64,
    round: i64,
    record: &RoundRecord,
) -> Result<(), StoreError> {
    if let Some((response, goal, optimum, natural)) = &record.optimum {
        sqlx::query("INSERT INTO optima (study_id, round, response, goal, value, exact, interval_low, interval_high) VALUES (?, ?, ?, ?, ?, ?, ?, ?)")
            .bind(study_id)
            .bind(round)
            .bind(response)
            .bind(goal)
            .bind(optimum.value)
            .bind(optimum.exact)
            .bind(record.optimum_interval.map(|i| i.0))
            .bind(record.optimum_interval.map(|i| i.1))
            .execute(&mut *tx)
            .await
            .map_err(query_error("record an optimum"))?;
        for (idx, (coded, natural)) in optimum.x.iter().zip(natural).enumerate() {
            sqlx::query("INSERT INTO optimum_values (study_id, round, factor_idx, coded, natural) VALUES (?, ?, ?, ?, ?)")
                .bind(study_id)
                .bind(round)
                .bind(idx as i64)
                .bind(coded)
                .bind(natural)
                .execute(&mut *tx)
                .await
                .map_err(query_error("record an optimum"))?;
        }
    }
    if let Some((response, spread, seed)) = &record.uncertainty {
        sqlx::query(
            "INSERT INTO uncertainty (study_id, round, response, samples, seed, mean, std, q025, q975, q05, q95,
                                      total_mean, total_std, total_q025, total_q975, total_q05, total_q95)
             VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
        )
        .bind(study_id)
        .bind(round)
        .bind(response)
        .bind(spread.samples as i64)
        .bind(*seed as i64)
        .bind(spread.mean)
        .bind(spread.std)
        .bind(spread.q025)
        .bind(spread.q975)
        .bind(spread.q05)
        .bind(spread.q95)
        .bind(record.uncertainty_total.map(|t| t.mean))
        .bind(record.uncertainty_total.map(|t| t.std))
        .bind(record.uncertainty_total.map(|t| t.q025))
        .bind(record.uncertainty_total.map(|t| t.q975))
        .bind(record.uncertainty_total.map(|t| t.q05))
        .bind(record.uncertainty_total.map(|t| t.q95))
        .execute(&mut *tx)
        .await
        .map_err(query_error("record an uncertainty"))?;
    }
    Ok(())
}

/// A round's Pareto front: each point's objectives and coordinates.
async fn insert_front(
    tx: &mut sqlx::SqliteConnection,
    study_id: i64,
    round: i64,
    front: &[FrontPoint],
) -> Result<(), StoreError> {
    for (idx, point) in front.iter().enumerate() {
        sqlx::query(
            "INSERT INTO pareto_points (study_id, round, idx, compromise) VALUES (?, ?, ?, ?)",
        )
        .bind(study_id)
        .bind(round)
        .bind(idx as i64)
        .bind(point.compromise)
        .execute(&mut *tx)
        .await
        .map_err(query_error("record a Pareto front"))?;
        for (objective_idx, (response, goal, value)) in point.objectives.iter().enumerate() {
            sqlx::query("INSERT INTO pareto_objectives (study_id, round, idx, objective_idx, response, goal, value) VALUES (?, ?, ?, ?, ?, ?, ?)")
                .bind(study_id)
                .bind(round)
                .bind(idx as i64)
                .bind(objective_idx as i64)
                .bind(response)
                .bind(goal)
                .bind(value)
                .execute(&mut *tx)
                .await
                .map_err(query_error("record a Pareto front"))?;
        }
        for (factor_idx, (coded, natural)) in point.coded.iter().zip(&point.natural).enumerate() {
            sqlx::query("INSERT INTO pareto_factors (study_id, round, idx, factor_idx, coded, natural) VALUES (?, ?, ?, ?, ?, ?)")
                .bind(study_id)
                .bind(round)
                .bind(idx as i64)
                .bind(factor_idx as i64)
                .bind(coded)
                .bind(natural)
                .execute(&mut *tx)
                .await
                .map_err(query_error("record a Pareto front"))?;
        }
    }
    Ok(())
}
