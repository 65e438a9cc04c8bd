//! Student's t distribution, Fisher's F distribution and Welch's two-sample interval.
//!
//! The t distribution function is written through the regularised incomplete beta
//! function, `P(T ≤ t) = 1 − ½ I_{ν/(ν+t²)}(ν/2, ½)` for `t ≥ 0`, evaluated by its
//! continued fraction (modified Lentz); the quantile inverts it by bisection on a
//! bracket that doubles until it holds the answer. Degrees of freedom may be any
//! positive real number, as Welch–Satterthwaite gives them.
//!
//! Fisher's F with `d1`, `d2` degrees of freedom goes through the same function:
//! `P(F ≤ f) = I_{d1 f / (d1 f + d2)}(d1/2, d2/2)`, and its upper tail
//! `P(F > f) = I_{d2 / (d2 + d1 f)}(d2/2, d1/2)` is evaluated directly, not as one minus the
//! distribution function, so that small p-values keep their digits (Abramowitz & Stegun,
//! *Handbook of Mathematical Functions*, 26.6.2).

/// Natural log of Γ(x) for x > 0 (Lanczos, g = 7, nine coefficients; relative error
/// below 1e-13 on the range used here).
fn ln_gamma(x: f64) -> f64 {
    const COEFFICIENTS: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection: Γ(x) Γ(1−x) = π / sin(πx).
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut sum = COEFFICIENTS[0];
    for (i, c) in COEFFICIENTS.iter().enumerate().skip(1) {
        sum += c / (x + i as f64);
    }
    let t = x + 7.5;
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + sum.ln()
}

/// Continued fraction of the incomplete beta function (modified Lentz).
fn beta_continued_fraction(a: f64, b: f64, x: f64) -> f64 {
    const TINY: f64 = 1e-300;
    let mut c = 1.0;
    let mut d = 1.0 - (a + b) * x / (a + 1.0);
    if d.abs() < TINY {
        d = TINY;
    }
    d = 1.0 / d;
    let mut h = d;
    for m in 1..=500 {
        let m = m as f64;
        let m2 = 2.0 * m;
        let even = m * (b - m) * x / ((a + m2 - 1.0) * (a + m2));
        d = 1.0 + even * d;
        d = if d.abs() < TINY { TINY } else { d };
        c = 1.0 + even / c;
        c = if c.abs() < TINY { TINY } else { c };
        d = 1.0 / d;
        h *= d * c;
        let odd = -(a + m) * (a + b + m) * x / ((a + m2) * (a + m2 + 1.0));
        d = 1.0 + odd * d;
        d = if d.abs() < TINY { TINY } else { d };
        c = 1.0 + odd / c;
        c = if c.abs() < TINY { TINY } else { c };
        d = 1.0 / d;
        let step = d * c;
        h *= step;
        if (step - 1.0).abs() < 1e-15 {
            break;
        }
    }
    h
}

/// The regularised incomplete beta function `I_x(a, b)` for `a, b > 0`, `0 ≤ x ≤ 1`.
fn regularised_beta(a: f64, b: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    if x >= 1.0 {
        return 1.0;
    }
    let front =
        (ln_gamma(a + b) - ln_gamma(a) - ln_gamma(b) + a * x.ln() + b * (1.0 - x).ln()).exp();
    if x < (a + 1.0) / (a + b + 2.0) {
        front * beta_continued_fraction(a, b, x) / a
    } else {
        1.0 - front * beta_continued_fraction(b, a, 1.0 - x) / b
    }
}

/// `P(T ≤ t)` for Student's t with `degrees_of_freedom` (> 0, any real).
pub fn student_t_cdf(t: f64, degrees_of_freedom: f64) -> f64 {
    let nu = degrees_of_freedom;
    let tail = 0.5 * regularised_beta(0.5 * nu, 0.5, nu / (nu + t * t));
    if t >= 0.0 {
        1.0 - tail
    } else {
        tail
    }
}

/// The `p` quantile of Student's t with `degrees_of_freedom` (> 0, any real): the `t`
/// with `P(T ≤ t) = p`. NaN when `p` is not inside (0, 1) or the degrees of freedom
/// are not positive.
pub fn student_t_quantile(p: f64, degrees_of_freedom: f64) -> f64 {
    if !(p > 0.0 && p < 1.0 && degrees_of_freedom > 0.0) {
        return f64::NAN;
    }
    if p == 0.5 {
        return 0.0;
    }
    if p < 0.5 {
        return -student_t_quantile(1.0 - p, degrees_of_freedom);
    }
    let mut high = 1.0;
    while student_t_cdf(high, degrees_of_freedom) < p {
        high *= 2.0;
        if high > 1e300 {
            return f64::INFINITY;
        }
    }
    let mut low = 0.0;
    for _ in 0..200 {
        let mid = 0.5 * (low + high);
        if student_t_cdf(mid, degrees_of_freedom) < p {
            low = mid;
        } else {
            high = mid;
        }
        if high - low <= 1e-14 * high {
            break;
        }
    }
    0.5 * (low + high)
}

/// `P(F ≤ f)` for Fisher's F with `d1` numerator and `d2` denominator degrees of freedom
/// (both > 0, any real). Zero for `f ≤ 0`; NaN when a degree of freedom is not positive.
pub fn f_cdf(f: f64, d1: f64, d2: f64) -> f64 {
    if !(d1 > 0.0 && d2 > 0.0) || f.is_nan() {
        return f64::NAN;
    }
    if f <= 0.0 {
        return 0.0;
    }
    if f.is_infinite() {
        return 1.0;
    }
    regularised_beta(0.5 * d1, 0.5 * d2, d1 * f / (d1 * f + d2))
}

/// `P(F > f)`, the upper tail of Fisher's F with `d1`, `d2` degrees of freedom: the
/// p-value of an F test whose statistic is `f`. Computed directly rather than as
/// `1 − f_cdf`, so that a p-value of 1e-12 is not lost to rounding. One for `f ≤ 0`; NaN
/// when a degree of freedom is not positive.
pub fn f_survival(f: f64, d1: f64, d2: f64) -> f64 {
    if !(d1 > 0.0 && d2 > 0.0) || f.is_nan() {
        return f64::NAN;
    }
    if f <= 0.0 {
        return 1.0;
    }
    if f.is_infinite() {
        return 0.0;
    }
    regularised_beta(0.5 * d2, 0.5 * d1, d2 / (d2 + d1 * f))
}

/// The `p` quantile of Fisher's F with `d1`, `d2` degrees of freedom: the `f` with
/// `P(F ≤ f) = p`, e.g. the critical value of a test at level `1 − p`. NaN when `p` is
/// not inside (0, 1) or a degree of freedom is not positive.
pub fn f_quantile(p: f64, d1: f64, d2: f64) -> f64 {
    if !(p > 0.0 && p < 1.0 && d1 > 0.0 && d2 > 0.0) {
        return f64::NAN;
    }
    let mut high = 1.0;
    while f_cdf(high, d1, d2) < p {
        high *= 2.0;
        if high > 1e300 {
            return f64::INFINITY;
        }
    }
    let mut low = 0.0;
    for _ in 0..200 {
        let mid = 0.5 * (low + high);
        if f_cdf(mid, d1, d2) < p {
            low = mid;
        } else {
            high = mid;
        }
        if high - low <= 1e-14 * high {
            break;
        }
    }
    0.5 * (low + high)
}

/// Mean, standard error of the mean and count of one sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SampleSummary {
    /// The sample mean.
    pub mean: f64,
    /// The standard error of the mean, `s / √n` (NaN for one value).
    pub standard_error: f64,
    /// How many values.
    pub count: usize,
}

impl SampleSummary {
    /// The summary of `values`; `None` when there are none.
    pub fn of(values: &[f64]) -> Option<SampleSummary> {
        let n = values.len();
        if n == 0 {
            return None;
        }
        let mean = values.iter().sum::<f64>() / n as f64;
        let standard_error = if n < 2 {
            f64::NAN
        } else {
            let variance =
                values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n as f64 - 1.0);
            (variance / n as f64).sqrt()
        };
        Some(SampleSummary {
            mean,
            standard_error,
            count: n,
        })
    }
}

/// Welch's interval for the difference of two means, `a − b`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WelchInterval {
    /// `mean(a) − mean(b)`.
    pub difference: f64,
    /// Welch–Satterthwaite degrees of freedom.
    pub degrees_of_freedom: f64,
    /// Lower end of the interval.
    pub low: f64,
    /// Upper end of the interval.
    pub high: f64,
}

/// Welch's two-sided `confidence` (e.g. 0.95) interval for `mean(a) − mean(b)` from the
/// two samples' summaries. When both standard errors are zero (identical repeats) the
/// interval is the difference itself; NaN ends when either sample has fewer than two
/// values.
pub fn welch_interval(a: &SampleSummary, b: &SampleSummary, confidence: f64) -> WelchInterval {
    let difference = a.mean - b.mean;
    let va = a.standard_error * a.standard_error;
    let vb = b.standard_error * b.standard_error;
    let spread = (va + vb).sqrt();
    if spread == 0.0 {
        return WelchInterval {
            difference,
            degrees_of_freedom: f64::INFINITY,
            low: difference,
            high: difference,
        };
    }
    let term = |v: f64, n: usize| {
        if v == 0.0 {
            0.0
        } else {
            v * v / (n as f64 - 1.0)
        }
    };
    let degrees_of_freedom = (va + vb).powi(2) / (term(va, a.count) + term(vb, b.count));
    let t = student_t_quantile(0.5 + 0.5 * confidence, degrees_of_freedom);
    WelchInterval {
        difference,
        degrees_of_freedom,
        low: difference - t * spread,
        high: difference + t * spread,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two-sided critical values t_{0.975, ν} and one-sided t_{0.95, ν}, from the
    /// standard table (e.g. NIST/SEMATECH e-Handbook, 1.3.6.7.2), to the table's
    /// three decimals.
    const TABLE: &[(f64, f64, f64)] = &[
        (1.0, 12.706, 6.314),
        (2.0, 4.303, 2.920),
        (3.0, 3.182, 2.353),
        (4.0, 2.776, 2.132),
        (5.0, 2.571, 2.015),
        (10.0, 2.228, 1.812),
        (20.0, 2.086, 1.725),
        (30.0, 2.042, 1.697),
        (100.0, 1.984, 1.660),
    ];

    #[test]
    fn quantiles_match_the_table() {
        for &(nu, t975, t95) in TABLE {
            let q = student_t_quantile(0.975, nu);
            assert!((q - t975).abs() < 6e-4, "ν = {nu}: {q} against {t975}");
            let q = student_t_quantile(0.95, nu);
            assert!((q - t95).abs() < 6e-4, "ν = {nu}: {q} against {t95}");
            let q = student_t_quantile(0.025, nu);
            assert!((q + t975).abs() < 6e-4, "ν = {nu}: {q} against -{t975}");
        }
    }

    #[test]
    fn closed_forms_and_the_normal_limit() {
        // ν = 1 is Cauchy: tan(π (p − ½)); ν = 2: (2p − 1) √(2 / (4p(1 − p))).
        for p in [0.6, 0.9, 0.975, 0.999] {
            let cauchy = (std::f64::consts::PI * (p - 0.5)).tan();
            assert!((student_t_quantile(p, 1.0) - cauchy).abs() < 1e-9 * cauchy.max(1.0));
            let two = (2.0 * p - 1.0) * (2.0 / (4.0 * p * (1.0 - p))).sqrt();
            assert!((student_t_quantile(p, 2.0) - two).abs() < 1e-9 * two.max(1.0));
        }
        assert!((student_t_quantile(0.975, 1e7) - 1.959_964).abs() < 1e-5);
        assert!(student_t_quantile(1.0, 3.0).is_nan());
        assert!(student_t_quantile(0.5, 3.0) == 0.0);
        // A real ν lies between its integer neighbours.
        let q = student_t_quantile(0.975, 3.5);
        assert!(q < 3.182 && q > 2.776, "{q}");
    }

    #[test]
    fn welch_interval_of_a_textbook_example() {
        // Two samples with known means, variances and counts; ν and the interval by
        // hand: va = 4/5, vb = 9/10, ν = 1.7² / (0.64/4 + 0.81/9) = 11.56.
        let a = SampleSummary {
            mean: 10.0,
            standard_error: (4.0f64 / 5.0).sqrt(),
            count: 5,
        };
        let b = SampleSummary {
            mean: 8.0,
            standard_error: (9.0f64 / 10.0).sqrt(),
            count: 10,
        };
        let w = welch_interval(&a, &b, 0.95);
        assert!((w.degrees_of_freedom - 11.56).abs() < 1e-9, "{w:?}");
        let t = student_t_quantile(0.975, 11.56);
        assert!(t > 2.179 && t < 2.201, "{t}"); // between t(12) and t(11)
        assert!((w.high - 2.0 - t * 1.7f64.sqrt()).abs() < 1e-12);
        assert!((w.low - 2.0 + t * 1.7f64.sqrt()).abs() < 1e-12);
        let s = SampleSummary::of(&[1.0, 2.0, 3.0, 4.0]).unwrap();
        assert_eq!(s.mean, 2.5);
        assert!((s.standard_error - (5.0f64 / 12.0).sqrt()).abs() < 1e-12);
    }

    /// Upper critical values `F_{1−α}(d1, d2)` from the standard tables (NIST/SEMATECH
    /// e-Handbook, 1.3.6.7.3, "Upper critical values of the F distribution"), to the
    /// tables' three decimals.
    const F_TABLE: &[(f64, f64, f64, f64)] = &[
        // (1 − α, d1, d2, critical value)
        (0.95, 3.0, 10.0, 3.708),
        (0.95, 1.0, 10.0, 4.965),
        (0.95, 5.0, 20.0, 2.711),
        (0.95, 2.0, 10.0, 4.103),
        (0.95, 10.0, 10.0, 2.978),
        (0.99, 2.0, 20.0, 5.849),
        (0.99, 10.0, 10.0, 4.849),
        (0.99, 1.0, 1.0, 4052.181),
    ];

    #[test]
    fn f_critical_values_match_the_table() {
        for &(p, d1, d2, critical) in F_TABLE {
            let cdf = f_cdf(critical, d1, d2);
            // Three printed decimals: the table's value is within 5e-4 of the true one.
            let slope = (f_cdf(critical + 5e-4, d1, d2) - f_cdf(critical - 5e-4, d1, d2)).abs();
            assert!(
                (cdf - p).abs() <= slope + 1e-9,
                "F({d1}, {d2}) at {critical}: {cdf} against {p}"
            );
            let q = f_quantile(p, d1, d2);
            assert!(
                (q - critical).abs() < 6e-4 * critical.max(1.0),
                "F_{p}({d1}, {d2}) = {q} against {critical}"
            );
            assert!((f_survival(critical, d1, d2) - (1.0 - cdf)).abs() < 1e-12);
        }
        // The NIST load-cell case study (e-Handbook 4.6.1.5) quotes F_{0.05}(18, 20) = 2.15.
        assert!((f_quantile(0.95, 18.0, 20.0) - 2.15).abs() < 5e-3);
    }

    #[test]
    fn f_closed_forms() {
        // F(1, ν) is the square of t(ν): P(F ≤ t²) = 2 P(T ≤ t) − 1.
        for (t, nu) in [(0.5, 3.0), (2.0, 7.5), (4.0, 30.0)] {
            let f = f_cdf(t * t, 1.0, nu);
            assert!(
                (f - (2.0 * student_t_cdf(t, nu) - 1.0)).abs() < 1e-12,
                "{t} {nu}"
            );
        }
        // d1 = 2: P(F > f) = (1 + 2f/d2)^(−d2/2).
        for (f, d2) in [(0.3f64, 4.0f64), (3.0, 11.0), (40.0, 25.0)] {
            let exact = (1.0 + 2.0 * f / d2).powf(-0.5 * d2);
            assert!((f_survival(f, 2.0, d2) - exact).abs() < 1e-12 * exact.max(1e-300) + 1e-15);
        }
        // A tiny p-value keeps its relative precision in the upper tail.
        let exact = (1.0 + 2.0 * 1e4 / 20.0f64).powf(-10.0);
        assert!((f_survival(1e4, 2.0, 20.0) / exact - 1.0).abs() < 1e-9);
        assert_eq!(f_cdf(0.0, 3.0, 4.0), 0.0);
        assert_eq!(f_survival(-1.0, 3.0, 4.0), 1.0);
        assert!(f_cdf(1.0, 0.0, 4.0).is_nan());
        assert!(f_quantile(1.0, 3.0, 4.0).is_nan());
    }
}
