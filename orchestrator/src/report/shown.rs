//! Which runs the report shows of a study with more than a chart can draw or a page
//! can list: a fixed number, spread evenly over the study's jobs in id order (so over
//! its points and replicates, the first and the last included), the same every time
//! the report is written. A study with fewer runs shows every one, as before the cap.
//! `orch export` and `orch export --series` give every run.

/// Most runs one series chart draws, one line each: above about a hundred the lines
/// and their legend cover one another.
pub const MAX_SERIES_RUNS: usize = 100;

/// Most rows one per-run table lists (the runs' responses, a round's design).
pub const MAX_TABLE_RUNS: usize = 500;

/// The positions (0-based, ascending) of the items shown when at most `max` of `total`
/// are: all of them when `total <= max`; otherwise `max` positions spread evenly from
/// the first to the last item, position `k` being `k (total − 1) / (max − 1)` rounded
/// down (the last item only for `max` = 1, so that a single line is not always the
/// first run).
pub fn evenly(total: usize, max: usize) -> Vec<usize> {
    if total <= max {
        return (0..total).collect();
    }
    match max {
        0 => Vec::new(),
        1 => vec![total - 1],
        _ => (0..max).map(|k| k * (total - 1) / (max - 1)).collect(),
    }
}

/// The note under a chart or table that shows `shown` of `total` runs, pointing to
/// the command (`orch export`, `orch export --series`) that gives all; nothing when
/// every run is shown.
pub fn note(shown: usize, total: usize, command: &str) -> String {
    if shown >= total {
        return String::new();
    }
    format!(
        "<p class=\"note\">Showing {shown} of {total} runs, spread evenly over the jobs in order (the first and the last included); <code>{command}</code> gives all.</p>\n"
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_study_within_the_cap_shows_every_run() {
        assert_eq!(evenly(0, 100), Vec::<usize>::new());
        assert_eq!(evenly(3, 100), vec![0, 1, 2]);
        assert_eq!(evenly(100, 100), (0..100).collect::<Vec<_>>());
    }

    #[test]
    fn above_the_cap_the_shown_runs_are_spread_evenly_from_the_first_to_the_last() {
        assert_eq!(evenly(10, 4), vec![0, 3, 6, 9]);
        assert_eq!(evenly(101, 3), vec![0, 50, 100]);
        assert_eq!(evenly(5, 1), vec![4]);
        assert_eq!(evenly(5, 0), Vec::<usize>::new());
        for (total, max) in [(101, 100), (10_000, 100), (10_040, 500), (1001, 2)] {
            let shown = evenly(total, max);
            assert_eq!(shown.len(), max, "{total} {max}");
            assert_eq!(shown.first(), Some(&0));
            assert_eq!(shown.last(), Some(&(total - 1)));
            // Distinct and in order, and no gap more than one step wider than another.
            assert!(shown.windows(2).all(|w| w[0] < w[1]), "{total} {max}");
            let gaps: Vec<usize> = shown.windows(2).map(|w| w[1] - w[0]).collect();
            let (low, high) = (gaps.iter().min().unwrap(), gaps.iter().max().unwrap());
            assert!(high - low <= 1, "{total} {max}: gaps {low}..{high}");
        }
    }

    #[test]
    fn only_a_capped_chart_or_table_has_a_note() {
        assert_eq!(note(100, 100, "orch export"), "");
        assert!(note(100, 10_000, "orch export").contains("Showing 100 of 10000 runs"));
    }

    #[test]
    fn the_choice_is_the_same_every_time() {
        assert_eq!(evenly(10_000, 100), evenly(10_000, 100));
    }
}
