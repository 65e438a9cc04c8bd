//! A native job stopped at its time limit continues from its restart file on its next
//! attempt instead of starting over, and stores the same responses, bit for bit, as
//! the same study run without a limit.

use crate::support::{solver_lock, text, Project};

/// Two vibrated hoppers of 2 000 spheres, 0.25 s of fill and 0.25 s of discharge
/// (about 6 s each on one core): a 3 s limit stops each attempt part-way.
fn study(time_limit: &str, retries: u32) -> String {
    format!(
        "name: resumed\n\
         solver: native\n\
         executor: {{max_parallel: 1, time_limit: {time_limit}, retries: {retries}}}\n\
         factors:\n  - {{name: outlet_diameter, min: 0.020, max: 0.024, unit: m}}\n\
         fixed: {{n_particles: 2000, fill_time: 0.25, discharge_time: 0.25, amplitude: 0.0005, frequency: 50}}\n\
         design: {{type: latin_hypercube, samples: 2}}\n\
         seed: 5\n"
    )
}

/// Submits `study` in `project`. The kernel's own saves are an hour apart: an attempt
/// stopped at its limit leaves only the state it saves on orch's SIGTERM.
fn submit(project: &Project, study: &str) -> serde_json::Value {
    let file = project.write("resumed.yaml", study);
    let out = project
        .orch(&["submit", file.to_str().unwrap()])
        .env("ORCH_DEM_RESTART_EVERY", "1h")
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "orch submit failed:\n{}",
        text(&out.stderr)
    );
    project.status("resumed")
}

#[test]
fn a_native_job_past_its_time_limit_continues_from_its_restart_file_on_its_next_attempt() {
    let _lock = solver_lock();
    let limited = Project::new();
    let stopped = submit(&limited, &study("3s", 12));
    let whole = Project::new();
    let reference = submit(&whole, &study("5min", 0));

    let jobs = stopped["jobs"].as_array().unwrap();
    let reference_jobs = reference["jobs"].as_array().unwrap();
    assert_eq!(jobs.len(), 2);
    for (job, other) in jobs.iter().zip(reference_jobs) {
        let name = job["name"].as_str().unwrap();
        assert_eq!(job["state"], "succeeded", "{job}");
        assert_eq!(other["state"], "succeeded", "{other}");
        let attempts = job["attempts"].as_u64().unwrap();
        assert!(attempts >= 2, "{name} finished in {attempts} attempt");
        // The kept files are not part of what the run is: the same identity.
        assert_eq!(job["identity"], other["identity"], "{name}");
        let run_dir = std::path::PathBuf::from(job["run_dir"].as_str().unwrap());
        let log = std::fs::read_to_string(run_dir.join("log.native")).unwrap();
        assert!(
            log.contains("Resumed from the restart file post/restart.orch-dem at step "),
            "{name} was not resumed:\n{log}"
        );
        assert!(!run_dir.join("post/restart.orch-dem").exists());
        assert!(!run_dir.join("orch-restart").exists());
        assert!(!run_dir.with_file_name(format!("{name}.kept")).exists());
        let (ours, theirs) = (
            job["responses"].as_object().unwrap(),
            other["responses"].as_object().unwrap(),
        );
        let measured: Vec<&String> = ours.keys().filter(|k| !k.starts_with("solver_")).collect();
        assert!(measured.len() > 5, "{ours:?}");
        for response in measured {
            let (a, b) = (
                ours[response].as_f64().unwrap(),
                theirs[response].as_f64().unwrap(),
            );
            assert_eq!(
                a.to_bits(),
                b.to_bits(),
                "{name} {response}: {a} resumed, {b} whole"
            );
        }
    }
}

/// The thermo rows in `run_dir`'s native log so far.
fn thermo_rows(run_dir: &std::path::Path) -> usize {
    std::fs::read_to_string(run_dir.join("log.native"))
        .unwrap_or_default()
        .lines()
        .filter(|l| {
            l.split_whitespace()
                .next()
                .is_some_and(|w| w.parse::<u64>().is_ok())
        })
        .count()
}

#[test]
fn a_native_job_cancelled_from_another_shell_saves_its_state_and_resume_continues_it() {
    let _lock = solver_lock();
    let project = Project::new();
    let file = project.write("resumed.yaml", &study("5min", 0));
    let mut orch = project
        .orch(&["submit", file.to_str().unwrap()])
        .env("ORCH_DEM_RESTART_EVERY", "1h")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    // Cancel once the first job has logged a few rows, early in its run.
    let waited = std::time::Instant::now();
    let run_dir = loop {
        // Until the store and its tables exist (the file comes first), no job has started.
        let dirs = project.try_run_dirs("resumed").unwrap_or_default();
        let running = dirs.into_iter().find(|dir| thermo_rows(dir) >= 5);
        if let Some(dir) = running {
            break dir;
        }
        assert!(
            waited.elapsed() < std::time::Duration::from_secs(120),
            "no job got going"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    };
    let cancel = project.run(&["cancel", "resumed"]);
    assert!(cancel.status.success(), "{}", text(&cancel.stderr));
    assert!(
        text(&cancel.stderr).contains("1 running solvers stopped"),
        "{}",
        text(&cancel.stderr)
    );
    orch.wait().unwrap();
    let log = std::fs::read_to_string(run_dir.join("log.native")).unwrap();
    assert!(
        log.lines()
            .last()
            .is_some_and(|l| l.starts_with("Stopped by SIGTERM at step ")),
        "{log}"
    );
    assert!(run_dir.join("post/restart.orch-dem").exists());

    let resumed = project
        .orch(&["resume", "resumed"])
        .env("ORCH_DEM_RESTART_EVERY", "1h")
        .output()
        .unwrap();
    assert!(resumed.status.success(), "{}", text(&resumed.stderr));
    let status = project.status("resumed");
    for job in status["jobs"].as_array().unwrap() {
        assert_eq!(job["state"], "succeeded", "{job}");
    }
    let log = std::fs::read_to_string(run_dir.join("log.native")).unwrap();
    assert!(
        log.contains("Resumed from the restart file post/restart.orch-dem at step "),
        "not resumed:\n{log}"
    );
}
