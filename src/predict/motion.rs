//! The motion model's samples ([`Method::Motion`](super::Method::Motion)) and constant
//! velocity of the last displacement ([`Method::CvmLast`](super::Method::CvmLast)).
//!
//! A motion sample walks the model's [`Forecast`] on a path of its own: sample `s` of
//! an agent draws a standard normal pair `z` from its generator (keyed as every
//! sample's, `lane_seed(agent key, s)`: two words, each a normal by the inverse
//! distribution function) and its positions are the forecast's at `j dt` on `z`; the
//! first sample (`s = 0`) is the expected path (`z = 0`). Its score is the log-density of
//! `z`, `-|z|^2 / 2`, so the best-ranked sample is the expected path. Every sample
//! reaches the horizon.

use glam::DVec2;

use super::Point;
use crate::math::lane_rng::{LaneRngs, lane_seed, normal_f32_with};
use crate::math::simd::Separate;
use crate::motion::{Forecast, History, MODEL_DT, State};

/// The normal pair of sample `s` of the agent keyed `key` (zero for the first sample).
#[inline]
pub(super) fn sample_normal(key: u64, s: usize) -> DVec2 {
    if s == 0 {
        return DVec2::ZERO;
    }
    let mut rng = LaneRngs::<1>::zero();
    rng.set(0, lane_seed(key, s as u64));
    let a = normal_f32_with::<Separate>(rng.next()[0]);
    let b = normal_f32_with::<Separate>(rng.next()[0]);
    DVec2::new(a as f64, b as f64)
}

/// Write the forecast's positions at `dt, 2 dt, ...` on the path `z` into `track`.
#[inline]
pub(super) fn roll_motion(forecast: &Forecast<'_>, dt: f64, z: DVec2, track: &mut [Point]) {
    for (j, out) in track.iter_mut().enumerate() {
        let p = forecast.position((j + 1) as f64 * dt, z);
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
