//! Binary impacts against Hertz's theory and the restitution they were given.

use approx::assert_relative_eq;
use orch_dem::force::hertz_contact_time_s;
use orch_dem::material::PairConstants;
use orch_dem::{Simulation, Vec3};

use crate::{config, floor, hertz_largest_overlap_m, material, particles, run_until, sphere};

const RADIUS: f64 = 0.001;

/// Two equal elastic spheres meet head on at a relative speed of 1 m/s: the contact
/// lasts Hertz's `2.87 (m*² / (R* E*² v))^(1/5)` and they part at the speed they met.
#[test]
fn head_on_elastic_impact_lasts_hertz_time_and_conserves_speed() {
    let m = material(1.0, 0.0);
    let kind = sphere(RADIUS, m);
    let dt = 2e-7;
    let p = particles(
        &kind,
        &[Vec3::new(-0.00101, 0.0, 0.0), Vec3::new(0.00101, 0.0, 0.0)],
        &[Vec3::new(0.5, 0.0, 0.0), Vec3::new(-0.5, 0.0, 0.0)],
    );
    let mut sim = Simulation::new(config(dt, m), vec![kind], p, vec![]).unwrap();
    // The stepper orders particles as it likes (and may reorder them at a rebuild):
    // the left one has id 1, the right one id 2.
    let index = |s: &Simulation, id| s.particles.index_of(id).unwrap();
    let gap = |s: &Simulation| {
        (s.particles.position_m[index(s, 2)] - s.particles.position_m[index(s, 1)]).x - 2.0 * RADIUS
    };
    run_until(&mut sim, 1_000_000, |s| gap(s) < 0.0);
    let start = sim.time_s();
    run_until(&mut sim, 1_000_000, |s| gap(s) >= 0.0);
    let duration = sim.time_s() - start;

    let k = PairConstants::between(&m, &m);
    let expected = hertz_contact_time_s(
        kind.mass_kg() / 2.0,
        RADIUS / 2.0,
        k.effective_youngs_pa,
        1.0,
    );
    assert_relative_eq!(duration, expected, max_relative = 0.01);
    let velocity = |id| sim.particles.velocity_m_per_s[index(&sim, id)].x;
    let rebound = velocity(2) - velocity(1);
    assert_relative_eq!(rebound, 1.0, max_relative = 0.005);
}

/// The rebound speed from a wall over the impact speed at 1 m/s.
fn wall_restitution(restitution: f64) -> f64 {
    let m = material(restitution, 0.0);
    let kind = sphere(RADIUS, m);
    let p = particles(
        &kind,
        &[Vec3::new(0.0, 0.0, 0.00102)],
        &[Vec3::new(0.0, 0.0, -1.0)],
    );
    let mut sim = Simulation::new(config(2e-7, m), vec![kind], p, vec![floor(0.01)]).unwrap();
    let height = |s: &Simulation| s.particles.position_m[0].z - RADIUS;
    run_until(&mut sim, 1_000_000, |s| height(s) < 0.0);
    run_until(&mut sim, 1_000_000, |s| height(s) >= 0.0);
    sim.particles.velocity_m_per_s[0].z
}

/// A sphere dropped on a wall at 1 m/s comes back at e m/s, for e = 0.3, 0.6, 0.9.
#[test]
fn normal_impact_on_a_wall_rebounds_with_the_given_restitution() {
    for e in [0.3, 0.6, 0.9] {
        let measured = wall_restitution(e);
        assert_relative_eq!(measured, e, max_relative = 0.01);
    }
}

/// An oblique impact whose tangential speed is too large to stick throughout: the
/// friction impulse is μ times the normal impulse, so the tangential speed falls by
/// `μ (1 + e) vn`. A rigid sphere would spin up to `5/2 Δvt / r`; the friction's lever
/// at a wall is `r − δ/2` (as in LIGGGHTS), so this soft sphere's spin lies between
/// that times `1 − δmax / 2r` and that, δmax being Hertz's largest overlap.
#[test]
fn oblique_impact_in_the_sliding_regime_loses_the_coulomb_impulse() {
    let (e, mu, vn, vt) = (0.9, 0.1, 1.0, 1.0);
    assert!(
        vt > 3.5 * mu * (1.0 + e) * vn,
        "the case must slide throughout"
    );
    let m = material(e, mu);
    let kind = sphere(RADIUS, m);
    let p = particles(
        &kind,
        &[Vec3::new(0.0, 0.0, 0.00102)],
        &[Vec3::new(vt, 0.0, -vn)],
    );
    let mut sim = Simulation::new(config(2e-7, m), vec![kind], p, vec![floor(0.02)]).unwrap();
    let height = |s: &Simulation| s.particles.position_m[0].z - RADIUS;
    run_until(&mut sim, 1_000_000, |s| height(s) < 0.0);
    run_until(&mut sim, 1_000_000, |s| height(s) >= 0.0);
    let v = sim.particles.velocity_m_per_s[0];
    let expected_loss = mu * (1.0 + e) * vn;
    assert_relative_eq!(vt - v.x, expected_loss, max_relative = 0.02);
    let spin = sim.particles.angular_velocity[0].y;
    let rigid = 2.5 * expected_loss / RADIUS;
    // Hertz's largest overlap of the impact at vn, against a wall of the same material.
    let overlap = hertz_largest_overlap_m(
        sim.particles.mass_kg[0],
        RADIUS,
        PairConstants::between(&m, &m).effective_youngs_pa,
        vn,
    );
    assert!(
        spin <= rigid && spin >= rigid * (1.0 - overlap / (2.0 * RADIUS)),
        "spin {spin} rad/s outside [{}, {rigid}] (largest overlap {overlap} m)",
        rigid * (1.0 - overlap / (2.0 * RADIUS))
    );
}

/// The wall-wear proxy: a sphere hitting the floor at 1.5 m/s adds `½ m v²` to the
/// wall impact energy once, however long the contact lasts; the bounce's second
/// impact (no gravity: none) adds nothing; a sphere resting on the floor under
/// gravity and sliding across the floor's diagonal edge adds nothing either.
#[test]
fn an_impact_adds_its_normal_kinetic_energy_to_the_wall_once() {
    let m = material(0.6, 0.3);
    let kind = sphere(RADIUS, m);
    let p = particles(
        &kind,
        &[Vec3::new(0.0, 0.0, 0.00102)],
        &[Vec3::new(0.3, 0.0, -1.5)],
    );
    let mut sim = Simulation::new(config(2e-7, m), vec![kind], p, vec![floor(0.01)]).unwrap();
    assert_eq!(sim.wall_impact_energy_j(), 0.0);
    let height = |s: &Simulation| s.particles.position_m[0].z - RADIUS;
    run_until(&mut sim, 1_000_000, |s| height(s) < 0.0);
    let expected = 0.5 * kind.mass_kg() * 1.5 * 1.5;
    assert_relative_eq!(sim.wall_impact_energy_j(), expected, max_relative = 1e-12);
    run_until(&mut sim, 1_000_000, |s| height(s) >= 0.0);
    for _ in 0..1000 {
        sim.step().unwrap();
    }
    assert_relative_eq!(sim.wall_impact_energy_j(), expected, max_relative = 1e-12);

    // At rest on the floor, then pushed along x across the diagonal between its two
    // triangles: one continuous contact, no impact.
    let p = particles(
        &kind,
        &[Vec3::new(-0.003, 0.002, RADIUS)],
        &[Vec3::new(0.5, 0.0, 0.0)],
    );
    let mut cfg = config(2e-6, m);
    cfg.gravity_m_per_s2 = Vec3::new(0.0, 0.0, -9.81);
    let mut sim = Simulation::new(cfg, vec![kind], p, vec![floor(0.01)]).unwrap();
    for _ in 0..20_000 {
        sim.step().unwrap();
    }
    // The diagonal is y = x: it crossed at x = 0.002 m.
    let x = sim.particles.position_m[0].x;
    assert!(x > 0.003, "it stopped at x = {x} m, short of the diagonal");
    let settle = 0.5 * kind.mass_kg() * (2.0 * 9.81 * 1e-9);
    assert!(
        sim.wall_impact_energy_j() < settle,
        "{}",
        sim.wall_impact_energy_j()
    );
}
