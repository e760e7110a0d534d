//! The drawn candidates of one agent ([`Options::candidates`](super::Options::candidates))
//! and their ranking: the furthest reaching first, then the highest score, ties to the
//! one drawn first.

use super::Point;
use super::flow_memo::FlowMemo;
use super::lanes::Lane;

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
    pub(super) centre: Vec<[f64; 3]>,
    /// The candidates' lanes between the stretches of a pruned rollout.
    pub(super) lanes: Vec<Lane>,
    /// The candidates' projected reach at a checkpoint of a pruned rollout.
    pub(super) reach: Vec<u32>,
    /// The flow walks' shared states at a checkpoint.
    pub(super) flow: FlowMemo,
}

/// The order key of candidate `i`, which reaches `len` with score `score`: the furthest
/// reaching first, then the highest score (in [`f32::total_cmp`]'s order), then the one
/// drawn first, as one unsigned integer (greater ranks first).
#[inline]
fn rank_key(len: u32, score: f32, i: usize) -> u128 {
    let b = score.to_bits();
    // total_cmp's order as an unsigned one: negative numbers reversed, below the others
    let s = if b >> 31 == 1 { !b } else { b | 0x8000_0000 };
    ((len as u128) << 64) | ((s as u128) << 32) | (u32::MAX - i as u32) as u128
}

/// Order the candidates of reaches `lens` and scores `scores` best first (the furthest
/// reaching, then the highest-scored, ties to the one drawn first) into
/// `order[..lens.len()]`, with `keys` as scratch.
pub(super) fn rank(lens: &[u32], scores: &[f32], keys: &mut Vec<u128>, order: &mut [u32]) {
    keys.clear();
    keys.extend(
        lens.iter()
            .zip(scores)
            .enumerate()
            .map(|(i, (&l, &s))| rank_key(l, s, i)),
    );
    keys.sort_unstable_by(|a, b| b.cmp(a));
    for (o, &key) in order.iter_mut().zip(keys.iter()) {
        *o = u32::MAX - key as u32;
    }
}
