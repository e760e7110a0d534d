//! The options of `improved` on AVX2 + FMA, eight samples to a register: the lane
//! loop's `ANY` flavour where it follows the map's flows ([`Options::follow`]), with
//! trust, blend and scores as the options say, and neither the speed kernel nor
//! coasting (the `improved` preset's step). Written with intrinsics like the paper's
//! loop (`lanes_avx2.rs`): the generators, the follow weights and the component choice
//! (slot by slot, each lane's blocks loaded whole and transposed:
//! [`CliffMap::lane_following8`]), the heading kernel, the
//! headings' angles and densities for the scores (`CliffMap::step_log_density8`) and
//! the map lookups run on eight lanes at once. It gives the bits of the generic loop's AVX2
//! copy (`Lanes::roll_body` with fused multiply-adds): the same draws, weights, turns,
//! scores, positions and lookups, for whole rollouts and for the stretches of a pruned
//! one.
//!
//! [`Options::follow`]: super::Options::follow
//! [`CliffMap::lane_following8`]: crate::map::CliffMap

use std::arch::x86_64::*;

use glam::DVec2;

use super::lanes::{ANY, Lane, LaneState, Lanes, PACK};
use super::lanes_avx2::{advance8, go_on8, step_scores8, turn_v};
use super::{HeadingRule, Point};
use crate::map::{NeighbourTable, lane_mask};
use crate::math::fastmath;
use crate::math::lane_rng::{next8, normal8, unit8};

impl<F: Fn(DVec2) -> Option<usize>> Lanes<'_, F> {
    /// Whether [`roll_options_avx2`](Self::roll_options_avx2) rolls this call's groups
    /// of the lane-loop flavour `MOTION`: the `ANY` flavour with follow on a map whose
    /// follow weights fit and whose lane tables have a width, the heading rule
    /// `CircularMean`, and neither the speed kernel nor coasting.
    pub(super) fn options_avx2_fits<const MOTION: u8>(&self) -> bool {
        let (map, extras) = (self.map, self.extras);
        MOTION == ANY
            && self.params.heading == HeadingRule::CircularMean
            && extras.follow > 0.0
            && extras.speed_beta == 0.0
            && extras.coast_steps == 0
            && map.follow_weights_fit()
            && map.lane_width().is_some()
    }

    /// [`roll_stretch`](Self::roll_stretch) of a group of 21 to 24 samples (where
    /// [`stretch_lanes`](Self::stretch_lanes) makes them): the lanes from `lanes` (or
    /// the agent's start at step 0, the samples numbered from `first`), steps
    /// `from..to` in this loop, the lanes stored back.
    pub(super) fn roll_stretch24<const SCORES: bool>(
        &self,
        (key, first): (u64, usize),
        lanes: &mut [Lane],
        (from, to): (usize, usize),
        tracks: &mut [Point],
        lens: &mut [u32],
    ) {
        let n = lens.len();
        assert!(n <= PACK && self.stretch_lanes::<ANY>() == PACK);
        let table = self.table.expect("a neighbour table (stretch_lanes)");
        let mut st = if from > 0 {
            LaneState::<PACK>::load(lanes)
        } else {
            lens.fill(0);
            self.start::<PACK, ANY>(n, key, first)
        };
        // SAFETY: `stretch_lanes` chose this loop: AVX2 and FMA are the rollout's path
        // (available), the options fit, and `table` is the table `near` answers from.
        unsafe { self.roll_options_avx2::<PACK, SCORES>(table, &mut st, (from, to), tracks, lens) };
        st.store(lanes);
    }

    /// Steps `from..to` of the `lens.len()` samples of one group (at most `N`, at most
    /// 24) from the lanes `st`, which it updates, as the generic loop's AVX2 copy does
    /// (`roll_body::<N, ANY, SCORES, Fused>`): the positions of the lanes that go on
    /// written to `tracks` (`steps` per sample), their lengths to `lens`, with `SCORES`
    /// their steps' log-densities added to their scores. (Unlike the generic loop it
    /// also writes the positions of the samples that have stopped, past their lengths:
    /// ending a sample makes those NaN.)
    ///
    /// # Safety
    /// The processor must have AVX2 and FMA, [`options_avx2_fits`](Self::options_avx2_fits)
    /// must hold, and `table` be the table `near` answers from.
    #[target_feature(enable = "avx2,fma")]
    #[inline(never)]
    pub(super) unsafe fn roll_options_avx2<const N: usize, const SCORES: bool>(
        &self,
        table: &NeighbourTable,
        st: &mut LaneState<N>,
        (from, to): (usize, usize),
        tracks: &mut [Point],
        lens: &mut [u32],
    ) {
        debug_assert!(N <= PACK && lens.len() <= N);
        // SAFETY: as this function requires.
        unsafe {
            match N.div_ceil(8) {
                1 => self.options_steps::<N, 1, SCORES>(table, st, (from, to), tracks, lens),
                2 => self.options_steps::<N, 2, SCORES>(table, st, (from, to), tracks, lens),
                _ => self.options_steps::<N, 3, SCORES>(table, st, (from, to), tracks, lens),
            }
        }
    }

    /// [`roll_options_avx2`](Self::roll_options_avx2) in `V` registers (`8 V >= N`).
    ///
    /// # Safety
    /// As [`roll_options_avx2`](Self::roll_options_avx2).
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn options_steps<const N: usize, const V: usize, const SCORES: bool>(
        &self,
        table: &NeighbourTable,
        st: &mut LaneState<N>,
        (from, to): (usize, usize),
        tracks: &mut [Point],
        lens: &mut [u32],
    ) {
        let Lanes {
            map,
            state,
            observed_speed,
            params,
            extras,
            ..
        } = *self;
        let n = lens.len();
        let steps = tracks.len() / n.max(1);
        let width = map.lane_width().expect("lane tables with a width");
        let dt = params.dt;
        let follow = extras.follow as f32;
        let (trusting, blend) = (extras.trust > 0.0, extras.blend > 0.0);
        let neg_beta = _mm256_set1_ps(-(params.beta as f32));
        let (s0, c0) = fastmath::sin_cos(crate::math::wrap_2pi(state.heading));

        // The lanes, padded to 8 V (the padding dead, at lane 0's place).
        let pad = |l: usize| if l < N { l } else { 0 };
        let mut alive_bits = 0u32;
        let px: [f64; PACK] = std::array::from_fn(|l| st.px[pad(l)]);
        let py: [f64; PACK] = std::array::from_fn(|l| st.py[pad(l)]);
        let ux: [f32; PACK] = std::array::from_fn(|l| st.ux[pad(l)]);
        let uy: [f32; PACK] = std::array::from_fn(|l| st.uy[pad(l)]);
        let speed: [f64; PACK] = std::array::from_fn(|l| st.speed[pad(l)]);
        let loc: [i32; PACK] = std::array::from_fn(|l| st.loc[pad(l)] as i32);
        let score: [f32; PACK] = std::array::from_fn(|l| if l < N { st.score[l] } else { 0.0 });
        let len: [u32; PACK] = std::array::from_fn(|l| if l < n { lens[l] } else { 0 });
        for l in 0..N {
            alive_bits |= (st.alive[l] as u32) << l;
        }
        // (lanes past the group's samples are dead: the live ones are all samples)
        debug_assert_eq!(alive_bits >> n, 0);
        let rng_words: [[u32; PACK]; 4] = std::array::from_fn(|w| {
            std::array::from_fn(|l| if l < N { st.rng.s[w][l] } else { 0 })
        });

        // SAFETY (the loads): the arrays hold 8 V <= PACK lanes.
        let load_pd = |a: &[f64; PACK], o: usize| unsafe { _mm256_loadu_pd(a.as_ptr().add(o)) };
        let load_ps = |a: &[f32; PACK], o: usize| unsafe { _mm256_loadu_ps(a.as_ptr().add(o)) };
        let load_i =
            |a: *const u32, o: usize| unsafe { _mm256_loadu_si256(a.add(o) as *const __m256i) };
        let mut px: [[__m256d; 2]; V] =
            std::array::from_fn(|v| [load_pd(&px, 8 * v), load_pd(&px, 8 * v + 4)]);
        let mut py: [[__m256d; 2]; V] =
            std::array::from_fn(|v| [load_pd(&py, 8 * v), load_pd(&py, 8 * v + 4)]);
        let mut speed: [[__m256d; 2]; V] =
            std::array::from_fn(|v| [load_pd(&speed, 8 * v), load_pd(&speed, 8 * v + 4)]);
        let mut ux: [__m256; V] = std::array::from_fn(|v| load_ps(&ux, 8 * v));
        let mut uy: [__m256; V] = std::array::from_fn(|v| load_ps(&uy, 8 * v));
        let mut score: [__m256; V] = std::array::from_fn(|v| load_ps(&score, 8 * v));
        let mut loc: [__m256i; V] =
            std::array::from_fn(|v| load_i(loc.as_ptr() as *const u32, 8 * v));
        let mut len: [__m256i; V] = std::array::from_fn(|v| load_i(len.as_ptr(), 8 * v));
        let mut alive: [__m256i; V] = std::array::from_fn(|v| lane_mask(alive_bits >> (8 * v)));
        let mut rng: [[__m256i; 4]; V] =
            std::array::from_fn(|v| std::array::from_fn(|w| load_i(rng_words[w].as_ptr(), 8 * v)));

        // each lane's row of positions (lanes past `n` write none)
        let base = tracks.as_mut_ptr();
        let rows: [*mut Point; PACK] = std::array::from_fn(|l| {
            if l < n {
                base.wrapping_add(l * steps)
            } else {
                std::ptr::null_mut()
            }
        });
        let mut step_score = [0.0f32; PACK];
        for j in from..to {
            // Trust: the map's share of the heading kernel, and the speed, at this step.
            let gain = if trusting {
                1.0 - fastmath::exp_neg(-(j as f64) * dt / extras.trust)
            } else {
                1.0
            };
            if trusting {
                let s = observed_speed + (state.speed - observed_speed) * gain;
                speed = [[_mm256_set1_pd(s); 2]; V];
            }
            // Draw: each lane's two words, the component by the follow weights of its
            // heading, and its direction.
            // (in a loop rather than `from_fn`, whose closures were not inlined)
            let mut u = [_mm256_setzero_ps(); V];
            let mut z = [_mm256_setzero_ps(); V];
            for v in 0..V {
                u[v] = unit8(next8(&mut rng[v]));
                z[v] = normal8(next8(&mut rng[v]));
            }
            // SAFETY: AVX2 and FMA; the follow weights fit, `width` is the map's, and
            // every lane's location is one of the map's (the start's, one the lookup
            // found, or lane 0's for the padding).
            let t = unsafe { map.lane_following8::<V>(width, &loc, &ux, &uy, follow, &u, &z) };
            // Turn (the kernel's weight scaled by the trust gain).
            turn_v(
                t,
                &mut ux,
                &mut uy,
                neg_beta,
                trusting.then_some(gain as f32),
            );
            // The step's log-density, eight lanes to a register (each lane's speed in
            // single precision, as `speed as f32` rounds it).
            if SCORES {
                let rho: [__m256; V] = std::array::from_fn(|v| {
                    let [lo, hi] = speed[v];
                    _mm256_set_m128(_mm256_cvtpd_ps(hi), _mm256_cvtpd_ps(lo))
                });
                step_scores8(map, (&ux, &uy), &loc, &rho, &mut step_score);
            }
            // Move, and probe the sub-cells of the new positions (every register's first,
            // so that their cache misses overlap).
            let mut probes = [crate::map::Probe8::default(); V];
            let dt_v = _mm256_set1_pd(dt);
            for v in 0..V {
                let dist = speed[v].map(|s| _mm256_mul_pd(s, dt_v));
                advance8(&mut px[v], &mut py[v], ux[v], uy[v], dist);
                // SAFETY: AVX2 and FMA.
                probes[v] = unsafe { table.probe8(px[v], py[v]) };
            }
            // The positions to write: blended with constant velocity's, or as rolled.
            let (w, cv_x, cv_y) = if blend {
                let d = observed_speed * dt * (j + 1) as f64;
                (
                    fastmath::exp_neg(-(j as f64) * dt / extras.blend),
                    state.position.x + c0 * d,
                    state.position.y + s0 * d,
                )
            } else {
                (0.0, 0.0, 0.0)
            };
            // Every sample's row takes its position at this step, whether or not the
            // lookup below lets it go on: a sample that stops here (or stopped before)
            // has its positions from its length on made NaN when it is ended
            // (`finish_sample`), so writing them costs no branch per lane.
            for v in 0..V {
                let out = |p: [__m256d; 2], cv: f64| {
                    let p = if blend {
                        let (wc, rest) = (_mm256_set1_pd(w * cv), _mm256_set1_pd(1.0 - w));
                        p.map(|p| _mm256_add_pd(wc, _mm256_mul_pd(rest, p)))
                    } else {
                        p
                    };
                    _mm256_set_m128(_mm256_cvtpd_ps(p[1]), _mm256_cvtpd_ps(p[0]))
                };
                let (x, y) = (out(px[v], cv_x), out(py[v], cv_y));
                // (x, y) of lanes 0 1 | 4 5 and 2 3 | 6 7, a position to 64 bits
                let (lo, hi) = (
                    _mm256_castps_si256(_mm256_unpacklo_ps(x, y)),
                    _mm256_castps_si256(_mm256_unpackhi_ps(x, y)),
                );
                let pairs = [
                    _mm256_castsi256_si128(lo),
                    _mm256_castsi256_si128(hi),
                    _mm256_extracti128_si256::<1>(lo),
                    _mm256_extracti128_si256::<1>(hi),
                ];
                for (q, pair) in pairs.into_iter().enumerate() {
                    let l = 8 * v + 2 * q;
                    let (first, second) = (_mm_cvtsi128_si64(pair), _mm_extract_epi64::<1>(pair));
                    // SAFETY: lanes below `n` write their sample's row, which holds
                    // `steps` positions, and j < to <= steps (8 bytes, unaligned).
                    unsafe {
                        if l < n {
                            std::ptr::write_unaligned(rows[l].add(j) as *mut i64, first);
                        }
                        if l + 1 < n {
                            std::ptr::write_unaligned(rows[l + 1].add(j) as *mut i64, second);
                        }
                    }
                }
            }
            // Finish the lookups; the lanes that found a location go on.
            let step_len = _mm256_set1_epi32(j as i32 + 1);
            let mut now_bits = 0u32;
            for v in 0..V {
                // SAFETY: AVX2 and FMA; the probe of these points.
                let (found, code) = unsafe { table.resolve8(&probes[v], px[v], py[v]) };
                let lane = (&mut loc[v], &mut len[v], &mut score[v]);
                let now = go_on8::<SCORES>(alive[v], (found, code), step_len, lane, &step_score, v);
                alive[v] = now;
                now_bits |= (_mm256_movemask_ps(_mm256_castsi256_ps(now)) as u32) << (8 * v);
            }
            alive_bits = now_bits;
            if now_bits == 0 {
                break;
            }
        }

        // The lanes back into `st`, and the lengths.
        let mut out_px = [0.0f64; PACK];
        let mut out_py = [0.0f64; PACK];
        let mut out_speed = [0.0f64; PACK];
        let mut out_ux = [0.0f32; PACK];
        let mut out_uy = [0.0f32; PACK];
        let mut out_score = [0.0f32; PACK];
        let mut out_loc = [0i32; PACK];
        let mut out_len = [0u32; PACK];
        let mut out_rng = [[0u32; PACK]; 4];
        // SAFETY: the arrays hold 8 V lanes.
        unsafe {
            for v in 0..V {
                let o = 8 * v;
                for h in 0..2 {
                    _mm256_storeu_pd(out_px.as_mut_ptr().add(o + 4 * h), px[v][h]);
                    _mm256_storeu_pd(out_py.as_mut_ptr().add(o + 4 * h), py[v][h]);
                    _mm256_storeu_pd(out_speed.as_mut_ptr().add(o + 4 * h), speed[v][h]);
                }
                _mm256_storeu_ps(out_ux.as_mut_ptr().add(o), ux[v]);
                _mm256_storeu_ps(out_uy.as_mut_ptr().add(o), uy[v]);
                _mm256_storeu_ps(out_score.as_mut_ptr().add(o), score[v]);
                _mm256_storeu_si256(out_loc.as_mut_ptr().add(o) as *mut __m256i, loc[v]);
                _mm256_storeu_si256(out_len.as_mut_ptr().add(o) as *mut __m256i, len[v]);
                for (word, reg) in out_rng.iter_mut().zip(rng[v]) {
                    _mm256_storeu_si256(word.as_mut_ptr().add(o) as *mut __m256i, reg);
                }
            }
        }
        for l in 0..N {
            st.px[l] = out_px[l];
            st.py[l] = out_py[l];
            st.speed[l] = out_speed[l];
            st.ux[l] = out_ux[l];
            st.uy[l] = out_uy[l];
            st.score[l] = out_score[l];
            st.loc[l] = out_loc[l] as usize;
            st.alive[l] = alive_bits >> l & 1 == 1;
            for (word, out) in st.rng.s.iter_mut().zip(&out_rng) {
                word[l] = out[l];
            }
        }
        lens.copy_from_slice(&out_len[..n]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::map::CliffMap;
    use crate::math::Simd;
    use crate::motion::State;
    use crate::predict::candidates::Candidates;
    use crate::predict::lanes::{Extras, Lane, MAX_LANES};
    use crate::predict::lanes_avx2::tests::starts_on_maps;
    use crate::predict::seeds::agent_key;
    use crate::predict::{Checkpoint, PRUNE_SCHEDULE, Params};

    /// What a rollout gives: the positions' bits, the lengths, the scores' bits.
    type Rolled = (Vec<[u32; 2]>, Vec<u32>, Vec<u32>);

    /// A case: candidates, samples kept, the pruning schedule (empty: whole rollouts).
    type Case<'a> = (usize, usize, &'a [Checkpoint]);

    /// `m` candidates of `state` rolled whole (`schedule` empty) or pruned to `k`,
    /// through the table (the intrinsics) or not (the generic loop's AVX2 copy).
    #[allow(clippy::too_many_arguments)] // the case's settings
    fn roll(
        map: &CliffMap,
        state: &State,
        params: &Params,
        extras: &Extras,
        (m, k, schedule): Case<'_>,
        scored: bool,
        through_table: bool,
        seed: u64,
    ) -> Rolled {
        let table = map.build_table(params.radius, false).unwrap();
        let near = |p| table.best_near(p);
        let lanes = Lanes {
            map,
            near: &near,
            state,
            observed_speed: state.speed * 1.1,
            params,
            extras,
            table: through_table.then_some(&*table),
        };
        let steps = params.steps();
        let mut c = Candidates {
            tracks: vec![[0.0; 2]; m * steps],
            lens: vec![0; m],
            scores: vec![0.0; m],
            order: vec![0; m],
            lanes: vec![Lane::default(); m],
            ..Candidates::default()
        };
        let key = agent_key(seed, 0);
        let left = if schedule.is_empty() {
            if scored {
                lanes.roll_agent::<ANY, true>(key, &mut c.tracks, &mut c.lens, &mut c.scores);
            } else {
                lanes.roll_agent::<ANY, false>(key, &mut c.tracks, &mut c.lens, &mut []);
            }
            m
        } else {
            lanes.roll_pruned::<ANY>(key, schedule, k, steps, scored, &mut c)
        };
        (
            c.tracks[..left * steps]
                .iter()
                .map(|p| p.map(f32::to_bits))
                .collect(),
            c.lens[..left].to_vec(),
            c.scores[..left].iter().map(|s| s.to_bits()).collect(),
        )
    }

    #[test]
    fn the_intrinsics_give_the_bits_of_the_generic_avx2_loop() {
        if !Simd::Avx2Fma.available() {
            return;
        }
        let mut samples = 0;
        for (map, radius, dt, starts) in starts_on_maps(8) {
            let map = &map;
            assert!(map.follow_weights_fit() && map.lane_width().is_some());
            for (i, state) in starts.iter().enumerate() {
                for (c, (k, trust, blend)) in [
                    (1, 0.5, 3.0),
                    (5, 0.5, 3.0),
                    (8, 0.0, 0.0),
                    (12, 0.5, 0.0),
                    (20, 0.0, 3.0),
                    (MAX_LANES + 7, 0.5, 3.0),
                ]
                .into_iter()
                .enumerate()
                {
                    let params = Params {
                        k,
                        dt,
                        radius,
                        beta: 2.0,
                        horizon: 40.0 * dt,
                        ..Params::default()
                    };
                    let extras = Extras {
                        speed_beta: 0.0,
                        coast_steps: 0,
                        follow: 4.0,
                        candidates: 4,
                        prune: true,
                        speed_prior: None,
                        trust,
                        blend,
                        motion: false,
                        consensus: false,
                        simd: Simd::Avx2Fma,
                    };
                    let seed = (i * 31 + k) as u64;
                    let cases: [Case<'_>; 2] = [(k, k, &[]), (2 * k, k, PRUNE_SCHEDULE)];
                    for (case, scored) in cases.into_iter().zip([c % 2 == 0, c % 3 != 1]) {
                        let fast = roll(map, state, &params, &extras, case, scored, true, seed);
                        let generic = roll(map, state, &params, &extras, case, scored, false, seed);
                        let what = format!("start {i}, k {k}, {} candidates", case.0);
                        assert_eq!(fast.1, generic.1, "lengths: {what}");
                        assert_eq!(fast.0, generic.0, "positions: {what}");
                        assert_eq!(fast.2, generic.2, "scores: {what}");
                        samples += fast.1.iter().filter(|&&l| l > 5).count();
                    }
                }
            }
        }
        assert!(samples > 500, "{samples}");
    }
}
