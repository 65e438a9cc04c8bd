//! Neighbour search: a cell list builds a Verlet list of particle pairs within reach
//! plus a skin, kept until some particle has moved half the skin.
//!
//! The list is a half list in compressed rows (pairs `(i, j)` with `i < j`, row `i`
//! sorted by `j`). Each pair carries its tangential history, which survives rebuilds,
//! particle removal and reordering (a new pair finds its old slot through each
//! member's former index), as rapier's narrow phase keeps persistent contact pairs. A
//! reverse index lets each particle gather the forces of the pairs it is the second
//! member of (the stepper reads those whose row lies outside the particle's block of
//! the pair pass), so the sum over a particle's contacts runs in a fixed order
//! whatever the number of threads. A particle's reverse entries ascend, pairs being
//! numbered row by row.
//!
//! At each rebuild the stepper sorts the particles along a Morton (Z-order) curve over
//! the cells ([`CurveOrder`]): a particle's partners then sit a few cache lines from
//! it instead of anywhere in memory, which is what keeps the cost per particle-step
//! from growing with the number of particles (LAMMPS's `atom_modify sort` does the
//! same).

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

/// `x`'s low 21 bits spread to every third bit.
fn spread_bits(x: u64) -> u64 {
    let mut x = x & 0x1f_ffff;
    x = (x | x << 32) & 0x1f_0000_0000_ffff;
    x = (x | x << 16) & 0x1f_0000_ff00_00ff;
    x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
    x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
    x = (x | x << 2) & 0x1249_2492_4924_9249;
    x
}

/// The Morton (Z-order) code of cell coordinates: their bits interleaved, so that
/// cells close in space mostly have close codes.
pub fn morton_code(c: [usize; 3]) -> u64 {
    spread_bits(c[0] as u64) | spread_bits(c[1] as u64) << 1 | spread_bits(c[2] as u64) << 2
}

/// The cells of a grid ranked along a Morton curve, to sort particles by.
#[derive(Debug, Clone, Default)]
pub struct CurveOrder {
    rank: Vec<u32>,
}

impl CurveOrder {
    /// Ranks `grid`'s cells by their Morton code.
    pub fn new(grid: &CellGrid) -> Self {
        let coords = |cell: usize| {
            [
                cell % grid.dims[0],
                (cell / grid.dims[0]) % grid.dims[1],
                cell / (grid.dims[0] * grid.dims[1]),
            ]
        };
        let mut cells: Vec<u32> = (0..grid.len() as u32).collect();
        cells.sort_unstable_by_key(|&c| morton_code(coords(c as usize)));
        let mut rank = vec![0u32; grid.len()];
        for (r, &c) in cells.iter().enumerate() {
            rank[c as usize] = r as u32;
        }
        Self { rank }
    }

    /// The indices `members` (ascending) sorted by the curve rank of their particle's
    /// cell, ties kept in index order (a counting sort: linear in the particles and
    /// cells, and the same whatever the number of threads).
    pub fn sort(&self, grid: &CellGrid, positions: &[Vec3], members: &[u32]) -> Vec<u32> {
        let rank_of: Vec<u32> = members
            .iter()
            .map(|&i| self.rank[grid.index(grid.coords(positions[i as usize]))])
            .collect();
        let mut start = vec![0u32; self.rank.len() + 1];
        for &r in &rank_of {
            start[r as usize + 1] += 1;
        }
        running_sum(&mut start);
        let mut sorted = vec![0u32; members.len()];
        for (&i, &r) in members.iter().zip(&rank_of) {
            sorted[start[r as usize] as usize] = i;
            start[r as usize] += 1;
        }
        sorted
    }
}

/// Each entry replaced by the sum of it and all before it: counts kept one slot ahead
/// of their bin become the bins' starts. The sum runs in a register, not through the
/// previous entry in memory (a store-to-load round trip per entry).
fn running_sum(values: &mut [u32]) {
    let mut total = 0u32;
    for value in values {
        total += *value;
        *value = total;
    }
}

/// Marks a particle that has no former index (it was inserted since the last build).
pub const NEW_PARTICLE: u32 = u32::MAX;

/// Particles sorted by cell, for neighbour queries (counting sort).
#[derive(Debug, Clone, Default)]
pub struct CellBins {
    start: Vec<u32>,
    members: Vec<u32>,
    /// The cells with at least one member, ascending: the pair search loops over
    /// these, not over every cell of the box (most are empty in a hopper's box).
    occupied: Vec<u32>,
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
        running_sum(&mut start);
        let mut fill = start.clone();
        let mut members = vec![0u32; positions.len()];
        for (i, &c) in cell_of.iter().enumerate() {
            members[fill[c] as usize] = i as u32;
            fill[c] += 1;
        }
        let occupied = (0..grid.len() as u32)
            .filter(|&c| start[c as usize] < start[c as usize + 1])
            .collect();
        Self {
            start,
            members,
            occupied,
        }
    }

    /// Where cell `cell`'s members (their particle indices, ascending) lie in the bin
    /// order, which the per-bin copies of [`CellBins::gather`] share.
    #[inline]
    pub fn slots(&self, cell: usize) -> std::ops::Range<usize> {
        self.start[cell] as usize..self.start[cell + 1] as usize
    }

    /// `values` in bin order: the value of every cell's members side by side, so a
    /// loop over a cell's members reads contiguous memory.
    pub fn gather<T: Copy>(&self, values: &[T]) -> Vec<T> {
        self.members.iter().map(|&i| values[i as usize]).collect()
    }
}

/// Whether `starts` are the row starts of compressed rows over `entries` entries: from 0,
/// never decreasing, ending at `entries`. A saved state that fails this is damaged.
pub(crate) fn rows_fit(starts: &[u32], entries: usize) -> bool {
    starts.first() == Some(&0)
        && starts.windows(2).all(|w| w[0] <= w[1])
        && starts.last().map(|&s| s as usize) == Some(entries)
}

/// The Verlet half list of particle pairs with their per-pair state.
#[derive(Debug, Clone, Default, serde::Serialize, serde::Deserialize)]
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

    /// The tangential history of particle `i` against particle `j`, m, when the list
    /// holds that pair. The list stores it once, under the lower index, as the first
    /// member's history against the second; the other way round it is the opposite
    /// vector (exactly: negation rounds nothing).
    pub fn history(&self, i: u32, j: u32) -> Option<Vec3> {
        let (first, second, sign) = if i < j { (i, j, 1.0) } else { (j, i, -1.0) };
        let row = self.row_start.get(first as usize..first as usize + 2)?;
        let (start, end) = (row[0] as usize, row[1] as usize);
        let k = self.partner[start..end].binary_search(&second).ok()?;
        Some(sign * self.shear_m[start + k])
    }

    /// Builds the list of pairs within `radius_i + radius_j + skin_m` and carries the
    /// tangential history over from `previous`, whose particle `former[i]` is this
    /// list's particle `i` ([`NEW_PARTICLE`] for a particle `previous` did not have).
    pub fn build(
        grid: &CellGrid,
        positions: &[Vec3],
        radii: &[Real],
        skin_m: Real,
        previous: &PairList,
        former: &[u32],
    ) -> Self {
        let n = positions.len();
        let bins = CellBins::build(grid, positions);
        // Positions and radii in bin order: the loops below run over contiguous slices
        // of them (a cell's members, and each neighbour cell's), not through indices.
        let (bin_positions, bin_radii) = (bins.gather(positions), bins.gather(radii));
        let bin = |cell: usize| {
            let slots = bins.slots(cell);
            let members = &bins.members[slots.clone()];
            (members, &bin_positions[slots.clone()], &bin_radii[slots])
        };
        let within = |xi: Vec3, ri: Real, xj: Vec3, rj: Real| {
            let reach = ri + rj + skin_m;
            (xj - xi).norm_squared() < reach * reach
        };
        // Each pair once: a cell against itself and its 13 "forward" neighbours.
        // Folded into one vector per rayon job; the flattened order is the cell order
        // whatever the number of threads.
        let found: Vec<Vec<(u32, u32)>> = bins
            .occupied
            .par_iter()
            .fold(Vec::new, |mut pairs, &cell| {
                let cell = cell as usize;
                let (members, xs, rs) = bin(cell);
                for (a, ((&i, &xi), &ri)) in members.iter().zip(xs).zip(rs).enumerate() {
                    let later = members[a + 1..].iter().zip(&xs[a + 1..]).zip(&rs[a + 1..]);
                    for ((&j, &xj), &rj) in later {
                        if within(xi, ri, xj, rj) {
                            pairs.push((i, j));
                        }
                    }
                }
                grid.for_each_forward_cell(cell, |other| {
                    let (others, other_xs, other_rs) = bin(other);
                    for ((&i, &xi), &ri) in members.iter().zip(xs).zip(rs) {
                        for ((&j, &xj), &rj) in others.iter().zip(other_xs).zip(other_rs) {
                            if within(xi, ri, xj, rj) {
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
        running_sum(&mut row_start);
        let mut fill = row_start.clone();
        let total = row_start[n] as usize;
        let mut partner = vec![0u32; total];
        for &(i, j) in found.iter().flatten() {
            partner[fill[i as usize] as usize] = j;
            fill[i as usize] += 1;
        }
        let mut shear_m = vec![Vec3::zeros(); total];
        // Sort rows and carry history over from the pair of the same two particles.
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
            let Some(&fi) = former.get(i).filter(|&&f| f != NEW_PARTICLE) else {
                return;
            };
            for (slot, &j) in row.iter().enumerate() {
                let Some(&fj) = former.get(j as usize).filter(|&&f| f != NEW_PARTICLE) else {
                    continue;
                };
                if let Some(history) = previous.history(fi, fj) {
                    shear[slot] = history;
                }
            }
        });
        let mut reverse_count = vec![0u32; n + 1];
        for &j in &partner {
            reverse_count[j as usize + 1] += 1;
        }
        running_sum(&mut reverse_count);
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
            let grid = CellGrid::new(Vec3::zeros(), Vec3::new(0.05, 0.05, 0.05), 0.005);
            let list = PairList::build(&grid, &positions, &radii, 0.001, &PairList::default(), &[]);
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
        /// Sorting along the curve is a permutation, and particles of one cell end up
        /// side by side in ascending index order.
        #[test]
        fn curve_sort_permutes_and_groups_cells(points in proptest::collection::vec((-0.01..0.06f64, 0.0..0.05f64, 0.0..0.05f64), 1..200)) {
            let positions: Vec<Vec3> = points.iter().map(|&(x, y, z)| Vec3::new(x, y, z)).collect();
            let grid = CellGrid::new(Vec3::zeros(), Vec3::new(0.05, 0.05, 0.05), 0.005);
            let curve = CurveOrder::new(&grid);
            let all: Vec<u32> = (0..positions.len() as u32).collect();
            let sorted = curve.sort(&grid, &positions, &all);
            let mut seen = sorted.clone();
            seen.sort_unstable();
            prop_assert_eq!(&seen, &all);
            let cell = |i: u32| grid.index(grid.coords(positions[i as usize]));
            for w in sorted.windows(2) {
                let (a, b) = (cell(w[0]), cell(w[1]));
                prop_assert!(curve.rank[a] < curve.rank[b] || (a == b && w[0] < w[1]));
            }
        }
    }

    #[test]
    fn morton_codes_interleave_the_coordinates_bits() {
        assert_eq!(morton_code([0, 0, 0]), 0);
        assert_eq!(morton_code([1, 0, 0]), 0b001);
        assert_eq!(morton_code([0, 1, 0]), 0b010);
        assert_eq!(morton_code([0, 0, 1]), 0b100);
        assert_eq!(morton_code([3, 0, 0]), 0b001_001);
        assert_eq!(morton_code([2, 3, 1]), 0b011_110);
        // The 21st bit of each coordinate is the code's top three.
        assert_eq!(morton_code([1 << 20, 1 << 20, 1 << 20]), 0b111 << 60);
    }

    #[test]
    fn history_follows_the_particles_across_a_removal_and_a_reordering() {
        let positions = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.0019, 0.0, 0.0),
            Vec3::new(0.0038, 0.0, 0.0),
        ];
        let radii = vec![0.001; 3];
        let grid = CellGrid::new(Vec3::zeros(), Vec3::new(0.01, 0.01, 0.01), 0.003);
        let mut first =
            PairList::build(&grid, &positions, &radii, 0.0005, &PairList::default(), &[]);
        assert_eq!(first.len(), 2);
        first.shear_m[1] = Vec3::new(1e-6, 0.0, 0.0); // pair (1, 2): 1 against 2
        assert_eq!(first.history(2, 1), Some(Vec3::new(-1e-6, 0.0, 0.0)));
        // Particle 0 leaves; particles 1 and 2 are now indices 0 and 1.
        let second = PairList::build(&grid, &positions[1..], &radii[1..], 0.0005, &first, &[1, 2]);
        assert_eq!(second.len(), 1);
        assert_eq!(second.shear_m[0], Vec3::new(1e-6, 0.0, 0.0));
        // They swap places in memory, and a new particle comes first: the pair is now
        // stored the other way round, and so is its history.
        let swapped = [Vec3::new(0.009, 0.009, 0.009), positions[2], positions[1]];
        let third = PairList::build(
            &grid,
            &swapped,
            &radii,
            0.0005,
            &second,
            &[NEW_PARTICLE, 1, 0],
        );
        assert_eq!(third.len(), 1);
        assert_eq!(third.history(1, 2), Some(Vec3::new(-1e-6, 0.0, 0.0)));
        assert_eq!(third.in_contact, [true]);
    }
}
