//! Running a comparison's runs through an [`Executor`], as a study's jobs run: each in
//! its own process group, at most [`RunOptions::parallel`] at once, stopped past
//! [`RunOptions::time_limit`], and all stopped on Ctrl-C or SIGTERM (the runs that
//! finished are kept, so the next `orch compare` takes them instead of running them
//! again).

use std::collections::{BTreeMap, HashMap, VecDeque};
use std::path::PathBuf;
use std::time::{Duration, Instant};

use orch_adapters::{equipment_for, CommandSpec, EquipmentOnSolver, Simulation};
use tokio::sync::watch;

use super::{analysis, Made, RunOptions, RunOutcome, RunSpec, SuiteCase, NATIVE};
use orch_executor::{Executor, JobStatus, LaunchSpec, Watched};

/// A run rendered and not made before: what launching and reading it needs.
struct Ready {
    index: usize,
    simulation: EquipmentOnSolver,
    parameters: orch_adapters::Case,
    command: CommandSpec,
    identity: String,
}

/// A run handed to the executor.
struct InFlight {
    ready: Ready,
    handle: String,
    started: Instant,
    /// Why it is being stopped, once it is.
    stopping: Option<String>,
}

/// What [`run_all`] did: an outcome per spec, and whether a signal cut it short.
pub(super) struct Ran {
    pub outcomes: Vec<RunOutcome>,
    pub interrupted: bool,
}

/// Renders every spec, takes the runs the project made before from `options.known`,
/// and runs the rest through `executor`, `options.parallel` at a time, in the order of
/// the list. `stop` turning true (Ctrl-C, SIGTERM) stops the running ones; those not
/// finished are outcomes of `Err("interrupted")`.
pub(super) async fn run_all<E: Executor>(
    executor: &mut E,
    cases: &[&SuiteCase],
    specs: &[RunSpec],
    options: &RunOptions,
    stop: &watch::Receiver<bool>,
) -> Ran {
    let mut outcomes: Vec<Option<RunOutcome>> = vec![None; specs.len()];
    let mut queue = VecDeque::new();
    for (index, spec) in specs.iter().enumerate() {
        let case = cases[spec.case];
        let perturbation = if spec.solver.name == NATIVE {
            options.perturbation.clone()
        } else {
            BTreeMap::new()
        };
        match prepare(index, case, spec, &perturbation, &options.known) {
            Ok(Prepared::Reused(made)) => outcomes[index] = Some(Ok(made)),
            Ok(Prepared::Ready(ready)) => queue.push_back(*ready),
            Err(why) => outcomes[index] = Some(Err(why)),
        }
    }
    let mut flying: Vec<InFlight> = Vec::new();
    let mut interrupted = false;
    loop {
        if *stop.borrow() && !interrupted {
            interrupted = true;
            for run in queue.drain(..) {
                outcomes[run.index] = Some(Err("interrupted before it started".into()));
            }
            stop_runs(executor, &mut flying, |_| true, "interrupted").await;
        }
        while flying.len() < options.parallel.max(1) && !interrupted {
            let Some(ready) = queue.pop_front() else {
                break;
            };
            let spec = &specs[ready.index];
            let launch = LaunchSpec {
                name: format!(
                    "compare/{}/{}-seed{}",
                    cases[spec.case].name, spec.solver.name, spec.seed
                ),
                run_dir: spec.dir.clone(),
                command: ready.command.clone(),
            };
            match executor.launch(&launch).await {
                Ok(launched) => flying.push(InFlight {
                    ready,
                    handle: launched.handle,
                    started: Instant::now(),
                    stopping: None,
                }),
                Err(e) => {
                    let hint = ready.simulation.install_hint();
                    outcomes[ready.index] = Some(Err(format!("cannot start it ({e}); {hint}")));
                }
            }
        }
        if flying.is_empty() && (queue.is_empty() || interrupted) {
            break;
        }
        let limit = options.time_limit;
        stop_runs(
            executor,
            &mut flying,
            |run| run.started.elapsed() > limit,
            &format!(
                "it ran past the time limit of {}",
                humantime::format_duration(limit)
            ),
        )
        .await;
        tokio::time::sleep(executor.poll_interval()).await;
        executor.tidy();
        let watched: Vec<Watched<'_>> = flying
            .iter()
            .map(|run| Watched {
                handle: &run.handle,
                run_dir: &specs[run.ready.index].dir,
            })
            .collect();
        let Ok(reports) = executor.poll(&watched).await else {
            continue;
        };
        let mut still = Vec::with_capacity(flying.len());
        for (run, report) in flying.into_iter().zip(reports) {
            let spec = &specs[run.ready.index];
            let log = spec.dir.join(&run.ready.command.log_file);
            let outcome = match (report.status, &run.stopping) {
                (JobStatus::Queued | JobStatus::Running, _) => {
                    still.push(run);
                    continue;
                }
                (_, Some(why)) => Err(why.clone()),
                (JobStatus::Exited(0), None) => read(cases[spec.case], spec, &run.ready),
                (JobStatus::Exited(code), None) => Err(format!(
                    "the solver failed (exit status {code}); see {}",
                    log.display()
                )),
                (JobStatus::Stopped { reason, .. }, None) => Err(format!("stopped: {reason}")),
                (JobStatus::Lost, None) => Err("it ended without an exit status".into()),
            };
            tracing::info!(
                case = %cases[spec.case].name, solver = spec.solver.name, seed = spec.seed,
                ok = outcome.is_ok(), "compare run finished"
            );
            outcomes[run.ready.index] = Some(outcome);
        }
        flying = still;
    }
    // Let the processes of stopped runs go before their directories are read or removed.
    let deadline =
        Instant::now() + orch_executor::local::TERMINATION_GRACE + Duration::from_secs(2);
    while executor.tidy() > 0 && Instant::now() < deadline {
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    Ran {
        outcomes: outcomes
            .into_iter()
            .map(|o| o.unwrap_or_else(|| Err("interrupted".into())))
            .collect(),
        interrupted,
    }
}

/// Terminates the runs `which` picks that are not being stopped yet, saying `why`.
async fn stop_runs<E: Executor>(
    executor: &mut E,
    flying: &mut [InFlight],
    which: impl Fn(&InFlight) -> bool,
    why: &str,
) {
    let chosen: Vec<&mut InFlight> = flying
        .iter_mut()
        .filter(|run| run.stopping.is_none() && which(run))
        .collect();
    if chosen.is_empty() {
        return;
    }
    let handles: Vec<String> = chosen.iter().map(|run| run.handle.clone()).collect();
    for run in chosen {
        run.stopping = Some(why.to_string());
    }
    let handles: Vec<&str> = handles.iter().map(String::as_str).collect();
    executor.terminate(&handles).await;
}

/// A run rendered: made before (its values taken) or ready to launch.
enum Prepared {
    Reused(Made),
    Ready(Box<Ready>),
}

/// Renders one run into its directory and takes its values from `known` when the
/// project already made it.
fn prepare(
    index: usize,
    case: &SuiteCase,
    spec: &RunSpec,
    perturbation: &BTreeMap<String, f64>,
    known: &HashMap<String, analysis::RunValues>,
) -> Result<Prepared, String> {
    let equipment = equipment_for(&case.equipment).expect("checked when loaded");
    let simulation = EquipmentOnSolver::new(equipment, spec.solver).ok_or_else(|| {
        format!(
            "{} has no template for {}",
            spec.solver.name, case.equipment
        )
    })?;
    let parameters = case.case(spec.seed, perturbation);
    clean_dir(&spec.dir)?;
    simulation
        .render(&parameters, &spec.dir)
        .map_err(|e| format!("cannot render: {e}"))?;
    let command = simulation.command();
    let identity = orch_study::identity::of_run(&spec.dir, &command, "")
        .map_err(|e| format!("cannot read the rendered run: {e}"))?;
    if let Some(values) = known.get(&identity) {
        // A reused run brings what it measured of the flow, not its speed: speed is of
        // the moment and the machine it ran on, and the native/reference ratio must
        // compare runs that shared one machine at one time.
        let mut values = values.clone();
        values.retain(|name, _| !name.starts_with("solver_"));
        return Ok(Prepared::Reused(Made {
            values,
            identity,
            reused: true,
        }));
    }
    Ok(Prepared::Ready(Box::new(Ready {
        index,
        simulation,
        parameters,
        command,
        identity,
    })))
}

/// An empty run directory at `dir`.
fn clean_dir(dir: &PathBuf) -> Result<(), String> {
    if dir.exists() {
        std::fs::remove_dir_all(dir).map_err(|e| format!("cannot clear the run directory: {e}"))?;
    }
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create the run directory: {e}"))
}

/// The values of a run that exited 0; a response the case compares that the run
/// lacks is a failure.
fn read(case: &SuiteCase, spec: &RunSpec, ready: &Ready) -> RunOutcome {
    let results = ready
        .simulation
        .results(&ready.parameters, &spec.dir)
        .map_err(|e| e.to_string())?;
    let mut values: analysis::RunValues = results.responses.into_iter().collect();
    for (name, why) in results.missing {
        if case.responses.contains_key(&name) {
            return Err(format!("no {name}: {why}"));
        }
        values.remove(&name);
    }
    Ok(Made {
        values,
        identity: ready.identity.clone(),
        reused: false,
    })
}
