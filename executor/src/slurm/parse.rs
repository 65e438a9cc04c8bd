//! What Slurm's commands print, parsed without running them (pure, tested on output
//! captured from Slurm 22.05).
//!
//! `squeue --json` changed shape across Slurm releases: 22.05 (OpenAPI v0.0.38) writes
//! `"job_state": "RUNNING"` and `"exit_code": 3`, later releases `"job_state":
//! ["RUNNING"]` and `"exit_code": {"return_code": {"number": 3, ...}}`. Both are read.
//! Where `--json` is missing, `squeue --array --format` text is read instead.
//!
//! Array tasks are jobs of their own to orch, named `<array job id>_<task id>` as
//! `squeue` and `scancel` name them. `squeue --json` lists the tasks that have started
//! one by one and the ones still pending as one record of the array with a task list
//! (`"array_task_string": "2-5,7"`); that record is expanded into one job per task.

use std::fmt;
use std::str::FromStr;

use serde_json::Value;

/// The `--format` that [`parse_squeue_text`] reads (with `--array`, one line per
/// task): id, state, reason, nodes.
pub const SQUEUE_TEXT_FORMAT: &str = "%i|%T|%r|%N";

/// A Slurm job (`123`) or one task of a job array (`123_4`), as `squeue` prints and
/// `scancel` takes it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct SlurmId {
    /// The job id; for an array task, the array's job id (`%A`).
    pub job: u64,
    /// The task's index within the array (`%a`), none for a plain job.
    pub task: Option<u32>,
}

impl SlurmId {
    /// A plain job.
    pub fn job(job: u64) -> SlurmId {
        SlurmId { job, task: None }
    }

    /// Task `task` of array job `job`.
    pub fn task(job: u64, task: u32) -> SlurmId {
        SlurmId {
            job,
            task: Some(task),
        }
    }
}

impl fmt::Display for SlurmId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.task {
            Some(task) => write!(f, "{}_{task}", self.job),
            None => write!(f, "{}", self.job),
        }
    }
}

impl FromStr for SlurmId {
    type Err = std::num::ParseIntError;

    /// Reads `123` or `123_4`.
    fn from_str(text: &str) -> Result<SlurmId, Self::Err> {
        match text.split_once('_') {
            Some((job, task)) => Ok(SlurmId::task(job.parse()?, task.parse()?)),
            None => Ok(SlurmId::job(text.parse()?)),
        }
    }
}

/// The task indices of an array task list as Slurm writes it: `2-5,7`, `0-99:2`,
/// with an optional `%N` limit of tasks running at once (ignored); `None` when it is
/// not such a list.
pub fn expand_task_list(list: &str) -> Option<Vec<u32>> {
    let list = list.split('%').next()?.trim();
    let list = list
        .strip_prefix('[')
        .and_then(|l| l.strip_suffix(']'))
        .unwrap_or(list);
    let mut tasks = Vec::new();
    for part in list.split(',') {
        let (range, step) = match part.split_once(':') {
            Some((range, step)) => (range, step.parse::<u32>().ok().filter(|s| *s > 0)?),
            None => (part, 1),
        };
        let (first, last) = match range.split_once('-') {
            Some((first, last)) => (first.parse::<u32>().ok()?, last.parse::<u32>().ok()?),
            None => {
                let task = range.parse::<u32>().ok()?;
                (task, task)
            }
        };
        if last < first {
            return None;
        }
        tasks.extend((first..=last).step_by(step as usize));
    }
    Some(tasks)
}

/// A job as `squeue` reports it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SlurmJob {
    /// The job, or the array task.
    pub id: SlurmId,
    /// Its state.
    pub state: SlurmState,
    /// Slurm's reason for the state (`Priority`, `TimeLimit`, `NonZeroExitCode`, …);
    /// empty when Slurm gives none.
    pub reason: String,
    /// Nodes it runs or ran on (`n1`, `n[1-2]`), empty while pending.
    pub nodes: String,
}

/// Slurm job states (`squeue` long names); the ones orch acts on are variants.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SlurmState {
    /// Waiting for resources or priority.
    Pending,
    /// Running.
    Running,
    /// The batch script ended; Slurm is cleaning up.
    Completing,
    /// Suspended by an administrator or preemption.
    Suspended,
    /// The batch script exited 0.
    Completed,
    /// The batch script exited non-zero.
    Failed,
    /// Killed at its time limit.
    Timeout,
    /// Cancelled with `scancel` (or by an administrator).
    Cancelled,
    /// A node it ran on failed.
    NodeFail,
    /// Preempted by a higher-priority job.
    Preempted,
    /// Killed for using more memory than it asked for.
    OutOfMemory,
    /// Its node could not be booted.
    BootFail,
    /// It could not finish before its deadline.
    Deadline,
    /// Any other state (`CONFIGURING`, `REQUEUED`, `RESIZING`, `SIGNALING`, …): not final.
    Other(String),
}

/// Slurm's long state names and short codes, one row per state orch names.
const STATE_NAMES: [(&str, &str, SlurmState); 13] = [
    ("PENDING", "PD", SlurmState::Pending),
    ("RUNNING", "R", SlurmState::Running),
    ("COMPLETING", "CG", SlurmState::Completing),
    ("SUSPENDED", "S", SlurmState::Suspended),
    ("COMPLETED", "CD", SlurmState::Completed),
    ("FAILED", "F", SlurmState::Failed),
    ("TIMEOUT", "TO", SlurmState::Timeout),
    ("CANCELLED", "CA", SlurmState::Cancelled),
    ("NODE_FAIL", "NF", SlurmState::NodeFail),
    ("PREEMPTED", "PR", SlurmState::Preempted),
    ("OUT_OF_MEMORY", "OOM", SlurmState::OutOfMemory),
    ("BOOT_FAIL", "BF", SlurmState::BootFail),
    ("DEADLINE", "DL", SlurmState::Deadline),
];

impl SlurmState {
    /// Reads Slurm's long state name (`RUNNING`) or short code (`R`).
    pub fn parse(text: &str) -> SlurmState {
        let text = text.trim();
        STATE_NAMES
            .iter()
            .find(|(long, short, _)| text == *long || text == *short)
            .map_or_else(
                || SlurmState::Other(text.to_string()),
                |(_, _, state)| state.clone(),
            )
    }

    /// True once Slurm will not run the job again by itself.
    pub fn is_final(&self) -> bool {
        !matches!(
            self,
            SlurmState::Pending
                | SlurmState::Running
                | SlurmState::Completing
                | SlurmState::Suspended
                | SlurmState::Other(_)
        )
    }

    /// Slurm's long name.
    pub fn name(&self) -> &str {
        match self {
            SlurmState::Other(name) => name,
            known => STATE_NAMES
                .iter()
                .find(|(_, _, state)| state == known)
                .map_or("", |(long, _, _)| long),
        }
    }
}

impl SlurmJob {
    /// What `orch status` shows: `RUNNING on n1`, `PENDING (Priority)`, `TIMEOUT
    /// (TimeLimit) on n2`.
    pub fn describe(&self) -> String {
        let mut text = self.state.name().to_string();
        if !self.reason.is_empty() && self.reason != "None" {
            text.push_str(&format!(" ({})", self.reason));
        }
        if !self.nodes.is_empty() {
            text.push_str(&format!(" on {}", self.nodes));
        }
        text
    }
}

/// Output a Slurm command printed that orch cannot read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("cannot read the output of `{command}`: {problem}")]
pub struct ParseError {
    /// The command.
    pub command: &'static str,
    /// What was wrong.
    pub problem: String,
}

/// The job id `sbatch --parsable` printed: `123`, or `123;cluster` on a federation.
pub fn parse_sbatch_output(stdout: &str) -> Result<u64, ParseError> {
    let line = stdout.lines().map(str::trim).find(|l| !l.is_empty());
    let id = line.and_then(|l| l.split(';').next()).unwrap_or("");
    id.parse().map_err(|_| ParseError {
        command: "sbatch --parsable",
        problem: format!("expected a job id, got {:?}", stdout.trim()),
    })
}

/// `MaxArraySize` from `scontrol show config` (`MaxArraySize            = 1001`).
pub fn parse_max_array_size(config: &str) -> Option<usize> {
    config.lines().find_map(|line| {
        let (key, value) = line.split_once('=')?;
        (key.trim() == "MaxArraySize").then(|| value.trim().parse().ok())?
    })
}

/// The jobs of `squeue --json` (every job slurmctld still holds, any user), array
/// tasks one by one.
pub fn parse_squeue_json(text: &str) -> Result<Vec<SlurmJob>, ParseError> {
    let problem = |problem: String| ParseError {
        command: "squeue --json",
        problem,
    };
    let value: Value = serde_json::from_str(text).map_err(|e| problem(format!("not JSON: {e}")))?;
    if let Some(error) = value["errors"].as_array().and_then(|errors| errors.first()) {
        return Err(problem(format!("Slurm reported an error: {error}")));
    }
    let records = value["jobs"]
        .as_array()
        .ok_or_else(|| problem("no `jobs` array".to_string()))?;
    let mut jobs = Vec::with_capacity(records.len());
    for job in records {
        let id = number(&job["job_id"])
            .ok_or_else(|| problem(format!("a job without a numeric job_id: {job}")))?;
        let state = match &job["job_state"] {
            Value::String(name) => name.clone(),
            // Later releases: a list of the base state and flags; the base comes first.
            Value::Array(names) => names
                .first()
                .and_then(Value::as_str)
                .unwrap_or("")
                .to_string(),
            _ => return Err(problem(format!("job {id} has no job_state"))),
        };
        let array = number(&job["array_job_id"]).filter(|&array| array != 0);
        let task = number(&job["array_task_id"]).and_then(|t| u32::try_from(t).ok());
        let pending_tasks = job["array_task_string"]
            .as_str()
            .filter(|list| !list.is_empty());
        let ids = match (array, task, pending_tasks) {
            (Some(array), Some(task), _) => vec![SlurmId::task(array, task)],
            (Some(array), None, Some(list)) => expand_task_list(list)
                .ok_or_else(|| problem(format!("array job {array} has the task list {list:?}")))?
                .into_iter()
                .map(|task| SlurmId::task(array, task))
                .collect(),
            _ => vec![SlurmId::job(id)],
        };
        for id in ids {
            jobs.push(SlurmJob {
                id,
                state: SlurmState::parse(&state),
                reason: job["state_reason"].as_str().unwrap_or("").to_string(),
                nodes: job["nodes"].as_str().unwrap_or("").to_string(),
            });
        }
    }
    Ok(jobs)
}

/// A number written plainly, or as later releases' `{"set": true, "number": N}`.
fn number(value: &Value) -> Option<u64> {
    value.as_u64().or_else(|| {
        value["set"]
            .as_bool()
            .filter(|set| *set)
            .and(value["number"].as_u64())
    })
}

/// The jobs of `squeue --array --noheader --states=all --format=`[`SQUEUE_TEXT_FORMAT`],
/// array tasks (`123_4`) included; a line of pending tasks (`123_[5-9]`, printed
/// without `--array`) is expanded.
pub fn parse_squeue_text(text: &str) -> Result<Vec<SlurmJob>, ParseError> {
    let mut jobs = Vec::new();
    for line in text.lines().filter(|l| !l.trim().is_empty()) {
        let fields: Vec<&str> = line.trim().split('|').collect();
        let [id, state, reason, nodes] = fields[..] else {
            return Err(ParseError {
                command: "squeue --format",
                problem: format!("expected 4 fields separated by |, got {line:?}"),
            });
        };
        let ids = match id.split_once("_[") {
            Some((array, list)) => {
                match (array.parse(), expand_task_list(list.trim_end_matches(']'))) {
                    (Ok(array), Some(tasks)) => {
                        tasks.into_iter().map(|t| SlurmId::task(array, t)).collect()
                    }
                    _ => Vec::new(),
                }
            }
            None => id.parse().into_iter().collect(),
        };
        for id in ids {
            jobs.push(SlurmJob {
                id,
                state: SlurmState::parse(state),
                reason: reason.to_string(),
                nodes: nodes.to_string(),
            });
        }
    }
    Ok(jobs)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `squeue --json` of Slurm 22.05.8 on this project's test cluster, cut to the fields
    /// orch reads plus neighbours: a failed, a timed-out, a cancelled, a completed, a
    /// running and a pending job.
    const SQUEUE_22_05: &str = include_str!("testdata/squeue-22.05.json");

    #[test]
    fn squeue_json_of_slurm_22_05_gives_every_state_and_reason() {
        let jobs = parse_squeue_json(SQUEUE_22_05).unwrap();
        let described: Vec<(u64, String)> = jobs.iter().map(|j| (j.id.job, j.describe())).collect();
        assert_eq!(
            described,
            vec![
                (1, "FAILED (NonZeroExitCode) on n1".to_string()),
                (3, "TIMEOUT (TimeLimit) on n1".to_string()),
                (4, "CANCELLED on n2".to_string()),
                (5, "COMPLETED on n2".to_string()),
                (7, "RUNNING on n2".to_string()),
                (8, "PENDING (Resources)".to_string()),
            ]
        );
        assert!(jobs[..4].iter().all(|j| j.state.is_final()));
        assert!(jobs[4..].iter().all(|j| !j.state.is_final()));
    }

    #[test]
    fn squeue_json_of_later_releases_with_state_lists_and_set_numbers() {
        let text = r#"{"jobs": [{"job_id": 42, "job_state": ["OUT_OF_MEMORY"],
            "state_reason": "OutOfMemory", "nodes": "c3",
            "exit_code": {"status": ["OUT_OF_MEMORY"], "return_code": {"set": true, "infinite": false, "number": 0}}},
            {"job_id": {"set": true, "number": 43}, "job_state": ["PENDING", "REQUEUED"], "state_reason": "BeginTime", "nodes": ""}],
            "errors": []}"#;
        let jobs = parse_squeue_json(text).unwrap();
        assert_eq!(jobs[0].state, SlurmState::OutOfMemory);
        assert_eq!(jobs[1].id, SlurmId::job(43));
        assert_eq!(jobs[1].describe(), "PENDING (BeginTime)");
    }

    #[test]
    fn squeue_errors_and_garbage_are_reported_not_taken_for_an_empty_queue() {
        let error = parse_squeue_json(
            r#"{"errors": [{"error": "Unable to contact slurm controller"}], "jobs": []}"#,
        )
        .unwrap_err();
        assert!(
            error
                .to_string()
                .contains("Unable to contact slurm controller"),
            "{error}"
        );
        assert!(parse_squeue_json("squeue: error: unrecognized option '--json'").is_err());
        assert!(parse_squeue_json(r#"{"jobs": [{"job_id": 1}]}"#).is_err());
        assert!(parse_squeue_text("12|RUNNING|None").is_err());
    }

    #[test]
    fn squeue_text_reads_array_tasks_and_skips_blank_lines() {
        let jobs = parse_squeue_text(
            "12|RUNNING|None|n1\n\n13_[1-3]|PENDING|Priority|\n13_0|RUNNING|None|n2\n14|NODE_FAIL|NodeDown|n2\n",
        )
        .unwrap();
        let ids: Vec<String> = jobs.iter().map(|j| j.id.to_string()).collect();
        assert_eq!(ids, ["12", "13_1", "13_2", "13_3", "13_0", "14"]);
        assert_eq!(jobs[3].describe(), "PENDING (Priority)");
        assert_eq!(jobs[5].state, SlurmState::NodeFail);
        assert_eq!(jobs[5].describe(), "NODE_FAIL (NodeDown) on n2");
    }

    /// `squeue --json` of Slurm 22.05.8 on the two-node test cluster, cut to the fields
    /// orch reads: a plain job, an array of six tasks of which four have completed and
    /// two run (the last in the array's own record, job id 404), and a second array
    /// whose six tasks all still wait in one record.
    const SQUEUE_ARRAY_22_05: &str = include_str!("testdata/squeue-array-22.05.json");

    #[test]
    fn squeue_json_lists_started_array_tasks_and_expands_pending_ones() {
        let jobs = parse_squeue_json(SQUEUE_ARRAY_22_05).unwrap();
        let described: Vec<(String, String)> = jobs
            .iter()
            .map(|j| (j.id.to_string(), j.describe()))
            .collect();
        assert_eq!(
            described,
            [
                ("403", "COMPLETED on n[1-2]"),
                ("404_0", "COMPLETED on n1"),
                ("404_1", "COMPLETED on n2"),
                ("404_2", "COMPLETED on n1"),
                ("404_3", "COMPLETED on n2"),
                ("404_4", "RUNNING on n1"),
                ("404_5", "RUNNING on n2"),
                ("410_0", "PENDING (Resources)"),
                ("410_1", "PENDING (Resources)"),
                ("410_2", "PENDING (Resources)"),
                ("410_3", "PENDING (Resources)"),
                ("410_4", "PENDING (Resources)"),
                ("410_5", "PENDING (Resources)"),
            ]
            .map(|(id, state)| (id.to_string(), state.to_string()))
        );
    }

    #[test]
    fn array_task_lists_expand_ranges_steps_and_single_tasks() {
        assert_eq!(expand_task_list("2-5"), Some(vec![2, 3, 4, 5]));
        assert_eq!(expand_task_list("0-6:3,9"), Some(vec![0, 3, 6, 9]));
        assert_eq!(expand_task_list("[1-2]%1"), Some(vec![1, 2]));
        assert_eq!(expand_task_list("7"), Some(vec![7]));
        assert_eq!(expand_task_list("5-2"), None);
        assert_eq!(expand_task_list("a-b"), None);
        assert_eq!(expand_task_list("0-4:0"), None);
    }

    #[test]
    fn slurm_ids_read_back_as_written() {
        for text in ["123", "123_0", "9_1000"] {
            assert_eq!(text.parse::<SlurmId>().unwrap().to_string(), text);
        }
        assert!("123_".parse::<SlurmId>().is_err());
        assert!("x".parse::<SlurmId>().is_err());
        assert!("12_[1-3]".parse::<SlurmId>().is_err());
    }

    #[test]
    fn sbatch_prints_an_id_or_an_id_and_cluster() {
        assert_eq!(parse_sbatch_output("1234\n"), Ok(1234));
        assert_eq!(parse_sbatch_output("1234;orch\n"), Ok(1234));
        assert!(parse_sbatch_output("sbatch: error: Batch job submission failed").is_err());
        assert!(parse_sbatch_output("").is_err());
    }

    #[test]
    fn max_array_size_is_read_from_scontrol_show_config() {
        let config = "MaxArraySize            = 1001\nMaxJobCount             = 10000\n";
        assert_eq!(parse_max_array_size(config), Some(1001));
        assert_eq!(parse_max_array_size("MaxJobCount = 10\n"), None);
    }

    #[test]
    fn every_state_name_reads_back() {
        for name in [
            "PENDING",
            "RUNNING",
            "COMPLETING",
            "SUSPENDED",
            "COMPLETED",
            "FAILED",
            "TIMEOUT",
            "CANCELLED",
            "NODE_FAIL",
            "PREEMPTED",
            "OUT_OF_MEMORY",
            "BOOT_FAIL",
            "DEADLINE",
            "CONFIGURING",
        ] {
            assert_eq!(SlurmState::parse(name).name(), name);
        }
        assert_eq!(SlurmState::parse("R"), SlurmState::Running);
    }
}
