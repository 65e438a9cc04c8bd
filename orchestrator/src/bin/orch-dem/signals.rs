//! The signals that ask a run to stop: SIGTERM (Slurm at a job's time limit, `scancel`,
//! orch's local executor at a time limit or `orch cancel`) and SIGINT (Ctrl-C).
//!
//! The first one asks the time loop to save the kernel's state at the end of the step
//! it is in and to end with exit status 128 + the signal's number, as the signal would
//! have ended it; the run started again continues from that step. Slurm sends SIGKILL
//! `KillWait` (30 s by default) after SIGTERM and orch's local executor 3 s after, so a
//! save has seconds, not minutes: one step and one write. A second signal ends the
//! process at once, with the same status, for a user who does not want to wait.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;

use signal_hook::consts::{SIGINT, SIGTERM};

/// The signals a run watches for, by number and name.
const WATCHED: [(i32, &str); 2] = [(SIGTERM, "SIGTERM"), (SIGINT, "SIGINT")];

/// Whether a stop signal has arrived since [`StopSignals::watch`].
#[derive(Debug)]
pub struct StopSignals {
    /// The number of the last signal received, 0 for none.
    received: Arc<AtomicUsize>,
}

/// A stop signal that arrived, by number.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StopSignal(pub i32);

impl StopSignal {
    /// The signal's name (`SIGTERM`).
    pub fn name(self) -> &'static str {
        WATCHED
            .iter()
            .find(|(number, _)| *number == self.0)
            .map_or("a signal", |(_, name)| name)
    }

    /// The exit status of a process this signal ended: 128 + its number.
    pub fn exit_status(self) -> i32 {
        128 + self.0
    }
}

impl StopSignals {
    /// Replaces the default action of SIGTERM and SIGINT (ending the process) for the
    /// rest of the process: the first one is recorded, a second ends it at once.
    pub fn watch() -> std::io::Result<Self> {
        let received = Arc::new(AtomicUsize::new(0));
        let seen = Arc::new(AtomicBool::new(false));
        for (signal, _) in WATCHED {
            // Handlers run in the order they were registered: the shutdown looks at
            // `seen` before the first signal sets it.
            let status = StopSignal(signal).exit_status();
            signal_hook::flag::register_conditional_shutdown(signal, status, seen.clone())?;
            signal_hook::flag::register(signal, seen.clone())?;
            signal_hook::flag::register_usize(signal, received.clone(), signal as usize)?;
        }
        Ok(Self { received })
    }

    /// The signal received, if one was.
    pub fn received(&self) -> Option<StopSignal> {
        match self.received.load(Ordering::Relaxed) {
            0 => None,
            signal => Some(StopSignal(signal as i32)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_signal_is_named_and_ends_with_128_plus_its_number() {
        assert_eq!(StopSignal(SIGTERM).name(), "SIGTERM");
        assert_eq!(StopSignal(SIGTERM).exit_status(), 143);
        assert_eq!(StopSignal(SIGINT).exit_status(), 130);
    }
}
