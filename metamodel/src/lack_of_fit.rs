//! The lack-of-fit F test from replicated runs.
//!
//! When some runs repeat the same coded point, the residual sum of squares of a fit splits
//! into *pure error*, the scatter of the replicates about their own means, which no model
//! can remove, and *lack of fit*, the rest, which a better model could:
//!
//! - `SS_PE = Σ_points Σ_replicates (y − ȳ_point)²` on `n − m` degrees of freedom,
//!   with `m` distinct points among `n` runs;
//! - `SS_LOF = SS_res − SS_PE` on `m − p` degrees of freedom, `p` the model's terms;
//! - `F = (SS_LOF / (m − p)) / (SS_PE / (n − m))`, compared with `F(m − p, n − m)`.
//!
//! A small p-value says the surface misses the replicates' means by more than their
//! scatter explains: add terms or a transformation. (Montgomery & Runger, *Applied
//! Statistics and Probability for Engineers*, 3rd ed., Wiley 2003, supplement S11-1;
//! Montgomery, Peck & Vining, *Introduction to Linear Regression Analysis*, 5th ed.,
//! §4.5.)
//!
//! Runs are replicates when every coded coordinate is equal (`==`, so `-0.0` equals `0.0`),
//! as the design points of [`crate::design`] repeated by centre runs or replicates are.
//! A deterministic simulation repeats itself exactly, which leaves no pure error: the test
//! then has no scale and is not made.

use crate::fit::Fit;
use crate::student::f_survival;

/// The lack-of-fit test's sums of squares, degrees of freedom and verdict.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LackOfFit {
    /// Pure-error sum of squares: replicates about their point's mean, in squared response
    /// units.
    pub ss_pure_error: f64,
    /// Pure-error degrees of freedom, runs minus distinct points.
    pub dof_pure_error: usize,
    /// Lack-of-fit sum of squares, residual minus pure error, in squared response units.
    pub ss_lack_of_fit: f64,
    /// Lack-of-fit degrees of freedom, distinct points minus terms.
    pub dof_lack_of_fit: usize,
    /// The statistic `(SS_LOF / dof_LOF) / (SS_PE / dof_PE)`.
    pub f: f64,
    /// `P(F > f)` under `F(dof_LOF, dof_PE)`: small means the model's form is wrong.
    pub p_value: f64,
}

/// The lack-of-fit test of `fit` on the runs it was fitted to (coded `x`, responses `y`;
/// any order). `None` when there are no replicates (no pure-error degrees of freedom),
/// when the distinct points are no more than the terms (no lack-of-fit degrees of
/// freedom: the model passes through every point's mean), when the replicates agree
/// exactly (zero pure error, as a deterministic solver gives: add noise-bearing
/// replicates or judge the fit by `σ_cross` instead), or when `x`, `y` and the fit's runs
/// differ in number.
pub fn lack_of_fit(fit: &Fit, x: &[Vec<f64>], y: &[f64]) -> Option<LackOfFit> {
    let n = y.len();
    if x.len() != n || fit.quality.runs != n {
        return None;
    }
    let groups = replicate_groups(x);
    let distinct = groups.len();
    let dof_pure_error = n - distinct;
    let dof_lack_of_fit = distinct.checked_sub(fit.quality.terms)?;
    if dof_pure_error == 0 || dof_lack_of_fit == 0 {
        return None;
    }
    let ss_pure_error: f64 = groups
        .iter()
        .map(|group| {
            let mean = group.iter().map(|&i| y[i]).sum::<f64>() / group.len() as f64;
            group.iter().map(|&i| (y[i] - mean).powi(2)).sum::<f64>()
        })
        .sum();
    if ss_pure_error <= 0.0 {
        return None;
    }
    let ss_residual: f64 = x
        .iter()
        .zip(y)
        .map(|(point, value)| (value - fit.predict(point)).powi(2))
        .sum();
    // Rounding can leave a hair below zero when the model fits every point's mean.
    let ss_lack_of_fit = (ss_residual - ss_pure_error).max(0.0);
    let f = (ss_lack_of_fit / dof_lack_of_fit as f64) / (ss_pure_error / dof_pure_error as f64);
    Some(LackOfFit {
        ss_pure_error,
        dof_pure_error,
        ss_lack_of_fit,
        dof_lack_of_fit,
        f,
        p_value: f_survival(f, dof_lack_of_fit as f64, dof_pure_error as f64),
    })
}

/// Indices of the runs grouped by identical point, by sorting rather than comparing every
/// pair.
fn replicate_groups(x: &[Vec<f64>]) -> Vec<Vec<usize>> {
    // Adding 0.0 turns -0.0 into 0.0, so the total order agrees with `==` on zeros.
    let key = |i: usize| x[i].iter().map(|v| v + 0.0).collect::<Vec<f64>>();
    let mut order: Vec<usize> = (0..x.len()).collect();
    order.sort_by(|&a, &b| {
        let (ka, kb) = (key(a), key(b));
        ka.iter()
            .zip(&kb)
            .map(|(u, v)| u.total_cmp(v))
            .find(|o| o.is_ne())
            .unwrap_or(ka.len().cmp(&kb.len()))
    });
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for i in order {
        match groups.last_mut() {
            Some(group) if x[group[0]] == x[i] => group.push(i),
            _ => groups.push(vec![i]),
        }
    }
    groups
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::basis::{Basis, BasisKind};
    use crate::design::{Design, DesignKind};

    /// Montgomery & Runger, *Applied Statistics and Probability for Engineers*, 3rd ed.,
    /// Wiley 2003, Example S11-1 (supplement to chapter 11): 16 runs at nine levels of x,
    /// a straight line `ŷ = 1.697 + 0.259 x` with `SS_R = 3.4930`. Table S11-1 gives
    /// residual 7.3372 (14 df) = lack of fit 4.3005 (7 df, MS 0.6144) + pure error
    /// 3.0366 (7 df, MS 0.4338), `f₀ = 1.42`, `P = 0.3276`. (Data and table as
    /// reproduced from the supplement's page 11-3.)
    #[test]
    fn montgomery_runger_example_s11_1_is_reproduced() {
        let levels: [(f64, &[f64]); 9] = [
            (1.0, &[2.3, 1.8]),
            (2.0, &[2.8]),
            (3.3, &[1.8, 3.7]),
            (4.0, &[2.6, 2.6, 2.2]),
            (5.0, &[2.0]),
            (5.6, &[3.5, 2.8, 2.1]),
            (6.0, &[3.4, 3.2]),
            (6.5, &[3.4]),
            (6.9, &[5.0]),
        ];
        let mut x = Vec::new();
        let mut y = Vec::new();
        for (level, responses) in levels {
            for &response in responses {
                x.push(vec![level]);
                y.push(response);
            }
        }
        let fit = Fit::new(
            Basis::complete(BasisKind::Monomial, 1, 1),
            &["x".into()],
            &x,
            &y,
        )
        .unwrap();
        assert!((fit.coefficients[0] - 1.697).abs() < 5e-4, "{fit:?}");
        assert!((fit.coefficients[1] - 0.259).abs() < 5e-4, "{fit:?}");
        let lof = lack_of_fit(&fit, &x, &y).unwrap();
        assert_eq!((lof.dof_lack_of_fit, lof.dof_pure_error), (7, 7));
        assert!((lof.ss_pure_error - 3.0366).abs() < 5e-4, "{lof:?}");
        assert!((lof.ss_lack_of_fit - 4.3005).abs() < 5e-4, "{lof:?}");
        assert!((lof.f - 1.42).abs() < 5e-3, "{lof:?}");
        // The book's P is that of its rounded f₀ = 1.42; the unrounded 1.4162 gives
        // 0.3288.
        assert!((f_survival(1.42, 7.0, 7.0) - 0.3276).abs() < 5e-5);
        assert!((lof.p_value - 0.3288).abs() < 5e-5, "{lof:?}");
        // The order of the runs does not matter.
        let (mut xr, mut yr) = (x.clone(), y.clone());
        xr.reverse();
        yr.reverse();
        assert_eq!(lack_of_fit(&fit, &xr, &yr), Some(lof));
    }

    #[test]
    fn a_wrong_model_is_rejected_and_a_right_one_is_not() {
        // A 3² factorial run twice; the truth is quadratic in a, with a fixed
        // "noise" pattern between the two replicates.
        let design = Design::build(&DesignKind::FullFactorial { levels: 3 }, 2)
            .unwrap()
            .points;
        let mut x = design.clone();
        x.extend(design.iter().cloned());
        let y: Vec<f64> = x
            .iter()
            .enumerate()
            .map(|(i, p)| {
                1.0 + p[0] + 2.0 * p[0] * p[0] - 0.5 * p[1] + 0.05 * ((i * 5 % 7) as f64 - 3.0)
            })
            .collect();
        let names = ["a".to_string(), "b".to_string()];
        let line = Fit::new(Basis::complete(BasisKind::Monomial, 2, 1), &names, &x, &y).unwrap();
        let lof = lack_of_fit(&line, &x, &y).unwrap();
        assert_eq!((lof.dof_lack_of_fit, lof.dof_pure_error), (6, 9));
        assert!(lof.p_value < 1e-6, "{lof:?}");
        let quadratic =
            Fit::new(Basis::complete(BasisKind::Monomial, 2, 2), &names, &x, &y).unwrap();
        let lof = lack_of_fit(&quadratic, &x, &y).unwrap();
        assert_eq!((lof.dof_lack_of_fit, lof.dof_pure_error), (3, 9));
        assert!(lof.p_value > 0.05, "{lof:?}");
        // Residual = lack of fit + pure error.
        let ss_res: f64 = quadratic.residuals.iter().map(|e| e * e).sum();
        assert!((lof.ss_lack_of_fit + lof.ss_pure_error - ss_res).abs() < 1e-10);
    }

    #[test]
    fn no_test_without_replicates_lack_of_fit_freedom_or_pure_error() {
        let names = ["a".to_string()];
        let basis = Basis::complete(BasisKind::Monomial, 1, 1);
        // No replicates.
        let x: Vec<Vec<f64>> = [-1.0, -0.5, 0.0, 0.5, 1.0].map(|v| vec![v]).to_vec();
        let y = [1.0, 1.4, 2.2, 2.4, 3.1];
        let fit = Fit::new(basis.clone(), &names, &x, &y).unwrap();
        assert_eq!(lack_of_fit(&fit, &x, &y), None);
        // Two distinct points for two terms: the line passes through both means.
        let x: Vec<Vec<f64>> = [-1.0, -1.0, 1.0, 1.0].map(|v| vec![v]).to_vec();
        let y = [1.0, 1.2, 3.0, 3.3];
        let fit = Fit::new(basis.clone(), &names, &x, &y).unwrap();
        assert_eq!(lack_of_fit(&fit, &x, &y), None);
        // Exact replicates, as from a deterministic solver: no pure error.
        let x: Vec<Vec<f64>> = [-1.0, -1.0, 0.0, 1.0, 1.0].map(|v| vec![v]).to_vec();
        let y = [1.0, 1.0, 2.5, 3.0, 3.0];
        let fit = Fit::new(basis.clone(), &names, &x, &y).unwrap();
        assert_eq!(lack_of_fit(&fit, &x, &y), None);
        // Signed zeros are one point.
        let x: Vec<Vec<f64>> = [-0.0, 0.0, 1.0, 2.0].map(|v| vec![v]).to_vec();
        let y = [1.0, 1.1, 2.9, 5.2];
        let fit = Fit::new(basis, &names, &x, &y).unwrap();
        let lof = lack_of_fit(&fit, &x, &y).unwrap();
        assert_eq!((lof.dof_lack_of_fit, lof.dof_pure_error), (1, 1));
        // Data that are not the fit's runs.
        assert_eq!(lack_of_fit(&fit, &x[..3], &y[..3]), None);
    }
}
