//! Responses computed from the particles that crossed the sensor plane (SCIENCE.md §4);
//! docs/method.md, "Responses of the hopper", gives the reasons for each definition.
//!
//! - **Discharge rate**: least-squares slope of the cumulative discharged mass over
//!   the steady window the flow itself shows ([`crate::steady`]), kg/s, with the
//!   half-width of its 95 % confidence interval by batch means.
//! - **Radial segregation**: `R1_mean` and `R2_mean`, the mean radial distances of the
//!   centres of fine and coarse particles from the axis at the plane, and their ratio
//!   `R1/R2`; and that ratio divided by what perfect mixing gives when centres are kept
//!   a particle radius from the stream's edge ([`radial::uniform_mixing_ratio`]).
//! - **Stream radius** `R_s`: the 95 % mass quantile of the particles' *surface*
//!   distances from the axis (centre distance plus radius); the largest centre distance
//!   is kept as `stream_radius`.
//! - **Fine mass fraction in the outer layer** `p` (2, 5, 10, 12 %): among the particles
//!   whose surface reaches beyond `(1 − p) R_s`, the mass fraction of fines. Every layer
//!   holds at least the 5 % of the mass beyond `R_s`, so it cannot shrink to the one
//!   outermost particle.
//! - **Exit speed**: the mass-weighted mean downward speed at the plane, m/s (what the
//!   CFD stage needs to know of the stream, with its rate and radius).
//! - **Fines early and late** `fine_fraction_first_quarter`, `fine_fraction_last_quarter`:
//!   the fines' mass fraction in the first and the last quarter of the discharged mass
//!   ([`crate::temporal`]): segregation in time rather than in radius.
//! - **Radial densities** of fines and coarse (series): histograms of centre distance
//!   normalised to probability densities, 1/m.

use crate::crossing::Crossing;
use crate::radial::{self, outer_layer_fine_fraction, radial_density, uniform_mixing_ratio};
use crate::steady::{steady_rate, SteadyOptions, SteadyRate};
use crate::temporal::fine_fraction_by_discharged_mass;

/// Choices that define the responses.
#[derive(Debug, Clone, PartialEq)]
pub struct ResponseOptions {
    /// Particle type that counts as fine; every other type is coarse.
    pub fine_type: u32,
    /// How the steady window of the discharge is found.
    pub steady: SteadyOptions,
    /// Mass quantile of surface distances that defines the stream radius `R_s`.
    pub stream_quantile: f64,
    /// Outer-layer thicknesses as fractions of the stream radius `R_s`.
    pub outer_layers: Vec<f64>,
    /// Bins of the radial densities, over `[0, largest centre distance]`.
    pub density_bins: usize,
}

impl Default for ResponseOptions {
    fn default() -> Self {
        ResponseOptions {
            fine_type: 2,
            steady: SteadyOptions::default(),
            stream_quantile: 0.95,
            outer_layers: vec![0.02, 0.05, 0.10, 0.12],
            density_bins: 20,
        }
    }
}

pub use crate::steady::MIN_STEADY_CROSSINGS;

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
    /// Half-width of the 95 % confidence interval of the steady rate, kg/s.
    pub discharge_rate_ci95_kg_per_s: Option<f64>,
    /// The steady window and its rate, when one was found.
    pub steady: Option<SteadyRate>,
    /// Mean radial distance of the centres of fine particles at the plane, m.
    pub r1_mean_m: Option<f64>,
    /// Mean radial distance of the centres of coarse particles at the plane, m.
    pub r2_mean_m: Option<f64>,
    /// `R1_mean / R2_mean`.
    pub segregation_ratio: Option<f64>,
    /// `R1_mean / R2_mean` over its value for a perfectly mixed stream whose centres
    /// keep a particle radius from its edge at `R_s`: `(R_s − a_f)/(R_s − a_c)`.
    pub segregation_ratio_normalised: Option<f64>,
    /// Largest radial distance of any crossing's centre, m.
    pub stream_radius_m: Option<f64>,
    /// Robust stream radius `R_s`: 95 % mass quantile of surface distances, m.
    pub stream_radius_95_m: Option<f64>,
    /// Mass-weighted mean downward speed of the particles at the plane, m/s.
    pub exit_speed_m_per_s: Option<f64>,
    /// `(layer thickness fraction, fine mass fraction in that layer)`.
    pub fine_fraction_outer: Vec<(f64, Option<f64>)>,
    /// Fines' mass fraction in the first quarter of the discharged mass.
    pub fine_fraction_first_quarter: Option<f64>,
    /// Fines' mass fraction in the last quarter of the discharged mass.
    pub fine_fraction_last_quarter: Option<f64>,
}

impl DischargeResponses {
    /// Computes every response from `crossings` (any order).
    pub fn compute(crossings: &[Crossing], options: &ResponseOptions) -> DischargeResponses {
        let discharged_mass_kg = crossings.iter().map(|c| c.mass_kg).sum();
        let is_fine = |c: &&Crossing| c.particle_type == options.fine_type;
        let fines = || crossings.iter().filter(is_fine);
        let coarse = || crossings.iter().filter(|c| !is_fine(c));
        let r1_mean_m = mean(fines().map(|c| c.radial_distance_m()));
        let r2_mean_m = mean(coarse().map(|c| c.radial_distance_m()));
        let segregation_ratio = match (r1_mean_m, r2_mean_m) {
            (Some(r1), Some(r2)) if r2 > 0.0 => Some(r1 / r2),
            _ => None,
        };
        let stream_radius_m = crossings
            .iter()
            .map(|c| c.radial_distance_m())
            .reduce(f64::max);
        let stream_radius_95_m = radial::stream_radius_m(crossings, options.stream_quantile);
        let segregation_ratio_normalised = (|| {
            let expected = uniform_mixing_ratio(
                stream_radius_95_m?,
                mean(fines().map(|c| c.radius_m))?,
                mean(coarse().map(|c| c.radius_m))?,
            )?;
            Some(segregation_ratio? / expected)
        })();
        let fine_fraction_outer = options
            .outer_layers
            .iter()
            .map(|&layer| {
                let fraction = stream_radius_95_m.and_then(|radius| {
                    outer_layer_fine_fraction(crossings, radius, layer, options.fine_type)
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
        let steady = steady_rate(crossings, &options.steady);
        // Quarters need a particle in each; with fewer crossings they mean nothing.
        let quarters = fine_fraction_by_discharged_mass(crossings, options.fine_type, 4);
        let quarter = |k: usize| {
            (quarters.len() == 4 && fines().next().is_some())
                .then(|| quarters[k].fine_mass_fraction)
        };
        DischargeResponses {
            discharged_count: crossings.len(),
            discharged_mass_kg,
            discharge_rate_kg_per_s: steady.map(|s| s.rate_kg_per_s),
            discharge_rate_ci95_kg_per_s: steady.and_then(|s| s.ci95_kg_per_s),
            steady,
            r1_mean_m,
            r2_mean_m,
            segregation_ratio,
            segregation_ratio_normalised,
            stream_radius_m,
            stream_radius_95_m,
            exit_speed_m_per_s,
            fine_fraction_outer,
            fine_fraction_first_quarter: quarter(0),
            fine_fraction_last_quarter: quarter(3),
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
            ("discharge_rate_ci95", self.discharge_rate_ci95_kg_per_s),
            ("R1_mean", self.r1_mean_m),
            ("R2_mean", self.r2_mean_m),
            ("segregation_ratio", self.segregation_ratio),
            (
                "segregation_ratio_normalised",
                self.segregation_ratio_normalised,
            ),
            ("stream_radius", self.stream_radius_m),
            ("stream_radius_95", self.stream_radius_95_m),
            ("exit_speed", self.exit_speed_m_per_s),
            (
                "fine_fraction_first_quarter",
                self.fine_fraction_first_quarter,
            ),
            (
                "fine_fraction_last_quarter",
                self.fine_fraction_last_quarter,
            ),
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
        "discharge_rate_ci95",
        "R1_mean",
        "R2_mean",
        "segregation_ratio",
        "segregation_ratio_normalised",
        "stream_radius",
        "stream_radius_95",
        "exit_speed",
        "fine_fraction_first_quarter",
        "fine_fraction_last_quarter",
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

/// The radial probability densities of the centres of fine and of coarse particles at
/// the plane (SCIENCE.md §4; the thesis's Fig. 1.3), each `(radius m, density 1/m)`.
#[derive(Debug, Clone, PartialEq)]
pub struct RadialDensities {
    /// Fines; empty when none crossed.
    pub fine: Vec<(f64, f64)>,
    /// Coarse particles; empty when none crossed.
    pub coarse: Vec<(f64, f64)>,
}

/// The radial densities of `crossings` over the same `options.density_bins` bins from
/// the axis to the largest centre distance of any crossing, so the two compare bin by
/// bin.
pub fn radial_densities(crossings: &[Crossing], options: &ResponseOptions) -> RadialDensities {
    let r_max = crossings
        .iter()
        .map(|c| c.radial_distance_m())
        .fold(0.0, f64::max);
    let fine = |c: &Crossing| c.particle_type == options.fine_type;
    RadialDensities {
        fine: radial_density(crossings, fine, r_max, options.density_bins),
        coarse: radial_density(crossings, |c| !fine(c), r_max, options.density_bins),
    }
}

fn mean(values: impl Iterator<Item = f64>) -> Option<f64> {
    let (sum, count) = values.fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
    (count > 0).then(|| sum / count as f64)
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
        // Every particle has a 1 mm radius, so surfaces reach 1 mm beyond the centres:
        // 14 g of fines at 2 mm, 2 g of fines at 10 mm, 1 g of fines at 10.6 mm and
        // 3 g of coarse at 11 mm. 95 % of the 20 g is reached at 11 mm = R_s.
        // 2 % layer (surface ≥ 10.78 mm): the coarse particle alone → 0. 5 % (≥ 10.45
        // mm): 1 g fine + 3 g coarse → 0.25. 10 % (≥ 9.9 mm) and 12 % (≥ 9.68 mm): add
        // 2 g of fines → 3/6 = 0.5.
        let crossings = vec![
            crossing(1, 2, 1e-3, 0.0096, 0.1),
            crossing(2, 1, 3e-3, 0.0100, 0.2),
            crossing(3, 2, 2e-3, 0.0090, 0.3),
            crossing(4, 2, 14e-3, 0.0010, 0.4),
        ];
        let r = DischargeResponses::compute(&crossings, &ResponseOptions::default());
        assert_relative_eq!(r.stream_radius_95_m.unwrap(), 0.011, max_relative = 1e-12);
        let by_layer: Vec<(f64, Option<f64>)> = r.fine_fraction_outer.clone();
        assert_eq!(by_layer[0], (0.02, Some(0.0)));
        assert_relative_eq!(by_layer[1].1.unwrap(), 0.25, max_relative = 1e-12);
        assert_relative_eq!(by_layer[2].1.unwrap(), 0.5, max_relative = 1e-12);
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

    /// Synthetic streams with analytic answers: stratified samples of discs and rings
    /// (`crate::synthetic`), fines of 1 mg (type 2) and coarse of 8 mg (type 1).
    mod synthetic_streams {
        use super::*;
        use crate::synthetic::{ring, Kind};

        const MM: f64 = 1e-3;

        fn fine(radius_m: f64) -> Kind {
            Kind {
                particle_type: 2,
                radius_m,
                mass_kg: 1e-6,
            }
        }

        fn coarse(radius_m: f64) -> Kind {
            Kind {
                particle_type: 1,
                radius_m,
                mass_kg: 8e-6,
            }
        }

        fn fractions(r: &DischargeResponses) -> Vec<f64> {
            r.fine_fraction_outer.iter().map(|l| l.1.unwrap()).collect()
        }

        /// Checks a radial density against `pdf` at the bin centres, to `tolerance` of
        /// its largest value, and that it integrates to 1.
        fn assert_density(density: &[(f64, f64)], pdf: impl Fn(f64) -> f64, tolerance: f64) {
            let width = 2.0 * density[0].0;
            let integral: f64 = density.iter().map(|p| p.1 * width).sum();
            assert!((integral - 1.0).abs() < 1e-9, "{integral}");
            let largest = density.iter().map(|p| pdf(p.0)).fold(0.0, f64::max);
            for &(r, d) in density {
                let expected = pdf(r);
                assert!(
                    (d - expected).abs() <= tolerance * largest,
                    "at {r}: {d} against {expected}"
                );
            }
        }

        #[test]
        fn a_uniform_disc_of_point_particles() {
            // Fines and coarse both spread uniformly over a 10 mm disc, half of the mass
            // each: mean distance 2R/3 for both, density 2r/R², R_s = R √0.95 (the
            // 95 % quantile of a uniform disc), and every layer as fine as the stream.
            let radius = 10.0 * MM;
            let mut c = ring(fine(0.0), 40_000, 0.0, radius, 0);
            c.extend(ring(coarse(0.0), 5_000, 0.0, radius, 100_000));
            let r = DischargeResponses::compute(&c, &ResponseOptions::default());
            assert_relative_eq!(
                r.r1_mean_m.unwrap(),
                2.0 * radius / 3.0,
                max_relative = 1e-4
            );
            assert_relative_eq!(
                r.r2_mean_m.unwrap(),
                2.0 * radius / 3.0,
                max_relative = 1e-4
            );
            assert_relative_eq!(r.segregation_ratio.unwrap(), 1.0, max_relative = 1e-4);
            assert_relative_eq!(
                r.segregation_ratio_normalised.unwrap(),
                1.0,
                max_relative = 1e-4
            );
            assert_relative_eq!(
                r.stream_radius_95_m.unwrap(),
                radius * 0.95f64.sqrt(),
                max_relative = 1e-4
            );
            for f in fractions(&r) {
                assert!((f - 0.5).abs() < 2e-3, "{:?}", r.fine_fraction_outer);
            }
            let RadialDensities {
                fine: fines,
                coarse,
            } = radial_densities(&c, &ResponseOptions::default());
            assert_eq!(fines.len(), 20);
            let pdf = |x: f64| 2.0 * x / (radius * radius);
            assert_density(&fines, pdf, 1e-3);
            assert_density(&coarse, pdf, 5e-3);
        }

        #[test]
        fn two_concentric_populations() {
            // Fines on the disc r < a = 6 mm, coarse on the ring a < r < b = 10 mm,
            // equal masses: R1 = 2a/3, R2 = 2(b³ − a³)/(3(b² − a²)); the stream's mass
            // reaches 95 % at r² = a² + 0.9 (b² − a²); every outer layer (from 0.88 R_s
            // = 8.5 mm) is coarse only.
            let (a, b) = (6.0 * MM, 10.0 * MM);
            let mut c = ring(fine(0.0), 40_000, 0.0, a, 0);
            c.extend(ring(coarse(0.0), 5_000, a, b, 100_000));
            let r = DischargeResponses::compute(&c, &ResponseOptions::default());
            let r2 = 2.0 * (b.powi(3) - a.powi(3)) / (3.0 * (b * b - a * a));
            assert_relative_eq!(r.r1_mean_m.unwrap(), 2.0 * a / 3.0, max_relative = 1e-4);
            assert_relative_eq!(r.r2_mean_m.unwrap(), r2, max_relative = 1e-4);
            assert_relative_eq!(
                r.segregation_ratio.unwrap(),
                2.0 * a / 3.0 / r2,
                max_relative = 1e-4
            );
            assert_relative_eq!(
                r.stream_radius_95_m.unwrap(),
                (a * a + 0.9 * (b * b - a * a)).sqrt(),
                max_relative = 1e-4
            );
            assert_eq!(fractions(&r), vec![0.0; 4]);
            // Densities over 20 bins of 0.5 mm: a = 6 mm is a bin edge.
            let RadialDensities {
                fine: fines,
                coarse,
            } = radial_densities(&c, &ResponseOptions::default());
            assert_density(
                &fines,
                |x| if x < a { 2.0 * x / (a * a) } else { 0.0 },
                1e-3,
            );
            assert_density(
                &coarse,
                |x| {
                    if x > a {
                        2.0 * x / (b * b - a * a)
                    } else {
                        0.0
                    }
                },
                5e-3,
            );
        }

        #[test]
        fn a_known_mixture_in_the_outer_ring() {
            // Uniform mass per area over a 10 mm disc; fines are 70 % of the mass in
            // the core r < 8 mm and 30 % in the ring beyond. R_s = 10 mm · √0.95 =
            // 9.75 mm, so every layer (from 0.88 R_s = 8.58 mm) lies in the ring and
            // holds 30 % fines. Per-particle means follow from the number densities
            // (fines 700 and 300 per mm², coarse 37.5 and 87.5 per mm²).
            let (core, edge) = (8.0 * MM, 10.0 * MM);
            let mut c = ring(fine(0.0), 44_800, 0.0, core, 0);
            c.extend(ring(coarse(0.0), 2_400, 0.0, core, 100_000));
            c.extend(ring(fine(0.0), 10_800, core, edge, 200_000));
            c.extend(ring(coarse(0.0), 3_150, core, edge, 300_000));
            let r = DischargeResponses::compute(&c, &ResponseOptions::default());
            for f in fractions(&r) {
                assert!((f - 0.3).abs() < 1e-3, "{:?}", r.fine_fraction_outer);
            }
            let mean = |inner: f64, outer: f64| {
                let moment = |x: f64| 2.0 / 3.0 * x.powi(3);
                let area = |x: f64| x * x;
                (
                    inner * moment(core) + outer * (moment(edge) - moment(core)),
                    inner * area(core) + outer * (area(edge) - area(core)),
                )
            };
            let (m1, n1) = mean(700.0, 300.0);
            let (m2, n2) = mean(37.5, 87.5);
            assert_relative_eq!(r.r1_mean_m.unwrap(), m1 / n1, max_relative = 1e-4);
            assert_relative_eq!(r.r2_mean_m.unwrap(), m2 / n2, max_relative = 1e-4);
        }

        /// The former definition of the outer layers, for comparison only: centre
        /// distance against the largest centre distance of any crossing.
        fn former_outer_fraction(c: &[Crossing], layer: f64) -> f64 {
            let max = c.iter().map(|c| c.radial_distance_m()).fold(0.0, f64::max);
            let beyond = c
                .iter()
                .filter(|c| c.radial_distance_m() >= (1.0 - layer) * max);
            let (fine, all) = beyond.fold((0.0, 0.0), |(f, a), c| {
                let is_fine = if c.particle_type == 2 { c.mass_kg } else { 0.0 };
                (f + is_fine, a + c.mass_kg)
            });
            fine / all
        }

        #[test]
        fn excluded_volume_at_the_rim_is_exposed_by_r1_r2_and_removed_by_the_new_definitions() {
            // The case: perfectly mixed 2 mm and 4 mm spheres (radii 1 and 2 mm),
            // half of the mass each, through a 24 mm outlet (R = 12 mm). Centres of fines
            // are uniform over a disc of R − 1 mm, of coarse over R − 2 mm.
            let (big_r, a_f, a_c) = (12.0 * MM, 1.0 * MM, 2.0 * MM);
            let mut c = ring(fine(a_f), 40_000, 0.0, big_r - a_f, 0);
            c.extend(ring(coarse(a_c), 5_000, 0.0, big_r - a_c, 100_000));
            let r = DischargeResponses::compute(&c, &ResponseOptions::default());

            // Centre-based R1/R2 shows the geometric bias, (R − a_f)/(R − a_c) = 1.1.
            let ratio = r.segregation_ratio.unwrap();
            assert_relative_eq!(ratio, 11.0 / 10.0, max_relative = 1e-4);

            // The former outer layers: only fine centres reach beyond 10 mm, the
            // largest coarse centre distance, so the 2 % and 5 % layers (from 10.78
            // and 10.45 mm) are all fines: the constant 1.0 of the issue.
            let former: Vec<f64> = [0.02, 0.05, 0.10, 0.12]
                .iter()
                .map(|&p| former_outer_fraction(&c, p))
                .collect();
            assert_eq!(&former[..2], &[1.0, 1.0]);

            // By surfaces both kinds reach the rim. The surface distance s of a kind of
            // radius a has CDF ((s − a)/(R − a))² on [a, R]; R_s solves
            // ½ F_f(R_s) + ½ F_c(R_s) = 0.95.
            let cdf = |s: f64, a: f64| ((s - a) / (big_r - a)).clamp(0.0, 1.0).powi(2);
            let mixture = |s: f64| 0.5 * cdf(s, a_f) + 0.5 * cdf(s, a_c);
            let (mut lo, mut hi) = (a_c, big_r);
            for _ in 0..100 {
                let mid = 0.5 * (lo + hi);
                if mixture(mid) < 0.95 {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            let r_s = 0.5 * (lo + hi);
            assert_relative_eq!(r.stream_radius_95_m.unwrap(), r_s, max_relative = 1e-4);
            let expected: Vec<f64> = [0.02, 0.05, 0.10, 0.12]
                .iter()
                .map(|&p| {
                    let t = (1.0 - p) * r_s;
                    let (f, k) = (1.0 - cdf(t, a_f), 1.0 - cdf(t, a_c));
                    f / (f + k)
                })
                .collect();
            let new = fractions(&r);
            for (n, e) in new.iter().zip(&expected) {
                assert!((n - e).abs() < 2e-3, "{new:?} against {expected:?}");
                // Within 3 points of the mixture's 0.5, where the former gave 1.
                assert!((n - 0.5).abs() < 0.03, "{new:?}");
            }
            // The normalised ratio divides out (R_s − a_f)/(R_s − a_c).
            let normalised = r.segregation_ratio_normalised.unwrap();
            assert_relative_eq!(
                normalised,
                ratio / ((r_s - a_f) / (r_s - a_c)),
                max_relative = 1e-5
            );
            assert!((normalised - 1.0).abs() < 0.005, "{normalised}");
            eprintln!(
                "excluded volume, R = 12 mm, radii 1 and 2 mm: R1/R2 = {ratio:.4}, \
                 normalised {normalised:.4}, R_s = {:.3} mm; outer 2/5/10/12 %: former \
                 {former:.3?}, new {new:.3?} (analytic {expected:.3?})",
                r_s / MM
            );
        }
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
