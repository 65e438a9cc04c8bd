//! The wall profile of the conical section as a clamped B-spline (the thesis's shape
//! variables).
//!
//! The straight cone runs from the outlet rim `P0 = (r_outlet, 0)` to the top rim
//! `P3 = (r_top, h)` in the `(r, z)` half-plane. Two interior control points sit at a
//! third and two thirds of that line and are moved along its normal:
//!
//! - `P1 = P0 + (P3 − P0)/3 + x1 · n`
//! - `P2 = P0 + 2 (P3 − P0)/3 − x2 · n`
//!
//! where `n` is the unit normal pointing away from the axis. The signs follow the
//! thesis's design box (SCIENCE.md §6): `(x1, x2) = (0, 0)` is the straight cone,
//! `(min x1, max x2)` moves both points towards the axis (a concave wall: steep at the
//! outlet, flaring at the top) and `(max x1, min x2)` moves both away from it (convex).
//!
//! The curve is clamped (it passes through both rims) and of degree 2 or 3 over the four
//! control points. A profile is usable when its height rises monotonically along the
//! curve (it cannot fold back on itself, so the revolved wall cannot self-intersect) and
//! it stays inside the box `r_outlet ≤ r ≤ r_top`, `0 ≤ z ≤ h`.

/// Samples along the curve used by the checks and by [`ConeProfile::radius_at`].
const CHECK_SAMPLES: usize = 400;

/// A cone wall profile: outlet and top rims plus the two normal offsets.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConeProfile {
    /// Radius of the outlet rim at `z = 0`, m.
    pub outlet_radius_m: f64,
    /// Radius of the top rim at `z = height_m`, m.
    pub top_radius_m: f64,
    /// Height of the conical section, m.
    pub height_m: f64,
    /// Offset of the lower interior control point away from the axis, m.
    pub x1_m: f64,
    /// Offset of the upper interior control point towards the axis, m.
    pub x2_m: f64,
    /// B-spline degree, 2 or 3.
    pub degree: usize,
}

/// Why a profile cannot be built, with the offending values.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ProfileError {
    /// The degree is not 2 or 3.
    #[error("shape_degree must be 2 or 3, got {0}")]
    BadDegree(usize),
    /// The curve turns downwards: the revolved wall would fold onto itself.
    #[error(
        "the cone profile with shape_x1 = {x1_m} m and shape_x2 = {x2_m} m folds back on itself near z = {z_m:.4} m (its height stops rising); use smaller offsets"
    )]
    SelfIntersecting {
        /// Offset x1, m.
        x1_m: f64,
        /// Offset x2, m.
        x2_m: f64,
        /// Height where the curve stops rising, m.
        z_m: f64,
    },
    /// The curve leaves the box between the two rims.
    #[error(
        "the cone profile with shape_x1 = {x1_m} m and shape_x2 = {x2_m} m reaches radius {r_m:.4} m at z = {z_m:.4} m, outside the outlet-to-top range {min_m:.4}..{max_m:.4} m; use smaller offsets"
    )]
    OutsideBox {
        /// Offset x1, m.
        x1_m: f64,
        /// Offset x2, m.
        x2_m: f64,
        /// Radius reached, m.
        r_m: f64,
        /// Height where it is reached, m.
        z_m: f64,
        /// Smallest radius allowed (the outlet's), m.
        min_m: f64,
        /// Largest radius allowed (the top rim's), m.
        max_m: f64,
    },
}

impl ConeProfile {
    /// The four control points `(r, z)`, m.
    pub fn control_points(&self) -> [(f64, f64); 4] {
        let p0 = (self.outlet_radius_m, 0.0);
        let p3 = (self.top_radius_m, self.height_m);
        let (dr, dz) = (p3.0 - p0.0, p3.1 - p0.1);
        let length = dr.hypot(dz);
        // Normal pointing away from the axis: the direction (dr, dz) turned clockwise.
        let normal = (dz / length, -dr / length);
        let along = |s: f64, offset: f64| {
            (
                p0.0 + s * dr + offset * normal.0,
                p0.1 + s * dz + offset * normal.1,
            )
        };
        [
            p0,
            along(1.0 / 3.0, self.x1_m),
            along(2.0 / 3.0, -self.x2_m),
            p3,
        ]
    }

    /// True for the straight cone (both offsets zero).
    pub fn is_straight(&self) -> bool {
        self.x1_m == 0.0 && self.x2_m == 0.0
    }

    /// The point `(r, z)` at curve parameter `t` in `[0, 1]`.
    pub fn point(&self, t: f64) -> (f64, f64) {
        de_boor(&self.control_points(), &self.knots(), self.degree, t)
    }

    /// `samples + 1` points from the outlet rim to the top rim, evenly spaced in the
    /// curve parameter; the first and last are exactly the rims.
    pub fn points(&self, samples: usize) -> Vec<(f64, f64)> {
        let samples = samples.max(1);
        let mut points: Vec<(f64, f64)> = (0..=samples)
            .map(|i| self.point(i as f64 / samples as f64))
            .collect();
        points[0] = (self.outlet_radius_m, 0.0);
        points[samples] = (self.top_radius_m, self.height_m);
        points
    }

    /// Checks the degree, that the curve keeps rising and that it stays in the box.
    pub fn validate(&self) -> Result<(), ProfileError> {
        if !(2..=3).contains(&self.degree) {
            return Err(ProfileError::BadDegree(self.degree));
        }
        let tolerance = 1e-9 * self.height_m.max(self.top_radius_m);
        let points = self.points(CHECK_SAMPLES);
        for pair in points.windows(2) {
            if pair[1].1 <= pair[0].1 {
                return Err(ProfileError::SelfIntersecting {
                    x1_m: self.x1_m,
                    x2_m: self.x2_m,
                    z_m: pair[0].1,
                });
            }
        }
        for &(r, z) in &points {
            if r < self.outlet_radius_m - tolerance || r > self.top_radius_m + tolerance {
                return Err(ProfileError::OutsideBox {
                    x1_m: self.x1_m,
                    x2_m: self.x2_m,
                    r_m: r,
                    z_m: z,
                    min_m: self.outlet_radius_m,
                    max_m: self.top_radius_m,
                });
            }
        }
        Ok(())
    }

    /// Wall radius at height `z_m` (clamped to the section), m. Exact for the straight
    /// cone; for a curved profile found by bisection on the rising curve.
    pub fn radius_at(&self, z_m: f64) -> f64 {
        let z = z_m.clamp(0.0, self.height_m);
        if self.is_straight() {
            return self.outlet_radius_m
                + (self.top_radius_m - self.outlet_radius_m) * z / self.height_m;
        }
        let (mut lo, mut hi) = (0.0, 1.0);
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if self.point(mid).1 < z {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        self.point(0.5 * (lo + hi)).0
    }

    /// Clamped uniform knot vector for four control points.
    fn knots(&self) -> Vec<f64> {
        clamped_knots(self.degree)
    }
}

/// Clamped uniform knot vector for four control points and a degree of 2 or 3.
pub(crate) fn clamped_knots(degree: usize) -> Vec<f64> {
    let p = degree;
    let interior = 4 - p - 1;
    let mut knots = vec![0.0; p + 1];
    knots.extend((1..=interior).map(|i| i as f64 / (interior + 1) as f64));
    knots.extend(std::iter::repeat_n(1.0, p + 1));
    knots
}

/// De Boor's algorithm: the B-spline of `degree` over `control` and `knots` at `t`.
pub(crate) fn de_boor(control: &[(f64, f64)], knots: &[f64], degree: usize, t: f64) -> (f64, f64) {
    let n = control.len();
    let t = t.clamp(0.0, 1.0);
    // The knot span [knots[k], knots[k + 1]) holding t; t = 1 belongs to the last one.
    let k = (degree..n).rev().find(|&k| knots[k] <= t).unwrap_or(degree);
    let mut d: Vec<(f64, f64)> = (0..=degree).map(|j| control[j + k - degree]).collect();
    for r in 1..=degree {
        for j in (r..=degree).rev() {
            let i = j + k - degree;
            let denominator = knots[i + degree + 1 - r] - knots[i];
            let alpha = if denominator == 0.0 {
                0.0
            } else {
                (t - knots[i]) / denominator
            };
            d[j] = (
                (1.0 - alpha) * d[j - 1].0 + alpha * d[j].0,
                (1.0 - alpha) * d[j - 1].1 + alpha * d[j].1,
            );
        }
    }
    d[degree]
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn profile(x1_m: f64, x2_m: f64, degree: usize) -> ConeProfile {
        ConeProfile {
            outlet_radius_m: 0.012,
            top_radius_m: 0.040,
            height_m: 0.040,
            x1_m,
            x2_m,
            degree,
        }
    }

    #[test]
    fn straight_profile_is_the_cone_line() {
        for degree in [2, 3] {
            let p = profile(0.0, 0.0, degree);
            p.validate().unwrap();
            for (r, z) in p.points(50) {
                let line = 0.012 + 0.028 * z / 0.040;
                assert!((r - line).abs() < 1e-12, "degree {degree}: {r} vs {line}");
            }
        }
    }

    #[test]
    fn cubic_profile_is_the_bezier_curve_of_its_control_points() {
        let p = profile(-0.004, 0.006, 3);
        let c = p.control_points();
        for t in [0.0, 0.2, 0.5, 0.77, 1.0] {
            let s = 1.0 - t;
            let w = [s * s * s, 3.0 * s * s * t, 3.0 * s * t * t, t * t * t];
            let r: f64 = (0..4).map(|i| w[i] * c[i].0).sum();
            let z: f64 = (0..4).map(|i| w[i] * c[i].1).sum();
            let (pr, pz) = p.point(t);
            assert!((pr - r).abs() < 1e-15 && (pz - z).abs() < 1e-15);
        }
    }

    #[test]
    fn quadratic_profile_passes_the_rims_and_the_knot_midpoint() {
        let p = profile(0.003, -0.002, 2);
        assert_eq!(p.point(0.0), (0.012, 0.0));
        let end = p.point(1.0);
        assert!((end.0 - 0.040).abs() < 1e-15 && (end.1 - 0.040).abs() < 1e-15);
        // Knots 0 0 0 ½ 1 1 1: at t = ½ the curve is the midpoint of P1 and P2.
        let c = p.control_points();
        let mid = p.point(0.5);
        assert!((mid.0 - 0.5 * (c[1].0 + c[2].0)).abs() < 1e-15);
        assert!((mid.1 - 0.5 * (c[1].1 + c[2].1)).abs() < 1e-15);
    }

    #[test]
    fn concave_corner_bends_towards_the_axis_and_convex_away() {
        let straight = profile(0.0, 0.0, 3);
        let concave = profile(-0.006, 0.006, 3);
        let convex = profile(0.006, -0.006, 3);
        for p in [concave, convex] {
            p.validate().unwrap();
        }
        for z in [0.01, 0.02, 0.03] {
            assert!(concave.radius_at(z) < straight.radius_at(z) - 1e-3);
            assert!(convex.radius_at(z) > straight.radius_at(z) + 1e-3);
        }
    }

    #[test]
    fn folding_and_escaping_profiles_are_refused_with_their_values() {
        let folded = profile(0.0, 0.0, 3);
        let folded = ConeProfile {
            x1_m: 0.030,
            x2_m: -0.030,
            ..folded
        };
        let message = folded.validate().unwrap_err().to_string();
        assert!(message.contains("shape_x1 = 0.03 m"), "{message}");
        assert!(
            matches!(
                folded.validate(),
                Err(ProfileError::SelfIntersecting { .. }) | Err(ProfileError::OutsideBox { .. })
            ),
            "{message}"
        );
        // Pushed well inside at the outlet: the throat is narrower than the outlet.
        let narrow = profile(-0.015, 0.0, 3);
        assert!(matches!(
            narrow.validate(),
            Err(ProfileError::OutsideBox { .. })
        ));
        // Pushed far outwards: wider than the top rim.
        let wide = profile(0.0, -0.016, 3);
        let error = wide.validate().unwrap_err();
        assert!(
            matches!(error, ProfileError::OutsideBox { r_m, .. } if r_m > 0.040),
            "{error}"
        );
        // Rising curve, nearly horizontal: folds.
        let flat = ConeProfile {
            height_m: 0.004,
            ..profile(0.0, 0.0, 3)
        };
        let flat = ConeProfile { x1_m: 0.01, ..flat };
        assert!(flat.validate().is_err());
        assert_eq!(
            profile(0.0, 0.0, 4).validate(),
            Err(ProfileError::BadDegree(4))
        );
    }

    proptest! {
        /// radius_at inverts the curve: the point at height z has that radius.
        #[test]
        fn radius_at_inverts_valid_profiles(
            x1 in -0.008f64..0.008,
            x2 in -0.008f64..0.008,
            degree in 2usize..=3,
            t in 0.0f64..1.0,
        ) {
            let p = profile(x1, x2, degree);
            prop_assume!(p.validate().is_ok());
            let (r, z) = p.point(t);
            prop_assert!((p.radius_at(z) - r).abs() < 1e-9);
        }
    }
}
