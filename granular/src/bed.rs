//! Radial size segregation of a settled bed: how far from the hopper's axis the fine
//! and the coarse particles lie before the outlet opens.
//!
//! Pouring a bidisperse mixture onto a heap from a central inlet segregates it: fines
//! percolate into the heap's core under the inlet while coarse particles roll down its
//! flanks to the wall. The ratio of the fines' mean radial distance to the coarse
//! particles' measures that state; a mixture placed at random gives about 1 (a little
//! above, since a fine centre can come closer to the wall than a coarse one).

use crate::crossing::Sighting;

/// Mean radial distances of the two sizes in a bed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BedRadialProfile {
    /// Mean distance of fine particles' centres from the vertical axis, m.
    pub fine_mean_radius_m: f64,
    /// Mean distance of coarse particles' centres from the vertical axis, m.
    pub coarse_mean_radius_m: f64,
    /// Fine particles counted.
    pub fine_count: usize,
    /// Coarse particles counted.
    pub coarse_count: usize,
}

impl BedRadialProfile {
    /// The profile of `particles` around the axis x = y = 0. Particles whose radius is
    /// below the midpoint of the smallest and largest radius are fine, the others
    /// coarse. `None` when either size is missing.
    pub fn of(particles: &[Sighting]) -> Option<BedRadialProfile> {
        let smallest = particles
            .iter()
            .map(|p| p.radius_m)
            .fold(f64::INFINITY, f64::min);
        let largest = particles.iter().map(|p| p.radius_m).fold(0.0, f64::max);
        let cut = 0.5 * (smallest + largest);
        let (mut fine_sum, mut coarse_sum) = (0.0, 0.0);
        let (mut fine_count, mut coarse_count) = (0, 0);
        for p in particles {
            let r = p.position_m[0].hypot(p.position_m[1]);
            if p.radius_m < cut {
                fine_sum += r;
                fine_count += 1;
            } else {
                coarse_sum += r;
                coarse_count += 1;
            }
        }
        (fine_count > 0 && coarse_count > 0).then(|| BedRadialProfile {
            fine_mean_radius_m: fine_sum / fine_count as f64,
            coarse_mean_radius_m: coarse_sum / coarse_count as f64,
            fine_count,
            coarse_count,
        })
    }

    /// Fines' mean radial distance over the coarse particles'; below 1 the fines
    /// gather nearer the axis.
    pub fn ratio(&self) -> f64 {
        self.fine_mean_radius_m / self.coarse_mean_radius_m
    }
}

/// The angle of a heap's free surface around the vertical axis x = y = 0, degrees,
/// positive when the surface falls away from the axis (a poured cone's angle of
/// repose).
///
/// The rings `[r, r + ring_m)` from `from_m` to `to_m` each give a surface height: the
/// mean top (centre height plus radius) of their `highest` highest particles, so that
/// one particle perched on the heap does not set it. The angle is that of the
/// least-squares line through the rings' mid-radii and heights. `None` when a ring
/// holds fewer than `highest` particles or there are fewer than two rings.
pub fn heap_angle_deg(
    particles: &[Sighting],
    from_m: f64,
    to_m: f64,
    ring_m: f64,
    highest: usize,
) -> Option<f64> {
    let rings = ((to_m - from_m) / ring_m).floor() as usize;
    if rings < 2 || highest == 0 {
        return None;
    }
    let mut tops: Vec<Vec<f64>> = vec![Vec::new(); rings];
    for p in particles {
        let r = p.position_m[0].hypot(p.position_m[1]);
        if r >= from_m {
            let ring = ((r - from_m) / ring_m) as usize;
            if ring < rings {
                tops[ring].push(p.position_m[2] + p.radius_m);
            }
        }
    }
    let mut points = Vec::with_capacity(rings);
    for (k, ring) in tops.iter_mut().enumerate() {
        if ring.len() < highest {
            return None;
        }
        ring.sort_by(|a, b| b.total_cmp(a));
        let height = ring[..highest].iter().sum::<f64>() / highest as f64;
        points.push((from_m + (k as f64 + 0.5) * ring_m, height));
    }
    let n = points.len() as f64;
    let mean_r = points.iter().map(|p| p.0).sum::<f64>() / n;
    let mean_h = points.iter().map(|p| p.1).sum::<f64>() / n;
    let (mut covariance, mut variance) = (0.0, 0.0);
    for (r, h) in &points {
        covariance += (r - mean_r) * (h - mean_h);
        variance += (r - mean_r) * (r - mean_r);
    }
    Some((-covariance / variance).atan().to_degrees())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn particle(radius_m: f64, x: f64, y: f64) -> Sighting {
        Sighting {
            id: 0,
            particle_type: 1,
            radius_m,
            mass_kg: 1.0,
            position_m: [x, y, 0.01],
            velocity_m_per_s: [0.0; 3],
        }
    }

    #[test]
    fn two_rings_give_the_ratio_of_their_radii() {
        let mut bed = Vec::new();
        for k in 0..36 {
            let angle = k as f64 * std::f64::consts::TAU / 36.0;
            bed.push(particle(0.001, 0.01 * angle.cos(), 0.01 * angle.sin()));
            bed.push(particle(0.002, 0.03 * angle.cos(), 0.03 * angle.sin()));
        }
        let profile = BedRadialProfile::of(&bed).unwrap();
        assert!((profile.fine_mean_radius_m - 0.01).abs() < 1e-15);
        assert!((profile.coarse_mean_radius_m - 0.03).abs() < 1e-15);
        assert_eq!((profile.fine_count, profile.coarse_count), (36, 36));
        assert!((profile.ratio() - 1.0 / 3.0).abs() < 1e-12);
    }

    #[test]
    fn a_uniform_mixture_on_a_disk_gives_one() {
        // Both sizes on the same polar grid, uniform in area: the ratio is exactly 1.
        let mut bed = Vec::new();
        for i in 0..20 {
            let r = 0.03 * ((i as f64 + 0.5) / 20.0).sqrt();
            for k in 0..24 {
                let angle = k as f64 * std::f64::consts::TAU / 24.0;
                bed.push(particle(0.001, r * angle.cos(), r * angle.sin()));
                bed.push(particle(0.002, r * angle.cos(), r * angle.sin()));
            }
        }
        let profile = BedRadialProfile::of(&bed).unwrap();
        assert!((profile.ratio() - 1.0).abs() < 1e-12);
        // Mean radius of a uniform disk is 2R/3, to the grid's resolution.
        assert!((profile.fine_mean_radius_m - 0.02).abs() < 2e-4);
    }

    /// Particles on a cone of 25° and a filling below it: the angle comes back.
    #[test]
    fn a_cone_of_particles_gives_its_angle() {
        let (radius, top, slope) = (0.0015, 0.03, 25f64.to_radians().tan());
        let mut heap = Vec::new();
        for i in 0..40 {
            let r = 0.001 * i as f64;
            for k in 0..36 {
                let angle = k as f64 * std::f64::consts::TAU / 36.0 + 0.1 * i as f64;
                let (x, y) = (r * angle.cos(), r * angle.sin());
                let surface = top - r * slope;
                heap.push(Sighting {
                    position_m: [x, y, surface - radius],
                    ..particle(radius, x, y)
                });
                heap.push(Sighting {
                    position_m: [x, y, 0.5 * surface],
                    ..particle(radius, x, y)
                });
            }
        }
        let angle = heap_angle_deg(&heap, 0.005, 0.035, 0.005, 3).unwrap();
        assert!((angle - 25.0).abs() < 0.5, "{angle}");
        // A ring with too few particles, or a single ring, gives no angle.
        assert_eq!(heap_angle_deg(&heap, 0.005, 0.035, 0.005, 1000), None);
        assert_eq!(heap_angle_deg(&heap, 0.005, 0.009, 0.005, 3), None);
    }

    #[test]
    fn one_size_alone_has_no_profile() {
        let bed = vec![particle(0.001, 0.01, 0.0), particle(0.001, 0.0, 0.02)];
        assert_eq!(BedRadialProfile::of(&bed), None);
        assert_eq!(BedRadialProfile::of(&[]), None);
    }
}
