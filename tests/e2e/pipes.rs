//! `orch` writing into a pipe whose reader has gone (`orch status | head -1`): no
//! panic, a sane exit code, and a running study goes on to the end. On a terminal, a
//! progress bar per round; into a pipe, plain lines.

use std::process::{Command, Output, Stdio};

use crate::support::{count, text, Project};

/// A native study of two tiny runs.
const TINY: &str = "\
name: piped
solver: native
executor: {max_parallel: 1, time_limit: 1min, retries: 0}
factors:
  - {name: outlet_diameter, min: 0.020, max: 0.024, unit: m}
fixed: {n_particles: 30, fill_time: 0.05, discharge_time: 0.1}
design: {type: full_factorial, levels: 2}
seed: 3
";

/// Runs `command` with its standard output a pipe closed before it writes anything;
/// stderr is captured unless `close_stderr`, then it is a closed pipe too.
fn into_closed_pipe(mut command: Command, close_stderr: bool) -> Output {
    let mut child = command
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    if close_stderr {
        drop(child.stderr.take());
    }
    child.wait_with_output().unwrap()
}

#[test]
fn status_into_a_closed_pipe_ends_quietly_with_success() {
    let project = Project::new();
    let file = project.write("piped.yaml", TINY);
    let submitted = project.run(&["submit", file.to_str().unwrap()]);
    assert_eq!(
        submitted.status.code(),
        Some(0),
        "{}",
        text(&submitted.stderr)
    );
    for args in [
        vec!["status"],
        vec!["status", "--json"],
        vec!["status", "piped"],
        vec!["status", "piped", "--json"],
        vec!["logs", "piped/p000r0"],
    ] {
        let output = into_closed_pipe(project.orch(&args), false);
        let stderr = text(&output.stderr);
        assert_eq!(output.status.code(), Some(0), "orch {args:?}: {stderr}");
        assert_eq!(stderr, "", "orch {args:?} was not quiet");
    }
}

#[test]
fn submit_into_closed_pipes_runs_the_study_to_the_end() {
    let project = Project::new();
    let file = project.write("piped.yaml", TINY);
    // -vv: the log lines go to the closed standard error too.
    let output = into_closed_pipe(
        project.orch(&["-vv", "submit", file.to_str().unwrap()]),
        true,
    );
    assert_eq!(
        output.status.code(),
        Some(0),
        "orch submit did not end cleanly"
    );
    let status = project.status("piped");
    assert_eq!(count(&status, "succeeded"), 2, "{status:#}");
    assert_eq!(status["study"]["state"], "finished", "{status:#}");

    // With only stdout closed, stderr shows no panic either.
    let again = into_closed_pipe(project.orch(&["submit", file.to_str().unwrap()]), false);
    let stderr = text(&again.stderr);
    assert_eq!(again.status.code(), Some(0), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
}

/// On a terminal (a pty from util-linux's `script`), `orch submit` shows a bar for the
/// round: jobs done of all, "round i of n", running jobs, with each job's line above
/// it. Into a pipe it prints the job lines alone.
#[test]
fn a_terminal_shows_a_progress_bar_per_round_and_a_pipe_plain_lines() {
    let project = Project::new();
    let file = project.write(
        "tiny.yaml",
        "name: tiny\nsolver: native\n\
         factors:\n  - {name: outlet_diameter, min: 0.020, max: 0.024}\n\
         fixed: {n_particles: 150, fill_time: 0.1, discharge_time: 0.4}\n\
         design: {type: full_factorial, levels: 3}\n",
    );
    let command = format!(
        "{} --project-dir {} submit {}",
        crate::support::orch_bin().display(),
        project.project_dir().display(),
        file.display()
    );
    let output = std::process::Command::new("script")
        .args(["-q", "-e", "-c", &command, "/dev/null"])
        .current_dir(project.dir.path())
        .output()
        .expect("util-linux's `script` runs orch on a pty");
    assert!(output.status.success(), "{}", text(&output.stderr));
    let screen = text(&output.stdout);
    assert!(screen.contains("3/3 jobs, round 1 of 1"), "{screen}");
    assert!(screen.contains("tiny/p002r0: succeeded in"), "{screen}");

    let other = project.write(
        "tiny2.yaml",
        &std::fs::read_to_string(&file)
            .unwrap()
            // Another seed: the same decks would be reused, not run.
            .replace("name: tiny", "name: tiny-piped\nseed: 2"),
    );
    let output = project.run(&["submit", other.to_str().unwrap()]);
    let stderr = text(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    assert!(
        stderr.contains("tiny-piped/p002r0: succeeded in"),
        "{stderr}"
    );
    assert!(
        !stderr.contains("jobs, round"),
        "no bar into a pipe: {stderr}"
    );
}
