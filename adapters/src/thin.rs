//! Bounded series: a run may write millions of values (a JSON array of 2·10^7 numbers,
//! a log line per step), but a stored series keeps at most [`MAX_SERIES_POINTS`] of
//! them, an even choice with the first and the last included, chosen while the values
//! stream past, so reading one never holds more than that many.
//!
//! The choice keeps every `stride`-th point; when the kept points exceed the bound,
//! every other one is dropped and the stride doubles. At the end the last point is
//! added when the stride skipped it. The kept points are then the indices 0, s, 2s, …
//! and the last: between half the bound and the bound, evenly spaced in index.

use crate::Series;

/// Most points a stored series keeps (10^4: a plot of it is still exact to the pixel).
pub const MAX_SERIES_POINTS: usize = 10_000;

/// An even choice of at most `max` + 1 points of a stream, first and last included.
#[derive(Debug, Clone)]
pub struct Thinned {
    max: usize,
    stride: usize,
    seen: usize,
    kept: Vec<(f64, f64)>,
    last: Option<(f64, f64)>,
}

impl Thinned {
    /// An empty choice bounded by `max` points (at least 2).
    pub fn new(max: usize) -> Thinned {
        Thinned {
            max: max.max(2),
            stride: 1,
            seen: 0,
            kept: Vec::new(),
            last: None,
        }
    }

    /// Offers the next point of the stream.
    pub fn push(&mut self, point: (f64, f64)) {
        if self.seen.is_multiple_of(self.stride) {
            self.kept.push(point);
            if self.kept.len() > self.max {
                let mut index = 0;
                self.kept.retain(|_| {
                    index += 1;
                    (index - 1) % 2 == 0
                });
                self.stride *= 2;
            }
        }
        self.last = Some(point);
        self.seen += 1;
    }

    /// Points offered so far.
    pub fn seen(&self) -> usize {
        self.seen
    }

    /// The chosen points, the last one included, and how many were offered.
    pub fn finish(mut self) -> (Vec<(f64, f64)>, usize) {
        if let Some(last) = self.last {
            if !(self.seen - 1).is_multiple_of(self.stride) {
                self.kept.push(last);
            }
        }
        (self.kept, self.seen)
    }
}

/// `series` bounded to [`MAX_SERIES_POINTS`] (+ its last point), and, when it had more,
/// the note that says so: `mass_flow (2·10^7 points) stored as 10001 of them …`.
pub fn bound_series(series: Series) -> (Series, Option<String>) {
    if series.points.len() <= MAX_SERIES_POINTS + 1 {
        return (series, None);
    }
    let mut thinned = Thinned::new(MAX_SERIES_POINTS);
    for &point in &series.points {
        thinned.push(point);
    }
    let (points, seen) = thinned.finish();
    let note = thinned_note(&series.name, seen, points.len());
    (
        Series {
            name: series.name,
            points,
        },
        Some(note),
    )
}

/// What a thinned series' note says.
pub fn thinned_note(name: &str, seen: usize, kept: usize) -> String {
    format!(
        "series `{name}` had {seen} points; {kept} of them are stored, evenly spaced with the first and the last (responses are computed from all {seen})"
    )
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    fn thinned(n: usize, max: usize) -> (Vec<(f64, f64)>, usize) {
        let mut thinned = Thinned::new(max);
        for i in 0..n {
            thinned.push((i as f64, 2.0 * i as f64));
        }
        thinned.finish()
    }

    #[test]
    fn a_short_series_is_kept_whole() {
        let (points, seen) = thinned(7, 10);
        assert_eq!(seen, 7);
        assert_eq!(points.len(), 7);
        assert_eq!(thinned(0, 10), (vec![], 0));
    }

    #[test]
    fn a_long_series_keeps_an_even_choice_with_its_first_and_last_point() {
        let (points, seen) = thinned(1_000_001, 1000);
        assert_eq!(seen, 1_000_001);
        assert!(
            points.len() > 500 && points.len() <= 1001,
            "{}",
            points.len()
        );
        assert_eq!(points[0], (0.0, 0.0));
        assert_eq!(*points.last().unwrap(), (1_000_000.0, 2_000_000.0));
        let steps: Vec<f64> = points[..points.len() - 1]
            .windows(2)
            .map(|w| w[1].0 - w[0].0)
            .collect();
        assert!(steps.iter().all(|&s| s == steps[0]), "evenly spaced");
    }

    #[test]
    fn a_bounded_series_says_how_many_points_it_had() {
        let series = Series {
            name: "flow".into(),
            points: (0..25_000).map(|i| (i as f64, 1.0)).collect(),
        };
        let (bounded, note) = bound_series(series);
        assert!(bounded.points.len() <= MAX_SERIES_POINTS + 1);
        let note = note.unwrap();
        assert!(
            note.starts_with("series `flow` had 25000 points; "),
            "{note}"
        );
        let small = Series {
            name: "flow".into(),
            points: vec![(0.0, 1.0)],
        };
        assert_eq!(bound_series(small.clone()), (small, None));
    }

    proptest! {
        #[test]
        fn never_more_than_the_bound_and_always_the_ends(n in 1_usize..5000, max in 2_usize..64) {
            let (points, seen) = thinned(n, max);
            prop_assert_eq!(seen, n);
            prop_assert!(points.len() <= max + 1);
            prop_assert!(points.len() >= n.min(max / 2));
            prop_assert_eq!(points[0].0, 0.0);
            prop_assert_eq!(points.last().unwrap().0, (n - 1) as f64);
            prop_assert!(points.windows(2).all(|w| w[0].0 < w[1].0));
        }
    }
}
