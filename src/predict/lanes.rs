//! The CLiFF-LHMP lane loop: the samples of one agent rolled side by side, step by
//! step, in the flavour (const parameters) the options need.

use std::f64::consts::PI;

use glam::DVec2;

use super::options::NO_LOCATION_LOG_DENSITY;
use super::{HeadingRule, Params, Point};
use crate::map::{CliffMap, FollowWeights, NeighbourTable};
use crate::math::fastmath;
use crate::math::lane_rng::{LaneRngs, lane_seed, normal_f32_with, unit_f32};
use crate::math::simd::{MulAdd, Separate};
use crate::math::{Simd, wrap_2pi};
use crate::motion::{SpeedPrior, State};

/// The options as the lane loop uses them.
#[derive(Debug, Clone, Copy)]
pub(super) struct Extras {
    pub(super) speed_beta: f64,
    /// Positions a sample may coast off the map.
    pub(super) coast_steps: u32,
    pub(super) follow: f64,
    /// Samples drawn per kept sample (at least 1).
    pub(super) candidates: usize,
    /// [`Options::prune`](super::Options::prune): candidates rolled in pruned stretches.
    pub(super) prune: bool,
    pub(super) speed_prior: Option<SpeedPrior>,
    /// [`Options::trust`](super::Options::trust), seconds (0: off).
    pub(super) trust: f64,
    /// [`Options::blend`](super::Options::blend), seconds (0: off).
    pub(super) blend: f64,
    /// [`Options::motion`](super::Options::motion): the samples bent towards the motion
    /// model after the rollout.
    pub(super) motion: bool,
    /// Scores by [`Rank::Consensus`](super::Rank::Consensus) instead of likelihood.
    pub(super) consensus: bool,
    /// The instructions the loop runs on (an available path: [`Simd::available`]).
    pub(super) simd: Simd,
}

/// Lane-loop flavour: the paper's method, without per-sample speeds or coasting state.
pub(super) const PAPER: u8 = 0;
/// Lane-loop flavour: the speed kernel alone (per-sample speeds, no coasting state).
pub(super) const SPEED: u8 = 1;
/// Lane-loop flavour: any of the speed kernel, coasting and follow, as the options say.
pub(super) const ANY: u8 = 2;

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
pub(super) const MAX_LANES: usize = 20;

/// The most samples a group of the AVX2 intrinsics loops holds: three registers of
/// eight (`lanes_avx2.rs`, `lanes_options_avx2.rs`), and so the groups of a pruned
/// rollout's stretches where the options' loop rolls them
/// ([`Lanes::stretch_lanes`]).
pub(super) const PACK: usize = 24;

/// Where the lanes of one group are between stretches of steps: what the lane loop
/// carries from one step to the next (lanes past the group's samples stay dead).
#[derive(Debug, Clone, Copy)]
pub(super) struct LaneState<const N: usize> {
    pub(super) px: [f64; N],
    pub(super) py: [f64; N],
    pub(super) ux: [f32; N],
    pub(super) uy: [f32; N],
    theta: [f64; N],
    pub(super) speed: [f64; N],
    pub(super) loc: [usize; N],
    pub(super) alive: [bool; N],
    on_map: [bool; N],
    coast_left: [u32; N],
    /// The steps' log-densities summed so far (with scores).
    pub(super) score: [f32; N],
    /// Each lane's generator.
    pub(super) rng: LaneRngs<N>,
}

/// One sample's lane of a [`LaneState`], kept between the stretches of a pruned
/// rollout (`prune.rs`).
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Lane {
    px: f64,
    py: f64,
    ux: f32,
    uy: f32,
    theta: f64,
    speed: f64,
    loc: usize,
    alive: bool,
    on_map: bool,
    coast_left: u32,
    /// The sample's log-densities summed so far.
    pub(super) score: f32,
    /// The sample's generator.
    rng: [u32; 4],
}

impl Lane {
    /// The same sample drawing from the generator `rng` from now on (a copy of a
    /// candidate that a checkpoint keeps: [`Checkpoint`](super::Checkpoint)).
    pub(super) fn reseed(&mut self, rng: [u32; 4]) {
        self.rng = rng;
    }

    /// The map location at the sample's position where the lane loop found one (the
    /// lookup's answer there, kept with the lane), `None` where it did not (an ended
    /// or coasting sample: look the position up again).
    pub(super) fn location(&self) -> Option<usize> {
        (self.alive && self.on_map).then_some(self.loc)
    }

    /// Whether the sample goes on, its position, its heading (a unit vector) and speed.
    pub(super) fn motion(&self) -> (bool, DVec2, [f32; 2], f64) {
        (
            self.alive,
            DVec2::new(self.px, self.py),
            [self.ux, self.uy],
            self.speed,
        )
    }
}

impl<const N: usize> LaneState<N> {
    /// The lanes `lanes` (at most `N`; the others dead).
    pub(super) fn load(lanes: &[Lane]) -> Self {
        let mut st = LaneState {
            px: [0.0; N],
            py: [0.0; N],
            ux: [1.0; N],
            uy: [0.0; N],
            theta: [0.0; N],
            speed: [0.0; N],
            loc: [0; N],
            alive: [false; N],
            on_map: [false; N],
            coast_left: [0; N],
            score: [0.0; N],
            rng: LaneRngs::zero(),
        };
        for (l, lane) in lanes.iter().enumerate() {
            st.px[l] = lane.px;
            st.py[l] = lane.py;
            st.ux[l] = lane.ux;
            st.uy[l] = lane.uy;
            st.theta[l] = lane.theta;
            st.speed[l] = lane.speed;
            st.loc[l] = lane.loc;
            st.alive[l] = lane.alive;
            st.on_map[l] = lane.on_map;
            st.coast_left[l] = lane.coast_left;
            st.score[l] = lane.score;
            st.rng.set(l, lane.rng);
        }
        st
    }

    /// Write the first `lanes.len()` lanes into `lanes`.
    pub(super) fn store(&self, lanes: &mut [Lane]) {
        for (l, lane) in lanes.iter_mut().enumerate() {
            *lane = Lane {
                px: self.px[l],
                py: self.py[l],
                ux: self.ux[l],
                uy: self.uy[l],
                theta: self.theta[l],
                speed: self.speed[l],
                loc: self.loc[l],
                alive: self.alive[l],
                on_map: self.on_map[l],
                coast_left: self.coast_left[l],
                score: self.score[l],
                rng: self.rng.get(l),
            };
        }
    }
}

/// End a sample of `track.len()` steps that reached `len`: the positions after it NaN;
/// its score, the `partial` log-density of its steps and [`NO_LOCATION_LOG_DENSITY`] for
/// each step it does not reach.
#[inline]
pub(super) fn finish_sample(track: &mut [Point], len: u32, partial: f32) -> f32 {
    let steps = track.len();
    track[len as usize..].fill([f32::NAN; 2]);
    (partial as f64 + (steps - len as usize) as f64 * NO_LOCATION_LOG_DENSITY) as f32
}

/// What every group of one agent's samples shares.
pub(super) struct Lanes<'a, F> {
    pub(super) map: &'a CliffMap,
    pub(super) near: &'a F,
    pub(super) state: &'a State,
    /// The observed speed (`state.speed` is the speed prior's, when on).
    pub(super) observed_speed: f64,
    pub(super) params: &'a Params,
    pub(super) extras: &'a Extras,
    /// The neighbour table `near` answers from, if it is one (the AVX2 loop of the
    /// paper's method reads it directly).
    pub(super) table: Option<&'a NeighbourTable>,
}

impl<F: Fn(DVec2) -> Option<usize>> Lanes<'_, F> {
    /// All samples of one agent (`lens.len()` of them), in groups of up to
    /// [`MAX_LANES`]; sample `s` draws from the generator `lane_seed(key, s)`.
    pub(super) fn roll_agent<const MOTION: u8, const SCORES: bool>(
        &self,
        key: u64,
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
            let first = g * MAX_LANES;
            self.group_any::<MOTION, SCORES>(
                (key, first),
                None,
                0,
                steps,
                tracks,
                lens,
                group_scores,
            );
        }
    }

    /// Steps `from..to` of one group of samples of one agent (`lens.len()` of them, at
    /// most [`stretch_lanes`](Self::stretch_lanes); `tracks` their positions), scored
    /// with `SCORES` (else the lanes' scores stay as they are), from the lanes `lanes`
    /// (from the agent's start when `from` is 0, the group's samples then numbered from
    /// `first` for their generators), which it updates: a stretch of a pruned
    /// rollout. The tracks' positions after the stretch are left as they are, and the
    /// lanes hold the partial scores ([`finish_sample`] ends a sample).
    #[allow(clippy::too_many_arguments)] // the group's buffers
    pub(super) fn roll_stretch<const MOTION: u8, const SCORES: bool>(
        &self,
        (key, first): (u64, usize),
        lanes: &mut [Lane],
        from: usize,
        to: usize,
        tracks: &mut [Point],
        lens: &mut [u32],
    ) {
        debug_assert!(lanes.len() == lens.len() && lens.len() <= self.stretch_lanes::<MOTION>());
        #[cfg(target_arch = "x86_64")]
        if lens.len() > MAX_LANES {
            // (groups this large only where the options' AVX2 loop rolls them)
            self.roll_stretch24::<SCORES>((key, first), lanes, (from, to), tracks, lens);
            return;
        }
        self.group_any::<MOTION, SCORES>(
            (key, first),
            Some(lanes),
            from,
            to,
            tracks,
            lens,
            &mut [],
        );
    }

    /// The most samples a group of a pruned rollout's stretches holds
    /// ([`roll_stretch`](Self::roll_stretch)): three full AVX2 registers (24) where the
    /// options' AVX2 loop rolls them (`lanes_options_avx2.rs`), else [`MAX_LANES`]. (How
    /// the samples are grouped changes no sample: each draws from its own generator.)
    pub(super) fn stretch_lanes<const MOTION: u8>(&self) -> usize {
        #[cfg(target_arch = "x86_64")]
        if self.extras.simd == Simd::Avx2Fma
            && self.table.is_some()
            && self.options_avx2_fits::<MOTION>()
        {
            return PACK;
        }
        MAX_LANES
    }

    /// One group (at most [`MAX_LANES`] samples) in the copy of the loop with the
    /// smallest lane count that holds it.
    #[allow(clippy::too_many_arguments)] // the group's buffers
    fn group_any<const MOTION: u8, const SCORES: bool>(
        &self,
        seeds: (u64, usize),
        lanes: Option<&mut [Lane]>,
        from: usize,
        to: usize,
        tracks: &mut [Point],
        lens: &mut [u32],
        scores: &mut [f32],
    ) {
        let args = (seeds, lanes, from, to, tracks, lens, scores);
        match args.5.len() {
            1..=4 => self.group::<4, MOTION, SCORES>(args),
            5..=8 => self.group::<8, MOTION, SCORES>(args),
            9..=12 => self.group::<12, MOTION, SCORES>(args),
            13..=16 => self.group::<16, MOTION, SCORES>(args),
            _ => self.group::<MAX_LANES, MOTION, SCORES>(args),
        }
    }

    /// [`group_any`](Self::group_any) with `N` lanes: the lanes' state from the start
    /// or from `lanes`, the steps on the path the extras name, then the samples ended
    /// (whole rollouts) or the lanes stored (stretches).
    #[allow(clippy::type_complexity)] // group_any's arguments, passed through
    #[inline(always)]
    fn group<const N: usize, const MOTION: u8, const SCORES: bool>(
        &self,
        ((key, first), lanes, from, to, tracks, lens, scores): (
            (u64, usize),
            Option<&mut [Lane]>,
            usize,
            usize,
            &mut [Point],
            &mut [u32],
            &mut [f32],
        ),
    ) {
        let n = lens.len();
        let steps = tracks.len() / n;
        debug_assert!(!SCORES || lanes.is_some() || scores.len() == n);
        let mut st = match &lanes {
            Some(lanes) if from > 0 => LaneState::load(lanes),
            _ => {
                lens.fill(0);
                self.start::<N, MOTION>(n, key, first)
            }
        };
        #[cfg(target_arch = "x86_64")]
        if self.extras.simd == Simd::Avx2Fma {
            match self.table {
                // the paper's method, whole, with or without scores: in AVX2 registers
                Some(table)
                    if MOTION == PAPER
                        && lanes.is_none()
                        && self.params.heading == HeadingRule::CircularMean
                        && self.map.lane_width().is_some() =>
                {
                    // SAFETY: `Extras::simd` is a path the processor has
                    // (`Simd::available`, checked where the call's extras are made), so
                    // AVX2 and FMA exist; the map's lane tables have a width.
                    unsafe { self.roll_paper_avx2::<N, SCORES>(table, &mut st, tracks, lens) }
                }
                // follow, trust, blend and scores (the `improved` step): in AVX2 registers
                Some(table) if self.options_avx2_fits::<MOTION>() => {
                    // SAFETY: AVX2 and FMA as above; the options fit; `table` is the
                    // table `near` answers from.
                    unsafe {
                        self.roll_options_avx2::<N, SCORES>(
                            table,
                            &mut st,
                            (from, to),
                            tracks,
                            lens,
                        )
                    }
                }
                // SAFETY: as above.
                _ => unsafe {
                    self.roll_avx2::<N, MOTION, SCORES>(&mut st, from, to, tracks, lens)
                },
            }
        } else {
            self.roll::<N, MOTION, SCORES>(&mut st, from, to, tracks, lens);
        }
        #[cfg(not(target_arch = "x86_64"))]
        self.roll::<N, MOTION, SCORES>(&mut st, from, to, tracks, lens);
        match lanes {
            Some(lanes) => st.store(lanes),
            None => {
                for (l, (track, &len)) in tracks.chunks_exact_mut(steps).zip(&*lens).enumerate() {
                    let score = finish_sample(track, len, st.score[l]);
                    if SCORES {
                        scores[l] = score;
                    }
                }
            }
        }
    }

    /// The lanes of `n` samples at the agent's start, lane `l`'s generator
    /// `lane_seed(key, first + l)`.
    #[inline(always)]
    pub(super) fn start<const N: usize, const MOTION: u8>(
        &self,
        n: usize,
        key: u64,
        first: usize,
    ) -> LaneState<N> {
        let (state, extras) = (self.state, self.extras);
        let coast_steps = if MOTION == ANY { extras.coast_steps } else { 0 };
        let trusting = MOTION == ANY && extras.trust > 0.0;
        let theta0 = wrap_2pi(state.heading);
        let (s0, c0) = fastmath::sin_cos(theta0);
        let start = (self.near)(state.position);
        let mut st = LaneState {
            px: [state.position.x; N],
            py: [state.position.y; N],
            ux: [c0 as f32; N],
            uy: [s0 as f32; N],
            theta: [theta0; N],
            speed: [if trusting {
                self.observed_speed
            } else {
                state.speed
            }; N],
            loc: [start.unwrap_or(0); N],
            // alive: the sample goes on; on_map: it has a location to sample from
            // (always, without coasting). Lanes n..N stay dead: they never draw, and
            // their arithmetic is discarded.
            alive: [false; N],
            on_map: [false; N],
            coast_left: [coast_steps; N],
            score: [0.0; N],
            rng: LaneRngs::zero(),
        };
        for l in 0..n {
            st.on_map[l] = start.is_some();
            st.alive[l] = start.is_some() || coast_steps > 0;
            st.rng.set(l, lane_seed(key, (first + l) as u64));
        }
        st
    }

    /// [`roll_body`](Self::roll_body) on the baseline instructions.
    #[inline(never)]
    #[allow(clippy::too_many_arguments)] // the group's buffers
    fn roll<const N: usize, const MOTION: u8, const SCORES: bool>(
        &self,
        st: &mut LaneState<N>,
        from: usize,
        to: usize,
        tracks: &mut [Point],
        lens: &mut [u32],
    ) {
        self.roll_body::<N, MOTION, SCORES, Separate>(st, from, to, tracks, lens)
    }

    /// [`roll_body`](Self::roll_body) compiled for AVX2 and FMA (eight single-precision
    /// lanes per instruction, multiply-adds fused).
    ///
    /// # Safety
    /// The processor must have AVX2 and FMA ([`Simd::Avx2Fma`] available).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    #[inline(never)]
    #[allow(clippy::too_many_arguments)] // the group's buffers
    unsafe fn roll_avx2<const N: usize, const MOTION: u8, const SCORES: bool>(
        &self,
        st: &mut LaneState<N>,
        from: usize,
        to: usize,
        tracks: &mut [Point],
        lens: &mut [u32],
    ) {
        self.roll_body::<N, MOTION, SCORES, crate::math::simd::Fused>(st, from, to, tracks, lens)
    }

    /// Steps `from..to` of up to `N` CLiFF-LHMP samples of one agent from the lanes
    /// `st`: `tracks` holds `lens.len()` samples of `steps` positions each. `N` is a
    /// multiple of four. A whole rollout is the lanes at the start, steps `0..steps`,
    /// then each sample ended ([`finish_sample`]).
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
    /// `M` says how its single-precision kernels and position updates multiply and add
    /// (fused only in the AVX2 copy).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)] // the group's buffers
    fn roll_body<const N: usize, const MOTION: u8, const SCORES: bool, M: MulAdd>(
        &self,
        st: &mut LaneState<N>,
        from: usize,
        to: usize,
        tracks: &mut [Point],
        lens: &mut [u32],
    ) {
        let Lanes {
            map,
            near,
            state,
            observed_speed,
            params,
            extras,
            ..
        } = *self;
        let n = lens.len();
        debug_assert!(n <= N && N.is_multiple_of(4));
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
        let blend = MOTION == ANY && extras.blend > 0.0;
        let trusting = MOTION == ANY && extras.trust > 0.0;
        let theta0 = wrap_2pi(state.heading);
        let (s0, c0) = fastmath::sin_cos(theta0);
        let LaneState {
            mut px,
            mut py,
            mut ux,
            mut uy,
            mut theta,
            mut speed,
            mut loc,
            mut alive,
            mut on_map,
            mut coast_left,
            mut score,
            mut rng,
        } = *st;
        let mut ts = [0.0f32; N];
        let mut rs = [0.0f64; N];
        // (single precision: a score sums at most a few hundred steps of the horizon's
        // worth, each kept to 1e-7 relative)
        let mut heading = [0.0f32; N];
        // a coasting lane's heading, kept through the turn
        let (mut old_ux, mut old_uy, mut old_theta) = ([0.0f32; N], [0.0f32; N], [0.0f64; N]);
        let mut step_score = [0.0f32; N];
        for j in from..to {
            // Trust: how far the map has taken over from the observed motion at the
            // start of this step (0 at the first); the speed moves from the observed one
            // towards the prior's as the heading kernel gains weight.
            let gain = if trusting {
                1.0 - fastmath::exp_neg(-(j as f64) * dt / extras.trust)
            } else {
                1.0
            };
            if trusting && !with_speed {
                speed = [observed_speed + (state.speed - observed_speed) * gain; N];
            }
            // Blend: this step's constant-velocity position and its weight.
            let (cv_weight, cv_x, cv_y) = if blend {
                let d = observed_speed * dt * (j + 1) as f64;
                (
                    fastmath::exp_neg(-(j as f64) * dt / extras.blend),
                    state.position.x + c0 * d,
                    state.position.y + s0 * d,
                )
            } else {
                (0.0, 0.0, 0.0)
            };
            // Phase 1: draw at each sampling lane's location; follow's weights, which
            // draw nothing, first for all lanes. Every lane's generator gives its words
            // for the step (two, three with the speed kernel), whether the lane draws
            // or not, so a sample's draws depend on its own generator alone.
            let weights = if follow_split {
                follow_weights_on::<N>(extras.simd, map, &loc, &ux, &uy, &alive, &on_map, follow)
            } else {
                [FollowWeights::default(); N]
            };
            let pick = rng.next();
            let normal = rng.next();
            let noise = if with_speed { rng.next() } else { [0; N] };
            let z: [f32; N] = std::array::from_fn(|l| normal_f32_with::<M>(normal[l]));
            let mut drawing = [false; N];
            for l in 0..N {
                if alive[l] && (MOTION != ANY || on_map[l]) {
                    drawing[l] = true;
                    let u = unit_f32(pick[l]);
                    if with_speed {
                        (ts[l], rs[l]) = map.lane_velocity::<M>(loc[l], u, z[l], noise[l]);
                    } else if follow_split {
                        ts[l] = map.lane_following::<M>(loc[l], &weights[l], u, z[l]);
                    } else if with_follow {
                        ts[l] = map
                            .lane_direction_following::<M>(loc[l], ux[l], uy[l], follow, u, z[l]);
                    } else {
                        ts[l] = map.lane_direction::<M>(loc[l], u, z[l]);
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
                    let beta = params.beta as f32;
                    // (eight lanes at a time: one AVX register, or two SSE2 ones)
                    let (ts8, ts4) = ts.as_chunks::<8>();
                    let (ux8, ux4) = ux.as_chunks_mut::<8>();
                    let (uy8, uy4) = uy.as_chunks_mut::<8>();
                    if trusting {
                        let gain = gain as f32;
                        for ((t, hx), hy) in ts8.iter().zip(ux8).zip(uy8) {
                            turn::<8, M, true>(t, hx, hy, beta, gain);
                        }
                        if let (Some(t), Some(hx), Some(hy)) = (
                            ts4.first_chunk::<4>(),
                            ux4.first_chunk_mut::<4>(),
                            uy4.first_chunk_mut::<4>(),
                        ) {
                            turn::<4, M, true>(t, hx, hy, beta, gain);
                        }
                    } else {
                        for ((t, hx), hy) in ts8.iter().zip(ux8).zip(uy8) {
                            turn::<8, M, false>(t, hx, hy, beta, 1.0);
                        }
                        if let (Some(t), Some(hx), Some(hy)) = (
                            ts4.first_chunk::<4>(),
                            ux4.first_chunk_mut::<4>(),
                            uy4.first_chunk_mut::<4>(),
                        ) {
                            turn::<4, M, false>(t, hx, hy, beta, 1.0);
                        }
                    }
                }
                HeadingRule::Paper => {
                    for l in 0..N {
                        let mut signed = wrap_2pi(ts[l] as f64) - theta[l];
                        if signed > PI {
                            signed -= 2.0 * PI;
                        } else if signed < -PI {
                            signed += 2.0 * PI;
                        }
                        let mut lambda = fastmath::exp_neg(-params.beta * signed * signed);
                        if trusting {
                            lambda *= gain;
                        }
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
                    let lambda: [f32; N] = std::array::from_fn(|l| {
                        fastmath::exp_neg_f32_with::<M>(-beta * d[l] * d[l])
                    });
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
                    heading[l] = fastmath::atan2_f32_with::<M>(uy[l], ux[l]);
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
                px[l] = M::madd(ux[l] as f64, dist, px[l]);
                py[l] = M::madd(uy[l] as f64, dist, py[l]);
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
                tracks[l * steps + j] = if blend {
                    let w = cv_weight;
                    [
                        (w * cv_x + (1.0 - w) * px[l]) as f32,
                        (w * cv_y + (1.0 - w) * py[l]) as f32,
                    ]
                } else {
                    [px[l] as f32, py[l] as f32]
                };
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
        *st = LaneState {
            px,
            py,
            ux,
            uy,
            theta,
            speed,
            loc,
            alive,
            on_map,
            coast_left,
            score,
            rng,
        };
    }
}

/// [`follow_weights`] on the path `simd` (the lane loop's).
#[allow(clippy::too_many_arguments)] // the lane loop's arrays, passed through
#[inline(always)]
fn follow_weights_on<const N: usize>(
    simd: Simd,
    map: &CliffMap,
    loc: &[usize; N],
    ux: &[f32; N],
    uy: &[f32; N],
    alive: &[bool; N],
    on_map: &[bool; N],
    follow: f32,
) -> [FollowWeights; N] {
    #[cfg(target_arch = "x86_64")]
    if simd == Simd::Avx2Fma {
        // SAFETY: the lane loop runs on `Simd::Avx2Fma` only where it is available.
        return unsafe { follow_weights_avx2::<N>(map, loc, ux, uy, alive, on_map, follow) };
    }
    let _ = simd;
    follow_weights::<N>(map, loc, ux, uy, alive, on_map, follow)
}

/// [`follow_weights`] compiled for AVX2 and FMA, the same bits: two lanes to a
/// register where their locations hold at most four components, a location's eight in
/// one register where it holds more ([`CliffMap::follow_weights_pair_avx2`],
/// [`CliffMap::follow_weights_avx2`]).
///
/// # Safety
/// The processor must have AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline(never)]
unsafe fn follow_weights_avx2<const N: usize>(
    map: &CliffMap,
    loc: &[usize; N],
    ux: &[f32; N],
    uy: &[f32; N],
    alive: &[bool; N],
    on_map: &[bool; N],
    follow: f32,
) -> [FollowWeights; N] {
    let mut w = [FollowWeights::default(); N];
    let wanted = |l: usize| alive[l] && on_map[l];
    // two lanes to a register where their locations hold at most four components each
    for l in (0..N).step_by(2) {
        if !(wanted(l) || wanted(l + 1)) {
            continue;
        }
        let index = [loc[l], loc[l + 1]];
        let (x, y) = ([ux[l], ux[l + 1]], [uy[l], uy[l + 1]]);
        // SAFETY: AVX2 and FMA, as this function requires.
        if let Some([a, b]) = unsafe { map.follow_weights_pair_avx2(index, x, y, follow) } {
            // (a lane that does not sample keeps no weights, as on the baseline path)
            if wanted(l) {
                w[l] = a;
            }
            if wanted(l + 1) {
                w[l + 1] = b;
            }
            continue;
        }
        for l in [l, l + 1] {
            if wanted(l) {
                // SAFETY: as above.
                w[l] = unsafe { map.follow_weights_avx2(loc[l], ux[l], uy[l], follow) };
            }
        }
    }
    w
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

/// The reference's heading update for `L` lanes: the circular weighted mean of the
/// sampled direction `t` (weight `lambda = exp(-beta * delta^2)`) and the heading
/// `(hx, hy)` (weight `1 - lambda`), as a unit vector. Straight-line code over the
/// lanes, which the compiler turns into SSE2 instructions (AVX2 and FMA in the loop's
/// AVX2 copy, with `M` fused). With `GAIN` the kernel's weight is scaled by `gain`
/// ([`Options::trust`](super::Options::trust)).
#[inline(always)]
fn turn<const L: usize, M: MulAdd, const GAIN: bool>(
    t: &[f32; L],
    hx: &mut [f32; L],
    hy: &mut [f32; L],
    beta: f32,
    gain: f32,
) {
    let m = M::madd32;
    for l in 0..L {
        let (sin, cos) = fastmath::sin_cos_f32_with::<M>(t[l]);
        let (x, y) = (hx[l], hy[l]);
        // |shortest angle| between the sample and the heading, in [0, pi].
        let delta = fastmath::acos_f32_with::<M>(m(cos, x, sin * y));
        let mut lambda = fastmath::exp_neg_f32_with::<M>(-beta * delta * delta);
        if GAIN {
            lambda *= gain;
        }
        let vx = m(cos, lambda, x * (1.0 - lambda));
        let vy = m(sin, lambda, y * (1.0 - lambda));
        let n2 = m(vx, vx, vy * vy);
        // Exactly opposite with lambda = 1/2: the reference's atan2(0, 0) = 0.
        let ok = n2 > 1e-20;
        let inv = 1.0 / n2.max(1e-20).sqrt();
        hx[l] = if ok { vx * inv } else { 1.0 };
        hy[l] = if ok { vy * inv } else { 0.0 };
    }
}
