//! Study files: parse, then validate into a [`Study`] that the driver can run.
//!
//! Parsing and validation happen before anything is written. Every error names the
//! file, the line and column, the field and what was expected ([`StudyError`]).

mod custom;
mod fidelity;
mod file;
mod locate;

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

use crate::executor::SlurmSettings;
pub use locate::Location;

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

/// How jobs of a study run.
#[derive(Debug, Clone, PartialEq)]
pub struct ExecutorConfig {
    /// Which executor.
    pub kind: ExecutorKind,
    /// Jobs launched and not yet final at once: running locally (`max_parallel`), or
    /// submitted to Slurm (`max_submitted`).
    pub max_parallel: usize,
    /// Wall-time limit per attempt.
    pub time_limit: Option<Duration>,
    /// Extra attempts after a failure.
    pub retries: u32,
    /// Submission settings when `kind` is Slurm.
    pub slurm: Option<SlurmSettings>,
    /// Cores each design job uses (`cores_per_job`; a custom deck's `case.cores`).
    pub cores_per_job: usize,
    /// Cores the running jobs may use together: this machine's
    /// ([`std::thread::available_parallelism`]) for the local executor, so that two
    /// 2-core jobs do not run at once on 2 cores; none on Slurm, which places jobs on
    /// its nodes itself.
    pub core_budget: Option<usize>,
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

/// Monte Carlo at the optimum over uncertain factors.
#[derive(Debug, Clone, PartialEq)]
pub struct UncertaintyConfig {
    /// Samples.
    pub samples: usize,
    /// Seed.
    pub seed: u64,
    /// Factors held at their mean while optimising: `(factor index, distribution in
    /// natural units)`.
    pub parameters: Vec<(usize, Distribution)>,
    /// The design over materials and tolerances run around the optimum, if any.
    pub noise: Option<NoiseDesign>,
}

/// A design over uncertain parameters, run around the optimum after the rounds as a
/// study of its own (`<study>-noise`), whose surrogates carry the distributions to the
/// bounds of the responses there.
#[derive(Debug, Clone, PartialEq)]
pub struct NoiseDesign {
    /// Parameters that are not factors, with their distributions.
    pub materials: Vec<Material>,
    /// Factors with a manufacturing tolerance: `(factor index, standard deviation in
    /// natural units)`, normal around the optimum.
    pub tolerances: Vec<(usize, f64)>,
    /// The design over the materials and tolerances (in that order; default a
    /// central composite with orthogonal α and one centre point, or 5 levels of one).
    pub design: DesignKind,
    /// Standard deviations either side of the mean the design spans.
    pub half_width: f64,
    /// Its runs (points).
    pub runs: usize,
}

/// An uncertain parameter that is not a design factor (a material property).
#[derive(Debug, Clone, PartialEq)]
pub struct Material {
    /// The template parameter.
    pub name: String,
    /// Its distribution in natural units.
    pub distribution: Distribution,
    /// Its unit.
    pub unit: String,
}

/// The range a noise design spans for `distribution`: `mean ± half_width·std` for a
/// normal, the support of a uniform, `exp(mu ± half_width·sigma)` for a log-normal.
pub fn noise_range(distribution: &Distribution, half_width: f64) -> (f64, f64) {
    match *distribution {
        Distribution::Normal { mean, std } => (mean - half_width * std, mean + half_width * std),
        Distribution::Uniform { low, high } => (low, high),
        Distribution::LogNormal { mu, sigma } => (
            (mu - half_width * sigma).exp(),
            (mu + half_width * sigma).exp(),
        ),
    }
}

/// A parameter's allowed range and unit: `(min, max, unit)`.
type ParameterRange = (f64, f64, String);

/// `v` to six significant digits, without trailing zeros.
fn short(v: f64) -> String {
    let text = format!(
        "{:.*}",
        5usize.saturating_sub(v.abs().log10().floor().max(-10.0) as usize),
        v
    );
    let text = if text.contains('.') {
        text.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        text
    };
    if text == "-0" {
        "0".into()
    } else {
        text
    }
}

/// The mean of `distribution`.
pub fn mean_of(distribution: &Distribution) -> f64 {
    match *distribution {
        Distribution::Normal { mean, .. } => mean,
        Distribution::Uniform { low, high } => 0.5 * (low + high),
        Distribution::LogNormal { mu, sigma } => (mu + 0.5 * sigma * sigma).exp(),
    }
}

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

/// `stop_when:`: a running design job is asked to stop cleanly (its run directory
/// gets a [`STOP_FILE`]) once the 95 % interval of `response` is narrower than
/// `relative_ci95` times the response at three checks in a row, each on new output.
#[derive(Debug, Clone, PartialEq)]
pub struct StopWhen {
    /// The response whose interval decides.
    pub response: String,
    /// Its interval half-width: the response the equipment reports beside it.
    pub ci95_response: String,
    /// Relative half-width of the 95 % interval to reach, e.g. 0.03.
    pub relative_ci95: f64,
    /// Time between checks of a running job's output.
    pub check_every: Duration,
}

/// `coupling:`: after each design job and its `cfd` stage, the DEM runs again in the
/// air that stage computed (a job of the stage `air`,
/// [`orch_adapters::dem_in_air`]), then the CFD again on the new stream, until
/// `response` changes by less than `tolerance` (relative) between two DEM runs, or
/// `iterations` DEM runs in air have been made.
#[derive(Debug, Clone)]
pub struct Coupling {
    /// DEM runs in moving air, at most.
    pub iterations: u32,
    /// The DEM response whose change decides.
    pub response: String,
    /// Relative change that ends the iteration.
    pub tolerance: f64,
    /// The stage that runs the design point again in the air of the job before it.
    pub rerun: StageConfig,
    /// The stage of the study that each rerun follows, and that follows each rerun but
    /// the last (`cfd`).
    pub feeder: StageConfig,
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

/// A stage as a study holds it: a built-in kind ([`orch_adapters::STAGES`]), or one the
/// study file configures (a user's script, [`orch_adapters::script_stage`]).
#[derive(Clone)]
pub enum StageRef {
    /// A kind of the registry.
    BuiltIn(&'static dyn Stage),
    /// A kind built from the study file.
    Configured(Arc<dyn Stage>),
}

impl std::ops::Deref for StageRef {
    type Target = dyn Stage;

    fn deref(&self) -> &(dyn Stage + 'static) {
        match self {
            StageRef::BuiltIn(stage) => *stage,
            StageRef::Configured(stage) => stage.as_ref(),
        }
    }
}

/// A stage run after each design job of the study, fed by that job's case and
/// responses.
#[derive(Clone)]
pub struct StageConfig {
    /// The stage.
    pub stage: StageRef,
    /// Its parameters held constant; the rest keep their defaults.
    pub fixed: BTreeMap<String, f64>,
}

impl std::fmt::Debug for StageConfig {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("StageConfig")
            .field("kind", &self.stage.kind())
            .field("fixed", &self.fixed)
            .finish()
    }
}

impl StageConfig {
    /// Cores one of its jobs uses: its `cores` parameter (OpenFOAM's ranks), else 1.
    pub fn cores(&self) -> usize {
        let cores = self.case().get("cores");
        if cores.is_finite() && cores >= 1.0 {
            cores.round() as usize
        } else {
            1
        }
    }

    /// The stage's case: defaults with the fixed values applied.
    pub fn case(&self) -> Case {
        let mut parameters = ResolvedParameters::defaults(self.stage.parameters());
        for (name, value) in &self.fixed {
            parameters.set(name, *value);
        }
        Case {
            parameters,
            seed: 0,
            text: Default::default(),
        }
    }
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
        let stages = self.stages.iter().flat_map(|s| s.stage.responses());
        self.simulation
            .responses()
            .iter()
            .chain(stages)
            .find(|spec| spec.name == response)
            .and_then(|spec| spec.interval.as_deref())
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
        let stages = self.stages.iter().flat_map(|s| s.stage.responses());
        self.simulation
            .responses()
            .iter()
            .chain(stages)
            .find(|r| r.name == name)
            .map(|r| r.unit.as_ref())
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

/// The coded points of design `kind` over factors with `levels` (0 for numeric):
/// see [`Study::coded_design`]. The crossed design's size is checked against
/// [`MAX_RUNS`] before it is built.
pub fn coded_design(kind: &DesignKind, levels: &[u32]) -> Result<Vec<Vec<f64>>, DesignError> {
    use orch_metamodel::levels as text;
    let k = levels.len();
    let numeric = text::numeric_factors(levels, k).len();
    let combinations = text::combination_count(levels);
    if let DesignKind::LatinHypercube { samples, seed, .. } = *kind {
        let rows = if numeric == 0 {
            vec![Vec::new(); samples]
        } else {
            Design::build(kind, numeric)?.points
        };
        return Ok(text::stratify(levels, k, &rows, seed));
    }
    let rows = if numeric == 0 {
        vec![Vec::new()]
    } else {
        let runs = orch_metamodel::run_count(kind, numeric)?;
        let crossed = runs.saturating_mul(combinations);
        if crossed > MAX_RUNS {
            return Err(DesignError::TooManyRuns {
                runs: crossed,
                limit: MAX_RUNS,
            });
        }
        Design::build(kind, numeric)?.points
    };
    Ok(text::cross(levels, k, &rows))
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
    /// The stages: `stages:` by kind, and `cfd:` as shorthand for `stages: {cfd: …}`;
    /// every fixed value a parameter of its stage within its range, and every upstream
    /// response and parameter a stage reads one the equipment has.
    fn stages(
        &self,
        file: &StudyFile,
        simulation: &dyn Simulation,
        inputs: &mut Vec<(String, Vec<u8>)>,
    ) -> Result<Vec<StageConfig>, StudyError> {
        let mut sections: Vec<(String, &file::StageFile)> = file
            .stages
            .iter()
            .map(|(kind, section)| (format!("stages.{kind}"), section))
            .collect();
        if let Some(cfd) = &file.cfd {
            if file.stages.contains_key(orch_adapters::openfoam::KIND) {
                return Err(self.error(
                    "cfd",
                    "the cfd stage is given twice, as `cfd:` and under `stages:`; keep one",
                ));
            }
            sections.push((orch_adapters::openfoam::KIND.to_string(), cfd));
        }
        let mut stages = Vec::new();
        for (at, section) in sections {
            let kind = at.trim_start_matches("stages.");
            let stage = match (&section.case, stage_for(kind)) {
                (Some(case), _) if kind == script_stage::KIND => {
                    let deck = self.deck_of(case, &format!("{at}.case"), inputs)?;
                    StageRef::Configured(Arc::new(script_stage::ScriptStage::new(deck)))
                }
                (None, _) if kind == script_stage::KIND => {
                    return Err(self.error(
                        &at,
                        "the script stage runs your own deck: give it a `case:` with templates, command and responses, as `equipment: custom` takes (see docs/custom-decks.md)",
                    ))
                }
                (Some(_), Some(_)) => {
                    return Err(self.error(
                        &format!("{at}.case"),
                        format!("the {kind} stage is built in and takes no `case:`; only the script stage runs a deck of yours"),
                    ))
                }
                (_, Some(stage)) => StageRef::BuiltIn(stage),
                (_, None) => {
                    let kinds: Vec<&str> = orch_adapters::STAGES
                        .iter()
                        .filter(|s| !s.reruns_design())
                        .map(|s| s.kind())
                        .chain([script_stage::KIND])
                        .collect();
                    return Err(self.error(
                        &at,
                        format!(
                            "unknown stage `{kind}`; expected one of: {}",
                            kinds.join(", ")
                        ),
                    ));
                }
            };
            if let (true, Some(follows)) = (stage.reruns_design(), stage.follows()) {
                return Err(self.error(
                    &at,
                    format!(
                        "the {kind} stage runs the design point again after a `{follows}` job; `coupling:` chains it, so drop it from `stages:` and add `coupling:`"
                    ),
                ));
            }
            for (name, value) in &section.fixed {
                let field = format!("{at}.fixed.{name}");
                self.check_value(&field, name, *value, stage.parameters(), || {
                    format!("is not a parameter of the {kind} stage")
                })?;
            }
            let has_parameter =
                |name: &&str| simulation.parameters().iter().any(|p| p.name == *name);
            let has_response = |name: &&str| simulation.responses().iter().any(|r| r.name == *name);
            let missing = stage
                .upstream_responses()
                .iter()
                .find(|r| !has_response(r))
                .map(|r| format!("response `{r}`"))
                .or_else(|| {
                    stage
                        .upstream_parameters()
                        .iter()
                        .find(|p| !has_parameter(p))
                        .map(|p| format!("parameter `{p}`"))
                });
            if let Some(missing) = missing {
                return Err(self.error(
                    &at,
                    format!(
                        "the {kind} stage reads the {missing} of its upstream job, which the {} equipment does not have",
                        simulation.equipment_name()
                    ),
                ));
            }
            stages.push(StageConfig {
                stage,
                fixed: section.fixed.clone(),
            });
        }
        Ok(stages)
    }

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

    /// `coupling:` checked: the `cfd` stage is there, the response is the DEM's and
    /// the equipment has the air parameters ([`Study::check_coupled_case`] then renders
    /// a design point in moving air).
    fn coupling(
        &self,
        coupling: &file::CouplingFile,
        simulation: &dyn Simulation,
        stages: &[StageConfig],
    ) -> Result<Coupling, StudyError> {
        let rerun: &'static dyn Stage = &orch_adapters::dem_in_air::DemInAir;
        let Some(feeder) = stages
            .iter()
            .find(|s| Some(s.stage.kind()) == rerun.follows())
        else {
            return Err(self.error(
                "coupling",
                "couples the DEM with the air of the `cfd` stage: add `cfd:` (or `stages: {cfd: …}`) to the study",
            ));
        };
        if coupling.iterations == 0 || coupling.iterations > 10 {
            return Err(self.error(
                "coupling.iterations",
                format!(
                    "expected 1 to 10 DEM runs in moving air, got {}",
                    coupling.iterations
                ),
            ));
        }
        if !(coupling.tolerance > 0.0 && coupling.tolerance < 1.0) {
            return Err(self.error(
                "coupling.tolerance",
                format!(
                    "expected a relative change between 0 and 1 (0.01 = 1 %), got {}",
                    coupling.tolerance
                ),
            ));
        }
        // Default: the equipment's first headline response (the hopper's rate).
        let Some(response) = coupling
            .response
            .clone()
            .or_else(|| simulation.headline_responses().into_iter().next())
        else {
            return Err(self.error(
                "coupling.response",
                "expected the DEM response whose change ends the iteration",
            ));
        };
        if !simulation.responses().iter().any(|r| r.name == response) {
            let names: Vec<&str> = simulation
                .responses()
                .iter()
                .map(|r| r.name.as_ref())
                .collect();
            return Err(self.error(
                "coupling.response",
                format!(
                    "expected a response of the DEM run, got `{response}`; expected one of: {}",
                    names.join(", ")
                ),
            ));
        }
        let specs = simulation.parameters();
        if !rerun
            .upstream_parameters()
            .iter()
            .all(|name| specs.iter().any(|s| s.name == *name))
        {
            return Err(self.error(
                "coupling",
                format!(
                    "the {} equipment cannot run in moving air (it has no {} parameters)",
                    simulation.equipment_name(),
                    rerun.upstream_parameters().join(", ")
                ),
            ));
        }
        Ok(Coupling {
            iterations: coupling.iterations,
            response,
            tolerance: coupling.tolerance,
            rerun: StageConfig {
                stage: StageRef::BuiltIn(rerun),
                fixed: BTreeMap::new(),
            },
            feeder: feeder.clone(),
        })
    }

    /// `stop_when:` checked against what the simulation reports.
    fn stop_when(
        &self,
        stop: file::StopWhenFile,
        simulation: &dyn Simulation,
    ) -> Result<StopWhen, StudyError> {
        let interval = simulation
            .responses()
            .iter()
            .find(|r| r.name == stop.response)
            .and_then(|r| r.interval.clone());
        let Some(ci95_response) = interval else {
            let with_interval: Vec<&str> = simulation
                .responses()
                .iter()
                .filter(|r| r.interval.is_some())
                .map(|r| r.name.as_ref())
                .collect();
            return Err(self.error(
                "stop_when.response",
                format!(
                    "expected a response reported with its 95 % interval (`orch params` names each one's), got `{}`; such responses here: {}",
                    stop.response,
                    if with_interval.is_empty() {
                        "none".to_string()
                    } else {
                        with_interval.join(", ")
                    }
                ),
            ));
        };
        if !(stop.ci95_below > 0.0 && stop.ci95_below < 1.0) {
            return Err(self.error(
                "stop_when.ci95_below",
                format!(
                    "expected the relative half-width of the interval, between 0 and 1 (0.03 = ±3 %), got {}",
                    stop.ci95_below
                ),
            ));
        }
        let check_every = stop.check_every.map_or(Duration::from_secs(5), |t| t.0);
        if check_every.is_zero() {
            return Err(self.error("stop_when.check_every", "expected a positive duration"));
        }
        Ok(StopWhen {
            response: stop.response,
            ci95_response: ci95_response.into_owned(),
            relative_ci95: stop.ci95_below,
            check_every,
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
        let specs = simulation.parameters();
        let spec_of = |name: &str| specs.iter().find(|s| s.name == name);
        let known_names = || {
            let names: Vec<&str> = specs.iter().map(|s| s.name.as_ref()).collect();
            names.join(", ")
        };
        let custom_template = simulation.accepts_undeclared_parameters();
        let equipment_name = simulation.equipment_name();

        if file.factors.is_empty() {
            return Err(self.error("factors", "expected at least one factor"));
        }
        let mut factors = Vec::with_capacity(file.factors.len());
        for (i, factor) in file.factors.iter().enumerate() {
            let at = |field: &str| format!("factors[{i}].{field}");
            if file.factors[..i].iter().any(|f| f.name == factor.name) {
                return Err(self.error(
                    &at("name"),
                    format!("factor `{}` is listed twice", factor.name),
                ));
            }
            if file.fixed.contains_key(&factor.name) {
                return Err(self.error(
                    &at("name"),
                    format!(
                        "`{}` is both a factor and fixed; remove it from one of them",
                        factor.name
                    ),
                ));
            }
            if let Some(levels) = &factor.levels {
                factors.push(self.text_factor(
                    i,
                    factor,
                    levels,
                    deck.is_some(),
                    equipment_name,
                )?);
                continue;
            }
            let (Some(min), Some(max)) = (factor.min, factor.max) else {
                return Err(self.error(
                    &at(if factor.min.is_none() { "min" } else { "max" }),
                    format!(
                        "`{}` needs a range (min and max, SI units) or, for text, `levels: [a, b]`",
                        factor.name
                    ),
                ));
            };
            if !(min.is_finite() && max.is_finite()) {
                return Err(self.error(&at("min"), "expected finite numbers for min and max"));
            }
            if !(max - min).is_finite() {
                return Err(self.error(
                    &at("max"),
                    format!(
                        "the range [{:?}, {:?}] is wider than a number can hold (max − min overflows), so its design points would be infinite; give a range in SI units that fits the equipment",
                        min, max
                    ),
                ));
            }
            if min >= max {
                return Err(self.error(
                    &at("max"),
                    format!("expected max greater than min ({}), got {}", min, max),
                ));
            }
            let unit = match spec_of(&factor.name) {
                Some(spec) => {
                    if min < spec.min || max > spec.max {
                        return Err(self.error(
                            &at(if min < spec.min { "min" } else { "max" }),
                            format!(
                                "`{}` must lie within [{}, {}] {}, got [{}, {}]",
                                factor.name, spec.min, spec.max, spec.unit, min, max
                            ),
                        ));
                    }
                    if let Some(unit) = &factor.unit {
                        if *unit != spec.unit {
                            return Err(self.error(
                                &at("unit"),
                                format!("`{}` is in {} (SI), got `{unit}`", factor.name, spec.unit),
                            ));
                        }
                    }
                    spec.unit.to_string()
                }
                None if custom_template => factor.unit.clone().unwrap_or_default(),
                None => {
                    return Err(self.error(
                        &at("name"),
                        format!(
                            "`{}` is not a parameter of the {} equipment; expected one of: {}",
                            factor.name,
                            equipment_name,
                            known_names()
                        ),
                    ))
                }
            };
            factors.push(Factor {
                name: factor.name.clone(),
                range: FactorRange { min, max },
                unit,
                levels: Vec::new(),
            });
        }
        let mut fixed = BTreeMap::new();
        let mut fixed_text = BTreeMap::new();
        for (name, value) in &file.fixed {
            let at = format!("fixed.{name}");
            let value = match value {
                FixedValue::Number(value) if !value.is_finite() => {
                    return Err(self.error(
                        &at,
                        format!("expected a finite number (SI units), got {value}"),
                    ))
                }
                FixedValue::Number(value) => *value,
                FixedValue::Text(text) if deck.is_some() => {
                    fixed_text.insert(name.clone(), text.clone());
                    continue;
                }
                FixedValue::Text(text) => {
                    return Err(self.error(
                        &at,
                        format!("expected a number (SI units), got `{text}`; text values are for a custom case"),
                    ))
                }
            };
            self.fixed_parameter(&at, name, value, simulation.as_ref())?;
            fixed.insert(name.clone(), value);
        }
        if file.replicates == 0 || file.replicates as usize > MAX_RUNS {
            return Err(self.error(
                "replicates",
                format!(
                    "expected 1 to {MAX_RUNS} replicates, got {}",
                    file.replicates
                ),
            ));
        }
        let design_kind = self.design_kind("design", &file.design, file.seed)?;
        let levels: Vec<u32> = factors.iter().map(Factor::level_count).collect();
        let design =
            coded_design(&design_kind, &levels).map_err(|e| self.error("design", e.to_string()))?;
        let limits: Vec<FactorRange> = factors.iter().map(|f| f.range).collect();
        let points: Vec<DesignPoint> = design
            .into_iter()
            .map(|coded| DesignPoint::in_box(coded, &limits, &levels))
            .collect();
        for (index, point) in points.iter().enumerate() {
            if let Some((factor, value)) = factors
                .iter()
                .zip(&point.natural)
                .find(|(_, v)| !v.is_finite())
            {
                return Err(self.error(
                    "design",
                    format!(
                        "design point {index} puts `{}` at {value}; every design value must be a finite number: narrow the factor's range",
                        factor.name
                    ),
                ));
            }
        }
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
            Some(objective) => {
                let known = |field: &str, name: &str| {
                    if known_responses.contains(&name) {
                        Ok(())
                    } else {
                        Err(self.error(
                            field,
                            format!(
                                "unknown response `{name}`; expected one of: {}",
                                known_responses.join(", ")
                            ),
                        ))
                    }
                };
                let goal_of = |goal: GoalFile| match goal {
                    GoalFile::Minimise => Goal::Minimise,
                    GoalFile::Maximise => Goal::Maximise,
                };
                let mut objectives = Vec::new();
                let mut front_points = DEFAULT_FRONT_POINTS;
                let (terms, goal) = if let Some(listed) = &objective.objectives {
                    for (field, given) in [
                        ("response", objective.response.is_some()),
                        ("weights", objective.weights.is_some()),
                        ("goal", objective.goal.is_some()),
                    ] {
                        if given {
                            return Err(self.error(
                                &format!("objective.{field}"),
                                format!("`objectives:` gives each response its own goal and takes no `{field}:`; remove `{field}:`, or `objectives:` to optimise one response"),
                            ));
                        }
                    }
                    if listed.len() < 2 {
                        return Err(self.error(
                            "objective.objectives",
                            format!("expected two or more objectives for a Pareto front, got {}; for one write `response:` and `goal:` instead", listed.len()),
                        ));
                    }
                    for (i, term) in listed.iter().enumerate() {
                        let at = format!("objective.objectives[{i}].response");
                        known(&at, &term.response)?;
                        if listed[..i].iter().any(|t| t.response == term.response) {
                            return Err(self.error(
                                &at,
                                format!("`{}` is listed twice; a Pareto front needs different responses", term.response),
                            ));
                        }
                        objectives.push((term.response.clone(), goal_of(term.goal)));
                    }
                    if let Some(n) = objective.front_points {
                        if !(3..=100).contains(&n) {
                            return Err(self.error(
                                "objective.front_points",
                                format!("expected 3 to 100 points on the Pareto front, got {n}"),
                            ));
                        }
                        front_points = n;
                    }
                    let (first, goal) = objectives[0].clone();
                    (vec![(first, 1.0)], goal)
                } else {
                    if objective.front_points.is_some() {
                        return Err(self.error(
                            "objective.front_points",
                            "only a Pareto front has points; list two or more `objectives:` or remove `front_points:`",
                        ));
                    }
                    let terms = match (&objective.response, &objective.weights) {
                        (Some(response), None) => {
                            known("objective.response", response)?;
                            vec![(response.clone(), 1.0)]
                        }
                        (None, Some(weights)) if !weights.is_empty() => {
                            for (name, weight) in weights {
                                known(&format!("objective.weights.{name}"), name)?;
                                if !weight.is_finite() {
                                    return Err(self.error(&format!("objective.weights.{name}"), "expected a finite weight"));
                                }
                            }
                            weights.iter().map(|(n, w)| (n.clone(), *w)).collect()
                        }
                        _ => return Err(self.error("objective", "expected either `response:` or `weights:` (a map of response to weight), not both")),
                    };
                    let Some(goal) = objective.goal else {
                        return Err(self.error(
                            "objective",
                            "missing field `goal`; add `goal: maximise` or `goal: minimise`",
                        ));
                    };
                    (terms, goal_of(goal))
                };
                let mut constraints = Vec::new();
                let mut probabilities = Vec::new();
                for (i, c) in objective.constraints.iter().enumerate() {
                    let at = format!("objective.constraints[{i}]");
                    known(&format!("{at}.response"), &c.response)?;
                    if c.min.is_none() && c.max.is_none() {
                        return Err(self.error(&at, "expected `min:`, `max:` or both"));
                    }
                    if let Some(p) = c.probability {
                        if !(p > 0.0 && p <= 0.5) {
                            return Err(self.error(
                                &format!("{at}.probability"),
                                format!("expected a probability of passing the bound in (0, 0.5], got {p}"),
                            ));
                        }
                        if c.min.is_some() && c.max.is_some() {
                            return Err(self.error(
                                &format!("{at}.probability"),
                                "a probabilistic bound takes `min:` or `max:`, not both; write two constraints",
                            ));
                        }
                    }
                    constraints.push((c.response.clone(), c.min, c.max));
                    probabilities.push(c.probability);
                }
                let robust = match &objective.robust {
                    Some(r) if !(r.k.is_finite() && r.k > 0.0 && r.k <= 6.0) => {
                        return Err(self.error(
                            "objective.robust.k",
                            format!(
                                "expected a number of standard deviations in (0, 6], got {}",
                                r.k
                            ),
                        ))
                    }
                    Some(_) if !objectives.is_empty() => return Err(self.error(
                        "objective.robust",
                        "a Pareto front is not made robust; remove `robust:` or list one objective",
                    )),
                    Some(r) => Some(r.k),
                    None => None,
                };
                Some(Objective {
                    terms,
                    goal,
                    constraints,
                    objectives,
                    front_points,
                    robust,
                    probabilities,
                })
            }
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
            test_points: file.metamodel.test_points.unwrap_or_else(|| {
                default_test_points(&design_kind, factors.len(), objective.is_some())
            }),
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
        let uncertainty = match &file.uncertainty {
            None => None,
            Some(u) => {
                let known = |name: &str| -> Option<ParameterRange> {
                    match spec_of(name) {
                        Some(spec) => Some((spec.min, spec.max, spec.unit.to_string())),
                        None if custom_template => {
                            Some((f64::NEG_INFINITY, f64::INFINITY, String::new()))
                        }
                        None => None,
                    }
                };
                let config = self.uncertainty(u, &factors, &known, &file.fixed, file.seed)?;
                // Materials are rendered at their mean while the design is optimised.
                for material in config.noise.iter().flat_map(|n| &n.materials) {
                    fixed.insert(material.name.clone(), mean_of(&material.distribution));
                }
                Some(config)
            }
        };
        if let Some(objective) = &objective {
            let spread = uncertainty.as_ref().is_some_and(|u| {
                !u.parameters.is_empty()
                    || u.noise.as_ref().is_some_and(|n| !n.tolerances.is_empty())
            });
            let probabilistic = objective.probabilities.iter().position(Option::is_some);
            let field = match (objective.robust.is_some(), probabilistic) {
                (true, _) => Some("objective.robust".to_string()),
                (false, Some(i)) => Some(format!("objective.constraints[{i}].probability")),
                (false, None) => None,
            };
            if let Some(field) = field.filter(|_| !spread) {
                return Err(self.error(
                    &field,
                    "needs a spread to be robust against: an uncertain factor (with `mean:`) or a factor's tolerance (`std:` only) in `uncertainty.parameters` (materials that are not factors are outside the surfaces; their noise design runs after the rounds)",
                ));
            }
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
                let field = if deck.is_some() {
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
        if deck.is_some() {
            self.every_factor_is_used(&study)?;
        }
        self.check_coupled_case(&study)?;
        Ok(study)
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

    /// With `coupling:`, the simulation must run the first design point in the CFD
    /// stage's air (`air_field` = 1): its checks pass and its template renders.
    fn check_coupled_case(&self, study: &Study) -> Result<(), StudyError> {
        let (Some(_), Some(point)) = (&study.coupling, study.points.first()) else {
            return Ok(());
        };
        let moving = orch_adapters::dem_in_air::in_moving_air(
            &study.case(point, 0),
            &orch_adapters::dem_in_air::AirProperties::default(),
        );
        let simulation = &study.simulation;
        simulation
            .check(&moving)
            .and_then(|()| simulation.render_texts(&moving).map(drop))
            .map_err(|e| {
                self.error(
                    "coupling",
                    format!(
                        "the {} solver cannot run the DEM in the CFD stage's air: {e}",
                        simulation.solver_name()
                    ),
                )
            })
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

    fn uncertainty(
        &self,
        file: &file::UncertaintyFile,
        factors: &[Factor],
        known: &dyn Fn(&str) -> Option<ParameterRange>,
        fixed: &BTreeMap<String, FixedValue>,
        study_seed: u64,
    ) -> Result<UncertaintyConfig, StudyError> {
        if file.samples < 100 {
            return Err(self.error(
                "uncertainty.samples",
                format!("expected at least 100 samples, got {}", file.samples),
            ));
        }
        if file.samples > MAX_UNCERTAINTY_SAMPLES {
            return Err(self.error(
                "uncertainty.samples",
                format!(
                    "expected at most {MAX_UNCERTAINTY_SAMPLES} samples (10^7), got {}",
                    file.samples
                ),
            ));
        }
        let half_width = file.noise_design.as_ref().map_or(3.0, |n| n.half_width);
        if !(half_width.is_finite() && half_width > 0.0 && half_width <= 10.0) {
            return Err(self.error(
                "uncertainty.noise_design.half_width",
                format!("expected a number of standard deviations in (0, 10], got {half_width}"),
            ));
        }
        let mut parameters = Vec::new();
        let mut materials = Vec::new();
        let mut tolerances = Vec::new();
        for (i, p) in file.parameters.iter().enumerate() {
            let at = |field: &str| format!("uncertainty.parameters[{i}].{field}");
            if file.parameters[..i].iter().any(|q| q.name == p.name) {
                return Err(self.error(&at("name"), format!("`{}` is listed twice", p.name)));
            }
            let factor = factors.iter().position(|f| f.name == p.name);
            if let Some(text) = factor.map(|i| &factors[i]).filter(|f| f.is_text()) {
                return Err(self.error(
                    &at("name"),
                    format!(
                        "`{}` is a text factor ({}): it has no spread of numbers to be uncertain in; remove it from `uncertainty.parameters`",
                        text.name,
                        text.levels.join(", ")
                    ),
                ));
            }
            // A factor with a normal spread and no mean: a tolerance around the optimum.
            if let (Some(index), DistributionFile::Normal, None) = (factor, p.distribution, p.mean)
            {
                let std = p.std.ok_or_else(|| {
                    self.error(
                        &at("std"),
                        "a tolerance (a factor without `mean:`) needs `std:`",
                    )
                })?;
                if !(std.is_finite() && std > 0.0) {
                    return Err(self.error(
                        &at("std"),
                        format!("std must be positive and finite, got {std}"),
                    ));
                }
                tolerances.push((index, std));
                continue;
            }
            let need = |value: Option<f64>, field: &str| {
                value.ok_or_else(|| {
                    self.error(
                        &at(field),
                        format!("a {:?} distribution needs `{field}:`", p.distribution)
                            .to_lowercase(),
                    )
                })
            };
            let distribution = match p.distribution {
                DistributionFile::Normal => Distribution::Normal {
                    mean: need(p.mean, "mean")?,
                    std: need(p.std, "std")?,
                },
                DistributionFile::Uniform => Distribution::Uniform {
                    low: need(p.low, "low")?,
                    high: need(p.high, "high")?,
                },
                DistributionFile::Lognormal => Distribution::LogNormal {
                    mu: need(p.mu, "mu")?,
                    sigma: need(p.sigma, "sigma")?,
                },
            };
            orch_metamodel::propagate(&|x| x[0], &[distribution], 2, 0).map_err(|e| {
                self.error(
                    &at("distribution"),
                    e.to_string().trim_start_matches("input 0: ").to_string(),
                )
            })?;
            if let Some(index) = factor {
                parameters.push((index, distribution));
                continue;
            }
            // Not a factor: a material the noise design varies around the optimum.
            let Some((min, max, unit)) = known(&p.name) else {
                return Err(self.error(
                    &at("name"),
                    format!("`{}` is neither a factor nor a parameter of the equipment; name a factor (held at its mean while optimising, or with `std:` only, a tolerance) or a parameter (varied by the noise design around the optimum)", p.name),
                ));
            };
            if fixed.contains_key(&p.name) {
                return Err(self.error(
                    &at("name"),
                    format!("`{}` is both fixed and uncertain; remove it from `fixed:` (its mean is its value while the design is optimised)", p.name),
                ));
            }
            let (low, high) = noise_range(&distribution, half_width);
            if low < min || high > max {
                return Err(self.error(
                    &at("name"),
                    format!(
                        "the noise design would run `{}` over [{}, {}]{}, outside its range [{min}, {max}]; narrow the distribution or `noise_design.half_width`",
                        p.name,
                        short(low),
                        short(high),
                        if unit.is_empty() || unit == "-" { String::new() } else { format!(" {unit}") }
                    ),
                ));
            }
            materials.push(Material {
                name: p.name.clone(),
                distribution,
                unit,
            });
        }
        if file.parameters.is_empty() {
            return Err(self.error(
                "uncertainty.parameters",
                "expected at least one uncertain parameter",
            ));
        }
        let noise = if materials.is_empty() && tolerances.is_empty() {
            if file.noise_design.is_some() {
                return Err(self.error(
                    "uncertainty.noise_design",
                    "a noise design varies parameters that are not factors, or factors' tolerances (`std:` without `mean:`); the study has neither",
                ));
            }
            None
        } else {
            let at = "uncertainty.noise_design.design";
            let design = match file.noise_design.as_ref().and_then(|n| n.design.as_ref()) {
                Some(design) => self.design_kind(at, design, study_seed)?,
                None if materials.len() + tolerances.len() == 1 => {
                    DesignKind::FullFactorial { levels: 5 }
                }
                None => DesignKind::CentralComposite {
                    alpha: CentralCompositeAlpha::Orthogonal,
                    center_points: 1,
                },
            };
            let dimensions = materials.len() + tolerances.len();
            let runs = Design::build(&design, dimensions)
                .map_err(|e| {
                    self.error(
                        at,
                        format!("{e} (over the {dimensions} uncertain parameters)"),
                    )
                })?
                .len();
            Some(NoiseDesign {
                materials,
                tolerances,
                design,
                half_width,
                runs,
            })
        };
        Ok(UncertaintyConfig {
            samples: file.samples,
            seed: file.seed,
            parameters,
            noise,
        })
    }

    /// A design's centre points (default 1), at most [`MAX_RUNS`].
    fn center_points(&self, at: &str, design: &DesignFile) -> Result<usize, StudyError> {
        let centre = design.center_points.unwrap_or(1);
        if centre > MAX_RUNS {
            return Err(self.error(
                &format!("{at}.center_points"),
                format!("expected at most {MAX_RUNS} centre points, got {centre}"),
            ));
        }
        Ok(centre)
    }

    /// Factor `index` of the file, a text factor with `levels`: at least two distinct,
    /// non-empty values, no range and no unit, and only for a user's own deck
    /// (`own_deck`), whose templates take text.
    fn text_factor(
        &self,
        index: usize,
        factor: &file::FactorFile,
        levels: &[FixedValue],
        own_deck: bool,
        equipment_name: &str,
    ) -> Result<Factor, StudyError> {
        let at = |field: &str| format!("factors[{index}].{field}");
        if !own_deck {
            return Err(self.error(
                &at("levels"),
                format!(
                    "`{}` is a text factor, and the {equipment_name} equipment takes numbers only; text factors are for your own deck (`equipment: custom`). Give min and max instead",
                    factor.name
                ),
            ));
        }
        if factor.min.is_some() || factor.max.is_some() {
            return Err(self.error(
                &at(if factor.min.is_some() { "min" } else { "max" }),
                format!(
                    "`{}` has levels and a range; a factor is either text (`levels:`) or a number (min and max): remove one",
                    factor.name
                ),
            ));
        }
        if factor.unit.is_some() {
            return Err(self.error(
                &at("unit"),
                format!(
                    "`{}` is a text factor and has no unit; remove `unit:`",
                    factor.name
                ),
            ));
        }
        let texts: Vec<String> = levels
            .iter()
            .map(|level| match level {
                FixedValue::Text(text) => text.clone(),
                FixedValue::Number(number) => format!("{number}"),
            })
            .collect();
        if texts.len() < 2 {
            return Err(self.error(
                &at("levels"),
                format!(
                    "`{}` has {} level; a text factor needs at least two (a single value belongs in `fixed:`)",
                    factor.name,
                    texts.len()
                ),
            ));
        }
        for (i, text) in texts.iter().enumerate() {
            if text.trim().is_empty() {
                return Err(self.error(
                    &format!("factors[{index}].levels[{i}]"),
                    "expected a non-empty value",
                ));
            }
            if texts[..i].contains(text) {
                return Err(self.error(
                    &format!("factors[{index}].levels[{i}]"),
                    format!("`{text}` is listed twice; each level must differ"),
                ));
            }
        }
        Ok(Factor {
            name: factor.name.clone(),
            range: FactorRange {
                min: 0.0,
                max: (texts.len() - 1) as f64,
            },
            unit: String::new(),
            levels: texts,
        })
    }

    /// The design `design` describes; `at` is its field path (`design`, or a noise
    /// design's) for errors.
    fn design_kind(
        &self,
        at: &str,
        design: &DesignFile,
        study_seed: u64,
    ) -> Result<DesignKind, StudyError> {
        let refuse = |field: &str, present: bool, kind: &str| {
            if present {
                Err(self.error(
                    &format!("{at}.{field}"),
                    format!("`{field}` does not apply to a {kind} design"),
                ))
            } else {
                Ok(())
            }
        };
        Ok(match design.kind {
            DesignType::FullFactorial => {
                refuse("alpha", design.alpha.is_some(), "full_factorial")?;
                refuse(
                    "center_points",
                    design.center_points.is_some(),
                    "full_factorial",
                )?;
                refuse("samples", design.samples.is_some(), "full_factorial")?;
                refuse("seed", design.seed.is_some(), "full_factorial")?;
                DesignKind::FullFactorial {
                    levels: design.levels.unwrap_or(3),
                }
            }
            DesignType::CentralComposite => {
                refuse("levels", design.levels.is_some(), "central_composite")?;
                refuse("samples", design.samples.is_some(), "central_composite")?;
                refuse("seed", design.seed.is_some(), "central_composite")?;
                DesignKind::CentralComposite {
                    alpha: match design.alpha.unwrap_or(AlphaFile::Orthogonal) {
                        AlphaFile::Orthogonal => CentralCompositeAlpha::Orthogonal,
                        AlphaFile::Rotatable => CentralCompositeAlpha::Rotatable,
                        AlphaFile::FaceCentred => CentralCompositeAlpha::FaceCentred,
                    },
                    center_points: self.center_points(at, design)?,
                }
            }
            DesignType::BoxBehnken => {
                refuse("levels", design.levels.is_some(), "box_behnken")?;
                refuse("alpha", design.alpha.is_some(), "box_behnken")?;
                refuse("samples", design.samples.is_some(), "box_behnken")?;
                refuse("seed", design.seed.is_some(), "box_behnken")?;
                DesignKind::BoxBehnken {
                    center_points: self.center_points(at, design)?,
                }
            }
            DesignType::LatinHypercube => {
                refuse("levels", design.levels.is_some(), "latin_hypercube")?;
                refuse("alpha", design.alpha.is_some(), "latin_hypercube")?;
                refuse(
                    "center_points",
                    design.center_points.is_some(),
                    "latin_hypercube",
                )?;
                let samples = design.samples.ok_or_else(|| {
                    self.error(
                        at,
                        "a latin_hypercube design needs `samples:` (number of runs)",
                    )
                })?;
                DesignKind::LatinHypercube {
                    samples,
                    seed: design.seed.unwrap_or(study_seed),
                    candidates: 50,
                }
            }
        })
    }

    fn executor(
        &self,
        executor: &ExecutorFile,
        simulation: &dyn Simulation,
    ) -> Result<ExecutorConfig, StudyError> {
        let cores = std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(1);
        let per_job = simulation.command().cores.max(1);
        if let Some(limit) = executor.time_limit {
            if limit.0.is_zero() {
                return Err(self.error("executor.time_limit", "expected a positive duration"));
            }
        }
        if executor.retries > 100 {
            return Err(self.error(
                "executor.retries",
                format!("expected at most 100, got {}", executor.retries),
            ));
        }
        let (max_parallel, slurm) = match executor.kind {
            ExecutorKind::Local => {
                self.refuse_slurm_fields(executor)?;
                let max_parallel = match executor.max_parallel {
                    Some(0) => {
                        return Err(self.error("executor.max_parallel", "expected at least 1"))
                    }
                    Some(n) => n,
                    None => (cores / per_job).max(1),
                };
                (max_parallel, None)
            }
            ExecutorKind::Slurm => {
                if executor.max_parallel.is_some() {
                    return Err(self.error(
                        "executor.max_parallel",
                        "Slurm decides how many jobs run at once; use max_submitted to limit the jobs orch keeps in its queue",
                    ));
                }
                let max_submitted = match executor.max_submitted {
                    Some(0) => {
                        return Err(self.error("executor.max_submitted", "expected at least 1"))
                    }
                    Some(n) => n,
                    None => crate::executor::slurm::DEFAULT_MAX_SUBMITTED,
                };
                (max_submitted, Some(self.slurm_settings(executor)?))
            }
        };
        Ok(ExecutorConfig {
            kind: executor.kind,
            max_parallel,
            time_limit: executor.time_limit.map(|t| t.0),
            retries: executor.retries,
            slurm,
            cores_per_job: per_job,
            core_budget: (executor.kind == ExecutorKind::Local).then_some(cores),
        })
    }

    /// A local study naming Slurm options is a mistake worth telling.
    fn refuse_slurm_fields(&self, executor: &ExecutorFile) -> Result<(), StudyError> {
        let given = [
            ("partition", executor.partition.is_some()),
            ("cpus_per_task", executor.cpus_per_task.is_some()),
            ("mem", executor.mem.is_some()),
            ("account", executor.account.is_some()),
            ("qos", executor.qos.is_some()),
            ("extra_sbatch", !executor.extra_sbatch.is_empty()),
            ("max_submitted", executor.max_submitted.is_some()),
            ("poll_interval", executor.poll_interval.is_some()),
            ("array_size", executor.array_size.is_some()),
        ];
        match given.iter().find(|(_, set)| *set) {
            Some((name, _)) => Err(self.error(
                &format!("executor.{name}"),
                "is a Slurm option; add `kind: slurm` to the executor, or remove it",
            )),
            None => Ok(()),
        }
    }

    fn slurm_settings(&self, executor: &ExecutorFile) -> Result<SlurmSettings, StudyError> {
        // A value goes into an `#SBATCH --name=value` line: one word, no line breaks.
        let word = |name: &str, value: &Option<String>| -> Result<Option<String>, StudyError> {
            match value {
                Some(v) if v.is_empty() || v.chars().any(|c| c.is_whitespace() || c == '\'') => {
                    Err(self.error(
                        &format!("executor.{name}"),
                        format!("expected one word without spaces or quotes, got {v:?}"),
                    ))
                }
                other => Ok(other.clone()),
            }
        };
        let mem = word("mem", &executor.mem)?;
        if let Some(mem) = &mem {
            let digits = mem.trim_end_matches(['K', 'M', 'G', 'T']);
            if digits.is_empty()
                || !digits.chars().all(|c| c.is_ascii_digit())
                || mem.len() - digits.len() > 1
            {
                return Err(self.error(
                    "executor.mem",
                    format!("expected a size as sbatch writes it (4000, 500M, 2G), got {mem:?}"),
                ));
            }
        }
        if executor.cpus_per_task == Some(0) {
            return Err(self.error("executor.cpus_per_task", "expected at least 1"));
        }
        if executor.array_size == Some(0) {
            return Err(self.error(
                "executor.array_size",
                "expected at least 1 (1 submits each job with an sbatch of its own)",
            ));
        }
        for (i, option) in executor.extra_sbatch.iter().enumerate() {
            if !option.starts_with("--") || option.contains('\n') || option.len() < 3 {
                return Err(self.error(
                    &format!("executor.extra_sbatch[{i}]"),
                    format!(
                        "expected one sbatch option such as `--constraint=avx2`, got {option:?}"
                    ),
                ));
            }
        }
        let poll_interval = executor
            .poll_interval
            .map_or(crate::executor::slurm::DEFAULT_POLL_INTERVAL, |t| t.0);
        if poll_interval < Duration::from_millis(200) {
            return Err(self.error(
                "executor.poll_interval",
                "expected at least 200ms: every poll is a call to slurmctld",
            ));
        }
        Ok(SlurmSettings {
            partition: word("partition", &executor.partition)?,
            cpus_per_task: executor.cpus_per_task,
            mem,
            account: word("account", &executor.account)?,
            qos: word("qos", &executor.qos)?,
            extra_sbatch: executor.extra_sbatch.clone(),
            time_limit: executor.time_limit.map(|t| t.0),
            poll_interval,
            array_size: executor.array_size,
        })
    }
}

/// Held-out test points a study gets when it names none: on a full-factorial grid with
/// an objective, `k + 2` off-grid points (at least 4), because on a grid leave-one-out
/// can be exactly zero while the surface is wrong between the grid lines; none
/// otherwise.
pub fn default_test_points(design: &DesignKind, n_factors: usize, has_objective: bool) -> usize {
    match design {
        DesignKind::FullFactorial { .. } if has_objective => (n_factors + 2).max(4),
        _ => 0,
    }
}

#[cfg(test)]
mod tests;
