//! Robust design: a surface's mean and spread at a design point under uncertain
//! inputs, and its probability of passing a limit, from one fixed set of scenarios.
//!
//! A scenario is one draw of the uncertain inputs: factors that are uncertain in
//! themselves (a material held at its mean while the others are optimised) take the
//! drawn value, and factors with a manufacturing tolerance are shifted by the drawn
//! deviation from wherever the design puts them. Every candidate design is judged on
//! the same scenarios (common random numbers), so the optimiser compares designs, not
//! sampling noise, and an objective like `mean − k·std` is a smooth function of the
//! design.
//!
//! References: Taguchi's robust design as response-surface optimisation of mean and
//! variance, Myers, Montgomery & Anderson-Cook, *Response Surface Methodology*, 4th ed.,
//! ch. 10; probability of failure by Monte Carlo and its binomial standard error,
//! Melchers & Beck, *Structural Reliability Analysis and Prediction*, 3rd ed., §3.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::propagate::{DistributionError, Sampler};
use crate::{Distribution, FactorRange};

/// Draws of the uncertain inputs, in coded units of one box.
#[derive(Debug, Clone, PartialEq)]
pub struct Scenarios {
    /// `(factor, coded value in each scenario)`: factors uncertain in themselves.
    set: Vec<(usize, Vec<f64>)>,
    /// `(factor, coded deviation in each scenario)`: factors with a tolerance.
    shift: Vec<(usize, Vec<f64>)>,
    /// Scenarios.
    count: usize,
}

impl Scenarios {
    /// `count` scenarios seeded by `seed`: each factor of `uncertain` (index,
    /// distribution in natural units) drawn from its distribution, each of
    /// `tolerances` (index, standard deviation in natural units) shifted by a normal
    /// deviation; `ranges` is the box the coded units refer to.
    pub fn draw(
        uncertain: &[(usize, Distribution)],
        tolerances: &[(usize, f64)],
        ranges: &[FactorRange],
        count: usize,
        seed: u64,
    ) -> Result<Scenarios, DistributionError> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut set = Vec::new();
        for (i, (index, distribution)) in uncertain.iter().enumerate() {
            let sampler = Sampler::new(i, *distribution)?;
            let range = ranges[*index];
            let values = (0..count)
                .map(|_| range.to_coded(sampler.sample(&mut rng)))
                .collect();
            set.push((*index, values));
        }
        let mut shift = Vec::new();
        for (i, (index, std)) in tolerances.iter().enumerate() {
            let normal = Distribution::Normal {
                mean: 0.0,
                std: *std,
            };
            let sampler = Sampler::new(uncertain.len() + i, normal)?;
            let half_width = 0.5 * (ranges[*index].max - ranges[*index].min);
            let values = (0..count)
                .map(|_| sampler.sample(&mut rng) / half_width)
                .collect();
            shift.push((*index, values));
        }
        Ok(Scenarios { set, shift, count })
    }

    /// Number of scenarios.
    pub fn len(&self) -> usize {
        self.count
    }

    /// True without scenarios.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// `f` at design point `x` (coded) in every scenario.
    pub fn values(&self, f: &dyn Fn(&[f64]) -> f64, x: &[f64]) -> Vec<f64> {
        let mut point = x.to_vec();
        (0..self.count)
            .map(|s| {
                point.copy_from_slice(x);
                for (index, values) in &self.set {
                    point[*index] = values[s];
                }
                for (index, deviations) in &self.shift {
                    point[*index] += deviations[s];
                }
                f(&point)
            })
            .collect()
    }

    /// Mean and standard deviation (n − 1) of `f` at `x` over the scenarios.
    pub fn moments(&self, f: &dyn Fn(&[f64]) -> f64, x: &[f64]) -> (f64, f64) {
        let values = self.values(f, x);
        let n = values.len() as f64;
        let mean = values.iter().sum::<f64>() / n;
        let variance = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
        (mean, variance.sqrt())
    }

    /// The fraction of scenarios in which `f` at `x` lies beyond `limit` (above it
    /// when `above`, else below), and its binomial standard error
    /// `sqrt(p (1 − p) / n)`: a Monte Carlo probability of failure.
    pub fn exceedance(
        &self,
        f: &dyn Fn(&[f64]) -> f64,
        x: &[f64],
        limit: f64,
        above: bool,
    ) -> (f64, f64) {
        let values = self.values(f, x);
        let n = values.len() as f64;
        let failures = values
            .iter()
            .filter(|&&v| if above { v > limit } else { v < limit })
            .count() as f64;
        let p = failures / n;
        (p, (p * (1.0 - p) / n).sqrt())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_box(k: usize) -> Vec<FactorRange> {
        vec![
            FactorRange {
                min: -1.0,
                max: 1.0
            };
            k
        ]
    }

    #[test]
    fn a_linear_surface_has_the_textbook_mean_and_spread() {
        // y = 2 x0 + 3 x1, x1 ~ N(0.1, 0.2), x0 shifted by N(0, 0.05):
        // mean 2 x0 + 0.3, std sqrt(0.6² + 0.1²).
        let scenarios = Scenarios::draw(
            &[(
                1,
                Distribution::Normal {
                    mean: 0.1,
                    std: 0.2,
                },
            )],
            &[(0, 0.05)],
            &unit_box(2),
            200_000,
            3,
        )
        .unwrap();
        let f = |x: &[f64]| 2.0 * x[0] + 3.0 * x[1];
        let (mean, std) = scenarios.moments(&f, &[0.5, 0.0]);
        assert!((mean - 1.3).abs() < 0.005, "{mean}");
        let expected = (0.36f64 + 0.01).sqrt();
        assert!((std - expected).abs() / expected < 0.01, "{std}");
    }

    #[test]
    fn the_probability_of_failure_matches_the_normal_tail_within_its_standard_error() {
        // y = x, x ~ N(0, 1): P[y > 1.644854] = 0.05.
        let scenarios = Scenarios::draw(
            &[(
                0,
                Distribution::Normal {
                    mean: 0.0,
                    std: 1.0,
                },
            )],
            &[],
            &unit_box(1),
            100_000,
            5,
        )
        .unwrap();
        let (p, se) = scenarios.exceedance(&|x| x[0], &[0.0], 1.644854, true);
        assert!((se - (0.05f64 * 0.95 / 1e5).sqrt()).abs() < 1e-4);
        assert!((p - 0.05).abs() < 3.0 * se, "{p} ± {se}");
        let (below, _) = scenarios.exceedance(&|x| x[0], &[0.0], -1.644854, false);
        assert!((below - 0.05).abs() < 0.003);
    }

    #[test]
    fn every_design_sees_the_same_scenarios() {
        let scenarios = Scenarios::draw(&[], &[(0, 0.1)], &unit_box(1), 100, 1).unwrap();
        let f = |x: &[f64]| x[0];
        // The spread of a shifted factor does not depend on where it sits.
        let (_, a) = scenarios.moments(&f, &[-0.5]);
        let (_, b) = scenarios.moments(&f, &[0.5]);
        assert!((a - b).abs() < 1e-12);
        assert_eq!(
            scenarios,
            Scenarios::draw(&[], &[(0, 0.1)], &unit_box(1), 100, 1).unwrap()
        );
    }
}
