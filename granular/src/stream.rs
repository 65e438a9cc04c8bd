//! Responses of a particle stream that leaves a chute's lip and lands on a horizontal
//! receiving plane, from its crossings of that plane.
//!
//! - *Impact speed*: the mass-weighted mean speed `|v|` at the plane.
//! - *Lip speed and angle*: each crossing traced back in free flight to the lip's
//!   height `h` above the plane (no drag): the horizontal velocity is unchanged and
//!   `v_z,lip² = v_z² − 2 g h`, so `|v_lip|² = |v|² − 2 g h`; the angle is that of the
//!   velocity below the horizontal. Mass-weighted means.
//! - *Stream width*: the 5–95 % range of the crossings' `y` (across the flow).
//! - *Outer-layer fine fraction* (the dust proxy): each crossing's distance from the
//!   stream's centre on the plane, `y` and `x` each scaled by half its 5–95 % range,
//!   and the mass fraction of fines among the crossings at or beyond the 90th
//!   percentile of that distance. The layer holds a tenth of the crossings whatever
//!   their number, so the fraction is a proportion of many particles and does not
//!   saturate at 1 as a thin layer of a few particles does.
//! - *Held-up mass*: the mass fed minus the mass that crossed, never negative.

use crate::crossing::Crossing;

/// What defines the responses besides the crossings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StreamOptions {
    /// Particle type that counts as fine; every other type is coarse.
    pub fine_type: u32,
    /// Height of the lip above the receiving plane, m.
    pub lip_height_m: f64,
    /// Gravitational acceleration, m/s² (positive).
    pub gravity_m_per_s2: f64,
    /// Mass fed into the chute, kg.
    pub fed_mass_kg: f64,
    /// Fraction of crossings in the outer layer, e.g. 0.1.
    pub outer_layer: f64,
}

/// The stream's responses; `None` when the crossings cannot define one.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StreamResponses {
    /// Particles that crossed.
    pub count: usize,
    /// Mass that crossed, kg.
    pub mass_kg: f64,
    /// Mass-weighted mean speed at the plane, m/s.
    pub impact_speed_m_per_s: Option<f64>,
    /// Mass-weighted mean speed traced back to the lip, m/s.
    pub lip_speed_m_per_s: Option<f64>,
    /// Mass-weighted mean angle below the horizontal traced back to the lip, degrees.
    pub lip_angle_deg: Option<f64>,
    /// 5–95 % range of `y` at the plane, m.
    pub width_m: Option<f64>,
    /// Mass fraction of fines in the outer layer.
    pub outer_fine_fraction: Option<f64>,
    /// Mass fraction of fines in the whole stream.
    pub fine_fraction: Option<f64>,
    /// Mass fed minus mass crossed, kg (≥ 0).
    pub held_up_mass_kg: f64,
}

/// The `q`-quantile (linear interpolation) of sorted values; `None` when empty.
fn quantile(sorted: &[f64], q: f64) -> Option<f64> {
    let last = sorted.len().checked_sub(1)?;
    let at = q.clamp(0.0, 1.0) * last as f64;
    let (lo, hi) = (at.floor() as usize, at.ceil() as usize);
    Some(sorted[lo] + (sorted[hi] - sorted[lo]) * (at - lo as f64))
}

fn sorted(values: impl Iterator<Item = f64>) -> Vec<f64> {
    let mut v: Vec<f64> = values.collect();
    v.sort_by(f64::total_cmp);
    v
}

/// Mass-weighted mean of `f` over the crossings; `None` without mass.
fn mass_mean(crossings: &[Crossing], f: impl Fn(&Crossing) -> f64) -> Option<f64> {
    let mass: f64 = crossings.iter().map(|c| c.mass_kg).sum();
    (mass > 0.0).then(|| crossings.iter().map(|c| c.mass_kg * f(c)).sum::<f64>() / mass)
}

fn fine_fraction(crossings: &[&Crossing], fine_type: u32) -> Option<f64> {
    let mass: f64 = crossings.iter().map(|c| c.mass_kg).sum();
    let fine: f64 = crossings
        .iter()
        .filter(|c| c.particle_type == fine_type)
        .map(|c| c.mass_kg)
        .sum();
    (mass > 0.0).then(|| fine / mass)
}

impl StreamResponses {
    /// The responses of `crossings` of the receiving plane.
    pub fn compute(crossings: &[Crossing], options: &StreamOptions) -> Self {
        let two_g_h = 2.0 * options.gravity_m_per_s2 * options.lip_height_m;
        let speed_squared = |c: &Crossing| c.velocity_m_per_s.iter().map(|v| v * v).sum::<f64>();
        let lip_vertical = |c: &Crossing| {
            let vz = c.velocity_m_per_s[2];
            (vz * vz - two_g_h).max(0.0).sqrt()
        };
        let horizontal = |c: &Crossing| c.velocity_m_per_s[0].hypot(c.velocity_m_per_s[1]);
        let xs = sorted(crossings.iter().map(|c| c.position_m[0]));
        let ys = sorted(crossings.iter().map(|c| c.position_m[1]));
        let range = |v: &[f64]| Some(quantile(v, 0.95)? - quantile(v, 0.05)?);
        let width_m = range(&ys);
        let outer_fine_fraction = (|| {
            let (x0, y0) = (quantile(&xs, 0.5)?, quantile(&ys, 0.5)?);
            let scale = |r: f64| if r > 0.0 { 0.5 * r } else { 1.0 };
            let (sx, sy) = (scale(range(&xs)?), scale(range(&ys)?));
            let distance =
                |c: &Crossing| ((c.position_m[0] - x0) / sx).hypot((c.position_m[1] - y0) / sy);
            let distances = sorted(crossings.iter().map(distance));
            let threshold = quantile(&distances, 1.0 - options.outer_layer)?;
            let outer: Vec<&Crossing> = crossings
                .iter()
                .filter(|c| distance(c) >= threshold)
                .collect();
            fine_fraction(&outer, options.fine_type)
        })();
        let mass_kg: f64 = crossings.iter().map(|c| c.mass_kg).sum();
        let all: Vec<&Crossing> = crossings.iter().collect();
        StreamResponses {
            count: crossings.len(),
            mass_kg,
            impact_speed_m_per_s: mass_mean(crossings, |c| speed_squared(c).sqrt()),
            lip_speed_m_per_s: mass_mean(crossings, |c| {
                (speed_squared(c) - two_g_h).max(0.0).sqrt()
            }),
            lip_angle_deg: mass_mean(crossings, |c| {
                lip_vertical(c).atan2(horizontal(c)).to_degrees()
            }),
            width_m,
            outer_fine_fraction,
            fine_fraction: fine_fraction(&all, options.fine_type),
            held_up_mass_kg: (options.fed_mass_kg - mass_kg).max(0.0),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn crossing(id: u64, kind: u32, mass: f64, position: [f64; 3], velocity: [f64; 3]) -> Crossing {
        Crossing {
            id,
            particle_type: kind,
            radius_m: 0.001,
            mass_kg: mass,
            position_m: position,
            velocity_m_per_s: velocity,
            time_s: id as f64 * 1e-3,
        }
    }

    fn options(fed_mass_kg: f64) -> StreamOptions {
        StreamOptions {
            fine_type: 2,
            lip_height_m: 0.1,
            gravity_m_per_s2: 9.81,
            fed_mass_kg,
            outer_layer: 0.1,
        }
    }

    #[test]
    fn a_projectile_traces_back_to_its_launch_speed_and_angle() {
        // Launched at 1.5 m/s, 30° below the horizontal, from 0.1 m above the plane.
        let (v0, angle) = (1.5f64, 30f64.to_radians());
        let (vx, vz0) = (v0 * angle.cos(), -v0 * angle.sin());
        let vz = -(vz0 * vz0 + 2.0 * 9.81 * 0.1).sqrt();
        let c = [crossing(1, 1, 1e-4, [0.3, 0.0, -0.1], [vx, 0.0, vz])];
        let r = StreamResponses::compute(&c, &options(1e-4));
        // Free fall: v² = v0² + 2 g h.
        let impact = (v0 * v0 + 2.0 * 9.81 * 0.1).sqrt();
        assert!((r.impact_speed_m_per_s.unwrap() - impact).abs() < 1e-12);
        assert!((r.lip_speed_m_per_s.unwrap() - v0).abs() < 1e-12);
        assert!((r.lip_angle_deg.unwrap() - 30.0).abs() < 1e-9);
        assert_eq!(r.held_up_mass_kg, 0.0);
        assert_eq!(r.count, 1);
    }

    #[test]
    fn speeds_are_mass_weighted_and_held_up_mass_is_fed_minus_crossed() {
        let c = [
            crossing(1, 1, 3e-4, [0.3, 0.0, -0.1], [0.0, 0.0, -2.0]),
            crossing(2, 2, 1e-4, [0.3, 0.0, -0.1], [0.0, 0.0, -4.0]),
        ];
        let r = StreamResponses::compute(&c, &options(1e-3));
        assert!((r.impact_speed_m_per_s.unwrap() - 2.5).abs() < 1e-12);
        assert!((r.held_up_mass_kg - 6e-4).abs() < 1e-15);
        assert!((r.fine_fraction.unwrap() - 0.25).abs() < 1e-12);
    }

    #[test]
    fn width_is_the_5_to_95_percent_range_across_the_flow() {
        // 101 crossings evenly across y ∈ [−0.05, 0.05]: the range is 0.09 m.
        let c: Vec<Crossing> = (0..=100)
            .map(|i| {
                let y = -0.05 + 0.001 * i as f64;
                crossing(i, 1, 1e-4, [0.3, y, -0.1], [1.0, 0.0, -2.0])
            })
            .collect();
        let r = StreamResponses::compute(&c, &options(0.0));
        assert!((r.width_m.unwrap() - 0.09).abs() < 1e-12);
    }

    #[test]
    fn the_outer_layer_is_a_tenth_of_the_stream_and_does_not_saturate() {
        // A core of 90 coarse particles within 1 cm of the centre and a ring of 10 at
        // 3 cm, of which 4 fine (by mass: 4 of 10 equal masses).
        let mut c = Vec::new();
        for i in 0..90u64 {
            let a = i as f64 * 0.7;
            let r = 0.01 * (i as f64 / 90.0);
            c.push(crossing(
                i,
                1,
                1e-4,
                [0.3 + r * a.cos(), r * a.sin(), -0.1],
                [1.0, 0.0, -2.0],
            ));
        }
        for i in 0..10u64 {
            let a = std::f64::consts::TAU * i as f64 / 10.0;
            let kind = if i < 4 { 2 } else { 1 };
            c.push(crossing(
                100 + i,
                kind,
                1e-4,
                [0.3 + 0.03 * a.cos(), 0.03 * a.sin(), -0.1],
                [1.0, 0.0, -2.0],
            ));
        }
        let r = StreamResponses::compute(&c, &options(0.0));
        assert!(
            (r.outer_fine_fraction.unwrap() - 0.4).abs() < 1e-12,
            "{r:?}"
        );
        assert!((r.fine_fraction.unwrap() - 0.04).abs() < 1e-12);
    }

    #[test]
    fn no_crossings_define_no_speeds_and_all_mass_is_held_up() {
        let r = StreamResponses::compute(&[], &options(0.5));
        assert_eq!(r.count, 0);
        assert_eq!(r.impact_speed_m_per_s, None);
        assert_eq!(r.width_m, None);
        assert_eq!(r.outer_fine_fraction, None);
        assert_eq!(r.held_up_mass_kg, 0.5);
    }
}
