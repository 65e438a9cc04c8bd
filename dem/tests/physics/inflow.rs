//! Continuous inflow: the mass fed matches rate × time, new particles never overlap,
//! a type without room does not stop the others, and a run with an inflow is the same
//! on 1 and 2 threads.

use orch_dem::case::Case;
use orch_dem::inflow::{Inflow, InflowState};
use orch_dem::insert::Region;
use orch_dem::particles::Particles;
use orch_dem::{Simulation, Vec3};

use crate::{config, floor, material, on_threads, sphere};

const RATE_KG_S: f64 = 0.1;
const WINDOW_S: f64 = 0.1;

fn feeding(threads: usize, check_overlaps: bool) -> (Simulation, Vec<Vec3>) {
    on_threads(threads, || {
        let m = material(0.6, 0.5);
        let types = vec![sphere(0.002, m), sphere(0.001, m)];
        let mut cfg = config(2e-5, m);
        cfg.gravity_m_per_s2 = Vec3::new(0.0, 0.0, -9.81);
        let mut sim =
            Simulation::new(cfg, types, Particles::default(), vec![floor(0.045)]).unwrap();
        let region = Region::Box {
            min_m: Vec3::new(-0.012, -0.012, 0.030),
            max_m: Vec3::new(0.012, 0.012, 0.036),
        };
        let velocity = Vec3::new(0.0, 0.0, -1.0);
        sim.add_inflow(Inflow {
            region,
            mass_fractions: vec![0.5, 0.5],
            mass_rate_kg_per_s: RATE_KG_S,
            velocity_m_per_s: velocity,
            start_s: 0.0,
            end_s: WINDOW_S,
            interval_s: Inflow::crossing_time_s(&region, velocity).unwrap(),
            seed: 10007,
        })
        .unwrap();
        for _ in 0..7500 {
            let before = sim.particles.len();
            let first_new = sim.particles.max_id().map_or(1, |id| id + 1);
            sim.step().unwrap();
            if check_overlaps && sim.particles.len() > before {
                let p = &sim.particles;
                for i in 0..p.len() {
                    if p.id[i] < first_new {
                        continue;
                    }
                    assert_eq!(p.velocity_m_per_s[i].z, velocity.z + 0.5 * 2e-5 * -9.81);
                    for j in 0..p.len() {
                        if j == i {
                            continue;
                        }
                        let gap = (p.position_m[i] - p.position_m[j]).norm()
                            - (p.radius_m[i] + p.radius_m[j]);
                        assert!(gap >= 0.0, "new particle {} overlaps {}", p.id[i], p.id[j]);
                    }
                }
            }
        }
        let positions = sim.particles.position_m.clone();
        (sim, positions)
    })
}

#[test]
fn the_mass_fed_is_rate_times_time_within_one_particle_and_nothing_overlaps() {
    let (sim, _) = feeding(1, true);
    let coarse = sim.types()[0].mass_kg();
    let fine = sim.types()[1].mass_kg();
    let target = RATE_KG_S * WINDOW_S;
    let inserted = sim.inserted_mass_kg();
    assert!(
        inserted >= target && inserted - target < coarse,
        "inserted {inserted} kg for {target} kg"
    );
    let by_type = sim.inflows()[0].inserted_mass_by_type_kg();
    assert!((by_type[0] - 0.5 * target).abs() < coarse, "{by_type:?}");
    assert!(
        (by_type[1] - 0.5 * target).abs() < coarse + fine,
        "{by_type:?}"
    );
    // Every particle present came from the inflow (there is no sink).
    let mass: f64 = sim.particles.mass_kg.iter().sum();
    assert!((mass - inserted).abs() < 1e-12);
}

#[test]
fn a_run_with_an_inflow_is_the_same_on_one_and_two_threads() {
    let (_, one) = feeding(1, false);
    let (_, two) = feeding(2, false);
    assert!(one.len() > 500);
    assert_eq!(one, two);
}

const CASE: &str = r#"
[run]
timestep = 2e-5
end_time = 0.01
seed = 10007

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

[[inflow]]
mass_rate = 0.02
mass_fractions = [1.0]
velocity = [0.5, 0.0, 0.0]
end = 0.005
region = { kind = "box", min = [-0.01, -0.01, 0.0], max = [0.0, 0.01, 0.02] }
"#;

#[test]
fn an_inflow_case_parses_runs_and_names_its_bad_fields() {
    let case = Case::parse(CASE).unwrap();
    let mut sim = case.build(vec![]).unwrap();
    assert_eq!(sim.particles.len(), 0);
    // The default interval: 1 cm along x at 0.5 m/s.
    assert!((sim.inflows()[0].inflow().interval_s - 0.02).abs() < 1e-15);
    for _ in 0..500 {
        sim.step().unwrap();
    }
    let inserted = sim.inserted_mass_kg();
    let one = sim.types()[0].mass_kg();
    assert!(inserted >= 0.02 * 0.005 && inserted < 0.02 * 0.005 + one);
    for (from, to, field) in [
        (
            "velocity = [0.5, 0.0, 0.0]",
            "velocity = [0.0, 0.0, 0.0]",
            "inflow[0].interval",
        ),
        ("mass_rate = 0.02", "mass_rate = -1.0", "inflow[0]"),
        (
            "mass_fractions = [1.0]",
            "mass_fractions = [0.5, 0.5]",
            "inflow[0]",
        ),
    ] {
        let message = Case::parse(&CASE.replace(from, to))
            .unwrap_err()
            .to_string();
        assert!(message.contains(&format!("`{field}`")), "{message}");
    }
}

#[test]
fn a_type_without_room_sits_the_batch_out_while_the_others_go_on() {
    // A 10 mm box whose 9.8 mm spheres fit only near its centre, where a 1 mm sphere
    // already sits: the large type finds no room, and the small one fills the batch.
    let m = material(0.6, 0.5);
    let types = vec![sphere(0.0049, m), sphere(0.0005, m)];
    let mut particles = Particles::default();
    particles.push(1, 1, &types[1], Vec3::new(0.0, 0.0, 0.035));
    let region = Region::Box {
        min_m: Vec3::new(-0.005, -0.005, 0.030),
        max_m: Vec3::new(0.005, 0.005, 0.040),
    };
    let small_kg = types[1].mass_kg();
    let mut inflow = InflowState::new(
        Inflow {
            region,
            mass_fractions: vec![0.5, 0.5],
            mass_rate_kg_per_s: 40.0 * small_kg / 0.01,
            velocity_m_per_s: Vec3::zeros(),
            start_s: 0.0,
            end_s: 0.01,
            interval_s: 0.01,
            seed: 7,
        },
        types.len(),
    );
    let mut next_id = 2;
    let placed = inflow.insert_due(0.0, &types, &mut particles, &mut next_id);
    let by_type = inflow.inserted_mass_by_type_kg();
    assert_eq!(by_type[0], 0.0, "no room for a large sphere");
    assert_eq!(placed, 40, "the small ones fill the batch's mass");
    assert!((inflow.asked_mass_kg() - 40.0 * small_kg).abs() < 1e-9 * small_kg);
    assert!(inflow.inserted_mass_kg() >= inflow.asked_mass_kg() - 1e-9 * small_kg);
}
