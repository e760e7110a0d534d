//! Predicting with [`Options`]: [`predict_with`] and [`predict_into_with`], the entry
//! points that run a [`Rollout`] with the options beyond the paper, and
//! [`predict_batch`] and [`predict_batch_into`], the same on all cores.

use super::options::Options;
use super::rollout::Rollout;
use super::{BatchMut, Params, PredictError, TrajectoryBatch};
use crate::map::CliffMap;
use crate::motion::{History, State};

/// [`predict`](super::predict) with [`Options`]: scores, when asked (by the options or a
/// preset method), go to [`TrajectoryBatch::scores`].
pub fn predict_with(
    map: &CliffMap,
    agents: &[State],
    params: &Params,
    options: &Options,
    out: &mut TrajectoryBatch,
) -> Result<(), PredictError> {
    let mut rollout = Rollout::new(params)?.with_options(*options)?;
    let scored = rollout.options().scores;
    out.try_reshape(agents.len(), params.k, params.steps())?;
    out.try_size_scores(scored)?;
    let (batch, scores) = out.parts_mut();
    rollout.predict_agents(map, agents, batch, scored.then_some(scores))
}

/// [`predict_with`] from each agent's observed [`History`] as well as its state (one
/// history per agent), which [`Method::Motion`](super::Method::Motion) and
/// [`Method::CvmLast`](super::Method::CvmLast) read (the other methods predict as
/// [`predict_with`] does).
///
/// ```
/// use cliff::map::CliffMap;
/// use cliff::motion::{History, State};
/// use cliff::predict::{Method, Options, Params, TrajectoryBatch, predict_with_histories};
/// use glam::DVec2;
///
/// // walking east at 1 m/s, then the last step turned north
/// let times = [0.0, 0.4, 0.8, 1.2];
/// let points = [DVec2::new(0.0, 0.0), DVec2::new(0.4, 0.0), DVec2::new(0.8, 0.0), DVec2::new(0.8, 0.4)];
/// let history = History::from_points(&times, &points).unwrap();
/// let state = State { position: points[3], speed: 1.0, heading: 0.0, time: 1.2 };
/// let params = Params { method: Method::CvmLast, k: 1, horizon: 2.0, ..Params::default() };
/// let mut batch = TrajectoryBatch::new();
/// predict_with_histories(&CliffMap::demo(), &[state], &[history], &params, &Options::default(), &mut batch).unwrap();
/// let end = batch.sample(0, 0).last().unwrap();
/// assert!((end[0] - 0.8).abs() < 1e-5 && (end[1] - 2.4).abs() < 1e-5); // on north at 1 m/s
/// ```
pub fn predict_with_histories(
    map: &CliffMap,
    agents: &[State],
    histories: &[History],
    params: &Params,
    options: &Options,
    out: &mut TrajectoryBatch,
) -> Result<(), PredictError> {
    Rollout::new(params)?
        .with_options(*options)?
        .predict_batch(map, agents, Some(histories), out)
}

/// [`predict_with`] on all cores (rayon): the agents are shared among the threads, each
/// drawing from a generator of its own, so the result is the same bytes and scores as
/// [`predict_with`]'s on one thread. For calls over many people.
///
/// ```
/// use cliff::map::CliffMap;
/// use cliff::motion::State;
/// use cliff::predict::{Params, Options, TrajectoryBatch, predict_batch, predict_with};
/// use glam::DVec2;
///
/// let map = CliffMap::demo();
/// let people: Vec<State> = (0..200)
///     .map(|i| State { position: DVec2::new(-10.0, 0.01 * i as f64), speed: 1.2, heading: 0.0, time: 0.0 })
///     .collect();
/// let params = Params { seed: 5, ..Params::default() };
/// let (mut one, mut all) = (TrajectoryBatch::new(), TrajectoryBatch::new());
/// predict_with(&map, &people, &params, &Options::default(), &mut one).unwrap();
/// predict_batch(&map, &people, &params, &Options::default(), &mut all).unwrap();
/// let bits = |b: &TrajectoryBatch| b.positions().iter().flatten().map(|v| v.to_bits()).collect::<Vec<_>>();
/// assert_eq!((bits(&one), one.lens()), (bits(&all), all.lens()));
/// ```
pub fn predict_batch(
    map: &CliffMap,
    agents: &[State],
    params: &Params,
    options: &Options,
    out: &mut TrajectoryBatch,
) -> Result<(), PredictError> {
    let mut rollout = Rollout::new(params)?.with_options(*options)?;
    let scored = rollout.options().scores;
    out.try_reshape(agents.len(), params.k, params.steps())?;
    out.try_size_scores(scored)?;
    let (batch, scores) = out.parts_mut();
    rollout.predict_agents_parallel(map, agents, batch, scored.then_some(scores))
}

/// [`predict_into_with`] on all cores, as [`predict_batch`] is [`predict_with`] on all
/// cores: the same bytes and scores.
pub fn predict_batch_into(
    map: &CliffMap,
    agents: &[State],
    params: &Params,
    options: &Options,
    out: BatchMut<'_>,
    scores: &mut [f32],
) -> Result<(), PredictError> {
    let buffer = (options.scores || !scores.is_empty()).then_some(scores);
    Rollout::new(params)?
        .with_options(*options)?
        .predict_agents_parallel(map, agents, out, buffer)
}

/// [`predict_into`](super::predict_into) with [`Options`]; `scores` holds one score per
/// sample (`agents x k`), or is empty for none. Scores are computed when the options
/// ask for them ([`Options::scores`], or a preset method's) and `scores` is not empty;
/// a non-empty `scores` without scores asked for is filled with NaN. [`Options::scores`]
/// with an empty `scores` is an error.
pub fn predict_into_with(
    map: &CliffMap,
    agents: &[State],
    params: &Params,
    options: &Options,
    out: BatchMut<'_>,
    scores: &mut [f32],
) -> Result<(), PredictError> {
    let buffer = (options.scores || !scores.is_empty()).then_some(scores);
    Rollout::new(params)?
        .with_options(*options)?
        .predict_agents(map, agents, out, buffer)
}
