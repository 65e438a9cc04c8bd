//! Bounded inputs and outputs of a user's own deck: a response of 2·10^7 numbers is
//! read in one streaming pass and stored as a bounded series, SIGTERM stops orch while
//! it reads and `orch resume` reads it without running the deck again; `orch logs`
//! shows a custom deck's declared log; names too long for the file system and ranges
//! wider than a float can hold are refused before anything is written.
//!
//! The decks run a user's shell script (`awk` writes the numbers): they test orch's
//! handling of what a deck writes, not a solver's results.

use std::time::{Duration, Instant};

use crate::support::{text, Project};

/// 2·10^7 numbers `i mod 1000` as one JSON array (78 MB), and a log line.
const HUGE_DECK: &str = "\
mkdir -p post
echo \"x = {{ x }}\" > deck.log
awk 'BEGIN { printf \"{\\\"flow\\\": [\"; for (i = 0; i < 20000000; i++) { if (i) printf \",\"; printf \"%d\", i % 1000 } print \"]}\" }' > post/flow.json
";

const HUGE_STUDY: &str = "\
name: huge
equipment: custom
case:
  templates: [deck.sh.tera]
  command: [sh, deck.sh]
  log: deck.log
  responses:
    - {name: flow, json: post/flow.json, key: flow, reduce: mean, unit: kg/s}
executor: {max_parallel: 1, retries: 0}
factors:
  - {name: x, min: 0, max: 1}
design: {type: full_factorial, levels: 2}
";

#[test]
fn a_huge_response_is_streamed_and_thinned_sigterm_stops_orch_while_it_reads_and_resume_reads_it() {
    let project = Project::new();
    project.write("deck.sh.tera", HUGE_DECK);
    let file = project.write("huge.yaml", HUGE_STUDY);
    let orch = project
        .orch(&["submit", file.to_str().unwrap()])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();

    // Once the first deck has exited (its exit status is written), orch is reading its
    // 78 MB of output: SIGTERM then.
    let status_file = project.project_dir().join("runs/huge/p000r0/exit_status");
    let deadline = Instant::now() + Duration::from_secs(120);
    while !status_file.exists() {
        assert!(Instant::now() < deadline, "the deck did not finish");
        std::thread::sleep(Duration::from_millis(20));
    }
    std::thread::sleep(Duration::from_millis(300));
    let signalled = Instant::now();
    let kill = std::process::Command::new("kill")
        .args(["-TERM", &orch.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let output = orch.wait_with_output().unwrap();
    let exit = output.status;
    let stopped_in = signalled.elapsed();
    eprintln!(
        "orch stopped {:.2} s after SIGTERM",
        stopped_in.as_secs_f64()
    );
    assert_eq!(exit.code(), Some(130));
    assert!(
        stopped_in < Duration::from_secs(3),
        "orch took {stopped_in:?} to stop"
    );
    let stderr = text(&output.stderr);
    assert!(
        stderr.contains("orch: 1 jobs had finished but their output was not read yet; `orch resume huge` reads it without running them again"),
        "{stderr}"
    );
    // The run was not read; it is not thrown away either.
    let state = project.query("SELECT state, attempts FROM jobs WHERE name = 'p000r0'");
    assert_eq!(state[0], ["running", "1"], "left for resume to read");

    let output = project.run(&["resume", "huge"]);
    assert_eq!(output.status.code(), Some(0), "{}", text(&output.stderr));
    let status = project.status("huge");
    for job in status["jobs"].as_array().unwrap() {
        assert_eq!(job["state"], "succeeded", "{job:#}");
        assert_eq!(job["attempts"], 1, "read, not run again: {job:#}");
        // The mean of all 2·10^7 values, not of the stored ones.
        assert_eq!(job["responses"]["flow"].as_f64(), Some(499.5), "{job:#}");
        let note = job["error"].as_str().unwrap_or_default();
        assert!(
            note.starts_with("series `flow` had 20000000 points; "),
            "status says the series was thinned: {note}"
        );
    }
    let rows = project.query(
        "SELECT COUNT(*) FROM series s JOIN jobs j ON j.id = s.job_id WHERE j.name = 'p000r0'",
    );
    let rows: usize = rows[0][0].parse().unwrap();
    assert!(
        (5_000..=10_001).contains(&rows),
        "{rows} series rows stored"
    );
    let last = project.query(
        "SELECT CAST(MAX(t) AS INTEGER), CAST(value AS INTEGER) FROM series s JOIN jobs j ON j.id = s.job_id WHERE j.name = 'p000r0'",
    );
    assert_eq!(last[0], ["19999999", "999"], "the last point is kept");

    // `orch logs` shows the deck's declared log besides stdout and stderr.
    let output = project.run(&["logs", "huge/p001r0"]);
    let stdout = text(&output.stdout);
    assert_eq!(output.status.code(), Some(0), "{}", text(&output.stderr));
    assert!(
        stdout.contains("deck.log <==\nx = 1\n"),
        "the declared log is shown: {stdout}"
    );
}

/// A name too long for the file system and a range whose width overflows a float are
/// refused at validation: exit 2, the field named, nothing written.
#[test]
fn a_study_name_too_long_for_a_folder_and_an_infinite_range_are_refused_with_nothing_written() {
    let project = Project::new();
    project.write("deck.sh.tera", "echo \"y = {{ x }}\"\n");
    let study = "\
name: NAME
equipment: custom
case:
  templates: [deck.sh.tera]
  command: [sh, deck.sh]
  responses:
    - {name: y, regex: 'y = (\\S+)'}
factors:
  - {name: x, min: -1, max: 1}
design: {type: full_factorial, levels: 3}
";
    let long = "n".repeat(300);
    let cases = [
        (
            study.replace("NAME", &long),
            "name: expected at most 200 characters",
        ),
        (
            study
                .replace("NAME", "wide")
                .replace("min: -1, max: 1", "min: -1e308, max: 1e308"),
            "factors[0].max: the range [-1e308, 1e308] is wider than a number can hold",
        ),
    ];
    for (text_of_study, expected) in cases {
        let file = project.write("refused.yaml", &text_of_study);
        for args in [vec!["submit", "--dry-run"], vec!["submit"]] {
            let mut args = args;
            args.push(file.to_str().unwrap());
            let output = project.run(&args);
            let stderr = text(&output.stderr);
            assert_eq!(output.status.code(), Some(2), "{stderr}");
            assert!(stderr.contains(expected), "{expected}: {stderr}");
            assert!(!project.project_dir().exists(), "nothing is written");
        }
    }
    let file = project.write("refused.yaml", &study.replace("NAME", "fine"));
    let output = project.run(&["submit", "--as", &long, file.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(2));
    assert!(text(&output.stderr).contains("--as: expected at most 200 characters"));
}
