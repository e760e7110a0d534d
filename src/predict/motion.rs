//! The motion model's samples ([`Method::Motion`](super::Method::Motion)), constant
//! velocity of the last displacement ([`Method::CvmLast`](super::Method::CvmLast)), and
//! the map's samples bent towards the motion model ([`Options::motion`](super::Options::motion)).
//!
//! A motion sample walks the model's [`Forecast`] on a path of its own: sample `s` of
//! an agent draws a standard normal pair `z` from its generator (keyed as every
//! sample's, `lane_seed(agent key, s)`: two words, each a normal by the inverse
//! distribution function) and its positions are the forecast's at `j dt` on `z`; the
//! first sample (`s = 0`) is the expected path (`z = 0`). Its score is the log-density of
//! `z`, `-|z|^2 / 2`, so the best-ranked sample is the expected path. Every sample
//! reaches the horizon.
//!
//! With [`Options::motion`](super::Options::motion), a CLiFF-LHMP sample `S` of a person
//! (rolled as the options say) becomes `M + w(t) (S' - M)` at `t` seconds ahead: `M` is
//! the motion model's path on the sample's own normal pair (`z`, drawn as a motion
//! sample's), `S'` the map's sample with the blend ([`Options::blend`](super::Options::blend))
//! leaving `M` instead of constant velocity's line, standing where it stopped from the
//! step where the map stopped it (the map saw no one walk on from there); `w(t)` is the
//! map's share ([`bend_to_motion`]):
//!
//! * the map's **likelihood ratio** for this person, `exp(L)`: how much likelier the
//!   headings of their observed moving steps (0.4 s steps over 0.2 m/s) are under the
//!   map's mixture at each step's place, given the step's speed, than under a uniform
//!   heading: `L = 0.3 sum_i clamp(log p_map(theta_i | rho_i) + ln(2 pi), -2, 2)` (the
//!   steps of one walk are far from independent, hence the weight 0.3; the clamp keeps
//!   one odd step from deciding). The heading's density given the speed is the
//!   mixture's joint density over its density of that speed
//!   ([`CliffMap::heading_log_density`]): every map of a place where people walk at
//!   about 1.2 m/s explains their speed, a wrong one (turned, another room's) as well,
//!   so the speed is no evidence for the map. A step with no location near counts -2.
//!   No moving step: `L = 0`. No location near any moving step: the share is 0, the
//!   motion model alone;
//! * the **near share**, `e^max(exp(-t / 5 s), 1/2)`: the map's evidence `e = 1 / (1 +
//!   exp(2.5 - L))` (prior odds of `e^-2.5` against the map; about 0.08 before any
//!   step), near the present itself, from about 3.5 s on its square root: the motion
//!   model knows the next seconds;
//! * the **far share**, `1 / (1 + exp(p(t) - 2 L))`: the same steps counted twice as
//!   strongly, against prior log-odds `p(t) = -0.5 + 6 exp(-t / 5 s)` that fall from 5.5
//!   at the present through 2.2 at 4 s and 0.3 at 10 s
//!   to -0.5 far out: the map knows where people go. A map whose headings match the
//!   person's (`L` of 1.5, the median on ATC with its right map) takes 97 % at 20 s, a
//!   map against them (`L` of -3, the median with that map turned 90 degrees) 0.4 %;
//! * the share `w(t)` is the larger of the two.
//!
//! So where the map is wrong or missing the samples are the motion model's, and where it
//! is right they are the map's, starting from the motion model near the present. Every
//! sample reaches the horizon. The first sample then becomes the samples' mean path (the
//! expected position at each step), the best-ranked under the consensus ranking; the
//! normal pairs come in antithetic pairs (sample `2 i` draws `-z` of sample `2 i - 1`), so
//! with no map the mean path is the motion model's expected path.
//!
//! The share's exponents and the blend's weights depend on the steps alone: they are
//! computed once and kept for the following calls with the same steps ([`Bend`]), and
//! the evidence is raised to each exponent once. The bending runs over the steps in columns (four steps to
//! an instruction on AVX2), with the same bits on both instruction paths.

use glam::DVec2;

use super::Point;
use crate::map::CliffMap;
use crate::math::Simd;
use crate::math::lane_rng::{LaneRngs, lane_seed, normal_f32_with};
use crate::math::simd::Separate;
use crate::motion::{Forecast, History, MODEL_DT, State};

/// The normal pair of sample `s` of the agent keyed `key`: zero for the first sample,
/// then antithetic pairs (sample `2 i` is minus sample `2 i - 1`, drawn from that one's
/// generator), so that the pairs' mean is zero.
#[inline]
pub(super) fn sample_normal(key: u64, s: usize) -> DVec2 {
    if s == 0 {
        return DVec2::ZERO;
    }
    let (drawn, sign) = if s % 2 == 1 { (s, 1.0) } else { (s - 1, -1.0) };
    let mut rng = LaneRngs::<1>::zero();
    rng.set(0, lane_seed(key, drawn as u64));
    let a = normal_f32_with::<Separate>(rng.next()[0]);
    let b = normal_f32_with::<Separate>(rng.next()[0]);
    DVec2::new(a as f64, b as f64) * sign
}

/// Agent `a`'s observed path: its history when the caller gave them, else the path of
/// constant velocity up to its state.
#[inline]
pub(super) fn history_of(histories: Option<&[History]>, a: usize, state: &State) -> History {
    match histories {
        Some(h) => h[a],
        None => History::from_state(state),
    }
}

/// The motion model's path of one agent at the call's steps, computed once per agent
/// ([`MotionPath::fill`]): at each step the mean (x, y) and the world frame's spread
/// factor (`a, b, c, d`: the normal pair `z` moves the mean by `(a z0 + b z1, c z0 +
/// d z1)`), one column per value.
#[derive(Debug, Clone, Default)]
pub(super) struct MotionPath {
    mean: [Vec<f64>; 2],
    spread: [Vec<f64>; 4],
}

impl MotionPath {
    /// The path of `forecast` at `steps` steps of `dt` seconds.
    pub(super) fn fill(&mut self, forecast: &Forecast<'_>, dt: f64, steps: usize) {
        for c in self.mean.iter_mut().chain(&mut self.spread) {
            c.clear();
        }
        for j in 0..steps {
            let (m, a, b) = forecast.frame((j + 1) as f64 * dt);
            for (c, v) in self.mean.iter_mut().zip([m.x, m.y]) {
                c.push(v);
            }
            for (c, v) in self.spread.iter_mut().zip([a.x, b.x, a.y, b.y]) {
                c.push(v);
            }
        }
    }

    /// Its steps.
    #[inline]
    pub(super) fn len(&self) -> usize {
        self.mean[0].len()
    }

    /// The position at step `j` on the normal pair `z`.
    #[inline]
    pub(super) fn point(&self, j: usize, z: DVec2) -> DVec2 {
        let ([mx, my], [a, b, c, d]) = (&self.mean, &self.spread);
        DVec2::new(
            mx[j] + a[j] * z.x + b[j] * z.y,
            my[j] + c[j] * z.x + d[j] * z.y,
        )
    }
}

/// Write the positions of `path` on the normal pair `z` into `track`.
#[inline]
pub(super) fn roll_motion(path: &MotionPath, z: DVec2, track: &mut [Point]) {
    for (j, out) in track.iter_mut().enumerate() {
        let p = path.point(j, z);
        *out = [p.x as f32, p.y as f32];
    }
}

/// The score of a motion sample on the path `z`: the standard normal pair's
/// log-density up to its constant.
#[inline]
pub(super) fn motion_score(z: DVec2) -> f32 {
    (-0.5 * z.length_squared()) as f32
}

/// The state of constant velocity of the last displacement: `state`'s position and time
/// with the velocity of the history's last step.
#[inline]
pub(super) fn last_displacement(state: &State, history: &History) -> State {
    let v = history.last_step() / MODEL_DT;
    State {
        speed: v.length(),
        heading: crate::math::wrap_2pi(v.y.atan2(v.x)),
        ..*state
    }
}

/// Observed steps slower than this (m/s) are a person standing: no evidence for or
/// against the map.
const MOVING: f64 = 0.2;

/// The weight of one moving step's log-likelihood ratio (the map's heading against a
/// uniform heading) in the map's evidence: the steps of one walk are far from
/// independent.
const EVIDENCE_WEIGHT: f64 = 0.3;

/// The prior log-odds against the map near the present (nats): before any step, the
/// map's evidence is `1 / (1 + e^2.5)`, about 0.08; the motion model leads until the
/// person's steps show the map explains them.
const EVIDENCE_PRIOR: f64 = 2.5;

/// `ln(2 pi)`: the log-density of a uniform heading is its negative.
const LOG_TAU: f64 = 1.837_877_066_409_345_3;

/// The largest log-likelihood ratio one step adds or takes from the evidence (nats);
/// a step with no map location near counts its negative.
const EVIDENCE_CLAMP: f64 = 2.0;

/// Seconds over which the exponent of the near share falls from 1 to its floor 1/2:
/// `e^max(exp(-t / SHARE_GROWTH), 1/2)`.
const SHARE_GROWTH: f64 = 5.0;

/// The prior log-odds against the map far out (nats, negative: for the person, the map),
/// reached from `FAR_PRIOR + FAR_PRIOR_START` at the present over `FAR_PRIOR_FALL` s.
const FAR_PRIOR: f64 = -0.5;

/// How far above [`FAR_PRIOR`] the far evidence's prior log-odds start (nats).
const FAR_PRIOR_START: f64 = 6.0;

/// Seconds over which the far evidence's prior falls to [`FAR_PRIOR`].
const FAR_PRIOR_FALL: f64 = 5.0;

/// The far-out prior log-odds against the map at `t` seconds ahead, as odds
/// (`exp(FAR_PRIOR + FAR_PRIOR_START exp(-t / FAR_PRIOR_FALL))`).
#[inline]
fn far_prior_odds(t: f64) -> f64 {
    (FAR_PRIOR + FAR_PRIOR_START * (-t / FAR_PRIOR_FALL).exp()).exp()
}

/// The map's likelihood ratio for this person, `exp(L)` (see the [module
/// documentation](self)): how much likelier their observed moving steps' headings are
/// under the map's mixtures (given each step's speed) than under a uniform heading, each
/// step's log-ratio clamped and weighted; 1 with no moving step, 0 when no moving step
/// has a map location near.
pub(super) fn map_evidence(
    map: &CliffMap,
    near: &impl Fn(DVec2) -> Option<usize>,
    history: &History,
) -> f64 {
    let p = history.points();
    let (mut log_odds, mut moving, mut located) = (0.0, false, false);
    for w in p.windows(2) {
        let v = (w[1] - w[0]) / MODEL_DT;
        let speed = v.length();
        if speed < MOVING {
            continue;
        }
        moving = true;
        let ratio = match near((w[0] + w[1]) * 0.5) {
            Some(i) => {
                located = true;
                let heading = crate::math::wrap_2pi(v.y.atan2(v.x));
                map.heading_log_density(i, heading, speed) + LOG_TAU
            }
            None => -EVIDENCE_CLAMP,
        };
        log_odds += EVIDENCE_WEIGHT * ratio.clamp(-EVIDENCE_CLAMP, EVIDENCE_CLAMP);
    }
    if moving && !located {
        return 0.0;
    }
    log_odds.exp()
}

/// The buffers of [`bend_to_motion`], grown once and reused from call to call.
#[derive(Debug, Clone, Default)]
pub(super) struct Bend {
    /// The motion model's path at each step of the call.
    pub(super) path: MotionPath,
    /// Per step: the exponent of the near share (`max(exp(-t / SHARE_GROWTH), 1/2)`),
    /// the blend's weight on the line and the far prior's odds ([`far_prior_odds`]), for
    /// the steps, step length and blend of `times_of` (the same for every agent of every
    /// call that has them).
    times: Vec<[f64; 3]>,
    times_of: Option<(usize, u64, u64)>,
    /// Per step of the agent being bent: the map's share, the blend's weight, and the
    /// constant-velocity line's point (x, y), one column each.
    at: [Vec<f64>; 4],
    /// The samples' normal pairs.
    normals: Vec<DVec2>,
    /// Per step: the sums of the bent samples' x and y.
    sums: Vec<[f64; 2]>,
}

/// The normal pairs of the first `k` samples of the agent keyed `key` ([`sample_normal`]
/// of each) into `out`.
fn sample_normals(key: u64, k: usize, out: &mut Vec<DVec2>) {
    out.clear();
    out.push(DVec2::ZERO);
    // the odd samples draw, eight generators side by side; the even ones are their
    // antithetic pairs
    const W: usize = 8;
    let drawn = k / 2;
    let mut first = 0;
    while out.len() < k {
        let n = (drawn - first).min(W);
        let mut rng = LaneRngs::<W>::zero();
        for l in 0..W {
            // (lanes past the last draw repeat it)
            rng.set(l, lane_seed(key, (2 * (first + l.min(n - 1)) + 1) as u64));
        }
        let (wa, wb) = (rng.next(), rng.next());
        let (mut a, mut b) = ([0.0f32; W], [0.0f32; W]);
        for l in 0..W {
            a[l] = normal_f32_with::<Separate>(wa[l]);
            b[l] = normal_f32_with::<Separate>(wb[l]);
        }
        for l in 0..n {
            let z = DVec2::new(a[l] as f64, b[l] as f64);
            out.push(z);
            out.push(-z);
        }
        first += n;
    }
    out.truncate(k);
}

/// Bend one agent's samples (`tracks`, `lens`: `k` samples of `steps`) towards the
/// motion model's path `bend.path` (see the [module documentation](self)), then make the
/// first sample their mean path: every sample then reaches the horizon. `evidence` is
/// the map's likelihood ratio for the person ([`map_evidence`]), `cv` the
/// constant-velocity line the blend left (its start, its step), `blend` the blend's seconds (0: none), `key` the agent's key. The
/// same bits on every path (`simd` only lets the compiler use wider registers).
#[allow(clippy::too_many_arguments)]
pub(super) fn bend_to_motion(
    bend: &mut Bend,
    evidence: f64,
    cv: (DVec2, DVec2),
    dt: f64,
    blend: f64,
    key: u64,
    tracks: &mut [Point],
    lens: &mut [u32],
    simd: Simd,
) {
    let steps = bend.path.len();
    if steps == 0 || lens.is_empty() {
        return;
    }
    // the exponents of the share and the blend's weights: the same for every agent
    let times_of = Some((steps, dt.to_bits(), blend.to_bits()));
    if bend.times_of != times_of {
        bend.times.clear();
        bend.times.extend((0..steps).map(|j| {
            let t = (j + 1) as f64 * dt;
            // the blend's weight on the line at this step (0: no blend)
            let w = if blend > 0.0 {
                (-(j as f64) * dt / blend).exp()
            } else {
                0.0
            };
            [(-t / SHARE_GROWTH).exp().max(0.5), w, far_prior_odds(t)]
        }));
        bend.times_of = times_of;
    }
    // the map's share at each step (one power per exponent: from about 3.5 s on the
    // exponent is 1/2 at every step)
    let near = evidence / (evidence + EVIDENCE_PRIOR.exp());
    let far = evidence * evidence;
    let mut last = (f64::NAN.to_bits(), 0.0);
    for c in &mut bend.at {
        c.clear();
    }
    for (j, &[e, w, far_prior]) in bend.times.iter().enumerate() {
        if e.to_bits() != last.0 {
            last = (e.to_bits(), near.powf(e));
        }
        let share = last.1.max(far / (far + far_prior));
        let line = cv.0 + cv.1 * (j + 1) as f64;
        for (c, v) in bend.at.iter_mut().zip([share, w, line.x, line.y]) {
            c.push(v);
        }
    }
    sample_normals(key, lens.len(), &mut bend.normals);
    bend.sums.clear();
    bend.sums.resize(steps, [0.0; 2]);
    let Bend {
        path,
        at,
        normals,
        sums,
        ..
    } = bend;
    match simd {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: a rollout's path is one the processor has.
        Simd::Avx2Fma => unsafe { bend_samples_avx2(path, at, normals, tracks, lens, sums) },
        _ => bend_samples(path, at, normals, tracks, lens, sums),
    }
    // the first sample: the samples' mean path
    let k = lens.len() as f64;
    for (out, [x, y]) in tracks.iter_mut().zip(sums.iter()) {
        *out = [(x / k) as f32, (y / k) as f32];
    }
}

/// [`bend_samples`] compiled for AVX2 (the same bits: no multiply-add is fused).
///
/// # Safety
/// The processor must have AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn bend_samples_avx2(
    path: &MotionPath,
    at: &[Vec<f64>; 4],
    normals: &[DVec2],
    tracks: &mut [Point],
    lens: &mut [u32],
    sums: &mut [[f64; 2]],
) {
    bend_samples(path, at, normals, tracks, lens, sums)
}

/// Bend each sample (`at`: the share, the blend's weight and the line's point at each
/// step; `normals`: each sample's normal pair), every sample to the horizon, adding its
/// bent positions (as written) to `sums`.
#[inline(always)]
fn bend_samples(
    path: &MotionPath,
    at: &[Vec<f64>; 4],
    normals: &[DVec2],
    tracks: &mut [Point],
    lens: &mut [u32],
    sums: &mut [[f64; 2]],
) {
    let steps = path.len();
    let ([mx, my], [fa, fb, fc, fd]) = (&path.mean, &path.spread);
    let [share, w, lx, ly] = at;
    let (mx, my, fa, fb, fc, fd) = (
        &mx[..steps],
        &my[..steps],
        &fa[..steps],
        &fb[..steps],
        &fc[..steps],
        &fd[..steps],
    );
    let (share, w, lx, ly) = (&share[..steps], &w[..steps], &lx[..steps], &ly[..steps]);
    let sums = &mut sums[..steps];
    for ((track, len), z) in tracks
        .chunks_exact_mut(steps)
        .zip(lens.iter_mut())
        .zip(normals)
    {
        let (zx, zy) = (z.x, z.y);
        let reached = (*len as usize).min(steps);
        // where the map stopped it, it stands: at its last point (moved as below), or,
        // stopped before its first step, on the model's first step
        let standing = match reached.checked_sub(1) {
            _ if reached == steps => DVec2::ZERO,
            None => path.point(0, *z),
            Some(j) => {
                let p = DVec2::new(track[j][0] as f64, track[j][1] as f64);
                p + (path.point(j, *z) - DVec2::new(lx[j], ly[j])) * w[j]
            }
        };
        // the steps the map's sample reached: the sample with its blend's weight on the
        // line moved onto the model, and the map's share of it
        let r = reached;
        for ((((((((((out, sum), mx), my), fa), fb), fc), fd), share), w), (lx, ly)) in track[..r]
            .iter_mut()
            .zip(sums[..r].iter_mut())
            .zip(&mx[..r])
            .zip(&my[..r])
            .zip(&fa[..r])
            .zip(&fb[..r])
            .zip(&fc[..r])
            .zip(&fd[..r])
            .zip(&share[..r])
            .zip(&w[..r])
            .zip(lx[..r].iter().zip(&ly[..r]))
        {
            let x = mx + fa * zx + fb * zy;
            let y = my + fc * zx + fd * zy;
            let sx = out[0] as f64 + (x - lx) * w;
            let sy = out[1] as f64 + (y - ly) * w;
            let p = [(x + (sx - x) * share) as f32, (y + (sy - y) * share) as f32];
            *out = p;
            sum[0] += p[0] as f64;
            sum[1] += p[1] as f64;
        }
        // the steps after: standing, and the map's share of that
        for (((((((out, sum), mx), my), fa), fb), (fc, fd)), share) in track[r..]
            .iter_mut()
            .zip(sums[r..].iter_mut())
            .zip(&mx[r..])
            .zip(&my[r..])
            .zip(&fa[r..])
            .zip(&fb[r..])
            .zip(fc[r..].iter().zip(&fd[r..]))
            .zip(&share[r..])
        {
            let x = mx + fa * zx + fb * zy;
            let y = my + fc * zx + fd * zy;
            let p = [
                (x + (standing.x - x) * share) as f32,
                (y + (standing.y - y) * share) as f32,
            ];
            *out = p;
            sum[0] += p[0] as f64;
            sum[1] += p[1] as f64;
        }
        *len = steps as u32;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::MotionModel;

    /// The map's share at one step from the person's likelihood ratio `odds`
    /// ([`map_evidence`]): the larger of the near share `near^exponent` (`near` the
    /// evidence against [`EVIDENCE_PRIOR`]) and the far share, the ratio squared against
    /// `far_prior` ([`far_prior_odds`]).
    fn share(near: f64, exponent: f64, odds: f64, far_prior: f64) -> f64 {
        let far = odds * odds;
        near.powf(exponent).max(far / (far + far_prior))
    }

    /// The bending one sample and one step at a time, as the module documentation
    /// writes it: the sample's point moved by the blend's weight from the line onto the
    /// model, or where it stopped, then `M + w(t) (S' - M)`; the first sample the mean.
    fn one_at_a_time(
        path: &MotionPath,
        evidence: f64,
        cv: (DVec2, DVec2),
        (dt, blend, key): (f64, f64, u64),
        tracks: &mut [Point],
        lens: &mut [u32],
    ) {
        let steps = path.len();
        for (s, (track, len)) in tracks
            .chunks_exact_mut(steps)
            .zip(lens.iter_mut())
            .enumerate()
        {
            let z = sample_normal(key, s);
            let reached = (*len as usize).min(steps);
            let mut last = DVec2::ZERO;
            for (j, out) in track.iter_mut().enumerate() {
                let m = path.point(j, z);
                let sample = if j < reached {
                    let w = if blend > 0.0 {
                        (-(j as f64) * dt / blend).exp()
                    } else {
                        0.0
                    };
                    let line = cv.0 + cv.1 * (j + 1) as f64;
                    DVec2::new(out[0] as f64, out[1] as f64) + (m - line) * w
                } else if j == 0 {
                    m
                } else {
                    last
                };
                last = sample;
                let t = (j + 1) as f64 * dt;
                let near = evidence / (evidence + EVIDENCE_PRIOR.exp());
                let exponent = (-t / SHARE_GROWTH).exp().max(0.5);
                let share = share(near, exponent, evidence, far_prior_odds(t));
                let p = m + (sample - m) * share;
                *out = [p.x as f32, p.y as f32];
            }
            *len = steps as u32;
        }
        let k = lens.len();
        for j in 0..steps {
            let (mut x, mut y) = (0.0f64, 0.0f64);
            for s in 0..k {
                x += tracks[s * steps + j][0] as f64;
                y += tracks[s * steps + j][1] as f64;
            }
            tracks[j] = [(x / k as f64) as f32, (y / k as f64) as f32];
        }
    }

    #[test]
    fn the_bending_gives_the_bits_of_one_sample_and_step_at_a_time_on_every_path() {
        let walker = State {
            position: DVec2::new(2.0, -1.0),
            speed: 1.3,
            heading: 0.4,
            time: 0.0,
        };
        let forecast = MotionModel::builtin().forecast(&History::from_state(&walker));
        let mut bend = Bend::default();
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        // step lengths, horizons (past the model's 12 s), blends (none too), odd and even k
        for (dt, steps, blend, k) in [(0.4, 30, 3.0, 20), (1.0, 50, 0.0, 7), (0.3, 11, 3.0, 1)] {
            bend.path.fill(&forecast, dt, steps);
            let cv = (
                walker.position,
                DVec2::from_angle(walker.heading) * (1.3 * dt),
            );
            for evidence in [0.0, 0.31, 1.0, 4.5, 60.0] {
                // samples stopped anywhere from before their first step to the horizon
                let lens: Vec<u32> = (0..k)
                    .map(|_| (next() % (steps as u64 + 1)) as u32)
                    .collect();
                let tracks: Vec<Point> = (0..k * steps)
                    .map(|_| {
                        [
                            (next() % 4000) as f32 * 0.01 - 20.0,
                            (next() % 3000) as f32 * 0.01,
                        ]
                    })
                    .collect();
                let key = next();
                let (mut want, mut want_lens) = (tracks.clone(), lens.clone());
                let times = (dt, blend, key);
                one_at_a_time(&bend.path, evidence, cv, times, &mut want, &mut want_lens);
                for simd in [Simd::Baseline, Simd::Avx2Fma]
                    .into_iter()
                    .filter(|s| s.available())
                {
                    let (mut got, mut got_lens) = (tracks.clone(), lens.clone());
                    bend_to_motion(
                        &mut bend,
                        evidence,
                        cv,
                        dt,
                        blend,
                        key,
                        &mut got,
                        &mut got_lens,
                        simd,
                    );
                    let bits =
                        |t: &[Point]| t.iter().map(|p| p.map(f32::to_bits)).collect::<Vec<_>>();
                    assert_eq!(
                        bits(&got),
                        bits(&want),
                        "dt {dt} k {k} evidence {evidence} {simd:?}"
                    );
                    assert_eq!(got_lens, want_lens);
                }
            }
        }
    }
}
