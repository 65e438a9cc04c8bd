//! Rows read from the store, and the state enums stored as text.
//!
//! A state is an enum from the moment it leaves SQLite: the rows decode it
//! ([`sqlx::FromRow`] written out here, so that a bad value can name its row), and the
//! enums encode and decode themselves as TEXT ([`sqlx::Type`]). A value this orch does
//! not know is an [`UnknownState`] error, never a default: reading a damaged `running`
//! as `pending` would launch the job a second time.

use std::fmt;
use std::str::FromStr;

use sqlx::error::BoxDynError;
use sqlx::sqlite::{SqliteArgumentValue, SqliteRow, SqliteTypeInfo, SqliteValueRef};
use sqlx::{Decode, Encode, Row, Sqlite, Type};

/// A state column holds a value this orch does not know.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{table} row {id} has {column} `{value}`, which this orch does not know; the database was written by another version or damaged: use the orch that wrote it, or restore {} from a backup", super::DATABASE_FILE)]
pub struct UnknownState {
    /// The table (`jobs`, `studies`).
    pub table: &'static str,
    /// The column (`state`, or `stage`: a job's kind).
    pub column: &'static str,
    /// The row's id.
    pub id: i64,
    /// The stored text.
    pub value: String,
}

/// TEXT encoding and decoding for a state enum with `as_str` and `FromStr`.
macro_rules! text_state {
    ($state:ty) => {
        impl Type<Sqlite> for $state {
            fn type_info() -> SqliteTypeInfo {
                <&str as Type<Sqlite>>::type_info()
            }

            fn compatible(ty: &SqliteTypeInfo) -> bool {
                <&str as Type<Sqlite>>::compatible(ty)
            }
        }

        impl<'q> Encode<'q, Sqlite> for $state {
            fn encode_by_ref(
                &self,
                args: &mut Vec<SqliteArgumentValue<'q>>,
            ) -> Result<sqlx::encode::IsNull, BoxDynError> {
                <&str as Encode<'q, Sqlite>>::encode_by_ref(&self.as_str(), args)
            }
        }

        impl<'r> Decode<'r, Sqlite> for $state {
            fn decode(value: SqliteValueRef<'r>) -> Result<Self, BoxDynError> {
                let text = <&str as Decode<'r, Sqlite>>::decode(value)?;
                Ok(text.parse::<$state>()?)
            }
        }
    };
}

text_state!(JobState);
text_state!(StudyState);
text_state!(Decision);

/// Reads the `state` column of a row of `table` as `S`, naming the row when it holds a
/// value this orch does not know.
fn state_of<S: FromStr>(row: &SqliteRow, table: &'static str, id: i64) -> sqlx::Result<S> {
    let value: String = row.try_get("state")?;
    value.parse().map_err(|_| {
        sqlx::Error::Decode(Box::new(UnknownState {
            table,
            column: "state",
            id,
            value,
        }))
    })
}

/// The kind of job `id`, decoded from its `stage` column.
fn kind_of(row: &SqliteRow, id: i64) -> sqlx::Result<JobKind> {
    let value: String = row.try_get("stage")?;
    JobKind::parse(&value).ok_or_else(|| {
        sqlx::Error::Decode(Box::new(UnknownState {
            table: "jobs",
            column: "stage",
            id,
            value,
        }))
    })
}

/// Parses a state read on its own (`SELECT state …`), naming its row when unknown.
pub(crate) fn parse_state<S: FromStr>(
    table: &'static str,
    id: i64,
    value: String,
) -> Result<S, UnknownState> {
    parse_state_column(table, "state", id, value)
}

/// Parses an enum column other than `state` (`points.purpose`), naming its row and
/// column when unknown.
pub(crate) fn parse_state_column<S: FromStr>(
    table: &'static str,
    column: &'static str,
    id: i64,
    value: String,
) -> Result<S, UnknownState> {
    value.parse().map_err(|_| UnknownState {
        table,
        column,
        id,
        value,
    })
}

/// The life of a job: pending → rendered → (submitted →) running → succeeded | failed |
/// cancelled. A job that must run again goes back to pending.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum JobState {
    /// Waiting to be rendered and launched.
    Pending,
    /// Its run directory holds the rendered input.
    Rendered,
    /// Handed to a batch scheduler, not yet running.
    Submitted,
    /// The solver is running.
    Running,
    /// Finished and its results are stored.
    Succeeded,
    /// Finished without results; `error` says why.
    Failed,
    /// Stopped by the user.
    Cancelled,
}

impl JobState {
    /// Every state, in life order.
    pub const ALL: [JobState; 7] = [
        JobState::Pending,
        JobState::Rendered,
        JobState::Submitted,
        JobState::Running,
        JobState::Succeeded,
        JobState::Failed,
        JobState::Cancelled,
    ];

    /// The text stored in the database.
    pub fn as_str(self) -> &'static str {
        match self {
            JobState::Pending => "pending",
            JobState::Rendered => "rendered",
            JobState::Submitted => "submitted",
            JobState::Running => "running",
            JobState::Succeeded => "succeeded",
            JobState::Failed => "failed",
            JobState::Cancelled => "cancelled",
        }
    }

    /// True for succeeded, failed and cancelled.
    pub fn is_final(self) -> bool {
        matches!(
            self,
            JobState::Succeeded | JobState::Failed | JobState::Cancelled
        )
    }

    /// True for submitted and running: an executor holds the job, and it is polled.
    pub fn is_launched(self) -> bool {
        matches!(self, JobState::Submitted | JobState::Running)
    }
}

/// The states for which `keep` holds as an SQL list (`'submitted', 'running'`), spelled
/// by [`JobState::as_str`], so that the store's queries name no state of their own.
pub(super) fn state_list(keep: impl Fn(JobState) -> bool) -> String {
    JobState::ALL
        .into_iter()
        .filter(|&state| keep(state))
        .map(|state| format!("'{}'", state.as_str()))
        .collect::<Vec<_>>()
        .join(", ")
}

impl FromStr for JobState {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        JobState::ALL
            .into_iter()
            .find(|state| state.as_str() == s)
            .ok_or_else(|| format!("unknown job state `{s}`"))
    }
}

impl fmt::Display for JobState {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// The state of a study as a whole.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StudyState {
    /// Submitted; jobs run or wait to run.
    Active,
    /// Stopped by Ctrl-C; `orch resume` continues it.
    Interrupted,
    /// Stopped by `orch cancel`.
    Cancelled,
    /// Every job reached a final state.
    Finished,
}

impl StudyState {
    /// The text stored in the database.
    pub fn as_str(self) -> &'static str {
        match self {
            StudyState::Active => "active",
            StudyState::Interrupted => "interrupted",
            StudyState::Cancelled => "cancelled",
            StudyState::Finished => "finished",
        }
    }
}

impl FromStr for StudyState {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        [
            StudyState::Active,
            StudyState::Interrupted,
            StudyState::Cancelled,
            StudyState::Finished,
        ]
        .into_iter()
        .find(|state| state.as_str() == s)
        .ok_or_else(|| format!("unknown study state `{s}`"))
    }
}

impl fmt::Display for StudyState {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// What the metamodel stage decided after a round (`proposals.decision`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Decision {
    /// Another round runs in a box around the optimum.
    NextRound,
    /// The optimum moved less than the tolerance: the study stops.
    Converged,
    /// The study's last round (or it has no objective).
    LastRound,
    /// No surface gave an optimum to move to: the study stops.
    NoOptimum,
}

impl Decision {
    /// Every decision.
    pub const ALL: [Decision; 4] = [
        Decision::NextRound,
        Decision::Converged,
        Decision::LastRound,
        Decision::NoOptimum,
    ];

    /// The text stored in the database.
    pub fn as_str(self) -> &'static str {
        match self {
            Decision::NextRound => "next_round",
            Decision::Converged => "converged",
            Decision::LastRound => "last_round",
            Decision::NoOptimum => "no_optimum",
        }
    }
}

impl FromStr for Decision {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Decision::ALL
            .into_iter()
            .find(|d| d.as_str() == s)
            .ok_or_else(|| format!("unknown decision `{s}`"))
    }
}

impl fmt::Display for Decision {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// A row of `studies`.
#[derive(Debug, Clone, PartialEq)]
pub struct StudyRow {
    /// Id.
    pub id: i64,
    /// Name.
    pub name: String,
    /// Solver name.
    pub solver: String,
    /// Study file as given at submission.
    pub file_path: String,
    /// Study file text.
    pub file_text: String,
    /// SHA-256 of the text, hex.
    pub file_sha256: String,
    /// Template name.
    pub template_name: String,
    /// Template text.
    pub template_text: String,
    /// State.
    pub state: StudyState,
    /// pid of the orch process driving it, if any.
    pub driver_pid: Option<i64>,
    /// Start time of that process (clock ticks since boot), to tell pid reuse apart.
    pub driver_started: Option<i64>,
    /// Creation time, Unix seconds.
    pub created_at: f64,
    /// Last change, Unix seconds.
    pub updated_at: f64,
}

impl StudyRow {
    /// The state.
    pub fn state(&self) -> StudyState {
        self.state
    }
}

impl<'r> sqlx::FromRow<'r, SqliteRow> for StudyRow {
    fn from_row(row: &'r SqliteRow) -> sqlx::Result<Self> {
        let id = row.try_get("id")?;
        Ok(StudyRow {
            id,
            name: row.try_get("name")?,
            solver: row.try_get("solver")?,
            file_path: row.try_get("file_path")?,
            file_text: row.try_get("file_text")?,
            file_sha256: row.try_get("file_sha256")?,
            template_name: row.try_get("template_name")?,
            template_text: row.try_get("template_text")?,
            state: state_of(row, "studies", id)?,
            driver_pid: row.try_get("driver_pid")?,
            driver_started: row.try_get("driver_started")?,
            created_at: row.try_get("created_at")?,
            updated_at: row.try_get("updated_at")?,
        })
    }
}

/// A row of `jobs`.
#[derive(Debug, Clone, PartialEq)]
pub struct JobRow {
    /// Id.
    pub id: i64,
    /// Study id.
    pub study_id: i64,
    /// Design point id.
    pub point_id: i64,
    /// Replicate number from 0.
    pub replicate: i64,
    /// Name within the study, `p<point>r<replicate>`.
    pub name: String,
    /// Solver seed.
    pub seed: i64,
    /// State.
    pub state: JobState,
    /// Attempts started.
    pub attempts: i64,
    /// The executor's handle of the current attempt (local: `pid:start-ticks`;
    /// Slurm: `slurm:<job id>`).
    pub executor_handle: Option<String>,
    /// Run directory.
    pub run_dir: String,
    /// Start of the current attempt, Unix seconds.
    pub started_at: Option<f64>,
    /// End of the last attempt, Unix seconds.
    pub finished_at: Option<f64>,
    /// Exit code of the last attempt.
    pub exit_code: Option<i64>,
    /// Why the job failed or was put back.
    pub error: Option<String>,
    /// What a batch scheduler last said about the current attempt ("PENDING
    /// (Priority)", "RUNNING on n1"); none for local jobs.
    pub scheduler_state: Option<String>,
    /// A design job, or a stage job and its kind (`jobs.stage`: [`DESIGN_STAGE`] or the
    /// kind), decoded when the row is read.
    pub kind: JobKind,
    /// The job this one waits for and reads its inputs from (stages).
    pub after_job_id: Option<i64>,
    /// The run's identity ([`orch_study::identity`]), once rendered; none for jobs of
    /// earlier versions.
    pub identity: Option<String>,
    /// `study/job` of the run this job reused instead of running, if it did.
    pub reused_from: Option<String>,
}

pub use orch_study::plan::{JobKind, PointRole, DESIGN_STAGE};

impl JobRow {
    /// The kind of stage this job is, or `None` for a design job.
    pub fn stage_kind(&self) -> Option<&'static str> {
        self.kind.stage()
    }

    /// The state.
    pub fn state(&self) -> JobState {
        self.state
    }
}

impl<'r> sqlx::FromRow<'r, SqliteRow> for JobRow {
    fn from_row(row: &'r SqliteRow) -> sqlx::Result<Self> {
        let id = row.try_get("id")?;
        Ok(JobRow {
            id,
            study_id: row.try_get("study_id")?,
            point_id: row.try_get("point_id")?,
            replicate: row.try_get("replicate")?,
            name: row.try_get("name")?,
            seed: row.try_get("seed")?,
            state: state_of(row, "jobs", id)?,
            attempts: row.try_get("attempts")?,
            executor_handle: row.try_get("executor_handle")?,
            run_dir: row.try_get("run_dir")?,
            started_at: row.try_get("started_at")?,
            finished_at: row.try_get("finished_at")?,
            exit_code: row.try_get("exit_code")?,
            error: row.try_get("error")?,
            scheduler_state: row.try_get("scheduler_state")?,
            kind: kind_of(row, id)?,
            after_job_id: row.try_get("after_job_id")?,
            identity: row.try_get("identity")?,
            reused_from: row.try_get("reused_from")?,
        })
    }
}

/// What the analysis needs of a job to tie it to its design point and its chain: the
/// fields a run keeps. [`JobRow`] and the lean [`JobLinkRow`] both have them, so the
/// same code links the jobs a status view read whole and those a round analysis read
/// lean.
pub trait JobLink {
    /// Id.
    fn id(&self) -> i64;
    /// Design point id.
    fn point_id(&self) -> i64;
    /// Name within the study.
    fn name(&self) -> &str;
    /// State.
    fn state(&self) -> JobState;
    /// A design job, or the kind of the stage chained after [`JobLink::after_job_id`].
    fn kind(&self) -> JobKind;
    /// The job this one follows in its chain.
    fn after_job_id(&self) -> Option<i64>;
    /// The run's identity: jobs that share one are one observation.
    fn identity(&self) -> Option<&str>;
}

/// Implements [`JobLink`] for a row type whose fields have the trait's names.
macro_rules! job_link_from_fields {
    ($row:ty) => {
        impl JobLink for $row {
            fn id(&self) -> i64 {
                self.id
            }
            fn point_id(&self) -> i64 {
                self.point_id
            }
            fn name(&self) -> &str {
                &self.name
            }
            fn state(&self) -> JobState {
                self.state
            }
            fn kind(&self) -> JobKind {
                self.kind
            }
            fn after_job_id(&self) -> Option<i64> {
                self.after_job_id
            }
            fn identity(&self) -> Option<&str> {
                self.identity.as_deref()
            }
        }
    };
}

job_link_from_fields!(JobRow);
job_link_from_fields!(JobLinkRow);

/// A lean read of a row of `jobs`: only its [`JobLink`] fields, without the run
/// directory, executor handle, times and error text, so that an analysis of a
/// 10^4-job study holds a fraction of the whole rows.
#[derive(Debug, Clone, PartialEq)]
pub struct JobLinkRow {
    /// Id.
    pub id: i64,
    /// Design point id.
    pub point_id: i64,
    /// Name within the study.
    pub name: Box<str>,
    /// State.
    pub state: JobState,
    /// A design job, or a stage's and its kind.
    pub kind: JobKind,
    /// The job this one follows.
    pub after_job_id: Option<i64>,
    /// The run's identity.
    pub identity: Option<Box<str>>,
}

impl JobLinkRow {
    /// The columns a [`JobLinkRow`] is read from, for a `SELECT`.
    pub const COLUMNS: &'static str = "id, point_id, name, state, stage, after_job_id, identity";
}

impl<'r> sqlx::FromRow<'r, SqliteRow> for JobLinkRow {
    fn from_row(row: &'r SqliteRow) -> sqlx::Result<Self> {
        let id = row.try_get("id")?;
        Ok(JobLinkRow {
            id,
            point_id: row.try_get("point_id")?,
            name: row.try_get::<String, _>("name")?.into_boxed_str(),
            state: state_of(row, "jobs", id)?,
            kind: kind_of(row, id)?,
            after_job_id: row.try_get("after_job_id")?,
            identity: row
                .try_get::<Option<String>, _>("identity")?
                .map(String::into_boxed_str),
        })
    }
}

/// A factor of a study.
#[derive(Debug, Clone, PartialEq, sqlx::FromRow)]
pub struct FactorRow {
    /// Parameter name.
    pub name: String,
    /// Lower bound.
    pub min: f64,
    /// Upper bound.
    pub max: f64,
    /// Unit.
    pub unit: String,
    /// A text factor's values as a JSON array (NULL, `None`, for a numeric factor).
    #[sqlx(default)]
    pub levels: Option<String>,
}

impl FactorRow {
    /// A text factor's values in the study's order; empty for a numeric factor.
    pub fn levels(&self) -> Vec<String> {
        self.levels
            .as_deref()
            .and_then(|json| serde_json::from_str(json).ok())
            .unwrap_or_default()
    }

    /// The text of level index `natural` of a text factor; `None` for a numeric one.
    pub fn level_text(&self, natural: f64) -> Option<String> {
        let index = natural.round();
        let levels = self.levels();
        (index >= 0.0)
            .then(|| levels.get(index as usize).cloned())
            .flatten()
    }

    /// A value of this factor as people read it: the level's text for a text factor,
    /// else `number` (the caller's formatting of `natural`).
    pub fn show(&self, natural: f64, number: impl FnOnce(f64) -> String) -> String {
        match self.level_text(natural) {
            Some(text) => text,
            None => number(natural),
        }
    }
}

/// A design point with its values in factor order.
#[derive(Debug, Clone, PartialEq)]
pub struct PointRow {
    /// Id.
    pub id: i64,
    /// Round of the study (0 for the initial design).
    pub round: i64,
    /// Index within the round.
    pub idx: i64,
    /// Fitted or held out, decoded from `points.purpose`.
    pub purpose: PointRole,
    /// Fidelity level (0 the cheapest; 0 in a study without levels).
    pub fidelity: u32,
    /// Coded values.
    pub coded: Vec<f64>,
    /// Natural values.
    pub natural: Vec<f64>,
}

/// One job's response values, in name order: a short list rather than a map, because
/// a map's first node has room for eleven entries and a study of 10^4 jobs keeps the
/// one or two values its analysis fits for every job at once.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ResponseValues(Vec<(String, f64)>);

impl ResponseValues {
    /// The value of the response `name`, if the job has it.
    pub fn get(&self, name: &str) -> Option<f64> {
        self.0
            .binary_search_by(|(n, _)| n.as_str().cmp(name))
            .ok()
            .map(|k| self.0[k].1)
    }

    /// The names and values, in name order.
    pub fn iter(&self) -> impl Iterator<Item = (&str, f64)> {
        self.0.iter().map(|(n, v)| (n.as_str(), *v))
    }

    /// Whether the job has no value.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// The values as a map by name.
    pub fn into_map(self) -> std::collections::BTreeMap<String, f64> {
        self.0.into_iter().collect()
    }
}

impl FromIterator<(String, f64)> for ResponseValues {
    /// Sorted by name; of a name given twice the last value is kept, as a map would.
    fn from_iter<I: IntoIterator<Item = (String, f64)>>(values: I) -> Self {
        let mut values: Vec<(String, f64)> = values.into_iter().collect();
        values.reverse();
        values.sort_by(|a, b| a.0.cmp(&b.0));
        values.dedup_by(|later, kept| later.0 == kept.0);
        values.shrink_to_fit();
        Self(values)
    }
}
