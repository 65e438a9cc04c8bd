//! `stop_when:`: ending a run once the response a study is after is known well enough.
//!
//! While a design job runs, the driver reads its output every `check_every` (the
//! equipment's responses from the crossings written so far). When the response's 95 %
//! interval is narrower than the target at two checks in a row, it writes
//! [`STOP_FILE`] into the run directory with why; every solver's template checks for
//! that file (the native kernel's `stop_file`, a LIGGGHTS `shell test -e` between
//! chunks, the YADE script's sensor) and ends the run as if its end time had come. The
//! run succeeds, and its responses come from all it wrote. Two checks rather than one,
//! because an interval from the first few batches of a steady window can be narrow by
//! chance.

use std::collections::HashMap;
use std::path::Path;
use std::time::Instant;

use orch_adapters::RunResults;

use crate::study::{StopWhen, STOP_FILE};

/// Checks in a row the interval must pass before the run is stopped.
pub const NARROW_CHECKS: u32 = 2;

/// The response and its relative interval half-width in `results`, when both are
/// there and the response is not zero.
pub fn relative_ci95(results: &RunResults, stop: &StopWhen) -> Option<(f64, f64)> {
    let value_of = |name: &str| {
        results
            .responses
            .iter()
            .find(|(n, _)| n == name)
            .map(|&(_, v)| v)
    };
    let value = value_of(&stop.response)?;
    let half_width = value_of(&stop.ci95_response)?;
    (value != 0.0 && value.is_finite() && half_width.is_finite())
        .then(|| (value, (half_width / value).abs()))
}

/// What the stop file says, and what status shows for a run it stopped.
pub fn stop_reason(stop: &StopWhen, value: f64, relative: f64) -> String {
    format!(
        "stopped early: {} = {value:.5} ± {:.2} % (95 %), below the study's ± {:.2} % (stop_when)",
        stop.response,
        100.0 * relative,
        100.0 * stop.relative_ci95
    )
}

/// The stop file's reason when a run was asked to stop, else `None`.
pub fn stopped_early(run_dir: &Path) -> Option<String> {
    std::fs::read_to_string(run_dir.join(STOP_FILE))
        .ok()
        .map(|text| text.trim().to_string())
}

/// When each running job was last checked and how many checks in a row found its
/// interval narrow enough.
#[derive(Debug, Default)]
pub struct ConvergenceWatch {
    checked: HashMap<i64, (Instant, u32)>,
}

impl ConvergenceWatch {
    /// True when job `job_id` has not been checked for `stop.check_every`.
    pub fn due(&self, job_id: i64, stop: &StopWhen, now: Instant) -> bool {
        self.checked
            .get(&job_id)
            .is_none_or(|&(at, _)| now.duration_since(at) >= stop.check_every)
    }

    /// Records a check of job `job_id`; true when its interval has now been narrow
    /// enough at [`NARROW_CHECKS`] checks in a row.
    pub fn record(&mut self, job_id: i64, narrow: bool, now: Instant) -> bool {
        let entry = self.checked.entry(job_id).or_insert((now, 0));
        entry.0 = now;
        entry.1 = if narrow { entry.1 + 1 } else { 0 };
        entry.1 >= NARROW_CHECKS
    }

    /// Forgets job `job_id` (it ended, or was stopped).
    pub fn forget(&mut self, job_id: i64) {
        self.checked.remove(&job_id);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    fn stop() -> StopWhen {
        StopWhen {
            response: "discharge_rate".to_string(),
            ci95_response: "discharge_rate_ci95".to_string(),
            relative_ci95: 0.03,
            check_every: Duration::from_secs(5),
        }
    }

    fn results(pairs: &[(&str, f64)]) -> RunResults {
        RunResults {
            responses: pairs.iter().map(|&(n, v)| (n.to_string(), v)).collect(),
            ..RunResults::default()
        }
    }

    #[test]
    fn the_relative_interval_needs_both_responses_and_a_nonzero_value() {
        let both = results(&[("discharge_rate", 0.2), ("discharge_rate_ci95", 0.004)]);
        let (value, relative) = relative_ci95(&both, &stop()).unwrap();
        assert_eq!(value, 0.2);
        assert!((relative - 0.02).abs() < 1e-15);
        assert_eq!(
            relative_ci95(&results(&[("discharge_rate", 0.2)]), &stop()),
            None
        );
        let zero = results(&[("discharge_rate", 0.0), ("discharge_rate_ci95", 0.004)]);
        assert_eq!(relative_ci95(&zero, &stop()), None);
    }

    #[test]
    fn two_narrow_checks_in_a_row_stop_a_run_and_a_wide_one_starts_again() {
        let mut watch = ConvergenceWatch::default();
        let t0 = Instant::now();
        assert!(watch.due(7, &stop(), t0));
        assert!(!watch.record(7, true, t0));
        assert!(!watch.due(7, &stop(), t0 + Duration::from_secs(4)));
        let t1 = t0 + Duration::from_secs(5);
        assert!(watch.due(7, &stop(), t1));
        assert!(!watch.record(7, false, t1));
        assert!(!watch.record(7, true, t1 + Duration::from_secs(5)));
        assert!(watch.record(7, true, t1 + Duration::from_secs(10)));
        watch.forget(7);
        assert!(watch.due(7, &stop(), t1 + Duration::from_secs(10)));
    }

    #[test]
    fn the_reason_says_what_was_reached_against_what() {
        assert_eq!(
            stop_reason(&stop(), 0.21, 0.0212),
            "stopped early: discharge_rate = 0.21000 ± 2.12 % (95 %), below the study's ± 3.00 % (stop_when)"
        );
    }
}
