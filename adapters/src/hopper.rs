//! The conical hopper, the first [`Equipment`]: its parameters (SI, with the verified
//! LIGGGHTS deck's values as defaults), the values derived from them that the templates
//! use (fill region, sensor and sink planes, step counts, seeds), the checks a case must
//! pass, the wall meshes written beside each deck, and the discharge responses computed
//! from the particles that crossed its sensor plane (rate, radial segregation,
//! outer-layer fines, exit speed).
//!
//! Every solver renders the same context, so one design point is the same physical case
//! on LIGGGHTS, YADE or the native kernel. The hopper's response names live here and
//! nowhere else in `orch`.

use std::path::Path;

use orch_granular::responses::{
    cumulative_mass_series, mass_flow_series, radial_densities, RadialDensities,
};
use orch_granular::steady::BATCHES;
use orch_granular::temporal::fine_fraction_by_discharged_mass;
use orch_granular::{DischargeResponses, HopperGeometry, ResponseOptions};
use tera::Context;

use crate::equipment::{
    response, response_with_interval, series_over, Equipment, ResponseSpec, SensorPlane,
};
use crate::params::spec;
use crate::primes::prime_seed;
use crate::simulation::write;
use crate::{Case, Observations, ParameterSpec, RenderError, RunResults, Series};

/// The hopper equipment.
#[derive(Debug, Clone, Copy, Default)]
pub struct Hopper;

/// Width of the bins of the stored mass-flow-rate series, s.
pub const MASS_FLOW_BIN_S: f64 = 0.02;

/// The hopper's scalar responses, from the particles that crossed its sensor plane
/// (definitions and reasons: docs/method.md, "Responses of the hopper").
pub static RESPONSES: &[ResponseSpec] = &[
    response("discharged_count", "-", "particles that crossed the sensor plane"),
    response("discharged_mass", "kg", "mass that crossed the sensor plane"),
    response_with_interval(
        "discharge_rate",
        "kg/s",
        "steady discharge rate: least-squares slope of the discharged mass over the steady window (the longest run of local rates within 25 % of the median)",
        "discharge_rate_ci95",
    ),
    response(
        "discharge_rate_ci95",
        "kg/s",
        "half-width of the 95 % confidence interval of discharge_rate, by batch means over the steady window",
    ),
    response(
        "R1_mean",
        "m",
        "mean radial distance of the centres of fine particles at the sensor plane",
    ),
    response(
        "R2_mean",
        "m",
        "mean radial distance of the centres of coarse particles at the sensor plane",
    ),
    response(
        "segregation_ratio",
        "-",
        "R1_mean / R2_mean; below 1 the fines are nearer the axis",
    ),
    response(
        "segregation_ratio_normalised",
        "-",
        "segregation_ratio over its value for a perfectly mixed stream whose centres keep a particle radius from its edge, (R_s - r_fine)/(R_s - r_coarse); 1 = no segregation beyond that geometric bias",
    ),
    response(
        "stream_radius",
        "m",
        "largest radial distance of any crossing's centre",
    ),
    response(
        "stream_radius_95",
        "m",
        "robust stream radius R_s: 95 % mass quantile of the particles' surface distances from the axis (centre distance + radius)",
    ),
    response(
        "exit_speed",
        "m/s",
        "mass-weighted mean downward speed at the sensor plane",
    ),
    response(
        "fine_fraction_first_quarter",
        "-",
        "mass fraction of fines in the first quarter of the discharged mass",
    ),
    response(
        "fine_fraction_last_quarter",
        "-",
        "mass fraction of fines in the last quarter of the discharged mass",
    ),
    response(
        "fine_fraction_outer_2",
        "-",
        "mass fraction of fines among the particles whose surface reaches beyond 98 % of stream_radius_95",
    ),
    response(
        "fine_fraction_outer_5",
        "-",
        "mass fraction of fines among the particles whose surface reaches beyond 95 % of stream_radius_95",
    ),
    response(
        "fine_fraction_outer_10",
        "-",
        "mass fraction of fines among the particles whose surface reaches beyond 90 % of stream_radius_95",
    ),
    response(
        "fine_fraction_outer_12",
        "-",
        "mass fraction of fines among the particles whose surface reaches beyond 88 % of stream_radius_95",
    ),
];

/// The hopper's series. The radial densities are over radius (m), not time.
pub static SERIES: &[ResponseSpec] = &[
    response(
        "mass_flow_rate",
        "kg/s",
        "mass crossing the sensor plane per 0.02 s bin, over time",
    ),
    response(
        "discharged_mass",
        "kg",
        "cumulative mass that crossed the sensor plane, over time",
    ),
    response(
        "fine_fraction_over_discharge",
        "-",
        "mass fraction of fines in each tenth of the discharged mass, over its mean crossing time",
    ),
    response(
        "kinetic_energy",
        "J",
        "kinetic energy of all particles, over time (LIGGGHTS and native)",
    ),
    series_over(
        "radial_density_fine",
        "1/m",
        "probability density of the radial distance of fine particles' centres at the sensor plane, over radius in m (20 bins to the largest distance)",
        "r [m]",
    ),
    series_over(
        "radial_density_coarse",
        "1/m",
        "probability density of the radial distance of coarse particles' centres at the sensor plane, over radius in m (same bins as the fines')",
        "r [m]",
    ),
];

impl Equipment for Hopper {
    fn name(&self) -> &'static str {
        "hopper"
    }

    fn description(&self) -> &'static str {
        "conical hopper (B-spline cone profile, optional internal valve, vertical vibration) discharging a bidisperse mixture through a sensor plane"
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
        &["discharge_rate", "segregation_ratio"]
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
            height_m: sensor_z_m(case),
        }
    }

    fn results(&self, case: &Case, observations: &Observations) -> RunResults {
        let crossings = &observations.crossings;
        let options = ResponseOptions::default();
        let responses = DischargeResponses::compute(crossings, &options);
        let named = responses.named();
        let crossed = crossings.len();
        let inserted = case.get("n_particles").round();
        let missing = RESPONSES
            .iter()
            .filter(|spec| !named.iter().any(|(name, _)| *name == spec.name))
            .map(|spec| {
                let rate = spec.name == "discharge_rate" || spec.name == "discharge_rate_ci95";
                let why = if rate && responses.steady.is_none() {
                    format!(
                        "no steady discharge: {crossed} of {inserted} particles crossed the sensor plane (is the outlet jammed, or the run too short?)"
                    )
                } else if rate {
                    format!(
                        "the steady window holds fewer than {} crossings, too few for {} batches",
                        2 * BATCHES,
                        BATCHES
                    )
                } else {
                    format!("the {crossed} particles that crossed the sensor plane cannot define it (one of the sizes missing?)")
                };
                (spec.name.to_string(), why)
            })
            .collect();
        let mut series = vec![
            Series {
                name: "mass_flow_rate".to_string(),
                points: mass_flow_series(crossings, MASS_FLOW_BIN_S),
            },
            Series {
                name: "discharged_mass".to_string(),
                points: cumulative_mass_series(crossings),
            },
            Series {
                name: "fine_fraction_over_discharge".to_string(),
                points: fine_fraction_by_discharged_mass(crossings, options.fine_type, 10)
                    .iter()
                    .map(|slice| (slice.time_s, slice.fine_mass_fraction))
                    .collect(),
            },
        ];
        let RadialDensities { fine, coarse } = radial_densities(crossings, &options);
        for (name, points) in [
            ("radial_density_fine", fine),
            ("radial_density_coarse", coarse),
        ] {
            if !points.is_empty() {
                series.push(Series {
                    name: name.to_string(),
                    points,
                });
            }
        }
        series.extend(observations.series.iter().cloned());
        RunResults {
            responses: named,
            series,
            missing,
            notes: Vec::new(),
        }
    }
}

/// Half-thickness of the band around the sensor plane that LIGGGHTS dumps, m.
pub const SENSOR_BAND_M: f64 = 0.005;

/// Parameters of the hopper template; defaults are the verified deck of
/// `shared/solvers/README.md` (3000 glass-like spheres of 4 and 2 mm, 24 mm outlet).
pub static PARAMETERS: &[ParameterSpec] = &[
    spec("n_particles", 3000.0, "-", 1.0, 1e7, "particles inserted"),
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
        0.5,
        "-",
        0.01,
        0.99,
        "mass fraction of fines in the mixture",
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
    spec(
        "outlet_diameter",
        0.024,
        "m",
        1e-3,
        1.0,
        "outlet diameter D",
    ),
    spec(
        "cone_half_angle",
        35.0,
        "deg",
        1.0,
        89.0,
        "cone half-angle from the vertical",
    ),
    spec(
        "cone_height",
        0.040,
        "m",
        1e-3,
        10.0,
        "height of the conical section",
    ),
    spec(
        "cylinder_height",
        0.060,
        "m",
        0.0,
        10.0,
        "height of the cylinder above the cone",
    ),
    spec(
        "valve_diameter",
        0.0,
        "m",
        0.0,
        1.0,
        "internal cone valve diameter; 0 = no valve",
    ),
    spec(
        "valve_gap",
        0.010,
        "m",
        0.0,
        1.0,
        "valve base height above the outlet (h)",
    ),
    spec("valve_height", 0.008, "m", 0.0, 1.0, "valve cone height"),
    spec(
        "amplitude",
        0.0,
        "m",
        0.0,
        0.1,
        "vertical vibration amplitude a; 0 = none",
    ),
    spec(
        "frequency",
        50.0,
        "Hz",
        0.0,
        1000.0,
        "vertical vibration frequency f",
    ),
    spec("timestep", 2e-5, "s", 1e-8, 1e-3, "time step"),
    spec(
        "fill_time",
        0.3,
        "s",
        0.01,
        100.0,
        "filling and settling time, outlet closed",
    ),
    spec(
        "discharge_time",
        0.6,
        "s",
        0.01,
        1000.0,
        "longest discharge time after opening",
    ),
    spec(
        "sensor_depth",
        0.005,
        "m",
        0.0,
        1.0,
        "sensor plane distance below the outlet",
    ),
    spec(
        "sensor_every",
        50.0,
        "steps",
        1.0,
        1e6,
        "steps between sensor-band dumps",
    ),
    spec(
        "shape_x1",
        0.0,
        "m",
        -0.1,
        0.1,
        "cone profile: lower B-spline control point moved away from the axis (X1)",
    ),
    spec(
        "shape_x2",
        0.0,
        "m",
        -0.1,
        0.1,
        "cone profile: upper B-spline control point moved towards the axis (X2)",
    ),
    spec(
        "shape_degree",
        3.0,
        "-",
        2.0,
        3.0,
        "degree of the B-spline cone profile",
    ),
    spec(
        "dump_every",
        0.0,
        "steps",
        0.0,
        1e9,
        "steps between snapshots of every particle (post/dump<step>.liggghts, LIGGGHTS dump custom text); 0 = none",
    ),
    spec(
        "vtk_every",
        0.0,
        "steps",
        0.0,
        1e9,
        "steps between ParaView snapshots of every particle (post/particles_<step>.vtk, legacy VTK polydata with id, type, radius, velocity, angular velocity); 0 = none; native and LIGGGHTS only",
    ),
    spec(
        "pour_rate",
        0.0,
        "kg/s",
        0.0,
        1e3,
        "filling: 0 = particles placed at random in the hopper; > 0 = poured through a central inlet at this mass rate, then settled",
    ),
    spec(
        "pour_diameter",
        0.030,
        "m",
        1e-3,
        10.0,
        "diameter of the pouring inlet (a disk on the axis at the top of the hopper)",
    ),
    spec(
        "pour_speed",
        1.0,
        "m/s",
        0.01,
        100.0,
        "downward speed of poured particles as they leave the inlet",
    ),
    spec(
        "air_density",
        0.0,
        "kg/m^3",
        0.0,
        100.0,
        "density of still air dragging the particles (Schiller-Naumann); 0 = vacuum, 1.2 = air at 20 C",
    ),
    spec(
        "air_viscosity",
        1.8e-5,
        "Pa s",
        1e-7,
        1.0,
        "dynamic viscosity of the air",
    ),
    spec(
        "air_field",
        0.0,
        "-",
        0.0,
        1.0,
        "1 = the air moves as air-field.csv in the run directory says (written by the DEM-CFD coupling; native kernel only), 0 = still air",
    ),
    spec(
        "mesh_segments",
        48.0,
        "-",
        8.0,
        1024.0,
        "facets around the hopper circumference",
    ),
];

/// The hopper geometry of a case.
pub fn geometry(case: &Case) -> HopperGeometry {
    HopperGeometry {
        outlet_diameter_m: case.get("outlet_diameter"),
        cone_half_angle_deg: case.get("cone_half_angle"),
        cone_height_m: case.get("cone_height"),
        cylinder_height_m: case.get("cylinder_height"),
        valve_diameter_m: case.get("valve_diameter"),
        valve_gap_m: case.get("valve_gap"),
        valve_height_m: case.get("valve_height"),
        segments: case.get("mesh_segments").round() as usize,
        band_height_m: 0.005,
        shape_x1_m: case.get("shape_x1"),
        shape_x2_m: case.get("shape_x2"),
        shape_degree: case.get("shape_degree").round() as usize,
    }
}

/// Height of the sensor plane, m (below the outlet at z = 0).
pub fn sensor_z_m(case: &Case) -> f64 {
    -case.get("sensor_depth")
}

/// Height of the sink plane that counts and removes particles, just below the
/// dumped band around the sensor plane.
pub fn sink_z_m(case: &Case) -> f64 {
    sensor_z_m(case) - SENSOR_BAND_M - 0.003
}

/// Every value the template sees: the parameters plus what follows from them.
pub fn context(case: &Case) -> Context {
    let geometry = geometry(case);
    let mut context = Context::new();
    for (name, value) in &case.parameters.0 {
        context.insert(name.as_str(), value);
    }
    let coarse_radius = 0.5 * case.get("coarse_diameter");
    let sensor_z = sensor_z_m(case);
    // Fill region: above the valve (or where the cone is as wide as the straight cone
    // a third of the way up) up to the rim, one coarse diameter from the wall.
    let fill_bottom = if geometry.has_valve() {
        geometry.valve_gap_m + geometry.valve_height_m + coarse_radius * 2.0
    } else {
        lowest_height_of_radius(&geometry, geometry.cone_height_m / 3.0)
    };
    let fill_top = geometry.total_height_m() - 2.0 * coarse_radius;
    let fill_radius = geometry.radius_at(fill_bottom) - 2.0 * coarse_radius;
    let half_width = geometry.top_radius_m() + 0.005;
    let delete_z = sink_z_m(case);
    let derived = [
        ("coarse_radius", coarse_radius),
        ("fine_radius", 0.5 * case.get("fine_diameter")),
        ("coarse_mass_fraction", 1.0 - case.get("fine_mass_fraction")),
        ("fill_bottom", fill_bottom),
        ("fill_top", fill_top),
        ("fill_radius", fill_radius),
        ("box_half_width", half_width),
        ("box_bottom", delete_z - 0.01),
        ("box_top", geometry.total_height_m() + 0.005),
        ("sensor_z", sensor_z),
        ("sensor_band_top", sensor_z + SENSOR_BAND_M),
        ("sensor_band_bottom", sensor_z - SENSOR_BAND_M),
        // Heights within this of the sensor plane may print onto it with the six
        // significant digits of LIGGGHTS's dumps (half a unit in the sixth digit of
        // heights up to |z| + band).
        (
            "sensor_ambiguity",
            1e-5 * (sensor_z.abs() + SENSOR_BAND_M) + 1e-12,
        ),
        ("delete_z", delete_z),
        ("vibration_period", 1.0 / case.get("frequency").max(1e-12)),
    ];
    for (name, value) in derived {
        context.insert(name, &value);
    }
    let steps = |seconds: f64| (seconds / case.get("timestep")).round() as u64;
    context.insert("fill_steps", &steps(case.get("fill_time")));
    let pour = Pour::of(case, fill_top);
    context.insert("pour", &pour.is_some());
    if let Some(pour) = pour {
        for (name, value) in [
            ("pour_mass", pour.mass_kg),
            ("pour_end", pour.end_s),
            ("pour_interval", pour.interval_s),
            ("pour_radius", pour.radius_m),
            ("pour_bottom", pour.bottom_m),
            ("pour_top", pour.top_m),
        ] {
            context.insert(name, &value);
        }
        context.insert("pour_every", &steps(pour.interval_s).max(1));
    }
    context.insert("air", &(case.get("air_density") > 0.0));
    context.insert("air_field", &(case.get("air_field") > 0.5));
    // The YADE script writes the crossings table the native kernel writes.
    context.insert("crossings_header", orch_granular::crossing_csv::HEADER);
    let chunk = 1000u64;
    context.insert("chunk_steps", &chunk);
    context.insert(
        "discharge_chunks",
        &steps(case.get("discharge_time")).div_ceil(chunk),
    );
    context.insert("n_particles_int", &(case.get("n_particles").round() as u64));
    context.insert("dump_every_int", &(case.get("dump_every").round() as u64));
    context.insert("vtk_every_int", &(case.get("vtk_every").round() as u64));
    context.insert(
        "sensor_every_int",
        &(case.get("sensor_every").round() as u64),
    );
    context.insert("has_valve", &geometry.has_valve());
    context.insert(
        "vibrate",
        &(case.get("amplitude") > 0.0 && case.get("frequency") > 0.0),
    );
    // Particles that stay behind on the walls: stop when at most this many remain.
    let leftover = ((case.get("n_particles") * 0.002).round() as u64).max(5);
    context.insert("leftover", &leftover);
    for (index, name) in ["seed_coarse", "seed_fine", "seed_mix", "seed_insert"]
        .iter()
        .enumerate()
    {
        context.insert(*name, &prime_seed(case.seed, index as u64));
    }
    context
}

/// Pouring (`pour_rate` > 0): the mixture falls through a disk-shaped inlet on the
/// axis at the top of the hopper, at `pour_rate` kg/s, until the mass of
/// `n_particles` particles of the mixture is in; the rest of `fill_time` lets it
/// settle. Like filling from a particle factory, this builds a heap under the inlet.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pour {
    /// Mass poured, kg: `n_particles` particles of the mixture's mean particle mass.
    pub mass_kg: f64,
    /// When the inlet stops, s (pouring starts at 0).
    pub end_s: f64,
    /// Time between insertion batches, s: the time a particle leaving the inlet at
    /// `pour_speed` takes to cross the inlet's height, capped at 10 ms.
    pub interval_s: f64,
    /// Radius of the region particles appear in, m (`pour_diameter` / 2).
    pub radius_m: f64,
    /// Bottom of that region, m.
    pub bottom_m: f64,
    /// Top of that region, m.
    pub top_m: f64,
}

/// The solid fraction of the stream leaving the pouring inlet that
/// [`Pour::capacity_kg_per_s`] allows: random placement without overlaps fills a region to
/// about 0.3 at best, so half of that leaves room for every batch.
pub const POUR_SOLID_FRACTION: f64 = 0.15;

impl Pour {
    /// The largest mass rate the inlet passes, kg/s: particles leave its disk at
    /// `pour_speed` with a solid fraction of [`POUR_SOLID_FRACTION`]. A faster pour
    /// could not place every batch, and the bed would hold fewer particles than asked.
    pub fn capacity_kg_per_s(&self, case: &Case) -> f64 {
        POUR_SOLID_FRACTION
            * case.get("density")
            * std::f64::consts::PI
            * self.radius_m.powi(2)
            * case.get("pour_speed")
    }

    /// The pour of `case` whose inlet ends at `top_m`, or `None` when the case fills
    /// at random (`pour_rate` = 0).
    pub fn of(case: &Case, top_m: f64) -> Option<Pour> {
        let rate = case.get("pour_rate");
        if rate <= 0.0 {
            return None;
        }
        let density = case.get("density");
        let mass_of = |diameter: f64| density * std::f64::consts::PI * diameter.powi(3) / 6.0;
        let fine = case.get("fine_mass_fraction");
        let particles_per_kg = (1.0 - fine) / mass_of(case.get("coarse_diameter"))
            + fine / mass_of(case.get("fine_diameter"));
        let mass_kg = case.get("n_particles") / particles_per_kg;
        let height = 3.0 * case.get("coarse_diameter");
        let interval_s = (height / case.get("pour_speed")).min(0.01);
        Some(Pour {
            mass_kg,
            end_s: mass_kg / rate,
            interval_s,
            radius_m: 0.5 * case.get("pour_diameter"),
            bottom_m: top_m - height,
            top_m,
        })
    }
}

/// The lowest height, from `z_m` up, where the hopper is at least as wide as the
/// straight cone is at `z_m`: `z_m` itself for the straight cone, higher for a concave
/// one, so the fill region holds as many particles whatever the shape.
fn lowest_height_of_radius(geometry: &HopperGeometry, z_m: f64) -> f64 {
    let straight = geometry.outlet_radius_m()
        + (geometry.top_radius_m() - geometry.outlet_radius_m()) * z_m / geometry.cone_height_m;
    let steps = 200;
    (0..=steps)
        .map(|i| z_m + (geometry.cone_height_m - z_m) * i as f64 / steps as f64)
        .find(|&z| geometry.radius_at(z) >= straight - 1e-12)
        .unwrap_or(geometry.cone_height_m)
}

/// Checks a resolved case beyond per-parameter ranges: the geometry can be built, the
/// fines are not larger than the coarse particles, and the outlet lets them through.
pub fn check(case: &Case) -> Result<(), RenderError> {
    let geometry = geometry(case);
    geometry
        .validate()
        .map_err(|e| RenderError::InvalidCase(e.to_string()))?;
    let (coarse, fine) = (case.get("coarse_diameter"), case.get("fine_diameter"));
    if fine > coarse {
        return Err(RenderError::InvalidCase(format!(
            "fine_diameter ({fine} m) must not exceed coarse_diameter ({coarse} m)"
        )));
    }
    // The inlet ends where the fill region does (`context`'s `fill_top`).
    let fill_top = geometry.total_height_m() - case.get("coarse_diameter");
    if let Some(pour) = Pour::of(case, fill_top) {
        let fill_time = case.get("fill_time");
        if pour.end_s >= fill_time {
            return Err(RenderError::InvalidCase(format!(
                "pouring {:.4} kg at pour_rate {} kg/s takes {:.3} s, longer than fill_time ({fill_time} s); raise pour_rate or fill_time (and leave time to settle)",
                pour.mass_kg,
                case.get("pour_rate"),
                pour.end_s
            )));
        }
        let capacity = pour.capacity_kg_per_s(case);
        if case.get("pour_rate") > capacity {
            return Err(RenderError::InvalidCase(format!(
                "pour_rate ({} kg/s) exceeds what the inlet passes, {capacity:.4} kg/s (a solid fraction of {POUR_SOLID_FRACTION} through a {} m disk at pour_speed {} m/s); widen pour_diameter, raise pour_speed or lower pour_rate",
                case.get("pour_rate"),
                case.get("pour_diameter"),
                case.get("pour_speed")
            )));
        }
        let room = geometry.top_radius_m() - case.get("coarse_diameter");
        if pour.radius_m > room {
            return Err(RenderError::InvalidCase(format!(
                "pour_diameter ({} m) must leave a coarse particle's room inside the hopper's top diameter ({:.4} m)",
                case.get("pour_diameter"),
                2.0 * geometry.top_radius_m()
            )));
        }
    }
    if case.get("air_field") > 0.5 && case.get("air_density") <= 0.0 {
        return Err(RenderError::InvalidCase(
            "air_field = 1 moves air that is not there: set air_density (1.2 for air at 20 C)"
                .to_string(),
        ));
    }
    let outlet = case.get("outlet_diameter");
    if outlet <= coarse {
        return Err(RenderError::InvalidCase(format!(
            "outlet_diameter ({outlet} m) must exceed coarse_diameter ({coarse} m), or nothing can flow"
        )));
    }
    Ok(())
}

/// Writes the walls as ASCII STL into `run_dir`: `hopper.stl`, `plug.stl` (closes the
/// outlet while filling), `valve.stl` when the case has a valve, and `sink.stl` (the
/// plane that removes particles), and creates `post/` for the solver's output.
pub fn write_meshes(case: &Case, run_dir: &Path) -> Result<(), RenderError> {
    let geometry = geometry(case);
    let post = run_dir.join("post");
    std::fs::create_dir_all(&post).map_err(|source| RenderError::Write { path: post, source })?;
    write(
        run_dir,
        "hopper.stl",
        &geometry.wall_mesh().to_ascii_stl("hopper"),
    )?;
    let plug_overlap = 0.5 * case.get("coarse_diameter");
    write(
        run_dir,
        "plug.stl",
        &geometry.plug_mesh(plug_overlap).to_ascii_stl("plug"),
    )?;
    if let Some(valve) = geometry.valve_mesh() {
        write(run_dir, "valve.stl", &valve.to_ascii_stl("valve"))?;
    }
    let sink = geometry.sensor_mesh(geometry.top_radius_m() + 0.005, sink_z_m(case));
    write(run_dir, "sink.stl", &sink.to_ascii_stl("sink"))?;
    Ok(())
}

/// A case of the hopper template with its defaults, `overrides` applied, seed 1.
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

/// The poured case every solver's snapshot tests render: 1500 particles through a
/// 20 mm inlet at 0.08 kg/s, dumped every 50 000 steps, with `extra` applied.
#[cfg(test)]
pub(crate) fn poured_case(extra: &[(&str, f64)]) -> Case {
    let mut overrides = vec![
        ("pour_rate", 0.08),
        ("pour_diameter", 0.02),
        ("fill_time", 1.0),
        ("dump_every", 50000.0),
        ("n_particles", 1500.0),
    ];
    overrides.extend_from_slice(extra);
    case_with(&overrides)
}

/// The hopper on `solver`, for the solvers' tests.
#[cfg(test)]
pub(crate) fn on(solver: &'static crate::DemSolver) -> crate::EquipmentOnSolver {
    crate::EquipmentOnSolver::new(&Hopper, solver).unwrap()
}

/// Renders `case` with `solver`'s default hopper template into `run_dir`; returns the
/// deck's text.
#[cfg(test)]
pub(crate) fn render_default(
    solver: &'static crate::DemSolver,
    case: &Case,
    run_dir: &Path,
) -> String {
    use crate::Simulation;
    let simulation = on(solver);
    simulation.render(case, run_dir).unwrap();
    std::fs::read_to_string(run_dir.join(simulation.deck_file())).unwrap()
}

/// What `solver`'s parser reads of a hopper run in `run_dir`.
#[cfg(test)]
pub(crate) fn observe(
    solver: &'static crate::DemSolver,
    case: &Case,
    run_dir: &Path,
) -> Result<Observations, crate::ParseError> {
    (solver.parse)(case, &Hopper.sensor(case), run_dir)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_response_table_names_every_response_the_hopper_computes() {
        let table: Vec<&str> = RESPONSES.iter().map(|r| r.name.as_ref()).collect();
        assert_eq!(table, orch_granular::responses::response_names());
    }

    #[test]
    fn a_pour_carries_the_mass_of_n_particles_of_the_mixture() {
        let case = case_with(&[("pour_rate", 0.1), ("n_particles", 3000.0)]);
        let pour = Pour::of(&case, 0.1).unwrap();
        // Half the mass in 4 mm spheres, half in 2 mm ones of 2500 kg/m³.
        let mass = |d: f64| 2500.0 * std::f64::consts::PI * d.powi(3) / 6.0;
        let count = 0.5 * pour.mass_kg / mass(0.004) + 0.5 * pour.mass_kg / mass(0.002);
        assert!((count - 3000.0).abs() < 1e-9, "{count}");
        assert!((pour.end_s - pour.mass_kg / 0.1).abs() < 1e-15);
        assert!((pour.top_m - 0.1).abs() < 1e-15);
        assert!((pour.top_m - pour.bottom_m - 0.012).abs() < 1e-15);
        // 12 mm at 1 m/s would be 12 ms; batches come at most 10 ms apart.
        assert_eq!(pour.interval_s, 0.01);
        assert_eq!(Pour::of(&case_with(&[]), 0.1), None);
    }

    #[test]
    fn a_pour_longer_than_the_fill_or_faster_than_the_inlet_passes_is_refused() {
        let slow = case_with(&[("pour_rate", 0.1), ("fill_time", 0.3)]);
        assert_eq!(
            check(&slow).unwrap_err().to_string(),
            "invalid case: pouring 0.0559 kg at pour_rate 0.1 kg/s takes 0.559 s, longer than fill_time (0.3 s); raise pour_rate or fill_time (and leave time to settle)"
        );
        let narrow = case_with(&[("pour_rate", 0.2), ("pour_diameter", 0.01)]);
        assert_eq!(
            check(&narrow).unwrap_err().to_string(),
            "invalid case: pour_rate (0.2 kg/s) exceeds what the inlet passes, 0.0295 kg/s (a solid fraction of 0.15 through a 0.01 m disk at pour_speed 1 m/s); widen pour_diameter, raise pour_speed or lower pour_rate"
        );
        let wide = case_with(&[
            ("pour_rate", 0.3),
            ("pour_diameter", 0.079),
            ("pour_speed", 5.0),
        ]);
        let error = check(&wide).unwrap_err().to_string();
        assert!(
            error.contains("pour_diameter (0.079 m) must leave a coarse particle's room"),
            "{error}"
        );
        assert!(check(&case_with(&[("pour_rate", 0.2), ("fill_time", 0.5)])).is_ok());
    }

    #[test]
    fn headline_responses_are_responses() {
        for name in Hopper.headline_responses() {
            assert!(RESPONSES.iter().any(|r| r.name == *name), "{name}");
        }
    }
}
