//! Python bindings of cliff: the extension module `cliff_lhmp._native`.
//!
//! A thin layer over the `cliff` library and the `cliff-client` crate: arguments are
//! checked and copied into Rust values, the work runs with the GIL released, and the
//! results come back as NumPy arrays. The Python package `cliff_lhmp`
//! (`python/python/cliff_lhmp`) re-exports everything and holds the exception classes.

use pyo3::prelude::*;

mod client;
mod errors;
mod evaluation;
mod histories;
mod map;
mod predict_signature;
mod prediction;

use map::Map;
use predict_signature::predict_fn;

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
    /// Each person starts at its last row. Thousands of people in one call are fine;
    /// the GIL is released while Rust predicts.
    ///
    /// Example:
    ///     >>> import numpy as np, cliff_lhmp
    ///     >>> walk = np.array([[0.0, -10.0, 0.5], [0.4, -9.5, 0.5], [0.8, -9.0, 0.5]])
    ///     >>> p = cliff_lhmp.predict(cliff_lhmp.Map.demo(), [walk], k=5, horizon=4.0)
    ///     >>> p.positions.shape, p.lengths.shape
    ///     ((1, 5, 10, 2), (1, 5))
    #[pyfunction]
    fn predict(
        py: Python<'_>,
        map: &Bound<'_, Map>,
        histories: &Bound<'_, PyAny>,
        ..args: PredictArgs
    ) -> PyResult<prediction::Prediction> {
        prediction::predict_local(py, map.get(), histories, &args)
    }
}

/// The extension module; `cliff_lhmp` re-exports its contents.
#[pymodule(name = "_native")]
mod native {
    #[pymodule_export]
    use super::client::Client;
    /// Whether this build has the zenoh client (``Client.connect_zenoh``): the cargo
    /// feature ``zenoh`` (``maturin build --release --features zenoh``).
    #[pymodule_export]
    const HAS_ZENOH: bool = super::client::HAS_ZENOH;
    #[pymodule_export]
    use super::evaluation::{Evaluation, evaluate};
    #[pymodule_export]
    use super::map::{Map, OnlineMap, build_map};
    #[pymodule_export]
    use super::predict;
    #[pymodule_export]
    use super::prediction::Prediction;
}
