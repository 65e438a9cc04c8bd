//! YADE (Debian `yade` 2023.02a): the hopper case as a Python script run in batch.
//!
//! The default template `templates/yade/hopper.py.tera` builds the same case as the
//! LIGGGHTS deck and the native kernel's case file (same parameters, the derived values
//! of [`crate::hopper::context`], the same STL walls imported as facets): Hertz-Mindlin
//! contacts (`Ip2_FrictMat_FrictMat_MindlinPhys` + `Law2_ScGeom_MindlinPhys_Mindlin`),
//! a plug removed after filling, vertical vibration by `HarmonicMotionEngine`. A
//! `PyRunner` sensor writes each particle's crossing of the sensor plane to
//! `post/crossings.csv` in the native kernel's format, so [`read_crossings`] reads both.
//!
//! Facts this relies on (`shared/solvers/README.md`): `yade -n -x script.py` runs
//! without a GUI and exits when the script ends, 0 on success and 1 on an uncaught
//! exception; `NewtonIntegrator`'s default damping 0.2 must be set to 0; `-j 2` is not
//! reproducible, so runs use one thread unless `executor.cores_per_job` asks for more.

mod log;

use std::path::Path;

pub use log::{read_log, YadeSummary, SUMMARY_PREFIX};

use crate::native::read_crossings;
use crate::solver::{deck_as_rendered, solver_command, SolverTemplate};
use crate::{
    crossings_cover_sink, open_in_run_dir, Case, CommandSpec, DemSolver, Observations, ParseError,
    SensorPlane,
};

/// YADE, run in batch (one thread unless the study asks for more cores).
pub static SOLVER: DemSolver = DemSolver {
    name: "yade",
    deck_extension: "py",
    log_file: LOG_FILE,
    install_hint: "apt-get install -y yade (or scripts/setup)",
    templates: &[SolverTemplate {
        equipment: "hopper",
        path: "templates/yade/hopper.py.tera",
        text: include_str!("../../../templates/yade/hopper.py.tera"),
    }],
    command,
    decompose: deck_as_rendered,
    check_deck: None,
    parse,
    parse_running: crate::native::parse_running,
};

/// The log the script writes in the run directory.
pub const LOG_FILE: &str = "log.yade";
/// The sensor's crossings, relative to the run directory.
pub const CROSSINGS_FILE: &str = "post/crossings.csv";

/// `yade -j N -n -x SCRIPT`: no GUI, exit when the script ends, N OpenMP threads.
/// One thread (the default) is reproducible; `-j 2` and more are not (the order of
/// YADE's parallel force sums changes from run to run), so a study that asks for more
/// cores trades bit-for-bit replays for speed. Python writes its output unbuffered
/// (`PYTHONUNBUFFERED=1`), so a traceback is not lost when YADE dies.
fn command(script_file: &str, cores: usize) -> CommandSpec {
    let threads = cores.to_string();
    let mut command = solver_command(
        "yade".to_string(),
        &["-j", &threads, "-n", "-x", script_file],
        cores,
        LOG_FILE,
    );
    command
        .env
        .insert("PYTHONUNBUFFERED".to_string(), "1".to_string());
    command
}

/// The script's summary line (loop time, work) and its crossings.
fn parse(_case: &Case, _sensor: &SensorPlane, run_dir: &Path) -> Result<Observations, ParseError> {
    let open = |file: &str| open_in_run_dir(run_dir, file);
    let (reader, log_path) = open(LOG_FILE)?;
    let summary = read_log(reader, &log_path)?;
    let (reader, crossings_path) = open(CROSSINGS_FILE)?;
    let crossings = read_crossings(reader, &crossings_path)?;
    if let Some(removed) = summary.removed_mass_kg {
        crossings_cover_sink(&crossings, removed, &crossings_path)?;
    }
    Ok(Observations {
        crossings,
        solver_loop_time_s: Some(summary.loop_time_s),
        particle_steps: Some(summary.particle_steps),
        wall_impact_energy_j: None,
        largest_overlap_ratio: None,
        inflow: None,
        series: Vec::new(),
    })
}

#[cfg(test)]
mod tests;
