//! Prime seeds: LIGGGHTS refuses random seeds that are not primes above 10000, and
//! reads them into a C `int`, so they lie in `[10007, 2^31)`.

/// The smallest prime a seed may start its search from.
const FIRST: u64 = 10_007;

/// Width of the range a seed's search starts in: below 2^31 with room for the search
/// (prime gaps below 2^31 are at most 292) and a few indices.
const SPAN: u64 = (1 << 31) - FIRST - 100_000;

/// The `index`-th prime of a deck seeded `seed`. Each index starts its search at its
/// own point of `[10007, 2^31 − 10^5)`, chosen by a SplitMix64 mix of the whole 64-bit
/// `seed` and the index, so the streams of one deck start far apart (LIGGGHTS's
/// Park–Miller generator turns nearby seeds into nearby first numbers); a prime an
/// earlier index of the deck already took moves on to the next prime, so the seeds of
/// one deck are distinct. Two decks' seeds share nothing but chance (about one pair in
/// 10^8).
pub fn prime_seed(seed: u64, index: u64) -> u64 {
    let mut taken = Vec::with_capacity(index as usize + 1);
    for k in 0..=index {
        let mixed = splitmix64(splitmix64(seed).wrapping_add(k));
        let mut prime = next_prime(FIRST + mixed % SPAN);
        while taken.contains(&prime) {
            prime = next_prime(prime + 1);
        }
        taken.push(prime);
    }
    taken[index as usize]
}

/// SplitMix64's finaliser (Steele, Lea & Flood 2014): every input bit moves about half
/// the output bits.
fn splitmix64(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The smallest prime at or above `n`.
fn next_prime(mut n: u64) -> u64 {
    while !is_prime(n) {
        n += 1;
    }
    n
}

fn is_prime(n: u64) -> bool {
    if n < 2 {
        return false;
    }
    if n.is_multiple_of(2) {
        return n == 2;
    }
    let mut d = 3;
    while d * d <= n {
        if n.is_multiple_of(d) {
            return false;
        }
        d += 2;
    }
    true
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    #[test]
    fn seeds_are_primes_above_ten_thousand_and_distinct() {
        let seeds: Vec<u64> = (0..5)
            .flat_map(|s| (0..4).map(move |i| prime_seed(s, i)))
            .collect();
        assert!(seeds.iter().all(|&p| p > 10_000 && is_prime(p)));
        let mut unique = seeds.clone();
        unique.sort_unstable();
        unique.dedup();
        assert_eq!(unique.len(), seeds.len());
    }

    #[test]
    fn seeds_that_differ_by_a_multiple_of_a_million_get_different_primes() {
        // Earlier versions took `seed % 10^6`: a later round's offset of 10^8 vanished.
        assert_ne!(prime_seed(7_002_021, 0), prime_seed(107_002_021, 0));
        assert_ne!(prime_seed(1, 0), prime_seed(1 + (1 << 40), 0));
    }

    #[test]
    fn primality_agrees_with_a_sieve() {
        let n = 20_000;
        let mut composite = vec![false; n + 1];
        for d in 2..=n {
            for multiple in (2 * d..=n).step_by(d) {
                composite[multiple] = true;
            }
        }
        for (k, &c) in composite.iter().enumerate().skip(2) {
            assert_eq!(is_prime(k as u64), !c, "{k}");
        }
    }

    proptest! {
        #[test]
        fn every_seed_is_a_prime_a_c_int_holds_and_a_decks_seeds_are_distinct(seed in any::<u64>()) {
            let primes: Vec<u64> = (0..4).map(|i| prime_seed(seed, i)).collect();
            for (i, &p) in primes.iter().enumerate() {
                prop_assert!(is_prime(p) && p > 10_000 && p < (1 << 31), "{p}");
                prop_assert!(!primes[..i].contains(&p));
            }
        }
    }
}
