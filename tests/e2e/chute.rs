//! The transfer chute end to end on the native kernel: the chute-profile study runs,
//! its responses make physical sense (free fall from the lip, energy bound on the
//! chute, a flatter lip throws slower), and its constrained optimum lies where the
//! fitted surfaces say; impact speed rises with the drop height and the chute angle;
//! LIGGGHTS and the native kernel agree on identical chutes.

use std::time::Instant;

use serde_json::Value;

use crate::support::{count, require_liggghts, root, solver_lock, text, Project};

const G: f64 = 9.81;

fn response(job: &Value, name: &str) -> f64 {
    job["responses"][name]
        .as_f64()
        .unwrap_or_else(|| panic!("{} has no {name}: {job:#}", job["name"]))
}

fn job_at<'a>(status: &'a Value, factors: &[(&str, f64)]) -> &'a Value {
    status["jobs"]
        .as_array()
        .unwrap()
        .iter()
        .find(|j| {
            factors
                .iter()
                .all(|(name, value)| (j["factors"][*name].as_f64().unwrap() - value).abs() < 1e-9)
        })
        .unwrap_or_else(|| panic!("no job at {factors:?}: {status:#}"))
}

#[test]
fn the_chute_profile_study_minimises_impact_speed_under_its_lip_speed_bound() {
    let _lock = solver_lock();
    let project = Project::new();
    let study = std::fs::read_to_string(root().join("jobs/chute-profile.yaml")).unwrap();
    let file = project.write("chute-profile.yaml", &study);
    let started = Instant::now();
    let output = project.run(&["submit", file.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(0), "{}", text(&output.stderr));
    eprintln!(
        "chute-profile on the native kernel: {:.1} s wall",
        started.elapsed().as_secs_f64()
    );
    let status = project.status("chute-profile");
    assert_eq!(count(&status, "succeeded"), 9, "{status:#}");

    // Straight chute: L = 0.2 m at 40°, fed at 0.5 m/s.
    let height = 0.2 * 40f64.to_radians().sin();
    let frictionless_lip = (0.5f64.powi(2) + 2.0 * G * height).sqrt();
    for job in status["jobs"].as_array().unwrap() {
        let (impact, lip) = (response(job, "impact_speed"), response(job, "lip_speed"));
        eprintln!(
            "{} {}: impact {impact:.4} m/s, lip {lip:.4} m/s at {:.1}°, width {:.4} m, outer fines {:.3}, held up {:.2e} kg, wall impacts {:.4} J/m²",
            job["name"],
            job["factors"],
            response(job, "lip_angle"),
            response(job, "stream_width"),
            response(job, "outer_fine_fraction"),
            response(job, "held_up_mass"),
            response(job, "wall_impact_energy"),
        );
        // Free fall over the drop height: v² = v_lip² + 2 g h, to the spread of the
        // mean of square roots.
        let fall = (lip * lip + 2.0 * G * 0.1).sqrt();
        assert!((impact - fall).abs() < 0.03 * impact, "{impact} vs {fall}");
        // Friction and collisions only take energy: below the frictionless slide, but
        // the stream keeps most of it (a rolling sphere keeps 5/7 of the drop's).
        assert!(
            lip < frictionless_lip && lip > 0.6 * frictionless_lip,
            "{lip}"
        );
        // Everything fed reached the belt; the dust proxy is a proper fraction.
        assert!(response(job, "held_up_mass") < 0.01 * 0.025);
        let outer = response(job, "outer_fine_fraction");
        assert!(outer > 0.0 && outer < 1.0, "{outer}");
        // The wear proxy: impacts happened, and they cannot have brought the walls more
        // energy than the feed had, a few times over for the bounces (0.025 kg from at
        // most 0.17 m at 0.5 m/s: 0.045 J over 0.0163 m² of wall).
        let wear = response(job, "wall_impact_energy");
        assert!(wear > 0.0 && wear < 10.0 * 0.045 / 0.0163, "{wear}");
    }
    // A flatter lip (X2 < 0 lowers the control point near the lip) throws flatter and
    // slower, a steeper one faster.
    let straight = job_at(&status, &[("shape_x1", 0.0), ("shape_x2", 0.0)]);
    let flat = job_at(&status, &[("shape_x1", 0.0), ("shape_x2", -0.02)]);
    let steep = job_at(&status, &[("shape_x1", 0.0), ("shape_x2", 0.02)]);
    assert!(response(flat, "lip_angle") < response(straight, "lip_angle") - 5.0);
    assert!(response(steep, "lip_angle") > response(straight, "lip_angle") + 5.0);
    assert!(response(flat, "impact_speed") < response(straight, "impact_speed"));
    assert!(response(steep, "impact_speed") > response(straight, "impact_speed"));

    // The lowest impact among the runs breaks the lip-speed bound, so the optimum
    // is not there; it is at least as slow as the straight chute and on the flat side.
    let optimum = &status["rounds"][0]["optimum"];
    eprintln!("optimum: {optimum}");
    assert_eq!(optimum["response"], "impact_speed", "{optimum:#}");
    let lowest = status["jobs"]
        .as_array()
        .unwrap()
        .iter()
        .min_by(|a, b| response(a, "impact_speed").total_cmp(&response(b, "impact_speed")))
        .unwrap();
    assert!(response(lowest, "lip_speed") < 1.1, "{lowest:#}");
    let (x1, x2) = (
        optimum["factors"]["shape_x1"].as_f64().unwrap(),
        optimum["factors"]["shape_x2"].as_f64().unwrap(),
    );
    assert!(x2 < 0.0, "optimum at ({x1}, {x2})");
    assert!(
        (x1, x2)
            != (
                lowest["factors"]["shape_x1"].as_f64().unwrap(),
                lowest["factors"]["shape_x2"].as_f64().unwrap()
            ),
        "the optimum ignores the bound"
    );
    let value = optimum["value"].as_f64().unwrap();
    assert!(value < response(straight, "impact_speed"), "{value}");
    assert!(value > response(lowest, "impact_speed"), "{value}");
}

#[test]
fn impact_speed_rises_with_the_drop_height_and_the_chute_angle() {
    let _lock = solver_lock();
    let project = Project::new();
    let file = project.write(
        "chute-drop.yaml",
        "name: chute-drop\n\
         equipment: chute\n\
         solver: native\n\
         executor: {max_parallel: 2, time_limit: 3min, retries: 0}\n\
         factors:\n\
         \x20 - {name: drop_height, min: 0.05, max: 0.2, unit: m}\n\
         \x20 - {name: chute_angle, min: 30, max: 50, unit: deg}\n\
         fixed: {feed_time: 0.15, run_time: 0.75}\n\
         design: {type: full_factorial, levels: 2}\n\
         seed: 3\n\
         responses: [impact_speed, lip_speed]\n",
    );
    let output = project.run(&["submit", file.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(0), "{}", text(&output.stderr));
    let status = project.status("chute-drop");
    assert_eq!(count(&status, "succeeded"), 4, "{status:#}");
    for angle in [30.0, 50.0] {
        let low = job_at(&status, &[("drop_height", 0.05), ("chute_angle", angle)]);
        let high = job_at(&status, &[("drop_height", 0.2), ("chute_angle", angle)]);
        let (low_impact, high_impact) = (
            response(low, "impact_speed"),
            response(high, "impact_speed"),
        );
        eprintln!(
            "{angle}°: impact {low_impact:.4} m/s from 0.05 m, {high_impact:.4} m/s from 0.2 m"
        );
        // The same chute: the lip speed does not depend on the drop below it, and the
        // impact follows free fall.
        let lip = response(low, "lip_speed");
        assert!((response(high, "lip_speed") - lip).abs() < 0.05 * lip);
        let expected = (high_impact.powi(2) - low_impact.powi(2)) / (2.0 * G * 0.15);
        assert!((expected - 1.0).abs() < 0.05, "{expected}");
    }
    for drop in [0.05, 0.2] {
        let shallow = job_at(&status, &[("drop_height", drop), ("chute_angle", 30.0)]);
        let steep = job_at(&status, &[("drop_height", drop), ("chute_angle", 50.0)]);
        assert!(response(steep, "impact_speed") > response(shallow, "impact_speed"));
        assert!(response(steep, "lip_speed") > response(shallow, "lip_speed"));
    }
}

/// The status of a two-point study over the lip's control point on `solver`.
fn lip_study(solver: &str) -> Value {
    let project = Project::new();
    let file = project.write(
        "chute-lip.yaml",
        &format!(
            "name: chute-lip\n\
             equipment: chute\n\
             solver: {solver}\n\
             executor: {{max_parallel: 2, time_limit: 10min, retries: 0}}\n\
             factors:\n\
             \x20 - {{name: shape_x2, min: -0.02, max: 0.02, unit: m}}\n\
             design: {{type: full_factorial, levels: 2}}\n\
             seed: 5\n\
             responses: [impact_speed, lip_speed, lip_angle, landed_mass]\n"
        ),
    );
    let output = project.run(&["submit", file.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(0), "{}", text(&output.stderr));
    let status = project.status("chute-lip");
    assert_eq!(count(&status, "succeeded"), 2, "{status:#}");
    status
}

#[test]
fn liggghts_and_the_native_kernel_agree_on_identical_chutes() {
    if !require_liggghts() {
        return;
    }
    let _lock = solver_lock();
    let started = Instant::now();
    let native = lip_study("native");
    let native_s = started.elapsed().as_secs_f64();
    let started = Instant::now();
    let liggghts = lip_study("liggghts");
    eprintln!(
        "chute on native {native_s:.1} s, on LIGGGHTS {:.1} s wall (2 runs each, 2 at once)",
        started.elapsed().as_secs_f64()
    );
    for x2 in [-0.02, 0.02] {
        let (n, l) = (
            job_at(&native, &[("shape_x2", x2)]),
            job_at(&liggghts, &[("shape_x2", x2)]),
        );
        for name in ["impact_speed", "lip_speed"] {
            let (a, b) = (response(n, name), response(l, name));
            let difference = 100.0 * (a / b - 1.0);
            eprintln!(
                "X2 = {x2} m: {name} native {a:.4} m/s, LIGGGHTS {b:.4} m/s ({difference:+.1} %)"
            );
            assert!(difference.abs() < 10.0, "{name} at X2 = {x2}: {a} vs {b}");
        }
        let (a, b) = (response(n, "lip_angle"), response(l, "lip_angle"));
        eprintln!("X2 = {x2} m: lip_angle native {a:.2}°, LIGGGHTS {b:.2}°");
        assert!((a - b).abs() < 5.0, "lip_angle at X2 = {x2}: {a} vs {b}");
        // Both fed the same mass, to within a few particles, and it all landed.
        let (a, b) = (response(n, "landed_mass"), response(l, "landed_mass"));
        assert!((a - b).abs() < 0.03 * a, "landed mass {a} vs {b}");
    }
}
