//! Insertion of a polydisperse mixture into a region without overlaps: random
//! sequential addition, largest particles first, seeded so that a case inserts the same
//! packing every time.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::material::ParticleType;
use crate::math::{Real, Vec3};
use crate::particles::Particles;

/// Where particles are inserted; every particle lies wholly inside.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Region {
    /// A vertical cylinder.
    Cylinder {
        /// Axis position (x, y), m.
        centre_m: [Real; 2],
        /// Radius, m.
        radius_m: Real,
        /// Bottom, m.
        z_min_m: Real,
        /// Top, m.
        z_max_m: Real,
    },
    /// An axis-aligned box.
    Box {
        /// Lower corner, m.
        min_m: Vec3,
        /// Upper corner, m.
        max_m: Vec3,
    },
}

impl Region {
    /// The region's axis-aligned bounding box (lower, upper corner), m.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        match *self {
            Region::Cylinder {
                centre_m,
                radius_m,
                z_min_m,
                z_max_m,
            } => (
                Vec3::new(centre_m[0] - radius_m, centre_m[1] - radius_m, z_min_m),
                Vec3::new(centre_m[0] + radius_m, centre_m[1] + radius_m, z_max_m),
            ),
            Region::Box { min_m, max_m } => (min_m, max_m),
        }
    }

    /// A uniformly random centre for a sphere of `radius_m` wholly inside, or `None`
    /// when no such sphere fits.
    pub(crate) fn sample(&self, radius_m: Real, rng: &mut ChaCha8Rng) -> Option<Vec3> {
        match *self {
            Region::Cylinder {
                centre_m,
                radius_m: cylinder_radius,
                z_min_m,
                z_max_m,
            } => {
                let reach = cylinder_radius - radius_m;
                let (low, high) = (z_min_m + radius_m, z_max_m - radius_m);
                if reach < 0.0 || low > high {
                    return None;
                }
                let r = reach * rng.random::<Real>().sqrt();
                let angle = 2.0 * std::f64::consts::PI * rng.random::<Real>();
                Some(Vec3::new(
                    centre_m[0] + r * angle.cos(),
                    centre_m[1] + r * angle.sin(),
                    low + (high - low) * rng.random::<Real>(),
                ))
            }
            Region::Box { min_m, max_m } => {
                let mut centre = Vec3::zeros();
                for axis in 0..3 {
                    let (low, high) = (min_m[axis] + radius_m, max_m[axis] - radius_m);
                    if low > high {
                        return None;
                    }
                    centre[axis] = low + (high - low) * rng.random::<Real>();
                }
                Some(centre)
            }
        }
    }
}

/// Why an insertion could not place every particle.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum InsertionError {
    /// The region is too small for the particles asked for.
    #[error("the fill region holds only {placed} of the {requested} particles without overlaps (random sequential addition gave up after {attempts} tries for one particle); enlarge the region or insert fewer particles")]
    RegionFull {
        /// Particles placed before giving up.
        placed: usize,
        /// Particles asked for.
        requested: usize,
        /// Tries for the particle that did not fit.
        attempts: usize,
    },
    /// A particle type is larger than the region.
    #[error("particle type {kind} (radius {radius_m} m) does not fit inside the fill region")]
    TooLarge {
        /// Type index.
        kind: usize,
        /// Its radius, m.
        radius_m: Real,
    },
}

/// Numbers of particles of each type for `total` particles whose types make up the
/// given mass fractions (which must sum to 1), rounded so that they add up to `total`.
pub fn counts_from_mass_fractions(
    types: &[ParticleType],
    mass_fractions: &[Real],
    total: usize,
) -> Vec<usize> {
    let per_mass: Vec<Real> = types
        .iter()
        .zip(mass_fractions)
        .map(|(t, w)| w / t.mass_kg())
        .collect();
    let sum: Real = per_mass.iter().sum();
    let mut counts: Vec<usize> = per_mass
        .iter()
        .map(|p| (p / sum * total as Real).round() as usize)
        .collect();
    // Give the rounding difference to the most numerous type.
    let assigned: usize = counts.iter().sum();
    if let Some(largest) = (0..counts.len()).max_by_key(|&k| counts[k]) {
        counts[largest] = (counts[largest] + total).saturating_sub(assigned);
    }
    counts
}

/// Tries per particle before random sequential addition gives up.
pub const MAX_ATTEMPTS: usize = 20_000;

/// Inserts `counts[k]` particles of each type `k` into `region` at rest, none
/// overlapping another, numbering them from `first_id`; largest first, seeded.
pub fn insert(
    particles: &mut Particles,
    types: &[ParticleType],
    counts: &[usize],
    region: &Region,
    seed: u64,
    first_id: u32,
) -> Result<(), InsertionError> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut order: Vec<usize> = (0..types.len()).collect();
    order.sort_by(|&a, &b| types[b].radius_m.total_cmp(&types[a].radius_m));
    let requested: usize = counts.iter().sum();
    let largest = types.iter().map(|t| t.radius_m).fold(0.0, Real::max);
    let mut grid = OccupancyGrid::new(2.0 * largest);
    let mut placed: Vec<(Vec3, Real, usize)> = Vec::with_capacity(requested);
    for &kind in &order {
        let radius = types[kind].radius_m;
        if region.sample(radius, &mut rng).is_none() {
            return Err(InsertionError::TooLarge {
                kind,
                radius_m: radius,
            });
        }
        for _ in 0..counts[kind] {
            let mut found = None;
            for _ in 0..MAX_ATTEMPTS {
                let centre = region.sample(radius, &mut rng).expect("checked above");
                if !grid.overlaps(&placed, centre, radius) {
                    found = Some(centre);
                    break;
                }
            }
            let Some(centre) = found else {
                return Err(InsertionError::RegionFull {
                    placed: placed.len(),
                    requested,
                    attempts: MAX_ATTEMPTS,
                });
            };
            grid.add(placed.len(), centre);
            placed.push((centre, radius, kind));
        }
    }
    // Ids follow height so that dumps read naturally; the packing is what the seed fixed.
    placed.sort_by(|a, b| a.0.z.total_cmp(&b.0.z));
    for (offset, (centre, _, kind)) in placed.into_iter().enumerate() {
        particles.push(first_id + offset as u32, kind as u16, &types[kind], centre);
    }
    Ok(())
}

/// A hash grid of placed centres for overlap checks during insertion.
pub(crate) struct OccupancyGrid {
    cell_m: Real,
    cells: std::collections::HashMap<[i64; 3], Vec<usize>>,
}

impl OccupancyGrid {
    pub(crate) fn new(cell_m: Real) -> Self {
        Self {
            cell_m,
            cells: Default::default(),
        }
    }

    fn cell(&self, p: Vec3) -> [i64; 3] {
        [0, 1, 2].map(|k| (p[k] / self.cell_m).floor() as i64)
    }

    pub(crate) fn add(&mut self, index: usize, centre: Vec3) {
        self.cells.entry(self.cell(centre)).or_default().push(index);
    }

    pub(crate) fn overlaps(
        &self,
        placed: &[(Vec3, Real, usize)],
        centre: Vec3,
        radius: Real,
    ) -> bool {
        let [cx, cy, cz] = self.cell(centre);
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let Some(members) = self.cells.get(&[cx + dx, cy + dy, cz + dz]) else {
                        continue;
                    };
                    for &j in members {
                        let (other, other_radius, _) = placed[j];
                        let reach = radius + other_radius;
                        if (other - centre).norm_squared() < reach * reach {
                            return true;
                        }
                    }
                }
            }
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::Material;

    fn sphere(radius_m: Real) -> ParticleType {
        ParticleType {
            radius_m,
            density_kg_m3: 2500.0,
            material: Material {
                youngs_modulus_pa: 5e6,
                poisson_ratio: 0.3,
                restitution: 0.6,
                friction: 0.5,
                rolling_friction: 0.0,
            },
        }
    }

    #[test]
    fn half_and_half_by_mass_of_4_and_2_mm_is_one_coarse_to_eight_fine() {
        let types = [sphere(0.002), sphere(0.001)];
        assert_eq!(
            counts_from_mass_fractions(&types, &[0.5, 0.5], 3000),
            vec![333, 2667]
        );
    }

    #[test]
    fn insertion_is_seeded_inside_and_without_overlaps() {
        let types = [sphere(0.002), sphere(0.001)];
        let region = Region::Cylinder {
            centre_m: [0.0, 0.0],
            radius_m: 0.02,
            z_min_m: 0.0,
            z_max_m: 0.05,
        };
        let mut a = Particles::default();
        insert(&mut a, &types, &[50, 400], &region, 7, 1).unwrap();
        let mut b = Particles::default();
        insert(&mut b, &types, &[50, 400], &region, 7, 1).unwrap();
        assert_eq!(a.position_m, b.position_m);
        assert_eq!(a.len(), 450);
        for i in 0..a.len() {
            let p = a.position_m[i];
            let r = a.radius_m[i];
            assert!(p.xy().norm() + r <= 0.02 + 1e-12 && p.z - r >= 0.0 && p.z + r <= 0.05);
            for j in 0..i {
                let reach = r + a.radius_m[j];
                assert!((p - a.position_m[j]).norm() >= reach);
            }
        }
    }

    #[test]
    fn an_overfull_region_is_an_error_not_a_hang() {
        let types = [sphere(0.002)];
        let region = Region::Box {
            min_m: Vec3::zeros(),
            max_m: Vec3::new(0.01, 0.01, 0.01),
        };
        let error = insert(&mut Particles::default(), &types, &[100], &region, 1, 1).unwrap_err();
        assert!(matches!(
            error,
            InsertionError::RegionFull { requested: 100, .. }
        ));
        let error = insert(
            &mut Particles::default(),
            &[sphere(0.02)],
            &[1],
            &region,
            1,
            1,
        )
        .unwrap_err();
        assert!(error.to_string().contains("does not fit"));
    }
}
