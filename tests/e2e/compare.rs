//! `orch compare --quick` on real LIGGGHTS and the native kernel: the CI subset of the
//! nightly comparison agrees, is stored with its solvers' versions, and a deliberately
//! perturbed native kernel is caught as a regression naming the response.

use std::path::{Path, PathBuf};
use std::process::Stdio;
use std::time::{Duration, Instant};

use crate::support::{require_liggghts, root, solver_lock, text, Project};

fn suite() -> String {
    root()
        .join("jobs/compare/suite.yaml")
        .to_str()
        .unwrap()
        .to_string()
}

/// The quick suite agrees (exit 0) and its row, responses and speeds are stored; the
/// same suite with the native density off by 30 % exits 1 naming the discharge rate.
/// (A friction off by 30 % moves the quick hopper's discharge rate by about 1 %, well
/// inside any useful tolerance, so it cannot be the test's perturbation: measured
/// when the suite was written, see docs/nightly.md.)
#[test]
fn quick_comparison_agrees_and_a_perturbed_native_kernel_is_a_regression() {
    if !require_liggghts() {
        return;
    }
    let _lock = solver_lock();
    let project = Project::new();
    let started = Instant::now();
    let output = project.run(&["compare", &suite(), "--quick"]);
    let stdout = text(&output.stdout);
    let stderr = text(&output.stderr);
    eprintln!(
        "orch compare --quick: {:.0} s\n{stdout}",
        started.elapsed().as_secs_f64()
    );
    assert_eq!(output.status.code(), Some(0), "{stdout}\n{stderr}");
    assert!(!stdout.contains("regression"), "{stdout}");
    assert!(stdout.contains("liggghts=LIGGGHTS-PUBLIC"), "{stdout}");
    let rows = project
        .query("SELECT verdict, quick, solver_versions, git_commit IS NOT NULL FROM comparisons");
    assert_eq!(rows.len(), 1, "{rows:?}");
    assert_eq!(rows[0][1], "1");
    assert!(rows[0][2].contains("native="), "{rows:?}");
    assert_eq!(rows[0][3], "1", "the repository's commit is recorded");
    let speeds = project
        .query("SELECT solver, particle_steps_per_s, runs FROM comparison_speeds ORDER BY solver");
    assert_eq!(speeds.len(), 2, "{speeds:?}");
    for speed in &speeds {
        assert!(speed[1].parse::<f64>().unwrap() > 1e5, "{speeds:?}");
    }
    let responses = project.query("SELECT response, verdict FROM comparison_responses");
    assert!(
        responses.iter().any(|r| r[0] == "discharge_rate"),
        "{responses:?}"
    );
    assert!(
        project.project_dir().join("reports/compare.html").is_file(),
        "the report is written"
    );

    let made = project.query("SELECT COUNT(*) FROM comparison_runs");
    let made: usize = made[0][0].parse().unwrap();
    assert!(made >= 2, "every run is recorded by its identity: {made}");

    // The perturbation changes only the native decks: the LIGGGHTS runs are the
    // first comparison's, taken from the store instead of running again.
    let output = project.run(&["compare", &suite(), "--quick", "--perturb", "density=1.3"]);
    let stdout = text(&output.stdout);
    let stderr = text(&output.stderr);
    eprintln!("orch compare --quick --perturb density=1.3:\n{stdout}");
    let reused = format!(
        "orch compare: {} runs were made by an earlier comparison",
        made / 2
    );
    assert!(stderr.contains(&reused), "{reused}:\n{stderr}");
    // The taken runs bring their rates, not their speed: it was of another moment.
    let speeds = project.query(
        "SELECT solver, runs FROM comparison_speeds WHERE comparison_id = (SELECT MAX(id) FROM comparisons) ORDER BY solver",
    );
    assert_eq!(speeds[0], ["liggghts", "0"], "{speeds:?}");
    assert_ne!(speeds[1][1], "0", "{speeds:?}");
    assert_eq!(output.status.code(), Some(1), "{stdout}\n{stderr}");
    let regression = stdout
        .lines()
        .find(|l| l.starts_with("REGRESSION:"))
        .unwrap_or_else(|| panic!("no REGRESSION line:\n{stdout}"));
    assert!(regression.contains("discharge_rate"), "{regression}");
    assert!(
        stdout.contains("CHANGED: hopper-quick discharge_rate"),
        "the change since the last clean run is flagged:\n{stdout}"
    );
    let rows = project.query("SELECT verdict, perturbation FROM comparisons ORDER BY id");
    assert_eq!(
        rows[1],
        vec!["regression".to_string(), "density=1.3".to_string()]
    );
}

/// Wrong input is refused before anything runs, naming what is wrong (exit 2).
#[test]
fn compare_refuses_a_bad_suite_and_bad_options() {
    let project = Project::new();
    let bad = project.write(
        "suite.yaml",
        "cases:\n- name: a\n  equipment: hopper\n  quick: true\n  seeds: [1]\n  responses: {discharge_rate: {tolerance: 0.1}}\n",
    );
    for (args, expected) in [
        (
            vec!["compare", bad.to_str().unwrap()],
            "two different seeds",
        ),
        (
            vec!["compare", &suite(), "--perturb", "friction"],
            "NAME=FACTOR",
        ),
        (
            vec!["compare", &suite(), "--perturb", "grip=1.3"],
            "not a parameter of hopper",
        ),
        (
            vec!["compare", &suite(), "--solvers", "liggghts"],
            "`native`",
        ),
    ] {
        let output = project.run(&args);
        let stderr = text(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(expected), "{args:?}: {stderr}");
    }
    assert!(!project.project_dir().join("orch.db").exists());
}

/// One small hopper case, two seeds: runs of a few seconds each.
const SMALL_SUITE: &str = "\
confidence: 0.95
cases:
  - name: hopper-small
    description: a small hopper for the runner's limits
    equipment: hopper
    quick: true
    seeds: [1, 2]
    fixed: {n_particles: 1500, fill_time: 0.25, discharge_time: 0.5}
    responses:
      discharge_rate: {tolerance: 0.1}
";

/// Processes whose working directory lies under `dir`: a comparison's solver runs.
fn processes_under(dir: &Path) -> Vec<(u32, PathBuf)> {
    let mut found = Vec::new();
    for entry in std::fs::read_dir("/proc").unwrap().flatten() {
        let Ok(pid) = entry.file_name().to_string_lossy().parse::<u32>() else {
            continue;
        };
        let zombie = std::fs::read_to_string(entry.path().join("stat"))
            .map(|stat| stat.contains(") Z "))
            .unwrap_or(true);
        if let Ok(cwd) = std::fs::read_link(entry.path().join("cwd")) {
            if cwd.starts_with(dir) && !zombie {
                found.push((pid, cwd));
            }
        }
    }
    found
}

/// `orch compare` runs its solvers through the executor: a run past `--time-limit` is
/// stopped (its process group with it) and counts as a failed run, and Ctrl-C stops
/// every run, exits 130 and records no comparison.
#[test]
fn compare_runs_are_stopped_past_their_time_limit_and_on_ctrl_c() {
    if !require_liggghts() {
        return;
    }
    let _lock = solver_lock();
    let project = Project::new();
    let suite = project.write("suite.yaml", SMALL_SUITE);
    let suite = suite.to_str().unwrap();
    let runs = project.project_dir().join("runs/compare");

    let output = project.run(&["compare", suite, "--time-limit", "1s"]);
    let stdout = text(&output.stdout);
    assert_eq!(
        output.status.code(),
        Some(1),
        "{stdout}\n{}",
        text(&output.stderr)
    );
    assert!(stdout.contains("ran past the time limit of 1s"), "{stdout}");
    assert!(
        processes_under(&runs).is_empty(),
        "{:?}",
        processes_under(&runs)
    );

    let orch = project
        .orch(&["compare", suite])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(60);
    while processes_under(&runs).is_empty() {
        assert!(Instant::now() < deadline, "no solver started in 60 s");
        std::thread::sleep(Duration::from_millis(50));
    }
    let kill = std::process::Command::new("kill")
        .args(["-INT", &orch.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let output = orch.wait_with_output().unwrap();
    let stderr = text(&output.stderr);
    assert_eq!(output.status.code(), Some(130), "{stderr}");
    assert!(stderr.contains("orch compare: interrupted"), "{stderr}");
    assert!(
        processes_under(&runs).is_empty(),
        "{:?}",
        processes_under(&runs)
    );
    // Only the first comparison was recorded; the interrupted one compared nothing.
    let rows = project.query("SELECT COUNT(*) FROM comparisons");
    assert_eq!(rows[0][0], "1", "{rows:?}");
}
