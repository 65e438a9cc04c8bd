//! Several `orch` processes on one project at once: studies submitted side by side
//! into a fresh project directory all run to the end while `orch status` watches.

use std::process::{Command, Output};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread;

use crate::support::{count, solver_lock, text, Project};

/// How many studies are submitted at once.
const STUDIES: usize = 8;

/// A native study of two tiny runs (well under a second each).
fn tiny_study(name: &str) -> String {
    format!(
        "name: {name}\n\
         solver: native\n\
         executor: {{max_parallel: 1, time_limit: 1min, retries: 0}}\n\
         factors:\n  - {{name: outlet_diameter, min: 0.020, max: 0.024, unit: m}}\n\
         fixed: {{n_particles: 30, fill_time: 0.05, discharge_time: 0.1}}\n\
         design: {{type: full_factorial, levels: 2}}\n\
         seed: 3\n"
    )
}

/// Panics with the output of `what` unless it exited 0 without an error, a lock or a
/// panic on stderr.
fn assert_clean(what: &str, output: &Output) {
    let stderr = text(&output.stderr);
    assert_eq!(output.status.code(), Some(0), "{what} failed:\n{stderr}");
    for bad in ["error", "locked", "panicked", "already exists"] {
        assert!(
            !stderr.to_lowercase().contains(bad),
            "{what} said `{bad}`:\n{stderr}"
        );
    }
}

#[test]
fn studies_submitted_at_once_into_a_fresh_project_all_finish_while_status_watches() {
    let _lock = solver_lock();
    let project = Project::new();
    let files: Vec<_> = (0..STUDIES)
        .map(|i| {
            let name = format!("side{i}");
            project.write(&format!("{name}.yaml"), &tiny_study(&name))
        })
        .collect();
    let done = Arc::new(AtomicBool::new(false));
    let watchers: Vec<_> = [vec!["status"], vec!["status", "--json"]]
        .into_iter()
        .map(|args| {
            let mut command: Command = project.orch(&args);
            let done = Arc::clone(&done);
            thread::spawn(move || {
                let mut runs = 0;
                while !done.load(Ordering::SeqCst) {
                    let output = command.output().unwrap();
                    assert_clean(&format!("orch {}", args.join(" ")), &output);
                    runs += 1;
                }
                runs
            })
        })
        .collect();
    let submits: Vec<_> = files
        .iter()
        .map(|file| {
            project
                .orch(&["submit", file.to_str().unwrap()])
                .spawn_output()
        })
        .collect();
    let outputs: Vec<Output> = submits.into_iter().map(|s| s.join().unwrap()).collect();
    done.store(true, Ordering::SeqCst);
    let status_runs: Vec<usize> = watchers.into_iter().map(|w| w.join().unwrap()).collect();
    eprintln!("orch status ran {status_runs:?} times while the studies ran");
    for (i, output) in outputs.iter().enumerate() {
        assert_clean(&format!("orch submit side{i}"), output);
    }
    for i in 0..STUDIES {
        let status = project.status(&format!("side{i}"));
        assert_eq!(count(&status, "succeeded"), 2, "{status:#}");
        assert_eq!(status["study"]["state"], "finished", "{status:#}");
    }
    assert!(status_runs.iter().all(|&n| n > 0), "{status_runs:?}");
}

/// Runs a command on its own thread and hands back its output.
trait SpawnOutput {
    fn spawn_output(self) -> thread::JoinHandle<Output>;
}

impl SpawnOutput for Command {
    fn spawn_output(mut self) -> thread::JoinHandle<Output> {
        let child = self
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        thread::spawn(move || child.wait_with_output().unwrap())
    }
}
