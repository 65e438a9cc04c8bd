//! Results people can look at: `orch export` read back by Python's csv module, and
//! `orch report` rendered by headless Chromium, on small native studies.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use crate::support::{headless, require_program, solver_lock, text, Project};

/// Two factors, a face-centred CCD of 300 particles each (about 1 s per run), an
/// objective and Monte Carlo over one factor: every part of a report has something
/// to show.
const SMALL_STUDY: &str = "\
name: small
solver: native
executor: {max_parallel: 2, time_limit: 2min, retries: 0}
factors:
  - {name: outlet_diameter, min: 0.020, max: 0.028, unit: m}
  - {name: amplitude, min: 0.0, max: 0.0008, unit: m}
fixed: {n_particles: 300, fill_time: 0.12, discharge_time: 0.3}
design: {type: central_composite, alpha: face_centred, center_points: 1}
seed: 5
objective: {response: discharge_rate, goal: maximise}
uncertainty:
  samples: 20000
  seed: 3
  parameters:
    - {name: amplitude, distribution: normal, mean: 0.0004, std: 0.00005}
";

/// Runs the small study in a fresh project.
fn small_project() -> Project {
    let project = Project::new();
    let file = project.write("small.yaml", SMALL_STUDY);
    let output = project.run(&["submit", file.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(0), "{}", text(&output.stderr));
    project
}

/// Rows of a CSV file as Python's csv module reads them (header first), as JSON.
fn python_csv(path: &Path) -> Vec<Vec<String>> {
    let script = "import csv, json, sys\n\
                  with open(sys.argv[1], newline='') as f:\n    \
                  print(json.dumps(list(csv.reader(f))))\n";
    let output = Command::new("python3")
        .args(["-c", script])
        .arg(path)
        .output()
        .expect("python3 runs");
    assert!(output.status.success(), "{}", text(&output.stderr));
    serde_json::from_slice(&output.stdout).unwrap()
}

#[test]
fn export_writes_one_csv_row_per_run_with_units_that_python_reads_and_series_in_long_form() {
    let _lock = solver_lock();
    let project = small_project();
    let csv = project.dir.path().join("out/small.csv");
    let output = project.run(&["export", "small", "-o", csv.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(0), "{}", text(&output.stderr));

    let rows = python_csv(&csv);
    let header = &rows[0];
    for column in [
        "job",
        "round",
        "purpose",
        "point",
        "replicate",
        "seed",
        "state",
        "outlet_diameter [m]",
        "amplitude [m]",
        "identity",
        "reused_from",
        "fill_time [s]",
        "n_particles [-]",
    ] {
        assert!(header.contains(&column.to_string()), "{header:?}");
    }
    let fill = header.iter().position(|h| h == "fill_time [s]").unwrap();
    assert!(
        rows[1..].iter().all(|r| r[fill] == "0.12"),
        "a fixed value in every row"
    );
    assert_eq!(rows.len(), 1 + 9, "{rows:?}");
    let status = project.status("small");
    let column = |name: &str| header.iter().position(|h| h == name).unwrap();
    for job in status["jobs"].as_array().unwrap() {
        let name = job["name"].as_str().unwrap();
        let row = rows.iter().find(|r| r[0] == name).unwrap();
        assert_eq!(row[column("state")], "succeeded");
        assert_eq!(row[column("purpose")], "design");
        // A design value is exported without its round-off (15 significant digits).
        let outlet: f64 = row[column("outlet_diameter [m]")].parse().unwrap();
        let stored = job["factors"]["outlet_diameter"].as_f64().unwrap();
        assert_eq!(outlet, format!("{stored:.14e}").parse::<f64>().unwrap());
        assert!(row[column("outlet_diameter [m]")].len() <= 17, "{row:?}");
        // Every stored response is a column with its unit, and equal to the store's.
        for (response, value) in job["responses"].as_object().unwrap() {
            let cell = header
                .iter()
                .position(|h| h == response || h.starts_with(&format!("{response} [")))
                .unwrap_or_else(|| panic!("no column for {response}: {header:?}"));
            let exported: f64 = row[cell].parse().unwrap();
            assert_eq!(exported.to_bits(), value.as_f64().unwrap().to_bits());
        }
    }
    assert!(
        header.iter().any(|h| h.ends_with("[kg/s]")),
        "a mass-rate response with its unit: {header:?}"
    );

    // JSON: the same rows as objects.
    let output = project.run(&["export", "small", "--format", "json"]);
    assert_eq!(output.status.code(), Some(0), "{}", text(&output.stderr));
    let json: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    assert_eq!(json.as_array().unwrap().len(), 9);
    assert_eq!(json[0]["round"], 0);
    assert!(json[0]["outlet_diameter [m]"].is_f64(), "{:#}", json[0]);

    // Series in long form: every stored point, each with its job and unit.
    let series_csv = project.dir.path().join("series.csv");
    let output = project.run(&[
        "export",
        "small",
        "--series",
        "-o",
        series_csv.to_str().unwrap(),
    ]);
    assert_eq!(output.status.code(), Some(0), "{}", text(&output.stderr));
    let series = python_csv(&series_csv);
    assert_eq!(series[0], ["job", "series", "unit", "over", "x", "value"]);
    let stored = project.query("SELECT COUNT(*) FROM series");
    assert_eq!((series.len() - 1).to_string(), stored[0][0]);
    assert!(series[1..].iter().all(|r| r[4].parse::<f64>().is_ok()));
    // Time series are over t, the radial densities over r.
    for row in &series[1..] {
        let expected = if row[1].starts_with("radial_density") {
            "r [m]"
        } else {
            "t [s]"
        };
        assert_eq!(row[3], expected, "{row:?}");
    }
    assert!(
        series[1..].iter().any(|r| r[2] == "kg/s"),
        "a unit per series"
    );
}

#[test]
fn the_report_of_a_small_study_renders_in_headless_chromium_with_its_figures() {
    if !require_program("Chromium", "chromium", "chromium") {
        return;
    }
    let _lock = solver_lock();
    let project = small_project();
    let output = project.run(&["report", "small"]);
    assert_eq!(output.status.code(), Some(0), "{}", text(&output.stderr));
    let path = PathBuf::from(text(&output.stdout).trim());
    assert_eq!(path, project.project_dir().join("reports/small.html"));
    let html = std::fs::read_to_string(&path).unwrap();
    eprintln!("report: {} ({} bytes)", path.display(), html.len());
    // Self-contained: nothing is fetched from anywhere (SVG's xmlns is a name, not a fetch).
    for external in [
        "<script", "<link", "@import", "url(", "src=", "href=", "<img",
    ] {
        assert!(!html.contains(external), "the report refers to {external}");
    }

    let user_data = project.dir.path().join("chromium-profile");
    let started = Instant::now();
    let dom = headless(&user_data)
        .arg("--dump-dom")
        .arg(format!("file://{}", path.display()))
        .output()
        .unwrap();
    eprintln!(
        "chromium --dump-dom: {:.2} s",
        started.elapsed().as_secs_f64()
    );
    assert!(dom.status.success(), "{}", text(&dom.stderr));
    let dom = text(&dom.stdout);
    let svgs = dom.matches("<svg").count();
    eprintln!("rendered DOM: {} bytes, {svgs} <svg> elements", dom.len());
    // Per round: a surface, predicted vs observed, a Pareto chart (a polynomial with
    // t-values; Kriging has no terms) and the Sobol indices per response (2 headline
    // responses), the trust-region box; a chart per stored series.
    let series = project.query("SELECT COUNT(DISTINCT name) FROM series")[0][0]
        .parse::<usize>()
        .unwrap();
    assert!(series >= 1);
    let status = project.status("small");
    let per_response: usize = status["rounds"][0]["fits"]
        .as_array()
        .unwrap()
        .iter()
        .map(|fit| {
            // The chart ranks the factors' terms; the mean alone (`1`) has none.
            let pareto = fit["terms"]
                .as_array()
                .unwrap()
                .iter()
                .any(|t| !t["t"].is_null() && t["name"] != "1");
            let sobol = !fit["sobol"].as_object().unwrap().is_empty();
            if !pareto {
                // Where the chart is missing, the reader is told why: a Kriging surface
                // has no terms, a polynomial none that earned its place.
                let kriging = fit["model"].as_str().unwrap_or("").starts_with("kriging");
                let why = if kriging {
                    "Pareto chart: a Kriging surface has no terms"
                } else {
                    "Pareto chart: no standardised effects"
                };
                assert!(dom.contains(why), "{why}: {fit:#}");
            }
            2 + usize::from(pareto) + usize::from(sobol)
        })
        .sum();
    assert_eq!(
        svgs,
        per_response + 1 + series,
        "<svg> elements in the rendered DOM"
    );
    assert!(
        dom.contains("Sobol indices"),
        "the rendered report lacks Sobol indices"
    );
    for title in [
        "<title>small: report</title>",
        "Definitions",
        "Round 0",
        "Design",
        "Response surface",
        "Predicted against observed",
        "Pareto chart",
        "Optimum",
        "Monte Carlo",
        "Trust region",
        "Runs",
    ] {
        assert!(dom.contains(title), "the rendered report lacks {title}");
    }
    assert!(dom.contains("σ_cross"), "the definitions name σ_cross");

    let screenshot = project.dir.path().join("report.png");
    let shot = headless(&user_data)
        .arg(format!("--screenshot={}", screenshot.display()))
        .arg("--window-size=1280,4000")
        .arg(format!("file://{}", path.display()))
        .output()
        .unwrap();
    assert!(shot.status.success(), "{}", text(&shot.stderr));
    let png = std::fs::read(&screenshot).unwrap();
    assert!(png.starts_with(b"\x89PNG"), "not a PNG");
    assert!(
        png.len() > 20_000,
        "a nearly empty screenshot: {} bytes",
        png.len()
    );
    // Kept for people to look at: the temporary project is kept too.
    let kept = project.dir.keep();
    eprintln!(
        "screenshot of the report: {}",
        kept.join("report.png").display()
    );
}
