//! The steady discharge rate of a run and its 95 % confidence interval, from the
//! cumulative mass that crossed the sensor plane.
//!
//! **The steady window is detected, not cut at fixed mass fractions.** The crossings,
//! in time order, are split into [`SteadyOptions::bins`] bins of equal mass (the last
//! crossing of each bin is the first whose cumulative mass reaches `k/bins` of the
//! total). The *local rate* of `window_bins` consecutive bins is their mass over their
//! duration; the *reference rate* is the median of the local rates (with bins of equal
//! mass, the rate at which the median kilogram left). The steady window is the longest
//! run of consecutive local rates within `tolerance` of the reference, from the centre
//! of its first local window to the centre of its last (so half a window of margin is
//! left at both ends). Start-up and tail are slow, so they fall outside; a long
//! trickle after the hopper has emptied carries little mass and moves nothing.
//!
//! **The rate** is the least-squares slope of cumulative mass against time over the
//! crossings in the window, as before.
//!
//! **Its 95 % interval** is by batch means: the window is cut into [`BATCHES`] batches
//! of equal duration, each with its own rate `q_b` (mass over duration). A
//! least-squares slope of a cumulative curve over `[0, T]` weights the rate at time
//! `u T` by `6 u (1 − u)`, so it is the weighted mean `Σ W_b q_b` with
//! `W_b = ∫ 6u(1−u) du` over batch `b`; batches long against the flow's correlation
//! time are nearly independent, so its variance is `s_b² Σ W_b²` with `s_b²` the
//! sample variance of the batch rates. The half-width is
//! `t_{0.975, B−1} · s_b · √(Σ W_b²)`. (Batch means: Law and Kelton, *Simulation
//! Modeling and Analysis*, McGraw-Hill, ch. 9; Schmeiser, *Operations Research* 30,
//! 1982, on 10 to 30 batches.) The interval is of the statistical noise of the flow
//! within the window only; it does not cover a window chosen wrongly.

use crate::crossing::Crossing;

/// How the steady window is found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SteadyOptions {
    /// Bins of equal mass the discharge is split into.
    pub bins: usize,
    /// Consecutive bins over which a local rate is taken.
    pub window_bins: usize,
    /// Largest relative deviation of a local rate from the reference that still counts
    /// as steady.
    pub tolerance: f64,
}

impl Default for SteadyOptions {
    fn default() -> Self {
        SteadyOptions {
            bins: 50,
            window_bins: 5,
            tolerance: 0.25,
        }
    }
}

/// Fewest crossings in the steady window for a discharge rate to be reported.
pub const MIN_STEADY_CROSSINGS: usize = 10;

/// Batches of the steady window for the confidence interval.
pub const BATCHES: usize = 10;

/// Student's `t_{0.975}` with `BATCHES − 1 = 9` degrees of freedom.
const T_975_BATCHES: f64 = 2.262_157_162_740_991;

/// The steady rate of one run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SteadyRate {
    /// Least-squares slope of cumulative mass against time in the window, kg/s.
    pub rate_kg_per_s: f64,
    /// Half-width of its 95 % confidence interval, kg/s; `None` when the window holds
    /// fewer than two crossings per batch.
    pub ci95_kg_per_s: Option<f64>,
    /// Start and end of the steady window, s.
    pub window_s: (f64, f64),
    /// Fractions of the discharged mass at the start and end of the window.
    pub window_mass_fraction: (f64, f64),
}

/// The median of `values` (any order); `None` when empty.
fn median(values: &[f64]) -> Option<f64> {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    match n {
        0 => None,
        _ if n % 2 == 1 => Some(v[n / 2]),
        _ => Some(0.5 * (v[n / 2 - 1] + v[n / 2])),
    }
}

/// Indices into `curve` (time order) of the start and end of the steady window.
fn steady_span(curve: &[(f64, f64)], options: &SteadyOptions) -> Option<(usize, usize)> {
    let total = curve.last()?.1;
    let bins = options.bins.max(2);
    let w = options.window_bins.clamp(1, bins - 1);
    // Edge k: the first crossing whose cumulative mass reaches k / bins of the total
    // (edge 0 is the first crossing).
    let mut edges = Vec::with_capacity(bins + 1);
    edges.push(0usize);
    let mut i = 0;
    for k in 1..=bins {
        let target = total * k as f64 / bins as f64;
        while i + 1 < curve.len() && curve[i].1 < target * (1.0 - 1e-12) {
            i += 1;
        }
        edges.push(i);
    }
    let local: Vec<f64> = (0..=bins - w)
        .map(|k| {
            let (a, b) = (curve[edges[k]], curve[edges[k + w]]);
            let dt = b.0 - a.0;
            if dt > 0.0 {
                (b.1 - a.1) / dt
            } else {
                f64::INFINITY
            }
        })
        .collect();
    let reference = median(&local)?;
    if !(reference.is_finite() && reference > 0.0) {
        return None;
    }
    let steady = |q: f64| (q - reference).abs() <= options.tolerance * reference;
    // The longest run of steady local rates; the earliest among equals.
    let (mut best, mut start) = (None::<(usize, usize)>, None::<usize>);
    for (k, &q) in local.iter().enumerate() {
        match (steady(q), start) {
            (true, None) => start = Some(k),
            (false, Some(s)) => {
                if best.is_none_or(|(a, b)| k - 1 - s > b - a) {
                    best = Some((s, k - 1));
                }
                start = None;
            }
            _ => {}
        }
    }
    if let Some(s) = start {
        let last = local.len() - 1;
        if best.is_none_or(|(a, b)| last - s > b - a) {
            best = Some((s, last));
        }
    }
    let (first, last) = best?;
    // From the centre of the first local window to the centre of the last: the edge
    // half a window in (rounded down), so half a window of margin at both ends.
    Some((edges[first + w / 2], edges[last + w.div_ceil(2)]))
}

/// The steady rate of `crossings` (any order), with its window and 95 % interval;
/// `None` when no window of at least [`MIN_STEADY_CROSSINGS`] crossings is steady.
pub fn steady_rate(crossings: &[Crossing], options: &SteadyOptions) -> Option<SteadyRate> {
    let curve = crate::responses::cumulative_mass_series(crossings);
    let (from, to) = steady_span(&curve, options)?;
    let window = &curve[from..=to];
    if window.len() < MIN_STEADY_CROSSINGS {
        return None;
    }
    let rate_kg_per_s = least_squares_slope(window)?;
    let total = curve.last()?.1;
    Some(SteadyRate {
        rate_kg_per_s,
        ci95_kg_per_s: batch_means_ci95(window),
        window_s: (window[0].0, window[window.len() - 1].0),
        window_mass_fraction: (window[0].1 / total, window[window.len() - 1].1 / total),
    })
}

/// Least-squares slope of `(t, m)` points; `None` when all times are equal.
fn least_squares_slope(points: &[(f64, f64)]) -> Option<f64> {
    let n = points.len() as f64;
    let t_mean = points.iter().map(|p| p.0).sum::<f64>() / n;
    let m_mean = points.iter().map(|p| p.1).sum::<f64>() / n;
    let (mut stt, mut stm) = (0.0, 0.0);
    for &(t, m) in points {
        stt += (t - t_mean) * (t - t_mean);
        stm += (t - t_mean) * (m - m_mean);
    }
    (stt > 0.0).then(|| stm / stt)
}

/// Half-width of the batch-means 95 % interval of the least-squares slope over
/// `window` (cumulative-mass points in time order).
fn batch_means_ci95(window: &[(f64, f64)]) -> Option<f64> {
    if window.len() < 2 * BATCHES {
        return None;
    }
    let (t0, t1) = (window[0].0, window[window.len() - 1].0);
    let duration = t1 - t0;
    if duration <= 0.0 {
        return None;
    }
    // Cumulative mass at a time inside the window, by linear interpolation between
    // crossings (the mass of a crossing is spread over the gap before it).
    let mass_at = |t: f64| -> f64 {
        let i = window.partition_point(|p| p.0 < t);
        if i == 0 {
            return window[0].1;
        }
        if i >= window.len() {
            return window[window.len() - 1].1;
        }
        let (a, b) = (window[i - 1], window[i]);
        if b.0 > a.0 {
            a.1 + (b.1 - a.1) * (t - a.0) / (b.0 - a.0)
        } else {
            b.1
        }
    };
    let batch_s = duration / BATCHES as f64;
    let rates: Vec<f64> = (0..BATCHES)
        .map(|b| {
            let (a, z) = (t0 + b as f64 * batch_s, t0 + (b + 1) as f64 * batch_s);
            (mass_at(z) - mass_at(a)) / batch_s
        })
        .collect();
    let mean = rates.iter().sum::<f64>() / BATCHES as f64;
    let variance = rates.iter().map(|q| (q - mean).powi(2)).sum::<f64>() / (BATCHES - 1) as f64;
    // ∫ 6u(1 − u) du = 3u² − 2u³.
    let weight = |u: f64| 3.0 * u * u - 2.0 * u * u * u;
    let sum_w2: f64 = (0..BATCHES)
        .map(|b| {
            let (a, z) = (b as f64 / BATCHES as f64, (b + 1) as f64 / BATCHES as f64);
            (weight(z) - weight(a)).powi(2)
        })
        .sum();
    Some(T_975_BATCHES * (variance * sum_w2).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synthetic::Rng;
    use approx::assert_relative_eq;

    fn at(id: u64, mass_kg: f64, time_s: f64) -> Crossing {
        Crossing {
            id,
            particle_type: 1,
            radius_m: 0.001,
            mass_kg,
            position_m: [0.001, 0.0, 0.0],
            velocity_m_per_s: [0.0, 0.0, -1.0],
            time_s,
        }
    }

    /// A Poisson stream of `n` crossings at `per_s` crossings per second, masses
    /// `m` (fine, 8 of 9) or `8 m` (coarse, 1 of 9): a 50/50 mixture by mass, mean
    /// mass `16 m / 9`, so a true rate of `per_s · 16 m / 9`.
    fn poisson_mixture(rng: &mut Rng, n: usize, per_s: f64, m: f64, t0: f64) -> Vec<Crossing> {
        let mut t = t0;
        (0..n)
            .map(|i| {
                t += -rng.uniform().ln() / per_s;
                let mass = if rng.uniform() < 1.0 / 9.0 {
                    8.0 * m
                } else {
                    m
                };
                at(i as u64, mass, t)
            })
            .collect()
    }

    #[test]
    fn constant_flow_gives_its_rate_exactly_and_a_zero_interval() {
        let crossings: Vec<Crossing> = (0..1000)
            .map(|i| at(i, 1e-3, 0.5 + i as f64 * 1e-3))
            .collect();
        let r = steady_rate(&crossings, &SteadyOptions::default()).unwrap();
        assert_relative_eq!(r.rate_kg_per_s, 1.0, max_relative = 1e-9);
        assert!(r.ci95_kg_per_s.unwrap() < 1e-9, "{r:?}");
        // The whole flow is steady: the window is all but half a local window
        // (rounded down to two bins, 4 % of the mass) at each end.
        assert!((r.window_mass_fraction.0 - 0.04).abs() < 0.002, "{r:?}");
        assert!((r.window_mass_fraction.1 - 0.96).abs() < 0.002, "{r:?}");
    }

    #[test]
    fn start_up_and_a_long_trickle_are_found_and_left_out() {
        // 1 g crossings: a ramp (the rate rises linearly to 2 kg/s over the first
        // 100), a steady 2 kg/s for 800, a slowing tail (100, the rate falling
        // linearly), then 20 more trickling out over 3 s. A window may only hold
        // ramp and tail where they are within the 25 % tolerance of 2 kg/s: after the
        // 75th crossing and before the 925th (of 1020).
        let mut crossings = Vec::new();
        let mut t = 0.0;
        let m = 1e-3;
        for i in 0..100 {
            t += m / (2.0 * (i + 1) as f64 / 100.0);
            crossings.push(at(i, m, t));
        }
        for i in 100..900 {
            t += m / 2.0;
            crossings.push(at(i, m, t));
        }
        for i in 900..1000 {
            t += m / (2.0 * (1000 - i) as f64 / 100.0);
            crossings.push(at(i, m, t));
        }
        for i in 1000..1020 {
            t += 0.15;
            crossings.push(at(i, m, t));
        }
        let r = steady_rate(&crossings, &SteadyOptions::default()).unwrap();
        assert_relative_eq!(r.rate_kg_per_s, 2.0, max_relative = 1e-3);
        let (a, b) = r.window_mass_fraction;
        assert!(a >= 75.0 / 1020.0 && b <= 925.0 / 1020.0, "{r:?}");
        // It holds nearly all of the steady part.
        assert!(a <= 100.0 / 1020.0 && b >= 900.0 / 1020.0, "{r:?}");
    }

    #[test]
    fn noisy_flow_with_a_known_rate_is_within_its_interval_about_95_percent_of_the_time() {
        // 400 independent Poisson flows of a 50/50 mixture (by mass) of particles of
        // 1 and 8 mg, 4500 crossings per second: true rate 4500 · 16/9 mg/s = 8 g/s.
        let truth = 4500.0 * 16.0 / 9.0 * 1e-6;
        let mut rng = Rng::new(15);
        let (mut covered, mut width, runs) = (0, 0.0, 400);
        for _ in 0..runs {
            let c = poisson_mixture(&mut rng, 2000, 4500.0, 1e-6, 0.0);
            let r = steady_rate(&c, &SteadyOptions::default()).unwrap();
            let half = r.ci95_kg_per_s.unwrap();
            covered += usize::from((r.rate_kg_per_s - truth).abs() <= half);
            width += half / truth / runs as f64;
        }
        let coverage = covered as f64 / runs as f64;
        eprintln!("coverage {coverage}, mean relative half-width {width:.4}");
        // 400 runs: the binomial standard error of 95 % is 1.1 %.
        assert!((0.91..=0.985).contains(&coverage), "coverage {coverage}");
        // Poisson noise of the ~1800 crossings in the window: a relative standard
        // deviation of √(E[m²] / E[m]² / n) = √(2.53 / 1800) = 3.7 %, times √1.2 for
        // the slope's weights and t = 2.26: a half-width near 9 %.
        assert!((0.07..0.11).contains(&width), "mean half-width {width}");
    }

    #[test]
    fn too_few_crossings_give_no_rate() {
        let c: Vec<Crossing> = (0..5).map(|i| at(i, 1e-3, i as f64)).collect();
        assert_eq!(steady_rate(&c, &SteadyOptions::default()), None);
        assert_eq!(steady_rate(&[], &SteadyOptions::default()), None);
    }
}
