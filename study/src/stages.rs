//! The stages of a study (`stages:`, `cfd:`) and its DEM ↔ air `coupling:`, as the
//! study file asks for them and as validation checks them.

use super::*;

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

impl Checker<'_> {
    /// The stages: `stages:` by kind, and `cfd:` as shorthand for `stages: {cfd: …}`;
    /// every fixed value a parameter of its stage within its range, and every upstream
    /// response and parameter a stage reads one the equipment has.
    pub(super) fn stages(
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

    /// `coupling:` checked: the `cfd` stage is there, the response is the DEM's and
    /// the equipment has the air parameters ([`Study::check_coupled_case`] then renders
    /// a design point in moving air).
    pub(super) fn coupling(
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
    pub(super) fn stop_when(
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

    /// With `coupling:`, the simulation must run the first design point in the CFD
    /// stage's air (`air_field` = 1): its checks pass and its template renders.
    pub(super) fn check_coupled_case(&self, study: &Study) -> Result<(), StudyError> {
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
}
