//! The transfer chute: a curved plate in the x–z plane, extruded across a width, with
//! side walls, a back wall at the inlet and a receiving plane (the belt) below the lip.
//!
//! Coordinates: material flows in `+x`, `z` is up, the chute is symmetric about
//! `y = 0`. The straight chute runs from the inlet point `P0 = (0, L sin θ)` down to the
//! lip `P3 = (L cos θ, 0)`, where `L` is `length_m` and `θ` is `angle_deg` from the
//! horizontal. As for the hopper cone ([`crate::ConeProfile`]), two interior control
//! points sit at a third and two thirds of that line and move along its normal `n`,
//! the unit normal pointing *away from the material* (downwards, into the plate):
//!
//! - `P1 = P0 + (P3 − P0)/3 + x1 · n`
//! - `P2 = P0 + 2 (P3 − P0)/3 − x2 · n`
//!
//! So `(x1, x2) = (0, 0)` is the straight chute; `x1 > 0, x2 < 0` sags both points
//! (a "spoon": steep at the inlet, flatter at the lip); `x1 < 0, x2 > 0` humps them
//! (flat at the inlet, steep at the lip). The curve is a clamped B-spline of degree 2
//! or 3. A profile is usable when `x` rises along the curve (it cannot fold back) and
//! it stays in the box between the inlet and the lip.
//!
//! The receiving plane is the horizontal plane `z = −drop_height_m`.

use crate::mesh::TriMesh;
use crate::profile::{clamped_knots, de_boor};

/// Samples along the curve used by the checks.
const CHECK_SAMPLES: usize = 400;

/// The shape of a transfer chute, lengths in metres.
#[derive(Debug, Clone, PartialEq)]
pub struct ChuteGeometry {
    /// Length of the straight line from the inlet point to the lip, m.
    pub length_m: f64,
    /// Angle of that line below the horizontal, degrees, in (0, 90).
    pub angle_deg: f64,
    /// Width of the chute across the flow (y), m.
    pub width_m: f64,
    /// Height of the lip above the receiving plane, m.
    pub drop_height_m: f64,
    /// Height of the side and back walls above the chute surface, m.
    pub side_height_m: f64,
    /// Offset of the lower-x interior control point away from the material, m (X1).
    pub shape_x1_m: f64,
    /// Offset of the upper-x interior control point towards the material, m (X2).
    pub shape_x2_m: f64,
    /// B-spline degree, 2 or 3.
    pub shape_degree: usize,
    /// Facets along the profile (each is split into two triangles per width strip).
    pub segments: usize,
    /// Strips across the width.
    pub width_segments: usize,
}

/// A chute that cannot be built, with the offending value.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ChuteError {
    /// A length that must be positive is not.
    #[error("{name} must be positive and finite, got {value} m")]
    NotPositive {
        /// Parameter name.
        name: &'static str,
        /// Its value.
        value: f64,
    },
    /// The chute angle is outside (0°, 90°).
    #[error("chute_angle must lie strictly between 0 and 90 degrees, got {0}")]
    BadAngle(f64),
    /// The degree is not 2 or 3.
    #[error("shape_degree must be 2 or 3, got {0}")]
    BadDegree(usize),
    /// Too few facets along the profile or across the width.
    #[error("the chute needs at least 4 segments along its profile and 1 across, got {0} and {1}")]
    TooFewSegments(usize, usize),
    /// The curve turns back against the flow.
    #[error(
        "the chute profile with shape_x1 = {x1_m} m and shape_x2 = {x2_m} m folds back on itself near x = {x_m:.4} m (x stops rising along it); use smaller offsets"
    )]
    Folding {
        /// Offset x1, m.
        x1_m: f64,
        /// Offset x2, m.
        x2_m: f64,
        /// Where x stops rising, m.
        x_m: f64,
    },
    /// The curve leaves the box between the inlet and the lip.
    #[error(
        "the chute profile with shape_x1 = {x1_m} m and shape_x2 = {x2_m} m reaches ({x_m:.4}, {z_m:.4}) m, outside the box from the inlet (0, {top_m:.4}) to the lip ({lip_x_m:.4}, 0); use smaller offsets"
    )]
    OutsideBox {
        /// Offset x1, m.
        x1_m: f64,
        /// Offset x2, m.
        x2_m: f64,
        /// Point reached, m.
        x_m: f64,
        /// See `x_m`.
        z_m: f64,
        /// Inlet height, m.
        top_m: f64,
        /// Lip position, m.
        lip_x_m: f64,
    },
}

impl ChuteGeometry {
    /// The inlet point `(x, z)`, m: the top of the chute.
    pub fn inlet(&self) -> (f64, f64) {
        (0.0, self.length_m * self.angle_deg.to_radians().sin())
    }

    /// The lip `(x, z)`, m: the bottom end of the chute, at `z = 0`.
    pub fn lip(&self) -> (f64, f64) {
        (self.length_m * self.angle_deg.to_radians().cos(), 0.0)
    }

    /// Height of the receiving plane, m (`−drop_height_m`).
    pub fn receiving_plane_z_m(&self) -> f64 {
        -self.drop_height_m
    }

    /// The four control points `(x, z)`, m.
    pub fn control_points(&self) -> [(f64, f64); 4] {
        let p0 = self.inlet();
        let p3 = self.lip();
        let (dx, dz) = (p3.0 - p0.0, p3.1 - p0.1);
        let length = dx.hypot(dz);
        // Normal away from the material (below the plate): (dx, dz) turned clockwise.
        let normal = (dz / length, -dx / length);
        let along = |s: f64, offset: f64| {
            (
                p0.0 + s * dx + offset * normal.0,
                p0.1 + s * dz + offset * normal.1,
            )
        };
        [
            p0,
            along(1.0 / 3.0, self.shape_x1_m),
            along(2.0 / 3.0, -self.shape_x2_m),
            p3,
        ]
    }

    /// The profile point `(x, z)` at curve parameter `t` in `[0, 1]`.
    pub fn point(&self, t: f64) -> (f64, f64) {
        de_boor(
            &self.control_points(),
            &clamped_knots(self.shape_degree),
            self.shape_degree,
            t,
        )
    }

    /// `samples + 1` profile points from the inlet to the lip; the ends are exact.
    pub fn profile_points(&self, samples: usize) -> Vec<(f64, f64)> {
        let samples = samples.max(1);
        let mut points: Vec<(f64, f64)> = (0..=samples)
            .map(|i| self.point(i as f64 / samples as f64))
            .collect();
        points[0] = self.inlet();
        points[samples] = self.lip();
        points
    }

    /// Angle of the surface below the horizontal at the lip, degrees: the direction in
    /// which a particle sliding along the chute leaves it (the clamped curve is tangent
    /// to `P3 − P2` there).
    pub fn lip_angle_deg(&self) -> f64 {
        let [_, _, p2, p3] = self.control_points();
        (p2.1 - p3.1).atan2(p3.0 - p2.0).to_degrees()
    }

    /// Checks every parameter and the profile; the meshes assume a valid geometry.
    pub fn validate(&self) -> Result<(), ChuteError> {
        for (name, value) in [
            ("chute_length", self.length_m),
            ("chute_width", self.width_m),
            ("drop_height", self.drop_height_m),
            ("side_height", self.side_height_m),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(ChuteError::NotPositive { name, value });
            }
        }
        if !(self.angle_deg > 0.0 && self.angle_deg < 90.0) {
            return Err(ChuteError::BadAngle(self.angle_deg));
        }
        if !(2..=3).contains(&self.shape_degree) {
            return Err(ChuteError::BadDegree(self.shape_degree));
        }
        if self.segments < 4 || self.width_segments < 1 {
            return Err(ChuteError::TooFewSegments(
                self.segments,
                self.width_segments,
            ));
        }
        let (top, lip_x) = (self.inlet().1, self.lip().0);
        let tolerance = 1e-9 * self.length_m;
        let points = self.profile_points(CHECK_SAMPLES);
        for pair in points.windows(2) {
            if pair[1].0 <= pair[0].0 {
                return Err(ChuteError::Folding {
                    x1_m: self.shape_x1_m,
                    x2_m: self.shape_x2_m,
                    x_m: pair[0].0,
                });
            }
        }
        for &(x, z) in &points {
            let inside = (-tolerance..=lip_x + tolerance).contains(&x)
                && (-tolerance..=top + tolerance).contains(&z);
            if !inside {
                return Err(ChuteError::OutsideBox {
                    x1_m: self.shape_x1_m,
                    x2_m: self.shape_x2_m,
                    x_m: x,
                    z_m: z,
                    top_m: top,
                    lip_x_m: lip_x,
                });
            }
        }
        Ok(())
    }

    /// The chute plate: the profile extruded across `y ∈ [−w/2, w/2]`, normals up
    /// (towards the material). `2 · segments · width_segments` triangles.
    pub fn surface_mesh(&self) -> TriMesh {
        let profile = self.profile_points(self.segments);
        let columns = self.width_segments + 1;
        let half = 0.5 * self.width_m;
        let mut mesh = TriMesh::default();
        for &(x, z) in &profile {
            for j in 0..columns {
                let y = -half + self.width_m * j as f64 / self.width_segments as f64;
                mesh.vertices.push([x, y, z]);
            }
        }
        let index = |i: usize, j: usize| (i * columns + j) as u32;
        for i in 0..self.segments {
            for j in 0..self.width_segments {
                let (a, b) = (index(i, j), index(i + 1, j));
                let (c, d) = (index(i + 1, j + 1), index(i, j + 1));
                mesh.triangles.push([a, b, c]);
                mesh.triangles.push([a, c, d]);
            }
        }
        mesh
    }

    /// The two side walls at `y = ±w/2`, from the profile up by `side_height_m`, normals
    /// pointing inwards. `4 · segments` triangles.
    pub fn side_walls_mesh(&self) -> TriMesh {
        let profile = self.profile_points(self.segments);
        let half = 0.5 * self.width_m;
        let h = self.side_height_m;
        let mut mesh = TriMesh::default();
        for (side, y) in [(0, -half), (1, half)] {
            let start = mesh.vertices.len() as u32;
            for &(x, z) in &profile {
                mesh.vertices.push([x, y, z]);
                mesh.vertices.push([x, y, z + h]);
            }
            for i in 0..self.segments as u32 {
                let (bottom, top) = (start + 2 * i, start + 2 * i + 1);
                let (next_bottom, next_top) = (bottom + 2, top + 2);
                // Seen from inside (+y at y = −w/2) counter-clockwise.
                let pair = [[bottom, top, next_bottom], [top, next_top, next_bottom]];
                for [a, b, c] in pair {
                    mesh.triangles
                        .push(if side == 0 { [a, b, c] } else { [a, c, b] });
                }
            }
        }
        mesh
    }

    /// The back wall at the inlet (`x = 0`), across the width and from the inlet point
    /// up by `side_height_m`, normal along `+x`. Two triangles.
    pub fn back_wall_mesh(&self) -> TriMesh {
        let (x, z) = self.inlet();
        let half = 0.5 * self.width_m;
        let top = z + self.side_height_m;
        TriMesh {
            vertices: vec![[x, -half, z], [x, half, z], [x, half, top], [x, -half, top]],
            triangles: vec![[0, 1, 2], [0, 2, 3]],
        }
    }

    /// Every wall of the chute in one mesh: plate, side walls and back wall.
    pub fn wall_mesh(&self) -> TriMesh {
        let mut mesh = self.surface_mesh();
        mesh.append(&self.side_walls_mesh());
        mesh.append(&self.back_wall_mesh());
        mesh
    }

    /// The receiving plane as a rectangle at `z_m` from `x = 0` to `x_max_m` and
    /// `|y| ≤ half_width_m`, normal up. Two triangles.
    pub fn receiving_plane_mesh(&self, x_max_m: f64, half_width_m: f64, z_m: f64) -> TriMesh {
        let h = half_width_m;
        TriMesh {
            vertices: vec![
                [0.0, -h, z_m],
                [x_max_m, -h, z_m],
                [x_max_m, h, z_m],
                [0.0, h, z_m],
            ],
            triangles: vec![[0, 1, 2], [0, 2, 3]],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn chute(x1_m: f64, x2_m: f64, degree: usize) -> ChuteGeometry {
        ChuteGeometry {
            length_m: 0.3,
            angle_deg: 40.0,
            width_m: 0.06,
            drop_height_m: 0.1,
            side_height_m: 0.04,
            shape_x1_m: x1_m,
            shape_x2_m: x2_m,
            shape_degree: degree,
            segments: 24,
            width_segments: 3,
        }
    }

    #[test]
    fn straight_profile_is_the_line_at_the_chute_angle() {
        for degree in [2, 3] {
            let c = chute(0.0, 0.0, degree);
            c.validate().unwrap();
            let (lip_x, top) = (c.lip().0, c.inlet().1);
            assert!((lip_x - 0.3 * 40f64.to_radians().cos()).abs() < 1e-15);
            assert!((top - 0.3 * 40f64.to_radians().sin()).abs() < 1e-15);
            for (x, z) in c.profile_points(50) {
                let line = top * (1.0 - x / lip_x);
                assert!((z - line).abs() < 1e-12, "degree {degree}: {z} vs {line}");
            }
            assert!((c.lip_angle_deg() - 40.0).abs() < 1e-9);
        }
    }

    #[test]
    fn sagging_offsets_flatten_the_lip_and_humping_offsets_steepen_it() {
        let straight = chute(0.0, 0.0, 3);
        let spoon = chute(0.03, -0.03, 3);
        let hump = chute(-0.03, 0.03, 3);
        spoon.validate().unwrap();
        hump.validate().unwrap();
        assert!(spoon.lip_angle_deg() < straight.lip_angle_deg() - 5.0);
        assert!(hump.lip_angle_deg() > straight.lip_angle_deg() + 5.0);
        // The spoon lies below the straight line, the hump above.
        let (sx, sz) = spoon.point(0.5);
        let (hx, hz) = hump.point(0.5);
        let line = |x: f64| straight.inlet().1 * (1.0 - x / straight.lip().0);
        assert!(sz < line(sx) - 0.01 && hz > line(hx) + 0.01);
    }

    #[test]
    fn bad_chutes_are_refused_with_their_values() {
        let escaping = chute(0.2, -0.2, 3);
        let message = escaping.validate().unwrap_err().to_string();
        assert!(message.contains("shape_x1 = 0.2 m"), "{message}");
        assert_eq!(chute(0.0, 0.0, 4).validate(), Err(ChuteError::BadDegree(4)));
        let flat = ChuteGeometry {
            angle_deg: 90.0,
            ..chute(0.0, 0.0, 3)
        };
        assert_eq!(flat.validate(), Err(ChuteError::BadAngle(90.0)));
        let narrow = ChuteGeometry {
            width_m: 0.0,
            ..chute(0.0, 0.0, 3)
        };
        assert!(narrow
            .validate()
            .unwrap_err()
            .to_string()
            .contains("chute_width"));
    }

    #[test]
    fn the_wall_mesh_has_the_expected_facets_bounds_and_normals() {
        let c = chute(0.02, -0.01, 3);
        c.validate().unwrap();
        let surface = c.surface_mesh();
        assert_eq!(surface.triangles.len(), 2 * 24 * 3);
        for i in 0..surface.triangles.len() {
            let n = surface.normal(i);
            assert!(n[2] > 0.0 && n[0] > 0.0 && n[1].abs() < 1e-12, "{n:?}");
        }
        let sides = c.side_walls_mesh();
        assert_eq!(sides.triangles.len(), 4 * 24);
        for i in 0..sides.triangles.len() {
            let [a, _, _] = sides.corners(i);
            let n = sides.normal(i);
            // Inwards: towards y = 0.
            assert!((n[1] + a[1].signum()).abs() < 1e-12, "{n:?} at {a:?}");
        }
        let back = c.back_wall_mesh();
        assert_eq!(back.normal(0), [1.0, 0.0, 0.0]);
        let all = c.wall_mesh();
        assert_eq!(all.triangles.len(), 2 * 24 * 3 + 4 * 24 + 2);
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for v in &all.vertices {
            for k in 0..3 {
                lo[k] = lo[k].min(v[k]);
                hi[k] = hi[k].max(v[k]);
            }
        }
        let top = c.inlet().1 + c.side_height_m;
        assert!(lo[0].abs() < 1e-15 && (hi[0] - c.lip().0).abs() < 1e-15);
        assert!((lo[1] + 0.03).abs() < 1e-15 && (hi[1] - 0.03).abs() < 1e-15);
        assert!(lo[2].abs() < 1e-15 && (hi[2] - top).abs() < 1e-15);
        // The plate's area: the straight chute is L × w exactly.
        let straight = chute(0.0, 0.0, 3);
        assert!((straight.surface_mesh().area_m2() - 0.3 * 0.06).abs() < 1e-12);
        // ASCII STL: one facet per triangle.
        let stl = all.to_ascii_stl("chute");
        assert_eq!(stl.matches("facet normal").count(), all.triangles.len());
    }

    #[test]
    fn the_receiving_plane_lies_drop_height_below_the_lip() {
        let c = chute(0.0, 0.0, 3);
        let z = c.receiving_plane_z_m();
        assert_eq!(z, -0.1);
        let plane = c.receiving_plane_mesh(0.5, 0.05, z);
        assert_eq!(plane.triangles.len(), 2);
        assert!(plane.vertices.iter().all(|v| v[2] == -0.1));
        assert_eq!(plane.normal(0), [0.0, 0.0, 1.0]);
        assert!((plane.area_m2() - 0.5 * 0.1).abs() < 1e-15);
    }
}
