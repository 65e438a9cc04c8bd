//! The native DEM kernel end to end: the quickstart study runs on it with no external
//! solver and discharges like Beverloo, and the cone-shape study finds the thesis's
//! direction (its agreement with LIGGGHTS and YADE is in `yade.rs`).

use std::collections::BTreeMap;
use std::path::Path;
use std::time::Instant;

use crate::support::{beverloo, count, rendered_dom, root, solver_lock, text, Project};

#[test]
fn the_quickstart_study_runs_on_the_native_kernel_and_discharges_like_beverloo() {
    let _lock = solver_lock();
    let project = Project::new();
    let study = std::fs::read_to_string(root().join("jobs/quickstart.yaml")).unwrap();
    let file = project.write("quickstart.yaml", &study);
    let started = Instant::now();
    let output = project.run(&["submit", file.to_str().unwrap()]);
    let stderr = text(&output.stderr);
    assert_eq!(output.status.code(), Some(0), "{stderr}");
    eprintln!(
        "quickstart on the native kernel: {:.1} s wall",
        started.elapsed().as_secs_f64()
    );

    // Two rounds: nine runs, then the next round's (the design in a smaller box around
    // the first optimum, or expected-improvement points when Kriging was chosen for the
    // rate) with a run where the first round's surrogate was least certain.
    let status = project.status("quickstart");
    let jobs = status["jobs"].as_array().unwrap().len();
    assert_eq!(count(&status, "succeeded"), jobs, "{status:#}");
    let second = status["jobs"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|j| j["name"].as_str().unwrap().starts_with("r1-"))
        .count();
    assert!(jobs == 9 + second && second >= 3, "{status:#}");
    // It ends with the whole method's answer: the recommended outlet, the rate there
    // and its 95 % interval under the uncertain friction, and where the report is.
    assert!(
        stderr.contains(
            "orch: recommended design (round 1): outlet_diameter = 0.028 m, friction = 0.5 -"
        ) && stderr
            .contains("under the uncertain friction ~ N(0.5, 0.025) (100000 samples): mean ")
            && stderr.contains("kg/s, 95 % interval [")
            && stderr.contains("widen outlet_diameter's range above 0.028"),
        "{stderr}"
    );
    let report = stderr
        .lines()
        .find_map(|l| l.strip_prefix("orch: report: "))
        .unwrap_or_else(|| panic!("no report path in:\n{stderr}"));
    // The report the quickstart wrote, as a browser renders it: both rounds' figures.
    if let Some(dom) = rendered_dom(Path::new(report), project.dir.path()) {
        assert!(
            dom.contains(&format!("study finished, {jobs} jobs")),
            "the report says the study finished"
        );
        for title in ["Round 0", "Round 1", "Response surface", "Monte Carlo"] {
            assert!(dom.contains(title), "the rendered report lacks {title}");
        }
        let svgs = dom.matches("<svg").count();
        eprintln!("quickstart report: {svgs} <svg> figures rendered by Chromium");
        assert!(svgs >= 2 * (2 * 3 + 1), "{svgs} <svg> elements");
    }

    let mut by_outlet: BTreeMap<u64, Vec<f64>> = BTreeMap::new();
    for job in status["jobs"].as_array().unwrap() {
        let name = job["name"].as_str().unwrap();
        let outlet = job["factors"]["outlet_diameter"].as_f64().unwrap();
        let rate = job["responses"]["discharge_rate"].as_f64().unwrap();
        let ratio = rate / beverloo(outlet);
        eprintln!(
            "{name}: D = {outlet} m, rate = {rate:.4} kg/s, Beverloo {:.4}, ratio {ratio:.2}",
            beverloo(outlet)
        );
        assert!(
            (1.0 / 1.5..=1.5).contains(&ratio),
            "{name}: {rate} kg/s against Beverloo's {}",
            beverloo(outlet)
        );
        let discharged = job["responses"]["discharged_count"].as_f64().unwrap();
        assert!(
            discharged >= 990.0,
            "{name}: only {discharged} of 1000 particles crossed the sensor"
        );
        if !name.starts_with("r1-") {
            by_outlet
                .entry((outlet * 1e6).round() as u64)
                .or_default()
                .push(rate);
        }
    }
    // A wider outlet discharges faster (round 1, at every friction).
    let means: Vec<f64> = by_outlet
        .values()
        .map(|r| r.iter().sum::<f64>() / r.len() as f64)
        .collect();
    assert!(means.windows(2).all(|w| w[0] < w[1]), "{means:?}");
    // The kernel's own figures reach the store too.
    let rows = project.query(
        "SELECT COUNT(*) FROM responses WHERE name = 'solver_particle_steps_per_s' AND value > 0",
    );
    assert_eq!(
        rows[0][0],
        jobs.to_string(),
        "every run's throughput is stored"
    );
}

/// The kernel is deterministic, so the quickstart as it was before the hopper became
/// one equipment behind the seam (`tests/fixtures/quickstart-eb004ce.yaml`) gives the
/// same responses bit for bit as recorded (`tests/fixtures/quickstart-responses.json`).
/// The record was made at eb004ce and made again only where the kernel's arithmetic
/// changed on purpose: when particles began to be kept in Morton order (the sums run in
/// another order; each rate stayed within the two runs' 95 % intervals, signed changes
/// −9.9 … +6.9 %, exit speeds within 0.8 %), and when the pair pass began to sum the
/// pairs inside each block of 256 particles itself (again another order; each rate
/// within both runs' 95 % intervals, signed changes −4.4 … +6.8 %, mean −0.7 %, exit
/// speeds within 1.7 %, discharged counts within 0.3 %), and when seeds became a keyed
/// hash of the study seed, the case and the replicate, and LIGGGHTS-style primes a mix
/// of the whole seed (every particle inserted elsewhere; each rate within both runs'
/// 95 % intervals, signed changes −12.1 … +4.6 %, mean −0.8 %, exit speeds within
/// 1.2 %), and when the friction's lever at a wall became `r − δ/2`, as LIGGGHTS takes
/// it, and the fines' early and late shares joined the responses (each rate within
/// both runs' 95 % intervals, signed changes −10.1 … +7.8 %, mean −1.4 %, exit speeds
/// within 2.0 %, discharged counts within 0.2 %).
#[test]
fn the_former_quickstart_gives_the_same_responses_bit_for_bit() {
    let _lock = solver_lock();
    let project = Project::new();
    let study =
        std::fs::read_to_string(root().join("tests/fixtures/quickstart-eb004ce.yaml")).unwrap();
    let file = project.write("quickstart.yaml", &study);
    let output = project.run(&["submit", file.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(0), "{}", text(&output.stderr));
    same_responses_as_before_the_equipment_seam(&project.status("quickstart"));
}

/// Compares every job's responses with the recorded ones, bit for bit; timing responses
/// (`solver_*`) are left out.
fn same_responses_as_before_the_equipment_seam(status: &serde_json::Value) {
    let fixture = root().join("tests/fixtures/quickstart-responses.json");
    let expected: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&fixture).unwrap()).unwrap();
    let expected = expected.as_object().unwrap();
    let jobs = status["jobs"].as_array().unwrap();
    assert_eq!(jobs.len(), expected.len());
    for job in jobs {
        let name = job["name"].as_str().unwrap();
        let before = expected[name].as_object().unwrap();
        let now = job["responses"].as_object().unwrap();
        let measured: Vec<&String> = now.keys().filter(|k| !k.starts_with("solver_")).collect();
        assert_eq!(measured, before.keys().collect::<Vec<_>>(), "{name}");
        for (response, value) in before {
            let (before, now) = (value.as_f64().unwrap(), now[response].as_f64().unwrap());
            assert_eq!(
                before.to_bits(),
                now.to_bits(),
                "{name} {response}: {now} now, {before} recorded"
            );
        }
    }
}

/// A time step beyond the largest safe one (0.3 of the fines' Rayleigh time here) is
/// refused at `orch submit`, which reads every design point's case as the kernel will:
/// the error names the point and the largest safe step, and nothing is written (the
/// kernel's own refusal of such a case file is tested in `orch-dem`'s case tests).
#[test]
fn a_native_study_with_an_unsafe_time_step_is_refused_at_submit_naming_the_safe_step() {
    let project = Project::new();
    let file = project.write(
        "unsafe.yaml",
        "name: unsafe\n\
         solver: native\n\
         executor: {max_parallel: 2, time_limit: 1min, retries: 0}\n\
         factors:\n  - {name: timestep, min: 0.00002, max: 0.0008, unit: s}\n\
         fixed: {n_particles: 200, fill_time: 0.1, discharge_time: 0.1}\n\
         design: {type: full_factorial, levels: 2}\n\
         seed: 1\n\
         responses: [discharge_rate]\n",
    );
    let output = project.run(&["submit", file.to_str().unwrap()]);
    let stderr = text(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("design point 1 (timestep = 0.0008)")
            && stderr
                .contains("8.0000e-4 s is above the largest safe time step for these particles")
            && stderr.contains("give at most")
            && stderr.contains("nothing was written"),
        "{stderr}"
    );
    assert!(
        !project.project_dir().exists(),
        "a refused study wrote {}",
        project.project_dir().display()
    );
}

/// The discharge rate of the job at `(shape_x1, shape_x2)` of a cone-shape study.
fn rate_at(status: &serde_json::Value, x1: f64, x2: f64) -> f64 {
    let job = status["jobs"]
        .as_array()
        .unwrap()
        .iter()
        .find(|j| {
            (j["factors"]["shape_x1"].as_f64().unwrap() - x1).abs() < 1e-9
                && (j["factors"]["shape_x2"].as_f64().unwrap() - x2).abs() < 1e-9
        })
        .unwrap_or_else(|| panic!("no job at ({x1}, {x2}): {status:#}"));
    job["responses"]["discharge_rate"].as_f64().unwrap()
}

#[test]
fn the_cone_shape_study_finds_the_concave_corner_faster_than_the_straight_cone() {
    let _lock = solver_lock();
    let project = Project::new();
    let study = std::fs::read_to_string(root().join("jobs/cone-shape.yaml")).unwrap();
    let file = project.write("cone-shape.yaml", &study);
    let output = project.run(&["submit", file.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(0), "{}", text(&output.stderr));
    let status = project.status("cone-shape");
    assert_eq!(count(&status, "succeeded"), 9, "{status:#}");

    // The thesis: the concave corner (min X1, max X2) discharges 51.67 % faster than
    // the straight cone; the convex corner (max X1, min X2) slower.
    let straight = rate_at(&status, 0.0, 0.0);
    let concave = rate_at(&status, -0.008, 0.008);
    let convex = rate_at(&status, 0.008, -0.008);
    let gain = 100.0 * (concave / straight - 1.0);
    eprintln!(
        "cone shape: straight {straight:.4} kg/s, concave {concave:.4} (+{gain:.1} %, thesis +51.67 %), convex {convex:.4}"
    );
    assert!(gain > 20.0, "concave only {gain:.1} % faster");
    assert!(convex < straight, "convex {convex} vs straight {straight}");

    // The fitted surface puts the optimum of the discharge rate at the concave corner.
    // Its report, as a browser renders it.
    let output = project.run(&["report", "cone-shape"]);
    assert_eq!(output.status.code(), Some(0), "{}", text(&output.stderr));
    let page = std::path::PathBuf::from(text(&output.stdout).trim());
    if let Some(dom) = rendered_dom(&page, project.dir.path()) {
        assert!(dom.contains("Response surface") && dom.matches("<svg").count() >= 7);
    }
    let optimum = &status["rounds"][0]["optimum"];
    assert_eq!(optimum["response"], "discharge_rate", "{optimum:#}");
    assert_eq!(optimum["factors"]["shape_x1"].as_f64(), Some(-0.008));
    assert_eq!(optimum["factors"]["shape_x2"].as_f64(), Some(0.008));
}

/// `orch-dem verify` as a user runs it: the shipped verification set passes, and a case
/// whose reference is wrong fails with exit 1 and says which.
#[test]
fn orch_dem_verify_passes_the_shipped_cases_and_fails_a_wrong_reference() {
    let orch_dem = crate::support::orch_bin().with_file_name("orch-dem");
    let cases = root().join("dem/verification");
    let output = std::process::Command::new(&orch_dem)
        .arg("verify")
        .arg(&cases)
        .output()
        .unwrap();
    let stdout = text(&output.stdout);
    assert_eq!(
        output.status.code(),
        Some(0),
        "{stdout}{}",
        text(&output.stderr)
    );
    let checks = stdout
        .lines()
        .filter(|l| l.ends_with(" pass") && !l.contains("checks pass"))
        .count();
    assert!(
        checks >= 15 && stdout.contains(&format!("{checks} of {checks} checks pass")),
        "{stdout}"
    );

    let project = Project::new();
    std::fs::create_dir_all(project.dir.path().join("verification")).unwrap();
    let wrong = std::fs::read_to_string(cases.join("restitution_wall_e05.toml"))
        .unwrap()
        .replace("reference = 0.5\n", "reference = 0.6\n");
    project.write("verification/restitution_wall_e05.toml", &wrong);
    std::fs::copy(
        cases.join("floor.stl"),
        project.dir.path().join("verification/floor.stl"),
    )
    .unwrap();
    let output = std::process::Command::new(&orch_dem)
        .arg("verify")
        .arg(project.dir.path().join("verification"))
        .output()
        .unwrap();
    let stdout = text(&output.stdout);
    assert_eq!(output.status.code(), Some(1), "{stdout}");
    assert!(
        stdout
            .lines()
            .any(|l| l.starts_with("restitution_wall_e05") && l.contains("FAIL")),
        "{stdout}"
    );
}

/// Issue 15: the fine fraction of the outer layers was 1.0 in 15 of 15 runs of the
/// vibration-segregation design, because the layers were measured against the one
/// outermost centre, which only a fine particle reaches. Measured by particle surfaces
/// against the robust stream radius, every layer's fraction varies across the design,
/// and the radial densities of both kinds are stored as series.
#[test]
fn outer_layer_fractions_vary_across_the_vibration_segregation_design() {
    let _lock = solver_lock();
    let project = Project::new();
    let study = std::fs::read_to_string(root().join("jobs/vibration-segregation.yaml")).unwrap();
    let file = project.write("vibration-segregation.yaml", &study);
    let output = project.run(&["submit", file.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(0), "{}", text(&output.stderr));
    let status = project.status("vibration-segregation");
    assert_eq!(count(&status, "succeeded"), 15, "{status:#}");
    let jobs = status["jobs"].as_array().unwrap();
    let value = |job: &serde_json::Value, name: &str| {
        job["responses"][name]
            .as_f64()
            .unwrap_or_else(|| panic!("{} has no {name}: {job:#}", job["name"]))
    };
    for job in jobs {
        let rate = value(job, "discharge_rate");
        let half_width = value(job, "discharge_rate_ci95");
        eprintln!(
            "{}: a = {:.5} m, f = {:.1} Hz, h = {:.4} m; outer 2/5/10/12 % = {:.3} {:.3} {:.3} {:.3}; R1/R2 = {:.3}, normalised {:.3}; rate {rate:.4} ± {half_width:.4} kg/s",
            job["name"].as_str().unwrap(),
            job["factors"]["amplitude"].as_f64().unwrap(),
            job["factors"]["frequency"].as_f64().unwrap(),
            job["factors"]["valve_gap"].as_f64().unwrap(),
            value(job, "fine_fraction_outer_2"),
            value(job, "fine_fraction_outer_5"),
            value(job, "fine_fraction_outer_10"),
            value(job, "fine_fraction_outer_12"),
            value(job, "segregation_ratio"),
            value(job, "segregation_ratio_normalised"),
        );
        assert!(
            half_width > 0.0 && half_width < 0.5 * rate,
            "{rate} ± {half_width}"
        );
    }
    for layer in [2, 5, 10, 12] {
        let name = format!("fine_fraction_outer_{layer}");
        let values: Vec<f64> = jobs.iter().map(|job| value(job, &name)).collect();
        let (min, max) = values
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
                (lo.min(v), hi.max(v))
            });
        assert!(max > min, "{name} is {min} in every run");
        let saturated = values.iter().filter(|&&v| v == 1.0 || v == 0.0).count();
        assert_eq!(saturated, 0, "{name}: {values:?}");
    }
    let rows = project.query(
        "SELECT COUNT(DISTINCT job_id) FROM series WHERE name IN ('radial_density_fine', 'radial_density_coarse')",
    );
    assert_eq!(rows[0][0], "15", "every run stores its radial densities");
}
