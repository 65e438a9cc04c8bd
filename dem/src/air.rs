//! Air drag on each particle: `F = ½ ρ_a C_d A |u − v| (u − v)` with `A = π r²`, the
//! particle's velocity `v`, the air's `u` (still, a given uniform velocity, or a gridded
//! field's value at the particle, [`crate::air_field`]) and the
//! Schiller–Naumann drag coefficient of a sphere at the particle Reynolds number
//! `Re = ρ_a |u − v| d / μ`:
//! `C_d = 24/Re (1 + 0.15 Re^0.687)` below `Re = 1000`, `0.44` above (Schiller &
//! Naumann 1933; Clift, Grace & Weber, *Bubbles, Drops, and Particles*, 1978, ch. 5).
//! This is the thesis's `F_d = C_d · ½ ρ_a (v_a − v_p)² · π d_p²/4` on every particle.
//! Buoyancy (`ρ_a/ρ_p` ≈ 5·10⁻⁴ of the weight for glass in air) is left out, as in
//! LIGGGHTS's and EDEM's drag models without a CFD coupling.

use crate::math::{Real, Vec3};

/// The air around the particles.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Air {
    /// Density, kg/m³ (1.2 for air at 20 °C).
    pub density_kg_m3: Real,
    /// Dynamic viscosity, Pa·s (1.8e-5 for air at 20 °C).
    pub viscosity_pa_s: Real,
    /// Its velocity, m/s (zero: still air).
    pub velocity_m_per_s: Vec3,
}

/// The drag coefficient of a sphere at particle Reynolds number `re` (> 0).
pub fn drag_coefficient(re: Real) -> Real {
    if re >= 1000.0 {
        0.44
    } else {
        24.0 / re * (1.0 + 0.15 * re.powf(0.687))
    }
}

impl Air {
    /// The drag force on a sphere of radius `radius_m` moving at `velocity_m_per_s`, N.
    pub fn drag_n(&self, radius_m: Real, velocity_m_per_s: Vec3) -> Vec3 {
        self.drag_in_n(self.velocity_m_per_s, radius_m, velocity_m_per_s)
    }

    /// The drag force on a sphere of radius `radius_m` moving at `velocity_m_per_s` where
    /// this air (its density and viscosity) moves at `air_velocity_m_per_s` instead of its
    /// uniform velocity, N.
    #[inline]
    pub fn drag_in_n(
        &self,
        air_velocity_m_per_s: Vec3,
        radius_m: Real,
        velocity_m_per_s: Vec3,
    ) -> Vec3 {
        let relative = air_velocity_m_per_s - velocity_m_per_s;
        let speed = relative.norm();
        if speed == 0.0 {
            return Vec3::zeros();
        }
        let re = self.density_kg_m3 * speed * 2.0 * radius_m / self.viscosity_pa_s;
        let area = std::f64::consts::PI * radius_m * radius_m;
        relative * (0.5 * self.density_kg_m3 * drag_coefficient(re) * area * speed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn air() -> Air {
        Air {
            density_kg_m3: 1.2,
            viscosity_pa_s: 1.8e-5,
            velocity_m_per_s: Vec3::zeros(),
        }
    }

    #[test]
    fn stokes_drag_at_small_reynolds_numbers() {
        // Re → 0: C_d → 24/Re, so F → 6π μ r v (Stokes).
        let (r, v) = (1e-6, 1e-3);
        let f = air().drag_n(r, Vec3::new(0.0, 0.0, -v));
        let stokes = 6.0 * std::f64::consts::PI * 1.8e-5 * r * v;
        assert!((f.z - stokes).abs() / stokes < 1e-3, "{} vs {stokes}", f.z);
        assert!(f.x == 0.0 && f.y == 0.0);
    }

    #[test]
    fn drag_opposes_the_motion_relative_to_the_air() {
        let wind = Air {
            velocity_m_per_s: Vec3::new(2.0, 0.0, 0.0),
            ..air()
        };
        // A particle at rest in a wind is pushed along it.
        assert!(wind.drag_n(1e-3, Vec3::zeros()).x > 0.0);
        // One moving with the wind feels none.
        assert_eq!(wind.drag_n(1e-3, Vec3::new(2.0, 0.0, 0.0)), Vec3::zeros());
    }

    #[test]
    fn the_coefficient_is_continuous_enough_at_its_switch() {
        // Schiller–Naumann gives 0.4383 at Re = 1000, against the constant 0.44.
        assert!((drag_coefficient(999.999) - 0.4383).abs() < 1e-3);
        assert_eq!(drag_coefficient(1000.0), 0.44);
    }
}
