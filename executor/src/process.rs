//! Processes by pid: liveness that survives pid reuse, and signals to process groups.
//!
//! A pid alone is not an identity: after a reboot or a long time it may name another
//! process. The kernel's start time of the process (`/proc/<pid>/stat`, field 22, in
//! clock ticks since boot) is recorded with it, and a process counts as ours only when
//! both match.

use nix::sys::signal::{killpg, Signal};
use nix::unistd::Pid;

/// The start time of process `pid` in clock ticks since boot, if it exists and is not
/// a zombie.
pub fn start_ticks(pid: i64) -> Option<i64> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    // The command name may contain spaces and parentheses; fields resume after the last ')'.
    let after_name = &stat[stat.rfind(')')? + 1..];
    let fields: Vec<&str> = after_name.split_whitespace().collect();
    // fields[0] is field 3 (state); field 22 (starttime) is fields[19].
    if fields.first() == Some(&"Z") {
        return None;
    }
    fields.get(19)?.parse().ok()
}

/// True when the process `pid` that started at `started_ticks` still runs.
pub fn is_alive(pid: i64, started_ticks: i64) -> bool {
    start_ticks(pid) == Some(started_ticks)
}

/// This process's pid and start time.
pub fn current() -> (i64, i64) {
    let pid = std::process::id() as i64;
    (pid, start_ticks(pid).unwrap_or(0))
}

/// Sends `signal` to every process of group `pgid`; false when the group is gone.
pub fn signal_group(pgid: i64, signal: Signal) -> bool {
    killpg(Pid::from_raw(pgid as i32), signal).is_ok()
}

/// True while any process of group `pgid` exists.
pub fn group_exists(pgid: i64) -> bool {
    killpg(Pid::from_raw(pgid as i32), None).is_ok()
}

/// A local job's handle: `pid:start-ticks`; the pid is also the process group id.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ProcessHandle {
    /// pid of the job's wrapper, which leads its own process group.
    pub pid: i64,
    /// Its start time in clock ticks since boot.
    pub started_ticks: i64,
}

impl ProcessHandle {
    /// Parses `pid:start-ticks`.
    pub fn parse(text: &str) -> Option<ProcessHandle> {
        let (pid, ticks) = text.split_once(':')?;
        Some(ProcessHandle {
            pid: pid.parse().ok()?,
            started_ticks: ticks.parse().ok()?,
        })
    }

    /// True while the process runs.
    pub fn is_alive(&self) -> bool {
        is_alive(self.pid, self.started_ticks)
    }
}

impl std::fmt::Display for ProcessHandle {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}:{}", self.pid, self.started_ticks)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn this_process_is_alive_and_a_wrong_start_time_is_not() {
        let (pid, ticks) = current();
        assert!(is_alive(pid, ticks));
        assert!(!is_alive(pid, ticks + 1));
        let handle = ProcessHandle {
            pid,
            started_ticks: ticks,
        };
        assert_eq!(ProcessHandle::parse(&handle.to_string()), Some(handle));
    }
}
