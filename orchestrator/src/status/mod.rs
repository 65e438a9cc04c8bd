//! `orch status`: what the store says, as tables for people and JSON for scripts.
//!
//! The JSON has a `schema` number that changes only when a field is removed or changes
//! meaning; fields may be added.
//!
//! A study stays `active` in the store when its `orch` dies without releasing it
//! (`kill -9`, a full disk); status looks up the recorded driver process and says when
//! none is alive, since nothing moves until `orch resume`.

mod fits;
mod json;

pub use fits::{fits_report, points, recommendation, rounds_summary, verdict_of};
pub use json::write_json_paged;
use json::*;

use std::collections::BTreeMap;
use std::io::{self, Write};
use std::path::Path;

use serde_json::{json, Value};

use crate::executor::process;
use crate::store::{
    Extremes, FactorRow, JobExtents, JobPages, JobRow, JobState, PointRow, ResponseValues, Store,
    StoreError, StoredFit, StoredRound, StudyRow, StudyState,
};
use crate::surfaces::{self, Run};
use crate::verdict::{self, Verdict};

/// Version of the JSON printed by `orch status --json`.
pub const JSON_SCHEMA: u32 = 1;

/// The orch process recorded as driving a study, and whether it still runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Driver {
    /// Its pid, if one was recorded and not released.
    pub pid: Option<i64>,
    /// True when that process (pid and start time) is alive on this machine.
    pub alive: bool,
}

impl Driver {
    /// Looks the study's recorded driver up among this machine's processes.
    pub fn of(study: &StudyRow) -> Driver {
        let alive = match (study.driver_pid, study.driver_started) {
            (Some(pid), Some(started)) => process::is_alive(pid, started),
            _ => false,
        };
        Driver {
            pid: study.driver_pid,
            alive,
        }
    }

    /// What to tell of a study in `state` driven by this driver: for an active study
    /// no live process drives (its orch was killed or failed), that it stands still and
    /// how to continue it; `None` otherwise.
    pub fn note(self, study: &str, state: StudyState) -> Option<String> {
        (state == StudyState::Active && !self.alive).then(|| {
            format!(
                "no orch process drives study `{study}`{}: its running jobs are not followed and its pending jobs do not start; `orch resume {study}` continues it",
                self.pid
                    .map(|pid| format!(" (its driver, pid {pid}, is gone)"))
                    .unwrap_or_default()
            )
        })
    }
}

/// Everything `orch status <study>` shows.
#[derive(Debug, Clone)]
pub struct StudyDetail {
    /// The study.
    pub study: StudyRow,
    /// Its recorded driver, looked up when loaded.
    pub driver: Driver,
    /// Its factors.
    pub factors: Vec<FactorRow>,
    /// Its jobs with their point's values and responses.
    pub jobs: Vec<JobDetail>,
    /// Its rounds with fits, optimum, spread and decision.
    pub rounds: Vec<StoredRound>,
    /// Succeeded design runs by round, which the rounds' fits used.
    pub runs: BTreeMap<i64, Vec<Run>>,
    /// What its noise design found, when it has run.
    pub noise: Option<crate::noise::NoiseSummary>,
}

/// One job with what belongs to it.
#[derive(Debug, Clone)]
pub struct JobDetail {
    /// The job.
    pub job: JobRow,
    /// Index of its design point.
    pub point: i64,
    /// Fidelity level of its point (0 the cheapest).
    pub fidelity: u32,
    /// Coded factor values.
    pub coded: Vec<f64>,
    /// Natural factor values.
    pub natural: Vec<f64>,
    /// Responses by name.
    pub responses: BTreeMap<String, f64>,
}

impl JobDetail {
    /// `job` with its design point and its responses.
    fn of(job: JobRow, point: &PointRow, responses: ResponseValues) -> JobDetail {
        JobDetail {
            point: point.idx,
            fidelity: point.fidelity,
            coded: point.coded.clone(),
            natural: point.natural.clone(),
            responses: responses.into_map(),
            job,
        }
    }
}

/// The columns of `orch status STUDY`'s job table: identity, state, the point's
/// factors, the responses shown and the error.
struct JobColumns<'a> {
    factors: &'a [FactorRow],
    shown: &'a [String],
    /// Whether the `SCHEDULER` column is shown (some job has a scheduler state).
    on_scheduler: bool,
    /// Decimals of each factor's column, then of each shown response's: enough for
    /// the column's largest value to show 4 significant digits (a response of 10^-7
    /// is not `0.00000`).
    decimals: Vec<usize>,
}

impl JobColumns<'_> {
    fn header(&self) -> Vec<String> {
        let mut header: Vec<String> = ["JOB", "STATE", "TRIES", "HANDLE"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        if self.on_scheduler {
            header.push("SCHEDULER".into());
        }
        header.extend(self.factors.iter().map(|f| match f.levels {
            Some(_) => f.name.clone(),
            None => format!("{} [{}]", f.name, f.unit),
        }));
        header.extend(self.shown.iter().cloned());
        header.push("ERROR".into());
        header
    }

    /// The row of `job` at the natural factor values `natural`, its responses looked
    /// up by name in `response`.
    fn row(
        &self,
        job: &JobRow,
        natural: &[f64],
        response: impl Fn(&str) -> Option<f64>,
    ) -> Vec<String> {
        let mut row = vec![
            job.name.clone(),
            job.state.to_string(),
            job.attempts.to_string(),
            job.executor_handle.clone().unwrap_or_else(|| "-".into()),
        ];
        if self.on_scheduler {
            row.push(job.scheduler_state.clone().unwrap_or_else(|| "-".into()));
        }
        let (factors, responses) = self.decimals.split_at(self.factors.len());
        row.extend(
            natural
                .iter()
                .zip(factors)
                .zip(self.factors)
                .map(|((&v, &d), factor)| factor.show(v, |v| fixed(v, d))),
        );
        row.extend(self.shown.iter().zip(responses).map(|(name, &d)| {
            response(name)
                .map(|v| fixed(v, d))
                .unwrap_or_else(|| "-".into())
        }));
        let error = match (&job.reused_from, &job.error) {
            (Some(source), Some(error)) => format!("reused {source}; {error}"),
            (Some(source), None) => format!("reused {source}"),
            (None, error) => error.clone().unwrap_or_default(),
        };
        row.push(if error.chars().count() > 100 {
            format!("{}…", error.chars().take(100).collect::<String>())
        } else {
            error
        });
        row
    }

    /// The widest cell of each column but the last, of the jobs whose extents these
    /// are (`counts`: their states): what [`JobColumns::row`] gives the longest texts
    /// for. The last column (the error) needs no width: a line's end is trimmed.
    fn widths(&self, extents: &JobExtents, counts: &BTreeMap<JobState, usize>) -> Vec<usize> {
        let widest = |extremes: Option<&Extremes>, decimals: usize| {
            extremes.map_or(0, |e| {
                e.candidates()
                    .map(|v| fixed(v, decimals).chars().count())
                    .max()
                    .unwrap_or(0)
            })
        };
        let (factors, responses) = self.decimals.split_at(self.factors.len());
        let mut widths = vec![
            extents.name_chars,
            counts.keys().map(|s| s.as_str().len()).max().unwrap_or(0),
            extents.attempts.to_string().len(),
            extents.handle_chars,
        ];
        if self.on_scheduler {
            widths.push(extents.scheduler_chars.unwrap_or(0));
        }
        widths.extend(
            factors
                .iter()
                .zip(self.factors)
                .enumerate()
                .map(|(k, (&d, factor))| match factor.levels.is_some() {
                    true => factor
                        .levels()
                        .iter()
                        .map(|l| l.chars().count())
                        .max()
                        .unwrap_or(0),
                    false => widest(extents.natural.get(k), d),
                }),
        );
        widths.extend(
            self.shown
                .iter()
                .zip(responses)
                .map(|(name, &d)| widest(extents.responses.get(name), d).max(1)),
        );
        widths
    }

    /// The decimals of each column from the extremes of its values (`natural` by factor,
    /// `responses` by name).
    fn decimals_of(
        factors: usize,
        shown: &[String],
        natural: impl Fn(usize) -> Option<Extremes>,
        responses: impl Fn(&str) -> Option<Extremes>,
    ) -> Vec<usize> {
        (0..factors)
            .map(|k| decimals(natural(k).as_ref(), NATURAL_DECIMALS))
            .chain(
                shown
                    .iter()
                    .map(|name| decimals(responses(name).as_ref(), RESPONSE_DECIMALS)),
            )
            .collect()
    }
}

/// Decimals of a design value in `orch status STUDY`, at least.
const NATURAL_DECIMALS: usize = 6;
/// Decimals of a response in `orch status STUDY`, at least.
const RESPONSE_DECIMALS: usize = 5;

/// Decimals for a column whose values span `extremes`: `least`, or more where its
/// largest magnitude is small, so that it shows 4 significant digits.
fn decimals(extremes: Option<&Extremes>, least: usize) -> usize {
    let largest = extremes
        .map(|e| {
            [e.min_finite, e.max_finite]
                .into_iter()
                .flatten()
                .map(f64::abs)
                .fold(0.0, f64::max)
        })
        .unwrap_or(0.0);
    if largest <= 0.0 || !largest.is_finite() {
        return least;
    }
    let needed = 3 - largest.log10().floor() as i64;
    (needed.max(least as i64) as usize).min(15)
}

/// `value` to `decimals` decimals.
fn fixed(value: f64, decimals: usize) -> String {
    format!("{value:.decimals$}")
}

/// `names` sorted, each once.
fn distinct(names: &[String]) -> Vec<String> {
    let mut names = names.to_vec();
    names.sort();
    names.dedup();
    names
}

impl StudyDetail {
    /// Reads a study's detail from the store, every job in memory: what the tests
    /// compare the paged writers ([`write_table_paged`], [`write_json_paged`]) with.
    pub async fn load(store: &Store, study: StudyRow) -> Result<StudyDetail, StoreError> {
        let rounds = store.rounds(study.id).await?;
        let factors = store.factors(study.id).await?;
        // The points, responses and jobs are read once: the design runs are made from
        // the same rows.
        let points = store.points(study.id).await?;
        let mut responses = store.responses(study.id).await?;
        let jobs = store.jobs(study.id).await?;
        let runs = surfaces::design_runs_from(store, study.id, &points, &jobs, &responses).await?;
        let points: BTreeMap<i64, _> = points.into_iter().map(|p| (p.id, p)).collect();
        let jobs = jobs
            .into_iter()
            .map(|job| {
                let values = responses.remove(&job.id).unwrap_or_default();
                let point = &points[&job.point_id];
                JobDetail::of(job, point, values)
            })
            .collect();
        let noise = crate::noise::summary(store, &study.name).await?;
        Ok(StudyDetail {
            noise,
            driver: Driver::of(&study),
            study,
            factors,
            jobs,
            rounds,
            runs,
        })
    }

    /// The study's detail without its jobs and design runs: what the paged writers
    /// ([`write_table_paged`], [`write_json_paged`]) write around the jobs they read
    /// a page at a time.
    async fn head(store: &Store, study: StudyRow) -> Result<StudyDetail, StoreError> {
        Ok(StudyDetail {
            rounds: store.rounds(study.id).await?,
            factors: store.factors(study.id).await?,
            noise: crate::noise::summary(store, &study.name).await?,
            driver: Driver::of(&study),
            jobs: Vec::new(),
            runs: BTreeMap::new(),
            study,
        })
    }

    /// Jobs per state.
    pub fn counts(&self) -> BTreeMap<JobState, usize> {
        let mut counts = BTreeMap::new();
        for detail in &self.jobs {
            *counts.entry(detail.job.state()).or_insert(0) += 1;
        }
        counts
    }

    /// The per-job table, showing `responses` (the study's
    /// [`crate::study::Study::shown_responses`]).
    pub fn table(&self, responses: &[String]) -> String {
        let decimals = JobColumns::decimals_of(
            self.factors.len(),
            responses,
            |k| {
                Some(Extremes::of(
                    self.jobs.iter().filter_map(|d| d.natural.get(k).copied()),
                ))
            },
            |name| {
                Some(Extremes::of(
                    self.jobs
                        .iter()
                        .filter_map(|d| d.responses.get(name).copied()),
                ))
            },
        );
        let columns = JobColumns {
            factors: &self.factors,
            shown: responses,
            on_scheduler: self.jobs.iter().any(|d| d.job.scheduler_state.is_some()),
            decimals,
        };
        let mut rows = vec![columns.header()];
        rows.extend(self.jobs.iter().map(|detail| {
            columns.row(&detail.job, &detail.natural, |name| {
                detail.responses.get(name).copied()
            })
        }));
        format!(
            "{}{}{}",
            self.headline(
                &self.counts(),
                self.jobs
                    .iter()
                    .filter(|d| d.job.reused_from.is_some())
                    .count()
            ),
            table(&rows),
            self.tail()
        )
    }

    /// The lines above the job table: the study, its jobs per state (`counts`, of the
    /// succeeded `reused` took an earlier run) and the note on a dead driver.
    fn headline(&self, counts: &BTreeMap<JobState, usize>, reused: usize) -> String {
        let summary: Vec<String> = counts
            .iter()
            .map(|(state, n)| match state {
                JobState::Succeeded if reused > 0 => {
                    format!("{n} {state} ({reused} reused, not run again)")
                }
                _ => format!("{n} {state}"),
            })
            .collect();
        let note = self
            .driver
            .note(&self.study.name, self.study.state)
            .map(|note| format!("{note}\n"))
            .unwrap_or_default();
        format!(
            "study {} ({}, {}): {} jobs: {}\n{note}",
            self.study.name,
            self.study.solver,
            self.study.state,
            counts.values().sum::<usize>(),
            summary.join(", "),
        )
    }

    /// The lines below the job table: the rounds and the noise design.
    fn tail(&self) -> String {
        format!(
            "{}{}",
            rounds_summary(&self.rounds, &self.factors, &self.runs),
            self.noise
                .as_ref()
                .and_then(|n| n.line())
                .map(|line| format!("{line}\n"))
                .unwrap_or_default()
        )
    }

    /// The machine-readable form.
    pub fn json(&self, project_dir: &Path) -> Value {
        let names = self.factor_names();
        json!({
            "schema": JSON_SCHEMA,
            "study": self.study_json(project_dir),
            "rounds": self.rounds_json(&names),
            "noise_design": self.noise_json(),
            "factors": self.factors_json(),
            "jobs": self.jobs.iter().map(|d| job_json(d, &self.factors)).collect::<Vec<_>>(),
        })
    }

    /// Writes [`StudyDetail::json`] to `out` as `serde_json::to_writer_pretty` writes
    /// it, without building it: each job's object is made as it is written, so what is
    /// held does not grow with the jobs' text.
    pub fn write_json(&self, project_dir: &Path, out: impl Write) -> io::Result<()> {
        let mut writer = JsonWriter::begin(out, &self.factors)?;
        for detail in &self.jobs {
            writer.job(detail)?;
        }
        writer.end(self, project_dir)?;
        Ok(())
    }

    fn factor_names(&self) -> Vec<&str> {
        self.factors.iter().map(|f| f.name.as_str()).collect()
    }

    fn study_json(&self, project_dir: &Path) -> Value {
        self.study_json_counted(project_dir, &self.counts())
    }

    /// The `study` object with `counts` as its jobs per state.
    fn study_json_counted(&self, project_dir: &Path, counts: &BTreeMap<JobState, usize>) -> Value {
        let counts: BTreeMap<&str, usize> = counts.iter().map(|(s, n)| (s.as_str(), *n)).collect();
        json!({
            "name": self.study.name,
            "solver": self.study.solver,
            "state": self.study.state.as_str(),
            "driver": {"pid": self.driver.pid, "alive": self.driver.alive},
            "note": self.driver.note(&self.study.name, self.study.state),
            "file": self.study.file_path,
            "project_dir": project_dir.display().to_string(),
            "counts": counts,
        })
    }

    fn rounds_json(&self, names: &[&str]) -> Value {
        let levels: Vec<Vec<String>> = self.factors.iter().map(FactorRow::levels).collect();
        Value::Array(
            self.rounds
                .iter()
                .map(|r| round_json(r, names, &levels))
                .collect(),
        )
    }

    fn noise_json(&self) -> Value {
        json!(self.noise.as_ref().map(|n| {
            let names: Vec<&str> = n.factors.iter().map(String::as_str).collect();
            json!({"study": n.study, "round": round_json(&n.round, &names, &[])})
        }))
    }

    fn factors_json(&self) -> Value {
        factors_json(&self.factors)
    }
}

/// Why `orch status STUDY` (its table or `--json`) could not be written.
#[derive(Debug, thiserror::Error)]
pub enum WriteStatusError {
    /// The store could not be read.
    #[error(transparent)]
    Store(#[from] StoreError),
    /// The output could not be written.
    #[error("cannot write the status: {0}")]
    Write(#[from] io::Error),
}

/// Writes `orch status STUDY` of `study` to `out`, showing the responses `shown`: the
/// same text as [`StudyDetail::table`], its rows read a page of jobs at a time
/// ([`JobPages`]) and written as they are read, its columns' widths known beforehand
/// from the jobs' extents ([`Store::job_extents`]), so that memory does not grow with
/// the study's jobs (the rounds' lines still read their design runs). Returns `out`.
pub async fn write_table_paged<W: Write>(
    store: &Store,
    study: StudyRow,
    shown: &[String],
    mut out: W,
) -> Result<W, WriteStatusError> {
    // One counting query first: it refuses a job state this orch does not know
    // before a byte is written, and gives the headline's figures.
    let counts = store.job_counts(study.id).await?;
    let extents = store.job_extents(study.id, shown).await?;
    let mut head = StudyDetail::head(store, study).await?;
    if !head.rounds.is_empty() {
        let fitted = surfaces::fitted_names(&head.rounds);
        head.runs = surfaces::design_runs_named(store, head.study.id, &fitted).await?;
    }
    let decimals = JobColumns::decimals_of(
        head.factors.len(),
        shown,
        |k| extents.natural.get(k).cloned(),
        |name| extents.responses.get(name).cloned(),
    );
    let columns = JobColumns {
        factors: &head.factors,
        shown,
        on_scheduler: extents.scheduler_chars.is_some(),
        decimals,
    };
    let header = columns.header();
    let mut widths = Vec::new();
    widen(&mut widths, &header);
    for (width, cell) in widths.iter_mut().zip(columns.widths(&extents, &counts)) {
        *width = (*width).max(cell);
    }
    let reused = store.reused_count(head.study.id).await?;
    out.write_all(head.headline(&counts, reused).as_bytes())?;
    out.write_all(aligned(&header, &widths).as_bytes())?;
    let mut pages = JobPages::with_responses(head.study.id, &distinct(shown));
    while let Some(mut page) = pages.next(store).await? {
        for (job, point, responses) in page.drain() {
            let row = columns.row(&job, &point.natural, |n| responses.get(n));
            out.write_all(aligned(&row, &widths).as_bytes())?;
        }
    }
    out.write_all(head.tail().as_bytes())?;
    Ok(out)
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
    let mut notes = String::new();
    for (dir, store) in stores {
        for study in store.studies().await? {
            let driver = Driver::of(&study);
            let note = driver.note(&study.name, study.state);
            if let Some(note) = &note {
                notes.push_str(note);
                notes.push('\n');
            }
            // Counted by the store (one query), not read: a study of 10^4 jobs is a
            // line here too.
            let counts = store.job_counts(study.id).await?;
            let total: usize = counts.values().sum();
            let n = |s: JobState| counts.get(&s).copied().unwrap_or(0);
            let waiting = n(JobState::Pending) + n(JobState::Rendered) + n(JobState::Submitted);
            rows.push(vec![
                study.name.clone(),
                study.solver.clone(),
                study.state.to_string(),
                total.to_string(),
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
                "state": study.state.as_str(),
                "driver": {"pid": driver.pid, "alive": driver.alive},
                "note": note,
                "jobs": total,
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
    Ok(table(&rows) + &notes)
}

/// Left-aligned columns separated by two spaces.
fn table(rows: &[Vec<String>]) -> String {
    let mut widths = Vec::new();
    for row in rows {
        widen(&mut widths, row);
    }
    let mut out = String::new();
    for row in rows {
        out.push_str(&aligned(row, &widths));
    }
    out
}

/// Widens `widths` (characters per column) to fit `row`.
fn widen(widths: &mut Vec<usize>, row: &[String]) {
    if widths.len() < row.len() {
        widths.resize(row.len(), 0);
    }
    for (width, cell) in widths.iter_mut().zip(row) {
        *width = (*width).max(cell.chars().count());
    }
}

/// `row` as one line of [`table`] with column `widths`.
fn aligned(row: &[String], widths: &[usize]) -> String {
    let cells: Vec<String> = row
        .iter()
        .zip(widths)
        .map(|(cell, &width)| format!("{cell:<width$}"))
        .collect();
    let mut line = cells.join("  ").trim_end().to_string();
    line.push('\n');
    line
}

#[cfg(test)]
mod tests {
    use super::fits::{front_lines, kriging_lines};
    use super::*;

    #[test]
    fn a_per_level_kriging_surface_lists_each_combinations_length_scales() {
        use orch_metamodel::surrogate::ModelSpec;
        use orch_metamodel::{Kernel, Trend};
        let model = |l: f64| ModelSpec::Kriging {
            kernel: Kernel::Matern52,
            trend: Trend::Constant,
            length_scales: vec![l],
            process_variance: 4.0,
            noise_variance: 0.01,
        };
        let spec = ModelSpec::KrigingPerLevel {
            levels: vec![0, 2],
            models: vec![(vec![0], model(0.25)), (vec![1], model(1.5))],
        };
        let fit = StoredFit {
            spec: Some(surfaces::spec_json(&spec)),
            ..StoredFit::default()
        };
        let lines = kriging_lines(&fit, &["angle".into(), "contact".into()]);
        assert_eq!(
            lines,
            "  at levels [1]:\n    length scales (coded units; small = the response changes fast along it): angle 0.250\n    process std 2.0000e0, noise std 1.0000e-1\n  at levels [2]:\n    length scales (coded units; small = the response changes fast along it): angle 1.500\n    process std 2.0000e0, noise std 1.0000e-1\n"
        );
    }

    #[test]
    fn a_column_of_small_values_shows_four_significant_digits_and_others_keep_theirs() {
        let column =
            |values: &[f64], least| decimals(Some(&Extremes::of(values.iter().copied())), least);
        // Responses of 10^-7 were `0.00000`.
        let d = column(&[1.2345e-7, 3.5e-8], RESPONSE_DECIMALS);
        assert_eq!(fixed(1.2345e-7, d), "0.0000001235");
        // Columns of values from 0.01 up keep their decimals, as every table had them.
        assert_eq!(column(&[0.09304, 1.28], RESPONSE_DECIMALS), 5);
        assert_eq!(column(&[0.024, 0.5], NATURAL_DECIMALS), 6);
        assert_eq!(column(&[-2.5e-5, 0.0], NATURAL_DECIMALS), 8);
        assert_eq!(column(&[], RESPONSE_DECIMALS), 5);
        assert_eq!(column(&[f64::NAN, 0.0], RESPONSE_DECIMALS), 5);
    }

    #[test]
    fn only_an_active_study_without_a_live_driver_gets_a_note() {
        let gone = Driver {
            pid: Some(4321),
            alive: false,
        };
        assert_eq!(
            gone.note("short", StudyState::Active).as_deref(),
            Some("no orch process drives study `short` (its driver, pid 4321, is gone): its running jobs are not followed and its pending jobs do not start; `orch resume short` continues it")
        );
        let never = Driver {
            pid: None,
            alive: false,
        };
        assert!(never
            .note("short", StudyState::Active)
            .unwrap()
            .starts_with("no orch process drives study `short`: "));
        let alive = Driver {
            pid: Some(4321),
            alive: true,
        };
        assert_eq!(alive.note("short", StudyState::Active), None);
        for state in [
            StudyState::Interrupted,
            StudyState::Cancelled,
            StudyState::Finished,
        ] {
            assert_eq!(never.note("short", state), None);
        }
    }

    use orch_metamodel::FactorRange;

    fn fit(response: &str, r2_cross: Option<f64>) -> StoredFit {
        StoredFit {
            response: response.into(),
            basis: "legendre".into(),
            order: 1,
            runs: 4,
            r2: Some(1.0),
            adjusted_r2: None,
            sigma_cross: r2_cross.map(|r| 100.0 * (1.0 - r).sqrt()),
            r2_cross,
            press: Some(0.0),
            test_runs: 0,
            sigma_test: None,
            r2_test: None,
            error: None,
            terms: vec![("1".into(), 1.0, None, Some(1e15))],
            ..Default::default()
        }
    }

    fn run(x: f64, rate: f64) -> Run {
        Run {
            job: format!("p{x}"),
            coded: vec![x],
            natural: vec![0.024 + 0.004 * x],
            fidelity: 0,
            responses: [("fraction".to_string(), 1.0), ("rate".to_string(), rate)]
                .into_iter()
                .collect(),
        }
    }

    #[test]
    fn the_summary_warns_of_a_constant_response_a_surface_that_does_not_predict_and_a_limit() {
        let factors = vec![FactorRow {
            name: "outlet_diameter".into(),
            min: 0.02,
            max: 0.028,
            unit: "m".into(),
            levels: None,
        }];
        let round = StoredRound {
            round: 0,
            ranges: vec![FactorRange {
                min: 0.02,
                max: 0.028,
            }],
            fits: vec![fit("rate", Some(0.2)), fit("fraction", None)],
            optimum: Some(("rate".into(), "maximise".into(), 1.5, vec![0.028])),
            uncertainty: None,
            decision: None,
            ..Default::default()
        };
        let runs = BTreeMap::from([(
            0,
            vec![run(-1.0, 1.0), run(0.0, 1.4), run(1.0, 1.3), run(0.5, 1.1)],
        )]);
        let text = rounds_summary(std::slice::from_ref(&round), &factors, &runs);
        assert!(text.contains("rate: σ_cross 89.4 %"), "{text}");
        assert!(text.contains(": does not predict"), "{text}");
        assert!(
            text.contains("fraction: constant: 1 in every run; nothing to fit"),
            "{text}"
        );
        assert!(!text.contains("fraction: σ_cross"), "{text}");
        assert!(
            text.contains("best point of the surface, not an answer (maximise rate)"),
            "{text}"
        );
        assert!(
            text.contains("widen outlet_diameter's range above 0.028"),
            "{text}"
        );

        let report = fits_report(&round, &["outlet_diameter".into()], &runs[&0]);
        assert!(
            report.contains("warning: fraction does not vary"),
            "{report}"
        );
        assert_eq!(
            report.matches("TERM").count(),
            1,
            "a term table for rate only, none with t-values for the constant: {report}"
        );
        assert!(
            report.contains("warning: the surface of rate does not predict"),
            "{report}"
        );
    }

    #[test]
    fn a_missing_sigma_cross_is_a_dash_with_the_reason() {
        let mut saturated = fit("rate", None);
        saturated.press = None;
        saturated.runs = 2;
        saturated.terms = vec![("1".into(), 1.0, None, None), ("x".into(), 0.1, None, None)];
        let round = StoredRound {
            round: 0,
            ranges: vec![FactorRange { min: 0.0, max: 1.0 }],
            fits: vec![saturated],
            optimum: None,
            uncertainty: None,
            decision: None,
            ..Default::default()
        };
        let factors = vec![FactorRow {
            name: "x".into(),
            min: 0.0,
            max: 1.0,
            unit: "m".into(),
            levels: None,
        }];
        let runs = BTreeMap::from([(0, vec![run(-1.0, 1.0), run(1.0, 2.0)])]);
        let text = rounds_summary(&[round], &factors, &runs);
        assert!(text.contains("rate: σ_cross – %"), "{text}");
        assert!(
            text.contains("σ_cross of rate is –: 2 runs for 2 terms: every run has leverage 1"),
            "{text}"
        );
    }

    #[test]
    fn a_rounds_json_has_its_pareto_front_by_name() {
        let point = |rate: f64, ratio: f64, d: f64, compromise: bool| crate::store::FrontPoint {
            objectives: vec![
                ("rate".into(), "maximise".into(), rate),
                ("ratio".into(), "minimise".into(), ratio),
            ],
            coded: vec![0.0],
            natural: vec![d],
            compromise,
        };
        let round = StoredRound {
            front: vec![point(2.0, 1.5, 0.028, false), point(1.0, 1.1, 0.024, true)],
            ..Default::default()
        };
        let json = round_json(&round, &["outlet_diameter"], &[]);
        assert_eq!(
            json["pareto_front"],
            json!([
                {"objectives": {"rate": 2.0, "ratio": 1.5}, "factors": {"outlet_diameter": 0.028}, "compromise": false},
                {"objectives": {"rate": 1.0, "ratio": 1.1}, "factors": {"outlet_diameter": 0.024}, "compromise": true},
            ])
        );
        assert_eq!(
            front_lines(&round, &["outlet_diameter".into()]),
            "  Pareto front of 2 points; compromise point: rate = 1.000000 (maximise), ratio = 1.100000 (minimise) at outlet_diameter = 0.024000\n"
        );
        // A single-objective round has an empty front and no line.
        assert_eq!(
            round_json(&StoredRound::default(), &[], &[])["pareto_front"],
            json!([])
        );
        assert_eq!(front_lines(&StoredRound::default(), &[]), "");
    }

    /// A detail of `n_jobs` jobs, one failed with an error and one without responses.
    fn detail(n_jobs: i64) -> StudyDetail {
        let study = StudyRow {
            id: 1,
            name: "s".into(),
            solver: "native".into(),
            file_path: "s.yaml".into(),
            file_text: String::new(),
            file_sha256: String::new(),
            template_name: String::new(),
            template_text: String::new(),
            state: StudyState::Finished,
            driver_pid: None,
            driver_started: None,
            created_at: 0.0,
            updated_at: 0.0,
        };
        let job = |id: i64| JobDetail {
            job: JobRow {
                id,
                study_id: 1,
                point_id: id,
                replicate: 0,
                name: format!("p{id:03}r0"),
                seed: id,
                state: if id == 2 {
                    JobState::Failed
                } else {
                    JobState::Succeeded
                },
                attempts: 1,
                executor_handle: Some(format!("{id}:1")),
                run_dir: format!("runs/s/p{id:03}r0"),
                started_at: Some(1.5),
                finished_at: Some(2.25),
                exit_code: Some(i64::from(id == 2)),
                error: (id == 2).then(|| "exit \"1\"\nsee log".into()),
                scheduler_state: None,
                kind: crate::store::JobKind::Design,
                after_job_id: None,
                identity: None,
                reused_from: None,
            },
            point: id,
            fidelity: 0,
            coded: vec![-1.0 + 0.5 * id as f64],
            natural: vec![0.02 + 1e-3 * id as f64],
            responses: if id == 2 {
                BTreeMap::new()
            } else {
                [("exit_speed".to_string(), 0.1 * id as f64)].into()
            },
        };
        StudyDetail {
            study,
            driver: Driver {
                pid: None,
                alive: false,
            },
            factors: vec![FactorRow {
                name: "outlet_diameter".into(),
                min: 0.02,
                max: 0.028,
                unit: "m".into(),
                levels: None,
            }],
            jobs: (1..=n_jobs).map(job).collect(),
            rounds: vec![StoredRound::default()],
            runs: BTreeMap::new(),
            noise: None,
        }
    }

    /// A store holding a study `big` of two more jobs than a page
    /// ([`crate::store::ROWS_PER_PAGE`]): three succeeded on either side of the page
    /// boundary (with a response), one failed with a long error, and, when
    /// `on_scheduler`, one with a scheduler state.
    async fn big_study(on_scheduler: bool) -> (tempfile::TempDir, Store, StudyRow) {
        use crate::store::JobResults;
        let levels = crate::store::ROWS_PER_PAGE as usize + 2;
        let text = format!("name: big\nsolver: native\nfactors:\n  - {{name: outlet_diameter, min: 0.020, max: 0.028, unit: m}}\ndesign: {{type: full_factorial, levels: {levels}}}\n");
        let dir = tempfile::tempdir().unwrap();
        let store = Store::open(dir.path()).await.unwrap();
        let study = crate::study::Study::from_text(Path::new("big.yaml"), &text, None).unwrap();
        let id = store
            .insert_study(&study, Path::new("big.yaml"), dir.path())
            .await
            .unwrap();
        let jobs = store.jobs(id).await.unwrap();
        // The widest value is on the second page: a table whose widths came from the
        // first page alone would not line up.
        for (job, value) in [
            (&jobs[1], 0.5),
            (&jobs[2], -1234.5),
            (&jobs[levels - 2], 1.5e6),
        ] {
            store
                .mark_rendered(job.id, &format!("test run {}", job.id))
                .await
                .unwrap();
            store.mark_running(job.id, "1:1", 0.0).await.unwrap();
            let results = JobResults {
                responses: vec![("exit_speed".into(), value)],
                ..JobResults::default()
            };
            store.mark_succeeded(job.id, 0, &results).await.unwrap();
        }
        let error = format!("solver exited with 1: {}", "a".repeat(150));
        store
            .mark_failed(jobs[levels - 1].id, Some(1), &error)
            .await
            .unwrap();
        if on_scheduler {
            store
                .mark_rendered(jobs[3].id, &format!("test run {}", jobs[3].id))
                .await
                .unwrap();
            store.mark_submitted(jobs[3].id, "4242").await.unwrap();
            store
                .set_scheduler_state(jobs[3].id, "PENDING")
                .await
                .unwrap();
        }
        let row = store.study_by_name("big").await.unwrap().unwrap();
        (dir, store, row)
    }

    /// `status --json` read a page of jobs at a time is the JSON of the whole detail,
    /// also past a page boundary with responses on either side of it.
    #[tokio::test]
    async fn the_json_read_a_page_at_a_time_is_the_json_of_the_whole() {
        let (_dir, store, row) = big_study(false).await;
        let project = Path::new("/p/.orch");
        let paged = write_json_paged(&store, row.clone(), project, Vec::new())
            .await
            .unwrap();
        let detail = StudyDetail::load(&store, row).await.unwrap();
        let whole = serde_json::to_string_pretty(&detail.json(project)).unwrap();
        assert_eq!(String::from_utf8(paged).unwrap(), whole);
        assert_eq!(detail.counts()[&JobState::Succeeded], 3);
    }

    /// `orch status STUDY` written a page of jobs at a time, its widths from the jobs'
    /// extents, is the table of the whole detail: the same widths (the longest cell
    /// may be on any page), with and without a SCHEDULER column, and a response that
    /// no job has shown as `-`.
    #[tokio::test]
    async fn the_table_read_a_page_at_a_time_is_the_table_of_the_whole() {
        let shown = ["exit_speed".to_string(), "discharge_rate".to_string()];
        for on_scheduler in [false, true] {
            let (_dir, store, row) = big_study(on_scheduler).await;
            let paged = write_table_paged(&store, row.clone(), &shown, Vec::new())
                .await
                .unwrap();
            let paged = String::from_utf8(paged).unwrap();
            let whole = StudyDetail::load(&store, row).await.unwrap().table(&shown);
            assert_eq!(paged, whole, "on_scheduler {on_scheduler}");
            let header = paged.lines().find(|l| l.starts_with("JOB")).unwrap();
            assert_eq!(header.contains("SCHEDULER"), on_scheduler, "{header}");
            assert!(paged.starts_with("study big (native, "), "{paged:.80}");
            let rows = paged.lines().filter(|l| l.starts_with('p')).count();
            assert_eq!(
                rows,
                crate::store::ROWS_PER_PAGE as usize + 2,
                "{paged:.600}"
            );
            assert!(paged.contains("1 failed"), "{paged:.200}");
            assert!(paged.contains(&format!("{}…", "a".repeat(78))));
        }
    }

    /// The overview counts each study's jobs by state in the store.
    #[tokio::test]
    async fn the_overview_counts_a_study_s_jobs_by_state() {
        let (dir, store, _row) = big_study(false).await;
        let stores = vec![(dir.path().to_path_buf(), store)];
        let json: Value = serde_json::from_str(&overview(&stores, true).await.unwrap()).unwrap();
        let study = &json["studies"][0];
        assert_eq!(study["jobs"], 1002);
        assert_eq!(
            study["counts"],
            json!({"failed": 1, "pending": 998, "succeeded": 3})
        );
        let text = overview(&stores, false).await.unwrap();
        let line = text.lines().find(|l| l.starts_with("big ")).unwrap();
        let cells: Vec<&str> = line.split_whitespace().collect();
        assert_eq!(cells[3..9], ["1002", "998", "0", "3", "1", "0"], "{line}");
    }

    #[test]
    fn the_json_written_a_job_at_a_time_is_the_pretty_json_of_the_whole() {
        for n_jobs in [0, 1, 3] {
            let detail = detail(n_jobs);
            let project = Path::new("/p/.orch");
            let mut written = Vec::new();
            detail.write_json(project, &mut written).unwrap();
            let whole = serde_json::to_string_pretty(&detail.json(project)).unwrap();
            assert_eq!(String::from_utf8(written).unwrap(), whole, "{n_jobs} jobs");
        }
    }
}
