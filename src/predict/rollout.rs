//! The rollout: one call's random generator, its options, and the loop that moves the
//! samples.
//!
//! Every prediction ([`predict`](super::predict), [`predict_with`](super::predict_with),
//! a server's chunks) runs through [`Rollout::predict_agents`], and every CLiFF-LHMP
//! sample through one lane loop, [`roll_lanes`]. The loop is compiled in a few flavours
//! (const parameters): the paper's method alone, with scores, and with the speed kernel
//! or coasting (with and without scores). The paper's flavour has none of the options'
//! arithmetic or bookkeeping, so the options cost nothing when they are off.

use std::f64::consts::PI;

use glam::DVec2;
use rand::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;

use super::options::{NO_LOCATION_LOG_DENSITY, Options};
use super::{BatchMut, HeadingRule, Method, Params, Point, PredictError, preset};
use crate::map::{CliffMap, FollowWeights, Lookup};
use crate::math::fastmath;
use crate::math::wrap_2pi;
use crate::motion::{SpeedPrior, State};

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
/// [`predict_into`](super::predict_into) and
/// [`predict_into_with`](super::predict_into_with) are one `Rollout` over all agents.
/// Cutting the agents into consecutive chunks and predicting them in order with the
/// same `Rollout` gives the same bytes (and scores), since the generator draws for the
/// agents in order; a server uses this to interleave a large request with others.
///
/// ```
/// use cliff::map::CliffMap;
/// use cliff::motion::State;
/// use cliff::predict::{BatchMut, Options, Params, Rollout, TrajectoryBatch, predict_with};
/// use glam::DVec2;
///
/// let map = CliffMap::demo();
/// let agents: Vec<State> = (0..4)
///     .map(|i| State { position: DVec2::new(-10.0, 0.5 * i as f64), speed: 1.2, heading: 0.0, time: 0.0 })
///     .collect();
/// let params = Params { k: 5, horizon: 4.0, seed: 7, ..Params::default() };
/// let options = Options { speed_beta: 1.0, coast: 2.0, scores: true, follow: 2.0, candidates: 3, ..Options::default() };
/// let mut whole = TrajectoryBatch::new();
/// predict_with(&map, &agents, &params, &options, &mut whole).unwrap();
///
/// let mut pieces = TrajectoryBatch::new();
/// pieces.reshape(4, 5, params.steps());
/// let mut scores = vec![0.0f32; 4 * 5];
/// let mut rollout = Rollout::new(&params).unwrap().with_options(options).unwrap();
/// let per_agent = 5 * params.steps();
/// let out = pieces.as_mut();
/// let (p1, p2) = out.positions.split_at_mut(3 * per_agent);
/// let (l1, l2) = out.lens.split_at_mut(3 * 5);
/// let (s1, s2) = scores.split_at_mut(3 * 5);
/// rollout.predict_agents(&map, &agents[..3], BatchMut { positions: p1, lens: l1 }, Some(s1)).unwrap();
/// rollout.predict_agents(&map, &agents[3..], BatchMut { positions: p2, lens: l2 }, Some(s2)).unwrap();
/// assert_eq!((whole.positions(), whole.lens()), (pieces.positions(), pieces.lens()));
/// assert_eq!(whole.scores(), &scores[..]);
/// ```
#[derive(Debug, Clone)]
pub struct Rollout {
    /// The parameters as given (the method may be a preset).
    asked: Params,
    /// The parameters and options resolved ([`preset::resolve`]).
    params: Params,
    options: Options,
    tables: Tables,
    rng: Xoshiro256PlusPlus,
    /// Buffers for [`Options::candidates`], grown once and reused.
    scratch: Candidates,
}

/// The drawn candidates of one agent before the best `k` are kept.
#[derive(Debug, Clone, Default)]
struct Candidates {
    tracks: Vec<Point>,
    lens: Vec<u32>,
    scores: Vec<f32>,
    order: Vec<u32>,
}

impl Rollout {
    /// A rollout of `params` (checked) with [`Options::default`] (the paper's method,
    /// unless `params.method` is a preset), whose generator is seeded from
    /// `params.seed`.
    pub fn new(params: &Params) -> Result<Self, PredictError> {
        params.validate()?;
        let (resolved, options) = preset::resolve(params, &Options::default());
        Ok(Self {
            asked: *params,
            params: resolved,
            options,
            tables: Tables::Build,
            rng: Xoshiro256PlusPlus::seed_from_u64(params.seed),
            scratch: Candidates::default(),
        })
    }

    /// The same rollout with `options` (checked; a preset method replaces them with its
    /// own, see [`preset::resolve`]). Scores are computed only when the options ask for
    /// them and [`predict_agents`](Self::predict_agents) is given a score buffer.
    pub fn with_options(mut self, options: Options) -> Result<Self, PredictError> {
        options.validate()?;
        (self.params, self.options) = preset::resolve(&self.asked, &options);
        Ok(self)
    }

    /// Start over with `params` and `options`, as
    /// `Rollout::new(params)?.with_options(options)?` would (checked, the generator
    /// seeded from `params.seed`), keeping the neighbour-table path and the buffers grown
    /// so far: a server that keeps one rollout per request slot allocates nothing per
    /// request. On `Err` the rollout is unchanged.
    pub fn restart(&mut self, params: &Params, options: Options) -> Result<(), PredictError> {
        params.validate()?;
        options.validate()?;
        self.asked = *params;
        (self.params, self.options) = preset::resolve(params, &options);
        self.rng = Xoshiro256PlusPlus::seed_from_u64(params.seed);
        Ok(())
    }

    /// The same rollout with another neighbour-table path.
    pub fn with_tables(mut self, tables: Tables) -> Self {
        self.tables = tables;
        self
    }

    /// The parameters it predicts with (a preset method resolved: never
    /// [`Method::Improved`]).
    pub fn params(&self) -> &Params {
        &self.params
    }

    /// The options it predicts with (a preset method's, if the method is one).
    pub fn options(&self) -> &Options {
        &self.options
    }

    /// Predict the next `agents` (after those of earlier calls) into `out`, shaped as
    /// [`predict_into`](super::predict_into) needs for these agents alone.
    ///
    /// `scores`, when given, holds one value per sample (`agents.len() x k`): the
    /// samples' scores when the options ask for scores ([`Options::scores`], or a
    /// preset's), else NaN. Scores draw nothing:
    /// with or without them, the samples are the same.
    pub fn predict_agents(
        &mut self,
        map: &CliffMap,
        agents: &[State],
        out: BatchMut<'_>,
        scores: Option<&mut [f32]>,
    ) -> Result<(), PredictError> {
        let params = &self.params;
        let options = &self.options;
        let steps = check_call(agents, params, &out)?;
        let scores = match scores {
            Some(s) if s.len() != out.lens.len() => {
                return Err(PredictError::Param {
                    name: "scores",
                    why: format!(
                        "the score buffer holds {} values, the call has {} samples",
                        s.len(),
                        out.lens.len()
                    ),
                });
            }
            Some(s) if !options.scores => {
                s.fill(f32::NAN);
                None
            }
            other => other,
        };
        if steps == 0 {
            out.lens.fill(0);
            if let Some(s) = scores {
                s.fill(0.0);
            }
            return Ok(());
        }
        let rng = &mut self.rng;
        let extras = Extras {
            speed_beta: options.speed_beta,
            coast_steps: options.coast_steps(params.dt),
            follow: options.follow,
            candidates: options.candidates.max(1) as usize,
            speed_prior: if options.speed_prior {
                map.speed_prior()
            } else {
                None
            },
        };
        let lookup = match (params.method, scores.is_some(), self.tables) {
            // constant velocity looks the map up only for scores
            (Method::Cvm, false, _) => None,
            (_, _, Tables::Build) => Some(map.lookup(params.radius)),
            (_, _, Tables::CachedOnly) => Some(map.cached_lookup(params.radius)),
        };
        let call = Call {
            map,
            agents,
            params,
            extras: &extras,
            rng,
            out,
            scores,
            scratch: &mut self.scratch,
        };
        match lookup {
            None => call.cvm(|_: DVec2| None::<usize>),
            Some(Lookup::Table(t)) => call.run(|p| t.best_near(p)),
            Some(Lookup::Grid(m, r)) => call.run(|p| m.best_near(p, r)),
        }
        Ok(())
    }
}

/// Check the parameters, the buffer shapes and the agents' states of a call; the
/// number of steps.
pub(super) fn check_call(
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

/// The options as the lane loop uses them.
#[derive(Debug, Clone, Copy)]
struct Extras {
    speed_beta: f64,
    /// Positions a sample may coast off the map.
    coast_steps: u32,
    follow: f64,
    /// Samples drawn per kept sample (at least 1).
    candidates: usize,
    speed_prior: Option<SpeedPrior>,
}

/// One call's inputs and outputs, for the flavour dispatch.
struct Call<'a, 'b> {
    map: &'a CliffMap,
    agents: &'a [State],
    params: &'a Params,
    extras: &'a Extras,
    rng: &'a mut Xoshiro256PlusPlus,
    out: BatchMut<'b>,
    scores: Option<&'b mut [f32]>,
    scratch: &'a mut Candidates,
}

impl Call<'_, '_> {
    /// Predict with the map lookup `near` (monomorphised per lookup kind so the hot loop
    /// inlines it).
    fn run(self, near: impl Fn(DVec2) -> Option<usize>) {
        if self.params.method == Method::Cvm {
            return self.cvm(near);
        }
        let e = self.extras;
        let motion = if e.coast_steps > 0 || e.follow > 0.0 {
            ANY
        } else if e.speed_beta > 0.0 {
            SPEED
        } else {
            PAPER
        };
        // candidates are ranked by their scores
        let scores = self.scores.is_some() || e.candidates > 1;
        match (motion, scores) {
            (PAPER, false) => self.cliff::<PAPER, false>(near),
            (PAPER, true) => self.cliff::<PAPER, true>(near),
            (SPEED, false) => self.cliff::<SPEED, false>(near),
            (SPEED, true) => self.cliff::<SPEED, true>(near),
            (_, false) => self.cliff::<ANY, false>(near),
            (_, true) => self.cliff::<ANY, true>(near),
        }
    }

    fn cvm(mut self, near: impl Fn(DVec2) -> Option<usize>) {
        let steps = self.params.steps();
        let k = self.params.k;
        for (a, state) in self.agents.iter().enumerate() {
            let tracks = &mut self.out.positions[a * k * steps..(a + 1) * k * steps];
            let lens = &mut self.out.lens[a * k..(a + 1) * k];
            for (track, len) in tracks.chunks_exact_mut(steps).zip(lens) {
                roll_cvm(state, self.params.dt, track);
                *len = steps as u32;
            }
            if let Some(scores) = self.scores.as_deref_mut() {
                let v = cvm_score(self.map, &near, state, self.params.dt, steps);
                scores[a * k..(a + 1) * k].fill(v as f32);
            }
        }
    }

    /// Roll every CLiFF-LHMP sample of every agent in the flavour `MOTION` ([`PAPER`],
    /// [`SPEED`] or [`ANY`]), `SCORES` (scores on, or candidates to rank).
    fn cliff<const MOTION: u8, const SCORES: bool>(self, near: impl Fn(DVec2) -> Option<usize>) {
        let Call {
            map,
            agents,
            params,
            extras,
            rng,
            out,
            mut scores,
            scratch,
        } = self;
        let steps = params.steps();
        let k = params.k;
        let c = extras.candidates;
        if c > 1 {
            scratch.tracks.resize(c * k * steps, [0.0; 2]);
            scratch.lens.resize(c * k, 0);
            scratch.scores.resize(c * k, 0.0);
            scratch.order.resize(c * k, 0);
        }
        for (a, state) in agents.iter().enumerate() {
            let state = &match extras.speed_prior {
                Some(prior) => State {
                    speed: prior.apply(state.speed),
                    ..*state
                },
                None => *state,
            };
            let lanes = Lanes {
                map,
                near: &near,
                state,
                params,
                extras,
            };
            let tracks = &mut out.positions[a * k * steps..(a + 1) * k * steps];
            let lens = &mut out.lens[a * k..(a + 1) * k];
            let agent_scores = scores.as_deref_mut().map(|s| &mut s[a * k..(a + 1) * k]);
            if c == 1 {
                lanes.roll_agent::<MOTION, SCORES>(
                    rng,
                    tracks,
                    lens,
                    agent_scores.unwrap_or(&mut []),
                );
                continue;
            }
            lanes.roll_agent::<MOTION, true>(
                rng,
                &mut scratch.tracks,
                &mut scratch.lens,
                &mut scratch.scores,
            );
            // keep the k that reach furthest, then the highest-scored (ties: drawn first)
            let (cl, cs) = (&scratch.lens, &scratch.scores);
            for (i, o) in scratch.order.iter_mut().enumerate() {
                *o = i as u32;
            }
            scratch.order.sort_unstable_by(|&x, &y| {
                let (x, y) = (x as usize, y as usize);
                cl[y]
                    .cmp(&cl[x])
                    .then(cs[y].total_cmp(&cs[x]))
                    .then(x.cmp(&y))
            });
            for (s, &i) in scratch.order[..k].iter().enumerate() {
                let i = i as usize;
                tracks[s * steps..(s + 1) * steps]
                    .copy_from_slice(&scratch.tracks[i * steps..(i + 1) * steps]);
                lens[s] = scratch.lens[i];
            }
            if let Some(out_scores) = agent_scores {
                for (s, &i) in scratch.order[..k].iter().enumerate() {
                    out_scores[s] = scratch.scores[i as usize];
                }
            }
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

/// The score of a constant-velocity sample: each step at the location near the position
/// it starts from (or [`NO_LOCATION_LOG_DENSITY`]).
fn cvm_score(
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

/// Lane-loop flavour: the paper's method, without per-sample speeds or coasting state.
const PAPER: u8 = 0;
/// Lane-loop flavour: the speed kernel alone (per-sample speeds, no coasting state).
const SPEED: u8 = 1;
/// Lane-loop flavour: any of the speed kernel, coasting and follow, as the options say.
const ANY: u8 = 2;

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

/// What every group of one agent's samples shares.
struct Lanes<'a, F> {
    map: &'a CliffMap,
    near: &'a F,
    state: &'a State,
    params: &'a Params,
    extras: &'a Extras,
}

impl<F: Fn(DVec2) -> Option<usize>> Lanes<'_, F> {
    /// All samples of one agent (`lens.len()` of them), in groups of up to
    /// [`MAX_LANES`].
    fn roll_agent<const MOTION: u8, const SCORES: bool>(
        &self,
        rng: &mut Xoshiro256PlusPlus,
        tracks: &mut [Point],
        lens: &mut [u32],
        scores: &mut [f32],
    ) {
        let steps = tracks.len() / lens.len().max(1);
        for (g, (tracks, lens)) in tracks
            .chunks_mut(MAX_LANES * steps)
            .zip(lens.chunks_mut(MAX_LANES))
            .enumerate()
        {
            let n = lens.len();
            let group_scores: &mut [f32] = if SCORES {
                &mut scores[g * MAX_LANES..g * MAX_LANES + n]
            } else {
                &mut []
            };
            match n {
                1..=4 => self.roll::<4, MOTION, SCORES>(rng, tracks, lens, group_scores),
                5..=8 => self.roll::<8, MOTION, SCORES>(rng, tracks, lens, group_scores),
                9..=12 => self.roll::<12, MOTION, SCORES>(rng, tracks, lens, group_scores),
                13..=16 => self.roll::<16, MOTION, SCORES>(rng, tracks, lens, group_scores),
                _ => self.roll::<MAX_LANES, MOTION, SCORES>(rng, tracks, lens, group_scores),
            }
        }
    }

    /// Up to `N` CLiFF-LHMP samples of one agent: `tracks` holds `lens.len()` samples of
    /// `steps` positions each, `scores` (with `SCORES`) their scores. `N` is a multiple
    /// of four.
    ///
    /// As in the reference: the direction is sampled at the current position, the
    /// person moves, and a new position with no map location near it ends the sample and
    /// is not part of it. (The location found there is the next step's sampling
    /// location, so each step queries the map once.)
    ///
    /// With `MOTION` [`SPEED`] the speed kernel is compiled in, with [`ANY`] the speed
    /// kernel, coasting and follow as the options say (see [`Options`]): a sample that
    /// neither coasts nor changes speed does the same arithmetic and draws as with
    /// [`PAPER`] (same bytes). With `SCORES` each step adds its log-density. With
    /// [`PAPER`] and without scores, the loop is the paper's method and nothing else.
    #[inline(never)]
    fn roll<const N: usize, const MOTION: u8, const SCORES: bool>(
        &self,
        rng: &mut Xoshiro256PlusPlus,
        tracks: &mut [Point],
        lens: &mut [u32],
        scores: &mut [f32],
    ) {
        let Lanes {
            map,
            near,
            state,
            params,
            extras,
        } = *self;
        let n = lens.len();
        debug_assert!(n <= N && N.is_multiple_of(4));
        debug_assert!(!SCORES || scores.len() == n);
        let steps = tracks.len() / n;
        let dt = params.dt;
        let dist = state.speed * dt;
        let moving = MOTION != PAPER;
        let with_speed = match MOTION {
            SPEED => true,
            ANY => extras.speed_beta > 0.0,
            _ => false,
        };
        let with_follow = MOTION == ANY && extras.follow > 0.0;
        let follow_split = with_follow && map.follow_weights_fit();
        let follow = extras.follow as f32;
        let coast_steps = if MOTION == ANY { extras.coast_steps } else { 0 };
        let coasting = coast_steps > 0;
        let theta0 = wrap_2pi(state.heading);
        let (s0, c0) = fastmath::sin_cos(theta0);
        let start = near(state.position);
        let mut px = [state.position.x; N];
        let mut py = [state.position.y; N];
        let mut ux = [c0 as f32; N];
        let mut uy = [s0 as f32; N];
        let mut theta = [theta0; N];
        let mut speed = [state.speed; N];
        let mut loc = [start.unwrap_or(0); N];
        // alive: the sample goes on; on_map: it has a location to sample from (always,
        // without coasting). Lanes n..N stay dead: they never draw, and their
        // arithmetic is discarded.
        let mut alive = [false; N];
        let mut on_map = [false; N];
        let mut coast_left = [coast_steps; N];
        for l in 0..n {
            on_map[l] = start.is_some();
            alive[l] = start.is_some() || coast_steps > 0;
        }
        let mut ts = [0.0f64; N];
        let mut rs = [0.0f64; N];
        // (single precision: a score sums at most a few hundred steps of the horizon's
        // worth, each kept to 1e-7 relative)
        let mut heading = [0.0f32; N];
        // a coasting lane's heading, kept through the turn
        let (mut old_ux, mut old_uy, mut old_theta) = ([0.0f32; N], [0.0f32; N], [0.0f64; N]);
        let mut step_score = [0.0f32; N];
        let mut score = [0.0f32; N];
        lens.fill(0);
        for j in 0..steps {
            // Phase 1: draw at each sampling lane's location (in lane order); follow's
            // weights, which draw nothing, first for all lanes.
            let weights = if follow_split {
                follow_weights::<N>(map, &loc, &ux, &uy, &alive, &on_map, follow)
            } else {
                [FollowWeights::default(); N]
            };
            let mut drawing = [false; N];
            for l in 0..N {
                if alive[l] && (MOTION != ANY || on_map[l]) {
                    drawing[l] = true;
                    if with_speed {
                        (ts[l], rs[l]) = map.velocity_at(loc[l], rng);
                    } else if follow_split {
                        ts[l] = map.draw_following(loc[l], &weights[l], rng);
                    } else if with_follow {
                        let (hx, hy) = (ux[l] as f64, uy[l] as f64);
                        ts[l] = map.direction_following(loc[l], hx, hy, extras.follow, rng);
                    } else {
                        ts[l] = map.direction_at(loc[l]).sample_unwrapped(rng);
                    }
                }
            }
            // Phase 2: turn every lane (straight-line arithmetic, lanes interleaved).
            if coasting {
                (old_ux, old_uy, old_theta) = (ux, uy, theta);
            }
            match params.heading {
                HeadingRule::CircularMean => {
                    // Single precision: a heading error of 1e-7 rad per step is far below
                    // the sampling noise, and four f32 lanes fill one SSE2 register.
                    // (Converted first: a loop that reads f64 lanes vectorises two lanes
                    // at a time.)
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
            // The options: a coasting lane keeps its heading and speed; the speed moves
            // towards the drawn one.
            if moving {
                if with_speed {
                    // branch-free over the lanes (single-precision kernel weight)
                    let beta = extras.speed_beta as f32;
                    let d: [f32; N] = std::array::from_fn(|l| (rs[l] - speed[l]) as f32);
                    let lambda: [f32; N] =
                        std::array::from_fn(|l| fastmath::exp_neg_f32(-beta * d[l] * d[l]));
                    for l in 0..N {
                        let moved = speed[l] + (lambda[l] * d[l]) as f64;
                        // (without coasting every live lane drew; the others are dead)
                        speed[l] = if drawing[l] || !coasting {
                            moved
                        } else {
                            speed[l]
                        };
                    }
                }
                if coasting {
                    for l in 0..N {
                        if !drawing[l] {
                            ux[l] = old_ux[l];
                            uy[l] = old_uy[l];
                            theta[l] = old_theta[l];
                        }
                    }
                }
            }
            // The step's log-density (the headings' angles four lanes at a time).
            if SCORES {
                for l in 0..N {
                    heading[l] = fastmath::atan2_f32(uy[l], ux[l]);
                }
                for l in 0..N {
                    step_score[l] = if drawing[l] {
                        map.step_log_density_at(loc[l], heading[l], speed[l] as f32)
                    } else {
                        NO_LOCATION_LOG_DENSITY as f32
                    };
                }
            }
            for l in 0..N {
                let dist = if moving { speed[l] * dt } else { dist };
                px[l] += ux[l] as f64 * dist;
                py[l] += uy[l] as f64 * dist;
            }
            // Phase 3: look up the new positions; off the map a lane coasts or ends.
            let mut any = false;
            for l in 0..N {
                if !alive[l] {
                    continue;
                }
                match near(DVec2::new(px[l], py[l])) {
                    Some(next) => {
                        loc[l] = next;
                        if MOTION == ANY {
                            on_map[l] = true;
                            coast_left[l] = coast_steps;
                        }
                    }
                    None if MOTION == ANY && coast_left[l] > 0 => {
                        coast_left[l] -= 1;
                        on_map[l] = false;
                    }
                    None => {
                        alive[l] = false;
                        continue;
                    }
                }
                tracks[l * steps + j] = [px[l] as f32, py[l] as f32];
                lens[l] = j as u32 + 1;
                if SCORES {
                    score[l] += step_score[l];
                }
                any = true;
            }
            if !any {
                break;
            }
        }
        for (l, &len) in lens.iter().enumerate() {
            tracks[l * steps + len as usize..(l + 1) * steps].fill([f32::NAN; 2]);
            if SCORES {
                scores[l] = (score[l] as f64
                    + (steps - len as usize) as f64 * NO_LOCATION_LOG_DENSITY)
                    as f32;
            }
        }
    }
}

/// The follow weights of every lane that samples the map ([`CliffMap::follow_weights`]),
/// computed apart from the lane loop (which stays small) and before the lanes draw.
#[inline(never)]
fn follow_weights<const N: usize>(
    map: &CliffMap,
    loc: &[usize; N],
    ux: &[f32; N],
    uy: &[f32; N],
    alive: &[bool; N],
    on_map: &[bool; N],
    follow: f32,
) -> [FollowWeights; N] {
    let mut w = [FollowWeights::default(); N];
    for l in 0..N {
        if alive[l] && on_map[l] {
            w[l] = map.follow_weights(loc[l], ux[l], uy[l], follow);
        }
    }
    w
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
