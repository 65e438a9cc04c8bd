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
    /// What the deck's rate insertions placed by the end of its first `run`, when any
    /// printed a target (`fix insert/rate/region` does; `insert/pack` does not).
    pub insertion: Option<Insertion>,
}

/// What a deck's rate insertions (`fix insert/rate/region … mass M`) set out to place
/// and had placed by the end of the deck's first `run`: the fill stage of orch's
/// hopper decks, after which the plug is removed. LIGGGHTS goes on inserting until its
/// mass is in, so an inlet too narrow for its rate pours on into the discharge without
/// a word; this is how far it had got when the discharge began. Summed over the
/// insertion fixes.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Insertion {
    /// Particles the fixes set out to insert, from their `<n> particles (mass <kg>)
    /// within <steps> steps` lines.
    pub asked_count: u64,
    /// Mass they set out to insert, kg.
    pub asked_kg: f64,
    /// Particles inserted by the end of the first run, from the last `- a total of <n>
    /// particle templates (mass <kg>) inserted so far.` line of each fix before it.
    pub placed_count: u64,
    /// Mass inserted by the end of the first run, kg.
    pub placed_kg: f64,
}

impl Insertion {
    /// The mass placed by the fill's end against the mass asked; short when fewer
    /// particles than asked were in. LIGGGHTS turns the mass into a count (over the
    /// mixture's mean particle mass) and inserts that count, so the mass placed differs
    /// from the mass asked by the random draw of types even when every particle is in
    /// (−0.4 % to +0.5 % in five 8 558-particle 5:1 pours): the count, not the mass,
    /// says whether the pour was done.
    pub fn inflow_placed(&self) -> crate::InflowPlaced {
        crate::InflowPlaced {
            placed_kg: self.placed_kg,
            asked_kg: self.asked_kg,
            short: self.placed_count < self.asked_count,
        }
    }
}

/// Each insertion fix's target and running total, read from its `INFO: Particle
/// insertion <id>: …` lines and the line after each.
#[derive(Debug, Default)]
struct InsertionLines {
    /// `(fix id, what it asked and had placed by the end of the first run)`.
    fixes: Vec<(String, Insertion)>,
    /// The fix whose `INFO` line came last: the next line continues it.
    current: Option<usize>,
    /// Whether the first run has ended (its loop line seen).
    first_run_over: bool,
}

impl InsertionLines {
    /// Reads `line` if it is an insertion line; `false` when it is not.
    fn read(&mut self, line: &str) -> bool {
        if let Some(rest) = line.strip_prefix("INFO: Particle insertion ") {
            let id = rest.split(':').next().unwrap_or_default().to_string();
            let index = match self.fixes.iter().position(|(f, _)| *f == id) {
                Some(index) => index,
                None => {
                    self.fixes.push((id, Insertion::default()));
                    self.fixes.len() - 1
                }
            };
            self.current = Some(index);
            return true;
        }
        let Some(index) = self.current else {
            return false;
        };
        let fix = &mut self.fixes[index].1;
        // `8558 particles (mass 2.778889e-02) within 224991 steps`
        if let Some((count, mass)) = count_and_mass(line, " particles (mass ", ") within ") {
            // Printed again at a later run's set-up: the same target.
            fix.asked_count = count;
            fix.asked_kg = mass;
            return true;
        }
        // `- a total of 616 particle templates (mass 1.991854e-03) inserted so far.`
        if let Some(rest) = line.strip_prefix("- a total of ") {
            if let Some((count, mass)) =
                count_and_mass(rest, " particle templates (mass ", ") inserted so far")
            {
                if !self.first_run_over {
                    fix.placed_count = count;
                    fix.placed_kg = mass;
                }
                return true;
            }
        }
        false
    }

    /// The fixes that printed a target, summed; `None` when none did.
    fn summary(&self) -> Option<Insertion> {
        let asked: Vec<&Insertion> = self
            .fixes
            .iter()
            .map(|(_, fix)| fix)
            .filter(|fix| fix.asked_count > 0)
            .collect();
        (!asked.is_empty()).then(|| {
            asked
                .iter()
                .fold(Insertion::default(), |sum, fix| Insertion {
                    asked_count: sum.asked_count + fix.asked_count,
                    asked_kg: sum.asked_kg + fix.asked_kg,
                    placed_count: sum.placed_count + fix.placed_count,
                    placed_kg: sum.placed_kg + fix.placed_kg,
                })
        })
    }
}

/// `<count><between><mass><after>…` read from the start of `text`.
fn count_and_mass(text: &str, between: &str, after: &str) -> Option<(u64, f64)> {
    let (count, rest) = text.split_once(between)?;
    let (mass, _) = rest.split_once(after)?;
    let count = count.trim().parse().ok()?;
    let mass: f64 = mass.trim().parse().ok()?;
    mass.is_finite().then_some((count, mass))
}

/// The thermo column of the mass the templates' sink (`fix outflow … massflow/mesh …
/// delete_atoms yes`) has removed, kg.
pub const SINK_MASS_COLUMN: &str = "outflow[1]";

/// Reads a LIGGGHTS log. `path` names the file in errors.
pub fn read_log<R: BufRead>(reader: R, path: &Path) -> Result<LogSummary, ParseError> {
    let mut summary = LogSummary::default();
    let mut columns: Option<Vec<String>> = None;
    let mut previous_row: Option<(u64, f64)> = None;
    let mut insertions = InsertionLines::default();
    for numbered in numbered_lines(reader, path) {
        let (number, line) = numbered?;
        let trimmed = line.trim();
        if insertions.read(trimmed) {
            continue;
        }
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
            insertions.first_run_over = true;
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
    summary.insertion = insertions.summary();
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
        // `insert/pack` prints no target: nothing to say of a pour.
        assert_eq!(summary.insertion, None);
    }

    #[test]
    fn a_poured_fill_reads_as_the_mass_its_insertion_placed_before_the_discharge() {
        // The first 530 lines of a stream-fed 5:1 hopper run (orch compare, seed 1):
        // 28 batches of `insert/rate/region`, the fill's loop line, the discharge's
        // first chunk.
        let log = include_str!("../../../tests/fixtures/liggghts/log.poured-start");
        let summary = read_log(log.as_bytes(), Path::new("log.liggghts")).unwrap();
        let insertion = summary.insertion.unwrap();
        assert_eq!(
            insertion,
            Insertion {
                asked_count: 8558,
                asked_kg: 2.778889e-02,
                placed_count: 8558,
                placed_kg: 2.784172e-02,
            }
        );
        let placed = insertion.inflow_placed();
        assert!(!placed.short);
        assert!((placed.placed_kg / placed.asked_kg - 1.0019).abs() < 1e-4);
    }

    #[test]
    fn an_insertion_still_going_when_the_fill_ends_reads_as_short() {
        let log = "\
INFO: Particle insertion insert: 307.952496 particles every 8333 steps - particle rate 30796.481488, (mass rate 1.000000e-01)
      8558 particles (mass 2.778889e-02) within 224991 steps
    Step    Atoms         KinEng            CPU 
       0        0              0              0 
INFO: Particle insertion insert: inserted 308 particle templates (mass 1.037480e-03) at step 1
 - a total of 308 particle templates (mass 1.037480e-03) inserted so far.
    1000      308   0.0005310187    0.073626262 
INFO: Particle insertion insert: inserted 308 particle templates (mass 9.543740e-04) at step 1001
 - a total of 616 particle templates (mass 1.991854e-03) inserted so far.
    2000      616   0.0011191792     0.62176191 
Loop time of 0.6 on 1 procs for 2000 steps with 616 atoms, finish time Sun Dec  6 10:28:40 2026
INFO: Particle insertion insert: inserted 308 particle templates (mass 1.037480e-03) at step 2001
 - a total of 924 particle templates (mass 3.029334e-03) inserted so far.
Loop time of 0.3 on 1 procs for 1000 steps with 924 atoms
";
        let summary = read_log(log.as_bytes(), Path::new("log.liggghts")).unwrap();
        let insertion = summary.insertion.unwrap();
        // What came in after the first run (the discharge) does not count.
        assert_eq!(
            (insertion.placed_count, insertion.placed_kg),
            (616, 1.991854e-03)
        );
        assert!(insertion.inflow_placed().short);
        // The insertion lines are not thermo rows: the work is still read.
        assert_eq!(summary.steps, 3000);
        assert!(summary.particle_steps > 0.0);
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
