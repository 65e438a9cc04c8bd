//! YADE end to end: the cone-shape study runs on it, and the three DEM solvers (YADE,
//! LIGGGHTS, the native kernel) discharge the identical hopper at the same rate.

use std::collections::BTreeMap;

use crate::support::{
    beverloo, count, require_liggghts, require_yade, root, solver_lock, text, Project,
};

/// The shipped cone-shape study on YADE at a scale CI affords.
#[test]
fn the_cone_shape_study_runs_on_yade_end_to_end() {
    if !require_yade() {
        return;
    }
    let _lock = solver_lock();
    let project = Project::new();
    let study = std::fs::read_to_string(root().join("jobs/cone-shape.yaml"))
        .unwrap()
        .replace("name: cone-shape", "name: cone-shape-yade")
        .replace("solver: native", "solver: yade")
        .replace("n_particles: 1500", "n_particles: 400")
        .replace("fill_time: 0.25", "fill_time: 0.2");
    assert!(study.contains("solver: yade") && study.contains("n_particles: 400"));
    let file = project.write("cone-shape-yade.yaml", &study);
    let output = project.run(&["submit", file.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(0), "{}", text(&output.stderr));

    let status = project.status("cone-shape-yade");
    assert_eq!(count(&status, "succeeded"), 9, "{status:#}");
    let stored =
        project.query("SELECT COUNT(*) FROM responses WHERE name = 'discharge_rate' AND value > 0");
    assert_eq!(stored[0][0], "9", "every run's discharge rate is in SQLite");
    let table = project.run(&["status", "cone-shape-yade"]);
    let table = text(&table.stdout);
    assert!(
        table.contains("(yade, finished)") && table.contains("discharge_rate"),
        "{table}"
    );
    let rate = |x1: f64, x2: f64| {
        status["jobs"]
            .as_array()
            .unwrap()
            .iter()
            .find(|j| j["factors"]["shape_x1"] == x1 && j["factors"]["shape_x2"] == x2)
            .unwrap()["responses"]["discharge_rate"]
            .as_f64()
            .unwrap()
    };
    let (straight, concave) = (rate(0.0, 0.0), rate(-0.008, 0.008));
    eprintln!(
        "cone shape on YADE (400 particles): straight {straight:.4} kg/s, concave {concave:.4} (+{:.1} %)",
        100.0 * (concave / straight - 1.0)
    );
    assert!(
        concave > straight,
        "concave {concave} vs straight {straight}"
    );
}

/// One study file for `solver`: the same two outlets, replicated twice.
fn agreement_study(solver: &str) -> String {
    format!(
        "name: agreement-{solver}\n\
         solver: {solver}\n\
         executor: {{max_parallel: 2, time_limit: 5min, retries: 0}}\n\
         factors:\n  - {{name: outlet_diameter, min: 0.022, max: 0.026, unit: m}}\n\
         fixed: {{n_particles: 1000, fill_time: 0.25, discharge_time: 0.5}}\n\
         design: {{type: full_factorial, levels: 2}}\n\
         replicates: 2\n\
         seed: 3\n\
         responses: [discharge_rate]\n"
    )
}

/// Mean discharge rate over replicates, by outlet diameter in µm.
fn mean_rates(project: &Project, study: &str) -> BTreeMap<u64, f64> {
    let status = project.status(study);
    assert_eq!(count(&status, "succeeded"), 4, "{status:#}");
    let mut rates: BTreeMap<u64, Vec<f64>> = BTreeMap::new();
    for job in status["jobs"].as_array().unwrap() {
        let outlet = job["factors"]["outlet_diameter"].as_f64().unwrap();
        let rate = job["responses"]["discharge_rate"].as_f64().unwrap();
        rates
            .entry((outlet * 1e6).round() as u64)
            .or_default()
            .push(rate);
    }
    rates
        .into_iter()
        .map(|(outlet, r)| (outlet, r.iter().sum::<f64>() / r.len() as f64))
        .collect()
}

/// The same cases (parameters, seeds, STL walls) on LIGGGHTS, YADE and the native
/// kernel: the mean discharge rates of two replicates agree within 25 % pairwise.
#[test]
fn three_dem_solvers_discharge_the_identical_hopper_at_the_same_rate() {
    if !require_liggghts() || !require_yade() {
        return;
    }
    let _lock = solver_lock();
    let project = Project::new();
    let solvers = ["liggghts", "yade", "native"];
    let mut means = Vec::new();
    for solver in solvers {
        let file = project.write(&format!("{solver}.yaml"), &agreement_study(solver));
        let output = project.run(&["submit", file.to_str().unwrap()]);
        assert_eq!(output.status.code(), Some(0), "{}", text(&output.stderr));
        means.push(mean_rates(&project, &format!("agreement-{solver}")));
    }
    for outlet in means[0].keys() {
        let rates: Vec<f64> = means.iter().map(|m| m[outlet]).collect();
        eprintln!(
            "D = {} mm: LIGGGHTS {:.4} kg/s, YADE {:.4}, native {:.4}; Beverloo {:.4}",
            *outlet as f64 / 1000.0,
            rates[0],
            rates[1],
            rates[2],
            beverloo(*outlet as f64 * 1e-6)
        );
        for i in 0..3 {
            for j in i + 1..3 {
                let ratio = rates[i] / rates[j];
                assert!(
                    (0.8..=1.25).contains(&ratio),
                    "D = {outlet} µm: {} {} vs {} {}",
                    solvers[i],
                    rates[i],
                    solvers[j],
                    rates[j]
                );
            }
        }
    }
}
