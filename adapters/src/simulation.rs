//! A simulation: one equipment on one DEM solver, the unit the driver renders, runs and
//! reads.
//!
//! [`Simulation::render`] checks the case (the equipment's checks), renders the template
//! with the equipment's context, and writes the equipment's geometry beside the deck;
//! [`Simulation::command`] is the solver's; [`Simulation::results`] parses the solver's
//! output into observations and lets the equipment compute its responses, adding the
//! solver's throughput figures.

use std::path::Path;

use tera::{Context, Tera};

use crate::{
    in_run_dir, Case, CommandSpec, DemSolver, Equipment, ParseError, RenderError, RunResults,
};

/// Responses every DEM run stores besides its equipment's: the solver's own figures.
pub const SOLVER_LOOP_TIME: &str = "solver_loop_time";
/// Particle steps per second of wall time in the solver's loop.
pub const SOLVER_THROUGHPUT: &str = "solver_particle_steps_per_s";

/// One equipment simulated by one solver.
#[derive(Clone, Copy)]
pub struct Simulation {
    /// What is simulated.
    pub equipment: &'static dyn Equipment,
    /// Which program simulates it.
    pub solver: &'static DemSolver,
}

impl std::fmt::Debug for Simulation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} on {}", self.equipment.name(), self.solver.name)
    }
}

/// A template's name (for messages) and text.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TemplateText {
    /// Its name in messages: the default's repository path or the user's file.
    pub name: String,
    /// Its text.
    pub text: String,
}

impl Simulation {
    /// The pair, or `None` when the solver has no template for the equipment.
    pub fn new(equipment: &'static dyn Equipment, solver: &'static DemSolver) -> Option<Self> {
        solver.template_for(equipment.name())?;
        Some(Simulation { equipment, solver })
    }

    /// The solver's default template for the equipment.
    pub fn default_template(&self) -> TemplateText {
        let template = self
            .solver
            .template_for(self.equipment.name())
            .expect("Simulation::new checked the template exists");
        TemplateText {
            name: template.path.to_string(),
            text: template.text.to_string(),
        }
    }

    /// The rendered deck's file name in the run directory: `<equipment>.<extension>`.
    pub fn deck_file(&self) -> String {
        format!("{}.{}", self.equipment.name(), self.solver.deck_extension)
    }

    /// Writes the deck for `case` from `template` and the equipment's geometry into
    /// `run_dir`, after the equipment's checks.
    pub fn render(
        &self,
        case: &Case,
        template: &TemplateText,
        run_dir: &Path,
    ) -> Result<(), RenderError> {
        self.equipment.check(case)?;
        let text = render_template(
            &template.name,
            &template.text,
            &self.equipment.context(case),
        )?;
        self.equipment.write_geometry(case, run_dir)?;
        write(run_dir, &self.deck_file(), &text)
    }

    /// The command that runs a rendered case.
    pub fn command(&self) -> CommandSpec {
        (self.solver.command)(&self.deck_file())
    }

    /// Reads a finished run: the solver's observations, the equipment's responses and
    /// series, and the solver's loop time and throughput.
    pub fn results(&self, case: &Case, run_dir: &Path) -> Result<RunResults, ParseError> {
        let sensor = self.equipment.sensor(case);
        let observations = (self.solver.parse)(case, &sensor, run_dir)?;
        let mut results = self.equipment.results(case, &observations);
        if let Some(loop_time) = observations.solver_loop_time_s {
            results
                .responses
                .push((SOLVER_LOOP_TIME.to_string(), loop_time));
            if let Some(work) = observations.particle_steps.filter(|_| loop_time > 0.0) {
                results
                    .responses
                    .push((SOLVER_THROUGHPUT.to_string(), work / loop_time));
            }
        }
        Ok(results)
    }
}

/// Renders a Tera template given as text, naming it in errors with every cause.
pub(crate) fn render_template(
    template_name: &str,
    template: &str,
    context: &Context,
) -> Result<String, RenderError> {
    let describe = |error: tera::Error| RenderError::Template {
        template: template_name.to_string(),
        message: error_chain(&error),
    };
    let mut tera = Tera::default();
    tera.add_raw_template(template_name, template)
        .map_err(describe)?;
    tera.render(template_name, context).map_err(describe)
}

/// A Tera error with every cause, `: `-separated (Tera's own message rarely says which
/// variable or line).
pub(crate) fn error_chain(error: &tera::Error) -> String {
    let mut message = error.to_string();
    let mut source = std::error::Error::source(error);
    while let Some(cause) = source {
        message.push_str(": ");
        message.push_str(&cause.to_string());
        source = cause.source();
    }
    message
}

/// Writes a file into the run directory.
pub(crate) fn write(run_dir: &Path, file: &str, text: &str) -> Result<(), RenderError> {
    let path = in_run_dir(run_dir, file);
    std::fs::write(&path, text).map_err(|source| RenderError::Write { path, source })
}
