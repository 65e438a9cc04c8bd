//! Particle–wall contacts: which triangles are near each particle (found at each
//! neighbour-list rebuild), and the contacts of one particle with them in one step.
//!
//! A sphere near a shared edge or vertex finds the same point through several
//! triangles; it must be pushed once. The rules, applied per particle and per mesh:
//!
//! 1. every contact on a face interior counts;
//! 2. a contact on an edge or a vertex counts only if no counted face contains that
//!    feature and it has not been counted already (through the other triangle);
//! 3. of contacts on one mesh whose normals differ by less than the *coplanar angle*
//!    (facets of one smooth surface, such as the segments of a cone), only the deepest
//!    counts, so a sphere in the crease between two nearly flat facets is not pushed
//!    twice.
//!
//! The tangential history of a wall contact is kept per particle, keyed by mesh and
//! feature; a contact that moves on to a neighbouring facet inherits the history of
//! the one it replaces when their normals are within the coplanar angle.

use rayon::prelude::*;

use crate::force::{hertz_mindlin, ContactGeometry};
use crate::material::{ContactTable, PairConstants};
use crate::math::{Real, Vec3};
use crate::mesh::{FeatureId, WallMesh};
use crate::neighbour::CellGrid;

/// Most wall contacts one particle can have at once (a sphere in a corner has three).
pub const MAX_WALL_CONTACTS: usize = 6;

/// The triangles of one mesh by cell of a grid fixed to the mesh.
#[derive(Debug, Clone)]
pub struct MeshIndex {
    grid: CellGrid,
    start: Vec<u32>,
    triangles: Vec<u32>,
}

impl MeshIndex {
    /// Indexes `mesh` so that every triangle within `reach_m` of a point is listed in
    /// the point's cell.
    pub fn new(mesh: &WallMesh, reach_m: Real) -> Self {
        let (low, high) = mesh.mesh().bounding_box();
        let margin = Vec3::repeat(reach_m * 1.01);
        let (low, high) = (Vec3::from(low) - margin, Vec3::from(high) + margin);
        let extent = (high - low).max();
        let grid = CellGrid::new(low, high, (2.0 * reach_m).max(extent / 64.0));
        let mut lists: Vec<Vec<u32>> = vec![Vec::new(); grid.len()];
        for t in 0..mesh.triangle_count() as u32 {
            let [a, b, c] = mesh.corners(t);
            let tmin = a.inf(&b).inf(&c) - margin;
            let tmax = a.sup(&b).sup(&c) + margin;
            let [xs, ys, zs] = grid.covering(tmin, tmax);
            for z in zs {
                for y in ys.clone() {
                    for x in xs.clone() {
                        lists[grid.index([x, y, z])].push(t);
                    }
                }
            }
        }
        let mut start = vec![0u32];
        let mut triangles = Vec::new();
        for list in lists {
            triangles.extend(list);
            start.push(triangles.len() as u32);
        }
        Self {
            grid,
            start,
            triangles,
        }
    }

    /// Triangles that may lie within reach of `p_local` (a point in the mesh's frame).
    #[inline]
    pub fn near(&self, p_local: Vec3) -> &[u32] {
        let cell = self.grid.index(self.grid.coords(p_local));
        &self.triangles[self.start[cell] as usize..self.start[cell + 1] as usize]
    }
}

/// One wall triangle near a particle, with the triangle's plane beside it: the plane
/// test rejects most candidates in a step, and with its data here it needs no look-up
/// in the mesh.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct WallCandidate {
    /// Mesh index.
    pub mesh: u16,
    /// Triangle index in the mesh.
    pub triangle: u32,
    /// The triangle's unit normal, in the mesh's file position.
    normal: Vec3,
    /// The plane's offset along `normal` in the mesh's file position, m.
    plane_offset_m: Real,
}

impl WallCandidate {
    /// Whether the triangle's plane passes closer than `reach_m` to `local` (a point
    /// in the mesh's file position): false means the triangle certainly does not.
    #[inline]
    fn plane_within(&self, local: Vec3, reach_m: Real) -> bool {
        (self.normal.dot(&local) - self.plane_offset_m).abs() < reach_m
    }
}

/// For each particle, the wall triangles within its radius plus a margin, in
/// compressed rows.
#[derive(Debug, Clone, Default, serde::Serialize, serde::Deserialize)]
pub struct WallCandidates {
    start: Vec<u32>,
    entries: Vec<WallCandidate>,
}

impl WallCandidates {
    /// Finds the candidates of every particle: triangles closer than its radius plus
    /// `margin_m` (how much closer the two can come before the next rebuild); meshes
    /// that are gone are skipped.
    pub fn build(
        meshes: &[WallMesh],
        indexes: &[MeshIndex],
        offsets_m: &[Vec3],
        present: &[bool],
        positions_m: &[Vec3],
        radii_m: &[Real],
        margin_m: Real,
    ) -> Self {
        let rows: Vec<Vec<WallCandidate>> = (0..positions_m.len())
            .into_par_iter()
            .map(|i| {
                let mut row = Vec::new();
                for (m, mesh) in meshes.iter().enumerate() {
                    if !present[m] {
                        continue;
                    }
                    let reach = radii_m[i] + margin_m;
                    let p = positions_m[i];
                    for &t in indexes[m].near(p - offsets_m[m]) {
                        if !mesh.may_reach(t, p, offsets_m[m], reach) {
                            continue;
                        }
                        let q = mesh.closest_point(t, p, offsets_m[m]).point;
                        if (p - q).norm_squared() < reach * reach {
                            let (normal, plane_offset_m) = mesh.plane(t);
                            row.push(WallCandidate {
                                mesh: m as u16,
                                triangle: t,
                                normal,
                                plane_offset_m,
                            });
                        }
                    }
                }
                row
            })
            .collect();
        let mut start = vec![0u32];
        let mut entries = Vec::new();
        for row in rows {
            entries.extend(row);
            start.push(entries.len() as u32);
        }
        Self { start, entries }
    }

    /// Candidates of particle `i`.
    #[inline]
    pub fn of(&self, i: usize) -> &[WallCandidate] {
        &self.entries[self.start[i] as usize..self.start[i + 1] as usize]
    }

    /// The number of particles the rows are for, when the rows are well formed and
    /// every entry names a triangle of `meshes`; `None` otherwise (a damaged saved
    /// state).
    pub(crate) fn rows_for(&self, meshes: &[WallMesh]) -> Option<usize> {
        let ordered = crate::neighbour::rows_fit(&self.start, self.entries.len());
        let named = self.entries.iter().all(|e| {
            meshes
                .get(usize::from(e.mesh))
                .is_some_and(|m| (e.triangle as usize) < m.triangle_count())
        });
        (ordered && named).then(|| self.start.len() - 1)
    }
}

/// One wall contact that persists from step to step.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct WallContact {
    /// Mesh index.
    pub mesh: u16,
    /// Feature of the mesh touched.
    pub feature: FeatureId,
    /// Unit normal from the wall towards the particle.
    pub normal: Vec3,
    /// Tangential history, m.
    pub shear_m: Vec3,
}

const NO_CONTACT: WallContact = WallContact {
    mesh: u16::MAX,
    feature: FeatureId::Face(u32::MAX),
    normal: Vec3::new(0.0, 0.0, 0.0),
    shear_m: Vec3::new(0.0, 0.0, 0.0),
};

/// The wall contacts of one particle, a fixed-capacity list.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct WallContacts {
    len: usize,
    items: [WallContact; MAX_WALL_CONTACTS],
}

impl Default for WallContacts {
    fn default() -> Self {
        Self {
            len: 0,
            items: [NO_CONTACT; MAX_WALL_CONTACTS],
        }
    }
}

impl WallContacts {
    /// The current contacts.
    pub fn as_slice(&self) -> &[WallContact] {
        &self.items[..self.len]
    }

    fn push(&mut self, contact: WallContact) {
        if self.len < MAX_WALL_CONTACTS {
            self.items[self.len] = contact;
            self.len += 1;
        }
    }
}

/// The wall contacts of the particles that have wall candidates, one list each, in
/// particle order. Most particles of a large bed are far from every wall; a list per
/// particle would cost them ~400 bytes each.
#[derive(Debug, Clone, Default, serde::Serialize, serde::Deserialize)]
pub struct WallContactStore {
    /// Particle `i`'s list is `lists[slot_start[i]]` when `slot_start[i + 1] >
    /// slot_start[i]`, else it has none.
    slot_start: Vec<u32>,
    lists: Vec<WallContacts>,
}

impl WallContactStore {
    /// One empty list per particle with candidates.
    pub fn new(candidates: &WallCandidates) -> Self {
        Self::carried(&Self::default(), candidates, &[])
    }

    /// The lists for `candidates`, each carried over from `previous`, whose particle
    /// `former[i]` is particle `i` now (an index `previous` lacks starts empty).
    pub fn carried(previous: &Self, candidates: &WallCandidates, former: &[u32]) -> Self {
        let n = candidates.start.len().saturating_sub(1);
        let mut slot_start = Vec::with_capacity(n + 1);
        let mut lists = Vec::new();
        slot_start.push(0);
        for i in 0..n {
            if !candidates.of(i).is_empty() {
                let list = former
                    .get(i)
                    .and_then(|&f| previous.slot(f as usize))
                    .map_or_else(WallContacts::default, |k| previous.lists[k]);
                lists.push(list);
            }
            slot_start.push(lists.len() as u32);
        }
        Self { slot_start, lists }
    }

    /// Whether the lists are those of `candidates`' particles (one for each particle
    /// with candidates, none for the others) and each holds at most
    /// [`MAX_WALL_CONTACTS`] contacts with meshes below `mesh_count`: a damaged saved
    /// state fails this.
    pub(crate) fn fits(&self, candidates: &WallCandidates, mesh_count: usize) -> bool {
        let Some(n) = candidates.start.len().checked_sub(1) else {
            return false;
        };
        self.slot_start.len() == n + 1
            && self.slot_start.first() == Some(&0)
            && (0..n).all(|i| {
                let width = self.slot_start[i + 1].checked_sub(self.slot_start[i]);
                width == Some(u32::from(!candidates.of(i).is_empty()))
            })
            && self.slot_start.last().map(|&s| s as usize) == Some(self.lists.len())
            && self.lists.iter().all(|list| {
                list.len <= MAX_WALL_CONTACTS
                    && list
                        .as_slice()
                        .iter()
                        .all(|c| usize::from(c.mesh) < mesh_count)
            })
    }

    fn slot(&self, i: usize) -> Option<usize> {
        let range = self.slot_start.get(i..i + 2)?;
        (range[1] > range[0]).then_some(range[0] as usize)
    }

    /// The contacts of particle `i` in the last step.
    pub fn of(&self, i: usize) -> &[WallContact] {
        self.slot(i).map_or(&[], |k| self.lists[k].as_slice())
    }

    /// The lists of the particles `first..first + chunk` for each chunk of `chunk`
    /// particles, in order (for a parallel pass over chunks).
    pub fn chunks_mut(&mut self, chunk: usize) -> Vec<&mut [WallContacts]> {
        let n = self.slot_start.len().saturating_sub(1);
        let mut rest: &mut [WallContacts] = &mut self.lists;
        let mut out = Vec::with_capacity(n.div_ceil(chunk));
        for first in (0..n).step_by(chunk) {
            let last = (first + chunk).min(n);
            let len = (self.slot_start[last] - self.slot_start[first]) as usize;
            let (mine, others) = std::mem::take(&mut rest).split_at_mut(len);
            rest = others;
            out.push(mine);
        }
        out
    }
}

/// What the wall pass needs to know of the walls at the current step.
#[derive(Debug, Clone, Copy)]
pub struct WallState<'a> {
    /// The walls.
    pub meshes: &'a [WallMesh],
    /// Each mesh's displacement from its file position, m.
    pub offsets_m: &'a [Vec3],
    /// Each mesh's velocity, m/s.
    pub velocities_m_per_s: &'a [Vec3],
    /// Whether each mesh is present.
    pub present: &'a [bool],
    /// Contact constants.
    pub table: &'a ContactTable,
    /// Time step, s.
    pub dt_s: Real,
    /// Cosine of the coplanar angle (rule 3 above).
    pub cos_coplanar: Real,
}

/// One particle as the wall pass sees it.
#[derive(Debug, Clone, Copy)]
pub struct ParticleView {
    /// Centre, m.
    pub position_m: Vec3,
    /// Velocity, m/s.
    pub velocity_m_per_s: Vec3,
    /// Angular velocity, rad/s.
    pub angular_velocity: Vec3,
    /// Radius, m.
    pub radius_m: Real,
    /// Mass, kg.
    pub mass_kg: Real,
    /// Type index.
    pub kind: usize,
}

/// Force and torque the walls exert on one particle, and its deepest wall overlap.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct WallLoad {
    /// Force, N.
    pub force_n: Vec3,
    /// Torque, N m.
    pub torque_n_m: Vec3,
    /// Largest overlap divided by the radius (1 when the centre is on the wall).
    pub worst_overlap_ratio: Real,
    /// Kinetic energy of the normal approach, `½ m v_n²`, of the contacts that began
    /// this step (an impact; a contact that moves on to a nearly parallel facet is the
    /// same contact), J: the wall-wear proxy's increment.
    pub impact_energy_j: Real,
}

#[derive(Clone, Copy)]
struct Touch {
    mesh: u16,
    feature: FeatureId,
    normal: Vec3,
    overlap_m: Real,
}

/// The walls' contacts with one particle in this step: finds the touching features
/// among `candidates`, applies the counting rules, carries the histories in
/// `contacts` over, and sums the forces.
pub fn wall_load(
    walls: &WallState<'_>,
    candidates: &[WallCandidate],
    particle: &ParticleView,
    contacts: &mut WallContacts,
) -> WallLoad {
    let mut load = WallLoad {
        force_n: Vec3::zeros(),
        torque_n_m: Vec3::zeros(),
        worst_overlap_ratio: 0.0,
        impact_energy_j: 0.0,
    };
    if candidates.is_empty() {
        contacts.len = 0;
        return load;
    }
    let p = particle.position_m;
    let r = particle.radius_m;
    let mut touches: [Option<Touch>; 8] = [None; 8];
    let mut count = 0;
    for candidate in candidates {
        let (m, t) = (candidate.mesh, candidate.triangle);
        if !walls.present[m as usize] || count == touches.len() {
            continue;
        }
        // The tests of `WallMesh::may_reach`, the plane's first.
        let offset_m = walls.offsets_m[m as usize];
        let local = p - offset_m;
        if !candidate.plane_within(local, r) {
            continue;
        }
        let mesh = &walls.meshes[m as usize];
        if !mesh.bound_within(t, local, r) {
            continue;
        }
        let hit = mesh.closest_point(t, p, offset_m);
        let offset = p - hit.point;
        let distance_squared = offset.norm_squared();
        if distance_squared >= r * r {
            continue;
        }
        let distance = distance_squared.sqrt();
        if distance == 0.0 {
            load.worst_overlap_ratio = 1.0;
            continue;
        }
        touches[count] = Some(Touch {
            mesh: m,
            feature: hit.feature,
            normal: offset * (1.0 / distance),
            overlap_m: r - distance,
        });
        count += 1;
    }
    if count == 0 {
        contacts.len = 0;
        return load;
    }
    let constants = walls.table.wall(particle.kind);
    if count == 1 {
        // Every rule keeps a lone touch; its history is found as for any other.
        let touch = touches[0].expect("the first touch is set");
        let (shear, continued) = lone_history(contacts.as_slice(), &touch, walls.cos_coplanar);
        contacts.len = 0;
        add_contact(
            walls, constants, particle, &touch, shear, continued, &mut load, contacts,
        );
        return load;
    }
    let previous = *contacts;
    let (kept, n_kept) = kept_touches(walls, &mut touches[..count]);
    let mut inherited = [false; MAX_WALL_CONTACTS];
    contacts.len = 0;
    // Histories: the same feature first, else a nearly parallel contact on the mesh.
    let mut shears = [Vec3::zeros(); MAX_WALL_CONTACTS];
    let mut continued = [false; MAX_WALL_CONTACTS];
    for (slot, touch) in kept[..n_kept].iter().flatten().enumerate() {
        if let Some(k) = same_feature(previous.as_slice(), touch) {
            shears[slot] = previous.items[k].shear_m;
            inherited[k] = true;
            continued[slot] = true;
        }
    }
    for (slot, touch) in kept[..n_kept].iter().flatten().enumerate() {
        // Only the same-feature pass has set `continued` so far.
        if continued[slot] {
            continue;
        }
        let best = most_parallel(previous.as_slice(), touch, walls.cos_coplanar, &inherited);
        if let Some(k) = best {
            shears[slot] = previous.items[k].shear_m;
            inherited[k] = true;
            continued[slot] = true;
        }
    }

    for (slot, touch) in kept[..n_kept].iter().flatten().enumerate() {
        add_contact(
            walls,
            constants,
            particle,
            touch,
            shears[slot],
            continued[slot],
            &mut load,
            contacts,
        );
    }
    load
}

/// Of several `touches`, the contacts that count, deepest first (rules 1 to 3 above):
/// faces before edges before vertices, a feature covered by a counted one dropped, and
/// a contact nearly parallel to a deeper kept one on its mesh dropped.
#[inline]
fn kept_touches(
    walls: &WallState<'_>,
    touches: &mut [Option<Touch>],
) -> ([Option<Touch>; MAX_WALL_CONTACTS], usize) {
    // Rules 1 and 2: faces first, then edges, then vertices, each only once.
    let rank = |t: &Option<Touch>| match t.map(|t| t.feature) {
        Some(FeatureId::Face(_)) => 0,
        Some(FeatureId::Edge(_)) => 1,
        _ => 2,
    };
    touches.sort_by_key(rank);
    let mut counted: [Option<Touch>; 8] = [None; 8];
    let mut n_counted = 0;
    for touch in touches.iter().flatten() {
        let mesh = &walls.meshes[touch.mesh as usize];
        let covered = counted[..n_counted].iter().flatten().any(|c| {
            c.mesh == touch.mesh
                && (c.feature == touch.feature
                    || match (c.feature, touch.feature) {
                        (FeatureId::Face(face), feature) => mesh.face_contains(face, feature),
                        (FeatureId::Edge(edge), FeatureId::Vertex(vertex)) => {
                            mesh.edge_contains(edge, vertex)
                        }
                        _ => false,
                    })
        });
        if !covered && n_counted < counted.len() {
            counted[n_counted] = Some(*touch);
            n_counted += 1;
        }
    }
    // Rule 3: deepest first; drop a contact nearly parallel to a kept one on its mesh.
    let counted = &mut counted[..n_counted];
    counted.sort_by(|a, b| {
        let depth = |t: &Option<Touch>| t.map_or(0.0, |t| t.overlap_m);
        depth(b).total_cmp(&depth(a))
    });
    let mut kept: [Option<Touch>; MAX_WALL_CONTACTS] = [None; MAX_WALL_CONTACTS];
    let mut n_kept = 0;
    for touch in counted.iter().flatten() {
        let parallel = kept[..n_kept]
            .iter()
            .flatten()
            .any(|k| k.mesh == touch.mesh && k.normal.dot(&touch.normal) > walls.cos_coplanar);
        if parallel || n_kept == MAX_WALL_CONTACTS {
            continue;
        }
        kept[n_kept] = Some(*touch);
        n_kept += 1;
    }
    (kept, n_kept)
}

/// The history a lone touch carries on, by the rules above with nothing inherited yet,
/// and whether it continues a contact of the last step.
fn lone_history(previous: &[WallContact], touch: &Touch, cos_coplanar: Real) -> (Vec3, bool) {
    same_feature(previous, touch)
        .or_else(|| most_parallel(previous, touch, cos_coplanar, &[false; MAX_WALL_CONTACTS]))
        .map_or((Vec3::zeros(), false), |k| (previous[k].shear_m, true))
}

/// The contact of the last step, if any, on the same feature as `touch`.
fn same_feature(previous: &[WallContact], touch: &Touch) -> Option<usize> {
    previous
        .iter()
        .position(|c| c.mesh == touch.mesh && c.feature == touch.feature)
}

/// Of the last step's contacts not `inherited` yet, the one on `touch`'s mesh most
/// nearly parallel to it within the coplanar angle (the last of equals).
fn most_parallel(
    previous: &[WallContact],
    touch: &Touch,
    cos_coplanar: Real,
    inherited: &[bool; MAX_WALL_CONTACTS],
) -> Option<usize> {
    previous
        .iter()
        .enumerate()
        .filter(|(k, c)| {
            !inherited[*k] && c.mesh == touch.mesh && c.normal.dot(&touch.normal) > cos_coplanar
        })
        .max_by(|a, b| {
            a.1.normal
                .dot(&touch.normal)
                .total_cmp(&b.1.normal.dot(&touch.normal))
        })
        .map(|(k, _)| k)
}

/// Adds one kept touch's contact force, with the history `shear`, to `load`, its
/// impact energy when it begins (`continued` false), and the contact to `contacts`.
#[allow(clippy::too_many_arguments)]
fn add_contact(
    walls: &WallState<'_>,
    constants: &PairConstants,
    particle: &ParticleView,
    touch: &Touch,
    mut shear: Vec3,
    continued: bool,
    load: &mut WallLoad,
    contacts: &mut WallContacts,
) {
    let r = particle.radius_m;
    let n = touch.normal;
    // The lever from the centre to the contact point: to the middle of the overlap,
    // r − δ/2, as LIGGGHTS's wall/gran takes it (between two particles both codes use
    // the radii).
    let arm = r - 0.5 * touch.overlap_m;
    let wall_velocity = walls.velocities_m_per_s[touch.mesh as usize];
    let contact_velocity =
        particle.velocity_m_per_s - arm * particle.angular_velocity.cross(&n) - wall_velocity;
    if !continued {
        let approach = -contact_velocity.dot(&n);
        if approach > 0.0 {
            load.impact_energy_j += 0.5 * particle.mass_kg * approach * approach;
        }
    }
    let geometry = ContactGeometry {
        normal: n,
        overlap_m: touch.overlap_m,
        effective_radius_m: r,
        effective_mass_kg: particle.mass_kg,
    };
    let result = hertz_mindlin(
        constants,
        &geometry,
        contact_velocity,
        particle.angular_velocity,
        &mut shear,
        walls.dt_s,
    );
    load.force_n += result.force;
    load.torque_n_m += (-arm * n).cross(&result.tangential) + result.rolling_torque;
    load.worst_overlap_ratio = load.worst_overlap_ratio.max(touch.overlap_m / r);
    contacts.push(WallContact {
        mesh: touch.mesh,
        feature: touch.feature,
        normal: n,
        shear_m: shear,
    });
}
