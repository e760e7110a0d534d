//! The keyword arguments every `predict` of the package takes, in one place: the
//! macro that writes them and the [`PredictArgs`] that checks them.
//!
//! `cliff_lhmp.predict`, `Map.predict` and `Client.predict` share the same twelve
//! keyword-only arguments (`k`, `dt`, `horizon`, `beta`, `radius`, `seed`, `method`,
//! `heading`, `speed_beta`, `coast`, `scores`, `time`) with the same defaults.
//! [`predict_fn!`] writes them, the `#[pyo3(signature = ...)]` that makes them
//! keyword-only and the [`PredictArgs`] they are gathered into, so that a new keyword
//! or a changed default is one edit here (and one in `cliff_lhmp/__init__.pyi`, whose
//! stubs spell each signature out).

use cliff::predict::{HeadingRule, Method, Options, Params};
use cliff_client::{MapTime, Request};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;

/// The keyword arguments shared by every prediction call.
pub struct PredictArgs<'a> {
    /// Samples per person (checked to be at least 1).
    pub k: i64,
    /// Time step (s) between predicted positions.
    pub dt: f64,
    /// How far ahead (s).
    pub horizon: f64,
    /// How strongly the heading turns towards a sampled direction.
    pub beta: f64,
    /// Sampling radius (m).
    pub radius: f64,
    /// Any Python int; checked to fit in 64 bits unsigned.
    pub seed: i128,
    /// "cliff", "cvm" or "improved".
    pub method: &'a str,
    /// "circular-mean" or "paper".
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

/// A `predict` function or method with the shared keyword arguments.
///
/// Write the function with its own leading parameters (`&self` for a method, then
/// `py`, then the positional arguments, which stay positional in Python) and a last
/// pseudo-parameter `..args: PredictArgs`: the macro appends the keyword-only
/// parameters and binds the checked-in arguments as `args` before the body runs.
/// Doc comments, attributes (`#[pyfunction]`) and the visibility (`pub fn`) are kept
/// as written.
///
/// A method stands alone in a `#[pymethods] impl` block of its own (PyO3's
/// `multiple-pymethods`): `#[pymethods]` cannot expand a macro inside its block.
///
/// ```ignore
/// predict_fn! {
///     /// Docstring of the Python function.
///     #[pyfunction]
///     pub fn predict(
///         py: Python<'_>,
///         map: &Bound<'_, Map>,
///         histories: &Bound<'_, PyAny>,
///         ..args: PredictArgs
///     ) -> PyResult<Prediction> {
///         predict_local(py, map.get(), histories, &args)
///     }
/// }
///
/// predict_fn! {
///     #[pymethods]
///     impl Map {
///         /// Docstring of the Python method.
///         fn predict(&self, py: Python<'_>, histories: &Bound<'_, PyAny>, ..args: PredictArgs)
///             -> PyResult<Prediction> { predict_local(py, self, histories, &args) }
///     }
/// }
/// ```
macro_rules! predict_fn {
    // The function with the keyword parameters, then handed to `@wrap`.
    (@fn [$($wrap:tt)*]
        $(#[$attr:meta])*
        $vis:vis fn $name:ident(
            $(&$slf:ident,)?
            $py:ident: $py_ty:ty,
            $($arg:ident: $arg_ty:ty,)+
            ..$args:ident: PredictArgs $(,)?
        ) -> $ret:ty $body:block
    ) => {
        $crate::predict_args::predict_fn! { @wrap [$($wrap)*]
            $(#[$attr])*
            #[pyo3(signature = ($($arg,)+ *, k = 20, dt = 0.4, horizon = 12.0, beta = 1.0,
                radius = 0.7071067811865476, seed = 0, method = "cliff",
                heading = "circular-mean", speed_beta = 0.0, coast = 0.0, scores = false,
                time = None))]
            #[allow(clippy::too_many_arguments)]
            $vis fn $name(
                $(&$slf,)?
                $py: $py_ty,
                $($arg: $arg_ty,)+
                k: i64,
                dt: f64,
                horizon: f64,
                beta: f64,
                radius: f64,
                seed: i128,
                method: &str,
                heading: &str,
                speed_beta: f64,
                coast: f64,
                scores: bool,
                time: ::std::option::Option<&::pyo3::Bound<'_, ::pyo3::PyAny>>,
            ) -> $ret {
                let $args = $crate::predict_args::PredictArgs {
                    k,
                    dt,
                    horizon,
                    beta,
                    radius,
                    seed,
                    method,
                    heading,
                    speed_beta,
                    coast,
                    scores,
                    time: $crate::predict_args::time_arg(time)?,
                };
                $body
            }
        }
    };
    (@wrap [] $($item:tt)*) => {
        $($item)*
    };
    (@wrap [$(#[$impl_attr:meta])* impl $ty:ty] $($item:tt)*) => {
        $(#[$impl_attr])*
        impl $ty {
            $($item)*
        }
    };
    // A method: its own `#[pymethods] impl` block.
    ($(#[$impl_attr:meta])* impl $ty:ty { $($method:tt)* }) => {
        $crate::predict_args::predict_fn! { @fn [$(#[$impl_attr])* impl $ty] $($method)* }
    };
    // A free function (`#[pyfunction]`).
    ($($function:tt)*) => {
        $crate::predict_args::predict_fn! { @fn [] $($function)* }
    };
}

pub(crate) use predict_fn;
