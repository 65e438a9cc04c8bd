//! Number types used throughout the kernel: one place to change the precision.
//!
//! Every quantity is SI (m, kg, s, N, Pa); names carry the unit where it is not obvious.

/// The kernel's floating-point type.
pub type Real = f64;

/// A 3-vector of [`Real`]: positions (m), velocities (m/s), forces (N), torques (N m).
pub type Vec3 = nalgebra::Vector3<Real>;

/// Standard gravity, m/s².
pub const STANDARD_GRAVITY_M_S2: Real = 9.81;
