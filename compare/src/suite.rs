//! The suite file of `orch compare`: reference cases, each an equipment with fixed
//! parameters, seeds and the responses compared with their tolerances.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use orch_adapters::{equipment_for, Case, Equipment, ResolvedParameters};
use serde::Deserialize;

/// The default confidence of the intervals, when the suite does not give one.
pub const DEFAULT_CONFIDENCE: f64 = 0.95;

/// Why a suite file cannot be used; every message names the file and the field.
#[derive(Debug, thiserror::Error)]
pub enum SuiteError {
    /// The file could not be read.
    #[error("cannot read the suite file {}: {source}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// The file is not a suite.
    #[error("the suite file {} is not valid: {message}", path.display())]
    Parse {
        /// The file.
        path: PathBuf,
        /// serde's message with the field's path.
        message: String,
    },
    /// A case is wrong.
    #[error("the suite file {}, case `{case}`: {message}", path.display())]
    Case {
        /// The file.
        path: PathBuf,
        /// The case.
        case: String,
        /// What is wrong and what to do.
        message: String,
    },
}

/// One compared response of a case.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResponseTolerance {
    /// Largest acceptable relative difference `|native − reference| / |reference|`.
    pub tolerance: f64,
}

/// One reference case as written in the file.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SuiteCase {
    /// Unique name, used in tables and the store.
    pub name: String,
    /// What one sentence says the case checks.
    #[serde(default)]
    pub description: String,
    /// A built-in equipment (`hopper`).
    pub equipment: String,
    /// Parameters that differ from the equipment's defaults, SI.
    #[serde(default)]
    pub fixed: BTreeMap<String, f64>,
    /// Seeds of the replicates; at least two, the same for every solver.
    pub seeds: Vec<u64>,
    /// Compared responses with their tolerances.
    pub responses: BTreeMap<String, ResponseTolerance>,
    /// In the small suite of `orch compare --quick` (run in CI).
    #[serde(default)]
    pub quick: bool,
}

/// A suite file.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Suite {
    /// Confidence of the intervals (default 0.95).
    #[serde(default = "default_confidence")]
    pub confidence: f64,
    /// The cases, in the order they run.
    pub cases: Vec<SuiteCase>,
}

fn default_confidence() -> f64 {
    DEFAULT_CONFIDENCE
}

impl Suite {
    /// Reads, parses and checks the suite at `path`.
    pub fn load(path: &Path) -> Result<Suite, SuiteError> {
        let text = std::fs::read_to_string(path).map_err(|source| SuiteError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        Suite::parse(&text, path)
    }

    /// Parses and checks a suite's text; `path` names it in errors.
    pub fn parse(text: &str, path: &Path) -> Result<Suite, SuiteError> {
        let deserializer = serde_yaml_ng::Deserializer::from_str(text);
        let suite: Suite =
            serde_path_to_error::deserialize(deserializer).map_err(|error| SuiteError::Parse {
                path: path.to_path_buf(),
                message: format!("{}: {}", error.path(), error.inner()),
            })?;
        suite.check(path)?;
        Ok(suite)
    }

    /// The cases `--quick` runs, or all.
    pub fn selected(&self, quick: bool) -> Vec<&SuiteCase> {
        self.cases.iter().filter(|c| c.quick || !quick).collect()
    }

    fn check(&self, path: &Path) -> Result<(), SuiteError> {
        let parse_error = |message: String| SuiteError::Parse {
            path: path.to_path_buf(),
            message,
        };
        if !(self.confidence > 0.0 && self.confidence < 1.0) {
            return Err(parse_error(format!(
                "confidence: {} is not between 0 and 1 (e.g. 0.95)",
                self.confidence
            )));
        }
        if self.cases.is_empty() {
            return Err(parse_error("cases: the suite has no case".into()));
        }
        if !self.cases.iter().any(|c| c.quick) {
            return Err(parse_error(
                "cases: no case has `quick: true`, so `orch compare --quick` would run nothing"
                    .into(),
            ));
        }
        let mut names = std::collections::BTreeSet::new();
        for case in &self.cases {
            let error = |message: String| SuiteError::Case {
                path: path.to_path_buf(),
                case: case.name.clone(),
                message,
            };
            if !names.insert(case.name.as_str()) {
                return Err(error("the name is used by another case".into()));
            }
            let equipment = case.equipment()?;
            let equipment = equipment.ok_or_else(|| {
                error(format!(
                    "unknown equipment `{}`; `orch params` lists them",
                    case.equipment
                ))
            })?;
            for (name, value) in &case.fixed {
                let spec = equipment
                    .parameters()
                    .iter()
                    .find(|p| p.name == name.as_str())
                    .ok_or_else(|| {
                        error(format!(
                            "fixed: `{name}` is not a parameter of {}; `orch params {}` lists them",
                            case.equipment, case.equipment
                        ))
                    })?;
                if !(*value >= spec.min && *value <= spec.max) {
                    return Err(error(format!(
                        "fixed: {name} = {value} {} is outside [{}, {}]",
                        spec.unit, spec.min, spec.max
                    )));
                }
            }
            let mut seeds = case.seeds.clone();
            seeds.sort_unstable();
            seeds.dedup();
            if seeds.len() < 2 || seeds.len() != case.seeds.len() {
                return Err(error(
                    "seeds: give at least two different seeds (an interval needs replicates)"
                        .into(),
                ));
            }
            if case.responses.is_empty() {
                return Err(error("responses: name at least one response".into()));
            }
            for (name, response) in &case.responses {
                if !equipment
                    .responses()
                    .iter()
                    .any(|r| r.name == name.as_str())
                {
                    return Err(error(format!(
                        "responses: `{name}` is not a response of {}; `orch params {}` lists them",
                        case.equipment, case.equipment
                    )));
                }
                if !(response.tolerance > 0.0 && response.tolerance.is_finite()) {
                    return Err(error(format!(
                        "responses: {name}: the tolerance must be a positive fraction (0.1 = 10 %)"
                    )));
                }
            }
        }
        Ok(())
    }
}

impl SuiteCase {
    fn equipment(&self) -> Result<Option<&'static dyn Equipment>, SuiteError> {
        Ok(equipment_for(&self.equipment))
    }

    /// The case for `seed`, every parameter the equipment's default but the fixed ones,
    /// each multiplied by its factor in `perturbation` (by name).
    pub fn case(&self, seed: u64, perturbation: &BTreeMap<String, f64>) -> Case {
        let equipment = equipment_for(&self.equipment).expect("checked when loaded");
        let mut parameters = ResolvedParameters::defaults(equipment.parameters());
        for (name, value) in &self.fixed {
            parameters.set(name, *value);
        }
        for (name, factor) in perturbation {
            let value = parameters.get(name);
            parameters.set(name, value * factor);
        }
        Case {
            parameters,
            seed,
            text: Default::default(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Suite, SuiteError> {
        Suite::parse(text, Path::new("suite.yaml"))
    }

    #[test]
    fn the_repository_suite_is_valid_and_has_a_quick_subset() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../jobs/compare/suite.yaml");
        let suite = Suite::load(&path).unwrap();
        assert!(!suite.selected(true).is_empty());
        assert!(suite.selected(true).len() < suite.selected(false).len());
    }

    #[test]
    fn wrong_cases_are_refused_naming_what() {
        let good = "cases:\n- name: a\n  equipment: hopper\n  quick: true\n  seeds: [1, 2]\n  fixed: {n_particles: 500}\n  responses: {exit_speed: {tolerance: 0.1}}\n";
        let suite = parse(good).unwrap();
        assert_eq!(suite.confidence, DEFAULT_CONFIDENCE);
        let perturbed = suite.cases[0].case(1, &BTreeMap::from([("friction".into(), 1.3)]));
        assert!((perturbed.get("friction") - 0.65).abs() < 1e-12);
        assert_eq!(perturbed.get("n_particles"), 500.0);
        for (bad, expected) in [
            (
                good.replace("seeds: [1, 2]", "seeds: [1, 1]"),
                "two different seeds",
            ),
            (
                good.replace("n_particles", "particles"),
                "`particles` is not a parameter",
            ),
            (
                good.replace("exit_speed", "speed"),
                "`speed` is not a response",
            ),
            (good.replace("0.1}", "-1}"), "positive fraction"),
            (good.replace("hopper", "silo"), "unknown equipment `silo`"),
            (
                good.replace("quick: true", "quick: false"),
                "no case has `quick: true`",
            ),
            (
                good.replace("n_particles: 500", "n_particles: 0"),
                "outside",
            ),
            (good.replace("seeds", "seed"), "unknown field"),
        ] {
            let error = parse(&bad).unwrap_err().to_string();
            assert!(error.contains(expected), "{error}");
        }
    }
}
