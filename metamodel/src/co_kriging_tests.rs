use super::*;
use crate::design::{Design, DesignKind};
use crate::kriging::Kernel;

/// Forrester's high-fidelity function on coded `u ∈ [−1, 1]` (x = (u + 1)/2 ∈ [0, 1]).
fn forrester_high(u: f64) -> f64 {
    let x = 0.5 * (u + 1.0);
    (6.0 * x - 2.0).powi(2) * (12.0 * x - 4.0).sin()
}

/// Forrester, Sóbester & Keane (2007)'s cheap version: `0.5 f + 10(x − 0.5) − 5`.
fn forrester_low(u: f64) -> f64 {
    let x = 0.5 * (u + 1.0);
    0.5 * forrester_high(u) + 10.0 * (x - 0.5) - 5.0
}

/// Branin's base function at natural `(x1, x2)`.
fn branin_base(x1: f64, x2: f64) -> f64 {
    use std::f64::consts::PI;
    (x2 - 5.1 * x1 * x1 / (4.0 * PI * PI) + 5.0 * x1 / PI - 6.0).powi(2)
        + 10.0 * (1.0 - 1.0 / (8.0 * PI)) * x1.cos()
        + 10.0
}

/// Coded `[−1, 1]²` to Branin's box `[−5, 10] × [0, 15]`.
fn branin_natural(u: &[f64]) -> (f64, f64) {
    (2.5 + 7.5 * u[0], 7.5 + 7.5 * u[1])
}

/// Branin's first term, `x2 − 5.1 x1²/(4π²) + 5 x1/π − 6`.
fn branin_term(x1: f64, x2: f64) -> f64 {
    use std::f64::consts::PI;
    x2 - 5.1 * x1 * x1 / (4.0 * PI * PI) + 5.0 * x1 / PI - 6.0
}

/// Branin itself: the high fidelity of both pairs below.
fn branin_high(u: &[f64]) -> f64 {
    let (x1, x2) = branin_natural(u);
    branin_base(x1, x2)
}

/// Toal (2015)'s adjustable cheap Branin at `a1 = 0`:
/// `f_b − 0.5 (x2 − 5.1 x1²/(4π²) + 5 x1/π − 6)²`.
fn branin_low_toal(u: &[f64]) -> f64 {
    let (x1, x2) = branin_natural(u);
    branin_base(x1, x2) - 0.5 * branin_term(x1, x2).powi(2)
}

/// Dong, Song & Wang (2015)'s cheap Branin, `f_b(0.7 x) − 15.75 x2 + 20 (0.9 + x1)² − 50`,
/// paired with `f_b − 22.5 x2`: a cheap level that explains little of the expensive one.
fn branin_low_dong(u: &[f64]) -> f64 {
    let (x1, x2) = branin_natural(u);
    branin_base(0.7 * x1, 0.7 * x2) - 15.75 * x2 + 20.0 * (0.9 + x1).powi(2) - 50.0
}

/// The expensive half of Dong, Song & Wang (2015)'s pair.
fn branin_high_dong(u: &[f64]) -> f64 {
    let (x1, x2) = branin_natural(u);
    branin_base(x1, x2) - 22.5 * x2
}

/// Mean held-out RMSE over five designs of co-Kriging (60 cheap runs, a nested 14 of
/// them expensive: the cost of 20 expensive runs when a cheap run costs a tenth) and
/// of Kriging on 20 expensive runs alone.
fn branin_at_equal_cost(
    low: fn(&[f64]) -> f64,
    high: fn(&[f64]) -> f64,
    options: &KrigingOptions,
) -> (f64, f64) {
    let grid = square(31);
    let (mut co_total, mut single_total) = (0.0, 0.0);
    for seed in 0..5 {
        let low_x = latin(60, seed);
        let low_y: Vec<f64> = low_x.iter().map(|p| low(p)).collect();
        let high_x: Vec<Vec<f64>> = nested_subset(&low_x, 14)
            .into_iter()
            .map(|i| low_x[i].clone())
            .collect();
        let high_y: Vec<f64> = high_x.iter().map(|p| high(p)).collect();
        let model = CoKriging::fit(
            &[
                LevelRuns {
                    x: &low_x,
                    y: &low_y,
                },
                LevelRuns {
                    x: &high_x,
                    y: &high_y,
                },
            ],
            options,
        )
        .unwrap();
        let only_x = latin(20, 100 + seed);
        let only_y: Vec<f64> = only_x.iter().map(|p| high(p)).collect();
        let only = Kriging::fit(&only_x, &only_y, options).unwrap();
        co_total += rmse(|p| model.predict(p), high, &grid);
        single_total += rmse(|p| only.predict(p), high, &grid);
    }
    (co_total / 5.0, single_total / 5.0)
}

fn rmse(predict: impl Fn(&[f64]) -> f64, truth: impl Fn(&[f64]) -> f64, grid: &[Vec<f64>]) -> f64 {
    let sum: f64 = grid.iter().map(|p| (predict(p) - truth(p)).powi(2)).sum();
    (sum / grid.len() as f64).sqrt()
}

fn line(n: usize) -> Vec<Vec<f64>> {
    (0..n)
        .map(|i| vec![-1.0 + 2.0 * i as f64 / (n - 1) as f64])
        .collect()
}

fn square(n: usize) -> Vec<Vec<f64>> {
    let side = line(n);
    side.iter()
        .flat_map(|a| side.iter().map(move |b| vec![a[0], b[0]]))
        .collect()
}

fn latin(samples: usize, seed: u64) -> Vec<Vec<f64>> {
    let kind = DesignKind::LatinHypercube {
        samples,
        seed,
        candidates: 50,
    };
    Design::build(&kind, 2).unwrap().points
}

/// Forrester, Sóbester & Keane (2007)'s design: 11 cheap runs and 4 expensive ones at
/// x = 0, 0.4, 0.6, 1, fitted with the Gaussian correlation they used (under Matérn
/// 5/2 four expensive runs make a short-scale δ likelier than ρ = 2 and a linear δ).
fn forrester_pair() -> (CoKriging, KrigingOptions) {
    let low_x = line(11);
    let low_y: Vec<f64> = low_x.iter().map(|p| forrester_low(p[0])).collect();
    let high_x: Vec<Vec<f64>> = [0, 4, 6, 10].iter().map(|&i| low_x[i].clone()).collect();
    let high_y: Vec<f64> = high_x.iter().map(|p| forrester_high(p[0])).collect();
    let options = KrigingOptions {
        kernel: Kernel::SquaredExponential,
        ..KrigingOptions::default()
    };
    let runs = [
        LevelRuns {
            x: &low_x,
            y: &low_y,
        },
        LevelRuns {
            x: &high_x,
            y: &high_y,
        },
    ];
    (CoKriging::fit(&runs, &options).unwrap(), options)
}

#[test]
fn one_level_is_plain_kriging() {
    let x = line(7);
    let y: Vec<f64> = x.iter().map(|p| forrester_high(p[0])).collect();
    let options = KrigingOptions::default();
    let co = CoKriging::fit(&[LevelRuns { x: &x, y: &y }], &options).unwrap();
    let plain = Kriging::fit(&x, &y, &options).unwrap();
    for p in line(23) {
        assert_eq!(co.predict(&p), plain.predict(&p));
        assert_eq!(co.predict_variance(&p), plain.predict_variance(&p));
    }
    assert_eq!(co.scale_factor(0), None);
    assert_eq!(co.correlation(0), None);
}

#[test]
fn a_high_level_that_is_the_low_one_scaled_is_learned_exactly() {
    // y_high = 2 y_low + 3: ρ = 2, nothing left for δ, correlation 1; four high runs
    // then predict as well as eleven low ones.
    let low_x = line(11);
    let low_y: Vec<f64> = low_x.iter().map(|p| forrester_low(p[0])).collect();
    let high_x: Vec<Vec<f64>> = [0, 4, 6, 10].iter().map(|&i| low_x[i].clone()).collect();
    let high_y: Vec<f64> = high_x
        .iter()
        .map(|p| 2.0 * forrester_low(p[0]) + 3.0)
        .collect();
    let model = CoKriging::fit(
        &[
            LevelRuns {
                x: &low_x,
                y: &low_y,
            },
            LevelRuns {
                x: &high_x,
                y: &high_y,
            },
        ],
        &KrigingOptions::default(),
    )
    .unwrap();
    let rho = model.scale_factor(1).unwrap();
    assert!((rho - 2.0).abs() < 1e-3, "ρ = {rho}");
    let correlation = model.correlation(1).unwrap();
    assert!(correlation > 0.999, "correlation {correlation}");
    for (p, y) in high_x.iter().zip(&high_y) {
        assert!((model.predict(p) - y).abs() < 1e-3 * y.abs().max(1.0));
    }
    let grid = line(101);
    let error = rmse(
        |p| model.predict(p),
        |p| 2.0 * forrester_low(p[0]) + 3.0,
        &grid,
    );
    let low_only = Kriging::fit(&low_x, &low_y, &KrigingOptions::default()).unwrap();
    let low_error = rmse(|p| low_only.predict(p), |p| forrester_low(p[0]), &grid);
    assert!(error < 2.0 * low_error + 1e-3, "{error} vs 2 × {low_error}");
    // The top level's variance includes ρ² times the low level's.
    let mid = [0.1];
    assert!(model.predict_variance(&mid) >= rho * rho * model.predict_level(0, &mid).1 - 1e-12);
}

#[test]
fn forrester_at_equal_cost_beats_high_fidelity_kriging_by_30_percent() {
    // A cheap run costs a tenth, so Forrester's pair costs 5.1 expensive runs;
    // high-fidelity Kriging gets 6 (more than the same cost).
    let (model, options) = forrester_pair();
    let only_x = line(6);
    let only_y: Vec<f64> = only_x.iter().map(|p| forrester_high(p[0])).collect();
    let only = Kriging::fit(&only_x, &only_y, &options).unwrap();
    let grid = line(201);
    let truth = |p: &[f64]| forrester_high(p[0]);
    let (co, single) = (
        rmse(|p| model.predict(p), truth, &grid),
        rmse(|p| only.predict(p), truth, &grid),
    );
    assert!(
        co <= 0.7 * single,
        "co-Kriging RMSE {co} vs high-fidelity Kriging {single}"
    );
    // ρ = 2 undoes the cheap function's halving.
    let rho = model.scale_factor(1).unwrap();
    assert!((rho - 2.0).abs() < 0.1, "ρ = {rho}");
}

#[test]
fn branin_at_equal_cost_beats_high_fidelity_kriging_by_30_percent() {
    for kernel in [Kernel::Matern52, Kernel::SquaredExponential] {
        let options = KrigingOptions {
            kernel,
            ..KrigingOptions::default()
        };
        let (co, single) = branin_at_equal_cost(branin_low_toal, branin_high, &options);
        assert!(
            co <= 0.7 * single,
            "{kernel:?}: mean RMSE co-Kriging {co} vs high-fidelity Kriging {single}"
        );
    }
}

#[test]
fn a_cheap_level_that_explains_little_costs_accuracy_at_equal_cost() {
    // Dong et al.'s pair: the cheap level is dominated by a term the expensive one
    // lacks, ρ comes out near 0 and the 14 expensive runs do worse than 20 would.
    // Recorded, not hidden: this is why the proposal weighs a level by its correlation.
    let options = KrigingOptions::default();
    let (co, single) = branin_at_equal_cost(branin_low_dong, branin_high_dong, &options);
    assert!(
        co > single,
        "co-Kriging {co} vs high-fidelity Kriging {single}"
    );
}

#[test]
fn the_nested_subset_is_spread_and_starts_at_the_centre() {
    let points = square(5);
    let chosen = nested_subset(&points, 5);
    assert_eq!(chosen.len(), 5);
    assert_eq!(points[chosen[0]], vec![0.0, 0.0]);
    // Then the four corners, each as far as can be from what is chosen.
    let mut rest: Vec<Vec<f64>> = chosen[1..].iter().map(|&i| points[i].clone()).collect();
    rest.sort_by(|a, b| a.partial_cmp(b).unwrap());
    assert_eq!(
        rest,
        vec![
            vec![-1.0, -1.0],
            vec![-1.0, 1.0],
            vec![1.0, -1.0],
            vec![1.0, 1.0]
        ]
    );
    assert_eq!(nested_subset(&points, 40).len(), 25);
    assert!(nested_subset(&points, 0).is_empty());
}

#[test]
fn a_cheap_faithful_level_is_proposed_and_an_unrelated_one_is_not() {
    let low_x = line(11);
    let high_x: Vec<Vec<f64>> = [0, 2, 4, 6, 8, 10]
        .iter()
        .map(|&i| low_x[i].clone())
        .collect();
    let high_y: Vec<f64> = high_x.iter().map(|p| forrester_high(p[0])).collect();
    let options = KrigingOptions::default();
    let bounds = BoxBounds::coded(1);
    let everywhere = |_: &[f64]| 1.0;

    // The cheap level is the expensive one halved: worth running at a tenth of the cost.
    let faithful: Vec<f64> = low_x.iter().map(|p| 0.5 * forrester_high(p[0])).collect();
    let model = CoKriging::fit(
        &[
            LevelRuns {
                x: &low_x,
                y: &faithful,
            },
            LevelRuns {
                x: &high_x,
                y: &high_y,
            },
        ],
        &options,
    )
    .unwrap();
    let proposal =
        propose_fidelity(&model, &[0.1, 1.0], &bounds, Goal::Minimise, 1, &everywhere).unwrap();
    assert_eq!(proposal.level, 0, "{proposal:?}");

    // The cheap level is a sine too fast for 11 runs to resolve (noise, as far as the
    // expensive one is concerned) and costs as much: run the
    // expensive one.
    let unrelated: Vec<f64> = low_x.iter().map(|p| (37.0 * p[0] + 1.0).sin()).collect();
    let model = CoKriging::fit(
        &[
            LevelRuns {
                x: &low_x,
                y: &unrelated,
            },
            LevelRuns {
                x: &high_x,
                y: &high_y,
            },
        ],
        &options,
    )
    .unwrap();
    let correlation = model.correlation(1).unwrap();
    let proposal =
        propose_fidelity(&model, &[1.0, 1.0], &bounds, Goal::Minimise, 1, &everywhere).unwrap();
    assert_eq!(proposal.level, 1, "{proposal:?}, correlation {correlation}");
}

#[test]
fn a_batch_spreads_its_proposals_and_keeps_them_apart() {
    let (model, _) = forrester_pair();
    let low_x = line(11);
    let everywhere = |_: &[f64]| 1.0;
    let batch = propose_fidelity_batch(
        &model,
        &[0.1, 1.0],
        &BoxBounds::coded(1),
        3,
        Goal::Minimise,
        5,
        &everywhere,
    );
    assert_eq!(batch.len(), 3, "{batch:?}");
    let mut all: Vec<f64> = low_x.iter().map(|p| p[0]).collect();
    for p in &batch {
        assert!(
            all.iter()
                .all(|q| (p.point[0] - q).abs() >= 2.0 * MIN_SEPARATION),
            "{p:?} too close to {all:?}"
        );
        all.push(p.point[0]);
    }
    // Forrester's minimum is at x ≈ 0.757 (coded 0.514): the first proposal is near it.
    assert!((batch[0].point[0] - 0.514).abs() < 0.1, "{batch:?}");
}
