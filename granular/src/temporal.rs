//! Segregation in time: which share of the fines leaves early, which late.
//!
//! A hopper can sort a mixture without any radial segregation at its outlet: if the
//! fines sink through the coarse bed while it is filled (or shaken), the stream carries
//! more of them early in the discharge and fewer late. The mass fraction of fines in
//! consecutive slices of equal discharged mass shows it; Ketterhagen et al. (2007,
//! *Chemical Engineering Science* 62, 6423–6439) plot the same, normalised by the fill's
//! fraction, against the discharged mass fraction.
//!
//! Each crossing belongs to the slice that holds the midpoint of its own mass in the
//! cumulative discharged mass (crossings in time order), so no particle is split and
//! every slice's fraction is a plain mass ratio.

use crate::crossing::Crossing;

/// One slice of the discharge, in crossing-time order.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MassSlice {
    /// Mass-weighted mean crossing time of the slice, s.
    pub time_s: f64,
    /// Mass of the slice, kg.
    pub mass_kg: f64,
    /// Mass fraction of fines in the slice.
    pub fine_mass_fraction: f64,
}

/// The fines' mass fraction in `slices` consecutive slices of equal discharged mass.
/// Empty when nothing crossed or `slices` is 0; a slice that no crossing's midpoint
/// falls in (possible only when single particles outweigh a slice) is left out.
pub fn fine_fraction_by_discharged_mass(
    crossings: &[Crossing],
    fine_type: u32,
    slices: usize,
) -> Vec<MassSlice> {
    let total: f64 = crossings.iter().map(|c| c.mass_kg).sum();
    if slices == 0 || total <= 0.0 {
        return Vec::new();
    }
    let mut ordered: Vec<&Crossing> = crossings.iter().collect();
    ordered.sort_by(|a, b| a.time_s.total_cmp(&b.time_s).then(a.id.cmp(&b.id)));
    // Per slice: mass, fine mass, mass × time.
    let mut sums = vec![(0.0, 0.0, 0.0); slices];
    let mut before = 0.0;
    for c in ordered {
        let midpoint = (before + 0.5 * c.mass_kg) / total;
        before += c.mass_kg;
        let slice = ((midpoint * slices as f64) as usize).min(slices - 1);
        let (mass, fine, timed) = &mut sums[slice];
        *mass += c.mass_kg;
        *timed += c.mass_kg * c.time_s;
        if c.particle_type == fine_type {
            *fine += c.mass_kg;
        }
    }
    sums.into_iter()
        .filter(|&(mass, _, _)| mass > 0.0)
        .map(|(mass, fine, timed)| MassSlice {
            time_s: timed / mass,
            mass_kg: mass,
            fine_mass_fraction: fine / mass,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn crossing(id: u64, time_s: f64, fine: bool) -> Crossing {
        Crossing {
            id,
            particle_type: if fine { 2 } else { 1 },
            time_s,
            position_m: [0.0, 0.0, 0.0],
            velocity_m_per_s: [0.0, 0.0, -1.0],
            radius_m: if fine { 0.001 } else { 0.002 },
            mass_kg: 1.0,
        }
    }

    #[test]
    fn fines_that_leave_first_fill_the_first_slices() {
        // 40 particles of equal mass: the first 10 fine, then 30 coarse, given out of
        // order: quarters of 10 particles each.
        let mut crossings: Vec<Crossing> = (0..40)
            .map(|k| crossing(k, k as f64 * 0.01, k < 10))
            .collect();
        crossings.reverse();
        let quarters = fine_fraction_by_discharged_mass(&crossings, 2, 4);
        let fractions: Vec<f64> = quarters.iter().map(|q| q.fine_mass_fraction).collect();
        assert_eq!(fractions, vec![1.0, 0.0, 0.0, 0.0]);
        assert!((quarters[0].time_s - 0.045).abs() < 1e-12);
        assert!(quarters.iter().all(|q| q.mass_kg == 10.0));
    }

    #[test]
    fn a_mixed_stream_has_the_fill_s_fraction_in_every_slice() {
        let crossings: Vec<Crossing> = (0..100)
            .map(|k| crossing(k, k as f64, k % 5 == 0))
            .collect();
        for slice in fine_fraction_by_discharged_mass(&crossings, 2, 5) {
            assert!((slice.fine_mass_fraction - 0.2).abs() < 1e-12, "{slice:?}");
        }
    }

    #[test]
    fn nothing_crossed_gives_no_slices() {
        assert!(fine_fraction_by_discharged_mass(&[], 2, 4).is_empty());
        assert!(fine_fraction_by_discharged_mass(&[crossing(1, 0.0, true)], 2, 0).is_empty());
    }
}
