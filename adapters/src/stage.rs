//! Stages: a job that runs after another and takes its upstream job's case, responses
//! and files as inputs: OpenFOAM after DEM ([`crate::openfoam`]), or the design
//! point's DEM again in the air OpenFOAM computed ([`crate::dem_in_air`]).
//!
//! The orchestrator knows stages only through [`Stage`]: it creates one job per stage
//! after each design job (and, with `coupling:`, a chain of them), launches it once its
//! upstream job succeeded, renders it from [`Upstream`], and stores what
//! [`Stage::results`] returns. To add a stage kind: implement [`Stage`] in its own
//! module and list it in [`STAGES`]; a study turns it on with a section named after
//! [`Stage::kind`] under `stages:`.

use std::collections::BTreeMap;
use std::path::Path;

use crate::{
    Case, CommandSpec, ParameterSpec, ParseError, RenderError, ResponseSpec, RunResults, Simulation,
};

/// What a stage reads of the job it follows.
#[derive(Debug, Clone, Copy)]
pub struct Upstream<'a> {
    /// The design point's resolved case, with the upstream job's seed.
    pub case: &'a Case,
    /// The upstream job's stored responses by name.
    pub responses: &'a BTreeMap<String, f64>,
    /// The upstream job's run directory (its files, as `keep:` left them: a stage
    /// that reads files of the job before it needs at least `results`).
    pub run_dir: &'a Path,
    /// The upstream job's own parameters when it is a stage's job, `None` for a design
    /// job.
    pub stage_case: Option<&'a Case>,
    /// What runs the design point (a stage that runs it again uses it).
    pub simulation: &'a dyn Simulation,
}

/// Why a stage cannot be rendered.
#[derive(Debug, thiserror::Error)]
pub enum StageError {
    /// The upstream job lacks a response the stage reads.
    #[error("its upstream job has no `{0}` response")]
    MissingResponse(&'static str),
    /// Rendering failed.
    #[error("cannot render the stage: {0}")]
    Render(#[from] RenderError),
    /// The stage must follow a job of another stage and does not.
    #[error("an `{kind}` job runs after a `{follows}` job, and this one follows none")]
    NotAfterStage {
        /// This stage's kind.
        kind: &'static str,
        /// The kind it must follow.
        follows: &'static str,
    },
    /// What the upstream job left in its run directory cannot be used.
    #[error("its upstream job's files: {0}")]
    UpstreamFiles(String),
}

/// A job kind that follows another job.
pub trait Stage: Send + Sync {
    /// Name in study files (`stages: {cfd: …}`) and in the store (`jobs.stage`); the
    /// stage's jobs are named `<upstream job>-<kind>`.
    fn kind(&self) -> &'static str;

    /// One line on what it does, for `orch params` and dry runs.
    fn description(&self) -> &'static str;

    /// Its parameters (set under the study's `fixed:` of the stage).
    fn parameters(&self) -> &[ParameterSpec];

    /// The responses it produces.
    fn responses(&self) -> &[ResponseSpec];

    /// Upstream responses it reads; a study whose equipment lacks one is refused.
    fn upstream_responses(&self) -> &'static [&'static str];

    /// Upstream case parameters it reads; a study whose equipment lacks one is refused.
    fn upstream_parameters(&self) -> &'static [&'static str];

    /// Programs that must be on PATH to run it.
    fn programs(&self) -> Vec<&str>;

    /// How a user installs them.
    fn install_hint(&self) -> &'static str;

    /// The stage's log in its run directory; `None`: the design's simulation's log
    /// (a stage that runs the design point again).
    fn log_file(&self) -> Option<&str>;

    /// Writes the stage's input for `case` (its parameters, with the job's seed) fed
    /// by `upstream` into `run_dir`, and returns the command that runs it.
    fn render(
        &self,
        case: &Case,
        upstream: &Upstream<'_>,
        run_dir: &Path,
    ) -> Result<CommandSpec, StageError>;

    /// Reads a finished run's responses and series; `case` and `upstream` are those it
    /// was rendered with.
    fn results(
        &self,
        case: &Case,
        upstream: &Upstream<'_>,
        run_dir: &Path,
    ) -> Result<RunResults, ParseError>;

    /// True when the stage runs the design point's simulation again, in conditions a
    /// stage before it computed: its jobs take the design job's cores and random
    /// stream (the same particles, so that a change is the conditions'), it is chained
    /// by `coupling:` rather than listed under `stages:`, and a later run of it in a
    /// chain replaces the design run (or the one before) in fits.
    fn reruns_design(&self) -> bool {
        false
    }

    /// The stage kind whose job this one must follow (`None`: the design job).
    fn follows(&self) -> Option<&'static str> {
        None
    }

    /// What it reads of the upstream job's run directory, which that job must keep
    /// until this one has run.
    fn upstream_files(&self) -> UpstreamFiles {
        UpstreamFiles::None
    }
}

/// What a stage reads of the files its upstream job left in its run directory.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum UpstreamFiles {
    /// Nothing: only the upstream job's case and stored responses.
    None,
    /// What the upstream's parsers read (logs, probes, tables), not particle snapshots.
    Results,
    /// Anything, snapshots included (a user's script).
    Everything,
}

/// Every stage kind `orch` knows.
pub static STAGES: &[&dyn Stage] = &[&crate::openfoam::StreamAir, &crate::dem_in_air::DemInAir];

/// The stage of kind `kind`, or `None`.
pub fn stage_for(kind: &str) -> Option<&'static dyn Stage> {
    STAGES.iter().copied().find(|s| s.kind() == kind)
}

/// Kinds of every stage, for messages.
pub fn stage_kinds() -> Vec<&'static str> {
    STAGES.iter().map(|s| s.kind()).collect()
}
