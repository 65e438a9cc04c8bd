//! Designs of experiments in coded units.
//!
//! Every design returns points whose coordinates lie in `[-1, 1]`. For a central
//! composite design with an axial distance `α > 1`, the axial ("star") points sit on the
//! faces of the box at `±1` and the factorial points shrink to `±1/α` (the *inscribed*
//! form), so that no run leaves the range the user gave.
//!
//! Box-Behnken designs are those of Box & Behnken, "Some new three level designs for the
//! study of quantitative variables", *Technometrics* 2(4), 455–475 (1960). Each combines
//! a balanced (or partially balanced) incomplete block design with two-level factorials:
//! in every block the block's factors take all their `±1` combinations while the others
//! stay at 0, so every run lies at the midpoint of an edge (or a higher face) of the cube.
//! For 3 to 5 factors the blocks are every pair of factors (12, 24 and 40 edge runs). For 6
//! and 7 factors the blocks have three factors each, from the paper's tables as Lenth's R
//! package `rsm` (function `bbd`) tabulates them, with 48 and 56 edge runs as the
//! `DoE.wrapper` documentation lists:
//!
//! - 6 factors, 6 blocks: (1,2,4) (2,3,5) (3,4,6) (1,4,5) (2,5,6) (1,3,6);
//! - 7 factors, 7 blocks: (4,5,6) (1,6,7) (2,5,7) (1,2,4) (3,4,7) (1,3,5) (2,3,6), the
//!   balanced design in which every pair of factors shares exactly one block.
//!
//! Larger designs (9 to 12 and 16 factors) use blocks of four or more factors with
//! fractional factorials and are not implemented.

use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// How the axial distance `α` of a central composite design is chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CentralCompositeAlpha {
    /// Axial and factorial columns are orthogonal: `α = sqrt((sqrt(F·N) − F) / 2)`,
    /// with `F = 2^k` factorial runs and `N` runs in all.
    Orthogonal,
    /// Prediction variance depends only on the distance from the centre: `α = F^(1/4)`.
    Rotatable,
    /// Axial points on the faces of the factorial cube: `α = 1`.
    FaceCentred,
}

/// The kind of design and its parameters, independent of the number of factors.
#[derive(Debug, Clone, PartialEq)]
pub enum DesignKind {
    /// Every combination of `levels` equally spaced levels per factor.
    FullFactorial {
        /// Levels per factor, at least 2.
        levels: usize,
    },
    /// Two-level factorial, `2k` axial points and `center_points` centre runs.
    CentralComposite {
        /// How `α` is chosen.
        alpha: CentralCompositeAlpha,
        /// Number of runs at the centre, at least 1 for a second-order fit.
        center_points: usize,
    },
    /// Box-Behnken (3 to 7 factors): blocks of two (3 to 5 factors) or three (6 and 7
    /// factors) factors at all `±1` combinations with the others at 0, plus centre runs.
    BoxBehnken {
        /// Number of runs at the centre.
        center_points: usize,
    },
    /// Latin hypercube with the maximin criterion over `candidates` random hypercubes.
    LatinHypercube {
        /// Number of runs.
        samples: usize,
        /// Seed of the random generator; the same seed gives the same design.
        seed: u64,
        /// Random hypercubes drawn; the one with the largest minimum distance wins.
        candidates: usize,
    },
}

/// Why a design cannot be built.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum DesignError {
    /// The design needs more factors than were given.
    #[error("a {design} design needs at least {min} factors, the study has {given}")]
    TooFewFactors {
        /// The design's name.
        design: &'static str,
        /// Fewest factors it can take.
        min: usize,
        /// Factors given.
        given: usize,
    },
    /// A full factorial needs at least two levels.
    #[error("a full factorial design needs at least 2 levels per factor, got {0}")]
    TooFewLevels(usize),
    /// A Latin hypercube needs at least two samples.
    #[error("a Latin hypercube needs at least 2 samples, got {0}")]
    TooFewSamples(usize),
    /// No published Box-Behnken design is implemented for this many factors.
    #[error("no Box-Behnken design is implemented for {factors} factors (only for 3 to 7, from Box & Behnken's published tables); use central_composite or latin_hypercube")]
    BoxBehnkenUnavailable {
        /// Factors given.
        factors: usize,
    },
    /// The design would have more runs than anyone should launch by accident.
    #[error("the design would have {runs} runs, more than the limit of {limit}; expected fewer levels, samples or centre points")]
    TooManyRuns {
        /// Runs the design would have.
        runs: usize,
        /// The limit.
        limit: usize,
    },
}

/// Most runs a design may have; a guard against `levels: 10` over 8 factors.
pub const MAX_RUNS: usize = 100_000;

/// A design of experiments: one row per run, one column per factor, coded units.
#[derive(Debug, Clone, PartialEq)]
pub struct Design {
    /// Coded coordinates of every run, each in `[-1, 1]`.
    pub points: Vec<Vec<f64>>,
}

impl Design {
    /// Builds the design of `kind` over `n_factors` factors. Its number of runs is
    /// checked against [`MAX_RUNS`] (see [`run_count`]) before anything is allocated.
    pub fn build(kind: &DesignKind, n_factors: usize) -> Result<Design, DesignError> {
        run_count(kind, n_factors)?;
        let points = match *kind {
            DesignKind::FullFactorial { levels } => full_factorial(n_factors, levels)?,
            DesignKind::CentralComposite {
                alpha,
                center_points,
            } => central_composite(n_factors, alpha, center_points)?,
            DesignKind::BoxBehnken { center_points } => box_behnken(n_factors, center_points)?,
            DesignKind::LatinHypercube {
                samples,
                seed,
                candidates,
            } => latin_hypercube(n_factors, samples, seed, candidates.max(1))?,
        };
        Ok(Design { points })
    }

    /// Number of runs.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// True when the design has no runs.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }
}

/// Number of runs a design of `kind` over `n_factors` factors has, computed without
/// building it and without overflow; more than [`MAX_RUNS`] is refused.
pub fn run_count(kind: &DesignKind, n_factors: usize) -> Result<usize, DesignError> {
    let k = n_factors as u128;
    let runs: u128 = match *kind {
        DesignKind::FullFactorial { levels } => u32::try_from(n_factors)
            .ok()
            .and_then(|k| (levels as u128).checked_pow(k))
            .unwrap_or(u128::MAX),
        DesignKind::CentralComposite { center_points, .. } => u32::try_from(n_factors)
            .ok()
            .and_then(|k| 2u128.checked_pow(k))
            .unwrap_or(u128::MAX)
            .saturating_add(2 * k)
            .saturating_add(center_points as u128),
        DesignKind::BoxBehnken { center_points } => {
            let edge_runs = match box_behnken_blocks(n_factors) {
                Some(blocks) => blocks.len() as u128 * (1u128 << blocks[0].len()),
                None if n_factors < 3 => 2 * k * k.saturating_sub(1),
                None => return Err(DesignError::BoxBehnkenUnavailable { factors: n_factors }),
            };
            edge_runs.saturating_add(center_points as u128)
        }
        DesignKind::LatinHypercube { samples, .. } => samples as u128,
    };
    if runs > MAX_RUNS as u128 {
        return Err(DesignError::TooManyRuns {
            runs: runs.min(usize::MAX as u128) as usize,
            limit: MAX_RUNS,
        });
    }
    Ok(runs as usize)
}

fn require_factors(design: &'static str, min: usize, given: usize) -> Result<(), DesignError> {
    if given < min {
        return Err(DesignError::TooFewFactors { design, min, given });
    }
    Ok(())
}

fn full_factorial(n_factors: usize, levels: usize) -> Result<Vec<Vec<f64>>, DesignError> {
    require_factors("full factorial", 1, n_factors)?;
    if levels < 2 {
        return Err(DesignError::TooFewLevels(levels));
    }
    let runs = (levels as u128)
        .checked_pow(n_factors as u32)
        .unwrap_or(u128::MAX);
    if runs > MAX_RUNS as u128 {
        return Err(DesignError::TooManyRuns {
            runs: runs.min(usize::MAX as u128) as usize,
            limit: MAX_RUNS,
        });
    }
    let level_value = |i: usize| -1.0 + 2.0 * i as f64 / (levels - 1) as f64;
    let mut points = Vec::with_capacity(runs as usize);
    for run in 0..runs as usize {
        // The first factor varies slowest, as in the usual standard order tables.
        let mut rest = run;
        let mut point = vec![0.0; n_factors];
        for factor in (0..n_factors).rev() {
            point[factor] = level_value(rest % levels);
            rest /= levels;
        }
        points.push(point);
    }
    Ok(points)
}

/// Axial distance `α` of a central composite design over `n_factors` factors.
pub fn central_composite_alpha(
    alpha: CentralCompositeAlpha,
    n_factors: usize,
    center_points: usize,
) -> f64 {
    let factorial_runs = 2f64.powi(n_factors as i32);
    match alpha {
        CentralCompositeAlpha::FaceCentred => 1.0,
        CentralCompositeAlpha::Rotatable => factorial_runs.powf(0.25),
        CentralCompositeAlpha::Orthogonal => {
            let total_runs = factorial_runs + 2.0 * n_factors as f64 + center_points as f64;
            (0.5 * ((factorial_runs * total_runs).sqrt() - factorial_runs).max(0.0)).sqrt()
        }
    }
}

fn central_composite(
    n_factors: usize,
    alpha: CentralCompositeAlpha,
    center_points: usize,
) -> Result<Vec<Vec<f64>>, DesignError> {
    require_factors("central composite", 2, n_factors)?;
    let axial = central_composite_alpha(alpha, n_factors, center_points);
    // Inscribed form: the larger of the factorial level and α maps to 1.
    let scale = axial.max(1.0);
    let factorial_level = 1.0 / scale;
    let axial_level = axial / scale;

    let mut points = full_factorial(n_factors, 2)?;
    for point in &mut points {
        for x in point.iter_mut() {
            *x *= factorial_level;
        }
    }
    for factor in 0..n_factors {
        for sign in [-1.0, 1.0] {
            let mut point = vec![0.0; n_factors];
            point[factor] = sign * axial_level;
            points.push(point);
        }
    }
    points.extend((0..center_points).map(|_| vec![0.0; n_factors]));
    Ok(points)
}

/// Blocks of the six-factor design, factors numbered from 1 as in the published table.
const BOX_BEHNKEN_6: [[usize; 3]; 6] = [
    [1, 2, 4],
    [2, 3, 5],
    [3, 4, 6],
    [1, 4, 5],
    [2, 5, 6],
    [1, 3, 6],
];

/// Blocks of the seven-factor design, factors numbered from 1 as in the published table.
const BOX_BEHNKEN_7: [[usize; 3]; 7] = [
    [4, 5, 6],
    [1, 6, 7],
    [2, 5, 7],
    [1, 2, 4],
    [3, 4, 7],
    [1, 3, 5],
    [2, 3, 6],
];

/// The blocks of the Box-Behnken design over `n_factors`, factors numbered from 0; `None`
/// when none is implemented (fewer than 3 or more than 7 factors).
fn box_behnken_blocks(n_factors: usize) -> Option<Vec<Vec<usize>>> {
    let from_table = |table: &[[usize; 3]]| {
        table
            .iter()
            .map(|block| block.iter().map(|f| f - 1).collect())
            .collect()
    };
    match n_factors {
        3..=5 => Some(
            (0..n_factors)
                .flat_map(|i| (i + 1..n_factors).map(move |j| vec![i, j]))
                .collect(),
        ),
        6 => Some(from_table(&BOX_BEHNKEN_6)),
        7 => Some(from_table(&BOX_BEHNKEN_7)),
        _ => None,
    }
}

fn box_behnken(n_factors: usize, center_points: usize) -> Result<Vec<Vec<f64>>, DesignError> {
    require_factors("Box-Behnken", 3, n_factors)?;
    let blocks = box_behnken_blocks(n_factors)
        .ok_or(DesignError::BoxBehnkenUnavailable { factors: n_factors })?;
    let mut points = Vec::new();
    for block in &blocks {
        // All ±1 combinations of the block's factors, the first factor varying slowest.
        for combination in 0..1usize << block.len() {
            let mut point = vec![0.0; n_factors];
            for (position, &factor) in block.iter().enumerate() {
                let bit = (combination >> (block.len() - 1 - position)) & 1;
                point[factor] = if bit == 1 { 1.0 } else { -1.0 };
            }
            points.push(point);
        }
    }
    points.extend((0..center_points).map(|_| vec![0.0; n_factors]));
    Ok(points)
}

fn latin_hypercube(
    n_factors: usize,
    samples: usize,
    seed: u64,
    candidates: usize,
) -> Result<Vec<Vec<f64>>, DesignError> {
    require_factors("Latin hypercube", 1, n_factors)?;
    if samples < 2 {
        return Err(DesignError::TooFewSamples(samples));
    }
    if samples > MAX_RUNS {
        return Err(DesignError::TooManyRuns {
            runs: samples,
            limit: MAX_RUNS,
        });
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut best: Option<(f64, Vec<Vec<f64>>)> = None;
    for _ in 0..candidates {
        let candidate = random_hypercube(&mut rng, n_factors, samples);
        let spread = min_pairwise_distance_squared(&candidate);
        if best
            .as_ref()
            .is_none_or(|(best_spread, _)| spread > *best_spread)
        {
            best = Some((spread, candidate));
        }
    }
    Ok(best.map(|(_, points)| points).unwrap_or_default())
}

/// One random Latin hypercube: each factor's `samples` strata are each hit once.
fn random_hypercube(rng: &mut ChaCha8Rng, n_factors: usize, samples: usize) -> Vec<Vec<f64>> {
    let mut points = vec![vec![0.0; n_factors]; samples];
    let mut strata: Vec<usize> = (0..samples).collect();
    for factor in 0..n_factors {
        strata.shuffle(rng);
        for (point, &stratum) in points.iter_mut().zip(&strata) {
            let unit = (stratum as f64 + rng.random::<f64>()) / samples as f64;
            point[factor] = 2.0 * unit - 1.0;
        }
    }
    points
}

fn min_pairwise_distance_squared(points: &[Vec<f64>]) -> f64 {
    let mut min = f64::INFINITY;
    for (i, a) in points.iter().enumerate() {
        for b in &points[i + 1..] {
            let d: f64 = a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum();
            min = min.min(d);
        }
    }
    min
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn ccd(alpha: CentralCompositeAlpha, k: usize, centre: usize) -> Design {
        Design::build(
            &DesignKind::CentralComposite {
                alpha,
                center_points: centre,
            },
            k,
        )
        .unwrap()
    }

    #[test]
    fn central_composite_run_counts_match_the_thesis() {
        // SCIENCE.md §6: 3 factors, one centre point → 15 runs; 2 factors → 9 runs.
        assert_eq!(ccd(CentralCompositeAlpha::Orthogonal, 3, 1).len(), 15);
        assert_eq!(ccd(CentralCompositeAlpha::Orthogonal, 2, 1).len(), 9);
        // 4 factors: 16 + 8 + 1 = 25.
        assert_eq!(ccd(CentralCompositeAlpha::Rotatable, 4, 1).len(), 25);
    }

    #[test]
    fn alpha_values_match_tables() {
        // Orthogonal α for k = 2, n0 = 1 is 1; for k = 3, n0 = 1 it is 1.2154.
        let a2 = central_composite_alpha(CentralCompositeAlpha::Orthogonal, 2, 1);
        let a3 = central_composite_alpha(CentralCompositeAlpha::Orthogonal, 3, 1);
        assert!((a2 - 1.0).abs() < 1e-12, "{a2}");
        assert!((a3 - 1.2154).abs() < 1e-4, "{a3}");
        let rot = central_composite_alpha(CentralCompositeAlpha::Rotatable, 3, 1);
        assert!((rot - 8f64.powf(0.25)).abs() < 1e-12);
    }

    #[test]
    fn orthogonal_ccd_has_orthogonal_quadratic_columns() {
        // The defining property: centred square columns are orthogonal to each other.
        let design = ccd(CentralCompositeAlpha::Orthogonal, 3, 1);
        let n = design.len() as f64;
        let column = |j: usize| -> Vec<f64> {
            let sq: Vec<f64> = design.points.iter().map(|p| p[j] * p[j]).collect();
            let mean = sq.iter().sum::<f64>() / n;
            sq.iter().map(|v| v - mean).collect()
        };
        let (c0, c1) = (column(0), column(1));
        let dot: f64 = c0.iter().zip(&c1).map(|(a, b)| a * b).sum();
        assert!(dot.abs() < 1e-12, "{dot}");
    }

    #[test]
    fn inscribed_ccd_stays_in_the_box_with_axial_points_on_faces() {
        let design = ccd(CentralCompositeAlpha::Rotatable, 2, 1);
        let max = design
            .points
            .iter()
            .flatten()
            .fold(0.0f64, |m, v| m.max(v.abs()));
        assert!((max - 1.0).abs() < 1e-12);
        // Factorial corners at 1/α = 2^(-1/2).
        assert!((design.points[0][0].abs() - 0.5f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn face_centred_ccd_for_two_factors_is_the_three_level_factorial_set() {
        let mut design = ccd(CentralCompositeAlpha::FaceCentred, 2, 1).points;
        let mut grid = Design::build(&DesignKind::FullFactorial { levels: 3 }, 2)
            .unwrap()
            .points;
        let key = |p: &Vec<f64>| (p[0] * 10.0) as i64 * 100 + (p[1] * 10.0) as i64;
        design.sort_by_key(key);
        grid.sort_by_key(key);
        assert_eq!(design, grid);
    }

    #[test]
    fn box_behnken_run_counts() {
        let bb = |k, c| {
            Design::build(&DesignKind::BoxBehnken { center_points: c }, k)
                .unwrap()
                .len()
        };
        assert_eq!(bb(3, 3), 15);
        assert_eq!(bb(4, 3), 27);
        assert_eq!(
            Design::build(&DesignKind::BoxBehnken { center_points: 1 }, 2),
            Err(DesignError::TooFewFactors {
                design: "Box-Behnken",
                min: 3,
                given: 2
            })
        );
    }

    fn bb(k: usize, centre: usize) -> Design {
        Design::build(
            &DesignKind::BoxBehnken {
                center_points: centre,
            },
            k,
        )
        .unwrap()
    }

    #[test]
    fn box_behnken_for_three_factors_is_the_published_edge_midpoints_in_order() {
        // The 12 edge midpoints in three blocks of pairs (x1,x2), (x1,x3), (x2,x3), in the
        // order MathWorks' documentation of `bbdesign(3)` prints them (unchanged here).
        let expected = [
            [-1.0, -1.0, 0.0],
            [-1.0, 1.0, 0.0],
            [1.0, -1.0, 0.0],
            [1.0, 1.0, 0.0],
            [-1.0, 0.0, -1.0],
            [-1.0, 0.0, 1.0],
            [1.0, 0.0, -1.0],
            [1.0, 0.0, 1.0],
            [0.0, -1.0, -1.0],
            [0.0, -1.0, 1.0],
            [0.0, 1.0, -1.0],
            [0.0, 1.0, 1.0],
            [0.0, 0.0, 0.0],
        ];
        assert_eq!(bb(3, 1).points, expected.map(|p| p.to_vec()));
    }

    #[test]
    fn box_behnken_six_and_seven_factors_have_the_published_run_counts() {
        // 48 and 56 edge runs (Box & Behnken 1960; DoE.wrapper's bbd.design lists them).
        for centre in [0, 1, 6] {
            assert_eq!(bb(6, centre).len(), 48 + centre);
            assert_eq!(bb(7, centre).len(), 56 + centre);
        }
        // Every pair for 5 factors: 10 pairs × 4.
        assert_eq!(bb(5, 0).len(), 40);
    }

    #[test]
    fn box_behnken_edge_runs_have_one_block_of_factors_at_plus_or_minus_one() {
        for (k, in_block) in [(3, 2), (4, 2), (5, 2), (6, 3), (7, 3)] {
            let design = bb(k, 2);
            let edges = &design.points[..design.len() - 2];
            for point in edges {
                let nonzero: Vec<f64> = point.iter().copied().filter(|v| *v != 0.0).collect();
                assert_eq!(nonzero.len(), in_block, "{k} factors: {point:?}");
                assert!(nonzero.iter().all(|v| v.abs() == 1.0), "{point:?}");
            }
            let mut distinct = edges.to_vec();
            distinct.sort_by(|a, b| a.partial_cmp(b).unwrap());
            distinct.dedup();
            assert_eq!(distinct.len(), edges.len(), "{k} factors: a run repeats");
            assert!(design.points[design.len() - 2..]
                .iter()
                .all(|p| p.iter().all(|v| *v == 0.0)));
        }
    }

    #[test]
    fn box_behnken_blocks_are_balanced() {
        // Each factor lies in the same number of blocks: 3 for both tables. Every pair of
        // factors shares a block (so every interaction is estimable): exactly once for
        // seven factors (a balanced incomplete block design); for six, the pairs (1,4),
        // (2,5), (3,6) share two blocks and the other twelve one.
        for (k, table) in [(6, &BOX_BEHNKEN_6[..]), (7, &BOX_BEHNKEN_7[..])] {
            for factor in 1..=k {
                let blocks = table.iter().filter(|b| b.contains(&factor)).count();
                assert_eq!(blocks, 3, "{k} factors: factor {factor}");
            }
            for i in 1..=k {
                for j in i + 1..=k {
                    let shared = table
                        .iter()
                        .filter(|b| b.contains(&i) && b.contains(&j))
                        .count();
                    let twice = k == 6 && j == i + 3;
                    assert_eq!(shared, if twice { 2 } else { 1 }, "{k} factors: ({i}, {j})");
                }
            }
        }
    }

    #[test]
    fn box_behnken_six_and_seven_factors_estimate_a_full_quadratic() {
        use crate::basis::{Basis, BasisKind};
        use crate::fit::Fit;
        for k in [6, 7] {
            let design = bb(k, 3);
            let names: Vec<String> = (0..k).map(|i| format!("x{i}")).collect();
            // An arbitrary non-polynomial response: only the rank matters here.
            let y: Vec<f64> = design
                .points
                .iter()
                .map(|p| {
                    p.iter()
                        .enumerate()
                        .map(|(i, v)| (v * (i + 1) as f64).sin())
                        .sum()
                })
                .collect();
            let basis = Basis::complete(BasisKind::Monomial, k, 2);
            let terms = basis.len();
            let fit = Fit::new(basis, &names, &design.points, &y)
                .unwrap_or_else(|e| panic!("{k} factors: {e}"));
            assert_eq!(fit.coefficients.len(), terms);
            assert_eq!(fit.quality.terms, (k + 1) * (k + 2) / 2);
        }
    }

    #[test]
    fn box_behnken_beyond_seven_factors_is_refused_with_a_way_out() {
        for k in [8, 9, 12] {
            let kind = DesignKind::BoxBehnken { center_points: 3 };
            let error = DesignError::BoxBehnkenUnavailable { factors: k };
            assert_eq!(Design::build(&kind, k), Err(error.clone()));
            assert_eq!(run_count(&kind, k), Err(error.clone()));
            assert!(error
                .to_string()
                .ends_with("use central_composite or latin_hypercube"));
        }
    }

    #[test]
    fn run_count_agrees_with_the_built_design() {
        for k in 1..=7 {
            for centre in [0, 1, 4] {
                let kinds = [
                    DesignKind::FullFactorial { levels: 3 },
                    DesignKind::CentralComposite {
                        alpha: CentralCompositeAlpha::Rotatable,
                        center_points: centre,
                    },
                    DesignKind::BoxBehnken {
                        center_points: centre,
                    },
                    DesignKind::LatinHypercube {
                        samples: 5 + centre,
                        seed: 1,
                        candidates: 2,
                    },
                ];
                for kind in kinds {
                    if let Ok(design) = Design::build(&kind, k) {
                        assert_eq!(run_count(&kind, k), Ok(design.len()), "{kind:?}, {k}");
                    }
                }
            }
        }
    }

    #[test]
    fn full_factorial_enumerates_every_combination_once() {
        let design = Design::build(&DesignKind::FullFactorial { levels: 3 }, 3).unwrap();
        assert_eq!(design.len(), 27);
        let mut seen = design.points.clone();
        seen.sort_by(|a, b| a.partial_cmp(b).unwrap());
        seen.dedup();
        assert_eq!(seen.len(), 27);
        assert!(matches!(
            Design::build(&DesignKind::FullFactorial { levels: 10 }, 8),
            Err(DesignError::TooManyRuns { .. })
        ));
    }

    #[test]
    fn centre_points_count_against_the_run_limit_before_anything_is_built() {
        use CentralCompositeAlpha::{FaceCentred, Orthogonal};
        for centre in [100_000_000_000, usize::MAX] {
            for kind in [
                DesignKind::CentralComposite {
                    alpha: FaceCentred,
                    center_points: centre,
                },
                DesignKind::CentralComposite {
                    alpha: Orthogonal,
                    center_points: centre,
                },
                DesignKind::BoxBehnken {
                    center_points: centre,
                },
            ] {
                assert!(
                    matches!(
                        Design::build(&kind, 3),
                        Err(DesignError::TooManyRuns { .. })
                    ),
                    "{kind:?}"
                );
            }
        }
        // Two factors: 4 factorial + 4 axial runs, so 99 992 centre points reach the limit.
        assert_eq!(ccd(FaceCentred, 2, 99_992).len(), MAX_RUNS);
        assert_eq!(
            Design::build(
                &DesignKind::CentralComposite {
                    alpha: FaceCentred,
                    center_points: 99_993
                },
                2
            ),
            Err(DesignError::TooManyRuns {
                runs: MAX_RUNS + 1,
                limit: MAX_RUNS
            })
        );
        // Three factors: 12 edge midpoints.
        assert_eq!(
            Design::build(
                &DesignKind::BoxBehnken {
                    center_points: 99_989
                },
                3
            ),
            Err(DesignError::TooManyRuns {
                runs: MAX_RUNS + 1,
                limit: MAX_RUNS
            })
        );
    }

    #[test]
    fn latin_hypercube_is_reproducible_for_a_seed() {
        let kind = DesignKind::LatinHypercube {
            samples: 12,
            seed: 7,
            candidates: 20,
        };
        assert_eq!(Design::build(&kind, 3), Design::build(&kind, 3));
        let other = DesignKind::LatinHypercube {
            samples: 12,
            seed: 8,
            candidates: 20,
        };
        assert_ne!(Design::build(&kind, 3), Design::build(&other, 3));
    }

    proptest! {
        #[test]
        fn latin_hypercube_hits_every_stratum_once(samples in 2usize..40, factors in 1usize..5, seed: u64) {
            let kind = DesignKind::LatinHypercube { samples, seed, candidates: 3 };
            let design = Design::build(&kind, factors).unwrap();
            prop_assert_eq!(design.len(), samples);
            for factor in 0..factors {
                let mut strata: Vec<usize> = design.points.iter()
                    .map(|p| (((p[factor] + 1.0) / 2.0 * samples as f64).floor() as usize).min(samples - 1))
                    .collect();
                strata.sort_unstable();
                prop_assert_eq!(strata, (0..samples).collect::<Vec<_>>());
            }
        }

        #[test]
        fn every_design_stays_in_the_coded_box(k in 2usize..6, centre in 0usize..4) {
            for alpha in [CentralCompositeAlpha::Orthogonal, CentralCompositeAlpha::Rotatable, CentralCompositeAlpha::FaceCentred] {
                let design = Design::build(&DesignKind::CentralComposite { alpha, center_points: centre }, k).unwrap();
                prop_assert!(design.points.iter().flatten().all(|v| v.abs() <= 1.0 + 1e-12));
            }
        }
    }
}
