//! Options beyond the paper's method: speed from the map, coasting where the map has no
//! data, and a score per sample. All are off by default; with [`Options::default`]
//! [`predict_with`] is [`predict`](super::predict), byte for byte.
//!
//! * **Speed kernel** ([`Options::speed_beta`] > 0): at each step the speed is drawn
//!   with the direction (from the chosen component's bivariate normal, the speed given
//!   the drawn direction; its noise a sum of four uniforms, see
//!   [`CliffMap::velocity_at`]) and the current speed `v` moves towards the drawn speed `r` as
//!   the heading does towards the drawn direction:
//!   `v <- v + lambda * (r - v)`, `lambda = exp(-speed_beta * (r - v)^2)` (m/s; `lambda`
//!   in single precision). The paper keeps the observed speed.
//! * **Coasting** ([`Options::coast`] > 0 seconds): a sample that reaches a position with
//!   no map location near does not stop there (the paper's rule) but goes on at constant
//!   velocity for up to `floor(coast / dt)` positions; back near a location it samples
//!   the map again (and may coast again later). A start with no location near coasts too.
//! * **Scores** ([`Options::scores`]): every sample gets the log-likelihood of its
//!   rollout under the map, summed over the `steps` of the horizon. A step taken from a
//!   map location adds the log-density of the step's velocity (the heading and speed after
//!   the update) under that location's mixture, approximated by its likeliest component
//!   ([`CliffMap::step_log_density`]: at most `ln(3 x components)` below
//!   [`CliffMap::log_density`], equal where one component explains the step; on real
//!   predictions the median step is within 0.04 of it and the scores order 99 % of the
//!   pairs of samples alike); any other
//!   step (coasting, after the sample ended, or every step of constant velocity far from
//!   the map) adds [`NO_LOCATION_LOG_DENSITY`], the log-density of a uniform velocity
//!   over all headings and speeds of 0 to 2 m/s. Scores compare samples of the same
//!   call; [`TrajectoryBatch::best_sample`] picks the most likely.
//!
//! * **Follow** ([`Options::follow`] > 0): at each step the component is chosen by its
//!   weight times a von Mises likelihood of the walker's heading,
//!   `w_j exp(-follow (1 - cos(heading - mu_j)))` ([`CliffMap::direction_following`]):
//!   a walker keeps to the flows going its way instead of jumping to a crossing one.
//! * **Candidates** ([`Options::candidates`] > 1): each agent's samples are the best
//!   `k` of `candidates x k` drawn ones: those that reach furthest (the paper's rule
//!   stops a sample where the map has no data), then the highest-scored. Costs
//!   `candidates` times the work (with follow, twice that: [`Options::cost_factor`]).
//! * **Prune** ([`Options::prune`], with candidates): the candidates are rolled in
//!   stretches and cut at the checkpoints of [`PRUNE_SCHEDULE`] to the best of them:
//!   the furthest projected reach first (the steps reached, plus the steps a walker
//!   following the map's likeliest flow from where the candidate is would stay on the
//!   map; at the checkpoints before half the horizon), then the partial score; each
//!   kept one goes on as the checkpoint's copies (itself and copies drawing from
//!   generators of their own). So most of them stop early: with 2 candidates, the best
//!   half of `k` going on twice at a fifth, at half and at eight tenths of the horizon,
//!   1.2 times the samples' steps of `k` samples instead of 2.
//! * **Speed prior** ([`Options::speed_prior`]): the start speed regresses to the
//!   typical speed of the map's walkers with the map's
//!   [`SpeedPrior`](crate::motion::SpeedPrior) (`cliff map build` learns one; a map
//!   without one leaves the speed as observed).
//! * **Trust** ([`Options::trust`] > 0 seconds): near the present the observed motion
//!   holds: at the step that starts `t` seconds ahead the heading kernel's weight is
//!   scaled by `1 - exp(-t / trust)`, and the speed goes from the observed one to the
//!   speed prior's as the same share (so the first step is the observed velocity's).
//! * **Blend** ([`Options::blend`] > 0 seconds): the positions leave the
//!   constant-velocity line gradually: `w` times constant velocity's position plus
//!   `1 - w` times the sample's, `w = exp(-(t - dt) / blend)` (the rollout itself, and so
//!   where a sample ends, is unchanged).
//! * **Rank** ([`Options::rank`]): with [`Rank::Consensus`] the scores measure how
//!   central a sample is among the agent's samples instead of its likelihood, so the
//!   best-ranked sample is the one to keep as a single prediction.
//!
//! The draws: with the speed kernel, each live sample's draw takes one uniform and two
//! normals (direction, then speed) instead of one uniform and one normal; coasting
//! samples draw nothing. Scores draw nothing.
//!
//! ```
//! use cliff::map::CliffMap;
//! use cliff::motion::State;
//! use cliff::predict::{predict_with, Options, Params, TrajectoryBatch};
//! use glam::DVec2;
//!
//! let map = CliffMap::demo();
//! let walker = State { position: DVec2::new(-10.0, 0.5), speed: 1.2, heading: 0.0, time: 0.0 };
//! let opts = Options { speed_beta: 2.0, coast: 4.0, scores: true, ..Options::default() };
//! let mut batch = TrajectoryBatch::new();
//! predict_with(&map, &[walker], &Params::default(), &opts, &mut batch).unwrap();
//! let best = batch.best_sample(0).unwrap();
//! assert!(batch.scores().iter().all(|s| *s <= batch.score(0, best).unwrap()));
//! ```

use super::PredictError;

/// Log-density of a step without a map location in a sample's score: a uniform
/// velocity over headings `[0, 2pi)` and speeds `[0, 2]` m/s, `-ln(4 pi)`.
pub const NO_LOCATION_LOG_DENSITY: f64 = -2.531_024_246_969_290_7;

/// Options beyond the paper's method (see the [module documentation](self)).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Options {
    /// Speed kernel parameter (per (m/s)^2); 0 keeps the observed speed (the paper).
    pub speed_beta: f64,
    /// Seconds a sample goes on at constant velocity where the map has no location near;
    /// 0 stops it there (the paper).
    pub coast: f64,
    /// Compute a score per sample ([`TrajectoryBatch::scores`]).
    pub scores: bool,
    /// Concentration of the heading likelihood that weighs the components at each
    /// step (0: by weight alone, the paper; at most [`MAX_FOLLOW`]).
    pub follow: f64,
    /// Keep the best `k` of `candidates x k` samples per agent (0 or 1: draw `k`, the
    /// paper; at most [`MAX_CANDIDATES`]).
    pub candidates: u32,
    /// Prune the candidates ([`Options::candidates`] > 1) along the way: they are
    /// rolled in stretches, and at each checkpoint of [`PRUNE_SCHEDULE`] only the best
    /// go on (those that reach furthest, then the highest partial score), each as the
    /// checkpoint's copies ([`Checkpoint`]), no fewer than `k` in all; the `k` kept are
    /// the best of those left at the horizon. Most candidates then stop early.
    pub prune: bool,
    /// Start from the speed the map's speed prior gives for the observed one.
    pub speed_prior: bool,
    /// Seconds over which the map takes over from the observed motion: at the step that
    /// starts `t` seconds ahead the heading kernel's weight and the speed prior's pull
    /// are scaled by `1 - exp(-t / trust)` (0: the map acts fully from the first step).
    pub trust: f64,
    /// Seconds over which the predicted positions leave the constant-velocity line: the
    /// position `t` seconds ahead is `w` times constant velocity's plus `1 - w` times
    /// the sample's, `w = exp(-(t - dt) / blend)` (0: the samples as rolled).
    pub blend: f64,
    /// What the scores rank: the likelihood under the map (the default) or the
    /// agreement with the other samples ([`Rank::Consensus`]).
    pub rank: Rank,
    /// Start from the learned motion model instead of constant velocity: the blend
    /// ([`Options::blend`]) leaves the model's path, a sample the map stops (where it
    /// has no data) stands there, and the map bends the model's samples by a share that
    /// starts at its evidence for the person (how much better it explains the headings
    /// of their observed steps, given their speeds, than a uniform heading) and grows
    /// with the horizon; with no map location
    /// near the person the samples are the model's. Every sample reaches the horizon and
    /// the first becomes the samples' mean path (see `predict/motion.rs`).
    pub motion: bool,
}

/// What a sample's score ([`Options::scores`]) measures, and so which sample
/// [`TrajectoryBatch::best_sample`](super::TrajectoryBatch::best_sample) picks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Rank {
    /// The log-likelihood of the sample's rollout under the map.
    #[default]
    Likelihood,
    /// Agreement with the agent's other samples: minus the mean distance (m) of the
    /// sample's positions from the mean position of the samples at each step, minus
    /// [`CONSENSUS_STEP_PENALTY`] per step of the horizon the sample does not reach.
    /// The best-ranked sample is the most central one among those that reach furthest:
    /// as a single prediction it has a lower error than the likeliest sample (held-out
    /// figures in docs/accuracy.md).
    Consensus,
}

/// What a step of the horizon that a sample does not reach costs its
/// [`Rank::Consensus`] score (m): more than any distance between samples, so samples
/// that reach further rank first.
pub const CONSENSUS_STEP_PENALTY: f64 = 1.0e4;

/// Largest [`Options::follow`]: beyond it a heading's likelihood under a component
/// 180 degrees away underflows towards zero and nothing changes.
pub const MAX_FOLLOW: f64 = 100.0;

/// Largest [`Options::candidates`].
pub const MAX_CANDIDATES: u32 = 16;

impl Options {
    /// True when every option is off: the paper's method.
    pub fn is_paper(&self) -> bool {
        self.speed_beta == 0.0
            && self.coast == 0.0
            && !self.scores
            && self.follow == 0.0
            && self.candidates <= 1
            && !self.prune
            && !self.speed_prior
            && self.trust == 0.0
            && self.blend == 0.0
            && self.rank == Rank::Likelihood
            && !self.motion
    }

    /// How many times the paper's work a call with these options does, at most: 2 with
    /// follow on (else 1), and with [`Options::candidates`] > 1 that times the samples'
    /// steps rolled per kept sample's step (the candidates, or fewer when
    /// [pruned](Options::prune)), times 1.25 for their scores without follow (follow's
    /// 2 includes them), plus a half for a pruned rollout's flow walks at its
    /// checkpoints, rounded up. What a daemon's cost limits and its scheduler count.
    ///
    /// Measured per call on the benchmark people, against the paper's method on the
    /// same instructions (`cargo bench --bench options_cost`, BENCHMARKS.md): scores
    /// cost 1.2-1.3 times the paper, follow 1.3-1.7 times; `improved` (2 candidates
    /// pruned and resampled, follow, scores, trust, blend, consensus) 2.5-2.8 times on
    /// both paths (docs/accuracy.md, "What `improved` costs"), its flow walks 0.4-0.5 of that (with
    /// its earlier 4 candidates cut to 2 and to 1 per sample: 4.3-4.8 and up to 5.4,
    /// 6.9-7.8 without pruning). The speed
    /// kernel and coasting cost 1.2 times the paper on the baseline path (the count
    /// here) but 1.5-1.9 on AVX2, where they run the generic loop beside the paper's
    /// eight-lane one (2.2-2.5 with both and scores).
    ///
    /// ```
    /// use cliff::predict::Options;
    /// assert_eq!(Options::default().cost_factor(), 1);
    /// assert_eq!(Options { scores: true, speed_beta: 1.0, ..Options::default() }.cost_factor(), 1);
    /// assert_eq!(Options { follow: 4.0, candidates: 5, ..Options::default() }.cost_factor(), 10);
    /// assert_eq!(Options { candidates: 5, ..Options::default() }.cost_factor(), 7);
    /// let pruned = Options { follow: 4.0, candidates: 2, prune: true, ..Options::default() };
    /// // 2 to a fifth of the horizon, then 1 (half of them, each twice): 1.2 x 2 + 0.5
    /// assert_eq!(pruned.cost_factor(), 3);
    /// ```
    pub fn cost_factor(&self) -> usize {
        let follow = self.follow > 0.0;
        let step = if follow { 2.0 } else { 1.0 };
        let candidates = self.candidates.max(1) as usize;
        if candidates == 1 {
            return step as usize;
        }
        let drawn = if self.prune {
            pruned_share(candidates)
        } else {
            candidates as f64
        };
        // candidates are scored (to rank them): about 1.25 times the paper's step, and
        // within follow's step of 2 (its loop computes them beside the follow draw); a
        // pruned rollout walks the flow from its candidates at a checkpoint (0.4-0.5
        // times the paper's work on the benchmark people)
        let scored = if follow { 1.0 } else { 1.25 };
        let walks = if self.prune { 0.5 } else { 0.0 };
        (drawn * step * scored + walks).ceil() as usize
    }

    /// Check the options; the error names the first unusable one.
    pub fn validate(&self) -> Result<(), PredictError> {
        if !(self.speed_beta.is_finite() && self.speed_beta >= 0.0) {
            return Err(PredictError::Param {
                name: "speed_beta",
                why: format!("{} is not a non-negative number", self.speed_beta),
            });
        }
        if !(self.coast.is_finite() && self.coast >= 0.0) {
            return Err(PredictError::Param {
                name: "coast",
                why: format!("{} is not a non-negative number of seconds", self.coast),
            });
        }
        if !(self.follow.is_finite() && (0.0..=MAX_FOLLOW).contains(&self.follow)) {
            return Err(PredictError::Param {
                name: "follow",
                why: format!("{} is not a number in [0, {MAX_FOLLOW}]", self.follow),
            });
        }
        if !(self.trust.is_finite() && self.trust >= 0.0) {
            return Err(PredictError::Param {
                name: "trust",
                why: format!("{} is not a non-negative number of seconds", self.trust),
            });
        }
        if !(self.blend.is_finite() && self.blend >= 0.0) {
            return Err(PredictError::Param {
                name: "blend",
                why: format!("{} is not a non-negative number of seconds", self.blend),
            });
        }
        if self.candidates > MAX_CANDIDATES {
            return Err(PredictError::Param {
                name: "candidates",
                why: format!(
                    "{} candidates per sample, at most {MAX_CANDIDATES}",
                    self.candidates
                ),
            });
        }
        Ok(())
    }

    /// Positions a sample may coast off the map at time step `dt`.
    pub(super) fn coast_steps(&self, dt: f64) -> u32 {
        (self.coast / dt + 1e-9).floor().min(u32::MAX as f64) as u32
    }
}

/// A checkpoint of a pruned rollout ([`PRUNE_SCHEDULE`]): at `at` of the horizon's
/// steps (rounded, at least one step in, before the last) the candidates left are ranked
/// by the steps they reached, then their partial scores (before half the horizon the
/// steps reached count those the map's likeliest flow would keep them on the map from
/// there: a flow walk), the best `keep` times `k` of them (rounded up; at least `k`
/// divided by `copies`, rounded up) are kept, and each kept one goes on as `copies`
/// candidates: itself and `copies - 1` copies of it (its path so far and its partial
/// score) that draw from generators of their own, as a particle filter resamples.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Checkpoint {
    /// Where, as a fraction of the horizon's steps.
    pub at: f64,
    /// How many candidates are kept, per kept sample.
    pub keep: f64,
    /// How many candidates each kept one goes on as (1: itself alone).
    pub copies: u32,
}

/// The checkpoints of a pruned rollout ([`Checkpoint`]): the best half of `k` kept at a
/// fifth of the horizon (ranked with the flow walk), at half and at eight tenths, each
/// going on twice, from `2 k` candidates (the `improved` preset). So the candidates
/// roll 1.2 times the kept samples' steps, and the samples are chosen three times, the
/// better half each time (docs/performance-history.md, "Resampling the best
/// candidates"): more accurate on average and further reaching than four candidates per
/// sample cut to two at a fifth and to one at seven tenths (2.1 times the steps), less
/// diverse (pairs of samples share their path up to the last checkpoint).
pub const PRUNE_SCHEDULE: &[Checkpoint] = &[
    Checkpoint {
        at: 0.2,
        keep: 0.5,
        copies: 2,
    },
    Checkpoint {
        at: 0.5,
        keep: 0.5,
        copies: 2,
    },
    Checkpoint {
        at: 0.8,
        keep: 0.5,
        copies: 2,
    },
];

impl Checkpoint {
    /// How many candidates each kept one goes on as (0 counts as 1).
    pub(super) fn copies(&self) -> usize {
        self.copies.max(1) as usize
    }

    /// The candidates kept at this checkpoint for `k` samples (see [`Checkpoint`]).
    pub(super) fn kept(&self, k: usize) -> usize {
        ((self.keep * k as f64).ceil() as usize).max(k.div_ceil(self.copies()))
    }

    /// How many candidates go on after it, per kept sample, from `rolling` (the
    /// checkpoints' rounding aside).
    pub(super) fn going_on(&self, rolling: f64) -> f64 {
        let copies = self.copies() as f64;
        rolling.min(self.keep.max(1.0 / copies) * copies)
    }
}

/// The samples' steps a pruned rollout of `candidates` per kept sample rolls, per kept
/// sample's step, at most (the share of the horizon each stretch covers times the
/// candidates that roll it; the checkpoints' rounding aside): what
/// [`Options::cost_factor`](super::Options::cost_factor) counts.
pub(super) fn pruned_share(candidates: usize) -> f64 {
    let mut share = 0.0;
    let (mut from, mut rolling) = (0.0, candidates as f64);
    for c in PRUNE_SCHEDULE {
        share += (c.at - from) * rolling;
        (from, rolling) = (c.at, c.going_on(rolling));
    }
    share + (1.0 - from) * rolling
}
