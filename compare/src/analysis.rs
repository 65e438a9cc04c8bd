//! From the runs of a suite to means, standard errors, relative differences with
//! Welch intervals, verdicts and throughputs.
//!
//! The rule: for each compared response the relative difference is
//! `d = (mean_native − mean_reference) / |mean_reference|`, and its interval is
//! Welch's interval of `mean_native − mean_reference` divided by `|mean_reference|`
//! (the reference mean is treated as exact in the scaling; its standard error is in
//! the interval of the difference). With the tolerance `τ` of the response:
//! - **agree**: the whole interval lies inside `[−τ, τ]`;
//! - **regression**: the whole interval lies outside it (`low > τ` or `high < −τ`):
//!   the solvers differ by more than the tolerance at the stated confidence;
//! - **inconclusive**: the interval crosses `±τ` (too few seeds, or a difference near
//!   the tolerance). Not a failure, but the table says so.

use std::collections::BTreeMap;

use orch_metamodel::{welch_interval, SampleSummary};

/// The verdict on one response of one case.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Verdict {
    /// The interval lies inside ±tolerance.
    Agree,
    /// The interval crosses a tolerance bound.
    Inconclusive,
    /// The interval lies outside ±tolerance, or a run gave no value.
    Regression,
}

impl Verdict {
    /// The word stored and printed.
    pub fn as_str(self) -> &'static str {
        match self {
            Verdict::Agree => "agree",
            Verdict::Inconclusive => "inconclusive",
            Verdict::Regression => "regression",
        }
    }

    /// The verdict of a stored word.
    pub fn parse(word: &str) -> Option<Verdict> {
        [Verdict::Agree, Verdict::Inconclusive, Verdict::Regression]
            .into_iter()
            .find(|v| v.as_str() == word)
    }

    /// The verdict on `[low, high]` against `±tolerance` (see the module documentation).
    pub fn of_interval(low: f64, high: f64, tolerance: f64) -> Verdict {
        if !(low.is_finite() && high.is_finite()) {
            Verdict::Regression
        } else if low >= -tolerance && high <= tolerance {
            Verdict::Agree
        } else if low > tolerance || high < -tolerance {
            Verdict::Regression
        } else {
            Verdict::Inconclusive
        }
    }
}

/// One compared response of one case against one reference solver.
#[derive(Debug, Clone, PartialEq)]
pub struct ResponseComparison {
    /// The case.
    pub case: String,
    /// The response.
    pub response: String,
    /// The reference solver (`liggghts`).
    pub reference: String,
    /// The native kernel's replicates.
    pub native: SampleSummary,
    /// The reference solver's replicates.
    pub reference_summary: SampleSummary,
    /// `(native − reference) / |reference|`.
    pub relative_difference: f64,
    /// Lower end of its interval.
    pub low: f64,
    /// Upper end of its interval.
    pub high: f64,
    /// The tolerance on `|relative_difference|`.
    pub tolerance: f64,
    /// The verdict.
    pub verdict: Verdict,
}

/// Mean throughput of one solver over the runs of one case.
#[derive(Debug, Clone, PartialEq)]
pub struct Throughput {
    /// The case.
    pub case: String,
    /// The solver.
    pub solver: String,
    /// Mean particle-steps per second of the solver's loop.
    pub particle_steps_per_s: f64,
    /// Runs averaged.
    pub runs: usize,
}

/// What one run gave: its responses (the solver's figures included).
pub type RunValues = BTreeMap<String, f64>;

/// Compares `native` against `reference` replicates of one case for each response in
/// `tolerances`, at `confidence`. A response a run did not give is a regression with
/// NaN figures (the caller names the run and why).
pub fn compare_case(
    case: &str,
    reference: &str,
    native: &[RunValues],
    reference_runs: &[RunValues],
    tolerances: &BTreeMap<String, f64>,
    confidence: f64,
) -> Vec<ResponseComparison> {
    let values = |runs: &[RunValues], name: &str| -> Option<Vec<f64>> {
        runs.iter()
            .map(|r| r.get(name).copied().filter(|v| v.is_finite()))
            .collect()
    };
    let nan = SampleSummary {
        mean: f64::NAN,
        standard_error: f64::NAN,
        count: 0,
    };
    tolerances
        .iter()
        .map(|(name, &tolerance)| {
            let a = values(native, name).and_then(|v| SampleSummary::of(&v));
            let b = values(reference_runs, name).and_then(|v| SampleSummary::of(&v));
            let (relative_difference, low, high) = match (&a, &b) {
                (Some(a), Some(b)) => {
                    let w = welch_interval(a, b, confidence);
                    let scale = b.mean.abs();
                    (w.difference / scale, w.low / scale, w.high / scale)
                }
                _ => (f64::NAN, f64::NAN, f64::NAN),
            };
            ResponseComparison {
                case: case.to_string(),
                response: name.clone(),
                reference: reference.to_string(),
                native: a.unwrap_or(nan),
                reference_summary: b.unwrap_or(nan),
                relative_difference,
                low,
                high,
                tolerance,
                verdict: Verdict::of_interval(low, high, tolerance),
            }
        })
        .collect()
}

/// The mean of `name` over `runs` that give it, with their number.
pub fn mean_of(runs: &[RunValues], name: &str) -> (f64, usize) {
    let values: Vec<f64> = runs.iter().filter_map(|r| r.get(name).copied()).collect();
    let n = values.len();
    let mean = if n == 0 {
        f64::NAN
    } else {
        values.iter().sum::<f64>() / n as f64
    };
    (mean, n)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn runs(name: &str, values: &[f64]) -> Vec<RunValues> {
        values
            .iter()
            .map(|&v| BTreeMap::from([(name.to_string(), v)]))
            .collect()
    }

    #[test]
    fn the_rule_on_intervals() {
        assert_eq!(Verdict::of_interval(-0.05, 0.08, 0.1), Verdict::Agree);
        assert_eq!(Verdict::of_interval(0.05, 0.2, 0.1), Verdict::Inconclusive);
        assert_eq!(Verdict::of_interval(0.12, 0.3, 0.1), Verdict::Regression);
        assert_eq!(Verdict::of_interval(-0.3, -0.12, 0.1), Verdict::Regression);
        assert_eq!(Verdict::of_interval(-0.3, 0.3, 0.1), Verdict::Inconclusive);
        assert_eq!(
            Verdict::of_interval(f64::NAN, 0.0, 0.1),
            Verdict::Regression
        );
        for v in [Verdict::Agree, Verdict::Inconclusive, Verdict::Regression] {
            assert_eq!(Verdict::parse(v.as_str()), Some(v));
        }
    }

    #[test]
    fn close_samples_agree_and_shifted_ones_regress() {
        let tolerances = BTreeMap::from([("rate".to_string(), 0.1)]);
        let reference = runs("rate", &[1.00, 1.02, 0.98, 1.01]);
        let close = runs("rate", &[1.01, 0.99, 1.03, 1.00]);
        let c = compare_case("c", "ref", &close, &reference, &tolerances, 0.95);
        assert_eq!(c[0].verdict, Verdict::Agree, "{c:?}");
        assert!((c[0].relative_difference - 0.005 / 1.0025).abs() < 1e-12);
        let shifted = runs("rate", &[1.31, 1.29, 1.33, 1.30]);
        let c = compare_case("c", "ref", &shifted, &reference, &tolerances, 0.95);
        assert_eq!(c[0].verdict, Verdict::Regression, "{c:?}");
        assert!(c[0].low > 0.1 && c[0].low < c[0].relative_difference);
        let missing = runs("other", &[1.0, 1.0]);
        let c = compare_case("c", "ref", &missing, &reference, &tolerances, 0.95);
        assert_eq!(c[0].verdict, Verdict::Regression);
        assert!(c[0].relative_difference.is_nan());
    }
}
