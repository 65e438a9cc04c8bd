//! Synthetic crossings with known answers, for the responses' tests: stratified
//! samples of discs and rings (deterministic, so answers hold to the sampling's
//! resolution) and a small random generator for noisy flows.

use crate::crossing::Crossing;

/// A small deterministic generator (SplitMix64).
pub struct Rng(u64);

impl Rng {
    /// A generator started from `seed`.
    pub fn new(seed: u64) -> Rng {
        Rng(seed)
    }

    /// Uniform on (0, 1).
    pub fn uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        ((z >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
}

/// A population of particles of one kind.
#[derive(Debug, Clone, Copy)]
pub struct Kind {
    /// Particle type.
    pub particle_type: u32,
    /// Radius, m.
    pub radius_m: f64,
    /// Mass, kg.
    pub mass_kg: f64,
}

/// `n` crossings of `kind` whose centres are spread uniformly (per unit area) over the
/// ring `inner_m ≤ r ≤ outer_m` (a disc when `inner_m` is 0), stratified in radius
/// and turned by the golden angle; ids from `first_id`, times one per millisecond.
pub fn ring(kind: Kind, n: usize, inner_m: f64, outer_m: f64, first_id: u64) -> Vec<Crossing> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|i| {
            let u = (i as f64 + 0.5) / n as f64;
            let r = (inner_m * inner_m + (outer_m * outer_m - inner_m * inner_m) * u).sqrt();
            let angle = golden * i as f64;
            let id = first_id + i as u64;
            Crossing {
                id,
                particle_type: kind.particle_type,
                radius_m: kind.radius_m,
                mass_kg: kind.mass_kg,
                position_m: [r * angle.cos(), r * angle.sin(), 0.0],
                velocity_m_per_s: [0.0, 0.0, -1.0],
                time_s: id as f64 * 1e-3,
            }
        })
        .collect()
}
