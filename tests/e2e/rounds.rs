//! The metamodel stage in the loop: two rounds on LIGGGHTS, the second around the
//! first's optimum, with fit quality, optimum and 95 % bounds in `orch status`.

use crate::support::{count, require_liggghts, root, solver_lock, text, Project};

#[test]
fn two_rounds_zoom_in_around_the_first_optimum_and_status_shows_the_metamodel() {
    if !require_liggghts() {
        return;
    }
    let _lock = solver_lock();
    let project = Project::new();
    let file = root().join("jobs/discharge-two-rounds-liggghts.yaml");
    let output = project.run(&["submit", file.to_str().unwrap()]);
    let stderr = text(&output.stderr);
    assert_eq!(output.status.code(), Some(0), "{stderr}");
    assert!(
        stderr.contains("round 0 analysed; round 1 starts"),
        "{stderr}"
    );

    let status = project.status("discharge-two-rounds");
    // 18 runs a round, and one more in round 1 where round 0's surrogate was least certain.
    assert_eq!(count(&status, "succeeded"), 37);
    let rounds = status["rounds"].as_array().unwrap();
    assert_eq!(rounds.len(), 2);
    let first = &rounds[0];
    assert_eq!(first["decision"]["decision"], "next_round");
    let fit = first["fits"]
        .as_array()
        .unwrap()
        .iter()
        .find(|f| f["response"] == "discharge_rate")
        .unwrap();
    assert!(fit["sigma_cross_percent"].as_f64().unwrap() > 0.0);
    assert!(fit["r2"].as_f64().unwrap() > 0.5, "{fit}");
    assert_eq!(fit["test_runs"], 3);
    assert!(fit["sigma_test_percent"].as_f64().unwrap() > 0.0, "{fit}");
    // Round 1's box is half as wide and holds round 0's optimum (moved inside the limits).
    let optimum = &first["optimum"]["factors"];
    let limits: std::collections::BTreeMap<&str, (f64, f64)> = [
        ("outlet_diameter", (0.018, 0.026)),
        ("amplitude", (0.0, 0.0008)),
    ]
    .into_iter()
    .collect();
    for (factor, (min, max)) in limits {
        let range = &rounds[1]["box"][factor];
        let (lo, hi) = (
            range["min"].as_f64().unwrap(),
            range["max"].as_f64().unwrap(),
        );
        let at = optimum[factor].as_f64().unwrap();
        assert!(
            lo <= at + 1e-12 && at <= hi + 1e-12,
            "{factor}: optimum {at} outside [{lo}, {hi}]"
        );
        assert!(
            ((hi - lo) - 0.5 * (max - min)).abs() < 1e-9,
            "{factor}: [{lo}, {hi}] is not half of [{min}, {max}]"
        );
        assert!(lo >= min - 1e-12 && hi <= max + 1e-12);
        let centre = 0.5 * (lo + hi);
        let inside = at.clamp(min + 0.25 * (max - min), max - 0.25 * (max - min));
        assert!(
            (centre - inside).abs() < 1e-9,
            "{factor}: box centre {centre}, optimum {at}"
        );
    }
    // Friction is uncertain: it keeps its range and is held at its mean in the optimum.
    assert_eq!(rounds[1]["box"]["friction"]["min"], 0.4);
    assert!((optimum["friction"].as_f64().unwrap() - 0.5).abs() < 1e-12);
    let spread = &first["uncertainty"];
    let (low, high) = (
        spread["interval_95"][0].as_f64().unwrap(),
        spread["interval_95"][1].as_f64().unwrap(),
    );
    let mean = spread["mean"].as_f64().unwrap();
    assert!(
        low < mean && mean < high && spread["samples"] == 1_000_000,
        "{spread}"
    );
    assert_eq!(rounds[1]["decision"]["decision"], "last_round");

    let table = text(&project.run(&["status", "discharge-two-rounds"]).stdout);
    for needle in [
        "σ_cross",
        "R² ",
        "optimum (maximise discharge_rate)",
        "95 % interval",
        "decision: next_round",
    ] {
        assert!(table.contains(needle), "`{needle}` missing from:\n{table}");
    }
    let fits = project.run(&["fit", "discharge-two-rounds", "--round", "0"]);
    let fits = text(&fits.stdout);
    assert!(
        fits.starts_with(
            "round 0, discharge_rate (quadratic, all 10 terms, legendre basis, 15 runs)\n"
        ),
        "{fits}"
    );
    assert!(fits.contains("P1(outlet_diameter)*P1(amplitude)"), "{fits}");
    // The stored surfaces, optimum and bounds are in their tables.
    assert_eq!(project.query("SELECT COUNT(*) FROM fits")[0][0], "4");
    assert_eq!(project.query("SELECT COUNT(*) FROM uncertainty")[0][0], "2");
}
