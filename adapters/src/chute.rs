//! The transfer chute, the second [`Equipment`]: a stream of a bidisperse mixture fed
//! at a mass rate onto the top of a curved chute (the B-spline plate of
//! [`orch_granular::ChuteGeometry`], with the hopper cone's shape variables), sliding
//! off its lip and falling `drop_height` onto a receiving plane (a belt), which is the
//! sensor plane. The responses come from the crossings of that plane
//! ([`orch_granular::stream`]): impact speed, speed and angle at the lip traced back
//! through the free fall, stream width, fines in the stream's outer layer (the dust
//! proxy), the mass held up on the chute and, where the solver reports wall impacts
//! (the native kernel), a wall-wear proxy: normal impact energy per unit wall area.
//!
//! Templates: `templates/native/chute.toml.tera` (the kernel's `[[inflow]]`) and
//! `templates/liggghts/chute.in.tera` (`fix insert/rate/region`, the same sensor band
//! dump as the hopper deck); both render the same context, so a design point is the
//! same case on either.
//!
//! The chute's response names live here and nowhere else in `orch`.

use std::path::Path;

use orch_granular::responses::cumulative_mass_series;
use orch_granular::stream::{StreamOptions, StreamResponses};
use orch_granular::ChuteGeometry;
use tera::Context;

use crate::equipment::{response, Equipment, ResponseSpec, SensorPlane};
use crate::params::spec;
use crate::primes::prime_seed;
use crate::simulation::write;
use crate::{Case, Observations, ParameterSpec, RenderError, RunResults, Series};

/// The transfer chute equipment.
#[derive(Debug, Clone, Copy, Default)]
pub struct Chute;

/// Gravity of every chute template, m/s².
pub const GRAVITY_M_S2: f64 = 9.81;

/// Half-thickness of the band around the receiving plane that LIGGGHTS dumps, m.
pub const SENSOR_BAND_M: f64 = 0.005;

/// Fraction of the crossings in the stream's outer layer.
pub const OUTER_LAYER: f64 = 0.1;

/// The chute's scalar responses, from the particles that crossed the receiving plane.
pub static RESPONSES: &[ResponseSpec] = &[
    response(
        "impact_speed",
        "m/s",
        "mass-weighted mean speed of the particles reaching the receiving plane",
    ),
    response(
        "lip_speed",
        "m/s",
        "mass-weighted mean speed at the lip, each landing traced back through free fall (|v|² − 2 g drop_height)",
    ),
    response(
        "lip_angle",
        "deg",
        "mass-weighted mean angle below the horizontal at the lip, traced back through free fall",
    ),
    response(
        "stream_width",
        "m",
        "5-95 % range of the landing positions across the flow (y)",
    ),
    response(
        "outer_fine_fraction",
        "-",
        "mass fraction of fines among the 10 % of landings farthest from the stream's centre (each axis scaled by its 5-95 % half-range): the dust proxy",
    ),
    response(
        "stream_fine_fraction",
        "-",
        "mass fraction of fines among all landings",
    ),
    response(
        "held_up_mass",
        "kg",
        "mass fed (mass_rate × feed_time) that has not reached the receiving plane by the end of the run",
    ),
    response(
        "wall_impact_energy",
        "J/m^2",
        "wear proxy: sum over particle-wall impacts of the normal approach energy ½ m v_n², per unit area of the chute's walls (plate, side and back walls); native kernel only",
    ),
    response("landed_mass", "kg", "mass that crossed the receiving plane"),
    response(
        "landed_count",
        "-",
        "particles that crossed the receiving plane",
    ),
];

/// The chute's series.
pub static SERIES: &[ResponseSpec] = &[
    response(
        "landed_mass_over_time",
        "kg",
        "cumulative mass that crossed the receiving plane, over time",
    ),
    response(
        "kinetic_energy",
        "J",
        "kinetic energy of all particles, over time (LIGGGHTS and native)",
    ),
];

/// Parameters of the chute templates.
pub static PARAMETERS: &[ParameterSpec] = &[
    spec(
        "chute_length",
        0.2,
        "m",
        0.02,
        10.0,
        "length of the straight line from the inlet point to the lip",
    ),
    spec(
        "chute_angle",
        40.0,
        "deg",
        5.0,
        85.0,
        "angle of that line below the horizontal",
    ),
    spec(
        "shape_x1",
        0.0,
        "m",
        -1.0,
        1.0,
        "chute profile: upper B-spline control point moved away from the material (down) (X1)",
    ),
    spec(
        "shape_x2",
        0.0,
        "m",
        -1.0,
        1.0,
        "chute profile: lower B-spline control point moved towards the material (up) (X2)",
    ),
    spec(
        "shape_degree",
        3.0,
        "-",
        2.0,
        3.0,
        "degree of the B-spline chute profile",
    ),
    spec(
        "chute_width",
        0.04,
        "m",
        0.005,
        10.0,
        "width of the chute between its side walls",
    ),
    spec(
        "side_height",
        0.03,
        "m",
        0.005,
        10.0,
        "height of the side and back walls above the chute surface",
    ),
    spec(
        "drop_height",
        0.1,
        "m",
        0.005,
        10.0,
        "height of the lip above the receiving plane (the belt)",
    ),
    spec(
        "mass_rate",
        0.1,
        "kg/s",
        1e-4,
        1e3,
        "mass fed per second at the inlet",
    ),
    spec(
        "inlet_speed",
        0.5,
        "m/s",
        0.0,
        20.0,
        "speed of the fed particles, along the chute's inlet tangent",
    ),
    spec(
        "inlet_length",
        0.04,
        "m",
        0.005,
        10.0,
        "length along x of the inlet region above the top of the chute",
    ),
    spec(
        "feed_time",
        0.25,
        "s",
        0.001,
        1000.0,
        "time the inlet feeds, from t = 0",
    ),
    spec(
        "run_time",
        0.75,
        "s",
        0.001,
        1000.0,
        "simulated time of the run",
    ),
    spec(
        "coarse_diameter",
        0.004,
        "m",
        1e-5,
        0.1,
        "diameter of coarse particles (type 1)",
    ),
    spec(
        "fine_diameter",
        0.002,
        "m",
        1e-5,
        0.1,
        "diameter of fine particles (type 2)",
    ),
    spec(
        "fine_mass_fraction",
        0.3,
        "-",
        0.0,
        1.0,
        "mass fraction of fines in the feed",
    ),
    spec(
        "density",
        2500.0,
        "kg/m^3",
        100.0,
        20_000.0,
        "particle density",
    ),
    spec(
        "youngs_modulus",
        5e6,
        "Pa",
        1e4,
        1e12,
        "Young's modulus of particles and walls",
    ),
    spec("poisson_ratio", 0.3, "-", 0.0, 0.499, "Poisson ratio"),
    spec(
        "restitution",
        0.6,
        "-",
        0.01,
        1.0,
        "coefficient of restitution",
    ),
    spec(
        "friction",
        0.5,
        "-",
        0.0,
        2.0,
        "sliding friction coefficient",
    ),
    spec("timestep", 2e-5, "s", 1e-8, 1e-3, "time step"),
    spec(
        "sensor_every",
        50.0,
        "steps",
        1.0,
        1e6,
        "steps between sensor-band dumps (LIGGGHTS)",
    ),
    spec(
        "mesh_segments",
        24.0,
        "-",
        4.0,
        1024.0,
        "facets along the chute profile",
    ),
];

impl Equipment for Chute {
    fn name(&self) -> &'static str {
        "chute"
    }

    fn description(&self) -> &'static str {
        "transfer chute (B-spline profile, side walls) fed at a mass rate, throwing a bidisperse stream onto a receiving plane"
    }

    fn parameters(&self) -> &'static [ParameterSpec] {
        PARAMETERS
    }

    fn responses(&self) -> &'static [ResponseSpec] {
        RESPONSES
    }

    fn series(&self) -> &'static [ResponseSpec] {
        SERIES
    }

    fn headline_responses(&self) -> &'static [&'static str] {
        &["impact_speed", "lip_speed"]
    }

    fn check(&self, case: &Case) -> Result<(), RenderError> {
        check(case)
    }

    fn context(&self, case: &Case) -> Context {
        context(case)
    }

    fn write_geometry(&self, case: &Case, run_dir: &Path) -> Result<(), RenderError> {
        write_meshes(case, run_dir)
    }

    fn sensor(&self, case: &Case) -> SensorPlane {
        SensorPlane {
            height_m: geometry(case).receiving_plane_z_m(),
        }
    }

    fn results(&self, case: &Case, observations: &Observations) -> RunResults {
        let crossings = &observations.crossings;
        let r = StreamResponses::compute(crossings, &stream_options(case));
        let mut responses = vec![
            ("landed_count".to_string(), r.count as f64),
            ("landed_mass".to_string(), r.mass_kg),
            ("held_up_mass".to_string(), r.held_up_mass_kg),
        ];
        for (name, value) in [
            ("impact_speed", r.impact_speed_m_per_s),
            ("lip_speed", r.lip_speed_m_per_s),
            ("lip_angle", r.lip_angle_deg),
            ("stream_width", r.width_m),
            ("outer_fine_fraction", r.outer_fine_fraction),
            ("stream_fine_fraction", r.fine_fraction),
        ] {
            if let Some(value) = value {
                responses.push((name.to_string(), value));
            }
        }
        if let Some(energy) = observations.wall_impact_energy_j {
            let area = geometry(case).wall_mesh().area_m2();
            responses.push(("wall_impact_energy".to_string(), energy / area));
        }
        let mut series = vec![Series {
            name: "landed_mass_over_time".to_string(),
            points: cumulative_mass_series(crossings),
        }];
        series.extend(observations.series.iter().cloned());
        let landed = r.count;
        let missing = RESPONSES
            .iter()
            .filter(|spec| !responses.iter().any(|(name, _)| *name == spec.name))
            .map(|spec| {
                let why = if spec.name == "wall_impact_energy" {
                    "the solver does not count wall impacts (the native kernel does)".to_string()
                } else {
                    format!("{landed} particles landed on the receiving plane, too few to define it (is the chute blocked?)")
                };
                (spec.name.to_string(), why)
            })
            .collect();
        RunResults {
            responses,
            series,
            missing,
            notes: Vec::new(),
        }
    }
}

/// What the stream responses need from a case.
pub fn stream_options(case: &Case) -> StreamOptions {
    StreamOptions {
        fine_type: 2,
        lip_height_m: case.get("drop_height"),
        gravity_m_per_s2: GRAVITY_M_S2,
        fed_mass_kg: case.get("mass_rate") * case.get("feed_time"),
        outer_layer: OUTER_LAYER,
    }
}

/// The chute geometry of a case.
pub fn geometry(case: &Case) -> ChuteGeometry {
    ChuteGeometry {
        length_m: case.get("chute_length"),
        angle_deg: case.get("chute_angle"),
        width_m: case.get("chute_width"),
        drop_height_m: case.get("drop_height"),
        side_height_m: case.get("side_height"),
        shape_x1_m: case.get("shape_x1"),
        shape_x2_m: case.get("shape_x2"),
        shape_degree: case.get("shape_degree").round() as usize,
        segments: case.get("mesh_segments").round() as usize,
        width_segments: 2,
    }
}

/// Height of the sink plane that removes particles, below the dumped band around the
/// receiving plane, m.
pub fn sink_z_m(case: &Case) -> f64 {
    geometry(case).receiving_plane_z_m() - SENSOR_BAND_M - 0.003
}

/// How far beyond the lip (in x) the domain and the sink reach, m: a generous bound on
/// the throw of the stream.
fn throw_m(case: &Case) -> f64 {
    0.1 + 2.0 * case.get("drop_height") + 0.5 * case.get("chute_length")
}

/// Every value the templates see: the parameters plus what follows from them.
pub fn context(case: &Case) -> Context {
    let g = geometry(case);
    let mut context = Context::new();
    for (name, value) in &case.parameters.0 {
        context.insert(name.as_str(), value);
    }
    let coarse_diameter = case.get("coarse_diameter");
    let (inlet_x, inlet_z) = g.inlet();
    let (lip_x, _) = g.lip();
    // The inlet region: a thin box above the top of the chute, one coarse diameter
    // clear of the back and side walls and of the inlet point.
    let clearance = coarse_diameter;
    let inlet_x_min = inlet_x + clearance;
    let inlet_x_max = inlet_x_min + case.get("inlet_length");
    let inlet_y_half = 0.5 * g.width_m - clearance;
    let inlet_z_min = inlet_z + clearance;
    let inlet_z_max = inlet_z_min + 2.0 * coarse_diameter;
    // Fed along the chute's inlet tangent, P1 − P0.
    let [p0, p1, _, _] = g.control_points();
    let (tx, tz) = (p1.0 - p0.0, p1.1 - p0.1);
    let tangent = tx.hypot(tz);
    let speed = case.get("inlet_speed");
    let (vx, vz) = (speed * tx / tangent, speed * tz / tangent);
    // Batches every 10 ms, or more often for a fast feed, so that a batch has moved at
    // most four coarse diameters when the next one comes.
    let inflow_interval = (4.0 * coarse_diameter / speed.max(1e-9)).min(0.01);
    let sensor_z = g.receiving_plane_z_m();
    let sink_z = sink_z_m(case);
    let half_width = 0.5 * g.width_m + 0.01;
    let fed_mass = case.get("mass_rate") * case.get("feed_time");
    let derived = [
        ("coarse_radius", 0.5 * coarse_diameter),
        ("fine_radius", 0.5 * case.get("fine_diameter")),
        ("coarse_mass_fraction", 1.0 - case.get("fine_mass_fraction")),
        ("lip_x", lip_x),
        ("inlet_z", inlet_z),
        ("inlet_x_min", inlet_x_min),
        ("inlet_x_max", inlet_x_max),
        ("inlet_y_half", inlet_y_half),
        ("inlet_z_min", inlet_z_min),
        ("inlet_z_max", inlet_z_max),
        ("inlet_vx", vx),
        ("inlet_vz", vz),
        ("inflow_interval", inflow_interval),
        ("fed_mass", fed_mass),
        ("sensor_z", sensor_z),
        ("sensor_band_top", sensor_z + SENSOR_BAND_M),
        ("sensor_band_bottom", sensor_z - SENSOR_BAND_M),
        ("sink_z", sink_z),
        ("sink_x_max", lip_x + throw_m(case)),
        ("box_x_min", -0.01),
        ("box_x_max", lip_x + throw_m(case) + 0.01),
        ("box_half_width", half_width),
        ("box_bottom", sink_z - 0.01),
        ("box_top", inlet_z + g.side_height_m + 0.01),
        ("gravity", GRAVITY_M_S2),
    ];
    for (name, value) in derived {
        context.insert(name, &value);
    }
    let steps = |seconds: f64| (seconds / case.get("timestep")).round() as u64;
    context.insert("run_steps", &steps(case.get("run_time")));
    context.insert("feed_steps", &steps(case.get("feed_time")));
    context.insert("inflow_every", &steps(inflow_interval).max(1));
    context.insert(
        "sensor_every_int",
        &(case.get("sensor_every").round() as u64),
    );
    for (index, name) in ["seed_coarse", "seed_fine", "seed_mix", "seed_insert"]
        .iter()
        .enumerate()
    {
        context.insert(*name, &prime_seed(case.seed, index as u64));
    }
    context
}

/// Checks a resolved case beyond per-parameter ranges: the geometry can be built, the
/// fines are not larger than the coarse particles, the inlet fits between the walls
/// and the feed ends within the run.
pub fn check(case: &Case) -> Result<(), RenderError> {
    let invalid = |m: String| Err(RenderError::InvalidCase(m));
    let g = geometry(case);
    g.validate()
        .map_err(|e| RenderError::InvalidCase(e.to_string()))?;
    let (coarse, fine) = (case.get("coarse_diameter"), case.get("fine_diameter"));
    if fine > coarse {
        return invalid(format!(
            "fine_diameter ({fine} m) must not exceed coarse_diameter ({coarse} m)"
        ));
    }
    if g.width_m < 4.0 * coarse {
        return invalid(format!(
            "chute_width ({} m) must be at least four coarse diameters ({} m)",
            g.width_m,
            4.0 * coarse
        ));
    }
    if g.side_height_m < 4.0 * coarse {
        return invalid(format!(
            "side_height ({} m) must be at least four coarse diameters ({} m): the inlet region lies between the walls",
            g.side_height_m,
            4.0 * coarse
        ));
    }
    if case.get("inlet_length") + coarse > g.lip().0 {
        return invalid(format!(
            "inlet_length ({} m) must be shorter than the chute's horizontal extent ({:.4} m)",
            case.get("inlet_length"),
            g.lip().0
        ));
    }
    if case.get("feed_time") > case.get("run_time") {
        return invalid(format!(
            "feed_time ({} s) must not exceed run_time ({} s)",
            case.get("feed_time"),
            case.get("run_time")
        ));
    }
    Ok(())
}

/// Writes the walls as ASCII STL into `run_dir`: `chute.stl` (plate, side walls and
/// back wall), `belt.stl` (the receiving plane, for viewing) and `sink.stl` (the plane
/// that removes particles below the sensor band), and creates `post/`.
pub fn write_meshes(case: &Case, run_dir: &Path) -> Result<(), RenderError> {
    let g = geometry(case);
    let post = run_dir.join("post");
    std::fs::create_dir_all(&post).map_err(|source| RenderError::Write { path: post, source })?;
    write(run_dir, "chute.stl", &g.wall_mesh().to_ascii_stl("chute"))?;
    let x_max = g.lip().0 + throw_m(case);
    let half = 0.5 * g.width_m + 0.01;
    write(
        run_dir,
        "belt.stl",
        &g.receiving_plane_mesh(x_max, half, g.receiving_plane_z_m())
            .to_ascii_stl("belt"),
    )?;
    write(
        run_dir,
        "sink.stl",
        &g.receiving_plane_mesh(x_max, half, sink_z_m(case))
            .to_ascii_stl("sink"),
    )?;
    Ok(())
}

/// A case of the chute with its defaults, `overrides` applied, seed 1.
#[cfg(test)]
pub(crate) fn case_with(overrides: &[(&str, f64)]) -> Case {
    let mut parameters = crate::ResolvedParameters::defaults(PARAMETERS);
    for (name, value) in overrides {
        parameters.set(name, *value);
    }
    Case {
        parameters,
        seed: 1,
        text: Default::default(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Simulation;
    use orch_granular::Crossing;

    #[test]
    fn headline_responses_are_responses() {
        for name in Chute.headline_responses() {
            assert!(RESPONSES.iter().any(|r| r.name == *name), "{name}");
        }
    }

    #[test]
    fn no_response_name_is_also_a_hopper_response() {
        for r in RESPONSES {
            assert!(
                !crate::hopper::RESPONSES.iter().any(|h| h.name == r.name),
                "{}",
                r.name
            );
        }
    }

    #[test]
    fn results_name_only_declared_responses_and_trace_back_the_lip() {
        let case = case_with(&[("drop_height", 0.2)]);
        // One particle leaving the lip at 1 m/s horizontally.
        let vz = -(2.0 * GRAVITY_M_S2 * 0.2f64).sqrt();
        let crossings = vec![Crossing {
            id: 1,
            particle_type: 1,
            radius_m: 0.002,
            mass_kg: 1e-4,
            position_m: [0.3, 0.0, -0.2],
            velocity_m_per_s: [1.0, 0.0, vz],
            time_s: 0.5,
        }];
        let results = Chute.results(
            &case,
            &Observations {
                crossings,
                wall_impact_energy_j: Some(0.5),
                ..Default::default()
            },
        );
        let get = |name: &str| {
            results
                .responses
                .iter()
                .find(|(n, _)| n == name)
                .map(|(_, v)| *v)
                .unwrap()
        };
        assert!((get("lip_speed") - 1.0).abs() < 1e-12);
        assert!(get("lip_angle").abs() < 1e-6);
        assert!((get("held_up_mass") - (0.1 * 0.25 - 1e-4)).abs() < 1e-15);
        // Walls: plate 0.2 × 0.04, two vertical sides 0.2 cos 40° × 0.03 (a
        // parallelogram over the profile), back 0.04 × 0.03 m².
        let area = 0.2 * 0.04 + 2.0 * 0.2 * 40f64.to_radians().cos() * 0.03 + 0.04 * 0.03;
        assert!((get("wall_impact_energy") - 0.5 / area).abs() < 1e-9);
        for (name, _) in &results.responses {
            assert!(RESPONSES.iter().any(|r| r.name == *name), "{name}");
        }
        for series in &results.series {
            assert!(
                SERIES.iter().any(|r| r.name == series.name),
                "{}",
                series.name
            );
        }
    }

    #[test]
    fn checks_name_the_offending_parameter() {
        check(&case_with(&[])).unwrap();
        for (overrides, word) in [
            (vec![("shape_x1", 0.2), ("shape_x2", -0.2)], "shape_x1"),
            (vec![("fine_diameter", 0.005)], "fine_diameter"),
            (vec![("chute_width", 0.01)], "chute_width"),
            (vec![("feed_time", 2.0)], "feed_time"),
            (vec![("inlet_length", 0.5)], "inlet_length"),
        ] {
            let message = check(&case_with(&overrides)).unwrap_err().to_string();
            assert!(message.contains(word), "{message}");
        }
    }

    #[test]
    fn the_native_case_parses_in_the_kernel_and_feeds_what_the_study_asks() {
        let dir = tempfile::tempdir().unwrap();
        let case = case_with(&[("shape_x1", 0.01), ("shape_x2", -0.005)]);
        let simulation = crate::EquipmentOnSolver::new(&Chute, &crate::native::SOLVER).unwrap();
        simulation.render(&case, dir.path()).unwrap();
        let text = std::fs::read_to_string(dir.path().join("chute.toml")).unwrap();
        let parsed = orch_dem::case::Case::parse(&text).unwrap();
        let walls: Vec<_> = parsed
            .meshes
            .iter()
            .enumerate()
            .map(|(k, m)| {
                let bytes = std::fs::read(dir.path().join(&m.file)).unwrap();
                parsed.wall_mesh(k, &bytes).unwrap()
            })
            .collect();
        let mut sim = parsed.build(walls).unwrap();
        assert_eq!(sim.particles.len(), 0);
        let inflow = sim.inflows()[0].inflow().clone();
        assert!((inflow.mass_rate_kg_per_s - 0.1).abs() < 1e-15);
        assert!((inflow.end_s - 0.25).abs() < 1e-15);
        assert!((inflow.velocity_m_per_s.norm() - 0.5).abs() < 1e-12);
        // The first batch lands inside the walls without touching them.
        for _ in 0..10 {
            sim.step().unwrap();
        }
        assert!(sim.particles.len() > 10);
    }

    #[test]
    fn the_rendered_liggghts_deck_is_the_snapshot() {
        let dir = tempfile::tempdir().unwrap();
        let simulation = crate::EquipmentOnSolver::new(&Chute, &crate::liggghts::SOLVER).unwrap();
        simulation.render(&case_with(&[]), dir.path()).unwrap();
        let text = std::fs::read_to_string(dir.path().join("chute.in")).unwrap();
        for file in ["chute.stl", "sink.stl", "belt.stl"] {
            assert!(dir.path().join(file).is_file(), "{file}");
        }
        insta::assert_snapshot!("liggghts_chute_deck", text);
    }

    #[test]
    fn the_rendered_native_case_is_the_snapshot() {
        let dir = tempfile::tempdir().unwrap();
        let simulation = crate::EquipmentOnSolver::new(&Chute, &crate::native::SOLVER).unwrap();
        simulation.render(&case_with(&[]), dir.path()).unwrap();
        let text = std::fs::read_to_string(dir.path().join("chute.toml")).unwrap();
        insta::assert_snapshot!("native_chute_case", text);
    }
}
