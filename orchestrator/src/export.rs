//! `orch export`: a study's runs as one table, for spreadsheets, pandas or R.
//!
//! One row per job: its round, purpose (`design` or `test`), point, replicate, seed
//! and state, then every factor and every stored response as a named column whose
//! header carries the unit (`outlet_diameter [m]`). Written as CSV (RFC 4180: CRLF
//! line ends, fields with a comma, quote or line break quoted, quotes doubled) or as
//! JSON (an array of objects keyed by the same headers). `--series` writes the time
//! series in long form instead: one row per `(job, series, t, value)`.

use std::collections::{BTreeMap, BTreeSet, HashMap};

use serde_json::{Map, Value};

use crate::store::{Store, StoreError, StudyRow};
use crate::study::Study;

/// One cell of an exported table.
#[derive(Debug, Clone, PartialEq)]
pub enum Cell {
    /// Text, quoted in CSV when it must be.
    Text(String),
    /// A whole number.
    Int(i64),
    /// A real number, written with all its digits (shortest round-trip form).
    Real(f64),
    /// No value (a job without that response): empty in CSV, `null` in JSON.
    Empty,
}

/// A table: headers and rows of cells, each row as long as the headers.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    /// Column headers, units in brackets where a column has one.
    pub headers: Vec<String>,
    /// The rows.
    pub rows: Vec<Vec<Cell>>,
}

/// The output format of `orch export`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    /// Comma-separated values, RFC 4180.
    Csv,
    /// A JSON array of objects.
    Json,
}

/// `name [unit]`, or `name` alone when the unit is unknown or empty.
pub fn header(name: &str, unit: Option<&str>) -> String {
    match unit {
        Some(unit) if !unit.is_empty() => format!("{name} [{unit}]"),
        _ => name.to_string(),
    }
}

/// The unit of a response or series: what the study's equipment or stages declare,
/// or the solver's own figures (loop time, s; throughput, particle-steps per s).
pub fn unit_of(study: Option<&Study>, name: &str) -> Option<String> {
    use orch_adapters::simulation::{SOLVER_LOOP_TIME, SOLVER_THROUGHPUT};
    match name {
        SOLVER_LOOP_TIME => return Some("s".into()),
        SOLVER_THROUGHPUT => return Some("1/s".into()),
        _ => {}
    }
    let study = study?;
    if let Some(unit) = study.response_unit(name) {
        return Some(unit.to_string());
    }
    study
        .simulation
        .series()
        .iter()
        .find(|s| s.name == name)
        .map(|s| s.unit.to_string())
}

/// The abscissa of series `name` with its unit, as the study's equipment (or deck)
/// declares it: `t [s]` for a time series, and for any series it does not declare.
pub fn abscissa_of(study: Option<&Study>, name: &str) -> String {
    study
        .and_then(|s| {
            s.simulation
                .series()
                .iter()
                .find(|spec| spec.name == name)
                .map(|spec| spec.over.to_string())
        })
        .unwrap_or_else(|| orch_adapters::equipment::TIME_AXIS.to_string())
}

impl Table {
    /// The table as CSV text (RFC 4180).
    pub fn to_csv(&self) -> String {
        let mut out = String::new();
        let line = |cells: Vec<String>, out: &mut String| {
            let quoted: Vec<String> = cells.iter().map(|c| csv_field(c)).collect();
            out.push_str(&quoted.join(","));
            out.push_str("\r\n");
        };
        line(self.headers.clone(), &mut out);
        for row in &self.rows {
            line(row.iter().map(cell_text).collect(), &mut out);
        }
        out
    }

    /// The table as a JSON array of objects keyed by header, in column order.
    pub fn to_json(&self) -> Value {
        let rows = self
            .rows
            .iter()
            .map(|row| {
                let object: Map<String, Value> = self
                    .headers
                    .iter()
                    .zip(row)
                    .map(|(h, c)| (h.clone(), cell_json(c)))
                    .collect();
                Value::Object(object)
            })
            .collect();
        Value::Array(rows)
    }

    /// The table in `format`, ending with a line break.
    pub fn render(&self, format: Format) -> String {
        match format {
            Format::Csv => self.to_csv(),
            Format::Json => {
                let mut text =
                    serde_json::to_string_pretty(&self.to_json()).expect("JSON of plain values");
                text.push('\n');
                text
            }
        }
    }
}

/// One CSV field, quoted when it holds a comma, a quote or a line break.
fn csv_field(text: &str) -> String {
    if text.contains([',', '"', '\r', '\n']) {
        format!("\"{}\"", text.replace('"', "\"\""))
    } else {
        text.to_string()
    }
}

fn cell_text(cell: &Cell) -> String {
    match cell {
        Cell::Text(s) => s.clone(),
        Cell::Int(i) => i.to_string(),
        Cell::Real(v) if v.is_finite() => format!("{v:?}"),
        Cell::Real(v) => v.to_string(),
        Cell::Empty => String::new(),
    }
}

fn cell_json(cell: &Cell) -> Value {
    match cell {
        Cell::Text(s) => Value::String(s.clone()),
        Cell::Int(i) => Value::from(*i),
        Cell::Real(v) => serde_json::Number::from_f64(*v)
            .map(Value::Number)
            .unwrap_or(Value::Null),
        Cell::Empty => Value::Null,
    }
}

/// Response names in the order the study declares them, then any other stored ones
/// alphabetically.
fn response_order(study: Option<&Study>, stored: &BTreeSet<String>) -> Vec<String> {
    let mut names: Vec<String> = study
        .map(|s| s.known_responses())
        .unwrap_or_default()
        .into_iter()
        .filter(|n| stored.contains(*n))
        .map(str::to_string)
        .collect();
    for name in stored {
        if !names.contains(name) {
            names.push(name.clone());
        }
    }
    names
}

/// One row per job of the study: identity, factors and responses.
pub async fn runs_table(
    store: &Store,
    row: &StudyRow,
    study: Option<&Study>,
) -> Result<Table, StoreError> {
    let factors = store.factors(row.id).await?;
    let points: HashMap<i64, _> = store
        .points(row.id)
        .await?
        .into_iter()
        .map(|p| (p.id, p))
        .collect();
    let responses = store.responses(row.id).await?;
    let stored: BTreeSet<String> = responses.values().flat_map(|r| r.keys().cloned()).collect();
    let names = response_order(study, &stored);
    let mut headers: Vec<String> = [
        "job",
        "stage",
        "round",
        "purpose",
        "point",
        "replicate",
        "seed",
        "state",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    headers.extend(factors.iter().map(|f| header(&f.name, Some(&f.unit))));
    headers.extend(
        names
            .iter()
            .map(|n| header(n, unit_of(study, n).as_deref())),
    );
    let empty = BTreeMap::new();
    let mut rows = Vec::new();
    for job in store.jobs(row.id).await? {
        let point = &points[&job.point_id];
        let values = responses.get(&job.id).unwrap_or(&empty);
        let mut cells = vec![
            Cell::Text(job.name.clone()),
            Cell::Text(job.stage.clone()),
            Cell::Int(point.round),
            Cell::Text(point.purpose.clone()),
            Cell::Int(point.idx),
            Cell::Int(job.replicate),
            Cell::Int(job.seed),
            Cell::Text(job.state.to_string()),
        ];
        cells.extend(point.natural.iter().map(|v| Cell::Real(*v)));
        cells.extend(
            names
                .iter()
                .map(|n| values.get(n).map(|v| Cell::Real(*v)).unwrap_or(Cell::Empty)),
        );
        rows.push(cells);
    }
    Ok(Table { headers, rows })
}

/// Every series of every job in long form: `job, series, unit, over, x, value`, where
/// `over` names the abscissa with its unit (`t [s]`, or `r [m]` for a radial density).
pub async fn series_table(
    store: &Store,
    row: &StudyRow,
    study: Option<&Study>,
) -> Result<Table, StoreError> {
    let names: HashMap<i64, String> = store
        .jobs(row.id)
        .await?
        .into_iter()
        .map(|j| (j.id, j.name))
        .collect();
    let mut units: HashMap<String, (Cell, Cell)> = HashMap::new();
    let rows = store
        .study_series(row.id)
        .await?
        .into_iter()
        .map(|(job_id, series, t, value)| {
            let (unit, over) = units
                .entry(series.clone())
                .or_insert_with(|| {
                    (
                        unit_of(study, &series)
                            .map(Cell::Text)
                            .unwrap_or(Cell::Empty),
                        Cell::Text(abscissa_of(study, &series)),
                    )
                })
                .clone();
            vec![
                Cell::Text(names.get(&job_id).cloned().unwrap_or_default()),
                Cell::Text(series),
                unit,
                over,
                Cell::Real(t),
                Cell::Real(value),
            ]
        })
        .collect();
    Ok(Table {
        headers: ["job", "series", "unit", "over", "x", "value"]
            .iter()
            .map(|s| s.to_string())
            .collect(),
        rows,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table() -> Table {
        Table {
            headers: vec!["job".into(), "x [m]".into(), "note".into()],
            rows: vec![
                vec![Cell::Text("p000r0".into()), Cell::Real(0.02), Cell::Empty],
                vec![
                    Cell::Text("p001r0".into()),
                    Cell::Real(1e-7),
                    Cell::Text("a, \"quoted\"\nline".into()),
                ],
            ],
        }
    }

    #[test]
    fn csv_quotes_fields_with_commas_quotes_and_line_breaks_as_rfc_4180_says() {
        assert_eq!(
            table().to_csv(),
            "job,x [m],note\r\np000r0,0.02,\r\np001r0,1e-7,\"a, \"\"quoted\"\"\nline\"\r\n"
        );
    }

    #[test]
    fn json_is_an_array_of_objects_with_null_for_missing_values() {
        let json = table().to_json();
        assert_eq!(json[0]["x [m]"], 0.02);
        assert_eq!(json[0]["note"], Value::Null);
        assert_eq!(json[1]["note"], "a, \"quoted\"\nline");
        assert_eq!(json.as_array().unwrap().len(), 2);
    }

    #[test]
    fn headers_carry_units_only_when_there_is_one() {
        assert_eq!(header("outlet_diameter", Some("m")), "outlet_diameter [m]");
        assert_eq!(header("count", Some("")), "count");
        assert_eq!(header("other", None), "other");
    }

    #[test]
    fn reals_keep_every_digit() {
        let v = 0.1 + 0.2;
        let text = cell_text(&Cell::Real(v));
        assert_eq!(text.parse::<f64>().unwrap().to_bits(), v.to_bits());
    }
}
