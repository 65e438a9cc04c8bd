//! Honest warnings about surfaces and optima, shared by `orch status`, `orch fit` and
//! `orch report`: a surface whose R²(σ_cross) is below 0.5 does not predict and its
//! optimum is no answer; a response that does not vary is said to be constant instead
//! of showing R² 1 and huge t-values; σ_cross shown as `–` says why; an optimum on a
//! face of the study file's factor limits says which range to widen.

use crate::store::{FactorRow, StoredFit, StoredRound};
use crate::surfaces::{self, Run};

/// Below this R²(σ_cross) a surface does not predict new runs.
pub const MIN_R2_CROSS: f64 = 0.5;

/// How a warning that an optimum is no answer begins.
pub const NOT_AN_ANSWER: &str = "this optimum is not an answer";

/// Leverage at or above this counts as 1 (as in `orch_metamodel::Fit`).
const SATURATED_LEVERAGE: f64 = 1.0 - 1e-10;

/// What can be said of one fitted surface.
#[derive(Debug, Clone, PartialEq)]
pub enum Verdict {
    /// Cross-validated with R²(σ_cross) ≥ 0.5.
    Predicts,
    /// The response has the same value in every run: nothing to fit.
    Constant {
        /// The value.
        value: f64,
    },
    /// R²(σ_cross) < 0.5: the surface does not predict new runs.
    DoesNotPredict {
        /// Its R²(σ_cross).
        r2_cross: f64,
    },
    /// σ_cross is not defined; `why` says why and what to do.
    NotCrossValidated {
        /// Why, for people.
        why: String,
    },
}

/// True when every value equals the first to 12 significant digits.
pub fn is_constant(y: &[f64]) -> bool {
    let Some(first) = y.first() else {
        return false;
    };
    let scale = y
        .iter()
        .fold(0.0_f64, |m, v| m.max(v.abs()))
        .max(f64::MIN_POSITIVE);
    y.iter().all(|v| (v - first).abs() <= 1e-12 * scale)
}

/// Judges a stored fit from its observed values `y` (the round's design runs) and,
/// when known, the runs' leverages.
pub fn judge(fit: &StoredFit, y: &[f64], leverages: Option<&[f64]>) -> Verdict {
    // Without observations, a defined PRESS with no σ_cross means no spread at all.
    let constant = if y.is_empty() {
        fit.press.is_some() && fit.sigma_cross.is_none()
    } else {
        is_constant(y)
    };
    if constant {
        let value = y
            .first()
            .copied()
            .or_else(|| fit.terms.first().map(|t| t.1));
        return Verdict::Constant {
            value: value.unwrap_or(f64::NAN),
        };
    }
    match fit.r2_cross {
        Some(r2) if r2 < MIN_R2_CROSS => Verdict::DoesNotPredict { r2_cross: r2 },
        Some(_) => Verdict::Predicts,
        None => Verdict::NotCrossValidated {
            why: no_sigma_cross_reason(fit, leverages),
        },
    }
}

fn no_sigma_cross_reason(fit: &StoredFit, leverages: Option<&[f64]>) -> String {
    let terms = fit.terms.len() as i64;
    if terms > 0 && fit.runs <= terms {
        return format!(
            "{} runs for {terms} terms: every run has leverage 1 and none can be left out; add runs (more levels or points, replicates, center_points: 3) or lower the order",
            fit.runs
        );
    }
    let saturated = leverages
        .map(|h| h.iter().filter(|&&h| h >= SATURATED_LEVERAGE).count())
        .unwrap_or(0);
    let which = if saturated > 0 {
        format!("{saturated} run(s) have")
    } else {
        "a run has".to_string()
    };
    format!(
        "{which} leverage 1 (a point that alone fixes a term, as a single centre point does), so leave-one-out cannot predict it; use center_points: 3"
    )
}

impl Verdict {
    /// True for a constant response.
    pub fn is_constant(&self) -> bool {
        matches!(self, Verdict::Constant { .. })
    }

    /// True when the surface's optimum may be presented as an answer.
    pub fn trusted(&self) -> bool {
        matches!(self, Verdict::Predicts)
    }

    /// Why an optimum on this surface is no answer, in a few words; `None` when it is one.
    pub fn short(&self, response: &str) -> Option<String> {
        match self {
            Verdict::Predicts => None,
            Verdict::Constant { .. } => Some(format!("{response} is constant")),
            Verdict::DoesNotPredict { r2_cross } => Some(format!(
                "the surface of {response} does not predict (R²(σ_cross) {r2_cross:.2} < {MIN_R2_CROSS})"
            )),
            Verdict::NotCrossValidated { .. } => Some(format!(
                "the surface of {response} is not cross-validated (σ_cross –)"
            )),
        }
    }

    /// The warning to show about `response`, if any.
    pub fn warning(&self, response: &str) -> Option<String> {
        match self {
            Verdict::Predicts => None,
            Verdict::Constant { value } => Some(format!(
                "{response} does not vary: it is {} in every run, so there is nothing to fit (R² and t-values mean nothing); choose factors that change it, or drop it from responses",
                crate::numbers::number(*value)
            )),
            Verdict::DoesNotPredict { r2_cross } => Some(format!(
                "the surface of {response} does not predict: R²(σ_cross) {r2_cross:.2} < {MIN_R2_CROSS}, so neither its predictions nor an optimum on it are an answer; add runs or replicates, narrow the box, or lower the order"
            )),
            Verdict::NotCrossValidated { why } => Some(format!("σ_cross of {response} is –: {why}")),
        }
    }
}

/// The fits an optimum's objective is made of: the fit of that name, or those named
/// inside a weighted objective's name.
fn objective_fits<'a>(round: &'a StoredRound, objective: &str) -> Vec<&'a StoredFit> {
    let exact: Vec<&StoredFit> = round
        .fits
        .iter()
        .filter(|f| f.response == objective)
        .collect();
    if !exact.is_empty() {
        return exact;
    }
    round
        .fits
        .iter()
        .filter(|f| objective.contains(f.response.as_str()))
        .collect()
}

/// Warnings about a round's optimum: it is no answer when a surface of its objective
/// does not predict (or is constant or not cross-validated), and it says which range to
/// widen when it lies on a face of the study file's factor limits.
pub fn optimum_warnings(round: &StoredRound, factors: &[FactorRow], runs: &[Run]) -> Vec<String> {
    let Some((objective, _, _, natural)) = &round.optimum else {
        return Vec::new();
    };
    let mut out = Vec::new();
    for fit in objective_fits(round, objective) {
        let y = surfaces::observed(runs, &fit.response).y;
        let verdict = judge(fit, &y, None);
        if !verdict.trusted() {
            out.push(format!(
                "{NOT_AN_ANSWER}: {}",
                verdict.short(&fit.response).unwrap_or_default()
            ));
        }
    }
    out.extend(limit_faces(natural, factors));
    out
}

/// One sentence per factor whose value lies on its lower or upper limit of the study
/// file, saying which way to widen its range.
pub fn limit_faces(natural: &[f64], factors: &[FactorRow]) -> Vec<String> {
    let mut out = Vec::new();
    // A text factor has no beyond: its first and last levels are not limits.
    for (value, f) in natural
        .iter()
        .zip(factors)
        .filter(|(_, f)| f.levels.is_none())
    {
        let tolerance = 1e-9 * (f.max - f.min).abs().max(f64::MIN_POSITIVE);
        let side = if (value - f.min).abs() <= tolerance {
            Some(("lower", "below", f.min))
        } else if (value - f.max).abs() <= tolerance {
            Some(("upper", "above", f.max))
        } else {
            None
        };
        if let Some((face, way, limit)) = side {
            out.push(format!(
                "the optimum lies on the {face} limit of {} ({} {}): the best may be beyond it; widen {}'s range {way} {} if the equipment allows",
                f.name,
                crate::numbers::number(limit),
                f.unit,
                f.name,
                crate::numbers::number(limit),
            ));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use orch_metamodel::FactorRange;

    fn fit(r2_cross: Option<f64>, runs: i64, terms: usize) -> StoredFit {
        StoredFit {
            response: "rate".into(),
            basis: "legendre".into(),
            order: 2,
            runs,
            r2: Some(0.99),
            adjusted_r2: None,
            sigma_cross: r2_cross.map(|r| 100.0 * (1.0 - r).sqrt()),
            r2_cross,
            press: r2_cross.map(|_| 1.0),
            test_runs: 0,
            sigma_test: None,
            r2_test: None,
            error: None,
            terms: (0..terms)
                .map(|i| (format!("t{i}"), 1.0, None, None))
                .collect(),
            ..Default::default()
        }
    }

    #[test]
    fn a_surface_below_half_r2_cross_does_not_predict_and_says_so() {
        let verdict = judge(&fit(Some(0.3), 9, 6), &[1.0, 2.0, 3.0], None);
        assert_eq!(verdict, Verdict::DoesNotPredict { r2_cross: 0.3 });
        assert!(!verdict.trusted());
        let text = verdict.warning("rate").unwrap();
        assert!(
            text.contains("does not predict") && text.contains("0.30"),
            "{text}"
        );
        assert_eq!(
            judge(&fit(Some(0.8), 9, 6), &[1.0, 2.0], None),
            Verdict::Predicts
        );
    }

    #[test]
    fn a_response_equal_in_every_run_is_constant_not_a_perfect_fit() {
        let verdict = judge(&fit(None, 9, 6), &[1.0; 9], None);
        assert_eq!(verdict, Verdict::Constant { value: 1.0 });
        let text = verdict.warning("fraction").unwrap();
        assert!(
            text.contains("does not vary") && text.contains("1 in every run"),
            "{text}"
        );
        // From the stored numbers alone: a PRESS without σ_cross means no spread.
        let mut stored = fit(None, 9, 6);
        stored.press = Some(0.0);
        assert!(judge(&stored, &[], None).is_constant());
        assert!(!is_constant(&[1.0, 1.0 + 1e-9]));
    }

    #[test]
    fn a_missing_sigma_cross_says_why() {
        let saturated = judge(&fit(None, 6, 6), &[1.0, 2.0], None);
        let text = saturated.warning("rate").unwrap();
        assert!(
            text.contains("6 runs for 6 terms") && text.contains("center_points: 3"),
            "{text}"
        );
        let centre = judge(&fit(None, 9, 6), &[1.0, 2.0], Some(&[0.5, 1.0, 0.3]));
        let text = centre.warning("rate").unwrap();
        assert!(
            text.contains("1 run(s) have leverage 1") && text.contains("centre point"),
            "{text}"
        );
    }

    fn factors() -> Vec<FactorRow> {
        vec![
            FactorRow {
                name: "outlet_diameter".into(),
                min: 0.02,
                max: 0.028,
                unit: "m".into(),
                levels: None,
            },
            FactorRow {
                name: "amplitude".into(),
                min: 0.0,
                max: 0.0008,
                unit: "m".into(),
                levels: None,
            },
        ]
    }

    #[test]
    fn an_optimum_on_a_limit_says_which_range_to_widen() {
        let faces = limit_faces(&[0.028, 0.0004], &factors());
        assert_eq!(faces.len(), 1, "{faces:?}");
        assert!(
            faces[0].contains("upper limit of outlet_diameter (0.028 m)"),
            "{}",
            faces[0]
        );
        assert!(
            faces[0].contains("widen outlet_diameter's range above 0.028"),
            "{}",
            faces[0]
        );
        let faces = limit_faces(&[0.024, 0.0], &factors());
        assert!(
            faces[0].contains("lower limit of amplitude") && faces[0].contains("below"),
            "{faces:?}"
        );
        assert!(limit_faces(&[0.024, 0.0004], &factors()).is_empty());
    }

    #[test]
    fn an_optimum_of_a_surface_that_does_not_predict_is_not_an_answer() {
        let round = StoredRound {
            round: 0,
            ranges: vec![
                FactorRange {
                    min: 0.02,
                    max: 0.028,
                },
                FactorRange {
                    min: 0.0,
                    max: 0.0008,
                },
            ],
            fits: vec![fit(Some(0.1), 9, 6)],
            optimum: Some(("rate".into(), "maximise".into(), 1.0, vec![0.024, 0.0004])),
            uncertainty: None,
            decision: None,
            ..Default::default()
        };
        let warnings = optimum_warnings(&round, &factors(), &[]);
        assert_eq!(warnings.len(), 1, "{warnings:?}");
        assert_eq!(
            warnings[0],
            "this optimum is not an answer: the surface of rate does not predict (R²(σ_cross) 0.10 < 0.5)"
        );
        let mut good = round.clone();
        good.fits = vec![fit(Some(0.9), 9, 6)];
        assert!(optimum_warnings(&good, &factors(), &[]).is_empty());
    }
}
