//! Writing to standard output and error when the reader may have gone.
//!
//! `orch status | head -1` closes the pipe after one line; Rust's `println!` then
//! panics. Here a closed pipe (`BrokenPipe`) is not an error: what nobody reads any
//! more is dropped and the command goes on (a study keeps running). Use [`outln!`] and
//! [`out!`] instead of `println!`/`print!` (they return `io::Result<()>` for other
//! errors, such as a full disk) and [`errln!`] instead of `eprintln!` (errors of
//! standard error are dropped: there is nowhere left to report them).

use std::fmt;
use std::io::{self, Write};

/// Writes `args` to standard output; `Ok` when the reader has closed the pipe.
pub fn stdout(args: fmt::Arguments<'_>) -> io::Result<()> {
    ignore_closed_pipe(io::stdout().lock().write_fmt(args))
}

/// Writes `args` to standard error, dropping any error (a closed pipe included).
pub fn stderr(args: fmt::Arguments<'_>) {
    let _ = io::stderr().lock().write_fmt(args);
}

/// `Ok` for a closed pipe, else `result` as it is.
fn ignore_closed_pipe(result: io::Result<()>) -> io::Result<()> {
    match result {
        Err(e) if e.kind() == io::ErrorKind::BrokenPipe => Ok(()),
        other => other,
    }
}

/// `println!` that survives a closed pipe; returns `io::Result<()>`.
macro_rules! outln {
    ($($arg:tt)*) => {
        $crate::output::stdout(format_args!("{}\n", format_args!($($arg)*)))
    };
}

/// `print!` that survives a closed pipe; returns `io::Result<()>`.
macro_rules! out {
    ($($arg:tt)*) => {
        $crate::output::stdout(format_args!($($arg)*))
    };
}

/// `eprintln!` that survives a closed pipe.
macro_rules! errln {
    ($($arg:tt)*) => {
        $crate::output::stderr(format_args!("{}\n", format_args!($($arg)*)))
    };
}

pub(crate) use {errln, out, outln};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_closed_pipe_is_not_an_error_but_other_failures_are() {
        let closed = io::Error::from(io::ErrorKind::BrokenPipe);
        assert!(ignore_closed_pipe(Err(closed)).is_ok());
        let full = io::Error::from(io::ErrorKind::StorageFull);
        assert!(ignore_closed_pipe(Err(full)).is_err());
    }
}
