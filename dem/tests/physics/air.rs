//! Air drag: a sphere falling from rest in still air reaches the terminal speed where
//! Schiller–Naumann drag balances its weight, a sphere at rest in a wind is carried
//! along it, and a wind given on a grid acts as the same wind inside the grid and not
//! beyond it.

use orch_dem::air::Air;
use orch_dem::air_field::AirField;
use orch_dem::material::ParticleType;
use orch_dem::math::Real;
use orch_dem::{Simulation, Vec3};

use crate::{config, material, particles, sphere};

/// The terminal speed of a sphere in still air from the force balance
/// `m g = ½ ρ_a C_d(Re) π r² v²`, solved by fixed-point iteration on
/// `v = sqrt(8 r ρ_p g / (3 ρ_a C_d(Re)))` with Schiller–Naumann's `C_d`, written out
/// here independently of the kernel.
fn terminal_speed(
    radius: Real,
    density: Real,
    air_density: Real,
    viscosity: Real,
    g: Real,
) -> Real {
    let mut v: Real = 1.0;
    for _ in 0..500 {
        let re = air_density * v * 2.0 * radius / viscosity;
        let cd = if re < 1000.0 {
            24.0 / re * (1.0 + 0.15 * re.powf(0.687))
        } else {
            0.44
        };
        v = (8.0 * radius * density * g / (3.0 * air_density * cd)).sqrt();
    }
    v
}

/// A sphere of glass's density (2500 kg/m³).
fn glass(radius: Real) -> ParticleType {
    sphere(radius, material(0.9, 0.5))
}

#[test]
fn a_sphere_falling_in_still_air_reaches_its_terminal_speed_within_one_percent() {
    for radius in [0.1e-3, 0.5e-3, 2e-3] {
        let kind = glass(radius);
        let dt = 1e-4;
        let mut config = lone_sphere(dt);
        config.gravity_m_per_s2 = Vec3::new(0.0, 0.0, -9.81);
        config.air = Some(Air {
            density_kg_m3: 1.2,
            viscosity_pa_s: 1.8e-5,
            velocity_m_per_s: Vec3::zeros(),
        });
        let expected = terminal_speed(radius, 2500.0, 1.2, 1.8e-5, 9.81);
        let p = particles(&kind, &[Vec3::zeros()], &[Vec3::zeros()]);
        let mut sim = Simulation::new(config, vec![kind], p, vec![]).unwrap();
        // Long enough to settle: several relaxation times v_t / g.
        let steps = (8.0 * expected / 9.81 / dt) as usize;
        for _ in 0..steps {
            sim.step().unwrap();
        }
        let v = -sim.particles.velocity_m_per_s[0].z;
        eprintln!("r = {radius} m: terminal speed {v:.4} m/s, expected {expected:.4}");
        assert!((v - expected).abs() / expected < 0.01, "{v} vs {expected}");
    }
}

#[test]
fn a_sphere_at_rest_in_a_wind_is_carried_along_it() {
    let kind = glass(0.5e-3);
    let mut config = lone_sphere(1e-4);
    config.air = Some(Air {
        density_kg_m3: 1.2,
        viscosity_pa_s: 1.8e-5,
        velocity_m_per_s: Vec3::new(3.0, 0.0, 0.0),
    });
    let p = particles(&kind, &[Vec3::zeros()], &[Vec3::zeros()]);
    let mut sim = Simulation::new(config, vec![kind], p, vec![]).unwrap();
    // Without gravity it approaches the wind's speed from below and never passes it;
    // near it the drag is Stokes's, with relaxation time ρ_p d² / (18 μ) = 7.7 s.
    let mut previous = 0.0;
    for _ in 0..40 {
        for _ in 0..10_000 {
            sim.step().unwrap();
        }
        let v = sim.particles.velocity_m_per_s[0];
        assert!(v.x > previous && v.x < 3.0, "{v:?} after {previous}");
        assert_eq!((v.y, v.z), (0.0, 0.0));
        previous = v.x;
    }
    assert!(previous > 2.9, "{previous} m/s after 40 s");
}

/// A configuration for one sphere far from anything: a skin of 10 m, so that its
/// neighbour list (empty) is not rebuilt as it flies.
fn lone_sphere(dt: Real) -> orch_dem::Config {
    let mut config = config(dt, material(0.9, 0.5));
    config.skin_m = 10.0;
    config.max_speed_m_per_s = 100.0;
    config
}

#[test]
fn a_uniform_wind_given_on_a_grid_drives_a_sphere_as_the_same_uniform_wind_and_not_beyond_the_grid()
{
    let kind = glass(0.5e-3);
    let dt = 1e-4;
    let wind = Vec3::new(0.0, 0.0, 2.0);
    // 2 m/s upwards at every node of an unevenly spaced grid that holds the sphere's
    // whole flight (it rises about 0.6 m in the second simulated).
    let (xs, ys, zs) = (
        [-0.2, -0.05, 0.1, 0.2],
        [-0.2, 0.0, 0.2],
        [-0.1, 0.3, 0.7, 1.5, 3.0],
    );
    let mut csv = String::from("x,y,z,ux,uy,uz\n");
    for x in xs {
        for y in ys {
            for z in zs {
                csv.push_str(&format!("{x},{y},{z},{},{},{}\n", wind.x, wind.y, wind.z));
            }
        }
    }
    let still = Air {
        density_kg_m3: 1.2,
        viscosity_pa_s: 1.8e-5,
        velocity_m_per_s: Vec3::zeros(),
    };
    let mut gridded = lone_sphere(dt);
    gridded.air = Some(still);
    gridded.air_field = Some(AirField::parse_csv(&csv).unwrap());
    let mut uniform = lone_sphere(dt);
    uniform.air = Some(Air {
        velocity_m_per_s: wind,
        ..still
    });
    // The first sphere inside the grid; the second 1 mm beyond its x = 0.2 m face.
    let (inside, outside) = (Vec3::zeros(), Vec3::new(0.201, 0.0, 0.0));
    let rest = Vec3::zeros();
    let two = particles(&kind, &[inside, outside], &[rest, rest]);
    let mut in_field = Simulation::new(gridded, vec![kind], two, vec![]).unwrap();
    let one = particles(&kind, &[inside], &[rest]);
    let mut in_wind = Simulation::new(uniform, vec![kind], one, vec![]).unwrap();
    let close = |a: Vec3, b: Vec3| (a - b).norm() <= 1e-9 * b.norm();
    let mut previous = 0.0;
    for _ in 0..10 {
        for _ in 0..1000 {
            in_field.step().unwrap();
            in_wind.step().unwrap();
        }
        let (field, wind) = (&in_field.particles, &in_wind.particles);
        assert!(
            close(field.position_m[0], wind.position_m[0])
                && close(field.velocity_m_per_s[0], wind.velocity_m_per_s[0]),
            "at t = {} s: {:?}, {:?} in the gridded wind against {:?}, {:?} in the uniform one",
            in_field.time_s(),
            field.position_m[0],
            field.velocity_m_per_s[0],
            wind.position_m[0],
            wind.velocity_m_per_s[0]
        );
        // It speeds up towards the wind's speed without reaching it.
        let v = field.velocity_m_per_s[0].z;
        assert!(v > previous && v < 2.0, "{v} m/s after {previous} m/s");
        previous = v;
        // Beyond the grid the air is still: with no gravity nothing moves it.
        assert_eq!(
            (field.position_m[1], field.velocity_m_per_s[1]),
            (outside, Vec3::zeros())
        );
    }
    assert!(previous > 0.5, "{previous} m/s after 1 s");
}
