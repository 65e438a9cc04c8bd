//! DEM solvers: *which program* simulates an equipment, as small descriptors.
//!
//! A solver is data plus two functions: the deck's file extension, one Tera template per
//! equipment it can simulate, the command that runs a rendered deck, how to install the
//! program, and how to read what the program wrote into [`Observations`]. Everything
//! about the equipment itself (parameters, geometry, responses) lives in the
//! [`crate::Equipment`]; the [`crate::Simulation`] pairs the two.
//!
//! To add a solver: write its module with a `pub static SOLVER: DemSolver`, its
//! templates under `templates/<solver>/<equipment>.<ext>.tera`, and list it in
//! [`SOLVERS`].

use std::path::Path;

use crate::{Case, CommandSpec, Observations, ParseError, SensorPlane};

/// A template a solver ships for one equipment.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SolverTemplate {
    /// The equipment it renders.
    pub equipment: &'static str,
    /// Its path in the repository, for messages (`templates/liggghts/hopper.in.tera`).
    pub path: &'static str,
    /// Its text, compiled into the binary.
    pub text: &'static str,
}

/// A DEM program behind `orch`.
#[derive(Debug)]
pub struct DemSolver {
    /// Name used in study files (`solver: liggghts`).
    pub name: &'static str,
    /// Extension of the rendered deck: the deck is `<equipment>.<extension>`.
    pub deck_extension: &'static str,
    /// The solver's own log in the run directory.
    pub log_file: &'static str,
    /// How a user installs the program, for the message when it is missing.
    pub install_hint: &'static str,
    /// The default template of every equipment it can simulate.
    pub templates: &'static [SolverTemplate],
    /// The command that runs the deck named by the first argument in the run directory
    /// on as many cores as the second (threads or MPI ranks, as the program does it);
    /// with 1 core, the command every study ran before `executor.cores_per_job`.
    pub command: fn(deck_file: &str, cores: usize) -> CommandSpec,
    /// The rendered deck made fit to run on this many cores (LIGGGHTS: its `processors`
    /// grid); with 1 core the deck as rendered.
    pub decompose: fn(deck: String, cores: usize) -> String,
    /// Checks a rendered deck before anything is written, as far as orch can read it:
    /// the native kernel's whole case file (its time step against the Rayleigh and
    /// Hertz times included), so that a study whose runs would be refused fails at
    /// `orch submit` instead of once per job. `Err` says what is wrong. `None` for a
    /// solver whose decks orch cannot read ahead (LIGGGHTS, YADE): nothing is rendered
    /// for a check, and the solver says what is wrong when it runs.
    pub check_deck: Option<DeckCheck>,
    /// Reads what the program wrote into a run directory: crossings of `sensor`, loop
    /// time and work, series.
    pub parse:
        fn(case: &Case, sensor: &SensorPlane, run_dir: &Path) -> Result<Observations, ParseError>,
    /// Reads the crossings a *running* program has written so far (its last, possibly
    /// half-written record left out); the other observations stay empty.
    pub parse_running:
        fn(case: &Case, sensor: &SensorPlane, run_dir: &Path) -> Result<Observations, ParseError>,
}

/// Reads a rendered deck ahead of its solver; `Err` says what is wrong.
pub type DeckCheck = fn(deck: &str) -> Result<(), String>;

impl DemSolver {
    /// The default template for `equipment`, if this solver has one.
    pub fn template_for(&self, equipment: &str) -> Option<&'static SolverTemplate> {
        self.templates.iter().find(|t| t.equipment == equipment)
    }

    /// The program the command runs, for the "is it installed?" check.
    pub fn program(&self) -> String {
        (self.command)("deck", 1).program
    }
}

/// Every DEM solver `orch` knows.
pub static SOLVERS: &[&DemSolver] = &[
    &crate::liggghts::SOLVER,
    &crate::native::SOLVER,
    &crate::yade::SOLVER,
];

/// The solver called `name`, or `None`.
pub fn solver_for(name: &str) -> Option<&'static DemSolver> {
    SOLVERS.iter().copied().find(|s| s.name == name)
}

/// Names of every solver, for messages.
pub fn solver_names() -> Vec<&'static str> {
    SOLVERS.iter().map(|s| s.name).collect()
}

/// A command of `program` with `args` on `cores` cores, logging to `log_file`.
pub(crate) fn solver_command(
    program: String,
    args: &[&str],
    cores: usize,
    log_file: &str,
) -> CommandSpec {
    CommandSpec {
        program,
        args: args.iter().map(|s| s.to_string()).collect(),
        env: Default::default(),
        cores,
        mpi: false,
        same_result_on_any_cores: false,
        log_file: log_file.to_string(),
    }
}

/// [`DemSolver::decompose`] of a solver whose decks run on any number of cores as
/// they are (threads are chosen on the command line).
pub(crate) fn deck_as_rendered(deck: String, _cores: usize) -> String {
    deck
}
