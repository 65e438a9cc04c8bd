//! Continuous insertion: a mixture fed through a region at a given mass rate and
//! initial velocity over a time window, as LIGGGHTS's `fix insert/stream` feeds a
//! chute.
//!
//! Particles are inserted in batches, one every `interval_s` from `start_s` while the
//! window lasts. Batch `k` tops the inserted mass up to `rate × (min(start + (k + 1)
//! interval, end) − start)`: particles are added while the inserted mass is below that
//! target, each of the type whose mass lags furthest behind its share, so at the end of
//! the window the inserted mass is `rate × (end − start)` to within one particle's mass
//! and each type's mass its share to within one of its particles. Positions are drawn
//! uniformly in the region (seeded) and refused when they overlap any particle already
//! there. A type that finds no room (after [`INFLOW_ATTEMPTS`] draws) sits the rest of
//! the batch out while the other types go on, and what the batch could not place is
//! left to the next one, where the type furthest behind goes first; what the last
//! batch cannot place is not placed ([`InflowState::asked_mass_kg`] against
//! [`InflowState::inserted_mass_kg`] says how much). Walls are not checked: the region
//! must be clear of them.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::insert::{OccupancyGrid, Region};
use crate::material::ParticleType;
use crate::math::{Real, Vec3};
use crate::particles::Particles;

/// Tries per particle before a batch leaves the rest of its mass to the next batch.
pub const INFLOW_ATTEMPTS: usize = 2_000;

/// A continuous inflow of a mixture.
#[derive(Debug, Clone, PartialEq)]
pub struct Inflow {
    /// Where particles appear; every particle lies wholly inside.
    pub region: Region,
    /// Mass fraction of each particle type, in type order; sums to 1.
    pub mass_fractions: Vec<Real>,
    /// Mass fed per second, kg/s.
    pub mass_rate_kg_per_s: Real,
    /// Velocity of every inserted particle, m/s.
    pub velocity_m_per_s: Vec3,
    /// Start of the window, s.
    pub start_s: Real,
    /// End of the window, s.
    pub end_s: Real,
    /// Time between batches, s.
    pub interval_s: Real,
    /// Seed of the positions.
    pub seed: u64,
}

/// Why an inflow cannot be used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum InflowError {
    /// A number out of its range.
    #[error("inflow: {0}")]
    Invalid(String),
}

impl Inflow {
    /// The default batch interval: the time the inflow's velocity takes to cross the
    /// region's extent along it, so a batch has left the region before the next one.
    /// `None` when the velocity is zero.
    pub fn crossing_time_s(region: &Region, velocity_m_per_s: Vec3) -> Option<Real> {
        let speed = velocity_m_per_s.norm();
        if speed == 0.0 {
            return None;
        }
        let (lo, hi) = region.bounds();
        let direction = velocity_m_per_s / speed;
        let extent: Real = (0..3).map(|k| direction[k].abs() * (hi[k] - lo[k])).sum();
        Some(extent / speed)
    }

    /// Checks the numbers against `types`.
    pub fn validate(&self, types: &[ParticleType]) -> Result<(), InflowError> {
        let bad = |m: String| Err(InflowError::Invalid(m));
        if self.mass_fractions.len() != types.len() {
            return bad(format!(
                "expected one mass fraction per type ({}), got {}",
                types.len(),
                self.mass_fractions.len()
            ));
        }
        let sum: Real = self.mass_fractions.iter().sum();
        if self.mass_fractions.iter().any(|w| !(0.0..=1.0).contains(w)) || (sum - 1.0).abs() > 1e-6
        {
            return bad(format!(
                "expected mass fractions in [0, 1] that sum to 1, got {:?}",
                self.mass_fractions
            ));
        }
        if !(self.mass_rate_kg_per_s.is_finite() && self.mass_rate_kg_per_s > 0.0) {
            return bad(format!(
                "expected a positive mass rate, got {} kg/s",
                self.mass_rate_kg_per_s
            ));
        }
        if !(self.interval_s.is_finite() && self.interval_s > 0.0) {
            return bad(format!(
                "expected a positive batch interval, got {} s",
                self.interval_s
            ));
        }
        if !(self.start_s.is_finite() && self.end_s.is_finite() && self.end_s > self.start_s) {
            return bad(format!(
                "expected start < end, got {} s and {} s",
                self.start_s, self.end_s
            ));
        }
        if self.velocity_m_per_s.iter().any(|v| !v.is_finite()) {
            return bad("expected a finite velocity".to_string());
        }
        let mut rng = ChaCha8Rng::seed_from_u64(0);
        for (kind, t) in types.iter().enumerate() {
            if self.mass_fractions[kind] > 0.0 && self.region.sample(t.radius_m, &mut rng).is_none()
            {
                return bad(format!(
                    "particle type {kind} (radius {} m) does not fit inside the inflow region",
                    t.radius_m
                ));
            }
        }
        Ok(())
    }
}

/// How far an inflow has got: the part of [`InflowState`] its [`Inflow`] does not
/// give, which a saved state keeps so that a resumed run draws the same positions.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct InflowProgress {
    rng: ChaCha8Rng,
    batches: u64,
    inserted_kg: Vec<Real>,
}

/// An inflow and how far it has got.
#[derive(Debug, Clone)]
pub struct InflowState {
    inflow: Inflow,
    rng: ChaCha8Rng,
    batches: u64,
    inserted_kg: Vec<Real>,
}

impl InflowState {
    /// A fresh inflow (nothing inserted) for `n_types` particle types.
    pub fn new(inflow: Inflow, n_types: usize) -> Self {
        Self {
            rng: ChaCha8Rng::seed_from_u64(inflow.seed),
            inflow,
            batches: 0,
            inserted_kg: vec![0.0; n_types],
        }
    }

    /// The inflow.
    pub fn inflow(&self) -> &Inflow {
        &self.inflow
    }

    /// Mass inserted so far, kg.
    pub fn inserted_mass_kg(&self) -> Real {
        self.inserted_kg.iter().sum()
    }

    /// Mass the batches so far were asked to bring the inflow up to, kg:
    /// `rate × (min(start + batches × interval, end) − start)`. It exceeds
    /// [`InflowState::inserted_mass_kg`] by more than one particle when a batch found
    /// no room for all of its mass (and the next batches did not make it up).
    pub fn asked_mass_kg(&self) -> Real {
        if self.batches == 0 {
            return 0.0;
        }
        let horizon = self.next_batch_s().min(self.inflow.end_s);
        self.inflow.mass_rate_kg_per_s * (horizon - self.inflow.start_s)
    }

    /// Mass of each type inserted so far, kg.
    pub fn inserted_mass_by_type_kg(&self) -> &[Real] {
        &self.inserted_kg
    }

    /// How far the inflow has got (its random stream, batches and mass placed).
    pub fn progress(&self) -> InflowProgress {
        InflowProgress {
            rng: self.rng.clone(),
            batches: self.batches,
            inserted_kg: self.inserted_kg.clone(),
        }
    }

    /// Takes up `progress` (from [`InflowState::progress`] of the same inflow); `false`,
    /// and nothing changed, when it counts another number of particle types.
    pub fn resume(&mut self, progress: InflowProgress) -> bool {
        if progress.inserted_kg.len() != self.inserted_kg.len() {
            return false;
        }
        self.rng = progress.rng;
        self.batches = progress.batches;
        self.inserted_kg = progress.inserted_kg;
        true
    }

    fn next_batch_s(&self) -> Real {
        self.inflow.start_s + self.batches as Real * self.inflow.interval_s
    }

    /// Whether a batch is due at `time_s`.
    pub fn is_due(&self, time_s: Real) -> bool {
        let next = self.next_batch_s();
        next < self.inflow.end_s && time_s >= next
    }

    /// Inserts the batch due at `time_s` (if any) into `particles`, numbering new
    /// particles from `*next_id` (advanced); returns how many were inserted. They
    /// avoid every particle in `particles`.
    pub fn insert_due(
        &mut self,
        time_s: Real,
        types: &[ParticleType],
        particles: &mut Particles,
        next_id: &mut u32,
    ) -> usize {
        if !self.is_due(time_s) {
            return 0;
        }
        self.batches += 1;
        let target = self.asked_mass_kg();
        let inflow = &self.inflow;
        let largest = types.iter().map(|t| t.radius_m).fold(0.0, Real::max);
        let (lo, hi) = inflow.region.bounds();
        let reach = Vec3::repeat(2.0 * largest);
        let (lo, hi) = (lo - reach, hi + reach);
        let mut grid = OccupancyGrid::new(2.0 * largest);
        let mut placed: Vec<(Vec3, Real, usize)> = Vec::new();
        for i in 0..particles.len() {
            let x = particles.position_m[i];
            if (0..3).all(|k| x[k] >= lo[k] && x[k] <= hi[k]) {
                grid.add(placed.len(), x);
                placed.push((x, particles.radius_m[i], particles.kind[i] as usize));
            }
        }
        let mut count = 0;
        // Types that found no room in this batch: the others go on without them.
        let mut full = vec![false; types.len()];
        loop {
            let total: Real = self.inserted_kg.iter().sum();
            if total >= target {
                break;
            }
            // The type furthest behind its share (the first on a tie) that still finds
            // room.
            let Some(kind) = (0..types.len())
                .filter(|&k| !full[k])
                .map(|k| (k, inflow.mass_fractions[k] * target - self.inserted_kg[k]))
                .fold(None, |best: Option<(usize, Real)>, (k, d)| match best {
                    Some((_, best_d)) if d <= best_d => best,
                    _ => Some((k, d)),
                })
                .map(|(k, _)| k)
            else {
                break;
            };
            let radius = types[kind].radius_m;
            let mut found = None;
            for _ in 0..INFLOW_ATTEMPTS {
                let Some(centre) = inflow.region.sample(radius, &mut self.rng) else {
                    break;
                };
                if !grid.overlaps(&placed, centre, radius) {
                    found = Some(centre);
                    break;
                }
            }
            let Some(centre) = found else {
                full[kind] = true;
                continue;
            };
            grid.add(placed.len(), centre);
            placed.push((centre, radius, kind));
            particles.push(*next_id, kind as u16, &types[kind], centre);
            let last = particles.len() - 1;
            particles.velocity_m_per_s[last] = inflow.velocity_m_per_s;
            *next_id += 1;
            self.inserted_kg[kind] += types[kind].mass_kg();
            count += 1;
        }
        count
    }
}
