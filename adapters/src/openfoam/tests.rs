use std::io::Cursor;
use std::path::Path;

use super::*;
use crate::ResolvedParameters;

fn cfd_case() -> Case {
    Case {
        parameters: ResolvedParameters::defaults(PARAMETERS),
        seed: 1,
        text: Default::default(),
    }
}

fn stream() -> StreamInputs {
    StreamInputs {
        discharge_rate_kg_per_s: 0.1,
        exit_speed_m_per_s: 0.8,
        stream_radius_m: 0.01,
        coarse_diameter_m: 0.004,
        fine_diameter_m: 0.002,
        fine_mass_fraction: 0.5,
        particle_density: 2500.0,
    }
}

fn fixtures() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/fixtures/openfoam")
}

/// Every rendered file, concatenated with its name, for the snapshot.
#[test]
fn rendered_case_snapshot() {
    let dir = tempfile::tempdir().unwrap();
    render(&cfd_case(), &stream(), dir.path()).unwrap();
    let mut all = String::new();
    for (file, _) in FILES {
        all.push_str(&format!("==> {file} <==\n"));
        all.push_str(&std::fs::read_to_string(dir.path().join(file)).unwrap());
    }
    insta::assert_snapshot!("stream_case", all);
}

#[test]
fn parallel_case_decomposes_and_reconstructs() {
    let dir = tempfile::tempdir().unwrap();
    let mut case = cfd_case();
    case.parameters.set("cores", 2.0);
    render(&case, &stream(), dir.path()).unwrap();
    let allrun = std::fs::read_to_string(dir.path().join("Allrun")).unwrap();
    assert!(allrun.contains("decomposePar") && allrun.contains("-np 2 pimpleFoam -parallel"));
    assert!(allrun.contains("reconstructPar"));
    let decompose = std::fs::read_to_string(dir.path().join("system/decomposeParDict")).unwrap();
    assert!(decompose.contains("numberOfSubdomains 2;"), "{decompose}");
    assert_eq!(command(&case).cores, 2);
}

#[test]
fn a_probe_ring_wider_than_the_domain_is_refused() {
    let mut case = cfd_case();
    case.parameters.set("ring_radius_factor", 5.0);
    let error = check(&case, &stream()).unwrap_err().to_string();
    assert!(error.contains("domain_half_width"), "{error}");
    let no_flow = StreamInputs {
        discharge_rate_kg_per_s: 0.0,
        ..stream()
    };
    assert!(check(&cfd_case(), &no_flow).is_err());
}

#[test]
fn the_drag_source_follows_the_stream() {
    let context = context(&cfd_case(), &stream()).into_json();
    let rate = context["drag_rate"].as_f64().unwrap();
    let speed = context["particle_speed"].as_f64().unwrap();
    // Free fall over 0.1 m from 0.8 m/s averages 1.252 m/s.
    assert!((speed - 1.2522).abs() < 1e-3, "{speed}");
    // Twice the mass flow, twice the drag.
    let double = StreamInputs {
        discharge_rate_kg_per_s: 0.2,
        ..stream()
    };
    let rate2 = super::context(&cfd_case(), &double).into_json()["drag_rate"]
        .as_f64()
        .unwrap();
    assert!((rate2 / rate - 2.0).abs() < 1e-12);
}

/// Output of a real run (tests/fixtures/openfoam/, the default case, 0.3 s).
#[test]
fn real_output_parses_into_responses_and_series() {
    let results = parse(&fixtures()).unwrap();
    let response = |name: &str| results.responses.iter().find(|(n, _)| n == name).unwrap().1;
    assert!(response("air_entrained_flow") > 0.0);
    assert!(response("air_ring_speed") > 0.0);
    assert!(results.series.iter().all(|s| s.points.len() > 50));
}

#[test]
fn restarted_runs_join_their_start_time_directories() {
    let dir = tempfile::tempdir().unwrap();
    for (start, rows) in [("0", "0.1 1\n0.2 2\n0.3 3\n"), ("0.2", "0.25 20\n0.3 30\n")] {
        let sub = dir.path().join(start);
        std::fs::create_dir_all(&sub).unwrap();
        std::fs::write(sub.join("f.dat"), format!("# Time value\n{rows}")).unwrap();
    }
    let rows = read_time_series_dirs(dir.path(), "f.dat", read_surface_field_value).unwrap();
    assert_eq!(rows, vec![(0.1, 1.0), (0.25, 20.0), (0.3, 30.0)]);
}

#[test]
fn truncated_and_malformed_output_is_an_error_naming_the_file_and_line() {
    let path = Path::new("surfaceFieldValue.dat");
    let flow = std::fs::read_to_string(
        fixtures().join("postProcessing/entrained/0/surfaceFieldValue.dat"),
    )
    .unwrap();
    // Cut in the middle of the last row's value: still a number, so cut after the time.
    let lines = flow.lines().count();
    let last = flow.lines().last().unwrap();
    let cut = format!(
        "{}{}",
        &flow[..flow.len() - last.len() - 1],
        last.split_whitespace().next().unwrap()
    );
    let error = read_surface_field_value(Cursor::new(cut), path).unwrap_err();
    assert!(
        error.to_string().starts_with(&format!(
            "surfaceFieldValue.dat:{lines}: expected `time value`"
        )),
        "{error}"
    );
    let error =
        read_surface_field_value(Cursor::new("# Time sum(phi)\n0.1 nan\n"), path).unwrap_err();
    assert!(
        error.to_string().contains(":2: expected the value"),
        "{error}"
    );
    let error = read_surface_field_value(Cursor::new("# Time sum(phi)\n"), path).unwrap_err();
    assert!(error.to_string().contains("no data rows"), "{error}");

    let probes = std::fs::read_to_string(fixtures().join("postProcessing/ring/0/U")).unwrap();
    let cut = &probes[..probes.len() - 30];
    let lines = cut.lines().count();
    let error = read_probes(Cursor::new(cut), Path::new("U")).unwrap_err();
    assert!(
        error.to_string().starts_with(&format!("U:{lines}:")),
        "{error}"
    );
    let error = read_probes(Cursor::new("0.1 (1 2 3)\n"), Path::new("U")).unwrap_err();
    assert!(error.to_string().contains("not a probes file"), "{error}");
    let bad = "# Probe 0 (0 0 0)\n#  Time\n0.1 (1 2)\n";
    let error = read_probes(Cursor::new(bad), Path::new("U")).unwrap_err();
    assert!(
        error.to_string().contains("U:3: expected a vector"),
        "{error}"
    );

    let missing = tempfile::tempdir().unwrap();
    let error = parse(missing.path()).unwrap_err().to_string();
    assert!(error.contains("postProcessing/entrained"), "{error}");
}

#[test]
fn the_air_grid_is_regular_and_inside_the_domain() {
    let points = grid_points(0.04, 0.1);
    assert_eq!(points.len(), GRID_ACROSS * GRID_ACROSS * GRID_DOWN);
    // x fastest, then y, then z; half a spacing in from every face.
    let dx = 0.08 / GRID_ACROSS as f64;
    assert!((points[0][0] - (-0.04 + 0.5 * dx)).abs() < 1e-15);
    assert!((points[1][0] - points[0][0] - dx).abs() < 1e-15);
    assert!((points[GRID_ACROSS][1] - points[0][1] - dx).abs() < 1e-15);
    for p in &points {
        assert!(p[0].abs() < 0.04 && p[1].abs() < 0.04, "{p:?}");
        assert!(p[2] < 0.0 && p[2] > -0.1, "{p:?}");
    }
}

#[test]
fn the_air_field_is_the_last_row_of_the_grid_probes_at_their_positions() {
    let dir = tempfile::tempdir().unwrap();
    let probes = dir.path().join(GRID_PROBES).join("0");
    std::fs::create_dir_all(&probes).unwrap();
    std::fs::write(
        probes.join("U"),
        "# Probe 0 (0.01 0 -0.05)\n# Probe 1 (-0.01 0.002 -0.05)\n#  Probe   Time\n\
         0.1  (0 0 -0.1)  (0 0 -0.2)\n0.3  (0.001 0 -0.5)  (0 -0.002 -0.25)\n",
    )
    .unwrap();
    assert_eq!(
        air_field_csv(dir.path()).unwrap(),
        "x,y,z,ux,uy,uz\n1e-2,0e0,-5e-2,1e-3,0e0,-5e-1\n-1e-2,2e-3,-5e-2,0e0,-2e-3,-2.5e-1\n"
    );
    std::fs::write(
        probes.join("U"),
        "# Probe 0 (0.01 0 -0.05)\n# Probe 1 (-0.01 0.002)\n0.1  (0 0 -0.1)  (0 0 -0.2)\n",
    )
    .unwrap();
    let error = air_field_csv(dir.path()).unwrap_err().to_string();
    assert!(error.contains("U:2"), "{error}");
    assert!(error.contains("expected a position `(x y z)`"), "{error}");
}
