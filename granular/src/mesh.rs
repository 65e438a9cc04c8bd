//! Triangle meshes and their ASCII STL form.

use std::fmt::Write as _;

/// A triangle mesh: vertex positions in metres and triangles as vertex indices.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TriMesh {
    /// Vertex positions (x, y, z) in metres.
    pub vertices: Vec<[f64; 3]>,
    /// Triangles as indices into `vertices`, counter-clockwise seen from the normal.
    pub triangles: Vec<[u32; 3]>,
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn norm(a: [f64; 3]) -> f64 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

impl TriMesh {
    /// The three corners of triangle `index`.
    pub fn corners(&self, index: usize) -> [[f64; 3]; 3] {
        let [a, b, c] = self.triangles[index];
        [
            self.vertices[a as usize],
            self.vertices[b as usize],
            self.vertices[c as usize],
        ]
    }

    /// Unit normal of triangle `index` (zero for a degenerate triangle).
    pub fn normal(&self, index: usize) -> [f64; 3] {
        let [a, b, c] = self.corners(index);
        let n = cross(sub(b, a), sub(c, a));
        let length = norm(n);
        if length == 0.0 {
            return [0.0; 3];
        }
        [n[0] / length, n[1] / length, n[2] / length]
    }

    /// Total surface area in m².
    pub fn area_m2(&self) -> f64 {
        (0..self.triangles.len())
            .map(|i| {
                let [a, b, c] = self.corners(i);
                0.5 * norm(cross(sub(b, a), sub(c, a)))
            })
            .sum()
    }

    /// Volume enclosed by a closed mesh, m³ (divergence theorem: the sum of signed
    /// tetrahedra from the origin). Positive when the normals point outwards; meaningless
    /// for an open surface.
    pub fn volume_m3(&self) -> f64 {
        (0..self.triangles.len())
            .map(|i| {
                let [a, b, c] = self.corners(i);
                let n = cross(b, c);
                (a[0] * n[0] + a[1] * n[1] + a[2] * n[2]) / 6.0
            })
            .sum()
    }

    /// Edges not shared by exactly two triangles. Zero for a watertight (closed,
    /// manifold) mesh; for an open surface, the edges of its rims.
    pub fn open_edge_count(&self) -> usize {
        let mut uses: std::collections::HashMap<(u32, u32), usize> =
            std::collections::HashMap::new();
        for t in &self.triangles {
            for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                *uses.entry((a.min(b), a.max(b))).or_insert(0) += 1;
            }
        }
        uses.values().filter(|&&n| n != 2).count()
    }

    /// Appends another mesh's vertices and triangles to this one.
    pub fn append(&mut self, other: &TriMesh) {
        let offset = self.vertices.len() as u32;
        self.vertices.extend_from_slice(&other.vertices);
        self.triangles.extend(
            other
                .triangles
                .iter()
                .map(|t| [t[0] + offset, t[1] + offset, t[2] + offset]),
        );
    }

    /// Moves every vertex up by `dz_m` metres.
    pub fn translated_z(mut self, dz_m: f64) -> TriMesh {
        for v in &mut self.vertices {
            v[2] += dz_m;
        }
        self
    }

    /// The mesh as an ASCII STL solid named `name`, coordinates in metres.
    pub fn to_ascii_stl(&self, name: &str) -> String {
        let mut out = String::with_capacity(self.triangles.len() * 260);
        let _ = writeln!(out, "solid {name}");
        for i in 0..self.triangles.len() {
            let n = self.normal(i);
            let _ = writeln!(out, "  facet normal {:e} {:e} {:e}", n[0], n[1], n[2]);
            out.push_str("    outer loop\n");
            for p in self.corners(i) {
                let _ = writeln!(out, "      vertex {:e} {:e} {:e}", p[0], p[1], p[2]);
            }
            out.push_str("    endloop\n  endfacet\n");
        }
        let _ = writeln!(out, "endsolid {name}");
        out
    }

    /// A surface of revolution about the z axis through the profile points `(r, z)`,
    /// with `segments` facets around. A profile point on the axis (`r = 0`) becomes a
    /// single apex vertex, so no triangle is degenerate.
    pub fn revolve(profile: &[(f64, f64)], segments: usize) -> TriMesh {
        let mut mesh = TriMesh::default();
        let mut rings: Vec<Vec<u32>> = Vec::with_capacity(profile.len());
        for &(r, z) in profile {
            let start = mesh.vertices.len() as u32;
            if r == 0.0 {
                mesh.vertices.push([0.0, 0.0, z]);
                rings.push(vec![start; segments]);
                continue;
            }
            for k in 0..segments {
                let phi = std::f64::consts::TAU * k as f64 / segments as f64;
                mesh.vertices.push([r * phi.cos(), r * phi.sin(), z]);
            }
            rings.push((start..start + segments as u32).collect());
        }
        for pair in rings.windows(2) {
            let (lo, hi) = (&pair[0], &pair[1]);
            for k in 0..segments {
                let k1 = (k + 1) % segments;
                if lo[k] != lo[k1] {
                    mesh.triangles.push([lo[k], lo[k1], hi[k1]]);
                }
                if hi[k] != hi[k1] {
                    mesh.triangles.push([lo[k], hi[k1], hi[k]]);
                }
            }
        }
        mesh
    }

    /// A flat disk of `radius_m` at height `z_m`, made of `rings` concentric rings so
    /// that no triangle is a long sliver.
    pub fn disk(radius_m: f64, z_m: f64, segments: usize, rings: usize) -> TriMesh {
        let profile: Vec<(f64, f64)> = (0..=rings)
            .map(|j| (radius_m * j as f64 / rings as f64, z_m))
            .collect();
        TriMesh::revolve(&profile, segments)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn disk_area_converges_to_pi_r_squared() {
        let disk = TriMesh::disk(0.01, 0.0, 256, 3);
        let exact = PI * 0.01 * 0.01;
        // An inscribed 256-gon: area = N/2 r² sin(2π/N).
        let polygon = 128.0 * 0.01 * 0.01 * (2.0 * PI / 256.0).sin();
        assert!((disk.area_m2() - polygon).abs() < 1e-15);
        assert!((disk.area_m2() - exact).abs() / exact < 1e-3);
    }

    #[test]
    fn stl_has_one_facet_per_triangle() {
        let disk = TriMesh::disk(0.01, 0.0, 8, 2);
        let stl = disk.to_ascii_stl("plate");
        assert!(stl.starts_with("solid plate\n"));
        assert!(stl.ends_with("endsolid plate\n"));
        assert_eq!(stl.matches("facet normal").count(), disk.triangles.len());
        // 8 around the centre, 16 in the outer ring.
        assert_eq!(disk.triangles.len(), 24);
    }
}
