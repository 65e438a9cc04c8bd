//! A study's progress on a terminal: a bar for the round being run ("round 1 of 2",
//! jobs done, running and failed, and an ETA from the durations of the jobs that have
//! finished), with each job's line printed above it. When standard error is not a
//! terminal (a pipe, a file, CI) there is no bar: the job lines are printed as they
//! are, one per line.

use std::io::IsTerminal;
use std::time::Duration;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use crate::output::errln;
use crate::store::{JobRow, JobState};

/// Where a round stands, for the bar.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RoundProgress {
    /// The round, counted from 1.
    pub round: u32,
    /// Rounds at most.
    pub rounds: u32,
    /// Jobs of the round that are final.
    pub done: usize,
    /// Jobs of the round.
    pub total: usize,
    /// Jobs of the round running or handed to a scheduler.
    pub running: usize,
    /// Jobs of the round that failed.
    pub failed: usize,
    /// Time left, from the mean duration of the round's finished jobs.
    pub eta: Option<Duration>,
}

impl RoundProgress {
    /// Where the round of the jobs `round_jobs` stands (`round` counted from 0), with
    /// `parallel` jobs at once.
    pub fn of(round: i64, rounds: u32, round_jobs: &[&JobRow], parallel: usize) -> RoundProgress {
        let done = round_jobs.iter().filter(|j| j.state().is_final()).count();
        let durations: Vec<f64> = round_jobs
            .iter()
            .filter(|j| j.state() == JobState::Succeeded)
            .filter_map(|j| Some(j.finished_at? - j.started_at?))
            .filter(|d| d.is_finite() && *d >= 0.0)
            .collect();
        let left = round_jobs.len() - done;
        let eta = (!durations.is_empty()).then(|| {
            let mean = durations.iter().sum::<f64>() / durations.len() as f64;
            let waves = left.div_ceil(parallel.max(1));
            Duration::from_secs_f64(mean * waves as f64)
        });
        RoundProgress {
            round: round as u32 + 1,
            rounds,
            done,
            total: round_jobs.len(),
            running: round_jobs
                .iter()
                .filter(|j| matches!(j.state(), JobState::Running | JobState::Submitted))
                .count(),
            failed: round_jobs
                .iter()
                .filter(|j| j.state() == JobState::Failed)
                .count(),
            eta,
        }
    }

    /// The bar's text: `round 1 of 2: 4 running, 1 failed, ETA 12 s`.
    pub fn message(&self) -> String {
        let mut text = format!(
            "round {} of {}: {} running",
            self.round, self.rounds, self.running
        );
        if self.failed > 0 {
            text.push_str(&format!(", {} failed", self.failed));
        }
        match self.eta {
            Some(eta) if self.done < self.total => {
                text.push_str(&format!(", ETA {} s", eta.as_secs_f64().round() as u64))
            }
            _ => {}
        }
        text
    }
}

/// The bar, or plain lines when standard error is not a terminal.
pub struct Progress {
    bar: Option<ProgressBar>,
}

impl Progress {
    /// A bar when standard error is a terminal.
    pub fn on_stderr() -> Progress {
        let bar = std::io::stderr().is_terminal().then(|| {
            let bar = ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr());
            bar.set_style(
                ProgressStyle::with_template("{bar:30} {pos}/{len} jobs, {msg}")
                    .expect("a valid template"),
            );
            bar
        });
        Progress { bar }
    }

    /// True when there is a bar (standard error is a terminal).
    pub fn is_shown(&self) -> bool {
        self.bar.is_some()
    }

    /// Prints a line: above the bar, or plainly.
    pub fn println(&self, line: &str) {
        match &self.bar {
            Some(bar) => bar.println(line),
            None => errln!("{line}"),
        }
    }

    /// Shows where the round stands.
    pub fn update(&self, progress: &RoundProgress) {
        if let Some(bar) = &self.bar {
            bar.set_length(progress.total as u64);
            bar.set_position(progress.done as u64);
            bar.set_message(progress.message());
        }
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn job(id: i64, state: JobState, started: f64, finished: f64) -> JobRow {
        JobRow {
            id,
            study_id: 1,
            point_id: 1,
            replicate: 0,
            name: format!("p{id:03}r0"),
            seed: 1,
            state,
            attempts: 1,
            executor_handle: None,
            run_dir: String::new(),
            started_at: Some(started),
            finished_at: Some(finished),
            exit_code: None,
            error: None,
            scheduler_state: None,
            kind: crate::store::JobKind::Design,
            after_job_id: None,
            identity: None,
            reused_from: None,
        }
    }

    #[test]
    fn the_eta_is_the_mean_finished_duration_times_the_waves_left() {
        let jobs = [
            job(1, JobState::Succeeded, 0.0, 10.0),
            job(2, JobState::Succeeded, 0.0, 20.0),
            job(3, JobState::Failed, 0.0, 1.0),
            job(4, JobState::Running, 5.0, f64::NAN),
            job(5, JobState::Pending, 0.0, f64::NAN),
            job(6, JobState::Pending, 0.0, f64::NAN),
        ];
        let refs: Vec<&JobRow> = jobs.iter().collect();
        let progress = RoundProgress::of(1, 2, &refs, 2);
        assert_eq!(progress.done, 3);
        assert_eq!(progress.total, 6);
        // Three jobs left, two at once: two waves of the 15 s mean.
        assert_eq!(progress.eta, Some(Duration::from_secs(30)));
        assert_eq!(
            progress.message(),
            "round 2 of 2: 1 running, 1 failed, ETA 30 s"
        );
    }

    #[test]
    fn no_eta_before_a_job_finishes_and_none_once_the_round_is_done() {
        let running = [job(1, JobState::Running, 0.0, f64::NAN)];
        let refs: Vec<&JobRow> = running.iter().collect();
        assert_eq!(
            RoundProgress::of(0, 1, &refs, 2).message(),
            "round 1 of 1: 1 running"
        );
        let done = [job(1, JobState::Succeeded, 0.0, 3.0)];
        let refs: Vec<&JobRow> = done.iter().collect();
        assert_eq!(
            RoundProgress::of(0, 1, &refs, 2).message(),
            "round 1 of 1: 0 running"
        );
    }
}
