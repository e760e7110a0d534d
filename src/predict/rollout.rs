//! The rollout: one call's random generator, its options, and the checks of a call.
//!
//! Every prediction ([`predict`](super::predict), [`predict_with`](super::predict_with),
//! a server's chunks) runs through [`Rollout::predict_agents`], which hands the call to
//! the flavour dispatch (`call.rs`), and every CLiFF-LHMP sample through one lane loop
//! (`lanes.rs`). The loop is compiled in a few flavours (const parameters): the paper's
//! method alone, with scores, and with the speed kernel or coasting (with and without
//! scores). The paper's flavour has none of the options' arithmetic or bookkeeping, so
//! the options cost nothing when they are off. Each flavour has a baseline copy and an
//! AVX2 + FMA copy, chosen at run time ([`Simd`](crate::math::Simd)).

use std::sync::Arc;

use glam::DVec2;

use super::call::Call;
use super::candidates::Candidates;
use super::lanes::Extras;
use super::options::Options;
use super::{BatchMut, Method, Params, PredictError, TrajectoryBatch, preset};
use crate::map::{CliffMap, Lookup};
use crate::math::Simd;
use crate::motion::{History, MotionModel, State};

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
/// same `Rollout` gives the same bytes (and scores), since each agent draws from a
/// generator of its own, seeded from the call's seed and the agent's place in the call;
/// a server uses this to interleave a large request with others. Chunks may also run at
/// once on other threads, each from a copy [`ahead`](Rollout::ahead) of the chunks
/// before it ([`predict_agents_parallel`](Rollout::predict_agents_parallel)).
///
/// (Before this scheme one generator drew for all agents in order: calls with more
/// than one agent gave other samples then; one-agent calls give the same.)
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
    /// The call's seed; agent `i` of the call draws from generators keyed
    /// `seeds::agent_key(seed, i)`.
    seed: u64,
    /// Agents predicted so far (the index of the next agent in the call).
    next_agent: u64,
    /// Buffers for [`Options::candidates`], grown once and reused (and left to the next
    /// rollout on the thread when this one is dropped).
    scratch: Candidates,
    /// The instructions the lane loop runs on (available on this processor).
    simd: Simd,
    /// The motion model of [`Method::Motion`] (none: the built-in one).
    motion: Option<Arc<MotionModel>>,
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
            seed: params.seed,
            next_agent: 0,
            scratch: Candidates::reuse(),
            simd: Simd::active(),
            motion: None,
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
        self.seed = params.seed;
        self.next_agent = 0;
        Ok(())
    }

    /// The same rollout with another neighbour-table path.
    pub fn with_tables(mut self, tables: Tables) -> Self {
        self.tables = tables;
        self
    }

    /// The same rollout on the instructions `simd` ([`Simd::active`] by default, which
    /// honours `CLIFF_SIMD`); a path the processor does not have falls back to
    /// [`Simd::Baseline`]. The two paths differ in the last bits of the positions
    /// (see [`Simd`]).
    pub fn with_simd(mut self, simd: Simd) -> Self {
        self.simd = if simd.available() {
            simd
        } else {
            Simd::Baseline
        };
        self
    }

    /// The same rollout with the motion model `model` for [`Method::Motion`] instead of
    /// the built-in one ([`MotionModel::builtin`]).
    pub fn with_motion_model(mut self, model: Arc<MotionModel>) -> Self {
        self.motion = Some(model);
        self
    }

    /// The motion model [`Method::Motion`] predicts with.
    pub fn motion_model(&self) -> &MotionModel {
        self.motion.as_deref().unwrap_or(MotionModel::builtin())
    }

    /// The instructions the lane loop runs on.
    pub fn simd(&self) -> Simd {
        self.simd
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
        self.predict_agents_observed(map, agents, None, out, scores)
    }

    /// [`predict_agents`](Self::predict_agents) with each agent's observed
    /// [`History`] (one per agent, `histories[i]` ending at `agents[i]`'s position),
    /// which [`Method::Motion`], [`Method::CvmLast`] and
    /// [`Options::motion`](super::Options::motion) read; the rest ignores them. Without
    /// histories they take the path of constant velocity up to each state.
    pub fn predict_agents_observed(
        &mut self,
        map: &CliffMap,
        agents: &[State],
        histories: Option<&[History]>,
        out: BatchMut<'_>,
        scores: Option<&mut [f32]>,
    ) -> Result<(), PredictError> {
        if let Some(h) = histories
            && h.len() != agents.len()
        {
            return Err(PredictError::Param {
                name: "histories",
                why: format!("{} histories for {} agents", h.len(), agents.len()),
            });
        }
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
        let first_agent = self.next_agent;
        self.next_agent += agents.len() as u64;
        let extras = Extras {
            speed_beta: options.speed_beta,
            coast_steps: options.coast_steps(params.dt),
            follow: options.follow,
            candidates: options.candidates.max(1) as usize,
            prune: options.prune,
            speed_prior: if options.speed_prior {
                map.speed_prior()
            } else {
                None
            },
            trust: options.trust,
            blend: options.blend,
            motion: options.motion,
            consensus: options.rank == super::Rank::Consensus,
            simd: self.simd,
        };
        let lookup = match (params.method, scores.is_some(), self.tables) {
            // constant velocity looks the map up only for scores, the motion model never
            (Method::Cvm | Method::CvmLast, false, _) | (Method::Motion, _, _) => None,
            (_, _, Tables::Build) => Some(map.lookup(params.radius)),
            (_, _, Tables::CachedOnly) => Some(map.cached_lookup(params.radius)),
        };
        let call = Call {
            map,
            agents,
            histories,
            motion: self.motion.as_deref().unwrap_or(MotionModel::builtin()),
            params,
            extras: &extras,
            seed: self.seed,
            first_agent,
            out,
            scores,
            scratch: &mut self.scratch,
        };
        match lookup {
            None if params.method == Method::Motion => call.motion(),
            None => call.cvm(|_: DVec2| None::<usize>),
            Some(Lookup::Table(t)) => call.run(Some(&t), |p| t.best_near(p)),
            Some(Lookup::Grid(m, r)) => call.run(None, |p| m.best_near(p, r)),
        }
        Ok(())
    }
}

impl Rollout {
    /// Predict `agents` (with their observed histories, when given: see
    /// [`predict_agents_observed`](Self::predict_agents_observed)) into `out`, sized
    /// for them, with scores in [`TrajectoryBatch::scores`] when the options ask for them.
    pub fn predict_batch(
        &mut self,
        map: &CliffMap,
        agents: &[State],
        histories: Option<&[History]>,
        out: &mut TrajectoryBatch,
    ) -> Result<(), PredictError> {
        let scored = self.options.scores;
        out.try_reshape(agents.len(), self.params.k, self.params.steps())?;
        out.try_size_scores(scored)?;
        let (batch, scores) = out.parts_mut();
        self.predict_agents_observed(map, agents, histories, batch, scored.then_some(scores))
    }
}

impl Drop for Rollout {
    /// Leave the buffers to the thread's next rollout (an in-process call's).
    fn drop(&mut self) {
        std::mem::take(&mut self.scratch).spare();
    }
}

impl Rollout {
    /// [`predict_agents`](Self::predict_agents) with the agents shared among rayon's
    /// threads (all cores, unless the caller runs it in a smaller pool): the same bytes
    /// and scores, since each agent draws from a generator of its own
    /// (`seeds::agent_rng`). Small calls (under about a millisecond of work) run on the
    /// calling thread. Each thread's share gets a rollout of its own (buffers for
    /// candidates are allocated per share).
    pub fn predict_agents_parallel(
        &mut self,
        map: &CliffMap,
        agents: &[State],
        out: BatchMut<'_>,
        scores: Option<&mut [f32]>,
    ) -> Result<(), PredictError> {
        self.predict_agents_parallel_observed(map, agents, None, out, scores)
    }

    /// [`predict_agents_parallel`](Self::predict_agents_parallel) with each agent's
    /// observed [`History`], as [`predict_agents_observed`](Self::predict_agents_observed)
    /// takes them: the same bytes and scores as that on one thread.
    pub fn predict_agents_parallel_observed(
        &mut self,
        map: &CliffMap,
        agents: &[State],
        histories: Option<&[History]>,
        out: BatchMut<'_>,
        scores: Option<&mut [f32]>,
    ) -> Result<(), PredictError> {
        use rayon::prelude::*;
        let steps = check_call(agents, &self.params, &out)?;
        let k = self.params.k;
        let work = (agents.len() * k * steps).saturating_mul(self.options.cost_factor());
        let threads = rayon::current_num_threads();
        let wrong_histories = histories.is_some_and(|h| h.len() != agents.len());
        if threads < 2 || agents.len() < 2 || steps == 0 || work < PARALLEL_MIN_POSITIONS {
            return self.predict_agents_observed(map, agents, histories, out, scores);
        }
        if wrong_histories || scores.as_ref().is_some_and(|s| s.len() != out.lens.len()) {
            // (the sequential call names the error)
            return self.predict_agents_observed(map, agents, histories, out, scores);
        }
        // shares of a few agents, several per thread (agents differ in cost)
        let per = agents.len().div_ceil(threads * 8).max(1);
        let first = self.next_agent;
        let BatchMut { positions, lens } = out;
        let mut score_shares: Vec<Option<&mut [f32]>> = match scores {
            Some(s) => s.chunks_mut(per * k).map(Some).collect(),
            None => (0..agents.len().div_ceil(per)).map(|_| None).collect(),
        };
        let this = &*self;
        agents
            .par_chunks(per)
            .zip(positions.par_chunks_mut(per * k * steps))
            .zip(lens.par_chunks_mut(per * k))
            .zip(score_shares.par_iter_mut())
            .enumerate()
            .try_for_each(|(i, (((agents, positions), lens), scores))| {
                let from = i * per;
                let histories = histories.map(|h| &h[from..from + agents.len()]);
                this.ahead(from as u64).predict_agents_observed(
                    map,
                    agents,
                    histories,
                    BatchMut { positions, lens },
                    scores.take(),
                )
            })?;
        self.next_agent = first + agents.len() as u64;
        Ok(())
    }

    /// A rollout of the same call for the agents `agents` after this one's next agent,
    /// with buffers of its own: what a thread or worker predicting a later share of a
    /// call starts from (the shares' results are those of one call). This one does not
    /// move; [`skip`](Self::skip) moves it past the shares given away.
    pub fn ahead(&self, agents: u64) -> Rollout {
        Rollout {
            asked: self.asked,
            params: self.params,
            options: self.options,
            tables: self.tables,
            seed: self.seed,
            next_agent: self.next_agent + agents,
            scratch: Candidates::reuse(),
            simd: self.simd,
            motion: self.motion.clone(),
        }
    }

    /// Move past `agents` agents predicted elsewhere (by [`ahead`](Self::ahead)
    /// copies).
    pub fn skip(&mut self, agents: u64) {
        self.next_agent += agents;
    }

    /// The index in the call of the next agent this rollout predicts.
    pub fn next_agent(&self) -> u64 {
        self.next_agent
    }
}

/// Predicted positions (at their cost factor) below which
/// [`Rollout::predict_agents_parallel`] stays on the calling thread: handing work to
/// another thread costs tens of microseconds, about a thousand positions' work.
const PARALLEL_MIN_POSITIONS: usize = 20_000;

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
