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
            summary.loop_time_s += parse_loop_line(rest)
                .ok_or_else(|| {
                    ParseError::malformed(
                        path,
                        number,
                        format!("cannot read the loop line `{trimmed}`"),
                    )
                })?
                .0;
            summary.steps += parse_loop_line(rest).map(|l| l.1).unwrap_or(0);
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

/// `(seconds, steps)` from the text after `Loop time of `.
fn parse_loop_line(rest: &str) -> Option<(f64, u64)> {
    let mut words = rest.split_whitespace();
    let seconds = words.next()?.parse().ok()?;
    let steps = words.skip_while(|w| *w != "for").nth(1)?.parse().ok()?;
    Some((seconds, steps))
}

#[cfg(test)]
mod tests {
    use super::*;

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
