//! The keyword arguments every `predict` of the package takes, in one place.
//!
//! `cliff_lhmp.predict`, `Map.predict` and `Client.predict` share the same twelve
//! keyword-only arguments (`k`, `dt`, `horizon`, `beta`, `radius`, `seed`, `method`,
//! `heading`, `speed_beta`, `coast`, `scores`, `time`) with the same defaults.
//! [`predict_fn!`] writes them, the `#[pyo3(signature = ...)]` that makes them
//! keyword-only and the [`PredictArgs`](crate::histories::PredictArgs) they are
//! gathered into, so that a new keyword or a changed default is one edit here (and
//! one in `cliff_lhmp/__init__.pyi`, whose stubs spell each signature out).

/// A `predict` function or method with the shared keyword arguments.
///
/// Write the function with its own leading parameters (`&self` for a method, then
/// `py`, then the positional arguments, which stay positional in Python) and a last
/// pseudo-parameter `..args: PredictArgs`: the macro appends the keyword-only
/// parameters and binds the checked-in arguments as `args` before the body runs.
/// Doc comments and attributes (`#[pyfunction]`) are kept as written.
///
/// A method stands alone in a `#[pymethods] impl` block of its own (PyO3's
/// `multiple-pymethods`): `#[pymethods]` cannot expand a macro inside its block.
///
/// ```ignore
/// predict_fn! {
///     /// Docstring of the Python function.
///     #[pyfunction]
///     fn predict(
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
        fn $name:ident(
            $(&$slf:ident,)?
            $py:ident: $py_ty:ty,
            $($arg:ident: $arg_ty:ty,)+
            ..$args:ident: PredictArgs $(,)?
        ) -> $ret:ty $body:block
    ) => {
        $crate::predict_signature::predict_fn! { @wrap [$($wrap)*]
            $(#[$attr])*
            #[pyo3(signature = ($($arg,)+ *, k = 20, dt = 0.4, horizon = 12.0, beta = 1.0,
                radius = 0.7071067811865476, seed = 0, method = "cliff",
                heading = "circular-mean", speed_beta = 0.0, coast = 0.0, scores = false,
                time = None))]
            #[allow(clippy::too_many_arguments)]
            fn $name(
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
                let $args = $crate::histories::PredictArgs {
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
                    time: $crate::histories::time_arg(time)?,
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
        $crate::predict_signature::predict_fn! { @fn [$(#[$impl_attr])* impl $ty] $($method)* }
    };
    // A free function (`#[pyfunction]`).
    ($($function:tt)*) => {
        $crate::predict_signature::predict_fn! { @fn [] $($function)* }
    };
}

pub(crate) use predict_fn;
