//! The particle store: one array per quantity (structure of arrays), owned by the
//! caller and passed to the stepper, as rapier keeps bodies in caller-owned sets.
//!
//! The order of the particles is the stepper's: at each neighbour-list rebuild it
//! sorts them along a space-filling curve so that particles near in space are near in
//! memory ([`crate::neighbour::CurveOrder`]). Ids are unique and stable;
//! look a particle up by id with [`Particles::index_of`].

use crate::material::ParticleType;
use crate::math::{Real, Vec3};

/// Every particle's state, SI units.
#[derive(Debug, Clone, Default, serde::Serialize, serde::Deserialize)]
pub struct Particles {
    /// Identity, unique for the whole run, from 1 (LIGGGHTS numbers atoms from 1 too).
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
    pub velocity_m_per_s: Vec<Vec3>,
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
    /// differ from every id already present.
    pub fn push(&mut self, id: u32, kind: u16, particle_type: &ParticleType, position_m: Vec3) {
        self.id.push(id);
        self.kind.push(kind);
        self.radius_m.push(particle_type.radius_m);
        self.mass_kg.push(particle_type.mass_kg());
        self.position_m.push(position_m);
        self.velocity_m_per_s.push(Vec3::zeros());
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
                0.5 * self.mass_kg[i] * self.velocity_m_per_s[i].norm_squared()
                    + 0.5 * self.inertia_kg_m2(i) * self.angular_velocity[i].norm_squared()
            })
            .sum()
    }

    /// The index of the particle with id `id` (a linear search: for tests and readers,
    /// not for the step).
    pub fn index_of(&self, id: u32) -> Option<usize> {
        self.id.iter().position(|&i| i == id)
    }

    /// The largest id present.
    pub fn max_id(&self) -> Option<u32> {
        self.id.iter().copied().max()
    }

    /// Rearranges the particles as `reorder` says, in place.
    pub fn reorder(&mut self, reorder: &Reorder) {
        reorder.apply(&mut self.id);
        reorder.apply(&mut self.kind);
        reorder.apply(&mut self.radius_m);
        reorder.apply(&mut self.mass_kg);
        reorder.apply(&mut self.position_m);
        reorder.apply(&mut self.velocity_m_per_s);
        reorder.apply(&mut self.angular_velocity);
        reorder.apply(&mut self.force_n);
        reorder.apply(&mut self.torque_n_m);
    }
}

/// A selection of particles in a new order, applied in place to every per-particle
/// array (no second copy of the arrays: at 10^6 particles that copy would be hundreds
/// of megabytes at every neighbour-list rebuild).
#[derive(Debug, Clone)]
pub struct Reorder {
    /// A permutation of all indices: the kept ones first, in their new order, then
    /// the dropped ones.
    permutation: Vec<u32>,
    /// The first index of each cycle of `permutation` longer than one, found once so
    /// that every array is reordered without bookkeeping of its own; particles that
    /// keep their place (most, between two rebuilds) cost nothing.
    cycle_starts: Vec<u32>,
    kept: usize,
}

impl Reorder {
    /// Particle `i` becomes the former particle `order[i]`; the particles of
    /// `0..len` that `order` does not name are dropped. `order` names each index at
    /// most once.
    pub fn new(order: &[u32], len: usize) -> Self {
        let mut named = vec![false; len];
        for &i in order {
            named[i as usize] = true;
        }
        let mut permutation = order.to_vec();
        permutation.extend((0..len as u32).filter(|&i| !named[i as usize]));
        // `named` is reused as "visited".
        let visited = &mut named;
        visited.fill(false);
        let mut cycle_starts = Vec::new();
        for start in 0..len {
            if visited[start] || permutation[start] as usize == start {
                continue;
            }
            cycle_starts.push(start as u32);
            let mut at = start;
            while !visited[at] {
                visited[at] = true;
                at = permutation[at] as usize;
            }
        }
        Self {
            permutation,
            cycle_starts,
            kept: order.len(),
        }
    }

    /// `values[i] = former values[order[i]]`, then the dropped ones are cut off: the
    /// permutation's cycles are followed, one value held aside per cycle.
    pub fn apply<T: Copy>(&self, values: &mut Vec<T>) {
        let p = &self.permutation;
        assert_eq!(values.len(), p.len(), "one value per particle");
        for &start in &self.cycle_starts {
            let start = start as usize;
            let held = values[start];
            let mut at = start;
            loop {
                let from = p[at] as usize;
                if from == start {
                    values[at] = held;
                    break;
                }
                values[at] = values[from];
                at = from;
            }
        }
        values.truncate(self.kept);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// In place, the reordering gives what a copy would.
        #[test]
        fn reordering_in_place_equals_a_copy(
            (len, order) in (0usize..60).prop_flat_map(|len| {
                (Just(len), Just((0..len as u32).collect::<Vec<u32>>()).prop_shuffle())
            }),
            keep in 0usize..61,
        ) {
            let order = &order[..keep.min(len)];
            let mut values: Vec<u64> = (0..len as u64).map(|v| v * 10 + 7).collect();
            let copy: Vec<u64> = order.iter().map(|&i| values[i as usize]).collect();
            Reorder::new(order, len).apply(&mut values);
            prop_assert_eq!(values, copy);
        }
    }
}
