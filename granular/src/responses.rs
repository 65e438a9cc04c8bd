//! Responses computed from the particles that crossed the sensor plane (SCIENCE.md §4).
//!
//! - **Discharge rate**: slope of the cumulative discharged mass over time, fitted by
//!   least squares over its steady part (between `steady_from` and `steady_to` of the
//!   total mass, 20 % and 80 % by default), kg/s.
//! - **Radial segregation**: `R1_mean` and `R2_mean`, the mean radial distances from
//!   the axis of fine and coarse particles at the plane, and their ratio `R1/R2`.
//! - **Exit speed**: the mass-weighted mean downward speed at the plane, m/s (what the
//!   CFD stage needs to know of the stream, with its rate and radius).
//! - **Fine mass fraction in the outer layer**: among particles whose radial distance
//!   is at least `(1 − p) R_s`, the mass fraction of fines, for layer thicknesses `p`
//!   of 2, 5, 10 and 12 % of the stream radius `R_s`, the largest radial distance of
//!   any crossing.

use crate::crossing::Crossing;

/// Choices that define the responses.
#[derive(Debug, Clone, PartialEq)]
pub struct ResponseOptions {
    /// Particle type that counts as fine; every other type is coarse.
    pub fine_type: u32,
    /// Fraction of the total mass where the steady part starts.
    pub steady_from: f64,
    /// Fraction of the total mass where the steady part ends.
    pub steady_to: f64,
    /// Outer-layer thicknesses as fractions of the stream radius.
    pub outer_layers: Vec<f64>,
}

impl Default for ResponseOptions {
    fn default() -> Self {
        ResponseOptions {
            fine_type: 2,
            steady_from: 0.2,
            steady_to: 0.8,
            outer_layers: vec![0.02, 0.05, 0.10, 0.12],
        }
    }
}

/// Fewest crossings in the steady window for a discharge rate to be reported.
pub const MIN_STEADY_CROSSINGS: usize = 10;

/// The responses of one run. A value is `None` when the crossings cannot define it
/// (no fines at all, say); such a response is missing rather than a made-up number.
#[derive(Debug, Clone, PartialEq)]
pub struct DischargeResponses {
    /// Particles that crossed.
    pub discharged_count: usize,
    /// Mass that crossed, kg.
    pub discharged_mass_kg: f64,
    /// Steady discharge rate, kg/s.
    pub discharge_rate_kg_per_s: Option<f64>,
    /// Mean radial distance of fine particles at the plane, m.
    pub r1_mean_m: Option<f64>,
    /// Mean radial distance of coarse particles at the plane, m.
    pub r2_mean_m: Option<f64>,
    /// `R1_mean / R2_mean`.
    pub segregation_ratio: Option<f64>,
    /// Largest radial distance of any crossing, m.
    pub stream_radius_m: Option<f64>,
    /// Mass-weighted mean downward speed of the particles at the plane, m/s.
    pub exit_speed_m_per_s: Option<f64>,
    /// `(layer thickness fraction, fine mass fraction in that layer)`.
    pub fine_fraction_outer: Vec<(f64, Option<f64>)>,
}

impl DischargeResponses {
    /// Computes every response from `crossings` (any order).
    pub fn compute(crossings: &[Crossing], options: &ResponseOptions) -> DischargeResponses {
        let discharged_mass_kg = crossings.iter().map(|c| c.mass_kg).sum();
        let is_fine = |c: &&Crossing| c.particle_type == options.fine_type;
        let r1_mean_m = mean(
            crossings
                .iter()
                .filter(is_fine)
                .map(|c| c.radial_distance_m()),
        );
        let r2_mean_m = mean(
            crossings
                .iter()
                .filter(|c| !is_fine(c))
                .map(|c| c.radial_distance_m()),
        );
        let segregation_ratio = match (r1_mean_m, r2_mean_m) {
            (Some(r1), Some(r2)) if r2 > 0.0 => Some(r1 / r2),
            _ => None,
        };
        let stream_radius_m = crossings
            .iter()
            .map(|c| c.radial_distance_m())
            .reduce(f64::max);
        let fine_fraction_outer = options
            .outer_layers
            .iter()
            .map(|&layer| {
                let fraction = stream_radius_m.and_then(|radius| {
                    fine_mass_fraction_beyond(crossings, (1.0 - layer) * radius, options.fine_type)
                });
                (layer, fraction)
            })
            .collect();
        let exit_speed_m_per_s = (discharged_mass_kg > 0.0).then(|| {
            crossings
                .iter()
                .map(|c| -c.velocity_m_per_s[2] * c.mass_kg)
                .sum::<f64>()
                / discharged_mass_kg
        });
        DischargeResponses {
            discharged_count: crossings.len(),
            discharged_mass_kg,
            discharge_rate_kg_per_s: steady_rate(crossings, options),
            r1_mean_m,
            r2_mean_m,
            segregation_ratio,
            stream_radius_m,
            exit_speed_m_per_s,
            fine_fraction_outer,
        }
    }

    /// Every defined response as `(name, value)`, with the names studies use.
    pub fn named(&self) -> Vec<(String, f64)> {
        let mut out = vec![
            ("discharged_count".to_string(), self.discharged_count as f64),
            ("discharged_mass".to_string(), self.discharged_mass_kg),
        ];
        let optional = [
            ("discharge_rate", self.discharge_rate_kg_per_s),
            ("R1_mean", self.r1_mean_m),
            ("R2_mean", self.r2_mean_m),
            ("segregation_ratio", self.segregation_ratio),
            ("stream_radius", self.stream_radius_m),
            ("exit_speed", self.exit_speed_m_per_s),
        ];
        out.extend(
            optional
                .into_iter()
                .filter_map(|(name, value)| value.map(|v| (name.to_string(), v))),
        );
        for &(layer, fraction) in &self.fine_fraction_outer {
            if let Some(fraction) = fraction {
                out.push((outer_layer_name(layer), fraction));
            }
        }
        out
    }
}

/// The response name of the outer layer of thickness `layer` (a fraction):
/// `fine_fraction_outer_5` for 0.05.
pub fn outer_layer_name(layer: f64) -> String {
    format!("fine_fraction_outer_{}", (layer * 100.0).round() as i64)
}

/// Every response name [`DischargeResponses::named`] can produce with default options.
pub fn response_names() -> Vec<String> {
    let mut names: Vec<String> = [
        "discharged_count",
        "discharged_mass",
        "discharge_rate",
        "R1_mean",
        "R2_mean",
        "segregation_ratio",
        "stream_radius",
        "exit_speed",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    names.extend(
        ResponseOptions::default()
            .outer_layers
            .iter()
            .map(|&l| outer_layer_name(l)),
    );
    names
}

fn mean(values: impl Iterator<Item = f64>) -> Option<f64> {
    let (sum, count) = values.fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
    (count > 0).then(|| sum / count as f64)
}

fn fine_mass_fraction_beyond(crossings: &[Crossing], radius_m: f64, fine_type: u32) -> Option<f64> {
    let (fine, total) = crossings
        .iter()
        .filter(|c| c.radial_distance_m() >= radius_m)
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

/// Least-squares slope of cumulative mass against time over the steady window.
fn steady_rate(crossings: &[Crossing], options: &ResponseOptions) -> Option<f64> {
    let mut sorted: Vec<&Crossing> = crossings.iter().collect();
    sorted.sort_by(|a, b| a.time_s.total_cmp(&b.time_s));
    let total: f64 = sorted.iter().map(|c| c.mass_kg).sum();
    let (lo, hi) = (options.steady_from * total, options.steady_to * total);
    let mut cumulative = 0.0;
    let mut window: Vec<(f64, f64)> = Vec::new();
    for c in sorted {
        cumulative += c.mass_kg;
        if cumulative >= lo && cumulative <= hi {
            window.push((c.time_s, cumulative));
        }
    }
    if window.len() < MIN_STEADY_CROSSINGS {
        return None;
    }
    let n = window.len() as f64;
    let t_mean = window.iter().map(|p| p.0).sum::<f64>() / n;
    let m_mean = window.iter().map(|p| p.1).sum::<f64>() / n;
    let (mut stt, mut stm) = (0.0, 0.0);
    for &(t, m) in &window {
        stt += (t - t_mean) * (t - t_mean);
        stm += (t - t_mean) * (m - m_mean);
    }
    (stt > 0.0).then(|| stm / stt)
}

/// Discharge rate over time: crossings binned into intervals of `bin_s` seconds,
/// as `(bin centre time s, rate kg/s)`, from the first crossing to the last.
pub fn mass_flow_series(crossings: &[Crossing], bin_s: f64) -> Vec<(f64, f64)> {
    let Some(first) = crossings.iter().map(|c| c.time_s).reduce(f64::min) else {
        return Vec::new();
    };
    let last = crossings.iter().map(|c| c.time_s).fold(first, f64::max);
    let bins = ((last - first) / bin_s).floor() as usize + 1;
    let mut mass = vec![0.0; bins];
    for c in crossings {
        let index = (((c.time_s - first) / bin_s) as usize).min(bins - 1);
        mass[index] += c.mass_kg;
    }
    mass.iter()
        .enumerate()
        .map(|(i, m)| (first + (i as f64 + 0.5) * bin_s, m / bin_s))
        .collect()
}

/// Cumulative discharged mass at each crossing, as `(time s, mass kg)`.
pub fn cumulative_mass_series(crossings: &[Crossing]) -> Vec<(f64, f64)> {
    let mut sorted: Vec<&Crossing> = crossings.iter().collect();
    sorted.sort_by(|a, b| a.time_s.total_cmp(&b.time_s));
    let mut total = 0.0;
    sorted
        .into_iter()
        .map(|c| {
            total += c.mass_kg;
            (c.time_s, total)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use proptest::prelude::*;

    fn crossing(id: u64, particle_type: u32, mass_kg: f64, r: f64, time_s: f64) -> Crossing {
        Crossing {
            id,
            particle_type,
            radius_m: 0.001,
            mass_kg,
            position_m: [r, 0.0, -0.01],
            velocity_m_per_s: [0.0, 0.0, -1.0],
            time_s,
        }
    }

    #[test]
    fn constant_flow_gives_its_rate_exactly() {
        // 1000 crossings of 1 g each, one every millisecond: 1 kg/s.
        let crossings: Vec<Crossing> = (0..1000)
            .map(|i| crossing(i, 1, 1e-3, 0.001, 0.5 + i as f64 * 1e-3))
            .collect();
        let r = DischargeResponses::compute(&crossings, &ResponseOptions::default());
        assert_relative_eq!(r.discharge_rate_kg_per_s.unwrap(), 1.0, max_relative = 1e-9);
        assert_relative_eq!(r.discharged_mass_kg, 1.0, max_relative = 1e-12);
    }

    #[test]
    fn exit_speed_is_the_mass_weighted_downward_speed() {
        // 3 g at 1 m/s and 1 g at 2 m/s: (3 · 1 + 1 · 2) / 4 = 1.25 m/s.
        let mut slow = crossing(0, 1, 3e-3, 0.001, 0.1);
        slow.velocity_m_per_s = [0.3, 0.0, -1.0];
        let mut fast = crossing(1, 2, 1e-3, 0.002, 0.2);
        fast.velocity_m_per_s = [0.0, 0.0, -2.0];
        let r = DischargeResponses::compute(&[slow, fast], &ResponseOptions::default());
        assert_relative_eq!(r.exit_speed_m_per_s.unwrap(), 1.25, max_relative = 1e-12);
        let none = DischargeResponses::compute(&[], &ResponseOptions::default());
        assert_eq!(none.exit_speed_m_per_s, None);
    }

    #[test]
    fn start_and_end_transients_are_excluded_from_the_rate() {
        // Slow trickle (first 10 %), steady 2 kg/s, slow tail (last 10 %).
        let mut crossings = Vec::new();
        let mut t = 0.0;
        let mut id = 0;
        for (count, dt) in [(100, 0.01), (800, 0.0005), (100, 0.02)] {
            for _ in 0..count {
                t += dt;
                crossings.push(crossing(id, 1, 1e-3, 0.001, t));
                id += 1;
            }
        }
        let r = DischargeResponses::compute(&crossings, &ResponseOptions::default());
        assert_relative_eq!(r.discharge_rate_kg_per_s.unwrap(), 2.0, max_relative = 1e-6);
    }

    #[test]
    fn segregation_ratio_from_hand_made_radii() {
        // Fines (type 2) at 2 and 4 mm, coarse (type 1) at 5 and 7 mm: R1 = 3, R2 = 6.
        let crossings = vec![
            crossing(1, 2, 1e-5, 0.002, 0.1),
            crossing(2, 2, 1e-5, 0.004, 0.2),
            crossing(3, 1, 8e-5, 0.005, 0.3),
            crossing(4, 1, 8e-5, 0.007, 0.4),
        ];
        let r = DischargeResponses::compute(&crossings, &ResponseOptions::default());
        assert_relative_eq!(r.r1_mean_m.unwrap(), 0.003, max_relative = 1e-12);
        assert_relative_eq!(r.r2_mean_m.unwrap(), 0.006, max_relative = 1e-12);
        assert_relative_eq!(r.segregation_ratio.unwrap(), 0.5, max_relative = 1e-12);
        assert_eq!(r.stream_radius_m, Some(0.007));
        // Too few crossings for a steady rate: reported as missing, not invented.
        assert_eq!(r.discharge_rate_kg_per_s, None);
    }

    #[test]
    fn outer_layer_fine_fraction_from_hand_made_data() {
        // Stream radius 10 mm. Outer 5 % layer: r ≥ 9.5 mm holds a fine of 1 g at
        // 9.6 mm and a coarse of 3 g at 10 mm → 0.25. Outer 12 % (r ≥ 8.8 mm) adds a
        // fine of 2 g at 9 mm → 3/6 = 0.5. The 2 % layer (r ≥ 9.8 mm) has only the
        // coarse particle → 0.
        let crossings = vec![
            crossing(1, 2, 1e-3, 0.0096, 0.1),
            crossing(2, 1, 3e-3, 0.0100, 0.2),
            crossing(3, 2, 2e-3, 0.0090, 0.3),
            crossing(4, 2, 5e-3, 0.0010, 0.4),
        ];
        let r = DischargeResponses::compute(&crossings, &ResponseOptions::default());
        let by_layer: Vec<(f64, Option<f64>)> = r.fine_fraction_outer.clone();
        assert_eq!(by_layer[0], (0.02, Some(0.0)));
        assert_relative_eq!(by_layer[1].1.unwrap(), 0.25, max_relative = 1e-12);
        assert_relative_eq!(by_layer[3].1.unwrap(), 0.5, max_relative = 1e-12);
        let names: Vec<String> = r.named().into_iter().map(|(n, _)| n).collect();
        assert!(names.contains(&"fine_fraction_outer_12".to_string()));
    }

    #[test]
    fn no_fines_means_no_segregation_ratio() {
        let crossings = vec![crossing(1, 1, 1e-3, 0.002, 0.1)];
        let r = DischargeResponses::compute(&crossings, &ResponseOptions::default());
        assert_eq!(r.r1_mean_m, None);
        assert_eq!(r.segregation_ratio, None);
        assert!(r
            .named()
            .iter()
            .all(|(n, v)| n != "segregation_ratio" && v.is_finite()));
    }

    proptest! {
        #[test]
        fn binned_series_conserves_mass(times in proptest::collection::vec(0.0f64..2.0, 1..300), bin in 0.001f64..0.2) {
            let crossings: Vec<Crossing> = times.iter().enumerate()
                .map(|(i, &t)| crossing(i as u64, 1, 1e-3, 0.001, t)).collect();
            let series = mass_flow_series(&crossings, bin);
            let mass: f64 = series.iter().map(|(_, rate)| rate * bin).sum();
            prop_assert!((mass - 1e-3 * times.len() as f64).abs() < 1e-9);
        }
    }
}
