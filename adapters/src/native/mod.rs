//! orch's native DEM kernel (`orch-dem`, crate `orch-dem`): the hopper and the chute
//! as TOML case files.
//!
//! The default template `templates/native/hopper.toml.tera` describes the same case as
//! the LIGGGHTS deck (same parameters, the same derived values from
//! [`crate::hopper::context`], the same STL walls). The kernel detects crossings of the
//! sensor plane itself, interpolated within the step, and writes them to
//! `post/crossings.csv`; its log `log.native` holds a thermo table and a `Loop time`
//! line like LIGGGHTS's.

mod log;

use std::io::BufRead;
use std::path::Path;

use orch_granular::{crossing_csv, Crossing};

pub use log::{read_log, InflowLine, LargestOverlapLine, LoopLine, NativeLog, THERMO_HEADER};

use crate::solver::{deck_as_rendered, solver_command, SolverTemplate};
use crate::{
    crossings_cover_sink, numbered_lines, open_in_run_dir, Case, CommandSpec, DemSolver,
    Observations, ParseError, SensorPlane, Series,
};

/// orch's native kernel.
pub static SOLVER: DemSolver = DemSolver {
    name: "native",
    deck_extension: "toml",
    log_file: LOG_FILE,
    install_hint: "cargo install --path orchestrator (it installs orch-dem beside orch)",
    templates: &[
        SolverTemplate {
            equipment: "hopper",
            path: "templates/native/hopper.toml.tera",
            text: include_str!("../../../templates/native/hopper.toml.tera"),
        },
        SolverTemplate {
            equipment: "chute",
            path: "templates/native/chute.toml.tera",
            text: include_str!("../../../templates/native/chute.toml.tera"),
        },
    ],
    command,
    decompose: deck_as_rendered,
    check_deck: Some(check_case),
    parse,
    parse_running,
};

/// The rendered case file as the kernel reads it (`orch_dem::case::Case::parse`):
/// every field and its range, and a given time step against the Rayleigh and Hertz
/// times of the case's particles.
fn check_case(text: &str) -> Result<(), String> {
    orch_dem::case::Case::parse(text).map(drop).map_err(|e| {
        let message = e.to_string().replace("`run.timestep`", "`timestep`");
        format!("the native kernel would refuse its case file: {message}")
    })
}

/// The kernel's log in the run directory.
pub const LOG_FILE: &str = "log.native";
/// The sensor's crossings, relative to the run directory.
pub const CROSSINGS_FILE: &str = "post/crossings.csv";
/// Name of the kernel's program.
pub const PROGRAM: &str = "orch-dem";
/// Header line of [`CROSSINGS_FILE`] ([`crossing_csv`] owns the format).
pub use orch_granular::crossing_csv::HEADER as CROSSINGS_HEADER;

/// The `orch-dem` program: the one installed beside the running executable (as
/// `cargo install --path orchestrator` installs both), else the name, found on PATH.
pub fn program_path() -> String {
    std::env::current_exe()
        .ok()
        .and_then(|exe| exe.parent().map(|dir| dir.join(PROGRAM)))
        .filter(|candidate| candidate.is_file())
        .map(|path| path.display().to_string())
        .unwrap_or_else(|| PROGRAM.to_string())
}

/// `orch-dem run CASE --log log.native`, one thread; on more cores
/// `… --threads N`: the kernel's worker threads, whose number does not change a bit of
/// the result (forces are summed per particle in a fixed order).
fn command(case_file: &str, cores: usize) -> CommandSpec {
    let threads = cores.to_string();
    let mut args = vec!["run", case_file, "--log", LOG_FILE];
    if cores > 1 {
        args.extend(["--threads", &threads]);
    }
    CommandSpec {
        same_result_on_any_cores: true,
        ..solver_command(program_path(), &args, cores, LOG_FILE)
    }
}

/// The log's loop time, work and kinetic energy, and the kernel's own crossings.
fn parse(_case: &Case, _sensor: &SensorPlane, run_dir: &Path) -> Result<Observations, ParseError> {
    let open = |file: &str| open_in_run_dir(run_dir, file);
    let (reader, log_path) = open(LOG_FILE)?;
    let log = read_log(reader, &log_path)?;
    let (reader, crossings_path) = open(CROSSINGS_FILE)?;
    let crossings = read_crossings(reader, &crossings_path)?;
    if let Some(&(_, sink_mass)) = log.discharged_mass.last() {
        crossings_cover_sink(&crossings, sink_mass, &crossings_path)?;
    }
    Ok(Observations {
        crossings,
        solver_loop_time_s: Some(log.loop_time_s),
        particle_steps: Some(log.particle_steps),
        wall_impact_energy_j: log.wall_impact_energy_j,
        largest_overlap_ratio: log.largest_overlap_ratio,
        inflow: log.inflow_placed(),
        series: vec![Series {
            name: "kinetic_energy".to_string(),
            points: log.kinetic_energy,
        }],
    })
}

/// The crossings the kernel has flushed so far (it flushes them every `thermo_every`
/// steps); the YADE script writes the same file.
pub(crate) fn parse_running(
    _case: &Case,
    _sensor: &SensorPlane,
    run_dir: &Path,
) -> Result<Observations, ParseError> {
    let (text, path) = crate::simulation::complete_lines(run_dir, CROSSINGS_FILE)?;
    Ok(Observations {
        crossings: read_crossings(std::io::Cursor::new(text), &path)?,
        ..Observations::default()
    })
}

/// Reads the kernel's crossings CSV (YADE's script writes the same), in time order.
pub fn read_crossings<R: BufRead>(reader: R, path: &Path) -> Result<Vec<Crossing>, ParseError> {
    let malformed = |line: usize, message: String| ParseError::malformed(path, line, message);
    let mut crossings = Vec::new();
    // A header and no rows is a run in which nothing crossed (a jammed outlet): the
    // responses that need crossings are then missing, with why.
    let mut saw_header = false;
    for numbered in numbered_lines(reader, path) {
        let (number, line) = numbered?;
        if number == 1 {
            saw_header = true;
            if line.trim() != CROSSINGS_HEADER {
                return Err(malformed(
                    1,
                    format!("expected the header `{CROSSINGS_HEADER}`, found `{line}`"),
                ));
            }
            continue;
        }
        if line.trim().is_empty() {
            continue;
        }
        crossings.push(crossing_csv::parse_row(&line).map_err(|e| malformed(number, e))?);
    }
    if !saw_header {
        return Err(malformed(
            1,
            format!("the file is empty; the solver writes the header `{CROSSINGS_HEADER}` first, so it did not get that far"),
        ));
    }
    crossings.sort_by(|a, b| a.time_s.total_cmp(&b.time_s));
    Ok(crossings)
}

#[cfg(test)]
mod tests;
