//! The local executor: each job is a process group on this machine.
//!
//! A job runs as `/bin/sh -c WRAPPER orch-job PROGRAM ARGS…` in its run directory, as
//! the leader of a new process group. The wrapper sends the solver's output to
//! `stdout.txt` / `stderr.txt`, then writes the solver's exit status to `exit_status`
//! (through a rename, so it is never half-written) and appends start and end lines to
//! `orch-attempts.log`. Terminating a job signals the whole group: SIGTERM, then
//! SIGKILL after a grace period; a terminated wrapper writes no exit status.

use std::collections::HashMap;
use std::path::Path;
use std::process::Stdio;
use std::time::{Duration, Instant};

use nix::sys::signal::Signal;
use tokio::process::{Child, Command};

use super::process::{self, ProcessHandle};
use super::{
    read_exit_status, Executor, JobStatus, LaunchError, LaunchSpec, Launched, PollError, Recovered,
    Report, Unrecorded, Watched, ATTEMPTS_LOG, EXIT_STATUS_FILE, LINE_BUFFERED, STDERR_FILE,
    STDOUT_FILE,
};

/// How long a terminated job has between SIGTERM and SIGKILL.
pub const TERMINATION_GRACE: Duration = Duration::from_secs(3);
/// How often the driver polls local jobs.
pub const POLL_INTERVAL: Duration = Duration::from_millis(100);

/// The shell wrapper around every local job; `$@` is the solver's command line.
fn wrapper_script() -> String {
    format!(
        "echo \"start $$ $(date +%s.%N)\" >> {ATTEMPTS_LOG}; {LINE_BUFFERED}; \
         $line_buffered \"$@\" > {STDOUT_FILE} 2> {STDERR_FILE} < /dev/null; rc=$?; \
         echo $rc > {EXIT_STATUS_FILE}.tmp && mv {EXIT_STATUS_FILE}.tmp {EXIT_STATUS_FILE}; \
         echo \"end $rc $(date +%s.%N)\" >> {ATTEMPTS_LOG}; exit $rc"
    )
}

/// Runs jobs as local process groups and keeps the children it started so they are
/// reaped; jobs started by an earlier `orch` are followed through `/proc`.
#[derive(Debug, Default)]
pub struct LocalExecutor {
    children: HashMap<i64, Child>,
    dying: Vec<(i64, Instant)>,
}

impl LocalExecutor {
    /// A new executor with no jobs.
    pub fn new() -> LocalExecutor {
        LocalExecutor::default()
    }

    /// Starts a job; returns its handle.
    pub fn start(&mut self, spec: &LaunchSpec) -> Result<ProcessHandle, LaunchError> {
        let launch_error = |source| LaunchError {
            program: spec.command.program.clone(),
            run_dir: spec.run_dir.clone(),
            source,
        };
        let _ = std::fs::remove_file(spec.run_dir.join(EXIT_STATUS_FILE));
        let child = Command::new("/bin/sh")
            .arg("-c")
            .arg(wrapper_script())
            .arg("orch-job")
            .arg(&spec.command.program)
            .args(&spec.command.args)
            .envs(&spec.command.env)
            .current_dir(&spec.run_dir)
            .process_group(0)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .kill_on_drop(false)
            .spawn()
            .map_err(launch_error)?;
        let pid = child.id().map(i64::from).ok_or_else(|| {
            launch_error(std::io::Error::other(
                "the job exited before its pid was read",
            ))
        })?;
        // The kernel knows the start time as soon as the process exists.
        let started_ticks = process::start_ticks(pid).unwrap_or(0);
        self.children.insert(pid, child);
        Ok(ProcessHandle { pid, started_ticks })
    }

    /// Where the job of `handle`, running in `run_dir`, stands.
    pub fn status_of(&mut self, handle: ProcessHandle, run_dir: &Path) -> JobStatus {
        let running = JobStatus::Running;
        if let Some(child) = self.children.get_mut(&handle.pid) {
            match child.try_wait() {
                Ok(None) => return running,
                Ok(Some(_)) | Err(_) => {
                    self.children.remove(&handle.pid);
                }
            }
        } else if handle.is_alive() {
            return running;
        }
        match read_exit_status(run_dir) {
            Some(code) => JobStatus::Exited(code),
            None => JobStatus::Lost,
        }
    }

    /// Asks the job's process group to stop, and kills it after [`TERMINATION_GRACE`].
    pub fn stop(&mut self, handle: ProcessHandle) {
        if handle.is_alive() || self.children.contains_key(&handle.pid) {
            process::signal_group(handle.pid, Signal::SIGTERM);
            self.dying
                .push((handle.pid, Instant::now() + TERMINATION_GRACE));
        }
    }

    /// Reaps finished children and escalates terminations past their grace period.
    /// Call it regularly.
    pub fn reap(&mut self) {
        self.children
            .retain(|_, child| matches!(child.try_wait(), Ok(None)));
        let now = Instant::now();
        self.dying.retain(|&(pgid, deadline)| {
            if !process::group_exists(pgid) {
                return false;
            }
            if now >= deadline {
                process::signal_group(pgid, Signal::SIGKILL);
            }
            true
        });
    }

    /// Jobs still being terminated.
    pub fn terminating(&self) -> usize {
        self.dying.len()
    }
}

impl Executor for LocalExecutor {
    async fn launch(&mut self, spec: &LaunchSpec) -> Result<Launched, LaunchError> {
        self.start(spec).map(|handle| Launched {
            handle: handle.to_string(),
            queued: false,
        })
    }

    async fn poll(&mut self, jobs: &[Watched<'_>]) -> Result<Vec<Report>, PollError> {
        Ok(jobs
            .iter()
            .map(|job| Report {
                status: match ProcessHandle::parse(job.handle) {
                    Some(handle) => self.status_of(handle, job.run_dir),
                    None => JobStatus::Lost,
                },
                scheduler_state: None,
            })
            .collect())
    }

    async fn terminate(&mut self, handles: &[&str]) {
        for handle in handles.iter().filter_map(|h| ProcessHandle::parse(h)) {
            self.stop(handle);
        }
    }

    async fn recover_unrecorded(&mut self, jobs: &[Unrecorded<'_>]) -> Vec<Recovered> {
        jobs.iter()
            .map(|job| match kill_unrecorded(job.run_dir) {
                Some(pid) => Recovered::Killed(pid),
                None => Recovered::Nothing,
            })
            .collect()
    }

    fn tidy(&mut self) -> usize {
        self.reap();
        self.terminating()
    }

    fn is_gone(&self, handle: &str) -> bool {
        ProcessHandle::parse(handle).is_none_or(|h| !process::group_exists(h.pid))
    }

    fn poll_interval(&self) -> Duration {
        POLL_INTERVAL
    }

    fn is_batch(&self) -> bool {
        false
    }
}

/// Kills a job that an `orch` launched in `run_dir` but stopped before recording its
/// handle (the window between spawn and the store's update). The wrapper's last
/// `start <pid>` line in the attempts log names it; it counts as that job only while
/// its working directory is `run_dir`. Returns the pid it killed.
pub fn kill_unrecorded(run_dir: &Path) -> Option<i64> {
    let log = std::fs::read_to_string(run_dir.join(ATTEMPTS_LOG)).ok()?;
    let pid: i64 = log
        .lines()
        .last()?
        .strip_prefix("start ")?
        .split_whitespace()
        .next()?
        .parse()
        .ok()?;
    let cwd = std::fs::read_link(format!("/proc/{pid}/cwd")).ok()?;
    if cwd != std::fs::canonicalize(run_dir).ok()? {
        return None;
    }
    process::signal_group(pid, Signal::SIGKILL);
    let deadline = Instant::now() + Duration::from_secs(5);
    while process::group_exists(pid) && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(20));
    }
    Some(pid)
}

#[cfg(test)]
mod tests {
    use super::*;
    use orch_adapters::CommandSpec;

    fn spec(dir: &Path, script: &str) -> LaunchSpec {
        LaunchSpec {
            name: "test/job".into(),
            run_dir: dir.to_path_buf(),
            command: CommandSpec {
                program: "/bin/sh".into(),
                args: vec!["-c".into(), script.into()],
                env: Default::default(),
                cores: 1,
                mpi: false,
                same_result_on_any_cores: false,
                log_file: STDOUT_FILE.into(),
            },
        }
    }

    async fn wait(executor: &mut LocalExecutor, handle: ProcessHandle, dir: &Path) -> JobStatus {
        let deadline = Instant::now() + Duration::from_secs(20);
        loop {
            let status = executor.status_of(handle, dir);
            if status != JobStatus::Running || Instant::now() > deadline {
                return status;
            }
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    }

    #[tokio::test]
    async fn exit_status_and_output_land_in_the_run_directory() {
        let dir = tempfile::tempdir().unwrap();
        let mut executor = LocalExecutor::new();
        let handle = executor
            .start(&spec(dir.path(), "echo out; echo err >&2; exit 3"))
            .unwrap();
        assert_eq!(
            wait(&mut executor, handle, dir.path()).await,
            JobStatus::Exited(3)
        );
        assert_eq!(
            std::fs::read_to_string(dir.path().join(STDOUT_FILE)).unwrap(),
            "out\n"
        );
        assert_eq!(
            std::fs::read_to_string(dir.path().join(STDERR_FILE)).unwrap(),
            "err\n"
        );
        let attempts = std::fs::read_to_string(dir.path().join(ATTEMPTS_LOG)).unwrap();
        assert!(
            attempts.lines().last().unwrap().starts_with("end 3 "),
            "{attempts}"
        );
    }

    #[tokio::test]
    async fn terminate_kills_the_whole_group_even_a_child_that_ignores_sigterm() {
        let dir = tempfile::tempdir().unwrap();
        let mut executor = LocalExecutor::new();
        // A grandchild that ignores SIGTERM and would outlive its parent.
        let handle = executor
            .start(&spec(
                dir.path(),
                "sh -c 'trap \"\" TERM; sleep 60' & sleep 60",
            ))
            .unwrap();
        tokio::time::sleep(Duration::from_millis(200)).await;
        executor.stop(handle);
        let deadline = Instant::now() + TERMINATION_GRACE + Duration::from_secs(5);
        while process::group_exists(handle.pid) && Instant::now() < deadline {
            executor.reap();
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        assert!(!process::group_exists(handle.pid));
        // No exit status: the attempt did not finish.
        assert_eq!(executor.status_of(handle, dir.path()), JobStatus::Lost);
    }

    #[tokio::test]
    async fn an_unrecorded_job_is_found_by_its_attempts_log_and_killed() {
        let dir = tempfile::tempdir().unwrap();
        let handle = LocalExecutor::new()
            .start(&spec(dir.path(), "sleep 30"))
            .unwrap();
        tokio::time::sleep(Duration::from_millis(200)).await;
        // After a crash the job's wrapper is no child of the resumed orch (init reaps
        // it). Here it is this test's child, and its zombie would keep its group in
        // being until reaped, which the blocked runtime cannot do: reap it here.
        let pid = nix::unistd::Pid::from_raw(handle.pid as i32);
        let reaper = std::thread::spawn(move || nix::sys::wait::waitpid(pid, None));
        assert_eq!(kill_unrecorded(dir.path()), Some(handle.pid));
        let _ = reaper.join();
        assert!(!process::group_exists(handle.pid));
        // Nothing runs there any more: nothing to kill.
        assert_eq!(kill_unrecorded(dir.path()), None);
    }

    #[tokio::test]
    async fn a_job_started_by_another_executor_is_followed_by_handle() {
        let dir = tempfile::tempdir().unwrap();
        let handle = LocalExecutor::new()
            .start(&spec(dir.path(), "sleep 0.3; exit 0"))
            .unwrap();
        // A fresh executor, as after `orch` was killed and resumed.
        let mut fresh = LocalExecutor::new();
        assert_eq!(fresh.status_of(handle, dir.path()), JobStatus::Running);
        assert_eq!(
            wait(&mut fresh, handle, dir.path()).await,
            JobStatus::Exited(0)
        );
    }
}
