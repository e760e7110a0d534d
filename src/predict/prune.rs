//! Pruned candidates ([`Options::prune`](super::Options::prune)): the `c x k`
//! candidates of an agent are rolled in stretches of steps, and at each checkpoint of
//! [`PRUNE_SCHEDULE`] only the best of them go on (those that reach furthest, then the
//! highest partial score, ties to the one drawn first), so most of the candidates stop
//! before the horizon.

use glam::DVec2;

#[cfg(doc)]
use super::PRUNE_SCHEDULE;
use super::candidates::{Candidates, rank};
use super::lanes::{Lanes, MAX_LANES, finish_sample};

impl<F: Fn(DVec2) -> Option<usize>> Lanes<'_, F> {
    /// Roll the `scratch.lens.len()` candidates of one agent (their positions in
    /// `scratch.tracks`, `steps` per candidate), pruned at the checkpoints of `schedule`
    /// (as [`PRUNE_SCHEDULE`]) down to no fewer than `k`; the candidates left (their number is
    /// returned) are the first of the scratch buffers, in the order they were drawn,
    /// ended and scored ([`finish_sample`]). Unless `ranked` (the caller keeps the
    /// likelihood scores), a last stretch of `k` candidates is rolled without scores:
    /// their scores are then those at the last checkpoint.
    pub(super) fn roll_pruned<const MOTION: u8>(
        &self,
        key: u64,
        schedule: &[(f64, f64)],
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
            ..
        } = scratch;
        let mut m = lens.len();
        let mut from = 0;
        let mut cuts = schedule.iter().map(|&(at, keep)| {
            let step = ((at * steps as f64).round() as usize).clamp(1, steps.max(2) - 1);
            (step, ((keep * k as f64).ceil() as usize).max(k))
        });
        loop {
            let (to, keep) = loop {
                match cuts.next() {
                    Some((to, _)) if to <= from || to >= steps => continue,
                    Some(cut) => break cut,
                    None => break (steps, m),
                }
            };
            // the last stretch of exactly `k` needs no scores if nothing ranks by them
            let scored = ranked || to < steps || m > k;
            for g in (0..m).step_by(MAX_LANES) {
                let e = (g + MAX_LANES).min(m);
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
                // the best `keep` go on, in the order they were drawn
                for (s, lane) in scores[..m].iter_mut().zip(&lanes[..m]) {
                    *s = lane.score;
                }
                rank(&lens[..m], &scores[..m], keys, order);
                let order = &mut order[..keep];
                order.sort_unstable();
                for (s, &i) in order.iter().enumerate() {
                    let i = i as usize;
                    if s != i {
                        lanes[s] = lanes[i];
                        lens[s] = lens[i];
                        tracks.copy_within(i * steps..i * steps + to, s * steps);
                    }
                }
                m = keep;
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::map::CliffMap;
    use crate::math::Simd;
    use crate::motion::State;
    use crate::predict::PRUNE_SCHEDULE;
    use crate::predict::lanes::{ANY, Extras, Lane};
    use crate::predict::options::pruned_share;
    use crate::predict::seeds::agent_key;
    use crate::predict::{Params, Point};

    #[test]
    fn the_pruned_share_counts_each_stretch_at_its_candidates() {
        let share = |c: f64| {
            let (mut s, mut from, mut rolling) = (0.0, 0.0, c);
            for &(at, keep) in PRUNE_SCHEDULE {
                s += (at - from) * rolling;
                (from, rolling) = (at, rolling.min(keep));
            }
            s + (1.0 - from) * rolling
        };
        for c in [1, 2, 5, 16] {
            assert!((pruned_share(c) - share(c as f64)).abs() < 1e-12, "{c}");
            assert!(pruned_share(c) <= c as f64 && pruned_share(c) >= 1.0);
        }
        assert_eq!(pruned_share(1), 1.0);
    }

    /// The demo map, a walker on it, and the improved preset's extras.
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
        let lanes = Lanes {
            map: &map,
            near: &near,
            state: &state,
            observed_speed: state.speed,
            params: &params,
            extras: &extras,
            table: None,
        };
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
                &[(0.2, 50.0), (0.5, 50.0)],
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

    #[test]
    fn a_cut_keeps_the_furthest_reaching_then_best_scored_and_they_go_on() {
        let (map, state, params, extras) = setup();
        let near = |p| map.best_near(p, params.radius);
        let lanes = Lanes {
            map: &map,
            near: &near,
            state: &state,
            observed_speed: state.speed,
            params: &params,
            extras: &extras,
            table: None,
        };
        let steps = params.steps();
        let (m, k, cut) = (20, 5, 9);
        let mut pruned = scratch(m, steps);
        let key = agent_key(8, 0);
        let at = cut as f64 / steps as f64;
        let left = lanes.roll_pruned::<ANY>(key, &[(at, 1.0)], k, steps, true, &mut pruned);
        assert_eq!(left, k);
        // the same by hand: all candidates to the cut, the best k by (reach, score)
        let mut by_hand = scratch(m, steps);
        let key = agent_key(8, 0);
        let c = &mut by_hand;
        let c_lanes = &mut c.lanes;
        lanes.roll_stretch::<ANY, true>((key, 0), c_lanes, 0, cut, &mut c.tracks, &mut c.lens);
        let mut best: Vec<usize> = (0..m).collect();
        best.sort_by(|&x, &y| {
            (c.lens[y], c.lanes[y].score)
                .partial_cmp(&(c.lens[x], c.lanes[x].score))
                .unwrap()
                .then(x.cmp(&y))
        });
        best.truncate(k);
        best.sort();
        let mut kept = scratch(k, steps);
        for (s, &i) in best.iter().enumerate() {
            kept.lanes[s] = c.lanes[i];
            kept.lens[s] = c.lens[i];
            kept.tracks[s * steps..s * steps + cut]
                .copy_from_slice(&c.tracks[i * steps..i * steps + cut]);
        }
        let kc = &mut kept;
        lanes.roll_stretch::<ANY, true>(
            (key, 0),
            &mut kc.lanes,
            cut,
            steps,
            &mut kc.tracks,
            &mut kc.lens,
        );
        for s in 0..k {
            let t = &mut kept.tracks[s * steps..(s + 1) * steps];
            kept.scores[s] = finish_sample(t, kept.lens[s], kept.lanes[s].score);
        }
        assert_eq!(bits(&pruned.tracks[..k * steps]), bits(&kept.tracks));
        assert_eq!(&pruned.lens[..k], &kept.lens[..]);
        assert_eq!(&pruned.scores[..k], &kept.scores[..]);
        // the cut was a choice: some candidates that reached it were left behind
        let reached = c.lens.iter().filter(|&&l| l as usize == cut).count();
        assert!(reached > k, "{reached}");
        assert!(pruned.lens[..k].iter().all(|&l| l as usize >= cut));
    }
}
