//! Text factors (a contact model, a mesh): variables that take one of a few named
//! levels instead of a value in a range.
//!
//! Such a factor lives among the numeric ones as one coded coordinate: level `i` of
//! `L` sits at `−1 + 2i/(L − 1)`, so `−1` and `1` for two levels and `−1, 0, 1` for
//! three. Nothing between the levels means anything; every function of this crate that
//! meets such a coordinate reads its level with [`level_of`], which also maps a value
//! drawn uniformly from `[−1, 1]` to each level with probability `1/L` (what Monte
//! Carlo and Sobol sampling need).
//!
//! A *level list* gives, per factor in order, its number of levels: 0 for a numeric
//! factor. An empty list means every factor is numeric.
//!
//! Designs over text factors are the numeric design crossed with every combination of
//! levels ([`cross`]), or, for a Latin hypercube, the numeric hypercube with the levels
//! stratified over its rows ([`stratify`]): every level of every text factor gets the
//! same number of runs (±1), as every interval of a numeric factor does.

use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// The coded coordinate of level `level` (0-based) of a factor with `count` levels.
pub fn coded_level(level: u32, count: u32) -> f64 {
    if count < 2 {
        return 0.0;
    }
    -1.0 + 2.0 * level as f64 / (count - 1) as f64
}

/// The level (0-based) a coded coordinate `coded` stands for, for a factor with
/// `count` levels: exact at [`coded_level`], and each level's share of `[−1, 1]` is
/// `1/count`.
pub fn level_of(coded: f64, count: u32) -> u32 {
    if count < 2 || !coded.is_finite() {
        return 0;
    }
    let share = ((coded + 1.0) / 2.0 * count as f64).floor();
    share.clamp(0.0, (count - 1) as f64) as u32
}

/// True when factor `index` of `levels` is a text factor.
pub fn is_text(levels: &[u32], index: usize) -> bool {
    levels.get(index).is_some_and(|&l| l > 0)
}

/// The indices of the numeric factors among `n_factors`.
pub fn numeric_factors(levels: &[u32], n_factors: usize) -> Vec<usize> {
    (0..n_factors).filter(|&i| !is_text(levels, i)).collect()
}

/// Every combination of the text factors' levels, as one level per text factor (in
/// factor order), the first factor varying slowest. One empty combination when there
/// are no text factors.
pub fn combinations(levels: &[u32]) -> Vec<Vec<u32>> {
    let counts: Vec<u32> = levels.iter().copied().filter(|&l| l > 0).collect();
    let mut out = vec![Vec::new()];
    for &count in &counts {
        out = out
            .into_iter()
            .flat_map(|prefix: Vec<u32>| {
                (0..count).map(move |level| {
                    let mut next = prefix.clone();
                    next.push(level);
                    next
                })
            })
            .collect();
    }
    out
}

/// Number of level combinations (1 without text factors), saturating.
pub fn combination_count(levels: &[u32]) -> usize {
    levels
        .iter()
        .filter(|&&l| l > 0)
        .fold(1usize, |n, &l| n.saturating_mul(l as usize))
}

/// The combination (one level per text factor) that coded point `x` is at.
pub fn combination_of(levels: &[u32], x: &[f64]) -> Vec<u32> {
    levels
        .iter()
        .zip(x)
        .filter(|(&l, _)| l > 0)
        .map(|(&l, &c)| level_of(c, l))
        .collect()
}

/// The full coded point of `n_factors` factors with numeric coordinates `numeric` (in
/// the order of [`numeric_factors`]) and the text factors at `combination`.
pub fn embed(levels: &[u32], n_factors: usize, numeric: &[f64], combination: &[u32]) -> Vec<f64> {
    let (mut next_numeric, mut next_text) = (numeric.iter(), combination.iter());
    (0..n_factors)
        .map(|i| {
            if is_text(levels, i) {
                coded_level(*next_text.next().unwrap_or(&0), levels[i])
            } else {
                *next_numeric.next().unwrap_or(&0.0)
            }
        })
        .collect()
}

/// The numeric coordinates of coded point `x` (dropping its text factors).
pub fn numeric_part(levels: &[u32], x: &[f64]) -> Vec<f64> {
    x.iter()
        .enumerate()
        .filter(|(i, _)| !is_text(levels, *i))
        .map(|(_, v)| *v)
        .collect()
}

/// A design over numeric factors (`numeric_points`, each of the numeric factors'
/// dimension) crossed with every combination of the text factors' levels: each
/// combination gets the whole numeric design.
pub fn cross(levels: &[u32], n_factors: usize, numeric_points: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let mut out = Vec::new();
    for combination in combinations(levels) {
        for point in numeric_points {
            out.push(embed(levels, n_factors, point, &combination));
        }
    }
    out
}

/// A Latin hypercube over the numeric factors (`numeric_points`) with each text
/// factor's levels assigned to its rows in equal shares (a level gets ⌊n/L⌋ or
/// ⌈n/L⌉ rows), each factor by its own seeded permutation: the text factor's column is
/// itself a Latin hypercube column over its levels.
pub fn stratify(
    levels: &[u32],
    n_factors: usize,
    numeric_points: &[Vec<f64>],
    seed: u64,
) -> Vec<Vec<f64>> {
    let n = numeric_points.len();
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x7465_7874);
    let columns: Vec<Vec<u32>> = levels
        .iter()
        .filter(|&&l| l > 0)
        .map(|&count| {
            let mut column: Vec<u32> = (0..n)
                .map(|row| (row * count as usize / n) as u32)
                .collect();
            column.shuffle(&mut rng);
            column
        })
        .collect();
    numeric_points
        .iter()
        .enumerate()
        .map(|(row, point)| {
            let combination: Vec<u32> = columns.iter().map(|c| c[row]).collect();
            embed(levels, n_factors, point, &combination)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn levels_sit_evenly_on_the_coded_axis_and_read_back() {
        assert_eq!(coded_level(0, 2), -1.0);
        assert_eq!(coded_level(1, 2), 1.0);
        assert_eq!(coded_level(1, 3), 0.0);
        for count in 2..9 {
            for level in 0..count {
                assert_eq!(level_of(coded_level(level, count), count), level);
            }
        }
    }

    #[test]
    fn a_uniform_coded_value_picks_each_level_equally() {
        let count = 3;
        let mut seen = [0usize; 3];
        let n = 30_000;
        for i in 0..n {
            let u = -1.0 + 2.0 * (i as f64 + 0.5) / n as f64;
            seen[level_of(u, count) as usize] += 1;
        }
        assert_eq!(seen, [10_000; 3]);
    }

    #[test]
    fn crossing_gives_each_combination_the_whole_numeric_design() {
        // Factors: x (numeric), mode (2 levels), y (numeric), mesh (3 levels).
        let levels = [0, 2, 0, 3];
        let numeric = vec![vec![-1.0, -1.0], vec![1.0, 1.0], vec![0.0, 0.5]];
        let design = cross(&levels, 4, &numeric);
        assert_eq!(design.len(), 3 * 6);
        for combination in combinations(&levels) {
            let rows: Vec<&Vec<f64>> = design
                .iter()
                .filter(|p| combination_of(&levels, p) == combination)
                .collect();
            assert_eq!(rows.len(), 3);
            let numerics: Vec<Vec<f64>> = rows.iter().map(|p| numeric_part(&levels, p)).collect();
            assert_eq!(numerics, numeric);
        }
        assert_eq!(design[0], vec![-1.0, -1.0, -1.0, -1.0]);
    }

    #[test]
    fn only_text_factors_give_the_full_factorial_of_levels() {
        let design = cross(&[2, 3], 2, &[vec![]]);
        assert_eq!(design.len(), 6);
        assert_eq!(combination_count(&[2, 3]), 6);
        assert_eq!(combinations(&[]), vec![Vec::<u32>::new()]);
    }

    proptest! {
        #[test]
        fn stratified_levels_are_shared_equally(n in 2usize..60, count in 2u32..6, seed: u64) {
            let numeric: Vec<Vec<f64>> = (0..n).map(|i| vec![i as f64 / n as f64]).collect();
            let design = stratify(&[0, count], 2, &numeric, seed);
            let mut per_level = vec![0usize; count as usize];
            for (row, point) in design.iter().enumerate() {
                prop_assert_eq!(point[0], numeric[row][0]);
                per_level[level_of(point[1], count) as usize] += 1;
            }
            let (lo, hi) = (n / count as usize, n.div_ceil(count as usize));
            prop_assert!(per_level.iter().all(|&c| c >= lo && c <= hi), "{:?}", per_level);
        }
    }
}
