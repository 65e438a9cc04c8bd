use std::io::Cursor;
use std::path::Path;

use super::*;
use crate::hopper::{self, case_with, observe, on, render_default};
use crate::Simulation;

/// Renders `case` with the default template and returns the script's text.
fn render(case: &Case) -> String {
    let dir = tempfile::tempdir().unwrap();
    let script = render_default(&SOLVER, case, dir.path());
    for mesh in ["hopper.stl", "plug.stl", "sink.stl"] {
        assert!(dir.path().join(mesh).is_file(), "{mesh} not written");
    }
    script
}

#[test]
fn default_script_snapshot() {
    insta::assert_snapshot!("default_script", render(&case_with(&[])));
}

#[test]
fn vibrated_valve_script_snapshot() {
    let case = case_with(&[
        ("valve_diameter", 0.016),
        ("amplitude", 0.0005),
        ("n_particles", 500.0),
    ]);
    insta::assert_snapshot!("vibrated_valve_script", render(&case));
}

#[test]
fn poured_script_with_dumps_snapshot() {
    insta::assert_snapshot!(
        "poured_script_with_dumps",
        render(&hopper::poured_case(&[]))
    );
}

#[test]
fn yade_refuses_air_drag_and_says_which_solvers_have_it() {
    let dir = tempfile::tempdir().unwrap();
    let error = on(&SOLVER)
        .render(&case_with(&[("air_density", 1.2)]), dir.path())
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("YADE has no air drag in orch's hopper template: set air_density to 0, or use solver: native or liggghts"),
        "{error}"
    );
}

#[test]
fn the_script_is_the_liggghts_deck_s_case() {
    let case = case_with(&[("amplitude", 0.0005)]);
    let script = render(&case);
    let context = hopper::context(&case).into_json();
    for name in [
        "sensor_z",
        "fill_bottom",
        "fill_radius",
        "fill_top",
        "timestep",
        "delete_z",
    ] {
        let value = context[name].to_string();
        assert!(script.contains(&value), "{name} = {value} in the script");
    }
    // Physical restitution needs YADE's numerical damping off.
    assert!(script.contains("NewtonIntegrator(damping=0.0"));
}

#[test]
fn command_runs_yade_in_batch_on_one_thread() {
    let command = on(&SOLVER).command();
    assert_eq!(command.program, "yade");
    assert_eq!(command.args, ["-j", "1", "-n", "-x", "hopper.py"]);
    assert_eq!(command.cores, 1);
}

/// A real run's output (tests/fixtures/yade/, 300 particles) parses into crossings.
#[test]
fn real_output_parses_into_crossings() {
    let fixtures = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/fixtures/yade");
    let observations = observe(&SOLVER, &case_with(&[]), &fixtures).unwrap();
    assert!(
        observations.crossings.len() > 250,
        "{}",
        observations.crossings.len()
    );
    assert!(observations
        .crossings
        .windows(2)
        .all(|w| w[0].time_s <= w[1].time_s));
    assert!(observations
        .crossings
        .iter()
        .all(|c| c.position_m[2] == -0.005));
    assert!(observations.solver_loop_time_s.unwrap() > 0.0);
    assert!(observations.particle_steps.unwrap() > 1e5);
}

#[test]
fn truncated_and_malformed_output_is_an_error_naming_the_file_and_line() {
    let fixtures = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/fixtures/yade");
    let log = std::fs::read_to_string(fixtures.join(LOG_FILE)).unwrap();
    // A run killed before its summary line.
    let truncated: String = log
        .lines()
        .filter(|l| !l.starts_with(SUMMARY_PREFIX))
        .map(|l| format!("{l}\n"))
        .collect();
    let error = read_log(Cursor::new(truncated), Path::new("log.yade")).unwrap_err();
    assert!(error.to_string().contains("did not finish"), "{error}");
    let bad = "ORCH SUMMARY loop_time_s=abc steps=1 particle_steps=1 particles_left=0\n";
    let error = read_log(Cursor::new(bad), Path::new("log.yade")).unwrap_err();
    assert!(error.to_string().contains("log.yade:1"), "{error}");
    assert!(error.to_string().contains("loop_time_s"), "{error}");

    // Crossings cut in the middle of a line.
    let csv = std::fs::read_to_string(fixtures.join(CROSSINGS_FILE)).unwrap();
    let cut = &csv[..csv.len() - 20];
    let lines = cut.lines().count();
    let error = read_crossings(Cursor::new(cut), Path::new("c.csv")).unwrap_err();
    assert!(
        error.to_string().contains(&format!("c.csv:{lines}")),
        "{error}"
    );
}

/// The script's own count of the mass it removed below the sink, against the
/// crossings it wrote: crossings cut short are refused; a log without the count (an
/// older script) is read as before.
#[test]
fn crossings_are_checked_against_the_mass_the_script_removed() {
    let fixtures = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/fixtures/yade");
    let log = std::fs::read_to_string(fixtures.join(LOG_FILE)).unwrap();
    assert_eq!(
        read_log(Cursor::new(&log), Path::new("log.yade"))
            .unwrap()
            .removed_mass_kg,
        None
    );
    let csv = std::fs::read_to_string(fixtures.join(CROSSINGS_FILE)).unwrap();
    let crossings = read_crossings(Cursor::new(&csv), Path::new("c.csv")).unwrap();
    let crossed: f64 = crossings.iter().map(|c| c.mass_kg).sum();
    let with_count = |removed: f64| {
        log.lines()
            .map(|l| {
                if l.starts_with(SUMMARY_PREFIX) {
                    format!("{l} removed_mass_kg={removed:.9e}\n")
                } else {
                    format!("{l}\n")
                }
            })
            .collect::<String>()
    };
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("post")).unwrap();
    std::fs::write(dir.path().join(CROSSINGS_FILE), &csv).unwrap();
    std::fs::write(dir.path().join(LOG_FILE), with_count(crossed)).unwrap();
    observe(&SOLVER, &case_with(&[]), dir.path()).unwrap();
    std::fs::write(dir.path().join(LOG_FILE), with_count(2.0 * crossed)).unwrap();
    let error = observe(&SOLVER, &case_with(&[]), dir.path())
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("the file is cut short or damaged"),
        "{error}"
    );
}

#[test]
fn command_on_two_cores_asks_yade_for_two_threads() {
    let command = on(&SOLVER).with_cores(2).command();
    assert_eq!(command.program, "yade");
    assert_eq!(command.args, ["-j", "2", "-n", "-x", "hopper.py"]);
    assert_eq!(command.cores, 2);
    assert_eq!(
        command.env.get("PYTHONUNBUFFERED").map(String::as_str),
        Some("1"),
        "a traceback is written as it happens"
    );
    assert_eq!(command.env.len(), 1);
}
