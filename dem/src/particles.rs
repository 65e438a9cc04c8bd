//! The particle store: one array per quantity (structure of arrays), owned by the
//! caller and passed to the stepper, as rapier keeps bodies in caller-owned sets.
//!
//! Particles are kept in ascending id order; removing particles keeps that order, so an
//! index comparison `i < j` is an id comparison and pair lists stay sorted.

use crate::material::ParticleType;
use crate::math::{Real, Vec3};

/// Every particle's state, SI units.
#[derive(Debug, Clone, Default)]
pub struct Particles {
    /// Identity, unique for the whole run, ascending, from 1 (LIGGGHTS numbers atoms
    /// from 1 too).
    pub id: Vec<u32>,
    /// Index into the simulation's particle types.
    pub kind: Vec<u16>,
    /// Radius, m.
    pub radius_m: Vec<Real>,
    /// Mass, kg.
    pub mass_kg: Vec<Real>,
    /// Position of the centre, m.
    pub position_m: Vec<Vec3>,
    /// Velocity, m/s.
    pub velocity_m_s: Vec<Vec3>,
    /// Angular velocity, rad/s.
    pub angular_velocity: Vec<Vec3>,
    /// Force of the current step, N.
    pub force_n: Vec<Vec3>,
    /// Torque of the current step, N m.
    pub torque_n_m: Vec<Vec3>,
}

impl Particles {
    /// Number of particles.
    pub fn len(&self) -> usize {
        self.id.len()
    }

    /// Whether there are no particles.
    pub fn is_empty(&self) -> bool {
        self.id.is_empty()
    }

    /// Appends a particle of `kind` (described by `particle_type`) at rest; its id must
    /// exceed every id already present.
    pub fn push(&mut self, id: u32, kind: u16, particle_type: &ParticleType, position_m: Vec3) {
        debug_assert!(self.id.last().is_none_or(|&last| last < id));
        self.id.push(id);
        self.kind.push(kind);
        self.radius_m.push(particle_type.radius_m);
        self.mass_kg.push(particle_type.mass_kg());
        self.position_m.push(position_m);
        self.velocity_m_s.push(Vec3::zeros());
        self.angular_velocity.push(Vec3::zeros());
        self.force_n.push(Vec3::zeros());
        self.torque_n_m.push(Vec3::zeros());
    }

    /// Moment of inertia of particle `i` (a solid sphere, 2/5 m r²), kg m².
    #[inline]
    pub fn inertia_kg_m2(&self, i: usize) -> Real {
        0.4 * self.mass_kg[i] * self.radius_m[i] * self.radius_m[i]
    }

    /// Translational plus rotational kinetic energy, J.
    pub fn kinetic_energy_j(&self) -> Real {
        (0..self.len())
            .map(|i| {
                0.5 * self.mass_kg[i] * self.velocity_m_s[i].norm_squared()
                    + 0.5 * self.inertia_kg_m2(i) * self.angular_velocity[i].norm_squared()
            })
            .sum()
    }

    /// Keeps the particles for which `keep[i]` is true, in order; returns for each kept
    /// particle its former index.
    pub fn retain(&mut self, keep: &[bool]) -> Vec<u32> {
        let kept: Vec<u32> = (0..self.len() as u32)
            .filter(|&i| keep[i as usize])
            .collect();
        fn select<T: Copy>(values: &mut Vec<T>, kept: &[u32]) {
            *values = kept.iter().map(|&i| values[i as usize]).collect();
        }
        select(&mut self.id, &kept);
        select(&mut self.kind, &kept);
        select(&mut self.radius_m, &kept);
        select(&mut self.mass_kg, &kept);
        select(&mut self.position_m, &kept);
        select(&mut self.velocity_m_s, &kept);
        select(&mut self.angular_velocity, &kept);
        select(&mut self.force_n, &kept);
        select(&mut self.torque_n_m, &kept);
        kept
    }
}
