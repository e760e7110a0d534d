//! The paper's method on AVX2 + FMA, eight samples to a register: the lane loop's
//! `PAPER` flavour without scores, written with intrinsics so that every part of a step
//! runs on eight lanes at once (the generators, the normal draw, the component choice
//! and the map lookup by gathers, the bookkeeping of live lanes by masks). It gives the
//! bits of the generic loop's AVX2 copy (`Lanes::roll_body` with fused multiply-adds):
//! the same draws, the same heading kernel (`turn`, here `turn_v`), the same lookups.

use std::arch::x86_64::*;

use glam::DVec2;

use super::Point;
use super::lanes::{LaneState, Lanes};
use crate::map::{NeighbourTable, Probe8, lane_mask};
use crate::math::fastmath::x8::{self, per};
use crate::math::lane_rng::{next8, normal8, unit8};

impl<F: Fn(DVec2) -> Option<usize>> Lanes<'_, F> {
    /// A whole rollout of the paper's method (heading rule `CircularMean`) for the
    /// `lens.len()` samples of one group, from their start `st`, in `V` registers of
    /// eight lanes (`8 V >= N`; lanes past the samples stay dead), looking the map up in
    /// `table` (the table `near` answers from). Writes the positions and lengths; the
    /// caller ends the samples (`finish_sample`).
    ///
    /// Every lane, dead or alive, takes its generator's two words and draws at every
    /// step (a dead lane's draws are discarded), and every sample's position is written
    /// at every step (past a sample's end, `finish_sample` overwrites them).
    ///
    /// # Safety
    /// The processor must have AVX2 and FMA, and the map lane tables a width
    /// (`CliffMap::lane_width`).
    #[target_feature(enable = "avx2,fma")]
    #[inline(never)]
    pub(super) unsafe fn roll_paper_avx2<const V: usize, const N: usize>(
        &self,
        table: &NeighbourTable,
        st: &LaneState<N>,
        tracks: &mut [Point],
        lens: &mut [u32],
    ) {
        let (map, params) = (self.map, self.params);
        let n = lens.len();
        debug_assert!(n <= N && N <= 8 * V);
        let steps = tracks.len() / n;
        let width = map.lane_width().expect("lane tables with a width");
        let dist = _mm256_set1_pd(self.state.speed * params.dt);
        let neg_beta = _mm256_set1_ps(-(params.beta as f32));
        // the lanes, eight to a register (positions: two registers of four)
        let mut px = [[_mm256_setzero_pd(); 2]; V];
        let mut py = [[_mm256_setzero_pd(); 2]; V];
        let mut ux = [_mm256_setzero_ps(); V];
        let mut uy = [_mm256_setzero_ps(); V];
        let mut loc = [_mm256_setzero_si256(); V];
        let mut alive = [_mm256_setzero_si256(); V];
        let mut len = [_mm256_setzero_si256(); V];
        let mut rng = [[_mm256_setzero_si256(); 4]; V];
        {
            let (x, y) = (&st.px, &st.py);
            let (mut xs, mut ys) = ([[x[0]; 8]; V], [[y[0]; 8]; V]);
            let (mut hx, mut hy) = ([[1.0f32; 8]; V], [[0.0f32; 8]; V]);
            let mut locs = [[st.loc[0] as i32; 8]; V];
            let mut live = [[0i32; 8]; V];
            let mut words = [[[0u32; 8]; 4]; V];
            for l in 0..N {
                let (v, i) = (l / 8, l % 8);
                xs[v][i] = x[l];
                ys[v][i] = y[l];
                hx[v][i] = st.ux[l];
                hy[v][i] = st.uy[l];
                locs[v][i] = st.loc[l] as i32;
                live[v][i] = -(st.alive[l] as i32);
                let state = st.rng.get(l);
                for w in 0..4 {
                    words[v][w][i] = state[w];
                }
            }
            for v in 0..V {
                // SAFETY: each array holds eight lanes.
                unsafe {
                    for h in 0..2 {
                        px[v][h] = _mm256_loadu_pd(xs[v].as_ptr().add(4 * h));
                        py[v][h] = _mm256_loadu_pd(ys[v].as_ptr().add(4 * h));
                    }
                    ux[v] = _mm256_loadu_ps(hx[v].as_ptr());
                    uy[v] = _mm256_loadu_ps(hy[v].as_ptr());
                    loc[v] = _mm256_loadu_si256(locs[v].as_ptr() as *const __m256i);
                    alive[v] = _mm256_loadu_si256(live[v].as_ptr() as *const __m256i);
                    for w in 0..4 {
                        rng[v][w] = _mm256_loadu_si256(words[v][w].as_ptr() as *const __m256i);
                    }
                }
            }
        }
        // each sample's positions (the group's `n` samples, `steps` each)
        let base = tracks.as_mut_ptr();
        let live = |v: usize| n.saturating_sub(8 * v).min(8);
        // the first step's words: a uniform (the component) and a normal per lane
        let mut u = [_mm256_setzero_ps(); V];
        let mut z = [_mm256_setzero_ps(); V];
        for v in 0..V {
            u[v] = unit8(next8(&mut rng[v]));
            z[v] = normal8(next8(&mut rng[v]));
        }
        let mut probes = [Probe8::default(); V];
        let mut pairs = [[0.0f32; 2]; 8];
        for j in 0..steps {
            // Draw (the component and its direction) and turn.
            // SAFETY: AVX2 and FMA; every lane's location is one of the map's (the
            // start's, or one the lookup found), and the tables have this width.
            let t = unsafe { map.lane_direction8(width, &loc, &u, &z) };
            turn_v(t, &mut ux, &mut uy, neg_beta);
            // Move, and find the sub-cells of the new positions (every register's first,
            // so that their cache misses overlap).
            for v in 0..V {
                let hx = [
                    _mm256_castps256_ps128(ux[v]),
                    _mm256_extractf128_ps::<1>(ux[v]),
                ];
                let hy = [
                    _mm256_castps256_ps128(uy[v]),
                    _mm256_extractf128_ps::<1>(uy[v]),
                ];
                for h in 0..2 {
                    px[v][h] = _mm256_fmadd_pd(_mm256_cvtps_pd(hx[h]), dist, px[v][h]);
                    py[v][h] = _mm256_fmadd_pd(_mm256_cvtps_pd(hy[h]), dist, py[v][h]);
                }
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
                // SAFETY: `pairs` holds eight pairs; sample 8 v + i < n has `steps`
                // positions from `base + (8 v + i) steps`, and j < steps.
                unsafe {
                    let o = pairs.as_mut_ptr() as *mut f32;
                    _mm256_storeu_ps(o, _mm256_permute2f128_ps::<0x20>(lo, hi));
                    _mm256_storeu_ps(o.add(8), _mm256_permute2f128_ps::<0x31>(lo, hi));
                    for (i, &pair) in pairs[..live(v)].iter().enumerate() {
                        *base.add((8 * v + i) * steps + j) = pair;
                    }
                }
            }
            // Finish the lookups and keep the lanes that found a location.
            let step_len = _mm256_set1_epi32(j as i32 + 1);
            let mut any = 0;
            for v in 0..V {
                // SAFETY: AVX2 and FMA; the probe of these points.
                let (found, code) = unsafe { table.resolve8(&probes[v], px[v], py[v]) };
                let now = _mm256_and_si256(alive[v], lane_mask(found));
                loc[v] = _mm256_blendv_epi8(loc[v], code, now);
                len[v] = _mm256_blendv_epi8(len[v], step_len, now);
                alive[v] = now;
                any |= _mm256_movemask_ps(_mm256_castsi256_ps(now));
            }
            if any == 0 {
                break;
            }
        }
        for v in 0..V {
            let mut l = [0u32; 8];
            // SAFETY: eight lanes.
            unsafe { _mm256_storeu_si256(l.as_mut_ptr() as *mut __m256i, len[v]) };
            for (i, &len) in l.iter().enumerate().take(n.saturating_sub(8 * v).min(8)) {
                lens[8 * v + i] = len;
            }
        }
    }
}

/// The generic loop's heading update (`turn::<8, Fused, false>`) of `V` registers of
/// eight lanes: the same bits for finite inputs (see `turn` for what it computes).
#[target_feature(enable = "avx2,fma")]
#[inline]
fn turn_v<const V: usize>(
    t: [__m256; V],
    x: &mut [__m256; V],
    y: &mut [__m256; V],
    neg_beta: __m256,
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
mod tests {
    use super::*;
    use crate::map::CliffMap;
    use crate::math::Simd;
    use crate::motion::State;
    use crate::predict::Params;
    use crate::predict::lanes::{Extras, MAX_LANES, PAPER};
    use crate::predict::seeds::agent_key;

    /// The samples of `k` lanes of the paper's method from `state`, through the table
    /// (the intrinsics) or not (the generic loop's AVX2 copy).
    fn roll(
        map: &CliffMap,
        state: &State,
        params: &Params,
        through_table: bool,
        seed: u64,
    ) -> (Vec<[u32; 2]>, Vec<u32>) {
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
        lanes.roll_agent::<PAPER, false>(agent_key(seed, 0), &mut tracks, &mut lens, &mut []);
        (tracks.iter().map(|p| p.map(f32::to_bits)).collect(), lens)
    }

    #[test]
    fn the_intrinsics_give_the_bits_of_the_generic_avx2_loop() {
        if !Simd::Avx2Fma.available() {
            return;
        }
        let data = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data/");
        let thor = CliffMap::load(format!("{data}thor1/cliffmap.csv")).unwrap();
        let atc = CliffMap::load(format!("{data}atc/cliffmap-20121024.csv")).unwrap();
        let demo = CliffMap::demo();
        let mut samples = 0;
        for (map, radius, dt) in [(&thor, 0.7071, 0.4), (&atc, 1.0, 1.0), (&demo, 1.0, 0.4)] {
            assert!(map.lane_width().is_some());
            // starts at locations of the map, heading every way
            let positions: Vec<DVec2> = (0..map.locations().len())
                .step_by((map.locations().len() / 15).max(1))
                .map(|i| map.locations()[i].position + DVec2::new(0.1, -0.05))
                .collect();
            for (i, &position) in positions.iter().enumerate() {
                let state = State {
                    position,
                    speed: 0.6 + 0.1 * (i % 9) as f64,
                    heading: i as f64 * 0.7,
                    time: 0.0,
                };
                for k in [1, 5, 8, 12, 20, MAX_LANES + 7] {
                    let params = Params {
                        k,
                        dt,
                        radius,
                        horizon: 40.0 * dt,
                        ..Params::default()
                    };
                    let seed = (i * 31 + k) as u64;
                    let fast = roll(map, &state, &params, true, seed);
                    let generic = roll(map, &state, &params, false, seed);
                    assert_eq!(fast.1, generic.1, "lengths: start {i}, k {k}");
                    assert_eq!(fast.0, generic.0, "positions: start {i}, k {k}");
                    samples += fast.1.iter().filter(|&&l| l > 5).count();
                }
            }
        }
        assert!(samples > 500, "{samples}");
    }
}
