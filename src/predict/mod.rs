//! CLiFF-LHMP and constant-velocity prediction into reusable batch buffers.
//!
//! [`predict`] rolls `k` samples forward for every agent and writes them into a
//! caller-owned [`TrajectoryBatch`] (or, through [`predict_into`], into any pair of
//! slices such as a shared-memory response). Once the buffer is sized, a call does not
//! allocate. One `Xoshiro256PlusPlus` generator per call, seeded from
//! [`Params::seed`], draws for the agents in order; an agent's samples advance in
//! lockstep (groups of up to 20), one draw per live sample per step, in sample order. The
//! same map, states and parameters give the same bytes.
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
mod extended;
pub(crate) mod fastmath;

use std::f64::consts::PI;
use std::fmt;
use std::str::FromStr;

use glam::DVec2;
use rand::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;

use crate::map::{CliffMap, Lookup, wrap_2pi};
use crate::motion::State;

pub use batch::{BatchMut, Point, TrajectoryBatch};
pub use extended::{NO_LOCATION_LOG_DENSITY, Options, predict_into_with, predict_with};

/// Prediction method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Method {
    /// CLiFF-LHMP: constant velocity bent towards directions sampled from the map.
    #[default]
    Cliff,
    /// Constant velocity: never turns, never stops.
    Cvm,
}

impl Method {
    /// The method's name on the command line and in reports (`cliff`, `cvm`).
    pub fn name(self) -> &'static str {
        match self {
            Method::Cliff => "cliff",
            Method::Cvm => "cvm",
        }
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
            other => Err(format!("unknown method '{other}' (expected cliff or cvm)")),
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
    Rollout::new(params)?.predict_agents(map, agents, out)
}

/// Which neighbour-table path a [`Rollout`] takes for CLiFF-LHMP map lookups.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Tables {
    /// Build the radius's table on first use ([`CliffMap::lookup`]): the fastest
    /// prediction, but the first call with a new radius pays for the build.
    #[default]
    Build,
    /// Use the table if it is built, else the grid scan ([`CliffMap::cached_lookup`]):
    /// never builds, so every call's cost is bounded by its size and the radius (for
    /// servers, which build tables on another thread).
    CachedOnly,
}

/// A prediction made in pieces: the call's random generator between chunks of agents.
///
/// [`predict_into`] is one `Rollout` over all agents. Cutting the agents into
/// consecutive chunks and predicting them in order with the same `Rollout` gives the
/// same bytes, since the generator draws for the agents in order; a server uses this
/// to interleave a large request with others.
///
/// ```
/// use cliff::map::CliffMap;
/// use cliff::motion::State;
/// use cliff::predict::{Params, Rollout, TrajectoryBatch, predict};
/// use glam::DVec2;
///
/// let map = CliffMap::demo();
/// let agents: Vec<State> = (0..4)
///     .map(|i| State { position: DVec2::new(-10.0, 0.5 * i as f64), speed: 1.2, heading: 0.0, time: 0.0 })
///     .collect();
/// let params = Params { k: 5, horizon: 4.0, seed: 7, ..Params::default() };
/// let mut whole = TrajectoryBatch::new();
/// predict(&map, &agents, &params, &mut whole).unwrap();
///
/// let mut pieces = TrajectoryBatch::new();
/// pieces.reshape(4, 5, params.steps());
/// let mut rollout = Rollout::new(&params).unwrap();
/// let per_agent = 5 * params.steps();
/// let out = pieces.as_mut();
/// let (p1, p2) = out.positions.split_at_mut(3 * per_agent);
/// let (l1, l2) = out.lens.split_at_mut(3 * 5);
/// use cliff::predict::BatchMut;
/// rollout.predict_agents(&map, &agents[..3], BatchMut { positions: p1, lens: l1 }).unwrap();
/// rollout.predict_agents(&map, &agents[3..], BatchMut { positions: p2, lens: l2 }).unwrap();
/// assert_eq!(whole, pieces);
/// ```
#[derive(Debug, Clone)]
pub struct Rollout {
    params: Params,
    tables: Tables,
    rng: Xoshiro256PlusPlus,
}

impl Rollout {
    /// A rollout of `params` (checked) whose generator is seeded from `params.seed`.
    pub fn new(params: &Params) -> Result<Self, PredictError> {
        params.validate()?;
        Ok(Self {
            params: *params,
            tables: Tables::Build,
            rng: Xoshiro256PlusPlus::seed_from_u64(params.seed),
        })
    }

    /// The same rollout with another neighbour-table path.
    pub fn with_tables(mut self, tables: Tables) -> Self {
        self.tables = tables;
        self
    }

    /// The parameters.
    pub fn params(&self) -> &Params {
        &self.params
    }

    /// Predict the next `agents` (after those of earlier calls) into `out`, shaped as
    /// [`predict_into`] needs for these agents alone.
    pub fn predict_agents(
        &mut self,
        map: &CliffMap,
        agents: &[State],
        out: BatchMut<'_>,
    ) -> Result<(), PredictError> {
        let params = &self.params;
        let steps = check_call(agents, params, &out)?;
        if steps == 0 {
            out.lens.fill(0);
            return Ok(());
        }
        let rng = &mut self.rng;
        match params.method {
            Method::Cvm => {
                for ((positions, lens), state) in out
                    .positions
                    .chunks_exact_mut(params.k * steps)
                    .zip(out.lens.chunks_exact_mut(params.k))
                    .zip(agents)
                {
                    for (track, len) in positions.chunks_exact_mut(steps).zip(lens) {
                        roll_cvm(state, params.dt, track);
                        *len = steps as u32;
                    }
                }
            }
            Method::Cliff => {
                let lookup = match self.tables {
                    Tables::Build => map.lookup(params.radius),
                    Tables::CachedOnly => map.cached_lookup(params.radius),
                };
                match lookup {
                    Lookup::Table(t) => {
                        roll_cliff_all(map, agents, params, rng, out, |p| t.best_near(p))
                    }
                    Lookup::Grid(m, r) => {
                        roll_cliff_all(map, agents, params, rng, out, |p| m.best_near(p, r))
                    }
                }
            }
        }
        Ok(())
    }
}

/// Check the parameters, the buffer shapes and the agents' states of a call; the
/// number of steps.
fn check_call(
    agents: &[State],
    params: &Params,
    out: &BatchMut<'_>,
) -> Result<usize, PredictError> {
    params.validate()?;
    let steps = params.steps();
    let too_large = PredictError::TooLarge {
        agents: agents.len(),
        k: params.k,
        steps,
    };
    let samples = agents
        .len()
        .checked_mul(params.k)
        .ok_or(too_large.clone())?;
    let need = samples.checked_mul(steps).ok_or(too_large)?;
    if out.positions.len() != need || out.lens.len() != samples {
        return Err(PredictError::Shape {
            got: out.positions.len(),
            got_lens: out.lens.len(),
            need,
            need_lens: samples,
        });
    }
    if let Some(i) = agents.iter().position(|s| {
        !(s.position.is_finite() && s.speed.is_finite() && s.heading.is_finite() && s.speed >= 0.0)
    }) {
        return Err(PredictError::State(i));
    }
    Ok(steps)
}

/// Roll every CLiFF-LHMP sample of every agent; `near` finds the sampling location
/// (monomorphised per lookup kind so the hot loop inlines it).
fn roll_cliff_all(
    map: &CliffMap,
    agents: &[State],
    params: &Params,
    rng: &mut Xoshiro256PlusPlus,
    out: BatchMut<'_>,
    near: impl Fn(DVec2) -> Option<usize>,
) {
    let steps = params.steps();
    let per_agent = params.k * steps;
    for ((positions, lens), state) in out
        .positions
        .chunks_exact_mut(per_agent)
        .zip(out.lens.chunks_exact_mut(params.k))
        .zip(agents)
    {
        for (tracks, lens) in positions
            .chunks_mut(MAX_LANES * steps)
            .zip(lens.chunks_mut(MAX_LANES))
        {
            roll_cliff_group(map, &near, state, params, rng, tracks, lens);
        }
    }
}

fn roll_cvm(state: &State, dt: f64, track: &mut [Point]) {
    let step = DVec2::from_angle(state.heading) * (state.speed * dt);
    let mut p = state.position;
    for out in track.iter_mut() {
        p += step;
        *out = [p.x as f32, p.y as f32];
    }
}

/// Group sizes: the samples of one agent are rolled side by side in groups of at most
/// [`MAX_LANES`], each in the copy of the loop with the smallest lane count (4, 8, 12,
/// 16 or 20) that holds it (idle lanes cost their share of the arithmetic: k = 12 takes
/// 8.3 us in the 12-lane copy, 10.4 us in the 20-lane one). A step is
/// a chain of dependent arithmetic (sample -> angle -> kernel -> heading -> position ->
/// map lookup); computing each phase of a step for all lanes together lets the processor
/// overlap the lanes' chains, and the heading arithmetic runs four lanes per SSE2
/// instruction. The lane count is a constant of each copy of the loop, so the compiler
/// unrolls the lanes (each lane's branches get their own prediction history). Measured
/// on the THÖR1 benchmark case (k = 20): groups of 4 lanes 18.8 us, 8 lanes 15.3 us,
/// one group of 20 lanes 13.7 us.
const MAX_LANES: usize = 20;

/// Roll `lens.len()` (at most [`MAX_LANES`]) samples of one agent with the smallest
/// lane count that holds them.
#[inline]
fn roll_cliff_group(
    map: &CliffMap,
    near: &impl Fn(DVec2) -> Option<usize>,
    state: &State,
    params: &Params,
    rng: &mut Xoshiro256PlusPlus,
    tracks: &mut [Point],
    lens: &mut [u32],
) {
    match lens.len() {
        0 => {}
        1..=4 => roll_cliff_lanes::<4>(map, near, state, params, rng, tracks, lens),
        5..=8 => roll_cliff_lanes::<8>(map, near, state, params, rng, tracks, lens),
        9..=12 => roll_cliff_lanes::<12>(map, near, state, params, rng, tracks, lens),
        13..=16 => roll_cliff_lanes::<16>(map, near, state, params, rng, tracks, lens),
        _ => roll_cliff_lanes::<MAX_LANES>(map, near, state, params, rng, tracks, lens),
    }
}

/// Up to `N` CLiFF-LHMP samples of one agent: `tracks` holds `lens.len()` samples of
/// `steps` positions each. `N` is a multiple of four.
///
/// As in the reference: the direction is sampled at the current position, the person
/// moves, and a new position with no map location near it ends the sample and is not
/// part of it. (The location found there is the next step's sampling location, so each
/// step queries the map once.)
#[inline(never)]
fn roll_cliff_lanes<const N: usize>(
    map: &CliffMap,
    near: &impl Fn(DVec2) -> Option<usize>,
    state: &State,
    params: &Params,
    rng: &mut Xoshiro256PlusPlus,
    tracks: &mut [Point],
    lens: &mut [u32],
) {
    let n = lens.len();
    debug_assert!(n <= N && N.is_multiple_of(4));
    let steps = tracks.len() / n;
    let dist = state.speed * params.dt;
    let theta0 = wrap_2pi(state.heading);
    let (s0, c0) = fastmath::sin_cos(theta0);
    let start = near(state.position);
    let mut px = [state.position.x; N];
    let mut py = [state.position.y; N];
    let mut ux = [c0 as f32; N];
    let mut uy = [s0 as f32; N];
    let mut theta = [theta0; N];
    let mut loc = [start.unwrap_or(0); N];
    // Lanes n..N stay inactive: they never draw, and their arithmetic is discarded.
    let mut active = [false; N];
    for a in &mut active[..n] {
        *a = start.is_some();
    }
    let mut ts = [0.0f64; N];
    lens.fill(0);
    for j in 0..steps {
        // Phase 1: draw a direction at each active lane's location (in lane order).
        for l in 0..N {
            if active[l] {
                ts[l] = map.direction_at(loc[l]).sample_unwrapped(rng);
            }
        }
        // Phase 2: turn and move every lane (straight-line arithmetic, lanes interleaved).
        match params.heading {
            HeadingRule::CircularMean => {
                // Single precision: a heading error of 1e-7 rad per step is far below the
                // sampling noise, and four f32 lanes fill one SSE2 register. (Converted
                // first: a loop that reads f64 lanes vectorises two lanes at a time.)
                let ts32: [f32; N] = std::array::from_fn(|l| ts[l] as f32);
                let beta = params.beta as f32;
                let (ts4, _) = ts32.as_chunks::<4>();
                let (ux4, _) = ux.as_chunks_mut::<4>();
                let (uy4, _) = uy.as_chunks_mut::<4>();
                for ((t, hx), hy) in ts4.iter().zip(ux4).zip(uy4) {
                    turn4(t, hx, hy, beta);
                }
            }
            HeadingRule::Paper => {
                for l in 0..N {
                    let mut signed = wrap_2pi(ts[l]) - theta[l];
                    if signed > PI {
                        signed -= 2.0 * PI;
                    } else if signed < -PI {
                        signed += 2.0 * PI;
                    }
                    let lambda = fastmath::exp_neg(-params.beta * signed * signed);
                    theta[l] = wrap_2pi(theta[l] + lambda * signed);
                    let (sin, cos) = fastmath::sin_cos(theta[l]);
                    ux[l] = cos as f32;
                    uy[l] = sin as f32;
                }
            }
        }
        for l in 0..N {
            px[l] += ux[l] as f64 * dist;
            py[l] += uy[l] as f64 * dist;
        }
        // Phase 3: look up the new positions; a lane with nothing near ends.
        let mut any = false;
        for l in 0..N {
            if !active[l] {
                continue;
            }
            match near(DVec2::new(px[l], py[l])) {
                Some(next) => {
                    loc[l] = next;
                    tracks[l * steps + j] = [px[l] as f32, py[l] as f32];
                    lens[l] = j as u32 + 1;
                    any = true;
                }
                None => active[l] = false,
            }
        }
        if !any {
            break;
        }
    }
    for (l, &len) in lens.iter().enumerate() {
        tracks[l * steps + len as usize..(l + 1) * steps].fill([f32::NAN; 2]);
    }
}

/// The reference's heading update for four lanes: the circular weighted mean of the
/// sampled direction `t` (weight `lambda = exp(-beta * delta^2)`) and the heading
/// `(hx, hy)` (weight `1 - lambda`), as a unit vector. Straight-line code over four
/// lanes, which the compiler turns into SSE2 instructions.
#[inline(always)]
fn turn4(t: &[f32; 4], hx: &mut [f32; 4], hy: &mut [f32; 4], beta: f32) {
    for l in 0..4 {
        let (sin, cos) = fastmath::sin_cos_f32(t[l]);
        let (x, y) = (hx[l], hy[l]);
        // |shortest angle| between the sample and the heading, in [0, pi].
        let delta = fastmath::acos_f32(cos * x + sin * y);
        let lambda = fastmath::exp_neg_f32(-beta * delta * delta);
        let vx = cos * lambda + x * (1.0 - lambda);
        let vy = sin * lambda + y * (1.0 - lambda);
        let n2 = vx * vx + vy * vy;
        // Exactly opposite with lambda = 1/2: the reference's atan2(0, 0) = 0.
        let ok = n2 > 1e-20;
        let inv = 1.0 / n2.max(1e-20).sqrt();
        hx[l] = if ok { vx * inv } else { 1.0 };
        hy[l] = if ok { vy * inv } else { 0.0 };
    }
}

#[cfg(test)]
mod tests {
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
