//! `orch-dem`: orch's native DEM kernel as a program, like the other solvers.
//!
//! `orch-dem run CASE.toml` runs a case file rendered from
//! `templates/native/hopper.toml.tera` (or written by hand); `orch-dem bench` runs the
//! same hopper on LIGGGHTS and on the native kernel and prints their throughput.
//! It lives in the `orch` package so that `cargo install --path orchestrator`
//! installs it beside `orch`.
//!
//! Exit status: 0 finished, 1 the run failed (e.g. went unstable; the log says at which
//! step and particle), 2 bad case file or mesh.

mod bench;
mod run;

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
    },
    /// Run the same hopper on LIGGGHTS (1 core) and on the native kernel (1 and 2
    /// threads) back to back and print particle-steps per second and their ratios.
    Bench(bench::BenchArgs),
}

fn main() {
    let args = Args::parse();
    let result = match args.command {
        Command::Run { case, log, threads } => run::run(&case, &log, threads.max(1)).map(|s| {
            println!(
                "orch-dem: {} steps, {:.4e} particle-steps/s, {} particles left, {:.4e} kg discharged",
                s.steps,
                s.throughput(),
                s.remaining,
                s.discharged_mass_kg
            );
        }),
        Command::Bench(args) => bench::bench(&args),
    };
    if let Err(error) = result {
        eprintln!("orch-dem: error: {error:#}");
        let code = if error.downcast_ref::<run::BadCase>().is_some() {
            2
        } else {
            1
        };
        std::process::exit(code);
    }
}
