//! An initial packing given as a LAMMPS data file, the format LAMMPS's and LIGGGHTS's
//! `read_data` read, so that all three codes can start from the very same spheres.
//!
//! Only what a packing of spheres at rest needs is read: the header's atom count and
//! the `Atoms` section in the `sphere` (LAMMPS) or `granular` (LIGGGHTS) style,
//! `id type diameter density x y z`, SI units (m, kg/m³), each row optionally followed
//! by three image flags, which are ignored. Ids must ascend; the particles start at
//! rest, so a `Velocities` section is refused rather than silently dropped. The box
//! lines and any other header lines are left to the codes that need them.
//!
//! ```text
//! LAMMPS data file: settled bed
//!
//! 2 atoms
//! 2 atom types
//! -0.01 0.01 xlo xhi
//! -0.01 0.01 ylo yhi
//! 0 0.02 zlo zhi
//!
//! Atoms # sphere
//!
//! 1 1 0.004 2500 0 0 0.002
//! 2 2 0.002 2500 0.005 0 0.001
//! ```

use crate::math::{Real, Vec3};

/// One sphere of a packing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PackedSphere {
    /// Id, ascending through the file.
    pub id: u32,
    /// Type, counted from 1 as in dumps and data files.
    pub kind: u32,
    /// Radius, m.
    pub radius_m: Real,
    /// Density, kg/m³.
    pub density_kg_m3: Real,
    /// Centre, m.
    pub position_m: Vec3,
}

/// What is wrong with a packing file, with the line (counted from 1) when one line is.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PackingError {
    /// A line of the file is not what the format expects.
    #[error("line {line}: {message}")]
    Line {
        /// Line number, from 1.
        line: usize,
        /// What was expected.
        message: String,
    },
    /// The file as a whole does not add up.
    #[error("{0}")]
    File(String),
}

fn at(line: usize, message: impl Into<String>) -> PackingError {
    PackingError::Line {
        line,
        message: message.into(),
    }
}

/// Reads the spheres of a LAMMPS data file's `Atoms` section (see the module docs).
pub fn parse_lammps_data(text: &str) -> Result<Vec<PackedSphere>, PackingError> {
    let mut declared: Option<usize> = None;
    let mut spheres: Vec<PackedSphere> = Vec::new();
    let mut in_atoms = false;
    // The first line is a title, whatever it says.
    for (index, raw) in text.lines().enumerate().skip(1) {
        let line = index + 1;
        let content = raw.split('#').next().unwrap_or("").trim();
        if content.is_empty() {
            continue;
        }
        let words: Vec<&str> = content.split_whitespace().collect();
        let keyword_line = words[0].parse::<f64>().is_err();
        if keyword_line {
            match words[0] {
                "Atoms" => {
                    if let Some(style) = raw.split('#').nth(1).map(str::trim) {
                        if !style.is_empty() && style != "sphere" && style != "granular" {
                            return Err(at(
                                line,
                                format!("expected `Atoms # sphere` or `Atoms # granular`, got the atom style `{style}`"),
                            ));
                        }
                    }
                    in_atoms = true;
                }
                "Velocities" => {
                    return Err(at(
                        line,
                        "a packing starts at rest: remove the Velocities section",
                    ))
                }
                other => {
                    if in_atoms {
                        return Err(at(
                            line,
                            format!("unexpected section `{other}` after Atoms; a packing has only Atoms"),
                        ));
                    }
                    return Err(at(line, format!("unexpected section `{other}`")));
                }
            }
            continue;
        }
        if !in_atoms {
            // A header line: only the atom count matters here.
            if words.len() == 2 && words[1] == "atoms" {
                let count = words[0]
                    .parse::<usize>()
                    .map_err(|_| at(line, format!("expected an atom count, got `{}`", words[0])))?;
                declared = Some(count);
            }
            continue;
        }
        if words.len() != 7 && words.len() != 10 {
            return Err(at(
                line,
                format!(
                    "expected `id type diameter density x y z` (and optionally three image flags), got {} fields",
                    words.len()
                ),
            ));
        }
        let integer = |k: usize, name: &str| -> Result<u32, PackingError> {
            words[k].parse::<u32>().map_err(|_| {
                at(
                    line,
                    format!(
                        "field `{name}`: expected a positive integer, got `{}`",
                        words[k]
                    ),
                )
            })
        };
        let number = |k: usize, name: &str| -> Result<Real, PackingError> {
            let value = words[k].parse::<Real>().map_err(|_| {
                at(
                    line,
                    format!("field `{name}`: expected a number, got `{}`", words[k]),
                )
            })?;
            if value.is_finite() {
                Ok(value)
            } else {
                Err(at(
                    line,
                    format!(
                        "field `{name}`: expected a finite number, got `{}`",
                        words[k]
                    ),
                ))
            }
        };
        let id = integer(0, "id")?;
        let kind = integer(1, "type")?;
        let diameter = number(2, "diameter")?;
        let density = number(3, "density")?;
        if kind == 0 {
            return Err(at(line, "field `type`: types count from 1"));
        }
        if diameter <= 0.0 || density <= 0.0 {
            return Err(at(
                line,
                format!(
                    "diameter and density must be positive, got {diameter} m and {density} kg/m³"
                ),
            ));
        }
        if let Some(previous) = spheres.last() {
            if id <= previous.id {
                return Err(at(
                    line,
                    format!("ids must ascend: {id} follows {}", previous.id),
                ));
            }
        }
        spheres.push(PackedSphere {
            id,
            kind,
            radius_m: 0.5 * diameter,
            density_kg_m3: density,
            position_m: Vec3::new(number(4, "x")?, number(5, "y")?, number(6, "z")?),
        });
    }
    match declared {
        None => Err(PackingError::File(
            "the header declares no atom count (`N atoms`)".to_string(),
        )),
        Some(n) if n != spheres.len() => Err(PackingError::File(format!(
            "the header declares {n} atoms, the Atoms section has {}",
            spheres.len()
        ))),
        Some(_) => Ok(spheres),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TWO: &str = "LAMMPS data file: two spheres

2 atoms
2 atom types
-0.01 0.01 xlo xhi
-0.01 0.01 ylo yhi
0 0.02 zlo zhi

Atoms # sphere

1 1 0.004 2500 0 0 0.002
2 2 0.002 2600 0.005 0 0.001 0 0 0
";

    #[test]
    fn the_atoms_section_is_read_with_radii_from_diameters() {
        let spheres = parse_lammps_data(TWO).unwrap();
        assert_eq!(spheres.len(), 2);
        assert_eq!(
            spheres[1],
            PackedSphere {
                id: 2,
                kind: 2,
                radius_m: 0.001,
                density_kg_m3: 2600.0,
                position_m: Vec3::new(0.005, 0.0, 0.001),
            }
        );
        let granular = TWO.replace("# sphere", "# granular");
        assert_eq!(parse_lammps_data(&granular).unwrap(), spheres);
    }

    #[test]
    fn bad_files_are_refused_naming_the_line() {
        let cases = [
            (TWO.replace("2 atoms", "3 atoms"), "the header declares 3 atoms, the Atoms section has 2"),
            (TWO.replace("2 2 0.002", "1 2 0.002"), "line 12: ids must ascend: 1 follows 1"),
            (TWO.replace("0.005 0 0.001 0 0 0", "0.005 0"), "line 12: expected `id type diameter density x y z` (and optionally three image flags), got 6 fields"),
            (TWO.replace("# sphere", "# atomic"), "line 9: expected `Atoms # sphere` or `Atoms # granular`, got the atom style `atomic`"),
            (format!("{TWO}\nVelocities\n\n1 0 0 0 0 0 0\n"), "line 14: a packing starts at rest: remove the Velocities section"),
            (TWO.replace("1 1 0.004 2500 0 0 0.002", "1 1 0.004 2500 0 0 nan"), "line 11: field `z`: expected a finite number, got `nan`"),
            (TWO.replace("1 1 0.004", "1 0 0.004"), "line 11: field `type`: types count from 1"),
        ];
        for (text, message) in cases {
            assert_eq!(parse_lammps_data(&text).unwrap_err().to_string(), message);
        }
    }
}
