//! Constant velocity: a sample that goes on with the observed velocity, and its score.

use glam::DVec2;

use super::Point;
use super::options::NO_LOCATION_LOG_DENSITY;
use crate::map::CliffMap;
use crate::motion::State;

#[inline]
pub(super) fn roll_cvm(state: &State, dt: f64, track: &mut [Point]) {
    let step = DVec2::from_angle(state.heading) * (state.speed * dt);
    let mut p = state.position;
    for out in track.iter_mut() {
        p += step;
        *out = [p.x as f32, p.y as f32];
    }
}

/// The score of a constant-velocity sample: each step at the location near the position
/// it starts from (or [`NO_LOCATION_LOG_DENSITY`]).
#[inline]
pub(super) fn cvm_score(
    map: &CliffMap,
    near: &impl Fn(DVec2) -> Option<usize>,
    state: &State,
    dt: f64,
    steps: usize,
) -> f64 {
    let step = DVec2::from_angle(state.heading) * (state.speed * dt);
    let (uy, ux) = state.heading.sin_cos();
    let (ux, uy) = (ux as f32, uy as f32);
    let mut p = state.position;
    let mut score = 0.0;
    for _ in 0..steps {
        score += match near(p) {
            Some(i) => map.step_log_density(i, ux, uy, state.speed),
            None => NO_LOCATION_LOG_DENSITY,
        };
        p += step;
    }
    score
}
