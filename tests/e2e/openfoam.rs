//! The CFD stage on real OpenFOAM, chained after native DEM jobs: the air each design
//! point's particle stream drags along, computed from that point's DEM responses.

use crate::support::{count, require_openfoam, solver_lock, text, Project};

/// Two outlets on the native kernel, each followed by its OpenFOAM stage.
const STREAM: &str = "\
name: stream-air
solver: native
executor: {max_parallel: 2, time_limit: 3min, retries: 0}
factors:
  - {name: outlet_diameter, min: 0.018, max: 0.028, unit: m}
fixed: {n_particles: 600, fill_time: 0.15, discharge_time: 0.6}
design: {type: full_factorial, levels: 2}
seed: 5
responses: [discharge_rate, exit_speed, air_entrained_flow, air_ring_speed]
cfd:
  fixed: {end_time: 0.2, cells_across: 16, cells_down: 20}
";

#[test]
fn each_design_point_s_stream_drives_an_openfoam_stage() {
    if !require_openfoam() {
        return;
    }
    let _lock = solver_lock();
    let project = Project::new();
    let file = project.write("stream.yaml", STREAM);
    let output = project.run(&["submit", file.to_str().unwrap()]);
    let stderr = text(&output.stderr);
    assert_eq!(output.status.code(), Some(0), "{stderr}");
    let status = project.status("stream-air");
    assert_eq!(count(&status, "succeeded"), 4, "{status:#}");

    let jobs = status["jobs"].as_array().unwrap();
    let job = |name: &str| jobs.iter().find(|j| j["name"] == name).unwrap();
    // Each CFD stage started after its DEM job ended, and read that job's stream.
    let mut entrained = Vec::new();
    for point in ["p000r0", "p001r0"] {
        let (dem, cfd) = (job(point), job(&format!("{point}-cfd")));
        let started = project.query(&format!(
            "SELECT (SELECT MIN(at) FROM job_events e JOIN jobs j ON j.id = e.job_id WHERE j.name = '{point}-cfd' AND e.to_state = 'rendered') >= (SELECT finished_at FROM jobs WHERE name = '{point}')"
        ));
        assert_eq!(
            started[0][0], "1",
            "{point}-cfd rendered before {point} finished"
        );
        let fv_options = std::fs::read_to_string(
            project
                .project_dir()
                .join(format!("runs/stream-air/{point}-cfd/constant/fvOptions")),
        )
        .unwrap();
        let rate = dem["responses"]["discharge_rate"].as_f64().unwrap();
        assert!(rate > 0.0);
        assert!(
            fv_options.contains("cellZone        stream;"),
            "{fv_options}"
        );
        let flow = cfd["responses"]["air_entrained_flow"].as_f64().unwrap();
        let ring = cfd["responses"]["air_ring_speed"].as_f64().unwrap();
        eprintln!(
            "{point}: D = {} m, {rate:.4} kg/s at {:.3} m/s -> air {flow:.3e} m^3/s out of the bottom, {ring:.4} m/s on the ring",
            dem["factors"]["outlet_diameter"],
            dem["responses"]["exit_speed"].as_f64().unwrap()
        );
        assert!(flow > 0.0 && ring > 0.0, "{cfd:#}");
        entrained.push(flow);
    }
    // The wider outlet's heavier stream entrains more air.
    assert!(entrained[1] > entrained[0], "{entrained:?}");
    // Time series and responses are in SQLite, and orch status shows them.
    let rows = project.query(
        "SELECT COUNT(*) FROM series s JOIN jobs j ON j.id = s.job_id WHERE j.stage = 'cfd' AND s.name = 'air_entrained_flow'",
    );
    assert!(rows[0][0].parse::<usize>().unwrap() > 20, "{rows:?}");
    let table = text(&project.run(&["status", "stream-air"]).stdout);
    assert!(
        table.contains("p001r0-cfd") && table.contains("air_entrained_flow"),
        "{table}"
    );
}

#[test]
fn a_failed_dem_job_fails_its_cfd_stage_and_the_study_goes_on() {
    if !require_openfoam() {
        return;
    }
    let project = Project::new();
    let study = STREAM
        .replace("name: stream-air", "name: stream-fault")
        // Spheres of 10 kPa are accepted (their Rayleigh time is long) but sink a
        // quarter radius into the plug at once: the kernel stops that run on its
        // overlap bound.
        .replace(
            "- {name: outlet_diameter, min: 0.018, max: 0.028, unit: m}",
            "- {name: youngs_modulus, min: 10000, max: 5000000, unit: Pa}",
        );
    let file = project.write("fault.yaml", &study);
    let output = project.run(&["submit", file.to_str().unwrap()]);
    assert_ne!(output.status.code(), Some(0), "{}", text(&output.stderr));
    let status = project.status("stream-fault");
    let jobs = status["jobs"].as_array().unwrap();
    let job = |name: &str| jobs.iter().find(|j| j["name"] == name).unwrap().clone();
    assert_eq!(job("p001r0")["state"], "succeeded");
    assert_eq!(job("p001r0-cfd")["state"], "succeeded");
    let dem = job("p000r0");
    assert_eq!(dem["state"], "failed");
    assert!(
        dem["error"].as_str().unwrap().contains("overlaps"),
        "{dem:#}"
    );
    let cfd = job("p000r0-cfd");
    assert_eq!(cfd["state"], "failed");
    assert!(
        cfd["error"]
            .as_str()
            .unwrap()
            .contains("its upstream job p000r0 failed"),
        "{cfd:#}"
    );
}

/// `coupling:`: each DEM job is followed by its CFD stage, then the DEM again in the
/// air that stage computed (a 9 × 9 × 11 grid of velocities), then the CFD on the new
/// stream, until the exit speed 60 mm under the outlet moves by less than 2 %.
const COUPLED: &str = "\
name: coupled
solver: native
executor: {max_parallel: 2, time_limit: 5min, retries: 0}
factors:
  - {name: outlet_diameter, min: 0.020, max: 0.026, unit: m}
fixed:
  n_particles: 1500
  fill_time: 0.2
  discharge_time: 0.8
  sensor_depth: 0.06
  air_density: 1.2
design: {type: full_factorial, levels: 2}
seed: 9
responses: [discharge_rate, exit_speed, air_entrained_flow]
cfd:
  fixed: {end_time: 0.2, cells_across: 16, cells_down: 20}
coupling: {iterations: 2, response: exit_speed, tolerance: 0.02}
";

#[test]
fn a_coupled_study_runs_the_dem_again_in_the_cfd_air_until_the_exit_speed_settles() {
    if !require_openfoam() {
        return;
    }
    let _lock = solver_lock();
    let project = Project::new();
    let file = project.write("coupled.yaml", COUPLED);
    let output = project.run(&["submit", file.to_str().unwrap()]);
    let stderr = text(&output.stderr);
    assert_eq!(output.status.code(), Some(0), "{stderr}");
    let status = project.status("coupled");
    let jobs = status["jobs"].as_array().unwrap();
    let job = |name: &str| {
        jobs.iter()
            .find(|j| j["name"] == name)
            .unwrap_or_else(|| panic!("no job {name}: {status:#}"))
    };
    for point in ["p000r0", "p001r0"] {
        let still = job(point);
        let cfd = job(&format!("{point}-cfd"));
        let moving = job(&format!("{point}-air1"));
        assert_eq!(still["state"], "succeeded", "{still:#}");
        assert_eq!(cfd["state"], "succeeded", "{cfd:#}");
        assert_eq!(moving["state"], "succeeded", "{moving:#}");
        let field = std::fs::read_to_string(
            project
                .project_dir()
                .join(format!("runs/coupled/{point}-air1/air-field.csv")),
        )
        .unwrap();
        assert_eq!(field.lines().count(), 1 + 9 * 9 * 11);
        assert!(field.starts_with("x,y,z,ux,uy,uz\n"));
        // The stream drags the air down: the grid's mean vertical velocity is negative.
        let uz: Vec<f64> = field
            .lines()
            .skip(1)
            .map(|l| l.split(',').nth(5).unwrap().parse().unwrap())
            .collect();
        let mean_uz = uz.iter().sum::<f64>() / uz.len() as f64;
        assert!(mean_uz < 0.0, "mean air velocity {mean_uz} m/s");
        let speed = |j: &serde_json::Value| j["responses"]["exit_speed"].as_f64().unwrap();
        let change = (speed(moving) - speed(still)) / speed(still);
        eprintln!(
            "{point}: exit speed {:.5} m/s in still air, {:.5} in the CFD air ({:+.3} %); mean air uz {mean_uz:.4} m/s",
            speed(still),
            speed(moving),
            100.0 * change
        );
        assert_ne!(
            speed(moving),
            speed(still),
            "the moving air changed nothing"
        );
        // Settled or not, the chain ends after two DEM runs in air at most; a settled
        // chain cancels the rest with why.
        let next = job(&format!("{point}-cfd2"));
        if change.abs() < 0.02 {
            assert_eq!(next["state"], "cancelled", "{next:#}");
            let note = next["error"].as_str().unwrap_or("");
            assert!(
                note.starts_with(&format!("coupling settled at {point}-air1: exit_speed")),
                "{note}"
            );
            assert_eq!(job(&format!("{point}-air2"))["state"], "cancelled");
        } else {
            assert_eq!(next["state"], "succeeded", "{next:#}");
        }
    }
}
