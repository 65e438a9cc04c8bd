//! Radial statistics of the crossings of a sensor plane across a stream falling along
//! the hopper axis: the robust stream radius, the fine fraction of the outer layers,
//! the uniform-mixing expectation of `R1/R2`, and radial probability densities.
//!
//! Two distances of a crossing from the axis are used. The *centre distance*
//! `r` ([`Crossing::radial_distance_m`]) is the thesis's radial distance (`R1_mean`,
//! `R2_mean`, the densities). The *surface distance* `r + a` (`a` the particle's
//! radius) is how far the particle's material reaches; it is what the outer layers and
//! the stream radius are measured by, because a wall or the stream's free edge bounds
//! surfaces, not centres: a coarse centre cannot come within `a_c` of a wall, a fine
//! one within `a_f`, so by centres alone the outermost band holds only fines whatever
//! the mixing (docs/method.md, "Responses of the hopper").

use crate::crossing::Crossing;

/// How far a crossing's material reaches from the axis: centre distance plus radius, m.
pub fn surface_distance_m(c: &Crossing) -> f64 {
    c.radial_distance_m() + c.radius_m
}

/// The mass-weighted `q`-quantile of `value` over the crossings: the smallest value
/// at which the mass of crossings with a value at or below it reaches `q` of the
/// total. `None` without mass.
pub fn mass_quantile(
    crossings: &[Crossing],
    value: impl Fn(&Crossing) -> f64,
    q: f64,
) -> Option<f64> {
    let mut pairs: Vec<(f64, f64)> = crossings.iter().map(|c| (value(c), c.mass_kg)).collect();
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
    let total: f64 = pairs.iter().map(|p| p.1).sum();
    if total <= 0.0 {
        return None;
    }
    let target = q.clamp(0.0, 1.0) * total;
    let mut cumulative = 0.0;
    for &(v, m) in &pairs {
        cumulative += m;
        if cumulative >= target * (1.0 - 1e-12) {
            return Some(v);
        }
    }
    pairs.last().map(|p| p.0)
}

/// The robust stream radius `R_s`: the mass-weighted `q`-quantile of the surface
/// distances (`q` = 0.95 for the hopper's `stream_radius_95`), m.
pub fn stream_radius_m(crossings: &[Crossing], q: f64) -> Option<f64> {
    mass_quantile(crossings, surface_distance_m, q)
}

/// Mass fraction of fines (`fine_type`) among the crossings whose surface reaches at
/// least `(1 − layer) · stream_radius_m`; `None` when that layer holds no mass.
///
/// With `stream_radius_m` the 95 % quantile of surface distances, every layer holds
/// at least 5 % of the mass that crossed, so it is a proportion of many particles.
pub fn outer_layer_fine_fraction(
    crossings: &[Crossing],
    stream_radius_m: f64,
    layer: f64,
    fine_type: u32,
) -> Option<f64> {
    let threshold = (1.0 - layer) * stream_radius_m;
    let (fine, total) = crossings
        .iter()
        .filter(|c| surface_distance_m(c) >= threshold)
        .fold((0.0, 0.0), |(fine, total), c| {
            let f = if c.particle_type == fine_type {
                c.mass_kg
            } else {
                0.0
            };
            (fine + f, total + c.mass_kg)
        });
    (total > 0.0).then(|| fine / total)
}

/// What `R1_mean / R2_mean` is when fines and coarse are perfectly mixed but their
/// centres are kept `fine_radius_m` and `coarse_radius_m` from the stream's edge at
/// `stream_radius_m`: centres uniform over discs of radii `R − a_f` and `R − a_c`
/// have mean distances `2(R − a)/3`, so the ratio is `(R − a_f)/(R − a_c)`. `None`
/// when the coarse disc is empty.
pub fn uniform_mixing_ratio(
    stream_radius_m: f64,
    fine_radius_m: f64,
    coarse_radius_m: f64,
) -> Option<f64> {
    let coarse = stream_radius_m - coarse_radius_m;
    (coarse > 0.0).then(|| (stream_radius_m - fine_radius_m) / coarse)
}

/// The probability density of the centre distance of the crossings `select` picks,
/// as a histogram of `bins` equal bins over `[0, r_max_m]`: `(bin centre m, density
/// 1/m)`, integrating to 1 over the bins (a crossing beyond `r_max_m` counts in the
/// last bin). Empty when nothing is selected or `r_max_m` is not positive.
pub fn radial_density(
    crossings: &[Crossing],
    select: impl Fn(&Crossing) -> bool,
    r_max_m: f64,
    bins: usize,
) -> Vec<(f64, f64)> {
    if r_max_m.is_nan() || r_max_m <= 0.0 || bins == 0 {
        return Vec::new();
    }
    let width = r_max_m / bins as f64;
    let mut counts = vec![0usize; bins];
    let mut n = 0usize;
    for c in crossings.iter().filter(|c| select(c)) {
        let index = ((c.radial_distance_m() / width) as usize).min(bins - 1);
        counts[index] += 1;
        n += 1;
    }
    if n == 0 {
        return Vec::new();
    }
    counts
        .iter()
        .enumerate()
        .map(|(i, &k)| ((i as f64 + 0.5) * width, k as f64 / (n as f64 * width)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synthetic::{ring, Kind};

    #[test]
    fn the_mass_quantile_is_where_the_mass_below_reaches_q() {
        // Masses 1, 1, 2 at 1, 2, 3: half of the mass is reached at 2, 95 % at 3.
        let kind = |m: f64| Kind {
            particle_type: 1,
            radius_m: 0.0,
            mass_kg: m,
        };
        let mut c = ring(kind(1.0), 1, 0.0, 0.0, 0);
        c[0].position_m[0] = 1.0;
        let mut two = ring(kind(1.0), 1, 0.0, 0.0, 1);
        two[0].position_m[0] = 2.0;
        let mut three = ring(kind(2.0), 1, 0.0, 0.0, 2);
        three[0].position_m[0] = 3.0;
        c.extend(two);
        c.extend(three);
        let r = |c: &Crossing| c.radial_distance_m();
        assert_eq!(mass_quantile(&c, r, 0.5), Some(2.0));
        assert_eq!(mass_quantile(&c, r, 0.95), Some(3.0));
        assert_eq!(mass_quantile(&c, r, 0.0), Some(1.0));
        assert_eq!(mass_quantile(&[], r, 0.5), None);
    }

    #[test]
    fn uniform_mixing_ratio_is_that_of_the_accessible_discs() {
        let ratio = uniform_mixing_ratio(0.012, 0.001, 0.002).unwrap();
        assert!((ratio - 1.1).abs() < 1e-12, "{ratio}");
        assert_eq!(uniform_mixing_ratio(0.002, 0.001, 0.002), None);
    }

    #[test]
    fn no_selected_crossings_give_an_empty_density() {
        let kind = Kind {
            particle_type: 1,
            radius_m: 0.0,
            mass_kg: 1.0,
        };
        let c = ring(kind, 10, 0.0, 1.0, 0);
        assert!(radial_density(&c, |c| c.particle_type == 2, 1.0, 10).is_empty());
        assert!(radial_density(&c, |_| true, 0.0, 10).is_empty());
        assert_eq!(radial_density(&c, |_| true, 1.0, 10).len(), 10);
    }
}
