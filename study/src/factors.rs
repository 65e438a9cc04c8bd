//! `factors:` and `fixed:` of a study: each factor a parameter of the equipment within
//! its range (or a text factor's levels), each fixed value one too.

use super::*;

impl Checker<'_> {
    /// The factors as the file lists them; `custom_deck`: the equipment is the user's
    /// own deck, whose templates may take any name and text.
    pub(super) fn factors(
        &self,
        file: &StudyFile,
        simulation: &dyn Simulation,
        custom_deck: bool,
    ) -> Result<Vec<Factor>, StudyError> {
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
                factors.push(self.text_factor(i, factor, levels, custom_deck, equipment_name)?);
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
        Ok(factors)
    }

    /// The fixed values: numbers (parameters within their ranges) and, for a custom
    /// deck, text.
    #[allow(clippy::type_complexity)]
    pub(super) fn fixed_values(
        &self,
        file: &StudyFile,
        simulation: &dyn Simulation,
        custom_deck: bool,
    ) -> Result<(BTreeMap<String, f64>, BTreeMap<String, String>), StudyError> {
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
                FixedValue::Text(text) if custom_deck => {
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
            self.fixed_parameter(&at, name, value, simulation)?;
            fixed.insert(name.clone(), value);
        }
        Ok((fixed, fixed_text))
    }
}
