//! The air's velocity on a regular rectilinear grid, interpolated trilinearly.
//!
//! A field comes from a CSV text with the header `x,y,z,ux,uy,uz` (positions in m,
//! velocities in m/s) and one row per grid node, in any order. The grid's x, y and z
//! coordinates are the distinct values of each column (compared exactly, so a node's
//! coordinates must be written the same way on every row); the spacing along an axis
//! may vary, and every axis needs at least two coordinates. Every node of the grid
//! they span must appear exactly once:
//!
//! ```text
//! x,y,z,ux,uy,uz
//! 0.0,0.0,0.0,0.0,0.0,2.0
//! 0.1,0.0,0.0,0.0,0.0,2.0
//! ...
//! ```
//!
//! Inside the grid's box (its faces included) the velocity at a point is the trilinear
//! interpolation of the eight nodes of its cell, which gives node values exactly and
//! reproduces any linear field; outside it, [`AirField::velocity_at`] says `None` and
//! the caller uses the air's uniform velocity. Parsing reads a string; the
//! interpolation allocates nothing.

use crate::math::{Real, Vec3};

/// The header a field's CSV text starts with.
pub const AIR_FIELD_HEADER: &str = "x,y,z,ux,uy,uz";

/// The air's velocity at the nodes of a rectilinear grid.
#[derive(Debug, Clone, PartialEq)]
pub struct AirField {
    /// Node coordinates along x, ascending, m.
    x_m: Vec<Real>,
    /// Node coordinates along y, ascending, m.
    y_m: Vec<Real>,
    /// Node coordinates along z, ascending, m.
    z_m: Vec<Real>,
    /// Velocity of node `(i, j, k)` at `(i * ny + j) * nz + k`, m/s.
    velocity_m_per_s: Vec<Vec3>,
}

/// What is wrong with a field's CSV text; the caller adds the file name.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AirFieldError {
    /// A line does not read as expected.
    #[error("line {line}: {message}")]
    Line {
        /// Line number, from 1.
        line: usize,
        /// What was expected there.
        message: String,
    },
    /// The rows do not make up a grid.
    #[error("{0}")]
    Grid(String),
}

fn at_line(line: usize, message: impl Into<String>) -> AirFieldError {
    AirFieldError::Line {
        line,
        message: message.into(),
    }
}

/// A parsed row: its line number, node position (m) and velocity (m/s).
struct Row {
    line: usize,
    position_m: [Real; 3],
    velocity_m_per_s: Vec3,
}

const COLUMNS: [&str; 6] = ["x", "y", "z", "ux", "uy", "uz"];

impl AirField {
    /// Reads a field from its CSV text (see the module documentation).
    pub fn parse_csv(text: &str) -> Result<Self, AirFieldError> {
        let mut lines = text
            .lines()
            .enumerate()
            .map(|(k, line)| (k + 1, line.trim()))
            .filter(|(_, line)| !line.is_empty());
        let Some((line, header)) = lines.next() else {
            return Err(at_line(
                1,
                format!("expected the header `{AIR_FIELD_HEADER}`, but the file is empty"),
            ));
        };
        let header = header.trim_start_matches('\u{feff}');
        if !header
            .split(',')
            .map(str::trim)
            .eq(AIR_FIELD_HEADER.split(','))
        {
            return Err(at_line(
                line,
                format!("expected the header `{AIR_FIELD_HEADER}`, got `{header}`"),
            ));
        }
        let rows = lines.map(parse_row).collect::<Result<Vec<_>, _>>()?;
        if rows.is_empty() {
            return Err(AirFieldError::Grid(format!(
                "expected one row per grid node after the header `{AIR_FIELD_HEADER}`, got none"
            )));
        }
        let axes: [Vec<Real>; 3] = std::array::from_fn(|axis| {
            let mut values: Vec<Real> = rows.iter().map(|r| r.position_m[axis]).collect();
            values.sort_by(Real::total_cmp);
            values.dedup();
            values
        });
        for (axis, values) in axes.iter().enumerate() {
            if values.len() < 2 {
                return Err(AirFieldError::Grid(format!(
                    "expected at least two distinct {} values (a grid spans a box), got only {} = {}",
                    COLUMNS[axis], COLUMNS[axis], values[0]
                )));
            }
        }
        let node_of = |row: &Row| -> [usize; 3] {
            std::array::from_fn(|axis| {
                axes[axis]
                    .binary_search_by(|v| v.total_cmp(&row.position_m[axis]))
                    .expect("every coordinate is one of its axis's values")
            })
        };
        let mut nodes: Vec<([usize; 3], usize)> = rows
            .iter()
            .enumerate()
            .map(|(k, row)| (node_of(row), k))
            .collect();
        // By node, then by line, so that a repeat names the earlier line.
        nodes.sort_unstable();
        for pair in nodes.windows(2) {
            let ((node, first), (repeat, second)) = (pair[0], pair[1]);
            if node == repeat {
                let (earlier, row) = (&rows[first], &rows[second]);
                return Err(at_line(
                    row.line,
                    format!(
                        "the grid node {} appears again (first on line {}); expected each node exactly once",
                        position(&row.position_m),
                        earlier.line
                    ),
                ));
            }
        }
        let [nx, ny, nz] = axes.each_ref().map(Vec::len);
        let expected = (nx as u128) * (ny as u128) * (nz as u128);
        if (nodes.len() as u128) < expected {
            // Nodes are distinct and sorted as the grid enumerates them: the first gap
            // is the first missing node.
            let mut wanted = [0, 0, 0];
            for &(node, _) in &nodes {
                if node != wanted {
                    break;
                }
                wanted = if wanted[2] + 1 < nz {
                    [wanted[0], wanted[1], wanted[2] + 1]
                } else if wanted[1] + 1 < ny {
                    [wanted[0], wanted[1] + 1, 0]
                } else {
                    [wanted[0] + 1, 0, 0]
                };
            }
            let missing: [Real; 3] = std::array::from_fn(|axis| axes[axis][wanted[axis]]);
            return Err(AirFieldError::Grid(format!(
                "no row for the grid node {}; expected every node of the {nx} × {ny} × {nz} grid that the distinct x, y and z values span ({expected} rows), got {} rows",
                position(&missing),
                nodes.len()
            )));
        }
        let velocity_m_per_s = nodes
            .iter()
            .map(|&(_, k)| rows[k].velocity_m_per_s)
            .collect();
        let [x_m, y_m, z_m] = axes;
        Ok(Self {
            x_m,
            y_m,
            z_m,
            velocity_m_per_s,
        })
    }

    /// The air's velocity at `position_m`, m/s: the trilinear interpolation of its
    /// grid cell's nodes inside the grid's box (faces included), `None` outside it.
    pub fn velocity_at(&self, position_m: Vec3) -> Option<Vec3> {
        let (i, tx) = cell(&self.x_m, position_m.x)?;
        let (j, ty) = cell(&self.y_m, position_m.y)?;
        let (k, tz) = cell(&self.z_m, position_m.z)?;
        let (ny, nz) = (self.y_m.len(), self.z_m.len());
        let node = |i: usize, j: usize, k: usize| self.velocity_m_per_s[(i * ny + j) * nz + k];
        // `(1 − t) a + t b` is exact at both ends, so nodes and faces get their values.
        let lerp = |a: Vec3, b: Vec3, t: Real| a * (1.0 - t) + b * t;
        let along_z = |i: usize, j: usize| lerp(node(i, j, k), node(i, j, k + 1), tz);
        let along_y = |i: usize| lerp(along_z(i, j), along_z(i, j + 1), ty);
        Some(lerp(along_y(i), along_y(i + 1), tx))
    }

    /// The grid's lower corner, m.
    pub fn min_m(&self) -> Vec3 {
        Vec3::new(self.x_m[0], self.y_m[0], self.z_m[0])
    }

    /// The grid's upper corner, m.
    pub fn max_m(&self) -> Vec3 {
        let last = |v: &[Real]| v[v.len() - 1];
        Vec3::new(last(&self.x_m), last(&self.y_m), last(&self.z_m))
    }

    /// The number of nodes along x, y and z.
    pub fn node_counts(&self) -> [usize; 3] {
        [self.x_m.len(), self.y_m.len(), self.z_m.len()]
    }
}

/// The cell of ascending `nodes` (at least two) that holds `x`, and `x`'s fraction of
/// the way across it; `None` outside `[first, last]` (and for NaN).
#[inline]
fn cell(nodes: &[Real], x: Real) -> Option<(usize, Real)> {
    let last = nodes.len() - 1;
    if !(x >= nodes[0] && x <= nodes[last]) {
        return None;
    }
    // The last node at or below x, but the last cell for x on the upper face.
    let i = (nodes.partition_point(|&n| n <= x) - 1).min(last - 1);
    Some((i, (x - nodes[i]) / (nodes[i + 1] - nodes[i])))
}

fn position(p: &[Real; 3]) -> String {
    format!("(x, y, z) = ({}, {}, {})", p[0], p[1], p[2])
}

/// Reads data line `line` (numbered from 1).
fn parse_row((line, text): (usize, &str)) -> Result<Row, AirFieldError> {
    let fields: Vec<&str> = text.split(',').map(str::trim).collect();
    if fields.len() != COLUMNS.len() {
        return Err(at_line(
            line,
            format!(
                "expected {} comma-separated numbers ({AIR_FIELD_HEADER}), got {} fields in `{text}`",
                COLUMNS.len(),
                fields.len()
            ),
        ));
    }
    let mut values = [0.0; 6];
    for ((value, field), name) in values.iter_mut().zip(&fields).zip(COLUMNS) {
        *value = match field.parse::<Real>() {
            Ok(v) if v.is_finite() => v,
            Ok(v) => {
                return Err(at_line(
                    line,
                    format!("field `{name}`: expected a finite number, got {v}"),
                ))
            }
            Err(_) => {
                return Err(at_line(
                    line,
                    format!("field `{name}`: expected a number, got `{field}`"),
                ))
            }
        };
    }
    Ok(Row {
        line,
        position_m: [values[0], values[1], values[2]],
        velocity_m_per_s: Vec3::new(values[3], values[4], values[5]),
    })
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    /// The CSV text of `field` sampled on the grid `x × y × z`, rows in reverse order
    /// (any order is allowed).
    fn csv(x: &[Real], y: &[Real], z: &[Real], field: impl Fn(Vec3) -> Vec3) -> String {
        let mut rows = Vec::new();
        for &a in x {
            for &b in y {
                for &c in z {
                    let u = field(Vec3::new(a, b, c));
                    rows.push(format!("{a},{b},{c},{},{},{}", u.x, u.y, u.z));
                }
            }
        }
        rows.reverse();
        format!("{AIR_FIELD_HEADER}\n{}\n", rows.join("\n"))
    }

    const X: [Real; 3] = [-0.1, 0.0, 0.25];
    const Y: [Real; 2] = [0.0, 0.1];
    const Z: [Real; 4] = [0.0, 0.05, 0.1, 0.3];

    fn linear(p: Vec3) -> Vec3 {
        Vec3::new(
            1.0 + 2.0 * p.x - 3.0 * p.y + 0.5 * p.z,
            -0.5 + 4.0 * p.z,
            2.0 - p.x + p.y,
        )
    }

    fn error_of(text: &str) -> String {
        AirField::parse_csv(text).unwrap_err().to_string()
    }

    #[test]
    fn the_grid_is_inferred_from_the_distinct_coordinates() {
        let field = AirField::parse_csv(&csv(&X, &Y, &Z, linear)).unwrap();
        assert_eq!(field.node_counts(), [3, 2, 4]);
        assert_eq!(field.min_m(), Vec3::new(-0.1, 0.0, 0.0));
        assert_eq!(field.max_m(), Vec3::new(0.25, 0.1, 0.3));
    }

    #[test]
    fn node_values_are_given_exactly() {
        // Values no interpolation could make up by rounding luck.
        let wild = |p: Vec3| Vec3::new((37.0 * p.x).sin(), (p.y * p.z).exp(), 1.0 / (3.0 + p.x));
        let field = AirField::parse_csv(&csv(&X, &Y, &Z, wild)).unwrap();
        for &a in &X {
            for &b in &Y {
                for &c in &Z {
                    let p = Vec3::new(a, b, c);
                    // The text round-trips f64 exactly, so the node gives back `wild`.
                    assert_eq!(field.velocity_at(p), Some(wild(p)), "at {p:?}");
                }
            }
        }
    }

    #[test]
    fn outside_the_box_there_is_no_field() {
        let field = AirField::parse_csv(&csv(&X, &Y, &Z, linear)).unwrap();
        for p in [
            Vec3::new(-0.1000001, 0.05, 0.1),
            Vec3::new(0.2500001, 0.05, 0.1),
            Vec3::new(0.0, -1e-9, 0.1),
            Vec3::new(0.0, 0.05, 0.31),
            Vec3::new(Real::NAN, 0.05, 0.1),
        ] {
            assert_eq!(field.velocity_at(p), None, "at {p:?}");
        }
        // The faces belong to the box.
        assert!(field.velocity_at(Vec3::new(0.25, 0.1, 0.3)).is_some());
    }

    #[test]
    fn a_linear_field_is_reproduced_at_a_handful_of_points() {
        let field = AirField::parse_csv(&csv(&X, &Y, &Z, linear)).unwrap();
        for p in [
            Vec3::new(-0.05, 0.03, 0.07),
            Vec3::new(0.2, 0.09, 0.29),
            Vec3::new(0.0, 0.05, 0.3),
            Vec3::new(0.25, 0.0, 0.01),
        ] {
            let u = field.velocity_at(p).unwrap();
            assert!((u - linear(p)).norm() < 1e-12, "{u:?} vs {:?}", linear(p));
        }
    }

    /// Ascending, distinct coordinates, two to five of them, spread over ±1 m.
    fn axis() -> impl Strategy<Value = Vec<Real>> {
        prop::collection::vec(0.01..0.5f64, 1..5).prop_flat_map(|steps| {
            (-1.0..0.0f64).prop_map(move |start| {
                let mut nodes = vec![start];
                for step in &steps {
                    nodes.push(nodes[nodes.len() - 1] + step);
                }
                nodes
            })
        })
    }

    proptest! {
        #[test]
        fn any_linear_field_is_reproduced_inside_the_box(
            x in axis(),
            y in axis(),
            z in axis(),
            gradient in prop::array::uniform9(-5.0..5.0f64),
            offset in prop::array::uniform3(-5.0..5.0f64),
            fractions in prop::array::uniform3(0.0..=1.0f64),
        ) {
            let u = |p: Vec3| {
                let g = &gradient;
                Vec3::new(
                    offset[0] + g[0] * p.x + g[1] * p.y + g[2] * p.z,
                    offset[1] + g[3] * p.x + g[4] * p.y + g[5] * p.z,
                    offset[2] + g[6] * p.x + g[7] * p.y + g[8] * p.z,
                )
            };
            let field = AirField::parse_csv(&csv(&x, &y, &z, u)).unwrap();
            let (min, max) = (field.min_m(), field.max_m());
            let p = min + (max - min).component_mul(&Vec3::from(fractions));
            let p = p.zip_map(&max, Real::min);
            let interpolated = field.velocity_at(p).unwrap();
            prop_assert!(
                (interpolated - u(p)).norm() < 1e-10 * (1.0 + u(p).norm()),
                "{interpolated:?} vs {:?} at {p:?}", u(p)
            );
        }
    }

    #[test]
    fn a_bad_header_names_its_line_and_the_expected_header() {
        let text = csv(&X, &Y, &Z, linear).replace("ux,uy,uz", "u,v,w");
        assert_eq!(
            error_of(&format!("\n{text}")),
            "line 2: expected the header `x,y,z,ux,uy,uz`, got `x,y,z,u,v,w`"
        );
        assert_eq!(
            error_of("  \n"),
            "line 1: expected the header `x,y,z,ux,uy,uz`, but the file is empty"
        );
        assert_eq!(
            error_of("x,y,z,ux,uy,uz\n"),
            "expected one row per grid node after the header `x,y,z,ux,uy,uz`, got none"
        );
    }

    #[test]
    fn a_value_that_is_not_a_number_names_its_line_and_field() {
        let text = "x,y,z,ux,uy,uz\n0,0,0,0,0,1\n1,0,0,0,fast,1\n";
        assert_eq!(
            error_of(text),
            "line 3: field `uy`: expected a number, got `fast`"
        );
        let text = "x,y,z,ux,uy,uz\n0,0,0,0,0,1\n1,0,NaN,0,0,1\n";
        assert_eq!(
            error_of(text),
            "line 3: field `z`: expected a finite number, got NaN"
        );
        let text = "x,y,z,ux,uy,uz\n0,0,0,0,0\n";
        assert_eq!(
            error_of(text),
            "line 2: expected 6 comma-separated numbers (x,y,z,ux,uy,uz), got 5 fields in `0,0,0,0,0`"
        );
    }

    #[test]
    fn a_missing_node_is_named_with_the_grid_it_breaks() {
        let text = csv(&X, &Y, &Z, linear);
        // Drop the node (0, 0.1, 0.05).
        let dropped: Vec<&str> = text
            .lines()
            .filter(|l| !l.starts_with("0,0.1,0.05,"))
            .collect();
        assert_eq!(dropped.len(), text.lines().count() - 1);
        assert_eq!(
            error_of(&dropped.join("\n")),
            "no row for the grid node (x, y, z) = (0, 0.1, 0.05); expected every node of the 3 × 2 × 4 grid that the distinct x, y and z values span (24 rows), got 23 rows"
        );
        // A stray coordinate opens a whole plane of missing nodes.
        let text = format!("{}\n0.3,0,0,1,1,1\n", text.trim_end());
        assert!(
            error_of(&text).starts_with("no row for the grid node (x, y, z) = (0.3, 0, 0.05); expected every node of the 4 × 2 × 4 grid"),
            "{}",
            error_of(&text)
        );
    }

    #[test]
    fn a_repeated_node_names_both_its_lines() {
        let text = "x,y,z,ux,uy,uz\n0,0,0,0,0,1\n1,0,0,0,0,1\n0,1,0,0,0,1\n1,1,0,0,0,1\n0,0,1,0,0,1\n1,0,1,0,0,1\n0,1,1,0,0,1\n1,1,1,0,0,1\n1.0,0,0.0,5,5,5\n";
        assert_eq!(
            error_of(text),
            "line 10: the grid node (x, y, z) = (1, 0, 0) appears again (first on line 3); expected each node exactly once"
        );
    }

    #[test]
    fn a_flat_grid_is_refused() {
        let text = "x,y,z,ux,uy,uz\n0,0,0,0,0,1\n1,0,0,0,0,1\n0,1,0,0,0,1\n1,1,0,0,0,1\n";
        assert_eq!(
            error_of(text),
            "expected at least two distinct z values (a grid spans a box), got only z = 0"
        );
    }
}
