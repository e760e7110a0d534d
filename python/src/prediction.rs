//! In-process prediction (`cliff_lhmp.predict`) and its result type `Prediction`.

use std::sync::Arc;

use cliff::map::CliffMap;
use cliff::predict::preset::cost_factor;
use cliff::predict::{BatchMut, predict_into_with};
use cliff_client::protocol::{
    DecodeScratch, Limits, MAX_HISTORY, decode_request, scores_in_response,
};
use cliff_client::{Field, Rejection, Status};
use numpy::ndarray::{Array2, Array4};
use numpy::{IntoPyArray, PyArray2, PyArray4, PyArrayMethods};
use pyo3::exceptions::{PyMemoryError, PyValueError};
use pyo3::prelude::*;

use crate::errors::local_rejection;
use crate::histories::{PredictArgs, add_histories};

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
    shape: (usize, usize, usize),
}

impl Prediction {
    /// A prediction from flat buffers (positions sample-major, one length per sample,
    /// one score per sample when `scores` is given).
    pub fn from_flat(
        py: Python<'_>,
        shape: (usize, usize, usize),
        positions: Vec<f32>,
        lens: &[u32],
        scores: Option<Vec<f32>>,
        dt: f64,
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
            shape,
        })
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

/// The in-process predictor: decode the request exactly as `cliffd` does, then predict
/// straight into the output arrays with the GIL released (with the options and scores
/// of [`cliff::predict::predict_with`]; the time is validated, the one map used).
pub fn predict_local(
    py: Python<'_>,
    map: Arc<CliffMap>,
    histories: &Bound<'_, PyAny>,
    args: &PredictArgs<'_>,
) -> PyResult<Prediction> {
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
        // the predictor fills every point (NaN past a sample's end)
        predict_into_with(
            &map,
            scratch.states(),
            &d.params,
            &d.options,
            out,
            scores_flat,
        )
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
    )
}

/// A flat `[x0, y0, x1, y1, ...]` slice as points.
fn as_points(flat: &mut [f32]) -> &mut [[f32; 2]] {
    let (points, rest) = flat.as_chunks_mut::<2>();
    debug_assert!(rest.is_empty());
    points
}
