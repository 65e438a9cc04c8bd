//! Reader of `log.native`, the native kernel's log: a thermo table
//! (`step time_s particles kinetic_energy_J discharged_mass_kg`), then
//! `Loop time of <s> s on <n> threads for <steps> steps with <p> particle-steps`, and
//! `Wall impact energy of <J> J` (the sum of `½ m v_n²` over particle–wall impacts) and
//! `Largest overlap of <ratio> of the smaller radius` (the deepest contact of the run),
//! and for each inflow an [`InflowLine`] (`Inflow 1 of 1 placed <kg> kg of the <kg> kg
//! asked …`).
//! A run that stopped with an error has an `ERROR:` line and no loop line.

use std::io::BufRead;
use std::path::Path;

use crate::{numbered_lines, InflowPlaced, ParseError};

/// What the native log says about a run.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct NativeLog {
    /// Wall time of the time loop, s.
    pub loop_time_s: f64,
    /// Steps taken.
    pub steps: u64,
    /// Σ particles × steps.
    pub particle_steps: f64,
    /// `(time s, kinetic energy J)` from the thermo table.
    pub kinetic_energy: Vec<(f64, f64)>,
    /// `(time s, discharged mass kg)` from the thermo table.
    pub discharged_mass: Vec<(f64, f64)>,
    /// Sum over particle–wall impacts of `½ m v_n²`, J (absent from older logs).
    pub wall_impact_energy_j: Option<f64>,
    /// The deepest overlap of the run over the smaller radius (absent from older logs).
    pub largest_overlap_ratio: Option<f64>,
    /// One line per inflow that began, in inflow order (none without an inflow, and
    /// none in logs older than the line).
    pub inflows: Vec<InflowLine>,
}

impl NativeLog {
    /// What all inflows placed against what they were asked for, or `None` when the
    /// run had no inflow line.
    pub fn inflow_placed(&self) -> Option<InflowPlaced> {
        (!self.inflows.is_empty()).then(|| InflowPlaced {
            placed_kg: self.inflows.iter().map(|i| i.placed_kg).sum(),
            asked_kg: self.inflows.iter().map(|i| i.asked_kg).sum(),
            short: self.inflows.iter().any(|i| i.short),
        })
    }
}

/// What one inflow placed against what it was asked for, as the log's
/// `Inflow <k> of <n> placed <kg> kg of the <kg> kg asked (<%> %; by mass <type> <%> %,
/// …)` line, with `: its region had no room for the rest; …` when it fell short by
/// more than one particle; the kernel's runner writes it and the adapter reads it,
/// both through this type.
#[derive(Debug, Clone, PartialEq)]
pub struct InflowLine {
    /// The inflow's place among the case's inflows, from 1.
    pub number: usize,
    /// How many inflows the case has.
    pub count: usize,
    /// Mass placed, kg.
    pub placed_kg: f64,
    /// Mass the inflow's batches asked for, kg.
    pub asked_kg: f64,
    /// Each type's name and its share of the mass placed, in %.
    pub shares_by_mass_percent: Vec<(String, f64)>,
    /// True when the inflow fell short by more than one particle: its region had no
    /// room for the rest, and the run holds less material than the case asked for.
    pub short: bool,
}

impl InflowLine {
    const PREFIX: &'static str = "Inflow ";
    const SHORT: &'static str = ": its region had no room for the rest; make the region \
         larger (or the feed faster) or lower the mass rate";

    /// The line's values, `None` when it is not an inflow line; `Some(Err)` when it
    /// starts like one and cannot be read.
    fn parse(line: &str) -> Option<Result<InflowLine, ()>> {
        let rest = line.strip_prefix(Self::PREFIX)?;
        Some(Self::parse_after_prefix(rest).ok_or(()))
    }

    fn parse_after_prefix(rest: &str) -> Option<InflowLine> {
        let (head, tail) = rest.split_once(" asked (")?;
        let words: Vec<&str> = head.split_whitespace().collect();
        let [number, "of", count, "placed", placed, "kg", "of", "the", asked, "kg"] =
            words.as_slice()
        else {
            return None;
        };
        let (shares, after) = tail.split_once(')')?;
        let (_, by_mass) = shares.split_once("; by mass ")?;
        let shares_by_mass_percent = by_mass
            .split(", ")
            .map(|share| {
                let (name, percent) = share.strip_suffix(" %")?.rsplit_once(' ')?;
                Some((name.to_string(), percent.parse().ok()?))
            })
            .collect::<Option<Vec<_>>>()?;
        let finite = |text: &str| {
            text.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite() && *v >= 0.0)
        };
        Some(InflowLine {
            number: number.parse().ok()?,
            count: count.parse().ok()?,
            placed_kg: finite(placed)?,
            asked_kg: finite(asked)?,
            shares_by_mass_percent,
            short: after.starts_with(Self::SHORT),
        })
    }
}

impl std::fmt::Display for InflowLine {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let shares: Vec<String> = self
            .shares_by_mass_percent
            .iter()
            .map(|(name, percent)| format!("{name} {percent:.1} %"))
            .collect();
        write!(
            f,
            "{}{} of {} placed {:.6e} kg of the {:.6e} kg asked ({:.1} %; by mass {})",
            Self::PREFIX,
            self.number,
            self.count,
            self.placed_kg,
            self.asked_kg,
            100.0 * self.placed_kg / self.asked_kg,
            shares.join(", ")
        )?;
        if self.short {
            f.write_str(Self::SHORT)?;
        }
        Ok(())
    }
}

/// The log's `Largest overlap of <ratio> of the smaller radius` line, written and read
/// through this type.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LargestOverlapLine(pub f64);

impl LargestOverlapLine {
    const PREFIX: &'static str = "Largest overlap of ";
    const SUFFIX: &'static str = " of the smaller radius";

    /// The ratio of a line, `None` when it is not this line; `Some(Err)` when it starts
    /// like one and cannot be read.
    fn parse(line: &str) -> Option<Result<f64, ()>> {
        let rest = line.strip_prefix(Self::PREFIX)?;
        Some(
            rest.strip_suffix(Self::SUFFIX)
                .and_then(|v| v.trim().parse::<f64>().ok())
                .filter(|v| v.is_finite() && *v >= 0.0)
                .ok_or(()),
        )
    }
}

impl std::fmt::Display for LargestOverlapLine {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}{:.6}{}", Self::PREFIX, self.0, Self::SUFFIX)
    }
}

/// The thermo table's header.
pub const THERMO_HEADER: &str = "step time_s particles kinetic_energy_J discharged_mass_kg";

/// The log's `Loop time of <s> s on <n> threads for <steps> steps with <p>
/// particle-steps (<rate> particle-steps/s)` line: the kernel writes it, `orch` and
/// `orch-dem bench` read it, all through this type.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoopLine {
    /// Wall time of the time loop, s.
    pub seconds: f64,
    /// Threads the loop ran on.
    pub threads: usize,
    /// Steps taken.
    pub steps: u64,
    /// Σ particles × steps.
    pub particle_steps: f64,
}

impl LoopLine {
    /// Particle-steps per second of loop time.
    pub fn throughput(&self) -> f64 {
        self.particle_steps / self.seconds.max(1e-12)
    }

    /// The line parsed from the text after `Loop time of `, or `None`.
    pub fn parse_after_prefix(rest: &str) -> Option<LoopLine> {
        let words: Vec<&str> = rest.split_whitespace().collect();
        match words.as_slice() {
            [seconds, "s", "on", threads, "threads", "for", steps, "steps", "with", particle_steps, "particle-steps", ..] => {
                Some(LoopLine {
                    seconds: seconds.parse().ok()?,
                    threads: threads.parse().ok()?,
                    steps: steps.parse().ok()?,
                    particle_steps: particle_steps.parse().ok()?,
                })
            }
            _ => None,
        }
    }

    /// The first loop line of a whole log, or `None`.
    pub fn find_in(log: &str) -> Option<LoopLine> {
        log.lines()
            .find_map(|line| Self::parse_after_prefix(line.trim().strip_prefix("Loop time of ")?))
    }
}

impl std::fmt::Display for LoopLine {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "Loop time of {:.6} s on {} threads for {} steps with {} particle-steps ({:.4e} particle-steps/s)",
            self.seconds,
            self.threads,
            self.steps,
            self.particle_steps,
            self.throughput()
        )
    }
}

/// Reads a native log; `path` names the file in errors.
pub fn read_log<R: BufRead>(reader: R, path: &Path) -> Result<NativeLog, ParseError> {
    let malformed = |line: usize, message: String| ParseError::malformed(path, line, message);
    let mut log = NativeLog::default();
    let mut in_table = false;
    let mut finished = false;
    let mut last_line = 0;
    for numbered in numbered_lines(reader, path) {
        let (number, line) = numbered?;
        last_line = number;
        let trimmed = line.trim();
        if trimmed == THERMO_HEADER {
            in_table = true;
        } else if let Some(error) = trimmed.strip_prefix("ERROR: ") {
            return Err(malformed(number, format!("the run failed: {error}")));
        } else if let Some(rest) = trimmed.strip_prefix("Wall impact energy of ") {
            let value = rest
                .strip_suffix(" J")
                .and_then(|v| v.trim().parse::<f64>().ok())
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    malformed(number, format!("cannot read the impact line `{trimmed}`"))
                })?;
            log.wall_impact_energy_j = Some(value);
        } else if let Some(ratio) = LargestOverlapLine::parse(trimmed) {
            let ratio = ratio.map_err(|()| {
                malformed(number, format!("cannot read the overlap line `{trimmed}`"))
            })?;
            log.largest_overlap_ratio = Some(ratio);
        } else if let Some(inflow) = InflowLine::parse(trimmed) {
            let inflow = inflow.map_err(|()| {
                malformed(number, format!("cannot read the inflow line `{trimmed}`"))
            })?;
            log.inflows.push(inflow);
        } else if let Some(rest) = trimmed.strip_prefix("Loop time of ") {
            let line = LoopLine::parse_after_prefix(rest).ok_or_else(|| {
                malformed(number, format!("cannot read the loop line `{trimmed}`"))
            })?;
            log.loop_time_s = line.seconds;
            log.steps = line.steps;
            log.particle_steps = line.particle_steps;
            in_table = false;
            finished = true;
        } else if in_table {
            let values: Option<Vec<f64>> =
                trimmed.split_whitespace().map(|f| f.parse().ok()).collect();
            match values {
                Some(v) if v.len() == 5 => {
                    log.kinetic_energy.push((v[1], v[3]));
                    log.discharged_mass.push((v[1], v[4]));
                }
                _ => {
                    return Err(malformed(
                        number,
                        format!("expected a thermo row ({THERMO_HEADER}), found `{trimmed}`"),
                    ))
                }
            }
        }
    }
    if !finished {
        return Err(malformed(
            last_line,
            "the log ends without a `Loop time` line: the run did not finish".to_string(),
        ));
    }
    Ok(log)
}
