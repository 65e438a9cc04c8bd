//! Particle crossings of a horizontal sensor plane.
//!
//! Solvers report particles near the sensor plane at discrete times (LIGGGHTS dumps a
//! thin band around the plane every few steps). [`CrossingDetector`] follows each
//! particle through those sightings and records its first downward crossing, with
//! time and position interpolated linearly between the last sighting above the plane
//! and the first below it. A particle first seen already below the plane is traced
//! back along its velocity. Each particle crosses at most once.

use std::collections::HashMap;

/// One particle seen at one time, as a solver reports it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sighting {
    /// Particle id, stable over the run.
    pub id: u64,
    /// Particle type as the solver numbers it.
    pub particle_type: u32,
    /// Radius, m.
    pub radius_m: f64,
    /// Mass, kg.
    pub mass_kg: f64,
    /// Centre position, m.
    pub position_m: [f64; 3],
    /// Velocity, m/s.
    pub velocity_m_per_s: [f64; 3],
}

/// A particle's crossing of the sensor plane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Crossing {
    /// Particle id.
    pub id: u64,
    /// Particle type as the solver numbers it.
    pub particle_type: u32,
    /// Radius, m.
    pub radius_m: f64,
    /// Mass, kg.
    pub mass_kg: f64,
    /// Position where the centre crossed the plane, m.
    pub position_m: [f64; 3],
    /// Velocity at the crossing, m/s.
    pub velocity_m_per_s: [f64; 3],
    /// Time of the crossing, s.
    pub time_s: f64,
}

impl Crossing {
    /// Distance from the hopper axis (the z axis), m.
    pub fn radial_distance_m(&self) -> f64 {
        self.position_m[0].hypot(self.position_m[1])
    }
}

/// Follows particles through sightings and records first crossings of `plane_z_m`.
#[derive(Debug)]
pub struct CrossingDetector {
    plane_z_m: f64,
    last_above: HashMap<u64, (f64, Sighting)>,
    crossed: HashMap<u64, Crossing>,
}

impl CrossingDetector {
    /// A detector for the horizontal plane at height `plane_z_m`.
    pub fn new(plane_z_m: f64) -> CrossingDetector {
        CrossingDetector {
            plane_z_m,
            last_above: HashMap::new(),
            crossed: HashMap::new(),
        }
    }

    /// Feeds one sighting at time `time_s`. Sightings of one particle must come in
    /// time order; different particles may interleave.
    pub fn observe(&mut self, time_s: f64, sighting: Sighting) {
        if self.crossed.contains_key(&sighting.id) {
            return;
        }
        let z = sighting.position_m[2];
        if z > self.plane_z_m {
            self.last_above.insert(sighting.id, (time_s, sighting));
            return;
        }
        let crossing = match self.last_above.remove(&sighting.id) {
            Some((t_above, above)) => self.interpolate(t_above, &above, time_s, &sighting),
            None => self.trace_back(time_s, &sighting),
        };
        self.crossed.insert(sighting.id, crossing);
    }

    fn interpolate(&self, t0: f64, above: &Sighting, t1: f64, below: &Sighting) -> Crossing {
        let (z0, z1) = (above.position_m[2], below.position_m[2]);
        let s = if z0 == z1 {
            1.0
        } else {
            (z0 - self.plane_z_m) / (z0 - z1)
        };
        let lerp = |a: f64, b: f64| a + (b - a) * s;
        Crossing {
            id: below.id,
            particle_type: below.particle_type,
            radius_m: below.radius_m,
            mass_kg: below.mass_kg,
            position_m: [
                lerp(above.position_m[0], below.position_m[0]),
                lerp(above.position_m[1], below.position_m[1]),
                self.plane_z_m,
            ],
            velocity_m_per_s: [
                lerp(above.velocity_m_per_s[0], below.velocity_m_per_s[0]),
                lerp(above.velocity_m_per_s[1], below.velocity_m_per_s[1]),
                lerp(above.velocity_m_per_s[2], below.velocity_m_per_s[2]),
            ],
            time_s: lerp(t0, t1),
        }
    }

    fn trace_back(&self, time_s: f64, below: &Sighting) -> Crossing {
        let v = below.velocity_m_per_s;
        let dz = self.plane_z_m - below.position_m[2];
        // Only a particle moving down can be traced back up to the plane.
        let dt = if v[2] < 0.0 { dz / v[2] } else { 0.0 };
        Crossing {
            id: below.id,
            particle_type: below.particle_type,
            radius_m: below.radius_m,
            mass_kg: below.mass_kg,
            position_m: [
                below.position_m[0] + v[0] * dt,
                below.position_m[1] + v[1] * dt,
                self.plane_z_m,
            ],
            velocity_m_per_s: v,
            time_s: time_s + dt,
        }
    }

    /// The crossings recorded so far, in order of crossing time.
    pub fn finish(self) -> Vec<Crossing> {
        let mut crossings: Vec<Crossing> = self.crossed.into_values().collect();
        crossings.sort_by(|a, b| a.time_s.total_cmp(&b.time_s).then(a.id.cmp(&b.id)));
        crossings
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(id: u64, x: f64, z: f64, vz: f64) -> Sighting {
        Sighting {
            id,
            particle_type: 1,
            radius_m: 0.001,
            mass_kg: 1e-5,
            position_m: [x, 0.0, z],
            velocity_m_per_s: [0.0, 0.0, vz],
        }
    }

    #[test]
    fn crossing_between_sightings_is_interpolated() {
        let mut detector = CrossingDetector::new(0.0);
        detector.observe(1.0, at(7, 0.002, 0.001, -1.0));
        detector.observe(1.001, at(7, 0.004, -0.003, -1.0));
        let crossings = detector.finish();
        assert_eq!(crossings.len(), 1);
        let c = crossings[0];
        assert!((c.time_s - 1.00025).abs() < 1e-12);
        assert!((c.position_m[0] - 0.0025).abs() < 1e-12);
    }

    #[test]
    fn first_sighting_below_is_traced_back_along_velocity() {
        let mut detector = CrossingDetector::new(-0.01);
        detector.observe(2.0, at(3, 0.0, -0.012, -2.0));
        let c = detector.finish()[0];
        assert!((c.time_s - 1.999).abs() < 1e-12);
    }

    #[test]
    fn each_particle_crosses_once() {
        let mut detector = CrossingDetector::new(0.0);
        detector.observe(0.0, at(1, 0.0, 0.001, -1.0));
        detector.observe(0.1, at(1, 0.0, -0.001, -1.0));
        detector.observe(0.2, at(1, 0.0, 0.001, 1.0));
        detector.observe(0.3, at(1, 0.0, -0.001, -1.0));
        assert_eq!(detector.finish().len(), 1);
    }
}
