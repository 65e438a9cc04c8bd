//! The Nelder–Mead simplex search in a box, for the local polishing of expected
//! improvement (single- and multi-fidelity): derivative-free, since EI's gradient is not
//! worth deriving for a few hundred evaluations.
//!
//! Reference: J. A. Nelder and R. Mead, "A simplex method for function minimization",
//! *The Computer Journal* 7 (1965) 308–313.

/// When a Nelder–Mead search stops.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Stop {
    /// Most evaluations of the function.
    pub max_evaluations: usize,
    /// The simplex's values agree to this, relative to `1 + |best|`…
    pub f_tolerance: f64,
    /// …and its vertices to this per coordinate.
    pub x_tolerance: f64,
}

/// Nelder–Mead simplex minimisation of `f` inside the box `[lower, upper]` (trial
/// points are clamped into it) from `start` with initial steps `step`, until `stop`.
/// Non-finite values count as +∞.
pub(crate) fn nelder_mead(
    f: &dyn Fn(&[f64]) -> f64,
    start: &[f64],
    step: &[f64],
    lower: &[f64],
    upper: &[f64],
    stop: Stop,
) -> (Vec<f64>, f64) {
    let Stop {
        max_evaluations,
        f_tolerance,
        x_tolerance,
    } = stop;
    let d = start.len();
    let clamp = |x: &mut Vec<f64>| {
        for j in 0..d {
            x[j] = x[j].clamp(lower[j], upper[j]);
        }
    };
    let eval = |x: &[f64]| {
        let v = f(x);
        if v.is_finite() {
            v
        } else {
            f64::INFINITY
        }
    };
    let mut x0 = start.to_vec();
    clamp(&mut x0);
    let mut simplex: Vec<(Vec<f64>, f64)> = Vec::with_capacity(d + 1);
    let f0 = eval(&x0);
    simplex.push((x0.clone(), f0));
    for j in 0..d {
        let mut v = x0.clone();
        v[j] = if v[j] + step[j] <= upper[j] {
            v[j] + step[j]
        } else {
            v[j] - step[j]
        };
        clamp(&mut v);
        let fv = eval(&v);
        simplex.push((v, fv));
    }
    let mut evaluations = d + 1;
    while evaluations < max_evaluations {
        simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
        let best = simplex[0].1;
        let worst = simplex[d].1;
        let spread_f = (worst - best).abs();
        let spread_x = (1..=d)
            .flat_map(|i| (0..d).map(move |j| (i, j)))
            .map(|(i, j)| (simplex[i].0[j] - simplex[0].0[j]).abs())
            .fold(0.0, f64::max);
        if best.is_finite()
            && spread_f <= f_tolerance * (1.0 + best.abs())
            && spread_x <= x_tolerance
        {
            break;
        }
        let centroid: Vec<f64> = (0..d)
            .map(|j| simplex[..d].iter().map(|v| v.0[j]).sum::<f64>() / d as f64)
            .collect();
        let along = |t: f64| {
            let mut x: Vec<f64> = (0..d)
                .map(|j| centroid[j] + t * (simplex[d].0[j] - centroid[j]))
                .collect();
            clamp(&mut x);
            x
        };
        let reflected = along(-1.0);
        let f_reflected = eval(&reflected);
        evaluations += 1;
        if f_reflected < simplex[0].1 {
            let expanded = along(-2.0);
            let f_expanded = eval(&expanded);
            evaluations += 1;
            simplex[d] = if f_expanded < f_reflected {
                (expanded, f_expanded)
            } else {
                (reflected, f_reflected)
            };
        } else if f_reflected < simplex[d - 1].1 {
            simplex[d] = (reflected, f_reflected);
        } else {
            let outside = f_reflected < simplex[d].1;
            let contracted = along(if outside { -0.5 } else { 0.5 });
            let f_contracted = eval(&contracted);
            evaluations += 1;
            if f_contracted < f_reflected.min(simplex[d].1) {
                simplex[d] = (contracted, f_contracted);
            } else {
                let best_x = simplex[0].0.clone();
                for vertex in simplex.iter_mut().skip(1) {
                    for (v, b) in vertex.0.iter_mut().zip(&best_x) {
                        *v = b + 0.5 * (*v - b);
                    }
                    vertex.1 = eval(&vertex.0);
                }
                evaluations += d;
            }
        }
    }
    simplex
        .into_iter()
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .expect("a simplex has vertices")
}
