//! Stages: a job that runs after another and takes its upstream job's case and
//! responses as inputs (OpenFOAM after DEM; later a user's post-processing script, or
//! a second DEM pass with an air field).
//!
//! The orchestrator knows stages only through [`Stage`]: it creates one job per stage
//! after each design job, launches it once its upstream job succeeded, renders it from
//! [`Upstream`], and stores what [`Stage::results`] returns. To add a stage kind:
//! implement [`Stage`] in its own module and list it in [`STAGES`]; a study turns it on
//! with a section named after [`Stage::kind`] under `stages:`.

use std::collections::BTreeMap;
use std::path::Path;

use crate::{Case, CommandSpec, ParameterSpec, ParseError, RenderError, ResponseSpec, RunResults};

/// What a stage reads of the job it follows.
#[derive(Debug, Clone, Copy)]
pub struct Upstream<'a> {
    /// The upstream job's resolved case.
    pub case: &'a Case,
    /// The upstream job's stored responses by name.
    pub responses: &'a BTreeMap<String, f64>,
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
}

/// A job kind that follows another job.
pub trait Stage: Send + Sync {
    /// Name in study files (`stages: {cfd: …}`) and in the store (`jobs.stage`); the
    /// stage's jobs are named `<upstream job>-<kind>`.
    fn kind(&self) -> &'static str;

    /// One line on what it does, for `orch params` and dry runs.
    fn description(&self) -> &'static str;

    /// Its parameters (set under the study's `fixed:` of the stage).
    fn parameters(&self) -> &'static [ParameterSpec];

    /// The responses it produces.
    fn responses(&self) -> &'static [ResponseSpec];

    /// Upstream responses it reads; a study whose equipment lacks one is refused.
    fn upstream_responses(&self) -> &'static [&'static str];

    /// Upstream case parameters it reads; a study whose equipment lacks one is refused.
    fn upstream_parameters(&self) -> &'static [&'static str];

    /// Programs that must be on PATH to run it.
    fn programs(&self) -> &'static [&'static str];

    /// How a user installs them.
    fn install_hint(&self) -> &'static str;

    /// The stage's log in its run directory.
    fn log_file(&self) -> &'static str;

    /// Writes the stage's input for `case` fed by `upstream` into `run_dir`, and
    /// returns the command that runs it.
    fn render(
        &self,
        case: &Case,
        upstream: &Upstream<'_>,
        run_dir: &Path,
    ) -> Result<CommandSpec, StageError>;

    /// Reads a finished run's responses and series.
    fn results(&self, run_dir: &Path) -> Result<RunResults, ParseError>;
}

/// Every stage kind `orch` knows.
pub static STAGES: &[&dyn Stage] = &[&crate::openfoam::StreamAir];

/// The stage of kind `kind`, or `None`.
pub fn stage_for(kind: &str) -> Option<&'static dyn Stage> {
    STAGES.iter().copied().find(|s| s.kind() == kind)
}

/// Kinds of every stage, for messages.
pub fn stage_kinds() -> Vec<&'static str> {
    STAGES.iter().map(|s| s.kind()).collect()
}
