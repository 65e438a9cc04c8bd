//! The conical hopper with its outlet plug, optional internal valve and sensor planes.
//!
//! Coordinates: the hopper axis is the z axis, the outlet plane is `z = 0`, material
//! flows in `−z`. The cone widens from the outlet radius at `z = 0` to the top radius at
//! `z = cone_height_m`, above which a cylinder continues to `cone_height_m +
//! cylinder_height_m`. The cone's wall is straight unless the shape offsets bend it
//! into a B-spline ([`ConeProfile`]).

use crate::mesh::TriMesh;
use crate::profile::{ConeProfile, ProfileError};

/// The shape of a conical hopper, all lengths in metres.
#[derive(Debug, Clone, PartialEq)]
pub struct HopperGeometry {
    /// Diameter of the outlet at `z = 0`.
    pub outlet_diameter_m: f64,
    /// Half-angle of the cone measured from the vertical axis, degrees, in (0, 90).
    pub cone_half_angle_deg: f64,
    /// Height of the conical section.
    pub cone_height_m: f64,
    /// Height of the cylindrical section above the cone (may be 0).
    pub cylinder_height_m: f64,
    /// Diameter of the internal cone valve; 0 means no valve.
    pub valve_diameter_m: f64,
    /// Height of the valve's base above the outlet plane (the gap `h` of the thesis).
    pub valve_gap_m: f64,
    /// Height of the valve cone from its base to its apex.
    pub valve_height_m: f64,
    /// Facets around the circumference.
    pub segments: usize,
    /// Height of one band of facets along the wall; small bands keep facets compact.
    pub band_height_m: f64,
    /// Offset of the cone profile's lower control point away from the axis, m
    /// (the thesis's X1; 0 with `shape_x2_m = 0` is the straight cone).
    pub shape_x1_m: f64,
    /// Offset of the cone profile's upper control point towards the axis, m (X2).
    pub shape_x2_m: f64,
    /// Degree of the B-spline profile, 2 or 3.
    pub shape_degree: usize,
}

/// A hopper that cannot be built, with the offending value.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GeometryError {
    /// A length that must be positive is not.
    #[error("{name} must be positive and finite, got {value} m")]
    NotPositive {
        /// Parameter name.
        name: &'static str,
        /// Its value.
        value: f64,
    },
    /// The cone half-angle is outside (0°, 90°).
    #[error("cone_half_angle must lie strictly between 0 and 90 degrees, got {0}")]
    BadAngle(f64),
    /// Fewer than 8 facets around would not approximate a circle.
    #[error("segments must be at least 8, got {0}")]
    TooFewSegments(usize),
    /// The valve does not fit inside the cone at its height.
    #[error(
        "the valve (diameter {valve_diameter_m} m at {valve_gap_m} m above the outlet) does not fit: the cone is only {cone_diameter_m:.4} m wide there"
    )]
    ValveDoesNotFit {
        /// Valve diameter.
        valve_diameter_m: f64,
        /// Valve gap.
        valve_gap_m: f64,
        /// Cone diameter at the valve's base.
        cone_diameter_m: f64,
    },
    /// The B-spline cone profile cannot be built.
    #[error(transparent)]
    Profile(#[from] ProfileError),
}

impl HopperGeometry {
    /// Checks every parameter; the meshes below assume a valid geometry.
    pub fn validate(&self) -> Result<(), GeometryError> {
        for (name, value) in [
            ("outlet_diameter", self.outlet_diameter_m),
            ("cone_height", self.cone_height_m),
            ("band_height", self.band_height_m),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(GeometryError::NotPositive { name, value });
            }
        }
        if !(self.cylinder_height_m.is_finite() && self.cylinder_height_m >= 0.0) {
            return Err(GeometryError::NotPositive {
                name: "cylinder_height",
                value: self.cylinder_height_m,
            });
        }
        if !(self.cone_half_angle_deg > 0.0 && self.cone_half_angle_deg < 90.0) {
            return Err(GeometryError::BadAngle(self.cone_half_angle_deg));
        }
        if self.segments < 8 {
            return Err(GeometryError::TooFewSegments(self.segments));
        }
        self.profile().validate()?;
        if self.has_valve() {
            for (name, value) in [
                ("valve_gap", self.valve_gap_m),
                ("valve_height", self.valve_height_m),
            ] {
                if !(value.is_finite() && value > 0.0) {
                    return Err(GeometryError::NotPositive { name, value });
                }
            }
            let cone_diameter_m = 2.0 * self.radius_at(self.valve_gap_m);
            if self.valve_diameter_m >= cone_diameter_m {
                return Err(GeometryError::ValveDoesNotFit {
                    valve_diameter_m: self.valve_diameter_m,
                    valve_gap_m: self.valve_gap_m,
                    cone_diameter_m,
                });
            }
        }
        Ok(())
    }

    /// True when the hopper has an internal valve.
    pub fn has_valve(&self) -> bool {
        self.valve_diameter_m > 0.0
    }

    /// Outlet radius in metres.
    pub fn outlet_radius_m(&self) -> f64 {
        0.5 * self.outlet_diameter_m
    }

    /// Radius of the cone at the top of the conical section: the straight cone's, which
    /// the shape offsets do not move.
    pub fn top_radius_m(&self) -> f64 {
        self.outlet_radius_m() + self.cone_height_m * self.cone_half_angle_deg.to_radians().tan()
    }

    /// The wall profile of the conical section.
    pub fn profile(&self) -> ConeProfile {
        ConeProfile {
            outlet_radius_m: self.outlet_radius_m(),
            top_radius_m: self.top_radius_m(),
            height_m: self.cone_height_m,
            x1_m: self.shape_x1_m,
            x2_m: self.shape_x2_m,
            degree: self.shape_degree,
        }
    }

    /// Wall radius at height `z_m` above the outlet (the top radius above the cone).
    pub fn radius_at(&self, z_m: f64) -> f64 {
        self.profile().radius_at(z_m)
    }

    /// Total height of cone plus cylinder.
    pub fn total_height_m(&self) -> f64 {
        self.cone_height_m + self.cylinder_height_m
    }

    /// Interior volume of the straight cone's frustum plus cylinder, m³ (closed form;
    /// the shape offsets are ignored).
    pub fn straight_volume_m3(&self) -> f64 {
        let (r0, r1, h) = (
            self.outlet_radius_m(),
            self.top_radius_m(),
            self.cone_height_m,
        );
        let frustum = std::f64::consts::PI * h / 3.0 * (r0 * r0 + r0 * r1 + r1 * r1);
        frustum + std::f64::consts::PI * r1 * r1 * self.cylinder_height_m
    }

    /// The wall profile `(r, z)` from the outlet rim up the cone and the cylinder, in
    /// bands no taller than `band_height_m` (a curved cone: no longer along the curve).
    pub fn wall_profile(&self) -> Vec<(f64, f64)> {
        let cone = self.profile();
        let mut profile = if cone.is_straight() {
            banded(
                (self.outlet_radius_m(), 0.0),
                (self.top_radius_m(), self.cone_height_m),
                self.band_height_m,
            )
        } else {
            let fine = cone.points(400);
            let length: f64 = fine
                .windows(2)
                .map(|p| (p[1].0 - p[0].0).hypot(p[1].1 - p[0].1))
                .sum();
            cone.points(((length / self.band_height_m).ceil() as usize).max(8))
        };
        if self.cylinder_height_m > 0.0 {
            let cylinder = banded(
                (self.top_radius_m(), self.cone_height_m),
                (self.top_radius_m(), self.total_height_m()),
                self.band_height_m,
            );
            profile.extend_from_slice(&cylinder[1..]);
        }
        profile
    }

    /// The hopper wall: cone and cylinder, open at both ends.
    pub fn wall_mesh(&self) -> TriMesh {
        TriMesh::revolve(&self.wall_profile(), self.segments)
    }

    /// The hopper's interior as a closed, watertight solid with outward normals: the
    /// wall closed by a disk over the outlet and one over the top. This is the volume a
    /// CFD mesher (snappyHexMesh) needs; its bottom disk is the outlet's cross-section.
    pub fn solid_mesh(&self) -> TriMesh {
        let wall = self.wall_profile();
        let top = wall.last().copied().unwrap_or_default();
        let mut profile = Vec::with_capacity(wall.len() + 2);
        profile.push((0.0, 0.0));
        profile.extend_from_slice(&wall);
        profile.push((0.0, top.1));
        TriMesh::revolve(&profile, self.segments)
    }

    /// The plug that closes the outlet while the hopper fills: a square of two
    /// triangles at `z = 0` whose inscribed circle is wider than the outlet by
    /// `overlap_m`, so nothing slips past its rim. Two large facets rather than a
    /// fine disk: a particle resting on a finely divided plug would touch dozens of
    /// facets meeting at its centre, which every solver then has to sort out.
    pub fn plug_mesh(&self, overlap_m: f64) -> TriMesh {
        let h = self.outlet_radius_m() + overlap_m;
        TriMesh {
            vertices: vec![[-h, -h, 0.0], [h, -h, 0.0], [h, h, 0.0], [-h, h, 0.0]],
            triangles: vec![[0, 1, 2], [0, 2, 3]],
        }
    }

    /// The internal valve: a cone pointing up with its base `valve_gap_m` above the
    /// outlet, closed underneath by a disk; `None` without a valve.
    pub fn valve_mesh(&self) -> Option<TriMesh> {
        if !self.has_valve() {
            return None;
        }
        let base_z = self.valve_gap_m;
        let radius = 0.5 * self.valve_diameter_m;
        let mut mesh = TriMesh::revolve(
            &[(radius, base_z), (0.0, base_z + self.valve_height_m)],
            self.segments,
        );
        mesh.append(&TriMesh::disk(radius, base_z, self.segments, 2));
        Some(mesh)
    }

    /// A flat sensor disk of `radius_m` at height `z_m` (negative: below the outlet).
    pub fn sensor_mesh(&self, radius_m: f64, z_m: f64) -> TriMesh {
        TriMesh::disk(radius_m, z_m, self.segments, 3)
    }
}

/// Profile points from `from` to `to` in bands no taller than `band_height`.
fn banded(from: (f64, f64), to: (f64, f64), band_height: f64) -> Vec<(f64, f64)> {
    let bands = (((to.1 - from.1) / band_height).round() as usize).max(1);
    (0..=bands)
        .map(|j| {
            let s = j as f64 / bands as f64;
            (from.0 + (to.0 - from.0) * s, from.1 + (to.1 - from.1) * s)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// The hopper of shared/solvers/README.md: 24 mm outlet, 35° cone 40 mm high.
    fn reference() -> HopperGeometry {
        HopperGeometry {
            outlet_diameter_m: 0.024,
            cone_half_angle_deg: 35.0,
            cone_height_m: 0.040,
            cylinder_height_m: 0.060,
            valve_diameter_m: 0.0,
            valve_gap_m: 0.0,
            valve_height_m: 0.0,
            segments: 48,
            band_height_m: 0.005,
            shape_x1_m: 0.0,
            shape_x2_m: 0.0,
            shape_degree: 3,
        }
    }

    #[test]
    fn solid_of_the_straight_cone_is_watertight_with_the_frustum_volume() {
        let g = reference();
        let solid = g.solid_mesh();
        assert_eq!(solid.open_edge_count(), 0);
        // Cross-sections are regular 48-gons of area A(r) = N/2 r² sin(2π/N), scaled
        // linearly along the cone: the prismatoid formula is exact for them.
        let n = g.segments as f64;
        let polygon = |r: f64| 0.5 * n * r * r * (2.0 * PI / n).sin();
        let (a0, a1) = (polygon(g.outlet_radius_m()), polygon(g.top_radius_m()));
        let exact = g.cone_height_m / 3.0 * (a0 + (a0 * a1).sqrt() + a1) + a1 * g.cylinder_height_m;
        let volume = solid.volume_m3();
        assert!(
            (volume - exact).abs() / exact < 1e-12,
            "{volume} vs {exact}"
        );
        // And it converges to the round hopper's closed form.
        let mut fine = reference();
        fine.segments = 720;
        let round = g.straight_volume_m3();
        assert!((fine.solid_mesh().volume_m3() - round).abs() / round < 1e-4);
    }

    #[test]
    fn outlet_cross_section_of_the_solid_has_the_outlet_area() {
        let mut g = reference();
        g.segments = 720;
        let solid = g.solid_mesh();
        let outlet: f64 = (0..solid.triangles.len())
            .filter(|&i| solid.corners(i).iter().all(|v| v[2] == 0.0))
            .map(|i| {
                let [a, b, c] = solid.corners(i);
                0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])).abs()
            })
            .sum();
        let exact = PI * g.outlet_radius_m().powi(2);
        assert!((outlet - exact).abs() / exact < 1e-4, "{outlet} vs {exact}");
    }

    #[test]
    fn curved_cones_stay_watertight_and_concave_holds_less() {
        let straight = reference().solid_mesh().volume_m3();
        for (x1, x2, degree) in [(-0.006, 0.006, 3), (0.006, -0.006, 3), (-0.004, 0.004, 2)] {
            let mut g = reference();
            (g.shape_x1_m, g.shape_x2_m, g.shape_degree) = (x1, x2, degree);
            g.validate().unwrap();
            let solid = g.solid_mesh();
            assert_eq!(solid.open_edge_count(), 0);
            let volume = solid.volume_m3();
            assert_eq!(
                volume < straight,
                x1 < 0.0,
                "{x1} {x2}: {volume} vs {straight}"
            );
            // The wall is open only at its two rims.
            assert_eq!(g.wall_mesh().open_edge_count(), 2 * g.segments);
            // Rims stay where the straight cone has them.
            assert!((g.radius_at(0.0) - g.outlet_radius_m()).abs() < 1e-12);
            assert!((g.radius_at(g.cone_height_m) - g.top_radius_m()).abs() < 1e-9);
        }
    }

    #[test]
    fn a_folding_profile_is_refused_by_the_geometry() {
        let mut g = reference();
        g.shape_x1_m = -0.02;
        let message = g.validate().unwrap_err().to_string();
        assert!(message.contains("shape_x1 = -0.02 m"), "{message}");
    }

    #[test]
    fn wall_area_approaches_the_frustum_and_cylinder_area() {
        let mut g = reference();
        g.segments = 720;
        let (r0, r1, h) = (g.outlet_radius_m(), g.top_radius_m(), g.cone_height_m);
        let slant = ((r1 - r0).powi(2) + h * h).sqrt();
        let exact = PI * (r0 + r1) * slant + 2.0 * PI * r1 * g.cylinder_height_m;
        let area = g.wall_mesh().area_m2();
        assert!((area - exact).abs() / exact < 1e-4, "{area} vs {exact}");
    }

    #[test]
    fn reference_hopper_matches_the_verified_deck() {
        let g = reference();
        g.validate().unwrap();
        assert!((g.top_radius_m() - 0.040).abs() < 1e-3);
        // 8 bands of cone + 12 of cylinder, two triangles per segment per band.
        assert_eq!(g.wall_mesh().triangles.len(), 20 * 48 * 2);
    }

    #[test]
    fn valve_must_fit_inside_the_cone() {
        let mut g = reference();
        g.valve_diameter_m = 0.03;
        g.valve_gap_m = 0.002;
        g.valve_height_m = 0.01;
        assert!(matches!(
            g.validate(),
            Err(GeometryError::ValveDoesNotFit { .. })
        ));
        g.valve_gap_m = 0.02;
        g.validate().unwrap();
        let valve = g.valve_mesh().unwrap();
        let r = 0.015;
        let exact = PI * r * (r * r + 0.01f64 * 0.01).sqrt() + PI * r * r;
        assert!((valve.area_m2() - exact).abs() / exact < 0.01);
    }

    #[test]
    fn bad_parameters_are_named() {
        let mut g = reference();
        g.cone_half_angle_deg = 95.0;
        assert_eq!(g.validate(), Err(GeometryError::BadAngle(95.0)));
        let mut g = reference();
        g.outlet_diameter_m = -1.0;
        assert_eq!(
            g.validate().unwrap_err().to_string(),
            "outlet_diameter must be positive and finite, got -1 m"
        );
    }
}
