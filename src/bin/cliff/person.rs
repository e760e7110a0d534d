//! One prepared person's prediction, made the same way by `cliff predict`,
//! `cliff plot predict` and `cliff demo`.

use anyhow::{Context, Result};
use cliff::eval::person_seed;
use cliff::eval::protocol::Case;
use cliff::map::CliffMap;
use cliff::predict::{Method, Params, TrajectoryBatch, predict_with_histories};

use crate::args::PredictionArgs;

/// Predict one prepared person (from its observed path, which `motion` and `cvm-last`
/// read): its own horizon, and the seed mixed with its id as in
/// `cliff eval` (so `cliff predict`, `cliff plot predict` and the demo draw the same
/// samples for the same seed).
pub fn predict_case(
    map: &CliffMap,
    case: &Case,
    prediction: &PredictionArgs,
    method: Method,
    seed: u64,
    batch: &mut TrajectoryBatch,
) -> Result<Params> {
    let params = Params {
        horizon: case.steps as f64 * prediction.dt,
        ..prediction.params(method, person_seed(seed, case.seed_key()))
    };
    predict_with_histories(
        map,
        std::slice::from_ref(&case.start),
        &[case.history()],
        &params,
        &prediction.options(true),
        batch,
    )
    .with_context(|| format!("predicting person {}", case.id))?;
    Ok(params)
}
