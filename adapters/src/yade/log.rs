//! The log the hopper script writes (`log.yade`): stage lines, then one summary line.
//!
//! YADE itself prints nothing per step, so the script reports what orch needs:
//!
//! ```text
//! ORCH SUMMARY loop_time_s=12.3 steps=45000 particle_steps=1.2e+07 particles_left=3
//! ```

use std::io::BufRead;
use std::path::Path;

use crate::{numbered_lines, ParseError};

/// Start of the summary line.
pub const SUMMARY_PREFIX: &str = "ORCH SUMMARY";

/// What the summary line says about a run.
#[derive(Debug, Clone, PartialEq)]
pub struct YadeSummary {
    /// Wall time of the fill and discharge loops, s.
    pub loop_time_s: f64,
    /// Time steps run.
    pub steps: u64,
    /// Particles × time steps advanced.
    pub particle_steps: f64,
    /// Particles still in the hopper at the end.
    pub particles_left: u64,
    /// Mass the script removed below the sink, kg (`removed_mass_kg`; logs written
    /// before it was added lack it).
    pub removed_mass_kg: Option<f64>,
}

/// Reads `log.yade`; a log without its summary line is a run that did not finish.
pub fn read_log<R: BufRead>(reader: R, path: &Path) -> Result<YadeSummary, ParseError> {
    let mut last_line = 0;
    for numbered in numbered_lines(reader, path) {
        let (number, line) = numbered?;
        last_line = number;
        let Some(rest) = line.strip_prefix(SUMMARY_PREFIX) else {
            continue;
        };
        let value = |key: &str| -> Result<f64, ParseError> {
            rest.split_whitespace()
                .find_map(|pair| pair.strip_prefix(key)?.strip_prefix('='))
                .and_then(|v| v.parse::<f64>().ok())
                .filter(|v| v.is_finite() && *v >= 0.0)
                .ok_or_else(|| {
                    ParseError::malformed(
                        path,
                        number,
                        format!("expected `{key}=<non-negative number>` in `{line}`"),
                    )
                })
        };
        return Ok(YadeSummary {
            loop_time_s: value("loop_time_s")?,
            steps: value("steps")? as u64,
            particle_steps: value("particle_steps")?,
            particles_left: value("particles_left")? as u64,
            removed_mass_kg: rest
                .contains("removed_mass_kg=")
                .then(|| value("removed_mass_kg"))
                .transpose()?,
        });
    }
    Err(ParseError::malformed(
        path,
        last_line.max(1),
        format!("no `{SUMMARY_PREFIX}` line: the YADE script did not finish"),
    ))
}
