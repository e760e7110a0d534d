//! Reading the `histories` argument (a sequence of 2-D arrays) into wire rows.

use cliff::predict::{HeadingRule, Method, Options, Params};
use cliff_client::protocol::MAX_HISTORY;
use cliff_client::{MapTime, Observation, Request};
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
fn as_f64_array<'py>(
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

/// The keyword arguments shared by every prediction call.
pub struct PredictArgs<'a> {
    pub k: i64,
    pub dt: f64,
    pub horizon: f64,
    pub beta: f64,
    pub radius: f64,
    /// Any Python int; checked to fit in 64 bits unsigned.
    pub seed: i128,
    pub method: &'a str,
    pub heading: &'a str,
    /// Speed kernel parameter (0: the paper's constant speed).
    pub speed_beta: f64,
    /// Seconds of coasting where the map has no data (0: stop there).
    pub coast: f64,
    /// A score per sample in the result.
    pub scores: bool,
    /// Which map of the time of day.
    pub time: MapTime,
}

/// The `time` argument: `None` (or "now") for the daemon's wall clock, a number of
/// seconds on the map's clock, or "all-day"; the error names the argument.
pub fn time_arg(time: Option<&Bound<'_, PyAny>>) -> PyResult<MapTime> {
    let Some(t) = time.filter(|t| !t.is_none()) else {
        return Ok(MapTime::Now);
    };
    if let Ok(s) = t.extract::<String>() {
        return match s.trim().to_ascii_lowercase().as_str() {
            "all-day" | "all_day" | "allday" => Ok(MapTime::AllDay),
            "now" => Ok(MapTime::Now),
            _ => Err(PyValueError::new_err(format!(
                "time: unknown time {s:?} (expected None or \"now\", seconds, or \"all-day\")"
            ))),
        };
    }
    if t.is_instance_of::<pyo3::types::PyBool>() {
        return Err(PyTypeError::new_err(
            "time: expected None, seconds or \"all-day\", got a bool",
        ));
    }
    let seconds: f64 = t.extract().map_err(|_| {
        PyTypeError::new_err(format!(
            "time: expected None, seconds or \"all-day\", got {}",
            t.get_type()
                .name()
                .map(|n| n.to_string())
                .unwrap_or_else(|_| "another type".into())
        ))
    })?;
    Ok(MapTime::At(seconds))
}

impl PredictArgs<'_> {
    /// Checked parameters; the error names the argument.
    pub fn params(&self) -> PyResult<Params> {
        let method: Method = self
            .method
            .parse()
            .map_err(|e: String| PyValueError::new_err(format!("method: {e}")))?;
        let heading: HeadingRule = self
            .heading
            .parse()
            .map_err(|e: String| PyValueError::new_err(format!("heading: {e}")))?;
        if self.k < 1 || self.k > u32::MAX as i64 {
            return Err(PyValueError::new_err(format!(
                "k: {} samples per person; must be at least 1",
                self.k
            )));
        }
        let seed = u64::try_from(self.seed).map_err(|_| {
            PyValueError::new_err(format!(
                "seed: {} is not between 0 and 2**64 - 1",
                self.seed
            ))
        })?;
        let params = Params {
            method,
            k: self.k as usize,
            dt: self.dt,
            horizon: self.horizon,
            beta: self.beta,
            radius: self.radius,
            seed,
            heading,
        };
        params.validate().map_err(|e| match e {
            cliff::predict::PredictError::Param { name, why } => {
                PyValueError::new_err(format!("{name}: {why}"))
            }
            e => PyValueError::new_err(e.to_string()),
        })?;
        if params.steps() == 0 {
            return Err(PyValueError::new_err(format!(
                "horizon: {} s is less than one step of dt {} s",
                self.horizon, self.dt
            )));
        }
        Ok(params)
    }

    /// The options beyond the paper as given (validated with the request, as the
    /// daemon does).
    pub fn options(&self) -> Options {
        Options {
            speed_beta: self.speed_beta,
            coast: self.coast,
            scores: self.scores,
            ..Options::default()
        }
    }

    /// A request against `map` with these arguments (no agents yet).
    pub fn request(&self, map: &str) -> PyResult<Request> {
        let params = self.params()?;
        let mut request =
            Request::new(map, &params).map_err(|e| PyValueError::new_err(format!("map: {e}")))?;
        request.set_options(&self.options());
        request.set_map_time(self.time);
        Ok(request)
    }
}
