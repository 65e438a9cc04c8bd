//! Equipment, solvers and stages for `orch`: the seam between *what* is simulated and
//! *which program* simulates it.
//!
//! - An [`Equipment`] (the [`hopper::Hopper`], the [`chute::Chute`]) owns its parameters
//!   ([`ParameterSpec`]), checks, template context, geometry files, sensor plane and
//!   responses ([`ResponseSpec`]).
//! - A [`DemSolver`] (LIGGGHTS, YADE, the native kernel) is a descriptor: deck
//!   extension, one template per equipment, the command ([`CommandSpec`]) and a parser
//!   of its output into [`Observations`], failing with file and line on bad input.
//! - A [`Simulation`] is what runs for each design point: an [`EquipmentOnSolver`]
//!   (render, command, results), or a user's own deck ([`custom::CustomDeck`]) with
//!   the responses its study declares.
//! - A [`Stage`] (OpenFOAM's stream air, [`openfoam::StreamAir`]) is a job that follows
//!   another and reads its case and responses ([`Upstream`]).
//!
//! The orchestrator knows equipment, solvers and stages only through these types and
//! the registries [`EQUIPMENT`], [`SOLVERS`] and [`STAGES`].

pub mod chute;
pub mod custom;
pub mod dem_in_air;
pub mod dump;
pub mod equipment;
mod error;
pub mod hopper;
pub mod liggghts;
pub mod native;
pub mod openfoam;
mod params;
mod primes;
pub mod script_stage;
pub mod simulation;
pub mod solver;
pub mod stage;
pub mod thin;
pub mod yade;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

pub use equipment::{
    equipment_for, equipment_names, Equipment, ResponseSpec, SensorPlane, DEFAULT_EQUIPMENT,
    EQUIPMENT,
};
pub(crate) use error::numbered_lines;
pub use error::{ParseError, RenderError};
pub use params::{ParameterSpec, ResolvedParameters};
pub use simulation::{locked_tera, EquipmentOnSolver, Simulation, TemplateText};
pub use solver::{solver_for, solver_names, DemSolver, SolverTemplate, SOLVERS};
pub use stage::{stage_for, stage_kinds, Stage, StageError, Upstream, UpstreamFiles, STAGES};

/// One fully resolved simulation: every template parameter has a value.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Case {
    /// Parameter values in SI units, by name (defaults, fixed values and factors merged).
    pub parameters: ResolvedParameters,
    /// Text parameters by name (a user's own deck may take words, e.g. a contact model).
    pub text: BTreeMap<String, String>,
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
    /// True when `cores` are MPI ranks the command starts itself (`mpirun -np N`), one
    /// process each; false when they are threads of one process. A batch scheduler
    /// asks for `N` tasks of one CPU for the first and one task of `N` CPUs for the
    /// second.
    pub mpi: bool,
    /// True when the result is bit-for-bit the same on any number of cores (the native
    /// kernel's fixed summation order): a run's identity then leaves the cores and
    /// the arguments that carry them out. False for every program that decomposes
    /// its domain or sums in the order threads finish (LIGGGHTS, YADE, OpenFOAM, a
    /// user's deck).
    pub same_result_on_any_cores: bool,
    /// The file, relative to the run directory, holding the solver's own log.
    pub log_file: String,
}

/// A time series observed in one run, e.g. the mass-flow rate.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Name, e.g. `mass_flow_rate`.
    pub name: String,
    /// `(abscissa, value)` pairs: time in s, unless the series' declaration says
    /// otherwise (the hopper's radial densities are over radius in m).
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
    /// Sum over particle–wall impacts of the normal approach energy `½ m v_n²`, J, when
    /// the solver reports it (the native kernel does).
    pub wall_impact_energy_j: Option<f64>,
    /// The deepest overlap of the run over the smaller radius, when the solver reports
    /// it (the native kernel does).
    pub largest_overlap_ratio: Option<f64>,
    /// What the run's inflows placed against what they were asked for, when the solver
    /// reports it (the native kernel does, for a case with an inflow).
    pub inflow: Option<InflowPlaced>,
    /// Time series read from solver output other than the crossings.
    pub series: Vec<Series>,
}

/// What a run's inflows placed, summed over its inflows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InflowPlaced {
    /// Mass placed, kg.
    pub placed_kg: f64,
    /// Mass the inflows' batches asked for, kg.
    pub asked_kg: f64,
    /// True when an inflow fell short by more than one particle: its region had no
    /// room for the rest, and the bed holds less material than the case asked for.
    pub short: bool,
}

/// What a run gives the store: named scalar responses and named series.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RunResults {
    /// `(name, value)` in the unit the response's [`ResponseSpec`] gives.
    pub responses: Vec<(String, f64)>,
    /// Time series.
    pub series: Vec<Series>,
    /// Responses the run could not define, with why (`discharge_rate`: "no steady
    /// discharge: 6 of 300 particles crossed the sensor plane").
    pub missing: Vec<(String, String)>,
    /// What a user should know of how the results were read (a series stored thinned).
    pub notes: Vec<String>,
}

/// Fraction of the mass a solver counted past its sink that the crossings of the sensor
/// plane above it must hold: every particle that left crossed the plane first, so less
/// means the crossings were cut short (a sensor that samples may miss a few).
pub const CROSSINGS_COVER_SINK: f64 = 0.98;

/// Checks the crossings read from `path` against the mass the solver itself counted past
/// its sink, kg: a file cut short (a truncated write, a full disk) holds less.
pub(crate) fn crossings_cover_sink(
    crossings: &[orch_granular::Crossing],
    sink_mass_kg: f64,
    path: &Path,
) -> Result<(), ParseError> {
    let crossed: f64 = crossings.iter().map(|c| c.mass_kg).sum();
    if crossed < CROSSINGS_COVER_SINK * sink_mass_kg {
        return Err(ParseError::Unusable {
            path: path.to_path_buf(),
            message: format!(
                "its {} crossings hold {crossed:.6e} kg, but the solver counted {sink_mass_kg:.6e} kg past its sink below the sensor plane; the file is cut short or damaged",
                crossings.len()
            ),
        });
    }
    Ok(())
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
