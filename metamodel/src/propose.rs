//! The next round: a smaller box around the optimum (a trust region), and when to stop.

use crate::FactorRange;

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
}
