//! `orch-dem verify [DIR]`: runs every verification case (`*.toml` with a `[verify]`
//! table) of a folder, by default the kernel's own `dem/verification/`, and prints
//! one table of measured against reference values. Reading files happens here; the
//! measuring is `orch_dem::verify`.

use std::path::{Path, PathBuf};

use anyhow::Context;
use orch_dem::verify::{self, Outcome};

use crate::run;

/// One row of the table: a case's check and how it came out.
pub struct Row {
    /// The case file's stem.
    pub case: String,
    /// The outcome, or why the case could not be measured at all.
    pub outcome: Result<Outcome, String>,
}

impl Row {
    fn passed(&self) -> bool {
        self.outcome.as_ref().is_ok_and(Outcome::passed)
    }
}

/// The verification folder: `dir` when given, else `dem/verification/` of the source
/// tree this binary was built from, else one found beside the binary.
pub fn folder(dir: Option<PathBuf>) -> anyhow::Result<PathBuf> {
    if let Some(dir) = dir {
        return Ok(dir);
    }
    let mut candidates = vec![Path::new(env!("CARGO_MANIFEST_DIR")).join("../dem/verification")];
    if let Ok(exe) = std::env::current_exe() {
        // target/<profile>/orch-dem → the workspace root; or an install's share folder.
        for up in exe.ancestors().skip(1).take(4) {
            candidates.push(up.join("dem/verification"));
            candidates.push(up.join("share/orch-dem/verification"));
        }
    }
    candidates
        .into_iter()
        .find(|c| c.is_dir())
        .with_context(|| {
            "cannot find the verification cases (dem/verification/ of the orch source tree); pass the folder: orch-dem verify path/to/dem/verification"
        })
}

/// Runs every case of `dir` in file-name order.
pub fn run_all(dir: &Path) -> anyhow::Result<Vec<Row>> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .with_context(|| format!("cannot list the verification folder {}", dir.display()))?
        .filter_map(|entry| entry.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    anyhow::ensure!(
        !files.is_empty(),
        "{} holds no case files (*.toml); pass the folder of the verification cases",
        dir.display()
    );
    let mut rows = Vec::new();
    for file in files {
        let case_name = file
            .file_stem()
            .map_or_else(String::new, |s| s.to_string_lossy().into_owned());
        match run_case(&file) {
            Ok(outcomes) => rows.extend(outcomes.into_iter().map(|o| Row {
                case: case_name.clone(),
                outcome: Ok(o),
            })),
            Err(error) => rows.push(Row {
                case: case_name,
                outcome: Err(format!("{error:#}")),
            }),
        }
    }
    Ok(rows)
}

fn run_case(file: &Path) -> anyhow::Result<Vec<Outcome>> {
    let (case, mut simulation) = run::load(file)?;
    let table = case.verify.as_ref().ok_or(verify::VerifyError::NoTable)?;
    verify::run(&mut simulation, table, case.run.end_time)
        .with_context(|| format!("{}", file.display()))
}

/// Seven significant digits, in exponent form outside 0.01 to 10⁴.
fn number(x: f64) -> String {
    let magnitude = x.abs();
    if magnitude == 0.0 {
        "0".to_string()
    } else if (1e-2..1e4).contains(&magnitude) {
        let decimals = (6 - magnitude.log10().floor() as i32).max(0) as usize;
        format!("{x:.decimals$}")
    } else {
        format!("{x:.6e}")
    }
}

/// The table, one line per check, and a closing count.
pub fn render(rows: &[Row]) -> String {
    let mut lines = vec![[
        "case".to_string(),
        "quantity".to_string(),
        "measured".to_string(),
        "reference".to_string(),
        "rel. error".to_string(),
        "tolerance".to_string(),
        "verdict".to_string(),
    ]];
    let mut notes = Vec::new();
    for row in rows {
        let line = match &row.outcome {
            Ok(o) => {
                if let Some(note) = &o.note {
                    notes.push(format!("{}: {}: {note}", row.case, o.quantity.name()));
                }
                [
                    row.case.clone(),
                    format!("{} ({})", o.quantity.name(), o.quantity.unit()),
                    o.measured.map_or("-".into(), number),
                    number(o.reference),
                    o.relative_error()
                        .map_or("-".into(), |e| format!("{e:.2e}")),
                    format!("{:.1e}", o.tolerance),
                    if o.passed() { "pass" } else { "FAIL" }.to_string(),
                ]
            }
            Err(error) => {
                notes.push(format!("{}: {error}", row.case));
                [
                    row.case.clone(),
                    "-".into(),
                    "-".into(),
                    "-".into(),
                    "-".into(),
                    "-".into(),
                    "FAIL".into(),
                ]
            }
        };
        lines.push(line);
    }
    let widths: Vec<usize> = (0..7)
        .map(|k| {
            lines
                .iter()
                .map(|l| l[k].chars().count())
                .max()
                .unwrap_or(0)
        })
        .collect();
    let mut out = String::new();
    for line in &lines {
        let cells: Vec<String> = line
            .iter()
            .zip(&widths)
            .enumerate()
            .map(|(k, (cell, &w))| {
                if (2..6).contains(&k) {
                    format!("{cell:>w$}")
                } else {
                    format!("{cell:<w$}")
                }
            })
            .collect();
        out.push_str(cells.join("  ").trim_end());
        out.push('\n');
    }
    let passed = rows.iter().filter(|r| r.passed()).count();
    out.push_str(&format!("{passed} of {} checks pass\n", rows.len()));
    for note in notes {
        out.push_str(&format!("note: {note}\n"));
    }
    out
}

/// Runs the verification set of `dir` (or the default folder), prints the table;
/// returns whether every check passed.
pub fn verify(dir: Option<PathBuf>) -> anyhow::Result<bool> {
    let dir = folder(dir)?;
    let rows = run_all(&dir)?;
    print!("{}", render(&rows));
    Ok(rows.iter().all(Row::passed))
}
