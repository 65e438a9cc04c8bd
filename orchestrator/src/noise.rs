//! The noise design: after a study's rounds, a design over its uncertain parameters
//! around the optimum, run as a study of its own, `<study>-noise`.
//!
//! Its factors are the materials (parameters that are not design factors) on
//! `mean ± half_width·std` and the design factors with a tolerance on
//! `optimum ± half_width·std`; every other design factor is fixed at the optimum. Its
//! `uncertainty:` gives each factor its distribution (a tolerance: normal around the
//! optimum), so its one round fits a surrogate per response over the noise box, holds
//! every factor at its mean (the optimum) and carries the distributions to the 95 %
//! bounds there, with and without the surrogate's own error. That is the thesis's
//! procedure: a plan of experiments on the material properties around the optimum, a
//! metamodel of it, and the response's distribution from the properties'.
//!
//! The noise study's file is written from the parent's stored text, so it is validated,
//! stored, resumed and reported like any study; it is found again by its name, and its
//! text starts with [`HEADER`] and the parent's name.

use std::collections::BTreeMap;
use std::path::Path;

use orch_metamodel::Distribution;
use serde_yaml_ng::{Mapping, Value};

use crate::store::{Store, StoreError, StoredRound, StudyRow};
use crate::study::{noise_range, NoiseDesign, Stored, Study, StudyError};

/// How the noise study's name ends.
pub const SUFFIX: &str = "-noise";

/// The first words of a noise study's file.
pub const HEADER: &str = "# Written by orch: the noise design around the optimum of ";

/// The noise study's name for a parent named `parent`.
pub fn name_of(parent: &str) -> String {
    format!("{parent}{SUFFIX}")
}

/// The noise study's file text for `parent` (stored under `parent_name`) around its
/// optimum `optimum` (natural units, one value per factor).
pub fn study_text(
    parent: &Study,
    parent_name: &str,
    noise: &NoiseDesign,
    optimum: &[f64],
) -> Result<String, String> {
    let mut doc: Value = serde_yaml_ng::from_str(&parent.file_text)
        .map_err(|e| format!("the stored study file no longer parses: {e}"))?;
    let map = doc
        .as_mapping_mut()
        .ok_or("the stored study file is not a mapping")?;
    let key = |k: &str| Value::String(k.to_string());
    let number = |v: f64| Value::Number(serde_yaml_ng::Number::from(v));
    let uncertainty = map
        .get(key("uncertainty"))
        .cloned()
        .ok_or("the study has no uncertainty section")?;
    let written: BTreeMap<String, Value> = uncertainty
        .get("parameters")
        .and_then(Value::as_sequence)
        .map(|list| {
            list.iter()
                .filter_map(|p| Some((p.get("name")?.as_str()?.to_string(), p.clone())))
                .collect()
        })
        .unwrap_or_default();

    let mut factors = Vec::new();
    let mut distributions = Vec::new();
    for material in &noise.materials {
        let (min, max) = noise_range(&material.distribution, noise.half_width);
        factors.push(factor_value(&material.name, min, max, &material.unit));
        distributions.push(
            written
                .get(&material.name)
                .cloned()
                .ok_or_else(|| format!("`{}` is not in the stored uncertainty", material.name))?,
        );
    }
    let specs = parent.simulation.parameters();
    for &(index, std) in &noise.tolerances {
        let factor = &parent.factors[index];
        let centre = optimum[index];
        let (mut min, mut max) = noise_range(
            &Distribution::Normal { mean: centre, std },
            noise.half_width,
        );
        // A tolerance may reach past the study's range, not past what the equipment takes.
        if let Some(spec) = specs.iter().find(|s| s.name == factor.name) {
            (min, max) = (min.max(spec.min), max.min(spec.max));
        }
        factors.push(factor_value(&factor.name, min, max, &factor.unit));
        let mut normal = Mapping::new();
        normal.insert(key("name"), key(&factor.name));
        normal.insert(key("distribution"), key("normal"));
        normal.insert(key("mean"), number(centre));
        normal.insert(key("std"), number(std));
        distributions.push(Value::Mapping(normal));
    }

    let mut fixed = map
        .get(key("fixed"))
        .and_then(Value::as_mapping)
        .cloned()
        .unwrap_or_default();
    // Over fidelity levels the noise is the top level's: its solver and parameters.
    if let Some(top) = map
        .remove(key("fidelity"))
        .and_then(|levels| levels.as_sequence()?.last().cloned())
    {
        if let Some(solver) = top.get("solver") {
            map.insert(key("solver"), solver.clone());
        }
        for (name, value) in top
            .get("fixed")
            .and_then(Value::as_mapping)
            .into_iter()
            .flatten()
        {
            fixed.insert(name.clone(), value.clone());
        }
    }
    for (index, factor) in parent.factors.iter().enumerate() {
        if !noise.tolerances.iter().any(|(i, _)| *i == index) {
            // A text factor is fixed at its level's text, as the deck saw it.
            let value = match factor.level_text(optimum[index]) {
                Some(level) => key(level),
                None => number(optimum[index]),
            };
            fixed.insert(key(&factor.name), value);
        }
    }
    let design = uncertainty
        .get("noise_design")
        .and_then(|n| n.get("design"))
        .cloned()
        .unwrap_or_else(|| default_design(noise));
    let mut section = Mapping::new();
    for field in ["samples", "seed"] {
        if let Some(value) = uncertainty.get(field) {
            section.insert(key(field), value.clone());
        }
    }
    section.insert(key("parameters"), Value::Sequence(distributions));

    map.insert(key("name"), key(&name_of(parent_name)));
    map.insert(
        key("description"),
        key(&format!(
            "The noise design around the optimum of {parent_name}: its uncertain parameters varied on ±{} standard deviations, the design factors at the optimum.",
            noise.half_width
        )),
    );
    map.insert(key("factors"), Value::Sequence(factors));
    map.insert(key("fixed"), Value::Mapping(fixed));
    map.insert(key("design"), design);
    map.insert(
        key("seed"),
        Value::Number(parent.seed.wrapping_add(1).into()),
    );
    map.insert(key("rounds"), Value::Number(1.into()));
    map.remove(key("next_round"));
    map.insert(key("uncertainty"), Value::Mapping(section));
    if let Some(objective) = map
        .get_mut(key("objective"))
        .and_then(Value::as_mapping_mut)
    {
        // Every factor is held at its mean: the "optimum" is the noise box's centre,
        // and bounds on responses there are reported, not enforced; a front or a
        // robust objective has nothing to trade there, so the first objective is
        // propagated as is.
        for field in ["constraints", "robust", "front_points"] {
            objective.remove(key(field));
        }
        let first = objective
            .remove(key("objectives"))
            .and_then(|list| list.as_sequence().and_then(|l| l.first().cloned()));
        if let Some(first) = first {
            for field in ["response", "goal"] {
                if let Some(value) = first.get(field) {
                    objective.insert(key(field), value.clone());
                }
            }
        }
    }
    let body = serde_yaml_ng::to_string(&doc).map_err(|e| e.to_string())?;
    Ok(format!("{HEADER}{parent_name}.\n{body}"))
}

/// A `factors:` entry.
fn factor_value(name: &str, min: f64, max: f64, unit: &str) -> Value {
    let mut factor = Mapping::new();
    let key = |k: &str| Value::String(k.to_string());
    factor.insert(key("name"), key(name));
    factor.insert(key("min"), Value::Number(min.into()));
    factor.insert(key("max"), Value::Number(max.into()));
    if !unit.is_empty() && unit != "-" {
        factor.insert(key("unit"), key(unit));
    }
    Value::Mapping(factor)
}

/// The noise design's default, as `design:` would write it.
fn default_design(noise: &NoiseDesign) -> Value {
    let text = if noise.materials.len() + noise.tolerances.len() == 1 {
        "{type: full_factorial, levels: 5}"
    } else {
        "{type: central_composite, alpha: orthogonal, center_points: 1}"
    };
    serde_yaml_ng::from_str(text).expect("a literal design parses")
}

/// The optimum the noise design is centred on: the last round's that was not refused
/// (natural units), `None` when no round found one.
pub fn centre(rounds: &[StoredRound]) -> Option<Vec<f64>> {
    rounds.iter().rev().find_map(|round| {
        let refused = matches!(round.decision, Some((crate::store::Decision::NoOptimum, _)));
        round
            .optimum
            .as_ref()
            .filter(|_| !refused)
            .map(|o| o.3.clone())
    })
}

/// The noise study of `parent` (stored as `parent_row`), validated from the text
/// [`study_text`] writes around the parent's optimum; `None` when the parent has no
/// noise design or no optimum.
pub async fn study_of(
    store: &Store,
    parent_row: &StudyRow,
    parent: &Study,
) -> Result<Option<Result<Study, String>>, StoreError> {
    let Some(noise) = parent.uncertainty.as_ref().and_then(|u| u.noise.as_ref()) else {
        return Ok(None);
    };
    let Some(optimum) = centre(&store.rounds(parent_row.id).await?) else {
        return Ok(None);
    };
    let text = match study_text(parent, &parent_row.name, noise, &optimum) {
        Ok(text) => text,
        Err(e) => return Ok(Some(Err(e))),
    };
    let stored = Stored {
        template: Some(parent.template()),
        inputs: parent.inputs.iter().cloned().collect(),
        for_reading: false,
    };
    let study = Study::from_text(Path::new(&parent_row.file_path), &text, Some(stored))
        .map_err(|e: StudyError| format!("the noise design's study is not valid: {e}"));
    Ok(Some(study))
}

/// The stored noise study of a parent named `parent`, if it ran.
pub async fn stored_row(store: &Store, parent: &str) -> Result<Option<StudyRow>, StoreError> {
    Ok(store
        .study_by_name(&name_of(parent))
        .await?
        .filter(|row| row.file_text.starts_with(&format!("{HEADER}{parent}."))))
}

/// What the noise design of a parent named `parent` found, for people: where it
/// ran, the surrogate of the objective, and the objective's 95 % bounds at the optimum
/// under the uncertain parameters, with and without the surrogate's own error. `None`
/// when it has not run or has no analysed round.
pub async fn summary(store: &Store, parent: &str) -> Result<Option<NoiseSummary>, StoreError> {
    let Some(row) = stored_row(store, parent).await? else {
        return Ok(None);
    };
    let rounds = store.rounds(row.id).await?;
    let Some(round) = rounds.into_iter().find(|r| r.decision.is_some()) else {
        return Ok(None);
    };
    let factors = store
        .factors(row.id)
        .await?
        .into_iter()
        .map(|f| f.name)
        .collect();
    Ok(Some(NoiseSummary {
        study: row.name,
        factors,
        round,
    }))
}

/// The noise design's result as [`summary`] reads it.
#[derive(Debug, Clone)]
pub struct NoiseSummary {
    /// The noise study's name.
    pub study: String,
    /// Its factors: the uncertain parameters.
    pub factors: Vec<String>,
    /// Its one analysed round.
    pub round: StoredRound,
}

impl NoiseSummary {
    /// One line for the end of `orch submit` and for `orch status`, or `None` when the
    /// round found no bounds.
    pub fn line(&self) -> Option<String> {
        let (response, _, value, _) = self.round.optimum.as_ref()?;
        let spread = self.round.uncertainty.as_ref()?;
        let model = self
            .round
            .fits
            .iter()
            .find(|f| &f.response == response)
            .and_then(|f| f.model.clone())
            .unwrap_or_else(|| "no surrogate".into());
        let n = crate::numbers::number;
        let mut line = format!(
            "noise design `{}` over {} ({} runs, {model}): {response} {} at the optimum; 95 % interval [{}, {}]",
            self.study,
            self.factors.join(", "),
            self.round.fits.first().map_or(0, |f| f.runs),
            n(*value),
            n(spread.q025),
            n(spread.q975),
        );
        if let Some(total) = &self.round.uncertainty_total {
            line.push_str(&format!(
                ", with the surrogate's own error [{}, {}]",
                n(total.q025),
                n(total.q975)
            ));
        }
        Some(line)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const PARENT: &str = "\
name: cone
solver: native
factors:
  - {name: shape_x1, min: -0.008, max: 0.008, unit: m}
  - {name: shape_x2, min: -0.008, max: 0.008, unit: m}
fixed: {n_particles: 1500, outlet_diameter: 0.020}
design: {type: central_composite, alpha: face_centred}
responses: [discharge_rate]
objective:
  objectives: [{response: discharge_rate, goal: maximise}, {response: segregation_ratio, goal: minimise}]
  front_points: 5
  constraints: [{response: segregation_ratio, max: 2}]
next_round: {shrink: 0.5}
rounds: 2
uncertainty:
  samples: 1000
  seed: 9
  parameters:
    - {name: density, distribution: normal, mean: 2400, std: 96}
    - {name: shape_x2, distribution: normal, std: 0.0005}
";

    #[test]
    fn a_text_factor_is_fixed_at_its_level_in_the_noise_study() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("deck.sh.tera"),
            "echo {{ x }} {{ contact }} {{ density }}\n",
        )
        .unwrap();
        let text = "name: deck\nequipment: custom\ncase:\n  templates: [deck.sh.tera]\n  command: [sh, deck.sh]\n  responses:\n    - {name: y, regex: 'y = (\\S+)'}\nfactors:\n  - {name: x, min: 0, max: 1}\n  - {name: contact, levels: [hertz, hooke]}\ndesign: {type: full_factorial, levels: 2}\nobjective: {response: y, goal: minimise}\nuncertainty:\n  parameters:\n    - {name: density, distribution: normal, mean: 2500, std: 100}\n";
        let path = dir.path().join("deck.yaml");
        std::fs::write(&path, text).unwrap();
        let parent = Study::load(&path).unwrap();
        let noise = parent.uncertainty.as_ref().unwrap().noise.as_ref().unwrap();
        let child_text = study_text(&parent, "deck", noise, &[0.25, 1.0]).unwrap();
        std::fs::write(&path, &child_text).unwrap();
        let child = Study::load(&path).unwrap();
        assert_eq!(child.fixed_text["contact"], "hooke", "{child_text}");
        assert_eq!(child.fixed["x"], 0.25);
    }

    #[test]
    fn the_noise_study_varies_materials_and_tolerances_around_the_optimum() {
        let parent = Study::from_text(Path::new("jobs/cone.yaml"), PARENT, None).unwrap();
        let noise = parent.uncertainty.as_ref().unwrap().noise.as_ref().unwrap();
        let text = study_text(&parent, "cone", noise, &[0.004, -0.002]).unwrap();
        assert!(
            text.starts_with("# Written by orch: the noise design around the optimum of cone.\n")
        );
        let child = Study::from_text(Path::new("jobs/cone.yaml"), &text, None).unwrap();
        assert_eq!(child.name, "cone-noise");
        assert_eq!(child.rounds, 1);
        // Density on 2400 ± 3·96, the shape's tolerance on −0.002 ± 3·0.0005.
        let names: Vec<&str> = child.factors.iter().map(|f| f.name.as_str()).collect();
        assert_eq!(names, ["density", "shape_x2"]);
        assert!((child.factors[0].range.min - 2112.0).abs() < 1e-9);
        assert!((child.factors[0].range.max - 2688.0).abs() < 1e-9);
        assert!((child.factors[1].range.min + 0.0035).abs() < 1e-12);
        assert!((child.factors[1].range.max + 0.0005).abs() < 1e-12);
        // The other design factor sits at the optimum; the old fixed values stay.
        assert_eq!(child.fixed["shape_x1"], 0.004);
        assert_eq!(child.fixed["n_particles"], 1500.0);
        // Both are uncertain with their means at the optimum and the material's mean.
        let uncertainty = child.uncertainty.as_ref().unwrap();
        assert!(uncertainty.noise.is_none());
        assert_eq!(uncertainty.parameters.len(), 2);
        assert_eq!(
            uncertainty.parameters[1].1,
            Distribution::Normal {
                mean: -0.002,
                std: 0.0005
            }
        );
        assert_eq!((uncertainty.samples, uncertainty.seed), (1000, 9));
        // A central composite over two: 9 runs; no constraints, no next round.
        assert_eq!(child.points.len(), 9);
        // One objective, the front's first, without constraints.
        let objective = child.objective.as_ref().unwrap();
        assert!(objective.constraints.is_empty() && objective.objectives.is_empty());
        assert_eq!(objective.name(), "discharge_rate");
        // Written again from the same optimum, it is the same study (same hash).
        let again = study_text(&parent, "cone", noise, &[0.004, -0.002]).unwrap();
        assert_eq!(again, text);
    }

    #[test]
    fn a_multi_fidelity_parent_is_replicated_at_its_top_level() {
        let text = PARENT.replace(
            "rounds: 2\n",
            "rounds: 2\nfidelity:\n  - {name: coarse, cost: 1}\n  - {name: dear, solver: liggghts, cost: 5, runs: 4, fixed: {n_particles: 3000}}\n",
        );
        let parent = Study::from_text(Path::new("jobs/cone.yaml"), &text, None).unwrap();
        assert_eq!(parent.fidelities.len(), 2);
        let noise = parent.uncertainty.as_ref().unwrap().noise.as_ref().unwrap();
        let child_text = study_text(&parent, "cone", noise, &[0.004, -0.002]).unwrap();
        let child = Study::from_text(Path::new("jobs/cone.yaml"), &child_text, None).unwrap();
        assert!(child.fidelities.is_empty(), "{child_text}");
        assert_eq!(child.simulation.solver_name(), "liggghts");
        assert_eq!(child.fixed["n_particles"], 3000.0);
    }

    #[test]
    fn the_centre_is_the_last_optimum_that_was_not_refused() {
        let round = |r: i64, at: f64, decision| StoredRound {
            round: r,
            optimum: Some(("y".into(), "maximise".into(), 1.0, vec![at])),
            decision: Some((decision, String::new())),
            ..Default::default()
        };
        use crate::store::Decision;
        let rounds = [
            round(0, 1.0, Decision::NextRound),
            round(1, 2.0, Decision::NoOptimum),
        ];
        assert_eq!(centre(&rounds), Some(vec![1.0]));
        assert_eq!(centre(&rounds[1..]), None);
    }
}
