//! Walls: triangle meshes read from STL, welded so that edges and vertices have
//! identities, moved rigidly (translation or sinusoidal vibration), and removable at a
//! given time (the plug that closes an outlet while a hopper fills).

mod stl;

pub use stl::{parse_stl, Corners, MeshError, StlError, WeldedMesh};

use crate::contact::{closest_point_on_triangle, TriangleFeature};
use crate::math::{Real, Vec3};

/// How a wall moves: a rigid translation of the whole mesh.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Motion {
    /// The wall stays where its file put it.
    Fixed,
    /// Constant velocity from `start_s` on.
    Translation {
        /// Velocity, m/s.
        velocity_m_per_s: Vec3,
        /// Time the motion starts, s.
        start_s: Real,
    },
    /// `d(t) = A sin(2π f (t - t0))` from `t0 = start_s` on, like LIGGGHTS's
    /// `move/mesh wiggle`.
    Vibration {
        /// Amplitude vector A, m.
        amplitude_m: Vec3,
        /// Frequency f, Hz.
        frequency_hz: Real,
        /// Time the vibration starts, s.
        start_s: Real,
    },
}

impl Motion {
    /// Displacement from the file's position at time `t_s`, m.
    pub fn displacement_m(&self, t_s: Real) -> Vec3 {
        match *self {
            Motion::Fixed => Vec3::zeros(),
            Motion::Translation {
                velocity_m_per_s,
                start_s,
            } => velocity_m_per_s * (t_s - start_s).max(0.0),
            Motion::Vibration {
                amplitude_m,
                frequency_hz,
                start_s,
            } => {
                if t_s <= start_s {
                    Vec3::zeros()
                } else {
                    let phase = 2.0 * std::f64::consts::PI * frequency_hz * (t_s - start_s);
                    amplitude_m * phase.sin()
                }
            }
        }
    }

    /// Velocity at time `t_s`, m/s.
    pub fn velocity_m_per_s(&self, t_s: Real) -> Vec3 {
        match *self {
            Motion::Fixed => Vec3::zeros(),
            Motion::Translation {
                velocity_m_per_s,
                start_s,
            } => {
                if t_s >= start_s {
                    velocity_m_per_s
                } else {
                    Vec3::zeros()
                }
            }
            Motion::Vibration {
                amplitude_m,
                frequency_hz,
                start_s,
            } => {
                if t_s <= start_s {
                    Vec3::zeros()
                } else {
                    let omega = 2.0 * std::f64::consts::PI * frequency_hz;
                    amplitude_m * omega * (omega * (t_s - start_s)).cos()
                }
            }
        }
    }
}

/// Identity of the mesh feature a contact is on, unique within one mesh: a face by its
/// triangle index, an edge by its edge id, a vertex by its vertex id.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize, serde::Deserialize,
)]
pub enum FeatureId {
    /// Interior of triangle `i`.
    Face(u32),
    /// Edge `i` of the welded mesh.
    Edge(u32),
    /// Vertex `i` of the welded mesh.
    Vertex(u32),
}

/// A wall of the simulation: a welded mesh with its motion and lifetime.
#[derive(Debug, Clone)]
pub struct WallMesh {
    /// Name for messages (the file stem).
    pub name: String,
    mesh: WeldedMesh,
    /// Triangles on each edge (`u32::MAX` where an edge has only one).
    edge_triangles: Vec<[u32; 2]>,
    /// Each triangle's bounding sphere (centre, radius m), for a quick rejection.
    bounds: Vec<(Vec3, Real)>,
    /// Each triangle's plane (unit normal, offset m), for a quick rejection.
    planes: Vec<(Vec3, Real)>,
    /// How the wall moves.
    pub motion: Motion,
    /// The wall disappears at this time, s (`None`: never).
    pub removed_at_s: Option<Real>,
}

/// The closest point of a wall triangle to a sphere centre, with its feature identity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WallPoint {
    /// Closest point in the wall's current position, m.
    pub point: Vec3,
    /// The feature it lies on.
    pub feature: FeatureId,
}

impl WallMesh {
    /// A wall from a welded mesh.
    pub fn new(name: impl Into<String>, mesh: WeldedMesh, motion: Motion) -> Self {
        let mut edge_triangles = vec![[u32::MAX; 2]; mesh.edges.len()];
        for (triangle, edges) in mesh.triangle_edges.iter().enumerate() {
            for &edge in edges {
                let slot = &mut edge_triangles[edge as usize];
                if slot[0] == u32::MAX {
                    slot[0] = triangle as u32;
                } else {
                    slot[1] = triangle as u32;
                }
            }
        }
        let bounds = (0..mesh.triangles.len())
            .map(|t| {
                let [a, b, c] = mesh.corners(t).map(Vec3::from);
                let centre = (a + b + c) / 3.0;
                let radius = [a, b, c]
                    .iter()
                    .map(|v| (v - centre).norm())
                    .fold(0.0, Real::max);
                (centre, radius)
            })
            .collect();
        let planes = (0..mesh.triangles.len())
            .map(|t| {
                let [a, b, c] = mesh.corners(t).map(Vec3::from);
                let normal = (b - a).cross(&(c - a)).normalize();
                (normal, normal.dot(&a))
            })
            .collect();
        Self {
            name: name.into(),
            mesh,
            edge_triangles,
            bounds,
            planes,
            motion,
            removed_at_s: None,
        }
    }

    /// The welded mesh in the file's position.
    pub fn mesh(&self) -> &WeldedMesh {
        &self.mesh
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.mesh.triangles.len()
    }

    /// Whether the wall exists at time `t_s`.
    pub fn is_present(&self, t_s: Real) -> bool {
        self.removed_at_s.is_none_or(|removed| t_s < removed)
    }

    /// Triangle `index`'s corners in the file's position, m.
    #[inline]
    pub fn corners(&self, index: u32) -> [Vec3; 3] {
        let [a, b, c] = self.mesh.triangles[index as usize];
        let v = |i: u32| Vec3::from(self.mesh.vertices[i as usize]);
        [v(a), v(b), v(c)]
    }

    /// Whether triangle `index`, displaced by `offset_m`, may come within `reach_m`
    /// of `p` (bounding-sphere and plane tests: false means certainly not).
    #[inline]
    pub fn may_reach(&self, index: u32, p: Vec3, offset_m: Vec3, reach_m: Real) -> bool {
        let local = p - offset_m;
        if !self.bound_within(index, local, reach_m) {
            return false;
        }
        let (normal, offset) = self.planes[index as usize];
        (normal.dot(&local) - offset).abs() < reach_m
    }

    /// Whether triangle `index`'s bounding sphere passes closer than `reach_m` to
    /// `local` (a point in the file's position): false means the triangle does not.
    #[inline]
    pub fn bound_within(&self, index: u32, local: Vec3, reach_m: Real) -> bool {
        let (centre, radius) = self.bounds[index as usize];
        let limit = radius + reach_m;
        (local - centre).norm_squared() < limit * limit
    }

    /// Triangle `index`'s plane in the file's position: unit normal and offset along
    /// it, m.
    #[inline]
    pub fn plane(&self, index: u32) -> (Vec3, Real) {
        self.planes[index as usize]
    }

    /// The point of triangle `index`, displaced by `offset_m`, closest to `p`.
    #[inline]
    pub fn closest_point(&self, index: u32, p: Vec3, offset_m: Vec3) -> WallPoint {
        let [a, b, c] = self.corners(index);
        let local = closest_point_on_triangle(p - offset_m, a, b, c);
        let triangle = &self.mesh.triangles[index as usize];
        let feature = match local.feature {
            TriangleFeature::Face => FeatureId::Face(index),
            TriangleFeature::Edge(k) => {
                FeatureId::Edge(self.mesh.triangle_edges[index as usize][k as usize])
            }
            TriangleFeature::Vertex(k) => FeatureId::Vertex(triangle[k as usize]),
        };
        WallPoint {
            point: local.point + offset_m,
            feature,
        }
    }

    /// Whether `feature` lies on the boundary of `face` (an edge of it or a corner),
    /// so that a contact with `face` already accounts for a contact with `feature`.
    pub fn face_contains(&self, face: u32, feature: FeatureId) -> bool {
        match feature {
            FeatureId::Face(other) => other == face,
            FeatureId::Edge(edge) => self.edge_triangles[edge as usize].contains(&face),
            FeatureId::Vertex(vertex) => self.mesh.triangles[face as usize].contains(&vertex),
        }
    }

    /// Whether vertex `vertex` is an end of edge `edge`.
    pub fn edge_contains(&self, edge: u32, vertex: u32) -> bool {
        self.mesh.edges[edge as usize].contains(&vertex)
    }
}
