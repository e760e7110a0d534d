//! The motion model: how people walk on over the next seconds, learned from tracks.
//!
//! A [`MotionModel`] reads a person's [`History`] (the last 2.8 s on a 0.4 s grid) in
//! the walker's own frame (x along the direction from the oldest to the newest point, y
//! to its left), so it holds for any site and heading, and gives for every future step
//! of its grid the expected displacement from the newest position (a regularised linear
//! function of the seven observed displacements and a constant: ridge regression,
//! [`fit`](super::fit_motion_model), optionally corrected by a small
//! [`Network`](super::network::Network) where walking is not linear in the history) and
//! its spread (the covariance of the fit's residuals at that step). A sample of the model draws one standard normal pair `z`
//! and walks `mean_j + L_j z` (with `L_j` the Cholesky factor of step `j`'s spread), so
//! a sample that starts to the left of the expected path stays to its left. Past the
//! model's last step the path goes on at the velocity of its last step, and its spread
//! grows as in its last step.
//!
//! Forecasting one person computes the features and `2 x steps` dot products of 15 terms
//! (and the network's layers, when the model has one) into a [`Forecast`] on the stack:
//! no allocation, under a microsecond.
//!
//! ```
//! use cliff::motion::{History, MotionModel, State};
//! use glam::DVec2;
//!
//! let model = MotionModel::builtin();
//! let walker = State { position: DVec2::new(2.0, 1.0), speed: 1.2, heading: 0.0, time: 0.0 };
//! let forecast = model.forecast(&History::from_state(&walker));
//! let ahead = forecast.position(4.0, DVec2::ZERO); // the expected position 4 s ahead
//! assert!(ahead.x > 2.0 + 3.0 && (ahead.y - 1.0).abs() < 0.5, "{ahead}");
//! ```

use glam::DVec2;

use super::history::{HISTORY_POINTS, History, MODEL_DT};
use super::network::Network;

/// Coefficients of one output: two per observed displacement and a constant.
pub const FEATURES: usize = 2 * (HISTORY_POINTS - 1) + 1;

/// Most grid steps a model may forecast (60 s at [`MODEL_DT`]).
pub const MAX_MODEL_STEPS: usize = 150;

const _: () = assert!(2 * MAX_MODEL_STEPS <= super::network::MAX_OUTPUTS);
const _: () = assert!(FEATURES == super::network::INPUTS + 1);

/// Largest absolute coefficient a model may hold (a file with larger ones is refused:
/// no fit on walking people comes near it).
pub(super) const MAX_COEFFICIENT: f64 = 1.0e3;

/// What a model was fitted on and with (kept in its file, shown by `cliff motion`).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ModelInfo {
    /// Windows of history and future the fit used (mirrored copies not counted).
    pub windows: u64,
    /// The ridge penalty (m^2) on the displacement coefficients.
    pub lambda: f64,
    /// Steps faster than this (m/s) were taken as tracking jumps and left out.
    pub max_speed: f64,
    /// What the fit read (file names, or a description).
    pub source: String,
}

/// A learned motion model (see the [module documentation](self)).
#[derive(Debug, Clone, PartialEq)]
pub struct MotionModel {
    /// Per grid step: the coefficients of the forward and the left displacement.
    weights: Vec<[[f64; FEATURES]; 2]>,
    /// Per grid step: the residuals' covariance in the walker's frame `[xx, xy, yy]`.
    covariance: Vec<[f64; 3]>,
    /// Per grid step: its Cholesky factor `[l00, l10, l11]` (from `covariance`).
    factor: Vec<[f64; 3]>,
    /// The network's corrections to the linear part, when the model has one.
    network: Option<Network>,
    info: ModelInfo,
}

/// A person's forecast by a [`MotionModel`]: the expected path and its spread, in the
/// world frame. Made by [`MotionModel::forecast`]; lives on the stack.
#[derive(Debug, Clone, Copy)]
pub struct Forecast<'a> {
    model: &'a MotionModel,
    origin: DVec2,
    forward: DVec2,
    mean: [DVec2; MAX_MODEL_STEPS],
}

/// Why a model's values are unusable.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct ModelValueError(pub String);

impl MotionModel {
    /// A model from its coefficients and residual covariances (one entry per grid step,
    /// at most [`MAX_MODEL_STEPS`]); every value is checked.
    pub fn new(
        weights: Vec<[[f64; FEATURES]; 2]>,
        covariance: Vec<[f64; 3]>,
        info: ModelInfo,
    ) -> Result<Self, ModelValueError> {
        let bad = |m: String| Err(ModelValueError(m));
        if weights.is_empty() || weights.len() > MAX_MODEL_STEPS {
            return bad(format!(
                "{} forecast steps, a model holds 1 to {MAX_MODEL_STEPS}",
                weights.len()
            ));
        }
        if covariance.len() != weights.len() {
            return bad(format!(
                "{} spreads for {} forecast steps",
                covariance.len(),
                weights.len()
            ));
        }
        for (j, w) in weights.iter().enumerate() {
            if let Some(v) = w
                .iter()
                .flatten()
                .find(|v| !v.is_finite() || v.abs() > MAX_COEFFICIENT)
            {
                return bad(format!(
                    "step {}: coefficient {v} is not a number within {MAX_COEFFICIENT}",
                    j + 1
                ));
            }
        }
        let mut factor = Vec::with_capacity(covariance.len());
        for (j, &[xx, xy, yy]) in covariance.iter().enumerate() {
            let ok = [xx, xy, yy].iter().all(|v| v.is_finite() && v.abs() <= 1e4);
            if !ok || xx < 0.0 || yy < 0.0 || xy * xy > xx * yy * (1.0 + 1e-9) + 1e-12 {
                return bad(format!(
                    "step {}: spread [{xx}, {xy}, {yy}] is not a covariance",
                    j + 1
                ));
            }
            let l00 = xx.sqrt();
            let l10 = if l00 > 0.0 { xy / l00 } else { 0.0 };
            let l11 = (yy - l10 * l10).max(0.0).sqrt();
            factor.push([l00, l10, l11]);
        }
        if !(info.lambda.is_finite() && info.lambda >= 0.0) {
            return bad(format!(
                "ridge penalty {} is not a non-negative number",
                info.lambda
            ));
        }
        if !(info.max_speed.is_finite() && info.max_speed > 0.0) {
            return bad(format!(
                "largest speed {} is not a positive number",
                info.max_speed
            ));
        }
        Ok(Self {
            weights,
            covariance,
            factor,
            network: None,
            info,
        })
    }

    /// The model with `network` correcting its linear part (its shapes and values are
    /// checked against the model's steps).
    pub fn with_network(mut self, network: Network) -> Result<Self, ModelValueError> {
        network.check(self.steps()).map_err(ModelValueError)?;
        self.network = Some(network);
        Ok(self)
    }

    /// The network correcting the linear part, if the model has one.
    pub fn network(&self) -> Option<&Network> {
        self.network.as_ref()
    }

    /// Grid steps the model forecasts ([`MODEL_DT`] each) before it goes on at its last
    /// step's velocity.
    pub fn steps(&self) -> usize {
        self.weights.len()
    }

    /// The coefficients of every step: `[forward, left]`, each over the observed
    /// displacements (forward, left of each, oldest first) and a constant.
    pub fn weights(&self) -> &[[[f64; FEATURES]; 2]] {
        &self.weights
    }

    /// The residuals' covariance of every step in the walker's frame, `[xx, xy, yy]`.
    pub fn covariance(&self) -> &[[f64; 3]] {
        &self.covariance
    }

    /// What the model was fitted on and with.
    pub fn info(&self) -> &ModelInfo {
        &self.info
    }

    /// The forecast for a person with this history.
    #[inline]
    pub fn forecast(&self, history: &History) -> Forecast<'_> {
        let (forward, features) = features(history);
        let left = forward.perp();
        let mut mean = [DVec2::ZERO; MAX_MODEL_STEPS];
        self.local_means(&features, &mut mean);
        for m in mean.iter_mut().take(self.steps()) {
            *m = forward * m.x + left * m.y;
        }
        Forecast {
            model: self,
            origin: history.last(),
            forward,
            mean,
        }
    }
}

impl MotionModel {
    /// The expected displacement at every step in the walker's frame (forward, left)
    /// for `features`, into `out[..steps]`: the linear part, plus the network's
    /// corrections when the model has one.
    #[inline]
    pub(super) fn local_means(&self, features: &[f64; FEATURES], out: &mut [DVec2]) {
        for (m, w) in out.iter_mut().zip(&self.weights) {
            *m = DVec2::new(dot(&w[0], features), dot(&w[1], features));
        }
        if let Some(net) = &self.network {
            net.add_to(features, out);
        }
    }
}

/// The walker's frame (its forward axis) and the model's inputs: the observed
/// displacements in that frame, oldest first, and a constant 1.
#[inline]
pub(super) fn features(history: &History) -> (DVec2, [f64; FEATURES]) {
    let p = history.points();
    let span = p[HISTORY_POINTS - 1] - p[0];
    let len = span.length();
    // a person standing still has no direction of their own: the x axis stands in
    let forward = if len > 1e-3 { span / len } else { DVec2::X };
    let left = forward.perp();
    let mut f = [0.0; FEATURES];
    for i in 0..HISTORY_POINTS - 1 {
        let d = p[i + 1] - p[i];
        f[2 * i] = d.dot(forward);
        f[2 * i + 1] = d.dot(left);
    }
    f[FEATURES - 1] = 1.0;
    (forward, f)
}

#[inline]
pub(super) fn dot(w: &[f64; FEATURES], f: &[f64; FEATURES]) -> f64 {
    w.iter().zip(f).map(|(a, b)| a * b).sum()
}

impl Forecast<'_> {
    /// Where the person is `t` seconds ahead on the path of the standard normal pair
    /// `z` (`DVec2::ZERO`: the expected path): linear between the grid's steps, past the
    /// model's last step on at that step's velocity (and spread).
    #[inline]
    pub fn position(&self, t: f64, z: DVec2) -> DVec2 {
        let s = (t / MODEL_DT).max(0.0);
        self.at_grid(s, s.floor() as usize, z)
    }

    /// The expected position `t` seconds ahead and the world frame's spread there: how
    /// far the paths of `z = (1, 0)` and of `z = (0, 1)` are from it (as
    /// [`position`](Self::position) gives them, the same bits).
    #[inline]
    pub fn frame(&self, t: f64) -> (DVec2, DVec2, DVec2) {
        let s = (t / MODEL_DT).max(0.0);
        let i = s.floor() as usize;
        let m = self.at_grid(s, i, DVec2::ZERO);
        (
            m,
            self.at_grid(s, i, DVec2::X) - m,
            self.at_grid(s, i, DVec2::Y) - m,
        )
    }

    /// [`position`](Self::position) at `s` grid steps ahead (`i` its floor).
    #[inline(always)]
    fn at_grid(&self, s: f64, i: usize, z: DVec2) -> DVec2 {
        let n = self.model.steps();
        let offset = if i >= n {
            let last = self.offset(n, z);
            let before = self.offset(n - 1, z);
            last + (last - before) * (s - n as f64)
        } else {
            let a = self.offset(i, z);
            let b = self.offset(i + 1, z);
            a.lerp(b, s - i as f64)
        };
        self.origin + offset
    }

    /// The offset from the newest position at grid step `j` (0: none) on the path `z`.
    #[inline(always)]
    fn offset(&self, j: usize, z: DVec2) -> DVec2 {
        if j == 0 {
            return DVec2::ZERO;
        }
        let [l00, l10, l11] = self.model.factor[j - 1];
        let local = DVec2::new(l00 * z.x, l10 * z.x + l11 * z.y);
        self.mean[j - 1] + self.forward * local.x + self.forward.perp() * local.y
    }

    /// The newest observed position, where every path starts.
    pub fn origin(&self) -> DVec2 {
        self.origin
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::State;

    /// A model that continues the last displacement (constant velocity), spread
    /// `s^2 j` along and across.
    fn constant_velocity(steps: usize, s: f64) -> MotionModel {
        let mut w = [[0.0; FEATURES]; 2];
        w[0][2 * (HISTORY_POINTS - 2)] = 1.0;
        w[1][2 * (HISTORY_POINTS - 2) + 1] = 1.0;
        let weights = (1..=steps)
            .map(|j| {
                let mut wj = w;
                for v in wj.iter_mut().flatten() {
                    *v *= j as f64;
                }
                wj
            })
            .collect();
        let cov = (1..=steps)
            .map(|j| [s * s * j as f64, 0.0, s * s * j as f64])
            .collect();
        MotionModel::new(weights, cov, info()).unwrap()
    }

    fn info() -> ModelInfo {
        ModelInfo {
            windows: 1,
            lambda: 1.0,
            max_speed: 3.0,
            source: "test".into(),
        }
    }

    #[test]
    fn a_constant_velocity_model_walks_on_in_the_world_frame() {
        let m = constant_velocity(12, 0.1);
        // walking north-west at 1 m/s
        let heading = 3.0 * std::f64::consts::FRAC_PI_4;
        let s = State {
            position: DVec2::new(5.0, -2.0),
            speed: 1.0,
            heading,
            time: 0.0,
        };
        let f = m.forecast(&History::from_state(&s));
        let dir = DVec2::from_angle(heading);
        for t in [0.4, 1.0, 4.8, 10.0] {
            let p = f.position(t, DVec2::ZERO);
            assert!(p.distance(s.position + dir * t) < 1e-9, "{t}: {p}");
        }
        // z = (1, 0) is along the heading by the spread's factor at 2 steps
        let p = f.position(0.8, DVec2::new(1.0, 0.0));
        assert!(p.distance(s.position + dir * (0.8 + 0.1 * 2f64.sqrt())) < 1e-9);
        // z = (0, 1) is to the walker's left
        let p = f.position(0.8, DVec2::new(0.0, 1.0));
        assert!(p.distance(s.position + dir * 0.8 + dir.perp() * 0.1 * 2f64.sqrt()) < 1e-9);
    }

    #[test]
    fn values_that_are_no_model_are_refused() {
        let m = constant_velocity(3, 0.1);
        let w = m.weights().to_vec();
        let c = m.covariance().to_vec();
        assert!(MotionModel::new(vec![], vec![], info()).is_err());
        assert!(MotionModel::new(w.clone(), c[..2].to_vec(), info()).is_err());
        let mut nan = w.clone();
        nan[1][0][3] = f64::NAN;
        let e = MotionModel::new(nan, c.clone(), info()).unwrap_err();
        assert!(e.0.contains("step 2"), "{e}");
        let mut cov = c.clone();
        cov[2] = [1.0, 2.0, 1.0];
        let e = MotionModel::new(w.clone(), cov, info()).unwrap_err();
        assert!(
            e.0.contains("step 3") && e.0.contains("not a covariance"),
            "{e}"
        );
        let neg = ModelInfo {
            lambda: -1.0,
            ..info()
        };
        assert!(MotionModel::new(w, c, neg).is_err());
    }
}
