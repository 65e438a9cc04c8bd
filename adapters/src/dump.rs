//! Streaming reader of LAMMPS/LIGGGHTS `dump custom` text files.
//!
//! A file holds one or more snapshots:
//!
//! ```text
//! ITEM: TIMESTEP
//! 20000
//! ITEM: NUMBER OF ATOMS
//! 2
//! ITEM: BOX BOUNDS mm mm mm
//! -0.045 0.045
//! -0.045 0.045
//! -0.03 0.105
//! ITEM: ATOMS id type x y z vx vy vz radius
//! 510 2 -0.012689 0.021384 0.0226856 0.0377017 -0.0372203 -0.0636574 0.001
//! ...
//! ```
//!
//! The reader holds one snapshot in memory at a time and hands it to a callback, so a
//! dump of any length is read in constant memory. A snapshot cut short (fewer atom lines
//! than announced, or a short line) is an error naming the file and line.

use std::io::BufRead;
use std::path::Path;

use orch_granular::Sighting;

use crate::ParseError;

/// One snapshot: its time step, column names and rows of values.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Snapshot {
    /// Time step number of the snapshot.
    pub timestep: u64,
    /// Column names from the `ITEM: ATOMS` line.
    pub columns: Vec<String>,
    /// Values row by row, `columns.len()` per row.
    pub values: Vec<f64>,
}

impl Snapshot {
    /// Number of atom rows.
    pub fn len(&self) -> usize {
        if self.columns.is_empty() {
            0
        } else {
            self.values.len() / self.columns.len()
        }
    }

    /// True when the snapshot has no atoms.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Index of column `name`.
    pub fn column(&self, name: &str) -> Option<usize> {
        self.columns.iter().position(|c| c == name)
    }

    /// The rows as sightings; needs columns `id type radius mass x y z vx vy vz`.
    /// Returns the names of missing columns otherwise.
    pub fn sightings(&self) -> Result<Vec<Sighting>, Vec<&'static str>> {
        const NEEDED: [&str; 10] = [
            "id", "type", "radius", "mass", "x", "y", "z", "vx", "vy", "vz",
        ];
        let index: Vec<Option<usize>> = NEEDED.iter().map(|n| self.column(n)).collect();
        let missing: Vec<&'static str> = NEEDED
            .iter()
            .zip(&index)
            .filter(|(_, i)| i.is_none())
            .map(|(n, _)| *n)
            .collect();
        if !missing.is_empty() {
            return Err(missing);
        }
        let i: Vec<usize> = index.into_iter().flatten().collect();
        let width = self.columns.len();
        Ok(self
            .values
            .chunks_exact(width)
            .map(|row| Sighting {
                id: row[i[0]] as u64,
                particle_type: row[i[1]] as u32,
                radius_m: row[i[2]],
                mass_kg: row[i[3]],
                position_m: [row[i[4]], row[i[5]], row[i[6]]],
                velocity_m_per_s: [row[i[7]], row[i[8]], row[i[9]]],
            })
            .collect())
    }
}

/// The columns of a lean sensor dump that hold each row's state at the snapshot
/// before (position m, velocity m/s), as LIGGGHTS names the `fix store/state` values.
pub const PREVIOUS_COLUMNS: [&str; 6] = [
    "f_sensor_prev[1]",
    "f_sensor_prev[2]",
    "f_sensor_prev[3]",
    "f_sensor_prev[4]",
    "f_sensor_prev[5]",
    "f_sensor_prev[6]",
];

/// The column of a lean sensor dump that is 1 where the snapshot before saw the row's
/// particle in the sensor band, 0 where it did not.
pub const PREVIOUS_SEEN_COLUMN: &str = "v_sensor_seen";

impl Snapshot {
    /// In a lean sensor dump (columns [`PREVIOUS_COLUMNS`] and [`PREVIOUS_SEEN_COLUMN`]),
    /// each row's sighting at the snapshot before where that snapshot saw it in the
    /// band, else `None`; `Ok(None)` for a dump without those columns. Needs the
    /// columns of [`Snapshot::sightings`] too; returns missing names otherwise.
    pub fn previous_sightings(&self) -> Result<Option<Vec<Option<Sighting>>>, Vec<&'static str>> {
        let Some(seen) = self.column(PREVIOUS_SEEN_COLUMN) else {
            return Ok(None);
        };
        let previous: Vec<Option<usize>> =
            PREVIOUS_COLUMNS.iter().map(|n| self.column(n)).collect();
        let missing: Vec<&'static str> = PREVIOUS_COLUMNS
            .iter()
            .zip(&previous)
            .filter(|(_, i)| i.is_none())
            .map(|(n, _)| *n)
            .collect();
        if !missing.is_empty() {
            return Err(missing);
        }
        let p: Vec<usize> = previous.into_iter().flatten().collect();
        let width = self.columns.len();
        let current = self.sightings()?;
        Ok(Some(
            self.values
                .chunks_exact(width)
                .zip(current)
                .map(|(row, now)| {
                    (row[seen] > 0.5).then_some(Sighting {
                        position_m: [row[p[0]], row[p[1]], row[p[2]]],
                        velocity_m_per_s: [row[p[3]], row[p[4]], row[p[5]]],
                        ..now
                    })
                })
                .collect(),
        ))
    }
}

/// What was read from a whole file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct DumpSummary {
    /// Snapshots read.
    pub snapshots: usize,
    /// Atom rows read over all snapshots.
    pub rows: usize,
}

/// Reads every snapshot of a dump from `reader`, calling `on_snapshot` for each.
/// `path` names the file in errors.
pub fn read_dump<R: BufRead>(
    reader: R,
    path: &Path,
    mut on_snapshot: impl FnMut(&Snapshot) -> Result<(), String>,
) -> Result<DumpSummary, ParseError> {
    let mut lines = NumberedLines {
        inner: reader.lines().peekable(),
        path,
        number: 0,
    };
    let mut summary = DumpSummary::default();
    let mut snapshot = Snapshot::default();
    while let Some(line) = lines.next_line()? {
        if line.trim().is_empty() {
            continue;
        }
        lines.expect_item(&line, "ITEM: TIMESTEP")?;
        let timestep = lines.parse_single("a time step number")?;
        if summary.snapshots > 0 && timestep <= snapshot.timestep {
            return Err(lines.malformed(format!(
                "time step {timestep} follows time step {}: a dump's snapshots go forward in time (two runs written into one file?)",
                snapshot.timestep
            )));
        }
        snapshot.timestep = timestep;
        let header = lines.required("ITEM: NUMBER OF ATOMS")?;
        lines.expect_item(&header, "ITEM: NUMBER OF ATOMS")?;
        let atoms: usize = lines.parse_single("a number of atoms")?;
        let bounds = lines.required("ITEM: BOX BOUNDS")?;
        lines.expect_item(&bounds, "ITEM: BOX BOUNDS")?;
        for _ in 0..3 {
            lines.required("a line of box bounds")?;
        }
        let header = lines.required("ITEM: ATOMS")?;
        lines.expect_item(&header, "ITEM: ATOMS")?;
        let earlier = std::mem::take(&mut snapshot.columns);
        snapshot.columns = header["ITEM: ATOMS".len()..]
            .split_whitespace()
            .map(str::to_string)
            .collect();
        // The last line of the file naming fewer columns than the snapshot before: the
        // file was cut inside it (a lean dump's snapshots are mostly headers).
        if atoms == 0 && lines.at_end() && snapshot.columns.len() < earlier.len() {
            return Err(lines.malformed(format!(
                "`ITEM: ATOMS` names {} columns where the snapshot before named {}, and the file ends there (truncated dump?)",
                snapshot.columns.len(),
                earlier.len()
            )));
        }
        if snapshot.columns.is_empty() {
            return Err(lines.malformed("`ITEM: ATOMS` names no columns".into()));
        }
        snapshot.values.clear();
        snapshot.values.reserve(atoms * snapshot.columns.len());
        for read in 0..atoms {
            let what = format!(
                "atom {} of {atoms} of the snapshot at time step {}",
                read + 1,
                snapshot.timestep
            );
            let row = lines.required(&what)?;
            let before = snapshot.values.len();
            for field in row.split_whitespace() {
                let value = field.parse::<f64>().map_err(|_| {
                    lines.malformed(format!("expected a number in {what}, found `{field}`"))
                })?;
                snapshot.values.push(value);
            }
            let found = snapshot.values.len() - before;
            if found != snapshot.columns.len() {
                // A row cut short at the very end of the file is a truncated dump.
                let ending = if found < snapshot.columns.len() && lines.at_end() {
                    " and the file ends there (truncated dump?)"
                } else {
                    ""
                };
                return Err(lines.malformed(format!(
                    "{what} has {found} values, the header names {} columns{ending}",
                    snapshot.columns.len()
                )));
            }
        }
        summary.snapshots += 1;
        summary.rows += atoms;
        on_snapshot(&snapshot).map_err(|message| lines.malformed(message))?;
    }
    Ok(summary)
}

struct NumberedLines<'p, L: Iterator> {
    inner: std::iter::Peekable<L>,
    path: &'p Path,
    number: usize,
}

impl<L: Iterator<Item = std::io::Result<String>>> NumberedLines<'_, L> {
    fn next_line(&mut self) -> Result<Option<String>, ParseError> {
        match self.inner.next() {
            None => Ok(None),
            Some(Ok(line)) => {
                self.number += 1;
                Ok(Some(line))
            }
            Some(Err(source)) => Err(ParseError::read(self.path)(source)),
        }
    }

    /// Whether no line follows.
    fn at_end(&mut self) -> bool {
        self.inner.peek().is_none()
    }

    fn required(&mut self, what: &str) -> Result<String, ParseError> {
        match self.next_line()? {
            Some(line) => Ok(line),
            None => Err(ParseError::malformed(
                self.path,
                self.number + 1,
                format!("file ends where {what} was expected (truncated dump?)"),
            )),
        }
    }

    fn parse_single<T: std::str::FromStr>(&mut self, what: &str) -> Result<T, ParseError> {
        let line = self.required(what)?;
        line.trim()
            .parse()
            .map_err(|_| self.malformed(format!("expected {what}, found `{}`", line.trim())))
    }

    fn expect_item(&self, line: &str, item: &str) -> Result<(), ParseError> {
        if line.trim_start().starts_with(item) {
            Ok(())
        } else {
            Err(self.malformed(format!("expected `{item}`, found `{}`", line.trim())))
        }
    }

    fn malformed(&self, message: String) -> ParseError {
        ParseError::malformed(self.path, self.number, message)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TWO_SNAPSHOTS: &str = "ITEM: TIMESTEP
100
ITEM: NUMBER OF ATOMS
2
ITEM: BOX BOUNDS mm mm mm
-0.045 0.045
-0.045 0.045
-0.03 0.105
ITEM: ATOMS id type radius mass x y z vx vy vz 
883 2 0.001 1.0472e-05 -0.00242326 -0.000232454 0.001 -0.0681199 -0.0333297 -0.322138 
12 1 0.002 8.3776e-05 0.001 0.002 0.003 0 0 -1 
ITEM: TIMESTEP
150
ITEM: NUMBER OF ATOMS
0
ITEM: BOX BOUNDS mm mm mm
-0.045 0.045
-0.045 0.045
-0.03 0.105
ITEM: ATOMS id type radius mass x y z vx vy vz 
";

    fn read(text: &str) -> Result<(DumpSummary, Vec<Snapshot>), ParseError> {
        let mut seen = Vec::new();
        let summary = read_dump(text.as_bytes(), Path::new("post/sensor.liggghts"), |s| {
            seen.push(s.clone());
            Ok(())
        })?;
        Ok((summary, seen))
    }

    #[test]
    fn a_time_step_that_goes_back_is_malformed() {
        let twice = format!("{TWO_SNAPSHOTS}{TWO_SNAPSHOTS}");
        let error = read(&twice).unwrap_err().to_string();
        assert!(
            error.contains("follows time step") && error.contains("go forward in time"),
            "{error}"
        );
    }

    #[test]
    fn reads_snapshots_with_trailing_spaces_and_empty_ones() {
        let (summary, seen) = read(TWO_SNAPSHOTS).unwrap();
        assert_eq!(
            summary,
            DumpSummary {
                snapshots: 2,
                rows: 2
            }
        );
        assert_eq!(seen[0].timestep, 100);
        let sightings = seen[0].sightings().unwrap();
        assert_eq!(sightings[0].id, 883);
        assert_eq!(sightings[0].particle_type, 2);
        assert_eq!(sightings[1].velocity_m_per_s, [0.0, 0.0, -1.0]);
        assert!(seen[1].is_empty());
    }

    #[test]
    fn a_real_liggghts_sensor_dump_parses() {
        // Written by LIGGGHTS 3.8.0 on this machine with the sensor dump of our template.
        let sample = include_str!("../../tests/fixtures/liggghts/sensor_excerpt.liggghts");
        let (summary, seen) = read(sample).unwrap();
        assert_eq!(summary.snapshots, 3);
        assert!(summary.rows > 0);
        let sightings = seen[0].sightings().unwrap();
        assert!(sightings
            .iter()
            .all(|s| s.mass_kg > 0.0 && s.radius_m > 0.0));
    }

    #[test]
    fn the_truncated_shared_sample_is_refused() {
        // shared/solvers/samples/liggghts/dump20000.liggghts.head: a real dump announcing
        // 2592 atoms, cut after 21 of them.
        let sample = include_str!("../../tests/fixtures/liggghts/dump20000_truncated.liggghts");
        let error = read(sample).unwrap_err().to_string();
        assert!(
            error.starts_with("post/sensor.liggghts:31: file ends where atom 22 of 2592"),
            "{error}"
        );
    }

    #[test]
    fn truncated_snapshot_names_file_and_line() {
        let cut = &TWO_SNAPSHOTS[..TWO_SNAPSHOTS.find("12 1 0.002").unwrap()];
        let error = read(cut).unwrap_err().to_string();
        assert_eq!(
            error,
            "post/sensor.liggghts:11: file ends where atom 2 of 2 of the snapshot at time step 100 was expected (truncated dump?)"
        );
    }

    #[test]
    fn a_header_cut_at_the_end_of_the_file_is_a_truncated_dump() {
        let end = TWO_SNAPSHOTS.rfind(" vx vy vz").unwrap();
        let error = read(&TWO_SNAPSHOTS[..end]).unwrap_err().to_string();
        assert_eq!(
            error,
            "post/sensor.liggghts:20: `ITEM: ATOMS` names 7 columns where the snapshot before named 10, and the file ends there (truncated dump?)"
        );
    }

    #[test]
    fn a_row_cut_at_the_end_of_the_file_is_a_truncated_dump() {
        let end = TWO_SNAPSHOTS.find("12 1 0.002").unwrap() + "12 1 0.002".len();
        let error = read(&TWO_SNAPSHOTS[..end]).unwrap_err().to_string();
        assert_eq!(
            error,
            "post/sensor.liggghts:11: atom 2 of 2 of the snapshot at time step 100 has 3 values, the header names 10 columns and the file ends there (truncated dump?)"
        );
    }

    #[test]
    fn short_line_and_garbage_are_refused_with_line_numbers() {
        let short = TWO_SNAPSHOTS.replace(
            "12 1 0.002 8.3776e-05 0.001 0.002 0.003 0 0 -1 ",
            "12 1 0.002",
        );
        assert_eq!(
            read(&short).unwrap_err().to_string(),
            "post/sensor.liggghts:11: atom 2 of 2 of the snapshot at time step 100 has 3 values, the header names 10 columns"
        );
        let garbage = TWO_SNAPSHOTS.replace("ITEM: TIMESTEP\n150", "ITEM: TIMESTEP\nabc");
        assert_eq!(
            read(&garbage).unwrap_err().to_string(),
            "post/sensor.liggghts:13: expected a time step number, found `abc`"
        );
    }
}
