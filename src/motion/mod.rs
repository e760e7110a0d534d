//! Motion state, the observed velocity of a tracked person, and the learned motion model.
//!
//! | file | what it holds |
//! |---|---|
//! | `mod.rs` | [`State`], the observed velocity from a history (below) |
//! | [`speed_prior`] | [`SpeedPrior`]: how the speed ahead regresses to the typical one |
//! | [`history`] | [`History`]: a person's recent path on the motion model's grid |
//! | [`model`] | [`MotionModel`] and its [`Forecast`]: how people walk on, learned from tracks |
//! | [`model_fit`] | [`fit_motion_model`], [`motion_model_errors`]: fitting and scoring a model |
//! | [`network`] | [`Network`]: the small network that corrects the linear part where walking is not linear |
//! | `network_fit` | [`NetworkFit`]: training the network (Adam on the mean displacement error) |
//! | [`model_file`] | `.motion` files ([`MotionModel::load`], [`MotionModel::save`]) |
//! | `model_builtin` | the built-in model ([`MotionModel::builtin`]) |
//!
//! A prediction starts from a [`State`]: position, speed and heading at a time. The
//! observed velocity comes from the recent history with Gaussian weights
//! `g(t) = exp(-t^2 / (2 sigma^2))`, `t = 1..n`, normalised to sum one, the largest on
//! the most recent row (the reference uses `sigma = 1.5`):
//!
//! * [`velocity_from_speed_angle`]: from a tracker's speed and heading columns (the
//!   reference rule);
//! * [`velocity_from_positions`]: from timestamped positions only (finite differences),
//!   for callers that only track positions.
//!
//! ```
//! use cliff::motion::{velocity_from_positions, DEFAULT_SIGMA};
//! use glam::DVec2;
//! // walking east at 1 m/s
//! let t = [0.0, 0.4, 0.8, 1.2];
//! let p = [DVec2::new(0.0, 0.0), DVec2::new(0.4, 0.0), DVec2::new(0.8, 0.0), DVec2::new(1.2, 0.0)];
//! let v = velocity_from_positions(&t, &p, DEFAULT_SIGMA).unwrap();
//! assert!((v.speed - 1.0).abs() < 1e-9 && v.heading.abs() < 1e-9);
//! ```

use glam::DVec2;

use crate::math::wrap_2pi;

pub mod history;
pub mod model;
mod model_builtin;
pub mod model_file;
pub mod model_fit;
pub mod network;
mod network_fit;
pub mod speed_prior;
pub use history::{HISTORY_POINTS, History, MODEL_DT};
pub use model::{FEATURES, Forecast, MAX_MODEL_STEPS, ModelInfo, ModelValueError, MotionModel};
pub use model_builtin::BUILTIN_MOTION_BYTES;
pub use model_file::{MAX_MOTION_FILE_BYTES, MOTION_MAGIC, MOTION_VERSION, MotionError};
pub use model_fit::{
    FitError, HorizonErrors, MAX_EPOCHS, MAX_NETWORK_WINDOWS, MotionFit, NetworkFit,
    fit_motion_model, fit_motion_model_sources, motion_model_errors,
};
pub use network::{MAX_HIDDEN, Network};
pub use speed_prior::{MAX_PRIOR_SPEED, SpeedPrior};

/// The reference's velocity kernel width.
pub const DEFAULT_SIGMA: f64 = 1.5;

/// A person's motion state at one time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct State {
    /// Position (m).
    pub position: DVec2,
    /// Speed (m/s).
    pub speed: f64,
    /// Heading (rad, `[0, 2pi)`).
    pub heading: f64,
    /// Time (s).
    pub time: f64,
}

/// A speed and a heading.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Velocity {
    /// Speed (m/s).
    pub speed: f64,
    /// Heading (rad, `[0, 2pi)`).
    pub heading: f64,
}

/// Why an observed velocity could not be computed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum HistoryError {
    /// Too few rows.
    #[error("history has {got} rows, needs at least {need}")]
    TooShort {
        /// Rows given.
        got: usize,
        /// Rows needed.
        need: usize,
    },
    /// Timestamps do not increase.
    #[error("history time does not increase at row {0}")]
    NotIncreasing(usize),
    /// A value is NaN or infinite.
    #[error("history row {0} has a non-finite value")]
    NonFinite(usize),
    /// Input slices differ in length.
    #[error("history columns differ in length")]
    LengthMismatch,
}

/// Weights `g(t)`, `t = 1..n`, normalised, written oldest first (so `w[n-1]` is the
/// largest, for the most recent row).
fn weights(n: usize, sigma: f64, out: &mut [f64]) {
    let mut total = 0.0;
    for (i, w) in out[..n].iter_mut().enumerate() {
        let t = (n - i) as f64;
        *w = (-t * t / (2.0 * sigma * sigma)).exp();
        total += *w;
    }
    for w in &mut out[..n] {
        *w /= total;
    }
}

/// Weighted speed and circular mean heading of rows given oldest first.
fn weighted(
    speeds: impl Iterator<Item = f64>,
    angles: impl Iterator<Item = f64>,
    n: usize,
    sigma: f64,
) -> Velocity {
    const STACK: usize = 64;
    let mut buf = [0.0f64; STACK];
    let mut heap;
    let w: &mut [f64] = if n <= STACK {
        &mut buf[..n]
    } else {
        heap = vec![0.0; n];
        &mut heap
    };
    weights(n, sigma, w);
    let speed = speeds.zip(w.iter()).map(|(s, w)| s * w).sum();
    let (mut s, mut c) = (0.0, 0.0);
    for (a, w) in angles.zip(w.iter()) {
        s += w * a.sin();
        c += w * a.cos();
    }
    Velocity {
        speed,
        heading: wrap_2pi(s.atan2(c)),
    }
}

/// Observed velocity from speed and heading columns (oldest row first): weighted speed
/// and weighted circular mean heading. The reference rule.
pub fn velocity_from_speed_angle(
    speeds: &[f64],
    angles: &[f64],
    sigma: f64,
) -> Result<Velocity, HistoryError> {
    if speeds.len() != angles.len() {
        return Err(HistoryError::LengthMismatch);
    }
    if speeds.is_empty() {
        return Err(HistoryError::TooShort { got: 0, need: 1 });
    }
    if let Some(i) = speeds
        .iter()
        .zip(angles)
        .position(|(s, a)| !s.is_finite() || !a.is_finite())
    {
        return Err(HistoryError::NonFinite(i));
    }
    Ok(weighted(
        speeds.iter().copied(),
        angles.iter().copied(),
        speeds.len(),
        sigma,
    ))
}

/// Observed velocity from timestamped positions (oldest first): the velocities of the
/// `n - 1` finite differences, weighted as in the reference rule (speed by weighted sum,
/// heading by weighted circular mean).
pub fn velocity_from_positions(
    times: &[f64],
    positions: &[DVec2],
    sigma: f64,
) -> Result<Velocity, HistoryError> {
    if times.len() != positions.len() {
        return Err(HistoryError::LengthMismatch);
    }
    if times.len() < 2 {
        return Err(HistoryError::TooShort {
            got: times.len(),
            need: 2,
        });
    }
    for i in 0..times.len() {
        if !times[i].is_finite() || !positions[i].is_finite() {
            return Err(HistoryError::NonFinite(i));
        }
        if i > 0 && times[i] <= times[i - 1] {
            return Err(HistoryError::NotIncreasing(i));
        }
    }
    let vel = |i: usize| (positions[i + 1] - positions[i]) / (times[i + 1] - times[i]);
    let n = times.len() - 1;
    Ok(weighted(
        (0..n).map(|i| vel(i).length()),
        (0..n).map(|i| vel(i).to_angle()),
        n,
        sigma,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{PI, TAU};

    #[test]
    fn weights_favour_the_most_recent_row() {
        let mut w = [0.0; 8];
        weights(8, 1.5, &mut w);
        assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        assert!(w.windows(2).all(|p| p[0] < p[1]));
        // g(1)/g(2) = exp(3 / 4.5)
        assert!((w[7] / w[6] - (3.0f64 / 4.5).exp()).abs() < 1e-12);
    }

    #[test]
    fn heading_mean_wraps_around_zero() {
        let v = velocity_from_speed_angle(&[1.0, 1.0], &[TAU - 0.1, 0.1], 1e9).unwrap();
        assert!(v.heading < 1e-9 || v.heading > TAU - 1e-9, "{}", v.heading);
        let v =
            velocity_from_speed_angle(&[1.0, 1.0, 1.0], &[-PI + 0.05, PI - 0.05, PI], 1.5).unwrap();
        assert!((v.heading - PI).abs() < 0.05, "{}", v.heading);
        assert!((0.0..TAU).contains(&v.heading));
    }

    #[test]
    fn positions_rule_matches_speed_angle_rule_on_consistent_data() {
        let t: Vec<f64> = (0..9).map(|i| i as f64 * 0.4).collect();
        let p: Vec<DVec2> = t.iter().map(|&t| DVec2::new(t * t * 0.5, -t)).collect();
        let v = velocity_from_positions(&t, &p, 1.5).unwrap();
        let speeds: Vec<f64> = (0..8).map(|i| ((p[i + 1] - p[i]) / 0.4).length()).collect();
        let angles: Vec<f64> = (0..8)
            .map(|i| ((p[i + 1] - p[i]) / 0.4).to_angle())
            .collect();
        let w = velocity_from_speed_angle(&speeds, &angles, 1.5).unwrap();
        assert!((v.speed - w.speed).abs() < 1e-12 && (v.heading - w.heading).abs() < 1e-12);
    }

    #[test]
    fn bad_histories_are_refused() {
        assert_eq!(
            velocity_from_positions(&[0.0], &[DVec2::ZERO], 1.5),
            Err(HistoryError::TooShort { got: 1, need: 2 })
        );
        assert_eq!(
            velocity_from_positions(&[0.0, 0.0], &[DVec2::ZERO, DVec2::ONE], 1.5),
            Err(HistoryError::NotIncreasing(1))
        );
        assert_eq!(
            velocity_from_positions(&[0.0, 1.0], &[DVec2::ZERO, DVec2::NAN], 1.5),
            Err(HistoryError::NonFinite(1))
        );
        assert_eq!(
            velocity_from_speed_angle(&[1.0], &[], 1.5),
            Err(HistoryError::LengthMismatch)
        );
    }
}
