//! The foundation's acceptance test: a 9-run central composite study on real LIGGGHTS.

use std::collections::BTreeMap;
use std::time::Instant;

use crate::support::{beverloo, count, require_liggghts, root, solver_lock, text, Project};

#[test]
fn a_nine_run_ccd_on_liggghts_discharges_like_beverloo_and_status_matches_the_store() {
    if !require_liggghts() {
        return;
    }
    let _lock = solver_lock();
    let project = Project::new();
    let study_file = root().join("jobs/hopper-vibration-liggghts.yaml");
    let started = Instant::now();
    let output = project.run(&["submit", study_file.to_str().unwrap()]);
    let wall = started.elapsed();
    let stderr = text(&output.stderr);
    assert_eq!(output.status.code(), Some(0), "{stderr}");
    assert!(
        stderr.contains("finished: 9 succeeded, 0 failed"),
        "{stderr}"
    );
    eprintln!("9-run LIGGGHTS study: {:.1} s wall", wall.as_secs_f64());

    let status = project.status("hopper-vibration");
    let jobs = status["jobs"].as_array().unwrap();
    assert_eq!(jobs.len(), 9);
    assert_eq!(count(&status, "succeeded"), 9);
    for job in jobs {
        let name = job["name"].as_str().unwrap();
        let outlet = job["factors"]["outlet_diameter"].as_f64().unwrap();
        let rate = job["responses"]["discharge_rate"].as_f64().unwrap();
        let ratio = rate / beverloo(outlet);
        eprintln!(
            "{name}: D = {outlet} m, rate = {rate:.4} kg/s, Beverloo = {:.4}, ratio {ratio:.2}",
            beverloo(outlet)
        );
        assert!(
            (0.5..=2.0).contains(&ratio),
            "{name}: rate {rate} vs Beverloo {}",
            beverloo(outlet)
        );
        let segregation = job["responses"]["segregation_ratio"].as_f64().unwrap();
        assert!(
            segregation.is_finite() && (0.3..=2.0).contains(&segregation),
            "{name}: R1/R2 = {segregation}"
        );
        let discharged = job["responses"]["discharged_count"].as_f64().unwrap();
        assert!(
            discharged >= 1990.0,
            "{name}: only {discharged} of 2000 particles crossed the sensor"
        );
    }

    // What status prints is what the store holds, response by response.
    let mut stored: BTreeMap<(String, String), String> = BTreeMap::new();
    for row in project
        .query("SELECT j.name, r.name, r.value FROM responses r JOIN jobs j ON j.id = r.job_id")
    {
        stored.insert((row[0].clone(), row[1].clone()), row[2].clone());
    }
    let mut shown: BTreeMap<(String, String), String> = BTreeMap::new();
    for job in jobs {
        for (name, value) in job["responses"].as_object().unwrap() {
            shown.insert(
                (job["name"].as_str().unwrap().to_string(), name.clone()),
                format!("{:e}", value.as_f64().unwrap()),
            );
        }
    }
    assert_eq!(shown, stored);
    let states = project.query("SELECT name, state, attempts FROM jobs ORDER BY id");
    for (row, job) in states.iter().zip(jobs) {
        assert_eq!(
            (row[0].as_str(), row[1].as_str(), row[2].as_str()),
            (job["name"].as_str().unwrap(), "succeeded", "1")
        );
    }
    // The mass-flow series is stored for every job.
    let series =
        project.query("SELECT COUNT(DISTINCT job_id) FROM series WHERE name = 'mass_flow_rate'");
    assert_eq!(series[0][0], "9");

    let table = text(&project.run(&["status", "hopper-vibration"]).stdout);
    assert!(
        table.starts_with("study hopper-vibration (liggghts, finished): 9 jobs: 9 succeeded\n"),
        "{table}"
    );
}
