use crate::math::{Real, Vec3};

/// The contact of two spheres whose centres are `offset_m` = x1 - x2 apart: the unit
/// normal from sphere 2 towards sphere 1 and the overlap `r1 + r2 - |x1 - x2|`, m, or
/// `None` when they do not touch (or coincide, which has no normal).
#[inline]
pub fn contact_sphere_sphere(
    offset_m: Vec3,
    radius_1_m: Real,
    radius_2_m: Real,
) -> Option<(Vec3, Real)> {
    let reach = radius_1_m + radius_2_m;
    let distance_squared = offset_m.norm_squared();
    if distance_squared >= reach * reach || distance_squared == 0.0 {
        return None;
    }
    let distance = distance_squared.sqrt();
    Some((offset_m / distance, reach - distance))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn touching_spheres_overlap_by_the_missing_distance() {
        let (normal, overlap) =
            contact_sphere_sphere(Vec3::new(0.0, 0.0, 0.0019), 0.001, 0.001).unwrap();
        assert_eq!(normal, Vec3::z());
        assert!((overlap - 0.0001).abs() < 1e-15);
        assert!(contact_sphere_sphere(Vec3::new(0.0, 0.002, 0.0), 0.001, 0.001).is_none());
        assert!(contact_sphere_sphere(Vec3::zeros(), 0.001, 0.001).is_none());
    }
}
