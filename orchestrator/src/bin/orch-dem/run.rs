//! `orch-dem run`: reads a case file, its meshes, any packing and air velocity field, runs the
//! kernel, looks for the case's stop file, writes the log,
//! the sensor's crossings and any dumps. All the kernel's I/O happens here.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::Context;
use orch_dem::awake::AwakeWorkers;
use orch_dem::case::Case;
use orch_dem::output::{write_crossings, write_dump_custom, write_vtk_legacy, CROSSINGS_HEADER};
use orch_dem::simulation::StageTimers;
use orch_dem::Simulation;
// The log format the native adapter reads.
use orch_adapters::native::{InflowLine, THERMO_HEADER};

use orch_executor::RESTART_LIST;

use crate::restart;
use crate::signals::{StopSignal, StopSignals};

/// A case file that cannot be run as written (exit status 2).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct BadCase(pub String);

/// A run that a stop signal ended after saving its state (exit status 128 + the
/// signal's number, see [`signals`](crate::signals)).
#[derive(Debug, thiserror::Error)]
#[error(
    "Stopped by {} at step {step} (t = {time_s:.6} s), its state saved in {}: run the same case again to continue from there",
    .signal.name(),
    .restart_file.display()
)]
pub struct StoppedBySignal {
    /// The signal.
    pub signal: StopSignal,
    /// The last step taken.
    pub step: u64,
    /// Simulated time at that step, s.
    pub time_s: f64,
    /// The restart file holding the state at that step.
    pub restart_file: PathBuf,
}

/// A run paused by `--stop-at`: its state saved at the first step at or after the
/// asked time, to be continued by running the same case again.
#[derive(Debug, Clone)]
pub struct Paused {
    /// The last step taken.
    pub step: u64,
    /// Simulated time at that step, s.
    pub time_s: f64,
    /// The restart file holding the state at that step.
    pub restart_file: PathBuf,
    /// What this leg of the run (since it started or continued) measured.
    pub leg: Leg,
    /// This leg's `Stage times` line (see [`profile`]).
    pub stages: String,
}

/// The time loop's wall time and work over a stretch of a run: one leg (from its
/// start or the restart file it continued from, to its end or pause; timing a leg
/// times a window of simulated time on its own), or the whole run.
#[derive(Debug, Clone, Copy)]
pub struct Leg {
    /// Wall time of the time loop over the stretch.
    pub loop_time: Duration,
    /// Steps taken.
    pub steps: u64,
    /// Σ particles × steps.
    pub particle_steps: u64,
}

impl Leg {
    /// Particle-steps per second of wall time.
    pub fn throughput(&self) -> f64 {
        self.particle_steps as f64 / self.loop_time.as_secs_f64()
    }
}

/// How a run that did not fail ended.
#[derive(Debug, Clone)]
pub enum RunEnd {
    /// It reached its end time (or its stop file or stop condition ended it).
    Finished(RunSummary),
    /// `--stop-at` paused it, its state saved.
    Paused(Paused),
}

/// What a finished run measured.
#[derive(Debug, Clone)]
pub struct RunSummary {
    /// The whole run, over every leg (the same as `leg` unless it continued from a
    /// restart file).
    pub whole: Leg,
    /// Time per stage.
    pub timers: StageTimers,
    /// Particles left at the end.
    pub remaining: usize,
    /// Mass that left through the sink, kg.
    pub discharged_mass_kg: f64,
    /// Whether the case's `stop_file` ended the run before `end_time`.
    pub stopped_by_stop_file: bool,
    /// The last leg alone (the whole run unless it continued from a restart file).
    pub leg: Leg,
}

/// Reads `case_path`, the meshes, the packing and the air velocity field it names (relative to its
/// folder) into a ready simulation; bad input is a [`BadCase`] naming the file.
pub fn load(case_path: &Path) -> anyhow::Result<(Case, Simulation)> {
    let text = std::fs::read_to_string(case_path)
        .with_context(|| format!("cannot read the case file {}", case_path.display()))?;
    let bad = |message: String| BadCase(format!("{}: {message}", case_path.display()));
    let case = Case::parse(&text).map_err(|e| bad(e.to_string()))?;
    let dir = case_path.parent().unwrap_or(Path::new("."));
    let mut walls = Vec::new();
    for (index, mesh) in case.meshes.iter().enumerate() {
        let path = dir.join(&mesh.file);
        let bytes = std::fs::read(&path).map_err(|e| {
            bad(format!(
                "mesh `{}`: cannot read {}: {e}",
                mesh.name,
                path.display()
            ))
        })?;
        walls.push(
            case.wall_mesh(index, &bytes)
                .map_err(|e| bad(e.to_string()))?,
        );
    }
    let air_field = match case.air_field_file() {
        None => None,
        Some(file) => {
            let path = dir.join(file);
            let text = std::fs::read_to_string(&path).map_err(|e| {
                bad(format!(
                    "`air.velocity_field`: cannot read {}: {e}",
                    path.display()
                ))
            })?;
            Some(case.air_field(&text).map_err(|e| bad(e.to_string()))?)
        }
    };
    let packing = match case.packing_file() {
        None => None,
        Some(file) => {
            let path = dir.join(file);
            Some(std::fs::read_to_string(&path).map_err(|e| {
                bad(format!(
                    "`packing.file`: cannot read {}: {e}",
                    path.display()
                ))
            })?)
        }
    };
    let simulation = case
        .build_from(walls, air_field, packing.as_deref())
        .map_err(|e| bad(e.to_string()))?;
    Ok((case, simulation))
}

/// One line per inflow that has begun: the mass it placed against the mass its batches
/// asked for, the share of each type (named `type_names`, in type order) in what it
/// placed, and whether it fell short by more than one particle (its region had no
/// room for the rest; the run then holds less material than the case asked for).
fn inflow_report(simulation: &Simulation, type_names: &[&str]) -> Vec<InflowLine> {
    let heaviest_kg = simulation
        .types()
        .iter()
        .map(|t| t.mass_kg())
        .fold(0.0, f64::max);
    let count = simulation.inflows().len();
    simulation
        .inflows()
        .iter()
        .enumerate()
        .filter(|(_, inflow)| inflow.asked_mass_kg() > 0.0)
        .map(|(k, inflow)| {
            let (placed_kg, asked_kg) = (inflow.inserted_mass_kg(), inflow.asked_mass_kg());
            InflowLine {
                number: k + 1,
                count,
                placed_kg,
                asked_kg,
                shares_by_mass_percent: inflow
                    .inserted_mass_by_type_kg()
                    .iter()
                    .zip(type_names)
                    .map(|(kg, name)| {
                        (
                            name.to_string(),
                            100.0 * kg / placed_kg.max(f64::MIN_POSITIVE),
                        )
                    })
                    .collect(),
                short: asked_kg - placed_kg > heaviest_kg,
            }
        })
        .collect()
}

/// Runs the case at `case_path` on `threads` threads, writing the log to `log_path`
/// and outputs under `post/` beside the case file. The kernel's state is saved to a
/// restart file (see [`restart`]) at the first log line after each `restart_every` of
/// wall time; a run started where the restart file of the same case lies continues
/// from it. A run that ends (finished, stopped, or unstable) removes its restart file.
///
/// With `stop_at_s` before the case's end, the run pauses at the first step at or
/// after that simulated time (s): the state is saved to the restart file as a stop
/// signal saves it, and running the same case again continues from there, bit for bit.
pub fn run_until(
    case_path: &Path,
    log_path: &Path,
    threads: usize,
    restart_every: Duration,
    stop_at_s: Option<f64>,
) -> anyhow::Result<RunEnd> {
    if let Some(t) = stop_at_s.filter(|t| !(t.is_finite() && *t > 0.0)) {
        anyhow::bail!(
            "--stop-at {t}: expected a positive simulated time in seconds; give one, or leave it out to run to the case's end time"
        );
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .context("cannot start the worker threads")?;
    let loaded = pool.install(|| load(case_path));
    let (case, mut simulation) = match loaded {
        Ok(loaded) => loaded,
        Err(error) => {
            let mut log = create(log_path, "the log")?;
            writeln!(log, "ERROR: {error:#}")?;
            return Err(error);
        }
    };
    let case_dir = case_path.parent().unwrap_or(Path::new("."));
    let post = case_dir.join("post");
    let stop_file = case.run.stop_file.as_ref().map(|name| case_dir.join(name));
    std::fs::create_dir_all(&post).with_context(|| format!("cannot create {}", post.display()))?;
    let crossings_path = post.join("crossings.csv");
    let restart_path = restart::path_in(&post);
    // Taken once, when a restart file is read or first written: it reads the program.
    let mut fingerprint: Option<[u8; 32]> = None;
    let found = restart::read(&restart_path, || {
        Ok(*fingerprint.insert(restart::fingerprint(case_path, &case)?))
    })?;

    // Lines for the end of the log, after the loop line.
    let mut end_notes = Vec::new();
    let continued = match found {
        restart::Found::Nothing => None,
        restart::Found::SetAside(why) => {
            end_notes.push(set_aside_note(&restart_path, &why));
            None
        }
        restart::Found::Usable(header, state) => {
            match continue_outputs(log_path, &crossings_path, &header) {
                Err(why) => {
                    end_notes.push(set_aside_note(&restart_path, &why));
                    None
                }
                Ok((log, crossings)) => match simulation.restore(*state) {
                    Err(e) => {
                        end_notes.push(set_aside_note(&restart_path, &e.to_string()));
                        None
                    }
                    Ok(()) => {
                        end_notes.push(format!(
                            "Resumed from the restart file {} at step {} (t = {:.6} s); the loop line counts the time loop of every leg, {:.3} s before this one",
                            restart_path.display(),
                            simulation.step_count(),
                            simulation.time_s(),
                            header.loop_s
                        ));
                        Some((header.loop_s, log, crossings))
                    }
                },
            }
        }
    };
    for note in &end_notes {
        eprintln!("orch-dem: {note}");
    }
    let dt = simulation.config().timestep_s;
    let steps = (case.run.end_time / dt).round() as u64;
    let stop_step = stop_at_s.map(|t| (t / dt).ceil() as u64);
    if let Some(stop_step) = stop_step.filter(|&s| s <= simulation.step_count()) {
        anyhow::bail!(
            "--stop-at {} s: the run is already at step {} (t = {:.6} s), past step {stop_step}; give a later time, or leave it out to run to the end",
            stop_at_s.unwrap_or_default(),
            simulation.step_count(),
            simulation.time_s()
        );
    }
    let (first_step, first_particle_steps) = (simulation.step_count(), simulation.particle_steps());
    let thermo = |log: &mut BufWriter<File>, s: &Simulation| -> std::io::Result<()> {
        writeln!(
            log,
            "{} {:.6} {} {:.6e} {:.6e}",
            s.step_count(),
            s.time_s(),
            s.remaining(),
            s.particles.kinetic_energy_j(),
            s.discharged_mass_kg()
        )?;
        log.flush()
    };
    let (earlier_loop_s, mut log, mut crossings) = match continued {
        Some(continued) => continued,
        None => {
            let mut log = create(log_path, "the log")?;
            let mut crossings = create(&crossings_path, "the crossings file")?;
            writeln!(crossings, "{CROSSINGS_HEADER}")?;
            writeln!(
                log,
                "orch-dem {}: case {}, {} particles of {} types, {} meshes, dt {dt:e} s, {steps} steps, {threads} threads",
                env!("CARGO_PKG_VERSION"),
                case_path.display(),
                simulation.particles.len(),
                simulation.types().len(),
                simulation.meshes().len(),
            )?;
            writeln!(log, "{THERMO_HEADER}")?;
            thermo(&mut log, &simulation)?;
            (0.0, log, crossings)
        }
    };

    let started = Instant::now();
    let mut saves = RestartSaves::new(restart_list(case_dir, log_path), fingerprint);
    let fingerprint = || restart::fingerprint(case_path, &case);
    let signals = StopSignals::watch().context("cannot watch for SIGTERM and SIGINT")?;
    let mut stopped_by_stop_file = false;
    // `Ok(Some(stages))`: paused by `--stop-at`, its state saved; the leg's stage times.
    let outcome = pool.install(|| -> anyhow::Result<Option<String>> {
        // The other threads poll for the next pass instead of sleeping between passes.
        let _awake = AwakeWorkers::start();
        while simulation.step_count() < steps {
            if let Err(unstable) = simulation.step() {
                writeln!(log, "ERROR: {unstable}")?;
                log.flush()?;
                // Its end is decided: nothing to continue from.
                let _ = remove_restart_files(&restart_path, &saves.list.0);
                anyhow::bail!(unstable);
            }
            write_crossings(&mut crossings, &simulation.take_crossings())?;
            let step = simulation.step_count();
            if step.is_multiple_of(case.run.thermo_every.max(1)) {
                thermo(&mut log, &simulation)?;
                crossings.flush()?;
                // One look per log line; on the last step the run ends anyway.
                stopped_by_stop_file =
                    step < steps && stop_file.as_ref().is_some_and(|file| file.exists());
            }
            write_snapshots(&case, &simulation, &post)?;
            let stop = stopped_by_stop_file
                || case.run.stop_when_at_most.is_some_and(|at_most| {
                    simulation.time_s() >= case.run.stop_check_after
                        && simulation.remaining() <= at_most
                });
            if stop {
                break;
            }
            // A stop signal or `--stop-at` saves at this step; otherwise a save is due
            // at a log line.
            let signal = signals.received().filter(|_| step < steps);
            let pause = stop_step.is_some_and(|s| step >= s) && step < steps;
            let logged = step.is_multiple_of(case.run.thermo_every.max(1));
            if signal.is_some() || pause || (logged && saves.due(restart_every)) {
                let loop_s = earlier_loop_s + started.elapsed().as_secs_f64();
                saves.save(
                    &restart_path,
                    fingerprint,
                    &mut log,
                    &mut crossings,
                    loop_s,
                    &simulation,
                )?;
            }
            // After the save, the line saying why: a run continued from it cuts the
            // line off again.
            if let Some(signal) = signal {
                let stopped = StoppedBySignal {
                    signal,
                    step,
                    time_s: simulation.time_s(),
                    restart_file: restart_path.clone(),
                };
                writeln!(log, "{stopped}")?;
                log.flush()?;
                return Err(stopped.into());
            }
            if pause {
                writeln!(
                    log,
                    "Paused by --stop-at at step {step} (t = {:.6} s), its state saved in {}: run the same case again to continue",
                    simulation.time_s(),
                    restart_path.display()
                )?;
                // This leg's stages (the timers start from zero in each leg).
                let stages = profile(&simulation.timers(), started.elapsed());
                writeln!(log, "{stages}")?;
                log.flush()?;
                return Ok(Some(stages));
            }
        }
        Ok(None)
    });
    let leg_time = started.elapsed();
    let loop_time = Duration::from_secs_f64(earlier_loop_s) + leg_time;
    crossings.flush()?;
    let leg = Leg {
        loop_time: leg_time,
        steps: simulation.step_count() - first_step,
        particle_steps: simulation.particle_steps() - first_particle_steps,
    };
    if let Some(stages) = outcome? {
        return Ok(RunEnd::Paused(Paused {
            step: simulation.step_count(),
            time_s: simulation.time_s(),
            restart_file: restart_path,
            leg,
            stages,
        }));
    }
    // The run has ended: nothing to continue from.
    end_notes.extend(remove_restart_files(&restart_path, &saves.list.0));
    thermo(&mut log, &simulation)?;
    let summary = RunSummary {
        whole: Leg {
            loop_time,
            steps: simulation.step_count(),
            particle_steps: simulation.particle_steps(),
        },
        timers: simulation.timers(),
        remaining: simulation.remaining(),
        discharged_mass_kg: simulation.discharged_mass_kg(),
        stopped_by_stop_file,
        leg,
    };
    let loop_line = orch_adapters::native::LoopLine {
        seconds: loop_time.as_secs_f64(),
        threads,
        steps: summary.whole.steps,
        particle_steps: summary.whole.particle_steps as f64,
    };
    writeln!(log, "{loop_line}")?;
    writeln!(log, "{}", profile(&summary.timers, leg_time))?;
    for note in &end_notes {
        writeln!(log, "{note}")?;
    }
    if saves.count > 0 {
        writeln!(
            log,
            "Restart files: {} written in {:.3} s, every {} s of wall time or more",
            saves.count,
            saves.time.as_secs_f64(),
            restart_every.as_secs_f64()
        )?;
    }
    writeln!(
        log,
        "Wall impact energy of {:.9e} J",
        simulation.wall_impact_energy_j()
    )?;
    writeln!(
        log,
        "{}",
        orch_adapters::native::LargestOverlapLine(simulation.largest_overlap_ratio())
    )?;
    let type_names: Vec<&str> = case.types.iter().map(|t| t.name.as_str()).collect();
    for line in inflow_report(&simulation, &type_names) {
        writeln!(log, "{line}")?;
        if line.short {
            eprintln!("orch-dem: warning: {line}");
        }
    }
    let (spilled, spilled_kg) = simulation.spilled();
    if spilled > 0 {
        writeln!(
            log,
            "Spilled before the sensor's start: {spilled} particles, {spilled_kg:.6e} kg (taken by the sink, not counted as discharged)"
        )?;
    }
    if let Some(file) = stop_file.filter(|_| stopped_by_stop_file) {
        // After the loop line, where the native adapter's log reader ignores it.
        writeln!(
            log,
            "Stopped by the stop file {} at step {} (t = {:.6} s), before the end time {} s",
            file.display(),
            summary.whole.steps,
            simulation.time_s(),
            case.run.end_time
        )?;
    }
    writeln!(
        log,
        "ORCH-DEM DONE at step {} (t = {:.6} s) with {} particles left",
        summary.whole.steps,
        simulation.time_s(),
        summary.remaining
    )?;
    // Last, as LAMMPS ends its logs: the one figure to compare runs by.
    writeln!(
        log,
        "Performance: {:.4e} particle-steps/s on {threads} threads",
        summary.whole.throughput()
    )?;
    log.flush()?;
    Ok(RunEnd::Finished(summary))
}

/// Creates (or empties) the output file at `path`, `what` for the error.
fn create(path: &Path, what: &str) -> anyhow::Result<BufWriter<File>> {
    let file =
        File::create(path).with_context(|| format!("cannot write {what} {}", path.display()))?;
    Ok(BufWriter::new(file))
}

/// Removes the restart file and the restart list of a run whose end is decided;
/// returns a log line for each that exists but could not be removed.
fn remove_restart_files(restart_file: &Path, restart_list: &Path) -> Vec<String> {
    [restart_file, restart_list]
        .into_iter()
        .filter_map(|file| match std::fs::remove_file(file) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                Some(format!("{} could not be removed: {e}", file.display()))
            }
            _ => None,
        })
        .collect()
}

/// The log line for a restart file at `path` that was not continued from, and why.
fn set_aside_note(path: &Path, why: &str) -> String {
    format!(
        "The restart file {} was set aside and the run started from t = 0: {why}",
        path.display()
    )
}

/// The log and the crossings file of a run continued from a restart file of `header`:
/// each cut back to its length when the state was saved, open for appending. Either
/// shorter than that (removed or cut since) is a reason not to continue.
fn continue_outputs(
    log_path: &Path,
    crossings_path: &Path,
    header: &restart::Header,
) -> Result<(BufWriter<File>, BufWriter<File>), String> {
    let reopen = |path: &Path, bytes: u64| -> Result<BufWriter<File>, String> {
        let file = std::fs::OpenOptions::new()
            .append(true)
            .open(path)
            .map_err(|e| format!("{} cannot be opened ({e})", path.display()))?;
        let length = file.metadata().map_err(|e| e.to_string())?.len();
        if length < bytes {
            return Err(format!(
                "{} holds {length} bytes, fewer than the {bytes} it held when the state was saved",
                path.display()
            ));
        }
        file.set_len(bytes).map_err(|e| e.to_string())?;
        Ok(BufWriter::new(file))
    };
    Ok((
        reopen(log_path, header.log_bytes)?,
        reopen(crossings_path, header.crossings_bytes)?,
    ))
}

/// The restart list orch reads ([`RESTART_LIST`], beside the case) and its text: what
/// a new attempt of the job must keep for this run to continue, `post/` and the log
/// (when the log lies in the case's folder).
fn restart_list(case_dir: &Path, log_path: &Path) -> (PathBuf, String) {
    let mut text = String::from("post\n");
    if let Ok(log) = log_path.strip_prefix(case_dir) {
        text.push_str(&format!("{}\n", log.display()));
    }
    (case_dir.join(RESTART_LIST), text)
}

/// When the run last saved its state, how often and how long saving took, the
/// restart list written with the first save, and the fingerprint of the case and
/// program once taken.
#[derive(Debug)]
struct RestartSaves {
    last: Instant,
    count: u64,
    time: Duration,
    list: (PathBuf, String),
    fingerprint: Option<[u8; 32]>,
}

impl RestartSaves {
    fn new(list: (PathBuf, String), fingerprint: Option<[u8; 32]>) -> Self {
        Self {
            last: Instant::now(),
            count: 0,
            time: Duration::ZERO,
            list,
            fingerprint,
        }
    }

    /// Whether `every` has passed since the start or the last save.
    fn due(&self, every: Duration) -> bool {
        self.last.elapsed() >= every
    }

    /// Saves `simulation`'s state to `path`, with the case and program's fingerprint
    /// (taken with `fingerprint` at the first save if not known), the lengths of the log
    /// and the crossings file (flushed first) and the time loop's wall time so far,
    /// `loop_s`.
    fn save(
        &mut self,
        path: &Path,
        fingerprint: impl FnOnce() -> anyhow::Result<[u8; 32]>,
        log: &mut BufWriter<File>,
        crossings: &mut BufWriter<File>,
        loop_s: f64,
        simulation: &Simulation,
    ) -> anyhow::Result<()> {
        let started = Instant::now();
        log.flush()?;
        crossings.flush()?;
        let fingerprint = match self.fingerprint {
            Some(fingerprint) => fingerprint,
            None => *self.fingerprint.insert(fingerprint()?),
        };
        let header = restart::Header::new(
            fingerprint,
            log.get_ref().metadata()?.len(),
            crossings.get_ref().metadata()?.len(),
            loop_s,
        );
        restart::write(path, &header, &simulation.saved_state())?;
        if self.count == 0 {
            let (list, text) = &self.list;
            std::fs::write(list, text)
                .with_context(|| format!("cannot write the restart list {}", list.display()))?;
        }
        self.time += started.elapsed();
        self.count += 1;
        self.last = Instant::now();
        Ok(())
    }
}

/// Where the loop's time went, as one line.
pub fn profile(timers: &StageTimers, total: Duration) -> String {
    let share = |d: Duration| 100.0 * d.as_secs_f64() / total.as_secs_f64().max(1e-12);
    let pairs = timers
        .pairs_per_particle()
        .map(|(listed, touching)| {
            format!("; per particle {listed:.2} pairs listed, {touching:.2} touching")
        })
        .unwrap_or_default();
    format!(
        "Stage times: pair forces {:.1} %, walls, gather and closing kick {:.1} %, neighbour rebuilds {:.1} % ({} rebuilds{pairs}), integration {:.1} %",
        share(timers.pairs),
        share(timers.gather_and_walls),
        share(timers.neighbours),
        timers.rebuilds,
        share(timers.integrate)
    )
}

fn write_snapshots(case: &Case, simulation: &Simulation, post: &Path) -> anyhow::Result<()> {
    let step = simulation.step_count();
    let due = |every: u64| every > 0 && step.is_multiple_of(every);
    let file = |name: String| -> anyhow::Result<BufWriter<File>> {
        let path: PathBuf = post.join(name);
        Ok(BufWriter::new(File::create(&path).with_context(|| {
            format!("cannot write {}", path.display())
        })?))
    };
    if due(case.output.dump_every) {
        let mut out = file(format!("dump{step}.liggghts"))?;
        write_dump_custom(
            &mut out,
            step,
            &simulation.particles,
            simulation.config().domain_min_m,
            simulation.config().domain_max_m,
        )?;
        out.flush()?;
    }
    if due(case.output.vtk_every) {
        let mut out = file(format!("particles_{step}.vtk"))?;
        write_vtk_legacy(&mut out, simulation.time_s(), &simulation.particles)?;
        out.flush()?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use std::io::BufReader;

    use orch_adapters::dump::read_dump;
    use orch_adapters::native::{read_crossings, read_log};

    use super::*;

    /// One glass sphere (4 mm radius, so that 0.1 ms is a safe step) launched down at
    /// 1 m/s through a sensor plane 4 mm below it (it crosses near step 40), for 2000
    /// steps of 0.1 ms, a log line every 100 steps
    /// and a dump every 50; its stop file is `STOP`.
    const CASE: &str = r#"
[run]
timestep = 1e-4
end_time = 0.2
seed = 1
thermo_every = 100
stop_file = "STOP"
skin = 0.01

[domain]
min = [-0.05, -0.05, -0.5]
max = [0.05, 0.05, 0.05]

[[types]]
name = "glass"
radius = 0.004
density = 2500
youngs_modulus = 5e6
poisson_ratio = 0.3
restitution = 0.5
friction = 0.3

[wall_material]
youngs_modulus = 5e6
poisson_ratio = 0.3
restitution = 0.5
friction = 0.3

[[particles]]
type = "glass"
position = [0.0, 0.0, 0.004]
velocity = [0.0, 0.0, -1.0]

[sensor]
z = 0.0

[output]
dump_every = 50
"#;

    /// [`run_until`] to the case's end.
    fn run(
        case_path: &Path,
        log_path: &Path,
        threads: usize,
        restart_every: Duration,
    ) -> anyhow::Result<RunSummary> {
        match run_until(case_path, log_path, threads, restart_every, None)? {
            RunEnd::Finished(summary) => Ok(summary),
            RunEnd::Paused(paused) => panic!("a run without --stop-at paused: {paused:?}"),
        }
    }

    /// A fresh folder holding `case_text` as `case.toml`; returns the folder, the case
    /// file's path and the log's (not yet written).
    fn case_folder(case_text: &str) -> (tempfile::TempDir, PathBuf, PathBuf) {
        let dir = tempfile::tempdir().unwrap();
        let case = dir.path().join("case.toml");
        std::fs::write(&case, case_text).unwrap();
        let log = dir.path().join("log.native");
        (dir, case, log)
    }

    /// Runs `CASE` in a fresh folder, with its stop file there from the start when
    /// `stop_file_present`; returns the folder, the summary and the log's text.
    fn run_case(stop_file_present: bool) -> (tempfile::TempDir, RunSummary, String) {
        let (dir, case, log) = case_folder(CASE);
        if stop_file_present {
            std::fs::write(dir.path().join("STOP"), "").unwrap();
        }
        let summary = run(&case, &log, 1, Duration::from_secs(600)).unwrap();
        let text = std::fs::read_to_string(&log).unwrap();
        (dir, summary, text)
    }

    /// The log, crossings and dumps of a finished run read back as the native adapter
    /// reads them; returns the dumps' time steps in order.
    fn check_outputs(dir: &Path, summary: &RunSummary) -> Vec<u64> {
        let log_path = dir.join("log.native");
        let log = read_log(BufReader::new(File::open(&log_path).unwrap()), &log_path).unwrap();
        assert_eq!(log.steps, summary.whole.steps);
        let last = *log.kinetic_energy.last().unwrap();
        assert_eq!(last.0, summary.whole.steps as f64 * 1e-4);
        let crossings_path = dir.join("post/crossings.csv");
        let crossings = read_crossings(
            BufReader::new(File::open(&crossings_path).unwrap()),
            &crossings_path,
        )
        .unwrap();
        assert_eq!(crossings.len(), 1, "{crossings:?}");
        let mut dumps: Vec<u64> = std::fs::read_dir(dir.join("post"))
            .unwrap()
            .filter_map(|e| {
                let name = e.unwrap().file_name().into_string().unwrap();
                name.strip_prefix("dump")?
                    .strip_suffix(".liggghts")?
                    .parse()
                    .ok()
            })
            .collect();
        dumps.sort_unstable();
        for step in &dumps {
            let path = dir.join(format!("post/dump{step}.liggghts"));
            let read = read_dump(BufReader::new(File::open(&path).unwrap()), &path, |s| {
                assert_eq!((s.timestep, s.len()), (*step, 1));
                Ok(())
            })
            .unwrap();
            assert_eq!(read.snapshots, 1);
        }
        dumps
    }

    /// The log's thermo rows (the lines after its header, which names the case's
    /// folder, up to its loop line), and every file under `post/` with its bytes.
    fn run_record(dir: &Path) -> (Vec<String>, Vec<(String, Vec<u8>)>) {
        let log = std::fs::read_to_string(dir.join("log.native")).unwrap();
        let rows = log
            .lines()
            .skip(1)
            .take_while(|l| !l.starts_with("Loop time"))
            .map(str::to_string)
            .collect();
        let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir.join("post"))
            .unwrap()
            .map(|e| {
                let e = e.unwrap();
                (
                    e.file_name().into_string().unwrap(),
                    std::fs::read(e.path()).unwrap(),
                )
            })
            .collect();
        files.sort();
        (rows, files)
    }

    #[test]
    fn a_run_paused_by_stop_at_and_continued_in_legs_is_the_straight_run_bit_for_bit() {
        let (straight_dir, straight, _) = run_case(false);
        let (dir, case, log) = case_folder(CASE);
        let every = Duration::from_secs(600);
        // Before the sphere crosses the sensor (step 40 or so), then mid-run, then on.
        let mut legs = Vec::new();
        for (stop_at, paused_step) in [(0.002, 20), (0.1, 1000)] {
            match run_until(&case, &log, 1, every, Some(stop_at)).unwrap() {
                RunEnd::Paused(paused) => {
                    assert_eq!(paused.step, paused_step);
                    assert!(paused.restart_file.exists());
                    legs.push(paused.leg);
                }
                RunEnd::Finished(s) => panic!("not paused at {stop_at} s: {s:?}"),
            }
            let text = std::fs::read_to_string(&log).unwrap();
            let pause = text.find("\nPaused by --stop-at at step").expect(&text);
            assert!(
                text[pause..].contains("\nStage times: pair forces "),
                "{text}"
            );
        }
        let finished = match run_until(&case, &log, 1, every, None).unwrap() {
            RunEnd::Finished(summary) => summary,
            RunEnd::Paused(p) => panic!("paused without --stop-at: {p:?}"),
        };
        legs.push(finished.leg);
        assert_eq!(
            legs.iter().map(|l| l.steps).collect::<Vec<_>>(),
            [20, 980, 1000]
        );
        let leg_sum: u64 = legs.iter().map(|l| l.particle_steps).sum();
        assert_eq!(leg_sum, straight.whole.particle_steps);
        assert_eq!(finished.whole.particle_steps, straight.whole.particle_steps);
        // The pause lines were cut off on continuing; outputs are the straight run's.
        let text = std::fs::read_to_string(&log).unwrap();
        assert!(!text.contains("Paused by --stop-at"), "{text}");
        assert_eq!(text.matches("Stage times: ").count(), 1, "{text}");
        let (rows, files) = run_record(dir.path());
        let (straight_rows, straight_files) = run_record(straight_dir.path());
        assert_eq!(rows, straight_rows);
        let names =
            |files: &[(String, Vec<u8>)]| files.iter().map(|f| f.0.clone()).collect::<Vec<_>>();
        assert_eq!(names(&files), names(&straight_files));
        for (ours, theirs) in files.iter().zip(&straight_files) {
            assert!(
                ours.1 == theirs.1,
                "{} differs from the straight run's",
                ours.0
            );
        }
        check_outputs(dir.path(), &finished);
    }

    #[test]
    fn stop_at_that_is_not_ahead_of_the_run_is_refused_and_changes_nothing() {
        let (dir, case, log) = case_folder(CASE);
        let every = Duration::from_secs(600);
        for bad in [0.0, -1.0, f64::NAN] {
            let error = run_until(&case, &log, 1, every, Some(bad)).unwrap_err();
            assert!(
                error
                    .to_string()
                    .contains("expected a positive simulated time"),
                "{error}"
            );
        }
        assert!(!log.exists(), "a refused --stop-at wrote the log");
        run_until(&case, &log, 1, every, Some(0.05)).unwrap();
        let saved = std::fs::read(dir.path().join("post").join(restart::RESTART_FILE)).unwrap();
        let error = run_until(&case, &log, 1, every, Some(0.03)).unwrap_err();
        assert!(
            error
                .to_string()
                .contains("past step 300; give a later time"),
            "{error}"
        );
        let kept = std::fs::read(dir.path().join("post").join(restart::RESTART_FILE)).unwrap();
        assert_eq!(saved, kept, "the refused leg changed the restart file");
    }

    #[test]
    fn a_run_saves_its_state_at_log_lines_and_removes_the_restart_file_when_it_ends() {
        let (dir, case, log_path) = case_folder(CASE);
        let summary = run(&case, &log_path, 1, Duration::ZERO).unwrap();
        let log = std::fs::read_to_string(&log_path).unwrap();
        // 2000 steps, a log line every 100: a save at each.
        assert!(log.contains("\nRestart files: 20 written in "), "{log}");
        assert!(!dir.path().join("post").join(restart::RESTART_FILE).exists());
        check_outputs(dir.path(), &summary);
    }

    #[test]
    fn a_restart_file_of_another_case_is_set_aside_and_the_run_starts_from_zero() {
        let dir = tempfile::tempdir().unwrap();
        let case = dir.path().join("case.toml");
        std::fs::write(&case, CASE).unwrap();
        let restart_file = dir.path().join("post").join(restart::RESTART_FILE);
        let fingerprint = restart::fingerprint(&case, &Case::parse(CASE).unwrap()).unwrap();
        // A file of this layout for another case, then one of no layout at all.
        let (_, simulation) = load(&case).unwrap();
        let other = restart::Header::new([7; 32], 0, 0, 1.0);
        let reasons = [
            "it was written for another case or input file, or by another build of orch-dem",
            "it is not a restart file of this layout",
        ];
        for (k, why) in reasons.iter().enumerate() {
            std::fs::create_dir_all(dir.path().join("post")).unwrap();
            if k == 0 {
                restart::write(&restart_file, &other, &simulation.saved_state()).unwrap();
                assert_ne!(fingerprint, [7; 32]);
            } else {
                std::fs::write(&restart_file, b"not a restart file").unwrap();
            }
            let log_path = dir.path().join("log.native");
            let summary = run(&case, &log_path, 1, Duration::from_secs(600)).unwrap();
            let log = std::fs::read_to_string(&log_path).unwrap();
            let note = format!(
                "The restart file {} was set aside and the run started from t = 0: {why}",
                restart_file.display()
            );
            assert!(log.contains(&note), "{log}");
            assert_eq!(summary.whole.steps, 2000);
            check_outputs(dir.path(), &summary);
            assert!(!restart_file.exists());
        }
    }

    #[test]
    fn a_stop_file_present_from_the_start_ends_the_run_at_the_first_check() {
        let (dir, summary, log) = run_case(true);
        assert!(summary.stopped_by_stop_file);
        assert_eq!(summary.whole.steps, 100);
        assert_eq!(check_outputs(dir.path(), &summary), [50, 100]);
        let stop_file = dir.path().join("STOP");
        let line = format!(
            "Stopped by the stop file {} at step 100 (t = 0.010000 s), before the end time 0.2 s",
            stop_file.display()
        );
        assert_eq!(log.matches(&line).count(), 1, "{log}");
        assert!(
            log.contains("ORCH-DEM DONE at step 100 (t = 0.010000 s) with 1 particles left\n"),
            "{log}"
        );
        let last = log.trim_end().lines().last().unwrap();
        assert!(
            last.starts_with("Performance: ") && last.ends_with(" particle-steps/s on 1 threads"),
            "{log}"
        );
    }

    #[test]
    fn an_air_velocity_field_is_read_beside_the_case_and_a_bad_one_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let case = dir.path().join("case.toml");
        let air = "\n[air]\nvelocity_field = \"air-field.csv\"\n";
        std::fs::write(&case, format!("{CASE}{air}")).unwrap();
        let field = dir.path().join("air-field.csv");
        let message = |case: &Path| match load(case) {
            Ok(_) => panic!("{} loaded", case.display()),
            Err(e) => e.downcast::<BadCase>().unwrap().to_string(),
        };
        let error = message(&case);
        assert!(
            error.starts_with(&format!(
                "{}: `air.velocity_field`: cannot read {}: ",
                case.display(),
                field.display()
            )),
            "{error}"
        );
        let mut csv = String::from("x,y,z,ux,uy,uz\n");
        for node in 0..8 {
            let corner = |bit: usize| if node >> bit & 1 == 1 { "0.1" } else { "-0.1" };
            csv.push_str(&format!(
                "{},{},{},0,0,2\n",
                corner(2),
                corner(1),
                corner(0)
            ));
        }
        std::fs::write(&field, &csv).unwrap();
        let (_, simulation) = load(&case).unwrap();
        let loaded = simulation.config().air_field.as_ref().unwrap();
        assert_eq!(loaded.node_counts(), [2, 2, 2]);
        std::fs::write(&field, csv.replace("\n0.1,0.1,0.1,", "\n0.1,0.1,0.1.5,")).unwrap();
        assert_eq!(
            message(&case),
            format!(
                "{}: `air.velocity_field` (air-field.csv): line 9: field `z`: expected a number, got `0.1.5`",
                case.display()
            )
        );
    }

    #[test]
    fn the_profile_line_gives_each_stage_share_and_the_pairs_per_particle() {
        let timers = StageTimers {
            integrate: Duration::from_millis(100),
            neighbours: Duration::from_millis(200),
            pairs: Duration::from_millis(500),
            gather_and_walls: Duration::from_millis(200),
            rebuilds: 2,
            particles_at_rebuilds: 2000,
            pairs_listed_at_rebuilds: 12_000,
            pairs_touching_at_rebuilds: 5_000,
        };
        assert_eq!(
            profile(&timers, Duration::from_secs(1)),
            "Stage times: pair forces 50.0 %, walls, gather and closing kick 20.0 %, neighbour rebuilds 20.0 % (2 rebuilds; per particle 6.00 pairs listed, 2.50 touching), integration 10.0 %"
        );
        let none = StageTimers::default();
        assert!(profile(&none, Duration::from_secs(1)).contains("(0 rebuilds)"));
    }

    #[test]
    fn an_inflow_that_finds_no_room_for_its_mass_says_so_in_the_log() {
        // A box with room for one 8 mm sphere at a time, asked for 0.5 kg/s over two
        // batches (0.01 kg, fifteen spheres): it places one a batch.
        let case = CASE
            .replace("end_time = 0.2", "end_time = 0.02")
            .replace("[sensor]", "[[inflow]]\nmass_rate = 0.5\nmass_fractions = [1.0]\nvelocity = [0.0, 0.0, -1.0]\nstart = 0.0\nend = 0.02\nregion = { kind = \"box\", min = [-0.005, -0.005, 0.02], max = [0.005, 0.005, 0.03] }\n\n[sensor]");
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("case.toml"), case).unwrap();
        let log_path = dir.path().join("log.native");
        run(
            &dir.path().join("case.toml"),
            &log_path,
            1,
            Duration::from_secs(600),
        )
        .unwrap();
        let log = std::fs::read_to_string(&log_path).unwrap();
        let line = log
            .lines()
            .find(|l| l.starts_with("Inflow 1 of 1 placed "))
            .unwrap_or_else(|| panic!("no inflow line in {log}"));
        assert!(line.contains("of the 1.000000e-2 kg asked"), "{line}");
        assert!(
            line.contains("its region had no room for the rest"),
            "{line}"
        );
        // Read back as the adapter reads a finished run's log.
        let read = read_log(BufReader::new(File::open(&log_path).unwrap()), &log_path).unwrap();
        assert_eq!(read.steps, 200);
        let placed = read.inflow_placed().unwrap();
        assert!(placed.short, "{placed:?}");
        assert_eq!(placed.asked_kg, 1e-2);
        assert!(placed.placed_kg < 0.5 * placed.asked_kg, "{placed:?}");
        // A run without an inflow has no such line.
        let (_dir, _summary, log) = run_case(false);
        assert!(!log.contains("Inflow"), "{log}");
    }

    #[test]
    fn without_its_stop_file_a_run_reaches_its_end_time() {
        let (dir, summary, log) = run_case(false);
        assert!(!summary.stopped_by_stop_file);
        assert_eq!(summary.whole.steps, 2000);
        let dumps = check_outputs(dir.path(), &summary);
        assert_eq!(dumps.len(), 40);
        assert_eq!(dumps.last(), Some(&2000));
        assert!(!log.contains("stop file"), "{log}");
    }
}
