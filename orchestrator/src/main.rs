//! The `orch` binary: parse arguments, run, map errors to exit codes.

use clap::Parser;
use orch::cli::{self, Args, InputError};
use orch::exit_codes;

fn main() {
    let args = Args::parse();
    let filter = match args.verbose {
        0 => "warn",
        1 => "info",
        _ => "debug",
    };
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(filter)),
        )
        .with_writer(std::io::stderr)
        // A log line that cannot be written (stderr a closed pipe) is dropped; the
        // default reports it with `eprintln!`, which panics on that same pipe.
        .log_internal_errors(false)
        .init();
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .expect("a tokio runtime");
    let code = match runtime.block_on(cli::run(args)) {
        Ok(code) => code,
        Err(error) => {
            orch::output::stderr(format_args!("error: {error:#}\n"));
            if error.downcast_ref::<InputError>().is_some() {
                exit_codes::BAD_INPUT
            } else {
                exit_codes::INTERNAL
            }
        }
    };
    std::process::exit(code);
}
