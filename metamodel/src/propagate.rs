//! Uncertainty propagation by Monte Carlo through a surface.
//!
//! Inputs are independent random variables; every sample of them is pushed through
//! the function, and the output's mean, standard deviation, two-sided 95 % interval
//! (2.5 % and 97.5 % quantiles) and one-sided 95 % bounds (5 % and 95 % quantiles)
//! are reported. The generator is seeded: the same seed gives the same figures.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution as _, LogNormal, Normal, Uniform};

/// One uncertain input.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Distribution {
    /// Normal with mean and standard deviation.
    Normal {
        /// Mean.
        mean: f64,
        /// Standard deviation, > 0.
        std: f64,
    },
    /// Uniform on `[low, high)`.
    Uniform {
        /// Lower end.
        low: f64,
        /// Upper end, > low.
        high: f64,
    },
    /// Log-normal: `ln X` is normal with mean `mu` and standard deviation `sigma`.
    LogNormal {
        /// Mean of `ln X`.
        mu: f64,
        /// Standard deviation of `ln X`, > 0.
        sigma: f64,
    },
}

/// What an output's distribution looks like.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spread {
    /// Samples drawn.
    pub samples: usize,
    /// Mean.
    pub mean: f64,
    /// Standard deviation (n − 1).
    pub std: f64,
    /// 2.5 % quantile: lower end of the two-sided 95 % interval.
    pub q025: f64,
    /// 97.5 % quantile: upper end of the two-sided 95 % interval.
    pub q975: f64,
    /// 5 % quantile: the one-sided 95 % lower bound.
    pub q05: f64,
    /// 95 % quantile: the one-sided 95 % upper bound.
    pub q95: f64,
}

/// Why a propagation cannot run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("input {index}: {message}")]
pub struct DistributionError {
    /// Which input.
    pub index: usize,
    /// What is wrong.
    pub message: String,
}

/// A validated [`Distribution`] ready to draw from; shared with [`crate::sobol`].
pub(crate) enum Sampler {
    Normal(Normal<f64>),
    Uniform(Uniform<f64>),
    LogNormal(LogNormal<f64>),
}

impl Sampler {
    /// Checks `d` (input number `index`, for the error) and builds its sampler.
    pub(crate) fn new(index: usize, d: Distribution) -> Result<Sampler, DistributionError> {
        let error = |message: String| DistributionError { index, message };
        let positive = |name: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(error(format!(
                    "{name} must be positive and finite, got {v}"
                )))
            }
        };
        match d {
            Distribution::Normal { std, .. } => positive("std", std)?,
            Distribution::Uniform { low, high } => positive("high - low", high - low)?,
            Distribution::LogNormal { sigma, .. } => positive("sigma", sigma)?,
        }
        Ok(match d {
            Distribution::Normal { mean, std } => Sampler::Normal(
                Normal::new(mean, std).map_err(|e| error(format!("normal({mean}, {std}): {e}")))?,
            ),
            Distribution::Uniform { low, high } => Sampler::Uniform(
                Uniform::new(low, high)
                    .map_err(|e| error(format!("uniform({low}, {high}): {e}")))?,
            ),
            Distribution::LogNormal { mu, sigma } => Sampler::LogNormal(
                LogNormal::new(mu, sigma)
                    .map_err(|e| error(format!("lognormal({mu}, {sigma}): {e}")))?,
            ),
        })
    }

    /// One draw.
    pub(crate) fn sample(&self, rng: &mut ChaCha8Rng) -> f64 {
        match self {
            Sampler::Normal(d) => d.sample(rng),
            Sampler::Uniform(d) => d.sample(rng),
            Sampler::LogNormal(d) => d.sample(rng),
        }
    }
}

/// Propagates `inputs` through `f` with `samples` draws from a generator seeded by `seed`.
pub fn propagate(
    f: &dyn Fn(&[f64]) -> f64,
    inputs: &[Distribution],
    samples: usize,
    seed: u64,
) -> Result<Spread, DistributionError> {
    propagate_draws(inputs, samples, seed, &mut |x, _| f(x))
}

/// Propagates `inputs` through a surface whose value is itself uncertain: `f` gives
/// its mean and standard deviation at a point (a surrogate's estimate and its standard
/// error), and each sample draws the inputs, then a normal value around that mean.
/// The spread is then that of the response at the uncertain inputs, surrogate error
/// included: the marginal of `f(X)` over both the inputs and the surrogate's
/// posterior (independent draws per sample give that marginal exactly, whatever the
/// correlation of the surrogate's error between points).
pub fn propagate_with_error(
    f: &dyn Fn(&[f64]) -> (f64, f64),
    inputs: &[Distribution],
    samples: usize,
    seed: u64,
) -> Result<Spread, DistributionError> {
    let standard = Normal::new(0.0, 1.0).expect("the standard normal is valid");
    propagate_draws(inputs, samples, seed, &mut |x, rng| {
        // No draw where the surface is certain, so a surface without error gives
        // exactly `propagate`'s figures from the same seed.
        match f(x) {
            (mean, std) if std > 0.0 => mean + std * standard.sample(rng),
            (mean, _) => mean,
        }
    })
}

fn propagate_draws(
    inputs: &[Distribution],
    samples: usize,
    seed: u64,
    draw: &mut dyn FnMut(&[f64], &mut ChaCha8Rng) -> f64,
) -> Result<Spread, DistributionError> {
    let samplers = inputs
        .iter()
        .enumerate()
        .map(|(i, d)| Sampler::new(i, *d))
        .collect::<Result<Vec<_>, _>>()?;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut x = vec![0.0; inputs.len()];
    let mut outputs = Vec::with_capacity(samples);
    for _ in 0..samples {
        for (value, sampler) in x.iter_mut().zip(&samplers) {
            *value = sampler.sample(&mut rng);
        }
        outputs.push(draw(&x, &mut rng));
    }
    let n = samples as f64;
    let mean = outputs.iter().sum::<f64>() / n;
    let variance = outputs.iter().map(|y| (y - mean).powi(2)).sum::<f64>() / (n - 1.0);
    let mut quantile = |p: f64| {
        let index = ((p * (samples - 1) as f64).round() as usize).min(samples - 1);
        *outputs.select_nth_unstable_by(index, f64::total_cmp).1
    };
    Ok(Spread {
        samples,
        mean,
        std: variance.sqrt(),
        q025: quantile(0.025),
        q975: quantile(0.975),
        q05: quantile(0.05),
        q95: quantile(0.95),
    })
}

#[cfg(test)]
mod tests {
    use std::f64::consts::PI;

    use super::*;

    #[test]
    fn ishigami_mean_and_variance_within_one_percent() {
        // Ishigami & Homma (1990): f = sin x1 + a sin² x2 + b x3⁴ sin x1, x ~ U(−π, π)³.
        // Mean a/2; variance a²/8 + b π⁴/5 + b² π⁸/18 + 1/2.
        let (a, b) = (7.0, 0.1);
        let f = |x: &[f64]| x[0].sin() + a * x[1].sin().powi(2) + b * x[2].powi(4) * x[0].sin();
        let u = Distribution::Uniform { low: -PI, high: PI };
        let spread = propagate(&f, &[u, u, u], 1_000_000, 42).unwrap();
        let mean = a / 2.0;
        let variance = a * a / 8.0 + b * PI.powi(4) / 5.0 + b * b * PI.powi(8) / 18.0 + 0.5;
        assert!((spread.mean - mean).abs() / mean < 0.01, "{spread:?}");
        assert!(
            (spread.std.powi(2) - variance).abs() / variance < 0.01,
            "{} vs {variance}",
            spread.std.powi(2)
        );
    }

    #[test]
    fn a_linear_function_of_normals_has_its_exact_mean_variance_and_quantiles() {
        // y = 2 + 3 x1 − 0.5 x2, x1 ~ N(1, 0.2), x2 ~ N(−2, 1.5): mean 6, var 0.36 + 0.5625.
        let f = |x: &[f64]| 2.0 + 3.0 * x[0] - 0.5 * x[1];
        let inputs = [
            Distribution::Normal {
                mean: 1.0,
                std: 0.2,
            },
            Distribution::Normal {
                mean: -2.0,
                std: 1.5,
            },
        ];
        let spread = propagate(&f, &inputs, 1_000_000, 7).unwrap();
        let std = (0.36f64 + 0.5625).sqrt();
        assert!((spread.mean - 6.0).abs() / 6.0 < 0.01);
        assert!((spread.std - std).abs() / std < 0.01);
        assert!((spread.q975 - (6.0 + 1.959964 * std)).abs() / std < 0.01);
        assert!((spread.q95 - (6.0 + 1.644854 * std)).abs() / std < 0.01);
        // Seeded: the same seed gives the same figures.
        assert_eq!(
            propagate(&f, &inputs, 1000, 7),
            propagate(&f, &inputs, 1000, 7)
        );
    }

    #[test]
    fn bad_distributions_are_named() {
        let error = propagate(
            &|x| x[0],
            &[Distribution::Normal {
                mean: 0.0,
                std: -1.0,
            }],
            10,
            0,
        )
        .unwrap_err();
        assert_eq!(
            error.to_string(),
            "input 0: std must be positive and finite, got -1"
        );
    }

    #[test]
    fn surrogate_error_adds_its_variance_to_the_inputs() {
        // y = 3 x + ε, x ~ N(0, 0.2), ε ~ N(0, 0.5) from the surrogate: var 0.36 + 0.25.
        let f = |x: &[f64]| (3.0 * x[0], 0.5);
        let inputs = [Distribution::Normal {
            mean: 0.0,
            std: 0.2,
        }];
        let spread = propagate_with_error(&f, &inputs, 1_000_000, 11).unwrap();
        let std = (0.36f64 + 0.25).sqrt();
        assert!((spread.std - std).abs() / std < 0.01, "{spread:?}");
        assert!((spread.q975 - 1.959964 * std).abs() / std < 0.01);
        // Without surrogate error it is exactly the input-only spread.
        let without = propagate_with_error(&|x: &[f64]| (3.0 * x[0], 0.0), &inputs, 1000, 11);
        assert_eq!(
            without,
            propagate(&|x: &[f64]| 3.0 * x[0], &inputs, 1000, 11)
        );
    }
}
