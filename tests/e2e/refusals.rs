//! A command `orch` refuses changes nothing.

use std::process::Stdio;
use std::time::Duration;

use crate::support::{count, text, Project};

/// Two jobs on a fake LIGGGHTS (supervision only): `p000r0` fails at once, `p001r0`
/// runs for a minute, so the study has a failed job while its driver lives.
const STUDY: &str = "\
name: busy
solver: liggghts
executor: {max_parallel: 2, time_limit: 5min, retries: 0}
factors:
  - {name: amplitude, min: 0.0, max: 0.0006}
fixed: {n_particles: 400, fill_time: 0.1, discharge_time: 0.5, outlet_diameter: 0.020}
design: {type: full_factorial, levels: 2}
";

#[test]
fn a_refused_resume_retry_failed_leaves_the_failed_jobs_failed() {
    let mut project = Project::new();
    project.fake_program(
        "liggghts",
        "case \"$PWD\" in\n  */p000r0) echo 'ERROR: refused on purpose'; exit 1;;\n  *) sleep 60;;\nesac",
    );
    let file = project.write("busy.yaml", STUDY);
    let mut driver = project
        .orch(&["submit", file.to_str().unwrap()])
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    project.wait_for("busy", Duration::from_secs(60), |s| {
        count(s, "failed") == 1 && count(s, "running") == 1
    });
    let events = || project.query("SELECT COUNT(*) FROM job_events")[0][0].clone();
    let before = events();

    let output = project.run(&["resume", "busy", "--retry-failed"]);
    let stderr = text(&output.stderr);
    let refused = output.status.code();

    let status = project.status("busy");
    let after = events();
    // `orch cancel` kills the sleeping fake; the driver sees it and ends.
    project.run(&["cancel", "busy"]);
    driver.wait().unwrap();
    assert_ne!(refused, Some(0), "{stderr}");
    assert!(
        stderr.contains("is being run by another orch process"),
        "{stderr}"
    );
    assert_eq!(count(&status, "failed"), 1, "{status:#}");
    assert_eq!(count(&status, "pending"), 0, "{status:#}");
    assert_eq!(before, after, "the refused resume logged job events");
}

/// Two jobs on a fake LIGGGHTS that fails at once (supervision only).
const DAMAGED: &str = "\
name: damaged
solver: liggghts
executor: {max_parallel: 2, time_limit: 5min, retries: 0}
factors:
  - {name: amplitude, min: 0.0, max: 0.0006}
fixed: {n_particles: 400, fill_time: 0.1, discharge_time: 0.5, outlet_diameter: 0.020}
design: {type: full_factorial, levels: 2}
";

#[test]
fn a_job_state_this_orch_does_not_know_is_refused_by_status_export_and_resume() {
    let mut project = Project::new();
    project.fake_program("liggghts", "echo 'ERROR: refused on purpose'; exit 1");
    let file = project.write("damaged.yaml", DAMAGED);
    let output = project.run(&["submit", file.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(1), "{}", text(&output.stderr));
    // One job cancelled (a resume would run it again), one with a state from nowhere.
    project.execute("UPDATE jobs SET state = 'cancelled' WHERE name = 'p000r0'");
    project.execute("UPDATE jobs SET state = 'runnning' WHERE name = 'p001r0'");
    let id = &project.query("SELECT id FROM jobs WHERE name = 'p001r0'")[0][0];
    let expected = format!(
        "error: jobs row {id} has state `runnning`, which this orch does not know; the database was written by another version or damaged: use the orch that wrote it, or restore orch.db from a backup\n"
    );
    let snapshot = || {
        (
            project.query("SELECT name, state, attempts FROM jobs ORDER BY id"),
            project.query("SELECT COUNT(*) FROM job_events"),
            project.query("SELECT state, driver_pid FROM studies"),
        )
    };
    let before = snapshot();

    for args in [
        &["status", "damaged", "--json"][..],
        &["status", "damaged"],
        &["status"],
        &["export", "damaged"],
        &["resume", "damaged"],
    ] {
        let output = project.run(args);
        assert_eq!(output.status.code(), Some(3), "orch {args:?}");
        assert_eq!(text(&output.stderr), expected, "orch {args:?}");
        assert!(output.stdout.is_empty(), "orch {args:?}");
    }
    assert_eq!(snapshot(), before, "a refused command changed the store");
}
