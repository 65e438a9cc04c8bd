//! The time step a case may run at, from the Rayleigh and Hertz criteria.
//!
//! An explicit integrator of stiff contacts resolves a collision, and stays stable,
//! only while its step is a small fraction of two times:
//!
//! - the **Rayleigh time** of the smallest particle, `T_R = π r sqrt(ρ/G) /
//!   (0.1631 ν + 0.8766)`, the time a Rayleigh surface wave takes to cross it
//!   ([`ParticleType::rayleigh_time_s`]); it bounds the step in dense, long-lasting
//!   contact networks (a settled bed, a hopper's fill);
//! - **Hertz's contact time** of the hardest impact the case can see, `T_H =
//!   2.87 (m*² / (R* E*² v))^(1/5)` (Johnson 1985, §11.4) with the pair's effective
//!   mass, radius and Young's modulus and the impact speed `v`
//!   ([`hertz_contact_time_s`]); it
//!   bounds the step in fast collisions, and is smallest for the smallest spheres.
//!
//! The largest step a case may give is the smaller of [`MAX_RAYLEIGH_FRACTION`] `T_R`
//! and [`MAX_HERTZ_FRACTION`] `T_H`: Li, Xu & Thornton (2005) advise 0.2–0.4 `T_R`
//! (0.2 for dense packings, where coordination numbers exceed 4), and 0.2 `T_H` is
//! the bound at which LIGGGHTS's `fix check/timestep/gran` warns. A case that gives no
//! step gets `rayleigh_fraction` `T_R` (0.15 by default), and at most
//! [`CHOSEN_HERTZ_FRACTION`] `T_H`: half the largest, for a margin.
//!
//! The impact speed is bounded from the case alone, before anything moves: twice a
//! particle's fall over the domain's height along gravity plus the fastest wall, feed,
//! initial particle and uniform air speed, for two bodies meeting head on
//! ([`impact_speed_bound_m_per_s`]).
//!
//! Johnson, K. L. (1985) *Contact Mechanics*, Cambridge University Press.
//! Li, Y., Xu, Y., Thornton, C. (2005) A comparison of discrete element simulations and
//! experiments for 'sandpiles' composed of spherical particles. *Powder Technology*
//! 160, 219–228.

use crate::case::{Case, MotionEntry};
use crate::force::hertz_contact_time_s;
use crate::material::{Material, PairConstants, ParticleType};
use crate::math::{Real, Vec3};

/// The largest step a case may give, as a fraction of its smallest Rayleigh time.
pub const MAX_RAYLEIGH_FRACTION: Real = 0.3;

/// The largest step a case may give, as a fraction of its shortest Hertz contact time.
pub const MAX_HERTZ_FRACTION: Real = 0.2;

/// The step the kernel chooses at most, as a fraction of the shortest Hertz time.
pub const CHOSEN_HERTZ_FRACTION: Real = 0.1;

/// Hertz's contact time at `speed_m_per_s` ([`hertz_contact_time_s`]), infinite when
/// nothing approaches.
fn hertz_time_s(
    effective_mass_kg: Real,
    effective_radius_m: Real,
    effective_youngs_pa: Real,
    speed_m_per_s: Real,
) -> Real {
    if speed_m_per_s <= 0.0 {
        return Real::INFINITY;
    }
    hertz_contact_time_s(
        effective_mass_kg,
        effective_radius_m,
        effective_youngs_pa,
        speed_m_per_s,
    )
}

/// The two times a case's step is measured against, and the speed the Hertz time
/// assumes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimestepLimits {
    /// The smallest Rayleigh time of the case's particles, s.
    pub rayleigh_time_s: Real,
    /// The shortest Hertz contact time of any pair of particles, or of a particle and
    /// the wall, at [`TimestepLimits::impact_speed_m_per_s`], s.
    pub hertz_time_s: Real,
    /// The bound of impact speeds the Hertz time assumes, m/s.
    pub impact_speed_m_per_s: Real,
}

impl TimestepLimits {
    /// The limits of `types` (each at its smallest radius) meeting each other and a
    /// `wall` at `impact_speed_m_per_s`.
    pub fn of(types: &[ParticleType], wall: &Material, impact_speed_m_per_s: Real) -> Self {
        let rayleigh_time_s = types
            .iter()
            .map(ParticleType::rayleigh_time_s)
            .fold(Real::INFINITY, Real::min);
        let mut hertz = Real::INFINITY;
        for (k, a) in types.iter().enumerate() {
            for b in &types[k..] {
                let (ma, mb) = (a.mass_kg(), b.mass_kg());
                let e = PairConstants::between(&a.material, &b.material).effective_youngs_pa;
                let r = a.radius_m * b.radius_m / (a.radius_m + b.radius_m);
                hertz = hertz.min(hertz_time_s(
                    ma * mb / (ma + mb),
                    r,
                    e,
                    impact_speed_m_per_s,
                ));
            }
            let e = PairConstants::between(&a.material, wall).effective_youngs_pa;
            hertz = hertz.min(hertz_time_s(
                a.mass_kg(),
                a.radius_m,
                e,
                impact_speed_m_per_s,
            ));
        }
        TimestepLimits {
            rayleigh_time_s,
            hertz_time_s: hertz,
            impact_speed_m_per_s,
        }
    }

    /// The largest step a case may give, s.
    pub fn largest_s(&self) -> Real {
        (MAX_RAYLEIGH_FRACTION * self.rayleigh_time_s).min(MAX_HERTZ_FRACTION * self.hertz_time_s)
    }

    /// The step chosen when a case gives none, s: `rayleigh_fraction` of the Rayleigh
    /// time, and at most [`CHOSEN_HERTZ_FRACTION`] of the Hertz time.
    pub fn chosen_s(&self, rayleigh_fraction: Real) -> Real {
        (rayleigh_fraction * self.rayleigh_time_s).min(CHOSEN_HERTZ_FRACTION * self.hertz_time_s)
    }
}

/// A bound of the speeds at which bodies of `case` meet, m/s: twice the speed a body
/// can reach (free fall over the domain's extent along gravity, plus the fastest of
/// the walls' motions, the feeds' and initial particles' velocities and the uniform
/// air), since two such bodies may approach each other head on.
pub fn impact_speed_bound_m_per_s(case: &Case) -> Real {
    let gravity = case
        .run
        .gravity
        .unwrap_or([0.0, 0.0, -crate::math::STANDARD_GRAVITY_M_S2]);
    let g = Vec3::from(gravity).norm();
    let height_m = if g > 0.0 {
        (0..3)
            .map(|i| (gravity[i] / g).abs() * (case.domain.max[i] - case.domain.min[i]))
            .sum::<Real>()
    } else {
        0.0
    };
    let fall = (2.0 * g * height_m).sqrt();
    let walls = case
        .meshes
        .iter()
        .filter_map(|m| m.motion.as_ref())
        .map(|motion| match motion {
            MotionEntry::Vibration {
                amplitude,
                frequency,
                ..
            } => Vec3::from(*amplitude).norm() * 2.0 * std::f64::consts::PI * frequency,
            MotionEntry::Translation { velocity, .. } => Vec3::from(*velocity).norm(),
        });
    let feeds = case.inflow.iter().map(|f| Vec3::from(f.velocity).norm());
    let particles = case.particles.iter().map(|p| Vec3::from(p.velocity).norm());
    let air = case.air.iter().map(|a| Vec3::from(a.velocity).norm());
    let launched = walls
        .chain(feeds)
        .chain(particles)
        .chain(air)
        .fold(0.0, Real::max);
    2.0 * (fall + launched)
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    fn glass(radius_m: Real, youngs_modulus_pa: Real) -> ParticleType {
        ParticleType {
            radius_m,
            density_kg_m3: 2500.0,
            material: Material {
                youngs_modulus_pa,
                poisson_ratio: 0.3,
                restitution: 0.5,
                friction: 0.5,
                rolling_friction: 0.0,
            },
        }
    }

    /// Johnson's formula by hand for two 1 mm glass spheres at 5 MPa meeting at 1 m/s:
    /// m* = m/2, R* = r/2, E* = E / (2 (1 - ν²)).
    #[test]
    fn hertz_time_of_two_equal_spheres_follows_johnson() {
        let sphere = glass(1e-3, 5e6);
        let m = sphere.mass_kg();
        let e_star = 5e6 / (2.0 * (1.0 - 0.09));
        let expected = 2.87 * ((m / 2.0).powi(2) / (0.5e-3 * e_star * e_star * 1.0)).powf(0.2);
        let limits = TimestepLimits::of(&[sphere], &sphere.material, 1.0);
        // The wall pair (m* = m, R* = r, the same E*) lasts longer: 2^(1/5).
        assert_relative_eq!(limits.hertz_time_s, expected, max_relative = 1e-12);
        assert_relative_eq!(expected, 2.6e-4, max_relative = 0.05);
        // A faster impact is shorter, as v^(-1/5).
        let faster = TimestepLimits::of(&[sphere], &sphere.material, 32.0);
        assert_relative_eq!(faster.hertz_time_s, expected / 2.0, max_relative = 1e-12);
    }

    /// The smallest particle sets both times; the step is the smaller bound.
    #[test]
    fn the_finest_particle_sets_the_limits() {
        let (coarse, fine) = (glass(2e-3, 5e6), glass(0.4e-3, 5e6));
        let limits = TimestepLimits::of(&[coarse, fine], &coarse.material, 2.0);
        assert_relative_eq!(limits.rayleigh_time_s, fine.rayleigh_time_s());
        let alone = TimestepLimits::of(&[fine], &fine.material, 2.0);
        assert_relative_eq!(limits.hertz_time_s, alone.hertz_time_s);
        assert_eq!(
            limits.largest_s(),
            (0.3 * limits.rayleigh_time_s).min(0.2 * limits.hertz_time_s)
        );
        assert!(limits.chosen_s(0.15) < limits.largest_s());
        // Nothing moving: the Rayleigh time alone.
        let still = TimestepLimits::of(&[fine], &fine.material, 0.0);
        assert_eq!(still.largest_s(), 0.3 * still.rayleigh_time_s);
    }
}
