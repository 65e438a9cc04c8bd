//! The SQLite store: the single source of truth for studies, points and jobs.
//!
//! All SQL of `orch` lives in this crate. Every change of state is one transaction;
//! a job transition is guarded by the state the caller expects (`UPDATE … WHERE state
//! IN (…)`), so two processes can never both move the same job, and every transition
//! is recorded in `job_events`. The database is `<project>/orch.db` in WAL mode.
//!
//! Several `orch` processes share one store (two studies submitted into one project,
//! `orch status` while they run). So every transaction that writes begins `IMMEDIATE`
//! (takes the write lock before its first read: a deferred transaction that read and
//! then wants to write cannot wait for the lock, SQLite fails it with "database is
//! locked" at once), and the schema is created and migrated under an exclusive `flock`
//! of [`LOCK_FILE`], so two processes never both apply the same migration.

mod comparisons;
mod job_pages;
mod rounds;
mod rows;
mod series;
mod transitions;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::LazyLock;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use sqlx::sqlite::{SqliteConnectOptions, SqliteJournalMode, SqlitePoolOptions, SqliteSynchronous};
use sqlx::{Row, SqlitePool};

pub use comparisons::{ComparisonRecord, ResponseRecord, SpeedRecord, StoredComparison};
pub use job_pages::{Extremes, JobExtents, JobPage, JobPages};
pub use rounds::{
    CandidateScore, FitRecord, FrontPoint, LackOfFitRow, RoundRecord, Sensitivity, StoredFit,
    StoredRound,
};
pub use rows::{
    Decision, FactorRow, JobKind, JobLink, JobLinkRow, JobRow, JobState, PointRole, PointRow,
    ResponseValues, StudyRow, StudyState, UnknownState, DESIGN_STAGE,
};
pub use series::{SeriesPages, SeriesPoint};

use orch_study::plan::{self, PlannedPoint};
use orch_study::Study;

/// Name of the database file inside a project directory.
pub const DATABASE_FILE: &str = "orch.db";
/// Name of the file beside the database whose exclusive `flock` serialises opening
/// and migrating the store.
pub const LOCK_FILE: &str = "orch.db.lock";
/// How long a statement waits for another process's write lock before failing.
const BUSY_TIMEOUT: Duration = Duration::from_secs(120);
/// Each connection's page cache, as SQLite's `cache_size` (negative: KiB). SQLite's
/// default keeps up to 2 MiB per connection, and every command that reads a whole
/// study fills it, so peak RSS grew with the study up to that cap; 512 KiB holds the
/// tables' upper B-tree levels and the OS's file cache serves the rest (measured at
/// 3004 jobs: same wall times, 1.2–4.4 MB less peak RSS per command).
const CACHE_SIZE_KIB: &str = "-512";
/// How a transaction that writes begins: with the write lock taken, so that the
/// busy timeout applies to it (see the module documentation).
const BEGIN_WRITE: &str = "BEGIN IMMEDIATE";

/// Why the store could not do what was asked.
#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    /// The database could not be opened or created.
    #[error("cannot open the orch database {}: {source}", path.display())]
    Open {
        /// The database file.
        path: PathBuf,
        /// The cause.
        #[source]
        source: sqlx::Error,
    },
    /// The schema could not be brought up to date.
    #[error("cannot update the schema of {}: {source}; each migration runs in a transaction, so nothing stored was changed. A store written by a newer orch needs that orch (or open a copy of the project with it); otherwise keep a copy of the file and report this error", path.display())]
    Migrate {
        /// The database file.
        path: PathBuf,
        /// The cause.
        #[source]
        source: sqlx::migrate::MigrateError,
    },
    /// A query failed.
    #[error("database error while trying to {what}: {source}")]
    Query {
        /// What was being done.
        what: &'static str,
        /// The cause.
        #[source]
        source: sqlx::Error,
    },
    /// A job was not in a state the transition starts from (someone else moved it).
    #[error("job {job} is no longer {expected}; it was changed by another orch command")]
    Stale {
        /// The job id.
        job: i64,
        /// The states the transition expected.
        expected: String,
    },
    /// A state column holds a value this orch does not know (another version wrote
    /// it, or it was damaged); nothing is guessed.
    #[error(transparent)]
    UnknownState(#[from] UnknownState),
    /// Another live orch process drives this study.
    #[error("study `{study}` is being run by another orch process (pid {pid}); wait for it, or stop it with `orch cancel {study}`")]
    Busy {
        /// The study name.
        study: String,
        /// The other process.
        pid: i64,
    },
}

fn query_error(what: &'static str) -> impl FnOnce(sqlx::Error) -> StoreError {
    move |source| {
        // A row whose state is unknown says so itself, not as a database failure.
        if let sqlx::Error::Decode(cause) = &source {
            if let Some(unknown) = cause.downcast_ref::<UnknownState>() {
                return StoreError::UnknownState(unknown.clone());
            }
        }
        StoreError::Query { what, source }
    }
}

/// Seconds since the Unix epoch, now.
pub fn now_s() -> f64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .unwrap_or_default()
        .as_secs_f64()
}

/// What a finished job produced.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct JobResults {
    /// Named scalar responses.
    pub responses: Vec<(String, f64)>,
    /// Named time series of `(t s, value)`.
    pub series: Vec<(String, Vec<(f64, f64)>)>,
    /// Why a response the study asks for is missing from a run that succeeded (kept
    /// in the job's `error`, shown by status).
    pub note: Option<String>,
}

/// A succeeded run that a job with the same identity reuses.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ReuseSource {
    /// Its job id.
    pub job_id: i64,
    /// `study/job`.
    pub name: String,
    /// Its run directory.
    pub run_dir: PathBuf,
    /// What its study noted when it succeeded (a response it lacks, and why).
    pub note: Option<String>,
}

/// The open store of one project directory.
#[derive(Debug, Clone)]
pub struct Store {
    pool: SqlitePool,
    path: PathBuf,
}

impl Store {
    /// Opens (creating if needed) the store in `project_dir` and migrates its schema.
    pub async fn open(project_dir: &Path) -> Result<Store, StoreError> {
        let path = project_dir.join(DATABASE_FILE);
        if let Err(e) = std::fs::create_dir_all(project_dir) {
            return Err(StoreError::Open {
                path,
                source: sqlx::Error::Io(e),
            });
        }
        // Held until the schema is up to date; dropping it unlocks.
        let _lock = lock_exclusively(&project_dir.join(LOCK_FILE))
            .await
            .map_err(|e| StoreError::Open {
                path: path.clone(),
                source: sqlx::Error::Io(e),
            })?;
        let options = SqliteConnectOptions::new()
            .filename(&path)
            .create_if_missing(true)
            .journal_mode(SqliteJournalMode::Wal)
            .synchronous(SqliteSynchronous::Normal)
            .foreign_keys(true)
            .busy_timeout(BUSY_TIMEOUT)
            .pragma("cache_size", CACHE_SIZE_KIB);
        let pool = SqlitePoolOptions::new()
            .max_connections(4)
            .connect_with(options)
            .await
            .map_err(|source| StoreError::Open {
                path: path.clone(),
                source,
            })?;
        sqlx::migrate!("./migrations")
            .run(&pool)
            .await
            .map_err(|source| StoreError::Migrate {
                path: path.clone(),
                source,
            })?;
        Ok(Store { pool, path })
    }

    /// Begins a transaction that will write, holding the write lock from the start.
    async fn begin_write(&self) -> Result<sqlx::Transaction<'static, sqlx::Sqlite>, StoreError> {
        self.pool
            .begin_with(BEGIN_WRITE)
            .await
            .map_err(query_error("start a transaction"))
    }

    /// Opens an existing store; `None` when `project_dir` holds no database.
    pub async fn open_existing(project_dir: &Path) -> Result<Option<Store>, StoreError> {
        if !project_dir.join(DATABASE_FILE).exists() {
            return Ok(None);
        }
        Store::open(project_dir).await.map(Some)
    }

    /// The database file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Closes the pool, checkpointing the WAL.
    pub async fn close(self) {
        self.pool.close().await;
    }

    /// Records a validated study with its factors, points and jobs, all at once.
    /// Jobs are named `p<point>r<replicate>` and run in `<runs_root>/<study>/<job>`.
    /// The files stored with study `study_id` at submission, by path as written.
    pub async fn study_inputs(
        &self,
        study_id: i64,
    ) -> Result<BTreeMap<String, Vec<u8>>, StoreError> {
        let rows = sqlx::query("SELECT path, content FROM study_inputs WHERE study_id = ?")
            .bind(study_id)
            .fetch_all(&self.pool)
            .await
            .map_err(query_error("read the study's files"))?;
        Ok(rows
            .into_iter()
            .map(|row| (row.get::<String, _>(0), row.get::<Vec<u8>, _>(1)))
            .collect())
    }

    /// Records a validated study with its factors, points and jobs, all at once.
    pub async fn insert_study(
        &self,
        study: &Study,
        file_path: &Path,
        runs_root: &Path,
    ) -> Result<i64, StoreError> {
        let now = now_s();
        let mut tx = self.begin_write().await?;
        let study_id: i64 = sqlx::query(
            "INSERT INTO studies (name, solver, file_path, file_text, file_sha256, template_name,
                                  template_text, state, created_at, updated_at)
             VALUES (?, ?, ?, ?, ?, ?, ?, 'active', ?, ?) RETURNING id",
        )
        .bind(&study.name)
        .bind(study.simulation.solver_name())
        .bind(file_path.display().to_string())
        .bind(&study.file_text)
        .bind(&study.file_sha256)
        .bind(&study.template().name)
        .bind(&study.template().text)
        .bind(now)
        .bind(now)
        .fetch_one(&mut *tx)
        .await
        .map_err(query_error("record the study"))?
        .get(0);
        for (path, content) in &study.inputs {
            sqlx::query("INSERT INTO study_inputs (study_id, path, content) VALUES (?, ?, ?)")
                .bind(study_id)
                .bind(path)
                .bind(content)
                .execute(&mut *tx)
                .await
                .map_err(query_error("record the study's files"))?;
        }
        for (idx, factor) in study.factors.iter().enumerate() {
            let levels = factor
                .is_text()
                .then(|| serde_json::to_string(&factor.levels).expect("strings serialise"));
            sqlx::query("INSERT INTO factors (study_id, idx, name, min, max, unit, levels) VALUES (?, ?, ?, ?, ?, ?, ?)")
                .bind(study_id)
                .bind(idx as i64)
                .bind(&factor.name)
                .bind(factor.range.min)
                .bind(factor.range.max)
                .bind(&factor.unit)
                .bind(levels)
                .execute(&mut *tx)
                .await
                .map_err(query_error("record a factor"))?;
        }
        for (idx, range) in study.factors.iter().map(|f| f.range).enumerate() {
            sqlx::query(
                "INSERT INTO round_factors (study_id, round, idx, min, max) VALUES (?, 0, ?, ?, ?)",
            )
            .bind(study_id)
            .bind(idx as i64)
            .bind(range.min)
            .bind(range.max)
            .execute(&mut *tx)
            .await
            .map_err(query_error("record the round's box"))?;
        }
        let runs_dir = runs_root.join(&study.name);
        let ranges: Vec<_> = study.factors.iter().map(|f| f.range).collect();
        let tests = study.test_points(0, &ranges);
        for planned in plan::plan_round(study, 0, &study.points, &tests) {
            insert_planned(&mut tx, study_id, 0, &planned, &runs_dir).await?;
        }
        tx.commit()
            .await
            .map_err(query_error("commit the new study"))?;
        Ok(study_id)
    }

    /// The study called `name`.
    pub async fn study_by_name(&self, name: &str) -> Result<Option<StudyRow>, StoreError> {
        sqlx::query_as("SELECT * FROM studies WHERE name = ?")
            .bind(name)
            .fetch_optional(&self.pool)
            .await
            .map_err(query_error("look up a study"))
    }

    /// Every study, oldest first.
    pub async fn studies(&self) -> Result<Vec<StudyRow>, StoreError> {
        sqlx::query_as("SELECT * FROM studies ORDER BY id")
            .fetch_all(&self.pool)
            .await
            .map_err(query_error("list studies"))
    }

    /// Sets a study's state.
    pub async fn set_study_state(
        &self,
        study_id: i64,
        state: StudyState,
    ) -> Result<(), StoreError> {
        sqlx::query("UPDATE studies SET state = ?, updated_at = ? WHERE id = ?")
            .bind(state)
            .bind(now_s())
            .bind(study_id)
            .execute(&self.pool)
            .await
            .map_err(query_error("change a study's state"))?;
        Ok(())
    }

    /// Claims the study for this process, unless another live driver holds it.
    /// `is_alive(pid, started)` tells whether a recorded driver still runs.
    pub async fn claim_driver(
        &self,
        study: &StudyRow,
        pid: i64,
        started: i64,
        is_alive: impl Fn(i64, i64) -> bool,
    ) -> Result<(), StoreError> {
        let mut tx = self.begin_write().await?;
        refuse_if_driven(&mut tx, study, Some(pid), &is_alive).await?;
        sqlx::query("UPDATE studies SET driver_pid = ?, driver_started = ?, state = 'active', updated_at = ? WHERE id = ?")
            .bind(pid)
            .bind(started)
            .bind(now_s())
            .bind(study.id)
            .execute(&mut *tx)
            .await
            .map_err(query_error("claim the study"))?;
        tx.commit().await.map_err(query_error("claim the study"))
    }

    /// Deletes study `study` with everything recorded of it (points, jobs, responses,
    /// rounds, files), unless a live orch process drives it. Its run directories are
    /// the caller's to remove.
    pub async fn delete_study(
        &self,
        study: &StudyRow,
        is_alive: impl Fn(i64, i64) -> bool,
    ) -> Result<(), StoreError> {
        let mut tx = self.begin_write().await?;
        refuse_if_driven(&mut tx, study, None, &is_alive).await?;
        sqlx::query("DELETE FROM studies WHERE id = ?")
            .bind(study.id)
            .execute(&mut *tx)
            .await
            .map_err(query_error("delete the study"))?;
        tx.commit().await.map_err(query_error("delete the study"))
    }

    /// Releases the study's driver claim and sets its final state.
    pub async fn release_driver(&self, study_id: i64, state: StudyState) -> Result<(), StoreError> {
        sqlx::query("UPDATE studies SET driver_pid = NULL, driver_started = NULL, state = ?, updated_at = ? WHERE id = ?")
            .bind(state)
            .bind(now_s())
            .bind(study_id)
            .execute(&self.pool)
            .await
            .map_err(query_error("release the study"))?;
        Ok(())
    }

    /// The study's current state as stored (another process may have cancelled it).
    pub async fn study_state(&self, study_id: i64) -> Result<StudyState, StoreError> {
        let state: String = sqlx::query_scalar("SELECT state FROM studies WHERE id = ?")
            .bind(study_id)
            .fetch_one(&self.pool)
            .await
            .map_err(query_error("read a study's state"))?;
        Ok(rows::parse_state("studies", study_id, state)?)
    }

    /// Every job of a study, in point and replicate order; read [`ROWS_PER_PAGE`] at a
    /// time (the index `jobs_by_study`).
    pub async fn jobs(&self, study_id: i64) -> Result<Vec<JobRow>, StoreError> {
        let mut jobs: Vec<JobRow> = Vec::new();
        loop {
            let page = self
                .jobs_after(study_id, jobs.last().map_or(i64::MIN, |j| j.id))
                .await?;
            let whole = page.len() < PAGE_LEN;
            jobs.extend(page);
            if whole {
                return Ok(jobs);
            }
        }
    }

    /// The next page of a study's jobs: up to [`ROWS_PER_PAGE`] of them with ids
    /// above `after_id`, in id order; fewer than a page means the last. A command
    /// that writes every job goes through the study this way and holds one page.
    pub async fn jobs_after(
        &self,
        study_id: i64,
        after_id: i64,
    ) -> Result<Vec<JobRow>, StoreError> {
        sqlx::query_as("SELECT * FROM jobs WHERE study_id = ? AND id > ? ORDER BY id LIMIT ?")
            .bind(study_id)
            .bind(after_id)
            .bind(ROWS_PER_PAGE)
            .fetch_all(&self.pool)
            .await
            .map_err(query_error("list jobs"))
    }

    /// The jobs chained after job `job_id` (its stages, or a coupling chain's next
    /// job), in id order.
    pub async fn followers_of(&self, job_id: i64) -> Result<Vec<JobRow>, StoreError> {
        sqlx::query_as("SELECT * FROM jobs WHERE after_job_id = ? ORDER BY id")
            .bind(job_id)
            .fetch_all(&self.pool)
            .await
            .map_err(query_error("list a job's followers"))
    }

    /// Every job of a study as [`JobLinkRow`]s (no run directories, handles or error
    /// text), in id order, read [`ROWS_PER_PAGE`] at a time: what an analysis of the
    /// study's runs needs, at a fraction of [`Store::jobs`]'s memory.
    pub async fn job_links(&self, study_id: i64) -> Result<Vec<JobLinkRow>, StoreError> {
        static SQL: LazyLock<String> = LazyLock::new(|| {
            format!(
                "SELECT {} FROM jobs WHERE study_id = ? AND id > ? ORDER BY id LIMIT ?",
                JobLinkRow::COLUMNS
            )
        });
        let mut jobs: Vec<JobLinkRow> = Vec::new();
        loop {
            let page: Vec<JobLinkRow> = sqlx::query_as(&SQL)
                .bind(study_id)
                .bind(jobs.last().map_or(i64::MIN, |j| j.id))
                .bind(ROWS_PER_PAGE)
                .fetch_all(&self.pool)
                .await
                .map_err(query_error("list jobs' links"))?;
            let whole = page.len() < PAGE_LEN;
            jobs.extend(page);
            if whole {
                jobs.shrink_to_fit();
                return Ok(jobs);
            }
        }
    }

    /// A study's jobs that are submitted or running (to poll), in id order.
    pub async fn launched_jobs(&self, study_id: i64) -> Result<Vec<JobRow>, StoreError> {
        static SQL: LazyLock<String> = LazyLock::new(|| {
            format!(
                "SELECT * FROM jobs WHERE study_id = ? AND state IN ({}) ORDER BY id",
                rows::state_list(JobState::is_launched)
            )
        });
        sqlx::query_as(&SQL)
            .bind(study_id)
            .fetch_all(&self.pool)
            .await
            .map_err(query_error("list launched jobs"))
    }

    /// A study's jobs in `state`, in id order.
    pub async fn jobs_in_state(
        &self,
        study_id: i64,
        state: JobState,
    ) -> Result<Vec<JobRow>, StoreError> {
        sqlx::query_as("SELECT * FROM jobs WHERE study_id = ? AND state = ? ORDER BY id")
            .bind(study_id)
            .bind(state.as_str())
            .fetch_all(&self.pool)
            .await
            .map_err(query_error("list jobs in a state"))
    }

    /// How many of a study's jobs are in each state (states without jobs left out).
    pub async fn job_counts(&self, study_id: i64) -> Result<BTreeMap<JobState, usize>, StoreError> {
        let counted: Vec<(String, i64, i64)> = sqlx::query_as(
            "SELECT state, COUNT(*), MIN(id) FROM jobs WHERE study_id = ? GROUP BY state",
        )
        .bind(study_id)
        .fetch_all(&self.pool)
        .await
        .map_err(query_error("count jobs by state"))?;
        let mut counts = BTreeMap::new();
        for (state, n, first) in counted {
            let state = rows::parse_state("jobs", first, state)?;
            counts.insert(state, usize::try_from(n).unwrap_or(0));
        }
        Ok(counts)
    }

    /// What the driver decides about at each tick, in id order: a study's jobs that
    /// are rendered, submitted or running; the first `pending_limit` pending jobs that
    /// can be acted on (they follow no job, or one that is final: launched, failed or
    /// cancelled with it); and the jobs all those follow (`after_job_id`). A pending
    /// job that waits for an unfinished one is left out; so are the pending jobs past
    /// the limit, which cannot be launched this tick anyway. So a tick's cost grows
    /// with the jobs running and the limit, not with the study (the index
    /// `jobs_by_state`), and the list is empty exactly when no job is unfinished: the
    /// first job of any chain of pending jobs follows no job or a final or running one.
    pub async fn unfinished_jobs(
        &self,
        study_id: i64,
        pending_limit: usize,
    ) -> Result<Vec<JobRow>, StoreError> {
        static SQL: LazyLock<String> = LazyLock::new(|| {
            let open = rows::state_list(|s| !s.is_final() && s != JobState::Pending);
            let pending = rows::state_list(|s| s == JobState::Pending);
            let finals = rows::state_list(JobState::is_final);
            format!(
                "WITH open AS (
                     SELECT id, after_job_id FROM jobs WHERE study_id = ?1 AND state IN ({open})
                 ), ready AS (
                     SELECT j.id, j.after_job_id FROM jobs j LEFT JOIN jobs up ON up.id = j.after_job_id
                      WHERE j.study_id = ?1 AND j.state IN ({pending})
                        AND (j.after_job_id IS NULL OR up.state IN ({finals}))
                      ORDER BY j.id LIMIT ?2
                 ), picked AS (
                     SELECT id, after_job_id FROM open UNION ALL SELECT id, after_job_id FROM ready
                 )
                 SELECT * FROM jobs
                  WHERE id IN (SELECT id FROM picked
                               UNION SELECT after_job_id FROM picked WHERE after_job_id IS NOT NULL)
                  ORDER BY id"
            )
        });
        sqlx::query_as(&SQL)
            .bind(study_id)
            .bind(i64::try_from(pending_limit).unwrap_or(i64::MAX))
            .fetch_all(&self.pool)
            .await
            .map_err(query_error("list unfinished jobs"))
    }

    /// One job by id.
    pub async fn job(&self, job_id: i64) -> Result<JobRow, StoreError> {
        sqlx::query_as("SELECT * FROM jobs WHERE id = ?")
            .bind(job_id)
            .fetch_one(&self.pool)
            .await
            .map_err(query_error("read a job"))
    }

    /// The names of the jobs `job_ids`, by id (unknown ids are left out), in one query.
    pub async fn job_names(&self, job_ids: &[i64]) -> Result<BTreeMap<i64, String>, StoreError> {
        if job_ids.is_empty() {
            return Ok(BTreeMap::new());
        }
        let ids = serde_json::to_string(job_ids).expect("JSON of integers");
        let rows: Vec<(i64, String)> = sqlx::query_as(
            "SELECT id, name FROM jobs WHERE id IN (SELECT value FROM json_each(?))",
        )
        .bind(ids)
        .fetch_all(&self.pool)
        .await
        .map_err(query_error("read jobs' names"))?;
        Ok(rows.into_iter().collect())
    }

    /// The factors of a study in order.
    pub async fn factors(&self, study_id: i64) -> Result<Vec<FactorRow>, StoreError> {
        sqlx::query_as(
            "SELECT name, min, max, unit, levels FROM factors WHERE study_id = ? ORDER BY idx",
        )
        .bind(study_id)
        .fetch_all(&self.pool)
        .await
        .map_err(query_error("list factors"))
    }

    /// The design points of a study with their coded and natural values.
    /// In round and index order, read [`ROWS_PER_PAGE`] points at a time.
    pub async fn points(&self, study_id: i64) -> Result<Vec<PointRow>, StoreError> {
        let mut points: Vec<PointRow> = Vec::new();
        loop {
            let (round, idx) = points
                .last()
                .map_or((i64::MIN, i64::MIN), |p| (p.round, p.idx));
            let rows = sqlx::query(
                "WITH page AS (
                     SELECT id, round, idx, purpose, fidelity FROM points
                      WHERE study_id = ?1 AND (round, idx) > (?2, ?3)
                      ORDER BY round, idx LIMIT ?4
                 )
                 SELECT p.id, p.round, p.idx, v.coded, v.natural, p.purpose, p.fidelity FROM page p
                 JOIN point_values v ON v.point_id = p.id ORDER BY p.round, p.idx, v.factor_idx",
            )
            .bind(study_id)
            .bind(round)
            .bind(idx)
            .bind(ROWS_PER_PAGE)
            .fetch_all(&self.pool)
            .await
            .map_err(query_error("list design points"))?;
            let page = collect_points(rows)?;
            let whole = page.len() < PAGE_LEN;
            points.extend(page);
            if whole {
                return Ok(points);
            }
        }
    }

    /// The design points of `ids` (those that exist), in id order.
    pub async fn points_by_id(&self, ids: &[i64]) -> Result<Vec<PointRow>, StoreError> {
        if ids.is_empty() {
            return Ok(Vec::new());
        }
        let ids = serde_json::to_string(ids).expect("JSON of integers");
        let rows = sqlx::query(
            "SELECT p.id, p.round, p.idx, v.coded, v.natural, p.purpose, p.fidelity FROM points p
             JOIN point_values v ON v.point_id = p.id
             WHERE p.id IN (SELECT value FROM json_each(?)) ORDER BY p.id, v.factor_idx",
        )
        .bind(ids)
        .fetch_all(&self.pool)
        .await
        .map_err(query_error("read design points"))?;
        collect_points(rows)
    }

    /// The latest round that has jobs (0 for none) and its jobs, in id order: what the
    /// terminal's bar counts.
    pub async fn latest_round_jobs(&self, study_id: i64) -> Result<(i64, Vec<JobRow>), StoreError> {
        let (round,): (i64,) = sqlx::query_as(
            "SELECT COALESCE(MAX(p.round), 0) FROM jobs j JOIN points p ON p.id = j.point_id
             WHERE j.study_id = ?",
        )
        .bind(study_id)
        .fetch_one(&self.pool)
        .await
        .map_err(query_error("find the latest round"))?;
        let jobs = sqlx::query_as(
            "SELECT j.* FROM jobs j JOIN points p ON p.id = j.point_id
             WHERE j.study_id = ? AND p.round = ? ORDER BY j.id",
        )
        .bind(study_id)
        .bind(round)
        .fetch_all(&self.pool)
        .await
        .map_err(query_error("list the latest round's jobs"))?;
        Ok((round, jobs))
    }

    /// How many jobs the study's round `round` has.
    pub async fn round_job_count(&self, study_id: i64, round: i64) -> Result<usize, StoreError> {
        let (n,): (i64,) = sqlx::query_as(
            "SELECT COUNT(*) FROM jobs j JOIN points p ON p.id = j.point_id
             WHERE j.study_id = ? AND p.round = ?",
        )
        .bind(study_id)
        .bind(round)
        .fetch_one(&self.pool)
        .await
        .map_err(query_error("count a round's jobs"))?;
        Ok(usize::try_from(n).unwrap_or(0))
    }

    /// The jobs at `positions` (0-based) of round `round`'s jobs in id order, in id
    /// order (positions past the end are left out): a page or table that shows a few
    /// of a large round reads those, not the round.
    pub async fn round_jobs_at(
        &self,
        study_id: i64,
        round: i64,
        positions: &[usize],
    ) -> Result<Vec<JobRow>, StoreError> {
        self.jobs_at_positions(study_id, Some(round), positions)
            .await
    }

    /// The jobs at `positions` (0-based) of the study's jobs in id order, in id order
    /// (positions past the end are left out): [`Store::round_jobs_at`] over every
    /// round, for a table that lists a few of a large study.
    pub async fn jobs_at(
        &self,
        study_id: i64,
        positions: &[usize],
    ) -> Result<Vec<JobRow>, StoreError> {
        self.jobs_at_positions(study_id, None, positions).await
    }

    /// The jobs at `positions` of the study's jobs in id order, of round `round` only
    /// when given.
    async fn jobs_at_positions(
        &self,
        study_id: i64,
        round: Option<i64>,
        positions: &[usize],
    ) -> Result<Vec<JobRow>, StoreError> {
        if positions.is_empty() {
            return Ok(Vec::new());
        }
        let positions = serde_json::to_string(positions).expect("JSON of integers");
        // The window numbers ids only: SQLite holds what it numbers in a temporary
        // table, and whole rows there would cost memory in proportion to the study.
        sqlx::query_as(
            "SELECT * FROM jobs WHERE id IN (
                 SELECT id FROM (
                     SELECT j.id, row_number() OVER (ORDER BY j.id) - 1 AS position
                       FROM jobs j JOIN points p ON p.id = j.point_id
                      WHERE j.study_id = ?1 AND (?2 IS NULL OR p.round = ?2)
                 ) WHERE position IN (SELECT value FROM json_each(?3))
             ) ORDER BY id",
        )
        .bind(study_id)
        .bind(round)
        .bind(positions)
        .fetch_all(&self.pool)
        .await
        .map_err(query_error("read some of a study's jobs"))
    }

    /// Responses of every job of a study, by job id then name.
    pub async fn responses(
        &self,
        study_id: i64,
    ) -> Result<BTreeMap<i64, ResponseValues>, StoreError> {
        // One row per job with a column per response name rather than one row per
        // value: every row crosses from SQLite's thread with its own allocations, and
        // a study has an order of magnitude more values than jobs.
        let names = self.response_names(study_id).await?;
        self.responses_by_job(study_id, &names, false).await
    }

    /// The names of the responses a study's jobs stored, in name order.
    pub async fn response_names(&self, study_id: i64) -> Result<Vec<String>, StoreError> {
        sqlx::query_scalar(
            "SELECT DISTINCT r.name FROM responses r JOIN jobs j ON j.id = r.job_id
             WHERE j.study_id = ? ORDER BY r.name",
        )
        .bind(study_id)
        .fetch_all(&self.pool)
        .await
        .map_err(query_error("list response names"))
    }

    /// The responses `names` (distinct) of every job of a study, by job id then name:
    /// what [`Store::responses`] gives restricted to those names, for a command that
    /// needs only some (`orch fit`, the round analysis, status's table); each value
    /// is found through the primary key, so the cost grows with the jobs and names
    /// asked for, not with every stored value.
    pub async fn responses_named(
        &self,
        study_id: i64,
        names: &[String],
    ) -> Result<BTreeMap<i64, ResponseValues>, StoreError> {
        self.responses_by_job(study_id, names, true).await
    }

    /// The values of `names` by job, through the primary key when `seek` (for a few
    /// names), else from every response row (for all of them).
    async fn responses_by_job(
        &self,
        study_id: i64,
        names: &[String],
        seek: bool,
    ) -> Result<BTreeMap<i64, ResponseValues>, StoreError> {
        self.responses_by_job_in(study_id, names, seek, i64::MIN, i64::MAX)
            .await
    }

    /// [`Store::responses_by_job`] of the study's jobs with ids in `(after, up_to]`:
    /// a page of jobs ([`JobPages`]) in one query.
    async fn responses_by_job_in(
        &self,
        study_id: i64,
        names: &[String],
        seek: bool,
        mut after: i64,
        up_to: i64,
    ) -> Result<BTreeMap<i64, ResponseValues>, StoreError> {
        let mut out: BTreeMap<i64, ResponseValues> = BTreeMap::new();
        if names.is_empty() {
            return Ok(out);
        }
        let sql = responses_by_job_sql(names.len(), seek);
        loop {
            let mut query = sqlx::query(&sql)
                .bind(study_id)
                .bind(after)
                .bind(ROWS_PER_PAGE)
                .bind(up_to);
            for name in names {
                query = query.bind(name);
            }
            let rows = query
                .fetch_all(&self.pool)
                .await
                .map_err(query_error("read responses"))?;
            let whole = rows.len() < PAGE_LEN;
            for row in rows {
                let values: ResponseValues = names
                    .iter()
                    .enumerate()
                    .filter_map(|(k, name)| {
                        let value: Option<f64> = row.get(k + 1);
                        value.map(|v| (name.clone(), v))
                    })
                    .collect();
                after = row.get(0);
                out.insert(after, values);
            }
            if whole {
                return Ok(out);
            }
        }
    }

    /// Responses of one job, by name.
    pub async fn job_responses(&self, job_id: i64) -> Result<BTreeMap<String, f64>, StoreError> {
        let rows: Vec<(String, f64)> =
            sqlx::query_as("SELECT name, value FROM responses WHERE job_id = ?")
                .bind(job_id)
                .fetch_all(&self.pool)
                .await
                .map_err(query_error("read a job's responses"))?;
        Ok(rows.into_iter().collect())
    }

    /// The responses of the jobs `job_ids`, by job id then name (a job without any is
    /// left out), in one query: what [`Store::job_responses`] gives for each.
    pub async fn responses_of_jobs(
        &self,
        job_ids: &[i64],
    ) -> Result<BTreeMap<i64, ResponseValues>, StoreError> {
        if job_ids.is_empty() {
            return Ok(BTreeMap::new());
        }
        let ids = serde_json::to_string(job_ids).expect("JSON of integers");
        let rows: Vec<(i64, String, f64)> = sqlx::query_as(
            "SELECT job_id, name, value FROM responses
             WHERE job_id IN (SELECT value FROM json_each(?))",
        )
        .bind(ids)
        .fetch_all(&self.pool)
        .await
        .map_err(query_error("read some jobs' responses"))?;
        let mut by_job: BTreeMap<i64, Vec<(String, f64)>> = BTreeMap::new();
        for (job, name, value) in rows {
            by_job.entry(job).or_default().push((name, value));
        }
        Ok(by_job
            .into_iter()
            .map(|(job, values)| (job, values.into_iter().collect()))
            .collect())
    }

    /// One time series of a job, in time order.
    pub async fn series(&self, job_id: i64, name: &str) -> Result<Vec<(f64, f64)>, StoreError> {
        sqlx::query_as("SELECT t, value FROM series WHERE job_id = ? AND name = ? ORDER BY t")
            .bind(job_id)
            .bind(name)
            .fetch_all(&self.pool)
            .await
            .map_err(query_error("read a time series"))
    }
}

/// Takes an exclusive `flock` of `path` (created if missing), waiting for any other
/// holder; the lock is released when the returned value is dropped.
async fn lock_exclusively(path: &Path) -> std::io::Result<nix::fcntl::Flock<std::fs::File>> {
    let path = path.to_path_buf();
    tokio::task::spawn_blocking(move || {
        let file = std::fs::OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .open(&path)?;
        nix::fcntl::Flock::lock(file, nix::fcntl::FlockArg::LockExclusive)
            .map_err(|(_, errno)| std::io::Error::from(errno))
    })
    .await
    .map_err(std::io::Error::other)?
}

/// Inserts the points of `planned` (one round's, as [`orch_study::plan::plan_points`]
/// planned them) and their jobs as they are: the store decides nothing about them.
pub(crate) async fn insert_planned(
    tx: &mut sqlx::SqliteConnection,
    study_id: i64,
    round: i64,
    planned: &[PlannedPoint<'_>],
    runs_dir: &Path,
) -> Result<(), StoreError> {
    for point in planned {
        let point_id: i64 = sqlx::query(
            "INSERT INTO points (study_id, round, idx, purpose, fidelity) VALUES (?, ?, ?, ?, ?) RETURNING id",
        )
        .bind(study_id)
        .bind(round)
        .bind(point.idx as i64)
        .bind(point.purpose.as_str())
        .bind(i64::from(point.point.fidelity))
        .fetch_one(&mut *tx)
        .await
        .map_err(query_error("record a design point"))?
        .get(0);
        let values = point.point.coded.iter().zip(&point.point.natural);
        for (factor_idx, (coded, natural)) in values.enumerate() {
            sqlx::query("INSERT INTO point_values (point_id, factor_idx, coded, natural) VALUES (?, ?, ?, ?)")
                .bind(point_id)
                .bind(factor_idx as i64)
                .bind(coded)
                .bind(natural)
                .execute(&mut *tx)
                .await
                .map_err(query_error("record a design point"))?;
        }
        let mut ids: Vec<i64> = Vec::with_capacity(point.jobs.len());
        for job in &point.jobs {
            let after = job.after.map(|index| ids[index]);
            let id: i64 = sqlx::query(
                "INSERT INTO jobs (study_id, point_id, replicate, name, seed, state, run_dir, stage, after_job_id)
                 VALUES (?, ?, ?, ?, ?, 'pending', ?, ?, ?) RETURNING id",
            )
            .bind(study_id)
            .bind(point_id)
            .bind(job.replicate as i64)
            .bind(&job.name)
            .bind(job.seed as i64)
            .bind(runs_dir.join(&job.name).display().to_string())
            .bind(job.kind.as_str())
            .bind(after)
            .fetch_one(&mut *tx)
            .await
            .map_err(query_error("record a job"))?
            .get(0);
            ids.push(id);
        }
    }
    Ok(())
}

/// Replaces `job_id`'s responses and series with `results`, inside `tx`.
async fn store_results(
    tx: &mut sqlx::SqliteConnection,
    job_id: i64,
    results: &JobResults,
) -> Result<(), StoreError> {
    for table in ["responses", "series"] {
        sqlx::query(&format!("DELETE FROM {table} WHERE job_id = ?"))
            .bind(job_id)
            .execute(&mut *tx)
            .await
            .map_err(query_error("clear old results"))?;
    }
    for (name, value) in &results.responses {
        sqlx::query("INSERT INTO responses (job_id, name, value) VALUES (?, ?, ?)")
            .bind(job_id)
            .bind(name)
            .bind(value)
            .execute(&mut *tx)
            .await
            .map_err(query_error("record a response"))?;
    }
    for (name, points) in &results.series {
        for (t, value) in points {
            sqlx::query("INSERT INTO series (job_id, name, t, value) VALUES (?, ?, ?, ?)")
                .bind(job_id)
                .bind(name)
                .bind(t)
                .bind(value)
                .execute(&mut *tx)
                .await
                .map_err(query_error("record a time series"))?;
        }
    }
    Ok(())
}

/// Refuses, inside the write transaction `tx`, when a live orch process other than
/// `me` drives `study` (`is_alive(pid, started)` tells whether a recorded one runs).
async fn refuse_if_driven(
    tx: &mut sqlx::Transaction<'_, sqlx::Sqlite>,
    study: &StudyRow,
    me: Option<i64>,
    is_alive: impl Fn(i64, i64) -> bool,
) -> Result<(), StoreError> {
    let holder: (Option<i64>, Option<i64>) =
        sqlx::query_as("SELECT driver_pid, driver_started FROM studies WHERE id = ?")
            .bind(study.id)
            .fetch_one(&mut **tx)
            .await
            .map_err(query_error("read the study's driver"))?;
    match holder {
        (Some(other), Some(started)) if Some(other) != me && is_alive(other, started) => {
            Err(StoreError::Busy {
                study: study.name.clone(),
                pid: other,
            })
        }
        _ => Ok(()),
    }
}

/// Rows a read of a whole study's jobs, points or responses takes from SQLite per
/// query: each page is handed over and dropped before the next, so what such a read
/// holds beyond its result does not grow with the study.
pub const ROWS_PER_PAGE: i64 = 1000;

/// [`ROWS_PER_PAGE`] as a length: a shorter page is the last.
const PAGE_LEN: usize = ROWS_PER_PAGE as usize;

/// The query of [`Store::responses`] for `n_names` response names: the study `?1`,
/// the last job id of the page before `?2`, the page's length `?3`, the last job id
/// wanted `?4`, then the names (`?5` on). One row per job with responses, with its value of each name or NULL, in
/// job id order (the index `jobs_by_study`). A job has at most one value per name
/// (the primary key), so `MAX` returns it as stored. With `seek` only the names'
/// rows are visited (`r.name IN …`, through the primary key); without, every response
/// row of the job (cheaper when the names are all there are).
fn responses_by_job_sql(n_names: usize, seek: bool) -> String {
    let columns: Vec<String> = (0..n_names)
        .map(|k| format!("MAX(CASE WHEN r.name = ?{} THEN r.value END)", k + 5))
        .collect();
    let names: Vec<String> = (0..n_names).map(|k| format!("?{}", k + 5)).collect();
    let only = if seek {
        format!(" AND r.name IN ({})", names.join(", "))
    } else {
        String::new()
    };
    format!(
        "SELECT j.id, {} FROM jobs j JOIN responses r ON r.job_id = j.id{only}
         WHERE j.study_id = ?1 AND j.id > ?2 AND j.id <= ?4 GROUP BY j.id ORDER BY j.id LIMIT ?3",
        columns.join(", "),
    )
}

/// Design points from rows of `(id, round, idx, coded, natural, purpose)`, one row per
/// factor, ordered by point and factor.
fn collect_points(rows: Vec<sqlx::sqlite::SqliteRow>) -> Result<Vec<PointRow>, StoreError> {
    let mut points: Vec<PointRow> = Vec::new();
    for row in rows {
        let id: i64 = row.get(0);
        if points.last().is_none_or(|p| p.id != id) {
            let purpose: String = row.get(5);
            points.push(PointRow {
                id,
                round: row.get(1),
                idx: row.get(2),
                purpose: rows::parse_state_column("points", "purpose", id, purpose)?,
                fidelity: row.get::<i64, _>(6) as u32,
                coded: Vec::new(),
                natural: Vec::new(),
            });
        }
        let point = points.last_mut().expect("pushed above");
        point.coded.push(row.get(3));
        point.natural.push(row.get(4));
    }
    Ok(points)
}

/// A value bound into a transition's assignments.
enum Bind {
    Int(i64),
    Real(f64),
    Text(String),
    Null,
}

#[cfg(test)]
mod tests;
