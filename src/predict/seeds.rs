//! Where an agent's draws come from: a key per agent, from the call's seed and the
//! agent's place in the call, and from it a generator per sample
//! (`crate::math::lane_rng::lane_seed`).

use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

/// The key of agent `index` of a call seeded with `seed`: the first word of
/// [`agent_rng`]`(seed, index)`. Sample `s` of the agent draws from
/// `lane_seed(key, s)`.
pub(super) fn agent_key(seed: u64, index: u64) -> u64 {
    agent_rng(seed, index).next_u64()
}

/// The generator agent `index` of a call seeded with `seed` draws from: agent 0 from
/// `Xoshiro256PlusPlus::seed_from_u64(seed)` (a one-agent call draws as it always
/// has), agent `i > 0` from the seed mixed with `i` (splitmix64's finaliser). An agent's
/// samples so depend on the seed, its state and its place in the call alone: chunks of
/// a call, and agents predicted on other threads or daemon workers, give the bytes of
/// one call on one thread.
pub(super) fn agent_rng(seed: u64, index: u64) -> Xoshiro256PlusPlus {
    if index == 0 {
        return Xoshiro256PlusPlus::seed_from_u64(seed);
    }
    let mut z = seed ^ index.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    Xoshiro256PlusPlus::seed_from_u64(z ^ (z >> 31))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_agent_draws_from_the_seed_and_the_others_apart() {
        let first = |r: &mut Xoshiro256PlusPlus| r.next_u64();
        let seeded = first(&mut Xoshiro256PlusPlus::seed_from_u64(42));
        assert_eq!(first(&mut agent_rng(42, 0)), seeded);
        let words: Vec<u64> = (0..1000).map(|i| first(&mut agent_rng(42, i))).collect();
        let mut unique = words.clone();
        unique.sort_unstable();
        unique.dedup();
        assert_eq!(unique.len(), words.len());
        assert_ne!(first(&mut agent_rng(43, 1)), first(&mut agent_rng(42, 1)));
    }
}
