//! Run identity and reuse on the README's first study, on the native kernel: a run
//! is never made twice, and a copy is never counted as a replicate.

use std::collections::BTreeMap;

use serde_json::Value;

use crate::support::{root, solver_lock, text, Project};

/// Each job's name → (identity, responses, reused_from).
fn runs(status: &Value) -> BTreeMap<String, (String, Value, Value)> {
    status["jobs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|job| {
            (
                job["name"].as_str().unwrap().to_string(),
                (
                    job["identity"].as_str().unwrap().to_string(),
                    job["responses"].clone(),
                    job["reused_from"].clone(),
                ),
            )
        })
        .collect()
}

#[test]
fn quickstart_runs_each_deck_once_and_a_resubmission_reuses_every_run() {
    let _lock = solver_lock();
    let project = Project::new();
    let file = root().join("jobs/quickstart.yaml");
    let file = file.to_str().unwrap();
    let output = project.run(&["submit", file]);
    let stderr = text(&output.stderr);
    assert_eq!(output.status.code(), Some(0), "{stderr}");

    // Round 2 revisits three points of round 1 on the outlet's upper limit: the same
    // decks, reused, not run again.
    let first = project.status("quickstart");
    let jobs = runs(&first);
    assert_eq!(jobs.len(), 19);
    let reused: Vec<(&String, &Value)> = jobs
        .iter()
        .filter(|(_, (_, _, from))| !from.is_null())
        .map(|(name, (_, _, from))| (name, from))
        .collect();
    assert_eq!(reused.len(), 3, "{reused:?}");
    for (name, from) in &reused {
        let source = from.as_str().unwrap().strip_prefix("quickstart/").unwrap();
        assert!(
            name.starts_with("r1-") && !source.starts_with("r1-"),
            "{name} ← {source}"
        );
        assert_eq!(jobs[*name].0, jobs[source].0, "the same identity");
        assert_eq!(jobs[*name].1, jobs[source].1, "the same responses");
    }
    assert!(
        stderr.contains("19 succeeded (3 of them reused identical runs instead of running)"),
        "{stderr}"
    );
    let table = text(&project.run(&["status", "quickstart"]).stdout);
    assert!(
        table.contains("19 jobs: 19 succeeded (3 reused, not run again)")
            && table.contains("reused quickstart/p00"),
        "{table}"
    );
    // Every job that ran has an identity of its own: no two runs are the same deck.
    let mut identities: Vec<&String> = jobs
        .values()
        .filter(|(_, _, from)| from.is_null())
        .map(|(identity, _, _)| identity)
        .collect();
    identities.sort();
    identities.dedup();
    assert_eq!(identities.len(), 16);
    // Round 2 fits its own 10 runs and round 1's 6 inside its box, less the 3 copies.
    let fits = first["rounds"][1]["fits"].as_array().unwrap();
    assert!(fits.iter().all(|f| f["runs"] == 13), "{fits:?}");
    // Nothing was launched for a reused job.
    let attempts = project.query("SELECT SUM(attempts) FROM jobs WHERE reused_from IS NOT NULL");
    assert_eq!(attempts[0][0], "0");

    // Submitted again under another name: every job is a run the project has.
    let output = project.run(&["submit", "--as", "quickstart-again", file]);
    let stderr = text(&output.stderr);
    assert_eq!(output.status.code(), Some(0), "{stderr}");
    assert!(stderr.contains("19 of them reused"), "{stderr}");
    let again = runs(&project.status("quickstart-again"));
    for (name, (identity, responses, from)) in &again {
        assert!(from.as_str().unwrap().starts_with("quickstart/"), "{name}");
        assert_eq!(identity, &jobs[name].0, "{name}");
        assert_eq!(responses, &jobs[name].1, "{name}");
    }
    // The report says where a reused run came from.
    let html = std::fs::read_to_string(project.project_dir().join("reports/quickstart-again.html"))
        .unwrap();
    assert!(
        html.contains("succeeded (reused quickstart/p000r0, not run again)"),
        "the report's design table names the source"
    );

    // Deleting the first study leaves the second whole: its results and run files.
    let output = project.run(&["delete", "quickstart"]);
    let stderr = text(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    assert!(
        stderr.contains("19 jobs of other studies reused runs of `quickstart`"),
        "{stderr}"
    );
    let kept = runs(&project.status("quickstart-again"));
    for (name, (_, responses, from)) in &kept {
        assert_eq!(responses, &jobs[name].1, "{name}");
        assert!(from.as_str().unwrap().starts_with("quickstart/"), "{name}");
    }
    let log = project
        .project_dir()
        .join("runs/quickstart-again/p000r0/log.native");
    assert!(
        std::fs::read_to_string(&log)
            .unwrap()
            .contains("ORCH-DEM DONE"),
        "{} keeps the run's log",
        log.display()
    );

    // --no-reuse runs every job of the first round again (the native kernel is
    // deterministic: the same responses); those runs count once in the fits.
    let output = project.run(&["submit", "--as", "quickstart-fresh", "--no-reuse", file]);
    let stderr = text(&output.stderr);
    assert_eq!(output.status.code(), Some(0), "{stderr}");
    let fresh = project.status("quickstart-fresh");
    let fresh_runs = runs(&fresh);
    assert!(fresh_runs.values().all(|(_, _, from)| from.is_null()));
    let physics = |responses: &Value| -> Value {
        let mut responses = responses.as_object().unwrap().clone();
        responses.retain(|name, _| !name.starts_with("solver_"));
        Value::Object(responses)
    };
    assert_eq!(physics(&fresh_runs["p004r0"].1), physics(&jobs["p004r0"].1));
    assert!(fresh["rounds"][1]["fits"]
        .as_array()
        .unwrap()
        .iter()
        .all(|f| f["runs"] == 13));
}
