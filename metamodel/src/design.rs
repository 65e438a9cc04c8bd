//! Designs of experiments in coded units.
//!
//! Every design returns points whose coordinates lie in `[-1, 1]`. For a central
//! composite design with an axial distance `α > 1`, the axial ("star") points sit on the
//! faces of the box at `±1` and the factorial points shrink to `±1/α` (the *inscribed*
//! form), so that no run leaves the range the user gave.

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
    /// Box-Behnken: every pair of factors at `±1` with the others at 0, plus centre runs.
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
            (2 * k * k.saturating_sub(1)).saturating_add(center_points as u128)
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

fn box_behnken(n_factors: usize, center_points: usize) -> Result<Vec<Vec<f64>>, DesignError> {
    require_factors("Box-Behnken", 3, n_factors)?;
    let mut points = Vec::new();
    for i in 0..n_factors {
        for j in i + 1..n_factors {
            for (a, b) in [(-1.0, -1.0), (-1.0, 1.0), (1.0, -1.0), (1.0, 1.0)] {
                let mut point = vec![0.0; n_factors];
                point[i] = a;
                point[j] = b;
                points.push(point);
            }
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
