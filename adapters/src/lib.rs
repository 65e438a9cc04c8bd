//! Solver adapters for `orch`.
//!
//! Each DEM solver (LIGGGHTS, YADE and orch's native kernel) sits behind
//! one trait, [`SolverAdapter`], that does three things for a fully resolved [`Case`]:
//!
//! 1. **render** the solver's input into a run directory (a Tera template plus the
//!    geometry files `orch-granular` generates),
//! 2. **describe the command** that runs it ([`CommandSpec`]), which an executor then
//!    launches locally or through Slurm, and
//! 3. **parse** what the solver wrote into [`Observations`] (the particles that crossed
//!    the sensor plane, solver statistics), failing with file and line on bad input.
//!
//! Adapters own their templates' variables ([`ParameterSpec`]) so a study file can be
//! checked against them before anything runs.

pub mod dump;
mod error;
pub mod hopper;
pub mod liggghts;
pub mod native;
pub mod openfoam;
mod params;
mod primes;
pub mod yade;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

pub(crate) use error::numbered_lines;
pub use error::{ParseError, RenderError};
pub use params::{ParameterSpec, ResolvedParameters};

/// One fully resolved simulation: every template parameter has a value.
#[derive(Debug, Clone, PartialEq)]
pub struct Case {
    /// Parameter values in SI units, by name (defaults, fixed values and factors merged).
    pub parameters: ResolvedParameters,
    /// Seed for the solver's random insertion; replicates differ only in their seed.
    pub seed: u64,
}

impl Case {
    /// The value of parameter `name`; adapters call this only for their own parameters,
    /// which validation guarantees are present.
    pub fn get(&self, name: &str) -> f64 {
        self.parameters.get(name)
    }
}

/// How to run a rendered case: what an executor needs and nothing more.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CommandSpec {
    /// Program to run, looked up on `PATH` when not absolute.
    pub program: String,
    /// Arguments, relative paths being relative to the run directory.
    pub args: Vec<String>,
    /// Extra environment variables.
    pub env: BTreeMap<String, String>,
    /// Cores the run uses; executors use it to limit concurrency.
    pub cores: usize,
    /// The file, relative to the run directory, holding the solver's own log.
    pub log_file: String,
}

/// A time series observed in one run, e.g. the mass-flow rate.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Name, e.g. `mass_flow_rate`.
    pub name: String,
    /// `(time s, value)` pairs.
    pub points: Vec<(f64, f64)>,
}

/// What a solver observed in one run, before responses are computed from it.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Observations {
    /// Every particle's first crossing of the sensor plane, in time order.
    pub crossings: Vec<orch_granular::Crossing>,
    /// Wall time the solver spent in its time loop, s.
    pub solver_loop_time_s: Option<f64>,
    /// Particles × time steps the solver advanced (for throughput figures).
    pub particle_steps: Option<f64>,
    /// Time series read from solver output other than the crossings.
    pub series: Vec<Series>,
}

/// A solver behind `orch`: render, command, parse.
pub trait SolverAdapter: Send + Sync {
    /// Name used in study files (`solver: liggghts`).
    fn name(&self) -> &'static str;

    /// The parameters the default template understands, with defaults and ranges.
    fn parameters(&self) -> &'static [ParameterSpec];

    /// The default template's file name under `templates/<solver>/`, for messages.
    fn default_template_name(&self) -> &'static str;

    /// How a user installs the solver, for the message when it is missing.
    fn install_hint(&self) -> &'static str;

    /// The default template's text (compiled into the binary).
    fn default_template(&self) -> &'static str;

    /// Checks a resolved case beyond per-parameter ranges (e.g. that the geometry can
    /// be built); returns what is wrong, naming the parameters.
    fn check(&self, case: &Case) -> Result<(), RenderError>;

    /// Writes the solver's input for `case` into `run_dir` from `template` (the text of
    /// a Tera template named `template_name` in messages).
    fn render(
        &self,
        case: &Case,
        template_name: &str,
        template: &str,
        run_dir: &Path,
    ) -> Result<(), RenderError>;

    /// The command that runs a case rendered into `run_dir`.
    fn command(&self, case: &Case) -> CommandSpec;

    /// Reads what the solver wrote into `run_dir`.
    fn parse(&self, case: &Case, run_dir: &Path) -> Result<Observations, ParseError>;
}

/// Names of every solver `orch` knows, for messages.
pub const SOLVER_NAMES: &[&str] = &["liggghts", "native", "yade"];

/// The adapter for solver `name`, or `None` for an unknown solver.
pub fn adapter_for(name: &str) -> Option<&'static dyn SolverAdapter> {
    match name {
        "liggghts" => Some(&liggghts::Liggghts),
        "native" => Some(&native::Native),
        "yade" => Some(&yade::Yade),
        _ => None,
    }
}

/// Opens a file of a run directory for reading; the error names the file.
pub(crate) fn open_in_run_dir(
    run_dir: &Path,
    file: &str,
) -> Result<(std::io::BufReader<std::fs::File>, PathBuf), ParseError> {
    let path = in_run_dir(run_dir, file);
    let file = std::fs::File::open(&path).map_err(ParseError::read(&path))?;
    Ok((std::io::BufReader::new(file), path))
}

/// The path of a file in a run directory, for messages.
pub(crate) fn in_run_dir(run_dir: &Path, file: &str) -> PathBuf {
    run_dir.join(file)
}
