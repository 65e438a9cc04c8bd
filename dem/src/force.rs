//! The contact law: Hertz normal force and Mindlin tangential spring with history,
//! both with viscous damping from the restitution coefficient, a Coulomb limit, and an
//! optional constant directional rolling torque.
//!
//! This follows LIGGGHTS's `hertz` + `tangential history` (and `rolling_friction cdt`)
//! so that the native kernel and LIGGGHTS can be compared case by case:
//!
//! - `kn = 4/3 E* sqrt(R* δ)`, `Sn = 2 E* sqrt(R* δ)`, `St = 8 G* sqrt(R* δ)`;
//! - `γn = -2 sqrt(5/6) β sqrt(Sn m*)`, `γt = -2 sqrt(5/6) β sqrt(St m*)`;
//! - `Fn = kn δ - γn vn` along the normal, *not* clamped at zero: the damping pulls a
//!   little at the end of a contact, which is what makes the measured restitution equal
//!   the input (clamping raises e = 0.3 to about 0.40);
//! - the tangential history `ξ` grows by `vt dt`, is turned into the current tangent
//!   plane, `Ft = -kt ξ - γt vt`, and when `|kt ξ| > μ |Fn|` the contact slides:
//!   `Ft = μ |Fn|` against `ξ` and `ξ` is shortened to match;
//! - the rolling torque (`rolling_friction cdt`) is `μr kn δ R*` against the relative
//!   spin's part in the tangent plane: the elastic normal force, not the damped one,
//!   and no torque against twisting about the normal, as LIGGGHTS's CDT model has it.

use crate::material::PairConstants;
use crate::math::{Real, Vec3};

/// Where and how deep two bodies touch.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactGeometry {
    /// Unit normal from the other body towards this one.
    pub normal: Vec3,
    /// Overlap δ > 0, m.
    pub overlap_m: Real,
    /// Effective radius R* = r1 r2 / (r1 + r2) (a wall: R* = r), m.
    pub effective_radius_m: Real,
    /// Effective mass m* = m1 m2 / (m1 + m2) (a wall: m* = m), kg.
    pub effective_mass_kg: Real,
}

/// The contact's forces on "this" body (the other gets the opposite force).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactForce {
    /// Total force on this body, N.
    pub force: Vec3,
    /// The tangential part of `force`, N (its torque arm is the body's radius against
    /// another particle, the radius less half the overlap against a wall).
    pub tangential: Vec3,
    /// Rolling-resistance torque on this body, N m (the other gets the opposite).
    pub rolling_torque: Vec3,
}

/// Evaluates the contact law for one time step of length `dt_s`.
///
/// `contact_velocity` is this body's velocity at the contact point minus the other's,
/// m/s; `relative_spin` is this body's angular velocity minus the other's, rad/s.
/// `shear` is the pair's tangential history, m, updated in place.
#[inline]
pub fn hertz_mindlin(
    constants: &PairConstants,
    geometry: &ContactGeometry,
    contact_velocity: Vec3,
    relative_spin: Vec3,
    shear: &mut Vec3,
    dt_s: Real,
) -> ContactForce {
    let n = geometry.normal;
    let sqrt_rd = (geometry.effective_radius_m * geometry.overlap_m).sqrt();
    let sn = 2.0 * constants.effective_youngs_pa * sqrt_rd;
    let st = 8.0 * constants.effective_shear_pa * sqrt_rd;
    let kn = 2.0 / 3.0 * sn;
    let gamma_n = constants.damping_factor * (sn * geometry.effective_mass_kg).sqrt();
    // sqrt(St m*) = sqrt(St / Sn) sqrt(Sn m*), and St / Sn = 4 G* / E* is a constant.
    let gamma_t = gamma_n * constants.tangential_to_normal_damping;

    let vn = contact_velocity.dot(&n);
    let normal_force = kn * geometry.overlap_m - gamma_n * vn;
    let vt = contact_velocity - vn * n;

    // Keep the history in the current tangent plane at its length, then add this step.
    let length_squared = shear.norm_squared();
    if length_squared > 0.0 {
        let projected = *shear - shear.dot(&n) * n;
        let projected_squared = projected.norm_squared();
        if projected_squared > 0.0 {
            *shear = projected * (length_squared / projected_squared).sqrt();
        }
    }
    *shear += vt * dt_s;

    let elastic = -st * *shear;
    let limit = constants.friction * normal_force.abs();
    let elastic_squared = elastic.norm_squared();
    let tangential = if elastic_squared > limit * limit {
        // Sliding: the force is the Coulomb limit; the spring keeps what it can hold.
        let sliding = elastic * (limit / elastic_squared.sqrt());
        *shear = -sliding / st;
        sliding
    } else {
        elastic - gamma_t * vt
    };

    // LIGGGHTS's constant directional torque: μr kn δ R* against the relative spin's
    // part in the tangent plane (twisting about the normal is left alone).
    let mut rolling_torque = Vec3::zeros();
    if constants.rolling_friction > 0.0 {
        let rolling_spin = relative_spin - relative_spin.dot(&n) * n;
        let spin = rolling_spin.norm();
        if spin > 0.0 {
            rolling_torque = -constants.rolling_friction
                * kn
                * geometry.overlap_m
                * geometry.effective_radius_m
                * rolling_spin
                / spin;
        }
    }
    ContactForce {
        force: normal_force * n + tangential,
        tangential,
        rolling_torque,
    }
}

/// Hertz's duration of an elastic impact of two spheres at relative speed
/// `speed_m_per_s`: `2.87 (m*² / (R* E*² v))^(1/5)`, s.
pub fn hertz_contact_time_s(
    effective_mass_kg: Real,
    effective_radius_m: Real,
    effective_youngs_pa: Real,
    speed_m_per_s: Real,
) -> Real {
    2.87 * (effective_mass_kg.powi(2)
        / (effective_radius_m * effective_youngs_pa.powi(2) * speed_m_per_s))
        .powf(0.2)
}

/// The approach speed at which an undamped head-on Hertz impact of two spheres
/// reaches the overlap `overlap_m`: the largest overlap at speed `v` is
/// `(15 m* v² / (16 E* sqrt(R*)))^(2/5)` (Johnson 1985, §11.4), so
/// `v = sqrt(16 E* sqrt(R*) δ^(5/2) / (15 m*))`, m/s. It says how soft a contact is:
/// bodies that meet faster overlap deeper, whatever the time step.
pub fn hertz_speed_for_overlap_m_per_s(
    effective_mass_kg: Real,
    effective_radius_m: Real,
    effective_youngs_pa: Real,
    overlap_m: Real,
) -> Real {
    (16.0 * effective_youngs_pa * effective_radius_m.sqrt() * overlap_m.powf(2.5)
        / (15.0 * effective_mass_kg))
        .sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::{Material, PairConstants};
    use approx::assert_relative_eq;

    fn constants(restitution: Real, friction: Real) -> PairConstants {
        let m = Material {
            youngs_modulus_pa: 5e6,
            poisson_ratio: 0.3,
            restitution,
            friction,
            rolling_friction: 0.0,
        };
        PairConstants::between(&m, &m)
    }

    fn geometry(overlap_m: Real) -> ContactGeometry {
        ContactGeometry {
            normal: Vec3::z(),
            overlap_m,
            effective_radius_m: 0.0005,
            effective_mass_kg: 1e-5,
        }
    }

    #[test]
    fn the_speed_for_an_overlap_inverts_hertz_largest_overlap() {
        let (mass_kg, radius_m, youngs_pa, speed): (Real, Real, Real, Real) =
            (1e-5, 0.0005, 2.7e6, 1.7);
        let overlap_m =
            (15.0 * mass_kg * speed * speed / (16.0 * youngs_pa * radius_m.sqrt())).powf(0.4);
        let back = hertz_speed_for_overlap_m_per_s(mass_kg, radius_m, youngs_pa, overlap_m);
        assert_relative_eq!(back, speed, max_relative = 1e-12);
    }

    #[test]
    fn static_normal_force_is_hertz() {
        let k = constants(0.6, 0.5);
        let mut shear = Vec3::zeros();
        let g = geometry(1e-5);
        let f = hertz_mindlin(&k, &g, Vec3::zeros(), Vec3::zeros(), &mut shear, 1e-5);
        // F = 4/3 E* sqrt(R*) δ^(3/2)
        let expected = 4.0 / 3.0 * k.effective_youngs_pa * 0.0005f64.sqrt() * 1e-5f64.powf(1.5);
        assert_relative_eq!(f.force.z, expected, max_relative = 1e-12);
        assert_eq!(f.tangential, Vec3::zeros());
    }

    #[test]
    fn tangential_force_never_exceeds_the_coulomb_limit() {
        let k = constants(0.6, 0.3);
        let mut shear = Vec3::zeros();
        let g = geometry(1e-5);
        for _ in 0..1000 {
            let f = hertz_mindlin(&k, &g, Vec3::x(), Vec3::zeros(), &mut shear, 1e-5);
            let normal = f.force.z;
            assert!(f.tangential.norm() <= 0.3 * normal.abs() * (1.0 + 1e-12));
            assert!(f.tangential.x < 0.0, "friction opposes sliding");
        }
    }

    #[test]
    fn history_turns_with_the_contact_plane_and_keeps_its_length() {
        let k = constants(0.6, 0.5);
        let mut shear = Vec3::new(1e-7, 0.0, 0.0);
        let mut g = geometry(1e-5);
        g.normal = Vec3::new(0.1, 0.0, 1.0).normalize();
        hertz_mindlin(&k, &g, Vec3::zeros(), Vec3::zeros(), &mut shear, 1e-5);
        assert_relative_eq!(shear.norm(), 1e-7, max_relative = 1e-12);
        assert!(shear.dot(&g.normal).abs() < 1e-20);
    }

    #[test]
    fn hertz_contact_time_of_the_solver_notes_pair() {
        // Two 4 mm glass-like spheres (E 5 MPa, ν 0.3, ρ 2500) at 1 m/s: 538.5 µs.
        let mass = 4.0 / 3.0 * std::f64::consts::PI * 0.002f64.powi(3) * 2500.0;
        let k = constants(1.0, 0.0);
        let t = hertz_contact_time_s(mass / 2.0, 0.001, k.effective_youngs_pa, 1.0);
        assert_relative_eq!(t, 538.5e-6, max_relative = 1e-3);
    }
}
