//! Command-line interface: arguments, and one function per command.

mod compare;
mod inspect;

use compare::{compare, CompareArgs};
use inspect::{export, logs, report, show_fits, write_output};

use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::{Parser, Subcommand};

use crate::catalogue;
use crate::driver::{self, Ending};
use crate::executor::process::{self, ProcessHandle};
use crate::executor::{Executor, LocalExecutor, SlurmExecutor};
use crate::exit_codes;
use crate::output::{errln, out, outln};
use crate::project;
use crate::rounds;
use crate::status;
use crate::store::{JobState, Store, StudyRow, StudyState};
use crate::study::{ExecutorKind, Stored, Study, StudyError, Template};

/// Runs design-of-experiments studies of DEM solvers and collects their responses.
#[derive(Debug, Parser)]
#[command(name = "orch", version, about, long_about = None)]
pub struct Args {
    /// Project directory holding orch.db and runs/ (default: `.orch` beside the study
    /// file; for other commands `./.orch` and `./*/.orch`).
    #[arg(long, global = true, env = "ORCH_PROJECT_DIR", value_name = "DIR")]
    pub project_dir: Option<PathBuf>,

    /// More log output (-v info, -vv debug); RUST_LOG overrides.
    #[arg(short, long, global = true, action = clap::ArgAction::Count)]
    pub verbose: u8,

    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The commands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Validate a study file, record its design and run every job.
    Submit {
        /// The study file (YAML).
        study_file: PathBuf,
        /// Validate and print the design without writing or running anything.
        #[arg(long)]
        dry_run: bool,
        /// Submit under this name instead of the file's `name:` (e.g. a changed
        /// template beside the study submitted before).
        #[arg(long = "as", value_name = "NAME")]
        as_name: Option<String>,
        /// Run every job, even one whose run (the same rendered files, program, seed
        /// and cores) already succeeded in the project; as `reuse: false` in the file.
        #[arg(long)]
        no_reuse: bool,
    },
    /// Where every study, or every job of one study, stands.
    Status {
        /// A study name; without it, one line per study.
        study: Option<String>,
        /// Machine-readable JSON instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// A job's solver output: stdout, stderr and the solver's log.
    Logs {
        /// `study/job` (e.g. `hopper-vibration/p003r0`), or a job name unique across studies.
        job: String,
        /// Lines from the end of each file; 0 prints whole files.
        #[arg(long, default_value_t = 40)]
        tail: usize,
    },
    /// The response surfaces of a study: terms, coefficients, t-values, σ_cross, R².
    Fit {
        /// The study name.
        study: String,
        /// The round (default: the latest one analysed).
        #[arg(long)]
        round: Option<i64>,
    },
    /// A study's runs as a table: one row per job with its round, point, factors and
    /// responses (units in the headers); or, with --series, every time series.
    Export {
        /// The study name.
        study: String,
        /// CSV (RFC 4180) or a JSON array of objects.
        #[arg(long, value_enum, default_value = "csv")]
        format: crate::export::Format,
        /// The time series in long form (job, series, unit, t, value) instead of the runs.
        #[arg(long)]
        series: bool,
        /// Write here instead of standard output.
        #[arg(short, long, value_name = "FILE")]
        output: Option<PathBuf>,
    },
    /// One self-contained HTML report of a study: design, surfaces, predicted against
    /// observed, Pareto charts, optimum, trust regions, runs and series.
    Report {
        /// The study name.
        study: String,
        /// Where to write it (default: `<project>/reports/<study>.html`).
        #[arg(short, long, value_name = "FILE")]
        output: Option<PathBuf>,
    },
    /// Stop a study: running jobs are killed, pending ones will not start.
    Cancel {
        /// The study name.
        study: String,
    },
    /// Remove a study from the project: its records and its run directories.
    Delete {
        /// The study name.
        study: String,
    },
    /// Continue an interrupted or cancelled study; re-attaches to jobs still running.
    Resume {
        /// The study name.
        study: String,
        /// Also run failed jobs again, with fresh attempts.
        #[arg(long)]
        retry_failed: bool,
        /// Run every job, even one whose run already succeeded in the project.
        #[arg(long)]
        no_reuse: bool,
    },
    /// What a study can use: equipment, solvers and stages; with a name, its parameters
    /// (default, unit, range) and responses (unit).
    Params {
        /// An equipment (`hopper`) or a stage kind (`cfd`); without it, the list.
        name: Option<String>,
        /// Also say what this solver renders and runs for the equipment.
        #[arg(long)]
        solver: Option<String>,
        /// Every table as Markdown (docs/parameters.md).
        #[arg(long, conflicts_with_all = ["name", "solver"])]
        markdown: bool,
    },
    /// The native kernel against LIGGGHTS (and YADE when asked) on a suite of reference
    /// cases: per response the means, standard errors, the relative difference with a
    /// Welch interval and a verdict against its tolerance; the throughput of each
    /// solver and their ratio. Stored in the project's history; writes
    /// `<project>/reports/compare.html`. Exit status 0 when nothing regressed, 1 on a
    /// regression (an interval wholly outside ±tolerance, or a failed run).
    Compare {
        /// The suite file (default: `jobs/compare/suite.yaml`).
        #[arg(default_value = "jobs/compare/suite.yaml")]
        suite: PathBuf,
        /// Only the cases marked `quick: true` (the CI subset).
        #[arg(long)]
        quick: bool,
        /// The solvers: `native` and at least one reference (`liggghts`, `yade`).
        #[arg(long, value_delimiter = ',', default_value = "native,liggghts")]
        solvers: Vec<String>,
        /// Multiply a parameter of the NATIVE runs only by a factor, e.g.
        /// `friction=1.3`: for tests that a real difference is caught. Repeatable.
        #[arg(long, value_name = "NAME=FACTOR")]
        perturb: Vec<String>,
        /// Runs at once (one core each).
        #[arg(long, default_value_t = 2)]
        parallel: usize,
        /// A run still going after this long is stopped and counts as a failed run
        /// (`90s`, `30min`, `2h`).
        #[arg(long, default_value = "1h", value_parser = humantime::parse_duration)]
        time_limit: std::time::Duration,
        /// Keep the run directories (default: removed when every run succeeded).
        #[arg(long)]
        keep_runs: bool,
        /// Run every case again, even one an earlier comparison ran with the same deck
        /// and solver build (default: take those runs from the store).
        #[arg(long)]
        no_reuse: bool,
    },
    /// Default templates, to copy and adapt as a study's `template:`.
    Template {
        /// What to do.
        #[command(subcommand)]
        action: TemplateAction,
    },
}

/// `orch template` actions.
#[derive(Debug, Subcommand)]
pub enum TemplateAction {
    /// Print a solver's default template of an equipment.
    Show {
        /// The equipment (`hopper`).
        equipment: String,
        /// The solver (`liggghts`, `yade`, `native`).
        #[arg(long)]
        solver: String,
    },
}

/// An error in what the user gave: exit code [`exit_codes::BAD_INPUT`].
#[derive(Debug, thiserror::Error)]
#[error("{message}")]
pub struct InputError {
    /// What is wrong and what to do.
    pub message: String,
}

fn input_error(message: impl Into<String>) -> anyhow::Error {
    InputError {
        message: message.into(),
    }
    .into()
}

/// Runs the command; returns the exit code.
pub async fn run(args: Args) -> anyhow::Result<i32> {
    let project_dir = args.project_dir.as_deref();
    match args.command {
        Command::Submit {
            study_file,
            dry_run,
            as_name,
            no_reuse,
        } => {
            submit(
                &study_file,
                project_dir,
                dry_run,
                as_name.as_deref(),
                no_reuse,
            )
            .await
        }
        Command::Delete { study } => delete(project_dir, &study).await,
        Command::Status { study, json } => show_status(project_dir, study.as_deref(), json).await,
        Command::Logs { job, tail } => logs(project_dir, &job, tail).await,
        Command::Fit { study, round } => show_fits(project_dir, &study, round).await,
        Command::Export {
            study,
            format,
            series,
            output,
        } => export(project_dir, &study, format, series, output.as_deref()).await,
        Command::Report { study, output } => report(project_dir, &study, output).await,
        Command::Cancel { study } => cancel(project_dir, &study).await,
        Command::Resume {
            study,
            retry_failed,
            no_reuse,
        } => resume(project_dir, &study, retry_failed, no_reuse).await,
        Command::Params {
            name,
            solver,
            markdown,
        } => params(name.as_deref(), solver.as_deref(), markdown),
        Command::Compare {
            suite,
            quick,
            solvers,
            perturb,
            parallel,
            time_limit,
            keep_runs,
            no_reuse,
        } => {
            let options = CompareArgs {
                quick,
                solvers,
                perturb,
                parallel,
                time_limit,
                keep_runs,
                no_reuse,
            };
            compare(project_dir, &suite, &options).await
        }
        Command::Template {
            action: TemplateAction::Show { equipment, solver },
        } => {
            let solver = known_solver(&solver)?;
            let text = catalogue::template(&equipment, solver).map_err(input_error)?;
            out!("{text}")?;
            Ok(exit_codes::SUCCESS)
        }
    }
}

/// What a dry run says besides the design: every parameter with its value and where it
/// comes from, the responses with units, the objective and the rounds.
fn dry_run_summary(study: &Study) -> String {
    use std::fmt::Write;
    let simulation = &study.simulation;
    let mut out = format!(
        "parameters of the {} (factor, fixed or default):\n",
        simulation.equipment_name()
    );
    let mut line = |name: &str, value: String, unit: &str, origin: &str| {
        let _ = writeln!(out, "  {name:<20} {value:>22} {unit:<8} {origin}");
    };
    for factor in &study.factors {
        let range = match factor.is_text() {
            true => format!("{{{}}}", factor.levels.join(", ")),
            false => format!("[{}, {}]", factor.range.min, factor.range.max),
        };
        line(&factor.name, range, &factor.unit, "factor");
    }
    let declared = |name: &str| simulation.parameters().iter().any(|p| p.name == name);
    for spec in simulation.parameters() {
        if study.factors.iter().any(|f| f.name == spec.name) {
            continue;
        }
        match study.fixed.get(spec.name.as_ref()) {
            Some(value) => line(&spec.name, value.to_string(), &spec.unit, "fixed"),
            None => line(&spec.name, spec.default.to_string(), &spec.unit, "default"),
        }
    }
    for (name, value) in study.fixed.iter().filter(|(n, _)| !declared(n)) {
        line(name, value.to_string(), "", "fixed");
    }
    for (name, text) in &study.fixed_text {
        line(name, text.clone(), "", "fixed");
    }
    for stage in &study.stages {
        let kind = stage.stage.kind();
        for spec in stage.stage.parameters() {
            let (value, origin) = match stage.fixed.get(spec.name.as_ref()) {
                Some(value) => (*value, "fixed"),
                None => (spec.default, "default"),
            };
            let name = format!("{kind}.{}", spec.name);
            line(&name, value.to_string(), &spec.unit, origin);
        }
    }
    let responses: Vec<String> = study
        .shown_responses()
        .iter()
        .map(|r| format!("{r} [{}]", study.response_unit(r).unwrap_or("?")))
        .collect();
    let _ = writeln!(out, "responses: {}", responses.join(", "));
    match &study.objective {
        Some(objective) => {
            let what = if objective.is_pareto() {
                format!(
                    "Pareto front of {} points: {}",
                    objective.front_points,
                    objective
                        .objectives
                        .iter()
                        .map(|(r, g)| format!("{g:?} {r}"))
                        .collect::<Vec<_>>()
                        .join(" vs ")
                )
            } else {
                format!("{:?} {}", objective.goal, objective.name())
            };
            let _ = writeln!(
                out,
                "objective: {what}{}",
                objective
                    .constraints
                    .iter()
                    .map(|(r, min, max)| format!(
                        ", subject to {}{r}{}",
                        min.map(|m| format!("{m} ≤ ")).unwrap_or_default(),
                        max.map(|m| format!(" ≤ {m}")).unwrap_or_default()
                    ))
                    .collect::<String>()
            );
        }
        None => out.push_str("objective: none (one round, surfaces fitted, no optimum)\n"),
    }
    let _ = writeln!(out, "rounds: at most {}", study.rounds);
    let tests = study.metamodel.test_points;
    if tests > 0 {
        let grid = matches!(
            study.design,
            orch_metamodel::DesignKind::FullFactorial { .. }
        );
        let why = if grid {
            " (off the grid: on a full-factorial grid leave-one-out can be exactly zero while the surface is wrong between the grid lines)"
        } else {
            ""
        };
        let _ = writeln!(out, "held-out test points per round: {tests}{why}");
    }
    out
}

/// The solver called `name`, or an input error listing the solvers.
fn known_solver(name: &str) -> anyhow::Result<&'static orch_adapters::DemSolver> {
    orch_adapters::solver_for(name).ok_or_else(|| {
        input_error(format!(
            "unknown solver `{name}`; expected one of: {}",
            orch_adapters::solver_names().join(", ")
        ))
    })
}

/// `orch params`: the catalogue, one equipment or stage, or the Markdown of all.
fn params(name: Option<&str>, solver: Option<&str>, markdown: bool) -> anyhow::Result<i32> {
    let text = match name {
        _ if markdown => catalogue::markdown(),
        None => catalogue::overview(),
        Some(name) if name == orch_adapters::custom::EQUIPMENT => catalogue::custom_text(),
        Some(name) => {
            if let Some(stage) = orch_adapters::stage_for(name) {
                catalogue::stage_text(stage)
            } else {
                let equipment = orch_adapters::equipment_for(name).ok_or_else(|| {
                    input_error(format!(
                        "no equipment or stage `{name}`; expected one of: {}, {}",
                        orch_adapters::equipment_names().join(", "),
                        orch_adapters::stage_kinds().join(", ")
                    ))
                })?;
                let simulation = match solver {
                    None => None,
                    Some(solver) => {
                        let solver = known_solver(solver)?;
                        let simulation = orch_adapters::EquipmentOnSolver::new(equipment, solver)
                            .ok_or_else(|| {
                            input_error(format!(
                                "the {} solver has no template for `{name}`",
                                solver.name
                            ))
                        })?;
                        Some(simulation)
                    }
                };
                catalogue::equipment_text(equipment, simulation.as_ref())
            }
        }
    };
    out!("{text}")?;
    Ok(exit_codes::SUCCESS)
}

fn study_error(error: StudyError) -> anyhow::Error {
    input_error(format!(
        "{error}\nFix the study file and submit it again; nothing was written."
    ))
}

/// True when `program` can be started: an existing path, or a name found on PATH.
fn program_exists(program: &str) -> bool {
    if program.contains('/') {
        return Path::new(program).is_file();
    }
    std::env::var_os("PATH")
        .map(|paths| std::env::split_paths(&paths).any(|dir| dir.join(program).is_file()))
        .unwrap_or(false)
}

/// The study's solver, or its levels' (`native (native), fine (liggghts)`).
fn solvers_text(study: &Study) -> String {
    if study.fidelities.is_empty() {
        return study.simulation.solver_name().to_string();
    }
    let levels: Vec<String> = study
        .fidelities
        .iter()
        .map(|f| format!("{} ({})", f.name, f.simulation.solver_name()))
        .collect();
    format!("fidelity levels {}", levels.join(", "))
}

/// Refuses a study whose solver (or the programs its command runs behind a wrapper,
/// or `mpirun` for MPI ranks) is not installed.
fn check_installed(simulation: &dyn orch_adapters::Simulation) -> anyhow::Result<()> {
    let solver = simulation.solver_name();
    let command = simulation.command();
    let program = command.program;
    if command.mpi && !program_exists(&program) {
        return Err(input_error(format!(
            "the study runs each {solver} job on {} MPI ranks (`executor.cores_per_job`) but `{program}` is not on PATH; install Open MPI (apt-get install -y openmpi-bin) or leave cores_per_job out, and submit again; nothing was written",
            command.cores
        )));
    }
    if !program_exists(&program) {
        return Err(input_error(format!(
            "the {solver} solver `{program}` is not installed (not found on PATH); install it with `{}` and submit again; nothing was written",
            simulation.install_hint()
        )));
    }
    // Behind a wrapper (`stdbuf -oL`, `mpirun -np 2`, `sh -c "…"`) is the solver itself.
    let words: Vec<String> = std::iter::once(program.clone())
        .chain(command.args.iter().cloned())
        .collect();
    let programs = crate::programs::programs_of(&words);
    if let Some(missing) = programs.iter().skip(1).find(|p| !program_exists(p)) {
        return Err(input_error(format!(
            "the study's command runs `{missing}` (behind `{}`), which is not on PATH; install it, or give its full path in the command, and submit again; nothing was written",
            programs[0]
        )));
    }
    Ok(())
}

async fn submit(
    study_file: &Path,
    project_dir: Option<&Path>,
    dry_run: bool,
    as_name: Option<&str>,
    no_reuse: bool,
) -> anyhow::Result<i32> {
    let mut study = Study::load(study_file).map_err(study_error)?;
    if let Some(name) = as_name {
        study.rename(name).map_err(input_error)?;
    }
    study.reuse &= !no_reuse;
    let simulations: Vec<&dyn orch_adapters::Simulation> = if study.fidelities.is_empty() {
        vec![study.simulation.as_ref()]
    } else {
        study
            .fidelities
            .iter()
            .map(|f| f.simulation.as_ref())
            .collect()
    };
    for simulation in simulations {
        check_installed(simulation)?;
    }
    for stage in &study.stages {
        let stage = &stage.stage;
        if let Some(missing) = stage.programs().iter().find(|p| !program_exists(p)) {
            return Err(input_error(format!(
                "the study has a `{}` stage but its program `{missing}` is not on PATH; install it with `{}` and submit again; nothing was written",
                stage.kind(),
                stage.install_hint()
            )));
        }
    }
    if dry_run {
        outln!(
            "{}: {} design points × {} replicates = {} jobs: {} on {}",
            study.name,
            study.points.len(),
            study.replicates,
            study.job_count(),
            study.simulation.equipment_name(),
            solvers_text(&study)
        )?;
        for stage in &study.stages {
            outln!(
                "  each design job followed by a {} stage ({} jobs): {}",
                stage.stage.kind(),
                study.points.len() * study.replicates as usize,
                stage.stage.description()
            )?;
        }
        for (i, point) in study.points.iter().enumerate() {
            let values: Vec<String> = study
                .factors
                .iter()
                .zip(&point.natural)
                .map(|(f, v)| match f.level_text(*v) {
                    Some(level) => format!("{} = {level}", f.name),
                    None => format!("{} = {v:.6} {}", f.name, f.unit),
                })
                .collect();
            let level = match study.fidelities.get(point.fidelity as usize) {
                Some(level) if level.name == level.simulation.solver_name() => {
                    format!(" [{}]", level.name)
                }
                Some(level) => format!(" [{} on {}]", level.name, level.simulation.solver_name()),
                None => String::new(),
            };
            outln!("  p{i:03}: {}{level}", values.join(", "))?;
        }
        out!("{}", dry_run_summary(&study))?;
        return Ok(exit_codes::SUCCESS);
    }
    if study.executor.kind == ExecutorKind::Slurm {
        if let Some(missing) = ["sbatch", "squeue", "scancel"]
            .into_iter()
            .find(|p| !program_exists(p))
        {
            return Err(input_error(format!(
                "the study runs on Slurm but `{missing}` is not on PATH: run orch where Slurm's commands are (a login node), install them (apt-get install slurm-wlm), or start a local test cluster with scripts/slurm up; nothing was written"
            )));
        }
    }
    let project = project::for_study_file(study_file, project_dir).with_context(|| {
        format!(
            "cannot resolve the project directory of {}",
            study_file.display()
        )
    })?;
    let study_file = &std::path::absolute(study_file).unwrap_or_else(|_| study_file.to_path_buf());
    if study.executor.kind == ExecutorKind::Slurm {
        let runs = project.join(project::RUNS_DIR_NAME).join(&study.name);
        crate::executor::slurm::script::check_value(
            "the run directories' folder",
            &runs.display().to_string(),
            crate::executor::slurm::script::PATH_REMEDY,
        )
        .map_err(|e| input_error(format!("{e}; nothing was written")))?;
    }
    let store = Store::open(&project).await?;
    match store.study_by_name(&study.name).await? {
        Some(existing) if existing.file_sha256 == study.file_sha256 => {
            errln!("orch: study `{}` was submitted before from the same file; continuing it", study.name);
            claim_and_reopen(&store, &existing, false).await?;
        }
        Some(existing) => {
            return Err(input_error(format!(
                "a different study named `{name}` already exists in {} (submitted from {}; this file, its template or its files differ); submit this one under another name with `orch submit --as NAME {}`, or remove the old one with `orch delete {name}`; nothing was written",
                store.path().display(),
                existing.file_path,
                study_file.display(),
                name = study.name,
            )))
        }
        None => {
            let runs = project.join(project::RUNS_DIR_NAME);
            store.insert_study(&study, study_file, &runs).await?;
            errln!(
                "orch: study `{}`: {} jobs ({} points × {} replicates) on {}, at most {} at once; store {}",
                study.name,
                study.job_count(),
                study.points.len(),
                study.replicates,
                solvers_text(&study),
                study.executor.max_parallel,
                store.path().display()
            );
        }
    }
    let row = store
        .study_by_name(&study.name)
        .await?
        .context("the study vanished from the store")?;
    drive(&store, &row, &study).await
}

/// Claims the study, drives its rounds, releases it, and reports.
async fn drive(store: &Store, row: &StudyRow, study: &Study) -> anyhow::Result<i32> {
    let (pid, started) = process::current();
    store
        .claim_driver(row, pid, started, process::is_alive)
        .await?;
    let runs_dir = store
        .path()
        .parent()
        .unwrap_or(Path::new("."))
        .join(project::RUNS_DIR_NAME)
        .join(&study.name);
    let outcome = drive_rounds(store, row.id, study, &runs_dir).await;
    let final_state = match &outcome {
        Ok(summary) => match summary.ending {
            Ending::Finished => StudyState::Finished,
            Ending::Interrupted => StudyState::Interrupted,
            Ending::Cancelled => StudyState::Cancelled,
        },
        Err(_) => StudyState::Interrupted,
    };
    store.release_driver(row.id, final_state).await?;
    let summary = outcome?;
    errln!(
        "orch: study `{}` {}: {} succeeded{}, {} failed, {} cancelled, {} unfinished; details: orch status {}",
        study.name,
        match summary.ending {
            Ending::Finished => "finished",
            Ending::Interrupted => "interrupted",
            Ending::Cancelled => "cancelled",
        },
        summary.succeeded,
        match summary.reused {
            0 => String::new(),
            n => format!(" ({n} of them reused identical runs instead of running)"),
        },
        summary.failed,
        summary.cancelled,
        summary.unfinished,
        study.name
    );
    let mut code = match summary.ending {
        Ending::Interrupted => exit_codes::INTERRUPTED,
        Ending::Finished if summary.failed == 0 => exit_codes::SUCCESS,
        _ => exit_codes::JOBS_FAILED,
    };
    if summary.ending == Ending::Finished {
        match drive_noise_design(store, row, study).await? {
            Some(exit_codes::INTERRUPTED) => return Ok(exit_codes::INTERRUPTED),
            Some(exit_codes::SUCCESS) | None => {}
            Some(_) => code = exit_codes::JOBS_FAILED,
        }
        conclude(store, row, study).await;
    }
    Ok(code)
}

/// The noise design after the rounds, when the study has one: its study is written
/// around the optimum (see [`crate::noise`]), stored or found again, and driven like
/// any other; its exit code, or `None` when there is none to run.
async fn drive_noise_design(
    store: &Store,
    row: &StudyRow,
    study: &Study,
) -> anyhow::Result<Option<i32>> {
    let child = match crate::noise::study_of(store, row, study).await? {
        None => return Ok(None),
        Some(Err(why)) => {
            errln!("orch: the noise design cannot run: {why}");
            return Ok(Some(exit_codes::JOBS_FAILED));
        }
        Some(Ok(child)) => child,
    };
    match store.study_by_name(&child.name).await? {
        Some(existing) if existing.file_sha256 == child.file_sha256 => {
            claim_and_reopen(store, &existing, false).await?;
        }
        Some(_) => {
            return Err(input_error(format!(
                "the noise design of `{}` would be stored as `{}`, but a different study has that name; remove it with `orch delete {}` and submit again",
                row.name, child.name, child.name
            )))
        }
        None => {
            let project = store.path().parent().unwrap_or(Path::new("."));
            store
                .insert_study(
                    &child,
                    Path::new(&row.file_path),
                    &project.join(project::RUNS_DIR_NAME),
                )
                .await?;
            errln!(
                "orch: the noise design around the optimum: study `{}`, {} jobs over {}",
                child.name,
                child.job_count(),
                child
                    .factors
                    .iter()
                    .map(|f| f.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
    }
    let child_row = store
        .study_by_name(&child.name)
        .await?
        .context("the noise design's study vanished from the store")?;
    Ok(Some(Box::pin(drive(store, &child_row, &child)).await?))
}

/// The end of a finished study: the recommended design with its bounds and warnings,
/// and the report written to `<project>/reports/<study>.html`. A failure here is said,
/// not fatal: the study itself is done and stored.
async fn conclude(store: &Store, row: &StudyRow, study: &Study) {
    let recommendation = async {
        let rounds = store.rounds(row.id).await?;
        let factors = store.factors(row.id).await?;
        let fitted = crate::surfaces::fitted_names(&rounds);
        let runs = crate::surfaces::design_runs_named(store, row.id, &fitted).await?;
        anyhow::Ok(status::recommendation(study, &rounds, &factors, &runs))
    };
    match recommendation.await {
        Ok(Some(text)) => {
            for line in text.lines() {
                errln!("orch: {line}");
            }
        }
        Ok(None) => {}
        Err(e) => errln!("orch: cannot read the study's optimum back: {e:#}"),
    }
    match crate::noise::summary(store, &row.name).await {
        Ok(Some(noise)) => {
            if let Some(line) = noise.line() {
                errln!("orch:   {line}");
            }
        }
        Ok(None) => {}
        Err(e) => errln!("orch: cannot read the noise design back: {e:#}"),
    }
    let path = store
        .path()
        .parent()
        .unwrap_or(Path::new("."))
        .join("reports")
        .join(format!("{}.html", row.name));
    let written = async {
        // The row as it is now (finished), not as it was when the study was claimed.
        let row = store
            .study_by_name(&row.name)
            .await?
            .unwrap_or_else(|| row.clone());
        let html = crate::report::render(store, &row, Some(study)).await?;
        write_output(&path, html.as_bytes())
    };
    match written.await {
        Ok(()) => {
            let path = std::path::absolute(&path).unwrap_or(path);
            errln!("orch: report: {}", path.display());
        }
        Err(e) => errln!(
            "orch: the report could not be written: {e:#}; `orch report {}` tries again",
            row.name
        ),
    }
}

/// Runs jobs, analyses each finished round, and runs the next until the rounds end.
async fn drive_rounds(
    store: &Store,
    study_id: i64,
    study: &Study,
    runs_dir: &Path,
) -> anyhow::Result<driver::Summary> {
    loop {
        let summary = driver::drive(store, study_id, study).await?;
        if summary.ending != Ending::Finished {
            return Ok(summary);
        }
        match rounds::advance(store, study_id, study, runs_dir).await? {
            rounds::Advance::NextRound(next) => {
                errln!("orch: round {} analysed; round {next} starts", next - 1);
                let rounds = store.rounds(study_id).await?;
                let fitted = crate::surfaces::fitted_names(&rounds);
                for line in status::rounds_summary(
                    &rounds,
                    &store.factors(study_id).await?,
                    &crate::surfaces::design_runs_named(store, study_id, &fitted).await?,
                )
                .lines()
                {
                    errln!("orch:   {line}");
                }
            }
            rounds::Advance::Done(note) => {
                if study.objective.is_some() || !study.responses.is_empty() {
                    errln!("orch: analysis done: {note}");
                }
                return Ok(summary);
            }
        }
    }
}

async fn find(project_dir: Option<&Path>, name: &str) -> anyhow::Result<(Store, StudyRow)> {
    let dirs = project::discover(project_dir);
    match project::find_study(&dirs, name).await? {
        Some(found) => Ok(found),
        None => Err(input_error(format!(
            "no study named `{name}` in {}; `orch status` lists the studies, --project-dir points elsewhere",
            if dirs.is_empty() { "./.orch or ./*/.orch".to_string() } else { dirs.iter().map(|d| d.display().to_string()).collect::<Vec<_>>().join(", ") }
        ))),
    }
}

async fn show_status(
    project_dir: Option<&Path>,
    study: Option<&str>,
    as_json: bool,
) -> anyhow::Result<i32> {
    match study {
        None => {
            let stores = project::open_all(&project::discover(project_dir)).await?;
            let overview = status::overview(&stores, as_json).await?;
            out!("{overview}")?;
        }
        Some(name) => {
            let (store, row) = find(project_dir, name).await?;
            let project = store
                .path()
                .parent()
                .unwrap_or(Path::new("."))
                .to_path_buf();
            let responses = stored_study_to_read(&store, &row)
                .await?
                .map(|s| s.shown_responses())
                .unwrap_or_default();
            // Written as it is read, a page of jobs at a time: a study's status grows
            // with its jobs.
            use std::io::Write;
            let stdout = std::io::BufWriter::new(std::io::stdout().lock());
            let written: Result<(), status::WriteStatusError> = async {
                let mut stdout = if as_json {
                    let mut stdout =
                        status::write_json_paged(&store, row, &project, stdout).await?;
                    stdout.write_all(b"\n")?;
                    stdout
                } else {
                    status::write_table_paged(&store, row, &responses, stdout).await?
                };
                Ok(stdout.flush()?)
            }
            .await;
            match written {
                // The reader has gone (`| head`): nobody wants the rest.
                Err(status::WriteStatusError::Write(e))
                    if e.kind() == std::io::ErrorKind::BrokenPipe => {}
                other => other?,
            }
        }
    }
    Ok(exit_codes::SUCCESS)
}

/// The study as it was submitted: its stored file text, template and files, validated
/// again, every design point included (to run it).
async fn stored_study(store: &Store, row: &StudyRow) -> anyhow::Result<Result<Study, StudyError>> {
    load_stored_study(store, row, false).await
}

/// The stored study for commands that only read it (status, export, report, cancel):
/// validated again except for the per-point check it passed when it was submitted,
/// whose cost grows with the points.
async fn stored_study_to_read(
    store: &Store,
    row: &StudyRow,
) -> anyhow::Result<Result<Study, StudyError>> {
    load_stored_study(store, row, true).await
}

async fn load_stored_study(
    store: &Store,
    row: &StudyRow,
    for_reading: bool,
) -> anyhow::Result<Result<Study, StudyError>> {
    let stored = Stored {
        template: Some(Template {
            name: row.template_name.clone(),
            text: row.template_text.clone(),
        }),
        inputs: store.study_inputs(row.id).await?,
        for_reading,
    };
    let study = Study::from_text(Path::new(&row.file_path), &row.file_text, Some(stored));
    // Submitted with `--as`, the study's name is the stored one, not the file's.
    Ok(study.map(|mut study| {
        study.name = row.name.clone();
        study
    }))
}

/// `orch delete`: the study's records and run directories, and its noise design's,
/// unless one is running.
async fn delete(project_dir: Option<&Path>, name: &str) -> anyhow::Result<i32> {
    let (store, row) = find(project_dir, name).await?;
    let mut rows = vec![row];
    if let Some(noise) = crate::noise::stored_row(&store, name).await? {
        rows.insert(0, noise);
    }
    for row in &rows {
        // What other studies reused of this one is theirs already: their jobs hold
        // their own copy of each run's results, and hard links to its files.
        let reusers = store.reusers_of(row.id).await?;
        store.delete_study(row, process::is_alive).await?;
        let runs = store
            .path()
            .parent()
            .unwrap_or(Path::new("."))
            .join(project::RUNS_DIR_NAME)
            .join(&row.name);
        if runs.exists() {
            std::fs::remove_dir_all(&runs).with_context(|| {
                format!(
                    "the study's records are deleted, but not its runs in {}",
                    runs.display()
                )
            })?;
        }
        errln!("orch: deleted study `{}` and its runs", row.name);
        if let Some(first) = reusers.first() {
            errln!(
                "orch: {} jobs of other studies reused runs of `{}` ({first}{}); they keep their own copies of those runs' results and files",
                reusers.len(),
                row.name,
                if reusers.len() > 1 { ", …" } else { "" }
            );
        }
    }
    Ok(exit_codes::SUCCESS)
}

async fn cancel(project_dir: Option<&Path>, name: &str) -> anyhow::Result<i32> {
    let (store, row) = find(project_dir, name).await?;
    store.set_study_state(row.id, StudyState::Cancelled).await?;
    let jobs: Vec<_> = store
        .jobs(row.id)
        .await?
        .into_iter()
        .filter(|job| !job.state().is_final())
        .collect();
    let handles: Vec<&str> = jobs
        .iter()
        .filter_map(|job| job.executor_handle.as_deref())
        .collect();
    let slurm = stored_study_to_read(&store, &row)
        .await?
        .ok()
        .and_then(|study| study.executor.slurm);
    let stopped = match slurm {
        Some(settings) => {
            // One scancel for all; Slurm ends them, the store records them cancelled.
            let mut executor = SlurmExecutor::new(settings);
            executor.terminate(&handles).await;
            format!("{} Slurm jobs cancelled with scancel", handles.len())
        }
        None => {
            let running: Vec<&str> = handles
                .iter()
                .copied()
                .filter(|h| ProcessHandle::parse(h).is_some_and(|h| h.is_alive()))
                .collect();
            // As the driver stops them: SIGTERM (the native kernel then saves its state,
            // so `orch resume` continues the run), SIGKILL after the grace.
            let mut executor = LocalExecutor::new();
            executor.terminate(&running).await;
            executor.wait_for_terminations().await;
            format!("{} running solvers stopped", running.len())
        }
    };
    let mut cancelled = 0;
    for job in &jobs {
        // The driver, if one runs, may get there first; that is fine.
        if store
            .mark_cancelled(job.id, "cancelled by orch cancel")
            .await
            .is_ok()
        {
            cancelled += 1;
        }
    }
    errln!("orch: study `{name}` cancelled: {cancelled} jobs cancelled, {stopped}; `orch resume {name}` runs them again");
    Ok(exit_codes::SUCCESS)
}

/// Claims the study for this process, then puts its cancelled (and with
/// `retry_failed`, failed) jobs back in the queue. A study another live driver holds is
/// refused before anything is written.
async fn claim_and_reopen(store: &Store, row: &StudyRow, retry_failed: bool) -> anyhow::Result<()> {
    // Every job's state is read before the claim: a store this orch cannot read (a
    // state it does not know) is refused before anything is written.
    store.job_links(row.id).await?;
    let (pid, started) = process::current();
    store
        .claim_driver(row, pid, started, process::is_alive)
        .await?;
    if let Err(e) = reopen(store, row, retry_failed).await {
        store
            .release_driver(row.id, StudyState::Interrupted)
            .await?;
        return Err(e);
    }
    Ok(())
}

/// Puts cancelled (and with `retry_failed`, failed) jobs back in the queue.
async fn reopen(store: &Store, row: &StudyRow, retry_failed: bool) -> anyhow::Result<()> {
    for job in store.job_links(row.id).await? {
        let state = job.state;
        if state == JobState::Cancelled || (retry_failed && state == JobState::Failed) {
            store.reopen(job.id, retry_failed).await?;
        }
    }
    Ok(())
}

async fn resume(
    project_dir: Option<&Path>,
    name: &str,
    retry_failed: bool,
    no_reuse: bool,
) -> anyhow::Result<i32> {
    let (store, row) = find(project_dir, name).await?;
    let mut study = stored_study(&store, &row)
        .await?
        .map_err(|e| input_error(format!("the stored study file no longer validates: {e}")))?;
    study.reuse &= !no_reuse;
    claim_and_reopen(&store, &row, retry_failed).await?;
    if store
        .job_links(row.id)
        .await?
        .iter()
        .all(|j| j.state.is_final())
    {
        errln!("orch: every job of `{name}` is final; nothing to resume (use --retry-failed to run failed jobs again)");
    }
    drive(&store, &row, &study).await
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    #[test]
    fn arguments_are_consistent() {
        Args::command().debug_assert();
    }
}
