//! Contacts between particles exert equal and opposite forces, so with no gravity and
//! no walls the particles' total momentum stays what it was, to rounding: whether the
//! pair pass summed both members of a pair within one of its blocks or left the second
//! member's share for the gather.

use orch_dem::insert::{insert, Region};
use orch_dem::particles::Particles;
use orch_dem::{Simulation, Vec3};

use crate::{config, material, sphere};

/// Σ m v, kg m/s, and Σ m |v|, the scale its rounding is measured against.
fn momentum(sim: &Simulation) -> (Vec3, f64) {
    let p = &sim.particles;
    p.mass_kg
        .iter()
        .zip(&p.velocity_m_per_s)
        .fold((Vec3::zeros(), 0.0), |(sum, scale), (&m, v)| {
            (sum + m * v, scale + m * v.norm())
        })
}

#[test]
fn colliding_spheres_keep_their_total_momentum_across_the_pair_pass_blocks() {
    let m = material(0.6, 0.5);
    let mut rolling = m;
    rolling.rolling_friction = 0.1;
    let types = vec![sphere(0.001, m), sphere(0.0007, rolling)];
    let mut p = Particles::default();
    let region = Region::Box {
        min_m: Vec3::repeat(-0.012),
        max_m: Vec3::repeat(0.012),
    };
    // 1200 spheres: the pair pass's blocks are 256 particles, so many pairs join two.
    insert(&mut p, &types, &[400, 800], &region, 3, 1).unwrap();
    for (i, (v, w)) in p
        .velocity_m_per_s
        .iter_mut()
        .zip(&mut p.angular_velocity)
        .enumerate()
    {
        let a = i as f64;
        *v = Vec3::new((1.3 * a).sin(), (2.1 * a).cos(), (0.7 * a).sin()) * 0.5;
        *w = Vec3::new((0.9 * a).cos(), (1.7 * a).sin(), (2.3 * a).cos()) * 200.0;
    }
    let mut sim = Simulation::new(config(2e-5, m), types, p, Vec::new()).unwrap();
    let (before, scale) = momentum(&sim);
    let energy = sim.particles.kinetic_energy_j();
    let mut touching_steps = 0;
    for _ in 0..1500 {
        sim.step().unwrap();
        touching_steps += usize::from(sim.particles.force_n.iter().any(|f| f.norm() > 0.0));
    }
    let (after, _) = momentum(&sim);
    assert!(
        (after - before).norm() < 1e-12 * scale,
        "momentum {before:?} became {after:?} (scale {scale:e} kg m/s)"
    );
    // Not vacuous: the spheres collided throughout, and the kinetic energy fell.
    assert_eq!(touching_steps, 1500);
    assert!(sim.particles.kinetic_energy_j() < 0.9 * energy);
    assert!(sim.timers().rebuilds > 5, "the spheres moved about");
}
