//! Responses a user declares for their own deck: where a number comes from (a column of
//! a table file, a regular expression over a log, a value in a JSON file), how a
//! series of them is reduced to one number over a window, and its unit.
//!
//! Table files are what DEM and CFD codes write for time series: LIGGGHTS `fix
//! ave/time` and `fix print` files (`#` comments, the last one naming the columns),
//! OpenFOAM `postProcessing` `.dat` files (tab-separated, `#` header), and CSV with a
//! header line. The first column is the time (or step) unless `time_column` says
//! otherwise; a window `from`/`to` is in that column's units.

use std::io::BufRead;
use std::path::Path;

use crate::{numbered_lines, open_in_run_dir, ParseError, Series};

/// How a series of values becomes one response.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reduction {
    /// The last value.
    Last,
    /// The arithmetic mean of the values.
    Mean,
    /// The smallest value.
    Min,
    /// The largest value.
    Max,
    /// Least-squares slope of value over time.
    Slope,
    /// Trapezoidal integral of value over time.
    Integral,
    /// Sample standard deviation (n − 1).
    Std,
}

impl Reduction {
    /// Every reduction with its name in study files.
    pub const ALL: [(&'static str, Reduction); 7] = [
        ("last", Reduction::Last),
        ("mean", Reduction::Mean),
        ("min", Reduction::Min),
        ("max", Reduction::Max),
        ("slope", Reduction::Slope),
        ("integral", Reduction::Integral),
        ("std", Reduction::Std),
    ];

    /// Its name in study files.
    pub fn name(self) -> &'static str {
        Reduction::ALL
            .iter()
            .find(|(_, r)| *r == self)
            .map_or("?", |(n, _)| n)
    }

    /// The reduction called `name`.
    pub fn from_name(name: &str) -> Option<Reduction> {
        Reduction::ALL
            .iter()
            .find(|(n, _)| *n == name)
            .map(|(_, r)| *r)
    }

    /// Applies the reduction to `(time, value)` points in time order; `None` when there
    /// are too few points (none; fewer than two for slope, integral and std).
    pub fn apply(self, points: &[(f64, f64)]) -> Option<f64> {
        let n = points.len();
        let values = || points.iter().map(|p| p.1);
        match self {
            Reduction::Last => points.last().map(|p| p.1),
            Reduction::Mean => (n > 0).then(|| values().sum::<f64>() / n as f64),
            Reduction::Min => values().reduce(f64::min),
            Reduction::Max => values().reduce(f64::max),
            Reduction::Slope => {
                if n < 2 {
                    return None;
                }
                let t_mean = points.iter().map(|p| p.0).sum::<f64>() / n as f64;
                let v_mean = values().sum::<f64>() / n as f64;
                let (mut sxy, mut sxx) = (0.0, 0.0);
                for &(t, v) in points {
                    sxy += (t - t_mean) * (v - v_mean);
                    sxx += (t - t_mean) * (t - t_mean);
                }
                (sxx > 0.0).then(|| sxy / sxx)
            }
            Reduction::Integral => (n >= 2).then(|| {
                points
                    .windows(2)
                    .map(|w| 0.5 * (w[0].1 + w[1].1) * (w[1].0 - w[0].0))
                    .sum()
            }),
            Reduction::Std => (n >= 2).then(|| {
                let mean = values().sum::<f64>() / n as f64;
                (values().map(|v| (v - mean) * (v - mean)).sum::<f64>() / (n - 1) as f64).sqrt()
            }),
        }
    }
}

/// A column of a table file: by its name in the header, or 1-based position.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Column {
    /// The header's name for it (`c_vmean`, `areaNormalIntegrate(U)`, `mass_kg`).
    Name(String),
    /// Its position, 1 = the first column.
    Index(usize),
}

/// Where a declared response's values come from.
#[derive(Debug, Clone)]
pub enum Source {
    /// A column of a whitespace- or comma-separated table file, against its time column.
    Table {
        /// The file, relative to the run directory.
        file: String,
        /// The value column.
        column: Column,
        /// The time column (default: the first).
        time_column: Column,
    },
    /// Every match of a regular expression's first group in a text file (the match
    /// number is the "time").
    Regex {
        /// The file, relative to the run directory.
        file: String,
        /// The expression; its first capture group is the number.
        pattern: regex::Regex,
    },
    /// A number, or an array of numbers, at a dotted key path of a JSON file
    /// (`results.flow.0`).
    Json {
        /// The file, relative to the run directory.
        file: String,
        /// The key path; array elements by index.
        key: String,
    },
}

impl std::fmt::Display for Source {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Source::Table { file, column, .. } => match column {
                Column::Name(name) => write!(f, "column `{name}` of {file}"),
                Column::Index(index) => write!(f, "column {index} of {file}"),
            },
            Source::Regex { file, pattern } => write!(f, "`{pattern}` in {file}"),
            Source::Json { file, key } => write!(f, "`{key}` of {file}"),
        }
    }
}

impl Source {
    /// A `Regex` source over `file`; the error says what is wrong with `pattern`
    /// (not an expression, or no group around the number).
    pub fn regex(file: String, pattern: &str) -> Result<Source, String> {
        let pattern =
            regex::Regex::new(pattern).map_err(|e| format!("not a regular expression: {e}"))?;
        if pattern.captures_len() < 2 {
            return Err("expected a group around the number, e.g. `Torque = (\\S+)`".to_string());
        }
        Ok(Source::Regex { file, pattern })
    }

    /// The file it reads, relative to the run directory.
    pub fn file(&self) -> &str {
        match self {
            Source::Table { file, .. } | Source::Regex { file, .. } | Source::Json { file, .. } => {
                file
            }
        }
    }
}

/// A response a study declares for its own deck.
#[derive(Debug, Clone)]
pub struct DeclaredResponse {
    /// Its name in the study and the store.
    pub name: String,
    /// Its unit, for tables and reports.
    pub unit: String,
    /// Where the values come from.
    pub source: Source,
    /// How they become one number.
    pub reduce: Reduction,
    /// Window start, in the time column's units (inclusive); `None` from the first row.
    pub from: Option<f64>,
    /// Window end (inclusive); `None` to the last row.
    pub to: Option<f64>,
}

impl DeclaredResponse {
    /// Reads the response from a finished run: its value, and its whole series.
    pub fn read(&self, run_dir: &Path) -> Result<(f64, Series), ParseError> {
        let (reader, path) =
            open_in_run_dir(run_dir, self.source.file()).map_err(|error| match error {
                ParseError::Read { path, source }
                    if source.kind() == std::io::ErrorKind::NotFound =>
                {
                    ParseError::Missing {
                        path,
                        what: format!(
                            "response `{}` is read from it; check that the deck writes {} (relative to the run directory)",
                            self.name,
                            self.source.file()
                        ),
                    }
                }
                other => other,
            })?;
        let points = match &self.source {
            Source::Table {
                column,
                time_column,
                ..
            } => read_table_column(reader, &path, column, time_column)?,
            Source::Regex { pattern, .. } => read_regex_matches(reader, &path, pattern)?,
            Source::Json { key, .. } => read_json_values(reader, &path, key)?,
        };
        let window: Vec<(f64, f64)> = points
            .iter()
            .copied()
            .filter(|(t, _)| self.from.is_none_or(|from| *t >= from))
            .filter(|(t, _)| self.to.is_none_or(|to| *t <= to))
            .collect();
        let value = self
            .reduce
            .apply(&window)
            .ok_or_else(|| ParseError::Unusable {
                path: path.clone(),
                message: format!(
                    "response `{}`: {} values in the window [{}, {}] of {} read, too few for `{}`",
                    self.name,
                    window.len(),
                    self.from.map_or("first".to_string(), |v| v.to_string()),
                    self.to.map_or("last".to_string(), |v| v.to_string()),
                    points.len(),
                    self.reduce.name()
                ),
            })?;
        Ok((
            value,
            Series {
                name: self.name.clone(),
                points,
            },
        ))
    }
}

/// Splits a table line into fields: on commas when it has any, else on white space.
fn fields(line: &str) -> Vec<&str> {
    if line.contains(',') {
        line.split(',').map(str::trim).collect()
    } else {
        line.split_whitespace().collect()
    }
}

/// `(time, value)` rows of a table file's two columns. Lines starting with `#` are
/// comments, the last one before the data naming the columns; a first line that is not
/// numbers is a header too.
pub fn read_table_column<R: BufRead>(
    reader: R,
    path: &Path,
    column: &Column,
    time_column: &Column,
) -> Result<Vec<(f64, f64)>, ParseError> {
    let mut header: Option<Vec<String>> = None;
    let mut indices: Option<(usize, usize)> = None;
    let mut points = Vec::new();
    for numbered in numbered_lines(reader, path) {
        let (number, line) = numbered?;
        let trimmed = line.trim();
        if trimmed.is_empty() {
            continue;
        }
        if let Some(comment) = trimmed.strip_prefix('#') {
            if indices.is_none() {
                header = Some(fields(comment).iter().map(|s| s.to_string()).collect());
            }
            continue;
        }
        let row = fields(trimmed);
        let numbers: Option<Vec<f64>> = row.iter().map(|f| f.parse().ok()).collect();
        let Some(numbers) = numbers else {
            if indices.is_none() && points.is_empty() {
                header = Some(row.iter().map(|s| s.to_string()).collect());
                continue;
            }
            return Err(ParseError::malformed(
                path,
                number,
                format!("expected numbers, found `{trimmed}`"),
            ));
        };
        let (t, v) = match indices {
            Some(found) => found,
            None => {
                let locate = |wanted: &Column| {
                    position(wanted, header.as_deref(), numbers.len())
                        .map_err(|message| ParseError::malformed(path, number, message))
                };
                let found = (locate(time_column)?, locate(column)?);
                indices = Some(found);
                found
            }
        };
        let (Some(time), Some(value)) = (numbers.get(t), numbers.get(v)) else {
            return Err(ParseError::malformed(
                path,
                number,
                format!(
                    "expected at least {} columns, found {}",
                    t.max(v) + 1,
                    numbers.len()
                ),
            ));
        };
        if !(time.is_finite() && value.is_finite()) {
            return Err(ParseError::malformed(
                path,
                number,
                format!("expected finite numbers, found `{trimmed}`"),
            ));
        }
        points.push((*time, *value));
    }
    Ok(points)
}

/// The 0-based position of `column` in a row of `width` numbers under `header`.
fn position(column: &Column, header: Option<&[String]>, width: usize) -> Result<usize, String> {
    match column {
        Column::Index(index) if (1..=width).contains(index) => Ok(index - 1),
        Column::Index(index) => Err(format!(
            "column {index} asked for, but the rows have {width} columns"
        )),
        Column::Name(name) => {
            let Some(header) = header else {
                return Err(format!(
                    "column `{name}` asked for, but the file has no header line naming its columns; give the column's number instead"
                ));
            };
            // A `# TimeStep c_a c_b` header names every column; a header with one more
            // word than the rows (`# Time  p  U`, a leading label) is aligned to the right.
            let offset = header.len().saturating_sub(width);
            header
                .iter()
                .skip(offset)
                .position(|h| h == name)
                .ok_or_else(|| {
                    format!(
                        "no column `{name}`; the header names: {}",
                        header[offset..].join(", ")
                    )
                })
        }
    }
}

/// Every match of `pattern`'s first group, numbered from 1 as its "time".
pub fn read_regex_matches<R: BufRead>(
    reader: R,
    path: &Path,
    pattern: &regex::Regex,
) -> Result<Vec<(f64, f64)>, ParseError> {
    let mut points = Vec::new();
    for numbered in numbered_lines(reader, path) {
        let (number, line) = numbered?;
        for captures in pattern.captures_iter(&line) {
            let Some(text) = captures.get(1) else {
                continue;
            };
            let value: f64 = text.as_str().parse().map_err(|_| {
                ParseError::malformed(
                    path,
                    number,
                    format!(
                        "`{}` matched `{}`, which is not a number",
                        pattern,
                        text.as_str()
                    ),
                )
            })?;
            points.push(((points.len() + 1) as f64, value));
        }
    }
    Ok(points)
}

/// The number, or array of numbers (index as "time"), at `key` of a JSON file.
pub fn read_json_values<R: BufRead>(
    reader: R,
    path: &Path,
    key: &str,
) -> Result<Vec<(f64, f64)>, ParseError> {
    let document: serde_json::Value = serde_json::from_reader(reader)
        .map_err(|e| ParseError::malformed(path, e.line(), format!("not JSON: {e}")))?;
    let mut value = &document;
    for part in key.split('.').filter(|p| !p.is_empty()) {
        let next = match value {
            serde_json::Value::Array(items) => {
                part.parse::<usize>().ok().and_then(|i| items.get(i))
            }
            other => other.get(part),
        };
        value = next.ok_or_else(|| ParseError::Unusable {
            path: path.to_path_buf(),
            message: format!("no `{part}` on the way to key `{key}`"),
        })?;
    }
    let number = |v: &serde_json::Value| {
        v.as_f64().ok_or_else(|| ParseError::Unusable {
            path: path.to_path_buf(),
            message: format!("`{key}` holds {v}, not a number"),
        })
    };
    match value {
        serde_json::Value::Array(items) => items
            .iter()
            .enumerate()
            .map(|(i, v)| Ok((i as f64, number(v)?)))
            .collect(),
        single => Ok(vec![(0.0, number(single)?)]),
    }
}

#[cfg(test)]
mod tests {
    use std::io::Cursor;

    use super::*;

    const AVE_TIME: &str = "# Time-averaged data for fix ave\n# TimeStep c_vmean c_ke\n1000 0.5 2\n2000 1.5 4\n3000 2.5 6\n";
    const OPENFOAM_DAT: &str = "# Region type : patch bottom\n# Faces       : 256\n# Time        \tsum(phi)\n0.01\t-1e-4\n0.02\t-3e-4\n";
    const CSV: &str = "time,mass_kg,count\n0.1,1.0,10\n0.2,2.0,20\n0.4,4.0,40\n";

    fn table(text: &str, column: Column) -> Result<Vec<(f64, f64)>, ParseError> {
        read_table_column(
            Cursor::new(text),
            Path::new("t.txt"),
            &column,
            &Column::Index(1),
        )
    }

    #[test]
    fn liggghts_ave_time_columns_are_found_by_name() {
        let points = table(AVE_TIME, Column::Name("c_ke".into())).unwrap();
        assert_eq!(points, [(1000.0, 2.0), (2000.0, 4.0), (3000.0, 6.0)]);
    }

    #[test]
    fn openfoam_dat_and_csv_headers_name_their_columns() {
        let points = table(OPENFOAM_DAT, Column::Name("sum(phi)".into())).unwrap();
        assert_eq!(points, [(0.01, -1e-4), (0.02, -3e-4)]);
        let points = table(CSV, Column::Name("count".into())).unwrap();
        assert_eq!(points, [(0.1, 10.0), (0.2, 20.0), (0.4, 40.0)]);
        assert_eq!(table(CSV, Column::Index(2)).unwrap()[2], (0.4, 4.0));
    }

    #[test]
    fn unknown_columns_and_bad_rows_name_the_file_line_and_header() {
        let error = table(AVE_TIME, Column::Name("c_v".into()))
            .unwrap_err()
            .to_string();
        assert_eq!(
            error,
            "t.txt:3: no column `c_v`; the header names: TimeStep, c_vmean, c_ke"
        );
        let error = table("1 2\n3 x\n", Column::Index(2))
            .unwrap_err()
            .to_string();
        assert_eq!(error, "t.txt:2: expected numbers, found `3 x`");
        let error = table("1 2\n", Column::Index(3)).unwrap_err().to_string();
        assert_eq!(
            error,
            "t.txt:1: column 3 asked for, but the rows have 2 columns"
        );
        let error = table("1 2\n", Column::Name("a".into()))
            .unwrap_err()
            .to_string();
        assert!(error.contains("no header line"), "{error}");
    }

    #[test]
    fn reductions_match_hand_computed_values() {
        let points = [(0.0, 1.0), (1.0, 3.0), (2.0, 5.0), (4.0, 9.0)];
        let r = |reduction: Reduction| reduction.apply(&points).unwrap();
        assert_eq!(r(Reduction::Last), 9.0);
        assert_eq!(r(Reduction::Mean), 4.5);
        assert_eq!(r(Reduction::Min), 1.0);
        assert_eq!(r(Reduction::Max), 9.0);
        assert!((r(Reduction::Slope) - 2.0).abs() < 1e-12, "v = 1 + 2 t");
        // ∫0^4 (1 + 2t) dt = 4 + 16 = 20, exact for a line.
        assert!((r(Reduction::Integral) - 20.0).abs() < 1e-12);
        // values 1, 3, 5, 9: mean 4.5, squares 12.25 + 2.25 + 0.25 + 20.25 = 35 over 3.
        assert!((r(Reduction::Std) - (35.0f64 / 3.0).sqrt()).abs() < 1e-12);
        assert_eq!(Reduction::Slope.apply(&points[..1]), None);
        assert_eq!(Reduction::Mean.apply(&[]), None);
    }

    #[test]
    fn regex_matches_become_a_numbered_series() {
        let log = "step 1\nTorque = 0.5 N m\nTorque = 1.5 N m\nLoop time of 2.0 on 1 procs\n";
        let pattern = regex::Regex::new(r"Torque = (\S+)").unwrap();
        let points = read_regex_matches(Cursor::new(log), Path::new("log"), &pattern).unwrap();
        assert_eq!(points, [(1.0, 0.5), (2.0, 1.5)]);
        let pattern = regex::Regex::new(r"step (\w+)").unwrap();
        let bad = read_regex_matches(Cursor::new("step x\n"), Path::new("log"), &pattern);
        assert_eq!(
            bad.unwrap_err().to_string(),
            "log:1: `step (\\w+)` matched `x`, which is not a number"
        );
    }

    #[test]
    fn json_values_are_found_by_key_path() {
        let json = r#"{"flow": {"rate": 0.25, "history": [1, 2, 4]}}"#;
        let read = |key: &str| read_json_values(Cursor::new(json), Path::new("r.json"), key);
        assert_eq!(read("flow.rate").unwrap(), [(0.0, 0.25)]);
        assert_eq!(read("flow.history").unwrap()[2], (2.0, 4.0));
        assert_eq!(read("flow.history.1").unwrap(), [(0.0, 2.0)]);
        assert_eq!(
            read("flow.speed").unwrap_err().to_string(),
            "r.json: no `speed` on the way to key `flow.speed`"
        );
    }

    #[test]
    fn a_declared_response_reduces_its_window_and_keeps_its_series() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(dir.path().join("post")).unwrap();
        std::fs::write(dir.path().join("post/v.txt"), AVE_TIME).unwrap();
        let response = DeclaredResponse {
            name: "mean_velocity".into(),
            unit: "m/s".into(),
            source: Source::Table {
                file: "post/v.txt".into(),
                column: Column::Name("c_vmean".into()),
                time_column: Column::Index(1),
            },
            reduce: Reduction::Mean,
            from: Some(2000.0),
            to: None,
        };
        let (value, series) = response.read(dir.path()).unwrap();
        assert_eq!(value, 2.0);
        assert_eq!(series.points.len(), 3);
        let missing = DeclaredResponse {
            source: Source::Table {
                file: "post/w.txt".into(),
                column: Column::Index(2),
                time_column: Column::Index(1),
            },
            ..response
        };
        let error = missing.read(dir.path()).unwrap_err().to_string();
        assert!(
            error.ends_with("post/w.txt is missing: response `mean_velocity` is read from it; check that the deck writes post/w.txt (relative to the run directory)"),
            "{error}"
        );
    }
}
