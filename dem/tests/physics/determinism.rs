//! The same case gives the same numbers, bit for bit, run twice and on 1 or 2 threads.

use orch_dem::insert::{insert, Region};
use orch_dem::particles::Particles;
use orch_dem::{Simulation, Vec3};

use crate::{config, floor, material, sphere};

fn settle(threads: usize) -> Vec<Vec3> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        let m = material(0.6, 0.5);
        let types = vec![sphere(0.002, m), sphere(0.001, m)];
        let mut p = Particles::default();
        let region = Region::Box {
            min_m: Vec3::new(-0.01, -0.01, 0.0),
            max_m: Vec3::new(0.01, 0.01, 0.03),
        };
        insert(&mut p, &types, &[30, 240], &region, 11, 1).unwrap();
        let mut cfg = config(2e-5, m);
        cfg.gravity_m_s2 = Vec3::new(0.0, 0.0, -9.81);
        let mut sim = Simulation::new(cfg, types, p, vec![floor(0.045)]).unwrap();
        for _ in 0..6000 {
            sim.step().unwrap();
        }
        sim.particles.position_m.clone()
    })
}

#[test]
fn a_run_is_reproducible_and_independent_of_the_thread_count() {
    let one = settle(1);
    assert_eq!(one, settle(1));
    assert_eq!(one, settle(2));
    // The particles did fall and come to rest on the floor.
    let lowest = one.iter().map(|x| x.z).fold(f64::INFINITY, f64::min);
    assert!(
        lowest < 0.0011 && lowest > 0.0009,
        "lowest centre at {lowest} m"
    );
}
