//! `objective:` of a study: one response, a weighted sum, or a Pareto front of two or
//! more, with bounds on other responses (probabilistic ones too) and a robust
//! optimum, checked against the responses the study's runs produce.

use super::file::ObjectiveFile;
use super::*;

impl Checker<'_> {
    /// The objective as the file gives it; every response named is one of
    /// `known_responses`.
    pub(super) fn objective(
        &self,
        objective: &ObjectiveFile,
        known_responses: &[&str],
    ) -> Result<Objective, StudyError> {
        let known = |field: &str, name: &str| {
            if known_responses.contains(&name) {
                Ok(())
            } else {
                Err(self.error(
                    field,
                    format!(
                        "unknown response `{name}`; expected one of: {}",
                        known_responses.join(", ")
                    ),
                ))
            }
        };
        let goal_of = |goal: GoalFile| match goal {
            GoalFile::Minimise => Goal::Minimise,
            GoalFile::Maximise => Goal::Maximise,
        };
        let mut objectives = Vec::new();
        let mut front_points = DEFAULT_FRONT_POINTS;
        let (terms, goal) = if let Some(listed) = &objective.objectives {
            for (field, given) in [
                ("response", objective.response.is_some()),
                ("weights", objective.weights.is_some()),
                ("goal", objective.goal.is_some()),
            ] {
                if given {
                    return Err(self.error(
                        &format!("objective.{field}"),
                        format!("`objectives:` gives each response its own goal and takes no `{field}:`; remove `{field}:`, or `objectives:` to optimise one response"),
                    ));
                }
            }
            if listed.len() < 2 {
                return Err(self.error(
                    "objective.objectives",
                    format!("expected two or more objectives for a Pareto front, got {}; for one write `response:` and `goal:` instead", listed.len()),
                ));
            }
            for (i, term) in listed.iter().enumerate() {
                let at = format!("objective.objectives[{i}].response");
                known(&at, &term.response)?;
                if listed[..i].iter().any(|t| t.response == term.response) {
                    return Err(self.error(
                        &at,
                        format!(
                            "`{}` is listed twice; a Pareto front needs different responses",
                            term.response
                        ),
                    ));
                }
                objectives.push((term.response.clone(), goal_of(term.goal)));
            }
            if let Some(n) = objective.front_points {
                if !(3..=100).contains(&n) {
                    return Err(self.error(
                        "objective.front_points",
                        format!("expected 3 to 100 points on the Pareto front, got {n}"),
                    ));
                }
                front_points = n;
            }
            let (first, goal) = objectives[0].clone();
            (vec![(first, 1.0)], goal)
        } else {
            if objective.front_points.is_some() {
                return Err(self.error(
                    "objective.front_points",
                    "only a Pareto front has points; list two or more `objectives:` or remove `front_points:`",
                ));
            }
            let terms = match (&objective.response, &objective.weights) {
                (Some(response), None) => {
                    known("objective.response", response)?;
                    vec![(response.clone(), 1.0)]
                }
                (None, Some(weights)) if !weights.is_empty() => {
                    for (name, weight) in weights {
                        known(&format!("objective.weights.{name}"), name)?;
                        if !weight.is_finite() {
                            return Err(self.error(&format!("objective.weights.{name}"), "expected a finite weight"));
                        }
                    }
                    weights.iter().map(|(n, w)| (n.clone(), *w)).collect()
                }
                _ => return Err(self.error("objective", "expected either `response:` or `weights:` (a map of response to weight), not both")),
            };
            let Some(goal) = objective.goal else {
                return Err(self.error(
                    "objective",
                    "missing field `goal`; add `goal: maximise` or `goal: minimise`",
                ));
            };
            (terms, goal_of(goal))
        };
        let (constraints, probabilities) = self.constraints(objective, &known)?;
        let robust = match &objective.robust {
            Some(r) if !(r.k.is_finite() && r.k > 0.0 && r.k <= 6.0) => {
                return Err(self.error(
                    "objective.robust.k",
                    format!(
                        "expected a number of standard deviations in (0, 6], got {}",
                        r.k
                    ),
                ))
            }
            Some(_) if !objectives.is_empty() => {
                return Err(self.error(
                    "objective.robust",
                    "a Pareto front is not made robust; remove `robust:` or list one objective",
                ))
            }
            Some(r) => Some(r.k),
            None => None,
        };
        Ok(Objective {
            terms,
            goal,
            constraints,
            objectives,
            front_points,
            robust,
            probabilities,
        })
    }
}

impl Checker<'_> {
    /// A robust objective or a probabilistic bound needs a spread to be robust against.
    pub(super) fn objective_has_spread(
        &self,
        objective: &Objective,
        uncertainty: Option<&UncertaintyConfig>,
    ) -> Result<(), StudyError> {
        let spread = uncertainty.is_some_and(|u| {
            !u.parameters.is_empty() || u.noise.as_ref().is_some_and(|n| !n.tolerances.is_empty())
        });
        let probabilistic = objective.probabilities.iter().position(Option::is_some);
        let field = match (objective.robust.is_some(), probabilistic) {
            (true, _) => Some("objective.robust".to_string()),
            (false, Some(i)) => Some(format!("objective.constraints[{i}].probability")),
            (false, None) => None,
        };
        if let Some(field) = field.filter(|_| !spread) {
            return Err(self.error(
                &field,
                "needs a spread to be robust against: an uncertain factor (with `mean:`) or a factor's tolerance (`std:` only) in `uncertainty.parameters` (materials that are not factors are outside the surfaces; their noise design runs after the rounds)",
            ));
        }
        Ok(())
    }
}

/// Bounds on responses, `(response, min, max)`, as [`Objective::constraints`] holds them.
type Bounds = Vec<(String, Option<f64>, Option<f64>)>;

impl Checker<'_> {
    /// `objective.constraints`: each a known response with `min:`, `max:` or both, and
    /// a probability of passing a one-sided bound in (0, 0.5] when it is probabilistic.
    fn constraints(
        &self,
        objective: &ObjectiveFile,
        known: &impl Fn(&str, &str) -> Result<(), StudyError>,
    ) -> Result<(Bounds, Vec<Option<f64>>), StudyError> {
        let mut constraints = Vec::new();
        let mut probabilities = Vec::new();
        for (i, c) in objective.constraints.iter().enumerate() {
            let at = format!("objective.constraints[{i}]");
            known(&format!("{at}.response"), &c.response)?;
            if c.min.is_none() && c.max.is_none() {
                return Err(self.error(&at, "expected `min:`, `max:` or both"));
            }
            if let Some(p) = c.probability {
                if !(p > 0.0 && p <= 0.5) {
                    return Err(self.error(
                        &format!("{at}.probability"),
                        format!("expected a probability of passing the bound in (0, 0.5], got {p}"),
                    ));
                }
                if c.min.is_some() && c.max.is_some() {
                    return Err(self.error(
                        &format!("{at}.probability"),
                        "a probabilistic bound takes `min:` or `max:`, not both; write two constraints",
                    ));
                }
            }
            constraints.push((c.response.clone(), c.min, c.max));
            probabilities.push(c.probability);
        }
        Ok((constraints, probabilities))
    }
}
