use std::path::Path;

use super::*;
use crate::hopper::{self, case_with, observe, on, render_default};
use crate::{Simulation, TemplateText};

/// Renders `case` with the default template and returns the deck.
fn check(case: &Case) -> String {
    let dir = tempfile::tempdir().unwrap();
    let deck = render_default(&SOLVER, case, dir.path());
    for file in ["hopper.stl", "plug.stl", "sink.stl"] {
        assert!(dir.path().join(file).exists(), "{file}");
    }
    deck
}

#[test]
fn default_deck_snapshot() {
    insta::assert_snapshot!("default_deck", check(&case_with(&[])));
}

#[test]
fn vibrated_deck_with_valve_snapshot() {
    let case = case_with(&[
        ("valve_diameter", 0.012),
        ("valve_gap", 0.010),
        ("amplitude", 0.0009),
        ("frequency", 50.0),
        ("n_particles", 1500.0),
    ]);
    insta::assert_snapshot!("vibrated_valve_deck", check(&case));
}

#[test]
fn poured_deck_in_air_with_dumps_snapshot() {
    let case = hopper::poured_case(&[("air_density", 1.2)]);
    insta::assert_snapshot!("poured_deck_in_air_with_dumps", check(&case));
}

#[test]
fn impossible_geometry_is_refused_before_rendering() {
    let case = case_with(&[("outlet_diameter", 0.003)]);
    let error = on(&SOLVER).equipment.check(&case).unwrap_err().to_string();
    assert_eq!(
        error,
        "invalid case: outlet_diameter (0.003 m) must exceed coarse_diameter (0.004 m), or nothing can flow"
    );
}

#[test]
fn template_errors_name_the_template() {
    let dir = tempfile::tempdir().unwrap();
    let template = TemplateText {
        name: "my.in.tera".to_string(),
        text: "run {{ no_such_value }}".to_string(),
    };
    let error = on(&SOLVER)
        .with_template(template)
        .render(&case_with(&[]), dir.path())
        .unwrap_err()
        .to_string();
    assert!(error.starts_with("template my.in.tera:1: "), "{error}");
    assert!(error.contains("no_such_value"), "{error}");
}

#[test]
fn parse_reads_crossings_from_a_rendered_then_written_run() {
    // A hand-written sensor dump: particle 1 crosses z = -0.005 between steps 100 and
    // 150 (dt = 2e-5 s), moving down at 1 m/s from 0.5 mm above the plane.
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("post")).unwrap();
    let snapshot = |step: u64, z: f64| {
        format!(
            "ITEM: TIMESTEP\n{step}\nITEM: NUMBER OF ATOMS\n1\nITEM: BOX BOUNDS mm mm mm\n0 1\n0 1\n0 1\nITEM: ATOMS id type radius mass x y z vx vy vz \n1 2 0.001 1e-5 0.003 0.004 {z} 0 0 -1 \n"
        )
    };
    let dump = snapshot(100, -0.0045) + &snapshot(150, -0.0055);
    std::fs::write(dir.path().join(SENSOR_DUMP), dump).unwrap();
    std::fs::write(
        dir.path().join(LOG_FILE),
        "Loop time of 1.5 on 1 procs for 150 steps with 1 atoms\n",
    )
    .unwrap();
    let observations = observe(&SOLVER, &case_with(&[]), dir.path()).unwrap();
    assert_eq!(observations.crossings.len(), 1);
    let crossing = observations.crossings[0];
    assert!((crossing.time_s - 125.0 * 2e-5).abs() < 1e-12);
    assert!((crossing.radial_distance_m() - 0.005).abs() < 1e-12);
    assert_eq!(observations.solver_loop_time_s, Some(1.5));
}

#[test]
fn missing_output_names_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let error = observe(&SOLVER, &case_with(&[]), dir.path())
        .unwrap_err()
        .to_string();
    assert!(
        error.starts_with(&format!(
            "cannot read {}",
            Path::new(dir.path()).join(LOG_FILE).display()
        )),
        "{error}"
    );
}

/// The sink's own count in the log (`outflow[1]`, kg) against the crossings found in
/// the sensor dump: a dump cut short holds less.
#[test]
fn a_sensor_dump_that_holds_less_than_the_sink_removed_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("post")).unwrap();
    let snapshot = |step: u64, z: f64| {
        format!(
            "ITEM: TIMESTEP\n{step}\nITEM: NUMBER OF ATOMS\n1\nITEM: BOX BOUNDS mm mm mm\n0 1\n0 1\n0 1\nITEM: ATOMS id type radius mass x y z vx vy vz \n1 2 0.001 1e-5 0.003 0.004 {z} 0 0 -1 \n"
        )
    };
    std::fs::write(
        dir.path().join(SENSOR_DUMP),
        snapshot(100, -0.0045) + &snapshot(150, -0.0055),
    )
    .unwrap();
    let log = |removed: &str| {
        format!(
            "    Step    Atoms         KinEng     outflow[1]     outflow[2]            CPU \n     100        3              0              0              0              0 \n     150        1              0         {removed}              2              0 \nLoop time of 1.5 on 1 procs for 150 steps with 1 atoms\n"
        )
    };
    // One crossing of 1e-5 kg; the sink removed 1e-5 kg: consistent.
    std::fs::write(dir.path().join(LOG_FILE), log("1e-5")).unwrap();
    observe(&SOLVER, &case_with(&[]), dir.path()).unwrap();
    // The sink removed 2e-5 kg, twice what crossed: the dump is cut short.
    std::fs::write(dir.path().join(LOG_FILE), log("2e-5")).unwrap();
    let error = observe(&SOLVER, &case_with(&[]), dir.path())
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("sensor.liggghts: its 1 crossings hold 1.000000e-5 kg, but the solver counted 2.000000e-5 kg"),
        "{error}"
    );
}

#[test]
fn a_running_dump_is_read_up_to_its_last_snapshot_which_may_be_half_written() {
    // Particle 1 crosses z = -0.005 between steps 100 and 150; step 200's snapshot is
    // being written (its atom line cut short) and is left out; no log is read.
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("post")).unwrap();
    let snapshot = |step: u64, z: f64| {
        format!(
            "ITEM: TIMESTEP\n{step}\nITEM: NUMBER OF ATOMS\n1\nITEM: BOX BOUNDS mm mm mm\n0 1\n0 1\n0 1\nITEM: ATOMS id type radius mass x y z vx vy vz\n1 2 0.001 1e-5 0.003 0.004 {z} 0 0 -1\n"
        )
    };
    let full = snapshot(100, -0.0045) + &snapshot(150, -0.0055);
    let writing = format!("{full}ITEM: TIMESTEP\n200\nITEM: NUMBER OF ATOMS\n1\nITEM: BOX BOUNDS mm mm mm\n0 1\n0 1\n0 1\nITEM: ATOMS id type radius mass x y z vx vy vz\n1 2 0.0");
    std::fs::write(dir.path().join(SENSOR_DUMP), writing).unwrap();
    let sensor = crate::SensorPlane { height_m: -0.005 };
    let observations = (SOLVER.parse_running)(&case_with(&[]), &sensor, dir.path()).unwrap();
    assert_eq!(observations.crossings.len(), 1);
    assert!((observations.crossings[0].time_s - 125.0 * 2e-5).abs() < 1e-12);
    assert_eq!(observations.solver_loop_time_s, None);
    // A dump whose only snapshot is still being written holds no crossing yet.
    std::fs::write(
        dir.path().join(SENSOR_DUMP),
        "ITEM: TIMESTEP\n100\nITEM: NUMBER OF ATOMS\n1\nITEM: BOX",
    )
    .unwrap();
    let observations = (SOLVER.parse_running)(&case_with(&[]), &sensor, dir.path()).unwrap();
    assert!(observations.crossings.is_empty());
}

#[test]
fn command_on_one_core_runs_liggghts_itself() {
    let command = on(&SOLVER).command();
    assert_eq!(command.program, "liggghts");
    assert_eq!(
        command.args,
        ["-in", "hopper.in", "-log", LOG_FILE, "-echo", "none"]
    );
    assert_eq!(command.cores, 1);
    assert!(command.env.is_empty());
}

#[test]
fn command_on_two_cores_runs_two_mpi_ranks_allowed_as_root() {
    let command = on(&SOLVER).with_cores(2).command();
    assert_eq!(command.program, "mpirun");
    assert_eq!(
        command.args,
        [
            "-np",
            "2",
            "liggghts",
            "-in",
            "hopper.in",
            "-log",
            LOG_FILE,
            "-echo",
            "none"
        ]
    );
    assert_eq!(command.cores, 2);
    assert_eq!(command.env["OMPI_ALLOW_RUN_AS_ROOT"], "1");
    assert_eq!(command.env["OMPI_ALLOW_RUN_AS_ROOT_CONFIRM"], "1");
    assert_eq!(command.env["OMPI_MCA_mpi_yield_when_idle"], "1");
}

#[test]
fn decks_on_more_cores_differ_only_in_their_processor_grid() {
    let case = case_with(&[]);
    let deck = |cores| {
        let texts = on(&SOLVER).with_cores(cores).render_texts(&case).unwrap();
        texts.into_iter().next().unwrap().1
    };
    let one = deck(1);
    assert!(one.contains("\nprocessors      1 1 1\n"));
    // The hopper's box is taller than wide: two ranks split it along z.
    assert_eq!(
        deck(2),
        one.replace("processors      1 1 1", "processors      1 1 2")
    );
    assert_eq!(
        deck(4),
        one.replace("processors      1 1 1", "processors      1 2 2")
    );
}
