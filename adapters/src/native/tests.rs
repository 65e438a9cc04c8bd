use std::io::Cursor;
use std::path::Path;

use super::*;
use crate::hopper::{self, case_with, render_default};

/// Renders `case` with the default template, checks that the kernel accepts the case
/// file and its meshes, and returns the case file's text.
fn check(case: &Case) -> String {
    let dir = tempfile::tempdir().unwrap();
    let text = render_default(&SOLVER, case, dir.path());
    let parsed = orch_dem::case::Case::parse(&text).unwrap_or_else(|e| panic!("{e}\n{text}"));
    for (index, mesh) in parsed.meshes.iter().enumerate() {
        let bytes = std::fs::read(dir.path().join(&mesh.file)).unwrap();
        parsed.wall_mesh(index, &bytes).unwrap();
    }
    text
}

#[test]
fn default_case_snapshot() {
    insta::assert_snapshot!("default_case", check(&case_with(&[])));
}

#[test]
fn vibrated_valve_case_snapshot() {
    let case = case_with(&[
        ("valve_diameter", 0.016),
        ("amplitude", 0.0005),
        ("n_particles", 500.0),
    ]);
    insta::assert_snapshot!("vibrated_valve_case", check(&case));
}

#[test]
fn poured_case_in_air_with_dumps_snapshot() {
    let case = hopper::poured_case(&[("air_density", 1.2)]);
    insta::assert_snapshot!("poured_case_in_air_with_dumps", check(&case));
}

#[test]
fn the_case_is_the_liggghts_deck_s_case() {
    // Same particles, time step and planes in both solvers' input.
    let case = case_with(&[("amplitude", 0.0005)]);
    let native = check(&case);
    let dir = tempfile::tempdir().unwrap();
    let deck = render_default(&crate::liggghts::SOLVER, &case, dir.path());
    let context = hopper::context(&case).into_json();
    for name in ["sensor_z", "fill_bottom", "fill_radius", "fill_top"] {
        let value = context[name].to_string();
        assert!(
            native.contains(&value),
            "{name} = {value} in the native case"
        );
        assert!(
            deck.contains(&value),
            "{name} = {value} in the LIGGGHTS deck"
        );
    }
}

/// The neighbour skin is half the coarse radius, at most the fine radius, in both
/// solvers' input: at 2:1 the two are equal; at 5:1 the fine radius.
#[test]
fn the_skin_is_at_most_the_fine_radius() {
    let skin_of = |text: &str, key: &str| -> f64 {
        let line = text.lines().find(|l| l.starts_with(key)).unwrap();
        let value = line.trim_start_matches(key).trim_start_matches([' ', '=']);
        value.split_whitespace().next().unwrap().parse().unwrap()
    };
    for (fine_diameter_m, skin_m) in [(0.002, 0.001), (0.0008, 0.0004)] {
        let case = case_with(&[
            ("coarse_diameter", 0.004),
            ("fine_diameter", fine_diameter_m),
            ("timestep", 5e-6),
        ]);
        let native = check(&case);
        let dir = tempfile::tempdir().unwrap();
        let deck = render_default(&crate::liggghts::SOLVER, &case, dir.path());
        assert_eq!(skin_of(&native, "skin"), skin_m, "{native}");
        assert_eq!(skin_of(&deck, "neighbor"), skin_m, "{deck}");
    }
}

const LOG: &str = "orch-dem: case hopper.toml, 3 particles\n\
step time_s particles kinetic_energy_J discharged_mass_kg\n\
0 0 3 0 0\n\
1000 0.02 3 1.5e-4 0\n\
2000 0.04 1 2.5e-4 1.2e-4\n\
Loop time of 0.5 s on 1 threads for 2000 steps with 5000 particle-steps (1.0e4 particle-steps/s)\n";

#[test]
fn log_gives_loop_time_work_and_series() {
    let log = read_log(Cursor::new(LOG), Path::new("log.native")).unwrap();
    assert_eq!(log.loop_time_s, 0.5);
    assert_eq!(log.steps, 2000);
    assert_eq!(log.particle_steps, 5000.0);
    assert_eq!(log.kinetic_energy[2], (0.04, 2.5e-4));
    assert_eq!(log.discharged_mass[2], (0.04, 1.2e-4));
    assert_eq!(log.wall_impact_energy_j, None);
}

#[test]
fn the_largest_overlap_line_reads_back_as_written_and_a_bad_one_is_an_error() {
    let line = LargestOverlapLine(0.0412345).to_string();
    assert_eq!(line, "Largest overlap of 0.041235 of the smaller radius");
    let log = read_log(
        Cursor::new(format!("{LOG}{line}\n")),
        Path::new("log.native"),
    )
    .unwrap();
    assert_eq!(log.largest_overlap_ratio, Some(0.041235));
    assert_eq!(
        read_log(Cursor::new(LOG), Path::new("log.native"))
            .unwrap()
            .largest_overlap_ratio,
        None,
        "older logs have no such line"
    );
    let bad = format!("{LOG}Largest overlap of deep of the smaller radius\n");
    let error = read_log(Cursor::new(bad), Path::new("log.native")).unwrap_err();
    assert!(error.to_string().contains("overlap line"), "{error}");
}

#[test]
fn the_wall_impact_line_is_read_and_a_bad_one_is_an_error() {
    let with = format!("{LOG}Wall impact energy of 1.250000000e-3 J\n");
    let log = read_log(Cursor::new(with), Path::new("log.native")).unwrap();
    assert_eq!(log.wall_impact_energy_j, Some(1.25e-3));
    let bad = format!("{LOG}Wall impact energy of lots J\n");
    let error = read_log(Cursor::new(bad), Path::new("log.native")).unwrap_err();
    assert!(
        error
            .to_string()
            .contains("log.native:7: cannot read the impact line"),
        "{error}"
    );
}

#[test]
fn truncated_or_failed_logs_are_errors_with_the_line() {
    let truncated = &LOG[..LOG.find("Loop").unwrap()];
    let error = read_log(Cursor::new(truncated), Path::new("log.native")).unwrap_err();
    assert!(error.to_string().contains("did not finish"), "{error}");
    let failed = LOG.replace(
        "2000 0.04 1",
        "ERROR: the run went unstable at step 1234\n2000 0.04 1",
    );
    let error = read_log(Cursor::new(failed), Path::new("log.native")).unwrap_err();
    assert!(
        error
            .to_string()
            .contains("log.native:5: the run failed: the run went unstable at step 1234"),
        "{error}"
    );
    // Nine words: the particle-steps figure would be the tenth; reading it must not panic.
    let short = LOG.replace(" 5000 particle-steps (1.0e4 particle-steps/s)", "");
    let error = read_log(Cursor::new(short), Path::new("log.native")).unwrap_err();
    assert!(
        error
            .to_string()
            .contains("log.native:6: cannot read the loop line"),
        "{error}"
    );
    let garbled = LOG.replace("1000 0.02 3", "1000 0.02 x");
    let error = read_log(Cursor::new(garbled), Path::new("log.native")).unwrap_err();
    assert!(error.to_string().contains("log.native:4"), "{error}");
}

#[test]
fn crossings_are_read_in_time_order() {
    let csv = format!(
        "{CROSSINGS_HEADER}\n0.5,7,1,0.002,8e-5,0.001,0,-0.005,0,0,-1\n0.25,3,2,0.001,1e-5,0,0.002,-0.005,0,0,-0.5\n"
    );
    let crossings = read_crossings(Cursor::new(csv), Path::new("c.csv")).unwrap();
    assert_eq!(crossings.len(), 2);
    assert_eq!(crossings[0].id, 3);
    assert_eq!(crossings[1].particle_type, 1);
    assert_eq!(crossings[1].velocity_m_per_s, [0.0, 0.0, -1.0]);
}

#[test]
fn malformed_crossings_name_the_line() {
    let csv = format!("{CROSSINGS_HEADER}\n0.5,7,1,0.002,8e-5,0.001,0,-0.005,0,0\n");
    let error = read_crossings(Cursor::new(csv), Path::new("c.csv")).unwrap_err();
    assert!(
        error
            .to_string()
            .starts_with("c.csv:2: expected 11 finite numbers"),
        "{error}"
    );
    let error = read_crossings(Cursor::new("time,id\n"), Path::new("c.csv")).unwrap_err();
    assert!(
        error.to_string().contains("c.csv:1: expected the header"),
        "{error}"
    );
    // A header and no rows: nothing crossed (a jammed outlet); the responses that need
    // crossings are missing with why (see hopper::results), not a parse error.
    let nothing = format!("{CROSSINGS_HEADER}\n");
    assert!(read_crossings(Cursor::new(nothing), Path::new("c.csv"))
        .unwrap()
        .is_empty());
    // An empty file: the solver never got as far as its header.
    let error = read_crossings(Cursor::new(""), Path::new("c.csv")).unwrap_err();
    assert!(
        error.to_string().contains("c.csv:1: the file is empty"),
        "{error}"
    );
}

/// The kernel's `dump custom` snapshots read with the LIGGGHTS dump reader: one
/// parser serves both solvers.
#[test]
fn kernel_dumps_read_with_the_liggghts_dump_reader() {
    use orch_dem::material::{Material, ParticleType};
    use orch_dem::particles::Particles;
    use orch_dem::Vec3;
    let kind = ParticleType {
        radius_m: 0.001,
        density_kg_m3: 2500.0,
        material: Material {
            youngs_modulus_pa: 5e6,
            poisson_ratio: 0.3,
            restitution: 0.6,
            friction: 0.5,
            rolling_friction: 0.0,
        },
    };
    let mut particles = Particles::default();
    particles.push(4, 1, &kind, Vec3::new(0.001, 0.002, -0.004));
    particles.velocity_m_per_s[0] = Vec3::new(0.0, 0.0, -1.25);
    particles.angular_velocity[0] = Vec3::new(0.5, -2.0, 0.0);
    let mut bytes = Vec::new();
    orch_dem::output::write_dump_custom(
        &mut bytes,
        300,
        &particles,
        Vec3::repeat(-0.1),
        Vec3::repeat(0.1),
    )
    .unwrap();
    let mut seen = Vec::new();
    crate::dump::read_dump(
        Cursor::new(bytes),
        Path::new("dump300.liggghts"),
        |snapshot| {
            assert_eq!(snapshot.timestep, 300);
            // The angular velocity comes after the columns LIGGGHTS readers expect.
            let omega: Vec<usize> = ["omegax", "omegay", "omegaz"]
                .iter()
                .map(|c| snapshot.column(c).expect("the native dump carries ω"))
                .collect();
            assert_eq!(omega, [10, 11, 12]);
            assert_eq!(snapshot.values[11], -2.0);
            seen.extend(snapshot.sightings().map_err(|m| m.join(","))?);
            Ok(())
        },
    )
    .unwrap();
    assert_eq!(seen.len(), 1);
    assert_eq!(seen[0].id, 4);
    assert_eq!(seen[0].particle_type, 2);
    assert_eq!(seen[0].velocity_m_per_s, [0.0, 0.0, -1.25]);
}

/// A real 150-particle run of the kernel (`tests/fixtures/native/`).
fn fixtures() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/fixtures/native")
}

#[test]
fn a_real_run_parses_and_its_crossings_cover_the_mass_the_kernel_removed() {
    let observations = hopper::observe(&SOLVER, &case_with(&[]), &fixtures()).unwrap();
    let crossed: f64 = observations.crossings.iter().map(|c| c.mass_kg).sum();
    let log = read_log(
        std::fs::read(fixtures().join(LOG_FILE)).unwrap().as_slice(),
        Path::new(LOG_FILE),
    )
    .unwrap();
    let removed = log.discharged_mass.last().unwrap().1;
    assert!(
        crossed >= removed * 0.999999,
        "{crossed} kg crossed, {removed} kg removed"
    );
}

/// A crossings file cut short at any byte (here: half its size, which may end in a
/// number that still parses) is refused against the kernel's own total.
#[test]
fn crossings_cut_short_are_refused_against_the_kernel_s_total() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("post")).unwrap();
    std::fs::copy(fixtures().join(LOG_FILE), dir.path().join(LOG_FILE)).unwrap();
    let csv = std::fs::read_to_string(fixtures().join(CROSSINGS_FILE)).unwrap();
    // Cut at the last line end before half the size, so every row left parses.
    let half = csv[..csv.len() / 2].rfind('\n').unwrap() + 1;
    std::fs::write(dir.path().join(CROSSINGS_FILE), &csv[..half]).unwrap();
    let error = hopper::observe(&SOLVER, &case_with(&[]), dir.path())
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("post/crossings.csv: its ")
            && error.contains("the file is cut short or damaged"),
        "{error}"
    );
}

#[test]
fn crossings_with_no_mass_or_a_negative_time_are_malformed() {
    let row = |time: &str, mass: &str| {
        format!("{CROSSINGS_HEADER}\n{time},1,1,0.002,{mass},0.001,0,-0.005,0,0,-1\n")
    };
    for (time, mass, what) in [
        ("0.1", "0", "mass 0 kg"),
        ("0.1", "-1e-5", "mass -0.00001 kg"),
        ("-0.1", "1e-5", "time -0.1 s"),
    ] {
        let error = read_crossings(Cursor::new(row(time, mass)), Path::new("c.csv"))
            .unwrap_err()
            .to_string();
        assert!(error.starts_with("c.csv:2: a crossing needs"), "{error}");
        assert!(error.contains(what), "{what}: {error}");
    }
}

#[test]
fn a_running_crossings_file_is_read_up_to_its_last_complete_line() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("post")).unwrap();
    let row = "0.25,3,2,0.001,1e-5,0,0.002,-0.005,0,0,-0.5";
    std::fs::write(
        dir.path().join(CROSSINGS_FILE),
        format!("{CROSSINGS_HEADER}\n{row}\n0.5,7,1,0.00"),
    )
    .unwrap();
    let sensor = crate::SensorPlane { height_m: -0.005 };
    let case = case_with(&[]);
    let observations = (SOLVER.parse_running)(&case, &sensor, dir.path()).unwrap();
    assert_eq!(observations.crossings.len(), 1);
    assert_eq!(observations.crossings[0].id, 3);
    // The log is not read: a running kernel has not written its summary yet.
    assert_eq!(observations.solver_loop_time_s, None);
}

#[test]
fn command_runs_the_kernel_on_one_thread_unless_given_more_cores() {
    use crate::Simulation;
    let one = hopper::on(&SOLVER).command();
    assert!(one.program.ends_with(PROGRAM), "{}", one.program);
    assert_eq!(one.args, ["run", "hopper.toml", "--log", LOG_FILE]);
    assert_eq!(one.cores, 1);
    let two = hopper::on(&SOLVER).with_cores(2).command();
    assert_eq!(
        two.args,
        ["run", "hopper.toml", "--log", LOG_FILE, "--threads", "2"]
    );
    assert_eq!(two.cores, 2);
    assert_eq!(two.program, one.program);
}

#[test]
fn the_case_file_does_not_depend_on_the_cores() {
    use crate::Simulation;
    let case = case_with(&[]);
    let texts = |cores| hopper::on(&SOLVER).with_cores(cores).render_texts(&case);
    assert_eq!(texts(1).unwrap(), texts(4).unwrap());
}

#[test]
fn the_loop_line_reads_back_as_written() {
    let line = LoopLine {
        seconds: 3.25,
        threads: 2,
        steps: 10_000,
        particle_steps: 3e7,
    };
    let text = line.to_string();
    assert_eq!(
        text,
        "Loop time of 3.250000 s on 2 threads for 10000 steps with 30000000 particle-steps (9.2308e6 particle-steps/s)"
    );
    assert_eq!(LoopLine::find_in(&format!("x\n{text}\ny\n")), Some(line));
    assert_eq!(LoopLine::find_in("Loop time of 3 s\n"), None);
}

#[test]
fn the_inflow_line_reads_back_as_written_and_a_bad_one_is_an_error() {
    let short = InflowLine {
        number: 1,
        count: 2,
        placed_kg: 2.1e-2,
        asked_kg: 2.7792e-2,
        shares_by_mass_percent: vec![("coarse".into(), 79.9), ("fine sand".into(), 20.1)],
        short: true,
    };
    let full = InflowLine {
        number: 2,
        placed_kg: 1e-3,
        asked_kg: 1e-3,
        short: false,
        ..short.clone()
    };
    let text = format!("{LOG}{short}\n{full}\n");
    assert!(
        text.contains("Inflow 1 of 2 placed 2.100000e-2 kg of the 2.779200e-2 kg asked (75.6 %; by mass coarse 79.9 %, fine sand 20.1 %): its region had no room for the rest"),
        "{text}"
    );
    let log = read_log(Cursor::new(text), Path::new("log.native")).unwrap();
    assert_eq!(log.inflows, vec![short, full]);
    let placed = log.inflow_placed().unwrap();
    assert!((placed.placed_kg - 2.2e-2).abs() < 1e-15, "{placed:?}");
    assert!((placed.asked_kg - 2.8792e-2).abs() < 1e-15, "{placed:?}");
    assert!(placed.short);
    assert_eq!(
        read_log(Cursor::new(LOG), Path::new("log.native"))
            .unwrap()
            .inflow_placed(),
        None,
        "a run without an inflow has no such line"
    );
    let bad =
        format!("{LOG}Inflow 1 of 1 placed much kg of the 1e-3 kg asked (0 %; by mass a 1 %)\n");
    let error = read_log(Cursor::new(bad), Path::new("log.native")).unwrap_err();
    assert!(error.to_string().contains("inflow line"), "{error}");
}

#[test]
fn a_short_inflow_is_stored_as_its_placed_fraction_and_said_in_the_note() {
    use crate::simulation::{Simulation, SOLVER_INFLOW_PLACED};
    let simulation = crate::EquipmentOnSolver::new(&hopper::Hopper, &SOLVER).unwrap();
    let case = case_with(&[]);
    let results_of = |inflow: &InflowLine| {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(dir.path().join("post")).unwrap();
        std::fs::write(
            dir.path().join(CROSSINGS_FILE),
            format!("{CROSSINGS_HEADER}\n"),
        )
        .unwrap();
        // Nothing discharged, as the empty crossings file says.
        let log = LOG.replace("2.5e-4 1.2e-4", "2.5e-4 0");
        std::fs::write(dir.path().join(LOG_FILE), format!("{log}{inflow}\n")).unwrap();
        simulation.results(&case, dir.path()).unwrap()
    };
    let fraction = |results: &crate::RunResults| {
        results
            .responses
            .iter()
            .find(|(name, _)| name == SOLVER_INFLOW_PLACED)
            .map(|&(_, v)| v)
    };
    let short = InflowLine {
        number: 1,
        count: 1,
        placed_kg: 0.75,
        asked_kg: 1.0,
        shares_by_mass_percent: vec![("coarse".into(), 80.0), ("fine".into(), 20.0)],
        short: true,
    };
    let results = results_of(&short);
    assert_eq!(fraction(&results), Some(0.75));
    let note = results.notes.join("; ");
    assert!(
        note.contains("the inflow placed 75.0 % of the 1.0000e0 kg asked")
            && note.contains("`pour_diameter`"),
        "{note}"
    );
    let full = InflowLine {
        placed_kg: 1.0,
        short: false,
        ..short
    };
    let results = results_of(&full);
    assert_eq!(fraction(&results), Some(1.0));
    assert!(results.notes.is_empty(), "{:?}", results.notes);
}
