//! The noise design (issue 13): the thesis's material-uncertainty study as a noise
//! design around the cone-shape optimum on the native kernel, its bounds with and
//! without the surrogate's own error, and the report that shows them as a browser
//! renders it.

use std::path::Path;

use crate::support::{count, rendered_dom, root, solver_lock, text, Project};

#[test]
fn the_material_uncertainty_study_runs_a_noise_design_around_the_cone_shape_optimum() {
    let _lock = solver_lock();
    let project = Project::new();
    let study = std::fs::read_to_string(root().join("jobs/material-uncertainty.yaml")).unwrap();
    let file = project.write("material-uncertainty.yaml", &study);
    let output = project.run(&["submit", file.to_str().unwrap()]);
    let stderr = text(&output.stderr);
    assert_eq!(output.status.code(), Some(0), "{stderr}");
    assert!(
        stderr.contains("orch: the noise design around the optimum: study `material-uncertainty-noise`, 15 jobs over density, restitution, friction"),
        "{stderr}"
    );

    // The shape rounds: 9 runs, the materials at their means, an optimum.
    let parent = project.status("material-uncertainty");
    assert_eq!(count(&parent, "succeeded"), 9, "{parent:#}");
    let optimum = &parent["rounds"][0]["optimum"]["factors"];
    let (x1, x2) = (
        optimum["shape_x1"].as_f64().unwrap(),
        optimum["shape_x2"].as_f64().unwrap(),
    );

    // The noise design: a central composite over the three materials on ±3σ, the shape
    // fixed at the optimum, every run at it.
    let noise = project.status("material-uncertainty-noise");
    assert_eq!(count(&noise, "succeeded"), 15, "{noise:#}");
    let noise_box = &noise["rounds"][0]["box"];
    for (name, min, max) in [
        ("density", 2112.0, 2688.0),
        ("restitution", 0.51, 0.69),
        ("friction", 0.425, 0.575),
    ] {
        assert!(
            (noise_box[name]["min"].as_f64().unwrap() - min).abs() < 1e-9,
            "{noise_box}"
        );
        assert!(
            (noise_box[name]["max"].as_f64().unwrap() - max).abs() < 1e-9,
            "{noise_box}"
        );
    }
    let runs = project.query(
        "SELECT COUNT(*) FROM jobs j JOIN studies s ON s.id = j.study_id WHERE s.name = 'material-uncertainty-noise'",
    );
    assert_eq!(runs[0][0], "15");
    // Its optimum is the materials' means (every factor is uncertain, held at its mean).
    let centre = &noise["rounds"][0]["optimum"]["factors"];
    assert!(
        (centre["density"].as_f64().unwrap() - 2400.0).abs() < 1e-6,
        "{centre}"
    );

    // The parent reports the noise design's bounds, with the surrogate's own error.
    let bounds = &parent["noise_design"]["round"]["uncertainty"];
    let inputs = bounds["interval_95"].as_array().unwrap();
    let total = &bounds["with_surrogate_error"];
    let mean = bounds["mean"].as_f64().unwrap();
    assert!(
        inputs[0].as_f64().unwrap() < mean && mean < inputs[1].as_f64().unwrap(),
        "{bounds:#}"
    );
    assert!(
        total["std"].as_f64().unwrap() >= bounds["std"].as_f64().unwrap(),
        "{bounds:#}"
    );
    let model = parent["noise_design"]["round"]["fits"][0]["model"]
        .as_str()
        .unwrap()
        .to_string();
    eprintln!(
        "material uncertainty at the cone optimum ({x1}, {x2}): discharge rate {mean:.4} kg/s, 95 % [{}, {}], with surrogate error [{}, {}], surrogate {model}",
        inputs[0], inputs[1], total["interval_95"][0], total["interval_95"][1]
    );
    assert!(
        stderr.contains("orch:   noise design `material-uncertainty-noise` over density, restitution, friction (15 runs, "),
        "{stderr}"
    );

    // Both reports were written; the parent's, as Chromium renders it, shows the bounds.
    let page = project
        .project_dir()
        .join("reports/material-uncertainty.html");
    assert!(project
        .project_dir()
        .join("reports/material-uncertainty-noise.html")
        .exists());
    if let Some(dom) = rendered_dom(Path::new(&page), project.dir.path()) {
        for needle in [
            "Noise design around the optimum",
            "uncertain inputs only",
            "and the surrogate's own error",
            "Sobol indices: discharge_rate",
        ] {
            assert!(
                dom.contains(needle),
                "`{needle}` missing from the rendered report"
            );
        }
    }

    // Submitted again, nothing runs twice: both studies continue and are done.
    let again = project.run(&["submit", file.to_str().unwrap()]);
    assert_eq!(again.status.code(), Some(0), "{}", text(&again.stderr));
    let jobs = project.query("SELECT COUNT(*) FROM jobs");
    assert_eq!(jobs[0][0], "24");
    // Deleting the study deletes its noise design too.
    let deleted = project.run(&["delete", "material-uncertainty"]);
    assert_eq!(deleted.status.code(), Some(0), "{}", text(&deleted.stderr));
    assert_eq!(project.query("SELECT COUNT(*) FROM studies")[0][0], "0");
}
