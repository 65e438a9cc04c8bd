//! Readers for OpenFOAM function-object output (`postProcessing/<name>/<startTime>/`).
//!
//! Both formats are text with `#` header lines, then one row per time step:
//!
//! ```text
//! # Time          sum(phi)                      <- surfaceFieldValue.dat
//! 0.00012         2.26474106e-06
//! # Probe 0 (0.02 0 -0.05)                      <- probes/<startTime>/U
//! #          Time
//!         0.00012  (-3.65e-05 4.51e-06 6.08e-05)  (4.51e-06 -3.65e-05 6.08e-05)
//! ```
//!
//! A restarted run starts a new `<startTime>` directory; [`read_time_series_dirs`]
//! joins them in time order.

use std::io::BufRead;
use std::path::{Path, PathBuf};

use crate::{numbered_lines, ParseError};

/// A `#`-commented file: its header lines and its data rows as `(1-based line, text)`,
/// both trimmed; an error when it has no data row.
struct Commented {
    header: Vec<String>,
    rows: Vec<(usize, String)>,
}

fn read_commented<R: BufRead>(reader: R, path: &Path) -> Result<Commented, ParseError> {
    let mut file = Commented {
        header: Vec::new(),
        rows: Vec::new(),
    };
    for numbered in numbered_lines(reader, path) {
        let (number, line) = numbered?;
        let trimmed = line.trim();
        if trimmed.starts_with('#') {
            file.header.push(trimmed.to_string());
        } else if !trimmed.is_empty() {
            file.rows.push((number, trimmed.to_string()));
        }
    }
    if file.rows.is_empty() {
        return Err(ParseError::malformed(
            path,
            file.header.len().max(1),
            "no data rows after the header: the solver wrote no time step",
        ));
    }
    Ok(file)
}

fn number(path: &Path, line: usize, text: &str, what: &str) -> Result<f64, ParseError> {
    text.parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| {
            ParseError::malformed(
                path,
                line,
                format!("expected {what} (a finite number), found `{text}`"),
            )
        })
}

/// Reads a `surfaceFieldValue.dat` of one field: `(time s, value)` rows.
pub fn read_surface_field_value<R: BufRead>(
    reader: R,
    path: &Path,
) -> Result<Vec<(f64, f64)>, ParseError> {
    read_commented(reader, path)?
        .rows
        .into_iter()
        .map(|(line, text)| {
            let fields: Vec<&str> = text.split_whitespace().collect();
            if fields.len() != 2 {
                return Err(ParseError::malformed(
                    path,
                    line,
                    format!("expected `time value`, found `{text}`"),
                ));
            }
            Ok((
                number(path, line, fields[0], "the time")?,
                number(path, line, fields[1], "the value")?,
            ))
        })
        .collect()
}

/// Rows of a vector probes file: time (s) and one vector per probe.
pub type ProbeRows = Vec<(f64, Vec<[f64; 3]>)>;

/// The probe positions of a `probes` file, from its `# Probe k (x y z)` header lines,
/// in probe order.
pub fn read_probe_positions<R: BufRead>(
    reader: R,
    path: &Path,
) -> Result<Vec<[f64; 3]>, ParseError> {
    let mut positions = Vec::new();
    for numbered in numbered_lines(reader, path) {
        let (line, text) = numbered?;
        let Some(rest) = text.trim().strip_prefix("# Probe ") else {
            continue;
        };
        let inside = rest
            .split_once('(')
            .and_then(|(_, after)| after.split_once(')'))
            .map(|(inside, _)| inside)
            .ok_or_else(|| {
                ParseError::malformed(
                    path,
                    line,
                    format!("expected `# Probe k (x y z)`, found `{text}`"),
                )
            })?;
        let parts: Vec<&str> = inside.split_whitespace().collect();
        if parts.len() != 3 {
            return Err(ParseError::malformed(
                path,
                line,
                format!("expected a position `(x y z)`, found `({inside})`"),
            ));
        }
        let mut p = [0.0; 3];
        for (slot, part) in p.iter_mut().zip(parts) {
            *slot = number(path, line, part, "a probe coordinate")?;
        }
        positions.push(p);
    }
    if positions.is_empty() {
        return Err(ParseError::malformed(
            path,
            1,
            "no `# Probe k (x y z)` header lines: not a probes file",
        ));
    }
    Ok(positions)
}

/// Reads a vector probes file: per row the time and one `(x y z)` per probe, as many
/// as its `# Probe k (...)` header lines announce.
pub fn read_probes<R: BufRead>(reader: R, path: &Path) -> Result<ProbeRows, ParseError> {
    let Commented { header, rows } = read_commented(reader, path)?;
    let probes = header.iter().filter(|l| l.starts_with("# Probe ")).count();
    if probes == 0 {
        return Err(ParseError::malformed(
            path,
            1,
            "no `# Probe k (x y z)` header lines: not a probes file",
        ));
    }
    rows.into_iter()
        .map(|(line, row)| {
            let (time, rest) = row.split_once(char::is_whitespace).unwrap_or((&row, ""));
            let time = number(path, line, time, "the time")?;
            let mut vectors = Vec::with_capacity(probes);
            let mut rest = rest.trim();
            while let Some(open) = rest.strip_prefix('(') {
                let Some((inside, after)) = open.split_once(')') else {
                    return Err(ParseError::malformed(path, line, format!("a vector is not closed in `{row}`")));
                };
                let parts: Vec<&str> = inside.split_whitespace().collect();
                if parts.len() != 3 {
                    return Err(ParseError::malformed(
                        path,
                        line,
                        format!("expected a vector `(x y z)`, found `({inside})`"),
                    ));
                }
                let mut v = [0.0; 3];
                for (slot, part) in v.iter_mut().zip(parts) {
                    *slot = number(path, line, part, "a vector component")?;
                }
                vectors.push(v);
                rest = after.trim_start();
            }
            if vectors.len() != probes || !rest.is_empty() {
                return Err(ParseError::malformed(
                    path,
                    line,
                    format!(
                        "expected {probes} vectors after the time, found {} (the row is cut or malformed)",
                        vectors.len()
                    ),
                ));
            }
            Ok((time, vectors))
        })
        .collect()
}

/// Reads `<dir>/<startTime>/<file>` for every start time, in time order, and joins the
/// rows: a later start time's rows replace the earlier ones from that time on.
pub fn read_time_series_dirs<T>(
    dir: &Path,
    file: &str,
    read: impl Fn(std::io::BufReader<std::fs::File>, &Path) -> Result<Vec<(f64, T)>, ParseError>,
) -> Result<Vec<(f64, T)>, ParseError> {
    let entries = std::fs::read_dir(dir).map_err(ParseError::read(dir))?;
    let mut starts: Vec<(f64, PathBuf)> = entries
        .filter_map(|e| e.ok())
        .filter_map(|e| {
            let start = e.file_name().to_str()?.parse::<f64>().ok()?;
            Some((start, e.path()))
        })
        .collect();
    if starts.is_empty() {
        return Err(ParseError::malformed(
            dir,
            0,
            "no <startTime> directory: the function object wrote nothing",
        ));
    }
    starts.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut rows: Vec<(f64, T)> = Vec::new();
    for (start, start_dir) in starts {
        let path = start_dir.join(file);
        let reader = std::fs::File::open(&path)
            .map(std::io::BufReader::new)
            .map_err(ParseError::read(&path))?;
        rows.retain(|(t, _)| *t < start);
        rows.extend(read(reader, &path)?);
    }
    Ok(rows)
}
