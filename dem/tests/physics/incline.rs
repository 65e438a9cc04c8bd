//! A sphere on an incline (gravity tilted by θ over a horizontal floor). A sphere rolls
//! on any incline; friction decides whether its contact point sticks: it rolls without
//! slipping, accelerating at `5/7 g sin θ`, while `tan θ < 7/2 μ`, and slides above,
//! accelerating at `g (sin θ − μ cos θ)`.

use approx::assert_relative_eq;
use orch_dem::{Simulation, Vec3};

use crate::{config, floor, material, particles, sphere};

const RADIUS: f64 = 0.001;
const G: f64 = 9.81;

/// Acceleration along the slope and slip speed of the contact point after 20 ms on a
/// slope of `tan θ`, with friction `mu`.
fn slope(tan_theta: f64, mu: f64) -> (f64, f64) {
    let theta = tan_theta.atan();
    let m = material(0.5, mu);
    let kind = sphere(RADIUS, m);
    let mut cfg = config(1e-6, m);
    cfg.gravity_m_per_s2 = Vec3::new(G * theta.sin(), 0.0, -G * theta.cos());
    // Start resting on the floor at the static overlap (1.5 µm under its weight).
    let p = particles(
        &kind,
        &[Vec3::new(-0.01, 0.0, RADIUS - 1.5e-6)],
        &[Vec3::zeros()],
    );
    let mut sim = Simulation::new(cfg, vec![kind], p, vec![floor(0.05)]).unwrap();
    let mut speeds = Vec::new();
    for step in 1..=20_000 {
        sim.step().unwrap();
        if step % 5000 == 0 {
            speeds.push((sim.time_s(), sim.particles.velocity_m_per_s[0].x));
        }
    }
    let (t0, v0) = speeds[1];
    let (t1, v1) = speeds[3];
    let acceleration = (v1 - v0) / (t1 - t0);
    let slip = sim.particles.velocity_m_per_s[0].x - RADIUS * sim.particles.angular_velocity[0].y;
    (acceleration, slip / sim.particles.velocity_m_per_s[0].x)
}

#[test]
fn below_the_limit_the_contact_sticks_and_the_sphere_rolls() {
    let mu = 0.2;
    let tan_theta = 0.5 * 3.5 * mu;
    let (acceleration, relative_slip) = slope(tan_theta, mu);
    let theta = f64::atan(tan_theta);
    assert_relative_eq!(
        acceleration,
        5.0 / 7.0 * G * theta.sin(),
        max_relative = 0.02
    );
    assert!(relative_slip.abs() < 0.01, "slip {relative_slip}");
}

#[test]
fn above_the_limit_the_contact_slides() {
    let mu = 0.2;
    let tan_theta = 2.0 * 3.5 * mu;
    let (acceleration, relative_slip) = slope(tan_theta, mu);
    let theta = f64::atan(tan_theta);
    assert_relative_eq!(
        acceleration,
        G * (theta.sin() - mu * theta.cos()),
        max_relative = 0.02
    );
    assert!(relative_slip > 0.1, "slip {relative_slip}");
}

/// A sphere rolling on a level floor against a constant directional rolling torque
/// `μr Fn r` decelerates at `5/7 μr g` (the torque is shared between spin and slide).
#[test]
fn rolling_friction_decelerates_a_rolling_sphere_at_five_sevenths_mu_r_g() {
    let mu_r = 0.1;
    let mut m = material(0.5, 0.5);
    m.rolling_friction = mu_r;
    let kind = sphere(RADIUS, m);
    let mut cfg = config(1e-6, m);
    cfg.gravity_m_per_s2 = Vec3::new(0.0, 0.0, -G);
    let p = particles(
        &kind,
        &[Vec3::new(-0.01, 0.0, RADIUS - 1.5e-6)],
        &[Vec3::new(0.1, 0.0, 0.0)],
    );
    let mut sim = Simulation::new(cfg, vec![kind], p, vec![floor(0.05)]).unwrap();
    sim.particles.angular_velocity[0] = Vec3::new(0.0, 0.1 / RADIUS, 0.0);
    let mut speeds = Vec::new();
    for step in 1..=10_000 {
        sim.step().unwrap();
        if step % 2500 == 0 {
            speeds.push((sim.time_s(), sim.particles.velocity_m_per_s[0].x));
        }
    }
    let (t0, v0) = speeds[1];
    let (t1, v1) = speeds[3];
    assert_relative_eq!(
        (v0 - v1) / (t1 - t0),
        5.0 / 7.0 * mu_r * G,
        max_relative = 0.03
    );
}
