//! The driver's decisions, as pure functions from jobs to actions.
//!
//! After HyperQueue's scheduler core (`run_scheduling_inner(core, comm, now)`) and
//! argmin's split of the step from the executor: every function here takes the jobs as
//! the store holds them, what the executor reported, the study's [`Budgets`] and the
//! time, and returns the [`Action`]s to take, in order. Nothing here reads the store,
//! the clock, the file system or an executor; [`crate::driver`] reads them, calls these
//! functions and applies their actions. So every transition is tested in
//! milliseconds, without processes or a database.
//!
//! A tick of the driver uses them in this order: [`on_reports`] for the jobs it polled,
//! then (on the jobs read again) [`settle_and_launch`], then [`is_finished`]. Ctrl-C
//! uses [`on_interrupt`], `orch cancel` from elsewhere [`on_cancel`]; a successful run
//! whose output cannot be read goes through [`retry_or_fail`]; a DEM run of a coupled
//! chain through [`coupling_settled`] and [`on_chain_settled`].

use std::collections::{HashMap, HashSet};
use std::time::Duration;

use crate::executor::{JobStatus, Report, StopCause};
use crate::store::{JobRow, JobState};

/// What bounds a study's jobs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Budgets {
    /// At most this many jobs submitted or running at once.
    pub max_parallel: usize,
    /// Attempts a failing job gets after its first.
    pub retries: u32,
    /// Wall time of one attempt.
    pub time_limit: Option<Duration>,
    /// True when a batch scheduler runs the jobs: it enforces the time limit itself,
    /// and its jobs outlive orch.
    pub batch: bool,
    /// Cores the launched jobs may use together (local: this machine's); none when a
    /// batch scheduler places the jobs. A job wider than the whole budget still runs,
    /// alone, rather than never.
    pub cores: Option<usize>,
}

/// Why an attempt failed; the driver adds what the run's output says
/// ([`crate::driver::failure_summary`]) where there is output to read.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Failure {
    /// The solver exited with this non-zero status.
    Exited(i32),
    /// The batch scheduler stopped it (TIMEOUT, NODE_FAIL, …), with its reason.
    Stopped(String),
    /// It ended without an exit status.
    Lost,
    /// It ran past the study's time limit and is being terminated.
    TimeLimit(Duration),
    /// It exited 0 but its results cannot be had; the reason is complete.
    Unreadable(String),
}

impl Failure {
    /// The exit code a failed job keeps.
    pub fn exit_code(&self) -> Option<i32> {
        match self {
            Failure::Exited(code) => Some(*code),
            Failure::Unreadable(_) => Some(0),
            Failure::Stopped(_) | Failure::Lost | Failure::TimeLimit(_) => None,
        }
    }
}

/// Why a job is cancelled.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum CancelCause {
    /// The batch scheduler cancelled it (outside orch), with its reason.
    Scheduler(String),
    /// Its upstream job, named here, was cancelled (a stage).
    Upstream(String),
    /// `orch cancel` cancelled the study.
    Study,
    /// The coupled chain it belongs to has settled before it: the note says where and
    /// by how much ([`on_chain_settled`]).
    Settled(String),
}

/// One thing the driver does to one job.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Action {
    /// Record what the batch scheduler now says about the job (not a transition).
    NoteSchedulerState {
        /// The job's id.
        job: i64,
        /// The scheduler's words.
        state: String,
    },
    /// submitted → running: the scheduler started it.
    MarkStarted {
        /// The job's id.
        job: i64,
    },
    /// It exited 0: read its results and store them (or retry or fail it when they
    /// cannot be read, through [`retry_or_fail`]).
    Collect {
        /// The job's id.
        job: i64,
    },
    /// Stop the job's processes (local: SIGTERM, then SIGKILL; Slurm: `scancel`);
    /// it is not launched again until they are gone.
    Terminate {
        /// The job's id.
        job: i64,
        /// Its executor handle.
        handle: String,
    },
    /// Its attempt failed and the budget allows another: back to pending.
    Retry {
        /// The job's id.
        job: i64,
        /// The attempt that failed, from 1.
        attempt: i64,
        /// Attempts allowed in all (1 + retries).
        budget: i64,
        /// Why.
        failure: Failure,
    },
    /// Its attempt failed and the budget is spent: failed for good.
    Fail {
        /// The job's id.
        job: i64,
        /// Why.
        failure: Failure,
    },
    /// A stage whose upstream job failed: failed, having no inputs.
    FailOrphan {
        /// The stage job's id.
        job: i64,
        /// The upstream job's name.
        upstream: String,
    },
    /// Cancelled.
    Cancel {
        /// The job's id.
        job: i64,
        /// Why.
        cause: CancelCause,
    },
    /// Back to pending with its attempt refunded: the user interrupted it.
    Requeue {
        /// The job's id.
        job: i64,
    },
    /// Render and launch it.
    Launch {
        /// The job's id.
        job: i64,
    },
}

impl Action {
    /// The id of the job it is about.
    pub fn job(&self) -> i64 {
        match self {
            Action::NoteSchedulerState { job, .. }
            | Action::MarkStarted { job }
            | Action::Collect { job }
            | Action::Terminate { job, .. }
            | Action::Retry { job, .. }
            | Action::Fail { job, .. }
            | Action::FailOrphan { job, .. }
            | Action::Cancel { job, .. }
            | Action::Requeue { job }
            | Action::Launch { job } => *job,
        }
    }
}

/// True while a job holds a slot of `max_parallel`: handed to the executor, not final.
pub fn is_launched(state: JobState) -> bool {
    state.is_launched()
}

/// Another attempt if the budget allows, else failed: `attempts` counts the attempt
/// that just failed, and a job gets `1 + retries` in all.
pub fn retry_or_fail(job: &JobRow, budgets: &Budgets, failure: Failure) -> Action {
    let budget = 1 + i64::from(budgets.retries);
    if job.attempts < budget {
        Action::Retry {
            job: job.id,
            attempt: job.attempts,
            budget,
            failure,
        }
    } else {
        Action::Fail {
            job: job.id,
            failure,
        }
    }
}

/// What to do about each polled job given its report, at `now` (Unix seconds), in the
/// order of `polled`. A lost attempt spends the retry budget like any failure, or a
/// solver that loses its own exit status would run again for ever.
pub fn on_reports(polled: &[(&JobRow, Report)], budgets: &Budgets, now: f64) -> Vec<Action> {
    let mut actions = Vec::new();
    for (job, report) in polled {
        if let Some(state) = &report.scheduler_state {
            if job.scheduler_state.as_deref() != Some(state.as_str()) {
                actions.push(Action::NoteSchedulerState {
                    job: job.id,
                    state: state.clone(),
                });
            }
        }
        match &report.status {
            JobStatus::Queued => {}
            JobStatus::Running if job.state == JobState::Submitted => {
                actions.push(Action::MarkStarted { job: job.id });
            }
            JobStatus::Running => actions.extend(time_limit(job, budgets, now)),
            JobStatus::Exited(0) => actions.push(Action::Collect { job: job.id }),
            JobStatus::Exited(code) => {
                actions.push(retry_or_fail(job, budgets, Failure::Exited(*code)));
            }
            JobStatus::Stopped {
                cause: StopCause::Cancelled,
                reason,
            } => actions.push(Action::Cancel {
                job: job.id,
                cause: CancelCause::Scheduler(reason.clone()),
            }),
            JobStatus::Stopped { reason, .. } => {
                actions.push(retry_or_fail(
                    job,
                    budgets,
                    Failure::Stopped(reason.clone()),
                ));
            }
            JobStatus::Lost => actions.push(retry_or_fail(job, budgets, Failure::Lost)),
        }
    }
    actions
}

/// A running local job past its time limit is terminated and retried or failed; a
/// batch scheduler enforces the limit itself. A job without a start time has just
/// started.
fn time_limit(job: &JobRow, budgets: &Budgets, now: f64) -> Vec<Action> {
    let Some(limit) = budgets.time_limit else {
        return Vec::new();
    };
    let elapsed = now - job.started_at.unwrap_or(now);
    if budgets.batch || elapsed <= limit.as_secs_f64() {
        return Vec::new();
    }
    let mut actions = Vec::new();
    if let Some(handle) = &job.executor_handle {
        actions.push(Action::Terminate {
            job: job.id,
            handle: handle.clone(),
        });
    }
    actions.push(retry_or_fail(job, budgets, Failure::TimeLimit(limit)));
    actions
}

/// Settles pending stages whose upstream job failed or was cancelled (they follow it:
/// nothing can feed them), then launches pending jobs in id order while slots are
/// free and, under a core budget, while the cores of launched jobs (`cores_of` a job)
/// fit in it. A stage job is ready only once its upstream job succeeded; a job in
/// `terminating` (its last attempt may still be dying in its run directory) waits.
/// Launching stops at the first ready job that does not fit, so a wide job is not
/// passed over for ever by narrower ones behind it.
pub fn settle_and_launch(
    jobs: &[JobRow],
    budgets: &Budgets,
    terminating: &HashSet<i64>,
    cores_of: impl Fn(&JobRow) -> usize,
) -> Vec<Action> {
    let by_id: HashMap<i64, &JobRow> = jobs.iter().map(|j| (j.id, j)).collect();
    let upstream = |job: &JobRow| job.after_job_id.and_then(|id| by_id.get(&id).copied());
    let mut actions = Vec::new();
    for job in jobs.iter().filter(|j| j.state == JobState::Pending) {
        match upstream(job) {
            Some(up) if up.state == JobState::Failed => actions.push(Action::FailOrphan {
                job: job.id,
                upstream: up.name.clone(),
            }),
            Some(up) if up.state == JobState::Cancelled => actions.push(Action::Cancel {
                job: job.id,
                cause: CancelCause::Upstream(up.name.clone()),
            }),
            _ => {}
        }
    }
    let ready = |job: &JobRow| {
        job.after_job_id.is_none()
            || upstream(job).is_some_and(|up| up.state == JobState::Succeeded)
    };
    let launched = jobs.iter().filter(|j| is_launched(j.state)).count();
    let free = budgets.max_parallel.saturating_sub(launched);
    let mut used: usize = jobs
        .iter()
        .filter(|j| is_launched(j.state))
        .map(&cores_of)
        .sum();
    let candidates = jobs
        .iter()
        .filter(|j| j.state == JobState::Pending && !terminating.contains(&j.id))
        .filter(|j| ready(j))
        .take(free);
    for job in candidates {
        let need = cores_of(job).max(1);
        if let Some(budget) = budgets.cores {
            if used > 0 && used + need > budget {
                break;
            }
        }
        used += need;
        actions.push(Action::Launch { job: job.id });
    }
    actions
}

/// True when every job is final.
pub fn is_finished(jobs: &[JobRow]) -> bool {
    jobs.iter().all(|j| j.state.is_final())
}

/// Ctrl-C or SIGTERM: local jobs that run (or were rendered) are terminated and put
/// back with their attempt refunded; on a batch scheduler submitted and running jobs
/// keep running there (`orch resume` re-attaches) and only rendered ones are put back.
pub fn on_interrupt(jobs: &[JobRow], budgets: &Budgets) -> Vec<Action> {
    let mut actions = Vec::new();
    for job in jobs {
        let stop = if budgets.batch {
            job.state == JobState::Rendered
        } else {
            matches!(job.state, JobState::Running | JobState::Rendered)
        };
        if !stop {
            continue;
        }
        if let (false, Some(handle)) = (budgets.batch, &job.executor_handle) {
            actions.push(Action::Terminate {
                job: job.id,
                handle: handle.clone(),
            });
        }
        actions.push(Action::Requeue { job: job.id });
    }
    actions
}

/// The study was cancelled by `orch cancel`: every unfinished job's processes are
/// terminated (all first, so a batch scheduler gets one call), then every unfinished
/// job is cancelled.
pub fn on_cancel(jobs: &[JobRow]) -> Vec<Action> {
    let unfinished = || jobs.iter().filter(|j| !j.state.is_final());
    let terminate = unfinished().filter_map(|j| {
        j.executor_handle.as_ref().map(|handle| Action::Terminate {
            job: j.id,
            handle: handle.clone(),
        })
    });
    let cancel = unfinished().map(|j| Action::Cancel {
        job: j.id,
        cause: CancelCause::Study,
    });
    terminate.chain(cancel).collect()
}

#[cfg(test)]
mod tests;

/// The relative change of the coupling's response from the DEM run `before` to the
/// one `now` (each run in the air of the CFD run before it) when it is below
/// `tolerance`, the chain having settled; `None` while it has not (or when the change
/// cannot be told: a zero or non-finite response).
pub fn coupling_settled(before: f64, now: f64, tolerance: f64) -> Option<f64> {
    let change = ((now - before) / before).abs();
    (before != 0.0 && change.is_finite() && change < tolerance).then_some(change)
}

/// A coupled chain settled at job `settled` (`note` says how): the pending job that
/// follows it is cancelled, and with it (through [`settle_and_launch`]'s upstream
/// rule) the rest of the chain.
pub fn on_chain_settled(jobs: &[JobRow], settled: i64, note: &str) -> Vec<Action> {
    jobs.iter()
        .filter(|j| j.after_job_id == Some(settled) && j.state() == JobState::Pending)
        .map(|j| Action::Cancel {
            job: j.id,
            cause: CancelCause::Settled(note.to_string()),
        })
        .collect()
}
