//! The sensor plane records a falling sphere's crossing at the free-fall time, and
//! none before its start: a hopper's sensor starts when the plug is removed, so what
//! spills over the rim while filling is not counted as discharge.

use orch_dem::math::Vec3;
use orch_dem::Simulation;

use crate::{config, material, particles, sphere};

const GRAVITY: f64 = 9.81;

/// Two spheres at rest, far apart, that cross `z = 0` in free fall after 0.1 s and
/// 0.2 s, under a sensor at `z = 0` from `start_s`; and the mass of each, kg.
fn two_falling_spheres(start_s: f64) -> (Simulation, f64) {
    let m = material(0.5, 0.5);
    let kind = sphere(0.001, m);
    let height = |t: f64| 0.5 * GRAVITY * t * t;
    let positions = [
        Vec3::new(-0.02, 0.0, height(0.1)),
        Vec3::new(0.02, 0.0, height(0.2)),
    ];
    let mut cfg = config(1e-5, m);
    cfg.gravity_m_per_s2 = Vec3::new(0.0, 0.0, -GRAVITY);
    cfg.domain_max_m = Vec3::new(0.05, 0.05, 0.25);
    let p = particles(&kind, &positions, &[Vec3::zeros(); 2]);
    let mass_kg = p.mass_kg[0];
    let mut sim = Simulation::new(cfg, vec![kind], p, Vec::new()).unwrap();
    sim.set_sensor_plane(0.0, start_s);
    (sim, mass_kg)
}

/// The crossings recorded in 0.25 s: `(id, time s)`.
fn crossing_times(start_s: f64) -> Vec<(u64, f64)> {
    let (mut sim, _) = two_falling_spheres(start_s);
    let mut times = Vec::new();
    for _ in 0..25_000 {
        sim.step().unwrap();
        times.extend(sim.take_crossings().iter().map(|c| (c.id, c.time_s)));
    }
    times
}

#[test]
fn the_sensor_records_a_free_fall_at_its_time_and_nothing_before_its_start() {
    let all = crossing_times(0.0);
    assert_eq!(all.len(), 2, "{all:?}");
    for ((id, time), expected) in all.iter().zip([0.1, 0.2]) {
        assert!((time - expected).abs() < 2e-5, "sphere {id}: {time} s");
    }
    // Started at 0.15 s, it sees only the second sphere.
    let late = crossing_times(0.15);
    assert_eq!(late.len(), 1, "{late:?}");
    assert_eq!(late[0].0, 2);
    assert!((late[0].1 - 0.2).abs() < 2e-5, "{late:?}");
}

#[test]
fn what_the_sink_takes_before_the_sensor_starts_is_spill_not_discharge() {
    let (mut sim, mass_kg) = two_falling_spheres(0.15);
    sim.set_sink_plane(0.0);
    for _ in 0..25_000 {
        sim.step().unwrap();
    }
    assert_eq!(sim.remaining(), 0);
    assert_eq!(sim.spilled(), (1, mass_kg));
    assert_eq!(sim.discharged_mass_kg(), mass_kg);
}
