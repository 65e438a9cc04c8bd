//! The driver: runs a study's jobs to completion through an executor (local or Slurm).
//!
//! One loop, ticking every [`TICK`], is the only writer of job states while it runs:
//!
//! 1. stop if the study was cancelled (by `orch cancel` from another process) or the
//!    user pressed Ctrl-C / sent SIGTERM (local jobs are stopped and go back to pending,
//!    attempt refunded; Slurm jobs keep running on the cluster; the study is
//!    `interrupted`);
//! 2. every executor poll interval, ask about every submitted or running job at once:
//!    a finished one is parsed and its responses stored, a failed one is retried
//!    within its budget or marked failed with the reason, a local job past its time
//!    limit is terminated (Slurm enforces its own), and a job that vanished without an
//!    exit status is retried within its budget like a failure;
//! 3. render and launch pending jobs while fewer than `max_parallel` (local) or
//!    `max_submitted` (Slurm) are unfinished. A stage job (e.g. OpenFOAM after DEM)
//!    waits until its upstream job has succeeded and is rendered from that job's case
//!    and responses; when the upstream job failed or was cancelled, so is the stage.
//!
//! The driver knows no equipment, solver or stage by name: a design job is rendered,
//! run and read through the study's [`orch_adapters::Simulation`], a stage job through
//! its [`orch_adapters::Stage`].
//!
//! The store is the truth: after `kill -9` of `orch`, a new driver finds submitted and
//! running jobs by their handles, follows them to the end and collects their results;
//! jobs caught between render and launch are re-attached (Slurm, found by name) or
//! rendered again.

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use orch_adapters::{CommandSpec, RunResults, Upstream};
use tokio::signal::unix::{signal, SignalKind};

use crate::executor::{
    Executor, JobStatus, LaunchSpec, LocalExecutor, Recovered, SlurmExecutor, StopCause, Watched,
    ATTEMPTS_LOG, STDERR_FILE, STDOUT_FILE,
};
use crate::output::errln;
use crate::store::{now_s, JobResults, JobRow, JobState, PointRow, Store, StoreError, StudyState};
use crate::study::{ExecutorKind, StageConfig, Study};

/// How often the driver looks at its jobs.
pub const TICK: Duration = Duration::from_millis(100);
/// How often an executor that cannot be asked (slurmctld down) is reported.
const POLL_ERROR_REPORT: Duration = Duration::from_secs(60);

/// How a run of the driver ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ending {
    /// Every job reached a final state.
    Finished,
    /// Ctrl-C or SIGTERM; `orch resume` continues.
    Interrupted,
    /// `orch cancel` stopped the study.
    Cancelled,
}

/// Counts of jobs by final state at the end of a run.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Summary {
    /// How the run ended.
    pub ending: Ending,
    /// Jobs succeeded.
    pub succeeded: usize,
    /// Jobs failed.
    pub failed: usize,
    /// Jobs cancelled.
    pub cancelled: usize,
    /// Jobs not final (after an interruption).
    pub unfinished: usize,
}

/// Why the driver stopped without finishing.
#[derive(Debug, thiserror::Error)]
pub enum DriverError {
    /// The store failed.
    #[error(transparent)]
    Store(#[from] StoreError),
    /// A signal handler could not be installed.
    #[error("cannot watch for signals: {0}")]
    Signals(#[source] std::io::Error),
}

/// Runs `study` (stored as `study_id`) until every job is final, or it is stopped,
/// with the executor the study names.
pub async fn drive(store: &Store, study_id: i64, study: &Study) -> Result<Summary, DriverError> {
    match (study.executor.kind, &study.executor.slurm) {
        (ExecutorKind::Slurm, Some(settings)) => {
            drive_with(store, study_id, study, SlurmExecutor::new(settings.clone())).await
        }
        _ => drive_with(store, study_id, study, LocalExecutor::new()).await,
    }
}

/// True while a job holds a slot of `max_parallel`: handed to the executor, not final.
fn is_launched(state: JobState) -> bool {
    matches!(state, JobState::Submitted | JobState::Running)
}

async fn drive_with<E: Executor>(
    store: &Store,
    study_id: i64,
    study: &Study,
    executor: E,
) -> Result<Summary, DriverError> {
    let mut driver = Driver {
        store,
        study,
        study_id,
        executor,
        points: store
            .points(study_id)
            .await?
            .into_iter()
            .map(|p| (p.id, p))
            .collect(),
        terminating: HashMap::new(),
        started: Instant::now(),
        last_poll: None,
        last_poll_error: None,
    };
    let mut interrupt = signal(SignalKind::interrupt()).map_err(DriverError::Signals)?;
    let mut terminate = signal(SignalKind::terminate()).map_err(DriverError::Signals)?;
    driver.reconcile().await?;
    let mut ticker = tokio::time::interval(TICK);
    let ending = loop {
        tokio::select! {
            _ = interrupt.recv() => break driver.interrupt().await?,
            _ = terminate.recv() => break driver.interrupt().await?,
            _ = ticker.tick() => {}
        }
        driver.executor.tidy();
        let executor = &driver.executor;
        driver
            .terminating
            .retain(|_, handle| !executor.is_gone(handle));
        if store.study_state(study_id).await? == StudyState::Cancelled {
            break driver.stop_for_cancel().await?;
        }
        let jobs = store.jobs(study_id).await?;
        if driver.poll_due() {
            let launched: Vec<&JobRow> = jobs.iter().filter(|j| is_launched(j.state())).collect();
            driver.poll(&launched).await?;
        }
        let jobs = store.jobs(study_id).await?;
        // Stages settled here are still pending in `jobs`, so not ready: next tick sees them.
        driver.settle_orphaned_stages(&jobs).await?;
        let state_of: HashMap<i64, JobState> = jobs.iter().map(|j| (j.id, j.state())).collect();
        let ready = |job: &JobRow| {
            job.after_job_id
                .is_none_or(|after| state_of.get(&after) == Some(&JobState::Succeeded))
        };
        let launched = jobs.iter().filter(|j| is_launched(j.state())).count();
        let free = study.executor.max_parallel.saturating_sub(launched);
        let launchable: Vec<&JobRow> = jobs
            .iter()
            .filter(|j| j.state() == JobState::Pending && !driver.terminating.contains_key(&j.id))
            .filter(|j| ready(j))
            .take(free)
            .collect();
        for job in launchable {
            driver.launch(job).await?;
        }
        if jobs.iter().all(|j| j.state().is_final()) {
            break Ending::Finished;
        }
    };
    // Jobs killed for their time limit must be gone before orch reports and exits.
    driver.wait_for_terminations().await;
    if let Some(calls) = driver.executor.calls() {
        tracing::info!(
            "{calls} calls in {:.1} s",
            driver.started.elapsed().as_secs_f64()
        );
    }
    let jobs = store.jobs(study_id).await?;
    let count = |state: JobState| jobs.iter().filter(|j| j.state() == state).count();
    Ok(Summary {
        ending,
        succeeded: count(JobState::Succeeded),
        failed: count(JobState::Failed),
        cancelled: count(JobState::Cancelled),
        unfinished: jobs.iter().filter(|j| !j.state().is_final()).count(),
    })
}

struct Driver<'a, E> {
    store: &'a Store,
    study: &'a Study,
    study_id: i64,
    executor: E,
    points: HashMap<i64, PointRow>,
    /// Jobs whose terminated attempt may still be dying (by handle): not relaunched yet,
    /// so two attempts never share a run directory.
    terminating: HashMap<i64, String>,
    started: Instant,
    last_poll: Option<Instant>,
    last_poll_error: Option<Instant>,
}

impl<E: Executor> Driver<'_, E> {
    /// Jobs caught between render and launch by a stopped `orch`: re-attached when the
    /// executor still knows them (Slurm), else rendered again.
    async fn reconcile(&mut self) -> Result<(), DriverError> {
        for job in self.store.jobs(self.study_id).await? {
            // Submitted and running jobs always have a handle: they are polled.
            if job.state() != JobState::Rendered {
                continue;
            }
            match self
                .executor
                .recover_unrecorded(&self.spec_name(&job), Path::new(&job.run_dir))
                .await
            {
                Recovered::Attached(handle) => {
                    tracing::warn!(job = %job.name, %handle, "re-attached to a job a stopped orch submitted before recording it");
                    self.store.mark_submitted(job.id, &handle).await?;
                    continue;
                }
                Recovered::Killed(pid) => {
                    tracing::warn!(job = %job.name, pid, "killed a solver launched by a stopped orch before its handle was recorded");
                }
                _ => {}
            }
            self.store
                .requeue(
                    job.id,
                    "orch stopped before launching it; rendered again",
                    false,
                )
                .await?;
        }
        Ok(())
    }

    /// `study/job`: the job's name for executors.
    fn spec_name(&self, job: &JobRow) -> String {
        format!("{}/{}", self.study.name, job.name)
    }

    fn case(&self, job: &JobRow) -> orch_adapters::Case {
        let natural = &self.points[&job.point_id].natural;
        self.study.case_at(natural, job.seed as u64)
    }

    fn poll_due(&mut self) -> bool {
        let due = self
            .last_poll
            .is_none_or(|last| last.elapsed() >= self.executor.poll_interval());
        if due {
            self.last_poll = Some(Instant::now());
        }
        due
    }

    /// Stage jobs whose upstream job failed or was cancelled follow it: nothing can
    /// feed them. (`orch resume` reopens both.)
    async fn settle_orphaned_stages(&mut self, jobs: &[JobRow]) -> Result<(), DriverError> {
        let by_id: HashMap<i64, &JobRow> = jobs.iter().map(|j| (j.id, j)).collect();
        for job in jobs.iter().filter(|j| j.state() == JobState::Pending) {
            let Some(upstream) = job.after_job_id.and_then(|id| by_id.get(&id)) else {
                continue;
            };
            let kind = job.stage_kind().unwrap_or("stage");
            match upstream.state() {
                JobState::Failed => {
                    let reason = format!(
                        "its upstream job {} failed, so the {kind} stage has no inputs",
                        upstream.name
                    );
                    self.report(job, &format!("failed: {reason}"));
                    self.store.mark_failed(job.id, None, &reason).await?;
                }
                JobState::Cancelled => {
                    let note = format!("its upstream job {} was cancelled", upstream.name);
                    self.store.mark_cancelled(job.id, &note).await?;
                }
                _ => {}
            }
        }
        Ok(())
    }

    /// The study's stage of a stage job, or why it has none.
    fn stage_of(&self, kind: &str) -> Result<&StageConfig, String> {
        self.study.stage(kind).ok_or_else(|| {
            format!("the study file no longer has the `{kind}` stage this job belongs to")
        })
    }

    /// Renders a job into its run directory and returns its command, or why not.
    async fn render(&self, job: &JobRow, run_dir: &Path) -> Result<CommandSpec, String> {
        let Some(kind) = job.stage_kind() else {
            let simulation = &self.study.simulation;
            simulation
                .render(&self.case(job), run_dir)
                .map_err(|e| format!("cannot render the case: {e}"))?;
            return Ok(simulation.command());
        };
        let stage = self.stage_of(kind)?;
        let upstream = match job.after_job_id {
            Some(id) => self.store.job(id).await.map_err(|e| e.to_string())?,
            None => return Err(format!("a {kind} stage without its upstream job")),
        };
        let responses = self
            .store
            .job_responses(upstream.id)
            .await
            .map_err(|e| e.to_string())?;
        let upstream = Upstream {
            case: &self.case(&upstream),
            responses: &responses,
        };
        stage
            .stage
            .render(&stage.case(), &upstream, run_dir)
            .map_err(|e| e.to_string())
    }

    async fn launch(&mut self, job: &JobRow) -> Result<(), DriverError> {
        let run_dir = PathBuf::from(&job.run_dir);
        if let Err(e) = clean_run_dir(&run_dir) {
            self.store
                .mark_failed(
                    job.id,
                    None,
                    &format!(
                        "cannot prepare the run directory {}: {e}",
                        run_dir.display()
                    ),
                )
                .await?;
            return Ok(());
        }
        let command = match self.render(job, &run_dir).await {
            Ok(command) => command,
            Err(message) => {
                self.report(job, &message);
                self.store.mark_failed(job.id, None, &message).await?;
                return Ok(());
            }
        };
        self.store.mark_rendered(job.id).await?;
        let spec = LaunchSpec {
            name: self.spec_name(job),
            run_dir: run_dir.clone(),
            command,
        };
        match self.executor.launch(&spec).await {
            Ok(launched) if launched.queued => {
                self.store.mark_submitted(job.id, &launched.handle).await?;
                tracing::info!(job = %job.name, handle = %launched.handle, "submitted");
            }
            Ok(launched) => {
                self.store
                    .mark_running(job.id, &launched.handle, now_s())
                    .await?;
                tracing::info!(job = %job.name, handle = %launched.handle, "launched");
            }
            Err(e) => {
                let message = e.to_string();
                self.report(job, &message);
                self.store.mark_failed(job.id, None, &message).await?;
            }
        }
        Ok(())
    }

    /// Asks the executor about every launched job at once and acts on the answers.
    async fn poll(&mut self, jobs: &[&JobRow]) -> Result<(), DriverError> {
        let watched: Vec<Watched> = jobs
            .iter()
            .map(|job| Watched {
                handle: job.executor_handle.as_deref().unwrap_or(""),
                run_dir: Path::new(&job.run_dir),
            })
            .collect();
        let reports = match self.executor.poll(&watched).await {
            Ok(reports) => reports,
            Err(e) => {
                // Nothing is known; nothing changes. Say so now and then.
                if self
                    .last_poll_error
                    .is_none_or(|last| last.elapsed() >= POLL_ERROR_REPORT)
                {
                    errln!("orch: {e}; jobs are left as they are and asked about again");
                    self.last_poll_error = Some(Instant::now());
                }
                return Ok(());
            }
        };
        for (job, report) in jobs.iter().zip(reports) {
            if let Some(state) = &report.scheduler_state {
                self.note_scheduler_state(job, state).await?;
            }
            self.act_on(job, report.status).await?;
        }
        Ok(())
    }

    async fn act_on(&mut self, job: &JobRow, status: JobStatus) -> Result<(), DriverError> {
        let run_dir = PathBuf::from(&job.run_dir);
        match status {
            JobStatus::Queued => {}
            JobStatus::Running if job.state() == JobState::Submitted => {
                self.store.mark_started(job.id, now_s()).await?;
            }
            JobStatus::Running => self.enforce_time_limit(job, &run_dir).await?,
            JobStatus::Exited(0) => self.collect(job, &run_dir).await?,
            JobStatus::Exited(code) => {
                let reason = format!(
                    "the solver exited with status {code}; {}",
                    failure_summary(&run_dir, &self.log_file(job))
                );
                self.fail_or_retry(job, Some(code), reason).await?;
            }
            JobStatus::Stopped { cause, reason } => {
                if cause == StopCause::Cancelled {
                    let note = format!("{reason}; `orch resume {}` runs it again", self.study.name);
                    self.report(job, &note);
                    self.store.mark_cancelled(job.id, &note).await?;
                } else {
                    let reason = format!(
                        "{reason}; {}",
                        failure_summary(&run_dir, &self.log_file(job))
                    );
                    self.fail_or_retry(job, None, reason).await?;
                }
            }
            JobStatus::Lost => {
                // A lost attempt spends the retry budget like any failure, or a solver
                // that loses its own exit status would run again for ever.
                let reason = "it ended without an exit status (orch, the machine or the scheduler stopped it, or its run directory was removed)".to_string();
                self.fail_or_retry(job, None, reason).await?;
            }
        }
        Ok(())
    }

    /// Stores what the scheduler says about a job when it changed.
    async fn note_scheduler_state(&self, job: &JobRow, state: &str) -> Result<(), DriverError> {
        if job.scheduler_state.as_deref() != Some(state) {
            self.store.set_scheduler_state(job.id, state).await?;
        }
        Ok(())
    }

    /// A local job past its time limit is terminated and fails (or runs again); a batch
    /// scheduler enforces the limit itself.
    async fn enforce_time_limit(
        &mut self,
        job: &JobRow,
        run_dir: &Path,
    ) -> Result<(), DriverError> {
        let Some(limit) = self.study.executor.time_limit else {
            return Ok(());
        };
        let elapsed = now_s() - job.started_at.unwrap_or_else(now_s);
        if self.executor.is_batch() || elapsed <= limit.as_secs_f64() {
            return Ok(());
        }
        if let Some(handle) = job.executor_handle.as_deref() {
            self.executor.terminate(&[handle]).await;
            self.terminating.insert(job.id, handle.to_string());
        }
        let reason = format!(
            "exceeded its time limit of {}; {}",
            humantime::format_duration(limit),
            failure_summary(run_dir, &self.log_file(job))
        );
        self.fail_or_retry(job, None, reason).await
    }

    fn log_file(&self, job: &JobRow) -> String {
        match job.stage_kind().and_then(|kind| self.study.stage(kind)) {
            Some(stage) => stage.stage.log_file().to_string(),
            None => self.study.simulation.command().log_file,
        }
    }

    /// Parses a successful run and stores its results, or fails the job with why not.
    async fn collect(&mut self, job: &JobRow, run_dir: &Path) -> Result<(), DriverError> {
        let case = self.case(job);
        let simulation = self.study.simulation.clone();
        let stage = match job.stage_kind() {
            Some(kind) => match self.stage_of(kind) {
                Ok(config) => Some(config.stage),
                Err(reason) => return self.fail_or_retry(job, Some(0), reason).await,
            },
            None => None,
        };
        let dir = run_dir.to_path_buf();
        let parsed = tokio::task::spawn_blocking(move || match stage {
            Some(stage) => stage.results(&dir),
            None => simulation.results(&case, &dir),
        })
        .await
        .unwrap_or_else(|e| panic!("the parser of {} panicked: {e}", job.name));
        match parsed {
            Ok(results) => {
                let results = job_results(results);
                self.report_success(job, &results);
                self.store.mark_succeeded(job.id, 0, &results).await?;
            }
            Err(e) => {
                let reason = format!("the solver exited 0 but its output cannot be read: {e}");
                self.fail_or_retry(job, Some(0), reason).await?;
            }
        }
        Ok(())
    }

    async fn fail_or_retry(
        &mut self,
        job: &JobRow,
        exit_code: Option<i32>,
        reason: String,
    ) -> Result<(), DriverError> {
        let budget = 1 + self.study.executor.retries as i64;
        if job.attempts < budget {
            let note = format!(
                "attempt {} of {budget} failed: {reason}; retrying",
                job.attempts
            );
            self.report(job, &note);
            self.store.requeue(job.id, &note, false).await?;
        } else {
            self.report(job, &format!("failed: {reason}"));
            self.store.mark_failed(job.id, exit_code, &reason).await?;
        }
        Ok(())
    }

    /// Ctrl-C / SIGTERM: local jobs are stopped and put back; jobs on a batch
    /// scheduler keep running there and `orch resume` re-attaches to them.
    async fn interrupt(&mut self) -> Result<Ending, DriverError> {
        let jobs = self.store.jobs(self.study_id).await?;
        if self.executor.is_batch() {
            let left = jobs.iter().filter(|j| is_launched(j.state())).count();
            errln!(
                "orch: interrupted; {left} submitted jobs keep running on the cluster; `orch resume {}` re-attaches to them",
                self.study.name
            );
            for job in jobs.iter().filter(|j| j.state() == JobState::Rendered) {
                self.store
                    .requeue(job.id, "interrupted by the user", true)
                    .await?;
            }
            return Ok(Ending::Interrupted);
        }
        errln!(
            "orch: interrupted; stopping running jobs (they will run again on `orch resume {}`)",
            self.study.name
        );
        for job in jobs {
            if matches!(job.state(), JobState::Running | JobState::Rendered) {
                if let Some(handle) = job.executor_handle.as_deref() {
                    self.executor.terminate(&[handle]).await;
                }
                self.store
                    .requeue(job.id, "interrupted by the user", true)
                    .await?;
            }
        }
        self.wait_for_terminations().await;
        Ok(Ending::Interrupted)
    }

    /// The study was cancelled elsewhere: make sure nothing of ours still runs.
    async fn stop_for_cancel(&mut self) -> Result<Ending, DriverError> {
        let jobs = self.store.jobs(self.study_id).await?;
        let handles: Vec<&str> = jobs
            .iter()
            .filter(|j| !j.state().is_final())
            .filter_map(|j| j.executor_handle.as_deref())
            .collect();
        self.executor.terminate(&handles).await;
        for job in jobs.iter().filter(|j| !j.state().is_final()) {
            self.store
                .mark_cancelled(job.id, "cancelled by orch cancel")
                .await
                .ok();
        }
        self.wait_for_terminations().await;
        Ok(Ending::Cancelled)
    }

    async fn wait_for_terminations(&mut self) {
        let deadline =
            Instant::now() + crate::executor::local::TERMINATION_GRACE + Duration::from_secs(2);
        while self.executor.tidy() > 0 && Instant::now() < deadline {
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
    }

    fn report(&self, job: &JobRow, message: &str) {
        errln!(
            "[{:>7.1} s] {}/{}: {message}",
            self.started.elapsed().as_secs_f64(),
            self.study.name,
            job.name
        );
    }

    fn report_success(&self, job: &JobRow, results: &JobResults) {
        let shown: Vec<String> = results
            .responses
            .iter()
            .filter(|(name, _)| {
                self.study.responses.is_empty() || self.study.responses.contains(name)
            })
            .filter(|(name, _)| !name.starts_with("solver_"))
            .map(|(name, value)| format!("{name} = {value:.4}"))
            .collect();
        let took = now_s() - job.started_at.unwrap_or_else(now_s);
        self.report(
            job,
            &format!("succeeded in {took:.1} s: {}", shown.join(", ")),
        );
    }
}

/// What the store keeps of a run's results.
fn job_results(results: RunResults) -> JobResults {
    JobResults {
        responses: results.responses,
        series: results
            .series
            .into_iter()
            .map(|s| (s.name, s.points))
            .collect(),
    }
}

/// Empties a run directory for a fresh attempt, keeping the attempts log.
fn clean_run_dir(run_dir: &Path) -> std::io::Result<()> {
    std::fs::create_dir_all(run_dir)?;
    for entry in std::fs::read_dir(run_dir)? {
        let entry = entry?;
        if entry.file_name() == ATTEMPTS_LOG {
            continue;
        }
        if entry.file_type()?.is_dir() {
            std::fs::remove_dir_all(entry.path())?;
        } else {
            std::fs::remove_file(entry.path())?;
        }
    }
    Ok(())
}

/// What a user needs to see of a failed run: the solver's `ERROR` lines, or else the
/// last lines of its error output, standard output or log.
pub fn failure_summary(run_dir: &Path, log_file: &str) -> String {
    // Solvers may print gigabytes, and bytes that are not UTF-8: only a bounded head
    // and tail of each file are read, and a reason must survive them.
    let read = |file: &str| {
        crate::tail::Windows::read(&run_dir.join(file), crate::tail::WINDOW).unwrap_or_default()
    };
    let log = read(log_file);
    let stdout = read(STDOUT_FILE);
    let errors: Vec<&str> = log
        .lines()
        .chain(stdout.lines())
        .filter(|l| l.trim_start().starts_with("ERROR") || l.contains("FATAL"))
        .collect();
    if let Some(first) = errors.first() {
        return format!("it reported: {}", first.trim());
    }
    for (name, windows) in [
        (STDERR_FILE, read(STDERR_FILE)),
        (log_file, log),
        (STDOUT_FILE, stdout),
    ] {
        let last = windows.last_lines(5);
        if !last.is_empty() {
            return format!("last lines of {name}: {}", last.join(" | "));
        }
    }
    "it wrote no output".to_string()
}

/// Job counts by state for one study, for status lines.
pub fn counts(jobs: &[JobRow]) -> BTreeMap<JobState, usize> {
    let mut counts = BTreeMap::new();
    for job in jobs {
        *counts.entry(job.state()).or_insert(0) += 1;
    }
    counts
}
