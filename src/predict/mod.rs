//! CLiFF-LHMP and constant-velocity prediction into reusable batch buffers.
//!
//! [`predict`] rolls `k` samples forward for every agent and writes them into a
//! caller-owned [`TrajectoryBatch`] (or, through [`predict_into`], into any pair of
//! slices such as a shared-memory response). Once the buffer is sized, a call does not
//! allocate. Each sample draws from a small generator of its own (xoshiro128++), seeded
//! from its agent's key and its place among the agent's samples; the agent's key comes
//! from [`Params::seed`] and the agent's place in the call (the first agent's from the
//! seed itself, so a one-agent call is a call with that seed). An agent's samples
//! advance in lockstep (groups of up to 20, or eight to a register on AVX2), every
//! sample taking the same number of words from its generator at every step, so a
//! sample's draws do not depend on the others. The same map, states and parameters give
//! the same bytes, whether the agents are predicted in one call, in chunks, or on several
//! threads ([`predict_batch`]); on one instruction path ([`Simd`](crate::math::Simd)).
//!
//! ```
//! use cliff::map::CliffMap;
//! use cliff::motion::State;
//! use cliff::predict::{predict, Params, TrajectoryBatch};
//! use glam::DVec2;
//!
//! let map = CliffMap::demo();
//! let walker = State { position: DVec2::new(-10.0, 0.5), speed: 1.2, heading: 0.0, time: 0.0 };
//! let params = Params { k: 20, dt: 0.4, horizon: 12.0, ..Params::default() };
//! let mut batch = TrajectoryBatch::new();
//! predict(&map, &[walker], &params, &mut batch).unwrap();
//! assert_eq!(batch.shape(), (1, 20, 30));
//! let first = batch.sample(0, 0);
//! assert!(!first.is_empty() && first[0][0] > -10.0); // moving east
//! ```

mod batch;
mod call;
mod candidates;
mod cvm;
mod flow_memo;
mod flow_walk;
mod lanes;
#[cfg(target_arch = "x86_64")]
mod lanes_avx2;
#[cfg(target_arch = "x86_64")]
mod lanes_options_avx2;
mod motion;
mod options;
pub mod preset;
mod prune;
mod rollout;
mod seeds;
mod with_options;

use std::fmt;
use std::str::FromStr;

use crate::map::CliffMap;
use crate::motion::State;

pub use batch::{BatchMut, Point, TrajectoryBatch};
pub use options::{
    CONSENSUS_STEP_PENALTY, Checkpoint, NO_LOCATION_LOG_DENSITY, Options, PRUNE_SCHEDULE, Rank,
};
pub use rollout::{Rollout, Tables};
pub use with_options::{
    predict_batch, predict_batch_into, predict_into_with, predict_with, predict_with_histories,
};

/// Prediction method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Method {
    /// CLiFF-LHMP: constant velocity bent towards directions sampled from the map.
    #[default]
    Cliff,
    /// Constant velocity: never turns, never stops.
    Cvm,
    /// CLiFF-LHMP with the settings of the [`preset::IMPROVED`] preset (beyond the
    /// paper: a heading kernel of beta 2 and a score per sample); its content is set by
    /// the project's held-out experiments. Resolved by [`preset::resolve`].
    Improved,
    /// The learned motion model alone ([`MotionModel`](crate::motion::MotionModel), the
    /// built-in one unless [`Rollout::with_motion_model`] names another): how people
    /// walk on from their last 2.8 s, without a map; the first sample is the expected
    /// path, the others spread as the model's residuals did. Every sample reaches the
    /// horizon. From observed histories
    /// ([`predict_with_histories`]); from bare states, from the path of constant velocity
    /// up to the state.
    Motion,
    /// Constant velocity of the last observed displacement (the THÖR-MAGNI benchmark's
    /// baseline): from observed histories ([`predict_with_histories`]) the velocity of
    /// the history's last step; from bare states the state's velocity, as [`Method::Cvm`].
    CvmLast,
}

impl Method {
    /// Every method, in the order of their wire codes.
    pub const ALL: [Method; 5] = [
        Method::Cliff,
        Method::Cvm,
        Method::Improved,
        Method::Motion,
        Method::CvmLast,
    ];

    /// The method's name on the command line and in reports (`cliff`, `cvm`,
    /// `improved`).
    pub fn name(self) -> &'static str {
        match self {
            Method::Cliff => "cliff",
            Method::Cvm => "cvm",
            Method::Improved => "improved",
            Method::Motion => "motion",
            Method::CvmLast => "cvm-last",
        }
    }

    /// True for the methods that sample from the map (every method but constant
    /// velocity): they need the map's neighbour table for the sampling radius, and
    /// their samples differ from seed to seed.
    pub fn samples_map(self) -> bool {
        matches!(self, Method::Cliff | Method::Improved)
    }

    /// True for the methods whose every sample is the same path (constant velocity):
    /// one sample stands for all.
    pub fn is_deterministic(self) -> bool {
        matches!(self, Method::Cvm | Method::CvmLast)
    }
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Method {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim().to_ascii_lowercase().as_str() {
            "cliff" | "cliff-lhmp" | "lhmp" | "mod" => Ok(Method::Cliff),
            "cvm" | "cv" | "constant-velocity" => Ok(Method::Cvm),
            "improved" => Ok(Method::Improved),
            "motion" => Ok(Method::Motion),
            "cvm-last" | "cv-last" => Ok(Method::CvmLast),
            other => Err(format!(
                "unknown method '{other}' (expected cliff, cvm, improved, motion or cvm-last)"
            )),
        }
    }
}

/// How CLiFF-LHMP bends the heading towards a sampled direction.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum HeadingRule {
    /// The reference implementation: circular weighted mean of the sampled direction
    /// (weight `lambda`) and the current heading (weight `1 - lambda`).
    #[default]
    CircularMean,
    /// The paper's formula: `theta + lambda * signed_delta`.
    Paper,
}

impl FromStr for HeadingRule {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim().to_ascii_lowercase().as_str() {
            "circular-mean" | "reference" => Ok(HeadingRule::CircularMean),
            "paper" => Ok(HeadingRule::Paper),
            other => Err(format!(
                "unknown heading rule '{other}' (expected circular-mean or paper)"
            )),
        }
    }
}

/// Prediction parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Params {
    /// Method.
    pub method: Method,
    /// Samples per agent.
    pub k: usize,
    /// Time step (s).
    pub dt: f64,
    /// Prediction horizon (s); the number of steps is `floor(horizon / dt)`.
    pub horizon: f64,
    /// Kernel parameter: how strongly the heading turns to the sampled direction.
    pub beta: f64,
    /// Sampling radius (m): map locations strictly within it are near. (The reference's
    /// `r_s = 0.5` compares squared distances with 0.5: pass `sqrt(0.5) = 0.7071`.)
    pub radius: f64,
    /// Seed of the call's random generator.
    pub seed: u64,
    /// Heading update rule.
    pub heading: HeadingRule,
}

impl Default for Params {
    /// THÖR settings of the paper: k 20, dt 0.4 s, 12 s, beta 1, radius 0.7071 m.
    fn default() -> Self {
        Self {
            method: Method::Cliff,
            k: 20,
            dt: 0.4,
            horizon: 12.0,
            beta: 1.0,
            radius: std::f64::consts::FRAC_1_SQRT_2,
            seed: 0,
            heading: HeadingRule::CircularMean,
        }
    }
}

/// Steps in `horizon` seconds at `dt`: `floor(horizon / dt)`, robust to rounding just
/// below a whole number (12 / 0.4 is 30).
pub fn steps_for(horizon: f64, dt: f64) -> usize {
    let s = horizon / dt;
    let r = s.round();
    if (s - r).abs() < 1e-9 {
        r as usize
    } else {
        s.floor() as usize
    }
}

impl Params {
    /// Number of predicted positions per sample.
    pub fn steps(&self) -> usize {
        steps_for(self.horizon, self.dt)
    }

    /// Check every parameter; the error names the first one that is unusable.
    pub fn validate(&self) -> Result<(), PredictError> {
        let bad = |name: &'static str, why: String| Err(PredictError::Param { name, why });
        if self.k == 0 {
            return bad("k", "must be at least 1".into());
        }
        if !(self.dt.is_finite() && self.dt > 0.0) {
            return bad("dt", format!("{} is not a positive number", self.dt));
        }
        if !(self.horizon.is_finite() && self.horizon >= 0.0) {
            return bad(
                "horizon",
                format!("{} is not a non-negative number", self.horizon),
            );
        }
        if self.horizon / self.dt > 1e7 {
            return bad(
                "horizon",
                format!(
                    "{} s at dt {} is more than 10^7 steps",
                    self.horizon, self.dt
                ),
            );
        }
        if !(self.beta.is_finite() && self.beta >= 0.0) {
            return bad(
                "beta",
                format!("{} is not a non-negative number", self.beta),
            );
        }
        if !(self.radius.is_finite() && self.radius > 0.0) {
            return bad(
                "radius",
                format!("{} is not a positive number", self.radius),
            );
        }
        Ok(())
    }
}

/// Errors from a prediction call.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PredictError {
    /// A parameter is unusable.
    #[error("parameter {name}: {why}")]
    Param {
        /// The parameter.
        name: &'static str,
        /// What is wrong.
        why: String,
    },
    /// An agent's state holds a non-finite number or a negative speed.
    #[error("agent {0}: state has a non-finite value or negative speed")]
    State(usize),
    /// The output buffers do not have the shape the call needs.
    #[error(
        "output buffer holds {got} positions and {got_lens} lengths, the call needs {need} and {need_lens}"
    )]
    Shape {
        /// Positions in the buffer.
        got: usize,
        /// Lengths in the buffer.
        got_lens: usize,
        /// Positions needed.
        need: usize,
        /// Lengths needed.
        need_lens: usize,
    },
    /// The batch would not fit in memory (its size overflows, or it cannot be allocated).
    #[error("{agents} agents x {k} samples x {steps} steps is too large a batch to allocate")]
    TooLarge {
        /// Agents.
        agents: usize,
        /// Samples per agent.
        k: usize,
        /// Steps per sample.
        steps: usize,
    },
}

/// Predict `params.k` samples for every agent into `out`, resizing it as needed
/// (no allocation once it has held a batch at least this large).
pub fn predict(
    map: &CliffMap,
    agents: &[State],
    params: &Params,
    out: &mut TrajectoryBatch,
) -> Result<(), PredictError> {
    params.validate()?;
    out.try_reshape(agents.len(), params.k, params.steps())?;
    out.try_size_scores(false)?;
    predict_into(map, agents, params, out.as_mut())
}

/// Predict into caller-provided slices (for example a shared-memory response):
/// `out.positions` holds `agents x k x steps` points, sample-major, and `out.lens`
/// the valid length of each of the `agents x k` samples. Points past a sample's valid
/// length are set to NaN.
pub fn predict_into(
    map: &CliffMap,
    agents: &[State],
    params: &Params,
    out: BatchMut<'_>,
) -> Result<(), PredictError> {
    Rollout::new(params)?.predict_agents(map, agents, out, None)
}

#[cfg(test)]
mod tests {
    use std::f64::consts::PI;

    use glam::DVec2;

    use super::*;
    use crate::map::{Component, Location};

    fn walker(x: f64, y: f64, heading: f64) -> State {
        State {
            position: DVec2::new(x, y),
            speed: 1.0,
            heading,
            time: 0.0,
        }
    }

    #[test]
    fn cvm_moves_straight_and_never_stops() {
        let map = CliffMap::demo();
        let params = Params {
            method: Method::Cvm,
            k: 2,
            dt: 0.5,
            horizon: 100.0,
            ..Params::default()
        };
        let mut b = TrajectoryBatch::new();
        predict(&map, &[walker(0.0, 0.0, PI / 2.0)], &params, &mut b).unwrap();
        assert_eq!(b.shape(), (1, 2, 200));
        let s = b.sample(0, 1);
        assert_eq!(s.len(), 200);
        assert!((s[199][1] - 100.0).abs() < 1e-3 && s[199][0].abs() < 1e-3);
    }

    #[test]
    fn same_seed_same_bytes_other_seed_other_bytes() {
        let map = CliffMap::demo();
        let agents = [walker(-10.0, 0.0, 0.0), walker(0.0, -8.0, PI / 2.0)];
        let p = Params {
            seed: 42,
            ..Params::default()
        };
        let (mut a, mut b, mut c) = (
            TrajectoryBatch::new(),
            TrajectoryBatch::new(),
            TrajectoryBatch::new(),
        );
        predict(&map, &agents, &p, &mut a).unwrap();
        predict(&map, &agents, &p, &mut b).unwrap();
        predict(&map, &agents, &Params { seed: 43, ..p }, &mut c).unwrap();
        let bits = |t: &TrajectoryBatch| {
            t.positions()
                .iter()
                .flatten()
                .map(|v| v.to_bits())
                .collect::<Vec<_>>()
        };
        assert_eq!(bits(&a), bits(&b));
        assert_eq!(a.lens(), b.lens());
        assert_ne!(bits(&a), bits(&c));
    }

    #[test]
    fn sample_stops_where_no_location_is_near() {
        // a single location at the origin; walking east from it at 1 m/s, 1 s steps
        let map = CliffMap::new(vec![Location {
            position: DVec2::ZERO,
            components: vec![Component {
                theta: 0.0,
                rho: 1.0,
                cov: [1e-8, 0.0, 0.0, 0.01],
                weight: 1.0,
            }],
            motion_ratio: 1.0,
            observation_ratio: 1.0,
        }])
        .unwrap();
        let params = Params {
            k: 3,
            dt: 1.0,
            horizon: 5.0,
            radius: 1.5,
            ..Params::default()
        };
        let mut b = TrajectoryBatch::new();
        predict(
            &map,
            &[walker(0.0, 0.0, 0.0), walker(5.0, 5.0, 0.0)],
            &params,
            &mut b,
        )
        .unwrap();
        // x = 0 and x = 1 have the location near; x = 2 has not, so the sample ends
        // after one step and x = 2 is not part of it (the reference's rule)
        for s in 0..3 {
            assert_eq!(b.len(0, s), 1);
            assert!((b.sample(0, s)[0][0] - 1.0).abs() < 1e-3);
            assert!(b.full_sample(0, s)[1][0].is_nan());
        }
        // starting off the map: nothing
        assert_eq!(b.len(1, 0), 0);
        assert!(b.sample(1, 0).is_empty());
    }

    #[test]
    fn heading_turns_towards_sampled_direction_across_zero() {
        // map says "go at 0.1 rad" everywhere; agent heads at 2pi - 0.3
        let mut locs = vec![];
        for ix in -5..=30 {
            for iy in -10..=10 {
                locs.push(Location {
                    position: DVec2::new(ix as f64, iy as f64),
                    components: vec![Component {
                        theta: 0.1,
                        rho: 1.0,
                        cov: [1e-10, 0.0, 0.0, 0.01],
                        weight: 1.0,
                    }],
                    motion_ratio: 1.0,
                    observation_ratio: 1.0,
                });
            }
        }
        let map = CliffMap::new(locs).unwrap();
        for rule in [HeadingRule::CircularMean, HeadingRule::Paper] {
            let params = Params {
                k: 1,
                dt: 1.0,
                horizon: 10.0,
                radius: 1.0,
                beta: 1.0,
                heading: rule,
                ..Params::default()
            };
            let mut b = TrajectoryBatch::new();
            predict(&map, &[walker(0.0, 0.0, 2.0 * PI - 0.3)], &params, &mut b).unwrap();
            let s = b.sample(0, 0);
            assert_eq!(s.len(), 10);
            let last = DVec2::new((s[9][0] - s[8][0]) as f64, (s[9][1] - s[8][1]) as f64);
            let ang = last.to_angle();
            assert!((ang - 0.1).abs() < 0.01, "{rule:?}: {ang}");
            // first step: lambda = exp(-0.16); circular mean lands between -0.3 and 0.1
            let first = DVec2::new(s[0][0] as f64, s[0][1] as f64).to_angle();
            assert!(first > -0.3 && first < 0.1, "{rule:?}: {first}");
        }
        // the circular mean rule's first heading, exactly
        let lambda = (-0.16f64).exp();
        let v = DVec2::from_angle(0.1) * lambda + DVec2::from_angle(-0.3) * (1.0 - lambda);
        let params = Params {
            k: 1,
            dt: 1.0,
            horizon: 1.0,
            radius: 1.0,
            ..Params::default()
        };
        let mut b = TrajectoryBatch::new();
        predict(&map, &[walker(0.0, 0.0, 2.0 * PI - 0.3)], &params, &mut b).unwrap();
        let s = b.sample(0, 0)[0];
        assert!((s[1] as f64).atan2(s[0] as f64) - v.to_angle() < 1e-5);
    }

    #[test]
    fn bad_parameters_and_states_are_refused() {
        let map = CliffMap::demo();
        let mut b = TrajectoryBatch::new();
        let w = [walker(0.0, 0.0, 0.0)];
        for (p, name) in [
            (
                Params {
                    k: 0,
                    ..Params::default()
                },
                "k",
            ),
            (
                Params {
                    dt: 0.0,
                    ..Params::default()
                },
                "dt",
            ),
            (
                Params {
                    horizon: f64::NAN,
                    ..Params::default()
                },
                "horizon",
            ),
            (
                Params {
                    beta: -1.0,
                    ..Params::default()
                },
                "beta",
            ),
            (
                Params {
                    radius: f64::INFINITY,
                    ..Params::default()
                },
                "radius",
            ),
        ] {
            match predict(&map, &w, &p, &mut b) {
                Err(PredictError::Param { name: n, .. }) => assert_eq!(n, name),
                other => panic!("{name}: {other:?}"),
            }
        }
        let bad = [walker(0.0, 0.0, 0.0), walker(f64::NAN, 0.0, 0.0)];
        assert_eq!(
            predict(&map, &bad, &Params::default(), &mut b),
            Err(PredictError::State(1))
        );
        let mut pos = vec![[0.0f32; 2]; 5];
        let mut lens = vec![0u32; 20];
        let e = predict_into(
            &map,
            &w,
            &Params::default(),
            BatchMut {
                positions: &mut pos,
                lens: &mut lens,
            },
        );
        assert!(matches!(e, Err(PredictError::Shape { .. })));
        // a batch that overflows or cannot be allocated is an error, not an abort
        for k in [usize::MAX / 2, 1 << 44] {
            let p = Params {
                k,
                ..Params::default()
            };
            assert!(matches!(
                predict(&map, &w, &p, &mut b),
                Err(PredictError::TooLarge { .. })
            ));
        }
        // and the buffer still works afterwards
        predict(&map, &w, &Params::default(), &mut b).unwrap();
        assert_eq!(b.shape(), (1, 20, 30));
    }

    #[test]
    fn every_sample_count_fills_its_samples() {
        // every group size (4 to 20 lanes), partly filled, and several groups per agent
        let map = CliffMap::demo();
        let agents = [walker(-10.0, 0.5, 0.0), walker(0.5, -6.0, PI / 2.0)];
        for k in [1, 3, 4, 5, 8, 9, 12, 13, 16, 19, 20, 21, 45] {
            let params = Params {
                k,
                seed: k as u64,
                ..Params::default()
            };
            let mut b = TrajectoryBatch::new();
            predict(&map, &agents, &params, &mut b).unwrap();
            assert_eq!(b.shape(), (2, k, 30));
            let mut distinct = std::collections::HashSet::new();
            for a in 0..2 {
                for s in 0..k {
                    let full = b.full_sample(a, s);
                    let len = b.len(a, s);
                    assert!(len > 5, "k {k}: agent {a} sample {s} has {len} points");
                    assert!(full[..len].iter().flatten().all(|v| v.is_finite()));
                    assert!(full[len..].iter().flatten().all(|v| v.is_nan()));
                    distinct.insert(full[len - 1].map(f32::to_bits));
                }
            }
            // every sample is its own draw
            assert_eq!(distinct.len(), 2 * k, "k {k}");
        }
    }

    #[test]
    fn steps_round_like_the_reference() {
        assert_eq!(steps_for(12.0, 0.4), 30);
        assert_eq!(steps_for(11.0, 0.4), 27);
        assert_eq!(steps_for(5.0, 0.4), 12);
        assert_eq!(steps_for(50.0, 1.0), 50);
        assert_eq!(steps_for(0.3, 0.4), 0);
    }

    #[test]
    fn buffer_is_reused_without_reallocation() {
        let map = CliffMap::demo();
        let mut b = TrajectoryBatch::new();
        let agents = [walker(-10.0, 0.0, 0.0); 3];
        predict(&map, &agents, &Params::default(), &mut b).unwrap();
        let ptr = b.positions().as_ptr();
        predict(
            &map,
            &agents[..2],
            &Params {
                seed: 9,
                ..Params::default()
            },
            &mut b,
        )
        .unwrap();
        assert_eq!(b.positions().as_ptr(), ptr);
        assert_eq!(b.shape(), (2, 20, 30));
    }
}
