//! LIGGGHTS (Debian `liggghts` 3.8.0): a conical hopper discharge deck and a transfer
//! chute deck.
//!
//! The hopper template `templates/liggghts/hopper.in.tera` fills the hopper with a
//! bidisperse mixture while a plug closes the outlet, removes the plug, vibrates the
//! hopper (and its internal valve) vertically, and dumps every particle in a thin band
//! around the sensor plane every `sensor_every` steps. The parser turns those
//! sightings into crossings of the plane ([`SOLVER`]'s parser). The chute template
//! `templates/liggghts/chute.in.tera` feeds the stream with `fix insert/rate/region`
//! and dumps the same band around its receiving plane. Facts this relies on are measured in
//! `shared/solvers/README.md`: `quit` exits 1, so the deck ends by running out of input;
//! seeds must be primes above 10000; the mass-flow file has no time column, so the
//! sensor dump (whose time step gives the time) is what we read.

mod grid;
mod log;

use std::path::Path;

use orch_granular::CrossingDetector;

pub use grid::{decompose, processor_grid};
pub use log::{read_log, LogSummary, LoopLine};

use crate::dump::read_dump;
use crate::solver::{solver_command, SolverTemplate};
use crate::{
    crossings_cover_sink, open_in_run_dir, Case, DemSolver, Observations, ParseError, SensorPlane,
};

/// The LIGGGHTS solver.
pub static SOLVER: DemSolver = DemSolver {
    name: "liggghts",
    deck_extension: "in",
    log_file: LOG_FILE,
    install_hint: "apt-get install -y liggghts",
    templates: &[
        SolverTemplate {
            equipment: "hopper",
            path: "templates/liggghts/hopper.in.tera",
            text: include_str!("../../../templates/liggghts/hopper.in.tera"),
        },
        SolverTemplate {
            equipment: "chute",
            path: "templates/liggghts/chute.in.tera",
            text: include_str!("../../../templates/liggghts/chute.in.tera"),
        },
    ],
    command,
    decompose,
    check_deck: None,
    parse,
    parse_running,
};

/// Name of the LIGGGHTS log in the run directory.
pub const LOG_FILE: &str = "log.liggghts";
/// The sensor dump, relative to the run directory.
pub const SENSOR_DUMP: &str = "post/sensor.liggghts";

/// `liggghts -in DECK -log log.liggghts -echo none` on one core; on `N` > 1 cores
/// `mpirun -np N liggghts …`, `N` MPI ranks (Debian's LIGGGHTS is built with Open MPI),
/// the deck's box split by [`decompose`]. Open MPI refuses to run as root unless told
/// it may (containers run as root), so the command's environment says so; inside a
/// Slurm allocation `mpirun` takes its hosts from the allocation.
fn command(deck_file: &str, cores: usize) -> crate::CommandSpec {
    let liggghts = ["-in", deck_file, "-log", LOG_FILE, "-echo", "none"];
    if cores <= 1 {
        return solver_command("liggghts".to_string(), &liggghts, 1, LOG_FILE);
    }
    let ranks = cores.to_string();
    let mut args = vec!["-np", &ranks, "liggghts"];
    args.extend(liggghts);
    let mut spec = solver_command(MPIRUN.to_string(), &args, cores, LOG_FILE);
    spec.mpi = true;
    for (key, value) in MPI_ENV {
        spec.env.insert(key.to_string(), value.to_string());
    }
    spec
}

/// The MPI launcher of multi-core runs.
pub const MPIRUN: &str = "mpirun";
/// Environment of multi-core runs: Open MPI's consent to run as root (it refuses
/// otherwise; harmless for other users), and to start more ranks than it counts slots
/// (a container may show fewer cores than it may use; a study that asks for more ranks
/// than the machine has runs slower rather than not at all), and to yield the CPU while
/// a rank waits for messages instead of spinning: on a machine shared with other jobs a
/// spinning rank takes the CPU its peer needs (measured here under a load of 7 on two
/// cores: a 1000-particle hopper on two ranks took 25–28 s spinning, 12–13 s yielding).
pub const MPI_ENV: [(&str, &str); 4] = [
    ("OMPI_ALLOW_RUN_AS_ROOT", "1"),
    ("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1"),
    ("OMPI_MCA_rmaps_base_oversubscribe", "1"),
    ("OMPI_MCA_mpi_yield_when_idle", "1"),
];

/// The log's loop time and work, and the crossings of the sensor plane from the
/// sightings in the sensor dump (its time step times `timestep` gives the time).
fn parse(case: &Case, sensor: &SensorPlane, run_dir: &Path) -> Result<Observations, ParseError> {
    let open = |file: &str| open_in_run_dir(run_dir, file);
    let (reader, log_path) = open(LOG_FILE)?;
    let log = read_log(reader, &log_path)?;

    let dt = case.get("timestep");
    let (reader, dump_path) = open(SENSOR_DUMP)?;
    let crossings = crossings_in_dump(reader, &dump_path, dt, sensor_every(case), sensor)?;
    if let Some(sink_mass) = log.sink_mass_kg {
        crossings_cover_sink(&crossings, sink_mass, &dump_path)?;
    }
    let kinetic_energy = log
        .kinetic_energy
        .iter()
        .map(|&(step, ke)| (step as f64 * dt, ke))
        .collect();
    Ok(Observations {
        crossings,
        solver_loop_time_s: Some(log.loop_time_s),
        particle_steps: Some(log.particle_steps),
        wall_impact_energy_j: None,
        largest_overlap_ratio: None,
        inflow: log.insertion.map(|i| i.inflow_placed()),
        series: vec![crate::Series {
            name: "kinetic_energy".to_string(),
            points: kinetic_energy,
        }],
    })
}

/// The crossings in the sensor dump of a run still going: every snapshot but the last,
/// which LIGGGHTS may be writing.
fn parse_running(
    case: &Case,
    sensor: &SensorPlane,
    run_dir: &Path,
) -> Result<Observations, ParseError> {
    let (mut text, dump_path) = crate::simulation::complete_lines(run_dir, SENSOR_DUMP)?;
    text.truncate(text.rfind("ITEM: TIMESTEP").unwrap_or(0));
    let crossings = crossings_in_dump(
        std::io::Cursor::new(text),
        &dump_path,
        case.get("timestep"),
        sensor_every(case),
        sensor,
    )?;
    Ok(Observations {
        crossings,
        ..Observations::default()
    })
}

/// Steps between sensor snapshots (`sensor_every`).
fn sensor_every(case: &Case) -> u64 {
    case.get("sensor_every").round() as u64
}

/// Each particle's crossing of `sensor` from the sightings in a sensor dump whose
/// time step number times `dt_s` gives the time, `every` steps apart.
///
/// Reads both forms of the dump: every particle in the band at every snapshot, or the
/// lean form the hopper deck writes, where a particle appears at the snapshot that
/// first sees it below the plane with its state at the snapshot before (see
/// [`crate::dump::PREVIOUS_COLUMNS`]). The detector then sees, per particle, the same
/// last sighting above and first below as in the full band, so the crossings are the
/// same. The first snapshot's previous states are not sightings (nothing was stored
/// before it) and are ignored.
fn crossings_in_dump(
    reader: impl std::io::BufRead,
    path: &Path,
    dt_s: f64,
    every: u64,
    sensor: &SensorPlane,
) -> Result<Vec<orch_granular::Crossing>, ParseError> {
    let mut detector = CrossingDetector::new(sensor.height_m);
    let mut first = true;
    read_dump(reader, path, |snapshot| {
        let lacks = |missing: Vec<&str>| {
            format!("the sensor dump lacks the columns {}", missing.join(", "))
        };
        let sightings = snapshot.sightings().map_err(lacks)?;
        let previous = snapshot.previous_sightings().map_err(lacks)?;
        let now_s = snapshot.timestep as f64 * dt_s;
        match previous {
            Some(previous) => {
                let before_s = snapshot.timestep.saturating_sub(every) as f64 * dt_s;
                for (sighting, before) in sightings.into_iter().zip(previous) {
                    if let Some(before) = before.filter(|_| !first) {
                        detector.observe(before_s, before);
                    }
                    detector.observe(now_s, sighting);
                }
            }
            None => {
                for sighting in sightings {
                    detector.observe(now_s, sighting);
                }
            }
        }
        first = false;
        Ok(())
    })?;
    Ok(detector.finish())
}

#[cfg(test)]
mod tests;
