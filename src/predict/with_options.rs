//! Predicting with [`Options`]: [`predict_with`] and [`predict_into_with`], the entry
//! points that run a [`Rollout`] with the options beyond the paper.

use super::options::Options;
use super::rollout::Rollout;
use super::{BatchMut, Params, PredictError, TrajectoryBatch};
use crate::map::CliffMap;
use crate::motion::State;

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
