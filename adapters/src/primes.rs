//! Prime seeds: LIGGGHTS refuses random seeds that are not primes above 10000.

/// The `index`-th prime at or above `10007 + 7919 · seed` (distinct for distinct
/// `(seed, index)` pairs in practice, always prime and above 10000).
pub fn prime_seed(seed: u64, index: u64) -> u64 {
    let mut candidate = 10_007 + 7_919 * (seed % 1_000_000) + 1_009 * index;
    while !is_prime(candidate) {
        candidate += 1;
    }
    candidate
}

fn is_prime(n: u64) -> bool {
    if n < 2 {
        return false;
    }
    let mut d = 2;
    while d * d <= n {
        if n.is_multiple_of(d) {
            return false;
        }
        d += 1;
    }
    true
}

#[cfg(test)]
mod tests {
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
}
