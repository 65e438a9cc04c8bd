//! `orch-dem`: orch's native DEM kernel as a program, like the other solvers.
//!
//! `orch-dem run CASE.toml` runs a case file rendered from
//! `templates/native/hopper.toml.tera` (or written by hand); `orch-dem bench` runs the
//! same case on the native kernel, LIGGGHTS and LAMMPS and prints one table of
//! throughput, ratios and peak memory;
//! `orch-dem verify [DIR]` runs the kernel's verification cases (`dem/verification/`)
//! and prints measured against analytic or published values.
//! It lives in the `orch` package so that `cargo install --path orchestrator`
//! installs it beside `orch`.
//!
//! A run saves its state every ten minutes of wall time to `post/restart.orch-dem`;
//! started again where that file lies (after a kill, a node failure or a batch system's
//! time limit), it continues from there and ends as if it had never stopped.
//!
//! Exit status: 0 finished (also when the case's `stop_file` ended the run early; for
//! `verify`: every check passed), 1 the run failed (e.g. went unstable; the log says at
//! which step and particle) or a verification check failed, 2 bad case file or mesh.

mod bench;
mod restart;
mod run;
mod signals;
mod verify;

use std::path::PathBuf;

use clap::{Parser, Subcommand};

/// orch's native DEM kernel.
#[derive(Debug, Parser)]
#[command(name = "orch-dem", version, about)]
struct Args {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Run a case file; outputs go to `post/` beside it.
    Run {
        /// The case file (TOML).
        case: PathBuf,
        /// The log file.
        #[arg(long, default_value = "log.native")]
        log: PathBuf,
        /// Worker threads (the result does not depend on it).
        #[arg(long, default_value_t = 1, env = "ORCH_DEM_THREADS")]
        threads: usize,
        /// Wall time between saves of the run's state to `post/restart.orch-dem`
        /// (at the next log line; `0s`: at every log line). A run started where that
        /// file lies continues from it, bit for bit.
        #[arg(long, default_value = "10min", env = "ORCH_DEM_RESTART_EVERY")]
        restart_every: humantime::Duration,
        /// Pause once the simulated time reaches this, s: save the state to the restart
        /// file and exit 0. Running the same case again (with a later `--stop-at`, or
        /// none) continues from there, bit for bit, and each leg prints its own wall
        /// time and particle-steps per second, so a window of a run can be timed alone.
        #[arg(long, value_name = "SECONDS")]
        stop_at: Option<f64>,
    },
    /// Run the same case (the hopper, or a settled bed from one packing file) on the
    /// native kernel and on LIGGGHTS and LAMMPS, on 1 and 2 cores, at one or more
    /// sizes, back to back, and print one table of particle-steps per second, ratios,
    /// peak memory and a sanity figure.
    Bench(bench::BenchArgs),
    /// Run every verification case (impacts, Hertz contact time, incline) and print
    /// measured against reference values; exit 1 unless every check passes.
    Verify {
        /// The folder of cases (default: `dem/verification/` of the source tree, or
        /// one found beside the binary).
        dir: Option<PathBuf>,
        /// Worker threads (the result does not depend on it).
        #[arg(long, default_value_t = 1, env = "ORCH_DEM_THREADS")]
        threads: usize,
    },
}

/// A leg's figures for the line `orch-dem run` prints at its end.
fn leg_figures(leg: &run::Leg) -> String {
    format!(
        "this leg: {} steps, {} particle-steps in {:.3} s of loop, {:.4e} particle-steps/s",
        leg.steps,
        leg.particle_steps,
        leg.loop_time.as_secs_f64(),
        leg.throughput()
    )
}

fn main() {
    let args = Args::parse();
    let result = match args.command {
        Command::Run {
            case,
            log,
            threads,
            restart_every,
            stop_at,
        } => run::run_until(&case, &log, threads.max(1), restart_every.into(), stop_at).map(
            |end| match end {
                run::RunEnd::Finished(s) => println!(
                    "orch-dem: {} steps, {:.4e} particle-steps/s, {} particles left, {:.4e} kg discharged{}; {}",
                    s.whole.steps,
                    s.whole.throughput(),
                    s.remaining,
                    s.discharged_mass_kg,
                    if s.stopped_by_stop_file {
                        ", stopped by the case's stop file"
                    } else {
                        ""
                    },
                    leg_figures(&s.leg)
                ),
                run::RunEnd::Paused(p) => println!(
                    "orch-dem: paused at step {} (t = {:.6} s) as --stop-at asked, the state saved in {}: run the same case again to continue; {}\norch-dem: this leg's {}",
                    p.step,
                    p.time_s,
                    p.restart_file.display(),
                    leg_figures(&p.leg),
                    p.stages
                ),
            },
        ),
        Command::Bench(args) => bench::bench(&args),
        Command::Verify { dir, threads } => rayon::ThreadPoolBuilder::new()
            .num_threads(threads.max(1))
            .build()
            .map_err(anyhow::Error::from)
            .and_then(|pool| pool.install(|| verify::verify(dir)))
            .map(|all_passed| {
                if !all_passed {
                    std::process::exit(1);
                }
            }),
    };
    if let Err(error) = result {
        if let Some(stopped) = error.downcast_ref::<run::StoppedBySignal>() {
            eprintln!("orch-dem: {stopped}");
            std::process::exit(stopped.signal.exit_status());
        }
        eprintln!("orch-dem: error: {error:#}");
        let code = if error.downcast_ref::<run::BadCase>().is_some() {
            2
        } else {
            1
        };
        std::process::exit(code);
    }
}
