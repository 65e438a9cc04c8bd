//! The same case gives the same numbers, bit for bit, run twice and on 1 or 2 threads,
//! with the other threads sleeping between passes or kept polling.

use orch_dem::awake::AwakeWorkers;
use orch_dem::insert::{insert, Region};
use orch_dem::particles::Particles;
use orch_dem::{Simulation, Vec3};

use crate::{config, floor, material, on_threads, sphere};

fn settle(threads: usize, awake: bool) -> Vec<Vec3> {
    on_threads(threads, || {
        let _awake = awake.then(AwakeWorkers::start);
        let m = material(0.6, 0.5);
        let types = vec![sphere(0.002, m), sphere(0.001, m)];
        let mut p = Particles::default();
        let region = Region::Box {
            min_m: Vec3::new(-0.01, -0.01, 0.0),
            max_m: Vec3::new(0.01, 0.01, 0.03),
        };
        insert(&mut p, &types, &[30, 240], &region, 11, 1).unwrap();
        let mut cfg = config(2e-5, m);
        cfg.gravity_m_per_s2 = Vec3::new(0.0, 0.0, -9.81);
        let mut sim = Simulation::new(cfg, types, p, vec![floor(0.045)]).unwrap();
        for _ in 0..6000 {
            sim.step().unwrap();
        }
        sim.particles.position_m.clone()
    })
}

#[test]
fn a_run_is_reproducible_and_independent_of_the_thread_count() {
    let one = settle(1, false);
    assert_eq!(one, settle(1, false));
    assert_eq!(one, settle(2, false));
    assert_eq!(one, settle(2, true));
    // The particles did fall and come to rest on the floor.
    let lowest = one.iter().map(|x| x.z).fold(f64::INFINITY, f64::min);
    assert!(
        lowest < 0.0011 && lowest > 0.0009,
        "lowest centre at {lowest} m"
    );
}

/// 1200 spheres (three chunks of the integration) fall through a sensor plane onto a
/// sink below it: what each step's chunks find is recorded in index order, so the
/// crossings and the discharged mass are the same, bit for bit, on 1, 2 and 3 threads.
fn fall_through(threads: usize) -> (Vec<orch_dem::Crossing>, f64, usize) {
    on_threads(threads, || {
        let m = material(0.6, 0.5);
        let types = vec![sphere(0.001, m), sphere(0.0007, m)];
        let mut p = Particles::default();
        let region = Region::Box {
            min_m: Vec3::new(-0.02, -0.02, 0.02),
            max_m: Vec3::new(0.02, 0.02, 0.05),
        };
        insert(&mut p, &types, &[400, 800], &region, 7, 1).unwrap();
        let mut cfg = config(2e-5, m);
        cfg.gravity_m_per_s2 = Vec3::new(0.0, 0.0, -9.81);
        let mut sim = Simulation::new(cfg, types, p, Vec::new()).unwrap();
        sim.set_sensor_plane(0.01, 0.0);
        sim.set_sink_plane(0.0);
        let mut crossings = Vec::new();
        for _ in 0..6000 {
            sim.step().unwrap();
            crossings.extend(sim.take_crossings());
        }
        (crossings, sim.discharged_mass_kg(), sim.remaining())
    })
}

#[test]
fn crossings_and_the_sink_are_the_same_on_any_thread_count() {
    let one = fall_through(1);
    let (crossings, discharged_kg, remaining) = &one;
    // Every sphere crossed the sensor once and reached the sink (0.12 s of free fall
    // covers 7 cm), and a step's crossings come in id order.
    assert_eq!(crossings.len(), 1200);
    assert_eq!(*remaining, 0);
    assert!(*discharged_kg > 0.0);
    let mut ids: Vec<u64> = crossings.iter().map(|c| c.id).collect();
    ids.sort_unstable();
    ids.dedup();
    assert_eq!(ids.len(), 1200);
    assert_eq!(one, fall_through(2));
    assert_eq!(one, fall_through(3));
}
