//! Executors launch rendered jobs and report on them; the driver decides what to do.
//!
//! An executor is asked three things, in the shape batch schedulers impose: *launch*
//! this job and give me a handle; *poll* these handles; *terminate* this one. Handles
//! are strings the store keeps, so a new `orch` process can poll a job that an earlier,
//! killed one launched. What an attempt ended with is written by the job itself into
//! its run directory (`exit_status`), so the outcome does not depend on `orch` having
//! watched it.

pub mod local;
pub mod process;
pub mod slurm;

use std::path::{Path, PathBuf};
use std::time::Duration;

use orch_adapters::CommandSpec;

pub use local::LocalExecutor;
pub use slurm::{SlurmExecutor, SlurmSettings};

/// File in the run directory where a job's wrapper writes the solver's exit status.
pub const EXIT_STATUS_FILE: &str = "exit_status";
/// Solver standard output, in the run directory.
pub const STDOUT_FILE: &str = "stdout.txt";
/// Solver standard error, in the run directory.
pub const STDERR_FILE: &str = "stderr.txt";
/// One line per attempt start and end, kept across attempts, in the run directory.
pub const ATTEMPTS_LOG: &str = "orch-attempts.log";
/// A solver's restart list in the run directory: what it needs to continue where a
/// stopped attempt left off (its restart file, the outputs written so far), one path
/// relative to the run directory a line. While it exists a new attempt of the job
/// keeps those paths and the solver continues instead of starting over; the solver
/// removes it when its run ends. `orch-dem` writes one with its first restart file.
pub const RESTART_LIST: &str = "orch-restart";

/// Shell that sets `$line_buffered` to `stdbuf -oL -eL` where coreutils' `stdbuf` is
/// installed: a job's command runs behind it, so a C or MPI solver's stdout reaches
/// `stdout.txt` line by line, and its `ERROR:` line is written before an `MPI_Abort`
/// kills it (with a full buffer the line was lost, and the job's only reason was Open
/// MPI's abort text).
pub const LINE_BUFFERED: &str =
    "line_buffered=; command -v stdbuf >/dev/null 2>&1 && line_buffered='stdbuf -oL -eL'";

/// Launches jobs and reports on them, in the shape batch schedulers impose (after
/// HyperQueue's `QueueHandler`): launch one job, poll many at once, terminate some.
/// The driver decides what the answers mean for the study.
///
/// orch drives a study on one task, so the futures need not be `Send`.
#[allow(async_fn_in_trait)]
pub trait Executor {
    /// Starts a job (local) or hands it to the scheduler (Slurm).
    async fn launch(&mut self, spec: &LaunchSpec) -> Result<Launched, LaunchError>;

    /// Starts or submits `specs`, all of one study; one answer per spec, in order. By
    /// default one [`Executor::launch`] each ([`launch_each`]); Slurm submits them as
    /// job arrays.
    async fn launch_many(&mut self, specs: &[LaunchSpec]) -> Vec<Result<Launched, LaunchError>> {
        launch_each(self, specs).await
    }

    /// Where each of `jobs` stands, in the same order; one query for all of them. An
    /// error means the executor could not be asked (e.g. slurmctld is down): nothing
    /// is known, nothing should change.
    async fn poll(&mut self, jobs: &[Watched<'_>]) -> Result<Vec<Report>, PollError>;

    /// Stops the jobs of `handles` (local: SIGTERM, SIGKILL after a grace period;
    /// Slurm: one `scancel`).
    async fn terminate(&mut self, handles: &[&str]);

    /// Deals with jobs that a stopped `orch` launched but did not record, all of one
    /// study: a local process is killed (it will run again), a Slurm job is found by
    /// name and re-attached (so nothing is submitted twice; one `squeue` for all of
    /// them). One answer per job, in order.
    async fn recover_unrecorded(&mut self, jobs: &[Unrecorded<'_>]) -> Vec<Recovered>;

    /// Housekeeping between polls (reaps children, escalates terminations); returns the
    /// number of jobs still being terminated.
    fn tidy(&mut self) -> usize;

    /// After [`Executor::terminate`]: tidies until no job is being terminated any more,
    /// or for at most the local grace before SIGKILL ([`local::TERMINATION_GRACE`]) and
    /// 2 s more for the killed processes to be reaped.
    async fn wait_for_terminations(&mut self) {
        let deadline =
            std::time::Instant::now() + local::TERMINATION_GRACE + Duration::from_secs(2);
        while self.tidy() > 0 && std::time::Instant::now() < deadline {
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
    }

    /// True once nothing of the job of `handle` runs any more, so that its run
    /// directory can be used by the next attempt.
    fn is_gone(&self, handle: &str) -> bool;

    /// How often the driver should poll.
    fn poll_interval(&self) -> Duration;

    /// True for a batch scheduler: jobs outlive `orch` (Ctrl-C leaves them running and
    /// `orch resume` re-attaches) and the scheduler enforces time limits itself.
    fn is_batch(&self) -> bool;

    /// Commands run against the scheduler so far (`"12 sbatch, 40 squeue"`), if any.
    fn calls(&self) -> Option<String> {
        None
    }
}

/// What to launch.
#[derive(Debug, Clone)]
pub struct LaunchSpec {
    /// `study/job`, unique within a project; names the job on a scheduler.
    pub name: String,
    /// The run directory, also the working directory.
    pub run_dir: PathBuf,
    /// The command the adapter describes.
    pub command: CommandSpec,
}

/// [`Executor::launch`] of each of `specs` in turn, one answer each, in order: what
/// [`Executor::launch_many`] does unless an executor can do better.
pub async fn launch_each<E: Executor + ?Sized>(
    executor: &mut E,
    specs: &[LaunchSpec],
) -> Vec<Result<Launched, LaunchError>> {
    let mut answers = Vec::with_capacity(specs.len());
    for spec in specs {
        answers.push(executor.launch(spec).await);
    }
    answers
}

/// A job a stopped `orch` may have launched without recording it.
#[derive(Debug, Clone, Copy)]
pub struct Unrecorded<'a> {
    /// `study/job`, as in [`LaunchSpec::name`].
    pub spec_name: &'a str,
    /// Its run directory.
    pub run_dir: &'a Path,
}

/// A launched job.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Launched {
    /// What the store keeps to find the job again (`pid:ticks`, `slurm:<id>`).
    pub handle: String,
    /// True when it waits in a scheduler's queue; false when it already runs.
    pub queued: bool,
}

/// A job to poll.
#[derive(Debug, Clone, Copy)]
pub struct Watched<'a> {
    /// Its handle.
    pub handle: &'a str,
    /// Its run directory, where it records its exit status.
    pub run_dir: &'a Path,
}

/// What a poll found about one job.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Report {
    /// Where it stands.
    pub status: JobStatus,
    /// What a batch scheduler says about it (`PENDING (Priority)`, `RUNNING on n1`,
    /// `TIMEOUT (TimeLimit) on n2`); none for local jobs.
    pub scheduler_state: Option<String>,
}

/// Where a job stands.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum JobStatus {
    /// Waiting in the scheduler's queue.
    Queued,
    /// Running.
    Running,
    /// The solver ended with this exit status.
    Exited(i32),
    /// The scheduler ended the job before the solver's exit was recorded.
    Stopped {
        /// Why, as orch acts on it.
        cause: StopCause,
        /// What the scheduler said, for the user.
        reason: String,
    },
    /// The job is gone and left no exit status (killed, or the machine rebooted).
    Lost,
}

/// Why a scheduler ended a job.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StopCause {
    /// It ran past its time limit.
    TimeLimit,
    /// Someone cancelled it outside orch.
    Cancelled,
    /// Its node failed or it was preempted: not the job's fault, worth another attempt.
    NodeLost,
    /// It used more memory than it asked for.
    OutOfMemory,
    /// Ended in a way orch cannot attribute (e.g. no exit status was recorded).
    Other,
}

/// What [`Executor::recover_unrecorded`] did.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Recovered {
    /// Found the job still known to the scheduler: this is its handle.
    Attached(String),
    /// Killed a process it left behind (this pid).
    Killed(i64),
    /// Nothing of it was found.
    Nothing,
}

/// Why a launch failed.
#[derive(Debug, thiserror::Error)]
#[error("cannot start `{program}` in {}: {source}", run_dir.display())]
pub struct LaunchError {
    /// The program.
    pub program: String,
    /// The run directory.
    pub run_dir: PathBuf,
    /// The cause.
    #[source]
    pub source: std::io::Error,
}

/// Why the executor could not be asked about its jobs.
#[derive(Debug, Clone, thiserror::Error)]
#[error("cannot ask `{command}` about the jobs: {message}")]
pub struct PollError {
    /// The command that failed.
    pub command: String,
    /// What it said.
    pub message: String,
}

/// Reads the exit status a job's wrapper wrote, if it did.
pub fn read_exit_status(run_dir: &Path) -> Option<i32> {
    std::fs::read_to_string(run_dir.join(EXIT_STATUS_FILE))
        .ok()?
        .trim()
        .parse()
        .ok()
}
