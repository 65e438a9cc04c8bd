//! Fidelity levels (`fidelity:`): every design point runs at the cheap level, a nested
//! subset at the dear one, each response is fitted by co-Kriging over the levels, the
//! next round runs where the cost-weighted expected improvement says, at the level it
//! says, and status and the report (as Chromium renders it) show both levels and
//! the learned correlation.

use std::collections::BTreeMap;

use serde_json::Value;

use crate::support::{count, rendered_dom, require_liggghts, solver_lock, text, Project};

/// Two levels of the native hopper: 300 particles for all 9 points, 1000 for a nested 4.
const COARSE_AND_FINE: &str = "\
name: grains
solver: native
executor: {max_parallel: 2, time_limit: 2min, retries: 0}
factors:
  - {name: outlet_diameter, min: 0.020, max: 0.028, unit: m}
  - {name: friction, min: 0.4, max: 0.6}
fixed: {n_particles: 300, fill_time: 0.15, discharge_time: 0.4}
design: {type: full_factorial, levels: 3}
metamodel: {test_points: 0}
fidelity:
  - {name: coarse, cost: 1}
  - {name: fine, cost: 3, runs: 4, fixed: {n_particles: 1000}}
seed: 5
responses: [discharge_rate]
objective: {response: discharge_rate, goal: maximise}
rounds: 2
";

/// Each job's name, level and factor values, by name.
fn jobs_by_name(status: &Value) -> BTreeMap<String, (u64, Vec<f64>)> {
    status["jobs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|job| {
            let factors = &job["factors"];
            (
                job["name"].as_str().unwrap().to_string(),
                (
                    job["fidelity"].as_u64().unwrap(),
                    vec![
                        factors["outlet_diameter"].as_f64().unwrap(),
                        factors["friction"].as_f64().unwrap(),
                    ],
                ),
            )
        })
        .collect()
}

/// Every job at a level above the first has its twin at the first, at the same
/// point: `p004r0-fine` and `p004r0`.
fn assert_nested(jobs: &BTreeMap<String, (u64, Vec<f64>)>, suffix: &str) {
    let dear: Vec<&String> = jobs.keys().filter(|n| n.ends_with(suffix)).collect();
    assert!(!dear.is_empty(), "{jobs:?}");
    // Round 0's and any later round's.
    for name in dear {
        let (level, at) = &jobs[name];
        assert_eq!(*level, 1, "{name}");
        let twin = name.trim_end_matches(suffix);
        let (twin_level, twin_at) = &jobs[twin];
        assert_eq!((*twin_level, twin_at), (0, at), "{name} and {twin}");
    }
}

#[test]
fn coarse_and_fine_runs_are_nested_fitted_by_co_kriging_and_shown() {
    let _lock = solver_lock();
    let project = Project::new();
    let file = project.write("grains.yaml", COARSE_AND_FINE);
    let output = project.run(&["submit", file.to_str().unwrap()]);
    let stderr = text(&output.stderr);
    assert_eq!(output.status.code(), Some(0), "{stderr}");
    assert!(
        stderr.contains("on fidelity levels coarse (native), fine (native)"),
        "{stderr}"
    );

    let status = project.status("grains");
    let jobs = jobs_by_name(&status);
    assert_eq!(count(&status, "succeeded"), jobs.len(), "{status:#}");
    // Round 0: 9 coarse runs and a nested 4 fine ones, the centre first.
    let first: Vec<&String> = jobs.keys().filter(|n| n.starts_with('p')).collect();
    assert_eq!(first.len(), 13, "{first:?}");
    assert!(jobs.contains_key("p004r0-fine"), "{first:?}");
    assert_nested(&jobs, "-fine");
    // The levels rendered their own particle counts, and the twins are other runs.
    let case = |job: &str| {
        std::fs::read_to_string(
            project
                .project_dir()
                .join("runs/grains")
                .join(job)
                .join("hopper.toml"),
        )
        .unwrap()
    };
    assert!(
        case("p004r0").contains("count = 300\n"),
        "{}",
        case("p004r0")
    );
    assert!(case("p004r0-fine").contains("count = 1000\n"));
    let seeds =
        project.query("SELECT name, seed FROM jobs WHERE name LIKE 'p004r0%' ORDER BY name");
    assert_eq!(seeds.len(), 2);
    assert_ne!(seeds[0][1], seeds[1][1], "{seeds:?}");
    let levels =
        project.query("SELECT fidelity, COUNT(*) FROM points WHERE round = 0 GROUP BY fidelity");
    assert_eq!(levels, [["0", "9"], ["1", "4"]]);

    // Co-Kriging with a scale and a correlation between the levels.
    let fit = &status["rounds"][0]["fits"][0];
    let model = fit["model"].as_str().unwrap();
    assert!(
        model.starts_with("co-kriging over 2 fidelity levels") && model.contains("level 1: ρ = "),
        "{fit:#}"
    );
    assert_eq!(fit["runs"], 13);
    // Round 1 runs where the cost-weighted expected improvement is largest, nested too.
    let decision = status["rounds"][0]["decision"]["note"].as_str().unwrap();
    assert!(
        decision.contains("cost-weighted expected improvement over the fidelity levels"),
        "{decision}"
    );
    let second: Vec<&String> = jobs.keys().filter(|n| n.starts_with("r1-")).collect();
    assert!(!second.is_empty(), "{jobs:?}");
    let fitted = &status["rounds"][1]["fits"][0];
    assert!(fitted["error"].is_null(), "{fitted:#}");

    // Export: each row's level, solver and the particle count its level ran with.
    let csv = project.dir.path().join("grains.csv");
    let output = project.run(&["export", "grains", "-o", csv.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(0), "{}", text(&output.stderr));
    let table = std::fs::read_to_string(&csv).unwrap();
    let header: Vec<&str> = table.lines().next().unwrap().split(',').collect();
    let column = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (job, level, particles) = (column("job"), column("fidelity"), column("n_particles [-]"));
    for line in table.lines().skip(1) {
        let cells: Vec<&str> = line.split(',').collect();
        let fine = cells[job].ends_with("-fine");
        assert_eq!(cells[level], if fine { "fine" } else { "coarse" }, "{line}");
        assert_eq!(
            cells[particles],
            if fine { "1000.0" } else { "300.0" },
            "{line}"
        );
    }

    // The report, as a browser shows it: the levels with ρ and the correlation, and a
    // curve per level.
    let output = project.run(&["report", "grains"]);
    assert_eq!(output.status.code(), Some(0), "{}", text(&output.stderr));
    let page = std::path::PathBuf::from(text(&output.stdout).trim());
    if let Some(dom) = rendered_dom(&page, project.dir.path()) {
        assert!(dom.contains("<h4>Fidelity levels</h4>"), "no levels table");
        assert!(dom.contains("correlation with the level below"));
        assert!(dom.contains("measured loop time of a run [s]"));
        assert!(dom.contains("<td>fine</td>") && dom.contains("<td>coarse</td>"));
        assert!(dom.contains("Fidelity levels: discharge_rate along friction"));
        assert!(dom.contains("coarse (native, cost 1) &lt; fine (native, cost 3)"));
    }
}

#[test]
fn native_and_liggghts_levels_of_one_hopper_agree_up_to_a_learned_scale() {
    if !require_liggghts() {
        return;
    }
    let _lock = solver_lock();
    let project = Project::new();
    let study =
        std::fs::read_to_string(crate::support::root().join("jobs/hopper-multi-fidelity.yaml"))
            .unwrap();
    let file = project.write("hopper-multi-fidelity.yaml", &study);
    let output = project.run(&["submit", file.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(0), "{}", text(&output.stderr));
    let status = project.status("hopper-multi-fidelity");
    let jobs = jobs_by_name(&status);
    assert_eq!(count(&status, "succeeded"), jobs.len(), "{status:#}");
    assert_nested(&jobs, "-liggghts");
    // Each level ran its own solver: a LIGGGHTS deck and log for the dear level.
    for (name, (level, _)) in &jobs {
        let run = project
            .project_dir()
            .join("runs/hopper-multi-fidelity")
            .join(name);
        let (deck, log) = if *level == 1 {
            ("hopper.in", "log.liggghts")
        } else {
            ("hopper.toml", "log.native")
        };
        assert!(
            run.join(deck).is_file() && run.join(log).is_file(),
            "{name}"
        );
    }
    // The rates, native against LIGGGHTS at the same points.
    let rate = |job: &Value| job["responses"]["discharge_rate"].as_f64().unwrap();
    let by_name: BTreeMap<&str, f64> = status["jobs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|j| (j["name"].as_str().unwrap(), rate(j)))
        .collect();
    for (name, dear) in by_name.iter().filter(|(n, _)| n.ends_with("-liggghts")) {
        let cheap = by_name[name.trim_end_matches("-liggghts")];
        eprintln!("{name}: native {cheap:.4} kg/s, LIGGGHTS {dear:.4} kg/s");
    }
    // The learned scale and correlation: the two codes agree on how the rate moves.
    let model = status["rounds"][0]["fits"][0]["model"]
        .as_str()
        .unwrap()
        .to_string();
    eprintln!("{model}");
    let number_after = |key: &str| -> f64 {
        let rest = &model[model.find(key).unwrap_or_else(|| panic!("{model}")) + key.len()..];
        rest.split([',', ';', ' '])
            .find(|w| !w.is_empty())
            .unwrap()
            .parse()
            .unwrap()
    };
    let (rho, correlation) = (number_after("ρ = "), number_after("correlation "));
    assert!((0.5..1.5).contains(&rho), "{model}");
    assert!(correlation > 0.8, "{model}");
    // `orch fit` gives each level's length scales and noise; the report both levels.
    let fit = text(&project.run(&["fit", "hopper-multi-fidelity"]).stdout);
    assert!(
        fit.contains("fidelity level 0 (its own Kriging)")
            && fit.contains("fidelity level 1 (ρ times the level below plus its own Kriging)"),
        "{fit}"
    );
    let output = project.run(&["report", "hopper-multi-fidelity"]);
    assert_eq!(output.status.code(), Some(0), "{}", text(&output.stderr));
    let page = std::path::PathBuf::from(text(&output.stdout).trim());
    if let Some(dom) = rendered_dom(&page, project.dir.path()) {
        assert!(
            dom.contains("<td>liggghts</td>"),
            "no LIGGGHTS level in the report"
        );
        assert!(dom.contains("Fidelity levels: discharge_rate along outlet_diameter"));
    }
}
