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

/// A vibrating floor 24 mm wide fed by an inflow: spheres pile up on it, spill over
/// its edges through a sensor plane and into a sink. Everything a step carries over
/// (pair and wall histories, the inflow's random stream, sensor and sink marks) is in
/// play when the state is saved.
fn vibrated_feed() -> Simulation {
    let m = material(0.6, 0.5);
    let types = vec![sphere(0.0015, m), sphere(0.0008, m)];
    let mut cfg = config(2e-5, m);
    cfg.gravity_m_per_s2 = Vec3::new(0.0, 0.0, -9.81);
    let mut plate = floor(0.012);
    plate.motion = orch_dem::mesh::Motion::Vibration {
        amplitude_m: Vec3::new(0.0003, 0.0, 0.0005),
        frequency_hz: 50.0,
        start_s: 0.01,
    };
    let mut sim = Simulation::new(cfg, types, Particles::default(), vec![plate]).unwrap();
    let region = Region::Box {
        min_m: Vec3::new(-0.008, -0.008, 0.010),
        max_m: Vec3::new(0.008, 0.008, 0.016),
    };
    let velocity = Vec3::new(0.0, 0.0, -0.5);
    sim.add_inflow(orch_dem::inflow::Inflow {
        region,
        mass_fractions: vec![0.6, 0.4],
        mass_rate_kg_per_s: 0.05,
        velocity_m_per_s: velocity,
        start_s: 0.0,
        end_s: 0.06,
        interval_s: orch_dem::inflow::Inflow::crossing_time_s(&region, velocity).unwrap(),
        seed: 4242,
    })
    .unwrap();
    sim.set_sensor_plane(-0.004, 0.0);
    sim.set_sink_plane(-0.02);
    sim
}

/// Steps `sim` `steps` times, collecting its crossings.
fn advance(sim: &mut Simulation, steps: usize, crossings: &mut Vec<orch_dem::Crossing>) {
    for _ in 0..steps {
        sim.step().unwrap();
        crossings.extend(sim.take_crossings());
    }
}

#[test]
fn a_run_resumed_from_its_saved_state_continues_bit_for_bit() {
    let (whole, steps_before, steps_after) = (5000, 2345, 2655);
    let mut straight = vibrated_feed();
    let mut straight_crossings = Vec::new();
    advance(&mut straight, whole, &mut straight_crossings);

    let mut first = vibrated_feed();
    let mut crossings = Vec::new();
    advance(&mut first, steps_before, &mut crossings);
    let saved = first.saved_state();
    assert_eq!(saved.step_count(), steps_before as u64);
    drop(first);
    // A new simulation of the same case, on another thread count, takes it up.
    let resumed = on_threads(2, || {
        let mut second = vibrated_feed();
        second.restore(saved).unwrap();
        advance(&mut second, steps_after, &mut crossings);
        second
    });

    let (a, b) = (&straight.particles, &resumed.particles);
    assert_eq!(a.id, b.id);
    assert_eq!(a.position_m, b.position_m);
    assert_eq!(a.velocity_m_per_s, b.velocity_m_per_s);
    assert_eq!(a.angular_velocity, b.angular_velocity);
    assert_eq!(straight_crossings, crossings);
    assert_eq!(straight.time_s(), resumed.time_s());
    assert_eq!(straight.step_count(), resumed.step_count());
    assert_eq!(straight.particle_steps(), resumed.particle_steps());
    assert_eq!(straight.discharged_mass_kg(), resumed.discharged_mass_kg());
    assert_eq!(straight.inserted_mass_kg(), resumed.inserted_mass_kg());
    assert_eq!(
        straight.wall_impact_energy_j(),
        resumed.wall_impact_energy_j()
    );
    assert_eq!(
        straight.largest_overlap_ratio(),
        resumed.largest_overlap_ratio()
    );
    // The case did what it is for: a pile on the plate, spheres over its edges, the
    // inflow still feeding when the state was saved (0.047 s of its 0.06 s).
    assert!(a.len() > 50, "{} spheres left", a.len());
    assert!(
        straight_crossings.len() > 5,
        "{} crossings",
        straight_crossings.len()
    );
    assert!(straight.discharged_mass_kg() > 0.0);
    assert!(straight.wall_impact_energy_j() > 0.0);
}

#[test]
fn a_saved_state_of_another_shape_is_refused_and_changes_nothing() {
    let mut fed = vibrated_feed();
    advance(&mut fed, 200, &mut Vec::new());
    let saved = fed.saved_state();
    // The same spheres without the plate: one mesh saved, none here.
    let m = material(0.6, 0.5);
    let mut cfg = config(2e-5, m);
    cfg.gravity_m_per_s2 = Vec3::new(0.0, 0.0, -9.81);
    let types = vec![sphere(0.0015, m), sphere(0.0008, m)];
    let mut other = Simulation::new(cfg, types, Particles::default(), Vec::new()).unwrap();
    let error = other.restore(saved).unwrap_err().to_string();
    assert!(error.contains("does not fit"), "{error}");
    assert_eq!(other.step_count(), 0);
    assert_eq!(other.particles.len(), 0);
}
