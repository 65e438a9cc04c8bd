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
//! What to do about each job is decided by the pure functions of [`crate::decide`]
//! (jobs, reports, budgets and the time in; actions out); this loop reads the store
//! and the executor, calls them, and applies their actions.
//!
//! The driver knows no equipment, solver or stage by name: a design job is rendered,
//! run and read through the study's [`orch_adapters::Simulation`], a stage job through
//! its [`orch_adapters::Stage`].
//!
//! The store is the truth: after `kill -9` of `orch`, a new driver finds submitted and
//! running jobs by their handles, follows them to the end and collects their results;
//! jobs caught between render and launch are re-attached (Slurm, found by name) or
//! rendered again.

mod collect;
mod kept;

use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use orch_adapters::{CommandSpec, RunResults, Simulation, Upstream, UpstreamFiles};
use tokio::signal::unix::{signal, SignalKind};

use crate::convergence::{self, ConvergenceWatch};
use crate::decide::{self, is_launched, Action, Budgets, CancelCause, Failure};
use crate::executor::{
    Executor, LaunchSpec, LocalExecutor, Recovered, SlurmExecutor, Unrecorded, Watched,
    ATTEMPTS_LOG, STDERR_FILE, STDOUT_FILE,
};
use crate::output::errln;
use crate::progress::{Progress, RoundProgress};
use crate::store::{now_s, JobResults, JobRow, JobState, PointRow, Store, StoreError, StudyState};
use crate::study::{ExecutorKind, StageConfig, Study, STOP_FILE};

/// How often the driver looks at its jobs.
pub const TICK: Duration = Duration::from_millis(100);
/// How often the bar of a round is brought up to date (it reads every job of the
/// study).
const PROGRESS_EVERY: Duration = Duration::from_secs(1);
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
    /// Of those, jobs that reused an identical run instead of running.
    pub reused: usize,
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

async fn drive_with<E: Executor>(
    store: &Store,
    study_id: i64,
    study: &Study,
    executor: E,
) -> Result<Summary, DriverError> {
    let budgets = Budgets {
        max_parallel: study.executor.max_parallel,
        retries: study.executor.retries,
        time_limit: study.executor.time_limit,
        batch: executor.is_batch(),
        cores: study.executor.core_budget.filter(|_| !executor.is_batch()),
    };
    let mut driver = Driver {
        store,
        study,
        study_id,
        budgets,
        executor,
        points: HashMap::new(),
        terminating: HashMap::new(),
        started: Instant::now(),
        last_poll: None,
        last_poll_error: None,
        progress: Progress::on_stderr(),
        last_progress: None,
        convergence: ConvergenceWatch::default(),
        stop: stop_on_signals()?,
        uncollected: HashSet::new(),
        reused_in_tick: false,
    };
    driver.reconcile().await?;
    let mut ticker = tokio::time::interval(TICK);
    let ending = loop {
        let mut stop = driver.stop.clone();
        let stopped = tokio::select! {
            _ = stop.wait_for(|stopped| *stopped) => true,
            _ = ticker.tick() => false,
        };
        if stopped || driver.stopped() {
            break driver.interrupt().await?;
        }
        driver.executor.tidy();
        let executor = &driver.executor;
        driver
            .terminating
            .retain(|_, handle| !executor.is_gone(handle));
        if store.study_state(study_id).await? == StudyState::Cancelled {
            break driver.stop_for_cancel().await?;
        }
        if driver.poll_due() {
            let launched = store.launched_jobs(study_id).await?;
            driver.keep_points_of(&launched, false).await?;
            driver.poll(&launched.iter().collect::<Vec<_>>()).await?;
            if driver.stopped() {
                break driver.interrupt().await?;
            }
        }
        // A final job stays final while this driver holds the study, so a tick reads the
        // others and the jobs they follow, not the whole study; of the pending jobs only
        // as many as could be launched now (every launch slot, and the jobs still being
        // terminated, which are pending but skipped). What is decided about them is the
        // same, at a cost that grows with neither the finished nor the waiting jobs.
        let pending_limit = driver.budgets.max_parallel + driver.terminating.len();
        let jobs = store.unfinished_jobs(study_id, pending_limit).await?;
        driver.keep_points_of(&jobs, true).await?;
        driver.stop_converged(&jobs).await;
        let terminating: HashSet<i64> = driver.terminating.keys().copied().collect();
        let actions = decide::settle_and_launch(&jobs, &driver.budgets, &terminating, |job| {
            driver.cores_of(job)
        });
        driver
            .apply(&jobs.iter().collect::<Vec<_>>(), actions)
            .await?;
        // A reused job took no slot: the next jobs need not wait for the next tick.
        if std::mem::take(&mut driver.reused_in_tick) {
            ticker.reset_immediately();
        }
        let finished = decide::is_finished(&jobs);
        // The bar's last state is the round's end, however soon it came.
        driver.show_progress(finished).await?;
        if finished {
            break Ending::Finished;
        }
    };
    // Jobs killed for their time limit must be gone before orch reports and exits.
    driver.executor.wait_for_terminations().await;
    if let Some(calls) = driver.executor.calls() {
        tracing::info!(
            "{calls} calls in {:.1} s",
            driver.started.elapsed().as_secs_f64()
        );
    }
    let counts = store.job_counts(study_id).await?;
    let count = |state: JobState| counts.get(&state).copied().unwrap_or(0);
    Ok(Summary {
        ending,
        succeeded: count(JobState::Succeeded),
        reused: store.reused_count(study_id).await?,
        failed: count(JobState::Failed),
        cancelled: count(JobState::Cancelled),
        unfinished: counts
            .iter()
            .filter(|(state, _)| !state.is_final())
            .map(|(_, n)| n)
            .sum(),
    })
}

struct Driver<'a, E> {
    store: &'a Store,
    study: &'a Study,
    study_id: i64,
    budgets: Budgets,
    executor: E,
    /// The design points of the jobs the driver reads (those of the last tick and the
    /// last poll), not the whole study's: see [`Driver::keep_points_of`].
    points: HashMap<i64, PointRow>,
    /// Jobs whose terminated attempt may still be dying (by handle): not relaunched yet,
    /// so two attempts never share a run directory.
    terminating: HashMap<i64, String>,
    started: Instant,
    last_poll: Option<Instant>,
    last_poll_error: Option<Instant>,
    /// The bar of the round on a terminal; job lines go above it.
    progress: Progress,
    /// When the bar was last updated.
    last_progress: Option<Instant>,
    /// Running jobs' checks against the study's `stop_when:`.
    convergence: ConvergenceWatch,
    /// Turns true on Ctrl-C or SIGTERM, whatever the driver is doing.
    stop: tokio::sync::watch::Receiver<bool>,
    /// Jobs that exited 0 but whose output was not read because orch was asked to
    /// stop: left running in the store for `orch resume` to read, not run again.
    uncollected: HashSet<i64>,
    /// True when this tick recorded a job as reused instead of launching it.
    reused_in_tick: bool,
}

/// What became of a job whose run the project may already have.
enum Reuse {
    /// It was recorded (reused, or failed as the study counts that run).
    Done,
    /// No succeeded run has its identity, or the study runs everything.
    NoSource,
    /// One has, but its files could not be linked or read: the job runs after all,
    /// from a clean run directory.
    RunAgain,
}

/// What reading a finished run gave.
enum Read {
    /// Its results, as its parsers read them.
    Results(RunResults),
    /// Why its output cannot be read.
    Unreadable(String),
    /// Ctrl-C or SIGTERM came first; the job is left as it was.
    Interrupted,
}

/// A flag that turns true on the first Ctrl-C (SIGINT) or SIGTERM, set by a task of its
/// own, so that a driver busy reading a large output still stops within a tick.
pub(crate) fn stop_on_signals() -> Result<tokio::sync::watch::Receiver<bool>, DriverError> {
    let mut interrupt = signal(SignalKind::interrupt()).map_err(DriverError::Signals)?;
    let mut terminate = signal(SignalKind::terminate()).map_err(DriverError::Signals)?;
    let (set, flag) = tokio::sync::watch::channel(false);
    tokio::spawn(async move {
        tokio::select! {
            _ = interrupt.recv() => {}
            _ = terminate.recv() => {}
        }
        let _ = set.send(true);
    });
    Ok(flag)
}

impl<E: Executor> Driver<'_, E> {
    /// True once Ctrl-C or SIGTERM came.
    fn stopped(&self) -> bool {
        *self.stop.borrow()
    }

    /// Jobs caught between render and launch by a stopped `orch`: re-attached when the
    /// executor still knows them (Slurm), else rendered again.
    async fn reconcile(&mut self) -> Result<(), DriverError> {
        // Submitted and running jobs always have a handle: they are polled.
        let rendered = self
            .store
            .jobs_in_state(self.study_id, JobState::Rendered)
            .await?;
        if rendered.is_empty() {
            return Ok(());
        }
        let names: Vec<String> = rendered.iter().map(|job| self.spec_name(job)).collect();
        let unrecorded: Vec<Unrecorded> = rendered
            .iter()
            .zip(&names)
            .map(|(job, name)| Unrecorded {
                spec_name: name,
                run_dir: Path::new(&job.run_dir),
            })
            .collect();
        let recovered = self.executor.recover_unrecorded(&unrecorded).await;
        for (job, recovered) in rendered.iter().zip(recovered) {
            match recovered {
                Recovered::Attached(handle) => {
                    tracing::warn!(job = %job.name, %handle, "re-attached to a job a stopped orch submitted before recording it");
                    self.store.mark_submitted(job.id, &handle).await?;
                    continue;
                }
                Recovered::Killed(pid) => {
                    tracing::warn!(job = %job.name, pid, "killed a solver launched by a stopped orch before its handle was recorded");
                }
                Recovered::Nothing => {}
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

    /// The case of `job`'s design point with its seed, and what runs it: the point's
    /// fidelity level's simulation (the study's without levels), both from the same
    /// point, read from the store when the driver does not hold it.
    async fn case_and_simulation(
        &self,
        job: &JobRow,
    ) -> Result<(orch_adapters::Case, Arc<dyn Simulation>), StoreError> {
        let at = |point: &PointRow| {
            (
                self.study
                    .case_at_level(&point.natural, point.fidelity, job.seed as u64),
                self.study.simulation_at(point.fidelity).clone(),
            )
        };
        if let Some(point) = self.points.get(&job.point_id) {
            return Ok(at(point));
        }
        let point = self.store.points_by_id(&[job.point_id]).await?;
        let point = point.first().ok_or_else(|| StoreError::Query {
            what: "read a job's design point",
            source: sqlx::Error::RowNotFound,
        })?;
        Ok(at(point))
    }

    /// What runs `job`'s design point, for the synchronous callers (its log file, the
    /// responses it owes), which come after the driver read the job and so holds its
    /// point; level 0's should it not.
    fn simulation_of(&self, job: &JobRow) -> &Arc<dyn Simulation> {
        let level = self.points.get(&job.point_id).map_or(0, |p| p.fidelity);
        self.study.simulation_at(level)
    }

    /// Holds the design points of `jobs` (reading those it lacks in one query) and,
    /// when `forget_others`, lets go of every other: what the driver holds grows with
    /// the jobs it reads, not with the study.
    async fn keep_points_of(
        &mut self,
        jobs: &[JobRow],
        forget_others: bool,
    ) -> Result<(), StoreError> {
        if forget_others {
            let wanted: HashSet<i64> = jobs.iter().map(|j| j.point_id).collect();
            self.points.retain(|id, _| wanted.contains(id));
        }
        let mut missing: Vec<i64> = jobs
            .iter()
            .map(|j| j.point_id)
            .filter(|id| !self.points.contains_key(id))
            .collect();
        missing.sort_unstable();
        missing.dedup();
        for point in self.store.points_by_id(&missing).await? {
            self.points.insert(point.id, point);
        }
        Ok(())
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

    /// The study's stage of a stage job, or why it has none.
    fn stage_of(&self, kind: &str) -> Result<&StageConfig, String> {
        self.study.stage(kind).ok_or_else(|| {
            format!("the study file no longer has the `{kind}` stage this job belongs to")
        })
    }

    /// Cores a job uses, for the core budget: a stage's own (`cores` of OpenFOAM), else
    /// the study's per design job (a stage that runs the design again is one).
    fn cores_of(&self, job: &JobRow) -> usize {
        let stage = job.stage_kind().and_then(|kind| self.study.stage(kind));
        match stage.filter(|stage| !stage.stage.reruns_design()) {
            Some(stage) => stage.cores(),
            None => self.study.executor.cores_per_job,
        }
    }

    /// Renders a job into its run directory and returns its command, or why not.
    async fn render(&self, job: &JobRow, run_dir: &Path) -> Result<CommandSpec, String> {
        let Some(kind) = job.stage_kind() else {
            let (case, simulation) = self
                .case_and_simulation(job)
                .await
                .map_err(|e| e.to_string())?;
            simulation
                .render(&case, run_dir)
                .map_err(|e| format!("cannot render the case: {e}"))?;
            return Ok(simulation.command());
        };
        let stage = self.stage_of(kind)?;
        let upstream = self.upstream_of(job, kind).await?;
        stage
            .stage
            .render(&stage_case(stage, job), &upstream.view(), run_dir)
            .map_err(|e| e.to_string())
    }

    /// What stage job `job` (of kind `kind`) reads of the job it follows.
    async fn upstream_of(&self, job: &JobRow, kind: &str) -> Result<UpstreamRun, String> {
        let upstream = match job.after_job_id {
            Some(id) => self.store.job(id).await.map_err(|e| e.to_string())?,
            None => return Err(format!("a {kind} stage without its upstream job")),
        };
        let responses = self
            .store
            .job_responses(upstream.id)
            .await
            .map_err(|e| e.to_string())?;
        let (case, simulation) = self
            .case_and_simulation(&upstream)
            .await
            .map_err(|e| e.to_string())?;
        let stage_case = match upstream.stage_kind() {
            Some(kind) => Some(stage_case(self.stage_of(kind)?, &upstream)),
            None => None,
        };
        Ok(UpstreamRun {
            run_dir: PathBuf::from(&upstream.run_dir),
            case,
            responses,
            stage_case,
            simulation,
        })
    }

    /// Renders `jobs` and hands them to the executor in one call (on Slurm, job arrays);
    /// a job that cannot be prepared or rendered fails alone with why.
    async fn launch(&mut self, jobs: &[&JobRow]) -> Result<(), DriverError> {
        let mut ready: Vec<(&JobRow, LaunchSpec)> = Vec::with_capacity(jobs.len());
        for &job in jobs {
            let run_dir = PathBuf::from(&job.run_dir);
            // What the solver of an earlier attempt listed to continue from.
            let kept = match kept::Kept::set_aside(&run_dir) {
                Ok(kept) => kept,
                Err(e) => {
                    self.report(
                        job,
                        &format!(
                            "cannot keep its earlier attempt's restart files ({e}); it starts over"
                        ),
                    );
                    None
                }
            };
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
                continue;
            }
            let command = match self.render(job, &run_dir).await {
                Ok(command) => command,
                Err(message) => {
                    self.report(job, &message);
                    self.store.mark_failed(job.id, None, &message).await?;
                    continue;
                }
            };
            let identity = match crate::identity::of_run(&run_dir, &command, &self.conditions()) {
                Ok(identity) => identity,
                Err(e) => {
                    let message = format!(
                        "cannot read the rendered run directory {}: {e}",
                        run_dir.display()
                    );
                    self.report(job, &message);
                    self.store.mark_failed(job.id, None, &message).await?;
                    continue;
                }
            };
            match self.reuse(job, &identity).await? {
                Reuse::Done => {
                    if let Some(kept) = kept {
                        // Best effort: the job is done without them.
                        let _ = kept.discard();
                    }
                    continue;
                }
                Reuse::NoSource => {}
                Reuse::RunAgain => {
                    // The source's files were linked in: start again from a clean
                    // directory with the job's own inputs.
                    let again = clean_run_dir(&run_dir).map_err(|e| {
                        format!(
                            "cannot prepare the run directory {}: {e}",
                            run_dir.display()
                        )
                    });
                    let again = match again {
                        Ok(()) => self.render(job, &run_dir).await,
                        Err(message) => Err(message),
                    };
                    if let Err(message) = again {
                        self.report(job, &message);
                        self.store.mark_failed(job.id, None, &message).await?;
                        continue;
                    }
                }
            }
            if let Some(kept) = kept {
                match kept.put_back(&run_dir) {
                    Ok(()) => self.report(job, "continues from its earlier attempt's restart files"),
                    Err(e) => self.report(
                        job,
                        &format!("cannot put back its earlier attempt's restart files ({e}); it starts over"),
                    ),
                }
            }
            self.store.mark_rendered(job.id, &identity).await?;
            let spec = LaunchSpec {
                name: self.spec_name(job),
                run_dir,
                command,
            };
            ready.push((job, spec));
        }
        if ready.is_empty() {
            return Ok(());
        }
        let specs: Vec<LaunchSpec> = ready.iter().map(|(_, spec)| spec.clone()).collect();
        let answers = self.executor.launch_many(&specs).await;
        for ((job, _), answer) in ready.into_iter().zip(answers) {
            match answer {
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
        }
        Ok(())
    }

    /// What changes a run's result besides its files and program: the study's
    /// `stop_when:`, which ends runs early.
    fn conditions(&self) -> String {
        match &self.study.stop_when {
            Some(stop) => format!("{stop:?}"),
            None => String::new(),
        }
    }

    /// When the project already holds a succeeded run with `identity` (and the study
    /// allows reuse), records `job` as that run ([`Reuse::Done`]): the same deck is
    /// never run twice. The run's files are linked into the job's run directory and
    /// read with this study's parsers (a study that declares other responses gets
    /// them); a run whose files cannot be linked or read is run again instead
    /// ([`Reuse::RunAgain`]).
    async fn reuse(&mut self, job: &JobRow, identity: &str) -> Result<Reuse, DriverError> {
        if !self.study.reuse {
            return Ok(Reuse::NoSource);
        }
        let Some(source) = self.store.succeeded_run(identity, job.id).await? else {
            return Ok(Reuse::NoSource);
        };
        let run_dir = Path::new(&job.run_dir);
        if let Err(e) = crate::identity::link_run(&source.run_dir, run_dir) {
            self.report(
                job,
                &format!(
                    "the same run as {} but its files in {} cannot be linked ({e}); running it again",
                    source.name,
                    source.run_dir.display()
                ),
            );
            return Ok(Reuse::RunAgain);
        }
        let results = match self.read_run(job).await? {
            Read::Interrupted => return Ok(Reuse::Done),
            Read::Unreadable(reason) => {
                self.report(
                    job,
                    &format!(
                        "the same run as {}, but its output cannot be read now ({reason}; `keep:` may have pruned it); running it again",
                        source.name
                    ),
                );
                return Ok(Reuse::RunAgain);
            }
            Read::Results(results) => results,
        };
        self.reused_in_tick = true;
        let counted = self
            .as_the_study_counts(job, results, Some(&source.name))
            .await?;
        let Some(results) = counted else {
            return Ok(Reuse::Done);
        };
        self.store
            .mark_reused(job.id, identity, &source, &results)
            .await?;
        self.report(
            job,
            &format!(
                "reused {} (the same run, not run again): {}",
                source.name,
                self.shown(&results)
            ),
        );
        self.after_success(job, &results).await?;
        Ok(Reuse::Done)
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
        let polled: Vec<(&JobRow, _)> = jobs.iter().copied().zip(reports).collect();
        let actions = decide::on_reports(&polled, &self.budgets, now_s());
        self.apply(jobs, actions).await
    }

    /// `stop_when:`: reads each running design job's output when its check is due, and
    /// asks the solver to stop (writes the stop file) once the response's interval has
    /// been narrow enough at [`convergence::NARROW_CHECKS`] checks in a row.
    async fn stop_converged(&mut self, jobs: &[JobRow]) {
        let Some(stop) = &self.study.stop_when else {
            return;
        };
        let now = Instant::now();
        // Jobs that ended since the last tick are not in `jobs` any more.
        let running: HashSet<i64> = jobs
            .iter()
            .filter(|j| j.state() == JobState::Running)
            .map(|j| j.id)
            .collect();
        self.convergence.retain(|id| running.contains(&id));
        for job in jobs {
            let running = job.state() == JobState::Running && job.stage_kind().is_none();
            if !running {
                self.convergence.forget(job.id);
                continue;
            }
            let run_dir = PathBuf::from(&job.run_dir);
            if !self.convergence.due(job.id, stop, now) || run_dir.join(STOP_FILE).exists() {
                continue;
            }
            let (case, simulation) = match self.case_and_simulation(job).await {
                Ok(found) => found,
                Err(e) => {
                    tracing::warn!(job = %job.name, "cannot check stop_when: {e}");
                    continue;
                }
            };
            let dir = run_dir.clone();
            let so_far =
                tokio::task::spawn_blocking(move || simulation.results_so_far(&case, &dir))
                    .await
                    .ok()
                    .flatten();
            let seen = so_far
                .as_ref()
                .and_then(|results| convergence::relative_ci95(results, stop));
            let reached = seen.filter(|&(_, relative)| relative < stop.relative_ci95);
            if self
                .convergence
                .record(job.id, seen, reached.is_some(), now)
            {
                let (value, relative) = reached.expect("recorded as narrow");
                let reason = convergence::stop_reason(stop, value, relative);
                match std::fs::write(run_dir.join(STOP_FILE), format!("{reason}\n")) {
                    Ok(()) => self.report(job, &format!("{reason}; asked the solver to stop")),
                    Err(e) => errln!(
                        "orch: cannot write {}: {e}; {} runs on to its end time",
                        run_dir.join(STOP_FILE).display(),
                        job.name
                    ),
                }
            }
        }
    }

    /// Applies the decisions of [`crate::decide`] about `jobs`, in order. Consecutive
    /// terminations go to the executor in one call (one `scancel` for many), and so do
    /// consecutive launches (one job array for many).
    async fn apply(&mut self, jobs: &[&JobRow], actions: Vec<Action>) -> Result<(), DriverError> {
        let by_id: HashMap<i64, &JobRow> = jobs.iter().map(|j| (j.id, *j)).collect();
        let mut actions = actions.into_iter().peekable();
        while let Some(action) = actions.next() {
            let Some(job) = by_id.get(&action.job()).copied() else {
                continue;
            };
            match action {
                Action::NoteSchedulerState { state, .. } => {
                    self.store.set_scheduler_state(job.id, &state).await?;
                }
                Action::MarkStarted { .. } => self.store.mark_started(job.id, now_s()).await?,
                Action::Collect { .. } => self.collect(job).await?,
                Action::Terminate { job: id, handle } => {
                    let mut batch = vec![(id, handle)];
                    while let Some(Action::Terminate { .. }) = actions.peek() {
                        if let Some(Action::Terminate { job, handle }) = actions.next() {
                            batch.push((job, handle));
                        }
                    }
                    let handles: Vec<&str> = batch.iter().map(|(_, h)| h.as_str()).collect();
                    self.executor.terminate(&handles).await;
                    self.terminating.extend(batch);
                }
                Action::Retry { .. } | Action::Fail { .. } => {
                    self.record_failure(job, action).await?;
                }
                Action::FailOrphan { upstream, .. } => {
                    let kind = job.stage_kind().unwrap_or("stage");
                    let reason = format!(
                        "its upstream job {upstream} failed, so the {kind} stage has no inputs"
                    );
                    self.report(job, &format!("failed: {reason}"));
                    self.store.mark_failed(job.id, None, &reason).await?;
                }
                Action::Cancel { cause, .. } => match cause {
                    CancelCause::Scheduler(reason) => {
                        let note =
                            format!("{reason}; `orch resume {}` runs it again", self.study.name);
                        self.report(job, &note);
                        self.store.mark_cancelled(job.id, &note).await?;
                    }
                    CancelCause::Upstream(upstream) => {
                        let note = format!("its upstream job {upstream} was cancelled");
                        self.store.mark_cancelled(job.id, &note).await?;
                    }
                    CancelCause::Settled(note) => {
                        self.store.mark_cancelled(job.id, &note).await?;
                    }
                    CancelCause::Study => {
                        // `orch cancel` may have got there first; that is fine.
                        self.store
                            .mark_cancelled(job.id, "cancelled by orch cancel")
                            .await
                            .ok();
                    }
                },
                Action::Requeue { .. } => {
                    self.store
                        .requeue(job.id, "interrupted by the user", true)
                        .await?;
                }
                Action::Launch { .. } => {
                    let mut batch = vec![job];
                    while let Some(Action::Launch { .. }) = actions.peek() {
                        if let Some(next) = actions.next().and_then(|a| by_id.get(&a.job())) {
                            batch.push(*next);
                        }
                    }
                    self.launch(&batch).await?;
                }
            }
        }
        Ok(())
    }

    /// What a user needs to read of a failure: the cause and, where the run left
    /// output, what it says.
    fn reason(&self, job: &JobRow, failure: &Failure) -> String {
        let summary = || failure_summary(Path::new(&job.run_dir), &self.log_file(job));
        match failure {
            Failure::Exited(code) => {
                format!("the solver exited with status {code}; {}", summary())
            }
            Failure::Stopped(reason) => format!("{reason}; {}", summary()),
            Failure::Lost => "it ended without an exit status (orch, the machine or the scheduler stopped it, or its run directory was removed)".to_string(),
            Failure::TimeLimit(limit) => format!(
                "exceeded its time limit of {}; {}",
                humantime::format_duration(*limit),
                summary()
            ),
            Failure::Unreadable(reason) => reason.clone(),
        }
    }

    /// Records a [`Action::Retry`] (back to pending) or [`Action::Fail`] with its
    /// reason; other actions are not failures and are ignored here.
    async fn record_failure(&mut self, job: &JobRow, action: Action) -> Result<(), DriverError> {
        match action {
            Action::Retry {
                attempt,
                budget,
                failure,
                ..
            } => {
                let reason = self.reason(job, &failure);
                let note = format!("attempt {attempt} of {budget} failed: {reason}; retrying");
                self.report(job, &note);
                self.store.requeue(job.id, &note, false).await?;
            }
            Action::Fail { failure, .. } => {
                let reason = self.reason(job, &failure);
                self.report(job, &format!("failed: {reason}"));
                self.store
                    .mark_failed(job.id, failure.exit_code(), &reason)
                    .await?;
            }
            _ => {}
        }
        Ok(())
    }

    fn log_file(&self, job: &JobRow) -> String {
        match job
            .stage_kind()
            .and_then(|kind| self.study.stage(kind))
            .and_then(|stage| stage.stage.log_file())
        {
            Some(log) => log.to_string(),
            None => self.simulation_of(job).command().log_file,
        }
    }

    /// Ctrl-C / SIGTERM: local jobs are stopped and put back; jobs on a batch
    /// scheduler keep running there and `orch resume` re-attaches to them.
    async fn interrupt(&mut self) -> Result<Ending, DriverError> {
        let mut jobs = self.store.jobs(self.study_id).await?;
        // A job that ended but was not read yet is left running, for resume to read.
        jobs.retain(|job| !self.uncollected.contains(&job.id));
        if self.budgets.batch {
            let left = jobs.iter().filter(|j| is_launched(j.state())).count();
            errln!(
                "orch: interrupted; {left} submitted jobs keep running on the cluster; `orch resume {}` re-attaches to them",
                self.study.name
            );
        } else {
            errln!(
                "orch: interrupted; stopping running jobs (they will run again on `orch resume {}`)",
                self.study.name
            );
        }
        if !self.uncollected.is_empty() {
            errln!(
                "orch: {} jobs had finished but their output was not read yet; `orch resume {}` reads it without running them again",
                self.uncollected.len(),
                self.study.name
            );
        }
        let actions = decide::on_interrupt(&jobs, &self.budgets);
        self.apply(&jobs.iter().collect::<Vec<_>>(), actions)
            .await?;
        if !self.budgets.batch {
            self.executor.wait_for_terminations().await;
        }
        Ok(Ending::Interrupted)
    }

    /// The study was cancelled elsewhere: make sure nothing of ours still runs.
    async fn stop_for_cancel(&mut self) -> Result<Ending, DriverError> {
        let jobs = self.store.jobs(self.study_id).await?;
        let actions = decide::on_cancel(&jobs);
        self.apply(&jobs.iter().collect::<Vec<_>>(), actions)
            .await?;
        self.executor.wait_for_terminations().await;
        Ok(Ending::Cancelled)
    }

    fn report(&self, job: &JobRow, message: &str) {
        self.progress.println(&format!(
            "[{:>7.1} s] {}/{}: {message}",
            self.started.elapsed().as_secs_f64(),
            self.study.name,
            job.name
        ));
    }

    /// Updates the bar, when there is one, with where the latest round stands, at most
    /// every [`PROGRESS_EVERY`] unless `now`: it counts every job of the round, finished
    /// ones too.
    async fn show_progress(&mut self, now: bool) -> Result<(), DriverError> {
        let recent = self
            .last_progress
            .is_some_and(|last| last.elapsed() < PROGRESS_EVERY);
        if !self.progress.is_shown() || (recent && !now) {
            return Ok(());
        }
        self.last_progress = Some(Instant::now());
        let (round, jobs) = self.store.latest_round_jobs(self.study_id).await?;
        let round_jobs: Vec<&JobRow> = jobs.iter().collect();
        let progress = RoundProgress::of(
            round,
            self.study.rounds,
            &round_jobs,
            self.budgets.max_parallel,
        );
        self.progress.update(&progress);
        Ok(())
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
    let stderr = read(STDERR_FILE);
    // The solver's own words first: its log, then what it printed; Open MPI's abort
    // text on stderr comes after the solver's `ERROR:` line in importance.
    for windows in [&log, &stdout, &stderr] {
        let lines: Vec<&str> = windows.lines().collect();
        if let Some(error) = crate::tail::last_error(&lines) {
            return format!("it reported: {error}");
        }
    }
    for (name, windows) in [
        (STDERR_FILE, stderr),
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

/// A stage job's own case: its stage's parameters, with the job's seed.
fn stage_case(stage: &StageConfig, job: &JobRow) -> orch_adapters::Case {
    orch_adapters::Case {
        seed: job.seed as u64,
        ..stage.case()
    }
}

/// What a stage job reads of the job it follows, owned; [`UpstreamRun::view`] lends
/// it as the stage takes it.
struct UpstreamRun {
    run_dir: PathBuf,
    case: orch_adapters::Case,
    responses: std::collections::BTreeMap<String, f64>,
    stage_case: Option<orch_adapters::Case>,
    simulation: Arc<dyn Simulation>,
}

impl UpstreamRun {
    fn view(&self) -> Upstream<'_> {
        Upstream {
            case: &self.case,
            responses: &self.responses,
            run_dir: &self.run_dir,
            stage_case: self.stage_case.as_ref(),
            simulation: self.simulation.as_ref(),
        }
    }
}
