//! Particle materials and the contact constants of each pair of them.
//!
//! The contact law is LIGGGHTS's `hertz` + `tangential history` (see [`crate::force`]);
//! the constants here are its effective moduli and the damping factor derived from the
//! coefficient of restitution the way LIGGGHTS and EDEM do.

use crate::math::Real;

/// One particle type (or the wall material): what a user measures of a material.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Material {
    /// Young's modulus E, Pa.
    pub youngs_modulus_pa: Real,
    /// Poisson ratio ν, dimensionless.
    pub poisson_ratio: Real,
    /// Coefficient of restitution e of a normal impact, 0 < e ≤ 1.
    pub restitution: Real,
    /// Coulomb sliding friction coefficient μ.
    pub friction: Real,
    /// Rolling friction coefficient μr of the constant directional torque model; 0 = off.
    pub rolling_friction: Real,
}

/// A spherical particle type: its size and density and the material it is made of.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParticleType {
    /// Sphere radius, m.
    pub radius_m: Real,
    /// Density, kg/m³.
    pub density_kg_m3: Real,
    /// Contact properties.
    pub material: Material,
}

impl ParticleType {
    /// Mass of one sphere, kg.
    pub fn mass_kg(&self) -> Real {
        4.0 / 3.0 * std::f64::consts::PI * self.radius_m.powi(3) * self.density_kg_m3
    }

    /// The Rayleigh time of this sphere, s: the period of the Rayleigh surface wave
    /// across it, `π r sqrt(ρ/G) / (0.1631 ν + 0.8766)`. DEM time steps are chosen as a
    /// fraction of the smallest Rayleigh time in a simulation.
    pub fn rayleigh_time_s(&self) -> Real {
        let nu = self.material.poisson_ratio;
        let shear_modulus = self.material.youngs_modulus_pa / (2.0 * (1.0 + nu));
        std::f64::consts::PI * self.radius_m * (self.density_kg_m3 / shear_modulus).sqrt()
            / (0.1631 * nu + 0.8766)
    }
}

/// The constants of the contact law between two materials.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PairConstants {
    /// Effective Young's modulus E*, Pa: `1/E* = (1-ν1²)/E1 + (1-ν2²)/E2`.
    pub effective_youngs_pa: Real,
    /// Effective shear modulus G*, Pa: `1/G* = 2(2-ν1)(1+ν1)/E1 + 2(2-ν2)(1+ν2)/E2`.
    pub effective_shear_pa: Real,
    /// `-2 sqrt(5/6) β` with `β = ln e / sqrt(ln² e + π²)`: the damping coefficients
    /// are this times `sqrt(S m*)`. Zero for e = 1.
    pub damping_factor: Real,
    /// `sqrt(St / Sn) = sqrt(4 G* / E*)`: the tangential damping coefficient over the
    /// normal one.
    pub tangential_to_normal_damping: Real,
    /// Sliding friction μ (the smaller of the two materials', as a conservative choice
    /// when they differ; LIGGGHTS takes it per type pair).
    pub friction: Real,
    /// Rolling friction μr (the smaller of the two).
    pub rolling_friction: Real,
}

impl PairConstants {
    /// Constants for a contact between materials `a` and `b`. Restitution is combined
    /// as the smaller of the two.
    pub fn between(a: &Material, b: &Material) -> Self {
        let inv_e = (1.0 - a.poisson_ratio.powi(2)) / a.youngs_modulus_pa
            + (1.0 - b.poisson_ratio.powi(2)) / b.youngs_modulus_pa;
        let shear_term = |m: &Material| {
            2.0 * (2.0 - m.poisson_ratio) * (1.0 + m.poisson_ratio) / m.youngs_modulus_pa
        };
        let restitution = a.restitution.min(b.restitution);
        let effective_youngs_pa = 1.0 / inv_e;
        let effective_shear_pa = 1.0 / (shear_term(a) + shear_term(b));
        Self {
            effective_youngs_pa,
            effective_shear_pa,
            tangential_to_normal_damping: (4.0 * effective_shear_pa / effective_youngs_pa).sqrt(),
            damping_factor: damping_factor(restitution),
            friction: a.friction.min(b.friction),
            rolling_friction: a.rolling_friction.min(b.rolling_friction),
        }
    }
}

/// `-2 sqrt(5/6) β`, `β = ln e / sqrt(ln² e + π²)`: zero for a perfectly elastic contact.
pub fn damping_factor(restitution: Real) -> Real {
    if restitution >= 1.0 {
        return 0.0;
    }
    let ln_e = restitution.ln();
    let beta = ln_e / (ln_e * ln_e + std::f64::consts::PI.powi(2)).sqrt();
    -2.0 * (5.0_f64 / 6.0).sqrt() * beta
}

/// Pair constants for every pair of particle types and for each type against the wall,
/// looked up by type index in the force loop.
#[derive(Debug, Clone)]
pub struct ContactTable {
    type_count: usize,
    particle_pairs: Vec<PairConstants>,
    particle_wall: Vec<PairConstants>,
}

impl ContactTable {
    /// Builds the table for `types` against each other and against `wall`.
    pub fn new(types: &[ParticleType], wall: &Material) -> Self {
        let type_count = types.len();
        let mut particle_pairs = Vec::with_capacity(type_count * type_count);
        for a in types {
            for b in types {
                particle_pairs.push(PairConstants::between(&a.material, &b.material));
            }
        }
        let particle_wall = types
            .iter()
            .map(|t| PairConstants::between(&t.material, wall))
            .collect();
        Self {
            type_count,
            particle_pairs,
            particle_wall,
        }
    }

    /// Constants between particle types `a` and `b`.
    #[inline]
    pub fn particles(&self, a: usize, b: usize) -> &PairConstants {
        &self.particle_pairs[a * self.type_count + b]
    }

    /// Constants between particle type `a` and the wall.
    #[inline]
    pub fn wall(&self, a: usize) -> &PairConstants {
        &self.particle_wall[a]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    fn glass() -> Material {
        Material {
            youngs_modulus_pa: 5e6,
            poisson_ratio: 0.3,
            restitution: 0.6,
            friction: 0.5,
            rolling_friction: 0.0,
        }
    }

    #[test]
    fn effective_moduli_of_identical_materials() {
        let k = PairConstants::between(&glass(), &glass());
        assert_relative_eq!(k.effective_youngs_pa, 5e6 / (2.0 * (1.0 - 0.09)));
        assert_relative_eq!(k.effective_shear_pa, 5e6 / (4.0 * 1.7 * 1.3));
    }

    #[test]
    fn damping_vanishes_for_elastic_contacts_and_grows_as_restitution_falls() {
        assert_eq!(damping_factor(1.0), 0.0);
        assert!(damping_factor(0.9) < damping_factor(0.6));
        assert!(damping_factor(0.6) < damping_factor(0.3));
    }

    #[test]
    fn rayleigh_time_of_a_two_millimetre_glass_sphere() {
        let sphere = ParticleType {
            radius_m: 0.001,
            density_kg_m3: 2500.0,
            material: glass(),
        };
        // π r sqrt(ρ/G) / (0.1631 ν + 0.8766) with G = E / 2.6.
        let expected = std::f64::consts::PI * 0.001 * (2500.0f64 / (5e6 / 2.6)).sqrt()
            / (0.1631 * 0.3 + 0.8766);
        assert_relative_eq!(sphere.rayleigh_time_s(), expected);
        assert_relative_eq!(sphere.rayleigh_time_s(), 1.2239e-4, max_relative = 1e-3);
    }
}
