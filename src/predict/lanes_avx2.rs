//! The paper's method on AVX2 + FMA, eight samples to a register: the lane loop's
//! `PAPER` flavour, with or without scores, written with intrinsics so that every part
//! of a step runs on eight lanes at once (the generators, the normal draw, the component
//! choice and the map lookup by gathers, the bookkeeping of live lanes by masks; with
//! scores, the headings' angles and the densities, each location's first block of
//! components loaded whole and transposed). It gives the bits of
//! the generic loop's AVX2 copy (`Lanes::roll_body` with fused multiply-adds): the same
//! draws, the same heading kernel (`turn`, here `turn_v`), the same lookups and scores.

use std::arch::x86_64::*;

use glam::DVec2;

use super::Point;
use super::lanes::{LaneState, Lanes, PACK};
use crate::map::{NeighbourTable, Probe8, lane_mask};
use crate::math::fastmath::x8::{self, per};
use crate::math::lane_rng::{next8, normal8, unit8};

/// The lanes of one group between stretches of the AVX2 loop, lane by lane: the first
/// `n` in use (after a [`compact`](Pack::compact), all of them alive).
struct Pack {
    n: usize,
    /// Each lane's sample (its row of the output).
    sample: [u32; PACK],
    px: [f64; PACK],
    py: [f64; PACK],
    ux: [f32; PACK],
    uy: [f32; PACK],
    /// The next step's uniform (the component) and normal.
    u: [f32; PACK],
    z: [f32; PACK],
    loc: [i32; PACK],
    /// All ones for a live lane.
    alive: [i32; PACK],
    len: [u32; PACK],
    /// The sample's log-densities summed so far (with scores).
    score: [f32; PACK],
    rng: [[u32; PACK]; 4],
}

impl Pack {
    /// Keep the live lanes (in order); the others' lengths go to `lens`, their scores
    /// to `scores`.
    fn compact(&mut self, lens: &mut [u32], scores: &mut [f32]) {
        let mut k = 0;
        for l in 0..self.n {
            if self.alive[l] == 0 {
                lens[self.sample[l] as usize] = self.len[l];
                scores[self.sample[l] as usize] = self.score[l];
                continue;
            }
            if k != l {
                self.sample[k] = self.sample[l];
                self.px[k] = self.px[l];
                self.py[k] = self.py[l];
                self.ux[k] = self.ux[l];
                self.uy[k] = self.uy[l];
                self.u[k] = self.u[l];
                self.z[k] = self.z[l];
                self.loc[k] = self.loc[l];
                self.alive[k] = self.alive[l];
                self.len[k] = self.len[l];
                self.score[k] = self.score[l];
                for w in 0..4 {
                    self.rng[w][k] = self.rng[w][l];
                }
            }
            k += 1;
        }
        // lanes past the live ones: dead, at a live lane's place (valid for the loads)
        for l in k..PACK {
            self.alive[l] = 0;
            self.sample[l] = u32::MAX;
            if k > 0 {
                self.px[l] = self.px[0];
                self.py[l] = self.py[0];
                self.loc[l] = self.loc[0];
            }
        }
        self.n = k;
    }
}

impl<F: Fn(DVec2) -> Option<usize>> Lanes<'_, F> {
    /// A whole rollout of the paper's method (heading rule `CircularMean`) for the
    /// `lens.len()` samples of one group (at most 24), from their start `st`, looking
    /// the map up in `table` (the table `near` answers from). Writes the positions and
    /// lengths, and with `SCORES` the samples' summed log-densities to `st.score`; the
    /// caller ends the samples (`finish_sample`).
    ///
    /// The lanes roll in three, two or one registers of eight: whenever the live
    /// samples fit in fewer registers, the live lanes are packed together and the rest
    /// of the rollout takes fewer registers (a lane's arithmetic does not depend on
    /// where it is). Every lane takes its generator's two words at every step, and every
    /// live lane's position is written at every step of a stretch (past a sample's end,
    /// `finish_sample` overwrites them).
    ///
    /// # Safety
    /// The processor must have AVX2 and FMA, and the map lane tables a width
    /// (`CliffMap::lane_width`).
    #[target_feature(enable = "avx2,fma")]
    #[inline(never)]
    pub(super) unsafe fn roll_paper_avx2<const N: usize, const SCORES: bool>(
        &self,
        table: &NeighbourTable,
        st: &mut LaneState<N>,
        tracks: &mut [Point],
        lens: &mut [u32],
    ) {
        let n = lens.len();
        debug_assert!(n <= N && N <= PACK);
        let steps = tracks.len() / n;
        let mut pack = Pack {
            n,
            sample: [u32::MAX; PACK],
            px: [st.px[0]; PACK],
            py: [st.py[0]; PACK],
            ux: [1.0; PACK],
            uy: [0.0; PACK],
            u: [0.0; PACK],
            z: [0.0; PACK],
            loc: [st.loc[0] as i32; PACK],
            alive: [0; PACK],
            len: [0; PACK],
            score: [0.0; PACK],
            rng: [[0; PACK]; 4],
        };
        for l in 0..n {
            pack.sample[l] = l as u32;
            pack.px[l] = st.px[l];
            pack.py[l] = st.py[l];
            pack.ux[l] = st.ux[l];
            pack.uy[l] = st.uy[l];
            pack.loc[l] = st.loc[l] as i32;
            pack.alive[l] = -(st.alive[l] as i32);
            pack.score[l] = st.score[l];
            for (word, w) in pack.rng.iter_mut().zip(st.rng.get(l)) {
                word[l] = w;
            }
        }
        let mut j = 0;
        let mut first = true;
        while j < steps {
            let before = j;
            // SAFETY: AVX2 and FMA, lane tables with a width (this function's
            // contract); the pack's lanes are the group's.
            j = unsafe {
                match pack.n.div_ceil(8) {
                    0 => break,
                    1 => self.stretch::<1, SCORES>(table, &mut pack, first, (j, steps), tracks),
                    2 => self.stretch::<2, SCORES>(table, &mut pack, first, (j, steps), tracks),
                    _ => self.stretch::<3, SCORES>(table, &mut pack, first, (j, steps), tracks),
                }
            };
            debug_assert!(j > before);
            first = false;
            pack.compact(lens, &mut st.score[..n]);
        }
        for l in 0..pack.n {
            lens[pack.sample[l] as usize] = pack.len[l];
            st.score[pack.sample[l] as usize] = pack.score[l];
        }
    }

    /// Steps `from..steps` of the pack's first `8 V` lanes (the pack holds no more),
    /// in `V` registers, until the horizon, until no lane is alive, or until the live
    /// lanes fit in fewer registers; the lanes stored back. The step to go on from. With
    /// `first` the lanes take the first step's words from their generators (else the
    /// pack holds them). `tracks` holds the group's samples, `steps` positions each.
    /// With `SCORES` each step's log-density is added to the scores of the lanes that go
    /// on.
    ///
    /// # Safety
    /// As [`roll_paper_avx2`](Self::roll_paper_avx2).
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn stretch<const V: usize, const SCORES: bool>(
        &self,
        table: &NeighbourTable,
        pack: &mut Pack,
        first: bool,
        (from, steps): (usize, usize),
        tracks: &mut [Point],
    ) -> usize {
        let (map, params) = (self.map, self.params);
        let width = map.lane_width().expect("lane tables with a width");
        let dist = _mm256_set1_pd(self.state.speed * params.dt);
        let neg_beta = _mm256_set1_ps(-(params.beta as f32));
        let n = pack.n;
        // the lanes, eight to a register (positions: two registers of four)
        let mut px = [[_mm256_setzero_pd(); 2]; V];
        let mut py = [[_mm256_setzero_pd(); 2]; V];
        let mut ux = [_mm256_setzero_ps(); V];
        let mut uy = [_mm256_setzero_ps(); V];
        let mut u = [_mm256_setzero_ps(); V];
        let mut z = [_mm256_setzero_ps(); V];
        let mut loc = [_mm256_setzero_si256(); V];
        let mut alive = [_mm256_setzero_si256(); V];
        let mut len = [_mm256_setzero_si256(); V];
        let mut score = [_mm256_setzero_ps(); V];
        let mut rng = [[_mm256_setzero_si256(); 4]; V];
        // SAFETY: the pack's arrays hold 8 V lanes and more.
        unsafe {
            for v in 0..V {
                let o = 8 * v;
                score[v] = _mm256_loadu_ps(pack.score.as_ptr().add(o));
                for h in 0..2 {
                    px[v][h] = _mm256_loadu_pd(pack.px.as_ptr().add(o + 4 * h));
                    py[v][h] = _mm256_loadu_pd(pack.py.as_ptr().add(o + 4 * h));
                }
                ux[v] = _mm256_loadu_ps(pack.ux.as_ptr().add(o));
                uy[v] = _mm256_loadu_ps(pack.uy.as_ptr().add(o));
                u[v] = _mm256_loadu_ps(pack.u.as_ptr().add(o));
                z[v] = _mm256_loadu_ps(pack.z.as_ptr().add(o));
                loc[v] = _mm256_loadu_si256(pack.loc.as_ptr().add(o) as *const __m256i);
                alive[v] = _mm256_loadu_si256(pack.alive.as_ptr().add(o) as *const __m256i);
                len[v] = _mm256_loadu_si256(pack.len.as_ptr().add(o) as *const __m256i);
                for (reg, word) in rng[v].iter_mut().zip(&pack.rng) {
                    *reg = _mm256_loadu_si256(word.as_ptr().add(o) as *const __m256i);
                }
            }
        }
        if first {
            // the first step's words: a uniform (the component) and a normal per lane
            for v in 0..V {
                u[v] = unit8(next8(&mut rng[v]));
                z[v] = normal8(next8(&mut rng[v]));
            }
        }
        // each lane's row of positions (lanes past `n` write none)
        let base = tracks.as_mut_ptr();
        let rows: [*mut Point; PACK] = std::array::from_fn(|l| {
            if l < n {
                base.wrapping_add(pack.sample[l] as usize * steps)
            } else {
                std::ptr::null_mut()
            }
        });
        let live = |v: usize| n.saturating_sub(8 * v).min(8);
        let fewer = 8 * (V - 1) as u32;
        let mut probes = [Probe8::default(); V];
        let mut pairs = [[0.0f32; 2]; 8];
        let speed = self.state.speed as f32;
        let mut step_score = [0.0f32; PACK];
        let mut j = from;
        while j < steps {
            // Draw (the component and its direction) and turn.
            // SAFETY: AVX2 and FMA; every lane's location is one of the map's (the
            // start's, or one the lookup found), and the tables have this width.
            let t = unsafe { map.lane_direction8(width, &loc, &u, &z) };
            turn_v(t, &mut ux, &mut uy, neg_beta, None);
            if SCORES {
                // the step's log-density, eight lanes to a register
                let rho = [_mm256_set1_ps(speed); V];
                step_scores8(map, (&ux, &uy), &loc, &rho, &mut step_score);
            }
            // Move, and find the sub-cells of the new positions (every register's first,
            // so that their cache misses overlap).
            for v in 0..V {
                advance8(&mut px[v], &mut py[v], ux[v], uy[v], [dist; 2]);
                // SAFETY: AVX2 and FMA.
                probes[v] = unsafe { table.probe8(px[v], py[v]) };
            }
            // Work that needs no lookup while the probes load: the next step's words,
            // and this step's positions (past a sample's end, overwritten later).
            for v in 0..V {
                u[v] = unit8(next8(&mut rng[v]));
                z[v] = normal8(next8(&mut rng[v]));
                let xs = _mm256_set_m128(_mm256_cvtpd_ps(px[v][1]), _mm256_cvtpd_ps(px[v][0]));
                let ys = _mm256_set_m128(_mm256_cvtpd_ps(py[v][1]), _mm256_cvtpd_ps(py[v][0]));
                let (lo, hi) = (_mm256_unpacklo_ps(xs, ys), _mm256_unpackhi_ps(xs, ys));
                // SAFETY: `pairs` holds eight pairs; lane 8 v + i < n writes its sample's
                // row, which holds `steps` positions, and j < steps.
                unsafe {
                    let o = pairs.as_mut_ptr() as *mut f32;
                    _mm256_storeu_ps(o, _mm256_permute2f128_ps::<0x20>(lo, hi));
                    _mm256_storeu_ps(o.add(8), _mm256_permute2f128_ps::<0x31>(lo, hi));
                    for (i, &pair) in pairs[..live(v)].iter().enumerate() {
                        *rows[8 * v + i].add(j) = pair;
                    }
                }
            }
            // Finish the lookups and keep the lanes that found a location.
            let step_len = _mm256_set1_epi32(j as i32 + 1);
            let mut alive_now = 0;
            for v in 0..V {
                // SAFETY: AVX2 and FMA; the probe of these points.
                let (found, code) = unsafe { table.resolve8(&probes[v], px[v], py[v]) };
                let lane = (&mut loc[v], &mut len[v], &mut score[v]);
                let now = go_on8::<SCORES>(alive[v], (found, code), step_len, lane, &step_score, v);
                alive[v] = now;
                alive_now += (_mm256_movemask_ps(_mm256_castsi256_ps(now)) as u32).count_ones();
            }
            j += 1;
            if alive_now == 0 || (V > 1 && alive_now <= fewer) {
                break;
            }
        }
        // SAFETY: the pack's arrays hold 8 V lanes and more.
        unsafe {
            for v in 0..V {
                let o = 8 * v;
                for h in 0..2 {
                    _mm256_storeu_pd(pack.px.as_mut_ptr().add(o + 4 * h), px[v][h]);
                    _mm256_storeu_pd(pack.py.as_mut_ptr().add(o + 4 * h), py[v][h]);
                }
                _mm256_storeu_ps(pack.ux.as_mut_ptr().add(o), ux[v]);
                _mm256_storeu_ps(pack.uy.as_mut_ptr().add(o), uy[v]);
                _mm256_storeu_ps(pack.u.as_mut_ptr().add(o), u[v]);
                _mm256_storeu_ps(pack.z.as_mut_ptr().add(o), z[v]);
                _mm256_storeu_si256(pack.loc.as_mut_ptr().add(o) as *mut __m256i, loc[v]);
                _mm256_storeu_si256(pack.alive.as_mut_ptr().add(o) as *mut __m256i, alive[v]);
                _mm256_storeu_si256(pack.len.as_mut_ptr().add(o) as *mut __m256i, len[v]);
                _mm256_storeu_ps(pack.score.as_mut_ptr().add(o), score[v]);
                for (word, reg) in pack.rng.iter_mut().zip(rng[v]) {
                    _mm256_storeu_si256(word.as_mut_ptr().add(o) as *mut __m256i, reg);
                }
            }
        }
        j
    }
}

/// The generic loop's position step (`p + u d`, fused, in double precision) of eight
/// lanes: positions `x`, `y` (lanes 0-3 in the first register), headings `(ux, uy)`,
/// metres `d` (lanes 0-3 first).
#[target_feature(enable = "avx2,fma")]
#[inline]
pub(super) fn advance8(
    x: &mut [__m256d; 2],
    y: &mut [__m256d; 2],
    ux: __m256,
    uy: __m256,
    d: [__m256d; 2],
) {
    let hx = [_mm256_castps256_ps128(ux), _mm256_extractf128_ps::<1>(ux)];
    let hy = [_mm256_castps256_ps128(uy), _mm256_extractf128_ps::<1>(uy)];
    for h in 0..2 {
        x[h] = _mm256_fmadd_pd(_mm256_cvtps_pd(hx[h]), d[h], x[h]);
        y[h] = _mm256_fmadd_pd(_mm256_cvtps_pd(hy[h]), d[h], y[h]);
    }
}

/// The step's log-densities (`CliffMap::step_log_density_at`) of the `8 V` lanes into
/// `out`, eight to a register (`CliffMap::step_log_density8`): each lane's heading angle
/// from `(ux, uy)` (`x8::atan2`, the generic loop's `atan2_f32_with::<Fused>`), its
/// location from `loc`, its speed from `rho`. The dead lanes' are written too (their
/// locations are the map's; no score takes them).
#[target_feature(enable = "avx2,fma")]
#[inline]
pub(super) fn step_scores8<const V: usize>(
    map: &crate::map::CliffMap,
    (ux, uy): (&[__m256; V], &[__m256; V]),
    loc: &[__m256i; V],
    rho: &[__m256; V],
    out: &mut [f32; PACK],
) {
    let angle = x8::atan2(*uy, *ux);
    for v in 0..V {
        // SAFETY: AVX2 and FMA; every lane's location is one of the map's (as the loops
        // that call this keep them); the array holds PACK >= 8 V lanes.
        unsafe {
            let d = map.step_log_density8(loc[v], angle[v], rho[v]);
            _mm256_storeu_ps(out.as_mut_ptr().add(8 * v), d);
        }
    }
}

/// The end of a step for register `v` of the lanes `alive`: the lanes whose new position
/// the lookup placed (`(found, code)`: `resolve8`'s answer) go on, with that location
/// and the length `step_len`, and with `SCORES` their step's log-density (`step_score`)
/// added to their score; the others keep theirs. The lanes that go on.
#[target_feature(enable = "avx2,fma")]
#[inline]
pub(super) fn go_on8<const SCORES: bool>(
    alive: __m256i,
    (found, code): (u32, __m256i),
    step_len: __m256i,
    (loc, len, score): (&mut __m256i, &mut __m256i, &mut __m256),
    step_score: &[f32; PACK],
    v: usize,
) -> __m256i {
    let now = _mm256_and_si256(alive, lane_mask(found));
    *loc = _mm256_blendv_epi8(*loc, code, now);
    *len = _mm256_blendv_epi8(*len, step_len, now);
    if SCORES {
        // SAFETY: the array holds PACK >= 8 (v + 1) lanes.
        let add = unsafe { _mm256_loadu_ps(step_score.as_ptr().add(8 * v)) };
        *score = _mm256_blendv_ps(*score, _mm256_add_ps(*score, add), _mm256_castsi256_ps(now));
    }
    now
}

/// The generic loop's heading update (`turn::<8, Fused, GAIN>`) of `V` registers of
/// eight lanes, the kernel's weight scaled by `gain` where given (`GAIN`): the same bits
/// for finite inputs (see `turn` for what it computes).
#[target_feature(enable = "avx2,fma")]
#[inline]
pub(super) fn turn_v<const V: usize>(
    t: [__m256; V],
    x: &mut [__m256; V],
    y: &mut [__m256; V],
    neg_beta: __m256,
    gain: Option<f32>,
) {
    let one = _mm256_set1_ps(1.0);
    let (sin, cos) = x8::sin_cos(t);
    let dot = per!(V, |v| _mm256_fmadd_ps(
        cos[v],
        x[v],
        _mm256_mul_ps(sin[v], y[v])
    ));
    let delta = x8::acos(dot);
    let arg = per!(V, |v| _mm256_mul_ps(
        _mm256_mul_ps(neg_beta, delta[v]),
        delta[v]
    ));
    let lambda = x8::exp_neg(arg);
    let lambda = match gain {
        Some(g) => per!(V, |v| _mm256_mul_ps(lambda[v], _mm256_set1_ps(g))),
        None => lambda,
    };
    let rest = per!(V, |v| _mm256_sub_ps(one, lambda[v]));
    let vx = per!(V, |v| _mm256_fmadd_ps(
        cos[v],
        lambda[v],
        _mm256_mul_ps(x[v], rest[v])
    ));
    let vy = per!(V, |v| _mm256_fmadd_ps(
        sin[v],
        lambda[v],
        _mm256_mul_ps(y[v], rest[v])
    ));
    let n2 = per!(V, |v| _mm256_fmadd_ps(
        vx[v],
        vx[v],
        _mm256_mul_ps(vy[v], vy[v])
    ));
    let tiny = _mm256_set1_ps(1e-20);
    let inv = per!(V, |v| _mm256_div_ps(
        one,
        _mm256_sqrt_ps(_mm256_max_ps(n2[v], tiny))
    ));
    for v in 0..V {
        let ok = _mm256_cmp_ps::<_CMP_GT_OQ>(n2[v], tiny);
        x[v] = _mm256_blendv_ps(one, _mm256_mul_ps(vx[v], inv[v]), ok);
        y[v] = _mm256_blendv_ps(_mm256_setzero_ps(), _mm256_mul_ps(vy[v], inv[v]), ok);
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::map::CliffMap;
    use crate::math::Simd;
    use crate::motion::State;
    use crate::predict::Params;
    use crate::predict::lanes::{Extras, MAX_LANES, PAPER};
    use crate::predict::seeds::agent_key;

    /// The samples of `k` lanes of the paper's method from `state`, through the table
    /// (the intrinsics) or not (the generic loop's AVX2 copy): the positions' bits, the
    /// lengths, and with `scored` the scores' bits.
    fn roll(
        map: &CliffMap,
        state: &State,
        params: &Params,
        (through_table, scored): (bool, bool),
        seed: u64,
    ) -> (Vec<[u32; 2]>, Vec<u32>, Vec<u32>) {
        let table = map.build_table(params.radius, false).unwrap();
        let near = |p| table.best_near(p);
        let extras = Extras {
            speed_beta: 0.0,
            coast_steps: 0,
            follow: 0.0,
            candidates: 1,
            prune: false,
            speed_prior: None,
            trust: 0.0,
            blend: 0.0,
            motion: false,
            consensus: false,
            simd: Simd::Avx2Fma,
        };
        let lanes = Lanes {
            map,
            near: &near,
            state,
            observed_speed: state.speed,
            params,
            extras: &extras,
            table: through_table.then_some(&*table),
        };
        let steps = params.steps();
        let mut tracks = vec![[0.0f32; 2]; params.k * steps];
        let mut lens = vec![0u32; params.k];
        let mut scores = vec![0.0f32; params.k];
        let key = agent_key(seed, 0);
        if scored {
            lanes.roll_agent::<PAPER, true>(key, &mut tracks, &mut lens, &mut scores);
        } else {
            lanes.roll_agent::<PAPER, false>(key, &mut tracks, &mut lens, &mut []);
        }
        (
            tracks.iter().map(|p| p.map(f32::to_bits)).collect(),
            lens,
            scores.iter().map(|s| s.to_bits()).collect(),
        )
    }

    /// The real maps (THÖR1, ATC) and the demo map, each with its radius and time step,
    /// and starts at every `every`-th of its locations' places (a little off each),
    /// heading every way at walking speeds: the cases the intrinsics loops' tests
    /// compare with the generic loop.
    pub(in crate::predict) fn starts_on_maps(
        every: usize,
    ) -> Vec<(CliffMap, f64, f64, Vec<State>)> {
        let data = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data/");
        let thor = CliffMap::load(format!("{data}thor1/cliffmap.csv")).unwrap();
        let atc = CliffMap::load(format!("{data}atc/cliffmap-20121024.csv")).unwrap();
        [
            (thor, 0.7071, 0.4),
            (atc, 1.0, 1.0),
            (CliffMap::demo(), 1.0, 0.4),
        ]
        .into_iter()
        .map(|(map, radius, dt)| {
            let n = map.locations().len();
            let starts = (0..n)
                .step_by((n / every).max(1))
                .enumerate()
                .map(|(i, l)| State {
                    position: map.locations()[l].position + DVec2::new(0.1, -0.05),
                    speed: 0.6 + 0.1 * (i % 9) as f64,
                    heading: i as f64 * 0.7,
                    time: 0.0,
                })
                .collect();
            (map, radius, dt, starts)
        })
        .collect()
    }

    #[test]
    fn the_intrinsics_give_the_bits_of_the_generic_avx2_loop() {
        if !Simd::Avx2Fma.available() {
            return;
        }
        let (mut samples, mut scored_samples) = (0, 0);
        for (map, radius, dt, starts) in starts_on_maps(15) {
            assert!(map.lane_width().is_some());
            for (i, state) in starts.iter().enumerate() {
                for k in [1, 5, 8, 12, 20, MAX_LANES + 7] {
                    let params = Params {
                        k,
                        dt,
                        radius,
                        horizon: 40.0 * dt,
                        ..Params::default()
                    };
                    let seed = (i * 31 + k) as u64;
                    for scored in [false, true] {
                        let fast = roll(&map, state, &params, (true, scored), seed);
                        let generic = roll(&map, state, &params, (false, scored), seed);
                        let what = format!("start {i}, k {k}, scores {scored}");
                        assert_eq!(fast.1, generic.1, "lengths: {what}");
                        assert_eq!(fast.0, generic.0, "positions: {what}");
                        assert_eq!(fast.2, generic.2, "scores: {what}");
                        samples += fast.1.iter().filter(|&&l| l > 5).count();
                        if scored {
                            // (finite scores where a sample went on)
                            scored_samples += fast
                                .2
                                .iter()
                                .filter(|&&b| f32::from_bits(b).is_finite() && b != 0)
                                .count();
                        }
                    }
                }
            }
        }
        assert!(
            samples > 500 && scored_samples > 250,
            "{samples}, {scored_samples}"
        );
    }
}
