//! Pruned candidates ([`Options::prune`](super::Options::prune)): the `c x k`
//! candidates of an agent are rolled in stretches of steps, and at each checkpoint of
//! [`PRUNE_SCHEDULE`] only the best of them go on, so most of the candidates stop
//! before the horizon. Best: the furthest projected reach (the steps reached, plus, at
//! checkpoints before [`FLOW_WALK_BEFORE`] of the horizon and for a candidate still
//! going, the steps a walker following the map's likeliest flow from where it is would
//! stay on the map: `flow_walk.rs`), then the highest partial score, ties to the
//! one drawn first. The walks go best-scored first and stop once enough candidates
//! are projected to the horizon to fill the checkpoint (`Lanes::project_reach`).

use glam::DVec2;

use super::Checkpoint;
#[cfg(doc)]
use super::PRUNE_SCHEDULE;
use super::candidates::{Candidates, best};
use super::lanes::{Lanes, finish_sample};
use crate::math::lane_rng::lane_seed;

impl<F: Fn(DVec2) -> Option<usize>> Lanes<'_, F> {
    /// Roll the `scratch.lens.len()` candidates of one agent (their positions in
    /// `scratch.tracks`, `steps` per candidate), pruned at the checkpoints of `schedule`
    /// (as [`PRUNE_SCHEDULE`]): at each the best are kept and each goes on as its
    /// checkpoint's copies (the copies after the kept ones, copy `d` drawing from
    /// [`copy_seed`]`(key, checkpoint, d)`), never more than the buffers hold; no fewer
    /// than `k` are left at the end. The candidates left (their number is returned) are
    /// the first of the scratch buffers, ended and scored ([`finish_sample`]). Unless
    /// `ranked` (the caller keeps the likelihood scores), a last stretch of `k`
    /// candidates is rolled without scores: their scores are then those at the last
    /// checkpoint.
    pub(super) fn roll_pruned<const MOTION: u8>(
        &self,
        key: u64,
        schedule: &[Checkpoint],
        k: usize,
        steps: usize,
        ranked: bool,
        scratch: &mut Candidates,
    ) -> usize {
        let Candidates {
            tracks,
            lens,
            scores,
            order,
            keys,
            lanes,
            reach,
            flow,
            walk_order,
            ..
        } = scratch;
        let room = lens.len();
        let mut m = room;
        let mut from = 0;
        let mut cuts = schedule.iter().enumerate().map(|(c, cut)| {
            let step = ((cut.at * steps as f64).round() as usize).clamp(1, steps.max(2) - 1);
            let walk = cut.at < FLOW_WALK_BEFORE;
            (step, cut.kept(k), walk, cut.copies(), c)
        });
        loop {
            let (to, keep, walk, copies, cut) = loop {
                match cuts.next() {
                    Some((to, ..)) if to <= from || to >= steps => continue,
                    Some(cut) => break cut,
                    None => break (steps, m, false, 1, 0),
                }
            };
            // the last stretch of exactly `k` needs no scores if nothing ranks by them
            let scored = ranked || to < steps || m > k;
            let group = self.stretch_lanes::<MOTION>();
            for g in (0..m).step_by(group) {
                let e = (g + group).min(m);
                let (lanes, lens) = (&mut lanes[g..e], &mut lens[g..e]);
                let tracks = &mut tracks[g * steps..e * steps];
                if scored {
                    self.roll_stretch::<MOTION, true>((key, g), lanes, from, to, tracks, lens);
                } else {
                    self.roll_stretch::<MOTION, false>((key, g), lanes, from, to, tracks, lens);
                }
            }
            if to == steps {
                break;
            }
            if keep < m {
                // the best `keep` go on, in the order they were drawn: by projected
                // reach (how far they got, plus, before FLOW_WALK_BEFORE, how far the
                // flow would take those that reached the checkpoint), then partial score
                for (s, lane) in scores[..m].iter_mut().zip(&lanes[..m]) {
                    *s = lane.score;
                }
                reach.clear();
                reach.extend_from_slice(&lens[..m]);
                if walk {
                    let candidates = (&lanes[..m], &scores[..m]);
                    self.project_reach((to, steps), keep, candidates, reach, walk_order, flow);
                }
                best(reach, &scores[..m], keep, keys, order);
                for (s, &i) in order[..keep].iter().enumerate() {
                    let i = i as usize;
                    if s != i {
                        lanes[s] = lanes[i];
                        lens[s] = lens[i];
                        tracks.copy_within(i * steps..i * steps + to, s * steps);
                    }
                }
                // each kept one goes on as `copies`: the copies after the kept ones,
                // with their paths so far and generators of their own
                m = (keep * copies).min(room);
                for d in keep..m {
                    let s = d % keep;
                    lanes[d] = lanes[s];
                    lanes[d].reseed(copy_seed(key, cut, d));
                    lens[d] = lens[s];
                    tracks.copy_within(s * steps..s * steps + to, d * steps);
                }
            }
            from = to;
        }
        for i in 0..m {
            scores[i] = finish_sample(
                &mut tracks[i * steps..(i + 1) * steps],
                lens[i],
                lanes[i].score,
            );
        }
        m
    }
}

/// The generator of copy `d` made at checkpoint `cut` of the agent of key `key`
/// ([`Lanes::roll_pruned`]): not one a sample starts from.
pub(super) fn copy_seed(key: u64, cut: usize, d: usize) -> [u32; 4] {
    // (the agent's samples start from lane_seed(key, s); a checkpoint's copies from
    // another key, one per checkpoint)
    let salt = (cut as u64 + 1).wrapping_mul(0xd1b5_4a32_d192_ed03);
    lane_seed(key ^ salt, d as u64)
}

/// Checkpoints before this fraction of the horizon rank the candidates by their
/// projected reach with the flow walk (`flow_walk.rs`); later ones by the steps
/// reached alone (a candidate that got that far has shown whether it stays on the map,
/// and the walk predicts less well where the map is small: on THÖR1 a walk at 40 % of
/// the horizon kept samples that then ended, 11 s FDE 2 % above constant velocity's).
pub(super) const FLOW_WALK_BEFORE: f64 = 0.5;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::map::CliffMap;
    use crate::math::Simd;
    use crate::motion::State;
    use crate::predict::PRUNE_SCHEDULE;
    use crate::predict::flow_memo::{FLOW_SLOTS, FlowMemo};
    use crate::predict::lanes::{ANY, Extras, Lane};
    use crate::predict::options::pruned_share;
    use crate::predict::seeds::agent_key;
    use crate::predict::{Params, Point};

    #[test]
    fn the_pruned_share_counts_each_stretch_at_its_candidates() {
        // after a checkpoint, its kept candidates times their copies go on (at least
        // one per kept sample)
        let share = |c: f64| {
            let (mut s, mut from, mut rolling) = (0.0, 0.0, c);
            for cut in PRUNE_SCHEDULE {
                s += (cut.at - from) * rolling;
                let copies = cut.copies as f64;
                (from, rolling) = (cut.at, rolling.min(cut.keep.max(1.0 / copies) * copies));
            }
            s + (1.0 - from) * rolling
        };
        for c in [1, 2, 5, 16] {
            assert!((pruned_share(c) - share(c as f64)).abs() < 1e-12, "{c}");
            assert!(pruned_share(c) <= c as f64 && pruned_share(c) >= 1.0);
        }
        // the preset's 2 candidates: two per kept sample to a fifth, then one
        assert!((pruned_share(2) - (2.0 * 0.2 + 0.8)).abs() < 1e-12);
        assert_eq!(pruned_share(1), 1.0);
    }

    /// The demo map, a walker on it, and the improved preset's extras.
    /// The lanes of [`setup`]'s walker (`near` the map's best-near lookup).
    macro_rules! lanes_of {
        ($map:ident, $near:ident, $state:ident, $params:ident, $extras:ident) => {
            Lanes {
                map: &$map,
                near: &$near,
                state: &$state,
                observed_speed: $state.speed,
                params: &$params,
                extras: &$extras,
                table: None,
            }
        };
    }

    fn setup() -> (CliffMap, State, Params, Extras) {
        let map = CliffMap::demo();
        let state = State {
            position: glam::DVec2::new(-10.0, 0.5),
            speed: 1.2,
            heading: 0.1,
            time: 0.0,
        };
        let params = Params {
            beta: 2.0,
            horizon: 12.0,
            ..Params::default()
        };
        let extras = Extras {
            speed_beta: 0.0,
            coast_steps: 0,
            follow: 4.0,
            candidates: 1,
            prune: true,
            speed_prior: None,
            trust: 0.5,
            blend: 3.0,
            motion: false,
            consensus: false,
            simd: Simd::active(),
        };
        (map, state, params, extras)
    }

    /// Candidates' buffers for `m` candidates of `steps` steps.
    fn scratch(m: usize, steps: usize) -> Candidates {
        Candidates {
            tracks: vec![[0.0; 2]; m * steps],
            lens: vec![0; m],
            scores: vec![0.0; m],
            order: vec![0; m],
            lanes: vec![Lane::default(); m],
            ..Candidates::default()
        }
    }

    fn bits(t: &[Point]) -> Vec<[u32; 2]> {
        t.iter().map(|p| p.map(f32::to_bits)).collect()
    }

    #[test]
    fn stretches_without_a_cut_give_the_whole_rollout_of_one_group() {
        let (map, state, params, extras) = setup();
        let near = |p| map.best_near(p, params.radius);
        let lanes = lanes_of!(map, near, state, params, extras);
        let steps = params.steps();
        for m in [3, 12, 20] {
            let mut whole = scratch(m, steps);
            let key = agent_key(3, 0);
            lanes.roll_agent::<ANY, true>(
                key,
                &mut whole.tracks,
                &mut whole.lens,
                &mut whole.scores,
            );
            // checkpoints that keep every candidate
            let mut pieces = scratch(m, steps);
            let key = agent_key(3, 0);
            let left = lanes.roll_pruned::<ANY>(
                key,
                &[
                    Checkpoint {
                        at: 0.2,
                        keep: 50.0,
                        copies: 1,
                    },
                    Checkpoint {
                        at: 0.5,
                        keep: 50.0,
                        copies: 1,
                    },
                ],
                1,
                steps,
                true,
                &mut pieces,
            );
            assert_eq!(left, m);
            assert_eq!(bits(&pieces.tracks), bits(&whole.tracks), "{m}");
            assert_eq!(pieces.lens, whole.lens);
            assert_eq!(pieces.scores, whole.scores);
            assert!(whole.lens.iter().any(|&l| l as usize > steps / 2));
        }
    }

    /// By hand: `m` candidates of the agent of key `key` rolled to step `cut`, and the
    /// best `n` of them by (projected reach, partial score), in the order drawn; with
    /// how many of them the flow walks project to the horizon.
    fn best_at_cut<F: Fn(DVec2) -> Option<usize>>(
        lanes: &Lanes<'_, F>,
        key: u64,
        m: usize,
        cut: usize,
        n: usize,
    ) -> (Candidates, Vec<usize>, usize) {
        let steps = lanes.params.steps();
        let mut c = scratch(m, steps);
        lanes.roll_stretch::<ANY, true>((key, 0), &mut c.lanes, 0, cut, &mut c.tracks, &mut c.lens);
        // the projected reach: the flow walk from each that reached the cut, all of
        // them, the best-scored first (ties: the one drawn first), one memo
        let mut memo = FlowMemo::default();
        memo.start();
        let mut walkers: Vec<usize> = (0..m).filter(|&i| c.lens[i] as usize == cut).collect();
        walkers.sort_by(|&x, &y| {
            c.lanes[y]
                .score
                .total_cmp(&c.lanes[x].score)
                .then(x.cmp(&y))
        });
        let mut reach: Vec<u32> = c.lens.clone();
        for &i in &walkers {
            reach[i] += lanes.look_ahead(&c.lanes[i], steps - cut, &mut memo);
        }
        let horizon = reach.iter().filter(|&&r| r as usize == steps).count();
        let mut best: Vec<usize> = (0..m).collect();
        best.sort_by(|&x, &y| {
            (reach[y], c.lanes[y].score)
                .partial_cmp(&(reach[x], c.lanes[x].score))
                .unwrap()
                .then(x.cmp(&y))
        });
        best.truncate(n);
        best.sort();
        (c, best, horizon)
    }

    /// By hand: slot `d` takes candidate `picks[d]` of `c` at step `cut` (its generator
    /// replaced by `reseed(d)` where that gives one), and the slots go on to the horizon
    /// and are ended and scored.
    fn on_from_cut<F: Fn(DVec2) -> Option<usize>>(
        lanes: &Lanes<'_, F>,
        key: u64,
        c: &Candidates,
        picks: &[usize],
        reseed: impl Fn(usize) -> Option<[u32; 4]>,
        cut: usize,
    ) -> Candidates {
        let steps = lanes.params.steps();
        let n = picks.len();
        let mut out = scratch(n, steps);
        for (d, &j) in picks.iter().enumerate() {
            out.lanes[d] = c.lanes[j];
            if let Some(rng) = reseed(d) {
                out.lanes[d].reseed(rng);
            }
            out.lens[d] = c.lens[j];
            out.tracks[d * steps..d * steps + cut]
                .copy_from_slice(&c.tracks[j * steps..j * steps + cut]);
        }
        let o = &mut out;
        lanes.roll_stretch::<ANY, true>(
            (key, 0),
            &mut o.lanes,
            cut,
            steps,
            &mut o.tracks,
            &mut o.lens,
        );
        for d in 0..n {
            let t = &mut out.tracks[d * steps..(d + 1) * steps];
            out.scores[d] = finish_sample(t, out.lens[d], out.lanes[d].score);
        }
        out
    }

    #[test]
    fn a_cut_keeps_the_furthest_reaching_then_best_scored_and_they_go_on() {
        let (map, state, params, extras) = setup();
        let near = |p| map.best_near(p, params.radius);
        let lanes = lanes_of!(map, near, state, params, extras);
        let steps = params.steps();
        let (m, k, cut) = (20, 5, 9);
        let mut pruned = scratch(m, steps);
        let key = agent_key(8, 0);
        let at = cut as f64 / steps as f64;
        let once = Checkpoint {
            at,
            keep: 1.0,
            copies: 1,
        };
        let left = lanes.roll_pruned::<ANY>(key, &[once], k, steps, true, &mut pruned);
        assert_eq!(left, k);
        // the same by hand: all candidates to the cut, the best k by (reach, score),
        // every flow walked (the checkpoint stops once k are projected to the horizon)
        let (c, best, horizon) = best_at_cut(&lanes, key, m, cut, k);
        assert!(horizon > k, "{horizon}");
        let kept = on_from_cut(&lanes, key, &c, &best, |_| None, cut);
        assert_eq!(bits(&pruned.tracks[..k * steps]), bits(&kept.tracks));
        assert_eq!(&pruned.lens[..k], &kept.lens[..]);
        assert_eq!(&pruned.scores[..k], &kept.scores[..]);
        // the cut was a choice: some candidates that reached it were left behind
        let reached = c.lens.iter().filter(|&&l| l as usize == cut).count();
        assert!(reached > k, "{reached}");
        assert!(pruned.lens[..k].iter().all(|&l| l as usize >= cut));
    }

    #[test]
    fn a_checkpoint_with_copies_lets_each_kept_candidate_go_on_with_a_generator_of_its_own() {
        let (map, state, params, extras) = setup();
        let near = |p| map.best_near(p, params.radius);
        let lanes = lanes_of!(map, near, state, params, extras);
        let steps = params.steps();
        let (m, k, cut) = (16, 8, 9);
        let twice = Checkpoint {
            at: cut as f64 / steps as f64,
            keep: 0.5,
            copies: 2,
        };
        let key = agent_key(8, 0);
        let mut pruned = scratch(m, steps);
        let left = lanes.roll_pruned::<ANY>(key, &[twice], k, steps, true, &mut pruned);
        assert_eq!(left, k);
        // the same by hand: all to the checkpoint, the best half of k by (projected
        // reach, score), in the order drawn, then each kept one and its copy (after the
        // kept ones, drawing from copy_seed) to the horizon
        let (c, best, _) = best_at_cut(&lanes, key, m, cut, k / 2);
        let picks: Vec<usize> = (0..k).map(|d| best[d % (k / 2)]).collect();
        let copy = |d: usize| (d >= k / 2).then(|| copy_seed(key, 0, d));
        let doubled = on_from_cut(&lanes, key, &c, &picks, copy, cut);
        assert_eq!(bits(&pruned.tracks[..k * steps]), bits(&doubled.tracks));
        assert_eq!(&pruned.lens[..k], &doubled.lens[..]);
        assert_eq!(&pruned.scores[..k], &doubled.scores[..]);
        // a copy shares its original's path to the checkpoint and goes its own way after
        let h = k / 2;
        let apart = (0..h)
            .filter(|&i| pruned.lens[i] as usize > cut && pruned.lens[h + i] as usize > cut)
            .inspect(|&i| {
                let (a, b) = (
                    &pruned.tracks[i * steps..],
                    &pruned.tracks[(h + i) * steps..],
                );
                assert_eq!(bits(&a[..cut]), bits(&b[..cut]), "copy {i}");
            })
            .filter(|&i| {
                let (a, b) = (
                    &pruned.tracks[i * steps..],
                    &pruned.tracks[(h + i) * steps..],
                );
                a[cut..steps] != b[cut..steps]
            })
            .count();
        assert!(
            apart > 0,
            "no copy went past the checkpoint on a path of its own"
        );
    }

    /// A lane of a walker at `(x, y)` heading `heading` on the demo map, one step on
    /// (trust keeps the first step along the observed heading).
    fn walker_lane(x: f64, y: f64, heading: f64) -> (u32, Lane) {
        let (map, _, params, extras) = setup();
        let state = State {
            position: glam::DVec2::new(x, y),
            speed: 1.2,
            heading,
            time: 0.0,
        };
        let near = |p| map.best_near(p, params.radius);
        let lanes = lanes_of!(map, near, state, params, extras);
        let steps = params.steps();
        let mut c = scratch(1, steps);
        let key = agent_key(1, 0);
        lanes.roll_stretch::<ANY, true>((key, 0), &mut c.lanes, 0, 1, &mut c.tracks, &mut c.lens);
        assert_eq!(c.lens[0], 1);
        let mut memo = FlowMemo::default();
        memo.start();
        (
            lanes.look_ahead(&c.lanes[0], steps - 1, &mut memo),
            c.lanes[0],
        )
    }

    #[test]
    fn the_flow_walk_goes_further_along_a_corridor_than_across_it() {
        let steps = setup().2.steps() as u32;
        // east along the east-west corridor (1.2 m/s for 12 s: inside the hall)
        let (along, _) = walker_lane(-10.0, 0.5, 0.0);
        // north out of it, west of the north-south corridor: off the map within metres
        let (across, _) = walker_lane(-10.0, 0.5, std::f64::consts::FRAC_PI_2);
        assert_eq!(along, steps - 1, "{along}");
        assert!(across < 8, "{across}");
    }

    #[test]
    fn a_walk_that_meets_a_state_seen_before_takes_its_count() {
        let (map, state, params, extras) = setup();
        let near = |p| map.best_near(p, params.radius);
        let lanes = lanes_of!(map, near, state, params, extras);
        let (first, lane) = walker_lane(-10.0, 0.5, 0.3);
        let mut memo = FlowMemo::default();
        memo.start();
        let max = params.steps() - 1;
        assert_eq!(lanes.look_ahead(&lane, max, &mut memo), first);
        assert!(!memo.path.is_empty());
        // the same start again: its first state is known, the walk stops at once
        assert_eq!(lanes.look_ahead(&lane, max, &mut memo), first);
        assert!(memo.path.is_empty());
        // a new checkpoint knows nothing
        memo.start();
        assert_eq!(lanes.look_ahead(&lane, max, &mut memo), first);
        assert!(!memo.path.is_empty());
    }

    #[test]
    fn the_flow_memo_answers_right_or_not_at_all_when_full() {
        let mut memo = FlowMemo::default();
        memo.start();
        let n = 3 * FLOW_SLOTS as u32;
        for key in 0..n {
            memo.insert(key * 7, key);
        }
        let mut known = 0;
        for key in 0..n {
            if let Some(v) = memo.get(key * 7) {
                assert_eq!(v, key);
                known += 1;
            }
        }
        assert!(known > FLOW_SLOTS / 2 && known <= FLOW_SLOTS, "{known}");
        memo.start();
        assert!((0..n).all(|key| memo.get(key * 7).is_none()));
    }
}
