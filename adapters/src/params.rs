//! Template parameters: what an equipment's templates understand, with SI units.

use std::borrow::Cow;
use std::collections::BTreeMap;

/// One parameter of an equipment's templates. Built-in equipment declare theirs in
/// static tables; a user's own deck declares its own in the study (hence `Cow`).
#[derive(Debug, Clone, PartialEq)]
pub struct ParameterSpec {
    /// Name used in study files and templates.
    pub name: Cow<'static, str>,
    /// Value used when a study does not set it.
    pub default: f64,
    /// SI unit, for messages and reports (`m`, `Hz`, `kg/m^3`, `-`).
    pub unit: Cow<'static, str>,
    /// Smallest physically meaningful value (inclusive).
    pub min: f64,
    /// Largest physically meaningful value (inclusive).
    pub max: f64,
    /// What it is.
    pub description: Cow<'static, str>,
}

/// Parameter values by name, after defaults, fixed values and factors are merged.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ResolvedParameters(pub BTreeMap<String, f64>);

impl ResolvedParameters {
    /// Starts from every spec's default.
    pub fn defaults(specs: &[ParameterSpec]) -> ResolvedParameters {
        ResolvedParameters(
            specs
                .iter()
                .map(|s| (s.name.to_string(), s.default))
                .collect(),
        )
    }

    /// Sets `name` to `value`.
    pub fn set(&mut self, name: &str, value: f64) {
        self.0.insert(name.to_string(), value);
    }

    /// The value of `name`; NaN when absent, which every range check then refuses.
    pub fn get(&self, name: &str) -> f64 {
        self.0.get(name).copied().unwrap_or(f64::NAN)
    }
}

/// A parameter spec, for the adapters' tables.
pub(crate) const fn spec(
    name: &'static str,
    default: f64,
    unit: &'static str,
    min: f64,
    max: f64,
    description: &'static str,
) -> ParameterSpec {
    ParameterSpec {
        name: Cow::Borrowed(name),
        default,
        unit: Cow::Borrowed(unit),
        min,
        max,
        description: Cow::Borrowed(description),
    }
}
