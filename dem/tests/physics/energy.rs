//! With no damping and no friction the kernel conserves energy: kinetic, gravitational
//! and the elastic energy stored in the contacts (`8/15 E* sqrt(R*) δ^(5/2)` each).

use orch_dem::material::PairConstants;
use orch_dem::mesh::{Motion, WallMesh, WeldedMesh};
use orch_dem::{Simulation, Vec3};

use crate::{config, material, particles, sphere};

const RADIUS: f64 = 0.001;
const HALF: f64 = 0.004;

/// A closed box `[-HALF, HALF]² × [0, 2 HALF]`, twelve triangles.
fn closed_box() -> WallMesh {
    let c = |x: f64, y: f64, z: f64| [x * HALF, y * HALF, (z + 1.0) * HALF];
    let corners = [
        c(-1., -1., -1.),
        c(1., -1., -1.),
        c(1., 1., -1.),
        c(-1., 1., -1.),
        c(-1., -1., 1.),
        c(1., -1., 1.),
        c(1., 1., 1.),
        c(-1., 1., 1.),
    ];
    let quads = [
        [0, 1, 2, 3],
        [4, 5, 6, 7],
        [0, 1, 5, 4],
        [1, 2, 6, 5],
        [2, 3, 7, 6],
        [3, 0, 4, 7],
    ];
    let mut triangles = Vec::new();
    for [a, b, cc, d] in quads {
        triangles.push([corners[a], corners[b], corners[cc]]);
        triangles.push([corners[a], corners[cc], corners[d]]);
    }
    let mesh = WeldedMesh::from_triangles(&triangles).unwrap();
    assert_eq!(mesh.boundary_edge_count(), 0);
    WallMesh::new("box", mesh, Motion::Fixed)
}

fn total_energy(sim: &Simulation, k: &PairConstants, gravity: f64) -> f64 {
    let p = &sim.particles;
    let elastic = |overlap: f64, effective_radius: f64| {
        if overlap > 0.0 {
            8.0 / 15.0 * k.effective_youngs_pa * effective_radius.sqrt() * overlap.powf(2.5)
        } else {
            0.0
        }
    };
    let mut energy = p.kinetic_energy_j();
    for i in 0..p.len() {
        let x = p.position_m[i];
        energy += p.mass_kg[i] * gravity * x.z;
        for j in i + 1..p.len() {
            energy += elastic(2.0 * RADIUS - (x - p.position_m[j]).norm(), RADIUS / 2.0);
        }
        for distance in [
            x.x + HALF,
            HALF - x.x,
            x.y + HALF,
            HALF - x.y,
            x.z,
            2.0 * HALF - x.z,
        ] {
            energy += elastic(RADIUS - distance, RADIUS);
        }
    }
    energy
}

#[test]
fn energy_is_conserved_to_a_millionth_over_a_hundred_thousand_steps() {
    let m = material(1.0, 0.0);
    let kind = sphere(RADIUS, m);
    let positions: Vec<Vec3> = (0..8)
        .map(|i| {
            let (x, y, z) = ((i % 2) as f64, ((i / 2) % 2) as f64, (i / 4) as f64);
            Vec3::new((x - 0.5) * 0.0042, (y - 0.5) * 0.0043, 0.0015 + z * 0.0031)
        })
        .collect();
    let velocities: Vec<Vec3> = (0..8)
        .map(|i| {
            let a = i as f64;
            Vec3::new((a * 1.3).sin(), (a * 2.1).cos(), (a * 0.7).sin()) * 0.3
        })
        .collect();
    let p = particles(&kind, &positions, &velocities);
    let mut cfg = config(1e-6, m);
    let gravity = 9.81;
    cfg.gravity_m_per_s2 = Vec3::new(0.0, 0.0, -gravity);
    cfg.coplanar_angle_deg = 1.0;
    let mut sim = Simulation::new(cfg, vec![kind], p, vec![closed_box()]).unwrap();
    let k = PairConstants::between(&m, &m);
    let before = total_energy(&sim, &k, gravity);
    for _ in 0..100_000 {
        sim.step().unwrap();
    }
    let after = total_energy(&sim, &k, gravity);
    let drift = (after - before).abs() / before;
    assert!(drift < 1e-6, "relative energy drift {drift:e}");
    assert!(sim.timers().rebuilds > 10, "the particles moved about");
    // Eight spheres in a box have at most 28 pairs: 3.5 per sphere.
    let (listed, touching) = sim.timers().pairs_per_particle().unwrap();
    assert!(listed <= 3.5 && touching <= listed, "{listed} {touching}");
}
