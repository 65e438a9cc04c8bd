//! The study file as written: serde types that mirror the YAML one to one.
//!
//! These types are only a parse target. [`super::Study`] is what the rest of `orch`
//! uses, built by [`super::Study::from_text`] after every check has passed.

use std::collections::BTreeMap;
use std::fmt;
use std::time::Duration;

use serde::de::{self, Deserializer, Visitor};
use serde::Deserialize;

/// A study file. Unknown keys are refused.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StudyFile {
    /// Study name, used in paths and commands: letters, digits, `-` and `_`.
    pub name: String,
    /// Free text.
    #[serde(default)]
    pub description: Option<String>,
    /// What is simulated (`hopper`, the default).
    #[serde(default)]
    pub equipment: Option<String>,
    /// Solver name (`liggghts`); not with `equipment: custom`, whose `case:` names
    /// its command.
    #[serde(default)]
    pub solver: Option<String>,
    /// A Tera template of the user's, relative to the study file; default per solver.
    #[serde(default)]
    pub template: Option<String>,
    /// Where and how jobs run.
    #[serde(default)]
    pub executor: ExecutorFile,
    /// Design variables.
    pub factors: Vec<FactorFile>,
    /// Template parameters held constant, by name, SI units; a user's own deck may
    /// also take text.
    #[serde(default)]
    pub fixed: BTreeMap<String, FixedValue>,
    /// The design of experiments.
    pub design: DesignFile,
    /// Runs per design point, each with its own seed.
    #[serde(default = "one")]
    pub replicates: u32,
    /// Base seed; job seeds derive from it, the point and the replicate.
    #[serde(default)]
    pub seed: u64,
    /// Responses the study is about; every response is stored, these are shown.
    #[serde(default)]
    pub responses: Vec<String>,
    /// The response to optimise; needed for more than one round.
    #[serde(default)]
    pub objective: Option<ObjectiveFile>,
    /// Rounds of design, fit and proposal (default 1).
    #[serde(default)]
    pub rounds: Option<u32>,
    /// The response surfaces fitted after each round.
    #[serde(default)]
    pub metamodel: MetamodelFile,
    /// How the next round's box is chosen and when to stop.
    #[serde(default)]
    pub next_round: NextRoundFile,
    /// Uncertain parameters propagated by Monte Carlo at the optimum.
    #[serde(default)]
    pub uncertainty: Option<UncertaintyFile>,
    /// Stages run after each design job, by kind (`stages: {cfd: {fixed: …}}`).
    #[serde(default)]
    pub stages: BTreeMap<String, StageFile>,
    /// Shorthand for `stages: {cfd: …}`: the OpenFOAM stage of the air the particle
    /// stream drags.
    #[serde(default)]
    pub cfd: Option<StageFile>,
    /// What a run that succeeded but lacks a response the study asks for counts as:
    /// `record` (default: succeeded, with why in status) or `fail`.
    #[serde(default)]
    pub missing_response: Option<MissingResponseFile>,
    /// A user's own deck (`equipment: custom`): templates, files, command, responses.
    #[serde(default)]
    pub case: Option<CaseFile>,
    /// Ends each run once a response is known well enough (`stop_when: {response:
    /// discharge_rate, ci95_below: 0.03}`).
    #[serde(default)]
    pub stop_when: Option<StopWhenFile>,
    /// Runs the DEM again in the air the CFD stage computed, and the CFD again on
    /// that stream, until a response settles (`coupling: {iterations: 3, response:
    /// discharge_rate, tolerance: 0.01}`); needs the `cfd` stage.
    #[serde(default)]
    pub coupling: Option<CouplingFile>,
    /// What a succeeded job's run directory keeps once its results are stored: `all`
    /// (default), `results` (no particle dumps or VTK files) or `none` (a small
    /// record); failed jobs keep everything.
    #[serde(default)]
    pub keep: crate::keep::Keep,
    /// Whether a job whose run already succeeded in the project (the same rendered
    /// files, program, seed and cores) takes that run's results instead of running
    /// again (default `true`).
    #[serde(default)]
    pub reuse: Option<bool>,
    /// Fidelity levels, cheapest first: each design point runs at the first, nested
    /// subsets of them at the next ones, and every response is fitted by co-Kriging
    /// over the levels.
    #[serde(default)]
    pub fidelity: Vec<FidelityFile>,
}

/// One fidelity level (`fidelity: [{name: coarse, cost: 1}, {name: fine, cost: 8,
/// runs: 5, fixed: {n_particles: 4000}}]`).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FidelityFile {
    /// Its name: letters, digits, `-` and `_`.
    pub name: String,
    /// Its solver, when not the study's (built-in equipment only).
    #[serde(default)]
    pub solver: Option<String>,
    /// Cost of one run, in any unit the levels share (core-seconds, say); rising
    /// from level to level.
    pub cost: f64,
    /// How many of the level below's design points also run here (every level but
    /// the first).
    #[serde(default)]
    pub runs: Option<usize>,
    /// Template parameters set at this level, over the study's `fixed:`.
    #[serde(default)]
    pub fixed: BTreeMap<String, FixedValue>,
}

/// `coupling:` of a study: the staggered DEM ↔ air iteration.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CouplingFile {
    /// DEM runs in moving air after the first, still-air one, at most.
    pub iterations: u32,
    /// The DEM response whose change decides (default: the equipment's first
    /// headline response, the hopper's discharge rate).
    #[serde(default)]
    pub response: Option<String>,
    /// Relative change of that response between two DEM runs that ends the iteration.
    pub tolerance: f64,
}

/// `stop_when:` of a study: a run is asked to stop cleanly once the 95 % confidence
/// interval of `response` (its `<response>_ci95` half-width) is narrower than
/// `ci95_below` times the response, at three checks in a row, each on new output.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StopWhenFile {
    /// The response whose interval decides; the equipment must report
    /// `<response>_ci95`.
    pub response: String,
    /// Relative half-width of the 95 % interval below which the run stops (0.03 =
    /// ±3 %).
    pub ci95_below: f64,
    /// Time between checks of a running job's output (default 5 s).
    #[serde(default)]
    pub check_every: Option<TimeLimit>,
}

/// `missing_response:` of a study.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MissingResponseFile {
    /// The job succeeded; status shows which response is missing and why.
    Record,
    /// The job fails with why.
    Fail,
}

/// A fixed value: a number (SI units) or, for a user's own deck, a word or text.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(untagged)]
pub enum FixedValue {
    /// A number.
    Number(f64),
    /// Text.
    Text(String),
}

/// The `case:` section of `equipment: custom`: the user's own deck.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CaseFile {
    /// Tera templates, relative to the study file, each rendered into every run under
    /// its file name without `.tera`.
    pub templates: Vec<String>,
    /// Files or folders copied unchanged into every run under their path relative to
    /// the study file's folder (`meshes/chute.stl` lands as `meshes/chute.stl`; a
    /// folder is copied whole): meshes, includes, restart files.
    #[serde(default)]
    pub files: Vec<String>,
    /// Folders the deck writes into, made before it starts (besides those of the
    /// responses' files, which are always made): `[post, dumps]`.
    #[serde(default)]
    pub folders: Vec<String>,
    /// The command, one word per element (`[liggghts, -in, in.chute]`); a word may use
    /// `{{ cores }}`.
    pub command: Vec<String>,
    /// Cores the command uses (default 1).
    #[serde(default)]
    pub cores: Option<usize>,
    /// The program's log in the run directory (default: its standard output).
    #[serde(default)]
    pub log: Option<String>,
    /// Declared parameters: default, unit, range, description.
    #[serde(default)]
    pub parameters: BTreeMap<String, DeclaredParameterFile>,
    /// The responses read from each finished run.
    pub responses: Vec<DeclaredResponseFile>,
}

/// A declared parameter of a user's own deck.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DeclaredParameterFile {
    /// Value when a study neither fixes nor varies it.
    pub default: f64,
    /// Unit.
    #[serde(default)]
    pub unit: Option<String>,
    /// Smallest allowed value.
    #[serde(default)]
    pub min: Option<f64>,
    /// Largest allowed value.
    #[serde(default)]
    pub max: Option<f64>,
    /// What it is.
    #[serde(default)]
    pub description: Option<String>,
}

/// A column of a table file, by header name or 1-based number.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(untagged)]
pub enum ColumnFile {
    /// Its number, 1 = the first column.
    Number(usize),
    /// Its name in the header.
    Name(String),
}

/// A declared response: one source (`table:`, `regex:` or `json:`), a reduction and a
/// window.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DeclaredResponseFile {
    /// Its name in `responses:`, `objective:` and the store.
    pub name: String,
    /// Another declared response that holds the half-width of this one's 95 %
    /// interval in each run (for `stop_when:` and the fit's noise).
    #[serde(default)]
    pub interval: Option<String>,
    /// Its unit.
    #[serde(default)]
    pub unit: Option<String>,
    /// A table file (whitespace or CSV; `#` comments; header names columns).
    #[serde(default)]
    pub table: Option<String>,
    /// The table's value column.
    #[serde(default)]
    pub column: Option<ColumnFile>,
    /// The table's time column (default 1).
    #[serde(default)]
    pub time_column: Option<ColumnFile>,
    /// A regular expression whose first group is the number, over `file:` (default:
    /// the log).
    #[serde(default)]
    pub regex: Option<String>,
    /// A JSON file, with `key:`.
    #[serde(default)]
    pub json: Option<String>,
    /// A legacy VTK file (`dump mesh/vtk`, `dump custom/vtk`), with `field:`.
    #[serde(default)]
    pub vtk: Option<String>,
    /// The point or cell field of a `vtk:` file.
    #[serde(default)]
    pub field: Option<String>,
    /// Where a `vtk:` field is: `point` or `cell` (default: whichever has it).
    #[serde(default)]
    pub at: Option<String>,
    /// The component (from 0) of a `vtk:` field of several (default: its magnitude).
    #[serde(default)]
    pub component: Option<usize>,
    /// The file a `regex:` reads.
    #[serde(default)]
    pub file: Option<String>,
    /// The dotted key path in a `json:` file.
    #[serde(default)]
    pub key: Option<String>,
    /// last (default), first, mean, min, max, sum, count, slope, integral or std.
    #[serde(default)]
    pub reduce: Option<String>,
    /// Window start, in the time column's units.
    #[serde(default)]
    pub from: Option<f64>,
    /// Window end.
    #[serde(default)]
    pub to: Option<f64>,
    /// Which files of a glob are read: last (default, natural order), newest or all.
    #[serde(default)]
    pub pick: Option<String>,
}

/// A stage's section: its parameters held constant, and for a user's script stage its
/// deck.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StageFile {
    /// Stage parameters by name, SI units (`orch params` lists them).
    #[serde(default)]
    pub fixed: BTreeMap<String, f64>,
    /// The `script` stage's deck: templates, files, command and responses, as a custom
    /// case's `case:` (its templates also see `upstream_dir` and `upstream_<name>`).
    #[serde(default)]
    pub case: Option<CaseFile>,
}

/// Minimise or maximise.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GoalFile {
    /// Smallest value.
    #[serde(alias = "minimize")]
    Minimise,
    /// Largest value.
    #[serde(alias = "maximize")]
    Maximise,
}

/// The `objective:` section: one response, a weighted sum of responses, or two or more
/// responses traded off on a Pareto front, optionally subject to bounds on other
/// responses.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectiveFile {
    /// A single response to optimise.
    #[serde(default)]
    pub response: Option<String>,
    /// Or a weighted sum of responses, `{name: weight}`.
    #[serde(default)]
    pub weights: Option<BTreeMap<String, f64>>,
    /// Direction of `response:` or `weights:`; not with `objectives:`.
    #[serde(default)]
    pub goal: Option<GoalFile>,
    /// Or two or more responses, each with its own goal, traded off on a Pareto front.
    #[serde(default)]
    pub objectives: Option<Vec<ObjectiveTermFile>>,
    /// Points asked of the Pareto front of `objectives:` (default 15, 3 to 100).
    #[serde(default)]
    pub front_points: Option<usize>,
    /// Bounds on other responses' surfaces.
    #[serde(default)]
    pub constraints: Vec<ConstraintFile>,
    /// Robust design: optimise `mean ∓ k·std` of the objective under the uncertain
    /// factors and tolerances instead of its value at their means.
    #[serde(default)]
    pub robust: Option<RobustFile>,
}

/// The `objective.robust:` section.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobustFile {
    /// Standard deviations taken off the mean (maximise) or added to it (minimise).
    pub k: f64,
}

/// One entry of `objectives:`: a response and its goal.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectiveTermFile {
    /// Response name.
    pub response: String,
    /// Direction.
    pub goal: GoalFile,
}

/// A bound on a response at the optimum.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConstraintFile {
    /// Response name.
    pub response: String,
    /// Smallest allowed value.
    #[serde(default)]
    pub min: Option<f64>,
    /// Largest allowed value.
    #[serde(default)]
    pub max: Option<f64>,
    /// A probabilistic bound: the response may pass `min`/`max` with at most this
    /// probability under the uncertain factors and tolerances.
    #[serde(default)]
    pub probability: Option<f64>,
}

/// Polynomial bases.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BasisFile {
    /// Powers of the coded factors.
    Monomial,
    /// Legendre polynomials of the coded factors.
    #[default]
    Legendre,
}

/// Which surrogate each response gets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ModelFile {
    /// The best of pruned polynomials of order 1–3 and Kriging by leave-one-out RMSE.
    Auto,
    /// The complete polynomial of `order`.
    Polynomial,
    /// Kriging.
    Kriging,
}

/// Kriging's correlation kernels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum KernelFile {
    /// Matérn with ν = 5/2: twice differentiable, the usual choice for physics.
    #[default]
    Matern52,
    /// Squared exponential: infinitely smooth.
    SquaredExponential,
}

/// Kriging's trends.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TrendFile {
    /// A constant mean (ordinary Kriging).
    #[default]
    Constant,
    /// A mean linear in the factors (universal Kriging).
    Linear,
}

/// The `metamodel:` section.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MetamodelFile {
    /// Basis (default legendre).
    #[serde(default)]
    pub basis: BasisFile,
    /// Surrogate: `auto`, `polynomial` or `kriging` (default `auto`, or `polynomial`
    /// when `order` is given).
    #[serde(default)]
    pub model: Option<ModelFile>,
    /// Total polynomial order, 1 to 3, of `model: polynomial` (default 2).
    #[serde(default)]
    pub order: Option<u32>,
    /// Kriging's kernel (default `matern52`).
    #[serde(default)]
    pub kernel: KernelFile,
    /// Kriging's trend (default `constant`).
    #[serde(default)]
    pub trend: TrendFile,
    /// Extra Latin-hypercube points per round, run but left out of the fit, to
    /// measure prediction error (default 0; `k + 2`, at least 4, on a full-factorial
    /// grid with an objective).
    #[serde(default)]
    pub test_points: Option<usize>,
}

impl Default for MetamodelFile {
    fn default() -> Self {
        MetamodelFile {
            basis: BasisFile::Legendre,
            model: None,
            order: None,
            kernel: KernelFile::default(),
            trend: TrendFile::default(),
            test_points: None,
        }
    }
}

/// The `next_round:` section.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NextRoundFile {
    /// Each half-width of the next box is this fraction of the current one (default 0.5).
    #[serde(default = "half")]
    pub shrink: f64,
    /// Stop when the predicted optimum changes by less than this fraction (default 0.01).
    #[serde(default = "one_percent")]
    pub tolerance: f64,
}

impl Default for NextRoundFile {
    fn default() -> Self {
        NextRoundFile {
            shrink: 0.5,
            tolerance: 0.01,
        }
    }
}

fn half() -> f64 {
    0.5
}

fn one_percent() -> f64 {
    0.01
}

/// The `uncertainty:` section.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UncertaintyFile {
    /// Monte Carlo samples (default 100000).
    #[serde(default = "hundred_thousand")]
    pub samples: usize,
    /// Seed of the sampler.
    #[serde(default)]
    pub seed: u64,
    /// The uncertain parameters: factors held at their mean while optimising (with
    /// `mean`), factors with a manufacturing tolerance (normal, `std` only), and
    /// parameters that are not factors (materials), which the noise design varies.
    pub parameters: Vec<UncertainParameterFile>,
    /// The design run around the optimum after the rounds over the materials and
    /// tolerances (default: central composite, orthogonal α, one centre point, on
    /// ±3 standard deviations).
    #[serde(default)]
    pub noise_design: Option<NoiseDesignFile>,
}

/// The `uncertainty.noise_design:` section.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoiseDesignFile {
    /// The design (as `design:`; default central composite, orthogonal α, one centre).
    #[serde(default)]
    pub design: Option<DesignFile>,
    /// How many standard deviations either side of the mean it spans (default 3).
    #[serde(default = "three")]
    pub half_width: f64,
}

fn three() -> f64 {
    3.0
}

fn hundred_thousand() -> usize {
    100_000
}

/// Distribution families.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DistributionFile {
    /// Needs `mean`, `std`.
    Normal,
    /// Needs `low`, `high`.
    Uniform,
    /// Needs `mu`, `sigma` (of the logarithm).
    Lognormal,
}

/// One uncertain parameter.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UncertainParameterFile {
    /// A factor's or a template parameter's name.
    pub name: String,
    /// Distribution family.
    pub distribution: DistributionFile,
    /// Normal: mean.
    #[serde(default)]
    pub mean: Option<f64>,
    /// Normal: standard deviation.
    #[serde(default)]
    pub std: Option<f64>,
    /// Uniform: lower end.
    #[serde(default)]
    pub low: Option<f64>,
    /// Uniform: upper end.
    #[serde(default)]
    pub high: Option<f64>,
    /// Log-normal: mean of the logarithm.
    #[serde(default)]
    pub mu: Option<f64>,
    /// Log-normal: standard deviation of the logarithm.
    #[serde(default)]
    pub sigma: Option<f64>,
}

fn one() -> u32 {
    1
}

/// Executor kinds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ExecutorKind {
    /// Processes on this machine.
    #[default]
    Local,
    /// Batch jobs on a Slurm cluster (`sbatch`, `squeue`, `scancel`).
    Slurm,
}

/// The `executor:` section.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExecutorFile {
    /// Which executor.
    #[serde(default)]
    pub kind: ExecutorKind,
    /// Jobs running at once; default: cores divided by the cores a job uses. Locally,
    /// jobs also start only while their cores fit in the machine's.
    #[serde(default)]
    pub max_parallel: Option<usize>,
    /// Cores each DEM job uses (default 1): the native kernel's and YADE's threads,
    /// LIGGGHTS's MPI ranks. A user's own deck sets its cores with `case.cores`.
    #[serde(default)]
    pub cores_per_job: Option<usize>,
    /// Wall-time limit per job attempt: seconds, or text such as `90s`, `10min`, `2h`.
    #[serde(default)]
    pub time_limit: Option<TimeLimit>,
    /// Extra attempts for a job that failed.
    #[serde(default)]
    pub retries: u32,
    /// Slurm: the partition (default: the cluster's default partition).
    #[serde(default)]
    pub partition: Option<String>,
    /// Slurm: CPUs per job (default: the cores the solver's command asks for).
    #[serde(default)]
    pub cpus_per_task: Option<u32>,
    /// Slurm: memory per node, as sbatch writes it (`4000`, `500M`, `2G`).
    #[serde(default)]
    pub mem: Option<String>,
    /// Slurm: the account to charge.
    #[serde(default)]
    pub account: Option<String>,
    /// Slurm: the quality of service.
    #[serde(default)]
    pub qos: Option<String>,
    /// Slurm: further `#SBATCH` options, each one `--option[=value]`.
    #[serde(default)]
    pub extra_sbatch: Vec<String>,
    /// Slurm: jobs submitted and not yet final at once (default 500).
    #[serde(default)]
    pub max_submitted: Option<usize>,
    /// Slurm: how often `squeue` is asked about the jobs (default 5 s; one call for all).
    #[serde(default)]
    pub poll_interval: Option<TimeLimit>,
    /// Slurm: most jobs per job array, one `sbatch` each (default 1000, at most the
    /// cluster's `MaxArraySize`); 1 submits every job with an `sbatch` of its own.
    #[serde(default)]
    pub array_size: Option<usize>,
}

/// A duration written as seconds or as humantime text.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TimeLimit(pub Duration);

impl<'de> Deserialize<'de> for TimeLimit {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct TimeLimitVisitor;
        impl Visitor<'_> for TimeLimitVisitor {
            type Value = TimeLimit;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str(
                    "a positive number of seconds or a duration such as `90s`, `10min`, `2h`",
                )
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<TimeLimit, E> {
                Ok(TimeLimit(Duration::from_secs(v)))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<TimeLimit, E> {
                u64::try_from(v)
                    .map(|v| TimeLimit(Duration::from_secs(v)))
                    .map_err(|_| E::invalid_value(de::Unexpected::Signed(v), &self))
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<TimeLimit, E> {
                Duration::try_from_secs_f64(v)
                    .map(TimeLimit)
                    .map_err(|_| E::invalid_value(de::Unexpected::Float(v), &self))
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<TimeLimit, E> {
                humantime::parse_duration(v)
                    .map(TimeLimit)
                    .map_err(|_| E::invalid_value(de::Unexpected::Str(v), &self))
            }
        }
        deserializer.deserialize_any(TimeLimitVisitor)
    }
}

/// One design variable.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FactorFile {
    /// Template parameter it sets.
    pub name: String,
    /// Lower bound, natural units (a numeric factor).
    #[serde(default)]
    pub min: Option<f64>,
    /// Upper bound, natural units (a numeric factor).
    #[serde(default)]
    pub max: Option<f64>,
    /// The values of a text factor, in the order the study lists them (`[hertz,
    /// hooke]`); a user's own deck's templates see the chosen one as text.
    #[serde(default)]
    pub levels: Option<Vec<FixedValue>>,
    /// Unit, for reports; checked against the parameter's unit when given.
    #[serde(default)]
    pub unit: Option<String>,
}

/// Design types.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DesignType {
    /// Every combination of levels.
    FullFactorial,
    /// Central composite.
    CentralComposite,
    /// Box-Behnken.
    BoxBehnken,
    /// Latin hypercube.
    LatinHypercube,
}

/// Central composite alpha choices.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum AlphaFile {
    /// Orthogonal.
    Orthogonal,
    /// Rotatable.
    Rotatable,
    /// Face-centred.
    #[serde(alias = "face_centered")]
    FaceCentred,
}

/// The `design:` section; which fields apply depends on `type`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DesignFile {
    /// Design type.
    #[serde(rename = "type")]
    pub kind: DesignType,
    /// Full factorial: levels per factor (default 3).
    #[serde(default)]
    pub levels: Option<usize>,
    /// Central composite: how alpha is chosen (default orthogonal).
    #[serde(default)]
    pub alpha: Option<AlphaFile>,
    /// Central composite and Box-Behnken: centre runs (default 1).
    #[serde(default)]
    pub center_points: Option<usize>,
    /// Latin hypercube: number of runs.
    #[serde(default)]
    pub samples: Option<usize>,
    /// Latin hypercube: seed (default the study seed).
    #[serde(default)]
    pub seed: Option<u64>,
}
