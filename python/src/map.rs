//! `cliff_lhmp.Map` (loading, saving, its arrays, scoring) and `build_map`.
//!
//! `Map.predict` is with the other in-process prediction in `predict.rs`.

use std::path::PathBuf;
use std::sync::Arc;

use cliff::map::build::observations_from_tracks;
use cliff::map::{BuildParams, CliffMap, MapSet, ScoreParams};
use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::args::{parse_format, positive, read_tracks_arg};
use crate::errors::map_err;

/// A CLiFF-map: for each location, a mixture of the velocities people moved with there.
///
/// Make one with ``Map.load(path)`` (the published CSV format or a ``.cliff``
/// snapshot), ``Map.demo()`` (the built-in synthetic hall) or ``build_map(...)``.
/// A map is immutable and safe to share between threads.
///
/// A time-of-day set (``cliff map build --slice``) loads as its all-day map;
/// ``slice_at(time)`` gives the map of the slice a timestamp falls in.
///
/// Example:
///     >>> import cliff_lhmp
///     >>> m = cliff_lhmp.Map.demo()
///     >>> m.info()["locations"]
///     315
#[pyclass(module = "cliff_lhmp", frozen)]
pub struct Map {
    /// The map (of a time-of-day set: its all-day map).
    pub inner: Arc<CliffMap>,
    /// The time-of-day set the map is the all-day map of (loaded from a set file).
    pub set: Option<Arc<MapSet>>,
}

impl Map {
    /// A map without slices.
    pub fn single(map: Arc<CliffMap>) -> Self {
        Map {
            inner: map,
            set: None,
        }
    }
}

#[pymethods]
impl Map {
    /// Map.load(path) -> Map
    ///
    /// Load a map file: ``.csv`` (the published format: no header, one row per mixture
    /// component) or ``.cliff`` (our checksummed snapshot). A time-of-day set loads as its
    /// all-day map, with its slices for ``slice_at``. Raises FileNotFoundError for a
    /// missing file and ValueError naming the file, line and column of a bad value.
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Map> {
        let set = py
            .detach(|| MapSet::load(&path))
            .map_err(|e| map_err("path", e))?;
        Ok(Map {
            inner: set.all_day().clone(),
            set: set.is_sliced().then(|| Arc::new(set)),
        })
    }

    /// slice_at(time, *, clock_offset=None) -> Map
    ///
    /// The map for a timestamp ``time`` (s, the clock of the data; ATC: unix time): the
    /// map of the time-of-day slice it falls in after adding the clock offset (the one
    /// stored in the set, or ``clock_offset`` seconds), or the all-day map where that
    /// slice has none. A map without slices returns itself.
    ///
    /// Example:
    ///     >>> m = cliff_lhmp.Map.load("atc-set.cliff")
    ///     >>> m.slice_at(1351054800.0)  # 2012-10-24 14:00 in Japan (stored offset +9 h)
    #[pyo3(signature = (time, *, clock_offset = None))]
    fn slice_at(slf: &Bound<'_, Self>, time: f64, clock_offset: Option<f64>) -> PyResult<Py<Map>> {
        let this = slf.get();
        let Some(set) = &this.set else {
            return Ok(slf.clone().unbind());
        };
        if !time.is_finite() {
            return Err(PyValueError::new_err(format!(
                "time: {time} is not a finite number of seconds"
            )));
        }
        let map = match clock_offset {
            None => set.at(time).clone(),
            Some(o) => {
                let mut other = MapSet::clone(set);
                other
                    .set_clock_offset(o)
                    .map_err(|e| PyValueError::new_err(format!("clock_offset: {e}")))?;
                other.at(time).clone()
            }
        };
        Py::new(slf.py(), Map::single(map))
    }

    /// Map.demo() -> Map
    ///
    /// The built-in synthetic scene: a 30 m x 20 m hall with two crossing pedestrian
    /// flows (the map ``cliffd`` serves as ``demo`` when started without ``--map``).
    #[staticmethod]
    fn demo() -> Map {
        Map::single(Arc::new(CliffMap::demo()))
    }

    /// save(path) -> None
    ///
    /// Write the map: ``.csv`` in the published format, ``.cliff`` as a snapshot
    /// (chosen by the file's extension). The all-day map of a time-of-day set is
    /// written with its slices to ``.cliff``, alone to ``.csv``.
    fn save(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        let map = self.inner.clone();
        let set = self.set.clone();
        py.detach(move || match set {
            Some(set)
                if cliff::map::MapFormat::from_path(&path)? == cliff::map::MapFormat::Snapshot =>
            {
                set.save(&path)
            }
            _ => map.save(&path),
        })
        .map_err(|e| map_err("path", e))
    }

    /// info() -> dict
    ///
    /// Summary figures (as ``cliff map info`` prints them): ``locations``,
    /// ``components``, ``components_per_location`` (min, max), ``grid_step`` (m),
    /// ``extent`` ((x_min, y_min), (x_max, y_max)), ``observation_ratio`` (min, max),
    /// ``clamped_covariances`` and ``renormalised_locations`` (what was fixed at load);
    /// for a time-of-day set, ``slices`` (0 without), ``slice_length`` (s) and
    /// ``clock_offset`` (s).
    fn info<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let i = self.inner.info();
        let d = PyDict::new(py);
        d.set_item("locations", i.locations)?;
        d.set_item("components", i.components)?;
        d.set_item("components_per_location", i.components_per_location)?;
        d.set_item("grid_step", i.grid_step)?;
        d.set_item(
            "extent",
            ((i.extent.0.x, i.extent.0.y), (i.extent.1.x, i.extent.1.y)),
        )?;
        d.set_item("observation_ratio", i.observation_ratio)?;
        d.set_item("clamped_covariances", i.report.clamped_covariances)?;
        d.set_item("renormalised_locations", i.report.renormalised_locations)?;
        let (slices, length, offset) = match &self.set {
            Some(s) => (s.slices().len(), s.slice_length(), s.clock_offset()),
            None => (0, 86_400.0, 0.0),
        };
        d.set_item("slices", slices)?;
        d.set_item("slice_length", length)?;
        d.set_item("clock_offset", offset)?;
        Ok(d)
    }

    /// float64 array (locations, 2): x, y of every location (m).
    #[getter]
    fn locations<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let locs = self.inner.locations();
        Array2::from_shape_fn((locs.len(), 2), |(i, c)| {
            if c == 0 {
                locs[i].position.x
            } else {
                locs[i].position.y
            }
        })
        .into_pyarray(py)
    }

    /// float64 array (locations,): samples seen at each location / the largest count.
    #[getter]
    fn observation_ratio<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        Array1::from_iter(self.inner.locations().iter().map(|l| l.observation_ratio))
            .into_pyarray(py)
    }

    /// float64 array (locations,): moving samples / all samples at each location.
    #[getter]
    fn motion_ratio<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        Array1::from_iter(self.inner.locations().iter().map(|l| l.motion_ratio)).into_pyarray(py)
    }

    /// float64 array (components, 9), one row per mixture component, columns
    /// x, y (of its location, m), theta (mean direction, rad in [0, 2pi)), rho (mean
    /// speed, m/s), cov_tt, cov_tr, cov_rt, cov_rr (covariance of (theta, rho)) and
    /// weight. For a quiver plot: ``plt.quiver(c[:, 0], c[:, 1], c[:, 3] *
    /// np.cos(c[:, 2]), c[:, 3] * np.sin(c[:, 2]))``.
    #[getter]
    fn components<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let mut flat = Vec::new();
        for l in self.inner.locations() {
            for c in &l.components {
                flat.extend_from_slice(&[
                    l.position.x,
                    l.position.y,
                    c.theta,
                    c.rho,
                    c.cov[0],
                    c.cov[1],
                    c.cov[2],
                    c.cov[3],
                    c.weight,
                ]);
            }
        }
        let n = flat.len() / 9;
        Ok(Array2::from_shape_vec((n, 9), flat)
            .map_err(|e| PyValueError::new_err(e.to_string()))?
            .into_pyarray(py))
    }

    /// int64 array (components,): the location (row of ``locations``) of each component.
    #[getter]
    fn component_location<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        Array1::from_iter(
            self.inner
                .locations()
                .iter()
                .enumerate()
                .flat_map(|(i, l)| std::iter::repeat_n(i as i64, l.components.len())),
        )
        .into_pyarray(py)
    }

    /// score(tracks, *, format=None, radius=None, topic=None) -> dict
    ///
    /// How well the map explains held-out trajectories (as ``cliff map score``): every
    /// moving row is scored at the nearest location strictly within ``radius`` metres
    /// (``None``: the map's grid step). Keys:
    /// ``mean_log_likelihood``, ``median_log_likelihood``, ``observations`` (moving rows),
    /// ``standing``, ``unmatched`` (no location near), ``share_below`` (share of matched
    /// rows scoring below ``bad_below``), ``bad_below``, ``radius``. ``tracks``,
    /// ``format`` and ``topic`` as in ``build_map``.
    #[pyo3(signature = (tracks, *, format = None, radius = None, topic = None))]
    fn score<'py>(
        &self,
        py: Python<'py>,
        tracks: &Bound<'py, PyAny>,
        format: Option<&str>,
        radius: Option<f64>,
        topic: Option<&str>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let format = parse_format(format)?;
        let radius = positive("radius", radius.unwrap_or(self.inner.grid().step()))?;
        let tracks = read_tracks_arg(tracks, format, topic)?;
        let map = self.inner.clone();
        let r = py
            .detach(move || {
                let obs = observations_from_tracks(&tracks);
                cliff::map::score(
                    &map,
                    &obs,
                    &ScoreParams {
                        radius,
                        ..ScoreParams::default()
                    },
                )
            })
            .map_err(|e| PyValueError::new_err(format!("tracks: {e}")))?;
        let d = PyDict::new(py);
        d.set_item("mean_log_likelihood", r.mean_log_likelihood)?;
        d.set_item("median_log_likelihood", r.median_log_likelihood)?;
        d.set_item("observations", r.observations)?;
        d.set_item("standing", r.standing)?;
        d.set_item("unmatched", r.unmatched)?;
        d.set_item("share_below", r.share_below)?;
        d.set_item("bad_below", r.bad_below)?;
        d.set_item("radius", r.radius)?;
        Ok(d)
    }

    fn __repr__(&self) -> String {
        let i = self.inner.info();
        format!(
            "Map(locations={}, components={}, grid_step={})",
            i.locations, i.components, i.grid_step
        )
    }
}

/// build_map(tracks, *, format=None, grid=1.0, radius=1.0, topic=None) -> Map
///
/// Build a CLiFF-map from recorded trajectories (as ``cliff map build``): mean shift
/// and EM on the velocities seen within ``radius`` metres of every node of a grid with
/// step ``grid`` metres. ``tracks`` is a trajectory file or a list of them, each in
/// the format recognised from the file itself unless ``format`` names one ("thor" or
/// "atc": headerless rows of time, person id, x, y, speed, motion angle, told apart by
/// the scale of the times; "magni": a THÖR-MAGNI header row; "csv": another header
/// row), or rosbag2 recordings (MCAP files, read as such whatever the format): the
/// messages of ``topic`` (people_msgs/msg/People or
/// autoware_perception_msgs/msg/TrackedObjects), by default of the recording's one
/// topic of such a type. A file whose format is not recognised (a headerless file whose
/// times could be either thor or atc, say) is a ValueError naming the formats to choose
/// from. Runs on all cores, with the GIL released.
#[pyfunction]
#[pyo3(signature = (tracks, *, format = None, grid = 1.0, radius = 1.0, topic = None))]
pub fn build_map(
    py: Python<'_>,
    tracks: &Bound<'_, PyAny>,
    format: Option<&str>,
    grid: f64,
    radius: f64,
    topic: Option<&str>,
) -> PyResult<Map> {
    let format = parse_format(format)?;
    let grid = positive("grid", grid)?;
    let radius = positive("radius", radius)?;
    let tracks = read_tracks_arg(tracks, format, topic)?;
    let built = py
        .detach(move || {
            let obs = observations_from_tracks(&tracks);
            cliff::map::build_map(
                &obs,
                &BuildParams {
                    grid,
                    radius,
                    ..BuildParams::default()
                },
            )
        })
        .map_err(|e| PyValueError::new_err(format!("build_map: {e}")))?;
    Ok(Map::single(Arc::new(built.map)))
}
