//! STL triangle meshes for wall geometry.
//!
//! [`parse_stl`] reads a binary or ASCII STL file into triangles, and
//! [`WeldedMesh::from_triangles`] merges their shared corners into vertices and
//! numbers their edges, so that a particle touching a shared edge or vertex can
//! be counted as one contact rather than one per triangle. All lengths are in
//! metres.

use std::collections::HashMap;
use thiserror::Error;

/// A triangle's three corners, m.
pub type Corners = [[f64; 3]; 3];

/// Size of a binary STL's header plus its triangle count, bytes.
const BINARY_PREAMBLE_BYTES: usize = 84;
/// Size of one binary STL triangle record, bytes.
const BINARY_RECORD_BYTES: usize = 50;
/// Corners closer than this fraction of the bounding-box diagonal are welded.
const WELD_TOLERANCE: f64 = 1e-9;
/// Triangles with less area than this fraction of the squared diagonal are degenerate.
const DEGENERATE_AREA: f64 = 1e-12;
/// The most triangles whose vertex and edge ids (at most three per triangle) fit in `u32`.
const MAX_TRIANGLES: usize = (u32::MAX / 3) as usize;

/// Why an STL file could not be read. Messages say what is wrong, where, and
/// what was expected; the caller adds the file path.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum StlError {
    /// The file has no bytes, or declares or contains no triangles.
    #[error("the STL file holds no triangles; expected at least one `facet` (ASCII) or a non-zero triangle count (binary)")]
    Empty,
    /// A binary file whose length does not match the triangle count in its header.
    #[error("the binary STL header declares {triangles_declared} triangles, which need {expected_bytes} bytes (84-byte header + 50 bytes per triangle), but the file has {bytes} bytes; expected a complete binary STL file (this one is truncated, padded or not STL)")]
    TruncatedBinary {
        /// Triangle count stored in bytes 80..84 of the file.
        triangles_declared: u32,
        /// Actual file length, bytes.
        bytes: usize,
        /// File length the declared count requires, bytes.
        expected_bytes: usize,
    },
    /// An ASCII file has something other than what the grammar allows at this point.
    #[error("line {line}: expected {expected}, found {found}")]
    Syntax {
        /// Line number, counting from 1.
        line: usize,
        /// What the grammar allows here, e.g. "`vertex x y z`".
        expected: String,
        /// What the line holds instead (or "the end of the file").
        found: String,
    },
    /// An ASCII file ends inside a facet, or without `endsolid`.
    #[error("the ASCII STL file ends at line {line} while {what}")]
    Unterminated {
        /// Last line of the file, counting from 1.
        line: usize,
        /// What is left open and the keyword(s) that should have closed it.
        what: String,
    },
    /// An ASCII coordinate that is not a decimal number.
    #[error("line {line}: `{text}` is not a number; expected a decimal coordinate such as `1`, `-0.5` or `4.0E+01`")]
    BadNumber {
        /// Line number, counting from 1.
        line: usize,
        /// The offending text.
        text: String,
    },
    /// A corner coordinate that is NaN or infinite.
    #[error("facet {facet}{}: a corner coordinate is NaN or infinite; expected finite coordinates in metres", at_line(.line))]
    NonFinite {
        /// Facet number, counting from 1.
        facet: usize,
        /// Line number for ASCII files, counting from 1; `None` for binary files.
        line: Option<usize>,
    },
}

/// Formats an optional line number as a message suffix.
fn at_line(line: &Option<usize>) -> String {
    line.map_or_else(String::new, |line| format!(" (line {line})"))
}

/// Why triangles could not be welded into a usable mesh.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum MeshError {
    /// No triangles were given.
    #[error("the mesh has no triangles; expected at least one")]
    Empty,
    /// A zero-area triangle, which has no usable normal for contact.
    #[error("facet {facet} is degenerate: its corners {corners:?} enclose {area_m2:.3e} m²; expected three distinct, non-collinear corners. Re-export the mesh without degenerate (zero-area) facets")]
    Degenerate {
        /// Facet number, counting from 1.
        facet: usize,
        /// The facet's corners as given, m.
        corners: Corners,
        /// The facet's area, m².
        area_m2: f64,
    },
    /// An edge shared by more than two triangles, so "the other side" is ambiguous.
    #[error("the edge from {a:?} to {b:?} is shared by {} facets ({}); expected at most two facets per edge (a manifold surface). Re-export the mesh so that each edge joins at most two facets", .facets.len(), facet_list(.facets))]
    NonManifoldEdge {
        /// One end of the edge, m.
        a: [f64; 3],
        /// The other end of the edge, m.
        b: [f64; 3],
        /// Numbers of the facets on the edge, counting from 1.
        facets: Vec<usize>,
    },
    /// A corner coordinate that is NaN or infinite.
    #[error("facet {facet} has a NaN or infinite corner coordinate; expected finite coordinates in metres")]
    NonFinite {
        /// Facet number, counting from 1.
        facet: usize,
    },
    /// More triangles than 32-bit vertex and edge ids can number.
    #[error("the mesh has {triangles} triangles; expected at most {MAX_TRIANGLES} so that vertex and edge ids fit in 32 bits")]
    TooLarge {
        /// Number of triangles given.
        triangles: usize,
    },
}

/// Formats facet numbers as "facets 1, 2, 3".
fn facet_list(facets: &[usize]) -> String {
    let numbers: Vec<String> = facets.iter().map(usize::to_string).collect();
    format!("facets {}", numbers.join(", "))
}

/// Reads an STL file's bytes, binary or ASCII, into triangles (facet normals in the file are ignored; orientation is not used).
///
/// A file is binary when its length is exactly 84 bytes plus 50 per triangle
/// declared at bytes 80..84, even if its header begins with `solid` (many
/// exporters write that). Otherwise a file beginning with the keyword `solid`
/// is read as ASCII; several solids in one file are concatenated. Binary
/// coordinates are `f32` widened to `f64`.
pub fn parse_stl(bytes: &[u8]) -> Result<Vec<Corners>, StlError> {
    if bytes.iter().all(u8::is_ascii_whitespace) {
        return Err(StlError::Empty);
    }
    let declared = declared_triangles(bytes);
    if let Some((count, expected_bytes)) = declared {
        if expected_bytes == bytes.len() {
            return parse_binary(count, &bytes[BINARY_PREAMBLE_BYTES..]);
        }
    }
    // A binary file (NUL bytes) whose header says "solid" but whose length is wrong
    // is reported as a bad binary file, not as ASCII gibberish.
    let looks_binary = declared.is_some() && bytes.contains(&0);
    if starts_with_solid(bytes) && !looks_binary {
        return parse_ascii(&String::from_utf8_lossy(bytes));
    }
    match declared {
        Some((triangles_declared, expected_bytes)) => Err(StlError::TruncatedBinary {
            triangles_declared,
            bytes: bytes.len(),
            expected_bytes,
        }),
        None => Err(StlError::Syntax {
            line: 1,
            expected: "`solid` (ASCII STL) or an 84-byte header (binary STL)".to_string(),
            found: quote(&String::from_utf8_lossy(bytes)),
        }),
    }
}

/// The triangle count in a binary header and the file length it implies, if
/// the file is long enough to have a header.
fn declared_triangles(bytes: &[u8]) -> Option<(u32, usize)> {
    let count = bytes.get(80..BINARY_PREAMBLE_BYTES)?;
    let count = u32::from_le_bytes([count[0], count[1], count[2], count[3]]);
    let expected = usize::try_from(count)
        .unwrap_or(usize::MAX)
        .saturating_mul(BINARY_RECORD_BYTES)
        .saturating_add(BINARY_PREAMBLE_BYTES);
    Some((count, expected))
}

/// Whether the text, after leading whitespace, begins with the keyword `solid`.
fn starts_with_solid(bytes: &[u8]) -> bool {
    let text = bytes.trim_ascii_start();
    text.get(..5)
        .is_some_and(|word| word.eq_ignore_ascii_case(b"solid"))
        && text.get(5).is_none_or(u8::is_ascii_whitespace)
}

/// Reads the 50-byte triangle records that follow a binary header.
fn parse_binary(count: u32, records: &[u8]) -> Result<Vec<Corners>, StlError> {
    if count == 0 {
        return Err(StlError::Empty);
    }
    let mut triangles = Vec::with_capacity(records.len() / BINARY_RECORD_BYTES);
    for (index, record) in records.chunks_exact(BINARY_RECORD_BYTES).enumerate() {
        // Bytes 0..12 are the normal (ignored); 12..48 the three corners.
        let value = |k: usize| {
            let at = 12 + 4 * k;
            let raw = [record[at], record[at + 1], record[at + 2], record[at + 3]];
            f64::from(f32::from_le_bytes(raw))
        };
        let corners = [0, 1, 2].map(|corner| [0, 1, 2].map(|axis| value(3 * corner + axis)));
        if corners.iter().flatten().any(|c| !c.is_finite()) {
            return Err(StlError::NonFinite {
                facet: index + 1,
                line: None,
            });
        }
        triangles.push(corners);
    }
    Ok(triangles)
}

/// Reads ASCII STL text: one or more `solid ... endsolid` blocks of facets.
fn parse_ascii(text: &str) -> Result<Vec<Corners>, StlError> {
    let mut parser = AsciiParser::new(text);
    let mut triangles = Vec::new();
    while let Some((line, word)) = parser.next() {
        if !word.eq_ignore_ascii_case("solid") {
            return Err(parser.syntax(line, "`solid` or the end of the file"));
        }
        parser.skip_line(line); // the solid's name
        loop {
            match parser.next() {
                None => {
                    return Err(StlError::Unterminated {
                        line: parser.last_line(),
                        what: format!(
                            "{} (opened on line {line}) is still open; expected `endsolid`",
                            parser.found(line)
                        ),
                    })
                }
                Some((at, word)) if word.eq_ignore_ascii_case("facet") => {
                    triangles.push(parser.facet(triangles.len() + 1, at)?);
                }
                Some((at, word)) if word.eq_ignore_ascii_case("endsolid") => {
                    parser.skip_line(at); // the solid's name again
                    break;
                }
                Some((at, _)) => return Err(parser.syntax(at, "`facet` or `endsolid`")),
            }
        }
    }
    if triangles.is_empty() {
        return Err(StlError::Empty);
    }
    Ok(triangles)
}

/// Quotes the first non-blank line of `text` for an error message, shortened if long.
fn quote(text: &str) -> String {
    let line = text.trim().lines().next().unwrap_or_default().trim();
    let short: String = line.chars().take(60).collect();
    let more = if short.len() < line.len() { "…" } else { "" };
    format!("`{short}{more}`")
}

/// A whitespace-separated token stream over ASCII STL, remembering line numbers.
struct AsciiParser<'a> {
    /// The file's lines, for quoting in messages.
    lines: Vec<&'a str>,
    /// Every token with its line number (from 1).
    tokens: Vec<(usize, &'a str)>,
    /// Index of the next token.
    next: usize,
    /// Number (from 1) and opening line of the facet being read.
    facet: (usize, usize),
}

impl<'a> AsciiParser<'a> {
    fn new(text: &'a str) -> Self {
        let lines: Vec<&str> = text.lines().collect();
        let tokens = lines
            .iter()
            .enumerate()
            .flat_map(|(i, line)| line.split_whitespace().map(move |t| (i + 1, t)))
            .collect();
        AsciiParser {
            lines,
            tokens,
            next: 0,
            facet: (0, 0),
        }
    }

    fn next(&mut self) -> Option<(usize, &'a str)> {
        let token = self.tokens.get(self.next).copied();
        self.next += 1;
        token
    }

    /// Skips the remaining tokens on `line`.
    fn skip_line(&mut self, line: usize) {
        let rest = self.tokens.get(self.next..).unwrap_or_default();
        self.next += rest.iter().take_while(|&&(at, _)| at == line).count();
    }

    fn last_line(&self) -> usize {
        self.lines.len().max(1)
    }

    /// The text of `line`, quoted.
    fn found(&self, line: usize) -> String {
        line.checked_sub(1)
            .and_then(|i| self.lines.get(i))
            .map_or_else(|| "the end of the file".to_string(), |text| quote(text))
    }

    fn syntax(&self, line: usize, expected: &str) -> StlError {
        StlError::Syntax {
            line,
            expected: expected.to_string(),
            found: self.found(line),
        }
    }

    /// A syntax error inside the current facet, naming it.
    fn facet_syntax(&self, line: usize, expected: &str) -> StlError {
        self.syntax(line, &format!("{expected} in facet {}", self.facet.0))
    }

    /// The file ended inside the current facet, which still `needs` some keywords.
    fn unterminated(&self, needs: &str) -> StlError {
        let (facet, opened) = self.facet;
        StlError::Unterminated {
            line: self.last_line(),
            what: format!(
                "facet {facet} (opened on line {opened}) is still open; expected {needs}"
            ),
        }
    }

    /// Reads keyword `word` (any case), returning its line.
    fn keyword(&mut self, word: &str, expected: &str, needs: &str) -> Result<usize, StlError> {
        match self.next() {
            None => Err(self.unterminated(needs)),
            Some((line, found)) if found.eq_ignore_ascii_case(word) => Ok(line),
            Some((line, _)) => Err(self.facet_syntax(line, expected)),
        }
    }

    /// Reads the three numbers after the keyword on `line`; corners must be finite.
    fn numbers(
        &mut self,
        line: usize,
        expected: &str,
        needs: &str,
        corner: bool,
    ) -> Result<[f64; 3], StlError> {
        let mut values = [0.0; 3];
        for value in &mut values {
            let (at, text) = self.next().ok_or_else(|| self.unterminated(needs))?;
            match text.parse::<f64>() {
                Ok(number) if corner && !number.is_finite() => {
                    return Err(StlError::NonFinite {
                        facet: self.facet.0,
                        line: Some(at),
                    })
                }
                Ok(number) => *value = number,
                Err(_) if at == line => {
                    return Err(StlError::BadNumber {
                        line: at,
                        text: text.to_string(),
                    })
                }
                // A keyword on a later line: the keyword's own line has too few numbers.
                Err(_) => return Err(self.facet_syntax(line, expected)),
            }
        }
        Ok(values)
    }

    /// Reads one facet after its `facet` keyword on line `opened`.
    fn facet(&mut self, facet: usize, opened: usize) -> Result<Corners, StlError> {
        self.facet = (facet, opened);
        const LOOP_AND_FACET: &str = "`endloop` and `endfacet`";
        const NORMAL: &str = "`facet normal nx ny nz`";
        self.keyword("normal", NORMAL, LOOP_AND_FACET)?;
        self.numbers(opened, NORMAL, LOOP_AND_FACET, false)?;
        self.keyword("outer", "`outer loop`", LOOP_AND_FACET)?;
        self.keyword("loop", "`outer loop`", LOOP_AND_FACET)?;
        let mut corners = [[0.0; 3]; 3];
        for corner in &mut corners {
            const VERTEX: &str = "`vertex x y z`";
            let line = self.keyword("vertex", VERTEX, LOOP_AND_FACET)?;
            *corner = self.numbers(line, VERTEX, LOOP_AND_FACET, true)?;
        }
        self.keyword("endloop", "`endloop`", LOOP_AND_FACET)?;
        self.keyword("endfacet", "`endfacet`", "`endfacet`")?;
        Ok(corners)
    }
}

/// A welded triangle mesh: shared corners merged into vertices, with edge ids so that a
/// contact on a shared edge or vertex can be counted once.
#[derive(Debug, Clone)]
pub struct WeldedMesh {
    /// Vertex positions, m.
    pub vertices: Vec<[f64; 3]>,
    /// Each triangle's vertex indices, in file order.
    pub triangles: Vec<[u32; 3]>,
    /// Each triangle's edge ids: edge k joins corners k and (k+1)%3.
    pub triangle_edges: Vec<[u32; 3]>,
    /// Each edge's two vertex indices (smaller first).
    pub edges: Vec<[u32; 2]>,
    /// Number of triangles on each edge (1 = open boundary edge, 2 = interior edge).
    pub edge_triangle_count: Vec<u8>,
}

impl WeldedMesh {
    /// Welds triangles into a mesh and validates it.
    ///
    /// Corners within 1e-9 × the bounding-box diagonal of an earlier vertex
    /// become that vertex; vertices and edges are numbered in order of first
    /// appearance, so the result is deterministic. Rejects non-finite
    /// coordinates, zero-area triangles and edges shared by more than two
    /// triangles.
    pub fn from_triangles(triangles: &[Corners]) -> Result<WeldedMesh, MeshError> {
        if triangles.is_empty() {
            return Err(MeshError::Empty);
        }
        if triangles.len() > MAX_TRIANGLES {
            return Err(MeshError::TooLarge {
                triangles: triangles.len(),
            });
        }
        if let Some(index) = triangles
            .iter()
            .position(|t| t.iter().flatten().any(|c| !c.is_finite()))
        {
            return Err(MeshError::NonFinite { facet: index + 1 });
        }
        let (min, max) = bounds(triangles.iter().flatten());
        let diagonal = distance(min, max);

        let mut welder = Welder::new(min, WELD_TOLERANCE * diagonal);
        let welded: Vec<[u32; 3]> = triangles
            .iter()
            .map(|t| t.map(|corner| welder.weld(corner)))
            .collect();

        let min_area = DEGENERATE_AREA * diagonal * diagonal;
        for (index, (corners, ids)) in triangles.iter().zip(&welded).enumerate() {
            let area = triangle_area(corners);
            if ids[0] == ids[1] || ids[1] == ids[2] || ids[2] == ids[0] || area < min_area {
                return Err(MeshError::Degenerate {
                    facet: index + 1,
                    corners: *corners,
                    area_m2: area,
                });
            }
        }

        let vertices = welder.vertices;
        let mut edge_ids: HashMap<[u32; 2], u32> = HashMap::new();
        let mut edges: Vec<[u32; 2]> = Vec::new();
        let mut edge_triangle_count: Vec<u8> = Vec::new();
        let mut triangle_edges = Vec::with_capacity(welded.len());
        for ids in &welded {
            let mut these = [0u32; 3];
            for (k, edge_id) in these.iter_mut().enumerate() {
                let (p, q) = (ids[k], ids[(k + 1) % 3]);
                let key = [p.min(q), p.max(q)];
                let id = *edge_ids.entry(key).or_insert_with(|| {
                    edges.push(key);
                    edge_triangle_count.push(0);
                    // At most 3 × MAX_TRIANGLES edges, so this fits in u32.
                    (edges.len() - 1) as u32
                });
                let count = &mut edge_triangle_count[id as usize];
                if *count >= 2 {
                    let on_edge = |t: &[u32; 3]| t.contains(&key[0]) && t.contains(&key[1]);
                    return Err(MeshError::NonManifoldEdge {
                        a: vertices[key[0] as usize],
                        b: vertices[key[1] as usize],
                        facets: (1..)
                            .zip(&welded)
                            .filter(|(_, t)| on_edge(t))
                            .map(|(n, _)| n)
                            .collect(),
                    });
                }
                *count += 1;
                *edge_id = id;
            }
            triangle_edges.push(these);
        }
        Ok(WeldedMesh {
            vertices,
            triangles: welded,
            triangle_edges,
            edges,
            edge_triangle_count,
        })
    }

    /// Number of boundary (open) edges: 0 for a closed surface. A hopper wall is open by design, so this is information, not an error.
    pub fn boundary_edge_count(&self) -> usize {
        self.edge_triangle_count
            .iter()
            .filter(|&&count| count == 1)
            .count()
    }

    /// Axis-aligned bounding box (min, max), m. Both are the origin for a mesh without vertices.
    pub fn bounding_box(&self) -> ([f64; 3], [f64; 3]) {
        if self.vertices.is_empty() {
            return ([0.0; 3], [0.0; 3]);
        }
        bounds(self.vertices.iter())
    }

    /// The corners of triangle `index`.
    ///
    /// # Panics
    /// If `index` is not less than the number of triangles.
    pub fn corners(&self, index: usize) -> Corners {
        self.triangles[index].map(|vertex| self.vertices[vertex as usize])
    }
}

/// Merges points within a tolerance, using a hash grid of tolerance-sized cells.
struct Welder {
    /// Grid origin (the bounding box's minimum), so cell indices stay small.
    origin: [f64; 3],
    /// Cell edge length, m.
    cell: f64,
    /// Points closer than this merge, m.
    tolerance: f64,
    /// Vertex ids in each occupied cell.
    grid: HashMap<[i64; 3], Vec<u32>>,
    /// Vertex positions in order of first appearance, m.
    vertices: Vec<[f64; 3]>,
}

impl Welder {
    fn new(origin: [f64; 3], tolerance: f64) -> Self {
        // A zero tolerance (all points equal, or a tiny mesh) merges only equal points.
        let cell = if tolerance > 0.0 { tolerance } else { 1.0 };
        Welder {
            origin,
            cell,
            tolerance,
            grid: HashMap::new(),
            vertices: Vec::new(),
        }
    }

    /// The grid cell holding `point`; coordinates are at most 1e9 cells from the origin.
    fn cell_of(&self, point: [f64; 3]) -> [i64; 3] {
        [0, 1, 2].map(|k| ((point[k] - self.origin[k]) / self.cell).floor() as i64)
    }

    /// The id of the earliest vertex within tolerance of `point`, adding one if none is.
    fn weld(&mut self, point: [f64; 3]) -> u32 {
        let [x, y, z] = self.cell_of(point);
        let mut nearest: Option<u32> = None;
        // A point within one cell size may lie in any of the 27 surrounding cells.
        for n in 0..27 {
            let cell = [x + n / 9 - 1, y + n / 3 % 3 - 1, z + n % 3 - 1];
            for &id in self.grid.get(&cell).into_iter().flatten() {
                let close = distance(self.vertices[id as usize], point) <= self.tolerance;
                if close && nearest.is_none_or(|best| id < best) {
                    nearest = Some(id);
                }
            }
        }
        nearest.unwrap_or_else(|| {
            // The caller limits the number of corners so this fits in u32.
            let id = self.vertices.len() as u32;
            self.vertices.push(point);
            self.grid.entry([x, y, z]).or_default().push(id);
            id
        })
    }
}

/// Component-wise minimum and maximum of some points (infinite for none).
fn bounds<'p>(points: impl Iterator<Item = &'p [f64; 3]>) -> ([f64; 3], [f64; 3]) {
    points.fold(
        ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]),
        |(min, max), p| {
            (
                [0, 1, 2].map(|k| min[k].min(p[k])),
                [0, 1, 2].map(|k| max[k].max(p[k])),
            )
        },
    )
}

fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// Area of a triangle, m²: half the length of the cross product of two sides.
fn triangle_area([a, b, c]: &Corners) -> f64 {
    let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
    let cross = [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ];
    0.5 * distance(cross, [0.0; 3])
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::fmt::{Debug, Display};

    const SQUARE: &str = "solid square
  facet normal 0 0 1
    outer loop
      vertex 0 0 0
      vertex 1 0 0
      vertex 1 1 0
    endloop
  endfacet
  facet normal 0 0 1
    outer loop
      vertex 0 0 0
      vertex 1 1 0
      vertex 0 1 0
    endloop
  endfacet
endsolid square
";

    fn square() -> Vec<Corners> {
        vec![
            [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]],
            [[0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]],
        ]
    }

    /// Encodes triangles as binary STL with the given header text.
    fn binary(header: &str, triangles: &[Corners]) -> Vec<u8> {
        let mut bytes = header.as_bytes().to_vec();
        bytes.resize(80, b' ');
        bytes.extend_from_slice(&(triangles.len() as u32).to_le_bytes());
        for triangle in triangles {
            bytes.extend_from_slice(&[0; 12]);
            for value in triangle.iter().flatten() {
                bytes.extend_from_slice(&(*value as f32).to_le_bytes());
            }
            bytes.extend_from_slice(&[0; 2]);
        }
        bytes
    }

    /// SQUARE with line `line` (from 1) replaced by `with`, or removed if `with` is None.
    fn edit(line: usize, with: Option<&str>) -> String {
        let mut lines: Vec<&str> = SQUARE.lines().collect();
        match with {
            Some(text) => lines[line - 1] = text,
            None => drop(lines.remove(line - 1)),
        }
        lines.join("\n")
    }

    /// Unwraps an error whose message contains every one of `parts`.
    fn fails<T: Debug, E: Debug + Display>(result: Result<T, E>, parts: &[&str]) -> E {
        let message = result.as_ref().map(|_| ()).unwrap_err().to_string();
        let missing: Vec<_> = parts.iter().filter(|p| !message.contains(*p)).collect();
        assert!(missing.is_empty(), "{message:?} lacks {missing:?}");
        result.unwrap_err()
    }

    /// Parses ASCII `text`, expecting an error whose message contains every one of `parts`.
    fn ascii(text: &str, parts: &[&str]) -> StlError {
        fails(parse_stl(text.as_bytes()), parts)
    }

    #[test]
    fn ascii_square_welds_into_four_vertices_and_five_edges() {
        let triangles = parse_stl(SQUARE.as_bytes()).unwrap();
        assert_eq!(triangles, square());
        let mesh = WeldedMesh::from_triangles(&triangles).unwrap();
        assert_eq!(mesh.vertices.len(), 4);
        assert_eq!(mesh.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(mesh.edges, vec![[0, 1], [1, 2], [0, 2], [2, 3], [0, 3]]);
        assert_eq!(mesh.triangle_edges, vec![[0, 1, 2], [2, 3, 4]]);
        assert_eq!(mesh.edge_triangle_count, vec![1, 1, 2, 1, 1]);
        assert_eq!(mesh.boundary_edge_count(), 4);
        assert_eq!(mesh.bounding_box(), ([0.0; 3], [1.0, 1.0, 0.0]));
        assert_eq!(mesh.corners(1), square()[1]);
    }

    #[test]
    fn binary_square_matches_ascii_even_with_a_solid_header() {
        for header in ["exported by test", "solid square"] {
            assert_eq!(parse_stl(&binary(header, &square())).unwrap(), square());
        }
    }

    #[test]
    fn ascii_accepts_case_whitespace_number_forms_and_several_solids() {
        let one = "SOLID\tA b\nFacet Normal 0 0 1 Outer Loop\nVERTEX 1e-3 -0.5 4.0E+01\n vertex\t0 0 0\n\n vertex 1 1 1 EndLoop EndFacet\nENDSOLID";
        let triangles = parse_stl(format!("  {one}\n{SQUARE}").as_bytes()).unwrap();
        assert_eq!(triangles.len(), 3);
        assert_eq!(triangles[0][0], [0.001, -0.5, 40.0]);
        assert_eq!(&triangles[1..], &square()[..]);
    }

    #[test]
    fn closed_tetrahedron_has_no_boundary_edges() {
        let [o, x, y, z] = [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let mesh = WeldedMesh::from_triangles(&[[o, y, x], [o, x, z], [o, z, y], [x, y, z]]);
        let mesh = mesh.unwrap();
        assert_eq!((mesh.vertices.len(), mesh.edges.len()), (4, 6));
        assert_eq!(mesh.boundary_edge_count(), 0);
        assert!(mesh.edge_triangle_count.iter().all(|&count| count == 2));
    }

    #[test]
    fn corners_within_tolerance_weld_even_across_grid_cells() {
        let mut triangles = square();
        triangles[1][1] = [1.0 + 1e-13, 1.0 - 1e-13, 1e-13];
        let mesh = WeldedMesh::from_triangles(&triangles).unwrap();
        assert_eq!(mesh.vertices.len(), 4);
        assert_eq!(mesh.vertices[2], [1.0, 1.0, 0.0], "first appearance wins");

        let mut welder = Welder::new([0.0; 3], 1e-9);
        let boundary = (0.5 / welder.cell).ceil() * welder.cell;
        let (p, q) = ([boundary - 1e-13, 0.0, 0.0], [boundary + 1e-13, 0.0, 0.0]);
        assert_ne!(welder.cell_of(p), welder.cell_of(q), "p, q straddle");
        assert_eq!(welder.weld(p), welder.weld(q));
        let far = [boundary + 1e-8, 0.0, 0.0];
        assert_eq!(welder.weld(far), 1, "too far to weld");
    }

    #[test]
    fn empty_files_and_meshes_are_empty() {
        for text in ["", " \n", "solid x\nendsolid x\n"] {
            assert_eq!(ascii(text, &["no triangles", "`facet`"]), StlError::Empty);
        }
        let binary_error = fails(parse_stl(&binary("", &[])), &["triangle count"]);
        assert_eq!(binary_error, StlError::Empty);
        let mesh_error = fails(WeldedMesh::from_triangles(&[]), &["no triangles"]);
        assert_eq!(mesh_error, MeshError::Empty);
    }

    #[test]
    fn truncated_binary_reports_the_numbers() {
        for header in ["binary", "solid looks like ascii"] {
            let mut bytes = binary(header, &square());
            bytes.pop();
            let parts = ["2 triangles", "184 bytes", "183 bytes"];
            let error = fails(parse_stl(&bytes), &parts);
            let (triangles_declared, bytes, expected_bytes) = (2, 183, 184);
            let truncated = StlError::TruncatedBinary {
                triangles_declared,
                bytes,
                expected_bytes,
            };
            assert_eq!(error, truncated);
        }
    }

    #[test]
    fn ascii_syntax_errors_name_line_and_expectation() {
        let few = edit(13, Some("      vertex 0 1"));
        ascii(
            &few,
            &["line 13", "`vertex x y z` in facet 2", "found `vertex 0 1`"],
        );
        let no_endloop = edit(7, None);
        ascii(&no_endloop, &["line 7", "`endloop`", "found `endfacet`"]);
        let no_endfacet = edit(15, Some("endloop"));
        ascii(&no_endfacet, &["line 15", "expected `endfacet`"]);
        ascii("hello", &["line 1", "`solid`", "found `hello`"]);
        ascii(&format!("{SQUARE}junk"), &["line 17", "end of the file"]);
    }

    #[test]
    fn unterminated_facets_and_solids_are_named() {
        let cut = SQUARE.lines().take(12).collect::<Vec<_>>().join("\n");
        let error = ascii(&cut, &["line 12", "facet 2", "line 9", "`endloop`"]);
        assert!(matches!(error, StlError::Unterminated { line: 12, .. }));
        let no_endsolid = edit(16, None);
        ascii(&no_endsolid, &["line 15", "`solid square`", "`endsolid`"]);
    }

    #[test]
    fn bad_and_non_finite_numbers_are_rejected() {
        ascii(
            &edit(13, Some("vertex 0 1 zero")),
            &["line 13", "`zero`", "not a number"],
        );
        for bad in ["nan", "inf", "-Infinity", "1e999"] {
            let text = edit(11, Some(&format!("vertex {bad} 0 0")));
            let error = ascii(&text, &["facet 2 (line 11)", "NaN or infinite"]);
            assert_eq!(
                error,
                StlError::NonFinite {
                    facet: 2,
                    line: Some(11)
                }
            );
        }
        let mut triangles = square();
        triangles[0][2][1] = f64::NAN;
        let error = fails(parse_stl(&binary("", &triangles)), &["facet 1:", "NaN"]);
        assert_eq!(
            error,
            StlError::NonFinite {
                facet: 1,
                line: None
            }
        );
        let error = fails(WeldedMesh::from_triangles(&triangles), &["facet 1", "NaN"]);
        assert_eq!(error, MeshError::NonFinite { facet: 1 });
    }

    #[test]
    fn edge_on_three_triangles_is_non_manifold() {
        let mut triangles = square();
        triangles.push([[0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.5, 0.5, 1.0]]);
        let parts = ["shared by 3 facets", "facets 1, 2, 3", "at most two"];
        let error = fails(WeldedMesh::from_triangles(&triangles), &parts);
        let (a, b, facets) = ([0.0; 3], [1.0, 1.0, 0.0], vec![1, 2, 3]);
        assert_eq!(error, MeshError::NonManifoldEdge { a, b, facets });
    }

    #[test]
    fn degenerate_triangles_name_the_facet() {
        let mut repeated = square();
        repeated[1][2] = repeated[1][1];
        let mut collinear = square();
        collinear[1][2] = [2.0, 2.0, 0.0];
        for triangles in [repeated, collinear] {
            let parts = ["facet 2", "degenerate", "Re-export"];
            let error = fails(WeldedMesh::from_triangles(&triangles), &parts);
            let MeshError::Degenerate { facet, area_m2, .. } = error else {
                panic!("expected Degenerate, got {error:?}");
            };
            assert_eq!((facet, area_m2), (2, 0.0));
        }
    }
}
