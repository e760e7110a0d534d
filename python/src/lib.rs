//! Python bindings of cliff: the extension module `cliff_lhmp._native`.
//!
//! A thin layer over the `cliff` library and the `cliff-client` crate: arguments are
//! checked and copied into Rust values, the work runs with the GIL released, and the
//! results come back as NumPy arrays. The Python package `cliff_lhmp`
//! (`python/python/cliff_lhmp`) re-exports everything and holds the exception classes.
//!
//! The files, one part each:
//!
//! - `lib.rs`: this map and the module function (what `_native` exports)
//! - `map.rs`: `Map` (load, save, `slice_at`, its arrays, `score`) and `build_map`
//! - `online.rs`: `OnlineMap`, a map updated with batches of trajectories
//! - `predict.rs`: in-process prediction, `predict` and `Map.predict`
//! - `client.rs`: `Client` (and `Client.predict`), predictions from a running `cliffd`
//! - `observe.rs`: `Client.observe`, observations for a `cliffd` that learns its map
//! - `prediction.rs`: `Prediction`, the result of every `predict`
//! - `occupancy.rs`: `Prediction.occupancy`, `occupancy_window` and `path_meets`
//! - `evaluation.rs`: `evaluate` and its result `Evaluation`
//!
//! What those files share (they import these, and `Map`, `Prediction` or `Client` where
//! they take or return one; no two files import each other):
//!
//! - `predict_args.rs`: the keyword arguments of every `predict` (`predict_fn!`,
//!   `PredictArgs`)
//! - `histories.rs`: the `histories` argument read into request rows
//! - `args.rs`: the `tracks` and `format` arguments, positive numbers
//! - `errors.rs`: the library's errors as Python exceptions

use pyo3::prelude::*;

mod args;
mod client;
mod errors;
mod evaluation;
mod histories;
mod map;
mod observe;
mod occupancy;
mod online;
mod predict;
mod predict_args;
mod prediction;

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
    use super::map::{Map, build_map};
    #[pymodule_export]
    use super::online::OnlineMap;
    #[pymodule_export]
    use super::predict::predict;
    #[pymodule_export]
    use super::prediction::Prediction;
}
