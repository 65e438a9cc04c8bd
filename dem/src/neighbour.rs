//! Neighbour search: a cell list builds a Verlet list of particle pairs within reach
//! plus a skin, kept until some particle has moved half the skin.
//!
//! The list is a half list in compressed rows (pairs `(i, j)` with `i < j`, row `i`
//! sorted by `j`). Each pair carries its tangential history, which survives rebuilds
//! and particle removal (rows are matched by particle id), as rapier's narrow phase
//! keeps persistent contact pairs. A reverse index lets each particle gather the forces
//! of the pairs it is the second member of, so the sum over a particle's contacts runs
//! in a fixed order whatever the number of threads.

use rayon::prelude::*;

use crate::math::{Real, Vec3};

/// A uniform grid of cells over a box, each cell at least one cut-off wide.
#[derive(Debug, Clone)]
pub struct CellGrid {
    origin_m: Vec3,
    cell_m: Real,
    dims: [usize; 3],
}

impl CellGrid {
    /// A grid over the box `[min_m, max_m]` with cells at least `cell_m` wide.
    pub fn new(min_m: Vec3, max_m: Vec3, cell_m: Real) -> Self {
        let dims = [0, 1, 2].map(|k| (((max_m[k] - min_m[k]) / cell_m).floor() as usize).max(1));
        let cell_m = (0..3)
            .map(|k| (max_m[k] - min_m[k]) / dims[k] as Real)
            .fold(cell_m, Real::max);
        Self {
            origin_m: min_m,
            cell_m,
            dims,
        }
    }

    /// Number of cells.
    pub fn len(&self) -> usize {
        self.dims[0] * self.dims[1] * self.dims[2]
    }

    /// Whether the grid has no cells (never: a grid has at least one).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Cell coordinates of a point; points outside the box fall in the boundary cells,
    /// which keeps the search correct (those cells only hold more candidates).
    #[inline]
    pub fn coords(&self, p: Vec3) -> [usize; 3] {
        [0, 1, 2].map(|k| {
            let c = ((p[k] - self.origin_m[k]) / self.cell_m).floor();
            if c.is_nan() || c < 0.0 {
                0
            } else {
                (c as usize).min(self.dims[k] - 1)
            }
        })
    }

    /// Linear index of cell coordinates.
    #[inline]
    pub fn index(&self, c: [usize; 3]) -> usize {
        (c[2] * self.dims[1] + c[1]) * self.dims[0] + c[0]
    }

    /// Calls `visit` with the linear index of each of the up to 13 cells after cell
    /// `cell` in the 3×3×3 block around it (half the neighbours: each pair of
    /// neighbouring cells is visited from one side only).
    #[inline]
    pub fn for_each_forward_cell(&self, cell: usize, mut visit: impl FnMut(usize)) {
        let [nx, ny, nz] = self.dims.map(|d| d as isize);
        let (x, y, z) = (
            (cell % self.dims[0]) as isize,
            ((cell / self.dims[0]) % self.dims[1]) as isize,
            (cell / (self.dims[0] * self.dims[1])) as isize,
        );
        for dz in 0..=1isize {
            for dy in -1..=1isize {
                for dx in -1..=1isize {
                    let forward = dz > 0 || dy > 0 || (dy == 0 && dx > 0);
                    if !forward {
                        continue;
                    }
                    let (cx, cy, cz) = (x + dx, y + dy, z + dz);
                    if (0..nx).contains(&cx) && (0..ny).contains(&cy) && (0..nz).contains(&cz) {
                        visit(self.index([cx as usize, cy as usize, cz as usize]));
                    }
                }
            }
        }
    }

    /// Cell ranges (inclusive) covered by the box `[min_m, max_m]`.
    pub fn covering(&self, min_m: Vec3, max_m: Vec3) -> [std::ops::RangeInclusive<usize>; 3] {
        let low = self.coords(min_m);
        let high = self.coords(max_m);
        [low[0]..=high[0], low[1]..=high[1], low[2]..=high[2]]
    }
}

/// Particles sorted by cell, for neighbour queries (counting sort).
#[derive(Debug, Clone, Default)]
pub struct CellBins {
    start: Vec<u32>,
    members: Vec<u32>,
}

impl CellBins {
    /// Bins `positions` into `grid`'s cells.
    pub fn build(grid: &CellGrid, positions: &[Vec3]) -> Self {
        let cell_of: Vec<usize> = positions
            .iter()
            .map(|&p| grid.index(grid.coords(p)))
            .collect();
        let mut start = vec![0u32; grid.len() + 1];
        for &c in &cell_of {
            start[c + 1] += 1;
        }
        for c in 0..grid.len() {
            start[c + 1] += start[c];
        }
        let mut fill = start.clone();
        let mut members = vec![0u32; positions.len()];
        for (i, &c) in cell_of.iter().enumerate() {
            members[fill[c] as usize] = i as u32;
            fill[c] += 1;
        }
        Self { start, members }
    }

    /// Particle indices in cell `cell`, ascending.
    #[inline]
    pub fn members(&self, cell: usize) -> &[u32] {
        &self.members[self.start[cell] as usize..self.start[cell + 1] as usize]
    }
}

/// The Verlet half list of particle pairs with their per-pair state.
#[derive(Debug, Clone, Default)]
pub struct PairList {
    /// Row starts: pairs of particle `i` are `row_start[i]..row_start[i + 1]`.
    pub row_start: Vec<u32>,
    /// Second member `j > i` of each pair.
    pub partner: Vec<u32>,
    /// Tangential history of each pair, m (zero when not in contact).
    pub shear_m: Vec<Vec3>,
    /// Whether each pair touched in the last force computation.
    pub in_contact: Vec<bool>,
    /// Reverse index: pairs in which particle `j` is the second member are
    /// `reverse_pair[reverse_start[j]..reverse_start[j + 1]]`.
    pub reverse_start: Vec<u32>,
    /// See `reverse_start`.
    pub reverse_pair: Vec<u32>,
}

impl PairList {
    /// Number of pairs.
    pub fn len(&self) -> usize {
        self.partner.len()
    }

    /// Whether the list is empty.
    pub fn is_empty(&self) -> bool {
        self.partner.is_empty()
    }

    /// Builds the list of pairs within `radius_i + radius_j + skin_m` and carries the
    /// tangential history over from `previous`, whose particle `former[i]` is this
    /// list's particle `i` (`ids` are the current particle ids, `former_ids` those of
    /// the previous list's particles).
    #[allow(clippy::too_many_arguments)]
    pub fn build(
        grid: &CellGrid,
        positions: &[Vec3],
        radii: &[Real],
        skin_m: Real,
        previous: &PairList,
        former: &[u32],
        ids: &[u32],
        former_ids: &[u32],
    ) -> Self {
        let n = positions.len();
        let bins = CellBins::build(grid, positions);
        let within = |i: u32, j: u32| {
            let (i, j) = (i as usize, j as usize);
            let reach = radii[i] + radii[j] + skin_m;
            (positions[j] - positions[i]).norm_squared() < reach * reach
        };
        // Each pair once: a cell against itself and its 13 "forward" neighbours.
        // Folded into one vector per rayon job; the flattened order is the cell order
        // whatever the number of threads.
        let found: Vec<Vec<(u32, u32)>> = (0..grid.len())
            .into_par_iter()
            .fold(Vec::new, |mut pairs, cell| {
                let members = bins.members(cell);
                if members.is_empty() {
                    return pairs;
                }
                for (a, &i) in members.iter().enumerate() {
                    for &j in &members[a + 1..] {
                        if within(i, j) {
                            pairs.push((i, j));
                        }
                    }
                }
                grid.for_each_forward_cell(cell, |other| {
                    for &i in members {
                        for &j in bins.members(other) {
                            if within(i, j) {
                                pairs.push((i.min(j), i.max(j)));
                            }
                        }
                    }
                });
                pairs
            })
            .collect();
        // Rows by first member, each sorted by partner.
        let mut row_start = vec![0u32; n + 1];
        for &(i, _) in found.iter().flatten() {
            row_start[i as usize + 1] += 1;
        }
        for i in 0..n {
            row_start[i + 1] += row_start[i];
        }
        let mut fill = row_start.clone();
        let total = row_start[n] as usize;
        let mut partner = vec![0u32; total];
        for &(i, j) in found.iter().flatten() {
            partner[fill[i as usize] as usize] = j;
            fill[i as usize] += 1;
        }
        let mut shear_m = vec![Vec3::zeros(); total];
        // Sort rows and carry history: the previous row of the same particle, by id.
        let mut row_slices = Vec::with_capacity(n);
        let (mut partner_rest, mut shear_rest) = (&mut partner[..], &mut shear_m[..]);
        for i in 0..n {
            let len = (row_start[i + 1] - row_start[i]) as usize;
            let (p, rest) = partner_rest.split_at_mut(len);
            partner_rest = rest;
            let (h, rest) = shear_rest.split_at_mut(len);
            shear_rest = rest;
            row_slices.push((i, p, h));
        }
        row_slices.into_par_iter().for_each(|(i, row, shear)| {
            row.sort_unstable();
            let Some(&f) = former.get(i) else { return };
            let f = f as usize;
            if f + 1 >= previous.row_start.len() {
                return;
            }
            let base = previous.row_start[f] as usize;
            let old_row = &previous.partner[base..previous.row_start[f + 1] as usize];
            let mut cursor = 0;
            for (slot, &j) in row.iter().enumerate() {
                let id = ids[j as usize];
                while cursor < old_row.len() && former_ids[old_row[cursor] as usize] < id {
                    cursor += 1;
                }
                if cursor < old_row.len() && former_ids[old_row[cursor] as usize] == id {
                    shear[slot] = previous.shear_m[base + cursor];
                }
            }
        });
        let mut reverse_count = vec![0u32; n + 1];
        for &j in &partner {
            reverse_count[j as usize + 1] += 1;
        }
        for j in 0..n {
            reverse_count[j + 1] += reverse_count[j];
        }
        let reverse_start = reverse_count.clone();
        let mut fill = reverse_count;
        let mut reverse_pair = vec![0u32; total];
        for (k, &j) in partner.iter().enumerate() {
            reverse_pair[fill[j as usize] as usize] = k as u32;
            fill[j as usize] += 1;
        }
        let in_contact = shear_m.iter().map(|h| *h != Vec3::zeros()).collect();
        Self {
            row_start,
            partner,
            shear_m,
            in_contact,
            reverse_start,
            reverse_pair,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// The cell list finds exactly the pairs a brute-force search finds.
        #[test]
        fn cell_list_equals_brute_force(points in proptest::collection::vec((0.0..0.05f64, 0.0..0.05f64, 0.0..0.05f64), 2..120)) {
            let positions: Vec<Vec3> = points.iter().map(|&(x, y, z)| Vec3::new(x, y, z)).collect();
            let radii: Vec<Real> = (0..positions.len()).map(|i| if i % 3 == 0 { 0.002 } else { 0.001 }).collect();
            let ids: Vec<u32> = (1..=positions.len() as u32).collect();
            let grid = CellGrid::new(Vec3::zeros(), Vec3::new(0.05, 0.05, 0.05), 0.005);
            let list = PairList::build(&grid, &positions, &radii, 0.001, &PairList::default(), &[], &ids, &[]);
            let mut expected = Vec::new();
            for i in 0..positions.len() {
                for j in i + 1..positions.len() {
                    let reach = radii[i] + radii[j] + 0.001;
                    if (positions[i] - positions[j]).norm() < reach {
                        expected.push((i as u32, j as u32));
                    }
                }
            }
            let mut found = Vec::new();
            for i in 0..positions.len() {
                for k in list.row_start[i]..list.row_start[i + 1] {
                    found.push((i as u32, list.partner[k as usize]));
                }
            }
            prop_assert_eq!(found, expected);
            // The reverse index lists each pair once, under its second member.
            let mut reverse = 0;
            for j in 0..positions.len() {
                for r in list.reverse_start[j]..list.reverse_start[j + 1] {
                    let k = list.reverse_pair[r as usize] as usize;
                    prop_assert_eq!(list.partner[k] as usize, j);
                    reverse += 1;
                }
            }
            prop_assert_eq!(reverse, list.len());
        }
    }

    #[test]
    fn history_follows_particle_ids_across_a_removal() {
        let positions = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.0019, 0.0, 0.0),
            Vec3::new(0.0038, 0.0, 0.0),
        ];
        let radii = vec![0.001; 3];
        let grid = CellGrid::new(Vec3::zeros(), Vec3::new(0.01, 0.01, 0.01), 0.003);
        let ids = vec![1, 2, 3];
        let mut first = PairList::build(
            &grid,
            &positions,
            &radii,
            0.0005,
            &PairList::default(),
            &[],
            &ids,
            &[],
        );
        assert_eq!(first.len(), 2);
        first.shear_m[1] = Vec3::new(1e-6, 0.0, 0.0); // pair (2, 3)
                                                      // Particle 1 leaves; particles 2 and 3 are now indices 0 and 1.
        let second = PairList::build(
            &grid,
            &positions[1..],
            &radii[1..],
            0.0005,
            &first,
            &[1, 2],
            &[2, 3],
            &ids,
        );
        assert_eq!(second.len(), 1);
        assert_eq!(second.shear_m[0], Vec3::new(1e-6, 0.0, 0.0));
    }
}
