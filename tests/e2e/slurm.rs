//! Studies on a real Slurm cluster (slurmctld + two slurmd + munge, started by
//! `scripts/slurm up`), running the native kernel: the same responses as the local
//! executor, Slurm's reasons for failed, timed-out and scancelled jobs, a round of fifty
//! jobs as one job array through `kill -9` of orch mid-submission and `orch resume`
//! (re-attached, nothing submitted twice, a failed task retried alone), a node
//! failure, and native jobs killed at Slurm's time limit that continue from their
//! restart files.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

use serde_json::Value;

use crate::support::{count, require_slurm, root, slurm_lock, solver_lock, text, Project};

/// A 9-point face-centred CCD of short native runs (1000 particles, ~3 s each).
fn nine_point_study(name: &str, executor: &str) -> String {
    format!(
        "name: {name}\n\
         solver: native\n\
         executor: {executor}\n\
         factors:\n  - {{name: outlet_diameter, min: 0.020, max: 0.028, unit: m}}\n  - {{name: amplitude, min: 0.0, max: 0.0008, unit: m}}\n\
         fixed: {{frequency: 50, n_particles: 1000, fill_time: 0.2, discharge_time: 0.6}}\n\
         design: {{type: central_composite, alpha: face_centred, center_points: 1}}\n\
         seed: 7\n\
         responses: [discharge_rate, segregation_ratio]\n"
    )
}

/// Responses of every job, by job name.
fn responses(status: &Value) -> BTreeMap<String, BTreeMap<String, f64>> {
    status["jobs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|job| {
            let values = job["responses"]
                .as_object()
                .unwrap()
                .iter()
                .filter(|(name, _)| !name.starts_with("solver_"))
                .map(|(name, v)| (name.clone(), v.as_f64().unwrap()))
                .collect();
            (job["name"].as_str().unwrap().to_string(), values)
        })
        .collect()
}

/// The job of `name` in a status JSON.
fn job<'a>(status: &'a Value, name: &str) -> &'a Value {
    status["jobs"]
        .as_array()
        .unwrap()
        .iter()
        .find(|j| j["name"] == name)
        .unwrap_or_else(|| panic!("no job {name} in {status:#}"))
}

/// `orch ARGS` started in the background, its stderr kept in the project directory.
struct Background {
    child: std::process::Child,
    stderr: PathBuf,
}

impl Background {
    fn start(project: &Project, args: &[&str]) -> Background {
        let stderr = project.dir.path().join("orch-stderr.txt");
        let child = project
            .orch(args)
            .stderr(std::fs::File::create(&stderr).unwrap())
            .spawn()
            .unwrap();
        Background { child, stderr }
    }

    fn stderr(&self) -> String {
        std::fs::read_to_string(&self.stderr).unwrap_or_default()
    }

    /// Polls `orch status STUDY --json` until `done` holds; fails with orch's stderr
    /// if orch ends first or `limit` passes.
    fn wait_for(
        &mut self,
        project: &Project,
        study: &str,
        limit: Duration,
        done: impl Fn(&Value) -> bool,
    ) -> Value {
        let deadline = std::time::Instant::now() + limit;
        loop {
            let output = project.run(&["status", study, "--json"]);
            let status: Option<Value> = serde_json::from_slice(&output.stdout).ok();
            if let Some(status) = status.as_ref().filter(|s| done(s)) {
                return status.clone();
            }
            if let Some(code) = self.child.try_wait().unwrap() {
                panic!(
                    "orch ended ({code}) first; stderr:\n{}\nstatus: {status:#?}",
                    self.stderr()
                );
            }
            if std::time::Instant::now() > deadline {
                panic!(
                    "gave up after {limit:?}; orch's stderr:\n{}\nstatus: {status:#?}",
                    self.stderr()
                );
            }
            std::thread::sleep(Duration::from_millis(200));
        }
    }
}

#[test]
fn a_nine_point_study_on_slurm_equals_the_same_study_run_locally() {
    let Some(conf) = require_slurm() else { return };
    let _cluster = slurm_lock();
    let _lock = solver_lock();
    let slurm = Project::on_slurm(&conf);
    let file = slurm.write(
        "ccd.yaml",
        &nine_point_study("ccd", "{kind: slurm, poll_interval: 1s, time_limit: 5min}"),
    );
    let output = slurm.run(&["submit", file.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(0), "{}", text(&output.stderr));
    let on_slurm = slurm.status("ccd");
    assert_eq!(count(&on_slurm, "succeeded"), 9, "{on_slurm:#}");

    let local = Project::new();
    let file = local.write(
        "ccd.yaml",
        &nine_point_study("ccd", "{max_parallel: 2, time_limit: 5min}"),
    );
    let output = local.run(&["submit", file.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(0), "{}", text(&output.stderr));
    let here = local.status("ccd");

    // Same seeds, same cases, a deterministic kernel: the same numbers, point by point.
    let (slurm_responses, local_responses) = (responses(&on_slurm), responses(&here));
    assert_eq!(slurm_responses.len(), 9);
    assert_eq!(slurm_responses, local_responses);

    // Every job ran as a Slurm batch job and recorded its end in its run directory.
    for job in on_slurm["jobs"].as_array().unwrap() {
        let handle = job["handle"].as_str().unwrap();
        assert!(handle.starts_with("slurm:"), "{job}");
        let scheduler = job["scheduler_state"].as_str().unwrap_or("");
        assert!(
            scheduler.starts_with("COMPLETED") || scheduler.starts_with("COMPLETING"),
            "{job}"
        );
        let run_dir = PathBuf::from(job["run_dir"].as_str().unwrap());
        let attempts = std::fs::read_to_string(run_dir.join("orch-attempts.log")).unwrap();
        assert!(
            attempts.starts_with(&format!("start {handle} ")),
            "{attempts}"
        );
        assert!(run_dir.join("orch-job.sbatch").is_file());
    }
}

/// Two 3 000-sphere vibrated hoppers at a 4 µs step (about 90 s of one core each) under
/// Slurm's one-minute limit. The kernel's own saves are an hour apart: the only state
/// an attempt leaves is the one it saves on Slurm's SIGTERM at the limit.
const OVER_THE_LIMIT: &str = "\
name: slurm-resumed
solver: native
executor: {kind: slurm, time_limit: 1min, retries: 4, poll_interval: 1s}
factors:
  - {name: outlet_diameter, min: 0.020, max: 0.024, unit: m}
fixed: {n_particles: 3000, fill_time: 0.5, discharge_time: 1.0, amplitude: 0.0005, frequency: 50, timestep: 4.0e-6}
design: {type: latin_hypercube, samples: 2}
seed: 11
";

#[test]
fn a_native_job_killed_at_slurms_time_limit_continues_from_its_restart_file() {
    let Some(conf) = require_slurm() else { return };
    let _cluster = slurm_lock();
    let _lock = solver_lock();
    let project = Project::on_slurm(&conf);
    let file = project.write("resumed.yaml", OVER_THE_LIMIT);
    let output = project
        .orch(&["submit", file.to_str().unwrap()])
        .env("ORCH_DEM_RESTART_EVERY", "1h")
        .output()
        .unwrap();
    let stderr = text(&output.stderr);
    assert_eq!(output.status.code(), Some(0), "{stderr}");
    assert!(stderr.contains("TIMEOUT (TimeLimit)"), "{stderr}");
    let status = project.status("slurm-resumed");
    for job in status["jobs"].as_array().unwrap() {
        assert_eq!(job["state"], "succeeded", "{job:#}");
        assert!(job["attempts"].as_u64().unwrap() >= 2, "{job:#}");
        let run_dir = PathBuf::from(job["run_dir"].as_str().unwrap());
        let log = std::fs::read_to_string(run_dir.join("log.native")).unwrap();
        assert!(
            log.contains("Resumed from the restart file post/restart.orch-dem at step "),
            "{log}"
        );
    }
}

/// Three points keyed on the fill time: 0.05 s runs with a speed bound of 1 mm/s that
/// the falling particles pass, so the kernel stops as unstable (exit 1); 50 s and 100 s of filling run far past the 1-minute
/// limit. The test scancels the third itself.
const FAULTS: &str = "\
name: slurm-faults
solver: native
template: faulty.toml.tera
executor: {kind: slurm, time_limit: 1min, retries: 0, poll_interval: 1s}
factors:
  - {name: fill_time, min: 0.05, max: 100, unit: s}
fixed: {n_particles: 400, discharge_time: 0.1}
design: {type: full_factorial, levels: 3}
seed: 3
";

fn faulty_native_template() -> String {
    let template =
        std::fs::read_to_string(root().join("templates/native/hopper.toml.tera")).unwrap();
    let line = "timestep = {{ timestep }}";
    assert!(template.contains(line));
    template.replace(
        line,
        "timestep = {{ timestep }}\nmax_speed = {% if fill_time < 1 %}0.001{% else %}50{% endif %}",
    )
}

#[test]
fn failed_timed_out_and_scancelled_slurm_jobs_end_with_slurms_reason() {
    let Some(conf) = require_slurm() else { return };
    let _cluster = slurm_lock();
    let project = Project::on_slurm(&conf);
    project.write("faulty.toml.tera", &faulty_native_template());
    let file = project.write("faults.yaml", FAULTS);
    let mut orch = Background::start(&project, &["submit", file.to_str().unwrap()]);
    // Cancel the third job on the cluster, behind orch's back, once Slurm runs it.
    let running = orch.wait_for(&project, "slurm-faults", Duration::from_secs(120), |s| {
        job(s, "p002r0")["state"] == "running"
    });
    let handle = job(&running, "p002r0")["handle"]
        .as_str()
        .unwrap()
        .to_string();
    let id = handle.strip_prefix("slurm:").unwrap();
    let scancel = Command::new("scancel")
        .arg(id)
        .env("SLURM_CONF", &conf)
        .status()
        .unwrap();
    assert!(scancel.success());

    let exit = orch.child.wait().unwrap();
    assert_eq!(exit.code(), Some(1), "{}", orch.stderr());
    let status = project.status("slurm-faults");

    let unstable = job(&status, "p000r0");
    assert_eq!(unstable["state"], "failed", "{unstable:#}");
    assert_eq!(unstable["exit_code"], 1);
    let error = unstable["error"].as_str().unwrap();
    assert!(error.contains("went unstable at step"), "{error}");

    let timed_out = job(&status, "p001r0");
    assert_eq!(timed_out["state"], "failed", "{timed_out:#}");
    let error = timed_out["error"].as_str().unwrap();
    assert!(
        error.contains("was stopped at its time limit: TIMEOUT (TimeLimit) on n"),
        "{error}"
    );

    let cancelled = job(&status, "p002r0");
    assert_eq!(cancelled["state"], "cancelled", "{cancelled:#}");
    let error = cancelled["error"].as_str().unwrap();
    assert!(
        error.starts_with(&format!(
            "Slurm job {id} was cancelled outside orch: CANCELLED"
        )),
        "{error}"
    );
    assert!(error.ends_with("`orch resume slurm-faults` runs it again"));

    // The table shows Slurm's view too.
    let table = text(&project.run(&["status", "slurm-faults"]).stdout);
    assert!(table.contains("SCHEDULER"), "{table}");
    assert!(table.contains("TIMEOUT (TimeLimit)"), "{table}");
    assert!(table.contains(&format!("slurm:{id}")), "{table}");
}

/// Fifty short native runs (50 particles), one retry each: one job array.
const FIFTY: &str = "\
name: fifty
solver: native
executor: {kind: slurm, poll_interval: 1s, time_limit: 5min, retries: 1}
factors:
  - {name: outlet_diameter, min: 0.020, max: 0.028, unit: m}
fixed: {n_particles: 50, fill_time: 0.02, discharge_time: 0.2}
design: {type: full_factorial, levels: 50}
seed: 11
";

/// A directory with an `sbatch` that runs Slurm's, then appends the directory it was
/// called from to `sbatch-calls` and, while the file `slow-sbatch` exists, sleeps
/// before answering: an orch killed then has submitted without recording it.
fn counting_sbatch(dir: &Path) -> PathBuf {
    let real = Command::new("sh")
        .args(["-c", "command -v sbatch"])
        .output()
        .unwrap();
    let real = text(&real.stdout).trim().to_string();
    assert!(!real.is_empty(), "no sbatch on PATH");
    let bin = dir.join("bin");
    std::fs::create_dir_all(&bin).unwrap();
    let (calls, slow) = (dir.join("sbatch-calls"), dir.join("slow-sbatch"));
    let wrapper = bin.join("sbatch");
    std::fs::write(
        &wrapper,
        format!(
            "#!/bin/sh\nout=$('{real}' \"$@\")\nrc=$?\necho \"$PWD\" >> '{}'\n\
             while [ -e '{}' ]; do sleep 0.2; done\necho \"$out\"\nexit $rc\n",
            calls.display(),
            slow.display()
        ),
    )
    .unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&wrapper, std::fs::Permissions::from_mode(0o755)).unwrap();
    bin
}

#[test]
fn fifty_jobs_go_out_as_one_array_survive_sigkill_mid_submission_and_a_failed_task_runs_again_alone(
) {
    let Some(conf) = require_slurm() else { return };
    let _cluster = slurm_lock();
    // No solver lock: fifty 50-particle runs wait on Slurm far more than they compute,
    // so other solver tests may run meanwhile.
    let mut project = Project::on_slurm(&conf);
    let bin = counting_sbatch(project.dir.path());
    let path = std::env::join_paths(
        std::iter::once(bin).chain(std::env::split_paths(&std::env::var_os("PATH").unwrap())),
    )
    .unwrap();
    project.env.push(("PATH".into(), path));
    let (calls, slow) = (
        project.dir.path().join("sbatch-calls"),
        project.dir.path().join("slow-sbatch"),
    );
    std::fs::write(&slow, "").unwrap();
    let file = project.write("fifty.yaml", FIFTY);
    let mut orch = Background::start(&project, &["submit", file.to_str().unwrap()]);

    // Slurm holds the array; orch waits for sbatch's answer. Break the last job's deck
    // before its task can run, then kill orch before it records any handle.
    let deadline = std::time::Instant::now() + Duration::from_secs(120);
    while std::fs::read_to_string(&calls).map_or(0, |c| c.lines().count()) == 0 {
        assert!(
            std::time::Instant::now() < deadline,
            "no sbatch within 120 s: {}",
            orch.stderr()
        );
        assert!(
            orch.child.try_wait().unwrap().is_none(),
            "{}",
            orch.stderr()
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    let last = project.query("SELECT run_dir FROM jobs WHERE name = 'p049r0'")[0][0].clone();
    let last = PathBuf::from(last);
    assert!(
        !last.join("orch-attempts.log").exists(),
        "task 49 ran before the test could break its deck"
    );
    std::fs::write(last.join("hopper.toml"), "this is not a case file\n").unwrap();
    orch.child.kill().unwrap();
    orch.child.wait().unwrap();
    std::fs::remove_file(&slow).unwrap();
    let recorded = project.query("SELECT name FROM jobs WHERE executor_handle IS NOT NULL");
    assert!(
        recorded.is_empty(),
        "orch recorded handles before it was killed: {recorded:?}"
    );

    let output = project.run(&["resume", "fifty"]);
    let stderr = text(&output.stderr);
    assert_eq!(output.status.code(), Some(0), "{stderr}");
    assert!(stderr.contains("re-attached"), "{stderr}");
    let status = project.status("fifty");
    assert_eq!(count(&status, "succeeded"), 50, "{status:#}");

    // Two sbatch calls in all: the array, then the broken job's second attempt alone.
    let calls = std::fs::read_to_string(&calls).unwrap();
    let calls: Vec<&str> = calls.lines().collect();
    assert_eq!(calls.len(), 2, "{calls:?}");
    assert!(calls[0].contains("/slurm-arrays/"), "{calls:?}");
    assert_eq!(Path::new(calls[1]), last, "{calls:?}");

    let mut array = None;
    for job in status["jobs"].as_array().unwrap() {
        let name = job["name"].as_str().unwrap();
        let handle = job["handle"].as_str().unwrap();
        let run_dir = PathBuf::from(job["run_dir"].as_str().unwrap());
        let log = std::fs::read_to_string(run_dir.join("orch-attempts.log")).unwrap();
        if name == "p049r0" {
            assert_eq!(job["attempts"], 2, "{job}");
            assert!(!handle.contains('_'), "a batch job of its own: {job}");
            assert_eq!(
                log.lines().filter(|l| l.starts_with("end 0 ")).count(),
                1,
                "{log}"
            );
            assert_eq!(
                log.lines().filter(|l| l.starts_with("end ")).count(),
                2,
                "{log}"
            );
            continue;
        }
        // Task i of the one array, run once.
        let index: u32 = name[1..4].parse().unwrap();
        let (id, task) = handle
            .strip_prefix("slurm:")
            .and_then(|h| h.split_once('_'))
            .unwrap_or_else(|| panic!("not an array task: {job}"));
        assert_eq!(task.parse::<u32>().unwrap(), index, "{job}");
        assert_eq!(*array.get_or_insert(id.to_string()), id, "{job}");
        assert_eq!(job["attempts"], 1, "{job}");
        assert!(log.starts_with(&format!("start {handle} ")), "{log}");
        assert_eq!(
            log.lines().filter(|l| l.starts_with("end 0 ")).count(),
            1,
            "{log}"
        );
    }
    let notes = project.query(
        "SELECT e.note FROM job_events e JOIN jobs j ON j.id = e.job_id WHERE j.name = 'p049r0' AND e.to_state = 'pending' AND e.note LIKE 'attempt 1 of 2 failed%'",
    );
    assert_eq!(notes.len(), 1, "{notes:?}");
    assert!(
        notes[0][0].contains("the solver exited with status"),
        "{notes:?}"
    );
}

/// Runs `scontrol ARGS` on the test cluster.
fn scontrol(conf: &Path, args: &[&str]) {
    let status = Command::new("scontrol")
        .args(args)
        .env("SLURM_CONF", conf)
        .status()
        .unwrap();
    assert!(status.success(), "scontrol {args:?} failed");
}

/// Brings a node taken down by a test back, however the test ends.
struct NodeBack<'a> {
    conf: &'a Path,
    node: String,
}

impl Drop for NodeBack<'_> {
    fn drop(&mut self) {
        // With ReturnToService=2 the node may be back already; then this is refused.
        let _ = Command::new("scontrol")
            .args(["update", &format!("nodename={}", self.node), "state=resume"])
            .env("SLURM_CONF", self.conf)
            .status();
    }
}

/// Two long native runs (100 s of filling), one retry each.
const LONG: &str = "\
name: node-fail
solver: native
executor: {kind: slurm, time_limit: 5min, retries: 1, poll_interval: 1s}
factors:
  - {name: outlet_diameter, min: 0.020, max: 0.028, unit: m}
fixed: {n_particles: 400, fill_time: 100, discharge_time: 0.1}
design: {type: full_factorial, levels: 2}
seed: 5
";

#[test]
fn a_job_whose_node_fails_runs_again_and_orch_cancel_scancels_everything() {
    let Some(conf) = require_slurm() else { return };
    let _cluster = slurm_lock();
    let project = Project::on_slurm(&conf);
    let file = project.write("long.yaml", LONG);
    let mut orch = Background::start(&project, &["submit", file.to_str().unwrap()]);
    let running = orch.wait_for(&project, "node-fail", Duration::from_secs(60), |s| {
        count(s, "running") == 2
    });
    let first = job(&running, "p000r0");
    let first_handle = first["handle"].as_str().unwrap().to_string();
    // "RUNNING on n1": take that node down under the job.
    let node = first["scheduler_state"]
        .as_str()
        .unwrap()
        .rsplit(' ')
        .next()
        .unwrap()
        .to_string();
    let _back = NodeBack {
        conf: &conf,
        node: node.clone(),
    };
    let down = format!("nodename={node}");
    scontrol(
        &conf,
        &["update", &down, "state=down", "reason=orch-e2e-test"],
    );

    // The attempt fails with NODE_FAIL and orch submits a second one.
    let retried = orch.wait_for(&project, "node-fail", Duration::from_secs(60), |s| {
        job(s, "p000r0")["attempts"] == 2
    });
    let second_handle = job(&retried, "p000r0")["handle"]
        .as_str()
        .unwrap()
        .to_string();
    assert_ne!(second_handle, first_handle);
    let notes = project.query(
        "SELECT e.note FROM job_events e JOIN jobs j ON j.id = e.job_id WHERE j.name = 'p000r0' AND e.to_state = 'pending'",
    );
    let note = &notes[0][0];
    assert!(
        note.starts_with("attempt 1 of 2 failed: Slurm job ")
            && note.contains(" lost its node: NODE_FAIL"),
        "{note}"
    );

    // orch cancel stops both jobs on the cluster with one scancel.
    let output = project.run(&["cancel", "node-fail"]);
    assert!(output.status.success(), "{}", text(&output.stderr));
    assert!(text(&output.stderr).contains("2 Slurm jobs cancelled with scancel"));
    let exit = orch.child.wait().unwrap();
    assert_ne!(exit.code(), Some(0), "{}", orch.stderr());
    let status = project.status("node-fail");
    assert_eq!(count(&status, "cancelled"), 2, "{status:#}");
    let ids: Vec<String> = status["jobs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|j| {
            j["handle"]
                .as_str()
                .unwrap()
                .trim_start_matches("slurm:")
                .to_string()
        })
        .collect();
    let mut arrays: Vec<&str> = ids.iter().map(|id| id.split('_').next().unwrap()).collect();
    arrays.dedup();
    // A cancelled job shows COMPLETING until slurmd has killed its processes.
    let deadline = std::time::Instant::now() + Duration::from_secs(60);
    loop {
        let squeue = Command::new("squeue")
            .args([
                "--noheader",
                "--array", // a pending array's tasks one per line, not `758_[0-1]`
                "--states=all",
                "--format=%i %T",
                "--jobs",
                &arrays.join(","),
            ])
            .env("SLURM_CONF", &conf)
            .output()
            .unwrap();
        let states = text(&squeue.stdout);
        // An array cancelled before any task left the queue is listed whole (`761`).
        let cancelled = |id: &String| {
            let array = id.split('_').next().unwrap_or(id);
            states.contains(&format!("{id} CANCELLED"))
                || states.lines().any(|l| l == format!("{array} CANCELLED"))
        };
        if ids.iter().all(cancelled) {
            break;
        }
        assert!(
            std::time::Instant::now() < deadline,
            "{states} {ids:?} {}",
            text(&squeue.stderr)
        );
        std::thread::sleep(Duration::from_millis(500));
    }
}
