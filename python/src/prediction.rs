//! `cliff_lhmp.Prediction`: the sampled trajectories a `predict` returns (in-process
//! or from `cliffd`).

use numpy::ndarray::{Array2, Array4};
use numpy::{IntoPyArray, PyArray2, PyArray4, PyArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// Sampled future trajectories of a batch of people.
///
/// Attributes:
///     positions: float32 array of shape (agents, k, steps, 2): sample s of person a is
///         positions[a, s, :lengths[a, s]]; the points after a sample's end are NaN.
///     lengths: int64 array of shape (agents, k): valid steps of each sample (a
///         CLiFF-LHMP sample ends where the map has no location near).
///     dt: time between two predicted positions (s); step j (0-based) is at
///         t_last + (j + 1) * dt, t_last the time of the person's last history row.
///     scores: float32 array of shape (agents, k) when the call asked for
///         ``scores=True`` or used ``method="improved"`` (which scores its samples),
///         else None: the log-likelihood of each sample under the map (higher is more
///         likely; compare the samples of one call).
///     map_version: the version of the map that answered: a learning daemon's learned
///         version (``cliffd --learn``), 0 for the map as loaded and for predictions in
///         this process.
#[pyclass(module = "cliff_lhmp", frozen)]
pub struct Prediction {
    /// float32 array (agents, k, steps, 2): the sampled positions, NaN after each
    /// sample's end.
    #[pyo3(get)]
    positions: Py<PyArray4<f32>>,
    /// int64 array (agents, k): the valid steps of each sample.
    #[pyo3(get)]
    lengths: Py<PyArray2<i64>>,
    /// Time between two predicted positions (s).
    #[pyo3(get)]
    dt: f64,
    /// float32 array (agents, k): the score of each sample, or None when the call did
    /// not ask for scores.
    #[pyo3(get)]
    scores: Option<Py<PyArray2<f32>>>,
    /// The version of the map that answered (0: the map as loaded).
    #[pyo3(get)]
    map_version: u32,
    shape: (usize, usize, usize),
}

impl Prediction {
    /// A prediction from flat buffers (positions sample-major, one length per sample,
    /// one score per sample when `scores` is given), answered by map version
    /// `map_version`.
    #[allow(clippy::too_many_arguments)]
    pub fn from_flat(
        py: Python<'_>,
        shape: (usize, usize, usize),
        positions: Vec<f32>,
        lens: &[u32],
        scores: Option<Vec<f32>>,
        dt: f64,
        map_version: u32,
    ) -> PyResult<Self> {
        let (a, k, s) = shape;
        let internal = |e: numpy::ndarray::ShapeError| {
            PyValueError::new_err(format!("internal shape error: {e}"))
        };
        let p = Array4::from_shape_vec((a, k, s, 2), positions).map_err(internal)?;
        let l = Array2::from_shape_vec((a, k), lens.iter().map(|&v| v as i64).collect())
            .map_err(internal)?;
        let scores = match scores {
            Some(v) => Some(
                Array2::from_shape_vec((a, k), v)
                    .map_err(internal)?
                    .into_pyarray(py)
                    .unbind(),
            ),
            None => None,
        };
        Ok(Prediction {
            positions: p.into_pyarray(py).unbind(),
            lengths: l.into_pyarray(py).unbind(),
            dt,
            scores,
            map_version,
            shape,
        })
    }
}

impl Prediction {
    /// The positions array.
    pub(crate) fn positions_array<'py>(&self, py: Python<'py>) -> &Bound<'py, PyArray4<f32>> {
        self.positions.bind(py)
    }

    /// The lengths array.
    pub(crate) fn lengths_array<'py>(&self, py: Python<'py>) -> &Bound<'py, PyArray2<i64>> {
        self.lengths.bind(py)
    }

    /// `(agents, k, steps)`.
    pub(crate) fn shape3(&self) -> (usize, usize, usize) {
        self.shape
    }

    /// The step (s).
    pub(crate) fn dt_value(&self) -> f64 {
        self.dt
    }
}

#[pymethods]
impl Prediction {
    /// Number of people (the first dimension of positions).
    #[getter]
    fn agents(&self) -> usize {
        self.shape.0
    }

    /// Samples per person.
    #[getter]
    fn k(&self) -> usize {
        self.shape.1
    }

    /// Steps per sample (the longest a sample can be).
    #[getter]
    fn steps(&self) -> usize {
        self.shape.2
    }

    /// sample(agent, s) -> ndarray
    ///
    /// The valid positions of sample ``s`` of person ``agent``: a float32 view of shape
    /// (lengths[agent, s], 2) into ``positions``.
    fn sample<'py>(&self, py: Python<'py>, agent: usize, s: usize) -> PyResult<Bound<'py, PyAny>> {
        let (a, k, _) = self.shape;
        if agent >= a {
            return Err(pyo3::exceptions::PyIndexError::new_err(format!(
                "agent: {agent} is out of range for {a} people"
            )));
        }
        if s >= k {
            return Err(pyo3::exceptions::PyIndexError::new_err(format!(
                "s: {s} is out of range for k = {k} samples"
            )));
        }
        let len = *self
            .lengths
            .bind(py)
            .readonly()
            .get([agent, s])
            .unwrap_or(&0);
        let pos = self.positions.bind(py).as_any();
        let idx = (agent, s, pyo3::types::PySlice::new(py, 0, len as isize, 1));
        pos.get_item(idx)
    }

    /// best_sample(agent) -> Optional[int]
    ///
    /// The sample of person ``agent`` with the highest score (the first of equals), or
    /// None when the call did not ask for scores.
    fn best_sample(&self, py: Python<'_>, agent: usize) -> PyResult<Option<usize>> {
        let (a, _, _) = self.shape;
        if agent >= a {
            return Err(pyo3::exceptions::PyIndexError::new_err(format!(
                "agent: {agent} is out of range for {a} people"
            )));
        }
        let Some(scores) = &self.scores else {
            return Ok(None);
        };
        let scores = scores.bind(py).readonly();
        let row = scores.as_array();
        let row = row.row(agent);
        let mut best: Option<usize> = None;
        for (s, v) in row.iter().enumerate() {
            if best.is_none_or(|b| *v > row[b]) {
                best = Some(s);
            }
        }
        Ok(best)
    }

    fn __len__(&self) -> usize {
        self.shape.0
    }

    fn __repr__(&self) -> String {
        let (a, k, s) = self.shape;
        let scores = if self.scores.is_some() {
            ", scores"
        } else {
            ""
        };
        format!(
            "Prediction(agents={a}, k={k}, steps={s}, dt={}{scores})",
            self.dt
        )
    }
}
