//! `orch-dem bench`: the same case on the native kernel and on its peers, LIGGGHTS and
//! LAMMPS, back to back on this machine, at one or more sizes, so that ratios are
//! measured in one run.
//!
//! Two cases: `hopper`, the study's hopper rendered by the adapters from one set of
//! parameters (same particles, materials, time step, STL walls, fill and discharge
//! times and vibration; LAMMPS has no mesh walls and sits it out), and `settled-bed`,
//! bidisperse spheres falling from one packing file into an open box
//! ([`settled_bed`]), which every code reads.
//!
//! Every run is a child process (`orch-dem run` for the native kernel), timed by the
//! code's own accounting of its time loop (Σ particles × steps over the loop's wall
//! time) and measured for peak memory by `/usr/bin/time` (the largest resident set of
//! the process and any process it waited for: with MPI, of the largest rank).

mod settled_bed;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use anyhow::{bail, Context};
use clap::{Args, ValueEnum};
use orch_adapters::hopper::{self, Hopper};
use orch_adapters::{
    liggghts, native, Case, DemSolver, Equipment, EquipmentOnSolver, Observations,
    ResolvedParameters, Simulation,
};
use orch_granular::{DischargeResponses, ResponseOptions};

use settled_bed::{Bed, Material, Packing};

/// The case `orch-dem bench` runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum BenchCase {
    /// The study's hopper: fill, open, vibrate, discharge (LIGGGHTS and native).
    Hopper,
    /// Bidisperse spheres from one packing file settling in an open box (all codes).
    SettledBed,
}

/// A code the native kernel is compared with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Peer {
    /// LIGGGHTS 3.8 (`liggghts`), under `mpirun` on more than one core.
    Liggghts,
    /// LAMMPS with its GRANULAR package (`lmp`), under `mpirun` on more than one core.
    Lammps,
}

/// Options of `orch-dem bench`.
#[derive(Debug, Args)]
pub struct BenchArgs {
    /// The case.
    #[arg(long, value_enum, default_value = "hopper")]
    case: BenchCase,
    /// Particle counts, run in the order given (the solver notes' reference has 3000).
    #[arg(long, value_delimiter = ',', default_value = "3000")]
    particles: Vec<u32>,
    /// Cores of each run: native threads, peers' MPI ranks.
    #[arg(long, value_delimiter = ',', default_value = "1,2")]
    threads: Vec<usize>,
    /// Codes to compare with.
    #[arg(long, value_enum, value_delimiter = ',', default_value = "liggghts")]
    peers: Vec<Peer>,
    /// Run the native kernel alone (no peers, no ratios to them).
    #[arg(long, alias = "no-liggghts")]
    no_peers: bool,
    /// Skip a run predicted (from the same code's rate at the previous size) to take
    /// longer than this, s; a run that takes twice as long is stopped.
    #[arg(long, default_value_t = 600.0)]
    max_time: f64,
    /// Settled bed: simulated time, s.
    #[arg(long, default_value_t = 0.2)]
    settle_time: f64,
    /// Hopper: filling time with the outlet plugged, s.
    #[arg(long, default_value_t = 0.3)]
    fill_time: f64,
    /// Hopper: discharge time after opening, s.
    #[arg(long, default_value_t = 0.3)]
    discharge_time: f64,
    /// Folder for the runs (default: a temporary folder, removed afterwards).
    #[arg(long)]
    dir: Option<PathBuf>,
    /// Hopper: a parameter of `orch params hopper` set on top of the bench's own,
    /// repeatable; e.g. the 5:1 experiment's mixture: `--set fine_diameter=0.0008
    /// --set fine_mass_fraction=0.2 --set youngs_modulus=2e8 --set timestep=1.2e-6`.
    #[arg(long = "set", value_name = "NAME=VALUE", value_parser = parse_setting)]
    set: Vec<(String, f64)>,
}

/// `NAME=VALUE` of `--set`.
fn parse_setting(text: &str) -> Result<(String, f64), String> {
    let (name, value) = text
        .split_once('=')
        .ok_or_else(|| format!("`{text}` is not NAME=VALUE (e.g. fine_diameter=0.0008)"))?;
    let value: f64 = value
        .trim()
        .parse()
        .map_err(|_| format!("`{value}` in `{text}` is not a number"))?;
    Ok((name.trim().to_string(), value))
}

/// Refuses a `--set` the hopper does not take or a value outside its range, naming
/// the parameter and the range.
fn check_settings(settings: &[(String, f64)]) -> anyhow::Result<()> {
    for (name, value) in settings {
        let Some(spec) = hopper::PARAMETERS.iter().find(|p| p.name == name.as_str()) else {
            bail!("--set {name}: the hopper has no parameter `{name}`; `orch params hopper` lists them");
        };
        if !(spec.min..=spec.max).contains(value) {
            bail!(
                "--set {name}={value}: outside [{}, {}] {}; give a value in that range",
                spec.min,
                spec.max,
                spec.unit
            );
        }
    }
    Ok(())
}

/// A code on some cores.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Code {
    Native,
    Peer(Peer),
}

impl Code {
    fn name(self) -> &'static str {
        match self {
            Code::Native => "native",
            Code::Peer(Peer::Liggghts) => "LIGGGHTS",
            Code::Peer(Peer::Lammps) => "LAMMPS",
        }
    }

    fn folder(self) -> &'static str {
        match self {
            Code::Native => "native",
            Code::Peer(Peer::Liggghts) => "liggghts",
            Code::Peer(Peer::Lammps) => "lammps",
        }
    }
}

/// What one run measured.
#[derive(Debug, Clone)]
struct Measured {
    loop_time_s: f64,
    particle_steps: f64,
    peak_rss_bytes: Option<u64>,
    /// The case's sanity figure: mean centre height of the settled bed, m, or the
    /// hopper's discharge rate, kg/s.
    check: f64,
    /// Stage times of a native run.
    note: String,
}

impl Measured {
    fn throughput(&self) -> f64 {
        self.particle_steps / self.loop_time_s
    }
}

/// One line of the table: a measurement, or why there is none.
struct Row {
    particles: u32,
    code: Code,
    cores: usize,
    outcome: Result<Measured, String>,
}

/// A finished child process.
struct Finished {
    success: bool,
    status: String,
    peak_rss_bytes: Option<u64>,
}

const TIME: &str = "/usr/bin/time";

/// Runs `program args` in `dir` with `env`, stdout and stderr to `output` in `dir`,
/// under `/usr/bin/time` when there is one (for the peak RSS); stops its process group
/// after `limit`.
fn run_child(
    program: &str,
    args: &[String],
    env: &[(&str, &str)],
    dir: &Path,
    output: &str,
    limit: Duration,
) -> anyhow::Result<Finished> {
    let timed = Path::new(TIME).exists();
    let mut command = if timed {
        let mut command = Command::new(TIME);
        command
            .args(["-f", "%M", "-o", "maxrss.txt", program])
            .args(args);
        command
    } else {
        let mut command = Command::new(program);
        command.args(args);
        command
    };
    let out = std::fs::File::create(dir.join(output))
        .with_context(|| format!("cannot write {}", dir.join(output).display()))?;
    command
        .current_dir(dir)
        .envs(env.iter().copied())
        .stdin(Stdio::null())
        .stdout(out.try_clone()?)
        .stderr(out);
    std::os::unix::process::CommandExt::process_group(&mut command, 0);
    let mut child = command
        .spawn()
        .with_context(|| format!("cannot start `{program}`"))?;
    let started = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait()? {
            break status;
        }
        if started.elapsed() > limit {
            let group = nix::unistd::Pid::from_raw(child.id() as i32);
            let _ = nix::sys::signal::killpg(group, nix::sys::signal::Signal::SIGKILL);
            let _ = child.wait();
            return Ok(Finished {
                success: false,
                status: format!("stopped after {:.0} s", limit.as_secs_f64()),
                peak_rss_bytes: None,
            });
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    let peak_rss_bytes = timed
        .then(|| std::fs::read_to_string(dir.join("maxrss.txt")).ok())
        .flatten()
        .and_then(|text| text.lines().last()?.trim().parse::<u64>().ok())
        .map(|kib| kib * 1024);
    Ok(Finished {
        success: status.success(),
        status: status.to_string(),
        peak_rss_bytes,
    })
}

/// `mpirun -np N program args` with Open MPI's consent to run as root, or `program
/// args` on one core.
fn launcher(program: &str, args: &[&str], cores: usize) -> (String, Vec<String>) {
    let args: Vec<String> = args.iter().map(|a| a.to_string()).collect();
    if cores <= 1 {
        return (program.to_string(), args);
    }
    let mut mpi = vec!["-np".to_string(), cores.to_string(), program.to_string()];
    mpi.extend(args);
    (liggghts::MPIRUN.to_string(), mpi)
}

fn native_args(deck: &str, cores: usize) -> anyhow::Result<(String, Vec<String>)> {
    let exe = std::env::current_exe().context("cannot find the orch-dem program")?;
    Ok((
        exe.display().to_string(),
        [
            "run",
            deck,
            "--log",
            native::LOG_FILE,
            "--threads",
            &cores.to_string(),
        ]
        .map(String::from)
        .to_vec(),
    ))
}

fn hopper_case(args: &BenchArgs, particles: u32) -> Case {
    let mut parameters = ResolvedParameters::defaults(hopper::PARAMETERS);
    parameters.set("n_particles", particles as f64);
    parameters.set("fill_time", args.fill_time);
    parameters.set("discharge_time", args.discharge_time);
    // The solver notes' deck: 0.5 mm, 50 Hz vertical vibration while discharging.
    parameters.set("amplitude", 0.0005);
    parameters.set("frequency", 50.0);
    for (name, value) in &args.set {
        parameters.set(name, *value);
    }
    Case {
        parameters,
        seed: 1,
        text: Default::default(),
    }
}

/// Renders the hopper `case` for `solver` on `cores` into `dir`.
fn render(
    solver: &'static DemSolver,
    case: &Case,
    dir: &Path,
    cores: usize,
) -> anyhow::Result<EquipmentOnSolver> {
    let simulation = EquipmentOnSolver::new(&Hopper, solver)
        .context("no hopper template")?
        .with_cores(cores);
    simulation
        .render(case, dir)
        .with_context(|| format!("cannot render the {} case", solver.name))?;
    Ok(simulation)
}

/// What `solver` wrote into `dir`.
fn observe(solver: &DemSolver, case: &Case, dir: &Path) -> anyhow::Result<Observations> {
    Ok((solver.parse)(case, &Hopper.sensor(case), dir)?)
}

fn discharge_rate(observations: &Observations) -> f64 {
    DischargeResponses::compute(&observations.crossings, &ResponseOptions::default())
        .discharge_rate_kg_per_s
        .unwrap_or(f64::NAN)
}

fn failed(code: Code, finished: &Finished, dir: &Path, log: &str) -> anyhow::Error {
    anyhow::anyhow!(
        "{} {}; see {}",
        code.name(),
        finished.status,
        dir.join(log).display()
    )
}

/// One hopper run of `code` on `cores` in `dir`.
fn hopper_run(
    case: &Case,
    code: Code,
    cores: usize,
    dir: &Path,
    limit: Duration,
) -> anyhow::Result<Measured> {
    let solver = match code {
        Code::Native => &native::SOLVER,
        Code::Peer(Peer::Liggghts) => &liggghts::SOLVER,
        Code::Peer(Peer::Lammps) => {
            bail!("LAMMPS has no STL mesh walls for the hopper; use --case settled-bed")
        }
    };
    let simulation = render(solver, case, dir, cores)?;
    let (program, args, env): (String, Vec<String>, Vec<(&str, &str)>) = match code {
        Code::Native => {
            let (program, args) = native_args(&simulation.deck_file(), cores)?;
            (program, args, Vec::new())
        }
        _ => {
            let spec = simulation.command();
            (spec.program, spec.args, liggghts::MPI_ENV.to_vec())
        }
    };
    let finished = run_child(&program, &args, &env, dir, "output.txt", limit)?;
    if !finished.success {
        return Err(failed(code, &finished, dir, "output.txt"));
    }
    let observations = observe(solver, case, dir)?;
    let note = match code {
        Code::Native => std::fs::read_to_string(dir.join(native::LOG_FILE))
            .unwrap_or_default()
            .lines()
            .find(|l| l.starts_with("Stage times"))
            .unwrap_or_default()
            .to_string(),
        _ => String::new(),
    };
    Ok(Measured {
        loop_time_s: observations.solver_loop_time_s.unwrap_or(f64::NAN),
        particle_steps: observations.particle_steps.unwrap_or(f64::NAN),
        peak_rss_bytes: finished.peak_rss_bytes,
        check: discharge_rate(&observations),
        note,
    })
}

/// The settled bed's parameters: the hopper's particles, material and time step.
fn bed(args: &BenchArgs) -> Bed {
    let case = hopper_case(args, 3000);
    let timestep_s = case.get("timestep");
    Bed {
        coarse_radius_m: 0.5 * case.get("coarse_diameter"),
        fine_radius_m: 0.5 * case.get("fine_diameter"),
        fine_mass_fraction: case.get("fine_mass_fraction"),
        material: Material {
            density_kg_m3: case.get("density"),
            youngs_modulus_pa: case.get("youngs_modulus"),
            poisson_ratio: case.get("poisson_ratio"),
            restitution: case.get("restitution"),
            friction: case.get("friction"),
        },
        timestep_s,
        steps: (args.settle_time / timestep_s).round() as u64,
        seed: 1,
    }
}

/// Writes the packing file (once per size) into `root`.
fn write_packing(bed: &Bed, particles: u32, root: &Path) -> anyhow::Result<Packing> {
    let packing = settled_bed::packing(particles as usize, bed)?;
    std::fs::create_dir_all(root).with_context(|| format!("cannot create {}", root.display()))?;
    let path = root.join("packing.data");
    std::fs::write(
        &path,
        settled_bed::data_file(&packing, bed.material.density_kg_m3),
    )
    .with_context(|| format!("cannot write {}", path.display()))?;
    Ok(packing)
}

/// One settled-bed run of `code` on `cores` in `dir`, from the packing in `dir/..`.
fn settled_bed_run(
    bed: &Bed,
    packing: &Packing,
    code: Code,
    cores: usize,
    dir: &Path,
    limit: Duration,
) -> anyhow::Result<Measured> {
    std::fs::create_dir_all(dir.join("post"))
        .with_context(|| format!("cannot create {}", dir.display()))?;
    let parent = dir.parent().context("a run folder has a parent")?;
    std::fs::copy(parent.join("packing.data"), dir.join("packing.data"))
        .context("cannot copy the packing file")?;
    let write = |name: &str, text: String| {
        std::fs::write(dir.join(name), text)
            .with_context(|| format!("cannot write {}", dir.join(name).display()))
    };
    let (program, args, log, dump) = match code {
        Code::Native => {
            write("bed.toml", settled_bed::native_case(bed, packing))?;
            write("box.stl", settled_bed::box_stl(packing))?;
            let (program, args) = native_args("bed.toml", cores)?;
            (
                program,
                args,
                native::LOG_FILE,
                format!("post/dump{}.liggghts", bed.steps),
            )
        }
        Code::Peer(peer) => {
            let deck = match peer {
                Peer::Liggghts => settled_bed::liggghts_deck(bed, packing, cores),
                Peer::Lammps => settled_bed::lammps_deck(bed, packing),
            };
            write("bed.in", deck)?;
            let (program, log, dump) = match peer {
                Peer::Liggghts => ("liggghts", "log.liggghts", "liggghts"),
                Peer::Lammps => ("lmp", "log.lammps", "lammps"),
            };
            let (program, args) = launcher(
                program,
                &["-in", "bed.in", "-log", log, "-echo", "none"],
                cores,
            );
            (program, args, log, format!("post/dump{}.{dump}", bed.steps))
        }
    };
    let finished = run_child(
        &program,
        &args,
        &liggghts::MPI_ENV,
        dir,
        "output.txt",
        limit,
    )?;
    if !finished.success {
        return Err(failed(code, &finished, dir, "output.txt"));
    }
    let text = std::fs::read_to_string(dir.join(log))
        .with_context(|| format!("cannot read {}", dir.join(log).display()))?;
    let (loop_time_s, particle_steps, note) = match code {
        Code::Native => {
            let line = orch_adapters::native::LoopLine::find_in(&text)
                .with_context(|| format!("no loop time in {}", dir.join(log).display()))?;
            let (seconds, particle_steps) = (line.seconds, line.particle_steps);
            let note = text
                .lines()
                .find(|l| l.starts_with("Stage times"))
                .unwrap_or_default()
                .to_string();
            (seconds, particle_steps, note)
        }
        _ => {
            let lines = orch_adapters::liggghts::LoopLine::all_in(&text);
            if lines.is_empty() {
                bail!("no loop time in {}", dir.join(log).display());
            }
            let seconds = lines.iter().map(|l| l.seconds).sum();
            let work = lines.iter().map(|l| (l.steps * l.atoms) as f64).sum();
            (seconds, work, String::new())
        }
    };
    let (height, n) = settled_bed::mean_height(&dir.join(&dump))?;
    if n != packing.spheres.len() {
        bail!(
            "{}: {} of {} spheres left in the last snapshot of {}",
            code.name(),
            n,
            packing.spheres.len(),
            dump
        );
    }
    Ok(Measured {
        loop_time_s,
        particle_steps,
        peak_rss_bytes: finished.peak_rss_bytes,
        check: height,
        note,
    })
}

/// Runs the comparison and prints it.
pub fn bench(args: &BenchArgs) -> anyhow::Result<()> {
    check_settings(&args.set)?;
    if !args.set.is_empty() && args.case != BenchCase::Hopper {
        bail!("--set applies to the hopper only; drop it or run --case hopper");
    }
    let temporary;
    let root = match &args.dir {
        Some(dir) => dir.clone(),
        None => {
            temporary = tempfile::tempdir().context("cannot create a temporary folder")?;
            temporary.path().to_path_buf()
        }
    };
    let mut codes = vec![Code::Native];
    if !args.no_peers {
        for &peer in &args.peers {
            if !codes.contains(&Code::Peer(peer)) {
                codes.push(Code::Peer(peer));
            }
        }
    }
    let bed = bed(args);
    let settle = args.case == BenchCase::SettledBed;
    if settle {
        println!(
            "settled bed: spheres of {} mm and {} mm diameter ({} % of the mass fine) on a jittered lattice fall into an open box; dt {:e} s, {} steps ({} s); E {:e} Pa, nu {}, e {}, mu {}, no rolling friction",
            2e3 * bed.coarse_radius_m,
            2e3 * bed.fine_radius_m,
            100.0 * bed.fine_mass_fraction,
            bed.timestep_s,
            bed.steps,
            args.settle_time,
            bed.material.youngs_modulus_pa,
            bed.material.poisson_ratio,
            bed.material.restitution,
            bed.material.friction
        );
    } else {
        let case = hopper_case(args, 3000);
        println!(
            "hopper: {} mm / {} mm spheres ({} % of the mass fine), E {:e} Pa, dt {:e} s, fill {} s + discharge {} s, {} mm {} Hz vibration",
            1e3 * case.get("coarse_diameter"),
            1e3 * case.get("fine_diameter"),
            100.0 * case.get("fine_mass_fraction"),
            case.get("youngs_modulus"),
            case.get("timestep"),
            args.fill_time,
            args.discharge_time,
            1e3 * case.get("amplitude"),
            case.get("frequency")
        );
    }
    println!("load before the runs: {}", load_average());
    let limit = Duration::from_secs_f64(2.0 * args.max_time);
    let mut rows: Vec<Row> = Vec::new();
    for &particles in &args.particles {
        let size_dir = root.join(format!("n{particles}"));
        let packing = if settle {
            Some(write_packing(&bed, particles, &size_dir)?)
        } else {
            None
        };
        for &code in &codes {
            for &cores in &args.threads {
                let cores = cores.max(1);
                let work = match &packing {
                    Some(_) => particles as f64 * bed.steps as f64,
                    None => {
                        let case = hopper_case(args, particles);
                        particles as f64
                            * ((args.fill_time + args.discharge_time) / case.get("timestep"))
                    }
                };
                // The same code's rate at the largest size measured so far.
                let previous = rows
                    .iter()
                    .rev()
                    .filter(|r| r.code == code && r.cores == cores)
                    .find_map(|r| r.outcome.as_ref().ok());
                if let Some(previous) = previous {
                    let predicted = work / previous.throughput();
                    if predicted > args.max_time {
                        rows.push(Row {
                            particles,
                            code,
                            cores,
                            outcome: Err(format!(
                                "skipped: predicted {predicted:.0} s > --max-time {} s",
                                args.max_time
                            )),
                        });
                        continue;
                    }
                }
                if rows
                    .iter()
                    .any(|r| r.code == code && r.cores == cores && r.outcome.is_err())
                {
                    rows.push(Row {
                        particles,
                        code,
                        cores,
                        outcome: Err("skipped: a smaller size did not finish".to_string()),
                    });
                    continue;
                }
                let dir = size_dir.join(format!("{}-{cores}", code.folder()));
                std::fs::create_dir_all(&dir)
                    .with_context(|| format!("cannot create {}", dir.display()))?;
                eprintln!(
                    "orch-dem bench: {particles} particles, {} on {cores} cores…",
                    code.name()
                );
                let outcome = match &packing {
                    Some(packing) => settled_bed_run(&bed, packing, code, cores, &dir, limit),
                    None => hopper_run(&hopper_case(args, particles), code, cores, &dir, limit),
                };
                rows.push(Row {
                    particles,
                    code,
                    cores,
                    outcome: outcome.map_err(|e| format!("{e:#}")),
                });
            }
        }
    }
    print!("{}", table(&rows, settle));
    println!("load after the runs: {}", load_average());
    for row in &rows {
        if let Ok(m) = &row.outcome {
            if !m.note.is_empty() {
                println!(
                    "{} {} on {}: {}",
                    row.particles,
                    row.code.name(),
                    row.cores,
                    m.note
                );
            }
        }
    }
    Ok(())
}

/// `/proc/loadavg`'s three load averages, or why not.
fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|text| {
            text.split_whitespace()
                .take(3)
                .collect::<Vec<_>>()
                .join(" ")
        })
        .unwrap_or_else(|e| format!("unknown ({e})"))
}

/// The table: per run particle-steps/s, the ratio to native on 1 core at the same size,
/// the cost per particle-step relative to the same code and cores at the smallest size,
/// peak RSS and bytes per particle, and the sanity figure with its deviation from
/// native on 1 core.
fn table(rows: &[Row], settle: bool) -> String {
    let mut out = String::new();
    let check = if settle {
        "mean z mm"
    } else {
        "discharge kg/s"
    };
    let _ = writeln!(
        out,
        "{:>9} {:<9} {:>5} {:>10} {:>12} {:>9} {:>9} {:>10} {:>8} {:>14} {:>9}",
        "particles",
        "code",
        "cores",
        "loop s",
        "p-steps/s",
        "÷native1",
        "cost÷1st",
        "peak MB",
        "B/part",
        check,
        "Δ native1"
    );
    for row in rows {
        let m = match &row.outcome {
            Ok(m) => m,
            Err(reason) => {
                let _ = writeln!(
                    out,
                    "{:>9} {:<9} {:>5} {}",
                    row.particles,
                    row.code.name(),
                    row.cores,
                    reason
                );
                continue;
            }
        };
        let native1 = rows
            .iter()
            .find(|r| r.particles == row.particles && r.code == Code::Native && r.cores == 1)
            .and_then(|r| r.outcome.as_ref().ok());
        let first = rows
            .iter()
            .find(|r| r.code == row.code && r.cores == row.cores)
            .and_then(|r| r.outcome.as_ref().ok());
        let ratio = native1.map_or("-".to_string(), |n| {
            format!("{:.2}", m.throughput() / n.throughput())
        });
        let cost = first.map_or("-".to_string(), |f| {
            format!("{:.2}", f.throughput() / m.throughput())
        });
        let (rss, per) = match m.peak_rss_bytes {
            Some(bytes) => (
                format!("{:.1}", bytes as f64 / 1e6),
                format!("{:.0}", bytes as f64 / row.particles as f64),
            ),
            None => ("-".to_string(), "-".to_string()),
        };
        let (figure, deviation) = if settle {
            (
                format!("{:.3}", 1e3 * m.check),
                native1.map_or("-".to_string(), |n| {
                    format!("{:+.2} %", 100.0 * (m.check / n.check - 1.0))
                }),
            )
        } else {
            (
                format!("{:.4}", m.check),
                native1.map_or("-".to_string(), |n| {
                    format!("{:+.1} %", 100.0 * (m.check / n.check - 1.0))
                }),
            )
        };
        let _ = writeln!(
            out,
            "{:>9} {:<9} {:>5} {:>10.2} {:>12.4e} {:>9} {:>9} {:>10} {:>8} {:>14} {:>9}",
            row.particles,
            row.code.name(),
            row.cores,
            m.loop_time_s,
            m.throughput(),
            ratio,
            cost,
            rss,
            per,
            figure,
            deviation
        );
    }
    let _ = writeln!(
        out,
        "p-steps/s: Σ particles × steps / loop time, each code's own accounting; ÷native1: against native on 1 core at the same size; cost÷1st: time per particle-step against the same code and cores at the first size; peak MB: largest resident set of one process (with MPI: of the largest rank); B/part: peak / particles"
    );
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_setting_is_a_hopper_parameter_within_its_range() {
        assert_eq!(
            parse_setting("fine_diameter = 0.0008"),
            Ok(("fine_diameter".to_string(), 0.0008))
        );
        assert!(parse_setting("fine_diameter").is_err());
        assert!(parse_setting("fine_diameter=small").is_err());
        let setting = |name: &str, value: f64| vec![(name.to_string(), value)];
        assert!(check_settings(&setting("youngs_modulus", 2e8)).is_ok());
        let unknown = check_settings(&setting("fine_diametre", 0.0008)).unwrap_err();
        assert!(
            unknown.to_string().contains("orch params hopper"),
            "{unknown}"
        );
        let outside = check_settings(&setting("fine_diameter", 5.0)).unwrap_err();
        assert!(outside.to_string().contains("outside"), "{outside}");
    }
}
