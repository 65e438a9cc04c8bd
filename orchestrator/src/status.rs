//! `orch status`: what the store says, as tables for people and JSON for scripts.
//!
//! The JSON has a `schema` number that changes only when a field is removed or changes
//! meaning; fields may be added.

use std::collections::BTreeMap;
use std::path::Path;

use serde_json::{json, Value};

use crate::store::{FactorRow, JobRow, JobState, Store, StoreError, StudyRow};

/// Version of the JSON printed by `orch status --json`.
pub const JSON_SCHEMA: u32 = 1;

/// Everything `orch status <study>` shows.
#[derive(Debug, Clone)]
pub struct StudyDetail {
    /// The study.
    pub study: StudyRow,
    /// Its factors.
    pub factors: Vec<FactorRow>,
    /// Its jobs with their point's values and responses.
    pub jobs: Vec<JobDetail>,
}

/// One job with what belongs to it.
#[derive(Debug, Clone)]
pub struct JobDetail {
    /// The job.
    pub job: JobRow,
    /// Index of its design point.
    pub point: i64,
    /// Coded factor values.
    pub coded: Vec<f64>,
    /// Natural factor values.
    pub natural: Vec<f64>,
    /// Responses by name.
    pub responses: BTreeMap<String, f64>,
}

impl StudyDetail {
    /// Reads a study's detail from the store.
    pub async fn load(store: &Store, study: StudyRow) -> Result<StudyDetail, StoreError> {
        let factors = store.factors(study.id).await?;
        let points: BTreeMap<i64, _> = store
            .points(study.id)
            .await?
            .into_iter()
            .map(|p| (p.id, p))
            .collect();
        let mut responses = store.responses(study.id).await?;
        let jobs = store
            .jobs(study.id)
            .await?
            .into_iter()
            .map(|job| {
                let point = &points[&job.point_id];
                JobDetail {
                    point: point.idx,
                    coded: point.coded.clone(),
                    natural: point.natural.clone(),
                    responses: responses.remove(&job.id).unwrap_or_default(),
                    job,
                }
            })
            .collect();
        Ok(StudyDetail {
            study,
            factors,
            jobs,
        })
    }

    /// Jobs per state.
    pub fn counts(&self) -> BTreeMap<JobState, usize> {
        let rows: Vec<JobRow> = self.jobs.iter().map(|j| j.job.clone()).collect();
        crate::driver::counts(&rows)
    }

    /// The per-job table, showing `responses` (or a default set when empty).
    pub fn table(&self, responses: &[String]) -> String {
        let shown: Vec<String> = if responses.is_empty() {
            ["discharge_rate", "segregation_ratio"]
                .iter()
                .map(|s| s.to_string())
                .collect()
        } else {
            responses.to_vec()
        };
        let mut header: Vec<String> = ["JOB", "STATE", "TRIES", "HANDLE"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        header.extend(
            self.factors
                .iter()
                .map(|f| format!("{} [{}]", f.name, f.unit)),
        );
        header.extend(shown.iter().cloned());
        header.push("ERROR".into());
        let mut rows = vec![header];
        for detail in &self.jobs {
            let job = &detail.job;
            let mut row = vec![
                job.name.clone(),
                job.state.clone(),
                job.attempts.to_string(),
                job.executor_handle.clone().unwrap_or_else(|| "-".into()),
            ];
            row.extend(detail.natural.iter().map(|v| format!("{v:.6}")));
            row.extend(shown.iter().map(|name| {
                detail
                    .responses
                    .get(name)
                    .map(|v| format!("{v:.5}"))
                    .unwrap_or_else(|| "-".into())
            }));
            let error = job.error.clone().unwrap_or_default();
            row.push(if error.chars().count() > 100 {
                format!("{}…", error.chars().take(100).collect::<String>())
            } else {
                error
            });
            rows.push(row);
        }
        let counts = self.counts();
        let summary: Vec<String> = counts
            .iter()
            .map(|(state, n)| format!("{n} {state}"))
            .collect();
        format!(
            "study {} ({}, {}): {} jobs: {}\n{}",
            self.study.name,
            self.study.solver,
            self.study.state,
            self.jobs.len(),
            summary.join(", "),
            table(&rows)
        )
    }

    /// The machine-readable form.
    pub fn json(&self, project_dir: &Path) -> Value {
        let counts: BTreeMap<&str, usize> = self
            .counts()
            .iter()
            .map(|(s, n)| (s.as_str(), *n))
            .collect();
        let names: Vec<&str> = self.factors.iter().map(|f| f.name.as_str()).collect();
        let by_factor = |values: &[f64]| -> BTreeMap<String, f64> {
            names
                .iter()
                .zip(values)
                .map(|(n, v)| (n.to_string(), *v))
                .collect()
        };
        json!({
            "schema": JSON_SCHEMA,
            "study": {
                "name": self.study.name,
                "solver": self.study.solver,
                "state": self.study.state,
                "file": self.study.file_path,
                "project_dir": project_dir.display().to_string(),
                "counts": counts,
            },
            "factors": self.factors.iter().map(|f| json!({
                "name": f.name, "min": f.min, "max": f.max, "unit": f.unit,
            })).collect::<Vec<_>>(),
            "jobs": self.jobs.iter().map(|d| json!({
                "name": d.job.name,
                "id": d.job.id,
                "state": d.job.state,
                "attempts": d.job.attempts,
                "handle": d.job.executor_handle,
                "run_dir": d.job.run_dir,
                "point": d.point,
                "replicate": d.job.replicate,
                "seed": d.job.seed,
                "coded": by_factor(&d.coded),
                "factors": by_factor(&d.natural),
                "responses": d.responses,
                "exit_code": d.job.exit_code,
                "error": d.job.error,
                "started_at": d.job.started_at,
                "finished_at": d.job.finished_at,
            })).collect::<Vec<_>>(),
        })
    }
}

/// One line per study, for `orch status` without a study.
pub async fn overview(
    stores: &[(std::path::PathBuf, Store)],
    as_json: bool,
) -> Result<String, StoreError> {
    let mut rows = vec![[
        "STUDY",
        "SOLVER",
        "STATE",
        "JOBS",
        "PENDING",
        "RUNNING",
        "SUCCEEDED",
        "FAILED",
        "CANCELLED",
        "PROJECT",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect::<Vec<_>>()];
    let mut studies = Vec::new();
    for (dir, store) in stores {
        for study in store.studies().await? {
            let jobs = store.jobs(study.id).await?;
            let counts = crate::driver::counts(&jobs);
            let n = |s: JobState| counts.get(&s).copied().unwrap_or(0);
            let waiting = n(JobState::Pending) + n(JobState::Rendered) + n(JobState::Submitted);
            rows.push(vec![
                study.name.clone(),
                study.solver.clone(),
                study.state.clone(),
                jobs.len().to_string(),
                waiting.to_string(),
                n(JobState::Running).to_string(),
                n(JobState::Succeeded).to_string(),
                n(JobState::Failed).to_string(),
                n(JobState::Cancelled).to_string(),
                dir.display().to_string(),
            ]);
            let by_state: BTreeMap<&str, usize> =
                counts.iter().map(|(s, c)| (s.as_str(), *c)).collect();
            studies.push(json!({
                "name": study.name,
                "solver": study.solver,
                "state": study.state,
                "jobs": jobs.len(),
                "counts": by_state,
                "project_dir": dir.display().to_string(),
            }));
        }
    }
    if as_json {
        return Ok(serde_json::to_string_pretty(
            &json!({"schema": JSON_SCHEMA, "studies": studies}),
        )
        .expect("JSON of plain values"));
    }
    if rows.len() == 1 {
        return Ok("no studies yet: submit one with `orch submit STUDY.yaml`\n".into());
    }
    Ok(table(&rows))
}

/// Left-aligned columns separated by two spaces.
fn table(rows: &[Vec<String>]) -> String {
    let columns = rows.iter().map(|r| r.len()).max().unwrap_or(0);
    let widths: Vec<usize> = (0..columns)
        .map(|c| {
            rows.iter()
                .filter_map(|r| r.get(c))
                .map(|s| s.chars().count())
                .max()
                .unwrap_or(0)
        })
        .collect();
    let mut out = String::new();
    for row in rows {
        let cells: Vec<String> = row
            .iter()
            .enumerate()
            .map(|(c, cell)| format!("{cell:<width$}", width = widths[c]))
            .collect();
        out.push_str(cells.join("  ").trim_end());
        out.push('\n');
    }
    out
}
