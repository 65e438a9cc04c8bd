//! Solvers that fail, hang or leave broken output: each job fails with the reason and
//! the study goes on.

use std::process::Stdio;
use std::time::{Duration, Instant};

use crate::support::{default_liggghts_template, require_liggghts, solver_lock, text, Project};

/// Four short runs; the template misbehaves on purpose at three of them (chosen by
/// the amplitude factor: 0, 0.0003, 0.0006, 0.0009 m).
const STUDY: &str = "\
name: faults
solver: liggghts
template: faulty.in.tera
executor: {max_parallel: 2, time_limit: 12s, retries: 1}
factors:
  - {name: amplitude, min: 0.0, max: 0.0009}
fixed: {n_particles: 400, fill_time: 0.1, discharge_time: 0.5, outlet_diameter: 0.020}
design: {type: full_factorial, levels: 4}
";

/// The default template with three faults keyed on the amplitude.
fn faulty_template() -> String {
    let template = default_liggghts_template();
    let (head, tail) = template.split_once("# ---- stage 1").unwrap();
    let mut text = format!(
        "{head}{}# ---- stage 1{tail}",
        "{% if amplitude > 0.0002 and amplitude < 0.0004 %}frobnicate 3\n{% endif %}\
         {% if amplitude > 0.0008 %}run 100000000\n{% endif %}"
    );
    text.push_str(
        "{% if amplitude > 0.0005 and amplitude < 0.0007 %}undump sensor\nshell truncate -s -120 post/sensor.liggghts\n{% endif %}\n",
    );
    text
}

#[test]
fn failing_hanging_and_truncating_solvers_fail_their_jobs_and_the_study_goes_on() {
    if !require_liggghts() {
        return;
    }
    let _lock = solver_lock();
    let project = Project::new();
    project.write("faulty.in.tera", &faulty_template());
    let file = project.write("faults.yaml", STUDY);
    let output = project.run(&["submit", file.to_str().unwrap()]);
    let stderr = text(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    let status = project.status("faults");
    let job = |name: &str| {
        status["jobs"]
            .as_array()
            .unwrap()
            .iter()
            .find(|j| j["name"] == name)
            .unwrap()
            .clone()
    };

    let good = job("p000r0");
    assert_eq!(good["state"], "succeeded", "{good}");
    assert!(good["responses"]["discharge_rate"].as_f64().unwrap() > 0.0);

    let crashed = job("p001r0");
    assert_eq!(crashed["state"], "failed");
    assert_eq!(crashed["attempts"], 2, "a failed job is retried once");
    assert_eq!(crashed["exit_code"], 1);
    let error = crashed["error"].as_str().unwrap();
    assert!(
        error.starts_with(
            "the solver exited with status 1; it reported: ERROR: Unknown command: frobnicate 3"
        ),
        "{error}"
    );

    let truncated = job("p002r0");
    assert_eq!(truncated["state"], "failed");
    let error = truncated["error"].as_str().unwrap();
    assert!(
        error.starts_with("the solver exited 0 but its output cannot be read: "),
        "{error}"
    );
    assert!(
        error.contains("post/sensor.liggghts:") && error.contains("truncated dump?"),
        "{error}"
    );

    let hung = job("p003r0");
    assert_eq!(hung["state"], "failed");
    let error = hung["error"].as_str().unwrap();
    assert!(
        error.starts_with("exceeded its time limit of 12s"),
        "{error}"
    );
    // Its process group was killed: nothing runs in its directory any more.
    let run_dir = std::fs::canonicalize(hung["run_dir"].as_str().unwrap()).unwrap();
    for entry in std::fs::read_dir("/proc").unwrap().flatten() {
        if let Ok(cwd) = std::fs::read_link(entry.path().join("cwd")) {
            assert_ne!(
                cwd,
                run_dir,
                "process {:?} still runs in the hung job's directory",
                entry.file_name()
            );
        }
    }
    // Failed jobs hold no responses; the good one's are intact.
    let responses =
        project.query("SELECT DISTINCT j.name FROM responses r JOIN jobs j ON j.id = r.job_id");
    assert_eq!(responses, vec![vec!["p000r0".to_string()]]);
    // `orch logs` shows the solver's own words.
    let logs = text(&project.run(&["logs", "faults/p001r0"]).stdout);
    assert!(
        logs.contains("ERROR: Unknown command: frobnicate 3"),
        "{logs}"
    );
}

/// A solver that deletes its own run directory (a fake LIGGGHTS, supervision only)
/// ends without an exit status; each such attempt spends the retry budget, and the
/// job then fails with the reason instead of running again for ever.
#[test]
fn an_attempt_lost_without_an_exit_status_spends_the_retry_budget() {
    let mut project = Project::new();
    project.fake_program("liggghts", "rm -rf \"$PWD\"");
    let file = project.write(
        "lost.yaml",
        "name: lost\n\
         solver: liggghts\n\
         executor: {max_parallel: 2, time_limit: 1min, retries: 1}\n\
         factors:\n  - {name: amplitude, min: 0.0, max: 0.0006}\n\
         fixed: {n_particles: 400, fill_time: 0.1, discharge_time: 0.5, outlet_diameter: 0.020}\n\
         design: {type: full_factorial, levels: 2}\n",
    );
    let mut orch = project
        .orch(&["submit", file.to_str().unwrap()])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(30);
    let code = loop {
        if let Some(status) = orch.try_wait().unwrap() {
            break status.code();
        }
        if Instant::now() > deadline {
            orch.kill().unwrap();
            orch.wait().unwrap();
            let attempts = project.query("SELECT name, attempts, state FROM jobs");
            panic!("orch still ran the lost jobs after 30 s: {attempts:?}");
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    assert_eq!(code, Some(1), "the study ends with failed jobs");
    let status = project.status("lost");
    for job in status["jobs"].as_array().unwrap() {
        assert_eq!(job["state"], "failed", "{job}");
        assert_eq!(job["attempts"], 2, "one try and one retry: {job}");
        let error = job["error"].as_str().unwrap();
        assert!(error.contains("without an exit status"), "{error}");
    }
}

/// A jammed hopper: 4 mm spheres only, through a 4.5 mm outlet.
const JAMMED: &str = "\
name: jammed
solver: native
executor: {max_parallel: 2, retries: 0}
factors:
  - {name: amplitude, min: 0.0, max: 0.0002}
fixed: {n_particles: 100, fine_diameter: 0.004, outlet_diameter: 0.0045, fill_time: 0.1, discharge_time: 0.2}
design: {type: full_factorial, levels: 2}
responses: [discharge_rate]
";

/// A run that ends without the study's response is not a silent success: it is
/// recorded with why (default), or failed when the study says so.
#[test]
fn a_jammed_hopper_succeeds_without_its_discharge_rate_and_says_why() {
    let project = Project::new();
    let file = project.write("jammed.yaml", JAMMED);
    let output = project.run(&["submit", file.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(0), "{}", text(&output.stderr));
    let status = project.status("jammed");
    for job in status["jobs"].as_array().unwrap() {
        assert_eq!(job["state"], "succeeded", "{job:#}");
        assert!(job["responses"].get("discharge_rate").is_none(), "{job:#}");
        let note = job["error"].as_str().unwrap_or_default();
        assert!(
            note.starts_with(
                "succeeded without discharge_rate: discharge_rate: no steady discharge: "
            ) && note.contains(" of 100 particles crossed the sensor plane"),
            "{note}"
        );
    }
    let table = text(&project.run(&["status", "jammed"]).stdout);
    assert!(
        table.contains("succeeded without discharge_rate"),
        "{table}"
    );

    // The same decks under `missing_response: fail`: the runs are not made again,
    // and this study counts them failed.
    let failing = JAMMED.replace("name: jammed", "name: jammed-fails") + "missing_response: fail\n";
    let file = project.write("jammed-fails.yaml", &failing);
    let output = project.run(&["submit", file.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(1), "{}", text(&output.stderr));
    let status = project.status("jammed-fails");
    for job in status["jobs"].as_array().unwrap() {
        assert_eq!(job["state"], "failed", "{job:#}");
        let error = job["error"].as_str().unwrap();
        assert!(
            error.contains("no steady discharge") && error.contains("(not run again)"),
            "{job:#}"
        );
        assert_eq!(job["attempts"], 0, "{job:#}");
    }
}
