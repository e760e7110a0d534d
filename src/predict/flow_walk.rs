//! The flow walks that project a pruned candidate's reach at a checkpoint
//! ([`Lanes::project_reach`], called by `prune.rs`): from where a candidate is, a
//! walker follows the map's likeliest flow without the draws' noise, and the steps it
//! stays near the map are what the candidate is projected to gain. The walks of one
//! checkpoint share their ends ([`FlowMemo`]).

use glam::DVec2;

use super::candidates::score_order;
use super::flow_memo::{FlowMemo, flow_bin, flow_key, flow_key_of};
use super::lanes::{Lane, Lanes};
use crate::math::fastmath::{acos_f32_with, exp_neg_f32};
use crate::math::simd::Separate;

/// Walkers started side by side ([`Lanes::project_reach`]).
const WALKERS: usize = 8;

/// Where a flow walker is: its position, heading (a unit vector), location (if it is
/// near the map) and the key of its state ([`flow_key`], if it has a location).
#[derive(Debug, Clone, Copy)]
struct Walker {
    p: DVec2,
    h: [f32; 2],
    loc: Option<usize>,
    key: Option<u32>,
}

impl<F: Fn(DVec2) -> Option<usize>> Lanes<'_, F> {
    /// The projected reach at checkpoint step `to` of `steps`, where the best `keep`
    /// candidates go on: `reach` holds the steps each candidate reached, and those that
    /// reached the checkpoint gain the steps their flow walk stays on the map
    /// ([`walk_from`](Self::walk_from), one memo for the checkpoint). They walk
    /// best-scored first (ties: the one drawn first) and stop once `keep` of them are
    /// projected to the horizon: a candidate not walked could not rank above those (its
    /// reach would be no further, its score is lower), so it keeps the steps it reached.
    /// `order` is scratch.
    pub(super) fn project_reach(
        &self,
        (to, steps): (usize, usize),
        keep: usize,
        (lanes, scores): (&[Lane], &[f32]),
        reach: &mut [u32],
        order: &mut Vec<u64>,
        memo: &mut FlowMemo,
    ) {
        memo.start();
        // those that reached the checkpoint (no candidate gets further), best-scored
        // first, ties to the one drawn first
        order.clear();
        order.extend(
            reach
                .iter()
                .zip(scores)
                .enumerate()
                .filter(|(_, (r, _))| **r as usize == to)
                .map(|(i, (_, &s))| (score_order(s) as u64) << 32 | (u32::MAX - i as u32) as u64),
        );
        order.sort_unstable_by(|a, b| b.cmp(a));
        let max = steps - to;
        let mut horizon = 0;
        // the walkers start eight at a time: their heading bins side by side, off the
        // walks' chains (most walks stop at their first state)
        let index = |o: u64| (u32::MAX - o as u32) as usize;
        let mut starts = [None; WALKERS];
        for batch in order.chunks(WALKERS) {
            self.walkers(batch.iter().map(|&o| &lanes[index(o)]), &mut starts);
            for (&o, &start) in batch.iter().zip(&starts) {
                let i = index(o);
                let ahead = self.walk_from(start, max, memo);
                reach[i] += ahead;
                if ahead as usize == max {
                    horizon += 1;
                    if horizon == keep {
                        return;
                    }
                }
            }
        }
    }

    /// The walker at the state of each of `lanes` (at most [`WALKERS`]) and the distance
    /// it moves per step into `out` (`None`: the sample has stopped), their keys' heading
    /// bins computed side by side.
    #[inline]
    fn walkers<'l>(
        &self,
        lanes: impl Iterator<Item = &'l Lane>,
        out: &mut [Option<(Walker, f64)>; WALKERS],
    ) {
        let (mut hx, mut hy) = ([1.0f32; WALKERS], [0.0f32; WALKERS]);
        let mut n = 0;
        for (lane, out) in lanes.zip(out.iter_mut()) {
            *out = self.walker_without_key(lane);
            if let Some((w, _)) = out {
                [hx[n], hy[n]] = w.h;
            }
            n += 1;
        }
        let mut bins = [0u32; WALKERS];
        for l in 0..WALKERS {
            bins[l] = flow_bin(hx[l], hy[l]);
        }
        for (w, bin) in out[..n].iter_mut().zip(bins) {
            if let Some((w, _)) = w {
                w.key = w.loc.map(|l| flow_key_of(l, bin));
            }
        }
    }

    /// The walker at the state of the sample in `lane` without its key, and the distance
    /// it moves per step (`None`: the sample has stopped).
    #[inline(always)]
    fn walker_without_key(&self, lane: &Lane) -> Option<(Walker, f64)> {
        let (alive, p, h, speed) = lane.motion();
        if !alive {
            return None;
        }
        // (the lane loop looked the position up: its answer again, without the lookup)
        let loc = lane.location().or_else(|| (self.near)(p));
        debug_assert_eq!(loc, (self.near)(p));
        let key = None;
        Some((Walker { p, h, loc, key }, speed * self.params.dt))
    }

    /// Where one step takes walker `w`: turned towards its location's likeliest flow (if
    /// it has a location) by the heading kernel's weight, moved `d`, and looked up.
    #[inline]
    fn walk_step(&self, w: &Walker, d: f64) -> Walker {
        let (beta, kappa) = (self.params.beta as f32, self.extras.follow as f32);
        let [mut hx, mut hy] = w.h;
        if let Some(l) = w.loc {
            let (mx, my) = self.map.follow_mode(l, hx, hy, kappa);
            let delta = acos_f32_with::<Separate>((mx * hx + my * hy).clamp(-1.0, 1.0));
            let lambda = exp_neg_f32(-beta * delta * delta);
            let (vx, vy) = (
                lambda * mx + (1.0 - lambda) * hx,
                lambda * my + (1.0 - lambda) * hy,
            );
            let norm = (vx * vx + vy * vy).sqrt();
            if norm > 1e-6 {
                (hx, hy) = (vx / norm, vy / norm);
            }
        }
        let p = w.p + DVec2::new(hx as f64, hy as f64) * d;
        let loc = (self.near)(p);
        Walker {
            p,
            h: [hx, hy],
            loc,
            key: loc.map(|l| flow_key(l, hx, hy)),
        }
    }

    /// [`walk_from`](Self::walk_from) the walker at the state of the sample in `lane`,
    /// one sample at a time.
    #[cfg(test)]
    pub(super) fn look_ahead(&self, lane: &Lane, max: usize, memo: &mut FlowMemo) -> u32 {
        let start = self.walker_without_key(lane).map(|(mut w, d)| {
            w.key = w.loc.map(|l| flow_key(l, w.h[0], w.h[1]));
            (w, d)
        });
        self.walk_from(start, max, memo)
    }

    /// How many of the next `max` steps a sample would stay near the map if it followed
    /// the map's likeliest flow from where it is: a walker that starts as `start` (the
    /// sample's position, heading and speed, its state's key, and the distance it moves
    /// per step; `None`: the sample has stopped) and at each step turns towards the mean
    /// direction of its location's likeliest component for its heading
    /// ([`CliffMap::follow_mode`](crate::map::CliffMap::follow_mode), with the call's
    /// follow concentration) by the heading kernel's weight, as a sample would without
    /// the noise of the draws. The walks of one checkpoint share their ends: a walk that
    /// comes to a location with a heading (in [`FLOW_BINS`](super::flow_memo::FLOW_BINS)
    /// bins) that an earlier walk of the checkpoint passed stops there and takes that
    /// walk's count ([`FlowMemo`]), so most walks take a few steps; its own states are
    /// then remembered with theirs.
    #[inline(always)]
    fn walk_from(&self, start: Option<(Walker, f64)>, max: usize, memo: &mut FlowMemo) -> u32 {
        let Some((mut w, d)) = start else {
            return 0;
        };
        memo.path.clear();
        // steps walked, and what the rest of the walk is worth (a state seen before)
        let mut n = 0usize;
        let mut rest = None;
        while n < max {
            if let Some(key) = w.key {
                if let Some(v) = memo.get(key) {
                    rest = Some(v);
                    break;
                }
                memo.path.push(key);
            }
            let next = self.walk_step(&w, d);
            if next.loc.is_none() {
                break;
            }
            n += 1;
            w = next;
        }
        // the path's states, each worth the steps from it to the walk's end (or to the
        // end of the state it met); a walk that reached `max` counts as never ending
        let end = match rest {
            Some(v) => (n as u64 + v as u64).min(u32::MAX as u64),
            None if n >= max => u32::MAX as u64,
            None => n as u64,
        };
        for i in 0..memo.path.len() {
            let v = if end == u32::MAX as u64 {
                u32::MAX
            } else {
                (end - i as u64) as u32
            };
            memo.insert(memo.path[i], v);
        }
        end.min(max as u64) as u32
    }
}
