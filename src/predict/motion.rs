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
//! map's share ([`map_share`]):
//!
//! * the map's **evidence** for this person, `e`: the posterior odds that their observed
//!   moving steps (0.4 s steps over 0.2 m/s) came from the map's mixture at each step's
//!   place rather than from a uniform velocity, `e = 1 / (1 + exp(-L))`,
//!   `L = 0.3 sum_i clamp(log p_map(v_i) - log p_uniform, -2, 2)` (the steps of one walk
//!   are far from independent, hence the weight 0.3; the clamp keeps one odd step from
//!   deciding). A step with no location near counts -2. No moving step: `e = 1/2`. No
//!   location near any moving step: `e = 0`, the motion model alone;
//! * **growing with the horizon**: `w(t) = e^max(exp(-t / 5 s), 1/2)`, so near the
//!   present the share is the evidence and from about 3.5 s on its square root: far out
//!   a map with evidence for the person leads (the motion model knows the next seconds;
//!   the map knows where people go), and one with little still does not.
//!
//! So where the map is wrong or missing the samples are the motion model's, and where it
//! is right they are the map's, starting from the motion model near the present. Every
//! sample reaches the horizon. The first sample then becomes the samples' mean path (the
//! expected position at each step), the best-ranked under the consensus ranking; the
//! normal pairs come in antithetic pairs (sample `2 i` draws `-z` of sample `2 i - 1`), so
//! with no map the mean path is the motion model's expected path.

use glam::DVec2;

use super::Point;
use super::options::NO_LOCATION_LOG_DENSITY;
use crate::map::CliffMap;
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
/// ([`motion_path`]): the mean and the world frame's spread factor at each step.
pub(super) type MotionPath = [([f64; 2], [f64; 4])];

/// The position at step `j` of `path` on the normal pair `z`.
#[inline]
pub(super) fn path_point(path: &MotionPath, j: usize, z: DVec2) -> DVec2 {
    let (m, f) = path[j];
    DVec2::new(
        m[0] + f[0] * z.x + f[1] * z.y,
        m[1] + f[2] * z.x + f[3] * z.y,
    )
}

/// Write the positions of `path` on the normal pair `z` into `track`.
#[inline]
pub(super) fn roll_motion(path: &MotionPath, z: DVec2, track: &mut [Point]) {
    for (j, out) in track.iter_mut().enumerate() {
        let p = path_point(path, j, z);
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

/// The weight of one moving step's log-likelihood ratio (map against uniform) in the
/// map's evidence: the steps of one walk are far from independent.
const EVIDENCE_WEIGHT: f64 = 0.3;

/// The largest log-likelihood ratio one step adds or takes from the evidence (nats);
/// a step with no map location near counts its negative.
const EVIDENCE_CLAMP: f64 = 2.0;

/// Seconds over which the map's share grows from its evidence to the evidence's square
/// root: `w(t) = e^max(exp(-t / SHARE_GROWTH), 1/2)`.
const SHARE_GROWTH: f64 = 5.0;

/// The map's evidence for this person (see the [module documentation](self)): the
/// posterior probability that their observed moving steps come from the map's mixtures
/// rather than a uniform velocity; 1/2 with no moving step, 0 when no moving step has a
/// map location near.
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
                map.log_density(i, heading, speed) - NO_LOCATION_LOG_DENSITY
            }
            None => -EVIDENCE_CLAMP,
        };
        log_odds += EVIDENCE_WEIGHT * ratio.clamp(-EVIDENCE_CLAMP, EVIDENCE_CLAMP);
    }
    if moving && !located {
        return 0.0;
    }
    1.0 / (1.0 + (-log_odds).exp())
}

/// The map's share `t` seconds ahead given its `evidence`:
/// `evidence^max(exp(-t / SHARE_GROWTH), 1/2)`.
#[inline]
fn map_share(evidence: f64, t: f64) -> f64 {
    evidence.powf((-t / SHARE_GROWTH).exp().max(0.5))
}

/// The motion model's path at the call's steps into `path` (mean, and the world frame's
/// spread factor).
pub(super) fn motion_path(
    forecast: &Forecast<'_>,
    dt: f64,
    steps: usize,
    path: &mut Vec<([f64; 2], [f64; 4])>,
) {
    path.clear();
    for j in 0..steps {
        let t = (j + 1) as f64 * dt;
        let m = forecast.position(t, DVec2::ZERO);
        let a = forecast.position(t, DVec2::X) - m;
        let b = forecast.position(t, DVec2::Y) - m;
        path.push(([m.x, m.y], [a.x, b.x, a.y, b.y]));
    }
}

/// Bend one agent's samples (`tracks`, `lens`: `k` samples of `steps`) towards the
/// motion model (see the [module documentation](self)), then make the first sample their
/// mean path: every sample then reaches the horizon. `evidence` is the map's
/// ([`map_evidence`]), `shares` a buffer for the map's share and the blend's weight at
/// each step, `cv` the
/// constant-velocity line the blend left (its start, its step), `blend` the blend's
/// seconds (0: none), `key` the agent's key.
#[allow(clippy::too_many_arguments)]
pub(super) fn bend_to_motion(
    path: &MotionPath,
    shares: &mut Vec<[f64; 2]>,
    evidence: f64,
    cv: (DVec2, DVec2),
    dt: f64,
    blend: f64,
    key: u64,
    tracks: &mut [Point],
    lens: &mut [u32],
) {
    let steps = path.len();
    if steps == 0 || lens.is_empty() {
        return;
    }
    shares.clear();
    shares.extend((0..steps).map(|j| {
        // the blend's weight on the line at this step (0: no blend)
        let w = if blend > 0.0 {
            (-(j as f64) * dt / blend).exp()
        } else {
            0.0
        };
        [map_share(evidence, (j + 1) as f64 * dt), w]
    }));
    for (s, (track, len)) in tracks
        .chunks_exact_mut(steps)
        .zip(lens.iter_mut())
        .enumerate()
    {
        let z = sample_normal(key, s);
        let reached = (*len as usize).min(steps);
        let mut last = DVec2::ZERO;
        for (j, out) in track.iter_mut().enumerate() {
            let m = path_point(path, j, z);
            let sample = if j < reached {
                let p = DVec2::new(out[0] as f64, out[1] as f64);
                // the blend's weight on the line, moved onto the model
                let line = cv.0 + cv.1 * (j + 1) as f64;
                p + (m - line) * shares[j][1]
            } else if j == 0 {
                // stopped before its first step: it stands on the model's first step
                m
            } else {
                last
            };
            last = sample;
            let p = m + (sample - m) * shares[j][0];
            *out = [p.x as f32, p.y as f32];
        }
        *len = steps as u32;
    }
    // the first sample: the samples' mean path
    let k = lens.len();
    for j in 0..steps {
        let (mut x, mut y) = (0.0f64, 0.0f64);
        for s in 0..k {
            let p = tracks[s * steps + j];
            x += p[0] as f64;
            y += p[1] as f64;
        }
        tracks[j] = [(x / k as f64) as f32, (y / k as f64) as f32];
    }
}
