//! Physics of the native kernel checked against analytical answers: Hertz impacts,
//! restitution, Coulomb sliding, rolling and sliding on an incline, energy
//! conservation, spontaneous percolation of fines through a packed bed; plus
//! determinism, the errors of bad input and the verification set
//! `dem/verification/`.

mod air;
mod bad_input;
mod determinism;
mod energy;
mod impact_reference;
mod impacts;
mod incline;
mod inflow;
mod momentum;
mod percolation;
mod sensor;
mod verification;
mod walls;

use orch_dem::material::{Material, ParticleType};
use orch_dem::mesh::{Motion, WallMesh, WeldedMesh};
use orch_dem::particles::Particles;
use orch_dem::{Config, Real, Simulation, Vec3};

/// Glass-like spheres of the solver notes: E 5 MPa, ν 0.3, ρ 2500 kg/m³.
pub fn material(restitution: Real, friction: Real) -> Material {
    Material {
        youngs_modulus_pa: 5e6,
        poisson_ratio: 0.3,
        restitution,
        friction,
        rolling_friction: 0.0,
    }
}

/// A sphere type of radius `radius_m` made of `material`.
pub fn sphere(radius_m: Real, material: Material) -> ParticleType {
    ParticleType {
        radius_m,
        density_kg_m3: 2500.0,
        material,
    }
}

/// A square floor at z = 0 of half-width `half_m`, two triangles.
pub fn floor(half_m: Real) -> WallMesh {
    let h = half_m;
    let triangles = [
        [[-h, -h, 0.0], [h, -h, 0.0], [h, h, 0.0]],
        [[-h, -h, 0.0], [h, h, 0.0], [-h, h, 0.0]],
    ];
    WallMesh::new(
        "floor",
        WeldedMesh::from_triangles(&triangles).unwrap(),
        Motion::Fixed,
    )
}

/// A configuration with no gravity in a 10 cm box around the origin.
pub fn config(timestep_s: Real, wall: Material) -> Config {
    Config {
        timestep_s,
        gravity_m_per_s2: Vec3::zeros(),
        skin_m: 0.0005,
        domain_min_m: Vec3::repeat(-0.05),
        domain_max_m: Vec3::repeat(0.05),
        coplanar_angle_deg: 20.0,
        max_speed_m_per_s: 50.0,
        max_overlap_ratio: 0.25,
        wall_material: wall,
        air: None,
        air_field: None,
    }
}

/// Particles of type 0 at `positions` with `velocities`.
pub fn particles(kind: &ParticleType, positions: &[Vec3], velocities: &[Vec3]) -> Particles {
    let mut p = Particles::default();
    for (i, (&x, &v)) in positions.iter().zip(velocities).enumerate() {
        p.push(i as u32 + 1, 0, kind, x);
        p.velocity_m_per_s[i] = v;
    }
    p
}

/// Hertz's largest overlap of an elastic impact at `speed_m_per_s`,
/// `(15 m* v² / (16 E* √R*))^(2/5)`, m (Johnson, *Contact Mechanics*, 1985, §11.4).
pub fn hertz_largest_overlap_m(
    effective_mass_kg: Real,
    effective_radius_m: Real,
    effective_youngs_pa: Real,
    speed_m_per_s: Real,
) -> Real {
    (15.0 * effective_mass_kg * speed_m_per_s * speed_m_per_s
        / (16.0 * effective_youngs_pa * effective_radius_m.sqrt()))
    .powf(0.4)
}

/// Runs until `done` says so or `max_steps` pass; returns the steps taken.
pub fn run_until(
    simulation: &mut Simulation,
    max_steps: u64,
    mut done: impl FnMut(&Simulation) -> bool,
) -> u64 {
    for step in 0..max_steps {
        if done(simulation) {
            return step;
        }
        simulation.step().unwrap();
    }
    panic!("the run did not finish within {max_steps} steps");
}

/// `run` on a pool of `threads` rayon threads: what the determinism checks compare.
pub fn on_threads<T: Send>(threads: usize, run: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(run)
}
