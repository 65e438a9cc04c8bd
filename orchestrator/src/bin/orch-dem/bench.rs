//! `orch-dem bench`: the identical hopper on LIGGGHTS and on the native kernel, back
//! to back on this machine, so the ratio is measured in one run.
//!
//! Both solvers get the case rendered from one set of parameters by their adapters:
//! the same particles, materials, time step, STL walls, fill and discharge times and
//! vibration. Each solver's own accounting gives the work done (Σ particles × steps)
//! and the time of its time loop; throughput is their ratio.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use anyhow::{bail, Context};
use clap::Args;
use orch_adapters::hopper::{self, Hopper};
use orch_adapters::{
    liggghts, native, Case, DemSolver, Equipment, EquipmentOnSolver, Observations,
    ResolvedParameters, Simulation,
};
use orch_granular::{DischargeResponses, ResponseOptions};

use crate::run;

/// Options of `orch-dem bench`.
#[derive(Debug, Args)]
pub struct BenchArgs {
    /// Particles in the hopper (the solver notes' reference case has 3000).
    #[arg(long, default_value_t = 3000)]
    particles: u32,
    /// Filling time with the outlet plugged, s.
    #[arg(long, default_value_t = 0.3)]
    fill_time: f64,
    /// Discharge time after opening, s.
    #[arg(long, default_value_t = 0.3)]
    discharge_time: f64,
    /// Thread counts to run the native kernel with.
    #[arg(long, value_delimiter = ',', default_value = "1,2")]
    threads: Vec<usize>,
    /// Skip LIGGGHTS (when it is not installed); no ratios are printed.
    #[arg(long)]
    no_liggghts: bool,
    /// Folder for the runs (default: a temporary folder, removed afterwards).
    #[arg(long)]
    dir: Option<PathBuf>,
}

struct Measured {
    label: String,
    loop_time_s: f64,
    particle_steps: f64,
    discharge_rate_kg_s: f64,
    note: String,
}

impl Measured {
    fn throughput(&self) -> f64 {
        self.particle_steps / self.loop_time_s
    }
}

fn case(args: &BenchArgs) -> Case {
    let mut parameters = ResolvedParameters::defaults(hopper::PARAMETERS);
    parameters.set("n_particles", args.particles as f64);
    parameters.set("fill_time", args.fill_time);
    parameters.set("discharge_time", args.discharge_time);
    // The solver notes' deck: 0.5 mm, 50 Hz vertical vibration while discharging.
    parameters.set("amplitude", 0.0005);
    parameters.set("frequency", 50.0);
    Case {
        parameters,
        seed: 1,
        text: Default::default(),
    }
}

/// Renders the hopper `case` for `solver` into `dir`; returns the simulation.
fn render(
    solver: &'static DemSolver,
    case: &Case,
    dir: &Path,
) -> anyhow::Result<EquipmentOnSolver> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let simulation = EquipmentOnSolver::new(&Hopper, solver).context("no hopper template")?;
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

fn liggghts(case: &Case, dir: &Path) -> anyhow::Result<Measured> {
    let spec = render(&liggghts::SOLVER, case, dir)?.command();
    let status = Command::new(&spec.program)
        .args(&spec.args)
        .current_dir(dir)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .with_context(|| {
            format!(
                "cannot start `{}`; install it with `{}` or pass --no-liggghts",
                spec.program,
                liggghts::SOLVER.install_hint
            )
        })?;
    if !status.success() {
        bail!(
            "LIGGGHTS failed ({status}); see {}",
            dir.join(&spec.log_file).display()
        );
    }
    let observations = observe(&liggghts::SOLVER, case, dir)?;
    Ok(Measured {
        label: "LIGGGHTS 1 core".to_string(),
        loop_time_s: observations.solver_loop_time_s.unwrap_or(f64::NAN),
        particle_steps: observations.particle_steps.unwrap_or(f64::NAN),
        discharge_rate_kg_s: discharge_rate(&observations),
        note: String::new(),
    })
}

fn native(case: &Case, dir: &Path, threads: usize) -> anyhow::Result<Measured> {
    let simulation = render(&native::SOLVER, case, dir)?;
    let summary = run::run(
        &dir.join(simulation.deck_file()),
        &dir.join(native::LOG_FILE),
        threads,
    )?;
    let observations = observe(&native::SOLVER, case, dir)?;
    Ok(Measured {
        label: format!(
            "native {threads} thread{}",
            if threads == 1 { "" } else { "s" }
        ),
        loop_time_s: summary.loop_time.as_secs_f64(),
        particle_steps: summary.particle_steps as f64,
        discharge_rate_kg_s: discharge_rate(&observations),
        note: run::profile(&summary.timers, summary.loop_time),
    })
}

/// Runs the comparison and prints it.
pub fn bench(args: &BenchArgs) -> anyhow::Result<()> {
    let temporary;
    let root = match &args.dir {
        Some(dir) => dir.clone(),
        None => {
            temporary = tempfile::tempdir().context("cannot create a temporary folder")?;
            temporary.path().to_path_buf()
        }
    };
    let case = case(args);
    println!(
        "hopper: {} particles (4 mm / 2 mm, half of the mass each), dt {:e} s, fill {} s + discharge {} s, 0.5 mm 50 Hz vibration",
        args.particles,
        case.get("timestep"),
        args.fill_time,
        args.discharge_time
    );
    let mut results = Vec::new();
    if !args.no_liggghts {
        results.push(liggghts(&case, &root.join("liggghts"))?);
    }
    for &threads in &args.threads {
        results.push(native(
            &case,
            &root.join(format!("native-{threads}")),
            threads.max(1),
        )?);
    }
    let reference = (!args.no_liggghts).then(|| results[0].throughput());
    println!(
        "{:<18} {:>12} {:>16} {:>20} {:>18} {:>10}",
        "solver", "loop time s", "particle-steps", "particle-steps/s", "discharge kg/s", "ratio"
    );
    for m in &results {
        let ratio = reference.map_or("-".to_string(), |r| format!("{:.2}", m.throughput() / r));
        println!(
            "{:<18} {:>12.2} {:>16.4e} {:>20.4e} {:>18.4} {:>10}",
            m.label,
            m.loop_time_s,
            m.particle_steps,
            m.throughput(),
            m.discharge_rate_kg_s,
            ratio
        );
    }
    for m in results.iter().filter(|m| !m.note.is_empty()) {
        println!("{}: {}", m.label, m.note);
    }
    Ok(())
}
