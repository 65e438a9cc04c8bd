//! The history of `orch compare`: one row per run of a suite, its responses and speeds.

use std::collections::BTreeMap;

use sqlx::Row;

use super::{now_s, query_error, Store, StoreError};

/// One run of a comparison suite.
#[derive(Debug, Clone, PartialEq)]
pub struct ComparisonRecord {
    /// When it started, s since the Unix epoch.
    pub started_at: f64,
    /// Its wall time, s.
    pub wall_time_s: f64,
    /// `git rev-parse HEAD` of the suite's repository, when known.
    pub git_commit: Option<String>,
    /// The suite file, as given.
    pub suite: String,
    /// Only the quick cases ran.
    pub quick: bool,
    /// The native runs' perturbation (`friction=1.3`), empty when none.
    pub perturbation: String,
    /// The solvers' versions, `solver=version` joined by `, `.
    pub solver_versions: String,
    /// Confidence of the intervals.
    pub confidence: f64,
    /// The worst verdict (`agree`, `inconclusive`, `regression`).
    pub verdict: String,
}

/// One compared response of one case (NaN figures are stored as NULL).
#[derive(Debug, Clone, PartialEq)]
pub struct ResponseRecord {
    /// The case.
    pub case: String,
    /// The response.
    pub response: String,
    /// The reference solver.
    pub reference_solver: String,
    /// `[mean, standard error]` of the native runs.
    pub native: [f64; 2],
    /// Native runs that gave a value.
    pub native_runs: i64,
    /// `[mean, standard error]` of the reference runs.
    pub reference: [f64; 2],
    /// Reference runs that gave a value.
    pub reference_runs: i64,
    /// `(native − reference) / |reference|`.
    pub relative_difference: f64,
    /// Its interval, `[low, high]`.
    pub interval: [f64; 2],
    /// The tolerance.
    pub tolerance: f64,
    /// `agree`, `inconclusive` or `regression`.
    pub verdict: String,
}

/// Mean throughput of one solver on one case.
#[derive(Debug, Clone, PartialEq)]
pub struct SpeedRecord {
    /// The case.
    pub case: String,
    /// The solver.
    pub solver: String,
    /// Particle-steps per second of the solver's loop.
    pub particle_steps_per_s: f64,
    /// Runs averaged.
    pub runs: i64,
}

/// A stored run of a suite with its responses and speeds.
#[derive(Debug, Clone, PartialEq)]
pub struct StoredComparison {
    /// Its id.
    pub id: i64,
    /// The run.
    pub record: ComparisonRecord,
    /// Its responses.
    pub responses: Vec<ResponseRecord>,
    /// Its speeds.
    pub speeds: Vec<SpeedRecord>,
}

fn finite(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

fn or_nan(v: Option<f64>) -> f64 {
    v.unwrap_or(f64::NAN)
}

impl Store {
    /// Records one run of a suite, all at once; returns its id.
    pub async fn insert_comparison(
        &self,
        record: &ComparisonRecord,
        responses: &[ResponseRecord],
        speeds: &[SpeedRecord],
    ) -> Result<i64, StoreError> {
        let what = "record a comparison";
        let mut tx = self.begin_write().await?;
        let id: i64 = sqlx::query_scalar(
            "INSERT INTO comparisons (started_at, wall_time_s, git_commit, suite, quick,
               perturbation, solver_versions, confidence, verdict)
             VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?) RETURNING id",
        )
        .bind(record.started_at)
        .bind(record.wall_time_s)
        .bind(&record.git_commit)
        .bind(&record.suite)
        .bind(record.quick)
        .bind(&record.perturbation)
        .bind(&record.solver_versions)
        .bind(record.confidence)
        .bind(&record.verdict)
        .fetch_one(&mut *tx)
        .await
        .map_err(query_error(what))?;
        for r in responses {
            sqlx::query(
                "INSERT INTO comparison_responses (comparison_id, case_name, response,
                   reference_solver, native_mean, native_standard_error, native_runs,
                   reference_mean, reference_standard_error, reference_runs,
                   relative_difference, interval_low, interval_high, tolerance, verdict)
                 VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
            )
            .bind(id)
            .bind(&r.case)
            .bind(&r.response)
            .bind(&r.reference_solver)
            .bind(finite(r.native[0]))
            .bind(finite(r.native[1]))
            .bind(r.native_runs)
            .bind(finite(r.reference[0]))
            .bind(finite(r.reference[1]))
            .bind(r.reference_runs)
            .bind(finite(r.relative_difference))
            .bind(finite(r.interval[0]))
            .bind(finite(r.interval[1]))
            .bind(r.tolerance)
            .bind(&r.verdict)
            .execute(&mut *tx)
            .await
            .map_err(query_error(what))?;
        }
        for s in speeds {
            sqlx::query(
                "INSERT INTO comparison_speeds (comparison_id, case_name, solver,
                   particle_steps_per_s, runs) VALUES (?, ?, ?, ?, ?)",
            )
            .bind(id)
            .bind(&s.case)
            .bind(&s.solver)
            .bind(finite(s.particle_steps_per_s))
            .bind(s.runs)
            .execute(&mut *tx)
            .await
            .map_err(query_error(what))?;
        }
        tx.commit().await.map_err(query_error(what))?;
        Ok(id)
    }

    /// Every stored run of a suite, oldest first.
    pub async fn comparisons(&self) -> Result<Vec<StoredComparison>, StoreError> {
        let what = "read the comparisons";
        let rows = sqlx::query(
            "SELECT id, started_at, wall_time_s, git_commit, suite, quick, perturbation,
               solver_versions, confidence, verdict FROM comparisons ORDER BY started_at, id",
        )
        .fetch_all(&self.pool)
        .await
        .map_err(query_error(what))?;
        let mut found = Vec::new();
        for row in rows {
            let id: i64 = row.get("id");
            let record = ComparisonRecord {
                started_at: row.get("started_at"),
                wall_time_s: row.get("wall_time_s"),
                git_commit: row.get("git_commit"),
                suite: row.get("suite"),
                quick: row.get("quick"),
                perturbation: row.get("perturbation"),
                solver_versions: row.get("solver_versions"),
                confidence: row.get("confidence"),
                verdict: row.get("verdict"),
            };
            let responses = sqlx::query(
                "SELECT * FROM comparison_responses WHERE comparison_id = ?
                 ORDER BY rowid",
            )
            .bind(id)
            .fetch_all(&self.pool)
            .await
            .map_err(query_error(what))?
            .into_iter()
            .map(|r| ResponseRecord {
                case: r.get("case_name"),
                response: r.get("response"),
                reference_solver: r.get("reference_solver"),
                native: [
                    or_nan(r.get("native_mean")),
                    or_nan(r.get("native_standard_error")),
                ],
                native_runs: r.get("native_runs"),
                reference: [
                    or_nan(r.get("reference_mean")),
                    or_nan(r.get("reference_standard_error")),
                ],
                reference_runs: r.get("reference_runs"),
                relative_difference: or_nan(r.get("relative_difference")),
                interval: [
                    or_nan(r.get("interval_low")),
                    or_nan(r.get("interval_high")),
                ],
                tolerance: r.get("tolerance"),
                verdict: r.get("verdict"),
            })
            .collect();
            let speeds = sqlx::query(
                "SELECT case_name, solver, particle_steps_per_s, runs FROM comparison_speeds
                 WHERE comparison_id = ? ORDER BY rowid",
            )
            .bind(id)
            .fetch_all(&self.pool)
            .await
            .map_err(query_error(what))?
            .into_iter()
            .map(|r| SpeedRecord {
                case: r.get("case_name"),
                solver: r.get("solver"),
                particle_steps_per_s: or_nan(r.get("particle_steps_per_s")),
                runs: r.get("runs"),
            })
            .collect();
            found.push(StoredComparison {
                id,
                record,
                responses,
                speeds,
            });
        }
        Ok(found)
    }
}

impl Store {
    /// Every run an earlier `orch compare` made, by identity: its responses.
    pub async fn comparison_runs(
        &self,
    ) -> Result<std::collections::HashMap<String, BTreeMap<String, f64>>, StoreError> {
        let rows: Vec<(String, String)> =
            sqlx::query_as("SELECT identity, responses FROM comparison_runs")
                .fetch_all(&self.pool)
                .await
                .map_err(query_error("read the runs of earlier comparisons"))?;
        Ok(rows
            .into_iter()
            .filter_map(|(identity, text)| Some((identity, serde_json::from_str(&text).ok()?)))
            .collect())
    }

    /// Records the runs a comparison made (identity, responses), in one transaction.
    pub async fn record_comparison_runs(
        &self,
        runs: &[(String, BTreeMap<String, f64>)],
    ) -> Result<(), StoreError> {
        let mut tx = self.begin_write().await?;
        for (identity, responses) in runs {
            let text = serde_json::to_string(responses).expect("numbers by name serialise");
            sqlx::query(
                "INSERT OR REPLACE INTO comparison_runs (identity, responses, created_at) VALUES (?, ?, ?)",
            )
            .bind(identity)
            .bind(text)
            .bind(now_s())
            .execute(&mut *tx)
            .await
            .map_err(query_error("record a comparison's runs"))?;
        }
        tx.commit()
            .await
            .map_err(query_error("record a comparison's runs"))
    }
}
