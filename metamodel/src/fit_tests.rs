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
    };
    let optimum = optimise(&|p| fit.predict(p), true, Goal::Maximise, &bounds, 0);
    assert!(three_digits(optimum.value, 80.21), "{optimum:?}");
    assert!(
        (optimum.x[0] - 87.0).abs() < 0.5 && (optimum.x[1] - 176.5).abs() < 0.5,
        "{optimum:?}"
    );
}
