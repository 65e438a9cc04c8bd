//! Narrow-phase geometry: small pure functions, one per shape pair, that say whether
//! two shapes touch and where. The force law is in [`crate::force`].

mod sphere_sphere;
mod sphere_triangle;

pub use sphere_sphere::contact_sphere_sphere;
pub use sphere_triangle::{
    closest_point_on_triangle, distance_squared_to_triangle, TriangleFeature, TrianglePoint,
};
