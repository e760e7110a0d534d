//! The drawn candidates of one agent ([`Options::candidates`](super::Options::candidates))
//! and their ranking: the furthest reaching first, then the highest score, ties to the
//! one drawn first.

use super::Point;
use super::flow_memo::FlowMemo;
use super::lanes::Lane;
use super::motion::Bend;

/// The drawn candidates of one agent before the best `k` are kept.
#[derive(Debug, Clone, Default)]
pub(super) struct Candidates {
    pub(super) tracks: Vec<Point>,
    pub(super) lens: Vec<u32>,
    pub(super) scores: Vec<f32>,
    pub(super) order: Vec<u32>,
    /// The candidates' [`rank_key`]s, sorted.
    pub(super) keys: Vec<u128>,
    /// Per step: the sums of the samples' x and y, and how many reach it (consensus).
    pub(super) centre: Vec<[f64; 2]>,
    /// The candidates' lanes between the stretches of a pruned rollout.
    pub(super) lanes: Vec<Lane>,
    /// The candidates' projected reach at a checkpoint of a pruned rollout.
    pub(super) reach: Vec<u32>,
    /// The flow walks' shared states at a checkpoint.
    pub(super) flow: FlowMemo,
    /// The order of the flow walks at a checkpoint (scratch).
    pub(super) walk_order: Vec<u64>,
    /// The buffers of the samples' bending towards the motion model
    /// (`Options::motion`).
    pub(super) bend: Bend,
}

thread_local! {
    /// The buffers of the last rollout dropped on this thread ([`Candidates::reuse`]).
    static SPARE: std::cell::Cell<Option<Candidates>> = const { std::cell::Cell::new(None) };
}

/// The largest buffers a thread keeps for its next rollout, in candidates' positions
/// (12 bytes each with their share of the rest; larger ones are freed).
const SPARE_POSITIONS: usize = 1 << 18;

impl Candidates {
    /// Buffers for a new rollout: those the last rollout dropped on this thread left
    /// (grown to its calls' sizes), or empty ones. An in-process call makes a rollout of
    /// its own; with these, calls after the first on a thread allocate nothing.
    pub(super) fn reuse() -> Candidates {
        SPARE.take().unwrap_or_default()
    }

    /// Leave these buffers to the next rollout on this thread ([`reuse`](Self::reuse)),
    /// unless they are larger than [`SPARE_POSITIONS`].
    pub(super) fn spare(self) {
        if self.tracks.capacity() <= SPARE_POSITIONS {
            SPARE.set(Some(self));
        }
    }
}

/// The order key of candidate `i`, which reaches `len` with score `score`: the furthest
/// reaching first, then the highest score (in [`f32::total_cmp`]'s order), then the one
/// drawn first, as one unsigned integer (greater ranks first).
#[inline]
fn rank_key(len: u32, score: f32, i: usize) -> u128 {
    ((len as u128) << 64) | ((score_order(score) as u128) << 32) | (u32::MAX - i as u32) as u128
}

/// A score as an unsigned integer in [`f32::total_cmp`]'s order (negative numbers
/// reversed, below the others).
#[inline]
pub(super) fn score_order(score: f32) -> u32 {
    let b = score.to_bits();
    if b >> 31 == 1 { !b } else { b | 0x8000_0000 }
}

/// The `keep` best of the candidates of reaches `lens` and scores `scores` (as
/// [`rank`] orders them) into `order[..keep]`, in the order they were drawn: a
/// selection of the `keep`-th best key, then the candidates whose keys are at least
/// that one, in a pass in the order drawn (no sort), with `keys` as scratch.
pub(super) fn best(
    lens: &[u32],
    scores: &[f32],
    keep: usize,
    keys: &mut Vec<u128>,
    order: &mut [u32],
) {
    debug_assert!(keep <= lens.len() && keep <= order.len());
    if keep == 0 {
        return;
    }
    fill_keys(lens, scores, keys);
    // (keys are distinct: exactly `keep` of them are at least the `keep`-th best)
    let least = *keys.select_nth_unstable_by(keep - 1, |a, b| b.cmp(a)).1;
    let mut n = 0;
    for (i, (&l, &s)) in lens.iter().zip(scores).enumerate() {
        order[n] = i as u32;
        n += (rank_key(l, s, i) >= least) as usize;
        if n == keep {
            break;
        }
    }
    debug_assert_eq!(n, keep);
}

/// The candidates' [`rank_key`]s, in the order they were drawn, into `keys`.
fn fill_keys(lens: &[u32], scores: &[f32], keys: &mut Vec<u128>) {
    keys.clear();
    keys.extend(
        lens.iter()
            .zip(scores)
            .enumerate()
            .map(|(i, (&l, &s))| rank_key(l, s, i)),
    );
}

/// Order the candidates of reaches `lens` and scores `scores` best first (the furthest
/// reaching, then the highest-scored, ties to the one drawn first) into
/// `order[..lens.len()]`, with `keys` as scratch.
pub(super) fn rank(lens: &[u32], scores: &[f32], keys: &mut Vec<u128>, order: &mut [u32]) {
    fill_keys(lens, scores, keys);
    keys.sort_unstable_by(|a, b| b.cmp(a));
    for (o, &key) in order.iter_mut().zip(keys.iter()) {
        *o = u32::MAX - key as u32;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_best_are_the_first_of_the_ranking_in_the_order_drawn() {
        // reaches with many ties, scores with ties, infinities and both zeros
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let special = [f32::NEG_INFINITY, -0.0, 0.0, -2.5, 7.0];
        let (mut keys, mut a, mut b) = (Vec::new(), vec![0u32; 80], vec![0u32; 80]);
        for m in [1, 2, 7, 20, 40, 80] {
            for _ in 0..50 {
                let lens: Vec<u32> = (0..m).map(|_| (next() % 4) as u32 * 10).collect();
                let scores: Vec<f32> = (0..m)
                    .map(|_| match next() % 3 {
                        0 => special[(next() % 5) as usize],
                        _ => (next() % 1000) as f32 * -0.37,
                    })
                    .collect();
                rank(&lens, &scores, &mut keys, &mut a);
                for keep in [1, m / 2, m] {
                    if keep == 0 {
                        continue;
                    }
                    best(&lens, &scores, keep, &mut keys, &mut b);
                    let mut first = a[..keep].to_vec();
                    first.sort_unstable();
                    assert_eq!(first, b[..keep], "m {m}, keep {keep}");
                }
            }
        }
    }
}
