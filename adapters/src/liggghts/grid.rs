//! LIGGGHTS on several MPI ranks: the processor grid a deck's `processors` line gets.
//!
//! LIGGGHTS splits its simulation box into one brick per rank, `px × py × pz` of
//! them, and each rank computes the particles in its brick. Our templates say
//! `processors 1 1 1`, which LIGGGHTS refuses on any other number of ranks, so a deck
//! run on `N` ranks has that line replaced by a grid whose product is `N`.
//!
//! The grid gives each prime factor of `N`, largest first, to the axis whose bricks
//! are then longest (box extent over the bricks along it so far), z before y before x
//! on a tie. Bricks close to cubes have the least surface per volume, so the fewest
//! ghost particles to exchange; and the hopper, whose box is taller than wide, is split
//! along z first (each rank a slab of the column the bed drains down), the chute, long
//! along x, along x first. We write the grid out rather than `processors * * *` so the
//! deck itself says which grid ran.

/// The processor grid `[px, py, pz]` for `cores` ranks in a box of `extent` (m along
/// x, y, z): see the module's documentation. `cores` of 0 counts as 1.
pub fn processor_grid(cores: usize, extent: [f64; 3]) -> [usize; 3] {
    let mut grid = [1usize; 3];
    for factor in prime_factors(cores.max(1)).into_iter().rev() {
        // z first on a tie: iterate z, y, x and keep the first strictly longest.
        let axis = [2, 1, 0]
            .into_iter()
            .fold(None::<usize>, |best, axis| match best {
                Some(b) if brick(extent, grid, b) >= brick(extent, grid, axis) => Some(b),
                _ => Some(axis),
            })
            .unwrap_or(2);
        grid[axis] *= factor;
    }
    grid
}

/// The length of a brick along `axis`, m.
fn brick(extent: [f64; 3], grid: [usize; 3], axis: usize) -> f64 {
    extent[axis] / grid[axis] as f64
}

/// The prime factors of `n`, smallest first, with repeats (`12` → `2, 2, 3`).
fn prime_factors(mut n: usize) -> Vec<usize> {
    let mut factors = Vec::new();
    let mut p = 2;
    while p * p <= n {
        while n.is_multiple_of(p) {
            factors.push(p);
            n /= p;
        }
        p += 1;
    }
    if n > 1 {
        factors.push(n);
    }
    factors
}

/// The deck with its `processors` line(s) set to the grid for `cores` ranks, from the
/// extent of the box its `create_box` names (`region NAME block xlo xhi ylo yhi zlo
/// zhi`). A deck whose box cannot be read gets `processors * * *` (LIGGGHTS chooses);
/// a deck without a `processors` line is left as it is (LIGGGHTS chooses too). With
/// one core the deck is returned unchanged.
pub fn decompose(deck: String, cores: usize) -> String {
    if cores <= 1 || !deck.lines().any(|l| first_word(l) == Some("processors")) {
        return deck;
    }
    let grid = match box_extent(&deck) {
        Some(extent) => {
            let [px, py, pz] = processor_grid(cores, extent);
            format!("{px} {py} {pz}")
        }
        None => "* * *".to_string(),
    };
    let mut out = String::with_capacity(deck.len());
    for line in deck.split_inclusive('\n') {
        if first_word(line) == Some("processors") {
            out.push_str(&format!("processors      {grid}"));
            if line.ends_with('\n') {
                out.push('\n');
            }
        } else {
            out.push_str(line);
        }
    }
    out
}

fn first_word(line: &str) -> Option<&str> {
    line.split_whitespace().next()
}

/// The extent (m along x, y, z) of the block region the deck's `create_box` names.
fn box_extent(deck: &str) -> Option<[f64; 3]> {
    let words = |l: &str| l.split_whitespace().map(str::to_string).collect::<Vec<_>>();
    let region = deck
        .lines()
        .map(words)
        .find(|w| w.first().map(String::as_str) == Some("create_box"))?
        .get(2)?
        .clone();
    let block = deck
        .lines()
        .map(words)
        .find(|w| w.len() >= 9 && w[0] == "region" && w[1] == region && w[2] == "block")?;
    let bound = |i: usize| block[3 + i].parse::<f64>().ok();
    let mut extent = [0.0; 3];
    for (axis, e) in extent.iter_mut().enumerate() {
        *e = bound(2 * axis + 1)? - bound(2 * axis)?;
        if !(*e > 0.0 && e.is_finite()) {
            return None;
        }
    }
    Some(extent)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grids_multiply_to_the_cores_and_split_the_longest_axis_first() {
        let tall = [0.2, 0.2, 0.6];
        assert_eq!(processor_grid(1, tall), [1, 1, 1]);
        assert_eq!(processor_grid(0, tall), [1, 1, 1]);
        assert_eq!(processor_grid(2, tall), [1, 1, 2]);
        assert_eq!(processor_grid(3, tall), [1, 1, 3]);
        // 0.6 / 3 = 0.2 ties x and y: z wins the tie, then y.
        assert_eq!(processor_grid(6, tall), [1, 2, 3]);
        // 0.6 / 2 = 0.3 is still the longest: z again, then y on the tie at 0.2.
        assert_eq!(processor_grid(4, tall), [1, 1, 4]);
        assert_eq!(processor_grid(8, tall), [1, 2, 4]);
        // The chute's box is long along x.
        assert_eq!(processor_grid(2, [1.0, 0.2, 0.4]), [2, 1, 1]);
        assert_eq!(processor_grid(4, [1.0, 0.2, 0.4]), [4, 1, 1]);
        assert_eq!(processor_grid(4, [1.0, 0.2, 0.8]), [2, 1, 2]);
        // A cube: z, then y, then x.
        assert_eq!(processor_grid(2, [1.0; 3]), [1, 1, 2]);
        assert_eq!(processor_grid(4, [1.0; 3]), [1, 2, 2]);
        assert_eq!(processor_grid(7, [1.0; 3]), [1, 1, 7]);
        assert_eq!(processor_grid(8, [1.0; 3]), [2, 2, 2]);
        for n in 1..=64 {
            let [a, b, c] = processor_grid(n, [0.3, 0.5, 0.7]);
            assert_eq!(a * b * c, n, "{n} cores");
        }
    }

    #[test]
    fn prime_factors_repeat_and_keep_large_primes() {
        assert_eq!(prime_factors(1), Vec::<usize>::new());
        assert_eq!(prime_factors(12), [2, 2, 3]);
        assert_eq!(prime_factors(97), [97]);
        assert_eq!(prime_factors(2 * 49), [2, 7, 7]);
    }

    const DECK: &str = "units si\nprocessors      1 1 1\n\nregion domain block -0.1 0.1 -0.1 0.1 -0.05 0.55 units box\ncreate_box 2 domain\nrun 10\n";

    #[test]
    fn one_core_keeps_the_deck_and_more_split_the_tall_box_along_z() {
        assert_eq!(decompose(DECK.to_string(), 1), DECK);
        assert_eq!(
            decompose(DECK.to_string(), 2),
            DECK.replace("processors      1 1 1", "processors      1 1 2")
        );
        assert_eq!(
            decompose(DECK.to_string(), 4),
            DECK.replace("processors      1 1 1", "processors      1 1 4")
        );
    }

    #[test]
    fn decks_without_a_readable_box_let_liggghts_choose() {
        let no_box = DECK.replace("create_box 2 domain", "create_box 2 elsewhere");
        assert_eq!(
            decompose(no_box.clone(), 2),
            no_box.replace("processors      1 1 1", "processors      * * *")
        );
        let no_line = DECK.replace("processors      1 1 1\n", "");
        assert_eq!(decompose(no_line.clone(), 2), no_line);
    }
}
