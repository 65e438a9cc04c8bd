//! Fidelity levels (`fidelity:`): the same question asked of a cheap and a dear model —
//! orch's kernel and LIGGGHTS, or a coarse and a fine particle count — with the cheap
//! runs carrying the surface and the dear ones correcting it (co-Kriging,
//! [`orch_metamodel::co_kriging`]).
//!
//! Every design point runs at the first level; each higher level runs a nested subset
//! of the level below's points (greedy maximin, [`orch_metamodel::nested_subset`]), so
//! a dear run always has its cheap twin. A level may change the solver (built-in
//! equipment) and set template parameters over the study's `fixed:`.

use orch_metamodel::nested_subset;

use super::file::FidelityFile;
use super::*;

/// One fidelity level of a study, cheapest first.
#[derive(Clone)]
pub struct Fidelity {
    /// Its name (letters, digits, `-`, `_`).
    pub name: String,
    /// What runs at this level.
    pub simulation: Arc<dyn Simulation>,
    /// Cost of one run, in the unit the study's levels share.
    pub cost: f64,
    /// Design points of the first round at this level.
    pub runs: usize,
    /// Template parameters this level sets over the study's `fixed:`.
    pub fixed: BTreeMap<String, f64>,
}

impl std::fmt::Debug for Fidelity {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Fidelity")
            .field("name", &self.name)
            .field("solver", &self.simulation.solver_name())
            .field("cost", &self.cost)
            .field("runs", &self.runs)
            .field("fixed", &self.fixed)
            .finish()
    }
}

/// The first round's points of a study with `fidelities`: `points` at level 0, then at
/// each higher level the nested maximin subset of the level below's, as many as the
/// level's `runs`. Without levels, `points` unchanged.
pub fn nested_points(points: Vec<DesignPoint>, fidelities: &[Fidelity]) -> Vec<DesignPoint> {
    let mut all = points;
    let mut below: Vec<DesignPoint> = all.clone();
    for (level, fidelity) in fidelities.iter().enumerate().skip(1) {
        let coded: Vec<Vec<f64>> = below.iter().map(|p| p.coded.clone()).collect();
        let here: Vec<DesignPoint> = nested_subset(&coded, fidelity.runs)
            .into_iter()
            .map(|i| DesignPoint {
                fidelity: level as u32,
                ..below[i].clone()
            })
            .collect();
        all.extend(here.iter().cloned());
        below = here;
    }
    all
}

impl Checker<'_> {
    /// The study's fidelity levels, checked: none, or two or more with rising costs,
    /// nested run counts of at least 3, solvers and parameters each level can run.
    pub(super) fn fidelities(
        &self,
        file: &StudyFile,
        study_simulation: &Arc<dyn Simulation>,
        design_points: usize,
    ) -> Result<Vec<Fidelity>, StudyError> {
        if file.fidelity.is_empty() {
            return Ok(Vec::new());
        }
        if file.fidelity.len() == 1 {
            return Err(self.error(
                "fidelity",
                "expected two levels or more, cheapest first; one level is an ordinary study: remove `fidelity:`",
            ));
        }
        let refused = [
            (!file.stages.is_empty() || file.cfd.is_some(), "stages"),
            (file.coupling.is_some(), "coupling"),
            (
                file.metamodel.model.is_some() || file.metamodel.order.is_some(),
                "metamodel.model",
            ),
        ];
        if let Some((_, what)) = refused.iter().find(|(present, _)| *present) {
            return Err(self.error(
                what,
                format!("`{what}` cannot be combined with `fidelity:` (every response is fitted by co-Kriging over the levels, each run is one job); remove one of them"),
            ));
        }
        if file.factors.iter().any(|f| f.levels.is_some()) {
            return Err(self.error(
                "fidelity",
                "text factors cannot be combined with `fidelity:` yet (co-Kriging is over numeric factors); make the text factor `fixed:` or run one study per level",
            ));
        }
        let custom = file.equipment.as_deref() == Some(custom::EQUIPMENT);
        let mut levels: Vec<Fidelity> = Vec::with_capacity(file.fidelity.len());
        for (i, level) in file.fidelity.iter().enumerate() {
            let at = |field: &str| format!("fidelity[{i}].{field}");
            let rule_breaker = level.name.is_empty()
                || !level
                    .name
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_');
            if rule_breaker || level.name.len() > 64 {
                return Err(self.error(
                    &at("name"),
                    format!(
                        "expected 1 to 64 letters, digits, `-` or `_`, got `{}`",
                        level.name
                    ),
                ));
            }
            if levels.iter().any(|l| l.name == level.name) {
                return Err(self.error(
                    &at("name"),
                    format!("`{}` names two levels; give each its own name", level.name),
                ));
            }
            let cheaper = levels.last().map_or(0.0, |l| l.cost);
            if !(level.cost.is_finite() && level.cost > cheaper) {
                return Err(self.error(
                    &at("cost"),
                    format!(
                        "expected a finite cost above {cheaper} (levels go from the cheapest up), got {}",
                        level.cost
                    ),
                ));
            }
            let runs =
                self.level_runs(i, level, levels.last().map_or(design_points, |l| l.runs))?;
            let simulation = self.level_simulation(file, i, level, custom, study_simulation)?;
            let factor_names: Vec<&str> = file.factors.iter().map(|f| f.name.as_str()).collect();
            let fixed = self.level_fixed(i, level, simulation.as_ref(), &factor_names)?;
            levels.push(Fidelity {
                name: level.name.clone(),
                simulation,
                cost: level.cost,
                runs,
                fixed,
            });
        }
        Ok(levels)
    }

    /// Level `i`'s design points: all `below` at the first level, else its `runs:`,
    /// from 3 (a constant, the scale `ρ` and a variance) to `below`.
    fn level_runs(
        &self,
        i: usize,
        level: &FidelityFile,
        below: usize,
    ) -> Result<usize, StudyError> {
        let field = format!("fidelity[{i}].runs");
        match (i, level.runs) {
            (0, None) => Ok(below),
            (0, Some(_)) => Err(self.error(
                &field,
                "the first (cheapest) level runs every design point; remove its `runs:`",
            )),
            (_, None) => Err(self.error(
                &field,
                format!("expected `runs:`, how many of the {below} points of the level below also run here (3 to {below})"),
            )),
            (_, Some(runs)) if runs < 3 || runs > below => Err(self.error(
                &field,
                format!("expected 3 to {below} runs (a subset of the level below's points, at least 3 to estimate the scale between the levels), got {runs}"),
            )),
            (_, Some(runs)) => Ok(runs),
        }
    }

    /// What runs at level `i`: the study's simulation, or its equipment on the
    /// level's own solver.
    fn level_simulation(
        &self,
        file: &StudyFile,
        i: usize,
        level: &FidelityFile,
        custom: bool,
        study_simulation: &Arc<dyn Simulation>,
    ) -> Result<Arc<dyn Simulation>, StudyError> {
        let field = format!("fidelity[{i}].solver");
        match &level.solver {
            None => Ok(study_simulation.clone()),
            Some(_) if custom => Err(self.error(
                &field,
                "your own deck's command is in `case:`; a level of it may only set `fixed:` parameters",
            )),
            Some(solver) if file.solver.as_deref() == Some(solver.as_str()) => {
                Ok(study_simulation.clone())
            }
            Some(_) if file.template.is_some() => Err(self.error(
                &field,
                "the study's `template:` is for its own solver; remove `template:` or the level's `solver:`",
            )),
            Some(solver) => Ok(Arc::new(self.builtin_simulation_on(file, Some(solver), &field)?)),
        }
    }

    /// Level `i`'s `fixed:` numbers, each a parameter of its simulation within range.
    fn level_fixed(
        &self,
        i: usize,
        level: &FidelityFile,
        simulation: &dyn Simulation,
        factors: &[&str],
    ) -> Result<BTreeMap<String, f64>, StudyError> {
        let mut fixed = BTreeMap::new();
        for (name, value) in &level.fixed {
            let at = format!("fidelity[{i}].fixed.{name}");
            if factors.contains(&name.as_str()) {
                return Err(self.error(
                    &at,
                    format!(
                        "`{name}` is a factor, varied by the design at every level; remove it here"
                    ),
                ));
            }
            let value = match value {
                FixedValue::Number(v) if v.is_finite() => *v,
                other => {
                    return Err(self.error(
                        &at,
                        format!("expected a finite number (SI units), got {other:?}"),
                    ))
                }
            };
            self.fixed_parameter(&at, name, value, simulation)?;
            fixed.insert(name.clone(), value);
        }
        Ok(fixed)
    }
}

#[cfg(test)]
#[path = "fidelity_tests.rs"]
mod tests;
