//! Study files: parse, then validate into a [`Study`] that the driver can run.
//!
//! Parsing and validation happen before anything is written. Every error names the
//! file, the line and column, the field and what was expected ([`StudyError`]).
//!
//! Beside the study, what is derived from it without I/O beyond the study's own
//! files: [`plan`] names, seeds and chains every job of a point; [`identity`] is
//! what makes two runs the same run; [`keep`] is which files a finished run keeps.

pub mod identity;
pub mod keep;
pub mod plan;

mod custom;
mod design;
mod executor;
mod factors;
mod fidelity;
mod file;
mod locate;
mod objective;
mod stages;
mod uncertainty;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

use orch_adapters::script_stage;
use orch_adapters::{
    equipment_for, equipment_names, solver_for, solver_names, stage_for, Case, EquipmentOnSolver,
    ParameterSpec, ResolvedParameters, Simulation, Stage, DEFAULT_EQUIPMENT,
};
use orch_metamodel::kriging::{Kernel, KrigingOptions, Trend};
use orch_metamodel::levels::{coded_level, level_of};
use orch_metamodel::surrogate::ModelChoice;
use orch_metamodel::{
    BasisKind, CentralCompositeAlpha, Design, DesignError, DesignKind, Distribution, FactorRange,
    Goal, MAX_RUNS,
};
use sha2::{Digest, Sha256};

pub use fidelity::{nested_points, Fidelity};
use file::{
    AlphaFile, BasisFile, DesignFile, DesignType, DistributionFile, ExecutorFile, FixedValue,
    GoalFile, KernelFile, ModelFile, TrendFile,
};
pub use file::{ExecutorKind, StudyFile};

pub use design::{coded_design, default_test_points};
pub use executor::ExecutorConfig;
pub use locate::Location;
use orch_executor::SlurmSettings;
pub use stages::{Coupling, StageConfig, StageRef, StopWhen};
pub use uncertainty::{mean_of, noise_range, Material, NoiseDesign, UncertaintyConfig};

/// Most Monte Carlo samples `uncertainty.samples` may ask for: each round's analysis
/// holds them all in memory.
pub const MAX_UNCERTAINTY_SAMPLES: usize = 10_000_000;

/// A study file that cannot be used, with where and why.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{}{}: {field}: {message}", path.display(), location.map(|l| format!(":{}:{}", l.line, l.column)).unwrap_or_default())]
pub struct StudyError {
    /// The study file.
    pub path: PathBuf,
    /// Where in it, when known.
    pub location: Option<Location>,
    /// The field path, e.g. `factors[1].max`; `(file)` for the file as a whole.
    pub field: String,
    /// What is wrong and what was expected.
    pub message: String,
}

/// One design variable, validated.
#[derive(Debug, Clone, PartialEq)]
pub struct Factor {
    /// Template parameter it sets.
    pub name: String,
    /// Its range in natural units; for a text factor `[0, L − 1]`, its levels'
    /// indices.
    pub range: FactorRange,
    /// Unit (empty for a text factor).
    pub unit: String,
    /// A text factor's values in the study's order (empty for a numeric factor): its
    /// natural value is the index of one of them.
    pub levels: Vec<String>,
}

impl Factor {
    /// True for a text factor (`levels:`).
    pub fn is_text(&self) -> bool {
        !self.levels.is_empty()
    }

    /// Its number of levels as [`orch_metamodel::levels`] counts them: 0 for a
    /// numeric factor.
    pub fn level_count(&self) -> u32 {
        self.levels.len() as u32
    }

    /// The text of level index `natural` of a text factor, `None` for a numeric
    /// factor or an index outside its levels.
    pub fn level_text(&self, natural: f64) -> Option<&str> {
        let index = natural.round();
        (self.is_text() && index >= 0.0)
            .then(|| self.levels.get(index as usize).map(String::as_str))
            .flatten()
    }
}

/// One point of the design: coded and natural coordinates, in factor order.
#[derive(Debug, Clone, PartialEq)]
pub struct DesignPoint {
    /// Coordinates in `[-1, 1]`.
    pub coded: Vec<f64>,
    /// Coordinates in natural units.
    pub natural: Vec<f64>,
    /// Its fidelity level (0 the cheapest, and the only one of a study without
    /// `fidelity:`).
    pub fidelity: u32,
}

impl DesignPoint {
    /// The point at `coded` coordinates of the box `ranges` (one per factor); a text
    /// factor (`levels`, see [`orch_metamodel::levels`]) is put on the level its
    /// coordinate stands for, its natural value that level's index.
    pub fn in_box(coded: Vec<f64>, ranges: &[FactorRange], levels: &[u32]) -> DesignPoint {
        let coded: Vec<f64> = coded
            .iter()
            .enumerate()
            .map(|(i, &c)| match levels.get(i) {
                Some(&count) if count > 0 => coded_level(level_of(c, count), count),
                _ => c,
            })
            .collect();
        DesignPoint {
            natural: coded
                .iter()
                .enumerate()
                .zip(ranges)
                .map(|((i, &c), r)| match levels.get(i) {
                    Some(&count) if count > 0 => level_of(c, count) as f64,
                    _ => r.to_natural(c),
                })
                .collect(),
            coded,
            fidelity: 0,
        }
    }
}

/// The template a study renders: its name in messages (the solver's default path or
/// the user's file) and its text.
pub use orch_adapters::TemplateText as Template;

/// What the rounds optimise: a weighted sum of responses (one term for a single
/// response), or two or more responses traded off on a Pareto front, subject to bounds
/// on responses.
#[derive(Debug, Clone, PartialEq)]
pub struct Objective {
    /// `(response, weight)`; on a Pareto front, the first objective with weight 1
    /// (the response whose value at the compromise point decides convergence).
    pub terms: Vec<(String, f64)>,
    /// Direction; on a Pareto front, the first objective's.
    pub goal: Goal,
    /// `(response, min, max)` bounds at the optimum (at every point of a front).
    pub constraints: Vec<(String, Option<f64>, Option<f64>)>,
    /// `(response, goal)` of each objective traded off on a Pareto front (two or more),
    /// or empty for a single (possibly weighted) objective.
    pub objectives: Vec<(String, Goal)>,
    /// Points asked of the Pareto front (3 to 100); unused without `objectives`.
    pub front_points: usize,
    /// Robust design: `k` of `mean ∓ k·std` under the uncertain factors and tolerances.
    pub robust: Option<f64>,
    /// Per constraint (same order), the probability with which it may be passed under
    /// the uncertain factors and tolerances; `None` for a bound on the value at their
    /// means.
    pub probabilities: Vec<Option<f64>>,
}

/// Points asked of a Pareto front when `front_points:` is not given.
pub const DEFAULT_FRONT_POINTS: usize = 15;

impl Objective {
    /// A name for messages and the store: the response, `0.5*a + 2*b`, or on a Pareto
    /// front the objectives joined, `a vs b`.
    pub fn name(&self) -> String {
        if self.is_pareto() {
            return self
                .objectives
                .iter()
                .map(|(r, _)| r.as_str())
                .collect::<Vec<_>>()
                .join(" vs ");
        }
        match self.terms.as_slice() {
            [(response, weight)] if *weight == 1.0 => response.clone(),
            terms => terms
                .iter()
                .map(|(r, w)| format!("{w}*{r}"))
                .collect::<Vec<_>>()
                .join(" + "),
        }
    }

    /// True when the rounds trade two or more objectives off on a Pareto front.
    pub fn is_pareto(&self) -> bool {
        self.objectives.len() >= 2
    }

    /// Every response the objective needs a surface of.
    pub fn responses(&self) -> Vec<String> {
        let mut names: Vec<String> = if self.is_pareto() {
            self.objectives.iter().map(|(r, _)| r.clone()).collect()
        } else {
            self.terms.iter().map(|(r, _)| r.clone()).collect()
        };
        for (r, _, _) in &self.constraints {
            if !names.contains(r) {
                names.push(r.clone());
            }
        }
        names
    }
}

/// The response surfaces fitted after each round.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MetamodelConfig {
    /// Basis of the polynomials.
    pub basis: BasisKind,
    /// Which surrogate each response gets.
    pub model: ModelChoice,
    /// Kriging's kernel.
    pub kernel: Kernel,
    /// Kriging's trend.
    pub trend: Trend,
    /// Next box half-width over the current one.
    pub shrink: f64,
    /// Relative change of the optimum below which the study stops.
    pub tolerance: f64,
    /// Held-out Latin-hypercube points per round.
    pub test_points: usize,
}

impl MetamodelConfig {
    /// Kriging's settings: the study's kernel and trend, the nugget from replicates
    /// (fitted when there are none), hyperparameter starts seeded by the study.
    pub fn kriging_options(&self, seed: u64) -> KrigingOptions {
        KrigingOptions {
            kernel: self.kernel,
            trend: self.trend,
            seed,
            ..KrigingOptions::default()
        }
    }
}

/// A parameter's allowed range and unit: `(min, max, unit)`.
type ParameterRange = (f64, f64, String);

/// A validated study: everything needed to create and run its jobs.
#[derive(Clone)]
pub struct Study {
    /// Name.
    pub name: String,
    /// What runs for each design point: an equipment on a solver, or the user's own
    /// deck.
    pub simulation: Arc<dyn Simulation>,
    /// Executor settings.
    pub executor: ExecutorConfig,
    /// Design variables in order.
    pub factors: Vec<Factor>,
    /// Template parameters held constant.
    pub fixed: BTreeMap<String, f64>,
    /// Text parameters held constant (a user's own deck).
    pub fixed_text: BTreeMap<String, String>,
    /// Design points.
    pub points: Vec<DesignPoint>,
    /// Runs per point.
    pub replicates: u32,
    /// Base seed.
    pub seed: u64,
    /// Responses of interest.
    pub responses: Vec<String>,
    /// The design of every round.
    pub design: DesignKind,
    /// What the rounds optimise, if anything.
    pub objective: Option<Objective>,
    /// Rounds at most.
    pub rounds: u32,
    /// Fitting and proposal settings.
    pub metamodel: MetamodelConfig,
    /// Uncertain factors, if any.
    pub uncertainty: Option<UncertaintyConfig>,
    /// True when a run without a response the study asks for fails (`missing_response:
    /// fail`); else it succeeds with why in status.
    pub fail_on_missing_response: bool,
    /// What a succeeded job's run directory keeps once its results are stored (`keep:`).
    pub keep: crate::keep::Keep,
    /// True (the default) when a job whose run already succeeded in the project — the
    /// same rendered files, program, seed and cores — takes that run's results instead
    /// of running again; `reuse: false` or `orch submit --no-reuse` runs every job.
    pub reuse: bool,
    /// Stages chained after every design job, in the order of [`orch_adapters::STAGES`].
    pub stages: Vec<StageConfig>,
    /// When a design job is asked to stop before its end time (`stop_when:`).
    pub stop_when: Option<StopWhen>,
    /// The staggered DEM ↔ air iteration after each design job (`coupling:`).
    pub coupling: Option<Coupling>,
    /// Fidelity levels, cheapest first (`fidelity:`); empty for one level.
    pub fidelities: Vec<Fidelity>,
    /// The file's text, kept in the store.
    pub file_text: String,
    /// Files the study names relative to itself (a user's deck's templates and side
    /// files), as `(path as written, bytes)`, kept in the store.
    pub inputs: Vec<(String, Vec<u8>)>,
    /// SHA-256 of the file's text and of its template and inputs, hex: a study
    /// submitted again under its name must be the same in all of them.
    pub file_sha256: String,
}

/// The file whose presence in a run directory asks the solver to end the run as if
/// its end time had come; it holds why, for status.
pub const STOP_FILE: &str = "STOP";

/// What the store kept of a study at submission, used instead of the files on disk
/// when it is validated again (status, resume).
#[derive(Debug, Clone, Default)]
pub struct Stored {
    /// The template (a built-in equipment's; see [`Study::template`]).
    pub template: Option<Template>,
    /// The inputs by path as written in the study.
    pub inputs: BTreeMap<String, Vec<u8>>,
    /// Only reading the study (status, export, report): the check that every design
    /// point can be built and rendered, made when it was submitted and again before it
    /// runs, is left out; it costs a geometry per point (seconds at 10^4 points).
    pub for_reading: bool,
}

impl std::fmt::Debug for Study {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Study")
            .field("name", &self.name)
            .field("simulation", &self.simulation)
            .field("points", &self.points.len())
            .finish_non_exhaustive()
    }
}

impl Study {
    /// Reads and validates the study file at `path`.
    pub fn load(path: &Path) -> Result<Study, StudyError> {
        let text = std::fs::read_to_string(path).map_err(|e| StudyError {
            path: path.to_path_buf(),
            location: None,
            field: "(file)".into(),
            message: format!("cannot read the study file: {e}"),
        })?;
        Study::from_text(path, &text, None)
    }

    /// Validates a study from its text. `path` names the file in errors and anchors
    /// the files it names (`template:`, a custom `case:`'s templates and files);
    /// `stored` replaces reading them from disk (on resume, what was stored at
    /// submission is used). A leading byte order mark is not part of the YAML; a key
    /// given twice in one mapping is refused (serde would keep the last).
    pub fn from_text(path: &Path, text: &str, stored: Option<Stored>) -> Result<Study, StudyError> {
        let yaml = text.strip_prefix('\u{feff}').unwrap_or(text);
        let located = locate::locate(yaml);
        let checker = Checker {
            path,
            locations: located.values,
            stored,
        };
        if let Some(location) = located.second_document {
            return Err(StudyError {
                path: path.to_path_buf(),
                location: Some(location),
                field: "(file)".into(),
                message: "a second YAML document starts here; a study file holds one study: remove it, or put it in a file of its own".into(),
            });
        }
        if let Some((field, location, first_line)) = located.duplicate {
            // A complex key (`? …`) has no field path of its own.
            let field = if field.is_empty() {
                "(file)".to_string()
            } else {
                field
            };
            return Err(StudyError {
                path: path.to_path_buf(),
                location: Some(location),
                field,
                message: format!(
                    "given twice in one mapping (first on line {first_line}); keep one"
                ),
            });
        }
        let file = checker.parse(yaml)?;
        checker.validate(file, text)
    }

    /// Gives the study another name (`orch submit --as`); the error says what a name
    /// may hold.
    pub fn rename(&mut self, name: &str) -> Result<(), String> {
        if !is_study_name(name) {
            return Err(format!("--as: {}", study_name_rule(name)));
        }
        self.name = name.to_string();
        Ok(())
    }

    /// The template the store keeps with the study.
    pub fn template(&self) -> Template {
        self.simulation.template()
    }

    /// Levels of each factor as [`orch_metamodel::levels`] counts them (0 for numeric).
    pub fn levels(&self) -> Vec<u32> {
        self.factors.iter().map(Factor::level_count).collect()
    }

    /// The coded points of design `kind` over the study's factors: the design over the
    /// numeric factors, crossed with every combination of the text factors' levels
    /// (a Latin hypercube instead has its levels stratified over its rows).
    pub fn coded_design(&self, kind: &DesignKind) -> Result<Vec<Vec<f64>>, DesignError> {
        coded_design(kind, &self.levels())
    }

    /// `ranges` with every text factor's range back to all its levels: a next round
    /// narrows numbers around the optimum but keeps trying every level.
    pub fn text_kept_whole(&self, mut ranges: Vec<FactorRange>) -> Vec<FactorRange> {
        for (range, factor) in ranges.iter_mut().zip(&self.factors) {
            if factor.is_text() {
                *range = factor.range;
            }
        }
        ranges
    }

    /// The point at `coded` in the box `ranges` ([`DesignPoint::in_box`]).
    pub fn point(&self, coded: Vec<f64>, ranges: &[FactorRange]) -> DesignPoint {
        DesignPoint::in_box(coded, ranges, &self.levels())
    }

    /// Number of jobs of the first round: (design + test points) × replicates.
    pub fn job_count(&self) -> usize {
        (self.points.len() + self.metamodel.test_points) * self.replicates as usize
    }

    /// Held-out test points of `round` in a box of `ranges`: a maximin Latin hypercube
    /// seeded by the study seed and the round.
    pub fn test_points(&self, round: i64, ranges: &[FactorRange]) -> Vec<DesignPoint> {
        if self.metamodel.test_points == 0 {
            return Vec::new();
        }
        let kind = DesignKind::LatinHypercube {
            samples: self.metamodel.test_points,
            seed: self.seed.wrapping_add(7_919 * (round as u64 + 1)),
            candidates: 50,
        };
        self.coded_design(&kind)
            .unwrap_or_default()
            .into_iter()
            .map(|coded| DesignPoint {
                fidelity: self.top_fidelity(),
                ..self.point(coded, ranges)
            })
            .collect()
    }

    /// The fully resolved case of `point` (at its fidelity level) with the solver
    /// seed `seed`.
    pub fn case(&self, point: &DesignPoint, seed: u64) -> Case {
        self.case_at_level(&point.natural, point.fidelity, seed)
    }

    /// What runs at fidelity level `level`: the level's simulation, or the study's.
    pub fn simulation_at(&self, level: u32) -> &Arc<dyn Simulation> {
        self.fidelities
            .get(level as usize)
            .map_or(&self.simulation, |f| &f.simulation)
    }

    /// The top fidelity level (0 without levels).
    pub fn top_fidelity(&self) -> u32 {
        self.fidelities.len().saturating_sub(1) as u32
    }

    /// The stage of kind `kind`, if the study has it: under `stages:`, or the rerun
    /// of its `coupling:`.
    pub fn stage(&self, kind: &str) -> Option<&StageConfig> {
        let rerun = self.coupling.as_ref().map(|c| &c.rerun);
        self.stages
            .iter()
            .chain(rerun)
            .find(|s| s.stage.kind() == kind)
    }

    /// The stages whose jobs follow a job of kind `kind` (`None`: a design job), whose
    /// [`Stage::upstream_files`] say what that job's run directory must keep.
    pub fn stages_following(&self, kind: Option<&str>) -> Vec<&StageConfig> {
        match kind {
            None => self
                .stages
                .iter()
                .filter(|s| s.stage.follows().is_none())
                .collect(),
            Some(kind) => self
                .coupling
                .iter()
                .flat_map(|c| [(&c.feeder, &c.rerun), (&c.rerun, &c.feeder)])
                .filter(|(before, _)| before.stage.kind() == kind)
                .map(|(_, after)| after)
                .collect(),
        }
    }

    /// The response whose value in each run is the half-width of `response`'s 95 %
    /// interval, when its spec names one (the hopper's `discharge_rate_ci95`).
    pub fn interval_of(&self, response: &str) -> Option<&str> {
        self.response_spec(response)
            .and_then(|spec| spec.interval.as_deref())
    }

    /// The spec of response `name`, when the equipment or a stage declares it.
    fn response_spec(&self, name: &str) -> Option<&orch_adapters::ResponseSpec> {
        let stages = self.stages.iter().flat_map(|s| s.stage.responses());
        self.simulation
            .responses()
            .iter()
            .chain(stages)
            .find(|spec| spec.name == name)
    }

    /// Every response the study's runs can produce: the equipment's, then each stage's.
    pub fn known_responses(&self) -> Vec<&str> {
        known_responses(self.simulation.as_ref(), &self.stages)
    }

    /// The responses shown and fitted: the study's list, or the equipment's headline
    /// responses when it names none.
    pub fn shown_responses(&self) -> Vec<String> {
        if self.responses.is_empty() {
            self.simulation.headline_responses()
        } else {
            self.responses.clone()
        }
    }

    /// The unit of response `name`, when the equipment or a stage declares it.
    pub fn response_unit(&self, name: &str) -> Option<&str> {
        self.response_spec(name).map(|spec| spec.unit.as_ref())
    }

    /// The fully resolved case at natural factor values `natural` (in factor order),
    /// at the first fidelity level.
    pub fn case_at(&self, natural: &[f64], seed: u64) -> Case {
        self.case_at_level(natural, 0, seed)
    }

    /// The fully resolved case at natural factor values `natural` at fidelity level
    /// `level`: the level's parameters over the study's `fixed:`.
    pub fn case_at_level(&self, natural: &[f64], level: u32, seed: u64) -> Case {
        let simulation = self.simulation_at(level);
        let mut parameters = ResolvedParameters::defaults(simulation.parameters());
        let level_fixed = self.fidelities.get(level as usize).map(|f| &f.fixed);
        for (name, value) in self.fixed.iter().chain(level_fixed.into_iter().flatten()) {
            parameters.set(name, *value);
        }
        let mut text = self.fixed_text.clone();
        for (factor, value) in self.factors.iter().zip(natural) {
            match factor.level_text(*value) {
                Some(level) => {
                    text.insert(factor.name.clone(), level.to_string());
                }
                None => parameters.set(&factor.name, *value),
            }
        }
        Case {
            parameters,
            text,
            seed,
        }
    }
}

/// Every response of `simulation` and of `stages`.
fn known_responses<'a>(simulation: &'a dyn Simulation, stages: &'a [StageConfig]) -> Vec<&'a str> {
    let stage_responses = stages.iter().flat_map(|s| s.stage.responses());
    simulation
        .responses()
        .iter()
        .chain(stage_responses)
        .map(|r| r.name.as_ref())
        .collect()
}

/// True for a name that can name folders: letters, digits, `-` and `_`.
fn is_study_name(name: &str) -> bool {
    !name.is_empty()
        && name.len() <= MAX_STUDY_NAME
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
}

/// The field path (`factors[0].max`) and value of the first number in `value` that is
/// not finite (`.inf`, `.nan`, or a literal too large for a float, as `1e400`).
fn first_non_finite(value: &serde_yaml_ng::Value, path: String) -> Option<(String, f64)> {
    use serde_yaml_ng::Value;
    match value {
        Value::Number(n) => n.as_f64().filter(|v| !v.is_finite()).map(|v| (path, v)),
        Value::Sequence(items) => items
            .iter()
            .enumerate()
            .find_map(|(i, item)| first_non_finite(item, format!("{path}[{i}]"))),
        Value::Mapping(map) => map.iter().find_map(|(key, item)| {
            let key = match key {
                Value::String(key) => key.clone(),
                other => serde_yaml_ng::to_string(other)
                    .unwrap_or_default()
                    .trim()
                    .to_string(),
            };
            let path = if path.is_empty() {
                key
            } else {
                format!("{path}.{key}")
            };
            first_non_finite(item, path)
        }),
        Value::Tagged(tagged) => first_non_finite(&tagged.value, path),
        _ => None,
    }
}

/// The longest study name: a name is a folder (`runs/NAME/`) and part of the file names
/// orch derives from it (`reports/NAME-noise.html`, 11 bytes more), and file systems
/// allow 255 bytes per name (Linux's `NAME_MAX`); 200 leaves room for both.
pub const MAX_STUDY_NAME: usize = 200;

/// What a study name may hold, for messages.
fn study_name_rule(name: &str) -> String {
    if name.len() > MAX_STUDY_NAME {
        format!(
            "expected at most {MAX_STUDY_NAME} characters (it names folders and files, and file systems allow 255 bytes per name), got {}",
            name.len()
        )
    } else {
        format!("expected letters, digits, `-` or `_` (it names folders), got `{name}`")
    }
}

/// SHA-256 of the study file's text, plus, when the study has them, its own template
/// and inputs: the same name must mean the same study in all of them.
fn study_hash(
    text: &str,
    simulation: &Arc<dyn Simulation>,
    inputs: &[(String, Vec<u8>)],
) -> String {
    let template = simulation.template();
    let own_template = simulation.accepts_undeclared_parameters() && !template.text.is_empty();
    if inputs.is_empty() && !own_template {
        return format!("{:x}", Sha256::digest(text.as_bytes()));
    }
    let mut hasher = Sha256::new();
    hasher.update(text.as_bytes());
    if own_template {
        hasher.update(b"\0template\0");
        hasher.update(template.text.as_bytes());
    }
    for (path, bytes) in inputs {
        hasher.update(b"\0input\0");
        hasher.update(path.as_bytes());
        hasher.update(b"\0");
        hasher.update(Sha256::digest(bytes));
    }
    format!("{:x}", hasher.finalize())
}

struct Checker<'a> {
    path: &'a Path,
    locations: std::collections::HashMap<String, Location>,
    stored: Option<Stored>,
}

impl Checker<'_> {
    /// A fixed value: a parameter of `specs` within its range. `unknown` says what an
    /// unknown name is (`is not a parameter of …`).
    fn check_value(
        &self,
        field: &str,
        name: &str,
        value: f64,
        specs: &[ParameterSpec],
        unknown: impl Fn() -> String,
    ) -> Result<(), StudyError> {
        let Some(spec) = specs.iter().find(|s| s.name == name) else {
            let names: Vec<&str> = specs.iter().map(|s| s.name.as_ref()).collect();
            return Err(self.error(
                field,
                format!(
                    "`{name}` {}; expected one of: {}",
                    unknown(),
                    names.join(", ")
                ),
            ));
        };
        if !(spec.min..=spec.max).contains(&value) {
            return Err(self.error(
                field,
                format!(
                    "`{name}` must lie within [{}, {}] {}, got {value}",
                    spec.min, spec.max, spec.unit
                ),
            ));
        }
        Ok(())
    }

    fn error(&self, field: &str, message: impl Into<String>) -> StudyError {
        // Point at the field, or at the closest enclosing one that exists.
        let mut probe = field.to_string();
        let location = loop {
            if let Some(location) = self.locations.get(&probe) {
                break Some(*location);
            }
            match probe.rfind(['.', '[']) {
                Some(cut) => probe.truncate(cut),
                None => break None,
            }
        };
        StudyError {
            path: self.path.to_path_buf(),
            location,
            field: field.to_string(),
            message: message.into(),
        }
    }

    fn parse(&self, text: &str) -> Result<StudyFile, StudyError> {
        let deserializer = serde_yaml_ng::Deserializer::from_str(text);
        serde_path_to_error::deserialize(deserializer).map_err(|error| {
            let field = error.path().to_string();
            let inner = error.inner();
            let location = inner.location().map(|l| Location {
                line: l.line(),
                column: l.column(),
            });
            let mut message = inner.to_string();
            if let Some(cut) = message.rfind(" at line ") {
                message.truncate(cut);
            }
            // serde_yaml_ng starts its message with the path of the enclosing value.
            if let Some((prefix, rest)) = message.split_once(": ") {
                if !prefix.contains(' ') && field.starts_with(prefix) {
                    message = rest.to_string();
                }
            }
            // A syntax error inside a value ends in serde_path_to_error's unknown
            // segment `?`; an empty key at the top has an empty path.
            let field = field.trim_end_matches(".?");
            let field = if matches!(field, "." | "" | "?") {
                "(file)".to_string()
            } else {
                field.to_string()
            };
            StudyError {
                path: self.path.to_path_buf(),
                location,
                field,
                message,
            }
        })
    }

    fn validate(&self, file: StudyFile, text: &str) -> Result<Study, StudyError> {
        if !is_study_name(&file.name) {
            return Err(self.error("name", study_name_rule(&file.name)));
        }
        if let Ok(tree) = serde_yaml_ng::from_str::<serde_yaml_ng::Value>(text) {
            if let Some((field, value)) = first_non_finite(&tree, String::new()) {
                return Err(self.error(
                    &field,
                    format!("expected a finite number, got {value}: every value, range and bound of a study must be finite"),
                ));
            }
        }
        let mut inputs = Vec::new();
        let (simulation, deck): (Arc<dyn Simulation>, _) =
            if file.equipment.as_deref() == Some(custom::EQUIPMENT) {
                let deck = Arc::new(self.custom_deck(&file, &mut inputs)?);
                (deck.clone(), Some(deck))
            } else {
                (Arc::new(self.builtin_simulation(&file)?), None)
            };
        let factors = self.factors(&file, simulation.as_ref(), deck.is_some())?;
        let (mut fixed, fixed_text) =
            self.fixed_values(&file, simulation.as_ref(), deck.is_some())?;
        if file.replicates == 0 || file.replicates as usize > MAX_RUNS {
            return Err(self.error(
                "replicates",
                format!(
                    "expected 1 to {MAX_RUNS} replicates, got {}",
                    file.replicates
                ),
            ));
        }
        let (design_kind, points) = self.design_points(&file, &factors)?;
        let fidelities = self.fidelities(&file, &simulation, points.len())?;
        let points = nested_points(points, &fidelities);
        let stages = self.stages(&file, simulation.as_ref(), &mut inputs)?;
        let known_responses = known_responses(simulation.as_ref(), &stages);
        for (i, response) in file.responses.iter().enumerate() {
            if !known_responses.contains(&response.as_str()) {
                return Err(self.error(
                    &format!("responses[{i}]"),
                    format!(
                        "unknown response `{response}`; expected one of: {}",
                        known_responses.join(", ")
                    ),
                ));
            }
        }
        let executor = self.executor(&file.executor, simulation.as_ref())?;
        let objective = match &file.objective {
            None => None,
            Some(objective) => Some(self.objective(objective, &known_responses)?),
        };
        let rounds = file.rounds.unwrap_or(1);
        if rounds == 0 || rounds > 50 {
            return Err(self.error("rounds", format!("expected 1 to 50 rounds, got {rounds}")));
        }
        if rounds > 1 && objective.is_none() {
            return Err(self.error(
                "rounds",
                "more than one round needs an `objective:` to move the box towards",
            ));
        }
        let metamodel = self.metamodel(&file, &design_kind, factors.len(), objective.is_some())?;
        let uncertainty = self.uncertainty_of(&file, simulation.as_ref(), &factors, &mut fixed)?;
        if let Some(objective) = &objective {
            self.objective_has_spread(objective, uncertainty.as_ref())?;
        }
        let coupling = match &file.coupling {
            None => None,
            Some(coupling) => Some(self.coupling(coupling, simulation.as_ref(), &stages)?),
        };
        let stop_when = match file.stop_when {
            None => None,
            Some(stop) => Some(self.stop_when(stop, simulation.as_ref())?),
        };
        let coupled_jobs = coupling.as_ref().map_or(0, |c| 2 * c.iterations as usize);
        self.check_job_count(
            points.len(),
            metamodel.test_points,
            file.replicates,
            stages.len() + coupled_jobs,
            rounds,
        )?;
        let file_sha256 = study_hash(text, &simulation, &inputs);
        let study = Study {
            name: file.name,
            simulation,
            executor,
            factors,
            fixed,
            fixed_text,
            points,
            replicates: file.replicates,
            seed: file.seed,
            responses: file.responses,
            design: design_kind,
            objective,
            rounds,
            metamodel,
            uncertainty,
            stages,
            stop_when,
            coupling,
            fail_on_missing_response: file.missing_response
                == Some(file::MissingResponseFile::Fail),
            keep: file.keep,
            reuse: file.reuse.unwrap_or(true),
            fidelities,
            file_text: text.to_string(),
            inputs,
            file_sha256,
        };
        self.check_points(&study, deck.is_some())?;
        if deck.is_some() {
            self.every_factor_is_used(&study)?;
        }
        self.check_coupled_case(&study)?;
        Ok(study)
    }

    /// `metamodel:` and `next_round:`: the surrogate, its basis, kernel and trend, the
    /// box's shrink and tolerance, and the held-out test points (by default as many as
    /// the design and factor count call for).
    fn metamodel(
        &self,
        file: &StudyFile,
        design_kind: &DesignKind,
        factor_count: usize,
        has_objective: bool,
    ) -> Result<MetamodelConfig, StudyError> {
        let model = match (file.metamodel.model, file.metamodel.order) {
            (None, None) | (Some(ModelFile::Auto), None) => ModelChoice::Auto,
            (Some(ModelFile::Kriging), None) => ModelChoice::Kriging,
            (None | Some(ModelFile::Polynomial), order) => {
                let order = order.unwrap_or(2);
                if !(1..=3).contains(&order) {
                    return Err(self.error(
                        "metamodel.order",
                        format!("expected an order of 1, 2 or 3, got {order}"),
                    ));
                }
                ModelChoice::Polynomial { order }
            }
            (Some(other), Some(_)) => {
                let name = if other == ModelFile::Auto {
                    "auto"
                } else {
                    "kriging"
                };
                return Err(self.error(
                    "metamodel.order",
                    format!("`order` sets the polynomial of `model: polynomial`; `model: {name}` chooses its own (remove `order`, or write `model: polynomial`)"),
                ));
            }
        };
        let shrink = file.next_round.shrink;
        if !(shrink > 0.0 && shrink <= 1.0) {
            return Err(self.error(
                "next_round.shrink",
                format!("expected a fraction in (0, 1], got {shrink}"),
            ));
        }
        if !(file.next_round.tolerance.is_finite() && file.next_round.tolerance >= 0.0) {
            return Err(self.error("next_round.tolerance", "expected a non-negative fraction"));
        }
        let metamodel = MetamodelConfig {
            basis: match file.metamodel.basis {
                BasisFile::Monomial => BasisKind::Monomial,
                BasisFile::Legendre => BasisKind::Legendre,
            },
            model,
            kernel: match file.metamodel.kernel {
                KernelFile::Matern52 => Kernel::Matern52,
                KernelFile::SquaredExponential => Kernel::SquaredExponential,
            },
            trend: match file.metamodel.trend {
                TrendFile::Constant => Trend::Constant,
                TrendFile::Linear => Trend::Linear,
            },
            shrink,
            tolerance: file.next_round.tolerance,
            test_points: file
                .metamodel
                .test_points
                .unwrap_or_else(|| default_test_points(design_kind, factor_count, has_objective)),
        };
        if metamodel.test_points == 1 || metamodel.test_points > 1000 {
            return Err(self.error(
                "metamodel.test_points",
                format!(
                    "expected 0 or 2 to 1000 test points, got {}",
                    metamodel.test_points
                ),
            ));
        }
        Ok(metamodel)
    }

    /// Every design point describes something its solver can build, and a template of
    /// the user's renders at every point (`custom_deck`: the equipment is the user's
    /// own deck). Left out when the study is only read (status, report).
    fn check_points(&self, study: &Study, custom_deck: bool) -> Result<(), StudyError> {
        // Every point must describe something the solver can build; a template of the
        // user's must render at every point, and use every factor.
        let user_templates = study.simulation.accepts_undeclared_parameters();
        let for_reading = self.stored.as_ref().is_some_and(|s| s.for_reading);
        let checked_points = if for_reading {
            &[][..]
        } else {
            &study.points[..]
        };
        for (index, point) in checked_points.iter().enumerate() {
            let case = study.case(point, 0);
            let simulation = study.simulation_at(point.fidelity);
            let checked = simulation.check(&case).and_then(|()| {
                if user_templates {
                    simulation.render_texts(&case).map(drop)
                } else {
                    Ok(())
                }
            });
            if let Err(e) = checked {
                let values: Vec<String> = study
                    .factors
                    .iter()
                    .zip(&point.natural)
                    .map(|(f, v)| format!("{} = {v}", f.name))
                    .collect();
                let field = if custom_deck {
                    "case.templates"
                } else if user_templates {
                    "template"
                } else {
                    "factors"
                };
                return Err(self.error(
                    field,
                    format!(
                        "design point {index} ({}) cannot run: {e}",
                        values.join(", ")
                    ),
                ));
            }
        }
        Ok(())
    }

    /// A `fixed:` number (at field `at`) that `simulation` takes: within its range, or
    /// any name when its template takes undeclared parameters.
    fn fixed_parameter(
        &self,
        at: &str,
        name: &str,
        value: f64,
        simulation: &dyn Simulation,
    ) -> Result<(), StudyError> {
        let specs = simulation.parameters();
        match specs.iter().find(|s| s.name == name) {
            Some(spec) if !(spec.min..=spec.max).contains(&value) => Err(self.error(
                at,
                format!(
                    "`{name}` must lie within [{}, {}] {}, got {value}",
                    spec.min, spec.max, spec.unit
                ),
            )),
            None if !simulation.accepts_undeclared_parameters() => {
                let names: Vec<&str> = specs.iter().map(|s| s.name.as_ref()).collect();
                Err(self.error(
                    at,
                    format!(
                        "`{name}` is not a parameter of the {} equipment on {}; expected one of: {}",
                        simulation.equipment_name(),
                        simulation.solver_name(),
                        names.join(", ")
                    ),
                ))
            }
            _ => Ok(()),
        }
    }

    /// Refuses a study that would run more than [`MAX_RUNS`] jobs over all its rounds:
    /// (design points × (1 + a job per stage kind) + test points) × replicates × rounds.
    fn check_job_count(
        &self,
        design_points: usize,
        test_points: usize,
        replicates: u32,
        stage_kinds: usize,
        rounds: u32,
    ) -> Result<(), StudyError> {
        let stages = 1 + stage_kinds as u128;
        let jobs = (design_points as u128)
            .saturating_mul(stages)
            .saturating_add(test_points as u128)
            .saturating_mul(replicates as u128)
            .saturating_mul(rounds as u128);
        if jobs <= MAX_RUNS as u128 {
            return Ok(());
        }
        let field = if replicates > 1 {
            "replicates"
        } else if rounds > 1 {
            "rounds"
        } else {
            "design"
        };
        let plural = |n: u128, word: &str| format!("{n} {word}{}", if n == 1 { "" } else { "s" });
        let stage = if stage_kinds > 0 {
            format!(" × {stages} jobs (the design job and its stages) of each design point")
        } else {
            String::new()
        };
        Err(self.error(
            field,
            format!(
                "the study would run {jobs} jobs (({} design points + {} test points) × {}{stage} × {}), more than the limit of {MAX_RUNS}; expected fewer replicates, points or rounds",
                design_points,
                test_points,
                plural(replicates as u128, "replicate"),
                plural(rounds as u128, "round"),
            ),
        ))
    }
}

#[cfg(test)]
mod tests;
