//! Contacts with triangle meshes: a sphere resting on a shared vertex or edge is pushed
//! once, and a moving wall drags a sphere through its velocity at the contact.

use approx::assert_relative_eq;
use orch_dem::material::PairConstants;
use orch_dem::mesh::{Motion, WallMesh, WeldedMesh};
use orch_dem::{Simulation, Vec3};

use crate::{config, material, particles, sphere};

const RADIUS: f64 = 0.001;
const G: f64 = 9.81;

/// A floor at z = 0 made of eight triangles fanned around a vertex at the origin.
fn fan_floor(half_m: f64) -> WallMesh {
    let rim: Vec<[f64; 3]> = (0..8)
        .map(|k| {
            let angle = k as f64 * std::f64::consts::FRAC_PI_4;
            [half_m * angle.cos(), half_m * angle.sin(), 0.0]
        })
        .collect();
    let triangles: Vec<[[f64; 3]; 3]> = (0..8)
        .map(|k| [[0.0; 3], rim[k], rim[(k + 1) % 8]])
        .collect();
    WallMesh::new(
        "fan",
        WeldedMesh::from_triangles(&triangles).unwrap(),
        Motion::Fixed,
    )
}

/// Settles a sphere above `(x, y)` on the fan floor; returns (overlap, wall contacts).
fn rest_at(x: f64, y: f64) -> (f64, usize) {
    let m = material(0.3, 0.5);
    let kind = sphere(RADIUS, m);
    let mut cfg = config(1e-6, m);
    cfg.gravity_m_per_s2 = Vec3::new(0.0, 0.0, -G);
    let p = particles(&kind, &[Vec3::new(x, y, RADIUS)], &[Vec3::zeros()]);
    let mut sim = Simulation::new(cfg, vec![kind], p, vec![fan_floor(0.01)]).unwrap();
    for _ in 0..20_000 {
        sim.step().unwrap();
    }
    (
        RADIUS - sim.particles.position_m[0].z,
        sim.wall_contact_count(0),
    )
}

/// At rest the wall carries the weight once: `m g = 4/3 E* sqrt(r) δ^(3/2)`, whether
/// the sphere sits on a face, on an edge shared by two triangles, or on the vertex
/// eight triangles share.
#[test]
fn a_sphere_on_a_shared_vertex_or_edge_is_pushed_once() {
    let m = material(0.3, 0.5);
    let kind = sphere(RADIUS, m);
    let k = PairConstants::between(&m, &m);
    let expected =
        (kind.mass_kg() * G / (4.0 / 3.0 * k.effective_youngs_pa * RADIUS.sqrt())).powf(2.0 / 3.0);
    let edge = 0.004 * std::f64::consts::FRAC_PI_8.cos();
    for (x, y, place) in [
        (0.003, 0.001, "face"),
        (edge, 0.0, "edge"),
        (0.0, 0.0, "vertex"),
    ] {
        let (overlap, contacts) = rest_at(x, y);
        assert_eq!(contacts, 1, "{place}");
        assert_relative_eq!(overlap, expected, max_relative = 0.01);
    }
}

/// A sphere dropped at rest on a belt moving at V: friction makes it roll without
/// slipping at `2/7 V` (angular momentum about the contact point is conserved).
#[test]
fn a_moving_wall_drags_a_sphere_to_two_sevenths_of_its_speed() {
    let belt_speed = 0.2;
    let m = material(0.3, 0.5);
    let kind = sphere(RADIUS, m);
    let mut cfg = config(1e-6, m);
    cfg.gravity_m_per_s2 = Vec3::new(0.0, 0.0, -G);
    let belt = WallMesh::new(
        "belt",
        WeldedMesh::from_triangles(&[
            [[-0.04, -0.01, 0.0], [0.04, -0.01, 0.0], [0.04, 0.01, 0.0]],
            [[-0.04, -0.01, 0.0], [0.04, 0.01, 0.0], [-0.04, 0.01, 0.0]],
        ])
        .unwrap(),
        Motion::Translation {
            velocity_m_per_s: Vec3::new(belt_speed, 0.0, 0.0),
            start_s: 0.0,
        },
    );
    let p = particles(
        &kind,
        &[Vec3::new(0.0, 0.0, RADIUS - 1.5e-6)],
        &[Vec3::zeros()],
    );
    let mut sim = Simulation::new(cfg, vec![kind], p, vec![belt]).unwrap();
    for _ in 0..30_000 {
        sim.step().unwrap();
    }
    let v = sim.particles.velocity_m_per_s[0].x;
    assert_relative_eq!(v, 2.0 / 7.0 * belt_speed, max_relative = 0.01);
    // Rolling without slipping on the belt: v - ω r = V.
    let contact_speed = v - RADIUS * sim.particles.angular_velocity[0].y;
    assert_relative_eq!(contact_speed, belt_speed, max_relative = 0.01);
}

/// The wall candidates listed at a rebuild reach half the skin past each radius, as
/// far as a particle and a wall can close in before the next rebuild. A sphere at rest
/// (no gravity) waits above a floor that rises at constant speed, so the floor alone
/// decides when rebuilds fall: at each of forty clearances spread over three skins,
/// the sphere first touches the floor in the step its centre comes closer to it than
/// its radius, however that step falls between rebuilds.
#[test]
fn a_rising_floor_touches_a_sphere_from_the_step_it_reaches_it() {
    let radius = 0.0005;
    let rise_m_per_s = 0.5;
    let m = material(0.6, 0.5);
    let kind = sphere(radius, m);
    let skin = config(1e-5, m).skin_m;
    for k in 0..40 {
        let clearance = 7.3e-6 + k as f64 * 0.077 * skin;
        let p = particles(
            &kind,
            &[Vec3::new(0.0, 0.0, radius + clearance)],
            &[Vec3::zeros()],
        );
        let mut floor = crate::floor(0.01);
        floor.motion = Motion::Translation {
            velocity_m_per_s: Vec3::new(0.0, 0.0, rise_m_per_s),
            start_s: 0.0,
        };
        let mut sim = Simulation::new(config(1e-5, m), vec![kind], p, vec![floor]).unwrap();
        loop {
            sim.step().unwrap();
            let gap = sim.particles.position_m[0].z - rise_m_per_s * sim.time_s() - radius;
            assert_eq!(
                sim.wall_contact_count(0) > 0,
                gap < 0.0,
                "clearance {clearance:e} m: {gap:e} m from the floor at t = {} s",
                sim.time_s()
            );
            if gap < 0.0 {
                break;
            }
        }
    }
}
