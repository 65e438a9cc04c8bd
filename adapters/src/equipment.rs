//! Equipment: *what* is simulated (a hopper, a transfer chute, or a user's own deck).
//!
//! An equipment owns everything that does not depend on the program that simulates it:
//! its parameters (names, SI units, ranges, docs), the checks a case must pass, the
//! values its templates see, the geometry files written beside each deck, where its
//! sensor plane is, and the responses it computes from what a solver observed (names,
//! units, docs). Nothing outside an equipment's module knows its response names: the
//! orchestrator asks [`Equipment::responses`] and [`Equipment::headline_responses`].
//!
//! To add an equipment: implement [`Equipment`] in its own module, list it in
//! [`EQUIPMENT`], and give each solver that can simulate it a template
//! ([`crate::DemSolver::templates`]).

use std::borrow::Cow;
use std::path::Path;

use tera::Context;

use crate::{Case, Observations, ParameterSpec, RenderError, RunResults};

/// A named scalar response (or a series) an equipment or stage computes, for
/// validation, `orch params` and reports.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ResponseSpec {
    /// Name used in study files (`responses:`, `objective:`) and in the store.
    pub name: Cow<'static, str>,
    /// SI unit (`kg/s`, `m`, `-`).
    pub unit: Cow<'static, str>,
    /// What it measures.
    pub description: Cow<'static, str>,
    /// A series' abscissa with its unit, `t [s]` for a time series (`r [m]` for a
    /// radial density); unused by a scalar response.
    pub over: Cow<'static, str>,
    /// The response each run reports the half-width of this one's 95 % interval in
    /// (the hopper's `discharge_rate` → `discharge_rate_ci95`), when it has one: what
    /// `stop_when:` watches and what tells Kriging a run's noise.
    pub interval: Option<Cow<'static, str>>,
}

/// The horizontal plane below or beside the equipment where particles are watched:
/// every crossing of it is an observation ([`Observations::crossings`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorPlane {
    /// Height of the plane, m (z up).
    pub height_m: f64,
}

/// What is simulated: parameters, checks, template context, geometry and responses.
pub trait Equipment: Send + Sync {
    /// Name used in study files (`equipment: hopper`) and template file names.
    fn name(&self) -> &'static str;

    /// One line on what it is, for `orch params`.
    fn description(&self) -> &'static str;

    /// The parameters its templates understand, with defaults and ranges.
    fn parameters(&self) -> &'static [ParameterSpec];

    /// Every scalar response [`Equipment::results`] can produce.
    fn responses(&self) -> &'static [ResponseSpec];

    /// Every series [`Equipment::results`] stores (besides the solver's own).
    fn series(&self) -> &'static [ResponseSpec];

    /// The responses shown and fitted when a study names none.
    fn headline_responses(&self) -> &'static [&'static str];

    /// Checks a resolved case beyond per-parameter ranges (e.g. that the geometry can
    /// be built); the error names the parameters.
    fn check(&self, case: &Case) -> Result<(), RenderError>;

    /// Every value a template sees: the parameters plus what follows from them.
    fn context(&self, case: &Case) -> Context;

    /// Writes the geometry files (meshes) a deck reads into `run_dir`, and the folders
    /// the solver writes into.
    fn write_geometry(&self, case: &Case, run_dir: &Path) -> Result<(), RenderError>;

    /// Where the templates watch particles cross.
    fn sensor(&self, case: &Case) -> SensorPlane;

    /// Responses and series of a run from what its solver observed.
    fn results(&self, case: &Case, observations: &Observations) -> RunResults;
}

/// Every equipment `orch` knows, the default ([`DEFAULT_EQUIPMENT`]) first.
pub static EQUIPMENT: &[&dyn Equipment] = &[&crate::hopper::Hopper, &crate::chute::Chute];

/// The equipment a study gets when it names none.
pub const DEFAULT_EQUIPMENT: &str = "hopper";

/// The equipment called `name`, or `None`.
pub fn equipment_for(name: &str) -> Option<&'static dyn Equipment> {
    EQUIPMENT.iter().copied().find(|e| e.name() == name)
}

/// Names of every equipment, for messages.
pub fn equipment_names() -> Vec<&'static str> {
    EQUIPMENT.iter().map(|e| e.name()).collect()
}

/// A response spec, for the equipment tables.
pub(crate) const fn response(
    name: &'static str,
    unit: &'static str,
    description: &'static str,
) -> ResponseSpec {
    ResponseSpec {
        name: Cow::Borrowed(name),
        unit: Cow::Borrowed(unit),
        description: Cow::Borrowed(description),
        over: Cow::Borrowed(TIME_AXIS),
        interval: None,
    }
}

/// A response spec whose runs also report the half-width of its 95 % interval as the
/// response `interval`.
pub(crate) const fn response_with_interval(
    name: &'static str,
    unit: &'static str,
    description: &'static str,
    interval: &'static str,
) -> ResponseSpec {
    ResponseSpec {
        name: Cow::Borrowed(name),
        unit: Cow::Borrowed(unit),
        description: Cow::Borrowed(description),
        over: Cow::Borrowed(TIME_AXIS),
        interval: Some(Cow::Borrowed(interval)),
    }
}

/// The abscissa of a time series.
pub const TIME_AXIS: &str = "t [s]";

/// A series over something other than time: `over` names the abscissa with its unit.
pub(crate) const fn series_over(
    name: &'static str,
    unit: &'static str,
    description: &'static str,
    over: &'static str,
) -> ResponseSpec {
    ResponseSpec {
        name: Cow::Borrowed(name),
        unit: Cow::Borrowed(unit),
        description: Cow::Borrowed(description),
        over: Cow::Borrowed(over),
        interval: None,
    }
}
