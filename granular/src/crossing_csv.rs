//! The crossings table, the one owner of its format: a header line, then one row per
//! particle that crossed a sensor plane downwards, in SI units.
//!
//! ```text
//! time_s,id,type,radius_m,mass_kg,x_m,y_m,z_m,vx_m_per_s,vy_m_per_s,vz_m_per_s
//! 5e-1,7,1,2e-3,8e-5,1e-3,0e0,-5e-3,0e0,0e0,-1e0
//! ```
//!
//! The native kernel writes it (`post/crossings.csv`), the YADE script writes the same
//! header (rendered from [`HEADER`]) and rows, and the adapters read it back. Types are
//! numbered from 1, as LIGGGHTS numbers them. Text in, text out: no file is touched here.

use std::fmt;

use crate::crossing::Crossing;

/// The header line (without its newline).
pub const HEADER: &str = "time_s,id,type,radius_m,mass_kg,x_m,y_m,z_m,vx_m_s,vy_m_s,vz_m_s";

/// Number of fields of a row.
pub const FIELDS: usize = 11;

/// Appends `crossing` as one row (with its newline), numbers in shortest round-trip
/// exponent form.
pub fn write_row(out: &mut impl fmt::Write, crossing: &Crossing) -> fmt::Result {
    let ([x, y, z], [vx, vy, vz]) = (crossing.position_m, crossing.velocity_m_per_s);
    writeln!(
        out,
        "{:e},{},{},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e}",
        crossing.time_s,
        crossing.id,
        crossing.particle_type,
        crossing.radius_m,
        crossing.mass_kg,
        x,
        y,
        z,
        vx,
        vy,
        vz
    )
}

/// The crossing one row holds, or what is wrong with it (for a message that adds the
/// file and line).
pub fn parse_row(line: &str) -> Result<Crossing, String> {
    let numbers: Option<Vec<f64>> = line.split(',').map(|f| f.trim().parse().ok()).collect();
    let numbers = numbers
        .filter(|n| n.len() == FIELDS && n.iter().all(|v| v.is_finite()))
        .ok_or_else(|| format!("expected {FIELDS} finite numbers ({HEADER}), found `{line}`"))?;
    let (time, radius, mass) = (numbers[0], numbers[3], numbers[4]);
    if !(time >= 0.0 && radius > 0.0 && mass > 0.0) {
        return Err(format!(
            "a crossing needs a time ≥ 0 and a positive radius and mass, found time {time} s, radius {radius} m, mass {mass} kg"
        ));
    }
    Ok(Crossing {
        time_s: time,
        id: numbers[1] as u64,
        particle_type: numbers[2] as u32,
        radius_m: radius,
        mass_kg: mass,
        position_m: [numbers[5], numbers[6], numbers[7]],
        velocity_m_per_s: [numbers[8], numbers[9], numbers[10]],
    })
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    #[test]
    fn a_row_reads_back_as_the_crossing_it_was_written_from() {
        let crossing = Crossing {
            time_s: 0.5,
            id: 7,
            particle_type: 1,
            radius_m: 0.002,
            mass_kg: 8e-5,
            position_m: [0.001, 0.0, -0.005],
            velocity_m_per_s: [0.0, 0.0, -1.0],
        };
        let mut row = String::new();
        write_row(&mut row, &crossing).unwrap();
        assert_eq!(row, "5e-1,7,1,2e-3,8e-5,1e-3,0e0,-5e-3,0e0,0e0,-1e0\n");
        assert_eq!(parse_row(row.trim_end()), Ok(crossing));
    }

    #[test]
    fn a_short_or_impossible_row_says_what_it_expected() {
        assert!(parse_row("0.5,7,1")
            .unwrap_err()
            .contains("expected 11 finite numbers"));
        assert!(parse_row("0.5,7,1,0,8e-5,0,0,0,0,0,0")
            .unwrap_err()
            .contains("positive radius"));
    }

    proptest! {
        #[test]
        fn every_finite_crossing_round_trips_bit_for_bit(
            time in 0.0..10.0f64,
            id in 0u64..(1u64 << 52),
            kind in 1u32..10,
            radius in 1e-6..1e-1f64,
            mass in 1e-12..1.0f64,
            x in -1.0..1.0f64,
            v in -10.0..10.0f64,
        ) {
            let crossing = Crossing {
                time_s: time,
                id,
                particle_type: kind,
                radius_m: radius,
                mass_kg: mass,
                position_m: [x, -x, 0.5 * x],
                velocity_m_per_s: [v, 0.25 * v, -v],
            };
            let mut row = String::new();
            write_row(&mut row, &crossing).unwrap();
            prop_assert_eq!(parse_row(row.trim_end()), Ok(crossing));
        }
    }
}
