//! `orch compare`: the suite's runs, their comparison and its record in the store.

use super::*;

/// Options of `orch compare` as given.
pub(super) struct CompareArgs {
    pub(super) quick: bool,
    pub(super) solvers: Vec<String>,
    pub(super) perturb: Vec<String>,
    pub(super) parallel: usize,
    pub(super) time_limit: std::time::Duration,
    pub(super) keep_runs: bool,
    pub(super) no_reuse: bool,
}

/// `name=factor` pairs of `--perturb`.
pub(super) fn perturbation(
    given: &[String],
) -> anyhow::Result<std::collections::BTreeMap<String, f64>> {
    given
        .iter()
        .map(|p| {
            let parsed = p.split_once('=').and_then(|(name, factor)| {
                let factor: f64 = factor.trim().parse().ok()?;
                (factor.is_finite() && factor > 0.0).then(|| (name.trim().to_string(), factor))
            });
            parsed.ok_or_else(|| {
                input_error(format!(
                    "--perturb {p}: give NAME=FACTOR with a positive factor, e.g. friction=1.3"
                ))
            })
        })
        .collect()
}

pub(super) async fn compare(
    project_dir: Option<&Path>,
    suite_file: &Path,
    args: &CompareArgs,
) -> anyhow::Result<i32> {
    use crate::compare::{self, history, RunOptions, Suite, Verdict};
    let suite = Suite::load(suite_file).map_err(|e| input_error(e.to_string()))?;
    let perturbation = perturbation(&args.perturb)?;
    let solvers = checked_solvers(&suite, args, &perturbation)?;
    let project = project::for_study_file(suite_file, project_dir).with_context(|| {
        format!(
            "cannot resolve the project directory of {}",
            suite_file.display()
        )
    })?;
    let store = Store::open(&project).await?;
    let started_at = crate::store::now_s();
    let runs_dir = project
        .join(project::RUNS_DIR_NAME)
        .join("compare")
        .join(format!("{}", started_at as u64));
    let options = RunOptions {
        quick: args.quick,
        solvers,
        perturbation: perturbation.clone(),
        parallel: args.parallel,
        time_limit: args.time_limit,
        runs_dir: runs_dir.clone(),
        known: if args.no_reuse {
            Default::default()
        } else {
            store.comparison_runs().await?
        },
    };
    let cases = suite.selected(args.quick).len();
    errln!(
        "orch compare: {cases} case(s) of {} on {}, {} at once; runs in {}",
        suite_file.display(),
        args.solvers.join(", "),
        args.parallel,
        runs_dir.display()
    );
    let stop = crate::driver::stop_on_signals().context("cannot watch for Ctrl-C")?;
    let mut executor = crate::executor::local::LocalExecutor::new();
    let outcome = compare::run_suite(&suite, &options, &mut executor, &stop).await;
    if outcome.interrupted {
        // What finished is kept: the next comparison takes those runs, not runs them.
        store.record_comparison_runs(&outcome.made).await?;
        errln!(
            "orch compare: interrupted; the {} runs that finished are kept in the project and the next `orch compare` takes them instead of running them again; nothing was compared (runs in {})",
            outcome.made.len(),
            runs_dir.display()
        );
        store.close().await;
        return Ok(exit_codes::INTERRUPTED);
    }
    let verdict = outcome.verdict();
    let suite_dir = suite_file
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let record = crate::store::ComparisonRecord {
        started_at,
        wall_time_s: outcome.wall_time_s,
        git_commit: compare::git_commit(suite_dir),
        suite: suite_file.display().to_string(),
        quick: args.quick,
        perturbation: perturbation
            .iter()
            .map(|(n, f)| format!("{n}={f}"))
            .collect::<Vec<_>>()
            .join(","),
        solver_versions: history::versions_text(&outcome.solver_versions),
        confidence: suite.confidence,
        verdict: verdict.as_str().to_string(),
    };
    store.record_comparison_runs(&outcome.made).await?;
    if outcome.reused > 0 {
        errln!(
            "orch compare: {} runs were made by an earlier comparison (the same decks and solver builds) and taken from it, not run again; --no-reuse runs them",
            outcome.reused
        );
    }
    let (responses, speeds) = history::records(&outcome);
    let id = store
        .insert_comparison(&record, &responses, &speeds)
        .await?;
    let all = store.comparisons().await?;
    let report = project.join("reports").join("compare.html");
    write_output(&report, history::page(&all).as_bytes())?;
    out!("{}", compare::table(&outcome))?;
    for change in history::changes(&all) {
        outln!("CHANGED: {change}")?;
    }
    let slowdowns = history::slowdowns(&all);
    for slowdown in &slowdowns {
        outln!("SLOWER: {slowdown}")?;
    }
    outln!(
        "comparison {id}: {} (solvers {}; commit {}; wall time {:.0} s); report {}",
        verdict.as_str(),
        record.solver_versions,
        record.git_commit.as_deref().unwrap_or("unknown"),
        outcome.wall_time_s,
        report.display()
    )?;
    for r in outcome
        .responses
        .iter()
        .filter(|r| r.verdict == Verdict::Regression)
    {
        outln!(
            "REGRESSION: {} {} differs from {} by {:+.1} % [{:+.1} %, {:+.1} %], tolerance {:.0} %",
            r.case,
            r.response,
            r.reference,
            100.0 * r.relative_difference,
            100.0 * r.low,
            100.0 * r.high,
            100.0 * r.tolerance
        )?;
    }
    if outcome.failures.is_empty() && !args.keep_runs {
        if let Err(e) = std::fs::remove_dir_all(&runs_dir) {
            errln!("cannot remove {}: {e}", runs_dir.display());
        }
    }
    store.close().await;
    Ok(if verdict == Verdict::Regression || !slowdowns.is_empty() {
        exit_codes::REGRESSION
    } else {
        exit_codes::SUCCESS
    })
}

/// The solvers `--solvers` names: `native` and at least one installed reference, each
/// with a template for every selected case, whose equipment has every parameter
/// `--perturb` names.
fn checked_solvers(
    suite: &crate::compare::Suite,
    args: &CompareArgs,
    perturbation: &std::collections::BTreeMap<String, f64>,
) -> anyhow::Result<Vec<&'static orch_adapters::DemSolver>> {
    use crate::compare::NATIVE;
    let mut solvers = Vec::new();
    for name in &args.solvers {
        solvers.push(known_solver(name)?);
    }
    if !args.solvers.iter().any(|s| s == NATIVE) || solvers.len() < 2 {
        return Err(input_error(
            "--solvers: name `native` and at least one reference, e.g. native,liggghts",
        ));
    }
    for case in suite.selected(args.quick) {
        let equipment = orch_adapters::equipment_for(&case.equipment).expect("checked");
        for name in perturbation.keys() {
            if !equipment
                .parameters()
                .iter()
                .any(|p| p.name == name.as_str())
            {
                return Err(input_error(format!(
                    "--perturb {name}: not a parameter of {} (case `{}`)",
                    case.equipment, case.name
                )));
            }
        }
        for solver in &solvers {
            if solver.template_for(&case.equipment).is_none() {
                return Err(input_error(format!(
                    "{} cannot simulate {} (case `{}`)",
                    solver.name, case.equipment, case.name
                )));
            }
        }
    }
    for solver in solvers.iter().filter(|s| s.name != NATIVE) {
        let program = (solver.command)("probe", 1).program;
        if !program_exists(&program) {
            return Err(input_error(format!(
                "{} is not installed (`{program}` is not on PATH): {}",
                solver.name, solver.install_hint
            )));
        }
    }
    Ok(solvers)
}
