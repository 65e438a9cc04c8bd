//! The history of `orch compare`: an outcome as store records, changes since the last
//! comparable run, and the HTML page of agreement and speed over time.

use std::collections::BTreeMap;

use orch_page::{html, plots};
use orch_store::{ResponseRecord, SpeedRecord, StoredComparison};

use super::{SuiteOutcome, NATIVE};

/// The store's records of `outcome`.
pub fn records(outcome: &SuiteOutcome) -> (Vec<ResponseRecord>, Vec<SpeedRecord>) {
    let responses = outcome
        .responses
        .iter()
        .map(|r| ResponseRecord {
            case: r.case.clone(),
            response: r.response.clone(),
            reference_solver: r.reference.clone(),
            native: [r.native.mean, r.native.standard_error],
            native_runs: r.native.count as i64,
            reference: [r.reference_summary.mean, r.reference_summary.standard_error],
            reference_runs: r.reference_summary.count as i64,
            relative_difference: r.relative_difference,
            interval: [r.low, r.high],
            tolerance: r.tolerance,
            verdict: r.verdict.as_str().to_string(),
        })
        .collect();
    let speeds = outcome
        .speeds
        .iter()
        .map(|s| SpeedRecord {
            case: s.case.clone(),
            solver: s.solver.clone(),
            particle_steps_per_s: s.particle_steps_per_s,
            runs: s.runs as i64,
        })
        .collect();
    (responses, speeds)
}

/// `solver=version` pairs joined by `, `.
pub fn versions_text(versions: &BTreeMap<String, String>) -> String {
    versions
        .iter()
        .map(|(s, v)| format!("{s}={v}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Responses whose relative difference moved by more than their tolerance since the
/// previous run of the same suite selection without perturbation, as sentences.
/// `history` is oldest first and ends with the run judged.
pub fn changes(history: &[StoredComparison]) -> Vec<String> {
    let Some((latest, earlier)) = history.split_last() else {
        return Vec::new();
    };
    let Some(previous) = earlier.iter().rev().find(|c| {
        c.record.suite == latest.record.suite
            && c.record.quick == latest.record.quick
            && c.record.perturbation.is_empty()
    }) else {
        return Vec::new();
    };
    let mut found = Vec::new();
    for r in &latest.responses {
        let Some(p) = previous.responses.iter().find(|p| {
            p.case == r.case && p.response == r.response && p.reference_solver == r.reference_solver
        }) else {
            continue;
        };
        let moved = r.relative_difference - p.relative_difference;
        if moved.is_nan() || moved.abs() > r.tolerance {
            found.push(format!(
                "{} {} against {}: the relative difference moved from {:+.1} % to {:+.1} % since run {} ({}), more than the tolerance {:.0} %",
                r.case,
                r.response,
                r.reference_solver,
                100.0 * p.relative_difference,
                100.0 * r.relative_difference,
                previous.id,
                previous.record.git_commit.as_deref().unwrap_or("no commit"),
                100.0 * r.tolerance
            ));
        }
    }
    found
}

/// How much slower than its history the native kernel may run before a comparison
/// fails: 5 %.
pub const SLOWDOWN_TOLERANCE: f64 = 0.05;

/// How many earlier clean runs the speed is judged against (their median).
const SPEED_HISTORY: usize = 5;

/// The native kernel's speed on `case` in `run`, divided by the yardstick's: the first
/// reference solver (by name) that also ran `case` in the same run, since runs on a
/// shared machine slow down together; the absolute speed when `yardstick` is `None`.
fn native_speed(run: &StoredComparison, case: &str, yardstick: Option<&str>) -> Option<f64> {
    let speed = |solver: &str| {
        run.speeds
            .iter()
            .find(|s| s.case == case && s.solver == solver)
            .map(|s| s.particle_steps_per_s)
            .filter(|v| v.is_finite() && *v > 0.0)
    };
    let native = speed(NATIVE)?;
    match yardstick {
        Some(reference) => Some(native / speed(reference)?),
        None => Some(native),
    }
}

/// Cases on which the native kernel ran more than [`SLOWDOWN_TOLERANCE`] slower in the
/// latest run of `history` (oldest first) than the median of up to five earlier clean
/// runs of the same suite selection, as sentences. The speed is measured against a
/// reference solver run in the same invocation where one ran in both (machine noise
/// cancels); otherwise absolute, and the sentence says so. A perturbed run, or one that
/// made no native run of a case, is not judged.
pub fn slowdowns(history: &[StoredComparison]) -> Vec<String> {
    let Some((latest, earlier)) = history.split_last() else {
        return Vec::new();
    };
    if !latest.record.perturbation.is_empty() {
        return Vec::new();
    }
    let clean: Vec<&StoredComparison> = earlier
        .iter()
        .rev()
        .filter(|c| {
            c.record.suite == latest.record.suite
                && c.record.quick == latest.record.quick
                && c.record.perturbation.is_empty()
        })
        .collect();
    let mut cases: Vec<&str> = latest
        .speeds
        .iter()
        .filter(|s| s.solver == NATIVE)
        .map(|s| s.case.as_str())
        .collect();
    cases.dedup();
    let mut found = Vec::new();
    for case in cases {
        let mut references: Vec<&str> = latest
            .speeds
            .iter()
            .filter(|s| s.case == case && s.solver != NATIVE)
            .map(|s| s.solver.as_str())
            .collect();
        references.sort_unstable();
        let judged = references.iter().find_map(|&reference| {
            let past: Vec<f64> = clean
                .iter()
                .filter_map(|c| native_speed(c, case, Some(reference)))
                .take(SPEED_HISTORY)
                .collect();
            let now = native_speed(latest, case, Some(reference))?;
            (!past.is_empty()).then_some((Some(reference), now, past))
        });
        let judged = judged.or_else(|| {
            let past: Vec<f64> = clean
                .iter()
                .filter_map(|c| native_speed(c, case, None))
                .take(SPEED_HISTORY)
                .collect();
            let now = native_speed(latest, case, None)?;
            (!past.is_empty()).then_some((None, now, past))
        });
        let Some((yardstick, now, mut past)) = judged else {
            continue;
        };
        past.sort_by(f64::total_cmp);
        let middle = past.len() / 2;
        let baseline = if past.len() % 2 == 1 {
            past[middle]
        } else {
            0.5 * (past[middle - 1] + past[middle])
        };
        if now < (1.0 - SLOWDOWN_TOLERANCE) * baseline {
            let measure = match yardstick {
                Some(reference) => format!("its speed over {reference}'s in the same run"),
                None => "its absolute speed (no reference solver ran this case in both)".into(),
            };
            found.push(format!(
                "{case}: the native kernel is {:.1} % slower than the median of its last {} clean runs, by {measure}: {now:.4} against {baseline:.4}; more than {:.0} % fails the comparison",
                100.0 * (1.0 - now / baseline),
                past.len(),
                100.0 * SLOWDOWN_TOLERANCE
            ));
        }
    }
    found
}

/// Days since the Unix epoch, for the time axis.
fn days(seconds: f64) -> f64 {
    seconds / 86_400.0
}

/// The HTML page of the history: the latest run's table, changes, and agreement and
/// speed over time.
pub fn page(history: &[StoredComparison]) -> String {
    let mut body = String::from("<h1>Native kernel against the reference solvers</h1>\n");
    let Some(latest) = history.last() else {
        body.push_str("<p>No comparison has run yet: <code>orch compare</code>.</p>");
        return html::page("orch compare", &body);
    };
    let record = &latest.record;
    body.push_str(&format!(
        "<p>Latest run {} at {} s since the epoch, commit {}, solvers {}, {} suite {}{}, wall time {:.0} s: <b>{}</b>.</p>\n",
        latest.id,
        record.started_at.round(),
        html::escape(record.git_commit.as_deref().unwrap_or("unknown")),
        html::escape(&record.solver_versions),
        if record.quick { "quick" } else { "full" },
        html::escape(&record.suite),
        if record.perturbation.is_empty() {
            String::new()
        } else {
            format!(", native perturbed by {}", html::escape(&record.perturbation))
        },
        record.wall_time_s,
        html::escape(&record.verdict)
    ));
    let changes = changes(history);
    for change in changes.iter().chain(&slowdowns(history)) {
        body.push_str(&format!("<p class=\"warn\">{}</p>\n", html::escape(change)));
    }
    let headers: Vec<String> = [
        "case",
        "response",
        "reference",
        "native mean",
        "± se",
        "reference mean",
        "± se",
        "difference",
        "95 % interval",
        "tolerance",
        "verdict",
    ]
    .map(String::from)
    .to_vec();
    let pct = |v: f64| format!("{:+.1} %", 100.0 * v);
    let rows: Vec<Vec<String>> = latest
        .responses
        .iter()
        .map(|r| {
            vec![
                html::escape(&r.case),
                html::escape(&r.response),
                html::escape(&r.reference_solver),
                html::number(r.native[0]),
                html::number(r.native[1]),
                html::number(r.reference[0]),
                html::number(r.reference[1]),
                pct(r.relative_difference),
                format!("[{}, {}]", pct(r.interval[0]), pct(r.interval[1])),
                format!("{:.0} %", 100.0 * r.tolerance),
                html::escape(&r.verdict),
            ]
        })
        .collect();
    body.push_str("<h2>Agreement</h2>\n");
    body.push_str(&html::table(&headers, &rows));
    let speed_headers: Vec<String> = ["case", "solver", "particle-steps/s", "runs"]
        .map(String::from)
        .to_vec();
    let speed_rows: Vec<Vec<String>> = latest
        .speeds
        .iter()
        .map(|s| {
            vec![
                html::escape(&s.case),
                html::escape(&s.solver),
                html::number(s.particle_steps_per_s),
                s.runs.to_string(),
            ]
        })
        .collect();
    body.push_str("<h2>Speed</h2>\n");
    body.push_str(&html::table(&speed_headers, &speed_rows));
    // Over time: unperturbed runs only.
    let clean: Vec<&StoredComparison> = history
        .iter()
        .filter(|c| c.record.perturbation.is_empty())
        .collect();
    if clean.len() >= 2 {
        body.push_str(&over_time(&clean));
    }
    let history_headers: Vec<String> = [
        "run",
        "started at, s",
        "commit",
        "solvers",
        "suite",
        "perturbation",
        "wall time s",
        "verdict",
    ]
    .map(String::from)
    .to_vec();
    let history_rows: Vec<Vec<String>> = history
        .iter()
        .rev()
        .map(|c| {
            vec![
                c.id.to_string(),
                format!("{:.0}", c.record.started_at),
                html::escape(c.record.git_commit.as_deref().unwrap_or("–")),
                html::escape(&c.record.solver_versions),
                format!(
                    "{}{}",
                    html::escape(&c.record.suite),
                    if c.record.quick { " (quick)" } else { "" }
                ),
                html::escape(&c.record.perturbation),
                format!("{:.0}", c.record.wall_time_s),
                html::escape(&c.record.verdict),
            ]
        })
        .collect();
    body.push_str("<h2>Every run</h2>\n");
    body.push_str(&html::table(&history_headers, &history_rows));
    html::page("orch compare", &body)
}

/// The "Over time" section: each response's relative difference and the throughput
/// ratio, per clean (unperturbed) run.
fn over_time(clean: &[&StoredComparison]) -> String {
    let mut body = String::new();
    body.push_str("<h2>Over time</h2>\n");
    let mut agreement: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
    let mut ratio: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
    for c in clean {
        let t = days(c.record.started_at);
        for r in c
            .responses
            .iter()
            .filter(|r| r.relative_difference.is_finite())
        {
            agreement
                .entry(format!(
                    "{} {} / {}",
                    r.case, r.response, r.reference_solver
                ))
                .or_default()
                .push((t, 100.0 * r.relative_difference));
        }
        for s in c.speeds.iter().filter(|s| s.solver != NATIVE) {
            let native = c
                .speeds
                .iter()
                .find(|n| n.case == s.case && n.solver == NATIVE)
                .map_or(f64::NAN, |n| n.particle_steps_per_s);
            let value = native / s.particle_steps_per_s;
            if value.is_finite() {
                ratio
                    .entry(format!("{} native / {}", s.case, s.solver))
                    .or_default()
                    .push((t, value));
            }
        }
    }
    let agreement: Vec<(String, Vec<(f64, f64)>)> = agreement.into_iter().collect();
    let ratio: Vec<(String, Vec<(f64, f64)>)> = ratio.into_iter().collect();
    body.push_str(&html::figure(
        &plots::lines(
            "relative difference",
            "days since 1970",
            "native − reference, %",
            &agreement,
            &[],
            None,
            900,
        ),
        "Relative difference of each response, native against reference, per run.",
    ));
    body.push_str(&html::figure(
        &plots::lines(
            "speed ratio",
            "days since 1970",
            "native / reference throughput",
            &ratio,
            &[],
            None,
            900,
        ),
        "Throughput of the native kernel over the reference's, measured in the same run.",
    ));
    body
}

#[cfg(test)]
mod tests {
    use super::*;
    use orch_store::ComparisonRecord;

    fn run(id: i64, difference: f64, perturbation: &str) -> StoredComparison {
        timed(id, difference, perturbation, 4e6, Some(2e6))
    }

    fn timed(
        id: i64,
        difference: f64,
        perturbation: &str,
        native: f64,
        reference: Option<f64>,
    ) -> StoredComparison {
        StoredComparison {
            id,
            record: ComparisonRecord {
                started_at: 1.0e9 + 86_400.0 * id as f64,
                wall_time_s: 40.0,
                git_commit: Some(format!("commit{id}")),
                suite: "suite.yaml".into(),
                quick: true,
                perturbation: perturbation.into(),
                solver_versions: "liggghts=3.8.0, native=0.1.0".into(),
                confidence: 0.95,
                verdict: "agree".into(),
            },
            responses: vec![ResponseRecord {
                case: "c".into(),
                response: "rate".into(),
                reference_solver: "liggghts".into(),
                native: [1.0, 0.01],
                native_runs: 3,
                reference: [1.0, 0.01],
                reference_runs: 3,
                relative_difference: difference,
                interval: [difference - 0.02, difference + 0.02],
                tolerance: 0.1,
                verdict: "agree".into(),
            }],
            speeds: std::iter::once(SpeedRecord {
                case: "c".into(),
                solver: NATIVE.into(),
                particle_steps_per_s: native,
                runs: 3,
            })
            .chain(reference.map(|v| SpeedRecord {
                case: "c".into(),
                solver: "liggghts".into(),
                particle_steps_per_s: v,
                runs: 3,
            }))
            .collect(),
        }
    }

    #[test]
    fn a_move_beyond_the_tolerance_since_the_last_clean_run_is_flagged() {
        // The perturbed run 2 is skipped: run 3 is compared with run 1.
        let history = [
            run(1, 0.01, ""),
            run(2, 0.5, "density=1.3"),
            run(3, 0.05, ""),
        ];
        assert!(changes(&history).is_empty());
        let history = [
            run(1, 0.01, ""),
            run(2, 0.0, "density=1.3"),
            run(3, 0.2, ""),
        ];
        let found = changes(&history);
        assert_eq!(found.len(), 1, "{found:?}");
        assert!(found[0].contains("c rate against liggghts"), "{}", found[0]);
        assert!(found[0].contains("run 1 (commit1)"), "{}", found[0]);
        let html = page(&history);
        assert!(
            html.contains("Over time") && html.contains("<svg"),
            "{html}"
        );
        assert!(html.contains("+20.0 %"));
        assert!(page(&[]).contains("No comparison has run yet"));
    }

    #[test]
    fn a_native_slowdown_beyond_5_percent_against_liggghts_in_the_same_run_fails() {
        // Ratios 2.0, 2.1, 1.9 before: median 2.0. The machine got slower for both
        // (ratio 1.96, −2 %): fine. The kernel got slower alone (1.8, −10 %): flagged.
        let before = || {
            vec![
                timed(1, 0.0, "", 4.0e6, Some(2e6)),
                timed(2, 0.0, "", 4.2e6, Some(2e6)),
                timed(3, 0.0, "", 3.8e6, Some(2e6)),
            ]
        };
        let mut history = before();
        history.push(timed(4, 0.0, "", 2.94e6, Some(1.5e6)));
        assert!(slowdowns(&history).is_empty(), "{:?}", slowdowns(&history));
        let mut history = before();
        history.push(timed(4, 0.0, "", 3.6e6, Some(2e6)));
        let found = slowdowns(&history);
        assert_eq!(found.len(), 1, "{found:?}");
        assert!(found[0].contains("10.0 % slower") && found[0].contains("over liggghts's"));
        assert!(
            page(&history).contains("10.0 % slower"),
            "the page says it too"
        );
        // A perturbed run is not judged, nor is a first run.
        let mut history = before();
        history.push(timed(4, 0.0, "density=1.3", 1e6, Some(2e6)));
        assert!(slowdowns(&history).is_empty());
        assert!(slowdowns(&[timed(1, 0.0, "", 1e6, Some(2e6))]).is_empty());
    }

    #[test]
    fn without_a_reference_run_the_absolute_speed_is_judged_and_said_to_be() {
        // LIGGGHTS's runs were reused (no speed this time): absolute native speed.
        let mut history = vec![
            timed(1, 0.0, "", 4.0e6, Some(2e6)),
            timed(2, 0.0, "", 4.0e6, None),
        ];
        history.push(timed(3, 0.0, "", 3.9e6, None));
        assert!(slowdowns(&history).is_empty());
        history.push(timed(4, 0.0, "", 3.0e6, None));
        let found = slowdowns(&history);
        assert_eq!(found.len(), 1, "{found:?}");
        assert!(found[0].contains("absolute speed"), "{}", found[0]);
    }
}
