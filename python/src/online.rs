//! `cliff_lhmp.OnlineMap`: a map updated online with batches of trajectories.

use std::sync::{Arc, Mutex};

use cliff::map::build::observations_from_tracks;
use cliff::map::update::UpdateReport;
use cliff::map::{OnlineMap as RustOnlineMap, UpdateParams};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::args::{parse_format, positive, read_tracks_arg};
use crate::errors::map_err;
use crate::map::Map;

/// A map that learns online: each ``update`` decays the counts it holds and folds in
/// a new batch of trajectories (as ``cliff map update``).
///
/// ``OnlineMap(map, *, count_scale=None, decay=0.5, radius=None)`` starts from
/// ``map``, whose observation ratio 1 stands for ``count_scale`` moving samples (the
/// busiest node's count when it was built; ``None``: the busiest node of the first
/// update's batch, so that the map weighs as much as that node). ``decay`` in (0, 1]
/// multiplies the counts at each update; ``radius`` (m) is how far a node collects
/// samples (``None``: the grid step).
///
/// Example:
///     >>> online = cliff_lhmp.OnlineMap(cliff_lhmp.Map.load("hour9.csv"))
///     >>> online.update("hour10.csv", format="atc")["updated"]
///     >>> online.map().save("hour10.cliff")
#[pyclass(module = "cliff_lhmp", frozen)]
pub struct OnlineMap {
    inner: Mutex<OnlineState>,
}

struct OnlineState {
    online: RustOnlineMap,
    scale_set: bool,
}

#[pymethods]
impl OnlineMap {
    #[new]
    #[pyo3(signature = (map, *, count_scale = None, decay = 0.5, radius = None))]
    fn new(
        map: &Bound<'_, Map>,
        count_scale: Option<f64>,
        decay: f64,
        radius: Option<f64>,
    ) -> PyResult<Self> {
        if let Some(r) = radius {
            positive("radius", r)?;
        }
        if let Some(c) = count_scale {
            positive("count_scale", c)?;
        }
        if !(decay > 0.0 && decay <= 1.0) {
            return Err(PyValueError::new_err(format!(
                "decay: {decay} must be in (0, 1]"
            )));
        }
        let params = UpdateParams {
            decay,
            radius,
            ..UpdateParams::default()
        };
        let online = RustOnlineMap::from_map(&map.get().inner, count_scale.unwrap_or(1.0), params)
            .map_err(|e| PyValueError::new_err(format!("OnlineMap: {e}")))?;
        Ok(OnlineMap {
            inner: Mutex::new(OnlineState {
                online,
                scale_set: count_scale.is_some(),
            }),
        })
    }

    /// update(tracks, *, format=None, topic=None) -> dict
    ///
    /// Fold a batch of trajectory files into the map. Returns what changed:
    /// ``observations``, ``updated`` (locations that got samples), ``created`` (new
    /// locations), ``added``, ``merged`` and ``pruned`` (components). ``tracks``,
    /// ``format`` and ``topic`` as in ``build_map``.
    #[pyo3(signature = (tracks, *, format = None, topic = None))]
    fn update<'py>(
        &self,
        py: Python<'py>,
        tracks: &Bound<'py, PyAny>,
        format: Option<&str>,
        topic: Option<&str>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let format = parse_format(format)?;
        let tracks = read_tracks_arg(tracks, format, topic)?;
        let report = py
            .detach(|| {
                let obs = observations_from_tracks(&tracks);
                let mut st = self.inner.lock().unwrap_or_else(|p| p.into_inner());
                if !st.scale_set {
                    let s = st.online.busiest_node(&obs)?.max(1) as f64;
                    st.online.set_count_scale(s)?;
                    st.scale_set = true;
                }
                st.online.update(&obs)
            })
            .map_err(|e| PyValueError::new_err(format!("update: {e}")))?;
        update_report(py, &report)
    }

    /// The moving samples an observation ratio of 1 stands for.
    #[getter]
    fn count_scale(&self) -> f64 {
        self.inner
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .online
            .count_scale()
    }

    /// map() -> Map
    ///
    /// The current map (a snapshot: later updates do not change it).
    fn map(&self, py: Python<'_>) -> PyResult<Map> {
        let m = py
            .detach(|| {
                self.inner
                    .lock()
                    .unwrap_or_else(|p| p.into_inner())
                    .online
                    .to_map()
            })
            .map_err(|e| map_err("map", e))?;
        Ok(Map::single(Arc::new(m)))
    }

    fn __len__(&self) -> usize {
        self.inner
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .online
            .len()
    }
}

/// What an update changed, as a dict.
fn update_report<'py>(py: Python<'py>, r: &UpdateReport) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("observations", r.observations)?;
    d.set_item("updated", r.updated)?;
    d.set_item("created", r.created)?;
    d.set_item("added", r.added)?;
    d.set_item("merged", r.merged)?;
    d.set_item("pruned", r.pruned)?;
    Ok(d)
}
