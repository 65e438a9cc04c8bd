//! `orch compare`: the native kernel against LIGGGHTS (and YADE when asked) on a suite
//! of reference cases, with the history of every run in the store.
//!
//! Each case × seed × solver is rendered through the simulation seam
//! ([`EquipmentOnSolver`]: the same parameters, the same seed, each solver's own
//! template), run through the executor as a study's jobs are ([`runner`]: its own
//! process group, at most [`RunOptions::parallel`] at once, one core each, a time
//! limit, Ctrl-C), and read with `results`. Then, per case and response,
//! [`analysis::compare_case`] gives means, standard errors, the relative difference
//! with Welch's interval and a verdict (the rule is in [`analysis`]); per case and
//! solver the mean throughput of the solver's loop (particle-steps/s). Runs that share
//! the machine slow each other a little, equally for both solvers, so the ratio is
//! the figure to watch, not the absolute speeds.
//!
//! A rendered run whose identity ([`orch_study::identity`]: its files, the program and its
//! version) an earlier comparison of the project already made is not run again: its
//! stored responses are taken, but not its speed, which belongs to the moment it ran
//! (the speeds and their ratio are of the runs made in this invocation only). A
//! comparison of unchanged solvers on an unchanged suite runs nothing; a new build of
//! the native kernel is another program, so its runs are made.

pub mod analysis;
pub mod history;
mod runner;
pub mod suite;

use std::collections::{BTreeMap, HashMap};
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use orch_adapters::simulation::SOLVER_THROUGHPUT;
use orch_adapters::{liggghts, DemSolver};
use tokio::sync::watch;

use orch_executor::Executor;

pub use analysis::{ResponseComparison, Throughput, Verdict};
pub use suite::{Suite, SuiteCase, SuiteError};

/// The solver every other one is compared against.
pub const NATIVE: &str = "native";

/// How to run a suite.
#[derive(Debug, Clone)]
pub struct RunOptions {
    /// Only the cases marked `quick`.
    pub quick: bool,
    /// The solvers: the native kernel and at least one reference.
    pub solvers: Vec<&'static DemSolver>,
    /// Factors applied to parameters of the native runs only (for tests).
    pub perturbation: BTreeMap<String, f64>,
    /// Runs at once.
    pub parallel: usize,
    /// A run still going after this long is stopped and counts as failed.
    pub time_limit: Duration,
    /// Where the run directories go.
    pub runs_dir: PathBuf,
    /// Runs earlier comparisons made, by identity: taken instead of running again
    /// (empty with `--no-reuse`).
    pub known: HashMap<String, analysis::RunValues>,
}

/// One run of one case with one seed on one solver.
#[derive(Debug, Clone)]
struct RunSpec {
    case: usize,
    seed: u64,
    solver: &'static DemSolver,
    dir: PathBuf,
}

/// What one run gave, or why it gave nothing.
type RunOutcome = Result<Made, String>;

/// A run's values and how they were had.
#[derive(Debug, Clone)]
struct Made {
    values: analysis::RunValues,
    identity: String,
    reused: bool,
}

/// Everything one run of the suite found.
#[derive(Debug, Clone)]
pub struct SuiteOutcome {
    /// Per case and response, native against each reference.
    pub responses: Vec<ResponseComparison>,
    /// Per case and solver.
    pub speeds: Vec<Throughput>,
    /// Runs that failed, with why (their responses count as regressions).
    pub failures: Vec<String>,
    /// `solver=version` of each solver.
    pub solver_versions: BTreeMap<String, String>,
    /// Wall time of the whole suite, s.
    pub wall_time_s: f64,
    /// Runs made now, by identity, for the store to know next time.
    pub made: Vec<(String, analysis::RunValues)>,
    /// Runs taken from earlier comparisons instead of running.
    pub reused: usize,
    /// Ctrl-C or SIGTERM stopped it: the runs made are kept, nothing is compared.
    pub interrupted: bool,
}

impl SuiteOutcome {
    /// The worst verdict; a failed run is a regression.
    pub fn verdict(&self) -> Verdict {
        let worst = self.responses.iter().map(|r| r.verdict).max();
        if self.failures.is_empty() {
            worst.unwrap_or(Verdict::Agree)
        } else {
            Verdict::Regression
        }
    }
}

/// Runs the cases of `suite` that `options` selects on every solver through `executor`
/// and compares them; `stop` turning true (Ctrl-C, SIGTERM) stops the runs.
pub async fn run_suite<E: Executor>(
    suite: &Suite,
    options: &RunOptions,
    executor: &mut E,
    stop: &watch::Receiver<bool>,
) -> SuiteOutcome {
    let start = Instant::now();
    let cases = suite.selected(options.quick);
    let mut specs = Vec::new();
    for (index, case) in cases.iter().enumerate() {
        for &seed in &case.seeds {
            for &solver in &options.solvers {
                specs.push(RunSpec {
                    case: index,
                    seed,
                    solver,
                    dir: options
                        .runs_dir
                        .join(&case.name)
                        .join(format!("{}-seed{seed}", solver.name)),
                });
            }
        }
    }
    let ran = runner::run_all(executor, &cases, &specs, options, stop).await;
    let outcomes = ran.outcomes;
    let mut failures = Vec::new();
    let mut made = Vec::new();
    let mut reused = 0;
    let mut by_case: BTreeMap<(usize, &str), Vec<analysis::RunValues>> = BTreeMap::new();
    for (spec, outcome) in specs.iter().zip(&outcomes) {
        match outcome {
            Ok(run) => {
                if run.reused {
                    reused += 1;
                } else {
                    made.push((run.identity.clone(), run.values.clone()));
                }
                by_case
                    .entry((spec.case, spec.solver.name))
                    .or_default()
                    .push(run.values.clone())
            }
            Err(why) => failures.push(format!(
                "{} on {} seed {}: {why} (run directory {})",
                cases[spec.case].name,
                spec.solver.name,
                spec.seed,
                spec.dir.display()
            )),
        }
    }
    let empty = Vec::new();
    let mut responses = Vec::new();
    let mut speeds = Vec::new();
    for (index, case) in cases.iter().enumerate() {
        let native = by_case.get(&(index, NATIVE)).unwrap_or(&empty);
        let tolerances = case
            .responses
            .iter()
            .map(|(name, r)| (name.clone(), r.tolerance))
            .collect();
        for solver in &options.solvers {
            let runs = by_case.get(&(index, solver.name)).unwrap_or(&empty);
            let (mean, n) = analysis::mean_of(runs, SOLVER_THROUGHPUT);
            speeds.push(Throughput {
                case: case.name.clone(),
                solver: solver.name.to_string(),
                particle_steps_per_s: mean,
                runs: n,
            });
            if solver.name != NATIVE {
                responses.extend(analysis::compare_case(
                    &case.name,
                    solver.name,
                    native,
                    runs,
                    &tolerances,
                    suite.confidence,
                ));
            }
        }
    }
    let solver_versions = options
        .solvers
        .iter()
        .map(|s| {
            let dir = specs
                .iter()
                .find(|r| r.solver.name == s.name)
                .map(|r| &r.dir);
            (
                s.name.to_string(),
                solver_version(s, dir.map(PathBuf::as_path)),
            )
        })
        .collect();
    SuiteOutcome {
        responses,
        speeds,
        failures,
        solver_versions,
        wall_time_s: start.elapsed().as_secs_f64(),
        made,
        reused,
        interrupted: ran.interrupted,
    }
}

/// The version of `solver`: orch's for the native kernel, the first log line's for
/// LIGGGHTS (`Version …,`), else `unknown`.
fn solver_version(solver: &DemSolver, run_dir: Option<&Path>) -> String {
    if solver.name == NATIVE {
        return env!("CARGO_PKG_VERSION").to_string();
    }
    if solver.name == liggghts::SOLVER.name {
        let first_line = run_dir.and_then(|dir| {
            let mut text = String::new();
            std::fs::File::open(dir.join(liggghts::LOG_FILE))
                .ok()?
                .take(4096)
                .read_to_string(&mut text)
                .ok()?;
            text.lines().next().map(str::to_string)
        });
        if let Some(version) = first_line.as_deref().and_then(liggghts_version) {
            return version;
        }
    }
    "unknown".to_string()
}

/// `LIGGGHTS-PUBLIC 3.8.0` from LIGGGHTS's first log line.
fn liggghts_version(first_line: &str) -> Option<String> {
    let start = first_line.find("Version ")? + "Version ".len();
    let rest = &first_line[start..];
    let end = rest.find([',', ')']).unwrap_or(rest.len());
    Some(rest[..end].trim().to_string())
}

/// `git rev-parse HEAD` in `dir`, when it is in a git repository.
pub fn git_commit(dir: &Path) -> Option<String> {
    let output = Command::new("git")
        .args(["rev-parse", "HEAD"])
        .current_dir(dir)
        .stderr(Stdio::null())
        .output()
        .ok()?;
    let commit = String::from_utf8(output.stdout).ok()?.trim().to_string();
    (output.status.success() && !commit.is_empty()).then_some(commit)
}

/// `a` formatted as a percentage with one decimal; `–` for NaN.
fn percent(a: f64) -> String {
    if a.is_finite() {
        format!("{:+.1} %", 100.0 * a)
    } else {
        "–".to_string()
    }
}

/// A number with four significant digits (`–` for NaN).
fn number(v: f64) -> String {
    orch_page::numbers::number(v)
}

/// The table of an outcome, as printed: one line per case and response, then speeds.
pub fn table(outcome: &SuiteOutcome) -> String {
    let mut out = format!(
        "{:<24} {:<22} {:>11} {:>10} {:>11} {:>10} {:>9} {:>20} {:>6} {}\n",
        "case",
        "response",
        "native",
        "± se",
        "reference",
        "± se",
        "diff",
        "95 % CI",
        "tol",
        "verdict"
    );
    for r in &outcome.responses {
        out.push_str(&format!(
            "{:<24} {:<22} {:>11} {:>10} {:>11} {:>10} {:>9} {:>20} {:>6} {}\n",
            r.case,
            r.response,
            number(r.native.mean),
            number(r.native.standard_error),
            number(r.reference_summary.mean),
            number(r.reference_summary.standard_error),
            percent(r.relative_difference),
            format!("[{}, {}]", percent(r.low), percent(r.high)),
            format!("{:.0} %", 100.0 * r.tolerance),
            r.verdict.as_str()
        ));
    }
    out.push_str(&format!(
        "\n{:<24} {:<10} {:>20} {:>5} {:>14}\n",
        "case", "solver", "particle-steps/s", "runs", "native / this"
    ));
    for s in &outcome.speeds {
        let native = outcome
            .speeds
            .iter()
            .find(|n| n.case == s.case && n.solver == NATIVE)
            .map_or(f64::NAN, |n| n.particle_steps_per_s);
        out.push_str(&format!(
            "{:<24} {:<10} {:>20} {:>5} {:>14}\n",
            s.case,
            s.solver,
            number(s.particle_steps_per_s),
            s.runs,
            format!("{:.2}", native / s.particle_steps_per_s)
        ));
    }
    for failure in &outcome.failures {
        out.push_str(&format!("FAILED: {failure}\n"));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_liggghts_version_is_read_from_its_first_log_line() {
        let line = "LIGGGHTS (Version LIGGGHTS-PUBLIC 3.8.0, compiled 2022-01-26-19:42:32 by buildd, git commit unknown)";
        assert_eq!(
            liggghts_version(line).as_deref(),
            Some("LIGGGHTS-PUBLIC 3.8.0")
        );
        assert_eq!(liggghts_version("Created orthogonal box"), None);
        assert_eq!(percent(0.1234), "+12.3 %");
        assert_eq!(percent(f64::NAN), "–");
    }
}
