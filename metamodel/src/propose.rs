//! The next round: a smaller box around the optimum (a trust region), points where a
//! surrogate is least certain, and when to stop.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::optimise::BoxBounds;
use crate::FactorRange;

/// Up to `count` points of `bounds` (coded) where `std` (a surrogate's standard error,
/// response units) is largest, at least `spacing` (coded distance) from each other and
/// from `avoid` (the runs already made): the surrogate's least certain places, to be
/// run so that the next round tests it where it knows least. Picked greedily from
/// `1000 k` seeded random candidates; fewer than `count` when the spacing leaves no
/// room.
pub fn least_certain(
    std: &dyn Fn(&[f64]) -> f64,
    bounds: &BoxBounds,
    avoid: &[Vec<f64>],
    count: usize,
    spacing: f64,
    seed: u64,
) -> Vec<Vec<f64>> {
    let k = bounds.lower.len();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut candidates: Vec<(f64, Vec<f64>)> = (0..1000 * k.max(1))
        .map(|_| {
            let x: Vec<f64> = (0..k)
                .map(|i| {
                    if bounds.upper[i] > bounds.lower[i] {
                        rng.random_range(bounds.lower[i]..=bounds.upper[i])
                    } else {
                        bounds.lower[i]
                    }
                })
                .collect();
            (std(&x), x)
        })
        .filter(|(s, _)| s.is_finite())
        .collect();
    candidates.sort_by(|a, b| b.0.total_cmp(&a.0));
    let far = |x: &[f64], from: &[f64]| {
        x.iter()
            .zip(from)
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>()
            >= spacing * spacing
    };
    let mut chosen: Vec<Vec<f64>> = Vec::new();
    for (_, x) in candidates {
        if chosen.len() == count {
            break;
        }
        if avoid.iter().chain(&chosen).all(|p| far(&x, p)) {
            chosen.push(x);
        }
    }
    chosen
}

/// Box of the next round: centred on `optimum` (natural units), each half-width
/// `shrink` times the current one, moved back inside `limits` when it would leave
/// them (and cut to them when it is wider).
pub fn shrink_around(
    optimum: &[f64],
    current: &[FactorRange],
    limits: &[FactorRange],
    shrink: f64,
) -> Vec<FactorRange> {
    optimum
        .iter()
        .zip(current)
        .zip(limits)
        .map(|((&centre, range), limit)| {
            let half = (0.5 * (range.max - range.min) * shrink).min(0.5 * (limit.max - limit.min));
            let mut min = centre - half;
            let mut max = centre + half;
            if min < limit.min {
                max += limit.min - min;
                min = limit.min;
            }
            if max > limit.max {
                min -= max - limit.max;
                max = limit.max;
            }
            FactorRange {
                min: min.max(limit.min),
                max,
            }
        })
        .collect()
}

/// True when the predicted optimum moved by less than `tolerance` relative to its size.
pub fn converged(previous_value: f64, new_value: f64, tolerance: f64) -> bool {
    (new_value - previous_value).abs() <= tolerance * previous_value.abs().max(f64::MIN_POSITIVE)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn r(min: f64, max: f64) -> FactorRange {
        FactorRange { min, max }
    }

    #[test]
    fn the_next_box_is_centred_on_the_optimum_and_half_as_wide() {
        let next = shrink_around(
            &[0.024, 30.0],
            &[r(0.02, 0.028), r(20.0, 50.0)],
            &[r(0.02, 0.028), r(20.0, 50.0)],
            0.5,
        );
        assert!((next[0].min - 0.022).abs() < 1e-15 && (next[0].max - 0.026).abs() < 1e-15);
        assert_eq!((next[1].min, next[1].max), (22.5, 37.5));
    }

    #[test]
    fn a_box_at_the_edge_is_moved_back_inside_the_limits() {
        let next = shrink_around(&[50.0], &[r(20.0, 50.0)], &[r(20.0, 50.0)], 0.5);
        assert_eq!((next[0].min, next[0].max), (35.0, 50.0));
    }

    #[test]
    fn convergence_is_relative() {
        assert!(converged(0.150, 0.1505, 0.01));
        assert!(!converged(0.150, 0.160, 0.01));
    }

    #[test]
    fn the_least_certain_points_are_where_the_error_peaks_and_keep_their_distance() {
        // The error grows with the distance from the origin: the corners first, each
        // once, and never a point already run.
        let std = |x: &[f64]| x.iter().map(|v| v * v).sum::<f64>().sqrt();
        let bounds = BoxBounds::coded(2);
        let avoid = vec![vec![1.0, 1.0]];
        let points = least_certain(&std, &bounds, &avoid, 3, 0.5, 1);
        assert_eq!(points.len(), 3);
        for p in &points {
            assert!(std(p) > 1.2, "{p:?} is not near a corner");
            assert!(
                p.iter()
                    .zip(&avoid[0])
                    .map(|(a, b)| (a - b).powi(2))
                    .sum::<f64>()
                    >= 0.25
            );
        }
        // Each corner once: the three other than (1, 1).
        let mut signs: Vec<(bool, bool)> =
            points.iter().map(|p| (p[0] > 0.0, p[1] > 0.0)).collect();
        signs.sort();
        assert_eq!(signs, [(false, false), (false, true), (true, false)]);
        // A fixed dimension stays fixed.
        let fixed = BoxBounds {
            lower: vec![-1.0, 0.3],
            upper: vec![1.0, 0.3],
            levels: Vec::new(),
        };
        assert!(least_certain(&std, &fixed, &[], 2, 0.5, 2)
            .iter()
            .all(|p| p[1] == 0.3));
    }
}
