use crate::math::{Real, Vec3};

/// Which part of a triangle a closest point lies on. A sphere touching two triangles at
/// their shared edge or vertex must be counted once, so the feature is part of a
/// contact's identity.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum TriangleFeature {
    /// The interior of the face.
    Face,
    /// Edge `k`, joining corners `k` and `(k + 1) % 3`.
    Edge(u8),
    /// Corner `k`.
    Vertex(u8),
}

/// The point of a triangle closest to a query point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrianglePoint {
    /// The closest point, m.
    pub point: Vec3,
    /// The feature it lies on.
    pub feature: TriangleFeature,
}

/// The point of triangle `(a, b, c)` closest to `p`, by Voronoi regions of the
/// corners, edges and face (Ericson, Real-Time Collision Detection, §5.1.5).
#[inline]
pub fn closest_point_on_triangle(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> TrianglePoint {
    let at = |point, feature| TrianglePoint { point, feature };
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(&ap);
    let d2 = ac.dot(&ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return at(a, TriangleFeature::Vertex(0));
    }
    let bp = p - b;
    let d3 = ab.dot(&bp);
    let d4 = ac.dot(&bp);
    if d3 >= 0.0 && d4 <= d3 {
        return at(b, TriangleFeature::Vertex(1));
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return at(a + v * ab, TriangleFeature::Edge(0));
    }
    let cp = p - c;
    let d5 = ab.dot(&cp);
    let d6 = ac.dot(&cp);
    if d6 >= 0.0 && d5 <= d6 {
        return at(c, TriangleFeature::Vertex(2));
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return at(a + w * ac, TriangleFeature::Edge(2));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return at(b + w * (c - b), TriangleFeature::Edge(1));
    }
    let denominator = 1.0 / (va + vb + vc);
    let v = vb * denominator;
    let w = vc * denominator;
    at(a + ab * v + ac * w, TriangleFeature::Face)
}

/// Squared distance from `p` to triangle `(a, b, c)`, m².
#[inline]
pub fn distance_squared_to_triangle(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> Real {
    (p - closest_point_on_triangle(p, a, b, c).point).norm_squared()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn triangle() -> (Vec3, Vec3, Vec3) {
        (Vec3::zeros(), Vec3::x(), Vec3::y())
    }

    #[test]
    fn each_voronoi_region_reports_its_feature() {
        let (a, b, c) = triangle();
        let cases = [
            (Vec3::new(0.2, 0.2, 1.0), TriangleFeature::Face),
            (Vec3::new(-1.0, -1.0, 0.0), TriangleFeature::Vertex(0)),
            (Vec3::new(2.0, -0.1, 0.0), TriangleFeature::Vertex(1)),
            (Vec3::new(-0.1, 2.0, 0.0), TriangleFeature::Vertex(2)),
            (Vec3::new(0.5, -1.0, 0.3), TriangleFeature::Edge(0)),
            (Vec3::new(1.0, 1.0, 0.0), TriangleFeature::Edge(1)),
            (Vec3::new(-1.0, 0.5, 0.0), TriangleFeature::Edge(2)),
        ];
        for (p, feature) in cases {
            assert_eq!(
                closest_point_on_triangle(p, a, b, c).feature,
                feature,
                "{p:?}"
            );
        }
        let face = closest_point_on_triangle(Vec3::new(0.2, 0.3, -0.7), a, b, c);
        assert!((face.point - Vec3::new(0.2, 0.3, 0.0)).norm() < 1e-15);
    }

    proptest! {
        /// No point of the triangle (sampled by barycentric coordinates) is closer.
        #[test]
        fn the_closest_point_is_closest(
            px in -2.0..2.0f64, py in -2.0..2.0f64, pz in -2.0..2.0f64,
            u in 0.0..1.0f64, v in 0.0..1.0f64,
        ) {
            let (a, b, c) = (Vec3::new(0.1, 0.0, 0.2), Vec3::new(1.0, 0.3, 0.0), Vec3::new(0.2, 0.9, -0.4));
            let p = Vec3::new(px, py, pz);
            let best = distance_squared_to_triangle(p, a, b, c);
            let (u, v) = if u + v > 1.0 { (1.0 - u, 1.0 - v) } else { (u, v) };
            let sample = a + u * (b - a) + v * (c - a);
            prop_assert!(best <= (p - sample).norm_squared() + 1e-12);
        }
    }
}
