//! Exit codes of `orch`, in one place so scripts can rely on them.

/// Everything asked for was done; every job of the study succeeded.
pub const SUCCESS: i32 = 0;
/// The study ran to the end but some jobs failed (their reasons are in `orch status`).
pub const JOBS_FAILED: i32 = 1;
/// `orch compare`: the native kernel differs from a reference solver by more than a
/// tolerance (an interval wholly outside it), ran more than 5 % slower than its
/// history, or a run failed.
pub const REGRESSION: i32 = 1;
/// The input was wrong: a bad study file, an unknown study or job, a missing solver.
/// Nothing was written.
pub const BAD_INPUT: i32 = 2;
/// `orch` itself failed (database, file system); the message says what to do.
pub const INTERNAL: i32 = 3;
/// Stopped by Ctrl-C or SIGTERM; `orch resume <study>` continues.
pub const INTERRUPTED: i32 = 130;
