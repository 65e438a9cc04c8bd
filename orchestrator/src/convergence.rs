//! `stop_when:`: ending a run once the response a study is after is known well enough.
//!
//! While a design job runs, the driver reads its output every `check_every` (the
//! equipment's responses from the crossings written so far). When the response's 95 %
//! interval is narrower than the target at two checks in a row, it writes
//! [`STOP_FILE`] into the run directory with why; every solver's template checks for
//! that file (the native kernel's `stop_file`, a LIGGGHTS `shell test -e` between
//! chunks, the YADE script's sensor) and ends the run as if its end time had come. The
//! run succeeds, and its responses come from all it wrote. Several checks rather than
//! one, each on more output than the one before (a check that finds the same values
//! as the last, because the run wrote nothing new, does not count), because an interval
//! from the first few batches of a steady window can be narrow by chance.

use std::collections::HashMap;
use std::path::Path;
use std::time::Instant;

use orch_adapters::RunResults;

use crate::study::{StopWhen, STOP_FILE};

/// Checks in a row, each on new output, the interval must pass before the run is
/// stopped.
pub const NARROW_CHECKS: u32 = 3;

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

/// `x` with the fewest decimals, from two to eight, whose written value `reads`
/// accepts (eight when none does).
fn with_decimals_until(x: f64, reads: impl Fn(f64) -> bool) -> String {
    (2..=8)
        .map(|decimals| format!("{x:.decimals$}"))
        .find(|text| text.parse().is_ok_and(&reads))
        .unwrap_or_else(|| format!("{x:.8}"))
}

/// What the stop file says, and what status shows for a run it stopped.
///
/// Both percentages are written with as many decimals as it takes to read true: the
/// target as given (8.125 % is "8.125 %"), the reached interval below the target as
/// written (7.9996 % is "7.9996 %", not "8.00 %, below the study's ± 8.00 %").
pub fn stop_reason(stop: &StopWhen, value: f64, relative: f64) -> String {
    let (reached, target) = (100.0 * relative, 100.0 * stop.relative_ci95);
    let target_text = with_decimals_until(target, |shown| (shown - target).abs() <= 1e-9);
    let target_shown: f64 = target_text.parse().unwrap_or(target);
    let reached_text = with_decimals_until(reached, |shown| shown < target_shown);
    format!(
        "stopped early: {} = {value:.5} ± {reached_text} % (95 %), below the study's ± {target_text} % (stop_when)",
        stop.response,
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
    checked: HashMap<i64, Checked>,
}

/// The last check of a job.
#[derive(Debug, Clone, Copy)]
struct Checked {
    at: Instant,
    narrow_in_a_row: u32,
    /// The response and interval it found, to tell new output from old.
    seen: Option<(f64, f64)>,
}

impl ConvergenceWatch {
    /// True when job `job_id` has not been checked for `stop.check_every`.
    pub fn due(&self, job_id: i64, stop: &StopWhen, now: Instant) -> bool {
        self.checked
            .get(&job_id)
            .is_none_or(|c| now.duration_since(c.at) >= stop.check_every)
    }

    /// Records a check of job `job_id` that found `seen` (the response and its
    /// relative interval, if defined) and whether that is `narrow` enough; true when
    /// the interval has now been narrow at [`NARROW_CHECKS`] checks in a row. A check
    /// that found exactly what the last one found counts neither way.
    pub fn record(
        &mut self,
        job_id: i64,
        seen: Option<(f64, f64)>,
        narrow: bool,
        now: Instant,
    ) -> bool {
        let entry = self.checked.entry(job_id).or_insert(Checked {
            at: now,
            narrow_in_a_row: 0,
            seen: None,
        });
        entry.at = now;
        if seen.is_some() && seen == entry.seen {
            return false;
        }
        entry.seen = seen;
        entry.narrow_in_a_row = if narrow { entry.narrow_in_a_row + 1 } else { 0 };
        entry.narrow_in_a_row >= NARROW_CHECKS
    }

    /// Forgets job `job_id` (it ended, or was stopped).
    pub fn forget(&mut self, job_id: i64) {
        self.checked.remove(&job_id);
    }

    /// Forgets every job for which `keep` is false (those no longer running).
    pub fn retain(&mut self, keep: impl Fn(i64) -> bool) {
        self.checked.retain(|&job_id, _| keep(job_id));
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
    fn narrow_checks_on_new_output_in_a_row_stop_a_run_and_a_wide_one_starts_again() {
        let mut watch = ConvergenceWatch::default();
        let t = |s: u64| Instant::now() + Duration::from_secs(s);
        let t0 = t(0);
        assert!(watch.due(7, &stop(), t0));
        assert!(!watch.record(7, Some((0.2, 0.02)), true, t0));
        assert!(!watch.due(7, &stop(), t0 + Duration::from_secs(4)));
        assert!(watch.due(7, &stop(), t0 + Duration::from_secs(5)));
        // A wide interval starts the count again.
        assert!(!watch.record(7, Some((0.2, 0.05)), false, t(5)));
        assert!(!watch.record(7, Some((0.21, 0.02)), true, t(10)));
        assert!(!watch.record(7, Some((0.2, 0.021)), true, t(15)));
        // The same values again: the run wrote nothing new; it does not count.
        assert!(!watch.record(7, Some((0.2, 0.021)), true, t(20)));
        assert!(watch.record(7, Some((0.2, 0.019)), true, t(25)));
        watch.forget(7);
        assert!(watch.due(7, &stop(), t(25)));
    }

    #[test]
    fn retain_forgets_the_jobs_no_longer_kept_and_only_those() {
        let t0 = Instant::now();
        let mut watch = ConvergenceWatch::default();
        for job in [1, 2, 3] {
            watch.record(job, Some((0.2, 0.05)), false, t0);
        }
        watch.retain(|job| job != 2);
        assert!(watch.due(2, &stop(), t0));
        assert!(!watch.due(1, &stop(), t0));
        assert!(!watch.due(3, &stop(), t0));
    }

    #[test]
    fn the_reason_says_what_was_reached_against_what() {
        assert_eq!(
            stop_reason(&stop(), 0.21, 0.0212),
            "stopped early: discharge_rate = 0.21000 ± 2.12 % (95 %), below the study's ± 3.00 % (stop_when)"
        );
    }

    #[test]
    fn an_interval_just_below_the_target_is_not_rounded_up_to_it() {
        // A LIGGGHTS run in CI stopped at 7.9996 % and said "± 8.00 %, below ± 8.00 %".
        let eight = StopWhen {
            relative_ci95: 0.08,
            ..stop()
        };
        assert_eq!(
            stop_reason(&eight, 0.10289, 0.079996),
            "stopped early: discharge_rate = 0.10289 ± 7.9996 % (95 %), below the study's ± 8.00 % (stop_when)"
        );
        assert!(stop_reason(&eight, 0.1, 0.0799).contains("± 7.99 % (95 %)"));
        // A target with more than two decimals is written as given (two would make
        // it 8.13 or 8.12), and the reached interval below it as written.
        let finer = StopWhen {
            relative_ci95: 0.08125,
            ..stop()
        };
        let reason = stop_reason(&finer, 0.1, 0.08124);
        assert!(
            reason.contains("± 8.12 % (95 %), below the study's ± 8.125 %"),
            "{reason}"
        );
    }
}
