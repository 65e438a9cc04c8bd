use approx::assert_relative_eq;

use super::*;
use crate::basis::BasisKind;
use crate::design::{CentralCompositeAlpha, Design, DesignKind};

fn names(k: usize) -> Vec<String> {
    ["a", "b", "c", "d"][..k]
        .iter()
        .map(|s| s.to_string())
        .collect()
}

fn ccd(k: usize) -> Vec<Vec<f64>> {
    Design::build(
        &DesignKind::CentralComposite {
            alpha: CentralCompositeAlpha::Orthogonal,
            center_points: 1,
        },
        k,
    )
    .unwrap()
    .points
}

fn quadratic(x: &[f64]) -> f64 {
    3.0 + 1.5 * x[0] - 2.0 * x[1] + 0.5 * x[2] - 1.2 * x[0] * x[0] + 0.7 * x[1] * x[1]
        - 0.3 * x[2] * x[2]
        + 0.9 * x[0] * x[1]
        - 0.4 * x[0] * x[2]
        + 0.25 * x[1] * x[2]
}

#[test]
fn an_exact_quadratic_is_recovered_from_a_central_composite_design() {
    let x = ccd(3);
    let y: Vec<f64> = x.iter().map(|p| quadratic(p)).collect();
    let fit = Fit::new(
        Basis::complete(BasisKind::Monomial, 3, 2),
        &names(3),
        &x,
        &y,
    )
    .unwrap();
    assert_eq!(
        fit.names,
        ["1", "a", "b", "c", "a^2", "b^2", "c^2", "a*b", "a*c", "b*c"]
    );
    let expected = [3.0, 1.5, -2.0, 0.5, -1.2, 0.7, -0.3, 0.9, -0.4, 0.25];
    for (got, want) in fit.coefficients.iter().zip(expected) {
        assert!((got - want).abs() < 1e-10, "{got} vs {want}");
    }
    assert!((fit.quality.r2 - 1.0).abs() < 1e-12);
}

#[test]
fn legendre_and_monomial_fits_predict_the_same() {
    let x = ccd(3);
    // Not a quadratic: the two fits must still agree, being projections onto one space.
    let y: Vec<f64> = x
        .iter()
        .map(|p| (p[0] + 0.3 * p[1]).exp() + p[2].sin())
        .collect();
    let monomial = Fit::new(
        Basis::complete(BasisKind::Monomial, 3, 2),
        &names(3),
        &x,
        &y,
    )
    .unwrap();
    let legendre = Fit::new(
        Basis::complete(BasisKind::Legendre, 3, 2),
        &names(3),
        &x,
        &y,
    )
    .unwrap();
    for probe in [[0.1, -0.4, 0.9], [-1.0, 1.0, 0.0], [0.33, 0.66, -0.5]] {
        assert!((monomial.predict(&probe) - legendre.predict(&probe)).abs() < 1e-9);
    }
    assert!(
        (monomial.quality.sigma_cross_percent.unwrap()
            - legendre.quality.sigma_cross_percent.unwrap())
        .abs()
            < 1e-9
    );
}

#[test]
fn leave_one_out_residuals_from_the_hat_matrix_equal_refits() {
    let x = ccd(2);
    let y: Vec<f64> = x
        .iter()
        .enumerate()
        .map(|(i, p)| 1.0 + p[0] - p[1] * p[1] + 0.1 * ((i * 7) % 5) as f64)
        .collect();
    let basis = Basis::complete(BasisKind::Monomial, 2, 2);
    // Add two extra runs so that every point has leverage below one.
    let mut x = x;
    let mut y = y;
    x.push(vec![0.5, -0.5]);
    y.push(0.7);
    x.push(vec![-0.5, 0.25]);
    y.push(0.2);
    let fit = Fit::new(basis.clone(), &names(2), &x, &y).unwrap();
    let loo = fit.quality.loo_residuals.clone().unwrap();
    for (i, loo_i) in loo.iter().enumerate() {
        let (mut xs, mut ys) = (x.clone(), y.clone());
        let (held_x, held_y) = (xs.remove(i), ys.remove(i));
        let refit = Fit::new(basis.clone(), &names(2), &xs, &ys).unwrap();
        assert!(
            (loo_i - (held_y - refit.predict(&held_x))).abs() < 1e-10,
            "run {i}"
        );
    }
    let press: f64 = loo.iter().map(|e| e * e).sum();
    assert_relative_eq!(fit.quality.press.unwrap(), press, max_relative = 1e-12);
}

#[test]
fn a_design_that_cannot_separate_terms_is_refused_by_name() {
    // A two-level factorial cannot tell a^2 and b^2 from the constant.
    let x = Design::build(&DesignKind::FullFactorial { levels: 2 }, 2)
        .unwrap()
        .points;
    let mut x2 = x.clone();
    x2.extend(x.iter().cloned());
    let y = vec![1.0, 2.0, 3.0, 4.0, 1.1, 2.1, 3.1, 4.1];
    let error = Fit::new(
        Basis::complete(BasisKind::Monomial, 2, 2),
        &names(2),
        &x2,
        &y,
    )
    .unwrap_err();
    match &error {
        FitError::RankDeficient { aliased } => assert_eq!(aliased.len(), 2, "{aliased:?}"),
        other => panic!("{other}"),
    }
    assert!(error
        .to_string()
        .starts_with("the design cannot separate the terms "));
    let too_few = Fit::new(
        Basis::complete(BasisKind::Monomial, 2, 2),
        &names(2),
        &x,
        &[1.0; 4],
    )
    .unwrap_err();
    assert_eq!(too_few, FitError::TooFewRuns { runs: 4, terms: 6 });
}

/// Montgomery, *Design and Analysis of Experiments*, 5th ed., Wiley 2001, Example 11-1
/// (p. 431): a central composite design (α = 1.414, five centre runs) on the yield of
/// a chemical process against reaction time (min) and temperature (°F). The book's
/// fitted second-order model in natural units is
/// `yield = −1430.52285 + 7.80749 t + 13.27053 T − 0.05505 t² − 0.04005 T² + 0.01 t T`,
/// with model SS 28.25 of a total 28.74 (R² = 0.9827) and a maximum of 80.21 at
/// t = 87 min, T = 176.5 °F. (Data and results as reproduced in ReliaWiki's validation
/// page "Central Composite Response Surface Method".)
pub(crate) fn montgomery_example_11_1() -> (Vec<Vec<f64>>, Vec<f64>) {
    let runs = [
        (80.0, 170.0, 76.5),
        (80.0, 180.0, 77.0),
        (90.0, 170.0, 78.0),
        (90.0, 180.0, 79.5),
        (85.0, 175.0, 79.9),
        (85.0, 175.0, 80.3),
        (85.0, 175.0, 80.0),
        (85.0, 175.0, 79.7),
        (85.0, 175.0, 79.8),
        (92.07, 175.0, 78.4),
        (77.93, 175.0, 75.6),
        (85.0, 182.07, 78.5),
        (85.0, 167.93, 77.0),
    ];
    (
        runs.iter().map(|r| vec![r.0, r.1]).collect(),
        runs.iter().map(|r| r.2).collect(),
    )
}

/// Equal to `expected` to three significant digits.
fn three_digits(got: f64, expected: f64) -> bool {
    let scale = 10f64.powf(expected.abs().log10().floor() - 2.0);
    ((got - expected) / scale).abs() < 0.5
}

#[test]
fn montgomery_example_11_1_coefficients_and_r2_are_reproduced() {
    let (x, y) = montgomery_example_11_1();
    let fit = Fit::new(
        Basis::complete(BasisKind::Monomial, 2, 2),
        &["t".into(), "T".into()],
        &x,
        &y,
    )
    .unwrap();
    assert_eq!(fit.names, ["1", "t", "T", "t^2", "T^2", "t*T"]);
    let published = [-1430.52285, 7.80749, 13.27053, -0.05505, -0.04005, 0.01];
    for ((name, got), want) in fit.names.iter().zip(&fit.coefficients).zip(published) {
        assert!(
            three_digits(*got, want),
            "{name}: {got} vs published {want}"
        );
    }
    assert!(
        three_digits(fit.quality.r2, 0.9827),
        "R² {}",
        fit.quality.r2
    );
    let ss_res: f64 = fit.residuals.iter().map(|e| e * e).sum();
    assert!(
        three_digits(ss_res, 0.4962) || (ss_res - 0.50).abs() < 0.005,
        "SS_res {ss_res}"
    );
}

#[test]
fn montgomery_example_11_1_optimum_is_reproduced() {
    // The book: maximum yield 80.21 at t = 87 min, T = 176.5 °F, inside the design box.
    use crate::optimise::{optimise, BoxBounds, Goal};
    let (x, y) = montgomery_example_11_1();
    let fit = Fit::new(
        Basis::complete(BasisKind::Monomial, 2, 2),
        &["t".into(), "T".into()],
        &x,
        &y,
    )
    .unwrap();
    let bounds = BoxBounds {
        lower: vec![77.93, 167.93],
        upper: vec![92.07, 182.07],
        levels: Vec::new(),
    };
    let optimum = optimise(&|p| fit.predict(p), true, Goal::Maximise, &bounds, 0);
    assert!(three_digits(optimum.value, 80.21), "{optimum:?}");
    assert!(
        (optimum.x[0] - 87.0).abs() < 0.5 && (optimum.x[1] - 176.5).abs() < 0.5,
        "{optimum:?}"
    );
}

/// Montgomery, Peck & Vining, *Introduction to Linear Regression Analysis*, 5th ed.,
/// Wiley 2012, Table 3.2 (Example 3.1): the soft drink delivery time data, 25 outlets,
/// with the number of cases stocked, the walking distance (ft) and the delivery time
/// (min). The book's fit is `ŷ = 2.34123 + 1.61591 x₁ + 0.01438 x₂` with
/// `MS_res = 10.6239` on 22 degrees of freedom.
fn delivery_time_data() -> (Vec<Vec<f64>>, Vec<f64>) {
    let runs = [
        (7.0, 560.0, 16.68),
        (3.0, 220.0, 11.50),
        (3.0, 340.0, 12.03),
        (4.0, 80.0, 14.88),
        (6.0, 150.0, 13.75),
        (7.0, 330.0, 18.11),
        (2.0, 110.0, 8.00),
        (7.0, 210.0, 17.83),
        (30.0, 1460.0, 79.24),
        (5.0, 605.0, 21.50),
        (16.0, 688.0, 40.33),
        (10.0, 215.0, 21.00),
        (4.0, 255.0, 13.50),
        (6.0, 462.0, 19.75),
        (9.0, 448.0, 24.00),
        (10.0, 776.0, 29.00),
        (6.0, 200.0, 15.35),
        (7.0, 132.0, 19.00),
        (3.0, 36.0, 9.50),
        (17.0, 770.0, 35.10),
        (10.0, 140.0, 17.90),
        (26.0, 810.0, 52.32),
        (9.0, 450.0, 18.75),
        (8.0, 635.0, 19.83),
        (4.0, 150.0, 10.75),
    ];
    (
        runs.iter().map(|r| vec![r.0, r.1]).collect(),
        runs.iter().map(|r| r.2).collect(),
    )
}

/// Montgomery, Peck & Vining (5th ed.), Example 3.9 (95 % confidence interval on the mean
/// delivery time at `x₁ = 8` cases, `x₂ = 275` ft: `ŷ₀ = 19.22`,
/// `17.66 ≤ E(y|x₀) ≤ 20.78`) and Example 3.12 (95 % prediction interval at the same
/// point: `12.28 ≤ y₀ ≤ 26.16`).
///
/// The book evaluates `x₀ᵀ(XᵀX)⁻¹x₀ = 0.05346` from a `(XᵀX)⁻¹` printed to a few digits;
/// in full precision it is 0.05397, which moves the confidence interval's ends by 0.01
/// (17.654, 20.795). The ends are therefore compared to ±0.015; the prediction interval,
/// dominated by the `1 +`, agrees to the printed two decimals.
#[test]
fn delivery_time_intervals_match_montgomery_peck_vining() {
    let (x, y) = delivery_time_data();
    let fit = Fit::new(
        Basis::complete(BasisKind::Monomial, 2, 1),
        &["cases".into(), "distance".into()],
        &x,
        &y,
    )
    .unwrap();
    for (got, want) in fit.coefficients.iter().zip([2.34123, 1.61591, 0.01438]) {
        assert!(three_digits(*got, want), "{got} vs published {want}");
    }
    let s2 = fit.quality.residual_std.unwrap().powi(2);
    assert!((s2 - 10.6239).abs() < 5e-4, "MS_res {s2}");

    let x0 = [8.0, 275.0];
    let ci = fit.confidence_interval(&x0, 0.95).unwrap();
    assert_eq!(ci.degrees_of_freedom, 22.0);
    assert!((ci.estimate - 19.22).abs() < 0.005, "{ci:?}");
    assert!((ci.low - 17.66).abs() < 0.015, "{ci:?}");
    assert!((ci.high - 20.78).abs() < 0.015, "{ci:?}");
    // The full-precision quadratic form, against the book's rounded 0.05346.
    let quadratic = (ci.std_error / fit.quality.residual_std.unwrap()).powi(2);
    assert!((quadratic - 0.05397).abs() < 5e-5, "{quadratic}");

    let pi = fit.prediction_interval(&x0, 0.95).unwrap();
    assert_eq!(pi.estimate, ci.estimate);
    assert!((pi.low - 12.28).abs() < 0.005, "{pi:?}");
    assert!((pi.high - 26.16).abs() < 0.005, "{pi:?}");
    assert!(
        (pi.std_error.powi(2) - ci.std_error.powi(2) - s2).abs() < 1e-9,
        "var(PI) = var(CI) + s²"
    );

    // Nothing to say without a point of the right size or a sensible confidence.
    assert_eq!(fit.confidence_interval(&[8.0], 0.95), None);
    assert_eq!(fit.prediction_interval(&x0, 1.0), None);
    assert_eq!(fit.prediction_interval(&[f64::NAN, 1.0], 0.95), None);
}

#[test]
fn the_unscaled_covariance_is_the_inverse_of_xtx_and_absent_when_saturated() {
    let x = ccd(2);
    let y: Vec<f64> = x
        .iter()
        .enumerate()
        .map(|(i, p)| 1.0 + p[0] - p[1] * p[1] + 0.1 * ((i * 7) % 5) as f64)
        .collect();
    let basis = Basis::complete(BasisKind::Legendre, 2, 2);
    let fit = Fit::new(basis.clone(), &names(2), &x, &y).unwrap();
    let covariance = fit.unscaled_covariance.as_ref().unwrap();
    let p = basis.len();
    let rows: Vec<Vec<f64>> = x.iter().map(|point| basis.row(point)).collect();
    // (XᵀX) · (XᵀX)⁻¹ = I.
    for i in 0..p {
        for j in 0..p {
            let product: f64 = (0..p)
                .map(|k| {
                    let xtx_ik: f64 = rows.iter().map(|r| r[i] * r[k]).sum();
                    xtx_ik * covariance[k * p + j]
                })
                .sum();
            let identity = if i == j { 1.0 } else { 0.0 };
            assert!((product - identity).abs() < 1e-9, "({i}, {j}): {product}");
        }
    }
    // At a run, the confidence interval's variance is s² h_ii.
    let s = fit.quality.residual_std.unwrap();
    for (point, h) in x.iter().zip(&fit.leverages) {
        let ci = fit.confidence_interval(point, 0.9).unwrap();
        assert!((ci.std_error - s * h.sqrt()).abs() < 1e-10);
    }
    // Six runs, six terms: no residual variance, no intervals.
    let saturated = Fit::new(
        Basis::complete(BasisKind::Monomial, 1, 5),
        &names(1),
        &[-1.0, -0.6, -0.2, 0.2, 0.6, 1.0].map(|v| vec![v]),
        &[1.0, 2.0, 0.0, 3.0, 1.0, 2.0],
    )
    .unwrap();
    assert_eq!(saturated.unscaled_covariance, None);
    assert_eq!(saturated.prediction_interval(&[0.0], 0.95), None);
}

/// Coverage by simulation: a known quadratic plus normal noise on a 3² factorial with
/// two extra centre runs; each repetition draws fresh noise, fits, and draws one new
/// observation at a fresh uniform point. Over 5000 seeded repetitions the 95 % prediction
/// interval must hold the new observation 95 % ± 2 % of the time, and the 95 % confidence
/// interval the true mean as often. (The binomial standard deviation of the rate is
/// 0.3 %, so ± 2 % is over six of them: a real miscalibration fails, luck does not.)
#[test]
fn prediction_intervals_cover_new_observations_95_percent_of_the_time() {
    use rand::{Rng, SeedableRng};
    use rand_distr::{Distribution, Normal};
    let truth = |p: &[f64]| 2.0 + 0.8 * p[0] - 1.1 * p[1] + 0.6 * p[0] * p[0] + 0.4 * p[0] * p[1];
    let mut x = Design::build(&DesignKind::FullFactorial { levels: 3 }, 2)
        .unwrap()
        .points;
    x.push(vec![0.0, 0.0]);
    x.push(vec![0.0, 0.0]);
    let basis = Basis::complete(BasisKind::Monomial, 2, 2);
    let noise = Normal::new(0.0, 0.3).unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(20_261_123);
    let repetitions = 5000;
    let (mut predicted, mut confident) = (0usize, 0usize);
    for _ in 0..repetitions {
        let y: Vec<f64> = x
            .iter()
            .map(|p| truth(p) + noise.sample(&mut rng))
            .collect();
        let fit = Fit::new(basis.clone(), &names(2), &x, &y).unwrap();
        let x0 = [rng.random_range(-1.0..=1.0), rng.random_range(-1.0..=1.0)];
        let y0 = truth(&x0) + noise.sample(&mut rng);
        let pi = fit.prediction_interval(&x0, 0.95).unwrap();
        predicted += usize::from(pi.low <= y0 && y0 <= pi.high);
        let ci = fit.confidence_interval(&x0, 0.95).unwrap();
        confident += usize::from(ci.low <= truth(&x0) && truth(&x0) <= ci.high);
    }
    let rate = |hits: usize| hits as f64 / repetitions as f64;
    assert!(
        (rate(predicted) - 0.95).abs() < 0.02,
        "PI coverage {}",
        rate(predicted)
    );
    assert!(
        (rate(confident) - 0.95).abs() < 0.02,
        "CI coverage {}",
        rate(confident)
    );
}
