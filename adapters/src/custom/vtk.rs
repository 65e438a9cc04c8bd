//! A reader of one point or cell field of a legacy VTK file, as LIGGGHTS' `dump
//! mesh/vtk` (wear, stress on each triangle: cell data) and `dump custom/vtk` (one
//! point per particle: point data) write it.
//!
//! Legacy files (`# vtk DataFile Version 2.0` to `5.1`), ASCII or BINARY (big-endian),
//! datasets POLYDATA and UNSTRUCTURED_GRID (and any other whose sections are the ones
//! below). Sections are read in order and skipped unless they hold the field:
//! `POINTS`; `VERTICES`, `LINES`, `POLYGONS`, `TRIANGLE_STRIPS`, `CELLS` (in the ≤ 4.2
//! layout, or 5.1's `OFFSETS` + `CONNECTIVITY`); `CELL_TYPES`; `POINT_DATA` /
//! `CELL_DATA`, then `SCALARS` (with `LOOKUP_TABLE`), `VECTORS`, `NORMALS`, `TENSORS`,
//! `FIELD` arrays; `METADATA` blocks. A field of several components gives its
//! magnitude, or the component asked for. Values stream to a sink: a file of any size
//! is read in bounded memory.

use std::io::BufRead;
use std::path::Path;

use crate::ParseError;

/// Which values of a field are wanted.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct VtkField {
    /// The array's name (`SCALARS wear …`, a `FIELD` array `v`).
    pub name: String,
    /// Point or cell data; `None`: whichever holds an array of that name.
    pub at: Option<Attribute>,
    /// The component (0-based) of a many-component array; `None`: its magnitude.
    pub component: Option<usize>,
}

impl VtkField {
    /// True for the array `name` of the data section `here` (none before the first
    /// `POINT_DATA` or `CELL_DATA`).
    fn is(&self, name: &str, here: Option<Attribute>) -> bool {
        name == self.name && here.is_some() && self.at.is_none_or(|a| Some(a) == here)
    }
}

/// Where a field lives.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Attribute {
    /// One value per point (`POINT_DATA`).
    Point,
    /// One value per cell (`CELL_DATA`).
    Cell,
}

/// Reads `field` of the legacy VTK file `reader` (named `path` in errors), handing
/// `(index, value)` of each point or cell to `sink`; an error names the file and what
/// was expected.
pub fn for_each_vtk_value<R: BufRead>(
    reader: R,
    path: &Path,
    field: &VtkField,
    sink: &mut dyn FnMut((f64, f64)),
) -> Result<(), ParseError> {
    let mut file = Tokens {
        reader,
        path,
        binary: false,
        pending: std::collections::VecDeque::new(),
        line: 0,
    };
    let first = file.line()?.unwrap_or_default();
    if !first.starts_with("# vtk DataFile") {
        return Err(file.malformed("expected `# vtk DataFile Version …` (a legacy VTK file)"));
    }
    file.raw_line()?; // the title, any text
    match file.line()?.as_deref() {
        Some("ASCII") => {}
        Some("BINARY") => file.binary = true,
        other => {
            return Err(file.malformed(&format!(
                "expected ASCII or BINARY, found `{}`",
                other.unwrap_or("")
            )))
        }
    }
    // The data section being read, with its count of points or cells.
    let mut at: Option<(Attribute, usize)> = None;
    let mut found = false;
    while let Some(line) = file.line()? {
        let words: Vec<&str> = line.split_whitespace().collect();
        let number = |k: usize, file: &Tokens<'_, R>| -> Result<usize, ParseError> {
            words
                .get(k)
                .and_then(|w| w.parse().ok())
                .ok_or_else(|| file.malformed(&format!("expected a count in `{line}`")))
        };
        match words[0] {
            "DATASET" | "METADATA" | "INFORMATION" | "NAME" | "DATA" => {
                if words[0] == "METADATA" {
                    file.skip_metadata()?;
                }
            }
            "POINTS" => {
                let n = number(1, &file)?;
                file.skip(3 * n, words.get(2).copied().unwrap_or("float"))?;
            }
            "VERTICES" | "LINES" | "POLYGONS" | "TRIANGLE_STRIPS" | "CELLS" => {
                let (n, size) = (number(1, &file)?, number(2, &file)?);
                // 5.1 writes OFFSETS (n) and CONNECTIVITY (size) sections next; older
                // versions `size` integers here.
                if !file.next_is("OFFSETS")? {
                    file.skip(size, "int")?;
                } else {
                    let offsets = file.line()?.unwrap_or_default();
                    file.skip(
                        n,
                        offsets.split_whitespace().nth(1).unwrap_or("vtktypeint64"),
                    )?;
                    let connectivity = file.line()?.unwrap_or_default();
                    if !connectivity.starts_with("CONNECTIVITY") {
                        return Err(file.malformed("expected CONNECTIVITY after OFFSETS"));
                    }
                    let kind = connectivity
                        .split_whitespace()
                        .nth(1)
                        .unwrap_or("vtktypeint64");
                    file.skip(size, kind)?;
                }
            }
            "CELL_TYPES" => {
                let n = number(1, &file)?;
                file.skip(n, "int")?;
            }
            "POINT_DATA" => at = Some((Attribute::Point, number(1, &file)?)),
            "CELL_DATA" => at = Some((Attribute::Cell, number(1, &file)?)),
            "SCALARS" | "VECTORS" | "NORMALS" | "TENSORS" => {
                let name = words.get(1).copied().unwrap_or("");
                let kind = words.get(2).copied().unwrap_or("float");
                let components = match words[0] {
                    "SCALARS" => words.get(3).and_then(|w| w.parse().ok()).unwrap_or(1),
                    "TENSORS" => 9,
                    _ => 3,
                };
                let Some((here, tuples)) = at else {
                    return Err(file.malformed("expected POINT_DATA or CELL_DATA before data"));
                };
                if words[0] == "SCALARS" && file.next_is("LOOKUP_TABLE")? {
                    file.line()?;
                }
                let wanted = field.is(name, Some(here));
                file.values(
                    tuples,
                    components,
                    kind,
                    wanted.then_some((field, &mut *sink)),
                )?;
                found |= wanted;
            }
            "LOOKUP_TABLE" => {
                let n = number(2, &file)?;
                file.skip(4 * n, "float")?;
            }
            "FIELD" => {
                let arrays = number(2, &file)?;
                for _ in 0..arrays {
                    let header = file.line()?.unwrap_or_default();
                    let parts: Vec<&str> = header.split_whitespace().collect();
                    let (Some(components), Some(tuples)) = (
                        parts.get(1).and_then(|w| w.parse::<usize>().ok()),
                        parts.get(2).and_then(|w| w.parse::<usize>().ok()),
                    ) else {
                        return Err(file.malformed(&format!(
                            "expected `NAME COMPONENTS TUPLES TYPE`, found `{header}`"
                        )));
                    };
                    let kind = parts.get(3).copied().unwrap_or("float");
                    let wanted = field.is(parts[0], at.map(|(a, _)| a));
                    file.values(
                        tuples,
                        components,
                        kind,
                        wanted.then_some((field, &mut *sink)),
                    )?;
                    found |= wanted;
                }
            }
            other => {
                return Err(file.malformed(&format!("unknown section `{other}`")));
            }
        }
        if found {
            return Ok(());
        }
    }
    Err(ParseError::Unusable {
        path: path.to_path_buf(),
        message: format!(
            "no {}field `{}` in the file",
            match field.at {
                Some(Attribute::Point) => "point ",
                Some(Attribute::Cell) => "cell ",
                None => "",
            },
            field.name
        ),
    })
}

/// The field being read and where its values go.
type Wanted<'a> = (&'a VtkField, &'a mut dyn FnMut((f64, f64)));

/// The file as keyword lines and, between them, ASCII tokens or binary blocks.
struct Tokens<'p, R> {
    reader: R,
    path: &'p Path,
    binary: bool,
    /// ASCII values read with a line but not used yet.
    pending: std::collections::VecDeque<String>,
    /// Lines read, for messages.
    line: usize,
}

impl<R: BufRead> Tokens<'_, R> {
    fn malformed(&self, message: &str) -> ParseError {
        ParseError::malformed(self.path, self.line, message)
    }

    /// The next line as it is (possibly empty); `None` at the end.
    fn raw_line(&mut self) -> Result<Option<String>, ParseError> {
        let mut bytes = Vec::new();
        let n = self
            .reader
            .read_until(b'\n', &mut bytes)
            .map_err(ParseError::read(self.path))?;
        if n == 0 {
            return Ok(None);
        }
        self.line += 1;
        Ok(Some(String::from_utf8_lossy(&bytes).trim().to_string()))
    }

    /// The next line that is not blank, trimmed; `None` at the end.
    fn line(&mut self) -> Result<Option<String>, ParseError> {
        self.pending.clear();
        loop {
            match self.raw_line()? {
                None => return Ok(None),
                Some(line) if line.is_empty() => continue,
                Some(line) => return Ok(Some(line)),
            }
        }
    }

    /// True when the next non-blank line starts with `keyword`; the line is not taken
    /// unless it does (then it is left for [`Tokens::line`] to return).
    fn next_is(&mut self, keyword: &str) -> Result<bool, ParseError> {
        loop {
            let buffer = self
                .reader
                .fill_buf()
                .map_err(ParseError::read(self.path))?;
            match buffer.first() {
                None => return Ok(false),
                Some(b'\n' | b'\r' | b' ' | b'\t') => {
                    if buffer[0] == b'\n' {
                        self.line += 1;
                    }
                    self.reader.consume(1);
                }
                Some(_) => {
                    let starts = buffer.starts_with(keyword.as_bytes())
                        || (buffer.len() < keyword.len() && keyword.as_bytes().starts_with(buffer));
                    return Ok(starts);
                }
            }
        }
    }

    /// Skips `count` values of `kind`.
    fn skip(&mut self, count: usize, kind: &str) -> Result<(), ParseError> {
        self.values(count, 1, kind, None)
    }

    /// Reads `tuples` tuples of `components` values of `kind`; with a field and its
    /// sink, hands each tuple's value (the component asked for, or the magnitude).
    fn values(
        &mut self,
        tuples: usize,
        components: usize,
        kind: &str,
        mut wanted: Option<Wanted<'_>>,
    ) -> Result<(), ParseError> {
        let size =
            size_of(kind).ok_or_else(|| self.malformed(&format!("unknown data type `{kind}`")))?;
        if let Some((field, _)) = &wanted {
            if let Some(c) = field.component.filter(|&c| c >= components) {
                return Err(self.malformed(&format!(
                    "component {c} of `{}` asked for, but it has {components}",
                    field.name
                )));
            }
        }
        let mut tuple = vec![0.0; components];
        let mut bytes = vec![0_u8; size];
        for index in 0..tuples {
            for value in tuple.iter_mut() {
                *value = if self.binary {
                    self.reader
                        .read_exact(&mut bytes)
                        .map_err(|_| self.malformed("the file ends inside a binary block"))?;
                    decode(&bytes, kind)
                } else {
                    let token = self.token()?;
                    token.parse().map_err(|_| {
                        self.malformed(&format!("expected a number, found `{token}`"))
                    })?
                };
            }
            if let Some((field, sink)) = wanted.as_mut() {
                let value = match field.component {
                    Some(c) => tuple[c],
                    None if components == 1 => tuple[0],
                    None => tuple.iter().map(|v| v * v).sum::<f64>().sqrt(),
                };
                sink((index as f64, value));
            }
        }
        Ok(())
    }

    /// The next ASCII value, reading lines as needed.
    fn token(&mut self) -> Result<String, ParseError> {
        loop {
            if let Some(token) = self.pending.pop_front() {
                return Ok(token);
            }
            let Some(line) = self.raw_line()? else {
                return Err(self.malformed("the file ends inside a data block"));
            };
            self.pending
                .extend(line.split_whitespace().map(str::to_string));
        }
    }

    /// Skips a `METADATA` block: lines up to the first blank one.
    fn skip_metadata(&mut self) -> Result<(), ParseError> {
        while let Some(line) = self.raw_line()? {
            if line.is_empty() {
                break;
            }
        }
        Ok(())
    }
}

/// Bytes of one value of a legacy VTK data type.
fn size_of(kind: &str) -> Option<usize> {
    Some(match kind {
        "bit" | "char" | "unsigned_char" => 1,
        "short" | "unsigned_short" => 2,
        "int" | "unsigned_int" | "float" | "vtktypeint32" | "vtktypeuint32" => 4,
        "long" | "unsigned_long" | "double" | "vtktypeint64" | "vtktypeuint64" | "vtkIdType" => 8,
        _ => return None,
    })
}

/// A big-endian binary value of `kind` as a number.
fn decode(bytes: &[u8], kind: &str) -> f64 {
    let array = |n: usize| -> [u8; 8] {
        let mut out = [0_u8; 8];
        out[8 - n..].copy_from_slice(&bytes[..n]);
        out
    };
    match kind {
        "float" => f32::from_be_bytes(bytes[..4].try_into().expect("4 bytes")) as f64,
        "double" => f64::from_be_bytes(bytes[..8].try_into().expect("8 bytes")),
        "char" => bytes[0] as i8 as f64,
        "short" => i16::from_be_bytes(bytes[..2].try_into().expect("2 bytes")) as f64,
        "int" | "vtktypeint32" => {
            i32::from_be_bytes(bytes[..4].try_into().expect("4 bytes")) as f64
        }
        "long" | "vtktypeint64" | "vtkIdType" => i64::from_be_bytes(array(8)) as f64,
        _ => u64::from_be_bytes(array(bytes.len())) as f64,
    }
}

#[cfg(test)]
mod tests {
    use std::io::Cursor;

    use super::*;

    /// `dump mesh/vtk` as LIGGGHTS 3.8 writes it (version 5.1, OFFSETS/CONNECTIVITY,
    /// cell data as a FIELD), with two triangles.
    const MESH_VTK: &str = "# vtk DataFile Version 5.1
Generated by LIGGGHTS
ASCII
DATASET POLYDATA
POINTS 6 float
0 0 0 1 0 0 0 1 0
1 1 0 2 1 0 1 2 0
POLYGONS 3 6
OFFSETS vtktypeint64
0 3 6
CONNECTIVITY vtktypeint64
0 1 2 3 4 5
CELL_DATA 2
FIELD FieldData 2
v 3 2 double
3 4 0 0 0 2
wear 1 2 double
0.5 1.25
";

    fn read(
        bytes: &[u8],
        name: &str,
        at: Option<Attribute>,
        component: Option<usize>,
    ) -> Result<Vec<(f64, f64)>, ParseError> {
        let field = VtkField {
            name: name.into(),
            at,
            component,
        };
        let mut values = Vec::new();
        for_each_vtk_value(
            Cursor::new(bytes),
            Path::new("mesh.vtk"),
            &field,
            &mut |p| values.push(p),
        )?;
        Ok(values)
    }

    #[test]
    fn a_liggghts_mesh_dump_gives_its_cell_fields() {
        let wear = read(MESH_VTK.as_bytes(), "wear", Some(Attribute::Cell), None).unwrap();
        assert_eq!(wear, [(0.0, 0.5), (1.0, 1.25)]);
        let speed = read(MESH_VTK.as_bytes(), "v", None, None).unwrap();
        assert_eq!(speed, [(0.0, 5.0), (1.0, 2.0)], "a vector's magnitude");
        let vz = read(MESH_VTK.as_bytes(), "v", None, Some(2)).unwrap();
        assert_eq!(vz, [(0.0, 0.0), (1.0, 2.0)]);
        let point = read(MESH_VTK.as_bytes(), "wear", Some(Attribute::Point), None);
        assert_eq!(
            point.unwrap_err().to_string(),
            "mesh.vtk: no point field `wear` in the file"
        );
        let component = read(MESH_VTK.as_bytes(), "v", None, Some(3)).unwrap_err();
        assert!(
            component
                .to_string()
                .contains("component 3 of `v` asked for, but it has 3"),
            "{component}"
        );
    }

    /// A binary (big-endian) version 4.2 UNSTRUCTURED_GRID with point scalars and
    /// vectors, as `dump custom/vtk` of older builds writes it.
    fn binary_grid() -> Vec<u8> {
        let mut out = Vec::new();
        out.extend(b"# vtk DataFile Version 4.2\nparticles\nBINARY\nDATASET UNSTRUCTURED_GRID\nPOINTS 3 float\n");
        for v in [0.0_f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
            out.extend(v.to_be_bytes());
        }
        out.extend(b"\nCELLS 3 6\n");
        for v in [1_i32, 0, 1, 1, 1, 2] {
            out.extend(v.to_be_bytes());
        }
        out.extend(b"\nCELL_TYPES 3\n");
        for v in [1_i32, 1, 1] {
            out.extend(v.to_be_bytes());
        }
        out.extend(b"\nPOINT_DATA 3\nSCALARS radius double 1\nLOOKUP_TABLE default\n");
        for v in [0.001_f64, 0.002, 0.0015] {
            out.extend(v.to_be_bytes());
        }
        out.extend(b"\nVECTORS vel float\n");
        for v in [0.0_f32, 0.0, -1.0, 0.0, 3.0, 4.0, 1.0, 0.0, 0.0] {
            out.extend(v.to_be_bytes());
        }
        out.extend(b"\n");
        out
    }

    #[test]
    fn a_binary_particle_dump_gives_its_point_fields() {
        let grid = binary_grid();
        let radius = read(&grid, "radius", Some(Attribute::Point), None).unwrap();
        assert_eq!(radius, [(0.0, 0.001), (1.0, 0.002), (2.0, 0.0015)]);
        let speed = read(&grid, "vel", None, None).unwrap();
        assert_eq!(speed, [(0.0, 1.0), (1.0, 5.0), (2.0, 1.0)]);
        let cut = &grid[..grid.len() - 10];
        let error = read(cut, "vel", None, None).unwrap_err().to_string();
        assert!(
            error.contains("the file ends inside a binary block"),
            "{error}"
        );
    }

    #[test]
    fn a_file_that_is_not_legacy_vtk_says_so() {
        let error = read(b"<?xml version=\"1.0\"?>\n<VTKFile>", "v", None, None).unwrap_err();
        assert!(
            error
                .to_string()
                .ends_with("expected `# vtk DataFile Version …` (a legacy VTK file)"),
            "{error}"
        );
    }
}
