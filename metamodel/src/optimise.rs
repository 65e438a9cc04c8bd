//! The optimum of a response surface inside a box.
//!
//! For a surface of order two or less the optimum is found exactly: the minimum of a
//! quadratic on a box lies at a stationary point of the quadratic restricted to one
//! face of the box (its interior, an edge, …, a corner), so every face's stationary
//! point is solved for and the best one inside the box wins (3^k faces for k
//! factors). Higher orders, and objectives with constraints, use projected gradient
//! descent from many starts (the corners, the centre and seeded random points).

use nalgebra::{DMatrix, DVector};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::levels;

/// Minimise or maximise.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Goal {
    /// Smallest value.
    Minimise,
    /// Largest value.
    Maximise,
}

/// A box in coded units.
#[derive(Debug, Clone, PartialEq)]
pub struct BoxBounds {
    /// Lower corner.
    pub lower: Vec<f64>,
    /// Upper corner.
    pub upper: Vec<f64>,
    /// Levels of each factor, 0 for a numeric one ([`crate::levels`]); empty when all
    /// are numeric. The optimisers try every combination of the text factors' levels
    /// and search the numeric factors within each.
    pub levels: Vec<u32>,
}

impl BoxBounds {
    /// The coded design box `[-1, 1]^k`.
    pub fn coded(k: usize) -> BoxBounds {
        BoxBounds {
            lower: vec![-1.0; k],
            upper: vec![1.0; k],
            levels: Vec::new(),
        }
    }

    /// The same box with text factors of `levels` levels (see [`crate::levels`]).
    pub fn with_levels(mut self, levels: &[u32]) -> BoxBounds {
        self.levels = levels.to_vec();
        self
    }

    /// True when some factor is text.
    fn has_text(&self) -> bool {
        self.levels.iter().any(|&l| l > 0)
    }

    /// The box of the numeric factors only.
    fn numeric(&self) -> BoxBounds {
        BoxBounds {
            lower: levels::numeric_part(&self.levels, &self.lower),
            upper: levels::numeric_part(&self.levels, &self.upper),
            levels: Vec::new(),
        }
    }

    fn clamp(&self, x: &mut [f64]) {
        for (i, v) in x.iter_mut().enumerate() {
            *v = v.clamp(self.lower[i], self.upper[i]);
        }
    }

    fn contains(&self, x: &[f64]) -> bool {
        let slack = 1e-12;
        x.iter()
            .enumerate()
            .all(|(i, v)| *v >= self.lower[i] - slack && *v <= self.upper[i] + slack)
    }
}

/// Where the optimum is and what the surface says there.
#[derive(Debug, Clone, PartialEq)]
pub struct Optimum {
    /// Coded coordinates.
    pub x: Vec<f64>,
    /// The objective's value there.
    pub value: f64,
    /// True when found exactly (quadratic), false when by multistart search.
    pub exact: bool,
}

/// A quadratic `c + bᵀx + xᵀAx` (A symmetric).
#[derive(Debug, Clone, PartialEq)]
pub struct Quadratic {
    /// Constant.
    pub c: f64,
    /// Linear coefficients.
    pub b: Vec<f64>,
    /// Symmetric matrix of second-order coefficients.
    pub a: Vec<Vec<f64>>,
}

impl Quadratic {
    /// The quadratic that agrees with `f` in `k` variables, by exact finite differences
    /// (exact when `f` is a polynomial of order two or less).
    pub fn from_fn(k: usize, f: &dyn Fn(&[f64]) -> f64) -> Quadratic {
        let unit = |i: usize| {
            let mut e = vec![0.0; k];
            e[i] = 1.0;
            e
        };
        let zero = vec![0.0; k];
        let c = f(&zero);
        let mut b = vec![0.0; k];
        let mut a = vec![vec![0.0; k]; k];
        let plus: Vec<f64> = (0..k).map(|i| f(&unit(i))).collect();
        for i in 0..k {
            let mut minus = unit(i);
            minus[i] = -1.0;
            let f_minus = f(&minus);
            b[i] = (plus[i] - f_minus) / 2.0;
            a[i][i] = (plus[i] + f_minus - 2.0 * c) / 2.0;
            for j in 0..i {
                let mut both = unit(i);
                both[j] = 1.0;
                let mixed = (f(&both) - plus[i] - plus[j] + c) / 2.0;
                a[i][j] = mixed;
                a[j][i] = mixed;
            }
        }
        Quadratic { c, b, a }
    }

    /// Its value at `x`.
    pub fn value(&self, x: &[f64]) -> f64 {
        let mut v = self.c;
        for i in 0..x.len() {
            v += self.b[i] * x[i];
            for j in 0..x.len() {
                v += x[i] * self.a[i][j] * x[j];
            }
        }
        v
    }

    /// The exact minimum on `bounds`, by enumerating the faces of the box.
    pub fn minimise_in_box(&self, bounds: &BoxBounds) -> Optimum {
        let k = self.b.len();
        let mut best: Option<Optimum> = None;
        // Each factor is free (0), at its lower bound (1) or at its upper bound (2).
        let faces = 3usize.pow(k as u32);
        for face in 0..faces {
            let mut pattern = Vec::with_capacity(k);
            let mut rest = face;
            for _ in 0..k {
                pattern.push(rest % 3);
                rest /= 3;
            }
            let mut x: Vec<f64> = (0..k)
                .map(|i| match pattern[i] {
                    1 => bounds.lower[i],
                    2 => bounds.upper[i],
                    _ => 0.0,
                })
                .collect();
            let free: Vec<usize> = (0..k).filter(|&i| pattern[i] == 0).collect();
            if !free.is_empty() {
                // ∂/∂x_f: b_f + 2 Σ_j A_fj x_j = 0 over the free variables.
                let m = free.len();
                let matrix = DMatrix::from_fn(m, m, |r, s| 2.0 * self.a[free[r]][free[s]]);
                let rhs = DVector::from_fn(m, |r, _| {
                    let i = free[r];
                    -self.b[i]
                        - (0..k)
                            .filter(|j| pattern[*j] != 0)
                            .map(|j| 2.0 * self.a[i][j] * x[j])
                            .sum::<f64>()
                });
                let Some(solution) = matrix.lu().solve(&rhs) else {
                    continue;
                };
                for (r, &i) in free.iter().enumerate() {
                    x[i] = solution[r];
                }
                if !bounds.contains(&x) || x.iter().any(|v| !v.is_finite()) {
                    continue;
                }
                bounds.clamp(&mut x);
            }
            let value = self.value(&x);
            if best.as_ref().is_none_or(|b| value < b.value) {
                best = Some(Optimum {
                    x,
                    value,
                    exact: true,
                });
            }
        }
        best.expect("the corners of the box are always candidates")
    }
}

/// Optimum of `f` on `bounds` for `goal`: exact when `quadratic` (f is of order ≤ 2),
/// else by multistart projected gradient descent seeded with `seed`.
pub fn optimise(
    f: &dyn Fn(&[f64]) -> f64,
    quadratic: bool,
    goal: Goal,
    bounds: &BoxBounds,
    seed: u64,
) -> Optimum {
    if bounds.has_text() {
        return over_levels(bounds, goal, f, &[], |g, numeric, _| {
            (optimise(g, quadratic, goal, numeric, seed), true)
        })
        .0;
    }
    let sign = match goal {
        Goal::Minimise => 1.0,
        Goal::Maximise => -1.0,
    };
    let signed = |x: &[f64]| sign * f(x);
    let found = if quadratic {
        Quadratic::from_fn(bounds.lower.len(), &signed).minimise_in_box(bounds)
    } else {
        multistart(&signed, bounds, seed)
    };
    Optimum {
        value: f(&found.x),
        ..found
    }
}

/// A bound on another function of the factors (a response's surface).
pub struct Constraint<'a> {
    /// The constrained function.
    pub g: &'a dyn Fn(&[f64]) -> f64,
    /// Smallest allowed value.
    pub min: Option<f64>,
    /// Largest allowed value.
    pub max: Option<f64>,
}

impl Constraint<'_> {
    /// How far `x` is outside the allowed range (0 inside).
    pub fn violation(&self, x: &[f64]) -> f64 {
        let value = (self.g)(x);
        let below = self.min.map_or(0.0, |m| (m - value).max(0.0));
        let above = self.max.map_or(0.0, |m| (value - m).max(0.0));
        below + above
    }
}

/// Optimum of `f` subject to `constraints` on `bounds`, by multistart descent on `f`
/// plus a quadratic penalty on violations; without constraints it is [`optimise`].
/// Returns the optimum and whether it satisfies every constraint (within 1e-6 of
/// each constraint's scale).
pub fn optimise_subject_to(
    f: &dyn Fn(&[f64]) -> f64,
    quadratic: bool,
    constraints: &[Constraint],
    goal: Goal,
    bounds: &BoxBounds,
    seed: u64,
) -> (Optimum, bool) {
    if constraints.is_empty() {
        return (optimise(f, quadratic, goal, bounds, seed), true);
    }
    if bounds.has_text() {
        return over_levels(bounds, goal, f, constraints, |g, numeric, reduced| {
            optimise_subject_to(g, quadratic, reduced, goal, numeric, seed)
        });
    }
    let sign = match goal {
        Goal::Minimise => 1.0,
        Goal::Maximise => -1.0,
    };
    // Each function's typical size over the box, so that the objective and every
    // violation are compared in their own units (a function that is zero at the centre
    // must not make its term huge).
    let probes = magnitude_probes(bounds, seed);
    let scale = magnitude(f, &probes);
    let constraint_scales: Vec<f64> = constraints
        .iter()
        .map(|c| magnitude(c.g, &probes))
        .collect();
    let penalised = |x: &[f64]| {
        let penalty: f64 = constraints
            .iter()
            .zip(&constraint_scales)
            .map(|(c, s)| (c.violation(x) / s).powi(2))
            .sum();
        sign * f(x) / scale + 1e6 * penalty
    };
    let found = multistart(&penalised, bounds, seed);
    let feasible = constraints
        .iter()
        .zip(&constraint_scales)
        .all(|(c, s)| c.violation(&found.x) <= 1e-6 * s.max(1.0));
    (
        Optimum {
            value: f(&found.x),
            ..found
        },
        feasible,
    )
}

/// A function of the numeric factors: another function with the text factors held.
type Restricted<'a> = Box<dyn Fn(&[f64]) -> f64 + 'a>;

/// The best over every combination of the text factors' levels of `solve` run on
/// the numeric factors alone (`f` and `constraints` restricted to the combination):
/// a feasible optimum beats an infeasible one, then the better value for `goal`.
fn over_levels(
    bounds: &BoxBounds,
    goal: Goal,
    f: &dyn Fn(&[f64]) -> f64,
    constraints: &[Constraint],
    solve: impl Fn(&dyn Fn(&[f64]) -> f64, &BoxBounds, &[Constraint]) -> (Optimum, bool),
) -> (Optimum, bool) {
    let k = bounds.lower.len();
    let numeric = bounds.numeric();
    let mut best: Option<(Optimum, bool)> = None;
    for combination in levels::combinations(&bounds.levels) {
        let full = |x: &[f64]| levels::embed(&bounds.levels, k, x, &combination);
        let g = |x: &[f64]| f(&full(x));
        let restricted: Vec<Restricted> = constraints
            .iter()
            .map(|c| {
                let full = &full;
                Box::new(move |x: &[f64]| (c.g)(&full(x))) as Restricted
            })
            .collect();
        let reduced: Vec<Constraint> = constraints
            .iter()
            .zip(&restricted)
            .map(|(c, g)| Constraint {
                g: g.as_ref(),
                min: c.min,
                max: c.max,
            })
            .collect();
        let (found, feasible) = solve(&g, &numeric, &reduced);
        let candidate = Optimum {
            x: full(&found.x),
            ..found
        };
        let better = match &best {
            None => true,
            Some((incumbent, incumbent_feasible)) => {
                (feasible && !incumbent_feasible)
                    || (feasible == *incumbent_feasible
                        && match goal {
                            Goal::Minimise => candidate.value < incumbent.value,
                            Goal::Maximise => candidate.value > incumbent.value,
                        })
            }
        };
        if better {
            best = Some((candidate, feasible));
        }
    }
    best.expect("there is at least one combination of levels")
}

/// Points at which [`magnitude`] looks: the centre, the corners (up to 8 factors) and
/// 20 seeded random points of `bounds`.
fn magnitude_probes(bounds: &BoxBounds, seed: u64) -> Vec<Vec<f64>> {
    let k = bounds.lower.len();
    let mut points = vec![(0..k)
        .map(|i| 0.5 * (bounds.lower[i] + bounds.upper[i]))
        .collect::<Vec<f64>>()];
    if k <= 8 {
        for corner in 0..(1usize << k) {
            points.push(
                (0..k)
                    .map(|i| {
                        if corner >> i & 1 == 1 {
                            bounds.upper[i]
                        } else {
                            bounds.lower[i]
                        }
                    })
                    .collect(),
            );
        }
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x6d61_676e);
    for _ in 0..20 {
        points.push(
            (0..k)
                .map(|i| rng.random_range(bounds.lower[i]..=bounds.upper[i]))
                .collect(),
        );
    }
    points
}

/// A function's typical size: the largest of its value at the first probe (the centre)
/// and its change from there to any other probe; at least 10^-12.
fn magnitude(f: &dyn Fn(&[f64]) -> f64, probes: &[Vec<f64>]) -> f64 {
    let centre = f(&probes[0]);
    probes[1..]
        .iter()
        .map(|p| (f(p) - centre).abs())
        .filter(|v| v.is_finite())
        .fold(centre.abs(), f64::max)
        .max(1e-12)
}

/// Best local minimum of projected gradient descent from corners, centre and random starts.
pub fn multistart(f: &dyn Fn(&[f64]) -> f64, bounds: &BoxBounds, seed: u64) -> Optimum {
    let k = bounds.lower.len();
    let mut starts: Vec<Vec<f64>> = vec![(0..k)
        .map(|i| 0.5 * (bounds.lower[i] + bounds.upper[i]))
        .collect()];
    if k <= 8 {
        for corner in 0..(1usize << k) {
            starts.push(
                (0..k)
                    .map(|i| {
                        if corner >> i & 1 == 1 {
                            bounds.upper[i]
                        } else {
                            bounds.lower[i]
                        }
                    })
                    .collect(),
            );
        }
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    for _ in 0..(10 * k).max(20) {
        starts.push(
            (0..k)
                .map(|i| rng.random_range(bounds.lower[i]..=bounds.upper[i]))
                .collect(),
        );
    }
    starts
        .into_iter()
        .map(|start| descend(f, bounds, start))
        .min_by(|a, b| a.value.total_cmp(&b.value))
        .expect("at least one start")
}

/// The gradient of `f` at `x` by differences of step 10⁻⁶ that never leave `bounds`:
/// central inside, one-sided at a bound (a surface continued outside the box may be
/// undefined there, as `√x` below 0), zero along a coordinate the box holds fixed.
pub(crate) fn gradient_in_box(
    f: &dyn Fn(&[f64]) -> f64,
    x: &[f64],
    bounds: &BoxBounds,
) -> Vec<f64> {
    let h = 1e-6;
    let mut probe = x.to_vec();
    (0..x.len())
        .map(|i| {
            let up = (x[i] + h).min(bounds.upper[i]);
            let down = (x[i] - h).max(bounds.lower[i]);
            if up <= down {
                return 0.0;
            }
            probe[i] = up;
            let f_up = f(&probe);
            probe[i] = down;
            let f_down = f(&probe);
            probe[i] = x[i];
            (f_up - f_down) / (up - down)
        })
        .collect()
}

fn descend(f: &dyn Fn(&[f64]) -> f64, bounds: &BoxBounds, mut x: Vec<f64>) -> Optimum {
    let mut value = f(&x);
    let mut step = 0.5;
    for _ in 0..500 {
        let gradient = gradient_in_box(f, &x, bounds);
        let norm = gradient.iter().map(|g| g * g).sum::<f64>().sqrt();
        if norm < 1e-12 {
            break;
        }
        let mut improved = false;
        while step > 1e-12 {
            let mut candidate: Vec<f64> = x
                .iter()
                .zip(&gradient)
                .map(|(v, g)| v - step * g / norm)
                .collect();
            bounds.clamp(&mut candidate);
            let candidate_value = f(&candidate);
            if candidate_value < value {
                let moved: f64 = candidate.iter().zip(&x).map(|(a, b)| (a - b).abs()).sum();
                x = candidate;
                value = candidate_value;
                improved = moved > 1e-14;
                step *= 1.5;
                break;
            }
            step *= 0.5;
        }
        if !improved {
            break;
        }
    }
    Optimum {
        x,
        value,
        exact: false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bowl(centre: [f64; 2]) -> impl Fn(&[f64]) -> f64 {
        move |x: &[f64]| {
            (x[0] - centre[0]).powi(2)
                + 2.0 * (x[1] - centre[1]).powi(2)
                + 0.5 * (x[0] - centre[0]) * (x[1] - centre[1])
        }
    }

    fn close(a: &[f64], b: &[f64], tolerance: f64) -> bool {
        a.iter().zip(b).all(|(x, y)| (x - y).abs() < tolerance)
    }

    #[test]
    fn interior_edge_and_corner_optima_of_a_quadratic_are_found_exactly() {
        let bounds = BoxBounds::coded(2);
        // Interior: the bowl's centre.
        let interior = optimise(&bowl([0.3, -0.2]), true, Goal::Minimise, &bounds, 0);
        assert!(close(&interior.x, &[0.3, -0.2], 1e-12), "{interior:?}");
        // Edge: centre beyond x1 = 1; on that edge ∂/∂x2 = 0 gives x2 = -0.2 - 0.25 (1 - 1.6)/... solve directly.
        let f = bowl([1.6, -0.2]);
        let edge = optimise(&f, true, Goal::Minimise, &bounds, 0);
        assert!(
            (edge.x[0] - 1.0).abs() < 1e-12 && edge.x[1].abs() < 1.0 - 1e-6,
            "{edge:?}"
        );
        // On x1 = 1: 4 (x2 + 0.2) + 0.5 (1 - 1.6) = 0 → x2 = -0.2 + 0.075.
        assert!((edge.x[1] - (-0.125)).abs() < 1e-12, "{edge:?}");
        // Corner: a saddle maximised on the box lands on a corner.
        let saddle = |x: &[f64]| x[0] * x[0] - x[1] * x[1] + 0.1 * x[0] + 0.2 * x[1];
        let corner = optimise(&saddle, true, Goal::Maximise, &bounds, 0);
        assert!(
            close(&corner.x, &[1.0, 0.0], 1e-12) || corner.x[0].abs() == 1.0,
            "{corner:?}"
        );
        assert!((corner.value - saddle(&corner.x)).abs() < 1e-15);
        // Brute force over a grid agrees.
        let mut best = f64::NEG_INFINITY;
        for i in 0..=200 {
            for j in 0..=200 {
                best = best.max(saddle(&[-1.0 + i as f64 / 100.0, -1.0 + j as f64 / 100.0]));
            }
        }
        assert!(corner.value >= best - 1e-12);
    }

    #[test]
    fn a_concave_maximum_on_a_corner() {
        let f = |x: &[f64]| -(x[0] - 2.0).powi(2) - (x[1] + 3.0).powi(2);
        let found = optimise(&f, true, Goal::Maximise, &BoxBounds::coded(2), 0);
        assert!(close(&found.x, &[1.0, -1.0], 1e-12), "{found:?}");
    }

    #[test]
    fn a_constrained_maximum_lies_on_the_constraint() {
        // Maximise x + y subject to x² + y² ≤ 0.5: the optimum is (0.5, 0.5).
        let f = |x: &[f64]| x[0] + x[1];
        let g = |x: &[f64]| x[0] * x[0] + x[1] * x[1];
        let constraint = Constraint {
            g: &g,
            min: None,
            max: Some(0.5),
        };
        let (found, feasible) = optimise_subject_to(
            &f,
            true,
            &[constraint],
            Goal::Maximise,
            &BoxBounds::coded(2),
            1,
        );
        assert!(feasible, "{found:?}");
        assert!(close(&found.x, &[0.5, 0.5], 1e-3), "{found:?}");
        // An impossible constraint is reported as infeasible.
        let impossible = Constraint {
            g: &g,
            min: Some(5.0),
            max: None,
        };
        let (_, feasible) = optimise_subject_to(
            &f,
            true,
            &[impossible],
            Goal::Maximise,
            &BoxBounds::coded(2),
            1,
        );
        assert!(!feasible);
    }

    #[test]
    fn a_text_factor_is_searched_level_by_level() {
        // x numeric, m text with 3 levels; the surface depends on m through a table,
        // so no smooth search over m's coordinate could find level 2 (coded 0).
        let bounds = BoxBounds::coded(2).with_levels(&[0, 3]);
        let offset = [1.0, -2.0, 0.5];
        let f = |x: &[f64]| (x[0] - 0.3).powi(2) + offset[levels::level_of(x[1], 3) as usize];
        for quadratic in [true, false] {
            let best = optimise(&f, quadratic, Goal::Minimise, &bounds, 1);
            assert!((best.x[0] - 0.3).abs() < 1e-4, "{best:?}");
            assert_eq!(best.x[1], 0.0, "{best:?}");
            assert!((best.value + 2.0).abs() < 1e-8, "{best:?}");
        }
        // A constraint that rules level 2 out: the best feasible level is 3.
        let g = |x: &[f64]| levels::level_of(x[1], 3) as f64;
        let constraint = Constraint {
            g: &g,
            min: None,
            max: Some(0.5),
        };
        let (best, feasible) =
            optimise_subject_to(&f, true, &[constraint], Goal::Minimise, &bounds, 1);
        assert!(feasible);
        assert_eq!(best.x[1], -1.0, "{best:?}");
        // Only text factors: every combination is tried.
        let text_only = BoxBounds::coded(1).with_levels(&[3]);
        let h = |x: &[f64]| offset[levels::level_of(x[0], 3) as usize];
        let best = optimise(&h, false, Goal::Maximise, &text_only, 0);
        assert_eq!((best.x.clone(), best.value), (vec![-1.0], 1.0));
    }

    #[test]
    fn multistart_finds_the_global_minimum_of_a_cubic() {
        // Two local minima in the box; the deeper one is at x ≈ -0.87.
        let f = |x: &[f64]| x[0].powi(4) - 1.5 * x[0] * x[0] + 0.3 * x[0] + x[1] * x[1];
        let found = optimise(&f, false, Goal::Minimise, &BoxBounds::coded(2), 3);
        let mut best = f64::INFINITY;
        for i in 0..=20000 {
            best = best.min(f(&[-1.0 + i as f64 / 10000.0, 0.0]));
        }
        assert!(found.value <= best + 1e-8, "{found:?} vs {best}");
        assert!(found.x[0] < 0.0);
    }

    #[test]
    fn a_constraint_binds_even_when_the_objective_is_zero_at_the_centre() {
        // Maximise x0 subject to x0 + x1 ≤ 0.5 with x1 fixed at 0: x0 = 0.5. The
        // objective is 0 at the centre, which once made it outweigh the penalty.
        let f = |x: &[f64]| x[0];
        let g = |x: &[f64]| x[0] + x[1];
        let bounds = BoxBounds {
            lower: vec![-1.0, 0.0],
            upper: vec![1.0, 0.0],
            levels: Vec::new(),
        };
        let (found, feasible) = optimise_subject_to(
            &f,
            false,
            &[Constraint {
                g: &g,
                min: None,
                max: Some(0.5),
            }],
            Goal::Maximise,
            &bounds,
            1,
        );
        assert!(feasible);
        assert!((found.x[0] - 0.5).abs() < 1e-3, "{found:?}");
    }
}
