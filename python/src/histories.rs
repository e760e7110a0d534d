//! Reading the `histories` argument (a sequence of 2-D arrays) into wire rows.

use cliff_client::protocol::MAX_HISTORY;
use cliff_client::{Observation, Request};
use numpy::{PyReadonlyArray2, PyUntypedArray, PyUntypedArrayMethods};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyAnyMethods, PyList, PySequence, PyString, PyTuple};

/// Rows of one history that count: the most recent [`MAX_HISTORY`]. Older rows get a
/// velocity weight of exactly 0 (`exp(-t^2 / 4.5)` underflows for `t > 57` rows at
/// sigma 1.5), so dropping them changes no bit of the result.
pub const USED_ROWS: usize = MAX_HISTORY as usize;

const COLUMNS: [&str; 5] = ["t", "x", "y", "speed", "heading"];

/// One history as a float64 array: ndarrays of float64 as they are, anything else through
/// `numpy.asarray(h, dtype=float64)`.
pub(crate) fn as_f64_array<'py>(
    py: Python<'py>,
    h: &Bound<'py, PyAny>,
    i: usize,
) -> PyResult<PyReadonlyArray2<'py, f64>> {
    if let Ok(a) = h.extract::<PyReadonlyArray2<'py, f64>>() {
        return Ok(a);
    }
    let np = py.import("numpy")?;
    let kwargs = pyo3::types::PyDict::new(py);
    kwargs.set_item("dtype", "float64")?;
    let arr = np
        .call_method("asarray", (h,), Some(&kwargs))
        .map_err(|e| {
            PyTypeError::new_err(format!(
                "histories[{i}]: cannot be read as an array of numbers ({e})"
            ))
        })?;
    let ndim: usize = arr.getattr("ndim")?.extract()?;
    if ndim != 2 {
        let shape: Vec<usize> = arr.getattr("shape")?.extract()?;
        return Err(PyValueError::new_err(format!(
            "histories[{i}]: expected a 2-D array of rows (t, x, y) or (t, x, y, speed, heading), got {ndim} dimension(s), shape {shape:?}"
        )));
    }
    arr.extract::<PyReadonlyArray2<'py, f64>>().map_err(|_| {
        PyTypeError::new_err(format!(
            "histories[{i}]: cannot be converted to a float64 array"
        ))
    })
}

/// Append every history of `histories` to `request` as an agent (rows oldest first).
///
/// Checks the shape (rows x 3 or rows x 5) and that every value is finite, naming the
/// history, row and column; the daemon's rules (increasing times, enough rows) are
/// checked afterwards by the same decoder the daemon uses.
pub fn add_histories(
    py: Python<'_>,
    histories: &Bound<'_, PyAny>,
    request: &mut Request,
) -> PyResult<()> {
    if histories.is_instance_of::<PyString>() {
        return Err(PyTypeError::new_err(
            "histories: expected a sequence of 2-D arrays, got a str",
        ));
    }
    // A list or tuple of 2-D arrays, or a single 3-D array (agents, rows, columns):
    // anything with a length and integer indexing (NumPy arrays are no `Sequence`).
    if let Ok(a) = histories.cast::<PyUntypedArray>() {
        if a.ndim() != 3 {
            return Err(PyValueError::new_err(format!(
                "histories: a single array must be 3-D (people, rows, columns), got {} dimension(s); pass a list of 2-D arrays",
                a.ndim()
            )));
        }
    } else if !(histories.is_instance_of::<PyList>()
        || histories.is_instance_of::<PyTuple>()
        || histories.cast::<PySequence>().is_ok())
    {
        return Err(PyTypeError::new_err(format!(
            "histories: expected a sequence of 2-D arrays (one per person), got {}",
            histories
                .get_type()
                .name()
                .map(|n| n.to_string())
                .unwrap_or_else(|_| "?".into())
        )));
    }
    let n = histories.len()?;
    if n == 0 {
        return Err(PyValueError::new_err(
            "histories: is empty; give at least one person's history",
        ));
    }
    let mut rows: Vec<Observation> = Vec::with_capacity(USED_ROWS.min(16));
    for i in 0..n {
        let item = histories.get_item(i)?;
        let arr = as_f64_array(py, &item, i)?;
        let shape = arr.shape();
        let (len, cols) = (shape[0], shape[1]);
        if cols != 3 && cols != 5 {
            return Err(PyValueError::new_err(format!(
                "histories[{i}]: expected rows of 3 columns (t, x, y) or 5 (t, x, y, speed, heading), got shape ({len}, {cols})"
            )));
        }
        if len == 0 {
            return Err(PyValueError::new_err(format!(
                "histories[{i}]: has no rows"
            )));
        }
        let v = arr.as_array();
        for (r, row) in v.outer_iter().enumerate() {
            if let Some(c) = row.iter().position(|x| !x.is_finite()) {
                return Err(PyValueError::new_err(format!(
                    "histories[{i}] row {r} {} (column {c}): {} is not a finite number",
                    COLUMNS[c], row[c]
                )));
            }
        }
        rows.clear();
        let first = len.saturating_sub(USED_ROWS);
        for row in v.outer_iter().skip(first) {
            rows.push(if cols == 5 {
                Observation::with_velocity(row[0], row[1], row[2], row[3], row[4])
            } else {
                Observation::position(row[0], row[1], row[2])
            });
        }
        request.add_agent(rows.iter().copied());
    }
    Ok(())
}
