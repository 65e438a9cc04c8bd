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

use std::path::{Path, PathBuf};

use orch_adapters::CommandSpec;

pub use local::LocalExecutor;

/// File in the run directory where a job's wrapper writes the solver's exit status.
pub const EXIT_STATUS_FILE: &str = "exit_status";
/// Solver standard output, in the run directory.
pub const STDOUT_FILE: &str = "stdout.txt";
/// Solver standard error, in the run directory.
pub const STDERR_FILE: &str = "stderr.txt";
/// One line per attempt start and end, kept across attempts, in the run directory.
pub const ATTEMPTS_LOG: &str = "orch-attempts.log";

/// What to launch.
#[derive(Debug, Clone)]
pub struct LaunchSpec {
    /// The run directory, also the working directory.
    pub run_dir: PathBuf,
    /// The command the adapter describes.
    pub command: CommandSpec,
}

/// What a poll found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JobStatus {
    /// Still running.
    Running,
    /// The solver ended with this exit status.
    Exited(i32),
    /// The process is gone and left no exit status (killed, or the machine rebooted).
    Lost,
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

/// Reads the exit status a job's wrapper wrote, if it did.
pub fn read_exit_status(run_dir: &Path) -> Option<i32> {
    std::fs::read_to_string(run_dir.join(EXIT_STATUS_FILE))
        .ok()?
        .trim()
        .parse()
        .ok()
}
