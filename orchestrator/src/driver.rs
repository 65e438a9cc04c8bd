//! The driver: runs a study's jobs to completion through the local executor.
//!
//! One loop, ticking every [`TICK`], is the only writer of job states while it runs:
//!
//! 1. stop if the study was cancelled (by `orch cancel` from another process) or the
//!    user pressed Ctrl-C / sent SIGTERM (running jobs go back to pending, attempt
//!    refunded, and the study is `interrupted`);
//! 2. poll every running job: a finished one is parsed and its responses stored, a
//!    failed one is retried within its budget or marked failed with the reason, a job
//!    past its time limit is terminated, and a job whose process vanished without an
//!    exit status goes back to pending;
//! 3. render and launch pending jobs while fewer than `max_parallel` run.
//!
//! The store is the truth: after `kill -9` of `orch`, a new driver finds running jobs
//! by their handles, follows them to the end and collects their results; jobs caught
//! between render and launch are rendered again.

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use orch_adapters::Observations;
use orch_granular::responses::{cumulative_mass_series, mass_flow_series};
use orch_granular::{DischargeResponses, ResponseOptions};
use tokio::signal::unix::{signal, SignalKind};

use crate::executor::process::ProcessHandle;
use crate::executor::{
    JobStatus, LaunchSpec, LocalExecutor, ATTEMPTS_LOG, STDERR_FILE, STDOUT_FILE,
};
use crate::store::{now_s, JobResults, JobRow, JobState, PointRow, Store, StoreError, StudyState};
use crate::study::Study;

/// How often the driver looks at its jobs.
pub const TICK: Duration = Duration::from_millis(100);
/// Width of the bins of the stored mass-flow-rate series, s.
pub const MASS_FLOW_BIN_S: f64 = 0.02;

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

/// Runs `study` (stored as `study_id`) until every job is final, or it is stopped.
pub async fn drive(store: &Store, study_id: i64, study: &Study) -> Result<Summary, DriverError> {
    let mut driver = Driver {
        store,
        study,
        study_id,
        executor: LocalExecutor::new(),
        points: store
            .points(study_id)
            .await?
            .into_iter()
            .map(|p| (p.id, p))
            .collect(),
        terminating: HashMap::new(),
        started: Instant::now(),
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
        driver
            .terminating
            .retain(|_, pgid| crate::executor::process::group_exists(*pgid));
        if store.study_state(study_id).await? == StudyState::Cancelled {
            break driver.stop_for_cancel().await?;
        }
        let jobs = store.jobs(study_id).await?;
        for job in jobs.iter().filter(|j| j.state() == JobState::Running) {
            driver.poll(job).await?;
        }
        let jobs = store.jobs(study_id).await?;
        let running = jobs
            .iter()
            .filter(|j| j.state() == JobState::Running)
            .count();
        let free = study.executor.max_parallel.saturating_sub(running);
        let launchable: Vec<&JobRow> = jobs
            .iter()
            .filter(|j| j.state() == JobState::Pending && !driver.terminating.contains_key(&j.id))
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

struct Driver<'a> {
    store: &'a Store,
    study: &'a Study,
    study_id: i64,
    executor: LocalExecutor,
    points: HashMap<i64, PointRow>,
    /// Jobs whose terminated process group may still be dying: not relaunched yet.
    terminating: HashMap<i64, i64>,
    started: Instant,
}

impl Driver<'_> {
    /// Jobs caught between render and launch by a stopped `orch` are rendered again.
    async fn reconcile(&mut self) -> Result<(), DriverError> {
        for job in self.store.jobs(self.study_id).await? {
            if matches!(job.state(), JobState::Rendered | JobState::Submitted) {
                if let Some(pid) = crate::executor::local::kill_unrecorded(Path::new(&job.run_dir))
                {
                    tracing::warn!(job = %job.name, pid, "killed a solver launched by a stopped orch before its handle was recorded");
                }
                self.store
                    .requeue(
                        job.id,
                        "orch stopped before launching it; rendered again",
                        false,
                    )
                    .await?;
            }
        }
        Ok(())
    }

    fn case(&self, job: &JobRow) -> orch_adapters::Case {
        let natural = &self.points[&job.point_id].natural;
        self.study.case_at(natural, job.seed as u64)
    }

    async fn launch(&mut self, job: &JobRow) -> Result<(), DriverError> {
        let run_dir = PathBuf::from(&job.run_dir);
        let case = self.case(job);
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
        let template = &self.study.template;
        if let Err(e) = self
            .study
            .adapter
            .render(&case, &template.name, &template.text, &run_dir)
        {
            let message = format!("cannot render the case: {e}");
            self.report(job, &message);
            self.store.mark_failed(job.id, None, &message).await?;
            return Ok(());
        }
        self.store.mark_rendered(job.id).await?;
        let spec = LaunchSpec {
            run_dir: run_dir.clone(),
            command: self.study.adapter.command(&case),
        };
        match self.executor.launch(&spec) {
            Ok(handle) => {
                self.store
                    .mark_running(job.id, &handle.to_string(), now_s())
                    .await?;
                tracing::info!(job = %job.name, handle = %handle, "launched");
            }
            Err(e) => {
                self.store.mark_failed(job.id, None, &e.to_string()).await?;
            }
        }
        Ok(())
    }

    async fn poll(&mut self, job: &JobRow) -> Result<(), DriverError> {
        let Some(handle) = handle_of(job) else {
            self.store
                .requeue(job.id, "its handle was unreadable; it runs again", false)
                .await?;
            return Ok(());
        };
        let run_dir = PathBuf::from(&job.run_dir);
        match self.executor.poll(handle, &run_dir) {
            JobStatus::Running => {
                let limit = self.study.executor.time_limit;
                let elapsed = now_s() - job.started_at.unwrap_or_else(now_s);
                if let Some(limit) = limit.filter(|l| elapsed > l.as_secs_f64()) {
                    self.executor.terminate(handle);
                    self.terminating.insert(job.id, handle.pid);
                    let reason = format!(
                        "exceeded its time limit of {}; {}",
                        humantime::format_duration(limit),
                        failure_summary(
                            &run_dir,
                            &self.study.adapter.command(&self.case(job)).log_file
                        )
                    );
                    self.fail_or_retry(job, None, reason).await?;
                }
            }
            JobStatus::Exited(0) => self.collect(job, &run_dir).await?,
            JobStatus::Exited(code) => {
                let log_file = self.study.adapter.command(&self.case(job)).log_file;
                let reason = format!(
                    "the solver exited with status {code}; {}",
                    failure_summary(&run_dir, &log_file)
                );
                self.fail_or_retry(job, Some(code), reason).await?;
            }
            JobStatus::Lost => {
                let note = "its process ended without an exit status (orch or the machine stopped?); it runs again";
                self.report(job, note);
                self.store.requeue(job.id, note, false).await?;
            }
        }
        Ok(())
    }

    /// Parses a successful run and stores its results, or fails the job with why not.
    async fn collect(&mut self, job: &JobRow, run_dir: &Path) -> Result<(), DriverError> {
        let case = self.case(job);
        let adapter = self.study.adapter;
        let dir = run_dir.to_path_buf();
        let parsed = tokio::task::spawn_blocking(move || adapter.parse(&case, &dir))
            .await
            .unwrap_or_else(|e| panic!("the parser of {} panicked: {e}", adapter.name()));
        match parsed {
            Ok(observations) => {
                let results = results_of(&observations);
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

    /// Ctrl-C / SIGTERM: terminate running jobs, put them back, mark the study.
    async fn interrupt(&mut self) -> Result<Ending, DriverError> {
        eprintln!(
            "orch: interrupted; stopping running jobs (they will run again on `orch resume {}`)",
            self.study.name
        );
        for job in self.store.jobs(self.study_id).await? {
            if matches!(job.state(), JobState::Running | JobState::Rendered) {
                if let Some(handle) = handle_of(&job) {
                    self.executor.terminate(handle);
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
        for job in self.store.jobs(self.study_id).await? {
            if !job.state().is_final() {
                if let Some(handle) = handle_of(&job) {
                    self.executor.terminate(handle);
                }
                self.store
                    .mark_cancelled(job.id, "cancelled by orch cancel")
                    .await
                    .ok();
            }
        }
        self.wait_for_terminations().await;
        Ok(Ending::Cancelled)
    }

    async fn wait_for_terminations(&mut self) {
        let deadline =
            Instant::now() + crate::executor::local::TERMINATION_GRACE + Duration::from_secs(2);
        while self.executor.terminating() > 0 && Instant::now() < deadline {
            self.executor.tidy();
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
    }

    fn report(&self, job: &JobRow, message: &str) {
        eprintln!(
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

/// The local executor's handle of a job's current attempt, if it has one.
fn handle_of(job: &JobRow) -> Option<ProcessHandle> {
    job.executor_handle
        .as_deref()
        .and_then(ProcessHandle::parse)
}

/// Responses and series of a run from what its solver observed.
pub fn results_of(observations: &Observations) -> JobResults {
    let responses =
        DischargeResponses::compute(&observations.crossings, &ResponseOptions::default());
    let mut named = responses.named();
    if let Some(loop_time) = observations.solver_loop_time_s {
        named.push(("solver_loop_time".to_string(), loop_time));
        if let Some(work) = observations.particle_steps.filter(|_| loop_time > 0.0) {
            named.push(("solver_particle_steps_per_s".to_string(), work / loop_time));
        }
    }
    let mut series = vec![
        (
            "mass_flow_rate".to_string(),
            mass_flow_series(&observations.crossings, MASS_FLOW_BIN_S),
        ),
        (
            "discharged_mass".to_string(),
            cumulative_mass_series(&observations.crossings),
        ),
    ];
    series.extend(
        observations
            .series
            .iter()
            .map(|s| (s.name.clone(), s.points.clone())),
    );
    JobResults {
        responses: named,
        series,
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
    // Solvers may print bytes that are not UTF-8; a reason must survive them.
    let read = |file: &str| {
        std::fs::read(run_dir.join(file))
            .map(|bytes| String::from_utf8_lossy(&bytes).into_owned())
            .unwrap_or_default()
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
    for (name, text) in [
        (STDERR_FILE, read(STDERR_FILE)),
        (log_file, log),
        (STDOUT_FILE, stdout),
    ] {
        let tail: Vec<&str> = text.lines().filter(|l| !l.trim().is_empty()).collect();
        if !tail.is_empty() {
            let last = &tail[tail.len().saturating_sub(5)..];
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
