//! Bad case files, bad meshes and unstable runs are errors that say what is wrong.

use orch_dem::case::Case;
use orch_dem::material::PairConstants;
use orch_dem::{Simulation, Unstable, Vec3};

use crate::{config, floor, hertz_largest_overlap_m, material, particles, sphere};

const CASE: &str = r#"
[run]
timestep = 2e-5
end_time = 0.01
seed = 7

[domain]
min = [-0.02, -0.02, -0.02]
max = [0.02, 0.02, 0.04]

[[types]]
name = "glass"
radius = 0.001
density = 2500
youngs_modulus = 5e6
poisson_ratio = 0.3
restitution = 0.6
friction = 0.5

[wall_material]
youngs_modulus = 5e6
poisson_ratio = 0.3
restitution = 0.6
friction = 0.5

[[meshes]]
name = "floor"
file = "floor.stl"

[insert]
count = 20
mass_fractions = [1.0]
region = { kind = "box", min = [-0.01, -0.01, 0.0], max = [0.01, 0.01, 0.02] }
"#;

fn error_of(text: &str) -> String {
    Case::parse(text).unwrap_err().to_string()
}

#[test]
fn a_good_case_parses_and_builds() {
    let case = Case::parse(CASE).unwrap();
    let stl = "solid floor\nfacet normal 0 0 1\nouter loop\nvertex -0.02 -0.02 0\nvertex 0.02 -0.02 0\nvertex 0.02 0.02 0\nendloop\nendfacet\nendsolid floor\n";
    let wall = case.wall_mesh(0, stl.as_bytes()).unwrap();
    let sim = case.build(vec![wall]).unwrap();
    assert_eq!(sim.particles.len(), 20);
}

#[test]
fn bad_values_name_their_field() {
    let cases = [
        (
            CASE.replace("radius = 0.001", "radius = -0.001"),
            "types[0].radius",
        ),
        (
            CASE.replace(
                "restitution = 0.6\nfriction = 0.5\n\n[wall",
                "restitution = 1.5\nfriction = 0.5\n\n[wall",
            ),
            "types[0].restitution",
        ),
        (
            CASE.replace("mass_fractions = [1.0]", "mass_fractions = [0.5]"),
            "insert.mass_fractions",
        ),
        (
            CASE.replace("end_time = 0.01", "end_time = nan"),
            "run.end_time",
        ),
        (
            CASE.replace("seed = 7", "seed = 7\ntimestpe = 1e-5"),
            "unknown field `timestpe`",
        ),
        (
            CASE.replace("max = [0.02, 0.02, 0.04]", "max = [0.02, -0.03, 0.04]"),
            "domain",
        ),
    ];
    for (text, expected) in cases {
        let message = error_of(&text);
        assert!(
            message.contains(expected),
            "expected `{expected}` in: {message}"
        );
    }
}

#[test]
fn bad_meshes_are_refused_with_the_reason() {
    let case = Case::parse(CASE).unwrap();
    let unterminated = "solid floor\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 1 1 0\nendloop\nendfacet\n";
    let degenerate = "solid floor\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 2 0 0\nendloop\nendfacet\nendsolid floor\n";
    let nan = "solid floor\nfacet normal 0 0 1\nouter loop\nvertex 0 0 nan\nvertex 1 0 0\nvertex 1 1 0\nendloop\nendfacet\nendsolid floor\n";
    for (stl, expected) in [
        (unterminated, "endsolid"),
        (degenerate, "facet 1"),
        (nan, "facet 1"),
    ] {
        let message = case.wall_mesh(0, stl.as_bytes()).unwrap_err().to_string();
        assert!(message.contains("mesh `floor` (floor.stl)"), "{message}");
        assert!(
            message.contains(expected),
            "expected `{expected}` in: {message}"
        );
    }
}

#[test]
fn a_particle_larger_than_the_domain_is_refused() {
    let text = CASE.replace("radius = 0.001", "radius = 0.05");
    let case = Case::parse(&text).unwrap();
    let message = match case.build(vec![]) {
        Ok(_) => panic!("a 10 cm sphere in a 4 cm domain was accepted"),
        Err(e) => e.to_string(),
    };
    assert!(
        message.contains("does not fit") || message.contains("larger than the domain"),
        "{message}"
    );
}

/// A time step far beyond the Rayleigh time lets a sphere sink into the floor; the run
/// stops at that step, naming the particle.
#[test]
fn an_unstable_run_stops_with_the_step_and_the_particle() {
    let m = material(0.6, 0.5);
    let kind = sphere(0.001, m);
    let p = particles(
        &kind,
        &[Vec3::new(0.0, 0.0, 0.0011)],
        &[Vec3::new(0.0, 0.0, -2.0)],
    );
    let mut sim = Simulation::new(config(2e-4, m), vec![kind], p, vec![floor(0.01)]).unwrap();
    let error = (0..100)
        .find_map(|_| sim.step().err())
        .expect("the run went unstable");
    assert!(
        matches!(
            error,
            Unstable::Overlap { id: 1, .. } | Unstable::Speed { id: 1, .. }
        ),
        "{error}"
    );
    let message = error.to_string();
    assert!(
        message.contains("at step") && message.contains("particle 1"),
        "{message}"
    );
}

/// A soft sphere thrown at a wall faster than its contact can hold, at a step far
/// below the Hertz time, overlaps past the bound: the error blames the stiffness, not
/// the step, and names the speed at which a head-on Hertz impact reaches the bound.
#[test]
fn an_overlap_at_a_safe_step_names_the_speed_the_stiffness_can_hold() {
    let m = material(0.6, 0.5);
    let kind = sphere(0.001, m);
    let p = particles(
        &kind,
        &[Vec3::new(0.0, 0.0, 0.0011)],
        &[Vec3::new(0.0, 0.0, -5.0)],
    );
    let mut sim = Simulation::new(config(1e-7, m), vec![kind], p, vec![floor(0.01)]).unwrap();
    let error = (0..20_000)
        .find_map(|_| sim.step().err())
        .expect("a 5 m/s impact of a 5 MPa sphere overlaps past 0.25 radii");
    let Unstable::Overlap {
        bound_speed_m_per_s,
        ..
    } = error
    else {
        panic!("expected an overlap, got: {error}");
    };
    let wall_youngs_pa = PairConstants::between(&m, &m).effective_youngs_pa;
    let overlap_m =
        hertz_largest_overlap_m(kind.mass_kg(), 0.001, wall_youngs_pa, bound_speed_m_per_s);
    assert!((overlap_m / 0.00025 - 1.0).abs() < 1e-9, "{overlap_m}");
    assert!(bound_speed_m_per_s < 5.0, "{bound_speed_m_per_s}");
    assert!(
        sim.largest_overlap_ratio() > 0.25,
        "the run's deepest overlap is kept"
    );
    let message = error.to_string();
    assert!(
        message.contains("youngs_modulus")
            && message.contains(&format!("{bound_speed_m_per_s:.3} m/s")),
        "{message}"
    );
}
