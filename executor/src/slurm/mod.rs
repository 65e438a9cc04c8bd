//! The Slurm executor: `sbatch --parsable` to submit, one `squeue` per poll for all
//! jobs, `scancel` to stop.
//!
//! Jobs launched together (a round) go out as job arrays, one `sbatch` per
//! `executor.array_size` jobs (at most the cluster's `MaxArraySize`) that ask for the
//! same resources; a job launched alone (a retry) is a batch job of its own. An
//! array's task list and script live in a folder beside the run directories
//! (`slurm-arrays/`), and its tasks are jobs of their own to orch: polled, cancelled
//! and retried one by one.
//!
//! Handles are `slurm:<job id>` or `slurm:<array job id>_<task>`. Each job's batch script ([`script`]) records the
//! solver's exit status in the run directory; Slurm's state decides only what the
//! script could not record: a time limit, a `scancel`, a failed node, preemption, or
//! memory. A job slurmctld no longer lists (after `MinJobAge`) is judged by its run
//! directory alone. Jobs outlive `orch`: a new `orch` re-attaches to them by id.

pub mod parse;
pub mod script;

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::time::Duration;

use tokio::process::Command;

use self::parse::{SlurmId, SlurmJob, SlurmState};
use super::{
    launch_each, read_exit_status, Executor, JobStatus, LaunchError, LaunchSpec, Launched,
    PollError, Recovered, Report, StopCause, Unrecorded, Watched, EXIT_STATUS_FILE,
};

/// Default time between two `squeue` calls.
pub const DEFAULT_POLL_INTERVAL: Duration = Duration::from_secs(5);
/// Default number of jobs orch keeps submitted and unfinished at once.
pub const DEFAULT_MAX_SUBMITTED: usize = 500;
/// Default largest job array orch submits (tasks per `sbatch`).
pub const DEFAULT_ARRAY_SIZE: usize = 1000;
/// Slurm's default `MaxArraySize`, assumed when `scontrol show config` cannot say.
pub const SLURM_DEFAULT_MAX_ARRAY_SIZE: usize = 1001;
/// Folder of the job arrays' task lists, scripts and outputs, beside a study's run
/// directories.
pub const ARRAYS_DIR: &str = "slurm-arrays";

/// How a study's jobs are submitted: its `executor:` section for `kind: slurm`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SlurmSettings {
    /// `--partition` (none: the cluster's default).
    pub partition: Option<String>,
    /// `--cpus-per-task` (none: the cores the solver's command asks for when they are
    /// threads, 1 when they are MPI ranks, each then a task of its own).
    pub cpus_per_task: Option<u32>,
    /// `--mem`, as sbatch writes it (`2G`).
    pub mem: Option<String>,
    /// `--account`.
    pub account: Option<String>,
    /// `--qos`.
    pub qos: Option<String>,
    /// Further `#SBATCH` lines, each `--option[=value]`.
    pub extra_sbatch: Vec<String>,
    /// `--time`, rounded up to whole minutes.
    pub time_limit: Option<Duration>,
    /// Time between two `squeue` calls.
    pub poll_interval: Duration,
    /// Most jobs per job array (none: [`DEFAULT_ARRAY_SIZE`]; 1: no arrays, one
    /// `sbatch` per job).
    pub array_size: Option<usize>,
}

/// The Slurm job or array task of an orch handle `slurm:<id>` / `slurm:<id>_<task>`.
pub fn job_id(handle: &str) -> Option<SlurmId> {
    handle.strip_prefix("slurm:")?.parse().ok()
}

/// The orch handle of a Slurm job or array task.
pub fn handle_of(id: SlurmId) -> String {
    format!("slurm:{id}")
}

/// Submits to, asks and cancels on the Slurm cluster that the `sbatch`, `squeue` and
/// `scancel` on PATH talk to (`SLURM_CONF` chooses the cluster).
#[derive(Debug)]
pub struct SlurmExecutor {
    settings: SlurmSettings,
    /// Whether `squeue --json` works here; unknown until the first poll.
    json: Option<bool>,
    /// The cluster's `MaxArraySize`; unknown until the first array.
    max_array_size: Option<usize>,
    /// Arrays submitted by this process, to name their folders apart.
    arrays: u64,
    calls: HashMap<&'static str, u64>,
}

impl SlurmExecutor {
    /// An executor submitting with `settings`.
    pub fn new(settings: SlurmSettings) -> SlurmExecutor {
        SlurmExecutor {
            settings,
            json: None,
            max_array_size: None,
            arrays: 0,
            calls: HashMap::new(),
        }
    }

    /// Runs a Slurm command; its stdout, or what went wrong.
    async fn run(
        &mut self,
        program: &'static str,
        args: &[&str],
        dir: Option<&Path>,
    ) -> Result<String, String> {
        *self.calls.entry(program).or_default() += 1;
        let mut command = Command::new(program);
        command.args(args).kill_on_drop(true);
        if let Some(dir) = dir {
            command.current_dir(dir);
        }
        let output = command.output().await.map_err(|e| {
            format!("cannot run `{program}` ({e}); is Slurm installed (apt-get install slurm-wlm) and on PATH?")
        })?;
        if !output.status.success() {
            let stderr = String::from_utf8_lossy(&output.stderr);
            return Err(format!("{} ({})", stderr.trim(), output.status));
        }
        Ok(String::from_utf8_lossy(&output.stdout).into_owned())
    }

    /// Every job slurmctld holds, by id: `squeue --json` where it works, else text.
    async fn queue(&mut self) -> Result<HashMap<SlurmId, SlurmJob>, PollError> {
        if self.json != Some(false) {
            let answer = self.run("squeue", &["--json"], None).await;
            match answer.as_deref().map(parse::parse_squeue_json) {
                Ok(Ok(jobs)) => {
                    self.json = Some(true);
                    return Ok(jobs.into_iter().map(|j| (j.id, j)).collect());
                }
                Ok(Err(e)) if self.json == Some(true) => {
                    return Err(PollError {
                        command: "squeue --json".into(),
                        message: e.to_string(),
                    })
                }
                Err(e) if self.json == Some(true) => {
                    return Err(PollError {
                        command: "squeue --json".into(),
                        message: e.clone(),
                    })
                }
                // Unknown yet and it failed: try the text form; if that works, this
                // squeue has no JSON and text is used from now on.
                _ => {}
            }
        }
        let format = format!("--format={}", parse::SQUEUE_TEXT_FORMAT);
        let text = self
            .run(
                "squeue",
                &["--array", "--noheader", "--states=all", &format],
                None,
            )
            .await
            .map_err(|message| PollError {
                command: "squeue".into(),
                message,
            })?;
        let jobs = parse::parse_squeue_text(&text).map_err(|e| PollError {
            command: "squeue".into(),
            message: e.to_string(),
        })?;
        if self.json.is_none() {
            tracing::info!("squeue --json does not work here; reading squeue's text output");
            self.json = Some(false);
        }
        Ok(jobs.into_iter().map(|j| (j.id, j)).collect())
    }

    /// The tasks of one array, at most the cluster's `MaxArraySize` (asked once).
    async fn array_size(&mut self) -> usize {
        let wanted = self
            .settings
            .array_size
            .unwrap_or(DEFAULT_ARRAY_SIZE)
            .max(1);
        if wanted == 1 {
            return 1;
        }
        if self.max_array_size.is_none() {
            let config = self.run("scontrol", &["show", "config"], None).await;
            let max = config.as_deref().ok().and_then(parse::parse_max_array_size);
            if max.is_none() {
                tracing::warn!("cannot read MaxArraySize from `scontrol show config`; assuming Slurm's default {SLURM_DEFAULT_MAX_ARRAY_SIZE}");
            }
            self.max_array_size = Some(max.unwrap_or(SLURM_DEFAULT_MAX_ARRAY_SIZE));
        }
        wanted.min(self.max_array_size.unwrap_or(SLURM_DEFAULT_MAX_ARRAY_SIZE))
    }

    /// Writes `spec`'s batch script into its run directory (and clears an earlier
    /// attempt's exit status).
    fn prepare(&self, spec: &LaunchSpec) -> Result<(), LaunchError> {
        let launch_error = |source| LaunchError {
            program: "sbatch".into(),
            run_dir: spec.run_dir.clone(),
            source,
        };
        let _ = std::fs::remove_file(spec.run_dir.join(EXIT_STATUS_FILE));
        let text = script::batch_script(spec, &self.settings)
            .map_err(|e| launch_error(std::io::Error::other(e)))?;
        std::fs::write(spec.run_dir.join(script::BATCH_SCRIPT), text).map_err(launch_error)
    }

    /// Submits the prepared jobs `specs` (all asking for the same resources) as one
    /// array; the handle of each task, in order.
    async fn submit_array(&mut self, specs: &[&LaunchSpec]) -> Result<Vec<Launched>, LaunchError> {
        let first = specs[0];
        let launch_error = |source| LaunchError {
            program: "sbatch".into(),
            run_dir: first.run_dir.clone(),
            source,
        };
        let study = first.name.split('/').next().unwrap_or(&first.name);
        let runs = first.run_dir.parent().unwrap_or(Path::new("."));
        self.arrays += 1;
        let stamp = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |t| t.as_millis());
        let array_dir: PathBuf =
            runs.join(ARRAYS_DIR)
                .join(format!("{stamp}-{}-{}", std::process::id(), self.arrays));
        std::fs::create_dir_all(&array_dir).map_err(launch_error)?;
        let tasks: String = specs
            .iter()
            .map(|spec| format!("{}\n", spec.run_dir.display()))
            .collect();
        std::fs::write(array_dir.join(script::ARRAY_TASKS), tasks).map_err(launch_error)?;
        let text = script::array_script(study, &array_dir, specs.len(), first, &self.settings)
            .map_err(|e| launch_error(std::io::Error::other(e)))?;
        std::fs::write(array_dir.join(script::ARRAY_SCRIPT), text).map_err(launch_error)?;
        let stdout = self
            .run(
                "sbatch",
                &["--parsable", script::ARRAY_SCRIPT],
                Some(&array_dir),
            )
            .await
            .map_err(|e| {
                launch_error(std::io::Error::other(format!(
                    "sbatch refused the job array of {} jobs: {e}",
                    specs.len()
                )))
            })?;
        let array = parse::parse_sbatch_output(&stdout)
            .map_err(|e| launch_error(std::io::Error::other(e)))?;
        Ok((0..specs.len())
            .map(|task| Launched {
                handle: handle_of(SlurmId::task(array, task as u32)),
                queued: true,
            })
            .collect())
    }

    /// Runs `sbatch` on the batch script [`SlurmExecutor::prepare`] wrote into
    /// `spec`'s run directory: a batch job of its own.
    async fn sbatch_job(&mut self, spec: &LaunchSpec) -> Result<Launched, LaunchError> {
        let launch_error = |source| LaunchError {
            program: "sbatch".into(),
            run_dir: spec.run_dir.clone(),
            source,
        };
        let stdout = self
            .run(
                "sbatch",
                &["--parsable", script::BATCH_SCRIPT],
                Some(&spec.run_dir),
            )
            .await
            .map_err(|e| {
                launch_error(std::io::Error::other(format!(
                    "sbatch refused the job: {e}"
                )))
            })?;
        let id = parse::parse_sbatch_output(&stdout)
            .map_err(|e| launch_error(std::io::Error::other(e)))?;
        Ok(Launched {
            handle: handle_of(SlurmId::job(id)),
            queued: true,
        })
    }
}

/// The `squeue --format` of [`find_unrecorded`]'s listing: id, name, working directory.
pub const SQUEUE_NAMES_FORMAT: &str = "%i|%j|%Z";

/// Which Slurm job each of `jobs` (all of `study`) is, from one `squeue --array
/// --format=`[`SQUEUE_NAMES_FORMAT`] listing of the study's arrays and the jobs' own
/// names: an array task whose line of its array's task list (read from the array's
/// folder, its working directory) is the job's run directory, else a job of its own
/// name run in that directory; the newest, which orch submitted last, when several
/// are. A job found in neither is [`Recovered::Nothing`].
pub fn find_unrecorded(study: &str, listing: &str, jobs: &[Unrecorded<'_>]) -> Vec<Recovered> {
    let array_name = script::array_job_name(study);
    let listed: Vec<(SlurmId, &str, &Path)> = listing
        .lines()
        .filter_map(|line| {
            let mut fields = line.trim().splitn(3, '|');
            let id = fields.next()?.parse::<SlurmId>().ok()?;
            Some((id, fields.next()?, Path::new(fields.next()?)))
        })
        .collect();
    // Each array's task list, read once.
    let mut lists: HashMap<&Path, Vec<PathBuf>> = HashMap::new();
    for &(id, name, dir) in &listed {
        if name == array_name && id.task.is_some() {
            lists.entry(dir).or_insert_with(|| {
                std::fs::read_to_string(dir.join(script::ARRAY_TASKS))
                    .map(|t| t.lines().map(PathBuf::from).collect())
                    .unwrap_or_default()
            });
        }
    }
    jobs.iter()
        .map(|job| {
            let canonical = std::fs::canonicalize(job.run_dir).ok();
            let same = |dir: &Path| {
                dir == job.run_dir
                    || canonical.as_deref().is_some_and(|wanted| {
                        dir == wanted || std::fs::canonicalize(dir).is_ok_and(|d| d == wanted)
                    })
            };
            let task = listed
                .iter()
                .filter(|(id, name, _)| *name == array_name && id.task.is_some())
                .filter(|(id, _, dir)| {
                    let listed_dir = lists.get(dir).and_then(|l| l.get(id.task? as usize));
                    listed_dir.is_some_and(|d| same(d))
                })
                .map(|(id, _, _)| *id)
                .max();
            let own_name = script::slurm_job_name(job.spec_name);
            let own = || {
                listed
                    .iter()
                    .filter(|(id, name, dir)| id.task.is_none() && *name == own_name && same(dir))
                    .map(|(id, _, _)| *id)
                    .max()
            };
            task.or_else(own)
                .map_or(Recovered::Nothing, |id| Recovered::Attached(handle_of(id)))
        })
        .collect()
}

/// What a job's state means for orch: Slurm's view where the batch script could not
/// have recorded anything, the run directory's exit status otherwise. `recorded_exit`
/// is the status the batch script wrote, if any.
pub fn report_of(id: SlurmId, job: Option<&SlurmJob>, recorded_exit: Option<i32>) -> Report {
    let Some(job) = job else {
        // slurmctld forgot the job (MinJobAge): its run directory is all there is.
        return Report {
            status: recorded_exit.map_or(JobStatus::Lost, JobStatus::Exited),
            scheduler_state: Some("no longer listed by squeue".into()),
        };
    };
    let stopped = |cause, what: &str| JobStatus::Stopped {
        cause,
        reason: format!("Slurm job {id} {what}: {}", job.describe()),
    };
    let status = match job.state {
        SlurmState::Pending | SlurmState::Other(_) => JobStatus::Queued,
        SlurmState::Running | SlurmState::Completing | SlurmState::Suspended => {
            match recorded_exit {
                // The batch script has ended; Slurm is still cleaning up.
                Some(code) if job.state == SlurmState::Completing => JobStatus::Exited(code),
                _ => JobStatus::Running,
            }
        }
        SlurmState::Completed | SlurmState::Failed => match recorded_exit {
            Some(code) => JobStatus::Exited(code),
            // The script exited 0, so it wrote its exit status: a shared file system
            // has not shown it here yet. Ask again.
            None if job.state == SlurmState::Completed => JobStatus::Running,
            None => stopped(
                StopCause::Other,
                &format!(
                    "ended without recording an exit status (its batch script failed; see {})",
                    slurm_output(id)
                ),
            ),
        },
        SlurmState::Timeout | SlurmState::Deadline => match recorded_exit {
            // The solver finished and the batch script ran to its end: the limit struck
            // while the job was ending (Slurm checks limits every half minute or so,
            // and labels such a job TIMEOUT all the same). Its result stands; thrown
            // away, a retry would run the whole job again.
            Some(0) => JobStatus::Exited(0),
            _ => stopped(StopCause::TimeLimit, "was stopped at its time limit"),
        },
        SlurmState::Cancelled => stopped(StopCause::Cancelled, "was cancelled outside orch"),
        SlurmState::NodeFail | SlurmState::Preempted | SlurmState::BootFail => {
            stopped(StopCause::NodeLost, "lost its node")
        }
        SlurmState::OutOfMemory => stopped(
            StopCause::OutOfMemory,
            "ran out of memory (raise executor.mem)",
        ),
    };
    Report {
        status,
        scheduler_state: Some(job.describe()),
    }
}

/// Where Slurm wrote the output of the batch script of `id`: the run directory's
/// `slurm-<id>.out`, or an array task's `slurm-<array>_<task>.out` in its array's
/// folder.
fn slurm_output(id: SlurmId) -> String {
    match id.task {
        None => format!("slurm-{id}.out"),
        Some(_) => format!("slurm-{id}.out in the study's {ARRAYS_DIR}/ folder"),
    }
}

impl Executor for SlurmExecutor {
    async fn launch(&mut self, spec: &LaunchSpec) -> Result<Launched, LaunchError> {
        self.prepare(spec)?;
        self.sbatch_job(spec).await
    }

    /// Jobs that ask for the same resources go out as arrays of at most the array size;
    /// a job alone (or with arrays turned off) as a batch job of its own.
    async fn launch_many(&mut self, specs: &[LaunchSpec]) -> Vec<Result<Launched, LaunchError>> {
        if specs.len() < 2 {
            return launch_each(self, specs).await;
        }
        let size = self.array_size().await;
        if size < 2 {
            return launch_each(self, specs).await;
        }
        let mut answers: Vec<Option<Result<Launched, LaunchError>>> =
            specs.iter().map(|_| None).collect();
        // Prepared jobs by what they ask for, in launch order.
        let mut groups: Vec<(Vec<String>, Vec<usize>)> = Vec::new();
        for (i, spec) in specs.iter().enumerate() {
            if let Err(e) = self.prepare(spec) {
                answers[i] = Some(Err(e));
                continue;
            }
            let asks = script::resource_options(spec, &self.settings).unwrap_or_default();
            match groups.iter_mut().find(|(other, _)| *other == asks) {
                Some((_, members)) => members.push(i),
                None => groups.push((asks, vec![i])),
            }
        }
        for (_, members) in groups {
            for chunk in members.chunks(size) {
                let chunk_specs: Vec<&LaunchSpec> = chunk.iter().map(|&i| &specs[i]).collect();
                let submitted = if chunk.len() == 1 {
                    // Prepared above: its batch script is written.
                    self.sbatch_job(chunk_specs[0]).await.map(|l| vec![l])
                } else {
                    self.submit_array(&chunk_specs).await
                };
                match submitted {
                    Ok(launched) => {
                        for (&i, launched) in chunk.iter().zip(launched) {
                            answers[i] = Some(Ok(launched));
                        }
                    }
                    Err(e) => {
                        for &i in chunk {
                            answers[i] = Some(Err(LaunchError {
                                program: e.program.clone(),
                                run_dir: specs[i].run_dir.clone(),
                                source: std::io::Error::other(e.source.to_string()),
                            }));
                        }
                    }
                }
            }
        }
        answers
            .into_iter()
            .map(|answer| answer.expect("every job is prepared or refused"))
            .collect()
    }

    async fn poll(&mut self, jobs: &[Watched<'_>]) -> Result<Vec<Report>, PollError> {
        if jobs.is_empty() {
            return Ok(Vec::new());
        }
        let queue = self.queue().await?;
        Ok(jobs
            .iter()
            .map(|job| match job_id(job.handle) {
                Some(id) => report_of(id, queue.get(&id), read_exit_status(job.run_dir)),
                None => Report {
                    status: JobStatus::Lost,
                    scheduler_state: None,
                },
            })
            .collect())
    }

    async fn terminate(&mut self, handles: &[&str]) {
        let ids: Vec<String> = handles
            .iter()
            .filter_map(|h| job_id(h))
            .map(|id| id.to_string())
            .collect();
        if ids.is_empty() {
            return;
        }
        let args: Vec<&str> = ids.iter().map(String::as_str).collect();
        if let Err(e) = self.run("scancel", &args, None).await {
            tracing::warn!("scancel {}: {e}", ids.join(" "));
        }
    }

    async fn recover_unrecorded(&mut self, jobs: &[Unrecorded<'_>]) -> Vec<Recovered> {
        let Some(first) = jobs.first() else {
            return Vec::new();
        };
        let study = first.spec_name.split('/').next().unwrap_or(first.spec_name);
        // One query for all: the study's arrays and each job's own name.
        let names: Vec<String> = std::iter::once(script::array_job_name(study))
            .chain(jobs.iter().map(|job| script::slurm_job_name(job.spec_name)))
            .collect();
        let name = format!("--name={}", names.join(","));
        let format = format!("--format={SQUEUE_NAMES_FORMAT}");
        match self
            .run(
                "squeue",
                &["--array", "--noheader", "--states=all", &name, &format],
                None,
            )
            .await
        {
            Ok(listing) => find_unrecorded(study, &listing, jobs),
            Err(e) => {
                tracing::warn!("cannot ask squeue about jobs a stopped orch submitted: {e}");
                jobs.iter().map(|_| Recovered::Nothing).collect()
            }
        }
    }

    fn tidy(&mut self) -> usize {
        0
    }

    fn is_gone(&self, _handle: &str) -> bool {
        // orch terminates Slurm jobs only to cancel them; a retry is a new Slurm job.
        true
    }

    fn poll_interval(&self) -> Duration {
        self.settings.poll_interval
    }

    fn is_batch(&self) -> bool {
        true
    }

    fn calls(&self) -> Option<String> {
        let mut calls: Vec<String> = self
            .calls
            .iter()
            .map(|(program, n)| format!("{n} {program}"))
            .collect();
        calls.sort();
        Some(calls.join(", "))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn job(state: &str, reason: &str) -> SlurmJob {
        SlurmJob {
            id: SlurmId::job(7),
            state: SlurmState::parse(state),
            reason: reason.into(),
            nodes: "n2".into(),
        }
    }

    fn status(state: &str, reason: &str, recorded: Option<i32>) -> JobStatus {
        report_of(SlurmId::job(7), Some(&job(state, reason)), recorded).status
    }

    fn cause(status: JobStatus) -> Option<StopCause> {
        match status {
            JobStatus::Stopped { cause, .. } => Some(cause),
            _ => None,
        }
    }

    #[test]
    fn the_recorded_exit_status_decides_completed_and_failed_jobs() {
        assert_eq!(status("COMPLETED", "None", Some(0)), JobStatus::Exited(0));
        assert_eq!(
            status("FAILED", "NonZeroExitCode", Some(3)),
            JobStatus::Exited(3)
        );
        assert_eq!(status("COMPLETING", "None", Some(1)), JobStatus::Exited(1));
        assert_eq!(status("COMPLETING", "None", None), JobStatus::Running);
        // Exit 0 means the status was written; it is not visible here yet (NFS).
        assert_eq!(status("COMPLETED", "None", None), JobStatus::Running);
        let unrecorded = status("FAILED", "NonZeroExitCode", None);
        assert_eq!(cause(unrecorded.clone()), Some(StopCause::Other));
        assert!(format!("{unrecorded:?}").contains("slurm-7.out"));
    }

    #[test]
    fn slurm_decides_what_the_batch_script_could_not_record() {
        for (state, reason, expected) in [
            ("TIMEOUT", "TimeLimit", StopCause::TimeLimit),
            ("DEADLINE", "None", StopCause::TimeLimit),
            ("CANCELLED", "None", StopCause::Cancelled),
            ("NODE_FAIL", "NodeDown", StopCause::NodeLost),
            ("PREEMPTED", "None", StopCause::NodeLost),
            ("BOOT_FAIL", "None", StopCause::NodeLost),
            ("OUT_OF_MEMORY", "OutOfMemory", StopCause::OutOfMemory),
        ] {
            // Even when the solver managed to exit (SIGTERM) and an exit status exists.
            for recorded in [None, Some(143)] {
                assert_eq!(
                    cause(status(state, reason, recorded)),
                    Some(expected),
                    "{state}"
                );
            }
        }
        // A solver that finished as the limit struck: its exit 0 is the outcome.
        for state in ["TIMEOUT", "DEADLINE"] {
            assert_eq!(status(state, "TimeLimit", Some(0)), JobStatus::Exited(0));
        }
        let JobStatus::Stopped { reason, .. } = status("TIMEOUT", "TimeLimit", None) else {
            unreachable!()
        };
        assert_eq!(
            reason,
            "Slurm job 7 was stopped at its time limit: TIMEOUT (TimeLimit) on n2"
        );
    }

    #[test]
    fn waiting_and_running_jobs_carry_what_slurm_says() {
        let pending = report_of(SlurmId::job(7), Some(&job("PENDING", "Priority")), None);
        assert_eq!(pending.status, JobStatus::Queued);
        assert_eq!(
            pending.scheduler_state.as_deref(),
            Some("PENDING (Priority) on n2")
        );
        assert_eq!(status("RUNNING", "None", None), JobStatus::Running);
        assert_eq!(status("CONFIGURING", "None", None), JobStatus::Queued);
    }

    #[test]
    fn a_forgotten_job_is_judged_by_its_run_directory() {
        let seven = SlurmId::job(7);
        assert_eq!(report_of(seven, None, Some(0)).status, JobStatus::Exited(0));
        assert_eq!(report_of(seven, None, Some(2)).status, JobStatus::Exited(2));
        assert_eq!(report_of(seven, None, None).status, JobStatus::Lost);
    }

    /// After `kill -9`, one listing of the study's arrays and the jobs' own names tells
    /// which job is which: an array task by its line of its array's task list (the
    /// newest array holding it), a job of its own by name and directory.
    #[test]
    fn jobs_left_rendered_are_found_in_one_listing() {
        let root = tempfile::tempdir().unwrap();
        let runs = root.path().join("runs/s");
        let dir = |job: &str| runs.join(job);
        for job in ["p000r0", "p001r0", "p002r0", "p003r0"] {
            std::fs::create_dir_all(dir(job)).unwrap();
        }
        let arrays = runs.join(ARRAYS_DIR);
        let (older, newer) = (arrays.join("1-1-1"), arrays.join("2-1-2"));
        for (array, tasks) in [(&older, vec!["p000r0", "p001r0"]), (&newer, vec!["p001r0"])] {
            std::fs::create_dir_all(array).unwrap();
            let list: String = tasks
                .iter()
                .map(|t| format!("{}\n", dir(t).display()))
                .collect();
            std::fs::write(array.join(script::ARRAY_TASKS), list).unwrap();
        }
        let listing = format!(
            "100_0|orch-array.s|{older}\n100_1|orch-array.s|{older}\n105_0|orch-array.s|{newer}\n\
             200|orch.s.p002r0|{p2}\n201|orch.s.p003r0|{elsewhere}\nnot a line\n",
            older = older.display(),
            newer = newer.display(),
            p2 = dir("p002r0").display(),
            elsewhere = root.path().display(),
        );
        let names = ["s/p000r0", "s/p001r0", "s/p002r0", "s/p003r0"];
        let dirs: Vec<PathBuf> = names.iter().map(|n| dir(&n[2..])).collect();
        let jobs: Vec<Unrecorded> = names
            .iter()
            .zip(&dirs)
            .map(|(name, run_dir)| Unrecorded {
                spec_name: name,
                run_dir,
            })
            .collect();
        assert_eq!(
            find_unrecorded("s", &listing, &jobs),
            vec![
                Recovered::Attached("slurm:100_0".into()),
                Recovered::Attached("slurm:105_0".into()),
                Recovered::Attached("slurm:200".into()),
                Recovered::Nothing,
            ]
        );
        assert_eq!(
            find_unrecorded("s", "", &jobs[..1]),
            vec![Recovered::Nothing]
        );
    }

    #[test]
    fn handles_name_slurm_job_ids() {
        assert_eq!(job_id("slurm:123"), Some(SlurmId::job(123)));
        assert_eq!(job_id("slurm:123_4"), Some(SlurmId::task(123, 4)));
        assert_eq!(handle_of(SlurmId::task(123, 4)), "slurm:123_4");
        assert_eq!(job_id("123:456"), None);
        assert_eq!(job_id("slurm:"), None);
        let unrecorded = report_of(SlurmId::task(9, 3), Some(&job("FAILED", "None")), None);
        assert!(
            format!("{unrecorded:?}").contains("slurm-9_3.out in the study's slurm-arrays/ folder"),
            "{unrecorded:?}"
        );
    }
}
