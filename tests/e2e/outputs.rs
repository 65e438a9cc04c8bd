//! Lean outputs (issue 14): `keep: results` leaves a succeeded run directory without
//! particle snapshots but with what the parsers read and its responses stored, and
//! `vtk_every` writes legacy VTK files ParaView opens, on the native kernel and on
//! LIGGGHTS with 300 particles (a few seconds each).

use std::path::Path;

use crate::support::{count, require_liggghts, solver_lock, text, Project};

const PARTICLES: usize = 300;

fn study_on(solver: &str, name: &str, keep: &str) -> String {
    format!(
        r#"
name: {name}
solver: {solver}
executor: {{max_parallel: 1}}
factors:
  - {{name: outlet_diameter, min: 0.024, max: 0.025, unit: m}}
fixed:
  n_particles: {PARTICLES}
  fill_time: 0.05
  discharge_time: 0.15
  dump_every: 2000
  vtk_every: 2000
design: {{type: full_factorial, levels: 2}}
seed: 3
responses: [discharge_rate]
keep: {keep}
"#
    )
}

/// Every file under `dir`, relative.
fn files(dir: &Path) -> Vec<String> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else {
                out.push(path.strip_prefix(dir).unwrap().display().to_string());
            }
        }
    }
    out.sort();
    out
}

fn submit(project: &Project, name: &str, keep: &str) {
    submit_on(project, "native", name, keep);
}

fn submit_on(project: &Project, solver: &str, name: &str, keep: &str) {
    let file = project.write(&format!("{name}.yaml"), &study_on(solver, name, keep));
    let output = project.run(&["submit", file.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(0), "{}", text(&output.stderr));
    let status = project.status(name);
    assert_eq!(count(&status, "succeeded"), 2, "{status:#}");
}

/// The number of points of a legacy VTK polydata file, after checking its header, that
/// it holds that many coordinates, one vertex per point and point data for each.
fn vtk_points(path: &Path) -> usize {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    assert!(
        lines.next().unwrap().starts_with("# vtk DataFile Version "),
        "{}",
        path.display()
    );
    lines.next().unwrap(); // title
    assert_eq!(lines.next(), Some("ASCII"));
    assert_eq!(lines.next(), Some("DATASET POLYDATA"));
    let words: Vec<&str> = lines.flat_map(str::split_whitespace).collect();
    let at = |key: &str| words.iter().position(|w| *w == key).unwrap();
    let n: usize = words[at("POINTS") + 1].parse().unwrap();
    if n == 0 {
        // Every particle has left (LIGGGHTS then writes the points header alone).
        return 0;
    }
    let coordinates: Vec<f64> = words[at("POINTS") + 3..at("VERTICES")]
        .iter()
        .map(|w| w.parse().unwrap())
        .collect();
    assert_eq!(coordinates.len(), 3 * n, "{}", path.display());
    // `VERTICES n 2n` (legacy 3.0), or `VERTICES n+1 n` and offsets (5.1, LIGGGHTS).
    let vertices = (words[at("VERTICES") + 1], words[at("VERTICES") + 2]);
    assert!(
        vertices == (&n.to_string(), &(2 * n).to_string())
            || vertices == (&(n + 1).to_string(), &n.to_string()),
        "{}: VERTICES {vertices:?} for {n} points",
        path.display()
    );
    assert_eq!(words[at("POINT_DATA") + 1], n.to_string());
    n
}

#[test]
fn keep_results_leaves_no_snapshots_and_the_responses_stored() {
    let _lock = solver_lock();
    let project = Project::new();
    submit(&project, "lean-results", "results");
    for dir in project.run_dirs("lean-results") {
        let left = files(&dir);
        assert!(
            !left
                .iter()
                .any(|f| f.ends_with(".vtk") || f.ends_with(".liggghts")),
            "{}: {left:?}",
            dir.display()
        );
        for kept in [
            "hopper.toml",
            "log.native",
            "post/crossings.csv",
            "orch-kept.txt",
        ] {
            assert!(left.iter().any(|f| f == kept), "{kept} in {left:?}");
        }
        let record = std::fs::read_to_string(dir.join("orch-kept.txt")).unwrap();
        assert!(record.starts_with("keep: results removed "), "{record}");
    }
    let stored = project.query(
        "SELECT COUNT(*) FROM responses r JOIN jobs j ON j.id = r.job_id WHERE r.name = 'discharge_rate'",
    );
    assert_eq!(stored[0][0], "2");
}

#[test]
fn vtk_every_writes_legacy_vtk_files_of_every_particle() {
    let _lock = solver_lock();
    let project = Project::new();
    submit(&project, "lean-vtk", "all");
    check_vtk_snapshots(&project, "lean-vtk");
}

#[test]
fn vtk_every_on_liggghts_writes_legacy_vtk_files_of_every_particle() {
    if !require_liggghts() {
        return;
    }
    let _lock = solver_lock();
    let project = Project::new();
    submit_on(&project, "liggghts", "lean-vtk-liggghts", "all");
    check_vtk_snapshots(&project, "lean-vtk-liggghts");
}

/// Each run of `study` wrote at least two particle snapshots (`post/particles_<step>.vtk`;
/// LIGGGHTS's bounding-box files beside them are not particles), none with more than
/// every particle, and one, once the fill is in and before any left, with all of them
/// (the native kernel's first; LIGGGHTS inserts after its step 0, which is empty).
fn check_vtk_snapshots(project: &Project, study: &str) {
    for dir in project.run_dirs(study) {
        let vtk: Vec<String> = files(&dir)
            .into_iter()
            .filter(|f| f.ends_with(".vtk") && !f.contains("boundingBox"))
            .collect();
        assert!(vtk.len() >= 2, "{vtk:?}");
        let points: Vec<usize> = vtk.iter().map(|f| vtk_points(&dir.join(f))).collect();
        assert!(
            points.iter().all(|&n| n <= PARTICLES),
            "{vtk:?}: {points:?}"
        );
        assert!(points.contains(&PARTICLES), "{vtk:?}: {points:?}");
    }
}
