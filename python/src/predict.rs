//! In-process prediction (no daemon): `cliff_lhmp.predict` and `Map.predict`.

use std::sync::Arc;

use cliff::map::CliffMap;
use cliff::predict::preset::cost_factor;
use cliff::predict::{BatchMut, Rollout};
use cliff_client::protocol::{
    DecodeScratch, Limits, MAX_HISTORY, decode_request, scores_in_response,
};
use cliff_client::{Field, Rejection, Status};
use pyo3::exceptions::{PyMemoryError, PyValueError};
use pyo3::prelude::*;

use crate::errors::local_rejection;
use crate::histories::add_histories;
use crate::map::Map;
use crate::predict_args::{PredictArgs, predict_fn};
use crate::prediction::Prediction;

predict_fn! {
    /// Predict ``k`` future trajectories of every person, in-process (no daemon).
    ///
    /// Args:
    ///     map: the Map to predict with.
    ///     histories: one 2-D array per person, oldest row first, of rows ``(t, x, y)``
    ///         (at least 2 rows: the velocity comes from the positions) or
    ///         ``(t, x, y, speed, heading)`` (at least 1 row: the tracker's speed in m/s
    ///         and heading in rad). Times in s, positions in m. Any sequence of arrays (or
    ///         nested lists) works, and so does one 3-D array (people, rows, columns).
    ///         Only the last 64 rows are used (older rows have no weight).
    ///     k: samples per person.
    ///     dt: time step (s) between predicted positions.
    ///     horizon: how far ahead (s); ``floor(horizon / dt)`` steps.
    ///     beta: how strongly the heading turns towards a direction sampled from the map.
    ///     radius: sampling radius (m): map locations strictly closer are used.
    ///     seed: seed of the random generator; the same inputs and seed give the same
    ///         numbers (also through ``Client.predict``).
    ///     method: "cliff" (CLiFF-LHMP), "cvm" (constant velocity) or "improved" (a
    ///         preset of the options beyond the paper).
    ///     heading: "circular-mean" (the published code) or "paper" (the paper's formula).
    ///     speed_beta: speed kernel parameter (per (m/s)^2): the speed moves towards speeds
    ///         drawn from the map; 0 keeps the observed speed (the paper).
    ///     coast: seconds (at most ``horizon``) a sample goes on at constant velocity where
    ///         the map has no data; 0 stops it there (the paper).
    ///     scores: also return a score per sample (``Prediction.scores``).
    ///     time: for a time-of-day set (``Map.load`` of a set file), which of its maps:
    ///         None (the slice of the wall clock now, as ``cliffd`` does), seconds on the
    ///         map's clock (unix time, as the tracks had it: the slice of that time) or
    ///         "all-day". A map without slices is used whatever the time (it is checked).
    ///
    /// Returns:
    ///     Prediction with ``positions`` (float32, shape (people, k, steps, 2), NaN after
    ///     each sample's end), ``lengths`` (int64, shape (people, k)) and, with
    ///     ``scores=True``, ``scores`` (float32, shape (people, k)).
    ///
    /// Each person starts at its last row. Thousands of people in one call are fine:
    /// the GIL is released while Rust predicts, on all cores (each person draws from a
    /// generator of its own, so the numbers do not depend on the number of cores).
    ///
    /// Example:
    ///     >>> import numpy as np, cliff_lhmp
    ///     >>> walk = np.array([[0.0, -10.0, 0.5], [0.4, -9.5, 0.5], [0.8, -9.0, 0.5]])
    ///     >>> p = cliff_lhmp.predict(cliff_lhmp.Map.demo(), [walk], k=5, horizon=4.0)
    ///     >>> p.positions.shape, p.lengths.shape
    ///     ((1, 5, 10, 2), (1, 5))
    #[pyfunction]
    pub fn predict(
        py: Python<'_>,
        map: &Bound<'_, Map>,
        histories: &Bound<'_, PyAny>,
        ..args: PredictArgs
    ) -> PyResult<Prediction> {
        predict_local(py, map.get(), histories, &args)
    }
}

predict_fn! {
    #[pymethods]
    impl Map {
        /// The same as ``cliff_lhmp.predict(self, histories, ...)``.
        fn predict(
            &self,
            py: Python<'_>,
            histories: &Bound<'_, PyAny>,
            ..args: PredictArgs
        ) -> PyResult<Prediction> {
            predict_local(py, self, histories, &args)
        }
    }
}

/// The in-process predictor: decode the request exactly as `cliffd` does, then predict
/// straight into the output arrays with the GIL released (with the options and scores
/// of [`cliff::predict::predict_with`], on the map of the time asked for when `map` is
/// a time-of-day set).
pub fn predict_local(
    py: Python<'_>,
    map: &Map,
    histories: &Bound<'_, PyAny>,
    args: &PredictArgs<'_>,
) -> PyResult<Prediction> {
    // a time-of-day set: the slice of the time asked for, as cliffd picks it
    let map: Arc<CliffMap> = match &map.set {
        Some(set) => args.time.map_in(set).clone(),
        None => map.inner.clone(),
    };
    let params = args.params()?;
    let mut request = args.request("local")?;
    add_histories(py, histories, &mut request)?;
    let agents = request.agents();
    let (k, steps) = (params.k, params.steps());
    let limits = Limits {
        max_agents: u32::try_from(agents).map_err(|_| {
            PyValueError::new_err(format!(
                "histories: {agents} people is too many for one call"
            ))
        })?,
        // in-process there is no cost limit: `max_k` times the method's cost factor lets
        // the decoder's cost check (agents x k x steps x factor) pass for this call
        max_k: (params.k as u32).saturating_mul(
            u32::try_from(cost_factor(&params, &args.options())).unwrap_or(u32::MAX),
        ),
        max_steps: u32::try_from(steps).unwrap_or(u32::MAX),
        max_history: MAX_HISTORY,
    };
    // Rust-owned buffers, handed to NumPy without a copy afterwards; a batch too large
    // for memory is a MemoryError, not an abort.
    let too_large = || {
        PyMemoryError::new_err(format!(
            "{agents} people x {k} samples x {steps} steps is too large to allocate"
        ))
    };
    let floats = agents
        .checked_mul(k)
        .and_then(|v| v.checked_mul(steps))
        .and_then(|v| v.checked_mul(2))
        .ok_or_else(too_large)?;
    let mut positions: Vec<f32> = Vec::new();
    positions
        .try_reserve_exact(floats)
        .map_err(|_| too_large())?;
    positions.resize(floats, 0.0);
    let mut lens: Vec<u32> = Vec::new();
    lens.try_reserve_exact(agents * k)
        .map_err(|_| too_large())?;
    lens.resize(agents * k, 0);
    // the scores asked for, or those of a method that scores its samples (improved)
    let scored = scores_in_response(&params, &args.options());
    let mut scores: Vec<f32> = Vec::new();
    if scored {
        scores
            .try_reserve_exact(agents * k)
            .map_err(|_| too_large())?;
        scores.resize(agents * k, 0.0);
    }
    let header = *request.header();
    let rows = request.rows();
    let (pos_flat, lens_flat, scores_flat) = (
        positions.as_mut_slice(),
        lens.as_mut_slice(),
        scores.as_mut_slice(),
    );
    py.detach(move || {
        let mut scratch = DecodeScratch::new(&limits);
        let d = decode_request(&header, rows, &limits, &mut scratch)?;
        let out = BatchMut {
            positions: as_points(pos_flat),
            lens: lens_flat,
        };
        // the predictor fills every point (NaN past a sample's end), on all cores (the
        // same numbers as on one: each person draws from a generator of its own), from
        // each person's observed rows as the daemon predicts them
        let scores = (d.options.scores || !scores_flat.is_empty()).then_some(scores_flat);
        Rollout::new(&d.params)
            .and_then(|r| r.with_options(d.options))
            .and_then(|mut r| {
                r.predict_agents_parallel_observed(
                    &map,
                    scratch.states(),
                    Some(scratch.histories()),
                    out,
                    scores,
                )
            })
            .map_err(|_| Rejection {
                status: Status::Internal,
                agent: None,
                row: None,
                field: Field::None,
                limit: 0,
            })
    })
    .map_err(|r| local_rejection(&r))?;
    Prediction::from_flat(
        py,
        (agents, k, steps),
        positions,
        &lens,
        scored.then_some(scores),
        params.dt,
        0,
    )
}

/// A flat `[x0, y0, x1, y1, ...]` slice as points.
fn as_points(flat: &mut [f32]) -> &mut [[f32; 2]] {
    let (points, rest) = flat.as_chunks_mut::<2>();
    debug_assert!(rest.is_empty());
    points
}
