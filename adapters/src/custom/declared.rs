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
use std::path::{Path, PathBuf};

use super::vtk::{for_each_vtk_value, VtkField};
use crate::thin::{thinned_note, Thinned, MAX_SERIES_POINTS};
use crate::{in_run_dir, numbered_lines, open_in_run_dir, ParseError, Series};

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
    /// The first value.
    First,
    /// The sum of the values (a total over the cells or particles of a dump).
    Sum,
    /// How many values there are (particles, cells, matches).
    Count,
}

impl Reduction {
    /// Every reduction with its name in study files.
    pub const ALL: [(&'static str, Reduction); 10] = [
        ("last", Reduction::Last),
        ("mean", Reduction::Mean),
        ("min", Reduction::Min),
        ("max", Reduction::Max),
        ("slope", Reduction::Slope),
        ("integral", Reduction::Integral),
        ("std", Reduction::Std),
        ("first", Reduction::First),
        ("sum", Reduction::Sum),
        ("count", Reduction::Count),
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
        let mut running = Running::default();
        for &point in points {
            running.push(point);
        }
        running.value(self)
    }
}

/// One pass over a window's points with what every [`Reduction`] needs, so that a
/// series of any length is reduced without being held: counts, sums, extremes, the
/// trapezoidal integral, and the means and co-moments of time and value by Welford's
/// update (Welford 1962; for the co-moment, Pébay, Sandia report SAND2008-6212), which
/// stays accurate where `Σt² − n·t̄²` would cancel.
#[derive(Debug, Clone, Copy, Default)]
pub struct Running {
    n: usize,
    first: Option<f64>,
    last: Option<(f64, f64)>,
    sum: f64,
    min: Option<f64>,
    max: Option<f64>,
    integral: f64,
    mean_t: f64,
    mean_v: f64,
    m2_t: f64,
    m2_v: f64,
    co_tv: f64,
}

impl Running {
    /// Adds the next point (in time order).
    pub fn push(&mut self, (t, v): (f64, f64)) {
        if let Some((t0, v0)) = self.last {
            self.integral += 0.5 * (v0 + v) * (t - t0);
        }
        self.n += 1;
        let n = self.n as f64;
        let dt = t - self.mean_t;
        let dv = v - self.mean_v;
        self.mean_t += dt / n;
        self.mean_v += dv / n;
        self.m2_t += dt * (t - self.mean_t);
        self.m2_v += dv * (v - self.mean_v);
        self.co_tv += dt * (v - self.mean_v);
        self.sum += v;
        self.first.get_or_insert(v);
        self.min = Some(self.min.map_or(v, |m| m.min(v)));
        self.max = Some(self.max.map_or(v, |m| m.max(v)));
        self.last = Some((t, v));
    }

    /// Points pushed.
    pub fn count(&self) -> usize {
        self.n
    }

    /// The reduction's value, or `None` with too few points.
    pub fn value(&self, reduction: Reduction) -> Option<f64> {
        let n = self.n;
        match reduction {
            Reduction::Last => self.last.map(|p| p.1),
            Reduction::Mean => (n > 0).then(|| self.sum / n as f64),
            Reduction::Min => self.min,
            Reduction::Max => self.max,
            Reduction::Slope => (n >= 2 && self.m2_t > 0.0).then(|| self.co_tv / self.m2_t),
            Reduction::Integral => (n >= 2).then_some(self.integral),
            Reduction::Std => (n >= 2).then(|| (self.m2_v / (n - 1) as f64).sqrt()),
            Reduction::First => self.first,
            Reduction::Sum => (n > 0).then_some(self.sum),
            Reduction::Count => Some(n as f64),
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
    /// A point or cell field of a legacy VTK file (LIGGGHTS' `dump mesh/vtk` and
    /// `custom/vtk`), one value per point or cell (index as "time").
    Vtk {
        /// The file, relative to the run directory.
        file: String,
        /// Which field, where, and which component.
        field: VtkField,
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
            Source::Vtk { file, field } => write!(f, "field `{}` of {file}", field.name),
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
            Source::Table { file, .. }
            | Source::Regex { file, .. }
            | Source::Json { file, .. }
            | Source::Vtk { file, .. } => file,
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
    /// Which of the files a glob (`post/dump_*.txt`) matches are read.
    pub pick: Pick,
    /// The declared response that holds the half-width of this one's 95 % interval in
    /// each run, if any.
    pub interval: Option<String>,
}

/// Which files of a glob a response reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Pick {
    /// The last in natural order (`dump_900` before `dump_1000`): the latest step of
    /// numbered dumps (the default).
    #[default]
    Last,
    /// The one modified last.
    Newest,
    /// All of them, in natural order, as one series (an index-numbered source counts
    /// on across files).
    All,
}

impl Pick {
    /// Every pick with its name in study files.
    pub const ALL: [(&'static str, Pick); 3] = [
        ("last", Pick::Last),
        ("newest", Pick::Newest),
        ("all", Pick::All),
    ];

    /// The pick called `name`.
    pub fn from_name(name: &str) -> Option<Pick> {
        Pick::ALL.iter().find(|(n, _)| *n == name).map(|(_, p)| *p)
    }
}

/// True when `file` is a glob: it holds `*`, `?` or `[`.
pub fn is_glob(file: &str) -> bool {
    file.contains(['*', '?', '['])
}

/// Why `pattern` is not a glob orch can match (each `/`-separated part is matched
/// against names: `*`, `?`, `[…]`), or `None`.
pub fn glob_error(pattern: &str) -> Option<String> {
    pattern.split('/').find_map(|part| {
        glob::Pattern::new(part)
            .err()
            .map(|e| format!("`{part}` is not a glob: {e}"))
    })
}

/// `a` before `b` in natural order: runs of digits compare as numbers, so `dump_900`
/// comes before `dump_1000`.
fn natural_order(a: &str, b: &str) -> std::cmp::Ordering {
    let (mut a, mut b) = (a.as_bytes(), b.as_bytes());
    loop {
        match (a.first(), b.first()) {
            (None, None) => return std::cmp::Ordering::Equal,
            (None, _) => return std::cmp::Ordering::Less,
            (_, None) => return std::cmp::Ordering::Greater,
            (Some(x), Some(y)) if x.is_ascii_digit() && y.is_ascii_digit() => {
                let digits = |s: &[u8]| s.iter().take_while(|c| c.is_ascii_digit()).count();
                let (na, nb) = (digits(a), digits(b));
                let trim = |s: &[u8]| -> Vec<u8> {
                    let t: Vec<u8> = s.iter().copied().skip_while(|&c| c == b'0').collect();
                    t
                };
                let (da, db) = (trim(&a[..na]), trim(&b[..nb]));
                let order = da.len().cmp(&db.len()).then_with(|| da.cmp(&db));
                if order != std::cmp::Ordering::Equal {
                    return order;
                }
                a = &a[na..];
                b = &b[nb..];
            }
            (Some(x), Some(y)) if x != y => return x.cmp(y),
            _ => {
                a = &a[1..];
                b = &b[1..];
            }
        }
    }
}

/// The files of `run_dir` a glob `pattern` (relative, `*` `?` `[…]` within a name)
/// matches, relative to `run_dir`, in natural order.
fn glob_files(run_dir: &Path, pattern: &str) -> std::io::Result<Vec<String>> {
    let parts: Vec<&str> = pattern
        .split('/')
        .filter(|p| !p.is_empty() && *p != ".")
        .collect();
    let mut found = vec![String::new()];
    for (depth, part) in parts.iter().enumerate() {
        let last = depth + 1 == parts.len();
        let mut next = Vec::new();
        for prefix in &found {
            let dir = run_dir.join(prefix);
            let join = |name: &str| {
                if prefix.is_empty() {
                    name.to_string()
                } else {
                    format!("{prefix}/{name}")
                }
            };
            if !is_glob(part) {
                let path = dir.join(part);
                if (last && path.is_file()) || (!last && path.is_dir()) {
                    next.push(join(part));
                }
                continue;
            }
            let matcher = glob::Pattern::new(part)
                .map_err(|e| std::io::Error::new(std::io::ErrorKind::InvalidInput, e))?;
            let Ok(entries) = std::fs::read_dir(&dir) else {
                continue;
            };
            for entry in entries {
                let entry = entry?;
                let name = entry.file_name().to_string_lossy().into_owned();
                let kind = entry.file_type()?;
                let fits = if last { kind.is_file() } else { kind.is_dir() };
                if fits && matcher.matches(&name) {
                    next.push(join(&name));
                }
            }
        }
        found = next;
    }
    found.sort_by(|a, b| natural_order(a, b));
    Ok(found)
}

impl DeclaredResponse {
    /// The files the response reads, relative to `run_dir`: its file, or those of its
    /// glob that [`Pick`] chooses.
    fn files(&self, run_dir: &Path) -> Result<Vec<String>, ParseError> {
        let file = self.source.file();
        if !is_glob(file) {
            return Ok(vec![file.to_string()]);
        }
        let pattern_path = in_run_dir(run_dir, file);
        let mut matches = glob_files(run_dir, file).map_err(ParseError::read(&pattern_path))?;
        if matches.is_empty() {
            return Err(ParseError::Missing {
                path: pattern_path,
                what: format!(
                    "no file matches it; response `{}` is read from the files of {file} (relative to the run directory)",
                    self.name
                ),
            });
        }
        Ok(match self.pick {
            Pick::All => matches,
            Pick::Last => vec![matches.pop().expect("not empty")],
            Pick::Newest => {
                let modified = |f: &String| {
                    std::fs::metadata(run_dir.join(f))
                        .and_then(|m| m.modified())
                        .ok()
                };
                let newest = matches
                    .iter()
                    .max_by(|a, b| modified(a).cmp(&modified(b)).then(natural_order(a, b)))
                    .expect("not empty");
                vec![newest.clone()]
            }
        })
    }

    /// Reads the response from a finished run in one streaming pass: its value over the
    /// window from every point, and its series bounded to [`MAX_SERIES_POINTS`].
    pub fn read(&self, run_dir: &Path) -> Result<Read, ParseError> {
        let files = self.files(run_dir)?;
        let mut window = Running::default();
        let mut series = Thinned::new(MAX_SERIES_POINTS);
        // An index-numbered source (regex matches, JSON arrays) counts on across the
        // files of a glob; a table keeps its time column.
        let mut offset = 0.0;
        let mut path = PathBuf::new();
        for file in &files {
            let (reader, opened) = self.open(run_dir, file)?;
            path = opened;
            let mut count = 0.0_f64;
            let mut sink = |(t, v): (f64, f64)| {
                let t = match self.source {
                    Source::Table { .. } => t,
                    _ => t + offset,
                };
                count += 1.0;
                if self.from.is_none_or(|from| t >= from) && self.to.is_none_or(|to| t <= to) {
                    window.push((t, v));
                }
                series.push((t, v));
            };
            match &self.source {
                Source::Table {
                    column,
                    time_column,
                    ..
                } => for_each_table_row(reader, &path, column, time_column, &mut sink)?,
                Source::Regex { pattern, .. } => {
                    for_each_regex_match(reader, &path, pattern, &mut sink)?
                }
                Source::Json { key, .. } => for_each_json_value(reader, &path, key, &mut sink)?,
                Source::Vtk { field, .. } => for_each_vtk_value(reader, &path, field, &mut sink)?,
            }
            offset += count;
        }
        let value = window
            .value(self.reduce)
            .ok_or_else(|| ParseError::Unusable {
                path: path.clone(),
                message: format!(
                    "response `{}`: {} values in the window [{}, {}] of {} read, too few for `{}`",
                    self.name,
                    window.count(),
                    self.from.map_or("first".to_string(), |v| v.to_string()),
                    self.to.map_or("last".to_string(), |v| v.to_string()),
                    series.seen(),
                    self.reduce.name()
                ),
            })?;
        let (points, seen) = series.finish();
        let note = (seen > points.len()).then(|| thinned_note(&self.name, seen, points.len()));
        Ok(Read {
            value,
            series: Series {
                name: self.name.clone(),
                points,
            },
            note,
        })
    }
}

impl DeclaredResponse {
    /// Opens `file` of `run_dir`; a missing one says which response wanted it.
    fn open(
        &self,
        run_dir: &Path,
        file: &str,
    ) -> Result<(std::io::BufReader<std::fs::File>, PathBuf), ParseError> {
        open_in_run_dir(run_dir, file).map_err(|error| match error {
            ParseError::Read { path, source } if source.kind() == std::io::ErrorKind::NotFound => {
                ParseError::Missing {
                    path,
                    what: format!(
                        "response `{}` is read from it; check that the deck writes {file} (relative to the run directory)",
                        self.name
                    ),
                }
            }
            other => other,
        })
    }
}

/// What a declared response read from a finished run.
#[derive(Debug, Clone, PartialEq)]
pub struct Read {
    /// The reduced value.
    pub value: f64,
    /// Its series, bounded to [`MAX_SERIES_POINTS`] (+ the last point).
    pub series: Series,
    /// Why the series holds fewer points than were read, if it does.
    pub note: Option<String>,
}

/// Splits a table line into fields: on commas when it has any, else on white space.
fn fields(line: &str) -> Vec<&str> {
    if line.contains(',') {
        line.split(',').map(str::trim).collect()
    } else {
        line.split_whitespace().collect()
    }
}

/// [`for_each_table_row`]'s rows collected (for tests).
#[cfg(test)]
pub fn read_table_column<R: BufRead>(
    reader: R,
    path: &Path,
    column: &Column,
    time_column: &Column,
) -> Result<Vec<(f64, f64)>, ParseError> {
    let mut points = Vec::new();
    for_each_table_row(reader, path, column, time_column, &mut |p| points.push(p))?;
    Ok(points)
}

/// The `(time, value)` rows of a table file's two columns, each handed to `sink` as
/// it is read. Lines starting with `#` are comments, the last one before the data
/// naming the columns; a first line that is not numbers is a header too.
pub fn for_each_table_row<R: BufRead>(
    reader: R,
    path: &Path,
    column: &Column,
    time_column: &Column,
    sink: &mut dyn FnMut((f64, f64)),
) -> Result<(), ParseError> {
    let mut header: Option<Vec<String>> = None;
    let mut indices: Option<(usize, usize)> = None;
    let mut rows = 0_usize;
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
            if indices.is_none() && rows == 0 {
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
        sink((*time, *value));
        rows += 1;
    }
    Ok(())
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

/// [`for_each_regex_match`]'s matches collected (for tests).
#[cfg(test)]
pub fn read_regex_matches<R: BufRead>(
    reader: R,
    path: &Path,
    pattern: &regex::Regex,
) -> Result<Vec<(f64, f64)>, ParseError> {
    let mut points = Vec::new();
    for_each_regex_match(reader, path, pattern, &mut |p| points.push(p))?;
    Ok(points)
}

/// Every match of `pattern`'s first group, numbered from 1 as its "time", handed to
/// `sink` as it is found.
pub fn for_each_regex_match<R: BufRead>(
    reader: R,
    path: &Path,
    pattern: &regex::Regex,
    sink: &mut dyn FnMut((f64, f64)),
) -> Result<(), ParseError> {
    let mut matches = 0_usize;
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
            matches += 1;
            sink((matches as f64, value));
        }
    }
    Ok(())
}

/// [`for_each_json_value`]'s numbers collected (for tests).
#[cfg(test)]
pub fn read_json_values<R: BufRead>(
    reader: R,
    path: &Path,
    key: &str,
) -> Result<Vec<(f64, f64)>, ParseError> {
    let mut points = Vec::new();
    for_each_json_value(reader, path, key, &mut |p| points.push(p))?;
    Ok(points)
}

/// The number, or array of numbers (index as "time"), at `key` of a JSON file, in one
/// streaming pass: the document is not built in memory;
/// everything off the key's path is skipped, and the numbers at the key are handed to
/// `sink` one by one (a 100 MB array holds no more than one number at a time).
pub fn for_each_json_value<R: BufRead>(
    reader: R,
    path: &Path,
    key: &str,
    sink: &mut dyn FnMut((f64, f64)),
) -> Result<(), ParseError> {
    let parts: Vec<&str> = key.split('.').filter(|p| !p.is_empty()).collect();
    let mut miss = None;
    let mut deserializer = serde_json::Deserializer::from_reader(reader);
    let walked = serde::de::DeserializeSeed::deserialize(
        KeyPath {
            parts: &parts,
            key,
            sink,
            miss: &mut miss,
        },
        &mut deserializer,
    )
    .and_then(|()| deserializer.end());
    match (miss, walked) {
        (Some(message), _) => Err(ParseError::Unusable {
            path: path.to_path_buf(),
            message,
        }),
        (None, Err(e)) => Err(ParseError::malformed(
            path,
            e.line(),
            format!("not JSON: {e}"),
        )),
        (None, Ok(())) => Ok(()),
    }
}

/// The walk down a JSON document to `parts` (object keys, array indices), skipping
/// everything else; a step that is not there sets `miss` and stops the walk.
struct KeyPath<'a, 'k> {
    parts: &'a [&'k str],
    key: &'a str,
    sink: &'a mut dyn FnMut((f64, f64)),
    miss: &'a mut Option<String>,
}

impl KeyPath<'_, '_> {
    /// Stops the walk with `message` as the reason.
    fn stop<E: serde::de::Error>(self, message: String) -> E {
        *self.miss = Some(message);
        E::custom("stopped")
    }

    fn not_a_number<E: serde::de::Error>(self, what: &str) -> E {
        let message = format!("`{}` holds {what}, not a number", self.key);
        self.stop(message)
    }
}

impl<'de> serde::de::DeserializeSeed<'de> for KeyPath<'_, '_> {
    type Value = ();

    fn deserialize<D: serde::Deserializer<'de>>(self, deserializer: D) -> Result<(), D::Error> {
        deserializer.deserialize_any(self)
    }
}

impl<'de> serde::de::Visitor<'de> for KeyPath<'_, '_> {
    type Value = ();

    fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "a JSON value")
    }

    fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<(), E> {
        if let Some(part) = self.parts.first() {
            let message = format!("no `{part}` on the way to key `{}`", self.key);
            return Err(self.stop(message));
        }
        (self.sink)((0.0, v));
        Ok(())
    }

    fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<(), E> {
        self.visit_f64(v as f64)
    }

    fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<(), E> {
        self.visit_f64(v as f64)
    }

    fn visit_bool<E: serde::de::Error>(self, v: bool) -> Result<(), E> {
        self.visit_other(&v.to_string())
    }

    fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<(), E> {
        self.visit_other(&format!("{v:?}"))
    }

    fn visit_unit<E: serde::de::Error>(self) -> Result<(), E> {
        self.visit_other("null")
    }

    fn visit_map<A: serde::de::MapAccess<'de>>(self, mut map: A) -> Result<(), A::Error> {
        let Some((&part, rest)) = self.parts.split_first() else {
            return Err(self.not_a_number("an object"));
        };
        while let Some(name) = map.next_key::<std::borrow::Cow<'_, str>>()? {
            if name == part {
                map.next_value_seed(KeyPath {
                    parts: rest,
                    key: self.key,
                    sink: self.sink,
                    miss: self.miss,
                })?;
                while map
                    .next_entry::<serde::de::IgnoredAny, serde::de::IgnoredAny>()?
                    .is_some()
                {}
                return Ok(());
            }
            map.next_value::<serde::de::IgnoredAny>()?;
        }
        let message = format!("no `{part}` on the way to key `{}`", self.key);
        Err(self.stop(message))
    }

    fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<(), A::Error> {
        if let Some((&part, rest)) = self.parts.split_first() {
            let wanted = part.parse::<usize>().ok();
            let mut index = 0;
            loop {
                if Some(index) == wanted {
                    let seed = KeyPath {
                        parts: rest,
                        key: self.key,
                        sink: &mut *self.sink,
                        miss: &mut *self.miss,
                    };
                    if seq.next_element_seed(seed)?.is_none() {
                        break;
                    }
                    while seq.next_element::<serde::de::IgnoredAny>()?.is_some() {}
                    return Ok(());
                }
                if seq.next_element::<serde::de::IgnoredAny>()?.is_none() {
                    break;
                }
                index += 1;
            }
            let message = format!("no `{part}` on the way to key `{}`", self.key);
            return Err(self.stop(message));
        }
        let mut index = 0_usize;
        while let Some(element) = seq.next_element::<serde_json::Value>()? {
            let Some(v) = element.as_f64() else {
                return Err(self.not_a_number(&format!("{element} at index {index}")));
            };
            (self.sink)((index as f64, v));
            index += 1;
        }
        Ok(())
    }
}

impl KeyPath<'_, '_> {
    /// A scalar that is not a number: a miss if the path goes on, else not a number.
    fn visit_other<E: serde::de::Error>(self, what: &str) -> Result<(), E> {
        if let Some(part) = self.parts.first() {
            let message = format!("no `{part}` on the way to key `{}`", self.key);
            return Err(self.stop(message));
        }
        Err(self.not_a_number(what))
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
        assert_eq!(r(Reduction::First), 1.0);
        assert_eq!(r(Reduction::Sum), 18.0);
        assert_eq!(r(Reduction::Count), 4.0);
        assert_eq!(
            Reduction::Count.apply(&[]),
            Some(0.0),
            "no values is a count"
        );
        assert_eq!(Reduction::Sum.apply(&[]), None);
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
    fn json_walks_through_arrays_and_names_what_is_not_a_number() {
        let json =
            r#"{"runs": [{"v": [1, 2]}, {"v": [3, "x", 5]}], "skipped": {"deep": [[1], {}]}}"#;
        let read = |key: &str| read_json_values(Cursor::new(json), Path::new("r.json"), key);
        assert_eq!(read("runs.0.v").unwrap(), [(0.0, 1.0), (1.0, 2.0)]);
        assert_eq!(read("runs.1.v.2").unwrap(), [(0.0, 5.0)]);
        assert_eq!(
            read("runs.1.v").unwrap_err().to_string(),
            "r.json: `runs.1.v` holds \"x\" at index 1, not a number"
        );
        assert_eq!(
            read("runs.2").unwrap_err().to_string(),
            "r.json: no `2` on the way to key `runs.2`"
        );
        assert_eq!(
            read("runs").unwrap_err().to_string(),
            "r.json: `runs` holds {\"v\":[1,2]} at index 0, not a number"
        );
        let bad = read_json_values(Cursor::new("{\"a\": [1,\n 2,"), Path::new("r.json"), "a");
        assert!(
            bad.unwrap_err()
                .to_string()
                .starts_with("r.json:2: not JSON: "),
            "a syntax error names its line"
        );
    }

    #[test]
    fn a_response_of_millions_of_values_is_reduced_from_all_and_stores_a_bounded_series() {
        let dir = tempfile::tempdir().unwrap();
        let n = 2_000_000_usize;
        let mut json = String::with_capacity(16 * n);
        json.push_str("{\"flow\": [");
        for i in 0..n {
            if i > 0 {
                json.push(',');
            }
            json.push_str(&(i % 1000).to_string());
        }
        json.push_str("]}");
        std::fs::write(dir.path().join("r.json"), json).unwrap();
        let response = DeclaredResponse {
            name: "flow".into(),
            unit: "kg/s".into(),
            source: Source::Json {
                file: "r.json".into(),
                key: "flow".into(),
            },
            reduce: Reduction::Mean,
            from: None,
            to: None,
            pick: Pick::Last,
            interval: None,
        };
        let read = response.read(dir.path()).unwrap();
        assert_eq!(
            read.value, 499.5,
            "the mean of every value, not of the stored ones"
        );
        assert!(read.series.points.len() <= MAX_SERIES_POINTS + 1);
        assert_eq!(read.series.points.last(), Some(&((n - 1) as f64, 999.0)));
        let note = read.note.unwrap();
        assert!(
            note.starts_with("series `flow` had 2000000 points; "),
            "{note}"
        );
    }

    proptest::proptest! {
        #[test]
        fn the_one_pass_reductions_equal_the_two_pass_formulas(
            values in proptest::collection::vec(-1e3_f64..1e3, 2..200),
            t0 in -1e6_f64..1e6,
        ) {
            let points: Vec<(f64, f64)> = values
                .iter()
                .enumerate()
                .map(|(i, &v)| (t0 + 0.5 * i as f64, v))
                .collect();
            let n = points.len() as f64;
            let mean = values.iter().sum::<f64>() / n;
            let t_mean = points.iter().map(|p| p.0).sum::<f64>() / n;
            let (mut sxy, mut sxx, mut svv) = (0.0, 0.0, 0.0);
            for &(t, v) in &points {
                sxy += (t - t_mean) * (v - mean);
                sxx += (t - t_mean) * (t - t_mean);
                svv += (v - mean) * (v - mean);
            }
            let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * (1.0 + b.abs());
            let r = |reduction: Reduction| reduction.apply(&points).unwrap();
            proptest::prop_assert!(close(r(Reduction::Mean), mean));
            proptest::prop_assert!(close(r(Reduction::Slope), sxy / sxx));
            proptest::prop_assert!(close(r(Reduction::Std), (svv / (n - 1.0)).sqrt()));
        }
    }

    #[test]
    fn the_total_wear_of_the_newest_mesh_dump_is_a_sum_over_its_cells() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(dir.path().join("post")).unwrap();
        let mesh = |wear: [f64; 2]| {
            format!(
                "# vtk DataFile Version 5.1\nGenerated by LIGGGHTS\nASCII\nDATASET POLYDATA\nPOINTS 3 float\n0 0 0 1 0 0 0 1 0\nPOLYGONS 3 6\nOFFSETS vtktypeint64\n0 3 6\nCONNECTIVITY vtktypeint64\n0 1 2 0 1 2\nCELL_DATA 2\nFIELD FieldData 1\nwear 1 2 double\n{} {}\n",
                wear[0], wear[1]
            )
        };
        std::fs::write(dir.path().join("post/mesh_500.vtk"), mesh([1.0, 2.0])).unwrap();
        std::fs::write(dir.path().join("post/mesh_1000.vtk"), mesh([3.0, 4.5])).unwrap();
        let response = DeclaredResponse {
            name: "wear".into(),
            unit: "J".into(),
            source: Source::Vtk {
                file: "post/mesh_*.vtk".into(),
                field: VtkField {
                    name: "wear".into(),
                    at: Some(super::super::vtk::Attribute::Cell),
                    component: None,
                },
            },
            reduce: Reduction::Sum,
            from: None,
            to: None,
            pick: Pick::Last,
            interval: None,
        };
        assert_eq!(
            response.read(dir.path()).unwrap().value,
            7.5,
            "step 1000's cells"
        );
    }

    #[test]
    fn natural_order_puts_step_900_before_step_1000() {
        let mut names = vec![
            "dump_1000.txt",
            "dump_900.txt",
            "dump_0100.txt",
            "dump_a.txt",
        ];
        names.sort_by(|a, b| natural_order(a, b));
        assert_eq!(
            names,
            [
                "dump_0100.txt",
                "dump_900.txt",
                "dump_1000.txt",
                "dump_a.txt"
            ]
        );
    }

    #[test]
    fn a_glob_reads_the_last_the_newest_or_all_of_its_files() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(dir.path().join("post/a")).unwrap();
        for (step, total) in [(900, 1.0), (1000, 2.0), (200, 3.0)] {
            std::fs::write(
                dir.path().join(format!("post/wear_{step}.txt")),
                format!("total = {total}\ntotal = {}\n", total * 10.0),
            )
            .unwrap();
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
        std::fs::write(dir.path().join("post/a/ignored.txt"), "total = 99\n").unwrap();
        let response = |pick: Pick, reduce: Reduction| DeclaredResponse {
            name: "wear".into(),
            unit: "J".into(),
            source: Source::regex("post/wear_*.txt".into(), r"total = (\S+)").unwrap(),
            reduce,
            from: None,
            to: None,
            pick,
            interval: None,
        };
        let read = |pick, reduce| response(pick, reduce).read(dir.path()).unwrap();
        // The last in natural order is step 1000; the newest written is step 200.
        assert_eq!(read(Pick::Last, Reduction::Sum).value, 22.0);
        assert_eq!(read(Pick::Newest, Reduction::Sum).value, 33.0);
        let all = read(Pick::All, Reduction::Count);
        assert_eq!(all.value, 6.0);
        // The match numbers count on across the files, in natural order.
        assert_eq!(
            all.series.points,
            [
                (1.0, 3.0),
                (2.0, 30.0),
                (3.0, 1.0),
                (4.0, 10.0),
                (5.0, 2.0),
                (6.0, 20.0)
            ]
        );
        let none = DeclaredResponse {
            source: Source::regex("post/none_*.txt".into(), r"total = (\S+)").unwrap(),
            ..response(Pick::Last, Reduction::Sum)
        };
        let error = none.read(dir.path()).unwrap_err().to_string();
        assert!(
            error.contains("post/none_*.txt is missing: no file matches it"),
            "{error}"
        );
        assert_eq!(
            glob_error("post/[a.txt").map(|e| e.starts_with("`[a.txt` is not a glob")),
            Some(true)
        );
        assert_eq!(glob_error("post/*.txt"), None);
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
            pick: Pick::Last,
            interval: None,
        };
        let read = response.read(dir.path()).unwrap();
        assert_eq!(read.value, 2.0);
        assert_eq!(read.series.points.len(), 3);
        assert_eq!(read.note, None);
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
