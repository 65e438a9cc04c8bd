//! `kill -9` of orch mid-study, Ctrl-C, and `orch resume`: nothing lost, nothing run twice.

use std::process::Stdio;
use std::time::Duration;

use crate::support::{count, require_liggghts, solver_lock, text, Project};

/// Six short LIGGGHTS runs (400 particles, ~3 s each), two at a time.
const SHORT_STUDY: &str = "\
name: short
solver: liggghts
executor: {max_parallel: 2, time_limit: 2min}
factors:
  - {name: amplitude, min: 0.0, max: 0.0006}
fixed: {n_particles: 400, fill_time: 0.1, discharge_time: 0.5, outlet_diameter: 0.020}
design: {type: full_factorial, levels: 3}
replicates: 2
";

/// Every run directory's attempts log shows exactly one successful end.
fn assert_each_job_completed_once(project: &Project) {
    for row in project.query("SELECT name, run_dir FROM jobs") {
        let log = std::fs::read_to_string(std::path::Path::new(&row[1]).join("orch-attempts.log"))
            .unwrap();
        let completions = log.lines().filter(|l| l.starts_with("end 0 ")).count();
        assert_eq!(
            completions, 1,
            "job {} ran to completion {completions} times:\n{log}",
            row[0]
        );
    }
    let twice = project.query(
        "SELECT job_id, COUNT(*) FROM job_events WHERE to_state = 'succeeded' GROUP BY job_id HAVING COUNT(*) <> 1",
    );
    assert!(
        twice.is_empty(),
        "jobs recorded as succeeded more than once: {twice:?}"
    );
}

#[test]
fn sigkill_mid_study_then_resume_finishes_every_job_once() {
    if !require_liggghts() {
        return;
    }
    let _lock = solver_lock();
    let project = Project::new();
    let file = project.write("short.yaml", SHORT_STUDY);
    let mut orch = project
        .orch(&["submit", file.to_str().unwrap()])
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // Kill it while some jobs are done and others run.
    let before = project.wait_for("short", Duration::from_secs(120), |s| {
        count(s, "succeeded") >= 1 && count(s, "running") >= 1
    });
    orch.kill().unwrap();
    orch.wait().unwrap();
    eprintln!(
        "killed orch with {} succeeded, {} running, {} pending",
        count(&before, "succeeded"),
        count(&before, "running"),
        count(&before, "pending")
    );
    let after_kill = project.status("short");
    assert!(
        count(&after_kill, "succeeded") < 6,
        "the study finished before orch was killed"
    );

    let output = project.run(&["resume", "short"]);
    assert_eq!(output.status.code(), Some(0), "{}", text(&output.stderr));
    let status = project.status("short");
    assert_eq!(count(&status, "succeeded"), 6, "{status:#}");
    assert_eq!(status["study"]["state"], "finished");
    assert_each_job_completed_once(&project);
}

#[test]
fn ctrl_c_stops_running_jobs_and_resume_runs_them_again() {
    if !require_liggghts() {
        return;
    }
    let _lock = solver_lock();
    let project = Project::new();
    let file = project.write("short.yaml", SHORT_STUDY);
    let orch = project
        .orch(&["submit", file.to_str().unwrap()])
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    project.wait_for("short", Duration::from_secs(120), |s| {
        count(s, "running") >= 1
    });
    let running: Vec<String> = project
        .query("SELECT executor_handle FROM jobs WHERE state = 'running'")
        .into_iter()
        .map(|r| r[0].clone())
        .collect();
    let kill = std::process::Command::new("kill")
        .args(["-INT", &orch.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let output = orch.wait_with_output().unwrap();
    assert_eq!(output.status.code(), Some(130), "{}", text(&output.stderr));
    let status = project.status("short");
    assert_eq!(status["study"]["state"], "interrupted");
    assert_eq!(count(&status, "running"), 0);
    // The interrupted solvers are gone, and their attempts were not spent.
    for handle in running {
        let pid = handle.split(':').next().unwrap();
        assert!(
            !std::path::Path::new(&format!("/proc/{pid}")).exists()
                || std::fs::read_to_string(format!("/proc/{pid}/stat"))
                    .unwrap()
                    .contains(") Z "),
            "solver {pid} still runs"
        );
    }
    for job in status["jobs"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|j| j["state"] == "pending")
    {
        assert_eq!(job["attempts"], 0, "{job}");
    }
    let output = project.run(&["resume", "short"]);
    assert_eq!(output.status.code(), Some(0), "{}", text(&output.stderr));
    assert_eq!(count(&project.status("short"), "succeeded"), 6);
    assert_each_job_completed_once(&project);
}

#[test]
fn cancel_from_another_shell_stops_the_study_and_resume_finishes_it() {
    if !require_liggghts() {
        return;
    }
    let _lock = solver_lock();
    let project = Project::new();
    let file = project.write("short.yaml", SHORT_STUDY);
    let orch = project
        .orch(&["submit", file.to_str().unwrap()])
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    project.wait_for("short", Duration::from_secs(120), |s| {
        count(s, "running") >= 1
    });
    let cancel = project.run(&["cancel", "short"]);
    assert!(cancel.status.success(), "{}", text(&cancel.stderr));
    let output = orch.wait_with_output().unwrap();
    assert_eq!(output.status.code(), Some(1), "{}", text(&output.stderr));
    let status = project.status("short");
    assert_eq!(status["study"]["state"], "cancelled");
    assert!(count(&status, "cancelled") >= 1);
    assert_eq!(count(&status, "running") + count(&status, "pending"), 0);
    let output = project.run(&["resume", "short"]);
    assert_eq!(output.status.code(), Some(0), "{}", text(&output.stderr));
    assert_eq!(count(&project.status("short"), "succeeded"), 6);
}

/// Two jobs on a fake LIGGGHTS that sleeps (supervision only).
const SLEEPY_STUDY: &str = "\
name: sleepy
solver: liggghts
executor: {max_parallel: 2, time_limit: 5min, retries: 0}
factors:
  - {name: amplitude, min: 0.0, max: 0.0006}
fixed: {n_particles: 400, fill_time: 0.1, discharge_time: 0.5, outlet_diameter: 0.020}
design: {type: full_factorial, levels: 2}
";

#[test]
fn status_says_when_no_driver_is_alive_after_sigkill() {
    let mut project = Project::new();
    project.fake_program("liggghts", "sleep 60");
    let file = project.write("sleepy.yaml", SLEEPY_STUDY);
    let mut orch = project
        .orch(&["submit", file.to_str().unwrap()])
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let alive = project.wait_for("sleepy", Duration::from_secs(60), |s| {
        count(s, "running") == 2
    });
    orch.kill().unwrap();
    orch.wait().unwrap();

    let dead = project.status("sleepy");
    let table = text(&project.run(&["status", "sleepy"]).stdout);
    let overview = project.run(&["status", "--json"]);
    let overview: serde_json::Value = serde_json::from_slice(&overview.stdout).unwrap();
    let overview_table = text(&project.run(&["status"]).stdout);
    // The fakes still sleep; `orch cancel` kills them.
    project.run(&["cancel", "sleepy"]);

    assert_eq!(alive["study"]["driver"]["alive"], true, "{alive:#}");
    assert_eq!(
        alive["study"]["driver"]["pid"],
        i64::from(orch.id()),
        "{alive:#}"
    );
    assert!(alive["study"]["note"].is_null(), "{alive:#}");

    let note = format!(
        "no orch process drives study `sleepy` (its driver, pid {}, is gone): its running jobs are not followed and its pending jobs do not start; `orch resume sleepy` continues it",
        orch.id()
    );
    assert_eq!(dead["study"]["state"], "active", "{dead:#}");
    assert_eq!(count(&dead, "running"), 2, "{dead:#}");
    assert_eq!(dead["study"]["driver"]["alive"], false, "{dead:#}");
    assert_eq!(dead["study"]["note"], note.as_str(), "{dead:#}");
    assert_eq!(
        table.lines().nth(1),
        Some(note.as_str()),
        "the note follows the study's line:\n{table}"
    );
    assert_eq!(
        overview["studies"][0]["note"],
        note.as_str(),
        "{overview:#}"
    );
    assert_eq!(overview["studies"][0]["driver"]["alive"], false);
    assert!(
        overview_table.lines().any(|line| line == note),
        "{overview_table}"
    );
}
