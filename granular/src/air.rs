//! The air a falling particle stream drags along (SCIENCE.md §4: `F_d = C_d · ½ ρ_a
//! (v_a − v_p)² · π d_p² / 4`), reduced to what a CFD case needs as a momentum source.
//!
//! In a stream of mass flow `ṁ` through cross-section `A_s` falling at speed `v_p`, the
//! particles of diameter `d` number `n = ṁ / (m_p v_p A_s)` per unit volume. Their drag
//! per unit mass of air, linearised about the air at rest, is `K (v_p − u)` with
//!
//! `K = n · C_d · ½ v_p · π d²/4 = 3 C_d ṁ / (4 ρ_p d A_s)`  (1/s),
//!
//! which does not depend on `v_p`: the slower stream is denser. For a mixture the rates
//! of its sizes add.

use std::f64::consts::PI;

/// Standard gravity, m/s².
pub const GRAVITY_M_PER_S2: f64 = 9.81;

/// Drag coefficient of a sphere at particle Reynolds number `re` (Schiller–Naumann,
/// valid below `re` ≈ 1000, constant 0.44 above).
pub fn drag_coefficient(re: f64) -> f64 {
    if re <= 0.0 {
        return f64::INFINITY;
    }
    if re >= 1000.0 {
        return 0.44;
    }
    24.0 / re * (1.0 + 0.15 * re.powf(0.687))
}

/// Mean speed of a stream leaving at `exit_speed` (m/s) and falling freely over
/// `height_m`, averaged over the height: `((v0² + 2gH)^{3/2} − v0³) / (3gH)`.
pub fn mean_fall_speed(exit_speed_m_per_s: f64, height_m: f64) -> f64 {
    let (v0, g) = (exit_speed_m_per_s.abs(), GRAVITY_M_PER_S2);
    if height_m <= 0.0 {
        return v0;
    }
    ((v0 * v0 + 2.0 * g * height_m).powf(1.5) - v0.powi(3)) / (3.0 * g * height_m)
}

/// One particle size of a stream.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StreamFraction {
    /// Particle diameter, m.
    pub diameter_m: f64,
    /// Mass flow of particles of this size, kg/s.
    pub mass_flow_kg_per_s: f64,
}

/// The linearised drag rate `K` (1/s) of a stream of particles of density
/// `particle_density` (kg/m³) through a circle of `stream_radius_m`, moving at
/// `speed_m_per_s` through air of density `air_density` (kg/m³) and kinematic
/// viscosity `air_viscosity_m2_per_s`.
pub fn drag_rate_per_s(
    fractions: &[StreamFraction],
    particle_density: f64,
    stream_radius_m: f64,
    speed_m_per_s: f64,
    air_viscosity_m2_per_s: f64,
) -> f64 {
    let area = PI * stream_radius_m * stream_radius_m;
    fractions
        .iter()
        .map(|f| {
            let re = speed_m_per_s.abs() * f.diameter_m / air_viscosity_m2_per_s;
            3.0 * drag_coefficient(re) * f.mass_flow_kg_per_s
                / (4.0 * particle_density * f.diameter_m * area)
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn drag_coefficient_is_stokes_at_low_reynolds_and_newton_at_high() {
        assert!((drag_coefficient(0.01) * 0.01 / 24.0 - 1.0).abs() < 0.01);
        assert_eq!(drag_coefficient(5000.0), 0.44);
        // Schiller–Naumann meets the Newton value near Re = 1000.
        assert!((drag_coefficient(999.0) - 0.44).abs() < 0.02);
    }

    #[test]
    fn mean_fall_speed_is_the_height_average_of_free_fall() {
        // From rest over H: v(s) = sqrt(2 g s), mean = (2/3) sqrt(2 g H).
        let h = 0.1;
        let exact = 2.0 / 3.0 * (2.0 * GRAVITY_M_PER_S2 * h).sqrt();
        assert!((mean_fall_speed(0.0, h) - exact).abs() < 1e-12);
        // No height: the exit speed.
        assert_eq!(mean_fall_speed(0.8, 0.0), 0.8);
        // Numerical average agrees.
        let (v0, n) = (0.5, 100_000);
        let numeric: f64 = (0..n)
            .map(|i| {
                let s = (i as f64 + 0.5) / n as f64 * h;
                (v0 * v0 + 2.0 * GRAVITY_M_PER_S2 * s).sqrt()
            })
            .sum::<f64>()
            / n as f64;
        assert!((mean_fall_speed(v0, h) - numeric).abs() < 1e-8);
    }

    #[test]
    fn drag_rate_is_the_sum_of_particle_drags_per_unit_air_mass() {
        // Count the particles in a unit length of stream and add their drags directly.
        let (d, mdot, rho_p, radius, v, nu): (f64, f64, f64, f64, f64, f64) =
            (0.002, 0.1, 2500.0, 0.01, 1.0, 1.5e-5);
        let mass = rho_p * PI * d.powi(3) / 6.0;
        let per_volume = mdot / (mass * v * PI * radius * radius);
        let cd = drag_coefficient(v * d / nu);
        let rho_a = 1.2;
        let force_per_volume = per_volume * cd * 0.5 * rho_a * v * v * PI * d * d / 4.0;
        let expected = force_per_volume / rho_a / v;
        let fraction = StreamFraction {
            diameter_m: d,
            mass_flow_kg_per_s: mdot,
        };
        let k = drag_rate_per_s(&[fraction], rho_p, radius, v, nu);
        assert!((k - expected).abs() / expected < 1e-12, "{k} vs {expected}");
        // Two halves of the same size add up to the whole.
        let half = StreamFraction {
            mass_flow_kg_per_s: mdot / 2.0,
            ..fraction
        };
        let k2 = drag_rate_per_s(&[half, half], rho_p, radius, v, nu);
        assert!((k2 - k).abs() < 1e-9);
    }
}
