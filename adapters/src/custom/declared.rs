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
mod tests;
