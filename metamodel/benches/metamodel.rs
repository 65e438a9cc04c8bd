//! `cargo bench -p orch-metamodel`: prints how long the metamodel stage's two heavy
//! steps take, each beside a reference measured in the same run.
//!
//! - Fit + leave-one-out of a second-order surface in 4 factors to 51 runs (the size of
//!   the thesis's outlet-angle study), beside a plain least-squares solve of the same
//!   system through the normal equations (no QR, no hat matrix, no statistics).
//! - 10^6 Monte Carlo samples of three normal inputs through that surface, beside
//!   drawing the same samples through the identity (the cost of sampling alone).
//! - Sobol indices from 10^5 base samples of the four factors, uniform on the coded box,
//!   through that surface (6 × 10^5 evaluations and 200 bootstrap resamples), beside
//!   plain Monte Carlo of the same 6 × 10^5 evaluations, the fit above and the exact
//!   indices of the Legendre surface.
//! - The automatic model choice on the same 51 runs (pruned polynomials of order 1–3
//!   and Kriging, each scored by leave-one-out), beside the polynomial fit; and 10^6
//!   samples through the Kriging mean with its own error drawn, beside the mean alone.
//! - A Kriging model on the same 51 runs: fitted by maximum likelihood (default
//!   options) and rebuilt with given hyperparameters, beside the polynomial fit; and
//!   the same 10^6 Monte Carlo samples through its mean, beside the polynomial's.

use std::hint::black_box;
use std::time::Instant;

use nalgebra::{DMatrix, DVector};
use orch_metamodel::propagate_with_error;
use orch_metamodel::surrogate::{choose, ModelChoice};
use orch_metamodel::{
    legendre_sobol, propagate, sobol_indices, Basis, BasisKind, Design, DesignKind, Distribution,
    Fit, Kriging, KrigingOptions,
};

/// Median seconds of `runs` calls of `f`.
fn median_seconds(runs: usize, mut f: impl FnMut()) -> f64 {
    let mut times: Vec<f64> = (0..runs)
        .map(|_| {
            let start = Instant::now();
            f();
            start.elapsed().as_secs_f64()
        })
        .collect();
    times.sort_by(f64::total_cmp);
    times[runs / 2]
}

fn main() {
    let design = Design::build(
        &DesignKind::LatinHypercube {
            samples: 51,
            seed: 1,
            candidates: 20,
        },
        4,
    )
    .unwrap();
    let x = design.points;
    let y: Vec<f64> = x
        .iter()
        .map(|p| 1.0 + p[0] - 0.5 * p[1] * p[2] + 0.3 * p[3] * p[3] + 0.01 * (p[0] * 13.0).sin())
        .collect();
    let names: Vec<String> = ["h", "alpha", "f", "a"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    let basis = Basis::complete(BasisKind::Legendre, 4, 2);

    let fit_s = median_seconds(201, || {
        black_box(Fit::new(basis.clone(), &names, black_box(&x), black_box(&y)).unwrap());
    });
    let rows: Vec<f64> = x.iter().flat_map(|p| basis.row(p)).collect();
    let normal_s = median_seconds(201, || {
        let m = DMatrix::from_row_slice(x.len(), basis.len(), black_box(&rows));
        let yv = DVector::from_column_slice(black_box(&y));
        black_box(
            (m.transpose() * &m)
                .cholesky()
                .unwrap()
                .solve(&(m.transpose() * yv)),
        );
    });
    println!(
        "fit + leave-one-out, 51 runs x 15 terms: {:.1} µs; normal-equations solve alone: {:.1} µs; ratio {:.2}",
        fit_s * 1e6,
        normal_s * 1e6,
        fit_s / normal_s
    );

    let fit = Fit::new(basis, &names, &x, &y).unwrap();
    let inputs = [
        Distribution::Normal {
            mean: 0.1,
            std: 0.04,
        },
        Distribution::Normal {
            mean: -0.2,
            std: 0.05,
        },
        Distribution::Normal {
            mean: 0.3,
            std: 0.05,
        },
    ];
    let through = |s: &[f64]| fit.predict(&[0.5, s[0], s[1], s[2]]);
    let mc_s = median_seconds(5, || {
        black_box(propagate(&through, &inputs, 1_000_000, 7).unwrap());
    });
    let sampling_s = median_seconds(5, || {
        black_box(propagate(&|s| s[0], &inputs, 1_000_000, 7).unwrap());
    });
    println!(
        "Monte Carlo, 10^6 samples through the surface: {:.1} ms; sampling alone: {:.1} ms; ratio {:.2}",
        mc_s * 1e3,
        sampling_s * 1e3,
        mc_s / sampling_s
    );

    let uniform = [Distribution::Uniform {
        low: -1.0,
        high: 1.0,
    }; 4];
    let surface = |p: &[f64]| fit.predict(p);
    let base = 100_000;
    let sobol_s = median_seconds(3, || {
        black_box(sobol_indices(&surface, &uniform, base, 7).unwrap());
    });
    let evaluations = base * (uniform.len() + 2);
    let plain_s = median_seconds(3, || {
        black_box(propagate(&surface, &uniform, evaluations, 7).unwrap());
    });
    let exact_s = median_seconds(201, || {
        black_box(legendre_sobol(black_box(&fit)).unwrap());
    });
    let estimated = sobol_indices(&surface, &uniform, base, 7).unwrap();
    let (first, total) = legendre_sobol(&fit).unwrap();
    let error = estimated
        .first
        .iter()
        .zip(&first)
        .chain(estimated.total.iter().zip(&total))
        .map(|(e, exact)| (e.value - exact).abs())
        .fold(0.0, f64::max);
    println!(
        "Sobol, 10^5 base samples x 4 factors ({evaluations} evaluations, 200 bootstrap resamples): {:.1} ms; \
         Monte Carlo of as many evaluations: {:.1} ms; ratio {:.2}; ratio to the fit above {:.0}",
        sobol_s * 1e3,
        plain_s * 1e3,
        sobol_s / plain_s,
        sobol_s / fit_s
    );
    println!(
        "exact Legendre indices of the same surface: {:.2} µs (Sobol by sampling is {:.0} times slower); \
         largest |sampled - exact| index: {error:.4}",
        exact_s * 1e6,
        sobol_s / exact_s
    );

    let options = KrigingOptions::default();
    let kriging_fit_s = median_seconds(21, || {
        black_box(Kriging::fit(black_box(&x), black_box(&y), &options).unwrap());
    });
    let kriging = Kriging::fit(&x, &y, &options).unwrap();
    let given_s = median_seconds(201, || {
        black_box(kriging.refit(black_box(&x), black_box(&y)).unwrap());
    });
    println!(
        "Kriging, 51 runs x 4 factors: maximum-likelihood fit {:.2} ms (ratio to the polynomial fit {:.0}); with given hyperparameters {:.1} µs (ratio {:.1})",
        kriging_fit_s * 1e3,
        kriging_fit_s / fit_s,
        given_s * 1e6,
        given_s / fit_s
    );
    let through_kriging = |s: &[f64]| kriging.predict(&[0.5, s[0], s[1], s[2]]);
    let kriging_mc_s = median_seconds(5, || {
        black_box(propagate(&through_kriging, &inputs, 1_000_000, 7).unwrap());
    });
    println!(
        "Monte Carlo, 10^6 samples through the Kriging mean: {:.1} ms; ratio to the polynomial surface {:.2}",
        kriging_mc_s * 1e3,
        kriging_mc_s / mc_s
    );

    let choice_s = median_seconds(11, || {
        black_box(
            choose(
                ModelChoice::Auto,
                BasisKind::Legendre,
                &names,
                &[],
                black_box(&x),
                black_box(&y),
                &options,
            )
            .unwrap(),
        );
    });
    let chosen = choose(
        ModelChoice::Auto,
        BasisKind::Legendre,
        &names,
        &[],
        &x,
        &y,
        &options,
    )
    .unwrap();
    println!(
        "model choice over linear, quadratic and cubic (each pruned) and Kriging, 51 runs x 4 factors: {:.2} ms (ratio to the polynomial fit {:.0}); chose {}",
        choice_s * 1e3,
        choice_s / fit_s,
        chosen.candidates[chosen.chosen].name
    );
    let with_error = |s: &[f64]| {
        let x = [0.5, s[0], s[1], s[2]];
        (kriging.predict(&x), kriging.predict_variance(&x).sqrt())
    };
    let error_mc_s = median_seconds(3, || {
        black_box(propagate_with_error(&with_error, &inputs, 1_000_000, 7).unwrap());
    });
    println!(
        "Monte Carlo, 10^6 samples through the Kriging mean and its own error: {:.1} ms; ratio to the mean alone {:.2}",
        error_mc_s * 1e3,
        error_mc_s / kriging_mc_s
    );
}
