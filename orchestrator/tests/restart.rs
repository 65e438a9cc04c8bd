//! `orch-dem run` killed (SIGKILL, at no chosen step) or stopped (SIGTERM, which it
//! answers with a save at the step it is in) and started again continues from its
//! restart file and ends with the same thermo rows, crossings and dumps, byte for byte,
//! as a run of the same case that never stopped.

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use nix::sys::signal::{kill, Signal};
use nix::unistd::Pid;
use orch_adapters::hopper::{self, Hopper};
use orch_adapters::{native, Case, EquipmentOnSolver, ResolvedParameters, Simulation};

/// The hopper on the native kernel, small: 1 500 spheres poured for 0.15 s and
/// discharged for 0.15 s under 0.5 mm, 50 Hz vibration (15 000 steps, a log line and a
/// save every 1 000), a dump every 0.05 s.
fn render_hopper(dir: &Path) -> String {
    let mut parameters = ResolvedParameters::defaults(hopper::PARAMETERS);
    for (name, value) in [
        ("n_particles", 1500.0),
        ("fill_time", 0.15),
        ("discharge_time", 0.15),
        ("amplitude", 0.0005),
        ("frequency", 50.0),
        ("dump_every", 2500.0),
    ] {
        parameters.set(name, value);
    }
    let case = Case {
        parameters,
        seed: 3,
        text: Default::default(),
    };
    let simulation = EquipmentOnSolver::new(&Hopper, &native::SOLVER).unwrap();
    simulation.render(&case, dir).unwrap();
    simulation.deck_file()
}

fn start(dir: &Path, deck: &str) -> Child {
    start_saving_every(dir, deck, "0s")
}

/// `orch-dem run` of `deck` in `dir`, saving its state every `restart_every`.
fn start_saving_every(dir: &Path, deck: &str, restart_every: &str) -> Child {
    Command::new(env!("CARGO_BIN_EXE_orch-dem"))
        .args([
            "run",
            deck,
            "--log",
            native::LOG_FILE,
            "--restart-every",
            restart_every,
        ])
        .current_dir(dir)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

fn finish(child: Child) -> String {
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "orch-dem failed: {stderr}");
    stderr
}

/// The log's thermo rows (the header line holds the run folder's path, and the lines
/// after the loop line the wall time); none before the log exists.
fn thermo_rows(dir: &Path) -> Vec<String> {
    let log = std::fs::read_to_string(dir.join(native::LOG_FILE)).unwrap_or_default();
    log.lines()
        .skip_while(|l| *l != native::THERMO_HEADER)
        .take_while(|l| !l.starts_with("Loop time of "))
        .map(str::to_string)
        .collect()
}

/// Every file under `post/`, by name, with its bytes.
fn outputs(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir.join("post"))
        .unwrap()
        .map(|e| {
            let e = e.unwrap();
            let name = e.file_name().to_string_lossy().into_owned();
            (name, std::fs::read(e.path()).unwrap())
        })
        .collect();
    files.sort();
    files
}

/// Waits until the log of the run in `dir` holds `rows` thermo rows.
fn wait_for_rows(dir: &Path, child: &mut Child, rows: usize) {
    let waited = Instant::now();
    while thermo_rows(dir).len() < rows {
        assert!(
            waited.elapsed() < Duration::from_secs(300),
            "no progress in the log"
        );
        assert!(
            child.try_wait().unwrap().is_none(),
            "it ended before it was stopped"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// The step of the log's `Resumed from the restart file … at step N` line.
fn resumed_step(dir: &Path, stderr: &str) -> u64 {
    let log = std::fs::read_to_string(dir.join(native::LOG_FILE)).unwrap();
    let resumed = log
        .lines()
        .find(|l| l.starts_with("Resumed from the restart file "))
        .unwrap_or_else(|| panic!("not resumed: {log}\n{stderr}"));
    resumed
        .split(" at step ")
        .nth(1)
        .and_then(|rest| rest.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no step in `{resumed}`"))
}

/// The thermo rows and every file under `post/` of the runs in `ours` and `theirs` are
/// the same, byte for byte; spheres crossed the sensor.
fn assert_same_run(ours: &Path, theirs: &Path) {
    assert_eq!(thermo_rows(ours), thermo_rows(theirs));
    let (ours, theirs) = (outputs(ours), outputs(theirs));
    let names = |files: &[(String, Vec<u8>)]| -> Vec<String> {
        files.iter().map(|(name, _)| name.clone()).collect()
    };
    assert_eq!(names(&ours), names(&theirs));
    assert!(names(&ours).iter().any(|n| n.starts_with("dump")));
    for ((name, a), (_, b)) in ours.iter().zip(&theirs) {
        assert!(a == b, "{name} differs after the restart");
    }
    let crossings =
        String::from_utf8_lossy(&ours.iter().find(|(n, _)| n == "crossings.csv").unwrap().1)
            .lines()
            .count();
    assert!(crossings > 100, "{crossings} lines of crossings");
}

/// The small hopper run whole in one folder, the same case rendered afresh in another,
/// and the case file's name.
fn straight_run_and_fresh_copy() -> (tempfile::TempDir, tempfile::TempDir, String) {
    let straight = tempfile::tempdir().unwrap();
    let deck = render_hopper(straight.path());
    finish(start(straight.path(), &deck));
    let copy = tempfile::tempdir().unwrap();
    render_hopper(copy.path());
    (straight, copy, deck)
}

#[test]
fn a_killed_run_started_again_continues_from_its_restart_file_bit_for_bit() {
    let (straight, killed, deck) = straight_run_and_fresh_copy();
    let restart_file = killed.path().join("post/restart.orch-dem");
    let mut child = start(killed.path(), &deck);
    // Kill it once it is discharging (the header, t = 0 and ten more rows: step 10 000,
    // t = 0.2 s), between two log lines, at whatever step it has reached.
    wait_for_rows(killed.path(), &mut child, 12);
    child.kill().unwrap();
    child.wait().unwrap();
    let rows_at_kill = thermo_rows(killed.path()).len();
    assert!(restart_file.exists(), "no restart file after the kill");
    assert!(rows_at_kill < thermo_rows(straight.path()).len());

    let stderr = finish(start(killed.path(), &deck));
    let step = resumed_step(killed.path(), &stderr);
    // The save at the last row, or at the one before when the kill fell between a
    // row and its save.
    assert!((9_000..15_000).contains(&step), "resumed at step {step}");
    // Spheres crossed the sensor before the kill (its crossings file was cut back to
    // the save and written on) and after it.
    assert_same_run(killed.path(), straight.path());
    assert!(!restart_file.exists(), "the restart file outlived the run");
}

#[test]
fn a_run_stopped_by_sigterm_saves_the_step_it_is_in_and_continues_from_it_bit_for_bit() {
    let (straight, stopped, deck) = straight_run_and_fresh_copy();
    let restart_file = stopped.path().join("post/restart.orch-dem");
    // No save of its own in the run: the only one is the signal's.
    let mut child = start_saving_every(stopped.path(), &deck, "1h");
    wait_for_rows(stopped.path(), &mut child, 12);
    kill(Pid::from_raw(child.id() as i32), Signal::SIGTERM).unwrap();
    let waited = Instant::now();
    let status = child.wait().unwrap();
    // Slurm sends SIGKILL 30 s after SIGTERM by default (orch locally 3 s after): one
    // step and one save must fit well within that even in a debug build on a busy machine.
    assert!(
        waited.elapsed() < Duration::from_secs(20),
        "{:?}",
        waited.elapsed()
    );
    assert_eq!(
        status.code(),
        Some(143),
        "128 + SIGTERM, as a killed process"
    );
    assert!(restart_file.exists(), "no restart file after SIGTERM");
    let log = std::fs::read_to_string(stopped.path().join(native::LOG_FILE)).unwrap();
    let last = log.lines().last().unwrap();
    assert!(last.starts_with("Stopped by SIGTERM at step "), "{last}");
    let stopped_at: u64 = last["Stopped by SIGTERM at step ".len()..]
        .split_whitespace()
        .next()
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no step in `{last}`"));
    assert!(thermo_rows(stopped.path()).len() < thermo_rows(straight.path()).len());

    let stderr = finish(start(stopped.path(), &deck));
    assert_eq!(resumed_step(stopped.path(), &stderr), stopped_at);
    let log = std::fs::read_to_string(stopped.path().join(native::LOG_FILE)).unwrap();
    assert!(
        !log.contains("Stopped by SIGTERM"),
        "the stop's line outlived the restart"
    );
    assert_same_run(stopped.path(), straight.path());
    assert!(!restart_file.exists(), "the restart file outlived the run");
}
