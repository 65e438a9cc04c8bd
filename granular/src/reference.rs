//! Closed-form reference figures for hopper discharge (SCIENCE.md §4).

/// Standard gravity, m/s².
pub const G_M_PER_S2: f64 = 9.81;

/// Beverloo's discharge rate of a circular orifice, kg/s:
/// `W = C ρ_b sqrt(g) (D − k d)^(5/2)`.
///
/// `bulk_density` in kg/m³, `outlet_diameter_m` `D` and `particle_diameter_m` `d` in
/// metres; the usual constants are `C = 0.58`, `k = 1.5`. The exponent is 5/2 for a
/// circular outlet (3/2 is the two-dimensional slot form, per unit length).
pub fn beverloo_rate_kg_per_s(
    bulk_density_kg_per_m3: f64,
    outlet_diameter_m: f64,
    particle_diameter_m: f64,
    c: f64,
    k: f64,
) -> f64 {
    let effective = (outlet_diameter_m - k * particle_diameter_m).max(0.0);
    c * bulk_density_kg_per_m3 * G_M_PER_S2.sqrt() * effective.powf(2.5)
}

/// The hopper discharge estimate of SCIENCE.md §4, kg/s:
/// `ṁ = ρ · π D² / 4 · sqrt(D g / (4 tan α))`, with `α` the half-angle.
pub fn conical_hopper_rate_kg_per_s(
    bulk_density_kg_per_m3: f64,
    outlet_diameter_m: f64,
    cone_half_angle_deg: f64,
) -> f64 {
    let d = outlet_diameter_m;
    let tan = cone_half_angle_deg.to_radians().tan();
    bulk_density_kg_per_m3 * std::f64::consts::PI * d * d / 4.0
        * (d * G_M_PER_S2 / (4.0 * tan)).sqrt()
}

/// Vibration intensity `Γ = a ω² / g` for amplitude `a` (m) and frequency `f` (Hz).
pub fn vibration_intensity(amplitude_m: f64, frequency_hz: f64) -> f64 {
    let omega = std::f64::consts::TAU * frequency_hz;
    amplitude_m * omega * omega / G_M_PER_S2
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn beverloo_reproduces_the_solver_notes_estimate() {
        // shared/solvers/README.md: D = 24 mm, mean d = 3 mm, ρb = 1500, C = 0.58,
        // k = 1.5 → about 0.145 kg/s.
        let w = beverloo_rate_kg_per_s(1500.0, 0.024, 0.003, 0.58, 1.5);
        assert!((w - 0.145).abs() < 0.002, "{w}");
    }

    #[test]
    fn vibration_intensity_of_half_a_millimetre_at_fifty_hertz() {
        // a ω² / g = 0.0005 · (100π)² / 9.81 = 5.03.
        assert!((vibration_intensity(0.0005, 50.0) - 5.0303).abs() < 1e-3);
    }

    #[test]
    fn conical_rate_grows_with_outlet_and_falls_with_angle() {
        let base = conical_hopper_rate_kg_per_s(1500.0, 0.024, 35.0);
        assert!(conical_hopper_rate_kg_per_s(1500.0, 0.03, 35.0) > base);
        assert!(conical_hopper_rate_kg_per_s(1500.0, 0.024, 45.0) < base);
    }
}
