//! LIGGGHTS (Debian `liggghts` 3.8.0): a conical hopper discharge deck.
//!
//! The default template `templates/liggghts/hopper.in.tera` fills the hopper with a
//! bidisperse mixture while a plug closes the outlet, removes the plug, vibrates the
//! hopper (and its internal valve) vertically, and dumps every particle in a thin band
//! around the sensor plane every `sensor_every` steps. [`Liggghts::parse`] turns those
//! sightings into crossings of the plane. Facts this relies on are measured in
//! `shared/solvers/README.md`: `quit` exits 1, so the deck ends by running out of input;
//! seeds must be primes above 10000; the mass-flow file has no time column, so the
//! sensor dump (whose time step gives the time) is what we read.

mod log;

use std::path::Path;

use orch_granular::CrossingDetector;

pub use log::{read_log, LogSummary};

/// The hopper parameters (shared with the native kernel's template).
pub use crate::hopper::PARAMETERS;

use crate::dump::read_dump;
use crate::hopper;
use crate::{
    open_in_run_dir, Case, CommandSpec, Observations, ParameterSpec, ParseError, RenderError,
    SolverAdapter,
};

/// The LIGGGHTS adapter.
#[derive(Debug, Clone, Copy, Default)]
pub struct Liggghts;

/// Name of the rendered deck in the run directory.
pub const DECK_FILE: &str = "hopper.in";
/// Name of the LIGGGHTS log in the run directory.
pub const LOG_FILE: &str = "log.liggghts";
/// The sensor dump, relative to the run directory.
pub const SENSOR_DUMP: &str = "post/sensor.liggghts";

impl SolverAdapter for Liggghts {
    fn name(&self) -> &'static str {
        "liggghts"
    }

    fn parameters(&self) -> &'static [ParameterSpec] {
        PARAMETERS
    }

    fn default_template_name(&self) -> &'static str {
        "templates/liggghts/hopper.in.tera"
    }

    fn install_hint(&self) -> &'static str {
        "apt-get install -y liggghts"
    }

    fn default_template(&self) -> &'static str {
        include_str!("../../../templates/liggghts/hopper.in.tera")
    }

    fn check(&self, case: &Case) -> Result<(), RenderError> {
        hopper::check(case)
    }

    fn render(
        &self,
        case: &Case,
        template_name: &str,
        template: &str,
        run_dir: &Path,
    ) -> Result<(), RenderError> {
        hopper::render(case, template_name, template, run_dir, DECK_FILE)
    }

    fn command(&self, _case: &Case) -> CommandSpec {
        CommandSpec {
            program: "liggghts".to_string(),
            args: ["-in", DECK_FILE, "-log", LOG_FILE, "-echo", "none"]
                .iter()
                .map(|s| s.to_string())
                .collect(),
            env: Default::default(),
            cores: 1,
            log_file: LOG_FILE.to_string(),
        }
    }

    fn parse(&self, case: &Case, run_dir: &Path) -> Result<Observations, ParseError> {
        let open = |file: &str| open_in_run_dir(run_dir, file);
        let (reader, log_path) = open(LOG_FILE)?;
        let log = read_log(reader, &log_path)?;

        let dt = case.get("timestep");
        let mut detector = CrossingDetector::new(hopper::sensor_z_m(case));
        let (reader, dump_path) = open(SENSOR_DUMP)?;
        read_dump(reader, &dump_path, |snapshot| {
            let time = snapshot.timestep as f64 * dt;
            let sightings = snapshot.sightings().map_err(|missing| {
                format!("the sensor dump lacks the columns {}", missing.join(", "))
            })?;
            for sighting in sightings {
                detector.observe(time, sighting);
            }
            Ok(())
        })?;
        let kinetic_energy = log
            .kinetic_energy
            .iter()
            .map(|&(step, ke)| (step as f64 * dt, ke))
            .collect();
        Ok(Observations {
            crossings: detector.finish(),
            solver_loop_time_s: Some(log.loop_time_s),
            particle_steps: Some(log.particle_steps),
            series: vec![crate::Series {
                name: "kinetic_energy".to_string(),
                points: kinetic_energy,
            }],
        })
    }
}

#[cfg(test)]
mod tests;
