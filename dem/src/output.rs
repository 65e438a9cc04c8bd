//! Output formats the kernel owns, written to any [`std::io::Write`]: LIGGGHTS
//! `dump custom` text (so one parser serves both solvers), VTK legacy for ParaView, and
//! the sensor's crossings as CSV.

use std::io::{self, Write};

use crate::math::Vec3;
use crate::particles::Particles;
use crate::simulation::Crossing;

/// The columns of [`write_dump_custom`], as LIGGGHTS names them; the angular
/// velocity (rad/s) comes last so that readers of the older columns still find theirs.
pub const DUMP_COLUMNS: &str = "id type radius mass x y z vx vy vz omegax omegay omegaz";

/// One snapshot in LIGGGHTS `dump custom` format with the columns [`DUMP_COLUMNS`];
/// types are numbered from 1 as in LIGGGHTS.
pub fn write_dump_custom(
    out: &mut impl Write,
    step: u64,
    particles: &Particles,
    box_min_m: Vec3,
    box_max_m: Vec3,
) -> io::Result<()> {
    writeln!(out, "ITEM: TIMESTEP\n{step}")?;
    writeln!(out, "ITEM: NUMBER OF ATOMS\n{}", particles.len())?;
    writeln!(out, "ITEM: BOX BOUNDS ff ff ff")?;
    for k in 0..3 {
        writeln!(out, "{:e} {:e}", box_min_m[k], box_max_m[k])?;
    }
    writeln!(out, "ITEM: ATOMS {DUMP_COLUMNS}")?;
    for i in 0..particles.len() {
        let (x, v) = (particles.position_m[i], particles.velocity_m_per_s[i]);
        let w = particles.angular_velocity[i];
        writeln!(
            out,
            "{} {} {:e} {:e} {:e} {:e} {:e} {:e} {:e} {:e} {:e} {:e} {:e}",
            particles.id[i],
            particles.kind[i] + 1,
            particles.radius_m[i],
            particles.mass_kg[i],
            x.x,
            x.y,
            x.z,
            v.x,
            v.y,
            v.z,
            w.x,
            w.y,
            w.z
        )?;
    }
    Ok(())
}

/// All particles as VTK legacy polydata: points with `id`, `type`, `radius`,
/// `velocity` (m/s) and `angular_velocity` (rad/s) arrays (in ParaView, glyph by `radius` to see spheres).
pub fn write_vtk_legacy(
    out: &mut impl Write,
    time_s: f64,
    particles: &Particles,
) -> io::Result<()> {
    let n = particles.len();
    writeln!(
        out,
        "# vtk DataFile Version 3.0\norch-dem particles at t = {time_s} s\nASCII\nDATASET POLYDATA"
    )?;
    writeln!(out, "POINTS {n} double")?;
    for x in &particles.position_m {
        writeln!(out, "{:e} {:e} {:e}", x.x, x.y, x.z)?;
    }
    writeln!(out, "VERTICES {n} {}", 2 * n)?;
    for i in 0..n {
        writeln!(out, "1 {i}")?;
    }
    writeln!(out, "POINT_DATA {n}")?;
    writeln!(out, "SCALARS id int 1\nLOOKUP_TABLE default")?;
    for id in &particles.id {
        writeln!(out, "{id}")?;
    }
    writeln!(out, "SCALARS type int 1\nLOOKUP_TABLE default")?;
    for kind in &particles.kind {
        writeln!(out, "{}", kind + 1)?;
    }
    writeln!(out, "SCALARS radius double 1\nLOOKUP_TABLE default")?;
    for r in &particles.radius_m {
        writeln!(out, "{r:e}")?;
    }
    writeln!(out, "VECTORS velocity double")?;
    for v in &particles.velocity_m_per_s {
        writeln!(out, "{:e} {:e} {:e}", v.x, v.y, v.z)?;
    }
    writeln!(out, "VECTORS angular_velocity double")?;
    for w in &particles.angular_velocity {
        writeln!(out, "{:e} {:e} {:e}", w.x, w.y, w.z)?;
    }
    Ok(())
}

/// Header of the crossings CSV ([`orch_granular::crossing_csv`] owns the format).
pub use orch_granular::crossing_csv::HEADER as CROSSINGS_HEADER;

/// Appends crossings as rows of the crossings table ([`orch_granular::crossing_csv`]).
pub fn write_crossings(out: &mut impl Write, crossings: &[Crossing]) -> io::Result<()> {
    let mut rows = String::new();
    for crossing in crossings {
        orch_granular::crossing_csv::write_row(&mut rows, crossing)
            .expect("writing to a String cannot fail");
    }
    out.write_all(rows.as_bytes())
}
