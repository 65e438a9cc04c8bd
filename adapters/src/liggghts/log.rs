//! Reader of the LIGGGHTS log: thermo tables, `Loop time` lines and `ERROR:` lines.
//!
//! One `run` command prints a thermo header starting with `Step`, rows of numbers, then
//! `Loop time of <s> on <procs> procs for <steps> steps with <atoms> atoms`. A deck that
//! runs in chunks prints many such blocks; their loop times add up.

use std::io::BufRead;
use std::path::Path;

use crate::{numbered_lines, ParseError};

/// What the log says about a run.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LogSummary {
    /// Sum of all `Loop time` figures, s.
    pub loop_time_s: f64,
    /// Sum of the steps of all runs.
    pub steps: u64,
    /// Σ atoms × steps between consecutive thermo rows: the work the solver did.
    pub particle_steps: f64,
    /// `(step, kinetic energy J)` from thermo rows that have a `KinEng` column.
    pub kinetic_energy: Vec<(u64, f64)>,
    /// `ERROR:` lines, verbatim.
    pub errors: Vec<String>,
    /// The last mass the sink had removed ([`SINK_MASS_COLUMN`]), kg, when the log
    /// has that column.
    pub sink_mass_kg: Option<f64>,
}

/// The thermo column of the mass the templates' sink (`fix outflow … massflow/mesh …
/// delete_atoms yes`) has removed, kg.
pub const SINK_MASS_COLUMN: &str = "outflow[1]";

/// Reads a LIGGGHTS log. `path` names the file in errors.
pub fn read_log<R: BufRead>(reader: R, path: &Path) -> Result<LogSummary, ParseError> {
    let mut summary = LogSummary::default();
    let mut columns: Option<Vec<String>> = None;
    let mut previous_row: Option<(u64, f64)> = None;
    for numbered in numbered_lines(reader, path) {
        let (number, line) = numbered?;
        let trimmed = line.trim();
        if let Some(rest) = trimmed.strip_prefix("Loop time of ") {
            let line = LoopLine::parse_after_prefix(rest).ok_or_else(|| {
                ParseError::malformed(
                    path,
                    number,
                    format!("cannot read the loop line `{trimmed}`"),
                )
            })?;
            summary.loop_time_s += line.seconds;
            summary.steps += line.steps;
            columns = None;
            previous_row = None;
        } else if trimmed.starts_with("ERROR") {
            summary.errors.push(trimmed.to_string());
        } else if trimmed.starts_with("Step ") {
            columns = Some(trimmed.split_whitespace().map(str::to_string).collect());
        } else if let Some(names) = &columns {
            let values: Option<Vec<f64>> =
                trimmed.split_whitespace().map(|f| f.parse().ok()).collect();
            // Interleaved lines (insertion progress, warnings) are not thermo rows.
            let Some(values) = values.filter(|v| v.len() == names.len()) else {
                continue;
            };
            let value = |name: &str| names.iter().position(|n| n == name).map(|i| values[i]);
            let step = value("Step").unwrap_or(0.0) as u64;
            let atoms = value("Atoms").unwrap_or(0.0);
            if let Some((prev_step, prev_atoms)) = previous_row {
                summary.particle_steps += prev_atoms * step.saturating_sub(prev_step) as f64;
            }
            previous_row = Some((step, atoms));
            if let Some(ke) = value("KinEng") {
                summary.kinetic_energy.push((step, ke));
            }
            if let Some(mass) = value(SINK_MASS_COLUMN) {
                summary.sink_mass_kg = Some(mass);
            }
        }
    }
    Ok(summary)
}

/// One `Loop time of <s> on <procs> procs for <steps> steps with <atoms> atoms` line of
/// LIGGGHTS (which goes on `, finish time …`) or LAMMPS: the one reader of it, for the
/// adapter and for `orch-dem bench`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoopLine {
    /// Wall time of the run's time loop, s.
    pub seconds: f64,
    /// MPI ranks.
    pub procs: u32,
    /// Steps of the run.
    pub steps: u64,
    /// Atoms at the end of the run.
    pub atoms: u64,
}

impl LoopLine {
    /// The line parsed from the text after `Loop time of `, or `None`.
    pub fn parse_after_prefix(rest: &str) -> Option<LoopLine> {
        let words: Vec<&str> = rest.split_whitespace().collect();
        match words.as_slice() {
            [seconds, "on", procs, "procs", "for", steps, "steps", "with", atoms, unit, ..]
                if unit.trim_end_matches(',') == "atoms" =>
            {
                Some(LoopLine {
                    seconds: seconds.parse().ok()?,
                    procs: procs.parse().ok()?,
                    steps: steps.parse().ok()?,
                    atoms: atoms.parse().ok()?,
                })
            }
            _ => None,
        }
    }

    /// Every loop line of a whole log, in order.
    pub fn all_in(log: &str) -> Vec<LoopLine> {
        log.lines()
            .filter_map(|line| Self::parse_after_prefix(line.trim().strip_prefix("Loop time of ")?))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn loop_lines_of_liggghts_and_lammps_are_read() {
        let log = "Step Atoms KinEng CPU\n0 3000 0 0\nLoop time of 12.5 on 2 procs for 10000 steps with 2998 atoms\n\nPerformance: 1 tau/day\nLoop time of 0.25 on 1 procs for 100 steps with 3000 atoms, finish time Tue Dec  1 23:18:01 2026\n";
        assert_eq!(
            LoopLine::all_in(log),
            [
                LoopLine {
                    seconds: 12.5,
                    procs: 2,
                    steps: 10000,
                    atoms: 2998
                },
                LoopLine {
                    seconds: 0.25,
                    procs: 1,
                    steps: 100,
                    atoms: 3000
                },
            ]
        );
        assert!(
            LoopLine::all_in("Loop time of x on 1 procs for 1 steps with 1 atoms\n").is_empty()
        );
    }

    #[test]
    fn the_shared_liggghts_log_sums_both_runs() {
        // The full log of the verified 3000-particle run (shared/solvers/samples).
        let log = include_str!("../../../tests/fixtures/liggghts/log.hopper");
        let summary = read_log(log.as_bytes(), Path::new("log.hopper")).unwrap();
        assert_eq!(summary.steps, 45_000);
        assert!(summary.errors.is_empty());
        assert!((summary.loop_time_s - (15.1513 + 14.9432)).abs() < 1e-9);
        // 3000 atoms over the 15000 fill steps at least.
        assert!(
            summary.particle_steps > 3000.0 * 14_000.0,
            "{}",
            summary.particle_steps
        );
        assert!(!summary.kinetic_energy.is_empty());
    }

    #[test]
    fn error_lines_are_collected() {
        let log = "LIGGGHTS (Version LIGGGHTS-PUBLIC 3.8.0)\nERROR: Unknown command: frobnicate 3 (./src/input.cpp:252)\n";
        let summary = read_log(log.as_bytes(), Path::new("log.liggghts")).unwrap();
        assert_eq!(
            summary.errors,
            ["ERROR: Unknown command: frobnicate 3 (./src/input.cpp:252)"]
        );
    }
}
