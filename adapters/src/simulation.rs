//! A simulation: what runs for each design point, the unit the driver renders, runs and
//! reads.
//!
//! Two kinds implement [`Simulation`]:
//! - [`EquipmentOnSolver`]: a built-in equipment simulated by a DEM solver from the
//!   solver's template (or the user's): the equipment checks the case, gives the
//!   template's context and writes its geometry; the solver gives the command and
//!   reads the output into observations; the equipment computes the responses.
//! - [`crate::custom::CustomDeck`]: a user's own deck with declared responses.
//!
//! Templates render in a locked-down Tera ([`locked_tera`]): no environment, no files
//! but the case's own templates.

use std::path::Path;

use tera::{Context, Tera};

use crate::{
    in_run_dir, Case, CommandSpec, DemSolver, Equipment, ParameterSpec, ParseError, RenderError,
    ResponseSpec, RunResults,
};

/// Responses every DEM run stores besides its equipment's: the solver's own figures.
pub const SOLVER_LOOP_TIME: &str = "solver_loop_time";
/// Particle steps per second of wall time in the solver's loop.
pub const SOLVER_THROUGHPUT: &str = "solver_particle_steps_per_s";
/// The response holding the run's deepest overlap over the smaller radius, when the
/// solver reports it: how close the run came to the native kernel's overlap bound.
pub const SOLVER_LARGEST_OVERLAP: &str = "solver_largest_overlap";
/// The response holding the mass a run's inflows placed over the mass they were asked
/// for, when the solver reports it: below 1 by more than a particle's mass, the bed
/// holds less material than the case asked for (the run's note says so).
pub const SOLVER_INFLOW_PLACED: &str = "solver_inflow_placed_fraction";

/// What runs for each design point of a study: its parameters and responses for
/// validation, and render, command and results for the driver.
pub trait Simulation: Send + Sync + std::fmt::Debug {
    /// The equipment's name (`hopper`, `custom`).
    fn equipment_name(&self) -> &str;

    /// The solver's name (`liggghts`), or the program of a user's own deck.
    fn solver_name(&self) -> &str;

    /// The declared parameters, with defaults and ranges.
    fn parameters(&self) -> &[ParameterSpec];

    /// True when factors and fixed values may name parameters that are not declared
    /// (a user's template may use any name).
    fn accepts_undeclared_parameters(&self) -> bool;

    /// Every scalar response a run produces.
    fn responses(&self) -> &[ResponseSpec];

    /// Every series a run stores (besides the solver's own).
    fn series(&self) -> &[ResponseSpec];

    /// The responses shown and fitted when a study names none.
    fn headline_responses(&self) -> Vec<String>;

    /// The template the store keeps with the study (name and text).
    fn template(&self) -> TemplateText;

    /// Checks a resolved case beyond per-parameter ranges; the error names parameters.
    fn check(&self, case: &Case) -> Result<(), RenderError>;

    /// The text files `case` renders to, as `(file in the run directory, text)`,
    /// without writing anything: validation renders every design point with it.
    fn render_texts(&self, case: &Case) -> Result<Vec<(String, String)>, RenderError>;

    /// Writes everything the command needs for `case` into `run_dir`.
    fn render(&self, case: &Case, run_dir: &Path) -> Result<(), RenderError>;

    /// The command that runs a rendered case.
    fn command(&self) -> CommandSpec;

    /// How a user installs the program, for the message when it is missing.
    fn install_hint(&self) -> String;

    /// Reads a finished run's responses and series.
    fn results(&self, case: &Case, run_dir: &Path) -> Result<RunResults, ParseError>;

    /// The responses of a run that is still going, from what it has written so far;
    /// `None` when the simulation cannot tell before it ends (a user's own deck).
    fn results_so_far(&self, case: &Case, run_dir: &Path) -> Option<RunResults> {
        let _ = (case, run_dir);
        None
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

/// A built-in equipment on a DEM solver, from the solver's template or the user's.
#[derive(Clone)]
pub struct EquipmentOnSolver {
    /// What is simulated.
    pub equipment: &'static dyn Equipment,
    /// Which program simulates it.
    pub solver: &'static DemSolver,
    template: TemplateText,
    user_template: bool,
    cores: usize,
}

impl std::fmt::Debug for EquipmentOnSolver {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} on {}", self.equipment.name(), self.solver.name)
    }
}

impl EquipmentOnSolver {
    /// The pair with the solver's default template, or `None` when the solver has no
    /// template for the equipment.
    pub fn new(equipment: &'static dyn Equipment, solver: &'static DemSolver) -> Option<Self> {
        let template = solver.template_for(equipment.name())?;
        Some(EquipmentOnSolver {
            equipment,
            solver,
            template: TemplateText {
                name: template.path.to_string(),
                text: template.text.to_string(),
            },
            user_template: false,
            cores: 1,
        })
    }

    /// The same with the user's template instead of the default.
    pub fn with_template(self, template: TemplateText) -> Self {
        EquipmentOnSolver {
            template,
            user_template: true,
            ..self
        }
    }

    /// The same on `cores` cores per run (threads or MPI ranks, as the solver does it;
    /// 0 counts as 1): the solver's command and, for LIGGGHTS, the deck's processor
    /// grid follow.
    pub fn with_cores(self, cores: usize) -> Self {
        EquipmentOnSolver {
            cores: cores.max(1),
            ..self
        }
    }

    /// Cores each run uses.
    pub fn cores(&self) -> usize {
        self.cores
    }

    /// The rendered deck's file name in the run directory: `<equipment>.<extension>`.
    pub fn deck_file(&self) -> String {
        format!("{}.{}", self.equipment.name(), self.solver.deck_extension)
    }
}

impl Simulation for EquipmentOnSolver {
    fn equipment_name(&self) -> &str {
        self.equipment.name()
    }

    fn solver_name(&self) -> &str {
        self.solver.name
    }

    fn parameters(&self) -> &[ParameterSpec] {
        self.equipment.parameters()
    }

    fn accepts_undeclared_parameters(&self) -> bool {
        self.user_template
    }

    fn responses(&self) -> &[ResponseSpec] {
        self.equipment.responses()
    }

    fn series(&self) -> &[ResponseSpec] {
        self.equipment.series()
    }

    fn headline_responses(&self) -> Vec<String> {
        let headline = self.equipment.headline_responses();
        headline.iter().map(|r| r.to_string()).collect()
    }

    fn template(&self) -> TemplateText {
        self.template.clone()
    }

    /// The equipment's checks, then the solver's own reading of the rendered deck
    /// ([`DemSolver::check_deck`]).
    fn check(&self, case: &Case) -> Result<(), RenderError> {
        let Some(check_deck) = self.solver.check_deck else {
            return self.equipment.check(case);
        };
        for (_, text) in self.render_texts(case)? {
            check_deck(&text).map_err(RenderError::InvalidCase)?;
        }
        Ok(())
    }

    /// The deck from the template, after the equipment's checks.
    fn render_texts(&self, case: &Case) -> Result<Vec<(String, String)>, RenderError> {
        self.equipment.check(case)?;
        let template = &self.template;
        let text = render_template(
            &template.name,
            &template.text,
            &self.equipment.context(case),
        )?;
        let text = (self.solver.decompose)(text, self.cores);
        Ok(vec![(self.deck_file(), text)])
    }

    /// Writes the deck and the equipment's geometry.
    fn render(&self, case: &Case, run_dir: &Path) -> Result<(), RenderError> {
        let texts = self.render_texts(case)?;
        self.equipment.write_geometry(case, run_dir)?;
        for (file, text) in texts {
            write(run_dir, &file, &text)?;
        }
        Ok(())
    }

    fn command(&self) -> CommandSpec {
        (self.solver.command)(&self.deck_file(), self.cores)
    }

    fn install_hint(&self) -> String {
        self.solver.install_hint.to_string()
    }

    /// The solver's observations, the equipment's responses and series, and the
    /// solver's loop time and throughput.
    fn results(&self, case: &Case, run_dir: &Path) -> Result<RunResults, ParseError> {
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
        if let Some(ratio) = observations.largest_overlap_ratio {
            results
                .responses
                .push((SOLVER_LARGEST_OVERLAP.to_string(), ratio));
        }
        if let Some(inflow) = observations.inflow.filter(|i| i.asked_kg > 0.0) {
            let fraction = inflow.placed_kg / inflow.asked_kg;
            results
                .responses
                .push((SOLVER_INFLOW_PLACED.to_string(), fraction));
            if inflow.short {
                results.notes.push(format!(
                    "the inflow placed {:.1} % of the {:.4e} kg asked by the end of its fill: its region had no room for the rest in time, so the bed holds less material than the case asks for (LIGGGHTS goes on inserting, into the discharge); make the inlet wider or its feed faster, or lower the mass rate (the hopper's `pour_diameter`, `pour_speed`, `pour_rate`; the chute's `inlet_length`, `inlet_speed`, `mass_rate`); the solver's log names the inflow",
                    100.0 * fraction,
                    inflow.asked_kg
                ));
            }
        }
        Ok(results)
    }

    fn results_so_far(&self, case: &Case, run_dir: &Path) -> Option<RunResults> {
        let sensor = self.equipment.sensor(case);
        let observations = (self.solver.parse_running)(case, &sensor, run_dir).ok()?;
        Some(self.equipment.results(case, &observations))
    }
}

/// The text of `file` in `run_dir` up to the end of its last complete line, for
/// reading the output of a program that is still writing it.
pub(crate) fn complete_lines(
    run_dir: &Path,
    file: &str,
) -> Result<(String, std::path::PathBuf), ParseError> {
    let path = crate::in_run_dir(run_dir, file);
    let mut text = std::fs::read_to_string(&path).map_err(ParseError::read(&path))?;
    text.truncate(text.rfind('\n').map_or(0, |end| end + 1));
    Ok((text, path))
}

/// A Tera that can read neither orch's environment (`get_env` is refused) nor any
/// file: templates are added as text and can include only each other.
pub fn locked_tera() -> Tera {
    let mut tera = Tera::default();
    tera.register_function(
        "get_env",
        |_: &std::collections::HashMap<String, tera::Value>| -> tera::Result<tera::Value> {
            Err(tera::Error::msg(
                "templates cannot read orch's environment; pass the value as a parameter (`fixed:`) instead",
            ))
        },
    );
    tera
}

/// Renders a Tera template given as text, naming it (with the line, when known) in
/// errors with every cause.
pub(crate) fn render_template(
    template_name: &str,
    template: &str,
    context: &Context,
) -> Result<String, RenderError> {
    let describe = |error: tera::Error| RenderError::template(template_name, template, &error);
    let mut tera = locked_tera();
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

/// The 1-based line of `template` a Tera error is about: the `--> line:column` of a
/// syntax error, or the first line that uses the variable a render error names.
pub(crate) fn error_line(template: &str, message: &str) -> Option<usize> {
    if let Some(at) = message.find("--> ") {
        let digits: String = message[at + 4..]
            .chars()
            .take_while(char::is_ascii_digit)
            .collect();
        return digits.parse().ok();
    }
    let start = message.find("Variable `")? + "Variable `".len();
    let name = &message[start..start + message[start..].find('`')?];
    let first_word = name.split(['.', '[']).next().unwrap_or(name);
    template
        .lines()
        .position(|line| {
            (line.contains("{{") || line.contains("{%"))
                && line
                    .split(|c: char| !(c.is_alphanumeric() || c == '_'))
                    .any(|word| word == first_word)
        })
        .map(|index| index + 1)
}

/// The context every parameter of `case` is in: numbers, text, `seed`, and `cores`.
pub(crate) fn context_of(case: &Case, cores: usize) -> Context {
    let mut context = Context::new();
    for (name, value) in &case.parameters.0 {
        context.insert(name.as_str(), value);
    }
    for (name, value) in &case.text {
        context.insert(name.as_str(), value);
    }
    context.insert("seed", &case.seed);
    context.insert("seed_prime", &crate::primes::prime_seed(case.seed, 0));
    context.insert("cores", &cores);
    context
}

/// Writes a text file into the run directory.
pub(crate) fn write(run_dir: &Path, file: &str, text: &str) -> Result<(), RenderError> {
    write_bytes(run_dir, file, text.as_bytes())
}

/// Writes a file into the run directory, creating the folders on its path.
pub(crate) fn write_bytes(run_dir: &Path, file: &str, bytes: &[u8]) -> Result<(), RenderError> {
    let path = in_run_dir(run_dir, file);
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent).map_err(|source| RenderError::Write {
            path: parent.to_path_buf(),
            source,
        })?;
    }
    std::fs::write(&path, bytes).map_err(|source| RenderError::Write { path, source })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn syntax_and_undefined_variable_errors_name_the_line() {
        let template = "a = 1\nb = {{ b }\nc = 2\n";
        let error = render_template("t.tera", template, &Context::new()).unwrap_err();
        assert!(
            error.to_string().starts_with("template t.tera:2: "),
            "{error}"
        );
        let template = "a = 1\nb = {{ b }}\nc = {{ missing_value * 2 }}\n";
        let mut context = Context::new();
        context.insert("b", &1);
        let error = render_template("t.tera", template, &context)
            .unwrap_err()
            .to_string();
        assert!(error.starts_with("template t.tera:3: "), "{error}");
        assert!(error.contains("missing_value"), "{error}");
    }

    #[test]
    fn templates_cannot_read_the_environment() {
        let error = render_template("t.tera", "{{ get_env(name=\"HOME\") }}", &Context::new())
            .unwrap_err()
            .to_string();
        assert!(error.contains("cannot read orch's environment"), "{error}");
    }

    #[test]
    fn templates_cannot_include_files() {
        let error = render_template("t.tera", "{% include \"/etc/passwd\" %}", &Context::new())
            .unwrap_err()
            .to_string();
        assert!(error.contains("/etc/passwd"), "{error}");
    }
}
