use nalgebra::{DMatrix, DVector};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use super::*;
use crate::design::{Design, DesignKind};

fn lhs(samples: usize, k: usize, seed: u64) -> Vec<Vec<f64>> {
    Design::build(
        &DesignKind::LatinHypercube {
            samples,
            seed,
            candidates: 50,
        },
        k,
    )
    .unwrap()
    .points
}

fn smooth(p: &[f64]) -> f64 {
    (2.0 * p[0]).sin() + 0.5 * p[1] * p[1] - 0.3 * p[0] * p[1] + 2.0
}

fn spread(y: &[f64]) -> f64 {
    let (lo, hi) = y
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(*v), b.max(*v))
        });
    hi - lo
}

fn variance(y: &[f64]) -> f64 {
    let (_, s) = mean_and_std(y);
    s * s
}

fn options(kernel: Kernel, trend: Trend, nugget: Nugget) -> KrigingOptions {
    KrigingOptions {
        kernel,
        trend,
        nugget,
        ..KrigingOptions::default()
    }
}

const KERNELS: [Kernel; 2] = [Kernel::Matern52, Kernel::SquaredExponential];
const TRENDS: [Trend; 2] = [Trend::Constant, Trend::Linear];

#[test]
fn noise_free_data_are_interpolated_with_no_variance_left_at_the_runs() {
    let x = lhs(15, 2, 3);
    let y: Vec<f64> = x.iter().map(|p| smooth(p)).collect();
    let range = spread(&y);
    for kernel in KERNELS {
        // No nugget, and the default (no replicates, so a fitted nugget ≥ 10⁻¹⁰).
        for nugget in [Nugget::Fixed(0.0), Nugget::FromReplicates] {
            let model = Kriging::fit(&x, &y, &options(kernel, Trend::Constant, nugget)).unwrap();
            for (p, v) in x.iter().zip(&y) {
                let error = (model.predict(p) - v).abs();
                assert!(error < 1e-6 * range, "{kernel:?} {nugget:?}: {error}");
                let var = model.predict_variance(p);
                assert!(
                    (0.0..1e-6 * model.process_variance()).contains(&var),
                    "{kernel:?} {nugget:?}: variance {var} at a run"
                );
            }
            // Between the runs there is uncertainty.
            assert!(model.predict_variance(&[0.013, -0.021]) > 0.0);
        }
    }
}

#[test]
fn closed_form_leave_one_out_equals_refitting_without_each_run() {
    let x = lhs(12, 2, 5);
    let y: Vec<f64> = x.iter().map(|p| smooth(p)).collect();
    let (s2, range) = (variance(&y), spread(&y));
    let length_scales = [0.6, 0.9];
    for kernel in KERNELS {
        for trend in TRENDS {
            for noise in [0.0, 0.01 * s2] {
                let model =
                    Kriging::with_hyperparameters(&x, &y, kernel, trend, &length_scales, s2, noise)
                        .unwrap();
                assert_eq!(model.jitter(), 0.0, "the check needs identical systems");
                let residuals = model.loo_residuals();
                let variances = model.loo_variances();
                for i in 0..x.len() {
                    let (mut xs, mut ys) = (x.clone(), y.clone());
                    xs.remove(i);
                    ys.remove(i);
                    let without = model.refit(&xs, &ys).unwrap();
                    let brute = y[i] - without.predict(&x[i]);
                    let tolerance = 1e-8 * brute.abs().max(1e-3 * range);
                    assert!(
                        (residuals[i] - brute).abs() < tolerance,
                        "{kernel:?} {trend:?} τ²={noise}: run {i}: {} vs {brute}",
                        residuals[i]
                    );
                    let brute_variance = without.predict_variance(&x[i]) + noise;
                    assert!(
                        ((variances[i] - brute_variance) / brute_variance).abs() < 1e-8,
                        "{kernel:?} {trend:?} τ²={noise}: run {i}: variance {} vs {brute_variance}",
                        variances[i]
                    );
                }
            }
        }
    }
}

#[test]
fn leave_one_out_of_a_fitted_model_equals_refitting_with_its_hyperparameters() {
    let x = lhs(14, 2, 8);
    let y: Vec<f64> = x.iter().map(|p| smooth(p)).collect();
    let model = Kriging::fit(
        &x,
        &y,
        &options(Kernel::Matern52, Trend::Linear, Nugget::Fitted),
    )
    .unwrap();
    let residuals = model.loo_residuals();
    for i in 0..x.len() {
        let (mut xs, mut ys) = (x.clone(), y.clone());
        xs.remove(i);
        ys.remove(i);
        let brute = y[i] - model.refit(&xs, &ys).unwrap().predict(&x[i]);
        assert!(
            (residuals[i] - brute).abs() < 1e-8 * brute.abs().max(1e-3 * spread(&y)),
            "run {i}: {} vs {brute}",
            residuals[i]
        );
    }
}

#[test]
fn a_sine_is_predicted_between_eight_points_and_covered_by_its_intervals() {
    let f = |t: f64| (3.0 * t).sin();
    let x: Vec<Vec<f64>> = (0..8).map(|i| vec![-1.0 + 2.0 * i as f64 / 7.0]).collect();
    let y: Vec<f64> = x.iter().map(|p| f(p[0])).collect();
    let model = Kriging::fit(&x, &y, &KrigingOptions::default()).unwrap();
    let grid: Vec<f64> = (0..=400).map(|i| -1.0 + i as f64 / 200.0).collect();
    let mut worst: f64 = 0.0;
    let mut covered = 0;
    for &t in &grid {
        let error = (model.predict(&[t]) - f(t)).abs();
        worst = worst.max(error);
        if error <= 1.96 * model.predict_variance(&[t]).sqrt() + 1e-9 {
            covered += 1;
        }
    }
    // sin(3t) has amplitude 1; eight points over 0.95 of a period predict it to 3 %.
    assert!(worst < 0.03, "largest error {worst}");
    let coverage = covered as f64 / grid.len() as f64;
    assert!(coverage >= 0.9, "95 % intervals cover {coverage}");
}

#[test]
fn pure_error_from_replicates_estimates_the_known_noise() {
    // 10 points × 5 replicates of sin(2t) + N(0, 0.1²): 40 degrees of freedom, so the
    // pooled variance / 0.01 lies in [χ²_40(0.001), χ²_40(0.999)] / 40 = [0.448, 1.835]
    // with probability 0.998.
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let noise = Normal::new(0.0, 0.1).unwrap();
    let mut x = Vec::new();
    let mut y = Vec::new();
    for i in 0..10 {
        let t = -1.0 + 2.0 * i as f64 / 9.0;
        for _ in 0..5 {
            x.push(vec![t]);
            y.push((2.0 * t).sin() + noise.sample(&mut rng));
        }
    }
    let (pooled, dof) = pure_error_variance(&x, &y).unwrap();
    assert_eq!(dof, 40);
    assert!(
        (0.448 * 0.01..1.835 * 0.01).contains(&pooled),
        "pooled variance {pooled}"
    );
    let model = Kriging::fit(&x, &y, &KrigingOptions::default()).unwrap();
    assert!((model.noise_variance() - pooled).abs() < 1e-12 * pooled);
    // The surface smooths the replicates: near each group's mean, not through every run.
    for i in 0..10 {
        let group = &y[5 * i..5 * i + 5];
        let mean = group.iter().sum::<f64>() / 5.0;
        let predicted = model.predict(&x[5 * i]);
        assert!(
            (predicted - mean).abs() < 0.1,
            "group {i}: {predicted} vs {mean}"
        );
    }
    assert!(pure_error_variance(&lhs(6, 2, 1), &[1.0; 6]).is_none());
}

#[test]
fn identical_points_without_nugget_get_jitter_or_an_error_never_nan() {
    let mut x = lhs(8, 2, 2);
    x.push(x[0].clone());
    let mut y: Vec<f64> = x.iter().map(|p| smooth(p)).collect();
    y[8] += 0.1;
    for kernel in KERNELS {
        let given = Kriging::with_hyperparameters(
            &x,
            &y,
            kernel,
            Trend::Constant,
            &[0.5, 0.5],
            variance(&y),
            0.0,
        );
        let fitted = Kriging::fit(
            &x,
            &y,
            &options(kernel, Trend::Constant, Nugget::Fixed(0.0)),
        );
        for result in [given, fitted] {
            match result {
                Ok(model) => {
                    assert!(model.jitter() > 0.0, "{kernel:?}: jitter not recorded");
                    for p in &x {
                        assert!(model.predict(p).is_finite());
                        assert!(model.predict_variance(p).is_finite());
                    }
                    assert!(model.loo_residuals().iter().all(|r| r.is_finite()));
                    assert!(model.log_likelihood().is_finite());
                }
                Err(KrigingError::IllConditioned {
                    condition_estimate, ..
                }) => assert!(condition_estimate > MAX_CONDITION),
                Err(other) => panic!("{kernel:?}: {other}"),
            }
        }
    }
}

#[test]
fn an_indefinite_matrix_is_reported_as_ill_conditioned_with_advice() {
    let m = DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 2.0, 1.0]);
    let error = cholesky_with_jitter(&m).unwrap_err();
    assert!(matches!(
        error,
        KrigingError::IllConditioned { condition_estimate, jitter }
            if condition_estimate.is_infinite() && jitter > 0.0
    ));
    let message = error.to_string();
    assert!(
        message.contains("nugget") && message.contains("duplicate"),
        "{message}"
    );
}

#[test]
fn log_likelihood_is_the_gaussian_density_of_the_responses() {
    // ln N(y; Fβ̂, σ²R + τ²I) computed directly, in response units, with β̂ by GLS.
    let x = lhs(10, 2, 4);
    let y: Vec<f64> = x.iter().map(|p| 100.0 * smooth(p)).collect();
    let (l, s2, tau2) = ([0.4, 0.7], 3000.0, 20.0);
    for kernel in KERNELS {
        let model =
            Kriging::with_hyperparameters(&x, &y, kernel, Trend::Linear, &l, s2, tau2).unwrap();
        let n = x.len();
        let c = DMatrix::from_fn(n, n, |i, j| {
            let d2: f64 = (0..2).map(|m| ((x[i][m] - x[j][m]) / l[m]).powi(2)).sum();
            s2 * kernel.correlation(d2) + if i == j { tau2 } else { 0.0 }
        });
        let f = DMatrix::from_fn(n, 3, |i, j| if j == 0 { 1.0 } else { x[i][j - 1] });
        let yv = DVector::from_column_slice(&y);
        let c_inverse = c.clone().try_inverse().unwrap();
        let beta = (f.transpose() * &c_inverse * &f).try_inverse().unwrap()
            * (f.transpose() * &c_inverse * &yv);
        let r = &yv - &f * &beta;
        let direct = -0.5
            * (c.determinant().ln()
                + (r.transpose() * &c_inverse * &r)[(0, 0)]
                + n as f64 * (2.0 * std::f64::consts::PI).ln());
        assert!(
            (model.log_likelihood() - direct).abs() < 1e-8 * direct.abs(),
            "{kernel:?}: {} vs {direct}",
            model.log_likelihood()
        );
        for (got, want) in model.trend_coefficients().iter().zip(beta.iter()) {
            assert!(
                (got - want).abs() < 1e-8 * want.abs().max(1.0),
                "{got} vs {want}"
            );
        }
    }
}

#[test]
fn maximum_likelihood_is_not_beaten_nearby() {
    let x = lhs(20, 2, 6);
    let y: Vec<f64> = x.iter().map(|p| smooth(p)).collect();
    for kernel in KERNELS {
        let model =
            Kriging::fit(&x, &y, &options(kernel, Trend::Constant, Nugget::Fitted)).unwrap();
        let best = model.log_likelihood();
        let ell = model.length_scales().to_vec();
        let (s2, tau2) = (model.process_variance(), model.noise_variance());
        for (a, b, c) in [
            (1.2, 1.0, 1.0),
            (0.8, 1.0, 1.0),
            (1.0, 1.2, 1.0),
            (1.0, 0.8, 1.0),
            (1.0, 1.0, 1.3),
            (1.0, 1.0, 0.7),
            (1.1, 0.9, 1.2),
        ] {
            let other = Kriging::with_hyperparameters(
                &x,
                &y,
                kernel,
                Trend::Constant,
                &[ell[0] * a, ell[1] * b],
                s2 * c,
                tau2 * c,
            )
            .unwrap();
            assert!(
                other.log_likelihood() <= best + 1e-6,
                "{kernel:?}: ({a}, {b}, {c}) gives {} > {best}",
                other.log_likelihood()
            );
        }
    }
}

#[test]
fn the_same_seed_gives_the_same_fit() {
    let x = lhs(12, 3, 9);
    let y: Vec<f64> = x.iter().map(|p| smooth(p) + p[2]).collect();
    let a = Kriging::fit(&x, &y, &KrigingOptions::default()).unwrap();
    let b = Kriging::fit(&x, &y, &KrigingOptions::default()).unwrap();
    assert_eq!(a.length_scales(), b.length_scales());
    assert_eq!(a.predict(&[0.1, 0.2, 0.3]), b.predict(&[0.1, 0.2, 0.3]));
}

#[test]
fn bad_input_is_refused_with_what_to_do() {
    let x = lhs(6, 2, 1);
    let y: Vec<f64> = x.iter().map(|p| smooth(p)).collect();
    let default = KrigingOptions::default();
    assert!(matches!(
        Kriging::fit(&x, &y[..5], &default),
        Err(KrigingError::Mismatch {
            points: 6,
            responses: 5
        })
    ));
    let mut bad = y.clone();
    bad[3] = f64::NAN;
    assert!(matches!(
        Kriging::fit(&x, &bad, &default),
        Err(KrigingError::NotFinite { index: 3, .. })
    ));
    let mut short = x.clone();
    short[2] = vec![0.0];
    assert!(matches!(
        Kriging::fit(&short, &y, &default),
        Err(KrigingError::Dimensions { index: 2, .. })
    ));
    assert!(matches!(
        Kriging::fit(
            &x[..3],
            &y[..3],
            &options(Kernel::Matern52, Trend::Linear, Nugget::Fitted)
        ),
        Err(KrigingError::TooFewRuns { needed: 4, .. })
    ));
    assert!(matches!(
        Kriging::fit(&x, &[2.0; 6], &default),
        Err(KrigingError::ConstantResponse { .. })
    ));
    assert!(matches!(
        Kriging::with_hyperparameters(
            &x,
            &y,
            Kernel::Matern52,
            Trend::Constant,
            &[0.5, -1.0],
            1.0,
            0.0
        ),
        Err(KrigingError::BadHyperparameter {
            name: "length scale",
            ..
        })
    ));
    let flat: Vec<Vec<f64>> = x.iter().map(|p| vec![p[0], 0.3]).collect();
    let error = Kriging::fit(
        &flat,
        &y,
        &options(Kernel::Matern52, Trend::Linear, Nugget::Fitted),
    )
    .unwrap_err();
    assert!(
        matches!(error, KrigingError::TrendNotEstimable { .. }),
        "{error}"
    );
}

#[test]
fn a_dense_smooth_sample_gets_long_length_scales_and_an_earlier_fit_is_a_start() {
    // Branin-like smooth surface on 100 runs in 2 factors: the likelihood wants long
    // length scales and almost no nugget (the fit this once missed by capping them).
    let x = lhs(100, 2, 3);
    let f = |p: &[f64]| {
        let (a, b) = (7.5 * (p[0] + 1.0) - 5.0, 7.5 * (p[1] + 1.0));
        (b - 0.129 * a * a + 1.59 * a - 6.0).powi(2) + 9.6 * a.cos() + 10.0
    };
    let y: Vec<f64> = x.iter().map(|p| f(p)).collect();
    let squared = options(Kernel::SquaredExponential, Trend::Constant, Nugget::Fitted);
    let model = Kriging::fit(&x, &y, &squared).unwrap();
    assert!(
        model.noise_variance() / model.process_variance() < 1e-11,
        "nugget ratio {}",
        model.noise_variance() / model.process_variance()
    );
    let probe = lhs(200, 2, 99);
    let rmse = (probe
        .iter()
        .map(|p| (model.predict(p) - f(p)).powi(2))
        .sum::<f64>()
        / 200.0)
        .sqrt();
    // 3.6e-3 here; a nugget floor of 1e-10 and a condition cap of 1e10 gave 3.2e-2.
    assert!(rmse < 1e-4 * spread(&y), "held-out RMSE {rmse}");
    // One start alone, with the full fit's length scales as the earlier fit's: at least
    // as likely as the full search.
    let warm = KrigingOptions {
        starts: 1,
        previous_length_scales: Some(model.length_scales().to_vec()),
        ..squared
    };
    let again = Kriging::fit(&x, &y, &warm).unwrap();
    assert!(again.log_likelihood() >= model.log_likelihood() - 1e-3);
}
