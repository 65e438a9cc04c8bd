//! `orch export`: a study's runs as one table, for spreadsheets, pandas or R.
//!
//! One row per job: its round, purpose (`design` or `test`), point, replicate, seed,
//! state, run identity and the run it reused (`study/job`, empty when it ran), then every factor and every stored response as a named column whose
//! header carries the unit (`outlet_diameter [m]`). Written as CSV (RFC 4180: CRLF
//! line ends, fields with a comma, quote or line break quoted, quotes doubled) or as
//! JSON (an array of objects keyed by the same headers). `--series` writes the time
//! series in long form instead: one row per `(job, series, t, value)`.

use std::collections::{BTreeSet, HashMap};
use std::io::{self, Write};

use orch_page::numbers::header;
use serde_json::{Map, Value};

use crate::store::{JobPage, JobPages, ResponseValues, SeriesPages, Store, StoreError, StudyRow};
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

/// `value` to 15 significant digits, written shortest: a design value computed from
/// coded units (`0.1 + 0.2`) is exported as the `0.3` a user means, not as
/// `0.30000000000000004`; a measured value keeps every digit.
pub fn without_round_off(value: f64) -> f64 {
    if !value.is_finite() || value == 0.0 {
        return value;
    }
    format!("{value:.14e}").parse().unwrap_or(value)
}

/// The unit of a response or series: what the study's equipment or stages declare,
/// or the solver's own figures (loop time, s; throughput, particle-steps per s).
pub fn unit_of(study: Option<&Study>, name: &str) -> Option<String> {
    use orch_adapters::simulation::{
        SOLVER_INFLOW_PLACED, SOLVER_LARGEST_OVERLAP, SOLVER_LOOP_TIME, SOLVER_THROUGHPUT,
    };
    match name {
        SOLVER_LOOP_TIME => return Some("s".into()),
        SOLVER_THROUGHPUT => return Some("1/s".into()),
        SOLVER_LARGEST_OVERLAP | SOLVER_INFLOW_PLACED => return Some("-".into()),
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
        self.render(Format::Csv)
    }

    /// The table as a JSON array of objects keyed by header, in column order.
    pub fn to_json(&self) -> Value {
        let rows = self
            .rows
            .iter()
            .map(|row| Value::Object(json_object(&self.headers, row)))
            .collect();
        Value::Array(rows)
    }

    /// The table in `format`, ending with a line break (JSON is pretty-printed).
    pub fn render(&self, format: Format) -> String {
        let mut out = Vec::new();
        let mut writer =
            TableWriter::new(&mut out, format, self.headers.clone()).expect("writing to memory");
        for row in &self.rows {
            writer.row(row).expect("writing to memory");
        }
        writer.finish().expect("writing to memory");
        String::from_utf8(out).expect("the table's text is UTF-8")
    }
}

/// Writes a table row by row, in the text [`Table::render`] gives for the whole table,
/// so that a table too large to hold is never held.
pub struct TableWriter<W: Write> {
    out: W,
    format: Format,
    headers: Vec<String>,
    rows: usize,
}

impl<W: Write> TableWriter<W> {
    /// Starts the table: CSV's header line, or JSON's opening bracket (written with
    /// the first row, as `[]` alone stands for no rows).
    pub fn new(mut out: W, format: Format, headers: Vec<String>) -> io::Result<TableWriter<W>> {
        if format == Format::Csv {
            write_csv_line(&mut out, headers.iter().map(String::as_str))?;
        }
        Ok(TableWriter {
            out,
            format,
            headers,
            rows: 0,
        })
    }

    /// Writes one row, as long as the headers.
    pub fn row(&mut self, cells: &[Cell]) -> io::Result<()> {
        match self.format {
            Format::Csv => {
                let texts: Vec<String> = cells.iter().map(cell_text).collect();
                write_csv_line(&mut self.out, texts.iter().map(String::as_str))?;
            }
            Format::Json => {
                // serde_json's pretty form of an array: each element on its own lines,
                // indented one level more than the brackets.
                let object = Value::Object(json_object(&self.headers, cells));
                let text = serde_json::to_string_pretty(&object).map_err(io::Error::other)?;
                self.out
                    .write_all(if self.rows == 0 { b"[\n" } else { b",\n" })?;
                for (i, line) in text.lines().enumerate() {
                    if i > 0 {
                        self.out.write_all(b"\n")?;
                    }
                    write!(self.out, "  {line}")?;
                }
            }
        }
        self.rows += 1;
        Ok(())
    }

    /// Ends the table; the rows written.
    pub fn finish(mut self) -> io::Result<usize> {
        if self.format == Format::Json {
            self.out
                .write_all(if self.rows == 0 { b"[]\n" } else { b"\n]\n" })?;
        }
        self.out.flush()?;
        Ok(self.rows)
    }
}

/// One CSV record and its CRLF.
fn write_csv_line<'a>(
    out: &mut impl Write,
    fields: impl Iterator<Item = &'a str>,
) -> io::Result<()> {
    let quoted: Vec<String> = fields.map(csv_field).collect();
    out.write_all(quoted.join(",").as_bytes())?;
    out.write_all(b"\r\n")
}

/// A row as a JSON object keyed by `headers`, in column order.
fn json_object(headers: &[String], cells: &[Cell]) -> Map<String, Value> {
    headers
        .iter()
        .zip(cells)
        .map(|(h, c)| (h.clone(), cell_json(c)))
        .collect()
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
    let runs = RunRows::read(store, row, study).await?;
    Ok(Table {
        rows: (0..runs.len()).map(|k| runs.row(k)).collect(),
        headers: runs.headers,
    })
}

/// Writes [`runs_table`] to `out` a row at a time, in the same text, without holding
/// the table: the jobs are read a page at a time ([`JobPages`]) with their points and
/// responses, so memory does not grow with the study. Returns the rows written.
pub async fn write_runs(
    store: &Store,
    row: &StudyRow,
    study: Option<&Study>,
    format: Format,
    out: impl Write,
) -> Result<usize, ExportError> {
    // Every job's state is checked before a byte is written (one counting query): a
    // store with a state this orch does not know is refused with nothing printed.
    store.job_counts(row.id).await?;
    let mut pages = JobPages::of(row.id);
    let first = pages.next(store).await?.unwrap_or_default();
    let mut runs = RunRows::of_page(store, row, study, first).await?;
    let mut writer = TableWriter::new(out, format, runs.headers.clone())?;
    loop {
        for k in 0..runs.len() {
            writer.row(&runs.row(k))?;
        }
        let Some(page) = pages.next(store).await? else {
            break;
        };
        runs.page = page;
    }
    Ok(writer.finish()?)
}

/// What the rows of [`runs_table`] are made from, read from the store once (each
/// table in one query); a row's cells are made when asked for, so a caller that
/// writes or shows only some rows holds only those.
pub struct RunRows {
    /// The table's headers.
    pub headers: Vec<String>,
    names: Vec<String>,
    /// The study's `fixed:` values at each fidelity level (one list without levels),
    /// the same in every row of a level.
    fixed: Vec<Vec<Cell>>,
    /// Each fidelity level's name and solver; empty without levels.
    levels: Vec<(String, String)>,
    /// The study's factors: a text factor's column holds its level's text.
    factors: Vec<crate::store::FactorRow>,
    page: JobPage,
}

impl RunRows {
    /// Reads the study's factors, points, responses and jobs.
    pub async fn read(
        store: &Store,
        row: &StudyRow,
        study: Option<&Study>,
    ) -> Result<RunRows, StoreError> {
        let page = JobPage {
            responses: store.responses(row.id).await?,
            jobs: store.jobs(row.id).await?,
            points: store
                .points(row.id)
                .await?
                .into_iter()
                .map(|p| (p.id, p))
                .collect(),
        };
        RunRows::of(store, row, study, page).await
    }

    /// The rows of the jobs at the positions (in id order, ascending) that `choose`
    /// picks from the number of jobs, with the headers of every row, and that
    /// number: only the chosen jobs, their points and their responses are read.
    pub async fn read_chosen(
        store: &Store,
        row: &StudyRow,
        study: Option<&Study>,
        choose: impl FnOnce(usize) -> Vec<usize>,
    ) -> Result<(RunRows, usize), StoreError> {
        let total: usize = store.job_counts(row.id).await?.values().sum();
        let jobs = store.jobs_at(row.id, &choose(total)).await?;
        let page = JobPage::of_jobs(store, jobs).await?;
        Ok((RunRows::of_page(store, row, study, page).await?, total))
    }

    /// The rows of `page`'s jobs (in id order), with the headers of every row of the
    /// study: the study's response names are read, not taken from the page.
    async fn of_page(
        store: &Store,
        row: &StudyRow,
        study: Option<&Study>,
        page: JobPage,
    ) -> Result<RunRows, StoreError> {
        let mut runs = RunRows::of(store, row, study, page).await?;
        // The headers name every stored response, not only the chosen rows'.
        let stored: BTreeSet<String> = store.response_names(row.id).await?.into_iter().collect();
        let names = response_order(study, &stored);
        runs.headers.truncate(runs.headers.len() - runs.names.len());
        runs.headers.extend(
            names
                .iter()
                .map(|n| header(n, unit_of(study, n).as_deref())),
        );
        runs.names = names;
        Ok(runs)
    }

    async fn of(
        store: &Store,
        row: &StudyRow,
        study: Option<&Study>,
        page: JobPage,
    ) -> Result<RunRows, StoreError> {
        let factors = store.factors(row.id).await?;
        let stored: BTreeSet<String> = page
            .responses
            .values()
            .flat_map(|r| r.iter().map(|(name, _)| name.to_string()))
            .collect();
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
            "identity",
            "reused_from",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        headers.extend(factors.iter().map(|f| header(&f.name, Some(&f.unit))));
        // The values the study holds fixed, numbers and text, as columns constant
        // within a fidelity level (a level may set its own): a row says everything its
        // run was made with, its level and solver too.
        let mut fixed = vec![Vec::new()];
        let mut levels = Vec::new();
        if let Some(study) = study {
            let unit = |name: &str| {
                study
                    .simulation
                    .parameters()
                    .iter()
                    .find(|p| p.name == name)
                    .map(|p| p.unit.to_string())
            };
            levels = study
                .fidelities
                .iter()
                .map(|f| (f.name.clone(), f.simulation.solver_name().to_string()))
                .collect();
            if !levels.is_empty() {
                headers.extend(["fidelity".to_string(), "solver".to_string()]);
            }
            let names: BTreeSet<&String> = study
                .fixed
                .keys()
                .chain(study.fidelities.iter().flat_map(|f| f.fixed.keys()))
                .collect();
            fixed = (0..study.fidelities.len().max(1))
                .map(|level| {
                    let case = study.case_at_level(&[], level as u32, 0);
                    names
                        .iter()
                        .map(|name| Cell::Real(without_round_off(case.get(name))))
                        .chain(study.fixed_text.values().map(|t| Cell::Text(t.clone())))
                        .collect()
                })
                .collect();
            for name in names {
                headers.push(header(name, unit(name).as_deref()));
            }
            headers.extend(study.fixed_text.keys().cloned());
        }
        headers.extend(
            names
                .iter()
                .map(|n| header(n, unit_of(study, n).as_deref())),
        );
        Ok(RunRows {
            headers,
            names,
            fixed,
            levels,
            factors,
            page,
        })
    }

    /// The number of rows: one per job.
    pub fn len(&self) -> usize {
        self.page.jobs.len()
    }

    /// True for a study without jobs.
    pub fn is_empty(&self) -> bool {
        self.page.jobs.is_empty()
    }

    /// Row `k` (the `k`-th job in id order), as long as the headers.
    pub fn row(&self, k: usize) -> Vec<Cell> {
        let job = &self.page.jobs[k];
        let point = &self.page.points[&job.point_id];
        let empty = ResponseValues::default();
        let values = self.page.responses.get(&job.id).unwrap_or(&empty);
        let mut cells = vec![
            Cell::Text(job.name.clone()),
            Cell::Text(job.kind.as_str().to_string()),
            Cell::Int(point.round),
            Cell::Text(point.purpose.as_str().to_string()),
            Cell::Int(point.idx),
            Cell::Int(job.replicate),
            Cell::Int(job.seed),
            Cell::Text(job.state.to_string()),
            job.identity.clone().map_or(Cell::Empty, Cell::Text),
            job.reused_from.clone().map_or(Cell::Empty, Cell::Text),
        ];
        cells.extend(point.natural.iter().zip(&self.factors).map(|(v, factor)| {
            match factor.level_text(*v) {
                Some(text) => Cell::Text(text),
                None => Cell::Real(without_round_off(*v)),
            }
        }));
        let level = point.fidelity as usize;
        if let Some((name, solver)) = self.levels.get(level) {
            cells.extend([Cell::Text(name.clone()), Cell::Text(solver.clone())]);
        }
        cells.extend(self.fixed[level.min(self.fixed.len() - 1)].iter().cloned());
        cells.extend(
            self.names
                .iter()
                .map(|n| values.get(n).map(Cell::Real).unwrap_or(Cell::Empty)),
        );
        cells
    }
}

/// Why `orch export` could not write its table.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// The store could not be read.
    #[error(transparent)]
    Store(#[from] StoreError),
    /// The output could not be written.
    #[error("cannot write the table: {0}")]
    Write(#[from] io::Error),
}

/// The headers of [`write_series`]'s table.
pub const SERIES_HEADERS: [&str; 6] = ["job", "series", "unit", "over", "x", "value"];

/// Writes every series of every job in long form to `out`: `job, series, unit, over, x,
/// value`, where `over` names the abscissa with its unit (`t [s]`, or `r [m]` for a
/// radial density); in job, series and abscissa order. The store is read a page of
/// jobs at a time and each row written as it comes, so memory does not grow with the
/// study. Returns the rows written.
pub async fn write_series(
    store: &Store,
    row: &StudyRow,
    study: Option<&Study>,
    format: Format,
    out: impl Write,
) -> Result<usize, ExportError> {
    let headers = SERIES_HEADERS.iter().map(|s| s.to_string()).collect();
    let mut writer = TableWriter::new(out, format, headers)?;
    let mut units: HashMap<String, (Cell, Cell)> = HashMap::new();
    let mut pages = SeriesPages::of(row.id);
    while let Some(page) = pages.next(store).await? {
        for point in page {
            let (unit, over) = units
                .entry(point.series.clone())
                .or_insert_with(|| {
                    (
                        unit_of(study, &point.series)
                            .map(Cell::Text)
                            .unwrap_or(Cell::Empty),
                        Cell::Text(abscissa_of(study, &point.series)),
                    )
                })
                .clone();
            writer.row(&[
                Cell::Text(point.job),
                Cell::Text(point.series),
                unit,
                over,
                Cell::Real(point.x),
                Cell::Real(point.value),
            ])?;
        }
    }
    Ok(writer.finish()?)
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
    fn json_written_row_by_row_is_serde_json_s_pretty_array() {
        let whole = table();
        let expected = serde_json::to_string_pretty(&whole.to_json()).unwrap() + "\n";
        assert_eq!(whole.render(Format::Json), expected);
        let empty = Table {
            headers: whole.headers.clone(),
            rows: vec![],
        };
        assert_eq!(empty.render(Format::Json), "[]\n");
        assert_eq!(empty.render(Format::Csv), "job,x [m],note\r\n");
    }

    /// The runs table written a page of jobs at a time is the table read whole, also
    /// when the study has more jobs than a page and responses on either side of the
    /// page boundary.
    #[tokio::test]
    async fn runs_written_page_by_page_are_the_whole_table() {
        use crate::store::JobResults;
        const PAGE_LEN: usize = crate::store::ROWS_PER_PAGE as usize;
        let levels = PAGE_LEN + 3;
        let text = format!("name: big\nsolver: native\nfactors:\n  - {{name: outlet_diameter, min: 0.020, max: 0.028, unit: m}}\ndesign: {{type: full_factorial, levels: {levels}}}\n");
        let dir = tempfile::tempdir().unwrap();
        let store = Store::open(dir.path()).await.unwrap();
        let study = Study::from_text(std::path::Path::new("big.yaml"), &text, None).unwrap();
        let id = store
            .insert_study(&study, std::path::Path::new("big.yaml"), dir.path())
            .await
            .unwrap();
        let jobs = store.jobs(id).await.unwrap();
        assert_eq!(jobs.len(), levels);
        for (k, job) in [(0, &jobs[0]), (1, &jobs[PAGE_LEN]), (2, &jobs[levels - 1])] {
            store
                .mark_rendered(job.id, &format!("test run {}", job.id))
                .await
                .unwrap();
            store.mark_running(job.id, "1:1", 0.0).await.unwrap();
            let results = JobResults {
                responses: vec![(format!("r{k}"), k as f64 + 0.5)],
                ..JobResults::default()
            };
            store.mark_succeeded(job.id, 0, &results).await.unwrap();
        }
        let row = store.study_by_name("big").await.unwrap().unwrap();
        let whole = runs_table(&store, &row, Some(&study)).await.unwrap();
        for format in [Format::Csv, Format::Json] {
            let mut written = Vec::new();
            let rows = write_runs(&store, &row, Some(&study), format, &mut written)
                .await
                .unwrap();
            assert_eq!(rows, levels);
            assert_eq!(String::from_utf8(written).unwrap(), whole.render(format));
        }
        assert_eq!(whole.headers[whole.headers.len() - 3..], ["r0", "r1", "r2"]);
    }

    /// A small stored study with series on some jobs: the long table pages through the
    /// jobs, one without series in between, and keeps job, series and time order.
    #[tokio::test]
    async fn series_are_written_a_page_of_jobs_at_a_time_in_order() {
        use crate::store::{JobResults, SeriesPages};
        let text = "name: s\nsolver: liggghts\nfactors:\n  - {name: outlet_diameter, min: 0.020, max: 0.028, unit: m}\ndesign: {type: full_factorial, levels: 3}\n";
        let dir = tempfile::tempdir().unwrap();
        let store = Store::open(dir.path()).await.unwrap();
        let study = Study::from_text(std::path::Path::new("s.yaml"), text, None).unwrap();
        let id = store
            .insert_study(&study, std::path::Path::new("s.yaml"), dir.path())
            .await
            .unwrap();
        let jobs = store.jobs(id).await.unwrap();
        for (k, job) in jobs.iter().enumerate().filter(|(k, _)| *k != 1) {
            store
                .mark_rendered(job.id, &format!("test run {}", job.id))
                .await
                .unwrap();
            store.mark_running(job.id, "1:1", 0.0).await.unwrap();
            let results = JobResults {
                series: vec![
                    ("b".into(), vec![(0.2, k as f64), (0.1, -1.0)]),
                    ("a".into(), vec![(0.5, 1.0)]),
                ],
                ..JobResults::default()
            };
            store.mark_succeeded(job.id, 0, &results).await.unwrap();
        }
        let mut pages = SeriesPages::with_page_size(id, 1);
        let mut sizes = Vec::new();
        while let Some(page) = pages.next(&store).await.unwrap() {
            sizes.push(page.len());
        }
        assert_eq!(sizes, vec![3, 0, 3]);

        let row = store.study_by_name("s").await.unwrap().unwrap();
        let mut csv = Vec::new();
        let rows = write_series(&store, &row, Some(&study), Format::Csv, &mut csv)
            .await
            .unwrap();
        assert_eq!(rows, 6);
        let csv = String::from_utf8(csv).unwrap();
        let lines: Vec<&str> = csv.split("\r\n").collect();
        assert_eq!(lines[0], "job,series,unit,over,x,value");
        let (first, last) = (&jobs[0].name, &jobs[2].name);
        let keys: Vec<String> = lines[1..7]
            .iter()
            .map(|l| {
                l.split(',')
                    .enumerate()
                    .filter(|(i, _)| [0, 1, 4, 5].contains(i))
                    .map(|(_, f)| f)
                    .collect::<Vec<_>>()
                    .join(" ")
            })
            .collect();
        assert_eq!(
            keys,
            [
                format!("{first} a 0.5 1.0"),
                format!("{first} b 0.1 -1.0"),
                format!("{first} b 0.2 0.0"),
                format!("{last} a 0.5 1.0"),
                format!("{last} b 0.1 -1.0"),
                format!("{last} b 0.2 2.0"),
            ]
        );
        let mut json = Vec::new();
        write_series(&store, &row, Some(&study), Format::Json, &mut json)
            .await
            .unwrap();
        let parsed: Value = serde_json::from_slice(&json).unwrap();
        assert_eq!(parsed.as_array().unwrap().len(), 6);
        assert_eq!(parsed[5]["value"], 2.0);
        assert_eq!(parsed[5]["job"], last.as_str());
    }

    #[test]
    fn reals_keep_every_digit() {
        let v = 0.1 + 0.2;
        let text = cell_text(&Cell::Real(v));
        assert_eq!(text.parse::<f64>().unwrap().to_bits(), v.to_bits());
    }
}
